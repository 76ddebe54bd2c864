"""The closed-loop study: how well each engine closes a kinematic loop, against step size
(``harness loop-study``; the report is ``harness.studies.loops.report``).

Scenes: every scene whose multibody has cut joints (``Multibody.loops``), over its own horizon
(``--quick``: 0.5 s, at most a tenth of the scene's own). Steps: the scene's dt times ``FACTORS`` (2, 1, 1/2, 1/4; quick: 2, 1).

Variants (``VARIANTS``), each run at every step:

* the ideal-constraint engines, at the scene's integrator: in-house (the cut joint's rows in
  the KKT system, projection after each step; its compiled twin, ``rk4_compiled``, as
  ``harness validate`` runs it), Pinocchio (``constraintDynamics``, projection),
  Exudyn (index-3 DAE, generalized-alpha);
* MuJoCo RK4, whose ``<connect>`` equalities are soft constraints, four ways: the MJCF's own
  ``solref``/``solimp`` (as written); ``solref`` = (2 dt, the file's damping ratio), the time
  constant following the step at MuJoCo's safe minimum (MuJoCo raises a smaller one to 2 dt),
  with the file's ``solimp``; the file's ``solref`` with MuJoCo's default ``solimp`` (the
  impedance alone); and MuJoCo's defaults (``DEFAULT_SOLREF``,
  ``DEFAULT_SOLIMP``: what a user who writes ``<connect>`` with no settings gets). The
  variants are the scene's MJCF with the loop equalities rewritten (``rewrite_loop_settings``)
  and written to a temporary file (``soft_variant``). The study names MuJoCo once
  (``harness.studies.loops.SOFT_LOOP_ENGINE``); the ideal-constraint engines are those the
  registry declares so (``harness.engines.with_loops``);
* Drake where the scene does not say it cannot run (``[not_run]``): otherwise a "not run" row
  with the scene's reason.

Each run is made in its own worker process (``harness.validate.workers.run_cases``: a crash,
hang or exception is that run's status, never the study's end) and measured there
(``measure``): closure ``position`` (m), ``velocity`` (m/s), ``axis`` (rad) and ``axis_rate``
(rad/s), each the largest over the saved samples and the cut joints
(``harness.measure.compare.loop_closure``); ``energy``, max |E - E0| over the energy scale, or
for a scene whose forces do work the balance max |E - E0 - W| over it
(``compare.energy_balance``); ``exact`` (rad for the linkages), the error against the scene's
closed-form reference (``harness.measure.exact.exact_error``; NaN for a scene without one);
``wall_s`` (s) the time of the engine's ``simulate``; for a system whose source publishes a
reference state (``harness.measure.exact.published_state``: the Andrews squeezer at t = 0.03 s),
``published_digits_q`` and ``published_digits_v``, the run's correct digits of its positions and
velocities (NaN otherwise).

Samples are saved every ``scene.save_every`` s, or, for a scene whose forces do work, at every
step (as ``harness validate`` does): the energy balance integrates the forces' power over the
samples (Simpson, error ~ interval^4), and its estimate of that quadrature error is kept
(``energy_quadrature``, relative like ``energy``).
"""

from __future__ import annotations

import math
import tempfile
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable

import numpy as np

from harness.engines import (ENGINE_NAMES, IDEAL, check_scene, declaration, display, engine_module, prepare, run_method,
                             with_loops)
from harness.judging import error_model
from harness.model.errors import InputError
from harness.model.scene import MODELS_DIR, Scene, available_scenes, load_scene
from harness.studies.loops import SOFT_LOOP_ENGINE

