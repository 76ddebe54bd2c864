"""The scene's URDF in a Drake ``MultibodyPlant``, with the scene's physics applied.

Drake parses the scene's URDF itself (``Parser.AddModels``: its own importer, independent of
MuJoCo's and Pinocchio's) into a continuous-time plant (``MultibodyPlant(0.0)``: reduced
coordinates, Drake's own articulated-body implementation). The scene's description then
overrides what the file says, through Drake's parameters in the context: each body's mass,
centre of mass and inertia (``SetSpatialInertiaInBodyFrame``) and each joint's placement in its
parent (``SetPoseInParentFrame`` of the joint's frame on the parent), as the other engines
apply them; gravity is set on the plant. A joint a URDF cannot state is added before
``Finalize``: the scene's ``urdf_root_joint`` ``spherical`` becomes a ``BallRpyJoint`` at the
link frame (Drake has no quaternion ball joint: roll-pitch-yaw, singular at pitch +-pi/2); a
body without a joint floats (Drake's ``QuaternionFloatingJoint``). A ``JointSpring`` is a
``PrismaticSpring``; a ``PointSpring`` (with its damper) a ``LinearSpringDamper`` between the
two body points (the world body's for a world end): force ``k (L - L0) + c L'`` along the line,
the same element (Drake requires ``L0 > 0``: a zero rest length is not run).

A scene that names only an MJCF is parsed from the MJCF (Drake's own MJCF parser, same
``AddModels``): its bodies are the MJCF's, its hinge, slide and ball joints Drake's revolute,
prismatic and ``BallRpyJoint``s on a frame fixed to the parent (whose pose the scene sets), a
``<freejoint>`` body floats. What Drake's MJCF parser leaves out (options, flags) the scene
states anyway (gravity here, no contact: the plant has no scene graph).

Frames: the URDF link frame is the harness's body frame (the joint point); Drake's body pose
``X_WB`` and spatial velocity ``V_WB`` (angular velocity, velocity of the body origin, world) are
those of that frame. Units SI.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from harness.model import rotations
from harness.model.errors import InputError
from harness.model.forces import JOINT_SPRINGS, POINT_FORCES, POINT_SPRINGS, elements
from harness.model.joints import FREE, JOINTS, ROTATIONAL, TRANSLATIONAL
from harness.model.multibody import Multibody

@dataclass
class DrakeModel:
    """A finalised plant, its context with the scene's physics, and the handles the engine reads.

    Attributes:
        plant, context: the ``MultibodyPlant`` and its (root) context.
        bodies: scene body name -> Drake ``RigidBody``.
        joints: scene body name -> the Drake ``Joint`` that moves it (None for a floating body).
        diagram, diagram_context: the diagram when prescribed forces feed the plant, else None.
    """

    plant: object
    context: object
    bodies: dict = field(default_factory=dict)
    joints: dict = field(default_factory=dict)
    diagram: object = None
    diagram_context: object = None


def _check_supported(model: Multibody) -> None:
    if model.contacts:
        raise NotImplementedError("Drake has no ideal rolling constraint (its contact is compliant): "
                                  "the rolling disk is not run on Drake")
    for ft, _ in elements(model):
        if ft not in (JOINT_SPRINGS, POINT_FORCES, POINT_SPRINGS):
            raise NotImplementedError(f"the Drake engine does not model {ft.label}s ({ft.name})")
    for spring in POINT_SPRINGS.elements(model):
        if not spring.rest_length > 0.0:
            raise NotImplementedError(f"spring {spring.name!r}: Drake's LinearSpringDamper needs a rest length > 0")


class captured_drake_log:
    """Context manager: the messages Drake logs (Python logger ``drake``: warnings such as "does
    not handle joint limits for continuous models") are appended to ``messages`` instead of
    being printed; the logger's handlers and level are restored on exit."""

    def __enter__(self) -> "captured_drake_log":
        import logging

        self.messages: list[str] = []
        self._logger = logging.getLogger("drake")
        self._saved = (self._logger.handlers[:], self._logger.propagate)
        messages = self.messages

        class _Keep(logging.Handler):
            def emit(self, record):
                messages.append(record.getMessage())

        self._logger.handlers = [_Keep(logging.WARNING)]
        self._logger.propagate = False
        return self

    def __exit__(self, *exc) -> None:
        self._logger.handlers, self._logger.propagate = self._saved


def parse(path, root_joint: str, model: Multibody, *, springs: bool = True):
    """``(plant, instance, joints)``: the URDF (for a scene without one, the MJCF) at ``path``
    parsed by Drake into a continuous plant with the scene's gravity, its root joint and its
    springs, finalised; ``joints`` maps scene body name -> Drake joint (None: floating). InputError if Drake cannot read the file
    or it lacks a scene body."""
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import MultibodyPlant
    from pydrake.multibody.tree import BallRpyJoint, LinearSpringDamper, PrismaticSpring

    plant = MultibodyPlant(0.0)
    try:
        with captured_drake_log():  # a continuous plant ignores the URDF's joint limits: said once below
            (instance,) = Parser(plant).AddModels(str(path))
    except Exception as err:  # noqa: BLE001 - Drake raises RuntimeError with its parser's message
        raise InputError(f"{path}: Drake cannot read it: {' '.join(str(err).split())[:300]}") from None
    names = {plant.get_body(i).name() for i in plant.GetBodyIndices(instance)}
    for body in model.bodies:
        if body.name not in names:
            raise InputError(f"{path}: no link named {body.name!r} (the scene's body) for Drake")
    joints: dict = {}
    by_child = {plant.get_joint(j).child_body().name(): plant.get_joint(j) for j in plant.GetJointIndices(instance)}
    for body in model.bodies:
        jt = JOINTS[body.joint]
        if body.name in by_child:
            joints[body.name] = by_child[body.name]
        elif body.parent is None and jt.urdf_root == root_joint and jt.constrained:
            # the joint a URDF cannot state: a ball at the link frame (Drake: roll-pitch-yaw)
            joints[body.name] = plant.AddJoint(BallRpyJoint(f"{body.name}_{root_joint}", plant.world_frame(),
                                                            plant.GetFrameByName(body.name, instance), 0.0))
        elif not jt.constrained:
            joints[body.name] = None  # Drake floats a body without a joint
        else:
            raise InputError(f"{path}: Drake finds no joint for {body.name!r} ({body.joint} in the scene)")
    if springs:
        for spring in JOINT_SPRINGS.elements(model):
            joint = joints[spring.body]
            if joint is None or joint.type_name() != "prismatic":
                raise NotImplementedError(f"the Drake engine has no spring for the joint of {spring.body!r}")
            plant.AddForceElement(PrismaticSpring(joint, float(spring.q_ref), float(spring.stiffness)))
        for spring in POINT_SPRINGS.elements(model):
            if not spring.rest_length > 0.0:
                continue  # refused by _check_supported before a run
            ends = [plant.world_body() if b is None else plant.GetBodyByName(b, instance)
                    for b in (spring.body_a, spring.body_b)]
            plant.AddForceElement(LinearSpringDamper(ends[0], np.asarray(spring.p_A, float), ends[1],
                                                     np.asarray(spring.p_B, float), float(spring.rest_length),
                                                     float(spring.stiffness), float(spring.damping)))
    plant.mutable_gravity_field().set_gravity_vector(np.asarray(model.gravity_W, dtype=float))
    with captured_drake_log():  # the run's own capture (engine) records it; a bare parse keeps quiet
        plant.Finalize()
    return plant, instance, joints


def build(scene, model: Multibody) -> DrakeModel:
    """The scene's URDF in Drake with ``model``'s physics applied and its initial state set
    (NotImplementedError for what the Drake engine does not model: a rolling contact)."""
    from pydrake.math import RigidTransform
    from pydrake.multibody.tree import RotationalInertia, SpatialInertia

    _check_supported(model)
    plant, instance, joints = parse(scene.urdf, scene.urdf_root_joint, model)
    dm = DrakeModel(plant, None, joints=joints)
    dm.bodies = {b.name: plant.GetBodyByName(b.name, instance) for b in model.bodies}
    if POINT_FORCES.elements(model):
        dm.diagram, dm.diagram_context = _with_point_forces(plant, dm.bodies, model)
        dm.context = plant.GetMyMutableContextFromRoot(dm.diagram_context)
    else:
        dm.context = plant.CreateDefaultContext()
    ctx = dm.context
    for body in model.bodies:
        I = np.asarray(body.I_Cm_B, dtype=float)
        inertia = RotationalInertia(I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2])
        dm.bodies[body.name].SetSpatialInertiaInBodyFrame(
            ctx, SpatialInertia.MakeFromCentralInertia(float(body.mass), np.asarray(body.p_BCm_B, float), inertia))
        joint = joints[body.name]
        if joint is None:
            continue
        frame = joint.frame_on_parent()
        want = np.asarray(body.p_PB_P, dtype=float)
        if hasattr(frame, "SetPoseInParentFrame") and frame.body().index() == joint.parent_body().index():
            frame.SetPoseInParentFrame(ctx, RigidTransform(want))
        elif np.linalg.norm(want) > 0.0:
            raise NotImplementedError(f"Drake's joint of {body.name!r} sits on its parent's body frame: "
                                      f"its placement {want.tolist()} m cannot be set")
    set_initial_state(dm, model)
    return dm


