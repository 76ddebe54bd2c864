"""Force elements: the element types a ``Multibody`` carries and one table (``FORCES``) of what
each type is to the rest of the harness.

A ``ForceType`` names the ``Multibody`` field that holds its elements, what it contributes to
the energy evaluated in maximal coordinates (a potential, the ``elastic`` energy, or a power
whose integral is work), its generalised force on its joint's coordinate in common coordinates
where it acts on one joint (``harness.model.joints``), its sanity rules, and how each model file
expresses it.

Element types
-------------
* ``PointForce``: a prescribed force ``f_W(t)`` (N, world) at a point fixed in a body; it does
  work (power ``f_W · v_Q``). Its time law is a Python callable, or a ``HarmonicForce`` (constant
  plus cosine and sine terms, ``PointForce.harmonic``) that compiled code can evaluate. MJCF: a site at the point and three motors ``<name>_fx/_fy/_fz``
  (site transmission, world reference site); URDF: none (Pinocchio gets it as ``fext``).
* ``JointSpring``: a linear spring on a slide joint's coordinate, generalised force
  ``-stiffness (q - q_ref)``, potential ``stiffness (q - q_ref)^2 / 2``. MJCF: the joint's
  ``stiffness`` with ``springref``; URDF: none (Pinocchio gets it in ``tau``).
* ``JointTorque``: a constant torque (N m) on a hinge joint's coordinate (a motor), on the child
  about the axis and the opposite on the parent; it does work (power ``torque q'``). MJCF: a
  ``<general>`` actuator on the joint with constant bias (``biastype="affine"``,
  ``biasprm="torque 0 0"``, zero gain); URDF: none (Pinocchio gets it in ``tau``).
* ``PointSpring``: a linear spring between a point fixed in a body and a point fixed in another
  body or in the world, with a linear damper in parallel (``damping`` c, 0: none), force
  ``-(stiffness (L - rest_length) + damping L')`` along the line (L the distance, m; L' its
  rate, m/s), potential ``stiffness (L - rest_length)^2 / 2`` (part of ``elastic``); the damper
  stores nothing and dissipates ``damping L'^2`` (W): its power ``-damping L'^2`` is work in the
  energy balance, so that ``E(0) - E(t)`` is the energy dissipated, ``integral of damping L'^2``.
  MJCF: a spatial ``<tendon>`` through the sites ``<name>_a`` and ``<name>_b`` with
  ``stiffness``, ``springlength`` and ``damping``; URDF: none (Pinocchio gets it as ``fext``).

Adding a force type: its element dataclass and a ``ForceType`` here, its ``Multibody`` field
(``harness.model.multibody``), the in-house force (``harness.engines.inhouse.model`` and
``newton_euler``) and the MJCF writer (``harness.engines.mujoco.model``) where the file format
has it. Energy, power, sanity and Pinocchio's joint-space forces follow from the table. A type
whose power is that of only some of its elements (a point spring's damper) says which
(``ForceType.delivers``); ``does_work`` and the energy balance read it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from harness.model import joints, rotations
from harness.model.errors import InputError



@dataclass(frozen=True)
class HarmonicForce:
    """A force time law given by its numbers: ``f_W(t) = f_const_W + f_cos_W cos(omega t) +
    f_sin_W sin(omega t)`` (N, world; omega in rad/s, t in s). It is a callable ``t -> array(3)``
    like any ``PointForce.force_W``; unlike an arbitrary Python function, compiled code can
    evaluate it from the numbers (the compiled in-house solver does). Build one with
    ``PointForce.harmonic``.

    Attributes:
        f_const_W, f_cos_W, f_sin_W: the constant, cosine and sine amplitudes (N, world).
        omega: angular frequency (rad/s).
    """

    f_const_W: tuple[float, float, float]
    f_cos_W: tuple[float, float, float] = (0.0, 0.0, 0.0)
    f_sin_W: tuple[float, float, float] = (0.0, 0.0, 0.0)
    omega: float = 0.0

    def __call__(self, t: float) -> np.ndarray:
        wt = self.omega * t
        return (np.array(self.f_const_W) + np.array(self.f_cos_W) * np.cos(wt)) + np.array(self.f_sin_W) * np.sin(wt)


@dataclass(frozen=True)
class PointForce:
    """A prescribed force ``f_W(t)`` (N, world frame) applied at a point fixed in a body.

    Attributes:
        body: name of the body the point belongs to.
        p_BQ_B: the point of application in the body frame (m).
        force_W: callable ``t -> array(3)``, the force in world coordinates at time t (s): any
            Python function, or a ``HarmonicForce`` (``harmonic``), whose numbers compiled code
            can evaluate (``law``).
        name: name of the point in the model files (MJCF site, motors ``<name>_fx/_fy/_fz``).
    """

    body: str
    p_BQ_B: np.ndarray
    force_W: Callable[[float], np.ndarray]
    name: str = "force"

    @classmethod
    def harmonic(cls, body: str, p_BQ_B, f_const_W, f_cos_W=(0.0, 0.0, 0.0), f_sin_W=(0.0, 0.0, 0.0),
                 omega: float = 0.0, name: str = "force") -> "PointForce":
        """The force ``f_const_W + f_cos_W cos(omega t) + f_sin_W sin(omega t)`` (N, world;
        omega rad/s) at ``p_BQ_B`` (m, body frame) of ``body``: its ``force_W`` is the
        ``HarmonicForce`` of these numbers."""
        def vector(v) -> tuple[float, float, float]:
            x, y, z = (float(c) for c in np.asarray(v, dtype=float).reshape(3))
            return (x, y, z)

        law = HarmonicForce(vector(f_const_W), vector(f_cos_W), vector(f_sin_W), float(omega))
        return cls(body, np.asarray(p_BQ_B, dtype=float), law, name)

    @property
    def law(self) -> HarmonicForce | None:
        """The force's time law as numbers (``HarmonicForce``), or None for a force given only as
        a Python function."""
        return self.force_W if isinstance(self.force_W, HarmonicForce) else None


@dataclass(frozen=True)
class JointSpring:
    """A linear spring on the coordinate of a ``slide`` joint (the joint of ``body``).

    Attributes:
        body: name of the body whose slide joint carries the spring.
        stiffness: N/m, >= 0.
        q_ref: joint coordinate (m) at which the spring is relaxed (MuJoCo ``springref``).
    """

    body: str
    stiffness: float
    q_ref: float


@dataclass(frozen=True)
class JointTorque:
    """A constant torque on the coordinate of a ``hinge`` joint (the joint of ``body``): the
    torque ``torque`` (N m) about the hinge axis on the body and its opposite on the parent (a
    motor between them); generalised force ``torque`` on the joint coordinate.

    Attributes:
        body: name of the body whose hinge carries the torque.
        torque: N m, finite (sign: about the joint's axis, right-handed).
        name: name of the MJCF actuator that states it.
    """

    body: str
    torque: float
    name: str = "motor"


@dataclass(frozen=True)
class PointSpring:
    """A linear spring between the point ``p_A`` fixed in ``body_a`` and the point ``p_B`` fixed
    in ``body_b`` (or in the world when ``body_b`` is None), with a linear damper in parallel.
    With ``d = x_A - x_B`` (world, m), ``L = |d|`` and ``L' = d . (v_A - v_B) / L`` (m/s, the
    ends' velocities v_A, v_B in world), the force on body_a at its point is ``-(stiffness (L -
    rest_length) + damping L') d / L`` (N, world) and its opposite acts on body_b; potential
    ``stiffness (L - rest_length)^2 / 2`` (J); the damper's power ``-damping L'^2`` (W).

    Attributes:
        name: the spring's name (MJCF tendon ``<name>``, sites ``<name>_a``, ``<name>_b``).
        body_a: name of the body carrying the first end.
        p_A: the first end in body_a's frame (m).
        body_b: name of the body carrying the second end, or None for the world.
        p_B: the second end in body_b's frame, or in world for the world (m).
        stiffness: N/m, >= 0.
        rest_length: m, >= 0.
        damping: N s/m, >= 0 (0: a spring alone).
    """

    name: str
    body_a: str
    p_A: np.ndarray
    body_b: str | None
    p_B: np.ndarray
    stiffness: float
    rest_length: float
    damping: float = 0.0


@dataclass(frozen=True)
class ForceType:
    """One type of force element (see the module docstring).

    Attributes:
        name: identifier of the type.
        element: its element dataclass.
        field: the ``Multibody`` field holding its elements (a tuple).
        label: what an element is called in messages.
        joints: the joint kinds it may act on (``harness.model.joints``); None for an element
            acting at a body point.
        potential: ``(traj, model, element) -> (n,)`` J: its potential energy along a trajectory
            in maximal coordinates (part of ``elastic``), None if it stores none.
        power: ``(traj, model, element) -> (n,)`` W: the power it delivers along a trajectory
            (integrated to work for the energy balance), None if it does no external work.
        joint_force: ``(element, q, v) -> float``: its generalised force on its joint's single
            coordinate (common coordinates), None for an element not acting on a joint.
        joint_potential: ``(element, q) -> float`` J: its potential at joint coordinate q.
        check: ``(element, model, source)``: raise ``InputError`` for a non-physical element.
        mjcf: how an MJCF expresses it (``harness.engines.mujoco.model`` writes it).
        urdf: how a URDF expresses it (None: it cannot).
        works: ``element -> bool``: whether an element delivers power, for a type whose power is
            that of some of its elements only (a point spring with a damper); None: every
            element of a type with ``power`` (``delivers``).
    """

    name: str
    element: type
    field: str
    label: str
    joints: tuple[str, ...] | None
    potential: Callable | None
    power: Callable | None
    joint_force: Callable | None
    joint_potential: Callable | None
    check: Callable
    mjcf: str
    urdf: str | None
    works: Callable | None = None

    def elements(self, model) -> tuple:
        """The model's elements of this type."""
        return tuple(getattr(model, self.field, ()))

    def delivers(self, element) -> bool:
        """Whether ``element`` delivers power (its ``power`` counts in the energy balance)."""
        return self.power is not None and (self.works is None or bool(self.works(element)))


