"""harness.references.rolling_disk against an independent integration written here: Newton-Euler of the
disk in maximal coordinates (rotation matrix, world angular velocity) with the contact force
solved from the no-slip condition at acceleration level (3x3 solve), the contact point's motion
by central differences, SciPy DOP853 at tight tolerances. No code shared with the harness or the
reference's Euler-angle equations. Last, the exact check of a run (``exact_error``): it applies to
steady initial states only."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from harness.references import rolling_disk as rd

M, R14, G = 0.0075, 0.014, 9.81


def _skew(a):
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def _rot(axis, angle):
    K = _skew(np.asarray(axis, float) / np.linalg.norm(axis))
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def _offset(Rm, R, h):
    """Centre -> lowest point of the lower edge circle, by minimising over the two circles."""
    n = Rm[:, 2]
    best = None
    for side in (1.0, -1.0):
        e1, e2 = Rm[:, 0], Rm[:, 1]
        # lowest point of the circle c + R (cos a e1 + sin a e2): a = atan2(-e2z, -e1z)
        a = np.arctan2(-e2[2], -e1[2])
        p = side * h * n + R * (np.cos(a) * e1 + np.sin(a) * e2)
        if best is None or p[2] < best[2] - 1e-15:
            best = p
    return best


class Disk:
    def __init__(self, m, R, h, g):
        self.m, self.R, self.h, self.g = m, R, h, g
        At, C = m * (R * R / 4 + h * h / 3), m * R * R / 2
        self.I = np.diag([At, At, C])

    def rhs(self, t, y):
        Rm, v, w = y[3:12].reshape(3, 3), y[12:15], y[15:18]
        U, _, Vt = np.linalg.svd(Rm)
        Rm = U @ Vt
        r = _offset(Rm, self.R, self.h)
        eps, wn = 1e-6, np.linalg.norm(w)
        rd_ = (_offset(_rot(w, eps * wn) @ Rm, self.R, self.h) - _offset(_rot(w, -eps * wn) @ Rm, self.R, self.h)) / (2 * eps)
        Iw, Iinv = Rm @ self.I @ Rm.T, Rm @ np.linalg.inv(self.I) @ Rm.T
        g = np.array([0.0, 0.0, -self.g])
        alpha0 = -Iinv @ np.cross(w, Iw @ w)
        K = np.eye(3) / self.m - _skew(r) @ Iinv @ _skew(r)
        F = np.linalg.solve(K, -np.cross(w, rd_) - g - np.cross(alpha0, r))
        return np.concatenate([v, (_skew(w) @ Rm).ravel(), g + F / self.m, alpha0 + Iinv @ np.cross(r, F)])

    def state(self, theta, dphi, dtheta, dpsi):
        Rm = _rot([0, 1, 0], theta)
        w = dphi * np.array([0, 0, 1.0]) + dtheta * Rm[:, 1] + dpsi * Rm[:, 2]
        r = _offset(Rm, self.R, self.h)
        return np.concatenate([-r, Rm.ravel(), -np.cross(w, r), w])

    def run(self, y0, t_end, n=101):
        ts = np.linspace(0, t_end, n)
        sol = solve_ivp(self.rhs, (0, t_end), y0, method="DOP853", rtol=1e-11, atol=1e-13, t_eval=ts)
        assert sol.success
        return sol.t, sol.y


def _theta(y):
    return np.arccos(np.clip(y[11], -1, 1))


@pytest.mark.parametrize("h", [0.0, 0.001])
def test_steady_circular_motion_keeps_the_lean(h):
    p = rd.DiskParams(M, R14, h, G)
    theta, dphi = 1.2, 5.0
    steady = rd.steady_motion(p, theta, dphi)
    disk = Disk(M, R14, h, G)
    t, y = disk.run(disk.state(theta, dphi, 0.0, steady["dpsi"]), 0.5)
    assert np.max(np.abs(_theta(y) - theta)) < 1e-8
    speed = np.linalg.norm(y[12:15], axis=0)
    assert np.max(np.abs(speed - steady["speed"])) < 1e-8
    # the centre's circle: centre of the circle = A0 - (v_y'/dphi) e_x(horizontal)
    vy = y[12:15, 0] @ np.array([0.0, 1.0, 0.0])
    centre = y[:2, 0] - vy / dphi * np.array([1.0, 0.0])
    assert np.max(np.abs(np.linalg.norm(y[:2].T - centre, axis=1) - steady["radius"])) < 1e-9
    # the contact point runs on the concentric circle of contact_radius
    C = np.array([y[:3, k] + _offset(y[3:12, k].reshape(3, 3), R14, h) for k in range(len(t))])
    assert np.max(np.abs(np.linalg.norm(C[:, :2] - centre, axis=1) - steady["contact_radius"])) < 1e-9
    assert np.max(np.abs(C[:, 2])) < 1e-10
    # energy: no work at the contact, and the reference's formula
    E = [0.5 * M * y[12:15, k] @ y[12:15, k] + 0.5 * y[15:18, k] @ (y[3:12, k].reshape(3, 3) @ disk.I @ y[3:12, k].reshape(3, 3).T)
         @ y[15:18, k] + M * G * y[2, k] for k in range(len(t))]
    assert np.ptp(E) / E[0] < 1e-8  # the finite-difference contact-point rate and the unprojected R limit this
    assert abs(E[0] - rd.energy(p, theta, dphi, 0.0, steady["w3"])) < 1e-12 * E[0]


def test_ex_472_printed_formula_is_the_speed_squared():
    p = rd.DiskParams(M, R14, 0.0, G)
    for beta, dphi in [(1.2, 5.0), (0.9, 8.0), (1.45, 3.0)]:
        s = rd.steady_motion(p, beta, dphi)
        assert rd.printed_472(G, s["radius"], R14, beta) == pytest.approx(s["speed"] ** 2, rel=1e-12)


def test_euler_angle_equations_match_newton_euler():
    """A free transient (tilt rate, heading rate, spin) of a thick disk: the reference's
    Euler-angle equations against the maximal-coordinate integration."""
    p = rd.DiskParams(M, R14, 0.001, G)
    th0, dph0, dth0, dps0 = 1.1, 2.0, 0.5, -30.0
    disk = Disk(M, R14, 0.001, G)
    t, y = disk.run(disk.state(th0, dph0, dth0, dps0), 0.4, 41)
    w3 = dps0 + dph0 * np.cos(th0)
    x0 = np.concatenate([[0.0, th0, 0.0, dph0, dth0, w3], disk.state(th0, dph0, dth0, dps0)[:2]])
    sol = solve_ivp(rd.euler_rhs(p), (0, 0.4), x0, method="DOP853", rtol=1e-12, atol=1e-14, t_eval=t)
    assert np.max(np.abs(sol.y[1] - _theta(y))) < 1e-8
    assert np.max(np.abs(sol.y[6:8] - y[:2])) < 1e-9
    n = y[[5, 8, 11]]  # axis = third column of R
    assert np.max(np.abs(np.unwrap(np.arctan2(n[1], n[0])) - sol.y[0])) < 1e-8


def _jacobian(f, x, eps=1e-7):
    return np.stack([(f(0, x + eps * e) - f(0, x - eps * e)) / (2 * eps) for e in np.eye(len(x))], axis=1)


@pytest.mark.parametrize("h", [0.0, 0.001, 0.004])
def test_critical_speed_is_the_linearisation_of_the_correct_equations(h):
    p = rd.DiskParams(M, R14, h, G)
    ts = rd.balance_tilt(R14, h)
    for v in (0.8 * rd.critical_speed(p), 1.3 * rd.critical_speed(p)):
        x = np.array([0.0, ts, 0.0, 0.0, 0.0, -v / R14, 0.0, 0.0])
        A = _jacobian(rd.euler_rhs(p), x)[np.ix_([1, 3, 4], [1, 3, 4])]  # (theta, phi', theta')
        lam = np.linalg.eigvals(A)
        w2 = rd.straight_rolling_rate(p, v)
        big = lam[np.argmax(np.abs(lam))]
        assert big**2 == pytest.approx(-w2, rel=1e-5)
    if h == 0.0:
        assert rd.critical_speed(p) == pytest.approx(np.sqrt(G * R14 / 3), rel=1e-14)


def test_printed_threshold_follows_from_the_printed_equations_and_the_dynamics_contradict_it():
    assert rd.printed_critical_speed(G, R14) == pytest.approx(0.1235, abs=1e-4)  # "0.12 m/s"
    assert rd.critical_speed(rd.DiskParams(M, R14, 0.0, G)) == pytest.approx(0.2140, abs=1e-4)
    f = rd.printed_523_rhs(G, R14)
    for v, stable in ((0.11, False), (0.14, True), (0.17, True)):
        x = np.array([0.0, np.pi / 2, 0.0, 0.0, 0.0, v / R14])
        A = _jacobian(f, x)[np.ix_([1, 3, 4], [1, 3, 4])]
        assert (np.max(np.linalg.eigvals(A).real) < 1e-6) == stable
    # the correct dynamics (maximal coordinates, thin disk): at 0.17 m/s the disk falls, at 0.26 it rolls on
    disk = Disk(M, R14, 0.0, G)
    for v, falls in ((0.17, True), (0.26, False)):
        _, y = disk.run(disk.state(np.pi / 2 - 1e-3, 0.0, 0.0, -v / R14), 0.6, 61)
        assert (np.max(np.abs(_theta(y) - np.pi / 2)) > 0.05) == falls


def test_ex_523_printed_equations_disagree_with_newton_euler():
    """The printed Ex. 5.2.3 equations (constraint substituted into T) against the thin disk's
    Newton-Euler motion: the printed spin equation keeps w3 = psi' + phi' cos(theta) constant; the
    true w3 changes ((C + m R^2) w3' = m R^2 phi' theta' sin(theta)), and the lean parts."""
    th0, dph0, dth0, dps0 = 1.1, 2.0, 0.5, -30.0
    disk = Disk(M, R14, 0.0, G)
    t, y = disk.run(disk.state(th0, dph0, dth0, dps0), 0.3, 31)
    w3_true = np.einsum("it,it->t", y[15:18], y[[5, 8, 11]])  # w . axis
    sol = solve_ivp(rd.printed_523_rhs(G, R14), (0, 0.3), [0.0, th0, 0.0, dph0, dth0, dps0], method="DOP853",
                    rtol=1e-12, atol=1e-14, t_eval=t)
    w3_printed = sol.y[5] + sol.y[3] * np.cos(sol.y[1])
    assert np.ptp(w3_printed) < 1e-8 * abs(w3_printed[0])
    assert np.ptp(w3_true) > 0.5
    assert np.max(np.abs(sol.y[1] - _theta(y))) > 0.05


def test_exact_check_needs_a_steady_initial_state():
    from harness.engines import get_engine
    from harness.engines.base import RunSettings
    from harness.engines import load_scene

    scene = load_scene("rolling_disk")
    settings = RunSettings(0.05, scene.dt, 0.01, scene.integrators["mujoco"])
    traj = get_engine("mujoco").simulate(scene, settings)
    value, unit, detail = rd.exact_error(scene, traj, settings, None)
    assert unit == "rad" and value < 1e-3 and value == float(np.max(rd.exact_error_series(scene, traj)))
    leaning = scene.with_params(theta0=1.1, dpsi0=scene.params["dpsi0"])  # dpsi0 set: no longer the steady spin
    value, _, detail = rd.exact_error(leaning, traj, settings, None)
    assert np.isnan(value) and "not the steady spin" in detail
    with pytest.raises(ValueError, match="not the steady spin"):
        rd.exact_error_series(leaning, traj)
