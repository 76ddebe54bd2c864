"""The closed-loop study's report: ``loop_closure.md``, ``loop_closure.json`` and one plot per
scene, ``loop_closure_<scene>.png`` (closure gap and exact error against the step, log-log).

``write_reports(study, out, prov)`` writes them from a ``harness.studies.loops.run.loop_study``
result as one set (``harness.io.atomic.write_set``: all old or all new; nothing written if the
folder is not writable) and returns the paths of the PNGs. The paragraph under each scene's
table (``findings``) is generated from the numbers: what it says follows the data.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from harness.io import atomic
from harness.engines import IDEAL, REFERENCE_ENGINE, declaration, display, made_with, with_loops
from harness.judging import error_model
from harness.studies.loops.run import (DEFAULT_SOLIMP, DEFAULT_SOLIMP_ONLY, DEFAULT_SOLREF, DEFAULTS, IDEAL_CLOSURE, MODELLED,
                                       SOFT_INTEGRATOR, SOFT_LOOP_ENGINE, SOFT_NAME, TWO_DT, VARIANT, WRITTEN, LoopStudy,
                                       SceneStudy, error_models, failures, horizon, loglog_slope, series)

NAME = "loop_closure"
#: A measure's name in the report and JSON key, with its unit.
MEASURES = (("closure_position", "closure gap (m)"), ("closure_velocity", "closure velocity (m/s)"),
            ("energy", "energy"), ("exact", "exact error"))
FLAT = 0.5  # |log-log slope| below this: a measure "does not follow the step"
VELOCITY_HELD = 1e-6  # m/s: a closure velocity above this is not held at the velocity level


def write_reports(study: LoopStudy, out: Path, prov: dict, command: str | None = None) -> list[Path]:
    """Write the Markdown, JSON and PNGs into ``out`` as one set; returns the PNG paths.
    ``command``: the "Reproduce with" command (default ``harness.io.provenance.command_line()``).
    ``InputError`` if ``out`` cannot be written (the old files are then kept)."""
    if command is None:
        from harness.io.provenance import command_line

        command = command_line()
    out = Path(out)
    atomic.check_writable(out)
    figures = plot_files(study)
    pngs = [out / name for name in figures]
    files: dict[str, bytes | str] = dict(figures)
    files[f"{NAME}.md"] = markdown(study, prov, pngs, command)
    files[f"{NAME}.json"] = json.dumps(as_json(study, prov, command), indent=2, default=str, allow_nan=True)
    atomic.write_set(out, files)
    return pngs


# ------------------------------------------------------------------------------ formatting
def _e(x) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "—"
    return f"{x:.1e}"


def _ms(dt: float) -> str:
    """A step in ms: ``"0.25 ms"``."""
    return f"{dt * 1e3:g} ms"


def _steps(dts) -> str:
    return ", ".join(f"{dt * 1e3:g}" for dt in dts) + " ms"


def _samples(s: SceneStudy) -> str:
    """How the scene's runs were sampled."""
    if all(save == dt for save, dt in zip(s.saves, s.steps)):
        return "samples at every step (the energy balance integrates the forces' power over them)"
    if len(set(s.saves)) == 1:
        return f"samples every {_ms(s.saves[0])}"
    return "samples every " + _steps(s.saves)


def _bound() -> str:
    """``IDEAL_CLOSURE`` as "1e-9 m"."""
    mantissa, exponent = f"{IDEAL_CLOSURE:e}".split("e")
    m = float(mantissa)
    return f"{m:g}e{int(exponent)} m" if m != 1 else f"1e{int(exponent)} m"


def _ok(x) -> bool:
    return x is not None and isinstance(x, (int, float)) and math.isfinite(x)


def _times(a: float, b: float) -> str:
    """``a / b`` as "12×" (or "0.5×")."""
    if not (_ok(a) and _ok(b)) or b == 0:
        return "—"
    r = a / b
    return f"{r:.2g}×" if r < 10 else f"{r:.0f}×"


def _slope(x: float) -> str:
    return "—" if not _ok(x) else f"{abs(x) if abs(x) < 0.05 else x:.1f}"


def energy_name(s: SceneStudy) -> str:
    """What the energy column measures for the scene."""
    from harness.model.forces import does_work

    return "energy balance" if does_work(s.scene.multibody()) else "energy drift"


def exact_unit(s: SceneStudy) -> str:
    units = {r["exact_unit"] for r in s.rows if r.get("exact_unit")}
    return next(iter(units)) if len(units) == 1 else ""


