"""Joint-space dynamics of each engine at random states, compared term by term before any run.

For a few seeded random joint states (q, v) every source gives, in COMMON coordinates,

* ``M``: the joint-space mass matrix M(q) (kg, kg m, kg m^2 by dof type);
* ``bias``: Coriolis and centrifugal forces C(q, v) v, without gravity (N or N m);
* ``gravity``: the gravity forces g(q) = dV/dq (N or N m), with the sign of an equation
  ``M a + C v + g = tau`` (MuJoCo's ``qfrc_bias`` at v = 0, Pinocchio's
  ``computeGeneralizedGravity``).

Common coordinates are those of the joint table (``harness.model.joints``), which are MuJoCo's,
joint by joint in the order of a ``JointMap``; sizes, random states and the retraction come from
the table, the conversions to Pinocchio's coordinates from ``harness.engines.pinocchio.model``
(``to_pinocchio``, ``velocity_transform``):

* ``hinge`` / ``slide``: q = angle (rad) / displacement (m), v = its rate;
* ``ball``: q = quaternion ``wxyz`` of the body relative to its parent, v = angular velocity of
  the body relative to the parent, expressed in the body frame (rad/s);
* ``free``: q = [p_WB_W (m), quaternion ``wxyz`` body to world], v = [v_WB_W (m/s, velocity of
  the body-frame origin in WORLD), w_WB_B (rad/s, BODY frame)].

Pinocchio's free flyer has v_pin = [v_WB_B, w_WB_B] (linear velocity in the BODY frame), so
v = T v_pin with T = blockdiag(R_WB, I3) on a free joint's dofs (identity elsewhere). Power is
invariant, so generalized forces map as tau_pin = T^T tau; with ``T^-T = T`` (R orthonormal):

    M = T M_pin T^T,        g = T g_pin,        C v = T (C v)_pin - M (dT/dt v_pin),

where the last term comes from a = T a_pin + (dT/dt) v_pin; on a free joint's linear rows
(dT/dt) v_pin = dR/dt v_WB_B = w_WB_W x v_WB_W, zero elsewhere. (Derivation: substitute
a = T a_pin + dT v_pin into M a + b = tau and multiply by T^T: T^T M T a_pin + T^T (b + M dT v_pin)
= T^T tau, hence b_pin = T^T (b + M dT v_pin).)

Drake (``drake_terms``, any model file in ``harness check``): M from ``CalcMassMatrix``, C v from
``CalcBiasTerm`` and g = -``CalcGravityGeneralizedForces`` (Drake's is the force of gravity, on
the right-hand side). Drake orders q and v by its own joints, so each joint is placed by name
(``joint_map``: ``position_start``/``velocity_start``); hinge and slide coordinates are the
common ones, a free joint (quaternion floating joint) has q = [quat wxyz, p_WB_W] and
v = [w_WB_W, v_WB_W], so v = T v_drake with the blocks v_WB_W = v_lin and w_WB_B = R_WB^T w_W.
T is orthogonal on the mapped dofs and dT/dt v_drake = 0 (d(R^T)/dt w_W = -R^T (w_W x w_W)), so
M = T M_d T^T, C v = T (C v)_d, g = T g_d. Drake's roll-pitch-yaw ball joint is not mapped.

The in-house source is the scene's ``Multibody`` itself, through ``harness.model.kinematics.forward``
and ``harness.measure.invariants``: M by polarisation of the kinetic energy (exact: T is quadratic in v),
g by a fourth-order central difference of the potential energy along the joint manifold (step
1e-3, error ~1e-12 relative), C v by Kane's method, sum over bodies of J_b^T (m a_b ; I alpha_b +
w x I w) with J_b the body's velocity Jacobian and (a_b, alpha_b) the centre-of-mass and angular
accelerations at zero joint acceleration (fourth-order central difference of the body twists along
the zero-acceleration flow).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Mapping, Sequence

import mujoco
import numpy as np
import pinocchio as pin

from harness.engines.mujoco.model import body_joint
from harness.engines.mujoco.model import joint_kind as mujoco_joint_kind
from harness.engines.pinocchio.model import joint_kind as pin_joint_kind
from harness.engines.pinocchio.model import to_pinocchio, velocity_transform
from harness.measure import invariants
from harness.model import kinematics, rotations
from harness.model.joints import JOINTS, JointType
from harness.model.multibody import Multibody
from harness.measure.trajectory import Trajectory

TERMS = ("M", "bias", "gravity")
DEFAULT_RTOL = 1e-8     # relative to the term's largest entry; engines agree to ~1e-14
DEFAULT_STATES = 4
FD_STEP = 1e-3          # rad or m; fourth-order differences, truncation ~FD_STEP^4

class MappingError(ValueError):
    """Two models' joints cannot be put into common coordinates (missing joint, other type)."""


