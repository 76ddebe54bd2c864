"""A ``Multibody`` read from a model file as MuJoCo compiles it, and the scenes without code.

``read_model_file(path)`` compiles an MJCF, or a URDF through MuJoCo's own URDF importer
(``mujoco.MjSpec``), and reads the compiled ``MjModel`` into the harness's one description
(``harness.model.multibody``): per body its parent, its joint kind, the joint placement, axis,
mass, centre of mass and inertia, plus gravity and an initial state. What the file states is
what MuJoCo compiled: masses derived from geoms (``inertiafromgeom``) are read as MuJoCo
computed them, and a fixed child (a body without a joint, a URDF link on a fixed joint) is
merged into its parent by MuJoCo's compiler (``fusestatic``: on by default for a URDF; pass
``fuse_static=True`` for an MJCF), never by this module.

Frames (those of ``harness.model.joints``)
------------------------------------------
The harness puts each body's frame at its joint point (``jnt_pos``) and parallel to its
parent's frame at zero joint configuration, so that every frame of a tree without a free body
is parallel to the world there; a free body's frame is the file's body frame. The file's own
body frames may be rotated or offset from their joints: every quantity is re-expressed, at
MuJoCo's reference configuration ``qpos0`` (where the file's frames are as written), in the
harness's frame B: ``p_PB_P`` from the parent's frame to the joint point, ``axis_B`` the joint
axis, ``p_BCm_B`` and ``I_Cm_B`` the centre of mass and the inertia about it. With ``C`` the
rotation from the file's body frame to B (``ModelFile.rotations``), the joint coordinates map
as follows (MuJoCo ``qpos``/``qvel`` to the harness's ``q``/``v``):

* hinge, slide: ``q = qpos - qpos0`` (MuJoCo turns a joint by its distance from ``ref``),
  ``v = qvel``;
* ball: ``q = c qpos c*`` (``c`` the quaternion of ``C``; both ``wxyz``), ``v = C qvel``
  (the angular velocity relative to the parent, in the child's frame, in both);
* free: ``q = qpos`` (the body frame's position and orientation in world), ``v = qvel`` (the
  velocity of the body-frame origin in world, the angular velocity in the body frame).

What the harness cannot state is refused with one line naming the body or joint (InputError):
a body with several joints, a body that kept no joint (a mocap body, a fixed child MuJoCo did not
fuse), a joint kind without a ``JointType`` (``harness.model.joints.JOINTS``), an unnamed body,
and equality constraints (closed loops, welds: a scene with a closed loop needs a builder that
states its cut joints, ``Multibody.loops``).

A scene without code
--------------------
A scene folder whose ``scene.toml`` has no builder module (``harness/model/builders/<scene>.py``)
and names none (``builder = ...``) takes its multibody from its model file: the MJCF, else the
URDF (``harness.model.scene.scene_multibody``). Its parameters map onto that multibody by their ``sets`` key
(``TARGETS``; ``[parameters] m1 = { value = 1.0, unit = "kg", kind = "positive", doc = "...",
sets = "body.link1.mass" }``), applied in the order written, after the initial state that its
``initial_state`` key names (``zero``, the default: every joint at zero / identity and at rest;
``qpos0``: MuJoCo's reference configuration, at rest; or the name of a ``<key>`` in the MJCF:
its ``qpos`` and ``qvel``). Because the MuJoCo, Pinocchio and Drake engines rewrite body
positions and inertias from the description but not joint axes or frames, such a scene's
MJCF must state each body frame at its joint and parallel to its parent's (``ref`` zero), and
nothing the description lacks: no joint damping, stiffness, armature, friction loss or range,
no tendon, no actuator with a bias, no contact that can occur; each is refused with one line.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Iterable

import numpy as np

from harness.model import rotations
from harness.model.errors import InputError
from harness.model.joints import JOINTS, ROTATIONAL, JointType, by_mujoco, by_urdf_root
from harness.model.multibody import Body, Multibody

if TYPE_CHECKING:  # pragma: no cover
    import mujoco

MJCF, URDF = "MJCF", "URDF"

#: The initial states ``read_model_file`` and a scene's ``initial_state`` know besides a keyframe.
ZERO, QPOS0 = "zero", "qpos0"

#: What a scene parameter's ``sets`` may name (``<body>``: a body of the model file, ``<joint>``:
#: a joint's name in it): target -> (number of values, SI unit, what it sets). ``q0``/``v0`` set
#: a hinge's angle (rad) and rate (rad/s) or a slide's displacement (m) and rate (m/s);
#: ``gravity`` takes g along world -z (one number) or the vector (three).
TARGETS: dict[str, tuple[tuple[int, ...], str, str]] = {
    "gravity": ((1, 3), "m/s^2", "gravity: g along world -z, or the vector in world"),
    "body.<body>.mass": ((1,), "kg", "the body's mass"),
    "body.<body>.com": ((3,), "m", "the body's centre of mass in its frame (at its joint)"),
    "body.<body>.inertia": ((3,), "kg m^2", "the inertia about the centre of mass, diagonal in the body frame "
                                            "(products of inertia zero)"),
    "joint.<joint>.q0": ((1,), "rad or m", "the joint's initial coordinate (a hinge or slide)"),
    "joint.<joint>.v0": ((1,), "rad/s or m/s", "the joint's initial rate (a hinge or slide)"),
}
_FIELDS = {"body": ("mass", "com", "inertia"), "joint": ("q0", "v0")}

#: How far (rad, m) a file's frame may be from the harness's (rounding) before it is noted
#: (``ModelFile.frame_notes``, which ``check_runnable`` refuses in a scene without code).
FRAME_TOL = 1e-12


@dataclass(frozen=True)
class ModelFile:
    """A model file read into a ``Multibody``.

    Attributes:
        path: the file; ``format``: ``MJCF`` or ``URDF``.
        multibody: the description (initial state as asked of ``read_model_file``).
        joints: joint name in the file -> the name of the body it moves (unnamed joints left out).
        rotations: body name -> the rotation (3x3) from the file's body frame to the harness's.
        frame_notes: body name -> how the file's frame differs from the harness's (rotated, joint
            off the body origin, a nonzero ``ref``); empty where they coincide.
        keyframes: the names of the file's keyframes.
        model: the compiled ``mujoco.MjModel``.
    """

    path: Path
    format: str
    multibody: Multibody
    joints: dict[str, str]
    rotations: dict[str, np.ndarray]
    frame_notes: dict[str, str] = field(default_factory=dict)
    keyframes: tuple[str, ...] = ()
    model: "mujoco.MjModel | None" = None


def file_format(path: Path) -> str:
    """``URDF`` for a ``*.urdf`` file, else ``MJCF``."""
    return URDF if Path(path).suffix.lower() == ".urdf" else MJCF


def read_spec(path: Path, *, root_joint: str = "none"):
    """Parse an MJCF file, or a URDF (``*.urdf``: MuJoCo's URDF importer) with the root joint a
    scene's ``urdf_root_joint`` names added to its root link (``add_urdf_root_joint``), into a
    ``mujoco.MjSpec``; raise InputError (one line, naming the file) if it cannot be read, or if
    it is not a file MuJoCo may be given (``harness.model.input_files.check_model_file``: a regular
    file of bounded size, UTF-8, its includes and assets inside its folder).
    ``root_joint`` is ignored for an MJCF (it states its own)."""
    import mujoco

    from harness.model.input_files import check_model_file

    path = Path(path)
    fmt = file_format(path)
    check_model_file(path, what=fmt)  # missing, a FIFO or device, too large, not UTF-8, an include outside its folder
    try:
        spec = mujoco.MjSpec.from_file(str(path))
    except Exception as err:  # MuJoCo raises ValueError with a multi-line message
        raise InputError(f"{path}: cannot load {fmt}: {_one_line(err)}") from None
    if fmt == URDF:
        add_urdf_root_joint(spec, root_joint, path)
    return spec


def read_model_file(path: Path, *, root_joint: str = "none", initial: str = ZERO,
                    fuse_static: bool | None = None) -> ModelFile:
    """The model file at ``path`` as MuJoCo compiles it, in the harness's frames (module docstring).

    Args:
        root_joint: for a URDF, the root joint it cannot state that MuJoCo's import should add
            to its root link, as a scene's ``urdf_root_joint`` names it (``none``, ``free``,
            ``spherical``); ignored for an MJCF, whose root body carries its own joint.
        initial: ``zero``, ``qpos0`` or a keyframe's name (module docstring).
        fuse_static: MuJoCo's ``fusestatic`` (None: the file's own setting, MuJoCo's default
            being on for a URDF and off for an MJCF).

    Raises:
        InputError: the file is missing or does not compile, or holds what the harness cannot
            state (module docstring); one line naming the file and the body or joint.
    """
    path = Path(path)
    fmt = file_format(path)
    spec = read_spec(path, root_joint=root_joint)
    if fuse_static is not None:
        spec.compiler.fusestatic = bool(fuse_static)
    try:
        m = spec.compile()
    except Exception as err:
        raise InputError(f"{path}: MuJoCo cannot compile the {fmt}: {_one_line(err)}") from None
    return _from_compiled(m, path, fmt, initial)


def add_urdf_root_joint(spec, root_joint: str, path: Path) -> None:
    """Give a URDF's root link (the first body under the world) the joint a scene's
    ``urdf_root_joint`` names (``none``, ``free``, ``spherical``), as Pinocchio adds it
    (``add_root_joint``)."""
    if root_joint == "none":
        return
    jt = by_urdf_root(root_joint)
    if jt is None:
        known = ", ".join(["none"] + [k.urdf_root for k in JOINTS.values() if k.urdf_root])
        raise InputError(f"{path}: unknown root joint {root_joint!r} (known: {known})")
    add_root_joint(spec, jt.name, path)


def add_root_joint(spec, kind: str, source: Path) -> None:
    """Give the root body of a ``mujoco.MjSpec`` (first child of the world) a joint of kind
    ``kind`` named ``root_joint``: one Pinocchio can add as a root joint
    (``JointType.pinocchio_root``: free or ball), which a URDF cannot state; ``none`` leaves it
    welded. A root body that has that joint already keeps it (renamed ``root_joint``, Pinocchio's
    name); one with another joint is refused (InputError naming ``source``). The one place a
    root joint is added to a spec: MuJoCo running a URDF (``harness.engines.mujoco.model``),
    ``read_model_file`` and ``harness check``/``harness zoo``."""
    import mujoco

    from harness.model.joints import FREE

    if kind == "none":
        return
    jt = JOINTS.get(kind)
    if jt is None or jt.pinocchio_root is None:
        raise InputError(f"{source}: a {kind} joint cannot be a root joint Pinocchio adds")
    roots = [(k, b) for k, b in enumerate(spec.bodies)
             if k > 0 and b.name != "world" and b.parent is not None and b.parent.name == "world"]
    if not roots:
        raise InputError(f"{source}: no root body to attach a {kind} joint to")
    k, root = roots[0]
    joint = root.first_joint()
    if joint is not None:
        wanted = getattr(mujoco.mjtJoint, jt.mujoco)
        if joint.type == wanted and root.next_joint(joint) is None:
            joint.name = "root_joint"  # an MJCF that has the root joint already: match Pinocchio's name
            return
        raise InputError(f"{source}: root body {root.name or f'body{k}'!r} already has a joint that is not a single "
                         f"{kind} joint")
    if jt is FREE:
        root.add_freejoint(name="root_joint")
    else:
        root.add_joint(name="root_joint", type=getattr(mujoco.mjtJoint, jt.mujoco))


def read_compiled(m, path: Path, *, initial: str = ZERO, merge_fixed: bool = False) -> ModelFile:
    """``read_model_file`` of a model MuJoCo has already compiled (``path``: the file it came from,
    for messages and the format). ``merge_fixed``: a body without a joint is merged into its
    nearest ancestor with one (its mass, centre of mass and inertia added to that body's at
    ``qpos0``; welded to the world when it has none), as MuJoCo's ``fusestatic`` would, instead of
    refused."""
    return _from_compiled(m, Path(path), file_format(path), initial, merge_fixed=merge_fixed)


def _merged(m, d, b: int, owner) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass, world centre of mass and world inertia about it of body ``b`` with the jointless
    bodies ``owner`` assigns to it, at the kinematics in ``d``."""
    parts = [k for k in range(1, m.nbody) if owner[k] == b]
    mass = float(sum(m.body_mass[k] for k in parts))
    com = sum(m.body_mass[k] * d.xipos[k] for k in parts) / mass if mass > 0 else d.xipos[b].copy()
    inertia = np.zeros((3, 3))
    for k in parts:
        R, r = d.ximat[k].reshape(3, 3), d.xipos[k] - com
        inertia += R @ np.diag(m.body_inertia[k]) @ R.T + m.body_mass[k] * (r @ r * np.eye(3) - np.outer(r, r))
    return mass, com, inertia