def has_exact(s: SceneStudy) -> bool:
    return any(_ok(r["exact"]) for r in s.rows)


# ------------------------------------------------------------------------------ Markdown
def markdown(study: LoopStudy, prov: dict, pngs: list[Path], command: str) -> str:
    """The report (module docstring); ``command`` is the "Reproduce with" command."""
    bad = failures(study)
    horizon = f"{study.t_end:g} s" if study.t_end is not None else "each scene's t_end"
    lines = [
        "# Closed kinematic loops: closure, energy and exact error against the step",
        "",
        f"Made {prov['date_utc']} with {made_with(prov)}. Reproduce with `{command}`"
        + (" (this is a `--quick` smoke run: 0.5 s, two steps)." if study.quick else "."),
        "",
        f"Every scene with a cut joint (`Multibody.loops`), over {horizon}, at the scene's step dt times "
        f"{', '.join(f'{f:g}' for f in study.factors)}; each run in its own worker process "
        f"({study.jobs} at a time, {study.timeout:g} s allowed each"
        + "".join(f", {s.scene.name} {s.scene.timeout:g} s" for s in study.scenes
                  if (s.scene.timeout or 0.0) > study.timeout)
        + f"), {study.wall_s:.0f} s in all.",
        "",
        "Rows: the ideal-constraint engines at the scene's integrator ("
        + "; ".join(f"{display(e)}: {declaration(e).loops_how}" for e in with_loops(IDEAL))
        + f") and {SOFT_NAME} {SOFT_INTEGRATOR}, whose `<connect>` equalities are soft "
        "constraints, four ways: the MJCF's own `solref`/`solimp`; `solref` = (2·dt, the file's damping ratio), "
        f"the time constant following the step at {SOFT_NAME}'s safe minimum ({SOFT_NAME} raises a smaller one to 2·dt), "
        f"with the file's `solimp`; the file's `solref` with {SOFT_NAME}'s default `solimp` "
        f"({' '.join(f'{x:g}' for x in DEFAULT_SOLIMP)}); {SOFT_NAME}'s defaults, `solref` "
        f"{' '.join(f'{x:g}' for x in DEFAULT_SOLREF)}, `solimp` "
        f"{' '.join(f'{x:g}' for x in DEFAULT_SOLIMP)} (what a `<connect>` written with no settings gets).",
        "",
        "Measures, each the largest over the saved samples (and the cut joints): **closure gap** (m), the "
        "distance between the cut joint's two points; **closure velocity** (m/s), their relative velocity "
        "(`harness.measure.compare.loop_closure`); **energy**: max |E − E0| over the energy scale, or for a "
        "scene whose forces do work the balance max |E − E0 − W| over it; **exact error**: against the "
        "scene's closed-form reference (`references/<scene>.py`; rad for the linkages: the bodies' absolute "
        "angles), — where the scene has none; **wall** (s): the engine's `simulate`, per step, coarsest first. "
        "A run that did not end ok shows its status instead of numbers.",
        "",
        f"Verdict: every ideal-constraint engine keeps the closure gap below {_bound()} at every "
        f"step and every run that should run ends ok: **{'yes' if not bad else 'no'}**"
        + ("." if not bad else f" ({len(bad)} failure{'s' if len(bad) > 1 else ''}):"),
        "",
    ]
    lines += [f"* {line}" for line in bad] + ([""] if bad else [])
    by_png = {p.name: p for p in pngs}
    for s in study.scenes:
        lines += scene_lines(s, study)
        png = by_png.get(f"{NAME}_{s.scene.name}.png")
        if png is not None:
            lines += [f"![{s.scene.name}: closure gap and exact error against the step]({png.name})", ""]
    return "\n".join(lines)


def scene_lines(s: SceneStudy, study: LoopStudy) -> list[str]:
    """One scene's section: its settings, the table and the findings."""
    sc = s.scene
    t_end = horizon(sc, study.t_end)
    loops = ", ".join(f"`{loop.name}` ({loop.kind}, {loop.body_a} – {loop.body_b or 'world'})"
                      for loop in sc.multibody().loops)
    from harness.studies.loops.run import describe_settings

    lines = [
        f"## {sc.name}: {sc.title}",
        "",
        f"Cut joint{'s' if len(sc.multibody().loops) > 1 else ''} {loops}; {t_end:g} s, steps {_steps(s.steps)} "
        f"(the scene's: {_ms(sc.dt)}), {_samples(s)}. The MJCF's loop equalities: "
        f"{describe_settings(s.written)}. Energy column: {energy_name(s)}"
        + (f"; exact error in {exact_unit(s)}." if has_exact(s) else "; the scene has no exact reference."),
        "",
    ]
    lines += table_lines(s)
    lines += model_lines(s, study)
    lines += published_lines(s)
    lines += [""] + [" ".join(findings(s, study))] + [""]
    return lines


