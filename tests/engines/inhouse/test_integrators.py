"""The in-house engine's integrators: Butcher tables, convergence order, SciPy drivers, failures."""

from __future__ import annotations

import numpy as np
import pytest

from harness.engines.base import RunSettings
from harness.engines.inhouse import ENGINE, InhouseEngine, algebra
from harness.engines.inhouse.constraints import DynamicsError
from harness.engines.inhouse.integrators import (
    ADAPTIVE,
    COMPILED,
    EULER,
    FIXED_STEP,
    RK4,
    integrate,
    integrate_adaptive,
    integrate_fixed,
    rk_step,
)
from harness.model.errors import InputError
from harness.engines import load_scene


@pytest.mark.parametrize("tableau", [RK4, EULER])
def test_butcher_tables_are_consistent(tableau):
    A, b, c = np.array(tableau.A), np.array(tableau.b), np.array(tableau.c)
    assert np.allclose(np.triu(A), 0.0)  # explicit
    assert np.isclose(b.sum(), 1.0)
    np.testing.assert_allclose(A.sum(axis=1), c)


def test_rk4_step_is_the_fourth_order_taylor_polynomial_on_a_linear_ode():
    lam = np.array([-0.7, 1.3])
    h = 0.3
    y1 = rk_step(lambda t, y: lam * y, 0.0, np.ones(2), h, RK4)
    z = lam * h
    np.testing.assert_allclose(y1, 1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24, rtol=1e-15)
    np.testing.assert_allclose(rk_step(lambda t, y: lam * y, 0.0, np.ones(2), h, EULER), 1 + z, rtol=1e-15)


def test_rk4_nodes_are_used_for_time_dependent_rhs():
    # y' = t^3 is integrated exactly by a 4th-order method: y(1) = 1/4.
    res = integrate_fixed(lambda t, y: np.array([t**3]), np.zeros(1), np.array([0.0, 1.0]), 4, RK4)
    assert res.status == "ok" and res.steps == 4 and res.rhs_evals == 16
    assert abs(res.y[-1, 0] - 0.25) < 1e-15


def final_error(integrator, dt, reference):
    scene = load_scene("torque_free")
    traj = ENGINE.simulate(scene, RunSettings(t_end=2.0, dt=dt, save_every=0.1, integrator=integrator))
    assert traj.ok, traj.message
    return max(np.max(np.abs(traj.w_WB_W - reference.w_WB_W)), np.max(np.abs(algebra.quat_matrix(traj.quat_WB) - algebra.quat_matrix(reference.quat_WB))))


@pytest.fixture(scope="module")
def torque_free_reference():
    scene = load_scene("torque_free")
    settings = RunSettings(t_end=2.0, dt=1e-3, save_every=0.1, integrator="DOP853", rtol=1e-13, atol=1e-14)
    return ENGINE.simulate(scene, settings)


@pytest.mark.parametrize("integrator, order, dts", [("rk4", 4, (0.05, 0.025, 0.0125)), ("euler", 1, (0.004, 0.002, 0.001))])
def test_convergence_order_on_torque_free(integrator, order, dts, torque_free_reference):
    errors = [final_error(integrator, dt, torque_free_reference) for dt in dts]
    observed = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(observed - order) < 0.15), (errors, observed)


def test_adaptive_driver_samples_at_the_save_times():
    t_save = np.linspace(0.0, 3.0, 31)
    res = integrate_adaptive(lambda t, y: -y, np.array([1.0, 2.0]), t_save, "DOP853", rtol=1e-12, atol=1e-14)
    assert res.status == "ok"
    np.testing.assert_array_equal(res.t, t_save)
    np.testing.assert_allclose(res.y, np.exp(-t_save)[:, None] * np.array([1.0, 2.0]), rtol=1e-11)
    assert res.steps >= 30  # steps are capped at the save interval
    assert res.rhs_evals >= 12 * res.steps


@pytest.mark.parametrize("method", sorted(ADAPTIVE))
def test_every_scipy_method_runs_the_torque_free_body(method, torque_free_reference):
    scene = load_scene("torque_free")
    settings = RunSettings(t_end=2.0, dt=1e-3, save_every=0.1, integrator=method, rtol=1e-9, atol=1e-11)
    traj = ENGINE.simulate(scene, settings)
    assert traj.ok, traj.message
    assert traj.integrator == method and traj.engine == "inhouse"
    np.testing.assert_allclose(traj.t, np.arange(21) * 0.1)
    assert np.max(np.abs(traj.w_WB_W - torque_free_reference.w_WB_W)) < 1e-6
    np.testing.assert_allclose(np.linalg.norm(traj.quat_WB, axis=-1), 1.0, atol=1e-14)


