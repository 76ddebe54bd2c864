"""What each engine sees after loading a scene's model, compared with the scene description.

``mujoco_bodies`` / ``pinocchio_bodies`` / ``exudyn_bodies`` read back, per scene body: mass (kg), centre of mass in
the body frame (m), inertia about the centre of mass in the body frame (kg m^2), the body
frame's position in its parent (m), joint type and hinge axis (body frame).
``body_discrepancies`` measures every quantity against the ``Multibody`` (``Discrepancy``: value,
tolerance, unit, message); ``compare_bodies`` lists the disagreements beyond a relative tolerance.

For any model file (no scene), ``mujoco_joint_bodies`` / ``pinocchio_joint_bodies`` read back,
per joint, the rigid body it moves (fixed children merged) in the frame of its child link, and
``compare_joint_bodies`` compares two engines joint by joint (matched by name);
``check_joint_bodies_physical`` rejects non-positive masses and invalid inertia tensors.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
import pinocchio as pin

from harness.engines.mujoco.model import joint_kind as mujoco_joint_kind
from harness.engines.pinocchio.model import joint_kind as pin_joint_kind
from harness.engines.pinocchio.model import joint_type as pin_joint_type
from harness.model import rotations
from harness.model.forces import JOINT_SPRINGS
from harness.model.joints import FREE, JOINTS, ROTATIONAL, TRANSLATIONAL, by_exudyn
from harness.model.multibody import Multibody


@dataclass(frozen=True)
class LoadedBody:
    """A body as an engine holds it after loading (see module docstring for frames/units)."""

    name: str
    mass: float
    p_BCm_B: np.ndarray
    I_Cm_B: np.ndarray
    p_PB_P: np.ndarray
    joint: str
    axis_B: np.ndarray


def mujoco_bodies(m: mujoco.MjModel, model: Multibody) -> list[LoadedBody]:
    """Read back the scene's bodies from a compiled ``MjModel`` (missing bodies are skipped)."""
    out = []
    for body in model.bodies:
        bid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, body.name)
        if bid < 0:
            continue
        R = rotations.matrix(m.body_iquat[bid])
        I = R @ np.diag(m.body_inertia[bid]) @ R.T
        joint, axis = "none", np.zeros(3)
        if m.body_jntnum[bid] >= 1:
            jid = m.body_jntadr[bid]
            joint = mujoco_joint_kind(m, jid)
            axis = np.array(m.jnt_axis[jid])
        out.append(LoadedBody(body.name, float(m.body_mass[bid]), np.array(m.body_ipos[bid]), I,
                              np.array(m.body_pos[bid]), joint, axis))
    return out


def pinocchio_bodies(pmodel: pin.Model, model: Multibody) -> list[LoadedBody]:
    """Read back the scene's bodies from a Pinocchio model (body = link = its parent joint)."""
    data = pmodel.createData()
    pin.forwardKinematics(pmodel, data, pin.neutral(pmodel))
    out = []
    for body in model.bodies:
        if not pmodel.existFrame(body.name):
            continue
        jid = pmodel.frames[pmodel.getFrameId(body.name)].parentJoint
        inertia = pmodel.inertias[jid]
        joint, axis = pin_joint_kind(pmodel.joints[jid]), _pin_axis(data, jid, pin_joint_type(pmodel.joints[jid]))
        out.append(LoadedBody(body.name, float(inertia.mass), np.array(inertia.lever), np.array(inertia.inertia),
                              np.array(pmodel.jointPlacements[jid].translation), joint, axis))
    return out


