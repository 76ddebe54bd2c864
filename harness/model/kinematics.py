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

    Joint conventions are those of ``harness.model.multibody``.
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
        if body.joint == "free":
            p_WB = qb[:3]
            R_WB = rotations.matrix(qb[3:7] / np.linalg.norm(qb[3:7]))
            v_WB = vb[:3]
            w_WB = R_WB @ vb[3:6]
        else:
            p_WB = p_WP + R_WP @ body.p_PB_P
            v_WB = v_WP + np.cross(w_WP, R_WP @ body.p_PB_P)
            if body.joint == "ball":
                R_PB = rotations.matrix(qb / np.linalg.norm(qb))
                R_WB = R_WP @ R_PB
                w_WB = w_WP + R_WB @ vb
            elif body.joint == "hinge":
                R_PB = rotations.matrix(rotations.from_axis_angle(body.axis_B, qb[0]))
                R_WB = R_WP @ R_PB
                w_WB = w_WP + R_WB @ (body.axis_B * vb[0])
            elif body.joint == "slide":
                p_PB_W = R_WP @ (body.p_PB_P + body.axis_B * qb[0])
                p_WB = p_WP + p_PB_W
                v_WB = v_WP + np.cross(w_WP, p_PB_W) + R_WP @ (body.axis_B * vb[0])
                R_WB = R_WP
                w_WB = w_WP
            else:  # pragma: no cover - guarded when the model is built
                raise ValueError(f"unknown joint type {body.joint!r}")
        frames[body.name] = (p_WB, R_WB, v_WB, w_WB)
        r_W = R_WB @ body.p_BCm_B
        out[body.name] = BodyState(
            p_WCm_W=p_WB + r_W,
            quat_WB=rotations.from_matrix(R_WB),
            v_WCm_W=v_WB + np.cross(w_WB, r_W),
            w_WB_W=w_WB,
        )
    return out
