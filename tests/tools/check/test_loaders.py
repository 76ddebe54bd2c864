"""``harness check`` with three loaders (MuJoCo, Pinocchio, Drake): which agree on what, the odd
one out named where two agree against one, and a loader that refuses a file reported in one line
while the others still compare.

dm_control (a test dependency) ships the suite models of issue 14: the tests on them never skip
when it is installed."""

import math
import os
from pathlib import Path

import numpy as np
import pytest

from harness.cli.main import main
from harness.tools.check import Vote, run_check, summary_lines


def run(args, capsys):
    code = main(args)
    out = capsys.readouterr()
    return code, out.out, out.err


def suite_file(name: str) -> Path:
    dm_control = pytest.importorskip("dm_control", reason="dm_control (a test dependency) is not installed")
    return Path(os.path.dirname(dm_control.__file__)) / "suite" / f"{name}.xml"


def votes(res, quantity):
    return {v.joint: v for v in res.votes if v.quantity == quantity}


def capsule_volume(radius: float, length: float) -> float:
    """m^3: a cylinder of ``length`` between two hemispheres of ``radius``."""
    return math.pi * radius**2 * length + 4.0 / 3.0 * math.pi * radius**3


MJCF_DENSITY = 1000.0  # kg/m^3, MuJoCo's default geom density


def arm_urdf(joint_type: str = "revolute", base: str = '<link name="base"/>') -> str:
    """Two links on a ``joint_type`` joint and a continuous one, inertial frames offset and turned."""
    return f"""<?xml version="1.0"?>
<robot name="arm">
  {base}
  <joint name="j1" type="{joint_type}"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 1" rpy="0 0.1 0"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="1" velocity="1"/>
    <dynamics damping="0.1"/></joint>
  <link name="l1"><inertial><origin xyz="0 0 -0.25" rpy="0.2 0 0"/><mass value="1"/>
    <inertia ixx="0.01" ixy="0.001" ixz="0" iyy="0.012" iyz="0.0005" izz="0.005"/></inertial></link>
  <joint name="j2" type="continuous"><parent link="l1"/><child link="l2"/>
    <origin xyz="0.1 0 -0.5" rpy="0.3 0 0.2"/><axis xyz="1 0 0"/></joint>
  <link name="l2"><inertial><origin xyz="0 0.05 -0.2" rpy="0.1 0.2 0.3"/><mass value="0.7"/>
    <inertia ixx="0.02" ixy="0" ixz="0.001" iyy="0.03" iyz="0" izz="0.015"/></inertial></link>
</robot>
"""


def test_acrobot_pinocchio_is_the_odd_one_out_for_the_masses(tmp_path, capsys):
    """acrobot.xml gives its capsules ``mass="1"`` in ``<default><geom>``: MuJoCo and Drake read
    1 kg per arm; Pinocchio derives the mass from the capsule's volume at MuJoCo's default
    density (radius 0.05 m and 0.049 m, length 1 m in the file)."""
    path = suite_file("acrobot")
    res = run_check(path, None, n_free=1, t_end=0.05)
    assert all(r.loaded for r in res.readings.values() if not r.other_format)
    assert res.readings["PyBullet"].other_format and "compared on a URDF only" in res.readings["PyBullet"].refusal
    assert not res.refusals   # PyBullet reads a URDF only: not a refusal of this file
    mass = votes(res, "mass")
    for joint, radius in (("shoulder", 0.05), ("elbow", 0.049)):
        v = mass[joint]
        assert v.odd == "Pinocchio", v.message
        assert v.values["MuJoCo"] == v.values["Drake"] == "1 kg"
        pin_kg = float(v.values["Pinocchio"].split()[0])
        assert pin_kg == pytest.approx(MJCF_DENSITY * capsule_volume(radius, 1.0), rel=1e-5)
        assert "Pinocchio is the odd one out" in v.message and "where MuJoCo and Drake read 1 kg" in v.message
        assert votes(res, "inertia about the centre of mass")[joint].odd == "Pinocchio"
    # a known importer limitation: classified with its entry, reported with its workaround, not a failure
    c = res.classes
    assert c.file_class == "importer disagreement" and not c.defects and not c.unexplained
    assert {d.limitation.id for d in c.known} == {"pinocchio-mjcf-default-geom-mass"}
    assert res.passed
    code, out, _ = run(["check", "--mjcf", str(path), "--out-dir", str(tmp_path), "--free-runs", "0"], capsys)
    assert code == 0, out
    assert out.startswith("acrobot: IMPORTER DISAGREEMENT")
    assert "Pinocchio ignores a geom mass that comes from a <default> (known: pinocchio-mjcf-default-geom-mass" in out
    assert "workaround: state mass= on each geom element itself" in out
    report = (tmp_path / "check_acrobot.md").read_text()
    assert "Verdict: importer disagreement: Pinocchio ignores a geom mass" in report
    assert "| MuJoCo vs Drake | M |" in report   # Drake's dynamics terms at the same states


