"""Validation of scenes: run every engine, compare, judge each check by how its error converges.

First, for each scene, the model files are judged AS WRITTEN (``model_checks``): each engine that
reads one (MuJoCo the MJCF, Pinocchio the URDF) loads it without the scene's parameters applied
(``harness.engines.as_written``), and every body's mass, centre of mass, inertia, joint
position, joint type and axis (and the MJCF's gravity) is checked against the scene at its
``scene.toml`` defaults, which the files must hold: checks ``model.<body>.<quantity>`` of that
engine (relative, 1e-6, the files' rounded decimals; axes 1e-9 rad). The runs themselves load the
files with the scene's parameters written over them (``load_mjcf``, ``load_urdf``), which is how
``--set`` overrides reach every engine, and why a wrong number in a file shows only here.

Then, for each scene: an in-house reference run (DOP853, rtol = atol = 1e-12) is made first; then
each engine runs at the scene's default integrator and step (an error-controlled default, Drake's
RK5, at the target accuracy ``ERROR_CONTROL_TOL`` of ``harness.engines.base``, simulate's default
too). The in-house runs (the reference included) use the compiled twin of their method (``harness.engines.inhouse.run_method``:
``rk4_compiled`` for ``rk4``, ``dop853_compiled`` for ``DOP853``) wherever the compiled form models
the scene, unless ``fast=False`` (``harness validate --per-state``: the readable per-state oracle
everywhere); each run's record names the method that ran. Checks (those the scene declares
in ``[checks.*]`` of its ``scene.toml``):

* ``energy_drift`` (unforced; over the reference run's energy scale) or ``energy_balance``
  (forced: E - E0 - work of the forces);
* ``momentum_drift.<c>`` for each conserved component the scene lists;
* ``trajectory.position/orientation/velocity/angular_velocity`` against the reference (each
  quantity and its scale defined once in ``harness.judging.quantities``, which ``harness debug``
  uses too);
* ``constraint.position/axis``, joint violations from maximal coordinates;
* ``exact``: against the scene's closed-form solution (``harness.measure.exact``);
* ``reaction.force/moment`` (scenes with ``[checks.reaction]``): joint reactions against the
  reference run's, and ``reaction.exact`` against the exact support force where one exists;
* ``slip``, ``contact_height``, ``contact_force`` (scenes with rolling contacts,
  ``harness.measure.contact_metrics``): slip speed at the contact point, its height (penetration), and
  the contact force against the reference's;
* ``engine_energy``: the engine's own energy against the harness's recomputation.

Every check of every run is then judged by how its error converges (``judge_convergence``,
``harness.judging``): the run is repeated at a coarser step (or a looser tolerance), each check
fitted as ``C h^p + F``, classified (converges, model difference, defect) and given a verdict
against the scene's requirements and declared model differences; no check holds a per-engine
number.

The reference run is itself checked (engine ``reference``) for conservation and against the
exact solution before it judges anything. A scene that declares no check against the reference
run (``trajectory``, ``contact_force``), or whose ``[not_run]`` names the reference engine (a
finding of that engine's on the scene; it may then declare no such check, ``harness.engines.check_scene``
refuses them), gets no reference run (``has_reference``): its engines are judged by its closed
form (``[checks.exact]``) and their own invariants. four_bar_chain is such a scene: A02's 81
bodies over 20 s, whose reference run would cost more than all its engines' runs.
Every run (reference, and each scene x engine) is made in its own worker process (``harness.validate.workers``): cases run in parallel, and a crash, hang
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

from harness.engines import AGAINST_REFERENCE_RUN, declaration, display, get_engine, integrator, model_file, run_method
from harness.engines.base import ERROR_CONTROL_ATOL, ERROR_CONTROL_TOL, RunSettings  # one set of defaults (simulate's too)
from harness.judging import refinement
from harness.judging.checks import (REFERENCE_ENGINE, REFERENCE_LABEL, CheckResult, check_run, extrapolated_difference,
                                    judge_convergence)
from harness.measure import compare, contact_metrics, exact, solution_cache
from harness.measure.invariants import mark_non_finite
from harness.measure.trajectory import Trajectory
from harness.model import forces
from harness.model.errors import InputError
from harness.model.scene import MODELS_DIR, Scene
from harness.validate.workers import Outcome

REFERENCE_METHOD = "DOP853"
REFERENCE_TOL = 1e-12
DEFAULT_TIMEOUT = 300.0   # s per case


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
    # "<a> vs <b>" -> judged trajectory quantity -> the two engines' difference extrapolated to
    # zero step (``extrapolated_difference``), in the quantity's judged unit (rel or rad)
    cross_extrapolated: dict[str, dict[str, float]] = field(default_factory=dict)
    # the reference run's motion scales (``compare.motion_scales``: length m, velocity m/s,
    # angular_velocity rad/s), which judge ``cross`` in the units of ``cross_extrapolated``; empty
    # where the reference did not run
    scales: dict[str, float] = field(default_factory=dict)
    tolerance_changes: list[str] = field(default_factory=list)
    overrides: dict[str, dict] = field(default_factory=dict)  # parameter -> {"value", "default"}: set away from scene.toml
    not_run: dict[str, str] = field(default_factory=dict)  # engine -> why it does not run this scene ([not_run])

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)


def has_reference(scene: Scene) -> bool:
    """Whether validation makes a reference run of ``scene``: where it declares a check judged
    against one (``harness.engines.AGAINST_REFERENCE_RUN``) and the reference engine runs it
    (module docstring)."""
    return REFERENCE_ENGINE not in scene.not_run and any(c in scene.checks for c in AGAINST_REFERENCE_RUN)


def save_interval(scene: Scene) -> float:
    """The scene's save interval, or its step when a force acts: the energy balance integrates
    the force's power over the saved samples (Simpson, error ~ interval^4), so a forced run is
    saved at every step."""
    return scene.dt if forces.does_work(scene.multibody()) else scene.save_every


def reference_settings(scene: Scene, fast: bool = True) -> RunSettings:
    """The in-house high-accuracy run that judges the engines' trajectories (with ``fast``, the
    compiled DOP853 where the compiled form models the scene), its steps at most the scene's
    step: a longer error-controlled step of the maximal-coordinate equations with a projection
    after it leaves an error of order two in the step on a light body far from its joint (the
    pendulum's 1 mm bob released 0.14 rad below the top: 3.8e-8 m over 10 s with steps up to the
    0.01 s save interval, 4.1e-10 m up to 1e-3 s, whatever the tolerance), which a step the
    scene's engines resolve keeps below theirs."""
    save = save_interval(scene)
    method = run_method(REFERENCE_ENGINE, REFERENCE_METHOD, scene, fast)
    return RunSettings(scene.t_end, save, save, method, rtol=REFERENCE_TOL, atol=REFERENCE_TOL, max_step=scene.dt)


