"""``harness check``'s readers of any model file, beyond MuJoCo's and Pinocchio's per-joint bodies.

Drake as a third, independent reader (``load_drake``, ``drake_joint_bodies``, ``drake_gravity``),
each loader's joint limits, damping, armature and friction (``JointDetails``), and Pinocchio's
composite joints split back into the file's joints (``pinocchio_joint_slots``). The records
(``JointBody``, ``Part``) and MuJoCo's and Pinocchio's per-joint readers are
``harness.engines.loaded_models``'s, as is what each engine holds of a scene (``LoadedBody``,
``body_discrepancies``); the names ``harness check`` takes from there are imported here too.
"""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin

from harness.engines.loaded_models import (  # noqa: F401 - also imported from here by harness.tools.check
    JointBody,
    Part,
    _composite,
    _pin_body_frame,
    check_joint_bodies_physical,
    drake_joint_kind,
    has_axis,
    mujoco_joint_bodies,
    pinocchio_joint_bodies,
)
from harness.engines.mujoco.model import joint_kind as mujoco_joint_kind
from harness.model.joints import FREE, ROTATIONAL


# --------------------------------------------------------------------------- any model, per joint: Drake, limits, Pinocchio composites
#
# ``harness check`` reads a model file with a third, independent importer: Drake's parsers
# (URDF, MJCF, SDFormat) into a continuous-time ``MultibodyPlant``. ``drake_joint_bodies`` gives
# the same ``JointBody`` records as ``mujoco_joint_bodies`` / ``pinocchio_joint_bodies``;
# ``*_joint_settings`` read each loader's joint limits and damping; ``pinocchio_joint_slots`` splits
# Pinocchio's composite joints (several MJCF joints on one body) back into the file's joints.


class DrakeRefusal(Exception):
    """Drake's parser or ``MultibodyPlant.Finalize`` refuses a model file; ``str(err)`` is the
    reason, one line."""


@dataclass(frozen=True)
class DrakeLoad:
    """A model file as Drake holds it: the finalized plant and what loading said.

    Attributes:
        plant: ``MultibodyPlant`` (continuous, time step 0), finalized.
        warnings: Drake's parser warnings, one line each, without the file path
            (``"<line>: <message>"``), in the order Drake gave them.
        notes: what the harness did to the plant (welded or floated root links).
    """

    plant: object
    warnings: tuple[str, ...]
    notes: tuple[str, ...]


def _drake_line(text: str, path: Path) -> str:
    """Drake's message on one line, the file named by its name only ("line N: ..." for its own
    "<path>:N: ...")."""
    text = " ".join(str(text).split())
    for p in (str(Path(path).resolve()), str(path)):
        text = text.replace(f"{p}:", "line ").replace(p, Path(path).name)
    return text.replace(f"{Path(path).resolve().parent}/", "")


def _drake_joints(plant) -> list:
    return [plant.get_joint(j) for j in plant.GetJointIndices()]


def _drake_joints_root_first(plant) -> list:
    """Drake's joints, the floating joints on the world first (Drake adds a root link's floating
    joint after the file's joints; MuJoCo and Pinocchio list the root first, as
    ``drake_joint_details`` reports them), the others in Drake's order."""
    joints = _drake_joints(plant)
    world = int(plant.world_body().index())

    def floating_root(j) -> bool:
        return int(j.parent_body().index()) == world and j.num_velocities() == 6

    return [j for j in joints if floating_root(j)] + [j for j in joints if not floating_root(j)]


