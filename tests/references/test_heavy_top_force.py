"""harness.references.heavy_top.tip_force / cos_theta_rates against an independent tight integration.

The top is integrated here in its own way (rotation matrix and Euler's equations about the
fixed tip, SciPy DOP853 at rtol = atol = 1e-12); the tip force is Newton's law for the centre
of mass, F = m a_cm + m g z, with a_cm = alpha x r + w x (w x r) from the integrated state.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from harness.model import rotations
from harness.references import heavy_top as ht

TOL = dict(method="DOP853", rtol=1e-12, atol=1e-12)


def _rhs(t, y, m, l, A, I3, g):
    R = y[:9].reshape(3, 3)
    w = y[9:]
    Ib = np.array([A, A, I3])
    tau = rotations.cross(np.array([0.0, 0.0, l]), -m * g * R[2, :])
    wd = (rotations.cross(Ib * w, w) + tau) / Ib
    W = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    return np.concatenate([(R @ W).ravel(), wd])


P0 = ht.TopParams(mass=1.0, l=0.1, I1=0.004, I3=0.006, g=9.81)
CASES = {
    "scene_default": (P0, ht.tilt_about_y(0.5), (0.0, 0.0, 50.0)),
    "transverse": (P0, ht.tilt_about_y(0.5), (3.0, -2.0, 40.0)),
    "slow_top": (P0, ht.tilt_about_y(0.5), (0.0, 0.0, 5.0)),
    "com_below_tip": (ht.TopParams(l=-0.1), ht.tilt_about_y(2.5), (1.0, 0.3, 20.0)),
    "zero_gravity": (ht.TopParams(g=0.0), ht.tilt_about_y(0.5), (3.0, -2.0, 40.0)),
}


@pytest.mark.parametrize("name", list(CASES))
def test_tip_force_matches_newton_on_integration(name):
    p, R0, w0 = CASES[name]
    w0 = np.asarray(w0, dtype=float)
    A = p.I1 + p.mass * p.l**2
    args = (p.mass, p.l, A, p.I3, p.g)
    T = 2.0
    tt = np.linspace(0.0, T, 401)
    sol = solve_ivp(_rhs, (0.0, T), np.concatenate([R0.ravel(), w0]), t_eval=tt, args=args, **TOL)
    assert sol.success
    F_num, rates = [], []
    for k in range(len(tt)):
        y = sol.y[:, k]
        R, w = y[:9].reshape(3, 3), y[9:]
        wd = _rhs(0.0, y, *args)[9:]
        r = R @ np.array([0.0, 0.0, p.l])
        wW, aW = R @ w, R @ wd
        acc = np.cross(aW, r) + np.cross(wW, np.cross(wW, r))
        F = p.mass * acc + np.array([0.0, 0.0, p.mass * p.g])
        e3 = R[:, 2]
        e_rho = np.array([e3[0], e3[1], 0.0]) / np.hypot(e3[0], e3[1])
        e_phi = np.cross([0.0, 0.0, 1.0], e_rho)
        F_num.append([F @ e_rho, F @ e_phi, F[2]])
        rates.append([e3[2], np.cross(wW, e3)[2]])
    F_num, rates = np.array(F_num), np.array(rates)
    u, ud, _ = ht.cos_theta_rates(tt, p, R0, w0)
    assert np.abs(u - rates[:, 0]).max() < 1e-9 and np.abs(ud - rates[:, 1]).max() < 1e-8 * (1 + np.abs(w0).max())
    F = ht.tip_force(tt, p, R0, w0)
    scale = p.mass * (abs(p.g) + abs(p.l) * (np.abs(w0).max() ** 2 + 1.0))
    assert np.abs(F - F_num).max() < 1e-9 * scale
