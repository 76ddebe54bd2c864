"""Exudyn engine: the scene's bodies in redundant coordinates, joints as algebraic constraints.

A different formulation from the other engines (MuJoCo and Pinocchio: reduced coordinates and
articulated-body dynamics; in-house: maximal coordinates with Baumgarte-stabilised or projected
index-1 constraints): Exudyn integrates every body's absolute coordinates and enforces joints,
loop (cut) joints and the rolling contact as algebraic equations with Lagrange multipliers,
solved with the time step (index 3 or index 2; ``harness.engines.exudyn.integrators``). The
system is built from the scene's description (``harness.engines.exudyn.model``); Exudyn reads
no model file. A loop joint is an ``ObjectJointGeneric`` stating the loop's rows that are not
structurally implied by the tree (``harness.engines.exudyn.model.loop_rows``); when rows are
dependent at the initial state only, every row is kept and the run uses Eigen's full-pivot LU
(``EigenDense`` with ``ignoreSingularJacobian``). The run record's settings name the rows.

The linear solver of the Newton iteration (``linear_solver``) goes by the assembled system's
size: Exudyn's dense LU with full Newton below ``SPARSE_MIN_SIZE`` coordinates (every shipped
scene but four_bar_chain), Eigen's sparse LU with one Newton Jacobian per step from there on
(four_bar_chain at N = 40, 1131 coordinates: 20 s at a 1 ms step in 24-33 s instead of
800-1660 s), and the full-pivot LU whatever the size where rows are dependent. The run record's
settings name it.

Maximal coordinates come from Exudyn's sensors at every saved sample: the centre of mass
position and velocity (m, m/s, world), the rotation matrix and the world angular velocity
(rad/s). Exudyn reports no system energy: the harness computes it from these.

Joint reactions (``[checks.reaction]``): Exudyn's constraint force of each joint. For a
spherical joint, ``Force`` in world; for a generic joint (hinge, slide), ``ForceLocal`` and
``TorqueLocal`` in the joint frame of the parent's marker (the parent's body frame times the
joint's ``rotationMarker0``, after the marker's own rotation: ``joint_frame``), rotated to world. Exudyn reports the force the joint applies to
its first body (the parent); the force on the child (the harness's convention: what the
parent exerts on the child, about the joint point) is its negative. For the rolling contact,
the rolling-disc joint's ``ForceLocal`` (the force on the disc in Exudyn's contact frame J1:
lateral, longitudinal, normal) is turned to world with the joint's ``RotationMatrix`` output
(J1 -> world); the moment about the contact point is zero (an ideal point contact). A loop joint
``<name>`` (``LoopJoint``) reports under its name the reaction on body_a (its first marker):
the generic joint's ``ForceLocal`` in J_A turned to world (N), and the moment about the joint
point (N m, world) of the multipliers of its stated rotation conditions (``TorqueLocal``,
``rotation_conditions``), zero for a ball. A row left out as redundant carries nothing: the tree
joints take that direction. Like every multiplier here, the loop's starts off when a joint
point away from a node moves at t = 0 (Exudyn's initial accelerations) and generalized-alpha
damps the error out: on a spatial ball loop (tests/engines/exudyn/test_loops.py), 1.3e-2 of the
force scale at t = 0, 1.3e-4 from 0.1 s and 1.3e-5 from 0.2 s at a 1e-3 s step (the tree's ball
joints of that model alike; a double pendulum whose upper bar turns at t = 0 shows it too).
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from harness.engines.base import EngineBase, RunSettings, check_settings, first_blowup
from harness.engines.exudyn.integrators import IMPLICIT, METHODS, NODE_TYPE
from harness.engines.exudyn.model import build, rotation_conditions
from harness.measure.trajectory import Failure, Trajectory, unsupported
from harness.model import rotations
from harness.model.joints import JOINTS
from harness.model.scene import Scene

#: Newton iteration of the implicit methods: full Newton (Jacobian every iteration; once a step
#: from ``SPARSE_MIN_SIZE`` coordinates, ``linear_solver``), converged
#: when the residual falls below these (relative to the first residual of the step; absolute).
NEWTON_RTOL = 1e-8
NEWTON_ATOL = 1e-12

#: Spectral radius at infinity of generalized-alpha (Exudyn's default). At 1 (no numerical
#: damping) the index-3 multipliers are undamped: on the spring pendulum the joint-force error
#: after 0.5 s grows from 5e-4 N (step 1e-3 s) to 0.13 N (1e-4 s); on the rolling disk the
#: contact force stays 6 % off the reference at every step from 5e-4 to 6.25e-5 s (the motion
#: converges); on the double pendulum the energy error after 10 s grows from 2.2e-3 (1e-3 s) to
#: 3.8e-2 (2.5e-4 s). At 0.9 all three converge: spring pendulum force 3.2e-5 N at 2.5e-4 s
#: (1.3e-3 N at 1e-4 s, where the index-3 conditioning ~ 1/h^2 shows), rolling-disk force
#: 1.4e-2, 1.8e-3, 2.6e-5, 7.2e-7 of the force scale from 5e-4 to 6.25e-5 s, double pendulum
#: energy 1.5e-5, 3.7e-6, 9.3e-7 (tests/engines/exudyn/test_engine.py).
SPECTRAL_RADIUS = 0.9

#: Size of the assembled system (Exudyn's ODE2 and algebraic coordinates: 6 per rigid body on
#: rotation-vector nodes, 7 on Euler parameters, and every joint's multipliers; ``system_size``)
#: from which a run solves with Eigen's sparse LU (``LinearSolverType.EigenSparse``) and takes one
#: Newton Jacobian per step (``linear_solver``); below it, Exudyn's dense LU (``EXUdense``) and
#: full Newton. Wall time, GeneralizedAlpha at a 1 ms step, full Newton both (shared 2-core
#: machine): four_bar (39 coordinates) 2 s in 0.114 s dense, 0.128 s sparse (best of 3);
#: four_bar_chain N = 2 (67) 0.23 s, 0.22 s; andrews_squeezer (95; 0.03 s at 1e-5 s) 0.63 s,
#: 0.50 s (best of 3); four_bar_chain N = 4 (123) 0.62 s, 0.39 s; N = 8 (235) 2.0 s, 0.78 s;
#: N = 40 (1131) 51-72 ms a step dense (its factorization ~90 %), 1.7 ms sparse. The threshold
#: sits above every shipped scene but four_bar_chain (the largest, andrews_squeezer, has 95),
#: whose runs stay as they were (tests/engines/exudyn/test_linear_solver.py).
SPARSE_MIN_SIZE = 100

#: With the sparse LU the step's Newton Jacobian, computed at its first iteration, is kept while
#: each iteration reduces the residual by at least this factor; a poorer one takes a new
#: Jacobian (Exudyn's ``modifiedNewtonContractivity``). Exudyn's default, 0.5, lets a step next to
#: four_bar_chain's flat position creep at 0.38 an iteration down to the residual floor there
#: (``linear_solver``): N = 4 at a 2 ms step stopped at t = 1.236 s; at 0.1 it runs the 20 s.
STEP_JACOBIAN_CONTRACTIVITY = 0.1


class ExudynEngine(EngineBase):
    """Runs a scene in Exudyn, built from the scene's description. ``modified_newton``: reuse the
    Newton Jacobian across iterations and steps (Exudyn's modified Newton) where full Newton
    (``NEWTON_RTOL``, validation's setting; one Jacobian per step on a large system,
    ``linear_solver``) is not needed: the step converges to the same tolerances, 20 times faster
    on a 30-body robot (``harness check``'s witness runs)."""

    name = "exudyn"
    integrators = METHODS

    def __init__(self, modified_newton: bool = False):
        self.modified_newton = modified_newton

    def run(self, scene: Scene, settings: RunSettings) -> Trajectory:
        return self.simulate_model(scene.multibody(), settings, reactions="reaction" in scene.checks)

    def simulate_model(self, model, settings: RunSettings, *, reactions: bool = False) -> Trajectory:
        """Integrate ``model`` from its initial state; samples at ``t = k * save_every``.

        Returns the trajectory in maximal coordinates; a solver failure (Newton not converged),
        a non-finite state or a speed beyond ``BLOWUP_SPEED`` (``first_blowup``) ends it with
        its ``Failure`` and the samples before it; an explicit method on a model with joints or contacts
        gives status "unsupported". Never raises for a numerical failure."""
        check_settings(settings, self.integrators, self.name)
        import exudyn as exu

        names = tuple(model.body_names)
        method = settings.integrator
        constrained = [b.name for b in model.bodies if JOINTS[b.joint].constrained]
        if method not in IMPLICIT and (constrained or model.loops or model.contacts):
            what = "joints" if constrained or model.loops else "a rolling contact"
            return unsupported(self.name, method, names,
                               f"{method}: Exudyn's explicit solvers take no algebraic equations and this scene has {what} "
                          f"(implicit: {', '.join(IMPLICIT)})")
        start = time.perf_counter()
        try:
            system = build(model, NODE_TYPE[method], reactions=reactions)
        except NotImplementedError as err:
            return unsupported(self.name, method, names, f"{method}: {err}")
        n_steps = settings.n_saves * settings.steps_per_save
        ss = _solver_settings(exu, settings, n_steps, self.modified_newton, solver=linear_solver(system))
        printing = exu.config.printToConsole
        exu.config.printToConsole = False  # Exudyn's own failure banner; the run record says it
        reason, message = Failure.NONE, ""
        t0 = time.perf_counter()
        try:
            system.mbs.SolveDynamic(ss, solverType=getattr(exu.DynamicSolverType, method))
        except Exception as err:  # noqa: BLE001 - Exudyn raises SolverError (and RuntimeError) on failure
            reason, message = Failure.SOLVER, f"{method}: Exudyn solver stopped ({type(err).__name__}: {' '.join(str(err).split())})"
        finally:
            exu.config.printToConsole = printing
        wall_solve = time.perf_counter() - t0
        traj = _read(system, model, settings, self.name, method)
        saved = len(traj.t)
        if reason is not Failure.NONE and saved:
            message += f"; last sample t = {traj.t[-1]:.6g} s"
        bad, blowup, what = first_blowup(traj.p_WCm_W, traj.v_WCm_W, traj.w_WB_W, traj.t)
        if bad >= 0:
            saved = bad
            if reason is Failure.NONE:
                reason, message = blowup, what
        out = _truncate(traj, saved)
        if reason is Failure.NONE and len(out.t) != settings.n_saves + 1:
            reason, message = Failure.SOLVER, (f"Exudyn stored {len(out.t)} samples, expected {settings.n_saves + 1} "
                                               f"(t = k * {settings.save_every:g} s)")
        edge_flip = _edge_flip(system, out, model)
        if edge_flip and reason is Failure.NONE:
            reason, message = Failure.SINGULAR, edge_flip
        out.stats.update({
            # a failed run: the steps up to its last stored sample (a lower bound)
            "steps": n_steps if reason is Failure.NONE else max(len(out.t) - 1, 0) * settings.steps_per_save,
            "wall_s": time.perf_counter() - start,
            "wall_solve_s": wall_solve,
            "settings": _describe(method, settings, model, system, self.modified_newton),
        })
        if reason is not Failure.NONE:
            return replace(out, reason=reason, message=message)
        if reactions or model.contacts:
            out = replace(out, reactions=reaction_series(system, model, out, reactions=reactions))
        return out


def system_size(system) -> int:
    """Coordinates of the assembled Exudyn system (ODE2, ODE1 and algebraic): the order of the
    Newton iteration's linear system."""
    sd = system.mbs.systemData
    return int(sd.ODE2Size() + sd.ODE1Size() + sd.AEsize())


def linear_solver(system) -> str:
    """Exudyn's ``LinearSolverType`` (name) for ``system``'s Newton iteration:

    * ``EigenDense`` (Eigen's full-pivot LU, with ``ignoreSingularJacobian``) where rows are
      dependent, throughout (a rolling body on a joint, ``ExudynSystem.dependent_rows``) or at the
      initial state only (``LoopRows.singular``): it resolves them, whatever the size (Exudyn's
      ``ignoreSingularJacobian`` works with its dense solvers only);
    * ``EigenSparse`` (Eigen's SparseLU) from ``SPARSE_MIN_SIZE`` coordinates (``system_size``):
      the Newton matrix of a multibody system is sparse (a joint couples two bodies) and the
      dense LU's cost grows with the cube of its order. The step then takes one Newton Jacobian
      (Exudyn's modified Newton with ``modifiedNewtonJacUpdatePerStep``: the Jacobian of the
      step's first iteration kept for the others while they contract by
      ``STEP_JACOBIAN_CONTRACTIVITY``), converged to the same tolerances;
    * ``EXUdense`` (Exudyn's dense LU, its default) below that size, with full Newton.

    Measured on four_bar_chain (GeneralizedAlpha; wall times on the shared 2-core machine). N = 40
    (1131 coordinates), 1 ms step: 51-72 ms a step dense with full Newton, 1.7 ms sparse with full
    Newton (2 Jacobians a step), 1.1 ms sparse with one Jacobian a step (2 iterations a step in
    each); keeping the Jacobian across steps too (``ExudynEngine(modified_newton=True)``) takes 7
    iterations a step there and is no faster. N = 40 over 20 s at 2, 1, 0.5 ms: exact error
    1.283e-3, 3.205e-4, 8.12e-5 m (order 2.0, 2.0), in 15, 24, 58 s (dense with full Newton:
    1.283e-3 m in 723 s at 2 ms, 3.2e-4 m in 800-1660 s at 1 ms). Through the flat positions,
    where N loop rows become dependent for an instant, the sparse run is the dense one's: exact
    error 2.355e-5 m both over 2 s at N = 40 (first flat position at t = 0.715 s); positions
    within 4e-10 m over 1 s at N = 4, 2.5e-8 m over 3 s at N = 8.

    A step that lands next to a flat position may leave Newton stalled at a residual of
    ~1e-7 of the step's first one, above ``NEWTON_RTOL`` (a near-singular root: full Newton
    wanders or cycles there), and the run stops there (status failed). Which runs meet such a
    step goes by round-off, whatever the solver: over N = 2, 3, 4, 5, 6, 8, 12 at 2, 1, 0.5 ms
    (20 s), the dense LU with full Newton (the previous setting) stopped at N = 8, 2 ms
    (t = 18.35 s; it took 23 iterations at a step of N = 4, 2 ms and 14 at N = 12, 1 ms), the
    sparse LU with full Newton at N = 8, 2 ms and N = 12, 1 ms, the sparse LU with one Jacobian
    per step at N = 12, 1 ms (t = 16.42 s); at N = 40 both sparse settings ran all three steps.
    """
    if system.dependent_rows or (system.loop_rows is not None and system.loop_rows.singular):
        return "EigenDense"
    return "EigenSparse" if system_size(system) >= SPARSE_MIN_SIZE else "EXUdense"


def _solver_settings(exu, settings: RunSettings, n_steps: int, modified_newton: bool = False, *,
                     solver: str = "EXUdense"):
    """Exudyn ``SimulationSettings`` for a fixed-step run of ``n_steps`` steps to ``t_end`` with
    sensors stored every save interval, nothing written to files or the console, the Newton
    iteration's linear ``solver`` (``linear_solver``); full Newton unless ``modified_newton``
    (the Jacobian kept across steps) or the sparse solver (one Jacobian per step)."""
    ss = exu.SimulationSettings()
    ti = ss.timeIntegration
    ti.numberOfSteps = n_steps
    ti.endTime = settings.t_end
    ti.verboseMode = 0
    ti.adaptiveStep = False  # a fixed step: a Newton failure stops the run instead of halving the step
    ti.automaticStepSize = False
    ti.generalizedAlpha.spectralRadius = SPECTRAL_RADIUS
    ti.newton.useModifiedNewton = modified_newton
    ss.linearSolver.solverType = getattr(exu.LinearSolverType, solver)
    if solver == "EigenDense":  # dependent rows: the full-pivot LU resolves them
        ss.linearSolver.ignoreSingularJacobian = True
    if solver == "EigenSparse" and not modified_newton:  # a large system: one Jacobian per step
        ti.newton.useModifiedNewton = True
        ti.newton.modifiedNewtonJacUpdatePerStep = True
        ti.newton.modifiedNewtonContractivity = STEP_JACOBIAN_CONTRACTIVITY
    ti.newton.relativeTolerance = NEWTON_RTOL
    ti.newton.absoluteTolerance = NEWTON_ATOL
    ss.solution.file.write = False
    ss.solution.sensors.writePeriod = settings.save_every * (1.0 - 1e-9)  # every save interval, robust to rounding
    ss.show.statistics = False
    ss.show.computationTime = False
    ss.show.globalTimers = False
    return ss


#: How the run record names each linear solver (``linear_solver``).
SOLVER_TEXT = {"EXUdense": "dense LU (EXUdense)", "EigenSparse": "sparse LU (EigenSparse)",
               "EigenDense": "full-pivot LU (EigenDense, ignoreSingularJacobian)"}


def _describe(method: str, settings: RunSettings, model, system=None, modified_newton: bool = False) -> str:
    node = NODE_TYPE[method]
    text = f"Exudyn {method} on {node} nodes, step {settings.dt:g} s"
    if method in IMPLICIT:
        solver = "EXUdense" if system is None else linear_solver(system)
        if modified_newton:
            newton = "modified Newton (Jacobian kept across steps)"
        elif solver == "EigenSparse":
            newton = f"Newton with one Jacobian per step (a new one below {STEP_JACOBIAN_CONTRACTIVITY:g} contraction)"
        else:
            newton = "full Newton"
        text += f", {newton} (rtol {NEWTON_RTOL:g}, atol {NEWTON_ATOL:g})"
        if system is not None:
            text += f", {SOLVER_TEXT[solver]} on {system_size(system)} coordinates"
        if method == "GeneralizedAlpha":
            text += f", spectral radius {SPECTRAL_RADIUS:g}, index-3 constraints"
        else:
            text += ", index-2 constraints"
    if model.contacts:
        text += ", rolling contact: ObjectJointRollingDisc at the lower rim edge"
    if system is not None and system.loop_rows is not None:
        text += f", loop joints as ObjectJointGeneric rows ({system.loop_rows.describe()})"
    return text


def _stored(system, sensor) -> np.ndarray:
    data = np.asarray(system.mbs.GetSensorStoredData(sensor), dtype=float)
    return data.reshape(len(data), -1) if data.size else np.zeros((0, 2))


def _read(system, model, settings: RunSettings, engine: str, method: str) -> Trajectory:
    """The stored sensor samples as a Trajectory (the samples every sensor has)."""
    names = tuple(model.body_names)
    series = {b: [_stored(system, s) for s in system.body_sensors[b]] for b in names}
    n = min(len(x) for parts in series.values() for x in parts)
    t = series[names[0]][0][:n, 0] if n else np.zeros(0)
    nominal = np.arange(n) * settings.save_every
    if np.allclose(t, nominal, rtol=0.0, atol=1e-9 * settings.save_every):
        # Exudyn's stored times carry its step accumulation's round-off (~1e-17 s): the samples
        # are the grid's, given as every engine gives it (the closed forms cache by the times)
        t = nominal
    nb = len(names)
    p = np.zeros((n, nb, 3))
    quat = np.zeros((n, nb, 4))
    v = np.zeros((n, nb, 3))
    w = np.zeros((n, nb, 3))
    for i, b in enumerate(names):
        pos, rot, vel, omega = (x[:n, 1:] for x in series[b])
        p[:, i], v[:, i], w[:, i] = pos, vel, omega
        R = rot.reshape(n, 3, 3)
        finite = np.all(np.isfinite(R), axis=(1, 2))
        quat[:, i] = np.nan
        if finite.any():  # every sample at once (SciPy's per-call overhead is most of a single one)
            quat[finite, i] = rotations.from_matrix(R[finite])
    return Trajectory(engine, method, names, t, p, quat, v, w, stats={})


def _truncate(traj: Trajectory, n: int) -> Trajectory:
    return Trajectory(traj.engine, traj.integrator, traj.body_names, traj.t[:n], traj.p_WCm_W[:n], traj.quat_WB[:n],
                      traj.v_WCm_W[:n], traj.w_WB_W[:n], stats=dict(traj.stats))


def _edge_flip(system, traj: Trajectory, model) -> str:
    """Why the run is not the scene's motion when a rolling body's axis crossed the horizontal
    (the other rim edge would touch the plane; Exudyn's joint stays on the initial one), else ""."""
    for name, (_, body, edge) in system.contacts.items():
        if edge == 0.0 or not len(traj.t):
            continue
        i = traj.body_index(body)
        n_z = rotations.matrix(traj.quat_WB[:, i])[:, 2, 2]
        flipped = np.nonzero(np.sign(n_z) == -edge)[0]
        if len(flipped):
            return (f"rolling contact {name!r}: the axis crossed the horizontal at t = {traj.t[flipped[0]]:.6g} s; "
                    f"the other rim edge touches the plane there, Exudyn's rolling-disc joint stays on the first")
    return ""


def moment_of_conditions(pairs, J0, J1, lam):
    """Moment (N m, world) on a joint's child from the multipliers ``lam`` (n, k) (Exudyn's
    ``TorqueLocal``) of rotation conditions a0 . b1 = 0, one per ``(a, b)`` in ``pairs``
    (``ExudynJoint.rotation_conditions``: columns of the parent's joint frame J0 and the
    child's J1, world, (n, 3, 3)): a rotation dtheta of the child changes a0 . b1 by
    dtheta . (b1 x a0), so condition i acts on the child with the moment -lam_i (b1 x a0)
    (the sign that makes the forces, also reported on the parent, agree)."""
    out = np.zeros((len(lam), 3))
    for i, (a, b) in enumerate(pairs):
        out -= lam[:, i:i + 1] * np.cross(J1[:, :, b], J0[:, :, a])
    return out


def joint_frame(mbs, joint, side: int) -> np.ndarray:
    """Rotation (3x3) from the frame of joint object ``joint`` on its body ``side`` (0: the
    first body, the parent; 1: the child) to that body's frame: the marker's own rotation
    (``localHT``, where the marker has one) times the joint's ``rotationMarker<side>``."""
    obj = mbs.GetObject(joint)
    marker = mbs.GetMarker(obj["markerNumbers"][side])
    R_marker = np.asarray(marker["localHT"], dtype=float)[:3, :3] if "localHT" in marker else np.eye(3)
    return R_marker @ np.asarray(obj.get(f"rotationMarker{side}", np.eye(3)), dtype=float)


def reaction_series(system, model, traj: Trajectory, *, reactions: bool) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Joint reactions (when ``reactions``) and contact forces at the trajectory's samples:
    name -> (force_W (n, 3) N, moment_W (n, 3) N m); see the module docstring."""
    n = len(traj.t)
    out: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    if reactions:
        for body, sensors in system.joint_sensors.items():
            joint, kind, parent = system.joints[body]
            spec = JOINTS[kind].exudyn
            force = _stored(system, sensors[0])[:n, 1:4]
            R_P = np.broadcast_to(np.eye(3), (n, 3, 3)) if parent is None else rotations.matrix(traj.quat_WB[:, traj.body_index(parent)])
            J0 = R_P @ joint_frame(system.mbs, joint, 0)
            force_W = force if spec.force_output == "Force" else np.einsum("nij,nj->ni", J0, force)
            moment_W = np.zeros((n, 3))
            if sensors[1] is not None:
                lam = _stored(system, sensors[1])[:n, 1:1 + len(spec.rotation_conditions)]
                J1 = rotations.matrix(traj.quat_WB[:, traj.body_index(body)]) @ joint_frame(system.mbs, joint, 1)
                moment_W = moment_of_conditions(spec.rotation_conditions, J0, J1, lam)
            out[body] = (-force_W, moment_W)  # Exudyn reports the force on the parent
        for name, (force, torque) in system.loop_sensors.items():
            force_J0, torque_J0 = (_stored(system, s)[:n, 1:4] for s in (force, torque))
            out[name] = _loop_reaction(system, traj, name, force_J0, torque_J0)
    for name, (force, frame) in system.contact_sensors.items():
        f_J1 = _stored(system, force)[:n, 1:4]
        A = _stored(system, frame)[:n, 1:10].reshape(-1, 3, 3)  # J1 (lateral, longitudinal, normal) -> world
        out[name] = (np.einsum("nij,nj->ni", A, f_J1), np.zeros((n, 3)))
    return out


def _loop_reaction(system, traj: Trajectory, name: str, force_J0: np.ndarray, torque: np.ndarray):
    """A loop joint's reaction on body_a (its marker 0): force (N, world) and moment about the
    joint point (N m, world), from the generic joint's ``ForceLocal`` (J_A) and the multipliers
    of its rotation conditions (``rotation_conditions``; ``moment_of_conditions`` gives the
    moment on the second body, body_b: body_a gets its opposite)."""
    joint, rows, body_a, body_b = system.loops[name]
    n = len(traj.t)

    def rotation(body):
        return np.broadcast_to(np.eye(3), (n, 3, 3)) if body is None else rotations.matrix(traj.quat_WB[:, traj.body_index(body)])

    J0 = rotation(body_a) @ joint_frame(system.mbs, joint, 0)
    force_W = np.einsum("nij,nj->ni", J0, force_J0)
    conditions = rotation_conditions(rows)
    moment_W = np.zeros((n, 3))
    if conditions:
        J1 = rotation(body_b) @ joint_frame(system.mbs, joint, 1)
        lam = torque[:, [k for k, _ in conditions]]
        moment_W = -moment_of_conditions([pair for _, pair in conditions], J0, J1, lam)
    return force_W, moment_W


ENGINE = ExudynEngine()
