"""Exact motion of the IFToMM A02 N four-bar mechanism as the scene models it: N parallelogram
windows moving as one rigid one-degree-of-freedom system, a pendulum equation with a
Jacobi-elliptic solution, for any N, bar length, mass and radius and any initial crank state.

Source
------
Not in the textbook. IFToMM Technical Committee for Multibody Dynamics, Library of
Computational Benchmark Problems, problem A02 "N four-bar mechanism" (M. González, Laboratorio
de Ingeniería Mecánica, Universidade da Coruña, 2005-08-30):
http://lim.ii.udc.es/mbsbenchmark/dist/A02/A02_specification.xml. Its statement: a
one-degree-of-freedom assembly of N four-bar linkages of 2N+1 links, each 1 m long with a
uniformly distributed mass of 1 kg, under gravity 9.81 N/kg along −y; at the horizontal
position the number of degrees of freedom rises from 1 to N+1 (a singular configuration);
dynamic simulation of 20 s with N = 40 from the position of its figure (every crank upright,
the couplers level at the cranks' tips), the x-velocity of point B0 (the first crank's tip)
1 m/s; output: the time history of B0's x and y position and velocity; allowed errors 1e-1
(low precision) and 1e-3 (high precision), measured on 400 output steps with a threshold of
1e-3. The published solution is a data file (A02_solution_data.txt), not a formula: the
reference here is our own closed form, verified in ``tests/references/test_four_bar_chain.py``.
Secondary sources that state the same geometry: the OpenSim port of the benchmark
(RehabEngGroup/MBSbenchmarksInOpenSim, ``help/benchmarks/A02_N_FourBarMechanism.rst``: N = 2,
1 kg, 1 m, B0's ẋ(0) = 1 m/s, 10 s) and Exudyn's IFToMM double four-bar example (N = 2: bars at
(0, 0.5), (0.5, 1), (1, 0.5), ... with rates −v0/L of the cranks and v0 of the couplers).

The system
----------
Scene ``four_bar_chain`` (builder ``harness/model/builders/four_bar_chain.py``). The chain moves
in the world x-z plane (A02's (x, y) are the world (x, z)); gravity −g ẑ; every hinge axis is
world −y, so a positive angle turns +x toward +z, e(α) = (cos α, sin α) in (x, z). N + 1 cranks
of length L hinged to the ground at (i L, 0), i = 0 .. N; N couplers of length L, coupler i
hinged to the tip B_i of crank i and closing window i at the tip B_{i+1} of crank i + 1 (a cut
hinge). Every bar is a uniform solid cylinder of mass m and radius r (A02's slender rods are
r → 0): its moment about a transverse axis through its end J = m (r²/4 + L²/3) (kg m²).

Printed formulas and status
---------------------------
A02 prints no formula: its statement and data only (see Source). Derived here.

Verified formulas
-----------------
Kinematics. With the pivots' spacing equal to the couplers' length and every crank of one length,
each window closes as a parallelogram at every crank angle θ: every crank at θ, every coupler
level (absolute angle 0), B_i = (i L + L cos θ, L sin θ). This branch is a smooth curve of the
configuration space through the flat positions θ = 0 and θ = π (every bar on the ground line),
where the loops' Jacobian loses N rows and the other branches (a window crossing into an
anti-parallelogram, crank i + 1 at −θ_i) meet it at an angle; the velocity there is along this
branch, so the motion continues on it (the smooth solution of the constrained equations through
the singular point, the one A02's data file follows).
Dynamics (Lagrange on the branch): the couplers translate with the cranks' tips,
    T = ½ I θ̇²,  I = (N + 1) m (r²/4 + L²/3) + N m L²                        (kg m²),
    V = K sin θ,  K = m g L ((N + 1)/2 + N)                                     (N m),
    I θ̈ = −K cos θ.
With ψ = θ + π/2 (the cranks' angle from hanging down) this is the pendulum ψ̈ = −ω² sin ψ,
ω² = K / I (1/s²), whose Jacobi-elliptic solution (libration, separatrix, rotation) is
``harness.references.plate_pendulum.pendulum_motion``, used as it stands. A02's start ψ0 = π
(upright), θ̇0 = −1 rad/s lies above the separatrix (k² = 1 + θ̇0²/(4ω²) > 1): the chain turns
over for ever, passing both flat positions on every turn. At A02's defaults (N = 40, L = 1 m,
m = 1 kg, r = 5 mm, g = 9.81 m/s²): I = 53.667 kg m², K = 593.505 N m, ω = 3.3255 rad/s, a
turn in about 2 s, ten turns and 20 passages of a flat position in 20 s; the cylinders of
r = 5 mm against A02's rods (r = 0): B0 within ``rod_distance`` of theirs, 2.1e-4 m over the
20 s. Verified (tests/references/test_four_bar_chain.py): against DOP853 on the equation over the
20 s (1e-10 rad), and against the Lagrange equations of all 2N + 1 bars with the windows'
closures as constraints, N = 3, over every stretch between two flat positions in 4 s (1e-11 rad).

The exact check of a run
------------------------
``exact_error``: max over the saved samples and over the tips B_0 .. B_N of every crank of
|B_i,run − B_i,exact| (m). B_0 is A02's output point; every window's tip is judged as well, as a
window that left the parallelogram branch at a flat position (the benchmark's trap) would move
its crank's tip while B_0 may not notice. A run's tip is its crank's centre of mass plus its
orientation applied to (L/2, 0, 0). The detail gives B_0's own error (A02's) and the largest
error of the couplers' centres. No extra runs (EXACT_NEEDS_RUNS = False).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from harness.model import rotations
from harness.model.builders.four_bar_chain import coupler, crank
from harness.references.plate_pendulum import pendulum_motion

if TYPE_CHECKING:  # pragma: no cover
    from harness.measure.trajectory import Trajectory
    from harness.model.scene import Scene

__all__ = [
    "inertia_and_moment",
    "natural_frequency",
    "crank_motion",
    "tip_positions",
    "rod_distance",
    "first_flat_time",
    "start_before_flat",
    "EXACT_NEEDS_RUNS",
    "exact_error_series",
    "exact_error",
    "exact_trajectory",
    "BENCHMARK",
]


def _n(params) -> int:
    return int(round(float(params["N"])))


def inertia_and_moment(params) -> tuple[float, float]:
    """(I, K) of I θ̈ = −K cos θ (module docstring): I (kg m²) = (N + 1) m (r²/4 + L²/3) + N m L²,
    K (N m) = m g L ((N + 1)/2 + N)."""
    n, L, m, r, g = _n(params), float(params["L"]), float(params["m"]), float(params["r"]), float(params["g"])
    return (n + 1) * m * (0.25 * r * r + L * L / 3.0) + n * m * L * L, m * g * L * (0.5 * (n + 1) + n)


def natural_frequency(params) -> float:
    """ω = √(K / I) (rad/s) of the chain's pendulum equation."""
    I, K = inertia_and_moment(params)
    return math.sqrt(K / I)