def set_initial_state(dm: DrakeModel, model: Multibody) -> None:
    """The scene's joint-coordinate initial state into Drake's coordinates: a revolute or
    prismatic joint's single coordinate as is (the URDF axis is the scene's axis); a ball's
    quaternion as roll-pitch-yaw and its angular velocity (relative, in the child) rotated into
    the parent frame; a floating body's pose and spatial velocity in world."""
    from pydrake.common.eigen_geometry import Quaternion
    from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix
    from pydrake.multibody.math import SpatialVelocity

    plant, ctx = dm.plant, dm.context
    for body in model.bodies:
        q0 = np.asarray(model.q0[body.name], dtype=float)
        v0 = np.asarray(model.v0[body.name], dtype=float)
        joint = dm.joints[body.name]
        kind = JOINTS[body.joint]
        if joint is None:  # floating: q = [p_WB_W, quat_WB], v = [v_WB_W, w_WB_B]
            quat = q0[3:7] / np.linalg.norm(q0[3:7])
            R = rotations.matrix(quat)
            plant.SetFreeBodyPose(ctx, dm.bodies[body.name], RigidTransform(Quaternion(quat), q0[:3]))
            plant.SetFreeBodySpatialVelocity(ctx, dm.bodies[body.name], SpatialVelocity(R @ v0[3:6], v0[:3]))
        elif kind.axis == ROTATIONAL:
            joint.set_angle(ctx, float(q0[0]))
            joint.set_angular_rate(ctx, float(v0[0]))
        elif kind.axis == TRANSLATIONAL:
            joint.set_translation(ctx, float(q0[0]))
            joint.set_translation_rate(ctx, float(v0[0]))
        elif kind.quat_at is not None:  # ball: quaternion of B in P, angular velocity relative, in B
            R_PB = rotations.matrix(q0 / np.linalg.norm(q0))
            joint.set_angles(ctx, RollPitchYaw(RotationMatrix(R_PB)).vector())
            joint.set_angular_velocity(ctx, R_PB @ v0)
        else:
            raise NotImplementedError(f"no Drake coordinates for a {body.joint} joint")


