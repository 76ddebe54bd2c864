"""Validation: checks per scene, the model files judged as written, isolation of a crashing
engine, reports, JUnit, tolerance file."""

import json
import os
import re
import shutil
import signal
import time
import xml.etree.ElementTree as ET

import pytest

from harness.cli.main import main
from harness.engines.mujoco.engine import MujocoEngine
from harness.model.scene import MODELS_DIR, available_scenes
from harness.engines import load_scene
from harness.judging import quantities
from harness.model.errors import InputError
from harness.validate.run import model_checks, validate

SHORT = {"t_end": 0.5}


def short(name, **overrides):
    from dataclasses import replace

    return replace(load_scene(name, overrides), t_end=0.5)


def test_validate_passes_and_checks_only_what_the_scene_needs():
    (res,) = validate([short("heavy_top")], ["mujoco"], jobs=1)
    names = {c.check for c in res.checks if c.engine == "mujoco"}
    assert res.passed, [c for c in res.checks if not c.passed]
    assert "momentum_drift.Lz" in names and "momentum_drift.L3" in names
    assert not any(n.startswith("momentum_drift.p") for n in names)  # gravity and the tip act
    assert "constraint.position" in names and "exact" in names


def test_a_scene_without_a_check_against_the_reference_has_no_reference_run():
    """four_bar_chain declares no check against a reference run (no trajectory check: its closed
    form judges every engine): no reference run is made (listed as not run, with why), and each
    engine's checks are made and judged by how they converge, its exact check against the closed
    form. Where the scene's [not_run] names the reference engine, that is the reason given."""
    from dataclasses import replace

    scene = replace(load_scene("four_bar_chain", {"N": 1}), t_end=1.0)
    (res,) = validate([scene], ["mujoco", "inhouse"], jobs=1)
    assert "declares no check against a reference run" in res.not_run["reference"]
    assert [r.engine for r in res.runs] == ["mujoco", "inhouse"]
    for engine in ("mujoco", "inhouse"):
        exact = next(c for c in res.checks if c.engine == engine and c.check == "exact")
        assert exact.classification and exact.levels and exact.unit == "m" and exact.passed
    assert not any(c.check.startswith("trajectory") or c.check == "run" for c in res.checks)
    (res,) = validate([replace(scene, not_run={"inhouse": "a finding"})], ["mujoco", "inhouse"], jobs=1)
    assert {"reference", "inhouse"} <= set(res.not_run) and "does not run this scene" in res.not_run["reference"]


def test_a_scene_states_its_own_case_timeout(tmp_path):
    """four_bar_chain's [simulation] timeout lifts validate's per-case limit for its cases (where
    larger than --timeout); a non-positive one is refused at load."""
    import shutil

    from harness.model.scene import MODELS_DIR

    assert load_scene("four_bar_chain").timeout >= 1200.0 and load_scene("pendulum").timeout is None
    models = tmp_path / "models"
    shutil.copytree(MODELS_DIR / "four_bar_chain", models / "four_bar_chain")
    toml = models / "four_bar_chain" / "scene.toml"
    toml.write_text(re.sub(r"timeout = \d+", "timeout = -1", toml.read_text()))
    with pytest.raises(InputError, match=r"\[simulation\] timeout"):
        load_scene("four_bar_chain", models_dir=models)


def test_in_house_runs_use_the_compiled_twins_unless_per_state():
    scene = short("heavy_top")
    (fast,) = validate([scene], ["inhouse"], jobs=1)
    (oracle,) = validate([scene], ["inhouse"], jobs=1, fast=False)
    methods = lambda res: {r.engine: r.integrator for r in res.runs}  # noqa: E731
    assert methods(fast) == {"reference": "dop853_compiled", "inhouse": "rk4_compiled"}
    assert methods(oracle) == {"reference": "DOP853", "inhouse": "rk4"}
    assert fast.passed and oracle.passed
    # the same method compiled: the in-house run's errors against the reference agree (the two
    # references differ by their drift control, both far below the rk4 run's own error)
    value = lambda res, name: next(c.value for c in res.checks if c.engine == "inhouse" and c.check == name)  # noqa: E731
    for name in ("trajectory.position", "trajectory.orientation", "trajectory.velocity"):
        assert value(fast, name) == pytest.approx(value(oracle, name), rel=1e-2), name  # 1.1e-3 measured