def crank_motion(params, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exact (θ, θ̇, θ̈) of every crank at times ``t`` (s): rad, rad/s, rad/s², θ continuous in
    time (module docstring)."""
    psi, dpsi, ddpsi = pendulum_motion(t, natural_frequency(params), float(params["theta0"]) + 0.5 * np.pi,
                                       float(params["dtheta0"]))
    return psi - 0.5 * np.pi, dpsi, ddpsi


def tip_positions(params, theta) -> np.ndarray:
    """(n, N + 1, 3) positions (m, world) of the cranks' tips B_0 .. B_N at crank angles θ."""
    theta = np.asarray(theta, dtype=float)
    L = float(params["L"])
    x0 = L * np.arange(_n(params) + 1)
    tips = np.zeros(theta.shape + (len(x0), 3))
    tips[..., 0] = x0 + L * np.cos(theta)[..., None]
    tips[..., 2] = (L * np.sin(theta))[..., None]
    return tips


def first_flat_time(params, t_end: float = 100.0) -> float:
    """The first time (s) in (0, t_end] at which every crank of the exact motion lies flat
    (sin θ = 0: the windows' singular position), to 1e-15 s (``scipy.optimize.brentq`` on a sign
    change of sin θ over a grid of 1/400 of the small-oscillation period). Raises ValueError when
    the motion does not reach it by t_end (a chain swinging below the horizontal)."""
    from scipy.optimize import brentq

    sin_theta = lambda t: float(np.sin(crank_motion(params, np.array([t]))[0][0]))  # noqa: E731
    grid = np.arange(0.0, t_end, 2.0 * np.pi / natural_frequency(params) / 400.0)[1:]
    values = np.sin(crank_motion(params, grid)[0])
    change = np.flatnonzero(np.sign(values[:-1]) != np.sign(values[1:]))
    if not len(change):
        raise ValueError(f"the cranks do not reach the flat position within {t_end:g} s")
    k = int(change[0])
    return float(brentq(sin_theta, grid[k], grid[k + 1], xtol=1e-15))


def start_before_flat(params, lead: float, past: float = 0.0) -> dict[str, float]:
    """Scene parameters ``{"theta0", "dtheta0"}`` (rad, rad/s): the exact motion's crank state
    ``lead`` s before it is ``past`` rad beyond its first flat position (to first order in past:
    at the flat position's time plus past / |θ̇| there). A run started there with step h puts a
    stage at that point when lead is a multiple of h / 2 (how the tests place a Runge-Kutta stage
    at a chosen distance from the singular position)."""
    t_flat = first_flat_time(params)
    rate = abs(float(crank_motion(params, np.array([t_flat]))[1][0]))
    theta, dtheta, _ = crank_motion(params, np.array([t_flat + past / rate - lead]))
    return {"theta0": float(theta[0]), "dtheta0": float(dtheta[0])}


def rod_distance(params, t) -> float:
    """Largest distance (m) over the times ``t`` between B0 of the scene's cylinders of radius r
    and of A02's slender rods (r = 0) started alike: how far the modelled bars are from the
    statement."""
    theta, _, _ = crank_motion(params, t)
    rod, _, _ = crank_motion({**params, "r": 0.0}, t)
    return float(np.max(np.hypot(np.cos(theta) - np.cos(rod), np.sin(theta) - np.sin(rod)))) * float(params["L"])


# ---------------------------------------------------------------------------------------------
# Exact checks of a run (``harness.measure.exact``)
# ---------------------------------------------------------------------------------------------
EXACT_NEEDS_RUNS = False  # the run itself is judged: no extra runs


def _run_tips(scene: "Scene", traj: "Trajectory") -> np.ndarray:
    """(n, N + 1, 3) the run's crank tips: centre of mass + R (L/2, 0, 0) (m, world)."""
    half = np.array([0.5 * float(scene.params["L"]), 0.0, 0.0])
    n = _n(scene.params)
    idx = [traj.body_names.index(crank(i, n)) for i in range(n + 1)]
    R = rotations.matrix(traj.quat_WB[:, idx])
    return traj.p_WCm_W[:, idx] + R @ half


def exact_error_series(scene: "Scene", traj: "Trajectory") -> np.ndarray:
    """max over the cranks' tips B_0 .. B_N of |B_i(t) − B_i,exact(t)| (m): every window's tip
    (A02's output point B_0 among them) against the elliptic solution of the chain
    (``crank_motion``)."""
    theta, _, _ = crank_motion(scene.params, traj.t)
    return np.max(np.linalg.norm(_run_tips(scene, traj) - tip_positions(scene.params, theta), axis=-1), axis=1)


def exact_error(scene: "Scene", traj: "Trajectory", settings=None, run=None) -> tuple[float, str, str]:
    """Max over samples of ``exact_error_series`` (m); the detail gives B0's own error (A02's
    output), the largest error of the couplers' centres and the distance of A02's slender rods
    from the modelled cylinders over the run. ``settings`` and ``run`` are unused."""
    p = scene.params
    if len(traj.t) == 0:
        return float("nan"), "m", "no samples"
    theta, _, _ = crank_motion(p, traj.t)
    exact = tip_positions(p, theta)
    err = np.linalg.norm(_run_tips(scene, traj) - exact, axis=-1)
    n, L = _n(p), float(p["L"])
    idx = [traj.body_names.index(coupler(i, n)) for i in range(n)]
    centres = exact[:, :n] + np.array([0.5 * L, 0.0, 0.0])
    couplers = float(np.max(np.linalg.norm(traj.p_WCm_W[:, idx] - centres, axis=-1))) if n else 0.0
    return (float(np.max(err)), "m",
            f"every crank's tip vs the elliptic solution of the parallelogram chain; B0 (A02's output) "
            f"{float(np.max(err[:, 0])):.1e} m, couplers' centres {couplers:.1e} m; A02's slender rods (r = 0) "
            f"within {rod_distance(p, traj.t):.1e} m of the modelled r = {float(p['r']):g} m over the run")


def exact_trajectory(scene: "Scene", t) -> "Trajectory":
    """The exact motion of every body at times ``t`` (s) in maximal coordinates (the common
    state, ``harness.measure.trajectory.Trajectory``): crank i at angle θ about its pivot
    (i L, 0, 0), its centre of mass at the pivot + (L/2) e(θ), orientation θ about world −y
    (quaternion (cos θ/2, 0, −sin θ/2, 0)), velocity (L/2) θ̇ e'(θ), angular velocity −θ̇ ŷ
    (rad/s, world); coupler i level (identity orientation, at rest in rotation), its centre at
    B_i + (L/2, 0, 0), moving with B_i at L θ̇ e'(θ) (m/s), e'(θ) = (−sin θ, 0, cos θ). The
    work-precision study measures every run against it (the scene declares no check against a
    reference run, so it has none: ``harness.studies.workprecision.run.reference``)."""
    from harness.measure.trajectory import Trajectory

    t = np.asarray(t, dtype=float)
    p = scene.params
    n, L = _n(p), float(p["L"])
    theta, dtheta, _ = crank_motion(p, t)
    names = scene.multibody().body_names
    e = np.stack([np.cos(theta), np.zeros_like(theta), np.sin(theta)], axis=-1)
    de = np.stack([-np.sin(theta), np.zeros_like(theta), np.cos(theta)], axis=-1)
    pos, quat = np.zeros((len(t), len(names), 3)), np.zeros((len(t), len(names), 4))
    vel, omega = np.zeros_like(pos), np.zeros_like(pos)
    for i in range(n + 1):
        k = names.index(crank(i, n))
        pos[:, k] = np.array([i * L, 0.0, 0.0]) + 0.5 * L * e
        quat[:, k, 0], quat[:, k, 2] = np.cos(0.5 * theta), -np.sin(0.5 * theta)
        vel[:, k] = 0.5 * L * dtheta[:, None] * de
        omega[:, k, 1] = -dtheta
        if i < n:
            k = names.index(coupler(i, n))
            pos[:, k] = np.array([(i + 0.5) * L, 0.0, 0.0]) + L * e
            quat[:, k, 0] = 1.0
            vel[:, k] = L * dtheta[:, None] * de
    return Trajectory("closed form", "elliptic", tuple(names), t, pos, quat, vel, omega)


#: The scene as the benchmark report states it (``harness benchmark``): the IFToMM problem, what
#: the library publishes, and its required accuracy as a state error relative to the scene's
#: scales (A02's high precision: 1e-3 m on 1 m bars).
BENCHMARK = {
    "problem": "IFToMM A02",
    "title": "N four-bar mechanism (N = 40)",
    "published": "B0's position and velocity over 20 s as a data file (not available here): judged against the "
                 "closed form of the parallelogram chain (every window's crank tip)",
    "required": 1e-3,
}
