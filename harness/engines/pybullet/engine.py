"""PyBullet engine: the scene's URDF as a Bullet ``btMultiBody`` (Featherstone, reduced
coordinates), stepped by ``p.stepSimulation`` at the run's fixed step.

The integrator is PyBullet's only one, and it is first order: each ``stepSimulation`` computes
the joint accelerations at the current state (the articulated-body algorithm, gyroscopic terms
included), updates the joint velocities with them and then the positions with the *new*
velocities (semi-implicit, or symplectic, Euler; a ball joint's and the floating base's
orientation by the exponential map of the new angular velocity). Its constraint solver
(sequential impulses, ``numSolverIterations`` 50) runs every step but has nothing to solve here:
no contact (no collision shapes), no joint limit, the joint motors switched off
(``harness.engines.pybullet.model``). So the error falls as dt^1 (``Integrator.order`` 1).

Forces: gravity (``setGravity``); a joint spring (``JointSpring``, the spring pendulum) has no
PyBullet element and is applied as the joint's generalised force ``-k (q - q_ref)`` at the start
of every step (``TORQUE_CONTROL``, which PyBullet applies for that step only), as the step's
other forces are; a spring between body points with its damper (``PointSpring``, the flyball
governor) has none either and is applied the same way, as the pair of world forces
``-+(k (L - L0) + c L') d / L`` at its two end points (``applyExternalForce`` in the world frame,
for that step only), from the links' states at the step's start (``getLinkStates``: centre of
mass, orientation, velocities; ``_point_spring_forces``). Not modelled, run as "unsupported" with
the reason (``harness.engines.pybullet.model.check_supported``): loop joints, rolling contact,
prescribed point forces and joint torques.

Maximal coordinates at every saved sample: each body's inertial frame (centre of mass, world
position, orientation, velocity and angular velocity; ``getBasePositionAndOrientation``,
``getBaseVelocity`` for a floating base, ``getLinkStates`` with ``computeLinkVelocity``), its
body frame orientation from the inertial frame's orientation in it. PyBullet reports no system
energy (the harness computes it from these). Joint reactions (``[checks.reaction]``): its joint
force-torque sensors (``_reaction``), less the velocity-product wrench Bullet's second
(constraint-solver) pass adds to them (``harness.engines.pybullet.reactions``, ``_sensor_extra``).
"""

from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np

from harness.engines.base import EngineBase, Integrator, RunSettings, integrator_table, sample_run
from harness.engines.pybullet.model import MAX_JOINT_VELOCITY, Server, build, pybullet_module
from harness.engines.pybullet.reactions import constraint_pass_wrenches
from harness.measure.trajectory import Failure, RunStop, SampleBuffer, Trajectory, unsupported
from harness.model import rotations
from harness.model.joints import BALL, JOINTS, TRANSLATIONAL
from harness.model.scene import Scene

#: Substeps of ``semi_implicit_euler_16``: PyBullet stepped at dt / 16, 16 steps per step of the run.
SUBSTEPS = 16
#: PyBullet steps per step of the run, per integrator.
STEPS_PER_STEP = {"semi_implicit_euler": 1, f"semi_implicit_euler_{SUBSTEPS}": SUBSTEPS}

METHODS = integrator_table(
    Integrator("semi_implicit_euler", "fixed", 1, 1,
               "PyBullet stepSimulation: semi-implicit (symplectic) Euler on the btMultiBody's joint coordinates, "
               "order 1; its sequential-impulse constraint solver idle (no contact, limits or motors)"),
    Integrator(f"semi_implicit_euler_{SUBSTEPS}", "fixed", 1, SUBSTEPS,
               f"the same, stepped at dt/{SUBSTEPS} ({SUBSTEPS} steps per step of the run, as PyBullet users set a "
               "smaller fixedTimeStep or numSubSteps): order 1 in dt, its error 16 times smaller"),
)


