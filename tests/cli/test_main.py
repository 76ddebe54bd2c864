"""The command line: exit codes, one-line errors on bad input, nothing written on failure."""

import shutil
from pathlib import Path
import subprocess
import sys

import numpy as np
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


def test_console_script_is_installed(tmp_path):
    """The ``harness`` script of this environment (editable or plain install) runs, from any folder."""
    script = Path(sys.executable).with_name("harness")
    proc = subprocess.run([str(script), "simulate", "nope", "--engine", "mujoco", "--out", "x.csv"],
                          capture_output=True, text=True, cwd=tmp_path)
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1


# ---------------------------------------------------------------- no vacuous verdicts

def _validate(args, tmp_path, capsys):
    reports = tmp_path / "reports"
    code, out, err = run(["validate", *args, "--out-dir", str(reports)], capsys)
    return code, out, err, reports


@pytest.mark.parametrize("make_dir,args,fragment", [
    (False, ["--models-dir", "{tmp}/modles"], "argument --models-dir: no such folder"),
    (True, ["--models-dir", "{tmp}/empty"], "nothing to run: no scenes under"),
    (False, ["--engines", ","], "--engines selects nothing"),
    (False, ["--scenes", ","], "--scenes selects nothing"),
    (False, ["--scenes", "heavy_top", "--jobs", "-1"], "--jobs must be >= 0"),
    (False, ["--scenes", "heavy_top", "--timeout", "nan"], "argument --timeout: not a finite number"),
])
def test_validate_over_nothing_is_exit_2(tmp_path, capsys, make_dir, args, fragment):
    if make_dir:
        (tmp_path / "empty").mkdir()
    args = [a.replace("{tmp}", str(tmp_path)) for a in args]
    code, out, err, reports = _validate(args, tmp_path, capsys)
    assert_one_line_error(code, err, fragment)
    assert not reports.exists() and out == ""


def test_validation_in_which_no_check_ran_is_exit_2(tmp_path, capsys, monkeypatch):
    """Whatever makes a scene yield no check, the CLI writes nothing and exits 2."""
    import harness.validate.run as run_module
    from harness.validate.run import SceneValidation

    called = []

    def no_checks(scenes, engines, **kwargs):
        called.append([s.name for s in scenes])
        return [SceneValidation(scene=s.name, parameters={}) for s in scenes]

    monkeypatch.setattr(run_module, "validate", no_checks)
    code, _, err, reports = _validate(["--scenes", "heavy_top", "--engines", "mujoco"], tmp_path, capsys)
    assert called == [["heavy_top"]]
    assert_one_line_error(code, err, "no check ran for heavy_top")
    assert not reports.exists()


ENERGY = "[checks.energy_drift]\n"


@pytest.mark.parametrize("old,new,fragment", [
    ("[checks.energy_drift]", "[checks.enrgy_drift]", "unknown check table [checks.enrgy_drift]"),
    (ENERGY, ENERGY + "colour = 'red'\n", "unknown key 'colour' at [checks.energy_drift]"),
    ("t_end = 5.0", 't_end = "abc"', "[simulation] t_end must be a number"),
    (ENERGY, ENERGY + "mujoco = 1e-8\n", "[checks.energy_drift] mujoco: a check holds no tolerance"),
    ("[parameters]", 'colour = "red"\n[parameters]', "unknown key 'colour' at [needs]"),
])
def test_scene_description_mistakes_are_exit_2(models_copy, tmp_path, capsys, old, new, fragment):
    path = models_copy / "heavy_top" / "scene.toml"
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))
    code, _, err, reports = _validate(["--models-dir", str(models_copy)], tmp_path, capsys)
    assert_one_line_error(code, err, fragment)
    assert str(path) in err and not reports.exists()


def test_scene_without_checks_is_exit_2(models_copy, tmp_path, capsys):
    path = models_copy / "heavy_top" / "scene.toml"
    text = path.read_text()
    path.write_text(text[:text.index("[checks.")])
    code, _, err, reports = _validate(["--models-dir", str(models_copy)], tmp_path, capsys)
    assert_one_line_error(code, err, "declares no [checks.<name>] table")
    assert not reports.exists()


