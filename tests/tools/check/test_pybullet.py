"""PyBullet as ``harness check``'s fourth loader (URDF, ``URDF_USE_INERTIA_FROM_FILE``): it votes with
MuJoCo, Pinocchio and Drake on example-robot-data's ur5 and solo12, its dynamics terms are compared on a
fixed base, a difference planted in PyBullet alone makes it the odd one out (3 against 1), and its
inertia trap (the URDF loaded without the flag) is named as a known limitation, apart from the vote."""

from __future__ import annotations

import sysconfig
from pathlib import Path

import numpy as np
import pytest

from harness.cli.main import main
from harness.tools.check import Vote, run_check, summary_lines
from harness.tools.check import reading as check_reading
from harness.tools.check.comparing import dynamics_odd

ROBOTS = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
UR5 = ROBOTS / "ur_description" / "urdf" / "ur5_robot.urdf"
SOLO12 = ROBOTS / "solo_description" / "robots" / "solo12.urdf"
FAST = {"n_states": 2, "n_free": 1, "t_end": 0.1}
TRAP = "pybullet-urdf-inertia-from-collision-by-default"
LOADERS4 = {"MuJoCo", "Pinocchio", "Drake", "PyBullet"}

# a box link (mass 2 kg, 0.1 x 0.2 x 0.3 m collision box) whose file inertia is not the box's
BOX = """<robot name="box"><link name="world"/>
  <joint name="fix" type="fixed"><parent link="world"/><child link="base"/></joint>
  <link name="base"><inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
  <joint name="hinge" type="revolute"><parent link="base"/><child link="box"/><origin xyz="0 0 0.5"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <link name="box"><inertial><origin xyz="0 0 0.15"/><mass value="2"/>
      <inertia ixx="0.05" ixy="0" ixz="0" iyy="0.04" iyz="0" izz="0.03"/></inertial>
    <collision><origin xyz="0 0 0.15"/><geometry><box size="0.1 0.2 0.3"/></geometry></collision></link>
</robot>
"""


def test_ur5_compares_four_loaders_and_names_the_trap(tmp_path, capsys):
    res = run_check(None, UR5, strip=True, **FAST)
    assert all(res.readings[k].loaded for k in LOADERS4)
    masses = [v for v in res.votes if v.quantity == "mass"]
    assert len(masses) == 6 and all(set(v.values) == LOADERS4 and v.agree for v in masses)
    pairs = {frozenset((d.a, d.b)) for d in res.dynamics if d.passed}
    assert {frozenset((k, "PyBullet")) for k in ("MuJoCo", "Pinocchio", "Drake")} <= pairs   # fixed base: compared
    # the trap: every moving link's inertia differs without the flag (its collision meshes, or none)
    c = res.classes
    assert len(c.trap) == 6 and {d.limitation.id for d in c.trap} == {TRAP}
    assert not c.unexplained and all(d.quantity != "inertia without URDF_USE_INERTIA_FROM_FILE" for d in c.disagreements)
    lines = summary_lines(res)
    assert any("PyBullet without URDF_USE_INERTIA_FROM_FILE" in ln and "6 joint(s): known trap" in ln for ln in lines)
    assert max(len(ln) for ln in lines) <= 120
    code = main(["check", "--urdf", str(UR5), "--strip-geometry", "--out-dir", str(tmp_path), "--quiet", "--free-runs", "1",
                 "--t-end", "0.1"])
    out = capsys.readouterr().out
    assert code == 1 and "URDF -> MuJoCo, Pinocchio, Drake and PyBullet" in out   # ur5's wrist_3 density defect
    report = (tmp_path / "check_ur5_robot.md").read_text()
    assert f"known **{TRAP}** (PyBullet 3.2.7)" in report and "pass flags=p.URDF_USE_INERTIA_FROM_FILE" in report
    assert "| MuJoCo vs PyBullet | M |" in report


def test_solo12_floating_base_four_loaders_agree():
    res = run_check(None, SOLO12, floating_base=True, strip=True, **FAST)
    assert all(res.readings[k].loaded for k in LOADERS4)
    root = [v for v in res.votes if v.joint == "root_joint" and v.quantity == "mass"]
    assert root and set(root[0].values) == LOADERS4 and root[0].agree
    c = res.classes
    assert c.file_class == "consistent" and res.passed
    assert len(c.trap) == 13 and c.trap[0].limitation.id == TRAP
    assert "floating base" in res.readings["PyBullet"].dynamics   # its base dofs not mapped: said, not compared
    assert not any("PyBullet" in (d.a, d.b) for d in res.dynamics)