def test_cartpole_pinocchio_is_the_odd_one_out_for_the_slide_range_and_the_pole(tmp_path):
    """cartpole.xml: the slider's ``range="-1.8 1.8"`` (metres: MuJoCo converts only angles from
    degrees) and the pole's ``mass=".1"`` in its default class."""
    path = suite_file("cartpole")
    res = run_check(path, None, n_free=0)
    rng = votes(res, "range")["slider"]
    assert rng.odd == "Pinocchio", rng.message
    assert rng.values["MuJoCo"] == rng.values["Drake"] == "[-1.8, 1.8] m"
    lo, hi = (float(x) for x in rng.values["Pinocchio"].removesuffix(" m").strip("[]").split(","))
    assert (lo, hi) == pytest.approx((-1.8 * math.pi / 180, 1.8 * math.pi / 180))
    assert "read as degrees" in rng.message
    mass = votes(res, "mass")["hinge_1"]
    assert mass.odd == "Pinocchio" and mass.values["MuJoCo"] == mass.values["Drake"] == "0.1 kg"
    known = {d.limitation.id for d in res.classes.known}
    assert known == {"pinocchio-mjcf-slide-range-in-degrees", "pinocchio-mjcf-default-geom-mass"}
    assert "known: pinocchio-mjcf-slide-range-in-degrees" in " ".join(" ".join(summary_lines(res)).split())


def test_drake_agrees_with_mujoco_on_the_dynamics_of_the_dm_control_pendulums():
    """Where the files hold nothing any importer misreads, Drake's M, C v and g at random states
    agree with MuJoCo's and Pinocchio's (joint coordinates mapped by name)."""
    for name in ("pendulum", "acrobot", "cartpole"):
        res = run_check(suite_file(name), None, n_free=0)
        rows = {(d.a, d.b, d.term): d for d in res.dynamics}
        for term in ("M", "bias", "gravity"):
            assert rows[("MuJoCo", "Drake", term)].passed, (name, rows[("MuJoCo", "Drake", term)])


def test_floating_base_dynamics_agree_in_all_three(tmp_path):
    """A free root joint: Drake's quaternion floating joint (q = [quat, p], v = [w_W, v_W]) mapped
    to the common coordinates gives the same M, C v and g as MuJoCo and Pinocchio."""
    base = ('<link name="base"><inertial><origin xyz="0.05 0 0.9"/><mass value="2"/>'
            '<inertia ixx="0.02" ixy="0" ixz="0" iyy="0.03" iyz="0" izz="0.025"/></inertial></link>')
    path = tmp_path / "arm.urdf"
    path.write_text(arm_urdf(base=base))
    res = run_check(None, path, floating_base=True, n_free=0)
    assert res.passed, summary_lines(res)
    assert {(d.a, d.b) for d in res.dynamics} == {("MuJoCo", "Pinocchio"), ("MuJoCo", "Drake"), ("Pinocchio", "Drake")}


def test_mjcf_floating_base_in_all_three(tmp_path):
    """--floating-base on an MJCF whose root body has no joint: MuJoCo adds a free joint, Pinocchio
    a free-flyer root, Drake replaces its parser's weld to the world by a floating joint; all three
    name it root_joint and agree (bodies 3 kg and 1 kg in the file)."""
    path = tmp_path / "base.xml"
    path.write_text("""<mujoco model="base"><worldbody>
      <body name="base" pos="0 0 1"><geom type="box" size=".2 .1 .1" mass="3"/>
        <body name="arm" pos="0.2 0 0"><joint name="h" axis="0 1 0"/>
          <geom type="capsule" size=".05" fromto="0 0 0 .5 0 0" mass="1"/></body>
      </body></worldbody></mujoco>""")
    res = run_check(path, None, floating_base=True, n_free=1, t_end=0.05)
    assert res.passed, summary_lines(res)
    for r in res.readings.values():
        if r.other_format:   # PyBullet: a URDF only
            continue
        assert r.loaded and {x.joint: x.mass for x in r.bodies}["root_joint"] == pytest.approx(3.0), r.loader
    assert len(res.dynamics) == 9 and res.free


NAMELESS = """<mujoco>
  <compiler angle="radian"/>
  <worldbody>
    <body name="b1" pos="0 0 1">
      <joint name="h1" type="hinge" axis="0 1 0"/>
      <inertial pos="0 0 -0.25" mass="1" diaginertia="0.01 0.01 0.005"/>
    </body>
  </worldbody>
</mujoco>
"""