# ---------------------------------------------------------------- one line, never a traceback

@pytest.mark.parametrize("fname", ["scene.toml", "heavy_top.urdf", "heavy_top.xml"])
def test_non_utf8_files_are_exit_2(models_copy, tmp_path, capsys, fname):
    path = models_copy / "heavy_top" / fname
    path.write_bytes(path.read_bytes().replace(b"heavy", b"h\xe9avy", 1))
    code, _, err, reports = _validate(["--models-dir", str(models_copy)], tmp_path, capsys)
    assert_one_line_error(code, err, "not UTF-8 text (byte 0xe9 at offset")
    assert str(path) in err and not reports.exists()
    out_file = tmp_path / "top.csv"
    code, _, err = run(["simulate", "heavy_top", "--engine", "pinocchio", "--models-dir", str(models_copy),
                        "--out", str(out_file)], capsys)
    assert_one_line_error(code, err, "not UTF-8 text")
    assert not out_file.exists()


def test_non_utf8_model_in_check_is_exit_2(tmp_path, capsys):
    urdf = tmp_path / "m.urdf"
    urdf.write_bytes((MODELS_DIR / "heavy_top" / "heavy_top.urdf").read_bytes().replace(b"top", b"t\xf6p", 1))
    code, _, err = run(["check", "--urdf", str(urdf), "--out-dir", str(tmp_path / "r")], capsys)
    assert_one_line_error(code, err, f"{urdf}: URDF file is not UTF-8 text")
    assert not (tmp_path / "r").exists()


@pytest.mark.parametrize("text,fragment", [
    ("heavy_top = 5\n", "heavy_top = 5: expected a table [heavy_top] of check = bound"),
    (b"[heavy_top]\nexact = 1e-9 # \xff\n", "not UTF-8 text"),
    ("[heavy_top]\nexact = inf\n", "must be positive and finite"),
    ("[heavy_top]\nslip = 1e-3\n", "the scene makes no slip check"),
])
def test_bad_requirements_file_is_exit_2(tmp_path, capsys, text, fragment):
    tol = tmp_path / "tol.toml"
    (tol.write_bytes if isinstance(text, bytes) else tol.write_text)(text)
    code, _, err, reports = _validate(["--scenes", "heavy_top", "--requirements", str(tol)], tmp_path, capsys)
    assert_one_line_error(code, err, fragment)
    assert str(tol) in err and not reports.exists()


@pytest.mark.parametrize("args,fragment", [
    (["simulate", "double_pendulum", "--engine", "mujoco", "--set", "L=1e300"], "parameter 'L' = '1e300' is beyond +-1e+100"),
    (["simulate", "double_pendulum", "--engine", "mujoco", "--set", "L=-1e101"], "parameter 'L' = '-1e101' is beyond"),
    (["simulate", "torque_free", "--engine", "mujoco", "--t-end", "1e9"], "--t-end and --save-every"),
    (["simulate", "torque_free", "--engine", "inhouse", "--dt", "1e-12"],
     "--t-end and --dt: a horizon of 10 s at a step of 1e-12 s is 1e+13 integration steps, more than the 1e+08"),
    (["simulate", "torque_free", "--engine", "drake", "--integrator", "RK2", "--dt", "1e-12"],
     "is 1e+13 integration steps, more than the 1e+08 a run may take"),
    (["simulate", "torque_free", "--engine", "mujoco", "--dt", "1e-12"],  # MuJoCo's 32-bit step count: a traceback
     "is 1e+13 integration steps, more than the 1e+08 a run may take"),
    (["simulate", "torque_free", "--engine", "mujoco", "--t-end", "inf"], "argument --t-end: not a finite number"),
    (["simulate", "torque_free", "--engine", "inhouse", "--integrator", "DOP853", "--rtol", "0"], "--rtol must be positive"),
    (["simulate", "torque_free", "--engine", "mujoco", "--models-dir", "/nonexistent/models"], "no such folder"),
    (["simulate", "heavy_top", "--engine", "exudyn", "--integrator", "RK44"],
     "exudyn cannot run heavy_top with RK44: RK44: Exudyn's explicit solvers take no algebraic equations"),
])
def test_simulate_out_of_range_is_exit_2(tmp_path, capsys, args, fragment):
    out_file = tmp_path / "x.csv"
    code, _, err = run(args + ["--out", str(out_file)], capsys)
    assert_one_line_error(code, err, fragment)
    assert not out_file.exists()


