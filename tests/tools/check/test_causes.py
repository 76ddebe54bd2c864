"""``harness check`` names three faults planted in copies of a third-party model pair.

The pair: Unitree's Z1 arm from example-robot-data (a URDF: seven hinges with damping and dry
friction, full inertia tensors, a 0.526 kg gripper stator on a fixed joint) and its MJCF as
MuJoCo's own URDF import writes it (``MjSpec.to_xml``; geometry deleted, ``fusestatic`` off so
that the fixed child stays a body). MuJoCo's XML writer keeps 6 significant digits, coarser than
the 1e-6 tolerance between two files, so every ``<inertial>`` (as ``fullinertia``) and joint range
is copied back from the URDF as written. The unplanted pair passes; each copy carries one fault,
planted with ``xml.etree``:

1. a rotated inertial frame (mujoco #3559): ``<inertial><origin rpy="0.3 -0.2 0.5">`` on link03 of
   the URDF only;
2. an armature only in the MJCF: a default class giving joint2 ``armature="0.02"`` (kg m^2), and a
   motor with gear 50 on joint1;
3. a merged fixed child with its inertia dropped: the MJCF body gripperStator without its
   ``<inertial>`` (no geoms either, so MuJoCo gives it 0 kg).

A fourth test reads bolt (example-robot-data) as it is: its feet are massless links with a
rotational inertia on fixed joints.
"""

import shutil
import sysconfig
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from harness.cli.main import main
from harness.tools.check import render_report, run_check

ROBOTS = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
Z1 = ROBOTS / "z1_description" / "urdf" / "z1.urdf"
RPY = "0.3 -0.2 0.5"     # rad, planted on link03's inertial frame
ARMATURE = 0.02          # kg m^2, planted on joint2
FAST = {"n_states": 2, "n_free": 0}