def load_drake(path, *, root_joint: str = "none") -> DrakeLoad:
    """Parse ``path`` with ``pydrake.multibody.parsing.Parser(plant).AddModels`` into a
    ``MultibodyPlant(0.0)`` and finalize it.

    Base, as ``harness check`` loads MuJoCo and Pinocchio: a URDF's root link (a link no joint
    moves, which ``Finalize`` would float) is welded to the world; an MJCF's top-level bodies
    are as Drake's parser makes them (a body without joints welded, a ``<freejoint>`` body
    floating: ``Finalize`` adds a quaternion floating joint named after the body). With
    ``root_joint="free"`` the root link (URDF) or the first top-level body (MJCF) gets a
    quaternion floating joint named ``root_joint`` instead (an MJCF weld to the world is
    removed first).

    Raises ``DrakeRefusal`` (one line: Drake's reason) when Drake does not load the file, and
    ``InputError`` when ``path`` is not a file Drake may be given: a regular file of at most
    ``harness.model.input_files.MAX_INPUT_BYTES`` (a FIFO would block its parser, a device flood it).
    """
    import logging

    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import MultibodyPlant
    from pydrake.multibody.tree import QuaternionFloatingJoint

    from harness.model.input_files import check_input_file, model_format

    path = Path(path)
    check_input_file(path, model_format(path))
    logger = logging.getLogger("drake")
    said: list[str] = []

    class _Keep(logging.Handler):
        def emit(self, record):
            said.append(_drake_line(record.getMessage(), path))

    keep, propagate = _Keep(logging.WARNING), logger.propagate
    logger.addHandler(keep)
    logger.propagate = False
    notes = []
    try:
        plant = MultibodyPlant(0.0)
        instances = Parser(plant).AddModels(str(path))
        world = plant.world_body()
        moved = {int(j.child_body().index()) for j in _drake_joints(plant)}
        bodies = [plant.get_body(b) for inst in instances for b in plant.GetBodyIndices(inst)]
        loose = [b for b in bodies if int(b.index()) not in moved]
        urdf = path.suffix.lower() == ".urdf"
        if root_joint == FREE.name:
            if urdf:
                if len(loose) != 1:
                    raise DrakeRefusal(f"{len(loose)} root links, cannot add one root joint")
                root = loose[0]
            else:
                tops = [b for b in bodies if int(b.index()) not in moved
                        or any(j.child_body().index() == b.index() and j.parent_body().index() == world.index()
                               for j in _drake_joints(plant))]
                if not tops:
                    raise DrakeRefusal("no top-level body to attach a root joint to")
                root = tops[0]
                for j in _drake_joints(plant):
                    if j.child_body().index() == root.index():
                        if j.type_name() != "weld":
                            raise DrakeRefusal(f"root body {root.name()!r} already has a {j.type_name()} joint")
                        plant.RemoveJoint(j)
            plant.AddJoint(QuaternionFloatingJoint("root_joint", world.body_frame(), root.body_frame()))
        elif root_joint == "none" and urdf:
            for b in loose:
                plant.WeldFrames(world.body_frame(), b.body_frame())
            if loose:
                notes.append(f"root link(s) welded to the world (fixed base): {', '.join(b.name() for b in loose)}")
        elif root_joint != "none":
            raise DrakeRefusal(f"a {root_joint} root joint is not supported for Drake")
        plant.Finalize()
    except DrakeRefusal:
        raise
    except Exception as err:  # Drake raises RuntimeError/ValueError with "<file>:<line>: error: ..."
        raise DrakeRefusal(_drake_line(err, path)) from None
    finally:
        logger.removeHandler(keep)
        logger.propagate = propagate
    return DrakeLoad(plant, tuple(said), tuple(notes))


def _drake_structure(plant):
    """Per Drake body index: the inboard joint, and functions ``real``, ``owner``, ``auxiliary``.

    Drake's MJCF parser gives a body X with several joints a chain of massless bodies ``X0``,
    ``X1``, ... with one joint each, ending at X: such a body is *auxiliary* (massless, one
    outboard moving joint, named after the real body at the end of its chain plus digits) and its
    ``real`` body is the end of its chain. A body's ``owner`` is the real body of the nearest
    moving (non-weld) joint at or above it (the world for bodies welded to the world).
    """
    import re
    from functools import cache

    joints = _drake_joints(plant)
    inboard = {int(j.child_body().index()): j for j in joints}
    outboard: dict[int, list] = {}
    for j in joints:
        if j.type_name() != "weld":
            outboard.setdefault(int(j.parent_body().index()), []).append(j)
    world = int(plant.world_body().index())

    @cache
    def real(b: int) -> int:
        return real(int(outboard[b][0].child_body().index())) if auxiliary(b) else b

    @cache
    def auxiliary(b: int) -> bool:
        outs = outboard.get(b, [])
        body = plant.get_body(_index(plant, b))
        if b == world or len(outs) != 1 or body.default_mass() != 0.0:
            return False
        end = plant.get_body(_index(plant, real(int(outs[0].child_body().index()))))
        return re.fullmatch(re.escape(end.name()) + r"\d+", body.name()) is not None

    def owner(b: int) -> int:
        while b != world:
            j = inboard.get(b)
            if j is None or j.type_name() != "weld":
                return real(b)
            b = int(j.parent_body().index())
        return world

    return inboard, real, owner, auxiliary


def _drake_zero_context(plant):
    """A context of the plant at zero joint coordinates: every 1-dof joint (revolute, prismatic)
    at 0 (whatever its default position), other joints at their default positions."""
    context = plant.CreateDefaultContext()
    q = np.array(plant.GetDefaultPositions(), dtype=float)
    for j in _drake_joints(plant):
        if j.type_name() in ("revolute", "prismatic"):
            q[j.position_start()] = 0.0
    plant.SetPositions(context, q)
    return context


