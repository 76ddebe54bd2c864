"""Load a scene's MJCF into MuJoCo with the scene description's parameters (via ``MjSpec``).

The MJCF file is the model as a user writes it; ``load_mjcf`` rewrites, from the scene's
``Multibody``, what parameters can change (body positions, masses, centres of mass, inertias,
gravity, the site where a prescribed force acts, joint springs, point springs with their dampers
(tendons), the sites of a loop joint's
``<connect>`` equalities: ``harness.engines.mujoco.loops``) and sets timestep and integrator.
Joint types and axes are not rewritten: they are checked (``harness.engines.loaded_models``).

A scene that names only a URDF is run by MuJoCo from the URDF (MuJoCo compiles URDF; its
importer fuses fixed links and drops visuals): ``read_spec(path, root_joint=...)`` gives the
root link the joint a URDF cannot state (``harness.model.from_model_file.add_root_joint``, as
Pinocchio adds it), and ``load_mjcf`` sets what an MJCF would carry and a URDF cannot: the
options (timestep and integrator from the run settings, gravity from the scene, contact off as a
scene without code has none, energy on) and ideal joints (the URDF's limits, damping and friction
dropped, as Pinocchio's dynamics ignore them).

Joint kinds map to MuJoCo's ``mjtJoint`` through the joint table (``JointType.mujoco``,
``MJ_JOINTS``, ``joint_type``); each force type of the force table (``harness.model.forces``)
that an MJCF can express has its writer in ``MJCF_WRITERS``.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from harness.model import rotations
from harness.model.errors import InputError
from harness.model.from_model_file import URDF, file_format, read_spec  # read_spec: MJCF or URDF into an MjSpec
from harness.model.forces import (FORCES, JOINT_SPRINGS, JOINT_TORQUES, POINT_FORCES, POINT_SPRINGS, JointSpring,
                                  JointTorque, PointForce, PointSpring)
from harness.model.joints import JOINTS, JointType
from harness.model.multibody import Multibody
from harness.model.sanity import check_inertia

from harness.engines.mujoco.integrators import INTEGRATORS
from harness.engines.mujoco.loops import apply_loops
from harness.engines.mujoco.rolling import apply_contacts


MJ_JOINTS: dict[mujoco.mjtJoint, JointType] = {getattr(mujoco.mjtJoint, jt.mujoco): jt for jt in JOINTS.values()}


def joint_type(m: mujoco.MjModel, jid: int) -> JointType | None:
    """The joint kind (``harness.model.joints``) of joint ``jid`` of a compiled model, None for a
    kind the harness does not know."""
    return MJ_JOINTS.get(mujoco.mjtJoint(m.jnt_type[jid]))


def body_joint(m: mujoco.MjModel, body: str) -> int:
    """The id of the one joint that moves body ``body`` of a compiled model (a scene gives every
    body exactly one joint: ``Body.joint``). The one lookup of the harness from a scene's body to
    MuJoCo's joint (``set_initial_state``, ``harness.tools.dynamics_terms.scene_joint_map``).
    Raises LookupError saying what is wrong: "no body named 'b'", or "body 'b' has 2 joints, not
    one"."""
    bid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, body)
    if bid < 0:
        raise LookupError(f"no body named {body!r}")
    if m.body_jntnum[bid] != 1:
        raise LookupError(f"body {body!r} has {m.body_jntnum[bid]} joints, not one")
    return int(m.body_jntadr[bid])


def joint_kind(m: mujoco.MjModel, jid: int, unknown: str | None = None) -> str:
    """The harness name of joint ``jid``'s kind, or ``unknown`` (default: MuJoCo's own name)."""
    jt = joint_type(m, jid)
    if jt is not None:
        return jt.name
    return str(m.jnt_type[jid]) if unknown is None else unknown


def urdf_root_joint_of(model: Multibody) -> str:
    """The ``urdf_root_joint`` that gives a URDF the root joint of ``model``'s root body
    (``none`` when a URDF states it: a hinge, a slide, a weld)."""
    roots = [b for b in model.bodies if b.parent is None]
    return (JOINTS[roots[0].joint].urdf_root or "none") if len(roots) == 1 else "none"


def ideal_urdf_options(spec: mujoco.MjSpec) -> None:
    """What an MJCF of a scene carries and a URDF cannot (module docstring): contact off, energy
    on, and ideal joints (no range, damping, friction loss, armature or stiffness)."""
    spec.option.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    spec.option.enableflags |= int(mujoco.mjtEnableBit.mjENBL_ENERGY)
    for joint in spec.joints:
        joint.limited = mujoco.mjtLimited.mjLIMITED_FALSE
        joint.damping = np.zeros(len(np.atleast_1d(joint.damping))) if np.ndim(joint.damping) else 0.0
        joint.frictionloss = 0.0
        joint.armature = 0.0
        joint.stiffness = np.zeros(len(np.atleast_1d(joint.stiffness))) if np.ndim(joint.stiffness) else 0.0


