"""Work-precision sweeps: error against run time for every scene, engine and integrator.

Use: ``harness workprecision`` (``harness.cli.workprecision``), or ``run_sweep(scenes, engines,
options)``, one ``SceneSweep`` per scene (its ``WorkPrecisionPoint``s, where the time went, the
head to head and the batch benchmark), which ``report.write_reports`` writes out; nothing here
writes a file. ``SweepOptions`` holds every setting; ``QUICK`` is a small sweep for tests.

Vocabulary as DiffEqDevTools.jl: a reference solution judges every run; errors are ``final``
(at the horizon) and ``max`` (the L-infinity norm over the saved steps); timing is one warm-up
run, then the median (and the minimum) of repeated runs, in wall-clock seconds; a run that fails
or blows up is a recorded point with its reason (errors NaN), never an exception.

Curves (``curves``): each integrator of each engine over fixed steps ``dt`` (s) or, where it is
adaptive, over tolerances ``rtol = atol`` (kind and nominal order from the engine's
``Integrator`` records, ``harness.engines.integrator``). All run through their engine's
``simulate`` (``get_engine``) but MuJoCo's ``rollout`` variant; what a point's ``time_s`` covers:

* MuJoCo: Euler, implicit, implicitfast, RK4, twice: ``rollout`` (``mujoco.rollout``: the time
  inside the C rollout) and ``loop`` (``MujocoEngine.simulate``: the stepping loop, reading back
  every saved sample).
* Pinocchio: rkmk4, euler (the loop).
* Drake: RK3, RK5, Radau3 with Drake's error control over tolerances (maximum step
  ``adaptive_step``), RK3_fixed and RK2 over steps (the engine's whole run: parsing the URDF,
  building the plant, integrating, reading every sample).
* Exudyn: GeneralizedAlpha, TrapezoidalIndex2, and RK44, RK67 on free bodies only (the whole
  run: building the system, solving, reading the sensors).
* In-house: the compiled methods (variant ``compiled``: the integration alone, the kernel
  compiled beforehand, ``warm_kernels``) rk4_compiled, rkmk4_compiled over steps and
  dop853_compiled over tolerances; the per-state oracle (variant ``per-state``: the whole run)
  rk4, euler over steps and SciPy's RK45, DOP853 over tolerances, by default only on the scenes
  the compiled form does not model (``SweepOptions.per_state``).

``time_total_s`` adds loading the model and converting the result. A method that does not model
a scene (status ``"unsupported"``) is skipped there after its first run, its reason in
``SceneSweep.skipped``.

Ladders: steps ``dt = save / 2^k`` (whole steps per saved interval) from the first at or below
``coarsest_dt`` times the scene's dt down to ``save / 2^(dt_levels - 1)``, each held to
``harness.model.scene.MAX_STEPS`` steps over the horizon before any run (``check_step_budget``);
tolerances one per decade (``tolerances``).

Isolation: each curve runs in a worker process of its own
(``harness.validate.workers.stream_case``) that sends each point back as it is measured; a point
over ``run_timeout_s`` of wall clock is recorded as failed (``TIMED_OUT``) and its curve stops.
A scene's reference, head to head and batch benchmark each run in a worker too (``run_stage``,
``STAGE_TIMEOUT``).

Refinement rules: a point whose warm-up took less than ``slow_run_s`` is timed ``repeats`` more
times, a slower one once more. A curve stops (``stop_reason``, recorded in
``SceneSweep.curves[label]["stop"]``) when its next point, predicted from the last two
(``next_cost``), would take its points past their wall-time budget: ``curve_budget_s``;
``key_budget_s`` for the curves the targets are measured on (MuJoCo RK4 through ``rollout``, or
the loop where rollout cannot run the scene, and the in-house DOP853), ``reach_budget_s`` while
such a curve still converges above the error it must reach (``converging``, ``reach``);
``loop_budget_s`` for MuJoCo's loop variants. It also stops after a run slower than
``max_run_s``, at a state error below ``stop_error``, when a fixed-step error stalls (the best of
the last three points not twice better than the best before, below 1e-2, and their error model
not ``converges``), and after three failed runs that follow a sound one.

Error measures (``errors``), against the reference at the saved times with the reference's
scales (``harness.measure.compare``: ``motion_scales`` length L (m), velocity V (m/s), angular
velocity Omega (rad/s); ``energy_scale`` E (J); ``momentum_scales`` p (kg m/s), Lm (kg m^2/s)):

* state error at a sample = max over bodies of max( |dp_WCm_W| / L, geodesic angle of
  quat_WB^-1 quat_ref (rad), |dv_WCm_W| / V, |dw_WB_W| / Omega ): the largest of the trajectory
  quantities of ``harness.judging.quantities`` (``state_error``), as validate judges its
  ``trajectory.*`` checks;
* energy error = |E - E_ref| / E (the harness's energy recomputed from the common state);
* momentum error = max( |p_W - p_ref| / p, |L_W - L_ref| / Lm ) (linear and angular momentum
  about the world origin, world frame);

each at the final time (``*_final``) and as the max over the saved samples (``*_max``).

Reference (``reference``): the compiled in-house DOP853 at rtol = atol = ``REFERENCE_TOL``, its
steps capped at save / ``REFERENCE_SLICES`` and projected onto the constraints after each, where
the compiled form models the scene; else the per-state DOP853 at the same tolerance, steps
capped at save / 10. Its own error against the scene's closed form is reported where the exact
check needs no runs of its own (``reference_checks``).

Each curve is judged as validate judges its checks (``curve_model``,
``harness.judging.error_model``): its state error against its step or tolerance gives the
observed order, the floor and the class; ``observed_order`` adds, for adaptive methods, the order
in the work (against accepted steps).

Targets: at each state error of ``TARGETS`` the in-house solver's time over MuJoCo RK4's
(``head_to_head``, timed again in alternation) is at most ``TARGET_RATIO``; the compiled in-house
RK4's batched throughput over ``mujoco.rollout``'s (``batch_benchmark``, trajectory-steps per
second) is at least ``TARGET_THROUGHPUT``.
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass, field, replace
from typing import Callable

import numpy as np

from harness.measure import compare
from harness.measure import invariants
from harness.judging import quantities
from harness.engines import ENGINE_NAMES, REFERENCE_ENGINE, declaration, display, engine_module, get_engine, integrator
from harness.engines.base import RunSettings
from harness.studies.workprecision import BASELINE
from harness.judging import error_model
from harness.model.scene import Scene
from harness.measure.trajectory import UNSUPPORTED, Failure, Trajectory

_clock = time.perf_counter  # the sweep's clock (budgets and stage walls)

TARGETS = (1e-6, 1e-10)
TARGET_RATIO = 0.5  # the in-house solver's time at equal state error over MuJoCo RK4's: at most this
TARGET_THROUGHPUT = 5.0  # batched throughput of the compiled in-house RK4 over mujoco.rollout's: at least this
ERROR_KEYS = ("state_final", "state_max", "energy_final", "energy_max", "momentum_final", "momentum_max")
PER_STATE = ("uncovered", "all", "none")  # values of SweepOptions.per_state
BASE, REF = display(BASELINE), display(REFERENCE_ENGINE)  # the head to head's two sides, as reports write them
#: The baseline's curve the targets are measured on, by variant (``rollout``: ``mujoco.rollout``;
#: ``loop``: the engine's stepping loop): the curves' labels.
BASELINE_RK4 = {side: f"{BASELINE} RK4 ({side})" for side in ("rollout", "loop")}
ROLLOUT = f"{declaration(BASELINE).library}.rollout"  # the baseline library's batch rollout, as reports name it
NOT_REACHED_BASELINE = f"not reached by {BASE} RK4"  # head-to-head statuses
NOT_REACHED_REFERENCE = f"not reached by the {REF} solver"
NOT_REACHED_EITHER = "not reached by either"


def _reference_part(part: str):
    """Module ``part`` of the reference engine (its compiled form: ``compiled.solver``, ``model``)."""
    return engine_module(REFERENCE_ENGINE, part)


@dataclass(frozen=True)
class SweepOptions:
    """How a sweep is run (the module docstring says what each setting stops or sizes).

    Attributes:
        repeats: timed runs after the warm-up (median and minimum are reported).
        slow_run_s: a run whose warm-up took longer than this is timed once more only.
        max_run_s: stop refining a curve after a run this slow (s).
        saves: number of saved intervals over the horizon (errors are measured there).
        dt_levels: timesteps ``save / 2^k`` for k up to dt_levels - 1.
        coarsest_dt: the first timestep is the largest ``save / 2^k`` at or below this many times
            the scene's dt (at least three levels); None: from the save interval.
        tolerances: rtol = atol values of the adaptive methods.
        error_floor: the reference's accuracy (the order fits use errors above 100 x this).
        stop_error: stop refining a curve once its state error is below this.
        curve_budget_s: wall time (s) a curve's points may take together; None: no budget.
        key_budget_s: the same for the curves the targets are measured on (module docstring).
        reach_budget_s: theirs while they still converge towards the error they must reach
            (``reach``; None: no budget then).
        loop_budget_s: the same for MuJoCo's ``loop`` variants.
        per_state: where the per-state in-house curves run: "uncovered" (scenes the compiled
            form does not model), "all" or "none".
        h2h_rounds: most rounds of the head to head (at least 3).
        h2h_budget_s: rounds past the third only while a target's rounds took less than this (s).
        horizon: the scene's t_end when None.
        batch: most initial conditions of the batched-throughput benchmark (0: skip it).
        batch_steps: steps of each trajectory in that benchmark.
        batch_budget_s: about the time (s) of that benchmark's timed runs (None: always ``batch``).
        run_timeout_s: wall-clock budget (s) of one point (its warm-up and timed repeats), which
            runs in its curve's worker process (``sweep_scene``): a point over it is recorded
            as failed, "timed out after N s", its curve stops and the sweep goes on.
        progress: draw the progress bar on stderr (only ever when stderr is a terminal).
    """

    repeats: int = 3
    slow_run_s: float = 0.02
    max_run_s: float = 2.0
    saves: int = 20
    dt_levels: int = 16
    coarsest_dt: float | None = 32.0
    tolerances: tuple[float, ...] = tuple(10.0 ** -k for k in range(3, 14))
    error_floor: float = 1e-12
    stop_error: float = 1e-11
    curve_budget_s: float | None = 0.5
    key_budget_s: float | None = 3.0
    reach_budget_s: float | None = 10.0
    loop_budget_s: float | None = 0.25
    per_state: str = "uncovered"
    h2h_rounds: int = 5
    h2h_budget_s: float = 2.0
    horizon: float | None = None
    batch: int = 1000
    batch_steps: int = 100
    batch_budget_s: float | None = 3.0
    run_timeout_s: float = 60.0
    progress: bool = True


QUICK = SweepOptions(repeats=1, slow_run_s=0.05, max_run_s=0.05, saves=5, dt_levels=7, coarsest_dt=None,
                     tolerances=(1e-4, 1e-6, 1e-8), horizon=None, batch=16, batch_steps=5, per_state="all",
                     h2h_rounds=3, batch_budget_s=None)


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
    """Everything a sweep produced for one scene: its points, the curves it skipped (the method
    does not model the scene) or omitted (the sweep's options), per curve its wall time, points
    and why it stopped (``curves``), the wall time of each stage (``walls``), the head to head
    and the batch benchmark."""

    scene: str
    t_end: float
    save_every: float
    reference: str
    reference_checks: dict[str, float] = field(default_factory=dict)
    points: list[WorkPrecisionPoint] = field(default_factory=list)
    skipped: dict[str, str] = field(default_factory=dict)  # curve label -> why it does not run on this scene
    batch: dict | None = None
    head_to_head: list[dict] = field(default_factory=list)
    omitted: dict[str, str] = field(default_factory=dict)  # curve label -> why this sweep left it out (options)
    curves: dict[str, dict] = field(default_factory=dict)  # label -> {"wall_s", "points", "stop", "budget_s", "role"}
    walls: dict[str, float] = field(default_factory=dict)  # "reference", "curves", "head_to_head", "batch", "total" (s)


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


_REF_SIDE: list = []  # [(ref, model, quantities)]: the last reference's side of ``errors``


def _reference_side(ref: Trajectory, model) -> dict:
    """What ``errors`` needs of the reference (scales, energy, momenta), computed once per
    reference: every point of a scene is judged against the same one."""
    if _REF_SIDE and _REF_SIDE[0][0] is ref and _REF_SIDE[0][1] is model:
        return _REF_SIDE[0][2]
    n = len(ref.t)
    side = {"scales": compare.motion_scales(ref, model), "last": _take(ref, [n - 1]),
            "e_scale": compare.energy_scale(ref, model), "energy": invariants.energies(ref, model)["energy"],
            "momentum_scales": compare.momentum_scales(ref, model), "p": invariants.linear_momentum(ref, model),
            "L": invariants.angular_momentum(ref, model)}
    _REF_SIDE[:] = [(ref, model, side)]
    return side


def errors(traj: Trajectory, ref: Trajectory, model) -> dict[str, float]:
    """The error measures of the module docstring (keys ``ERROR_KEYS``); NaN when ``traj``
    did not reach every saved sample of ``ref``."""
    n = len(ref.t)
    if not traj.ok or len(traj.t) < n:
        return {k: float("nan") for k in ERROR_KEYS}
    traj = _take(traj, slice(0, n))
    side = _reference_side(ref, model)
    scales = side["scales"]
    out = {
        "state_max": _state_error(compare.trajectory_error(traj, ref), scales),
        "state_final": _state_error(compare.trajectory_error(_take(traj, [n - 1]), side["last"]), scales),
    }
    de = np.abs(invariants.energies(traj, model)["energy"] - side["energy"]) / side["e_scale"]
    p_scale, l_scale = side["momentum_scales"]
    dp = np.linalg.norm(invariants.linear_momentum(traj, model) - side["p"], axis=1) / p_scale
    dl = np.linalg.norm(invariants.angular_momentum(traj, model) - side["L"], axis=1) / l_scale
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


REFERENCE_TOL = 1e-13  # rtol = atol of the reference run
REFERENCE_SLICES = 25  # the compiled reference's steps are capped at save / REFERENCE_SLICES


def compiled_reference(scene: Scene, t_end: float, save: float, slices: int = REFERENCE_SLICES) -> tuple[Trajectory, int, float]:
    """The compiled in-house DOP853 (``compiled.solver.integrate_dop853``, rtol = atol =
    ``REFERENCE_TOL``) from the scene's initial state to ``t_end``, in slices of ``save / slices``
    s, each from the last one's end state (its first step the whole slice): the kernel has no
    max-step option, and this caps the steps as the per-state reference's ``max_step`` does;
    every saved state is a step's end, never dense output. Returns (trajectory at the saved
    times, accepted steps, integration wall time s). NotImplementedError when the compiled form
    does not model the scene; RuntimeError when a slice fails."""
    projection_tolerance = _reference_part("").projection_tolerance
    compiled = _reference_part("compiled.solver")
    ref_model = _reference_part("model")

    model = scene.multibody()
    nem = ref_model.build(model)
    packed = compiled.pack(nem)
    y = ref_model.initial_state(model, nem)
    proj_tol = projection_tolerance(nem)
    n = int(round(t_end / save))
    h = save / slices
    saved, steps, wall = [np.array(y, dtype=float)], 0, 0.0
    for k in range(n * slices):
        res = compiled.integrate_dop853(packed, y, np.array([k * h, (k + 1) * h]), rtol=REFERENCE_TOL,
                                        atol=REFERENCE_TOL, first_step=h, proj_tol=proj_tol)
        if res.status != "ok" or len(res.t) < 2 or not np.all(np.isfinite(res.y[-1])):
            raise RuntimeError(f"compiled reference {res.status} at t = {k * h:.6g} s: {res.message}")
        y = res.y[-1]
        steps += res.steps
        wall += res.wall_s
        if (k + 1) % slices == 0:
            saved.append(np.array(y, dtype=float))
    traj = ref_model.to_trajectory(nem, np.arange(n + 1) * save, np.array(saved), REFERENCE_ENGINE, "dop853_compiled")
    return replace(traj, stats={"steps": steps, "wall_s": wall}), steps, wall


def reference(scene: Scene, t_end: float, save: float, method: str | None = None) -> tuple[Trajectory, str]:
    """The reference trajectory at the save times and a line saying how it was made.

    ``method`` None: the compiled in-house DOP853 (``compiled_reference``: rtol = atol =
    ``REFERENCE_TOL``, steps capped at save / ``REFERENCE_SLICES``) when the compiled form models
    the scene, else (``pack`` raises NotImplementedError, or the compiled run fails) the
    per-state DOP853 at the same tolerance with steps capped at save / 10; "dop853_compiled" or
    "DOP853" forces one. A scene without a reference run (validate's ``has_reference``: it
    declares no check against one) whose reference module gives its exact motion in maximal
    coordinates (``exact_trajectory(scene, t)``: four_bar_chain) is measured against that
    instead, at every ``method``. RuntimeError when the reference run fails."""
    closed = closed_form(scene)
    if closed is not None:
        return closed(scene, np.arange(int(round(t_end / save)) + 1) * save), \
            f"the closed form ({closed.__module__}.exact_trajectory): no reference run"
    engine = get_engine(REFERENCE_ENGINE)
    fine = save / 10.0
    why = ""
    if method in (None, "dop853_compiled"):
        try:
            traj, steps, wall = compiled_reference(scene, t_end, save)
            how = (f"{REF} compiled DOP853 (dop853_compiled's kernel), rtol = atol = {REFERENCE_TOL:g}, max step "
                   f"{save / REFERENCE_SLICES:g} s ({steps} steps, {wall:.3g} s)")
            return traj, how
        except (NotImplementedError, RuntimeError) as err:
            if method == "dop853_compiled":
                raise RuntimeError(f"reference run: {err}") from err
            why = (f"; the compiled form does not model this scene ({err})" if isinstance(err, NotImplementedError)
                   else f"; the compiled reference failed ({err})")
    settings = RunSettings(t_end, fine, fine, "DOP853", rtol=REFERENCE_TOL, atol=REFERENCE_TOL)
    traj = engine.simulate(scene, settings)
    if not traj.ok:
        raise RuntimeError(f"reference run {traj.status}: {traj.message}")
    traj = _take(traj, slice(None, None, 10))
    how = (f"{REF} per-state engine, SciPy DOP853 rtol = atol = {REFERENCE_TOL:g}, max step {fine:g} s "
           f"({traj.stats.get('steps', '?')} steps, {traj.stats.get('wall_s', float('nan')):.3g} s){why}")
    return traj, how


def closed_form(scene: Scene) -> Callable | None:
    """The scene's ``exact_trajectory`` (its reference module's exact motion of every body) where
    validation makes it no reference run (``harness.validate.run.has_reference``), else None."""
    from harness.measure.exact import reference_module
    from harness.validate.run import has_reference

    if has_reference(scene):
        return None
    return getattr(reference_module(scene), "exact_trajectory", None)


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


def compiled_covers(scene: Scene) -> tuple[bool, str]:
    """Whether the compiled in-house form models ``scene`` (``compiled.solver.pack`` accepts its
    model) and, when not, why. A model that does not build counts as covered: its runs say why."""
    compiled = _reference_part("compiled.solver")
    build = _reference_part("model").build

    try:
        compiled.pack(build(scene.multibody()))
    except NotImplementedError as err:
        return False, str(err)
    except Exception:  # the runs report it, with either form
        return True, ""
    return True, ""


# ---------------------------------------------------------------------------------------------
# Runners: each returns a function run() -> (trajectory, engine time s, total time s, steps,
# rhs_evals); errors come from the warm-up run's trajectory.

Run = Callable[[], tuple[Trajectory, float, float, float, float]]


def _settings(curve: Curve, t_end: float, save: float, param: float, max_dt: float | None = None) -> RunSettings:
    """The settings of one point: a fixed-step curve at step ``param`` (s); an adaptive one at
    rtol = atol = ``param`` with ``dt`` the largest ``save / 2^k`` at or below ``max_dt`` (s,
    ``adaptive_step``; the save interval when None): the first-step hint of the in-house
    methods and Drake's maximum step, which comes from the scene's step, never the save interval
    (with the 1 s save interval of ``--quick`` as its maximum step Drake's RK5 did not return on
    heavy_top; ``harness.engines.drake.integrators``)."""
    if curve.adaptive:
        dt = save
        if max_dt is not None and 0 < max_dt < save:
            dt = save / 2 ** math.ceil(math.log2(save / max_dt) - 1e-9)
        return RunSettings(t_end, dt, save, curve.integrator, rtol=param, atol=param)
    return RunSettings(t_end, param, save, curve.integrator)


def adaptive_step(scene: Scene, options: SweepOptions) -> float:
    """The largest ``dt`` (s) of an adaptive curve's runs (``_settings``): where the fixed-step
    ladders start, ``coarsest_dt`` times the scene's step (the scene's step when None). Measured
    on heavy_top (save 0.25 s): Drake's RK3, RK5 and Radau3 at 1e-3..1e-10 with a 0.0156 s
    maximum step end in 0.8-10 s each."""
    return (options.coarsest_dt or 1.0) * scene.dt


def _runner(scene: Scene, curve: Curve, settings: RunSettings) -> Run:
    """The timed unit of work of one point (see the module docstring): ``mujoco.rollout`` for
    MuJoCo's ``rollout`` variant, else the engine's ``simulate`` (engine time: its
    ``stats["wall_s"]``)."""
    if curve.engine == BASELINE and curve.variant == "rollout":
        baseline_rollout = engine_module(BASELINE, "rollout")

        t0 = time.perf_counter()
        rm = baseline_rollout.prepare(scene, settings.dt, settings.integrator)
        setup = time.perf_counter() - t0
        nstep = settings.n_saves * settings.steps_per_save
        t_save = np.arange(settings.n_saves + 1) * settings.save_every
        init = rm.state0[None]

        def run():
            start = time.perf_counter()
            states = rm.run(init, nstep)[0]
            engine = time.perf_counter() - start
            saved = baseline_rollout.saved_states(rm.state0, states, settings.steps_per_save)
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
            traj = replace(traj, reason=Failure.SOLVER, message=traj.message or "fewer samples than the horizon")
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


TIMED_OUT = "timed out after"  # the message of a point over its wall-clock budget (``sweep_scene``)


def curves(engines) -> list[Curve]:
    """The curves of a sweep over ``engines`` (see the module docstring): each engine's declared
    curves (``harness.engines.Declaration.curves``), the baseline's first and the reference
    engine's last (what the reference engine's target curve must reach is the baseline's best,
    ``reach``), the others in registry order between."""
    order = [BASELINE, *(e for e in ENGINE_NAMES if e not in (BASELINE, REFERENCE_ENGINE)), REFERENCE_ENGINE]
    return [Curve(e, c.integrator, c.variant) for e in order if e in engines for c in declaration(e).curves]


def _ladder(curve: Curve, save: float, options: SweepOptions, scene_dt: float | None = None) -> list[float]:
    """The parameters a curve is swept over, coarse to fine: ``options.tolerances``, or the
    timesteps ``save / 2^k`` from the first at or below ``coarsest_dt x scene_dt`` (the save
    interval when either is None) down to ``save / 2^(dt_levels - 1)``, at least three of them."""
    if curve.adaptive:
        return list(options.tolerances)
    return _step_ladder(save, options, scene_dt)


def _step_ladder(save: float, options: SweepOptions, scene_dt: float | None = None) -> list[float]:
    """The timesteps (s) of every fixed-step curve, coarse to fine (``_ladder``)."""
    k0 = 0
    if options.coarsest_dt is not None and scene_dt is not None and scene_dt > 0:
        k0 = max(0, math.ceil(math.log2(save / (options.coarsest_dt * scene_dt)) - 1e-9))
    return [save / 2**k for k in range(k0, max(options.dt_levels, k0 + 3))]


def check_step_budget(scenes: list[Scene], options: SweepOptions) -> None:
    """InputError, before any run, when the finest timestep of a scene's ladder (``_ladder``)
    would take more integration steps over the sweep's horizon than
    ``harness.model.scene.MAX_STEPS`` (``check_steps``)."""
    from harness.model.scene import check_steps

    for scene in scenes:
        t_end, save = horizon(scene, options)
        finest = min(_step_ladder(save, options, scene.dt))
        check_steps(t_end, finest, f"{scene.name}: the sweep's finest step (--saves, --t-end)")


KEY, LOOP, ORDINARY = "key", "loop", "ordinary"  # roles of a curve (its budget)


def curve_role(curve: Curve, skipped: dict[str, str] | tuple = (), covered: bool = True) -> str:
    """``KEY`` for the curves the targets are measured on: MuJoCo RK4 through ``mujoco.rollout``
    (through the loop when ``skipped`` says rollout does not run the scene) and the in-house
    DOP853 (``dop853_compiled``; the per-state DOP853 when the compiled form does not model the
    scene, ``covered`` False); ``LOOP`` for MuJoCo's other ``loop`` variants; else ``ORDINARY``."""
    if curve.engine == BASELINE and curve.integrator == "RK4":
        if curve.variant == "rollout" or BASELINE_RK4["rollout"] in skipped:
            return KEY
    if curve.engine == REFERENCE_ENGINE and curve.integrator == ("dop853_compiled" if covered else "DOP853"):
        return KEY
    if curve.engine == BASELINE and curve.variant == "loop":
        return LOOP
    return ORDINARY


