"""plate_pendulum: a uniform rectangular plate (sides 2a, 2b, thickness h) pivoting about a
corner on a horizontal hinge perpendicular to the plate (Ex. 4.5.1, 4.5.2), gravity -g z."""

from __future__ import annotations

import numpy as np

from harness.model.multibody import Body, Multibody

# Hinge axis -y: a positive angle swings a hanging point toward +x (as in double_pendulum).
AXIS_B = np.array([0.0, -1.0, 0.0])


def plate_inertia(m: float, a: float, b: float, h: float) -> np.ndarray:
    """Inertia (kg m^2) about the centre of a box with sides 2a (body x), h (body y), 2b
    (body z): the plate lies in the body x-z plane."""
    return np.diag([m * (h * h + 4.0 * b * b) / 12.0, m * (a * a + b * b) / 3.0, m * (4.0 * a * a + h * h) / 12.0])


def build(params: dict) -> Multibody:
    """Body frame at the pivot corner, the plate spanning x in [0, 2a], z in [-2b, 0] at zero
    hinge angle (the side of length 2a horizontal through the pivot, the textbook's release
    position); centre of mass at (a, 0, -b). ``theta0`` is the initial hinge angle from that
    position (rad), ``dtheta0`` its rate (rad/s)."""
    m, a, b, h = (float(params[k]) for k in ("m", "a", "b", "h"))
    plate = Body("plate", None, "hinge", np.zeros(3), AXIS_B, m, np.array([a, 0.0, -b]), plate_inertia(m, a, b, h))
    q0 = {"plate": np.array([float(params["theta0"])])}
    v0 = {"plate": np.array([float(params["dtheta0"])])}
    gravity = np.array([0.0, 0.0, -float(params["g"])])
    return Multibody(bodies=(plate,), gravity_W=gravity, q0=q0, v0=v0)
