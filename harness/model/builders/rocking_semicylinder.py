"""rocking_semicylinder: a homogeneous semicylinder rocking on a smooth horizontal plane (Problem
5.12), its curved face on the plane z = 0, moving in the world x-z plane, gravity -g z.

The ideal frictionless contact of a circular face is holonomic: the face's axis O stays at height
R and the plane exerts no horizontal force, so O moves along the line z = R and the body turns
about O. That is a slide joint along world x at height R followed by a hinge about the axis: two
joints, and a scene body has one. The tree therefore splits the semicylinder's mass exactly:

* ``carrier``: a point mass mu = CARRIER_FRACTION m at O (a slide joint along world x through
  (0, 0, R); it never turns, so its inertia does not enter the dynamics: a small sphere's);
* ``semicylinder``: the rest, mass m - mu, on a hinge about -y at O (a positive angle phi turns
  +x toward +z, so the centre of mass moves toward +x), with its centre of mass at
  c' = m c / (m - mu) below O at phi = 0 and its inertia about O equal to the whole body's.

A point mass at O adds nothing to the inertia about O, so the pair has the semicylinder's mass,
centre of mass (c = 4R/(3 pi) below O) and inertia about O, hence its kinetic and potential
energy for every motion: the two-body tree is the semicylinder exactly (derivation in
``references/rocking_semicylinder.py``). Body frames: the carrier's and the semicylinder's at O,
body y along the axis, body z vertical at phi = 0 (the flat face is the body's x-y plane, the
curved half below it).

The model holds while the curved face touches the plane: the builder refuses, with one line, an
initial state whose rocking reaches |phi| >= pi/2 (the flat face's edge would touch the plane, or
the body turns over), from the conservation of horizontal momentum and energy; the normal force
stays positive on every such motion (``rocking_check``).
"""

from __future__ import annotations

import numpy as np

from harness.model.errors import InputError
from harness.model.multibody import Body, Multibody

SLIDE_AXIS = np.array([1.0, 0.0, 0.0])
HINGE_AXIS = np.array([0.0, -1.0, 0.0])
CARRIER_FRACTION = 0.1  # mu / m: any value below ~0.6 keeps the rest's inertia physical (module docstring)


def centroid_depth(R: float) -> float:
    """c = 4 R / (3 pi) (m): the centre of mass's distance from the axis O."""
    return 4.0 * R / (3.0 * np.pi)


def inertia_about_axis_point(m: float, R: float, w: float) -> np.ndarray:
    """The semicylinder's inertia (kg m^2) about O in the body frame (x across the flat face, y
    along the axis, z normal to the flat face): m R^2/2 about y, m (R^2/4 + w^2/12) about x and z
    (w its length along the axis); no products (the half-disk's symmetry)."""
    t = m * (R * R / 4.0 + w * w / 12.0)
    return np.diag([t, 0.5 * m * R * R, t])


def rocking_check(m: float, R: float, g: float, phi0: float, dphi0: float) -> None:
    """InputError unless the motion from (phi0, dphi0) rocks within |phi| < pi/2. With
    P = m (x' + c phi' cos phi) conserved, the energy gives J(phi) phi'^2 / 2 - m g c cos(phi) = E',
    J = I_G + m c^2 sin^2 phi, so the turning angle is cos(phi_max) = -E' / (m g c): the body rocks
    within |phi| < pi/2 exactly when E' < 0 (for g = 0 any rotation rate turns it over). The
    normal force needs no check: N = m (I_G / J) (g + c phi'^2 cos phi) > 0 for |phi| < pi/2
    (``references/rocking_semicylinder.py``, step 6)."""
    c = centroid_depth(R)
    I_G = 0.5 * m * R * R - m * c * c
    E = 0.5 * (I_G + m * c * c * np.sin(phi0) ** 2) * dphi0**2 - m * g * c * np.cos(phi0)
    if not abs(phi0) < 0.5 * np.pi or (g <= 0.0 and dphi0 != 0.0) or (g > 0.0 and E >= 0.0):
        raise InputError(f"rocking semicylinder: from phi0 = {phi0:g} rad, dphi0 = {dphi0:g} rad/s the body reaches "
                         f"|phi| >= pi/2 (its flat face would touch the plane, or it turns over): not a rocking motion")


def build(params: dict) -> Multibody:
    m, R, w, g = (float(params[k]) for k in ("m", "R", "w", "g"))
    phi0, dphi0, x0, dx0 = (float(params[k]) for k in ("phi0", "dphi0", "x0", "dx0"))
    rocking_check(m, R, g, phi0, dphi0)
    mu = CARRIER_FRACTION * m
    rest = m - mu
    c_rest = m * centroid_depth(R) / rest
    I_rest = inertia_about_axis_point(m, R, w) - rest * c_rest**2 * np.diag([1.0, 1.0, 0.0])  # about its own centre
    carrier = Body("carrier", None, "slide", np.array([0.0, 0.0, R]), SLIDE_AXIS, mu, np.zeros(3),
                   np.eye(3) * 0.4 * mu * (0.05 * R) ** 2)
    body = Body("semicylinder", "carrier", "hinge", np.zeros(3), HINGE_AXIS, rest, np.array([0.0, 0.0, -c_rest]), I_rest)
    q0 = {"carrier": np.array([x0]), "semicylinder": np.array([phi0])}
    v0 = {"carrier": np.array([dx0]), "semicylinder": np.array([dphi0])}
    return Multibody(bodies=(carrier, body), gravity_W=np.array([0.0, 0.0, -g]), q0=q0, v0=v0)
