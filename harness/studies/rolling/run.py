"""The rolling-disk study: the four cases on all engines, MuJoCo's contact settings, and the
stability threshold of straight rolling against the textbook's (``harness rolling-study``).

Everything here runs the scene ``rolling_disk`` through the engines' ordinary ``simulate``;
MuJoCo variants are the scene's MJCF with contact/solver options rewritten
(``mujoco_rolling.apply_options``) and written to a temporary file. Each run is judged by
``run_metrics``: energy drift (max |E - E0| over the energy scale), slip (max horizontal speed of
the material point at the contact, m/s), penetration (max depth of the contact point below the
floor, m), trajectory error against the in-house DOP853 reference (rtol = atol = 1e-12;
centre-of-mass position over the length scale, orientation in rad), the contact force against
the reference's (over the weight/peak force, t > 0) and the lean error (steady case: max
|theta - theta0|, rad).

Cases (``CASES``; straight rolling starts on one rim edge at the balance tilt theta* = atan(R/h)
plus an outward lean ``delta``, so that the contact never switches edges):

* ``steady_circle``: the scene's defaults, Ex. 4.7.2 (lean constant, centre on a circle);
* ``straight_fast``: straight rolling at 1.5 v_c (stable: the lean oscillates);
* ``straight_slow``: straight rolling at 0.8 v_c (unstable: the disk falls);
* ``transient``: released leaning 0.37 rad from upright and spinning, no heading rate: it
  rolls, turns and nutates.

The threshold sweep runs straight rolling at several speeds from delta = 1e-3 rad for 1 s and
records the largest lean deviation |theta - theta*|; a run "falls" when it exceeds 0.1 rad
(100 delta) or the run stops because the disk lies flat.
"""

from __future__ import annotations

import math
import tempfile
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from harness.judging import error_model
from harness.measure import compare
from harness.measure import contact_metrics
from harness.model import rotations
from harness.engines import IDEAL, REFERENCE_ENGINE, SOFT, check_scene, display, engine_module, get_engine, with_rolling
from harness.engines.base import RunSettings
from harness.studies.rolling import SETTINGS_ENGINE
from harness.model.scene import Scene, load_scene
from harness.measure.trajectory import Trajectory

REFERENCE = dict(integrator="DOP853", rtol=1e-12, atol=1e-12)
FALL_LEAN = 0.1  # rad: a straight-rolling run whose lean deviation exceeds this has fallen

BEST_LABEL = "RK4, solref 2 dt, solimp, elliptic, impratio 100"  # the settings the scene's MJCF holds

SETTINGS_NAME = display(SETTINGS_ENGINE)  # how the report writes the settings' engine
# MuJoCo's own defaults (what a user who writes a cylinder on a plane gets).
DEFAULTS = dict(integrator="Euler", timestep=0.002, cone="pyramidal", impratio=1.0, noslip_iterations=0,
                       condim=3, friction=(1.0, 0.005, 0.0001), solref=(0.02, 1.0), solimp=(0.9, 0.95, 0.001, 0.5, 2.0))


def disk_params(scene: Scene):
    from harness.references.rolling_disk import DiskParams

    p = scene.params
    return DiskParams(p["mass"], p["R"], p["h"], p["g"])


def straight_params(scene: Scene, speed: float, delta: float) -> dict[str, float]:
    """Overrides for straight rolling at ``speed`` (m/s) on the lower edge, leaning ``delta``
    (rad) beyond the balance tilt theta* = atan(R/h): theta0 = theta* - delta, no heading or tilt
    rate, spin w3 = -speed/R (the centre moves along +e_y')."""
    from harness.references.rolling_disk import balance_tilt

    p = scene.params
    return {"theta0": balance_tilt(p["R"], p["h"]) - delta, "dphi0": 0.0, "dtheta0": 0.0, "dpsi0": -speed / p["R"]}


@dataclass(frozen=True)
class Case:
    name: str
    doc: str
    params: dict
    t_end: float


