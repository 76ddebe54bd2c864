"""Scene descriptions: every folder complete, overrides validated, non-physical input rejected."""

import numpy as np
import pytest

from harness.engines import ENGINE_NAMES, check_scene, reads_other_format
from harness.model.errors import InputError
from harness.model.scene import MODELS_DIR, available_scenes, parse_set
from harness.model.scene import load_scene as model_load_scene
from harness.engines import load_scene


@pytest.mark.parametrize("name", available_scenes())
def test_scene_folder_is_complete(name):
    folder = MODELS_DIR / name
    scene = load_scene(name)
    assert scene.mjcf.is_file() and scene.urdf.is_file()
    assert (folder / "README.md").is_file()
    assert scene.textbook and set(scene.needs) == {"gravity", "contact", "forcing"}
    for engine in ("inhouse", "mujoco", "pinocchio"):  # each runs it with an integrator, or says why it does not
        assert (engine in scene.integrators) != (engine in scene.not_run), engine
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

ENERGY = "[checks.energy_drift]\n"


@pytest.mark.parametrize("name", available_scenes())
def test_every_scene_description_is_valid(name):
    path = MODELS_DIR / name / "scene.toml"
    data = read_toml(path)
    check_description(data, path)  # raises on any mistake
    assert set(data.get("checks", {})) <= set(CHECKS)


def test_checks_list_every_check_run_reads():
    """The check tables the validation reads (harness.judging.checks, harness.measure.contact_metrics)
    are exactly CHECKS: a new check must be added there, or scene.toml would reject it."""
    import inspect

    from harness.judging import checks
    from harness.measure import contact_metrics

    source = inspect.getsource(checks) + inspect.getsource(contact_metrics)
    import re

    read = set(re.findall(r'"(\w+)" in (?:scene\.)?checks', source)) | set(re.findall(r'checks\["(\w+)"\]', source))
    assert read == set(CHECKS)


def test_every_scene_names_the_registered_engines_only():
    """Each scene's per-engine tables hold registered engines, and every engine its ``[not_run]``
    does not exclude has a default integrator (``harness.engines.check_scene``)."""
    for name in available_scenes():
        check_scene(load_scene(name))


def test_component_names_match_their_source_and_engines_are_the_registrys():
    """The model layer keeps no copy of the engines: which a scene may name is the registry's
    (``harness.engines.check_scene``)."""
    from harness.measure.compare import MOMENTUM_COMPONENTS
    from harness.model import scene

    assert not hasattr(scene, "ENGINE_NAMES")
    assert scene.MOMENTUM_COMPONENTS == MOMENTUM_COMPONENTS


