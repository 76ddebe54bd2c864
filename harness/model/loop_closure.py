"""How far a state is from closing its kinematic loops (``harness.model.multibody.LoopJoint``), in
maximal coordinates: the one definition that the scene checks (``harness.model.sanity``, at the
initial state), ``validate`` and the loop study (``harness.measure.compare.loop_closure``) use.

For a cut joint between bodies A and B (B may be the world), with each end's joint point
``x = p_WCm_W + R_WB (p - p_BCm_B)`` (m, world) and its velocity ``v_WCm_W + w_WB_W x (x - p_WCm_W)``
(m/s, world):

* ``position`` (m): |x_A - x_B|, the gap of the cut point;
* ``velocity`` (m/s): |v_A - v_B|, the relative velocity of the two material points there;
* for a hinge, ``axis`` (rad): the angle between the axis carried by A and by B, and
  ``axis_rate`` (rad/s): the component of the relative angular velocity w_A - w_B perpendicular
  to the axis (a hinge lets the bodies turn about its axis only).

Arrays carry any leading shape (samples), the last axis the 3 components.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from harness.model import kinematics, rotations
from harness.model.joints import keeps_axis
from harness.model.multibody import LoopJoint, Multibody


@dataclass(frozen=True)
class End:
    """One end of a cut joint in world: joint point (m), its velocity (m/s), the hinge axis (unit)
    and the body's angular velocity (rad/s), each (..., 3)."""

    x: np.ndarray
    v: np.ndarray
    axis: np.ndarray
    w: np.ndarray


def end(p_WCm_W, R_WB, v_WCm_W, w_WB_W, p_BCm_B, p_B, axis_B) -> End:
    """The world end of a body point ``p_B`` (body frame, m) and body axis ``axis_B``, for a body
    with centre of mass ``p_BCm_B`` (body frame) at the given world state (leading shapes alike)."""
    r = np.einsum("...ij,j->...i", R_WB, np.asarray(p_B, float) - np.asarray(p_BCm_B, float))
    a = np.einsum("...ij,j->...i", R_WB, np.asarray(axis_B, float) / np.linalg.norm(axis_B))
    return End(p_WCm_W + r, v_WCm_W + np.cross(w_WB_W, r), a, w_WB_W)


def world_end(p_W, axis_W, shape: tuple[int, ...]) -> End:
    """An end fixed in the world: point ``p_W`` (m), axis ``axis_W``, at rest, broadcast to
    ``shape + (3,)``."""
    x = np.broadcast_to(np.asarray(p_W, float), shape + (3,))
    a = np.broadcast_to(np.asarray(axis_W, float) / np.linalg.norm(axis_W), shape + (3,))
    zero = np.zeros(shape + (3,))
    return End(x, zero, a, zero)


def residuals(loop: LoopJoint, a: End, b: End) -> dict[str, np.ndarray]:
    """The closure residuals of ``loop`` between its ends ``a`` (body_a) and ``b`` (body_b or the
    world): ``position`` (m), ``velocity`` (m/s) and, for a hinge, ``axis`` (rad) and ``axis_rate``
    (rad/s); each of the ends' leading shape (module docstring)."""
    out = {"position": np.linalg.norm(a.x - b.x, axis=-1), "velocity": np.linalg.norm(a.v - b.v, axis=-1)}
    if keeps_axis(loop.kind):
        s = np.linalg.norm(np.cross(a.axis, b.axis), axis=-1)
        c = np.einsum("...i,...i->...", a.axis, b.axis)
        out["axis"] = np.arctan2(s, c)
        dw = a.w - b.w
        out["axis_rate"] = np.linalg.norm(dw - np.einsum("...i,...i->...", dw, b.axis)[..., None] * b.axis, axis=-1)
    return out


def initial_residuals(model: Multibody) -> dict[str, dict[str, float]]:
    """Per cut joint, the largest residual of each kind (``residuals``) at the model's initial
    state ``q0, v0`` (forward kinematics of the tree)."""
    states = kinematics.forward(model, model.q0, model.v0)
    out = {}
    for loop in model.loops:
        ends = []
        for body, p, axis in ((loop.body_a, loop.p_A, loop.axis_A), (loop.body_b, loop.p_B, loop.axis_B)):
            if body is None:
                ends.append(world_end(p, axis, ()))
                continue
            st = states[body]
            R = rotations.matrix(np.asarray(st.quat_WB, float)).reshape(3, 3)
            ends.append(end(st.p_WCm_W, R, st.v_WCm_W, st.w_WB_W, model.body(body).p_BCm_B, p, axis))
        out[loop.name] = {k: float(v) for k, v in residuals(loop, *ends).items()}
    return out
