"""The N four-bar chain (IFToMM A02, ``references/four_bar_chain.py``) against independent checks.

* the elliptic closed form against a tight integration of its own equation I theta'' = -K cos theta,
  over A02's 20 s at N = 40 (every flat position of the motion included);
* the reduction to that equation against a second formulation written here: the planar
  Lagrange equations of all 2N + 1 bars in their absolute angles with the N windows' closures as
  constraints (an index-1 DAE, DOP853 rtol 1e-12), integrated from the closed form's state over
  every stretch of the motion between two flat positions (where that DAE is singular), N = 3;
* energy conservation of the closed form; the modelled cylinders' distance from A02's rods;
* the exact check: zero on the closed form's own trajectory, and a window off its
  parallelogram (one crank's tip moved) is what it reports.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from harness.engines import load_scene
from harness.measure.trajectory import Trajectory
from harness.model import rotations
from harness.model.builders.four_bar_chain import coupler, crank
from harness.references import four_bar_chain as ref

SCENE = load_scene("four_bar_chain", {"N": 3})
A02 = load_scene("four_bar_chain").params  # N = 40, 20 s


def _e(x):
    return np.stack([np.cos(x), np.sin(x)])


def _ep(x):
    return np.stack([-np.sin(x), np.cos(x)])


def test_the_closed_form_is_the_motion_of_its_equation_over_a02s_20_s():
    """``crank_motion`` against DOP853 (rtol 1e-13) on I theta'' = -K cos theta at N = 40 over 20 s:
    9.8e-11 rad and 1.6e-10 rad/s measured; the motion turns over about ten times, through 20 flat
    positions (theta a multiple of pi)."""
    I, K = ref.inertia_and_moment(A02)
    t = np.linspace(0.0, 20.0, 401)
    sol = solve_ivp(lambda _t, y: [y[1], -K * np.cos(y[0]) / I], (0.0, 20.0), [A02["theta0"], A02["dtheta0"]],
                    method="DOP853", t_eval=t, rtol=1e-13, atol=1e-14)
    theta, rate, acc = ref.crank_motion(A02, t)
    np.testing.assert_allclose(theta, sol.y[0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(rate, sol.y[1], rtol=0, atol=1e-9)
    np.testing.assert_allclose(acc, -K * np.cos(theta) / I, rtol=0, atol=1e-9)
    flats = np.floor(theta / np.pi)
    assert abs(flats[0] - flats[-1]) == 20


def test_the_closed_form_conserves_energy():
    """T + V = I theta'^2 / 2 + K sin theta (J) along the closed form, to round-off."""
    I, K = ref.inertia_and_moment(A02)
    theta, rate, _ = ref.crank_motion(A02, np.linspace(0.0, 20.0, 2001))
    energy = 0.5 * I * rate**2 + K * np.sin(theta)
    assert np.ptp(energy) < 1e-10 * (0.5 * I * np.max(rate**2))


def _chain_dae(p, alpha: float):
    """The right-hand side of the planar chain in its absolute angles q = (theta_0 .. theta_N,
    beta_0 .. beta_{N-1}) (rad): crank i about its pivot, coupler i about crank i's tip, the
    window i closure L e(theta_i) + L e(beta_i) - L e_x - L e(theta_{i+1}) = 0 (2 rows each,
    Baumgarte gain alpha), M q'' + h + grad V = Phi_q^T lambda (module docstring)."""
    n, L, m, r, g = int(p["N"]), p["L"], p["m"], p["r"], p["g"]
    J_pivot = m * (0.25 * r * r + L * L / 3.0)  # a cylinder about its end
    J_centre = m * (3.0 * r * r + L * L) / 12.0
    k = 0.5 * m * L * L

    def rhs(_t, y):
        q, u = y[: 2 * n + 1], y[2 * n + 1 :]
        th, be = q[: n + 1], q[n + 1 :]
        dth, dbe = u[: n + 1], u[n + 1 :]
        M = np.zeros((2 * n + 1, 2 * n + 1))
        f = np.zeros(2 * n + 1)
        M[range(n + 1), range(n + 1)] = J_pivot
        f[: n + 1] = -g * 0.5 * m * L * np.cos(th)
        for i in range(n):
            a, b = i, n + 1 + i
            c = k * np.cos(th[i] - be[i])
            M[a, a] += m * L * L
            M[b, b] = 0.25 * m * L * L + J_centre
            M[a, b] = M[b, a] = c
            s = k * np.sin(th[i] - be[i])
            f[a] += -s * dbe[i] ** 2 - g * m * L * np.cos(th[i])
            f[b] += s * dth[i] ** 2 - g * 0.5 * m * L * np.cos(be[i])
        Jq = np.zeros((2 * n, 2 * n + 1))
        gam = np.zeros(2 * n)
        for i in range(n):
            rows = slice(2 * i, 2 * i + 2)
            Jq[rows, i] = L * _ep(th[i])
            Jq[rows, n + 1 + i] = L * _ep(be[i])
            Jq[rows, i + 1] = -L * _ep(th[i + 1])
            phi = L * _e(th[i]) + L * _e(be[i]) - np.array([L, 0.0]) - L * _e(th[i + 1])
            bias = -L * _e(th[i]) * dth[i] ** 2 - L * _e(be[i]) * dbe[i] ** 2 + L * _e(th[i + 1]) * dth[i + 1] ** 2
            gam[rows] = -bias - 2.0 * alpha * (Jq[rows] @ u) - alpha * alpha * phi
        kkt = np.block([[M, -Jq.T], [Jq, np.zeros((2 * n, 2 * n))]])
        acc = np.linalg.solve(kkt, np.concatenate([f, gam]))[: 2 * n + 1]
        return np.concatenate([u, acc])

    return rhs


