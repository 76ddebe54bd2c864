"""The forces of a Pinocchio run, shared by the tree (``engine``), rolling (``rolling``) and
loop (``loops``) runs: the scene's applied forces as ``aba`` takes them, the potential energy of
the elements Pinocchio does not model, and the joint reactions ``rnea`` gives back.

Prescribed point forces and the springs between body points (``PointSpring``, from the current
configuration, and their dampers from the current velocities) enter ``aba`` as external forces
``fext`` expressed in the local frame of the joint that moves the body; every force element acting on a joint coordinate
(``ForceType.joint_force`` in ``harness.model.forces``: joint springs, joint torques) enters as
its generalised force in ``tau`` (``aba`` has no springs). Pinocchio's
``computePotentialEnergy`` knows gravity only: ``spring_energy`` and ``point_spring_energy`` give
the springs' potential energy (J).

Joint reactions: ``rnea`` at (q, v, a), with a from ``aba`` or a constrained forward dynamics
and the same ``fext``, leaves in ``data.f[j]`` the spatial force that the parent exerts on the
subtree of joint j, about the joint origin (the body-frame origin of the URDF link), in the
joint's local frame; it is rotated to world. The joint's own applied generalised force (the
``tau`` entry of a joint spring) acts along the motion subspace and is removed, so the reaction
is the constraint force alone.
"""

from __future__ import annotations

import weakref

import numpy as np
import pinocchio as pin

from harness.model.forces import POINT_FORCES, POINT_SPRINGS, elements, spring_force, spring_potential


def joint_slots(pmodel, ids, model) -> list[tuple[int, int, object, object]]:
    """``(idx_q, idx_v, force type, element)`` of each force element acting on a joint's single
    coordinate (``ForceType.joint_force``: joint springs)."""
    body_index = {b.name: i for i, b in enumerate(model.bodies)}
    slots = []
    for ft, element in elements(model):
        if ft.joint_force is not None:
            jm = pmodel.joints[ids[body_index[element.body]]]
            slots.append((jm.idx_q, jm.idx_v, ft, element))
    return slots


def spring_energy(slots, q) -> float:
    """Potential energy (J) of the joint-space force elements (``joint_slots``) at configuration q."""
    return float(sum(ft.joint_potential(element, q[iq]) for iq, _, ft, element in slots if ft.joint_potential is not None))


def _world_point(data, ids, body_index, body: str | None, p) -> np.ndarray:
    """The point ``p`` of ``body`` (its joint frame; None: the world's, in world) in world (m),
    from ``data.oMi`` (``forwardKinematics`` must have run)."""
    return np.asarray(p, float) if body is None else data.oMi[ids[body_index[body]]].act(np.asarray(p, float))


def _world_velocity(data, ids, body_index, body: str | None, p) -> np.ndarray:
    """The world velocity (m/s) of the point ``p`` of ``body`` (its joint frame; None: the
    world's, at rest): ``R (v + w x p)`` from the joint's spatial velocity ``data.v`` in its local
    frame (``forwardKinematics`` at q and v must have run)."""
    if body is None:
        return np.zeros(3)
    jid = ids[body_index[body]]
    v = data.v[jid]
    return data.oMi[jid].rotation @ (np.asarray(v.linear) + np.cross(np.asarray(v.angular), np.asarray(p, float)))


def has_dampers(model) -> bool:
    """Whether a point spring of ``model`` has a damper (its force needs the velocities: the
    caller's ``forwardKinematics`` then takes v, ``point_wrenches``)."""
    return any(sp.damping for sp in POINT_SPRINGS.elements(model))


def point_spring_energy(pmodel, data, ids, model, q) -> float:
    """Potential energy (J) of the springs between body points (``PointSpring``) at
    configuration q: k (L - L0)^2 / 2 each (Pinocchio does not model them)."""
    springs = POINT_SPRINGS.elements(model)
    if not springs:
        return 0.0
    pin.forwardKinematics(pmodel, data, q)
    body_index = {b.name: i for i, b in enumerate(model.bodies)}
    return float(sum(spring_potential(sp, _world_point(data, ids, body_index, sp.body_a, sp.p_A),
                                      _world_point(data, ids, body_index, sp.body_b, sp.p_B)) for sp in springs))


def joint_force_function(pmodel, ids, model):
    """``joint_forces(q, v) -> tau`` (nv,): the generalised forces of the joint-space force
    elements (``joint_slots``), zero without them (the same zero array each call)."""
    slots = joint_slots(pmodel, ids, model)
    tau0 = np.zeros(pmodel.nv)

    def joint_forces(q, v):
        if not slots:
            return tau0
        tau = np.zeros(pmodel.nv)
        for iq, iv, ft, element in slots:
            tau[iv] += ft.joint_force(element, q[iq], v[iv])
        return tau

    return joint_forces