def cases(scene: Scene, quick: bool = False) -> list[Case]:
    """The study's cases for ``scene`` (``quick``: shorter horizons)."""
    from harness.references.rolling_disk import critical_speed

    vc = critical_speed(disk_params(scene))
    T = 0.2 if quick else scene.t_end
    return [
        Case("steady_circle", "Ex. 4.7.2: steady circular motion, lean constant (scene defaults)", {}, T),
        Case("straight_fast", f"straight rolling at 1.5 v_c = {1.5 * vc:.3f} m/s, 0.01 rad beyond the balance tilt: stable",
             straight_params(scene, 1.5 * vc, 0.01), T),
        Case("straight_slow", f"straight rolling at 0.8 v_c = {0.8 * vc:.3f} m/s, 0.01 rad beyond the balance tilt: falls",
             straight_params(scene, 0.8 * vc, 0.01), 0.1 if quick else 0.3),
        Case("transient", "released leaning 0.37 rad, spinning at -35 rad/s, no heading rate: rolls, turns, nutates",
             {"theta0": 1.2, "dphi0": 0.0, "dtheta0": 0.0, "dpsi0": -35.0}, T),
    ]


def lean(traj: Trajectory) -> np.ndarray:
    """theta(t): angle of the symmetry axis from the vertical (rad)."""
    R = rotations.matrix(traj.quat_WB[:, 0])
    return np.arccos(np.clip(R[:, 2, 2], -1.0, 1.0))


#: Wall-clock budget of one run (s): each run is made in its own worker process
#: (``harness.validate.workers.run_cases``); one over it is recorded as "timeout" and the study goes on.
RUN_TIMEOUT = 300.0


def _simulate(engine: str, scene: Scene, settings: RunSettings) -> tuple[Trajectory, float]:
    """Worker body: one run and its wall time (s), measured around the run alone."""
    t0 = time.perf_counter()
    traj = get_engine(engine).simulate(scene, settings)
    return traj, time.perf_counter() - t0


def simulate_in_worker(engine: str, scene: Scene, settings: RunSettings,
                       timeout: float | None = None) -> tuple[Trajectory, float]:
    """One run in its own worker process under a wall-clock budget (``RUN_TIMEOUT`` s unless
    given): a crash, a hang or an error there is that run's failed trajectory, with its reason,
    and never takes the study down."""
    from harness.measure.trajectory import failed
    from harness.validate.workers import run_cases

    outcome = run_cases([("run", _simulate, (engine, scene, settings))], 1, timeout or RUN_TIMEOUT)["run"]
    if outcome.status == "ok":
        return outcome.value
    if outcome.status == "input_error":
        from harness.model.errors import InputError

        raise InputError(outcome.message)
    names = [b.name for b in scene.multibody().bodies]
    why = f"timed out after {timeout or RUN_TIMEOUT:g} s" if outcome.status == "timeout" else f"{outcome.status}: {outcome.message}"
    return failed(engine, settings.integrator, names, "failed", why), outcome.wall_s


def reference(scene: Scene, t_end: float, save: float) -> Trajectory:
    return simulate_in_worker(REFERENCE_ENGINE, scene, RunSettings(t_end, save, save, **REFERENCE))[0]


def run_metrics(scene: Scene, traj: Trajectory, ref: Trajectory | None, wall: float) -> dict:
    """The study's measures of one run (module docstring); NaN where not available."""
    model = scene.multibody()
    out = {"status": traj.status, "message": traj.message, "wall_s": wall, "samples": len(traj.t)}
    nan = float("nan")
    if len(traj.t) < 2:
        return out | {k: nan for k in ("energy", "slip", "penetration", "height", "position", "orientation", "force", "lean")}
    s = contact_metrics.summary(traj, model)
    out |= {"energy": compare.energy_drift(traj, model), "slip": s["slip_max"], "penetration": s["penetration_max"],
            "height": s["height_max"]}
    if ref is not None and ref.ok:
        err = compare.trajectory_error(traj, ref)
        scale = compare.motion_scales(ref, model)
        out |= {"position": err["position_max"] / scale["length"], "orientation": err["orientation_max"]}
        names = [c.name for c in model.contacts]
        if all(n in traj.reactions for n in names) and all(n in ref.reactions for n in names):
            own, other = contact_metrics._contacts_only(traj, names, True), contact_metrics._contacts_only(ref, names, True)
            out["force"] = compare.reaction_error(own, other)["force_max"] / compare.reaction_scales(other, model)[0]
        else:
            out["force"] = nan
    else:
        out |= {"position": nan, "orientation": nan, "force": nan}
    out["lean"] = float(np.max(np.abs(lean(traj) - scene.params["theta0"])))
    return out


