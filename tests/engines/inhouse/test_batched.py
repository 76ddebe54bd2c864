"""The batched in-house solver against the per-state engine (the slow oracle): right-hand side,
projection, integrators, orders of convergence, failures."""

from __future__ import annotations

import numpy as np
import pytest

from harness.engines.base import RunSettings
from harness.engines.inhouse import ENGINE, Baumgarte, build, initial_state, make_rhs, project, to_trajectory
from harness.engines.inhouse.batched import batched_model, columns, spd_solve
from harness.engines.inhouse.batched_integrators import NOMINAL_ORDER, dexpinv, integrate_batch, quat_exp
from harness.engines.inhouse.constraints import DynamicsError
from harness.engines.inhouse.fast import FAST_ENGINE
from harness.model.errors import InputError
from harness.model.scene import load_scene

SCENES = ("torque_free", "heavy_top", "double_pendulum")


def states_near(name, n, seed=0, **params):
    scene = load_scene(name).with_params(**params)
    model = scene.multibody()
    nem = build(model)
    y0 = initial_state(model, nem)
    rng = np.random.default_rng(seed)
    return nem, y0, y0 + 1e-2 * rng.standard_normal((n, len(y0)))


@pytest.mark.parametrize("name,params", [(s, {}) for s in SCENES] + [("double_pendulum", {"F0": 2.0, "omega_f": 3.0})])
@pytest.mark.parametrize("gains", [Baumgarte(), Baumgarte(omega=3.0, zeta=0.7)])
@pytest.mark.parametrize("nbatch", [2, 5, 40])  # LAPACK path (< 32 columns) and unrolled Cholesky
def test_batched_rhs_equals_per_state_rhs(name, params, gains, nbatch):
    nem, _, Y = states_near(name, nbatch, **params)
    oracle = make_rhs(nem, gains)
    expected = np.stack([oracle(0.37, y) for y in Y])
    got = batched_model(nem, gains).rhs_rows(0.37, Y)
    assert got.shape == (nbatch, nem.ny)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * np.max(np.abs(expected)))


def test_batched_rhs_takes_one_time_per_column():
    nem, _, Y = states_near("double_pendulum", 3, F0=2.0, omega_f=3.0)
    oracle = make_rhs(nem)
    t = np.array([0.1, 0.5, 0.9])
    got = batched_model(nem).rhs(t, columns(Y, nem.ny)).T
    expected = np.stack([oracle(ti, y) for ti, y in zip(t, Y)])
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * np.max(np.abs(expected)))


@pytest.mark.parametrize("name", SCENES)
@pytest.mark.parametrize("nbatch", [2, 40])
def test_batched_projection_equals_per_state_projection(name, nbatch):
    nem, _, Y = states_near(name, nbatch, seed=1)
    expected = np.stack([project(nem, y) for y in Y])
    got = batched_model(nem).project_rows(Y)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)


def test_columns_checks_the_shape():
    with pytest.raises(ValueError, match=r"states must be nbatch x 13, got shape \(2, 12\)"):
        columns(np.zeros((2, 12)), 13)
    assert columns(np.arange(13.0), 13).shape == (13, 1)


@pytest.mark.parametrize("nbatch", [3, 64])
def test_spd_solve_small_and_large_batches(nbatch):
    rng = np.random.default_rng(2)
    M = rng.standard_normal((nbatch, 6, 6))
    A = M @ M.transpose(0, 2, 1) + 6 * np.eye(6)
    b = rng.standard_normal((nbatch, 6))
    x = spd_solve(np.moveaxis(A, 0, -1).copy(), b.T.copy())
    np.testing.assert_allclose(x.T, np.linalg.solve(A, b[:, :, None])[:, :, 0], rtol=1e-12, atol=1e-12)
    A[0] = 0.0
    with pytest.raises(DynamicsError):
        spd_solve(np.moveaxis(A, 0, -1).copy(), b.T.copy())


