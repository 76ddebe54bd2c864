"""The part of PyBullet's joint force-torque sensor reading that is not the joint's reaction.

What ``getJointState(...)[2]`` holds (Bullet 3.25, the source of PyBullet 3.2.7): each
``stepSimulation`` runs ``btMultiBody::computeAccelerationsArticulatedBodyAlgorithmMultiDof``
twice, and the sensor (``btMultiBodyJointFeedback::m_reactionForces``) is the sum of the two.

1. The forward-dynamics pass (``isConstraintPass`` false) at the step's start state
   ``(q_n, u_n)``, with gravity and the joint forces: for link i it stores
   ``I^A_i a_i + p^A_i``, the exact wrench the parent exerts on the child's subtree (the
   articulated-body algorithm's transmitted force; child's inertial frame, moment about its
   centre of mass). This is the ideal reaction. The pass then sets the velocities to
   ``u_{n+1} = u_n + dt qdd``.
2. The "constraint pass" (``btMultiBodyDynamicsWorld::solveInternalConstraints``,
   ``isConstraintPass = true``), meant to add the reaction of the constraint solver's forces
   (contacts, limits, motors: none here). It *adds* (``+=``) ``I^A_i a_i + p^A_i`` of a second
   articulated-body solve at ``(q_n, u_{n+1})`` in which the applied forces are the constraint
   forces (zero), the joint forces are zeroed (bullet3 d7f9d66, PR #4583) and the linear
   velocity-product term ``m w x v`` of each link's bias force is skipped (bullet3 94e5b69, PR
   #4462, the fix of issue #4451: a passive pendulum's centripetal force counted twice) -- but
   the gyroscopic couple ``w x I w`` and the Coriolis accelerations ``c_i = v_i x (S_i qd_i)``
   stay in. On a single hinge on a fixed base that leftover is exactly ``w x I w`` (``c`` is
   zero, the couple has no component along the axis): the gyroscopic couple the harness used to
   take off. On a moving parent ``c`` is not zero (the cart pendulum: ``xd thd`` terms), on a
   ball joint the couple drives the joint, and on a chain the leftover propagates through the
   articulated inertias: the sensor is off by a velocity-squared wrench that does not shrink
   with the step.

The leftover is the reaction, in the true dynamics, of the tree at ``(q_n, u_{n+1})`` with no
gravity and no joint forces, under an applied force ``m_i w_i x v_i`` at each link's centre of
mass (the skipped bias term, moved to the applied side; ``v_i`` the centre of mass's velocity):
``constraint_pass_wrenches`` computes it (recursive Newton-Euler in world Plucker coordinates,
the joint accelerations from the mass matrix), and the engine takes it off the sensor's reading.
"""

from __future__ import annotations

import numpy as np

from harness.model.joints import BALL, FREE, HINGE, SLIDE


def _skew(x: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -x[2], x[1]], [x[2], 0.0, -x[0]], [-x[1], x[0], 0.0]])


def _crm(v: np.ndarray) -> np.ndarray:
    """The motion cross-product matrix of the spatial velocity ``v = (w, v_O)``."""
    out = np.zeros((6, 6))
    w, u = _skew(v[:3]), _skew(v[3:])
    out[:3, :3] = w
    out[3:, 3:] = w
    out[3:, :3] = u
    return out


def _crf(v: np.ndarray) -> np.ndarray:
    """The force cross-product matrix: ``-crm(v)^T``."""
    return -_crm(v).T


def _spatial_inertia(m: float, c: np.ndarray, I_c: np.ndarray) -> np.ndarray:
    """Spatial inertia about the world origin (angular first) of mass ``m``, centre of mass
    ``c`` and inertia ``I_c`` about it (world)."""
    C = _skew(c)
    out = np.zeros((6, 6))
    out[:3, :3] = I_c - m * C @ C
    out[:3, 3:] = m * C
    out[3:, :3] = -m * C
    out[3:, 3:] = m * np.eye(3)
    return out


