"""Stress runs: a stability map of every engine and integrator on stiff and extreme variants.

The catalogue (``harness/studies/stress/catalogue.toml``, read by ``load_catalogue``) lists variants of
the scenes: a scene, parameter overrides, optional body mass scalings, a horizon, a nominal
step, the largest step to try, the integrators per engine, the references and tolerance bands.
For each variant and each engine/integrator, ``run_stress`` finds the largest stable fixed step
by bisection and reports the error there; at the nominal step it reports the time each quantity
first leaves its tolerance band and the class of the energy drift, and, where the run diverged
there, its class in the judging vocabulary (``judging_class``: a ``defect``, as
``harness.judging.error_model`` calls a non-finite value at the scene's step). Error-controlled methods (every
integrator its engine's table marks adaptive: the in-house SciPy methods, Drake's RK3, RK5 and
Radau3) are run once at the catalogue's ``rtol`` instead, their largest step the save interval.
The in-house ``rk4`` and ``DOP853`` runs, and the DOP853 references, run their compiled twins
wherever the compiled form models the scene (``harness.engines.inhouse.run_method``; the rows
keep the catalogue's names): ``rk4_compiled`` gives rk4's trajectory to round-off and fails in
the same modes; ``dop853_compiled`` is the same method with its own step-size control, so its
steps and errors differ from SciPy's within the tolerance (mean steps 0-10 % apart on the
catalogue). Every trial runs in its own worker process with a
timeout (``harness.validate.workers.run_cases``): a crash or hang is that trial's failure mode.

Stability (``evaluate``)
------------------------
A run is *stable* when it reaches its horizon and none of these holds; the one that shows
first in time is the run's failure mode (ties in this order; an engine's own stop counts at the
sample after its last one):

* ``crash`` / ``timeout`` / ``error``: the worker died, ran past the timeout, or raised;
* ``nan``: a non-finite state; ``badqacc``: MuJoCo's own guards (``mjWARN_BADQACC``,
  ``BADQVEL``, ``BADQPOS``: MuJoCo resets the state, so the numbers stay finite);
  ``solver failure``: an integrator or dynamics failure the engine reports;
* ``magnitude growth`` (engine): a speed beyond the engine's own bound (1e8 m/s or rad/s);
* ``energy growth``: max_t |E(t) - E(0)| / E_scale > ``energy_bound`` (1 = 100%);
* ``magnitude growth``: a speed beyond ``magnitude_bound`` times the energy-scale speeds
  sqrt(2 E_scale / M) (m/s) and sqrt(2 E_scale / I_min) (rad/s);
* ``constraint drift``: a joint violation beyond ``constraint_bound`` times the length scale
  (m), or ``constraint_bound`` rad for a hinge axis (also an in-house projection that fails);
  ``singular constraint``: the engine reports a singular constraint (e.g. a rolling disk flat).

A run the engine/integrator cannot make at all (trajectory status ``"unsupported"``, e.g. a
compiled in-house integrator on the rolling disk) is neither stable nor unstable: its step search
stops at once and its cell is *not run*, with the engine's reason (``MapRow.unsupported``).

Scales, from the run's initial state: the length ``l`` is the largest of the bodies' distances
from the world origin and radii of gyration (m); ``E_scale = T(0) + M |g| l`` (J).

Accuracy, per quantity (``QUANTITIES``), as error series over the saved samples:

* ``exact``: the scene's closed-form error per sample, ``exact_error_series`` of its reference
  module ``references/<scene>.py`` (through ``harness.measure.exact``; only scenes whose exact
  check needs no extra run have one, and only for unscaled bodies: the closed forms read the
  scene's parameters); a variant checks it when its ``references`` list ``"exact"``;
* ``position`` / ``velocity`` / ``angular_velocity``: distance to the in-house DOP853 reference
  (rtol = atol = 1e-12) over the reference's motion scales (``compare.motion_scales``);
  ``orientation``: geodesic angle to the reference (rad); each maximised over bodies, per sample:
  the trajectory quantities of ``harness.judging.quantities``, the very definitions validate's
  ``trajectory.*`` checks and the work-precision study's state error use;
* ``energy``: |E(t) - E(0)| / E_scale (exact conservation; no reference needed).

A run is *accurate* when it is stable and every quantity stays within its band. The *first
divergence time* of a quantity is the first saved time at which it leaves its band. The
run's ``error`` is its largest ``exact`` error when the variant has a closed form, else its
largest trajectory error against DOP853 (the state error, ``quantities.state_error``), else its
energy error.

Largest stable step (``StepSearch``)
------------------------------------
Trial steps are ``save_every / n`` or ``save_every * p / q`` (whole n, p, q; q <= 4), so every
sample lands on the reference's saved times; a run at ``save_every * p / q`` is saved every p
reference samples and runs to the last of them within the horizon (at least 10 steps). The
search runs ``dt_max`` and the nominal step first; if ``dt_max`` is stable the result is
censored (stable at the largest step tried). Otherwise it divides the smallest unstable step by
``search_factor`` until a stable step lies within that factor (at most ``search_steps`` times,
never below ``t_end / max_steps[engine]``, the step budget, a tenth of it with ``--quick``),
then bisects on log(dt) between the largest stable and the smallest larger unstable step for
``bisect_iters`` steps or until their ratio is within ``1 + precision``. It assumes stability is
monotone in dt; a stable step above an unstable one is reported as ``non-monotone``. When the
two smallest steps tried fail with the same singular constraint, solver failure or constraint
drift at the same time (within 2% and one sample, after ten samples), the failure is not a
step-size instability (e.g. a disk landing flat) and the search stops there.

Energy drift (``classify_drift``)
---------------------------------
With e(t) = |E(t) - E(0)| / E_scale and its running maximum M(t) (the envelope, which removes
oscillation within a period), the exponent p is the least-squares slope of log M against log t
over the last two decades of the run (t from t_end/100 to t_end, 25 log-spaced points):

* ``bounded``: M(t_end) <= 1e-13 (round-off) or p < 0.3 (no secular trend);
* ``linear``: 0.3 <= p <= 1.5 (secular drift; a round-off random walk gives p ~ 0.5);
* ``faster``: p > 1.5, marked ``(exponential)`` when log M is closer to a straight line in t
  than in log t.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from dataclasses import fields as dataclass_fields
from fractions import Fraction
from pathlib import Path
from typing import Any, Callable, Mapping

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover
    import tomli as tomllib

import numpy as np

from harness.measure import compare
from harness.measure import exact
from harness.measure import invariants
from harness.judging import quantities
from harness.engines import (ENGINE_NAMES, REFERENCE_ENGINE, check_scene, declaration, engine_module, fast_method,
                             get_engine, prepare, preload, run_method)
from harness.engines import integrator as integrator_record
from harness.engines.base import RunSettings
from harness.judging.error_model import DEFECT
from harness.model.errors import InputError
from harness.model.multibody import Multibody
from harness.model.scene import Scene, available_scenes, load_scene
from harness.measure.trajectory import UNSUPPORTED, Failure, Trajectory
from harness.model.sanity import check_multibody
from harness.validate.workers import Outcome, effective_jobs

DEFAULT_CATALOGUE = Path(__file__).resolve().with_name("catalogue.toml")
QUANTITIES = ("exact", "position", "orientation", "velocity", "angular_velocity", "energy")
TRAJECTORY_QUANTITIES = quantities.NAMES  # position, orientation, velocity, angular_velocity
REFERENCE_KINDS = ("exact", "dop853")
REFERENCE_TOL = 1e-12
FAILURE_MODES = {  # mode -> one-letter code of the map
    "nan": "N", "badqacc": "Q", "solver failure": "S", "magnitude growth": "M", "energy growth": "E",
    "constraint drift": "C", "singular constraint": "Z", "crash": "X", "timeout": "T", "error": "!",
}
SERIES_POINTS = 600  # samples kept per series for the plots
_MODEL_FAILURES = ("singular constraint", "solver failure", "constraint drift")
#: Failure modes in which the state diverged: non-finite, MuJoCo's reset guards, speeds or energy
#: beyond their bounds (``judging_class``).
DIVERGED = ("nan", "badqacc", "magnitude growth", "energy growth")

_DEFAULT_KEYS = {"rtol", "energy_bound", "magnitude_bound", "constraint_bound", "bisect_iters", "search_factor",
                 "search_steps", "precision", "quick_bisect_iters", "references", "band", "max_steps", "integrators"}
_VARIANT_KEYS = {"scene", "doc", "group", "sweep", "sweep_label", "tags", "set", "scale", "t_end", "t_end_by_engine", "save_every",
                 "dt", "dt_max", "references", "band", "rate", "integrators", "rtol", "quick"}
_QUICK_KEYS = {"t_end", "t_end_by_engine", "dt", "dt_max"}


# ------------------------------------------------------------------------------------ catalogue
@dataclass(frozen=True)
class Bounds:
    """Stability bounds and search settings (the catalogue's ``[defaults]``)."""

    energy_bound: float = 1.0
    magnitude_bound: float = 10.0
    constraint_bound: float = 1e-2
    bisect_iters: int = 3
    search_factor: float = 4.0
    search_steps: int = 4
    precision: float = 0.15
    quick_bisect_iters: int = 1
    max_steps: Mapping[str, int] = field(default_factory=dict)


@dataclass(frozen=True)
class Variant:
    """One stress case: a scene with overrides and how to run it (times in s, rates in rad/s).

    ``integrators`` maps engine -> integrator names; ``band`` maps quantity -> tolerance;
    ``scale`` maps body name -> factor on its mass and inertia; ``t_end_by_engine`` shortens
    the horizon per engine (key ``"drake"``) or per engine and integrator (``"drake/RK5"``,
    which wins over the engine's key).
    """

    name: str
    scene: str
    doc: str
    group: str
    sweep: float | None
    sweep_label: str
    tags: tuple[str, ...]
    params: Mapping[str, Any]
    scale: Mapping[str, float]
    t_end: float
    t_end_by_engine: Mapping[str, float]
    save_every: float
    dt: float
    dt_max: float
    references: tuple[str, ...]
    band: Mapping[str, float]
    rate: float | None
    integrators: Mapping[str, tuple[str, ...]]
    rtol: float

    def horizon(self, engine: str, integrator: str | None = None) -> float:
        """The horizon (s) of ``engine``'s runs (of its ``integrator``'s, when given)."""
        by = self.t_end_by_engine
        return float(by.get(f"{engine}/{integrator}", by.get(engine, self.t_end)))


@dataclass(frozen=True)
class Catalogue:
    """The variants in catalogue order and the bounds they are judged by."""

    path: Path
    variants: tuple[Variant, ...]
    bounds: Bounds

    def variant(self, name: str) -> Variant:
        for v in self.variants:
            if v.name == name:
                return v
        raise InputError(f"unknown variant {name!r} (known: {', '.join(v.name for v in self.variants)})")


def load_catalogue(path: Path | None = None, *, quick: bool = False) -> Catalogue:
    """Read and check a stress catalogue; with ``quick`` each variant's ``quick`` table applies.

    Raises:
        InputError: unreadable or malformed file, unknown key, engine or integrator, bad value.
    """
    path = Path(path) if path is not None else DEFAULT_CATALOGUE
    if not path.is_file():
        raise InputError(f"{path}: stress catalogue not found")
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as err:
        raise InputError(f"{path}: malformed TOML: {err}") from None
    defaults = data.get("defaults", {})
    _check_keys(defaults, _DEFAULT_KEYS, f"{path}: [defaults]")
    bounds = Bounds(
        energy_bound=_positive(defaults.get("energy_bound", 1.0), "energy_bound", path),
        magnitude_bound=_positive(defaults.get("magnitude_bound", 10.0), "magnitude_bound", path),
        constraint_bound=_positive(defaults.get("constraint_bound", 1e-2), "constraint_bound", path),
        bisect_iters=int(defaults.get("bisect_iters", 3)),
        search_factor=_positive(defaults.get("search_factor", 4.0), "search_factor", path),
        search_steps=int(defaults.get("search_steps", 4)),
        precision=_positive(defaults.get("precision", 0.15), "precision", path),
        quick_bisect_iters=int(defaults.get("quick_bisect_iters", 1)),
        max_steps={e: int(n) for e, n in defaults.get("max_steps", {}).items()},
    )
    if bounds.search_factor <= 1.0:
        raise InputError(f"{path}: [defaults] search_factor must be > 1")
    variants = []
    for name, spec in data.get("variants", {}).items():
        variants.append(_variant(name, spec, defaults, path, quick))
    if not variants:
        raise InputError(f"{path}: no [variants.*] tables")
    return Catalogue(path, tuple(variants), bounds)


def _check_keys(table: Mapping, allowed: set[str], where: str) -> None:
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise InputError(f"{where}: unknown key {unknown[0]!r} (known: {', '.join(sorted(allowed))})")


def _positive(value: Any, what: str, where: Any) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{where}: {what} must be a number, got {value!r}") from None
    if not (math.isfinite(x) and x > 0.0):
        raise InputError(f"{where}: {what} must be positive and finite, got {value!r}")
    return x


def _variant(name: str, spec: Mapping, defaults: Mapping, path: Path, quick: bool) -> Variant:
    where = f"{path}: [variants.{name}]"
    _check_keys(spec, _VARIANT_KEYS, where)
    spec = dict(spec)
    q = spec.pop("quick", {})
    _check_keys(q, _QUICK_KEYS, where + " quick")
    if quick:
        spec.update(q)
    if "scene" not in spec:
        raise InputError(f"{where}: lacks 'scene'")
    save = _positive(spec.get("save_every"), "save_every", where)
    t_end = _positive(spec.get("t_end"), "t_end", where)
    if quick and "t_end" not in q:  # a tenth of the horizon, at least 10 saved intervals
        t_end = save * max(10, round(t_end / save / 10))
    by_engine = {e: _positive(x, f"t_end_by_engine.{e}", where) for e, x in spec.get("t_end_by_engine", {}).items()}
    for label, horizon in [("t_end", t_end)] + [(f"t_end_by_engine.{e}", x) for e, x in by_engine.items()]:
        ratio = horizon / save
        if abs(ratio - round(ratio)) > 1e-6 * ratio or round(ratio) < 1:
            raise InputError(f"{where}: {label} {horizon!r} is not a whole multiple of save_every {save!r}")
    dt = _positive(spec.get("dt", save), "dt", where)
    dt_max = _positive(spec.get("dt_max", save), "dt_max", where)
    integrators = dict(defaults.get("integrators", {}))
    integrators.update(spec.get("integrators", {}))
    for engine, names in integrators.items():
        if engine not in ENGINE_NAMES:
            raise InputError(f"{where}: unknown engine {engine!r} (known: {', '.join(ENGINE_NAMES)})")
        known = get_engine(engine).integrators
        for integ in names:
            if integ not in known:
                raise InputError(f"{where}: unknown integrator {integ!r} for {engine} (known: {', '.join(known)})")
    for key in by_engine:
        engine, _, integ = key.partition("/")
        if engine not in ENGINE_NAMES:
            raise InputError(f"{where}: t_end_by_engine: unknown engine {engine!r}")
        if integ and integ not in get_engine(engine).integrators:
            raise InputError(f"{where}: t_end_by_engine: unknown integrator {integ!r} for {engine}")
    refs = tuple(spec.get("references", defaults.get("references", ["dop853"])))
    for r in refs:
        if r not in REFERENCE_KINDS:
            raise InputError(f"{where}: unknown reference {r!r} (known: {', '.join(REFERENCE_KINDS)})")
    scale = {b: _positive(f, f"scale.{b}", where) for b, f in spec.get("scale", {}).items()}
    if "exact" in refs and (scale or not exact.has_error_series(str(spec["scene"]))):
        raise InputError(f"{where}: no exact solution for scene {spec['scene']!r}"
                         + (" with scaled bodies" if scale else
                            f" per sample (references/{spec['scene']}.py defines no exact_error_series)"))
    band = dict(defaults.get("band", {}))
    band.update(spec.get("band", {}))
    for key, value in band.items():
        if key not in QUANTITIES:
            raise InputError(f"{where}: band: unknown quantity {key!r} (known: {', '.join(QUANTITIES)})")
        band[key] = _positive(value, f"band.{key}", where)
    missing = [k for k in QUANTITIES if k not in band]
    if missing:
        raise InputError(f"{where}: band lacks {missing[0]!r}")
    sweep = spec.get("sweep")
    return Variant(
        name=name,
        scene=str(spec["scene"]),
        doc=str(spec.get("doc", "")),
        group=str(spec.get("group", name)),
        sweep=None if sweep is None else _positive(sweep, "sweep", where),
        sweep_label=str(spec.get("sweep_label", "")),
        tags=tuple(spec.get("tags", ())),
        params=dict(spec.get("set", {})),
        scale=scale,
        t_end=t_end,
        t_end_by_engine=by_engine,
        save_every=save,
        dt=dt,
        dt_max=dt_max,
        references=refs,
        band=band,
        rate=None if spec.get("rate") is None else _positive(spec["rate"], "rate", where),
        integrators={e: tuple(v) for e, v in integrators.items()},
        rtol=_positive(spec.get("rtol", defaults.get("rtol", 1e-8)), "rtol", where),
    )


# ------------------------------------------------------------------------------------ scenes
@dataclass(frozen=True)
class ScaledScene(Scene):
    """A scene whose bodies' masses and inertias are scaled (``body_scale``: (name, factor)
    pairs; same geometry, uniform density). Every engine builds its model from
    ``multibody()``, so all of them see the scaled bodies."""

    body_scale: tuple[tuple[str, float], ...] = ()

    def multibody(self) -> Multibody:
        model = super().multibody()
        factors = dict(self.body_scale)
        bodies = tuple(replace(b, mass=b.mass * factors[b.name], I_Cm_B=b.I_Cm_B * factors[b.name])
                       if b.name in factors else b for b in model.bodies)
        scaled = replace(model, bodies=bodies)
        check_multibody(scaled, source=f"{self.directory / 'scene.toml'} (scaled {dict(self.body_scale)})")
        return scaled


def skip_reason(variant: Variant, models_dir: Path | None = None) -> str | None:
    """Why ``variant`` cannot run with the scenes at hand (None when it can)."""
    if variant.scene not in available_scenes(models_dir):
        return f"scene not available: no {variant.scene}/scene.toml under models/"
    scene = check_scene(load_scene(variant.scene, models_dir=models_dir))
    unknown = [k for k in variant.params if k not in scene.parameters]
    if unknown:
        return f"scene {variant.scene!r} has no parameter {unknown[0]!r} (parameters: {', '.join(scene.parameters)})"
    names = scene.multibody().body_names
    missing = [b for b in variant.scale if b not in names]
    if missing:
        return f"scene {variant.scene!r} has no body {missing[0]!r} (bodies: {', '.join(names)})"
    for engine in variant.integrators:  # an engine the scene excludes ([not_run]) runs "unsupported": not run
        if engine not in scene.integrators and engine not in scene.not_run:
            return f"scene {variant.scene!r} has no default integrator for {engine}"
    return None


def variant_scene(variant: Variant, models_dir: Path | None = None) -> Scene:
    """The variant's scene: parameters overridden, bodies scaled."""
    scene = check_scene(load_scene(variant.scene, variant.params, models_dir=models_dir))
    if variant.scale:
        fields = {f.name: getattr(scene, f.name) for f in dataclass_fields(Scene) if f.init}
        scene = ScaledScene(**fields, body_scale=tuple(sorted(variant.scale.items())))
        scene.multibody()  # check the scaled bodies now
    return scene


def characteristic_rate(scene: Scene, t_end: float) -> float:
    """The reference engine's characteristic rate of the scene (rad/s): fastest body spin or
    compound-pendulum frequency at t = 0 (the in-house engine's ``characteristic_rate``)."""
    ref = engine_module(REFERENCE_ENGINE, "")
    model = scene.multibody()
    nem = ref.build(model)
    return float(ref.characteristic_rate(nem, ref.initial_state(model, nem), model.gravity_W, t_end))


# ------------------------------------------------------------------------------------ trials
@dataclass(frozen=True)
class TrialSpec:
    """One run to make: engine, integrator, step, horizon, save interval (s), role
    (``nominal``, ``search``, ``adaptive`` or ``reference``)."""

    variant: str
    engine: str
    integrator: str
    dt: float
    t_end: float
    save_every: float
    rtol: float
    role: str


@dataclass(frozen=True)
class TrialResult:
    """How one run ended and how it compares (see the module docstring for every measure).

    ``max_errors`` / ``divergence``: quantity -> largest error / first time (s) beyond its band
    (None: never). ``series_*``: downsampled time (s), error (the run's ``error_kind``) and
    energy error, for the plots. ``t_reached``: last saved time the run reached (s).
    """

    spec: TrialSpec
    status: str
    mode: str
    stable: bool
    accurate: bool
    error: float
    error_kind: str
    max_errors: Mapping[str, float]
    divergence: Mapping[str, float | None]
    energy_error: float
    constraint: float
    t_reached: float
    t_fail: float | None
    drift_class: str
    drift_p: float
    steps: float
    rhs_evals: float
    wall_s: float
    message: str
    series_t: np.ndarray = field(default_factory=lambda: np.zeros(0))
    series_error: np.ndarray = field(default_factory=lambda: np.zeros(0))
    series_energy: np.ndarray = field(default_factory=lambda: np.zeros(0))


@dataclass(frozen=True)
class Reference:
    """What judges a variant's runs: the DOP853 trajectory (or None), whether the closed form
    applies, and the tolerance band per quantity."""

    trajectory: Trajectory | None
    exact: bool
    band: Mapping[str, float]


def judging_class(result: TrialResult | None) -> str:
    """The nominal run's outcome (the run at the variant's nominal step, or an error-controlled
    method's one run) in the judging vocabulary (``harness.judging.error_model``) where it fits:
    a run that diverged there (``DIVERGED``) is a ``defect``, what the error model calls a
    non-finite value at the scene's step: ``"defect (diverged: <mode>)"``. Every other outcome
    keeps the study's own semantics and is "": a stable run has one step, so no error model (its
    bands judge its accuracy); a singular constraint, constraint drift or solver failure, a crash
    or a timeout is a failure mode of its own, not a class; and above the largest stable step a
    blow-up is the stability limit the map measures, not a defect."""
    if result is None or result.mode not in DIVERGED:
        return ""
    return f"{DEFECT} (diverged: {result.mode})"


def settings_of(spec: TrialSpec) -> RunSettings:
    return RunSettings(spec.t_end, spec.dt, spec.save_every, spec.integrator, rtol=spec.rtol, atol=1e-2 * spec.rtol)


def run_settings(scene: Scene, spec: TrialSpec) -> RunSettings:
    """The settings a trial runs with: an in-house run takes the compiled twin of the trial's
    method where the compiled form models the scene (``harness.engines.run_method``)."""
    settings = settings_of(spec)
    return replace(settings, integrator=run_method(spec.engine, settings.integrator, scene))


def trial_case(scene: Scene, spec: TrialSpec, ref: Reference, bounds: Bounds) -> TrialResult:
    """Worker body: make one run and evaluate it (an engine's own warnings are captured by its run)."""
    t0 = time.perf_counter()
    traj = get_engine(spec.engine).simulate(scene, run_settings(scene, spec))
    return evaluate(traj, scene, spec, ref, bounds, time.perf_counter() - t0)


def reference_case(scene: Scene, spec: TrialSpec, judge: Reference, bounds: Bounds) -> tuple[Trajectory, TrialResult]:
    """Worker body: the DOP853 reference run, and its own evaluation against the closed form
    (``judge`` without a trajectory)."""
    t0 = time.perf_counter()
    traj = get_engine(REFERENCE_ENGINE).simulate(scene, run_settings(scene, spec))
    result = evaluate(traj, scene, spec, judge, bounds, time.perf_counter() - t0)
    return traj, result


def failed_trial(spec: TrialSpec, outcome: Outcome) -> TrialResult:
    """The result of a trial whose worker crashed, timed out or raised."""
    mode = {"crashed": "crash", "timeout": "timeout"}.get(outcome.status, "error")
    nan = float("nan")
    return TrialResult(spec, outcome.status, mode, False, False, nan, "", {}, {}, nan, nan, 0.0, None, "", nan,
                       nan, nan, outcome.wall_s, outcome.message)


#: The failure mode of a run its engine stopped, per ``Failure`` (``engine_mode``).
ENGINE_MODES = {
    Failure.NONE: "", Failure.UNSUPPORTED: UNSUPPORTED,
    Failure.ENGINE_GUARD: "badqacc",            # MuJoCo's own guard tripped (it resets the state)
    Failure.SPEED: "magnitude growth",          # every engine's speed guard (BLOWUP_SPEED)
    Failure.NON_FINITE: "nan",
    Failure.SINGULAR: "singular constraint",    # a singular constraint matrix, a rolling disk lying flat
    Failure.PROJECTION: "constraint drift",     # a projection that did not converge
    Failure.SOLVER: "solver failure",
}


def engine_mode(traj: Trajectory) -> str:
    """Failure mode of a run the engine itself stopped ("" when it reached its horizon), decided
    by the trajectory's ``reason`` (``ENGINE_MODES``), never by its message; "unsupported" is not
    a failure: the cell is not run."""
    return ENGINE_MODES[traj.reason]


def scales(traj: Trajectory, model: Multibody) -> dict[str, float]:
    """Scales from a run's first sample: ``length`` l (m), ``energy`` T(0) + M |g| l (J),
    ``speed`` sqrt(2 E/M) (m/s), ``rate`` sqrt(2 E / I_min) (rad/s)."""
    gyration = max(float(np.sqrt(np.linalg.eigvalsh(b.I_Cm_B)[-1] / b.mass)) for b in model.bodies)
    length = max(float(np.max(np.linalg.norm(traj.p_WCm_W[0], axis=-1))), gyration)
    kinetic0 = float(invariants.energies(_head(traj, 1), model)["kinetic"][0])
    energy = kinetic0 + model.total_mass * float(np.linalg.norm(model.gravity_W)) * length
    energy = energy if energy > 0.0 else 1.0
    i_min = min(float(np.linalg.eigvalsh(b.I_Cm_B)[0]) for b in model.bodies)
    return {"length": length, "energy": energy, "speed": math.sqrt(2.0 * energy / model.total_mass),
            "rate": math.sqrt(2.0 * energy / i_min)}


def _head(traj: Trajectory, n: int) -> Trajectory:
    return _take(traj, slice(0, n))


def _take(traj: Trajectory, idx) -> Trajectory:
    """The samples ``idx`` (a slice or indices) of ``traj``'s state (engine energies dropped)."""
    return replace(traj, t=traj.t[idx], p_WCm_W=traj.p_WCm_W[idx], quat_WB=traj.quat_WB[idx],
                   v_WCm_W=traj.v_WCm_W[idx], w_WB_W=traj.w_WB_W[idx], engine_energy={})


def _reference_series(traj: Trajectory, ref: Trajectory, model: Multibody) -> dict[str, np.ndarray]:
    """The trajectory quantities against the reference on the samples both have
    (``quantities.judged_series`` over the reference's ``compare.motion_scales``; the reference is
    saved at least as often and is subsampled onto the run's times)."""
    stride = 1
    if len(traj.t) > 1 and len(ref.t) > 1:
        stride = max(1, int(round((traj.t[1] - traj.t[0]) / (ref.t[1] - ref.t[0]))))
    idx = np.arange(0, len(ref.t), stride)
    n = min(len(traj.t), len(idx))
    r = _take(ref, idx[:n])
    return quantities.judged_series(traj, r, compare.motion_scales(ref, model), n)


def evaluate(traj: Trajectory, scene: Scene, spec: TrialSpec, ref: Reference, bounds: Bounds,
             wall_s: float = float("nan")) -> TrialResult:
    """Stability, accuracy, divergence times and drift class of one run (module docstring)."""
    model = scene.multibody()
    nan = float("nan")
    steps = float(traj.stats.get("steps", nan))
    rhs = float(traj.stats.get("rhs_evals", nan))
    n = len(traj.t)
    if traj.unsupported:  # not a failure of the method: the cell is "not run" (StepSearch.summary)
        return TrialResult(spec, traj.status, UNSUPPORTED, False, False, nan, "", {}, {}, nan, nan, 0.0, None, "",
                           nan, steps, rhs, wall_s, traj.message)
    mode = engine_mode(traj)
    if n == 0:
        return TrialResult(spec, traj.status, mode or "solver failure", False, False, nan, "", {}, {}, nan, nan, 0.0,
                           0.0, "", nan, steps, rhs, wall_s, traj.message)
    sc = scales(traj, model)
    with np.errstate(all="ignore"):
        energy = invariants.energies(traj, model)["energy"]
        e = np.abs(energy - energy[0]) / sc["energy"]
        series: dict[str, np.ndarray] = {"energy": e}
        if ref.exact:
            series["exact"] = np.asarray(exact.exact_error_series(scene, traj), dtype=float)
        if ref.trajectory is not None and len(ref.trajectory.t):
            series.update(_reference_series(traj, ref.trajectory, model))
        speed = np.max(np.linalg.norm(traj.v_WCm_W, axis=-1), axis=1)
        rate = np.max(np.linalg.norm(traj.w_WB_W, axis=-1), axis=1)
        constraint = _violation(traj, model, sc["length"])
    finite = bool(np.all(np.isfinite(e)))
    # each failure with the first saved time it shows; the earliest is the run's failure mode
    # (an engine's own stop shows after its last sample; ties go to the earlier in this list)
    candidates: list[tuple[float, str]] = []
    if not finite:
        candidates.append((float(traj.t[int(np.argmax(~np.isfinite(e)))]), "nan"))
    if mode:
        candidates.append((float(traj.t[-1]) + spec.save_every, mode))
    over = np.flatnonzero(e > bounds.energy_bound)
    if over.size:
        candidates.append((float(traj.t[over[0]]), "energy growth"))
    over = np.flatnonzero((speed > bounds.magnitude_bound * sc["speed"]) | (rate > bounds.magnitude_bound * sc["rate"]))
    if over.size:
        candidates.append((float(traj.t[over[0]]), "magnitude growth"))
    if not constraint <= bounds.constraint_bound:
        k = _first_violation(traj, model, sc["length"], bounds.constraint_bound)
        candidates.append((float(traj.t[k]), "constraint drift"))
    t_fail = None
    if candidates:
        order = ["nan", mode, "energy growth", "magnitude growth", "constraint drift"]
        t_fail, mode = min(candidates, key=lambda c: (c[0], order.index(c[1])))
        t_fail = min(t_fail, float(traj.t[-1]))
    stable = not mode
    band = ref.band
    max_errors, divergence = {}, {}
    for q, err in series.items():
        err = np.where(np.isfinite(err), err, np.inf)
        max_errors[q] = float(np.max(err)) if len(err) else nan
        bad = np.flatnonzero(err > band[q])
        divergence[q] = float(traj.t[bad[0]]) if bad.size else None
    accurate = stable and all(max_errors[q] <= band[q] for q in series)
    if "exact" in series:
        kind = "exact"
    elif "position" in series:
        kind = "trajectory"
    else:
        kind = "energy"
    if kind == "trajectory":
        error = quantities.state_error(max_errors)
        err_series = quantities.state_error(series)
    else:
        error = max_errors[kind]
        err_series = series[kind]
    drift, p = classify_drift(traj.t, e) if finite else ("", nan)
    ts, es = downsample(traj.t[: len(err_series)], err_series)
    _, ee = downsample(traj.t, e)
    return TrialResult(spec, traj.status, mode, stable, accurate, float(error), kind, max_errors, divergence,
                       float(np.max(e)), float(constraint), float(traj.t[-1]), t_fail, drift, p, steps, rhs, wall_s,
                       traj.message, ts, es, ee)


def _violation(traj: Trajectory, model: Multibody, length: float) -> float:
    """Largest joint violation of a run: position over the length scale, or hinge-axis angle."""
    viol = compare.constraint_violation(traj, model)
    return max(viol["position"] / length, viol["axis"])


def _first_violation(traj: Trajectory, model: Multibody, length: float, bound: float) -> int:
    """Index of the first sample whose joint violation exceeds ``bound`` (bisection on
    prefixes; the run's largest violation must exceed it)."""
    lo, hi = 0, len(traj.t) - 1  # the prefix ending at hi exceeds, the one ending before lo does not
    while lo < hi:
        mid = (lo + hi) // 2
        if _violation(_head(traj, mid + 1), model, length) > bound:
            hi = mid
        else:
            lo = mid + 1
    return hi


def downsample(t: np.ndarray, x: np.ndarray, points: int = SERIES_POINTS) -> tuple[np.ndarray, np.ndarray]:
    """At most ~``points`` samples of ``x(t)``: the largest value in each bin (so that peaks
    survive), at the bin's last time. Bin edges are half evenly spaced, half log-spaced in the
    sample index, so that both linear and logarithmic time axes stay resolved."""
    n = len(x)
    if n <= points:
        return np.asarray(t[:n], float).copy(), np.asarray(x, float).copy()
    edges = np.unique(np.concatenate([np.linspace(0, n, points // 2 + 1), np.geomspace(1, n, points // 2),
                                      [0.0]]).astype(int))
    edges = edges[edges < n]
    xs = np.maximum.reduceat(np.where(np.isfinite(x), x, np.inf), edges)
    last = np.append(edges[1:], n) - 1
    return np.asarray(t)[last].astype(float), xs.astype(float)


def classify_drift(t: np.ndarray, e: np.ndarray) -> tuple[str, float]:
    """Class of the energy drift e(t) (dimensionless) and its exponent p (module docstring)."""
    t = np.asarray(t, float)
    e = np.asarray(e, float)
    if len(t) < 10 or t[-1] <= 0.0:
        return "", float("nan")
    env = np.maximum.accumulate(e)
    if env[-1] <= 1e-13:
        return "bounded", 0.0
    t_lo = max(t[-1] / 100.0, t[1])
    tk = np.geomspace(t_lo, t[-1], 25)
    idx = np.clip(np.searchsorted(t, tk, side="right") - 1, 0, len(t) - 1)
    mk = np.maximum(env[idx], 1e-300)
    log_m = np.log(mk)
    p = float(np.polyfit(np.log(t[idx]), log_m, 1)[0])
    if p < 0.3:
        return "bounded", p
    if p <= 1.5:
        return "linear", p
    res_pow = np.polyfit(np.log(t[idx]), log_m, 1, full=True)[1]
    res_exp = np.polyfit(t[idx], log_m, 1, full=True)[1]
    rp = float(res_pow[0]) if len(res_pow) else 0.0
    rx = float(res_exp[0]) if len(res_exp) else 0.0
    return ("faster (exponential)" if rx < rp else "faster"), p


# ------------------------------------------------------------------------------------ search
def _divisors(n: int) -> list[int]:
    small = [d for d in range(1, int(math.isqrt(n)) + 1) if n % d == 0]
    return sorted(set(small + [n // d for d in small]))


class StepSearch:
    """The largest stable step of one engine/integrator on one variant (module docstring)."""

    def __init__(self, variant: Variant, engine: str, integrator: str, bounds: Bounds, *, quick: bool = False):
        self.variant, self.engine, self.integrator = variant, engine, integrator
        self.t_end = variant.horizon(engine, integrator)
        self.save = variant.save_every
        self.n_saves = int(round(self.t_end / self.save))
        self.adaptive = integrator_record(engine, integrator).adaptive  # error-controlled: run once at rtol
        self.bounds = bounds
        self.max_iters = bounds.quick_bisect_iters if quick else bounds.bisect_iters
        budget = bounds.max_steps.get(engine)
        if budget and quick:  # a smoke run: a tenth of the step budget too
            budget = max(1, budget // 10)
        self.floor = self.t_end / budget if budget else 0.0
        self.same_time = False
        self.trials: dict[float, TrialResult] = {}
        self.iters = 0
        self.searches = 0
        self.done = False
        self.notes: list[str] = []
        self.dt_max = self._snap(variant.dt_max, 0.0, variant.dt_max, inclusive=True)
        nominal = variant.dt if self.adaptive else self._snap(variant.dt, 0.0, math.inf, inclusive=True)
        if not self.adaptive and nominal < self.floor * (1 - 1e-9):
            nominal = self._snap(self.floor, self.floor * (1 - 1e-9), math.inf, inclusive=True)
            self.notes.append(f"nominal step raised to {nominal:.3g} s by the step budget")
        self.nominal = min(nominal, self.dt_max) if not self.adaptive else nominal

    # candidate steps: save / n, or save * p / q (q <= 4) above save_every, so that samples land
    # on the reference's saved times: a run at save * p / q is saved every p reference samples
    # (q steps), runs to the last such sample within the horizon, and is tried only when the
    # horizon holds at least 10 of its steps
    def _candidates(self, target: float) -> list[float]:
        x = target / self.save
        out = []
        if x >= 1.0:
            r_max = max(1.0, self.n_saves / 10.0)
            for q in range(1, 5):
                p0 = int(x * q)
                out += [self.save * p / q for p in range(max(q, p0 - 1), p0 + 3) if p / q <= r_max]
            out.append(self.save * min(max(1, int(r_max)), max(1, int(round(x)))))
        if x <= 1.0:
            n0 = 1.0 / x
            out += [self.save / n for n in range(max(1, int(n0) - 1), int(math.ceil(n0)) + 2)]
        return out

    def _ratio(self, dt: float) -> Fraction:
        """dt / save_every as a fraction p / q (1 / n below save_every)."""
        x = dt / self.save
        if x < 1.0 - 1e-9:
            return Fraction(1, int(round(1.0 / x)))
        return Fraction(x).limit_denominator(8)

    def _snap(self, target: float, lo: float, hi: float, inclusive: bool = False) -> float | None:
        """The candidate step closest to ``target`` in log, in (lo, hi) (or [lo, hi])."""
        eps = 1e-9
        if inclusive:
            ok = [c for c in self._candidates(target) if lo * (1 - eps) <= c <= hi * (1 + eps)]
        else:
            ok = [c for c in self._candidates(target) if lo * (1 + eps) < c < hi * (1 - eps)]
        if not ok:
            return None
        return min(ok, key=lambda c: (abs(math.log(c / target)), -c))

    def spec(self, dt: float, role: str) -> TrialSpec:
        # adaptive methods step at most one save interval: save them at dt_max, not to cap them
        r = self._ratio(self.dt_max if self.adaptive else dt)
        m = max(1, r.numerator)  # reference samples per saved sample of this run
        save = m * self.save
        t_end = (self.n_saves // m) * m * self.save
        return TrialSpec(self.variant.name, self.engine, self.integrator, dt, t_end, save, self.variant.rtol, role)

    def next_specs(self) -> list[TrialSpec]:
        """The trials to run next (none once the search is done, or as soon as a trial shows
        that the engine/integrator does not model the variant's scene)."""
        if self.done:
            return []
        if self.unsupported_reason():
            self.done = True
            return []
        if self.adaptive:
            if self.trials:
                self.done = True
                return []
            return [self.spec(self.nominal, "adaptive")]
        if not self.trials:
            first = [self.spec(self.dt_max, "search")]
            if abs(self.nominal - self.dt_max) > 1e-12 * self.dt_max:
                first.append(self.spec(self.nominal, "nominal"))
            else:
                first = [self.spec(self.dt_max, "nominal")]
            return first
        stable = sorted(dt for dt, r in self.trials.items() if r.stable)
        unstable = sorted(dt for dt, r in self.trials.items() if not r.stable)
        if self._key(self.dt_max) in stable:
            self.done = True
            return []
        if stable:
            dt_s = stable[-1]
            above = [u for u in unstable if u > dt_s]
            dt_u = above[0]
            factor = self.bounds.search_factor
            if dt_u / dt_s > factor * (1 + 1e-9) and self.searches < self.bounds.search_steps:
                nxt = self._snap(dt_u / factor, dt_s, dt_u)
                if nxt is not None:  # narrow a wide bracket from above first
                    self.searches += 1
                    return [self.spec(nxt, "search")]
            if self.iters >= self.max_iters or dt_u / dt_s <= 1.0 + self.bounds.precision:
                self.done = True
                return []
            mid = self._snap(math.sqrt(dt_s * dt_u), dt_s, dt_u)
            if mid is None:
                self.done = True
                return []
            self.iters += 1
            return [self.spec(mid, "search")]
        dt_u = unstable[0]
        if self.searches >= self.bounds.search_steps or dt_u <= self.floor * (1 + 1e-9):
            self.done = True
            return []
        if len(unstable) >= 2 and self._fails_at_same_time(unstable[0], unstable[1]):
            self.same_time = True  # a smaller step does not help: not a step-size instability
            self.done = True
            return []
        nxt = self._snap(max(dt_u / self.bounds.search_factor, self.floor), self.floor, dt_u, inclusive=True)
        if nxt is None or nxt >= dt_u * (1 - 1e-9):
            self.done = True
            return []
        self.searches += 1
        return [self.spec(nxt, "search")]

    def _fails_at_same_time(self, dt_a: float, dt_b: float) -> bool:
        """Both runs failed the same model failure (singular constraint, solver failure,
        constraint drift) within 2% (and one sample) of the same time, after their first ten
        samples (an instability that shows at once looks step-independent too)."""
        a, b = self.trials[dt_a], self.trials[dt_b]
        if a.mode != b.mode or a.mode not in _MODEL_FAILURES or a.t_fail is None or b.t_fail is None:
            return False
        sample = max(a.spec.save_every, b.spec.save_every)
        if min(a.t_fail, b.t_fail) < 10 * sample:
            return False
        return abs(a.t_fail - b.t_fail) <= 0.02 * max(a.t_fail, b.t_fail) + sample

    def _key(self, dt: float) -> float:
        for k in self.trials:
            if abs(k - dt) <= 1e-12 * dt:
                return k
        return dt

    def record(self, result: TrialResult) -> None:
        self.trials[self._key(result.spec.dt)] = result

    def unsupported_reason(self) -> str:
        """The engine's reason when a trial came back "unsupported" (the engine/integrator does
        not model the scene, whatever the step), else ""."""
        return next((r.message or "unsupported" for r in self.trials.values() if r.status == UNSUPPORTED), "")

    def summary(self) -> "MapRow":
        """The search's outcome as one row of the stability map."""
        v = self.variant
        nominal = next((r for r in self.trials.values() if r.spec.role in ("nominal", "adaptive")), None)
        reason = self.unsupported_reason()
        if reason:  # not run: no step was searched, no failure mode applies
            return MapRow(v.name, self.engine, self.integrator, self.t_end, "adaptive" if self.adaptive else "fixed",
                          None, False, None, "", float("nan"), "", False, nominal, float("nan"),
                          list(self.notes) + [f"not run: {reason}"], dict(self.trials), unsupported=reason)
        if self.adaptive:
            r = nominal
            mean_h = (self.t_end / r.steps) if r is not None and r.steps and np.isfinite(r.steps) else float("nan")
            return MapRow(v.name, self.engine, self.integrator, self.t_end, "adaptive", None, False, None,
                          r.mode if r else "", r.error if r else float("nan"), r.error_kind if r else "",
                          bool(r and r.accurate), nominal, mean_h, list(self.notes), dict(self.trials))
        stable = sorted(dt for dt, r in self.trials.items() if r.stable)
        unstable = sorted(dt for dt, r in self.trials.items() if not r.stable)
        notes = list(self.notes)
        if stable:
            dt_s = stable[-1]
            above = [u for u in unstable if u > dt_s]
            dt_u = above[0] if above else None
            if any(u < dt_s for u in unstable):
                notes.append("non-monotone: unstable at " + ", ".join(f"{u:.3g}" for u in unstable if u < dt_s) + " s")
            r_s = self.trials[dt_s]
            mode = self.trials[dt_u].mode if dt_u is not None else ""
            return MapRow(v.name, self.engine, self.integrator, self.t_end, "fixed", dt_s, dt_u is None, dt_u, mode,
                          r_s.error, r_s.error_kind, r_s.accurate, nominal, dt_s, notes, dict(self.trials))
        dt_u = unstable[0] if unstable else None
        mode = self.trials[dt_u].mode if dt_u is not None else ""
        if dt_u is not None:
            if self.same_time:
                why = f"fails at t = {self.trials[dt_u].t_fail:.3g} s at every step tried: not a step-size instability"
            elif self.searches >= self.bounds.search_steps:
                why = f"{self.searches} divisions by {self.bounds.search_factor:g}"
            else:
                why = f"step budget: {self.t_end / self.floor:.3g} steps" if self.floor else "step budget"
            notes.append(f"no stable step down to {dt_u:.3g} s ({why})")
        return MapRow(v.name, self.engine, self.integrator, self.t_end, "fixed", None, False, dt_u, mode,
                      float("nan"), "", False, nominal, float("nan"), notes, dict(self.trials))


@dataclass
class MapRow:
    """One cell of the stability map: a variant on one engine/integrator.

    ``stable_dt``: largest stable step found (s; None: none); ``censored``: stable at the
    largest step tried; ``unstable_dt`` and ``mode``: the smallest unstable step above it and
    its failure mode; ``error``: error at ``stable_dt``; ``nominal``: the run at the nominal
    step (adaptive methods: their one run); ``step``: the stable step, or the mean step of an
    adaptive run (s); ``unsupported``: the engine's reason when the engine/integrator does not
    model the variant's scene (its trials came back "unsupported": the cell is not run), else "".
    """

    variant: str
    engine: str
    integrator: str
    t_end: float
    kind: str
    stable_dt: float | None
    censored: bool
    unstable_dt: float | None
    mode: str
    error: float
    error_kind: str
    accurate: bool
    nominal: TrialResult | None
    step: float
    notes: list[str]
    trials: dict[float, TrialResult]
    unsupported: str = ""

    @property
    def label(self) -> str:
        return f"{self.engine}/{self.integrator}"


@dataclass
class StressRun:
    """Everything a stress sweep produced."""

    catalogue: Catalogue
    variants: list[Variant]
    skipped: dict[str, str]
    rates: dict[str, float]
    references: dict[str, TrialResult]
    rows: list[MapRow]
    quick: bool
    timeout: float
    jobs: int
    wall_s: float

    @property
    def trials(self) -> list[TrialResult]:
        out = list(self.references.values())
        for row in self.rows:
            out += [row.trials[k] for k in sorted(row.trials, reverse=True)]
        return out


# ------------------------------------------------------------------------------------ driver
def select(catalogue: Catalogue, names: list[str] | None, engines: list[str] | None) -> tuple[list[Variant], list[str]]:
    """The variants and engines asked for; InputError for an unknown name."""
    variants = [catalogue.variant(n) for n in names] if names else list(catalogue.variants)
    engines = list(engines) if engines else list(ENGINE_NAMES)
    for e in engines:
        get_engine(e)
    return variants, engines


def _cost(spec: TrialSpec) -> float:
    if spec.role in ("adaptive", "reference"):  # error-controlled: ~20 steps per saved interval, a guess
        return 20.0 * spec.t_end / spec.save_every * declaration(spec.engine).cost_per_step
    return spec.t_end / spec.dt * declaration(spec.engine).cost_per_step


def run_dynamic(propose: Callable[[], list[tuple[Any, Callable, tuple, float, float]]],
                on_done: Callable[[Any, Outcome], None], jobs: int, dask: str | None = None) -> None:
    """Run cases in worker processes (``harness.validate.workers.Workers``, as ``run_cases``: the
    same isolation, outcomes and clean-up on SIGTERM), but work-conserving: ``propose()`` returns
    new ``(key, fn, args, cost, timeout)`` cases and is asked again whenever a case ends
    (``on_done(key, outcome)``), so a bisection's next step starts as soon as its last one ends. Waiting cases start highest ``cost`` first;
    each is limited to its own ``timeout`` (s). ``dask``: a scheduler address to run them on instead
    (``harness.validate.workers.open_workers``)."""
    from harness.validate.workers import open_workers

    pending: list[tuple[Any, Callable, tuple, float, float]] = sorted(propose(), key=lambda c: -c[3])
    with open_workers(jobs, dask) as workers:
        while pending or len(workers):
            while pending and workers.free():
                key, fn, args, _, limit = pending.pop(0)
                workers.start(key, fn, args, limit)
            done = workers.wait()
            for key, outcome in done:
                on_done(key, outcome)
            if done:
                pending = sorted(pending + propose(), key=lambda c: -c[3])


def run_stress(catalogue: Catalogue, variants: list[Variant], engines: list[str], *, quick: bool = False,
               jobs: int | None = None, timeout: float = 60.0, models_dir: Path | None = None,
               log: Callable[[str], None] = lambda s: None, progress: Any = None,
               dask: str | None = None) -> StressRun:
    """Run the variants on the engines (module docstring); every trial in its own worker, each
    limited to ``timeout`` s (a reference run to 4 ``timeout``). ``progress``: a bar
    (``harness.io.progress.make_bar``) whose total is set to the engine/integrator cells and
    which ticks as each cell's step search ends (its postfix counts the runs), or None.
    ``dask``: the address of a ``dask.distributed`` scheduler whose workers run the trials
    (``harness.validate.dask_workers``; the same map as a local run), else the local pool."""
    start = time.perf_counter()
    if dask:
        from harness.validate.dask_workers import slots

        jobs = slots(dask, jobs)  # the cluster's worker threads, at most jobs
    else:
        jobs = effective_jobs(jobs)  # clamped to the CPUs this process may use
    bounds = catalogue.bounds
    skipped, scenes, rates = {}, {}, {}
    for v in variants:
        reason = skip_reason(v, models_dir)
        if reason:
            skipped[v.name] = reason
            log(f"{v.name}: skipped ({reason})")
            continue
        scenes[v.name] = variant_scene(v, models_dir)
        rates[v.name] = v.rate or characteristic_rate(scenes[v.name], v.t_end)
    runnable = [v for v in variants if v.name in scenes]
    by_name = {v.name: v for v in runnable}

    refs: dict[str, Reference] = {}       # ready references; a variant's trials wait for its own
    ref_rows: dict[str, TrialResult] = {}
    ref_todo: dict[str, TrialSpec] = {}
    for v in runnable:
        used = [v.horizon(e, i) for e in engines for i in v.integrators.get(e, ())]
        if "dop853" in v.references and used:  # over the longest horizon any engine runs
            ref_todo[v.name] = TrialSpec(v.name, "reference", f"DOP853 rtol {REFERENCE_TOL:g}", v.save_every,
                                         max(used), v.save_every, REFERENCE_TOL, "reference")
        else:
            refs[v.name] = Reference(None, "exact" in v.references, dict(v.band))
    searches = [StepSearch(v, e, integ, bounds, quick=quick)
                for v in runnable for e in engines for integ in v.integrators.get(e, ())]
    by_id = {id(s): s for s in searches}
    if progress is not None:
        progress.total = len(searches)
        progress.refresh()
    # a compiled method with a cold Numba cache: the parent says so once, not each worker, and loads
    # the kernels once for the workers it forks (the runs' methods as run_settings picks them)
    for engine in dict.fromkeys([*engines, REFERENCE_ENGINE]):
        if not declaration(engine).compiled:
            continue
        own = {(s.integrator, s.variant.name) for s in searches if s.engine == engine}
        if engine == REFERENCE_ENGINE:
            own |= {("DOP853", name) for name in ref_todo}
        runs = []
        for method, name in sorted(own):
            model = scenes[name].multibody()
            runs.append((fast_method(engine, method, model), model))
        prepare(engine, runs)
    if not dask:
        preload(engines)  # the engines' own lazy imports (Drake's), once for the forked workers
    in_flight = {id(s): 0 for s in searches}
    left = {v.name: sum(s.variant.name == v.name for s in searches) for v in runnable}
    counts = {"trials": 0}
    flying: dict[Any, TrialSpec] = {}

    def propose():
        out = []
        while ref_todo:
            name, spec = ref_todo.popitem()
            v = by_name[name]
            judge = Reference(None, "exact" in v.references, dict(v.band))
            run_spec = replace(spec, engine=REFERENCE_ENGINE, integrator="DOP853")
            flying[("reference", name)] = spec
            out.append((("reference", name), reference_case, (scenes[name], run_spec, judge, bounds), math.inf,
                        4.0 * timeout))
        for s in searches:
            name = s.variant.name
            if name not in refs or in_flight[id(s)] or s.done:
                continue
            for spec in s.next_specs():
                flying[(id(s), spec.dt)] = spec
                out.append(((id(s), spec.dt), trial_case, (scenes[name], spec, refs[name], bounds), _cost(spec), timeout))
                in_flight[id(s)] += 1
            if s.done:
                if progress is not None:  # one line per finished cell where no bar is drawn
                    label = f"{name} {s.engine}/{s.integrator} done ({counts['trials']} runs, {time.perf_counter() - start:.0f} s)"
                    done = getattr(progress, "done", None)
                    done(label) if done is not None else progress.update(1)
                left[name] -= 1
                if left[name] == 0:
                    log(f"{name}: done ({time.perf_counter() - start:.0f} s)")
        return out

    def on_done(key, outcome):
        counts["trials"] += 1
        if progress is not None:
            progress.set_postfix_str(f"{counts['trials']} runs", refresh=False)
        spec = flying.pop(key)
        if key[0] == "reference":
            name = key[1]
            v = by_name[name]
            traj = None
            if outcome.status == "ok":
                traj, res = outcome.value
                res = replace(res, spec=replace(res.spec, engine="reference", integrator=spec.integrator))
                if not traj.ok:
                    log(f"{name}: reference run {traj.status}: {traj.message}")
                    traj = None
            else:
                res = failed_trial(spec, outcome)
                log(f"{name}: reference run {outcome.status}: {outcome.message}")
            ref_rows[name] = res
            refs[name] = Reference(traj, "exact" in v.references, dict(v.band))
            return
        in_flight[key[0]] -= 1
        by_id[key[0]].record(outcome.value if outcome.status == "ok" else failed_trial(spec, outcome))

    run_dynamic(propose, on_done, jobs, dask)
    log(f"{counts['trials']} runs in {time.perf_counter() - start:.0f} s")
    rows = [s.summary() for s in searches]
    return StressRun(catalogue, list(variants), skipped, rates, ref_rows, rows, quick, timeout, jobs,
                     time.perf_counter() - start)