def test_models_outside_the_batched_equations_are_refused():
    from harness.model import multibody

    body = multibody.Body("cart", None, "slide", np.zeros(3), np.array([1.0, 0, 0]), 1.0, np.zeros(3), np.eye(3))
    model = multibody.Multibody((body,), np.array([0, 0, -9.81]), {"cart": np.zeros(1)}, {"cart": np.zeros(1)})
    with pytest.raises(NotImplementedError, match="supports free, ball and hinge joints"):
        batched_model(build(model))


def test_quaternion_exponential_and_dexpinv():
    theta = np.array([[0.3], [-0.2], [0.5]])[None]  # (1, 3, 1)
    q = quat_exp(theta)[0, :, 0]
    angle = np.linalg.norm(theta)
    np.testing.assert_allclose(q, np.r_[np.cos(angle / 2), np.sin(angle / 2) * theta[0, :, 0] / angle], rtol=1e-15)
    np.testing.assert_allclose(quat_exp(np.zeros((1, 3, 1)))[0, :, 0], [1, 0, 0, 0])
    # dexpinv is the right-trivialised inverse Jacobian to O(|theta|^3): compare with the closed form
    small = 1e-2 * theta
    w = np.array([[0.7], [0.1], [-0.4]])[None]
    t, a = small[0, :, 0], np.linalg.norm(small)
    K = np.array([[0, -t[2], t[1]], [t[2], 0, -t[0]], [-t[1], t[0], 0]])
    exact = (np.eye(3) + K / 2 + (1 / a**2 - (1 + np.cos(a)) / (2 * a * np.sin(a))) * K @ K) @ w[0, :, 0]
    assert np.max(np.abs(dexpinv(small, w)[0, :, 0] - exact)) < 1e-3 * a**4


def reference(name, t_end, save):
    scene = load_scene(name)
    settings = RunSettings(t_end, save / 10, save / 10, "DOP853", rtol=1e-13, atol=1e-13)
    ref = ENGINE.simulate(scene, settings)
    return scene, ref, slice(None, None, 10)


def state_error(traj, ref, idx):
    """Largest absolute difference over samples and bodies: positions (m), orientation (rad,
    geodesic), velocities (m/s, rad/s)."""
    from harness.measure import compare
    from harness.studies.workprecision.run import _take

    e = compare.trajectory_error(traj, _take(ref, idx))
    return max(e["position_max"], e["orientation_max"], e["velocity_max"], e["angular_velocity_max"])


@pytest.mark.parametrize("name", SCENES)
def test_rk4_batched_reproduces_the_per_state_rk4(name):
    scene = load_scene(name)
    settings = RunSettings(0.5, scene.dt * 5, 0.05, "rk4")
    slow = ENGINE.simulate(scene, settings)
    fast = FAST_ENGINE.simulate(scene, RunSettings(0.5, scene.dt * 5, 0.05, "rk4_batched"))
    assert fast.ok and slow.ok
    for a, b in ((fast.p_WCm_W, slow.p_WCm_W), (fast.quat_WB, slow.quat_WB), (fast.v_WCm_W, slow.v_WCm_W), (fast.w_WB_W, slow.w_WB_W)):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-11)
    n = int(round(0.5 / (scene.dt * 5)))
    assert fast.stats["steps"] == slow.stats["steps"] == n
    assert fast.stats["rhs_evals"] == 4 * n


@pytest.mark.parametrize("name", SCENES)
@pytest.mark.parametrize("method,setting", [("rkmk4", 0.0025), ("dop853_fast", 1e-11), ("gbs_parallel", 1e-11)])
def test_fast_integrators_agree_with_the_per_state_engine(name, method, setting):
    t_end, save = 1.0, 0.25
    scene, ref, idx = reference(name, t_end, save)
    if method == "rkmk4":
        settings = RunSettings(t_end, setting * (0.2 if name == "heavy_top" else 1.0), save, method)
        tol = 1e-6
    else:
        settings = RunSettings(t_end, save, save, method, rtol=setting, atol=setting)
        tol = 1e-8
    traj = FAST_ENGINE.simulate(scene, settings)
    assert traj.ok, traj.message
    assert state_error(traj, ref, idx) < tol