def role_budget(role: str, options: SweepOptions) -> float:
    """The wall-time budget (s) of a curve of ``role``; inf for none."""
    value = {KEY: options.key_budget_s, LOOP: options.loop_budget_s}.get(role, options.curve_budget_s)
    return math.inf if value is None else float(value)


def next_cost(history: list[tuple[WorkPrecisionPoint, float]], adaptive: bool, options: SweepOptions) -> float:
    """Predicted wall time (s) of a curve's next point from its points so far (``(point, wall
    s)``, at least one): the per-run time (a point's wall over its runs, warm-up included) grows
    by the ratio of the last two (clamped to 1..4; 2 for a fixed step, 1.5 for a tolerance
    before there are two), times the runs the next point will take (1 + ``repeats`` below
    ``slow_run_s``, else 2)."""
    per_run = [w / (1 + p.repeats) for p, w in history]
    growth = 1.5 if adaptive else 2.0
    if len(per_run) >= 2 and per_run[-2] > 0:
        growth = min(4.0, max(1.0, per_run[-1] / per_run[-2]))
    run = growth * per_run[-1]
    return run * (1 + (options.repeats if run <= options.slow_run_s else 1))


def stop_reason(history: list[tuple[WorkPrecisionPoint, float]], options: SweepOptions) -> str:
    """Why a curve stops after its last point (module docstring), or "" to go on: a run slower
    than ``max_run_s``, a state error below ``stop_error``, a stalled error (fixed steps only:
    an adaptive method's error may sit flat over tolerances its step control does not see, then
    fall; its budget decides; and only where the error model of the last three points,
    ``curve_model``, does not say it converges: "error stalled (<class>, floor F)"), failing runs, a point over its wall-clock budget
    (``run_timeout_s``: "timed out after N s")."""
    last = history[-1][0]
    if last.message.startswith(TIMED_OUT):  # a finer step or tolerance only takes longer
        return last.message
    if math.isfinite(last.time_s) and last.time_s > options.max_run_s:
        return f"a run took more than {options.max_run_s:g} s"
    if last.ok and last.state_max < options.stop_error:
        return f"state error below {options.stop_error:g}"
    points = [p for p, _ in history]
    adaptive = integrator(last.engine, last.integrator).adaptive
    if not adaptive and len(points) >= 4 and all(p.ok for p in points[-3:]):
        before = [p.state_max for p in points[:-3] if p.ok]
        if before and min(before) < 1e-2 and min(p.state_max for p in points[-3:]) > 0.5 * min(before):
            m = curve_model(points[-3:], options.error_floor)
            if m.classification != error_model.CONVERGES:
                floor = f", floor {m.floor:.1e}" if m.floor > 0 else ""
                return f"error stalled ({m.classification}{floor})"
    if len(points) >= 4 and not any(p.ok for p in points[-3:]) and any(p.ok for p in points[:-3]):
        return "runs fail"
    return ""


