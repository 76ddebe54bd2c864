"""``run_check``: load, compare the models, the dynamics terms at random states and the free motions, run
the witnesses (``harness.tools.witnesses``); the order of the stages is the package docstring's."""

from __future__ import annotations

import time
from pathlib import Path

import mujoco
import numpy as np

from harness.tools import dynamics_terms as dc
from harness.tools import witnesses as wit
from harness.engines.mujoco.warning_capture import captured_warnings
from harness.model.errors import InputError
from harness.model.from_model_file import add_root_joint
from harness.model.joints import FREE
from harness.model.scene import check_steps
from harness.tools.check.results import CheckResult, LOADERS, Reading, SAME_FILE_RTOL, TWO_FILES_RTOL
from harness.tools.check.dynamics import (_drake_table, _pinocchio_frames, _pinocchio_table, _pybullet_table, _rigid_copy,
                                          free_motion)
from harness.tools.check.notes import _first_tree_note, importer_notes, not_compared
from harness.tools.check.classifying import DefectRefusal, KnownRefusal, classify, urdf_mimics
from harness.tools.check.defects import Defect, find_defects
from harness.tools.check.known_limitations import explain_refusal
from harness.tools.check.reading import _one_line, load_models, read_mujoco_spec
from harness.tools.check.causes import diagnose, diagnose_dynamics
from harness.tools.check.comparing import vote


def run_check(mjcf: Path | None, urdf: Path | None, *, seed: int = 0, n_states: int = dc.DEFAULT_STATES,
              n_free: int = 3, t_end: float = 0.5, dt: float = 1e-3, save_every: float = 0.01,
              floating_base: bool = False, strip: bool = False, keep_static: bool = False,
              joint_map: dict[str, str] | None = None, witnesses: bool = True, progress=None,
              allowed_dirs: tuple[Path, ...] = ()) -> CheckResult:
    """Load, compare models, dynamics terms and free motion (see module docstring); ``allowed_dirs``:
    folders besides the model's own that its includes and assets may lie in (``load_models``); ``joint_map``:
    MJCF joint name -> URDF joint name (``apply_joint_map``); ``witnesses``: also the in-house
    engine and Exudyn built from MuJoCo's reading (``harness.tools.witnesses``); ``progress``: a
    bar (``harness.io.progress.make_bar``) whose total is set to the stages (the loads, the
    witnesses, the dynamics terms, each free-motion run, the witnesses' runs), ticked as each
    ends; or None."""
    clock = [time.perf_counter()]

    def tick(label: str, n: int = 1) -> None:
        if progress is not None:
            now = time.perf_counter()
            progress.done(f"{label} {now - clock[0]:.1f} s", n)
            clock[0] = now

    for label, value in (("--t-end", t_end), ("--dt", dt)):
        if not (np.isfinite(value) and value > 0):
            raise InputError(f"{label} must be positive and finite, got {value!r}")
    check_steps(t_end, dt, "--t-end and --dt")  # before any model is loaded or run
    if n_states < 1 or n_free < 0:
        raise InputError("--states must be >= 1 and --free-runs >= 0")
    if progress is not None:
        progress.total = 4 + n_free
        progress.refresh()
    files = [Path(p) for p in (mjcf, urdf) if p is not None]
    try:
        readings, mode, notes, copies = load_models(mjcf, urdf, floating_base=floating_base, strip=strip,
                                                    keep_static=keep_static, joint_map=joint_map,
                                                    allowed_dirs=allowed_dirs)
    except InputError as err:   # a defect that stops the loaders is named as one, with its fix
        defects = _file_defects(files, floating_base)
        named = [d for d in defects if d.element.split(" ", 1)[1] in str(err)]
        fatal = next(iter(named), None) or next((d for d in defects if d.fatal), None)
        if fatal is not None:
            raise DefectRefusal(fatal) from err
        # MuJoCo reads the first file (the MJCF where both are given)
        known = explain_refusal(files[0], "MuJoCo", mujoco.__version__) if files else None
        if known is None:
            raise
        raise KnownRefusal(err, "MuJoCo", known) from err
    name = Path(urdf if urdf is not None else mjcf).stem
    tick(f"{name} loaded: " + ", ".join(f"{k} {'ok' if r.loaded else 'no'}" for k, r in readings.items()))
    res = CheckResult(name, mode, "floating (free root joint 'root_joint')" if floating_base else "fixed", readings)
    res.notes += notes
    res.copies = copies
    res.defects = [d for d in _file_defects(files, floating_base) if not d.fatal]
    res.not_compared = not_compared(readings["MuJoCo"].model)
    res.mapped = sum(1 for k, v in readings["Pinocchio"].names.items() if k != v)
    mjr, pinr, drr, pbr = (readings[k] for k in LOADERS)
    m = mjr.model
    rtol = SAME_FILE_RTOL if len({r.source for r in readings.values() if r.loaded}) == 1 else TWO_FILES_RTOL
    res.votes = vote(readings, rtol)
    res.findings = diagnose(readings, res.votes, rtol)
    res.notes += importer_notes(readings)
    pin_table = _pinocchio_table(mjr, pinr) if pinr.loaded else None
    drake_table = _drake_table(mjr, drr) if drr.loaded else None
    pybullet_table = _pybullet_table(mjr, pbr) if pbr.loaded else None
    res.notes += _first_tree_note(readings)
    lacking = {n for r, t in ((pinr, pin_table), (drr, drake_table), (pbr, pybullet_table)) if t is not None
               for n in r.partial}
    jmap = dc.joint_map(m, pin_table, drake_table, only=[x.joint for x in mjr.bodies if x.joint not in lacking])
    states = dc.random_states(jmap, n_states, seed)
    res.settings = {"seed": seed, "states": n_states, "free_runs": n_free, "t_end": t_end, "dt": dt,
                    "save_every": save_every, "rtol_model": rtol, "rtol_dynamics": max(dc.DEFAULT_RTOL, rtol)}
    d = mujoco.MjData(m)
    sources = {"MuJoCo": lambda q, v: dc.mujoco_terms(m, jmap, q, v, d)}
    if pin_table is not None:
        pmodel, data = pinr.model, pinr.model.createData()
        sources["Pinocchio"] = lambda q, v: dc.pinocchio_terms(pmodel, jmap, q, v, data)
    if drake_table is not None:
        plant = drr.model.plant
        context = plant.CreateDefaultContext()
        sources["Drake"] = lambda q, v: dc.drake_terms(plant, jmap, q, v, context)
    if pybullet_table is not None:
        pb_load, g_mj = pbr.model, mjr.gravity
        sources["PyBullet"] = lambda q, v: dc.pybullet_terms(pb_load, jmap, pybullet_table, q, v, g_mj)
    if witnesses:
        res.witnesses = _witnesses(res, mjr, jmap, sources)
    tick(f"{name} witnesses {'built' if witnesses else 'not asked for'}")
    with captured_warnings() as caught:  # MuJoCo's warnings go into the result, not onto stderr
        try:
            if len(sources) >= 2:
                terms = dc.evaluate(sources, states)
                res.dynamics = dc.compare_terms(terms, rtol=max(dc.DEFAULT_RTOL, rtol))
            w = res.witnesses
            if w is not None and w.source is not None:
                start = time.perf_counter()
                wterms = dc.evaluate({"in-house": w.source}, states)
                loader_terms = terms if len(sources) >= 2 else dc.evaluate(sources, states)
                w.dynamics = dc.compare_terms(loader_terms | wterms, pairs=[(k, "in-house") for k in loader_terms],
                                              rtol=max(dc.DEFAULT_RTOL, rtol))
                w.wall_s += time.perf_counter() - start
            if len(sources) >= 2:
                res.findings += diagnose_dynamics(readings, jmap, {k: t for k, t in terms.items() if k in LOADERS},
                                                  [d for d in res.dynamics if d.a in LOADERS and d.b in LOADERS],
                                                  max(dc.DEFAULT_RTOL, rtol))
            tick(f"{name} dynamics terms at {n_states} states")
            if pin_table is None:
                res.free_skipped = ("Pinocchio does not load the file" if not pinr.loaded
                                    else f"Pinocchio's dynamics are not compared ({pinr.dynamics})")
                res.free_skipped += "; the free motion compares MuJoCo with Pinocchio only"
                tick(f"{name} free motion skipped", n_free)
            else:
                frames = _pinocchio_frames(mjr, pinr)
                for k, (q, v) in enumerate(dc.random_states(jmap, n_free, seed + 1)):
                    res.free.append(free_motion(m, pinr.model, jmap, q, v, k, t_end=t_end, dt=dt, save_every=save_every,
                                                frames=frames))
                    tick(f"{name} free motion {k + 1}/{n_free}")
            w = res.witnesses
            if w is not None and not w.refusal:
                wit.run(w, m, jmap, dc.random_states(jmap, n_free, seed + 1)[:wit.FREE_STATES],
                        t_end=min(t_end, wit.FREE_T_END), dt=dt, save_every=save_every,
                        rigid_at=lambda h: _rigid_copy(m, h))
            tick(f"{name} witness runs {'done' if w is not None and not w.refusal else 'not run'}")
        finally:
            res.warnings = caught.stats()
    res.classes = classify(res)
    return res