# --------------------------------------------------------------------------- joint maps


@dataclass(frozen=True)
class JointSlot:
    """One joint in common coordinates and where it lives in each engine.

    Attributes:
        name: body name (scene maps) or joint name (maps by joint name).
        kind: the joint kind, a key of ``harness.model.joints.JOINTS``.
        qc, vc: offsets in the common q and v vectors.
        mj_q, mj_v: ``qpos``/``qvel`` addresses in MuJoCo (-1 where there is no MuJoCo model).
        pin_q, pin_v, pin_joint: ``idx_q``, ``idx_v`` and joint id in Pinocchio (-1 where none).
        pin_nq: Pinocchio's nq for the joint (2 for a continuous revolute joint: cos, sin).
        limits: (lower, upper) of q for a limited hinge or slide, else None.
        drake_q, drake_v: ``position_start``/``velocity_start`` of the joint in a Drake plant
            (-1 where none).
    """

    name: str
    kind: str
    qc: int
    vc: int
    mj_q: int = -1
    mj_v: int = -1
    pin_q: int = -1
    pin_v: int = -1
    pin_joint: int = -1
    pin_nq: int = 0
    limits: tuple[float, float] | None = None
    drake_q: int = -1
    drake_v: int = -1

    @property
    def joint(self) -> JointType:
        """The joint kind's record in the joint table."""
        return JOINTS[self.kind]

    def q(self, q: np.ndarray) -> np.ndarray:
        """This joint's entries of a common configuration vector."""
        return q[self.qc:self.qc + self.joint.nq]

    def v(self, v: np.ndarray) -> np.ndarray:
        """This joint's entries of a common velocity vector."""
        return v[self.vc:self.vc + self.joint.nv]


@dataclass(frozen=True)
class JointMap:
    """Joints in common order; ``nq``/``nv`` are the common vector sizes."""

    slots: tuple[JointSlot, ...]

    @property
    def nq(self) -> int:
        return sum(s.joint.nq for s in self.slots)

    @property
    def nv(self) -> int:
        return sum(s.joint.nv for s in self.slots)

    def dof_names(self) -> list[str]:
        names = []
        for s in self.slots:
            n = s.joint.nv
            names += [s.name] if n == 1 else [f"{s.name}[{i}]" for i in range(n)]
        return names


def _build(entries) -> JointMap:
    slots, qc, vc = [], 0, 0
    for e in entries:
        slots.append(JointSlot(qc=qc, vc=vc, **e))
        qc, vc = qc + JOINTS[e["kind"]].nq, vc + JOINTS[e["kind"]].nv
    return JointMap(tuple(slots))


