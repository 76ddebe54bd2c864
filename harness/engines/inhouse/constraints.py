"""Joint constraints of the in-house model: position error C, velocity Jacobian J, acceleration
bias gamma, and the projection of a state back onto the constraint manifold.

Derivation (frames and rows as in ``harness.engines.inhouse.model``; R = body -> world rotation,
w_W = R w_B the world angular velocity; ``d/dt (R w_B) = R dw_B/dt``):

Ball rows, joint point r_c (child frame, from the child's centre of mass), r_p (parent frame),
s = R r its world offset::

    C      = (p_c + s_c) - (p_p + s_p)                                   (m)
    dC/dt  = v_c - [s_c]x R_c w_c_B - v_p + [s_p]x R_p w_p_B            (J u)
    d2C/dt2 = J du/dt + gamma,  gamma = w_c x (w_c x s_c) - w_p x (w_p x s_p)   (world w's)

(the world point velocity of a body point r is v - R [r]x w_B = v + w_W x s.)

Hinge orientation rows, a = R_c a_c (child axis in world), n_k = R_p b_k (k = 1, 2)::

    C_k     = a . n_k                                                   (dimensionless)
    dC_k/dt = (a x n_k) . (w_c - w_p) = (R_c^T c_k) . w_c_B - (R_p^T c_k) . w_p_B,  c_k = a x n_k
    gamma_k = dc_k/dt . (w_c - w_p),  dc_k/dt = (w_c x a) x n_k + a x (w_p x n_k)

The same J maps a small displacement ``[dp_W, dtheta_B]`` (rotation R -> R exp([dtheta_B]x))
to the change of C, which the Gauss-Newton projection uses.
"""

from __future__ import annotations

import numpy as np

from harness import rotations
from harness.engines.inhouse import algebra
from harness.engines.inhouse.model import NEModel


class DynamicsError(ArithmeticError):
    """A numerical failure of the model: singular constraint (KKT) matrix, projection that does
    not converge. The integrators report it as a failed run."""


_EYE = np.eye(3)[None]
_ZERO = np.zeros((1, 3))


