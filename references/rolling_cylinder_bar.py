"""Rolling cylinder with a bar pinned to its axis: conserved quantities and the bar's rate at the vertical.

Textbook location
-----------------
Boström, *Rigid body dynamics*, Problem 5.13 (text line ~3084; answer line ~3519): "A homogeneous
circular cylinder with mass 4m and radius R rolls without slip on a horizontal surface. A bar
with mass m and length 4R is pinned to the axis of the cylinder and can swing freely. If the
system is released from rest with the bar horizontal, what is the angular velocity of the bar
when it has rotated 90°?" Printed answer: sqrt(21 g / (25 R)).

System and conventions (SI units, world z up)
---------------------------------------------
A uniform solid cylinder of mass M, radius R (axial moment I_a = M R^2 / 2 about its axis) rolls
without slip on the plane z = 0 with its axis horizontal along world -y; its axis is at
(x, 0, R). A uniform bar of mass m, length L (a round bar of radius a: moment about its centre,
for the swing axis, I_c = m (L^2/12 + a^2/4); the textbook's thin bar a -> 0) is pinned at one
end to the cylinder's axis and swings in the x-z plane. theta (rad): the bar's angle from the
downward vertical, positive toward +x; its centre of mass is at
(x + l sin(theta), R - l cos(theta)), l = L/2, and its angular velocity is theta' about world -y.
Gravity -g z. Abbreviations: I_O = I_c + m l^2 (the bar about its pivot),
S = M + m + I_a / R^2 (the effective mass of the rolling motion; 3M/2 + m for a uniform
cylinder).

Derivation (numbered)
---------------------
1. Rolling without slip: the cylinder turns at x'/R about world +y (its contact point at rest:
   v_axis + w x (0, 0, -R) = 0 gives v_x = R w_y). The contact is holonomic in the plane
   (x and the roll angle are tied by x = R phi + const), so Lagrange's equations in (x, theta)
   hold with the rolling substituted; the contact force does no work (it acts at a point at
   rest).
2. Kinetic energy: cylinder (M x'^2 + I_a x'^2 / R^2) / 2; bar: its centre's velocity is
   (x' + l cos(theta) theta', l sin(theta) theta'), plus I_c theta'^2 / 2. Sum::

       T = S x'^2 / 2 + m l cos(theta) x' theta' + I_O theta'^2 / 2
       V = -m g l cos(theta)      (plus a constant)

3. x is cyclic: p_x = dT/dx' = S x' + m l cos(theta) theta' is conserved (it is the
   angular momentum about the contact line divided by R, not the linear momentum: friction acts).
   Lagrange's equations (``planar_rhs``)::

       S x'' + m l (cos(theta) theta'' - sin(theta) theta'^2) = 0
       m l cos(theta) x'' + I_O theta'' + m g l sin(theta) = 0

4. Eliminating x' with p_x = P: x' = (P - m l cos(theta) theta') / S, so
   T = P^2 / (2 S) + J(theta) theta'^2 / 2 with J(theta) = I_O - m^2 l^2 cos^2(theta) / S > 0.
   Energy E = T + V is conserved (step 1), hence at any angle (``rate_squared``)::

       theta'^2 = 2 (E_rel + m g l cos(theta)) / J(theta),   E_rel = E - P^2 / (2 S)

5. At the vertical (theta = 0), from rest at theta0 (P = 0, E_rel = -m g l cos(theta0)):
   theta'^2 = 2 m g l (1 - cos(theta0)) / (I_O - m^2 l^2 / S).
6. Problem 5.13: M = 4m, L = 4R (l = 2R), thin bar (I_c = m L^2 / 12 = 4 m R^2 / 3),
   theta0 = pi/2. I_a / R^2 = 2m, S = 7m, I_O = 4/3 m R^2 + 4 m R^2 = 16/3 m R^2,
   J(0) = 16/3 m R^2 - 4 m^2 R^2 / (7 m) = 100/21 m R^2, and
   theta'^2 = 2 m g (2R) / (100/21 m R^2) = 21 g / (25 R): the printed answer is right
   (``textbook_rate``; the scene's bar has a = 5 mm, which lowers the rate by a relative 6.6e-5).
7. Contact force (N, world) on the cylinder, from the system's momentum: F_x = M x'' + m
   (x'' + l (cos(theta) theta'' - sin(theta) theta'^2)), F_z = (M + m) g + m l (sin(theta)
   theta'' + cos(theta) theta'^2) (``contact_force``). The ideal contact is bilateral: a state
   with F_z < 0 (the bar whirled fast enough to lift the cylinder) is still the scene's motion
   in the ideal engines, not in MuJoCo's unilateral soft contact.

Status: printed answer verified (steps 1-6) and checked against a maximal-coordinate
Newton-Euler integration in ``tests/references/test_rolling_cylinder_bar.py``. No erratum.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy.integrate import solve_ivp

from harness.model import rotations

if TYPE_CHECKING:  # pragma: no cover
    from harness.measure.trajectory import Trajectory
    from harness.model.scene import Scene

__all__ = [
    "Params",
    "planar_rhs",
    "integrate",
    "momentum",
    "energy",
    "rate_squared",
    "rate_at_vertical",
    "textbook_rate",
    "contact_force",
    "run_coordinates",
    "EXACT_NEEDS_RUNS",
    "exact_error",
    "exact_error_series",
]


@dataclass(frozen=True)
class Params:
    """The system (SI): cylinder mass M (kg) and radius R (m), bar mass m (kg), length L (m) and
    radius a (m), gravity g (m/s^2). The cylinder is uniform: I_a = M R^2 / 2."""

    M: float
    m: float
    R: float
    L: float
    a: float
    g: float

    @property
    def l(self) -> float:
        """Pivot to the bar's centre of mass (m)."""
        return 0.5 * self.L

    @property
    def S(self) -> float:
        """Effective mass of the rolling motion, M + m + I_a / R^2 (kg)."""
        return 1.5 * self.M + self.m

    @property
    def I_O(self) -> float:
        """The bar's moment about its pivot for the swing axis (kg m^2)."""
        return self.m * (self.L**2 / 12.0 + self.a**2 / 4.0) + self.m * self.l**2

    def J(self, theta) -> np.ndarray:
        """J(theta) = I_O - m^2 l^2 cos^2(theta) / S (kg m^2), step 4."""
        c = np.cos(np.asarray(theta, dtype=float))
        return self.I_O - (self.m * self.l * c) ** 2 / self.S

    @classmethod
    def of_scene(cls, params) -> "Params":
        return cls(*(float(params[k]) for k in ("M", "m", "R", "L", "a", "g")))


