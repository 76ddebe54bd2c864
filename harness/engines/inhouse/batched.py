"""The in-house Newton-Euler equations vectorized over bodies and over a batch of states.

The same physics as ``newton_euler.make_dynamics`` and ``constraints.project`` (maximal
coordinates, joints as constraint forces from the KKT system, optional Baumgarte terms), written
once for a stack of states: every operation is one NumPy call over all bodies, joint ends and
batch entries together, so there is no Python loop over bodies, joints or trajectories. A batch is
any set of independent states of one model: initial conditions of a parameter study, the parallel
sequences of an extrapolation step (``batched_integrators``), or one trajectory (``nbatch = 1``).

Layout. The batch axis is LAST (the states are the columns, as SciPy's ``vectorized=True``
right-hand sides): a contraction of a small per-body matrix with a vector is then one
matrix product or ``einsum`` whose innermost loop runs over the batch, which is what makes large
batches cheap. Shapes (``ny = 13 nb``, the state layout of ``harness.engines.inhouse.model``)::

    Z      ny x nbatch   rows [p_WCm_W (nb*3) | quat_WB (nb*4) | v_WCm_W (nb*3) | w_WB_B (nb*3)]
    dZ/dt  ny x nbatch
    t      scalar, or nbatch (one time per column; only prescribed forces read it)

``BatchedModel.rhs_rows`` and ``project_rows`` take and return the public ``nbatch x ny``
layout (one state per row, as ``mujoco.rollout``'s ``nbatch x nstate``).

Scope: free, ball and hinge joints, gravity and prescribed point forces (``SUPPORTED``); a model
with more (slide joints, springs, rolling contacts of the per-state engine) is refused with
NotImplementedError by ``batched_model``.

Constraints are kept per joint *end* (each joint has a child end and a parent end, the world
being an extra body at rest): an end contributes a constant translational block ``T_e``
(+I3 / -I3 on the ball rows, 0 on hinge rows) and a rotational block ``G_e`` (body frame) to the
joint's rows of J. ``J M^-1 J^T`` is then a sum over pairs of ends on the same body of
``T_e T_e'^T / m + G_e I^-1 G_e'^T``, assembled by gathers: the flops of the sparse product, not
of the dense (nc x 6nb) one.

A single state (``nbatch = 1``) goes to the per-state functions (``make_dynamics``, ``project``):
with one column every NumPy call costs its fixed overhead and the per-state formulation has the
fewest calls. For two columns and more the vectorized path below is used; the per-state engine is
also its slow oracle: ``tests/engines/inhouse/test_batched.py`` checks every function here against it
to 1e-12.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.linalg.lapack import dposv

from harness.engines.inhouse import algebra
from harness.engines.inhouse.constraints import DynamicsError
from harness.engines.inhouse.constraints import project as single_project
from harness.engines.inhouse.model import NEModel
from harness.engines.inhouse.newton_euler import Baumgarte, make_dynamics

__all__ = ["SUPPORTED", "BatchedModel", "batched_model", "check_supported", "columns", "spd_solve"]

_QUADRATIC = 1e-9  # as constraints.project: below this a Gauss-Newton step is not re-evaluated
_SMALL_BATCH = 32  # below this many columns, dense solves go to LAPACK one matrix at a time

# Bilinear maps as constant matrices acting on outer products (batch last): see algebra.py.
_QM_T = np.ascontiguousarray(algebra._QUAT_MATRIX.T)  # (9, 16): R_flat = _QM_T @ vec(q q^T)
_QR_T = np.ascontiguousarray(algebra._QUAT_RATE.T)  # (4, 12): qdot = _QR_T @ vec(q w^T)
_CR_T = np.ascontiguousarray(algebra._CROSS.T)  # (3, 9):  a x b = _CR_T @ vec(a b^T)


def _outer(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """vec(a b^T) per leading index and column: (n, p, B), (n, q, B) -> (n, p*q, B)."""
    n, p, B = a.shape
    return (a[:, :, None, :] * b[:, None, :, :]).reshape(n, p * b.shape[1], B)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b for stacks (n, 3, B)."""
    return _CR_T @ _outer(a, b)


def _cross_columns(a: np.ndarray, N: np.ndarray) -> np.ndarray:
    """a x n_m for each column m of N: a (n, 3, B) or (n, 3, m, B), N (n, 3, m, B)."""
    n, _, m, B = N.shape
    a4 = a if a.ndim == 4 else a[:, :, None, :]
    outer = (a4[:, :, None] * N[:, None, :, :, :]).reshape(n, 9, m * B)
    return (_CR_T @ outer).reshape(n, 3, m, B)


