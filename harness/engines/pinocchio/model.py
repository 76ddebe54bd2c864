"""Load a scene's URDF into Pinocchio with the scene description's parameters.

The URDF is the model as a user writes it. URDF has no free or ball joint, so the scene says
which root joint Pinocchio adds (``free`` -> ``JointModelFreeFlyer``, ``spherical`` ->
``JointModelSpherical``). ``load_urdf`` then rewrites, from the scene's ``Multibody``, the joint
placements (body positions), the inertias (mass, centre of mass, inertia about it) and gravity.
Joint types and axes are not rewritten: they are checked (``harness.tools.loaded_models``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin

from harness.model import rotations
from harness.model.errors import InputError
from harness.model.multibody import Multibody

ROOT_JOINTS = {
    "free": pin.JointModelFreeFlyer,
    "spherical": pin.JointModelSpherical,
    "none": None,
}


def read_urdf(path: Path, root_joint: str = "none") -> pin.Model:
    """Parse a URDF file; raise InputError (one line, naming the file) if it cannot be read."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: URDF file not found")
    if root_joint not in ROOT_JOINTS:
        raise InputError(f"{path}: unknown root joint {root_joint!r} (known: {', '.join(ROOT_JOINTS)})")
    try:
        root = ROOT_JOINTS[root_joint]
        return pin.buildModelFromUrdf(str(path), root()) if root else pin.buildModelFromUrdf(str(path))
    except Exception as err:
        raise InputError(f"{path}: cannot load URDF: {' '.join(str(err).split())}") from None


def body_joint_ids(pmodel: pin.Model, model: Multibody, source: Path) -> list[int]:
    """Pinocchio joint id that moves each scene body (the link's parent joint)."""
    ids = []
    for body in model.bodies:
        if not pmodel.existFrame(body.name):
            raise InputError(f"{source}: URDF has no link named {body.name!r}")
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

    Conversions (here and nowhere else): quaternions ``wxyz`` -> ``xyzw``; the free-flyer's
    linear velocity is expressed in the body frame in Pinocchio, in the world in the scene.
    """
    q = pin.neutral(pmodel)
    v = np.zeros(pmodel.nv)
    for body, jid in zip(model.bodies, ids):
        jq, jv = pmodel.joints[jid].idx_q, pmodel.joints[jid].idx_v
        q0, v0 = np.asarray(model.q0[body.name], float), np.asarray(model.v0[body.name], float)
        if body.joint == "free":
            R = rotations.matrix(q0[3:7])
            q[jq : jq + 7] = np.concatenate([q0[:3], rotations.wxyz_to_xyzw(q0[3:7])])
            v[jv : jv + 6] = np.concatenate([R.T @ v0[:3], v0[3:6]])
        elif body.joint == "ball":
            q[jq : jq + 4] = rotations.wxyz_to_xyzw(q0)
            v[jv : jv + 3] = v0
        else:
            q[jq] = q0[0]
            v[jv] = v0[0]
    return q, v
