"""Closed-form references (package ``references``) against independent tight integrations.

Every ODE below is written here, independently of the reference modules and of the harness
engines, and integrated with scipy DOP853 at rtol = atol = 1e-12.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.special import ellipj as scipy_ellipj

from harness.references import double_pendulum as dp
from harness.references import heavy_top as ht
from harness.references import torque_free as tf

TOL = dict(method="DOP853", rtol=1e-12, atol=1e-12)


# =============================================================================================
# torque-free rigid body
# =============================================================================================
def _euler_rhs(t, w, I):
    # I ω̇ = (I ω) × ω, body frame, principal axes
    return np.cross(I * w, w) / I


def _integrate_euler(I, w0, T, n=401):
    tt = np.linspace(0.0, T, n)
    sol = solve_ivp(_euler_rhs, (0.0, T), w0, t_eval=tt, args=(I,), **TOL)
    assert sol.success
    return tt, sol.y.T


TORQUE_FREE_CASES = [
    # (I, omega0, T, tol) -- tol on max|Δω|/|ω0|
    ((1.0, 2.0, 3.0), (1.0, 0.5, 2.0), 20.0, 1e-10),  # M² > 2E I_mid
    ((1.0, 2.0, 3.0), (2.0, 0.5, 0.3), 20.0, 1e-10),  # M² < 2E I_mid
    ((3.0, 2.0, 1.0), (0.3, -1.0, 0.2), 20.0, 1e-10),  # reversed order
    ((2.0, 1.0, 3.0), (-0.4, 1.3, -0.7), 20.0, 1e-10),  # odd permutation, mixed signs
    ((2.0, 3.0, 1.0), (1.0, -1.0, -1.0), 20.0, 1e-10),  # cyclic permutation
    ((1.0, 2.0, 3.0), (-1.0, -0.5, -2.0), 20.0, 1e-10),  # all negative
    ((0.01, 0.02, 0.025), (30.0, -20.0, 10.0), 20.0, 1e-9),  # fast, many periods
    ((1.0, 5.0, 9.0), (3.0 + 1e-7, 0.7, 1.0), 4.0, 1e-10),  # just outside separatrix
    ((1.0, 5.0, 9.0), (3.0 - 1e-7, 0.7, 1.0), 4.0, 1e-10),  # just inside separatrix
    ((1.0, 2.0, 3.0), (1e-3, 5.0, 1e-3), 4.0, 1e-9),  # near the unstable middle axis
    ((1.0, 1.0, 2.0), (1.0, 2.0, 3.0), 20.0, 1e-10),  # symmetric, oblate
    ((2.0, 1.0, 2.0), (1.0, 2.0, -3.0), 20.0, 1e-10),  # symmetric about y
    ((3.0, 3.0, 1.0), (0.1, 0.0, 5.0), 20.0, 1e-10),  # symmetric, prolate
    ((2.0, 2.0, 2.0), (1.0, 2.0, 3.0), 20.0, 1e-14),  # all equal: constant
    ((1.0, 2.0, 3.0), (0.0, 4.0, 0.0), 20.0, 1e-14),  # exactly about the middle axis
    ((1.0, 2.0, 3.0), (0.0, 0.0, -4.0), 20.0, 1e-14),  # exactly about the major axis
    ((1.0, 2.0, 3.0), (7.0, 0.0, 0.0), 20.0, 1e-14),  # exactly about the minor axis
    ((1.0, 1.0, 2.0), (1.0, 2.0, 0.0), 20.0, 1e-14),  # in the plane of the equal pair
]


@pytest.mark.parametrize("I, w0, T, tol", TORQUE_FREE_CASES)
def test_torque_free_matches_dop853(I, w0, T, tol):
    I, w0 = np.array(I), np.array(w0)
    tt, num = _integrate_euler(I, w0, T)
    ref = tf.omega_body(tt, I, w0)
    assert ref.shape == (tt.size, 3)
    err = np.abs(ref - num).max() / np.linalg.norm(w0)
    assert err < tol, err


def test_torque_free_negative_time():
    I, w0 = np.array([1.0, 2.0, 3.0]), np.array([0.4, -1.1, 0.9])
    tt = np.linspace(0.0, -10.0, 201)
    sol = solve_ivp(_euler_rhs, (0.0, -10.0), w0, t_eval=tt, args=(I,), **TOL)
    assert np.abs(tf.omega_body(tt, I, w0) - sol.y.T).max() < 1e-10


@pytest.mark.parametrize("signs", [(1, 1), (-1, 1), (1, -1), (-1, -1)])
@pytest.mark.parametrize("ysign", [1.0, -1.0])
def test_torque_free_exact_separatrix(signs, ysign):
    # I = (1, 5, 9): D = 9·4 z² − 1·4 x² = 0 exactly for x = 3 z  (M² = 2 E I_mid, m = 1)
    I = np.array([1.0, 5.0, 9.0])
    w0 = np.array([3.0 * signs[0], 0.7 * ysign, 1.0 * signs[1]])
    tt, num = _integrate_euler(I, w0, 4.0)  # exponential sensitivity: keep λT moderate
    ref = tf.omega_body(tt, I, w0)
    assert np.abs(ref - num).max() / np.linalg.norm(w0) < 1e-10
    # asymptotically the body ends on the unstable middle axis with |ω_b| = sqrt(2E/I_b)
    E, M = tf.invariants(I, w0)
    late = tf.omega_body([60.0], I, w0)[0]
    assert abs(late[0]) < 1e-12 and abs(late[2]) < 1e-12
    assert abs(abs(late[1]) - np.sqrt(2 * E / I[1])) < 1e-12


@pytest.mark.parametrize("I, w0, T, tol", TORQUE_FREE_CASES[:13])
def test_torque_free_reference_conserves_invariants(I, w0, T, tol):
    I, w0 = np.array(I), np.array(w0)
    E0, M0 = tf.invariants(I, w0)
    ref = tf.omega_body(np.linspace(0.0, 50.0, 501), I, w0)
    E = 0.5 * np.sum(I * ref**2, axis=1)
    M = np.linalg.norm(I * ref, axis=1)
    # SciPy's ellipj (cephes) carries ~1e-13 relative error growing with the argument: 1e-12
    # over 50 s is its round-off, not a modelling error.
    assert np.abs(E / E0 - 1).max() < 1e-12
    assert np.abs(M / M0 - 1).max() < 1e-12


@pytest.mark.parametrize("I1, I3, w3", [(1.0, 2.0, 3.0), (1.0, 2.0, -3.0), (3.0, 1.0, 5.0)])
def test_symmetric_precession_rate_textbook(I1, I3, w3):
    """§4.7 Eqs. (4.66)-(4.69): (ω_x, ω_y) = ω_12 (cos, sin)(γ ω3 t + α), γ = (I3 − I1)/I1."""
    I = np.array([I1, I1, I3])
    w0 = np.array([0.7, -0.2, w3])
    rate = tf.symmetric_precession_rate(I1, I3, w3)
    assert rate == pytest.approx((I3 - I1) / I1 * w3)
    tt, num = _integrate_euler(I, w0, 10.0)
    ang = np.unwrap(np.arctan2(num[:, 1], num[:, 0]))
    slope = np.polyfit(tt, ang, 1)[0]
    assert slope == pytest.approx(rate, rel=1e-10)
    # "if I3 > I1 then ω rotates in the positive direction": only when ω3 > 0
    assert np.sign(slope) == np.sign(I3 - I1) * np.sign(w3)


@pytest.mark.parametrize("I", [(1.0, 2.0, 3.0), (3.0, 2.0, 1.5), (1.0, 3.0, 2.0), (3.0, 1.0, 2.0)])
def test_torque_free_textbook_stability_beta(I):
    """§4.7 Eqs. (4.64)-(4.65): about body z, ω̈_x + β ω3² ω_x = 0 to first order,
    β = (I3 − I1)(I3 − I2)/(I1 I2); stable (harmonic) iff I3 is the largest or smallest."""
    I = np.array(I)
    w3, eps = 2.0, 1e-6
    w0 = np.array([eps, 0.5 * eps, w3])
    beta = (I[2] - I[0]) * (I[2] - I[1]) / (I[0] * I[1])
    wxdot0 = (I[1] - I[2]) / I[0] * w0[1] * w0[2]
    s = np.sqrt(abs(beta)) * w3
    T = 6.0 * 2 * np.pi / s if beta > 0 else 5.0 / s
    tt = np.linspace(0.0, T, 301)
    sol = solve_ivp(_euler_rhs, (0.0, T), w0, t_eval=tt, args=(I,), **TOL)
    if beta > 0:
        lin = eps * np.cos(s * tt) + wxdot0 / s * np.sin(s * tt)
    else:
        lin = eps * np.cosh(s * tt) + wxdot0 / s * np.sinh(s * tt)
    assert np.abs(sol.y[0] - lin).max() < 1e-4 * np.abs(lin).max()
    # the exact reference reproduces the same small-amplitude motion
    assert np.abs(tf.omega_body(tt, I, w0) - sol.y.T).max() < 1e-10 * np.linalg.norm(w0)


@pytest.mark.parametrize("I1, I3", [(1.0, 2.0), (2.0, 1.0)])
def test_torque_free_cone_geometry(I1, I3):
    """§4.7 after (4.73): flat body (I1 < I3): L lies between e3 and ω, α_s = α_b − α_3 < α_b,
    so the space cone (half-angle α_s about L) lies INSIDE the body cone (half-angle α_b about
    e3): the text's "body cone rolls inside the space cone" is reversed.  Slender body: the
    cones touch externally, α_3 = α_b + α_s (text correct)."""
    I = np.array([I1, I1, I3])
    w0 = np.array([0.6, 0.3, 2.0])
    tt, num = _integrate_euler(I, w0, 5.0, n=51)
    L = I * num
    e3 = np.array([0.0, 0.0, 1.0])

    def ang(a, b):
        return np.arccos(np.clip(np.sum(a * b, axis=1)
                                 / np.linalg.norm(a, axis=1) / np.linalg.norm(b, axis=1), -1, 1))

    a_b, a_3, a_s = ang(num, e3[None]), ang(L, e3[None]), ang(num, L)
    cb, c3, cs = tf.cone_angles(I1, I3, np.hypot(w0[0], w0[1]), w0[2])
    assert np.allclose(a_b, cb, atol=1e-10) and np.allclose(a_3, c3, atol=1e-10)
    assert np.allclose(a_s, cs, atol=1e-10)
    if I3 > I1:  # flat: space cone inside the body cone
        assert np.allclose(a_3 + a_s, a_b, atol=1e-10) and np.all(a_s < a_b)
    else:  # slender: external contact
        assert np.allclose(a_b + a_s, a_3, atol=1e-10)


def test_ellipj_helper():
    u = np.linspace(-40.0, 40.0, 2001)
    for m in (1e-12, 0.1, 0.5, 0.9, 0.999999):
        mine = np.array(tf.ellipj(u, m))
        ref = np.array(scipy_ellipj(u, m)[:3])
        assert np.abs(mine - ref).max() < 1e-11
    # near m = 1 (where scipy's cephes ellipj is wrong at large u) check the identities and the
    # derivative d sn/du = cn dn
    m1 = 1e-12
    sn, cn, dn = tf.ellipj(u, 1.0 - m1, m1)
    assert np.abs(sn**2 + cn**2 - 1).max() < 1e-14
    assert np.abs(dn**2 - (m1 + (1 - m1) * cn**2)).max() < 1e-14
    h = 1e-5
    snp, _, _ = tf.ellipj(u + h, 1.0 - m1, m1)
    snm, _, _ = tf.ellipj(u - h, 1.0 - m1, m1)
    assert np.abs((snp - snm) / (2 * h) - cn * dn).max() < 1e-9
    # F(φ|m) inverts sn/cn on (−π, π]
    phi = np.linspace(-np.pi, np.pi, 41)
    for m in (0.3, 1 - 1e-9):
        s, c, _ = tf.ellipj(tf.ellipf(phi, m), m)
        assert np.abs(s - np.sin(phi)).max() < 1e-13 and np.abs(c - np.cos(phi)).max() < 1e-13


# =============================================================================================
# heavy symmetric top (Lagrange top)
# =============================================================================================
def _top_rhs(t, y, m, l, A, I3, g):
    R = y[:9].reshape(3, 3)
    w = y[9:]
    Ib = np.array([A, A, I3])
    g_b = R[2, :]  # world z in body coordinates
    tau = np.cross(np.array([0.0, 0.0, l]), -m * g * g_b)  # moment of gravity about the tip
    wd = (np.cross(Ib * w, w) + tau) / Ib  # Euler's equations about the fixed tip
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


# =============================================================================================
# double pendulum
# =============================================================================================
def _dp_rhs(t, y, m, L, Ic, g, F0, wf, printed_sign=False):
    th, ph, dth, dph = y
    mL2 = m * L * L
    c, s = np.cos(ph - th), np.sin(ph - th)
    M = np.array([[Ic + 1.25 * mL2, 0.5 * mL2 * c], [0.5 * mL2 * c, Ic + 0.25 * mL2]])
    sgn = -1.0 if printed_sign else 1.0
    rhs = np.array([
        0.5 * mL2 * dph**2 * s - 1.5 * m * g * L * np.sin(th) + F0 * L * np.cos(th) * np.cos(wf * t),
        -sgn * 0.5 * mL2 * dth**2 * s - 0.5 * m * g * L * np.sin(ph),
    ])
    return np.concatenate([[dth, dph], np.linalg.solve(M, rhs)])


def _dp_linear_rhs(t, y, M, K, F0, L, wf):
    xi, v = y[:2], y[2:]
    Q = np.array([F0 * L * np.cos(wf * t), 0.0])
    return np.concatenate([v, np.linalg.solve(M, Q - K @ xi)])


def test_double_pendulum_textbook_matrices():
    m, L, g = 1.3, 0.7, 9.81
    M = dp.mass_matrix(m, L, dp.thin_bar_inertia(m, L))
    K = dp.stiffness_matrix(m, L, g)
    assert np.allclose(M, np.array([[4 / 3, 1 / 2], [1 / 2, 1 / 3]]) * m * L**2, rtol=1e-15)
    assert np.allclose(K, np.array([[3 / 2, 0], [0, 1 / 2]]) * m * g * L, rtol=1e-15)
    # the M of the nonlinear equations at θ = φ = 0 (written independently in _dp_rhs)
    Ic = dp.cylinder_inertia(m, L, 0.01)
    mL2 = m * L * L
    assert np.allclose(dp.mass_matrix(m, L, Ic), [[Ic + 1.25 * mL2, 0.5 * mL2], [0.5 * mL2, Ic + 0.25 * mL2]])


def test_double_pendulum_textbook_ex611_ex621_numbers():
    om, Uu, mk = dp.unit_modes(1.0, 1.0, 1.0 / 12.0, 1.0)  # g/L = 1, m L² = 1
    assert np.allclose(om**2, [3 - 6 / np.sqrt(7), 3 + 6 / np.sqrt(7)], rtol=1e-14)
    assert np.round(om, 2).tolist() == [0.86, 2.30]  # printed, correct
    ratio = Uu[1] / Uu[0]
    assert np.round(ratio, 2).tolist() == [1.43, -2.10]  # printed, correct
    assert np.round(Uu[:, 0], 2).tolist() == [0.57, 0.82]  # printed, correct
    assert np.round(Uu[:, 1], 2).tolist() == [0.43, -0.90]  # printed, correct
    assert round(mk[1], 2) == 0.13  # printed, correct
    # ERRATUM: printed m1 = 1.12 m L²; exact 1.1312 (1.12 results from the rounded vectors)
    assert mk[0] == pytest.approx(1.131178, abs=1e-6)
    assert round(mk[0], 2) == 1.13 != 1.12
    Ur = np.round(Uu, 2)
    assert round(float(Ur[:, 0] @ dp.mass_matrix(1, 1, 1 / 12) @ Ur[:, 0]), 2) == 1.12


DP_LIN_CASES = [
    # (I_c kind, x0 = (θ0, φ0, θ̇0, φ̇0), F0, ω_f as: None / ("mode", k, factor) / float)
    ("thin", (0.1, -0.05, 0.2, 0.3), 0.0, 0.0),
    ("cyl", (0.0, 0.0, 0.0, 0.0), 0.7, 1.7),  # Ex. 6.2.1 from rest, off resonance
    ("cyl", (0.02, 0.01, -0.1, 0.05), 0.7, 4.1),  # forced + homogeneous part
    ("thin", (0.0, 0.0, 0.0, 0.0), 0.5, ("mode", 0, 1.0)),  # exact resonance, mode 1
    ("cyl", (0.01, 0.0, 0.0, 0.0), 0.5, ("mode", 1, 1.0)),  # exact resonance, mode 2
    ("thin", (0.0, 0.0, 0.0, 0.0), 0.5, ("mode", 0, 1.0 + 1e-9)),  # near resonance
    ("cyl", (0.0, 0.0, 0.0, 0.0), 0.5, 0.0),  # constant force
]


@pytest.mark.parametrize("kind, x0, F0, wf", DP_LIN_CASES)
def test_double_pendulum_linear_response_exact(kind, x0, F0, wf):
    m, L, g = 1.0, 1.0, 9.81
    Ic = dp.thin_bar_inertia(m, L) if kind == "thin" else dp.cylinder_inertia(m, L, 0.01)
    om, U = dp.modes(m, L, Ic, g)
    M, K = dp.mass_matrix(m, L, Ic), dp.stiffness_matrix(m, L, g)
    assert np.allclose(U.T @ M @ U, np.eye(2), atol=1e-14)
    assert np.allclose(U.T @ K @ U, np.diag(om**2), atol=1e-12)
    assert om[0] < om[1]
    if isinstance(wf, tuple):
        wf = om[wf[1]] * wf[2]
    T = 20.0
    tt = np.linspace(0.0, T, 801)
    sol = solve_ivp(_dp_linear_rhs, (0.0, T), np.array(x0), t_eval=tt,
                    args=(M, K, F0, L, wf), **TOL)
    th, ph = dp.linear_response(tt, m, L, Ic, g, *x0, F0=F0, omega_f=wf)
    scale = max(np.abs(sol.y[:2]).max(), 1e-300)
    err = max(np.abs(th - sol.y[0]).max(), np.abs(ph - sol.y[1]).max()) / scale
    assert err < 1e-10, err


def test_double_pendulum_ex621_formula():
    """Ex. 6.2.1: from rest, Y_k = L F0 u1^k (cos ωt − cos ω_k t)/(m_k(ω_k² − ω²)) with the
    unit-normalised textbook modes."""
    m, L, g, F0, w = 1.0, 1.0, 9.81, 0.3, 2.0
    Ic = dp.thin_bar_inertia(m, L)
    om, Uu, mk = dp.unit_modes(m, L, Ic, g)
    tt = np.linspace(0, 10, 101)
    Y = [L * F0 * Uu[0, k] * (np.cos(w * tt) - np.cos(om[k] * tt)) / (mk[k] * (om[k]**2 - w**2))
         for k in range(2)]
    xi = Uu @ np.array(Y)
    th, ph = dp.linear_response(tt, m, L, Ic, g, 0, 0, 0, 0, F0=F0, omega_f=w)
    assert np.allclose(th, xi[0], atol=1e-15) and np.allclose(ph, xi[1], atol=1e-15)


@pytest.mark.parametrize("x0, F0, wf", [
    ((1e-4, -0.5e-4, 0.0, 2e-4), 0.0, 0.0),
    ((0.0, 0.0, 0.0, 0.0), 2e-4, 1.7),
    ((0.5e-4, 0.0, 0.0, 0.0), 1e-4, 4.1),
])
def test_double_pendulum_nonlinear_small_amplitude(x0, F0, wf):
    """Nonlinear (Ex. 5.2.2, corrected sign) vs linear_response: the difference is
    O(amplitude³), checked by its size and by halving the amplitude (ratio 8 absolute)."""
    m, L, g = 1.0, 1.0, 9.81
    Ic = dp.cylinder_inertia(m, L, 0.01)
    T = 10.0
    tt = np.linspace(0.0, T, 501)
    eps = 1e-4  # integrate z = ξ/ε so that atol = 1e-12 is relative to O(1) numbers
    rels = []
    for scale in (1.0, 0.5):
        xs = scale * np.array(x0)
        Fs = scale * F0
        sol = solve_ivp(lambda t, z: _dp_rhs(t, eps * z, m, L, Ic, g, Fs, wf) / eps, (0.0, T),
                        xs / eps, t_eval=tt, **TOL)
        y = sol.y * eps
        th, ph = dp.linear_response(tt, m, L, Ic, g, *xs, F0=Fs, omega_f=wf)
        amp = np.abs(y[:2]).max()
        assert 5e-6 < amp < 1e-3
        rel = max(np.abs(th - y[0]).max(), np.abs(ph - y[1]).max()) / amp
        assert rel < 20 * amp**2, rel  # O(amplitude²) relative = O(amplitude³) absolute
        rels.append(rel)
    assert 3.6 < rels[0] / rels[1] < 4.4


@pytest.mark.parametrize("k", [0, 1])
def test_double_pendulum_measured_period(k):
    m, L, g = 1.0, 1.0, 9.81
    Ic = dp.cylinder_inertia(m, L, 0.01)
    om, U = dp.modes(m, L, Ic, g)
    eps = 1e-4
    x0 = np.concatenate([eps * U[:, k] / np.abs(U[:, k]).max(), [0.0, 0.0]])

    def up(t, y, *a):
        return y[0]
    up.direction = 1.0
    T = 12 * 2 * np.pi / om[k]
    sol = solve_ivp(lambda t, z: _dp_rhs(t, eps * z, m, L, Ic, g, 0.0, 0.0) / eps, (0.0, T),
                    x0 / eps, events=up, **TOL)  # scaled state z = ξ/ε
    crossings = sol.t_events[0]
    period = np.diff(crossings).mean()
    assert period == pytest.approx(2 * np.pi / om[k], rel=1e-7)


def test_double_pendulum_ex522_printed_sign_breaks_energy():
    """Ex. 5.2.2's φ equation prints −½ θ̇² sin(φ−θ); the correct sign (+) conserves energy."""
    m, L, g = 1.0, 1.0, 9.81
    Ic = dp.thin_bar_inertia(m, L)
    x0 = np.array([1.0, -0.5, 0.0, 2.0])

    def energy(y):
        th, ph, dth, dph = y
        T = 0.5 * (Ic + 1.25 * m * L**2) * dth**2 + 0.5 * (Ic + 0.25 * m * L**2) * dph**2 \
            + 0.5 * m * L**2 * np.cos(ph - th) * dth * dph
        return T - m * g * L * (1.5 * np.cos(th) + 0.5 * np.cos(ph))

    drift = {}
    for printed in (False, True):
        sol = solve_ivp(_dp_rhs, (0.0, 5.0), x0, args=(m, L, Ic, g, 0.0, 0.0, printed),
                        t_eval=np.linspace(0, 5, 201), **TOL)
        E = energy(sol.y)
        drift[printed] = np.abs(E - E[0]).max() / abs(E[0])
    assert drift[False] < 1e-10
    assert drift[True] > 1e-2
