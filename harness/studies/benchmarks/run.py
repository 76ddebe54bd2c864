"""Published benchmarks against the engines: per problem and engine, the published figure, ours,
the agreement in digits, the class of the engine's convergence, and the run time to reach the
problem's required accuracy (the figure of merit of the IFToMM benchmark library).

A problem is a scene whose reference module (``harness.references.<scene>``) states
``BENCHMARK``: ``problem`` (e.g. "IFToMM A01"), ``title``, ``published`` (what the publication
gives, one sentence) and ``required`` (the required accuracy as a state error relative to the
scene's scales, ``harness.judging.quantities``), and optionally ``published_digits(scene)`` (the
reference's correct digits of the published figure). ``benchmark_study`` runs, on those scenes:

* ``harness.validate.run.validate``: each engine's default integrator at the scene's step, its
  ``exact`` error (against the scene's closed form or verified reference, in the check's unit)
  and the class of its convergence (``harness.judging.error_model``); the agreement in digits is
  ``-log10(exact / scale)``, the scale the reference run's length (m) for an error in m, 1 for rad;
  where the scene has no ``exact`` check, the class is its dominant check's
  (``harness.validate.report.dominant_check``);
* for a problem whose published figures are a linearisation (the reference states
  ``linearization_agreement(scene, matrix)``; the scene's builder its ``Coordinates(model, v)``),
  each engine that gives its accelerations (``harness.engines.with_accelerations``) linearised
  about the reference motion at speed v (``harness.engines.linearization``): the error and digits
  are its coefficients' against the published ones, and the detail its stability speeds;
* ``harness.studies.workprecision.run.run_sweep``: every curve of every engine; the time (s, the
  median of repeated runs on this machine, ``WorkPrecisionPoint.time_s``) to reach ``required``
  on the curve's lower envelope (``time_to_error`` of the largest state error over the saved
  samples), the fastest curve of each engine kept, and its ratio to the baseline engine's
  (``workprecision.run.BASELINE``, whose ``rollout`` it is measured through).

Nothing here writes a file.
"""

from __future__ import annotations

import importlib
import math
from dataclasses import dataclass, field

from harness.engines import with_accelerations
from harness.engines.linearization import linearize
from harness.measure import exact
from harness.model.scene import Scene, available_scenes
from harness.studies.workprecision.run import BASELINE, SweepOptions, by_curve, run_sweep, time_to_error
from harness.validate.report import dominant_check
from harness.validate.run import validate


@dataclass
class EngineResult:
    """One engine on one problem.

    Attributes:
        engine: the registered name; integrator: its default on the scene (validate's run).
        exact: its ``exact`` error at the scene's step (``unit``), NaN where not run.
        digits: agreement in significant digits, ``-log10(exact / scale)``.
        classification: the class of its ``exact`` check (``harness.judging.error_model``);
            passed: whether validate's verdict on it holds; check: the check they come from
            (``exact``, the linearisation's ``coefficients``, else the dominant check).
        detail: what else the figure says (a linearisation's stability speeds).
        time_s: run time (s) of its fastest curve to reach the problem's required accuracy
            (NaN: not reached); curve: that curve's label; ratio: ``time_s`` over the baseline's.
        step_wall_s: wall time (s) of validate's run at the scene's step with its default
            integrator (one run, in the same validate run as the baseline's; NaN where that run
            did not end ok); step_ratio: over the baseline's. For a problem whose runs are too
            long for the work-precision sweep's point budget (A02: 20 s of 81 bodies) it is the
            time of a run that meets the required accuracy where ``exact`` does.
    """

    engine: str
    integrator: str = ""
    exact: float = float("nan")
    unit: str = ""
    digits: float = float("nan")
    classification: str = ""
    passed: bool = False
    check: str = ""
    detail: str = ""
    time_s: float = float("nan")
    curve: str = ""
    ratio: float = float("nan")
    step_wall_s: float = float("nan")
    step_ratio: float = float("nan")


@dataclass
class ProblemResult:
    """One benchmark problem: its scene, what is published (``BENCHMARK``), the reference's
    correct digits of the published figure (None where the publication gives no number to
    compare), one ``EngineResult`` per engine that runs it, and the engines that do not, why."""

    scene: str
    problem: str
    title: str
    published: str
    required: float
    published_digits: float | None
    engines: list[EngineResult] = field(default_factory=list)
    not_run: dict[str, str] = field(default_factory=dict)
    #: for a problem published as a linearisation: its eigenvalues (1/s, complex) against speed,
    #: ``{"speeds": (n,), "published": (n, 4), <engine>: (n, 4)}`` (``EIGEN_SPEEDS``), and the
    #: published ones on a fine grid for the figure (``fine_speeds``, ``fine_published``)
    eigenvalues: dict = field(default_factory=dict)


def benchmark_scenes(models_dir=None) -> list[str]:
    """The scenes whose reference module states a ``BENCHMARK``, in name order."""
    out = []
    for name in available_scenes(models_dir):
        module = exact.reference_module(name)
        if module is not None and hasattr(module, "BENCHMARK"):
            out.append(name)
    return out


