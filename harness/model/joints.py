"""Joint kinds: the one table (``JOINTS``) that every engine and tool reads.

A ``JointType`` says what a kind of joint is: its coordinates (nq, nv), its axis, whether it
must be a root, the conditions it imposes between its child's and its parent's maximal
coordinates (and so the rows it removes), and how each model file and engine names it (the
MJCF joint type and MuJoCo's ``mjtJoint`` member, Pinocchio's joint models, the URDF joint
types). It also holds the per-joint physics in common coordinates that several modules need:
the joint's relative motion (forward kinematics), its coordinate recovered from maximal
coordinates, a seeded random state, the retraction and the distance of two configurations.

Frames and conventions
----------------------
* World frame W: z up; gravity is ``Multibody.gravity_W`` (m/s^2).
* Each body B has a body frame whose origin is its joint (for a free body: any point, here the
  centre of mass). ``p_PB_P`` is the position of B's frame origin in its parent's frame P at zero
  joint configuration, and the body frame is parallel to the parent frame there.
* ``p_BCm_B`` is the centre of mass in the body frame; ``I_Cm_B`` the 3x3 inertia tensor about
  the centre of mass, expressed in the body frame (kg m^2).
* Quaternions are unit quaternions in ``wxyz`` order (scalar first), rotating body to parent.

Joint coordinates (shared by all engines: the MJCF and URDF use the same tree; MuJoCo's own)
--------------------------------------------------------------------------------------------
* ``hinge``: q = [angle] (rad, right-handed about ``axis_B``), v = [rate] (rad/s).
* ``ball``: q = quat_wxyz of B relative to P (4), v = angular velocity of B relative to P,
  expressed in B (rad/s, 3).
* ``free`` (parent must be world): q = [p_WB_W (3), quat_wxyz (4)], v = [v_WB_W (3): velocity of
  the body frame origin in world, w_WB_B (3): angular velocity expressed in the body frame].
* ``slide`` (prismatic): q = [displacement] (m) along ``axis_B`` (unit, body frame = parent frame:
  the frames stay parallel), v = [rate] (m/s); B's frame origin is at ``p_PB_P + q axis_B`` in
  the parent frame.

Pinocchio differs in two places (converted in ``harness.engines.pinocchio.model`` only):
quaternions are ``xyzw``, and the free flyer's linear velocity is in the body frame.

Adding a joint kind: a ``JointType`` here (with its motion, draw, retract and distance, and
its ``ExudynJoint``), the
in-house constraint rows (``harness.engines.inhouse.model`` and ``constraints``: rows are
built per ``Condition``), and the engines' model editors where a file format or an engine's
coordinates need it (``harness.engines.mujoco.model``, ``harness.engines.pinocchio.model``).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Callable, Iterable

import numpy as np

from harness.model import rotations

ROTATIONAL = "rotational"
TRANSLATIONAL = "translational"


@dataclass(frozen=True)
class Condition:
    """A condition a joint imposes between its child's and its parent's maximal coordinates.

    Attributes:
        name: short identifier.
        rows: number of scalar conditions (rows of the constraint Jacobian it adds).
        measure: which violation measures it (``harness.measure.compare.constraint_violation``):
            ``"position"`` (m) or ``"axis"`` (rad).
        text: what it says, for reports ("<joint kind> <text>").
        violation: ``(x_c, x_p, R_c, R_p, axis_B) -> (n,)``: how far a trajectory is from it
            (m or rad), from the joint's frames in maximal coordinates (``joint_frames``).
    """

    name: str
    rows: int
    measure: str
    text: str
    violation: Callable


def _point_gap(x_c, x_p, R_c, R_p, axis_B) -> np.ndarray:
    """Distance (m) between the joint point as carried by the child and by the parent."""
    return np.linalg.norm(x_c - x_p, axis=-1)


def _line_gap(x_c, x_p, R_c, R_p, axis_B) -> np.ndarray:
    """Distance (m) of the child's joint point from the parent's line along the axis."""
    gap = x_c - x_p
    a_W = R_p @ axis_B
    gap = gap - np.einsum("ti,ti->t", gap, a_W)[:, None] * a_W
    return np.linalg.norm(gap, axis=-1)


def _axis_angle(x_c, x_p, R_c, R_p, axis_B) -> np.ndarray:
    """Angle (rad) between the axis carried by the child and by the parent."""
    a_child = R_c @ axis_B
    a_parent = R_p @ axis_B
    s = np.linalg.norm(np.cross(a_child, a_parent), axis=-1)
    c = np.einsum("ti,ti->t", a_child, a_parent)
    return np.arctan2(s, c)


def _frame_angle(x_c, x_p, R_c, R_p, axis_B) -> np.ndarray:
    """Geodesic angle (rad) of the child's orientation relative to the parent's."""
    R_rel = np.swapaxes(R_p, -1, -2) @ R_c
    cos = np.clip((np.trace(R_rel, axis1=-2, axis2=-1) - 1.0) / 2.0, -1.0, 1.0)
    skew = np.stack([R_rel[:, 2, 1] - R_rel[:, 1, 2], R_rel[:, 0, 2] - R_rel[:, 2, 0], R_rel[:, 1, 0] - R_rel[:, 0, 1]], axis=-1)
    return np.arctan2(0.5 * np.linalg.norm(skew, axis=-1), cos)


POINT = Condition("point", 3, "position", "joint points coincide", _point_gap)
ON_AXIS = Condition("on_axis", 2, "position", "joint point stays on the axis line", _line_gap)
ALIGNED = Condition("aligned", 2, "axis", "axes stay aligned", _axis_angle)
PARALLEL = Condition("parallel", 3, "axis", "frames stay parallel", _frame_angle)
CONDITIONS = (POINT, ON_AXIS, ALIGNED, PARALLEL)


@dataclass(frozen=True)
class ExudynJoint:
    """How Exudyn states a joint kind (``harness.engines.exudyn``): as a joint object between
    the parent's and the child's markers, with Lagrange multipliers.

    Attributes:
        create: the ``MainSystem`` method that creates it (``CreateRevoluteJoint`` ...).
        object_type: the type of the object it creates (``JointRevoluteZ`` ...).
        free_axis: the column of the joint frame along which it moves (revolute: z, prismatic:
            x), None without an axis.
        force_output: the output that holds its constraint force on the parent: ``Force``
            (world) or ``ForceLocal`` (the parent's joint frame J0).
        rotation_conditions: per entry of its ``TorqueLocal`` (the multipliers of its rotation
            conditions), ``(a, b)`` of the condition ``a0 . b1 = 0`` between column a of the
            parent's joint frame and column b of the child's; empty without them.
    """

    create: str
    object_type: str
    free_axis: int | None
    force_output: str
    rotation_conditions: tuple[tuple[int, int], ...] = ()


@dataclass(frozen=True)
class JointType:
    """One kind of joint (see the module docstring for its coordinates).

    Attributes:
        name: the harness's name, also the MJCF ``<joint type=...>`` (``Body.joint``).
        nq, nv: sizes of its configuration and velocity coordinates.
        axis: ``ROTATIONAL`` or ``TRANSLATIONAL`` for a joint along ``Body.axis_B``, else None.
        root_only: the joint must attach its body to the world.
        conditions: the ``Condition``s it imposes in maximal coordinates (none for a free joint).
        mujoco: the ``mujoco.mjtJoint`` member name (resolved by the MuJoCo engine).
        pinocchio: regular expression of the Pinocchio joint models (``shortname()`` without
            the ``JointModel`` prefix) that the loaders map to this kind.
        pinocchio_root: the joint model Pinocchio adds as a URDF's root joint for this kind
            (``pin.JointModel<...>``), None when a URDF can state the joint itself.
        urdf: the URDF joint types of this kind (none for free and ball: a URDF cannot state
            them; Pinocchio adds them as the root joint).
        urdf_root: the scene's ``urdf_root_joint`` that makes Pinocchio add this kind.
        exudyn: how Exudyn states it (``ExudynJoint``), None for a joint Exudyn needs no object
            for (free: an unconnected body).
        drake: Drake's joint ``type_name()``s of this kind (Drake's ball is ``BallRpyJoint``:
            the same kind in roll-pitch-yaw coordinates).
        quat_at: index in q of a ``wxyz`` quaternion, None without one.
        world_linear_velocity: v starts with the world-frame velocity of the body-frame origin.
        motion: ``(body, q, v) -> (p, R, v_rel, w_rel)``: B's frame origin in the parent frame
            (m), the rotation parent <- body (None: identity), the velocity of B's origin
            relative to the parent frame, in P (None: zero), and B's angular velocity relative
            to P, in B (None: zero).
        coordinate: ``(x_c, x_p, R_c, R_p, body) -> q`` (n,): the coordinate of a 1-dof joint
            recovered from maximal coordinates (``joint_frames``); None where not defined.
        draw: ``(rng, limits) -> (q, v)``: a seeded random state (``limits``: (lower, upper)
            of q for a limited 1-dof joint, or None).
        retract: ``(q, d) -> q'``: the configuration reached in unit time at constant
            velocity coordinates ``d``.
        distance: ``(qa, qb) -> float``: distance of two configurations (rad or m).
    """

    name: str
    nq: int
    nv: int
    axis: str | None
    root_only: bool
    conditions: tuple[Condition, ...]
    mujoco: str
    pinocchio: str
    pinocchio_root: str | None
    urdf: tuple[str, ...]
    urdf_root: str | None
    quat_at: int | None
    world_linear_velocity: bool
    motion: Callable
    coordinate: Callable | None
    draw: Callable
    retract: Callable
    distance: Callable
    exudyn: ExudynJoint | None = None
    drake: tuple[str, ...] = ()

    @property
    def rows(self) -> int:
        """Rows the joint removes in maximal coordinates (6 - nv for these joints)."""
        return sum(c.rows for c in self.conditions)

    @property
    def constrained(self) -> bool:
        """Whether the joint imposes any condition (has a joint point and a reaction)."""
        return bool(self.conditions)


# --------------------------------------------------------------------------- per-joint physics


def _random_quat(rng) -> np.ndarray:
    quat = rng.normal(size=4)
    return rotations.canonical(quat / np.linalg.norm(quat))


def _quat_exp_right(quat: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``quat * exp(w)``: rotation by the body-frame rotation vector ``w`` (rad)."""
    angle = float(np.linalg.norm(w))
    if angle == 0.0:
        return np.array(quat, dtype=float)
    return rotations.multiply(quat, rotations.from_axis_angle(w, angle))


