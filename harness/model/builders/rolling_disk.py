"""rolling_disk: a uniform disk (a cylinder of radius R and half-thickness h) rolling without slip
on the horizontal plane z = 0 on its rim edge, gravity -g z (Ex. 3.4.2, 4.7.2, 5.2.3, 5.3.3)."""

from __future__ import annotations

import numpy as np

from harness.model import rolling_contact
from harness.model import rotations
from harness.model.errors import InputError
from harness.model.multibody import Body, Multibody, RollingContact


def steady_dpsi0(params) -> float:
    """The spin rate dpsi0 (rad/s) of steady circular motion at the parameters' tilt theta0
    (rad) and heading rate dphi0 (rad/s, nonzero) for their disk (``references.rolling_disk``'s
    ``steady_motion``, the closed form's own home)."""
    from harness.references import rolling_disk as reference

    disk = reference.DiskParams(params["mass"], params["R"], params["h"], params["g"])
    return reference.steady_motion(disk, params["theta0"], params["dphi0"])["dpsi"]


#: Parameters whose default follows the others (``harness.model.scene``): a scene that changes
#: theta0, dphi0 or the disk and not dpsi0 starts in steady circular motion again, the motion
#: the closed form covers.
FOLLOWS = {"dpsi0": steady_dpsi0}


def disk_inertia(m: float, R: float, h: float) -> np.ndarray:
    """Inertia (kg m^2) of a solid cylinder of radius R and length 2h about its centre, body z
    along the axis: transverse m (R^2/4 + h^2/3), axial m R^2 / 2."""
    transverse = m * (R * R / 4.0 + h * h / 3.0)
    return np.diag([transverse, transverse, 0.5 * m * R * R])


def euler323(phi: float, theta: float, psi: float) -> np.ndarray:
    """Rotation body -> world of the textbook's 3-2-3 Euler angles (§3.2):
    ``Rz(phi) Ry(theta) Rz(psi)``; body z is the disk's symmetry axis, theta its angle from
    the vertical (pi/2: upright)."""
    def rz(a):
        c, s = np.cos(a), np.sin(a)
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    c, s = np.cos(theta), np.sin(theta)
    ry = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    return rz(phi) @ ry @ rz(psi)


def initial_state(R: float, h: float, theta0: float, dphi0: float, dtheta0: float, dpsi0: float):
    """``(p_WA_W, R_WB, v_WA_W, w_WB_W)`` at t = 0: Euler angles (0, theta0, 0), the contact point
    at the world origin, and the centre's velocity from rolling without slip,
    ``v_A = -w x r_AC`` with ``w = dphi e_Z + dtheta e_y' + dpsi e_z'``."""
    R_WB = euler323(0.0, theta0, 0.0)
    w_W = dphi0 * np.array([0.0, 0.0, 1.0]) + dtheta0 * R_WB[:, 1] + dpsi0 * R_WB[:, 2]
    r = rolling_contact.contact_offset(R_WB, R, h)
    return -r, R_WB, -np.cross(w_W, r), w_W


def build(params: dict) -> Multibody:
    """Body frame at the centre of mass, body z along the symmetry axis (the MJCF cylinder's
    axis). Initial state from the textbook's Euler angles (``initial_state``)."""
    m, R, h = float(params["mass"]), float(params["R"]), float(params["h"])
    theta0 = float(params["theta0"])
    if abs(np.sin(theta0)) < 1e-6:
        raise InputError(f"rolling_disk: theta0 = {theta0!r} lays the disk flat; the rim contact needs 0 < theta0 < pi")
    disk = Body("disk", None, "free", np.zeros(3), np.zeros(3), m, np.zeros(3), disk_inertia(m, R, h))
    p, R_WB, v, w_W = initial_state(R, h, theta0, float(params["dphi0"]), float(params["dtheta0"]), float(params["dpsi0"]))
    q0 = np.concatenate([p, rotations.from_matrix(R_WB)])
    v0 = np.concatenate([v, R_WB.T @ w_W])
    gravity = np.array([0.0, 0.0, -float(params["g"])])
    return Multibody(bodies=(disk,), gravity_W=gravity, q0={"disk": q0}, v0={"disk": v0},
                     contacts=(RollingContact("disk", R, h),))