FACTORS = (2.0, 1.0, 0.5, 0.25)  # steps: the scene's dt times these
QUICK_FACTORS = (2.0, 1.0)
QUICK_T_END = 0.5  # s, the horizon of --quick (at most a tenth of a scene's own)
IDEAL_CLOSURE = 1e-9  # m: the largest closure gap an ideal-constraint engine may leave (exit code)
DEFAULT_TIMEOUT = 300.0  # s per run
SOFT_NAME = display(SOFT_LOOP_ENGINE)  # how the report writes the soft-loop engine
SOFT_INTEGRATOR = "RK4"  # the integrator of its variants
#: MuJoCo's defaults for an equality constraint: solref (time constant s, damping ratio) and
#: solimp (d0, d_width, width m, midpoint, power); what ``<connect>`` without settings gets.
DEFAULT_SOLREF = (0.02, 1.0)
DEFAULT_SOLIMP = (0.9, 0.95, 0.001, 0.5, 2.0)


@dataclass(frozen=True)
class Variant:
    """One row of a scene's table: an engine, and for MuJoCo how its loop equalities are set.

    Attributes:
        key: identifier in the JSON and the cases.
        engine: the engine's registered name.
        label: the row's name in the report (the integrator is added from the scene).
        ideal: an ideal-constraint engine, whose closure gap must stay below ``IDEAL_CLOSURE``.
        loop: how the loop's constraints are set: ``"engine"`` (the engine's own, not a
            setting), ``"written"`` (the MJCF as written), ``"two_dt"`` (solref 2 dt),
            ``"default_solimp"`` (the MJCF's solref, MuJoCo's default solimp) or ``"defaults"``
            (MuJoCo's defaults).
    """

    key: str
    engine: str
    label: str
    ideal: bool
    loop: str = "engine"


#: The keys of the soft-loop engine's four variants (module docstring).
WRITTEN, TWO_DT, DEFAULT_SOLIMP_ONLY, DEFAULTS = (f"{SOFT_LOOP_ENGINE}_{loop}" for loop in
                                                  ("written", "two_dt", "default_solimp", "defaults"))
VARIANTS = (
    *(Variant(e, e, display(e), True) for e in with_loops(IDEAL)),
    Variant(WRITTEN, SOFT_LOOP_ENGINE, f"{SOFT_NAME}, MJCF's solref/solimp", False, "written"),
    Variant(TWO_DT, SOFT_LOOP_ENGINE, f"{SOFT_NAME}, solref 2·dt", False, "two_dt"),
    Variant(DEFAULT_SOLIMP_ONLY, SOFT_LOOP_ENGINE, f"{SOFT_NAME}, MJCF's solref, {SOFT_NAME}'s default solimp", False,
            "default_solimp"),
    Variant(DEFAULTS, SOFT_LOOP_ENGINE, f"{SOFT_NAME}, {SOFT_NAME}'s default solref/solimp", False, "defaults"),
    *(Variant(e, e, display(e), False) for e in ENGINE_NAMES if e not in with_loops(IDEAL) and e != SOFT_LOOP_ENGINE),
)
VARIANT = {v.key: v for v in VARIANTS}


# ------------------------------------------------------------------------------ scenes
def loop_scenes(models_dir: Path | None = None) -> list[Scene]:
    """Every scene under ``models_dir`` (default: the project's) whose multibody has cut joints,
    by name. InputError when there is none: a study over nothing is bad input."""
    scenes = [s for s in (check_scene(load_scene(n, models_dir=models_dir)) for n in available_scenes(models_dir))
              if s.multibody().loops]
    if not scenes:
        raise InputError(f"nothing to run: no scene with a closed kinematic loop (a cut joint) under "
                         f"{models_dir or MODELS_DIR}")
    return scenes


def integrator_of(scene: Scene, variant: Variant) -> str | None:
    """The integrator a variant runs: RK4 for MuJoCo, else the scene's ``[integrators]`` entry
    (None when the scene names none); for the in-house engine its compiled twin where the
    compiled form models the scene (``harness.engines.run_method``: ``rk4`` -> ``rk4_compiled``,
    the same method as Numba kernels, as ``harness validate`` runs it)."""
    if variant.engine == SOFT_LOOP_ENGINE:
        return SOFT_INTEGRATOR
    return run_method(variant.engine, scene.integrators.get(variant.engine), scene)


