"""The rolling-disk study: the four cases on all engines, MuJoCo's contact settings, and the
stability threshold of straight rolling against the textbook's (``harness rolling-study``).

Everything here runs the scene ``rolling_disk`` through the engines' ordinary ``simulate``;
MuJoCo variants are the scene's MJCF with contact/solver options rewritten
(``mujoco_rolling.apply_options``) and written to a temporary file. Each run is judged by
``run_metrics``: energy drift (max |E - E0| over the energy scale), slip (max horizontal speed of
the material point at the contact, m/s), penetration (max depth of the contact point below the
floor, m), trajectory error against the in-house DOP853 reference (rtol = atol = 1e-12;
centre-of-mass position over the length scale, orientation in rad), the contact force against
the reference's (over the weight/peak force, t > 0) and the lean error (steady case: max
|theta - theta0|, rad).

Cases (``CASES``; straight rolling starts on one rim edge at the balance tilt theta* = atan(R/h)
plus an outward lean ``delta``, so that the contact never switches edges):

* ``steady_circle``: the scene's defaults, Ex. 4.7.2 (lean constant, centre on a circle);
* ``straight_fast``: straight rolling at 1.5 v_c (stable: the lean oscillates);
* ``straight_slow``: straight rolling at 0.8 v_c (unstable: the disk falls);
* ``transient``: released leaning 0.37 rad from upright and spinning, no heading rate: it
  rolls, turns and nutates.

The threshold sweep runs straight rolling at several speeds from delta = 1e-3 rad for 1 s and
records the largest lean deviation |theta - theta*|; a run "falls" when it exceeds 0.1 rad
(100 delta) or the run stops because the disk lies flat.
"""

from __future__ import annotations

import math
import tempfile
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from harness.measure import compare
from harness.measure import contact_metrics
from harness.model import rotations
from harness.engines import get_engine
from harness.engines.base import RunSettings
from harness.model.scene import Scene, load_scene
from harness.measure.trajectory import Trajectory

REFERENCE = dict(integrator="DOP853", rtol=1e-12, atol=1e-12)
FALL_LEAN = 0.1  # rad: a straight-rolling run whose lean deviation exceeds this has fallen

BEST_LABEL = "RK4, solref 2 dt, solimp, elliptic, impratio 100"  # the settings the scene's MJCF holds

# MuJoCo's own defaults (what a user who writes a cylinder on a plane gets).
MUJOCO_DEFAULTS = dict(integrator="Euler", timestep=0.002, cone="pyramidal", impratio=1.0, noslip_iterations=0,
                       condim=3, friction=(1.0, 0.005, 0.0001), solref=(0.02, 1.0), solimp=(0.9, 0.95, 0.001, 0.5, 2.0))


def disk_params(scene: Scene):
    from harness.references.rolling_disk import DiskParams

    p = scene.params
    return DiskParams(p["mass"], p["R"], p["h"], p["g"])


def straight_params(scene: Scene, speed: float, delta: float) -> dict[str, float]:
    """Overrides for straight rolling at ``speed`` (m/s) on the lower edge, leaning ``delta``
    (rad) beyond the balance tilt theta* = atan(R/h): theta0 = theta* - delta, no heading or tilt
    rate, spin w3 = -speed/R (the centre moves along +e_y')."""
    from harness.references.rolling_disk import balance_tilt

    p = scene.params
    return {"theta0": balance_tilt(p["R"], p["h"]) - delta, "dphi0": 0.0, "dtheta0": 0.0, "dpsi0": -speed / p["R"]}


@dataclass(frozen=True)
class Case:
    name: str
    doc: str
    params: dict
    t_end: float


def cases(scene: Scene, quick: bool = False) -> list[Case]:
    """The study's cases for ``scene`` (``quick``: shorter horizons)."""
    from harness.references.rolling_disk import critical_speed

    vc = critical_speed(disk_params(scene))
    T = 0.2 if quick else scene.t_end
    return [
        Case("steady_circle", "Ex. 4.7.2: steady circular motion, lean constant (scene defaults)", {}, T),
        Case("straight_fast", f"straight rolling at 1.5 v_c = {1.5 * vc:.3f} m/s, 0.01 rad beyond the balance tilt: stable",
             straight_params(scene, 1.5 * vc, 0.01), T),
        Case("straight_slow", f"straight rolling at 0.8 v_c = {0.8 * vc:.3f} m/s, 0.01 rad beyond the balance tilt: falls",
             straight_params(scene, 0.8 * vc, 0.01), 0.1 if quick else 0.3),
        Case("transient", "released leaning 0.37 rad, spinning at -35 rad/s, no heading rate: rolls, turns, nutates",
             {"theta0": 1.2, "dphi0": 0.0, "dtheta0": 0.0, "dpsi0": -35.0}, T),
    ]


