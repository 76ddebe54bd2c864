"""Parameter sweeps: ``validate``'s judgement of one scene, repeated over its parameter space.

A sweep varies one or more parameters of one scene, on a grid (``KEY=lo:hi:n``, n values from lo
to hi inclusive, evenly spaced; ``KEY=lo:hi:n:log`` log-spaced) or at random (``KEY=lo:hi``,
uniform; ``KEY=lo:hi:log`` log-uniform; ``samples`` draws from NumPy's ``default_rng(seed)``, so a
seed gives the same points everywhere). ``KEY`` is a parameter of the scene (``harness scenes``),
or one component of a vector parameter as ``KEY[i]`` (i = 0, 1, 2; the others keep their value).
The two ends of every range must be values the scene accepts (its parameter kind: positive,
non-negative, ...): a range the scene refuses is bad input. A point whose system the scene's
builder or physical sanity refuses (``InputError`` while building it, e.g. principal moments that
break the triangle inequality) is recorded as ``refused: <reason>`` for that point, and the sweep
goes on.

Each point is a case of ``harness validate`` (``harness.validate.run``): the in-house DOP853
reference run (``reference_case``), then each engine at the scene's default integrator and step
(``engine_case``), judged by the scene's own ``[checks.*]`` (``check_run``), each check by how its
error converges (``judge_convergence``: the engine rerun at 2x the step, and half where
undecided, or at a 100x looser tolerance); the ``model.*``
checks of the files as written are not repeated (they do not depend on the parameters). Every
run is made in its own worker process with a timeout (``harness.validate.workers.open_workers``:
the local pool, or the workers of a Dask scheduler), so a crash or a timeout is that point's
result. An engine's runs of a point start as soon as that point's reference ends, with the
exact solution its reference case computed (``harness.measure.solution_cache``); a scene whose
``[not_run]`` names the reference engine has no reference run (``has_reference``): its engines
start at once.

A point's result, per engine (``PointResult``), from ``validate``'s verdicts (each check judged
by how its error converges, ``harness.judging.checks.judge_convergence``; ``harness.judging``):

* ``passed``: every check of the run passed (``CheckResult.passed``: its class is converges or a
  declared model difference within its bound, and it meets the scene's requirement if any);
* ``classification``: the worst class over the run's checks, in the order ``CLASS_ORDER``
  (defect > unresolved > not judged > model difference (undeclared) > model difference (declared) >
  converges); a check of a run that ended ok which got no value (e.g. a closed form that does not
  cover the point) counts as ``not judged`` (it fails the point and is named in ``no_value``,
  why in ``message``); "" where the run did not end ok (its ``status`` says how);
* ``failing``: the failing checks, each ``(check, class, reason)`` (the verdict's one line);
* ``error``: the largest dimensionless error at the scene's step, the largest value among the
  checks whose unit is ``rel``, ``rad`` or dimensionless "" (``DIMENSIONLESS``: trajectory errors
  over the motion scales and in rad, drifts over their scales, the closed form's error; not the
  checks in m, m/s or rad/s, such as constraint violations), and ``error_check``, the check that
  sets it: the number the figure plots;
* ``trajectory_error``: the largest ``trajectory.*`` check value against the reference (positions
  and velocities relative to the reference's motion scales, orientation in rad);
* ``energy_drift``: the ``energy_drift`` check value (max |E - E0| over the energy scale), or for
  a forced scene ``energy_balance`` (E - E0 - W over the energy scale);
* ``status``: ``ok`` (the run ended ok; its checks may still fail: ``passed``), the run's own
  status (``blowup``, ``failed``, ``unsupported``), the worker's (``crashed``, ``timeout``,
  ``error``), ``refused: <reason>`` or ``not run`` (the scene's ``[not_run]``).
"""

from __future__ import annotations

import collections
import math
import re
import time
from dataclasses import dataclass, field, replace
from typing import Any, Callable

import numpy as np

from harness.engines import REFERENCE_ENGINE, check_scene
from harness.engines.base import RunSettings, check_settings
from harness.judging.error_model import CONVERGES, DEFECT, MODEL_DIFFERENCE, NOT_JUDGED, UNRESOLVED_CLASS
from harness.io.progress import case_label
from harness.model.errors import InputError
from harness.model.scene import Scene, check_steps, load_scene
from harness.validate.run import REFERENCE_METHOD, engine_case, has_reference, reference_case, save_interval
from harness.validate.workers import Outcome, effective_jobs, open_workers

