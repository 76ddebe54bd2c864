"""``harness zoo``: ``check`` on every model of a folder or an installed collection, each model in
its own process, one table; bad input writes nothing."""

from __future__ import annotations

import csv
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from harness.cli.main import main
from harness.tools import zoo

# A thin rod (principal moments 5e-6, 0.01, 0.01 kg m^2: triangle margin 5e-4, a 1 m rod of 3.2 mm
# radius; implied density 9.6e4 kg/m^3, within the plausible range) on a hinge, as an
# MJCF and the matching URDF (checked as a pair), and a box-like arm welded to the world (URDF
# alone): a 1 kg link whose inertia is that of a uniform 0.1 x 0.2 x 0.3 m box (166.67 kg/m^3).
ROD_MJCF = """<mujoco model="rod">
  <worldbody>
    <body name="rod" pos="0 0 1">
      <joint name="hinge" type="hinge" axis="0 1 0"/>
      <inertial pos="0 0 -0.5" mass="1" diaginertia="5e-6 0.01 0.01"/>
    </body>
  </worldbody>
</mujoco>
"""
ROD_URDF = """<?xml version="1.0"?>
<robot name="rod">
  <link name="world"/>
  <joint name="hinge" type="continuous"><parent link="world"/><child link="rod"/>
    <origin xyz="0 0 1"/><axis xyz="0 1 0"/></joint>
  <link name="rod"><inertial><origin xyz="0 0 -0.5"/><mass value="1"/>
    <inertia ixx="5e-6" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
</robot>
"""
BOX = {"ixx": (0.2**2 + 0.3**2) / 12, "iyy": (0.1**2 + 0.3**2) / 12, "izz": (0.1**2 + 0.2**2) / 12}
ARM_URDF = f"""<?xml version="1.0"?>
<robot name="arm">
  <link name="world"/>
  <joint name="j1" type="revolute"><parent link="world"/><child link="l1"/>
    <origin xyz="0 0 1"/><axis xyz="1 0 0"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <link name="l1"><inertial><origin xyz="0 0 -0.25"/><mass value="1"/>
    <inertia ixx="{BOX['ixx']!r}" ixy="0" ixz="0" iyy="{BOX['iyy']!r}" iyz="0" izz="{BOX['izz']!r}"/></inertial></link>
</robot>
"""
BROKEN_URDF = '<?xml version="1.0"?>\n<robot name="broken">\n  <link name="l1">\n'


def folder(tmp_path: Path) -> Path:
    d = tmp_path / "my_models"
    d.mkdir()
    (d / "rod.xml").write_text(ROD_MJCF)
    (d / "rod.urdf").write_text(ROD_URDF)
    (d / "arm.urdf").write_text(ARM_URDF)
    (d / "broken.urdf").write_text(BROKEN_URDF)
    (d / "notes.txt").write_text("not a model")
    return d


def rows(csv_path: Path) -> dict[str, dict[str, str]]:
    with open(csv_path, newline="") as f:
        return {r["model"]: r for r in csv.DictReader(f)}


def test_folder_pairs_models_and_gives_a_malformed_file_its_row(tmp_path, capsys):
    d, out = folder(tmp_path), tmp_path / "out"
    code = main(["zoo", str(d), "--out-dir", str(out)])
    stdout = capsys.readouterr().out
    assert code == 0, stdout
    table = rows(out / "my_models.csv")
    assert sorted(table) == ["arm", "broken", "rod"]  # rod.xml and rod.urdf are one model; notes.txt is none
    rod, arm, broken = table["rod"], table["arm"], table["broken"]
    assert rod["files"] == f"{d / 'rod.xml'};{d / 'rod.urdf'}" and rod["base"] == "fixed"
    assert arm["base"] == "fixed"  # a URDF alone whose root link is `world` stays welded
    assert rod["class"] == arm["class"] == "consistent"
    assert rod["defects"] == rod["known"] == rod["unexplained"] == "0"
    assert {rod[f"{k}_loads"] for k in ("mujoco", "pinocchio", "drake", "pybullet")} == {"yes"}   # PyBullet: the URDF
    assert broken["class"] == "refused" and "cannot load" in broken["reason"]
    assert broken["mujoco_loads"] == broken["pinocchio_loads"] == broken["drake_loads"] == "no"
    assert all(broken[f"{k}_refusal"] for k in ("mujoco", "pinocchio", "drake"))
    # the rod's triangle margin (5e-6 / 0.01 = 5e-4) is flagged, the box's inertia is not
    assert rod["suspicious_bodies"] == "1" and "triangle margin 0.0005 < 0.001" in rod["suspicious"]
    assert arm["bodies"] == "1" and arm["suspicious_bodies"] == "0"
    assert float(arm["run_time_s"]) > 0
    md = (out / "my_models.md").read_text()
    assert ("**3 models; loaded by every loader of their format: 2; class: 0 defect in your file, 0 importer disagreement, "
            "2 consistent, 1 refused, 0 crashed; importer disagreements: 0 known, 0 unexplained; 1 model(s) with a "
            "suspicious inertia;") in md
    assert "[rod](my_models/check_rod.md)" in md and "- rod: rod (triangle margin 0.0005 < 0.001)" in md
    report = (out / "my_models" / "check_arm.md").read_text()
    assert report.startswith("# harness check: arm") and "Verdict: consistent" in report
    assert "implied density 167 kg/m^3: plausible" in report  # 1 kg / (0.1 x 0.2 x 0.3 m)
    assert "Verdict: **refused**" in (out / "my_models" / "check_broken.md").read_text()
    assert "consistent            arm" in stdout and "refused               broken" in stdout


