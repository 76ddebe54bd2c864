"""The compiled in-house solver through a singular position: the unit parallelogram four-bar
(``four_bar`` with a = b = c = d = 1 m; IFToMM benchmark A02 with N = 1: 1 kg bars, the crank
vertical, its tip moving at 1 m/s along +x) turns over and passes its flat positions, where the
loop's Jacobian loses an in-plane row. Against the exact motion (``parallelogram_motion``, a
closed form) and against the per-state pseudo-inverse (the readable oracle). No wall-clock
assertions."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.special import ellipj, ellipkinc

from harness.engines import integrator
from harness.engines.base import RunSettings
from harness.engines.inhouse import ENGINE, build, initial_state, make_rhs, project, projection_tolerance
from harness.engines.inhouse.compiled import kernels
from harness.engines.inhouse.compiled import solver as compiled
from harness.engines.inhouse.constraints import RANK_RTOL, project_stage, rows
from harness.model import rotations
from harness.engines import load_scene
from harness.references import four_bar as reference

A02 = {"a": 1.0, "b": 1.0, "c": 1.0, "d": 1.0, "m_crank": 1.0, "m_coupler": 1.0, "m_rocker": 1.0,
       "theta0": np.pi / 2, "dtheta0": -1.0}
# s: the crank passes theta = 0 (the bars stretched along +x) at 0.708 s and theta = -pi (folded,
# C on A) at 1.215 s; 1.5 s is 151 samples, a fraction of a second compiled
T_END = 1.5
SAVE = 0.01


def scene(**params):
    return load_scene("four_bar").with_params(**(A02 | params))


def inertia_and_moment(p) -> tuple[float, float]:
    """(I, K) of the parallelogram motion I theta'' = -K cos theta (``parallelogram_motion``):
    I (kg m^2) = J_a + m_coupler a^2 + J_c, each bar about its pivot m (r^2/4 + L^2/3) (a solid
    cylinder of radius r), the coupler translating; K (N m) = g ((m_crank/2 + m_coupler) a +
    m_rocker c / 2)."""
    J_a = p["m_crank"] * (0.25 * p["r"] ** 2 + p["a"] ** 2 / 3.0)
    J_c = p["m_rocker"] * (0.25 * p["r"] ** 2 + p["c"] ** 2 / 3.0)
    return J_a + p["m_coupler"] * p["a"] ** 2 + J_c, p["g"] * ((0.5 * p["m_crank"] + p["m_coupler"]) * p["a"]
                                                              + 0.5 * p["m_rocker"] * p["c"])


def fastest_rate(p) -> float:
    """Omega (rad/s), the largest crank rate of the motion: the energy integral
    theta'^2 = theta0'^2 - (2K/I)(sin theta - sin theta0) at sin theta = -1."""
    I, K = inertia_and_moment(p)
    return math.sqrt(p["dtheta0"] ** 2 + 2.0 * K / I * (1.0 + math.sin(p["theta0"])))


def parallelogram_motion(p, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The crank angle theta (rad) and rate (rad/s) at times t (s) of the exact motion.

    With a = c and b = d the coupler parallel to the ground (beta = 0) and the rocker parallel to
    the crank (gamma = theta) close the loop at every theta; the motion that starts on this
    branch stays on it through the flat positions (the other branch meets it there at an angle,
    and the velocity is along this one). The coupler translates, so I theta'' = -K cos theta
    (``inertia_and_moment``). With psi = theta + pi/2 that is the pendulum psi'' = -w0^2 sin psi,
    w0^2 = K / I; turning over (energy e = psi'^2/2 - w0^2 cos psi above w0^2), psi = s 2 am(u)
    and psi' = s (2 w0 / k) dn(u), u = u0 + w0 t / k, with s the sign of the rate,
    m = k^2 = 2 w0^2 / (e + w0^2) and u0 = F(s psi0 / 2 | m) (Jacobi's elliptic functions)."""
    I, K = inertia_and_moment(p)
    w0 = math.sqrt(K / I)
    psi0 = p["theta0"] + 0.5 * np.pi
    e = 0.5 * p["dtheta0"] ** 2 - w0 * w0 * math.cos(psi0)
    m = 2.0 * w0 * w0 / (e + w0 * w0)
    assert 0.0 < m < 1.0, "the crank must turn over"
    s = math.copysign(1.0, p["dtheta0"])
    k = math.sqrt(m)
    _, _, dn, am = ellipj(ellipkinc(s * psi0 / 2.0, m) + w0 * np.asarray(t, dtype=float) / k, m)
    return 2.0 * s * am - 0.5 * np.pi, s * 2.0 * w0 / k * dn


