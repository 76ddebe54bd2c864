"""torque_free_symmetric: one free symmetric body (I1 = I2 transverse, I3 axial), no gravity."""

from __future__ import annotations

from harness.multibody import Multibody
from harness.systems import torque_free


def build(params: dict) -> Multibody:
    """The torque_free body with I2 = I1 (body z is the symmetry axis)."""
    return torque_free.build({**params, "I2": params["I1"]})