def fixed_step_errors(method, hs, **kw):
    scene, ref, idx = reference("torque_free", 2.0, 0.5)
    nem = build(scene.multibody())
    bm, y0 = batched_model(nem), initial_state(scene.multibody(), nem)
    t_save = np.arange(5) * 0.5
    out = []
    for h in hs:
        if method in ("dop853_fast", "gbs_parallel"):
            res = integrate_batch(bm, y0, t_save, method, fixed_step=h, **kw)
        else:
            res = integrate_batch(bm, y0, t_save, method, steps_per_save=int(round(0.5 / h)))
        assert res.status == "ok", res.message
        out.append(state_error(to_trajectory(nem, res.t, res.Y[:, 0]), ref, idx))
    return np.array(out)


@pytest.mark.parametrize("method,hs,kw,order", [
    ("rk4_batched", [0.1, 0.05, 0.025], {}, 4),
    ("rkmk4", [0.1, 0.05, 0.025], {}, 4),
    ("euler_batched", [0.01, 0.005, 0.0025], {}, 1),
    ("dop853_fast", [0.5, 0.25, 0.125], {}, 8),
    ("gbs_parallel", [0.25, 0.125, 0.0625], {"sequences": 2}, 4),
    ("gbs_parallel", [0.5, 0.25, 0.125], {"sequences": 3}, 6),
])
def test_orders_of_convergence_are_the_nominal_ones(method, hs, kw, order):
    err = fixed_step_errors(method, hs, **kw)
    slopes = np.diff(np.log(err)) / np.diff(np.log(hs))
    assert np.all(np.abs(slopes - order) < 0.35 * order), (slopes, err)
    if method != "gbs_parallel":
        assert NOMINAL_ORDER[method] == order


def test_a_batch_is_the_trajectories_side_by_side():
    nem, _, Y = states_near("heavy_top", 3, seed=3)
    bm = batched_model(nem)
    Y = bm.project_rows(Y)
    t_save = np.linspace(0.0, 0.2, 5)
    together = integrate_batch(bm, Y, t_save, "rk4_batched", steps_per_save=10)
    for i in range(3):
        alone = integrate_batch(bm, Y[i], t_save, "rk4_batched", steps_per_save=10)
        np.testing.assert_allclose(together.Y[:, i], alone.Y[:, 0], rtol=0, atol=1e-12)
    adaptive = integrate_batch(bm, Y, t_save, "dop853_fast", rtol=1e-11, atol=1e-11)
    for i in range(3):  # one step size for the batch: each column at least as accurate as alone
        alone = integrate_batch(bm, Y[i], t_save, "dop853_fast", rtol=1e-11, atol=1e-11)
        np.testing.assert_allclose(adaptive.Y[:, i], alone.Y[:, 0], rtol=0, atol=1e-8)


def test_failures_are_returned_not_raised():
    nem, y0, _ = states_near("torque_free", 1)
    bm = batched_model(nem)
    bad = y0.copy()
    bad[-3:] = 1e200  # finite, but w x I w overflows in the first step
    res = integrate_batch(bm, bad, np.array([0.0, 0.1]), "rk4_batched", steps_per_save=2, project=False)
    assert res.status == "blowup" and len(res.t) == 1
    nem, y0, _ = states_near("heavy_top", 1)
    huge = y0.copy()
    huge[0] = 1e3  # tip 1 km off its pivot: the projection cannot converge
    res = integrate_batch(batched_model(nem), huge, np.array([0.0, 0.1]), "dop853_fast")
    assert res.status == "failed" and "DynamicsError" in res.message


def test_fast_engine_checks_settings():
    with pytest.raises(InputError, match="unknown integrator 'rk5'"):
        FAST_ENGINE.simulate(load_scene("torque_free"), RunSettings(1.0, 0.01, 0.1, "rk5"))