def full_label(variant: Variant, integrator: str | None) -> str:
    """The row's name with the integrator after the engine: "MuJoCo RK4, solref 2·dt"."""
    head, sep, tail = variant.label.partition(",")
    return f"{head} {integrator}{sep}{tail}" if integrator else variant.label


def horizon(scene: Scene, t_end: float | None) -> float:
    """A run's horizon (s): the scene's own, or for a study with its own ``t_end`` (``--quick``)
    the shorter of that and a tenth of the scene's (a smoke run of every scene)."""
    return scene.t_end if t_end is None else min(t_end, 0.1 * scene.t_end)


def save_interval(scene: Scene, dt: float) -> float:
    """Interval between saved samples (s) of a run at step ``dt`` (s): the scene's, or for a
    scene whose forces do work every step (module docstring)."""
    from harness.model.forces import does_work

    return dt if does_work(scene.multibody()) else scene.save_every


# ------------------------------------------------------------------------------ MuJoCo variants
Settings = dict[str, tuple[tuple[float, ...], tuple[float, ...]]]  # equality name -> (solref, solimp)


def loop_equalities(scene: Scene) -> list[str]:
    """Names of the MJCF equalities that close the scene's loops (``<connect>`` per cut joint,
    ``harness.engines.mujoco.loops.connects``)."""
    connects = engine_module(SOFT_LOOP_ENGINE, "loops").connects
    return [name for loop in scene.multibody().loops for name, *_ in connects(loop)]


def written_settings(spec, names: list[str], source: Path | str = "MJCF") -> Settings:
    """``{equality: (solref, solimp)}`` of the equalities ``names`` in an ``MjSpec`` as its file
    writes them (solref: time constant s and damping ratio, or negative stiffness and damping;
    solimp: d0, d_width, width m, midpoint, power). InputError naming ``source`` for a missing one."""
    out: Settings = {}
    found = {e.name: e for e in spec.equalities}
    for name in names:
        if name not in found:
            raise InputError(f"{source}: MJCF has no equality named {name!r}")
        eq = found[name]
        out[name] = (tuple(float(x) for x in eq.solref), tuple(float(x) for x in eq.solimp))
    return out


def variant_settings(loop: str, dt: float, written: Settings) -> Settings | None:
    """The loop equalities' settings of a MuJoCo variant at step ``dt`` (s); None for the MJCF
    as written (``loop == "written"``). ``"two_dt"``: solref (2 dt, the written damping ratio;
    1 where the file gives a negative, direct stiffness/damping solref) with the written solimp;
    ``"default_solimp"``: the written solref with MuJoCo's default solimp; ``"defaults"``:
    MuJoCo's defaults (solref and solimp)."""
    if loop == "written":
        return None
    if loop == "two_dt":
        return {name: ((2.0 * dt, ref[1] if ref[0] > 0 else 1.0), imp) for name, (ref, imp) in written.items()}
    if loop == "default_solimp":
        return {name: (ref, DEFAULT_SOLIMP) for name, (ref, _) in written.items()}
    if loop == "defaults":
        return {name: (DEFAULT_SOLREF, DEFAULT_SOLIMP) for name in written}
    raise ValueError(f"unknown loop setting {loop!r} (known: written, two_dt, default_solimp, defaults)")


def rewrite_loop_settings(spec, settings: Settings, source: Path | str = "MJCF") -> None:
    """Set ``solref``/``solimp`` of the named equalities of an ``MjSpec`` (nothing else changes).
    InputError naming ``source`` for an equality the spec does not have."""
    found = {e.name: e for e in spec.equalities}
    for name, (solref, solimp) in settings.items():
        if name not in found:
            raise InputError(f"{source}: MJCF has no equality named {name!r}")
        found[name].solref = [float(x) for x in solref]
        found[name].solimp = [float(x) for x in solimp]


