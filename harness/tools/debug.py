"""``harness debug SCENE --engines A,B``: where two runs of a scene part, quantity by quantity.

Both engines run at the scene's default settings (``harness.validate.run.default_settings``; the
engine name ``reference`` is the in-house DOP853 reference run of ``validate``). At every saved
time both have reached, the difference of each quantity, maximised over bodies:

* ``position``: centre-of-mass position (m); ``orientation``: geodesic angle on SO(3) (rad);
* ``velocity``: centre-of-mass velocity (m/s); ``angular_velocity``: world frame (rad/s);
* ``energy``: |E_A - E_B| / ``compare.energy_scale`` of run A (dimensionless), energies
  recomputed from the common trajectory (``invariants.energies``).

Tolerances: ``scene.checks["trajectory"]`` (position, orientation, velocity; angular velocity
uses the velocity tolerance, as ``validate`` does) and, for energy, the sum of the two engines'
``energy_drift`` tolerances (what the difference may reach when each run holds its own drift
check; ``reference`` uses the in-house tolerance). A quantity without a tolerance is plotted, not
judged.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from harness.io import atomic
from harness.measure import compare
from harness.measure import invariants
from harness.model import rotations
from harness.engines import ENGINE_NAMES, get_engine
from harness.model.errors import InputError
from harness.io.figures import new_figure, png_bytes
from harness.model.scene import Scene
from harness.measure.trajectory import Trajectory
from harness.validate.run import default_settings, reference_settings

QUANTITIES = ("position", "orientation", "velocity", "angular_velocity", "energy")
UNITS = {"position": "m", "orientation": "rad", "velocity": "m/s", "angular_velocity": "rad/s", "energy": "rel"}
DEBUG_ENGINES = ENGINE_NAMES + ("reference",)


@dataclass
class DebugResult:
    """Error series of one pair of runs and where each leaves its tolerance."""

    scene: Scene
    engines: tuple[str, str]
    runs: tuple[Trajectory, Trajectory]
    t: np.ndarray
    errors: dict[str, np.ndarray]
    tolerances: dict[str, float | None]
    first_exceed: dict[str, float | None] = field(default_factory=dict)

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


def run_engine(scene: Scene, engine: str, t_end: float | None) -> Trajectory:
    """One run at the scene's default settings (horizon ``t_end`` if given)."""
    settings = reference_settings(scene) if engine == "reference" else default_settings(scene, engine)
    if t_end is not None:
        settings = replace(settings, t_end=t_end)
    return get_engine("inhouse" if engine == "reference" else engine).simulate(scene, settings)


def error_series(a: Trajectory, b: Trajectory, model) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Saved times both runs reached and the per-time difference of each quantity."""
    n = min(len(a.t), len(b.t))
    t = a.t[:n]
    errors = {
        "position": np.linalg.norm(a.p_WCm_W[:n] - b.p_WCm_W[:n], axis=-1).max(axis=1, initial=0.0),
        "orientation": rotations.geodesic_angle(a.quat_WB[:n], b.quat_WB[:n]).max(axis=1, initial=0.0),
        "velocity": np.linalg.norm(a.v_WCm_W[:n] - b.v_WCm_W[:n], axis=-1).max(axis=1, initial=0.0),
        "angular_velocity": np.linalg.norm(a.w_WB_W[:n] - b.w_WB_W[:n], axis=-1).max(axis=1, initial=0.0),
    }
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
    """Tolerance per quantity (see module docstring); None where the scene sets none."""
    traj = scene.checks.get("trajectory", {})
    drift = scene.checks.get("energy_drift", {})
    own = [drift.get("inhouse" if e == "reference" else e) for e in engines]

    def pair(tol):  # a tolerance per engine (rolling_disk): the pair's larger one
        if not isinstance(tol, dict):
            return tol
        return max(tol.get("inhouse" if e == "reference" else e, 0.0) for e in engines)

    return {
        "position": pair(traj.get("position")),
        "orientation": pair(traj.get("orientation")),
        "velocity": pair(traj.get("velocity")),
        "angular_velocity": pair(traj.get("velocity")),
        "energy": float(sum(own)) if all(x is not None for x in own) else None,
    }


def debug(scene: Scene, engines: tuple[str, str], t_end: float | None = None) -> DebugResult:
    """Run both engines and find where each quantity first leaves its tolerance."""
    model = scene.multibody()
    a, b = (run_engine(scene, e, t_end) for e in engines)
    t, errors = error_series(a, b, model)
    tol = tolerances(scene, engines)
    res = DebugResult(scene, engines, (a, b), t, errors, tol)
    for q in QUANTITIES:
        res.first_exceed[q] = None
        if tol[q] is not None:
            bad = np.flatnonzero(~(errors[q] <= tol[q]))
            if bad.size:
                res.first_exceed[q] = float(t[bad[0]])
    return res


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
    for q in QUANTITIES:
        tol = res.tolerances[q]
        worst = float(np.max(res.errors[q], initial=0.0))
        if tol is None:
            lines.append(f"  {q:<17} max {worst:.3e} {UNITS[q]} (no tolerance in the scene)")
        elif res.first_exceed[q] is None:
            lines.append(f"  {q:<17} max {worst:.3e} {UNITS[q]} <= {tol:.1e}: within tolerance")
        else:
            lines.append(f"  {q:<17} first leaves {tol:.1e} {UNITS[q]} at t = {res.first_exceed[q]:.6g} s (max {worst:.3e})")
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