def _from_compiled(m, path: Path, fmt: str, initial: str, merge_fixed: bool = False) -> ModelFile:
    import mujoco

    if m.neq:
        names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_EQUALITY, i) or f"#{i}" for i in range(m.neq)]
        raise InputError(f"{path}: equality constraint(s) {', '.join(names)} (a closed loop or a weld): a model file "
                         "read as a tree cannot hold them; a scene with closed loops states its cut joints in a builder "
                         "(Multibody.loops)")
    d = mujoco.MjData(m)
    d.qpos[:] = m.qpos0
    mujoco.mj_kinematics(m, d)
    works = ", ".join(JOINTS)
    frames = {0: (np.zeros(3), np.eye(3))}  # MuJoCo body id -> the harness frame's origin and rotation in world
    names = {0: None}
    bodies, joints, rots, notes = [], {}, {}, {}
    owner = np.arange(m.nbody)   # body -> the body with a joint it belongs to (merge_fixed), 0: the world
    if merge_fixed:
        for b in range(1, m.nbody):
            owner[b] = b if m.body_jntnum[b] > 0 else owner[m.body_parentid[b]]
    for b in range(1, m.nbody):
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b)
        parent = int(owner[m.body_parentid[b]])
        if merge_fixed and m.body_jntnum[b] == 0:
            continue
        of = f"child of {names[parent]!r}" if names[parent] else "child of the world"
        if not name:
            raise InputError(f"{path}: body #{b} ({of}) has no name: the harness names every body")
        n = int(m.body_jntnum[b])
        if n == 0:
            raise InputError(f"{path}: body {name!r} ({of}) has no joint: the harness gives every body one joint "
                             f"({works}); merge it into its parent (MuJoCo's fusestatic does) or give it a joint")
        jnames = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or f"#{j}" for j in range(m.body_jntadr[b],
                                                                                            m.body_jntadr[b] + n)]
        if n > 1:
            raise InputError(f"{path}: body {name!r} has {n} joints ({', '.join(jnames)}): the harness gives every body "
                             f"one joint ({works}); split it into a chain of bodies with one joint each")
        j = int(m.body_jntadr[b])
        jt = by_mujoco(mujoco.mjtJoint(m.jnt_type[j]).name)
        if jt is None:
            raise InputError(f"{path}: joint {jnames[0]!r} of body {name!r} is a {mujoco.mjtJoint(m.jnt_type[j]).name}: "
                             f"the harness has the joint kinds {works}")
        o_P, R_P = frames[parent]
        R_file = d.xmat[b].reshape(3, 3).copy()
        if jt.root_only:  # free: the file's body frame, at the world origin at zero configuration
            o_B, R_B, p_PB_P = d.xpos[b].copy(), R_file, np.zeros(3)
        else:  # at the joint point, parallel to the parent's frame
            o_B, R_B = d.xanchor[j].copy(), R_P
            p_PB_P = R_P.T @ (o_B - o_P)
        axis = R_B.T @ d.xaxis[j] if jt.axis else np.zeros(3)
        if jt.axis:
            axis = axis / np.linalg.norm(axis)
        R_I = d.ximat[b].reshape(3, 3)
        mass, com_W, I_W = float(m.body_mass[b]), d.xipos[b], R_I @ np.diag(m.body_inertia[b]) @ R_I.T
        if merge_fixed:
            mass, com_W, I_W = _merged(m, d, b, owner)
        inertia = R_B.T @ I_W @ R_B
        C = R_B.T @ R_file
        bodies.append(Body(name, names[parent], jt.name, p_PB_P, axis, mass,
                           R_B.T @ (com_W - o_B), 0.5 * (inertia + inertia.T)))
        frames[b], names[b], rots[name] = (o_B, R_B), name, C
        if mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j):
            joints[jnames[0]] = name
        note = _frame_note(m, j, jt, C)
        if note:
            notes[name] = note
    keys = tuple(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_KEY, k) or f"#{k}" for k in range(m.nkey))
    q0, v0 = _initial_state(m, path, initial, keys, rots, bodies)
    # gravity as MuJoCo applies it: none where the file disables it (<option><flag gravity="disable"/>)
    off = bool(int(m.opt.disableflags) & int(mujoco.mjtDisableBit.mjDSBL_GRAVITY))
    gravity = np.zeros(3) if off else np.array(m.opt.gravity, dtype=float)
    model = Multibody(bodies=tuple(bodies), gravity_W=gravity, q0=q0, v0=v0)
    return ModelFile(path, fmt, model, joints, rots, notes, keys, m)


