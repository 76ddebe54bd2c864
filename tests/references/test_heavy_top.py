"""Heavy symmetric top (``references/heavy_top.py``) against an independent tight integration.

Every ODE below is written here, independently of the reference module and of the harness
engines, and integrated with scipy DOP853 at rtol = atol = 1e-12.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from harness.model import rotations
from harness.references import heavy_top as ht

TOL = dict(method="DOP853", rtol=1e-12, atol=1e-12)


def _top_rhs(t, y, m, l, A, I3, g):
    R = y[:9].reshape(3, 3)
    w = y[9:]
    Ib = np.array([A, A, I3])
    g_b = R[2, :]  # world z in body coordinates
    tau = rotations.cross(np.array([0.0, 0.0, l]), -m * g * g_b)  # moment of gravity about the tip
    wd = (rotations.cross(Ib * w, w) + tau) / Ib  # Euler's equations about the fixed tip
    W = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    return np.concatenate([(R @ W).ravel(), wd])  # Ṙ = R [ω]×


def _integrate_top(p, R0, w0, T, n=801):
    tt = np.linspace(0.0, T, n)
    args = (p.mass, p.l, p.I1 + p.mass * p.l**2, p.I3, p.g)
    sol = solve_ivp(_top_rhs, (0.0, T), np.concatenate([np.ravel(R0), w0]), t_eval=tt,
                    args=args, **TOL)
    assert sol.success
    R = sol.y[:9].T.reshape(-1, 3, 3)
    return tt, R, sol.y[9:].T


def _rot(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


P0 = ht.TopParams(mass=1.0, l=0.1, I1=0.004, I3=0.006, g=9.81)
TILT = ht.tilt_about_y(0.5)
TOP_CASES = {
    "default": (P0, TILT, (0.0, 0.0, 50.0), 2.0),
    "transverse": (P0, TILT, (3.0, -2.0, 40.0), 2.0),  # u̇(0) > 0
    "udot_negative": (P0, TILT, (0.0, 2.0, 10.0), 2.0),  # u̇(0) < 0
    "slow_top": (P0, TILT, (0.0, 0.0, 5.0), 3.0),  # big nutation, almost to the bottom
    "slow_top_negative_spin": (P0, TILT, (0.0, 0.0, -5.0), 3.0),
    "no_spin_pendulum": (P0, TILT, (0.0, 0.0, 0.0), 3.0),  # swings through θ = π
    "below_horizontal": (P0, ht.tilt_about_y(2.5), (1.0, 0.3, 20.0), 2.0),
    "near_vertical": (P0, ht.tilt_about_y(1e-3), (0.0, 0.0, 50.0), 1.0),
    "vertical_with_transverse_w": (P0, np.eye(3), (1.0, 0.0, 50.0), 1.0),
    "general_R0": (ht.TopParams(2.0, 0.05, 0.01, 0.003, 9.81),
                   _rot((0.3, -0.8, 0.2), 1.1), (1.5, -0.7, 30.0), 2.0),
    "com_below_tip": (ht.TopParams(l=-0.1), ht.tilt_about_y(2.5), (1.0, 0.3, 20.0), 2.0),
    "com_below_tip_udot_neg": (ht.TopParams(l=-0.1), TILT, (0.0, 2.0, 10.0), 2.0),
    "near_steady": (P0, ht.steady_precession_state(P0, 0.5, 50.0)[0],
                    ht.steady_precession_state(P0, 0.5, 50.0)[1] + np.array([0.0, 1e-3, 0.0]),
                    2.0),
    "zero_gravity": (ht.TopParams(g=0.0), TILT, (3.0, -2.0, 40.0), 2.0),
    "zero_gravity_no_spin": (ht.TopParams(g=0.0), TILT, (3.0, 1.0, 0.0), 2.0),
}


@pytest.mark.parametrize("name", list(TOP_CASES))
def test_heavy_top_cos_theta_matches_integration(name):
    p, R0, w0, T = TOP_CASES[name]
    w0 = np.array(w0)
    tt, R, _ = _integrate_top(p, R0, w0, T)
    u_num = R[:, 2, 2]  # e3·ẑ
    u_ref = ht.cos_theta(tt, p, R0, w0)
    assert np.abs(u_ref - u_num).max() < 2e-10
    # nutation bounds enclose the motion and are reached (sampling resolution)
    th_min, th_max = ht.nutation_bounds(p, R0, w0)
    th = np.arccos(np.clip(u_num, -1, 1))
    assert th.min() >= th_min - 1e-7 and th.max() <= th_max + 1e-7
    dense = ht.cos_theta(np.linspace(0, T, 200001), p, R0, w0)
    u1, u2, u3 = ht.nutation_roots(p, R0, w0)
    assert dense.min() == pytest.approx(u1, abs=1e-8)
    assert dense.max() == pytest.approx(u2, abs=1e-8)
    if p.g == 0.0:
        assert u3 == np.inf


@pytest.mark.parametrize("name", ["default", "transverse", "general_R0", "slow_top"])
def test_heavy_top_conserved_and_udot(name):
    p, R0, w0, T = TOP_CASES[name]
    w0 = np.array(w0)
    tt, R, W = _integrate_top(p, R0, w0, T, n=51)
    E0, Lz0, L30 = ht.conserved(p, R0, w0)
    A = p.I1 + p.mass * p.l**2
    for Rk, wk in zip(R, W):
        Lb = np.array([A * wk[0], A * wk[1], p.I3 * wk[2]])
        E = 0.5 * wk @ Lb + p.mass * p.g * p.l * Rk[2, 2]
        assert E == pytest.approx(E0, rel=1e-10, abs=1e-12)
        assert (Rk @ Lb)[2] == pytest.approx(Lz0, rel=1e-10, abs=1e-12)
        assert p.I3 * wk[2] == pytest.approx(L30, rel=1e-10, abs=1e-12)
    # u̇(0) from the kinematics ė3 = ω_W × e3 against a central difference of the integration
    h = 1e-6
    _, Rh, _ = _integrate_top(p, R0, w0, h, n=2)
    _, Rmh, _ = _integrate_top(p, R0, w0, -h, n=2)
    assert ht.u_dot0(R0, w0) == pytest.approx((Rh[1, 2, 2] - Rmh[1, 2, 2]) / (2 * h), abs=1e-7)
    e3 = R0[:, 2]
    assert ht.u_dot0(R0, w0) == pytest.approx(np.cross(R0 @ w0, e3)[2], abs=1e-14)


@pytest.mark.parametrize("branch, T", [("slow", 2.0), ("fast", 0.5)])
def test_heavy_top_steady_precession(branch, T):
    R0, w0 = ht.steady_precession_state(P0, 0.5, 50.0, branch)
    slow, fast = ht.steady_precession_rates(P0, 0.5, 50.0)
    rate = slow if branch == "slow" else fast
    A, L3, mgl = P0.I1 + P0.mass * P0.l**2, P0.I3 * 50.0, P0.mass * P0.g * P0.l
    for r in (slow, fast):  # A cos θ φ̇² − L3 φ̇ + m g l = 0
        assert abs(A * np.cos(0.5) * r * r - L3 * r + mgl) < 1e-12 * L3 * abs(r)
    assert mgl / L3 < slow < 2 * mgl / L3 < fast  # slow → m g l / L3 for a fast top
    tt, R, _ = _integrate_top(P0, R0, w0, T)
    u_num = R[:, 2, 2]
    assert np.abs(u_num - np.cos(0.5)).max() < 1e-10  # θ stays constant
    th_min, th_max = ht.nutation_bounds(P0, R0, w0)
    assert th_min == pytest.approx(0.5, abs=1e-12) and th_max == pytest.approx(0.5, abs=1e-12)
    assert np.abs(ht.cos_theta(tt, P0, R0, w0) - np.cos(0.5)).max() < 1e-14
    e3 = R[:, :, 2]
    phi = np.unwrap(np.arctan2(e3[:, 1], e3[:, 0]))
    assert np.polyfit(tt, phi, 1)[0] == pytest.approx(rate, rel=1e-9)
    assert np.allclose(ht.azimuth_rate(tt, P0, R0, w0), rate, rtol=1e-12)


@pytest.mark.parametrize("name", ["default", "transverse", "general_R0", "zero_gravity"])
def test_heavy_top_azimuth_rate(name):
    p, R0, w0, T = TOP_CASES[name]
    w0 = np.array(w0)
    tt, R, W = _integrate_top(p, R0, w0, T, n=201)
    e3 = R[:, :, 2]
    ew = np.einsum("nij,nj->ni", R, W)  # ω in the world frame
    e3dot = np.cross(ew, e3)
    phidot_num = (e3[:, 0] * e3dot[:, 1] - e3[:, 1] * e3dot[:, 0]) / (e3[:, 0]**2 + e3[:, 1]**2)
    phidot_ref = ht.azimuth_rate(tt, p, R0, w0)
    assert np.abs(phidot_ref - phidot_num).max() < 1e-8 * max(1.0, np.abs(phidot_num).max())


@pytest.mark.parametrize("R0, sign", [(np.eye(3), 1.0), (ht.tilt_about_y(np.pi), -1.0)])
def test_heavy_top_sleeping_and_hanging(R0, sign):
    w0 = np.array([0.0, 0.0, 50.0])
    tt, R, _ = _integrate_top(P0, R0, w0, 1.0, n=101)
    assert np.abs(R[:, 2, 2] - sign).max() < 1e-12
    assert np.all(ht.cos_theta(tt, P0, R0, w0) == R0[2, 2])
    th = 0.0 if sign > 0 else np.pi
    assert ht.nutation_bounds(P0, R0, w0) == pytest.approx((th, th), abs=1e-7)
    assert np.all(np.isnan(ht.azimuth_rate(tt, P0, R0, w0)))
