"""Drake as a third reader of model files (``harness.tools.loaded_models``: ``load_drake``,
``drake_joint_bodies``, ``drake_joint_details``): what it reads from the scenes' URDFs agrees
with MuJoCo's and Pinocchio's readings; fixed links are merged, a root link is welded or floated,
a file Drake refuses gives one line."""

import numpy as np
import pytest

from harness.model.scene import available_scenes
from harness.engines import load_scene
from harness.tools.check import load_mujoco, load_pinocchio
from harness.tools.check.reading import _zero_qpos
from harness.engines.loaded_models import compare_joint_bodies, mujoco_joint_bodies
from harness.tools.loaded_models import (
    DrakeRefusal,
    drake_gravity,
    drake_joint_bodies,
    drake_joint_details,
    load_drake,
    mujoco_joint_details,
    pinocchio_joint_details,
    pinocchio_joint_slots,
    pinocchio_split_joint_bodies,
)

# harness check adds a free root joint (or none) in every loader; a scene whose URDF needs a
# spherical root (heavy_top) is read by Drake only through the engine, not here
CHECK_ROOTS = {"none": "none", "free": "free"}
SCENES = [n for n in available_scenes() if load_scene(n).urdf_root_joint in CHECK_ROOTS]


def _readings(path, root):
    m, _ = load_mujoco(path, root_joint=root)
    pmodel = load_pinocchio(path, root_joint=root)
    slots = pinocchio_joint_slots(pmodel)
    drake = load_drake(path, root_joint=root)
    return ((mujoco_joint_bodies(m, _zero_qpos(m)), mujoco_joint_details(m)),
            (pinocchio_split_joint_bodies(pmodel, slots), pinocchio_joint_details(pmodel, slots)),
            (drake_joint_bodies(drake), drake_joint_details(drake)))


def _same_details(a, b):
    assert [x.joint for x in a] == [y.joint for y in b]
    for x, y in zip(a, b):
        assert np.allclose(x.point_B, y.point_B, atol=1e-12), (x, y)
        assert (x.limits is None) == (y.limits is None) and (x.limits is None or np.allclose(x.limits, y.limits)), (x, y)
        assert x.damping == pytest.approx(y.damping) if x.damping is not None else y.damping is None


@pytest.mark.parametrize("name", SCENES)
def test_drake_reads_each_scene_urdf_as_mujoco_and_pinocchio_do(name):
    scene = load_scene(name)
    root = CHECK_ROOTS[scene.urdf_root_joint]
    (mj, mj_d), (pn, pn_d), (dr, dr_d) = _readings(scene.urdf, root)
    assert compare_joint_bodies(mj, dr, ("MuJoCo", "Drake")) == []
    assert compare_joint_bodies(pn, dr, ("Pinocchio", "Drake")) == []
    _same_details(mj_d, dr_d)
    _same_details(pn_d, dr_d)


def test_double_pendulum_urdf_in_drake_is_the_files_bodies():
    """The physical facts of the file, as Drake holds them: each bar's mass and the second bar's
    joint on the first bar's axis, one bar length below."""
    scene = load_scene("double_pendulum")
    model = scene.multibody()
    bodies = {x.body: x for x in drake_joint_bodies(scene.urdf)}
    for body in model.bodies:
        x = bodies[body.name]
        assert x.kind == body.joint
        assert x.mass == pytest.approx(body.mass, rel=1e-9)
        assert np.allclose(x.I_Cm_B, body.I_Cm_B, rtol=1e-6, atol=1e-12)
    assert bodies["bar2"].parent == "bar1" and bodies["bar1"].parent == "world"
    assert np.allclose(drake_gravity(load_drake(scene.urdf)), model.gravity_W)


