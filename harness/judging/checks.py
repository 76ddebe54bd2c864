"""The checks of one run and how each is judged: what ``harness validate`` (and ``sweep``,
``debug``) measure of a run, and the verdict on each from how its error converges.

``check_run`` makes the checks a scene declares (``[checks.*]`` of its ``scene.toml``) on one run:

* ``energy_drift`` (unforced; over the reference run's energy scale) or ``energy_balance``
  (forced: E - E0 - work of the forces, the quadrature's own error its resolution);
* ``momentum_drift.<c>`` for each conserved component the scene lists;
* ``trajectory.position/orientation/velocity/angular_velocity`` against the reference run (the
  quantities and their scales: ``harness.judging.quantities``);
* ``constraint.position/axis``, joint violations from maximal coordinates;
* ``closure.*`` (loop scenes): the cut joints' gap, axis, relative velocity and rate;
* ``exact``: against the scene's closed-form solution (``harness.measure.exact``);
* ``reaction.force/moment`` against the reference run's reactions, ``reaction.exact`` against the
  exact support force where one exists;
* ``slip``, ``contact_height``, ``contact_force`` (rolling contacts,
  ``harness.measure.contact_metrics``);
* ``engine_energy``: the engine's own energy against the harness's recomputation.

Each value is bounded only by the scene's requirement (``verdict.requirement``: ``inf`` where it
states none). ``judge_convergence`` then repeats the run at a second level (and a third where
needed: ``refinement``), makes the same checks there, fits each check's error model
(``error_model``) and gives its verdict (``verdict``); ``extrapolated_difference`` compares two
engines once their steps are extrapolated away.

The reference run (``REFERENCE_LABEL``) is the in-house engine's (``REFERENCE_ENGINE``)
high-accuracy run that judges the others' trajectories and reactions.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from harness.engines import REFERENCE_ENGINE, get_engine, integrator
from harness.engines.base import RunSettings
from harness.judging import error_model, refinement
from harness.judging.verdict import ModelDifference, judge, requirement
from harness.measure import compare, contact_metrics, exact
from harness.measure.invariants import mark_non_finite
from harness.judging.quantities import TRAJECTORY
from harness.measure.trajectory import Trajectory
from harness.model import forces
from harness.model.errors import InputError
from harness.model.scene import Scene

REFERENCE_LABEL = "reference"   # the in-house DOP853 run that judges trajectories
# REFERENCE_ENGINE, the engine it runs on, is the registry's (``harness.engines``)


def run_engine(label: str) -> str:
    """The engine a run's label runs on (``reference`` -> the in-house engine)."""
    return REFERENCE_ENGINE if label == REFERENCE_LABEL else label


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
    # the check's error model (harness.judging.error_model): its class, the observed order, the
    # floor that does not vanish with the step and the resolution, in ``unit``; "" / NaN where not judged
    classification: str = ""
    order: float = float("nan")
    floor: float = float("nan")
    resolution: float = float("nan")
    judged: str = ""
    levels: tuple = ()  # ((step s, or tolerance), value) of each level, the scene's first