def _free_motion(body, q, v):
    return q[:3], rotations.matrix(q[3:7] / np.linalg.norm(q[3:7])), v[:3], v[3:6]


def _ball_motion(body, q, v):
    return body.p_PB_P, rotations.matrix(q / np.linalg.norm(q)), None, v


def _hinge_motion(body, q, v):
    return body.p_PB_P, rotations.matrix(rotations.from_axis_angle(body.axis_B, q[0])), None, body.axis_B * v[0]


def _slide_motion(body, q, v):
    return body.p_PB_P + body.axis_B * q[0], None, body.axis_B * v[0], None


def _slide_coordinate(x_c, x_p, R_c, R_p, body) -> np.ndarray:
    """(x_c - x_p)·a_W, a_W the axis in world through the parent's orientation."""
    return np.einsum("ti,ti->t", x_c - x_p, R_p @ body.axis_B)


def _draw_free(rng, limits):
    q = np.zeros(7)
    q[:3] = rng.uniform(-1.0, 1.0, 3)
    q[3:7] = _random_quat(rng)
    return q, rng.normal(0.0, 1.0, 6)


def _draw_ball(rng, limits):
    q = _random_quat(rng)
    return q, rng.normal(0.0, 1.0, 3)


def _draw_along_axis(span: float, rate: float):
    """Angle or displacement uniform in [-span, span] intersected with the limits (a range that
    does not meet it is used as it is), rate ~ N(0, rate)."""

    def draw(rng, limits):
        lo, hi = limits if limits else (-span, span)
        if max(lo, -span) < min(hi, span):  # very wide limits (1e16 for "unlimited"): the usual range
            lo, hi = max(lo, -span), min(hi, span)
        q = np.array([rng.uniform(lo, hi)])
        return q, np.array([rng.normal(0.0, rate)])

    return draw


