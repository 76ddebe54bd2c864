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
with a constant inverse). The last two terms are Baumgarte stabilisation: the constraint error
obeys ``C'' + 2 zeta w_b C' + w_b^2 C = 0`` instead of drifting; on the constraint manifold they
vanish and the dynamics are exact. ``lambda`` are the joint reactions: for a ball block, the
force (N, world) the parent exerts on the child at the joint point; for the two hinge
orientation rows, ``sum_k lambda_k (a x n_k)`` is the couple (N m, world) on the child.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from harness.engines.inhouse import algebra
from harness.engines.inhouse.constraints import DynamicsError, evaluate, extend
from harness.engines.inhouse.model import NEModel


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


def make_dynamics(nem: NEModel, gains: Baumgarte = Baumgarte()) -> Callable[[float, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """``dynamics(t, y) -> (dy/dt, lambda)``: state derivative (13 nb,) and constraint
    multipliers (nc,) at time t (s). Raises DynamicsError on a singular KKT matrix."""
    nb, nc = nem.nb, nem.nc
    I_B, Minv, weight = nem.I_B, nem.Minv, nem.weight_W
    forces = nem.forces
    kp, kd = float(gains.kp), float(gains.kd)
    n3, n7, n10 = 3 * nb, 7 * nb, 10 * nb
    no_lambda = np.zeros(0)
    cross, quat_matrix, quat_rate = algebra.cross, algebra.quat_matrix, algebra.quat_rate
    solve = np.linalg.solve

    def dynamics(t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        Q = y[n3:n7].reshape(nb, 4)
        Q = Q / np.sqrt(np.sum(Q * Q, axis=1, keepdims=True))
        W = y[n10:].reshape(nb, 3)
        u = y[n7:]
        tau = -cross(W, (I_B @ W[:, :, None])[:, :, 0])
        R = None
        if forces:
            R = quat_matrix(Q)
            F = weight.copy()
            for i, r_B, force_W in forces:
                f_W = np.asarray(force_W(t), dtype=float)
                F[i] += f_W
                tau[i] += cross(r_B, f_W @ R[i])  # r_B x (R^T f_W), body frame
            f = np.concatenate([F.ravel(), tau.ravel()])
        else:
            f = np.concatenate([weight.ravel(), tau.ravel()])
        a = Minv @ f
        lam = no_lambda
        if nc:
            if R is None:
                R = quat_matrix(Q)
            P = y[:n3].reshape(nb, 3)
            w_W = (R @ W[:, :, None])[:, :, 0]
            P_ext, R_ext, w_ext = extend(P, R, w_W)
            C, J, gamma = evaluate(nem, P_ext, R_ext, w_ext)
            JM = J @ Minv
            rhs = -gamma - J @ a
            if kd or kp:
                rhs -= kd * (J @ u) + kp * C
            try:
                lam = solve(JM @ J.T, rhs)
            except np.linalg.LinAlgError:
                raise DynamicsError(f"singular constraint (KKT) matrix at t = {t!r} s") from None
            a = a + lam @ JM
        ydot = np.empty_like(y)
        ydot[:n3] = y[n7:n10]
        ydot[n3:n7] = quat_rate(Q, W).ravel()
        ydot[n7:] = a
        return ydot, lam

    return dynamics


def make_rhs(nem: NEModel, gains: Baumgarte = Baumgarte()) -> Callable[[float, np.ndarray], np.ndarray]:
    """``rhs(t, y) -> dy/dt`` of the state vector (units: those of y per second)."""
    dynamics = make_dynamics(nem, gains)

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        return dynamics(t, y)[0]

    return rhs


def reactions(nem: NEModel, t: float, y: np.ndarray, gains: Baumgarte = Baumgarte()) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Joint reactions at state ``y`` and time ``t`` (s), per constrained joint (named by its
    child body): ``(force_W, moment_W)``, the force (N) and couple (N m), both in world, that the
    parent (or the world) exerts on the child; the force acts at the joint point, the couple is
    the hinge's orientation reaction (zero for a ball). Pass the run's ``gains`` to get exactly
    the multipliers the run used; off the constraint manifold they differ from the unstabilised
    ones by the Baumgarte terms."""
    _, lam = make_dynamics(nem, gains)(t, np.asarray(y, dtype=float))
    nb, nj = nem.nb, nem.nj
    out: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    moments = np.zeros((nj, 3))
    if nem.nh:
        R = algebra.quat_matrix(algebra.normalized(y[3 * nb : 7 * nb].reshape(nb, 4)))
        R_ext = np.concatenate([R, np.eye(3)[None]])
        a = (R_ext[nem.hinge_child] @ nem.a_c[:, :, None])[:, :, 0]
        n = nem.b_p @ np.swapaxes(R_ext[nem.hinge_parent], -1, -2)
        c = algebra.cross(a[:, None, :], n)
        lam_h = lam[3 * nj :].reshape(nem.nh, 2)
        moments[nem.hinge_joint] = np.einsum("hk,hki->hi", lam_h, c)
    for j, name in enumerate(nem.joint_names):
        out[name] = (lam[3 * j : 3 * j + 3].copy(), moments[j])
    return out


def energy(nem: NEModel, y: np.ndarray, gravity_W: np.ndarray) -> float:
    """Kinetic plus gravitational potential energy (J) of state ``y`` (zero potential at the
    world origin). ``gravity_W`` in m/s^2."""
    nb = nem.nb
    P = y[: 3 * nb].reshape(nb, 3)
    V = y[7 * nb : 10 * nb].reshape(nb, 3)
    W = y[10 * nb :].reshape(nb, 3)
    kin = 0.5 * np.sum(nem.mass * np.sum(V * V, axis=1)) + 0.5 * np.einsum("ni,nij,nj->", W, nem.I_B, W)
    return float(kin - np.sum(nem.mass * (P @ gravity_W)))