def errors(p, run, away: float = 0.0) -> tuple[float, float]:
    """Largest errors of the bar angles (rad; ``reference.bar_angles``) and of the bars' rates
    (rad/s, about world -y) against the exact motion: crank and rocker at theta, the coupler
    at 0; the rates at the samples more than ``away`` rad from a flat position (theta a multiple
    of pi)."""
    theta, rate = parallelogram_motion(p, run.t)
    zero = np.zeros_like(theta)
    angle = np.max(np.abs(rotations.wrap_angle(reference.bar_angles(run) - np.stack([theta, zero, theta], 1))))
    idx = [run.body_names.index(name) for name in reference.BODIES]
    rates = -run.w_WB_W[:, idx, 1]
    far = np.abs(rotations.wrap_angle(2.0 * theta)) > 2.0 * away  # 2 theta: both flat positions at 0
    return float(angle), float(np.max(np.abs(rates - np.stack([rate, zero, rate], 1))[far], initial=0.0))


def test_the_closed_form_is_the_motion_of_the_reduced_equation():
    """``parallelogram_motion`` against a tight integration of I theta'' = -K cos theta (DOP853,
    rtol 1e-13: 4e-13 rad from it over 1.5 s, measured), and the motion passes both flat
    positions within T_END."""
    p = scene().params
    I, K = inertia_and_moment(p)
    t = np.arange(151) * SAVE
    sol = solve_ivp(lambda _t, y: [y[1], -K * np.cos(y[0]) / I], (0.0, T_END), [p["theta0"], p["dtheta0"]],
                    method="DOP853", t_eval=t, rtol=1e-13, atol=1e-14)
    theta, rate = parallelogram_motion(p, t)
    np.testing.assert_allclose(theta, sol.y[0], rtol=0, atol=1e-11)
    np.testing.assert_allclose(rate, sol.y[1], rtol=0, atol=1e-10)
    assert theta[0] == pytest.approx(np.pi / 2) and theta.min() < -np.pi  # through theta = 0 and theta = -pi