def soft_variant(scene: Scene, settings: Settings | None, folder: Path, tag: str) -> Scene:
    """The scene with its MJCF's loop equalities rewritten to ``settings`` (None: the scene
    unchanged), written as ``folder/<scene>_<tag>.xml``; everything else in the file is kept
    (the harness rewrites the physics from the description when it loads the file)."""
    if settings is None:
        return scene
    spec = engine_module(SOFT_LOOP_ENGINE, "model").read_spec(scene.mjcf)
    rewrite_loop_settings(spec, settings, scene.mjcf)
    path = Path(folder) / f"{scene.name}_{tag}.xml"
    path.write_text(spec.to_xml())
    return replace(scene, mjcf=path)


def describe_settings(settings: Settings) -> str:
    """``"solref 0.002 1, solimp 0.9999 0.9999 0.001 0.5 2"`` (every equality alike), or each
    equality's own settings."""
    def one(s):
        return f"solref {' '.join(f'{x:g}' for x in s[0])}, solimp {' '.join(f'{x:g}' for x in s[1])}"

    texts = list(dict.fromkeys(one(s) for s in settings.values()))
    return texts[0] if len(texts) == 1 else "; ".join(f"{n}: {one(s)}" for n, s in settings.items())


# ------------------------------------------------------------------------------ one run


def measure(scene: Scene, traj, settings, engine: str) -> dict:
    """The study's measures of one trajectory (module docstring): ``closure_position`` (m),
    ``closure_velocity`` (m/s), ``closure_axis`` (rad), ``closure_axis_rate`` (rad/s),
    ``length_scale`` (m, ``compare.motion_scales``: the closure gap's scale in its error model),
    ``energy`` (relative), ``energy_quadrature`` (for an energy balance: the estimated
    quadrature error of the work, relative; else NaN), ``exact`` (its ``exact_unit``, rad for the linkages) and
    ``exact_detail``; NaN for what cannot be measured (no samples, no reference)."""
    from harness.measure import compare, exact
    from harness.model.forces import does_work

    model = scene.multibody()
    out = measure_nan()
    if len(traj.t) < 2:
        return out
    with np.errstate(all="ignore"):
        out["length_scale"] = float(compare.motion_scales(traj, model)["length"])
        closure = compare.loop_closure(traj, model)
        for key in ("position", "velocity", "axis", "axis_rate"):
            values = [c[key] for c in closure.values() if key in c]
            out[f"closure_{key}"] = float(max(values)) if values else float("nan")
        if does_work(model):
            out["energy"], out["energy_quadrature"] = compare.energy_balance(traj, model)
        else:
            out["energy"] = compare.energy_drift(traj, model)
    if exact.has_exact_error(scene):
        from harness.engines import get_engine

        value, unit, detail = exact.exact_error(scene, traj, settings, run=get_engine(engine).simulate)
        out |= {"exact": float(value), "exact_unit": unit, "exact_detail": detail}
    published = exact.published_state(scene, traj)
    if published is not None:
        out |= {"published_t": published["t"], "published_digits_q": published["positions"],
                "published_digits_v": published["velocities"]}
    return out


def run_case(scene: Scene, engine: str, integrator: str, dt: float, t_end: float, save: float) -> dict:
    """Worker body: one run of ``scene`` on ``engine`` at step ``dt`` (s) over ``t_end`` (s),
    saved every ``save`` (s), and its measures: ``status``, ``message``, ``wall_s`` (s, the
    engine's ``simulate``), ``settings`` (the engine's description of its run) and ``measure``'s."""
    from harness.engines import get_engine
    from harness.engines.base import RunSettings
    from harness.measure.invariants import mark_non_finite

    settings = RunSettings(t_end, dt, save, integrator)
    t0 = time.perf_counter()
    traj = get_engine(engine).simulate(scene, settings)
    wall = time.perf_counter() - t0
    traj = mark_non_finite(traj, scene.multibody())
    row = {"status": traj.status, "message": traj.message, "wall_s": wall,
           "settings": str(traj.stats.get("settings", "")) if traj.stats else ""}
    return row | measure(scene, traj, settings, engine)


