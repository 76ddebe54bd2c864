"""The command line: exit codes, one-line errors on bad input, nothing written on failure."""

import shutil
import subprocess
import sys

import pandas as pd
import pytest

from harness.cli.main import main
from harness.model.scene import MODELS_DIR


def run(args, capsys):
    code = main(args)
    out = capsys.readouterr()
    return code, out.out, out.err


def assert_one_line_error(code, err, fragment):
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("harness: error:"), err
    assert fragment in lines[0], lines[0]
    assert "Traceback" not in err


def test_scenes_lists_parameters(capsys):
    code, out, _ = run(["scenes"], capsys)
    assert code == 0
    for name in ("torque_free", "heavy_top", "double_pendulum"):
        assert name in out
    assert "omega0 = 1,0.3,0.6 rad/s" in out


def test_simulate_writes_the_schema(tmp_path, capsys):
    out_file = tmp_path / "top.csv"
    code, out, _ = run(["simulate", "heavy_top", "--engine", "mujoco", "--t-end", "0.1", "--out", str(out_file)], capsys)
    assert code == 0, out
    frame = pd.read_csv(out_file)
    head = ["t", "kinetic", "potential", "energy", "px", "py", "pz", "Lx", "Ly", "Lz"]
    assert list(frame.columns[:10]) == head
    for f in ("x", "y", "z", "qw", "qx", "qy", "qz", "vx", "vy", "vz", "wx", "wy", "wz"):
        assert f"top.{f}" in frame.columns
    assert frame["t"].iloc[0] == 0.0 and len(frame) == 21


@pytest.mark.parametrize("args,fragment", [
    (["simulate", "nope", "--engine", "mujoco"], "unknown scene 'nope'"),
    (["simulate", "heavy_top", "--engine", "bullet"], "unknown engine 'bullet'"),
    (["simulate", "heavy_top", "--engine", "mujoco", "--integrator", "leapfrog"], "unknown integrator 'leapfrog'"),
    (["simulate", "heavy_top", "--engine", "mujoco", "--set", "spin=3"], "unknown parameter 'spin'"),
    (["simulate", "heavy_top", "--engine", "mujoco", "--set", "mass"], "malformed --set"),
    (["simulate", "heavy_top", "--engine", "mujoco", "--set", "mass=nan"], "'mass' must be finite"),
    (["simulate", "heavy_top", "--engine", "mujoco", "--set", "mass=-2"], "'mass' must be > 0"),
    (["simulate", "heavy_top", "--engine", "mujoco", "--set", "I1=0.001", "--set", "I3=0.006"], "triangle inequality"),
    (["simulate", "heavy_top", "--engine", "pinocchio", "--dt", "0"], "timestep dt must be positive"),
    (["simulate", "heavy_top", "--engine", "inhouse", "--dt", "-0.001"], "timestep dt must be positive"),
    (["simulate", "heavy_top", "--engine", "mujoco", "--t-end", "-1"], "horizon t_end must be positive"),
    (["simulate", "heavy_top", "--engine", "mujoco", "--dt", "abc"], "not a number"),
    (["validate", "--scenes", "nope"], "unknown scene 'nope'"),
    (["validate", "--engines", "bullet"], "unknown engine 'bullet'"),
])
def test_bad_input_one_line_exit_2(tmp_path, capsys, args, fragment):
    out_file = tmp_path / "x.csv"
    if args[0] == "simulate":
        args = args + ["--out", str(out_file)]
    else:
        args = args + ["--out-dir", str(tmp_path / "reports")]
    code, _, err = run(args, capsys)
    assert_one_line_error(code, err, fragment)
    assert not out_file.exists() and not (tmp_path / "reports").exists()


@pytest.fixture
def models_copy(tmp_path):
    dst = tmp_path / "models"
    shutil.copytree(MODELS_DIR / "heavy_top", dst / "heavy_top")
    return dst


@pytest.mark.parametrize("fname,text,fragment", [
    ("heavy_top.xml", "<mujoco><worldbody><body name='top'>", "cannot load MJCF"),
    ("heavy_top.urdf", "<robot name='x'><link name='top'>", "cannot load URDF"),
    ("scene.toml", "name = [", "malformed TOML"),
])
def test_malformed_model_file_exit_2(models_copy, tmp_path, capsys, fname, text, fragment):
    (models_copy / "heavy_top" / fname).write_text(text)
    reports = tmp_path / "reports"
    code, _, err = run(["validate", "--scenes", "heavy_top", "--models-dir", str(models_copy), "--out-dir", str(reports)], capsys)
    assert_one_line_error(code, err, fragment)
    assert str(models_copy / "heavy_top") in err
    assert not reports.exists()


def test_missing_model_file_exit_2(models_copy, tmp_path, capsys):
    (models_copy / "heavy_top" / "heavy_top.urdf").unlink()
    code, _, err = run(["validate", "--scenes", "heavy_top", "--models-dir", str(models_copy), "--out-dir", str(tmp_path / "r")], capsys)
    assert_one_line_error(code, err, "URDF file not found")


def test_console_script_is_installed():
    proc = subprocess.run([sys.executable, "-m", "harness.cli.main", "simulate", "nope", "--engine", "mujoco", "--out", "x.csv"],
                          capture_output=True, text=True)
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1