@pytest.fixture
def scene_copy(tmp_path):
    """A copy of heavy_top's folder with no ``[not_run]`` and an ``[integrators]`` table naming
    every engine (as a user's scene may: the registry's defaults otherwise), the shape the edits
    below assume; returns (models dir, path of its scene.toml)."""
    import re

    from harness.engines import DECLARATIONS

    models = tmp_path / "models"
    shutil.copytree(MODELS_DIR / "heavy_top", models / "heavy_top")
    path = models / "heavy_top" / "scene.toml"
    text = re.sub(r"^\[not_run\]\n(?:[a-z]+ = .*\n)+\n", "", path.read_text(), flags=re.M)
    table = "".join(f'{d.name} = "{d.default_integrator}"\n' for d in DECLARATIONS)
    path.write_text(text.replace("\n[checks.", f"\n[integrators]\n{table}\n[checks.", 1))
    return models, path


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
    "unknown key in a check table": (ENERGY, ENERGY + "colour = 'red'\n", "unknown key 'colour' at [checks.energy_drift]"),
    "wrong type of t_end": ("t_end = 5.0", 't_end = "abc"', "[simulation] t_end must be a number (the horizon in s), got 'abc'"),
    "a per-engine tolerance": (ENERGY, ENERGY + "mujoco = 1e-8\n", "[checks.energy_drift] mujoco: a check holds no tolerance"),
    "a trajectory tolerance": ("[checks.trajectory]", "[checks.trajectory]\nposition = 1e-6",
                               "[checks.trajectory] position: a check holds no tolerance"),
    "a per-engine table": ("[checks.trajectory]", "[checks.trajectory]\nspeed = { inhouse = 1e-6 }",
                           "[checks.trajectory] speed: a check holds no tolerance"),
    "negative requirement": ("[checks.energy_drift]", "[requirements]\nexact = -1e-6\n\n[checks.energy_drift]",
                             "[requirements] exact must be positive and finite"),
    "requirement as a string": ("[checks.energy_drift]", '[requirements]\nexact = "1e-6"\n\n[checks.energy_drift]',
                                "[requirements] exact must be a number"),
    "requirement of no check": ("[checks.energy_drift]", "[requirements]\nslip = 1e-6\n\n[checks.energy_drift]",
                                "[requirements] slip: names no check the scene makes"),
    "model difference of no engine": ("[checks.energy_drift]", '[model_differences.bullet]\nmodel = "x"\nbound = 1e-3\n\n[checks.energy_drift]',
                                      "[model_differences.bullet]: unknown engine"),
    "model difference without a bound": ("[checks.energy_drift]", '[model_differences.mujoco]\nmodel = "soft"\n\n[checks.energy_drift]',
                                         "[model_differences.mujoco] bound must be a number"),
    "model difference without a model": ("[checks.energy_drift]", '[model_differences.mujoco]\nbound = 1e-3\n\n[checks.energy_drift]',
                                         "[model_differences.mujoco] model must say what differs"),
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
    "name not the folder's": ('name = "heavy_top"', 'name = "heavy_top2"', "differs from the scene's folder 'heavy_top'"),
    "unknown root joint": ('urdf_root_joint = "spherical"', 'urdf_root_joint = "ball"', "urdf_root_joint = 'ball' is not one of"),
    "no model file": ('mjcf = "heavy_top.xml"\nurdf = "heavy_top.urdf"\nurdf_root_joint = "spherical"', "",
                      "names no model file: give mjcf ="),
    "root joint without a URDF": ('urdf = "heavy_top.urdf"\n', "", "urdf_root_joint is for a URDF"),
    "urdf not a URDF": ('urdf = "heavy_top.urdf"', 'urdf = "heavy_top.xml"', "urdf = 'heavy_top.xml' is not a *.urdf file"),
    "too many samples": ("t_end = 5.0", "t_end = 1e9", f"saves more than {MAX_SAMPLES:.0e} samples"),
    "check not a table": (ENERGY, "[checks]\nenergy_drift = 1e-8\n", "[checks.energy_drift] must be a table"),
    "momentum without components": ('components = ["Lz", "L3"]\n', "", "[checks.momentum_drift] components must be a non-empty list"),
}


@pytest.mark.parametrize("kind", list(MISTAKES))
def test_scene_mistakes_are_input_errors_naming_file_and_table(scene_copy, kind):
    models, path = scene_copy
    old, new, fragment = MISTAKES[kind]
    _edit(path, old, new)
    with pytest.raises(InputError) as err:  # the engines' names against the registry (check_scene)
        check_scene(load_scene("heavy_top", models_dir=models))
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


def test_an_engine_the_scene_excludes_needs_no_integrator(scene_copy):
    """``[not_run] drake = "why"`` frees the integrators from naming drake; the scene keeps why.
    An engine the scene neither excludes nor names runs its declared default
    (``Declaration.integrator_for``)."""
    import re

    from harness.engines import declaration

    models, path = scene_copy
    text = re.sub(r"^drake = .*\n", "", path.read_text(), flags=re.M)  # drake's integrator
    path.write_text(text.replace("[integrators]", '[not_run]\ndrake = "a test: Drake left out"\n\n[integrators]', 1))
    scene = model_load_scene("heavy_top", models_dir=models)
    assert scene.not_run == {"drake": "a test: Drake left out"} and "drake" not in scene.integrators
    assert check_scene(scene) is scene and "drake" not in scene.integrators
    path.write_text(text)  # without [not_run], drake runs its declared default
    scene = check_scene(model_load_scene("heavy_top", models_dir=models))
    assert scene.integrators["drake"] == declaration("drake").default_integrator and not scene.not_run


# ---------------------------------------------------------------- a scene without code


@pytest.fixture
def chain_copy(tmp_path):
    """models/three_link_chain copied as ``my_chain`` (no builder, no reference module): returns
    (models dir, its folder)."""
    models = tmp_path / "models"
    shutil.copytree(MODELS_DIR / "three_link_chain", models / "my_chain")
    _edit(models / "my_chain" / "scene.toml", 'name = "three_link_chain"', 'name = "my_chain"')
    return models, models / "my_chain"