class PyBulletEngine(EngineBase):
    """Runs a scene in PyBullet from its URDF file."""

    name = "pybullet"
    integrators = METHODS

    def load_model_file(self, scene: Scene, model) -> None:
        """Load the scene's URDF into a PyBullet server as a run does (``read_urdf``): InputError
        where PyBullet cannot, NotImplementedError for a scene that names only an MJCF
        (``harness.engines.load_model_file``)."""
        from harness.engines.pybullet.model import read_urdf

        with Server() as client:
            read_urdf(scene.urdf, scene.urdf_root_joint, client)

    def run(self, scene: Scene, settings: RunSettings) -> Trajectory:
        p = pybullet_module()

        model = scene.multibody()
        names = tuple(model.body_names)
        method = settings.integrator
        start = time.perf_counter()
        sub = STEPS_PER_STEP[method]
        with Server() as client:
            try:
                pm = build(scene, model, client, settings.dt / sub)
            except NotImplementedError as err:
                return unsupported(self.name, method, names, f"{method}: {err}")
            jointed = [b for b in model.bodies if pm.links[b.name] >= 0] if "reaction" in scene.checks else []
            buf = SampleBuffer(settings.n_saves + 1, len(names), [b.name for b in jointed])
            for b in jointed:
                p.enableJointForceTorqueSensor(pm.body, pm.links[b.name], 1, physicsClientId=client)
            axes = _joint_axes(pm, model) if jointed else {}

            spring_forces = _point_spring_forces(pm, model) if pm.point_springs else None

            def step(count: int) -> None:
                for _ in range(count):
                    for link, stiffness, q_ref in pm.springs:  # the spring's force at the step's start
                        q = p.getJointState(pm.body, link, physicsClientId=client)[0]
                        p.setJointMotorControl2(pm.body, link, p.TORQUE_CONTROL, force=-stiffness * (q - q_ref),
                                                physicsClientId=client)
                    if spring_forces is not None:
                        spring_forces()
                    p.stepSimulation(physicsClientId=client)

            def advance(k: int) -> None:  # with reactions, the interval's first step was taken to read sample k - 1's
                step(settings.steps_per_save * sub - (1 if jointed else 0))

            def read(k: int) -> None:
                _read(pm, model, k, buf)
                if jointed:  # the sensors hold the reactions of the accelerations a step computes at its start
                    step(1)
                    extra = _sensor_extra(pm, model, k, buf, axes)
                    for b in jointed:
                        buf.set_reaction(b.name, k, *_reaction(pm, model, b, k, buf, extra[b.name]))

            done = sample_run(settings, buf, advance, read)
            solver = p.getPhysicsEngineParameters(physicsClientId=client)
        saved = done.saved
        stats = {"steps": max(saved - 1, 0) * settings.steps_per_save * sub + (1 if jointed and saved else 0),
                 "wall_s": time.perf_counter() - start, "wall_integrate_s": done.wall_s,
                 "settings": _describe(settings, scene, pm, solver, sub)}
        traj = buf.trajectory(self.name, method, names, settings.save_every, saved, stats, done.reason, done.message)
        return replace(traj, engine_energy={})  # PyBullet reports no system energy


def _reaction(pm, model, body, k: int, buf: SampleBuffer, extra) -> tuple[np.ndarray, np.ndarray]:
    """``(force_W, moment_W)`` (N, N m) of ``body``'s joint at sample ``k``: PyBullet's joint
    force-torque sensor (``enableJointForceTorqueSensor``; ``getJointState``'s reaction
    ``[Fx, Fy, Fz, Mx, My, Mz]``: the force of the parent on the child, in the child's inertial
    frame, the moment about its centre of mass) turned to world and its moment taken about the
    joint point, less ``extra`` (the wrench Bullet's second, constraint-solver pass adds to the
    sensor: ``harness.engines.pybullet.reactions``), without the component along a hinge's or
    slide's free direction (the joint spring's force, which an ideal joint's reaction has none
    of). Read after the step that follows the sample: the sensor holds the articulated-body
    solve at that step's start state, the sample's."""
    p = pybullet_module()

    i = model.body_names.index(body.name)
    F = np.asarray(p.getJointState(pm.body, pm.links[body.name], physicsClientId=pm.client)[2], dtype=float)
    R_WB = rotations.matrix(buf.quat_WB[k, i])
    R_WI = R_WB @ pm.R_BI[body.name]
    f, m = R_WI @ F[:3], R_WI @ F[3:]
    m = m + rotations.cross(R_WB @ pm.p_BCm_B[body.name], f)
    f, m = f - extra[0], m - extra[1]
    kind = JOINTS[body.joint]
    if kind.axis is not None:
        a = R_WB @ np.asarray(body.axis_B, dtype=float)
        if kind.axis == TRANSLATIONAL:
            f = f - (f @ a) * a
        else:
            m = m - (m @ a) * a
    return f, m