def check_run(scene: Scene, label: str, engine: str, traj: Trajectory, ref: Trajectory | None,
              settings: RunSettings) -> list[CheckResult]:
    """The checks of one run; ``label`` names it in the report. Each check's value is bounded
    only by the scene's requirement for it (``requirement``: ``inf`` where none): whether the
    run agrees with the physics is ``judge_convergence``'s verdict, from the same checks at
    further levels. A non-finite value fails here already."""
    model = scene.multibody()
    checks = scene.checks
    out: list[CheckResult] = []

    def add(check, value, unit, detail="", resolution=float("nan")):
        tol = requirement(scene, check)
        ok = bool(np.isfinite(value) and value <= tol)
        out.append(CheckResult(scene.name, label, check, float(value), float(tol), unit, ok, detail,
                               resolution=float(resolution)))

    traj = mark_non_finite(traj, model)  # any engine: a state or invariant that overflowed is never "ok"
    if not traj.ok:  # "unsupported": the scene's own integrator for this engine cannot run it, a configuration error
        why = " (bad configuration: see [integrators] in scene.toml)" if traj.unsupported else ""
        out.append(CheckResult(scene.name, label, "run", float("nan"), 0.0, "", False, f"{traj.status}: {traj.message}{why}"))
        return out
    if "energy_drift" in checks:
        if forces.does_work(model):
            balance, quad = compare.energy_balance(traj, model)
            add("energy_balance", balance, "rel", f"E - E0 - W(t) over the energy scale; quadrature error of W ~{quad:.1e}",
                resolution=quad)
        else:
            add("energy_drift", compare.energy_drift(traj, model, ref if ref is not None and ref.ok else None), "rel",
                "max |E - E0| / energy scale (of the reference run)")
    if "momentum_drift" in checks:
        spec = checks["momentum_drift"]
        for comp, value in compare.momentum_drift(traj, model, spec["components"]).items():
            add(f"momentum_drift.{comp}", value, "rel", "max |c - c0| / momentum scale")
    if "trajectory" in checks and ref is not None:
        if not ref.ok:
            out.append(CheckResult(scene.name, label, "trajectory", float("nan"), 0.0, "", False,
                                   f"reference run {ref.status}: {ref.message}"))
        else:
            err = compare.trajectory_error(traj, ref)
            scales = compare.motion_scales(ref, model)
            for q in TRAJECTORY:
                raw = err[f"{q.name}_max"]
                add(q.check, q.judged(raw, scales), q.judged_unit,
                    q.detail(raw, scales))
    if "constraint" in checks:
        viol = compare.constraint_violation(traj, model)
        add("constraint.position", viol["position"], "m", "joint points coincide")
        what = compare.angular_conditions(model)  # e.g. "hinge axes stay aligned" (joint table)
        if what:
            add("constraint.axis", viol["axis"], "rad", ", ".join(what))
    if "closure" in checks:
        _check_closure(traj, model, add)
    if "exact" in checks:
        try:
            value, unit, detail = exact.exact_error(scene, traj, settings, run=get_engine(engine).simulate)
        except InputError:
            raise
        except Exception as err:  # a failing modal run etc. is a failed check, not a crash
            value, unit, detail = float("nan"), "", f"{type(err).__name__}: {err}"
        add("exact", value, unit, detail)
    if "reaction" in checks:
        _check_reactions(scene, label, engine, traj, ref, model, add)
    if model.contacts:  # rolling contacts: slip, contact height, contact force (harness.measure.contact_metrics)
        contact_metrics.add_checks(scene, traj, ref, model, add)
    mismatch = compare.engine_energy_mismatch(traj, model)
    if mismatch is not None:
        add("engine_energy", mismatch, "rel", "engine's own energy vs harness recomputation")
    return out