def _index(plant, b: int):
    from pydrake.multibody.tree import BodyIndex

    return BodyIndex(b)


def _drake_inertia_parts(plant, context, owner_of, B: int) -> list[Part]:
    """Every body owned by B (B and the bodies welded to it; B first) as a ``Part`` in B's
    frame: mass (kg), centre of mass (m) and inertia about it (kg m^2)."""
    X_WB = plant.EvalBodyPoseInWorld(context, plant.get_body(_index(plant, B)))
    R_BW = X_WB.rotation().matrix().T
    parts = []
    for k in range(plant.num_bodies()):
        if k == int(plant.world_body().index()) or owner_of(k) != B:
            continue
        body = plant.get_body(_index(plant, k))
        M = body.default_spatial_inertia()
        m_k, c_K = float(M.get_mass()), np.array(M.get_com())
        I_Ko = np.array(M.CalcRotationalInertia().CopyToFullMatrix3())
        I_Kcm = I_Ko - m_k * (float(c_K @ c_K) * np.eye(3) - np.outer(c_K, c_K))
        X_WK = plant.EvalBodyPoseInWorld(context, body)
        R_BK = R_BW @ X_WK.rotation().matrix()
        c_B = R_BW @ (X_WK.multiply(c_K) - X_WB.translation())
        parts.append(Part(body.name(), m_k, c_B, R_BK @ I_Kcm @ R_BK.T))
    return sorted(parts, key=lambda p: p.name != plant.get_body(_index(plant, B)).name())


def drake_joint_bodies(source, *, root_joint: str = "none") -> list[JointBody]:
    """Per moving Drake joint (Drake's joint order; welds excluded): the composite body it moves,
    at zero joint coordinates (revolute and prismatic joints at 0, floating joints at their
    default pose: ``_drake_zero_context``), as ``mujoco_joint_bodies`` gives MuJoCo's.

    ``source``: a model file (loaded with ``load_drake``; ``DrakeRefusal`` when Drake refuses it)
    or a ``DrakeLoad`` / finalized ``MultibodyPlant``.

    The body a joint moves is its child with every body welded below it merged in (``_composite``:
    URDF fixed joints, MJCF bodies without joints), in the frame B of the child body; a body that
    Drake's MJCF parser split into a chain of massless auxiliary bodies (one joint each, for a
    body with several joints) is reported as MuJoCo reports it: every joint of the chain names
    the real body, the last one carries its mass, the others mass 0. ``parent`` is the owner of
    the chain's parent; ``p_PB_P``, ``R_PB`` the pose of B in it (m); ``axis_B`` the revolute or
    prismatic axis in B (unit). Drake's floating joints (a body with no joint, floated by
    ``Finalize``) are named after their body.
    """
    if isinstance(source, DrakeLoad):
        plant = source.plant
    elif isinstance(source, (str, Path)):
        plant = load_drake(source, root_joint=root_joint).plant
    else:
        plant = source
    context = _drake_zero_context(plant)
    inboard, real, owner, auxiliary = _drake_structure(plant)
    world = int(plant.world_body().index())

    def pose(b: int):
        if b == world:
            return np.eye(3), np.zeros(3)
        X = plant.EvalBodyPoseInWorld(context, plant.get_body(_index(plant, b)))
        return X.rotation().matrix(), X.translation()

    out = []
    for j in _drake_joints(plant):
        if j.type_name() == "weld":
            continue
        child = int(j.child_body().index())
        B = real(child)
        start = j
        while int(start.parent_body().index()) != world and auxiliary(int(start.parent_body().index())) \
                and real(int(start.parent_body().index())) == B:
            start = inboard[int(start.parent_body().index())]
        P = owner(int(start.parent_body().index()))
        last = child == B
        parts = _drake_inertia_parts(plant, context, owner, B) if last else []
        mass, com, inertia = _composite(parts) if parts else (0.0, np.zeros(3), np.zeros((3, 3)))
        R_WB, p_WB = pose(B)
        R_WP, p_WP = pose(P)
        kind = drake_joint_kind(j)
        axis = np.zeros(3)
        if j.type_name() in ("revolute", "prismatic"):
            a_F = np.array(j.revolute_axis() if j.type_name() == "revolute" else j.translation_axis(), dtype=float)
            R_WF = j.frame_on_parent().CalcPoseInWorld(context).rotation().matrix()
            axis = R_WB.T @ R_WF @ a_F
            axis = axis / max(np.linalg.norm(axis), 1e-300)
        out.append(JointBody(j.name(), plant.get_body(_index(plant, B)).name(), kind, mass, com, inertia,
                             plant.get_body(_index(plant, P)).name() if P != world else "world",
                             R_WP.T @ (p_WB - p_WP), R_WP.T @ R_WB, axis, tuple(parts)))
    return out