def test_drake_holds_its_tolerances_away_from_the_default_release_angle():
    """Drake's RK5 runs at ERROR_CONTROL_TOL: at 1e-10 it left plate_pendulum's orientation
    tolerance (2e-9 rad) 300x at theta0 = 2.5 rad over the scene's 5 s (6.1e-7 rad), 35x over the
    2 s run here, a release beyond the top whose closed form is the libration about the bottom
    nearest it."""
    from dataclasses import replace

    from harness.validate.run import ERROR_CONTROL_TOL, default_settings

    scene = replace(load_scene("plate_pendulum", {"theta0": 2.5}), t_end=2.0)
    assert default_settings(scene, "drake").rtol == ERROR_CONTROL_TOL
    (res,) = validate([scene], ["drake"], jobs=1)
    assert res.passed, [c for c in res.checks if not c.passed]
    exact = next(c for c in res.checks if c.engine == "reference" and c.check == "exact")
    assert exact.value < exact.tolerance  # the closed form covers the start beyond pi


def test_forced_pendulum_checks_energy_balance_not_conservation():
    (res,) = validate([short("double_pendulum", F0=2.0, omega_f=3.0)], ["pinocchio"], jobs=1)
    names = {c.check for c in res.checks if c.engine == "pinocchio"}
    assert "energy_balance" in names and "energy_drift" not in names
    assert res.passed, [c for c in res.checks if not c.passed]
    # the overrides reach the runs (energy balance above), the file is judged at the defaults, and
    # the result says which parameters the overrides set
    assert res.overrides == {"F0": {"value": 2.0, "default": 0.0}, "omega_f": {"value": 3.0, "default": 0.0}}
    assert {"model.bar1.mass", "model.bar2.inertia"} <= names


def test_a_killed_engine_worker_leaves_the_other_results(monkeypatch):
    def die(self, scene, settings):
        os.kill(os.getpid(), signal.SIGKILL)

    monkeypatch.setattr(MujocoEngine, "simulate", die)  # inherited by the forked worker
    (res,) = validate([short("torque_free")], ["mujoco", "pinocchio"], jobs=2)
    run = [c for c in res.checks if c.engine == "mujoco" and not c.check.startswith("model.")]
    assert len(run) == 1 and run[0].check == "run" and not run[0].passed
    assert "crashed" in run[0].detail
    pin_checks = [c for c in res.checks if c.engine == "pinocchio"]
    assert len(pin_checks) > 5 and all(c.passed for c in pin_checks)


def test_a_hanging_engine_times_out(monkeypatch):
    import time

    monkeypatch.setattr(MujocoEngine, "simulate", lambda self, s, st: time.sleep(60))
    (res,) = validate([short("torque_free")], ["mujoco"], jobs=1, timeout=3.0)
    assert [c.detail.split(":")[0] for c in res.checks if c.engine == "mujoco" and not c.check.startswith("model.")] == ["timeout"]


def test_cli_writes_reports_junit_and_exit_codes(tmp_path, capsys):
    out = tmp_path / "reports"
    code = main(["validate", "--scenes", "heavy_top", "--engines", "mujoco", "--out-dir", str(out)])
    assert code == 0, capsys.readouterr()
    data = json.loads((out / "validation.json").read_text())
    assert data["passed"] and data["provenance"]["mujoco"]
    suite = ET.parse(out / "validation.junit.xml").getroot().find("testsuite")
    assert suite.get("name") == "heavy_top" and int(suite.get("failures")) == 0
    cases = suite.findall("testcase")
    assert {c.get("classname") for c in cases} == {"heavy_top.reference", "heavy_top.mujoco"}
    text = (out / "validation.md").read_text()
    assert "MuJoCo" in text
    # stamped with the load and the command's wall time (the snapshot's timings are read against them)
    assert re.search(r"load average [0-9.]+ \(1 min, at the end of the run\)\. The run took [0-9]+ s wall on", text)

    req = tmp_path / "req.toml"
    req.write_text("[heavy_top]\nenergy_drift = 1e-16\n")
    code = main(["validate", "--scenes", "heavy_top", "--engines", "mujoco", "--requirements", str(req), "--out-dir", str(out)])
    assert code == 1
    suite = ET.parse(out / "validation.junit.xml").getroot().find("testsuite")
    failed = [c for c in suite.findall("testcase") if c.find("failure") is not None]
    assert {(c.get("classname"), c.get("name")) for c in failed} == {("heavy_top.reference", "energy_drift"),
                                                                    ("heavy_top.mujoco", "energy_drift")}
    assert all(c.find("failure").get("type") == "requirement" for c in failed)
    assert "energy_drift <= 1e-16 (added)" in (out / "validation.md").read_text()


