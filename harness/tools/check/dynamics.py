"""The loaders' joints in common coordinates (``joint_map`` tables of Pinocchio and Drake), and the free
motion under gravity of MuJoCo against Pinocchio from random states (``free_motion``; m, rad, m/s, rad/s)."""

from __future__ import annotations

import copy

import mujoco
import numpy as np
import pinocchio as pin

from harness.tools import dynamics_terms as dc
from harness.engines.pinocchio.lie_group_integrators import rkmk4_step
from harness.engines.pinocchio.model import from_pinocchio
from harness.model import rotations
from harness.judging.error_model import judge_refinement
from harness.model.joints import JOINTS
from harness.tools.check.results import FreeMotion, Reading


# --------------------------------------------------------------------------- dynamics: joints of each loader


def _pinocchio_table(mjr: Reading, r: Reading) -> dict | None:
    """Joint name -> Pinocchio coordinates for ``dynamics_terms.joint_map``; None (with
    ``r.dynamics`` saying why) when Pinocchio's joints are not MuJoCo's or its bodies are not
    physical."""
    kinds = {x.joint: x.kind for x in r.bodies}
    why = r.dynamics or _joint_set_problem(mjr, kinds, r)
    if why:
        r.dynamics = why
        return None
    return {name: {"pin_q": s.idx_q, "pin_v": s.idx_v, "pin_joint": s.jid, "pin_nq": s.nq} for name, s in r.slots.items()}


def _drake_table(mjr: Reading, r: Reading) -> dict | None:
    """Joint name -> Drake coordinates (``position_start``, ``velocity_start``); None (with
    ``r.dynamics`` saying why) when Drake's moving joints are not MuJoCo's, or are of a kind
    whose Drake coordinates are not mapped (Drake's ball joint has roll-pitch-yaw angles)."""
    kinds = {x.joint: x.kind for x in r.bodies}
    why = _joint_set_problem(mjr, kinds, r)
    balls = [n for n, k in kinds.items() if JOINTS.get(k) is not None and JOINTS[k].quat_at is not None
             and not JOINTS[k].world_linear_velocity]
    if not why and balls:
        why = f"Drake's ball joints ({', '.join(balls)}) have roll-pitch-yaw coordinates, not mapped to quaternions"
    if why:
        r.dynamics = why
        return None
    plant = r.model.plant
    moving = [plant.get_joint(j) for j in plant.GetJointIndices() if plant.get_joint(j).type_name() != "weld"]
    # drake_joint_bodies keeps Drake's joint order; a free joint may carry MuJoCo's name (_match_free_joints)
    return {x.joint: {"drake_q": int(j.position_start()), "drake_v": int(j.velocity_start())}
            for x, j in zip(r.bodies, moving)}


def _pybullet_table(mjr: Reading, r: Reading) -> dict | None:
    """Joint name -> PyBullet's dof index (its movable joints in link order) for
    ``dynamics_terms.pybullet_terms``; None (with ``r.dynamics`` saying why) when its joints are not
    MuJoCo's, or the base floats (``calculateInverseDynamics`` and ``calculateMassMatrix`` of a floating
    base put its 6 dofs in PyBullet's own base coordinates, at the centre of mass: not mapped), or a joint
    is neither a hinge nor a slide."""
    # the base's dofs are PyBullet's own (its inertial frame); only a fixed base is mapped
    kinds = {x.joint: x.kind for x in r.bodies}
    why = _joint_set_problem(mjr, kinds, r)
    if not why and not r.model.fixed_base:
        why = ("a floating base: the 6 base dofs of PyBullet's calculateMassMatrix and calculateInverseDynamics are "
               "not mapped to the common coordinates yet (a fixed base is compared)")
    odd = [n for n, k in kinds.items() if JOINTS.get(k) is None or JOINTS[k].nq != 1]
    if not why and odd:
        why = f"joints {', '.join(odd)} are neither hinges nor slides, whose PyBullet coordinates are not mapped"
    if why:
        r.dynamics = why
        return None
    return {x.joint: k for k, x in enumerate(r.bodies)}


