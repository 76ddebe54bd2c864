"""The symmetric free body judged by its closed form (``harness.references.torque_free_symmetric``):
w_perp turning at gamma w3 and the cones."""

import numpy as np
import pytest

from harness.engines import get_engine
from harness.engines.base import RunSettings
from harness.engines import load_scene
from harness.references import torque_free_symmetric as tfs


@pytest.mark.parametrize("overrides", [{}, {"I3": 0.6}, {"omega0": "0.5,0.2,-2"}])
def test_mujoco_run_meets_the_closed_form(overrides):
    scene = load_scene("torque_free_symmetric", overrides)
    settings = RunSettings(2.0, 1e-3, 0.01, "RK4")
    traj = get_engine("mujoco").simulate(scene, settings)
    value, _, detail = tfs.exact_error(scene, traj, settings, None)
    assert value < 1e-10, detail
    series = tfs.exact_error_series(scene, traj)
    assert series.shape == traj.t.shape and float(np.max(series)) == value


def test_a_wrong_axial_moment_is_caught():
    """Judging a run of one body by the closed form of another (I3 off by 5%) fails."""
    run_scene = load_scene("torque_free_symmetric")
    settings = RunSettings(2.0, 1e-3, 0.01, "RK4")
    traj = get_engine("mujoco").simulate(run_scene, settings)
    value, _, _ = tfs.exact_error(run_scene.with_params(I3=1.9), traj, settings, None)
    assert value > 1e-2
