"""Pinocchio with rolling contacts: rolling without slip imposed through Pinocchio's constrained
forward dynamics with our own constraint Jacobian and drift, on a free-flyer (the rolling disk)
or on a body jointed to the world (the rolling cone's spherical apex).

``pin.forwardDynamics(model, data, q, v, tau, J, gamma, damping)`` (still in Pinocchio 4.1, no
deprecation warning; it calls ``computeAllTerms`` and solves the KKT system
``[M J^T; J 0] [a; -lambda] = [tau - b; -gamma]``) returns the acceleration with
``J a + gamma = 0`` and leaves the multipliers in ``data.lambda_c``: ``J^T lambda`` is the
constraint's generalised force.

Rows. The rolling body's joint frame moves with the spatial velocity [v_O (linear velocity of
the joint origin O), w (angular velocity)], both in the local frame, ``J_j v`` with J_j the
joint's LOCAL Jacobian (``getJointJacobian``; for a free-flyer root the identity on its own
columns), and the spatial acceleration ``J_j a + a_b`` (a_b: ``data.a`` at zero joint
acceleration, zero for a free-flyer or spherical root). With p the contact point C in the body
frame (from O: the centre of mass lever plus R^T r_AC, ``harness.model.rolling_contact``; p moves
around the rim at the body-frame rate p') the world velocity of the material point at C and its
derivative are::

    v_C = R (v_O + w x p) = R (J_lin - [p]x J_ang) v = J v                          (3 rows)
    d v_C/dt = J a + gamma,  gamma = R (a_b,lin + a_b,ang x p + w x (v_O + w x p) + w x p')
    p' = R^T (r_AC' - w_W x r_AC)          (r_AC' = ``contact_offset_rate``, world)

(the classical acceleration of a body point from the spatial one gives the w x (v_O + w x p)
term; the last is d(w x p)/dt at fixed w.) Rows x, y: no slip (nonholonomic); row z: the height
of C (holonomic, z_C = 0). So ``J^T lambda`` is the force lambda (N, world) at C: it is
reported as the contact force.

Any body of the tree may roll (a bicycle's front wheel, three joints from its free rear frame):
its joint Jacobian carries the whole chain. Dependent rows. On a body the world holds through
joints alone (``harness.model.rolling_contact.dependent_rows``), a rim row can repeat the joint:
a cone held at its apex has apex and contact point at rest, and two points of a rigid body have
equal velocities along the line joining them, so the no-slip row along the contact generator is
implied. ``RollingRows.independent`` then reduces the rows to an independent set (SVD of J,
``RANK_RTOL``) before ``forwardDynamics`` (whose KKT solve needs independent rows) and the
velocity projection; the contact force is the minimum-norm one (its component along the
repeated row is left to the joint: statically indeterminate, ``models/rolling_cone/README.md``).

Drift control: after every step (``rkmk4`` or ``euler`` on the configuration Lie group,
``lie_group_integrators``) the state is projected: the height row by Gauss-Newton in the tangent
space, ``q <- integrate(q, -M^-1 J_z^T (J_z M^-1 J_z^T)^-1 z_C)``, then the velocity onto
``J v = 0``, ``v <- v - M^-1 J^T (J M^-1 J^T)^-1 J v`` (mass-weighted, M from ``crba``): the same
choice as the in-house engine's fixed-step methods (Baumgarte terms inside Runge-Kutta stages
cost accuracy there). ``damping`` (the KKT regularisation) is 0.

Joint reactions of the rolling model's jointed bodies (a rolling body's children, or a rolling
body on a joint; when the scene asks, ``[checks.reaction]``): ``rnea`` at (q, v, a) with a from
the constrained forward dynamics and the contact forces lambda as external forces
(``fext``: lambda at C, about each rolling body's joint origin, in its local frame) leaves in
``data.f[j]`` the spatial force the parent exerts on the subtree of joint j (as in
``harness.engines.pinocchio.forces``), rotated to world.
"""