def _whole_trees(mjr: Reading, missing: list[str]) -> list[str]:
    """The root bodies of MuJoCo's kinematic trees (bodies on the world) that hold ``missing``
    joints, when every joint of those trees is missing (whole trees); else []."""
    m = mjr.model
    tree = {x.joint: int(m.body_rootid[m.jnt_bodyid[j]]) for j, x in enumerate(mjr.bodies)}
    roots = {tree[n] for n in missing}
    if any(t in roots and n not in missing for n, t in tree.items()):
        return []
    return [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}" for b in sorted(roots)]


def _joint_set_problem(mjr: Reading, kinds: dict[str, str], r: Reading | None = None) -> str:
    """Why a loader's joints (name -> kind) cannot be put into MuJoCo's coordinates ("" when they
    can). A loader that lacks whole kinematic trees of MuJoCo's (every joint of a tree, and has
    some joints) is compared on the trees it has: ``r.partial`` lists the joints it lacks."""
    mj = {x.joint: x.kind for x in mjr.bodies}
    missing, extra = [n for n in mj if n not in kinds], [n for n in kinds if n not in mj]
    if missing and not extra and len(missing) < len(mj) and _whole_trees(mjr, missing) and r is not None:
        r.partial, missing = missing, []
    if missing or extra:
        return "its joints are not MuJoCo's (" + "; ".join(
            ([f"no {', '.join(missing)}"] if missing else []) + ([f"{', '.join(extra)} not in MuJoCo"] if extra else [])) + ")"
    other = [f"{n} is {kinds[n]}, MuJoCo's {k}" for n, k in mj.items() if n in kinds and kinds[n] != k]
    return f"its joint types differ from MuJoCo's ({'; '.join(other)})" if other else ""


def _rigid_copy(m: mujoco.MjModel, dt: float) -> mujoco.MjModel:
    """MuJoCo's rigid model of the free motion (``free_motion``)."""
    rigid = _mujoco_copy(m, dt, mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
                         | mujoco.mjtDisableBit.mjDSBL_DAMPER | mujoco.mjtDisableBit.mjDSBL_SPRING
                         | mujoco.mjtDisableBit.mjDSBL_ACTUATION)
    rigid.body_gravcomp[:] = 0.0
    rigid.opt.density, rigid.opt.viscosity = 0.0, 0.0
    return rigid


#: Order of the free motions' difference: MuJoCo's RK4 against Pinocchio's ``rkmk4_step``, both order 4.
FREE_ORDER = 4.0
#: The free motion's compared quantities and their units.
FREE_UNITS = {"joint": "rad or m", "velocity": "rad/s or m/s", "position": "m", "orientation": "rad"}


def free_motion(m: mujoco.MjModel, pmodel: pin.Model, jmap: dc.JointMap, q0: np.ndarray, v0: np.ndarray, k: int, *,
                t_end: float, dt: float, save_every: float, frames: dict[int, int] | None = None) -> FreeMotion:
    """Unforced motion under gravity from (q0, v0) (common coordinates) in both engines, judged by
    how the difference converges.

    MuJoCo: RK4 at ``dt``, contacts, constraints (limits, equalities, friction loss), passive
    forces (damping, springs, gravity compensation, fluid forces) and actuators disabled, so that
    both integrate M a + C v + g = 0. Pinocchio: ``aba`` with zero torque and ``rkmk4_step`` at
    ``dt``. Both are order 4: where they hold the same dynamics, their difference falls as dt^4
    (or sits at the resolution, 1e-9 of the motion's scale); where they do not, it has a floor. The
    pair runs again at 2 dt (dt / 2 when the save interval is an odd number of steps; and at half
    the finest step where two levels leave it open), and each quantity's difference is fitted
    (``harness.judging.error_model.judge_refinement``): ``FreeMotion.models``. Scales: joints and
    joint velocities their largest magnitude in MuJoCo's run (at least 1), positions the largest
    distance of a moving body from the world origin (at least 1 mm), orientations 1 rad.
    A second MuJoCo run with only contacts off measures how far limits, equality
    constraints, damping and actuators move the joints (``constrained_joint``; informational).
    ``frames``: MuJoCo body id -> Pinocchio frame id of each moving body (``_pinocchio_frames``;
    default: Pinocchio's BODY frame of the MuJoCo body's name).
    """
    steps_per_save = max(1, int(round(save_every / dt)))
    n_saves = max(1, int(round(t_end / (steps_per_save * dt))))
    if frames is None:
        bodies = [b for b in range(1, m.nbody) if m.body_jntnum[b] > 0]
        frames = {b: pmodel.getFrameId(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b), pin.FrameType.BODY)
                  for b in bodies}
    base = _free_run(m, pmodel, jmap, q0, v0, dt, steps_per_save, n_saves, frames, constrained=True)
    second = 2.0 * dt if steps_per_save % 2 == 0 else dt / 2.0

    def measure(h: float) -> dict[str, float]:
        if h == dt:
            return base["worst"]
        return _free_run(m, pmodel, jmap, q0, v0, h, int(round(steps_per_save * dt / h)), n_saves, frames)["worst"]

    scales = {q: (unit, base["scales"][q]) for q, unit in FREE_UNITS.items()}
    models = judge_refinement(measure, (dt, second), FREE_ORDER, scales, n_saves * steps_per_save)
    w = base["worst"]
    return FreeMotion(k, w["joint"], w["velocity"], w["position"], w["orientation"], base["worst_body"],
                      w["constrained"], models)


