"""``harness debug SCENE --engines A,B``: where two runs of a scene part, quantity by quantity.

Both engines run at the scene's default settings (``harness.validate.run.default_settings``; the
engine name ``reference`` is the in-house DOP853 reference run of ``validate``). At every saved
time both have reached, the difference of each quantity, maximised over bodies, judged exactly as
``harness validate`` judges its ``trajectory.*`` checks (one definition of quantity, scale and
unit: ``harness.measure.quantities``, which the stress and work-precision studies share; one of
tolerance: ``harness.validate.quantities``):

* ``position``: centre-of-mass position difference (m) over the ``length`` scale (rel);
* ``orientation``: geodesic angle on SO(3) (rad, absolute);
* ``velocity``: centre-of-mass velocity difference (m/s) over the ``velocity`` scale (rel);
* ``angular_velocity``: world-frame angular velocity difference (rad/s) over the
  ``angular_velocity`` scale (rel), with the velocity tolerance;
* ``energy``: |E_A - E_B| / ``compare.energy_scale`` of run A (rel), energies recomputed from the
  common trajectory (``invariants.energies``).

Scales: ``compare.motion_scales`` of the judging run, the reference when one of the two is
``reference`` (as in ``validate``), else run A. Tolerances: with ``reference`` in the pair, the
other engine's ``[checks.trajectory]`` tolerance, so the largest value and the verdict are
``validate``'s ``trajectory.*`` check of that engine (at the same horizon); for two engines, the
larger of their two tolerances (each engine within its own of the reference allows their sum;
this is stricter). Energy: the sum of the two engines' ``energy_drift`` tolerances (what the
difference may reach when each run holds its own drift check; ``reference`` uses the in-house
tolerance). A quantity without a tolerance is plotted, not judged.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from harness.io import atomic
from harness.measure import compare
from harness.measure import invariants, quantities
from harness.model import rotations
from harness.engines import ENGINE_NAMES, get_engine
from harness.model.errors import InputError
from harness.io.figures import new_figure, png_bytes
from harness.model.scene import Scene
from harness.measure.trajectory import Trajectory
from harness.validate import quantities as vq
from harness.validate.run import default_settings, reference_settings

QUANTITIES = tuple(q.name for q in vq.TRAJECTORY) + ("energy",)
UNITS = {q.name: q.judged_unit for q in vq.TRAJECTORY} | {"energy": "rel"}  # units of the judged values
RAW_UNITS = {q.name: q.unit for q in vq.TRAJECTORY}  # units of the differences before scaling
DEBUG_ENGINES = ENGINE_NAMES + (vq.REFERENCE_LABEL,)


@dataclass
class DebugResult:
    """Error series of one pair of runs and where each leaves its tolerance.

    ``errors``: the judged series per quantity (``UNITS``); ``scales``: the motion scales they are
    over (``compare.motion_scales`` of the judging run: m, m/s, rad/s)."""

    scene: Scene
    engines: tuple[str, str]
    runs: tuple[Trajectory, Trajectory]
    t: np.ndarray
    errors: dict[str, np.ndarray]
    tolerances: dict[str, float | None]
    first_exceed: dict[str, float | None] = field(default_factory=dict)
    scales: dict[str, float] = field(default_factory=dict)

    def worst(self, q: str) -> float:
        """The largest judged value of quantity ``q`` over the shared samples (``UNITS[q]``)."""
        return float(np.max(self.errors[q], initial=0.0))

    @property
    def passed(self) -> bool:
        return all(v is None for v in self.first_exceed.values()) and all(r.ok for r in self.runs)

    @property
    def first_index(self) -> int | None:
        """Index of the earliest saved time at which any quantity leaves its tolerance."""
        times = [t for t in self.first_exceed.values() if t is not None]
        return int(np.searchsorted(self.t, min(times))) if times else None


def parse_engines(text: list[str]) -> tuple[str, str]:
    """Two distinct engine names from ``--engines A,B``."""
    if len(text) != 2 or text[0] == text[1]:
        raise InputError(f"--engines needs two different engines, e.g. mujoco,pinocchio (got {','.join(text) or 'none'})")
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
    return get_engine("inhouse" if engine == "reference" else engine).simulate(scene, settings)


def judge_index(engines: tuple[str, str]) -> int:
    """Which run's motion scales judge the pair: the reference's if it is one of them, else A's."""
    return 1 if engines[1] == vq.REFERENCE_LABEL and engines[0] != vq.REFERENCE_LABEL else 0