from __future__ import annotations


import numpy as np
import pinocchio as pin

from harness.engines.base import RunSettings, sample_run
from harness.engines.pinocchio import linalg
from harness.engines.pinocchio.forces import rnea_reactions
from harness.engines.pinocchio.lie_group_integrators import stepper
from harness.engines.pinocchio.model import (RUN_ERRORS, MaximalReader, advance_function, configuration,
                                             initial_configuration, load_urdf, maximal_accelerations)
from harness.model.joints import JOINTS
from harness.model.rotations import cross
from harness.model.rolling_contact import FLAT, dependent_rows, offset_and_rate
from harness.measure.trajectory import Failure, RunStop, SampleBuffer, Trajectory

PROJECTION_TOL = 1e-13  # m, height error left by the position projection
MAX_PROJECTION_ITER = 8
RANK_RTOL = 1e-10  # singular values of the rolling rows below this fraction of the largest: dependent rows


def _cross(a, b) -> tuple[float, float, float]:
    """``a x b`` of two 3-sequences of floats (the products and differences of ``np.cross``)."""
    a0, a1, a2 = a
    b0, b1, b2 = b
    return (a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0)


def _add(a, b) -> tuple[float, float, float]:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def _sub(a, b) -> tuple[float, float, float]:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


class RollingRows:
    """The rolling rows of one model: ``rows(q, v) -> (C, J, gamma)`` for all its contacts."""

    def __init__(self, pmodel: pin.Model, data: pin.Data, ids: list[int], model):
        self.pmodel, self.data = pmodel, data
        index = {b.name: i for i, b in enumerate(model.bodies)}
        self.items = []
        for c in model.contacts:
            jid = ids[index[c.body]]
            self.items.append((c, jid, np.array(pmodel.inertias[jid].lever)))
        self.nc = 3 * len(self.items)
        #: A rolling body the world holds through joints: its rows may repeat the joints' (module
        #: docstring), so the rows are reduced to an independent set (``independent``).
        self.redundant = dependent_rows(model)
        self._a0 = np.zeros(pmodel.nv)

    def rows(self, q: np.ndarray, v: np.ndarray | None, heights: bool = True):
        """Height errors C (nc,) m (0 on the no-slip rows; all 0 without ``heights``), Jacobian J
        (nc, nv) and the bias gamma (nc,) (None when ``v`` is None). Runs the kinematics it needs
        itself (placements and joint Jacobians at q; with ``v``, velocities and the bias
        accelerations at zero joint acceleration), leaving them in ``data``."""
        pmodel, data = self.pmodel, self.data
        C = np.zeros(self.nc)
        J = np.zeros((self.nc, pmodel.nv))
        gamma = None if v is None else np.zeros(self.nc)
        if v is not None:  # the joints' bias accelerations (data.a at zero joint acceleration)
            pin.forwardKinematics(pmodel, data, q, v, self._a0)
        pin.computeJointJacobians(pmodel, data, q)
        for k, (c, jid, lever) in enumerate(self.items):
            oMi = data.oMi[jid]
            R = oMi.rotation
            if v is not None:
                vel, acc = data.v[jid], data.a[jid]  # views into data, read before the next kinematics
                w, v_O = vel.angular, vel.linear
                w_W = R @ w
            r_W, r_dot, s = offset_and_rate(R, None if v is None else w_W, c.radius, c.half_thickness, c.circle_z)
            if s < FLAT:
                raise RunStop(Failure.SINGULAR, f"rolling contact {c.name!r}: the disk lies flat, the contact point is undefined")
            p = lever + R.T @ r_W
            rows = slice(3 * k, 3 * k + 3)
            if heights:
                C[3 * k + 2] = oMi.translation[2] + R[2] @ p
            J_local = pin.getJointJacobian(pmodel, data, jid, pin.LOCAL)  # [v_O; w] of the joint frame, local
            J[rows] = R @ (J_local[:3] - pin.skew(p) @ J_local[3:])
            if v is not None:
                # the elementwise parts in Python floats (the same IEEE operations, in the same
                # order, as on 3-arrays), the products with R in NumPy
                w_ = w.tolist()
                p_dot = R.T @ np.array(_sub(r_dot.tolist(), _cross(w_W.tolist(), r_W.tolist())))
                p_ = p.tolist()
                bias = _add(acc.linear.tolist(), _cross(acc.angular.tolist(), p_))
                arg = _add(_add(bias, _cross(w_, _add(v_O.tolist(), _cross(w_, p_)))), _cross(w_, p_dot.tolist()))
                gamma[rows] = R @ np.array(arg)
        return C, J, gamma

    def independent(self, J: np.ndarray, gamma: np.ndarray | None):
        """``(J', gamma', U)``: the rows reduced to an independent set when the model is
        ``redundant`` (``J' = U^T J``, U (nc, r) an orthonormal basis of J's column space from its
        SVD, singular values below ``RANK_RTOL`` of the largest dropped), so that the contact force
        is ``U lambda'`` (the minimum-norm force; its component along a repeated row is left to
        the joint); ``(J, gamma, None)`` otherwise."""
        if not self.redundant:
            return J, gamma, None
        U, sv = linalg.svd_u(J)
        U = U[:, sv > RANK_RTOL * sv[0]]
        return U.T @ J, None if gamma is None else U.T @ gamma, U

    def external_forces(self, lam: np.ndarray) -> list:
        """``fext`` per joint for ``rnea``: contact k's force lambda_k (N, world) at its contact
        point, as a spatial force about its joint's origin in the joint's local frame. Needs
        ``forwardKinematics`` at the state of ``lam``."""
        fext = [pin.Force.Zero() for _ in range(self.pmodel.njoints)]
        for k, (c, jid, lever) in enumerate(self.items):
            R = self.data.oMi[jid].rotation
            r_W, _, _ = offset_and_rate(R, None, c.radius, c.half_thickness, c.circle_z)
            p = lever + R.T @ r_W  # contact point from the joint origin, local frame
            f = R.T @ lam[3 * k : 3 * k + 3]
            fext[jid] = fext[jid] + pin.Force(f, cross(p, f))
        return fext


