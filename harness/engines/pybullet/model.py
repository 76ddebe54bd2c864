"""The scene's URDF in PyBullet (Bullet's Featherstone ``btMultiBody``), with the scene's physics.

Every run and every read-back uses its own physics server in DIRECT mode (no GUI, no shared
memory), so runs in one process or in forked workers never share a world.

Reading the file: ``p.loadURDF(..., flags=URDF_USE_INERTIA_FROM_FILE)``. Without that flag
PyBullet ignores the file's ``<inertia>`` and derives every link's inertia from its collision
shapes (its quick-start guide documents it; a link without one gets a diagonal of 1e-6 kg m^2:
the double pendulum's bar, 0.0834 kg m^2 in the file): the well-known trap of its importer, which
``read_urdf`` never falls into. A URDF whose root link carries no joint is loaded with a fixed
base where the root link is the massless ``world`` link, and floating otherwise; the scene's
``urdf_root_joint`` (``spherical``: the heavy top; ``free``: a floating body) says what the file
cannot.

The run's system (``build``): the tree as PyBullet read it from the URDF (its links, parents,
joint types and axes, each checked against the scene), rebuilt with ``p.createMultiBody`` so
that the scene's description sets each body's mass, centre of mass, inertia (its principal
moments, ``changeDynamics(localInertiaDiagonal)``, and principal axes, the inertial frame's
orientation) and joint placement, as every engine applies them (a ``--set`` changes them; the
file's own values are checked by ``harness validate``'s ``model.*`` checks, ``pybullet_bodies``).
A root ball joint is a ``JOINT_SPHERICAL`` link on a massless fixed base. Reduced coordinates
(``useMaximalCoordinates=False``); no collision shapes (the tree scenes have no contact), so no
contact constraint and no joint limit (``createMultiBody`` states none); the default joint
motors are switched off (``VELOCITY_CONTROL`` with zero force, and zero-gain zero-force
spherical motors); PyBullet's damping defaults (``btMultiBody``'s linear and angular damping
0.04) and joint damping and friction are set to 0, the joint velocity clamp
(``maxJointVelocity``, 100 rad/s by default) lifted to ``MAX_JOINT_VELOCITY``, sleeping disabled.

Frames: PyBullet's link frame is the link's inertial frame (centre of mass, principal axes); the
harness's body frame B (the URDF link frame, at the joint) is recovered from it with the
inertial frame's pose in B, which ``build`` set (``PyBulletModel.R_BI``), not from
``getLinkState``'s URDF frame, which reaches the client with single-precision round-off
(~1e-8). ``getJointInfo`` gives a joint's axis in the child's inertial frame and its position in
the parent's inertial frame. Units SI; PyBullet's quaternions are ``xyzw``.
"""

from __future__ import annotations

import os
import sys

from dataclasses import dataclass, field

import numpy as np

from harness.model import rotations
from harness.model.errors import InputError
from harness.model.forces import JOINT_SPRINGS, POINT_SPRINGS, elements
from harness.model.joints import BALL, FREE, HINGE, JOINTS, SLIDE
from harness.model.multibody import Multibody

#: Joint velocity clamp (rad/s, m/s) set on every link (``changeDynamics(maxJointVelocity)``):
#: PyBullet clamps a joint's speed to 100 by default, a limit the ideal scenes do not have.
MAX_JOINT_VELOCITY = 1e6


def pybullet_module():
    """``pybullet``, imported with its build banner ("pybullet build time: ...", printed by its C
    code at import, on file descriptor 2 in the wheels measured: 3.2.7) kept off the output: both
    standard descriptors point to /dev/null while it loads."""
    if "pybullet" in sys.modules:
        return sys.modules["pybullet"]
    import ctypes

    sys.stdout.flush()
    sys.stderr.flush()
    saved = {fd: os.dup(fd) for fd in (1, 2)}
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        for fd in saved:
            os.dup2(devnull, fd)
        import pybullet

        ctypes.CDLL(None).fflush(None)   # its C output is buffered: flushed here, into /dev/null
    finally:
        for fd, copy in saved.items():
            os.dup2(copy, fd)
            os.close(copy)
        os.close(devnull)
    return pybullet