MAX_POINTS = 10_000  # points of one sweep (each point is 1 + len(engines) runs)
MAX_GRID_KEYS = 2    # a heatmap has two axes; --random takes any number of keys
_KEY = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*)(?:\[(\d+)\])?$")


# ------------------------------------------------------------------------------------ axes
@dataclass(frozen=True)
class Axis:
    """One swept parameter: ``key`` as given (``m`` or ``omega0[2]``), its parameter ``name`` and
    vector ``index`` (None for a scalar), the range ``lo`` < ``hi`` (the parameter's unit), the
    grid size ``n`` (None for a random axis) and ``log`` spacing."""

    key: str
    name: str
    index: int | None
    lo: float
    hi: float
    n: int | None
    log: bool = False
    unit: str = ""

    def grid(self) -> np.ndarray:
        """The grid values (lo and hi included)."""
        if self.log:
            return np.geomspace(self.lo, self.hi, self.n)
        return np.linspace(self.lo, self.hi, self.n)

    def draw(self, rng: np.random.Generator, samples: int) -> np.ndarray:
        """``samples`` values drawn uniformly (log-uniformly with ``log``) in [lo, hi)."""
        if self.log:
            return np.exp(rng.uniform(math.log(self.lo), math.log(self.hi), samples))
        return rng.uniform(self.lo, self.hi, samples)

    def spec(self) -> str:
        """The axis as the command line states it."""
        n = f":{self.n}" if self.n is not None else ""
        return f"{self.key}={self.lo:g}:{self.hi:g}{n}{':log' if self.log else ''}"


def parse_axis(text: str, *, grid: bool) -> Axis:
    """``KEY=lo:hi:n[:log]`` (grid) or ``KEY=lo:hi[:log]`` (random) -> Axis; InputError, naming
    the option, when malformed: no key, not numbers, lo >= hi, n < 2, log with lo <= 0."""
    option = "--grid" if grid else "--random"
    form = "KEY=lo:hi:n[:log]" if grid else "KEY=lo:hi[:log]"
    key, sep, rng = text.partition("=")
    key = key.strip()
    if not sep or not key:
        raise InputError(f"{option} {text!r}: expected {form}")
    m = _KEY.match(key)
    if not m:
        raise InputError(f"{option} {text!r}: {key!r} is not a parameter name (a name, or NAME[i] for a component)")
    parts = [p.strip() for p in rng.split(":")]
    log = bool(parts) and parts[-1].lower() == "log"
    if log:
        parts = parts[:-1]
    if len(parts) != (3 if grid else 2):
        raise InputError(f"{option} {text!r}: expected {form}")
    try:
        lo, hi = float(parts[0]), float(parts[1])
    except ValueError:
        raise InputError(f"{option} {text!r}: lo and hi must be numbers") from None
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise InputError(f"{option} {text!r}: lo and hi must be finite")
    if not lo < hi:
        raise InputError(f"{option} {text!r}: lo must be < hi, got {lo:g} >= {hi:g}")
    if log and lo <= 0:
        raise InputError(f"{option} {text!r}: a log range needs lo > 0")
    n = None
    if grid:
        try:
            n = int(parts[2])
        except ValueError:
            raise InputError(f"{option} {text!r}: n must be a whole number") from None
        if n < 2:
            raise InputError(f"{option} {text!r}: n must be >= 2 (a grid from lo to hi), got {n}")
    return Axis(key, m.group(1), None if m.group(2) is None else int(m.group(2)), lo, hi, n, log)


def check_axes(scene: Scene, axes: list[Axis]) -> list[Axis]:
    """The axes with their units, checked against ``scene``: each key a parameter of it (a
    component index only for a vector, within its length), no key twice, and both ends of each
    range values the scene accepts (its parameter kinds). InputError otherwise."""
    out = []
    seen = set()
    for a in axes:
        if a.name not in scene.parameters:
            known = ", ".join(scene.parameters)
            raise InputError(f"{a.key!r} is not a parameter of scene {scene.name!r} (parameters: {known})")
        p = scene.parameters[a.name]
        vector = isinstance(p.value, tuple)
        if vector and a.index is None:
            raise InputError(f"{a.key!r} is a vector parameter of {scene.name!r}: sweep one component, "
                             f"{a.name}[0] .. {a.name}[{len(p.value) - 1}]")
        if not vector and a.index is not None:
            raise InputError(f"{a.key!r}: {a.name!r} is a scalar parameter of {scene.name!r} (no component)")
        if vector and a.index >= len(p.value):
            raise InputError(f"{a.key!r}: {a.name!r} has components 0 .. {len(p.value) - 1}")
        if (a.name, a.index) in seen:
            raise InputError(f"{a.key!r} is swept twice")
        seen.add((a.name, a.index))
        for end in (a.lo, a.hi):  # the kinds (positive, non-negative, real) are intervals: both ends decide
            overrides = point_overrides(scene, [a], (end,))
            try:
                scene.with_params(**overrides)
            except InputError as err:
                raise InputError(f"{a.spec()}: scene {scene.name!r} refuses {a.key} = {end:g}: {err}") from None
        out.append(replace(a, unit=p.unit))
    return out


