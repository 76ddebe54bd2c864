"""A Multibody read from a model file as MuJoCo compiles it (harness.model.from_model_file): the
builders' own systems rebuilt from their scenes' MJCF and URDF, the harness's frame and joint
conventions against MuJoCo's and Pinocchio's kinematics, the refusals, and the parameter mapping
of a scene without code."""

from __future__ import annotations

import mujoco
import numpy as np
import pinocchio as pin
import pytest

from harness.model import rotations
from harness.model.errors import InputError
from harness.model.from_model_file import (TARGETS, apply_parameters, parse_target, read_model_file, zero_state)
from harness.model.joints import JOINTS, ROTATIONAL
from harness.model.kinematics import forward
from harness.model.scene import MODELS_DIR, Parameter, available_scenes
from harness.engines import load_scene
from harness.engines.loaded_models import LoadedBody, body_discrepancies

TREES = [s for s in available_scenes() if not load_scene(s).multibody().loops]
LOOPS = [s for s in available_scenes() if load_scene(s).multibody().loops]


def _as_loaded(model) -> list[LoadedBody]:
    return [LoadedBody(b.name, b.mass, b.p_BCm_B, b.I_Cm_B, b.p_PB_P, b.joint, b.axis_B) for b in model.bodies]


@pytest.mark.parametrize("fmt", ["mjcf", "urdf"])
@pytest.mark.parametrize("name", TREES)
def test_a_scene_file_rebuilds_its_builders_multibody(name, fmt):
    """Mass, centre of mass, inertia, joint placement, kind and axis of every body, and each
    parent, read from the scene's own MJCF and URDF (MuJoCo's URDF import, with the scene's
    root joint) match what its builder states (the files carry rounded decimals: 1e-6)."""
    scene = load_scene(name)
    want = scene.multibody()
    path = scene.mjcf if fmt == "mjcf" else scene.urdf
    got = read_model_file(path, root_joint=scene.urdf_root_joint).multibody
    assert [b.name for b in got.bodies] == want.body_names
    assert [b.parent for b in got.bodies] == [b.parent for b in want.bodies]
    bad = [d.message for d in body_discrepancies(_as_loaded(got), want, rtol=1e-6) if not d.passed]
    assert bad == []
    if fmt == "mjcf":  # a URDF states no gravity (MuJoCo's default then)
        assert np.allclose(got.gravity_W, want.gravity_W, rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", LOOPS)
def test_a_closed_loop_is_refused_naming_its_equalities(name):
    scene = load_scene(name)
    with pytest.raises(InputError, match=r"equality constraint\(s\) .* closed loop") as err:
        read_model_file(scene.mjcf)
    assert "\n" not in str(err.value) and str(scene.mjcf) in str(err.value)


# A free root carrying a rotated, offset hinge with a ref, then a ball joint in a rotated body,
# then a slide with a ref: every frame of the file differs from the harness's.
SPATIAL = """<mujoco model="spatial">
  <compiler angle="radian"/>
  <option gravity="0.3 -0.2 -9.7"/>
  <worldbody>
    <body name="base" pos="0.1 0.2 1.0" quat="0.9 0.1 0.3 -0.2">
      <freejoint name="float"/>
      <inertial pos="0.01 0.02 -0.03" quat="0.8 0.2 0.1 0.3" mass="2" diaginertia="0.1 0.2 0.25"/>
      <body name="arm" pos="0.2 0 0.1" quat="0.7 0.7 0 0.2">
        <joint name="shoulder" type="hinge" axis="0.3 1 0.2" pos="0.05 0 0.02" ref="0.2"/>
        <inertial pos="0 0.1 0.01" mass="0.7" fullinertia="0.02 0.03 0.025 0.001 -0.002 0.0005"/>
        <body name="fore" pos="0 0.3 0" euler="0.3 -0.2 0.5">
          <joint name="wrist" type="ball" pos="0 0.01 0.02"/>
          <inertial pos="0.02 0.05 0" quat="0.6 0 0.8 0" mass="0.4" diaginertia="0.004 0.005 0.006"/>
          <body name="tip" pos="0 0.2 0.05" quat="0.5 0.5 0.5 0.5">
            <joint name="slider" type="slide" axis="1 0.2 0" pos="0.01 0 0" ref="0.05"/>
            <inertial pos="0.03 0 0" mass="0.2" diaginertia="0.001 0.0012 0.0015"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <keyframe>
    <key name="moving" qpos="0.3 -0.1 0.8 0.8 0.3 -0.2 0.4  0.7  0.9 0.2 -0.3 0.1  0.12"
         qvel="0.4 -0.3 0.2 1.1 -0.7 0.5  2.0  -1.2 0.6 0.9  0.3"/>
  </keyframe>
</mujoco>
"""


def _mujoco_at(m, qpos, qvel):
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = qpos, qvel
    mujoco.mj_forward(m, d)
    return d


@pytest.mark.parametrize("initial", ["moving", "qpos0", "zero"])
def test_frames_and_joint_coordinates_follow_mujocos_kinematics(tmp_path, initial):
    """The harness's forward kinematics of what was read, at the initial state read, puts every
    centre of mass, orientation (file frame = harness frame x the rotation read), inertia in
    world, centre-of-mass velocity and angular velocity where MuJoCo's own kinematics puts them,
    for free, hinge, ball and slide joints whose file frames are rotated and offset, with refs."""
    path = tmp_path / "spatial.xml"
    path.write_text(SPATIAL)
    mf = read_model_file(path, initial=initial)
    model, m = mf.multibody, mf.model
    assert [b.joint for b in model.bodies] == ["free", "hinge", "ball", "slide"]
    if initial == "moving":
        qpos, qvel = m.key_qpos[0], m.key_qvel[0]
    elif initial == "qpos0":
        qpos, qvel = m.qpos0, np.zeros(m.nv)
    else:  # harness zero: the free body at the origin, hinge and slide at their ref, the ball at identity
        qpos, qvel = m.qpos0.copy(), np.zeros(m.nv)
        qpos[:7] = [0, 0, 0, 1, 0, 0, 0]
    d = _mujoco_at(m, qpos, qvel)
    states = forward(model, model.q0, model.v0)
    for body in model.bodies:
        b = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, body.name)
        s = states[body.name]
        R = rotations.matrix(s.quat_WB)
        assert np.allclose(s.p_WCm_W, d.xipos[b], atol=1e-12), body.name
        assert np.allclose(R @ mf.rotations[body.name], d.xmat[b].reshape(3, 3), atol=1e-12), body.name
        R_I = d.ximat[b].reshape(3, 3)
        assert np.allclose(R @ body.I_Cm_B @ R.T, R_I @ np.diag(m.body_inertia[b]) @ R_I.T, atol=1e-14), body.name
        vel = np.zeros(6)
        mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, b, vel, 0)  # at the centre of mass, world
        assert np.allclose(s.w_WB_W, vel[:3], atol=1e-12) and np.allclose(s.v_WCm_W, vel[3:], atol=1e-12), body.name
    assert np.allclose(model.gravity_W, [0.3, -0.2, -9.7])
    assert mf.keyframes == ("moving",) and mf.joints == {"float": "base", "shoulder": "arm", "wrist": "fore",
                                                         "slider": "tip"}
    assert set(mf.frame_notes) == {"arm", "fore", "tip"}  # the free body's frame is the file's


