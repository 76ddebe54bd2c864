"""Double pendulum (``references/double_pendulum.py``) against an independent tight integration.

Every ODE below is written here, independently of the reference module and of the harness
engines, and integrated with scipy DOP853 at rtol = atol = 1e-12.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from harness.references import double_pendulum as dp

TOL = dict(method="DOP853", rtol=1e-12, atol=1e-12)


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