def _frame_note(m, j: int, jt: JointType, C: np.ndarray) -> str:
    """How the file's frame of joint ``j``'s body differs from the harness's ("" where it does not)."""
    if jt.root_only:
        return ""
    angle = float(np.arccos(np.clip((np.trace(C) - 1.0) / 2.0, -1.0, 1.0)))
    if angle > FRAME_TOL:
        return f"its frame is rotated {np.degrees(angle):.6g} deg from its parent's"
    if np.linalg.norm(m.jnt_pos[j]) > FRAME_TOL:
        return f"its joint sits at {np.round(m.jnt_pos[j], 12).tolist()} m from its origin"
    if jt.nq == 1 and abs(float(m.qpos0[m.jnt_qposadr[j]])) > FRAME_TOL:
        return f"its joint's ref is {float(m.qpos0[m.jnt_qposadr[j]]):.6g} (MuJoCo's units: rad or m)"
    return ""


def zero_state(jt: JointType) -> tuple[np.ndarray, np.ndarray]:
    """A joint at zero configuration and at rest: zeros, with the identity quaternion where it has one."""
    q = np.zeros(jt.nq)
    if jt.quat_at is not None:
        q[jt.quat_at] = 1.0
    return q, np.zeros(jt.nv)


def _initial_state(m, path: Path, initial: str, keys: tuple[str, ...], rots: dict, bodies: list[Body]):
    """Per body (q, v) in the harness's coordinates for ``initial`` (module docstring)."""
    q0, v0 = {}, {}
    if initial == ZERO:
        for body in bodies:
            q0[body.name], v0[body.name] = zero_state(JOINTS[body.joint])
        return q0, v0
    if initial == QPOS0:
        qpos, qvel = np.array(m.qpos0), np.zeros(m.nv)
    elif initial in keys:
        k = keys.index(initial)
        qpos, qvel = np.array(m.key_qpos[k]), np.array(m.key_qvel[k])
    else:
        known = ", ".join([ZERO, QPOS0] + [f"keyframe {k!r}" for k in keys])
        raise InputError(f"{path}: no keyframe named {initial!r} for the initial state (known: {known})")
    import mujoco

    for body in bodies:
        jt = JOINTS[body.joint]
        j = int(m.body_jntadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, body.name)])
        qa, va = int(m.jnt_qposadr[j]), int(m.jnt_dofadr[j])
        q, v = qpos[qa:qa + jt.nq].copy(), qvel[va:va + jt.nv].copy()
        if jt.world_linear_velocity:  # free: the body frame's pose and velocity as they are
            q[3:7] = q[3:7] / np.linalg.norm(q[3:7])
        elif jt.quat_at is not None:  # ball: the relative rotation seen in the harness's frame
            c = rotations.from_matrix(rots[body.name])
            c_conj = c * np.array([1.0, -1.0, -1.0, -1.0])
            q = rotations.multiply(rotations.multiply(c, q / np.linalg.norm(q)), c_conj)
            v = rots[body.name] @ v
        else:  # hinge, slide: the distance from MuJoCo's reference (ref)
            q = q - m.qpos0[qa:qa + jt.nq]
        q0[body.name], v0[body.name] = q, v
    return q0, v0