_pybullet = pybullet_module


def connect_direct() -> int:
    """A new PyBullet server in DIRECT mode (no GUI): its client id. PyBullet's C code prints its
    build banner on the first connection (buffered C output, flushed at exit): it is flushed here
    into /dev/null, off the output."""
    import ctypes

    p = pybullet_module()
    sys.stdout.flush()
    saved, devnull = os.dup(1), os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        client = p.connect(p.DIRECT)
        ctypes.CDLL(None).fflush(None)
    finally:
        os.dup2(saved, 1)
        os.close(saved)
        os.close(devnull)
    return client


def joint_kind(code: int) -> str:
    """The harness name of a PyBullet joint type (``JOINT_REVOLUTE`` hinge, ``JOINT_PRISMATIC``
    slide, ``JOINT_SPHERICAL`` ball), else PyBullet's code as text (``JOINT_FIXED`` is 4)."""
    p = _pybullet()
    return {p.JOINT_REVOLUTE: HINGE.name, p.JOINT_PRISMATIC: SLIDE.name, p.JOINT_SPHERICAL: BALL.name}.get(
        code, f"pybullet joint type {code}")


def _joint_code(kind: str) -> int:
    p = _pybullet()
    return {HINGE.name: p.JOINT_REVOLUTE, SLIDE.name: p.JOINT_PRISMATIC, BALL.name: p.JOINT_SPHERICAL}[kind]


class Server:
    """A PyBullet physics server in DIRECT mode (``with Server() as client``), disconnected on exit."""

    def __enter__(self) -> int:
        self.client = connect_direct()
        return self.client

    def __exit__(self, *exc) -> None:
        _pybullet().disconnect(physicsClientId=self.client)


def check_supported(model: Multibody) -> None:
    """NotImplementedError for what the PyBullet engine does not model: loop joints, rolling
    contact, force elements other than joint springs and point springs (with their dampers)."""
    if model.loops:
        raise NotImplementedError("PyBullet's reduced-coordinate btMultiBody is a tree and a URDF cannot state a loop; "
                                  "its point-to-point constraints (createConstraint) are soft, solved by its "
                                  "iterative constraint solver: the loop is not modelled")
    if model.contacts:
        raise NotImplementedError("PyBullet has no ideal rolling constraint (its contact is a frictional contact "
                                  "solved by impulses): the rolling contact is not modelled")
    for ft, _ in elements(model):
        if ft not in (JOINT_SPRINGS, POINT_SPRINGS):
            raise NotImplementedError(f"the PyBullet engine does not model {ft.label}s ({ft.name})")


def read_urdf(path, root_joint: str, client: int) -> int:
    """The URDF at ``path`` loaded into ``client`` as written, inertia from the file
    (``URDF_USE_INERTIA_FROM_FILE``, see the module docstring); returns PyBullet's body id. Fixed
    base unless the scene's ``root_joint`` is ``free`` or ``spherical`` (the root link then floats
    in the file as read: ``build`` adds the ball). InputError if PyBullet cannot read it."""
    p = _pybullet()
    if str(path).lower().endswith((".xml", ".mjcf")):
        raise NotImplementedError(f"{path}: the PyBullet engine reads the URDF only (its MJCF reader is partial)")
    try:
        return p.loadURDF(str(path), useFixedBase=root_joint not in (FREE.urdf_root, BALL.urdf_root),
                          useMaximalCoordinates=False, flags=p.URDF_USE_INERTIA_FROM_FILE, physicsClientId=client)
    except Exception as err:  # noqa: BLE001 - pybullet.error("Cannot load URDF file.")
        raise InputError(f"{path}: PyBullet cannot read it: {' '.join(str(err).split())[:300]}") from None


def _links(body: int, client: int) -> dict[str, int]:
    """Link name -> PyBullet link index (-1: the base) of a loaded body."""
    p = _pybullet()
    out = {p.getBodyInfo(body, physicsClientId=client)[0].decode(): -1}
    for j in range(p.getNumJoints(body, physicsClientId=client)):
        out[p.getJointInfo(body, j, physicsClientId=client)[12].decode()] = j
    return out


