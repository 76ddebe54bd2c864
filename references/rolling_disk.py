"""Rolling disk: steady circular motion, stability of straight rolling, and the textbook's errata.

Textbook location
-----------------
Boström, *Rigid body dynamics*: Ex. 3.4.2 (l. 1735: Euler angles and rolling constraints of a
thin disk), Ex. 4.7.2 (l. 2414: steady circular motion), Ex. 5.2.3 (l. 2856: "Lagrange's
equations" of the rolling disk), Ex. 5.3.3 (l. 3003: stability of straight rolling).

System and conventions (SI units)
---------------------------------
A uniform disk: a solid cylinder of mass m, radius R and half-thickness h (h = 0: a thin disk);
centre A, transverse moment A_t = m (R^2/4 + h^2/3) and axial moment C = m R^2/2 about A
(``DiskParams`` takes any A_t, C). It rolls without slip on the plane z = 0 (gravity -g z) on
the lowest point of its lower rim edge. Euler angles 3-2-3 as in Ex. 3.4.2: phi (heading,
about Z), theta (angle of the symmetry axis from the vertical; pi/2 = upright), psi (spin).
Frame x'y'z' (follows phi and theta, not psi): z' the symmetry axis, x' in the disk plane
pointing down to the contact, y' horizontal. Angular velocity
``w = -phi' sin(theta) e_x' + theta' e_y' + w3 e_z'`` with the spin component
``w3 = psi' + phi' cos(theta)``. For 0 < theta < pi/2 (the axis tilted up, the disk leaning
toward -x' horizontally) the lower edge is the one at -h e_z'; then the offset from the contact
point C to the centre is constant in x'y'z'::

    rho = A - C = -R e_x' + h e_z'                            (theta > pi/2: h -> -h)

Derivation (numbered; not the textbook's route)
-----------------------------------------------
1. Rolling without slip: v_A = w x rho. The contact force F at C is an unknown.
2. Newton: m a_A = F - m g e_Z. Euler about A: dL_A/dt = (C - A) x F = -rho x F, so
   ``dL_A/dt + rho x m (a_A + g e_Z) = 0`` with L_A = (A_t w1, A_t w2, C w3) in x'y'z' and
   d/dt = (component rate) + Omega x, Omega = (-phi' s, theta', phi' c) the frame's rate.
3. The three components of step 2 are linear in (phi'', theta'', w3') and solve to
   (s = sin theta, c = cos theta, D = A_t C + A_t m R^2 + C m h^2)::

    phi''  = theta' [C (C + m R^2) w3 - phi' (2 A_t (C + m R^2) c + C m R h s + 2 C m h^2 c)] / (D s)
    theta'' = [phi'^2 ((A_t + m h^2) s c + m R h s^2) - phi' w3 ((C + m R^2) s + m R h c)
               - m g (R c - h s)] / (A_t + m R^2 + m h^2)
    w3'    = m R theta' (A_t R s phi' + C h w3) / D

   For h = 0 these are the classical (Appell/Routh) equations of the rolling disk:
   A_t (phi'' s + 2 phi' theta' c) = C w3 theta',  (C + m R^2) w3' = m R^2 phi' theta' s,
   (A_t + m R^2) theta'' = A_t phi'^2 s c - (C + m R^2) w3 phi' s - m g R c.
   (``euler_rhs``; derived once with a computer-algebra system, then checked against a
   maximal-coordinate Newton-Euler integration in ``tests/references/test_rolling_disk.py``.)
4. Centre velocity: ``v_A = w x rho = h theta' e_x' + (h phi' s - R w3) e_y' + R theta' e_z'``;
   at theta' = 0 it is horizontal.
5. Energy ``E = m |v_A|^2/2 + (A_t (w1^2 + w2^2) + C w3^2)/2 + m g (R s + h |c|)``: the contact
   force does no work (it acts at a point at rest), so E is conserved.

Steady circular motion (Ex. 4.7.2, corrected and extended to h > 0)
-------------------------------------------------------------------
theta' = 0, theta'' = 0 with constant phi' and w3: step 3's theta'' = 0 is linear in w3::

    w3 = [phi'^2 ((A_t + m h^2) s c + m R h s^2) - m g (R c - h s)] / (phi' ((C + m R^2) s + m R h c))

(``steady_spin``); phi'' = w3' = 0 hold identically. The centre moves on a circle of radius
``r_A = |h phi' s - R w3| / |phi'|`` at speed ``v = |h phi' s - R w3|``. For a thin uniform
disk with the textbook's signs (phi' = v/r, w3 = -v/R, beta = theta)::

    v^2 = 4 g r^2 cos(beta) / ((6 r + R cos(beta)) sin(beta))

**Printed** (Ex. 4.7.2): ``v = 4 g r^2 cos β / ((6r + R cos β) sin β)``: the right side has the
dimension of a speed squared (m^2/s^2); the printed v is v^2. The moment line prints
``(F_n r sin β − N r cos β) e_y'``: the lever arm of the contact force about A is R (the contact
point is at distance R from A), not r; the final formula follows from R, so only the
intermediate line is wrong. **Status:** final formula correct as v^2 (``printed_472``).

Stability of straight rolling (Ex. 5.3.3, corrected and extended to h > 0)
---------------------------------------------------------------------------
A thick disk rolls straight (phi' = 0, w3 = Omega, speed v = R |Omega|) on one rim edge only
at the balance tilt where the centre is right above the contact point: -R c + h s = 0, i.e.
``theta* = atan(R/h)`` (a lean of atan(h/R) from upright; theta* = pi/2 for h = 0). With
theta = theta* + xi, l = sqrt(R^2 + h^2) = |rho| and small xi, phi', w3 - Omega, step 3 gives::

    (A_t + m l^2) xi'' = m g l xi - Omega (R/l) (C + m l^2) phi'
    phi'' = Omega C (C + m R^2) l / (R D) xi'      =>  phi' = Omega C (C + m R^2) l/(R D) xi + const
    (A_t + m l^2) xi'' + [Omega^2 C (C + m R^2)(C + m l^2)/D - m g l] xi = const

so straight rolling is stable iff (``critical_spin``, ``critical_speed``)::

    Omega^2 > Omega_c^2 = m g l D / (C (C + m R^2)(C + m l^2)),     v_c = R Omega_c

For h = 0: Omega_c^2 = m g R A_t / (C (C + m R^2)); a thin uniform disk: v_c^2 = g R / 3,
``v_c = sqrt(g R / 3)`` = 0.2140 m/s for R = 14 mm, g = 9.81 m/s^2 (R = 14 mm, h = 1 mm:
0.2153 m/s). Above v_c the lean oscillates at
``w_osc^2 = (Omega^2 C (C + m R^2)(C + m l^2)/D - m g l) / (A_t + m l^2)``; below it grows at
``sqrt(-w_osc^2)`` (``straight_rolling_rate``).

**Printed** (Ex. 5.3.3): ``v > sqrt(g R)/3`` (0.12 m/s for R = 14 mm), from the linearised
equations ``phi'' - 6 (v/R) xi' = 0``, ``5 xi'' + 6 (v/R) phi' - 4 (g/R) xi = 0``. The lean
equation is right; the heading equation is wrong (correct: ``phi'' = 2 (v/R) xi'``, i.e.
C/A_t = 2 instead of 6). It comes from Ex. 5.2.3, which substitutes the nonholonomic rolling
constraint into the kinetic energy and then applies Lagrange's equations to phi, theta, psi as
if they were free coordinates (Ex. 5.2.1 itself warns that this is not allowed); that makes phi
and psi cyclic with the wrong "conserved" momenta dT/dphi' and dT/dpsi', and its yaw and spin
equations are wrong (``printed_523_rhs``). **Status:** threshold wrong;
v_c,printed / v_c = 1/sqrt(3) for a thin disk (``printed_critical_speed``).

Also in Ex. 5.2.3: dT/dtheta is printed with the wrong sign of its first term and the theta
equation's gravity term reads "4 (4g/R) cos θ" (OCR of 4 (g/R) cos θ); the theta equation of
the wrong Lagrangian is otherwise the same as the correct one.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from harness.model import rotations

if TYPE_CHECKING:  # pragma: no cover
    from harness.measure.trajectory import Trajectory
    from harness.model.scene import Scene


@dataclass(frozen=True)
class DiskParams:
    """Mass m (kg), rim radius R (m), half-thickness h (m, >= 0), gravity g (m/s^2), and the
    moments about the centre: transverse ``At`` and axial ``C`` (kg m^2; default: a uniform
    solid cylinder)."""

    m: float
    R: float
    h: float
    g: float
    At: float | None = None
    C: float | None = None

    def __post_init__(self):
        if self.At is None:
            object.__setattr__(self, "At", self.m * (self.R**2 / 4.0 + self.h**2 / 3.0))
        if self.C is None:
            object.__setattr__(self, "C", 0.5 * self.m * self.R**2)

    @property
    def D(self) -> float:
        return self.At * self.C + self.At * self.m * self.R**2 + self.C * self.m * self.h**2


def _edge(p: DiskParams, theta: float) -> float:
    """Signed half-thickness of the lower edge: +h for theta < pi/2, -h for theta > pi/2."""
    return p.h * float(np.sign(np.cos(theta)))


def euler_rhs(p: DiskParams):
    """``f(t, y)`` for y = [phi, theta, psi, phi', theta', w3, X_A, Y_A] (rad, rad/s, m): the
    correct equations of step 3 (module docstring), plus the centre's horizontal position."""
    m, R, g, At, C = p.m, p.R, p.g, p.At, p.C

    def f(t, y):
        phi, th, psi, dph, dth, w3 = y[:6]
        h = _edge(p, th)
        D_ = At * C + At * m * R * R + C * m * h * h
        s, c = np.sin(th), np.cos(th)
        ddph = dth * (C * (C + m * R * R) * w3 - dph * (2 * At * (C + m * R * R) * c + C * m * R * h * s
                                                        + 2 * C * m * h * h * c)) / (D_ * s)
        ddth = (dph**2 * ((At + m * h * h) * s * c + m * R * h * s * s) - dph * w3 * ((C + m * R * R) * s + m * R * h * c)
                - m * g * (R * c - h * s)) / (At + m * R * R + m * h * h)
        dw3 = m * R * dth * (At * R * s * dph + C * h * w3) / D_
        v_A = centre_velocity(p, th, phi, dph, dth, w3)
        return np.array([dph, dth, w3 - dph * c, ddph, ddth, dw3, v_A[0], v_A[1]])

    return f