def published_lines(s: SceneStudy) -> list[str]:
    """For a system whose source publishes a reference state (``published_digits_q``): a table of
    each run's correct digits of it, positions / velocities, per step; nothing otherwise."""
    rows = [r for r in s.rows if r["status"] == "ok" and math.isfinite(r.get("published_digits_q", math.nan))]
    if not rows:
        return []
    t = rows[0]["published_t"]
    lines = ["", f"The published reference state at t = {t:g} s: correct digits of each run (−log10 of the largest "
                 "relative error), positions / velocities. The reference (DOP853 at rtol 1e-13) has "
                 + _reference_digits(s) + ".", "",
             "| engine / variant | " + " | ".join(_ms(dt) for dt in s.steps) + " |", "|---|" + "---|" * len(s.steps)]
    for key in s.variants():
        cells = []
        for dt in s.steps:
            r = s.row(key, dt)
            ok = r is not None and r["status"] == "ok" and math.isfinite(r.get("published_digits_q", math.nan))
            cells.append(f"{r['published_digits_q']:.1f} / {r['published_digits_v']:.1f}" if ok else "—")
        lines.append(f"| {_label(s, key)} | " + " | ".join(cells) + " |")
    return lines


def _reference_digits(s: SceneStudy) -> str:
    """The scene's own reference solution's correct digits of the published state."""
    from harness.measure.exact import reference_module

    module = reference_module(s.scene)
    digits = getattr(module, "reference_digits", None)
    if not callable(digits):
        return "no digit count"
    q, v = digits(s.scene)
    return f"{q:.1f} / {v:.1f}"


def table_lines(s: SceneStudy) -> list[str]:
    """The scene's table: a row per engine/variant, per measure a column per step; a "not run"
    row with the reason for each engine the scene does not run."""
    heads = []
    for key, name in MEASURES:
        unit = f" ({exact_unit(s)})" if key == "exact" and exact_unit(s) else ""
        label = (energy_name(s) if key == "energy" else name) + unit
        heads += [f"{label}, {_ms(dt)}" if i == 0 else _ms(dt) for i, dt in enumerate(s.steps)]
    n = len(heads)
    lines = ["| engine / variant | " + " | ".join(heads) + " | wall (s) | status |",
             "|---|" + "---|" * (n + 2)]
    for key in s.variants():
        rows = [s.row(key, dt) for dt in s.steps]
        label = next(r["label"] for r in rows if r is not None)
        cells = []
        for measure, _ in MEASURES:
            cells += [("—" if r is None else _e(r[measure]) if r["status"] == "ok" else r["status"]) for r in rows]
        wall = " / ".join("—" if r is None else f"{r['wall_s']:.2g}" for r in rows)
        bad = [r for r in rows if r is not None and r["status"] != "ok"]
        status = "ok" if not bad else "; ".join(f"{_ms(r['dt'])}: {r['status']}" + (f" ({r['message']})" if r["message"] else "")
                                                for r in bad)
        lines.append(f"| {label} | " + " | ".join(cells) + f" | {wall} | {status} |")
    for key, why in s.not_run.items():
        lines.append(f"| {VARIANT[key].label} | " + " | ".join(["not run"] * n) + f" | — | not run: {why} |")
    return lines


def model_cell(m: error_model.ErrorModel, declared: dict | None = None) -> str:
    """One error model as its table shows it: ``class (order), floor F unit``, the order and floor
    left out where not measured; for an engine whose model difference the scene declares
    (``[model_differences.<engine>]``), whether it is within its declared bound
    (``harness.judging.verdict.judge``)."""
    from harness.judging.verdict import ModelDifference, judge

    order = 0.0 if abs(m.observed_order) < 0.005 else m.observed_order  # no "-0.00"
    text = m.classification + (f" ({order:.2f})" if math.isfinite(order) else "")
    if math.isfinite(m.floor) and m.floor > 0:
        text += f", floor {m.floor:.1e}" + (f" {m.unit}" if m.unit not in ("rel", "") else "")
    if (m.levels and m.classification != error_model.DEFECT and all(lv.step >= m.levels[0].step for lv in m.levels)
            and error_model.needs_finer_level(list(m.levels), m.formal_order, m.resolution)):
        text += " (undecided)"
    if declared and m.classification in (error_model.MODEL_DIFFERENCE, error_model.DEFECT):
        v = judge(m, ModelDifference(declared["model"], declared["bound"]))
        text += f" — declared, {'within' if v.passed else 'beyond'} its bound {declared['bound']:g}"
    return text


