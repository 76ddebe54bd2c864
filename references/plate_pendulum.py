"""Exact motion and support force of a rectangular plate swinging about a corner (compound
pendulum), for any parameters and any initial state.

Textbook location
-----------------
Boström, *Rigid body dynamics*, Ex. 4.5.1 (largest angular velocity, text line ~2179) and
Ex. 4.5.2 (support force at that instant, line ~2220); the plate's moment of inertia is from
Ex. 4.2.1 (line ~1991), Steiner's theorem and energy conservation (4.48) of §4.5.

The system
----------
A uniform rectangular plate of mass m (kg) with sides 2a and 2b (m; the textbook's a and b are
the HALF sides) and any thickness h, pivoting without friction about a horizontal axis through
one corner, perpendicular to the plate: a compound pendulum in the plane of the plate. The
textbook releases it from rest "when one side is horizontal": the side of length 2a along the
horizontal through the pivot, the plate below it, so the centre of mass starts at horizontal
distance a and depth b from the pivot.

Frames, conventions, units (SI)
-------------------------------
World z up, gravity −g ẑ, the plate swings in the world x-z plane about the pivot O at the
origin. φ is the angle of the centre of mass from the downward vertical through O, positive
toward +x, so the centre of mass is at r (sin φ, 0, −cos φ), r = √(a² + b²). The textbook
release is φ0 = atan2(a, b), φ̇0 = 0. Forces are in N, world frame.

Printed formulas (OCR text) and status
--------------------------------------
Ex. 4.2.1 / 4.5.1  Ī_zz = (1/3) m (a² + b²) about the centre, perpendicular to the plate;
           I_zz = (4/3) m (a² + b²) about the corner  — correct (box 2a × 2b: m(4a² + 4b²)/12;
           independent of the thickness h).
Ex. 4.5.1  ω = √( 3 g (√(a² + b²) − b) / (2 (a² + b²)) )  — correct.
Ex. 4.5.2  F_n = m g + 3 m g (√(a² + b²) − b) / (2 √(a² + b²)),  F_s = 0  — correct (F_n is
           the vertical support force on the plate, up; F_s the horizontal one). No couple is
           needed either: the plate's mid-plane contains the centre of mass and is
           perpendicular to the axis, so the products of inertia I_xy, I_yz about O vanish.

Verified formulas
-----------------
Pendulum equation (angular momentum about O, (4.47)): I_O φ̈ = −m g r sin φ, with
I_O = (4/3) m (a² + b²) = (4/3) m r², so φ̈ = −ω_p² sin φ, ω_p² = m g r / I_O = 3 g / (4 r).
Energy: φ̇² = φ̇0² + 2 ω_p² (cos φ − cos φ0). Modulus k² = sin²(φ0/2) + φ̇0²/(4 ω_p²).

* k < 1 (libration): sin(φ/2) = k sn(u | k²), u = ω_p t + u0,
  φ̇ = 2 k ω_p cn(u | k²);  u0 = F(ψ0 | k²), ψ0 = atan2(sin(φ0/2)/k, φ̇0/(2 k ω_p)).
  Derivation: d/dt sin(φ/2) = ½ cos(φ/2) φ̇ and cos(φ/2) = dn(u) give ½ φ̇ dn = k ω_p cn dn.
* k > 1 (rotation): φ/2 = σ am(k ω_p t + u0 | 1/k²), φ̇ = 2 σ k ω_p dn(·), σ = sign φ̇0,
  u0 = F(σ φ0/2 | 1/k²) (am continued by am(v + 2K) = am(v) + π).
* k = 1 (separatrix): φ/2 = σ gd(ω_p t + u0), gd(x) = arcsin(tanh x), u0 = atanh(sin(σ φ0/2)).

Largest angular velocity (φ = 0, centre of mass below O): |φ̇|max = 2 k ω_p (k <= 1), i.e.
ω_max² = φ̇0² + 2 ω_p² (1 − cos φ0); for the textbook release cos φ0 = b/r gives Ex. 4.5.1.
Support force on the plate (Newton's law for the centre of mass, F + m g = m a_cm):
    F = m a_cm − m g,  a_cm = r φ̈ (cos φ, 0, sin φ) + r φ̇² (−sin φ, 0, cos φ),
    at φ = 0: φ̈ = 0, F = (0, 0, m g + m r ω_max²), which is Ex. 4.5.2.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from harness.references.torque_free import ellipf, ellipj

if TYPE_CHECKING:  # pragma: no cover
    from harness.measure.trajectory import Trajectory
    from harness.model.scene import Scene

__all__ = [
    "pivot_inertia",
    "natural_frequency",
    "textbook_release_angle",
    "largest_angular_velocity",
    "textbook_largest_angular_velocity",
    "support_force_at_largest_velocity",
    "textbook_support_force",
    "pendulum_motion",
    "com_motion",
    "support_force",
    "EXACT_NEEDS_RUNS",
    "exact_error",
    "exact_error_series",
    "exact_reaction",
]


def pivot_inertia(m: float, a: float, b: float) -> float:
    """I_O = (4/3) m (a² + b²) (kg m²), the plate (sides 2a, 2b) about an axis through a corner
    perpendicular to the plate."""
    return 4.0 / 3.0 * m * (a * a + b * b)


def natural_frequency(a: float, b: float, g: float) -> float:
    """ω_p = √(m g r / I_O) = √(3 g / (4 r)) (rad/s), r = √(a² + b²)."""
    return float(np.sqrt(0.75 * g / np.hypot(a, b)))


def textbook_release_angle(a: float, b: float) -> float:
    """φ0 = atan2(a, b) (rad): one side (length 2a) horizontal through the pivot."""
    return float(np.arctan2(a, b))


def largest_angular_velocity(a: float, b: float, g: float, phi0: float, dphi0: float = 0.0) -> float:
    """Largest |φ̇| (rad/s) of the motion from (φ0, φ̇0): at φ = 0 (mod 2π) when the plate
    reaches or passes the bottom, else |φ̇0|-bounded: √(φ̇0² + 2 ω_p² (1 − cos φ0))."""
    wp = natural_frequency(a, b, g)
    return float(np.sqrt(dphi0 * dphi0 + 4.0 * wp * wp * np.sin(0.5 * phi0) ** 2))


def textbook_largest_angular_velocity(a: float, b: float, g: float) -> float:
    """Ex. 4.5.1 as printed: ω = √(3 g (√(a² + b²) − b) / (2 (a² + b²))) (rad/s)."""
    r2 = a * a + b * b
    return float(np.sqrt(3.0 * g * (np.sqrt(r2) - b) / (2.0 * r2)))


def support_force_at_largest_velocity(m: float, a: float, b: float, g: float, phi0: float, dphi0: float = 0.0) -> np.ndarray:
    """Support force on the plate (N, world (x, y, z)) when the centre of mass passes below the
    pivot: (0, 0, m g + m r ω_max²)."""
    w = largest_angular_velocity(a, b, g, phi0, dphi0)
    return np.array([0.0, 0.0, m * g + m * np.hypot(a, b) * w * w])


def textbook_support_force(m: float, a: float, b: float, g: float) -> tuple[float, float]:
    """Ex. 4.5.2 as printed: (F_n, F_s) = (m g + 3 m g (√(a²+b²) − b)/(2 √(a²+b²)), 0) (N)."""
    r = np.hypot(a, b)
    return float(m * g + 3.0 * m * g * (r - b) / (2.0 * r)), 0.0


def _am(v: np.ndarray, m: float, m1: float) -> tuple[np.ndarray, np.ndarray]:
    """Jacobi amplitude am(v | m) continued over all v, and dn(v | m)."""
    K = float(ellipf(0.5 * np.pi, m, m1))
    n = np.round(v / (2.0 * K))
    sn, cn, dn = ellipj(v - 2.0 * K * n, m, m1)
    return np.arctan2(sn, cn) + np.pi * n, dn


def pendulum_motion(t, omega_p: float, phi0: float, dphi0: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exact (φ, φ̇, φ̈) of φ̈ = −ω_p² sin φ from φ(0) = φ0, φ̇(0) = φ̇0 (rad, rad/s, rad/s²).

    φ is continuous in time (a rotating pendulum keeps winding) and starts at φ0 itself, any real
    angle: a libration or the separatrix about the bottom 2πn nearest φ0 is the one about 0 from
    φ0 − 2πn, shifted by 2πn. See the module docstring for the three regimes.
    """
    t = np.atleast_1d(np.asarray(t, dtype=float)).ravel()
    wp = float(omega_p)
    if wp == 0.0:
        phi = phi0 + dphi0 * t
        return phi, np.full(t.shape, float(dphi0)), np.zeros(t.shape)
    s0, c0 = np.sin(0.5 * phi0), np.cos(0.5 * phi0)
    e = dphi0 / (2.0 * wp)
    k2 = s0 * s0 + e * e
    k2c = c0 * c0 - e * e  # 1 - k², without cancellation from 1 - k²
    if k2 == 0.0:  # at rest at the bottom
        return np.zeros(t.shape), np.zeros(t.shape), np.zeros(t.shape)
    if k2c >= 0.0:  # libration or separatrix: about the bottom 2πn nearest φ0 (k² and 1 − k² do not change)
        turns = 2.0 * np.pi * np.round(phi0 / (2.0 * np.pi))
        phi0 = phi0 - turns
        s0 = np.sin(0.5 * phi0)
    if k2c > 0.0:  # libration
        k = np.sqrt(k2)
        psi0 = np.arctan2(s0 / k, e / k)
        u0 = float(ellipf(psi0, k2, k2c))
        sn, cn, _ = ellipj(wp * t + u0, k2, k2c)
        phi = turns + 2.0 * np.arcsin(np.clip(k * sn, -1.0, 1.0))
        dphi = 2.0 * k * wp * cn
    elif k2c < 0.0:  # rotation
        k = np.sqrt(k2)
        sigma = 1.0 if dphi0 > 0.0 else -1.0
        m, m1 = 1.0 / k2, -k2c / k2
        half = sigma * 0.5 * phi0
        n = np.round(half / np.pi)
        u0 = float(ellipf(half - np.pi * n, m, m1)) + 2.0 * n * float(ellipf(0.5 * np.pi, m, m1))
        am, dn = _am(k * wp * t + u0, m, m1)
        phi = 2.0 * sigma * am
        dphi = 2.0 * sigma * k * wp * dn
    else:  # separatrix
        sigma = 1.0 if dphi0 >= 0.0 else -1.0
        u0 = float(np.arctanh(np.sin(sigma * 0.5 * phi0)))
        v = wp * t + u0
        phi = turns + 2.0 * sigma * np.arcsin(np.tanh(v))
        dphi = 2.0 * sigma * wp / np.cosh(v)
    return phi, dphi, -wp * wp * np.sin(phi)


