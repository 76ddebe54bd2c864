"""Exact results for a particle on a spring swinging in a vertical plane (spring pendulum).

Textbook location
-----------------
Boström, *Rigid body dynamics*, Ex. 5.3.1 (text line ~2939): Lagrange's equations in polar
coordinates, the equilibrium, the linearised equations and their two frequencies, and a remark
on what happens when the two frequencies are equal.

The system
----------
A particle of mass m (kg) on a linear spring of stiffness k (N/m) and unstretched length L (m)
whose other end is fixed at the pivot O; gravity −g ẑ; motion in the vertical x-z plane. Polar
coordinates: r = |OP| (m), θ the angle of OP from the downward vertical (rad). The harness's
scene carries the spring on a slide joint of a rigid bob that turns with a light hub at the
pivot, which adds J = I_bob + I_hub (kg m²) about the swing axis; the textbook is J = 0.

Printed formulas (OCR text) and status
--------------------------------------
T = ½ m (ṙ² + r² θ̇²),  V = −m g r cos θ + ½ k (r − L)²                      — correct.
m r̈ − m r θ̇² + k (r − L) − m g cos θ = 0,  m r θ̈ + 2 m ṙ θ̇ + m g sin θ = 0  — correct.
r* = L + m g / k, θ* = 0                                                     — correct.
m ξ̈1 + k ξ1 = 0, r* ξ̈2 + g ξ2 = 0; ω1 = √(k/m), ω2 = √(g/r*)               — correct.
"If it should happen that the two frequencies become equal, ω1 = ω2, then the two oscillations
couple ... energy is gradually transferred between the two types of oscillation."
                                                                              — **wrong**.
    ω1 = ω2 means k/m = g/r* = g/(L + m g/k), i.e. L = 0: a zero-length spring. Then
    V = m g z + ½ k (x² + z²) in Cartesian coordinates (x = r sin θ, z = −r cos θ) and
    T = ½ m (ẋ² + ż²): the equations are exactly linear and uncoupled, at any amplitude, and no
    energy is ever transferred between the horizontal and the vertical motion. The internal
    (autoparametric) resonance at which energy does move between the spring and the swing is
    ω1 = 2 ω2: the quadratic terms m r θ̇² and ½ m g r θ² (the tension's dependence on the
    swing) drive the radial motion at 2 ω2 and, in return, modulate the pendulum's length at
    2 ω2, a parametric resonance of the swing. Evidence: ``tests/references/test_spring_pendulum.py``
    (``test_textbook_equal_frequencies_is_linear_no_exchange`` and
    ``test_two_to_one_resonance_exchanges_energy``).

Verified formulas (with J)
--------------------------
T = ½ m (ṙ² + r² θ̇²) + ½ J θ̇²:  m r̈ − m r θ̇² + k (r − L) − m g cos θ = 0,
(m r² + J) θ̈ + 2 m r ṙ θ̇ + m g r sin θ = 0.
r* = L + m g/k;  ω1 = √(k/m) (J does not enter: the bob's radial motion is a translation),
ω2 = √(m g r* / (m r*² + J)).
Radial mode, exact at any amplitude: θ ≡ 0 is invariant and m r̈ + k (r − r*) = 0, so
r(t) = r* + (r0 − r*) cos ω1 t + (ṙ0/ω1) sin ω1 t.
2:1 resonance (ω1 = 2 ω2): m r*² − 4 g m² r*/k + J = 0, r* the larger root; L = r* − m g/k
(for J = 0: r* = 4 m g/k, L = 3 m g/k). Mode energies about the equilibrium (quadratic, the
measure of the exchange): E_r = ½ m ṙ² + ½ k (r − r*)², E_θ = ½ (m r*² + J) θ̇² + ½ m g r* θ².
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "equilibrium_length",
    "frequencies",
    "textbook_frequencies",
    "resonance_length",
    "radial_motion",
    "mode_energies",
]


def equilibrium_length(m: float, k: float, L: float, g: float) -> float:
    """r* = L + m g / k (m)."""
    return L + m * g / k


def frequencies(m: float, k: float, L: float, g: float, J: float = 0.0) -> tuple[float, float]:
    """(ω1, ω2) (rad/s): spring √(k/m), swing √(m g r*/(m r*² + J))."""
    rs = equilibrium_length(m, k, L, g)
    return float(np.sqrt(k / m)), float(np.sqrt(m * g * rs / (m * rs * rs + J)))


def textbook_frequencies(m: float, k: float, L: float, g: float) -> tuple[float, float]:
    """Ex. 5.3.1 as printed: (√(k/m), √(g/r*)) (rad/s)."""
    return float(np.sqrt(k / m)), float(np.sqrt(g / equilibrium_length(m, k, L, g)))


def resonance_length(m: float, k: float, g: float, J: float = 0.0, ratio: float = 2.0) -> float:
    """Unstretched length L (m) at which ω1 = ratio · ω2: r* the larger root of
    m r*² − ratio² g m² r*/k + J = 0, L = r* − m g/k. ``ratio = 1`` with J = 0 gives L = 0
    (the textbook's ω1 = ω2). Raises when no such length exists."""
    b = ratio * ratio * g * m * m / k
    disc = b * b - 4.0 * m * J
    if disc < 0.0:
        raise ValueError("no spring length gives that frequency ratio")
    rs = (b + np.sqrt(disc)) / (2.0 * m)
    return float(rs - m * g / k)


def radial_motion(t, m: float, k: float, L: float, g: float, r0: float, dr0: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Exact (r, ṙ) of the purely radial motion (θ ≡ 0), any amplitude."""
    t = np.atleast_1d(np.asarray(t, dtype=float))
    rs = equilibrium_length(m, k, L, g)
    w = np.sqrt(k / m)
    c, s = np.cos(w * t), np.sin(w * t)
    return rs + (r0 - rs) * c + dr0 / w * s, -(r0 - rs) * w * s + dr0 * c


def mode_energies(r, theta, dr, dtheta, m: float, k: float, L: float, g: float, J: float = 0.0):
    """Quadratic energies (J) of the spring mode E_r and the swing mode E_θ about the
    equilibrium (module docstring); arrays like the inputs."""
    rs = equilibrium_length(m, k, L, g)
    r, theta, dr, dtheta = (np.asarray(x, dtype=float) for x in (r, theta, dr, dtheta))
    E_r = 0.5 * m * dr * dr + 0.5 * k * (r - rs) ** 2
    E_t = 0.5 * (m * rs * rs + J) * dtheta * dtheta + 0.5 * m * g * rs * theta * theta
    return E_r, E_t