def model_lines(s: SceneStudy, study: LoopStudy) -> list[str]:
    """The scene's error models (``harness.studies.loops.run.error_models``): a row per engine /
    variant, a column per measure, each ``class (order), floor``."""
    models = error_models(s, horizon(s.scene, study.t_end))
    if not models:
        return []
    names = dict(MEASURES)
    measures = [m for m, _ in MODELLED if any(k[1] == m for k in models)]
    heads = [(energy_name(s) if m == "energy" else names[m]) for m in measures]
    lines = ["", "Error model of each measure against the step (`harness.judging.error_model`, as validate judges "
             "its checks; the scene's step first, the order of the finest two steps, the floor from Richardson "
             "extrapolation): converges (falls at about the integrator's order, or sits at the resolution), model "
             "difference (a floor that does not shrink with the step), defect (an order far below the integrator's, "
             "or non-finite), unresolved (an error of the motion's own size), not judged (one step only); "
             "(undecided): no step finer than the scene's, where the finest two leave the class open (a floor read "
             "at the method's order; validate would add a finer step: the full study runs dt/2 and dt/4). "
             f"{SOFT_NAME}'s soft loop constraints show as a floor or a low order; where the scene declares {SOFT_NAME}'s "
             "model difference, the cell says whether it stays within the declared bound (of each quantity's scale).",
             "", "| engine / variant | class (order) of " + " | ".join(heads) + " |", "|---|" + "---|" * len(heads)]
    for key in s.variants():
        if not any((key, m) in models for m in measures):
            continue
        declared = s.scene.model_differences.get(VARIANT[key].engine) if not VARIANT[key].ideal else None
        cells = [model_cell(models[(key, m)], declared) if (key, m) in models else "—" for m in measures]
        lines.append(f"| {_label(s, key)} | " + " | ".join(cells) + " |")
    return lines


# ------------------------------------------------------------------------------ findings
def _label(s: SceneStudy, key: str) -> str:
    return next(r["label"] for r in s.rows if r["variant"] == key)


def _at(s: SceneStudy, key: str, measure: str, dt: float | None = None) -> float:
    r = s.row(key, s.scene.dt if dt is None else dt)
    return float(r[measure]) if r is not None and r["status"] == "ok" else math.nan


def _join(parts: list[str]) -> str:
    if len(parts) <= 1:
        return "".join(parts)
    return ", ".join(parts[:-1]) + " and " + parts[-1]


def clamped_steps(s: SceneStudy) -> list[float]:
    """Steps (s) at which the MJCF's own time constant (solref[0] > 0) is below 2 dt, so that
    MuJoCo raises it to 2 dt (its safe minimum)."""
    tcs = [ref[0] for ref, _ in s.written.values() if ref[0] > 0]
    return [dt for dt in s.steps if tcs and min(tcs) < 2.0 * dt * (1 - 1e-9)]


