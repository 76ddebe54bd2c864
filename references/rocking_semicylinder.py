"""Rocking semicylinder on a smooth plane (Problem 5.12): Lagrange's equations in x and φ, their
first integrals, the small-oscillation frequency, the normal force, and the exact motion.

Textbook location
-----------------
Boström, *Rigid body dynamics*, Problem 5.12 (l. 3080): "A homogeneous semicylinder with mass m
and radius R is moving on a horizontal surface without friction. Derive Lagrange's equations in
the variables x and φ." Printed answer (l. 3515)::

    ẍ + (4/(3π)) R φ̈ cos φ − (4/(3π)) R φ̇² sin φ = 0
    (4/(3π)) ẍ cos φ + R φ̈ + (4/(3π)) g sin φ = 0

The system (SI units)
---------------------
Scene ``rocking_semicylinder`` (builder ``harness/model/builders/rocking_semicylinder.py``): a
uniform semicylinder of mass m, radius R and length w, its curved face on the plane z = 0, moving
in the world x-z plane under gravity −g ẑ. x (m) is the abscissa of its axis O, which stays at
height R while the curved face touches the plane; φ (rad) its rotation about −y (φ = 0: flat
face up; a positive φ moves the centre of mass G toward +x). G lies c = 4R/(3π) from O:
G = (x + c sin φ, R − c cos φ). Moments about the axis: I_O = m R²/2 about O, I_G = I_O − m c².

Derivation (numbered)
---------------------
1. Velocity of G: (ẋ + c φ̇ cos φ, c φ̇ sin φ); T = ½ m (ẋ² + 2 c ẋ φ̇ cos φ + c² φ̇²) + ½ I_G φ̇²,
   V = −m g c cos φ (+ const). The plane is smooth: its normal force does no work on a motion
   that keeps O at height R, and there is no horizontal force.
2. Lagrange in x: d/dt[m (ẋ + c φ̇ cos φ)] = 0, i.e. ẍ + c φ̈ cos φ − c φ̇² sin φ = 0 (the printed
   first equation, c = (4/(3π)) R).
3. Lagrange in φ: d/dt[m c ẋ cos φ + (m c² + I_G) φ̇] + m c ẋ φ̇ sin φ + m g c sin φ = 0, i.e.
   m c ẍ cos φ + I_O φ̈ + m g c sin φ = 0, and with I_O = m R²/2, dividing by m R/2:
       (8/(3π)) ẍ cos φ + R φ̈ + (8/(3π)) g sin φ = 0.
   The printed second equation has 4/(3π) for both coefficients: it would hold for I_O = m R²,
   twice the semicylinder's moment about its axis. Wrong (``ERRATA.md``).
4. First integrals: the horizontal momentum P = m (ẋ + c φ̇ cos φ) and the energy
   E = P²/(2m) + ½ J(φ) φ̇² − m g c cos φ, J(φ) = I_G + m c² sin² φ.
5. Small oscillations (linearise 2–3, ẍ = −c φ̈): (I_O − m c²) φ̈ + m g c φ = 0,
       ω² = g c / (R²/2 − c²) = 1.3268 g/R;
   the printed equations give ω² = g c / (R² − c²) = 0.5177 g/R (a period 1.60 times too long).
6. Normal force: the plane's force is vertical, N = m (g + z̈_G) with z̈_G = c (φ̈ sin φ + φ̇² cos φ).
   With P fixed, d/dt(J φ̇) − ½ J' φ̇² + m g c sin φ = 0 gives J φ̈ = −m c sin φ (g + c φ̇² cos φ), so
       N = m (I_G / J(φ)) (g + c φ̇² cos φ) > 0 for |φ| < π/2:
   the body never leaves the plane while it rocks (the builder refuses |φ| ≥ π/2).

Verified by ``tests/references/test_rocking_semicylinder.py``: the equations of steps 2–3 against
an independent Newton–Euler integration of the free body with the height constraint written
there, the first integrals, the small-oscillation frequency, and the printed second equation's
frequency against the engines' runs.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Mapping

import numpy as np
from scipy.integrate import solve_ivp

from harness.measure.solution_cache import solution_cache
from harness.model import rotations
from harness.model.builders.rocking_semicylinder import centroid_depth  # c = 4R/(3π) (m)

if TYPE_CHECKING:  # pragma: no cover
    from harness.measure.trajectory import Trajectory
    from harness.model.scene import Scene

__all__ = [
    "SemicylinderParams",
    "centroid_depth",
    "accelerations",
    "printed_accelerations",
    "small_oscillation_frequency",
    "printed_small_oscillation_frequency",
    "momentum",
    "energy",
    "normal_force",
    "Motion",
    "reference_solution",
    "EXACT_NEEDS_RUNS",
    "exact_error_series",
    "exact_error",
    "exact_reaction",
]

RTOL = 1e-12  # the reference's DOP853 tolerances
ATOL = 1e-12


@dataclass(frozen=True)
class SemicylinderParams:
    """The scene's parameters (SI units; module docstring)."""

    m: float
    R: float
    g: float
    w: float = 0.1
    phi0: float = 0.0
    dphi0: float = 0.0
    x0: float = 0.0
    dx0: float = 0.0

    @classmethod
    def from_mapping(cls, p: Mapping[str, float]) -> "SemicylinderParams":
        keys = cls.__dataclass_fields__
        return cls(**{k: float(p[k]) for k in keys if k in p})


