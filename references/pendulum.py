"""Exact motion and support force of the IFToMM A01 simple pendulum as the scene models it (a
small uniform sphere on a massless rod), for any parameters and any initial state.

Source
------
Not in the textbook. IFToMM Technical Committee for Multibody Dynamics, Library of
Computational Benchmark Problems, problem A01 "Simple pendulum (planar)" (M. González,
Laboratorio de Ingeniería Mecánica, Universidade da Coruña, 2005):
http://lim.ii.udc.es/mbsbenchmark/dist/A01/A01_specification.xml. Its statement: a lumped mass
of 1 kg on a massless link of 1 m, gravity 9.81 N/kg along −y, released at rest from the
horizontal position with the mass P1 at x = +1 m; output: the time history of P1's x and y;
duration 2000 s, errors measured on 4000 output steps, allowed 1e-1 (low precision) and 1e-3
(high precision). The published solution is a data file (A01_solution_data.txt), not a formula:
the reference here is our own closed form, verified in ``tests/references/test_pendulum.py``.

The system
----------
A point mass has no rotational inertia, which not every engine can hold (a body needs a
positive-definite inertia), so the scene's bob is a uniform sphere of mass m (kg) and radius r
(m) centred at P1, a distance L (m) below the pivot on a massless rod: a compound pendulum with
I_O = m L² + (2/5) m r² about the pivot. The closed form below is exact for that body, for
every r; A01's point mass is r → 0. At the scene's r = 1e-3 m, P1 moves at most 8.7e-6 m from
the point mass's motion over 10 s and 1.8e-3 m over A01's 2000 s (``point_mass_distance``;
the distance grows as r² and with time).

Frames, conventions, units (SI)
-------------------------------
World z up, gravity −g ẑ, the bob swings in the world x-z plane about the pivot O at the
origin; A01's (x, y) are the world (x, z). θ is the rod's angle from the downward vertical,
positive toward +x, so P1 = L (sin θ, 0, −cos θ). A01's release is θ0 = π/2, θ̇0 = 0 (P1 at
(L, 0, 0)). Forces are in N, world frame.

Printed formulas and status
---------------------------
A01 prints no formula: its statement and data only (see Source). Derived here.

Verified formulas
-----------------
Angular momentum about O: I_O θ̈ = −m g L sin θ, so θ̈ = −ω_p² sin θ with
ω_p² = m g L / I_O = g L / (L² + (2/5) r²) (the point mass: g/L). This is the equation of
``harness.references.plate_pendulum.pendulum_motion``, whose Jacobi-elliptic solution (libration
sin(θ/2) = k sn(ω_p t + u0 | k²); rotation θ/2 = σ am(k ω_p t + u0 | 1/k²); separatrix
θ/2 = σ gd(ω_p t + u0); k² = sin²(θ0/2) + θ̇0²/(4 ω_p²)) is used as it stands.
Support force on the bob (Newton's law for its centre of mass): F = m a_P1 + m g ẑ,
a_P1 = L θ̈ (cos θ, 0, sin θ) + L θ̇² (−sin θ, 0, cos θ). No couple: the sphere's inertia about
O has no products with the axis (P1 lies on the plane of motion through O).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from harness.references.plate_pendulum import pendulum_motion, swing_point

if TYPE_CHECKING:  # pragma: no cover
    from harness.measure.trajectory import Trajectory
    from harness.model.scene import Scene

__all__ = [
    "pivot_inertia",
    "natural_frequency",
    "bob_motion",
    "support_force",
    "point_mass_distance",
    "EXACT_NEEDS_RUNS",
    "exact_error",
    "exact_error_series",
    "exact_reaction",
]


def pivot_inertia(m: float, L: float, r: float) -> float:
    """I_O = m L² + (2/5) m r² (kg m²): the sphere (mass m, radius r) with its centre at L from
    the hinge axis."""
    return m * (L * L + 0.4 * r * r)


def natural_frequency(L: float, r: float, g: float) -> float:
    """ω_p = √(m g L / I_O) = √(g L / (L² + (2/5) r²)) (rad/s); r = 0 is the point mass's √(g/L)."""
    return float(np.sqrt(g * L / (L * L + 0.4 * r * r)))