def findings(s: SceneStudy, study: LoopStudy | None = None) -> list[str]:
    """Sentences on what the scene's numbers show (each only when its data are there):
    the ideal engines' closure and convergence, MuJoCo's closure gap against its softness and
    the step (and the floor it levels off at), the energy, and, for a scene built as a variant
    of another studied scene (``builder``), the amplification of the errors at the steps both
    share."""
    out: list[str] = []
    have = set(s.variants())
    ideal = [k for k in VARIANT if k in have and VARIANT[k].ideal]
    mj = [k for k in VARIANT if k in have and VARIANT[k].engine == SOFT_LOOP_ENGINE]
    unit = exact_unit(s)
    # 1. the ideal engines' closure
    if ideal:
        worst = {k: max((x for x in series(s, k, "closure_position") if _ok(x)), default=math.nan) for k in ideal}
        held = [k for k in ideal if _ok(worst[k]) and worst[k] < IDEAL_CLOSURE]
        if held:
            roundoff = [k for k in held if worst[k] < ROUNDOFF]
            gaps = _join([f"{worst[k]:.1e} m ({_short(s, k)})" for k in held])
            if len(roundoff) == len(held):
                tail = f", round-off (below {ROUNDOFF:.0e} m)"
            elif roundoff:
                tail = f"; round-off (below {ROUNDOFF:.0e} m) for {_join([_short(s, k) for k in roundoff])}"
            else:
                tail = ""
            out.append(f"{_join([_label(s, k) for k in held])} keep{'s' if len(held) == 1 else ''} the loop closed "
                       f"below {_bound()} at every step: the largest gap is {gaps}{tail}.")
        for k in ideal:
            if k not in held:
                out.append(f"{_label(s, k)} does not keep the loop closed below {_bound()}: its largest gap is "
                           f"{_e(worst[k])} m.")
        for k in ideal:
            v0 = _at(s, k, "closure_velocity")
            if not (_ok(v0) and v0 > VELOCITY_HELD):
                continue
            p = loglog_slope(s.steps, series(s, k, "closure_velocity"))
            out.append(f"{_label(s, k)} does not hold the closure at the velocity level: the relative velocity at the cut "
                       f"is {_e(v0)} m/s at the scene's step"
                       + (f" and falls as dt^{_slope(p)} (a step error of a position-level constraint)." if _ok(p) and p > FLAT
                          else f" and does not fall with the step (slope {_slope(p)})."))
        if has_exact(s):
            parts = []
            for k in ideal:
                ex = _unsaturated(series(s, k, "exact"), unit)
                floor = levels_off(s.steps, ex)
                parts.append(f"{_e(_at(s, k, 'exact'))} ({_short(s, k)}, "
                             + (f"no longer falling: {floor[0]:.1e} from {_ms(floor[1])} down)" if floor is not None
                                else f"observed order {_slope(loglog_slope(s.steps, ex))})"))
            out.append(f"Against the exact solution, at the scene's step ({_ms(s.scene.dt)}) the ideal engines' error is "
                       f"{_join(parts)} {unit} (order: the log-log slope over the steps).")
    # 2. MuJoCo: the gap against the softness and the step
    floors = {k: levels_off(s.steps, series(s, k, "closure_position")) for k in mj}
    if WRITTEN in mj:
        gap = series(s, WRITTEN, "closure_position")
        ex = series(s, WRITTEN, "exact")
        clamp = clamped_steps(s)
        free = [(dt, g, e) for dt, g, e in zip(s.steps, gap, ex) if dt not in clamp]
        tc = min(ref[0] for ref, _ in s.written.values())
        text = (f"{SOFT_NAME}'s loop is open by {_e(_at(s, WRITTEN, 'closure_position'))} m at the scene's step "
                f"with the MJCF's settings (time constant {_ms(tc)}).")
        if len(free) >= 2:
            steps = [f[0] for f in free]
            p = loglog_slope(steps, [f[1] for f in free])
            pe = loglog_slope(steps, _unsaturated([f[2] for f in free], unit))
            g_lo, g_hi = min(f[1] for f in free), max(f[1] for f in free)
            flat = _ok(p) and abs(p) < FLAT
            if flat:
                text += (f" At the steps that keep this time constant ({_steps(steps)}) the gap stays within a factor "
                         f"{g_hi / g_lo:.2g} (slope {_slope(p)}): it follows the constraint's softness, not the step")
            else:
                text += f" At the steps that keep this time constant ({_steps(steps)}) the gap goes as dt^{_slope(p)}"
                floor = floors[WRITTEN]
                if floor is not None:
                    text += f", levelling off at {floor[0]:.1e} m from {_ms(floor[1])} down"
            if has_exact(s):
                lo, hi = min(f[2] for f in free), max(f[2] for f in free)
                if _ok(pe) and abs(pe) < FLAT:
                    text += (f"; {'so does the exact error' if flat else 'the exact error does not follow the step'} "
                             f"({_e(lo)} – {_e(hi)} {unit}, slope {_slope(pe)}).")
                else:
                    text += f"; the exact error goes as dt^{_slope(pe)} ({_e(hi)} – {_e(lo)} {unit})."
            else:
                text += "."
        if clamp:
            same = TWO_DT in mj and all(_same(s, WRITTEN, TWO_DT, dt) for dt in clamp)
            text += (f" At {_steps(clamp)} the file's time constant is below 2·dt and {SOFT_NAME} raises it to 2·dt"
                     + (": those runs are identical to the solref 2·dt row." if same else "."))
        out.append(text)
    if TWO_DT in mj:
        gap = series(s, TWO_DT, "closure_position")
        ex = series(s, TWO_DT, "exact")
        text = (f"With the time constant at 2·dt the gap shrinks with the step as dt^{_slope(loglog_slope(s.steps, gap))} "
                f"({_e(gap[0])} m at {_ms(s.steps[0])} to {_e(gap[-1])} m at {_ms(s.steps[-1])})")
        if has_exact(s):
            text += (f" and the exact error as dt^{_slope(loglog_slope(s.steps, _unsaturated(ex, unit)))} ({_e(ex[0])} to "
                     f"{_e(ex[-1])} {unit})")
        out.append(text + ".")
    ref_gap = _at(s, WRITTEN, "closure_position") if WRITTEN in mj else math.nan
    ref_ex = _at(s, WRITTEN, "exact") if WRITTEN in mj else math.nan
    for key, what in ((DEFAULT_SOLIMP_ONLY, f"{SOFT_NAME}'s default solimp alone (the file's solref)"),
                      (DEFAULTS, f"{SOFT_NAME}'s default solref and solimp")):
        if key not in mj:
            continue
        gap = series(s, key, "closure_position")
        p = loglog_slope(s.steps, gap)
        g0 = _at(s, key, "closure_position")
        text = (f"{what} leave{'s' if key.endswith('solimp') else ''} a gap of {_e(g0)} m at the scene's step, "
                f"{_times(g0, ref_gap)} the MJCF's")
        if _ok(p) and abs(p) < FLAT:
            text += f", whatever the step (slope {_slope(p)})"
        elif floors[key] is not None:
            text += f", the same at every step from {_ms(floors[key][1])} down"
        else:
            text += f" (slope {_slope(p)})"
        if has_exact(s):
            e0 = _at(s, key, "exact")
            text += f"; exact error {_e(e0)} {unit}" + (f" ({SATURATED_TEXT})" if _saturated(e0, unit) else
                                                        f", {_times(e0, ref_ex)} the MJCF's")
        out.append(text + ".")
    compliance = compliance_floors(s, floors)
    if compliance:
        out.append(compliance)
    if has_exact(s) and WRITTEN in mj and REFERENCE_ENGINE in have:
        out.append(f"At the scene's step {SOFT_NAME}'s exact error with the MJCF's settings is "
                   f"{_times(ref_ex, _at(s, REFERENCE_ENGINE, 'exact'))} the {display(REFERENCE_ENGINE)} engine's.")
    # 3. energy
    rows_e = [(k, _at(s, k, "energy")) for k in ideal + mj]
    rows_e = [(k, e) for k, e in rows_e if _ok(e)]
    if rows_e:
        quad = [_at(s, k, "energy_quadrature") for k, _ in rows_e if VARIANT[k].ideal]
        quad = [q for q in quad if _ok(q)]
        out.append(f"{energy_name(s).capitalize()} at the scene's step: "
                   + _join([f"{_e(e)} ({_short(s, k)})" for k, e in rows_e])
                   + (f"; the Richardson correction of the work's quadrature over the samples, an upper estimate of "
                      f"its error, is up to {_e(max(quad))} in the ideal engines' runs at that step" if quad else "") + ".")
    # 4. a variant of another studied scene: amplification at the shared steps
    if study is not None and s.scene.builder:
        base = next((b for b in study.scenes if b.scene.name == s.scene.builder), None)
        if base is not None:
            out += amplification(s, base)
    return [x[:1].upper() + x[1:] for x in out]


