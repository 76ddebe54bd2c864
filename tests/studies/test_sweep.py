"""``harness sweep``: grids and random samples of a scene's parameters, refused points, bad input."""

from __future__ import annotations

import math

import pandas as pd
import pytest

from harness.cli.main import main
from harness.model.errors import InputError
from harness.engines import load_scene
from harness.studies.sweep.report import figure_png, frame, markdown
from harness.studies.sweep.run import (Axis, PointResult, SweepRun, check_axes, grid_points, parse_axis,
                                       point_overrides, random_points, summarize, worst_class)
from harness.judging.checks import CheckResult
from harness.validate.run import RunRecord
from harness.validate.workers import Outcome

PNG = b"\x89PNG\r\n\x1a\n"


def files(folder, scene):
    return [folder / f"{scene}_sweep.{ext}" for ext in ("md", "csv", "png")]


@pytest.mark.slow
def test_a_1d_grid_writes_a_row_per_point_and_engine(tmp_path, capsys):
    out = tmp_path / "out"
    code = main(["sweep", "plate_pendulum", "--grid", "theta0=0:1.5:3", "--engines", "mujoco,pinocchio",
                 "--t-end", "0.1", "--jobs", "2", "--quiet", "--out-dir", str(out)])
    assert code == 0, capsys.readouterr().err
    md, csv, png = files(out, "plate_pendulum")
    rows = pd.read_csv(csv)
    assert len(rows) == 6 and list(rows["engine"]) == ["mujoco", "pinocchio"] * 3
    assert sorted(set(rows["theta0"])) == [0.0, 0.75, 1.5]
    assert (rows["status"] == "ok").all() and rows["passed"].all() and (rows["failed_checks"] == 0).all()
    assert (rows["classification"] == "converges").all() and rows["failing"].isna().all()  # every check converges
    assert ((rows["error"] > 0) & (rows["error"] < 1e-8)).all() and rows["error_check"].notna().all()
    assert (rows["error"] >= rows["trajectory_error"]).all()  # the largest dimensionless value: trajectory's included
    assert (rows["trajectory_error"] < 1e-8).all() and (rows["energy_drift"] < 1e-8).all()
    text = md.read_text()
    assert "## Largest error per engine" in text and "| mujoco | RK4 |" in text and "| pinocchio | rkmk4 |" in text
    assert "![log10 largest error](plate_pendulum_sweep.png)" in text and "| converges 3 | 0/3 |" in text
    data = png.read_bytes()
    assert data.startswith(PNG) and len(data) > 10_000
    printed = capsys.readouterr().out
    assert "mujoco: largest error" in printed and "pinocchio: largest error" in printed and "FAIL" not in printed


@pytest.mark.slow
def test_a_2x2_grid_records_refused_points_and_goes_on(tmp_path, capsys):
    """torque_free with I2 = 2: (I1, I3) = (1, 4) and (6, 2) break the triangle inequality of the
    principal moments; those points are refused, the other two run."""
    out = tmp_path / "out"
    code = main(["sweep", "torque_free", "--grid", "I1=1:6:2", "--grid", "I3=2:4:2", "--engines", "mujoco",
                 "--t-end", "0.05", "--quiet", "--out-dir", str(out)])
    assert code == 0, capsys.readouterr().err
    rows = pd.read_csv(files(out, "torque_free")[1])
    assert len(rows) == 4 and list(zip(rows["I1"], rows["I3"])) == [(1, 2), (1, 4), (6, 2), (6, 4)]
    refused = rows["status"].str.startswith("refused: ")
    assert list(refused) == [False, True, True, False]
    assert rows.loc[refused, "status"].str.contains("triangle inequality").all()
    assert (rows.loc[~refused, "status"] == "ok").all() and rows.loc[~refused, "passed"].all()
    assert (rows.loc[~refused, "classification"] == "converges").all() and rows.loc[refused, "classification"].isna().all()
    assert files(out, "torque_free")[2].read_bytes().startswith(PNG)
    assert "| mujoco | RK4 |" in files(out, "torque_free")[0].read_text()