# ------------------------------------------------------------------------------ the study
@dataclass
class SceneStudy:
    """One scene's part of the study.

    Attributes:
        scene: the scene (at its ``scene.toml`` defaults).
        steps: the steps run (s), coarsest first.
        saves: the interval between saved samples (s) at each step (``save_interval``).
        written: the MJCF's own loop-equality settings (``written_settings``).
        rows: one dict per run: ``variant``, ``label``, ``engine``, ``integrator``, ``factor``,
            ``dt`` (s), ``save_every`` (s), ``loop_settings`` (MuJoCo: the equalities' solref/solimp as run), then
            ``run_case``'s keys.
        not_run: variant key -> why it was not run (the scene's ``[not_run]``).
    """

    scene: Scene
    steps: list[float]
    saves: list[float]
    written: Settings
    rows: list[dict] = field(default_factory=list)
    not_run: dict[str, str] = field(default_factory=dict)

    def row(self, variant: str, dt: float) -> dict | None:
        return next((r for r in self.rows if r["variant"] == variant and r["dt"] == dt), None)

    def variants(self) -> list[str]:
        """Keys of the variants that have rows, in ``VARIANTS`` order."""
        have = {r["variant"] for r in self.rows}
        return [v.key for v in VARIANTS if v.key in have]


@dataclass
class LoopStudy:
    """Everything ``loop_study`` produces."""

    scenes: list[SceneStudy]
    t_end: float | None  # s; None: each scene's own horizon
    factors: tuple[float, ...]
    quick: bool
    jobs: int
    timeout: float
    wall_s: float = 0.0


def planned_runs(scenes: list[Scene], quick: bool = False) -> int:
    """How many runs ``loop_study`` makes for ``scenes`` (for a progress bar)."""
    steps = len(QUICK_FACTORS if quick else FACTORS)
    return sum(steps for s in scenes for v in VARIANTS
               if v.engine not in s.not_run and integrator_of(s, v) is not None)


def _cost(scene: Scene, variant: Variant, dt: float, t_end: float) -> float:
    """A rough cost (arbitrary units) to start the longest runs first."""
    return declaration(variant.engine).cost_per_step * len(scene.multibody().bodies) * t_end / dt