ROUNDOFF = 1e-12  # m: a closure gap below this is called round-off
SATURATED_TEXT = "≈ π, the largest a wrapped angle error can be: the motion is lost"


def _saturated(x: float, unit: str) -> bool:
    """An angle error (rad) near π: the wrapped difference cannot grow further."""
    return unit == "rad" and _ok(x) and x > 0.9 * math.pi


def _unsaturated(values: list[float], unit: str) -> list[float]:
    """``values`` with the saturated ones (``_saturated``) as NaN, for slopes and ratios."""
    return [math.nan if _saturated(v, unit) else v for v in values]


def levels_off(steps: list[float], values: list[float], within: float = 1.25) -> tuple[float, float] | None:
    """``(floor, step)`` when the values at the finer steps stop falling: the finest value and
    the coarsest step from which every value down to the finest is within a factor ``within``
    of it (at least the two finest steps); None otherwise."""
    pts = [(h, v) for h, v in zip(steps, values) if _ok(v) and v > 0]
    if len(pts) < 2:
        return None
    last = pts[-1][1]
    start = None
    for i in range(len(pts) - 1, -1, -1):
        if max(pts[i][1], last) / min(pts[i][1], last) <= within:
            start = i
        else:
            break
    if start is None or start > len(pts) - 2:
        return None
    return last, pts[start][0]