def test_trajectory_layout_and_stats():
    scene = load_scene("double_pendulum")
    settings = RunSettings(t_end=0.1, dt=1e-3, save_every=0.01, integrator="rk4")
    traj = ENGINE.simulate(scene, settings)
    assert traj.ok and traj.body_names == ("bar1", "bar2")
    np.testing.assert_allclose(traj.t, np.arange(11) * 0.01, atol=1e-15)
    assert traj.p_WCm_W.shape == (11, 2, 3) and traj.quat_WB.shape == (11, 2, 4)
    assert traj.v_WCm_W.shape == (11, 2, 3) and traj.w_WB_W.shape == (11, 2, 3)
    assert traj.stats["steps"] == 100 and traj.stats["rhs_evals"] == 400 and traj.stats["wall_s"] > 0
    # initial sample is the forward kinematics of the scene's joint coordinates
    from harness.model import kinematics

    model = scene.multibody()
    fk = kinematics.forward(model, model.q0, model.v0)
    for i, name in enumerate(traj.body_names):
        np.testing.assert_allclose(traj.p_WCm_W[0, i], fk[name].p_WCm_W, atol=1e-15)
        np.testing.assert_allclose(traj.w_WB_W[0, i], fk[name].w_WB_W, atol=1e-15)


def test_engine_declares_its_integrators():
    assert ENGINE.name == "inhouse"
    # every method has exactly one way to be computed, agreeing with its record
    assert set(ENGINE.integrators) == set(FIXED_STEP) | set(ADAPTIVE) | COMPILED
    for name, record in ENGINE.integrators.items():
        assert record.name == name and record.kind in ("fixed", "adaptive")
        if record.kind == "fixed":
            assert name in FIXED_STEP and name not in ADAPTIVE
            assert (record.order, record.stages) == (FIXED_STEP[name].order, len(FIXED_STEP[name].b))
        else:
            assert name not in FIXED_STEP and (name in ADAPTIVE) != (name in COMPILED)
    with pytest.raises(ValueError, match="compiled form"):
        integrate(lambda t, y: -y, np.ones(2), np.linspace(0.0, 1.0, 3), "rk4_compiled")
    scene = load_scene("torque_free")
    with pytest.raises(InputError):
        ENGINE.simulate(scene, RunSettings(t_end=1.0, dt=1e-3, save_every=0.01, integrator="rk45"))
    with pytest.raises(InputError):
        ENGINE.simulate(scene, RunSettings(t_end=1.0, dt=3e-3, save_every=0.01, integrator="rk4"))


@pytest.mark.parametrize("scene_name, dt", [("torque_free", 10.0), ("heavy_top", 0.5), ("double_pendulum", 1.0)])
def test_huge_step_blows_up_without_raising(scene_name, dt):
    scene = load_scene(scene_name, {"omega0": (3.0, 5.0, 4.0)} if scene_name == "torque_free" else None)
    traj = ENGINE.simulate(scene, RunSettings(t_end=200 * dt, dt=dt, save_every=dt, integrator="rk4"))
    assert traj.status in ("blowup", "failed")
    assert traj.message
    assert len(traj.t) < 201 and len(traj.t) >= 1  # the samples before the failure are kept
    assert np.all(np.isfinite(traj.p_WCm_W))


def test_rhs_failure_keeps_the_samples_before_it():
    def rhs(t, y):
        if t > 0.55:
            raise DynamicsError("singular constraint (KKT) matrix")
        return -y

    for method in ("rk4", "DOP853"):
        res = integrate(rhs, np.ones(3), np.linspace(0.0, 1.0, 11), method, steps_per_save=10)
        assert res.status == "failed" and "singular" in res.message
        assert 5 <= len(res.t) <= 6
        np.testing.assert_allclose(res.y, np.exp(-res.t)[:, None] * np.ones(3), rtol=1e-8)


def test_non_finite_rhs_is_reported_not_raised():
    res = integrate(lambda t, y: y * np.inf if t > 0.3 else y, np.ones(2), np.linspace(0.0, 1.0, 11), "RK45", rtol=1e-6, atol=1e-9)
    assert res.status in ("failed", "blowup")
    assert len(res.t) >= 3


def test_projection_can_be_switched_off():
    # Without projection, Baumgarte terms hold the constraints of a fixed-step run.
    scene = load_scene("heavy_top")
    settings = RunSettings(t_end=1.0, dt=scene.dt, save_every=scene.save_every, integrator="rk4")
    traj = InhouseEngine(project=False).simulate(scene, settings)
    assert traj.ok
    R = algebra.quat_matrix(traj.quat_WB[:, 0])
    tip = traj.p_WCm_W[:, 0] - R @ np.array([0.0, 0.0, scene.params["l"]])
    assert np.max(np.abs(tip)) < 1e-9
