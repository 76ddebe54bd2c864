"""Scene descriptions: every folder complete, overrides validated, non-physical input rejected."""

import numpy as np
import pytest

from harness.model.errors import InputError
from harness.model.scene import MODELS_DIR, available_scenes, load_scene, parse_set


@pytest.mark.parametrize("name", available_scenes())
def test_scene_folder_is_complete(name):
    folder = MODELS_DIR / name
    scene = load_scene(name)
    assert scene.mjcf.is_file() and scene.urdf.is_file()
    assert (folder / "README.md").is_file()
    assert scene.textbook and set(scene.needs) == {"gravity", "contact", "forcing"}
    for engine in ("inhouse", "mujoco", "pinocchio"):
        assert engine in scene.integrators
    model = scene.multibody()
    assert scene.needs["gravity"] == bool(np.any(model.gravity_W))


def test_override_reaches_the_multibody():
    scene = load_scene("torque_free", {"omega0": "0.02,2,0.05", "I2": 2.5})
    model = scene.multibody()
    assert np.allclose(model.v0["body"][3:], [0.02, 2.0, 0.05])
    assert model.body("body").I_Cm_B[1, 1] == 2.5


def test_parse_set():
    assert parse_set("omega0=1,2,3") == ("omega0", "1,2,3")
    for bad in ("omega0", "=3", "mass="):
        with pytest.raises(InputError, match="malformed --set"):
            parse_set(bad)


@pytest.mark.parametrize("overrides,message", [
    ({"mass": 0.0}, "'mass' must be > 0"),
    ({"mass": -1}, "'mass' must be > 0"),
    ({"I1": "nan"}, "'I1' must be finite"),
    ({"omega0": "1,inf,2"}, "'omega0' must be finite"),
    ({"omega0": "1,2"}, "needs 3 components"),
    ({"I1": "abc"}, "not a number"),
    ({"colour": 1}, "unknown parameter 'colour'"),
    ({"I1": 1.0, "I2": 1.0, "I3": 3.0}, "triangle inequality"),
])
def test_bad_parameters_are_rejected(overrides, message):
    with pytest.raises(InputError, match=message):
        load_scene("torque_free", overrides).multibody()


def test_unknown_scene():
    with pytest.raises(InputError, match="unknown scene 'pendulum9'"):
        load_scene("pendulum9")