def principal_axes(I: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Principal moments (ascending) and the quaternion ``wxyz`` of the principal frame."""
    moments, axes = rotations.principal_frame(I)
    return moments, rotations.from_matrix(axes)


def apply_multibody(spec: mujoco.MjSpec, model: Multibody, source: Path) -> None:
    """Write the scene's mass properties, body positions, gravity and force elements (each by
    its ``MJCF_WRITERS`` entry: force sites, joint springs) into ``spec``."""
    for body in model.bodies:
        sb = spec.body(body.name)
        if sb is None:
            raise InputError(f"{source}: MJCF has no body named {body.name!r}")
        sb.pos = body.p_PB_P
        sb.quat = [1.0, 0.0, 0.0, 0.0]
        moments, iquat = principal_axes(body.I_Cm_B)
        sb.mass = body.mass
        sb.ipos = body.p_BCm_B
        sb.iquat = iquat
        sb.fullinertia = [np.nan] * 6
        sb.inertia = moments
        sb.explicitinertial = True
    for ft in FORCES.values():
        elements = ft.elements(model)
        if elements and ft.name not in MJCF_WRITERS:
            raise NotImplementedError(f"MuJoCo: no MJCF writer for {ft.label}s ({ft.name})")
        for element in elements:
            MJCF_WRITERS[ft.name](spec, element, source)
    spec.option.gravity = model.gravity_W
    if getattr(model, "contacts", ()):  # rolling rims: cylinder size from the scene (mujoco_rolling)
        apply_contacts(spec, model, source)
    if model.loops:  # cut joints: the sites of their <connect> equalities (``loops``)
        apply_loops(spec, model, source)


def _write_spring(spec: mujoco.MjSpec, spring: JointSpring, source: Path) -> None:
    """``stiffness`` and ``springref`` of the spring's joint."""
    joints = spec.body(spring.body).joints
    if len(joints) != 1:
        raise InputError(f"{source}: body {spring.body!r} needs exactly one joint for its spring")
    stiffness = np.zeros(len(np.atleast_1d(joints[0].stiffness)))
    stiffness[0] = spring.stiffness  # linear spring; MuJoCo's higher-order coefficients zero
    joints[0].stiffness = stiffness if stiffness.size > 1 else float(stiffness[0])
    joints[0].springref = spring.q_ref


def _write_point_force(spec: mujoco.MjSpec, force: PointForce, source: Path) -> None:
    """The position of the force's site (its motors ``<name>_fx/_fy/_fz`` act there)."""
    site = spec.site(force.name)
    if site is None:
        raise InputError(f"{source}: MJCF has no site named {force.name!r} for the force at {force.body!r}")
    site.pos = force.p_BQ_B


def _write_torque(spec: mujoco.MjSpec, torque: JointTorque, source: Path) -> None:
    """The actuator ``<name>`` on the body's joint as a constant force: zero gain, affine bias
    ``torque + 0 q + 0 q'`` (N m), whatever its control."""
    act = spec.actuator(torque.name)
    joints = spec.body(torque.body).joints if spec.body(torque.body) is not None else []
    if act is None or len(joints) != 1 or act.target != joints[0].name:
        raise InputError(f"{source}: MJCF needs an actuator {torque.name!r} on the joint of body {torque.body!r} "
                         f"for its torque")
    act.trntype = mujoco.mjtTrn.mjTRN_JOINT
    act.gainprm = np.zeros(len(act.gainprm))
    act.biastype = mujoco.mjtBias.mjBIAS_AFFINE
    bias = np.zeros(len(act.biasprm))
    bias[0] = torque.torque
    act.biasprm = bias
    act.gear = np.eye(1, len(act.gear)).ravel()
    act.forcelimited = mujoco.mjtLimited.mjLIMITED_FALSE


