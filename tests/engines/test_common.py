"""Every engine: conventions of the common trajectory, failure handling, bad settings."""

import numpy as np
import pytest

from harness.measure import compare
from harness.model import rotations
from harness.engines import ENGINE_NAMES, get_engine
from harness.engines.base import RunSettings
from harness.model.errors import InputError
from harness.model.kinematics import forward
from harness.model.scene import available_scenes
from harness.engines import load_scene

DEFAULT_INTEGRATOR = {"inhouse": "rk4", "mujoco": "RK4", "pinocchio": "rkmk4", "exudyn": "GeneralizedAlpha", "drake": "RK5",
                     "pybullet": "semi_implicit_euler"}


@pytest.mark.parametrize("engine", ENGINE_NAMES)
@pytest.mark.parametrize("name", available_scenes())
def test_first_sample_is_the_scene_initial_state(engine, name):
    scene = load_scene(name)
    model = scene.multibody()
    dt = min(0.001, scene.dt)  # a stiff scene's explicit methods need its own step (flyball_governor: 1e-4 s)
    tr = get_engine(engine).simulate(scene, RunSettings(10 * dt, dt, 10 * dt, DEFAULT_INTEGRATOR[engine]))  # ten steps
    if engine in scene.not_run:  # the scene excludes the engine: it says so, with no samples
        assert tr.unsupported and tr.message and len(tr.t) == 0
        return
    assert tr.ok, tr.message
    init = forward(model, model.q0, model.v0)
    for i, body in enumerate(tr.body_names):
        assert np.allclose(tr.p_WCm_W[0, i], init[body].p_WCm_W, atol=1e-12)
        assert rotations.geodesic_angle(tr.quat_WB[0, i], init[body].quat_WB) < 1e-12
        assert np.allclose(tr.v_WCm_W[0, i], init[body].v_WCm_W, atol=1e-12)
        assert np.allclose(tr.w_WB_W[0, i], init[body].w_WB_W, atol=1e-12)


@pytest.mark.parametrize("engine", ENGINE_NAMES)
def test_short_run_agrees_across_engines(engine):
    """A 0.5 s heavy-top run agrees with MuJoCo RK4 at a tiny step to the integrator's accuracy."""
    scene = load_scene("heavy_top", {"omega0": "1,-2,30", "theta0": 0.8})
    ref = get_engine("mujoco").simulate(scene, RunSettings(0.5, 1e-4, 0.05, "RK4"))
    tr = get_engine(engine).simulate(scene, RunSettings(0.5, 5e-4, 0.05, DEFAULT_INTEGRATOR[engine]))
    if engine in scene.not_run:  # the scene excludes the engine: it says so
        assert tr.unsupported and tr.message
        return
    err = compare.trajectory_error(tr, ref)
    if engine == "pybullet":  # first order (semi-implicit Euler): its error halves with the step
        half = compare.trajectory_error(get_engine(engine).simulate(scene, RunSettings(0.5, 2.5e-4, 0.05,
                                                                                       DEFAULT_INTEGRATOR[engine])), ref)
        order = np.log2(err["orientation_max"] / half["orientation_max"])  # measured 0.047 and 0.023 rad
        assert 0.9 < order < 1.1 and err["orientation_max"] < 0.1, (err, half)
        return
    # Exudyn's default on a jointed scene is generalized-alpha, order 2 (measured: 8.2e-5 rad, 6.0e-6 m)
    orientation, position = (2e-4, 2e-5) if engine == "exudyn" else (1e-7, 1e-8)
    assert err["orientation_max"] < orientation and err["position_max"] < position


@pytest.mark.parametrize("engine", ENGINE_NAMES)
@pytest.mark.parametrize("dt", [0.0, -1e-3, float("nan"), float("inf")])
def test_bad_timestep_is_an_input_error(engine, dt):
    scene = load_scene("torque_free")
    with pytest.raises(InputError, match="timestep dt must be positive"):
        get_engine(engine).simulate(scene, RunSettings(1.0, dt, 0.01, DEFAULT_INTEGRATOR[engine]))


@pytest.mark.parametrize("engine", ENGINE_NAMES)
def test_unknown_integrator_is_an_input_error(engine):
    with pytest.raises(InputError, match="unknown integrator 'leapfrog'"):
        get_engine(engine).simulate(load_scene("torque_free"), RunSettings(1.0, 0.01, 0.01, "leapfrog"))


@pytest.mark.parametrize("engine", ENGINE_NAMES)
def test_blowup_is_recorded_not_raised(engine):
    """A double pendulum with a huge explicit step diverges: recorded as a failed run."""
    scene = load_scene("double_pendulum", {"theta0": 3.0, "dphi0": 40.0})
    integ = {"inhouse": "euler", "mujoco": "Euler", "pinocchio": "euler", "exudyn": "GeneralizedAlpha", "drake": "RK2",
             "pybullet": "semi_implicit_euler"}[engine]
    tr = get_engine(engine).simulate(scene, RunSettings(200.0, 0.5, 0.5, integ))
    if engine in scene.not_run:  # the scene excludes the engine: it says so
        assert tr.unsupported and tr.message
        return
    assert tr.status in ("blowup", "failed"), (tr.status, tr.message)
    assert tr.message


def test_unknown_engine():
    with pytest.raises(InputError, match="unknown engine 'bullet'"):
        get_engine("bullet")


def test_preload_leaves_an_engine_that_is_not_installed_to_its_runs(monkeypatch):
    """``preload`` runs each engine's optional ``preload()``; one that raises ImportError (an
    engine not installed) does not stop the others or the command: its runs report it."""
    from harness.engines import preload

    calls = []

    def missing():
        calls.append("drake")
        raise ImportError("No module named 'pydrake'")

    monkeypatch.setattr(get_engine("drake"), "preload", missing, raising=False)
    monkeypatch.setattr(get_engine("mujoco"), "preload", lambda: calls.append("mujoco"), raising=False)
    preload(["drake", "mujoco", "inhouse"])
    assert calls == ["drake", "mujoco"]