def settings_variant(scene: Scene, options: dict | None, folder: Path, label: str) -> tuple[Scene, RunSettings | None]:
    """The scene with its MJCF rewritten by ``options`` (None: the MJCF as written), and the
    integrator/step the options ask for (None: the scene's)."""
    if options is None:
        return scene, None
    read_spec = engine_module(SETTINGS_ENGINE, "model").read_spec
    apply_options = engine_module(SETTINGS_ENGINE, "rolling").apply_options

    spec = read_spec(scene.mjcf)
    apply_options(spec, {k: v for k, v in options.items() if k not in ("integrator", "timestep")})
    path = folder / f"{scene.name}_{abs(hash(label)) % 10**8}.xml"
    path.write_text(spec.to_xml())
    return replace(scene, mjcf=path), RunSettings(1.0, options["timestep"], 1.0, options["integrator"])


def run(scene: Scene, engine: str, t_end: float, *, dt: float | None = None, integrator: str | None = None,
        save: float | None = None) -> tuple[Trajectory, float]:
    save = save or scene.save_every
    dt = dt or scene.dt
    settings = RunSettings(t_end, dt, save, integrator or scene.integrators[engine])
    return simulate_in_worker(engine, scene, settings)


def settings_rows(dt: float) -> list[tuple[str, dict | None]]:
    """The settings study: (label, options) from MuJoCo's defaults; None = the scene's MJCF."""
    d = DEFAULTS
    stiff = (2.0 * dt, 1.0)
    hard = (0.99, 0.999, 0.001, 0.5, 2.0)

    def v(**kw):
        return {**d, "timestep": dt, **kw}

    return [
        (f"{SETTINGS_NAME} defaults (Euler, 2 ms, pyramidal, solref 0.02 1)", dict(d)),
        ("defaults at the scene step", v()),
        ("RK4", v(integrator="RK4")),
        ("implicitfast", v(integrator="implicitfast")),
        ("RK4, elliptic cone", v(integrator="RK4", cone="elliptic")),
        ("RK4, elliptic, impratio 100", v(integrator="RK4", cone="elliptic", impratio=100.0)),
        ("RK4, noslip_iterations 20", v(integrator="RK4", noslip_iterations=20)),
        ("RK4, condim 4 (torsional friction)", v(integrator="RK4", condim=4)),
        ("RK4, condim 6 (torsional + rolling friction)", v(integrator="RK4", condim=6)),
        ("RK4, friction 10 (pyramidal)", v(integrator="RK4", friction=(10.0, 0.005, 0.0001))),
        ("RK4, solimp 0.99 0.999", v(integrator="RK4", solimp=hard)),
        (f"RK4, solref {stiff[0]:g} 1 (2 dt)", v(integrator="RK4", solref=stiff)),
        ("implicitfast, solref 2 dt", v(integrator="implicitfast", solref=stiff)),
        ("RK4, solref 2 dt, solimp 0.99 0.999", v(integrator="RK4", solref=stiff, solimp=hard)),
        (BEST_LABEL, v(integrator="RK4", solref=stiff, solimp=hard, cone="elliptic", impratio=100.0)),
        ("RK4, solref 2 dt, solimp, elliptic, impratio 100, noslip 20",
         v(integrator="RK4", solref=stiff, solimp=hard, cone="elliptic", impratio=100.0, noslip_iterations=20)),
        ("RK4, solref 2 dt, solimp, condim 4", v(integrator="RK4", solref=stiff, solimp=hard, condim=4)),
        ("RK4, solref -1e6 -2000 (direct stiffness, damping)", v(integrator="RK4", solref=(-1e6, -2000.0), solimp=hard)),
        ("scene MJCF as written", None),
        ("as written, step dt/2.5 = 0.1 ms, solref 2 dt", {**v(integrator="RK4", solref=(0.0002, 1.0), solimp=hard,
                                                             cone="elliptic", impratio=100.0), "timestep": 1e-4}),
        ("as written, step 0.05 ms, solref 2 dt", {**v(integrator="RK4", solref=(0.0001, 1.0), solimp=hard,
                                                     cone="elliptic", impratio=100.0), "timestep": 5e-5}),
    ]


