"""The compiled in-house solver (scalar kernels and SIMD lanes) against the per-state engine
(the slow oracle) and the NumPy batched solver: right-hand side, projection, integrators,
orders of convergence, batches, failures. No wall-clock assertions."""

from __future__ import annotations

import numpy as np
import pytest

from harness.engines.base import RunSettings
from harness.engines.inhouse import ENGINE, build, initial_state, make_rhs, project
from harness.engines.inhouse.compiled import solver as compiled
from harness.engines.inhouse.compiled import kernels
from harness.engines.inhouse.compiled import lanes
from harness.engines.inhouse.batched import batched_model
from harness.engines.inhouse.batched_integrators import integrate_batch
from harness.engines.inhouse.fast import FAST_ENGINE, projection_tolerance
from harness.model.scene import load_scene

# every joint type the compiled solver models, with parameters away from the defaults
CASES = [
    ("torque_free", {}),
    ("torque_free", {"I1": 0.7, "I2": 1.9, "I3": 2.3}),
    ("heavy_top", {}),
    ("heavy_top", {"mass": 2.5, "g": 3.0, "I1": 0.01, "theta0": 1.2}),
    ("double_pendulum", {}),
    ("double_pendulum", {"m": 0.3, "L": 2.0, "theta0": 2.5, "phi0": 1.0}),
    ("plate_pendulum", {}),
    ("rotating_plate", {}),
    ("cart_pendulum", {}),
    ("cart_pendulum", {"M": 3.0, "m": 0.2, "theta0": 2.0}),
    ("spring_pendulum", {}),
    ("spring_pendulum", {"k": 400.0, "m_hub": 0.5}),
]


def kkt_tolerance(nem, y):
    """Round-off of a KKT solve grows with the condition number of J M^-1 J^T (1e6 for the
    spring pendulum's light hub, 4 for the heavy top): the relative tolerance of a comparison
    with the per-state engine."""
    from harness.engines.inhouse.constraints import rows

    if not nem.nc:
        return 1e-12
    _, J, _ = rows(nem, y)
    return max(1e-12, 1e-16 * float(np.linalg.cond(J @ nem.Minv @ J.T)))


def states_near(name, n, seed=0, scale=1e-2, **params):
    """The scene's model, its initial state, and n states near it (rows)."""
    scene = load_scene(name).with_params(**params)
    model = scene.multibody()
    nem = build(model)
    y0 = initial_state(model, nem)
    rng = np.random.default_rng(seed)
    return nem, y0, y0 + scale * rng.standard_normal((n, len(y0)))


@pytest.mark.parametrize("name,params", CASES)
def test_compiled_rhs_equals_the_per_state_rhs(name, params):
    nem, _, Y = states_near(name, 6, **params)
    model = compiled.pack(nem)
    oracle = make_rhs(nem)
    ws = kernels.workspace(model)
    lws = lanes.workspace(model, len(Y))
    got_lanes = np.empty((nem.ny, len(Y)))
    lanes.rhs(0.3, np.ascontiguousarray(Y.T), got_lanes, model, lws)
    for i, y in enumerate(Y):
        expected = oracle(0.3, y)
        got = np.empty_like(y)
        assert kernels.rhs(0.3, y, got, model, ws) == kernels.OK
        atol = kkt_tolerance(nem, y) * np.max(np.abs(expected))
        np.testing.assert_allclose(got, expected, rtol=0, atol=atol)
        np.testing.assert_allclose(got_lanes[:, i], expected, rtol=0, atol=atol)


@pytest.mark.parametrize("name,params", CASES)
def test_compiled_projection_equals_the_per_state_projection(name, params):
    nem, _, Y = states_near(name, 5, seed=1, **params)
    model = compiled.pack(nem)
    ws = kernels.workspace(model)
    lws = lanes.workspace(model, len(Y))
    Z = np.ascontiguousarray(Y.T)
    lanes.project(Z, model, lws, 1e-13)
    assert not lws[12][:2].any()
    for i, y in enumerate(Y):
        expected = project(nem, y)
        got = y.copy()
        assert kernels.project(got, model, ws, 1e-13) == kernels.OK
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-11)
        np.testing.assert_allclose(Z[:, i], expected, rtol=0, atol=1e-11)