def scene_joint_map(model: Multibody, m: mujoco.MjModel | None = None, pmodel: pin.Model | None = None) -> JointMap:
    """Common coordinates of a scene: one joint per body, in ``model.bodies`` order.

    MuJoCo: the joint of the body of the same name; Pinocchio: the parent joint of the frame of
    the same name. Raises MappingError when a body is missing or its joint has another type.
    """
    entries = []
    for body in model.bodies:
        e = {"name": body.name, "kind": body.joint}
        if m is not None:
            try:
                jid = body_joint(m, body.name)
            except LookupError as err:
                raise MappingError(f"MuJoCo model: {err} (the scene gives {body.name!r} one {body.joint} joint)") from None
            kind = mujoco_joint_kind(m, jid, "?")
            if kind != body.joint:
                raise MappingError(f"MuJoCo body {body.name!r} has a {kind} joint, the scene says {body.joint}")
            e.update(mj_q=int(m.jnt_qposadr[jid]), mj_v=int(m.jnt_dofadr[jid]))
        if pmodel is not None:
            if not pmodel.existFrame(body.name):
                raise MappingError(f"Pinocchio model has no frame {body.name!r}")
            jid = int(pmodel.frames[pmodel.getFrameId(body.name)].parentJoint)
            kind = pin_joint_kind(pmodel.joints[jid])
            if kind != body.joint:
                raise MappingError(f"Pinocchio moves {body.name!r} with {kind}, the scene says {body.joint}")
            e.update(pin_q=int(pmodel.joints[jid].idx_q), pin_v=int(pmodel.joints[jid].idx_v), pin_joint=jid,
                     pin_nq=int(pmodel.joints[jid].nq))
        entries.append(e)
    return _build(entries)


def named_joint_map(m: mujoco.MjModel, pmodel: pin.Model) -> JointMap:
    """Common coordinates of any model loaded in both engines: joints matched by NAME, in
    MuJoCo's order. Every joint of each engine must be matched, with the same type."""
    mj_names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint{j}" for j in range(m.njnt)]
    pin_names = list(pmodel.names)[1:]
    missing_pin = [n for n in mj_names if n not in pin_names]
    missing_mj = [n for n in pin_names if n not in mj_names]
    if missing_pin or missing_mj:
        parts = []
        if missing_pin:
            parts.append(f"MuJoCo joints {missing_pin} have no Pinocchio joint of that name")
        if missing_mj:
            parts.append(f"Pinocchio joints {missing_mj} have no MuJoCo joint of that name")
        raise MappingError("; ".join(parts))
    entries = []
    for j, name in enumerate(mj_names):
        kind = mujoco_joint_kind(m, j, "?")
        pid = int(pmodel.getJointId(name))
        pkind = pin_joint_kind(pmodel.joints[pid])
        if pkind != kind:
            raise MappingError(f"joint {name!r} is {kind} in MuJoCo and {pkind} in Pinocchio")
        limits = None
        if JOINTS[kind].axis is not None and m.jnt_limited[j]:
            limits = (float(m.jnt_range[j][0]), float(m.jnt_range[j][1]))
        entries.append({"name": name, "kind": kind, "mj_q": int(m.jnt_qposadr[j]), "mj_v": int(m.jnt_dofadr[j]),
                        "pin_q": int(pmodel.joints[pid].idx_q), "pin_v": int(pmodel.joints[pid].idx_v),
                        "pin_joint": pid, "pin_nq": int(pmodel.joints[pid].nq), "limits": limits})
    return _build(entries)