def _free_run(m: mujoco.MjModel, pmodel: pin.Model, jmap: dc.JointMap, q0: np.ndarray, v0: np.ndarray, dt: float,
              steps_per_save: int, n_saves: int, frames: dict[int, int], constrained: bool = False) -> dict:
    """MuJoCo's rigid run and Pinocchio's at ``dt`` (``free_motion``): the largest differences over
    the saved samples (``worst``: joint, velocity, position, orientation; ``constrained``: MuJoCo as
    the file says against rigid, when ``constrained``), the body where the pose differs most and
    the motion's scales."""
    rigid = _rigid_copy(m, dt)
    as_file = _mujoco_copy(m, dt, mujoco.mjtDisableBit.mjDSBL_CONTACT) if constrained else None
    bodies, frame_ids = list(frames), list(frames.values())
    d_rigid = mujoco.MjData(rigid)
    d_file = mujoco.MjData(as_file) if constrained else None
    for dd in (d_rigid, d_file):
        if dd is not None:
            dd.qpos[:], dd.qvel[:] = dc.mujoco_state(m, jmap, q0, v0)
    data = pmodel.createData()
    qp, vp = dc.pinocchio_state(pmodel, jmap, q0, v0)
    tau = np.zeros(pmodel.nv)

    def accel(t, q, v):
        return pin.aba(pmodel, data, q, v, tau).copy()

    worst = {"joint": 0.0, "velocity": 0.0, "position": 0.0, "orientation": 0.0, "constrained": float("nan")}
    if constrained:
        worst["constrained"] = 0.0
    scales = {"joint": 1.0, "velocity": 1.0, "position": 1e-3, "orientation": 1.0}
    worst_body = ""
    for i in range(n_saves + 1):
        if i > 0:
            for _ in range(steps_per_save):
                mujoco.mj_step(rigid, d_rigid)
                if d_file is not None:
                    mujoco.mj_step(as_file, d_file)
                qp, vp = rkmk4_step(pmodel, accel, 0.0, qp, vp, dt)
        mujoco.mj_kinematics(rigid, d_rigid)
        pin.framesForwardKinematics(pmodel, data, qp)
        qc_mj, vc_mj = _common_from_mujoco(jmap, d_rigid.qpos, d_rigid.qvel)
        qc_pin, vc_pin = _common_from_pinocchio(pmodel, jmap, qp, vp)
        worst["joint"] = _worse(worst["joint"], _joint_distance(jmap, qc_mj, qc_pin))
        worst["velocity"] = _worse(worst["velocity"], float(np.max(np.abs(vc_mj - vc_pin), initial=0.0)))
        scales["joint"] = max(scales["joint"], float(np.max(np.abs(qc_mj), initial=0.0)))
        scales["velocity"] = max(scales["velocity"], float(np.max(np.abs(vc_mj), initial=0.0)))
        if d_file is not None:
            qc_file, _ = _common_from_mujoco(jmap, d_file.qpos, d_file.qvel)
            worst["constrained"] = _worse(worst["constrained"], _joint_distance(jmap, qc_mj, qc_file))
        for b, fid in zip(bodies, frame_ids):
            oMf = data.oMf[fid]
            dp = float(np.linalg.norm(d_rigid.xpos[b] - oMf.translation))
            finite = np.all(np.isfinite(oMf.rotation)) and np.all(np.isfinite(d_rigid.xquat[b]))
            dq = float(rotations.geodesic_angle(d_rigid.xquat[b], rotations.from_matrix(oMf.rotation))) if finite else float("nan")
            if (dp > worst["position"] or dq > worst["orientation"]
                    or (not np.isfinite(dp + dq) and np.isfinite(worst["position"] + worst["orientation"]))):
                worst_body = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}"
            worst["position"], worst["orientation"] = _worse(worst["position"], dp), _worse(worst["orientation"], dq)
            scales["position"] = max(scales["position"], float(np.linalg.norm(d_rigid.xpos[b])))
    scales = {q: (x if np.isfinite(x) else 1.0) for q, x in scales.items()}
    return {"worst": worst, "worst_body": worst_body, "scales": scales}