def drake_gravity(source) -> np.ndarray:
    """The gravitational acceleration of a Drake plant (m/s^2, world): its gravity field (Drake's
    MJCF parser reads ``<option gravity>``; URDF has none: Drake's default)."""
    plant = source.plant if isinstance(source, DrakeLoad) else source
    return np.array(plant.gravity_field().gravity_vector(), dtype=float)


@dataclass(frozen=True)
class JointDetails:
    """What a loader holds about a joint beyond the body it moves (any model file). Units SI.

    Attributes:
        joint: joint name (as in the loader's ``JointBody`` records).
        point_B: the joint's point in the frame B of the body it moves, at the reference
            configuration (m): a hinge's axis passes through it, a ball turns about it; zeros
            for a free joint (a slide's point does not matter).
        limits: (lower, upper) of a limited hinge (rad) or slide (m); None when unlimited (an
            infinite bound, or one beyond 1e15, is no limit) or for other joints.
        damping: viscous damping of a hinge (N m s/rad) or slide (N s/m); None for others.
        armature: inertia added to the diagonal of M for a hinge (kg m^2) or slide (kg): MuJoCo's
            and Pinocchio's ``armature``, Drake's reflected rotor inertia of the joint's
            actuators; None for others.
        friction: dry friction (friction loss) of a hinge (N m) or slide (N): MuJoCo's
            ``frictionloss``, Pinocchio's ``friction``; None for other joints and for a loader
            that does not read it (Drake's parsers).
    """

    joint: str
    point_B: np.ndarray
    limits: tuple[float, float] | None
    damping: float | None
    armature: float | None
    friction: float | None = None


UNLIMITED = 1e15  # m or rad: a bound at least this large is no bound


def _limits(lo: float, hi: float) -> tuple[float, float] | None:
    lo, hi = float(lo), float(hi)
    if not (np.isfinite(lo) and np.isfinite(hi)) or max(abs(lo), abs(hi)) >= UNLIMITED:
        return None
    return lo, hi


def mujoco_joint_details(m: mujoco.MjModel) -> list[JointDetails]:
    """Per MuJoCo joint (model order): ``jnt_pos`` (the point, body frame), the range when
    ``jnt_limited``, ``dof_damping``, ``dof_armature`` and ``dof_frictionloss`` of a hinge or slide."""
    out = []
    for j in range(m.njnt):
        kind = mujoco_joint_kind(m, j)
        one = has_axis(kind)
        dof = int(m.jnt_dofadr[j])
        limits = _limits(*m.jnt_range[j]) if one and m.jnt_limited[j] else None
        point = np.zeros(3) if kind == FREE.name else np.array(m.jnt_pos[j], dtype=float)
        out.append(JointDetails(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint{j}", point, limits,
                                float(m.dof_damping[dof]) if one else None, float(m.dof_armature[dof]) if one else None,
                                float(m.dof_frictionloss[dof]) if one else None))
    return out


def drake_joint_details(source) -> list[JointDetails]:
    """Per moving Drake joint (as ``drake_joint_bodies``, but a floating root joint first, as
    MuJoCo and Pinocchio list it: ``_drake_joints_root_first``): the origin of the joint's child frame
    in the real body's frame at zero joint coordinates, the position limits of a 1-dof joint, its
    default damping, and the reflected inertia (rotor inertia x gear ratio^2, where Drake's MJCF
    parser puts an ``armature``) of the actuators on it."""
    plant = source.plant if isinstance(source, DrakeLoad) else source
    context = _drake_zero_context(plant)
    _, real, _, _ = _drake_structure(plant)
    reflected: dict[int, float] = {}
    for a in plant.GetJointActuatorIndices():
        act = plant.get_joint_actuator(a)
        reflected[int(act.joint().index())] = reflected.get(int(act.joint().index()), 0.0) + float(act.default_reflected_inertia())
    out = []
    for j in _drake_joints_root_first(plant):
        if j.type_name() == "weld":
            continue
        B = plant.get_body(_index(plant, real(int(j.child_body().index()))))
        X_WB = plant.EvalBodyPoseInWorld(context, B)
        p_WM = j.frame_on_child().CalcPoseInWorld(context).translation()
        kind = drake_joint_kind(j)
        one = has_axis(kind) and j.num_velocities() == 1
        point = np.zeros(3) if kind == FREE.name else X_WB.rotation().matrix().T @ (p_WM - X_WB.translation())
        limits = _limits(j.position_lower_limits()[0], j.position_upper_limits()[0]) if one else None
        out.append(JointDetails(j.name(), point, limits, float(j.default_damping_vector()[0]) if one else None,
                                reflected.get(int(j.index()), 0.0) if one else None))
    return out