def exudyn_bodies(system, model: Multibody) -> list[LoadedBody]:
    """Read back the scene's bodies from an Exudyn system (``harness.engines.exudyn.model.build``):
    each rigid body's ``mass``, ``centerOfMass`` and ``inertia`` (Exudyn's six components about
    the node, the body frame origin, shifted to the centre of mass), and its joint's object
    type, the parent's joint marker position (the joint point in the parent frame at the
    initial state, less ``q0 axis`` for a slide) and the free axis of the joint frame."""
    from harness.engines.exudyn.engine import joint_frame

    mbs = system.mbs
    out = []
    for body in model.bodies:
        if body.name not in system.bodies:
            continue
        obj = mbs.GetObject(system.bodies[body.name])
        m = float(obj["mass"])
        c = np.asarray(obj["centerOfMass"], dtype=float)
        xx, yy, zz, yz, xz, xy = np.asarray(obj["inertia"], dtype=float)
        I_ref = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
        I_C = I_ref - m * (float(c @ c) * np.eye(3) - np.outer(c, c))
        joint, axis, p_PB_P = FREE.name, np.zeros(3), np.zeros(3)
        if body.name in system.joints:
            jobj = system.joints[body.name][0]
            jd = mbs.GetObject(jobj)
            jt = by_exudyn(jd["objectType"])
            joint = jt.name if jt else jd["objectType"]
            p_PB_P = np.asarray(mbs.GetMarker(jd["markerNumbers"][0])["localPosition"], dtype=float)
            if jt and jt.exudyn.free_axis is not None:
                axis = joint_frame(mbs, jobj, 1)[:, jt.exudyn.free_axis]
            if jt and jt.axis == TRANSLATIONAL:  # the marker sits at the initial slide position
                p_PB_P = p_PB_P - float(np.asarray(model.q0[body.name]).ravel()[0]) * axis
        out.append(LoadedBody(body.name, m, c, I_C, p_PB_P, joint, axis))
    return out


def exudyn_gravity(system) -> np.ndarray:
    """The gravitational acceleration (m/s^2, world) of the Exudyn system's mass-proportional
    loads (all equal; NaN when they differ; zero when there is none: a body created with zero
    gravity gets no load)."""
    mbs = system.mbs
    loads = [np.asarray(mbs.GetLoad(i)["loadVector"], dtype=float) for i in range(mbs.systemData.NumberOfLoads())
             if mbs.GetLoad(i)["loadType"] == "MassProportional"]
    if not loads:  # Exudyn adds no load for zero gravity
        return np.zeros(3)
    if any(np.any(g != loads[0]) for g in loads):
        return np.full(3, np.nan)
    return loads[0]


def mujoco_spring_problems(m: mujoco.MjModel, model: Multibody, rtol: float = 1e-9) -> list[str]:
    """Disagreements between the scene's joint springs and a compiled ``MjModel``: the linear
    stiffness (N/m) and ``springref`` (m) of each spring's joint; joints with a stiffness the
    scene does not declare are reported too."""
    problems = []
    declared = {sp.body: sp for sp in JOINT_SPRINGS.elements(model)}
    for body in model.bodies:
        bid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, body.name)
        if bid < 0 or m.body_jntnum[bid] != 1:
            continue
        jid = m.body_jntadr[bid]
        k = float(np.atleast_1d(m.jnt_stiffness[jid])[0])
        sp = declared.get(body.name)
        if sp is None:
            if k != 0.0:
                problems.append(f"{body.name}: joint stiffness {k:g} N/m, the scene declares no spring")
            continue
        q_ref = float(m.qpos_spring[m.jnt_qposadr[jid]])
        if not np.isclose(k, sp.stiffness, rtol=rtol, atol=0.0):
            problems.append(f"{body.name}: spring stiffness {k:.9g} N/m, scene says {sp.stiffness:.9g} N/m")
        if abs(q_ref - sp.q_ref) > rtol * max(abs(sp.q_ref), 1e-3):
            problems.append(f"{body.name}: spring reference {q_ref:.9g} m, scene says {sp.q_ref:.9g} m")
    return problems