def test_a_copied_scene_without_code_reads_its_model_file(chain_copy):
    models, folder = chain_copy
    scene = load_scene("my_chain", models_dir=models)
    original = load_scene("three_link_chain").multibody()
    model = scene.multibody()
    assert scene.from_model_file and not scene.builder and scene.parameters["m1"].sets == "body.link1.mass"
    assert model.body_names == original.body_names == ["link1", "link2", "link3"]
    assert [b.mass for b in model.bodies] == [1.0, 0.8, 0.5] and model.q0["link3"][0] == -0.4
    over = scene.with_params(m3=0.7, q2=0.1, g=3.0).multibody()
    assert over.body("link3").mass == 0.7 and over.q0["link2"][0] == 0.1 and over.gravity_W[2] == -3.0
    (folder / "three_link_chain.xml").unlink()  # a named MJCF missing: refused, the URDF is not read in its place
    with pytest.raises(InputError, match=r"its MJCF three_link_chain.xml is not in"):
        load_scene("my_chain", models_dir=models).multibody()
    _edit(folder / "scene.toml", 'mjcf = "three_link_chain.xml"\n', "")  # only a URDF: through MuJoCo's importer
    from_urdf = load_scene("my_chain", models_dir=models).multibody()
    for a, b in zip(from_urdf.bodies, model.bodies):
        assert a.name == b.name and a.mass == b.mass and np.allclose(a.I_Cm_B, b.I_Cm_B, rtol=0, atol=1e-15)


def test_a_keyframe_is_the_initial_state_when_the_scene_names_it(chain_copy):
    models, folder = chain_copy
    _edit(folder / "three_link_chain.xml", "  </worldbody>",
          '  </worldbody>\n  <keyframe><key name="bent" qpos="0.1 0.2 0.3" qvel="1 2 3"/></keyframe>')
    _edit(folder / "scene.toml", 'urdf_root_joint = "none"', 'urdf_root_joint = "none"\ninitial_state = "bent"')
    model = load_scene("my_chain", models_dir=models).multibody()
    # the keyframe first, then the parameters that set a joint (q1, q2, q3 and dq1)
    assert [model.q0[b][0] for b in ("link1", "link2", "link3")] == [0.5, 0.3, -0.4]
    assert [model.v0[b][0] for b in ("link1", "link2", "link3")] == [0.0, 2.0, 3.0]


# (file, old text, new text, fragment of the one-line error, raised by: "load" or "build")
CHAIN_MISTAKES = {
    "a parameter without sets": ("scene.toml", ', sets = "body.link2.mass"', "", "[parameters] m2 lacks sets", "load"),
    "an unknown target": ("scene.toml", '"body.link2.mass"', '"body.link2.weight"', "[parameters] m2 sets = 'body.link2.weight' "
                          "is not one of gravity, body.<body>.mass", "load"),
    "a check that needs a builder": ("scene.toml", "[checks.reaction]", "[checks.closure]\n\n"
                                     "[checks.reaction]", "[checks.closure] needs a builder", "load"),
    "contact": ("scene.toml", "contact = false", "contact = true", "[needs] contact = true", "load"),
    "an unknown body": ("scene.toml", '"body.link2.mass"', '"body.link7.mass"', "has no body 'link7' (bodies: link1, link2, link3)",
                        "build"),
    "an unknown keyframe": ("scene.toml", 'urdf_root_joint = "none"', 'urdf_root_joint = "none"\ninitial_state = "start"',
                            "no keyframe named 'start'", "build"),
    "a wrong root joint": ("scene.toml", 'urdf_root_joint = "none"', 'urdf_root_joint = "spherical"',
                           "root body 'link1' has a hinge joint, so its scene needs urdf_root_joint = 'none'", "build"),
    "a rotated body frame": ("three_link_chain.xml", '<body name="link2" pos="0 0 -0.5">',
                             '<body name="link2" pos="0 0 -0.5" euler="0 0 0.3">', "body 'link2': its frame is rotated", "build"),
    "a joint off its body's origin": ("three_link_chain.xml", 'axis="1 0 0" pos="0 0 0"', 'axis="1 0 0" pos="0 0 0.1"',
                                      "body 'link2': its joint sits at [0.0, 0.0, 0.1] m from its origin", "build"),
    "two joints in one body": ("three_link_chain.xml", '<joint name="hinge2"', '<joint name="twist" axis="0 0 1"/><joint name="hinge2"',
                               "body 'link2' has 2 joints (twist, hinge2)", "build"),
    "joint damping": ("three_link_chain.xml", 'axis="1 0 0" pos="0 0 0"', 'axis="1 0 0" pos="0 0 0" damping="0.1"',
                      "joint 'hinge2' has damping", "build"),
    "a joint range": ("three_link_chain.xml", 'axis="1 0 0" pos="0 0 0"', 'axis="1 0 0" pos="0 0 0" range="-1 1"',
                      "joint 'hinge2' has a range [-1.0, 1.0]", "build"),
    "a possible contact": ("three_link_chain.xml", '<flag contact="disable" energy="enable"/>', '<flag energy="enable"/>',
                           "geoms 'link1_geom' and 'link3_geom' can touch", "build"),
    "a closed loop": ("three_link_chain.xml", "  </worldbody>",
                      '  </worldbody>\n  <equality><connect name="cut" body1="link3" body2="world" anchor="0 0 -0.3"/></equality>',
                      "equality constraint(s) cut (a closed loop or a weld)", "build"),
}


