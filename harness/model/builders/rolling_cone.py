"""rolling_cone: a uniform solid cone rolling without slip on the horizontal plane z = 0, its apex
held at the world origin (a ball joint on the plane), its base rim touching the plane, gravity
-g z (Boström Ex. 3.4.1 and Ex. 4.7.1).

The cone has height L (apex to the centre A of the base) and half apex angle beta: base radius
R = L tan(beta). "A slightly concave surface" (the textbook's assumption) makes it touch the
plane only at the apex and at the lowest point of its base rim, so the generator through that
point lies on the plane and the axis rises from the plane at the angle beta.
"""

from __future__ import annotations

import numpy as np

from harness.model import rotations
from harness.model.errors import InputError
from harness.model.multibody import Body, Multibody, RollingContact


def base_radius(L: float, beta: float) -> float:
    """R = L tan(beta) (m): the radius of the base of a cone of height L (m) and half apex angle
    beta (rad)."""
    return L * np.tan(beta)


def cone_inertia(m: float, L: float, beta: float) -> np.ndarray:
    """Solid uniform cone of mass m (kg), height L (m), half apex angle beta (rad), about its centre
    of mass (on the axis at 3L/4 from the apex), body z along the axis (kg m^2): axial
    3 m R^2 / 10, transverse 3 m R^2 / 20 + 3 m L^2 / 80 (about the apex: 3 m R^2 / 20 + 3 m L^2 / 5)."""
    R = base_radius(L, beta)
    transverse = 3.0 * m * R * R / 20.0 + 3.0 * m * L * L / 80.0
    return np.diag([transverse, transverse, 0.3 * m * R * R])


def initial_orientation(beta: float, phi0: float) -> np.ndarray:
    """R_WB (3x3) with the contact generator along world (cos phi0, sin phi0, 0) and the axis (body
    z) rising from it at the angle beta: a rotation by pi/2 - beta about world y (body z to
    (cos beta, 0, sin beta)), then by phi0 about world z."""
    return rotations.matrix(rotations.from_axis_angle(np.array([0.0, 0.0, 1.0]), phi0)) @ \
        rotations.matrix(rotations.from_axis_angle(np.array([0.0, 1.0, 0.0]), 0.5 * np.pi - beta))


def build(params: dict) -> Multibody:
    """Cone ``cone``: ball joint at the world origin (its apex), body frame at the apex, body z
    the symmetry axis toward the base, centre of mass at (0, 0, 3L/4). It rolls on its base rim:
    ``RollingContact`` with ``circle_z = L/4`` (the base circle's centre from the centre of mass
    along body z) and radius L tan(beta); ``half_thickness`` h is only the MJCF rim geom's
    half-height (a thin plate on the base, outside the cone).

    Initial state: the contact generator along world (cos phi0, sin phi0, 0) (rad); the cone rolls
    so that the centre A of its base moves at speed v (m/s; v > 0: A turns counter-clockwise
    about world +z). Ex. 3.4.1: the angular velocity is along the contact generator,
    w = -(v / (L sin beta)) e_gen; the precession rate is Omega = v / (L cos beta).

    Raises InputError unless 0 < beta < pi/2 and m, L, h are positive and finite."""
    m, L, beta, h = (float(params[k]) for k in ("mass", "L", "beta", "h"))
    for key, value in (("mass", m), ("L", L), ("h", h)):
        if not (np.isfinite(value) and value > 0.0):
            raise InputError(f"rolling_cone: {key} = {value!r} must be positive")
    if not (0.0 < beta < 0.5 * np.pi):
        raise InputError(f"rolling_cone: beta = {beta!r} rad must lie strictly between 0 and pi/2 (the half apex angle)")
    v, phi0 = float(params["v"]), float(params["phi0"])
    R_WB = initial_orientation(beta, phi0)
    e_gen = np.array([np.cos(phi0), np.sin(phi0), 0.0])
    w_W = -(v / (L * np.sin(beta))) * e_gen
    cone = Body("cone", None, "ball", np.zeros(3), np.zeros(3), m, np.array([0.0, 0.0, 0.75 * L]),
                cone_inertia(m, L, beta))
    gravity = np.array([0.0, 0.0, -float(params["g"])])
    return Multibody(bodies=(cone,), gravity_W=gravity, q0={"cone": rotations.from_matrix(R_WB)},
                     v0={"cone": R_WB.T @ w_W},
                     contacts=(RollingContact("cone", base_radius(L, beta), h, circle_z=0.25 * L),))
