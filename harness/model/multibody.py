"""The physics of a scene as data: bodies, joints, mass properties, gravity, forcing, initial state.

This is the one description of the truth from which the in-house model is built and against
which the MJCF and URDF models are edited and checked. Everything is in SI units.

Frames and conventions
----------------------
* World frame W: z up; gravity is ``gravity_W`` (m/s^2).
* Each body B has a body frame whose origin is its joint (for a free body: any point, here the
  centre of mass). ``p_PB_P`` is the position of B's frame origin in its parent's frame P at zero
  joint configuration, and the body frame is parallel to the parent frame there.
* ``p_BCm_B`` is the centre of mass in the body frame; ``I_Cm_B`` the 3x3 inertia tensor about
  the centre of mass, expressed in the body frame (kg m^2).
* Quaternions are unit quaternions in ``wxyz`` order (scalar first), rotating body to parent.

Joint coordinates (shared by all engines: the MJCF and URDF use the same tree)
------------------------------------------------------------------------------
* ``hinge``: q = [angle] (rad, right-handed about ``axis_B``), v = [rate] (rad/s).
* ``ball``: q = quat_wxyz of B relative to P (4), v = angular velocity of B relative to P,
  expressed in B (rad/s, 3).
* ``free`` (parent must be world): q = [p_WB_W (3), quat_wxyz (4)], v = [v_WB_W (3): velocity of
  the body frame origin in world, w_WB_B (3): angular velocity expressed in the body frame].
* ``slide`` (prismatic): q = [displacement] (m) along ``axis_B`` (unit, body frame = parent frame:
  the frames stay parallel), v = [rate] (m/s); B's frame origin is at ``p_PB_P + q axis_B`` in
  the parent frame.

Force elements
--------------
* ``JointSpring``: a linear spring on a slide joint's coordinate, generalised force
  ``-stiffness (q - q_ref)``, potential ``stiffness (q - q_ref)^2 / 2`` (MuJoCo: joint
  ``stiffness`` with ``springref``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

JOINT_TYPES = ("free", "ball", "hinge", "slide")
NQ = {"free": 7, "ball": 4, "hinge": 1, "slide": 1}
NV = {"free": 6, "ball": 3, "hinge": 1, "slide": 1}


@dataclass(frozen=True)
class Body:
    """One rigid body and the joint that connects it to its parent.

    Attributes:
        name: body name, the same in the MJCF, the URDF (link name) and the trajectory columns.
        parent: parent body name, or ``None`` for the world.
        joint: one of ``JOINT_TYPES``.
        p_PB_P: joint/body-frame origin in the parent frame at zero configuration (m).
        axis_B: hinge or slide axis, unit vector in the body frame (ignored for ``ball`` and
            ``free``).
        mass: kg.
        p_BCm_B: centre of mass in the body frame (m).
        I_Cm_B: inertia about the centre of mass, body frame (kg m^2), 3x3 symmetric.
    """

    name: str
    parent: str | None
    joint: str
    p_PB_P: np.ndarray
    axis_B: np.ndarray
    mass: float
    p_BCm_B: np.ndarray
    I_Cm_B: np.ndarray


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
class RollingContact:
    """Rolling without slip of a body's rim edge on the horizontal plane z = 0 (the plane is the
    world's, normal +z). The body is a cylinder of radius ``radius`` whose symmetry axis is body
    z through its centre of mass; its two edge circles lie at body z = +-``half_thickness``.
    The contact point is the lowest point of the lower edge circle (``harness.measure.contact_metrics``);
    rolling without slip makes the material point there have zero velocity (two nonholonomic
    rows and the holonomic height row z = 0).

    Attributes:
        body: name of the rolling body (a ``free`` body, frame at its centre of mass).
        radius: m, > 0.
        half_thickness: m, >= 0 (0: a thin disk).
        name: name of the contact in trajectories (its force columns ``<name>.Fx`` ...).
        geom: name of the cylinder geom in the MJCF (its size is rewritten from the scene).
    """

    body: str
    radius: float
    half_thickness: float
    name: str = "contact"
    geom: str = "rim"


@dataclass(frozen=True)
class Multibody:
    """A scene's mechanical system: bodies in tree order, gravity, forcing and initial state.

    Attributes:
        bodies: bodies in topological order (a parent comes before its children).
        gravity_W: gravitational acceleration in world frame (m/s^2).
        q0, v0: initial joint coordinates per body name (see module docstring for conventions).
        forces: prescribed point forces (empty when the scene is unforced).
        springs: joint springs (empty when the scene has none).
        contacts: rolling contacts with the plane z = 0 (empty when the scene has none).
    """

    bodies: tuple[Body, ...]
    gravity_W: np.ndarray
    q0: dict[str, np.ndarray]
    v0: dict[str, np.ndarray]
    forces: tuple[PointForce, ...] = field(default_factory=tuple)
    springs: tuple[JointSpring, ...] = field(default_factory=tuple)
    contacts: tuple[RollingContact, ...] = field(default_factory=tuple)

    def body(self, name: str) -> Body:
        for b in self.bodies:
            if b.name == name:
                return b
        raise KeyError(name)

    @property
    def body_names(self) -> list[str]:
        return [b.name for b in self.bodies]

    @property
    def total_mass(self) -> float:
        return float(sum(b.mass for b in self.bodies))