# --------------------------------------------------------------------------- point forces


def _point_force_power(traj, model, force: PointForce) -> np.ndarray:
    """f_W(t) · v_Q (W): the velocity of the material point Q from the body's twist."""
    i = traj.body_index(force.body)
    R = rotations.matrix(traj.quat_WB[:, i])
    r_W = R @ (force.p_BQ_B - model.body(force.body).p_BCm_B)
    v_Q = traj.v_WCm_W[:, i] + np.cross(traj.w_WB_W[:, i], r_W)
    f = np.stack([force.force_W(t) for t in traj.t])
    return np.einsum("ti,ti->t", f, v_Q)


def _check_point_force(force: PointForce, model, source: str) -> None:
    if force.body not in model.body_names:
        raise InputError(f"{source}: force {force.name!r}: no body named {force.body!r}")
    if not np.all(np.isfinite(force.p_BQ_B)):
        raise InputError(f"{source}: force {force.name!r}: point of application is not finite")
    law = force.law
    if law is not None and not np.all(np.isfinite([*law.f_const_W, *law.f_cos_W, *law.f_sin_W, law.omega])):
        raise InputError(f"{source}: force {force.name!r}: its amplitudes and frequency must be finite")


# --------------------------------------------------------------------------- joint springs


def _spring_potential(traj, model, spring: JointSpring) -> np.ndarray:
    """k (q - q_ref)^2 / 2 with q recovered from maximal coordinates (``joints.coordinate``)."""
    return 0.5 * spring.stiffness * (joints.coordinate(traj, model, spring.body) - spring.q_ref) ** 2