def frame(theta: float, phi: float) -> np.ndarray:
    """Columns e_x', e_y', e_z' (world) of the frame x'y'z'."""
    s, c, sp, cp = np.sin(theta), np.cos(theta), np.sin(phi), np.cos(phi)
    return np.array([[c * cp, -sp, s * cp], [c * sp, cp, s * sp], [-s, 0.0, c]])


def centre_velocity(p: DiskParams, theta: float, phi: float, dphi: float, dtheta: float, w3: float) -> np.ndarray:
    """v_A = w x rho (m/s, world), rho = -R e_x' + h_edge e_z'."""
    E = frame(theta, phi)
    w = np.array([-dphi * np.sin(theta), dtheta, w3])
    rho = np.array([-p.R, 0.0, _edge(p, theta)])
    return E @ np.cross(w, rho)


def energy(p: DiskParams, theta: float, dphi: float, dtheta: float, w3: float) -> float:
    """Total energy (J): kinetic plus m g z_A, z_A = R sin(theta) + h |cos(theta)|."""
    v = centre_velocity(p, theta, 0.0, dphi, dtheta, w3)
    w1, w2 = -dphi * np.sin(theta), dtheta
    z = p.R * np.sin(theta) + p.h * abs(np.cos(theta))
    return 0.5 * p.m * v @ v + 0.5 * (p.At * (w1 * w1 + w2 * w2) + p.C * w3 * w3) + p.m * p.g * z