def test_zero_state_has_the_identity_where_a_joint_has_a_quaternion():
    for jt in JOINTS.values():
        q, v = zero_state(jt)
        assert q.shape == (jt.nq,) and v.shape == (jt.nv,) and not v.any()
        assert q.sum() == (1.0 if jt.quat_at is not None else 0.0)


URDF = """<?xml version="1.0"?>
<robot name="bent">
  <link name="world"/>
  <joint name="j1" type="revolute">
    <parent link="world"/><child link="l1"/>
    <origin xyz="0 0 0.5" rpy="0.3 0 0.2"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/>
  </joint>
  <link name="l1">
    <inertial><origin xyz="0.1 0 -0.2" rpy="0.4 0.1 0"/><mass value="1.5"/>
      <inertia ixx="0.03" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.015"/></inertial>
  </link>
  <joint name="tool_mount" type="fixed">
    <parent link="l1"/><child link="tool"/><origin xyz="0 0.1 -0.4" rpy="0 0.5 0"/>
  </joint>
  <link name="tool">
    <inertial><origin xyz="0 0 0.05" rpy="0 0 0"/><mass value="0.3"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.0015"/></inertial>
  </link>
  <joint name="j2" type="prismatic">
    <parent link="tool"/><child link="l2"/>
    <origin xyz="0.05 0 0.1" rpy="0 0 -0.6"/><axis xyz="1 0 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <link name="l2">
    <inertial><origin xyz="0 0.02 0" rpy="0 0 0"/><mass value="0.5"/>
      <inertia ixx="0.002" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.003"/></inertial>
  </link>
</robot>
"""