@dataclass
class StudyResult:
    """Everything ``rolling_study`` produces (rows are dicts of ``run_metrics`` plus labels)."""

    scene: Scene
    engines: list[dict] = field(default_factory=list)
    settings: list[dict] = field(default_factory=list)
    threshold: list[dict] = field(default_factory=list)
    series: dict = field(default_factory=dict)
    thresholds: dict = field(default_factory=dict)


def _tick(progress, label: str, wall: float) -> None:
    """One finished run on the bar (``harness.io.progress.make_bar``), named, or nothing."""
    if progress is not None:
        progress.done(f"{label} {wall:.1f} s")


def engine_study(scene: Scene, case_list: list[Case], result: StudyResult, defaults_options: dict,
                 progress=None) -> None:
    """Every case on every engine (MuJoCo as written and at MuJoCo's defaults); ``progress``: a
    bar ticked once per finished run (``harness.io.progress.make_bar``), or None."""
    with tempfile.TemporaryDirectory() as tmp:
        for case in case_list:
            sc = scene.with_params(**case.params)
            ref = reference(sc, case.t_end, sc.save_every)
            result.engines.append({"case": case.name, "engine": "reference (DOP853 1e-12)",
                                   **run_metrics(sc, ref, ref, float(ref.stats.get("wall_s", math.nan)))})
            _tick(progress, f"{case.name} reference {ref.status}", float(ref.stats.get("wall_s", math.nan)))
            runs = [(e, sc, {}) for e in STUDY_ENGINES]
            dsc, dset = settings_variant(sc, defaults_options, Path(tmp), "defaults")
            runs.append((f"{SETTINGS_ENGINE} ({SETTINGS_NAME} defaults)", dsc, {"dt": dset.dt, "integrator": dset.integrator}))
            for label, s, kw in runs:
                traj, wall = run(s, label.split()[0], case.t_end, **kw)
                result.engines.append({"case": case.name, "engine": label, **run_metrics(sc, traj, ref, wall)})
                _tick(progress, f"{case.name} {label} {traj.status}", wall)
                if case.name in ("steady_circle", "transient"):
                    result.series[(case.name, label)] = (traj.t, lean(traj))
            result.series[(case.name, "reference")] = (ref.t, lean(ref))


def settings_study(scene: Scene, case_list: list[Case], result: StudyResult, rows: list[tuple[str, dict | None]],
                   progress=None) -> None:
    """MuJoCo's settings ``rows`` (``settings_rows``) on the steady and transient cases."""
    picked = [c for c in case_list if c.name in ("steady_circle", "transient")]
    refs = {}
    for c in picked:
        refs[c.name] = reference(scene.with_params(**c.params), c.t_end, scene.save_every)
        _tick(progress, f"{c.name} reference {refs[c.name].status}", float(refs[c.name].stats.get("wall_s", math.nan)))
    with tempfile.TemporaryDirectory() as tmp:
        for label, options in rows:
            row = {"setting": label, "options": options}
            for c in picked:
                sc = scene.with_params(**c.params)
                vs, vset = settings_variant(sc, options, Path(tmp), label)
                kw = {} if vset is None else {"dt": vset.dt, "integrator": vset.integrator}
                traj, wall = run(vs, SETTINGS_ENGINE, c.t_end, **kw)
                row[c.name] = run_metrics(sc, traj, refs[c.name], wall)
                _tick(progress, f"{c.name} {SETTINGS_ENGINE} {label} {traj.status}", wall)
            result.settings.append(row)


