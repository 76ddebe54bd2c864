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
  work (power ``f_W · v_Q``). MJCF: a site at the point and three motors ``<name>_fx/_fy/_fz``
  (site transmission, world reference site); URDF: none (Pinocchio gets it as ``fext``).
* ``JointSpring``: a linear spring on a slide joint's coordinate, generalised force
  ``-stiffness (q - q_ref)``, potential ``stiffness (q - q_ref)^2 / 2``. MJCF: the joint's
  ``stiffness`` with ``springref``; URDF: none (Pinocchio gets it in ``tau``).

Adding a force type: its element dataclass and a ``ForceType`` here, its ``Multibody`` field
(``harness.model.multibody``), the in-house force (``harness.engines.inhouse.model`` and
``newton_euler``) and the MJCF writer (``harness.engines.mujoco.model``) where the file format
has it. Energy, power, sanity and Pinocchio's joint-space forces follow from the table.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from harness.model import joints, rotations
from harness.model.errors import InputError



@dataclass(frozen=True)
class PointForce:
    """A prescribed force ``f_W(t)`` (N, world frame) applied at a point fixed in a body.

    Attributes:
        body: name of the body the point belongs to.
        p_BQ_B: the point of application in the body frame (m).
        force_W: callable ``t -> array(3)``, the force in world coordinates at time t (s).
        name: name of the point in the model files (MJCF site, motors ``<name>_fx/_fy/_fz``).
    """

    body: str
    p_BQ_B: np.ndarray
    force_W: Callable[[float], np.ndarray]
    name: str = "force"


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

    def elements(self, model) -> tuple:
        """The model's elements of this type."""
        return tuple(getattr(model, self.field, ()))


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

FORCES: dict[str, ForceType] = {ft.name: ft for ft in (POINT_FORCES, JOINT_SPRINGS)}


def elements(model):
    """Every force element of ``model`` as ``(ForceType, element)``, in table order."""
    for ft in FORCES.values():
        for element in ft.elements(model):
            yield ft, element


def does_work(model) -> bool:
    """Whether the model has elements that deliver power (its energy is balanced against their
    work rather than conserved)."""
    return any(ft.power is not None and ft.elements(model) for ft in FORCES.values())


def check_forces(model, source: str) -> None:
    """Raise InputError naming the first non-physical force element of ``model``: on a joint
    kind it cannot act on, or failing its type's own rules (``ForceType.check``)."""
    kinds = {b.name: b.joint for b in model.bodies}
    for ft, element in elements(model):
        if ft.joints is not None and kinds.get(element.body) not in ft.joints:
            raise InputError(f"{source}: {ft.label} on {element.body!r}: {ft.label}s act on "
                             f"{' or '.join(ft.joints)} joints only")
        ft.check(element, model, source)