def grid_points(axes: list[Axis]) -> list[tuple[float, ...]]:
    """The grid's points, the last axis varying fastest."""
    grids = [a.grid() for a in axes]
    mesh = np.meshgrid(*grids, indexing="ij")
    return [tuple(float(m.flat[i]) for m in mesh) for i in range(mesh[0].size)]


def random_points(axes: list[Axis], samples: int, seed: int) -> list[tuple[float, ...]]:
    """``samples`` points drawn with ``numpy.random.default_rng(seed)``, axis by axis."""
    rng = np.random.default_rng(seed)
    columns = [a.draw(rng, samples) for a in axes]
    return [tuple(float(c[i]) for c in columns) for i in range(samples)]


def point_overrides(scene: Scene, axes: list[Axis], values: tuple[float, ...]) -> dict[str, Any]:
    """The parameter overrides of one point: scalars as given, vector components written into
    the parameter's current value."""
    out: dict[str, Any] = {}
    for a, v in zip(axes, values):
        if a.index is None:
            out[a.name] = float(v)
        else:
            vec = list(out.get(a.name, scene.parameters[a.name].value))
            vec[a.index] = float(v)
            out[a.name] = tuple(vec)
    return out


def with_horizon(scene: Scene, t_end: float | None) -> Scene:
    """``scene`` with horizon ``t_end`` (s; None keeps the scene's); InputError when it is not
    positive, not a whole multiple of the save interval the runs use, or more integration steps
    at the scene's step than ``harness.model.scene.MAX_STEPS`` (``check_steps``)."""
    if t_end is None:
        return scene
    short = replace(scene, t_end=float(t_end))
    save = save_interval(scene)
    try:
        check_settings(RunSettings(short.t_end, save, save, REFERENCE_METHOD), [REFERENCE_METHOD], REFERENCE_ENGINE)
    except InputError as err:
        raise InputError(f"--t-end {t_end:g}: {err}") from None
    check_steps(short.t_end, scene.dt, f"--t-end (at the scene's step dt = {scene.dt:g} s)")
    return short


# ------------------------------------------------------------------------------------ results
DECLARED = f"{MODEL_DIFFERENCE} (declared)"
#: The classes of ``validate``'s verdicts (``CheckResult.classification``), best first: a point's
#: class is the last of these that one of its checks has.
CLASS_ORDER = (CONVERGES, DECLARED, MODEL_DIFFERENCE, NOT_JUDGED, UNRESOLVED_CLASS, DEFECT)
#: The units of the checks whose values make a point's ``error`` (dimensionless: over a scale, or an angle).
DIMENSIONLESS = ("rel", "rad", "")


def class_rank(cls: str) -> int:
    """The place of a class in ``CLASS_ORDER`` (higher is worse); -1 for "" (no class)."""
    return CLASS_ORDER.index(cls) if cls in CLASS_ORDER else -1


def worst_class(classes) -> str:
    """The worst of ``classes`` (``CLASS_ORDER``), "" when there is none."""
    return max(classes, key=class_rank, default="")


@dataclass(frozen=True)
class PointResult:
    """One engine at one point (see the module docstring). ``values``: the swept values in axis
    order; ``reference``: how the point's reference run ended; ``wall_s``: the engine run's wall
    time (s); ``failing``: ``(check, class, reason)`` of each failing check."""

    point: int
    values: tuple[float, ...]
    engine: str
    integrator: str
    status: str
    passed: bool
    classification: str
    error: float
    error_check: str
    failed_checks: int
    checks: int
    trajectory_error: float
    energy_drift: float
    reference: str
    wall_s: float
    message: str = ""
    no_value: tuple[str, ...] = ()  # checks of a run that ended ok which got no value (failed, "not judged")
    failing: tuple[tuple[str, str, str], ...] = ()

    @property
    def refused(self) -> bool:
        return self.status.startswith("refused")

    @property
    def failing_class(self) -> str:
        """The worst class among the failing checks ("" when none fails, or the run did not end
        ok): what the figure marks a failing point with."""
        return worst_class(cls for _, cls, _ in self.failing)