def _spring_joint_force(spring: JointSpring, q: float, v: float) -> float:
    return -spring.stiffness * (q - spring.q_ref)


def _spring_joint_potential(spring: JointSpring, q: float) -> float:
    return 0.5 * spring.stiffness * (q - spring.q_ref) ** 2


def _check_spring(spring: JointSpring, model, source: str) -> None:
    if not (np.isfinite(spring.stiffness) and spring.stiffness >= 0.0 and np.isfinite(spring.q_ref)):
        raise InputError(f"{source}: spring on {spring.body!r}: stiffness must be finite and >= 0, rest position finite")


# --------------------------------------------------------------------------- joint torques


def _joint_rate(traj, model, body_name: str) -> np.ndarray:
    """The hinge rate q' (n,) rad/s of body ``body_name``'s joint from maximal coordinates: the
    child's angular velocity relative to the parent along the axis (world)."""
    body = model.body(body_name)
    i = traj.body_index(body_name)
    R = rotations.matrix(traj.quat_WB[:, i])
    axis_W = R @ (np.asarray(body.axis_B, float) / np.linalg.norm(body.axis_B))
    w_rel = traj.w_WB_W[:, i] - (0.0 if body.parent is None else traj.w_WB_W[:, traj.body_index(body.parent)])
    return np.einsum("ti,ti->t", w_rel, axis_W)