@pytest.fixture(scope="module")
def pair(tmp_path_factory) -> tuple[Path, Path]:
    """The unplanted pair (MJCF, URDF), written once for the module."""
    d = tmp_path_factory.mktemp("z1")
    urdf = d / "z1.urdf"
    shutil.copy(Z1, urdf)
    spec = mujoco.MjSpec.from_file(str(Z1))
    for geom in list(spec.geoms):
        spec.delete(geom)
    for mesh in list(spec.meshes):
        spec.delete(mesh)
    spec.compiler.fusestatic = False
    spec.compile()
    root = ET.fromstring(spec.to_xml())
    urdf_root = ET.parse(Z1).getroot()
    links = {link.get("name"): link for link in urdf_root.findall("link")}
    joints = {joint.get("name"): joint for joint in urdf_root.findall("joint")}
    for body in root.iter("body"):
        inertial = links[body.get("name")].find("inertial")
        tensor = inertial.find("inertia")
        assert inertial.find("origin").get("rpy") == "0 0 0"   # the tensor is in the link frame as written
        body.find("inertial").attrib = {
            "pos": inertial.find("origin").get("xyz"), "mass": inertial.find("mass").get("value"),
            "fullinertia": " ".join(tensor.get(k) for k in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz"))}
    for joint in root.iter("joint"):
        limit = joints[joint.get("name")].find("limit")
        joint.set("range", f"{limit.get('lower')} {limit.get('upper')}")
    mjcf = d / "z1.xml"
    ET.ElementTree(root).write(mjcf)
    return mjcf, urdf


def copy_pair(pair, tmp_path) -> tuple[Path, Path]:
    return tuple(Path(shutil.copy(p, tmp_path / p.name)) for p in pair)


def element(path: Path, tag: str, name: str) -> tuple[ET.ElementTree, ET.Element]:
    tree = ET.parse(path)
    return tree, next(e for e in tree.getroot().iter(tag) if e.get("name") == name)


def votes(res, quantity):
    return {v.joint: v for v in res.votes if v.quantity == quantity}


def test_the_unplanted_pair_passes(pair, tmp_path):
    res = run_check(*pair, n_states=2, n_free=1, t_end=0.1)
    assert res.passed, res.model_problems
    assert not res.findings and not res.setting_differences
    report = render_report(res, "harness check")
    # the joint settings, per joint, with units; Drake's parsers do not read a friction loss
    assert ("| joint2 | same: 2 N m s/rad | same: 2 N m (Drake does not read it) | same: [0, 2.96706] rad "
            "| same: 0 kg m^2 | Drake 1 (Actuator2): not compared |") in report


def test_a_rotated_inertial_frame_in_the_urdf_is_named_with_its_rpy(pair, tmp_path):
    mjcf, urdf = copy_pair(pair, tmp_path)
    tree, link = element(urdf, "link", "link03")
    link.find("inertial/origin").set("rpy", RPY)
    tree.write(urdf)
    res = run_check(mjcf, urdf, **FAST)
    assert not res.passed
    inertia = votes(res, "inertia about the centre of mass")["joint3"]
    assert inertia.odd == "MuJoCo"   # the MJCF keeps the tensor unrotated
    assert [v.joint for v in res.votes if not v.agree] == ["joint3"]
    # by how much: the rotation's contribution R I0 R^T - I0, computed here from the URDF's numbers
    t = {k: float(link.find("inertial/inertia").get(k)) for k in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")}
    I0 = np.array([[t["ixx"], t["ixy"], t["ixz"]], [t["ixy"], t["iyy"], t["iyz"]], [t["ixz"], t["iyz"], t["izz"]]])
    R = Rotation.from_euler("xyz", [float(c) for c in RPY.split()]).as_matrix()
    gap = float(np.abs(R @ I0 @ R.T - I0).max())
    assert gap > 1e-3   # 0.00273 kg m^2, 29% of the largest entry: not round-off
    (finding,) = res.findings
    assert (finding.kind, finding.joint, finding.body) == ("inertial rotation", "joint3", "link03")
    assert f"differs by up to {gap:.3g} kg m^2" in finding.text
    assert f'<inertial><origin rpy="{RPY}">' in finding.text and "inertial-frame rotation (rpy)" in finding.text
    assert "MuJoCo's reading (of the MJCF) has it unrotated" in finding.text
    assert "rotating the unrotated tensor by that rpy reconciles the readings" in finding.text
    assert "same principal moments" in inertia.message
    assert f"inertial frame of link 'link03' rotated by the URDF's rpy=\"{RPY}\"" in res.findings[0].short

    # Not guessed: with the tensor also changed, the rotation no longer reconciles and is not named.
    link.find("inertial/inertia").set("iyy", str(1.01 * t["iyy"]))
    tree.write(urdf)
    res = run_check(mjcf, urdf, **FAST)
    assert votes(res, "inertia about the centre of mass")["joint3"].odd == "MuJoCo"
    assert not res.findings


def test_the_installed_mujoco_applies_the_urdf_inertial_rotation(pair, tmp_path):
    """mujoco #3559 (the rotation lost when MuJoCo compiles a URDF) is fixed in the installed
    MuJoCo: all three read the rotated URDF alike."""
    _, urdf = copy_pair(pair, tmp_path)
    tree, link = element(urdf, "link", "link03")
    link.find("inertial/origin").set("rpy", RPY)
    tree.write(urdf)
    res = run_check(None, urdf, strip=True, **FAST)
    assert res.passed and not res.findings, res.model_problems


def test_an_armature_only_in_the_mjcf_is_named_with_its_effect_on_m(pair, tmp_path, capsys):
    mjcf, urdf = copy_pair(pair, tmp_path)
    tree, joint = element(mjcf, "joint", "joint2")
    root = tree.getroot()
    default = ET.Element("default")
    ET.SubElement(ET.SubElement(default, "default", {"class": "rotor"}), "joint", armature=f"{ARMATURE}")
    root.insert(1, default)
    joint.set("class", "rotor")
    ET.SubElement(ET.SubElement(root, "actuator"), "motor", name="m1", joint="joint1", gear="50")
    tree.write(mjcf)
    base = mujoco.MjModel.from_xml_path(str(pair[0]))     # the unplanted MJCF: M without the armature
    M = np.zeros((base.nv, base.nv))
    data = mujoco.MjData(base)
    mujoco.mj_forward(base, data)
    mujoco.mj_fullM(base, data, M)
    rigid = M[1, 1]                                      # joint2's diagonal entry at zero joint coordinates

    res = run_check(mjcf, urdf, **FAST)
    arm = votes(res, "armature")["joint2"]
    assert arm.odd == "MuJoCo" and not arm.counted   # a URDF cannot state an armature: listed, not counted
    assert arm.values == {"MuJoCo": "0.02 kg m^2", "Pinocchio": "0 kg m^2", "Drake": "0 kg m^2"}
    findings = {f.kind: f for f in res.findings}
    assert set(findings) == {"armature", "dynamics armature"}
    text = findings["armature"].text
    assert ("joint 'joint2' (body 'link02'): armature: MuJoCo reads 0.02 kg m^2, the URDF has no armature "
            "(Pinocchio and Drake read 0 — only one loader reads it)") in text
    assert f"{rigid + ARMATURE:.6g} kg m^2 with it, {rigid:.6g} kg m^2 without, at zero joint coordinates" in text
    assert "joint2 +0.02 kg m^2" in findings["dynamics armature"].text
    rows = {(d.a, d.b, d.term): d for d in res.dynamics}
    assert rows[("MuJoCo", "Pinocchio", "M")].max_abs == pytest.approx(ARMATURE, rel=1e-9)
    assert rows[("Pinocchio", "Drake", "M")].passed
    assert all(d.passed for d in res.dynamics if d.term != "M")
    assert not res.model_problems   # the models agree; M does not, by the armature a URDF cannot state
    assert [d.limitation.id for d in res.classes.known] == ["urdf-format-no-armature"] and res.passed

    code = main(["check", "--mjcf", str(mjcf), "--urdf", str(urdf), "--out-dir", str(tmp_path), "--states", "2",
                 "--free-runs", "0"])
    out = " ".join(capsys.readouterr().out.split())
    assert code == 0
    assert ("Pinocchio and Drake read no armature from the URDF, which has no element for it (known: "
            "urdf-format-no-armature; dynamics)") in out
    report = (tmp_path / "check_z1.md").read_text()
    assert "- joint 'joint2' (body 'link02'): armature: MuJoCo reads 0.02 kg m^2" in report   # the cause, checked
    row = next(line for line in report.splitlines() if line.startswith("| joint2 | same: 2 N m s/rad"))
    assert "only MuJoCo reads it: 0.02 kg m^2 (the URDF has no armature)" in row
    row = next(line for line in report.splitlines() if line.startswith("| joint1 | same: 1 N m s/rad"))
    assert row.endswith("| MuJoCo 50 (m1), Drake 1 (Actuator1): not compared |")


def test_a_fixed_childs_dropped_inertia_is_named_with_its_parent(pair, tmp_path):
    mjcf, urdf = copy_pair(pair, tmp_path)
    tree, body = element(mjcf, "body", "gripperStator")
    body.remove(body.find("inertial"))
    tree.write(mjcf)
    child_kg = float(element(urdf, "link", "gripperStator")[1].find("inertial/mass").get("value"))
    res = run_check(mjcf, urdf, **FAST)
    for quantity in ("mass", "centre of mass", "inertia about the centre of mass"):
        assert votes(res, quantity)["joint6"].odd == "MuJoCo"
    assert [v.joint for v in res.votes if not v.agree] == ["joint6"] * 3
    assert f"they differ by {child_kg:.6g} kg" in votes(res, "mass")["joint6"].message
    (finding,) = res.findings
    assert (finding.kind, finding.joint, finding.body) == ("fixed child", "joint6", "link06")
    assert f"the merged body's mass differs by {child_kg:.6g} kg" in finding.text
    assert "a fixed child's inertia is missing in MuJoCo's reading (of the MJCF): link 'gripperStator'" in finding.text
    assert "the mass difference equals the child's mass" in finding.text
    assert "from its geoms since the MJCF gives it no <inertial>: no geoms, 0 kg" in finding.text
    assert finding.short == f"fixed child 'gripperStator' of body 'link06' missing in MuJoCo's reading ({child_kg:.6g} kg)"
    assert any("masses derived from geoms vs given" in n and "gripperStator" in n for n in res.notes)


def test_bolt_feet_massless_links_with_inertia():
    """bolt's feet: <mass value="0"> with a rotational inertia, on fixed joints below the lower
    legs. MuJoCo's fusestatic drops their inertia (Pinocchio keeps it); Drake's URDF parser gives
    each foot 1 kg. Both are named, per leg, with the element of the file."""
    res = run_check(None, ROBOTS / "bolt_description" / "robots" / "bolt.urdf", floating_base=True, strip=True, **FAST)
    shorts = [f.short for f in res.findings]
    for leg in ("FL", "FR"):
        assert (f"inertia of fixed child '{leg}_FOOT' of body '{leg}_LOWER_LEG' missing in MuJoCo's reading") in shorts
        assert f"fixed child '{leg}_FOOT' of body '{leg}_LOWER_LEG' given 1 kg by Drake (the URDF states 0 kg)" in shorts
    dropped = next(f for f in res.findings if f.short.startswith("inertia of fixed child 'FL_FOOT'"))
    assert "(MuJoCo fused the link into its parent: fusestatic)" in dropped.text
    assert "[[5.7e-07, 0, 0], [0, 8.4e-07, 0], [0, 0, 5.3e-07]] kg m^2 in Pinocchio's and PyBullet's reading" in dropped.text
