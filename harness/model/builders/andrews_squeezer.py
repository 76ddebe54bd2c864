"""andrews_squeezer: Andrews' squeezing mechanism (Schiehlen's seven-body benchmark, in Hairer and
Wanner, *Solving ODEs II*, sect. VII.7, and the IVP test set of Mazzia and Magherini): seven
planar bodies, a motor torque on the crank and a spring, closed by three cut hinges at one point E.

Geometry (SI units). The test set's plane (x, y) is the world x-z plane here (its y is world z);
every hinge axis is world -y, so a positive angle turns +x toward +z. The joint coordinates are
the test set's q = (beta, Theta, gamma, Phi, delta, Omega, epsilon), each body's frame sits at its
joint, parallel to the world when its coordinate (and its parent's) is zero; e(a) = (cos a, sin a)
and R(a) the rotation by a, in (x, z):

* ``body1`` (crank OF): hinged to the world at O = (0, 0), angle beta; F = rr e(beta); centre of
  mass ra along OF. The motor torque ``mom`` acts on its hinge.
* ``body2`` (rod FE): hinged to body1 at F, coordinate Theta (absolute angle beta + Theta);
  E = F - d e(beta + Theta); centre of mass da from F toward E.
* ``body3`` (triangle BDE): hinged to the world at B = (xb, yb), angle gamma; E = B + R(gamma)(0, -ss),
  the spring's end D = B + R(gamma)(sd, -sc), centre of mass B + R(gamma)(sb, -sa).
* ``body5`` (lever AH): hinged to the world at A = (xa, ya), angle delta; H = A + zt e(delta);
  centre of mass A + R(delta)(ta, tb).
* ``body4`` (link HE): hinged to body5 at H, coordinate Phi (absolute angle Phi + delta);
  E = H + R(Phi + delta)(0, -e); centre of mass e - ea from H toward E.
* ``body7`` (lever AG): hinged to the world at A, angle epsilon; G = A + R(epsilon)(0, -u); centre
  of mass A + R(epsilon)(ua, ub).
* ``body6`` (link GE): hinged to body7 at G, coordinate Omega (absolute angle Omega + epsilon);
  E = G + zf e(Omega + epsilon); centre of mass zf - fa from G toward E.
* cut hinges ``cut3``, ``cut4``, ``cut6`` join body2's end E to body3's, body4's and body6's E.
* a spring (stiffness c0, rest length l0) from D on body3 to the world point C = (xc, yc).

The test set gives each body's mass m_k and moment i_k (kg m^2, about its centre of mass, normal
to the plane) and, through its mass matrix, only the distance of the centres of mass of bodies 3,
5 and 7 from their pivots (sqrt(sa^2 + sb^2) ...); their directions above are this scene's
choice (they matter only under gravity, which the test set leaves out: g = 0). Out of the plane
each body gets the same moment i_k about its other two axes (any positive values that keep the
inertia physical do: the motion stays in the plane).

The initial state is assembled here from Theta0 and its rate dTheta0 (the test set: Theta = 0, at
rest): E lies on the circle about O of radius |rr - d e(Theta)| and on the circle about B of radius
ss, H on the circles about A (radius zt) and E (radius e), G on the circles about A (radius u)
and E (radius zf); each intersection is taken on the test set's side (``ASSEMBLY_SIDES``), and
the other six rates solve the velocity closure.
"""

from __future__ import annotations

import numpy as np

from harness.model.errors import InputError
from harness.model.kinematics import circle_intersection
from harness.model.multibody import Body, JointTorque, LoopJoint, Multibody, PointSpring

AXIS = np.array([0.0, -1.0, 0.0])  # every hinge: world -y (a positive angle turns +x toward +z)
BODIES = tuple(f"body{k}" for k in range(1, 8))
COORDINATES = ("beta", "Theta", "gamma", "Phi", "delta", "Omega", "epsilon")  # the joint coordinate of body1..body7
#: The side of each circle intersection of the assembly (module docstring): the sign of the
#: cross product (second centre - first centre) x (point - first centre), as in the test set's
#: initial configuration. E from circles about O and B; H about A and E; G about A and E.
ASSEMBLY_SIDES = {"E": 1.0, "H": 1.0, "G": -1.0}


