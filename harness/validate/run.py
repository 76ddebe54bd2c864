"""Validation of scenes: run every engine, compare, check each quantity against its tolerance.

First, for each scene, the model files are judged AS WRITTEN (``model_checks``): each engine that
reads one (MuJoCo the MJCF, Pinocchio the URDF) loads it without the scene's parameters applied
(``harness.tools.inspection.as_written``), and every body's mass, centre of mass, inertia, joint
position, joint type and axis (and the MJCF's gravity) is checked against the scene at its
``scene.toml`` defaults, which the files must hold: checks ``model.<body>.<quantity>`` of that
engine (relative, 1e-6, the files' rounded decimals; axes 1e-9 rad). The runs themselves load the
files with the scene's parameters written over them (``load_mjcf``, ``load_urdf``), which is how
``--set`` overrides reach every engine, and why a wrong number in a file shows only here.

Then, for each scene: an in-house reference run (DOP853, rtol = atol = 1e-12) is made first; then
each engine runs at the scene's default integrator and step (an error-controlled default, Drake's
RK5, at the target accuracy ``ERROR_CONTROL_TOL``). The in-house runs (the reference
included) use the compiled twin of their method (``harness.engines.inhouse.run_method``:
``rk4_compiled`` for ``rk4``, ``dop853_compiled`` for ``DOP853``) wherever the compiled form models
the scene, unless ``fast=False`` (``harness validate --per-state``: the readable per-state oracle
everywhere); each run's record names the method that ran. Checks (those the scene declares
in ``[checks.*]`` of its ``scene.toml``):

* ``energy_drift`` (unforced; over the reference run's energy scale) or ``energy_balance``
  (forced: E - E0 - work of the forces);
* ``momentum_drift.<c>`` for each conserved component the scene lists;
* ``trajectory.position/orientation/velocity/angular_velocity`` against the reference (each
  quantity, its scale and its tolerance defined once in ``harness.validate.quantities``, which
  ``harness debug`` judges by too);
* ``constraint.position/axis``, joint violations from maximal coordinates;
* ``exact``: against the scene's closed-form solution (``harness.measure.exact``);
* ``reaction.force/moment`` (scenes with ``[checks.reaction]``): joint reactions against the
  reference run's, and ``reaction.exact`` against the exact support force where one exists;
* ``slip``, ``contact_height``, ``contact_force`` (scenes with rolling contacts,
  ``harness.measure.contact_metrics``): slip speed at the contact point, its height (penetration), and
  the contact force against the reference's;
* ``engine_energy``: the engine's own energy against the harness's recomputation.

A ``[checks.trajectory]`` tolerance is a number for every engine or a table per engine (rolling_disk:
MuJoCo's soft contact is held to what it can reach, the ideal-constraint engines to 1e-9). A check
whose tolerance is such a regression bound (what the engine reaches, with a margin) is marked
``regression_only`` (``harness.validate.quantities.regression_only``).

The reference run is itself checked (engine ``reference``) for conservation and against the
exact solution before it judges anything. Every run (reference, and each scene x engine) is
made in its own worker process (``harness.validate.workers``): cases run in parallel, and a crash, hang
or blow-up is recorded as that case's failed ``run`` check while every other result is kept.
Where the exact solution is itself integrated (the loop scenes' reference DAEs), the reference
run's worker, which judges its own run with it at the times every run is saved at, returns it
and the engine runs' workers adopt it (``harness.measure.solution_cache``): each scene's exact
solution is computed once, in parallel with the other scenes' reference runs.
"""

from __future__ import annotations

import os
import time
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np

from harness.engines import get_engine, integrator
from harness.engines.base import RunSettings
from harness.engines.inhouse import run_method
from harness.measure import compare, contact_metrics, exact, solution_cache
from harness.measure.invariants import mark_non_finite
from harness.measure.trajectory import Trajectory
from harness.model import forces
from harness.model.errors import InputError
from harness.model.scene import MODELS_DIR, Scene
from harness.validate import quantities
from harness.validate.quantities import REFERENCE_ENGINE  # the engine of the reference run (``reference_case``)
from harness.validate.workers import Outcome, run_cases