@pytest.mark.parametrize("kind", list(CHAIN_MISTAKES))
def test_scene_without_code_mistakes_are_one_line(chain_copy, kind):
    models, folder = chain_copy
    file, old, new, fragment, when = CHAIN_MISTAKES[kind]
    _edit(folder / file, old, new)
    if kind == "a possible contact":  # every geom collides: adjacent links are filtered (MuJoCo's filterparent)
        path = folder / file
        path.write_text(path.read_text().replace(' contype="0" conaffinity="0"', ""))
    with pytest.raises(InputError) as err:
        scene = load_scene("my_chain", models_dir=models)
        assert when == "build", f"{kind}: loaded"
        scene.multibody()
    message = str(err.value)
    assert fragment in message and "\n" not in message, message
    assert message.startswith(f"{folder}/")  # names the scene.toml or the model file


def test_no_model_file_is_one_line(chain_copy):
    models, folder = chain_copy
    for suffix in ("xml", "urdf"):
        (folder / f"three_link_chain.{suffix}").unlink()
    with pytest.raises(InputError, match=r"scene.toml: no model file: neither three_link_chain.xml nor "
                                         r"three_link_chain.urdf is in .*my_chain \(a scene without a builder"):
        load_scene("my_chain", models_dir=models).multibody()


def test_a_scene_with_a_builder_maps_no_parameter(scene_copy, tmp_path):
    models, path = scene_copy
    _edit(path, 'doc = "mass of the top"', 'doc = "mass of the top", sets = "body.top.mass"')
    with pytest.raises(InputError, match=r"\[parameters\] mass sets is for a scene without a builder, and "
                                         r"harness.model.builders.heavy_top builds this one"):
        load_scene("heavy_top", models_dir=models)
    # a copy of a coded scene under a new name, without builder = "...": told what it lacks
    shutil.copytree(MODELS_DIR / "heavy_top", models / "top2")
    _edit(models / "top2" / "scene.toml", 'name = "heavy_top"', 'name = "top2"')
    with pytest.raises(InputError, match=r'\[parameters\] mass lacks sets: a scene without a builder \(no '
                                         r'harness.model.builders.top2, no builder = "<scene>"\)'):
        load_scene("top2", models_dir=models)


@pytest.mark.parametrize("keep", ["mjcf", "urdf"])
def test_a_scene_may_name_one_model_file(scene_copy, keep):
    """A scene naming only a URDF (or only an MJCF) gives every engine that file: ``mjcf`` and
    ``urdf`` are then the same path, and the registry's ``reads_other_format`` says who reads the
    other format."""
    models, path = scene_copy
    if keep == "urdf":
        _edit(path, 'mjcf = "heavy_top.xml"\n', "")
    else:
        _edit(path, 'urdf = "heavy_top.urdf"\nurdf_root_joint = "spherical"', "")
    scene = load_scene("heavy_top", models_dir=models)
    only = models / "heavy_top" / ("heavy_top.xml" if keep == "mjcf" else "heavy_top.urdf")
    assert scene.model_files == (keep,) and scene.mjcf == scene.urdf == only
    assert reads_other_format(scene, "mujoco") == (keep == "urdf")
    assert reads_other_format(scene, "pinocchio") == reads_other_format(scene, "drake") == (keep == "mjcf")
    assert not reads_other_format(scene, "inhouse") and not reads_other_format(scene, "exudyn")
    assert scene.urdf_root_joint == ("spherical" if keep == "urdf" else "none")
    scene.mark_not_run("drake", "a test")
    assert scene.not_run == {"drake": "a test"} and load_scene("heavy_top", models_dir=models).not_run == {}


def test_both_model_files_by_default():
    scene = load_scene("heavy_top")
    assert scene.model_files == ("mjcf", "urdf") and scene.mjcf.suffix == ".xml" and scene.urdf.suffix == ".urdf"
    assert not any(reads_other_format(scene, e) for e in ENGINE_NAMES)


