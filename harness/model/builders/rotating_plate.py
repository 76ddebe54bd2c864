"""rotating_plate: a plate turning at constant rate about a fixed vertical axis through its centre
of mass, at an angle phi to its normal (Ex. 4.6.1); the bearings' couple is the quantity."""

from __future__ import annotations

import numpy as np

from harness.model.multibody import Body, Multibody

AXIS_B = np.array([0.0, 0.0, 1.0])  # the vertical rotation axis


def tilt(phi: float) -> np.ndarray:
    """R_BP: the plate's principal frame P in the body frame B (B's z = the axis): a rotation by
    -phi about y, so that the axis is sin(phi) e_xP + cos(phi) e_zP in P."""
    c, s = np.cos(phi), np.sin(phi)
    return np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])


def plate_inertia_B(m: float, a: float, h: float, phi: float) -> np.ndarray:
    """Inertia about the centre in B (kg m^2): principal m(a^2+h^2)/12, m(4a^2+h^2)/12, 5ma^2/12
    for sides 2a (x_P), a (y_P), thickness h (z_P), rotated by ``tilt(phi)``."""
    R = tilt(phi)
    I_P = m / 12.0 * np.diag([a * a + h * h, 4.0 * a * a + h * h, 5.0 * a * a])
    return R @ I_P @ R.T


def build(params: dict) -> Multibody:
    """Body frame at the centre of mass on the axis (the hinge point), z along the axis, parallel
    to the world at zero angle; spinning at ``omega`` from the start."""
    m, a, h, phi = (float(params[k]) for k in ("m", "a", "h", "phi"))
    plate = Body("plate", None, "hinge", np.zeros(3), AXIS_B, m, np.zeros(3), plate_inertia_B(m, a, h, phi))
    gravity = np.array([0.0, 0.0, -float(params["g"])])
    return Multibody(bodies=(plate,), gravity_W=gravity, q0={"plate": np.array([0.0])},
                     v0={"plate": np.array([float(params["omega"])])})
