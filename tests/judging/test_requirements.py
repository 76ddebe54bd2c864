"""A project's requirements file (``harness.judging.requirements``): bad files are one input
error naming the file, table and key; entries add to a scene's requirements, and a change to one
the scene states itself is reported as tightening or loosening it."""

import math

import pytest

from harness.judging.requirements import apply_requirements, check_scenes_known, read_requirements
from harness.judging.verdict import requirement
from harness.model.errors import InputError
from harness.engines import load_scene


@pytest.mark.parametrize("text,fragment", [
    ("heavy_top = 1\n", "expected a table [heavy_top]"),
    ("[heavy_top]\nenrgy_drift = 1e-8\n", "the harness has no check 'enrgy_drift'"),
    ("[heavy_top]\nexact = -1e-6\n", "[heavy_top] exact must be positive and finite"),
    ("[heavy_top]\nexact = \"1e-6\"\n", "[heavy_top] exact is not a number"),
    ("[heavy_top]\nexact = inf\n", "[heavy_top] exact must be positive and finite"),
    ("[heavy_top\n", "malformed TOML"),
])
def test_bad_requirements_file_is_one_input_error(tmp_path, text, fragment):
    path = tmp_path / "req.toml"
    path.write_text(text)
    with pytest.raises(InputError) as err:
        read_requirements(path)
    assert str(path) in str(err.value) and fragment in str(err.value) and "\n" not in str(err.value)


def test_missing_requirements_file(tmp_path):
    with pytest.raises(InputError, match="requirements file"):
        read_requirements(tmp_path / "none.toml")


def test_requirements_add_and_are_reported(tmp_path):
    path = tmp_path / "req.toml"
    path.write_text('[heavy_top]\nexact = 1e-6\n"trajectory.position" = 1e-7\n')
    table = read_requirements(path)
    scene = load_scene("heavy_top")
    assert requirement(scene, "exact") == math.inf  # the scene states none: convergence alone judges
    new, changes = apply_requirements(scene, table, path)
    assert requirement(new, "exact") == 1e-6 and requirement(new, "trajectory.position") == 1e-7
    assert requirement(new, "trajectory.orientation") == math.inf
    assert changes == ["exact <= 1e-06 (added)", "trajectory.position <= 1e-07 (added)"]
    # a change to a requirement the scene states itself says which way it goes
    stated = new.with_params()
    again, changes = apply_requirements(stated, {"heavy_top": {"exact": 1e-8}}, path)
    assert changes == ["exact <= 1e-08 (tightens the scene's 1e-06)"] and requirement(again, "exact") == 1e-8
    _, changes = apply_requirements(stated, {"heavy_top": {"exact": 1e-3}}, path)
    assert changes == ["exact <= 0.001 (loosens the scene's 1e-06)"]


def test_a_table_requirement_bounds_each_of_its_checks():
    scene = load_scene("four_bar")
    new, _ = apply_requirements(scene, {"four_bar": {"closure": 1e-9}}, "req.toml")
    assert requirement(new, "closure.position") == requirement(new, "closure.velocity") == 1e-9


def test_requirement_for_a_check_the_scene_lacks(tmp_path):
    with pytest.raises(InputError, match=r"\[heavy_top\] slip: the scene makes no slip check"):
        apply_requirements(load_scene("heavy_top"), {"heavy_top": {"slip": 1e-3}}, tmp_path / "r.toml")
    with pytest.raises(InputError, match="unknown scene 'nope'"):
        check_scenes_known({"nope": {}}, ["heavy_top"], tmp_path / "r.toml")