def _inertial(body: int, link: int, client: int):
    """``(mass, p_BI_B, R_BI)`` of a link: its mass (kg), its inertial frame's origin (the centre
    of mass) and orientation in the link's URDF frame, and ``diag`` its principal moments."""
    p = _pybullet()
    info = p.getDynamicsInfo(body, link, physicsClientId=client)
    R_BI = rotations.matrix(rotations.xyzw_to_wxyz(np.asarray(info[4], dtype=float)))
    return float(info[0]), np.asarray(info[3], dtype=float), R_BI, np.asarray(info[2], dtype=float)


def pybullet_bodies(body: int, client: int, model: Multibody, root_joint: str = "none") -> list:
    """Read back the scene's bodies as PyBullet holds them after ``read_urdf`` (``LoadedBody`` of
    ``harness.engines.loaded_models``): mass (kg, ``getDynamicsInfo``), centre of mass and the
    inertia about it in the URDF link frame (the principal moments turned by the inertial
    frame's orientation, m, kg m^2), the joint's position in the parent's link frame (m,
    ``getJointInfo``'s, which is in the parent's inertial frame, moved to its link frame), the
    joint kind and its unit axis in the child's link frame. A root link floats in the file as
    read: kind ``free``, or the scene's root joint (``spherical``: a ball at the link origin)."""
    from harness.engines.loaded_models import LoadedBody

    p = _pybullet()
    links = _links(body, client)
    out = []
    for b in model.bodies:
        if b.name not in links:
            continue
        link = links[b.name]
        m, c, R_BI, diag = _inertial(body, link, client)
        I_C = R_BI @ np.diag(diag) @ R_BI.T
        if link == -1:
            kind = BALL.name if root_joint == BALL.urdf_root else FREE.name
            out.append(LoadedBody(b.name, m, c, I_C, np.zeros(3), kind, np.zeros(3)))
            continue
        info = p.getJointInfo(body, link, physicsClientId=client)
        parent = info[16]
        _, c_P, R_PI, _ = _inertial(body, parent, client)
        p_PB_P = c_P + R_PI @ np.asarray(info[14], dtype=float)
        axis = R_BI @ np.asarray(info[13], dtype=float)
        out.append(LoadedBody(b.name, m, c, I_C, p_PB_P, joint_kind(info[2]), axis))
    return out


@dataclass
class PyBulletModel:
    """The run's multibody in a PyBullet server and what the engine reads it with.

    Attributes:
        client: the physics client id; ``body``: the multibody's id.
        links: scene body name -> PyBullet link index (-1: the base, a floating body).
        R_BI, p_BCm_B: per scene body, the inertial frame's orientation and origin (the centre of
            mass) in the body frame, as ``build`` set them.
        springs: ``(link, stiffness N/m, q_ref m)`` of the joint springs (applied each step).
        point_springs: ``(spring, body a, body b)`` of the springs between body points (with
            their dampers; ``PointSpring``, its ends' scene body names, None for the world),
            applied each step as external forces (``harness.engines.pybullet.engine``).
    """

    client: int
    body: int
    links: dict = field(default_factory=dict)
    R_BI: dict = field(default_factory=dict)
    p_BCm_B: dict = field(default_factory=dict)
    springs: list = field(default_factory=list)
    point_springs: list = field(default_factory=list)