def test_a_default_that_follows_the_others_follows_them_unless_set():
    """rolling_disk's dpsi0 (its builder's FOLLOWS): the file's value is the steady spin at the
    defaults; a scene that changes theta0 (or the disk) and not dpsi0 starts in steady circular
    motion again; a dpsi0 the user sets is kept, and a dphi0 of 0 (no steady motion) keeps the
    file's value."""
    from harness.model.builders.rolling_disk import steady_dpsi0

    scene = load_scene("rolling_disk")
    assert scene.params["dpsi0"] == pytest.approx(steady_dpsi0(scene.params), rel=1e-14)
    tilted = load_scene("rolling_disk", {"theta0": 1.0})
    assert tilted.params["dpsi0"] == steady_dpsi0(tilted.params) != scene.params["dpsi0"]
    assert scene.with_params(R=0.02).params["dpsi0"] == steady_dpsi0(scene.with_params(R=0.02).params)
    assert load_scene("rolling_disk", {"theta0": 1.0, "dpsi0": -20.0}).params["dpsi0"] == -20.0
    assert load_scene("rolling_disk", {"dphi0": 0.0}).params["dpsi0"] == scene.params["dpsi0"]


def test_a_changed_steady_motion_is_judged_against_its_closed_form():
    from harness.engines import get_engine
    from harness.measure.exact import exact_error
    from harness.validate.run import default_settings

    from harness.judging.error_model import JUDGING_RESOLUTION
    from harness.judging.refinement import scaled_step

    scene = load_scene("rolling_disk", {"theta0": 1.0, "dphi0": 4.0})
    errors = []
    for settings in (default_settings(scene, "inhouse"), scaled_step(default_settings(scene, "inhouse"), 2.0)):
        value, _, detail = exact_error(scene, get_engine("inhouse").simulate(scene, settings), settings)
        assert "no closed form" not in detail
        errors.append(value)
    # the run converges to the closed form: at its resolution, or falling at about RK4's order
    assert errors[0] <= 10 * JUDGING_RESOLUTION or errors[1] / errors[0] > 2 ** 3.5, errors


def test_a_scene_over_the_step_budget_is_refused(scene_copy):
    """``[simulation] t_end / dt`` beyond MAX_STEPS: one line naming the file, the step count
    and the limit; at the limit it loads."""
    from harness.model.scene import MAX_STEPS

    models, path = scene_copy
    _edit(path, "dt = 0.0005", "dt = 1e-9")
    _edit(path, "save_every = 0.005", "save_every = 0.5")
    with pytest.raises(InputError) as err:
        load_scene("heavy_top", models_dir=models)
    message = str(err.value)
    assert message.startswith(f"{path}: [simulation] t_end and dt: a horizon of 5 s at a step of 1e-09 s is 5e+09 "
                              f"integration steps, more than the {MAX_STEPS:.0e}"), message
    _edit(path, "dt = 1e-9", f"dt = {5.0 / MAX_STEPS!r}")
    assert load_scene("heavy_top", models_dir=models).t_end / load_scene("heavy_top", models_dir=models).dt <= MAX_STEPS


def test_numbers_in_parameter_messages_are_plain():
    """A sweep's values are NumPy scalars: a refused one prints as a number, never
    ``np.float64(...)``; text stays as typed."""
    scene = load_scene("heavy_top")
    for value, shown in ((np.float64(1e300), "'mass' = 1e+300 is beyond"), (np.float64(np.nan), "got nan"),
                         (np.float64(-0.0005), "'mass' must be > 0, got -0.0005"), ("1e300", "'mass' = '1e300' is")):
        with pytest.raises(InputError) as err:
            scene.with_params(mass=value)
        assert shown in str(err.value) and "np.float64" not in str(err.value), str(err.value)


def test_no_scene_holds_a_per_engine_number():
    """Every check is judged by how its error converges: a scene states only requirements (the
    same for every engine) and declared model differences, at most 5 numbers in all, and no
    check table holds a number (``check_description`` refuses one; this guards the files and
    the count)."""
    from harness.model.scene import available_scenes

    for name in available_scenes():
        data = read_toml(MODELS_DIR / name / "scene.toml")
        for check, table in data.get("checks", {}).items():
            assert set(table) <= set(CHECKS[check]), (name, check, table)
        numbers = len(data.get("requirements", {})) + len(data.get("model_differences", {}))
        assert numbers <= 5, (name, numbers)
        for engine, declared in data.get("model_differences", {}).items():
            assert set(declared) == {"model", "bound"} and declared["model"].strip(), (name, engine)
