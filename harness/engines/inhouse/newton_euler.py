"""Newton-Euler equations of constrained rigid bodies in maximal coordinates.

Per body (state layout in ``harness.engines.inhouse.model``)::

    dp_WCm_W/dt = v_WCm_W
    dq_WB/dt    = 1/2 q (x) (0, w_WB_B)                 with q -> q/|q| inside the RHS
    m dv_WCm_W/dt = m g_W + sum of prescribed forces + constraint forces      (N, world)
    I dw_WB_B/dt + w_WB_B x I w_WB_B = tau_B                                  (N m, body frame,
                                                                               about the COM)

With ``u = [v_WCm_W..., w_WB_B...]``, mass matrix M and generalised force
``f = [m g + F_ext..., -w x I w + tau_ext...]`` the joints (``constraints``) add ``J^T lambda``:
the accelerations and multipliers solve the KKT system::

    [ M  J^T ] [ du/dt   ]   [ f                                 ]
    [ J  0   ] [ -lambda ] = [ -gamma - 2 zeta w_b J u - w_b^2 C  ]

solved by its Schur complement ``(J M^-1 J^T) lambda = rhs - J M^-1 f`` (M is block diagonal
with a constant inverse); with loop joints, whose rows may be dependent, by its pseudo-inverse
(``constraints.solve_rows``: the minimum-norm multipliers). The last two terms are Baumgarte stabilisation: the constraint error
obeys ``C'' + 2 zeta w_b C' + w_b^2 C = 0`` instead of drifting; on the constraint manifold they
vanish and the dynamics are exact. ``lambda`` are the joint reactions: for a ball block, the
force (N, world) the parent exerts on the child at the joint point; for the two hinge
orientation rows, ``sum_k lambda_k (a x n_k)`` is the couple (N m, world) on the child.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from harness.engines.inhouse import algebra, rolling
from harness.engines.inhouse.constraints import (RowSystem, evaluate, frames, joint_offset_length, linear_velocities,
                                                 project_stage, slide_reactions)
from harness.engines.inhouse.model import NEModel, build
from harness.model.multibody import Multibody


#: A projected stage (``stage_tol``) whose rows' acceleration equation is left with a residual
#: ``max |J du - rhs| / max |rhs|`` above this lies within the band of a singular position: rows
#: that became dependent there (within about 1e-5 rad of a flat position of a parallelogram
#: chain) are dropped by the rank decision (``constraints.pseudo_inverse``) or by the sparse
#: solve's regularisation, and the stage loses their force, which stays O(1) while their
#: multipliers grow as 1/theta. Its accelerations are then those of ``across_singular_position``.
#: Where the rows are solved, the residual is round-off: at most 1.7e-11 on the stages of 3 s of
#: four_bar_near_singular (rk4), 1.3e-12 on bricard, 2.2e-12 on andrews_squeezer, 1.2e-11 on
#: four_bar_chain (N = 8) 1e-3 rad from flat; the stages 1.3e-5 rad from flat of four_bar_chain
#: (N = 40): 8.7e-7 and 5.4e-5; at N = 8, 1e-4 to 1e-7 rad from flat: 1.4e-10 to 4.9e-7 (at 1e-10
#: the mean replaced a stage 1e-4 rad away whose own solve was better: 2.4e-10 m against 1.9e-12 m).
SINGULAR_RESIDUAL = 1e-9
#: The first shift of ``across_singular_position``: a move of NEIGHBOUR_SHIFT times the model's
#: joint-offset length along the stage's velocity (doubled, at most NEIGHBOUR_DOUBLINGS times,
#: until both neighbours are out of the band).
NEIGHBOUR_SHIFT = 1e-4
NEIGHBOUR_DOUBLINGS = 6


@dataclass(frozen=True)
class Baumgarte:
    """Baumgarte gains: natural frequency ``omega`` (rad/s) and damping ratio ``zeta`` of the
    constraint-error dynamics ``C'' + 2 zeta omega C' + omega^2 C = 0``. ``omega = 0`` turns
    stabilisation off."""

    omega: float = 0.0
    zeta: float = 1.0

    @property
    def kp(self) -> float:
        return self.omega**2

    @property
    def kd(self) -> float:
        return 2.0 * self.zeta * self.omega


def make_dynamics(nem: NEModel, gains: Baumgarte = Baumgarte(), stage_tol: float | None = None
                  ) -> Callable[[float, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """``dynamics(t, y) -> (dy/dt, lambda)``: state derivative (13 nb,) and constraint
    multipliers (nc,) at time t (s). Raises DynamicsError on a singular KKT matrix.

    With ``stage_tol`` (m; a model with loop joints under a projected fixed-step method,
    ``harness.engines.inhouse.projected_stages``) the derivative is that of the state projected
    onto the constraint manifold (``constraints.project_stage``, positions to ``stage_tol``),
    whose factored rows the accelerations reuse."""
    nb, nc = nem.nb, nem.nc
    I_B, Minv, weight = nem.I_B, nem.Minv, nem.weight_W
    forces = nem.forces
    springs, slides = nem.springs, nem.slides
    torques, point_springs = nem.torques, nem.point_springs
    damped = any(ps.c for ps in point_springs)  # a damper needs the ends' velocities
    kp, kd = float(gains.kp), float(gains.kd)
    n3, n7, n10 = 3 * nb, 7 * nb, 10 * nb
    no_lambda = np.zeros(0)
    cross, quat_matrix, quat_rate = algebra.cross, algebra.quat_matrix, algebra.quat_rate

    length = joint_offset_length(nem) or 1.0  # m

    def dynamics(t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if stage_tol is None or not nc:
            return accelerations(t, y, None)[:2]
        y, rows = project_stage(nem, y, stage_tol)
        dy, lam, residual = accelerations(t, y, rows)
        if residual <= SINGULAR_RESIDUAL:
            return dy, lam
        return across_singular_position(t, y, dy, lam)

    def across_singular_position(t: float, y: np.ndarray, dy: np.ndarray, lam: np.ndarray):
        """(dy/dt, lambda) of a projected stage y within the band of a singular position
        (``SINGULAR_RESIDUAL``): the mean of those at its two neighbours, y moved by -tau and
        +tau along its own velocities (positions by tau v, quaternions by tau dq/dt) and
        projected back (``project_stage``), with tau such that the fastest joint point moves
        ``NEIGHBOUR_SHIFT`` of the joint-offset length, doubled until both neighbours are out of
        the band (then y's own result, unchanged, when none is). The mean is the derivative at y
        to O(tau^2) wherever the motion is smooth through the singular position (a
        parallelogram chain on its branch); its positions' rates (the projected velocities) are
        averaged too, since the velocity projection at y misses the same rows.

        Measured on four_bar_chain (N = 40, per-state rk4 at 1 ms over 0.2 s from the exact
        state at 8.5 s, whose stage at 8.584 s lands 1.3e-5 rad from flat): every crank tip
        2.6e-5 m from the exact motion without it; 8.6e-11 m with it (NEIGHBOUR_SHIFT 1e-5 to
        3e-4: 4.3e-11 to 1.7e-10 m; the accelerations alone averaged, the velocities left:
        2.0e-7 m); the passage at 0.7 s, whose nearest stage is 3.9e-4 rad from flat, 3.4e-11 m."""
        V, W = y[n7:n10].reshape(nb, 3), y[n10:].reshape(nb, 3)
        speed = float(np.max(np.sqrt(np.sum(V**2, axis=1)) + length * np.sqrt(np.sum(W**2, axis=1))))
        if not speed > 0.0:
            return dy, lam
        tau = NEIGHBOUR_SHIFT * length / speed
        for _ in range(NEIGHBOUR_DOUBLINGS):
            sides = []
            for sign in (-1.0, 1.0):
                z = y.copy()
                z[:n7] += sign * tau * dy[:n7]  # positions by tau v, quaternions by tau dq/dt (unit again in the projection)
                z, rows = project_stage(nem, z, stage_tol)
                sides.append(accelerations(t, z, rows))
            if max(sides[0][2], sides[1][2]) <= SINGULAR_RESIDUAL:
                return 0.5 * (sides[0][0] + sides[1][0]), 0.5 * (sides[0][1] + sides[1][1])
            tau *= 2.0
        return dy, lam

    def accelerations(t: float, y: np.ndarray, rows) -> tuple[np.ndarray, np.ndarray, float]:
        """(dy/dt, lambda, residual): residual = max |J du/dt - rhs| / max |rhs| of the rows'
        acceleration equation (0 without rows; round-off where the rows are solved exactly)."""
        W = y[n10:].reshape(nb, 3)
        tau = -cross(W, (I_B @ W[:, :, None])[:, :, 0])  # gyroscopic moment, body frame
        if nc or torques or point_springs:
            Q, R_ext, P_ext, w_ext = frames(nb, y, with_velocity=bool(nc) or damped)
        else:
            Q = algebra.normalized(y[n3:n7].reshape(nb, 4))
            R_ext = quat_matrix(Q) if forces else None
        if forces or springs or torques or point_springs:
            F = weight.copy()
            for i, r_B, force_W in forces:
                f_W = np.asarray(force_W(t), dtype=float)
                F[i] += f_W
                tau[i] += cross(r_B, f_W @ R_ext[i])  # r_B x (R^T f_W), body frame
            for sp in springs:
                spring_force(slides[sp.slide], sp, P_ext, R_ext, F, tau)
            for tq in torques:
                joint_torque(tq, R_ext, tau)
            V_ext = linear_velocities(nb, y) if damped else None
            for ps in point_springs:
                point_spring_force(ps, P_ext, R_ext, F, tau, V_ext, w_ext)
            f = np.concatenate([F.ravel(), tau.ravel()])
        else:
            f = np.concatenate([weight.ravel(), tau.ravel()])
        a = Minv @ f
        lam = no_lambda
        residual = 0.0
        if nc:
            C, J, gamma = evaluate(nem, P_ext, R_ext, w_ext, linear_velocities(nb, y) if slides else None)
            if rows is None:
                rows = RowSystem(nem, J)
            rhs = -gamma - J @ a
            if kd or kp:
                rhs -= kd * (J @ y[n7:]) + kp * C
            lam = rows.solve(rhs)
            da = rows.apply(lam)
            a = a + da
            if stage_tol is not None:
                scale = float(np.max(np.abs(rhs), initial=0.0))
                residual = float(np.max(np.abs(J @ da - rhs), initial=0.0)) / scale if scale > 0.0 else 0.0
        return np.concatenate([y[n7:n10], quat_rate(Q, W).ravel(), a]), lam, residual

    return dynamics


def spring_force(sl, sp, P_ext: np.ndarray, R_ext: np.ndarray, F: np.ndarray, tau: np.ndarray) -> None:
    """Add a slide-joint spring's forces to ``F`` (nb, 3) N world and ``tau`` (nb, 3) N m body
    frame: ``f = -k (q - q_ref) a_W`` on the child at its joint point x_c, ``-f`` on the parent
    at the same point, with q = (x_c - x_p)·a_W and a_W = R_c axis (``model.SpringElement``)."""
    nb = len(F)
    c, p = sl.child, sl.parent
    Rc, Rp = R_ext[c], R_ext[p]
    s_p = Rp @ sl.r_p
    d = (P_ext[c] + Rc @ sl.r_c) - (P_ext[p] + s_p)
    a_W = Rc @ sl.axis
    f = -sp.k * (d @ a_W - sp.q_ref) * a_W
    F[c] += f
    if p < nb:
        F[p] -= f
        arms = np.stack([sl.r_c, Rp.T @ (s_p + d)])  # x_c from each centre of mass, body frames
        moments = algebra.cross(arms, np.stack([Rc.T @ f, Rp.T @ f]))
        tau[c] += moments[0]
        tau[p] -= moments[1]
    else:
        tau[c] += algebra.cross(sl.r_c, Rc.T @ f)


def joint_torque(tq, R_ext: np.ndarray, tau: np.ndarray) -> None:
    """Add a hinge torque (``model.TorqueElement``) to ``tau`` (nb, 3) N m body frames: ``torque
    axis`` on the child, its opposite on the parent (none on the world)."""
    m_B = tq.torque * tq.axis_B
    tau[tq.child] += m_B
    if tq.parent < len(tau):
        tau[tq.parent] -= R_ext[tq.parent].T @ (R_ext[tq.child] @ m_B)


def point_spring_force(ps, P_ext: np.ndarray, R_ext: np.ndarray, F: np.ndarray, tau: np.ndarray,
                       V_ext: np.ndarray | None = None, w_ext: np.ndarray | None = None) -> None:
    """Add a point spring's forces (``model.PointSpringElement``) to ``F`` (nb, 3) N world and
    ``tau`` (nb, 3) N m body frames: ``f = -(k (L - L0) + c L') d / L`` at end a, ``-f`` at end
    b, d = x_a - x_b (world, m), ``L' = d . (v_a - v_b) / L`` from the ends' velocities
    ``v = V + w x arm`` (``V_ext``, ``w_ext``: centre-of-mass velocities and world angular
    velocities (nb+1, 3), the world last; needed only with a damper, c > 0)."""
    nb = len(F)
    a, b = ps.body_a, ps.body_b
    arm_a = R_ext[a] @ ps.r_a
    arm_b = R_ext[b] @ ps.r_b
    d = (P_ext[a] + arm_a) - (P_ext[b] + arm_b)
    L = float(np.sqrt(d @ d))
    magnitude = ps.k * (L - ps.rest_length)
    if ps.c:
        dv = (V_ext[a] + algebra.cross(w_ext[a], arm_a)) - (V_ext[b] + algebra.cross(w_ext[b], arm_b))
        magnitude += ps.c * float(d @ dv) / L
    f = -magnitude / L * d
    F[a] += f
    tau[a] += algebra.cross(ps.r_a, R_ext[a].T @ f)
    if b < nb:
        F[b] -= f
        tau[b] -= algebra.cross(ps.r_b, R_ext[b].T @ f)


def make_rhs(nem: NEModel, gains: Baumgarte = Baumgarte(), stage_tol: float | None = None
             ) -> Callable[[float, np.ndarray], np.ndarray]:
    """``rhs(t, y) -> dy/dt`` of the state vector (units: those of y per second); ``stage_tol``
    as ``make_dynamics``."""
    dynamics = make_dynamics(nem, gains, stage_tol)

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        return dynamics(t, y)[0]

    return rhs


def reactions(
    model: NEModel | Multibody, t: float, y: np.ndarray, gains: Baumgarte = Baumgarte()
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Joint reactions (the constraint multipliers) at state vector ``y`` and time ``t`` (s).

    Returns, per constrained joint (named by its child body), ``(force_W, moment_W)``: the force
    (N) and the couple (N m), both in world, that the parent (or the world) exerts on the child;
    the force acts at the joint point, the couple is the hinge's orientation reaction (zero for
    a ball; perpendicular to the hinge axis). The parent feels the opposite. ``model`` is an
    ``NEModel`` or a ``Multibody`` (built here). Pass a run's ``gains`` to get exactly the
    multipliers it used; on the constraint manifold the Baumgarte terms vanish anyway.
    Trajectory samples convert to state vectors with ``model.from_trajectory``
    (``harness.engines.inhouse.model``).
    """
    nem = model if isinstance(model, NEModel) else build(model)
    y = np.asarray(y, dtype=float)
    _, lam = make_dynamics(nem, gains)(t, y)
    return _reactions_from_multipliers(nem, y, lam)


def reaction_series(nem: NEModel, t: np.ndarray, ys: np.ndarray, gains: Baumgarte = Baumgarte(),
                    lam: np.ndarray | None = None) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """``reactions`` at every sample of a run: times ``t`` (n,) s and state vectors ``ys``
    (n, 13 nb). Returns per joint ``(force_W (n, 3) N, moment_W (n, 3) N m)``, the moment
    about the joint point (the force acts there, so it is the joint's couple). ``lam``: the
    run's multipliers at the samples (n, nc), where its integrator gave them (the compiled
    ones: ``Result.lam``, the same KKT system at the same states), else None: solved here."""
    multipliers = _sample_multipliers(nem, t, ys, gains, lam)
    names = list(nem.joint_names) + [sl.name for sl in nem.slides]
    out = {name: (np.zeros((len(t), 3)), np.zeros((len(t), 3))) for name in names}
    for k, (y, lam_k) in enumerate(zip(np.asarray(ys, dtype=float), multipliers)):
        for name, (f, m) in _reactions_from_multipliers(nem, y, lam_k).items():
            out[name][0][k] = f
            out[name][1][k] = m
    return out


def _sample_multipliers(nem: NEModel, t: np.ndarray, ys: np.ndarray, gains: Baumgarte, lam: np.ndarray | None):
    """The multipliers (nc,) at each sample: the rows of ``lam`` when given, else each solved
    by ``make_dynamics`` (one at a time)."""
    if lam is not None:
        return np.asarray(lam, dtype=float)[:, : nem.nc]
    dynamics = make_dynamics(nem, gains)
    return (dynamics(float(tk), y)[1] for tk, y in zip(t, np.asarray(ys, dtype=float)))


def _reactions_from_multipliers(nem: NEModel, y: np.ndarray, lam: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per joint (force_W, moment_W) from the multipliers ``lam`` at state ``y``."""
    nj, rpj = nem.nj, nem.rpj
    lam, lam_slide = lam[: nem.nc_fast], lam[nem.nc_fast :]
    full = np.zeros(nj * rpj)
    if nem.keep is None:
        full[:] = lam
    else:
        full[nem.keep] = lam
    full = full.reshape(nj, rpj)
    moments = np.zeros((nj, 3))
    if nem.has_hinge:
        _, R_ext, _, _ = frames(nem.nb, y, with_velocity=False)
        X = R_ext.take(nem.ends, axis=0) @ nem.D_end
        a, N = X[:nj, :, 1], X[nj:, :, 1:]
        c = algebra.cross(a[:, None, :], N.transpose(0, 2, 1))  # (nj, 2, 3): a x n_k
        moments = np.einsum("jk,jki->ji", full[:, 3:], c)
    out = {name: (full[j, :3].copy(), moments[j].copy()) for j, name in enumerate(nem.joint_names)}
    if nem.slides:
        _, R_ext, _, _ = frames(nem.nb, y, with_velocity=False)
        out.update(slide_reactions(nem, R_ext, lam_slide))
    return out


def contact_force_series(nem, t: np.ndarray, ys: np.ndarray, gains,
                         lam: np.ndarray | None = None) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """``contact_forces`` at every sample of a run (times ``t`` (n,) s, states ``ys``
    (n, 13 nb)): per contact ``(force_W (n, 3) N, moment_W (n, 3) N m)``. ``lam`` as
    ``reaction_series``."""
    k = len(nem.contacts)
    out = {c.name: (np.zeros((len(t), 3)), np.zeros((len(t), 3))) for c in nem.contacts}
    for n, lam_n in enumerate(_sample_multipliers(nem, t, ys, gains, lam)):
        for name, (f, _) in rolling.contact_forces(nem.contacts, lam_n[len(lam_n) - 3 * k :]).items():
            out[name][0][n] = f
    return out