def test_an_mjcf_lighter_than_its_urdf_is_a_defect_of_the_pair_with_its_fix(tmp_path):
    """An MJCF 10 % lighter than its URDF: the readers of each file agree with each other, so the two
    files state different masses: the row's class is a defect, its first finding names the joint
    and says what to make agree."""
    d = tmp_path / "pair"
    d.mkdir()
    (d / "rod.xml").write_text(ROD_MJCF.replace('mass="1"', 'mass="0.9"'))
    (d / "rod.urdf").write_text(ROD_URDF)
    (row,) = zoo.run_zoo(zoo.collection(str(d)), timeout=120.0).rows
    assert row.cls == "defect in your file" and row.counts["defects"] >= 1 and row.counts["unexplained"] == 0
    assert row.top.startswith("rod.urdf joint 'hinge' (body 'rod'): MJCF and URDF disagree (mass)")
    assert "fix: make the MJCF and the URDF state the same mass for joint 'hinge' (body 'rod')" in row.top


def test_plausibility_of_an_inertia():
    from harness.tools.check.defects import DENSITY_RANGE, plausibility

    box = plausibility("box", 6.0, [6 * (0.2**2 + 0.3**2) / 12, 6 * (0.1**2 + 0.3**2) / 12, 6 * (0.1**2 + 0.2**2) / 12])
    assert box.density == pytest.approx(1000.0) and not box.suspicious  # 6 kg in 0.006 m^3
    assert box.margin == pytest.approx(2 * 0.1**2 / (0.2**2 + 0.3**2))  # (I_a + I_b - I_c) / I_c = 2 a^2 / (b^2 + c^2)
    assert plausibility("sphere", 1.0, [0.4, 0.4, 0.4]).margin == pytest.approx(1.0)
    bad = plausibility("base", 1e-6, [0.0, 0.0, 3e-6])  # anymal's rank-1 base
    assert bad.margin == pytest.approx(-1.0) and np.isnan(bad.density) and bad.suspicious
    heavy = plausibility("lump", 1.0, [1e-7, 1e-7, 1e-7])  # 1 kg with a 2.4 mm box's inertia
    assert heavy.density > DENSITY_RANGE[1] and heavy.implausible and any("density" in f for f in heavy.flags)
    assert "point mass" in plausibility("dot", 1.0, [0, 0, 0]).flags[0]


def test_a_crash_and_a_hang_stay_in_their_rows(tmp_path, monkeypatch):
    """One model's worker aborts (SIGABRT), another's hangs past --timeout: each is its own row,
    the third model passes."""
    real = zoo.run_check

    def misbehaving(mjcf, urdf, **kwargs):
        name = Path(urdf if urdf is not None else mjcf).stem
        if name == "arm":
            os.abort()
        if name == "rod":
            time.sleep(60)
        return real(mjcf, urdf, **kwargs)

    monkeypatch.setattr(zoo, "run_check", misbehaving)
    d = folder(tmp_path)
    (d / "broken.urdf").write_text(ARM_URDF)  # a second, healthy arm
    result = zoo.run_zoo(zoo.collection(str(d)), timeout=4.0)
    by = {r.name: r for r in result.rows}
    assert by["arm"].cls == "crashed" and "SIGABRT" in by["arm"].reason
    assert "last Python frame" in by["arm"].reason and "misbehaving" in by["arm"].reason
    assert by["rod"].cls == "crashed" and "timed out" in by["rod"].reason and by["rod"].wall_s >= 4.0
    assert by["broken"].cls == "consistent" and by["arm"].loads == {}
    assert (result.count("consistent"), result.count("crashed")) == (1, 2)


