"""``harness debug SCENE --engines A,B``: where two runs of a scene part, quantity by quantity, and
how each engine's error converges.

Both engines run at the scene's default settings exactly as in ``harness validate``: the
in-house DOP853 reference run of the scene (``harness.validate.run.reference_case``; the engine
name ``reference`` is that run) and each engine's case (``engine_case``), whose checks are judged
by how their error converges (``judge_convergence``: the engine rerun at twice the step, and half
where undecided, or an error-controlled one at a 100x looser tolerance; the error model of
``harness.judging.error_model`` and the verdict of ``harness.judging.verdict``). At every saved
time both runs reached, the difference of each quantity, maximised over bodies, is judged as
``harness validate`` judges its ``trajectory.*`` checks (one definition of quantity, scale and
unit: ``harness.judging.quantities``, which the stress and work-precision studies share):

* ``position``: centre-of-mass position difference (m) over the ``length`` scale (rel);
* ``orientation``: geodesic angle on SO(3) (rad, absolute);
* ``velocity``: centre-of-mass velocity difference (m/s) over the ``velocity`` scale (rel);
* ``angular_velocity``: world-frame angular velocity difference (rad/s) over the
  ``angular_velocity`` scale (rel);
* ``energy``: |E_A - E_B| over ``compare.energy_scale`` of the reference run (rel), energies
  recomputed from the common trajectory (``invariants.energies``).

Scales: ``compare.motion_scales`` of the reference run (as in ``validate``), whichever two runs are
compared; with ``reference`` in the pair the largest value of a trajectory quantity is the other
engine's ``trajectory.*`` check in ``validate`` (at the same horizon).

Each quantity's error model, per engine of the pair (``models``): the engine's ``trajectory.<q>``
check (``energy``: its ``energy_drift``, or ``energy_balance`` when a force does work) as
``validate`` judged it: its class, observed order, floor, resolution and verdict. The pair
passes when both runs ended ok and every such check passed (``validate``'s verdicts; the other
checks' failures are listed, not counted). Where the runs part (``first_exceed``): the first
saved time at which the pair's difference exceeds the quantity's ``threshold``, the larger of the
scene's requirement on the check (if it states one) and ``error_model.NOISE`` (10) times the
largest resolution of the pair's checks (below which a difference is noise: round-off, the
reference's accuracy). A quantity whose checks no engine of the pair makes (no
``[checks.trajectory]``; the reference's own trajectory) has no threshold: plotted, not judged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from harness.io import atomic
from harness.measure import compare
from harness.judging import quantities
from harness.measure import invariants
from harness.model import rotations
from harness.engines import ENGINE_NAMES, LOADERS, get_engine
from harness.model.errors import InputError
from harness.io.figures import new_figure, png_bytes
from harness.model.scene import Scene
from harness.measure.trajectory import Trajectory
from harness.judging.error_model import NOISE
from harness.judging.verdict import requirement
from harness.judging import quantities as vq
from harness.judging.checks import REFERENCE_LABEL, CheckResult, run_engine as run_engine_of
from harness.validate.run import default_settings, engine_case, has_reference, reference_case, reference_settings

QUANTITIES = tuple(q.name for q in vq.TRAJECTORY) + ("energy",)
UNITS = {q.name: q.judged_unit for q in vq.TRAJECTORY} | {"energy": "rel"}  # units of the judged values
RAW_UNITS = {q.name: q.unit for q in vq.TRAJECTORY}  # units of the differences before scaling
DEBUG_ENGINES = ENGINE_NAMES + (REFERENCE_LABEL,)


@dataclass
class DebugResult:
    """Error series of one pair of runs, each quantity's error model per engine and where the runs part.

    ``errors``: the judged series per quantity (``UNITS``); ``scales``: the motion scales they are
    over (``compare.motion_scales`` of the reference run: m, m/s, rad/s); ``models``: quantity ->
    engine -> the engine's check of that quantity as ``validate`` judged it (class, order, floor,
    resolution, verdict; ``QUANTITY_CHECKS``); ``thresholds``: quantity -> the difference beyond
    which the runs part (module docstring), None where no check judges it; ``first_exceed``: the
    first saved time (s) the difference exceeds it, None where it never does; ``other_failures``:
    the pair's failing checks other than the quantities'."""

    scene: Scene
    engines: tuple[str, str]
    runs: tuple[Trajectory, Trajectory]
    t: np.ndarray
    errors: dict[str, np.ndarray]
    models: dict[str, dict[str, CheckResult]]
    thresholds: dict[str, float | None]
    first_exceed: dict[str, float | None] = field(default_factory=dict)
    scales: dict[str, float] = field(default_factory=dict)
    other_failures: list[CheckResult] = field(default_factory=list)

    def worst(self, q: str) -> float:
        """The largest judged value of quantity ``q`` over the shared samples (``UNITS[q]``)."""
        return float(np.max(self.errors[q], initial=0.0))

    def passed_quantity(self, q: str) -> bool:
        """Every check of the pair that judges ``q`` passed (True where none does)."""
        return all(c.passed for c in self.models.get(q, {}).values())

    @property
    def passed(self) -> bool:
        """Both runs ended ok and every check of the quantities passed (``validate``'s verdicts)."""
        return all(r.ok for r in self.runs) and all(self.passed_quantity(q) for q in QUANTITIES)

    @property
    def first_index(self) -> int | None:
        """Index of the earliest saved time at which any quantity's difference exceeds its threshold."""
        times = [t for t in self.first_exceed.values() if t is not None]
        return int(np.searchsorted(self.t, min(times))) if times else None


#: The check of each engine that judges each quantity (``energy``: the first of these it makes).
QUANTITY_CHECKS = {q.name: (q.check,) for q in vq.TRAJECTORY} | {"energy": ("energy_drift", "energy_balance")}


def parse_engines(text: list[str]) -> tuple[str, str]:
    """Two distinct engine names from ``--engines A,B``."""
    if len(text) != 2 or text[0] == text[1]:
        raise InputError(f"--engines needs two different engines, e.g. {','.join(LOADERS[:2])} "
                         f"(got {','.join(text) or 'none'})")
    for e in text:
        if e not in DEBUG_ENGINES:
            raise InputError(f"unknown engine {e!r} (known: {', '.join(DEBUG_ENGINES)})")
    return text[0], text[1]


def run_engine(scene: Scene, engine: str, t_end: float | None, fast: bool = True) -> Trajectory:
    """One run at the scene's default settings (horizon ``t_end`` if given; with ``fast`` the
    in-house runs use their methods' compiled twins where they apply, as ``validate``);
    InputError for an engine the scene excludes (``[not_run]``)."""
    if engine in scene.not_run:
        raise InputError(f"{engine} does not run {scene.name}: {scene.not_run[engine]}")
    settings = reference_settings(scene, fast) if engine == "reference" else default_settings(scene, engine, fast)
    if t_end is not None:
        settings = replace(settings, t_end=t_end)
    return get_engine(run_engine_of(engine)).simulate(scene, settings)


def error_series(a: Trajectory, b: Trajectory, model, scales: dict[str, float] | None = None,
                 energy_scale: float | None = None) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Saved times both runs reached and the per-time judged value of each quantity (``UNITS``):
    the trajectory quantities over ``scales`` (default: ``compare.motion_scales`` of ``a``) as
    ``harness.judging.quantities`` defines them (``judged_series``), and the energy difference over
    ``energy_scale`` (J; default: ``compare.energy_scale`` of ``a``)."""
    if scales is None:
        scales = compare.motion_scales(a, model)
    n = min(len(a.t), len(b.t))
    t = a.t[:n]
    errors = quantities.judged_series(a, b, scales, n)
    if n:
        ea = invariants.energies(_head(a, n), model)["energy"]
        eb = invariants.energies(_head(b, n), model)["energy"]
        scale = energy_scale if energy_scale is not None else compare.energy_scale(_head(a, n), model)
        errors["energy"] = np.abs(ea - eb) / scale
    else:
        errors["energy"] = np.zeros(0)
    return t, errors


def _head(traj: Trajectory, n: int) -> Trajectory:
    return replace(traj, t=traj.t[:n], p_WCm_W=traj.p_WCm_W[:n], quat_WB=traj.quat_WB[:n],
                   v_WCm_W=traj.v_WCm_W[:n], w_WB_W=traj.w_WB_W[:n], engine_energy={})


def quantity_checks(checks: list[CheckResult]) -> dict[str, CheckResult]:
    """Quantity -> the check among ``checks`` (one run's, judged) that judges it (``QUANTITY_CHECKS``)."""
    by_name = {c.check: c for c in checks}
    out = {}
    for q, names in QUANTITY_CHECKS.items():
        found = next((by_name[n] for n in names if n in by_name), None)
        if found is not None:
            out[q] = found
    return out


def threshold(scene: Scene, judged: dict[str, CheckResult]) -> float | None:
    """Where a quantity's difference counts as parting (module docstring): the larger of the
    scene's requirement on the check and ``NOISE`` times the largest resolution of ``judged``
    (engine -> its check of the quantity); None where no check of it has a resolution."""
    resolutions = [c.resolution for c in judged.values() if math.isfinite(c.resolution)]
    if not resolutions:
        return None
    bound = NOISE * max(resolutions)
    reqs = [requirement(scene, c.check) for c in judged.values()]
    return max([bound] + [r for r in reqs if math.isfinite(r)])


def debug(scene: Scene, engines: tuple[str, str], t_end: float | None = None, fast: bool = True) -> DebugResult:
    """Run the reference and both engines as ``validate`` does (each engine's checks judged by
    how its error converges), and find where each quantity's difference first exceeds its
    threshold. InputError for an engine the scene excludes (``[not_run]``)."""
    for e in engines:
        if e in scene.not_run or (e == REFERENCE_LABEL and not has_reference(scene)):
            raise InputError(f"{e} does not run {scene.name}: {scene.not_run[run_engine_of(e)]}")
    if t_end is not None:
        scene = replace(scene, t_end=float(t_end))
    model = scene.multibody()
    ref, ref_checks, solutions = None, [], None  # no reference run: the engines judged without one (validate's)
    if has_reference(scene):
        ref, _, ref_checks, solutions = reference_case(scene, fast)
    runs, checks = [], {}
    for e in engines:
        if e == REFERENCE_LABEL:
            runs.append(ref)
            checks[e] = ref_checks
        else:
            traj, _, own, _ = engine_case(scene, e, ref, fast, solutions)
            runs.append(traj)
            checks[e] = own
    a, b = runs
    judge = ref if ref is not None and ref.ok and len(ref.t) else a
    if len(judge.t):
        scales = compare.motion_scales(judge, model)
        energy_scale = compare.energy_scale(judge, model)
    else:
        scales, energy_scale = {"length": 1.0, "velocity": 1.0, "angular_velocity": 1.0}, 1.0
    t, errors = error_series(a, b, model, scales, energy_scale)
    models: dict[str, dict[str, CheckResult]] = {q: {} for q in QUANTITIES}
    for e in engines:
        for q, c in quantity_checks(checks[e]).items():
            models[q][e] = c
    judged_names = {n for names in QUANTITY_CHECKS.values() for n in names}
    others = [c for e in engines for c in checks[e] if not c.passed and c.check not in judged_names]
    res = DebugResult(scene, engines, (a, b), t, errors, models, {q: threshold(scene, models[q]) for q in QUANTITIES},
                      scales=scales, other_failures=others)
    for q in QUANTITIES:
        res.first_exceed[q] = None
        bound = res.thresholds[q]
        if bound is not None:
            bad = np.flatnonzero(~(errors[q] <= bound))
            if bad.size:
                res.first_exceed[q] = float(t[bad[0]])
    return res


_SCALE_UNITS = {"length": "m", "velocity": "m/s", "angular_velocity": "rad/s"}


def state_dump(res: DebugResult, k: int) -> list[str]:
    """Both runs' maximal states, all bodies, at sample ``k`` (world frame, SI units)."""
    lines = [f"states at t = {res.t[k]:.6g} s (centre-of-mass position m, quaternion body->world wxyz, "
             "centre-of-mass velocity m/s, angular velocity rad/s world):"]
    for i, body in enumerate(res.runs[0].body_names):
        for e, tr in zip(res.engines, res.runs):
            lines.append(f"  {body:<8} {e:<10} p {_v(tr.p_WCm_W[k, i])} q {_v(tr.quat_WB[k, i])} "
                         f"v {_v(tr.v_WCm_W[k, i])} w {_v(tr.w_WB_W[k, i])}")
        a, b = res.runs
        lines.append(f"  {body:<8} {'difference':<10} |dp| {np.linalg.norm(a.p_WCm_W[k, i] - b.p_WCm_W[k, i]):.3e} m, "
                     f"angle {float(rotations.geodesic_angle(a.quat_WB[k, i], b.quat_WB[k, i])):.3e} rad, "
                     f"|dv| {np.linalg.norm(a.v_WCm_W[k, i] - b.v_WCm_W[k, i]):.3e} m/s, "
                     f"|dw| {np.linalg.norm(a.w_WB_W[k, i] - b.w_WB_W[k, i]):.3e} rad/s")
    return lines


def _v(x) -> str:
    return "[" + ", ".join(f"{float(c): .12g}" for c in x) + "]"


def _num(x: float, fmt: str = ".2e") -> str:
    return "-" if not math.isfinite(x) else format(x, fmt)


def model_line(engine: str, c: CheckResult) -> str:
    """One engine's error model of one quantity: its check's class, order, floor, resolution,
    verdict and why (``validate``'s ``judge_convergence``)."""
    verdict = "passes" if c.passed else "FAILS"
    if not c.classification:
        return f"{engine}: {c.check} {verdict}, not judged by convergence ({' '.join(c.detail.split())})"
    return (f"{engine}: {c.check} {c.classification}, {verdict} ({_num(c.value)} {c.unit} at the scene's step; "
            f"order {_num(c.order, '.2f')}, floor {_num(c.floor)}, resolution {_num(c.resolution)} {c.unit}): "
            f"{' '.join(c.judged.split())}")


def _threshold_kind(res: DebugResult, q: str) -> str:
    """What a quantity's threshold is: a requirement of the scene, or 10x the resolution."""
    bound = res.thresholds[q]
    reqs = [requirement(res.scene, c.check) for c in res.models[q].values()]
    return "the scene's requirement" if bound is not None and bound in reqs else f"{NOISE:g}x the resolution"


def summary(res: DebugResult) -> list[str]:
    """What ``harness debug`` prints: runs, per quantity its largest difference, where the runs
    part and each engine's error model, other failing checks, and the state dump."""
    a, b = res.engines
    lines = [f"debug {res.scene.name}: {a} vs {b}, {len(res.t)} shared samples up to t = {res.t[-1] if len(res.t) else 0:.6g} s"]
    for e, tr in zip(res.engines, res.runs):
        lines.append(f"  {e}: {tr.engine}/{tr.integrator}, {len(tr.t)} samples, status {tr.status}"
                     + (f" ({tr.message})" if tr.message else ""))
    lines.append("  differences judged as validate's trajectory.* checks (harness.judging.quantities): rel = over the "
                 "motion scales of the reference run: "
                 + ", ".join(f"{k} {v:.3g} {_SCALE_UNITS[k]}" for k, v in res.scales.items())
                 + "; each engine's error model as validate's judge_convergence judges its check")
    for q in QUANTITIES:
        bound = res.thresholds[q]
        worst = res.worst(q)
        spec = vq.BY_NAME.get(q)
        raw = f" ({worst * res.scales[spec.scale]:.3e} {spec.unit})" if spec is not None and spec.scale and res.scales else ""
        verdict = "" if not res.models[q] else (": passes" if res.passed_quantity(q) else ": FAILS")
        if bound is None:
            where = "not judged (no check of the pair judges it)"
        elif res.first_exceed[q] is None:
            where = f"stays within {bound:.1e} {UNITS[q]} ({_threshold_kind(res, q)})"
        else:
            where = f"parts beyond {bound:.1e} {UNITS[q]} ({_threshold_kind(res, q)}) at t = {res.first_exceed[q]:.6g} s"
        lines.append(f"  {q:<17} max {worst:.3e} {UNITS[q]}{raw}; {where}{verdict}")
        for e, c in res.models[q].items():
            lines.append(f"      {model_line(e, c)}")
    if res.other_failures:
        lines.append("  other failing checks of the pair (validate's verdicts; not counted here): "
                     + "; ".join(f"{c.engine} {c.check} [{c.classification or 'not judged'}]" for c in res.other_failures))
    k = res.first_index
    if k is not None:
        lines += state_dump(res, k)
    return lines


def plot_png(res: DebugResult) -> bytes:
    """Difference against time per quantity (log y), the threshold dashed, each engine's floor
    dotted where it has one, the first time past the threshold a dotted vertical; each panel
    names the engines' classes."""
    fig = new_figure(8, 2.0 * len(QUANTITIES), tight_layout=True)
    axes = fig.subplots(len(QUANTITIES), 1, sharex=True)
    for ax, q in zip(axes, QUANTITIES):
        err = np.where(res.errors[q] > 0, res.errors[q], np.nan)
        if np.any(np.isfinite(err)):
            ax.semilogy(res.t, err, lw=1.0, label=f"|{res.engines[0]} - {res.engines[1]}|")
        else:
            ax.set_yscale("log")
            ax.text(0.5, 0.5, "identical", transform=ax.transAxes, ha="center")
        if res.thresholds[q] is not None:
            ax.axhline(res.thresholds[q], color="r", ls="--", lw=0.8, label=_threshold_kind(res, q))
        for e, c in res.models[q].items():
            if math.isfinite(c.floor) and c.floor > 0:
                ax.axhline(c.floor, color="0.4", ls=":", lw=0.8, label=f"{e}'s floor")
        if res.first_exceed.get(q) is not None:
            ax.axvline(res.first_exceed[q], color="k", ls=":", lw=0.8)
        classes = "; ".join(f"{e}: {c.classification or 'not judged'}{'' if c.passed else ' (FAILS)'}"
                            for e, c in res.models[q].items())
        if classes:
            ax.set_title(classes, fontsize="small", loc="right")
        ax.set_ylabel(f"{q}\n({UNITS[q]})")
        ax.legend(loc="lower right", fontsize="small")
    axes[-1].set_xlabel("t (s)")
    axes[0].set_title(f"{res.scene.name}: {res.engines[0]} vs {res.engines[1]}", loc="left")
    return png_bytes(fig, dpi=100)


def write_plot(res: DebugResult, out_dir: Path) -> Path:
    path = Path(out_dir) / f"debug_{res.scene.name}_{res.engines[0]}_{res.engines[1]}.png"
    atomic.write_bytes(path, plot_png(res))
    return path