def test_a_urdf_through_mujoco_agrees_with_pinocchio(tmp_path):
    """A URDF with rotated joint origins and inertial frames and a link on a fixed joint, read
    through MuJoCo's importer (which merges the fixed link into its parent: fusestatic): each
    moving body's mass, centre of mass and inertia in world and joint axis in world, at zero
    configuration, equal Pinocchio's reading of the same file (its own merge of the fixed link)."""
    path = tmp_path / "bent.urdf"
    path.write_text(URDF)
    mf = read_model_file(path)
    model = mf.multibody
    assert mf.format == "URDF" and model.body_names == ["l1", "l2"] and model.body("l1").mass == pytest.approx(1.8)
    assert model.body("l2").parent == "l1" and mf.joints == {"j1": "l1", "j2": "l2"}
    states = forward(model, model.q0, model.v0)
    pm = pin.buildModelFromUrdf(str(path))
    pd = pm.createData()
    pin.computeJointJacobians(pm, pd, pin.neutral(pm))  # and the joints' placements (oMi)
    for body in model.bodies:
        jid = pm.getJointId(next(j for j, b in mf.joints.items() if b == body.name))
        oMi, inertia = pd.oMi[jid], pm.inertias[jid]
        R = rotations.matrix(states[body.name].quat_WB)
        assert inertia.mass == pytest.approx(body.mass, rel=1e-12)
        assert np.allclose(oMi.act(inertia.lever), states[body.name].p_WCm_W, atol=1e-12)
        assert np.allclose(oMi.rotation @ inertia.inertia @ oMi.rotation.T, R @ body.I_Cm_B @ R.T, atol=1e-12)
        S = pin.getJointJacobian(pm, pd, jid, pin.ReferenceFrame.WORLD)[:, pm.joints[jid].idx_v]
        along = S[3:] if JOINTS[body.joint].axis == ROTATIONAL else S[:3]  # a slide's column is its direction
        assert np.allclose(along / np.linalg.norm(along), R @ body.axis_B, atol=1e-12), body.name


MJCF_HEAD = '<mujoco><compiler angle="radian"/><worldbody>'
MJCF_TAIL = "</worldbody></mujoco>"


@pytest.mark.parametrize("body,fragment", [
    ('<body name="a"><joint type="hinge"/><joint name="twist" type="hinge" axis="1 0 0"/><geom size="0.1"/></body>',
     "body 'a' has 2 joints (#0, twist): the harness gives every body one joint (free, ball, hinge, slide)"),
    ('<body name="a"><joint type="hinge"/><geom size="0.1"/><body name="tool" pos="0 0 -1"><geom size="0.1"/></body></body>',
     "body 'tool' (child of 'a') has no joint"),
    ('<body><joint type="hinge"/><geom size="0.1"/></body>', "body #1 (child of the world) has no name"),
    ('<body name="a"><joint type="hinge"/><geom size="0.1"/></body><body name="b" mocap="true"/>', "body 'b'"),
])
def test_what_the_harness_cannot_state_is_one_line(tmp_path, body, fragment):
    path = tmp_path / "bad.xml"
    path.write_text(MJCF_HEAD + body + MJCF_TAIL)
    with pytest.raises(InputError) as err:
        read_model_file(path)
    message = str(err.value)
    assert message.startswith(f"{path}: ") and fragment in message and "\n" not in message, message


def test_a_fixed_child_is_merged_when_mujoco_fuses_it(tmp_path):
    path = tmp_path / "tool.xml"
    path.write_text(MJCF_HEAD + '<body name="a"><joint type="hinge"/><inertial pos="0 0 -0.5" mass="1" diaginertia="1 1 1"/>'
                    '<body name="tool" pos="0 0 -1"><inertial pos="0 0 0" mass="3" diaginertia="1 1 1"/></body></body>'
                    + MJCF_TAIL)
    a = read_model_file(path, fuse_static=True).multibody.body("a")
    assert a.mass == 4.0 and np.allclose(a.p_BCm_B, [0, 0, -0.875])


@pytest.mark.parametrize("text,initial,fragment", [
    (None, "zero", "MJCF file not found"),
    ("<mujoco><worldbody><body", "zero", "cannot load MJCF"),
    (MJCF_HEAD + '<body name="a"><joint type="hinge"/><geom size="0.1"/></body>' + MJCF_TAIL, "start",
     "no keyframe named 'start' for the initial state (known: zero, qpos0)"),
])
def test_missing_or_broken_files_are_one_line(tmp_path, text, initial, fragment):
    path = tmp_path / "m.xml"
    if text is not None:
        path.write_text(text)
    with pytest.raises(InputError) as err:
        read_model_file(path, initial=initial)
    assert fragment in str(err.value) and "\n" not in str(err.value), str(err.value)


# --------------------------------------------------------------------------- the parameter mapping