def _file_defects(files: list[Path], floating_base: bool) -> list[Defect]:
    """The defects of the user's files (``harness.tools.check.defects``), with the root joint the
    check adds (a floating base moves the root body); none for a file MuJoCo's parser does not read
    (its refusal is then the message)."""
    out = []
    for path in files:
        try:
            spec = read_mujoco_spec(path)
            add_root_joint(spec, FREE.name if floating_base else "none", path)
            out += find_defects(path, spec)
        except (InputError, ValueError, KeyError):   # a file the parser refuses, or a malformed number in it
            continue
    return out


def _witnesses(res: CheckResult, mjr: Reading, jmap: dc.JointMap, sources: dict) -> wit.Witnesses:
    """The witnesses' description of MuJoCo's reading, their model rows and the in-house dynamics
    source (added to ``sources``); refused in one line when the description cannot hold the model."""
    start = time.perf_counter()
    w = wit.describe(mjr.model, mjr.source)
    mimics = urdf_mimics(res)
    if w.refusal and mimics and "equality constraint" in w.refusal:   # named as the file names them
        w.refusal = (f"mimic joint(s) {', '.join(repr(j) for j, *_ in mimics)}: the witnesses hold a tree of "
                     "independent joints, not a coupling")
    if not w.refusal:
        try:
            w.rows = wit.model_rows(w, mjr.bodies, res.settings["rtol_model"])
            w.source = wit.inhouse_source(w, jmap)
        except Exception as err:  # noqa: BLE001 - an engine that does not build this model is reported, not a crash
            w = wit.Witnesses(refusal=f"{type(err).__name__}: {_one_line(err)}")
    w.wall_s = time.perf_counter() - start
    return w