def test_simulate_a_scene_the_compiled_form_does_not_model_is_exit_2(tmp_path, capsys, monkeypatch):
    from harness.engines.inhouse.compiled import solver

    def refuse(nem):  # it models every scene today: made to refuse one
        raise NotImplementedError("the compiled in-house solver does not model rolling contacts")

    monkeypatch.setattr(solver, "pack", refuse)
    out_file = tmp_path / "x.csv"
    code, _, err = run(["simulate", "rolling_disk", "--engine", "inhouse", "--integrator", "rk4_compiled", "--out",
                        str(out_file)], capsys)
    assert_one_line_error(code, err, "inhouse cannot run rolling_disk")
    assert not out_file.exists()


def test_simulate_fast_runs_the_compiled_twin(tmp_path, capsys):
    out_file = tmp_path / "tf.csv"
    code, out, _ = run(["simulate", "torque_free", "--engine", "inhouse", "--fast", "--t-end", "0.1",
                        "--out", str(out_file)], capsys)
    assert code == 0 and "inhouse/rk4_compiled" in out, out
    code, out, _ = run(["simulate", "torque_free", "--engine", "inhouse", "--t-end", "0.1", "--out", str(out_file)],
                       capsys)
    assert code == 0 and "inhouse/rk4," in out, out  # without --fast: the scene's per-state default


def test_simulate_fast_on_another_engine_is_exit_2(tmp_path, capsys):
    out_file = tmp_path / "x.csv"
    code, _, err = run(["simulate", "torque_free", "--engine", "mujoco", "--fast", "--out", str(out_file)], capsys)
    assert_one_line_error(code, err, "--fast selects the in-house engine's compiled methods; mujoco has none")
    assert not out_file.exists()


def test_validate_overflowing_parameter_is_exit_2(tmp_path, capsys):
    code, _, err, reports = _validate(["--scenes", "double_pendulum", "--engines", "mujoco", "--set", "L=1e300"],
                                      tmp_path, capsys)
    assert_one_line_error(code, err, "parameter 'L' = '1e300' is beyond +-1e+100")
    assert not reports.exists()


def test_debug_huge_horizon_is_exit_2(tmp_path, capsys):
    code, _, err = run(["debug", "torque_free", "--engines", "mujoco,pinocchio", "--t-end", "1e9",
                        "--out-dir", str(tmp_path / "d")], capsys)
    assert_one_line_error(code, err, "--t-end: a horizon of 1e+09 s")
    assert not (tmp_path / "d").exists()


def test_non_finite_values_are_a_blowup_not_ok(tmp_path, capsys, monkeypatch):
    """An engine that reports ok while a velocity went non-finite (here: the in-house run with an
    inf put into sample 3): the CLI reports a blow-up, exit 1, and writes only samples 0-2."""
    from dataclasses import replace

    from harness.engines.inhouse import ENGINE

    real = ENGINE.simulate

    def misses_blowup(scene, settings):
        traj = real(scene, settings)
        v = traj.v_WCm_W.copy()
        v[3, 0, 0] = np.inf
        return replace(traj, v_WCm_W=v)

    monkeypatch.setattr(ENGINE, "simulate", misses_blowup)
    out_file = tmp_path / "top.csv"
    code, out, err = run(["simulate", "torque_free", "--engine", "inhouse", "--t-end", "0.1", "--out", str(out_file)],
                         capsys)
    assert code == 1, (out, err)
    assert "status blowup (non-finite kinetic, energy, px and " in out and "at t = 0.03 s" in out, out
    frame = pd.read_csv(out_file)
    assert list(frame["t"]) == pytest.approx([0.0, 0.01, 0.02])
    assert np.isfinite(frame.to_numpy(dtype=float)).all()