def test_the_trap_is_the_collision_box_inertia_and_without_geometry_a_2mm_cube(tmp_path):
    path = tmp_path / "box.urdf"
    path.write_text(BOX)
    res = run_check(None, path, **FAST)
    assert res.passed and res.classes.file_class == "consistent"   # the trap is not a disagreement of the loaders
    (t,) = res.readings["PyBullet"].inertia_trap
    box = 2.0 / 12.0 * np.array([0.2**2 + 0.3**2, 0.1**2 + 0.3**2, 0.1**2 + 0.2**2])
    assert t.joint == "hinge" and np.allclose(np.diag(t.default_inertia), box, rtol=1e-6)
    assert np.allclose(np.diag(t.file_inertia), [0.05, 0.04, 0.03], rtol=1e-12)
    # --strip-geometry: PyBullet still reads the file as written for the trap (its box is there)
    assert np.allclose(np.diag(run_check(None, path, strip=True, **FAST).readings["PyBullet"].inertia_trap[0]
                               .default_inertia), box, rtol=1e-6)
    # without any collision shape, PyBullet gives mass x 6.67e-7 m^2 (a 2 mm cube), whatever the file says
    bare = tmp_path / "bare.urdf"
    bare.write_text(BOX.replace('<collision><origin xyz="0 0 0.15"/><geometry><box size="0.1 0.2 0.3"/></geometry>'
                                "</collision>", ""))
    (t,) = run_check(None, bare, **FAST).readings["PyBullet"].inertia_trap
    assert np.allclose(np.diag(t.default_inertia), 2.0 * 0.002**2 / 6.0, rtol=1e-6)


def test_a_difference_planted_in_pybullet_makes_it_the_odd_one_out(tmp_path, monkeypatch):
    path = tmp_path / "box.urdf"
    path.write_text(BOX)
    real = check_reading.load_pybullet

    def planted(p, **kw):   # the box 10 % heavier in PyBullet alone (its reading and its dynamics)
        load = real(p, **kw)
        from harness.tools.loaded_models import _pybullet

        _pybullet().changeDynamics(load.body, 1, mass=2.2, physicsClientId=load.client)
        return load

    monkeypatch.setattr(check_reading, "load_pybullet", planted)
    res = run_check(None, path, **FAST)
    mass = next(v for v in res.votes if v.joint == "hinge" and v.quantity == "mass")
    assert mass.odd == "PyBullet" and mass.groups[0] == ("MuJoCo", "Pinocchio", "Drake")
    assert "PyBullet is the odd one out: 2.2 kg where MuJoCo, Pinocchio and Drake read 2 kg" in mass.message
    assert dynamics_odd(res.dynamics).get("M") == "PyBullet"
    assert res.classes.unexplained and not res.passed
    assert any(d.loaders == ("PyBullet",) for d in res.classes.unexplained)


def test_four_loaders_two_against_two_is_no_majority():
    v = Vote("j", "b", "mass", {"MuJoCo": "1 kg", "Pinocchio": "1 kg", "Drake": "2 kg", "PyBullet": "2 kg"},
             (("MuJoCo", "Pinocchio"), ("Drake", "PyBullet")))
    assert v.odd is None and not v.agree
    assert Vote("j", "b", "mass", {}, (("MuJoCo", "Pinocchio", "Drake"), ("PyBullet",))).odd == "PyBullet"
    assert Vote("j", "b", "mass", {}, (("MuJoCo", "Pinocchio"), ("Drake",), ("PyBullet",))).odd is None


@pytest.mark.parametrize("text", ["<mujoco model='m'><worldbody><body name='b'><joint name='h' axis='0 1 0'/>"
                                  "<geom type='box' size='.1 .1 .1' mass='1'/></body></worldbody></mujoco>"])
def test_an_mjcf_is_not_pybullets_format_and_the_three_compare_as_before(tmp_path, text):
    path = tmp_path / "m.xml"
    path.write_text(text)
    res = run_check(path, None, **FAST)
    r = res.readings["PyBullet"]
    assert not r.loaded and r.other_format and "compared on a URDF only" in r.refusal
    assert not res.refusals and not any("PyBullet" in u.what for u in res.classes.uncompared)
    assert res.passed and all(set(v.values) <= {"MuJoCo", "Pinocchio", "Drake"} for v in res.votes)


def test_a_link_without_inertial_weighs_1_kg_in_pybullet_a_known_limitation(tmp_path):
    """A tool flange on a fixed joint with no <inertial>: MuJoCo, Pinocchio and Drake read no mass,
    PyBullet 1 kg with a unit inertia; the disagreement is matched to its entry, none unexplained."""
    flange = ('  <joint name="tool" type="fixed"><parent link="box"/><child link="flange"/><origin xyz="0 0 0.3"/></joint>\n'
              '  <link name="flange"/>\n</robot>')
    path = tmp_path / "box.urdf"
    path.write_text(BOX.replace("</robot>", flange))
    res = run_check(None, path, n_states=1, n_free=0, witnesses=False)
    (mass,) = [v for v in res.votes if v.quantity == "mass" and not v.agree]
    assert mass.odd == "PyBullet" and mass.values["PyBullet"] == "3 kg" and mass.values["MuJoCo"] == "2 kg"
    c = res.classes
    assert not c.unexplained and not c.defects
    assert {d.limitation.id for d in c.known} >= {"pybullet-urdf-missing-inertial-one-kg"}
    assert all(d.limitation.id == "pybullet-urdf-missing-inertial-one-kg" for d in c.known if d.quantity == "mass")