def threshold_study(scene: Scene, result: StudyResult, speeds: list[float], engines: list[str], t_end: float,
                    delta: float = 1e-3, progress=None) -> None:
    """Straight rolling at each speed on each engine (module docstring)."""
    from harness.references.rolling_disk import (
        DiskParams,
        balance_tilt,
        critical_speed,
        printed_critical_speed,
        straight_rolling_rate,
    )

    p = scene.params
    disk = disk_params(scene)
    thin = DiskParams(p["mass"], p["R"], 0.0, p["g"])
    result.thresholds = {"correct": critical_speed(disk), "thin": critical_speed(thin),
                         "printed": printed_critical_speed(p["g"], p["R"]), "balance_tilt": balance_tilt(p["R"], p["h"]),
                         "delta": delta, "t_end": t_end}
    theta_star = result.thresholds["balance_tilt"]
    for v in speeds:
        sc = scene.with_params(**straight_params(scene, v, delta))
        w2 = straight_rolling_rate(disk, v)
        for engine in engines:
            traj, wall = run(sc, engine, t_end, save=0.005)
            dev = np.abs(lean(traj) - theta_star) if len(traj.t) else np.array([np.nan])
            # an engine that does not model the scene ("unsupported") neither falls nor rolls: not run
            fell = None if traj.unsupported else (not traj.ok) or float(np.max(dev)) > FALL_LEAN
            result.threshold.append({"speed": v, "engine": engine, "max_lean": float(np.nanmax(dev)) if np.any(np.isfinite(dev)) else math.nan,
                                     "fell": None if fell is None else bool(fell),
                                     "status": traj.status, "message": traj.message, "w2": w2, "wall_s": wall,
                                     "predicted_stable": w2 > 0, "printed_stable": v > result.thresholds["printed"]})
            result.series[("threshold", engine, v)] = (traj.t, dev)
            _tick(progress, f"threshold {v:g} m/s {engine} {traj.status}", wall)


def threshold_agrees(threshold: list[dict]) -> bool:
    """Whether every threshold run that was made (``fell`` not None: an "unsupported" run is not
    run) falls exactly when the correct linearisation predicts instability."""
    return all(r["fell"] != r["predicted_stable"] for r in threshold if r["fell"] is not None)


def rolling_study(*, quick: bool = False, engines: list[str] | None = None, models_dir: Path | None = None,
                  progress=None) -> StudyResult:
    """Run the whole study (``quick``: short horizons, few settings and speeds, for tests).
    ``progress``: a bar (``harness.io.progress.make_bar``): its total is set to the runs, and it
    is ticked once per finished run; or None."""
    scene = check_scene(load_scene("rolling_disk", models_dir=models_dir))
    engines = engines or list(STUDY_ENGINES)
    result = StudyResult(scene=scene)
    case_list = cases(scene, quick)
    if quick:
        case_list = case_list[:1]
    rows = settings_rows(scene.dt)
    if quick:  # MuJoCo's defaults, the best settings (with its finer steps: its error model), the MJCF as written
        rows = [r for r in rows if r[0].startswith((f"{SETTINGS_NAME} defaults", "as written, step")) or r[0] == BEST_LABEL
                or r[1] is None]
    speeds = [0.15, 0.26] if quick else [0.10, 0.15, 0.18, 0.20, 0.21, 0.22, 0.23, 0.26, 0.32]
    if progress is not None:  # the reference and a run per engine (and the defaults') per case, the settings rows, the threshold runs
        picked = sum(c.name in ("steady_circle", "transient") for c in case_list)
        progress.total = (2 + len(STUDY_ENGINES)) * len(case_list) + picked * (1 + len(rows)) + len(speeds) * len(engines)
        progress.refresh()
    engine_study(scene, case_list, result, {**DEFAULTS}, progress)
    settings_study(scene, case_list, result, rows, progress)
    threshold_study(scene, result, speeds, engines, 0.3 if quick else 1.0, progress=progress)
    return result


#: The engines whose contact is the ideal rolling constraint (the study's comparison for MuJoCo).
IDEAL_ENGINES = with_rolling(IDEAL)
#: The engines of the case and threshold runs: the ideal ones, then those with a soft rolling
#: contact (the settings' engine among them), in registry order.
STUDY_ENGINES = IDEAL_ENGINES + with_rolling(SOFT)
FIRST_ORDER = ("Euler", "implicit", "implicitfast")  # MuJoCo's first-order integrators


def _ladder_key(options: dict) -> tuple:
    """What a settings row holds besides its step and its contact time constant: rows equal in it
    whose ``solref`` is 2 steps form one step ladder (the best settings at finer steps)."""
    return tuple(sorted((k, str(v)) for k, v in options.items() if k not in ("timestep", "solref")))