def scene_curves(engines, options: SweepOptions, covered: bool) -> tuple[list[Curve], dict[str, str]]:
    """The curves of a scene (``curves``) less the per-state in-house ones ``options.per_state``
    leaves out (``covered``: the compiled form models the scene, ``compiled_covers``), and
    ``{label: why}`` for those."""
    out, omitted = [], {}
    for curve in curves(engines):
        if curve.variant == "per-state":
            if options.per_state == "none":
                omitted[curve.label] = "per-state curves not swept (per_state none)"
                continue
            if options.per_state == "uncovered" and covered:
                omitted[curve.label] = ("the compiled form models this scene: the per-state oracle is swept only "
                                        "where it does not (--per-state all sweeps it everywhere)")
                continue
        out.append(curve)
    return out, omitted


def converging(history: list[tuple[WorkPrecisionPoint, float]], curve: Curve) -> bool:
    """Whether a curve's last two points are sound and its error fell as it should: a fixed step
    at at least half its nominal order (slope of log error against log dt), a tolerance by at
    least half."""
    pts = [p for p, _ in history[-2:]]
    if len(pts) < 2 or not all(p.ok and p.state_max > 0 for p in pts):
        return False
    (a, b) = pts
    if curve.adaptive:
        return b.state_max < 0.5 * a.state_max
    slope = math.log(a.state_max / b.state_max) / math.log(a.param / b.param)
    return slope >= 0.5 * curve.nominal_order