@dataclass(frozen=True)
class Discrepancy:
    """One quantity of one loaded body measured against the scene description.

    Attributes:
        body: the body's name ("" for a model-wide quantity: gravity).
        quantity: ``present``, ``mass``, ``com``, ``inertia``, ``joint_position``, ``joint_type``,
            ``axis`` or ``gravity``.
        value: the disagreement, in ``unit``: ``rel`` for mass (|m - m_s| / m_s), centre of mass
            and joint position (distance over the body's length scale, m / m), inertia (largest
            entry difference over the scene's largest entry) and gravity (|g - g_s| over
            max(|g_s|, 1 m/s^2)); ``rad`` for an axis (angle between the loaded and the scene's
            unit axis); ``""`` for presence and joint type (1 when they differ, else 0).
        tolerance: the largest value that agrees, in ``unit``.
        message: what disagrees, loaded value against the scene's (as ``compare_bodies`` lists it).
    """

    body: str
    quantity: str
    value: float
    tolerance: float
    unit: str
    message: str

    @property
    def passed(self) -> bool:
        return bool(np.isfinite(self.value) and self.value <= self.tolerance)


AXIS_TOL = 1e-9  # rad: an axis is a direction in a file, written exactly (0 -1 0), never rounded


def body_discrepancies(loaded: list[LoadedBody], model: Multibody, rtol: float = 1e-9) -> list[Discrepancy]:
    """Every quantity of every body, loaded against the scene description (agreeing ones too):
    presence; mass; centre of mass; inertia about it; joint position in the parent (joints with
    a joint point); joint type; joint axis (joints with one, when the types agree). Relative
    quantities are judged against ``rtol``, the axis against ``AXIS_TOL`` rad."""
    out = []
    seen = {b.name for b in loaded}
    for body in model.bodies:
        if body.name not in seen:
            out.append(Discrepancy(body.name, "present", 1.0, 0.0, "", f"body {body.name!r} is missing"))
    for lb in loaded:
        body = model.body(lb.name)
        length = max(np.linalg.norm(body.p_BCm_B), np.linalg.norm(body.p_PB_P), 1e-3)
        out.append(Discrepancy(lb.name, "mass", abs(lb.mass - body.mass) / body.mass, rtol, "rel",
                               f"{lb.name}: mass {lb.mass:.9g} kg, scene says {body.mass:.9g} kg"))
        out.append(Discrepancy(lb.name, "com", float(np.linalg.norm(lb.p_BCm_B - body.p_BCm_B) / length), rtol, "rel",
                               f"{lb.name}: centre of mass {lb.p_BCm_B.tolist()} m, scene says {body.p_BCm_B.tolist()} m"))
        scale = max(float(np.abs(body.I_Cm_B).max()), 1e-300)
        out.append(Discrepancy(lb.name, "inertia", float(np.abs(lb.I_Cm_B - body.I_Cm_B).max() / scale), rtol, "rel",
                               f"{lb.name}: inertia about the centre of mass {np.round(lb.I_Cm_B, 12).tolist()} kg m^2, "
                               f"scene says {np.round(body.I_Cm_B, 12).tolist()} kg m^2"))
        if JOINTS[body.joint].constrained:
            out.append(Discrepancy(lb.name, "joint_position", float(np.linalg.norm(lb.p_PB_P - body.p_PB_P) / length), rtol,
                                   "rel", f"{lb.name}: joint position in parent {lb.p_PB_P.tolist()} m, "
                                          f"scene says {body.p_PB_P.tolist()} m"))
        same = lb.joint == body.joint
        out.append(Discrepancy(lb.name, "joint_type", 0.0 if same else 1.0, 0.0, "",
                               f"{lb.name}: joint type {lb.joint}, scene says {body.joint}"))
        if same and JOINTS[body.joint].axis:
            norm = float(np.linalg.norm(lb.axis_B))
            chord = float(np.linalg.norm(lb.axis_B / norm - body.axis_B)) if norm > 0 else 2.0
            out.append(Discrepancy(lb.name, "axis", 2.0 * float(np.arcsin(min(1.0, chord / 2.0))), AXIS_TOL, "rad",
                                   f"{lb.name}: {body.joint} axis {lb.axis_B.tolist()}, scene says {body.axis_B.tolist()}"))
    return out


