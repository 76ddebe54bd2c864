"""What each engine sees after loading a scene's model, compared with the scene description.

``mujoco_bodies`` / ``pinocchio_bodies`` / ``exudyn_bodies`` read back, per scene body: mass (kg), centre of mass in
the body frame (m), inertia about the centre of mass in the body frame (kg m^2), the body
frame's position in its parent (m), joint type and hinge axis (body frame).
``body_discrepancies`` measures every quantity against the ``Multibody`` (``Discrepancy``: value,
tolerance, unit, message); ``compare_bodies`` lists the disagreements beyond a relative tolerance.

For any model file (no scene), ``mujoco_joint_bodies`` / ``pinocchio_joint_bodies`` read back,
per joint, the rigid body it moves (fixed children merged) in the frame of its child link, and
``compare_joint_bodies`` compares two engines joint by joint (matched by name);
``check_joint_bodies_physical`` rejects non-positive masses and invalid inertia tensors. Each
``JointBody`` also lists its ``parts`` (``Part``: the body itself and the fixed children merged
into it, each with its own mass properties, named by body/link), so that a disagreement in a
merged body can be traced to one fixed child.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin

from harness.engines.mujoco.model import joint_kind as mujoco_joint_kind
from harness.engines.pinocchio.model import joint_kind as pin_joint_kind
from harness.engines.pinocchio.model import joint_type as pin_joint_type
from harness.model import rotations
from harness.model.forces import JOINT_SPRINGS, JOINT_TORQUES, POINT_SPRINGS
from harness.model.joints import FREE, JOINTS, ROTATIONAL, TRANSLATIONAL, by_drake, by_exudyn
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


def mujoco_loop_discrepancies(m, model: Multibody, rtol: float = 1e-9) -> list[Discrepancy]:
    """Every cut joint of the description (``Multibody.loops``) against the compiled MJCF's
    site-based ``<connect>`` equalities that state it (``harness.engines.mujoco.loops.connects``):
    each equality present, each site on the right body, at the right point (distance over the
    loop's length scale, the largest |p| of its points, at least 1 mm). Each is named by the
    equality (``body`` = its name, ``quantity`` = ``present``, ``site1``, ``site2`` or
    ``site<k>_body``), so a validation check reads ``model.cut_2.site1``."""
    from harness.engines.mujoco.loops import connects, loop_points

    found = loop_points(m)
    out = []
    for loop in model.loops:
        for eq_name, *ends in connects(loop):
            if eq_name not in found:
                out.append(Discrepancy(eq_name, "present", 1.0, 0.0, "",
                                       f"{loop.name}: no site-based <connect> named {eq_name!r}"))
                continue
            length = max([1e-3] + [float(np.linalg.norm(pos)) for _, _, pos in ends])
            for k, ((site, body, pos), (got_body, got_pos)) in enumerate(zip(ends, found[eq_name]), start=1):
                want = body or "world"
                if got_body != want:
                    out.append(Discrepancy(eq_name, f"site{k}_body", 1.0, 0.0, "",
                                           f"{loop.name}: {eq_name} site{k} on body {got_body!r}, scene says {want!r}"))
                    continue
                out.append(Discrepancy(eq_name, f"site{k}", float(np.linalg.norm(got_pos - pos)) / length, rtol,
                                       "rel", f"{loop.name}: {eq_name} site{k} at {got_pos.tolist()} m in {want}, "
                                              f"scene says {pos.tolist()} m"))
    return out


def mujoco_force_discrepancies(m, model: Multibody, rtol: float = 1e-9) -> list[Discrepancy]:
    """The description's joint torques and point springs (``harness.model.forces``) against a
    compiled MJCF: each torque's ``<general>`` actuator present, on its body's joint, with zero
    gain and constant bias equal to the torque (N m); each spring's tendon present with its
    stiffness (N/m) and rest length (m), and its two sites on the right bodies at the right
    points. Named by the element (``body`` = the actuator or tendon, ``quantity`` e.g.
    ``stiffness``), so a validation check reads ``model.spring.stiffness``."""
    out = []
    for tq in JOINT_TORQUES.elements(model):
        aid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, tq.name)
        bid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, tq.body)
        if aid < 0 or bid < 0 or m.actuator_trntype[aid] != mujoco.mjtTrn.mjTRN_JOINT \
                or m.actuator_trnid[aid, 0] != m.body_jntadr[bid]:
            out.append(Discrepancy(tq.name, "present", 1.0, 0.0, "", f"{tq.name}: no actuator on the joint of {tq.body!r}"))
            continue
        got = float(m.actuator_biasprm[aid, 0]) * float(m.actuator_gear[aid, 0])
        constant = not np.any(m.actuator_gainprm[aid, :1]) and not np.any(m.actuator_biasprm[aid, 1:3])
        out.append(Discrepancy(tq.name, "torque", abs(got - tq.torque) / max(abs(tq.torque), 1e-12) if constant else 1.0,
                               rtol, "rel", f"{tq.name}: constant torque {got:.9g} N m"
                               + ("" if constant else " (not constant: gain or state-dependent bias)")
                               + f", scene says {tq.torque:.9g} N m"))
    for sp in POINT_SPRINGS.elements(model):
        tid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_TENDON, sp.name)
        if tid < 0:
            out.append(Discrepancy(sp.name, "present", 1.0, 0.0, "", f"{sp.name}: no tendon named {sp.name!r}"))
            continue
        k = float(np.atleast_1d(m.tendon_stiffness[tid])[0])
        rest = np.asarray(m.tendon_lengthspring[tid], dtype=float)
        out.append(Discrepancy(sp.name, "stiffness", abs(k - sp.stiffness) / max(sp.stiffness, 1e-12), rtol, "rel",
                               f"{sp.name}: stiffness {k:.9g} N/m, scene says {sp.stiffness:.9g} N/m"))
        scale = max(sp.rest_length, 1e-3)
        out.append(Discrepancy(sp.name, "rest_length", float(np.max(np.abs(rest - sp.rest_length))) / scale, rtol, "rel",
                               f"{sp.name}: spring length {rest.tolist()} m, scene says {sp.rest_length:.9g} m"))
        for end, body, point in (("a", sp.body_a, sp.p_A), ("b", sp.body_b, sp.p_B)):
            sid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, f"{sp.name}_{end}")
            want = 0 if body is None else mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, body)
            if sid < 0 or m.site_bodyid[sid] != want:
                out.append(Discrepancy(sp.name, f"site_{end}_body", 1.0, 0.0, "",
                                       f"{sp.name}: site {sp.name}_{end} not on {body or 'world'!r}"))
                continue
            pos = np.asarray(m.site_pos[sid], dtype=float)
            length = max(1e-3, float(np.linalg.norm(point)))
            out.append(Discrepancy(sp.name, f"site_{end}", float(np.linalg.norm(pos - point)) / length, rtol, "rel",
                                   f"{sp.name}: site {sp.name}_{end} at {pos.tolist()} m, scene says {np.asarray(point).tolist()} m"))
    return out


def compare_bodies(loaded: list[LoadedBody], model: Multibody, rtol: float = 1e-9) -> list[str]:
    """Disagreements between loaded bodies and the scene description, one message each
    (the failing ``body_discrepancies``)."""
    return [d.message for d in body_discrepancies(loaded, model, rtol) if not d.passed]


# --------------------------------------------------------------------------- any model, per joint


@dataclass(frozen=True)
class Part:
    """One body/link merged into the rigid body a joint moves (the body itself or a fixed child).

    Attributes:
        name: the body (MuJoCo, Drake) or link (Pinocchio) name.
        mass: kg; ``p_BCm_B``: its centre of mass in the frame B of the joint's body (m);
        ``I_Cm_B``: its inertia about its own centre of mass, in B (kg m^2).
    """

    name: str
    mass: float
    p_BCm_B: np.ndarray
    I_Cm_B: np.ndarray


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
        parts: the bodies merged into it (``Part``, the body itself first, then its fixed
            children), whose composite is (mass, p_BCm_B, I_Cm_B); empty where the loader does
            not tell them apart (a body MuJoCo's ``fusestatic`` fused is already one body) or
            for a joint that carries no mass (not the last joint of its body).
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
    parts: tuple[Part, ...] = ()


def _composite(parts) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass, centre of mass and inertia about it of ``(m, c, I)`` parts or ``Part`` records (one frame)."""
    parts = [(p.mass, p.p_BCm_B, p.I_Cm_B) if isinstance(p, Part) else p for p in parts]
    mass = float(sum(p[0] for p in parts))
    if mass <= 0.0:
        return mass, np.zeros(3), sum((p[2] for p in parts), np.zeros((3, 3)))
    com = sum(p[0] * p[1] for p in parts) / mass
    inertia = np.zeros((3, 3))
    for m_k, c_k, I_k in parts:
        d = c_k - com
        inertia += I_k + m_k * (d @ d * np.eye(3) - np.outer(d, d))
    return mass, com, inertia


def mujoco_joint_bodies(m: mujoco.MjModel, qpos: np.ndarray | None = None) -> list[JointBody]:
    """Per MuJoCo joint (model order): the composite body it moves, at the configuration
    ``qpos`` (default ``qpos0``). MuJoCo turns a hinge or slide by ``qpos - qpos0``, ``qpos0``
    holding its ``ref``: at ``qpos`` = 0 the body stands where the joint coordinate is 0, as
    Pinocchio's ``neutral`` and Drake's zero positions put it.

    A body without joints belongs to its nearest ancestor with a joint (or to the world). A
    body with several joints is reported at its last joint; its other joints get mass 0.
    """
    d = mujoco.MjData(m)
    d.qpos[:] = m.qpos0 if qpos is None else qpos
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
        for k in ([b] + [k for k in range(1, m.nbody) if k != b and owner[k] == b]) if last else []:
            Rk = d.ximat[k].reshape(3, 3)
            parts.append(Part(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, k) or f"body{k}", float(m.body_mass[k]),
                              R_WB.T @ (d.xipos[k] - p_WB), R_WB.T @ Rk @ np.diag(m.body_inertia[k]) @ Rk.T @ R_WB))
        mass, com, inertia = _composite(parts) if parts else (0.0, np.zeros(3), np.zeros((3, 3)))
        pb = owner[m.body_parentid[b]]
        R_WP, p_WP = d.xmat[pb].reshape(3, 3), d.xpos[pb]
        kind = mujoco_joint_kind(m, j)
        axis = np.array(m.jnt_axis[j]) if has_axis(kind) else np.zeros(3)
        out.append(JointBody(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint{j}",
                             mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}", kind, mass, com, inertia,
                             mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, pb) or "world",
                             R_WP.T @ (p_WB - p_WP), R_WP.T @ R_WB, axis / max(np.linalg.norm(axis), 1e-300),
                             tuple(parts)))
    return out