def reach(curve: Curve, role: str, baseline_best: float | None, targets=TARGETS) -> float | None:
    """The state error a target curve (``role`` KEY) must reach for the head to head to judge
    every target it can: MuJoCo RK4, the smallest target; the in-house solver, the smallest
    target MuJoCo RK4 reached (``baseline_best``: its best state error, None when it did not run).
    None for every other curve, or when MuJoCo RK4 reached no target."""
    if role != KEY:
        return None
    if curve.engine == BASELINE:
        return min(targets)
    reached = [t for t in targets if baseline_best is not None and baseline_best <= t]
    return min(reached) if reached else None


def _prepare_workers(scene: Scene, curve_list: list[Curve], ref: Trajectory | None, model) -> None:
    """What every curve's worker (``stream_case``, forked from this process) would
    otherwise load or compute again at its start: the engines' lazy imports
    (``harness.engines.preload``), the compiled in-house kernels (``warm_kernels``) and the
    reference's side of the errors (``_reference_side``)."""
    from harness.engines import preload

    engines = list(dict.fromkeys(c.engine for c in curve_list))
    preload(engines)
    if any(c.engine == REFERENCE_ENGINE and c.variant == "compiled" for c in curve_list):
        warm_kernels([scene])
    if isinstance(ref, Trajectory):
        _reference_side(ref, model)


