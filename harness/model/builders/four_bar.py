"""four_bar: a planar four-bar linkage under gravity, closed by a cut hinge between coupler and
rocker.

Geometry (SI units). The linkage moves in the world x-z plane (gravity -g z); every hinge axis is
world -y, so a positive angle turns +x toward +z. Ground pivots A = (0, 0, 0) and D = (d, 0, 0).
Bars are uniform solid cylinders of radius r along their body +x axis, body frames at their
proximal joint:

* ``crank`` (length a, mass m_crank): hinged to the world at A, absolute angle theta;
* ``coupler`` (b, m_coupler): hinged to the crank's tip B, absolute angle beta (joint
  coordinate beta - theta);
* ``rocker`` (c, m_rocker): hinged to the world at D, absolute angle gamma;
* the cut hinge ``cut`` joins the coupler's tip and the rocker's tip C.

Closure: a e(theta) + b e(beta) = d e_x + c e(gamma), e(alpha) = (cos alpha, sin alpha) in (x, z).
The initial state is assembled here from theta0 and dtheta0: C is the intersection of the
circles about B (radius b) and D (radius c) on the side ``branch`` (+1: left of the directed line
B -> D, i.e. above it for a horizontal BD; -1: right), and the rates beta', gamma' solve the
velocity closure.
"""

from __future__ import annotations

import numpy as np

from harness.model.errors import InputError
from harness.model.kinematics import circle_intersection
from harness.model.multibody import Body, LoopJoint, Multibody

AXIS = np.array([0.0, -1.0, 0.0])  # every hinge: world -y (a positive angle turns +x toward +z)


def bar_inertia(m: float, L: float, r: float) -> np.ndarray:
    """Inertia (kg m^2) about the centre of a solid cylinder of mass m, length L, radius r, its
    axis along body x."""
    transverse = m * (3.0 * r**2 + L**2) / 12.0
    return np.diag([0.5 * m * r**2, transverse, transverse])


def assemble(a: float, b: float, c: float, d: float, theta: float, branch: float) -> tuple[float, float]:
    """Absolute coupler and rocker angles (beta, gamma) in rad at crank angle ``theta`` on
    ``branch`` (module docstring); InputError when the linkage cannot close there."""
    B = a * np.array([np.cos(theta), np.sin(theta)])
    C = circle_intersection(B, b, np.array([d, 0.0]), c, branch)
    if C is None:
        L = float(np.hypot(d - B[0], B[1]))
        raise InputError(f"four-bar cannot close at theta = {theta:g} rad: |BD| = {L:.6g} m must lie strictly "
                         f"between |b - c| = {abs(b - c):.6g} and b + c = {b + c:.6g} m")
    return float(np.arctan2(C[1] - B[1], C[0] - B[0])), float(np.arctan2(C[1], C[0] - d))


def rates(a: float, b: float, c: float, theta: float, beta: float, gamma: float, dtheta: float) -> tuple[float, float]:
    """(beta', gamma') in rad/s from the velocity closure
    a theta' e'(theta) + b beta' e'(beta) = c gamma' e'(gamma), e'(alpha) = (-sin alpha, cos alpha)."""
    perp = lambda alpha: np.array([-np.sin(alpha), np.cos(alpha)])  # noqa: E731
    A = np.column_stack([b * perp(beta), -c * perp(gamma)])
    if abs(np.linalg.det(A)) < 1e-12 * b * c:
        raise InputError("four-bar: coupler and rocker are collinear at the initial state (a singular position)")
    beta_dot, gamma_dot = np.linalg.solve(A, -a * dtheta * perp(theta))
    return float(beta_dot), float(gamma_dot)


def build(params: dict) -> Multibody:
    a, b, c, d = (float(params[k]) for k in ("a", "b", "c", "d"))
    r = float(params["r"])
    masses = {k: float(params[f"m_{k}"]) for k in ("crank", "coupler", "rocker")}
    branch = float(params["branch"])
    if branch not in (1.0, -1.0):
        raise InputError(f"four-bar: branch must be +1 or -1, got {branch:g}")
    theta0, dtheta0 = float(params["theta0"]), float(params["dtheta0"])
    beta0, gamma0 = assemble(a, b, c, d, theta0, branch)
    dbeta0, dgamma0 = rates(a, b, c, theta0, beta0, gamma0, dtheta0)

    def bar(name, parent, pivot, length):
        m = masses[name]
        return Body(name, parent, "hinge", np.asarray(pivot, float), AXIS, m,
                    np.array([0.5 * length, 0.0, 0.0]), bar_inertia(m, length, r))

    bodies = (
        bar("crank", None, (0.0, 0.0, 0.0), a),
        bar("coupler", "crank", (a, 0.0, 0.0), b),
        bar("rocker", None, (d, 0.0, 0.0), c),
    )
    cut = LoopJoint("cut", "hinge", "coupler", "rocker", np.array([b, 0.0, 0.0]), np.array([c, 0.0, 0.0]),
                    AXIS, AXIS, hinge_span=min(b, c))
    q0 = {"crank": np.array([theta0]), "coupler": np.array([beta0 - theta0]), "rocker": np.array([gamma0])}
    v0 = {"crank": np.array([dtheta0]), "coupler": np.array([dbeta0 - dtheta0]), "rocker": np.array([dgamma0])}
    gravity = np.array([0.0, 0.0, -float(params["g"])])
    return Multibody(bodies=bodies, gravity_W=gravity, q0=q0, v0=v0, loops=(cut,))
