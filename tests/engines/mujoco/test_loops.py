"""MuJoCo and loop joints: the MJCF's site-based <connect> equalities rewritten from the
description, their soft closure measured, and a file that does not state the loop refused."""

import shutil

import pytest

from harness.engines import get_engine
from harness.engines.base import RunSettings
from harness.engines.mujoco.loops import connects, loop_points
from harness.engines.mujoco.model import load_mjcf
from harness.measure import compare
from harness.model.errors import InputError
from harness.model.scene import MODELS_DIR
from harness.engines import load_scene


def test_the_sites_follow_the_description():
    scene = load_scene("four_bar", {"b": 0.55, "c": 0.35})
    model = scene.multibody()
    m = load_mjcf(scene.mjcf, model)
    found = loop_points(m)
    for eq, (_, body_a, p_a), (_, body_b, p_b) in connects(model.loops[0]):
        (got_a, pos_a), (got_b, pos_b) = found[eq]
        assert (got_a, got_b) == (body_a, body_b)
        assert pos_a.tolist() == pytest.approx(p_a.tolist()) and pos_b.tolist() == pytest.approx(p_b.tolist())


def test_the_soft_loop_stays_closed_to_its_stated_softness():
    scene = load_scene("four_bar")
    model = scene.multibody()
    traj = get_engine("mujoco").simulate(scene, RunSettings(t_end=1.0, dt=1e-3, save_every=0.01, integrator="RK4"))
    assert traj.ok
    gap = compare.loop_closure(traj, model)["cut"]["position"]
    assert 1e-12 < gap < 2e-6  # soft: not round-off, yet within the scene's tolerance
    assert "soft equality constraints (connect), solref 0.002 1, solimp 0.9999" in traj.stats["settings"]


def test_a_mjcf_without_the_loop_equality_is_refused(tmp_path):
    shutil.copytree(MODELS_DIR / "four_bar", tmp_path / "four_bar")
    path = tmp_path / "four_bar" / "four_bar.xml"
    path.write_text(path.read_text().replace('name="cut_2"', 'name="other"'))
    scene = load_scene("four_bar", models_dir=tmp_path)
    with pytest.raises(InputError, match="no equality named 'cut_2' for the loop joint 'cut'"):
        load_mjcf(scene.mjcf, scene.multibody())