def loop_study(*, quick: bool = False, models_dir: Path | None = None, jobs: int | None = None,
               timeout: float = DEFAULT_TIMEOUT, on_done: Callable | None = None,
               scenes: list[Scene] | None = None) -> LoopStudy:
    """Run the study (module docstring); ``quick``: 0.5 s and the steps ``QUICK_FACTORS``.
    ``jobs``: worker processes (None: every usable CPU); ``timeout``: s per run (a scene's own
    ``[simulation] timeout`` where larger: ``Scene.timeout``); ``on_done(key,
    outcome)`` is called as each run ends (a progress bar). ``scenes``: the loop scenes
    (default ``loop_scenes(models_dir)``). InputError when a run reports bad input."""
    from harness.engines import get_engine
    from harness.validate.workers import effective_jobs, run_cases

    read_spec = engine_module(SOFT_LOOP_ENGINE, "model").read_spec

    t_start = time.perf_counter()
    scenes = loop_scenes(models_dir) if scenes is None else scenes
    factors = QUICK_FACTORS if quick else FACTORS
    for v in VARIANTS:
        get_engine(v.engine)  # imported once here: forked workers start with it loaded
    studies: list[SceneStudy] = []
    cases, meta = [], {}
    by_scene = {s.name: s for s in scenes}
    with tempfile.TemporaryDirectory(prefix="loop-study-") as tmp:
        for scene in scenes:
            t_end = horizon(scene, QUICK_T_END if quick else None)
            names = loop_equalities(scene)
            written = written_settings(read_spec(scene.mjcf), names, scene.mjcf)
            steps = [f * scene.dt for f in factors]
            study = SceneStudy(scene, steps, [save_interval(scene, dt) for dt in steps], written)
            studies.append(study)
            for v in VARIANTS:
                if v.engine in scene.not_run:
                    study.not_run[v.key] = scene.not_run[v.engine]
                    continue
                integrator = integrator_of(scene, v)
                if integrator is None:
                    study.not_run[v.key] = f"the scene's [integrators] names none for {v.engine}"
                    continue
                for f, dt, save in zip(factors, study.steps, study.saves):
                    run_scene, loop = scene, ""
                    if v.engine == SOFT_LOOP_ENGINE:
                        chosen = variant_settings(v.loop, dt, written)
                        run_scene = soft_variant(scene, chosen, Path(tmp), f"{v.key}_{f:g}")
                        loop = describe_settings(chosen or written)
                    key = (scene.name, v.key, f)
                    meta[key] = {"variant": v.key, "label": full_label(v, integrator), "engine": v.engine, "integrator": integrator,
                                 "factor": f, "dt": dt, "save_every": save, "loop_settings": loop}
                    cases.append((_cost(scene, v, dt, t_end),
                                  (key, run_case, (run_scene, v.engine, integrator, dt, t_end, save))))
        cases.sort(key=lambda c: -c[0])  # longest first: the last runs to end are short ones
        for engine in dict.fromkeys(v.engine for v in VARIANTS):  # compiled kernels: once here, not per worker
            if declaration(engine).compiled:
                prepare(engine, [(m["integrator"], by_scene[k[0]].multibody()) for k, m in meta.items()
                                 if m["engine"] == engine])
        # a scene's own case limit ([simulation] timeout: four_bar_chain's 81 bodies over 20 s) where larger
        limit = lambda key: max(timeout, by_scene[key[0]].timeout or 0.0)  # noqa: E731
        outcomes = run_cases([c for _, c in cases], jobs, limit, on_done=on_done)
    bad = [(k, o) for k, o in outcomes.items() if o.status == "input_error"]
    if bad:
        (scene, variant, f), outcome = bad[0]
        raise InputError(f"{scene} on {variant} at {f:g} dt: {outcome.message}")
    by_name = {s.scene.name: s for s in studies}
    for key in sorted(meta, key=lambda k: ([s.scene.name for s in studies].index(k[0]),
                                           [v.key for v in VARIANTS].index(k[1]), -k[2])):
        outcome = outcomes[key]
        row = dict(meta[key])
        if outcome.status == "ok":
            row |= outcome.value
        else:  # the worker crashed, timed out or raised: the run's status, NaN measures
            row |= {"status": outcome.status, "message": outcome.message, "wall_s": outcome.wall_s, "settings": "",
                    **measure_nan()}
        by_name[key[0]].rows.append(row)
    return LoopStudy(studies, QUICK_T_END if quick else None, tuple(factors), quick, effective_jobs(jobs), timeout,
                     time.perf_counter() - t_start)


def measure_nan() -> dict:
    """``measure``'s keys for a run that produced nothing."""
    nan = math.nan
    return {"closure_position": nan, "closure_velocity": nan, "closure_axis": nan, "closure_axis_rate": nan,
            "energy": nan, "energy_quadrature": nan, "exact": nan, "exact_unit": "", "exact_detail": "",
            "published_t": nan, "published_digits_q": nan, "published_digits_v": nan, "length_scale": nan}


# ------------------------------------------------------------------------------ verdict and findings
def failures(study: LoopStudy) -> list[str]:
    """Why the study fails, one line each (empty: it passes): a run that should run and did not
    end ok, or an ideal-constraint engine whose closure gap reaches ``IDEAL_CLOSURE`` (m) (or
    could not be measured) at some step."""
    out = []
    for s in study.scenes:
        for r in s.rows:
            where = f"{s.scene.name}: {r['label']} at dt = {r['dt']:g} s"
            if r["status"] != "ok":
                out.append(f"{where}: {r['status']}" + (f" ({r['message']})" if r.get("message") else ""))
            elif VARIANT[r["variant"]].ideal and not (r["closure_position"] < IDEAL_CLOSURE):
                out.append(f"{where}: closure gap {r['closure_position']:.2e} m, not below {IDEAL_CLOSURE:g} m")
    return out