@pytest.mark.parametrize("name", ["torque_free", "heavy_top", "double_pendulum", "cart_pendulum", "spring_pendulum"])
def test_rk4_compiled_reproduces_the_per_state_rk4(name):
    scene = load_scene(name)
    dt = scene.dt * 5
    slow = ENGINE.simulate(scene, RunSettings(0.5, dt, 0.05, "rk4"))
    fast = FAST_ENGINE.simulate(scene, RunSettings(0.5, dt, 0.05, "rk4_compiled"))
    assert fast.ok and slow.ok, fast.message
    for a, b in ((fast.p_WCm_W, slow.p_WCm_W), (fast.quat_WB, slow.quat_WB), (fast.v_WCm_W, slow.v_WCm_W),
                 (fast.w_WB_W, slow.w_WB_W)):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-11)
    n = int(round(0.5 / dt))
    assert fast.stats["steps"] == n and fast.stats["rhs_evals"] == 4 * n
    assert "compiled in-house rk4_compiled" in fast.stats["settings"]


@pytest.mark.parametrize("name", ["torque_free", "heavy_top", "double_pendulum"])
def test_dop853_compiled_takes_the_steps_of_the_numpy_dop853(name):
    """Same method, same controller, same dense output: the same steps and samples."""
    scene = load_scene(name)
    settings = RunSettings(1.0, 0.1, 0.1, "dop853_compiled", rtol=1e-9, atol=1e-9)
    fast = FAST_ENGINE.simulate(scene, settings)
    numpy = FAST_ENGINE.simulate(scene, RunSettings(1.0, 0.1, 0.1, "dop853_fast", rtol=1e-9, atol=1e-9))
    assert fast.ok and numpy.ok
    assert fast.stats["steps"] == numpy.stats["steps"] and fast.stats["rejected"] == numpy.stats["rejected"]
    np.testing.assert_allclose(fast.p_WCm_W, numpy.p_WCm_W, rtol=0, atol=1e-11)
    np.testing.assert_allclose(fast.w_WB_W, numpy.w_WB_W, rtol=0, atol=1e-9 * np.max(np.abs(numpy.w_WB_W)))


def _torque_free_errors(method, settings):
    from harness.references.torque_free import omega_body

    scene = load_scene("torque_free")
    prm = scene.params
    nem = build(scene.multibody())
    model, y0 = compiled.pack(nem), initial_state(scene.multibody(), nem)
    t_save = np.arange(5) * 0.5
    errs = []
    for setting in settings:
        kw = ({"steps_per_save": int(round(0.5 / setting))} if method == "rk4_compiled"
              else {"rtol": setting, "atol": setting})
        res = compiled.integrate(model, y0, t_save, method, **kw)
        assert res.status == "ok", res.message
        w_B = res.Y[:, 0, 10:13]
        exact = omega_body(t_save, (prm["I1"], prm["I2"], prm["I3"]), prm["omega0"])
        errs.append(np.max(np.abs(w_B - exact)) / np.linalg.norm(exact[0]))
    return np.array(errs), res


def test_rk4_compiled_converges_at_order_4_to_the_elliptic_solution():
    hs = np.array([0.1, 0.05, 0.025])
    errs, _ = _torque_free_errors("rk4_compiled", hs)
    slopes = np.diff(np.log(errs)) / np.diff(np.log(hs))
    assert np.all(np.abs(slopes - 4) < 0.4), (slopes, errs)


def test_dop853_compiled_error_follows_its_tolerance():
    tols = np.array([1e-5, 1e-7, 1e-9, 1e-11])
    errs, res = _torque_free_errors("dop853_compiled", tols)
    assert np.all(np.diff(errs) < 0), errs
    assert errs[-1] < 1e-9 and res.rhs_evals >= 12 * res.steps