def joint_reactions(pmodel: pin.Model, data: pin.Data, rolling: RollingRows, jointed, q, v, a, lam):
    """Per ``(name, joint id)`` of ``jointed``: the force (N) and moment about the joint origin
    (N m), world, that the parent exerts on the joint's child (module docstring):
    ``forces.rnea_reactions`` at the constrained acceleration ``a`` with the contact forces as
    ``fext`` (no joint is actuated: ``tau`` zero)."""
    pin.forwardKinematics(pmodel, data, q, v)
    fext = rolling.external_forces(lam)
    return rnea_reactions(pmodel, data, jointed, np.zeros(pmodel.nv), fext, q, v, a)


def rolling_accelerations(scene, model, q_common, v_common) -> tuple[dict, dict]:
    """Each body's centre-of-mass and angular accelerations (world; ``maximal_accelerations``)
    at joint coordinates ``q_common, v_common`` (per body name) of a scene with rolling contacts:
    ``forwardDynamics`` with the rolling rows (module docstring), as a run's right-hand side."""
    pmodel, ids = load_urdf(scene.urdf, scene.urdf_root_joint, model)
    data = pmodel.createData()
    q, v = configuration(pmodel, ids, model, q_common, v_common)
    rolling = RollingRows(pmodel, data, ids, model)
    J, gamma, _ = rolling.independent(*rolling.rows(q, v, heights=False)[1:])
    a = pin.forwardDynamics(pmodel, data, q, v, np.zeros(pmodel.nv), J, gamma, 0.0).copy()
    return maximal_accelerations(pmodel, data, ids, [b.name for b in model.bodies], q, v, a)