REFERENCE_METHOD = "DOP853"
REFERENCE_TOL = 1e-12
#: Target accuracy (``RunSettings.rtol``) of an engine's default method where it is error-controlled
#: (Drake's RK5; the other defaults are fixed-step and ignore it). Drake's error control does not
#: bound the global error by it: at 1e-10 its RK5 held every scene's tolerances at the defaults
#: (worst margin 0.25) but left them up to 300x at other initial states (plate_pendulum at theta0 =
#: 2.5 rad: 6.1e-7 rad of orientation against 2e-9); at 1e-13 its worst margin at the defaults is
#: 0.11, those states pass, and its runs take 8.3 s in all instead of 4.7 s (validate --engines drake).
ERROR_CONTROL_TOL = 1e-13
ENGINE_ENERGY_TOL = 1e-9  # relative; a larger mismatch means the engine's mass model differs
DEFAULT_TIMEOUT = 300.0   # s per case


@dataclass(frozen=True)
class CheckResult:
    """One checked quantity of one scene on one engine."""

    scene: str
    engine: str
    check: str
    value: float
    tolerance: float
    unit: str
    passed: bool
    detail: str = ""
    regression_only: bool = False  # the tolerance is a regression bound (quantities.regression_only)

    @property
    def margin(self) -> float:
        """value / tolerance (1 = at the tolerance); 0 for a zero value, inf for a nonzero value
        against a zero tolerance, NaN for a missing value."""
        if not np.isfinite(self.value):
            return float("nan")
        if self.value == 0.0:
            return 0.0
        return self.value / self.tolerance if self.tolerance > 0 else float("inf")


@dataclass(frozen=True)
class RunRecord:
    """How one run was made and how it ended (``settings``: the engine's own description of
    its integrator and solver settings)."""

    scene: str
    engine: str
    integrator: str
    dt: float
    rtol: float | None
    t_end: float
    status: str
    message: str
    wall_s: float
    steps: float
    settings: str = ""
    warnings: dict = field(default_factory=dict)  # the engine's own warnings (stats["warnings"]: count, first)


@dataclass
class SceneValidation:
    """Everything validation produced for one scene."""

    scene: str
    parameters: dict
    checks: list[CheckResult] = field(default_factory=list)
    runs: list[RunRecord] = field(default_factory=list)
    cross: dict[str, dict[str, float]] = field(default_factory=dict)
    tolerance_changes: list[str] = field(default_factory=list)
    overrides: dict[str, dict] = field(default_factory=dict)  # parameter -> {"value", "default"}: set away from scene.toml
    not_run: dict[str, str] = field(default_factory=dict)  # engine -> why it does not run this scene ([not_run])

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)


def save_interval(scene: Scene) -> float:
    """The scene's save interval, or its step when a force acts: the energy balance integrates
    the force's power over the saved samples (Simpson, error ~ interval^4), so a forced run is
    saved at every step."""
    return scene.dt if forces.does_work(scene.multibody()) else scene.save_every


def reference_settings(scene: Scene, fast: bool = True) -> RunSettings:
    """The in-house high-accuracy run that judges the engines' trajectories (with ``fast``, the
    compiled DOP853 where the compiled form models the scene)."""
    save = save_interval(scene)
    method = run_method(REFERENCE_ENGINE, REFERENCE_METHOD, scene, fast)
    return RunSettings(scene.t_end, save, save, method, rtol=REFERENCE_TOL, atol=REFERENCE_TOL)


def default_settings(scene: Scene, engine: str, fast: bool = True) -> RunSettings:
    """The engine's default integrator (for the in-house engine with ``fast``, its compiled twin
    where the compiled form models the scene) and the scene's step, horizon and save interval; an
    error-controlled method at the target accuracy ``ERROR_CONTROL_TOL``."""
    method = run_method(engine, scene.integrators[engine], scene, fast)
    return RunSettings(scene.t_end, scene.dt, save_interval(scene), method, rtol=ERROR_CONTROL_TOL)


