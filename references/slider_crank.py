"""Slider-crank (crankshaft, connecting rod, piston) under gravity and a constant piston force:
closed-form kinematics with an offset, the exact 1-DOF equation of motion in the crank angle, and
Problem 3.4's collar kinematics.

Textbook location
-----------------
Boström, *Rigid body dynamics*: Ex. 5.1.1 (text line ~2608: the generalized force of a force F
on the piston of a crankshaft), Problem 3.4 (line ~1798, answer l. 3445: two collars on fixed
rods joined by a rod -- the slider's kinematics in 3-D).

The system (SI units)
---------------------
Scene ``slider_crank`` (builder ``harness/model/builders/slider_crank.py``). The mechanism moves
in the world x-z plane; gravity −g ẑ; hinge axes world −y, so a positive angle turns +x toward
+z, e(α) = (cos α, sin α) in (x, z). Crank AB (length a, mass m_crank) about A = (0, 0),
absolute angle θ; connecting rod BC (length b, mass m_rod), absolute angle φ; slider (mass
m_slider, centre of mass at its pin C) on the line z = e (offset e, m), coordinate x = C_x.
Crank and rod are uniform solid cylinders of radius r (centre of mass at the middle; transverse
moment m (3r² + L²)/12 about it). A constant force F (N) along +x acts on the slider.
The crank turns fully when a + |e| < b (the builder requires it); then the rod never reaches
the vertical, w = b cos φ > 0, and θ is a global coordinate: the equation below is regular for
every θ.

Printed formulas (OCR text) and status
--------------------------------------
Ex. 5.1.1  sin φ = (a/b) sin θ (law of sines; the book's φ is the rod's angle from the line of
           the piston, on the other side: φ_book = −φ here for e = 0)  — correct.
           x = a cos θ + b cos φ = a cos θ + √(b² − a² sin² θ)  — correct.
           δx = −(a sin θ + a² sin θ cos θ/√(b² − a² sin² θ)) δθ  — correct.
           Q_θ = F dx/dθ = −F a sin θ (1 − a cos θ/√(b² − a² sin² θ))  — **sign error**: F dx/dθ
           = −F a sin θ (1 + a cos θ/√(b² − a² sin² θ)), as the book's own δx line says
           (ERRATA.md; the printed form differs from F dx/dθ by 2F a² sin θ cos θ/√(…), and
           with it the energy balance of the equation of motion fails).
Problem 3.4 answer: v_B = (1/3) v e_y, a_B = −(25 v²/(27L)) e_y  — correct, for the geometry
           the numbers imply (the figure is not in the OCR'd copy): the rods OC (along x through
           O) and DE (along y through D) are skew, OD = 0.3L along their common perpendicular,
           b = OA = 0.4L, so that DB = 1.2L; A moves toward O at v (the direction of v fixes the
           sign of v_B only). No coplanar layout with these lengths gives both printed numbers.
           ``collar_kinematics`` solves any two straight guides in 3-D.

Verified formulas (offset e, derived here)
------------------------------------------
s = e − a sin θ (m), w = √(b² − s²) = b cos φ (m):
    sin φ = s/b,  x = a cos θ + w,
    φ' = dφ/dθ = −a cos θ/w,              φ'' = a sin θ/w + a² s cos² θ/w³,
    x' = dx/dθ = −a sin θ + a s cos θ/w,  x'' = −a cos θ − a(a cos² θ + s sin θ)/w − a² s² cos² θ/w³.
(e = 0: x' = −a sin θ (1 + a cos θ/√(b² − a² sin² θ)), Ex. 5.1.1's δx.)
Kinetic energy T = ½ M(θ) θ̇², with J_A = m_crank (r²/4 + a²/3) (crank about A),
J_B = m_rod (r²/4 + b²/3) (rod about B):
    M(θ) = J_A + m_rod a² + J_B φ'² + m_rod a b φ' cos(θ − φ) + m_slider x'²   (kg m²),
    M'(θ) = 2 J_B φ' φ'' + m_rod a b (φ'' cos(θ − φ) − φ'(1 − φ') sin(θ − φ)) + 2 m_slider x' x''.
Potential V = g [(½ m_crank + m_rod) a sin θ + ½ m_rod b sin φ + m_slider e] (J).
Equation of motion (Lagrange, one coordinate):
    M(θ) θ̈ + ½ M'(θ) θ̇² = Q(θ) = −dV/dθ + F x'(θ),
    dV/dθ = g [(½ m_crank + m_rod) a cos θ + ½ m_rod b cos φ φ'].
F is constant along x, so E = ½ M θ̇² + V − F x is conserved (the work F (x − x0) balances).
Integrated with SciPy DOP853 at rtol = atol = 1e-12; tests/references/test_slider_crank.py checks
it against an independent DAE in (θ, φ, x) with multipliers, the energy balance, convergence and
an in-house engine run.

The exact check of a run
------------------------
``exact_error``: max over crank and rod and all samples of |α_run − α_exact| (rad), each body's
angle read from its orientation (body +x in world, atan2(x_z, x_x)); the detail adds the largest
slider position error (m). No extra runs.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Mapping

import numpy as np
from scipy.integrate import solve_ivp

from harness.measure.solution_cache import solution_cache
from harness.model import rotations

if TYPE_CHECKING:  # pragma: no cover
    from harness.measure.trajectory import Trajectory
    from harness.model.scene import Scene

__all__ = [
    "SliderCrankParams",
    "kinematics",
    "piston_position",
    "rod_angle",
    "generalized_force_piston",
    "textbook_generalized_force",
    "mass_function",
    "generalized_force",
    "potential",
    "energy",
    "theta_acceleration",
    "Motion",
    "reference_solution",
    "collar_kinematics",
    "body_angles",
    "EXACT_NEEDS_RUNS",
    "exact_error_series",
    "exact_error",
]

RTOL = 1e-12
ATOL = 1e-12


@dataclass(frozen=True)
class SliderCrankParams:
    """The scene's parameters (SI units; module docstring). ``w`` (the slider's side) does not
    enter the planar dynamics: the slider does not rotate."""

    a: float
    b: float
    e: float
    r: float
    m_crank: float
    m_rod: float
    m_slider: float
    g: float
    F: float
    theta0: float
    dtheta0: float

    @classmethod
    def from_mapping(cls, p: Mapping[str, float]) -> "SliderCrankParams":
        return cls(**{k: float(p[k]) for k in cls.__dataclass_fields__})

    def __post_init__(self):
        if not self.a + abs(self.e) < self.b:
            raise ValueError(f"slider-crank: the crank must turn fully, a + |e| < b (a = {self.a:g}, e = {self.e:g}, "
                             f"b = {self.b:g} m)")


def _params(params) -> SliderCrankParams:
    return params if isinstance(params, SliderCrankParams) else SliderCrankParams.from_mapping(params)


# ---------------------------------------------------------------------------------------------
# Kinematics
# ---------------------------------------------------------------------------------------------
def kinematics(a: float, b: float, e: float, theta) -> tuple[np.ndarray, ...]:
    """(φ, x, φ', x', φ'', x'') at crank angle(s) θ (rad): rod angle (rad), piston position (m)
    and their first and second derivatives with respect to θ (rad/rad, m/rad, ...)."""
    theta = np.asarray(theta, float)
    st, ct = np.sin(theta), np.cos(theta)
    s = e - a * st
    w = np.sqrt(b * b - s * s)
    phi = np.arcsin(s / b)
    x = a * ct + w
    dphi = -a * ct / w
    ddphi = a * st / w + a * a * s * ct * ct / w**3
    dx = -a * st + a * s * ct / w
    ddx = -a * ct - a * (a * ct * ct + s * st) / w - a * a * s * s * ct * ct / w**3
    return phi, x, dphi, dx, ddphi, ddx


def piston_position(a: float, b: float, e: float, theta) -> np.ndarray:
    """x = a cos θ + √(b² − (e − a sin θ)²) (m)."""
    return kinematics(a, b, e, theta)[1]


def rod_angle(a: float, b: float, e: float, theta) -> np.ndarray:
    """φ = arcsin((e − a sin θ)/b) (rad), absolute, from +x toward +z."""
    return kinematics(a, b, e, theta)[0]


def generalized_force_piston(F: float, a: float, b: float, e: float, theta) -> np.ndarray:
    """Q_θ = F dx/dθ (N m) of a force F (N) along +x on the piston (Ex. 5.1.1, corrected sign;
    any offset e)."""
    return F * kinematics(a, b, e, theta)[3]


def textbook_generalized_force(F: float, a: float, b: float, theta) -> np.ndarray:
    """Ex. 5.1.1 as printed: Q_θ = −F a sin θ (1 − a cos θ/√(b² − a² sin² θ)) (N m). Wrong sign
    inside the bracket (module docstring)."""
    theta = np.asarray(theta, float)
    return -F * a * np.sin(theta) * (1.0 - a * np.cos(theta) / np.sqrt(b * b - (a * np.sin(theta)) ** 2))


def collar_kinematics(p_O, u_A, p_D, u_B, L: float, s_A: float, ds_A: float, dds_A: float = 0.0,
                      root: float = 1.0) -> tuple[float, float, float]:
    """Two collars joined by a rod of length L (m): A at p_O + s_A u_A on one straight guide,
    B at p_D + s_B u_B on another (unit directions u_A, u_B in 3-D). Returns (s_B, ṡ_B, s̈_B)
    (m, m/s, m/s²) from s_A, ṡ_A, s̈_A; ``root`` (±1) picks the intersection.

    ρ = r_B − r_A, |ρ| = L:  s_B = −δ·u_B + root √((δ·u_B)² − |δ|² + L²) with δ = p_D − r_A;
    ṡ_B = ṡ_A (ρ·u_A)/(ρ·u_B);  s̈_B = (s̈_A ρ·u_A − |ṡ_B u_B − ṡ_A u_A|²)/(ρ·u_B)
    (the derivatives of ρ·ρ = L²). Problem 3.4: ``collar_kinematics(0, e_x, 0.3L e_z, e_y,
    1.3L, 0.4L, -v)`` gives (1.2L, v/3, −25v²/(27L))."""
    p_O, u_A, p_D, u_B = (np.asarray(v, float) for v in (p_O, u_A, p_D, u_B))
    r_A = p_O + s_A * u_A
    delta = p_D - r_A
    du = float(delta @ u_B)
    disc = du * du - float(delta @ delta) + L * L
    if disc < 0.0:
        raise ValueError("collars: the rod cannot reach the second guide")
    s_B = -du + np.sign(root) * np.sqrt(disc)
    rho = p_D + s_B * u_B - r_A
    ds_B = ds_A * float(rho @ u_A) / float(rho @ u_B)
    v_rel = ds_B * u_B - ds_A * u_A
    dds_B = (dds_A * float(rho @ u_A) - float(v_rel @ v_rel)) / float(rho @ u_B)
    return float(s_B), float(ds_B), float(dds_B)


# ---------------------------------------------------------------------------------------------
# Dynamics
# ---------------------------------------------------------------------------------------------
def _moments(p: SliderCrankParams) -> tuple[float, float]:
    """(J_A, J_B) (kg m²): crank about A, rod about B."""
    return p.m_crank * (0.25 * p.r**2 + p.a**2 / 3.0), p.m_rod * (0.25 * p.r**2 + p.b**2 / 3.0)


def mass_function(params, theta) -> tuple[np.ndarray, np.ndarray]:
    """(M(θ), M'(θ)) (kg m², kg m²/rad) of T = ½ M(θ) θ̇²."""
    p = _params(params)
    J_A, J_B = _moments(p)
    phi, _, dphi, dx, ddphi, ddx = kinematics(p.a, p.b, p.e, theta)
    cc, sc = np.cos(theta - phi), np.sin(theta - phi)
    mab = p.m_rod * p.a * p.b
    M = J_A + p.m_rod * p.a**2 + J_B * dphi**2 + mab * dphi * cc + p.m_slider * dx**2
    dM = 2.0 * J_B * dphi * ddphi + mab * (ddphi * cc - dphi * (1.0 - dphi) * sc) + 2.0 * p.m_slider * dx * ddx
    return M, dM


def potential(params, theta) -> np.ndarray:
    """V (J) of gravity, zero at z = 0 for every centre of mass."""
    p = _params(params)
    phi = kinematics(p.a, p.b, p.e, theta)[0]
    return p.g * ((0.5 * p.m_crank + p.m_rod) * p.a * np.sin(theta) + 0.5 * p.m_rod * p.b * np.sin(phi)
                  + p.m_slider * p.e)


def generalized_force(params, theta) -> np.ndarray:
    """Q(θ) = −dV/dθ + F x'(θ) (N m)."""
    p = _params(params)
    phi, _, dphi, dx, _, _ = kinematics(p.a, p.b, p.e, theta)
    dV = p.g * ((0.5 * p.m_crank + p.m_rod) * p.a * np.cos(theta) + 0.5 * p.m_rod * p.b * np.cos(phi) * dphi)
    return -dV + p.F * dx


def energy(params, theta, dtheta) -> np.ndarray:
    """E = T + V − F x (J), conserved (the piston force's work is −Δ(−F x))."""
    p = _params(params)
    M, _ = mass_function(p, theta)
    return 0.5 * M * np.asarray(dtheta, float) ** 2 + potential(p, theta) - p.F * piston_position(p.a, p.b, p.e, theta)


def theta_acceleration(params, theta, dtheta) -> np.ndarray:
    """θ̈ = (Q(θ) − ½ M'(θ) θ̇²)/M(θ) (rad/s²)."""
    M, dM = mass_function(params, theta)
    return (generalized_force(params, theta) - 0.5 * dM * np.asarray(dtheta, float) ** 2) / M


@dataclass(frozen=True)
class Motion:
    """The reference motion at times ``t`` (s): crank and rod angles (rad), piston position (m)
    and their rates."""

    t: np.ndarray
    theta: np.ndarray
    phi: np.ndarray
    x: np.ndarray
    dtheta: np.ndarray
    dphi: np.ndarray
    dx: np.ndarray


def reference_solution(params, t, rtol: float = RTOL, atol: float = ATOL) -> Motion:
    """The motion at times ``t`` (s, increasing, ≥ 0) from θ0, θ̇0: the 1-DOF equation in θ
    (module docstring) with SciPy DOP853 at ``rtol``/``atol``."""
    return _solve(_params(params), np.asarray(t, float).tobytes(), rtol, atol)


@solution_cache()
def _solve(p: SliderCrankParams, t_bytes: bytes, rtol: float, atol: float) -> Motion:
    t = np.frombuffer(t_bytes, dtype=float)
    y0 = np.array([p.theta0, p.dtheta0])
    t_end = float(t[-1]) if len(t) else 0.0
    if t_end <= 0.0:
        Y = np.repeat(y0[:, None], len(t), axis=1)
    else:
        sol = solve_ivp(lambda _t, y: np.array([y[1], theta_acceleration(p, y[0], y[1])]), (0.0, t_end), y0,
                        method="DOP853", t_eval=t, rtol=rtol, atol=atol)
        if not sol.success:  # pragma: no cover - the equation is regular for a + |e| < b
            raise RuntimeError(f"slider-crank reference integration failed: {sol.message}")
        Y = sol.y
    theta, dtheta = Y
    phi, x, dphi, dx, _, _ = kinematics(p.a, p.b, p.e, theta)
    return Motion(t.copy(), theta, phi, x, dtheta, dphi * dtheta, dx * dtheta)


# ---------------------------------------------------------------------------------------------
# Exact check of a run (``harness.measure.exact``)
# ---------------------------------------------------------------------------------------------
EXACT_NEEDS_RUNS = False  # the run itself is judged: no extra runs
BARS = ("crank", "rod")


def body_angles(traj: "Trajectory") -> np.ndarray:
    """(n, 2) absolute angles (rad) of crank and rod in a run, atan2(x_z, x_x) of each body's +x
    axis (the rotation about world −y)."""
    return np.stack([rotations.xz_plane_angle(traj.quat_WB[:, traj.body_names.index(name)]) for name in BARS], axis=1)


def exact_error_series(scene: "Scene", traj: "Trajectory") -> np.ndarray:
    """max over crank and rod of |α_run − α_exact| (rad), their absolute angles against the tight
    integration of the exact 1-DOF equation (``reference_solution``).

    Angles from the bodies' orientations; differences wrapped to (−π, π]."""
    ref = reference_solution(scene.params, traj.t)
    return np.max(np.abs(rotations.wrap_angle(body_angles(traj) - np.stack([ref.theta, ref.phi], axis=1))), axis=1)


def exact_error(scene: "Scene", traj: "Trajectory", settings=None, run=None) -> tuple[float, str, str]:
    """Max over crank and rod and all samples of |α_run − α_exact| (rad; ``exact_error_series``)
    against the 1-DOF equation integrated with DOP853 at rtol 1e-12. The detail adds the largest
    slider position error (m) and the largest |Q_θ| of the piston force (Ex. 5.1.1, corrected).
    ``settings`` and ``run`` are unused."""
    p = SliderCrankParams.from_mapping(scene.params)
    if len(traj.t) == 0:
        return float("nan"), "rad", "no samples"
    ref = reference_solution(p, traj.t)
    err = float(np.max(exact_error_series(scene, traj)))
    x_run = traj.p_WCm_W[:, traj.body_names.index("slider"), 0]
    err_x = float(np.max(np.abs(x_run - ref.x)))
    Q = float(np.max(np.abs(generalized_force_piston(p.F, p.a, p.b, p.e, ref.theta))))
    detail = (f"crank and rod angles vs the exact 1-DOF equation (DOP853, rtol {RTOL:g}); slider position error "
              f"{err_x:.1e} m; largest |Q_theta| of the piston force {Q:.4g} N m (Ex. 5.1.1, corrected sign)")
    return err, "rad", detail
