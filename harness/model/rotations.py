"""Unit quaternions and rotations: the one place where quaternion order is converted.

The harness stores quaternions scalar-first (``wxyz``, as MuJoCo does). Pinocchio and
``scipy.spatial.transform.Rotation`` (by default) use scalar-last (``xyzw``): convert with
``wxyz_to_xyzw`` / ``xyzw_to_wxyz`` and nowhere else.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation


def wxyz_to_xyzw(q: np.ndarray) -> np.ndarray:
    """Reorder quaternion(s) ``[..., 4]`` from scalar-first to scalar-last."""
    q = np.asarray(q, dtype=float)
    return np.concatenate([q[..., 1:], q[..., :1]], axis=-1)


def xyzw_to_wxyz(q: np.ndarray) -> np.ndarray:
    """Reorder quaternion(s) ``[..., 4]`` from scalar-last to scalar-first."""
    q = np.asarray(q, dtype=float)
    return np.concatenate([q[..., 3:], q[..., :3]], axis=-1)


def matrix(q_wxyz: np.ndarray) -> np.ndarray:
    """Rotation matrix (or stack ``[..., 3, 3]``) of unit quaternion(s) in ``wxyz`` order."""
    q = np.asarray(q_wxyz, dtype=float)
    return Rotation.from_quat(wxyz_to_xyzw(q)).as_matrix()


def from_matrix(R: np.ndarray) -> np.ndarray:
    """Unit quaternion(s) ``wxyz`` of rotation matrix (or stack), with non-negative w."""
    q = xyzw_to_wxyz(Rotation.from_matrix(R).as_quat())
    return canonical(q)


def principal_frame(I: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(moments, R)``: the principal moments (ascending) of the symmetric inertia ``I`` and a
    proper rotation whose columns are its principal axes, in ``I``'s frame (``eigh``, the third
    axis flipped where the eigenvectors come out left-handed)."""
    moments, R = np.linalg.eigh(np.asarray(I, dtype=float))
    if np.linalg.det(R) < 0:
        R[:, 2] = -R[:, 2]
    return moments, R


def from_axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    """Quaternion ``wxyz`` of a rotation by ``angle`` (rad) about ``axis`` (normalized here)."""
    axis = np.asarray(axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    return xyzw_to_wxyz(Rotation.from_rotvec(axis * angle).as_quat())


def canonical(q_wxyz: np.ndarray) -> np.ndarray:
    """Flip sign so that w >= 0 (q and -q are the same rotation)."""
    q = np.array(q_wxyz, dtype=float)
    sign = np.where(q[..., :1] < 0.0, -1.0, 1.0)
    return q * sign


def multiply(a_wxyz: np.ndarray, b_wxyz: np.ndarray) -> np.ndarray:
    """Hamilton product ``a * b`` of quaternions (broadcasting over leading axes)."""
    a = np.asarray(a_wxyz, dtype=float)
    b = np.asarray(b_wxyz, dtype=float)
    aw, av = a[..., :1], a[..., 1:]
    bw, bv = b[..., :1], b[..., 1:]
    w = aw * bw - np.sum(av * bv, axis=-1, keepdims=True)
    v = aw * bv + bw * av + np.cross(av, bv)
    return np.concatenate([w, v], axis=-1)


def geodesic_angle(a_wxyz: np.ndarray, b_wxyz: np.ndarray) -> np.ndarray:
    """Angle (rad, in [0, pi]) of the rotation taking ``a`` to ``b``: the distance on SO(3).

    Independent of the sign of either quaternion. Computed with ``atan2`` so that it stays
    accurate for tiny angles (``arccos`` of a dot product loses half the digits there).
    """
    a = np.asarray(a_wxyz, dtype=float)
    b = np.asarray(b_wxyz, dtype=float)
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    b = b / np.linalg.norm(b, axis=-1, keepdims=True)
    conj_a = a * np.array([1.0, -1.0, -1.0, -1.0])
    d = multiply(conj_a, b)
    return 2.0 * np.arctan2(np.linalg.norm(d[..., 1:], axis=-1), np.abs(d[..., 0]))


def xz_plane_angle(q_wxyz: np.ndarray) -> np.ndarray:
    """Angle (rad) of a body's +x axis in the world x-z plane, from +x toward +z: the rotation
    about world -y of a body that turns in that plane (``atan2(R_zx, R_xx)``); one per quaternion
    ``wxyz`` (body -> world) of a stack."""
    R = matrix(q_wxyz)
    return np.arctan2(R[..., 2, 0], R[..., 0, 0])


def wrap_angle(x: np.ndarray) -> np.ndarray:
    """Angles (rad) wrapped into (-pi, pi]: the difference of two angles as the shortest turn."""
    return np.angle(np.exp(1j * np.asarray(x, dtype=float)))


def skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrix ``[v]x`` so that ``skew(v) @ u == cross(v, u)``."""
    x, y, z = v
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


_NEXT, _AFTER = [1, 2, 0], [2, 0, 1]


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a x b`` of two 3-vectors, or of stacks ``[..., 3]`` (leading axes broadcast): the same
    products and differences as ``np.cross`` (the same numbers), without its axis handling,
    which costs ~20 us a call, more than the product at these sizes: the form for loops over
    samples and right-hand sides. Single vectors are multiplied as Python floats."""
    a, b = np.asarray(a), np.asarray(b)
    if a.ndim == 1 and b.ndim == 1:
        a0, a1, a2 = a.tolist()
        b0, b1, b2 = b.tolist()
        return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])
    return a[..., _NEXT] * b[..., _AFTER] - a[..., _AFTER] * b[..., _NEXT]
