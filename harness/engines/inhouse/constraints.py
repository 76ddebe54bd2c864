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

Slide (prismatic) rows, appended after all ball/hinge rows (``model.SlideJoint``). Joint points
x_c = p_c + s_c (the child's frame origin), x_p = p_p + s_p, d = x_c - x_p, n_k = R_p b_k::

    C_k      = d . n_k                                                  (m), k = 1, 2
    dC_k/dt  = n_k . (v_c - [s_c]x R_c w_c_B) - n_k . (v_p - [s_p]x R_p w_p_B) + (n_k x d) . w_p
             i.e. rows  n_k^T | (s_c x n_k)^T R_c | -n_k^T | (n_k x (s_p + d))^T R_p
             (the reaction lambda_k n_k acts on the child at x_c, its opposite on the parent at
             the same point)
    gamma_k  = [w_c x (w_c x s_c) - w_p x (w_p x s_p)] . n_k + 2 d' . (w_p x n_k)
               + d . (w_p x (w_p x n_k)),   d' = (v_c + w_c x s_c) - (v_p + w_p x s_p)

and three orientation rows C = (R_c u_k).(R_p v_k) with (u_k, v_k) = (e_y, e_z), (e_z, e_x),
(e_x, e_y), whose J and gamma have the form of the hinge rows above (a = R_c u_k, n = R_p v_k).
The slide bias needs the linear velocities: ``evaluate`` takes them as ``v_ext``.

The slide rows' multipliers give the joint's reaction (``slide_reactions``): ``lambda_1 n_1 +
lambda_2 n_2`` the force on the child at x_c, ``sum_k lambda_{2+k} (a_k x n_k)`` the couple.

Rolling-contact rows (no slip and height of a rim edge on the plane z = 0) come last; they are
built in ``rolling`` (``rolling_rows``).

The same J maps a small displacement ``[dp_W, dtheta_B]`` (rotation R -> R exp([dtheta_B]x))
to the change of C, which the Gauss-Newton projection uses.
"""

from __future__ import annotations

import numpy as np
from typing import Callable

from scipy.linalg.lapack import dposv, dpotrf as _dpotrf, dpotrs as _dpotrs

from harness.engines.inhouse import algebra
from harness.engines.inhouse.model import _ROT_U, _ROT_V, NEModel, SPARSE_ROWS  # noqa: F401 (SPARSE_ROWS: re-exported)
from harness.engines.inhouse.rolling import rolling_rows
from harness.measure.trajectory import Failure


class DynamicsError(ArithmeticError):
    """A numerical failure of the model: singular constraint (KKT) matrix, projection that does
    not converge. The integrators report it as a failed run with its ``reason`` (a ``Failure``:
    ``SINGULAR`` unless stated)."""

    def __init__(self, message: str, reason: Failure = Failure.SINGULAR):
        super().__init__(message)
        self.reason = reason


_IDENTITY_QUAT = np.array([[1.0, 0.0, 0.0, 0.0]])
_ZERO = np.zeros((1, 3))


def spd_solve(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Solve ``A x = b`` for a symmetric positive definite ``A`` (Cholesky, LAPACK dposv).
    Raises DynamicsError when ``A`` is not positive definite (singular constraints)."""
    _, x, info = dposv(A, b)
    if info != 0:
        raise DynamicsError("constraint matrix J M^-1 J^T is singular or not positive definite")
    return x


#: Eigenvalues of ``J M^-1 J^T`` below this fraction of the largest are treated as zero by
#: ``solve_rows`` (dependent rows of a loop: round-off, ~1e-16; a genuine near-singular position of
#: a linkage stays far above it).
RANK_RTOL = 1e-10


def solve_rows(A: np.ndarray, b: np.ndarray, redundant: bool) -> np.ndarray:
    """Solve ``A x = b`` for the symmetric ``A = J M^-1 J^T``: by Cholesky (``spd_solve``) for a
    model whose rows are independent, by the pseudo-inverse for a model with loop joints whose
    rows may be dependent (``NEModel.redundant``): ``pseudo_inverse(A)`` applied to b."""
    if not redundant:
        return spd_solve(A, b)
    return pseudo_inverse(A)(b)


def pseudo_inverse(A: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """``b -> x``: the least-squares solution of ``A x = b`` for a symmetric positive
    semi-definite ``A = J M^-1 J^T`` whose rows may be dependent, minimum-norm in the row-scaled
    metric.

    The rank is decided on the row-scaled matrix ``S = D^-1/2 A D^-1/2`` (D = diag A: each row's
    own mobility), eigenvalues of S below ``RANK_RTOL`` of its largest dropped, and
    ``x = D^-1/2 S^+ D^-1/2 b``. Unscaled, A mixes scales that have nothing to do with dependence:
    a slender rod's spin about its own axis (inertia m r^2 / 2) makes its hinge-axis rows 1e4 to
    1e5 times more mobile than the in-plane rows of a window, and near a flat position of a
    parallelogram chain (four_bar_chain with r = 5 mm: largest eigenvalue of A ~1e5, the windows'
    in-plane rows ~theta^2 ~1e-5 within 3e-3 rad of flat) those rows fell below 1e-10 of the
    largest eigenvalue: dropped as dependent, the projections stopped correcting them and the
    Gauss-Newton projection stalled on a 3e-9 m closure error it no longer saw (t = 0.715 s at
    N = 2). Scaled, such a row is dropped only within about 1e-5 rad of its flat position."""
    d = np.sqrt(np.abs(np.diagonal(A)))
    d[d == 0.0] = 1.0
    w, V = np.linalg.eigh(A / d[:, None] / d)
    if not np.all(np.isfinite(w)):
        raise DynamicsError("non-finite constraint matrix J M^-1 J^T")
    keep = w > RANK_RTOL * max(float(w[-1]), 0.0)
    if not keep.any():
        raise DynamicsError("constraint matrix J M^-1 J^T is zero")
    Vk, wk = V[:, keep], w[keep]
    return lambda b: (Vk @ ((Vk.T @ (b / d)) / wk)) / d


#: The sparse solve's regularisation (``RowSystem``): ``A + REGULARIZATION diag(A)`` is factored
#: (dependent rows make A singular), and ``REFINEMENTS`` steps of iterative refinement against A
#: itself take the remaining relative error of a row of scaled eigenvalue w to
#: ``(REGULARIZATION / w)^(REFINEMENTS + 1)``.
REGULARIZATION = 1e-12
REFINEMENTS = 2


class RowSystem:
    """The constraint rows' system at one configuration: ``A = J M^-1 J^T`` factored once, for
    the multipliers of the accelerations and the projections.

    ``solve(b)``: x with ``A x = b`` (Cholesky for independent rows; for rows that may be
    dependent, ``NEModel.redundant``, the least-squares solution of ``pseudo_inverse``);
    ``apply(x)``: ``M^-1 J^T x`` (the velocity change of multipliers x, m/s and rad/s per unit).

    From ``SPARSE_ROWS`` rows on (``NEModel.Minv_sparse`` set) A is formed and factored as a
    sparse matrix (every row acts on at most two bodies): SuperLU (``scipy.sparse.linalg.splu``)
    of ``A + REGULARIZATION diag(A)`` with ``REFINEMENTS`` refinement steps, which is exact to
    round-off for independent rows and leaves dependent rows' multipliers at round-off / the
    regularisation (no effect on the motion: ``J^T`` annihilates them; ``solve`` of the sparse
    form is not minimum-norm). Measured on four_bar_chain (605 rows at N = 40): see SPARSE_ROWS.
    """

    def __init__(self, nem: NEModel, J: np.ndarray):
        self.sparse = nem.Minv_sparse is not None
        if self.sparse:
            from scipy import sparse
            from scipy.sparse.linalg import splu

            Js = J if sparse.issparse(J) else sparse.csr_matrix(J)
            self.JM = Js @ nem.Minv_sparse
            A = (self.JM @ Js.T).tocsc()
            self._A = A
            diag = A.diagonal()
            if not np.all(np.isfinite(diag)):
                raise DynamicsError("non-finite constraint matrix J M^-1 J^T")
            factored = (A + sparse.diags(REGULARIZATION * diag)).tocsc() if nem.redundant else A
            try:
                self._lu = splu(factored)
            except RuntimeError as err:  # "Factor is exactly singular"
                raise DynamicsError(f"constraint matrix J M^-1 J^T is singular ({err})") from None
            self._refine = nem.redundant
            return
        self.JM = J @ nem.Minv
        A = self.JM @ J.T
        if nem.redundant:
            self._solve = pseudo_inverse(A)
        else:
            c, info = _dpotrf(A, lower=True)
            if info != 0:
                raise DynamicsError("constraint matrix J M^-1 J^T is singular or not positive definite")
            self._solve = lambda b: _dpotrs(c, b, lower=True)[0]

    def solve(self, b: np.ndarray) -> np.ndarray:
        if not self.sparse:
            return self._solve(b)
        x = self._lu.solve(b)
        if self._refine:
            for _ in range(REFINEMENTS):
                x = x + self._lu.solve(b - self._A @ x)
        return x

    def apply(self, x: np.ndarray) -> np.ndarray:
        return self.JM.T @ x if self.sparse else x @ self.JM


def linear_velocities(nb: int, y: np.ndarray) -> np.ndarray:
    """Centre-of-mass velocities (nb+1, 3) of state ``y``, the world (at rest) appended."""
    return np.concatenate([y[7 * nb : 10 * nb].reshape(nb, 3), _ZERO])


def frames(nb: int, y: np.ndarray, with_velocity: bool = True):
    """World-extended frames of state ``y``: unit quaternions (nb, 4), rotations (nb+1, 3, 3),
    positions (nb+1, 3) and world angular velocities (nb+1, 3) (None unless asked), the world
    (at rest, at the origin, identity orientation) appended as index nb."""
    Q = algebra.normalized(y[3 * nb : 7 * nb].reshape(nb, 4))
    R_ext = algebra.quat_matrix(np.concatenate([Q, _IDENTITY_QUAT]))
    P_ext = np.concatenate([y[: 3 * nb].reshape(nb, 3), _ZERO])
    w_ext = None
    if with_velocity:
        W_ext = np.concatenate([y[10 * nb :].reshape(nb, 3), _ZERO])
        w_ext = (R_ext @ W_ext[:, :, None])[:, :, 0]
    return Q, R_ext, P_ext, w_ext


def evaluate(nem: NEModel, P_ext: np.ndarray, R_ext: np.ndarray, w_ext: np.ndarray | None,
             v_ext: np.ndarray | None = None):
    """Constraint rows at one configuration.

    Args:
        P_ext, R_ext: centre-of-mass positions (nb+1, 3) m and rotations body -> world
            (nb+1, 3, 3), the world last.
        w_ext: world-frame angular velocities (nb+1, 3) rad/s, or None to skip the bias.
        v_ext: centre-of-mass velocities (nb+1, 3) m/s (``linear_velocities``); needed for the
            bias of slide rows only.

    Returns:
        ``(C, J, gamma)``: position error (nc,), Jacobian (nc, 6nb) w.r.t.
        ``u = [v_WCm_W..., w_WB_B...]``, and the bias (nc,) with ``d2C/dt2 = J du/dt + gamma``
        (None when ``w_ext`` is None).
    """
    nj, nb = nem.nj, nem.nb
    ends = nem.ends
    R_end = R_ext.take(ends, axis=0)
    X = R_end @ nem.D_end  # world columns: s (joint-point offset), a | n_1, 0 | n_2
    S = X[:, :, 0]
    x = P_ext.take(ends, axis=0) + S
    C = x[:nj] - x[nj:]
    # Body-frame rotational blocks of the ball rows: child -R_c [r_c]x, parent +R_p [r_p]x
    # (constant K_end = -+[r]x), identical to the world rows -+[s]x times R.
    ball = R_end @ nem.K_end
    gamma = None
    if w_ext is not None:
        w_end = w_ext.take(ends, axis=0)
        Sk = algebra.skew(w_end)
        Y = Sk @ X  # w x (each column)
        Z = (Sk @ Y[:, :, :1])[:, :, 0]  # w x (w x s)
        gamma = Z[:nj] - Z[nj:]
    if nem.has_hinge:
        a = X[:nj, :, 1]  # child axis, world (nj, 3); zero for a ball joint
        N = X[nj:, :, 1:]  # columns n_1, n_2, world (nj, 3, 2)
        Ska = algebra.skew(a)
        c = Ska @ N  # columns c_k = a x n_k
        cT = c.transpose(0, 2, 1)
        hinge = np.concatenate([cT, -cT]) @ R_end  # body-frame rows: child c_k^T R_c, parent -c_k^T R_p
        C = np.concatenate([C, (a[:, None, :] @ N)[:, 0, :]], axis=1)
        if w_ext is not None:
            # dc_k/dt = (w_c x a) x n_k + a x (w_p x n_k); gamma_k = dc_k/dt . (w_c - w_p)
            cdot = algebra.skew(Y[:nj, :, 1]) @ N + Ska @ Y[nj:, :, 1:]
            dw = w_end[:nj] - w_end[nj:]
            gamma = np.concatenate([gamma, (dw[:, None, :] @ cdot)[:, 0, :]], axis=1)
        values = np.concatenate([ball, hinge], axis=1).ravel()
    else:
        values = ball.ravel()
    if nem.J_take is not None:
        values = values.take(nem.J_take)
    if nem.J_fixed is not None:  # a large model: J as a sparse matrix (``RowSystem``)
        from scipy import sparse

        r0, c0, v0, on_bodies = nem.J_fixed
        J = sparse.csr_matrix((np.concatenate([v0, values[on_bodies]]),
                               (np.concatenate([r0, nem.J_rows[on_bodies]]), np.concatenate([c0, nem.J_cols[on_bodies]]))),
                              shape=(nem.nc, 6 * nb))
    else:
        J = nem.J_template.copy()
        J[nem.J_rows, nem.J_cols] = values
        J = J[:, : 6 * nb]
    C = C.ravel()
    if nem.keep is not None:
        C = C.take(nem.keep)
        if gamma is not None:
            gamma = gamma.ravel().take(nem.keep)
    if gamma is not None:
        gamma = gamma.ravel()
    if nem.slides:
        Cs, Js, gs = slide_rows(nem, P_ext, R_ext, w_ext, v_ext)
        C, J = np.concatenate([C, Cs]), np.concatenate([J, Js])
        if gamma is not None:
            gamma = np.concatenate([gamma, gs])
    if nem.contacts:  # rolling contacts: 3 rows each, last (``rolling``)
        Cr, Jr, gr = rolling_rows(nem.contacts, nb, P_ext, R_ext, w_ext)
        C, J = np.concatenate([C, Cr]), np.concatenate([J, Jr])
        if gamma is not None:
            gamma = np.concatenate([gamma, gr])
    return C, J, gamma


def slide_rows(nem: NEModel, P_ext: np.ndarray, R_ext: np.ndarray, w_ext: np.ndarray | None,
               v_ext: np.ndarray | None):
    """The 5 rows of each slide joint (module docstring): ``(C, J, gamma)`` with shapes
    (5 ns,), (5 ns, 6 nb), (5 ns,) (gamma None when ``w_ext`` is None)."""
    nb = nem.nb
    ns = len(nem.slides)
    cross = algebra.cross
    C = np.empty(5 * ns)
    J = np.zeros((5 * ns, 6 * nb))
    gamma = None if w_ext is None else np.empty(5 * ns)
    if w_ext is not None and v_ext is None:
        raise ValueError("slide joints need the linear velocities (v_ext) for the constraint bias")
    for j, sl in enumerate(nem.slides):
        c, p = sl.child, sl.parent
        r0 = 5 * j
        Rc, Rp = R_ext[c], R_ext[p]
        s_c, s_p = Rc @ sl.r_c, Rp @ sl.r_p
        d = (P_ext[c] + s_c) - (P_ext[p] + s_p)
        N = sl.b @ Rp.T  # (2, 3) rows n_k = R_p b_k (world)
        A = _ROT_U @ Rc.T  # (3, 3) rows a_k = R_c u_k
        Nr = _ROT_V @ Rp.T  # (3, 3) rows n_k = R_p v_k
        # one batched cross product: s_c x n_k (2), a_k x n_k (3), n_k x (s_p + d) (2)
        L1, R1 = np.empty((7, 3)), np.empty((7, 3))
        L1[:2], L1[2:5], L1[5:] = s_c, A, N
        R1[:2], R1[2:5], R1[5:] = N, Nr, s_p + d
        X = cross(L1, R1)
        C[r0 : r0 + 2] = N @ d
        C[r0 + 2 : r0 + 5] = np.einsum("ki,ki->k", A, Nr)
        vc, wc_col = 3 * c, 3 * nb + 3 * c
        J[r0 : r0 + 2, vc : vc + 3] = N
        J[r0 : r0 + 5, wc_col : wc_col + 3] = X[:5] @ Rc
        if p < nb:
            vp, wp_col = 3 * p, 3 * nb + 3 * p
            J[r0 : r0 + 2, vp : vp + 3] = -N
            J[r0 : r0 + 2, wp_col : wp_col + 3] = X[5:] @ Rp
            J[r0 + 2 : r0 + 5, wp_col : wp_col + 3] = -X[2:5] @ Rp
        if gamma is not None:
            wc, wp = w_ext[c], w_ext[p]
            # w_c x s_c, w_p x s_p, w_p x n_k (2), w_c x a_k (3), w_p x n_k (3, orientation rows)
            L2, R2 = np.empty((10, 3)), np.empty((10, 3))
            L2[0], L2[1:7], L2[7:] = wc, wp, wc
            R2[0], R2[1], R2[2:4], R2[4:7], R2[7:] = s_c, s_p, N, Nr, A
            Y = cross(L2, R2)
            ws, wn, wNr, wA = Y[:2], Y[2:4], Y[4:7], Y[7:10]
            # w_c x (w_c x s_c), w_p x (w_p x s_p), w_p x (w_p x n_k) (2), (w_c x a_k) x n_k (3), a_k x (w_p x n_k) (3)
            L3, R3 = np.empty((10, 3)), np.empty((10, 3))
            L3[0], L3[1:4], L3[4:7], L3[7:] = wc, wp, wA, A
            R3[:2], R3[2:4], R3[4:7], R3[7:] = ws, wn, Nr, wNr
            Z = cross(L3, R3)
            dd = (v_ext[c] + ws[0]) - (v_ext[p] + ws[1])
            gamma[r0 : r0 + 2] = N @ (Z[0] - Z[1]) + 2.0 * (wn @ dd) + Z[2:4] @ d
            gamma[r0 + 2 : r0 + 5] = (Z[4:7] + Z[7:10]) @ (wc - wp)
    return C, J, gamma


def slide_reactions(nem: NEModel, R_ext: np.ndarray, lam_slide: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per slide joint, from its 5 multipliers (``lam_slide``: the slide rows' multipliers, in
    order) and the world-extended rotations ``R_ext`` (``frames``): the force (N, world) the
    parent exerts on the child at its joint point, perpendicular to the axis, and the couple
    (N m, world) of the orientation rows."""
    out = {}
    for j, sl in enumerate(nem.slides):
        lj = lam_slide[5 * j : 5 * j + 5]
        Rc, Rp = R_ext[sl.child], R_ext[sl.parent]
        N = sl.b @ Rp.T
        A, Nr = _ROT_U @ Rc.T, _ROT_V @ Rp.T
        out[sl.name] = (lj[:2] @ N, lj[2:] @ np.cross(A, Nr))
    return out


def rows(nem: NEModel, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(C, J, gamma)`` of ``evaluate`` at state vector ``y`` (any state, on the constraint
    manifold or not)."""
    y = np.asarray(y, dtype=float)
    _, R_ext, P_ext, w_ext = frames(nem.nb, y)
    return evaluate(nem, P_ext, R_ext, w_ext, linear_velocities(nem.nb, y) if nem.slides else None)


def violation(nem: NEModel, y: np.ndarray) -> tuple[float, float]:
    """Largest position-level (m for ball rows, dimensionless for hinge rows) and velocity-level
    (m/s, rad/s) constraint errors of a state vector; (0, 0) without constraints."""
    if nem.nc == 0:
        return 0.0, 0.0
    nb = nem.nb
    _, R_ext, P_ext, _ = frames(nb, y, with_velocity=False)
    C, J, _ = evaluate(nem, P_ext, R_ext, None)
    return float(np.max(np.abs(C))), float(np.max(np.abs(J @ y[7 * nb :])))


def joint_offset_length(nem: NEModel) -> float:
    """The largest joint-point offset of the model (m): the largest component of a joint point
    from its body's centre of mass (or of a world point), 0 for a model without joints."""
    return float(np.max(np.abs(nem.D_end[:, :, 0]), initial=0.0))


def projection_tolerance(nem: NEModel) -> float:
    """Tolerance (m) of the projection onto the joint constraints, both forms: 1e-13 of the
    largest joint-point offset (at least 1 m), far above round-off and far below every scene's
    constraint check (1e-9)."""
    return 1e-13 * max(1.0, joint_offset_length(nem))


def project_stage(nem: NEModel, y: np.ndarray, tol: float, max_iter: int = 8) -> tuple[np.ndarray, RowSystem]:
    """A Runge-Kutta stage's state brought onto the constraint manifold (a model with loop
    joints, ``harness.engines.inhouse.projected_stages``): a copy of ``y`` with unit
    quaternions, positions by mass-weighted Gauss-Newton until max |C| <= ``tol`` (m for ball
    rows, dimensionless for hinge rows; re-evaluated after every step), and velocities in the
    null space of J at those positions; with the factored rows there (``RowSystem``), which the
    stage's accelerations reuse. Raises DynamicsError when it does not converge.

    Converged to ``tol`` (round-off), not stopped early: the stage's map must be a smooth function
    of y that is the identity on the manifold, so that the method keeps its order. Accepting
    stage errors up to 1e-9 m made four_bar_chain's error grow with the number of steps (N = 2,
    rk4 over 20 s: 2.6e-7, 8.4e-7, 2.4e-6 m from the exact motion at dt 2e-3, 1e-3, 5e-4 s), and
    one Gauss-Newton step alone left 1.6e-8, 2.0e-9, 1.5e-9 m (near a flat position a step
    leaves e^2 / theta)."""
    return _project(nem, y, tol, max_iter, stage=True)


def project(nem: NEModel, y: np.ndarray, tol: float = 1e-13, max_iter: int = 8) -> np.ndarray:
    """A copy of state ``y`` with unit quaternions, positions on the constraint manifold
    (mass-weighted Gauss-Newton until max |C| <= tol; m for ball rows, dimensionless for hinge
    rows) and velocities in the null space of J (mass-weighted orthogonal projection
    ``u -= M^-1 J^T (J M^-1 J^T)^-1 J u``). Raises DynamicsError when it does not converge.

    A Gauss-Newton step from a tiny error (max |C| <= ``_QUADRATIC``) leaves an error of order
    |C|^2 / length, far below ``tol``: it is not re-evaluated, and the velocity projection uses
    the Jacobian of the step's start (it differs by O(|C|)). So the usual call after a fixed
    step costs one constraint evaluation and two small Cholesky solves.
    """
    return _project(nem, y, tol, max_iter, stage=False)[0]


def _project(nem: NEModel, y: np.ndarray, tol: float, max_iter: int, stage: bool) -> tuple[np.ndarray, RowSystem | None]:
    """``project`` (``stage`` False: a Gauss-Newton step from an error at or below ``_QUADRATIC``
    is not re-evaluated, and the velocities take the Jacobian of its start) and ``project_stage``
    (``stage`` True: re-evaluated after every step until max |C| <= ``tol``, the velocities with
    J at the final positions): the projected copy of ``y`` and the rows factored at the last
    evaluation (None without constraints)."""
    nb = nem.nb
    y = np.array(y, dtype=float)
    Q = algebra.normalized(y[3 * nb : 7 * nb].reshape(nb, 4))
    y[3 * nb : 7 * nb] = Q.ravel()
    if nem.nc == 0:
        return y, None
    for _ in range(max_iter):
        _, R_ext, P_ext, _ = frames(nb, y, with_velocity=False)
        C, J, _ = evaluate(nem, P_ext, R_ext, None)
        err = np.max(np.abs(C))
        if not np.isfinite(err):
            raise DynamicsError("non-finite constraint error in the projection", Failure.NON_FINITE)
        rows = RowSystem(nem, J)
        if err <= tol:
            break
        dx = -rows.apply(rows.solve(C))
        y[: 3 * nb] += dx[: 3 * nb]
        # R -> R exp([dtheta_B]x) to first order, q -> q (x) (1, dtheta_B / 2), renormalised:
        # exact to O(|dtheta|^3), and Gauss-Newton iterates on any remainder.
        Q = algebra.normalized(Q + algebra.quat_rate(Q, dx[3 * nb :].reshape(nb, 3)))
        y[3 * nb : 7 * nb] = Q.ravel()
        if not stage and err <= _QUADRATIC:
            break
    else:
        raise DynamicsError(f"position projection did not converge (max |C| = {err:.3e})", Failure.PROJECTION)
    u = y[7 * nb :]
    u -= rows.apply(rows.solve(J @ u))
    return y, rows


_QUADRATIC = 1e-9
