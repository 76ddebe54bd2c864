"""harness.references.cart_pendulum against independent tight integrations (Ex. 1.3.1, 1.5.1, 1.6.1).

The textbook's own equations of motion (Ex. 1.3.1, particle pendulum) are integrated as printed;
for a pendulum with its own moment of inertia the test writes the cart and the pendulum as two
free bodies with the rod force S along the rod, eliminated numerically at every step (Newton's
second law for each, as in the textbook's free-body diagrams, plus the pendulum's angular
momentum about its centre of mass). SciPy DOP853 at rtol = atol = 1e-12.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from harness.references import cart_pendulum as cp

TOL = dict(method="DOP853", rtol=1e-12, atol=1e-12)


def printed_ex131(M, m, L, g):
    """Ex. 1.3.1 as printed: (M+m)X'' + m(L th'' cos th - L th'^2 sin th) = 0,
    m X'' cos th + m L th'' + m g sin th = 0."""

    def rhs(t, y):
        X, th, dX, dth = y
        c, s = np.cos(th), np.sin(th)
        A = np.array([[M + m, m * L * c], [m * c, m * L]])
        b = np.array([m * L * dth**2 * s, -m * g * s])
        ddX, ddth = np.linalg.solve(A, b)
        return [dX, dth, ddX, ddth]

    return rhs


def free_bodies(M, m, l, I_c, g):
    """Cart (x only) and pendulum (x, z, th) with the pivot force (Fx, Fz) from the pendulum on
    the cart as unknowns: 4 accelerations + 2 forces from Newton's law per body and the two
    pivot conditions differentiated twice."""

    def rhs(t, y):
        X, th, dX, dth = y
        c, s = np.cos(th), np.sin(th)
        # unknowns u = [ddX, ddxb, ddzb, ddth, Fx, Fz]; force on the pendulum at the pivot: (Fx, Fz)
        A = np.zeros((6, 6))
        b = np.zeros(6)
        A[0, 0], A[0, 4] = M, 1.0  # cart: M X'' = -Fx
        A[1, 1], A[1, 4] = m, -1.0  # bob: m xb'' = Fx
        A[2, 2], A[2, 5] = m, -1.0
        b[2] = -m * g  # m zb'' = Fz - m g
        # angular momentum about the bob's centre: I_c th'' = moment of the pivot force about it
        # pivot relative to the centre: (-l s, +l c) in (x, z); rotation th about -y, so the
        # moment about -y is -(r x F)_y = -(z Fx - x Fz) = -(l c Fx + l s Fz)
        A[3, 3], A[3, 4], A[3, 5] = I_c, l * c, l * s
        # constraints: xb = X + l s, zb = -l c, differentiated twice
        A[4, 1], A[4, 0], A[4, 3] = 1.0, -1.0, -l * c
        b[4] = -l * s * dth**2
        A[5, 2], A[5, 3] = 1.0, -l * s
        b[5] = l * c * dth**2
        u = np.linalg.solve(A, b)
        return [dX, dth, u[0], u[3]]

    return rhs


def crossings(rhs, y0, T):
    ev = lambda t, y: y[1]  # noqa: E731
    sol = solve_ivp(rhs, (0.0, T), y0, events=ev, dense_output=True, **TOL)
    assert sol.success
    return sol


@pytest.mark.parametrize("M, m, L, g", [(2.0, 1.0, 1.0, 9.81), (1.0, 3.0, 0.5, 9.81), (10.0, 0.1, 2.0, 1.6)])
def test_textbook_ex161_cart_speed_and_ex151_frequency(M, m, L, g):
    """Printed results for the particle pendulum (I_c = 0), from the printed equations."""
    assert cp.textbook_cart_speed(M, m, L, g) == pytest.approx(cp.cart_speed_at_vertical(M, m, L, 0.0, g, np.pi / 2), rel=1e-14)
    assert cp.textbook_frequency(M, m, L, g) == pytest.approx(cp.small_oscillation_frequency(M, m, L, 0.0, g), rel=1e-14)
    sol = crossings(printed_ex131(M, m, L, g), [0.0, np.pi / 2, 0.0, 0.0], 3.0)
    ye = sol.y_events[0]
    assert np.allclose(np.abs(ye[:, 2]), cp.textbook_cart_speed(M, m, L, g), rtol=1e-10, atol=0)
    # small oscillations: period of the printed equations at 1e-5 rad against 2 pi / omega
    w = cp.textbook_frequency(M, m, L, g)
    ev = lambda t, y: y[1]  # noqa: E731
    sol = solve_ivp(printed_ex131(M, m, L, g), (0.0, 6.5 * 2 * np.pi / w), [0.0, 1e-5, 0.0, 0.0], events=ev,
                    method="DOP853", rtol=1e-12, atol=1e-18)  # absolute tolerance far below the amplitude
    te = sol.t_events[0]
    assert np.pi * (len(te) - 1) / (te[-1] - te[0]) == pytest.approx(w, rel=1e-9)


CASES = [
    # (M, m, l, I_c, g, theta0, dX0, dtheta0)
    (2.0, 1.0, 1.0, 0.001, 9.81, np.pi / 2, 0.0, 0.0),  # the scene's default
    (2.0, 1.0, 1.0, 0.2, 9.81, 1.0, 0.4, 0.0),  # heavy pendulum, cart moving
    (0.5, 2.0, 0.7, 0.05, 9.81, 2.8, -1.0, 0.5),  # near the top, light cart
    (3.0, 1.0, 1.0, 0.0, 9.81, -0.6, 0.0, 2.0),  # particle, started swinging
]


@pytest.mark.parametrize("M, m, l, I_c, g, theta0, dX0, dtheta0", CASES)
def test_cart_velocity_period_and_vertical_speed_match_integration(M, m, l, I_c, g, theta0, dX0, dtheta0):
    rhs = free_bodies(M, m, l, I_c, g)
    T = cp.period(M, m, l, I_c, g, theta0, dX0, dtheta0)
    sol = crossings(rhs, [0.0, theta0, dX0, dtheta0], 3.2 * T)
    te, ye = sol.t_events[0], sol.y_events[0]
    assert len(te) >= 5
    assert np.diff(te) == pytest.approx(np.full(len(te) - 1, T / 2), rel=1e-10)
    P = cp.momentum(M, m, l, theta0, dX0, dtheta0)
    assert np.allclose(np.abs(ye[:, 2] - P / (M + m)), cp.cart_speed_at_vertical(M, m, l, I_c, g, theta0, dX0, dtheta0), rtol=1e-10)
    tt = np.linspace(0.0, 3.0 * T, 601)
    X, th, dX, dth = sol.sol(tt)
    E = cp.relative_energy(M, m, l, I_c, g, theta0, dX0, dtheta0)
    v = 1.0 + abs(dX0) + l * abs(dtheta0)
    w = dX - P / (M + m)
    assert np.abs(cp.relative_speed_squared(th, M, m, l, I_c, g, E) - w * w).max() < 1e-10 * v * v
    away = np.abs(w) > 1e-3 * v  # the signed root, away from the turning points
    exact = cp.cart_velocity(th, dth * np.cos(th), M, m, l, I_c, g, P, E)
    assert np.abs(exact - dX)[away].max() < 1e-9 * v
    assert cp.amplitude(M, m, l, I_c, g, theta0, dX0, dtheta0) == pytest.approx(np.abs(th).max(), abs=1e-4)


def test_over_the_top_has_no_period():
    with pytest.raises(ValueError, match="over the top"):
        cp.period(2.0, 1.0, 1.0, 0.0, 9.81, 3.0, 0.0, 5.0)


def _exact_check_of_an_inhouse_run(overrides=None, factor=1.0):
    """(value, unit, detail) of the exact check on the in-house run at validate's settings (the
    step times ``factor``)."""
    from harness.engines import get_engine
    from harness.measure.exact import exact_error
    from harness.engines import load_scene
    from harness.validate.run import default_settings

    scene = load_scene("cart_pendulum", overrides)
    from harness.judging.refinement import scaled_step

    settings = scaled_step(default_settings(scene, "inhouse"), factor)
    run = get_engine("inhouse").simulate
    return exact_error(scene, run(scene, settings), settings, run)


@pytest.mark.parametrize("overrides, why", [
    # amplitude 116 degrees, a 3.6 s period: 4 s hold fewer than 1.5 periods
    ({"M": 2.16, "m": 1.49, "L": 1.52, "g": 6.26, "theta0": 2.02, "dtheta0": -0.16}, "fewer than 1.5 periods"),
    ({"dtheta0": 8.0}, "goes over the top"),
])
def test_the_exact_check_judges_what_a_short_horizon_or_a_rotation_leaves(overrides, why):
    """A libration too slow for the scene's horizon, or a pendulum going over the top, has no
    period to measure from the run: the exact check says so and still judges the cart velocity
    at every sample and the small oscillations (a run of its own), instead of giving no value."""
    value, unit, detail = _exact_check_of_an_inhouse_run(overrides)
    assert why in detail and "period not judged" in detail and "small-oscillation omega" in detail
    assert unit == "rel" and 0.0 < value and _converges(value, _exact_check_of_an_inhouse_run(overrides, 2.0)[0])


def _converges(fine: float, coarse: float) -> bool:
    """The other parts at RK4's error: within 10x what the harness resolves
    (``JUDGING_RESOLUTION``, relative), or falling at about the fourth order from 2 dt to dt."""
    from harness.judging.error_model import JUDGING_RESOLUTION

    return fine <= 10 * JUDGING_RESOLUTION or coarse / fine > 2 ** 3


def test_the_exact_check_measures_the_period_when_the_horizon_holds_it():
    value, _, detail = _exact_check_of_an_inhouse_run()
    assert "not judged" not in detail and " s vs exact " in detail
    assert _converges(value, _exact_check_of_an_inhouse_run(factor=2.0)[0])
