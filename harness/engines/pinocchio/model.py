"""Load a scene's URDF into Pinocchio with the scene description's parameters.

The URDF is the model as a user writes it. URDF has no free or ball joint, so the scene says
which root joint Pinocchio adds (``free`` -> ``JointModelFreeFlyer``, ``spherical`` ->
``JointModelSpherical``). ``load_urdf`` then rewrites, from the scene's ``Multibody``, the joint
placements (body positions), the inertias (mass, centre of mass, inertia about it) and gravity.
Joint types and axes are not rewritten: they are checked (``harness.engines.loaded_models``).
A scene that names only an MJCF is read from the MJCF (``buildModelFromMJCF``, Pinocchio's own
MJCF parser): the MJCF states its root joint, so none is added.

Joint kinds map to Pinocchio's joint models through the joint table (``JointType.pinocchio``,
``pinocchio_root``; ``joint_type``, ``ROOT_JOINTS``); the per-joint conversions between common
coordinates and Pinocchio's are ``to_pinocchio``, ``from_pinocchio`` and ``velocity_transform``
(here and nowhere else).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin

from harness.model import rotations
from harness.model.errors import InputError
from harness.model.joints import JOINTS, JointType, by_pinocchio
from harness.model.multibody import Multibody
from harness.measure.trajectory import Failure, RunStop, SampleBuffer

LOCAL_WORLD_ALIGNED = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


def root_joint_model(jt: JointType):
    """The Pinocchio joint-model class added as a URDF's root joint for kind ``jt``."""
    return getattr(pin, f"JointModel{jt.pinocchio_root}")


# scene.toml's ``urdf_root_joint`` -> the joint model Pinocchio adds (None: the root link is welded)
ROOT_JOINTS = {jt.urdf_root: root_joint_model(jt) for jt in JOINTS.values() if jt.urdf_root} | {"none": None}


def joint_type(jmodel) -> JointType | None:
    """The joint kind (``harness.model.joints``) of a Pinocchio joint model: revolute (aligned or
    not, bounded or continuous: a continuous joint has nq = 2, cos and sin) is a hinge, prismatic
    a slide, the free flyer free, spherical ball; None for any other."""
    return by_pinocchio(jmodel.shortname())


def joint_kind(jmodel) -> str:
    """The harness name of a Pinocchio joint model's kind, else Pinocchio's ``shortname()``."""
    jt = joint_type(jmodel)
    return jt.name if jt is not None else jmodel.shortname()


def to_pinocchio(jt: JointType, q: np.ndarray, v: np.ndarray, nq_pin: int | None = None,
                 placement: pin.SE3 | None = None) -> tuple[np.ndarray, np.ndarray]:
    """One joint's Pinocchio (q, v) from its common coordinates (``harness.model.joints``):
    quaternions ``wxyz`` -> ``xyzw``; the free flyer's linear velocity world -> body frame, its
    pose relative to the joint ``placement`` when given; a continuous revolute joint's angle
    (``nq_pin`` 2) as (cos, sin)."""
    q, v = np.asarray(q, dtype=float), np.asarray(v, dtype=float)
    if jt.world_linear_velocity:  # free flyer: [p, quat], v = [linear (body frame), angular]
        R = rotations.matrix(q[3:7])
        if placement is None:
            qp = np.concatenate([q[:3], rotations.wxyz_to_xyzw(q[3:7])])
        else:
            qp = np.array(pin.SE3ToXYZQUAT(placement.actInv(pin.SE3(R, q[:3]))))
        return qp, np.concatenate([R.T @ v[:3], v[3:6]])
    if jt.quat_at is not None:  # spherical: a quaternion alone
        return rotations.wxyz_to_xyzw(q), v
    if jt.nq == 1:
        if nq_pin == 2:  # continuous revolute joint: (cos, sin)
            return np.array([np.cos(q[0]), np.sin(q[0])]), v
        return q, v
    raise NotImplementedError(f"no Pinocchio coordinates for a {jt.name} joint")


