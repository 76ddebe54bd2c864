"""The compiled in-house solver (Numba kernels) against the per-state engine (the readable
oracle): right-hand side, projection, integrators, orders of convergence, batches, failures,
and its place in the engine (``rk4_compiled``, ``dop853_compiled``). No wall-clock assertions."""

from __future__ import annotations

import numpy as np
import pytest

from harness.cli.main import main
from harness.engines import get_engine, integrator
from harness.engines.base import RunSettings
from harness.engines.inhouse import ENGINE, build, initial_state, make_rhs, project, projection_tolerance
from harness.engines.inhouse.compiled import kernels
from harness.engines.inhouse.compiled import solver as compiled
from harness.engines.inhouse.integrators import RK4, ButcherTableau, integrate_fixed
from harness.engines import load_scene

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

# Kutta's third-order method: not used by the engine, here to show that a table is a method
KUTTA3 = ButcherTableau(
    name="kutta3",
    A=((0.0, 0.0, 0.0), (0.5, 0.0, 0.0), (-1.0, 2.0, 0.0)),
    b=(1.0 / 6.0, 2.0 / 3.0, 1.0 / 6.0),
    c=(0.0, 0.5, 1.0),
    order=3,
)


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


def same_motion(a, b, atol):
    for x, y in ((a.p_WCm_W, b.p_WCm_W), (a.quat_WB, b.quat_WB), (a.v_WCm_W, b.v_WCm_W), (a.w_WB_W, b.w_WB_W)):
        np.testing.assert_allclose(x, y, rtol=0, atol=atol)


@pytest.mark.parametrize("name,params", CASES)
def test_compiled_rhs_equals_the_per_state_rhs(name, params):
    nem, _, Y = states_near(name, 6, **params)
    model = compiled.pack(nem)
    oracle = make_rhs(nem)
    ws = kernels.workspace(model)
    for y in Y:
        expected = oracle(0.3, y)
        got = np.empty_like(y)
        assert kernels.rhs(0.3, y, got, model, ws) == kernels.OK
        np.testing.assert_allclose(got, expected, rtol=0, atol=kkt_tolerance(nem, y) * np.max(np.abs(expected)))


@pytest.mark.parametrize("name,params", CASES)
def test_compiled_projection_equals_the_per_state_projection(name, params):
    nem, _, Y = states_near(name, 5, seed=1, **params)
    model = compiled.pack(nem)
    ws = kernels.workspace(model)
    for y in Y:
        expected = project(nem, y)
        got = y.copy()
        assert kernels.project(got, model, ws, 1e-13) == kernels.OK
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-11)


def test_compiled_methods_are_integrators_of_the_inhouse_engine():
    assert {"rk4_compiled", "dop853_compiled"} <= set(get_engine("inhouse").integrators)
    rk4, dop = integrator("inhouse", "rk4_compiled"), integrator("inhouse", "dop853_compiled")
    assert (rk4.kind, rk4.order, rk4.stages) == ("fixed", RK4.order, len(RK4.b))
    assert (dop.kind, dop.order, dop.stages) == ("adaptive", 8, 12)


@pytest.mark.parametrize("name", ["torque_free", "heavy_top", "double_pendulum", "cart_pendulum", "spring_pendulum"])
def test_rk4_compiled_reproduces_the_per_state_rk4(name):
    scene = load_scene(name)
    dt = scene.dt * 5
    slow = ENGINE.simulate(scene, RunSettings(0.5, dt, 0.05, "rk4"))
    fast = ENGINE.simulate(scene, RunSettings(0.5, dt, 0.05, "rk4_compiled"))
    assert fast.ok and slow.ok, fast.message
    assert (fast.engine, fast.integrator) == ("inhouse", "rk4_compiled")
    same_motion(fast, slow, 1e-11)
    n = int(round(0.5 / dt))
    assert fast.stats["steps"] == n and fast.stats["rhs_evals"] == 4 * n and fast.stats["wall_s"] > 0
    assert "compiled (Numba)" in fast.stats["settings"] and "projection" in fast.stats["settings"]
    if "reaction" in scene.checks:  # the same joint reactions, from the oracle's reaction_series
        assert set(fast.reactions) == set(slow.reactions)
        for key in slow.reactions:
            ref = np.asarray(slow.reactions[key])
            np.testing.assert_allclose(fast.reactions[key], ref, rtol=0, atol=1e-8 * max(1.0, np.max(np.abs(ref))))


@pytest.mark.parametrize("name", ["torque_free", "torque_free_symmetric"])
@pytest.mark.parametrize("tol", [1e-6, 1e-9, 1e-12])
def test_dop853_compiled_takes_the_steps_of_scipys_dop853(name, tol):
    """Free bodies: no constraints, no Baumgarte terms in the per-state run, so the same method,
    controller and first step take the same steps (the compiled one renormalises quaternions)."""
    scene = load_scene(name)
    scipy = ENGINE.simulate(scene, RunSettings(2.0, 0.01, 2.0, "DOP853", rtol=tol, atol=tol))
    fast = ENGINE.simulate(scene, RunSettings(2.0, 0.01, 2.0, "dop853_compiled", rtol=tol, atol=tol))
    assert fast.ok and scipy.ok
    assert fast.stats["steps"] == scipy.stats["steps"]
    assert fast.stats["rhs_evals"] >= 12 * fast.stats["steps"]
    same_motion(fast, scipy, 100 * tol)