def reference_case(scene: Scene, fast: bool = True) -> tuple[Trajectory, RunRecord, list[CheckResult], dict]:
    """Worker body: the reference run and its own checks, and the exact solutions computed to
    judge it at its saved times (``solution_cache.recording``: for ``engine_case``'s
    ``solutions``; a scene whose closed form is not integrated has none)."""
    settings = reference_settings(scene, fast)
    t0 = time.perf_counter()
    traj = mark_non_finite(get_engine(REFERENCE_ENGINE).simulate(scene, settings), scene.multibody())
    record = _record(scene, "reference", settings, traj, time.perf_counter() - t0)
    with solution_cache.recording() as solutions:
        checks = check_run(scene, "reference", REFERENCE_ENGINE, traj, None, settings)
        if traj.ok and "exact" in scene.checks:
            exact.prepare(scene, traj)  # what the engines' exact checks need, if the reference's did not compute it
    return traj, record, checks, solutions


def engine_case(scene: Scene, engine: str, ref: Trajectory | None, fast: bool = True,
                solutions: dict | None = None) -> tuple[Trajectory, RunRecord, list[CheckResult]]:
    """Worker body: one engine's run at the scene's defaults and its checks. ``solutions``:
    the reference case's exact solutions, adopted before the checks (None: the checks compute
    what they need)."""
    solution_cache.adopt(solutions)
    settings = default_settings(scene, engine, fast)
    t0 = time.perf_counter()
    traj = mark_non_finite(get_engine(engine).simulate(scene, settings), scene.multibody())  # NaN "ok" -> blowup
    record = _record(scene, engine, settings, traj, time.perf_counter() - t0)
    checks = check_run(scene, engine, engine, traj, ref, settings)
    return traj, record, checks


def validate(scenes: list[Scene], engines: list[str], *, jobs: int | None = None,
             timeout: float = DEFAULT_TIMEOUT, tolerance_changes: dict[str, list[str]] | None = None,
             progress=None, dask: str | None = None, fast: bool = True) -> list[SceneValidation]:
    """Validate ``scenes`` on ``engines``, each run isolated in a worker process.
    ``progress``: a bar (``harness.io.progress.make_bar``) ticked once per finished case (each
    scene's reference run, then each scene x engine run), or None. ``dask``: the address of a
    ``dask.distributed`` scheduler whose workers run the cases (same results), else the local pool.
    ``fast``: the in-house runs use their methods' compiled twins where they apply (module docstring).

    Raises InputError if any case reports bad input (e.g. a model that does not load).
    """
    jobs = jobs or os.cpu_count() or 1
    defaults = {s.name: _defaults(s) for s in scenes}
    models = {s.name: model_checks(s, engines, defaults[s.name]) for s in scenes}
    tick = None if progress is None else (lambda key, outcome: progress.update(1))
    refs = run_cases([(s.name, reference_case, (s, fast)) for s in scenes], jobs, timeout, on_done=tick, dask=dask)
    _raise_input_errors(refs)
    cases = []
    for s in scenes:
        ref_outcome = refs[s.name]
        ref, solutions = (ref_outcome.value[0], ref_outcome.value[3]) if ref_outcome.status == "ok" else (None, None)
        cases += [((s.name, e), engine_case, (s, e, ref, fast, solutions)) for e in engines if e not in s.not_run]
    outcomes = run_cases(cases, jobs, timeout, on_done=tick, dask=dask)
    _raise_input_errors(outcomes)

    results = []
    for s in scenes:
        v = SceneValidation(scene=s.name, parameters={k: _jsonable(x) for k, x in s.params.items()},
                            tolerance_changes=list((tolerance_changes or {}).get(s.name, [])),
                            overrides=parameter_overrides(s, defaults[s.name]))
        v.checks.extend(models[s.name])
        _collect(v, s, "reference", refs[s.name], reference_settings(s, fast))
        trajectories = {}
        v.not_run = {e: s.not_run[e] for e in engines if e in s.not_run}
        for e in engines:
            if e in v.not_run:
                continue
            outcome = outcomes[(s.name, e)]
            _collect(v, s, e, outcome, default_settings(s, e, fast))
            if outcome.status == "ok" and outcome.value[0].ok:
                trajectories[e] = outcome.value[0]
            if refs[s.name].status != "ok" and "trajectory" in s.checks:
                v.checks.append(CheckResult(s.name, e, "trajectory", float("nan"), 0.0, "", False,
                                            f"no reference: reference run {refs[s.name].status}: {refs[s.name].message}"))
        names = list(trajectories)
        for i, a in enumerate(names):
            for b in names[i + 1:]:
                v.cross[f"{a} vs {b}"] = compare.trajectory_error(trajectories[a], trajectories[b])
        results.append(v)
    return results