def default_settings(scene: Scene, engine: str, fast: bool = True) -> RunSettings:
    """The engine's default integrator (for the in-house engine with ``fast``, its compiled twin
    where the compiled form models the scene) and the scene's step, horizon and save interval; an
    error-controlled method at ``harness.engines.base.ERROR_CONTROL_TOL`` and ``ERROR_CONTROL_ATOL``
    (``simulate``'s defaults too)."""
    method = run_method(engine, scene.integrators[engine], scene, fast)
    return RunSettings(scene.t_end, scene.dt, save_interval(scene), method, rtol=ERROR_CONTROL_TOL,
                       atol=ERROR_CONTROL_ATOL)


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
            # and at the engines' coarser level's saved times (a subset of these), once here rather than in every
            # engine's worker (the Andrews squeezer's, saved at every step: its DAE again per engine)
            coarse = refinement.scaled_step(RunSettings(scene.t_end, scene.dt, save_interval(scene), settings.integrator), 2.0)
            grid = None if coarse is None else refinement.on_grid(traj, np.arange(coarse.n_saves + 1) * coarse.save_every)
            if grid is not None and len(grid.t) != len(traj.t):
                exact.prepare(scene, grid)
        checks, _ = judge_convergence(scene, "reference", REFERENCE_ENGINE, settings, traj, None, checks)
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
    checks, second = judge_convergence(scene, engine, engine, settings, traj, ref, checks)
    return traj, record, checks, second


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
    refs, outcomes = _run_reference_then_engines(scenes, engines, jobs, timeout, progress, dask, fast)

    results = []
    for s in scenes:
        v = SceneValidation(scene=s.name, parameters={k: _jsonable(x) for k, x in s.params.items()},
                            tolerance_changes=list((tolerance_changes or {}).get(s.name, [])),
                            overrides=parameter_overrides(s, defaults[s.name]))
        v.checks.extend(models[s.name])
        ref = refs.get(s.name)
        if ref is not None:
            _collect(v, s, "reference", ref, reference_settings(s, fast))
        trajectories, seconds = {}, {}
        v.not_run = {e: s.not_run[e] for e in engines if e in s.not_run}
        if ref is None:
            why = (f"its engine ({REFERENCE_ENGINE}) does not run this scene" if REFERENCE_ENGINE in s.not_run
                   else "the scene declares no check against a reference run")
            v.not_run = {REFERENCE_LABEL: f"{why}; every engine is judged by the closed form and its own invariants",
                         **v.not_run}
        for e in engines:
            if e in v.not_run:
                continue
            outcome = outcomes[(s.name, e)]
            _collect(v, s, e, outcome, default_settings(s, e, fast))
            if outcome.status == "ok" and outcome.value[0].ok:
                trajectories[e] = outcome.value[0]
                seconds[e] = outcome.value[3]
            if ref is not None and ref.status != "ok" and "trajectory" in s.checks:
                v.checks.append(CheckResult(s.name, e, "trajectory", float("nan"), 0.0, "", False,
                                            f"no reference: reference run {ref.status}: {ref.message}"))
        ok = ref is not None and ref.status == "ok" and ref.value[0].ok
        if ok:
            v.scales = compare.motion_scales(ref.value[0], s.multibody())
        names = list(trajectories)
        methods = {e: integrator(e, default_settings(s, e, fast).integrator) for e in names}
        for i, a in enumerate(names):
            for b in names[i + 1:]:
                v.cross[f"{a} vs {b}"] = compare.trajectory_error(trajectories[a], trajectories[b])
                found = extrapolated_difference(s, (methods[a], trajectories[a], seconds.get(a)),
                                                (methods[b], trajectories[b], seconds.get(b)),
                                                ref.value[0] if ref is not None and ref.status == "ok" else None)
                if found:
                    v.cross_extrapolated[f"{a} vs {b}"] = found
        results.append(v)
    return results