def failed_point(scene: Scene, curve: Curve, param: float, why: str) -> WorkPrecisionPoint:
    """A point that has no run to show: failed, saying why (its budget, its worker's end)."""
    nan = float("nan")
    return WorkPrecisionPoint(scene=scene.name, engine=curve.engine, integrator=curve.integrator, variant=curve.variant,
                              param=float(param), status="failed", message=why, time_s=nan, time_min_s=nan,
                              time_total_s=nan, repeats=0, steps=nan, rhs_evals=nan, nominal_order=curve.nominal_order,
                              **{k: nan for k in ERROR_KEYS})


def _curve_points(scene: Scene, curve: Curve, ladder: list[float], t_end: float, save: float, ref: Trajectory,
                  model, options: SweepOptions, goal, base: float, longer: float):
    """Worker body (``harness.validate.workers.stream_case``): one curve's points down its ladder,
    each yielded as it is measured as ``(point, wall s, stop so far, budget s)``, under the
    curve's budget (``next_cost``) and stop rules (``stop_reason``); last ``(None, 0, stop,
    budget)``. Every point of a curve is measured in this one process, each within the
    stream's per-point budget (``run_timeout_s``); the wall time is measured here, around the
    point alone."""
    history: list[tuple[WorkPrecisionPoint, float]] = []
    spent, stop, budget = 0.0, "end of the ladder", base
    for param in ladder:
        best = min((p.state_max for p, _ in history if p.ok), default=math.inf)
        budget = longer if goal is not None and best > goal and converging(history, curve) else base
        if history and spent + next_cost(history, curve.adaptive, options) > budget:
            stop = f"budget {budget:g} s" + (f" (longer to reach {goal:g})" if budget != base else "")
            break
        settings = _settings(curve, t_end, save, param, adaptive_step(scene, options))
        t0 = _clock()
        point = measure(scene, curve, settings, ref, model, options)
        wall = _clock() - t0
        spent += wall
        yield point, wall, stop, budget
        if point.status == UNSUPPORTED:
            return
        history.append((point, wall))
        stop = stop_reason(history, options) or stop
        if stop != "end of the ladder":
            break
    yield None, 0.0, stop, budget