def _motion_subspace(kind: str, axis_W: np.ndarray, p_W: np.ndarray, R_WI: np.ndarray) -> np.ndarray:
    """Columns: the child's spatial velocity (world Plucker, angular first) per unit joint rate,
    in PyBullet's joint coordinates: a hinge's rate about ``axis_W`` through the pivot ``p_W``,
    a slide's along ``axis_W``, a ball's angular velocity in the child's inertial frame, a free
    base's world angular velocity and its velocity at the world origin."""
    if kind == HINGE.name:
        return np.concatenate([axis_W, np.cross(p_W, axis_W)])[:, None]
    if kind == SLIDE.name:
        return np.concatenate([np.zeros(3), axis_W])[:, None]
    if kind == BALL.name:
        return np.vstack([R_WI, _skew(p_W) @ R_WI])
    if kind == FREE.name:
        return np.eye(6)
    raise NotImplementedError(kind)


def constraint_pass_wrenches(bodies: list[dict]) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The wrench PyBullet's second articulated-body pass adds to each joint's sensor (module
    docstring): ``name -> (force_W, moment about the joint point_W)`` for every body with a
    joint to a parent (not a free base).

    ``bodies``: in tree order (parents first), each a dict with ``name``, ``parent`` (index or
    None), ``kind`` (joint kind), ``mass``, ``c`` (centre of mass, world, at the step's start),
    ``I_c`` (inertia about it, world), ``pivot`` (joint point, world), ``axis`` (a hinge's or
    slide's unit axis, world, PyBullet's), ``R_WI`` (the inertial frame's orientation), ``rate``
    (PyBullet's joint velocity after the step; a free base: ``(w_W, v_Cm_W)``), ``link``
    (PyBullet's link index, -1 for a free base).
    """
    n = len(bodies)
    S, X = [], []
    for b in bodies:
        S.append(_motion_subspace(b["kind"], b.get("axis"), b["pivot"], b["R_WI"]))
        X.append(_spatial_inertia(b["mass"], b["c"], b["I_c"]))
    offsets = np.cumsum([0] + [s.shape[1] for s in S])
    # the spatial velocities at (q_n, u_{n+1})
    vel, rel = [], []
    for i, b in enumerate(bodies):
        if b["kind"] == FREE.name:
            w, v_c = np.asarray(b["rate"][0], float), np.asarray(b["rate"][1], float)
            vr = np.concatenate([w, v_c - np.cross(w, b["c"])])
        else:
            vr = S[i] @ np.atleast_1d(np.asarray(b["rate"], float))
        vp = vel[b["parent"]] if b["parent"] is not None else np.zeros(6)
        rel.append(vr)
        vel.append(vp + vr)
    # the skipped bias term as an applied force m w x v_Cm at each link's centre of mass
    ext = []
    for i, b in enumerate(bodies):
        if b["link"] < 0:
            ext.append(np.zeros(6))
            continue
        w = vel[i][:3]
        v_c = vel[i][3:] + np.cross(w, b["c"])
        F = b["mass"] * np.cross(w, v_c)
        ext.append(np.concatenate([np.cross(b["c"], F), F]))

    def rnea(qdd: np.ndarray, with_velocity: bool) -> list[np.ndarray]:
        acc, force = [], []
        for i, b in enumerate(bodies):
            ap = acc[b["parent"]] if b["parent"] is not None else np.zeros(6)
            a = ap + S[i] @ qdd[offsets[i]:offsets[i + 1]]
            if with_velocity:
                a = a + _crm(vel[i]) @ rel[i]
            f = X[i] @ a
            if with_velocity:
                f = f + _crf(vel[i]) @ X[i] @ vel[i] - ext[i]
            acc.append(a)
            force.append(f)
        for i in range(n - 1, -1, -1):
            if bodies[i]["parent"] is not None:
                force[bodies[i]["parent"]] = force[bodies[i]["parent"]] + force[i]
        return force

    def generalised(force: list[np.ndarray]) -> np.ndarray:
        return np.concatenate([S[i].T @ force[i] for i in range(n)])

    nv = int(offsets[-1])
    bias = generalised(rnea(np.zeros(nv), True))
    M = np.column_stack([generalised(rnea(e, False)) for e in np.eye(nv)])
    qdd = np.linalg.solve(M, -bias)  # no joint forces in that pass
    force = rnea(qdd, True)
    out = {}
    for i, b in enumerate(bodies):
        if b["kind"] == FREE.name:
            continue
        f = force[i]
        out[b["name"]] = (f[3:].copy(), f[:3] - np.cross(b["pivot"], f[3:]))
    return out