def has_axis(kind: str) -> bool:
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


def _pin_parts(pmodel: pin.Model, jid: int, fid: int, jMb: pin.SE3) -> tuple[Part, ...]:
    """The links merged into joint ``jid``'s inertia, in the frame B of its body frame ``fid``:
    Pinocchio's parsers keep a fixed child's inertia on the child's frame (``Frame.inertia``, in
    that frame; its placement relative to the joint), and the body's own part is the rest of
    ``inertias[jid]``. A fixed child is named by its BODY frame (the frame after its fixed
    joint). Empty when the frames do not add up (a part with negative mass)."""
    children = []
    for k, f in enumerate(pmodel.frames):
        if k == fid or f.parentJoint != jid or f.type == pin.FrameType.JOINT:
            continue
        if f.inertia.mass == 0.0 and not np.any(np.asarray(f.inertia.inertia)):
            continue
        name = next((g.name for g in pmodel.frames if g.type == pin.FrameType.BODY and g.parentFrame == k
                     and g.parentJoint == jid), f.name)
        inertia = jMb.actInv(f.placement.act(f.inertia))
        children.append(Part(name, float(inertia.mass), np.array(inertia.lever), np.array(inertia.inertia)))
    total = jMb.actInv(pmodel.inertias[jid])
    rest = _remainder((float(total.mass), np.array(total.lever), np.array(total.inertia)), children)
    if rest is None:
        return ()
    return (Part(pmodel.frames[fid].name, *rest),) + tuple(children)