def steady_spin(p: DiskParams, theta: float, dphi: float) -> float:
    """Spin component w3 (rad/s) of steady circular motion at tilt theta (rad) and heading rate
    dphi (rad/s, nonzero); psi' = w3 - dphi cos(theta)."""
    m, R, g, At, C = p.m, p.R, p.g, p.At, p.C
    h = _edge(p, theta)
    s, c = np.sin(theta), np.cos(theta)
    return (dphi**2 * ((At + m * h * h) * s * c + m * R * h * s * s) - m * g * (R * c - h * s)) / (
        dphi * ((C + m * R * R) * s + m * R * h * c))


def steady_motion(p: DiskParams, theta: float, dphi: float) -> dict[str, float]:
    """Steady circular motion at (theta, dphi): ``w3``, ``dpsi`` (rad/s), centre ``speed``
    (m/s) and ``radius`` of the centre's circle (m), and the ``contact_radius`` of the contact
    point's circle (m), the circles' common centre lying on the side the disk leans to."""
    w3 = steady_spin(p, theta, dphi)
    h = _edge(p, theta)
    vy = h * dphi * np.sin(theta) - p.R * w3
    # horizontal offset of C from A along the horizontal of e_x': R cos(theta) - h sin(theta)
    offset = p.R * np.cos(theta) - h * np.sin(theta)
    radius = abs(vy / dphi)
    return {"w3": w3, "dpsi": w3 - dphi * np.cos(theta), "speed": abs(vy), "radius": radius,
            "contact_radius": abs(vy / dphi + offset)}  # circle centre at A - (vy/dphi) e_h, C at A + offset e_h


