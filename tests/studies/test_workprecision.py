"""Work-precision sweeps: the sweep runs and writes its reports, errors and orders are measured
as documented, failures are recorded points. No wall-clock thresholds: this is a benchmark."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from harness.cli.main import main
from harness.engines import ENGINE_NAMES, get_engine
from harness.engines.base import RunSettings
from harness.measure.trajectory import Failure
from harness.engines import load_scene
from harness.studies.workprecision.run import (
    ERROR_KEYS,
    QUICK,
    TARGETS,
    Curve,
    SceneSweep,
    SweepOptions,
    WorkPrecisionPoint,
    _ladder,
    _runner,
    curve_role,
    curves,
    errors,
    head_to_head,
    measure,
    next_cost,
    observed_order,
    reference,
    scene_curves,
    stop_reason,
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
    assert "In-house against MuJoCo RK4" in md and "Batched throughput" in md and "mujoco 4" in md
    assert "Head to head" in md and "loop / rollout" in md and "compiled / rollout" in md
    assert md.index("## Targets") < md.index("## How the sweep was run") and "| torque_free |" in md
    assert "Where the time went" in md and "| stopped |" in md
    png = (tmp_path / "workprecision" / "torque_free.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    table = pd.read_csv(tmp_path / "workprecision.csv", comment="#")
    assert set(ERROR_KEYS) <= set(table.columns)
    labels = set(table["label"])  # --quick sweeps the per-state curves too (per_state "all")
    expected = {"mujoco RK4 (rollout)", "mujoco RK4 (loop)", "mujoco implicitfast (rollout)", "pinocchio rkmk4",
                "inhouse rk4 (per-state)", "inhouse DOP853 (per-state)", "inhouse rk4_compiled (compiled)",
                "inhouse dop853_compiled (compiled)", "exudyn GeneralizedAlpha", "exudyn RK44", "drake RK5", "drake RK2"}
    assert expected <= labels and labels == {c.label for c in curves(list(ENGINE_NAMES))}
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
    options = replace(QUICK, horizon=2.0, saves=4, dt_levels=7, repeats=1, max_run_s=5.0, curve_budget_s=None,
                      key_budget_s=None, loop_budget_s=None)  # orders need whole ladders
    ref, _ = reference(scene, 2.0, 0.5)
    return scene, options, ref


def test_errors_of_the_reference_itself_vanish(torque_free_short):
    scene, _, ref = torque_free_short
    errs = errors(ref, ref, scene.multibody())
    assert all(errs[k] == 0.0 for k in ERROR_KEYS)
    bad = replace(ref, reason=Failure.NON_FINITE)
    assert all(math.isnan(v) for v in errors(bad, ref, scene.multibody()).values())


@pytest.mark.parametrize("curve,lo", [
    (Curve("mujoco", "RK4", "rollout"), 2), (Curve("mujoco", "Euler", "rollout"), 5),
    (Curve("mujoco", "implicitfast", "loop"), 5), (Curve("pinocchio", "rkmk4", ""), 2),
    (Curve("inhouse", "rk4_compiled", "compiled"), 2), (Curve("inhouse", "rkmk4_compiled", "compiled"), 2),
])
def test_observed_orders_are_the_nominal_ones(torque_free_short, curve, lo):
    scene, options, _ = torque_free_short
    options = replace(options, dt_levels=lo + 4, error_floor=1e-13)
    sweep = sweep_scene(scene, [curve.engine], options, curve_list=[curve])
    pts = [p for p in sweep.points if p.param <= 0.5 / 2**lo]
    order = observed_order(pts, options.error_floor)
    assert order["n"] >= 3, pts
    assert abs(order["order"] - curve.nominal_order) < 0.25 * curve.nominal_order, order


def test_the_lie_group_curve_is_exact_on_the_rotating_plate():
    """rkmk4_compiled is one of the in-house curves, and on a constant-rate rotation its error is
    round-off at the coarsest step of the ladder, where the quaternion RK4 is far from it."""
    assert Curve("inhouse", "rkmk4_compiled", "compiled") in curves(["inhouse"])
    options = replace(SweepOptions(), dt_levels=1, tolerances=(), repeats=1)
    scene = load_scene("rotating_plate")
    sweep = sweep_scene(scene, ["inhouse"], options, curve_list=[
        Curve("inhouse", "rkmk4_compiled", "compiled"), Curve("inhouse", "rk4_compiled", "compiled")])
    err = {p.integrator: p.state_max for p in sweep.points if p.param == max(q.param for q in sweep.points)}
    assert err["rkmk4_compiled"] < 1e-12 < err["rk4_compiled"], err


@pytest.mark.parametrize("curve", [Curve("inhouse", "dop853_compiled", "compiled")])
def test_adaptive_curves_report_tolerance_slope_and_effective_order(torque_free_short, curve):
    """On heavy_top (a tolerance matters there: torque_free's smooth motion stays far below every
    tolerance, and its slope against the tolerance says nothing)."""
    _, options, _ = torque_free_short
    options = replace(options, tolerances=(1e-5, 1e-7, 1e-9, 1e-11))
    sweep = sweep_scene(load_scene("heavy_top"), ["inhouse"], options, curve_list=[curve])
    assert all(p.ok for p in sweep.points)
    errs = [p.state_max for p in sweep.points]
    assert errs == sorted(errs, reverse=True)  # tighter tolerance, smaller error
    order = observed_order(sweep.points, 1e-13)
    assert 0.5 < order["tol_slope"] < 1.5 and math.isfinite(order["steps_order"])


def not_modelled(monkeypatch, why="the compiled in-house solver does not model rolling contacts"):
    """Make the compiled in-house form refuse every scene (``pack`` raises NotImplementedError),
    as it does for a scene it does not model, whatever it covers today."""
    from harness.engines.inhouse.compiled import solver

    def refuse(nem):
        raise NotImplementedError(why)

    monkeypatch.setattr(solver, "pack", refuse)


def test_a_failing_run_is_a_recorded_point(monkeypatch):
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
    not_modelled(monkeypatch)
    disk = load_scene("rolling_disk")
    outside = measure(disk, Curve("inhouse", "dop853_compiled", "compiled"),
                      RunSettings(0.5, 0.25, 0.25, "dop853_compiled", rtol=1e-6, atol=1e-6), ref, disk.multibody(), QUICK)
    assert outside.status == "unsupported" and "does not model rolling contacts" in outside.message
    assert math.isnan(outside.state_max)


def test_a_method_that_does_not_model_the_scene_is_skipped_and_reported(monkeypatch):
    """The compiled integrators on a scene they do not model: one unsupported run, then the curve
    is skipped on that scene (no points, no "failed" rows) and the report says why."""
    from harness.studies.workprecision.report import markdown

    not_modelled(monkeypatch)
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


def test_batch_benchmark_compares_the_compiled_batch_with_rollout(monkeypatch):
    from harness.studies.workprecision.run import batch_benchmark

    b = batch_benchmark(load_scene("heavy_top"), 8, 5, repeats=1)
    assert b["status"] == "ok" and b["threads"] >= 1 and b["nbatch"] == 8
    for key in ("mujoco", "mujoco_1thread", "compiled", "compiled_1thread"):
        assert b[f"{key}_steps_per_s"] > 0
    assert not any(k.startswith("numpy") for k in b)
    assert b["max_state_difference"] < 1e-6  # the same RK4 on the same states, two engines
    sized = batch_benchmark(load_scene("heavy_top"), 40, 5, repeats=3, options=replace(SweepOptions(), batch_budget_s=1e-6))
    assert sized["status"] == "ok" and sized["nbatch"] == min(40, sized["threads"])  # a tiny budget: the floor
    assert sized["rounds"] == 1 and sized["calibration_s_per_trajectory"] > 0  # rounds past the first: within budget
    large = batch_benchmark(load_scene("four_bar_chain", {"N": 14}), 2, 2, repeats=1)  # 215 rows: as its runs
    assert large["status"].startswith("skipped") and "constraint rows" in large["status"]
    not_modelled(monkeypatch)
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
    assert o["order"] == pytest.approx(4.0) and o["n"] == 3 and o["range"] == "0.013..0.05"  # the three finest
    assert o["model"].classification == "converges"
    adaptive = [point(tol, 2 * tol, 1.0, integrator="dop853_compiled", steps=tol**-0.125) for tol in (1e-4, 1e-6, 1e-8)]
    o = observed_order(adaptive, 1e-14)
    assert o["tol_slope"] == pytest.approx(1.0) and o["steps_order"] == pytest.approx(8.0)


def test_each_curve_gets_its_error_model():
    """``curve_model`` (``harness.judging.error_model``) on fabricated curves: a fourth-order power
    law converges at order 4 from its finest resolved points (the round-off tail left out), an
    error that levels off is a model difference with its floor, a first-order error of a
    fourth-order method is a defect, an error of the motion's size is unresolved, a curve whose
    every run blew up or one sound point is not judged; an error-controlled curve that follows its tolerance converges at order 1 in
    it, one flat over its tolerances has a floor."""
    from harness.studies.workprecision.run import curve_model

    steps = [0.1 / 2**k for k in range(9)]  # 3 h^4 falls below 10x the resolution (1e-11) after steps[6]
    rk4 = curve_model([point(h, max(3.0 * h**4, 3e-13), 1.0 / h) for h in steps])
    assert rk4.classification == "converges" and rk4.observed_order == pytest.approx(4.0)
    assert [lv.step for lv in rk4.levels] == steps[6:3:-1]  # the finest resolved three, the finest first
    steps = steps[:6]
    soft = curve_model([point(h, 1e-5 + 3.0 * h**4, 1.0 / h) for h in steps])
    assert soft.classification == "model difference" and soft.floor == pytest.approx(1e-5, rel=0.05)
    assert soft.observed_order < 1.0
    low = curve_model([point(h, 0.1 * h, 1.0 / h) for h in steps])
    assert low.classification == "defect" and low.observed_order == pytest.approx(1.0)
    blown = curve_model([point(h, float("nan"), 1.0, status="blowup") for h in steps[:2]])
    assert blown.classification == "not judged" and "2 blew up" in blown.reason  # beyond its stability: no defect
    lost = curve_model([point(h, 0.3 + h, 1.0 / h) for h in steps])
    assert lost.classification == "unresolved"  # the motion's own size: nothing to fit
    assert curve_model([point(0.1, 1e-4, 1.0)]).classification == "not judged"
    tols = [1e-4, 1e-6, 1e-8]
    dop = curve_model([point(t, 5.0 * t, 1.0, integrator="dop853_compiled") for t in tols])
    assert dop.kind == "adaptive" and dop.classification == "converges" and dop.observed_order == pytest.approx(1.0)
    flat = curve_model([point(t, 2.6e-6, 1.0, integrator="dop853_compiled") for t in tols])
    assert flat.classification == "model difference" and flat.floor == pytest.approx(2.6e-6)


def test_the_order_table_shows_each_curves_class():
    from harness.studies.workprecision.report import markdown

    steps = [0.1 / 2**k for k in range(5)]
    sweep = SceneSweep("s", 1.0, 0.1, "ref", points=[point(h, 2.0 * h**4, 1.0 / h) for h in steps]
                       + [mujoco_point("rollout", h, 1e-5 + 3.0 * h**4, 1.0 / h) for h in steps])
    md = markdown([sweep], {}, SweepOptions(), command="harness workprecision")
    assert "| curve | nominal | class (order) | floor |" in md
    assert "| inhouse rk4_compiled (compiled) | 4 | converges (4.00) | 0 |" in md
    row = next(line for line in md.splitlines() if line.startswith("| mujoco RK4 (rollout) | 4 |"))
    assert "| model difference (0." in row and "| 1.0e-05 |" in row
    from harness.studies.workprecision.run import points_table

    table = points_table([sweep])
    assert set(table["curve_class"]) == {"converges", "model difference"}


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
    assert o.stop_error < min(TARGETS) and o.per_state == "uncovered"
    assert o.loop_budget_s <= o.curve_budget_s < o.key_budget_s


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


# ---------------------------------------------------------------------------------------------
# The sweep's time: ladders, budgets, stop rules, the reference, the per-state curves


def test_ladders_start_at_a_multiple_of_the_scene_dt():
    rk4, dop = Curve("mujoco", "RK4", "rollout"), Curve("inhouse", "dop853_compiled", "compiled")
    o = SweepOptions()
    ladder = _ladder(rk4, 0.5, o, 1e-3)  # 32 x 1 ms: the first save / 2^k at or below 0.032 s
    assert ladder[0] == 0.5 / 16 and ladder[-1] == 0.5 / 2**15 and len(ladder) == 12
    assert all(np.isclose(a / b, 2.0) for a, b in zip(ladder, ladder[1:]))
    assert _ladder(rk4, 0.5, replace(o, coarsest_dt=None), 1e-3)[0] == 0.5
    assert _ladder(rk4, 0.5, o, 1.0)[0] == 0.5  # never coarser than the save interval
    short = _ladder(rk4, 0.5, replace(o, dt_levels=3), 1e-3)
    assert len(short) == 3 and short[0] == 0.5 / 16  # at least three levels
    assert _ladder(dop, 0.5, o, 1e-3) == list(o.tolerances)


def test_next_cost_predicts_from_the_last_two_points():
    o = replace(SweepOptions(), repeats=3, slow_run_s=0.02)
    one = [(point(0.1, 1e-3, 0.005), 0.02)]  # repeats 1: 2 runs of 0.01 s
    assert next_cost(one, False, o) == pytest.approx(0.02 * 4)  # 0.02 s per run: 1 + 3 runs
    assert next_cost(one, True, o) == pytest.approx(0.015 * 4)
    two = one + [(point(0.05, 1e-4, 0.03), 0.06)]  # per run 0.01 -> 0.03: growth 3
    assert next_cost(two, False, o) == pytest.approx(0.09 * 2)  # slower than slow_run_s: 2 runs
    fast_drop = one + [(point(0.05, 1e-4, 0.001), 0.002)]  # growth clamped to 1
    assert next_cost(fast_drop, False, o) == pytest.approx(0.001 * 4)


def test_stop_reasons():
    o = SweepOptions()
    hist = lambda errs, **kw: [(point(0.1 / 2**i, e, 0.01, **kw), 0.05) for i, e in enumerate(errs)]  # noqa: E731
    assert stop_reason(hist([1e-3, 1e-5]), o) == ""
    assert stop_reason(hist([1e-3, 5e-12]), o) == "state error below 1e-11"
    assert stop_reason(hist([1e-3, 1e-4, 9e-5, 8e-5, 8.5e-5]), o) == "error stalled (model difference, floor 8.5e-05)"
    assert stop_reason(hist([1e-3, 1e-4, 9e-5, 8e-5, 8.5e-5], integrator="dop853_compiled"), o) == ""  # tolerances
    assert stop_reason(hist([0.5, 0.4, 0.45, 0.42]), o) == ""  # not stalled: above 1e-2, the coarse end
    assert stop_reason(hist([1e-3, 1e-4, 1e-5, 1e-6]), o) == ""
    failing = hist([1e-3]) + hist([float("nan")] * 3, status="failed")
    assert stop_reason(failing, o) == "runs fail"
    assert stop_reason(hist([float("nan")] * 4, status="blowup"), o) == ""  # never sound yet: the budget decides
    slow = [(point(0.1, 1e-3, o.max_run_s * 1.5), 1.0)]
    assert stop_reason(slow, o).startswith("a run took more than")


def fake_sweep(monkeypatch, curve, options, cost=lambda dt: 0.01 * 0.5 / dt, err=lambda dt: dt**4):
    """``sweep_scene`` of one curve with a fake clock and fake runs: a point at dt costs
    ``cost(dt)`` s of the clock and has state error ``err(dt)``; no engine runs."""
    import harness.studies.workprecision.run as wp

    now = [0.0]
    monkeypatch.setattr(wp, "_clock", lambda: now[0])
    monkeypatch.setattr(wp, "reference", lambda scene, t_end, save: (None, "fake"))
    monkeypatch.setattr(wp, "reference_checks", lambda *a: {})
    monkeypatch.setattr(wp, "compiled_covers", lambda scene: (True, ""))

    def fake_measure(scene, c, settings, ref, model, opts):
        now[0] += cost(settings.dt)
        return replace(point(settings.dt, err(settings.dt), cost(settings.dt) / 2), engine=c.engine,
                       integrator=c.integrator, variant=c.variant)

    monkeypatch.setattr(wp, "measure", fake_measure)
    return sweep_scene(load_scene("torque_free"), [curve.engine], options, curve_list=[curve])


def test_a_curve_stops_before_its_budget(monkeypatch):
    """Costs double with each halved dt (0.01, 0.02, 0.04 ... s): the point that would end past
    the budget is not run; the curves the targets are measured on get the larger budget."""
    o = replace(SweepOptions(), repeats=1, slow_run_s=0.0, coarsest_dt=None, curve_budget_s=1.0, key_budget_s=3.0,
                reach_budget_s=3.0, horizon=10.0, saves=20)
    euler = fake_sweep(monkeypatch, Curve("mujoco", "Euler", "rollout"), o)
    log = euler.curves["mujoco Euler (rollout)"]
    assert log["points"] == 6 and log["stop"] == "budget 1 s" and log["role"] == "ordinary"
    assert log["wall_s"] == pytest.approx(0.63) and log["wall_s"] <= 1.0
    rk4 = fake_sweep(monkeypatch, Curve("mujoco", "RK4", "rollout"), o)
    log = rk4.curves["mujoco RK4 (rollout)"]
    assert log["points"] == 8 and log["role"] == "key" and log["wall_s"] == pytest.approx(2.55)
    unlimited = fake_sweep(monkeypatch, Curve("mujoco", "Euler", "rollout"), replace(o, curve_budget_s=None, max_run_s=1e9),
                           err=lambda dt: dt)
    assert unlimited.curves["mujoco Euler (rollout)"]["points"] == o.dt_levels  # the whole ladder
    converged = fake_sweep(monkeypatch, Curve("mujoco", "RK4", "rollout"), o, err=lambda dt: dt**8)
    log = converged.curves["mujoco RK4 (rollout)"]
    assert log["stop"] == "state error below 1e-11" and log["points"] == 5  # dt 0.5 / 16: error 8.7e-13


def test_the_reference_is_the_compiled_dop853_where_it_models_the_scene(monkeypatch):
    scene = load_scene("torque_free")
    compiled, how = reference(scene, 2.0, 0.5)
    assert how.startswith("in-house compiled DOP853") and compiled.integrator == "dop853_compiled"
    assert len(compiled.t) == 5 and np.allclose(compiled.t, [0.0, 0.5, 1.0, 1.5, 2.0])
    per_state, how_ps = reference(scene, 2.0, 0.5, "DOP853")
    assert how_ps.startswith("in-house per-state engine") and per_state.integrator == "DOP853"
    assert errors(compiled, per_state, scene.multibody())["state_max"] < 1e-10  # two references, one motion
    not_modelled(monkeypatch, "no compiled form for this")
    fallback, how_fb = reference(scene, 2.0, 0.5)
    assert how_fb.startswith("in-house per-state engine") and "does not model this scene (no compiled form for this)" in how_fb
    assert errors(fallback, per_state, scene.multibody())["state_max"] == 0.0
    with pytest.raises(RuntimeError, match="no compiled form"):
        reference(scene, 2.0, 0.5, "dop853_compiled")


def test_per_state_curves_run_where_the_compiled_form_does_not_model_the_scene():
    engines = ["mujoco", "inhouse"]
    per_state = {c.label for c in curves(engines) if c.variant == "per-state"}
    assert per_state == {"inhouse rk4 (per-state)", "inhouse euler (per-state)", "inhouse RK45 (per-state)",
                         "inhouse DOP853 (per-state)"}
    o = SweepOptions()
    covered, omitted = scene_curves(engines, o, covered=True)
    assert not per_state & {c.label for c in covered} and set(omitted) == per_state
    assert all("--per-state all" in why for why in omitted.values())
    uncovered, omitted = scene_curves(engines, o, covered=False)
    assert per_state <= {c.label for c in uncovered} and not omitted
    everywhere, _ = scene_curves(engines, replace(o, per_state="all"), covered=True)
    assert per_state <= {c.label for c in everywhere}
    nowhere, omitted = scene_curves(engines, replace(o, per_state="none"), covered=False)
    assert not per_state & {c.label for c in nowhere} and set(omitted) == per_state
    # the budgets: the curves the targets are measured on
    dop_ps, dop_c = Curve("inhouse", "DOP853", "per-state"), Curve("inhouse", "dop853_compiled", "compiled")
    assert curve_role(dop_c) == "key" and curve_role(dop_ps) == "ordinary"
    assert curve_role(dop_ps, covered=False) == "key" and curve_role(dop_c, covered=False) == "ordinary"
    loop = Curve("mujoco", "RK4", "loop")
    assert curve_role(loop) == "loop" and curve_role(loop, {"mujoco RK4 (rollout)": "forces"}) == "key"
    assert curve_role(Curve("mujoco", "Euler", "loop"), {"mujoco RK4 (rollout)": "forces"}) == "loop"
    assert curve_role(Curve("drake", "RK3", "")) == "ordinary"


def test_head_to_head_says_which_side_did_not_reach_a_target():
    """Statuses decided from the recorded points alone (nothing is run)."""
    scene = load_scene("torque_free")
    sweep = SceneSweep("torque_free", 1.0, 0.5, "ref")
    sweep.points = [point(1e-8, 1e-11, 0.01, integrator="dop853_compiled"), mujoco_point("rollout", 0.01, 1e-7, 0.1)]
    rows = {r["target"]: r for r in head_to_head(scene, sweep, SweepOptions(), targets=(1e-8, 1e-12))}
    assert rows[1e-8]["status"] == "not reached by MuJoCo RK4" and rows[1e-8]["mujoco"] == "rollout"
    assert rows[1e-12]["status"] == "not reached by either"
    sweep.points = [mujoco_point("rollout", 0.01, 1e-7, 0.1)]
    assert head_to_head(scene, sweep, SweepOptions(), targets=(1e-6,))[0]["status"] == "not reached by the in-house solver"
    sweep.skipped = {"mujoco RK4 (rollout)": "rollout: forces", "mujoco RK4 (loop)": "loop: no"}
    row = head_to_head(scene, sweep, SweepOptions(), targets=(1e-6,))[0]
    assert row["mujoco"] == "loop" and row["status"] == "MuJoCo RK4 not run: loop: no"


def test_the_targets_table_marks_each_scene(monkeypatch):
    from harness.studies.workprecision.report import markdown, target_rows

    def h2h(target, **kw):
        row = {"target": target, "mujoco": "rollout", **kw}
        if row["status"] == "ok":  # the runs, as ``head_to_head`` records them
            run = {"label": "x", "param": 0.1, "state_max": target / 2, "time_s": 1.0, "time_min_s": 1.0}
            row.update({"inhouse": run, f"mujoco RK4 ({row['mujoco']})": run, "rounds": 3})
        return row

    def batch(scene, compiled, mujoco):
        return {"scene": scene, "status": "ok", "nbatch": 100, "nstep": 100, "dt": 1e-3, "threads": 2,
                "compiled_steps_per_s": compiled, "mujoco_steps_per_s": mujoco, "compiled_1thread_steps_per_s": compiled,
                "mujoco_1thread_steps_per_s": mujoco, "max_state_difference": 1e-12}

    met = SceneSweep("a", 1.0, 0.1, "ref", head_to_head=[h2h(1e-6, status="ok", ratio=0.3),
                                                          h2h(1e-10, status="ok", ratio=0.7)],
                     batch=batch("a", 6e5, 1e5))
    unreached = SceneSweep("b", 1.0, 0.1, "ref", head_to_head=[h2h(1e-6, status="ok", ratio=0.5, mujoco="loop"),
                                                                h2h(1e-10, status="not reached by MuJoCo RK4")],
                           batch={"scene": "b", "status": "skipped: mujoco.rollout holds controls over a step"})
    failed = SceneSweep("c", 1.0, 0.1, "ref", head_to_head=[{"status": "failed: ValueError: x"}],
                        batch=batch("c", 2e5, 1e5))
    lonely = SceneSweep("d", 1.0, 0.1, "ref", head_to_head=[h2h(1e-6, status="not reached by the in-house solver"),
                                                             h2h(1e-10, status="MuJoCo RK4 not run: rollout: forces")])
    met.walls = {"reference": 0.1, "curves": 8.0, "head_to_head": 1.0, "batch": 2.0, "total": 11.1, "kernels": 3.0}
    met.curves = {"mujoco RK4 (rollout)": {"wall_s": 2.5, "points": 8, "stop": "budget 3 s", "budget_s": 3.0, "role": "key"}}
    rows = {r["scene"]: r for r in target_rows([met, unreached, failed, lonely])}
    status = lambda scene, key: rows[scene][key]["status"]  # noqa: E731
    assert [status("a", k) for k in (1e-6, 1e-10, "batch")] == ["met", "not met", "met"]
    assert rows["a"][1e-6]["value"] == 0.3 and rows["a"]["batch"]["value"] == pytest.approx(6.0)
    assert [status("b", k) for k in (1e-6, 1e-10, "batch")] == ["met", "not reached by MuJoCo", "not run"]
    assert "loop" in rows["b"][1e-6]["note"] and "holds controls" in rows["b"]["batch"]["note"]
    assert [status("c", k) for k in (1e-6, 1e-10, "batch")] == ["not run", "not run", "not met"]
    assert "ValueError" in rows["c"][1e-6]["note"]
    assert [status("d", k) for k in (1e-6, 1e-10, "batch")] == ["not met", "not run", "not run"]
    md = markdown([met, unreached, failed, lonely], {"machine": "test"}, SweepOptions(), load=(1.5, 2.5),
                  command="harness workprecision", wall_s=240.0)
    targets = md.split("## Targets")[1].split("## ")[0]
    assert "| a | met (0.30) | not met (0.70) | met (6.00) |" in targets
    assert "| b | met (0.50) — against MuJoCo's loop" in targets and "| not reached by MuJoCo | not run (skipped:" in targets
    unreached.points = [mujoco_point("rollout", 0.01, 3e-5, 0.1), mujoco_point("rollout", 0.005, 2e-5, 0.2)]
    unreached.curves = {"mujoco RK4 (rollout)": {"wall_s": 1.0, "points": 2, "stop": "error stalled"}}
    assert target_rows([unreached])[0][1e-10]["note"] == "best 2.0e-05, error stalled"
    alone = markdown([unreached], {}, SweepOptions(), command="harness workprecision")
    assert "| not reached by MuJoCo (best 2.0e-05, error stalled) |" in alone
    assert "ratio at 1e-06: met on 2 of 3 scenes judged (1 not run)" in targets
    assert "The sweep took 240 s wall (4.0 min) for 4 scenes; load average of the machine (1 min) before and after: 1.50, 2.50" in md
    assert md.index("## Targets") < md.index("## How the sweep was run") < md.index("## Where the time went")
    assert "| a | 11.1 | 0.10 | 8.0 | 1.0 | 2.0 | mujoco RK4 (rollout) 2.5 |" in md and "kernels" in md


def test_batch_size_fits_the_budget():
    from harness.studies.workprecision.run import batch_size

    o = replace(SweepOptions(), batch=1000, batch_budget_s=3.0)
    assert batch_size(1e-3, o, 2) == 250  # 3 s / (4 variants x 3 rounds) / 1 ms
    assert batch_size(1e-6, o, 2) == 1000 and batch_size(10.0, o, 2) == 2  # at most --batch, at least one per thread
    assert batch_size(1e-3, replace(o, batch_budget_s=None), 2) == 1000 and batch_size(float("nan"), o, 2) == 1000
    assert batch_size(10.0, replace(o, batch=1), 2) == 1


def test_target_curves_get_longer_while_they_converge_towards_a_target(monkeypatch):
    """heavy_top's MuJoCo RK4 stopped at 2e-10 with its 3 s budget, one halving short of 1e-10:
    a target curve converging at its order goes on under reach_budget_s until it reaches the
    smallest target; one that converges slower than half its order keeps its budget."""
    from harness.studies.workprecision.run import converging, reach

    o = replace(SweepOptions(), repeats=1, slow_run_s=0.0, coarsest_dt=None, curve_budget_s=1.0, key_budget_s=1.0,
                reach_budget_s=3.0, horizon=10.0, saves=20)
    rk4 = Curve("mujoco", "RK4", "rollout")
    fourth = fake_sweep(monkeypatch, rk4, o, err=lambda dt: 1e-2 * dt**4)  # 1e-10 at dt 0.0178: k = 5
    log = fourth.curves["mujoco RK4 (rollout)"]
    assert min(p.state_max for p in fourth.points) <= 1e-10 < 1e-2 * (0.5 / 16) ** 4
    assert log["points"] == 7 and log["wall_s"] > 1.0 and log["stop"] == "budget 1 s"  # past 1e-10: the base budget again
    slow = fake_sweep(monkeypatch, rk4, o, err=lambda dt: 1e-2 * dt**1.5)  # below half of order 4
    assert slow.curves["mujoco RK4 (rollout)"]["points"] == 6 and slow.curves["mujoco RK4 (rollout)"]["stop"] == "budget 1 s"
    euler = fake_sweep(monkeypatch, Curve("mujoco", "Euler", "rollout"), o, err=lambda dt: dt)  # not a target curve
    assert euler.curves["mujoco Euler (rollout)"]["points"] == 6
    # what each target curve must reach
    dop = Curve("inhouse", "dop853_compiled", "compiled")
    assert reach(rk4, "key", None) == min(TARGETS) and reach(rk4, "ordinary", None) is None
    assert reach(dop, "key", 3e-8) == 1e-6 and reach(dop, "key", 1e-12) == 1e-10 and reach(dop, "key", 1e-3) is None
    assert reach(dop, "key", None) is None
    hist = lambda errs, **kw: [(point(0.1 / 2**i, e, 0.01, **kw), 0.05) for i, e in enumerate(errs)]  # noqa: E731
    assert converging(hist([1e-4, 1e-4 / 16]), rk4) and not converging(hist([1e-4, 1e-4 / 3]), rk4)
    assert not converging(hist([1e-4]), rk4) and not converging(hist([1e-4, float("nan")], status="failed"), rk4)
    assert converging(hist([1e-4, 1e-5], integrator="dop853_compiled"), dop)


def test_cli_options_set_the_budgets_and_the_per_state_curves(capsys):
    from harness.cli.main import build_parser
    from harness.cli.workprecision import options_from_args

    parse = lambda *a: options_from_args(build_parser().parse_args(["workprecision", *a]))  # noqa: E731
    default = parse()
    assert default == replace(SweepOptions(), progress=True)
    o = parse("--budget-s", "2", "--key-budget-s", "5", "--per-state", "all", "--batch-budget-s", "1")
    assert (o.curve_budget_s, o.loop_budget_s, o.key_budget_s, o.per_state, o.batch_budget_s) == (2.0, 1.0, 5.0, "all", 1.0)
    free = parse("--no-budget", "--max-run-s", "0.5")
    assert free.curve_budget_s is free.key_budget_s is free.loop_budget_s is free.reach_budget_s is None
    assert free.max_run_s == 0.5
    assert parse("--quick").per_state == "all"
    assert main(["workprecision", "--budget-s", "0"]) == 2 and "--budget-s out of range" in capsys.readouterr().err


def test_a_point_over_its_wall_clock_budget_is_timed_out_and_the_sweep_goes_on(monkeypatch):
    """Every point runs in its own worker under ``run_timeout_s``: one that hangs is killed and
    recorded as failed, "timed out after N s", its curve stops there, and the next curve still
    runs all its points."""
    import time

    import harness.studies.workprecision.run as wp

    monkeypatch.setattr(wp, "reference", lambda scene, t_end, save: (None, "fake"))
    monkeypatch.setattr(wp, "reference_checks", lambda *a: {})
    monkeypatch.setattr(wp, "compiled_covers", lambda scene: (True, ""))

    def fake_measure(scene, c, settings, ref, model, opts):
        if c.integrator == "Euler" and settings.dt < 0.3:
            time.sleep(30)  # a hang: killed at the budget
        return replace(point(settings.dt, settings.dt**2, 1e-4), engine=c.engine, integrator=c.integrator,
                       variant=c.variant)

    monkeypatch.setattr(wp, "measure", fake_measure)
    options = replace(QUICK, run_timeout_s=0.3, curve_budget_s=None, key_budget_s=None, loop_budget_s=None,
                      reach_budget_s=None, progress=False)
    euler, rk4 = Curve("mujoco", "Euler", "rollout"), Curve("mujoco", "RK4", "rollout")
    start = time.perf_counter()
    sweep = sweep_scene(load_scene("torque_free"), ["mujoco"], options, curve_list=[euler, rk4])
    assert time.perf_counter() - start < 10
    by_label = {label: [p for p in sweep.points if p.label == label] for label in (euler.label, rk4.label)}
    assert [p.param for p in by_label[euler.label]] == [2.0, 1.0, 0.5, 0.25]  # torque_free: save 10 s / 5
    last = by_label[euler.label][-1]
    assert last.status == "failed" and last.message.startswith("timed out after 0.3 s"), last
    assert sweep.curves[euler.label]["stop"] == last.message
    assert all(p.ok for p in by_label[euler.label][:-1])
    assert len(by_label[rk4.label]) == QUICK.dt_levels and all(p.ok for p in by_label[rk4.label])


def test_a_sweep_beyond_the_step_budget_is_refused_before_any_run(tmp_path, capsys):
    from harness.cli.main import main

    out = tmp_path / "wp"
    code = main(["workprecision", "--scenes", "heavy_top", "--quick", "--saves", "10000000", "--out-dir", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert "heavy_top: the sweep's finest step (--saves, --t-end): a horizon of 5 s at a step of 7.8125e-09 s is " \
           "6.4e+08 integration steps, more than the 1e+08" in err[0], err
    assert not out.exists()


def test_a_scene_without_a_reference_run_is_measured_against_its_closed_form():
    """four_bar_chain has no reference run (validate's has_reference) and its reference module
    gives the exact motion of every body (exact_trajectory): the sweep measures against that. A
    scene whose reference engine does not run it and that has no such motion gets no points, and
    its reference line says why (``scene_study``)."""
    from dataclasses import replace

    from harness.studies.workprecision.run import reference, scene_study

    scene = load_scene("four_bar_chain", {"N": 1})
    traj, how = reference(scene, 1.0, 0.1)
    assert how.startswith("the closed form") and traj.t[-1] == pytest.approx(1.0) and len(traj.t) == 11
    mujoco = get_engine("mujoco").simulate(scene, RunSettings(1.0, 1e-4, 0.1, "RK4"))
    assert float(np.max(np.abs(mujoco.p_WCm_W - traj.p_WCm_W))) < 1e-4  # its soft loops, at a fine step
    assert float(np.max(np.abs(mujoco.w_WB_W - traj.w_WB_W))) < 1e-3
    lost = replace(load_scene("four_bar", {}), not_run={"inhouse": "a finding"})
    result = scene_study(lost, list(ENGINE_NAMES), SweepOptions(progress=False))
    assert result.points == [] and result.reference.startswith("none: the in-house engine does not run this scene")