@pytest.mark.parametrize("text,fragment", [
    ("[heavy_top]\nmujco = 1e-9\n", "the harness has no check 'mujco'"),
    ("[heavy_top]\nslip = 1e-9\n", "the scene makes no slip check"),
    ("[heavy_tops]\nexact = 1e-9\n", "unknown scene 'heavy_tops'"),
    ("[heavy_top]\nexact = -1\n", "must be positive"),
    ("[heavy_top", "malformed TOML"),
])
def test_bad_requirements_file(tmp_path, capsys, text, fragment):
    req = tmp_path / "req.toml"
    req.write_text(text)
    code = main(["validate", "--scenes", "heavy_top", "--requirements", str(req), "--out-dir", str(tmp_path / "r")])
    err = capsys.readouterr().err
    assert code == 2 and fragment in err and str(req) in err and err.count("\n") == 1
    assert not (tmp_path / "r").exists()


# --------------------------------------------------------------------------- model files as written

BAR1_MJCF_INERTIAL = '<inertial pos="0 0 -0.5" mass="1" diaginertia="0.083358333333333 0.083358333333333 0.00005"/>'
BAR2_URDF_INERTIA = '<inertia ixx="0.083358333333333" ixy="0" ixz="0" iyy="0.083358333333333" iyz="0" izz="0.00005"/>'


def copy_double_pendulum(tmp_path, t_end=None):
    """A copy of models/double_pendulum (its horizon shortened in the copy's scene.toml)."""
    dst = tmp_path / "models"
    shutil.copytree(MODELS_DIR / "double_pendulum", dst / "double_pendulum")
    if t_end is not None:
        toml = dst / "double_pendulum" / "scene.toml"
        text = toml.read_text()
        assert "t_end = 10.0" in text
        toml.write_text(text.replace("t_end = 10.0", f"t_end = {t_end}"))
    return dst


def move_bar1_com(models):
    """bar1's centre of mass 2 cm further down the bar in the MJCF (the first <inertial> is bar1's)."""
    path = models / "double_pendulum" / "double_pendulum.xml"
    text = path.read_text()
    assert text.count(BAR1_MJCF_INERTIAL) == 2
    path.write_text(text.replace(BAR1_MJCF_INERTIAL, BAR1_MJCF_INERTIAL.replace('pos="0 0 -0.5"', 'pos="0 0 -0.52"'), 1))


def swap_bar2_inertia(models):
    """bar2's inertia diagonal swapped (ixx <-> izz) in the URDF."""
    path = models / "double_pendulum" / "double_pendulum.urdf"
    text = path.read_text()
    start = text.index('<link name="bar2">')
    swapped = '<inertia ixx="0.00005" ixy="0" ixz="0" iyy="0.083358333333333" iyz="0" izz="0.083358333333333"/>'
    assert BAR2_URDF_INERTIA in text[start:]
    path.write_text(text[:start] + text[start:].replace(BAR2_URDF_INERTIA, swapped, 1))


@pytest.mark.parametrize("name", available_scenes())
def test_every_scene_file_holds_its_defaults(name):
    scene = load_scene(name)
    t0 = time.perf_counter()
    checks = model_checks(scene, ["inhouse", "mujoco", "pinocchio"])
    wall = time.perf_counter() - t0
    assert checks and all(c.passed for c in checks), [c for c in checks if not c.passed]
    readers = {"mujoco", "pinocchio"} - set(scene.not_run)  # the in-house engine reads no file; a not-run engine none
    assert {c.engine for c in checks} == readers
    for body in scene.multibody().bodies:
        for engine in readers:
            names = {c.check for c in checks if c.engine == engine}
            assert {f"model.{body.name}.{q}" for q in ("mass", "com", "inertia", "joint_type")} <= names
    assert wall < 1.0, f"model check of {name} took {wall:.2f} s"