def setting_models(result: StudyResult, case: str = "steady_circle", measure: str = "position") -> dict[str, dict]:
    """Each MuJoCo settings row's error (``measure`` of ``case``, relative) classified in the
    judging vocabulary (``harness.judging.error_model``), ``{setting: {"class", "order", "floor",
    "reason", "ideal"}}`` (``ideal``: the ideal engines' largest error at the scene's step):

    * rows that form a step ladder (the best settings at the scene's step and at finer steps,
      ``solref`` 2 steps each: ``_ladder_key``) get the error model of their levels, the scene's
      step first (RK4's order 4; the contact's time constant follows the step, so its order is the
      soft contact's, not the integrator's), and the verdict ``harness validate`` gives it
      (``harness.judging.verdict.judge``) with the soft contact the scene declares;
    * every other RK4 row at the scene's step has one level only: no order; its error is set
      against the ideal engines' at the same step (``IDEAL_ENGINES``, which converge at their
      order: their error is the step's share): more than ``NOISE`` times it, the excess is the
      soft contact's, a ``model difference``; within it, ``not judged``;
    * first-order rows and rows at another step are ``not judged`` (their step error is not the
      ideal engines')."""
    dt = result.scene.dt
    ideal = [float(r.get(measure, math.nan)) for r in result.engines
             if r["case"] == case and r["engine"] in IDEAL_ENGINES and r["status"] == "ok"]
    ideal_err = max((e for e in ideal if math.isfinite(e)), default=math.nan)
    rows = [r for r in result.settings if case in r]
    out: dict[str, dict] = {}

    def put(label, cls, reason, order=math.nan, floor=math.nan):
        out[label] = {"class": cls, "order": order, "floor": floor, "reason": reason, "ideal": ideal_err}

    ladders: dict[tuple, list[dict]] = {}
    for r in rows:
        o = r["options"]
        if o is not None and o.get("integrator") == "RK4" and math.isclose(tuple(o.get("solref", (0.0,)))[0], 2.0 * o["timestep"]):
            ladders.setdefault(_ladder_key(o), []).append(r)
    for group in ladders.values():
        base = [r for r in group if r["options"]["timestep"] == dt]
        if len(group) < 2 or not base:
            continue
        group = base[:1] + sorted((r for r in group if r is not base[0]), key=lambda r: -r["options"]["timestep"])
        levels = [error_model.Level(r["options"]["timestep"], float(r[case].get(measure, math.nan))
                                    if r[case].get("status") == "ok" else math.nan) for r in group]
        t_end = max(float(r[case].get("samples", 2)) - 1.0 for r in group) * result.scene.save_every
        res = max(error_model.JUDGING_RESOLUTION, error_model.roundoff(t_end / min(lv.step for lv in levels)))
        m = error_model.fit(measure, "rel", 1.0, "fixed", 4.0, levels, res)
        reason = f"step ladder {', '.join(f'{lv.step * 1e3:g}' for lv in levels)} ms: {m.reason}"
        declared = result.scene.model_differences.get(SETTINGS_ENGINE)
        if declared:  # the scene's declared soft contact: the verdict validate gives (harness.judging.verdict)
            from harness.judging.verdict import ModelDifference, judge

            v = judge(m, ModelDifference(declared["model"], declared["bound"]))
            reason += f"; verdict: {v.label}, {'passes' if v.passed else 'fails'} ({v.detail.split(';')[0]})"
        for r in group:
            put(r["setting"], m.classification, reason, m.observed_order, m.floor)
    for r in rows:
        if r["setting"] in out:
            continue
        o = r["options"] or {"integrator": result.scene.integrators.get(SETTINGS_ENGINE, "RK4"), "timestep": dt}
        e = float(r[case].get(measure, math.nan)) if r[case].get("status") == "ok" else math.nan
        if o.get("timestep") != dt or o.get("integrator") in FIRST_ORDER:
            put(r["setting"], error_model.NOT_JUDGED, "one step only, a first-order integrator or another step: "
                "its step error is not the ideal engines'")
        elif not math.isfinite(e):
            put(r["setting"], error_model.DEFECT if r[case].get("status") == "blowup" else error_model.NOT_JUDGED,
                f"the run: {r[case].get('status')}")
        elif math.isfinite(ideal_err) and e > error_model.NOISE * ideal_err:
            put(r["setting"], error_model.MODEL_DIFFERENCE, f"soft contact: {e / ideal_err:.3g}x the ideal engines' "
                f"error at the same step ({ideal_err:.1e}; one step only: no order)")
        else:
            put(r["setting"], error_model.NOT_JUDGED, f"within {error_model.NOISE:g}x the ideal engines' error at the "
                "same step (one step only: no order)")
    return out