def from_pinocchio(jt: JointType, qp: np.ndarray, vp: np.ndarray,
                   placement: pin.SE3 | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The inverse of ``to_pinocchio``: one joint's common (q, v) from its Pinocchio (q, v)."""
    qp, vp = np.asarray(qp, dtype=float), np.asarray(vp, dtype=float)
    if jt.world_linear_velocity:
        X = pin.XYZQUATToSE3(qp)
        if placement is not None:
            X = placement * X
        q = np.concatenate([X.translation, rotations.from_matrix(X.rotation)])
        return q, np.concatenate([X.rotation @ vp[:3], vp[3:6]])
    if jt.quat_at is not None:
        return rotations.xyzw_to_wxyz(qp), vp
    if jt.nq == 1:
        return np.array([np.arctan2(qp[1], qp[0]) if len(qp) == 2 else qp[0]]), vp
    raise NotImplementedError(f"no Pinocchio coordinates for a {jt.name} joint")


def velocity_transform(jt: JointType, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """For a joint whose common velocity differs from Pinocchio's (common v = T v_pin): ``(T,
    dT/dt v_pin)`` on its dofs; None where they coincide. The free flyer's linear velocity:
    T = blockdiag(R_WB, I3), (dT/dt) v_pin = w_WB_W x v_WB_W on the linear rows."""
    if not jt.world_linear_velocity:
        return None
    R = rotations.matrix(q[3:7])
    T, Tdot_v = np.eye(jt.nv), np.zeros(jt.nv)
    T[:3, :3] = R
    Tdot_v[:3] = np.cross(R @ v[3:6], v[:3])
    return T, Tdot_v


def read_urdf(path: Path, root_joint: str = "none") -> pin.Model:
    """Parse a URDF file, or an MJCF (any other suffix: a scene without a URDF, read by
    ``buildModelFromMJCF``; ``root_joint`` ignored, as the MJCF states its root joint); raise
    InputError (one line, naming the file) if it cannot be read."""
    path = Path(path)
    if path.suffix.lower() != ".urdf":
        return _read_mjcf(path)
    if not path.is_file():
        raise InputError(f"{path}: URDF file not found")
    if root_joint not in ROOT_JOINTS:
        raise InputError(f"{path}: unknown root joint {root_joint!r} (known: {', '.join(ROOT_JOINTS)})")
    try:
        root = ROOT_JOINTS[root_joint]
        return pin.buildModelFromUrdf(str(path), root()) if root else pin.buildModelFromUrdf(str(path))
    except Exception as err:
        raise InputError(f"{path}: cannot load URDF: {' '.join(str(err).split())}") from None


def _read_mjcf(path: Path) -> pin.Model:
    """``buildModelFromMJCF`` of the MJCF at ``path`` (its own root joint), InputError (one line)
    if Pinocchio cannot read it."""
    if not path.is_file():
        raise InputError(f"{path}: MJCF file not found")
    try:
        model = pin.buildModelFromMJCF(str(path))
    except Exception as err:
        raise InputError(f"{path}: Pinocchio cannot load the MJCF: {' '.join(str(err).split())}") from None
    return model[0] if isinstance(model, tuple) else model  # some overloads return (model, constraints)


def body_joint_ids(pmodel: pin.Model, model: Multibody, source: Path) -> list[int]:
    """Pinocchio joint id that moves each scene body (the link's parent joint)."""
    ids = []
    for body in model.bodies:
        if not pmodel.existFrame(body.name):
            what = "URDF has no link" if Path(source).suffix.lower() == ".urdf" else "MJCF has no body"
            raise InputError(f"{source}: {what} named {body.name!r}")
        frame = pmodel.frames[pmodel.getFrameId(body.name)]
        if not np.allclose(frame.placement.homogeneous, np.eye(4)):
            raise InputError(f"{source}: link {body.name!r} is not at its joint frame (fixed joints are not supported)")
        ids.append(int(frame.parentJoint))
    return ids


def load_urdf(path: Path, root_joint: str, model: Multibody) -> tuple[pin.Model, list[int]]:
    """The URDF as a Pinocchio model with the scene's physics applied, and each body's joint id."""
    pmodel = read_urdf(path, root_joint)
    ids = body_joint_ids(pmodel, model, path)
    for body, jid in zip(model.bodies, ids):
        pmodel.jointPlacements[jid] = pin.SE3(np.eye(3), np.asarray(body.p_PB_P, dtype=float))
        pmodel.inertias[jid] = pin.Inertia(body.mass, np.asarray(body.p_BCm_B, float), np.asarray(body.I_Cm_B, float))
    pmodel.gravity = pin.Motion(np.concatenate([model.gravity_W, np.zeros(3)]))
    return pmodel, ids


def initial_configuration(pmodel: pin.Model, ids: list[int], model: Multibody) -> tuple[np.ndarray, np.ndarray]:
    """Pinocchio (q, v) from the scene's joint-coordinate initial state.

    Conversions: ``to_pinocchio`` (quaternions ``wxyz`` -> ``xyzw``; the free-flyer's linear
    velocity is expressed in the body frame in Pinocchio, in the world in the scene).
    """
    return configuration(pmodel, ids, model, model.q0, model.v0)


def configuration(pmodel: pin.Model, ids: list[int], model: Multibody, q_common, v_common) -> tuple[np.ndarray, np.ndarray]:
    """Pinocchio (q, v) from joint coordinates ``q_common, v_common`` (per body name,
    ``harness.model.joints``): ``initial_configuration`` at any joint state."""
    q = pin.neutral(pmodel)
    v = np.zeros(pmodel.nv)
    for body, jid in zip(model.bodies, ids):
        jm = pmodel.joints[jid]
        qj, vj = to_pinocchio(JOINTS[body.joint], q_common[body.name], v_common[body.name], jm.nq)
        q[jm.idx_q : jm.idx_q + len(qj)] = qj
        v[jm.idx_v : jm.idx_v + len(vj)] = vj
    return q, v


def maximal_accelerations(pmodel: pin.Model, data: pin.Data, ids: list[int], names, q, v, a) -> tuple[dict, dict]:
    """Each body's centre-of-mass acceleration (m/s^2) and angular acceleration (rad/s^2), world,
    per body name (``names``, in the order of ``ids``), at Pinocchio's ``(q, v, a)``: the classical
    acceleration of the joint origin O and the angular acceleration (``getClassicalAcceleration``,
    LOCAL_WORLD_ALIGNED), and ``a_C = a_O + alpha x r + w x (w x r)`` with r = R lever."""
    pin.forwardKinematics(pmodel, data, q, v, a)
    acc, alpha = {}, {}
    for name, jid in zip(names, ids):
        R = data.oMi[jid].rotation
        r = R @ np.array(pmodel.inertias[jid].lever)
        w = pin.getVelocity(pmodel, data, jid, LOCAL_WORLD_ALIGNED).angular
        a_O = pin.getClassicalAcceleration(pmodel, data, jid, LOCAL_WORLD_ALIGNED)
        alpha[name] = np.array(a_O.angular)
        acc[name] = np.array(a_O.linear) + np.cross(alpha[name], r) + np.cross(w, np.cross(w, r))
    return acc, alpha


#: The exceptions that end a Pinocchio run as a numerical failure (``harness.engines.base.sample_run``):
#: Pinocchio's own errors (RuntimeError, ValueError) and a singular or non-finite linear solve.
RUN_ERRORS = {RuntimeError: Failure.SOLVER, ValueError: Failure.SOLVER, np.linalg.LinAlgError: Failure.SINGULAR,
              ArithmeticError: Failure.SOLVER}


def check_finite(q: np.ndarray, v: np.ndarray, t: float) -> None:
    """RunStop (``Failure.NON_FINITE``) where the state ``(q, v)`` at ``t`` (s) is not finite:
    within a sample's steps, before a projection would take a non-finite state for a drift."""
    if not (np.isfinite(q).all() and np.isfinite(v).all()):
        raise RunStop(Failure.NON_FINITE, f"non-finite state at t = {t:.6g} s")


def advance_function(state: list, step, accel, h: float, per: int, project=None):
    """The ``advance(k)`` a Pinocchio run hands ``harness.engines.base.sample_run``: ``per`` steps
    of ``step`` (s each, ``h``) of ``accel`` from t_{k-1} = (k - 1) per h, the state ``[q, v]``
    updated in place; with ``project``, the state is checked finite (``check_finite``) and
    projected onto the constraints after each step."""

    def advance(k: int) -> None:
        q, v = state
        for j in range(per):
            q, v = step(accel, ((k - 1) * per + j) * h, q, v, h)
            if project is not None:
                check_finite(q, v, ((k - 1) * per + j + 1) * h)
                q, v = project(q, v)
        state[:] = q, v

    return advance


class MaximalReader:
    """Fills sample ``k`` of a ``SampleBuffer`` with each body's world pose and twist (centre of
    mass) from Pinocchio's kinematics (``forwardKinematics``, ``oMi``, ``getVelocity`` in
    LOCAL_WORLD_ALIGNED). The orientations are kept as rotation matrices and turned into
    quaternions for all samples at once by ``finish`` (``rotations.from_matrix`` on the stack: the
    same numbers as one sample at a time)."""

    def __init__(self, pmodel, data, ids, buf: SampleBuffer):
        self.pmodel, self.data, self.buf = pmodel, data, buf
        self.items = [(i, jid, np.array(pmodel.inertias[jid].lever)) for i, jid in enumerate(ids)]
        self.R = np.full(buf.quat_WB.shape[:2] + (3, 3), np.nan)

    def read(self, q, v, k: int) -> None:
        pmodel, data, buf = self.pmodel, self.data, self.buf
        pin.forwardKinematics(pmodel, data, q, v)
        oMi_all = data.oMi
        for i, jid, lever in self.items:
            oMi = oMi_all[jid]
            R = oMi.rotation
            r_W = R @ lever
            vel = pin.getVelocity(pmodel, data, jid, LOCAL_WORLD_ALIGNED)
            w = vel.angular
            buf.p_WCm_W[k, i] = oMi.translation + r_W
            self.R[k, i] = R
            buf.w_WB_W[k, i] = w
            buf.v_WCm_W[k, i] = vel.linear + rotations.cross(w, r_W)

    def finish(self, saved: int) -> None:
        """Write the quaternions of the first ``saved`` samples."""
        if saved:
            self.buf.quat_WB[:saved] = rotations.from_matrix(self.R[:saved])