def compare_bodies(loaded: list[LoadedBody], model: Multibody, rtol: float = 1e-9) -> list[str]:
    """Disagreements between loaded bodies and the scene description, one message each
    (the failing ``body_discrepancies``)."""
    return [d.message for d in body_discrepancies(loaded, model, rtol) if not d.passed]


# --------------------------------------------------------------------------- any model, per joint


@dataclass(frozen=True)
class JointBody:
    """The rigid body a joint moves, as one engine holds it after loading (any model file).

    The body is everything rigidly attached to the joint's child (fixed children merged in);
    its frame B is the frame of the child body/link. Units SI.

    Attributes:
        joint: joint name; ``body``: name of the child body (MuJoCo) or link frame (Pinocchio).
        kind: ``free``, ``ball``, ``hinge``, ``slide`` or the engine's own name.
        mass: kg; ``p_BCm_B``: centre of mass in B (m); ``I_Cm_B``: inertia about it in B (kg m^2).
        parent: name of the parent joint's body (``world`` at the root).
        p_PB_P, R_PB: B's pose in the parent body's frame at the reference configuration
            (MuJoCo ``qpos0``, Pinocchio ``neutral``) (m, rotation matrix).
        axis_B: hinge or slide axis in B (unit vector; zeros for other joints).
    """

    joint: str
    body: str
    kind: str
    mass: float
    p_BCm_B: np.ndarray
    I_Cm_B: np.ndarray
    parent: str
    p_PB_P: np.ndarray
    R_PB: np.ndarray
    axis_B: np.ndarray


