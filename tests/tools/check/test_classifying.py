"""The verdict classes of ``harness check`` on faults planted in copies of third-party models: a
zero-mass link with inertia and an inertia breaking the triangle inequality are defects in the
file (element, line, fix), a ``<default>`` geom mass is an importer disagreement matched to its
known-limitation entry, a mimic joint is named as not compared; bolt's first screen says what to
change in at most 10 lines of at most 120 characters."""

from __future__ import annotations

import shutil
import sysconfig
from pathlib import Path

import dm_control
import pytest

from harness.cli.main import main
from harness.tools.check import run_check, summary_lines
from harness.tools.check.classifying import DEFECT, IMPORTER, KNOWN, witness_line

ROBOTS = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
UR5 = ROBOTS / "ur_description" / "urdf" / "ur5_robot.urdf"
BOLT = ROBOTS / "bolt_description" / "robots" / "bolt.urdf"
SUITE = Path(dm_control.__file__).parent / "suite"
FAST = {"n_states": 2, "n_free": 1, "t_end": 0.1}
EE_LINK_INERTIAL = '<mass value="0"/>'   # ur5_robot.urdf's ee_link: a massless frame, zero inertia


def ur5_copy(tmp_path: Path, old: str, new: str) -> Path:
    text = UR5.read_text()
    assert text.count(old) >= 1, old
    path = tmp_path / "ur5.urdf"
    path.write_text(text.replace(old, new, 1))
    return path


def line_of(path: Path, fragment: str, after: str = "") -> int:
    lines = path.read_text().splitlines()
    start = next(i for i, ln in enumerate(lines) if after in ln) if after else 0
    return next(i for i in range(start, len(lines)) if fragment in lines[i]) + 1


def ee_inertia(ixx: str, iyy: str, izz: str) -> str:
    return f'ixx="{ixx}" ixy="0.0" ixz="0.0" iyy="{iyy}" iyz="0.0" izz="{izz}"'


def test_a_zero_mass_link_with_inertia_is_a_defect_with_its_line_and_fix(tmp_path, capsys):
    text = UR5.read_text()
    start = text.index('<link name="ee_link">')
    inertia = text.index("<inertia ", start)
    end = text.index("/>", inertia)
    path = tmp_path / "ur5.urdf"
    path.write_text(text[:inertia] + f"<inertia {ee_inertia('1e-4', '2e-4', '2e-4')}" + text[end:])
    res = run_check(None, path, strip=True, **FAST)
    zero = [d for d in res.classes.defects if d.kind == "zero mass with inertia"]
    assert [(d.element, d.line, d.owner) for d in zero] == [("link 'ee_link'",
                                                             line_of(path, "<mass", '<link name="ee_link">'),
                                                             "wrist_3_link")]
    assert zero[0].fix == "give link 'ee_link' its mass, or set its inertia to zero"
    assert res.classes.file_class == DEFECT and not res.passed
    # what the importers then read differently follows from the defect, none of it unexplained
    assert not res.classes.unexplained
    assert all(d.defect is not None for d in res.classes.disagreements)
    code = main(["check", "--urdf", str(path), "--strip-geometry", "--out-dir", str(tmp_path / "r"), "--free-runs", "0",
                 "--states", "2"])
    out = capsys.readouterr().out
    assert code == 1
    assert f"ur5.urdf:{zero[0].line} link 'ee_link': zero mass with inertia" in out
    assert "fix: give link 'ee_link' its mass, or set its inertia to zero" in out


@pytest.mark.parametrize("link, inertia, moments", [
    ("ee_link", ("1e-5", "1e-5", "5e-5"), "I1 + I2 = 2e-05 < I3 = 5e-05 kg m^2"),       # a fixed link of 0.05 kg
    ("wrist_3_link", ("0.001", "0.001", "0.005"), "I1 + I2 = 0.002 < I3 = 0.005 kg m^2"),   # a link a joint moves
])
def test_an_inertia_breaking_the_triangle_inequality(tmp_path, capsys, link, inertia, moments):
    """No loader can run a body no rigid body can be (MuJoCo refuses it, fixed or moving): one line
    with the defect, its line in the file and the fix; exit 2, nothing written."""
    path = ur5_copy(tmp_path, EE_LINK_INERTIAL, '<mass value="0.05"/>')
    text = path.read_text()
    start = text.index(f'<link name="{link}">')
    at = text.index("<inertia ", start)
    path.write_text(text[:at] + f"<inertia {ee_inertia(*inertia)}" + text[text.index("/>", at):])
    out_dir = tmp_path / "r"
    code = main(["check", "--urdf", str(path), "--strip-geometry", "--out-dir", str(out_dir)])
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert code == 2 and captured.out == "" and len(lines) == 1 and not out_dir.exists()
    line = line_of(path, "<inertia ", f'<link name="{link}">')
    assert lines[0].startswith(f"harness: error: {path}:{line}: {DEFECT}: link '{link}': principal moments")
    assert f"break the triangle inequality: {moments}; fix: recompute link '{link}''s inertia about its centre of " \
           "mass (every rigid body has I1 + I2 >= I3)" in lines[0]