# --------------------------------------------------------------------------- scenes without code


def parse_target(text: str) -> tuple[str, str, str]:
    """``(group, name, field)`` of a parameter's ``sets`` (``TARGETS``): ``("gravity", "", "")``,
    ``("body", "<body>", "mass" | "com" | "inertia")`` or ``("joint", "<joint>", "q0" | "v0")``.
    A name may hold dots. ValueError (a one-line reason) for anything else."""
    if text == "gravity":
        return "gravity", "", ""
    group, _, rest = text.partition(".")
    name, _, fld = rest.rpartition(".")
    if group not in _FIELDS or not name or fld not in _FIELDS[group]:
        raise ValueError(f"sets = {text!r} is not one of {', '.join(TARGETS)}")
    return group, name, fld


def check_runnable(mf: ModelFile, urdf_root_joint: str | None) -> None:
    """InputError (one line naming the body, joint or element) unless every engine can run
    ``mf`` as a scene: frames as the harness's (``frame_notes``), the URDF's root joint the
    one the root body has (unless ``urdf_root_joint`` is None: a scene without a URDF), and (for an MJCF, which MuJoCo runs as written but for what the
    description rewrites) no joint damping, stiffness, armature, friction loss or range, no
    tendon, no actuator with a bias, no contact that can occur."""
    import mujoco

    path, m = mf.path, mf.model
    if mf.frame_notes:
        name, note = next(iter(mf.frame_notes.items()))
        raise InputError(f"{path}: body {name!r}: {note}: a scene without a builder states each body frame at its "
                         "joint and parallel to its parent's, with ref zero (the engines rewrite positions and inertias "
                         "from the description, not frames or axes)")
    for body in mf.multibody.bodies:
        jt = JOINTS[body.joint]
        if urdf_root_joint is not None and body.parent is None and (jt.urdf_root or "none") != urdf_root_joint:
            raise InputError(f"{path}: root body {body.name!r} has a {jt.name} joint, so its scene needs "
                             f"urdf_root_joint = {jt.urdf_root or 'none'!r} (it says {urdf_root_joint!r})")
    if mf.format != MJCF:
        return
    for j in range(m.njnt):
        dofs = slice(m.jnt_dofadr[j], m.jnt_dofadr[j] + by_mujoco(mujoco.mjtJoint(m.jnt_type[j]).name).nv)
        found = [what for what, values in (("damping", m.dof_damping[dofs]), ("armature", m.dof_armature[dofs]),
                                          ("frictionloss", m.dof_frictionloss[dofs]), ("stiffness", [m.jnt_stiffness[j]]))
                 if np.any(np.asarray(values) != 0.0)]
        if m.jnt_limited[j]:
            found.append(f"a range {np.round(m.jnt_range[j], 9).tolist()}")
        if found:
            raise InputError(f"{path}: joint {_name(m, mujoco.mjtObj.mjOBJ_JOINT, j)!r} has {' and '.join(found)}: a scene "
                             "without a builder has ideal joints (no damping, stiffness, armature, friction loss or "
                             "limits); remove them")
    if m.ntendon:
        raise InputError(f"{path}: tendon {_name(m, mujoco.mjtObj.mjOBJ_TENDON, 0)!r}: a scene without a builder has no "
                         "tendons or springs; remove it")
    for a in range(m.nu):
        if np.any(m.actuator_biasprm[a] != 0.0):
            raise InputError(f"{path}: actuator {_name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, a)!r} has a bias (a servo): a "
                             "scene without a builder has no forces but gravity; remove it")
    pair = _possible_contact(m)
    if pair:
        raise InputError(f"{path}: geoms {pair[0]!r} and {pair[1]!r} can touch: a scene without a builder has no contact; "
                         'disable it (<flag contact="disable"/>) or give the geoms contype="0" conaffinity="0"')