def _with_point_forces(plant, bodies, model):
    """A diagram feeding the plant's applied-spatial-force port with the scene's prescribed
    point forces ``f_W(t)`` at their body points; returns ``(diagram, diagram context)``."""
    from pydrake.common.value import AbstractValue
    from pydrake.multibody.math import SpatialForce
    from pydrake.multibody.plant import ExternallyAppliedSpatialForce
    from pydrake.systems.framework import DiagramBuilder, LeafSystem

    forces = POINT_FORCES.elements(model)

    class PointForces(LeafSystem):
        def __init__(self):
            super().__init__()
            self.DeclareAbstractOutputPort("forces", lambda: AbstractValue.Make([ExternallyAppliedSpatialForce()]),
                                           self._calc)

        def _calc(self, context, output):
            t = context.get_time()
            out = []
            for f in forces:
                applied = ExternallyAppliedSpatialForce()
                applied.body_index = bodies[f.body].index()
                applied.p_BoBq_B = np.asarray(f.p_BQ_B, dtype=float)
                applied.F_Bq_W = SpatialForce(np.zeros(3), np.asarray(f.force_W(t), dtype=float))
                out.append(applied)
            output.set_value(out)

    builder = DiagramBuilder()
    builder.AddSystem(plant)
    source = builder.AddSystem(PointForces())
    builder.Connect(source.get_output_port(0), plant.get_applied_spatial_force_input_port())
    diagram = builder.Build()
    return diagram, diagram.CreateDefaultContext()


def drake_bodies(plant, joints: dict, model: Multibody) -> list:
    """Read back the scene's bodies as Drake holds them by default (the file's values, before
    the scene's physics is applied in a context): mass (kg), centre of mass and inertia about it
    in the body frame (m, kg m^2), the joint frame's position in the parent body (m), the joint
    kind and its unit axis in the child's frame (``LoadedBody`` of
    ``harness.engines.loaded_models``; a floating body: kind free, no axis)."""
    from harness.engines.loaded_models import LoadedBody, drake_joint_kind

    out = []
    for body in model.bodies:
        b = plant.GetBodyByName(body.name)
        m = float(b.default_mass())
        c = np.asarray(b.default_com(), dtype=float)
        I_com = np.asarray(b.default_rotational_inertia().CopyToFullMatrix3(), dtype=float)  # about Bo
        I_C = I_com - m * (float(c @ c) * np.eye(3) - np.outer(c, c))  # shifted to the centre of mass
        joint = joints.get(body.name)
        if joint is None:
            out.append(LoadedBody(body.name, m, c, I_C, np.zeros(3), FREE.name, np.zeros(3)))
            continue
        X_PF = joint.frame_on_parent().GetFixedPoseInBodyFrame()
        R_CM = joint.frame_on_child().GetFixedPoseInBodyFrame().rotation().matrix()
        axis = np.zeros(3)
        if joint.num_velocities() == 1:
            a = joint.revolute_axis() if joint.type_name() == "revolute" else joint.translation_axis()
            axis = R_CM @ np.asarray(a, dtype=float)
        out.append(LoadedBody(body.name, m, c, I_C, np.asarray(X_PF.translation(), dtype=float),
                              drake_joint_kind(joint), axis))
    return out

