"""Pinocchio with closed kinematic loops: the scene's tree from its URDF, each cut joint
(``harness.model.multibody.LoopJoint``) as Pinocchio's own loop-closure constraint models, forward
dynamics by Pinocchio's proximal constrained solver ``pin.constraintDynamics``, our Lie-group
integrators and a projection onto the constraint manifold after every step.

How a cut joint reaches Pinocchio. A URDF is a tree and cannot state a loop, so the URDF holds the
tree only; the cut joints come from the scene description (``Multibody.loops``) and are built here
as ``pin.RigidConstraintModel``s (``LoopConstraints``):

* a ball: one ``CONTACT_3D`` model between ``joint1`` = the joint that moves ``body_a``, placement
  ``SE3(I, p_A)``, and ``joint2`` = the joint of ``body_b`` (0, the universe, for the world),
  placement ``SE3(I, p_B)``: the two points coincide (3 rows);
* a hinge: two ``CONTACT_3D`` models, at the joint point (p_A, p_B) and at the point one
  ``hinge_span`` (m) along the axis (p_A + hinge_span axis_A, p_B + hinge_span axis_B): two
  coinciding points fix the axis and leave the rotation about it free (6 rows for the hinge's 5:
  the one along the axis is always redundant) -- the same statement as the MJCF's two site
  ``<connect>``s (``harness.engines.mujoco.loops``);
* a planar hinge: one ``CONTACT_3D`` model at the joint point (3 rows), when every joint of the
  tree between its two bodies is a slide or a hinge about an axis parallel to the loop's
  (``turns_about_axis_only``: the tree itself keeps the axes aligned, so the second point's rows
  are implied, at every configuration, by the first point's and the tree). Its multipliers are
  the same in-plane force; the statically indeterminate split of the out-of-plane force and
  moments between two points does not arise (moment 0). Why: ``constraintDynamics`` factors the
  constraint block of its KKT matrix densely, in ~nc^3 operations: on four_bar_chain at N = 40
  (40 planar hinges) 240 rows took 1.0 ms a call and 120 rows take 0.25 ms (one BLAS thread),
  and a run's step 7 ms before, 2 ms after (the least-squares projection of 120 rows instead of
  240 is the rest). The motion is unchanged: four_bar, four_bar_near_singular, slider_crank and
  andrews_squeezer give the same exact errors to 3 digits at dt/2, dt and 2 dt.

The placements are in the body frame of the URDF link, which is the joint frame of the body
(``load_urdf`` refuses links not at their joint frame), so p_A, p_B (m, body frame of
body_a/body_b, or world) are used as they are.

Why these models. Pinocchio 4.1 has no hinge constraint: ``CONTACT_6D`` (a weld) also locks the
rotation about the axis, which is wrong for a hinge; the newer ``PointAnchorConstraintModel`` /
``FrameAnchorConstraintModel`` (4.1) feed the contact solvers (``ADMMConstraintSolver``,
``PGSConstraintSolver``) of a velocity-level time-stepping scheme, not ``constraintDynamics``,
whose Python binding takes ``RigidConstraintModel``s only, and a frame anchor is a weld too. Two
point constraints are what 4.1 offers to state a hinge exactly. Every model has the reference
frame ``LOCAL_WORLD_ALIGNED``: its 3 rows are the world components of x_1 - x_2 (the point on
joint1 minus the point on joint2), so ``getConstraintsJacobian`` is exactly the Jacobian of the
position residual e = x_1 - x_2 = -R_1 c1Mc2.translation (m, world; ``c1Mc2`` and ``oMc1`` of the
constraint data after ``RigidConstraintModel.calc``) used by the projection below, and the
multipliers are world forces.

Dynamics. ``pin.constraintDynamics(model, data, q, v, tau, models, datas, ProximalSettings)`` solves
the KKT system of the tree with the constraint rows by Pinocchio's sparse Cholesky of the
regularised KKT matrix and proximal iterations ``lambda_{k+1} = (D + mu I)^-1 (rhs + mu lambda_k)``
(D the Delassus matrix J M^-1 J^T), which converge for rank-deficient D: this is how the redundant
rows are handled (a planar loop closed by a hinge has 3 rows of rank 2, the out-of-plane row zero
in J and in the right-hand side; a 3-D hinge 6 rows of rank 5 or less; the determinate
multipliers converge, the rest is the proximal iteration's, which starts from 0, so the
minimum-norm one up to round-off). Settings (``proximal_settings``), with d the largest diagonal
entry of the Delassus matrix at the initial state (``pin.computeDelassusMatrix``; 1/kg for point
rows: 3.3/kg on four_bar, 3.0/kg on four_bar_chain for every N): ``mu = MU_RELATIVE`` (1e-8) x d
(1/kg); stop when the loops' acceleration residual ``|J a + gamma|`` of the iterate is below
``CLOSURE_ACCURACY`` (1e-15) x the acceleration scale ``d force_scale`` (``force_scale``: the total
weight; 7.6e-14 m/s^2 on four_bar), stated to Pinocchio as its relative accuracy (N) on the max
change of the multipliers between proximal iterations, ``CLOSURE_ACCURACY d force_scale / mu``
(the change times mu is that residual: ``(D + mu I) lambda_k = rhs + mu lambda_{k-1}``); at most
``MAX_PROXIMAL_ITER`` (20) iterations. The absolute accuracy is off (0): the absolute residual that
4.1's ``constraintDynamics`` reports (a Delassus product of the iterate minus the right-hand side)
is not the constraint-acceleration error: it stayed at 13 to 18 at converged solves on
four_bar/slider_crank where J a + gamma, computed apart, was 1e-15 m/s^2. The determinate
multipliers converge by a factor ~mu / (mu + sigma) per iteration, sigma the Delassus eigenvalue
of their direction (2 to 3 iterations on four_bar, slider_crank, andrews_squeezer); round-off in
null directions is mapped to zero by ``J^T`` (bricard's 3-D hinge: its rank-4 rows stop at
max_iter in most solves, at mu 1e-6 as at 1e-8, with the same exact errors, 5.9e-11 / 3.8e-12 /
1.8e-12 m at 2 dt / dt / dt/2); ``stats`` counts the solves that stopped at ``max_iter``
(``prox_unconverged``) and the most iterations taken (``prox_iter_max``).

Singular positions (four_bar_chain, IFToMM A02: N parallelogram windows through the flat position
twice a turn). There the windows' in-plane rows lose rank: N eigenvalues of D fall as
``c theta^2`` (theta the cranks' distance from the flat position; c = 1.5, 0.11, 0.0046 /kg at N = 2,
8, 40 with one point per hinge, twice that with two; the chain's lowest modes). Where
``c theta^2 < mu`` the proximal iteration no longer converges in MAX_PROXIMAL_ITER and the windows' in-plane
forces are missing from the stage accelerations; the run then gains or loses energy at each flat
crossing, a common-mode error of the cranks' angle (no window folds: the cranks stay parallel to
1e-10 rad). With the earlier ``mu = 1e-6 d`` (3e-6 /kg; two points per hinge) that band was
|theta| < 0.018 rad at N = 40 (719 of 80000 solves at max_iter at dt = 1 ms) and the error against
the exact motion 2.8e-6 / 7.1e-5 / 4.1e-5 m over the 20 s at 2 / 1 / 0.5 ms, not falling with the
step. ``mu = 1e-8 d`` (3e-8 /kg, one point) narrows it to |theta| < 2.6e-3 rad. Measured over 60
crossings at random phases (the energy change across one crossing, J, mean at 2 / 1 / 0.5 ms;
before: mu = 1e-6 d with one point per hinge): N = 2: 4.1e-7 / 4.4e-7 / 6.7e-8 before, 2.0e-10 /
1.4e-10 / 1.8e-8 after; N = 8: 1.5e-6 / 5.8e-7 / 1.7e-7 before, 9.4e-8 / 1.1e-7 / 2.0e-8 after;
N = 40: 2.2e-6 / 1.9e-5 / 1.2e-5 before, 8.5e-6 / 1.0e-7 / 1.8e-7 after. What remained was not a matter of mu:
a Runge-Kutta stage within |theta| < h theta' of the flat position solved acceleration-level
constraints whose near-singular rows amplified the stage's velocity error by ~h theta' / (2 theta)
(measured at N = 40, 2 ms: a stage at theta = 4e-6 rad took a multiplier of 9e4 N against 130 N,
the next one 1.6e7 N; up to 5e-4 J in a crossing); no mu from 1e-12 to 4e-6 removed both that
and the band. So every stage is evaluated at its projection onto the loop constraints (``accel``:
the Gauss-Newton position and velocity projection of the steps, ``project``), as the in-house
engine evaluates its stages (``harness.engines.inhouse.projected_stages``, which says why: a
stage's velocity error c reads as a folding velocity c / theta near flat). Measured on
four_bar_chain at N = 40 over 20 s, largest error of every crank tip against the exact motion:
6.5e-6 / 2.0e-5 / 3.7e-6 m at 2 / 1 / 0.5 ms before, 3.2e-9 / 7.7e-10 / 2.3e-9 m with it, at 61 /
105 / 213 s a run instead of 19 / 36 / 71 s; over 0.2 s from the exact state at 8.5 s (a stage
1.3e-5 rad from flat at 1 ms) 7.1e-10 m before, 6.9e-13 m with it; N = 2 and 8 at 1 ms, 20 s:
2.5e-10 and 5.5e-9 m before, 1.7e-10 and 6.3e-9 m with it. The configuration rates of the
Lie-group stages stay those of the unprojected stage velocities. The projections' cut-off
(RCOND on the singular values of J L^-T) is 1e-20 of the largest Delassus eigenvalue, below
c theta^2 for |theta| > 4e-9 rad.

The Baumgarte corrector of the models is off (Kp = Kd = 0): drift is controlled by projection.

``constraintDynamics`` takes no external forces: the scene's prescribed point forces and point
springs (``forces.point_wrenches``: spatial forces in the local frame of the joint that moves the
body) enter ``tau`` as generalised forces ``sum_j J_j^T f_j`` with ``J_j`` the joint's ``LOCAL``
Jacobian; joint springs are already in ``tau`` (``forces.joint_force_function``).

Drift control (after every step of ``rkmk4`` or ``euler`` on the configuration Lie group, and once
at t = 0): the position residual e(q) (m, world, all rows) is removed by Gauss-Newton in the tangent
space, ``q <- integrate(q, dq)``, ``dq = argmin{ dq^T M dq : J dq = -e }`` (the mass-weighted
minimum-norm step, by a least-squares solve of ``J L^-T z = -e`` with M = L L^T from ``crba`` and
rcond ``RCOND``, which drops the redundant rows), until ``max|e| <= PROJECTION_TOL`` (1e-14) x the
distance of the farthest constraint point from the world origin, at least 1 m (the round-off of e
grows with it), at most ``MAX_PROJECTION_ITER`` Gauss-Newton steps (else the run fails); then the
velocity onto ``J v = 0`` the same way, ``v <- v - L^-T pinv(J L^-T) J v`` (the mass-weighted
projection: a perfectly inelastic impulse on the rows). The same choice as the in-house engine's
fixed-step methods; no Baumgarte terms inside Runge-Kutta stages.

Reactions. At each saved sample the multipliers of one more ``constraintDynamics`` solve give, per
cut joint, ``Trajectory.reactions[<loop name>] = (force_W, moment_W)``: the force (N, world) that
body_b (or the world) exerts on body_a through the cut joint, and its moment (N m, world) about
the joint point x_A. With ``LOCAL_WORLD_ALIGNED`` rows on x_A - x_B the generalised constraint
force is ``J^T lambda`` = lambda applied on body_a at the point and -lambda on body_b, so a ball's
force is its lambda and its moment 0 (so is a planar hinge's, stated by its joint point alone);
a hinge's force is lambda_1 + lambda_2 and its moment (x_A2 - x_A) x lambda_2 (x_A2: the second
point, hinge_span along the axis). Components in redundant directions (for a planar loop: the
out-of-plane force and the moments about in-plane axes) are statically indeterminate: they are the
proximal solver's minimum-norm choice (in-house: minimum norm over its own 5 hinge rows, so these
can differ); the determinate ones agree. Reactions of the tree's joints (``[checks.reaction]``)
are not computed on this path.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from harness.engines.base import RunSettings, sample_run
from harness.engines.pinocchio import linalg
from harness.engines.pinocchio.forces import (has_dampers, joint_force_function, joint_slots, point_spring_energy,
                                              point_wrenches, rnea_reactions, spring_energy)
from harness.engines.pinocchio.lie_group_integrators import stepper
from harness.engines.pinocchio.model import RUN_ERRORS, MaximalReader, advance_function, initial_configuration, load_urdf
from harness.measure.trajectory import Failure, RunStop, SampleBuffer, Trajectory
from harness.model.joints import JOINTS, ROTATIONAL, TRANSLATIONAL, keeps_axis, loop_kinds
from harness.model.multibody import LoopJoint, Multibody
from harness.model.rotations import cross

MU_RELATIVE = 1e-8  # proximal regularisation mu, relative to the largest diagonal entry of the Delassus matrix
CLOSURE_ACCURACY = 1e-15  # stop at |J a + gamma| <= this x (largest Delassus diagonal x force scale), m/s^2
MAX_PROXIMAL_ITER = 20
PROJECTION_TOL = 1e-14  # m per m of length scale (at least 1 m): closure residual left by the projection
MAX_PROJECTION_ITER = 8
RCOND = 1e-10  # relative cut-off of the singular values of J L^-T (redundant rows)
PARALLEL_TOL = 1e-15  # two unit axes are parallel when |a . b| >= 1 - PARALLEL_TOL (within 4.5e-8 rad)


def turns_about_axis_only(model: Multibody, loop: LoopJoint) -> bool:
    """Whether the tree lets ``loop``'s two bodies turn relative to each other only about the
    loop's hinge axis, so that its axis rows are implied by the tree and the joint point alone
    states the hinge (the module docstring). True when every joint on the tree path between
    ``body_a`` and ``body_b`` (the world for None) up to their common ancestor is a slide or a
    hinge whose axis is parallel to the loop's (``axis_A``, ``axis_B``) -- the body frames are
    parallel at zero configuration (``Body.p_PB_P``), so an axis stated in a body frame is also
    its world direction there, and rotations about one direction keep every such axis parallel
    at any configuration. A planar mechanism (all hinges about one direction) is the case."""
    n = np.asarray(loop.axis_A, float) / np.linalg.norm(loop.axis_A)
    if abs(float(np.dot(n, np.asarray(loop.axis_B, float) / np.linalg.norm(loop.axis_B)))) < 1.0 - PARALLEL_TOL:
        return False
    bodies = {b.name: b for b in model.bodies}

    def path(name):
        out = []
        while name is not None:
            out.append(name)
            name = bodies[name].parent
        return out

    up_a, up_b = path(loop.body_a), path(loop.body_b)
    common = next((name for name in up_a if name in up_b), None)
    for name in up_a[: up_a.index(common) if common else None] + up_b[: up_b.index(common) if common else None]:
        body = bodies[name]
        kind = JOINTS[body.joint].axis
        if kind == TRANSLATIONAL:
            continue
        axis = np.asarray(body.axis_B, float)
        if kind != ROTATIONAL or abs(float(np.dot(n, axis / np.linalg.norm(axis)))) < 1.0 - PARALLEL_TOL:
            return False
    return True


class LoopConstraints:
    """The cut joints of a scene as Pinocchio constraint models (module docstring).

    Attributes:
        models, datas: ``StdVec_RigidConstraintModel`` / ``StdVec_RigidConstraintData``, in the
            order of ``Multibody.loops``, one model per ball and per planar hinge
            (``turns_about_axis_only``), two per other hinge.
        items: per cut joint ``(loop, first model index, number of models)``.
        nc: number of constraint rows (3 per model).
    """

    def __init__(self, pmodel: pin.Model, ids: list[int], model: Multibody):
        index = {b.name: i for i, b in enumerate(model.bodies)}
        self.models = pin.StdVec_RigidConstraintModel()
        self.datas = pin.StdVec_RigidConstraintData()
        self.items = []
        for loop in model.loops:
            j1 = ids[index[loop.body_a]]
            j2 = 0 if loop.body_b is None else ids[index[loop.body_b]]
            p_A, p_B = np.asarray(loop.p_A, float), np.asarray(loop.p_B, float)
            points = [(p_A, p_B)]
            if keeps_axis(loop.kind) and not turns_about_axis_only(model, loop):
                span = float(loop.hinge_span)
                a_A = np.asarray(loop.axis_A, float) / np.linalg.norm(loop.axis_A)
                a_B = np.asarray(loop.axis_B, float) / np.linalg.norm(loop.axis_B)
                points.append((p_A + span * a_A, p_B + span * a_B))
            elif loop.kind not in loop_kinds():
                raise NotImplementedError(f"loop joint {loop.name!r}: kind {loop.kind!r} (known: {', '.join(loop_kinds())})")
            self.items.append((loop, len(self.models), len(points)))
            for k, (x1, x2) in enumerate(points):
                cm = pin.RigidConstraintModel(pin.ContactType.CONTACT_3D, pmodel, j1, pin.SE3(np.eye(3), x1),
                                              j2, pin.SE3(np.eye(3), x2), pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
                cm.name = f"{loop.name}" if k == 0 else f"{loop.name}_2"
                self.models.append(cm)
                self.datas.append(cm.createData())
        self.nc = 3 * len(self.models)
        #: (model, data) per constraint model: Python references to the elements of ``models`` and
        #: ``datas`` (iterating the Pinocchio vectors again costs ~8 us per element)
        self.pairs = list(zip(self.models, self.datas))
        #: ``(model index, joint id, first)``: the ends of the constraint models on a moving
        #: joint (joint1 then joint2 of each model; ``first``: joint1)
        self.ends = [(k, jid, end == 1) for k, cm in enumerate(self.models)
                     for end, jid in ((1, cm.joint1_id), (2, cm.joint2_id)) if jid != 0]

    def rows(self, pmodel: pin.Model, data: pin.Data, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Position residual e (nc,) m, world (x_1 - x_2 = -R_1 c1Mc2.translation per model) and
        its Jacobian J (nc, nv) at configuration q (``computeJointJacobians``,
        ``RigidConstraintModel.calc``, ``getConstraintsJacobian``). ``length()`` then gives the
        length scale of the residual's round-off at q."""
        pin.computeJointJacobians(pmodel, data, q)
        e = np.empty(self.nc)
        for k, (cm, cd) in enumerate(self.pairs):
            cm.calc(pmodel, data, cd)
            e[3 * k : 3 * k + 3] = -cd.oMc1.rotation @ cd.c1Mc2.translation
        return e, pin.getConstraintsJacobian(pmodel, data, self.models, self.datas)

    def length(self) -> float:
        """The length scale (m) of the residual's round-off: the largest distance of a constraint
        point from the world origin, at least 1 m, at the configuration of the last ``rows``."""
        sq = 1.0  # the largest squared distance (m^2), at least 1
        for _, cd in self.pairs:
            x1, x2 = cd.oMc1.translation, cd.oMc2.translation
            sq = max(sq, float(x1.dot(x1)), float(x2.dot(x2)))
        return math.sqrt(sq)  # sqrt(x.x) is np.linalg.norm(x), and sqrt is monotonic: the same number

    def reactions(self, lam: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """Per cut joint, (force N, moment N m about the joint point), world, on body_a, from the
        multipliers ``lam`` (nc,) of ``constraintDynamics`` (module docstring). Needs the
        constraint datas of the same solve."""
        out = {}
        for loop, first, count in self.items:
            force = np.zeros(3)
            moment = np.zeros(3)
            x0 = np.array(self.pairs[first][1].oMc1.translation)
            for k in range(first, first + count):
                f = lam[3 * k : 3 * k + 3]
                force += f
                moment += cross(np.array(self.pairs[k][1].oMc1.translation) - x0, f)
            out[loop.name] = (force, moment)
        return out


def tree_reactions(pmodel: pin.Model, rdata: pin.Data, jointed, tau: np.ndarray, wrenches: dict,
                   constraints: LoopConstraints, lam: np.ndarray, q: np.ndarray, v: np.ndarray,
                   a: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The reactions of the tree's joints ``jointed`` (``(name, joint id)``) at (q, v) with the
    constrained acceleration ``a``: ``forces.rnea_reactions`` (``rnea``) with the joint-space
    forces ``tau``, and as ``fext`` the scene's applied point forces ``wrenches`` (joint id ->
    spatial force [f; m] in the joint's local frame, ``forces.point_wrenches``) with each
    constraint model's force added (``lam[3k:3k+3]``, world axes, on joint1 at its point, the
    opposite on joint2). Force (N) and moment about the joint origin (N m), world, that the parent
    exerts on the child."""
    pin.forwardKinematics(pmodel, rdata, q)
    fext = dict(wrenches)
    placements = {}
    for k, jid, first in constraints.ends:
        cd = constraints.pairs[k][1]
        f_W = lam[3 * k : 3 * k + 3]
        x_W = (cd.oMc1 if first else cd.oMc2).translation
        if jid not in placements:
            oMi = rdata.oMi[jid]
            placements[jid] = (oMi.rotation.T, oMi.translation)
        Rt, o = placements[jid]
        f_L = Rt @ (f_W if first else -f_W)
        w = np.concatenate((f_L, cross(Rt @ (x_W - o), f_L)))
        fext[jid] = w if jid not in fext else fext[jid] + w
    forces = [pin.Force.Zero() for _ in range(pmodel.njoints)]
    for jid, w in fext.items():
        forces[jid] = pin.Force(w)
    return rnea_reactions(pmodel, rdata, jointed, tau, forces, q, v, a)


def _baumgarte_off(constraints: LoopConstraints) -> None:
    """Set every model's Baumgarte gains to zero (Pinocchio's default, made explicit)."""
    for cm in constraints.models:
        bp = cm.m_baumgarte_parameters
        bp.Kp, bp.Kd = 0.0, 0.0
        cm.setBaumgarteCorrectorParameters(bp)


def _external_torque(pmodel: pin.Model, data: pin.Data, wrenches: dict) -> np.ndarray:
    """Generalised force (nv,) of the spatial forces ``wrenches`` (joint id -> [f; m] in the
    joint's local frame): ``sum_j J_j^T f_j`` over the joints in increasing order, with ``J_j`` the
    joint's LOCAL Jacobian (``computeJointJacobians`` at q must have run on ``data``)."""
    tau = np.zeros(pmodel.nv)
    for jid in sorted(wrenches):
        tau += pin.getJointJacobian(pmodel, data, jid, pin.ReferenceFrame.LOCAL).T @ wrenches[jid]
    return tau


def force_scale(model: Multibody) -> float:
    """Force scale (N) of the proximal stopping criterion: the total weight M |g|, at least 1 N."""
    return max(model.total_mass * float(np.linalg.norm(model.gravity_W)), 1.0)


def proximal_settings(pmodel: pin.Model, data: pin.Data, q: np.ndarray, constraints: LoopConstraints,
                      model: Multibody) -> pin.ProximalSettings:
    """``ProximalSettings(absolute accuracy 0, relative accuracy, mu, MAX_PROXIMAL_ITER)``
    (module docstring). With ``d`` the largest diagonal entry of the Delassus matrix at q (1/kg
    for point rows; ``pin.computeDelassusMatrix``): ``mu = MU_RELATIVE d`` (1/kg), and the
    relative accuracy (N, on the change of the multipliers between proximal iterations) is
    ``CLOSURE_ACCURACY d force_scale / mu``: the change times mu is the loops' acceleration
    residual ``|J a + gamma|`` of the iterate (m/s^2), so this stops at ``CLOSURE_ACCURACY`` times
    the acceleration scale ``d force_scale`` whatever mu is. Also ``initConstraintDynamics``."""
    pin.initConstraintDynamics(pmodel, data, constraints.models, constraints.datas)
    delassus = pin.computeDelassusMatrix(pmodel, data, q, constraints.models, constraints.datas, 0.0)
    scale = float(np.max(np.abs(np.diag(delassus)), initial=0.0))
    if not (np.isfinite(scale) and scale > 0.0):
        raise RunStop(Failure.SINGULAR, "the loop constraints' Delassus matrix is zero or not finite at the initial state")
    mu = MU_RELATIVE * scale
    return pin.ProximalSettings(0.0, CLOSURE_ACCURACY * scale * force_scale(model) / mu, mu, MAX_PROXIMAL_ITER)


def simulate_loops(engine, scene, settings: RunSettings, model: Multibody) -> Trajectory:
    """Run a scene with cut joints in Pinocchio (module docstring); the trajectory carries each cut
    joint's reaction on body_a in ``reactions[<loop name>]``."""
    pmodel, ids = load_urdf(scene.urdf, scene.urdf_root_joint, model)
    data = pmodel.createData()
    fdata = pmodel.createData()  # kinematics of the applied forces, apart from the solver's data
    q, v = initial_configuration(pmodel, ids, model)
    constraints = LoopConstraints(pmodel, ids, model)
    _baumgarte_off(constraints)
    joint_forces = joint_force_function(pmodel, ids, model)
    wrenches = point_wrenches(pmodel, fdata, ids, model)
    damped = has_dampers(model)

    def applied(t, q, v):
        """The joint-space forces (nv,) and the point forces' wrenches per joint ({} without)."""
        tau = joint_forces(q, v)
        if wrenches is None:
            return tau, {}
        pin.computeJointJacobians(pmodel, fdata, q)  # the placements oMi, and the Jacobians of _external_torque
        if damped:  # the joints' velocities data.v, which the dampers read (oMi as above)
            pin.forwardKinematics(pmodel, fdata, q, v)
        return tau, wrenches(t)
    slots = joint_slots(pmodel, ids, model)
    counters = {"rhs_evals": 0, "prox_iter_max": 0, "prox_unconverged": 0, "projection_iter_max": 0}
    step = stepper(settings.integrator, pmodel)
    h, per = settings.dt, settings.steps_per_save
    jointed = ([(b.name, ids[i]) for i, b in enumerate(model.bodies) if JOINTS[b.joint].constrained]
               if "reaction" in scene.checks else [])
    buf = SampleBuffer(settings.n_saves + 1, len(ids), [loop.name for loop in model.loops] + [name for name, _ in jointed])
    reader = MaximalReader(pmodel, data, ids, buf)
    rdata = pmodel.createData()
    prox = None

    def solve(t, q, v, forces=None):
        tau, fext = forces or applied(t, q, v)
        if fext:
            tau = tau + _external_torque(pmodel, fdata, fext)
        a = pin.constraintDynamics(pmodel, data, q, v, tau, constraints.models, constraints.datas, prox)
        it = prox.iter
        if it > counters["prox_iter_max"]:
            counters["prox_iter_max"] = it
        if it >= prox.max_iter:
            counters["prox_unconverged"] += 1
        return a.copy()

    def accel(t, q, v):
        """The accelerations of a Runge-Kutta stage, evaluated at its projection onto the loop
        constraints (module docstring: singular positions)."""
        counters["rhs_evals"] += 1
        return solve(t, *project(q, v))

    def project(q, v):
        for it in range(MAX_PROJECTION_ITER + 1):
            e, J = constraints.rows(pmodel, data, q)
            L = linalg.cholesky(pin.crba(pmodel, data, q).T)  # M = L L^T (lower triangle of M^T: M's upper one)
            A = linalg.solve(L, J.T).T  # J L^-T
            err = float(np.abs(e).max())
            if not math.isfinite(err):
                raise RunStop(Failure.NON_FINITE, "non-finite loop-closure residual")
            if err <= PROJECTION_TOL or err <= PROJECTION_TOL * constraints.length():  # length() >= 1 m
                break
            if it == MAX_PROJECTION_ITER:
                raise RunStop(Failure.PROJECTION, f"position projection did not converge (closure residual {err:.3e} m)")
            z = linalg.lstsq(A, -e, RCOND)
            q = pin.integrate(pmodel, q, linalg.solve(L.T, z))
        if it > counters["projection_iter_max"]:
            counters["projection_iter_max"] = it
        z = linalg.lstsq(A, J @ v, RCOND)
        return q, v - linalg.solve(L.T, z)

    state = [q, v]

    advance = advance_function(state, step, accel, h, per, project)

    def read(k: int) -> None:
        nonlocal prox
        if k == 0:
            prox = proximal_settings(pmodel, data, state[0], constraints, model)
            state[:] = project(*state)
        q, v = state
        t = k * per * h
        forces = applied(t, q, v)
        a = solve(t, q, v, forces)  # the multipliers at the sample (data.lambda_c)
        lam = np.array(data.lambda_c)
        for name, (force, moment) in constraints.reactions(lam).items():
            buf.set_reaction(name, k, force, moment)
        if jointed:  # the tree's joints: rnea at the constrained acceleration, cut forces as fext
            for name, fm in tree_reactions(pmodel, rdata, jointed, *forces, constraints, lam, q, v, a).items():
                buf.set_reaction(name, k, *fm)
        reader.read(q, v, k)
        buf.kinetic[k] = pin.computeKineticEnergy(pmodel, data, q, v)
        buf.potential[k] = (pin.computePotentialEnergy(pmodel, data, q) + spring_energy(slots, q)
                            + point_spring_energy(pmodel, data, ids, model, q))

    done = sample_run(settings, buf, advance, read, RUN_ERRORS)
    saved = done.saved
    reader.finish(saved)
    mu = prox.mu if prox is not None else float("nan")
    acc = prox.relative_accuracy if prox is not None else float("nan")
    two_point = [lp for lp, _, n in constraints.items if n == 2]
    one_point = sum(1 for lp, _, n in constraints.items if n == 1 and keeps_axis(lp.kind))
    hinges = "; ".join(x for x in (
        f"{one_point} planar hinge{'s' if one_point != 1 else ''} (turning only about the axis): 1 point" if one_point else "",
        f"other hinges: 2 points {'/'.join(f'{lp.hinge_span:g}' for lp in two_point)} m apart on the axis" if two_point else "",
    ) if x) or "no hinge"
    stats = {"steps": max(saved - 1, 0) * per, "rhs_evals": counters["rhs_evals"], "wall_s": done.wall_s,
             "prox_iter_max": counters["prox_iter_max"], "prox_unconverged": counters["prox_unconverged"],
             "projection_iter_max": counters["projection_iter_max"],
             "settings": f"constraintDynamics (proximal KKT) with RigidConstraintModel CONTACT_3D rows in "
                         f"LOCAL_WORLD_ALIGNED (ball: 1 point; {hinges}), "
                         f"mu {mu:.3g} ({MU_RELATIVE:g} of the Delassus diagonal), relative accuracy {acc:.3g} N "
                         f"(loop acceleration residual {acc * mu:.2g} m/s^2), "
                         f"max_iter {MAX_PROXIMAL_ITER}, Baumgarte off; {settings.integrator} on the configuration Lie group, "
                         f"step {h:g} s; drift: Gauss-Newton position projection (tol {PROJECTION_TOL:g} m per m, "
                         f"at least 1 m) then "
                         f"velocity projection after each step and at each Runge-Kutta stage, mass-weighted; "
                         f"root joint {scene.urdf_root_joint}"}
    return buf.trajectory(engine.name, settings.integrator, [b.name for b in model.bodies], settings.save_every,
                          saved, stats, done.reason, done.message)