def _run_reference_then_engines(scenes: list[Scene], engines: list[str], jobs: int, timeout: float, progress,
                                dask: str | None, fast: bool) -> tuple[dict, dict]:
    """Every scene's reference case, and each scene's engine cases as soon as its reference case
    has ended (they need its trajectory and exact solutions), on one pool of workers: no core
    waits for the slowest reference before the engines start (a scene without a reference run,
    ``has_reference``, starts its engine cases at once). Returns ``(refs, outcomes)``:
    ``{scene: Outcome}`` and ``{(scene, engine): Outcome}``. Raises InputError where a case
    reports bad input (the workers still running are killed on the way out)."""
    from harness.validate.workers import run_cases

    by_name = {s.name: s for s in scenes}

    def tick(key, outcome) -> None:
        if outcome.status == "input_error":
            raise InputError(outcome.message)
        if progress is not None:
            _tick(progress, key, outcome)

    def engines_of(key, outcome) -> list:
        if isinstance(key, tuple):
            return []
        s = by_name[key]
        ref, solutions = (outcome.value[0], outcome.value[3]) if outcome.status == "ok" else (None, None)
        return [((s.name, e), engine_case, (s, e, ref, fast, solutions)) for e in engines if e not in s.not_run]

    first = [(s.name, reference_case, (s, fast)) for s in scenes if has_reference(s)]
    first += [((s.name, e), engine_case, (s, e, None, fast, None))  # no reference run: the engines at once
              for s in scenes if not has_reference(s) for e in engines if e not in s.not_run]

    def limit(key) -> float:
        """A case's wall-clock limit (s): the command's, or its scene's own ``timeout`` where larger."""
        return max(timeout, by_name[key[0] if isinstance(key, tuple) else key].timeout or 0.0)

    found = run_cases(first, jobs, limit, on_done=tick, dask=dask, follow=engines_of)
    refs = {k: o for k, o in found.items() if not isinstance(k, tuple)}
    outcomes = {k: o for k, o in found.items() if isinstance(k, tuple)}
    return refs, outcomes