def compliance_floors(s: SceneStudy, floors: dict) -> str:
    """A sentence when the gap of the MJCF's settings and of MuJoCo's default solimp (same
    solref) both level off: the ratio of the floors against the ratio of the impedances'
    compliance (1 − d0)/d0 (d0 = solimp[0], the impedance at a gap well below solimp's width)."""
    a, b = floors.get(WRITTEN), floors.get(DEFAULT_SOLIMP_ONLY)
    if a is None or b is None:
        return ""
    d_file = min(imp[0] for _, imp in s.written.values())
    d_def = DEFAULT_SOLIMP[0]
    if not (0 < d_file < 1 and 0 < d_def < 1):
        return ""
    expected = ((1 - d_def) / d_def) / ((1 - d_file) / d_file)
    ratio = b[0] / a[0]
    text = (f"At the fine steps the gap levels off at {a[0]:.1e} m with the file's solimp (d0 = {d_file:g}) and at "
            f"{b[0]:.1e} m with the default's (d0 = {d_def:g}): a ratio of {_times(b[0], a[0])}")
    if 0.5 < ratio / expected < 2:
        return text + (f", that of their compliances (1 − d0)/d0, {_times(expected, 1.0)}: below these steps the gap "
                       f"is the constraint's compliance, not a step error.")
    return text + f" (the compliances (1 − d0)/d0 differ by {_times(expected, 1.0)})."


def _short(s: SceneStudy, key: str) -> str:
    label = _label(s, key)
    head, _, tail = label.partition(",")
    return f"{head.split()[0]}, {tail.strip()}" if tail else head.split()[0]


def _same(s: SceneStudy, a: str, b: str, dt: float) -> bool:
    ra, rb = s.row(a, dt), s.row(b, dt)
    if ra is None or rb is None:
        return False
    keys = ("closure_position", "closure_velocity", "energy", "exact")
    return all((not _ok(ra[k]) and not _ok(rb[k])) or ra[k] == rb[k] for k in keys)


def amplification(s: SceneStudy, base: SceneStudy) -> list[str]:
    """Sentences comparing a scene with the scene it varies (same builder) at the steps both
    sweeps share: the ratio of exact errors (angle errors near π left out: ``_saturated``) and,
    for MuJoCo, of closure gaps, per variant."""
    shared = [dt for dt in s.steps if any(abs(dt - b) <= 1e-12 * dt for b in base.steps)]
    if not shared:
        return []
    unit = exact_unit(s)

    def base_at(key, measure, dt):
        b = next(x for x in base.steps if abs(dt - x) <= 1e-12 * dt)
        return _at(base, key, measure, b)

    def ratios(key, measure):
        out = []
        for dt in shared:
            a, b = _at(s, key, measure, dt), base_at(key, measure, dt)
            if _ok(a) and _ok(b) and b > 0 and not (_saturated(a, unit) or _saturated(b, unit)):
                out.append(a / b)
        return out

    parts, gaps, ideal = [], [], []
    for key in s.variants():
        if key not in base.variants():
            continue
        if has_exact(s) and has_exact(base):
            r = ratios(key, "exact")
            if r:
                parts.append(f"{_fmt_ratio(r)} ({_short(s, key)})")
                if VARIANT[key].ideal:
                    ideal += r
        if VARIANT[key].engine == SOFT_LOOP_ENGINE:
            r = ratios(key, "closure_position")
            if r:
                gaps.append(f"{_fmt_ratio(r)} ({_short(s, key)})")
    out = []
    if parts:
        lead = (f"The ideal engines' errors are larger than on `{base.scene.name}`: at" if ideal and min(ideal) > 1
                else "At")
        left_out = any(_saturated(x, unit) for k in s.variants() for x in series(s, k, "exact"))
        out.append(f"{lead} the steps both `{s.scene.name}` and `{base.scene.name}` run ({_steps(shared)}), the exact "
                   f"error here is " + _join(parts) + f" that of `{base.scene.name}`"
                   + (" (runs whose error is near π left out)." if left_out else "."))
    if gaps:
        out.append(f"{SOFT_NAME}'s closure gap there is " + _join(gaps) + f" that of `{base.scene.name}`.")
    return out