def _retract_free(q, d):
    out = np.array(q, dtype=float)
    out[:3] += d[:3]
    out[3:7] = _quat_exp_right(out[3:7], d[3:])
    return out


def _retract_ball(q, d):
    return _quat_exp_right(np.array(q, dtype=float), d)


def _retract_along_axis(q, d):
    out = np.array(q, dtype=float)
    out[0] += d[0]
    return out


def _distance_free(a, b) -> float:
    return max(float(np.linalg.norm(a[:3] - b[:3])), float(rotations.geodesic_angle(a[3:7], b[3:7])))


def _distance_ball(a, b) -> float:
    return float(rotations.geodesic_angle(a, b))


def _distance_hinge(a, b) -> float:
    return abs(float((a[0] - b[0] + np.pi) % (2 * np.pi) - np.pi))


def _distance_slide(a, b) -> float:
    return abs(float(a[0] - b[0]))


# --------------------------------------------------------------------------- the table


FREE = JointType(
    name="free", nq=7, nv=6, axis=None, root_only=True, conditions=(),
    mujoco="mjJNT_FREE", pinocchio=r"FreeFlyer", pinocchio_root="FreeFlyer", urdf=(), urdf_root="free",
    quat_at=3, world_linear_velocity=True,
    motion=_free_motion, coordinate=None, draw=_draw_free, retract=_retract_free, distance=_distance_free,
    drake=("quaternion_floating", "rpy_floating"),
)
BALL = JointType(
    name="ball", nq=4, nv=3, axis=None, root_only=False, conditions=(POINT,),
    mujoco="mjJNT_BALL", pinocchio=r"Spherical", pinocchio_root="Spherical", urdf=(), urdf_root="spherical",
    quat_at=0, world_linear_velocity=False,
    motion=_ball_motion, coordinate=None, draw=_draw_ball, retract=_retract_ball, distance=_distance_ball,
    exudyn=ExudynJoint("CreateSphericalJoint", "JointSpherical", None, "Force"), drake=("ball_rpy",),
)
HINGE = JointType(
    name="hinge", nq=1, nv=1, axis=ROTATIONAL, root_only=False, conditions=(POINT, ALIGNED),
    mujoco="mjJNT_HINGE", pinocchio=r"R[XYZ]|RevoluteUnaligned|RUB[XYZ]|RevoluteUnboundedUnaligned",
    pinocchio_root=None, urdf=("revolute", "continuous"), urdf_root=None,
    quat_at=None, world_linear_velocity=False,
    motion=_hinge_motion, coordinate=None, draw=_draw_along_axis(np.pi, 1.0), retract=_retract_along_axis,
    distance=_distance_hinge,
    exudyn=ExudynJoint("CreateRevoluteJoint", "JointRevoluteZ", 2, "ForceLocal", ((2, 0), (2, 1))), drake=("revolute",),
)
SLIDE = JointType(
    name="slide", nq=1, nv=1, axis=TRANSLATIONAL, root_only=False, conditions=(ON_AXIS, PARALLEL),
    mujoco="mjJNT_SLIDE", pinocchio=r"P[XYZ]|PrismaticUnaligned", pinocchio_root=None, urdf=("prismatic",),
    urdf_root=None, quat_at=None, world_linear_velocity=False,
    motion=_slide_motion, coordinate=_slide_coordinate, draw=_draw_along_axis(0.5, 0.5), retract=_retract_along_axis,
    distance=_distance_slide,
    exudyn=ExudynJoint("CreatePrismaticJoint", "JointPrismaticX", 0, "ForceLocal", ((2, 1), (2, 0), (0, 1))),
    drake=("prismatic",),
)

