"""``harness inspect``: the scenes load consistently; a wrong inertia planted in a copy of a URDF
is named (body and quantity) and shows in the dynamics check; cross-loads are findings."""

import re
import shutil

import pytest

from harness.cli.main import main
from harness.model.scene import available_scenes, MODELS_DIR
from harness.engines import load_scene
from harness.validate.run import model_checks

BAR2_URDF_INERTIA = '<inertia ixx="0.083358333333333" ixy="0" ixz="0" iyy="0.083358333333333" iyz="0" izz="0.00005"/>'


def run(args, capsys):
    code = main(args)
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.fixture
def models(tmp_path):
    dst = tmp_path / "models"
    shutil.copytree(MODELS_DIR / "double_pendulum", dst / "double_pendulum")
    return dst


def edit_bar2(models, old, new):
    """Replace ``old`` by ``new`` inside bar2's <link> of the copied URDF."""
    path = models / "double_pendulum" / "double_pendulum.urdf"
    text = path.read_text()
    start = text.index('<link name="bar2">')
    head, tail = text[:start], text[start:]
    assert old in tail
    path.write_text(head + tail.replace(old, new, 1))


# Scenes inspected at other parameters than their defaults: four_bar_chain's 40 windows (81 bodies)
# take the in-house finite-difference terms minutes; two windows show the same loads and terms.
SMALL = {"four_bar_chain": ["--set", "N=2"]}


@pytest.mark.parametrize("name", available_scenes())
def test_scenes_agree(name, capsys):
    code, out, _ = run(["inspect", name, *SMALL.get(name, [])], capsys)
    assert code == 0, out
    assert "RESULT: primary loads agree" in out
    for needle in ("principal moments", "principal axes", "timestep", "integrator", "gravity", "mujoco vs pinocchio"):
        assert needle in out


def test_inertia_about_the_joint_in_the_urdf_is_named(models, capsys):
    # The classic slip: bar2's inertia about its hinge (I + m (L/2)^2) instead of its centre of mass.
    edit_bar2(models, BAR2_URDF_INERTIA,
              '<inertia ixx="0.333358333333333" ixy="0" ixz="0" iyy="0.333358333333333" iyz="0" izz="0.00005"/>')
    code, out, _ = run(["inspect", "double_pendulum", "--models-dir", str(models)], capsys)
    assert code == 1
    disagree = [ln for ln in out.splitlines() if "DISAGREES" in ln]
    # the URDF's two readers, Pinocchio and Drake, both see it; MuJoCo reads the MJCF
    assert len(disagree) == 2 and all("bar2: inertia about the centre of mass" in d and "0.333358333333" in d
                                      for d in disagree)
    block = out[out.index("-- files as written"):]
    block = block[:block.index("-- cross-load")]
    assert re.search(r"mujoco vs pinocchio\s+M\s+\S+\s+\S+\s+DIFFERS", block)
    assert re.search(r"pinocchio vs inhouse\s+M\s+\S+\s+\S+\s+DIFFERS", block)
    applied = out[out.index("-- scene parameters applied"):out.index("-- files as written")]
    assert "DIFFERS" not in applied  # load_urdf overwrites the inertia: only the file as written shows it
    assert "RESULT: DISAGREEMENT" in out


def test_inspect_and_validate_judge_a_file_alike(models, capsys):
    edit_bar2(models, BAR2_URDF_INERTIA,
              '<inertia ixx="0.333358333333333" ixy="0" ixz="0" iyy="0.333358333333333" iyz="0" izz="0.00005"/>')
    _, out, _ = run(["inspect", "double_pendulum", "--models-dir", str(models)], capsys)
    disagree = [ln.split("DISAGREES: ", 1)[1] for ln in out.splitlines() if "DISAGREES" in ln]
    bad = [c for c in model_checks(load_scene("double_pendulum", models_dir=models), ["mujoco", "pinocchio", "drake"])
           if not c.passed]
    assert len(disagree) == len(bad) == 2
    assert {(c.engine, c.check) for c in bad} == {("pinocchio", "model.bar2.inertia"), ("drake", "model.bar2.inertia")}
    assert all(d in c.detail for d, c in zip(disagree, bad))


def test_moved_inertial_origin_is_named(models, capsys):
    edit_bar2(models, '<origin xyz="0 0 -0.5" rpy="0 0 0"/>\n      <mass', '<origin xyz="0 0 -0.45" rpy="0 0 0"/>\n      <mass')
    code, out, _ = run(["inspect", "double_pendulum", "--models-dir", str(models)], capsys)
    assert code == 1
    assert any("bar2: centre of mass [0.0, 0.0, -0.45] m" in ln for ln in out.splitlines() if "DISAGREES" in ln)
    block = out[out.index("-- files as written"):out.index("-- cross-load")]
    assert re.search(r"mujoco vs pinocchio\s+M\s+\S+\s+\S+\s+DIFFERS", block)
    assert re.search(r"mujoco vs pinocchio\s+gravity\s+\S+\s+\S+\s+DIFFERS", block)


def test_overrides_reach_the_applied_loads_and_not_the_files(capsys):
    code, out, _ = run(["inspect", "double_pendulum", "--set", "m=2", "--set", "L=0.5"], capsys)
    assert code == 0, out
    assert "parameters: m=2, L=0.5" in out
    assert "mass 2 kg" in out


def test_cross_load_findings_do_not_fail(capsys):
    code, out, _ = run(["inspect", "torque_free"], capsys)
    assert code == 0
    findings = [ln for ln in out.splitlines() if "FINDING" in ln]
    assert any("Pinocchio's MJCF parser ignores <option>" in ln for ln in findings)
    assert any("body 'body' is missing" in ln and "fusestatic" in ln for ln in findings)
    assert re.search(r"pinocchio<-MJCF vs inhouse\s+gravity\s+9\.810e\+00\s+1\.000e\+00\s+DIFFERS", out)


@pytest.mark.parametrize("text,fragment", [
    ("<robot name='x'><link name='bar1'>", "cannot load URDF"),
    (None, "URDF file not found"),
])
def test_bad_model_file_exit_2(models, capsys, text, fragment):
    path = models / "double_pendulum" / "double_pendulum.urdf"
    if text is None:
        path.unlink()
    else:
        path.write_text(text)
    code, out, err = run(["inspect", "double_pendulum", "--models-dir", str(models)], capsys)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("harness: error:") and fragment in err
    assert str(path) in err


def test_non_physical_inertia_in_the_file_exit_2(models, capsys):
    edit_bar2(models, BAR2_URDF_INERTIA,
              '<inertia ixx="0.083358333333333" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.00005"/>')
    code, _, err = run(["inspect", "double_pendulum", "--models-dir", str(models)], capsys)
    assert code == 2 and "bar2" in err and "triangle inequality" in err and "double_pendulum.urdf" in err


def test_unknown_scene_exit_2(capsys):
    code, _, err = run(["inspect", "nope"], capsys)
    assert code == 2 and "unknown scene 'nope'" in err