def test_a_moved_centre_of_mass_in_the_mjcf_is_a_failed_model_check(tmp_path):
    models = copy_double_pendulum(tmp_path)
    move_bar1_com(models)
    checks = model_checks(load_scene("double_pendulum", models_dir=models), ["mujoco", "pinocchio"])
    bad = [c for c in checks if not c.passed]
    assert [(c.engine, c.check) for c in bad] == [("mujoco", "model.bar1.com")]
    (c,) = bad
    # 2 cm over bar1's length scale, the larger of its centre-of-mass (0.5 m) and joint (0 m) distances
    assert c.value == pytest.approx(0.02 / 0.5, rel=1e-9) and c.unit == "rel"
    assert "[0.0, 0.0, -0.52]" in c.detail and "scene says [0.0, 0.0, -0.5]" in c.detail
    assert f"harness inspect double_pendulum --models-dir {models}" in c.detail


def test_a_swapped_inertia_in_the_urdf_is_a_failed_model_check(tmp_path):
    models = copy_double_pendulum(tmp_path)
    swap_bar2_inertia(models)
    checks = model_checks(load_scene("double_pendulum", models_dir=models), ["mujoco", "pinocchio"])
    bad = [c for c in checks if not c.passed]
    assert [(c.engine, c.check) for c in bad] == [("pinocchio", "model.bar2.inertia")]
    assert "[[5e-05, 0.0, 0.0]" in bad[0].detail and "double_pendulum.urdf as written" in bad[0].detail


def test_overrides_do_not_count_against_the_files():
    scene = load_scene("double_pendulum", {"m": 2.0, "L": 0.5})
    assert all(c.passed for c in model_checks(scene, ["mujoco", "pinocchio"]))


@pytest.mark.slow
@pytest.mark.parametrize("edit,engine,check", [
    (move_bar1_com, "mujoco", "model.bar1.com"),
    (swap_bar2_inertia, "pinocchio", "model.bar2.inertia"),
])
def test_validate_fails_on_a_wrong_model_file(tmp_path, capsys, edit, engine, check):
    models = copy_double_pendulum(tmp_path, t_end=0.5)
    out = tmp_path / "out"
    args = ["validate", "--scenes", "double_pendulum", "--engines", engine, "--models-dir", str(models), "--out-dir", str(out)]
    assert main(args) == 0, capsys.readouterr().out  # the unmodified copy passes
    edit(models)
    code = main(args)
    printed = capsys.readouterr().out
    assert code == 1
    assert f"FAIL {engine} {check}:" in printed and "harness inspect double_pendulum" in printed
    data = json.loads((out / "validation.json").read_text())
    failed = [(c["engine"], c["check"]) for s in data["scenes"] for c in s["checks"] if not c["passed"]]
    assert failed == [(engine, check)]  # the runs load the file with the scene's parameters: they still agree
    head = (out / "validation.md").read_text().split("\n## ")[0]  # the matrix, before the details
    assert "[double_pendulum](#double_pendulum--fail) **✗**" in head and "**✗ model file** · " in head
    assert f"`{check}`" in head


def test_a_check_table_holds_no_regression_bound(tmp_path):
    """Checks are judged by how their error converges (issue #30): a check table's
    ``regression_only`` (a bound that was what an engine reaches) is refused, and the quantities
    module has no tolerances left to read."""
    from harness.model.errors import InputError

    models = tmp_path / "models"
    shutil.copytree(MODELS_DIR / "heavy_top", models / "heavy_top")
    toml = models / "heavy_top" / "scene.toml"
    toml.write_text(toml.read_text().replace("[checks.energy_drift]\n", '[checks.energy_drift]\nregression_only = ["mujoco"]\n'))
    with pytest.raises(InputError, match=r"\[checks.energy_drift\] regression_only: a check holds no tolerance"):
        load_scene("heavy_top", models_dir=models)
    for gone in ("tolerance", "per_engine", "regression_only", "check_table"):
        assert not hasattr(quantities, gone), gone