def _name(m, kind, i: int) -> str:
    """The name of MuJoCo object ``i`` of ``kind`` (``mjtObj``), or ``#i``."""
    import mujoco

    return mujoco.mj_id2name(m, kind, i) or f"#{i}"


def _possible_contact(m) -> tuple[str, str] | None:
    """Two geoms MuJoCo's collision filter lets touch (an explicit ``<pair>`` counts), or None."""
    import mujoco

    if m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT:
        return None
    geom = mujoco.mjtObj.mjOBJ_GEOM
    if m.npair:
        return _name(m, geom, int(m.pair_geom1[0])), _name(m, geom, int(m.pair_geom2[0]))
    filter_parent = not (m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_FILTERPARENT)
    excluded = set(int(s) for s in m.exclude_signature)
    weld, parent = m.body_weldid, m.body_parentid
    for g1 in range(m.ngeom):
        for g2 in range(g1 + 1, m.ngeom):
            if not (m.geom_contype[g1] & m.geom_conaffinity[g2] or m.geom_contype[g2] & m.geom_conaffinity[g1]):
                continue
            b1, b2 = int(m.geom_bodyid[g1]), int(m.geom_bodyid[g2])
            w1, w2 = int(weld[b1]), int(weld[b2])
            if w1 == w2 or {(b1 << 16) + b2, (b2 << 16) + b1, (w1 << 16) + w2, (w2 << 16) + w1} & excluded:
                continue
            if filter_parent and w1 and w2 and (int(weld[parent[w1]]) == w2 or int(weld[parent[w2]]) == w1):
                continue
            return _name(m, geom, g1), _name(m, geom, g2)
    return None