@dataclass
class SweepRun:
    """A sweep: what was asked and one ``PointResult`` per point x engine (point order, then
    engine order)."""

    scene: str
    mode: str  # "grid" or "random"
    axes: list[Axis]
    points: list[tuple[float, ...]]
    engines: list[str]
    t_end: float
    seed: int | None = None
    jobs: int = 1
    timeout: float = 300.0
    dask: str | None = None
    rows: list[PointResult] = field(default_factory=list)
    wall_s: float = 0.0

    def of(self, engine: str) -> list[PointResult]:
        return [r for r in self.rows if r.engine == engine]


def _unrun(point: int, values: tuple, engine: str, integrator: str, status: str, reference: str, wall_s: float,
           message: str, failed: int = 0) -> PointResult:
    """The result of a run that did not end ok (or was refused, or is not run): no class, no error."""
    nan = float("nan")
    failing = (("run", "", " ".join(message.split())),) if failed else ()
    return PointResult(point, values, engine, integrator, status, False, "", nan, "", failed, failed, nan, nan,
                       reference, wall_s, message, failing=failing)


def summarize(point: int, values: tuple, engine: str, integrator: str, outcome: Outcome, reference: str) -> PointResult:
    """The ``PointResult`` of one engine case's outcome (``engine_case``'s value when ok:
    ``(trajectory, record, checks, second level)``)."""
    nan = float("nan")
    if outcome.status == "input_error":
        return _unrun(point, values, engine, integrator, f"refused: {outcome.message}", reference, outcome.wall_s,
                      outcome.message)
    if outcome.status != "ok":
        return _unrun(point, values, engine, integrator, outcome.status, reference, outcome.wall_s,
                      outcome.message, failed=1)
    record, checks = outcome.value[1], outcome.value[2]
    if record.status != "ok":  # the run's own failure: its only check is a failed "run"
        return _unrun(point, values, engine, record.integrator, record.status, reference, record.wall_s,
                      record.message, failed=1)
    no_value = [c for c in checks if not math.isfinite(c.value)]
    classes = [c.classification or (NOT_JUDGED if not math.isfinite(c.value) else "") for c in checks]
    failing = tuple((c.check, cls or NOT_JUDGED, " ".join((c.judged or c.detail or "failed").split()))
                    for c, cls in zip(checks, classes) if not c.passed)
    sized = [c for c in checks if c.unit in DIMENSIONLESS and math.isfinite(c.value)]
    largest = max(sized, key=lambda c: c.value, default=None)
    traj = [c.value for c in checks if c.check.startswith("trajectory.")]
    energy = [c.value for c in checks if c.check in ("energy_drift", "energy_balance")]
    message = "; ".join(f"{c.check}: no value ({' '.join(c.detail.split())})" for c in no_value) or record.message
    return PointResult(point, values, engine, record.integrator, record.status, bool(checks) and not failing,
                       worst_class(classes), largest.value if largest else nan, largest.check if largest else "",
                       len(failing), len(checks), max(traj) if traj else nan, energy[0] if energy else nan, reference,
                       record.wall_s, message, tuple(c.check for c in no_value), failing)


def _reference_status(outcome: Outcome | None) -> str:
    if outcome is None:  # the scene has no reference run (validate's has_reference)
        return "not run"
    if outcome.status == "input_error":
        return f"refused: {outcome.message}"
    if outcome.status != "ok":
        return outcome.status
    return outcome.value[1].status