def _params(params) -> SemicylinderParams:
    return params if isinstance(params, SemicylinderParams) else SemicylinderParams.from_mapping(params)


def accelerations(params, phi, dx, dphi) -> tuple[np.ndarray, np.ndarray]:
    """(ẍ (m/s²), φ̈ (rad/s²)) from the correct Lagrange equations (steps 2–3); ẋ does not enter."""
    p = _params(params)
    c, I_O = centroid_depth(p.R), 0.5 * p.m * p.R**2
    cs, sn = np.cos(phi), np.sin(phi)
    # [[m, m c cos], [m c cos, I_O]] [ẍ, φ̈] = [m c φ̇² sin, −m g c sin]
    det = p.m * I_O - (p.m * c * cs) ** 2
    b1, b2 = p.m * c * dphi**2 * sn, -p.m * p.g * c * sn
    return (I_O * b1 - p.m * c * cs * b2) / det, (p.m * b2 - p.m * c * cs * b1) / det


def printed_accelerations(params, phi, dx, dphi) -> tuple[np.ndarray, np.ndarray]:
    """(ẍ, φ̈) from the equations as printed (l. 3515), k = 4/(3π):
    ẍ + k R φ̈ cos φ = k R φ̇² sin φ and k ẍ cos φ + R φ̈ = −k g sin φ."""
    p = _params(params)
    k = 4.0 / (3.0 * np.pi)
    cs, sn = np.cos(phi), np.sin(phi)
    det = p.R - (k * cs) * (k * p.R * cs)
    b1, b2 = k * p.R * dphi**2 * sn, -k * p.g * sn
    return (p.R * b1 - k * p.R * cs * b2) / det, (b2 - k * cs * b1) / det


def small_oscillation_frequency(params) -> float:
    """ω = sqrt(g c / (R²/2 − c²)) (rad/s), step 5."""
    p = _params(params)
    c = centroid_depth(p.R)
    return float(np.sqrt(p.g * c / (0.5 * p.R**2 - c * c)))


def printed_small_oscillation_frequency(params) -> float:
    """ω of the printed equations, sqrt(g c / (R² − c²)) (rad/s)."""
    p = _params(params)
    c = centroid_depth(p.R)
    return float(np.sqrt(p.g * c / (p.R**2 - c * c)))


def momentum(params, phi, dx, dphi):
    """P = m (ẋ + c φ̇ cos φ) (kg m/s), step 4."""
    p = _params(params)
    return p.m * (dx + centroid_depth(p.R) * dphi * np.cos(phi))


def energy(params, phi, dx, dphi):
    """E = T + V (J), V = −m g c cos φ."""
    p = _params(params)
    c = centroid_depth(p.R)
    I_G = 0.5 * p.m * p.R**2 - p.m * c * c
    T = 0.5 * p.m * (dx**2 + 2.0 * c * dx * dphi * np.cos(phi) + c * c * dphi**2) + 0.5 * I_G * dphi**2
    return T - p.m * p.g * c * np.cos(phi)


def normal_force(params, phi, dphi):
    """N = m (g + c (φ̈ sin φ + φ̇² cos φ)) (N), step 6."""
    p = _params(params)
    ddphi = accelerations(p, phi, 0.0, dphi)[1]
    return p.m * (p.g + centroid_depth(p.R) * (ddphi * np.sin(phi) + dphi**2 * np.cos(phi)))


@dataclass(frozen=True)
class Motion:
    """x (m), φ (rad) and their rates at times t (s)."""

    t: np.ndarray
    x: np.ndarray
    phi: np.ndarray
    dx: np.ndarray
    dphi: np.ndarray


