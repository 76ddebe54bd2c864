"""MuJoCo's warnings are captured into the run record (stats["warnings"]), never printed, and
the blow-up guard MuJoCo trips is still reported."""

import mujoco
import numpy as np

from harness.engines import get_engine
from harness.engines.base import RunSettings
from harness.engines.mujoco import rollout
from harness.engines import load_scene

# a huge explicit Euler step (s) on a fast double pendulum: MuJoCo's QACC guard trips
UNSTABLE = {"theta0": 3.0, "dphi0": 40.0}


def test_a_warning_is_recorded_not_printed(capfd):
    before = mujoco.get_mju_user_warning()
    traj = get_engine("mujoco").simulate(load_scene("double_pendulum", UNSTABLE), RunSettings(2.0, 0.2, 0.2, "Euler"))
    out, err = capfd.readouterr()
    assert out == "" and err == ""
    assert traj.stats["warnings"]["count"] >= 1
    assert "QACC" in traj.stats["warnings"]["first"] and "unstable" in traj.stats["warnings"]["first"]
    assert traj.status == "blowup" and "mjWARN_BADQACC" in traj.message  # the guard is still read
    assert mujoco.get_mju_user_warning() is before  # the handler is restored


def test_a_quiet_run_records_no_warning(capfd):
    traj = get_engine("mujoco").simulate(load_scene("double_pendulum"), RunSettings(0.2, 1e-3, 0.1, "RK4"))
    assert traj.ok and traj.stats["warnings"] == {"count": 0, "first": ""}
    assert capfd.readouterr() == ("", "")


def test_rollout_warnings_are_recorded_not_printed(capfd):
    rm = rollout.prepare(load_scene("double_pendulum", UNSTABLE), 0.2, "Euler")
    states = rm.run(np.stack([rm.state0] * 4), 10, nthread=2)
    traj = rm.trajectory(rollout.saved_states(rm.state0, states[0], 1), 0.2 * np.arange(11), "Euler")
    assert capfd.readouterr() == ("", "")
    assert traj.stats["warnings"]["count"] >= 4 and "QACC" in traj.stats["warnings"]["first"]