def simulate_rolling(engine, scene, settings: RunSettings, model) -> Trajectory:
    """Run a scene with rolling contacts in Pinocchio (module docstring); the trajectory carries
    the contact force of each contact in ``reactions[<contact name>]``."""

    pmodel, ids = load_urdf(scene.urdf, scene.urdf_root_joint, model)
    data = pmodel.createData()
    q, v = initial_configuration(pmodel, ids, model)
    rolling = RollingRows(pmodel, data, ids, model)
    tau = np.zeros(pmodel.nv)
    jointed = ([(b.name, jid) for b, jid in zip(model.bodies, ids) if JOINTS[b.joint].constrained]
               if "reaction" in scene.checks else [])

    def solve(q, v):
        J, gamma, U = rolling.independent(*rolling.rows(q, v)[1:])
        a = pin.forwardDynamics(pmodel, data, q, v, tau, J, gamma, 0.0)
        lam = np.array(data.lambda_c)
        return a.copy(), lam if U is None else U @ lam

    def accel(t, q, v):
        J, gamma, U = rolling.independent(*rolling.rows(q, v, heights=False)[1:])
        return pin.forwardDynamics(pmodel, data, q, v, tau, J, gamma, 0.0).copy()

    z = slice(2, rolling.nc, 3)  # the height rows

    def project(q, v):
        for _ in range(MAX_PROJECTION_ITER):
            C, J, _ = rolling.rows(q, None)
            Minv_JT = linalg.solve(linalg.symmetric_from_upper(pin.crba(pmodel, data, q)), J.T)
            err = float(np.abs(C).max())
            if err <= PROJECTION_TOL:
                break
            dq = -Minv_JT[:, z] @ linalg.solve(J[z] @ Minv_JT[:, z], C[z])
            q = pin.integrate(pmodel, q, dq)
        else:
            raise RunStop(Failure.PROJECTION, f"position projection did not converge (height error {err:.3e} m)")
        J, _, U = rolling.independent(J, None)
        if U is not None:
            Minv_JT = Minv_JT @ U
        v = v - Minv_JT @ linalg.solve(J @ Minv_JT, J @ v)
        return q, v

    step = stepper(settings.integrator, pmodel)
    h, per = settings.dt, settings.steps_per_save
    # the joints' reactions, and each contact's force at the contact point (no moment about it)
    buf = SampleBuffer(settings.n_saves + 1, len(ids), [name for name, _ in jointed] + [c.name for c in model.contacts])
    reader = MaximalReader(pmodel, data, ids, buf)
    state = [q, v]

    advance = advance_function(state, step, accel, h, per, project)

    def read(k: int) -> None:
        if k == 0:
            state[:] = project(*state)
        q, v = state
        reader.read(q, v, k)
        buf.kinetic[k] = pin.computeKineticEnergy(pmodel, data, q, v)
        buf.potential[k] = pin.computePotentialEnergy(pmodel, data, q)
        a, lam = solve(q, v)
        for j, (c, _, _) in enumerate(rolling.items):
            buf.set_reaction(c.name, k, lam[3 * j : 3 * j + 3], np.zeros(3))
        if jointed:
            for name, (f, mo) in joint_reactions(pmodel, data, rolling, jointed, q, v, a, lam).items():
                buf.set_reaction(name, k, f, mo)

    done = sample_run(settings, buf, advance, read, RUN_ERRORS)
    saved = done.saved
    reader.finish(saved)
    stats = {"steps": max(saved - 1, 0) * per, "wall_s": done.wall_s,
             "settings": f"forwardDynamics (KKT) with the rolling rows, {settings.integrator} on the configuration "
                         f"Lie group, step {h:g} s, projection after each step, root joint {scene.urdf_root_joint}"}
    return buf.trajectory(engine.name, settings.integrator, [b.name for b in model.bodies], settings.save_every,
                          saved, stats, done.reason, done.message)