def _write_point_spring(spec: mujoco.MjSpec, spring: PointSpring, source: Path) -> None:
    """The sites ``<name>_a``, ``<name>_b`` at the spring's ends and the tendon ``<name>``'s
    ``stiffness`` (N/m), ``springlength`` (m, both ends of MuJoCo's dead band) and ``damping``
    (N s/m: MuJoCo's passive tendon force ``-damping`` times the tendon's rate of length, the
    damper in parallel; its ``implicit`` integrators take it implicitly)."""
    for end, body, point in (("a", spring.body_a, spring.p_A), ("b", spring.body_b, spring.p_B)):
        site = spec.site(f"{spring.name}_{end}")
        parent = spec.worldbody if body is None else spec.body(body)
        if site is None or parent is None or site.parent.name != parent.name:
            where = "the world" if body is None else f"body {body!r}"
            raise InputError(f"{source}: MJCF needs a site {spring.name}_{end} on {where} for spring {spring.name!r}")
        site.pos = point
    tendon = spec.tendon(spring.name)
    if tendon is None:
        raise InputError(f"{source}: MJCF needs a spatial tendon {spring.name!r} for the spring")
    stiffness = np.zeros(len(np.atleast_1d(tendon.stiffness)))
    stiffness[0] = spring.stiffness  # linear spring; MuJoCo's higher-order coefficients zero
    tendon.stiffness = stiffness if stiffness.size > 1 else float(stiffness[0])
    tendon.springlength = [spring.rest_length, spring.rest_length]
    damping = np.zeros(len(np.atleast_1d(tendon.damping)))
    damping[0] = spring.damping  # linear damper; MuJoCo's higher-order coefficients zero
    tendon.damping = damping if np.ndim(tendon.damping) else float(damping[0])


MJCF_WRITERS = {JOINT_SPRINGS.name: _write_spring, POINT_FORCES.name: _write_point_force,
                JOINT_TORQUES.name: _write_torque, POINT_SPRINGS.name: _write_point_spring}


def load_mjcf(path: Path, model: Multibody, *, dt: float | None = None, integrator: str | None = None) -> mujoco.MjModel:
    """Compile the MJCF at ``path`` with the scene's physics applied (and dt/integrator if given).
    A URDF (a scene without an MJCF) gets its root body's joint (``urdf_root_joint_of``) and the
    options and ideal joints of ``ideal_urdf_options``; the scene's physics as for an MJCF."""
    urdf = file_format(path) == URDF
    spec = read_spec(path, root_joint=urdf_root_joint_of(model)) if urdf else read_spec(path)
    if urdf:
        ideal_urdf_options(spec)
    apply_multibody(spec, model, path)
    if dt is not None:
        spec.option.timestep = dt
    if integrator is not None:
        spec.option.integrator = INTEGRATORS[integrator]
    try:
        return spec.compile()
    except Exception as err:
        raise InputError(f"{path}: {file_format(path)} does not compile: {_one_line(err)}") from None


def set_initial_state(m: mujoco.MjModel, d: mujoco.MjData, model: Multibody, source: Path) -> None:
    """Write the scene's joint-coordinate initial state into ``d.qpos``/``d.qvel``.

    MuJoCo's conventions coincide with the joint table's (``harness.model.joints``): quaternions
    ``wxyz``, free-joint linear velocity in world, angular velocities in the body frame.
    """
    for body in model.bodies:
        try:
            jid = body_joint(m, body.name)
        except LookupError as err:
            raise InputError(f"{source}: MJCF: {err}") from None
        qadr, vadr = m.jnt_qposadr[jid], m.jnt_dofadr[jid]
        q, v = np.asarray(model.q0[body.name]), np.asarray(model.v0[body.name])
        d.qpos[qadr : qadr + len(q)] = q
        d.qvel[vadr : vadr + len(v)] = v


def check_spec_inertials(spec: mujoco.MjSpec, source: Path) -> None:
    """File-level sanity of the inertials: no body/link may have a negative mass, and every
    body/link that a joint moves and that has mass must have a valid inertia tensor
    (``check_inertia``: positive definite, triangle inequality). Fixed links (frames, sensors)
    are judged through the composite body they are merged into (``harness check``'s
    ``load_pair``, ``harness.engines.loaded_models.check_joint_bodies_physical``)."""
    for body in spec.bodies:
        if body.name == "world" or not body.explicitinertial:
            continue
        mass = float(body.mass)
        what = f"body {body.name!r}"
        if not np.isfinite(mass) or mass < 0.0:
            raise InputError(f"{source}: {what}: mass must be positive, got {mass:g} kg")
        if mass == 0.0 or body.first_joint() is None:
            continue
        full = np.asarray(body.fullinertia, dtype=float)
        if np.all(np.isfinite(full)):
            xx, yy, zz, xy, xz, yz = full
            inertia = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
        else:  # principal moments in the frame iquat: validity does not depend on the frame
            inertia = np.diag(np.asarray(body.inertia, dtype=float))
        check_inertia(inertia, what, str(source))


def _one_line(err: Exception) -> str:
    return " ".join(str(err).split())
