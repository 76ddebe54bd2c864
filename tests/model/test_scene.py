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
    ({"I1": 1e300}, r"'I1' = 1e\+300 is beyond \+-1e\+100"),
    ({"omega0": "1,-1e101,2"}, "'omega0' = '1,-1e101,2' is beyond"),
    ({"colour": 1}, "unknown parameter 'colour'"),
    ({"I1": 1.0, "I2": 1.0, "I3": 3.0}, "triangle inequality"),
])
def test_bad_parameters_are_rejected(overrides, message):
    with pytest.raises(InputError, match=message):
        load_scene("torque_free", overrides).multibody()


def test_unknown_scene():
    with pytest.raises(InputError, match="unknown scene 'pendulum9'"):
        load_scene("pendulum9")


# ---------------------------------------------------------------- scene.toml validation

import math  # noqa: E402
import shutil  # noqa: E402

from harness.model.scene import CHECKS, MAX_SAMPLES, check_description, read_toml  # noqa: E402

ENERGY = "[checks.energy_drift]\ninhouse = 1e-8\nmujoco = 1e-8\npinocchio = 1e-8\n"
# heavy_top's trajectory position line (a tolerance per engine), as written
TRAJ_POSITION = next(line for line in (MODELS_DIR / "heavy_top" / "scene.toml").read_text().splitlines(True)
                     if line.startswith("position = "))


@pytest.mark.parametrize("name", available_scenes())
def test_every_scene_description_is_valid(name):
    path = MODELS_DIR / name / "scene.toml"
    data = read_toml(path)
    check_description(data, path)  # raises on any mistake
    assert set(data.get("checks", {})) <= set(CHECKS)


def test_checks_list_every_check_run_reads():
    """The check tables the validation reads (harness.validate.run, harness.measure.contact_metrics)
    are exactly CHECKS: a new check must be added there, or scene.toml would reject it."""
    import inspect

    from harness.measure import contact_metrics
    from harness.validate import run

    source = inspect.getsource(run) + inspect.getsource(contact_metrics)
    import re

    read = set(re.findall(r'"(\w+)" in (?:scene\.)?checks', source)) | set(re.findall(r'checks\["(\w+)"\]', source))
    assert read == set(CHECKS)


def test_engine_and_component_names_match_their_sources():
    from harness.engines import ENGINE_NAMES
    from harness.measure.compare import MOMENTUM_COMPONENTS
    from harness.model import scene

    assert scene.ENGINE_NAMES == ENGINE_NAMES
    assert scene.MOMENTUM_COMPONENTS == MOMENTUM_COMPONENTS


@pytest.fixture
def scene_copy(tmp_path):
    """A copy of heavy_top's folder; returns (models dir, path of its scene.toml)."""
    models = tmp_path / "models"
    shutil.copytree(MODELS_DIR / "heavy_top", models / "heavy_top")
    return models, models / "heavy_top" / "scene.toml"


def _edit(path, old, new):
    text = path.read_text()
    assert old in text, old
    path.write_text(text.replace(old, new, 1))


