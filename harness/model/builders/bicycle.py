"""bicycle: the Whipple bicycle of the benchmark of Meijaard, Papadopoulos, Ruina and Schwab (2007)
-- rear frame B, rear wheel R, front frame H, front wheel F, two knife-edge wheels rolling without
slip on the plane z = 0 -- built in the harness's frames from the benchmark's parameters
(``harness.references.bicycle.BicycleParams``, the one source of its numbers).

Frames. The benchmark's global frame N has x forward, y to the right, z DOWN, its origin at the
rear contact of the upright bicycle; the harness's world W has z UP: W = N turned by pi about x
(y and z flip). Every body frame here is, at the upright, straight, zero-pitch configuration, the
frame with x forward, y up and z to the right (``R_UPRIGHT`` in W) turned by lambda about its z:
z is the lateral axis (a wheel's symmetry axis, its axle, is its body z, as ``RollingContact``
needs), y points up the steering axis, x forward and up by lambda (``body_axes``). So the
steering hinge's axis is body -y whatever lambda, and lambda reaches every engine through
positions and inertias, which they rewrite from the scene, not through a hinge axis, which the
MJCF and URDF state. A benchmark vector (x, y, z)_N is ``body_axes(lam)^T`` times it in the body
frame (``to_body``); an inertia tensor of the paper ``[[Ixx, 0, Ixz], [0, Iyy, 0], [Ixz, 0,
Izz]]`` is ``body_axes^T I body_axes`` (``inertia_to_body``; at lambda = 0 ``[[Ixx, -Ixz, 0],
[-Ixz, Izz, 0], [0, 0, Iyy]]``: the products of inertia xz change sign with y and z).

Bodies and joints (``build``):

* ``B`` rear frame with rider: free joint, frame origin at the rear wheel's centre;
* ``R`` rear wheel: hinge about the axle (body z) at B's origin; frame at its centre;
* ``H`` front frame (handlebar and fork): hinge about the steering axis, the line through the
  ground point (w + c, 0, 0) (N) along (sin lambda, 0, cos lambda) (N, pointing down; body -y);
  frame origin at the foot of the perpendicular from the front wheel's centre to that axis; a
  positive angle steers to the right;
* ``F`` front wheel: hinge about the axle (body z) at its centre.

Both wheels are knife edges (``RollingContact`` on the wheel's one rim circle, ``circle_z = 0``):
the contact point is the lowest point of that circle, at rest for rolling without slip. The
scene's ``tyre`` is the half-width of MuJoCo's cylinder geoms only.

Coordinates of the benchmark (``Coordinates``, ``joint_state``): the rear frame's orientation is
yaw psi, roll phi and pitch theta, ``R_NB = Rz(psi) Rx(phi) Ry(theta)`` (N, body-fixed
sequence), roll positive leaning to the right; steer delta is the hinge angle of H. Given
(psi, phi, delta) the pitch is fixed by the front contact (its height zero: solved by Newton,
``pitch``); given the roll rate, the steer rate and the forward speed v (the rear wheel's rim
speed, ``-rR`` times its spin rate relative to B) the other velocities -- the rear frame's twist,
both wheels' spin rates -- are fixed by the six no-slip rows of the two contacts (a linear solve,
``joint_state``). Measured on any state of the maximal coordinates (``roll_steer``)::

    sin phi = -n_z,  n = R_WB e_z (B's lateral axis),  phi' = -n'_z / cos phi,  n' = w_B x n
    delta' = a . (w_H - w_B),  a = R_WB axis_H (the steering axis, world)

and their second derivatives from the bodies' angular accelerations (``roll_steer_accelerations``)::

    phi''   = -n''_z / cos phi - n'_z sin phi phi' / cos^2 phi,  n'' = alpha_B x n + w_B x (w_B x n)
    delta'' = (w_B x a) . (w_H - w_B) + a . (alpha_H - alpha_B)

The linearisation of any engine's dynamics in these coordinates (``harness.engines.linearization``) is
the benchmark's state matrix ``harness.references.bicycle.state_matrix``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from harness.model import rotations
from harness.model.errors import InputError
from harness.model.multibody import Body, Multibody, RollingContact
from harness.model.rolling_contact import contact_offset
from harness.references import bicycle as reference

#: The frame with x forward, y up, z to the right (the benchmark's y) in the world: the body
#: frames at the upright configuration before their tilt by lambda (``body_axes``).
R_UPRIGHT = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
#: R_WN: the benchmark's global frame (z down) in the world (z up); its own inverse.
R_WN = np.diag([1.0, -1.0, -1.0])
#: The steering hinge's axis in H's frame (pointing down the steering axis: positive steers right).
STEER_AXIS = np.array([0.0, -1.0, 0.0])

BODIES = ("B", "R", "H", "F")
PITCH_TOL = 1e-15  # m, the front contact's height left by the pitch's Newton iteration
PITCH_ITER = 50


def benchmark(params) -> reference.BicycleParams:
    """The benchmark's parameters (``BicycleParams``) from the scene's parameter values."""
    return reference.params_of(params)


def _rot(axis: int, angle: float) -> np.ndarray:
    """The rotation by ``angle`` (rad) about coordinate axis ``axis`` (0, 1, 2: x, y, z)."""
    c, s = np.cos(angle), np.sin(angle)
    i, j = (axis + 1) % 3, (axis + 2) % 3
    R = np.eye(3)
    R[i, i], R[i, j], R[j, i], R[j, j] = c, -s, s, c
    return R


def body_axes(lam: float) -> np.ndarray:
    """R_NB (3x3): the body frames' axes in the benchmark frame N at the upright, straight,
    zero-pitch configuration, for steer axis tilt ``lam`` (rad; module docstring)."""
    return R_WN @ R_UPRIGHT @ _rot(2, lam)


def to_body(v_N, lam: float) -> np.ndarray:
    """A benchmark vector (N frame, m) in the body frames at the upright configuration."""
    return body_axes(lam).T @ np.asarray(v_N, dtype=float)


def inertia_to_body(Ixx: float, Iyy: float, Izz: float, Ixz: float, lam: float) -> np.ndarray:
    """A benchmark inertia ``[[Ixx, 0, Ixz], [0, Iyy, 0], [Ixz, 0, Izz]]`` (kg m^2, N frame) in the
    body frame at the upright configuration: ``R_NB^T I R_NB``."""
    I_N = np.array([[Ixx, 0.0, Ixz], [0.0, Iyy, 0.0], [Ixz, 0.0, Izz]])
    R = body_axes(lam)
    return R.T @ I_N @ R


@dataclass(frozen=True)
class Geometry:
    """The bicycle's points in the benchmark frame N at the upright configuration (m) and the
    steering axis: ``rear`` and ``front`` wheel centres, ``head`` (H's frame origin: the foot of
    the perpendicular from the front wheel's centre to the steering axis), ``axis_N`` (the
    steering axis, unit, pointing down)."""

    rear: np.ndarray
    front: np.ndarray
    head: np.ndarray
    axis_N: np.ndarray


def geometry(p: reference.BicycleParams) -> Geometry:
    """``Geometry`` of the benchmark's parameters ``p``."""
    axis = np.array([np.sin(p.lam), 0.0, np.cos(p.lam)])
    ground = np.array([p.w + p.c, 0.0, 0.0])  # where the steering axis meets the ground
    front = np.array([p.w, 0.0, -p.rF])
    head = ground + float((front - ground) @ axis) * axis
    return Geometry(np.array([0.0, 0.0, -p.rR]), front, head, axis)