def _principal(I: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(moments, R_BI)``: principal moments (kg m^2) and a proper rotation whose columns are
    the principal axes (body frame) of the symmetric inertia ``I`` (identity when ``I`` is
    diagonal, so that a diagonal file and its scene agree bit for bit)."""
    I = np.asarray(I, dtype=float)
    if not np.any(I - np.diag(np.diag(I))):
        return np.diag(I).copy(), np.eye(3)
    return rotations.principal_frame(I)


def _xyzw(R: np.ndarray) -> list[float]:
    return rotations.wxyz_to_xyzw(rotations.from_matrix(R)).tolist()


def build(scene, model: Multibody, client: int, dt: float) -> PyBulletModel:
    """The scene's system in ``client``: the URDF's tree as PyBullet reads it, with ``model``'s
    physics, gravity and initial state, stepped at ``dt`` (s) (module docstring).
    NotImplementedError for what the engine does not model (``check_supported``); InputError
    where PyBullet's reading of the URDF disagrees with the scene's tree."""
    p = _pybullet()
    check_supported(model)
    root = scene.urdf_root_joint
    read = read_urdf(scene.urdf, root, client)
    links = _links(read, client)
    kinds = {b.name: b.joint for b in model.bodies}
    for b in model.bodies:
        if b.name not in links:
            raise InputError(f"{scene.urdf}: no link named {b.name!r} (the scene's body) for PyBullet")
    read_kind = {x.name: x.joint for x in pybullet_bodies(read, client, model, root)}
    read_axis = {x.name: x.axis_B for x in pybullet_bodies(read, client, model, root)}
    for b in model.bodies:
        if read_kind[b.name] != b.joint:
            raise InputError(f"{scene.urdf}: PyBullet reads {b.name!r}'s joint as {read_kind[b.name]}, "
                             f"the scene says {b.joint}")
    p.removeBody(read, physicsClientId=client)

    free_root = model.bodies[0].joint == FREE.name
    index = {b.name: i for i, b in enumerate(model.bodies)}  # link index in the new multibody (base: -1)
    out = PyBulletModel(client, -1)
    args = {k: [] for k in ("linkMasses", "linkCollisionShapeIndices", "linkVisualShapeIndices", "linkPositions",
                            "linkOrientations", "linkInertialFramePositions", "linkInertialFrameOrientations",
                            "linkParentIndices", "linkJointTypes", "linkJointAxis")}
    moments = {}
    for b in model.bodies:
        moments[b.name], out.R_BI[b.name] = _principal(b.I_Cm_B)
        out.p_BCm_B[b.name] = np.asarray(b.p_BCm_B, dtype=float)
        if free_root and b.parent is None:
            continue
        if JOINTS[b.joint].root_only:
            raise NotImplementedError(f"the PyBullet engine floats the first body only, not {b.name!r} ({b.joint})")
        # createMultiBody's parent index: 0 the base, k the k-th link (1-based)
        parent = 0 if b.parent is None else index[b.parent] + (0 if free_root else 1)
        args["linkMasses"].append(float(b.mass))
        args["linkCollisionShapeIndices"].append(-1)
        args["linkVisualShapeIndices"].append(-1)
        args["linkPositions"].append(np.asarray(b.p_PB_P, dtype=float).tolist())
        args["linkOrientations"].append([0.0, 0.0, 0.0, 1.0])
        args["linkInertialFramePositions"].append(out.p_BCm_B[b.name].tolist())
        args["linkInertialFrameOrientations"].append(_xyzw(out.R_BI[b.name]))
        args["linkParentIndices"].append(parent)
        args["linkJointTypes"].append(_joint_code(kinds[b.name]))
        axis = read_axis[b.name] if JOINTS[b.joint].axis else np.array([0.0, 0.0, 1.0])
        args["linkJointAxis"].append(np.asarray(axis, dtype=float).tolist())
    if free_root:
        b0 = model.bodies[0]
        out.body = p.createMultiBody(baseMass=float(b0.mass), baseInertialFramePosition=out.p_BCm_B[b0.name].tolist(),
                                     baseInertialFrameOrientation=_xyzw(out.R_BI[b0.name]), useMaximalCoordinates=False,
                                     physicsClientId=client, **args)
        out.links = {b.name: index[b.name] - 1 for b in model.bodies}
    else:  # a massless fixed base at the world origin, every body a link
        out.body = p.createMultiBody(baseMass=0.0, useMaximalCoordinates=False, physicsClientId=client, **args)
        out.links = {b.name: index[b.name] for b in model.bodies}
    for b in model.bodies:
        link = out.links[b.name]
        # one setting per call: PyBullet 3.2.7 drops localInertiaDiagonal when the same call also sets
        # maxJointVelocity or activationState (the link keeps a zero inertia: a point mass)
        for setting in ({"localInertiaDiagonal": moments[b.name].tolist()}, {"linearDamping": 0.0},
                        {"angularDamping": 0.0}, {"jointDamping": 0.0}, {"maxJointVelocity": MAX_JOINT_VELOCITY},
                        {"activationState": p.ACTIVATION_STATE_DISABLE_SLEEPING}):
            p.changeDynamics(out.body, link, physicsClientId=client, **setting)
        held = np.asarray(p.getDynamicsInfo(out.body, link, physicsClientId=client)[2], dtype=float)
        if not np.array_equal(held, moments[b.name]):
            raise RuntimeError(f"PyBullet holds principal moments {held.tolist()} kg m^2 for {b.name!r}, "
                               f"set {moments[b.name].tolist()}")
        if link >= 0:
            _motor_off(out.body, link, b.joint, client)
    out.springs = [(out.links[s.body], float(s.stiffness), float(s.q_ref)) for s in JOINT_SPRINGS.elements(model)]
    out.point_springs = [(s, s.body_a, s.body_b) for s in POINT_SPRINGS.elements(model)]
    p.setGravity(*np.asarray(model.gravity_W, dtype=float).tolist(), physicsClientId=client)
    p.setPhysicsEngineParameter(fixedTimeStep=float(dt), numSubSteps=0, physicsClientId=client)
    set_initial_state(out, model)
    return out


def _motor_off(body: int, link: int, kind: str, client: int) -> None:
    """Switch off the joint motor PyBullet gives every joint (a velocity motor towards 0)."""
    p = _pybullet()
    if kind == BALL.name:
        p.setJointMotorControlMultiDof(body, link, p.POSITION_CONTROL, targetPosition=[0, 0, 0, 1],
                                       targetVelocity=[0, 0, 0], positionGain=0, velocityGain=0, force=[0, 0, 0],
                                       physicsClientId=client)
    else:
        p.setJointMotorControl2(body, link, p.VELOCITY_CONTROL, force=0.0, physicsClientId=client)


def set_initial_state(pm: PyBulletModel, model: Multibody) -> None:
    """The scene's joint coordinates into PyBullet's: a hinge's or slide's coordinate as is (the
    same axis); a ball's quaternion (``xyzw``) and its relative angular velocity in the child
    (PyBullet's spherical velocity is in the child frame too); a floating body's pose and
    velocity as its inertial frame's (centre of mass, world)."""
    p = _pybullet()
    c = pm.client
    for b in model.bodies:
        q0 = np.asarray(model.q0[b.name], dtype=float)
        v0 = np.asarray(model.v0[b.name], dtype=float)
        link = pm.links[b.name]
        if b.joint == FREE.name:  # q = [p_WB_W, quat_WB], v = [v_WB_W, w_WB_B]
            quat = q0[3:7] / np.linalg.norm(q0[3:7])
            R_WB = rotations.matrix(quat)
            p_WC = q0[:3] + R_WB @ pm.p_BCm_B[b.name]
            w_W = R_WB @ v0[3:6]
            v_WC = v0[:3] + rotations.cross(w_W, R_WB @ pm.p_BCm_B[b.name])
            p.resetBasePositionAndOrientation(pm.body, p_WC.tolist(), _xyzw(R_WB @ pm.R_BI[b.name]), physicsClientId=c)
            p.resetBaseVelocity(pm.body, v_WC.tolist(), w_W.tolist(), physicsClientId=c)
        elif b.joint == BALL.name:
            quat = q0 / np.linalg.norm(q0)
            p.resetJointStateMultiDof(pm.body, link, targetValue=rotations.wxyz_to_xyzw(quat).tolist(),
                                      targetVelocity=v0.tolist(), physicsClientId=c)
        else:
            p.resetJointState(pm.body, link, float(q0[0]), float(v0[0]), physicsClientId=c)