def test_the_chains_lagrange_equations_follow_the_closed_form_between_its_flat_positions():
    """N = 3 (7 bars, 3 windows): the DAE of ``_chain_dae`` from the closed form's state 0.05 s
    after a flat position (or at t = 0) to 0.05 s before the next, over the first 4 s (four
    stretches): every crank at theta(t), every coupler level, within 1e-9 rad (measured 1.1e-11).
    At a flat position the DAE's closure Jacobian loses rank (the 1 + N degrees of freedom of an
    instant): the closed form carries the motion through, the parallelogram branch being smooth."""
    p = SCENE.params
    n = int(p["N"])
    rhs = _chain_dae(p, alpha=10.0)
    t = np.linspace(0.0, 4.0, 4001)
    theta, _, _ = ref.crank_motion(p, t)
    flat = t[np.nonzero(np.diff(np.floor(theta / np.pi)))[0]]
    starts = [0.0] + list(flat + 0.05)
    ends = list(flat - 0.05) + [4.0]
    worst = 0.0
    for a, b in zip(starts, ends):
        th, dth, _ = ref.crank_motion(p, [a])
        y0 = np.concatenate([np.full(n + 1, th[0]), np.zeros(n), np.full(n + 1, dth[0]), np.zeros(n)])
        ts = np.linspace(a, b, 21)
        sol = solve_ivp(rhs, (a, b), y0, method="DOP853", t_eval=ts, rtol=1e-12, atol=1e-12)
        assert sol.success
        exact, _, _ = ref.crank_motion(p, ts)
        worst = max(worst, float(np.max(np.abs(sol.y[: n + 1] - exact))), float(np.max(np.abs(sol.y[n + 1 : 2 * n + 1]))))
    assert len(starts) >= 4
    assert worst < 1e-9


def test_a02s_rods_stay_within_its_allowed_error_of_the_modelled_cylinders():
    """B0 of the scene's cylinders (r = 5 mm) against A02's slender rods over the 20 s: well
    inside A02's 1e-3 m (measured 2.1e-4 m; it grows as r^2)."""
    assert ref.rod_distance(A02, np.linspace(0.0, 20.0, 401)) < 0.3 * ref.BENCHMARK["required"]


def _synthetic(p, t) -> Trajectory:
    """The closed form as a run of the scene: every crank at theta about its pivot, every coupler
    level at its crank's tip (the bodies in the builder's order)."""
    n, L = int(p["N"]), p["L"]
    theta, rate, _ = ref.crank_motion(p, t)
    tips = ref.tip_positions(p, theta)
    names, pos, quat = [], [], []
    for i in range(n + 1):
        names.append(crank(i, n))
        pos.append(tips[:, i] - 0.5 * L * np.stack([np.cos(theta), np.zeros_like(theta), np.sin(theta)], 1))
        quat.append(np.stack([rotations.from_axis_angle(np.array([0.0, -1.0, 0.0]), th) for th in theta]))
        if i < n:
            names.append(coupler(i, n))
            pos.append(tips[:, i] + np.array([0.5 * L, 0.0, 0.0]))
            quat.append(np.tile([1.0, 0.0, 0.0, 0.0], (len(t), 1)))
    zeros = np.zeros((len(t), len(names), 3))
    return Trajectory("synthetic", "none", tuple(names), np.asarray(t, float), np.stack(pos, 1), np.stack(quat, 1),
                      zeros, zeros)


def test_the_exact_check_is_zero_on_the_closed_form_and_sees_a_folded_window():
    """On the closed form itself: round-off. With crank 2 turned 1e-3 rad off theta after
    1 s (its window leaving the parallelogram): about L 1e-3 m, named by that tip."""
    t = np.linspace(0.0, 2.0, 41)
    run = _synthetic(SCENE.params, t)
    value, unit, detail = ref.exact_error(SCENE, run)
    assert unit == "m" and value < 1e-12 and "B0" in detail
    j = run.body_names.index(crank(2, 3))
    later = t >= 1.0
    off = rotations.from_axis_angle(np.array([0.0, -1.0, 0.0]), 1e-3)
    quat = run.quat_WB.copy()
    quat[later, j] = [rotations.multiply(q, off) for q in quat[later, j]]
    pos = run.p_WCm_W.copy()
    R = rotations.matrix(quat[:, j])
    pos[:, j] = np.array([2.0, 0.0, 0.0]) + R @ np.array([0.5, 0.0, 0.0])  # about its pivot
    moved = Trajectory("synthetic", "none", run.body_names, t, pos, quat, run.v_WCm_W, run.w_WB_W)
    series = ref.exact_error_series(SCENE, moved)
    assert np.all(series[~later] < 1e-12)
    assert series[later] == pytest.approx(np.full(later.sum(), 1e-3), rel=1e-3)


def test_the_benchmark_is_a02s():
    assert ref.BENCHMARK["problem"] == "IFToMM A02" and ref.BENCHMARK["required"] == 1e-3
    assert A02["N"] == 40 and load_scene("four_bar_chain").t_end == 20.0
