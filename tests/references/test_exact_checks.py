"""Every scene's exact check lives in its reference module (``references/<scene>.py``) and is
reached through the scene-agnostic dispatcher ``harness.measure.exact``; the references judge
trajectories and make extra runs only through the ``run`` callable they are given."""

from __future__ import annotations

import math
import pickle
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from harness.engines import get_engine
from harness.engines.base import RunSettings
from harness.measure.trajectory import Failure
from harness.measure import exact, solution_cache
from harness.model.scene import available_scenes
from harness.engines import load_scene

ROOT = Path(__file__).resolve().parents[2]
SCENES = available_scenes()
EXACT_SCENES = [s for s in SCENES if "exact" in load_scene(s).checks]


def short_run(scene, n_saves: int | None = 20):
    """A MuJoCo run of ``n_saves`` save intervals (None: the scene's horizon) at the scene's step
    and integrator."""
    t_end = scene.t_end if n_saves is None else n_saves * scene.save_every
    settings = RunSettings(t_end, scene.dt, scene.save_every, scene.integrators["mujoco"])
    return get_engine("mujoco").simulate(scene, settings), settings


@pytest.mark.parametrize("name", SCENES)
def test_a_scene_with_an_exact_check_has_its_reference(name):
    scene = load_scene(name)
    module = exact.reference_module(name)
    if "exact" not in scene.checks:
        assert not exact.has_exact_error(name)
        return
    assert module is not None, f"[checks.exact] in models/{name}/scene.toml but no references/{name}.py"
    assert callable(getattr(module, "exact_error", None)), f"references/{name}.py defines no exact_error"
    assert isinstance(getattr(module, "EXACT_NEEDS_RUNS", None), bool), f"references/{name}.py: EXACT_NEEDS_RUNS"
    assert exact.needs_runs(scene) is module.EXACT_NEEDS_RUNS
    if module.EXACT_NEEDS_RUNS:  # a per-sample form judges one run; extra runs do not fit it
        assert not exact.has_error_series(name)


def test_the_references_do_not_use_the_engines():
    for path in sorted((ROOT / "references").glob("*.py")):
        text = path.read_text()
        assert not re.search(r"harness\.engines|get_engine", text), f"{path.name} uses the engines"


@pytest.mark.parametrize("name", [s for s in EXACT_SCENES if not exact.needs_runs(s)])
def test_a_check_without_runs_judges_the_run_alone(name):
    scene = load_scene(name)
    traj, settings = short_run(scene)
    value, unit, detail = exact.exact_error(scene, traj, settings)  # no run callable
    assert math.isfinite(value) and value >= 0.0 and isinstance(unit, str) and detail
    if exact.has_error_series(name):
        series = np.asarray(exact.exact_error_series(scene, traj))
        assert series.shape == traj.t.shape and np.all(np.isfinite(series))
        assert exact.series_description(name)


@pytest.mark.parametrize("name", [s for s in EXACT_SCENES if exact.needs_runs(s)])
def test_a_check_with_runs_makes_them_through_the_callable(name):
    scene = load_scene(name)
    traj, settings = short_run(scene, None)  # the check may measure the run itself too
    with pytest.raises(ValueError, match="makes runs of its own"):
        exact.exact_error(scene, traj, settings)
    made = []

    def run(case, how):
        made.append(how)
        return get_engine("mujoco").simulate(case, how)

    value, _, detail = exact.exact_error(scene, traj, settings, run)
    assert made and all(h.dt == settings.dt and h.integrator == settings.integrator for h in made)
    assert math.isfinite(value) and value >= 0.0, detail


@pytest.mark.parametrize("name", [s for s in EXACT_SCENES if exact.needs_runs(s)])
def test_a_failed_extra_run_is_an_error(name):
    scene = load_scene(name)
    traj, settings = short_run(scene, None)

    def run(case, how):
        return replace(traj, reason=Failure.NON_FINITE, message="made to fail")

    with pytest.raises(RuntimeError, match="made to fail"):
        exact.exact_error(scene, traj, settings, run)


def test_a_scene_without_a_reference_module():
    scene = replace(load_scene(SCENES[0]), name="no_such_system")
    traj, settings = short_run(load_scene(SCENES[0]), 2)
    assert exact.reference_module(scene) is None and not exact.needs_runs(scene)
    with pytest.raises(ValueError, match="no exact check for scene 'no_such_system'"):
        exact.exact_error(scene, traj, settings)
    with pytest.raises(ValueError, match="no exact check"):
        exact.exact_error_series(scene, traj)
    assert exact.exact_reaction(scene, traj) is None


def test_prepare_computes_the_closed_form_for_the_workers_a_parent_forks():
    """``exact.prepare`` leaves the closed form at the trajectory's times in the reference
    module's memo: a run saved at the same times is judged without integrating it again."""
    from harness.references import four_bar as reference

    scene = load_scene("four_bar")
    traj = get_engine("mujoco").simulate(scene, RunSettings(t_end=0.2, dt=scene.dt, save_every=0.01, integrator="RK4"))
    reference._solve.cache_clear()
    with solution_cache.recording() as computed:
        exact.prepare(scene, traj)
    assert len(computed) == 1
    with solution_cache.recording() as again:
        exact.exact_error_series(scene, traj)
    assert again == {}


def test_a_closed_form_computed_in_one_process_is_adopted_by_another():
    """What a worker computed (``solution_cache.recording``) crosses a process boundary (here
    a pickle, as through a worker's pipe) and is adopted: the same series, nothing integrated."""
    from harness.references import four_bar as reference

    scene = load_scene("four_bar")
    traj = get_engine("mujoco").simulate(scene, RunSettings(t_end=0.2, dt=scene.dt, save_every=0.01, integrator="RK4"))
    reference._solve.cache_clear()
    with solution_cache.recording() as computed:
        series = exact.exact_error_series(scene, traj)
    shipped = pickle.loads(pickle.dumps(computed))
    reference._solve.cache_clear()
    solution_cache.adopt(shipped)
    with solution_cache.recording() as again:
        adopted = exact.exact_error_series(scene, traj)
    assert again == {} and np.array_equal(adopted, series)