def _remainder(whole, parts, tol: float = 1e-12):
    """(m, c, I) of ``whole`` less ``parts`` (``Part`` records, one frame); None when the
    remainder's mass is negative."""
    m, c, I = whole
    rest_m = m - sum(p.mass for p in parts)
    if rest_m < -tol * max(m, 1.0):
        return None
    rest_m = max(rest_m, 0.0)

    def about_origin(mk, ck, Ik):
        return Ik + mk * (float(ck @ ck) * np.eye(3) - np.outer(ck, ck))

    first = m * c - sum((p.mass * p.p_BCm_B for p in parts), np.zeros(3))
    rest_c = first / rest_m if rest_m > 0.0 else np.zeros(3)
    I_O = about_origin(m, c, I) - sum((about_origin(p.mass, p.p_BCm_B, p.I_Cm_B) for p in parts), np.zeros((3, 3)))
    return rest_m, rest_c, I_O - rest_m * (float(rest_c @ rest_c) * np.eye(3) - np.outer(rest_c, rest_c))


def pinocchio_joint_bodies(pmodel: pin.Model) -> list[JointBody]:
    """Per Pinocchio joint (model order, universe excluded): the body it moves (``inertias[j]``:
    Pinocchio merges fixed children into it), in the frame of the child link, at ``neutral``;
    its ``parts`` from the fixed children's frames (``_pin_parts``)."""
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
                             np.array(pMb.translation), np.array(pMb.rotation), axis, _pin_parts(pmodel, jid, fid, jMb)))
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
        if x.kind == y.kind and has_axis(x.kind) and np.linalg.norm(x.axis_B - y.axis_B) > max(rtol, 1e-12):
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


def drake_joint_kind(joint) -> str:
    """The harness name of a Drake joint's kind (``JointType.drake``), else Drake's ``type_name()``."""
    jt = by_drake(joint.type_name())
    return jt.name if jt is not None else joint.type_name()


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
