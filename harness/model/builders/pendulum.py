"""pendulum: IFToMM benchmark A01, the simple pendulum -- a small uniform sphere (the lumped
mass) on a massless rod, hinged at the origin, swinging in the world x-z plane, gravity -g z."""

from __future__ import annotations

import numpy as np

from harness.model.multibody import Body, Multibody

# Hinge axis -y: a positive angle swings the hanging bob toward +x (as in plate_pendulum).
AXIS_B = np.array([0.0, -1.0, 0.0])


def sphere_inertia(m: float, r: float) -> np.ndarray:
    """Inertia (kg m^2) of a uniform solid sphere of mass m (kg) and radius r (m) about its
    centre: (2/5) m r^2 on every axis."""
    return np.eye(3) * (0.4 * m * r * r)


def build(params: dict) -> Multibody:
    """Body frame at the pivot, parallel to the world at zero hinge angle; the sphere's centre
    (the benchmark's point P1) at (0, 0, -L), hanging. ``theta0`` is the initial angle of the
    rod from the downward vertical (rad, positive toward +x: pi/2 is A01's horizontal release
    with P1 at x = +L), ``dtheta0`` its rate (rad/s)."""
    m, L, r = (float(params[k]) for k in ("m", "L", "r"))
    bob = Body("bob", None, "hinge", np.zeros(3), AXIS_B, m, np.array([0.0, 0.0, -L]), sphere_inertia(m, r))
    q0 = {"bob": np.array([float(params["theta0"])])}
    v0 = {"bob": np.array([float(params["dtheta0"])])}
    gravity = np.array([0.0, 0.0, -float(params["g"])])
    return Multibody(bodies=(bob,), gravity_W=gravity, q0=q0, v0=v0)
