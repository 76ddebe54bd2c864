"""Batched small-vector algebra for the in-house engine: cross products, skew matrices,
quaternion -> rotation matrix and quaternion rates, for stacks of 3-vectors / quaternions.

Every map here is bilinear (or quadratic) in its arguments, so it is written as an outer
product followed by one matrix product with a constant coefficient table. For the tiny stacks
of this harness (1-4 rows) that is several times faster than ``np.cross`` or per-entry
assembly, and it broadcasts over any leading axes. Quaternions are ``wxyz`` (scalar first), as
everywhere in the harness; angular velocities here are whatever frame the caller passes.
"""

from __future__ import annotations

import numpy as np

from harness.model import rotations

# Levi-Civita symbol eps[i, j, k].
_EPS = np.zeros((3, 3, 3))
_EPS[0, 1, 2] = _EPS[1, 2, 0] = _EPS[2, 0, 1] = 1.0
_EPS[0, 2, 1] = _EPS[2, 1, 0] = _EPS[1, 0, 2] = -1.0

# (a x b)_i = eps_ijk a_j b_k: rows indexed by (j, k) flattened, columns by i.
_CROSS = np.ascontiguousarray(np.transpose(_EPS, (1, 2, 0)).reshape(9, 3))
# [a]x_{il} = eps_ijl a_j: rows indexed by j, columns by (i, l) flattened.
_SKEW = np.ascontiguousarray(np.transpose(_EPS, (1, 0, 2)).reshape(3, 9))

# Rotation matrix of a unit quaternion (w, x, y, z) as a quadratic form:
# R_ij = sum_ab Q[a*4 + b, i*3 + j] q_a q_b.
_W, _X, _Y, _Z = range(4)
_R_TERMS = {
    (0, 0): ((_W, _W, 1.0), (_X, _X, 1.0), (_Y, _Y, -1.0), (_Z, _Z, -1.0)),
    (0, 1): ((_X, _Y, 2.0), (_W, _Z, -2.0)),
    (0, 2): ((_X, _Z, 2.0), (_W, _Y, 2.0)),
    (1, 0): ((_X, _Y, 2.0), (_W, _Z, 2.0)),
    (1, 1): ((_W, _W, 1.0), (_X, _X, -1.0), (_Y, _Y, 1.0), (_Z, _Z, -1.0)),
    (1, 2): ((_Y, _Z, 2.0), (_W, _X, -2.0)),
    (2, 0): ((_X, _Z, 2.0), (_W, _Y, -2.0)),
    (2, 1): ((_Y, _Z, 2.0), (_W, _X, 2.0)),
    (2, 2): ((_W, _W, 1.0), (_X, _X, -1.0), (_Y, _Y, -1.0), (_Z, _Z, 1.0)),
}
_QUAT_MATRIX = np.zeros((16, 9))
for (_i, _j), _terms in _R_TERMS.items():
    for _a, _b, _coef in _terms:
        _QUAT_MATRIX[_a * 4 + _b, _i * 3 + _j] += _coef

# Quaternion rate qdot = 1/2 q (x) (0, w): bilinear in (q, w), rows indexed by (a, c) flattened,
# built from the harness's one Hamilton product so that the convention cannot diverge.
_QUAT_RATE = np.zeros((12, 4))
for _a in range(4):
    for _c in range(3):
        _e = np.zeros(4)
        _e[_a] = 1.0
        _pure = np.zeros(4)
        _pure[1 + _c] = 1.0
        _QUAT_RATE[_a * 3 + _c] = 0.5 * rotations.multiply(_e, _pure)


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a x b`` for stacks ``[..., 3]`` (leading axes broadcast)."""
    outer = a[..., :, None] * b[..., None, :]
    return outer.reshape(outer.shape[:-2] + (9,)) @ _CROSS


def skew(a: np.ndarray) -> np.ndarray:
    """Cross-product matrices ``[a]x`` of a stack ``[..., 3]`` -> ``[..., 3, 3]``."""
    return (a @ _SKEW).reshape(a.shape[:-1] + (3, 3))


def quat_matrix(q_wxyz: np.ndarray) -> np.ndarray:
    """Rotation matrices ``[..., 3, 3]`` of unit quaternions ``[..., 4]`` (wxyz, body -> world).

    The quaternions must already be normalised (the quadratic form is exact only then).
    """
    outer = q_wxyz[..., :, None] * q_wxyz[..., None, :]
    return (outer.reshape(outer.shape[:-2] + (16,)) @ _QUAT_MATRIX).reshape(q_wxyz.shape[:-1] + (3, 3))


def quat_rate(q_wxyz: np.ndarray, w_B: np.ndarray) -> np.ndarray:
    """Quaternion derivative ``1/2 q (x) (0, w_B)`` (1/s) for body-frame angular velocity ``w_B``
    (rad/s); stacks ``[..., 4]`` and ``[..., 3]``."""
    outer = q_wxyz[..., :, None] * w_B[..., None, :]
    return outer.reshape(outer.shape[:-2] + (12,)) @ _QUAT_RATE


def normalized(q: np.ndarray) -> np.ndarray:
    """Quaternions ``[..., 4]`` divided by their norm."""
    return q / np.sqrt((q * q) @ _ONES4)[..., None]


_ONES4 = np.ones(4)