def validate_scene(scene: Scene, engines: list[str], **kwargs) -> SceneValidation:
    """Validate one scene (see ``validate``)."""
    return validate([scene], engines, **kwargs)[0]


def _defaults(scene: Scene) -> Scene:
    from harness.tools.inspection import scene_defaults

    return scene_defaults(scene)


def parameter_overrides(scene: Scene, defaults: Scene) -> dict[str, dict]:
    """The parameters whose value differs from the ``scene.toml`` default (set by ``--set``, or
    following a set one: the builder's ``FOLLOWS``, ``harness.model.scene``):
    name -> ``{"value": ..., "default": ...}`` (units of the parameter)."""
    base = defaults.params
    return {k: {"value": _jsonable(x), "default": _jsonable(base.get(k))}
            for k, x in scene.params.items() if base.get(k) != x}


def model_checks(scene: Scene, engines: list[str], defaults: Scene | None = None) -> list[CheckResult]:
    """The model files of ``scene`` as written, against the scene at its ``scene.toml`` defaults
    (``defaults``; re-read when not given), for each of ``engines`` that reads one: a check
    ``model.<body>.<quantity>`` (``model.gravity`` for the MJCF's gravity) per quantity of
    ``harness.tools.loaded_models.body_discrepancies``, engine = the loader. A file that does not
    load or holds a non-physical body raises InputError; any other failure to read it back is
    a failed ``model.load`` check. A scene that names one model file only is checked as each
    engine reads that file: Pinocchio and Drake the MJCF (``as_written`` through their MJCF
    parsers), MuJoCo the URDF with the scene's root joint added (a URDF cannot state gravity,
    which is not checked there, as for Pinocchio and Drake)."""
    from harness.engines.mujoco.model import read_spec
    from harness.tools.inspection import AS_WRITTEN_RTOL, MODEL_ENGINES, AsWritten, as_written
    from harness.tools.loaded_models import body_discrepancies, mujoco_bodies

    def load(engine):
        if engine == "mujoco" and scene.reads_other_format(engine):  # the URDF into MuJoCo, as written
            m = read_spec(scene.mjcf, root_joint=scene.urdf_root_joint).compile()
            return AsWritten(engine, scene.mjcf, m, body_discrepancies(mujoco_bodies(m, model0), model0,
                                                                       rtol=AS_WRITTEN_RTOL))
        return as_written(scene, engine, model0)

    model0 = (defaults if defaults is not None else _defaults(scene)).multibody()
    hint = f"harness inspect {scene.name}"
    if scene.directory.parent.resolve() != MODELS_DIR.resolve():
        hint += f" --models-dir {scene.directory.parent}"
    out: list[CheckResult] = []
    for engine in engines:
        if engine in scene.not_run:
            continue
        if engine not in MODEL_ENGINES:
            continue
        try:
            loaded = load(engine)
        except InputError:
            raise
        except Exception as err:  # noqa: BLE001 - a model that cannot be read back is a failed check
            path = {"mujoco": scene.mjcf, "pinocchio": scene.urdf, "drake": scene.urdf}.get(engine, scene.directory / "scene.toml")
            out.append(CheckResult(scene.name, engine, "model.load", float("nan"), 0.0, "", False,
                                   f"{path.name} as written: {type(err).__name__}: {' '.join(str(err).split())}; {hint} shows more"))
            continue
        for d in loaded.discrepancies:
            name = f"model.{d.body}.{d.quantity}" if d.body else f"model.{d.quantity}"
            source = "Exudyn's system as built from scene.toml" if engine == "exudyn" else f"{loaded.path.name} as written"
            detail = f"{source} vs scene.toml defaults: {d.message}"
            if not d.passed:
                detail += f"; {hint} shows more"
            out.append(CheckResult(scene.name, engine, name, float(d.value), float(d.tolerance), d.unit, d.passed, detail))
    return out


