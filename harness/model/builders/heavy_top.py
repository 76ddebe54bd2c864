"""heavy_top: symmetric top, tip fixed at the world origin by a ball joint, gravity -g z."""

from __future__ import annotations

import numpy as np

from harness.model import rotations
from harness.model.multibody import Body, Multibody


def build(params: dict) -> Multibody:
    """Body frame at the tip, body z along the symmetry axis, centre of mass at (0, 0, l).

    Initial orientation: rotation by ``theta0`` about world +y (tilts body z toward world +x).
    Initial angular velocity ``omega0`` in the body frame.
    """
    I1, I3 = float(params["I1"]), float(params["I3"])
    top = Body(
        name="top",
        parent=None,
        joint="ball",
        p_PB_P=np.zeros(3),
        axis_B=np.zeros(3),
        mass=float(params["mass"]),
        p_BCm_B=np.array([0.0, 0.0, float(params["l"])]),
        I_Cm_B=np.diag([I1, I1, I3]),
    )
    q0 = rotations.from_axis_angle(np.array([0.0, 1.0, 0.0]), float(params["theta0"]))
    v0 = np.asarray(params["omega0"], dtype=float)
    gravity = np.array([0.0, 0.0, -float(params["g"])])
    return Multibody(bodies=(top,), gravity_W=gravity, q0={"top": q0}, v0={"top": v0})
