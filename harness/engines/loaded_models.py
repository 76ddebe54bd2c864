"""What each engine holds after loading a scene's model, compared with the scene description.

``mujoco_bodies`` / ``pinocchio_bodies`` / ``exudyn_bodies`` read back, per scene body: mass (kg), centre of mass in
the body frame (m), inertia about the centre of mass in the body frame (kg m^2), the body
frame's position in its parent (m), joint type and hinge axis (body frame); Drake's is
``harness.engines.drake.model.drake_bodies`` (``LoadedBody`` records too, joint kinds by ``drake_joint_kind``),
PyBullet's ``harness.engines.pybullet.model.pybullet_bodies`` (``getDynamicsInfo``, ``getJointInfo``).
``body_discrepancies`` measures every quantity against the ``Multibody`` (``Discrepancy``: value,
tolerance, unit, message); ``compare_bodies`` lists the disagreements beyond a relative tolerance.
``harness.engines.as_written`` applies them to a scene's model files as written (``validate``'s
``model.*`` checks, ``inspect``).

For any model file (no scene), ``mujoco_joint_bodies`` / ``pinocchio_joint_bodies`` read back,
per joint, the rigid body it moves (fixed children merged) in the frame of its child link, and
``compare_joint_bodies`` compares two engines joint by joint (matched by name);
``check_joint_bodies_physical`` rejects non-positive masses and invalid inertia tensors. Each
``JointBody`` also lists its ``parts`` (``Part``: the body itself and the fixed children merged
into it, each with its own mass properties, named by body/link), so that a disagreement in a
merged body can be traced to one fixed child. Drake as a third reader of any model file, joint
limits and damping, and Pinocchio's composite joints are ``harness check``'s
(``harness.tools.loaded_models``).
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
    stiffness (N/m), damping (N s/m) and rest length (m), and its two sites on the right bodies at the right
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
        c = float(np.atleast_1d(m.tendon_damping[tid])[0])
        out.append(Discrepancy(sp.name, "damping", abs(c - sp.damping) / max(sp.damping, 1e-12), rtol, "rel",
                               f"{sp.name}: damping {c:.9g} N s/m, scene says {sp.damping:.9g} N s/m"))
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


def drake_joint_kind(joint) -> str:
    """The harness name of a Drake joint's kind (``JointType.drake``), else Drake's ``type_name()``."""
    jt = by_drake(joint.type_name())
    return jt.name if jt is not None else joint.type_name()
