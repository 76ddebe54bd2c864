"""Generated model files (``harness.model.model_files``, ``generated = true`` in a scene.toml):
the MJCF and URDF written from a built system hold it for every joint kind the files state; a
generated scene points at files written for its parameters (N copies of a window: four_bar_chain),
content-addressed, rewritten where a worker lacks them; scene.toml's rules for it."""

from __future__ import annotations

import pickle
import shutil

import pytest

from harness.engines import load_scene
from harness.engines.as_written import as_written
from harness.engines.loaded_models import compare_bodies, mujoco_bodies, mujoco_loop_discrepancies, pinocchio_bodies
from harness.engines.mujoco.model import read_spec
from harness.engines.pinocchio.model import read_urdf
from harness.model.builders import four_bar_chain as builder
from harness.model.errors import InputError
from harness.model.model_files import generated_files, mjcf_text
from harness.model.scene import MODELS_DIR
from harness.model.scene import load_scene as load_description


@pytest.mark.parametrize("name", ["double_pendulum", "cart_pendulum", "heavy_top", "torque_free", "bricard", "four_bar"])
def test_the_written_files_hold_the_system_for_every_joint_kind(name, tmp_path):
    """Hinges and loops (double_pendulum, bricard, four_bar), a slide (cart_pendulum), a ball
    (heavy_top) and a free root (torque_free): MuJoCo compiles the MJCF and Pinocchio reads the
    URDF (with the scene's root joint) to exactly the bodies of the description (1e-9), and the
    cut joints' <connect> sites are where the description puts them."""
    scene = load_scene(name)
    model = scene.multibody()
    mjcf, urdf = generated_files(model, name, f"{name}.xml", f"{name}.urdf", scene.dt, name)
    m = read_spec(mjcf).compile()
    assert compare_bodies(mujoco_bodies(m, model), model, rtol=1e-9) == []
    assert [d.message for d in mujoco_loop_discrepancies(m, model, rtol=1e-9) if not d.passed] == []
    pmodel = read_urdf(urdf, scene.urdf_root_joint)
    assert compare_bodies(pinocchio_bodies(pmodel, model), model, rtol=1e-9) == []


def test_a_system_with_force_elements_is_not_written():
    with pytest.raises(InputError, match="spring_pendulum: a generated scene writes bodies, joints, loops and gravity"):
        generated_files(load_scene("spring_pendulum").multibody(), "x", "x.xml", "x.urdf", 1e-3, "spring_pendulum")


def test_a_generated_scene_points_at_files_for_its_parameters():
    """N = 2 and N = 3 windows: 5 and 7 bodies, 2 and 3 cut hinges (two <connect> each), in two
    folders of the cache, neither under models/; loading again gives the same files."""
    two, three = load_scene("four_bar_chain", {"N": 2}), load_scene("four_bar_chain", {"N": 3})
    for scene, n in ((two, 2), (three, 3)):
        assert scene.generated and MODELS_DIR not in scene.mjcf.parents and scene.mjcf.parent == scene.urdf.parent
        m = read_spec(scene.mjcf).compile()
        assert m.nbody - 1 == 2 * n + 1 and m.neq == 2 * n
        assert len(scene.multibody().loops) == n
    assert two.mjcf.parent != three.mjcf.parent
    assert load_scene("four_bar_chain", {"N": 2}).mjcf == two.mjcf
    assert not (MODELS_DIR / "four_bar_chain" / "four_bar_chain.xml").exists()


def test_the_files_as_written_hold_the_scene_they_were_written_for():
    """validate's model.* checks judge a generated scene's files against the scene itself (its
    files are written for its parameters), not against the scene.toml defaults."""
    scene = load_scene("four_bar_chain", {"N": 2, "L": 0.8, "m": 1.3})
    for engine in ("mujoco", "pinocchio"):
        assert as_written(scene, engine).problems == []


def test_a_worker_without_the_files_writes_them_again():
    scene = load_scene("four_bar_chain", {"N": 2})
    data = pickle.dumps(scene)
    shutil.rmtree(scene.mjcf.parent)
    back = pickle.loads(data)
    assert back.mjcf.is_file() and back.urdf.is_file()


def test_the_builder_takes_a_whole_number_of_windows():
    p = load_scene("four_bar_chain").params
    model = builder.build({**p, "N": 2.0})
    assert [b.name for b in model.bodies] == ["crank_0", "coupler_0", "crank_1", "coupler_1", "crank_2"]
    assert [(lp.body_a, lp.body_b) for lp in model.loops] == [("coupler_0", "crank_1"), ("coupler_1", "crank_2")]
    names = [b.name for b in builder.build({**p, "N": 12.0}).bodies]  # padded: they sort as they stand
    cranks = [x for x in names if x.startswith("crank")]
    assert names[:3] == ["crank_00", "coupler_00", "crank_01"] and cranks == sorted(cranks) and len(cranks) == 13
    for bad in (2.5, 1001.0):  # (0 is not positive: the parameter kind refuses it)
        with pytest.raises(InputError, match="whole number from 1 to 1000"):
            load_scene("four_bar_chain", {"N": bad})


def _copy(tmp_path, edit):
    models = tmp_path / "models"
    shutil.copytree(MODELS_DIR / "four_bar_chain", models / "four_bar_chain")
    toml = models / "four_bar_chain" / "scene.toml"
    toml.write_text(edit(toml.read_text()))
    return models


def test_scene_toml_rules_for_generated_files(tmp_path):
    """generated = true: a boolean; the folder keeps neither file; a scene without a builder
    cannot say it."""
    models = _copy(tmp_path, lambda t: t.replace("generated = true", 'generated = "yes"'))
    with pytest.raises(InputError, match="generated must be a boolean"):
        load_description("four_bar_chain", models_dir=models)
    models = _copy(tmp_path / "b", lambda t: t)
    (models / "four_bar_chain" / "four_bar_chain.xml").write_text(mjcf_text(load_scene("four_bar_chain", {"N": 1}).multibody(), "x", 1e-3))
    with pytest.raises(InputError, match="generated = true, yet four_bar_chain.xml is in"):
        load_description("four_bar_chain", models_dir=models)
    models = tmp_path / "c"
    shutil.copytree(MODELS_DIR / "three_link_chain", models / "three_link_chain")
    toml = models / "three_link_chain" / "scene.toml"
    toml.write_text(toml.read_text().replace('name = "three_link_chain"', 'name = "three_link_chain"\ngenerated = true'))
    with pytest.raises(InputError, match="generated = true writes the model files from the system a builder makes"):
        load_description("three_link_chain", models_dir=models)


def test_a_scene_without_a_reference_run_cannot_ask_for_the_trajectory_check(tmp_path):
    """A scene whose [not_run] names the reference engine: a [checks.trajectory] there has
    nothing to be judged against (harness.engines.check_scene)."""
    models = _copy(tmp_path, lambda t: t + '\n[not_run]\ninhouse = "a finding"\n\n[checks.trajectory]\n')
    with pytest.raises(InputError, match=r"\[checks.trajectory\] is judged against the reference run"):
        load_scene("four_bar_chain", models_dir=models)