@pytest.mark.slow
def test_a_seeded_random_sweep_is_reproducible(tmp_path, capsys):
    def sweep(seed, folder):
        assert main(["sweep", "torque_free", "--random", "omega0[2]=0.1:10:log", "--random", "I1=1:2",
                     "--samples", "2", "--seed", str(seed), "--engines", "mujoco", "--t-end", "0.05", "--quiet",
                     "--out-dir", str(tmp_path / folder)]) == 0
        return pd.read_csv(tmp_path / folder / "torque_free_sweep.csv")

    a, b = sweep(7, "a"), sweep(7, "b")
    cols = ["omega0[2]", "I1", "status", "passed", "classification", "error", "error_check"]
    pd.testing.assert_frame_equal(a[cols], b[cols])
    assert (a["status"] == "ok").all() and a["omega0[2]"].between(0.1, 10).all() and a["I1"].between(1, 2).all()
    assert a["passed"].all() and (a["error"] > 0).all()
    assert (tmp_path / "a" / "torque_free_sweep.png").read_bytes().startswith(PNG)
    assert "(seed 7)" in (tmp_path / "a" / "torque_free_sweep.md").read_text()
    axes = [Axis("I1", "I1", None, 1.0, 2.0, None)]
    assert random_points(axes, 3, 7) == random_points(axes, 3, 7) != random_points(axes, 3, 8)


@pytest.mark.slow
def test_dask_reaches_the_executor(tmp_path, capsys, monkeypatch):
    """``--dask ADDRESS`` is checked before the run and handed to ``open_workers`` (the executor
    and its Dask twin are tested in tests/validate)."""
    import harness.studies.sweep.run as sweep_run
    import harness.validate.dask_workers as dask_workers
    from harness.validate.workers import Workers

    seen = []
    monkeypatch.setattr(dask_workers, "connect", lambda address: seen.append(("connect", address)))
    monkeypatch.setattr(sweep_run, "open_workers",
                        lambda jobs, dask: seen.append(("open", dask)) or Workers(jobs))
    code = main(["sweep", "torque_free", "--grid", "I1=1:1.5:2", "--engines", "mujoco", "--t-end", "0.05",
                 "--dask", "127.0.0.1:8786", "--quiet", "--out-dir", str(tmp_path)])
    assert code == 0
    assert seen == [("connect", "tcp://127.0.0.1:8786"), ("open", "tcp://127.0.0.1:8786")]
    assert "on the Dask scheduler at tcp://127.0.0.1:8786" in (tmp_path / "torque_free_sweep.md").read_text()