URDF = """<?xml version="1.0"?>
<robot name="arm">
  <link name="base"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 1" rpy="0 0.1 0"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="1" velocity="1"/>
    <dynamics damping="0.1"/></joint>
  <link name="l1"><inertial><origin xyz="0 0 -0.25" rpy="0.2 0 0"/><mass value="1"/>
    <inertia ixx="0.1" ixy="0.01" ixz="0" iyy="0.12" iyz="0.005" izz="0.05"/></inertial></link>
  <joint name="tool" type="fixed"><parent link="l1"/><child link="l1_tool"/><origin xyz="0.1 0 -0.5" rpy="0 0 0.7"/></joint>
  <link name="l1_tool"><inertial><origin xyz="0.02 0 0"/><mass value="0.5"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.015"/></inertial></link>
</robot>
"""


def test_fixed_links_merged_into_the_moving_body(tmp_path):
    """A URDF fixed joint is a weld in Drake: the welded link's mass joins the joint's body (1 kg +
    0.5 kg in the file), as Pinocchio and MuJoCo (fusestatic) merge it; the root link is welded
    to the world, so the revolute joint is the only moving one."""
    path = tmp_path / "arm.urdf"
    path.write_text(URDF)
    (mj, _), (pn, _), (dr, _) = _readings(path, "none")
    assert [(x.joint, x.kind) for x in dr] == [("j1", "hinge")]
    assert dr[0].mass == pytest.approx(1.5)
    assert compare_joint_bodies(mj, dr, ("MuJoCo", "Drake")) == []
    assert compare_joint_bodies(pn, dr, ("Pinocchio", "Drake")) == []
    assert any("welded to the world" in n and "base" in n for n in load_drake(path).notes)


def test_floating_root_link_is_named_root_joint(tmp_path):
    path = tmp_path / "arm.urdf"
    path.write_text(URDF.replace('<link name="base"/>', '<link name="base"><inertial><mass value="2"/>'
                                 '<inertia ixx="0.2" ixy="0" ixz="0" iyy="0.3" iyz="0" izz="0.25"/></inertial></link>'))
    (mj, _), (pn, _), (dr, _) = _readings(path, "free")
    assert {x.joint: (x.body, x.kind) for x in dr}["root_joint"] == ("base", "free")
    assert compare_joint_bodies(mj, dr, ("MuJoCo", "Drake")) == []


def test_a_body_with_several_joints_is_reported_as_mujoco_reports_it(tmp_path):
    """Drake's MJCF parser gives a body with several joints a chain of massless bodies: each of
    its joints names the real body, the last carries the mass (1 kg in the file)."""
    path = tmp_path / "slider.xml"
    path.write_text("""<mujoco model="slider"><worldbody>
      <body name="box" pos="0 0 1">
        <joint name="x" type="slide" axis="1 0 0"/><joint name="z" type="slide" axis="0 0 1"/>
        <joint name="pitch" type="hinge" axis="0 1 0"/>
        <geom type="box" size=".1 .2 .3" mass="1"/>
      </body></worldbody></mujoco>""")
    m, _ = load_mujoco(path)
    dr = drake_joint_bodies(path)
    assert [(x.joint, x.body) for x in dr] == [("x", "box"), ("z", "box"), ("pitch", "box")]
    assert [x.mass for x in dr] == [0.0, 0.0, pytest.approx(1.0)]
    assert compare_joint_bodies(mujoco_joint_bodies(m, _zero_qpos(m)), dr, ("MuJoCo", "Drake")) == []


def test_a_file_drake_refuses_is_one_line(tmp_path):
    """Drake's MJCF parser needs a model name: an MJCF without one is refused with Drake's reason,
    one line, the file named by its name only."""
    path = tmp_path / "nameless.xml"
    path.write_text('<mujoco><worldbody><body name="a"><joint name="h" axis="0 1 0"/>'
                    '<geom size=".1" mass="1"/></body></worldbody></mujoco>')
    with pytest.raises(DrakeRefusal) as err:
        load_drake(path)
    reason = str(err.value)
    assert reason and "\n" not in reason and str(tmp_path) not in reason