def _unit_key(unit: str) -> str:
    return "".join(ch for ch in unit.lower() if ch not in " *^\u00b7")


def apply_parameters(mf: ModelFile, parameters: Iterable, source: Path) -> Multibody:
    """``mf``'s multibody with each parameter's value put where its ``sets`` says (``TARGETS``,
    in the order given); a parameter is read for its ``name``, ``sets``, ``value`` (SI units)
    and ``unit`` (a scene's ``harness.model.scene.Parameter``). InputError (one line naming the parameter) for a target the file does
    not have, a value of the wrong size, or a unit other than the target's SI unit."""
    model = mf.multibody
    bodies = {b.name: b for b in model.bodies}
    q0, v0 = dict(model.q0), dict(model.v0)
    gravity = np.array(model.gravity_W, dtype=float)
    for p in parameters:
        where = f"{source}: [parameters] {p.name}"
        try:
            group, name, fld = parse_target(p.sets)
        except ValueError as err:
            raise InputError(f"{where}: {err}") from None
        value = np.atleast_1d(np.asarray(p.value, dtype=float))
        if group == "gravity":
            sizes, unit = TARGETS["gravity"][:2]
        elif group == "body":
            if name not in bodies:
                raise InputError(f"{where} sets {p.sets!r}: {mf.path.name} has no body {name!r} "
                                 f"(bodies: {', '.join(bodies)})")
            sizes, unit = TARGETS[f"body.<body>.{fld}"][:2]
        else:
            if name not in mf.joints:
                raise InputError(f"{where} sets {p.sets!r}: {mf.path.name} has no joint {name!r} "
                                 f"(joints: {', '.join(mf.joints) or 'none named'})")
            jt = JOINTS[bodies[mf.joints[name]].joint]
            if jt.nq != 1:
                raise InputError(f"{where} sets {p.sets!r}: joint {name!r} is a {jt.name} joint; q0 and v0 set a "
                                 "one-coordinate joint (its initial state comes from initial_state)")
            unit = ("rad" if jt.axis == ROTATIONAL else "m") + ("/s" if fld == "v0" else "")
            sizes = (1,)
        if value.size not in sizes:
            raise InputError(f"{where} sets {p.sets!r}, which takes {' or '.join(map(str, sizes))} number(s), "
                             f"got {value.size}")
        if p.unit and _unit_key(p.unit) != _unit_key(unit):
            raise InputError(f"{where}: unit {p.unit!r}, but {p.sets} is in {unit} (the harness works in SI units)")
        if group == "gravity":
            gravity = value.copy() if value.size == 3 else np.array([0.0, 0.0, -float(value[0])])
        elif group == "body":
            body = bodies[name]
            change = {"mass": {"mass": float(value[0])}, "com": {"p_BCm_B": value.copy()},
                      "inertia": {"I_Cm_B": np.diag(value)}}[fld]
            bodies[name] = replace(body, **change)
        else:
            target = q0 if fld == "q0" else v0
            target[mf.joints[name]] = value.copy()
    return replace(model, bodies=tuple(bodies[b.name] for b in model.bodies), gravity_W=gravity, q0=q0, v0=v0)


def _one_line(err: Exception) -> str:
    return " ".join(str(err).split())
