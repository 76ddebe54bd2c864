"""Torque-free rigid body (``references/torque_free.py``) against an independent tight integration.

Every ODE below is written here, independently of the reference module and of the harness
engines, and integrated with scipy DOP853 at rtol = atol = 1e-12.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.special import ellipj as scipy_ellipj

from harness.model import rotations
from harness.references import torque_free as tf

TOL = dict(method="DOP853", rtol=1e-12, atol=1e-12)


def _euler_rhs(t, w, I):
    # I ω̇ = (I ω) × ω, body frame, principal axes
    return rotations.cross(I * w, w) / I


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
