"""A rectangular plate rotating at constant rate about a fixed axis at an angle to its normal:
the couple (bearing forces) needed to keep the axis fixed.

Textbook location
-----------------
Boström, *Rigid body dynamics*, Ex. 4.6.1 (text line ~2273), with the equations of rotation
about a fixed axis (4.53)-(4.59) of §4.6 and the plate's inertia from Ex. 4.2.1.

The system
----------
A uniform plate of mass m (kg), sides 2a (along its principal axis x_P) and a (along y_P) and
thickness h (along its normal z_P; the textbook's plate is thin, h -> 0), with its centre of
mass on a vertical axis that rotates at the constant rate ω (rad/s). The axis lies in the plate's
x_P-z_P plane at the fixed angle φ (rad) from the normal: ω = ω (sin φ e_xP + cos φ e_zP). The
axis is held by two bearings at the distance d (m) above and below the centre of mass.

Printed formulas (OCR text) and status
--------------------------------------
I_xx = m a²/12, I_yy = m a²/3, I_zz = 5 m a²/12 (thin plate)               — correct.
L = (1/12) m a² ω sin φ e_x + (5/12) m a² ω cos φ e_z                       — correct.
dL/dt = ω × L = −(1/3) m a² ω² cos φ sin φ e_y                              — correct.
2 F d = (1/3) m a² ω² cos φ sin φ,  F = m a² ω² cos φ sin φ / (6 d), along the rotating y — correct.

Verified formulas (any thickness)
---------------------------------
Principal moments about the centre for sides 2a along x, a along y, thickness h along z:
I_x = m (a² + h²)/12 (the side a and the thickness are perpendicular to x),
I_y = m (4a² + h²)/12, I_z = m (4a² + a²)/12 = 5 m a²/12.
With ω constant in the body (the body frame turns with the plate), the couple the bearings
exert is M = dL/dt = ω × (I ω) = −ω² sin φ cos φ (I_z − I_x) e_yP, I_z − I_x = m (4a² − h²)/12
(= m a²/3 for h -> 0), perpendicular to the axis and turning with the plate; the bearing force
pair is F = |M| / (2 d). The net force is the weight's opposite, m g ẑ: the centre of mass is on
the axis. The rate stays constant without a motor: gravity acts along the axis through the
centre of mass and the bearings' couple is perpendicular to the axis.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from harness.model import rotations

if TYPE_CHECKING:  # pragma: no cover
    from harness.measure.trajectory import Trajectory
    from harness.model.scene import Scene

__all__ = ["principal_moments", "couple", "bearing_force", "textbook_bearing_force", "EXACT_NEEDS_RUNS", "exact_error",
           "exact_error_series", "exact_reaction"]


def principal_moments(m: float, a: float, h: float = 0.0) -> np.ndarray:
    """(I_x, I_y, I_z) (kg m²) about the centre: sides 2a along x, a along y, thickness h along z."""
    return m / 12.0 * np.array([a * a + h * h, 4.0 * a * a + h * h, 5.0 * a * a])


def couple(m: float, a: float, h: float, phi: float, omega: float) -> float:
    """Signed component (N m) of the bearings' couple on the plate along the plate's y axis:
    −ω² sin φ cos φ (I_z − I_x)."""
    I = principal_moments(m, a, h)
    return float(-omega * omega * np.sin(phi) * np.cos(phi) * (I[2] - I[0]))


def bearing_force(m: float, a: float, h: float, phi: float, omega: float, d: float) -> float:
    """Magnitude (N) of each of the two horizontal bearing forces: |couple| / (2 d)."""
    return abs(couple(m, a, h, phi, omega)) / (2.0 * d)


def textbook_bearing_force(m: float, a: float, phi: float, omega: float, d: float) -> float:
    """Ex. 4.6.1 as printed: F = m a² ω² cos φ sin φ / (6 d) (N)."""
    return float(m * a * a * omega * omega * np.cos(phi) * np.sin(phi) / (6.0 * d))


# ---------------------------------------------------------------------------------------------
# Exact checks of a run (``harness.measure.exact``)
# ---------------------------------------------------------------------------------------------
EXACT_NEEDS_RUNS = False  # the run itself is judged: no extra runs


def exact_error_series(scene: "Scene", traj: "Trajectory") -> np.ndarray:
    """Geodesic angle (rad) between the run's orientation and the exact uniform rotation
    R_z(omega t) about the fixed axis (the rate stays constant: no moment about the axis)."""
    p = scene.params
    exact = np.stack([rotations.from_axis_angle(np.array([0.0, 0.0, 1.0]), p["omega"] * t) for t in traj.t])
    return rotations.geodesic_angle(traj.quat_WB[:, 0], exact)


def exact_error(scene: "Scene", traj: "Trajectory", settings=None, run=None) -> tuple[float, str, str]:
    """Max over samples of the geodesic angle (rad) between the run's orientation and R_z(omega t)
    (``exact_error_series``); the detail adds the largest |w - omega z|. ``settings`` and ``run``
    are unused (no extra runs)."""
    p = scene.params
    err = float(np.max(exact_error_series(scene, traj)))
    dw = float(np.max(np.linalg.norm(traj.w_WB_W[:, 0] - np.array([0.0, 0.0, p["omega"]]), axis=-1)))
    return err, "rad", f"orientation vs uniform rotation about the axis; |w - omega z| <= {dw:.1e} rad/s"


def exact_reaction(scene: "Scene", traj: "Trajectory") -> tuple[float, str]:
    """The larger of the force error and the couple error over 2d (the bearing forces' error),
    max over samples (N): force m g z, couple ``couple`` along the plate's turning y axis
    (Ex. 4.6.1)."""
    p = scene.params
    force, moment = traj.reactions["plate"]
    c, s = np.cos(p["omega"] * traj.t), np.sin(p["omega"] * traj.t)
    y_W = np.stack([-s, c, np.zeros_like(c)], axis=1)  # the plate's y axis turns about z
    M_exact = couple(p["m"], p["a"], p["h"], p["phi"], p["omega"]) * y_W
    F_exact = np.array([0.0, 0.0, p["m"] * p["g"]])
    err_f = float(np.max(np.linalg.norm(force - F_exact, axis=-1)))
    err_m = float(np.max(np.linalg.norm(moment - M_exact, axis=-1)))
    F_run = float(np.max(np.linalg.norm(moment, axis=-1))) / (2.0 * p["d"])
    return max(err_f, err_m / (2.0 * p["d"])), (
        f"force vs m g z, couple/(2d) vs the exact bearing forces; bearing force {F_run:.9f} N in the run, "
        f"{bearing_force(p['m'], p['a'], p['h'], p['phi'], p['omega'], p['d']):.9f} N exact, "
        f"{textbook_bearing_force(p['m'], p['a'], p['phi'], p['omega'], p['d']):.9f} N Ex. 4.6.1 (thin plate)")
