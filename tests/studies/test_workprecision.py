"""Work-precision sweeps: the sweep runs and writes its reports, errors and orders are measured
as documented, failures are recorded points. No wall-clock thresholds: this is a benchmark."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from harness.cli.main import main
from harness.engines.base import RunSettings
from harness.model.scene import load_scene
from harness.studies.workprecision.run import (
    ERROR_KEYS,
    QUICK,
    Curve,
    SweepOptions,
    WorkPrecisionPoint,
    _runner,
    curves,
    errors,
    measure,
    observed_order,
    reference,
    sweep_scene,
    time_table,
    time_to_error,
)


def point(param, err, t, integrator="rk4_compiled", status="ok", steps=float("nan")):
    return WorkPrecisionPoint(scene="s", engine="inhouse", integrator=integrator, variant="compiled", param=param,
                              status=status, message="", time_s=t, time_min_s=t, time_total_s=t, repeats=1,
                              steps=steps, rhs_evals=float("nan"), state_final=err, state_max=err, energy_final=err,
                              energy_max=err, momentum_final=err, momentum_max=err, nominal_order=4)


@pytest.mark.slow  # the whole CLI sweep of one scene with its plots and batch benchmark (2 s warm, every kernel compiled cold)
def test_quick_sweep_writes_the_reports(tmp_path, capsys):
    code = main(["workprecision", "--quick", "--scenes", "torque_free", "--no-progress", "--out-dir", str(tmp_path)])
    assert code == 0
    md = (tmp_path / "workprecision.md").read_text()
    assert "## torque_free" in md and "workprecision/torque_free.png" in md
    assert "in-house against MuJoCo RK4" in md and "Batched throughput" in md and "mujoco 4" in md
    assert "Head to head" in md and "loop / rollout" in md and "compiled / rollout" in md
    png = (tmp_path / "workprecision" / "torque_free.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    table = pd.read_csv(tmp_path / "workprecision.csv", comment="#")
    assert set(ERROR_KEYS) <= set(table.columns)
    labels = set(table["label"])
    expected = {"mujoco RK4 (rollout)", "mujoco RK4 (loop)", "mujoco implicitfast (rollout)", "pinocchio rkmk4",
                "inhouse rk4 (per-state)", "inhouse DOP853 (per-state)", "inhouse rk4_compiled (compiled)",
                "inhouse dop853_compiled (compiled)", "exudyn GeneralizedAlpha", "exudyn RK44", "drake RK5", "drake RK2"}
    assert expected <= labels and labels == {c.label for c in curves(["mujoco", "pinocchio", "inhouse", "exudyn", "drake"])}
    assert "rhs_calls" not in table.columns
    ok = table[table["status"] == "ok"]
    assert (ok["time_s"] > 0).all() and (ok["time_min_s"] <= ok["time_s"] + 1e-12).all()
    assert "torque_free:" in capsys.readouterr().out


def test_bad_options_exit_2(tmp_path, capsys):
    assert main(["workprecision", "--repeats", "0", "--out-dir", str(tmp_path)]) == 2
    assert "--repeats out of range" in capsys.readouterr().err
    assert not (tmp_path / "workprecision.md").exists()


@pytest.fixture(scope="module")
def torque_free_short():
    scene = load_scene("torque_free")
    options = replace(QUICK, horizon=2.0, saves=4, dt_levels=7, repeats=1, max_run_s=5.0)
    ref, _ = reference(scene, 2.0, 0.5)
    return scene, options, ref


def test_errors_of_the_reference_itself_vanish(torque_free_short):
    scene, _, ref = torque_free_short
    errs = errors(ref, ref, scene.multibody())
    assert all(errs[k] == 0.0 for k in ERROR_KEYS)
    bad = replace(ref, status="blowup")
    assert all(math.isnan(v) for v in errors(bad, ref, scene.multibody()).values())


@pytest.mark.parametrize("curve,lo", [
    (Curve("mujoco", "RK4", "rollout"), 2), (Curve("mujoco", "Euler", "rollout"), 5),
    (Curve("mujoco", "implicitfast", "loop"), 5), (Curve("pinocchio", "rkmk4", ""), 2),
    (Curve("inhouse", "rk4_compiled", "compiled"), 2),
])
def test_observed_orders_are_the_nominal_ones(torque_free_short, curve, lo):
    scene, options, _ = torque_free_short
    options = replace(options, dt_levels=lo + 4, error_floor=1e-13)
    sweep = sweep_scene(scene, [curve.engine], options, curve_list=[curve])
    pts = [p for p in sweep.points if p.param <= 0.5 / 2**lo]
    order = observed_order(pts, options.error_floor)
    assert order["n"] >= 3, pts
    assert abs(order["order"] - curve.nominal_order) < 0.25 * curve.nominal_order, order


@pytest.mark.parametrize("curve", [Curve("inhouse", "dop853_compiled", "compiled")])
def test_adaptive_curves_report_tolerance_slope_and_effective_order(torque_free_short, curve):
    scene, options, _ = torque_free_short
    options = replace(options, tolerances=(1e-5, 1e-7, 1e-9, 1e-11))
    sweep = sweep_scene(scene, ["inhouse"], options, curve_list=[curve])
    assert all(p.ok for p in sweep.points)
    errs = [p.state_max for p in sweep.points]
    assert errs == sorted(errs, reverse=True)  # tighter tolerance, smaller error
    order = observed_order(sweep.points, 1e-13)
    assert 0.5 < order["tol_slope"] < 1.5 and math.isfinite(order["steps_order"])


def test_a_failing_run_is_a_recorded_point():
    scene = load_scene("double_pendulum").with_params(F0=1.0, omega_f=2.0)
    ref, _ = reference(scene, 0.5, 0.25)
    settings = RunSettings(0.5, 0.01, 0.25, "RK4")
    p = measure(scene, Curve("mujoco", "RK4", "rollout"), settings, ref, scene.multibody(), QUICK)
    assert p.status == "unsupported" and "prescribed forces" in p.message and math.isnan(p.state_max)
    assert not p.ok
    top = load_scene("heavy_top")
    ref = reference(top, 0.5, 0.25)[0]
    coarse = measure(top, Curve("inhouse", "rk4_compiled", "compiled"), RunSettings(0.5, 0.25, 0.25, "rk4_compiled"),
                     ref, top.multibody(), QUICK)  # two RK4 steps of 0.25 s: the projection cannot recover
    assert coarse.status == "failed" and "projection did not converge" in coarse.message
    assert coarse.repeats == 0 and all(math.isnan(getattr(coarse, k)) for k in ERROR_KEYS)
    disk = load_scene("rolling_disk")
    outside = measure(disk, Curve("inhouse", "dop853_compiled", "compiled"),
                      RunSettings(0.5, 0.25, 0.25, "dop853_compiled", rtol=1e-6, atol=1e-6), ref, disk.multibody(), QUICK)
    assert outside.status == "unsupported" and "does not model rolling contacts" in outside.message
    assert math.isnan(outside.state_max)


def test_a_method_that_does_not_model_the_scene_is_skipped_and_reported():
    """The compiled integrators on the rolling disk: one unsupported run, then the curve is
    skipped on that scene (no points, no "failed" rows) and the report says why."""
    from harness.studies.workprecision.report import markdown

    disk = load_scene("rolling_disk")
    options = replace(QUICK, dt_levels=3, tolerances=(1e-4, 1e-6), horizon=0.2, saves=2)
    curves_ = [Curve("inhouse", "rk4_compiled", "compiled"), Curve("inhouse", "dop853_compiled", "compiled"),
               Curve("inhouse", "rk4", "per-state")]
    sweep = sweep_scene(disk, ["inhouse"], options, curve_list=curves_)
    assert set(sweep.skipped) == {"inhouse rk4_compiled (compiled)", "inhouse dop853_compiled (compiled)"}
    assert all("does not model rolling contacts" in why for why in sweep.skipped.values())
    assert {p.label for p in sweep.points} == {"inhouse rk4 (per-state)"}
    md = markdown([sweep], {"machine": "test"}, options, command="harness workprecision")
    section = md.split("## rolling_disk")[1]
    assert "Not run on this scene" in section
    assert "- inhouse dop853_compiled (compiled): dop853_compiled: the compiled in-house solver does not model" in section
    assert "Failed or blown-up runs" not in section


def test_every_curve_but_rollout_runs_through_its_engine(monkeypatch):
    """One dispatcher: the runner of an in-house compiled curve is the engine's simulate, and
    its engine time is the integration alone (the trajectory's ``wall_s``)."""
    import harness.studies.workprecision.run as wp
    from harness.engines import get_engine

    calls = []

    class Spy:
        def __init__(self, engine):
            self.engine = engine
            self.integrators = engine.integrators

        def simulate(self, scene, settings):
            calls.append(settings.integrator)
            return self.engine.simulate(scene, settings)

    monkeypatch.setattr(wp, "get_engine", lambda name: Spy(get_engine(name)))
    scene = load_scene("torque_free")
    run = _runner(scene, Curve("inhouse", "rk4_compiled", "compiled"), RunSettings(1.0, 0.01, 0.5, "rk4_compiled"))
    traj, engine_t, total_t, steps, evals = run()
    assert calls == ["rk4_compiled"] and traj.ok and traj.integrator == "rk4_compiled"
    assert engine_t == traj.stats["wall_s"] and 0 < engine_t <= total_t
    assert (steps, evals) == (100, 400)


def test_batch_benchmark_compares_the_compiled_batch_with_rollout():
    from harness.studies.workprecision.run import batch_benchmark

    b = batch_benchmark(load_scene("heavy_top"), 8, 5, repeats=1)
    assert b["status"] == "ok" and b["threads"] >= 1
    for key in ("mujoco", "mujoco_1thread", "compiled", "compiled_1thread"):
        assert b[f"{key}_steps_per_s"] > 0
    assert not any(k.startswith("numpy") for k in b)
    assert b["max_state_difference"] < 1e-6  # the same RK4 on the same states, two engines
    skipped = batch_benchmark(load_scene("rolling_disk"), 4, 2, repeats=1)
    assert skipped["status"].startswith("skipped") and "rolling contacts" in skipped["status"]


def test_time_to_error_interpolates_on_the_lower_envelope():
    pts = [point(0.1, 1e-4, 1.0), point(0.05, 1e-6, 2.0), point(0.025, 1e-8, 4.0), point(0.01, 2e-8, 8.0)]
    assert time_to_error(pts, 1e-6) == pytest.approx(2.0)
    assert time_to_error(pts, 1e-5) == pytest.approx(math.sqrt(2.0))  # half-way in log-log
    assert math.isnan(time_to_error(pts, 1e-10))
    assert time_to_error(pts + [point(0.001, float("nan"), 0.1, status="failed")], 1e-4) == pytest.approx(1.0)


def test_observed_order_of_an_exact_power_law():
    pts = [point(h, 3.0 * h**4, 1.0 / h) for h in (0.1, 0.05, 0.025, 0.0125)]
    o = observed_order(pts, 1e-14)
    assert o["order"] == pytest.approx(4.0) and o["n"] == 4
    adaptive = [point(tol, 2 * tol, 1.0, integrator="dop853_compiled", steps=tol**-0.125) for tol in (1e-4, 1e-6, 1e-8)]
    o = observed_order(adaptive, 1e-14)
    assert o["tol_slope"] == pytest.approx(1.0) and o["steps_order"] == pytest.approx(8.0)


def test_time_table_ratios_are_to_the_fastest_curve():
    from harness.studies.workprecision.run import SceneSweep

    sweep = SceneSweep("s", 1.0, 0.1, "ref")
    sweep.points = [point(0.1, 1e-7, 1.0), point(0.1, 1e-7, 3.0, integrator="dop853_compiled")]
    rows = {r["label"]: r for r in time_table(sweep, targets=(1e-6,))}
    assert rows["inhouse rk4_compiled (compiled)"]["ratio(1e-06)"] == 1.0
    assert rows["inhouse dop853_compiled (compiled)"]["ratio(1e-06)"] == 3.0


def test_default_options_describe_a_full_sweep():
    o = SweepOptions()
    assert o.repeats >= 1 and o.batch == 1000 and min(o.tolerances) <= 1e-12
    assert np.isclose(0.5 / 2 ** (o.dt_levels - 1), 0.5 / 2**15)


def mujoco_point(variant, param, err, t, integrator="RK4"):
    return replace(point(param, err, t), engine="mujoco", integrator=integrator, variant=variant)


def test_coinciding_curves_are_drawn_distinguishable():
    """MuJoCo's rollout and loop variants of one integrator have the same errors at times ~1.1x
    apart: the later one is flagged as coinciding, drawn dotted with open markers under the other,
    and its legend says so; curves with other errors or far apart in time are left alone."""
    from harness.studies.workprecision.report import (
        coinciding,
        curve_styles,
        plot_scene,
    )
    from harness.studies.workprecision.run import SceneSweep, by_curve

    dts = (0.1, 0.05, 0.025)
    pts = ([mujoco_point("rollout", dt, 10 * dt**4, 1e-3 / dt) for dt in dts]
           + [mujoco_point("loop", dt, 10 * dt**4, 1.1e-3 / dt) for dt in dts]
           + [mujoco_point("rollout", dt, 3 * dt, 1e-3 / dt, integrator="Euler") for dt in dts]
           + [point(dt, 10 * dt**4, 0.05 / dt, integrator="rk4") for dt in dts])  # same errors, 50x slower
    groups = by_curve(pts)
    assert coinciding(groups) == {"mujoco RK4 (loop)": "mujoco RK4 (rollout)"}
    styles = curve_styles(groups)
    legend, loop = styles["mujoco RK4 (loop)"]
    _, rollout = styles["mujoco RK4 (rollout)"]
    assert legend == "mujoco RK4 (loop) (same errors as mujoco RK4 (rollout))"
    assert loop["markerfacecolor"] == "none" and loop["markersize"] > rollout["markersize"]
    assert loop["linestyle"] != rollout["linestyle"] and loop["zorder"] < rollout["zorder"]
    assert styles["inhouse rk4 (compiled)"][0] == "inhouse rk4 (compiled)"
    sweep = SceneSweep("s", 1.0, 0.1, "ref", points=pts)
    assert plot_scene(sweep, {})[:4] == b"\x89PNG"
    # different errors at a common step: not the same curve
    pts[4] = replace(pts[4], state_max=2 * pts[4].state_max)
    assert coinciding(by_curve(pts)) == {}