def bodies(p: reference.BicycleParams) -> tuple[Body, ...]:
    """The four bodies (module docstring) with the benchmark's mass properties in body frames."""
    geo, lam = geometry(p), p.lam

    def body(v_N):
        return to_body(v_N, lam)

    rear_frame = Body("B", None, "free", np.zeros(3), np.zeros(3), p.mB, body(np.array([p.xB, 0.0, p.zB]) - geo.rear),
                      inertia_to_body(p.IBxx, p.IByy, p.IBzz, p.IBxz, lam))
    rear_wheel = Body("R", "B", "hinge", np.zeros(3), np.array([0.0, 0.0, 1.0]), p.mR, np.zeros(3),
                      inertia_to_body(p.IRxx, p.IRyy, p.IRxx, 0.0, lam))
    front_frame = Body("H", "B", "hinge", body(geo.head - geo.rear), STEER_AXIS.copy(), p.mH,
                       body(np.array([p.xH, 0.0, p.zH]) - geo.head), inertia_to_body(p.IHxx, p.IHyy, p.IHzz, p.IHxz, lam))
    front_wheel = Body("F", "H", "hinge", body(geo.front - geo.head), np.array([0.0, 0.0, 1.0]), p.mF, np.zeros(3),
                       inertia_to_body(p.IFxx, p.IFyy, p.IFxx, 0.0, lam))
    return rear_frame, rear_wheel, front_frame, front_wheel


