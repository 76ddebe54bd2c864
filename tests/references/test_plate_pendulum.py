"""harness.references.plate_pendulum against an independent tight integration (Ex. 4.5.1, 4.5.2).

The integration written here does not use the reference's formulas: the plate is a set of
Gauss-Legendre mass points over the rectangle (exact for its second moments), the angular
momentum about the pivot gives the equation of motion, and the support force is Newton's law
summed over the mass points. SciPy DOP853 at rtol = atol = 1e-12.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from harness.references import plate_pendulum as pp

TOL = dict(method="DOP853", rtol=1e-12, atol=1e-12)


def mass_points(m, a, b, n=4):
    """Points (x, z) of the plate x in [0, 2a], z in [-2b, 0] (pivot corner at the origin, zero
    angle) and their masses (Gauss-Legendre, exact for polynomials of degree <= 2n - 1)."""
    x, w = np.polynomial.legendre.leggauss(n)
    X, Z = np.meshgrid(a * (x + 1.0), -b * (x + 1.0))
    W = np.outer(w, w) / 4.0
    return np.stack([X.ravel(), Z.ravel()], axis=1), m * W.ravel()


def integrate_plate(m, a, b, g, q0, dq0, T, n=2001, events=None):
    """Hinge angle q (rotation about -y, positive toward +x) of the plate; returns the solution."""
    pts, dm = mass_points(m, a, b)
    I_O = float(np.sum(dm * np.sum(pts**2, axis=1)))

    def rot(q):  # world (x, z) of the body points at hinge angle q
        c, s = np.cos(q), np.sin(q)
        return np.stack([c * pts[:, 0] - s * pts[:, 1], s * pts[:, 0] + c * pts[:, 1]], axis=1)

    def rhs(t, y):
        p = rot(y[0])
        # moment of gravity about the pivot, component along the hinge axis -y:
        # -(r x F)_y = -(z F_x - x F_z) = x F_z = -x dm g
        M_axis = np.sum(dm * p[:, 0] * (-g))
        return [y[1], M_axis / I_O]

    tt = np.linspace(0.0, T, n)
    sol = solve_ivp(rhs, (0.0, T), [q0, dq0], t_eval=tt, events=events, dense_output=True, **TOL)
    assert sol.success
    return sol, rot, rhs, pts, dm


def support_force_newton(state, rot, rhs, dm, g):
    """Sum over the mass points of dm a_point, minus the weight: the pivot force (x, z)."""
    q, dq = state
    ddq = rhs(0.0, state)[1]
    p = rot(q)
    # rotation about -y at rate dq: velocity of a point (x, z) is dq (-z, x); acceleration
    # ddq (-z, x) - dq^2 (x, z)
    acc = ddq * np.stack([-p[:, 1], p[:, 0]], axis=1) - dq * dq * p
    F = np.sum(dm[:, None] * acc, axis=0)
    return F + np.array([0.0, np.sum(dm) * g])


CASES = [
    # (m, a, b, g, q0, dq0): textbook release, other aspect ratios, pushed and wound starts
    (2.0, 0.3, 0.2, 9.81, 0.0, 0.0),
    (1.0, 0.1, 0.5, 9.81, 0.0, 0.0),
    (3.0, 0.5, 0.05, 3.7, 0.0, 0.0),
    (2.0, 0.3, 0.2, 9.81, -1.2, 2.0),
    (2.0, 0.3, 0.2, 9.81, 0.4, -12.0),  # rotates over the top
]


@pytest.mark.parametrize("m, a, b, g, q0, dq0", CASES)
def test_plate_motion_matches_integration(m, a, b, g, q0, dq0):
    sol, rot, rhs, pts, dm = integrate_plate(m, a, b, g, q0, dq0, 6.0)
    phi0 = pp.textbook_release_angle(a, b) + q0
    phi, dphi, _ = pp.pendulum_motion(sol.t, pp.natural_frequency(a, b, g), phi0, dq0)
    assert np.abs(phi - (phi0 + sol.y[0] - q0)).max() < 1e-9
    assert np.abs(dphi - sol.y[1]).max() < 1e-9 * max(1.0, abs(dq0))
    F = pp.support_force(sol.t, m, a, b, g, phi0, dq0)
    F_num = np.array([support_force_newton(y, rot, rhs, dm, g) for y in sol.y.T])
    assert np.abs(F[:, 1]).max() == 0.0
    assert np.abs(F[:, [0, 2]] - F_num).max() < 1e-9 * m * g * (1.0 + dq0**2)


@pytest.mark.parametrize("m, a, b, g", [c[:4] for c in CASES[:3]])
def test_textbook_ex451_ex452_largest_angular_velocity_and_support_force(m, a, b, g):
    """Released from rest with one side horizontal: the printed omega (Ex. 4.5.1) and F_n, F_s
    (Ex. 4.5.2) equal the integration's values when the centre of mass passes below the pivot."""
    phi0 = pp.textbook_release_angle(a, b)

    def below(t, y):  # centre of mass at x = 0
        c, s = np.cos(y[0]), np.sin(y[0])
        return c * a + s * b

    below.terminal = True
    sol, rot, rhs, pts, dm = integrate_plate(m, a, b, g, 0.0, 0.0, 5.0, events=below)
    assert len(sol.t_events[0]) == 1
    y = sol.y_events[0][0]
    w_num = abs(y[1])
    F_num = support_force_newton(y, rot, rhs, dm, g)
    assert pp.textbook_largest_angular_velocity(a, b, g) == pytest.approx(w_num, rel=1e-10)
    assert pp.largest_angular_velocity(a, b, g, phi0) == pytest.approx(w_num, rel=1e-10)
    Fn, Fs = pp.textbook_support_force(m, a, b, g)
    assert Fn == pytest.approx(F_num[1], rel=1e-10) and abs(F_num[0]) < 1e-9 * m * g and Fs == 0.0
    assert np.allclose(pp.support_force_at_largest_velocity(m, a, b, g, phi0), [0.0, 0.0, F_num[1]], rtol=1e-10, atol=0)