def test_failed_run_writes_no_inf(tmp_path, capsys):
    """A huge pendulum rate (1e100 rad/s on a 1e5 m rod of 1e100 kg): the in-house engine's speed
    guard ends the run as a blow-up at t = 0 (the kinetic energy would overflow); the CSV holds
    no inf."""
    out_file = tmp_path / "cart.csv"
    code, out, err = run(["simulate", "cart_pendulum", "--engine", "inhouse", "--set", "m=1e100", "--set", "L=1e5",
                          "--set", "dtheta0=1e100", "--t-end", "0.1", "--out", str(out_file)], capsys)
    assert code == 1 and "Traceback" not in err
    assert "status blowup (speed 1e+105 m/s beyond 1e+08 at t = 0 s)" in out, out
    frame = pd.read_csv(out_file)
    assert list(frame.columns[:4]) == ["t", "kinetic", "potential", "energy"]
    assert np.isfinite(frame.to_numpy(dtype=float)).all()


def test_finite_rows_cuts_at_the_first_non_finite_value():
    from harness.cli.main import finite_rows

    frame = pd.DataFrame({"t": [0.0, 0.1, 0.2, 0.3], "energy": [1.0, 1.0, float("inf"), 1.0],
                          "b.x": [0.0, 0.0, float("nan"), float("nan")]})
    kept, message = finite_rows(frame)
    assert list(kept["t"]) == [0.0, 0.1]
    assert message == "non-finite energy, b.x at t = 0.2 s"
    same, none = finite_rows(frame.iloc[:2])
    assert none == "" and len(same) == 2


def test_diverging_check_is_exit_2(tmp_path, capsys, monkeypatch):
    """A free motion that diverges inside the linear algebra ends as one line, exit 2."""
    import harness.tools.check as check_module

    def diverges(*args, **kwargs):
        raise np.linalg.LinAlgError("Singular matrix")

    monkeypatch.setattr(check_module, "run_check", diverges)
    urdf = MODELS_DIR / "heavy_top" / "heavy_top.urdf"
    code, _, err = run(["check", "--urdf", str(urdf), "--out-dir", str(tmp_path / "r")], capsys)
    assert_one_line_error(code, err, f"{urdf}: the comparison diverged (LinAlgError: Singular matrix)")
    assert not (tmp_path / "r").exists()


def test_diverging_free_motion_in_check_is_a_failure_not_a_traceback(tmp_path, capfd):
    """A real divergence (RKMK4 at a 0.5 s step for 50 s): the non-finite motion is a failed
    comparison (exit 1, report written, an unexplained disagreement), never a traceback and never a pass."""
    urdf = MODELS_DIR / "double_pendulum" / "double_pendulum.urdf"
    code = main(["check", "--urdf", str(urdf), "--dt", "0.5", "--t-end", "50", "--out-dir", str(tmp_path / "r")])
    err = capfd.readouterr().err
    assert code == 1 and "Traceback" not in err
    (report,) = (tmp_path / "r").glob("check_*.md")
    assert "read(s) free motion differently, unexplained" in report.read_text()


@pytest.mark.parametrize("exc,fragment", [
    (OverflowError("(34, 'Numerical result out of range')"), "a value overflows (OverflowError"),
    (MemoryError(), "out of memory"),
    (UnicodeDecodeError("utf-8", b"\xff", 0, 1, "invalid start byte"), "a file is not UTF-8 text"),
])
def test_boundary_turns_input_caused_failures_into_one_line(capsys, monkeypatch, exc, fragment):
    import harness.cli.main as cli

    def boom(args):
        raise exc

    monkeypatch.setitem(cli.COMMANDS, "scenes", boom)
    code, _, err = run(["scenes"], capsys)
    assert_one_line_error(code, err, fragment)