def bob_motion(t, L: float, r: float, g: float, theta0: float, dtheta0: float = 0.0):
    """Exact position, velocity and acceleration of P1, the bob's centre (each (n, 3), world, m,
    m/s, m/s²), and the angle triple (θ, θ̇, θ̈) (rad, rad/s, rad/s²)."""
    th, dth, ddth = pendulum_motion(t, natural_frequency(L, r, g), theta0, dtheta0)
    return (*swing_point(L, th, dth, ddth), (th, dth, ddth))


def support_force(t, m: float, L: float, r: float, g: float, theta0: float, dtheta0: float = 0.0) -> np.ndarray:
    """Exact force (N, world, (n, 3)) the hinge exerts on the bob: F = m a_P1 + m g ẑ (no couple)."""
    _, _, a, _ = bob_motion(t, L, r, g, theta0, dtheta0)
    return m * a + np.array([0.0, 0.0, m * g])


def point_mass_distance(t, L: float, r: float, g: float, theta0: float, dtheta0: float = 0.0) -> float:
    """Largest distance (m) over the times ``t`` between P1 of the sphere of radius r and the
    point mass of A01's statement (r = 0) started alike: how far the modelled body is from the
    statement."""
    p, _, _, _ = bob_motion(t, L, r, g, theta0, dtheta0)
    p0, _, _, _ = bob_motion(t, L, 0.0, g, theta0, dtheta0)
    return float(np.max(np.linalg.norm(p - p0, axis=-1)))


# ---------------------------------------------------------------------------------------------
# Exact checks of a run (``harness.measure.exact``)
# ---------------------------------------------------------------------------------------------
EXACT_NEEDS_RUNS = False  # the run itself is judged: no extra runs


def _motion(scene: "Scene", t):
    p = scene.params
    return bob_motion(t, p["L"], p["r"], p["g"], p["theta0"], p["dtheta0"])


def exact_error_series(scene: "Scene", traj: "Trajectory") -> np.ndarray:
    """|P1(t) - P1_exact(t)| (m), the distance of the bob's centre (A01's output point) from its
    Jacobi-elliptic closed form (``bob_motion``)."""
    exact, _, _, _ = _motion(scene, traj.t)
    return np.linalg.norm(traj.p_WCm_W[:, 0] - exact, axis=-1)


def exact_error(scene: "Scene", traj: "Trajectory", settings=None, run=None) -> tuple[float, str, str]:
    """Max over samples of |P1(t) - P1_exact(t)| (m; ``exact_error_series``); the detail gives
    the point-mass statement's distance from the modelled sphere over the run. ``settings`` and
    ``run`` are unused (no extra runs)."""
    p = scene.params
    gap = point_mass_distance(traj.t, p["L"], p["r"], p["g"], p["theta0"], p["dtheta0"])
    return (float(np.max(exact_error_series(scene, traj))), "m",
            f"P1 (the bob's centre, A01's output) vs elliptic solution of the sphere r = {p['r']:g} m; "
            f"A01's point mass (r = 0) lies within {gap:.1e} m of it over the run")


def exact_reaction(scene: "Scene", traj: "Trajectory") -> tuple[float, str]:
    """Max over samples of |F(t) - F_exact(t)| (N): the hinge force on the bob against
    ``support_force``; the detail adds the largest reaction moment (exact: zero)."""
    p = scene.params
    force, moment = traj.reactions["bob"]
    exact = support_force(traj.t, p["m"], p["L"], p["r"], p["g"], p["theta0"], p["dtheta0"])
    err = float(np.max(np.linalg.norm(force - exact, axis=-1)))
    return err, (f"hinge force vs m a_P1 + m g of the elliptic solution; largest moment "
                 f"{np.max(np.linalg.norm(moment, axis=-1)):.1e} N m (exact 0)")


#: The scene as the benchmark report states it (``harness benchmark``): the IFToMM problem, what
#: the library publishes, and its required accuracy as a state error relative to the scene's
#: scales (A01's high precision: 1e-3 m on a 1 m pendulum).
BENCHMARK = {
    "problem": "IFToMM A01",
    "title": "simple pendulum",
    "published": "P1's trajectory over 2000 s as a data file (not available here): judged against the "
                 "closed form of the scene's body (A01's point mass within 8.7e-6 m over the 10 s)",
    "required": 1e-3,
}