def columns(Y: np.ndarray, ny: int) -> np.ndarray:
    """States given as rows (``nbatch x ny``, or one state ``(ny,)``) as columns ``ny x nbatch``."""
    Y = np.asarray(Y, dtype=float)
    if Y.ndim == 1:
        Y = Y[None, :]
    if Y.ndim != 2 or Y.shape[1] != ny:
        raise ValueError(f"states must be nbatch x {ny}, got shape {Y.shape}")
    return np.ascontiguousarray(Y.T)


def spd_solve(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Solve ``A x = b`` for symmetric positive definite matrices, batch last.

    ``A``: n x n x nbatch, ``b``: n x nbatch; returns n x nbatch. Small batches go to LAPACK
    one matrix at a time (``np.linalg.solve``); large ones use a Cholesky factorisation unrolled
    over the n columns, each step one NumPy operation over the whole batch. Raises
    DynamicsError when a matrix is singular or not positive definite.
    """
    n, B = b.shape
    if B == 1:
        _, x, info = dposv(A[:, :, 0], b)
        if info != 0:
            raise DynamicsError("constraint matrix J M^-1 J^T is singular or not positive definite")
    elif B < _SMALL_BATCH:
        try:
            x = np.linalg.solve(A.transpose(2, 0, 1), b.T[:, :, None])[:, :, 0].T
        except np.linalg.LinAlgError:
            raise DynamicsError("constraint matrix J M^-1 J^T is singular") from None
    else:
        with np.errstate(invalid="ignore", divide="ignore"):
            x = _cholesky_solve(A, b)
    if not np.all(np.isfinite(x)):
        raise DynamicsError("constraint matrix J M^-1 J^T is singular or not positive definite")
    return x


def _cholesky_solve(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``spd_solve`` for large batches: A = L L^T column by column, then two triangular solves."""
    n = b.shape[0]
    L = A.copy()  # the lower triangle becomes L
    inv_d = np.empty(b.shape)
    for k in range(n):
        inv_d[k] = 1.0 / np.sqrt(L[k, k])
        L[k:, k] *= inv_d[k]
        if k + 1 < n:
            col = L[k + 1 :, k]
            L[k + 1 :, k + 1 :] -= col[:, None, :] * col[None, :, :]
    z = b.copy()  # L z = b, column-oriented: solved entries update the rest at once
    for k in range(n):
        z[k] *= inv_d[k]
        if k + 1 < n:
            z[k + 1 :] -= L[k + 1 :, k] * z[k]
    for k in range(n - 1, -1, -1):  # L^T x = z, in place
        z[k] = (z[k] - np.einsum("jb,jb->b", L[k + 1 :, k], z[k + 1 :])) * inv_d[k] if k + 1 < n else z[k] * inv_d[k]
    return z


@dataclass(frozen=True)
class BatchedModel:
    """The batched equations of motion of one ``NEModel`` (batch last, see module docstring).

    Attributes:
        nem: the model (constant data, state layout).
        gains: Baumgarte gains used by ``rhs`` (none for methods that project after each step).
        rhs: ``rhs(t, Z) -> dZ/dt``, ny x nbatch.
        accelerations: ``accelerations(t, Z) -> (dv_WCm_W, dw_WB_B)``, each nb x 3 x nbatch: the
            velocity derivatives alone (what a Lie-group method needs besides ``w_WB_B``).
        project: ``project(Z, tol=1e-13) -> Z``, a copy with unit quaternions, positions on the
            constraint manifold and velocities tangent to it (``constraints.project`` per column).
    """

    nem: NEModel
    gains: Baumgarte
    rhs: Callable[[float | np.ndarray, np.ndarray], np.ndarray]
    accelerations: Callable[[float | np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]
    project: Callable[..., np.ndarray]

    @property
    def ny(self) -> int:
        return self.nem.ny

    def rhs_rows(self, t: float, Y: np.ndarray) -> np.ndarray:
        """``rhs`` on states given as rows (``nbatch x ny``); returns ``nbatch x ny``."""
        return self.rhs(t, columns(Y, self.ny)).T

    def project_rows(self, Y: np.ndarray, tol: float = 1e-13) -> np.ndarray:
        """``project`` on states given as rows (``nbatch x ny``); returns ``nbatch x ny``."""
        return self.project(columns(Y, self.ny), tol).T


def _end_structure(nem: NEModel) -> dict[str, np.ndarray]:
    """Constant tables of the joint ends (see the module docstring), as small matrices so that
    every gather or scatter over ends, bodies and end pairs is one matrix product."""
    nb, nj, rpj = nem.nb, nem.nj, nem.rpj
    ends = np.asarray(nem.ends)
    sel = np.zeros((2 * nj, nb))  # end -> its body (a world end selects nothing)
    for e, b in enumerate(ends):
        if b < nb:
            sel[e, b] = 1.0
    r_world = np.zeros((2 * nj, 3, 3, 1))  # the world's identity rotation on world ends
    r_world[ends == nb] = np.eye(3)[:, :, None]
    inv_mass_ext = np.concatenate([1.0 / nem.mass, [0.0]])
    Iinv_end = np.concatenate([nem.Iinv_B, np.zeros((1, 3, 3))])[ends]
    # Pairs of ends on the same (non-world) body, and the J M^-1 J^T block each adds to.
    T = np.zeros((2 * nj, rpj, 3))
    T[:, :3, :] = np.concatenate([np.ones(nj), -np.ones(nj)])[:, None, None] * np.eye(3)
    pairs, blocks = [], []
    for e in range(2 * nj):
        for f in range(2 * nj):
            if ends[e] == ends[f] and ends[e] < nb:
                pairs.append((e, f))
                blocks.append((e % nj) * nj + (f % nj))
    pairs = np.array(pairs, dtype=int).reshape(-1, 2)
    pair_to_block = np.zeros((nj * nj, len(pairs)))
    pair_to_block[blocks, np.arange(len(pairs))] = 1.0
    const = np.array([inv_mass_ext[ends[e]] * T[e] @ T[f].T for e, f in pairs]).reshape(len(pairs), rpj, rpj)
    const_blocks = np.einsum("kp,prs->krs", pair_to_block, const)[:, :, :, None]
    return {
        "sel": sel,
        "signed": sel[:nj] - sel[nj:],
        "r_world": r_world,
        "Iinv_end": Iinv_end,
        "pe": pairs[:, 0],
        "pf": pairs[:, 1],
        "pair_to_block": pair_to_block,
        "const_blocks": const_blocks,
    }


SUPPORTED = "free, ball and hinge joints, gravity and prescribed point forces"


def check_supported(nem: NEModel) -> None:
    """Raise NotImplementedError when ``nem`` has elements the batched equations do not model
    (they cover ``SUPPORTED``; the per-state engine may know more, e.g. slide joints, springs or
    rolling contacts)."""
    extra = [name for name in ("slides", "springs", "contacts") if getattr(nem, name, ())]
    n_rows = nem.nj * nem.rpj if nem.keep is None else len(nem.keep)
    if extra or n_rows != nem.nc:
        what = ", ".join(extra) or f"{nem.nc - n_rows} constraint rows besides ball/hinge joints"
        raise NotImplementedError(f"the batched in-house solver supports {SUPPORTED}; this model has {what}")


def batched_model(nem: NEModel, gains: Baumgarte = Baumgarte()) -> BatchedModel:
    """Build the batched right-hand side and projection of ``nem`` (see the module docstring).
    Raises NotImplementedError for a model outside ``SUPPORTED``."""
    check_supported(nem)
    nb, nc, nj, rpj = nem.nb, nem.nc, nem.nj, nem.rpj
    n3, n7, n10, ny = 3 * nb, 7 * nb, 10 * nb, 13 * nb
    I_B, Iinv_B = nem.I_B, nem.Iinv_B
    g_col = (nem.weight_W / nem.mass[:, None])[:, :, None]  # (nb, 3, 1) m/s^2
    inv_mass = 1.0 / nem.mass
    inv_mass_col = inv_mass[:, None, None]
    forces = nem.forces
    kp, kd = float(gains.kp), float(gains.kd)
    D_end, K_end, has_hinge, keep = nem.D_end, nem.K_end, nem.has_hinge, nem.keep
    child, parent = slice(0, nj), slice(nj, 2 * nj)
    single = make_dynamics(nem, gains)
    DK_T = np.ascontiguousarray(np.concatenate([D_end, K_end], axis=2).transpose(0, 2, 1))[:, None]  # (e, 1, 6, 3)
    if nc:
        st = _end_structure(nem)
        Iinv_endT = np.ascontiguousarray(st["Iinv_end"].transpose(0, 2, 1))
        sel, signed, r_world = st["sel"], st["signed"], st["r_world"]
        pe, pf, pair_to_block, const_blocks = st["pe"], st["pf"], st["pair_to_block"], st["const_blocks"]
        selT, signedT = np.ascontiguousarray(sel.T), np.ascontiguousarray(signed.T)

    def unit_quaternions(Z: np.ndarray) -> np.ndarray:
        Q = Z[n3:n7].reshape(nb, 4, -1)
        return Q / np.sqrt(np.einsum("nib,nib->nb", Q, Q))[:, None, :]

    def rotation(Qn: np.ndarray) -> np.ndarray:
        return (_QM_T @ _outer(Qn, Qn)).reshape(nb, 3, 3, -1)

    def per_end(M: np.ndarray, x: np.ndarray) -> np.ndarray:
        """Gather a per-body array (nb, ...) to the joint ends (2nj, ...) (0 on world ends)."""
        return (M @ x.reshape(x.shape[0], -1)).reshape((M.shape[0],) + x.shape[1:])

    def external(t, R, B: int, tau: np.ndarray) -> np.ndarray:
        """Linear accelerations (nb, 3, B or 1) from gravity and prescribed forces; adds the
        forces' moments (body frame) to ``tau`` in place."""
        if not forces:
            return g_col
        acc = np.repeat(g_col, B, axis=2)
        t_arr = np.asarray(t, dtype=float)
        for i, r_B, force_W in forces:
            if t_arr.ndim == 0:
                f_W = np.repeat(np.asarray(force_W(float(t_arr)), dtype=float)[:, None], B, axis=1)
            else:
                uniq, inv = np.unique(t_arr, return_inverse=True)
                f_W = np.stack([np.asarray(force_W(float(s)), dtype=float) for s in uniq], axis=1)[:, inv.ravel()]
            acc[i] += f_W * inv_mass[i]
            f_B = np.einsum("jib,jb->ib", R[i], f_W)  # R^T f_W
            tau[i] += _cross(np.repeat(r_B[None, :, None], B, axis=2), f_B[None])[0]
        return acc

    def constraint_blocks(P, R, W, with_error: bool):
        """Rotational rows G (2nj, rpj, 3, B) of J per end (body frame); the bias gamma
        (nj*rpj, B) (None when W is None); the position error C (nj*rpj, B) (None unless asked)."""
        B = R.shape[-1]
        R_end = per_end(sel, R) + r_world
        XG = DK_T @ R_end  # (e, i, 6, B): R_end @ [D_end | K_end]
        X = XG[:, :, :3]  # world columns: s, a | n_1, n_2
        S = X[:, :, 0]
        G = XG[:, :, 3:]  # ball rows
        C = gamma = None
        if with_error:
            C = per_end(signed, P) + S[child] - S[parent]
        if W is not None:
            w_end = per_end(sel, np.einsum("nijb,njb->nib", R, W))
            Zc = _cross(w_end, _cross(w_end, S))
            gamma = Zc[child] - Zc[parent]
        if has_hinge:
            a = X[child, :, 1]
            N = X[parent, :, 1:]  # (nj, 3, 2, B)
            c = _cross_columns(a, N)  # c_k = a x n_k
            hinge = np.einsum("eimb,feijb->femjb", c, R_end.reshape(2, nj, 3, 3, B))
            hinge[1] *= -1.0
            G = np.concatenate([G, hinge.reshape(2 * nj, 2, 3, B)], axis=1)
            if with_error:
                C = np.concatenate([C, np.einsum("eib,eimb->emb", a, N)], axis=1)
            if W is not None:
                wc, wp = w_end[child], w_end[parent]
                cdot = _cross_columns(_cross(wc, a), N) + _cross_columns(a, _cross_columns(wp, N))
                gamma = np.concatenate([gamma, np.einsum("eimb,eib->emb", cdot, wc - wp)], axis=1)
        if C is not None:
            C = C.reshape(nj * rpj, B)
            C = C if keep is None else C[keep]
        if gamma is not None:
            gamma = gamma.reshape(nj * rpj, B)
            gamma = gamma if keep is None else gamma[keep]
        return G, C, gamma

    def kkt_matrix(G: np.ndarray) -> np.ndarray:
        """J M^-1 J^T (nc, nc, B) from the rotational end blocks (sum over end pairs)."""
        B = G.shape[-1]
        GI = Iinv_endT[:, None] @ G  # (e, r, l, B): G I^-1
        prod = np.einsum("prkb,pskb->prsb", GI[pe], G[pf])
        blocks = per_end(pair_to_block, prod) + const_blocks
        A = blocks.reshape(nj, nj, rpj, rpj, B).transpose(0, 2, 1, 3, 4).reshape(nj * rpj, nj * rpj, B)
        return A if keep is None else A[keep][:, keep]

    def jacobian_times(G: np.ndarray, V: np.ndarray, W: np.ndarray) -> np.ndarray:
        """J u (nc, B) for velocities V (nb, 3, B or 1) (world), W (nb, 3, B) (body frame)."""
        B = G.shape[-1]
        rot = np.einsum("erkb,ekb->erb", G, per_end(sel, W))
        U = rot[child] + rot[parent]
        U[:, :3] += per_end(signed, V)
        U = U.reshape(nj * rpj, B)
        return U if keep is None else U[keep]

    def jacobian_transpose_times(G: np.ndarray, lam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """J^T lambda as body forces (nb, 3, B) (world) and moments (nb, 3, B) (body frame)."""
        B = G.shape[-1]
        if keep is not None:
            full = np.zeros((nj * rpj, B))
            full[keep] = lam
            lam = full
        lam = lam.reshape(nj, rpj, B)
        M_end = np.einsum("ferkb,erb->fekb", G.reshape(2, nj, rpj, 3, B), lam).reshape(2 * nj, 3, B)
        return per_end(signedT, lam[:, :3]), per_end(selT, M_end)

    def accelerations(t, Z: np.ndarray, Qn: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        B = Z.shape[1]
        if B == 1:
            dy = single(float(np.ravel(t)[0]), Z[:, 0])[0]
            return dy[n7:n10].reshape(nb, 3, 1), dy[n10:].reshape(nb, 3, 1)
        W = Z[n10:].reshape(nb, 3, B)
        tau = _cross(I_B @ W, W)  # -w x I w, body frame
        R = None
        if nc or forces:
            R = rotation(unit_quaternions(Z) if Qn is None else Qn)
        dv = external(t, R, B, tau)
        dw = Iinv_B @ tau
        if not nc:
            return dv, dw
        G, C, gamma = constraint_blocks(Z[:n3].reshape(nb, 3, B), R, W, with_error=bool(kp))
        if kd:
            rhs = -gamma - jacobian_times(G, dv + kd * Z[n7:n10].reshape(nb, 3, B), dw + kd * W)
        else:
            rhs = -gamma - jacobian_times(G, dv, dw)
        if kp:
            rhs -= kp * C
        F, M = jacobian_transpose_times(G, spd_solve(kkt_matrix(G), rhs))
        return dv + F * inv_mass_col, dw + Iinv_B @ M

    def rhs(t, Z: np.ndarray) -> np.ndarray:
        B = Z.shape[1]
        if B == 1:  # one state: the per-state formulation has the fewest NumPy calls
            return single(float(np.ravel(t)[0]), Z[:, 0])[0][:, None]
        Qn = unit_quaternions(Z)
        dv, dw = accelerations(t, Z, Qn)
        out = np.empty((ny, B))
        out[:n3] = Z[n7:n10]
        out[n3:n7] = (_QR_T @ _outer(Qn, Z[n10:].reshape(nb, 3, B))).reshape(4 * nb, B)
        out[n7:n10] = dv.reshape(n3, -1)
        out[n10:] = dw.reshape(n3, B)
        return out

    def project(Z: np.ndarray, tol: float = 1e-13, max_iter: int = 8) -> np.ndarray:
        Z = np.array(Z, dtype=float)
        B = Z.shape[1]
        if B == 1:
            return single_project(nem, Z[:, 0], tol=tol, max_iter=max_iter)[:, None]
        Qn = unit_quaternions(Z)
        Z[n3:n7] = Qn.reshape(4 * nb, B)
        if not nc:
            return Z
        for _ in range(max_iter):
            G, C, _ = constraint_blocks(Z[:n3].reshape(nb, 3, B), rotation(Qn), None, with_error=True)
            A = kkt_matrix(G)
            err = float(np.max(np.abs(C)))
            if not np.isfinite(err):
                raise DynamicsError("non-finite constraint error in the projection")
            if err <= tol:
                break
            F, M = jacobian_transpose_times(G, -spd_solve(A, C))
            Z[:n3] += (F * inv_mass_col).reshape(n3, B)
            Qn = Qn + _QR_T @ _outer(Qn, Iinv_B @ M)
            Qn = Qn / np.sqrt(np.einsum("nib,nib->nb", Qn, Qn))[:, None, :]
            Z[n3:n7] = Qn.reshape(4 * nb, B)
            if err <= _QUADRATIC:
                break
        else:
            raise DynamicsError(f"position projection did not converge (max |C| = {err:.3e})")
        V = Z[n7:n10].reshape(nb, 3, B)
        W = Z[n10:].reshape(nb, 3, B)
        F, M = jacobian_transpose_times(G, spd_solve(A, jacobian_times(G, V, W)))
        V -= F * inv_mass_col
        W -= Iinv_B @ M
        return Z

    return BatchedModel(nem=nem, gains=gains, rhs=rhs, accelerations=accelerations, project=project)