@pytest.mark.parametrize("name", ["torque_free", "heavy_top", "double_pendulum", "spring_pendulum"])
@pytest.mark.parametrize("threads,group", [(1, 64), (2, 4), (2, 3)])
def test_a_lane_batch_is_the_scalar_trajectories_side_by_side(name, threads, group):
    nem, _, Y = states_near(name, 7, seed=2)
    model = compiled.pack(nem)
    tol = projection_tolerance(nem)
    Yend, words = compiled.run_batch(model, Y, 20, 1e-3, threads=threads, proj_tol=tol, lanes_per_group=group)
    assert list(words) == ["ok"] * 7
    for i, y in enumerate(Y):
        res = compiled.integrate(model, y, np.array([0.0, 0.02]), "rk4_compiled", steps_per_save=20, proj_tol=tol)
        np.testing.assert_allclose(Yend[i], res.Y[-1, 0], rtol=0, atol=1e-12 * max(1.0, np.max(np.abs(y))))


def test_a_bad_lane_is_recorded_and_leaves_the_others_alone():
    nem, _, Y = states_near("heavy_top", 5, seed=4)
    model = compiled.pack(nem)
    clean, _ = compiled.run_batch(model, Y, 10, 1e-3, threads=1)
    bad = Y.copy()
    bad[2, 10] = np.nan  # one lane's angular velocity
    bad[3, 0] = 1e3  # another lane's top 1 km from its pivot: no projection
    Yend, words = compiled.run_batch(model, bad, 10, 1e-3, threads=1)
    assert words[2] == "blowup" and words[3] == "failed"
    keep = [0, 1, 4]
    assert list(words[keep]) == ["ok"] * 3
    np.testing.assert_array_equal(Yend[keep], clean[keep])


def test_failures_are_returned_not_raised():
    nem, y0, _ = states_near("torque_free", 1)
    model = compiled.pack(nem)
    bad = y0.copy()
    bad[-3:] = 1e200  # finite, but w x I w overflows in the first step
    res = compiled.integrate(model, bad, np.array([0.0, 0.1]), "rk4_compiled", steps_per_save=2)
    assert res.status == "blowup" and len(res.t) == 1
    nem, y0, _ = states_near("heavy_top", 1)
    huge = y0.copy()
    huge[0] = 1e3
    res = compiled.integrate(compiled.pack(nem), huge, np.array([0.0, 0.1]), "dop853_compiled")
    assert res.status == "failed" and "projection did not converge" in res.message
    scene = load_scene("heavy_top")
    coarse = FAST_ENGINE.simulate(scene, RunSettings(1.0, 0.5, 0.5, "rk4_compiled"))
    assert not coarse.ok and coarse.message


@pytest.mark.parametrize("name,params,what", [
    ("rolling_disk", {}, "rolling contacts"),
    ("double_pendulum", {"F0": 1.0, "omega_f": 2.0}, "prescribed forces"),
])
def test_models_outside_the_compiled_solver_are_refused(name, params, what):
    nem = build(load_scene(name).with_params(**params).multibody())
    with pytest.raises(NotImplementedError, match=what):
        compiled.pack(nem)


def test_integrate_takes_one_state():
    nem, y0, Y = states_near("torque_free", 2)
    with pytest.raises(ValueError, match="one state"):
        compiled.integrate(compiled.pack(nem), Y, np.array([0.0, 0.1]), "rk4_compiled")
    with pytest.raises(ValueError, match="unknown compiled integrator"):
        compiled.integrate(compiled.pack(nem), y0, np.array([0.0, 0.1]), "rk5_compiled")


def test_numpy_and_compiled_batches_agree():
    nem, _, Y = states_near("double_pendulum", 4, seed=5)
    model = compiled.pack(nem)
    bm = batched_model(nem)
    res = integrate_batch(bm, Y, np.array([0.0, 0.02]), "rk4_batched", steps_per_save=20,
                          proj_tol=projection_tolerance(nem))
    Yend, _ = compiled.run_batch(model, Y, 20, 1e-3, proj_tol=projection_tolerance(nem))
    np.testing.assert_allclose(Yend, res.Y[-1], rtol=0, atol=1e-11)
