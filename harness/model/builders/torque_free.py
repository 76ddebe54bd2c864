"""torque_free: one free rigid body, principal axes along body x, y, z, no gravity (§4.7)."""

from __future__ import annotations

import numpy as np

from harness.model.multibody import Body, Multibody


def build(params: dict) -> Multibody:
    """Body frame at the centre of mass; starts at the origin, identity orientation, at rest
    translationally, spinning with ``omega0`` (rad/s, body frame)."""
    body = Body(
        name="body",
        parent=None,
        joint="free",
        p_PB_P=np.zeros(3),
        axis_B=np.zeros(3),
        mass=float(params["mass"]),
        p_BCm_B=np.zeros(3),
        I_Cm_B=np.diag([params["I1"], params["I2"], params["I3"]]).astype(float),
    )
    q0 = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0])
    v0 = np.concatenate([np.zeros(3), np.asarray(params["omega0"], dtype=float)])
    return Multibody(bodies=(body,), gravity_W=np.zeros(3), q0={"body": q0}, v0={"body": v0})
