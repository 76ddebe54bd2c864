"""Validation of scenes: run every engine, compare, check each quantity against its tolerance.

For each scene: an in-house reference run (DOP853, rtol = atol = 1e-12) is made first; then
each engine runs at the scene's default integrator and step. Checks (those the scene declares
in ``[checks.*]`` of its ``scene.toml``):

* ``energy_drift`` (unforced) or ``energy_balance`` (forced: E - E0 - work of the forces);
* ``momentum_drift.<c>`` for each conserved component the scene lists;
* ``trajectory.position/orientation/velocity/angular_velocity`` against the reference;
* ``constraint.position/axis``, joint violations from maximal coordinates;
* ``exact``: against the scene's closed-form solution (``harness.exact``);
* ``engine_energy``: the engine's own energy against the harness's recomputation.

The reference run is itself checked (engine ``reference``) for conservation and against the
exact solution before it judges anything. A run that crashes or blows up is recorded as a
failed check with its reason; the other engines' results are kept.
"""

from __future__ import annotations

import time
import traceback
from dataclasses import asdict, dataclass, field

import numpy as np

from harness import compare, exact
from harness.engines import get_engine
from harness.engines.base import RunSettings
from harness.scene import Scene
from harness.trajectory import Trajectory, failed

REFERENCE_METHOD = "DOP853"
REFERENCE_TOL = 1e-12
ENGINE_ENERGY_TOL = 1e-9  # relative; a larger mismatch means the engine's mass model differs


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


@dataclass(frozen=True)
class RunRecord:
    """How one run was made and how it ended."""

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


@dataclass
class SceneValidation:
    """Everything validation produced for one scene."""

    scene: str
    parameters: dict
    checks: list[CheckResult] = field(default_factory=list)
    runs: list[RunRecord] = field(default_factory=list)
    cross: dict[str, dict[str, float]] = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)


def reference_settings(scene: Scene) -> RunSettings:
    """The in-house high-accuracy run that judges the engines' trajectories."""
    return RunSettings(scene.t_end, scene.save_every, scene.save_every, REFERENCE_METHOD, rtol=REFERENCE_TOL, atol=REFERENCE_TOL)


def default_settings(scene: Scene, engine: str) -> RunSettings:
    return RunSettings(scene.t_end, scene.dt, scene.save_every, scene.integrators[engine])


def run_engine(scene: Scene, engine: str, settings: RunSettings) -> Trajectory:
    """Run one engine; an exception inside the engine becomes a ``failed`` trajectory."""
    from harness.errors import InputError

    try:
        return get_engine(engine).simulate(scene, settings)
    except InputError:
        raise
    except Exception as err:  # a crash in one engine must not take the others down
        last = traceback.extract_tb(err.__traceback__)[-1]
        return failed(engine, settings.integrator, scene.multibody().body_names, "failed",
                      f"{type(err).__name__}: {err} ({last.filename.rsplit('/', 1)[-1]}:{last.lineno})")


def validate_scene(scene: Scene, engines: list[str]) -> SceneValidation:
    """Run and check ``scene`` on ``engines``; see the module docstring."""
    model = scene.multibody()
    result = SceneValidation(scene=scene.name, parameters={k: _jsonable(v) for k, v in scene.params.items()})
    ref_settings = reference_settings(scene)
    t0 = time.perf_counter()
    ref = run_engine(scene, "inhouse", ref_settings)
    result.runs.append(_record(scene, "reference", ref_settings, ref, time.perf_counter() - t0))
    _check_run(scene, model, "reference", "inhouse", ref, None, ref_settings, result)

    trajectories = {}
    for engine in engines:
        settings = default_settings(scene, engine)
        t0 = time.perf_counter()
        traj = run_engine(scene, engine, settings)
        result.runs.append(_record(scene, engine, settings, traj, time.perf_counter() - t0))
        trajectories[engine] = traj
        _check_run(scene, model, engine, engine, traj, ref, settings, result)

    names = list(trajectories)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            if trajectories[a].ok and trajectories[b].ok:
                result.cross[f"{a} vs {b}"] = compare.trajectory_error(trajectories[a], trajectories[b])
    return result