@pytest.mark.parametrize("args, message", [
    (["no_such_collection"], "no_such_collection: no such folder and not a known collection (example-robot-data, dm_control)"),
    (["EMPTY"], "no model file (*.xml, *.urdf) in the folder"),
    (["dm_control", "--only", "pendulum,no_such_model"], "--only: no model named 'no_such_model' in dm_control"),
    (["dm_control", "--timeout", "0"], "--timeout must be positive"),
])
def test_bad_input_is_one_line_and_writes_nothing(tmp_path, capsys, args, message):
    empty = tmp_path / "empty"
    empty.mkdir()
    (empty / "readme.txt").write_text("no model here")
    out = tmp_path / "out"
    code = main(["zoo", *[str(empty) if a == "EMPTY" else a for a in args], "--out-dir", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and err.startswith("harness: error:") and message in err, err
    assert not out.exists()


def test_dm_control_suite_models_by_name(tmp_path, capsys):
    """Two suite MJCFs checked in place: pendulum passes; lqr (a template without a moving
    joint) is refused with its reason, and which engines load it is still said."""
    out = tmp_path / "out"
    assert main(["zoo", "dm_control", "--only", "pendulum,lqr", "--out-dir", str(out)]) == 0
    table = rows(out / "dm_control.csv")
    assert sorted(table) == ["lqr", "pendulum"]
    assert table["pendulum"]["class"] == "consistent"
    assert table["pendulum"]["files"].endswith("dm_control/suite/pendulum.xml")
    lqr = table["lqr"]
    assert lqr["class"] == "refused" and "no moving joint" in lqr["reason"]
    assert lqr["mujoco_loads"] == "yes" and lqr["pinocchio_loads"] == "no" and lqr["pinocchio_refusal"]
    md = (out / "dm_control.md").read_text()
    assert "dm_control/suite/*.xml`, checked in place" in md and "class: 0 defect in your file, 0 importer disagreement, 1 consistent, 1 refused, 0 crashed" in md
    assert (out / "dm_control" / "check_pendulum.md").is_file() and (out / "dm_control" / "check_lqr.md").is_file()


def test_example_robot_data_is_found_from_the_installed_package(tmp_path, capsys):
    coll = zoo.collection("example-robot-data")
    assert coll.strip and coll.root.parts[-2:] == ("example-robot-data", "robots") and coll.root.is_dir()
    assert len(coll.models) >= 50 and all(m.urdf.is_file() and m.mjcf is None for m in coll.models)
    names = [m.name for m in coll.models]
    assert len(set(names)) == len(names)
    assert {"anymal_b_simple_description-anymal", "anymal_c_simple_description-anymal", "ur5_robot", "solo12"} <= set(names)
    by = {m.name: m for m in coll.models}
    assert not zoo.floating_base(by["ur5_robot"], "auto")  # root link `world`: welded by the file
    assert zoo.floating_base(by["solo12"], "auto") and not zoo.floating_base(by["solo12"], "fixed")
    out = tmp_path / "out"
    assert main(["zoo", "example-robot-data", "--only", "ur5_robot,ur3", "--out-dir", str(out)]) == 0
    table = rows(out / "example-robot-data.csv")
    # ur5's wrist_3_link: 0.1879 kg with the inertia of a 1.45 kg/m^3 box: a defect, its line and its fix
    ur5 = table["ur5_robot"]
    assert ur5["class"] == "defect in your file" and ur5["base"] == "fixed" and ur5["defects"] == "1"
    assert ur5["first_finding"].startswith("ur5_robot.urdf:") and "link 'wrist_3_link': implausible density" in \
        ur5["first_finding"] and "; fix: check link 'wrist_3_link'" in ur5["first_finding"]
    assert table["ur3"]["class"] == "refused"  # ur3.urdf is an empty <robot/>
    assert "--strip-geometry" in (out / "example-robot-data" / "check_ur5_robot.md").read_text()


def _children(pid: int) -> set[int]:
    found = set()
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            found |= {int(c) for c in (task / "children").read_text().split()}
        except OSError:
            pass
    return found


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_killing_the_parent_leaves_no_worker(tmp_path):
    """SIGKILL of `harness zoo` while two models hang in their workers: both workers die too."""
    d = folder(tmp_path)
    script = ("import time, sys\nimport harness.tools.zoo as z\n"
              "z.run_check = lambda *a, **k: time.sleep(120)\n"
              "from harness.cli.main import main\n"
              f"sys.exit(main(['zoo', {str(d)!r}, '--out-dir', {str(tmp_path / 'out')!r}]))\n")
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 30
        while len(workers := _children(proc.pid)) < 2 and time.monotonic() < deadline:
            time.sleep(0.1)
        assert len(workers) >= 2
    finally:
        proc.kill()
        proc.wait()
    deadline = time.monotonic() + 10
    while any(Path(f"/proc/{w}").exists() and "Z" not in _state(w) for w in workers) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not [w for w in workers if Path(f"/proc/{w}").exists() and "Z" not in _state(w)]
    assert not (tmp_path / "out").exists()  # nothing is written before every model ran


def _state(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return "Z"


def test_a_file_check_would_refuse_is_refused_not_crashed(tmp_path):
    """Issue #29: a latin-1 MJCF, a FIFO and a link to /dev/zero in the folder are rows "refused"
    with check's one-line reason (no engine is given them), never "crashed" or a hang."""
    d = tmp_path / "odd"
    d.mkdir()
    (d / "cafe.xml").write_bytes(ROD_MJCF.replace('model="rod"', 'model="caf\xe9"').encode("latin-1"))
    os.mkfifo(d / "pipe.urdf")
    (d / "zero.urdf").symlink_to("/dev/zero")  # read-side only: refused before a byte is read
    result = zoo.run_zoo(zoo.collection(str(d)), timeout=60.0)
    by = {r.name: r for r in result.rows}
    assert {n: r.cls for n, r in by.items()} == {"cafe": "refused", "pipe": "refused", "zero": "refused"}
    assert by["cafe"].reason == "MJCF file is not UTF-8 text (byte 0xe9 at offset 18)"
    assert by["pipe"].reason.startswith("the URDF is not a regular file but a FIFO (named pipe)")
    assert by["zero"].reason.startswith("the URDF is not a regular file but a character device (a symlink to /dev/zero)")
    assert all(r.loads == {} and "Verdict: **refused**" in r.report for r in by.values())


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("where", ["zoo", "check"])
def test_sigterm_removes_the_temporary_folders(tmp_path, where):
    """Issue #29: SIGTERM to `harness zoo` while its workers run (or to `harness check` while it
    loads a model): the process exits 143, its harness-zoo-* / harness-check-* folder is gone and
    no worker is left."""
    d = folder(tmp_path)
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    hang = ("z.run_check = lambda *a, **k: time.sleep(120)\n" if where == "zoo" else
            "import harness.tools.check.reading as c\nc._load_readings = lambda *a, **k: time.sleep(120)\n")
    command = (["zoo", str(d)] if where == "zoo" else ["check", "--mjcf", str(d / "rod.xml")])
    script = ("import time, sys\nimport harness.tools.zoo as z\n" + hang + "from harness.cli.main import main\n"
              f"sys.exit(main({command + ['--out-dir', str(tmp_path / 'out')]!r}))\n")
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            env={**os.environ, "TMPDIR": str(tmp)})
    workers: set[int] = set()
    try:
        deadline = time.monotonic() + 60
        want = 2 if where == "zoo" else 0
        while time.monotonic() < deadline and not (list(tmp.glob(f"harness-{where}-*"))
                                                   and len(workers := _children(proc.pid)) >= want):
            time.sleep(0.1)
        assert list(tmp.glob(f"harness-{where}-*")) and len(workers) >= want
        proc.send_signal(signal.SIGTERM)
        code = proc.wait(30)
    finally:
        proc.kill()
        proc.wait()
    assert code == 143, proc.stderr.read().decode()
    assert list(tmp.iterdir()) == []  # the temporary folder was removed on the way out
    assert not [w for w in workers if Path(f"/proc/{w}").exists() and "Z" not in _state(w)]
    assert not (tmp_path / "out").exists()