def test_trajectory_checks_follow_the_shared_definition():
    """Each ``trajectory.*`` check in its shared unit, bounded by the scene's requirement on it
    (its own entry over its table's; none: inf) and judged by convergence."""
    import math
    from dataclasses import replace

    scene = replace(short("heavy_top"), requirements={"trajectory": 1.0, "trajectory.orientation": 1e-3})
    (res,) = validate([scene], ["pinocchio"], jobs=1)
    by_name = {c.check: c for c in res.checks if c.engine == "pinocchio"}
    for q in quantities.TRAJECTORY:
        c = by_name[q.check]
        assert c.unit == q.judged_unit
        assert c.tolerance == (1e-3 if q.name == "orientation" else 1.0), q.name
        assert c.classification == "converges" and c.passed and math.isfinite(c.resolution), q.name
    assert by_name["trajectory.position"].unit == "rel" and by_name["trajectory.orientation"].unit == "rad"
    assert by_name["energy_drift"].tolerance == math.inf  # no requirement on it


def _spoiled(scene, k, value, field="v_WCm_W"):
    """A sound in-house run of ``scene`` whose sample ``k`` has ``value`` in body 0's first
    component of ``field``, still reported "ok" (an engine that missed its blow-up)."""
    from dataclasses import replace


    from harness.engines.inhouse import ENGINE
    from harness.validate.run import default_settings

    settings = default_settings(scene, "inhouse")
    traj = ENGINE.simulate(scene, settings)
    arr = getattr(traj, field).copy()
    arr[k, 0, 0] = value
    return replace(traj, **{field: arr}), settings


@pytest.mark.parametrize("value, field, what", [
    (float("nan"), "v_WCm_W", "velocity"),   # a NaN state: NaN energy and momentum too
    (1e200, "v_WCm_W", "kinetic"),           # a finite state whose energy overflows to inf
    (float("inf"), "p_WCm_W", "position"),
])
def test_a_non_finite_sample_is_a_failed_run_check(value, field, what):
    from harness.measure.invariants import first_non_finite
    from harness.judging.checks import check_run

    scene = short("double_pendulum")
    traj, settings = _spoiled(scene, 7, value, field)
    assert traj.ok  # the engine said ok
    t_bad, found = first_non_finite(traj, scene.multibody())
    assert t_bad == pytest.approx(traj.t[7]) and what in found
    checks = check_run(scene, "inhouse", "inhouse", traj, None, settings)
    run = [c for c in checks if c.check == "run"]
    assert len(run) == 1 and not run[0].passed
    assert run[0].detail.startswith("blowup: ") and f"t = {traj.t[7]:.6g} s" in run[0].detail
    assert not any(c.passed for c in checks)


def test_a_finite_run_has_no_run_check():
    from harness.measure.invariants import first_non_finite
    from harness.judging.checks import check_run

    scene = short("double_pendulum")
    traj, settings = _spoiled(scene, 7, 0.0)
    assert first_non_finite(traj, scene.multibody()) is None
    checks = check_run(scene, "inhouse", "inhouse", traj, None, settings)
    assert checks and not any(c.check == "run" for c in checks)


def test_validate_fails_an_engine_that_reports_ok_on_nan(monkeypatch):
    """End to end through the worker processes: MuJoCo made to return a NaN energy sample
    (a NaN angular velocity) with status ok fails the ``run`` check, never passes."""
    from dataclasses import replace

    import numpy as np

    real = MujocoEngine.simulate

    def nan_at_5(self, scene, settings):
        traj = real(self, scene, settings)
        w = traj.w_WB_W.copy()
        w[5:, 0, 1] = np.nan
        return replace(traj, w_WB_W=w)

    monkeypatch.setattr(MujocoEngine, "simulate", nan_at_5)
    (res,) = validate([short("double_pendulum")], ["mujoco"], jobs=1)
    run = [c for c in res.checks if c.engine == "mujoco" and c.check == "run"]
    assert not res.passed
    assert len(run) == 1 and not run[0].passed and run[0].detail.startswith("blowup: non-finite")
    assert "angular velocity" in run[0].detail and "energy" in run[0].detail
    (record,) = [r for r in res.runs if r.engine == "mujoco"]
    assert record.status == "blowup" and "reported ok" in record.message


