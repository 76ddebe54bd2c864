"""spring_pendulum: a particle on a spring swinging in a vertical plane (Ex. 5.3.1), gravity -g z.

Two joints carry the particle's two degrees of freedom (r, theta), one per body as
``harness.model.multibody`` requires: a light ``hub`` turns on a hinge at the pivot (theta), and the
``bob`` slides along the hub's -z axis (r = its distance from the pivot), with the spring on that
slide joint. The hub is a small sphere centred on the pivot: it adds only its tiny moment of
inertia to the swing and nothing to gravity; the bob is a small solid sphere that turns with the
hub. ``harness.references.spring_pendulum`` includes both inertias (J); the textbook is J = 0.
"""

from __future__ import annotations

import numpy as np

from harness.model.multibody import Body, JointSpring, Multibody

HINGE_AXIS = np.array([0.0, -1.0, 0.0])  # positive theta swings the bob toward +x
SLIDE_AXIS = np.array([0.0, 0.0, -1.0])  # r measured from the pivot, down the hub's axis


def sphere_inertia(m: float, radius: float) -> np.ndarray:
    """Solid sphere about its centre (kg m^2)."""
    return np.eye(3) * 0.4 * m * radius * radius


def swing_inertia(params: dict) -> float:
    """J = I_bob + I_hub about the swing axis (kg m^2), what the point-mass textbook omits."""
    return float(0.4 * params["m"] * params["rb"] ** 2 + 0.4 * params["m_hub"] * params["r_hub"] ** 2)


def build(params: dict) -> Multibody:
    """Hub frame at the pivot (hinge angle = theta from the downward vertical); bob frame at its
    centre, at distance q = r from the pivot along the hub's -z; spring k (N/m) relaxed at
    r = L on the slide joint."""
    m, k, L = float(params["m"]), float(params["k"]), float(params["L"])
    hub = Body("hub", None, "hinge", np.zeros(3), HINGE_AXIS, float(params["m_hub"]), np.zeros(3),
               sphere_inertia(float(params["m_hub"]), float(params["r_hub"])))
    bob = Body("bob", "hub", "slide", np.zeros(3), SLIDE_AXIS, m, np.zeros(3), sphere_inertia(m, float(params["rb"])))
    q0 = {"hub": np.array([float(params["theta0"])]), "bob": np.array([float(params["r0"])])}
    v0 = {"hub": np.array([float(params["dtheta0"])]), "bob": np.array([float(params["dr0"])])}
    gravity = np.array([0.0, 0.0, -float(params["g"])])
    return Multibody(bodies=(hub, bob), gravity_W=gravity, q0=q0, v0=v0, springs=(JointSpring("bob", k, L),))
