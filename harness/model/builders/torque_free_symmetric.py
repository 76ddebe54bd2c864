"""torque_free_symmetric: one free symmetric body (I1 = I2 transverse, I3 axial), no gravity."""

from __future__ import annotations

from harness.model.multibody import Multibody
from harness.model.builders import torque_free


def build(params: dict) -> Multibody:
    """The torque_free body with I2 = I1 (body z is the symmetry axis)."""
    return torque_free.build({**params, "I2": params["I1"]})