def error_series(a: Trajectory, b: Trajectory, model, scales: dict[str, float] | None = None
                 ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Saved times both runs reached and the per-time judged value of each quantity (``UNITS``):
    the trajectory quantities over ``scales`` (default: ``compare.motion_scales`` of ``a``) as
    ``harness.measure.quantities`` defines them (``judged_series``), and the energy difference."""
    if scales is None:
        scales = compare.motion_scales(a, model)
    n = min(len(a.t), len(b.t))
    t = a.t[:n]
    errors = quantities.judged_series(a, b, scales, n)
    if n:
        ea = invariants.energies(_head(a, n), model)["energy"]
        eb = invariants.energies(_head(b, n), model)["energy"]
        errors["energy"] = np.abs(ea - eb) / compare.energy_scale(_head(a, n), model)
    else:
        errors["energy"] = np.zeros(0)
    return t, errors


def _head(traj: Trajectory, n: int) -> Trajectory:
    return replace(traj, t=traj.t[:n], p_WCm_W=traj.p_WCm_W[:n], quat_WB=traj.quat_WB[:n],
                   v_WCm_W=traj.v_WCm_W[:n], w_WB_W=traj.w_WB_W[:n], engine_energy={})


def tolerances(scene: Scene, engines: tuple[str, str]) -> dict[str, float | None]:
    """Tolerance per quantity (see module docstring; ``UNITS``); None where the scene sets none."""
    drift = scene.checks.get("energy_drift", {})
    own = [drift.get(vq.tolerance_engine(e)) for e in engines]
    judged = [e for e in engines if e != vq.REFERENCE_LABEL]
    out: dict[str, float | None] = {}
    for q in vq.TRAJECTORY:
        tols = [vq.tolerance(scene.checks, q, e) for e in judged]
        out[q.name] = None if any(t is None for t in tols) else max(tols)
    out["energy"] = float(sum(own)) if all(x is not None for x in own) else None
    return out


def debug(scene: Scene, engines: tuple[str, str], t_end: float | None = None, fast: bool = True) -> DebugResult:
    """Run both engines and find where each quantity first leaves its tolerance."""
    model = scene.multibody()
    a, b = (run_engine(scene, e, t_end, fast) for e in engines)
    judge = (a, b)[judge_index(engines)]
    scales = compare.motion_scales(judge, model) if len(judge.t) else {"length": 1.0, "velocity": 1.0, "angular_velocity": 1.0}
    t, errors = error_series(a, b, model, scales)
    tol = tolerances(scene, engines)
    res = DebugResult(scene, engines, (a, b), t, errors, tol, scales=scales)
    for q in QUANTITIES:
        res.first_exceed[q] = None
        if tol[q] is not None:
            bad = np.flatnonzero(~(errors[q] <= tol[q]))
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


def summary(res: DebugResult) -> list[str]:
    """What ``harness debug`` prints: runs, first times, and the state dump."""
    a, b = res.engines
    lines = [f"debug {res.scene.name}: {a} vs {b}, {len(res.t)} shared samples up to t = {res.t[-1] if len(res.t) else 0:.6g} s"]
    for e, tr in zip(res.engines, res.runs):
        lines.append(f"  {e}: {tr.engine}/{tr.integrator}, {len(tr.t)} samples, status {tr.status}"
                     + (f" ({tr.message})" if tr.message else ""))
    judge = res.engines[judge_index(res.engines)]
    lines.append(f"  judged as validate's trajectory.* checks (harness.validate.quantities): rel = over the motion "
                 f"scales of the {judge} run: " + ", ".join(f"{k} {v:.3g} {_SCALE_UNITS[k]}" for k, v in res.scales.items()))
    for q in QUANTITIES:
        tol = res.tolerances[q]
        worst = res.worst(q)
        spec = vq.BY_NAME.get(q)
        raw = f" ({worst * res.scales[spec.scale]:.3e} {spec.unit})" if spec is not None and spec.scale and res.scales else ""
        if tol is None:
            lines.append(f"  {q:<17} max {worst:.3e} {UNITS[q]}{raw} (no tolerance in the scene)")
        elif res.first_exceed[q] is None:
            lines.append(f"  {q:<17} max {worst:.3e} {UNITS[q]}{raw} <= {tol:.1e}: within tolerance")
        else:
            lines.append(f"  {q:<17} first leaves {tol:.1e} {UNITS[q]} at t = {res.first_exceed[q]:.6g} s "
                         f"(max {worst:.3e}{raw})")
    k = res.first_index
    if k is not None:
        lines += state_dump(res, k)
    return lines


def plot_png(res: DebugResult) -> bytes:
    """Error against time per quantity (log y), tolerance dashed, first exceedance dotted."""
    fig = new_figure(8, 2.0 * len(QUANTITIES), tight_layout=True)
    axes = fig.subplots(len(QUANTITIES), 1, sharex=True)
    for ax, q in zip(axes, QUANTITIES):
        err = np.where(res.errors[q] > 0, res.errors[q], np.nan)
        if np.any(np.isfinite(err)):
            ax.semilogy(res.t, err, lw=1.0, label=f"|{res.engines[0]} - {res.engines[1]}|")
        else:
            ax.set_yscale("log")
            ax.text(0.5, 0.5, "identical", transform=ax.transAxes, ha="center")
        if res.tolerances[q] is not None:
            ax.axhline(res.tolerances[q], color="r", ls="--", lw=0.8, label="tolerance")
        if res.first_exceed.get(q) is not None:
            ax.axvline(res.first_exceed[q], color="k", ls=":", lw=0.8)
        ax.set_ylabel(f"{q}\n({UNITS[q]})")
        ax.legend(loc="lower right", fontsize="small")
    axes[-1].set_xlabel("t (s)")
    axes[0].set_title(f"{res.scene.name}: {res.engines[0]} vs {res.engines[1]}")
    return png_bytes(fig, dpi=100)


def write_plot(res: DebugResult, out_dir: Path) -> Path:
    path = Path(out_dir) / f"debug_{res.scene.name}_{res.engines[0]}_{res.engines[1]}.png"
    atomic.write_bytes(path, plot_png(res))
    return path
