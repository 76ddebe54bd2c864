"""``harness debug``: each quantity's error model per engine (``validate``'s verdicts by
convergence), the first time the runs part beyond 10x the resolution or a requirement, the state
dump, the plot."""

import shutil
from dataclasses import replace

import numpy as np
import pytest

from harness.tools import debug as debug_run
from harness.cli.main import main
from harness.model.scene import MODELS_DIR
from harness.engines import load_scene
from harness.judging import quantities
from harness.judging.checks import CheckResult
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
    lines = out.splitlines()
    for q in debug_run.QUANTITIES:
        line = next(ln for ln in lines if ln.strip().startswith(q + " "))
        assert line.endswith(": passes") and "x the resolution)" in line, line
    for e in ("mujoco", "pinocchio"):  # each engine's error model of each quantity: RK4 / RKMK4 converge at order 4
        models = [ln for ln in lines if ln.startswith(f"      {e}: ")]  # the model lines, under each quantity
        assert len(models) == 5 and all(" converges, passes (" in ln for ln in models), models
    assert "FAILS" not in out and "order 4." in out
    png = tmp_path / "debug_heavy_top_mujoco_pinocchio.png"
    assert png.read_bytes().startswith(PNG)
    assert not list(tmp_path.glob(".*.tmp"))


def test_a_first_order_method_converges_and_a_requirement_fails_it(tmp_path, capsys):
    """MuJoCo's Euler is first order: its error converges at the method's order and passes;
    a requirement of the scene on the position fails it, and the runs part at the requirement."""
    models = tmp_path / "models"
    shutil.copytree(MODELS_DIR / "double_pendulum", models / "double_pendulum")
    toml = models / "double_pendulum" / "scene.toml"
    toml.write_text(toml.read_text() + '\n[integrators]\nmujoco = "Euler"\n')
    args = ["debug", "double_pendulum", "--engines", "reference,mujoco", "--t-end", "0.5", "--models-dir", str(models)]
    code, out, _ = run([*args, "--out-dir", str(tmp_path / "a")], capsys)
    assert code == 0, out
    assert "mujoco: trajectory.position converges, passes" in out and "(method's 1)" in out
    toml.write_text(toml.read_text() + '\n[requirements]\n"trajectory.position" = 1e-6\n')
    out_dir = tmp_path / "out"
    code, out, _ = run([*args, "--out-dir", str(out_dir)], capsys)
    assert code == 1, out
    line = next(ln for ln in out.splitlines() if ln.strip().startswith("position "))
    assert "parts beyond 1.0e-06 rel (the scene's requirement) at t = 0.01 s: FAILS" in line, line  # first saved time after 0
    assert "mujoco: trajectory.position converges, FAILS" in out and "beyond the requirement" in out
    assert "states at t = 0.01 s" in out
    for body in ("bar1", "bar2"):
        assert sum(ln.strip().startswith(body) for ln in out.splitlines()) == 3  # reference, mujoco, difference
    assert (out_dir / "debug_double_pendulum_reference_mujoco.png").read_bytes().startswith(PNG)


def _check(check, resolution, passed=True, cls="converges"):
    return CheckResult("s", "e", check, 1e-6, float("inf"), "rel", passed, classification=cls, resolution=resolution)


def test_the_threshold_is_10x_the_resolution_or_the_requirement():
    scene = load_scene("heavy_top")
    judged = {"mujoco": _check("trajectory.position", 1e-9), "pinocchio": _check("trajectory.position", 3e-9)}
    assert debug_run.threshold(scene, judged) == pytest.approx(3e-8)  # the pair's larger resolution
    assert debug_run.threshold(replace(scene, requirements={"trajectory": 1e-6}), judged) == 1e-6
    assert debug_run.threshold(replace(scene, requirements={"trajectory.position": 1e-12}), judged) == pytest.approx(3e-8)
    assert debug_run.threshold(scene, {}) is None
    assert debug_run.threshold(scene, {"mujoco": _check("trajectory.position", float("nan"))}) is None
    checks = [_check("energy_balance", 1e-9), _check("trajectory.velocity", 1e-9), _check("exact", 1e-9)]
    assert {q: c.check for q, c in debug_run.quantity_checks(checks).items()} == {
        "velocity": "trajectory.velocity", "energy": "energy_balance"}
    assert debug_run.UNITS == {"position": "rel", "orientation": "rad", "velocity": "rel", "angular_velocity": "rel",
                               "energy": "rel"}


@pytest.mark.parametrize("name,engine", [("rolling_disk", "inhouse"), ("heavy_top", "mujoco")])
def test_debug_and_validate_give_the_same_value_and_verdict(name, engine):
    """Against the reference, each quantity's largest value and its error model are validate's
    ``trajectory.*`` check of the engine (on a shortened horizon)."""
    scene = replace(load_scene(name), t_end=0.2)
    res = debug_run.debug(scene, (engine, "reference"))
    (val,) = validate([scene], [engine], jobs=1)
    checks = {c.check: c for c in val.checks if c.engine == engine}
    for q in quantities.TRAJECTORY:
        c, mine = checks[q.check], res.models[q.name][engine]
        assert res.worst(q.name) == pytest.approx(c.value, rel=1e-12, abs=0.0), q.name
        assert mine.value == pytest.approx(c.value, rel=1e-12) and debug_run.UNITS[q.name] == c.unit
        assert (mine.classification, mine.passed, mine.resolution) == (c.classification, c.passed, c.resolution)
        assert c.classification and res.thresholds[q.name] >= 10 * c.resolution
        assert list(res.models[q.name]) == [engine]  # the reference has no trajectory check of its own
    assert res.passed == all(checks[q.check].passed for q in quantities.TRAJECTORY) and res.passed


def test_debug_prints_the_judged_and_the_raw_value(capsys, tmp_path):
    code, out, _ = run(["debug", "rolling_disk", "--engines", "inhouse,reference", "--t-end", "0.2",
                        "--out-dir", str(tmp_path)], capsys)
    assert code == 0, out
    line = next(ln for ln in out.splitlines() if ln.strip().startswith("angular_velocity"))
    assert " rel (" in line and " rad/s); " in line
    assert "motion scales of the reference run" in out
    assert "inhouse: trajectory.angular_velocity converges, passes" in out


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