def _point_spring_forces(pm, model):
    """``apply()``: the springs between body points with their dampers (``PointSpring``) as
    external forces for the next step: each end's world position and velocity from its link's
    state now (centre of mass c, inertial orientation q_WI, velocity v_c, angular velocity w:
    ``x = c + R_WI r_I``, r_I the end from the centre of mass in the inertial frame, ``v = v_c +
    w x (x - c)``), the force ``-(k (L - L0) + c L') d / L`` (``harness.model.forces.spring_force``)
    on end a and its opposite on end b (``applyExternalForce``, world frame, at the end point; none
    on the world). In plain floats: it runs at every PyBullet step (1.6e5 per simulated second of
    the flyball governor at its default 16 substeps)."""
    p = pybullet_module()
    c = pm.client
    links = sorted({pm.links[name] for _, *ends in pm.point_springs for name in ends if name is not None})
    ends = []
    for spring, a, b in pm.point_springs:
        pair = []
        for name, point in ((a, spring.p_A), (b, spring.p_B)):
            if name is None:  # the world's point, at rest
                pair.append((None, tuple(float(x) for x in point)))
            else:  # from the centre of mass, in the inertial frame
                r_I = pm.R_BI[name].T @ (np.asarray(point, dtype=float) - pm.p_BCm_B[name])
                pair.append((pm.links[name], tuple(float(x) for x in r_I)))
        ends.append((float(spring.stiffness), float(spring.rest_length), float(spring.damping), pair))
    world = p.WORLD_FRAME

    def end_state(state, r):
        """World position and velocity of the point r (inertial frame) of a link's state."""
        (cx, cy, cz), (qx, qy, qz, qw), (vx, vy, vz), (wx, wy, wz) = state[0], state[1], state[6], state[7]
        rx, ry, rz = r  # R r = r + 2 qw (q x r) + 2 q x (q x r)
        tx, ty, tz = 2.0 * (qy * rz - qz * ry), 2.0 * (qz * rx - qx * rz), 2.0 * (qx * ry - qy * rx)
        ax = rx + qw * tx + (qy * tz - qz * ty)
        ay = ry + qw * ty + (qz * tx - qx * tz)
        az = rz + qw * tz + (qx * ty - qy * tx)
        return ((cx + ax, cy + ay, cz + az),
                (vx + (wy * az - wz * ay), vy + (wz * ax - wx * az), vz + (wx * ay - wy * ax)))

    def apply() -> None:
        states = dict(zip(links, p.getLinkStates(pm.body, links, computeLinkVelocity=1, computeForwardKinematics=1,
                                                 physicsClientId=c)))
        for k, L0, damping, pair in ends:
            (la, ra), (lb, rb) = pair
            xa, va = (ra, (0.0, 0.0, 0.0)) if la is None else end_state(states[la], ra)
            xb, vb = (rb, (0.0, 0.0, 0.0)) if lb is None else end_state(states[lb], rb)
            dx, dy, dz = xa[0] - xb[0], xa[1] - xb[1], xa[2] - xb[2]
            L = math.sqrt(dx * dx + dy * dy + dz * dz)
            rate = (dx * (va[0] - vb[0]) + dy * (va[1] - vb[1]) + dz * (va[2] - vb[2])) / L
            m = -(k * (L - L0) + damping * rate) / L
            f = (m * dx, m * dy, m * dz)
            if la is not None:
                p.applyExternalForce(pm.body, la, f, xa, world, physicsClientId=c)
            if lb is not None:
                p.applyExternalForce(pm.body, lb, (-f[0], -f[1], -f[2]), xb, world, physicsClientId=c)

    return apply


def _joint_axes(pm, model) -> dict[str, np.ndarray]:
    """A hinge's or slide's unit axis in the child's inertial frame as PyBullet holds it
    (``getJointInfo``), per jointed body."""
    p = pybullet_module()

    out = {}
    for b in model.bodies:
        if pm.links[b.name] >= 0 and JOINTS[b.joint].axis is not None:
            info = p.getJointInfo(pm.body, pm.links[b.name], physicsClientId=pm.client)
            out[b.name] = np.asarray(info[13], dtype=float)
    return out