def lean(traj: Trajectory) -> np.ndarray:
    """theta(t): angle of the symmetry axis from the vertical (rad)."""
    R = rotations.matrix(traj.quat_WB[:, 0])
    return np.arccos(np.clip(R[:, 2, 2], -1.0, 1.0))


def reference(scene: Scene, t_end: float, save: float) -> Trajectory:
    return get_engine("inhouse").simulate(scene, RunSettings(t_end, save, save, **REFERENCE))


def run_metrics(scene: Scene, traj: Trajectory, ref: Trajectory | None, wall: float) -> dict:
    """The study's measures of one run (module docstring); NaN where not available."""
    model = scene.multibody()
    out = {"status": traj.status, "message": traj.message, "wall_s": wall, "samples": len(traj.t)}
    nan = float("nan")
    if len(traj.t) < 2:
        return out | {k: nan for k in ("energy", "slip", "penetration", "height", "position", "orientation", "force", "lean")}
    s = contact_metrics.summary(traj, model)
    out |= {"energy": compare.energy_drift(traj, model), "slip": s["slip_max"], "penetration": s["penetration_max"],
            "height": s["height_max"]}
    if ref is not None and ref.ok:
        err = compare.trajectory_error(traj, ref)
        scale = compare.motion_scales(ref, model)
        out |= {"position": err["position_max"] / scale["length"], "orientation": err["orientation_max"]}
        names = [c.name for c in model.contacts]
        if all(n in traj.reactions for n in names) and all(n in ref.reactions for n in names):
            own, other = contact_metrics._contacts_only(traj, names, True), contact_metrics._contacts_only(ref, names, True)
            out["force"] = compare.reaction_error(own, other)["force_max"] / compare.reaction_scales(other, model)[0]
        else:
            out["force"] = nan
    else:
        out |= {"position": nan, "orientation": nan, "force": nan}
    out["lean"] = float(np.max(np.abs(lean(traj) - scene.params["theta0"])))
    return out


def mujoco_variant(scene: Scene, options: dict | None, folder: Path, label: str) -> tuple[Scene, RunSettings | None]:
    """The scene with its MJCF rewritten by ``options`` (None: the MJCF as written), and the
    integrator/step the options ask for (None: the scene's)."""
    if options is None:
        return scene, None
    from harness.engines.mujoco.model import read_spec
    from harness.engines.mujoco.rolling import apply_options

    spec = read_spec(scene.mjcf)
    apply_options(spec, {k: v for k, v in options.items() if k not in ("integrator", "timestep")})
    path = folder / f"{scene.name}_{abs(hash(label)) % 10**8}.xml"
    path.write_text(spec.to_xml())
    return replace(scene, mjcf=path), RunSettings(1.0, options["timestep"], 1.0, options["integrator"])


def run(scene: Scene, engine: str, t_end: float, *, dt: float | None = None, integrator: str | None = None,
        save: float | None = None) -> tuple[Trajectory, float]:
    save = save or scene.save_every
    dt = dt or scene.dt
    settings = RunSettings(t_end, dt, save, integrator or scene.integrators[engine])
    t0 = time.perf_counter()
    traj = get_engine(engine).simulate(scene, settings)
    return traj, time.perf_counter() - t0


