"""``harness stress``: catalogue, stability rule, step search, drift classes, isolation, CLI."""

import math
import os
import time

import numpy as np
import pandas as pd
import pytest

from harness.cli.main import main
from harness.engines import inhouse
from harness.engines.pinocchio import engine as pinocchio_engine
from harness.model.errors import InputError
from harness.measure.trajectory import UNSUPPORTED, Failure, failed
from harness.studies.stress.run import (
    FAILURE_MODES,
    Reference,
    StepSearch,
    TrialResult,
    TrialSpec,
    classify_drift,
    engine_mode,
    load_catalogue,
    run_settings,
    run_stress,
    select,
    skip_reason,
    trial_case,
    variant_scene,
)

SMALL = """
[defaults]
bisect_iters = 0
search_steps = 0
band = { exact = 1e-4, position = 1e-3, orientation = 1e-3, velocity = 1e-3, angular_velocity = 1e-3, energy = 1e-3 }
max_steps = { inhouse = 10000, pinocchio = 10000, mujoco = 100000 }
integrators = { inhouse = ["rk4"], mujoco = ["RK4"], pinocchio = ["rkmk4"] }

[variants.spin]
scene = "torque_free"
set = { omega0 = [10.0, 10.0, 1000.0] }
t_end = 0.01
save_every = 1e-3
dt = 1e-3
dt_max = 1e-3
references = ["exact"]
"""


def run(args, capsys):
    code = main(args)
    out = capsys.readouterr()
    return code, out.out, out.err


def fake_result(spec: TrialSpec, stable: bool, mode: str = "energy growth", t_fail=None) -> TrialResult:
    return TrialResult(spec, "ok", "" if stable else mode, stable, stable, 0.0, "energy", {}, {}, 0.0, 0.0,
                       spec.t_end, None if stable else t_fail, "", float("nan"), 1.0, float("nan"), 0.0, "")


def test_catalogue_covers_the_issue():
    cat = load_catalogue()
    tags = {t for v in cat.variants for t in v.tags}
    assert {"fast_spin", "singular", "ratio", "stiff", "long", "flip"} <= tags
    spins = [v.sweep for v in cat.variants if "fast_spin" in v.tags]
    assert max(spins) >= 1e4
    springs = sorted(v.sweep for v in cat.variants if "stiff" in v.tags)
    assert springs[0] == 1e2 and springs[-1] == 1e8
    assert any(v.scene == "rolling_disk" for v in cat.variants)
    for v in cat.variants:
        assert "mujoco" in v.integrators and "inhouse" in v.integrators and "pinocchio" in v.integrators