def contacts(p: reference.BicycleParams, tyre: float = 0.0) -> tuple[RollingContact, ...]:
    """The two knife-edge wheels rolling on the plane z = 0: each rolls on its one rim circle
    (``circle_z = 0``, the wheel's mid-plane, at every lean); ``tyre`` (m) is only the
    half-width of MuJoCo's cylinder geoms (``rear_tyre``, ``front_tyre``), not part of the ideal
    model."""
    return (RollingContact("R", p.rR, tyre, name="rear_contact", geom="rear_tyre", circle_z=0.0),
            RollingContact("F", p.rF, tyre, name="front_contact", geom="front_tyre", circle_z=0.0))


def rear_orientation(psi: float, phi: float, theta: float, lam: float) -> np.ndarray:
    """R_WB of the rear frame at yaw psi, roll phi, pitch theta (rad) of a bicycle of steer axis
    tilt ``lam`` (rad): ``R_WN Rz(psi) Rx(phi) Ry(theta) body_axes(lam)`` (the rotations in N)."""
    return R_WN @ _rot(2, psi) @ _rot(0, phi) @ _rot(1, theta) @ body_axes(lam)


def tilt(model: Multibody) -> float:
    """The steer axis tilt lambda (rad) of a bicycle built here, read back from its bodies: the
    angle by which the body frames are turned (module docstring), from the rear-to-front wheel
    centre vector d = (w, rF - rR) in the untilted frame and as the bodies state it."""
    d = np.asarray(model.body("H").p_PB_P, float) + np.asarray(model.body("F").p_PB_P, float)
    dy = model.contacts[1].radius - model.contacts[0].radius
    u = np.array([np.sqrt(max(d[0] ** 2 + d[1] ** 2 - dy * dy, 0.0)), dy])
    return float(np.arctan2(u[1] * d[0] - u[0] * d[1], u @ d[:2]))


def _rear_centre(R_WB: np.ndarray, rR: float, xy) -> np.ndarray:
    """The rear wheel's centre (m, world) with its contact point (the lowest point of its mid
    circle) at (x, y, 0)."""
    return np.array([xy[0], xy[1], 0.0]) - contact_offset(R_WB, rR, 0.0, 0.0)