def _raise_input_errors(outcomes: dict[Any, Outcome]) -> None:
    for outcome in outcomes.values():
        if outcome.status == "input_error":
            raise InputError(outcome.message)


def _collect(v: SceneValidation, scene: Scene, label: str, outcome: Outcome, settings: RunSettings) -> None:
    """Add one case's run record and checks; a case that died becomes a failed ``run`` check."""
    if outcome.status == "ok":
        record, checks = outcome.value[1], outcome.value[2]
        v.runs.append(record)
        v.checks.extend(checks)
        return
    v.runs.append(RunRecord(scene.name, label, settings.integrator, settings.dt, None, settings.t_end,
                            outcome.status, outcome.message, outcome.wall_s, float("nan")))
    v.checks.append(CheckResult(scene.name, label, "run", float("nan"), 0.0, "", False, f"{outcome.status}: {outcome.message}"))


def check_run(scene: Scene, label: str, engine: str, traj: Trajectory, ref: Trajectory | None,
              settings: RunSettings) -> list[CheckResult]:
    """The checks of one run; ``label`` names it in the report, ``engine`` picks tolerances."""
    model = scene.multibody()
    checks = scene.checks
    out: list[CheckResult] = []

    def add(check, value, tol, unit, detail=""):
        ok = bool(np.isfinite(value) and value <= tol)
        out.append(CheckResult(scene.name, label, check, float(value), float(tol), unit, ok, detail,
                               quantities.regression_only(scene.name, checks, check, engine)))

    traj = mark_non_finite(traj, model)  # any engine: a state or invariant that overflowed is never "ok"
    if not traj.ok:  # "unsupported": the scene's own integrator for this engine cannot run it, a configuration error
        why = " (bad configuration: see [integrators] in scene.toml)" if traj.unsupported else ""
        out.append(CheckResult(scene.name, label, "run", float("nan"), 0.0, "", False, f"{traj.status}: {traj.message}{why}"))
        return out
    if "energy_drift" in checks:
        tol = checks["energy_drift"][engine]
        if forces.does_work(model):
            balance, quad = compare.energy_balance(traj, model)
            add("energy_balance", balance, tol, "rel", f"E - E0 - W(t) over the energy scale; quadrature error of W ~{quad:.1e}")
        else:
            add("energy_drift", compare.energy_drift(traj, model, ref if ref is not None and ref.ok else None), tol, "rel",
                "max |E - E0| / energy scale (of the reference run)")
    if "momentum_drift" in checks:
        spec = checks["momentum_drift"]
        for comp, value in compare.momentum_drift(traj, model, spec["components"]).items():
            add(f"momentum_drift.{comp}", value, spec[engine], "rel", "max |c - c0| / momentum scale")
    if "trajectory" in checks and ref is not None:
        if not ref.ok:
            out.append(CheckResult(scene.name, label, "trajectory", float("nan"), 0.0, "", False,
                                   f"reference run {ref.status}: {ref.message}"))
        else:
            err = compare.trajectory_error(traj, ref)
            scales = compare.motion_scales(ref, model)
            for q in quantities.TRAJECTORY:
                raw = err[f"{q.name}_max"]
                add(q.check, q.judged(raw, scales), quantities.tolerance(checks, q, engine), q.judged_unit,
                    q.detail(raw, scales))
    if "constraint" in checks:
        viol = compare.constraint_violation(traj, model)
        tol = checks["constraint"][engine]
        add("constraint.position", viol["position"], tol, "m", "joint points coincide")
        what = compare.angular_conditions(model)  # e.g. "hinge axes stay aligned" (joint table)
        if what:
            add("constraint.axis", viol["axis"], tol, "rad", ", ".join(what))
    if "closure" in checks:
        _check_closure(checks["closure"], engine, traj, model, add)
    if "exact" in checks:
        tol = checks["exact"][engine]
        try:
            value, unit, detail = exact.exact_error(scene, traj, settings, run=get_engine(engine).simulate)
        except InputError:
            raise
        except Exception as err:  # a failing modal run etc. is a failed check, not a crash
            value, unit, detail = float("nan"), "", f"{type(err).__name__}: {err}"
        add("exact", value, tol, unit, detail)
    if "reaction" in checks:
        _check_reactions(scene, label, engine, traj, ref, model, add)
    if model.contacts:  # rolling contacts: slip, contact height, contact force (harness.measure.contact_metrics)
        contact_metrics.add_checks(scene, engine, traj, ref, model, add)
    mismatch = compare.engine_energy_mismatch(traj, model)
    if mismatch is not None:
        add("engine_energy", mismatch, ENGINE_ENERGY_TOL, "rel", "engine's own energy vs harness recomputation")
    return out


