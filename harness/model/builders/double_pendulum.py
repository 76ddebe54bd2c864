"""double_pendulum: two equal uniform bars (solid cylinders) hinged at the origin and at the
pin between them, swinging in the world x-z plane, gravity -g z, optional force at the pin."""

from __future__ import annotations

import numpy as np

from harness.model.multibody import Body, Multibody, PointForce

# Hinge axis -y: a positive angle swings the lower end of a hanging bar toward +x.
AXIS_B = np.array([0.0, -1.0, 0.0])


def bar_inertia(m: float, L: float, r: float) -> np.ndarray:
    """Inertia (kg m^2) of a solid cylinder about its centre, body z along its axis."""
    transverse = m * (3.0 * r**2 + L**2) / 12.0
    return np.diag([transverse, transverse, 0.5 * m * r**2])


def build(params: dict) -> Multibody:
    """Body frames at the hinges, bars hanging along body -z, centres of mass at (0, 0, -L/2).

    Joint angles are relative (bar2 relative to bar1); the textbook's absolute angles map as
    q_bar1 = theta, q_bar2 = phi - theta.
    """
    m, L, r = float(params["m"]), float(params["L"]), float(params["r"])
    I = bar_inertia(m, L, r)
    com = np.array([0.0, 0.0, -0.5 * L])
    bar1 = Body("bar1", None, "hinge", np.zeros(3), AXIS_B, m, com, I)
    bar2 = Body("bar2", "bar1", "hinge", np.array([0.0, 0.0, -L]), AXIS_B, m, com, I)
    theta0, phi0 = float(params["theta0"]), float(params["phi0"])
    dtheta0, dphi0 = float(params["dtheta0"]), float(params["dphi0"])
    q0 = {"bar1": np.array([theta0]), "bar2": np.array([phi0 - theta0])}
    v0 = {"bar1": np.array([dtheta0]), "bar2": np.array([dphi0 - dtheta0])}
    F0, omega_f = float(params["F0"]), float(params["omega_f"])
    forces: tuple[PointForce, ...] = ()
    if F0 != 0.0:
        forces = (PointForce.harmonic("bar1", np.array([0.0, 0.0, -L]), np.zeros(3), f_cos_W=np.array([F0, 0.0, 0.0]),
                                      omega=omega_f, name="pin"),)  # F0 cos(omega_f t) along world x
    gravity = np.array([0.0, 0.0, -float(params["g"])])
    return Multibody(bodies=(bar1, bar2), gravity_W=gravity, q0=q0, v0=v0, forces=forces)