def _composite(parts) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass, centre of mass and inertia about it of ``(m, c, I)`` parts (one frame)."""
    mass = float(sum(p[0] for p in parts))
    if mass <= 0.0:
        return mass, np.zeros(3), sum((p[2] for p in parts), np.zeros((3, 3)))
    com = sum(p[0] * p[1] for p in parts) / mass
    inertia = np.zeros((3, 3))
    for m_k, c_k, I_k in parts:
        d = c_k - com
        inertia += I_k + m_k * (d @ d * np.eye(3) - np.outer(d, d))
    return mass, com, inertia


def mujoco_joint_bodies(m: mujoco.MjModel) -> list[JointBody]:
    """Per MuJoCo joint (model order): the composite body it moves, at ``qpos0``.

    A body without joints belongs to its nearest ancestor with a joint (or to the world). A
    body with several joints is reported at its last joint; its other joints get mass 0.
    """
    d = mujoco.MjData(m)
    d.qpos[:] = m.qpos0
    mujoco.mj_kinematics(m, d)
    owner = np.zeros(m.nbody, dtype=int)
    for b in range(1, m.nbody):
        owner[b] = b if m.body_jntnum[b] > 0 else owner[m.body_parentid[b]]
    out = []
    for j in range(m.njnt):
        b = int(m.jnt_bodyid[j])
        last = j == m.body_jntadr[b] + m.body_jntnum[b] - 1
        R_WB, p_WB = d.xmat[b].reshape(3, 3), d.xpos[b]
        parts = []
        for k in range(1, m.nbody):
            if last and owner[k] == b:
                Rk = d.ximat[k].reshape(3, 3)
                parts.append((float(m.body_mass[k]), R_WB.T @ (d.xipos[k] - p_WB),
                              R_WB.T @ Rk @ np.diag(m.body_inertia[k]) @ Rk.T @ R_WB))
        mass, com, inertia = _composite(parts) if parts else (0.0, np.zeros(3), np.zeros((3, 3)))
        pb = owner[m.body_parentid[b]]
        R_WP, p_WP = d.xmat[pb].reshape(3, 3), d.xpos[pb]
        kind = mujoco_joint_kind(m, j)
        axis = np.array(m.jnt_axis[j]) if _has_axis(kind) else np.zeros(3)
        out.append(JointBody(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint{j}",
                             mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}", kind, mass, com, inertia,
                             mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, pb) or "world",
                             R_WP.T @ (p_WB - p_WP), R_WP.T @ R_WB, axis / max(np.linalg.norm(axis), 1e-300)))
    return out


def _has_axis(kind: str) -> bool:
    """Whether a joint of kind ``kind`` (a harness name or an engine's own) moves along an axis."""
    jt = JOINTS.get(kind)
    return jt is not None and jt.axis is not None


def _pin_axis(data: pin.Data, jid: int, jt) -> np.ndarray:
    """The axis of a 1-dof joint from its motion subspace (joint frame): the angular part for a
    rotational axis, the linear part for a translational one; zeros without an axis."""
    if jt is None or jt.axis is None:
        return np.zeros(3)
    S = np.array(data.joints[jid].S).reshape(6, -1)[:, 0]
    return (S[3:6] if jt.axis == ROTATIONAL else S[0:3]).copy()


def _pin_body_frame(pmodel: pin.Model, jid: int) -> int:
    """The BODY frame attached directly to joint ``jid`` (the child link), or the joint frame."""
    joint_frame = -1
    for fid, f in enumerate(pmodel.frames):
        if f.parentJoint == jid and f.type == pin.FrameType.JOINT:
            joint_frame = fid
        elif f.parentJoint == jid and f.type == pin.FrameType.BODY and f.parentFrame == joint_frame:
            return fid
    return joint_frame


def pinocchio_joint_bodies(pmodel: pin.Model) -> list[JointBody]:
    """Per Pinocchio joint (model order, universe excluded): the body it moves (``inertias[j]``:
    Pinocchio merges fixed children into it), in the frame of the child link, at ``neutral``."""
    data = pmodel.createData()
    q = pin.neutral(pmodel)
    pin.forwardKinematics(pmodel, data, q)
    pin.updateFramePlacements(pmodel, data)
    frames = {jid: _pin_body_frame(pmodel, jid) for jid in range(1, pmodel.njoints)}
    out = []
    for jid in range(1, pmodel.njoints):
        fid = frames[jid]
        jMb = pmodel.frames[fid].placement
        inertia = jMb.actInv(pmodel.inertias[jid])
        oMb = data.oMf[fid]
        parent = int(pmodel.parents[jid])
        oMp = data.oMf[frames[parent]] if parent > 0 else pin.SE3.Identity()
        pMb = oMp.actInv(oMb)
        jm = pmodel.joints[jid]
        kind = pin_joint_kind(jm)
        axis = jMb.rotation.T @ _pin_axis(data, jid, pin_joint_type(jm))
        out.append(JointBody(pmodel.names[jid], pmodel.frames[fid].name, kind, float(inertia.mass),
                             np.array(inertia.lever), np.array(inertia.inertia),
                             pmodel.frames[frames[parent]].name if parent > 0 else "world",
                             np.array(pMb.translation), np.array(pMb.rotation), axis))
    return out


def compare_joint_bodies(a: list[JointBody], b: list[JointBody], labels=("A", "B"), rtol: float = 1e-9) -> list[str]:
    """Disagreements between two engines' per-joint bodies, matched by joint name."""
    problems = []
    by_name = {x.joint: x for x in b}
    names_a = {x.joint for x in a}
    for x in b:
        if x.joint not in names_a:
            problems.append(f"joint {x.joint!r}: only in {labels[1]}")
    for x in a:
        y = by_name.get(x.joint)
        if y is None:
            problems.append(f"joint {x.joint!r}: only in {labels[0]}")
            continue
        who = f"joint {x.joint!r} (body {x.body!r})"
        length = max(np.linalg.norm(x.p_BCm_B), np.linalg.norm(x.p_PB_P), 1e-3)
        if x.kind != y.kind:
            problems.append(f"{who}: type {x.kind} in {labels[0]}, {y.kind} in {labels[1]}")
        if not np.isclose(x.mass, y.mass, rtol=rtol, atol=1e-12):
            problems.append(f"{who}: mass {x.mass:.9g} kg in {labels[0]}, {y.mass:.9g} kg in {labels[1]}")
        if np.linalg.norm(x.p_BCm_B - y.p_BCm_B) > rtol * length:
            problems.append(f"{who}: centre of mass {np.round(x.p_BCm_B, 9).tolist()} m in {labels[0]}, "
                            f"{np.round(y.p_BCm_B, 9).tolist()} m in {labels[1]}")
        scale = max(np.abs(x.I_Cm_B).max(), np.abs(y.I_Cm_B).max(), 1e-300)
        if np.abs(x.I_Cm_B - y.I_Cm_B).max() > rtol * scale:
            problems.append(f"{who}: inertia about the centre of mass {np.round(x.I_Cm_B, 9).tolist()} kg m^2 in {labels[0]}, "
                            f"{np.round(y.I_Cm_B, 9).tolist()} kg m^2 in {labels[1]}")
        if _constrained(x.kind):
            if np.linalg.norm(x.p_PB_P - y.p_PB_P) > rtol * length:
                problems.append(f"{who}: position in parent {np.round(x.p_PB_P, 9).tolist()} m in {labels[0]}, "
                                f"{np.round(y.p_PB_P, 9).tolist()} m in {labels[1]}")
            if np.abs(x.R_PB - y.R_PB).max() > max(rtol, 1e-12):
                problems.append(f"{who}: orientation in parent differs by "
                                f"{_angle(x.R_PB.T @ y.R_PB):.3e} rad between {labels[0]} and {labels[1]}")
        if x.kind == y.kind and _has_axis(x.kind) and np.linalg.norm(x.axis_B - y.axis_B) > max(rtol, 1e-12):
            problems.append(f"{who}: axis {np.round(x.axis_B, 9).tolist()} in {labels[0]}, {np.round(y.axis_B, 9).tolist()} in {labels[1]}")
    return problems


def _constrained(kind: str) -> bool:
    """Whether a joint of kind ``kind`` has a joint point (all but free; an engine's own kind counts)."""
    jt = JOINTS.get(kind)
    return jt is None or jt.constrained


def _angle(R: np.ndarray) -> float:
    return float(np.arccos(np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)))