def printed_472(g: float, r: float, R: float, beta: float) -> float:
    """Ex. 4.7.2 as printed: ``4 g r^2 cos β / ((6r + R cos β) sin β)`` (its dimension is m^2/s^2:
    it is the speed squared of the centre, r the radius of the centre's circle, thin disk)."""
    return 4.0 * g * r * r * np.cos(beta) / ((6.0 * r + R * np.cos(beta)) * np.sin(beta))


def balance_tilt(R: float, h: float) -> float:
    """theta* = atan(R/h) (rad): the axis tilt at which a thick disk balances on one rim edge,
    centre right above the contact (pi/2 for h = 0)."""
    return float(np.arctan2(R, h))


def critical_spin(p: DiskParams) -> float:
    """Omega_c (rad/s): straight rolling on one edge at theta* is stable iff |w3| > Omega_c."""
    l2 = p.R**2 + p.h**2
    return float(np.sqrt(p.m * p.g * np.sqrt(l2) * p.D / (p.C * (p.C + p.m * p.R**2) * (p.C + p.m * l2))))


def critical_speed(p: DiskParams) -> float:
    """v_c = R Omega_c (m/s); sqrt(g R / 3) for a thin uniform disk."""
    return p.R * critical_spin(p)


def straight_rolling_rate(p: DiskParams, speed: float) -> float:
    """w_osc^2 (1/s^2) of the lean about straight rolling at ``speed`` (m/s): positive, the lean
    oscillates at that angular frequency; negative, it grows at sqrt(-w_osc^2)."""
    m, R, C, D = p.m, p.R, p.C, p.D
    l2 = R**2 + p.h**2
    omega = speed / R
    stiff = omega**2 * C * (C + m * R**2) * (C + m * l2) / D - m * p.g * np.sqrt(l2)
    return float(stiff / (p.At + m * l2))


def printed_critical_speed(g: float, R: float) -> float:
    """Ex. 5.3.3 as printed: v > sqrt(g R)/3 (wrong; see module docstring)."""
    return float(np.sqrt(g * R) / 3.0)


def printed_523_rhs(g: float, R: float):
    """``f(t, y)``, y = [phi, theta, psi, phi', theta', psi']: the equations printed in
    Ex. 5.2.3 (thin uniform disk; wrong: the constraint substituted into T)::

        phi'' (1 + 5 c^2) - 10 phi' theta' c s + 6 psi'' c - 6 theta' psi' s = 0
        psi'' + phi'' c - phi' theta' s = 0
        5 theta'' + 5 phi'^2 c s + 6 phi' psi' s + 4 (g/R) c = 0
    """

    def f(t, y):
        phi, th, psi, dph, dth, dps = y
        s, c = np.sin(th), np.cos(th)
        ddth = -(5 * dph**2 * c * s + 6 * dph * dps * s + 4 * g / R * c) / 5.0
        # psi'' = phi' theta' s - phi'' c ; substitute in the first equation
        ddph = (10 * dph * dth * c * s + 6 * dth * dps * s - 6 * c * dph * dth * s) / (1 + 5 * c * c - 6 * c * c)
        ddps = dph * dth * s - ddph * c
        return np.array([dph, dth, dps, ddph, ddth, ddps])

    return f