@pytest.mark.parametrize("name", ["heavy_top", "double_pendulum", "spring_pendulum"])
def test_dop853_compiled_agrees_with_the_per_state_reference(name):
    scene = load_scene(name)
    ref = ENGINE.simulate(scene, RunSettings(1.0, 0.025, 0.025, "DOP853", rtol=1e-13, atol=1e-13))
    fast = ENGINE.simulate(scene, RunSettings(1.0, 0.25, 0.25, "dop853_compiled", rtol=1e-11, atol=1e-11))
    assert fast.ok and ref.ok, fast.message
    idx = slice(None, None, 10)
    for a, b in ((fast.p_WCm_W, ref.p_WCm_W[idx]), (fast.v_WCm_W, ref.v_WCm_W[idx]), (fast.w_WB_W, ref.w_WB_W[idx])):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-8 * max(1.0, np.max(np.abs(b))))


def _torque_free_errors(settings, method="fixed", tableau=RK4):
    from harness.references.torque_free import omega_body

    scene = load_scene("torque_free")
    prm = scene.params
    nem = build(scene.multibody())
    model, y0 = compiled.pack(nem), initial_state(scene.multibody(), nem)
    t_save = np.arange(5) * 0.5
    errs = []
    for setting in settings:
        if method == "fixed":
            res = compiled.integrate_fixed(model, y0, t_save, tableau, steps_per_save=int(round(0.5 / setting)))
        else:
            res = compiled.integrate_dop853(model, y0, t_save, rtol=setting, atol=setting)
        assert res.status == "ok", res.message
        exact = omega_body(t_save, (prm["I1"], prm["I2"], prm["I3"]), prm["omega0"])
        errs.append(np.max(np.abs(res.y[:, 10:13] - exact)) / np.linalg.norm(exact[0]))
    return np.array(errs), res


@pytest.mark.parametrize("tableau,hs", [(RK4, [0.1, 0.05, 0.025]), (KUTTA3, [0.05, 0.025, 0.0125])])
def test_a_butcher_table_converges_at_its_order_to_the_elliptic_solution(tableau, hs):
    errs, res = _torque_free_errors(hs, tableau=tableau)
    slopes = np.diff(np.log(errs)) / np.diff(np.log(hs))
    assert np.all(np.abs(slopes - tableau.order) < 0.4), (slopes, errs)
    assert res.rhs_evals == len(tableau.b) * res.steps


def test_a_new_table_runs_the_same_in_both_forms():
    """The compiled stepper and the per-state one take any table: same steps, same states."""
    nem, y0, _ = states_near("double_pendulum", 1)
    t_save = np.linspace(0.0, 0.2, 5)
    tol = projection_tolerance(nem)
    slow = integrate_fixed(make_rhs(nem), y0, t_save, 10, KUTTA3, post_step=lambda y: project(nem, y, tol=tol))
    fast = compiled.integrate_fixed(compiled.pack(nem), y0, t_save, KUTTA3, steps_per_save=10, proj_tol=tol)
    assert fast.status == slow.status == "ok"
    assert fast.steps == slow.steps and fast.rhs_evals == slow.rhs_evals == 3 * 40
    np.testing.assert_allclose(fast.y[1:], slow.y[1:], rtol=0, atol=1e-12)


def test_dop853_compiled_error_follows_its_tolerance():
    tols = np.array([1e-5, 1e-7, 1e-9, 1e-11])
    errs, res = _torque_free_errors(tols, method="dop853")
    assert np.all(np.diff(errs) < 0), errs
    assert errs[-1] < 1e-9 and res.rhs_evals >= 12 * res.steps


def test_tables_must_be_explicit():
    implicit = ButcherTableau("midpoint", A=((0.5,),), b=(1.0,), c=(0.5,), order=2)
    with pytest.raises(ValueError, match="not an explicit Butcher table"):
        compiled.tableau_arrays(implicit)


@pytest.mark.parametrize("name", ["torque_free", "heavy_top", "double_pendulum", "spring_pendulum"])
@pytest.mark.parametrize("threads", [1, 2, 3])
def test_a_batch_is_the_scalar_trajectories(name, threads):
    nem, _, Y = states_near(name, 7, seed=2)
    model = compiled.pack(nem)
    tol = projection_tolerance(nem)
    Yend, words = compiled.run_batch(model, Y, 20, 1e-3, threads=threads, proj_tol=tol)
    assert list(words) == ["ok"] * 7
    for i, y in enumerate(Y):
        res = compiled.integrate_fixed(model, y, np.array([0.0, 0.02]), steps_per_save=20, proj_tol=tol)
        np.testing.assert_allclose(Yend[i], res.y[-1], rtol=0, atol=1e-12 * max(1.0, np.max(np.abs(y))))