def mujoco_settings_rows(dt: float) -> list[tuple[str, dict | None]]:
    """The settings study: (label, options) from MuJoCo's defaults; None = the scene's MJCF."""
    d = MUJOCO_DEFAULTS
    stiff = (2.0 * dt, 1.0)
    hard = (0.99, 0.999, 0.001, 0.5, 2.0)

    def v(**kw):
        return {**d, "timestep": dt, **kw}

    return [
        ("MuJoCo defaults (Euler, 2 ms, pyramidal, solref 0.02 1)", dict(d)),
        ("defaults at the scene step", v()),
        ("RK4", v(integrator="RK4")),
        ("implicitfast", v(integrator="implicitfast")),
        ("RK4, elliptic cone", v(integrator="RK4", cone="elliptic")),
        ("RK4, elliptic, impratio 100", v(integrator="RK4", cone="elliptic", impratio=100.0)),
        ("RK4, noslip_iterations 20", v(integrator="RK4", noslip_iterations=20)),
        ("RK4, condim 4 (torsional friction)", v(integrator="RK4", condim=4)),
        ("RK4, condim 6 (torsional + rolling friction)", v(integrator="RK4", condim=6)),
        ("RK4, friction 10 (pyramidal)", v(integrator="RK4", friction=(10.0, 0.005, 0.0001))),
        ("RK4, solimp 0.99 0.999", v(integrator="RK4", solimp=hard)),
        (f"RK4, solref {stiff[0]:g} 1 (2 dt)", v(integrator="RK4", solref=stiff)),
        ("implicitfast, solref 2 dt", v(integrator="implicitfast", solref=stiff)),
        ("RK4, solref 2 dt, solimp 0.99 0.999", v(integrator="RK4", solref=stiff, solimp=hard)),
        (BEST_LABEL, v(integrator="RK4", solref=stiff, solimp=hard, cone="elliptic", impratio=100.0)),
        ("RK4, solref 2 dt, solimp, elliptic, impratio 100, noslip 20",
         v(integrator="RK4", solref=stiff, solimp=hard, cone="elliptic", impratio=100.0, noslip_iterations=20)),
        ("RK4, solref 2 dt, solimp, condim 4", v(integrator="RK4", solref=stiff, solimp=hard, condim=4)),
        ("RK4, solref -1e6 -2000 (direct stiffness, damping)", v(integrator="RK4", solref=(-1e6, -2000.0), solimp=hard)),
        ("scene MJCF as written", None),
        ("as written, step dt/2.5 = 0.1 ms, solref 2 dt", {**v(integrator="RK4", solref=(0.0002, 1.0), solimp=hard,
                                                             cone="elliptic", impratio=100.0), "timestep": 1e-4}),
        ("as written, step 0.05 ms, solref 2 dt", {**v(integrator="RK4", solref=(0.0001, 1.0), solimp=hard,
                                                     cone="elliptic", impratio=100.0), "timestep": 5e-5}),
    ]


@dataclass
class StudyResult:
    """Everything ``rolling_study`` produces (rows are dicts of ``run_metrics`` plus labels)."""

    scene: Scene
    engines: list[dict] = field(default_factory=list)
    settings: list[dict] = field(default_factory=list)
    threshold: list[dict] = field(default_factory=list)
    series: dict = field(default_factory=dict)
    thresholds: dict = field(default_factory=dict)


def engine_study(scene: Scene, case_list: list[Case], result: StudyResult, defaults_options: dict) -> None:
    """Every case on every engine (MuJoCo as written and at MuJoCo's defaults)."""
    with tempfile.TemporaryDirectory() as tmp:
        for case in case_list:
            sc = scene.with_params(**case.params)
            ref = reference(sc, case.t_end, sc.save_every)
            result.engines.append({"case": case.name, "engine": "reference (DOP853 1e-12)",
                                   **run_metrics(sc, ref, ref, float(ref.stats.get("wall_s", math.nan)))})
            runs = [("inhouse", sc, {}), ("pinocchio", sc, {}), ("exudyn", sc, {}), ("mujoco", sc, {})]
            dsc, dset = mujoco_variant(sc, defaults_options, Path(tmp), "defaults")
            runs.append(("mujoco (MuJoCo defaults)", dsc, {"dt": dset.dt, "integrator": dset.integrator}))
            for label, s, kw in runs:
                traj, wall = run(s, label.split()[0], case.t_end, **kw)
                result.engines.append({"case": case.name, "engine": label, **run_metrics(sc, traj, ref, wall)})
                if case.name in ("steady_circle", "transient"):
                    result.series[(case.name, label)] = (traj.t, lean(traj))
            result.series[(case.name, "reference")] = (ref.t, lean(ref))