@pytest.mark.parametrize("args,fragment", [
    (["plate_pendulum", "--grid", "nope=0:1:3"], "'nope' is not a parameter of scene 'plate_pendulum'"),
    (["plate_pendulum", "--grid", "theta0=1:0:3"], "lo must be < hi"),
    (["plate_pendulum", "--grid", "theta0=1:1:3"], "lo must be < hi"),
    (["plate_pendulum", "--grid", "theta0=0:1:1"], "n must be >= 2"),
    (["plate_pendulum", "--grid", "theta0=0:1"], "expected KEY=lo:hi:n"),
    (["plate_pendulum", "--grid", "theta0=a:1:3"], "lo and hi must be numbers"),
    (["plate_pendulum", "--grid", "=0:1:3"], "expected KEY=lo:hi:n"),
    (["plate_pendulum", "--grid", "m=-1:1:3"], "refuses m = -1"),
    (["plate_pendulum", "--grid", "m=0:1:3:log"], "a log range needs lo > 0"),
    (["no_such_scene", "--grid", "m=1:2:3"], "unknown scene 'no_such_scene'"),
    (["torque_free", "--grid", "omega0=0:1:3"], "sweep one component"),
    (["torque_free", "--grid", "omega0[3]=0:1:3"], "has components 0 .. 2"),
    (["torque_free", "--grid", "I1[0]=0:1:3"], "is a scalar parameter"),
    (["torque_free", "--grid", "I1=1:2:2", "--grid", "I1=1:2:2"], "swept twice"),
    (["torque_free", "--grid", "I1=1:2:2", "--grid", "I2=1:2:2", "--grid", "I3=1:2:2"], "at most 2 keys"),
    (["torque_free"], "give --grid"),
    (["torque_free", "--grid", "I1=1:2:2", "--random", "I2=1:2"], "give --grid"),
    (["torque_free", "--random", "I2=1:2"], "--random needs --samples"),
    (["torque_free", "--random", "I2=1:2", "--samples", "0"], "--samples must be"),
    (["torque_free", "--grid", "I1=1:2:2", "--samples", "3"], "--samples goes with --random"),
    (["torque_free", "--grid", "I1=1:2:2", "--engines", "bullet"], "unknown engine 'bullet'"),
    (["torque_free", "--grid", "I1=1:2:2", "--t-end", "0.015"], "not a whole multiple of the save interval"),
    (["torque_free", "--grid", "I1=1:2:2", "--t-end", "-1"], "must be positive"),
    (["torque_free", "--grid", "I1=1:2:2", "--timeout", "0"], "--timeout must be positive"),
    (["torque_free", "--grid", "I1=1:200:200", "--grid", "I3=1:200:200"], "more than the 10000"),
])
def test_bad_input_is_one_line_exit_2_and_nothing_written(tmp_path, capsys, args, fragment):
    out = tmp_path / "out"
    code = main(["sweep", *args, "--out-dir", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and fragment in err, err
    assert not out.exists()


def test_axes_grid_and_overrides():
    scene = load_scene("torque_free")
    axes = check_axes(scene, [parse_axis("omega0[1]=1:100:3:log", grid=True), parse_axis("I1=1:2:2", grid=True)])
    assert axes[0].unit == "rad/s" and axes[0].log and axes[0].index == 1
    points = grid_points(axes)
    assert len(points) == 6 and points[0] == (1.0, 1.0) and points[1] == (1.0, 2.0)
    assert math.isclose(points[2][0], 10.0)
    over = point_overrides(scene, axes, points[5])
    assert over["omega0"] == (1.0, 100.0, 0.6) and over["I1"] == 2.0
    with pytest.raises(InputError, match="not a parameter name"):
        parse_axis("a b=1:2:3", grid=True)


def test_a_crash_or_timeout_is_that_point_s_result():
    for status in ("crashed", "timeout"):
        r = summarize(0, (1.0,), "mujoco", "RK4", Outcome(status, message="gone"), "ok")
        assert r.status == status and not r.passed and r.classification == "" and math.isnan(r.error)
        assert r.failing == (("run", "", "gone"),) and r.failed_checks == 1
    r = summarize(0, (1.0,), "mujoco", "RK4", Outcome("input_error", message="no such body"), "ok")
    assert r.status == "refused: no such body" and r.refused and not r.failing


def _c(check, value, unit, passed=True, cls="converges", judged="order 4.01 (method's 4)"):
    return CheckResult("s", "mujoco", check, value, math.inf, unit, passed, "detail", classification=cls,
                       judged=judged)


def _case(checks):
    record = RunRecord("s", "mujoco", "RK4", 1e-3, None, 1.0, "ok", "", 0.5, 1000.0)
    return Outcome("ok", value=(None, record, checks, None))


def test_a_point_is_judged_by_the_verdicts_of_its_checks():
    """The worst class, the failing checks with their class and reason, and the largest
    dimensionless error (rel, rad or unitless; not m) with its check."""
    declared = "model difference (declared)"
    checks = [_c("trajectory.position", 2e-6, "rel"), _c("trajectory.orientation", 5e-6, "rad", cls=declared),
              _c("constraint.position", 1.0, "m"), _c("exact", 7e-6, ""), _c("energy_drift", 1e-9, "rel")]
    r = summarize(3, (0.5,), "mujoco", "RK4", _case(checks), "ok")
    assert r.passed and r.classification == declared and r.failing == () and r.failing_class == ""
    assert (r.error, r.error_check) == (7e-6, "exact")  # the 1.0 m constraint violation is not dimensionless
    assert (r.trajectory_error, r.energy_drift, r.failed_checks, r.checks) == (5e-6, 1e-9, 0, 5)

    checks[1] = _c("trajectory.orientation", 5e-6, "rad", passed=False, cls="model difference",
                   judged="a floor of 4.9e-06 rad that does not shrink with the step; not declared by the scene")
    checks.append(_c("reaction.force", 3e-3, "rel", passed=False, cls="defect", judged="order 0.21 where the method's is 4"))
    checks.append(_c("reaction.exact", float("nan"), "rel", passed=False, cls="", judged=""))
    r = summarize(3, (0.5,), "mujoco", "RK4", _case(checks), "ok")
    assert not r.passed and r.classification == "defect" and r.failing_class == "defect" and r.failed_checks == 3
    assert r.failing == (("trajectory.orientation", "model difference",
                          "a floor of 4.9e-06 rad that does not shrink with the step; not declared by the scene"),
                         ("reaction.force", "defect", "order 0.21 where the method's is 4"),
                         ("reaction.exact", "not judged", "detail"))  # no value: not judged, why from its detail
    assert (r.error, r.error_check) == (3e-3, "reaction.force") and r.no_value == ("reaction.exact",)
    assert worst_class(["converges", declared, "model difference"]) == "model difference"
    assert worst_class(["not judged", "model difference", ""]) == "not judged" and worst_class([]) == ""


def test_the_report_shows_classes_errors_and_failing_checks():
    """The CSV and the table carry the class, the error, its check and each failing check with its
    class and reason; the figure (heatmap, line, scatter) is drawn with a failing point."""
    axes = [Axis("a", "a", None, 0.0, 1.0, 2), Axis("b", "b", None, 1.0, 2.0, 2)]
    points = grid_points(axes)

    def row(i, values, failing=()):
        return PointResult(i, values, "mujoco", "RK4", "ok", not failing, failing[0][1] if failing else "converges",
                           10.0 ** (-9 + i), "trajectory.position", len(failing), 5, 1e-9, 1e-10, "ok", 0.1,
                           failing=failing)

    bad = (("trajectory.position", "defect", "order 0.30 where the method's is 4"),)
    rows = [row(i, v, bad if i == 2 else ()) for i, v in enumerate(points)]
    run = SweepRun("demo", "grid", axes, points, ["mujoco"], 1.0, rows=rows)
    table = frame(run)
    assert list(table["classification"]) == ["converges", "converges", "defect", "converges"]
    assert table["error"].tolist() == pytest.approx([1e-9, 1e-8, 1e-7, 1e-6])
    assert table.loc[2, "failing"] == "trajectory.position [defect]: order 0.30 where the method's is 4"
    assert "worst_margin" not in table.columns
    text = markdown(run, {"harness": "0"}, "demo_sweep.png", "harness sweep demo")
    assert "| class | error | check | failing checks |" in text
    assert "| defect | 1.00e-07 | trajectory.position | trajectory.position [defect]: order 0.30" in text
    assert "| defect 1, converges 3 | 1/4 |" in text  # the headline's classes, worst first, and failing points
    assert "margin" not in text
    for r2 in (run, SweepRun("demo", "grid", axes[:1], [(0.0,), (1.0,)], ["mujoco"], 1.0, rows=rows[:2]),
               SweepRun("demo", "random", axes, points, ["mujoco"], 1.0, seed=1, rows=rows)):
        assert figure_png(r2).startswith(PNG)


def test_a_scene_without_a_reference_run_sweeps_without_one():
    """four_bar_chain declares no check against a reference run: each point's engines start at
    once, judged without one (validate's ``has_reference``)."""
    from harness.studies.sweep.run import run_sweep, with_horizon

    scene = with_horizon(load_scene("four_bar_chain"), 0.5)
    axes = check_axes(scene, [parse_axis("N=1:2:2", grid=True)])
    run = run_sweep(scene, axes, grid_points(axes), ["mujoco"], jobs=1)
    assert [(r.engine, r.status, r.reference) for r in run.rows] == [("mujoco", "ok", "not run")] * 2