def _torque_power(traj, model, torque: JointTorque) -> np.ndarray:
    """torque q' (W)."""
    return torque.torque * _joint_rate(traj, model, torque.body)


def _torque_joint_force(torque: JointTorque, q: float, v: float) -> float:
    return torque.torque


def _check_torque(torque: JointTorque, model, source: str) -> None:
    if not np.isfinite(torque.torque):
        raise InputError(f"{source}: torque on {torque.body!r}: torque must be finite")


# --------------------------------------------------------------------------- point springs


def spring_ends(traj, model, spring: PointSpring) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(x_A, x_B, v_A, v_B)``: the spring's two ends and their velocities in world (n, 3) (m,
    m/s) from maximal coordinates (the world end at rest)."""
    def end(body_name, p):
        p = np.asarray(p, float)
        if body_name is None:
            n = len(traj.t)
            return np.broadcast_to(p, (n, 3)), np.zeros((n, 3))
        i = traj.body_index(body_name)
        r = rotations.matrix(traj.quat_WB[:, i]) @ (p - model.body(body_name).p_BCm_B)
        return traj.p_WCm_W[:, i] + r, traj.v_WCm_W[:, i] + np.cross(traj.w_WB_W[:, i], r)

    (x_A, v_A), (x_B, v_B) = end(spring.body_a, spring.p_A), end(spring.body_b, spring.p_B)
    return x_A, x_B, v_A, v_B


def spring_force(spring: PointSpring, x_A: np.ndarray, x_B: np.ndarray, v_A: np.ndarray | None = None,
                 v_B: np.ndarray | None = None) -> np.ndarray:
    """The force (N, world) on body_a's end of a point spring with ends ``x_A``, ``x_B`` (m,
    world) moving at ``v_A``, ``v_B`` (m/s, world; broadcasts over leading axes): ``-(k (L - L0)
    + c L') (x_A - x_B) / L``, ``L' = (x_A - x_B) . (v_A - v_B) / L``. The velocities are needed
    only with a damper (``damping`` > 0; ValueError without them)."""
    d = np.asarray(x_A, float) - np.asarray(x_B, float)
    L = np.linalg.norm(d, axis=-1, keepdims=True)
    magnitude = spring.stiffness * (L - spring.rest_length)
    if spring.damping:
        magnitude = magnitude + spring.damping * length_rate(spring, d, L, v_A, v_B)
    return -magnitude * d / L


def length_rate(spring: PointSpring, d: np.ndarray, L: np.ndarray, v_A, v_B) -> np.ndarray:
    """L' = d . (v_A - v_B) / L (m/s, keeping the last axis) of a spring with ``d = x_A - x_B``
    and ``L = |d|`` (keepdims) whose ends move at ``v_A``, ``v_B`` (m/s, world)."""
    if v_A is None or v_B is None:
        raise ValueError(f"spring {spring.name!r} has a damper: its force needs the ends' velocities")
    dv = np.asarray(v_A, float) - np.asarray(v_B, float)
    return np.sum(d * dv, axis=-1, keepdims=True) / L


def damper_power(spring: PointSpring, x_A: np.ndarray, x_B: np.ndarray, v_A: np.ndarray, v_B: np.ndarray) -> np.ndarray:
    """The power (W) of a point spring's damper, ``-c L'^2`` (broadcasts over leading axes, the
    last axis dropped): what it dissipates, with the opposite sign (the spring's own force is
    conservative: its potential)."""
    d = np.asarray(x_A, float) - np.asarray(x_B, float)
    L = np.linalg.norm(d, axis=-1, keepdims=True)
    return -spring.damping * length_rate(spring, d, L, v_A, v_B)[..., 0] ** 2


def spring_potential(spring: PointSpring, x_A: np.ndarray, x_B: np.ndarray) -> np.ndarray:
    """The potential (J) of a point spring with ends ``x_A``, ``x_B`` (m, world; broadcasts over
    leading axes): ``k (L - L0)^2 / 2``."""
    L = np.linalg.norm(np.asarray(x_A, float) - np.asarray(x_B, float), axis=-1)
    return 0.5 * spring.stiffness * (L - spring.rest_length) ** 2


def _point_spring_potential(traj, model, spring: PointSpring) -> np.ndarray:
    return spring_potential(spring, *spring_ends(traj, model, spring)[:2])


def _point_damper_power(traj, model, spring: PointSpring) -> np.ndarray:
    """-c L'^2 (W) of the spring's damper along a trajectory (zero without one)."""
    if not spring.damping:
        return np.zeros(len(traj.t))
    return damper_power(spring, *spring_ends(traj, model, spring))


def _check_point_spring(spring: PointSpring, model, source: str) -> None:
    for body in (spring.body_a, spring.body_b):
        if body is not None and body not in model.body_names:
            raise InputError(f"{source}: spring {spring.name!r}: no body named {body!r}")
    if spring.body_a == spring.body_b:
        raise InputError(f"{source}: spring {spring.name!r}: both ends on {spring.body_a!r}")
    if not (np.isfinite(spring.stiffness) and spring.stiffness >= 0.0
            and np.isfinite(spring.rest_length) and spring.rest_length >= 0.0):
        raise InputError(f"{source}: spring {spring.name!r}: stiffness and rest length must be finite and >= 0")
    if not (np.isfinite(spring.damping) and spring.damping >= 0.0):
        raise InputError(f"{source}: spring {spring.name!r}: damping must be finite and >= 0")
    if not (np.all(np.isfinite(spring.p_A)) and np.all(np.isfinite(spring.p_B))):
        raise InputError(f"{source}: spring {spring.name!r}: its end points are not finite")


# --------------------------------------------------------------------------- the table


POINT_FORCES = ForceType(
    name="point_force", element=PointForce, field="forces", label="force", joints=None,
    potential=None, power=_point_force_power, joint_force=None, joint_potential=None, check=_check_point_force,
    mjcf="site <name> at p_BQ_B in the body, motors <name>_fx/_fy/_fz (site transmission, world reference site)",
    urdf=None,
)
JOINT_SPRINGS = ForceType(
    name="joint_spring", element=JointSpring, field="springs", label="spring", joints=(joints.SLIDE.name,),
    potential=_spring_potential, power=None, joint_force=_spring_joint_force, joint_potential=_spring_joint_potential,
    check=_check_spring, mjcf="stiffness and springref of the body's joint", urdf=None,
)

JOINT_TORQUES = ForceType(
    name="joint_torque", element=JointTorque, field="torques", label="torque", joints=(joints.HINGE.name,),
    potential=None, power=_torque_power, joint_force=_torque_joint_force, joint_potential=None, check=_check_torque,
    mjcf="<general> actuator <name> on the body's joint: gainprm 0, biastype affine, biasprm \"torque 0 0\"",
    urdf=None,
)
POINT_SPRINGS = ForceType(
    name="point_spring", element=PointSpring, field="point_springs", label="spring", joints=None,
    potential=_point_spring_potential, power=_point_damper_power, joint_force=None, joint_potential=None,
    check=_check_point_spring,
    mjcf="spatial <tendon> <name> through sites <name>_a, <name>_b: stiffness, springlength, damping", urdf=None,
    works=lambda spring: spring.damping > 0.0,  # a spring alone delivers none: only its damper does
)

FORCES: dict[str, ForceType] = {ft.name: ft for ft in (POINT_FORCES, JOINT_SPRINGS, JOINT_TORQUES, POINT_SPRINGS)}


def elements(model):
    """Every force element of ``model`` as ``(ForceType, element)``, in table order."""
    for ft in FORCES.values():
        for element in ft.elements(model):
            yield ft, element


def does_work(model) -> bool:
    """Whether the model has elements that deliver power (its energy is balanced against their
    work rather than conserved): prescribed forces, torques, a point spring's damper."""
    return any(ft.delivers(element) for ft, element in elements(model))


def check_forces(model, source: str) -> None:
    """Raise InputError naming the first non-physical force element of ``model``: on a joint
    kind it cannot act on, or failing its type's own rules (``ForceType.check``)."""
    kinds = {b.name: b.joint for b in model.bodies}
    for ft, element in elements(model):
        if ft.joints is not None and kinds.get(element.body) not in ft.joints:
            raise InputError(f"{source}: {ft.label} on {element.body!r}: {ft.label}s act on "
                             f"{' or '.join(ft.joints)} joints only")
        ft.check(element, model, source)