def extend(P: np.ndarray, R: np.ndarray, w_W: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Append the world (index nb: at the origin, identity orientation, at rest) to per-body
    stacks of positions (nb,3), rotations (nb,3,3) and world angular velocities (nb,3)."""
    return (
        np.concatenate([P, _ZERO]),
        np.concatenate([R, _EYE]),
        np.concatenate([w_W, _ZERO]) if w_W is not None else None,
    )


def evaluate(nem: NEModel, P_ext: np.ndarray, R_ext: np.ndarray, w_ext: np.ndarray | None):
    """Constraint rows at one configuration.

    Args:
        P_ext, R_ext: centre-of-mass positions (nb+1, 3) m and rotations (nb+1, 3, 3), world last.
        w_ext: world-frame angular velocities (nb+1, 3) rad/s, or None to skip the bias.

    Returns:
        ``(C, J, gamma)``: position error (nc,), Jacobian (nc, 6nb) w.r.t.
        ``u = [v_WCm_W..., w_WB_B...]``, and the bias (nc,) with ``d2C/dt2 = J du/dt + gamma``
        (None when ``w_ext`` is None).
    """
    nj, nh, nb = nem.nj, nem.nh, nem.nb
    ends = nem.ends
    R_end = R_ext[ends]
    s = (R_end @ nem.r_end[:, :, None])[:, :, 0]
    x = P_ext[ends] + s
    C_ball = x[:nj] - x[nj:]
    Jw_ball = (-nem.end_sign)[:, None, None] * (algebra.skew(s) @ R_end)
    if w_ext is not None:
        w_end = w_ext[ends]
        X = algebra.cross(w_end, algebra.cross(w_end, s))
        gamma_ball = X[:nj] - X[nj:]
    if nh:
        Rc = R_ext[nem.hinge_child]
        Rp = R_ext[nem.hinge_parent]
        a = (Rc @ nem.a_c[:, :, None])[:, :, 0]  # (nh, 3)
        n = nem.b_p @ np.swapaxes(Rp, -1, -2)  # (nh, 2, 3): rows R_p b_k
        a2 = a[:, None, :]
        C_h = np.sum(a2 * n, axis=-1)
        c = algebra.cross(a2, n)  # (nh, 2, 3)
        values = np.concatenate([Jw_ball.ravel(), (c @ Rc).ravel(), (-(c @ Rp)).ravel()])
        C = np.concatenate([C_ball.ravel(), C_h.ravel()])
        if w_ext is not None:
            wc = w_ext[nem.hinge_child]
            wp = w_ext[nem.hinge_parent]
            cdot = algebra.cross(algebra.cross(wc, a)[:, None, :], n) + algebra.cross(a2, algebra.cross(wp[:, None, :], n))
            gamma_h = np.sum(cdot * (wc - wp)[:, None, :], axis=-1)
            gamma = np.concatenate([gamma_ball.ravel(), gamma_h.ravel()])
        else:
            gamma = None
    else:
        values = Jw_ball.ravel()
        C = C_ball.ravel()
        gamma = gamma_ball.ravel() if w_ext is not None else None
    J = nem.J_template.copy()
    J[nem.J_rows, nem.J_cols] = values
    return C, J[:, : 6 * nb], gamma


def violation(nem: NEModel, y: np.ndarray) -> tuple[float, float]:
    """Largest position-level (m for ball rows, dimensionless for hinge rows) and velocity-level
    (m/s, rad/s) constraint errors of a state vector; (0, 0) without constraints."""
    if nem.nc == 0:
        return 0.0, 0.0
    nb = nem.nb
    P = y[: 3 * nb].reshape(nb, 3)
    R = algebra.quat_matrix(algebra.normalized(y[3 * nb : 7 * nb].reshape(nb, 4)))
    P_ext, R_ext, _ = extend(P, R, None)
    C, J, _ = evaluate(nem, P_ext, R_ext, None)
    return float(np.max(np.abs(C))), float(np.max(np.abs(J @ y[7 * nb :])))


def project(nem: NEModel, y: np.ndarray, tol: float = 1e-13, max_iter: int = 8) -> np.ndarray:
    """A copy of state ``y`` with unit quaternions, positions on the constraint manifold
    (mass-weighted Gauss-Newton until max |C| <= tol) and velocities in the null space of J
    (mass-weighted orthogonal projection). Raises DynamicsError when it does not converge.
    """
    nb = nem.nb
    y = np.array(y, dtype=float)
    Q = algebra.normalized(y[3 * nb : 7 * nb].reshape(nb, 4))
    y[3 * nb : 7 * nb] = Q.ravel()
    if nem.nc == 0:
        return y
    Minv = nem.Minv
    for _ in range(max_iter):
        P = y[: 3 * nb].reshape(nb, 3)
        R = algebra.quat_matrix(Q)
        P_ext, R_ext, _ = extend(P, R, None)
        C, J, _ = evaluate(nem, P_ext, R_ext, None)
        JM = J @ Minv
        A = JM @ J.T
        if not np.all(np.isfinite(C)):
            raise DynamicsError("non-finite constraint error in the projection")
        if np.max(np.abs(C)) <= tol:
            break
        try:
            dx = -(JM.T @ np.linalg.solve(A, C))
        except np.linalg.LinAlgError:
            raise DynamicsError("singular constraint matrix in the position projection") from None
        y[: 3 * nb] += dx[: 3 * nb]
        Q = algebra.normalized(rotations.multiply(Q, algebra.quat_exp(dx[3 * nb :].reshape(nb, 3))))
        y[3 * nb : 7 * nb] = Q.ravel()
    else:
        raise DynamicsError(f"position projection did not converge (max |C| = {np.max(np.abs(C)):.3e})")
    u = y[7 * nb :]
    try:
        u -= JM.T @ np.linalg.solve(A, J @ u)
    except np.linalg.LinAlgError:
        raise DynamicsError("singular constraint matrix in the velocity projection") from None
    return y