def test_a_file_drake_refuses_leaves_mujoco_and_pinocchio_comparing(tmp_path, capsys):
    """Drake's MJCF parser refuses an MJCF without a model name: one line in the summary and the
    report ("Drake: does not load: <reason>"), no traceback, and MuJoCo and Pinocchio still
    compare (they agree: exit 0)."""
    path = tmp_path / "nameless.xml"
    path.write_text(NAMELESS)
    code, out, err = run(["check", "--mjcf", str(path), "--out-dir", str(tmp_path), "--t-end", "0.05"], capsys)
    assert code == 0, out
    assert "Traceback" not in out + err
    lines = [ln for ln in out.splitlines() if "Drake: does not load: " in ln]
    assert len(lines) == 1 and lines[0].split("Drake: does not load: ")[1].strip()
    report = (tmp_path / "check_nameless.md").read_text()
    assert "Drake" in report and "**does not load**" in report
    assert "| MuJoCo vs Pinocchio | M |" in report and "| MuJoCo vs Drake |" not in report
    assert "## Free motion under gravity" in report and "Not run" not in report


def test_a_file_pinocchio_refuses_leaves_mujoco_and_drake_comparing(tmp_path):
    """Pinocchio 4.1's MJCF parser refuses a height field: MuJoCo and Drake still compare; the free
    motion (MuJoCo against Pinocchio) is not run, and says why."""
    path = tmp_path / "terrain.xml"
    path.write_text("""<mujoco model="terrain">
  <asset><hfield name="h" nrow="2" ncol="2" size="1 1 0.1 0.1"/></asset>
  <worldbody>
    <geom type="hfield" hfield="h"/>
    <body name="a" pos="0 0 1"><joint name="h1" type="hinge" axis="0 1 0"/>
      <geom type="capsule" size=".05" fromto="0 0 0 0 0 -1" mass="1"/></body>
  </worldbody>
</mujoco>
""")
    res = run_check(path, None, n_free=1, t_end=0.05)
    assert not res.readings["Pinocchio"].loaded and "\n" not in res.readings["Pinocchio"].refusal
    assert res.refusals == [f"Pinocchio: does not load: {res.readings['Pinocchio'].refusal}"]
    assert {(d.a, d.b) for d in res.dynamics} == {("MuJoCo", "Drake")}
    assert res.passed and not res.free and "Pinocchio does not load" in res.free_skipped


def test_only_mujoco_loads_is_bad_input(tmp_path, capsys):
    """A planar URDF joint: Pinocchio's planar joint cannot be compared and Drake refuses the
    file, so MuJoCo has nothing to compare with: exit 2, one line giving both reasons."""
    path = tmp_path / "arm.urdf"
    path.write_text(arm_urdf(joint_type="planar"))
    code, out, err = run(["check", "--urdf", str(path), "--out-dir", str(tmp_path / "r")], capsys)
    assert code == 2 and out == ""
    (line,) = err.strip().splitlines()
    assert "only MuJoCo loads the model" in line and "Pinocchio: " in line and "Drake: " in line
    assert not (tmp_path / "r").exists()


def test_two_agree_against_one_names_the_odd_one():
    """The vote itself: two loaders agreeing against a third name it; two loaders alone that
    differ, or three that all differ, name none."""
    odd = Vote("j", "b", "mass", {"MuJoCo": "1 kg", "Pinocchio": "8 kg", "Drake": "1 kg"},
               (("MuJoCo", "Drake"), ("Pinocchio",)))
    assert odd.odd == "Pinocchio" and not odd.agree
    assert odd.message == "joint 'j' (body 'b'): mass: Pinocchio is the odd one out: 8 kg where MuJoCo and Drake read 1 kg"
    pair = Vote("j", "b", "mass", {"MuJoCo": "1 kg", "Drake": "2 kg"}, (("MuJoCo",), ("Drake",)))
    assert pair.odd is None and pair.message == "joint 'j' (body 'b'): mass: 1 kg in MuJoCo, 2 kg in Drake"
    split = Vote("j", "b", "mass", {"MuJoCo": "1 kg", "Pinocchio": "2 kg", "Drake": "3 kg"},
                 (("MuJoCo",), ("Pinocchio",), ("Drake",)))
    assert split.odd is None and "all three differ" in split.message
    assert Vote("j", "b", "mass", {"MuJoCo": "1 kg", "Drake": "1 kg"}, (("MuJoCo", "Drake"),)).agree


def test_mujoco_alone_honouring_the_file_is_named_with_the_element():
    """cheetah.xml scales its masses with ``<compiler settotalmass>``, which only MuJoCo applies:
    MuJoCo is the odd one out and the message names the element; the total of MuJoCo's masses is
    the file's total."""
    import mujoco

    path = suite_file("cheetah")
    res = run_check(path, None, n_free=0)
    mass = [v for v in res.votes if v.quantity == "mass" and not v.agree]
    assert mass and all(v.odd == "MuJoCo" and "settotalmass" in v.hint for v in mass)
    spec = mujoco.MjSpec.from_file(str(path))
    total = sum(x.mass for x in res.readings["MuJoCo"].bodies)
    assert total == pytest.approx(spec.compiler.settotalmass, rel=1e-9)
    assert np.isfinite(total)