# (old text, new text, fragment of the one-line error)
MISTAKES = {
    "typo'd check table": ("[checks.energy_drift]", "[checks.enrgy_drift]",
                           "unknown check table [checks.enrgy_drift] (did you mean energy_drift?"),
    "unknown top-level key": ('title = ', 'colour = "red"\ntitle = ', "unknown key 'colour' at top level"),
    "typo'd top-level table": ("[simulation]", "[simulatoin]", "unknown key 'simulatoin' at top level (did you mean simulation?"),
    "unknown key in a check table": (ENERGY, ENERGY.replace("inhouse", "inhous"),
                                     "unknown key 'inhous' at [checks.energy_drift] (did you mean inhouse?"),
    "wrong type of t_end": ("t_end = 5.0", 't_end = "abc"', "[simulation] t_end must be a number (the horizon in s), got 'abc'"),
    "missing engine": (ENERGY, ENERGY.replace("pinocchio = 1e-8\n", ""), "[checks.energy_drift] lacks pinocchio"),
    "negative tolerance": (ENERGY, ENERGY.replace("mujoco = 1e-8", "mujoco = -1e-8"),
                           "[checks.energy_drift] mujoco must be positive and finite"),
    "zero tolerance": (ENERGY, ENERGY.replace("mujoco = 1e-8", "mujoco = 0"), "[checks.energy_drift] mujoco must be positive"),
    "infinite tolerance": (ENERGY, ENERGY.replace("mujoco = 1e-8", "mujoco = inf"),
                           "[checks.energy_drift] mujoco must be positive and finite"),
    "tolerance as a string": (ENERGY, ENERGY.replace("mujoco = 1e-8", 'mujoco = "1e-8"'),
                              "[checks.energy_drift] mujoco must be a number"),
    "trajectory tolerance missing": (TRAJ_POSITION, "", "[checks.trajectory] lacks position"),
    "trajectory table missing an engine": (TRAJ_POSITION, "position = { inhouse = 1e-6, mujoco = 1e-6 }\n",
                                           "[checks.trajectory] position lacks a tolerance for pinocchio"),
    "not_run reason not a string": ("[integrators]", "[not_run]\ndrake = 5\n\n[integrators]",
                                    "[not_run] drake must say why the engine does not run this scene"),
    "not_run unknown engine": ("[integrators]", '[not_run]\nbullet = "no"\n\n[integrators]', "unknown key 'bullet' at [not_run]"),
    "unknown momentum component": ('components = ["Lz", "L3"]', 'components = ["Lz", "L4"]',
                                   "[checks.momentum_drift] components must be a non-empty list"),
    "unknown parameter kind": ('kind = "positive", doc = "mass of the top"', 'kind = "positve", doc = "mass of the top"',
                               "[parameters] mass kind = 'positve' is not one of"),
    "unknown parameter key": ('doc = "mass of the top"', 'doc = "mass of the top", units = "kg"',
                              "unknown key 'units' at [parameters] mass"),
    "parameter value not a number": ("value = 1.0,", 'value = "heavy",', "[parameters] mass value must be a number"),
    "needs not a boolean": ("contact = false", 'contact = "no"', "[needs] contact must be true or false"),
    "missing integrator": ('pinocchio = "rkmk4"\n', "", "[integrators] lacks a default for pinocchio"),
    "name not the folder's": ('name = "heavy_top"', 'name = "heavy_top2"', "differs from the scene's folder 'heavy_top'"),
    "unknown root joint": ('urdf_root_joint = "spherical"', 'urdf_root_joint = "ball"', "urdf_root_joint = 'ball' is not one of"),
    "too many samples": ("t_end = 5.0", "t_end = 1e9", f"saves more than {MAX_SAMPLES:.0e} samples"),
    "check not a table": (ENERGY, "[checks]\nenergy_drift = 1e-8\n", "[checks.energy_drift] must be a table"),
}


@pytest.mark.parametrize("kind", list(MISTAKES))
def test_scene_mistakes_are_input_errors_naming_file_and_table(scene_copy, kind):
    models, path = scene_copy
    old, new, fragment = MISTAKES[kind]
    _edit(path, old, new)
    with pytest.raises(InputError) as err:
        load_scene("heavy_top", models_dir=models)
    message = str(err.value)
    assert message.startswith(f"{path}: ") and fragment in message and "\n" not in message, message


def test_scene_toml_not_utf8(scene_copy):
    models, path = scene_copy
    path.write_bytes(path.read_bytes().replace(b"Lagrange top", b"Lagrange \xff top"))
    with pytest.raises(InputError, match=r"scene.toml: not UTF-8 text \(byte 0xff at offset \d+\)"):
        load_scene("heavy_top", models_dir=models)


def test_copied_scene_names_its_builder(tmp_path):
    models = tmp_path / "models"
    shutil.copytree(MODELS_DIR / "heavy_top", models / "top_copy")
    path = models / "top_copy" / "scene.toml"
    _edit(path, 'name = "heavy_top"', 'name = "top_copy"\nbuilder = "heavy_top"')
    scene = load_scene("top_copy", models_dir=models)
    assert scene.builder == "heavy_top" and scene.name == "top_copy"
    assert len(scene.multibody().bodies) == len(load_scene("heavy_top").multibody().bodies)


def test_boolean_parameter_value_is_not_a_number():
    with pytest.raises(InputError, match="'mass': not a number"):
        load_scene("heavy_top", {"mass": True})
    assert math.isfinite(load_scene("heavy_top").params["mass"])


def test_an_engine_the_scene_excludes_needs_no_integrator_or_tolerances(scene_copy):
    """``[not_run] drake = "why"`` frees every table from naming drake; the scene keeps why."""
    import re

    models, path = scene_copy
    text = re.sub(r"^drake = .*\n", "", path.read_text(), flags=re.M)  # drake's integrator and scalar tolerances
    text = re.sub(r", drake = [0-9.e+-]+ \}", " }", text)  # and its per-engine trajectory tolerances
    path.write_text(text.replace("[integrators]", '[not_run]\ndrake = "a test: Drake left out"\n\n[integrators]', 1))
    scene = load_scene("heavy_top", models_dir=models)
    assert scene.not_run == {"drake": "a test: Drake left out"} and "drake" not in scene.integrators
    path.write_text(text)  # without [not_run], the same file lacks drake's entries
    with pytest.raises(InputError, match="lacks a default for drake"):
        load_scene("heavy_top", models_dir=models)