def _check_closure(table, engine: str, traj: Trajectory, model, add) -> None:
    """``closure.position`` (m) and ``closure.velocity`` (m/s): the largest gap and relative
    velocity of the cut joints' points (``compare.loop_closure``), and for hinges ``closure.axis``
    (rad, judged with the position tolerance) and ``closure.axis_rate`` (rad/s, with the velocity
    tolerance); the detail names the worst cut joint."""
    found = compare.loop_closure(traj, model)
    if not found:
        add("closure.position", float("nan"), quantities.per_engine(table["position"], engine), "",
            "the scene has [checks.closure] but no loop joints")
        return
    units = {"position": ("m", "position"), "axis": ("rad", "position"), "velocity": ("m/s", "velocity"),
             "axis_rate": ("rad/s", "velocity")}
    texts = {"position": "cut points coincide", "axis": "cut hinge axes stay aligned",
             "velocity": "cut points move together", "axis_rate": "relative rotation only about the cut hinge axis"}
    for kind, (unit, key) in units.items():
        values = {name: res[kind] for name, res in found.items() if kind in res}
        if not values:
            continue
        worst = max(values, key=lambda n: values[n])
        add(f"closure.{kind}", values[worst], quantities.per_engine(table[key], engine), unit,
            f"{texts[kind]}; worst: {worst}")