def loglog_slope(steps, values) -> float:
    """Least-squares slope of log(value) against log(step) over the finite positive pairs:
    the observed order p of value ~ step^p (NaN with fewer than two such pairs)."""
    pairs = [(math.log(h), math.log(v)) for h, v in zip(steps, values)
             if h > 0 and v is not None and math.isfinite(v) and v > 0]
    if len(pairs) < 2:
        return math.nan
    x, y = np.array(pairs).T
    if np.ptp(x) == 0:
        return math.nan
    return float(np.polyfit(x, y, 1)[0])


def series(study: SceneStudy, variant: str, key: str) -> list[float]:
    """The measure ``key`` of a variant at each step of ``study.steps`` (NaN where missing or
    not ok)."""
    out = []
    for dt in study.steps:
        r = study.row(variant, dt)
        out.append(float(r[key]) if r is not None and r["status"] == "ok" else math.nan)
    return out


#: The measures fitted by ``error_models``: (row key, the unit when it is not the row's ``exact_unit``).
MODELLED = (("closure_position", "m"), ("energy", "rel"), ("exact", None))


def error_models(study: SceneStudy, t_end: float) -> dict[tuple[str, str], error_model.ErrorModel]:
    """Each variant's error model of each measure in ``MODELLED`` (``harness.judging.error_model``,
    as validate judges its checks), ``{(variant key, measure): model}``: the measure's values at
    the steps run, the scene's step first, fitted against the step at the integrator's order
    (``harness.engines.integrator``); a run that blew up is a NaN level (non-finite at the scene's
    step: a ``defect``), one that timed out, crashed or failed otherwise is left out (at the
    scene's step: ``not judged``). Scales: the run's length scale for the closure gap (m), 1 for the energy
    (relative) and the exact error (rad). Resolution: the round-off ``N eps`` of the finest run
    and ``JUDGING_RESOLUTION`` (each times the scale), and for an energy balance its quadrature's
    estimated error. A measure a scene does not have (no exact reference) has no model."""
    from harness.engines import integrator as integrator_record

    out = {}
    base_dt = study.scene.dt
    for key in study.variants():
        rows = [r for r in (study.row(key, dt) for dt in study.steps) if r is not None]
        if not rows:
            continue
        rows.sort(key=lambda r: (abs(r["dt"] - base_dt) > 1e-12 * base_dt, study.steps.index(r["dt"])))
        ok = [r for r in rows if r["status"] == "ok"]
        try:
            order = float(integrator_record(rows[0]["engine"], rows[0]["integrator"]).order)
        except Exception:  # an integrator the registry does not list: no formal order to judge by
            continue
        length = max((r.get("length_scale", math.nan) for r in ok if math.isfinite(r.get("length_scale", math.nan))),
                     default=1.0)
        steps = max(t_end / min(r["dt"] for r in rows), 1.0)
        if rows[0]["status"] not in ("ok", "blowup"):  # a timeout or a crash is no error to model
            for measure, unit in MODELLED:
                out[(key, measure)] = error_model.not_judged(measure, unit or "rad", "fixed", order,
                                                             f"the run at the scene's step: {rows[0]['status']}")
            continue
        rows = [r for r in rows if r["status"] in ("ok", "blowup")]
        for measure, unit in MODELLED:
            values = [float(r[measure]) if r["status"] == "ok" else math.nan for r in rows]
            if measure == "exact" and not any(math.isfinite(v) for v in values):
                continue
            unit = unit or next((r["exact_unit"] for r in ok if r.get("exact_unit")), "rad")
            scale = length if unit == "m" else 1.0
            res = max(error_model.roundoff(steps, scale), error_model.JUDGING_RESOLUTION * scale)
            if measure == "energy":
                quad = [r.get("energy_quadrature", math.nan) for r in ok]
                res = max([res] + [q for q in quad if math.isfinite(q)])
            levels = [error_model.Level(r["dt"], v) for r, v in zip(rows, values)]
            out[(key, measure)] = error_model.fit(measure, unit, scale, "fixed", order, levels, res)
    return out