@pytest.mark.parametrize("method", ["rk4_compiled", "rkmk4_compiled"])
def test_fixed_step_compiled_methods_pass_the_flat_positions_at_their_order(method):
    """The bound is the method's own error at its order p and step h, not a measured number: an
    explicit p-stage Runge-Kutta method (p <= 4) has the stability function sum_{j <= p} z^j / j!,
    which leaves e^z by z^(p+1) / (p+1)!; on a motion whose fastest rate is Omega a step errs by
    about (Omega h)^(p+1) / (p+1)! rad, and the T / h steps add up to T Omega (Omega h)^p / (p+1)!
    (here 2.0e-10 rad at h = 1 ms, Omega = 6.93 rad/s; measured 6.2e-11 rk4_compiled, 5.5e-11
    rkmk4_compiled), Omega times that on the rates, at the samples more than two steps of the
    crank (2 Omega h) from a flat position. Nearer, the rates are not the method's: there the
    constraints' tangent turns with the position, by delta / theta for a coupler angle off the
    parallelogram by delta at theta from flat, so a position error of 1e-12 rad is a coupler rate of
    1e-9 rad/s at 7.7e-3 rad from flat (the sample at 0.71 s: 2.1e-9 rad/s rk4_compiled, per-state
    rk4 8.5e-9; rkmk4_compiled 6.6e-8, per-state rkmk4 6.1e-7: the Lie-group form takes its
    orientation rates from the stage's own angular velocities, not from those of its projection).
    Mishandled flat positions (a rank decision by pivots rather than by eigenvalues, the
    compiled form before 2026-11-27) add their own error to the angles and to the rates after the
    passage; a run that stops there fails the sample count."""
    sc = scene()
    h = 1e-3
    run = ENGINE.simulate(sc, RunSettings(T_END, h, SAVE, method))
    assert run.ok, run.message
    assert len(run.t) == round(T_END / SAVE) + 1 and run.t[-1] == pytest.approx(T_END)  # it did not stop early
    order = integrator("inhouse", method).order
    omega = fastest_rate(sc.params)
    bound = T_END * omega * (omega * h) ** order / math.factorial(order + 1)
    angle, rate = errors(sc.params, run, away=2.0 * omega * h)
    assert angle <= bound and rate <= omega * bound, (angle, rate, bound)


def test_dop853_compiled_passes_the_flat_positions_without_its_step_collapsing():
    """DOP853 sizes its steps so that its error estimate, of order (Omega h)^8 (SciPy's exponent
    -1/8), meets rtol: about rtol^(1/8) / Omega, capped at the save interval; twice the steps
    that makes is the bound (measured 160 against 185; deciding the rank by pivots took 1174:
    the step collapsed at every flat position, and before the least-squares multipliers the run
    stopped at the first, "step size collapsed"). Each accepted step's local error is at most
    sqrt(ny) (atol + rtol |y|) per entry (an RMS norm of 1), |y| <= 1 for quaternions, and a bar
    angle is twice its quaternion's: the steps add up to at most
    steps 2 sqrt(ny) (atol + rtol) rad (2e-7; measured 2e-14)."""
    sc = scene()
    rtol, atol = 1e-10, 1e-12
    run = ENGINE.simulate(sc, RunSettings(T_END, 1e-3, SAVE, "dop853_compiled", rtol=rtol, atol=atol))
    assert run.ok, run.message
    assert len(run.t) == round(T_END / SAVE) + 1 and run.t[-1] == pytest.approx(T_END)
    steps = run.stats["steps"]
    assert steps <= 2.0 * max(T_END / SAVE, T_END * fastest_rate(sc.params) * rtol ** (-1.0 / 8.0))
    ny = 13 * len(run.body_names)
    angle, _ = errors(sc.params, run)
    assert angle <= steps * 2.0 * math.sqrt(ny) * (atol + rtol)


# Where both forms keep the near-singular row, their accelerations differ by the round-off of a
# pseudo-inverse of condition kappa (n kappa eps of the largest, n rows; kappa of the row-scaled
# matrix); where both drop it, by the loops' usual round-off (OFF_MANIFOLD_RTOL of
# test_every_scene).
RHS_RTOL = 2e-9
# kernels.workspace: the buffer holding rhs's projection of its state (a loop model's stage) in
# its first 13 nb entries
STAGE = 17


def same_state(nem, got, expected, kappa) -> None:
    """Positions and orientations to 1e-11, velocities (m/s, rad/s) to 1e-11 of the largest, or
    near a flat position to the round-off of a solve of condition kappa amplified there: on the
    manifold the velocities turn with the positions (a position delta m off turns them by about
    |u| delta / theta), and kappa ~ 1 / theta^2 for the row-scaled matrix, so positions to
    n sqrt(kappa) eps m and velocities to n kappa eps of the largest (n rows)."""
    n7, eps = 7 * nem.nb, np.finfo(float).eps
    np.testing.assert_allclose(got[:n7], expected[:n7], rtol=0, atol=max(1e-11, nem.nc * math.sqrt(kappa) * eps))
    np.testing.assert_allclose(got[n7:], expected[n7:], rtol=0,
                               atol=max(1e-11, nem.nc * kappa * eps) * np.max(np.abs(expected[n7:])))


