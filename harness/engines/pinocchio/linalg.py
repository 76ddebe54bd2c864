"""Small dense linear algebra of the stepping loops, by the LAPACK routines behind NumPy's
``np.linalg`` called directly (``scipy.linalg.lapack``): the same routines (``dgesv`` for
``solve``, ``dpotrf`` for ``cholesky``, ``dgelsd`` for ``lstsq``, ``dgesdd`` for ``svd_u``), so
the same numbers to round-off (SciPy and NumPy bundle their own OpenBLAS builds, whose kernels
are chosen by CPU: the last bits may differ), without ``np.linalg``'s per-call checks, which cost 10-30 us each on
the few-by-few matrices here and dominated the projection steps. Matrix results are C-ordered as
NumPy's are (the memory order decides which BLAS kernel a later product uses, and so its last
bits). Failures raise ``np.linalg.LinAlgError`` as ``np.linalg`` does.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.linalg import lapack


def solve(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.linalg.solve(A, b)`` (LU with partial pivoting, ``dgesv``); a matrix ``b`` gives a
    C-ordered result as NumPy's does (the memory order decides which BLAS kernel a later product
    uses, and so its last bits)."""
    _, _, x, info = lapack.dgesv(A, b)
    if info > 0:
        raise np.linalg.LinAlgError("Singular matrix")
    if info < 0:
        raise ValueError(f"dgesv: illegal argument {-info}")
    return x if x.ndim == 1 else np.ascontiguousarray(x)


def cholesky(M: np.ndarray) -> np.ndarray:
    """``np.linalg.cholesky(M)``: the lower factor L (M = L L^T, ``dpotrf``), zeros above,
    C-ordered. Reads only the lower triangle of ``M``: the transpose of ``crba``'s mass matrix
    (whose upper triangle is set) is the symmetric matrix there."""
    L, info = lapack.dpotrf(M, lower=1, clean=1)
    if info > 0:
        raise np.linalg.LinAlgError("Matrix is not positive definite")
    if info < 0:
        raise ValueError(f"dpotrf: illegal argument {-info}")
    return np.ascontiguousarray(L)


@lru_cache(maxsize=64)
def _gelsd_work(m: int, n: int, rcond: float) -> tuple[int, int]:
    lwork, iwork, info = lapack.dgelsd_lwork(m, n, 1, rcond)
    if info != 0:
        raise ValueError(f"dgelsd_lwork: info {info}")
    return int(lwork), int(iwork)


def lstsq(A: np.ndarray, b: np.ndarray, rcond: float) -> np.ndarray:
    """``np.linalg.lstsq(A, b, rcond)[0]`` for a vector ``b``: the minimum-norm least-squares
    solution (SVD, singular values below ``rcond`` times the largest dropped; ``dgelsd``)."""
    m, n = A.shape
    lwork, iwork = _gelsd_work(m, n, float(rcond))
    if n > m:
        rhs = np.zeros(n)
        rhs[:m] = b
    else:
        rhs = b
    x, _, _, info = lapack.dgelsd(A, rhs, lwork, iwork, rcond)
    if info > 0:
        raise np.linalg.LinAlgError("SVD did not converge in Linear Least Squares")
    if info < 0:
        raise ValueError(f"dgelsd: illegal argument {-info}")
    return x[:n]


def svd_u(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``U, s`` of ``np.linalg.svd(A, full_matrices=False)`` (``dgesdd``): the left singular
    vectors (C-ordered, as NumPy's) and the singular values, largest first."""
    u, s, _, info = lapack.dgesdd(A, compute_uv=1, full_matrices=0)
    if info > 0:
        raise np.linalg.LinAlgError("SVD did not converge")
    if info < 0:
        raise ValueError(f"dgesdd: illegal argument {-info}")
    return np.ascontiguousarray(u), s


def symmetric_from_upper(M: np.ndarray) -> np.ndarray:
    """``M`` (``crba``'s mass matrix: the upper triangle is set) with its strictly lower triangle
    filled from the upper one, in place: ``np.triu(M) + np.triu(M, 1).T`` without temporaries."""
    il = _lower_indices(M.shape[0])
    M[il] = M.T[il]
    return M


@lru_cache(maxsize=64)
def _lower_indices(n: int):
    return np.tril_indices(n, -1)
