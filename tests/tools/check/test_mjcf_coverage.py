"""``harness check`` on MJCF beyond plain trees: geometry stripped for every loader, keyframes,
bodies with several joints, what is not compared, the supported-joint message, joint maps.

MuJoCo's own test model (``mujoco/testdata/model.xml``, shipped in the mujoco wheel) has a height
field, a mesh, textures and a material, a keyframe, three bodies with two hinges each, a ball
joint, unnamed bodies and joints, six kinematic trees, an equality, two tendons and ten actuators;
the small models written here have one of each, so that every behaviour is also pinned on a file
whose numbers the test can state.
"""

from pathlib import Path

import mujoco
import pytest

from harness.cli.main import main
from harness.model.errors import InputError
from harness.tools.check import (parse_map_options, read_joint_map, render_report, run_check, summary_lines,
                                 supported_joints)

MODEL_XML = Path(mujoco.__file__).parent / "testdata" / "model.xml"
FAST = {"n_states": 2, "n_free": 1, "t_end": 0.05}
FAST_CLI = ["--states", "2", "--free-runs", "1", "--t-end", "0.05"]

ROBOT = """<mujoco model="robot">
  <compiler angle="radian"/>
  <asset>
    <hfield name="terrain" nrow="3" ncol="3" size="1 1 0.1 0.1" elevation="0 1 0 1 0 1 0 1 0"/>
    <mesh name="tetra" vertex="0 0 0  0.1 0 0  0 0.1 0  0 0 0.1"/>
    <texture name="grid" type="2d" builtin="checker" width="8" height="8" rgb1="1 1 1" rgb2="0 0 0"/>
    <material name="grid" texture="grid"/>
  </asset>
  <worldbody>
    <geom type="hfield" hfield="terrain"/>
    <body name="base" pos="0 0 1">
      <geom type="box" size="0.1 0.1 0.05" density="1000" material="grid"/>
      <site name="tip" pos="0 0 0.1" material="grid"/>
      <body name="link1" pos="0.1 0 0" euler="0 0 0.3">
        <joint name="hip_z" axis="0 0 1"/>
        <joint name="hip_y" axis="0 1 0" pos="0.02 0 0"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
        <body name="link2" pos="0.3 0 0">
          <joint name="knee" axis="0 1 0" range="-2 2"/>
          <inertial pos="0.1 0 0" mass="0.5" diaginertia="0.001 0.004 0.004"/>
          <geom type="mesh" mesh="tetra"/>
          <geom name="probe" type="sphere" size="0.01" mass="0.01"/>
        </body>
      </body>
    </body>
  </worldbody>
  <equality><joint name="couple" joint1="knee" joint2="hip_y" polycoef="0 0.5 0 0 0"/></equality>
  <actuator><motor name="knee_motor" joint="knee" gear="20"/></actuator>
  <sensor><framepos objtype="geom" objname="probe"/></sensor>
  <keyframe><key name="bent" qpos="0.1 0.2 -0.3"/></keyframe>
</mujoco>
"""

ARM_MJCF = """<mujoco model="arm">
  <compiler angle="radian"/>
  <worldbody>
    <body name="upper" pos="0 0 1">
      <joint name="shoulder" axis="0 1 0"/>
      <inertial pos="0 0 -0.25" mass="1" diaginertia="0.02 0.02 0.001"/>
      <body name="lower" pos="0 0 -0.5">
        <joint name="elbow" axis="1 0 0"/>
        <inertial pos="0 0 -0.2" mass="0.5" diaginertia="0.005 0.006 0.002"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

ARM_URDF = """<?xml version="1.0"?>
<robot name="arm">
  <link name="base"/>
  <joint name="j1" type="continuous"><parent link="base"/><child link="l1"/><origin xyz="0 0 1"/><axis xyz="0 1 0"/></joint>
  <link name="l1"><inertial><origin xyz="0 0 -0.25"/><mass value="1"/>
    <inertia ixx="0.02" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.001"/></inertial></link>
  <joint name="j2" type="continuous"><parent link="l1"/><child link="l2"/><origin xyz="0 0 -0.5"/><axis xyz="1 0 0"/></joint>
  <link name="l2"><inertial><origin xyz="0 0 -0.2"/><mass value="0.5"/>
    <inertia ixx="0.005" ixy="0" ixz="0" iyy="0.006" iyz="0" izz="0.002"/></inertial></link>