# ---------------------------------------------------------------- help

def _subparsers():
    from harness.cli.main import build_parser

    parser = build_parser()
    action = next(a for a in parser._actions if a.dest == "command")
    return action.choices


def test_every_command_and_option_has_help():
    import argparse

    commands = _subparsers()
    assert {"scenes", "simulate", "validate", "inspect", "debug", "check", "workprecision", "stress",
            "rolling-study"} <= set(commands)
    missing = [f"{name} {a.option_strings or a.dest}" for name, sub in commands.items() for a in sub._actions
               if not isinstance(a, argparse._HelpAction) and not (a.help and a.help.strip())]
    assert missing == []


def test_option_help_states_units_and_defaults():
    commands = _subparsers()
    helps = {a.dest: a.help for a in commands["simulate"]._actions}
    assert "(s," in helps["t_end"] and "(s," in helps["dt"] and "(s;" in helps["save_every"]
    assert "inhouse" in helps["engine"] and "mujoco" in helps["engine"] and "pinocchio" in helps["engine"]
    from harness.engines.base import ERROR_CONTROL_TOL

    assert f"default {ERROR_CONTROL_TOL:g}" in helps["rtol"]  # validate's, one definition


def test_simulate_help_lists_every_option(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["simulate", "--help"])
    assert stop.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    for option in ("--engine", "--set", "--t-end", "--dt", "--integrator", "--save-every", "--rtol", "--atol",
                   "--out", "--models-dir"):
        assert option in text
    from harness.engines.base import ERROR_CONTROL_TOL

    assert "horizon (s" in text and f"default {ERROR_CONTROL_TOL:g}" in text


@pytest.mark.parametrize("args,fragment", [
    (["workprecision", "--engines", ","], "--engines selects nothing"),
    (["workprecision", "--models-dir", "{empty}"], "nothing to run: no scenes under"),
    (["workprecision", "--t-end", "inf"], "argument --t-end: not a finite number"),
    (["workprecision", "--saves", "100000000"], "--saves out of range"),
    (["stress", "--variants", ","], "--variants selects nothing"),
    (["rolling-study", "--models-dir", "{tmp}/nope"], "argument --models-dir: no such folder"),
    (["inspect", "heavy_top", "--models-dir", "{tmp}/nope"], "argument --models-dir: no such folder"),
])
def test_studies_over_nothing_are_exit_2(tmp_path, capsys, args, fragment):
    (tmp_path / "empty").mkdir()
    args = [a.replace("{empty}", str(tmp_path / "empty")).replace("{tmp}", str(tmp_path)) for a in args]
    out = tmp_path / "out"
    code, _, err = run(args + (["--out-dir", str(out)] if args[0] != "inspect" else []), capsys)
    assert_one_line_error(code, err, fragment)
    assert not out.exists()


@pytest.mark.slow
def test_subset_validation_never_replaces_the_full_snapshot(tmp_path, capsys, monkeypatch):
    """A run with --scenes writes to reports/partial/validate, leaving reports/ as it was; a
    read-only output folder is refused before anything runs."""
    monkeypatch.chdir(tmp_path)
    snapshot = tmp_path / "reports" / "validation.md"
    snapshot.parent.mkdir()
    snapshot.write_text("the committed snapshot\n")
    assert main(["validate", "--scenes", "rotating_plate", "--engines", "mujoco"]) == 0
    assert snapshot.read_text() == "the committed snapshot\n"
    partial = tmp_path / "reports" / "partial" / "validate" / "validation.md"
    assert "Reproduce with `harness validate --scenes rotating_plate --engines mujoco`" in partial.read_text()
    assert (partial.stat().st_mode & 0o777) == 0o666 & ~_umask()