def check_joint_bodies_physical(bodies: list[JointBody], source: str) -> None:
    """Raise InputError naming the first moving body whose mass is not positive or whose
    inertia is not a valid inertia tensor (``harness.model.sanity.check_inertia``)."""
    from harness.model.errors import InputError
    from harness.model.sanity import check_inertia

    for x in bodies:
        what = f"body {x.body!r} (moved by joint {x.joint!r})"
        if not (np.isfinite(x.mass) and x.mass > 0.0):
            raise InputError(f"{source}: {what}: mass must be positive, got {x.mass:g} kg")
        check_inertia(x.I_Cm_B, what, source)


def gravity_discrepancy(g_loaded: np.ndarray, g_scene: np.ndarray, rtol: float = 1e-9) -> Discrepancy:
    """The loaded gravity (m/s^2, world) against the scene's: |g - g_s| / max(|g_s|, 1 m/s^2)."""
    scale = max(np.linalg.norm(g_scene), 1.0)
    value = float(np.linalg.norm(np.asarray(g_loaded) - g_scene) / scale)
    return Discrepancy("", "gravity", value, rtol, "rel",
                       f"gravity {np.round(g_loaded, 12).tolist()} m/s^2, scene says {np.round(g_scene, 12).tolist()} m/s^2")


def gravity_problem(g_loaded: np.ndarray, g_scene: np.ndarray, rtol: float = 1e-9) -> str | None:
    """A message when the loaded gravity (m/s^2, world) differs from the scene's, else None."""
    d = gravity_discrepancy(g_loaded, g_scene, rtol)
    return None if d.passed else d.message