def test_a_default_geom_mass_is_an_importer_disagreement_matched_to_its_entry(tmp_path):
    """pendulum.xml's bob gets its 1 kg from a default class instead of its own ``mass=``: MuJoCo
    and Drake read 1 kg, Pinocchio the sphere's volume at MuJoCo's default density (0.524 kg)."""
    shutil.copytree(SUITE / "common", tmp_path / "common")
    text = (SUITE / "pendulum.xml").read_text()
    text = text.replace('size="0.05" mass="1"/>', 'size="0.05" class="bob"/>')
    text = text.replace("<worldbody>", '<default><default class="bob"><geom mass="1"/></default></default>\n  <worldbody>')
    path = tmp_path / "pendulum.xml"
    path.write_text(text)
    res = run_check(path, None, **FAST)
    c = res.classes
    assert c.file_class == IMPORTER and not c.defects and not c.unexplained
    mass = next(d for d in c.disagreements if d.quantity == "mass")
    assert mass.status == KNOWN and mass.loaders == ("Pinocchio",)
    assert mass.limitation.id == "pinocchio-mjcf-default-geom-mass" and mass.limitation.workaround
    assert "0.523599 kg where MuJoCo and Drake read 1 kg" in mass.text
    assert res.passed   # a known limitation is reported with its workaround, not failed
    # the unplanted file: nothing to match
    assert run_check(SUITE / "pendulum.xml", None, **FAST).classes.file_class == "consistent"


def test_a_mimic_joint_is_named_not_compared(tmp_path):
    path = ur5_copy(tmp_path, '<joint name="wrist_3_joint" type="revolute">',
                    '<joint name="wrist_3_joint" type="revolute"><mimic joint="wrist_2_joint" multiplier="-1" offset="0.1"/>')
    res = run_check(None, path, strip=True, **FAST)
    (mimic,) = [u for u in res.classes.uncompared if u.what.startswith("mimic joint")]
    assert mimic.what == "mimic joint 'wrist_3_joint' (follows 'wrist_2_joint' x -1 + 0.1)"
    assert "MuJoCo an equality constraint" in mimic.why
    assert not any("equality constraint" in u.what for u in res.classes.uncompared)   # named as the file names it
    assert witness_line(res) == ("witnesses (in-house, Exudyn): not run: mimic joint(s) 'wrist_3_joint': the "
                                 "witnesses hold a tree of independent joints, not a coupling")


def test_bolt_first_screen_says_what_to_change(capsys, tmp_path):
    """bolt.urdf: FL_FOOT and FR_FOOT have ``<mass value="0">`` with a non-zero inertia: within 10
    lines of at most 120 characters the check names both links with their line and the fix."""
    code = main(["check", "--urdf", str(BOLT), "--strip-geometry", "--out-dir", str(tmp_path), "--quiet",
                 "--free-runs", "1", "--t-end", "0.1"])
    lines = capsys.readouterr().out.splitlines()
    assert code == 1
    assert len(lines) <= 10 and max(len(ln) for ln in lines) <= 120, "\n".join(lines)
    text = "\n".join(lines)
    assert lines[0].startswith("bolt: DEFECT IN YOUR FILE")
    for link in ("FL_FOOT", "FR_FOOT"):
        at = line_of(BOLT, "<mass", f'<link name="{link}">')
        assert f"bolt.urdf:{at} link '{link}': zero mass with inertia" in text
        assert f"fix: give link '{link}' its mass, or set its inertia to zero" in text


@pytest.mark.parametrize("model", ["finger", "humanoid_CMU", "quadruped"])
def test_summary_lines_fit_a_terminal(model):
    res = run_check(SUITE / f"{model}.xml", None, n_states=1, n_free=0, witnesses=False)
    assert all(len(line) <= 120 for line in summary_lines(res, "reports/check.md"))
    assert not res.classes.unexplained   # every disagreement on the suite's files has its known entry