def test_textbook_plate_inertia():
    """Ex. 4.2.1 / 4.5.1: I = m(a^2 + b^2)/3 about the centre, 4/3 m(a^2 + b^2) about the corner."""
    m, a, b = 2.0, 0.3, 0.2
    pts, dm = mass_points(m, a, b)
    assert pp.pivot_inertia(m, a, b) == pytest.approx(np.sum(dm * np.sum(pts**2, axis=1)), rel=1e-13)


@pytest.mark.parametrize("phi0, dphi0", [(0.6, 0.0), (-2.5, -1.0), (0.3, 4.0), (0.3, -4.0), (3.0, 0.0), (7.0, 5.0),
                                         (3.5, 0.0), (-4.0, 0.5), (2 * np.pi + 0.6, 0.0), (-2 * np.pi - 0.3, 1.0)])
def test_pendulum_motion_regimes(phi0, dphi0):
    """Libration, rotation both ways and wound starts (a libration from beyond pi swings about
    the bottom nearest its start) against phi'' = -wp^2 sin phi."""
    wp = 1.7
    tt = np.linspace(0.0, 10.0, 501)
    sol = solve_ivp(lambda t, y: [y[1], -wp**2 * np.sin(y[0])], (0.0, 10.0), [phi0, dphi0], t_eval=tt, **TOL)
    phi, dphi, ddphi = pp.pendulum_motion(tt, wp, phi0, dphi0)
    assert np.abs(phi - sol.y[0]).max() < 1e-9 and np.abs(dphi - sol.y[1]).max() < 1e-9
    assert np.allclose(ddphi, -wp**2 * np.sin(sol.y[0]), atol=1e-9)