@dataclass(frozen=True)
class PinocchioSlot:
    """Where one joint of the model file lives in a Pinocchio model.

    Pinocchio's MJCF parser makes the joints of a body with several joints one composite joint
    (``JointModelComposite``, named ``Composite_<first joint>``); its sub-joints are the file's
    joints in order. Attributes: ``jid`` the Pinocchio joint (the composite for a sub-joint);
    ``sub`` the sub-joint's index (-1 for a plain joint); ``idx_q``, ``idx_v``, ``nq``, ``nv`` its
    coordinates in Pinocchio's q and v; ``shortname`` its joint model's ``shortname()``.
    """

    jid: int
    sub: int
    idx_q: int
    idx_v: int
    nq: int
    nv: int
    shortname: str


def pinocchio_joint_slots(pmodel: pin.Model, body_joints: dict[str, list[str]] | None = None) -> dict[str, PinocchioSlot]:
    """Joint name -> ``PinocchioSlot``. A composite joint is split into its sub-joints, named by
    ``body_joints`` (the file's joint names per body, e.g. MuJoCo's) when the body it moves has
    as many joints there, else ``<composite name>[k]``. A name Pinocchio gives twice (its MJCF
    parser names composites after their first joint) is made unique with ``#<joint id>``."""
    body_joints = body_joints or {}
    out = {}

    def unique(name: str, jid: int) -> str:
        return name if name not in out else f"{name}#{jid}"

    for jid in range(1, pmodel.njoints):
        jm = pmodel.joints[jid]
        if jm.shortname() != "JointModelComposite":
            out[unique(pmodel.names[jid], jid)] = PinocchioSlot(jid, -1, int(jm.idx_q), int(jm.idx_v), int(jm.nq),
                                                                int(jm.nv), jm.shortname())
            continue
        subs = list(jm.extract().joints)
        body = pmodel.frames[_pin_body_frame(pmodel, jid)].name
        names = body_joints.get(body, [])
        if len(names) != len(subs) or any(n in out for n in names):
            names = [f"{pmodel.names[jid]}[{k}]" for k in range(len(subs))]
        for k, (name, s) in enumerate(zip(names, subs)):
            out[unique(name, jid)] = PinocchioSlot(jid, k, int(s.idx_q), int(s.idx_v), int(s.nq), int(s.nv), s.shortname())
    return out


def _pin_sub_frames(pmodel: pin.Model, jid: int) -> list:
    """The frames of a composite joint's sub-joints at neutral, in the composite's output frame
    (the product of its ``jointPlacements`` up to each sub-joint, relative to the whole product)."""
    placements = list(pmodel.joints[jid].extract().jointPlacements)
    acc, frames = pin.SE3.Identity(), []
    for X in placements:
        acc = acc * X
        frames.append(acc)
    return [acc.actInv(F) for F in frames]


def pinocchio_split_joint_bodies(pmodel: pin.Model, slots: dict[str, PinocchioSlot]) -> list[JointBody]:
    """``pinocchio_joint_bodies`` with every composite joint split into its sub-joints (named as
    in ``slots``): each names the composite's body, the last carries its mass (the others mass 0,
    as ``mujoco_joint_bodies`` reports a body with several joints), each its own axis in B."""
    from dataclasses import replace

    whole = dict(enumerate(pinocchio_joint_bodies(pmodel), start=1))   # by joint id: names may repeat
    data = pmodel.createData()
    pin.forwardKinematics(pmodel, data, pin.neutral(pmodel))
    out = []
    for name, s in slots.items():
        x = whole[s.jid]
        if s.sub < 0:
            out.append(replace(x, joint=name))
            continue
        jt = pin_joint_type_by_name(s.shortname)
        jMb = pmodel.frames[_pin_body_frame(pmodel, s.jid)].placement
        S = np.array(data.joints[s.jid].S).reshape(6, -1)[:, s.idx_v - pmodel.joints[s.jid].idx_v]
        axis = np.zeros(3)
        if jt is not None and jt.axis is not None:
            axis = jMb.rotation.T @ (S[3:6] if jt.axis == ROTATIONAL else S[0:3])
        last = s.sub == len(pmodel.joints[s.jid].extract().joints) - 1
        out.append(replace(x, joint=name, kind=jt.name if jt is not None else s.shortname,
                           mass=x.mass if last else 0.0,
                           p_BCm_B=x.p_BCm_B if last else np.zeros(3), I_Cm_B=x.I_Cm_B if last else np.zeros((3, 3)),
                           parts=x.parts if last else (),
                           axis_B=axis / max(np.linalg.norm(axis), 1e-300)))
    return out