@dataclass(frozen=True)
class Coordinates:
    """The benchmark's coordinates on the bicycle's ``Multibody`` (module docstring): joint states
    from (phi, delta, phi', delta') at forward speed ``v`` (m/s), and phi'', delta'' measured on
    maximal coordinates. ``n = 2`` positions; ``names`` their names. The rear contact is at
    ``xy`` (m) and the yaw is ``psi`` (rad)."""

    model: Multibody
    v: float
    psi: float = 0.0
    xy: tuple[float, float] = (0.0, 0.0)
    names: tuple[str, ...] = ("phi", "delta")

    @property
    def n(self) -> int:
        return 2

    def joint_state(self, x) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
        """``(q, v)`` per body (joint coordinates) at ``x = (phi, delta, phi', delta')`` (rad,
        rad/s): ``joint_state`` of the module."""
        return joint_state(self.model, float(x[0]), float(x[1]), float(x[2]), float(x[3]), self.v, psi=self.psi, xy=self.xy)

    def rates(self, states) -> np.ndarray:
        """(phi, delta, phi', delta') of maximal-coordinate states (``kinematics.BodyState`` per
        body name)."""
        return roll_steer(self.model, states)

    def accelerations(self, states, a_WCm_W, alpha_WB_W) -> np.ndarray:
        """(phi'', delta'') (rad/s^2) from states and the bodies' angular accelerations
        ``alpha_WB_W`` (per body name, world, rad/s^2); ``a_WCm_W`` is not needed."""
        return roll_steer_accelerations(self.model, states, alpha_WB_W)


def _rotation(axis, angle: float) -> np.ndarray:
    """The rotation by ``angle`` (rad) about the unit ``axis`` (Rodrigues)."""
    k = rotations.skew(_unit(axis))
    return np.eye(3) + np.sin(angle) * k + (1.0 - np.cos(angle)) * (k @ k)


def _frames(model: Multibody, q: dict) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per body, its frame origin (m, world) and R_WB at joint coordinates ``q`` (the positions of
    ``kinematics.forward`` for the free root and hinges, without its velocities)."""
    out = {}
    for b in model.bodies:
        qb = np.asarray(q[b.name], dtype=float)
        if b.parent is None:  # the free rear frame
            out[b.name] = (qb[:3].copy(), rotations.matrix(qb[3:7] / np.linalg.norm(qb[3:7])))
        else:
            O_P, R_WP = out[b.parent]
            out[b.name] = (O_P + R_WP @ np.asarray(b.p_PB_P, float), R_WP @ _rotation(b.axis_B, qb[0]))
    return out


def _front_height(model: Multibody, q: dict) -> float:
    """Height (m) of the front wheel's lowest point at joint coordinates ``q``."""
    front = model.contacts[1]
    O, R = _frames(model, q)[front.body]
    centre = O + R @ np.asarray(model.body(front.body).p_BCm_B, float)
    return float(centre[2] + contact_offset(R, front.radius, front.half_thickness, front.circle_z)[2])


def _positions(model: Multibody, psi: float, phi: float, theta: float, delta: float, xy) -> dict[str, np.ndarray]:
    R_WB = rear_orientation(psi, phi, theta, tilt(model))
    rR = model.contacts[0].radius
    return {"B": np.concatenate([_rear_centre(R_WB, rR, xy), rotations.from_matrix(R_WB)]),
            "R": np.zeros(1), "H": np.array([delta]), "F": np.zeros(1)}


def pitch(model: Multibody, psi: float, phi: float, delta: float, xy=(0.0, 0.0), theta0: float = 0.0) -> float:
    """The rear frame's pitch theta (rad) that puts the front wheel on the ground at yaw psi,
    roll phi and steer delta (rad): Newton's method on the front contact's height, the
    derivative by a central difference; InputError when it does not converge (a roll or steer
    at which the front wheel cannot touch the ground)."""
    theta = float(theta0)
    height = _front_height(model, _positions(model, psi, phi, theta, delta, xy))
    for _ in range(PITCH_ITER):
        if abs(height) <= PITCH_TOL:
            return theta
        h = 1e-6
        slope = (_front_height(model, _positions(model, psi, phi, theta + h, delta, xy))
                 - _front_height(model, _positions(model, psi, phi, theta - h, delta, xy))) / (2.0 * h)
        step = -height / slope
        theta += step
        new = _front_height(model, _positions(model, psi, phi, theta, delta, xy))
        if abs(step) < 1e-17 and abs(new) >= abs(height):
            return theta  # round-off: no further progress
        height = new
    if abs(height) <= 1e3 * PITCH_TOL:
        return theta
    raise InputError(f"bicycle: no pitch puts the front wheel on the ground at roll {phi!r} rad, steer {delta!r} rad "
                     f"(height {height:.3g} m left)")


