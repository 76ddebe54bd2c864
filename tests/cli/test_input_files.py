"""Issue #29 on the command line: a file that is not a regular file (a FIFO, a link to a device),
an output that is not one, an include outside the model's folder, a model MuJoCo refuses for its
depth: one line on stderr, exit 2, nothing run or written."""

import os
import shutil
import stat
from pathlib import Path

import pytest

from harness.cli.main import main
from harness.model.scene import MODELS_DIR

ROD_MJCF = ('<mujoco model="rod"><worldbody><body name="rod" pos="0 0 1"><joint name="hinge" type="hinge" axis="0 1 0"/>'
            '<inertial pos="0 0 -0.5" mass="1" diaginertia="0.01 0.01 0.01"/></body></worldbody></mujoco>')
ROD_URDF = ('<robot name="rod"><link name="world"/><joint name="hinge" type="continuous"><parent link="world"/>'
            '<child link="rod"/><origin xyz="0 0 1"/><axis xyz="0 1 0"/></joint><link name="rod"><inertial>'
            '<origin xyz="0 0 -0.5"/><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/>'
            '</inertial></link></robot>')


def one_line_error(args, capsys, *fragments) -> str:
    code = main([str(a) for a in args])
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and lines[0].startswith("harness: error:"), err
    assert "Traceback" not in err and all(f in lines[0] for f in fragments), lines[0]
    return lines[0]


def test_simulate_refuses_an_out_that_is_a_fifo_before_running(tmp_path, capsys):
    fifo = tmp_path / "traj.csv"
    os.mkfifo(fifo)
    one_line_error(["simulate", "heavy_top", "--engine", "mujoco", "--out", fifo], capsys,
                   f"argument --out: cannot write {fifo}: it is a FIFO (named pipe), not a regular file")
    assert stat.S_ISFIFO(os.stat(fifo).st_mode) and os.listdir(tmp_path) == ["traj.csv"]


@pytest.mark.parametrize("command", [["validate", "--scenes", "heavy_top"], ["zoo", "dm_control"],
                                     ["check", "--mjcf", "ROD"], ["debug", "heavy_top", "--engines", "mujoco,inhouse"]])
def test_an_out_dir_that_is_not_a_folder_is_refused(tmp_path, capsys, command):
    fifo = tmp_path / "reports"
    os.mkfifo(fifo)
    (tmp_path / "rod.xml").write_text(ROD_MJCF)
    args = [tmp_path / "rod.xml" if a == "ROD" else a for a in command]
    one_line_error([*args, "--out-dir", fifo], capsys, f"argument --out-dir: cannot write to {fifo}: it is not a folder")
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)


def test_check_refuses_a_fifo_and_a_link_to_a_device(tmp_path, capsys):
    fifo, zero = tmp_path / "robot.xml", tmp_path / "robot.urdf"
    os.mkfifo(fifo)
    zero.symlink_to("/dev/zero")  # read-side only: refused before a byte is read
    out = tmp_path / "out"
    one_line_error(["check", "--mjcf", fifo, "--out-dir", out], capsys,
                   f"{fifo}: the MJCF is not a regular file but a FIFO (named pipe)")
    one_line_error(["check", "--urdf", zero, "--out-dir", out], capsys,
                   f"{zero}: the URDF is not a regular file but a character device (a symlink to /dev/zero)")
    assert not out.exists()


def test_check_refuses_a_joint_map_that_is_a_fifo(tmp_path, capsys):
    (tmp_path / "rod.xml").write_text(ROD_MJCF)
    (tmp_path / "rod.urdf").write_text(ROD_URDF)
    os.mkfifo(tmp_path / "map.txt")
    one_line_error(["check", "--mjcf", tmp_path / "rod.xml", "--urdf", tmp_path / "rod.urdf", "--joint-map",
                    tmp_path / "map.txt", "--out-dir", tmp_path / "out"], capsys,
                   "map.txt: the joint map is not a regular file but a FIFO")


def test_validate_refuses_a_requirements_file_that_is_a_fifo(tmp_path, capsys):
    os.mkfifo(tmp_path / "req.toml")
    one_line_error(["validate", "--scenes", "heavy_top", "--requirements", tmp_path / "req.toml", "--out-dir",
                    tmp_path / "out"], capsys, "req.toml: the requirements file is not a regular file but a FIFO")
    assert not (tmp_path / "out").exists()


def test_a_scene_whose_model_file_is_a_fifo_is_refused(tmp_path, capsys):
    models = tmp_path / "models"
    shutil.copytree(MODELS_DIR / "double_pendulum", models / "double_pendulum")
    urdf = models / "double_pendulum" / "double_pendulum.urdf"
    urdf.unlink()
    os.mkfifo(urdf)
    one_line_error(["simulate", "double_pendulum", "--engine", "pinocchio", "--models-dir", models, "--out",
                    tmp_path / "x.csv"], capsys, f"{urdf}: the URDF is not a regular file but a FIFO")
    assert not (tmp_path / "x.csv").exists()


def test_check_refuses_an_include_outside_the_models_folder_unless_allowed(tmp_path, capsys):
    model, outside = tmp_path / "model", tmp_path / "outside"
    model.mkdir()
    outside.mkdir()
    (outside / "body.xml").write_text(ROD_MJCF.replace('<mujoco model="rod">', "<mujoco>"))
    path = model / "robot.xml"
    path.write_text('<mujoco model="robot"><include file="../outside/body.xml"/></mujoco>')
    out = tmp_path / "out"
    one_line_error(["check", "--mjcf", path, "--out-dir", out], capsys,
                   f"{path}: <include file> '../outside/body.xml' ({outside / 'body.xml'}) is outside the model's "
                   f"folder {model}")
    assert not out.exists()
    assert main(["check", "--mjcf", str(path), "--allow-dir", str(outside), "--out-dir", str(out), "--quiet",
                 "--free-runs", "0"]) == 0
    assert "--allow-dir" in (out / "check_robot.md").read_text()


def _chain_urdf(path: Path, links: int) -> None:
    inertia = '<inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>'
    parts = ['<robot name="deep">'] + [f'<link name="l{i}">{inertia}</link>' for i in range(links + 1)]
    parts += [f'<joint name="j{i}" type="continuous"><parent link="l{i}"/><child link="l{i + 1}"/>'
              f'<origin xyz="0 0 0.1"/><axis xyz="0 1 0"/></joint>' for i in range(links)]
    path.write_text("\n".join(parts + ["</robot>"]))


def test_a_chain_too_deep_for_mujoco_is_refused_with_mujocos_reason(tmp_path, capsys):
    """MuJoCo refuses a chain deeper than 1024 bodies ("depth limit exceeded"); the refusal says
    so, instead of running out of memory asking Pinocchio for a second opinion (2000 links did)."""
    path = tmp_path / "deep.urdf"
    _chain_urdf(path, 1030)
    one_line_error(["check", "--urdf", path, "--out-dir", tmp_path / "out"], capsys,
                   f"{path}: MuJoCo cannot compile the URDF: Error: depth limit exceeded")