def pin_joint_type_by_name(shortname: str):
    """The joint kind of a Pinocchio joint model's ``shortname()`` (None when not in the table)."""
    from harness.model.joints import by_pinocchio

    return by_pinocchio(shortname)


def pinocchio_joint_details(pmodel: pin.Model, slots: dict[str, PinocchioSlot]) -> list[JointDetails]:
    """Per joint of ``slots``: the joint frame's origin in the frame of the body it moves (for a
    composite's sub-joint, its own frame at neutral), the position limits of a 1-dof joint
    (``lowerPositionLimit``/``upperPositionLimit``; a continuous joint, nq 2, has none),
    ``damping``, ``armature`` and ``friction``."""
    out = []
    for name, s in slots.items():
        jMb = pmodel.frames[_pin_body_frame(pmodel, s.jid)].placement
        jt = pin_joint_type_by_name(s.shortname)
        origin = np.zeros(3)
        if s.sub >= 0:
            origin = np.array(_pin_sub_frames(pmodel, s.jid)[s.sub].translation)
        point = np.zeros(3) if jt is FREE else np.array(jMb.actInv(origin))
        one = jt is not None and jt.axis is not None and s.nv == 1
        limits = (_limits(pmodel.lowerPositionLimit[s.idx_q], pmodel.upperPositionLimit[s.idx_q])
                  if one and s.nq == 1 else None)
        out.append(JointDetails(name, point, limits, float(pmodel.damping[s.idx_v]) if one else None,
                                float(pmodel.armature[s.idx_v]) if one else None,
                                float(pmodel.friction[s.idx_v]) if one else None))
    return out


# --------------------------------------------------------------------------- PyBullet: a fourth reader of a URDF
#
# ``harness check`` reads a URDF with PyBullet's importer too (``p.loadURDF`` into a DIRECT server),
# with ``URDF_USE_INERTIA_FROM_FILE`` (without it PyBullet derives every link's inertia from its
# collision shapes: the trap ``harness check`` names, loading the file a second time without the
# flag). Fixed links are NOT merged (no ``URDF_MERGE_FIXED_LINKS``): PyBullet keeps each link with
# its own inertial, and ``pybullet_joint_bodies`` merges a moving joint's fixed children itself,
# exactly as the other readers (``_composite``), keeping each as a ``Part`` (the merge flag would
# give only the merged body, without its parts).
#
# PyBullet's link frame is the link's inertial frame; ``getDynamicsInfo`` gives the mass, the
# principal moments and the inertial frame's pose in the URDF link frame; ``getJointInfo`` the
# joint frame's position in the parent's inertial frame and its orientation, and the axis in the
# child's inertial frame. The URDF link frames are rebuilt from these (``_pybullet_link_frames``).


#: the name of the free joint ``--floating-base`` adds (as MuJoCo, Pinocchio and Drake name it)
ROOT_JOINT = "root_joint"


class PyBulletRefusal(Exception):
    """PyBullet's importer refuses a model file; ``str(err)`` is the reason, one line."""


@contextmanager
def _quiet_native():
    """Capture what PyBullet prints on file descriptors 1 and 2 (its build time on import, the
    importer's warnings); yields a dict whose ``"text"`` holds it afterwards."""
    import os
    import sys
    import tempfile

    holder = {"text": ""}
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    with tempfile.TemporaryFile() as tmp:
        os.dup2(tmp.fileno(), 1)
        os.dup2(tmp.fileno(), 2)
        try:
            yield holder
        finally:
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            for fd in saved:
                os.close(fd)
            tmp.seek(0)
            holder["text"] = tmp.read().decode(errors="replace")


def _pybullet():
    from harness.engines.pybullet.model import pybullet_module

    return pybullet_module()


def connect_direct() -> int:
    from harness.engines.pybullet.model import connect_direct as connect

    return connect()


@dataclass
class PyBulletLoad:
    """A URDF as PyBullet holds it: its server (``client``, DIRECT mode, disconnected when this
    record is collected), the multibody's id, whether the base is fixed, whether the file's
    inertia was used (``URDF_USE_INERTIA_FROM_FILE``), the root joint (``none`` or ``free``) and
    what PyBullet printed while loading (``warnings``, one line each)."""

    client: int
    body: int
    fixed_base: bool
    inertia_from_file: bool
    root_joint: str = "none"
    warnings: tuple[str, ...] = ()

    def __post_init__(self):
        import weakref

        p = _pybullet()
        weakref.finalize(self, _disconnect, p, self.client)


