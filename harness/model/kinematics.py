"""Forward kinematics of a ``Multibody`` from joint coordinates to maximal coordinates.

Maximal coordinates of body B (all world frame W):
    p_WCm_W  centre-of-mass position (m)
    quat_WB  orientation, body to world, ``wxyz``
    v_WCm_W  centre-of-mass velocity (m/s)
    w_WB_W   angular velocity (rad/s)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from harness.model import rotations
from harness.model.joints import JOINTS
from harness.model.multibody import Multibody


@dataclass(frozen=True)
class BodyState:
    """Maximal-coordinate state of one body (see module docstring for frames and units)."""

    p_WCm_W: np.ndarray
    quat_WB: np.ndarray
    v_WCm_W: np.ndarray
    w_WB_W: np.ndarray


def forward(model: Multibody, q: dict[str, np.ndarray], v: dict[str, np.ndarray]) -> dict[str, BodyState]:
    """Maximal-coordinate state of every body from joint coordinates ``q``, ``v`` (per body name).

    Joint conventions and each joint's relative motion are those of ``harness.model.joints``.
    """
    # Per body: origin position, rotation, origin velocity, angular velocity (all world).
    frames: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = {}
    out: dict[str, BodyState] = {}
    for body in model.bodies:
        qb = np.asarray(q[body.name], dtype=float)
        vb = np.asarray(v[body.name], dtype=float)
        if body.parent is None:
            p_WP, R_WP, v_WP, w_WP = np.zeros(3), np.eye(3), np.zeros(3), np.zeros(3)
        else:
            p_WP, R_WP, v_WP, w_WP = frames[body.parent]
        # The joint's relative motion (``harness.model.joints``), composed with the parent's.
        p_rel, R_PB, v_rel, w_rel = JOINTS[body.joint].motion(body, qb, vb)
        p_PB_W = R_WP @ p_rel
        p_WB = p_WP + p_PB_W
        v_WB = v_WP + np.cross(w_WP, p_PB_W)
        if v_rel is not None:
            v_WB = v_WB + R_WP @ v_rel
        R_WB = R_WP if R_PB is None else R_WP @ R_PB
        w_WB = w_WP if w_rel is None else w_WP + R_WB @ w_rel
        frames[body.name] = (p_WB, R_WB, v_WB, w_WB)
        r_W = R_WB @ body.p_BCm_B
        out[body.name] = BodyState(
            p_WCm_W=p_WB + r_W,
            quat_WB=rotations.from_matrix(R_WB),
            v_WCm_W=v_WB + np.cross(w_WB, r_W),
            w_WB_W=w_WB,
        )
    return out


def circle_intersection(c1: np.ndarray, r1: float, c2: np.ndarray, r2: float, side: float) -> np.ndarray | None:
    """The intersection of two circles in a plane, the circle about ``c1`` (2,) of radius ``r1``
    and the one about ``c2`` of radius ``r2`` (m), on ``side``: the sign of the cross product
    (c2 - c1) x (point - c1) (+1: left of the directed line c1 -> c2). None when they do not
    intersect in two points (|c2 - c1| outside (|r1 - r2|, r1 + r2)). A linkage's builder
    assembles its loop with it."""
    u = np.asarray(c2, float) - np.asarray(c1, float)
    L = float(np.hypot(*u))
    if not (abs(r1 - r2) < L < r1 + r2):
        return None
    s = (r1 * r1 - r2 * r2 + L * L) / (2.0 * L)
    h = np.sqrt(max(r1 * r1 - s * s, 0.0))
    uh = u / L
    return np.asarray(c1, float) + s * uh + float(np.sign(side)) * h * np.array([-uh[1], uh[0]])