def _check_closure(traj: Trajectory, model, add) -> None:
    """``closure.position`` (m) and ``closure.velocity`` (m/s): the largest gap and relative
    velocity of the cut joints' points (``compare.loop_closure``), and for hinges ``closure.axis``
    (rad) and ``closure.axis_rate`` (rad/s); the detail names the worst cut joint."""
    found = compare.loop_closure(traj, model)
    if not found:
        add("closure.position", float("nan"), "",
            "the scene has [checks.closure] but no loop joints")
        return
    units = {"position": "m", "axis": "rad", "velocity": "m/s", "axis_rate": "rad/s"}
    texts = {"position": "cut points coincide", "axis": "cut hinge axes stay aligned",
             "velocity": "cut points move together", "axis_rate": "relative rotation only about the cut hinge axis"}
    for kind, unit in units.items():
        values = {name: res[kind] for name, res in found.items() if kind in res}
        if not values:
            continue
        worst = max(values, key=lambda n: values[n])
        add(f"closure.{kind}", values[worst], unit,
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
    traj, ref = _joint_reactions_only(traj, model), None if ref is None else _joint_reactions_only(ref, model)
    if not traj.reactions:
        add("reaction", float("nan"), "", f"{traj.engine} gave no joint reactions")
        return
    judge = ref if ref is not None and ref.ok and ref.reactions else traj
    f_scale, m_scale = compare.reaction_scales(judge, model)
    normal, part = None, ""
    if model.loops:  # redundant loop rows: only the determinate part of each reaction is the engines' to agree on
        normal = compare.plane_normal(model)
        if normal is None:
            add("reaction", float("nan"), "", "the loops' redundant rows leave the reactions indeterminate and the "
                "mechanism is not planar: no determinate part to compare")
            return
        part = "; in-plane force and moment about the plane normal (the determinate part with redundant loop rows)"
    if ref is not None and ref.ok:
        err = compare.reaction_error(traj, ref, normal)
        add("reaction.force", err["force_max"] / f_scale, "rel",
            f"{err['force_max']:.2e} N over force scale {f_scale:.3g} N; vs the reference's multipliers{part}")
        add("reaction.moment", err["moment_max"] / m_scale, "rel",
            f"{err['moment_max']:.2e} N m over moment scale {m_scale:.3g} N m; about the joint point{part}")
    try:
        found = exact.exact_reaction(scene, traj)
    except Exception as err:  # noqa: BLE001 - a failing reference is a failed check, not a crash
        found = (float("nan"), f"{type(err).__name__}: {err}")
    if found is not None:
        value, detail = found
        add("reaction.exact", value / f_scale, "rel", f"{value:.2e} N over force scale {f_scale:.3g} N; {detail}")


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


#: Checks judged against the reference run: their resolution includes the reference's own
#: accuracy (``stats["accuracy"]`` of the reference run).
AGAINST_REFERENCE = ("trajectory.", "reaction.force", "reaction.moment", "contact_force")


def judge_convergence(scene: Scene, label: str, engine: str, settings: RunSettings, traj: Trajectory,
                      ref: Trajectory | None, checks: list[CheckResult]) -> tuple[list[CheckResult], Trajectory | None]:
    """Each check of one run judged by its error model (``harness.judging``).

    The run is repeated at a coarser step (2x; the finer h/2 where that cannot be made or does
    not run to the end), and at the next finer step where the finest two levels leave a check's
    class undecided (a coarse level may be pre-asymptotic), or, error-controlled, at a looser
    tolerance; every level is judged by the same checks against the same reference (on
    the level's sample grid), and each check's values are fitted (observed order, floor,
    resolution, class) and given their verdict (``harness.judging.verdict.judge``: the scene's
    declared model difference for ``engine``, or its closed form's for ``exact``, and its
    requirement). The reference run (``ref`` None) records on its trajectory its accuracy
    against its looser level (``stats["accuracy"]``, and its own ``exact`` value: how far the
    closed form as computed can be trusted), the resolution of every check made against it.

    A run whose every check sits at its resolution already converges: no second level is made.

    Returns the checks with their classes and verdicts, and the run of the second level (2 h, or
    the looser tolerance; None where it did not run), from which ``validate`` extrapolates the
    engines' differences from one another."""
    if not traj.ok or not checks:
        return checks, None
    method = integrator(REFERENCE_ENGINE if label == REFERENCE_LABEL else engine, settings.integrator)
    model = scene.multibody()
    run = get_engine(engine).simulate
    judged = {c.check: c for c in checks if c.check != "run" and np.isfinite(c.value)}
    base = refinement.level_of(settings, method.adaptive)
    levels = {name: [error_model.Level(base, c.value)] for name, c in judged.items()}
    runs: list[Trajectory] = []
    scales = compare.motion_scales(ref if ref is not None and ref.ok else traj, model)
    if label == REFERENCE_LABEL and "exact" in judged:
        traj.stats.setdefault("accuracy", {})["exact"] = judged["exact"].value

    def measure(s: RunSettings | None) -> bool:
        """Run one more level and add its values; False where it cannot be made or fails."""
        if s is None:
            return False
        try:
            other = mark_non_finite(run(scene, s), model)
        except InputError:
            return False  # e.g. a finer level beyond the step budget
        if not other.ok:
            return False
        grid = refinement.on_grid(ref, other.t)
        if ref is not None and grid is None:
            return False
        values = {c.check: c.value for c in check_run(scene, label, engine, other, grid, s)}
        if label == REFERENCE_LABEL and method.adaptive:  # the reference against its looser self
            diff = compare.trajectory_error(other, traj)
            traj.stats.setdefault("accuracy", {}).update(
                {q.check: float(q.judged(diff[f"{q.name}_max"], scales)) / np.sqrt(error_model.LOOSER)
                 for q in TRAJECTORY})
        for name, lv in levels.items():
            lv.append(error_model.Level(refinement.level_of(s, method.adaptive), float(values.get(name, np.nan))))
        runs.append(other)
        return True

    steps = float(traj.stats.get("steps") or settings.t_end / settings.dt)
    accuracy = ref.stats.get("accuracy", {}) if ref is not None else {}
    unit_scales = {name: _unit_scale(c.unit, scales) for name, c in judged.items()}
    resolutions = {}
    for name, c in judged.items():
        scale = unit_scales[name]
        res = max(error_model.roundoff(steps, scale), error_model.JUDGING_RESOLUTION * scale)
        if np.isfinite(c.resolution):  # what the check's own measurement resolves (a quadrature)
            res = max(res, c.resolution)
        if name.startswith(AGAINST_REFERENCE) or name == "exact":
            res = max(res, float(accuracy.get(name, 0.0)) * (1.0 if c.unit in ("rel", "rad") else scale))
        resolutions[name] = res
    # a run whose every check already sits at its resolution converges whatever a second level
    # shows (``error_model.fit``): none is made (the reference always makes one: its accuracy)
    at_resolution = label != REFERENCE_LABEL and all(c.value <= resolutions[name] for name, c in judged.items())
    finer = [0.5, 0.25]  # finer levels, taken in turn where the class is undecided
    if at_resolution:
        finer = []
    elif method.adaptive:
        measure(refinement.looser(settings))
        finer = []
    elif not measure(refinement.scaled_step(settings, 2.0)) and measure(refinement.scaled_step(settings, 0.5)):
        finer = [0.25]
    declared = scene.model_differences.get(engine)
    declared = None if declared is None or label == REFERENCE_LABEL else ModelDifference(declared["model"], declared["bound"])
    # a finer level where the class is undecided; not for an engine whose model the scene declares
    # different: its soft model follows the step (its order is not the integrator's), so a finer
    # level decides nothing its verdict needs (the size of its floor, or of its error, against the bound)
    if finer and declared is None and any(error_model.needs_finer_level(lv, method.order_of(name), resolutions[name])
                                          for name, lv in levels.items()):
        measure(refinement.scaled_step(settings, finer[0]))
    closed_form = exact.declared_floor(scene)
    closed_form = None if closed_form is None else ModelDifference(closed_form[1], closed_form[0])
    out = []
    for c in checks:
        if c.check not in judged:
            out.append(c)
            continue
        m = error_model.fit(c.check, c.unit, unit_scales[c.check], method.kind,
                            1.0 if method.adaptive else method.order_of(c.check), levels[c.check], resolutions[c.check])
        expected = closed_form if c.check == "exact" and closed_form is not None else declared
        v = judge(m, expected, c.tolerance)
        out.append(replace(c, passed=v.passed, classification=v.label, order=m.observed_order, floor=m.floor,
                           resolution=m.resolution, judged=v.detail,
                           levels=tuple((lv.step, lv.error) for lv in m.levels)))
    return out, (runs[0] if runs else None)


def extrapolated_difference(scene: Scene, a: tuple, b: tuple, ref: Trajectory | None) -> dict[str, float]:
    """Two engines' trajectory difference extrapolated to zero step: ``a`` and ``b`` are
    ``(the method's Integrator, run at the scene's level, run at the second level or None)``. Each engine's run is
    extrapolated sample by sample from its two levels (``refinement.richardson``: fixed step at
    ``2^order``, error-controlled at ``LOOSER``), and the two extrapolated runs compared: the
    largest difference of each judged trajectory quantity (``TRAJECTORY``, over the
    reference's motion scales), what remains between the two engines' physics once their steps
    are gone (a floor of one of them: its model difference). A run without a second level (it sat
    at its resolution) is taken as it is. Empty where a common grid is missing."""
    (ea, a1, a2), (eb, b1, b2) = a, b
    if ref is None or not ref.ok:
        return {}
    model = scene.multibody()
    scales = compare.motion_scales(ref, model)
    runs = []
    for method, first, second in ((ea, a1, a2), (eb, b1, b2)):
        rate = error_model.LOOSER if method.adaptive else 2.0 ** method.order
        # the second level is coarser (2 h, a looser tolerance), or the finer h / 2 where 2 h could not run
        if second is None:  # no second level: the run was at its resolution (or its second level failed)
            runs.append(first)
            continue
        fine, coarse = (second, first) if _finer(second, first) else (first, second)
        runs.append(refinement.richardson(fine, coarse, rate))
    if None in runs:
        return {}
    coarse, fine = sorted(runs, key=lambda r: len(r.t))  # compared on the coarser run's saved times
    fine = refinement.on_grid(fine, coarse.t)
    if fine is None:
        return {}
    d = compare.trajectory_error(coarse, fine)
    return {q.check: float(q.judged(d[f"{q.name}_max"], scales)) for q in TRAJECTORY if f"{q.name}_max" in d}


def _finer(second: Trajectory, first: Trajectory) -> bool:
    """Whether the second level's run took more steps than the first's (it was the finer h/2)."""
    return float(second.stats.get("steps") or 0) > float(first.stats.get("steps") or 0)


def _unit_scale(unit: str, scales: dict[str, float]) -> float:
    """The scale of a check's unit in a run (``compare.motion_scales``): 1 for ``rel`` and ``rad``."""
    return {"m": scales["length"], "m/s": scales["velocity"], "rad/s": scales["angular_velocity"]}.get(unit, 1.0)
