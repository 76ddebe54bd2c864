"""harness.references.pendulum (IFToMM A01) against an independent tight integration.

The integration written here does not use the reference's formulas: the bob is a free rigid
body in the plane (centre x, z and rotation angle psi about -y) with its mass and its
inertia (2/5) m r^2 about its centre, held by the pivot's two constraint rows
x - L sin psi = 0, z + L cos psi = 0; each right-hand side solves the Newton-Euler equations
with the constraint's multipliers (the KKT system), which also give the pivot force. SciPy
DOP853 at rtol = atol = 1e-12, at several parameter sets: A01's release, small and large
swings, releases beyond the horizontal, rotation over the top both ways, a bob as large as
its rod, other gravity, no gravity.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from harness.references import pendulum as pd

TOL = dict(method="DOP853", rtol=1e-12, atol=1e-12)


def integrate_bob(m, L, r, g, theta0, dtheta0, T, n=1001):
    """The bob as a planar free body on two constraint rows; state (x, z, psi, dx, dz, dpsi).
    Returns the times, the states (n, 6) and the pivot force on the bob (n, 2) as (x, z)."""
    Ic = 0.4 * m * r * r
    M = np.diag([m, m, Ic])

    def kkt(y):
        x, z, psi, dx, dz, dpsi = y
        # rows: x - L sin psi = 0, z + L cos psi = 0; J = d rows / d(x, z, psi)
        J = np.array([[1.0, 0.0, -L * np.cos(psi)], [0.0, 1.0, -L * np.sin(psi)]])
        gamma = -np.array([L * np.sin(psi) * dpsi**2, -L * np.cos(psi) * dpsi**2])  # J a = gamma
        f = np.array([0.0, -m * g, 0.0])
        A = np.block([[M, J.T], [J, np.zeros((2, 2))]])
        sol = np.linalg.solve(A, np.concatenate([f, gamma]))
        return sol[:3], -sol[3:]  # accelerations, and the pivot force J^T lambda on (x, z)

    def rhs(t, y):
        acc, _ = kkt(y)
        return np.concatenate([y[3:], acc])

    s, c = np.sin(theta0), np.cos(theta0)
    y0 = [L * s, -L * c, theta0, L * c * dtheta0, L * s * dtheta0, dtheta0]
    tt = np.linspace(0.0, T, n)
    sol = solve_ivp(rhs, (0.0, T), y0, t_eval=tt, **TOL)
    assert sol.success
    force = np.array([kkt(y)[1] for y in sol.y.T])
    return sol.t, sol.y.T, force


CASES = [
    # (m, L, r, g, theta0, dtheta0)
    (1.0, 1.0, 1e-3, 9.81, 0.5 * np.pi, 0.0),    # A01: released at rest, horizontal
    (1.0, 1.0, 1e-3, 9.81, 0.05, 0.0),           # small swing
    (2.0, 0.3, 0.05, 3.7, 2.9, 0.0),             # released above the horizontal, near the top
    (1.0, 1.0, 1e-3, 9.81, -3.1, 0.0),           # released just off the top, the other side
    (0.5, 0.7, 0.7, 9.81, 1.2, -2.0),            # a bob as large as its rod, pushed back
    (1.0, 1.0, 0.02, 9.81, 0.5 * np.pi, 7.0),    # over the top, forward
    (3.0, 2.0, 0.1, 9.81, -2.0, -5.0),           # over the top, backward
    (1.0, 1.5, 0.01, 0.0, 0.3, 1.1),             # no gravity: uniform rotation
]


@pytest.mark.parametrize("m, L, r, g, theta0, dtheta0", CASES)
def test_bob_motion_and_support_force_match_integration(m, L, r, g, theta0, dtheta0):
    t, y, force = integrate_bob(m, L, r, g, theta0, dtheta0, 10.0)
    p, v, _, (th, dth, _) = pd.bob_motion(t, L, r, g, theta0, dtheta0)
    scale = 1.0 + abs(dtheta0)
    assert np.abs(p[:, 1]).max() == 0.0 and np.abs(v[:, 1]).max() == 0.0
    assert np.abs(p[:, [0, 2]] - y[:, :2]).max() < 1e-9 * L
    assert np.abs(v[:, [0, 2]] - y[:, 3:5]).max() < 1e-9 * L * scale
    assert np.abs(th - y[:, 2]).max() < 1e-9 and np.abs(dth - y[:, 5]).max() < 1e-9 * scale
    F = pd.support_force(t, m, L, r, g, theta0, dtheta0)
    assert np.abs(F[:, 1]).max() == 0.0
    assert np.abs(F[:, [0, 2]] - force).max() < 1e-9 * m * (g + L) * scale**2


def test_a01_release_period_of_the_point_mass():
    """r -> 0 is A01's point mass: the period from the horizontal release is 4 K(sin^2(pi/4)) /
    omega, omega = sqrt(g/L) (the elliptic integral by Gauss-Legendre quadrature here), and the
    mass is back at x = +L, at rest, after one period."""
    g, L = 9.81, 1.0
    x, w = np.polynomial.legendre.leggauss(60)
    u = 0.25 * np.pi * (x + 1.0)  # K(k^2) = int_0^{pi/2} du / sqrt(1 - k^2 sin^2 u)
    K = float(np.sum(0.25 * np.pi * w / np.sqrt(1.0 - 0.5 * np.sin(u) ** 2)))
    period = 4.0 * K / np.sqrt(g / L)
    p, v, _, _ = pd.bob_motion([0.0, 0.5 * period, period], L, 0.0, g, 0.5 * np.pi)
    assert np.allclose(p, [[L, 0, 0], [-L, 0, 0], [L, 0, 0]], atol=1e-12, rtol=0)
    assert np.allclose(v, 0.0, atol=1e-11)


def test_point_mass_distance_is_the_sphere_correction():
    """The sphere's frequency is the point mass's times 1/sqrt(1 + (2/5) r^2 / L^2): the
    distance from the point mass's motion vanishes at r = 0 and grows as r^2."""
    t = np.linspace(0.0, 10.0, 2001)
    assert pd.point_mass_distance(t, 1.0, 0.0, 9.81, 0.5 * np.pi) == 0.0
    d1 = pd.point_mass_distance(t, 1.0, 1e-3, 9.81, 0.5 * np.pi)
    d2 = pd.point_mass_distance(t, 1.0, 2e-3, 9.81, 0.5 * np.pi)
    assert 8e-6 < d1 < 1e-5 and d2 / d1 == pytest.approx(4.0, rel=1e-3)
    assert pd.natural_frequency(1.0, 0.0, 9.81) == pytest.approx(np.sqrt(9.81), rel=1e-15)
    assert pd.pivot_inertia(2.0, 0.5, 0.1) == pytest.approx(2.0 * (0.25 + 0.004), rel=1e-15)
