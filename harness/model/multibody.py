"""The physics of a scene as data: bodies, joints, mass properties, gravity, forcing, initial state.

This is the one description of the truth from which the in-house model is built and against
which the MJCF and URDF models are edited and checked. Everything is in SI units.

Frames, units and joint coordinates are those of ``harness.model.joints`` (the joint table:
one ``JointType`` per kind in ``JOINTS``). Force elements (``PointForce``, ``JointSpring``,
``JointTorque``, ``PointSpring``) and their table ``FORCES`` are in ``harness.model.forces``; they
are importable from here too.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from harness.model.forces import JointSpring, JointTorque, PointForce, PointSpring

__all__ = ["Body", "JointSpring", "JointTorque", "LoopJoint", "Multibody", "PointForce", "PointSpring", "RollingContact"]


@dataclass(frozen=True)
class Body:
    """One rigid body and the joint that connects it to its parent.

    Attributes:
        name: body name, the same in the MJCF, the URDF (link name) and the trajectory columns.
        parent: parent body name, or ``None`` for the world.
        joint: a joint kind, a key of ``harness.model.joints.JOINTS``.
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
class RollingContact:
    """Rolling without slip of a body's rim edge on the horizontal plane z = 0 (the plane is the
    world's, normal +z). The body is a cylinder of radius ``radius`` whose symmetry axis is body
    z through its centre of mass; its two edge circles lie at body z = +-``half_thickness``.
    The contact point is the lowest point of the lower edge circle (``harness.measure.contact_metrics``);
    rolling without slip makes the material point there have zero velocity (two nonholonomic
    rows and the holonomic height row z = 0).

    With ``circle_z`` set, the body rolls on one circle instead: radius ``radius``, centred on
    the symmetry axis at body z = ``circle_z`` (m, measured from the centre of mass along body
    z); the contact point is the lowest point of that circle (``harness.model.rolling_contact``).
    A cylinder lying on its side whose axis stays horizontal touches the plane along a segment
    whose midpoint is the lowest point of its mid circle (``circle_z = 0``); ``half_thickness``
    is then only the cylinder's half-length (the MJCF geom's size).

    Attributes:
        body: name of the rolling body, any body of the tree whose symmetry axis is body z
            through its centre of mass: a root body, free or on a joint to the world (a cone on a
            ball joint at its apex), or a body deeper in the tree (a bicycle's front wheel, on a
            hinge to the front frame, on a hinge to the free rear frame); it may have children.
        radius: m, > 0.
        half_thickness: m, >= 0 (0: a thin disk).
        name: name of the contact in trajectories (its force columns ``<name>.Fx`` ...).
        geom: name of the cylinder geom in the MJCF (its size is rewritten from the scene).
        circle_z: None (the lower of the two rim edges at +-half_thickness touches), or the
            body z (m) of the one rolling circle's centre.
    """

    body: str
    radius: float
    half_thickness: float
    name: str = "contact"
    geom: str = "rim"
    circle_z: float | None = None


@dataclass(frozen=True)
class LoopJoint:
    """A joint that closes a kinematic loop (a *cut joint*): it connects two bodies that the tree
    of ``Body`` joints already connects, so its conditions are extra constraints, not a tree edge.

    A URDF cannot state it; the MJCF states it as ``<equality><connect site1 site2>`` between two
    sites (one ``connect`` for a ball, two for a hinge: at the joint point and at the point one
    ``hinge_span`` along the axis). Its rows may be redundant with the tree's (a planar loop
    closed by a hinge: 3 of its 5 rows are implied by the other hinges); engines must handle that.

    Attributes:
        name: the cut joint's name (its reaction key ``<name>``; its MJCF sites are
            ``<name>_a``, ``<name>_b`` and, for a hinge, ``<name>_a2``, ``<name>_b2``; its
            equalities ``<name>`` and ``<name>_2``).
        kind: a joint kind of ``harness.model.joints.loop_kinds()``: a ball (the two points
            coincide, 3 rows) or a hinge (the points coincide and the axes stay aligned, 5 rows).
        body_a: the body carrying the first end (its reaction is the force on this body).
        body_b: the body carrying the second end, or None for the world.
        p_A: the joint point in body_a's frame (m).
        p_B: the joint point in body_b's frame, or in world for the world (m).
        axis_A, axis_B: the unit hinge axis in body_a's and in body_b's frame (ignored for a
            ball); at the initial state they coincide in world.
        hinge_span: distance (m) between the two MJCF connect points of a hinge, > 0.
    """

    name: str
    kind: str
    body_a: str
    body_b: str | None
    p_A: np.ndarray
    p_B: np.ndarray
    axis_A: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    axis_B: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    hinge_span: float = 0.1


@dataclass(frozen=True)
class Multibody:
    """A scene's mechanical system: bodies in tree order, gravity, forcing and initial state.

    Attributes:
        bodies: bodies in topological order (a parent comes before its children).
        gravity_W: gravitational acceleration in world frame (m/s^2).
        q0, v0: initial joint coordinates per body name (conventions: ``harness.model.joints``).
        forces: prescribed point forces (empty when the scene is unforced).
        springs: joint springs (empty when the scene has none).
        torques: constant joint torques (motors; empty when the scene has none).
        point_springs: springs between body points (empty when the scene has none).
        (Every force-element field is named in ``harness.model.forces.FORCES``.)
        contacts: rolling contacts with the plane z = 0 (empty when the scene has none).
        loops: cut joints closing kinematic loops (empty for a tree). The initial state
            ``q0, v0`` must satisfy them (a builder assembles the loop).
    """

    bodies: tuple[Body, ...]
    gravity_W: np.ndarray
    q0: dict[str, np.ndarray]
    v0: dict[str, np.ndarray]
    forces: tuple[PointForce, ...] = field(default_factory=tuple)
    springs: tuple[JointSpring, ...] = field(default_factory=tuple)
    torques: tuple[JointTorque, ...] = field(default_factory=tuple)
    point_springs: tuple[PointSpring, ...] = field(default_factory=tuple)
    contacts: tuple[RollingContact, ...] = field(default_factory=tuple)
    loops: tuple[LoopJoint, ...] = field(default_factory=tuple)

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