def settings_study(scene: Scene, case_list: list[Case], result: StudyResult, rows: list[tuple[str, dict | None]]) -> None:
    """MuJoCo's settings ``rows`` (``mujoco_settings_rows``) on the steady and transient cases."""
    picked = [c for c in case_list if c.name in ("steady_circle", "transient")]
    refs = {c.name: reference(scene.with_params(**c.params), c.t_end, scene.save_every) for c in picked}
    with tempfile.TemporaryDirectory() as tmp:
        for label, options in rows:
            row = {"setting": label, "options": options}
            for c in picked:
                sc = scene.with_params(**c.params)
                vs, vset = mujoco_variant(sc, options, Path(tmp), label)
                kw = {} if vset is None else {"dt": vset.dt, "integrator": vset.integrator}
                traj, wall = run(vs, "mujoco", c.t_end, **kw)
                row[c.name] = run_metrics(sc, traj, refs[c.name], wall)
            result.settings.append(row)


def threshold_study(scene: Scene, result: StudyResult, speeds: list[float], engines: list[str], t_end: float,
                    delta: float = 1e-3) -> None:
    """Straight rolling at each speed on each engine (module docstring)."""
    from harness.references.rolling_disk import (
        DiskParams,
        balance_tilt,
        critical_speed,
        printed_critical_speed,
        straight_rolling_rate,
    )

    p = scene.params
    disk = disk_params(scene)
    thin = DiskParams(p["mass"], p["R"], 0.0, p["g"])
    result.thresholds = {"correct": critical_speed(disk), "thin": critical_speed(thin),
                         "printed": printed_critical_speed(p["g"], p["R"]), "balance_tilt": balance_tilt(p["R"], p["h"]),
                         "delta": delta, "t_end": t_end}
    theta_star = result.thresholds["balance_tilt"]
    for v in speeds:
        sc = scene.with_params(**straight_params(scene, v, delta))
        w2 = straight_rolling_rate(disk, v)
        for engine in engines:
            traj, wall = run(sc, engine, t_end, save=0.005)
            dev = np.abs(lean(traj) - theta_star) if len(traj.t) else np.array([np.nan])
            # an engine that does not model the scene ("unsupported") neither falls nor rolls: not run
            fell = None if traj.unsupported else (not traj.ok) or float(np.max(dev)) > FALL_LEAN
            result.threshold.append({"speed": v, "engine": engine, "max_lean": float(np.nanmax(dev)) if np.any(np.isfinite(dev)) else math.nan,
                                     "fell": None if fell is None else bool(fell),
                                     "status": traj.status, "message": traj.message, "w2": w2, "wall_s": wall,
                                     "predicted_stable": w2 > 0, "printed_stable": v > result.thresholds["printed"]})
            result.series[("threshold", engine, v)] = (traj.t, dev)


def threshold_agrees(threshold: list[dict]) -> bool:
    """Whether every threshold run that was made (``fell`` not None: an "unsupported" run is not
    run) falls exactly when the correct linearisation predicts instability."""
    return all(r["fell"] != r["predicted_stable"] for r in threshold if r["fell"] is not None)


def rolling_study(*, quick: bool = False, engines: list[str] | None = None, models_dir: Path | None = None) -> StudyResult:
    """Run the whole study (``quick``: short horizons, few settings and speeds, for tests)."""
    scene = load_scene("rolling_disk", models_dir=models_dir)
    engines = engines or ["inhouse", "pinocchio", "exudyn", "mujoco"]
    result = StudyResult(scene=scene)
    case_list = cases(scene, quick)
    if quick:
        case_list = case_list[:1]
    engine_study(scene, case_list, result, {**MUJOCO_DEFAULTS})
    rows = mujoco_settings_rows(scene.dt)
    if quick:  # MuJoCo's defaults, the best settings, the MJCF as written
        rows = [r for r in rows if r[0].startswith("MuJoCo defaults") or r[0] == BEST_LABEL or r[1] is None]
    settings_study(scene, case_list, result, rows)
    speeds = [0.15, 0.26] if quick else [0.10, 0.15, 0.18, 0.20, 0.21, 0.22, 0.23, 0.26, 0.32]
    threshold_study(scene, result, speeds, engines, 0.3 if quick else 1.0)
    return result