def _worse(old: float, new: float) -> float:
    """The larger of two differences, NaN when either is NaN: a motion that went to NaN stays
    NaN and fails its tolerance (``max(old, nan)`` would keep ``old``)."""
    return float(np.maximum(old, new))


def _mujoco_copy(m: mujoco.MjModel, dt: float, disable: int) -> mujoco.MjModel:
    out = copy.deepcopy(m)
    out.opt.timestep = dt
    out.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    out.opt.disableflags = int(out.opt.disableflags) | int(disable)
    return out


def _pinocchio_frames(mjr: Reading, pinr: Reading) -> dict[int, int]:
    """MuJoCo body id -> the Pinocchio frame of the same body, for every body a joint moves: the
    body of Pinocchio's joint of the same name (joints are matched by name, through the joint map
    if any), its BODY frame (a URDF link's, an MJCF body's)."""
    m, pmodel = mjr.model, pinr.model
    pin_body = {x.joint: x.body for x in pinr.bodies}
    out = {}
    for j, x in enumerate(mjr.bodies):   # MuJoCo's joint order
        b = int(m.jnt_bodyid[j])
        name = pin_body.get(x.joint)
        if name is None:
            continue
        out[b] = (pmodel.getFrameId(name, pin.FrameType.BODY) if pmodel.existFrame(name, pin.FrameType.BODY)
                  else pmodel.getFrameId(name))
    return out


def _moving_bodies(m: mujoco.MjModel) -> list[str]:
    return [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(1, m.nbody) if m.body_jntnum[b] > 0]


def _common_from_mujoco(jmap: dc.JointMap, qpos: np.ndarray, qvel: np.ndarray):
    q, v = np.zeros(jmap.nq), np.zeros(jmap.nv)
    for s in jmap.slots:
        s.q(q)[:] = qpos[s.mj_q:s.mj_q + s.joint.nq]
        s.v(v)[:] = qvel[s.mj_v:s.mj_v + s.joint.nv]
    return q, v


def _common_from_pinocchio(pmodel: pin.Model, jmap: dc.JointMap, qp: np.ndarray, vp: np.ndarray):
    """Inverse of ``dynamics_terms.pinocchio_state`` (``harness.engines.pinocchio.model.from_pinocchio``)."""
    q, v = np.zeros(jmap.nq), np.zeros(jmap.nv)
    for s in jmap.slots:
        s.q(q)[:], s.v(v)[:] = from_pinocchio(s.joint, qp[s.pin_q:s.pin_q + s.pin_nq],
                                              vp[s.pin_v:s.pin_v + s.joint.nv], pmodel.jointPlacements[s.pin_joint])
    return q, v


def _joint_distance(jmap: dc.JointMap, a: np.ndarray, b: np.ndarray) -> float:
    """Largest per-joint distance (``JointType.distance``): |dq| for hinge (wrapped) and slide,
    geodesic angle for ball, position and geodesic angle for free."""
    return max((s.joint.distance(s.q(a), s.q(b)) for s in jmap.slots), default=0.0)

