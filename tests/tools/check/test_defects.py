"""Defects in the user's file (``harness.tools.check.defects``), found on the file as MuJoCo's parser
reads it: each with its element, its line in the file and a fix; what is not a defect is not one."""

from __future__ import annotations

from pathlib import Path

import mujoco
import pytest

from harness.tools.check.defects import DENSITY_RANGE, MASS_SHARE, find_defects


def defects(tmp_path: Path, name: str, text: str):
    path = tmp_path / name
    path.write_text(text)
    return find_defects(path, mujoco.MjSpec.from_file(str(path)))


def urdf(links: str, joints: str) -> str:
    return f'<?xml version="1.0"?>\n<robot name="r">\n<link name="world"/>\n{links}\n{joints}\n</robot>\n'


def link(name: str, mass: str, ixx: str, iyy: str, izz: str) -> str:
    return (f'<link name="{name}"><inertial><origin xyz="0 0 0"/><mass value="{mass}"/>\n'
            f'<inertia ixx="{ixx}" ixy="0" ixz="0" iyy="{iyy}" iyz="0" izz="{izz}"/></inertial></link>')


def joint(name: str, parent: str, child: str, kind: str = "revolute", limit: str = 'lower="-1" upper="1"') -> str:
    return (f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
            f'<axis xyz="0 0 1"/><limit {limit} effort="1" velocity="1"/></joint>')


ARM = link("arm", "1", "0.01", "0.01", "0.005")   # a 1 kg link of a 0.17 x 0.17 x 0.35 m box: 97 kg/m^3


def test_a_plausible_arm_has_no_defect(tmp_path):
    assert defects(tmp_path, "r.urdf", urdf(ARM, joint("j", "world", "arm"))) == []


def test_a_point_mass_and_round_off_are_not_defects(tmp_path):
    # a sensor frame of 10 g with no rotational inertia; a link whose tiny moments are round-off of zero
    frames = link("imu", "0.01", "0", "0", "0") + link("tip", "0.001", "-1e-20", "1e-20", "0")
    text = urdf(ARM + frames, joint("j", "world", "arm") + joint("f1", "arm", "imu", "fixed", "")
                + joint("f2", "arm", "tip", "fixed", ""))
    assert defects(tmp_path, "r.urdf", text) == []


def test_zero_mass_with_inertia_names_the_mass_line_and_the_body_it_ends_up_in(tmp_path):
    text = urdf(ARM + link("foot", "0", "1e-6", "1e-6", "1e-6"),
                joint("j", "world", "arm") + joint("f", "arm", "foot", "fixed", ""))
    (d,) = defects(tmp_path, "r.urdf", text)
    assert (d.kind, d.element, d.owner, d.fatal) == ("zero mass with inertia", "link 'foot'", "arm", False)
    assert d.line == next(i for i, ln in enumerate(text.splitlines(), 1) if '<link name="foot">' in ln)
    assert d.fix == "give link 'foot' its mass, or set its inertia to zero"


@pytest.mark.parametrize("inertia, kind", [(("-0.01", "0.01", "0.005"), "inertia not positive definite"),
                                           (("0.001", "0.001", "0.005"), "triangle inequality")])
def test_an_impossible_inertia_is_fatal_with_a_fix(tmp_path, inertia, kind):
    (d,) = defects(tmp_path, "r.urdf", urdf(link("arm", "1", *inertia), joint("j", "world", "arm")))
    assert d.kind == kind and d.fatal and d.fix.startswith("recompute link 'arm''s inertia about its centre of mass")


def test_an_implausible_density_counts_where_the_link_weighs_something(tmp_path):
    # 1 kg with a 2.4 mm box's inertia: 7e7 kg/m^3 on the moving link; the same on a 1 g frame is nothing
    lump = link("arm", "1", "1e-6", "1e-6", "1e-6")
    (d,) = defects(tmp_path, "r.urdf", urdf(lump, joint("j", "world", "arm")))
    assert d.kind == "implausible density" and not d.fatal and float(d.brief.split()[0]) > DENSITY_RANGE[1]
    frame = link("cam", f"{MASS_SHARE / 10:g}", "1e-12", "1e-12", "1e-12")
    text = urdf(ARM + frame, joint("j", "world", "arm") + joint("f", "arm", "cam", "fixed", ""))
    assert defects(tmp_path, "r.urdf", text) == []
    # welded to the world, a link moves nothing
    assert defects(tmp_path, "r.urdf", urdf(lump, joint("f", "world", "arm", "fixed", ""))) == []


def test_urdf_limits_that_contradict_the_joint_type(tmp_path):
    text = urdf(ARM + link("a2", "1", "0.01", "0.01", "0.005") + link("a3", "1", "0.01", "0.01", "0.005"),
                joint("j1", "world", "arm", limit="") + joint("j2", "arm", "a2", limit='lower="0" upper="0"')
                + joint("j3", "a2", "a3", "continuous", 'lower="-3" upper="3"'))
    found = {d.joint: d for d in defects(tmp_path, "r.urdf", text)}
    assert found["j1"].kind == "limits missing" and "locked at [0, 0]" in found["j1"].what
    assert found["j2"].kind == "locked range" and found["j2"].fix.startswith("make joint 'j2' fixed")
    assert found["j3"].kind == "limits on a continuous joint" and found["j3"].fix.startswith("drop lower/upper")


def test_an_mjcf_inertial_against_its_geoms_stated_masses(tmp_path):
    text = """<mujoco><worldbody>
  <body name="b" pos="0 0 1"><joint name="h" axis="0 1 0"/>
    <inertial pos="0 0 0" mass="2" diaginertia="0.02 0.02 0.01"/>
    <geom type="sphere" size="0.1" mass="1.5"/></body>
</worldbody></mujoco>"""
    (d,) = defects(tmp_path, "r.xml", text)
    assert (d.kind, d.element, d.line) == ("geom mass and inertial disagree", "body 'b'", 2)
    assert d.brief == "2 kg against 1.5 kg"
    # massless visual geoms beside an explicit inertial are the usual pattern, not a defect
    assert defects(tmp_path, "r.xml", text.replace('mass="1.5"', 'mass="0"')) == []