def joint_state(model: Multibody, phi: float, delta: float, dphi: float, ddelta: float, v: float, *, psi: float = 0.0,
                xy=(0.0, 0.0)) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Joint coordinates ``(q, v)`` per body of the bicycle at yaw ``psi``, roll ``phi``, steer
    ``delta`` (rad), roll rate ``dphi``, steer rate ``ddelta`` (rad/s) and forward speed ``v``
    (m/s), the rear contact at ``xy`` (m), both wheels at angle zero: the pitch from the front
    contact (``pitch``), the rear frame's twist and the wheels' spin rates from the six no-slip
    rows, the roll rate and the rear wheel's spin -v / rR (module docstring).

    The rows are linear in the unknowns u = [v_O (3, world: B's origin), w_B (3, B's frame), R's
    and F's spin rates]; with the origins O and world axes a of the bodies, w_B_W = R_WB w_B,
    w_R = w_B_W + a_R rate_R, w_H = w_B_W + a_H delta', w_F = w_H + a_F rate_F, and the
    velocity of a point x of a body b is v_O + w_B_W x (O_b - O) + ... down the chain, so the
    material point of wheel b at its contact point C_b moves at ``v_O + w_B_W x (C_b - O) +
    (joint rates) a_j x (C_b - O_j)`` over the hinges j between B and b."""
    theta = pitch(model, psi, phi, delta, xy)
    q = _positions(model, psi, phi, theta, delta, xy)
    frames = _frames(model, q)
    O_B, R_B = frames["B"]
    axis = {b.name: frames[b.name][1] @ _unit(b.axis_B) for b in model.bodies if b.parent is not None}

    def point_rows(body: str, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(G (3, 8), g (3,))``: the world velocity of the material point at x (world) of
        ``body`` is G u + g delta'."""
        G = np.zeros((3, 8))
        G[:, :3] = np.eye(3)
        G[:, 3:6] = -rotations.skew(x - O_B) @ R_B  # w_B_W x (x - O) = -[x - O]x R_B w_B
        g = np.zeros(3)
        chain = {"R": [("R", 6)], "H": [("H", None)], "F": [("H", None), ("F", 7)]}[body]
        for joint, column in chain:
            lever = np.cross(axis[joint], x - frames[joint][0])
            if column is None:
                g += lever
            else:
                G[:, column] = lever
        return G, g

    G_rows, g_rows = [], []
    for c in model.contacts:
        O, R = frames[c.body]
        C = O + R @ np.asarray(model.body(c.body).p_BCm_B, float) + contact_offset(R, c.radius, c.half_thickness, c.circle_z)
        G, g = point_rows(c.body, C)
        G_rows.append(G)
        g_rows.append(g)
    n = R_B[:, 2]
    # roll rate: -(w_B_W x n)_z / cos(phi) = (e_z x n) . R_B w_B / cos(phi)
    roll = np.zeros(8)
    roll[3:6] = (np.cross([0.0, 0.0, 1.0], n) @ R_B) / np.cos(phi)
    spin = np.zeros(8)
    spin[6] = 1.0
    A = np.vstack(G_rows + [roll, spin])
    rhs = np.concatenate([-ddelta * np.concatenate(g_rows), [dphi, -v / model.contacts[0].radius]])
    u = np.linalg.solve(A, rhs)
    return q, {"B": u[:6], "R": u[6:7], "H": np.array([ddelta]), "F": u[7:8]}


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def roll_steer(model: Multibody, states) -> np.ndarray:
    """``(phi, delta, phi', delta')`` (rad, rad/s) of maximal-coordinate states (per body name:
    ``quat_WB``, ``w_WB_W``; module docstring)."""
    R_B = rotations.matrix(np.asarray(states["B"].quat_WB, float))
    R_H = rotations.matrix(np.asarray(states["H"].quat_WB, float))
    w_B, w_H = np.asarray(states["B"].w_WB_W, float), np.asarray(states["H"].w_WB_W, float)
    n = R_B[:, 2]
    phi = float(np.arcsin(np.clip(-n[2], -1.0, 1.0)))
    axis_B = _unit(model.body("H").axis_B)
    a = R_B @ axis_B
    R_BH = R_B.T @ R_H  # a rotation about axis_B by delta
    e1 = np.cross(axis_B, [0.0, 0.0, 1.0] if abs(axis_B[2]) < 0.9 else [1.0, 0.0, 0.0])
    e1 = _unit(e1)
    delta = float(np.arctan2(np.cross(e1, R_BH @ e1) @ axis_B, e1 @ (R_BH @ e1)))
    dphi = float(-np.cross(w_B, n)[2] / np.cos(phi))
    ddelta = float(a @ (w_H - w_B))
    return np.array([phi, delta, dphi, ddelta])


def roll_steer_accelerations(model: Multibody, states, alpha_WB_W) -> np.ndarray:
    """``(phi'', delta'')`` (rad/s^2) from maximal-coordinate states and the bodies' angular
    accelerations (world, rad/s^2, per body name; module docstring)."""
    R_B = rotations.matrix(np.asarray(states["B"].quat_WB, float))
    w_B, w_H = np.asarray(states["B"].w_WB_W, float), np.asarray(states["H"].w_WB_W, float)
    al_B, al_H = np.asarray(alpha_WB_W["B"], float), np.asarray(alpha_WB_W["H"], float)
    n = R_B[:, 2]
    phi = np.arcsin(np.clip(-n[2], -1.0, 1.0))
    c, s = np.cos(phi), np.sin(phi)
    n_dot = np.cross(w_B, n)
    n_ddot = np.cross(al_B, n) + np.cross(w_B, n_dot)
    dphi = -n_dot[2] / c
    ddphi = -n_ddot[2] / c - n_dot[2] * s * dphi / (c * c)
    a = R_B @ _unit(model.body("H").axis_B)
    dddelta = np.cross(w_B, a) @ (w_H - w_B) + a @ (al_H - al_B)
    return np.array([float(ddphi), float(dddelta)])


def build(params: dict) -> Multibody:
    """The bicycle (module docstring) from the benchmark's parameters, running straight at
    ``v`` (m/s) with roll ``phi0``, steer ``delta0`` (rad), roll rate ``dphi0`` and steer rate
    ``ddelta0`` (rad/s), the rear contact at the world origin, yaw zero; pitch and the dependent
    velocities from the contacts (``joint_state``)."""
    p = benchmark(params)
    for key in ("w", "rR", "rF", "mR", "mB", "mH", "mF"):
        if not getattr(p, key) > 0.0:
            raise InputError(f"bicycle: {key} = {getattr(p, key)!r} must be positive")
    if not float(params["tyre"]) > 0.0:
        raise InputError(f"bicycle: tyre = {params['tyre']!r} must be positive (the half-width of the MJCF's tyre cylinders)")
    if not abs(p.lam) < 0.5 * np.pi:
        raise InputError(f"bicycle: the steer axis tilt lam = {p.lam!r} rad must be in (-pi/2, pi/2)")
    skeleton = Multibody(bodies=bodies(p), gravity_W=np.array([0.0, 0.0, -p.g]),
                         q0={b: np.zeros(7 if b == "B" else 1) for b in BODIES},
                         v0={b: np.zeros(6 if b == "B" else 1) for b in BODIES},
                         contacts=contacts(p, float(params["tyre"])))
    q0, v0 = joint_state(skeleton, float(params["phi0"]), float(params["delta0"]), float(params["dphi0"]),
                         float(params["ddelta0"]), float(params["v"]))
    return Multibody(bodies=skeleton.bodies, gravity_W=skeleton.gravity_W, q0=q0, v0=v0, contacts=skeleton.contacts)