# ---------------------------------------------------------------------------------------------
# Exact check of a run (``harness.measure.exact``)
# ---------------------------------------------------------------------------------------------
EXACT_NEEDS_RUNS = False  # the run itself is judged: no extra runs


def _scene_steady(scene: "Scene") -> tuple[DiskParams, dict | None, str]:
    """The scene's disk, its steady circular motion, and "" -- or (disk, None, why) when the
    scene's initial state is not a steady motion (needs dphi0 != 0, dtheta0 = 0 and dpsi0 the
    steady spin for theta0, dphi0)."""
    p = scene.params
    disk = DiskParams(p["mass"], p["R"], p["h"], p["g"])
    theta0, dphi0 = p["theta0"], p["dphi0"]
    if dphi0 == 0.0 or p["dtheta0"] != 0.0:
        return disk, None, "no closed form: the initial state is not a steady circular motion (needs dphi0 != 0, dtheta0 = 0)"
    steady = steady_motion(disk, theta0, dphi0)
    if abs(p["dpsi0"] - steady["dpsi"]) > 1e-9 * max(1.0, abs(steady["dpsi"])):
        return disk, None, (f"no closed form: dpsi0 = {p['dpsi0']:.10g} rad/s is not the steady spin "
                            f"{steady['dpsi']:.15g} rad/s for theta0 = {theta0:g}, dphi0 = {dphi0:g}")
    return disk, steady, ""


def _lean(traj: "Trajectory") -> np.ndarray:
    """theta(t): the angle of the run's symmetry axis (body z) from the vertical (rad)."""
    R = rotations.matrix(traj.quat_WB[:, 0])
    return np.arccos(np.clip(R[:, 2, 2], -1.0, 1.0))


def exact_error_series(scene: "Scene", traj: "Trajectory") -> np.ndarray:
    """|theta(t) - theta0| (rad), the lean of the symmetry axis from the vertical against the
    steady circular motion's constant lean (Ex. 4.7.2).

    Raises ValueError when the scene's initial state is not a steady motion."""
    _, steady, why = _scene_steady(scene)
    if steady is None:
        raise ValueError(why)
    return np.abs(_lean(traj) - scene.params["theta0"])


def exact_error(scene: "Scene", traj: "Trajectory", settings=None, run=None) -> tuple[float, str, str]:
    """Steady circular motion (Ex. 4.7.2): max |theta(t) - theta0| (rad), theta the angle of the
    symmetry axis from the vertical; the detail adds the centre's distance from the exact circle.
    NaN unless the scene's initial state is a steady motion (dpsi0 = the steady spin).
    ``settings`` and ``run`` are unused (no extra runs)."""
    p = scene.params
    theta0, dphi0 = p["theta0"], p["dphi0"]
    _, steady, why = _scene_steady(scene)
    if steady is None:
        return float("nan"), "rad", why
    theta = _lean(traj)
    # circle centre: A0 - (v_y'/dphi) e_h at t = 0, e_h the horizontal of e_x' (phi0 = 0)
    e = frame(theta0, 0.0)
    vy = float(traj.v_WCm_W[0, 0] @ e[:, 1])
    centre = traj.p_WCm_W[0, 0, :2] - (vy / dphi0) * np.array([1.0, 0.0])
    radius = np.linalg.norm(traj.p_WCm_W[:, 0, :2] - centre, axis=-1)
    return (float(np.max(np.abs(theta - theta0))), "rad",
            f"lean (axis from vertical) vs constant theta0 = {theta0:g} rad; centre's circle radius "
            f"{steady['radius']:.6g} m exact, max deviation {np.max(np.abs(radius - steady['radius'])):.2e} m; "
            f"speed {steady['speed']:.6g} m/s")