def _e(a: float) -> np.ndarray:
    return np.array([np.cos(a), np.sin(a)])


def _rot(a: float, r) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([c * r[0] - s * r[1], s * r[0] + c * r[1]])


def _intersect(c1: np.ndarray, r1: float, c2: np.ndarray, r2: float, side: float, what: str) -> np.ndarray:
    """``kinematics.circle_intersection``, or InputError naming ``what`` when the circles do not meet."""
    point = circle_intersection(c1, r1, c2, r2, side)
    if point is None:
        L = float(np.hypot(*(np.asarray(c2) - c1)))
        raise InputError(f"andrews squeezer cannot assemble {what}: the centres are {L:.6g} m apart, which must lie "
                         f"strictly between |r1 - r2| = {abs(r1 - r2):.6g} and r1 + r2 = {r1 + r2:.6g} m")
    return point


def _angle_of(v: np.ndarray) -> float:
    return float(np.arctan2(v[1], v[0]))


def assemble(p: dict, Theta: float) -> np.ndarray:
    """The seven joint coordinates q = (beta, Theta, gamma, Phi, delta, Omega, epsilon) (rad) of
    the closed mechanism at rod angle ``Theta`` (module docstring); InputError when it cannot
    close."""
    A, B = np.array([p["xa"], p["ya"]]), np.array([p["xb"], p["yb"]])
    w = np.array([p["rr"] - p["d"] * np.cos(Theta), -p["d"] * np.sin(Theta)])  # E = R(beta) w
    E = _intersect(np.zeros(2), float(np.hypot(*w)), B, p["ss"], ASSEMBLY_SIDES["E"], "E (crank, rod and triangle)")
    beta = _angle_of(E) - _angle_of(w)
    gamma = _angle_of(_rot(np.pi / 2.0, E - B))  # E - B = ss (sin gamma, -cos gamma)
    H = _intersect(A, p["zt"], E, p["e"], ASSEMBLY_SIDES["H"], "H (levers about A and E)")
    delta = _angle_of(H - A)
    Phi = _angle_of(_rot(np.pi / 2.0, E - H)) - delta
    G = _intersect(A, p["u"], E, p["zf"], ASSEMBLY_SIDES["G"], "G (levers about A and E)")
    epsilon = _angle_of(_rot(np.pi / 2.0, G - A))
    Omega = _angle_of(E - G) - epsilon
    wrap = lambda a: float((a + np.pi) % (2.0 * np.pi) - np.pi)  # noqa: E731
    return np.array([wrap(beta), Theta, wrap(gamma), wrap(Phi), wrap(delta), wrap(Omega), wrap(epsilon)])


