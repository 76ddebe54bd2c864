"""What each engine sees after loading a scene's model, compared with the scene description.

``mujoco_bodies`` / ``pinocchio_bodies`` read back, per scene body: mass (kg), centre of mass in
the body frame (m), inertia about the centre of mass in the body frame (kg m^2), the body
frame's position in its parent (m), joint type and hinge axis (body frame).
``compare_bodies`` lists every disagreement with the ``Multibody`` beyond a relative tolerance.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
import pinocchio as pin

from harness import rotations
from harness.multibody import Multibody


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


MJ_JOINTS = {
    mujoco.mjtJoint.mjJNT_FREE: "free",
    mujoco.mjtJoint.mjJNT_BALL: "ball",
    mujoco.mjtJoint.mjJNT_HINGE: "hinge",
    mujoco.mjtJoint.mjJNT_SLIDE: "slide",
}


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
            joint = MJ_JOINTS.get(mujoco.mjtJoint(m.jnt_type[jid]), str(m.jnt_type[jid]))
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
        short = pmodel.joints[jid].shortname()
        if "FreeFlyer" in short:
            joint, axis = "free", np.zeros(3)
        elif "Spherical" in short:
            joint, axis = "ball", np.zeros(3)
        elif "Revolute" in short and pmodel.joints[jid].nq == 1:
            joint, axis = "hinge", np.array(data.joints[jid].S).reshape(6, -1)[3:6, 0].copy()
        else:
            joint, axis = short, np.zeros(3)
        out.append(LoadedBody(body.name, float(inertia.mass), np.array(inertia.lever), np.array(inertia.inertia),
                              np.array(pmodel.jointPlacements[jid].translation), joint, axis))
    return out


def compare_bodies(loaded: list[LoadedBody], model: Multibody, rtol: float = 1e-9) -> list[str]:
    """Disagreements between loaded bodies and the scene description, one message each."""
    problems = []
    seen = {b.name for b in loaded}
    for body in model.bodies:
        if body.name not in seen:
            problems.append(f"body {body.name!r} is missing")
    for lb in loaded:
        body = model.body(lb.name)
        length = max(np.linalg.norm(body.p_BCm_B), np.linalg.norm(body.p_PB_P), 1e-3)
        if not np.isclose(lb.mass, body.mass, rtol=rtol, atol=0):
            problems.append(f"{lb.name}: mass {lb.mass:.9g} kg, scene says {body.mass:.9g} kg")
        if np.linalg.norm(lb.p_BCm_B - body.p_BCm_B) > rtol * length:
            problems.append(f"{lb.name}: centre of mass {lb.p_BCm_B.tolist()} m, scene says {body.p_BCm_B.tolist()} m")
        scale = np.abs(body.I_Cm_B).max()
        if np.abs(lb.I_Cm_B - body.I_Cm_B).max() > rtol * scale:
            problems.append(f"{lb.name}: inertia about the centre of mass {np.round(lb.I_Cm_B, 12).tolist()} kg m^2, "
                            f"scene says {np.round(body.I_Cm_B, 12).tolist()} kg m^2")
        if body.joint != "free" and np.linalg.norm(lb.p_PB_P - body.p_PB_P) > rtol * length:
            problems.append(f"{lb.name}: joint position in parent {lb.p_PB_P.tolist()} m, scene says {body.p_PB_P.tolist()} m")
        if lb.joint != body.joint:
            problems.append(f"{lb.name}: joint type {lb.joint}, scene says {body.joint}")
        elif body.joint == "hinge" and np.linalg.norm(lb.axis_B / np.linalg.norm(lb.axis_B) - body.axis_B) > 1e-9:
            problems.append(f"{lb.name}: hinge axis {lb.axis_B.tolist()}, scene says {body.axis_B.tolist()}")
    return problems