@pytest.mark.parametrize("threads", [1, 2])
def test_a_bad_trajectory_is_recorded_and_leaves_the_others_alone(threads):
    nem, _, Y = states_near("heavy_top", 5, seed=4)
    model = compiled.pack(nem)
    clean, _ = compiled.run_batch(model, Y, 10, 1e-3, threads=1)
    bad = Y.copy()
    bad[2, 10] = np.nan  # one trajectory's angular velocity
    bad[3, 0] = 1e3  # another's top 1 km from its pivot: no projection
    Yend, words = compiled.run_batch(model, bad, 10, 1e-3, threads=threads)
    assert words[2] == "blowup" and words[3] == "failed"
    assert np.isnan(Yend[[2, 3]]).all()
    keep = [0, 1, 4]
    assert list(words[keep]) == ["ok"] * 3
    np.testing.assert_array_equal(Yend[keep], clean[keep])


def test_failures_are_returned_not_raised():
    nem, y0, _ = states_near("torque_free", 1)
    model = compiled.pack(nem)
    bad = y0.copy()
    bad[-3:] = 1e200  # finite, but w x I w overflows in the first step
    res = compiled.integrate_fixed(model, bad, np.array([0.0, 0.1]), steps_per_save=2)
    assert res.status == "blowup" and len(res.t) == 1
    nem, y0, _ = states_near("heavy_top", 1)
    huge = y0.copy()
    huge[0] = 1e3
    res = compiled.integrate_dop853(compiled.pack(nem), huge, np.array([0.0, 0.1]))
    assert res.status == "failed" and "projection did not converge" in res.message
    coarse = ENGINE.simulate(load_scene("heavy_top"), RunSettings(1.0, 0.5, 0.5, "rk4_compiled"))
    assert not coarse.ok and coarse.message


def test_integrate_takes_one_state():
    nem, _, Y = states_near("torque_free", 2)
    with pytest.raises(ValueError, match="one state"):
        compiled.integrate_fixed(compiled.pack(nem), Y, np.array([0.0, 0.1]))


def test_simulate_command_runs_a_compiled_method(tmp_path, capsys):
    out = tmp_path / "tf.csv"
    code = main(["simulate", "torque_free", "--engine", "inhouse", "--integrator", "dop853_compiled", "--t-end", "1",
                 "--save-every", "0.5", "--out", str(out)])
    assert code == 0 and out.exists()
    assert "inhouse/dop853_compiled, status ok" in capsys.readouterr().out


def test_a_cold_compile_holds_a_lock_other_processes_wait_on(monkeypatch, tmp_path):
    """While one process compiles a kernel the cache lacks, the lock file in the cache folder is
    held (``flock``): a second process blocks on it, then loads the first one's result."""
    import fcntl

    monkeypatch.setattr(compiled, "is_cached", lambda kernel: False)
    monkeypatch.setattr(kernels.erk._cache, "_cache_path", str(tmp_path / "cache"))
    with compiled._compile_lock("erk"):
        with open(tmp_path / "cache" / "compile.lock") as other:  # another open file: another process's view
            with pytest.raises(BlockingIOError):
                fcntl.flock(other, fcntl.LOCK_EX | fcntl.LOCK_NB)
    with open(tmp_path / "cache" / "compile.lock") as other:  # released at the end
        fcntl.flock(other, fcntl.LOCK_EX | fcntl.LOCK_NB)
    monkeypatch.setattr(compiled, "is_cached", lambda kernel: True)  # a warm cache takes no lock
    with compiled._compile_lock("erk"):
        with open(tmp_path / "cache" / "compile.lock") as other:
            fcntl.flock(other, fcntl.LOCK_EX | fcntl.LOCK_NB)


def test_load_compiled_warms_the_kernels_of_compiled_runs_only(monkeypatch):
    from harness.engines.inhouse import load_compiled

    monkeypatch.setattr(compiled, "_warm", set())
    top = load_scene("heavy_top").multibody()
    load_compiled([("rk4", top), ("DOP853", top)])  # per-state methods: nothing to load
    assert compiled.warm_kernels() == frozenset()
    load_compiled([("rk4_compiled", top), ("dop853_compiled", top)])
    assert compiled.warm_kernels() == {"erk", "dop853"}


def test_run_method_is_the_compiled_twin_for_the_inhouse_engine_only():
    """The one rule validate, the stress map and the loop study run by: the in-house engine takes
    its method's compiled twin where the compiled form models the scene; other engines, a
    per-state run (``fast=False``) and a scene naming no method keep what they were given, and
    their scene's model is not even built."""
    from harness.engines.inhouse import run_method

    scene = load_scene("double_pendulum")
    assert run_method("inhouse", "rk4", scene) == "rk4_compiled"
    assert run_method("inhouse", "DOP853", scene) == "dop853_compiled"
    assert run_method("inhouse", "rk4", scene, fast=False) == "rk4"
    assert run_method("inhouse", None, scene) is None

    class Unbuilt:
        def multibody(self):
            raise AssertionError("built for another engine")

    assert run_method("mujoco", "RK4", Unbuilt()) == "RK4"
    assert run_method("exudyn", "GeneralizedAlpha", Unbuilt()) == "GeneralizedAlpha"
