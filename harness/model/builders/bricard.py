"""bricard: Bricard's overconstrained 6R linkage (the IFToMM multibody benchmark A04): five equal
bars and the ground joined by six hinges, each hinge axis perpendicular to both bars it joins.
Grübler's count gives no mobility (6 x 5 bodies - 5 x 6 hinges = 0), yet the special geometry
moves with one degree of freedom: one of the loop's rows is redundant.

Geometry (SI units; the benchmark's coordinates turned so that its "up" +y is the harness's +z,
(x, y, z)_A04 -> (x, -z, y)). Bars of length L (uniform square rods of side s, mass m) along the
edges of a cube of side L, at the initial (zero) configuration:

* ``link1`` from A = (0, 0, 0) along +x, hinged to the world at A about z;
* ``link2`` from (L, 0, 0) along -z, hinged to link1 about y;
* ``link3`` from (L, 0, -L) along -y, hinged to link2 about x;
* ``link4`` from (L, -L, -L) along -x, hinged to link3 about z;
* ``link5`` from (0, -L, -L) along +z, hinged to link4 about y;
* the cut hinge ``cut`` joins link5's tip (0, -L, 0) to the world about x (the ground bar runs
  from A to (0, -L, 0)).

Body frames at each bar's proximal hinge, parallel to the world at the initial configuration, so
every joint coordinate starts at 0. Gravity -g z. The initial joint rates are the loop's one
velocity mode (the null space of the cut hinge's 5 rows in the 5 tree rates, of rank 4 here),
scaled so that link1 turns at ``dq0`` (rad/s) about its hinge.
"""

from __future__ import annotations

import numpy as np

from harness.model.errors import InputError
from harness.model.multibody import Body, LoopJoint, Multibody

X, Y, Z = np.eye(3)


def rod_inertia(m: float, L: float, s: float, along: np.ndarray) -> np.ndarray:
    """Inertia (kg m^2) about the centre of a uniform rod of square section s x s (m), length L (m),
    mass m (kg), its long axis along the unit vector ``along`` (body frame)."""
    axial = m * s * s / 6.0
    transverse = m * (L * L + s * s) / 12.0
    a = np.asarray(along, float)
    return transverse * np.eye(3) + (axial - transverse) * np.outer(a, a)


def geometry(L: float) -> list[tuple[str, np.ndarray, np.ndarray, np.ndarray]]:
    """Per bar: name, hinge point (world, m), hinge axis (unit, world) and the bar's direction
    (unit, world), at the initial configuration."""
    return [
        ("link1", np.zeros(3), Z, X),
        ("link2", L * X, Y, -Z),
        ("link3", L * (X - Z), X, -Y),
        ("link4", L * (X - Y - Z), Z, -X),
        ("link5", L * (-Y - Z), Y, Z),
    ]


def velocity_mode(L: float) -> np.ndarray:
    """The five tree hinge rates (rad/s) of the loop's velocity mode with unit rate of link1's hinge:
    the null space of ``[a_i; a_i x (c - p_i)]`` (the velocity of link5 at the cut point c and its
    angular velocity, which the cut hinge allows only about its axis x)."""
    c = -L * Y
    cols = [np.concatenate([a, np.cross(a, c - p)]) for _, p, a, _ in geometry(L)]
    G = np.array(cols).T  # (6, 5): angular velocity of link5, velocity of its point at c
    G = G[[1, 2, 3, 4, 5]]  # the cut hinge leaves the rotation about x free: drop w_x
    _, s, Vt = np.linalg.svd(G)
    mode = Vt[-1]
    if s[-1] > 1e-9 * s[0] or abs(mode[0]) < 1e-9:
        raise InputError("bricard: the linkage has no single velocity mode driven by link1 (geometry not Bricard's)")
    return mode / mode[0]


def build(params: dict) -> Multibody:
    L, s, m = float(params["L"]), float(params["s"]), float(params["m"])
    if not s < L:
        raise InputError(f"bricard: the rods' side s = {s:g} m must be smaller than their length L = {L:g} m")
    dq0 = float(params["dq0"])
    rates = dq0 * velocity_mode(L)
    bodies, parent, origin = [], None, np.zeros(3)
    for (name, p, axis, along) in geometry(L):
        bodies.append(Body(name, parent, "hinge", p - origin, axis, m, 0.5 * L * along, rod_inertia(m, L, s, along)))
        parent, origin = name, p
    cut = LoopJoint("cut", "hinge", "link5", None, L * Z, -L * Y, X, X, hinge_span=0.5 * L)
    q0 = {b.name: np.zeros(1) for b in bodies}
    v0 = {b.name: np.array([r]) for b, r in zip(bodies, rates)}
    gravity = np.array([0.0, 0.0, -float(params["g"])])
    return Multibody(bodies=tuple(bodies), gravity_W=gravity, q0=q0, v0=v0, loops=(cut,))
