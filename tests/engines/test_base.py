"""The engine contract's checks (``harness.engines.base``)."""

from __future__ import annotations

import numpy as np
import pytest

from harness.engines import ENGINE_NAMES, get_engine
from harness.engines.base import RunSettings, check_settings
from harness.model.errors import InputError
from harness.model.scene import MAX_STEPS
from harness.engines import load_scene


@pytest.mark.parametrize("engine", ENGINE_NAMES)
def test_every_engine_refuses_more_steps_than_the_budget_before_running(engine):
    """Every engine's ``simulate`` holds t_end / dt to MAX_STEPS (a study or tool that builds its
    own settings included): InputError naming the count and the limit, before any run."""
    scene = load_scene("torque_free")
    settings = RunSettings(10.0, 1e-12, 0.01, scene.integrators[engine])
    with pytest.raises(InputError, match=r"is 1e\+13 integration steps, more than the 1e\+08 a run may take"):
        get_engine(engine).simulate(scene, settings)
    check_settings(RunSettings(1.0, 1.0 / MAX_STEPS, 0.5, "rk4"), ["rk4"], "inhouse")  # at the limit: allowed


def test_setting_messages_print_plain_numbers():
    with pytest.raises(InputError) as err:
        check_settings(RunSettings(1.0, np.float64(0.0005), np.float64(0.0007), "rk4"), ["rk4"], "inhouse")
    assert str(err.value) == "save interval 0.0007 s is not a whole multiple of dt 0.0005 s"