def _tick(progress, key, outcome) -> None:
    """One finished case on the bar: ``heavy_top reference ok 0.8 s``, ``heavy_top mujoco ok 0.3 s``."""
    from harness.io.progress import case_label

    label = case_label(key if isinstance(key, tuple) else (key, "reference"), outcome)
    done = getattr(progress, "done", None)
    done(label) if done is not None else progress.update(1)


def validate_scene(scene: Scene, engines: list[str], **kwargs) -> SceneValidation:
    """Validate one scene (see ``validate``)."""
    return validate([scene], engines, **kwargs)[0]


def _defaults(scene: Scene) -> Scene:
    from harness.engines.as_written import scene_defaults

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
    ``harness.engines.loaded_models.body_discrepancies``, engine = the loader. A file that does not
    load or holds a non-physical body raises InputError; any other failure to read it back is
    a failed ``model.load`` check. A scene that names one model file only is checked as each
    engine reads that file (``harness.engines.as_written.as_read``); a scene whose files are
    generated for its parameters (``Scene.generated``), against the scene itself."""
    from harness.engines.as_written import MODEL_ENGINES, as_read

    holder = scene if scene.generated else defaults if defaults is not None else _defaults(scene)
    model0 = holder.multibody()
    against = "the scene's description (files generated from it)" if scene.generated else "scene.toml defaults"
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
            loaded = as_read(scene, engine, model0)
        except InputError:
            raise
        except Exception as err:  # noqa: BLE001 - a model that cannot be read back is a failed check
            path = model_file(scene, engine)
            out.append(CheckResult(scene.name, engine, "model.load", float("nan"), 0.0, "", False,
                                   f"{path.name} as written: {type(err).__name__}: {' '.join(str(err).split())}; {hint} shows more"))
            continue
        for d in loaded.discrepancies:
            name = f"model.{d.body}.{d.quantity}" if d.body else f"model.{d.quantity}"
            source = (f"{display(engine)}'s system as built from scene.toml" if not declaration(engine).reads
                      else f"{loaded.path.name} as written")
            detail = f"{source} vs {against}: {d.message}"
            if not d.passed:
                detail += f"; {hint} shows more"
            out.append(CheckResult(scene.name, engine, name, float(d.value), float(d.tolerance), d.unit, d.passed, detail))
    return out


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
        "requirement_changes": v.tolerance_changes,
        "runs": [asdict(r) for r in v.runs],
        "checks": [asdict(c) for c in v.checks],
        "cross_engine": v.cross,
        "cross_engine_extrapolated": v.cross_extrapolated,
        "motion_scales": v.scales,
        "not_run": v.not_run,
    }
