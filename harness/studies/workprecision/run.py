"""Work-precision sweeps: error against run time for every scene, engine and integrator.

Vocabulary as DiffEqDevTools.jl: a reference solution judges every run; errors are ``final``
(at the horizon) and ``max`` (the L-infinity norm over the saved steps); timing is one warm-up
run, then the median (and the minimum) of repeated runs; a run that fails or blows up is a
recorded point with its reason (errors NaN), never an exception.

What is swept, per scene (``curves``):

* MuJoCo: each integrator (Euler, implicit, implicitfast, RK4) over timesteps, twice: through
  ``mujoco.rollout`` (variant ``rollout``: the time inside the C rollout; the conversion to
  maximal coordinates is in ``time_total_s``) and through the harness's stepping loop
  ``MujocoEngine.simulate`` (variant ``loop``: the loop's own time, which includes reading every
  saved sample back; ``time_total_s`` includes compiling the model).
* Pinocchio: each harness integrator (rkmk4, euler) over timesteps (loop time).
* Drake: RK3, RK5 and Radau3 with Drake's error control over target accuracies (as the in-house
  SciPy methods over tolerances), RK3_fixed and RK2 over timesteps, through
  ``DrakeEngine.simulate`` (the engine's whole run: parsing the URDF, building the plant,
  integrating, reading every sample); the rolling disk is not run on Drake (unsupported).
* Exudyn: GeneralizedAlpha and TrapezoidalIndex2 (implicit, every scene) and RK44, RK67
  (explicit, free bodies only) over timesteps, through ``ExudynEngine.simulate`` (the engine's
  whole run: building the Exudyn system, solving, reading the sensors).
* In-house, all through ``InhouseEngine.simulate``: the per-state methods (variant
  ``per-state``; the engine's whole run): rk4, euler over timesteps and SciPy's RK45, DOP853
  over tolerances; and the compiled ones (variant ``compiled``; the integration alone, the
  kernel compiled before the clock starts; ``time_total_s`` adds building the model and
  converting the result): rk4_compiled over timesteps, dop853_compiled over tolerances.

Every curve except MuJoCo's ``rollout`` variant runs through its engine's ``simulate`` (the
registry's ``get_engine``); whether a method is adaptive and its nominal order come from the
engine's ``Integrator`` records (``harness.engines.integrator``).

Timesteps are ``dt = save / 2^k``; tolerances ``rtol = atol`` per decade. A curve is refined
until a run takes longer than ``max_run_s``, or its state error is below ``error_floor``
(the reference's own accuracy), or the ladder ends. A method that does not model the scene (its
run comes back with status ``"unsupported"``, e.g. the compiled in-house integrators on the
rolling disk, or ``mujoco.rollout`` with a prescribed force) is skipped on that scene after its
first run: no points, its reason in ``SceneSweep.skipped``, and the report says so.

Error measures (one definition, used everywhere; ``errors``)
------------------------------------------------------------
Against the reference trajectory at the saved times, with the reference's scales
(``compare.motion_scales``: length L, velocity V, angular velocity Omega; ``compare.energy_scale``
E; ``compare.momentum_scales`` p and Lm):

* state error at a sample = max over bodies of max( |dp_WCm_W| / L, geodesic angle of
  quat_WB^-1 quat_ref (rad), |dv_WCm_W| / V, |dw_WB_W| / Omega ): the largest of the trajectory
  quantities of ``harness.measure.quantities`` (``state_error``), as validate judges its
  ``trajectory.*`` checks and the stress study its bands;
* energy error = |E - E_ref| / E (the harness's energy recomputed from the common state);
* momentum error = max( |p_W - p_ref| / p, |L_W - L_ref| / Lm ) (linear and angular momentum
  about the world origin, world frame);

each reported at the final time (``*_final``) and as the max over the saved samples (``*_max``).

Reference: the per-state in-house DOP853 at rtol = atol = 1e-13 with steps capped at a tenth of
the save interval (``reference``); where the scene's reference module has an exact check that
needs no runs of its own, the reference's own error against it is reported
(``harness.measure.exact``).

Observed order of convergence (``observed_order``): least-squares slope of log(state error max)
against log(dt) over the asymptotic range (the four smallest timesteps whose errors lie between
``100 x error_floor`` and 1e-2; at least three points), to compare with the method's nominal
order; for adaptive methods the slope against log(tolerance) (nominal 1: tolerance
proportionality) and the effective order -slope against log(accepted steps), over all points in
that error range.
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass, field, replace
from typing import Callable

import numpy as np

from harness.measure import compare
from harness.measure import invariants
from harness.measure import quantities
from harness.engines import get_engine, integrator
from harness.engines.base import RunSettings
from harness.model.scene import Scene
from harness.measure.trajectory import UNSUPPORTED, Trajectory

TARGETS = (1e-6, 1e-10)
ERROR_KEYS = ("state_final", "state_max", "energy_final", "energy_max", "momentum_final", "momentum_max")


@dataclass(frozen=True)
class SweepOptions:
    """How a sweep is run.

    Attributes:
        repeats: timed runs after the warm-up (median and minimum are reported).
        slow_run_s: a run whose warm-up took longer than this is timed once more only.
        max_run_s: stop refining a curve after a run this slow (s).
        saves: number of saved intervals over the horizon (errors are measured there).
        dt_levels: timesteps ``save / 2^k`` for k = 0 .. dt_levels - 1.
        tolerances: rtol = atol values of the adaptive methods.
        error_floor: stop refining once the state error is below this (reference accuracy).
        horizon: the scene's t_end when None.
        batch: initial conditions of the batched-throughput benchmark (0: skip it).
        batch_steps: steps of each trajectory in that benchmark.
        progress: draw the progress bar on stderr (only ever when stderr is a terminal).
    """

    repeats: int = 3
    slow_run_s: float = 0.25
    max_run_s: float = 2.0
    saves: int = 20
    dt_levels: int = 16
    tolerances: tuple[float, ...] = tuple(10.0 ** -k for k in range(3, 14))
    error_floor: float = 1e-12
    horizon: float | None = None
    batch: int = 1000
    batch_steps: int = 100
    progress: bool = True


QUICK = SweepOptions(repeats=1, slow_run_s=0.05, max_run_s=0.05, saves=5, dt_levels=7,
                     tolerances=(1e-4, 1e-6, 1e-8), horizon=None, batch=16, batch_steps=5)


@dataclass(frozen=True)
class Curve:
    """One engine/integrator combination swept over timesteps or tolerances."""

    engine: str
    integrator: str
    variant: str

    @property
    def adaptive(self) -> bool:
        return integrator(self.engine, self.integrator).adaptive

    @property
    def nominal_order(self) -> int:
        return integrator(self.engine, self.integrator).order

    @property
    def label(self) -> str:
        return f"{self.engine} {self.integrator}" + (f" ({self.variant})" if self.variant else "")


@dataclass(frozen=True)
class WorkPrecisionPoint:
    """One run of a sweep.

    Attributes:
        scene, engine, integrator, variant: what ran (``label`` joins them).
        param: the timestep dt (s) of a fixed-step method, or rtol (= atol) of an adaptive one.
        status, message: "ok", "failed", "blowup" or "unsupported" (the method does not model
            the scene) and why.
        time_s, time_min_s: median and minimum run time (s) over the timed repeats (see the
            module docstring for what each variant's time covers).
        time_total_s: median time including model loading and conversion (s).
        repeats: timed repeats after the warm-up.
        steps, rhs_evals: accepted steps and right-hand-side (dynamics) evaluations per
            trajectory (MuJoCo: 4 per RK4 step, 1 otherwise; Pinocchio rkmk4: 4 ``aba`` per step),
            NaN where the engine does not say.
        state_final ... momentum_max: errors (see the module docstring), NaN for a failed run.
        nominal_order: the method's order.
    """

    scene: str
    engine: str
    integrator: str
    variant: str
    param: float
    status: str
    message: str
    time_s: float
    time_min_s: float
    time_total_s: float
    repeats: int
    steps: float
    rhs_evals: float
    state_final: float
    state_max: float
    energy_final: float
    energy_max: float
    momentum_final: float
    momentum_max: float
    nominal_order: int

    @property
    def label(self) -> str:
        return Curve(self.engine, self.integrator, self.variant).label

    @property
    def ok(self) -> bool:
        return self.status == "ok" and math.isfinite(self.state_max)


@dataclass
class SceneSweep:
    """Everything a sweep produced for one scene."""

    scene: str
    t_end: float
    save_every: float
    reference: str
    reference_checks: dict[str, float] = field(default_factory=dict)
    points: list[WorkPrecisionPoint] = field(default_factory=list)
    skipped: dict[str, str] = field(default_factory=dict)  # curve label -> why it does not run on this scene
    batch: dict | None = None
    head_to_head: list[dict] = field(default_factory=list)


# ---------------------------------------------------------------------------------------------
# Progress bar


class Progress:
    """The sweep's progress on the shared bar (``harness.io.progress.make_bar``): drawn on
    ``stream`` (default stderr) only when it is a terminal and ``enabled``; nothing otherwise.
    ``advance(n, label)`` counts ``n`` more runs of ``total`` and shows ``label``."""

    def __init__(self, total: int, enabled: bool = True, stream=None) -> None:
        from harness.io.progress import make_bar

        self.bar = make_bar(max(1, total), desc="workprecision", unit="run", quiet=not enabled, stream=stream)

    def advance(self, n: int = 1, label: str = "") -> None:
        n = min(n, self.bar.total - self.bar.n)  # the total is an upper bound, never passed
        if label:
            self.bar.set_postfix_str(label[:60], refresh=not n)
        if n > 0:
            self.bar.update(n)

    def close(self) -> None:
        self.bar.close()


# ---------------------------------------------------------------------------------------------
# Errors


def _take(traj: Trajectory, idx) -> Trajectory:
    return replace(traj, t=traj.t[idx], p_WCm_W=traj.p_WCm_W[idx], quat_WB=traj.quat_WB[idx],
                   v_WCm_W=traj.v_WCm_W[idx], w_WB_W=traj.w_WB_W[idx], engine_energy={})


def _state_error(err: dict, scales: dict) -> float:
    """The state error (``quantities.state_error``) of ``compare.trajectory_error``'s maxima over
    ``scales`` (``compare.motion_scales``)."""
    return quantities.state_error(quantities.judged_max(err, scales))


def errors(traj: Trajectory, ref: Trajectory, model) -> dict[str, float]:
    """The error measures of the module docstring (keys ``ERROR_KEYS``); NaN when ``traj``
    did not reach every saved sample of ``ref``."""
    n = len(ref.t)
    if not traj.ok or len(traj.t) < n:
        return {k: float("nan") for k in ERROR_KEYS}
    traj = _take(traj, slice(0, n))
    scales = compare.motion_scales(ref, model)
    out = {
        "state_max": _state_error(compare.trajectory_error(traj, ref), scales),
        "state_final": _state_error(compare.trajectory_error(_take(traj, [n - 1]), _take(ref, [n - 1])), scales),
    }
    e_scale = compare.energy_scale(ref, model)
    de = np.abs(invariants.energies(traj, model)["energy"] - invariants.energies(ref, model)["energy"]) / e_scale
    p_scale, l_scale = compare.momentum_scales(ref, model)
    dp = np.linalg.norm(invariants.linear_momentum(traj, model) - invariants.linear_momentum(ref, model), axis=1) / p_scale
    dl = np.linalg.norm(invariants.angular_momentum(traj, model) - invariants.angular_momentum(ref, model), axis=1) / l_scale
    dm = np.maximum(dp, dl)
    out.update(energy_final=float(de[-1]), energy_max=float(np.max(de)), momentum_final=float(dm[-1]),
               momentum_max=float(np.max(dm)))
    return {k: float(v) if np.isfinite(v) else float("nan") for k, v in out.items()}


# ---------------------------------------------------------------------------------------------
# Reference


def horizon(scene: Scene, options: SweepOptions) -> tuple[float, float]:
    """(t_end, save interval) of a sweep."""
    t_end = options.horizon if options.horizon is not None else scene.t_end
    return t_end, t_end / options.saves


def reference(scene: Scene, t_end: float, save: float) -> tuple[Trajectory, str]:
    """The reference trajectory at the save times and a line saying how it was made."""
    from harness.engines.inhouse import ENGINE

    fine = save / 10.0
    settings = RunSettings(t_end, fine, fine, "DOP853", rtol=1e-13, atol=1e-13)
    traj = ENGINE.simulate(scene, settings)
    if not traj.ok:
        raise RuntimeError(f"reference run {traj.status}: {traj.message}")
    traj = _take(traj, slice(None, None, 10))
    how = (f"in-house per-state engine, SciPy DOP853 rtol = atol = 1e-13, max step {fine:g} s "
           f"({traj.stats.get('steps', '?')} steps)")
    return traj, how


def reference_checks(scene: Scene, ref: Trajectory, t_end: float, save: float) -> dict[str, float]:
    """The reference's own error against the scene's closed form, where its reference module has
    an exact check that needs no runs of its own (``harness.measure.exact.needs_runs``)."""
    from harness.measure import exact

    if not exact.has_exact_error(scene) or exact.needs_runs(scene):
        return {}
    try:
        value, unit, detail = exact.exact_error(scene, ref, RunSettings(t_end, save, save, "DOP853"))
    except Exception as err:  # pragma: no cover - reported, not raised
        return {f"exact ({type(err).__name__})": float("nan")}
    return {f"exact: {detail}": float(value)}


# ---------------------------------------------------------------------------------------------
# Runners: each returns a function run() -> (trajectory, engine time s, total time s, steps,
# rhs_evals); errors come from the warm-up run's trajectory.

Run = Callable[[], tuple[Trajectory, float, float, float, float]]


def _settings(curve: Curve, t_end: float, save: float, param: float) -> RunSettings:
    if curve.adaptive:
        return RunSettings(t_end, save, save, curve.integrator, rtol=param, atol=param)
    return RunSettings(t_end, param, save, curve.integrator)


def _runner(scene: Scene, curve: Curve, settings: RunSettings) -> Run:
    """The timed unit of work of one point (see the module docstring): ``mujoco.rollout`` for
    MuJoCo's ``rollout`` variant, else the engine's ``simulate`` (engine time: its
    ``stats["wall_s"]``)."""
    if curve.engine == "mujoco" and curve.variant == "rollout":
        from harness.engines.mujoco import rollout as mujoco_rollout

        t0 = time.perf_counter()
        rm = mujoco_rollout.prepare(scene, settings.dt, settings.integrator)
        setup = time.perf_counter() - t0
        nstep = settings.n_saves * settings.steps_per_save
        t_save = np.arange(settings.n_saves + 1) * settings.save_every
        init = rm.state0[None]

        def run():
            start = time.perf_counter()
            states = rm.run(init, nstep)[0]
            engine = time.perf_counter() - start
            saved = mujoco_rollout.saved_states(rm.state0, states, settings.steps_per_save)
            traj = rm.trajectory(saved, t_save, settings.integrator)
            evals = float(4 * nstep if settings.integrator == "RK4" else nstep)
            return traj, engine, setup + time.perf_counter() - start, float(nstep), evals

        return run
    engine = get_engine(curve.engine)

    def run():
        start = time.perf_counter()
        traj = engine.simulate(scene, settings)
        total = time.perf_counter() - start
        stats = traj.stats
        steps = float(stats.get("steps", float("nan")))
        evals = stats.get("rhs_evals")
        if evals is None:
            stages = integrator(curve.engine, settings.integrator).stages
            evals = (stages or 1) * steps
        return traj, float(stats.get("wall_s", total)), total, steps, float(evals)

    return run


def measure(scene: Scene, curve: Curve, settings: RunSettings, ref: Trajectory, model,
            options: SweepOptions) -> WorkPrecisionPoint:
    """One point: warm-up run (errors), then timed repeats; a failure is a recorded point."""
    param = settings.rtol if curve.adaptive else settings.dt
    base = dict(scene=scene.name, engine=curve.engine, integrator=curve.integrator, variant=curve.variant,
                param=float(param), nominal_order=curve.nominal_order)
    nan = float("nan")
    try:
        run = _runner(scene, curve, settings)
        with np.errstate(all="ignore"):
            traj, engine_t, total_t, steps, evals = run()
        if traj.ok and len(traj.t) < len(ref.t):
            traj = replace(traj, status="failed", message=traj.message or "fewer samples than the horizon")
        errs = errors(traj, ref, model)
        times, totals = [engine_t], [total_t]
        repeats = 0
        if traj.ok:
            n = 1 if engine_t > options.slow_run_s else options.repeats
            times, totals = [], []
            for _ in range(max(1, n)):
                with np.errstate(all="ignore"):
                    _, engine_t, total_t, _, _ = run()
                times.append(engine_t)
                totals.append(total_t)
            repeats = len(times)
        return WorkPrecisionPoint(**base, status=traj.status, message=traj.message,
                                  time_s=float(np.median(times)), time_min_s=float(np.min(times)),
                                  time_total_s=float(np.median(totals)), repeats=repeats, steps=steps,
                                  rhs_evals=evals, **errs)
    except NotImplementedError as err:  # the method does not model the scene (mujoco.rollout and a force)
        return WorkPrecisionPoint(**base, status=UNSUPPORTED, message=f"{curve.label}: {err}", time_s=nan,
                                  time_min_s=nan, time_total_s=nan, repeats=0, steps=nan, rhs_evals=nan,
                                  **{k: nan for k in ERROR_KEYS})
    except Exception as err:  # a failed run is a point with its reason
        return WorkPrecisionPoint(**base, status="failed", message=f"{type(err).__name__}: {err}", time_s=nan,
                                  time_min_s=nan, time_total_s=nan, repeats=0, steps=nan, rhs_evals=nan,
                                  **{k: nan for k in ERROR_KEYS})


def curves(engines) -> list[Curve]:
    """The curves of a sweep over ``engines`` (see the module docstring)."""
    out: list[Curve] = []
    if "mujoco" in engines:
        for method in ("Euler", "implicit", "implicitfast", "RK4"):
            out += [Curve("mujoco", method, "rollout"), Curve("mujoco", method, "loop")]
    if "pinocchio" in engines:
        out += [Curve("pinocchio", "rkmk4", ""), Curve("pinocchio", "euler", "")]
    if "drake" in engines:  # error-controlled ones over target accuracies, fixed-step ones over timesteps
        out += [Curve("drake", m, "") for m in ("RK3", "RK5", "Radau3", "RK3_fixed", "RK2")]
    if "exudyn" in engines:  # implicit on every scene; explicit ones on free bodies only (else unsupported)
        out += [Curve("exudyn", m, "") for m in ("GeneralizedAlpha", "TrapezoidalIndex2", "RK44", "RK67")]
    if "inhouse" in engines:
        from harness.engines.inhouse.integrators import COMPILED

        out += [Curve("inhouse", m, "compiled" if m in COMPILED else "per-state")
                for m in ("rk4", "euler", "RK45", "DOP853", "rk4_compiled", "dop853_compiled")]
    return out


def _ladder(curve: Curve, save: float, options: SweepOptions) -> list[float]:
    if curve.adaptive:
        return list(options.tolerances)
    return [save / 2**k for k in range(options.dt_levels)]


def sweep_scene(scene: Scene, engines, options: SweepOptions = SweepOptions(), progress: Progress | None = None,
                curve_list: list[Curve] | None = None) -> SceneSweep:
    """Sweep one scene (see the module docstring)."""
    t_end, save = horizon(scene, options)
    model = scene.multibody()
    ref, how = reference(scene, t_end, save)
    result = SceneSweep(scene.name, t_end, save, how, reference_checks(scene, ref, t_end, save))
    for curve in curve_list if curve_list is not None else curves(engines):
        ladder = _ladder(curve, save, options)
        for i, param in enumerate(ladder):
            point = measure(scene, curve, _settings(curve, t_end, save, param), ref, model, options)
            if point.status == UNSUPPORTED:  # not this method's scene: no points, say why
                result.skipped[curve.label] = point.message
                if progress is not None:
                    progress.advance(len(ladder) - i, f"{scene.name}: {curve.label} not run")
                break
            result.points.append(point)
            if progress is not None:
                progress.advance(1, f"{scene.name}: {curve.label} {param:.1e}")
            slow = math.isfinite(point.time_s) and point.time_s > options.max_run_s
            converged = point.ok and point.state_max < options.error_floor
            if slow or converged:
                if progress is not None:
                    progress.advance(len(ladder) - i - 1, f"{scene.name}: {curve.label} done")
                break
    return result


def head_to_head(scene: Scene, sweep: SceneSweep, options: SweepOptions, targets=TARGETS, rounds: int = 5) -> list[dict]:
    """At each target state error, the cheapest recorded point of the in-house solver (any
    curve) and of MuJoCo RK4 (rollout, and loop) that reach it, timed again in alternation
    (A, B, C, A, B, C, ...) so that both see the same machine load; the medians and their ratio.
    Uses recorded points, not interpolation: each run reaches at least the target."""
    out = []
    for target in targets:
        row: dict = {"target": target}
        picks = {}
        for key, pred in (("inhouse", lambda p: p.engine == "inhouse"),
                          ("mujoco RK4 (rollout)", lambda p: p.label == "mujoco RK4 (rollout)"),
                          ("mujoco RK4 (loop)", lambda p: p.label == "mujoco RK4 (loop)")):
            cands = [p for p in sweep.points if pred(p) and p.ok and p.state_max <= target]
            if cands:
                picks[key] = min(cands, key=lambda p: p.time_s)
        if "inhouse" not in picks or "mujoco RK4 (rollout)" not in picks:
            row["status"] = "not reached by both"
            out.append(row)
            continue
        runners = {}
        for key, p in picks.items():
            curve = Curve(p.engine, p.integrator, p.variant)
            runners[key] = _runner(scene, curve, _settings(curve, sweep.t_end, sweep.save_every, p.param))
            runners[key]()  # warm-up
        times: dict[str, list[float]] = {k: [] for k in runners}
        for _ in range(rounds):
            for key, run in runners.items():
                times[key].append(run()[1])
        for key, p in picks.items():
            row[key] = {"label": p.label, "param": p.param, "state_max": p.state_max,
                        "time_s": float(np.median(times[key])), "time_min_s": float(np.min(times[key]))}
        row["ratio_rollout"] = row["inhouse"]["time_s"] / row["mujoco RK4 (rollout)"]["time_s"]
        if "mujoco RK4 (loop)" in row:
            row["ratio_loop"] = row["inhouse"]["time_s"] / row["mujoco RK4 (loop)"]["time_s"]
        row["status"] = "ok"
        out.append(row)
    return out


def planned_runs(n_scenes: int, engines, options: SweepOptions) -> int:
    """Upper bound on the points of a sweep (for the progress bar)."""
    per_scene = sum(len(options.tolerances) if c.adaptive else options.dt_levels for c in curves(engines))
    return n_scenes * (per_scene + (1 if options.batch else 0))


# ---------------------------------------------------------------------------------------------
# Analysis


def by_curve(points: list[WorkPrecisionPoint]) -> dict[str, list[WorkPrecisionPoint]]:
    out: dict[str, list[WorkPrecisionPoint]] = {}
    for p in points:
        out.setdefault(p.label, []).append(p)
    return out


def _fit(x: np.ndarray, y: np.ndarray) -> float:
    return float(np.polyfit(np.log(x), np.log(y), 1)[0])


def observed_order(points: list[WorkPrecisionPoint], error_floor: float = 1e-12, upper: float = 1e-2) -> dict:
    """Observed order of one curve (see the module docstring): ``{"order", "range", "n"}`` for
    fixed-step methods, plus ``{"tol_slope", "steps_order"}`` for adaptive ones (NaN where fewer
    than three points are in the asymptotic range)."""
    good = [p for p in points if p.ok and 100 * error_floor < p.state_max < upper]
    out = {"n": len(good), "order": float("nan"), "range": ""}
    if not points:
        return out
    adaptive = integrator(points[0].engine, points[0].integrator).adaptive
    if not adaptive:  # the asymptotic range is the fine end: the (up to) four smallest steps
        good = sorted(good, key=lambda p: p.param)[:4]
        out["n"] = len(good)
    if adaptive:
        out.update(tol_slope=float("nan"), steps_order=float("nan"))
    if len(good) < 3:
        return out
    x = np.array([p.param for p in good])
    y = np.array([p.state_max for p in good])
    out["range"] = f"{x.min():.2g}..{x.max():.2g}"
    if adaptive:
        out["tol_slope"] = _fit(x, y)
        steps = np.array([p.steps for p in good])
        if len(set(steps)) >= 3:
            out["steps_order"] = -_fit(steps, y)
        out["order"] = out["steps_order"]
    else:
        out["order"] = _fit(x, y)
    return out


def time_to_error(points: list[WorkPrecisionPoint], target: float, key: str = "state_max") -> float:
    """Run time (s, median) a curve needs to reach ``target`` error: log-log interpolation on
    its lower envelope (errors that only improve with time); NaN when never reached."""
    pts = sorted((p for p in points if p.ok and math.isfinite(getattr(p, key))), key=lambda p: p.time_s)
    env: list[tuple[float, float]] = []
    for p in pts:
        e = getattr(p, key)
        if not env or e < env[-1][1]:
            env.append((p.time_s, e))
    for i, (t, e) in enumerate(env):
        if e <= target:
            if i == 0:
                return t
            t0, e0 = env[i - 1]
            w = (math.log(e0) - math.log(target)) / (math.log(e0) - math.log(e)) if e0 != e else 1.0
            return math.exp(math.log(t0) + w * (math.log(t) - math.log(t0)))
    return float("nan")


def time_table(sweep: SceneSweep, targets=TARGETS) -> list[dict]:
    """Per curve: time to each target error and its ratio to the fastest curve."""
    groups = by_curve(sweep.points)
    rows = [{"label": k, **{f"t({t:g})": time_to_error(v, t) for t in targets}} for k, v in groups.items()]
    for t in targets:
        key = f"t({t:g})"
        best = min((r[key] for r in rows if math.isfinite(r[key])), default=float("nan"))
        for r in rows:
            r[f"ratio({t:g})"] = r[key] / best if math.isfinite(r[key]) and math.isfinite(best) else float("nan")
    return rows


# ---------------------------------------------------------------------------------------------
# Batched throughput


def batch_initial_states(scene: Scene, nbatch: int, seed: int = 0):
    """``nbatch`` initial conditions near the scene's: joint positions moved by N(0, 0.05) rad
    (``mj_integratePos``), joint velocities by N(0, 0.05) times their scale. Returns the rollout
    model, MuJoCo states (nbatch x nstate) and the same states as in-house vectors (nbatch x ny)."""
    import mujoco

    from harness.model import rotations
    from harness.engines.mujoco import rollout as mujoco_rollout
    from harness.engines.inhouse.model import join

    rm = mujoco_rollout.prepare(scene, scene.dt, "RK4")
    m = rm.m
    rng = np.random.default_rng(seed)
    qpos0, qvel0 = rm.d.qpos.copy(), rm.d.qvel.copy()
    vscale = max(1.0, float(np.max(np.abs(qvel0), initial=0.0)))
    S, Y = [], []
    for _ in range(nbatch):
        qpos = qpos0.copy()
        mujoco.mj_integratePos(m, qpos, 0.05 * rng.standard_normal(m.nv), 1.0)
        state = rm.state_from_joints(qpos, qvel0 + 0.05 * vscale * rng.standard_normal(m.nv))
        p, q, v, w_W = rm.read_bodies(state)
        R = rotations.matrix(q).reshape(-1, 3, 3)
        Y.append(join(p, q, v, np.einsum("nji,nj->ni", R, w_W)))
        S.append(state)
    return rm, np.array(S), np.array(Y)


def batch_benchmark(scene: Scene, nbatch: int, nstep: int, repeats: int = 3) -> dict:
    """Throughput (trajectory-steps per second) of RK4 over ``nbatch`` initial conditions for
    ``nstep`` steps of the scene's dt: ``mujoco.rollout`` against the compiled in-house RK4
    (``rk4_compiled``'s kernel, ``compiled.solver.run_batch``: one trajectory after another on
    each thread), each with the machine's cores as threads and with one thread. All timed in
    alternation (one warm-up each, which also compiles the kernel, then ``repeats`` rounds;
    medians). Also the largest state difference between the MuJoCo and the in-house batch at the
    end (relative, as ``errors``), over a sample of the trajectories."""
    from harness.engines.mujoco import rollout as mujoco_rollout
    from harness.engines.inhouse import projection_tolerance
    from harness.engines.inhouse.compiled import solver as compiled
    from harness.engines.inhouse.integrators import FIXED_STEP
    from harness.engines.inhouse.model import build, to_trajectory

    out: dict = {"scene": scene.name, "nbatch": nbatch, "nstep": nstep, "dt": scene.dt, "method": "RK4"}
    model = scene.multibody()
    try:
        rm, S0, Y0 = batch_initial_states(scene, nbatch)
        nem = build(model)
        packed = compiled.pack(nem)
    except NotImplementedError as err:
        out["status"] = f"skipped: {err}"
        return out
    threads = mujoco_rollout.default_threads()
    out["threads"] = threads
    proj_tol = projection_tolerance(nem)
    tableau = FIXED_STEP["rk4_compiled"]
    box: dict = {}

    def mj(nthread):
        box["mj"] = rm.run(S0, nstep, nthread)

    def jit(nthread):
        box["jit"] = compiled.run_batch(packed, Y0, nstep, scene.dt, tableau, threads=nthread, proj_tol=proj_tol)

    runs = {"mujoco": lambda: mj(threads), "mujoco_1thread": lambda: mj(1),
            "compiled": lambda: jit(threads), "compiled_1thread": lambda: jit(1)}
    times: dict[str, list[float]] = {k: [] for k in runs}
    for fn in runs.values():
        fn()  # warm-up (and compilation of the kernel)
    for _ in range(max(1, repeats)):
        for key, fn in runs.items():
            start = time.perf_counter()
            fn()
            times[key].append(time.perf_counter() - start)
    work = nbatch * nstep
    for key, ts in times.items():
        out[f"{key}_s"] = float(np.median(ts))
        out[f"{key}_min_s"] = float(np.min(ts))
        out[f"{key}_steps_per_s"] = work / out[f"{key}_s"]
    Yend, words = box["jit"]  # the last run, on one thread (trajectories never mix: any thread count gives these)
    failed = int(np.sum(words != "ok"))
    out["status"] = "ok" if not failed else f"{failed} compiled trajectories failed"
    diffs = []
    t = np.array([0.0, nstep * scene.dt])
    for i in range(0, nbatch, max(1, nbatch // 20)):
        mj_traj = rm.trajectory(np.stack([S0[i], box["mj"][i, -1]]), t, "RK4")
        ih_traj = to_trajectory(nem, t, np.stack([Y0[i], Yend[i]]), "inhouse", "rk4_compiled")
        scales = compare.motion_scales(mj_traj, model)
        diffs.append(_state_error(compare.trajectory_error(_take(ih_traj, [1]), _take(mj_traj, [1])), scales))
    out["max_state_difference"] = float(np.max(diffs))
    return out


# ---------------------------------------------------------------------------------------------
# Whole sweep


SCENE_TIMEOUT = 3600.0  # s allowed to one scene's sweep on a Dask worker (a full scene takes minutes)


def scene_study(scene: Scene, engines, options: SweepOptions = SweepOptions(),
                progress: Progress | None = None) -> SceneSweep:
    """One scene's part of ``run_sweep``: its sweep, the head-to-head timing (with MuJoCo and
    the in-house engine) and, unless ``options.batch`` is 0, the batched-throughput benchmark."""
    res = sweep_scene(scene, engines, options, progress)
    if "mujoco" in engines and "inhouse" in engines:
        if progress is not None:
            progress.advance(0, f"{scene.name}: head to head")
        try:
            res.head_to_head = head_to_head(scene, res, options)
        except Exception as err:  # recorded, not raised
            res.head_to_head = [{"status": f"failed: {type(err).__name__}: {err}"}]
    if options.batch and "mujoco" in engines and "inhouse" in engines:
        if progress is not None:
            progress.advance(0, f"{scene.name}: batch of {options.batch}")
        try:
            res.batch = batch_benchmark(scene, options.batch, options.batch_steps, min(3, options.repeats))
        except Exception as err:  # recorded, not raised
            res.batch = {"scene": scene.name, "status": f"failed: {type(err).__name__}: {err}"}
        if progress is not None:
            progress.advance(1, f"{scene.name}: batch done")
    return res


def run_sweep(scenes: list[Scene], engines, options: SweepOptions = SweepOptions(), *,
              dask: str | None = None, jobs: int | None = None) -> list[SceneSweep]:
    """Sweep ``scenes`` on ``engines`` (progress bar on stderr) and, unless ``options.batch``
    is 0, run the batched-throughput benchmark per scene (``scene_study``).

    Locally the scenes run one after the other in this process: a timing benchmark, never two
    runs side by side. With ``dask`` (the address of a ``dask.distributed`` scheduler) each scene
    is one isolated case on its workers (``harness.validate.workers.run_cases``; at most ``jobs``
    at once when given, limited to ``SCENE_TIMEOUT`` s): the same points wherever the timing
    criteria (``max_run_s``) do not decide, times as quiet as the workers are. A scene whose case
    fails has no points and says why in its reference line."""
    progress = Progress(planned_runs(len(scenes), engines, options), enabled=options.progress)
    results = []
    try:
        if not dask:
            return [scene_study(scene, engines, options, progress) for scene in scenes]
        from harness.validate.workers import run_cases

        per_scene = planned_runs(1, engines, options)
        quiet = replace(options, progress=False)

        def done(name, outcome) -> None:
            progress.advance(per_scene, f"{name}: {outcome.status}")

        outcomes = run_cases([(s.name, scene_study, (s, engines, quiet)) for s in scenes], jobs, SCENE_TIMEOUT,
                             on_done=done, dask=dask)
        for scene in scenes:
            outcome = outcomes[scene.name]
            if outcome.status == "ok":
                results.append(outcome.value)
            else:
                t_end, save = horizon(scene, options)
                results.append(SceneSweep(scene.name, t_end, save,
                                          f"none, the scene's sweep did not end ({outcome.status}: {outcome.message})"))
        return results
    finally:
        progress.close()


def points_table(results: list[SceneSweep]):
    """All points as a pandas DataFrame (the CSV)."""
    import pandas as pd

    rows = []
    for r in results:
        for p in r.points:
            d = asdict(p)
            d["label"] = p.label
            rows.append(d)
    return pd.DataFrame(rows)