def planar_rhs(p: Params):
    """``f(t, y)`` of Lagrange's equations (step 3), y = (x, theta, x', theta') (m, rad, m/s, rad/s)."""
    ml, S, I_O = p.m * p.l, p.S, p.I_O

    def f(t, y):
        _, th, _, dth = y
        c, s = np.cos(th), np.sin(th)
        det = S * I_O - (ml * c) ** 2
        b1 = ml * s * dth * dth
        b2 = -ml * p.g * s
        ddx = (I_O * b1 - ml * c * b2) / det
        ddth = (S * b2 - ml * c * b1) / det
        return [y[2], dth, ddx, ddth]

    return f


def integrate(p: Params, y0, t: np.ndarray):
    """Lagrange's equations (``planar_rhs``) by DOP853 at rtol = atol = 1e-12, sampled at ``t``
    (s): the ``solve_ivp`` result."""
    sol = solve_ivp(planar_rhs(p), (float(t[0]), float(t[-1])), np.asarray(y0, float), t_eval=t,
                    method="DOP853", rtol=1e-12, atol=1e-12)
    if not sol.success:
        raise RuntimeError(sol.message)
    return sol


def momentum(p: Params, theta, dx, dtheta) -> np.ndarray:
    """p_x = S x' + m l cos(theta) theta' (kg m/s), conserved (step 3)."""
    return p.S * np.asarray(dx) + p.m * p.l * np.cos(theta) * np.asarray(dtheta)


def energy(p: Params, theta, dx, dtheta) -> np.ndarray:
    """E = T + V (J), V = -m g l cos(theta) (step 2)."""
    T = 0.5 * p.S * dx * dx + p.m * p.l * np.cos(theta) * dx * dtheta + 0.5 * p.I_O * dtheta * dtheta
    return T - p.m * p.g * p.l * np.cos(theta)