def test_per_state_validation_is_a_partial_run(tmp_path, monkeypatch):
    """--per-state runs the in-house oracle instead of the compiled twins: not the snapshot's run."""
    from harness.cli.arg_types import out_dir
    from harness.cli.main import VALIDATE_SUBSET, build_parser

    monkeypatch.chdir(tmp_path)
    full, oracle = (build_parser().parse_args(["validate", *extra]) for extra in ([], ["--per-state"]))
    assert not full.per_state and oracle.per_state
    assert out_dir(full, "validate", VALIDATE_SUBSET).parts[-1] == "reports"
    assert out_dir(oracle, "validate", VALIDATE_SUBSET).parts[-2:] == ("partial", "validate")


def _umask() -> int:
    import os

    mask = os.umask(0)
    os.umask(mask)
    return mask


def test_unwritable_output_folder_is_refused_before_the_run(tmp_path, capsys, monkeypatch):
    import harness.validate.run as run

    blocker = tmp_path / "file"
    blocker.write_text("")  # a file where the output folder should be
    monkeypatch.setattr(run, "validate", lambda *a, **k: pytest.fail("validation ran before the folder was checked"))
    code = main(["validate", "--scenes", "rotating_plate", "--engines", "mujoco", "--out-dir", str(blocker / "out")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and str(blocker) in err


@pytest.mark.parametrize("command", [["validate"], ["stress"], ["workprecision"], ["rolling-study"],
                                     ["check", "--mjcf", "x.xml"]])
def test_quiet_is_an_option_of_the_long_commands(command):
    from harness.cli.main import build_parser

    parser = build_parser()
    assert parser.parse_args(command + ["--quiet"]).quiet is True
    assert parser.parse_args(command).quiet is False


def test_no_progress_is_quiet_for_workprecision():
    from harness.cli.main import build_parser
    from harness.cli.workprecision import options_from_args

    args = build_parser().parse_args(["workprecision", "--no-progress"])
    assert args.quiet is True and options_from_args(args).progress is False
    assert options_from_args(build_parser().parse_args(["workprecision"])).progress is True


def test_quiet_lasts_one_command(tmp_path, capsys, monkeypatch):
    from harness.io import progress

    seen = []
    monkeypatch.setitem(__import__("harness.cli.main", fromlist=["COMMANDS"]).COMMANDS, "scenes",
                        lambda args: seen.append(progress.is_quiet()) or 0)
    assert main(["validate", "--quiet", "--scenes", "no_such_scene", "--out-dir", str(tmp_path)]) == 2
    assert not progress.is_quiet()  # reset after the command, even after an error
    assert main(["scenes"]) == 0 and seen == [False]


def test_check_refuses_more_steps_than_the_budget(tmp_path, capsys):
    """``harness check --dt`` is held to MAX_STEPS before any model is loaded or run."""
    out = tmp_path / "reports"
    code, _, err = run(["check", "--urdf", str(MODELS_DIR / "heavy_top" / "heavy_top.urdf"), "--dt", "1e-9",
                        "--out-dir", str(out)], capsys)
    assert_one_line_error(code, err, "--t-end and --dt: a horizon of 0.5 s at a step of 1e-09 s is 5e+08 integration "
                                     "steps, more than the 1e+08")
    assert not out.exists()


@pytest.mark.parametrize("engine", ["inhouse", "mujoco", "pinocchio", "exudyn", "drake"])
def test_simulate_runs_each_engine_as_validate_does(engine):
    """One set of defaults: simulate's settings without options are validate's for every engine
    (integrator, step, horizon, save interval, rtol and atol; validate's per-state in-house method,
    as simulate runs it without --fast), and the --rtol/--atol defaults are that one definition."""
    from harness.cli.main import build_parser, simulate_settings
    from harness.engines.base import ERROR_CONTROL_ATOL, ERROR_CONTROL_TOL
    from harness.engines import load_scene
    from harness.validate.run import default_settings

    args = build_parser().parse_args(["simulate", "heavy_top", "--engine", engine, "--out", "x.csv"])
    scene = load_scene("heavy_top")
    assert simulate_settings(args, scene) == default_settings(scene, engine, fast=False)
    assert (args.rtol, args.atol) == (ERROR_CONTROL_TOL, ERROR_CONTROL_ATOL)