def _check_run(scene, model, label, engine, traj, ref, settings, result: SceneValidation) -> None:
    """Append the checks of one run to ``result``; ``label`` names it in the report."""
    checks = scene.checks
    tol_key = engine

    def add(check, value, tol, unit, detail=""):
        ok = bool(np.isfinite(value) and value <= tol)
        result.checks.append(CheckResult(scene.name, label, check, float(value), float(tol), unit, ok, detail))

    if not traj.ok:
        result.checks.append(CheckResult(scene.name, label, "run", float("nan"), 0.0, "", False,
                                         f"{traj.status}: {traj.message}"))
        return
    forced = bool(model.forces)
    if "energy_drift" in checks:
        tol = checks["energy_drift"][tol_key]
        if forced:
            balance, quad = compare.energy_balance(traj, model)
            add("energy_balance", balance, tol, "rel", f"E - E0 - W(t) over the energy scale; quadrature error of W ~{quad:.1e}")
        else:
            add("energy_drift", compare.energy_drift(traj, model), tol, "rel", "max |E - E0| / energy scale")
    if "momentum_drift" in checks:
        spec = checks["momentum_drift"]
        for comp, value in compare.momentum_drift(traj, model, spec["components"]).items():
            add(f"momentum_drift.{comp}", value, spec[tol_key], "rel", "max |c - c0| / momentum scale")
    if "trajectory" in checks and ref is not None:
        if not ref.ok:
            result.checks.append(CheckResult(scene.name, label, "trajectory", float("nan"), 0.0, "", False,
                                             f"reference run {ref.status}: {ref.message}"))
        else:
            err = compare.trajectory_error(traj, ref)
            tol = checks["trajectory"]
            add("trajectory.position", err["position_max"], tol["position"], "m", "max over bodies and samples")
            add("trajectory.orientation", err["orientation_max"], tol["orientation"], "rad", "geodesic angle on SO(3)")
            add("trajectory.velocity", err["velocity_max"], tol["velocity"], "m/s", "centre-of-mass velocity")
            add("trajectory.angular_velocity", err["angular_velocity_max"], tol["velocity"], "rad/s", "world frame")
    if "constraint" in checks:
        viol = compare.constraint_violation(traj, model)
        tol = checks["constraint"][tol_key]
        add("constraint.position", viol["position"], tol, "m", "joint points coincide")
        if any(b.joint == "hinge" for b in model.bodies):
            add("constraint.axis", viol["axis"], tol, "rad", "hinge axes stay aligned")
    if "exact" in checks:
        tol = checks["exact"][tol_key]
        try:
            value, unit, detail = exact.exact_error(scene, engine, traj, settings)
        except Exception as err:  # a failing modal run etc. is a failed check, not a crash
            value, unit, detail = float("nan"), "", f"{type(err).__name__}: {err}"
        add("exact", value, tol, unit, detail)
    mismatch = compare.engine_energy_mismatch(traj, model)
    if mismatch is not None:
        add("engine_energy", mismatch, ENGINE_ENERGY_TOL, "rel", "engine's own energy vs harness recomputation")


def _record(scene, engine, settings, traj, wall) -> RunRecord:
    return RunRecord(scene.name, engine, settings.integrator, settings.dt,
                     settings.rtol if settings.integrator[0].isupper() and engine in ("inhouse", "reference") else None,
                     settings.t_end, traj.status, traj.message, wall, float(traj.stats.get("steps", float("nan"))))


def _jsonable(value):
    return list(value) if isinstance(value, tuple) else value


def as_dict(v: SceneValidation) -> dict:
    return {
        "scene": v.scene,
        "passed": v.passed,
        "parameters": v.parameters,
        "runs": [asdict(r) for r in v.runs],
        "checks": [asdict(c) for c in v.checks],
        "cross_engine": v.cross,
    }