def _disconnect(p, client: int) -> None:
    try:
        p.disconnect(physicsClientId=client)
    except Exception:  # noqa: BLE001 - already disconnected
        pass


def load_pybullet(path, *, root_joint: str = "none", inertia_from_file: bool = True) -> PyBulletLoad:
    """``p.loadURDF(path, useFixedBase=root_joint != "free", flags=URDF_USE_INERTIA_FROM_FILE
    (when ``inertia_from_file``))`` in a new DIRECT server, reduced coordinates, default gravity
    (PyBullet's is zero; ``harness check`` sets the comparison's for the dynamics terms).
    ``PyBulletRefusal`` (one line) when PyBullet does not load the file: an MJCF (its ``loadMJCF``
    makes separate bodies without ``<default>`` classes, ``harness check`` compares its URDF reader
    only), a missing mesh, a parse error."""
    from harness.model.input_files import check_input_file, model_format

    path = Path(path)
    fmt = model_format(path)
    check_input_file(path, fmt)
    if fmt != "URDF":
        raise PyBulletRefusal("PyBullet reads an MJCF only in part (loadMJCF: a separate multibody per top-level "
                              "body, no <default> classes, no compiler settings): compared on a URDF only")
    if root_joint not in ("none", FREE.name):
        raise PyBulletRefusal(f"a {root_joint} root joint is not supported for PyBullet")
    p = _pybullet()
    with _quiet_native() as said:
        client = connect_direct()
        try:
            flags = p.URDF_USE_INERTIA_FROM_FILE if inertia_from_file else 0
            body = p.loadURDF(str(path), useFixedBase=root_joint != FREE.name, useMaximalCoordinates=False,
                              flags=flags, physicsClientId=client)
        except Exception:  # noqa: BLE001 - pybullet.error("Cannot load URDF file.")
            body = None
    lines = [" ".join(ln.split()) for ln in said["text"].splitlines() if ln.strip()]
    lines = [ln.replace(str(path), path.name) for ln in lines if not ln.startswith("pybullet build time")]
    if body is None:
        _disconnect(p, client)
        why = [ln for ln in lines if "cannot find" in ln or "failed" in ln.lower() or "error" in ln.lower()]
        detail = "; ".join(dict.fromkeys(why))[:300]
        raise PyBulletRefusal("cannot load the URDF" + (f" ({detail})" if detail else ""))
    return PyBulletLoad(client, body, root_joint != FREE.name, inertia_from_file, root_joint, tuple(lines))


def _xyzw_matrix(q) -> np.ndarray:
    from harness.model import rotations

    return rotations.matrix(rotations.xyzw_to_wxyz(np.asarray(q, dtype=float)))


@dataclass(frozen=True)
class _PyBulletLink:
    """One PyBullet link (index -1: the base): name, joint (name, PyBullet type, axis in the URDF
    link frame), parent index, mass (kg), centre of mass and inertia about it in the URDF link frame,
    and the URDF link frame's pose in the parent's URDF frame at zero joint coordinates."""

    index: int
    name: str
    joint: str
    jtype: int
    parent: int
    mass: float
    com: np.ndarray
    inertia: np.ndarray
    p_PL: np.ndarray
    R_PL: np.ndarray
    axis: np.ndarray
    info: tuple = ()


def _pybullet_links(load: PyBulletLoad) -> list[_PyBulletLink]:
    """Every link of the loaded body, the base first (``_PyBulletLink``)."""
    p = _pybullet()
    c, b = load.client, load.body
    dyn = {k: p.getDynamicsInfo(b, k, physicsClientId=c) for k in range(-1, p.getNumJoints(b, physicsClientId=c))}

    def inertial(k):
        d = dyn[k]
        R = _xyzw_matrix(d[4])
        return float(d[0]), np.asarray(d[3], dtype=float), R, R @ np.diag(np.asarray(d[2], dtype=float)) @ R.T

    m0, c0, _, I0 = inertial(-1)
    out = [_PyBulletLink(-1, p.getBodyInfo(b, physicsClientId=c)[0].decode(), "", -1, -1, m0, c0, I0,
                         np.zeros(3), np.eye(3), np.zeros(3))]
    for k in range(p.getNumJoints(b, physicsClientId=c)):
        info = p.getJointInfo(b, k, physicsClientId=c)
        m, com, R_LI, I = inertial(k)
        parent = int(info[16])
        _, c_P, R_PI, _ = inertial(parent)
        # getJointInfo: the joint point in the parent's inertial frame, and the rotation taking the parent's
        # inertial frame to the child's (its transpose: the child's inertial frame in the parent's)
        R_PL = R_PI @ _xyzw_matrix(info[15]).T @ R_LI.T
        p_PL = c_P + R_PI @ np.asarray(info[14], dtype=float)
        axis = R_LI @ np.asarray(info[13], dtype=float)
        n = np.linalg.norm(axis)
        out.append(_PyBulletLink(k, info[12].decode(), info[1].decode(), int(info[2]), parent, m, com, I, p_PL, R_PL,
                                 axis / n if n > 0 else axis, tuple(info)))
    return out