def test_catalogue_rejects_unknown_keys_and_integrators(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text(SMALL.replace('scene = "torque_free"', 'scene = "torque_free"\nhorizon = 3'))
    with pytest.raises(InputError, match="unknown key 'horizon'"):
        load_catalogue(path)
    path.write_text(SMALL.replace('mujoco = ["RK4"]', 'mujoco = ["RK5"]'))
    with pytest.raises(InputError, match="unknown integrator 'RK5' for mujoco"):
        load_catalogue(path)


def test_missing_scene_or_parameter_is_skipped_with_a_reason(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text(SMALL.replace('scene = "torque_free"', 'scene = "no_such_scene"').replace('["exact"]', "[]"))
    v = load_catalogue(path).variants[0]
    assert skip_reason(v).startswith("scene not available")
    path.write_text(SMALL.replace("omega0 = [10.0, 10.0, 1000.0]", "stiffness = 3.0"))
    v = load_catalogue(path).variants[0]
    assert "has no parameter 'stiffness'" in skip_reason(v)


def test_exact_needs_a_per_sample_closed_form_and_unscaled_bodies(tmp_path):
    """``references = ["exact"]`` takes the scene's ``exact_error_series`` (references/<scene>.py):
    a scene whose exact check makes runs of its own has none; scaled bodies leave the closed form."""
    from harness.measure import exact
    from harness.model.scene import available_scenes

    path = tmp_path / "c.toml"
    with_runs = [s for s in available_scenes() if exact.needs_runs(s)]
    assert with_runs and not any(exact.has_error_series(s) for s in with_runs)
    path.write_text(SMALL.replace('scene = "torque_free"', f'scene = "{with_runs[0]}"'))
    with pytest.raises(InputError, match="no exact solution .* per sample"):
        load_catalogue(path)
    path.write_text(SMALL.replace('references = ["exact"]', 'references = ["exact"]\nscale = { body = 2.0 }'))
    with pytest.raises(InputError, match="with scaled bodies"):
        load_catalogue(path)


def _series_scenes():
    from harness.measure import exact
    from harness.model.scene import available_scenes

    return [s for s in available_scenes() if exact.has_error_series(s)]


@pytest.mark.parametrize("name", _series_scenes())
def test_a_trial_follows_the_reference_error_per_sample(tmp_path, name):
    """Every scene with a per-sample closed form can be stressed against it: ``exact`` is the
    reference module's series, its maximum the run's error."""
    from harness.engines import get_engine
    from harness.engines.base import RunSettings
    from harness.measure import exact
    from harness.engines import load_scene

    scene = load_scene(name)
    path = tmp_path / "c.toml"
    spec_text = SMALL.replace('scene = "torque_free"', f'scene = "{name}"').replace("set = { omega0 = [10.0, 10.0, 1000.0] }\n", "")
    spec_text = spec_text.replace("save_every = 1e-3\ndt = 1e-3\ndt_max = 1e-3",
                                  f"save_every = {scene.save_every!r}\ndt = {scene.dt!r}\ndt_max = {scene.dt!r}")
    spec_text = spec_text.replace("t_end = 0.01", f"t_end = {10 * scene.save_every!r}")
    path.write_text(spec_text)
    cat = load_catalogue(path)
    v = cat.variants[0]
    ref = Reference(None, True, dict(v.band))
    spec = TrialSpec(v.name, "mujoco", scene.integrators["mujoco"], v.dt, v.t_end, v.save_every, 1e-8, "nominal")
    r = trial_case(variant_scene(v), spec, ref, cat.bounds)
    traj = get_engine("mujoco").simulate(scene, RunSettings(v.t_end, v.dt, v.save_every, scene.integrators["mujoco"]))
    assert r.stable and r.error_kind == "exact"
    assert r.max_errors["exact"] == float(np.max(exact.exact_error_series(scene, traj)))


def test_scaled_bodies_reach_every_engine():
    from harness.engines.mujoco.model import load_mjcf

    cat = load_catalogue()
    scene = variant_scene(cat.variant("double_pendulum_mass_1e3"))
    model = scene.multibody()
    assert model.body("bar2").mass == pytest.approx(1e3 * model.body("bar1").mass)
    m = load_mjcf(scene.mjcf, model)
    assert m.body_mass[2] == pytest.approx(1e3 * m.body_mass[1])


def test_drift_classes():
    t = np.linspace(0.0, 1000.0, 20001)
    assert classify_drift(t, 1e-6 * np.abs(np.sin(3.0 * t)))[0] == "bounded"
    assert classify_drift(t, 1e-9 * t * (1.5 + np.sin(3.0 * t)))[0] == "linear"
    cls, p = classify_drift(t, 1e-12 * t**3)
    assert cls.startswith("faster") and p == pytest.approx(3.0, rel=1e-3)
    assert classify_drift(t, 1e-12 * np.exp(t / 50.0))[0] == "faster (exponential)"
    assert classify_drift(t, np.zeros_like(t))[0] == "bounded"


def drive(search: StepSearch, threshold: float) -> None:
    """Feed a search the answers of a system stable at dt <= threshold."""
    for _ in range(50):
        specs = search.next_specs()
        if not specs:
            return
        for spec in specs:
            search.record(fake_result(spec, spec.dt <= threshold))
    raise AssertionError("search did not end")


def test_step_search_brackets_the_stability_limit():
    cat = load_catalogue()
    v = cat.variant("heavy_top_spin_1e3")  # save 1e-4, dt_max 8e-3, horizon 0.2 s
    search = StepSearch(v, "mujoco", "RK4", cat.bounds)
    drive(search, 2.345e-3)
    row = search.summary()
    assert row.stable_dt <= 2.345e-3 < row.unstable_dt
    assert row.unstable_dt / row.stable_dt <= 1.0 + cat.bounds.precision + 1e-9 or search.iters == cat.bounds.bisect_iters
    assert row.mode == "energy growth" and not row.censored
    for dt, r in row.trials.items():  # every trial lands on the saved times
        ratio = r.spec.save_every / dt
        assert abs(ratio - round(ratio)) < 1e-9 and r.spec.save_every / v.save_every == pytest.approx(round(r.spec.save_every / v.save_every))


def test_step_search_censored_and_budget_floor():
    cat = load_catalogue()
    v = cat.variant("heavy_top_spin_1e3")
    search = StepSearch(v, "mujoco", "implicit", cat.bounds)
    drive(search, 1.0)
    row = search.summary()
    assert row.censored and row.stable_dt == pytest.approx(v.dt_max) and len(row.trials) == 2
    search = StepSearch(v, "inhouse", "euler", cat.bounds)  # budget: 1e4 steps over 0.2 s
    drive(search, 1e-9)
    row = search.summary()
    assert row.stable_dt is None and row.unstable_dt >= v.t_end / cat.bounds.max_steps["inhouse"] * (1 - 1e-9)
    assert any("no stable step" in n for n in row.notes)


@pytest.mark.parametrize("engine, method, adaptive", [
    ("drake", "RK5", True), ("drake", "Radau3", True), ("drake", "RK3_fixed", False),
    ("inhouse", "DOP853", True), ("inhouse", "rk4", False), ("mujoco", "RK4", False)])
def test_every_error_controlled_integrator_runs_once_at_rtol(engine, method, adaptive):
    """An error-controlled method takes the steps its accuracy asks for whatever dt is: a step
    search over dt would repeat the same run (Drake's RK5 was searched, and timed out, as if it
    stepped at dt)."""
    cat = load_catalogue()
    v = cat.variant("heavy_top_spin_1e3")
    search = StepSearch(v, engine, method, cat.bounds)
    assert search.adaptive is adaptive
    specs = search.next_specs()
    if adaptive:
        assert [s.role for s in specs] == ["adaptive"] and specs[0].rtol == v.rtol
        search.record(fake_result(specs[0], True))
        assert search.next_specs() == [] and search.summary().kind == "adaptive"
    else:
        assert {s.role for s in specs} <= {"search", "nominal"}


def test_a_horizon_per_engine_or_per_integrator(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text(SMALL.replace("t_end = 0.01", 't_end = 0.01\nt_end_by_engine = { mujoco = 0.005, "mujoco/Euler" = 0.002 }'))
    v = load_catalogue(path).variants[0]
    assert v.horizon("mujoco", "Euler") == 0.002 and v.horizon("mujoco", "RK4") == 0.005
    assert v.horizon("mujoco") == 0.005 and v.horizon("inhouse", "rk4") == 0.01
    assert StepSearch(v, "mujoco", "Euler", load_catalogue(path).bounds).t_end == 0.002
    path.write_text(SMALL.replace("t_end = 0.01", 't_end = 0.01\nt_end_by_engine = { "mujoco/RK5" = 0.002 }'))
    with pytest.raises(InputError, match="unknown integrator 'RK5' for mujoco"):
        load_catalogue(path)


def test_inhouse_trials_run_the_compiled_twin_where_it_models_the_scene(tmp_path):
    v = load_catalogue().variant("heavy_top_spin_1e3")
    scene = variant_scene(v)
    for method, runs in [("rk4", "rk4_compiled"), ("DOP853", "dop853_compiled"), ("euler", "euler")]:
        spec = TrialSpec(v.name, "inhouse", method, 1e-3, 0.01, 1e-3, 1e-8, "nominal")
        assert run_settings(scene, spec).integrator == runs
    spec = TrialSpec(v.name, "mujoco", "RK4", 1e-3, 0.01, 1e-3, 1e-8, "nominal")
    assert run_settings(scene, spec).integrator == "RK4"


def test_step_search_stops_on_a_failure_no_step_size_cures():
    cat = load_catalogue()
    v = cat.variant("rolling_disk_falling_flat")
    search = StepSearch(v, "pinocchio", "rkmk4", cat.bounds)
    for _ in range(10):
        specs = search.next_specs()
        if not specs:
            break
        for spec in specs:  # the disk lands at 0.0995 s whatever the step
            search.record(fake_result(spec, False, "singular constraint", t_fail=0.0995))
    row = search.summary()
    assert row.stable_dt is None and row.mode == "singular constraint" and len(row.trials) <= 3
    assert any("not a step-size instability" in n for n in row.notes)
    search = StepSearch(v, "pinocchio", "rkmk4", cat.bounds)
    for spec in search.next_specs():  # an instability that shows at the first samples goes on
        search.record(fake_result(spec, False, "energy growth", t_fail=2e-3))
    assert search.next_specs()


def test_trial_detects_mujoco_bad_acceleration_and_energy_growth():
    cat = load_catalogue()
    v = cat.variant("torque_free_spin_1e4")
    scene = variant_scene(v)
    ref = Reference(None, True, dict(v.band))
    spec = TrialSpec(v.name, "mujoco", "Euler", 1e-3, 0.02, 1e-3, 1e-8, "search")
    r = trial_case(scene, spec, ref, cat.bounds)
    # MuJoCo's own guard fires (and resets the state), but the energy left its bound earlier
    assert not r.stable and r.status == "blowup" and "mjWARN_BADQACC" in r.message
    assert r.mode == "energy growth" and r.t_fail < r.t_reached
    spec = TrialSpec(v.name, "pinocchio", "euler", 1e-4, 0.02, 1e-4, 1e-8, "search")
    r = trial_case(scene, spec, ref, cat.bounds)
    assert not r.stable and r.mode in ("energy growth", "magnitude growth")
    spec = TrialSpec(v.name, "mujoco", "implicit", 1e-4, 0.02, 1e-4, 1e-8, "search")
    r = trial_case(scene, spec, ref, cat.bounds)
    assert r.stable and r.error_kind == "exact" and r.divergence["exact"] is not None


def test_crash_and_timeout_are_recorded_and_the_rest_kept(tmp_path, monkeypatch):
    path = tmp_path / "c.toml"
    path.write_text(SMALL)
    cat = load_catalogue(path)

    def crash(scene, settings):
        os._exit(3)

    def hang(scene, settings):
        time.sleep(30)

    monkeypatch.setattr(pinocchio_engine.ENGINE, "simulate", crash)
    monkeypatch.setattr(inhouse.ENGINE, "simulate", hang)
    variants, engines = select(cat, None, None)
    t0 = time.perf_counter()
    result = run_stress(cat, variants, engines, jobs=2, timeout=1.0)
    assert time.perf_counter() - t0 < 15
    rows = {m.engine: m for m in result.rows}
    assert rows["pinocchio"].nominal.mode == "crash" and "exit code 3" in rows["pinocchio"].nominal.message
    assert rows["inhouse"].nominal.mode == "timeout"
    assert rows["mujoco"].stable_dt == pytest.approx(1e-3) and rows["mujoco"].nominal.stable


def test_cli_stress_quick_subset(tmp_path, capsys):
    out = tmp_path / "reports"
    code, stdout, err = run(["stress", "--variants", "torque_free_spin_1e3,heavy_top_spin_1e3",
                             "--engines", "mujoco,pinocchio", "--quick", "--jobs", "2", "--out-dir", str(out)], capsys)
    assert code == 0, err
    md = (out / "stress.md").read_text()
    for fragment in ("## Stability map", "## Closing note", "### torque_free_spin_1e3", "mujoco/RK4", "pinocchio/euler"):
        assert fragment in md
    trials = pd.read_csv(out / "stress.csv")
    assert set(trials["variant"]) == {"torque_free_spin_1e3", "heavy_top_spin_1e3"}
    assert {"reference", "mujoco", "pinocchio"} <= set(trials["engine"])
    assert set(trials["mode"].dropna()) <= set(FAILURE_MODES)
    cells = pd.read_csv(out / "stress_map.csv")
    assert len(cells) == 2 * 6
    rk4 = cells[(cells.variant == "torque_free_spin_1e3") & (cells.integrator == "RK4")].iloc[0]
    assert rk4.stable_dt > 0 and math.isfinite(rk4.error_at_stable)
    assert (out / "stress" / "map.png").read_bytes()[:4] == b"\x89PNG"
    legend = next(line for line in md.splitlines() if line.startswith("Map colours:"))
    assert "salmon = **none stable**" in legend and "light grey = **not run**" in legend
    assert (out / "stress" / "torque_free_spin_1e3.png").is_file()
    assert not list(out.rglob(".*.tmp"))


@pytest.mark.parametrize("args,fragment", [
    (["--variants", "no_such_variant"], "unknown variant 'no_such_variant'"),
    (["--engines", "bullet"], "unknown engine 'bullet'"),
    (["--timeout", "0"], "--timeout must be positive"),
])
def test_cli_stress_bad_input(tmp_path, capsys, args, fragment):
    code, _, err = run(["stress", "--out-dir", str(tmp_path / "r")] + args, capsys)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("harness: error:") and fragment in lines[0], err
    assert not (tmp_path / "r").exists()


def test_plots_are_drawn_in_workers_and_a_crash_is_named(monkeypatch):
    """The figures are drawn in workers: the PNGs come back under their names, and a worker that
    dies is an error naming its figures, not a report with a hole."""
    import os
    from types import SimpleNamespace

    from harness.studies.stress import report

    variants = [SimpleNamespace(name=n, sweep=None, group=n) for n in ("a", "b")]
    fake = SimpleNamespace(variants=variants, skipped={})
    monkeypatch.setattr(report, "map_png", lambda run: b"map")
    monkeypatch.setattr(report, "variant_png", lambda run, v: f"png {v.name} {os.getpid()}".encode())
    refs, files = report.plot_files(fake)
    assert refs == {"map": "stress/map.png", "a": "stress/a.png", "b": "stress/b.png"}
    assert files["stress/a.png"].startswith(b"png a ") and files["stress/map.png"] == b"map"
    assert int(files["stress/a.png"].split()[-1]) != os.getpid()  # drawn in a worker
    monkeypatch.setattr(report, "variant_png", lambda run, v: os._exit(3) if v.name == "b" else b"ok")
    with pytest.raises(RuntimeError, match=r"stress plots \(.*b\.png.*\): crashed"):
        report.plot_files(fake)


def test_map_tells_none_stable_from_not_run():
    """A searched cell with no stable step, an engine/integrator the variant does not list, a
    skipped variant and a stable cell get their own state and colour."""
    from types import SimpleNamespace

    from matplotlib.colors import to_rgba

    from harness.studies.stress import report
    from harness.studies.stress.run import MapRow

    def row(variant, engine, integrator, stable_dt, unstable_dt):
        return MapRow(variant, engine, integrator, 1.0, "fixed", stable_dt, False, unstable_dt, "energy_growth",
                      float("nan"), "", False, None, stable_dt or float("nan"), [], {})

    rows = [row("a", "inhouse", "rk4", 1e-3, 2e-3), row("a", "mujoco", "RK4", None, 1e-4),
            row("b", "inhouse", "rk4", None, 1e-5)]
    fake = SimpleNamespace(variants=[SimpleNamespace(name=n) for n in ("a", "b", "c")], skipped={"c": "no scene"},
                           rows=rows, rates={"a": 10.0, "b": 10.0})
    variants, labels, states, z = report.map_cells(fake)
    assert variants == ["a", "b", "c"] and labels == ["inhouse/rk4", "mujoco/RK4"]
    assert states == [["stable", report.NONE_STABLE], [report.NONE_STABLE, report.NOT_RUN],
                      [report.NOT_RUN, report.NOT_RUN]]
    assert z[0, 0] == pytest.approx(math.log10(1e-3 * 10.0)) and np.isnan(z[0, 1])
    colours = {k: to_rgba(c) for k, c in report.MAP_COLOURS.items()}
    assert colours[report.NONE_STABLE] != colours[report.NOT_RUN]
    assert report.MAP_LEGEND[report.NONE_STABLE] != report.MAP_LEGEND[report.NOT_RUN]
    assert report.map_png(fake)[:4] == b"\x89PNG"


COMPILED_ON_DISK = """
[defaults]
bisect_iters = 1
search_steps = 2
band = { exact = 1e-4, position = 1e-3, orientation = 1e-3, velocity = 1e-3, angular_velocity = 1e-3, energy = 1e-3 }
max_steps = { inhouse = 10000, pinocchio = 10000, mujoco = 100000 }
integrators = { inhouse = ["rk4", "rk4_compiled", "dop853_compiled"] }

[variants.disk]
scene = "rolling_disk"
t_end = 0.02
save_every = 1e-3
dt = 1e-3
dt_max = 4e-3
references = []
"""


@pytest.mark.slow  # worker processes
def test_an_unsupported_integrator_is_not_run_never_none_stable(tmp_path, monkeypatch):
    """Compiled in-house integrators on a scene they do not model (made to refuse it: they model
    every scene today): their trials come back "unsupported", the search stops after the first,
    and the cell is "not run: <reason>" in the map, the colours and the report, never "none
    stable"; the per-state rk4 is searched as usual."""
    from harness.engines.inhouse.compiled import solver
    from harness.studies.stress import report

    def refuse(nem):  # the workers are forked: they inherit it
        raise NotImplementedError("the compiled in-house solver does not model rolling contacts")

    monkeypatch.setattr(solver, "pack", refuse)

    path = tmp_path / "c.toml"
    path.write_text(COMPILED_ON_DISK)
    cat = load_catalogue(path)
    res = run_stress(cat, list(cat.variants), ["inhouse"], jobs=2, timeout=120)
    rows = {m.integrator: m for m in res.rows}
    for method in ("rk4_compiled", "dop853_compiled"):
        m = rows[method]
        assert "rolling contacts" in m.unsupported and m.stable_dt is None
        assert all(r.status == "unsupported" for r in m.trials.values())
        assert len(m.trials) <= 2  # the first trials only: no step search on a scene it cannot run
        assert report.cell_state(m) == report.NOT_RUN and report.map_cell(m) == report.NOT_RUN
        assert f"not run: {m.unsupported}" in m.notes
    assert not rows["rk4"].unsupported and report.cell_state(rows["rk4"]) != report.NOT_RUN
    _, labels, states, _ = report.map_cells(res)
    assert [s for label, s in zip(labels, states[0]) if "compiled" in label] == [report.NOT_RUN] * 2
    md = report.markdown(res, {"machine": "test"}, {}, command="harness stress")
    assert "none stable" not in md.split("## Stability map")[1].split("## Closing note")[0]
    assert "`disk` inhouse/rk4_compiled: rk4_compiled: the compiled in-house solver does not model rolling contacts" in md
    frame = report.map_frame(res).set_index("integrator")
    assert "rolling contacts" in frame.loc["dop853_compiled", "not_run"] and frame.loc["rk4", "not_run"] == ""


def test_an_unsupported_trial_stops_the_search():
    cat = load_catalogue_text(SMALL)
    v = cat.variants[0]
    s = StepSearch(v, "inhouse", "rk4", cat.bounds)
    (spec,) = s.next_specs()
    traj = failed("inhouse", "rk4", ["body"], Failure.UNSUPPORTED, "rk4: no equations for this joint")
    s.record(trial_case_result(traj, spec, v))
    assert s.next_specs() == [] and s.done
    row = s.summary()
    assert row.unsupported == "rk4: no equations for this joint" and row.mode == "" and row.stable_dt is None


def load_catalogue_text(text):
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "c.toml")
        with open(path, "w") as f:
            f.write(text)
        return load_catalogue(path)


def trial_case_result(traj, spec, variant):
    from harness.studies.stress.run import Bounds, evaluate

    return evaluate(traj, variant_scene(variant), spec, Reference(None, False, dict(variant.band)), Bounds())


def test_the_engine_mode_follows_the_reason_never_the_text():
    """The run's ``Failure`` decides its mode; the message is not read: the same text under
    different reasons gives different modes, and every reason has a mode; an unsupported run is
    not a failure mode at all."""
    def mode(reason, message="position projection did not converge: singular, flat, beyond 1e+08"):
        return engine_mode(failed("inhouse", "rk4", ["body"], reason, message))

    assert mode(Failure.SOLVER) == "solver failure"
    assert mode(Failure.SINGULAR) == "singular constraint"
    assert mode(Failure.PROJECTION) == "constraint drift"
    assert mode(Failure.NON_FINITE) == "nan"
    assert mode(Failure.SPEED) == "magnitude growth"
    assert mode(Failure.ENGINE_GUARD) == "badqacc"
    assert mode(Failure.UNSUPPORTED) == "unsupported"
    assert "unsupported" not in FAILURE_MODES
    assert {engine_mode(failed("e", "m", ["b"], r, "")) for r in Failure if r is not Failure.NONE} - {UNSUPPORTED} <= set(FAILURE_MODES)


def test_the_compiled_runs_fail_in_the_same_modes_as_the_per_state_ones():
    """The stress rows of rk4 and DOP853 run the compiled twins: their failures must land in the
    modes the per-state engine's do (a disk landing flat was a solver failure, not a singular
    constraint, before the compiled message was read)."""
    from harness.engines.inhouse.compiled import kernels
    from harness.engines.inhouse.compiled.solver import STATUS

    def mode(code):
        reason, message = STATUS[code]
        return engine_mode(failed("inhouse", "rk4_compiled", ["body"], reason, message + " (t = 0.1 s)"))

    assert mode(kernels.FLAT_DISK) == "singular constraint"
    assert mode(kernels.SINGULAR) == "singular constraint"
    assert mode(kernels.TOO_MANY_STEPS) == "solver failure"


def test_a_non_finite_compiled_error_estimate_is_a_blowup():
    from harness.engines.inhouse.compiled import kernels, solver

    assert solver.STATUS[kernels.BAD_ERROR][0].status == "blowup" and solver.STATUS[kernels.NONFINITE][0].status == "blowup"


def test_a_nominal_run_that_diverged_is_a_defect_in_the_judging_vocabulary():
    """``judging_class``: a nominal run that diverged (non-finite, MuJoCo's guards, energy or speed
    growth) is a ``defect`` as the error model calls a non-finite value at the scene's step; a
    stable run, a model failure (singular constraint) and a timeout keep the study's own terms;
    the variant table and the map's numbers say so."""
    from harness.studies.stress import report
    from harness.studies.stress.run import MapRow, judging_class

    spec = TrialSpec("v", "mujoco", "RK4", 1e-3, 1.0, 0.1, float("nan"), "nominal")
    assert judging_class(fake_result(spec, False, "nan")) == "defect (diverged: nan)"
    assert judging_class(fake_result(spec, False, "energy growth")) == "defect (diverged: energy growth)"
    assert judging_class(fake_result(spec, True)) == ""
    assert judging_class(fake_result(spec, False, "singular constraint")) == ""
    assert judging_class(fake_result(spec, False, "timeout")) == "" and judging_class(None) == ""
    blown = fake_result(spec, False, "badqacc", t_fail=0.5)
    row = report._section_row("mujoco/RK4", "< 1e-3", "—", "—", "—", blown, [], "", False)
    assert "(**defect (diverged: badqacc)**)" in row
    stiff = report._section_row("mujoco/RK4", "1e-3", "—", "—", "—", fake_result(spec, False, "constraint drift"), [],
                                "", False)
    assert "(constraint drift)" in stiff and "defect" not in stiff
    cell = MapRow("v", "mujoco", "RK4", 1.0, "fixed", None, False, 1e-3, "badqacc", float("nan"), "", False, blown,
                  float("nan"), [], {})
    fake = type("Run", (), {"rows": [cell], "rates": {}})()
    assert report.map_frame(fake)["nominal_class"].tolist() == ["defect (diverged: badqacc)"]