def test_an_unsupported_configured_integrator_is_a_failed_check_naming_the_reason(monkeypatch):
    """A scene whose own in-house integrator cannot run it (compiled form made to refuse the
    rolling contact: it models every scene today): the run comes back "unsupported"; validate
    records a failed ``run`` check and a run record that name the reason and call it bad
    configuration, and does not crash."""
    from dataclasses import replace

    from harness.engines.inhouse.compiled import solver

    def refuse(nem):  # forked workers inherit it
        raise NotImplementedError("the compiled in-house solver does not model rolling contacts")

    monkeypatch.setattr(solver, "pack", refuse)
    scene = short("rolling_disk")
    scene = replace(scene, integrators={**scene.integrators, "inhouse": "rk4_compiled"})
    (res,) = validate([scene], ["inhouse"], jobs=1)
    run = [c for c in res.checks if c.engine == "inhouse" and not c.check.startswith("model.")]
    assert len(run) == 1 and run[0].check == "run" and not run[0].passed and not res.passed
    assert run[0].detail.startswith("unsupported: rk4_compiled: the compiled in-house solver does not model rolling contacts")
    assert "bad configuration" in run[0].detail and "[integrators]" in run[0].detail
    (record,) = [r for r in res.runs if r.engine == "inhouse"]
    assert record.status == "unsupported" and "rolling contacts" in record.message
    ref = [c for c in res.checks if c.engine == "reference"]
    assert ref and all(c.passed for c in ref)  # the reference (per-state DOP853) is unaffected


def test_a_non_finite_run_is_judged_by_its_status():
    """``mark_non_finite`` turns an engine's "ok" with a NaN sample into status "blowup" (the run
    record and the ``run`` check follow the status, not the message text); a finite run and a run
    already not ok are unchanged."""
    from harness.measure.invariants import mark_non_finite
    from harness.measure.trajectory import Failure, failed

    scene = short("double_pendulum")
    traj, _ = _spoiled(scene, 7, float("nan"), "v_WCm_W")
    marked = mark_non_finite(traj, scene.multibody())
    assert marked.status == "blowup" and marked.message.startswith("non-finite velocity")
    assert "(inhouse reported ok)" in marked.message and len(marked.t) == len(traj.t)
    fine, _ = _spoiled(scene, 7, 0.0)
    assert mark_non_finite(fine, scene.multibody()) is fine
    gone = failed("inhouse", "rk4", fine.body_names, Failure.SOLVER, "solver failure")
    assert mark_non_finite(gone, scene.multibody()) is gone


def test_an_engine_that_drops_the_loop_fails_the_closure_check():
    """A run of the tree alone (the loop joint ignored, as an engine without loop support would)
    opens the loop: ``closure.*`` fails, naming the cut joint; the engines' real runs pass."""
    from dataclasses import replace

    from harness.engines.base import RunSettings
    from harness.engines.inhouse import ENGINE
    from harness.judging.checks import check_run

    from harness.judging import error_model
    from harness.judging.verdict import judge

    scene = short("four_bar")
    levels = []
    for dt in (1e-3, 2e-3):
        settings = RunSettings(t_end=0.5, dt=dt, save_every=0.01, integrator="rk4")
        tree = ENGINE.simulate_model(replace(scene.multibody(), loops=()), settings)
        checks = {c.check: c for c in check_run(scene, "inhouse", "inhouse", tree, None, settings)}
        levels.append(error_model.Level(dt, checks["closure.position"].value))
        if dt == 1e-3:
            assert checks["closure.position"].value > 1e-3 and "worst: cut" in checks["closure.position"].detail
            assert checks["constraint.position"].value < 1e-9  # the tree's own joints still hold
    # the gap does not shrink with the step: a floor no model difference declares -> fails
    model = error_model.fit("closure.position", "m", 0.45, "fixed", 4, levels, 1e-9)
    verdict = judge(model)
    assert model.classification in (error_model.MODEL_DIFFERENCE, error_model.UNRESOLVED_CLASS) and not verdict.passed
    (res,) = validate([scene], ["inhouse", "pinocchio", "exudyn", "drake"], jobs=2)
    closure = [c for c in res.checks if c.check.startswith("closure.")]
    assert {c.engine for c in closure} == {"reference", "inhouse", "pinocchio", "exudyn"} and all(c.passed for c in closure)
    assert "drake" in res.not_run