def sweep_scene(scene: Scene, engines, options: SweepOptions = SweepOptions(), progress: Progress | None = None,
                curve_list: list[Curve] | None = None) -> SceneSweep:
    """Sweep one scene (see the module docstring): the reference, then each curve under its
    budget (``curve_role``, ``role_budget``, ``next_cost``; ``reach_budget_s`` while a target
    curve is still converging towards what it must reach, ``reach``) and stop rules
    (``stop_reason``)."""
    t_end, save = horizon(scene, options)
    model = scene.multibody()
    start = _clock()
    ref, how = run_stage(reference, (scene, t_end, save), "the reference run")
    result = SceneSweep(scene.name, t_end, save, how, reference_checks(scene, ref, t_end, save))
    result.walls["reference"] = _clock() - start
    covered = compiled_covers(scene)[0] if REFERENCE_ENGINE in engines else True
    if curve_list is None:
        curve_list, result.omitted = scene_curves(engines, options, covered)
    from harness.validate.workers import stream_case

    _prepare_workers(scene, curve_list, ref, model)
    start = _clock()
    baseline_best = None  # best state error of MuJoCo RK4's target curve
    for curve in curve_list:
        role = curve_role(curve, result.skipped, covered)
        budget = base = role_budget(role, options)
        goal = reach(curve, role, baseline_best)
        longer = math.inf if options.reach_budget_s is None else max(base, float(options.reach_budget_s))
        ladder = _ladder(curve, save, options, scene.dt)
        history: list[tuple[WorkPrecisionPoint, float]] = []
        spent, stop = 0.0, "end of the ladder"
        stream = stream_case(_curve_points, (scene, curve, ladder, t_end, save, ref, model, options, goal, base, longer),
                             float(options.run_timeout_s))
        for outcome in stream:
            if outcome.status != "ok":  # the point being measured: over its budget, or its worker died
                param = ladder[len(history)] if len(history) < len(ladder) else ladder[-1]
                why = ({"timeout": f"{TIMED_OUT} {float(options.run_timeout_s):g} s (the wall-clock budget of a point, "
                                   "--run-timeout)"}.get(outcome.status, f"{outcome.status}: {outcome.message}"))
                point = failed_point(scene, curve, param, why)
                result.points.append(point)
                history.append((point, outcome.wall_s))
                spent += outcome.wall_s
                stop = why
                break
            point, wall, stop, budget = outcome.value
            if point is None:  # the curve's last word: why it stopped
                break
            spent += wall
            if point.status == UNSUPPORTED:  # not this method's scene: no points, say why
                result.skipped[curve.label] = point.message
                stop = "unsupported"
                break
            result.points.append(point)
            history.append((point, wall))
            if progress is not None:
                progress.advance(1, f"{scene.name}: {curve.label} {point.param:.1e}")
        if progress is not None:
            progress.advance(len(ladder) - len(history), f"{scene.name}: {curve.label} done")
        if role == KEY and curve.engine == BASELINE:
            baseline_best = min((p.state_max for p, _ in history if p.ok), default=None)
        result.curves[curve.label] = {"wall_s": spent, "points": len(history), "stop": stop,
                                      "budget_s": budget, "role": role}
    result.walls["curves"] = _clock() - start
    return result


def _alternate(runners: dict[str, Run], rounds: int, budget_s: float) -> dict[str, list[float]]:
    """Engine times of ``runners`` timed in alternation (A, B, C, A, B, C, ...) after one warm-up
    each: at least 3 rounds (or ``rounds`` if fewer), more up to ``rounds`` while the rounds so
    far took less than ``budget_s`` (s)."""
    for run in runners.values():
        run()  # warm-up
    times: dict[str, list[float]] = {k: [] for k in runners}
    start = time.perf_counter()
    for i in range(max(1, rounds)):
        if i >= min(3, rounds) and time.perf_counter() - start >= budget_s:
            break
        for key, run in runners.items():
            times[key].append(run()[1])
    return times


def head_to_head(scene: Scene, sweep: SceneSweep, options: SweepOptions, targets=TARGETS,
                 rounds: int | None = None) -> list[dict]:
    """At each target state error, the cheapest recorded point of the in-house solver (any
    curve) and of MuJoCo RK4 that reach it (through ``mujoco.rollout``; through the harness's loop
    where rollout does not run the scene), timed again in alternation so that both see the same
    machine load (``_alternate``: ``rounds``, default ``options.h2h_rounds``), with MuJoCo's loop
    at the rollout point's dt as a third; the medians and their ratios. Uses recorded points,
    not interpolation: each run reaches at least the target. ``ratio`` is the in-house time over
    MuJoCo's (``mujoco`` names the variant: "rollout" or "loop"); ``status`` "ok", or which side
    did not reach the target, or why MuJoCo RK4 did not run."""
    rounds = options.h2h_rounds if rounds is None else rounds
    side = "loop" if BASELINE_RK4["rollout"] in sweep.skipped else "rollout"
    out = []
    for target in targets:
        row: dict = {"target": target, BASELINE: side}
        if BASELINE_RK4[side] in sweep.skipped:
            row["status"] = f"{BASE} RK4 not run: {sweep.skipped[BASELINE_RK4[side]]}"
            out.append(row)
            continue
        picks = {}
        for key, pred in ((REFERENCE_ENGINE, lambda p: p.engine == REFERENCE_ENGINE),
                          (BASELINE, lambda p: p.label == BASELINE_RK4[side])):
            cands = [p for p in sweep.points if pred(p) and p.ok and p.state_max <= target]
            if cands:
                picks[key] = min(cands, key=lambda p: p.time_s)
        if len(picks) < 2:
            row["status"] = (NOT_REACHED_EITHER if not picks else
                             NOT_REACHED_BASELINE if REFERENCE_ENGINE in picks else NOT_REACHED_REFERENCE)
            out.append(row)
            continue
        ih, mj = picks[REFERENCE_ENGINE], picks[BASELINE]
        runs = {REFERENCE_ENGINE: (ih, Curve(ih.engine, ih.integrator, ih.variant)),
                BASELINE_RK4[side]: (mj, Curve(BASELINE, "RK4", side))}
        if side == "rollout":  # the harness's loop at the same dt: its overhead at equal error
            runs[BASELINE_RK4["loop"]] = (mj, Curve(BASELINE, "RK4", "loop"))
        max_dt = adaptive_step(scene, options)
        runners = {key: _runner(scene, c, _settings(c, sweep.t_end, sweep.save_every, p.param, max_dt))
                   for key, (p, c) in runs.items()}
        times = _alternate(runners, rounds, options.h2h_budget_s)
        for key, (p, c) in runs.items():
            row[key] = {"label": c.label, "param": p.param, "state_max": p.state_max,
                        "time_s": float(np.median(times[key])), "time_min_s": float(np.min(times[key]))}
        row["rounds"] = len(times[REFERENCE_ENGINE])
        ih_t = row[REFERENCE_ENGINE]["time_s"]
        row["ratio"] = ih_t / row[BASELINE_RK4[side]]["time_s"]
        if side == "rollout":
            row["ratio_rollout"] = row["ratio"]
            row["ratio_loop"] = ih_t / row[BASELINE_RK4["loop"]]["time_s"]
        else:
            row["ratio_loop"] = row["ratio"]
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