</robot>
"""


def run(args, capsys):
    code = main(args)
    out = capsys.readouterr()
    return code, out.out, out.err


def one_error_line(code, out, err) -> str:
    assert code == 2, out + err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("harness: error:") and "Traceback" not in err, err
    return lines[0]


def copy_line(res, fragment: str) -> str:
    lines = [c for c in res.copies if fragment in c]
    assert len(lines) == 1, res.copies
    return lines[0]


def joint_body(res, loader: str, joint: str):
    return next(x for x in res.readings[loader].bodies if x.joint == joint)


@pytest.fixture(scope="module")
def testdata_model():
    if not MODEL_XML.is_file():
        pytest.skip("mujoco's testdata/model.xml is not installed with this mujoco")
    return MODEL_XML


@pytest.fixture(scope="module")
def stripped_testdata(testdata_model):
    return run_check(testdata_model, None, strip=True, **FAST)


def test_testdata_model_stripped_loads_in_every_loader(stripped_testdata):
    res = stripped_testdata
    assert [r.loader for r in res.readings.values() if r.loaded] == ["MuJoCo", "Pinocchio", "Drake"], res.refusals
    stripped = copy_line(res, "geometry stripped")
    for part in ("copy of model.xml that every loader reads", "18 geoms", "1 mesh", "1 height field", "2 textures",
                 "1 material", "1 tendon wrap around a geom"):
        assert part in stripped, stripped
    # Every mass there comes from geom density: kept, as MuJoCo compiles them with the geometry.
    assert "the 13 body(ies) whose mass MuJoCo derives from their geoms keep it" in stripped
    full = mujoco.MjModel.from_xml_path(str(MODEL_XML))
    head = mujoco.mj_name2id(full, mujoco.mjtObj.mjOBJ_BODY, "head")
    for loader in ("MuJoCo", "Pinocchio", "Drake"):
        assert joint_body(res, loader, "joint0").mass == pytest.approx(full.body_mass[head], rel=1e-12)
    assert "10 unnamed body(ies) and 6 unnamed joint(s)" in copy_line(res, "unnamed")
    assert "(they do not fit its reading: nq 19, MuJoCo's 49)" in copy_line(res, "Pinocchio refuses the file's keyframes")
    assert "names the model 'model'" in copy_line(res, "names the model")
    report = render_report(res, "harness check")
    assert "What the loaders read differs from the file(s)" in report and "1 height field" in report


def test_testdata_model_several_joints_ball_and_trees(stripped_testdata):
    """Three bodies with two hinges each and a ball joint: Pinocchio's composite joints split back,
    dynamics and free motion against MuJoCo on the one tree Pinocchio's MJCF parser reads;
    Drake's first joint of each such body named at the parent's origin."""
    res = stripped_testdata
    slots = res.readings["Pinocchio"].slots
    assert slots["hipz_0"].jid == slots["hipy_0"].jid and slots["hipz_0"].sub == 0 and slots["hipy_0"].sub == 1
    assert len({slots[f"hipz_{k}"].jid for k in range(3)}) == 3
    assert joint_body(res, "Pinocchio", "wheel_0").kind == "ball"
    assert res.readings["Pinocchio"].partial == ["slider", "joint11", "joint12", "joint13", "joint14", "joint15"]
    assert any("reads only the first body under <worldbody> ('head')" in n for n in res.notes)
    pairs = {(d.a, d.b): d for d in res.dynamics}
    assert {d.term for d in res.dynamics if (d.a, d.b) == ("MuJoCo", "Pinocchio") and d.passed} == {"M", "bias", "gravity"}
    assert all(d.max_rel < 1e-12 for d in pairs.values())
    assert "ball joints (wheel_0)" in res.readings["Drake"].dynamics
    assert len(res.free) == 1 and res.free_passed, res.free
    several = [f for f in res.findings if f.kind == "several joints"]
    assert [f.joint for f in several] == ["hipz_0", "hipz_1", "hipz_2"]
    assert "Drake puts the first of the body's 2 joints (hipz_0, hipy_0) at the origin of the parent body 'head'" \
        in several[0].text


def test_testdata_model_lists_what_is_not_compared(stripped_testdata):
    res = stripped_testdata
    assert res.not_compared[0] == "1 equality constraint: weld world-cylinder"
    assert res.not_compared[1] == "2 tendons: spatial (spatial), fixed (fixed)"
    assert res.not_compared[2].startswith("10 actuators: actuator0 (tendon fixed, gear 100)")
    assert "actuator7 (site wheel_0, gear [0 0 0 0 10 0])" in res.not_compared[2]
    report = render_report(res, "harness check")
    section = report.split("### Not compared")[1].split("Importer differences")[0]
    assert "- 1 equality constraint" in section and "- 2 tendons" in section and "- 10 actuators" in section
    assert any(line.startswith("  not compared: 1 equality constraint: weld world-cylinder, 2 tendons")
               for line in summary_lines(res))
    uncompared = {u.what: u.why for u in res.classes.uncompared}
    assert uncompared["2 tendons: spatial (spatial), fixed (fixed)"] == "only MuJoCo reads tendons"


def test_testdata_model_unstripped_points_to_the_option(testdata_model, tmp_path, capsys):
    code, out, err = run(["check", "--mjcf", str(testdata_model), "--out-dir", str(tmp_path), *FAST_CLI], capsys)
    assert code in (0, 1), out + err
    out = " ".join(out.split())
    assert "Pinocchio: does not load: cannot load the MJCF: hfields are not supported yet " \
           "(--strip-geometry removes the geometry)" in out
    assert "Drake: does not load" not in out
    report = (tmp_path / "check_model.md").read_text()
    assert "- Drake's dynamics terms: Drake's ball joints (wheel_0)" in report
    assert "it does not load the file: cannot load the MJCF: hfields are not supported yet" in report
    assert "(known: pinocchio-mjcf-hfield-refused;" in report


@pytest.fixture
def robot(tmp_path) -> Path:
    path = tmp_path / "robot.xml"
    path.write_text(ROBOT)
    return path


def test_small_model_stripped_for_every_loader_masses_kept(robot, tmp_path, capsys):
    code, out, err = run(["check", "--mjcf", str(robot), "--strip-geometry", "--out-dir", str(tmp_path / "r"),
                          *FAST_CLI], capsys)
    assert code in (0, 1), out + err   # Pinocchio drops the fixed root body's pose; Drake misplaces hip_z
    report = (tmp_path / "r" / "check_robot.md").read_text()
    for part in ("5 geoms", "1 mesh", "1 height field", "1 texture", "1 material", "1 sensor on a geom",
                 "the 2 body(ies) whose mass MuJoCo derives from their geoms keep it"):
        assert part in report, part
    assert "- 1 equality constraint: couple: joint knee-hip_y" in report
    assert "- 1 actuator: knee_motor (joint knee, gear 20)" in report
    assert "Composite_hip_z" in report and "Drake puts the first of the body's 2 joints (hip_z, hip_y)" in report
    res = run_check(robot, None, strip=True, **FAST)
    full = mujoco.MjModel.from_xml_path(str(robot))
    link1 = mujoco.mj_name2id(full, mujoco.mjtObj.mjOBJ_BODY, "link1")
    for loader in ("MuJoCo", "Pinocchio", "Drake"):   # the capsule's mass, computed with the geometry
        assert joint_body(res, loader, "hip_y").mass == pytest.approx(full.body_mass[link1], rel=1e-12)
    code, out, _ = run(["check", "--mjcf", str(robot), "--out-dir", str(tmp_path / "r2"), *FAST_CLI], capsys)
    assert "hfields are not supported yet (--strip-geometry removes the geometry)" in out


def test_small_model_floating_drops_the_keyframe_and_compares(robot):
    """A root joint added to a jointless root body: the keyframe's qpos (3) no longer fits (nq 10);
    it is dropped from every loader's reading, and MuJoCo and Pinocchio agree on the two-hinge
    body, in the dynamics terms and in free motion."""
    res = run_check(robot, None, strip=True, floating_base=True, **FAST)
    for where in ("MuJoCo's reading", "Pinocchio's and Drake's copy"):
        line = copy_line(res, f"dropped from {where}")
        assert "'bent' (qpos has 3 numbers, the model's nq is 10)" in line and "does not use keyframes" in line
    assert all(d.passed for d in res.dynamics if (d.a, d.b) == ("MuJoCo", "Pinocchio"))
    assert res.free_passed and len(res.free) == 1
    assert {v.odd for v in res.votes if not v.agree and v.counted} == {"Drake"}
    assert [f.kind for f in res.findings] == ["several joints"]


def test_masses_lost_with_the_geometry_are_named(tmp_path, capsys):
    """A mesh file that is missing: MuJoCo cannot compute the geom masses before stripping, so a
    body whose mass came from its geoms has none; a moving one is bad input (one line saying
    why), a static one is named in the note."""
    mesh = '<asset><mesh name="m" file="gone.stl"/></asset>'
    moving = tmp_path / "moving.xml"
    moving.write_text(f"""<mujoco model="moving">{mesh}<worldbody><body name="arm" pos="0 0 1">
      <joint name="j" axis="0 1 0"/><geom type="mesh" mesh="m"/></body></worldbody></mujoco>""")
    line = one_error_line(*run(["check", "--mjcf", str(moving), "--strip-geometry", "--out-dir", str(tmp_path / "r")],
                               capsys))
    assert str(moving) in line and "could not compile the geometry (Error opening file 'gone.stl')" in line
    assert "have none once it is stripped" in line and "line " not in line.split("MJCF:")[1]
    static = tmp_path / "static.xml"
    static.write_text(f"""<mujoco model="static">{mesh}<worldbody><body name="arm" pos="0 0 1">
      <joint name="j" axis="0 1 0"/><inertial pos="0 0 -0.25" mass="1" diaginertia="0.02 0.02 0.001"/>
      <body name="deco"><geom type="mesh" mesh="m"/></body></body></worldbody></mujoco>""")
    res = run_check(static, None, strip=True, **FAST)
    assert res.passed
    assert "so the 1 body(ies) whose mass it derives from their geoms have none once it is stripped: deco" \
        in copy_line(res, "geometry stripped")


def test_a_copy_keeps_includes_and_mesh_folders(tmp_path):
    """Unnamed bodies and joints make the loaders read a copy (named after MuJoCo's numbering) in
    another folder: its <include> is inlined and its mesh folder made absolute."""
    (tmp_path / "meshes").mkdir()
    (tmp_path / "parts").mkdir()
    (tmp_path / "meshes" / "tetra.obj").write_text("v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\n"
                                                   "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
    (tmp_path / "parts" / "arm.xml").write_text("""<mujoco><worldbody><body pos="0 0 1"><joint axis="0 1 0"/>
      <inertial pos="0 0 -0.2" mass="1" diaginertia="0.02 0.02 0.001"/>
      <geom type="mesh" mesh="tetra" mass="0"/></body></worldbody></mujoco>""")
    path = tmp_path / "rel.xml"
    path.write_text('<mujoco model="rel"><compiler meshdir="meshes"/><asset><mesh name="tetra" file="tetra.obj"/>'
                    '</asset><include file="parts/arm.xml"/></mujoco>')
    res = run_check(path, None, **FAST)
    assert "1 unnamed body(ies) and 1 unnamed joint(s)" in copy_line(res, "unnamed")
    assert [x.joint for x in res.readings["Pinocchio"].bodies] == ["joint0"]
    assert res.passed, res.model_problems


def test_the_supported_joint_message_lists_what_works(tmp_path, capsys):
    text = supported_joints()
    for kind in ("free", "ball", "hinge", "slide", "several on one body", "revolute", "continuous", "prismatic", "fixed"):
        assert kind in text
    path = tmp_path / "planar.urdf"
    path.write_text(ARM_URDF.replace('type="continuous"', 'type="planar"', 1))
    _, out, _ = run(["check", "--urdf", str(path), "--out-dir", str(tmp_path / "r")], capsys)
    out = " ".join(out.split())
    assert "Pinocchio: does not load: joint 'j1' of type planar cannot be compared between engines (supported: MJCF " \
           "free, ball, hinge and slide joints, several on one body too;" in out


@pytest.fixture
def arm_pair(tmp_path) -> tuple[Path, Path]:
    mjcf, urdf = tmp_path / "arm.xml", tmp_path / "arm.urdf"
    mjcf.write_text(ARM_MJCF)
    urdf.write_text(ARM_URDF)
    return mjcf, urdf


def test_joint_map_options_and_files(arm_pair, tmp_path, capsys):
    mjcf, urdf = arm_pair
    base = ["check", "--mjcf", str(mjcf), "--urdf", str(urdf), *FAST_CLI]
    code, out, _ = run(base + ["--out-dir", str(tmp_path / "none")], capsys)
    assert code == 1 and "joint 'shoulder' (body 'upper'): MJCF and URDF disagree (present)" in out   # names differ
    code, out, _ = run(base + ["--out-dir", str(tmp_path / "map"), "--map", "shoulder=j1", "--map", "elbow=j2"], capsys)
    assert code == 0, out
    assert out.startswith("arm: CONSISTENT")
    report = (tmp_path / "map" / "check_arm.md").read_text()
    assert "joint map (--joint-map, --map): 2 URDF joint(s) compared under the MJCF's names (MJCF = URDF): " \
           "shoulder = j1, elbow = j2" in report
    assert "joints matched by name (2 URDF joint(s) through the joint map)" in report
    assert "--map shoulder=j1 --map elbow=j2" in report
    assert "| 0 |" in report.split("## Free motion under gravity")[1]   # bodies matched through their joints
    for name, text in (("map.toml", 'shoulder = "j1"\nelbow = "j2"\n'), ("map_table.toml", '[joints]\nshoulder = "j1"\n'
                                                                        'elbow = "j2"\n'),
                       ("map.txt", "# MJCF  URDF\nshoulder = j1\nelbow j2  # the forearm\n")):
        (tmp_path / name).write_text(text)
        code, out, _ = run(base + ["--out-dir", str(tmp_path / f"out_{name}"), "--joint-map", str(tmp_path / name)],
                           capsys)
        assert code == 0, (name, out)


def test_joint_map_mistakes_are_one_line(arm_pair, tmp_path, capsys):
    mjcf, urdf = arm_pair
    out_dir = tmp_path / "r"
    base = ["check", "--mjcf", str(mjcf), "--urdf", str(urdf), "--out-dir", str(out_dir)]
    line = one_error_line(*run(base + ["--map", "shoulder=j9", "--map", "wrist=j2"], capsys))
    assert ("unknown joint name(s): MJCF 'wrist' (the MJCF's joints: shoulder, elbow); URDF 'j9' (the URDF's joints: "
            "j1, j2)") in line
    line = one_error_line(*run(base + ["--map", "shoulder"], capsys))
    assert "--map 'shoulder': expected mjcf_name=urdf_name" in line
    line = one_error_line(*run(base + ["--map", "shoulder=j1", "--map", "elbow=j1"], capsys))
    assert "URDF joint(s) 'j1' mapped to several MJCF joints" in line
    line = one_error_line(*run(["check", "--mjcf", str(mjcf), "--out-dir", str(out_dir), "--map", "shoulder=j1"], capsys))
    assert "they need both --mjcf and --urdf" in line
    bad = tmp_path / "bad.txt"
    bad.write_text("shoulder = j1\nelbow\n")
    line = one_error_line(*run(base + ["--joint-map", str(bad)], capsys))
    assert f"{bad}: line 2: expected 'mjcf_name = urdf_name', got 'elbow'" in line
    assert not out_dir.exists()


def test_joint_map_readers(tmp_path):
    path = tmp_path / "m.toml"
    path.write_text('a = "x"\n"b c" = "y"\n')
    assert read_joint_map(path) == {"a": "x", "b c": "y"}
    path.write_text("a x\nb = y\n\n# nothing\n")
    assert read_joint_map(path) == {"a": "x", "b": "y"}
    path.write_text("a = 3\n")
    with pytest.raises(InputError, match="not so for 'a'"):
        read_joint_map(path)
    path.write_text("a = x\na = y\n")
    with pytest.raises(InputError, match="line 2: MJCF joint 'a' is mapped twice"):
        read_joint_map(path)
    assert parse_map_options(["a=x", " b = y "]) == {"a": "x", "b": "y"}
    with pytest.raises(InputError, match="mapped twice"):
        parse_map_options(["a=x", "a=y"])
    assert parse_map_options(None) == {}



def test_baxter_with_unreachable_package_meshes_loses_the_geom_masses_without_crashing():
    """example-robot-data's baxter names its meshes by ``package://`` URIs MuJoCo cannot open:
    compiling the geometry for the geom masses fails, after which MuJoCo's spec refuses every
    read (it raised from the list of lost bodies, crashing 14 of the collection's checks);
    the failure is recorded (baxter's one link without ``<inertial>`` has no geom: nothing lost)."""
    from harness.tools import zoo
    from harness.tools.check import geom_inertials

    baxter = {m.name: m for m in zoo.collection("example-robot-data").models}["baxter"].urdf
    frozen = geom_inertials(baxter)
    assert "Error opening file" in frozen.failed and frozen.model is None
    assert frozen.lost == [] and frozen.values == {}