def joint_map(m: mujoco.MjModel, pinocchio: Mapping[str, Mapping[str, int]] | None = None,
              drake: Mapping[str, Mapping[str, int]] | None = None, only: Sequence[str] | None = None) -> JointMap:
    """Common coordinates of any model file: MuJoCo's joints in MuJoCo's order, each with its
    place in the other loaders that are given, by joint name: ``pinocchio`` maps a joint name to
    ``pin_q``, ``pin_v``, ``pin_joint``, ``pin_nq`` (a composite joint's sub-joint: its own
    ``idx_q``/``idx_v`` and the composite's id), ``drake`` to ``drake_q``, ``drake_v``. ``only``:
    the joints to map (default all of MuJoCo's; the others stay at ``qpos0``, at rest: right
    when they are whole kinematic trees of their own, which do not enter the mapped joints' M,
    bias and gravity). Raises MappingError when a given loader lacks one of the mapped joints or
    has joints MuJoCo has not."""
    every = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint{j}" for j in range(m.njnt)]
    names = every if only is None else [n for n in every if n in set(only)]
    for label, table in (("Pinocchio", pinocchio), ("Drake", drake)):
        if table is None:
            continue
        missing, extra = [n for n in names if n not in table], [n for n in table if n not in every]
        if missing or extra:
            parts = ([f"MuJoCo joints {missing} are not in {label}"] if missing else []) + (
                [f"{label} joints {extra} are not in MuJoCo"] if extra else [])
            raise MappingError("; ".join(parts))
    entries = []
    for j, name in enumerate(every):
        if name not in names:
            continue
        kind = mujoco_joint_kind(m, j, "?")
        limits = None
        if JOINTS[kind].axis is not None and m.jnt_limited[j]:
            limits = (float(m.jnt_range[j][0]), float(m.jnt_range[j][1]))
        e = {"name": name, "kind": kind, "mj_q": int(m.jnt_qposadr[j]), "mj_v": int(m.jnt_dofadr[j]), "limits": limits}
        e.update((pinocchio or {}).get(name, {}))
        e.update((drake or {}).get(name, {}))
        entries.append(e)
    return _build(entries)


# --------------------------------------------------------------------------- states


def random_states(jmap: JointMap, n: int, seed: int = 0) -> list[tuple[np.ndarray, np.ndarray]]:
    """``n`` seeded random states (q, v) in common coordinates, each joint drawn by its kind
    (``JointType.draw``):

    Hinge: angle uniform in [-pi, pi] intersected with its limits, rate ~ N(0, 1) rad/s; slide:
    uniform in [-0.5, 0.5] m intersected with its limits, rate ~ N(0, 0.5) m/s (a range that
    does not meet the default one is used as it is); ball: uniform random unit quaternion,
    rate ~ N(0, 1) rad/s per axis; free: position uniform in [-1, 1]^3 m, random quaternion,
    velocities ~ N(0, 1).
    """
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        q, v = np.zeros(jmap.nq), np.zeros(jmap.nv)
        for s in jmap.slots:
            s.q(q)[:], s.v(v)[:] = s.joint.draw(rng, s.limits)
        out.append((q, v))
    return out


def retract(jmap: JointMap, q: np.ndarray, delta: np.ndarray) -> np.ndarray:
    """q "plus" a tangent vector ``delta`` (common velocity coordinates): the configuration
    reached in unit time at constant common velocity ``delta`` (``JointType.retract``: hinge/slide
    q + d; ball quat * exp(d); free p + d_lin (world), quat * exp(d_ang) (body frame))."""
    out = np.array(q, dtype=float)
    for s in jmap.slots:
        s.q(out)[:] = s.joint.retract(s.q(out), s.v(delta))
    return out


# --------------------------------------------------------------------------- terms


@dataclass(frozen=True)
class Terms:
    """Dynamics terms at one state in common coordinates (see module docstring)."""

    M: np.ndarray
    bias: np.ndarray
    gravity: np.ndarray

    def term(self, name: str) -> np.ndarray:
        return getattr(self, name)