def applied_function(pmodel, data, ids, model):
    """``applied(t, q, v) -> (tau, fext)``: the joint-space forces and the scene's prescribed
    point forces as ``fext`` in the local frame of each body's joint (None without forces).

    ``aba`` knows no springs: a joint-space force element enters ``tau`` as its generalised
    force on the joint's dof (``ForceType.joint_force``; a spring ``-k (q - q_ref)``), zero
    without them (no joint is actuated)."""
    joint_forces = joint_force_function(pmodel, ids, model)
    wrenches = point_wrenches(pmodel, data, ids, model)
    if wrenches is None:
        return lambda t, q, v: (joint_forces(q, v), None)

    damped = has_dampers(model)

    def applied(t, q, v):
        tau = joint_forces(q, v)
        if damped:  # the dampers' velocities too (data.v)
            pin.forwardKinematics(pmodel, data, q, v)
        else:
            pin.forwardKinematics(pmodel, data, q)
        fext = [pin.Force.Zero() for _ in range(pmodel.njoints)]
        for jid, w in wrenches(t).items():
            fext[jid] = pin.Force(w)
        return tau, fext

    return applied


def point_wrenches(pmodel, data, ids, model):
    """``wrenches(t) -> {joint id: wrench (6,)}``: the scene's prescribed point forces and the
    springs between body points (with their dampers) at time ``t`` (s), each as the spatial
    force ``[f_L, p x f_L]`` (N, N m) in the local frame of the joint that moves its body, summed
    per joint in the order the forces are listed (point forces, then each spring's end a and end
    b); None without such forces. Reads the placements ``data.oMi`` (``forwardKinematics`` at q
    must have run) and, for a damper (``has_dampers``), the joints' velocities ``data.v``
    (``forwardKinematics`` at q and v)."""
    point_forces = POINT_FORCES.elements(model)
    point_springs = POINT_SPRINGS.elements(model)
    if not point_forces and not point_springs:
        return None
    body_index = {b.name: i for i, b in enumerate(model.bodies)}
    jid_of = {b.name: ids[i] for i, b in enumerate(model.bodies)}
    def point(p):
        p = np.asarray(p, float)
        return p, tuple(p.tolist())

    forces = [(jid_of[f.body], point(f.p_BQ_B)[1], f.force_W) for f in point_forces]
    springs = [(sp, jid_of[sp.body_a], *point(sp.p_A), None if sp.body_b is None else jid_of[sp.body_b], *point(sp.p_B))
               for sp in point_springs]

    def push(out, jid, p, f_W):
        """Add the world force f_W at the point p (floats, joint frame) of joint ``jid``'s body to
        ``out``: [f_L, p x f_L] (the products and differences of ``np.cross``)."""
        f0, f1, f2 = (data.oMi[jid].rotation.T @ f_W).tolist()
        p0, p1, p2 = p
        w = np.array([f0, f1, f2, p1 * f2 - p2 * f1, p2 * f0 - p0 * f2, p0 * f1 - p1 * f0])
        out[jid] = w if jid not in out else out[jid] + w

    def wrenches(t):
        out = {}
        for jid, p, force_W in forces:
            push(out, jid, p, force_W(t))
        for spring, ja, p_A, pa, jb, p_B, pb in springs:  # -(k (L - L0) + c L') d / L on end a, the opposite on end b
            x_A = _world_point(data, ids, body_index, spring.body_a, p_A)
            x_B = _world_point(data, ids, body_index, spring.body_b, p_B)
            if spring.damping:
                f = spring_force(spring, x_A, x_B, _world_velocity(data, ids, body_index, spring.body_a, p_A),
                                 _world_velocity(data, ids, body_index, spring.body_b, p_B))
            else:
                f = spring_force(spring, x_A, x_B)
            push(out, ja, pa, f)
            if jb is not None:
                push(out, jb, pb, -f)
        return out

    return wrenches


def rnea_reactions(pmodel, data, jointed, tau, fext, q, v, a) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Constraint reaction of each ``(name, joint id)`` in ``jointed`` at the state (q, v) with
    acceleration ``a`` (from ``aba``, or a constrained one), the joint-space forces ``tau`` and
    the external forces ``fext`` (a ``pin.Force`` per joint, or None): force (N) and moment about
    the joint origin (N m), world frame, that the parent exerts on the joint's child (``rnea``;
    module docstring)."""
    if fext is None:
        pin.rnea(pmodel, data, q, v, a)
    else:
        pin.rnea(pmodel, data, q, v, a, fext)
    out = {}
    forces, placements = data.f, data.oMi
    for name, jid in jointed:
        f = forces[jid]
        lin, ang = np.array(f.linear), np.array(f.angular)
        iv = _single_dof(pmodel, jid)
        if iv is not None and tau[iv] != 0.0:  # the joint's own applied force along S
            S = np.array(data.joints[jid].S).reshape(6, -1)[:, 0]
            lin -= tau[iv] * S[:3]
            ang -= tau[iv] * S[3:]
        R = placements[jid].rotation
        out[name] = (R @ lin, R @ ang)
    return out


_SINGLE_DOF: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def _single_dof(pmodel, jid: int) -> int | None:
    """The velocity index of joint ``jid`` if it has one degree of freedom, else None (cached per
    model: ``pmodel.joints[jid]`` copies the joint model)."""
    table = _SINGLE_DOF.get(pmodel)
    if table is None:
        table = _SINGLE_DOF[pmodel] = [jm.idx_v if jm.nv == 1 else None for jm in pmodel.joints]
    return table[jid]