def com_motion(t, a: float, b: float, g: float, phi0: float, dphi0: float = 0.0):
    """Exact centre-of-mass position, velocity and acceleration (each (n, 3), world, m, m/s,
    m/s²) and the angle triple (φ, φ̇, φ̈) of the plate."""
    phi, dphi, ddphi = pendulum_motion(t, natural_frequency(a, b, g), phi0, dphi0)
    return (*swing_point(float(np.hypot(a, b)), phi, dphi, ddphi), (phi, dphi, ddphi))


def swing_point(r: float, phi, dphi, ddphi) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Position, velocity and acceleration (each (n, 3), world, m, m/s, m/s²) of a point at
    distance ``r`` (m) from a pivot at the origin, swinging in the x-z plane at the angle ``phi``
    (rad, from the downward vertical toward +x), its rate and its acceleration: p = r (sin φ, 0, −cos φ)."""
    s, c = np.sin(phi), np.cos(phi)
    zero = np.zeros_like(phi)
    p = r * np.stack([s, zero, -c], axis=1)
    v = r * dphi[:, None] * np.stack([c, zero, s], axis=1)
    acc = r * ddphi[:, None] * np.stack([c, zero, s], axis=1) + r * (dphi * dphi)[:, None] * np.stack([-s, zero, c], axis=1)
    return p, v, acc


def support_force(t, m: float, a: float, b: float, g: float, phi0: float, dphi0: float = 0.0) -> np.ndarray:
    """Exact force (N, world, (n, 3)) the pivot exerts on the plate: F = m a_cm + m g ẑ. The
    pivot exerts no couple (see the module docstring)."""
    _, _, acc, _ = com_motion(t, a, b, g, phi0, dphi0)
    return m * acc + np.array([0.0, 0.0, m * g])


# ---------------------------------------------------------------------------------------------
# Exact checks of a run (``harness.measure.exact``)
# ---------------------------------------------------------------------------------------------
EXACT_NEEDS_RUNS = False  # the run itself is judged: no extra runs


def _release_angle(scene: "Scene") -> float:
    """phi0: the scene's initial angle of the centre of mass from the downward vertical (the
    diagonal's atan2(a, b) plus the scene's theta0)."""
    p = scene.params
    return float(np.arctan2(p["a"], p["b"])) + p["theta0"]


def exact_error_series(scene: "Scene", traj: "Trajectory") -> np.ndarray:
    """|phi(t) - phi_exact(t)| (rad), the angle of the centre of mass from the downward vertical
    through the pivot against the Jacobi-elliptic closed form (``pendulum_motion``)."""
    p = scene.params
    phi0 = _release_angle(scene)
    r = traj.p_WCm_W[:, 0]
    phi = np.unwrap(np.arctan2(r[:, 0], -r[:, 2]))
    phi += 2.0 * np.pi * np.round((phi0 - phi[0]) / (2.0 * np.pi))
    exact, _, _ = pendulum_motion(traj.t, natural_frequency(p["a"], p["b"], p["g"]), phi0, p["dtheta0"])
    return np.abs(phi - exact)


def exact_error(scene: "Scene", traj: "Trajectory", settings=None, run=None) -> tuple[float, str, str]:
    """Max over samples of |phi(t) - phi_exact(t)| (rad; ``exact_error_series``); the detail gives
    the largest angular velocity (Ex. 4.5.1). ``settings`` and ``run`` are unused (no extra runs)."""
    p = scene.params
    w_max = largest_angular_velocity(p["a"], p["b"], p["g"], _release_angle(scene), p["dtheta0"])
    w_seen = float(np.max(np.linalg.norm(traj.w_WB_W[:, 0], axis=-1)))
    return (float(np.max(exact_error_series(scene, traj))), "rad",
            f"angle of the centre of mass vs elliptic solution; largest angular velocity {w_max:.6f} rad/s exact "
            f"(Ex. 4.5.1), {w_seen:.6f} rad/s largest sample")


def exact_reaction(scene: "Scene", traj: "Trajectory") -> tuple[float, str]:
    """Max over samples of |F(t) - F_exact(t)| (N): the pivot force on the plate against
    ``support_force`` (m a_cm + m g z of the elliptic solution); the detail adds the largest
    reaction moment (exact: zero) and the textbook's instant of Ex. 4.5.2."""
    p = scene.params
    phi0 = _release_angle(scene)
    force, moment = traj.reactions["plate"]
    exact = support_force(traj.t, p["m"], p["a"], p["b"], p["g"], phi0, p["dtheta0"])
    err = float(np.max(np.linalg.norm(force - exact, axis=-1)))
    at_bottom = support_force_at_largest_velocity(p["m"], p["a"], p["b"], p["g"], phi0, p["dtheta0"])
    return err, (f"pivot force vs m a_cm + m g of the elliptic solution; largest moment {np.max(np.linalg.norm(moment, axis=-1)):.1e} N m "
                 f"(exact 0); at the bottom F_z = {at_bottom[2]:.6f} N (Ex. 4.5.2)")