def run_sweep(scene: Scene, axes: list[Axis], points: list[tuple[float, ...]], engines: list[str], *,
              mode: str = "grid", seed: int | None = None, jobs: int | None = None, timeout: float = 300.0,
              dask: str | None = None, progress=None, log: Callable[[str], None] | None = None) -> SweepRun:
    """Run ``scene`` (its horizon already set) at every point on ``engines``. ``progress``: a bar
    ticked once per finished run (a point's reference and each engine), or None; ``log``: a
    function given one line per point as its last run ends, or None."""
    t0 = time.perf_counter()
    run = SweepRun(scene.name, mode, list(axes), list(points), list(engines), scene.t_end, seed,
                   effective_jobs(jobs), timeout, dask)
    scenes: dict[int, Scene] = {}
    results: dict[tuple[int, str], PointResult] = {}

    def tick(n: int = 1, label: str = "") -> None:
        done = getattr(progress, "done", None)
        if done is not None:  # a bar of harness.io.progress: one line per finished run where none is drawn
            done(label, n)
        elif progress is not None:
            progress.update(n)

    def where(i: int) -> str:
        return f"{scene.name} [{i + 1}/{len(points)}] " + ", ".join(f"{a.key}={v:.4g}" for a, v in zip(axes, points[i]))

    runnable = [e for e in engines if e not in scene.not_run]
    for i, values in enumerate(points):
        for e in engines:
            if e in scene.not_run:
                results[(i, e)] = _unrun(i, values, e, "", "not run", "", 0.0, scene.not_run[e])
        try:
            s = scene.with_params(**point_overrides(scene, axes, values))
            s.multibody()  # the builder and the physical sanity checks, here: a refused point starts no worker
        except InputError as err:
            why = _reason(scene, err)
            for e in runnable:
                results[(i, e)] = _unrun(i, values, e, scene.integrators.get(e, ""), f"refused: {why}",
                                         f"refused: {why}", 0.0, why)
            tick(1 + len(runnable), f"{where(i)} refused: {why}")
            continue
        scenes[i] = s

    pending = collections.deque()
    for i in scenes:  # a scene without a reference run (validate's has_reference): its engines at once
        pending.extend([("reference", i)] if has_reference(scenes[i]) else [(e, i) for e in runnable])
    refs: dict[int, Outcome | None] = {i: None for i in scenes if not has_reference(scenes[i])}
    left: dict[int, int] = {i: len(runnable) for i in refs}
    with open_workers(jobs, dask) as workers:
        while pending or len(workers):
            while pending and workers.free():
                kind, i = key = pending.popleft()
                if kind == "reference":
                    workers.start(key, reference_case, (scenes[i],), timeout)
                else:
                    ref = refs[i]
                    traj, solutions = (ref.value[0], ref.value[3]) if ref is not None and ref.status == "ok" else (None, None)
                    workers.start(key, engine_case, (scenes[i], kind, traj, True, solutions), timeout)
            for key, outcome in workers.wait():
                kind, i = key
                tick(1, f"{where(i)} {case_label(kind, outcome)}")
                if kind == "reference" and outcome.status == "input_error":  # the point is refused: no engine runs it
                    why = _reason(scene, outcome.message)
                    for e in runnable:
                        results[(i, e)] = _unrun(i, points[i], e, scenes[i].integrators.get(e, ""),
                                                 f"refused: {why}", f"refused: {why}", 0.0, why)
                    tick(len(runnable), f"{where(i)} refused: {why}")
                    continue
                if kind == "reference":
                    refs[i] = outcome
                    left[i] = len(runnable)
                    pending.extendleft(reversed([(e, i) for e in runnable]))  # this point's engines next
                    if not runnable:
                        refs.pop(i)
                    continue
                results[(i, kind)] = summarize(i, points[i], kind, scenes[i].integrators.get(kind, ""), outcome,
                                               _reference_status(refs[i]))
                left[i] -= 1
                if left[i] == 0:
                    refs.pop(i)  # its trajectory is no longer needed
                    if log is not None:
                        log(point_line(run, i, [results[(i, e)] for e in engines]))
    run.rows = [results[(i, e)] for i in range(len(points)) for e in engines]
    run.wall_s = time.perf_counter() - t0
    return run


def _reason(scene: Scene, err) -> str:
    """An InputError's message on one line, without the scene.toml path it may start with."""
    text = " ".join(str(err).split())
    return text.removeprefix(f"{scene.directory / 'scene.toml'}: ")


def point_line(run: SweepRun, i: int, rows: list[PointResult]) -> str:
    """One line per finished point: its values and each engine's largest error, worst class and
    failing checks, or status."""
    where = ", ".join(f"{a.key}={v:.4g}" for a, v in zip(run.axes, run.points[i]))
    cells = []
    for r in rows:
        if r.status == "ok":
            fails = f", FAIL {', '.join(c for c, _, _ in r.failing)}" if r.failing else ""
            cells.append(f"{r.engine} {r.error:.2g} ({r.error_check}), {r.classification or '-'}{fails}")
        else:
            cells.append(f"{r.engine} {r.status.split(':')[0]}")
    return f"sweep {run.scene} [{i + 1}/{len(run.points)}] {where}: " + "; ".join(cells)


def load_for_sweep(name: str, models_dir=None) -> Scene:
    """The scene at its defaults; InputError when it is unknown or declares no checks."""
    scene = check_scene(load_scene(name, models_dir=models_dir))
    if not scene.checks:
        raise InputError(f"{scene.directory / 'scene.toml'}: declares no [checks.<name>] table: a sweep would judge nothing")
    return scene