@pytest.mark.parametrize("theta", [1e-2, 5e-3, 2e-3, 1e-3, 1e-4, 3e-5, 1e-5, -1e-3, np.pi - 1e-3, np.pi + 2e-3])
def test_near_the_flat_position_the_kernels_solve_as_the_per_state_pseudo_inverse(theta):
    """At states of the parallelogram near its flat positions (the in-plane eigenvalue of the
    row-scaled J M^-1 J^T from 2.1e-5 to 2.1e-11 of the largest, on both sides of RANK_RTOL; a
    kept pivot below the kernels' _WELL_CONDITIONED within about 7e-5 rad: 3e-5 and 1e-5 here),
    on the manifold and off it (a Runge-Kutta stage, which both forms project first): the
    kernels' projection of the stage is the per-state ``project_stage``, their accelerations
    there the per-state ones (at that projection: near a flat position the accelerations turn
    with the positions as the velocities do), and the projection of a state 1e-8 off the
    manifold is the per-state projection. Round-off bounds of a solve of condition kappa (the
    row-scaled matrix's, on its kept spectrum), n kappa eps for the accelerations, and
    ``same_state``. Measured: accelerations at most 0.02 of their bound (3.7e-7 of the largest
    at 3e-5 rad, 1e-12 or less from 1e-3 rad on), positions and velocities at most 0.02 of
    theirs (1.7e-12 m and 1.7e-7 of 5 m/s at 1e-4 rad). Deciding the rank by the pivoted
    Cholesky's pivots of the unscaled matrix, the accelerations differed by up to 3e-6 (on the
    manifold) and 1.3e-3 (off it) of the largest, and the projections by 1.2e-7."""
    I, K = inertia_and_moment(scene().params)
    rate = -math.sqrt(1.0 + 2.0 * K / I * (1.0 - math.sin(theta)))  # the A02 motion's rate at theta
    sc = scene(theta0=theta, dtheta0=rate, branch=math.copysign(1.0, math.sin(theta)))  # the parallelogram side
    mb = sc.multibody()
    nem = build(mb)
    y = initial_state(mb, nem)
    model = compiled.pack(nem)
    ws = kernels.workspace(model)
    plain = make_rhs(nem)
    _, J, _ = rows(nem, y)
    A = J @ nem.Minv @ J.T
    d = np.sqrt(np.diag(A))
    w = np.linalg.eigvalsh(A / d[:, None] / d)
    kappa = w[-1] / np.min(w[w > RANK_RTOL * w[-1]])
    tol = projection_tolerance(nem)
    rng = np.random.default_rng(7)
    # a stage 1e-6 off the manifold, 1e-7 within 1e-4 rad of flat (1e-6 at 1e-5 rad: neither
    # form's Gauss-Newton converges in 8 steps)
    off_stage = 1e-6 if abs(math.sin(theta)) > 1e-4 else 1e-7
    for state in (y, y + off_stage * rng.standard_normal(len(y))):
        got = np.empty_like(state)
        assert kernels.rhs(0.0, state, got, model, ws) == kernels.OK
        stage = ws[STAGE][: len(state)].copy()  # the state whose derivative ``got`` is
        same_state(nem, stage, project_stage(nem, state, tol)[0], kappa)
        expected = plain(0.0, stage)
        np.testing.assert_allclose(got, expected, rtol=0,
                                   atol=max(RHS_RTOL, nem.nc * kappa * np.finfo(float).eps) * np.max(np.abs(expected)))
    off = y + 1e-8 * rng.standard_normal(len(y))
    expected = project(nem, off, tol=tol)
    assert kernels.project(off, model, ws, tol) == kernels.OK
    same_state(nem, off, expected, kappa)