def curve_model(points: list[WorkPrecisionPoint], error_floor: float = 1e-12) -> error_model.ErrorModel:
    """The error model of one curve's state error (module docstring; ``harness.judging.error_model``):
    fitted from its finest resolved sound points (up to three, the finest first), kind
    ``adaptive`` with order 1 for an error-controlled method; ``not judged`` where no run ended
    sound (a ladder's blow-ups are at steps beyond the method's stability, not at the scene's: no
    defect is read from them)."""
    nan = float("nan")
    if not points:
        return error_model.not_judged("state_max", "rel", "fixed", nan, "no points", resolution=error_floor)
    method = integrator(points[0].engine, points[0].integrator)
    kind, formal = ("adaptive", 1.0) if method.adaptive else ("fixed", float(method.order))
    ok = sorted((p for p in points if p.ok), key=lambda p: p.param)
    steps = max((p.steps for p in ok if math.isfinite(p.steps)), default=1.0)
    resolution = max(error_floor, error_model.roundoff(steps))
    if not ok:
        levels = tuple(error_model.Level(p.param, nan) for p in sorted(points, key=lambda p: p.param))
        blew = [p.param for p in points if p.status == "blowup"]
        why = (f"every run failed, {len(blew)} blew up (down to {min(blew):.2g}): the ladder has no sound point"
               if blew else "no run ended")
        return error_model.not_judged("state_max", "rel", kind, formal, why, levels, resolution)
    resolved = [p for p in ok if p.state_max > error_model.NOISE * resolution]
    chosen = resolved[:3] if len(resolved) >= 2 else ok[:3]
    return error_model.fit("state_max", "rel", 1.0, kind, formal,
                           [error_model.Level(p.param, p.state_max) for p in chosen], resolution)


def observed_order(points: list[WorkPrecisionPoint], error_floor: float = 1e-12, upper: float = 1e-2) -> dict:
    """One curve's error model (``curve_model``) as the report shows it: ``{"model", "order" (its
    observed order: in the step, or in the tolerance), "n" (levels fitted), "range" (their steps or
    tolerances)}``, plus for adaptive methods ``"tol_slope"`` (the same order in the tolerance)
    and ``"steps_order"`` (the effective order: -slope of log error against log accepted steps
    over the points between ``100 x error_floor`` and ``upper``; NaN with fewer than three)."""
    m = curve_model(points, error_floor)
    params = [lv.step for lv in m.levels if math.isfinite(lv.error)]
    out = {"model": m, "order": m.observed_order, "n": len(params),
           "range": f"{min(params):.2g}..{max(params):.2g}" if len(params) >= 2 else ""}
    if not points or m.kind != "adaptive":
        return out
    out.update(tol_slope=m.observed_order, steps_order=float("nan"))
    good = [p for p in points if p.ok and 100 * error_floor < p.state_max < upper and math.isfinite(p.steps)]
    steps = np.array([p.steps for p in good])
    if len(good) >= 3 and len(set(steps)) >= 3:
        out["steps_order"] = -_fit(steps, np.array([p.state_max for p in good]))
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
    from harness.model import rotations

    join = _reference_part("model").join
    rm = engine_module(BASELINE, "rollout").prepare(scene, scene.dt, "RK4")
    m = rm.m
    rng = np.random.default_rng(seed)
    qpos0, qvel0 = rm.d.qpos.copy(), rm.d.qvel.copy()
    vscale = max(1.0, float(np.max(np.abs(qvel0), initial=0.0)))
    S, Y = [], []
    for _ in range(nbatch):
        qpos = rm.integrate_pos(qpos0, 0.05 * rng.standard_normal(m.nv))
        state = rm.state_from_joints(qpos, qvel0 + 0.05 * vscale * rng.standard_normal(m.nv))
        p, q, v, w_W = rm.read_bodies(state)
        R = rotations.matrix(q).reshape(-1, 3, 3)
        Y.append(join(p, q, v, np.einsum("nji,nj->ni", R, w_W)))
        S.append(state)
    return rm, np.array(S), np.array(Y)


def batch_size(per_trajectory_s: float, options: SweepOptions, threads: int, runs: int = 4, rounds: int = 3) -> int:
    """Trajectories of the timed batch: about ``batch_budget_s / (runs x rounds)`` s for one run of
    the slowest variant (``per_trajectory_s`` s per trajectory, measured), at most ``options.batch``,
    at least one per thread (or ``options.batch`` if smaller); ``options.batch`` without a budget."""
    if options.batch_budget_s is None or not (per_trajectory_s > 0 and math.isfinite(per_trajectory_s)):
        return options.batch
    n = int(options.batch_budget_s / (runs * rounds) / per_trajectory_s)
    return max(min(options.batch, threads), min(options.batch, n))


def batch_benchmark(scene: Scene, nbatch: int, nstep: int, repeats: int = 3, options: SweepOptions | None = None) -> dict:
    """Throughput (trajectory-steps per second) of RK4 over at most ``nbatch`` initial conditions
    for ``nstep`` steps of the scene's dt: ``mujoco.rollout`` against the compiled in-house RK4
    (``rk4_compiled``'s kernel, ``compiled.solver.run_batch``: one trajectory after another on
    each thread), each with the machine's cores as threads and with one thread. All timed in
    alternation: one warm-up each on one trajectory per thread (which also compiles the kernel,
    and sizes the batch, ``batch_size``, under ``options.batch_budget_s``), then ``repeats``
    rounds (past the first only while the rounds took less than the budget; medians). Also the
    largest state difference between the MuJoCo and the in-house batch at the end (relative, as
    ``errors``), over a sample of the trajectories."""
    baseline_rollout = engine_module(BASELINE, "rollout")
    projection_tolerance = _reference_part("").projection_tolerance
    compiled = _reference_part("compiled.solver")
    FIXED_STEP = _reference_part("integrators").FIXED_STEP
    build, to_trajectory = _reference_part("model").build, _reference_part("model").to_trajectory

    options = replace(options or SweepOptions(batch_budget_s=None), batch=nbatch)
    budgeted = options.batch_budget_s is not None
    out: dict = {"scene": scene.name, "nbatch": nbatch, "nstep": nstep, "dt": scene.dt, "method": "RK4"}
    model = scene.multibody()
    threads = baseline_rollout.default_threads()
    k = min(nbatch, threads)
    try:
        rm, S0, Y0 = batch_initial_states(scene, k if budgeted else nbatch)  # row i is the same for any batch size
        nem = build(model)
        _reference_part("").dense_rows(nem)  # the compiled form's own limit, as its runs have it
        packed = compiled.pack(nem)
    except NotImplementedError as err:
        out["status"] = f"skipped: {err}"
        return out
    out["threads"] = threads
    proj_tol = projection_tolerance(nem)
    tableau = FIXED_STEP["rk4_compiled"]
    box: dict = {}

    def runs(S, Y):
        def mj(nthread):
            box["mj"] = rm.run(S, nstep, nthread)

        def jit(nthread):
            box["jit"] = compiled.run_batch(packed, Y, nstep, scene.dt, tableau, threads=nthread, proj_tol=proj_tol)

        return {BASELINE: lambda: mj(threads), f"{BASELINE}_1thread": lambda: mj(1),
                "compiled": lambda: jit(threads), "compiled_1thread": lambda: jit(1)}

    def timed(fn) -> float:
        start = time.perf_counter()
        fn()
        return time.perf_counter() - start

    for fn in runs(S0[:k], Y0[:k]).values():
        fn()  # warm-up (and compilation of the kernel)
    if budgeted:  # calibration: the one-thread variants scale with the batch (threads add a per-call cost)
        c = min(nbatch, 4 * threads)
        if c > len(S0):
            _, S0, Y0 = batch_initial_states(scene, c)
        cal = runs(S0[:c], Y0[:c])
        per_trajectory = max(timed(cal[f"{BASELINE}_1thread"]), timed(cal["compiled_1thread"])) / c
        out["calibration_s_per_trajectory"] = per_trajectory
        nbatch = batch_size(per_trajectory, options, threads, rounds=max(1, repeats))
        if nbatch > len(S0):
            _, S0, Y0 = batch_initial_states(scene, nbatch)  # the first rows as before: the warm model stays
    out["nbatch"] = nbatch
    S0, Y0 = S0[:nbatch], Y0[:nbatch]
    fns = runs(S0, Y0)
    times: dict[str, list[float]] = {key: [] for key in fns}
    start = time.perf_counter()
    for i in range(max(1, repeats)):
        if i and budgeted and time.perf_counter() - start > options.batch_budget_s:
            break
        for key, fn in fns.items():
            times[key].append(timed(fn))
    out["rounds"] = len(times[BASELINE])
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
        ih_traj = to_trajectory(nem, t, np.stack([Y0[i], Yend[i]]), REFERENCE_ENGINE, "rk4_compiled")
        scales = compare.motion_scales(mj_traj, model)
        diffs.append(_state_error(compare.trajectory_error(_take(ih_traj, [1]), _take(mj_traj, [1])), scales))
    out["max_state_difference"] = float(np.nanmax(diffs)) if np.any(np.isfinite(diffs)) else float("nan")
    return out