def _fmt_ratio(ratios: list[float]) -> str:
    lo, hi = min(ratios), max(ratios)
    f = lambda r: f"{r:.2g}" if r < 10 else f"{r:.0f}"
    return f"{f(lo)}×" if hi <= lo * 1.05 else f"{f(lo)}–{f(hi)}×"


# ------------------------------------------------------------------------------ JSON
def as_json(study: LoopStudy, prov: dict, command: str) -> dict:
    """Everything the report shows, and each run's engine settings and exact-error detail."""
    return {
        "provenance": prov,
        "command": command,
        "quick": study.quick,
        "t_end_s": study.t_end,
        "factors": list(study.factors),
        "jobs": study.jobs,
        "timeout_s": study.timeout,
        "wall_s": study.wall_s,
        "ideal_closure_bound_m": IDEAL_CLOSURE,
        "failures": failures(study),
        "scenes": [{
            "scene": s.scene.name,
            "title": s.scene.title,
            "dt_s": s.scene.dt,
            "t_end_s": horizon(s.scene, study.t_end),
            "steps_s": s.steps,
            "save_every_s": s.saves,
            "energy": energy_name(s),
            "exact_unit": exact_unit(s),
            "mjcf_loop_settings": {name: {"solref": list(ref), "solimp": list(imp)} for name, (ref, imp) in s.written.items()},
            "not_run": s.not_run,
            "findings": findings(s, study),
            "error_models": [{"variant": k, "measure": q, "class": m.classification, "order": m.observed_order,
                              "floor": m.floor, "resolution": m.resolution, "unit": m.unit, "reason": m.reason}
                             for (k, q), m in error_models(s, horizon(s.scene, study.t_end)).items()],
            "runs": s.rows,
        } for s in study.scenes],
    }


# ------------------------------------------------------------------------------ plots
def plot_files(study: LoopStudy) -> dict[str, bytes]:
    """Per scene, ``loop_closure_<scene>.png``: closure gap (m) and exact error against the step
    (s), log-log, a line per engine/variant (non-positive or missing values left out)."""
    from harness.io.figures import new_figure, png_bytes

    files: dict[str, bytes] = {}
    for s in study.scenes:
        fig = new_figure(12, 5.6)
        axes = fig.subplots(1, 2)
        for ax, measure, ylabel in ((axes[0], "closure_position", "closure gap (m)"),
                                    (axes[1], "exact", f"exact error ({exact_unit(s) or '—'})")):
            drawn = False
            for key in s.variants():
                values = series(s, key, measure)
                pts = [(dt, v) for dt, v in zip(s.steps, values) if _ok(v) and v > 0]
                if not pts:
                    continue
                x, y = zip(*pts)
                style = "o-" if VARIANT[key].ideal else "s--"
                ax.loglog(x, y, style, label=_label(s, key), lw=1.3, ms=5)
                drawn = True
            if measure == "closure_position":
                ax.axhline(IDEAL_CLOSURE, color="k", lw=0.8, ls=":", label=f"{_bound()} bound (ideal engines)")
            if not drawn and measure == "exact":
                ax.text(0.5, 0.5, "no exact reference for this scene", ha="center", va="center", transform=ax.transAxes)
                ax.set_xticks([])
                ax.set_yticks([])
            ax.set_xlabel("step dt (s)")
            ax.set_ylabel(ylabel)
            ax.grid(True, which="both", alpha=0.3)
        handles: dict = {}
        for ax in axes:  # one legend for both panels, below them
            for h, label in zip(*ax.get_legend_handles_labels()):
                handles.setdefault(label, h)
        if handles:
            fig.legend(list(handles.values()), list(handles), loc="lower center", ncol=3, fontsize=7.5, frameon=False)
        fig.suptitle(f"{s.scene.name}: closure gap and exact error against the step")
        fig.tight_layout(rect=(0, 0.06 + 0.035 * math.ceil(len(handles) / 3), 1, 1))
        files[f"{NAME}_{s.scene.name}.png"] = png_bytes(fig, dpi=110)
    return files