def mujoco_state(m: mujoco.MjModel, jmap: JointMap, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """MuJoCo ``qpos``/``qvel`` for a common state (unmapped joints at ``qpos0``, at rest)."""
    qpos, qvel = np.array(m.qpos0, dtype=float), np.zeros(m.nv)
    for s in jmap.slots:
        qpos[s.mj_q:s.mj_q + s.joint.nq] = s.q(q)
        qvel[s.mj_v:s.mj_v + s.joint.nv] = s.v(v)
    return qpos, qvel


def _mj_dofs(jmap: JointMap) -> np.ndarray:
    return np.array([i for s in jmap.slots for i in range(s.mj_v, s.mj_v + s.joint.nv)], dtype=int)


def _pin_dofs(jmap: JointMap) -> np.ndarray:
    return np.array([i for s in jmap.slots for i in range(s.pin_v, s.pin_v + s.joint.nv)], dtype=int)


def mujoco_terms(m: mujoco.MjModel, jmap: JointMap, q: np.ndarray, v: np.ndarray, d: mujoco.MjData | None = None) -> Terms:
    """M from ``mj_fullM`` (after ``mj_forward``; includes ``dof_armature``), C v + g from
    ``qfrc_bias``, g from ``qfrc_bias`` at v = 0."""
    d = d or mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = mujoco_state(m, jmap, q, v)
    mujoco.mj_forward(m, d)
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    total = np.array(d.qfrc_bias)
    d.qvel[:] = 0.0
    mujoco.mj_forward(m, d)
    g = np.array(d.qfrc_bias)
    idx = _mj_dofs(jmap)
    return Terms(M[np.ix_(idx, idx)], (total - g)[idx], g[idx])


def pinocchio_state(pmodel: pin.Model, jmap: JointMap, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pinocchio (q, v) for a common state: quaternions ``wxyz`` -> ``xyzw``; a free joint's
    linear velocity world -> body frame, its pose taken relative to the joint placement; a
    continuous revolute joint's angle as (cos, sin)."""
    qp, vp = pin.neutral(pmodel), np.zeros(pmodel.nv)
    for s in jmap.slots:
        qj, vj = to_pinocchio(s.joint, s.q(q), s.v(v), s.pin_nq, pmodel.jointPlacements[s.pin_joint])
        qp[s.pin_q:s.pin_q + len(qj)] = qj
        vp[s.pin_v:s.pin_v + len(vj)] = vj
    return qp, vp


def velocity_map(jmap: JointMap, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """T (common v = T v_pin) and dT/dt v_pin, both in common dof order (see module docstring)."""
    T, Tdot_v = np.eye(jmap.nv), np.zeros(jmap.nv)
    for s in jmap.slots:
        block = velocity_transform(s.joint, s.q(q), s.v(v))
        if block is not None:
            dofs = slice(s.vc, s.vc + s.joint.nv)
            T[dofs, dofs], Tdot_v[dofs] = block
    return T, Tdot_v


def pinocchio_terms(pmodel: pin.Model, jmap: JointMap, q: np.ndarray, v: np.ndarray, data: pin.Data | None = None) -> Terms:
    """M from ``crba`` (upper triangle symmetrised; includes ``model.armature``), C v + g from
    ``nonLinearEffects``, g from ``computeGeneralizedGravity``; mapped to common coordinates."""
    data = data or pmodel.createData()
    qp, vp = pinocchio_state(pmodel, jmap, q, v)
    M = np.triu(pin.crba(pmodel, data, qp))
    M = M + np.triu(M, 1).T
    nle = np.array(pin.nonLinearEffects(pmodel, data, qp, vp))
    g = np.array(pin.computeGeneralizedGravity(pmodel, data, qp))
    idx = _pin_dofs(jmap)
    M, nle, g = M[np.ix_(idx, idx)], nle[idx], g[idx]
    T, Tdot_v = velocity_map(jmap, q, v)
    Mc = T @ M @ T.T
    return Terms(Mc, T @ (nle - g) - Mc @ Tdot_v, T @ g)


def drake_state(plant, jmap: JointMap, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drake (q, v) for a common state (joints not in the map at the plant's default positions, at
    rest). Hinge and slide: the same. Free (Drake's quaternion floating joint): q = [quaternion
    wxyz, p_WB_W], v = [w_WB_W (angular velocity in WORLD), v_WB_W] -- angular first, both in the
    world frame, where the common v is [v_WB_W, w_WB_B]."""
    qd, vd = np.array(plant.GetDefaultPositions(), dtype=float), np.zeros(plant.num_velocities())
    for s in jmap.slots:
        qj, vj = s.q(q), s.v(v)
        if s.joint.world_linear_velocity:
            R = rotations.matrix(qj[3:7])
            qd[s.drake_q:s.drake_q + 7] = np.concatenate([qj[3:7], qj[:3]])
            vd[s.drake_v:s.drake_v + 6] = np.concatenate([R @ vj[3:6], vj[:3]])
        elif s.joint.nq == 1:
            qd[s.drake_q], vd[s.drake_v] = qj[0], vj[0]
        else:
            raise MappingError(f"joint {s.name!r}: no Drake coordinates for a {s.kind} joint")
    return qd, vd


def drake_velocity_map(plant, jmap: JointMap, q: np.ndarray) -> np.ndarray:
    """T with common v = T v_drake (rows: common dofs in map order; columns: Drake's dofs). A free
    joint's block: v_WB_W = the linear part of Drake's v, w_WB_B = R_WB^T times its angular part.
    T restricted to the mapped dofs is orthogonal and dT/dt v_drake = 0 (d(R^T)/dt w_W =
    -R^T (w_W x w_W) = 0), so M = T M_d T^T, C v = T (C v)_d, g = T g_d."""
    T = np.zeros((jmap.nv, plant.num_velocities()))
    for s in jmap.slots:
        if s.joint.world_linear_velocity:
            R = rotations.matrix(s.q(q)[3:7])
            T[s.vc:s.vc + 3, s.drake_v + 3:s.drake_v + 6] = np.eye(3)
            T[s.vc + 3:s.vc + 6, s.drake_v:s.drake_v + 3] = R.T
        else:
            T[s.vc, s.drake_v] = 1.0
    return T


def drake_terms(plant, jmap: JointMap, q: np.ndarray, v: np.ndarray, context=None) -> Terms:
    """M from ``CalcMassMatrix`` (includes the actuators' reflected inertia), C v from
    ``CalcBiasTerm``, g = -``CalcGravityGeneralizedForces`` (Drake's is the generalized force OF
    gravity, on the right-hand side: M vdot + C v = tau_g + tau); mapped to common coordinates
    (``drake_velocity_map``)."""
    context = context or plant.CreateDefaultContext()
    qd, vd = drake_state(plant, jmap, q, v)
    plant.SetPositions(context, qd)
    plant.SetVelocities(context, vd)
    M = np.array(plant.CalcMassMatrix(context))
    cv = np.array(plant.CalcBiasTerm(context))
    g = -np.array(plant.CalcGravityGeneralizedForces(context))
    T = drake_velocity_map(plant, jmap, q)
    return Terms(T @ M @ T.T, T @ cv, T @ g)


def pybullet_terms(load, jmap: JointMap, index: Mapping[str, int], q: np.ndarray, v: np.ndarray,
                   gravity: np.ndarray) -> Terms:
    """PyBullet's terms of a fixed-base URDF it loaded (``harness.tools.loaded_models.PyBulletLoad``):
    M from ``calculateMassMatrix``, C v + g from ``calculateInverseDynamics`` at zero acceleration, g
    from it at zero velocity too, with ``setGravity(gravity)`` (m/s^2, world: the comparison's, PyBullet's
    default is zero). ``index``: joint name -> PyBullet's dof index (its movable joints in link order);
    hinge and slide coordinates are the common ones; joints not in the map at 0, at rest."""
    from harness.tools.loaded_models import _pybullet

    p = _pybullet()
    c = load.client
    n = max(index.values(), default=-1) + 1
    qp, vp = [0.0] * n, [0.0] * n
    for s in jmap.slots:
        if s.joint.nq != 1:
            raise MappingError(f"joint {s.name!r}: no PyBullet coordinates for a {s.kind} joint")
        qp[index[s.name]], vp[index[s.name]] = float(s.q(q)[0]), float(s.v(v)[0])
    p.setGravity(*np.asarray(gravity, dtype=float).tolist(), physicsClientId=c)
    M = np.array(p.calculateMassMatrix(load.body, qp, physicsClientId=c), dtype=float)
    total = np.array(p.calculateInverseDynamics(load.body, qp, vp, [0.0] * n, physicsClientId=c), dtype=float)
    g = np.array(p.calculateInverseDynamics(load.body, qp, [0.0] * n, [0.0] * n, physicsClientId=c), dtype=float)
    idx = np.array([index[s.name] for s in jmap.slots], dtype=int)
    return Terms(M[np.ix_(idx, idx)], (total - g)[idx], g[idx])


def inhouse_terms(model: Multibody, jmap: JointMap, q: np.ndarray, v: np.ndarray) -> Terms:
    """The scene's ``Multibody`` through ``kinematics.forward`` and ``invariants.energies``
    (slot names must be body names; see the module docstring for the method)."""
    nv = jmap.nv

    def kinetic(qc, vc):
        return float(invariants.energies(_snapshot(model, jmap, qc, vc), model)["kinetic"][0])

    def potential(qc):
        return float(invariants.energies(_snapshot(model, jmap, qc, np.zeros(nv)), model)["potential"][0])

    E = np.eye(nv)
    diag = np.array([kinetic(q, E[i]) for i in range(nv)])
    M = np.diag(2.0 * diag)
    for i in range(nv):
        for j in range(i + 1, nv):
            M[i, j] = M[j, i] = kinetic(q, E[i] + E[j]) - diag[i] - diag[j]
    g = np.array([_d4(lambda h, i=i: potential(retract(jmap, q, h * E[i])), FD_STEP) for i in range(nv)])
    return Terms(M, _kane_bias(model, jmap, q, v), g)


def _snapshot(model: Multibody, jmap: JointMap, q: np.ndarray, v: np.ndarray) -> Trajectory:
    """A one-sample ``Trajectory`` of the scene's bodies at common state (q, v)."""
    states = kinematics.forward(model, *_per_body(jmap, q, v))
    names = tuple(b.name for b in model.bodies)

    def stack(attr):
        return np.stack([getattr(states[n], attr) for n in names])[None]

    return Trajectory("inhouse", "-", names, np.zeros(1), stack("p_WCm_W"), stack("quat_WB"),
                      stack("v_WCm_W"), stack("w_WB_W"))


def _per_body(jmap: JointMap, q: np.ndarray, v: np.ndarray):
    qd = {s.name: s.q(q) for s in jmap.slots}
    vd = {s.name: s.v(v) for s in jmap.slots}
    return qd, vd


def _twists(model: Multibody, jmap: JointMap, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(nbody, 6): centre-of-mass velocity and angular velocity (world) of every body."""
    states = kinematics.forward(model, *_per_body(jmap, q, v))
    return np.stack([np.concatenate([states[b.name].v_WCm_W, states[b.name].w_WB_W]) for b in model.bodies])


def _kane_bias(model: Multibody, jmap: JointMap, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    nv = jmap.nv
    J = np.stack([_twists(model, jmap, q, e) for e in np.eye(nv)], axis=-1)  # (nb, 6, nv)
    speed = max(1.0, float(np.max(np.abs(v))))
    h = FD_STEP / speed
    acc = _d4(lambda t: _twists(model, jmap, retract(jmap, q, t * v), v), h)  # (nb, 6)
    states = kinematics.forward(model, *_per_body(jmap, q, v))
    b = np.zeros(nv)
    for i, body in enumerate(model.bodies):
        R = rotations.matrix(states[body.name].quat_WB)
        I_W = R @ body.I_Cm_B @ R.T
        w = states[body.name].w_WB_W
        wrench = np.concatenate([body.mass * acc[i, :3], I_W @ acc[i, 3:] + np.cross(w, I_W @ w)])
        b += J[i].T @ wrench
    return b


def _d4(f: Callable[[float], np.ndarray | float], h: float):
    """Fourth-order central difference f'(0) with step h."""
    return (-f(2 * h) + 8 * f(h) - 8 * f(-h) + f(-2 * h)) / (12 * h)


# --------------------------------------------------------------------------- comparison


@dataclass(frozen=True)
class TermDiff:
    """Largest difference of one term between two sources over all states.

    ``max_abs`` in the term's units; ``max_rel`` = max_abs / (largest entry of the term in
    either source over all states), 0 when both vanish.
    """

    a: str
    b: str
    term: str
    max_abs: float
    max_rel: float
    rtol: float

    @property
    def passed(self) -> bool:
        return bool(np.isfinite(self.max_rel) and self.max_rel <= self.rtol)


SourceFn = Callable[[np.ndarray, np.ndarray], Terms]


def evaluate(sources: Mapping[str, SourceFn], states: Sequence[tuple[np.ndarray, np.ndarray]]) -> dict[str, list[Terms]]:
    """Terms of every source at every state."""
    return {label: [fn(q, v) for q, v in states] for label, fn in sources.items()}


def compare_terms(results: Mapping[str, list[Terms]], pairs: Sequence[tuple[str, str]] | None = None,
                  rtol: float = DEFAULT_RTOL) -> list[TermDiff]:
    """Per pair of sources and per term, the largest absolute and relative difference."""
    labels = list(results)
    pairs = pairs or [(a, b) for i, a in enumerate(labels) for b in labels[i + 1:]]
    out = []
    for a, b in pairs:
        for term in TERMS:
            diff = max(float(np.max(np.abs(ta.term(term) - tb.term(term)), initial=0.0))
                       for ta, tb in zip(results[a], results[b]))
            # Generalized forces (bias, gravity) share one scale, floored at max|M| x 1 s^-2
            # (the force of a unit acceleration), so a term that vanishes identically (the
            # bias of a single hinge) is not judged against its own round-off.
            same_units = ("M",) if term == "M" else ("bias", "gravity", "M")
            scale = max(float(np.max(np.abs(t.term(u)), initial=0.0))
                        for ta, tb in zip(results[a], results[b]) for t in (ta, tb) for u in same_units)
            rel = diff / scale if scale > 0 else (0.0 if diff == 0 else float("inf"))
            out.append(TermDiff(a, b, term, diff, rel, rtol))
    return out


def scene_sources(model: Multibody, m: mujoco.MjModel | None, pmodel: pin.Model | None,
                  jmap: JointMap | None = None, labels: tuple[str, str, str] = ("mujoco", "pinocchio", "inhouse")) -> dict[str, SourceFn]:
    """Sources for a scene: MuJoCo and Pinocchio models (either may be None) and the in-house
    ``Multibody``, in the scene's common coordinates."""
    jmap = jmap or scene_joint_map(model, m, pmodel)
    sources: dict[str, SourceFn] = {}
    if m is not None:
        d = mujoco.MjData(m)
        sources[labels[0]] = lambda q, v: mujoco_terms(m, jmap, q, v, d)
    if pmodel is not None:
        data = pmodel.createData()
        sources[labels[1]] = lambda q, v: pinocchio_terms(pmodel, jmap, q, v, data)
    sources[labels[2]] = lambda q, v: inhouse_terms(model, jmap, q, v)
    return sources


def format_diffs(diffs: Sequence[TermDiff]) -> list[str]:
    """Table lines: pair, term, max abs, max rel, verdict."""
    lines = [f"  {'sources':<34} {'term':<8} {'max abs':>10} {'max rel':>10}  verdict"]
    for d in diffs:
        verdict = "ok" if d.passed else f"DIFFERS (> {d.rtol:.0e})"
        lines.append(f"  {d.a + ' vs ' + d.b:<34} {d.term:<8} {d.max_abs:10.3e} {d.max_rel:10.3e}  {verdict}")
    return lines