def rate_squared(p: Params, theta, P: float, E: float) -> np.ndarray:
    """theta'^2 (rad^2/s^2) at the bar angle(s) theta from momentum P and energy E (step 4)."""
    E_rel = E - P * P / (2.0 * p.S)
    return 2.0 * (E_rel + p.m * p.g * p.l * np.cos(np.asarray(theta, float))) / p.J(theta)


def rate_at_vertical(p: Params, theta0: float, dx0: float = 0.0, dtheta0: float = 0.0) -> float:
    """|theta'| (rad/s) when the bar passes the vertical (theta = 0 mod 2 pi), steps 4-5."""
    P = float(momentum(p, theta0, dx0, dtheta0))
    E = float(energy(p, theta0, dx0, dtheta0))
    return float(np.sqrt(rate_squared(p, 0.0, P, E)))


def textbook_rate(g: float, R: float) -> float:
    """Problem 5.13 as printed: sqrt(21 g / (25 R)) (rad/s)."""
    return float(np.sqrt(21.0 * g / (25.0 * R)))


def contact_force(p: Params, y) -> np.ndarray:
    """Force (N, world x and z) of the plane on the cylinder at state(s) y = (x, theta, x',
    theta') (step 7); shape (..., 2)."""
    y = np.asarray(y, float)
    th, dth = y[..., 1], y[..., 3]
    f = planar_rhs(p)
    acc = np.array([f(0.0, yy)[2:] for yy in y.reshape(-1, 4)]).reshape(y.shape[:-1] + (2,))
    ddx, ddth = acc[..., 0], acc[..., 1]
    c, s = np.cos(th), np.sin(th)
    Fx = p.M * ddx + p.m * (ddx + p.l * (c * ddth - s * dth * dth))
    Fz = (p.M + p.m) * p.g + p.m * p.l * (s * ddth + c * dth * dth)
    return np.stack([Fx, Fz], axis=-1)


# ---------------------------------------------------------------------------------------------
# Exact check of a run (``harness.measure.exact``)
# ---------------------------------------------------------------------------------------------
EXACT_NEEDS_RUNS = False  # the run itself is judged: no extra runs


def run_coordinates(traj: "Trajectory") -> dict[str, np.ndarray]:
    """The planar coordinates of a run (maximal coordinates; body 0 the cylinder, body 1 the
    bar): ``theta`` (rad, unwrapped: the bar's centre relative to the pivot, the cylinder's
    centre), ``dtheta`` (rad/s, the bar's angular velocity about -y), ``dx`` (m/s, the axis's
    velocity along x), and the out-of-plane motion: ``tilt`` (rad, |n_x| and |n_z| of the
    cylinder's axis n, which stays -y in the plane) and ``y`` (m, the largest |y| of the two
    centres of mass)."""
    cyl, bar = traj.p_WCm_W[:, 0], traj.p_WCm_W[:, 1]
    theta = np.unwrap(np.arctan2(bar[:, 0] - cyl[:, 0], cyl[:, 2] - bar[:, 2]))
    R = rotations.matrix(traj.quat_WB[:, 0])
    n = R[:, :, 2]
    return {"theta": theta, "dtheta": -traj.w_WB_W[:, 1, 1], "dx": traj.v_WCm_W[:, 0, 0],
            "tilt": np.maximum(np.abs(n[:, 0]), np.abs(n[:, 2])),
            "y": np.maximum(np.abs(cyl[:, 1]), np.abs(bar[:, 1]))}


def _scales(p: Params, P: float, E: float, dtheta: np.ndarray) -> float:
    """The squared rate scale (rad^2/s^2): the largest of the run's theta'^2 and the exact one at
    the vertical (a floor: a run at rest has no rate)."""
    top = float(rate_squared(p, 0.0, P, E))
    return max(float(np.max(dtheta * dtheta, initial=0.0)), top, 1e-300)


