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

from typing import TYPE_CHECKING

import numpy as np

from harness.measure.exact import extra_run
from harness.measure.signals import frequency_from_hermite_crossings

if TYPE_CHECKING:  # pragma: no cover
    from harness.measure.trajectory import Trajectory
    from harness.model.multibody import Multibody
    from harness.model.scene import Scene

__all__ = [
    "equilibrium_length",
    "frequencies",
    "textbook_frequencies",
    "resonance_length",
    "radial_motion",
    "mode_energies",
    "EXACT_NEEDS_RUNS",
    "exact_error",
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


# ---------------------------------------------------------------------------------------------
# Exact check of a run (``harness.measure.exact``)
# ---------------------------------------------------------------------------------------------
EXACT_NEEDS_RUNS = True  # a radial run and a swing run of the check's own
SWING_AMPLITUDE = 1e-4   # rad, the swing run's release angle: amplitude shift ~ theta^2/16 ~ 6e-10


def run_polar(traj: "Trajectory", model: "Multibody") -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(r, theta, r', theta') of the bob from maximal coordinates: r the slide coordinate,
    theta the angle of the bob from the downward vertical (toward +x), rates from the bob's
    velocity and the hub's angular velocity about -y."""
    from harness.measure.invariants import slide_coordinate

    r = slide_coordinate(traj, model, "bob")
    p, v = traj.p_WCm_W[:, 1], traj.v_WCm_W[:, 1]
    theta = np.unwrap(np.arctan2(p[:, 0], -p[:, 2]))
    e_r = p / np.linalg.norm(p, axis=-1, keepdims=True)
    return r, theta, np.einsum("ti,ti->t", v, e_r), -traj.w_WB_W[:, 0, 1]


def exact_error(scene: "Scene", traj: "Trajectory", settings, run) -> tuple[float, str, str]:
    """The larger of two relative errors, each on a run of its own by ``run`` (the step,
    integrator and tolerances of ``settings``) from the scene's parameters: (1) the purely radial
    motion (theta = 0, r0 = 1.1 r*, 1.2 periods), exact at any amplitude (``radial_motion``):
    max |r(t) - r_exact(t)| over the amplitude; (2) the swing frequency measured on a run from
    rest at theta = SWING_AMPLITUDE, r = r* (1.6 periods, Hermite zero crossings) against
    omega2 = sqrt(m g r* / (m r*^2 + J)). The detail adds the spring and swing frequencies
    (Ex. 5.3.1) and how much of ``traj``'s energy reached the swing mode (the 2:1 internal
    resonance)."""
    from harness.model.builders.spring_pendulum import swing_inertia

    p = scene.params
    m, k, L, g = p["m"], p["k"], p["L"], p["g"]
    J = swing_inertia(p)
    w1, w2 = frequencies(m, k, L, g, J)
    rs = equilibrium_length(m, k, L, g)

    def own_run(periods, omega, what, **start):
        T = 2.0 * np.pi / omega
        save = settings.dt * max(1, int(round(0.02 * T / settings.dt)))
        case = scene.with_params(dr0=0.0, dtheta0=0.0, **start)
        return extra_run(run, case, settings, int(np.ceil(periods * T / save)), save, what), case.multibody()

    amp = 0.1 * rs
    radial, model = own_run(1.2, w1, "radial run", theta0=0.0, r0=rs + amp)
    r = run_polar(radial, model)[0]
    err_radial = float(np.max(np.abs(r - radial_motion(radial.t, m, k, L, g, rs + amp)[0]))) / amp
    swing, model = own_run(1.6, w2, "swing run", theta0=SWING_AMPLITUDE, r0=rs)  # 1.6 periods: 3 zero crossings
    _, theta, _, dtheta = run_polar(swing, model)
    w_swing = frequency_from_hermite_crossings(swing.t, theta, dtheta)
    err_swing = abs(w_swing / w2 - 1.0)
    r, theta, dr, dtheta = run_polar(traj, scene.multibody())
    E_r, E_t = mode_energies(r, theta, dr, dtheta, m, k, L, g, J)
    share = E_t / (E_r + E_t)
    detail = (f"radial mode vs exact {err_radial:.1e} of its amplitude; swing omega {w_swing:.6f} rad/s vs exact {w2:.6f} "
              f"({err_swing:.1e}); spring omega1 = {w1:.6f} rad/s, ratio {w1 / w2:.6f}; textbook sqrt(g/r*) = "
              f"{np.sqrt(g / rs):.6f} (Ex. 5.3.1, J = 0); swing share of the modal energy {share[0]:.3f} at t = 0, "
              f"max {share.max():.3f} at t = {traj.t[int(np.argmax(share))]:.2f} s")
    return max(err_radial, err_swing), "rel", detail
