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
``PointForce`` is a ``CreateForce`` with a load user function ``f_W(t)`` at the point; a
``JointTorque`` is a body-fixed ``CreateTorque`` about the hinge axis on the child (and its
opposite on the parent); a ``PointSpring`` is a ``CreateSpringDamper`` between the two points
(the ground's point in world) with its stiffness, reference length and damping (Exudyn's
``ObjectConnectorSpringDamper``: force ``k (L - L0) + d L'`` along the line, the same damper).

A ``RollingContact`` is Exudyn's own ideal rolling-disc joint (``CreateRollingDisc``,
``ObjectJointRollingDisc``): a thin disc of radius R that rolls without slip on the plane z = 0.
The scene's body is a cylinder of half-thickness h that touches the plane with one rim edge,
the circle of radius R at body z = -h sgn(n_z) (``harness.model.rolling_contact``). That edge is
itself a thin disc, centred at body (0, 0, -h sgn(n_z)): the rolling-disc joint is attached
there, with the sign of the initial state. The model is exact as long as the same edge stays
down (sgn(n_z) constant); a run in which the axis crosses the horizontal is reported failed.
A contact with one rolling circle (``RollingContact.circle_z``) has the joint at that circle's
centre, body (0, 0, circle_z) from the centre of mass, and no edge to switch. The rolling body is
any body (every body is a node of its own in redundant coordinates: a bicycle's front wheel is
one); on a body the world holds through joints alone (the rolling cone's spherical apex) the rows
include one the rolling-disc joint repeats (``ExudynSystem.dependent_rows``).

Loop (cut) joints (``Multibody.loops``, ``harness.model.multibody.LoopJoint``): each is one more
joint object, an ``ObjectJointGeneric`` between two rigid markers (``MarkerBodyRigid``), one on
body_a at ``p_A`` and one on body_b at ``p_B`` (m, each in its body frame: a node is its body-frame
origin, so these are the markers' local positions as written), or on the ground object at ``p_B``
in world when body_b is None. Each marker carries the joint frame in its ``localHT``: on body_a,
J_A, the right-handed orthonormal frame whose z is ``axis_A`` (``loop_frame``; a ball ignores the
axes); on body_b, J_B, the frame that coincides with J_A in world at the initial state (for a
hinge re-orthonormalised so that its z is ``axis_B`` exactly). The joint's candidate rows (``candidate_rows``) are ``constrainedAxes`` 0-4 of
the generic joint, in J_A:

* ball: translations along x, y, z (the two points coincide);
* hinge: the same and the rotations about x and y: with both, Exudyn states z_A . x_B = 0 and
  z_A . y_B = 0 (as ``JointRevoluteZ`` does): the z axes stay aligned, the rotation about them is
  free. With one only (``rotation_conditions``): y_A . z_B = 0 (about x) or x_A . z_B = 0 (about y).

Exudyn's translation rows are p_B - p_A in world when all three are stated, else the stated
components of J_A^T (p_B - p_A). The explicit methods take no loop joint (status unsupported).

Redundant rows (``candidate_rows``). A planar loop closed by a hinge has 3 of its 5 rows implied by the
tree's parallel hinges (the out-of-plane translation and the rotations about the in-plane axes);
stated, they make the iteration matrix singular and Exudyn stops at the first step ("System
Jacobian seems to be singular"). Which rows to state is decided from the tree's kinematics: the
loop-closure Jacobian G (``closure_jacobian``: per candidate row, the relative velocity or
angular velocity of body_b's end with respect to body_a's in J_A, per tree velocity coordinate;
translation rows divided by the model's length) at the initial state; rows are taken in order
(loops in order; tx, ty, tz, rx, ry) when they raise its numerical rank (``RANK_RTOL``). A row
left out is dependent on the kept ones at the initial state; it is left out only when that
holds *structurally*: at ``STRUCTURAL_SAMPLES`` seeded random configurations of the tree
(``JointType.draw``) G has the rank of its kept rows, their number. A dependency at generic
configurations holds at every configuration (rank can only drop on a closed set), so the kept
rows imply the dropped ones along any motion, wherever they keep full rank themselves. A
dependency of the initial state only (a singular position; a linkage whose mobility needs its
special geometry) keeps every row and sets ``LoopRows.singular``: the engine then solves with
Eigen's full-pivot LU (``LinearSolverType.EigenDense`` with ``ignoreSingularJacobian``), which
resolves dependent rows (measured: two collinear bars on ball joints, their tips joined by a
ball loop, spinning without gravity, run with it and stop at the first step without it).

Why leave rows out rather than state them all under the full-pivot LU, measured on four_bar and
slider_crank (both: tx, ty stated; tz, rx, ry left out). GeneralizedAlpha, 5 s, steps 1e-3,
5e-4, 2.5e-4 s: the two give the same motion (trajectory differences against the in-house rk4
equal to 2 digits; four_bar energy drift 1.63e-4, 4.06e-5, 1.02e-5 both) and close the loop to
round-off (gap < 1e-13 m). Leaving rows out keeps Exudyn's default dense solver (``EXUdense``,
which with ``ignoreSingularJacobian`` still stops at the first step with every row stated, in
this Exudyn build) and its report of a singular Jacobian, and makes the loop's multipliers unique
(the tree carries the redundant directions; with full pivoting their split follows the pivots).
The cost is with TrapezoidalIndex2: with one translation row left out Exudyn states the others in
J_A (local), at velocity level d/dt of J_A^T (p_B - p_A), so the relative velocity of the two
points is off by about w x (p_B - p_A), where the index-2 position drift opens the gap (four_bar,
5 s at 1e-3 s: velocity closure 1.0e-4 m/s against 6.5e-6 m/s with all rows; gap 1.5e-5 m
against 1.2e-5 m; both O(h^2)).

Outputs are Exudyn sensors stored in memory at every save interval: per body, the position
and velocity of its centre of mass, its rotation matrix and its world angular velocity; per
joint (tree and loop) the constraint force and moment that Exudyn reports (``reaction_series``
in ``harness.engines.exudyn.engine``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from harness.model import loop_closure, rotations
from harness.model.forces import JOINT_SPRINGS, JOINT_TORQUES, POINT_FORCES, POINT_SPRINGS, elements
from harness.model.joints import ALIGNED, JOINTS, POINT, TRANSLATIONAL, keeps_axis
from harness.model.kinematics import forward
from harness.model.multibody import LoopJoint, Multibody
from harness.model.rolling_contact import dependent_rows

#: The rows a loop joint may state, per kind, in its joint frame J (z: the hinge axis):
#: translations along J's x, y, z and rotations about its x, y (``ObjectJointGeneric``'s
#: ``constrainedAxes`` 0-4).
ROWS_OF_CONDITION = {POINT: ("tx", "ty", "tz"), ALIGNED: ("rx", "ry")}


def candidate_rows(kind: str) -> tuple[str, ...]:
    """The candidate rows (``ROWS_OF_CONDITION`` names) of a loop joint of ``kind``, from its conditions."""
    return tuple(r for c in JOINTS[kind].conditions for r in ROWS_OF_CONDITION[c])


#: Numerical rank of the loop-closure Jacobian: singular values below this times the largest
#: count as zero (redundant rows are dependent to round-off, ~1e-16; independent ones are O(1)
#: once translation rows are divided by the model's length).
RANK_RTOL = 1e-9

#: Seeded random configurations of the tree at which a dependency at the initial state must also
#: hold for its rows to be dropped (``candidate_rows``), and the seed.
STRUCTURAL_SAMPLES = 3
STRUCTURAL_SEED = 20240607


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
        loops: loop name -> (``ObjectJointGeneric`` object index, the rows it states (``candidate_rows``
            names), body_a, body_b or None).
        loop_sensors: loop name -> (``ForceLocal`` sensor, ``TorqueLocal`` sensor), only when asked.
        loop_rows: the rows decision (``LoopRows``), None without loops.
        dependent_rows: a rolling body the world holds through joints alone (a cone held at its
            apex; ``harness.model.rolling_contact.dependent_rows``): the rolling-disc
            joint's no-slip row along the line from the joint to the contact repeats the joint's
            (two points of a rigid body have equal velocities along the line joining them), at
            every instant and in a direction that turns with the body, so no row can be left out
            once: the engine solves with Eigen's full-pivot LU (``ignoreSingularJacobian``) and the
            split of the force along that line between joint and contact follows the pivots.
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
    loops: dict = field(default_factory=dict)
    loop_sensors: dict = field(default_factory=dict)
    loop_rows: LoopRows | None = None
    dependent_rows: bool = False


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
        if ft not in (JOINT_SPRINGS, POINT_FORCES, JOINT_TORQUES, POINT_SPRINGS):
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
    for torque in JOINT_TORQUES.elements(model):  # about the hinge axis, the same vector in both bodies' frames
        body = model.body(torque.body)
        m_B = torque.torque * np.asarray(body.axis_B, float) / np.linalg.norm(body.axis_B)
        mbs.CreateTorque(itemNumber=system.bodies[body.name], loadVector=list(map(float, m_B)), bodyFixed=True, show=False)
        if body.parent is not None:
            mbs.CreateTorque(itemNumber=system.bodies[body.parent], loadVector=list(map(float, -m_B)), bodyFixed=True,
                             show=False)
    for spring in POINT_SPRINGS.elements(model):
        ends = [ground if b is None else system.bodies[b] for b in (spring.body_a, spring.body_b)]
        mbs.CreateSpringDamper(itemNumbers=ends, localPosition0=list(map(float, spring.p_A)),
                               localPosition1=list(map(float, spring.p_B)), referenceLength=float(spring.rest_length),
                               stiffness=float(spring.stiffness), damping=float(spring.damping), show=False)
    for contact in model.contacts:
        body = model.body(contact.body)
        if contact.circle_z is None:  # the lower rim edge at the initial state
            n_z = frames[body.name][1][2, 2]
            edge = float(np.sign(n_z))
            centre = np.array([0.0, 0.0, -contact.half_thickness * edge])
        else:  # one rolling circle: no edge to switch (edge 0: ``_edge_flip`` skips it)
            edge = 0.0
            centre = np.array([0.0, 0.0, float(contact.circle_z)])
        centre = centre + np.asarray(body.p_BCm_B, float)  # from the node (body frame origin)
        joint = mbs.CreateRollingDisc(bodyNumbers=[ground, system.bodies[body.name]],
                                      axisPosition=list(map(float, centre)), axisVector=[0.0, 0.0, 1.0],
                                      discRadius=contact.radius, planePosition=[0.0, 0.0, 0.0], planeNormal=[0.0, 0.0, 1.0],
                                      show=False)
        system.contacts[contact.name] = (joint, body.name, edge)
        system.contact_sensors[contact.name] = tuple(
            mbs.AddSensor(SensorObject(objectNumber=joint, outputVariableType=t, storeInternal=True, writeToFile=False))
            for t in (ovt.ForceLocal, ovt.RotationMatrix))
    system.dependent_rows = dependent_rows(model)
    if model.loops:
        system.loop_rows = loop_rows(model)
        for loop in model.loops:
            _add_loop(mbs, system, ground, loop, frames, system.loop_rows.rows[loop.name], reactions=reactions)
    mbs.Assemble()
    return system


def loop_frame(axis) -> np.ndarray:
    """A right-handed orthonormal frame (columns x, y, z) whose z is the unit ``axis``: x is
    the cross product of the coordinate axis least aligned with it and it, normalised."""
    z = np.asarray(axis, float) / np.linalg.norm(axis)
    x = np.cross(np.eye(3)[int(np.argmin(np.abs(z)))], z)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


@dataclass(frozen=True)
class LoopRows:
    """Which rows of each loop joint Exudyn states (module docstring: redundant rows).

    Attributes:
        rows: loop name -> the rows stated (``candidate_rows`` names, in their order).
        dropped: loop name -> the rows left out as structurally redundant.
        singular: a dependency at the initial state that is not structural: every row is kept
            and the engine solves with the full-pivot LU.
    """

    rows: dict
    dropped: dict
    singular: bool

    def describe(self) -> str:
        """One phrase for run records, e.g. "cut: tx ty (tz rx ry redundant)"."""
        parts = []
        for name, rows in self.rows.items():
            text = f"{name}: {' '.join(rows) or 'no rows'}"
            if self.dropped[name]:
                text += f" ({' '.join(self.dropped[name])} redundant)"
            parts.append(text)
        text = "; ".join(parts)
        if self.singular:
            text += "; dependent rows at the initial state only: all kept, full-pivot LU"
        return text


def _length_scale(model: Multibody) -> float:
    """The model's length (m): the largest joint offset, centre-of-mass offset or loop point."""
    vecs = [b.p_PB_P for b in model.bodies] + [b.p_BCm_B for b in model.bodies]
    vecs += [lp.p_A for lp in model.loops] + [lp.p_B for lp in model.loops]
    size = max(float(np.linalg.norm(v)) for v in vecs)
    return size if size > 0.0 else 1.0


def closure_jacobian(model: Multibody, q: dict) -> np.ndarray:
    """The loop-closure Jacobian at tree configuration ``q`` (need not close the loops): per loop
    and ``candidate_rows`` row, the relative velocity of body_b's end with respect to body_a's
    (translation rows, divided by the model's length scale) or their relative angular velocity
    (rotation rows), in body_a's joint frame J_A (world), per unit tree velocity coordinate
    (columns: bodies in order, each joint's ``nv``; slide and free-body linear coordinates times
    the length scale, so that every column is a rate in rad/s)."""
    scale = _length_scale(model)
    columns = []
    for body in model.bodies:
        jt = JOINTS[body.joint]
        for k in range(jt.nv):
            v = {b.name: np.zeros(JOINTS[b.joint].nv) for b in model.bodies}
            v[body.name][k] = 1.0
            linear = jt.axis == TRANSLATIONAL or (jt.world_linear_velocity and k < 3)
            states = forward(model, q, v)
            columns.append((_closure_rows(model, states, scale)) * (scale if linear else 1.0))
    return np.column_stack(columns) if columns else np.zeros((sum(len(candidate_rows(lp.kind)) for lp in model.loops), 0))


def _closure_rows(model: Multibody, states, scale: float) -> np.ndarray:
    rows = []
    for loop in model.loops:
        ends = []
        for body, p, axis in ((loop.body_a, loop.p_A, loop.axis_A), (loop.body_b, loop.p_B, loop.axis_B)):
            if body is None:
                ends.append(loop_closure.world_end(p, axis, ()))
                continue
            st = states[body]
            R = rotations.matrix(np.asarray(st.quat_WB, float)).reshape(3, 3)
            ends.append(loop_closure.end(st.p_WCm_W, R, st.v_WCm_W, st.w_WB_W, model.body(body).p_BCm_B, p, axis))
        R_a = np.eye(3) if loop.body_a is None else rotations.matrix(np.asarray(states[loop.body_a].quat_WB, float)).reshape(3, 3)
        J = R_a @ loop_frame(loop.axis_A)
        dv = J.T @ (ends[1].v - ends[0].v) / scale
        dw = J.T @ (ends[1].w - ends[0].w)
        rows.extend(dv)
        if keeps_axis(loop.kind):
            rows.extend(dw[:2])
    return np.asarray(rows, float)


def _rank(G: np.ndarray, reference: float) -> int:
    """Numerical rank of ``G``: singular values above ``RANK_RTOL`` times ``reference``."""
    if G.size == 0 or reference <= 0.0:
        return 0
    return int(np.sum(np.linalg.svd(G, compute_uv=False) > RANK_RTOL * reference))


def _norm(G: np.ndarray) -> float:
    return float(np.linalg.norm(G, 2)) if G.size else 0.0


def loop_rows(model: Multibody) -> LoopRows:
    """Which rows of the model's loop joints Exudyn states (module docstring): the rows of
    ``closure_jacobian`` at ``q0`` that raise its rank, taken in order; the others are left out
    when the same rank holds at ``STRUCTURAL_SAMPLES`` seeded random tree configurations, else
    every row is kept and ``singular`` is set."""
    names = [(loop.name, row) for loop in model.loops for row in candidate_rows(loop.kind)]
    G0 = closure_jacobian(model, model.q0)
    reference = _norm(G0)
    kept: list[int] = []
    for i in range(len(names)):
        if _rank(G0[kept + [i]], reference) > len(kept):
            kept.append(i)
    singular = False
    if len(kept) < len(names):
        rng = np.random.default_rng(STRUCTURAL_SEED)
        for _ in range(STRUCTURAL_SAMPLES):
            q = {b.name: JOINTS[b.joint].draw(rng, None)[0] for b in model.bodies}
            G = closure_jacobian(model, q)
            if not _rank(G, _norm(G)) == _rank(G[kept], _norm(G)) == len(kept):
                singular = True
                break
    keep = set(range(len(names))) if singular else set(kept)
    rows = {loop.name: tuple(r for i, (n, r) in enumerate(names) if n == loop.name and i in keep) for loop in model.loops}
    dropped = {loop.name: tuple(r for r in candidate_rows(loop.kind) if r not in rows[loop.name]) for loop in model.loops}
    return LoopRows(rows, dropped, singular)


def loop_axes(rows) -> list[int]:
    """``ObjectJointGeneric.constrainedAxes`` for the stated ``rows`` (the rotation about z is
    always free: a hinge turns about it, a ball states no rotation row)."""
    return [int(r in rows) for r in ("tx", "ty", "tz", "rx", "ry")] + [0]


def rotation_conditions(rows) -> tuple[tuple[int, tuple[int, int]], ...]:
    """Per rotation condition Exudyn's ``ObjectJointGeneric`` states for ``rows``, the entry of its
    ``TorqueLocal`` (its multiplier) and ``(a, b)`` of the condition a0 . b1 = 0 between column a
    of J_A and column b of J_B (Exudyn's ``CObjectJointGeneric``): both rotations (a revolute
    configuration, free z) z0 . x1 and z0 . y1; only about x (universal, locked x) y0 . z1; only
    about y, x0 . z1."""
    rx, ry = "rx" in rows, "ry" in rows
    if rx and ry:
        return ((0, (2, 0)), (1, (2, 1)))
    if rx:
        return ((0, (1, 2)),)
    if ry:
        return ((1, (0, 2)),)
    return ()


def _add_loop(mbs, system: ExudynSystem, ground, loop: LoopJoint, frames, rows, *, reactions: bool) -> None:
    """One ``ObjectJointGeneric`` for ``loop`` stating ``rows`` (module docstring), and its force
    and torque sensors when ``reactions``."""
    import exudyn as exu
    from exudyn.itemInterface import (
        MarkerBodyRigid,
        ObjectJointGeneric,
        SensorObject,
        VObjectJointGeneric,
    )

    J_A = loop_frame(loop.axis_A)
    R_a = frames[loop.body_a][1]
    R_b = np.eye(3) if loop.body_b is None else frames[loop.body_b][1]
    J_B = R_b.T @ R_a @ J_A  # J_A carried to body_b at the initial state
    if keeps_axis(loop.kind):  # z exactly axis_B (the initial state aligns the axes to round-off)
        z_B = np.asarray(loop.axis_B, float) / np.linalg.norm(loop.axis_B)
        x_B = J_B[:, 0] - (J_B[:, 0] @ z_B) * z_B
        x_B /= np.linalg.norm(x_B)
        J_B = np.column_stack([x_B, np.cross(z_B, x_B), z_B])
    item_b = ground if loop.body_b is None else system.bodies[loop.body_b]
    markers = [mbs.AddMarker(MarkerBodyRigid(bodyNumber=item, localHT=exu.HT(rotation=J, translation=np.asarray(p, float)),
                                             visualization={"show": False}))
               for item, J, p in ((system.bodies[loop.body_a], J_A, loop.p_A), (item_b, J_B, loop.p_B))]
    joint = mbs.AddObject(ObjectJointGeneric(markerNumbers=markers, constrainedAxes=loop_axes(rows),
                                             visualization=VObjectJointGeneric(show=False)))
    system.loops[loop.name] = (joint, tuple(rows), loop.body_a, loop.body_b)
    if reactions:
        ovt = exu.OutputVariableType
        system.loop_sensors[loop.name] = tuple(
            mbs.AddSensor(SensorObject(objectNumber=joint, outputVariableType=t, storeInternal=True, writeToFile=False))
            for t in (ovt.ForceLocal, ovt.TorqueLocal))
