"""``harness.judging.refinement``: the further levels' settings and the judging run on their grid."""

from dataclasses import replace

import numpy as np
import pytest

from harness.engines.base import RunSettings
from harness.measure.trajectory import Failure
from harness.judging.error_model import LOOSER
from harness.judging.refinement import level_of, looser, on_grid, scaled_step
from harness.measure.trajectory import Trajectory


def test_a_coarser_level_keeps_the_save_interval():
    s = scaled_step(RunSettings(1.0, 1e-3, 1e-2, "rk4"), 2.0)
    assert s.dt == pytest.approx(2e-3) and s.save_every == pytest.approx(1e-2)
    assert s.t_end == 1.0 and s.integrator == "rk4"


def test_a_finer_level_keeps_the_save_interval():
    s = scaled_step(RunSettings(1.0, 1e-3, 1e-2, "rk4"), 0.5)
    assert s.dt == pytest.approx(5e-4) and s.save_every == pytest.approx(1e-2)


def test_a_step_that_does_not_divide_the_horizon_is_no_level():
    assert scaled_step(RunSettings(0.003, 1e-3, 1e-3, "rk4"), 2.0) is None


def test_saved_at_every_step_the_coarser_level_saves_at_every_new_step():
    s = scaled_step(RunSettings(1.0, 1e-3, 1e-3, "rk4"), 2.0)
    assert s.dt == pytest.approx(2e-3) and s.save_every == pytest.approx(2e-3)


def test_the_save_interval_becomes_its_smallest_multiple_on_the_new_grid():
    # 3 ms is not a whole number of 2 ms steps; 6 ms is, and divides the 12 ms horizon
    s = scaled_step(RunSettings(0.012, 1e-3, 3e-3, "rk4"), 2.0)
    assert s.dt == pytest.approx(2e-3) and s.save_every == pytest.approx(6e-3)


def test_an_error_controlled_level_is_looser_by_looser():
    base = RunSettings(1.0, 1e-3, 1e-2, "RK45", rtol=1e-8, atol=1e-10)
    s = looser(base)
    assert s.rtol == pytest.approx(1e-8 * LOOSER) and s.atol == pytest.approx(1e-10 * LOOSER)
    assert level_of(s, adaptive=True) == s.rtol
    assert level_of(base, adaptive=False) == base.dt


def _traj(t):
    n = len(t)
    t = np.asarray(t, dtype=float)
    p = np.zeros((n, 1, 3))
    p[:, 0, 0] = t  # the samples are told apart by their x
    q = np.zeros((n, 1, 4))
    q[:, 0, 0] = 1.0
    return Trajectory("inhouse", "DOP853", ("b",), t, p, q, np.zeros((n, 1, 3)), np.zeros((n, 1, 3)),
                      engine_energy={"kinetic": t.copy()}, reactions={"b": (np.zeros((n, 3)), np.zeros((n, 3)))})


def test_on_grid_restricts_the_judge_to_a_coarser_levels_times():
    judge = _traj(np.linspace(0.0, 1.0, 101))
    times = np.linspace(0.0, 1.0, 51)
    grid = on_grid(judge, times)
    np.testing.assert_allclose(grid.t, times, atol=1e-12)
    np.testing.assert_allclose(grid.p_WCm_W[:, 0, 0], times, atol=1e-12)
    np.testing.assert_allclose(grid.engine_energy["kinetic"], times, atol=1e-12)
    assert grid.reactions["b"][0].shape == (51, 3)


def test_on_grid_on_the_same_times_is_the_judge_itself():
    judge = _traj(np.linspace(0.0, 1.0, 11))
    assert on_grid(judge, np.linspace(0.0, 1.0, 11)) is judge


def test_on_grid_without_one_of_the_times_is_none():
    judge = _traj(np.linspace(0.0, 1.0, 11))
    assert on_grid(judge, np.linspace(0.0, 1.0, 21)) is None   # a finer level's times: half are missing
    assert on_grid(judge, np.array([0.0, 1.5])) is None        # beyond the judge's horizon


def test_on_grid_passes_a_missing_or_failed_judge_through():
    assert on_grid(None, np.array([0.0, 1.0])) is None
    failed = replace(_traj([0.0]), reason=Failure.SOLVER)
    assert on_grid(failed, np.array([0.0, 1.0])) is failed
