"""``harness debug``: first times a quantity leaves its tolerance, the state dump, the plot; each
quantity judged exactly as ``harness validate`` judges it."""

import shutil
from dataclasses import replace

import numpy as np
import pytest

from harness.tools import debug as debug_run
from harness.cli.main import main
from harness.model.scene import MODELS_DIR, load_scene
from harness.validate import quantities
from harness.validate.run import validate

PNG = b"\x89PNG\r\n\x1a\n"


def run(args, capsys):
    code = main(args)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_agreeing_engines_exit_0_and_plot(tmp_path, capsys):
    code, out, _ = run(["debug", "heavy_top", "--engines", "mujoco,pinocchio", "--t-end", "0.5",
                        "--out-dir", str(tmp_path)], capsys)
    assert code == 0, out
    for q in debug_run.QUANTITIES:
        assert f"{q}" in out
    assert out.count("within tolerance") == 5
    png = tmp_path / "debug_heavy_top_mujoco_pinocchio.png"
    assert png.read_bytes().startswith(PNG)
    assert not list(tmp_path.glob(".*.tmp"))


def test_diverging_run_names_first_times_and_dumps_states(tmp_path, capsys):
    models = tmp_path / "models"
    shutil.copytree(MODELS_DIR / "double_pendulum", models / "double_pendulum")
    toml = models / "double_pendulum" / "scene.toml"
    toml.write_text(toml.read_text().replace('mujoco = "RK4"', 'mujoco = "Euler"'))  # first order: leaves at once
    out_dir = tmp_path / "out"
    code, out, _ = run(["debug", "double_pendulum", "--engines", "reference,mujoco", "--t-end", "0.5",
                        "--models-dir", str(models), "--out-dir", str(out_dir)], capsys)
    assert code == 1
    assert "first leaves 1.0e-06 rel at t = 0.01 s" in out  # position over the length scale, first saved time after 0
    assert "states at t = 0.01 s" in out
    for body in ("bar1", "bar2"):
        assert sum(ln.strip().startswith(body) for ln in out.splitlines()) == 3  # reference, mujoco, difference
    assert (out_dir / "debug_double_pendulum_reference_mujoco.png").read_bytes().startswith(PNG)


def test_energy_tolerance_is_the_sum_of_the_drift_tolerances():
    scene = load_scene("heavy_top")
    tol = debug_run.tolerances(scene, ("reference", "mujoco"))
    assert tol["energy"] == pytest.approx(2e-8)
    assert tol["angular_velocity"] == tol["velocity"] == 1e-4


def test_tolerances_are_validates():
    scene = load_scene("rolling_disk")  # a tolerance per engine
    traj = scene.checks["trajectory"]
    assert debug_run.tolerances(scene, ("reference", "mujoco"))["position"] == traj["position"]["mujoco"]
    assert debug_run.tolerances(scene, ("inhouse", "reference"))["angular_velocity"] == traj["velocity"]["inhouse"]
    # two engines: the larger of the two (never looser than either engine's own check against the reference)
    assert debug_run.tolerances(scene, ("pinocchio", "mujoco"))["orientation"] == traj["orientation"]["mujoco"]
    assert debug_run.UNITS == {"position": "rel", "orientation": "rad", "velocity": "rel", "angular_velocity": "rel",
                               "energy": "rel"}


@pytest.mark.parametrize("name,engine", [("rolling_disk", "inhouse"), ("heavy_top", "mujoco")])
def test_debug_and_validate_give_the_same_value_and_verdict(name, engine):
    """The brief's cases: rolling_disk's angular velocity (absolute in debug, relative in validate,
    once) and heavy_top's position (10x looser in debug, once); on a shortened horizon."""
    scene = replace(load_scene(name), t_end=0.2)
    res = debug_run.debug(scene, (engine, "reference"))
    (val,) = validate([scene], [engine], jobs=1)
    checks = {c.check: c for c in val.checks if c.engine == engine}
    for q in quantities.TRAJECTORY:
        c = checks[q.check]
        assert res.worst(q.name) == pytest.approx(c.value, rel=1e-12, abs=0.0), q.name
        assert res.tolerances[q.name] == c.tolerance and debug_run.UNITS[q.name] == c.unit
        assert (res.first_exceed[q.name] is None) == c.passed
    assert res.passed == all(checks[q.check].passed for q in quantities.TRAJECTORY)


def test_debug_prints_the_judged_and_the_raw_value(capsys, tmp_path):
    code, out, _ = run(["debug", "rolling_disk", "--engines", "inhouse,reference", "--t-end", "0.2",
                        "--out-dir", str(tmp_path)], capsys)
    assert code == 0, out
    line = next(ln for ln in out.splitlines() if ln.strip().startswith("angular_velocity"))
    tol = load_scene("rolling_disk").checks["trajectory"]["velocity"]["inhouse"]  # velocity's entry judges both
    assert " rel (" in line and f" rad/s) <= {tol:.1e}: within tolerance" in line
    assert "motion scales of the reference run" in out


def test_error_series_is_zero_for_identical_runs():
    scene = load_scene("double_pendulum")
    traj = debug_run.run_engine(scene, "mujoco", 0.05)
    t, errors = debug_run.error_series(traj, traj, scene.multibody())
    assert len(t) == 6 and all(np.all(e == 0) for e in errors.values())


@pytest.mark.parametrize("engines,fragment", [
    ("mujoco", "two different engines"),
    ("mujoco,mujoco", "two different engines"),
    ("mujoco,bullet", "unknown engine 'bullet'"),
])
def test_bad_engines_exit_2(tmp_path, capsys, engines, fragment):
    code, _, err = run(["debug", "heavy_top", "--engines", engines, "--out-dir", str(tmp_path / "o")], capsys)
    assert code == 2 and fragment in err and err.count("\n") == 1
    assert not (tmp_path / "o").exists()


def test_horizon_not_a_multiple_of_the_save_interval_exit_2(tmp_path, capsys):
    code, _, err = run(["debug", "heavy_top", "--engines", "mujoco,pinocchio", "--t-end", "0.0123",
                        "--out-dir", str(tmp_path / "o")], capsys)
    assert code == 2 and "not a whole multiple" in err
    assert not (tmp_path / "o").exists()