# ---------------------------------------------------------------------------------------------
# Whole sweep


SCENE_TIMEOUT = 3600.0  # s allowed to one scene's sweep on a Dask worker (a full scene takes minutes)


def scene_study(scene: Scene, engines, options: SweepOptions = SweepOptions(),
                progress: Progress | None = None) -> SceneSweep:
    """One scene's part of ``run_sweep``: its sweep, the head-to-head timing (with MuJoCo and
    the in-house engine) and, unless ``options.batch`` is 0, the batched-throughput benchmark
    (none of them where the scene's ``[not_run]`` names the reference engine and it has no
    closed-form motion, ``closed_form``: no points, and why);
    the wall time of each stage in ``walls`` (``kernels``: loading the compiled kernels first,
    ``warm_kernels``, outside ``total``)."""
    if REFERENCE_ENGINE in scene.not_run and closed_form(scene) is None:  # nothing to measure errors against
        t_end, save = horizon(scene, options)
        return SceneSweep(scene.name, t_end, save, f"none: the {REF} engine does not run this scene "
                                                   f"({scene.not_run[REFERENCE_ENGINE]})")
    kernels_s = warm_kernels([scene]) if REFERENCE_ENGINE in engines else 0.0
    start = time.perf_counter()
    res = sweep_scene(scene, engines, options, progress)
    res.walls["kernels"] = kernels_s
    if BASELINE in engines and REFERENCE_ENGINE in engines:
        if progress is not None:
            progress.advance(0, f"{scene.name}: head to head")
        t0 = time.perf_counter()
        try:
            res.head_to_head = run_stage(head_to_head, (scene, res, options), "the head-to-head timing")
        except Exception as err:  # recorded, not raised
            res.head_to_head = [{"status": f"failed: {type(err).__name__}: {err}"}]
        res.walls["head_to_head"] = time.perf_counter() - t0
    if options.batch and BASELINE in engines and REFERENCE_ENGINE in engines:
        if progress is not None:
            progress.advance(0, f"{scene.name}: batch of up to {options.batch}")
        t0 = time.perf_counter()
        try:
            res.batch = run_stage(batch_benchmark, (scene, options.batch, options.batch_steps, min(3, options.repeats),
                                                    options), "the batch benchmark")
        except Exception as err:  # recorded, not raised
            res.batch = {"scene": scene.name, "status": f"failed: {type(err).__name__}: {err}"}
        res.walls["batch"] = time.perf_counter() - t0
        if progress is not None:
            progress.advance(1, f"{scene.name}: batch done")
    res.walls["total"] = time.perf_counter() - start
    return res


#: Wall-clock budget (s) of a scene's reference run, its head-to-head timing and its batch
#: benchmark, each made in its own worker process (``run_stage``).
STAGE_TIMEOUT = 600.0


def run_stage(fn, args: tuple, what: str):
    """``fn(*args)`` in its own worker process (``harness.validate.workers.run_cases``, forked from
    this one: its imports and compiled kernels come along) under ``STAGE_TIMEOUT``; its value, or
    RuntimeError saying why there is none ("timed out after N s", a crash, the error), which the
    callers record instead of the stage's result. Times are measured inside, around each run."""
    from harness.validate.workers import run_cases

    outcome = run_cases([("stage", fn, args)], 1, STAGE_TIMEOUT)["stage"]
    if outcome.status == "ok":
        return outcome.value
    if outcome.status == "input_error":
        from harness.model.errors import InputError

        raise InputError(outcome.message)
    if outcome.status == "timeout":
        raise RuntimeError(f"{what} {TIMED_OUT} {STAGE_TIMEOUT:g} s")
    raise RuntimeError(f"{what}: {outcome.status}: {outcome.message}")


def warm_kernels(scenes: list[Scene]) -> float:
    """Compile (or load from Numba's cache) the compiled in-house kernels, on the first of
    ``scenes`` the compiled form models, so that no curve's time budget pays for it (once per
    process: later calls only build and pack the model); returns the time it took (s)."""
    start = time.perf_counter()
    try:
        compiled = _reference_part("compiled.solver")
        build, initial_state = _reference_part("model").build, _reference_part("model").initial_state
    except ImportError:  # pragma: no cover - no Numba: the compiled runs say so
        return 0.0
    for scene in scenes:
        try:
            model = scene.multibody()
            nem = build(model)
            packed = compiled.pack(nem)
            y0 = initial_state(model, nem)
        except Exception:  # not modelled (NotImplementedError) or not built: the runs say why
            continue
        for kernel in compiled.KERNELS:
            compiled.warm_up(packed, y0, kernel)
        break
    return time.perf_counter() - start


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
    """All points as a pandas DataFrame (the CSV), each with its curve's error model: ``curve_class``,
    ``curve_order``, ``curve_floor`` (``curve_model`` at the default ``error_floor``)."""
    import pandas as pd

    rows = []
    for r in results:
        models = {label: curve_model(pts) for label, pts in by_curve(r.points).items()}
        for p in r.points:
            d = asdict(p)
            d["label"] = p.label
            m = models[p.label]  # the curve's error model (``curve_model``), on each of its points
            d.update(curve_class=m.classification, curve_order=m.observed_order, curve_floor=m.floor)
            rows.append(d)
    return pd.DataFrame(rows)