def test_targets_parse_and_reject():
    assert parse_target("gravity") == ("gravity", "", "")
    assert parse_target("body.link.1.mass") == ("body", "link.1", "mass")  # a name may hold dots
    assert parse_target("joint.hinge3.v0") == ("joint", "hinge3", "v0")
    assert {parse_target(t.replace("<body>", "b").replace("<joint>", "j"))[2] for t in TARGETS} == \
        {"", "mass", "com", "inertia", "q0", "v0"}
    for bad in ("body.link1.colour", "link1.mass", "body..mass", "joint.hinge1.mass", "gravity.z"):
        with pytest.raises(ValueError, match="is not one of"):
            parse_target(bad)


def _param(name, value, sets, unit=""):
    return Parameter(name, value, unit, "real", "", sets)


def test_parameters_land_where_they_say():
    scene = load_scene("three_link_chain")
    mf = read_model_file(scene.mjcf)
    model = apply_parameters(mf, [
        _param("m", 2.5, "body.link2.mass", "kg"), _param("c", (0.01, 0.0, -0.3), "body.link1.com", "m"),
        _param("I", (0.2, 0.3, 0.4), "body.link3.inertia", "kg*m^2"), _param("g", 3.0, "gravity", "m/s^2"),
        _param("q", 0.7, "joint.hinge2.q0", "rad"), _param("w", -1.5, "joint.hinge3.v0", "rad/s"),
    ], MODELS_DIR / "x.toml")
    assert model.body("link2").mass == 2.5 and np.allclose(model.body("link1").p_BCm_B, [0.01, 0, -0.3])
    assert np.array_equal(model.body("link3").I_Cm_B, np.diag([0.2, 0.3, 0.4]))
    assert np.array_equal(model.gravity_W, [0, 0, -3.0]) and model.q0["link2"][0] == 0.7 and model.v0["link3"][0] == -1.5
    assert model.q0["link1"][0] == 0.0 and mf.multibody.body("link2").mass == 0.8  # the rest as read; mf unchanged
    vec = apply_parameters(mf, [_param("g", (0.1, 0.0, -9.0), "gravity")], MODELS_DIR / "x.toml")
    assert np.array_equal(vec.gravity_W, [0.1, 0.0, -9.0])


@pytest.mark.parametrize("param,fragment", [
    (("m", 1.0, "body.link9.mass"), "sets 'body.link9.mass': three_link_chain.xml has no body 'link9' "
                                    "(bodies: link1, link2, link3)"),
    (("q", 1.0, "joint.elbow.q0"), "has no joint 'elbow' (joints: hinge1, hinge2, hinge3)"),
    (("m", (1.0, 2.0, 3.0), "body.link1.mass"), "which takes 1 number(s), got 3"),
    (("m", 1.0, "body.link1.mass", "g"), "unit 'g', but body.link1.mass is in kg"),
    (("q", 10.0, "joint.hinge1.q0", "deg"), "unit 'deg', but joint.hinge1.q0 is in rad"),
])
def test_a_mapping_the_file_cannot_take_is_one_line(param, fragment):
    mf = read_model_file(load_scene("three_link_chain").mjcf)
    with pytest.raises(InputError) as err:
        apply_parameters(mf, [_param(*param)], MODELS_DIR / "x.toml")
    assert fragment in str(err.value) and "\n" not in str(err.value), str(err.value)


def test_a_missing_mjcf_is_refused_unless_the_scene_names_only_a_urdf(tmp_path):
    """A scene without code that names an MJCF reads that MJCF: when it is missing, one line
    naming it, never a silent read of the URDF beside it; a scene that names only its URDF
    reads the URDF (its declared file)."""
    import shutil

    from harness.model.scene import model_file_of

    folder = tmp_path / "models" / "my_chain"
    shutil.copytree(MODELS_DIR / "three_link_chain", folder)
    toml = folder / "scene.toml"
    toml.write_text(toml.read_text().replace('name = "three_link_chain"', 'name = "my_chain"'))
    (folder / "three_link_chain.xml").unlink()
    with pytest.raises(InputError) as err:
        load_scene("my_chain", models_dir=tmp_path / "models").multibody()
    message = str(err.value)
    assert "its MJCF three_link_chain.xml is not in" in message and "\n" not in message, message
    toml.write_text(toml.read_text().replace('mjcf = "three_link_chain.xml"\n', ""))
    scene = load_scene("my_chain", models_dir=tmp_path / "models")
    assert scene.model_files == ("urdf",)
    assert model_file_of(scene) == folder / "three_link_chain.urdf"
    assert [b.name for b in scene.multibody().bodies] == [b.name for b in load_scene("three_link_chain").multibody().bodies]