def _sensor_extra(pm, model, k: int, buf: SampleBuffer, axes: dict) -> dict:
    """Per jointed body, the wrench (force_W, moment about the joint point_W) that PyBullet's
    constraint-solver pass added to its sensor in the step just taken from sample ``k``
    (``harness.engines.pybullet.reactions``): the tree at sample ``k``'s positions and the
    step's new joint velocities."""
    p = pybullet_module()

    c = pm.client
    bodies = []
    index = {b.name: i for i, b in enumerate(model.bodies)}
    for i, b in enumerate(model.bodies):
        link = pm.links[b.name]
        R_WB = rotations.matrix(buf.quat_WB[k, i])
        R_WI = R_WB @ pm.R_BI[b.name]
        c_W = np.asarray(buf.p_WCm_W[k, i], dtype=float)
        if link < 0:
            w, v = p.getBaseVelocity(pm.body, physicsClientId=c)
            rate = (np.asarray(w, dtype=float), np.asarray(v, dtype=float))
        elif b.joint == BALL.name:
            rate = np.asarray(p.getJointStateMultiDof(pm.body, link, physicsClientId=c)[1], dtype=float)
        else:
            rate = p.getJointState(pm.body, link, physicsClientId=c)[1]
        bodies.append({"name": b.name, "parent": None if b.parent is None else index[b.parent], "kind": b.joint,
                       "mass": float(b.mass), "c": c_W, "I_c": R_WB @ np.asarray(b.I_Cm_B, dtype=float) @ R_WB.T,
                       "pivot": c_W - R_WB @ pm.p_BCm_B[b.name], "R_WI": R_WI, "rate": rate, "link": link,
                       "axis": R_WI @ axes[b.name] if b.name in axes else None})
    return constraint_pass_wrenches(bodies)


def _describe(settings: RunSettings, scene: Scene, pm, solver: dict, sub: int = 1) -> str:
    from harness.engines import version

    springs = ", joint springs as a generalised force at each step's start" if pm.springs else ""
    if pm.point_springs:
        springs += ", spring-dampers between body points as external forces at each step's start"
    step = f"fixed step {settings.dt:g} s" if sub == 1 else f"fixed step {settings.dt / sub:g} s ({sub} per step of {settings.dt:g} s)"
    return (f"PyBullet {version('pybullet')} stepSimulation: semi-implicit Euler, {step}, "
            f"btMultiBody (Featherstone, reduced coordinates) from {scene.urdf.name} (inertia from the file), "
            f"constraint solver {solver.get('numSolverIterations', '?')} iterations (idle: no contact, limits or motors), "
            f"damping 0, maxJointVelocity {MAX_JOINT_VELOCITY:g}{springs}")


def _read(pm, model, k: int, buf: SampleBuffer) -> None:
    """Fill sample ``k`` of ``buf`` (centre-of-mass position and velocity, body orientation,
    world angular velocity)."""
    p = pybullet_module()

    c = pm.client
    links = [pm.links[b.name] for b in model.bodies if pm.links[b.name] >= 0]
    states = dict(zip(links, p.getLinkStates(pm.body, links, computeLinkVelocity=1, computeForwardKinematics=1,
                                             physicsClientId=c))) if links else {}
    for i, b in enumerate(model.bodies):
        link = pm.links[b.name]
        if link < 0:
            pos, orn = p.getBasePositionAndOrientation(pm.body, physicsClientId=c)
            vel, omega = p.getBaseVelocity(pm.body, physicsClientId=c)
        else:
            s = states[link]
            pos, orn, vel, omega = s[0], s[1], s[6], s[7]
        R_WI = rotations.matrix(rotations.xyzw_to_wxyz(np.asarray(orn, dtype=float)))
        if not np.all(np.isfinite(R_WI)):  # a blown-up state: no orientation to read (its SVD fails)
            raise RunStop(Failure.NON_FINITE, f"non-finite state at sample {k}")
        buf.p_WCm_W[k, i] = pos
        buf.quat_WB[k, i] = rotations.from_matrix(R_WI @ pm.R_BI[b.name].T)
        buf.v_WCm_W[k, i] = vel
        buf.w_WB_W[k, i] = omega


ENGINE = PyBulletEngine()