JOINTS: dict[str, JointType] = {jt.name: jt for jt in (FREE, BALL, HINGE, SLIDE)}


# --------------------------------------------------------------------------- lookups


def by_mujoco(member: str) -> JointType | None:
    """The kind whose ``mujoco.mjtJoint`` member is named ``member`` (e.g. ``mjJNT_HINGE``)."""
    return next((jt for jt in JOINTS.values() if jt.mujoco == member), None)


def by_drake(type_name: str) -> JointType | None:
    """The kind of a Drake joint by its ``type_name()`` (e.g. ``revolute``, ``ball_rpy``)."""
    return next((jt for jt in JOINTS.values() if type_name in jt.drake), None)


def by_exudyn(object_type: str) -> JointType | None:
    """The kind whose Exudyn joint object has type ``object_type`` (e.g. ``JointRevoluteZ``)."""
    return next((jt for jt in JOINTS.values() if jt.exudyn and jt.exudyn.object_type == object_type), None)


def by_pinocchio(shortname: str) -> JointType | None:
    """The kind of a Pinocchio joint model from its ``shortname()`` (``JointModelRX`` ...)."""
    kind = shortname.removeprefix("JointModel")
    return next((jt for jt in JOINTS.values() if re.fullmatch(jt.pinocchio, kind)), None)