def closure(p: dict, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The test set's six closure conditions g(q) (m) and their Jacobian G = dg/dq (6, 7): E as
    reached through body2 minus E through body3, body4 and body6, (x, z) each."""
    beta, Theta, gamma, Phi, delta, Omega, eps = q
    rr, d, ss, e, zt, zf, u = (p[k] for k in ("rr", "d", "ss", "e", "zt", "zf", "u"))
    sb, cb = np.sin(beta), np.cos(beta)
    sbt, cbt = np.sin(beta + Theta), np.cos(beta + Theta)
    E2 = np.array([rr * cb - d * cbt, rr * sb - d * sbt])
    dE2 = np.array([[-rr * sb + d * sbt, d * sbt], [rr * cb - d * cbt, -d * cbt]])
    g = np.zeros(6)
    G = np.zeros((6, 7))
    sg, cg = np.sin(gamma), np.cos(gamma)
    g[0:2] = E2 - np.array([p["xb"] + ss * sg, p["yb"] - ss * cg])
    G[0:2, 0:2] = dE2
    G[0:2, 2] = [-ss * cg, -ss * sg]
    spd, cpd, sd_, cd_ = np.sin(Phi + delta), np.cos(Phi + delta), np.sin(delta), np.cos(delta)
    g[2:4] = E2 - np.array([p["xa"] + e * spd + zt * cd_, p["ya"] - e * cpd + zt * sd_])
    G[2:4, 0:2] = dE2
    G[2:4, 3] = [-e * cpd, -e * spd]
    G[2:4, 4] = [-e * cpd + zt * sd_, -e * spd - zt * cd_]
    soe, coe, se, ce = np.sin(Omega + eps), np.cos(Omega + eps), np.sin(eps), np.cos(eps)
    g[4:6] = E2 - np.array([p["xa"] + zf * coe + u * se, p["ya"] + zf * soe - u * ce])
    G[4:6, 0:2] = dE2
    G[4:6, 5] = [zf * soe, -zf * coe]
    G[4:6, 6] = [zf * soe - u * ce, -zf * coe - u * se]
    return g, G


def assemble_rates(p: dict, q: np.ndarray, dTheta: float) -> np.ndarray:
    """The seven joint rates (rad/s) with Theta' = ``dTheta`` that keep the loops closed
    (G q' = 0); InputError at a configuration where the other six are not determined."""
    G = closure(p, q)[1]
    dep = [0, 2, 3, 4, 5, 6]
    Gd = G[:, dep]
    if np.linalg.cond(Gd) > 1e12:
        raise InputError("andrews squeezer: the loops do not determine the rates at the initial state (a singular position)")
    v = np.zeros(7)
    v[1] = dTheta
    v[dep] = np.linalg.solve(Gd, -G[:, 1] * dTheta)
    return v


def _xz(v2) -> np.ndarray:
    """A vector of the test set's plane (x, y) as a world / body vector (x, 0, y)."""
    return np.array([v2[0], 0.0, v2[1]], dtype=float)


def build(params: dict) -> Multibody:
    p = {k: float(v) for k, v in params.items()}
    q = assemble(p, p["theta0"])
    v = assemble_rates(p, q, p["dtheta0"])
    m = [p[f"m{k}"] for k in range(1, 8)]
    inertia = [np.eye(3) * p[f"i{k}"] for k in range(1, 8)]
    A, B = _xz((p["xa"], p["ya"])), _xz((p["xb"], p["yb"]))
    e, u, zf, zt = p["e"], p["u"], p["zf"], p["zt"]
    layout = (  # (parent, joint point in the parent frame, centre of mass in the body frame)
        (None, np.zeros(3), _xz((p["ra"], 0.0))),
        ("body1", _xz((p["rr"], 0.0)), _xz((-p["da"], 0.0))),
        (None, B, _xz((p["sb"], -p["sa"]))),
        ("body5", _xz((zt, 0.0)), _xz((0.0, -(e - p["ea"])))),
        (None, A, _xz((p["ta"], p["tb"]))),
        ("body7", _xz((0.0, -u)), _xz((zf - p["fa"], 0.0))),
        (None, A, _xz((p["ua"], p["ub"]))),
    )
    bodies = {name: Body(name, parent, "hinge", pivot, AXIS, m[k], com, inertia[k])
              for k, (name, (parent, pivot, com)) in enumerate(zip(BODIES, layout))}
    order = ("body1", "body2", "body3", "body5", "body4", "body7", "body6")  # parents first
    E2 = _xz((-p["d"], 0.0))
    span = p["d"]
    loops = (
        LoopJoint("cut3", "hinge", "body2", "body3", E2, _xz((0.0, -p["ss"])), AXIS, AXIS, hinge_span=span),
        LoopJoint("cut4", "hinge", "body2", "body4", E2, _xz((0.0, -e)), AXIS, AXIS, hinge_span=span),
        LoopJoint("cut6", "hinge", "body2", "body6", E2, _xz((zf, 0.0)), AXIS, AXIS, hinge_span=span),
    )
    q0 = {name: np.array([q[k]]) for k, name in enumerate(BODIES)}
    v0 = {name: np.array([v[k]]) for k, name in enumerate(BODIES)}
    spring = PointSpring("spring", "body3", _xz((p["sd"], -p["sc"])), None, _xz((p["xc"], p["yc"])), p["c0"], p["l0"])
    return Multibody(bodies=tuple(bodies[n] for n in order), gravity_W=np.array([0.0, 0.0, -p["g"]]), q0=q0, v0=v0,
                     loops=loops, torques=(JointTorque("body1", p["mom"], name="motor"),), point_springs=(spring,))
