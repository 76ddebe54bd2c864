"""Build an Exudyn system from a scene's ``Multibody``, and read back what Exudyn holds.

Exudyn reads neither MJCF nor URDF: the system is translated from the scene's description.
Every body is an Exudyn rigid body (``CreateRigidBody``) whose node (reference point) is the
body frame origin of ``harness.model.joints`` (the joint point; a free body's centre of mass),
with the body's mass, its centre of mass ``p_BCm_B`` relative to the node and its inertia
about the centre of mass, both in the body frame. Its reference configuration is the scene's
initial state (``harness.model.kinematics.forward`` of ``q0``, ``v0``): node position
``p_WB_W`` (m), rotation ``R_WB``, node velocity (m/s, world) and angular velocity (rad/s,
world).

Joints are Exudyn joint objects between the parent (or the ground) and the child, placed at
the child's joint point in that reference configuration, as the joint table says
(``JointType.exudyn`` in ``harness.model.joints``): hinge -> ``CreateRevoluteJoint``
(``JointRevoluteZ``: free rotation about the joint frame's z), slide -> ``CreatePrismaticJoint``
(``JointPrismaticX``: free translation along its x), ball -> ``CreateSphericalJoint``; a free
body has none. A ``JointSpring`` on a slide is a
``CreateLinearSpringDamper`` along the same axis with zero force at ``q = q_ref``; a
``PointForce`` is a ``CreateForce`` with a load user function ``f_W(t)`` at the point.

A ``RollingContact`` is Exudyn's own ideal rolling-disc joint (``CreateRollingDisc``,
``ObjectJointRollingDisc``): a thin disc of radius R that rolls without slip on the plane z = 0.
The scene's body is a cylinder of half-thickness h that touches the plane with one rim edge,
the circle of radius R at body z = -h sgn(n_z) (``harness.model.rolling_contact``). That edge is
itself a thin disc, centred at body (0, 0, -h sgn(n_z)): the rolling-disc joint is attached
there, with the sign of the initial state. The model is exact as long as the same edge stays
down (sgn(n_z) constant); a run in which the axis crosses the horizontal is reported failed.

Outputs are Exudyn sensors stored in memory at every save interval: per body, the position
and velocity of its centre of mass, its rotation matrix and its world angular velocity; per
joint the constraint force and moment that Exudyn reports (``reaction_series`` in
``harness.engines.exudyn.engine``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from harness.model import rotations
from harness.model.forces import JOINT_SPRINGS, POINT_FORCES, elements
from harness.model.joints import JOINTS, TRANSLATIONAL
from harness.model.kinematics import forward
from harness.model.multibody import Multibody

@dataclass
class ExudynSystem:
    """An assembled Exudyn system and the handles the engine reads.

    Attributes:
        SC, mbs: Exudyn's system container and main system (keep ``SC`` alive with ``mbs``).
        bodies: body name -> Exudyn object index of its rigid body.
        body_sensors: body name -> sensors (centre-of-mass position, rotation matrix,
            centre-of-mass velocity, world angular velocity).
        joints: body name -> (joint object index, joint kind, parent body name or None).
        joint_sensors: body name -> (force sensor, moment sensor or None), only when asked.
        contacts: contact name -> (rolling-disc joint object index, body name, edge sign s =
            sgn(n_z) at t = 0: the joint sits at body z = -h s).
        contact_sensors: contact name -> (``ForceLocal``, ``RotationMatrix``) sensors of the joint.
    """

    SC: object
    mbs: object
    node_type: str
    bodies: dict = field(default_factory=dict)
    body_sensors: dict = field(default_factory=dict)
    joints: dict = field(default_factory=dict)
    joint_sensors: dict = field(default_factory=dict)
    contacts: dict = field(default_factory=dict)
    contact_sensors: dict = field(default_factory=dict)


def initial_frames(model: Multibody) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """Per body, its frame at the initial state: origin ``p_WB_W`` (m), ``R_WB``, origin
    velocity ``v_WB_W`` (m/s) and angular velocity ``w_WB_W`` (rad/s), all world."""
    out = {}
    for body in model.bodies:
        s = forward(model, model.q0, model.v0)[body.name]
        R = rotations.matrix(s.quat_WB)
        r_W = R @ body.p_BCm_B
        out[body.name] = (s.p_WCm_W - r_W, R, s.v_WCm_W - np.cross(s.w_WB_W, r_W), s.w_WB_W)
    return out


def build(model: Multibody, node_type: str, *, reactions: bool = False) -> ExudynSystem:
    """The assembled Exudyn system of ``model`` with nodes of ``node_type`` (an
    ``exudyn.NodeType`` member name), sensors stored in memory (their period is set by the
    solver settings), and joint-force sensors when ``reactions``."""
    import exudyn as exu
    from exudyn.itemInterface import SensorBody, SensorObject
    from exudyn.rigidBodyUtilities import RigidBodyInertia

    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    system = ExudynSystem(SC, mbs, node_type)
    ground = mbs.CreateGround()
    frames = initial_frames(model)
    ovt = exu.OutputVariableType
    for body in model.bodies:
        p_WB, R_WB, v_WB, w_W = frames[body.name]
        inertia = RigidBodyInertia(body.mass, np.asarray(body.I_Cm_B, float), np.asarray(body.p_BCm_B, float),
                                   inertiaTensorAtCOM=True)
        obj = mbs.CreateRigidBody(inertia=inertia, referencePosition=p_WB, referenceRotationMatrix=R_WB,
                                  initialVelocity=v_WB, initialAngularVelocity=w_W, gravity=model.gravity_W,
                                  nodeType=getattr(exu.NodeType, node_type), show=False)
        system.bodies[body.name] = obj
        system.body_sensors[body.name] = tuple(
            mbs.AddSensor(SensorBody(bodyNumber=obj, localPosition=list(map(float, body.p_BCm_B)), outputVariableType=t,
                                     storeInternal=True, writeToFile=False))
            for t in (ovt.Position, ovt.RotationMatrix, ovt.Velocity, ovt.AngularVelocity))
        jt = JOINTS[body.joint]
        if not jt.constrained:  # a free body: no joint object
            continue
        if jt.exudyn is None:
            raise NotImplementedError(f"no Exudyn joint for a {body.joint} joint")
        parent = ground if body.parent is None else system.bodies[body.parent]
        create = getattr(mbs, jt.exudyn.create)
        if jt.axis:
            joint = create(itemNumbers=[parent, obj], position=p_WB, axis=R_WB @ body.axis_B, useGlobalFrame=True, show=False)
        else:
            joint = create(itemNumbers=[parent, obj], position=p_WB, useGlobalFrame=True, show=False)
        system.joints[body.name] = (joint, body.joint, body.parent)
        if reactions:
            outputs = (jt.exudyn.force_output, "TorqueLocal") if jt.exudyn.rotation_conditions else (jt.exudyn.force_output,)
            sensors = [mbs.AddSensor(SensorObject(objectNumber=joint, outputVariableType=getattr(ovt, t), storeInternal=True,
                                                  writeToFile=False)) for t in outputs]
            system.joint_sensors[body.name] = (sensors[0], sensors[1] if len(sensors) > 1 else None)
    for ft, _ in elements(model):
        if ft not in (JOINT_SPRINGS, POINT_FORCES):
            raise NotImplementedError(f"Exudyn does not model {ft.label}s ({ft.name})")
    for spring in JOINT_SPRINGS.elements(model):
        body = model.body(spring.body)
        if JOINTS[body.joint].axis != TRANSLATIONAL:
            raise NotImplementedError(f"no Exudyn spring for a {body.joint} joint")
        p_WB, R_WB = frames[body.name][:2]
        parent = ground if body.parent is None else system.bodies[body.parent]
        # displacement along the axis from the reference configuration (q = q0): q - q0
        q0 = float(np.asarray(model.q0[body.name]).ravel()[0])
        mbs.CreateLinearSpringDamper(itemNumbers=[parent, system.bodies[body.name]], position=p_WB, axis=R_WB @ body.axis_B,
                                     stiffness=spring.stiffness, damping=0.0, offset=spring.q_ref - q0,
                                     useGlobalFrame=True, show=False)
    for force in POINT_FORCES.elements(model):
        f_W = force.force_W
        mbs.CreateForce(itemNumber=system.bodies[force.body], loadVector=list(map(float, f_W(0.0))),
                        localPosition=list(map(float, force.p_BQ_B)), bodyFixed=False,
                        loadVectorUserFunction=lambda mbs_, t, load, f_W=f_W: list(map(float, f_W(t))), show=False)
    for contact in model.contacts:
        body = model.body(contact.body)
        if JOINTS[body.joint].constrained or body.parent is not None:
            raise NotImplementedError(f"rolling contact {contact.name!r}: the rolling body must be free (no joint)")
        n_z = frames[body.name][1][2, 2]
        edge = float(np.sign(n_z))
        joint = mbs.CreateRollingDisc(bodyNumbers=[ground, system.bodies[body.name]],
                                      axisPosition=[0.0, 0.0, -contact.half_thickness * edge], axisVector=[0.0, 0.0, 1.0],
                                      discRadius=contact.radius, planePosition=[0.0, 0.0, 0.0], planeNormal=[0.0, 0.0, 1.0],
                                      show=False)
        system.contacts[contact.name] = (joint, body.name, edge)
        system.contact_sensors[contact.name] = tuple(
            mbs.AddSensor(SensorObject(objectNumber=joint, outputVariableType=t, storeInternal=True, writeToFile=False))
            for t in (ovt.ForceLocal, ovt.RotationMatrix))
    mbs.Assemble()
    return system