def by_urdf_root(root: str) -> JointType | None:
    """The kind Pinocchio adds for a scene's ``urdf_root_joint`` (None for ``none``)."""
    return next((jt for jt in JOINTS.values() if jt.urdf_root == root), None)


def keeps_axis(kind: str) -> bool:
    """Whether joints of ``kind`` keep an axis aligned between their two bodies (``ALIGNED``: a
    hinge), e.g. to know whether a loop joint has axis rows."""
    return ALIGNED in JOINTS[kind].conditions


def loop_kinds() -> tuple[str, ...]:
    """The kinds a loop (cut) joint may be (``harness.model.multibody.LoopJoint``): those whose
    conditions start with a coinciding joint point (ball, hinge)."""
    return tuple(name for name, jt in JOINTS.items() if jt.conditions[:1] == (POINT,))


def angular_conditions(kinds: Iterable[str]) -> list[str]:
    """"<kind> <condition>" for each angular condition (``measure == "axis"``) that the joint
    kinds ``kinds`` impose, in table order (e.g. ``["hinge axes stay aligned"]``)."""
    present = set(kinds)
    return [f"{jt.name} {c.text}" for jt in JOINTS.values() if jt.name in present
            for c in jt.conditions if c.measure == "axis"]


# --------------------------------------------------------------------------- maximal coordinates


def joint_frames(traj, model, name: str, R_all: np.ndarray | None = None):
    """The joint of body ``name`` seen in maximal coordinates (a ``Trajectory``, n samples).

    Returns ``(x_c, x_p, R_c, R_p)``: the joint point in world as carried by the child (its
    body-frame origin) and by the parent (its point ``p_PB_P``, or the world point for a root),
    each (n, 3) m, and the child's and parent's rotations body -> world (n, 3, 3) (identity for
    the world). ``R_all``: the rotations of all bodies (n, nbody, 3, 3), if already computed.
    """
    body = model.body(name)
    if R_all is None:
        R_all = rotations.matrix(traj.quat_WB.reshape(-1, 4)).reshape(traj.quat_WB.shape[:2] + (3, 3))
    i = traj.body_index(name)
    R_c = R_all[:, i]
    x_c = traj.p_WCm_W[:, i] - R_c @ body.p_BCm_B
    if body.parent is None:
        return x_c, np.broadcast_to(body.p_PB_P, x_c.shape), R_c, np.broadcast_to(np.eye(3), R_c.shape)
    j = traj.body_index(body.parent)
    R_p = R_all[:, j]
    x_p = traj.p_WCm_W[:, j] + R_p @ (body.p_PB_P - model.body(body.parent).p_BCm_B)
    return x_c, x_p, R_c, R_p


def coordinate(traj, model, name: str) -> np.ndarray:
    """The joint coordinate q (n,) of body ``name``'s 1-dof joint recovered from maximal
    coordinates (``JointType.coordinate``; m for a slide)."""
    jt = JOINTS[model.body(name).joint]
    if jt.coordinate is None:
        raise NotImplementedError(f"no coordinate from maximal coordinates for a {jt.name} joint")
    return jt.coordinate(*joint_frames(traj, model, name), model.body(name))