def exact_error_series(scene: "Scene", traj: "Trajectory") -> np.ndarray:
    """|theta'^2 - theta'^2_exact(theta)| over the squared rate scale, per sample: the bar's rate
    against energy and momentum conservation at the run's own bar angle (step 4).

    theta'^2 rather than theta' because theta' is ill-conditioned at a turning point."""
    p = Params.of_scene(scene.params)
    q = scene.params
    P = float(momentum(p, q["theta0"], q["dx0"], q["dtheta0"]))
    E = float(energy(p, q["theta0"], q["dx0"], q["dtheta0"]))
    c = run_coordinates(traj)
    return np.abs(c["dtheta"] ** 2 - rate_squared(p, c["theta"], P, E)) / _scales(p, P, E, c["dtheta"])


def _vertical_rate(t, theta, dtheta) -> float:
    """|theta'| at the run's first crossing of the vertical (theta = 0 mod 2 pi), from the cubic
    Hermite interpolant of theta and theta' (NaN when the bar does not cross it)."""
    k0 = np.round(theta / (2.0 * np.pi)) * 2.0 * np.pi
    x = theta - k0
    s = np.sign(x)
    idx = np.nonzero((s[:-1] * s[1:] < 0) & (k0[:-1] == k0[1:]))[0]
    if not len(idx):
        return float("nan")
    k = idx[0]
    h = t[k + 1] - t[k]
    x1, x2, d1, d2 = x[k], x[k + 1], h * dtheta[k], h * dtheta[k + 1]
    tau = x1 / (x1 - x2)
    for _ in range(8):
        t2, t3 = tau * tau, tau**3
        pv = (2 * t3 - 3 * t2 + 1) * x1 + (t3 - 2 * t2 + tau) * d1 + (-2 * t3 + 3 * t2) * x2 + (t3 - t2) * d2
        dp = (6 * t2 - 6 * tau) * x1 + (3 * t2 - 4 * tau + 1) * d1 + (-6 * t2 + 6 * tau) * x2 + (3 * t2 - 2 * tau) * d2
        tau = min(max(tau - pv / dp, 0.0), 1.0)
    return float(abs(dp / h))


def exact_error(scene: "Scene", traj: "Trajectory", settings=None, run=None) -> tuple[float, str, str]:
    """The largest of three relative errors: (1) theta'^2 at every sample against its exact value
    at the run's own bar angle from energy and p_x conservation (step 4; at the vertical this is
    Problem 5.13), over the squared rate scale; (2) the drift of p_x = S x' + m l cos(theta)
    theta' (step 3) over S times the speed scale (the largest of |x'| and l |theta'|); (3) the
    out-of-plane motion of the planar scene: the tilt of the cylinder's axis from world -y (rad)
    and the largest |y| of the centres of mass over R. The detail adds the bar's rate at its first
    crossing of the vertical (cubic Hermite on the samples: a coarse measurement) against the
    closed form and the printed answer. ``settings`` and ``run`` are unused (no extra runs)."""
    p = Params.of_scene(scene.params)
    q = scene.params
    P = float(momentum(p, q["theta0"], q["dx0"], q["dtheta0"]))
    E = float(energy(p, q["theta0"], q["dx0"], q["dtheta0"]))
    c = run_coordinates(traj)
    err_rate = float(np.max(exact_error_series(scene, traj), initial=0.0))
    v_scale = max(float(np.max(np.abs(c["dx"]), initial=0.0)), p.l * float(np.max(np.abs(c["dtheta"]), initial=0.0)), 1e-300)
    err_p = float(np.max(np.abs(momentum(p, c["theta"], c["dx"], c["dtheta"]) - P), initial=0.0)) / (p.S * v_scale)
    tilt = float(np.max(c["tilt"], initial=0.0))
    lateral = float(np.max(c["y"], initial=0.0)) / p.R
    exact_v = rate_at_vertical(p, q["theta0"], q["dx0"], q["dtheta0"])
    run_v = _vertical_rate(traj.t, c["theta"], c["dtheta"])
    detail = (f"theta'^2 vs energy+p_x closed form {err_rate:.1e}; p_x drift {err_p:.1e}; out of plane: axis tilt "
              f"{tilt:.1e} rad, |y|/R {lateral:.1e}; bar rate at the vertical {exact_v:.6f} rad/s exact (printed "
              f"sqrt(21g/25R) = {textbook_rate(p.g, p.R):.6f} for M = 4m, L = 4R, a -> 0), run {run_v:.6f} "
              f"(first crossing, Hermite on the samples)")
    return max(err_rate, err_p, tilt, lateral), "rel", detail