def _pybullet_kind(jtype: int) -> str:
    from harness.engines.pybullet.model import joint_kind

    return joint_kind(jtype)


def pybullet_joint_bodies(load: PyBulletLoad) -> list[JointBody]:
    """Per moving PyBullet joint (PyBullet's link order; a floating base first, as the free joint
    ``root_joint``): the composite body it moves, its fixed children merged (``_composite``, each a
    ``Part``), in the child's URDF link frame, at zero joint coordinates, as
    ``pinocchio_joint_bodies`` gives Pinocchio's. With a fixed base the base link and the links
    fixed to it are the world's."""
    p = _pybullet()
    links = _pybullet_links(load)
    fixed = p.JOINT_FIXED
    # world pose of every URDF link frame at zero joint coordinates (base at the origin)
    R_W, p_W = {-1: np.eye(3)}, {-1: np.zeros(3)}
    for x in links[1:]:   # PyBullet lists a parent before its children
        R_W[x.index] = R_W[x.parent] @ x.R_PL
        p_W[x.index] = p_W[x.parent] + R_W[x.parent] @ x.p_PL
    moving = {x.index for x in links[1:] if x.jtype != fixed} | (set() if load.fixed_base else {-1})
    by_index = {x.index: x for x in links}

    def owner(k: int) -> int | None:
        while k not in moving:
            if k == -1:
                return None
            k = by_index[k].parent
        return k

    out = []
    for x in links:
        if x.index not in moving:
            continue
        B = x.index
        parts = []
        for y in links:
            if owner(y.index) == B:
                R_BY = R_W[B].T @ R_W[y.index]
                parts.append(Part(y.name, y.mass, R_W[B].T @ (p_W[y.index] + R_W[y.index] @ y.com - p_W[B]),
                                  R_BY @ y.inertia @ R_BY.T))
        mass, com, inertia = _composite(parts)
        if B == -1:
            out.append(JointBody(ROOT_JOINT, x.name, FREE.name, mass, com, inertia, "world", np.zeros(3), np.eye(3),
                                 np.zeros(3), tuple(parts)))
            continue
        P = owner(x.parent)
        R_P, p_P = (R_W[P], p_W[P]) if P is not None else (np.eye(3), np.zeros(3))
        if P is None and not load.fixed_base:
            P = -1
        out.append(JointBody(x.joint, x.name, _pybullet_kind(x.jtype), mass, com, inertia,
                             by_index[P].name if P is not None else "world", R_P.T @ (p_W[B] - p_P), R_P.T @ R_W[B],
                             x.axis, tuple(parts)))
    return out


def pybullet_joint_details(load: PyBulletLoad) -> list[JointDetails]:
    """Per moving PyBullet joint (as ``pybullet_joint_bodies``): the joint point (the child's URDF
    link origin: zeros), the limits of a revolute or prismatic joint (``getJointInfo``'s lower and
    upper; PyBullet gives a continuous joint lower 0 > upper -1: unlimited), its damping and
    friction (``<dynamics damping friction>``); no armature (a URDF cannot state one)."""
    fixed = _pybullet().JOINT_FIXED
    out = []
    for x in _pybullet_links(load):
        if x.index == -1:
            if not load.fixed_base:
                out.append(JointDetails(ROOT_JOINT, np.zeros(3), None, None, None, None))
            continue
        if x.jtype == fixed:
            continue
        kind = _pybullet_kind(x.jtype)
        one = has_axis(kind)
        lo, hi = float(x.info[8]), float(x.info[9])
        limits = _limits(lo, hi) if one and lo <= hi else None
        out.append(JointDetails(x.joint, np.zeros(3), limits, float(x.info[6]) if one else None, None,
                                float(x.info[7]) if one else None))
    return out


def pybullet_gravity(load: PyBulletLoad) -> np.ndarray:
    """PyBullet's gravity (m/s^2, world) in the server after loading: its default, zero (a URDF
    cannot state gravity; a PyBullet user calls ``setGravity``)."""
    params = _pybullet().getPhysicsEngineParameters(physicsClientId=load.client)
    return np.array([params.get(f"gravityAcceleration{k}", 0.0) for k in "XYZ"], dtype=float)