def _check_reactions(scene: Scene, label: str, engine: str, traj: Trajectory, ref: Trajectory | None, model, add) -> None:
    """``reaction.force`` / ``reaction.moment`` against the reference run's reactions, and
    ``reaction.exact`` against the scene's exact support force where ``harness.measure.exact`` has one;
    all relative to ``compare.reaction_scales`` of the reference (or of the run itself). In a
    model with loops the redundant rows leave part of each reaction to the engine's choice (the
    in-house minimum norm, Pinocchio's proximal solve, Exudyn's rows left out, MuJoCo's two
    connects); for a planar mechanism only the determinate part is compared, the force in the
    plane and the moment about its normal (``compare.plane_normal``). Joints
    only: a rolling contact's force is in ``Trajectory.reactions`` too, and has its own check
    (``contact_force``, ``harness.measure.contact_metrics``); with rolling contacts from the
    second sample on (``_joint_reactions_only``)."""
    tol = scene.checks["reaction"][engine]
    traj, ref = _joint_reactions_only(traj, model), None if ref is None else _joint_reactions_only(ref, model)
    if not traj.reactions:
        add("reaction", float("nan"), tol, "", f"{traj.engine} gave no joint reactions")
        return
    judge = ref if ref is not None and ref.ok and ref.reactions else traj
    f_scale, m_scale = compare.reaction_scales(judge, model)
    normal, part = None, ""
    if model.loops:  # redundant loop rows: only the determinate part of each reaction is the engines' to agree on
        normal = compare.plane_normal(model)
        if normal is None:
            add("reaction", float("nan"), tol, "", "the loops' redundant rows leave the reactions indeterminate and the "
                "mechanism is not planar: no determinate part to compare")
            return
        part = "; in-plane force and moment about the plane normal (the determinate part with redundant loop rows)"
    if ref is not None and ref.ok:
        err = compare.reaction_error(traj, ref, normal)
        add("reaction.force", err["force_max"] / f_scale, tol, "rel",
            f"{err['force_max']:.2e} N over force scale {f_scale:.3g} N; vs the reference's multipliers{part}")
        add("reaction.moment", err["moment_max"] / m_scale, tol, "rel",
            f"{err['moment_max']:.2e} N m over moment scale {m_scale:.3g} N m; about the joint point{part}")
    try:
        found = exact.exact_reaction(scene, traj)
    except Exception as err:  # noqa: BLE001 - a failing reference is a failed check, not a crash
        found = (float("nan"), f"{type(err).__name__}: {err}")
    if found is not None:
        value, detail = found
        add("reaction.exact", value / f_scale, tol, "rel", f"{value:.2e} N over force scale {f_scale:.3g} N; {detail}")


def _joint_reactions_only(traj: Trajectory, model) -> Trajectory:
    """``traj`` without the reactions of the model's rolling contacts (``Multibody.contacts``)
    and, in a model with rolling contacts, without the sample at t = 0, as the ``contact_force``
    check (``harness.measure.contact_metrics``): MuJoCo's soft contact carries no force before
    the rim penetrates the floor, so at t = 0 the whole system is in free fall there and every
    joint reaction differs from the ideal contact's (rolling_cylinder_bar: 2.45 N of 49 N at
    t = 0, 1.1e-6 N from t = 0.02 s)."""
    contacts = {c.name for c in getattr(model, "contacts", ())}
    if not contacts or not traj.reactions:
        return traj
    k = 1 if len(traj.t) > 1 else 0
    return replace(traj, t=traj.t[k:], p_WCm_W=traj.p_WCm_W[k:], quat_WB=traj.quat_WB[k:], v_WCm_W=traj.v_WCm_W[k:],
                   w_WB_W=traj.w_WB_W[k:],
                   reactions={n: (f[k:], m[k:]) for n, (f, m) in traj.reactions.items() if n not in contacts})


def _record(scene, engine, settings, traj, wall) -> RunRecord:
    adaptive = integrator(REFERENCE_ENGINE if engine == "reference" else engine, settings.integrator).adaptive
    return RunRecord(scene.name, engine, settings.integrator, settings.dt,
                     settings.rtol if adaptive else None, settings.t_end, traj.status, traj.message, wall,
                     float(traj.stats.get("steps", float("nan"))), str(traj.stats.get("settings", "")),
                     dict(traj.stats.get("warnings") or {}))


def _jsonable(value):
    return list(value) if isinstance(value, tuple) else value


def as_dict(v: SceneValidation) -> dict:
    return {
        "scene": v.scene,
        "passed": v.passed,
        "parameters": v.parameters,
        "parameter_overrides": v.overrides,
        "tolerance_changes": v.tolerance_changes,
        "runs": [asdict(r) for r in v.runs],
        "checks": [asdict(c) for c in v.checks],
        "cross_engine": v.cross,
        "not_run": v.not_run,
    }