def reference_solution(params, t, rtol: float = RTOL, atol: float = ATOL, printed: bool = False) -> Motion:
    """The motion at times ``t`` (s, increasing, t[0] ≥ 0): SciPy DOP853 on the equations of
    steps 2–3 (``printed``: the printed ones) from the scene's initial state."""
    p = _params(params)
    return _solve(p, np.asarray(t, float).tobytes(), rtol, atol, printed)


@solution_cache()
def _solve(p: SemicylinderParams, t_bytes: bytes, rtol: float, atol: float, printed: bool) -> Motion:
    t = np.frombuffer(t_bytes, dtype=float)
    acc = printed_accelerations if printed else accelerations
    y0 = np.array([p.x0, p.phi0, p.dx0, p.dphi0])

    def rhs(_t, y):
        return np.array([y[2], y[3], *acc(p, y[1], y[2], y[3])])

    if len(t) == 0 or t[-1] <= 0.0:
        Y = np.repeat(y0[:, None], len(t), axis=1)
    else:
        sol = solve_ivp(rhs, (0.0, float(t[-1])), y0, method="DOP853", t_eval=t, rtol=rtol, atol=atol)
        if not sol.success:  # pragma: no cover - a smooth ODE
            raise RuntimeError(f"semicylinder reference integration failed: {sol.message}")
        Y = sol.y
    return Motion(t.copy(), *Y)


# ---------------------------------------------------------------------------------------------
# Exact check of a run (``harness.measure.exact``)
# ---------------------------------------------------------------------------------------------
EXACT_NEEDS_RUNS = False


def run_coordinates(traj: "Trajectory") -> tuple[np.ndarray, np.ndarray]:
    """(x, φ) of a run: the carrier's centre (at O) along world x, and the semicylinder's
    rotation about −y (``rotations.xz_plane_angle``)."""
    x = traj.p_WCm_W[:, traj.body_index("carrier"), 0]
    return x, rotations.xz_plane_angle(traj.quat_WB[:, traj.body_index("semicylinder")])


def exact_error_series(scene: "Scene", traj: "Trajectory") -> np.ndarray:
    """max(|φ_run − φ_exact| (rad), |x_run − x_exact| / R) per sample against the tight
    integration of the correct Lagrange equations."""
    p = SemicylinderParams.from_mapping(scene.params)
    ref = reference_solution(p, traj.t)
    x, phi = run_coordinates(traj)
    return np.maximum(np.abs(rotations.wrap_angle(phi - ref.phi)), np.abs(x - ref.x) / p.R)


def exact_error(scene: "Scene", traj: "Trajectory", settings=None, run=None) -> tuple[float, str, str]:
    """Max over samples of ``exact_error_series`` (rad): the rotation and the axis's position
    (over R) against the reference (DOP853, rtol 1e-12). The detail gives both parts and the
    printed equations' distance from the same run."""
    if len(traj.t) == 0:
        return float("nan"), "rad", "no samples"
    p = SemicylinderParams.from_mapping(scene.params)
    ref = reference_solution(p, traj.t)
    printed = reference_solution(p, traj.t, printed=True)
    x, phi = run_coordinates(traj)
    e_phi = float(np.max(np.abs(rotations.wrap_angle(phi - ref.phi))))
    e_x = float(np.max(np.abs(x - ref.x)))
    e_printed = float(np.max(np.abs(rotations.wrap_angle(phi - printed.phi))))
    detail = (f"phi vs the correct Lagrange equations (DOP853, rtol {RTOL:g}) {e_phi:.1e} rad, axis position "
              f"{e_x:.1e} m; the printed equations (Problem 5.12) are {e_printed:.2g} rad away from this run")
    return max(e_phi, e_x / p.R), "rad", detail


def exact_reaction(scene: "Scene", traj: "Trajectory") -> tuple[float, str] | None:
    """Max over samples of |F_run − (0, 0, N_exact)| (N): the plane's force on the body, which the
    carrier's slide joint carries (frictionless: vertical), against step 6 at the reference's
    state. None when the run has no reaction of the carrier's joint."""
    if "carrier" not in (traj.reactions or {}) or len(traj.t) == 0:
        return None
    p = SemicylinderParams.from_mapping(scene.params)
    ref = reference_solution(p, traj.t)
    N = normal_force(p, ref.phi, ref.dphi)
    F = traj.reactions["carrier"][0]
    err = float(np.max(np.linalg.norm(F - np.stack([np.zeros_like(N), np.zeros_like(N), N], axis=1), axis=1)))
    return err, f"the slide's force vs the normal force N = m (g + z''_G) (from {np.min(N):.4g} to {np.max(N):.4g} N)"