#: The speeds (m/s) of the eigenvalue-against-speed figure of a problem published as a
#: linearisation (Table 2's range for the bicycle).
EIGEN_SPEEDS = tuple(0.5 * k for k in range(21))


def _coordinates(scene: Scene):
    """The ``Coordinates(model, v)`` class of the scene's builder (a problem published as a
    linearisation: module docstring)."""
    return importlib.import_module(f"harness.model.builders.{scene.builder or scene.name}").Coordinates


def _eigenvalue_curves(problem: ProblemResult, scene: Scene, module, engines) -> None:
    """The published eigenvalues at ``EIGEN_SPEEDS`` and each linearising engine's."""
    coordinates, model = _coordinates(scene), scene.multibody()
    fine = [0.025 * k for k in range(int(round(EIGEN_SPEEDS[-1] / 0.025)) + 1)]
    problem.eigenvalues = {"speeds": list(EIGEN_SPEEDS), "published": module.published_eigenvalues(scene, EIGEN_SPEEDS),
                           "fine_speeds": fine, "fine_published": module.published_eigenvalues(scene, fine)}
    for engine in engines:
        if engine in with_accelerations() and engine not in problem.not_run:
            problem.eigenvalues[engine] = [linearize(engine, scene, coordinates(model, v)).eigenvalues for v in EIGEN_SPEEDS]


def _linearized(row: EngineResult, scene: Scene, module) -> None:
    """Fill ``row``'s error and digits from its engine's linearisation against the published one
    (module docstring); an engine that gives no accelerations keeps NaN and says so."""
    if row.engine not in with_accelerations():
        row.detail = "not linearised: the engine gives no accelerations at a state"
        return
    coordinates, model = _coordinates(scene), scene.multibody()
    got = module.linearization_agreement(scene, lambda v: linearize(row.engine, scene, coordinates(model, v)).A)
    row.exact, row.unit, row.digits = got["error"], "rel", got["digits"]
    row.detail = (f"weave {got['weave']:.12g} m/s, capsize {got['capsize']:.12g} m/s "
                  f"({got['speed_error']:.1e} m/s from the published)")


def _digits(value: float, unit: str, scales: dict) -> float:
    scale = scales.get("length", 1.0) if unit == "m" else 1.0
    if not (math.isfinite(value) and value >= 0.0):
        return float("nan")
    return float("inf") if value == 0.0 else -math.log10(value / scale)


def benchmark_study(scenes: list[Scene], engines: list[str], options: SweepOptions = SweepOptions(), *,
                    jobs: int | None = None, progress=None) -> list[ProblemResult]:
    """Run the study on ``scenes`` (each with a ``BENCHMARK``) and ``engines`` (module docstring);
    the problems in the order of their names."""
    validations = {v.scene: v for v in validate(scenes, engines, jobs=jobs, progress=progress)}
    sweeps = {s.scene: s for s in run_sweep(scenes, engines, options)}
    results = []
    for scene in scenes:
        module = exact.reference_module(scene.name)
        bench = module.BENCHMARK
        digits = getattr(module, "published_digits", None)
        v, sweep = validations[scene.name], sweeps[scene.name]
        problem = ProblemResult(scene.name, bench["problem"], bench["title"], bench["published"], float(bench["required"]),
                                digits(scene) if digits else None, not_run=dict(v.not_run))
        fastest: dict[str, tuple[float, str]] = {}
        for label, points in by_curve(sweep.points).items():
            t = time_to_error(points, problem.required)
            engine = points[0].engine
            if math.isfinite(t) and t < fastest.get(engine, (math.inf, ""))[0]:
                fastest[engine] = (t, label)
        base = fastest.get(BASELINE, (float("nan"), ""))[0]
        runs = {r.engine: r for r in v.runs}
        step_wall = {r.engine: r.wall_s for r in v.runs
                     if r.status == "ok" and math.isclose(r.dt, scene.dt, rel_tol=1e-9)}
        base_step = step_wall.get(BASELINE, float("nan"))
        for engine in engines:
            if engine in v.not_run:
                continue
            mine = [c for c in v.checks if c.engine == engine and not c.check.startswith("model.")]
            check = next((c for c in mine if c.check == "exact"), None)
            row = EngineResult(engine, runs[engine].integrator if engine in runs else "")
            if check is not None:
                row.exact, row.unit, row.digits = check.value, check.unit, _digits(check.value, check.unit, v.scales)
            elif mine:
                check = dominant_check(mine)
            if check is not None:
                row.classification, row.check = check.classification, check.check
                row.passed = all(c.passed for c in mine)
            if hasattr(module, "linearization_agreement"):
                _linearized(row, scene, module)
            row.step_wall_s = step_wall.get(engine, float("nan"))
            row.step_ratio = row.step_wall_s / base_step if base_step > 0 else float("nan")
            if engine in fastest:
                row.time_s, row.curve = fastest[engine]
                row.ratio = row.time_s / base if math.isfinite(base) and base > 0 else float("nan")
            problem.engines.append(row)
        if hasattr(module, "published_eigenvalues"):
            _eigenvalue_curves(problem, scene, module, engines)
        results.append(problem)
    return sorted(results, key=lambda p: p.problem)
