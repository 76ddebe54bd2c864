"""cart_pendulum: a cart on a frictionless horizontal rail (slide joint along world x) carrying
a pendulum (hinge) that swings in the x-z plane, gravity -g z (Ex. 1.2.2, 1.3.1, 1.5.1, 1.6.1)."""

from __future__ import annotations

import numpy as np

from harness.model.multibody import Body, Multibody

RAIL_AXIS = np.array([1.0, 0.0, 0.0])
# Hinge axis -y: a positive angle swings the bob toward +x (the textbook's theta of Ex. 1.2.2).
HINGE_AXIS = np.array([0.0, -1.0, 0.0])


def cart_inertia(M: float, w: float, d: float, h: float) -> np.ndarray:
    """Inertia (kg m^2) of a box cart of sides w (x), d (y), h (z) about its centre (it never
    rotates, so only its mass enters the dynamics)."""
    return M / 12.0 * np.diag([d * d + h * h, w * w + h * h, w * w + d * d])


def bob_inertia(m: float, r: float) -> np.ndarray:
    """Solid sphere of radius r about its centre (kg m^2): the textbook's particle is r -> 0."""
    return np.eye(3) * 0.4 * m * r * r


def build(params: dict) -> Multibody:
    """The cart's frame origin is its centre of mass and the pivot, on the rail (world z = 0);
    q_cart = X. The pendulum's frame is at the pivot, the bob's centre at (0, 0, -L);
    q_pendulum = theta."""
    M, m, L, r = (float(params[k]) for k in ("M", "m", "L", "r"))
    cart = Body("cart", None, "slide", np.zeros(3), RAIL_AXIS, M, np.zeros(3), cart_inertia(M, 0.4, 0.2, 0.1))
    pendulum = Body("pendulum", "cart", "hinge", np.zeros(3), HINGE_AXIS, m, np.array([0.0, 0.0, -L]), bob_inertia(m, r))
    q0 = {"cart": np.array([float(params["X0"])]), "pendulum": np.array([float(params["theta0"])])}
    v0 = {"cart": np.array([float(params["dX0"])]), "pendulum": np.array([float(params["dtheta0"])])}
    gravity = np.array([0.0, 0.0, -float(params["g"])])
    return Multibody(bodies=(cart, pendulum), gravity_W=gravity, q0=q0, v0=v0)
