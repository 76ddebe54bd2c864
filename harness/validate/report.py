"""Validation report, written as one set (``harness.io.atomic.write_set``: a reader sees the old
set or the new one):

* ``validation.md`` (read by a person). It opens with the scene x engine matrix of the judging
  classes: per cell the worst class over the scene's checks on that engine (``defect`` > a run
  that failed or a model file that disagrees > ``not judged`` > an undeclared ``model
  difference`` > a declared one > ``converges``; the worst *failing* check where one fails),
  the observed order of the check that dominates (the largest error against its resolution)
  and its error at the scene's step in that check's unit, failing cells marked **✗**. Then the
  engines against each other per scene: each pair's trajectory difference extrapolated to zero
  step (``SceneValidation.cross_extrapolated``, rel or rad) beside the difference at the scene's
  step (``cross``, judged over the reference's motion scales). Then the error-against-step
  figure, then per scene: the parameters (those set away from their ``scene.toml`` defaults
  marked), the runs and the levels each was repeated at, engine warnings, the model files as
  written (``model.*`` checks, summarised when they agree) and every other check with its value,
  unit, class, observed order, floor, resolution, requirement (where the scene or the project
  states one) and the verdict's reason.
* ``validation_matrix.png``: the class matrix of ``validation.md`` (colour by class; text: class,
  error, order).
* ``validation_convergence.png``: error against step, one small log-log panel per scene: each
  fixed-step engine's ``trajectory.position`` (else the scene's check with the largest error)
  at its levels with the slope of its method's formal order hinted, and beside it, against the
  tolerance, the error-controlled runs (Drake's default, and the reference's ``exact``).
* ``validation.csv`` (one row per check), ``validation.json`` (everything, with provenance and the
  matrix) and ``validation.junit.xml`` (one test case per scene x engine x check, for CI systems;
  a failure's message is its class and the verdict's reason).
"""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pandas as pd

from harness.io import atomic
from harness.io.figures import new_figure, png_bytes
from harness.engines import DECLARATIONS, ENGINES as DECLARATIONS_BY_NAME, REFERENCE_ENGINE, declaration, display, made_with
from harness.io.provenance import command_line
from harness.judging.error_model import (
    CONVERGES,
    DEFECT,
    JUDGING_RESOLUTION,
    LOOSER,
    MODEL_DIFFERENCE,
    NOISE,
    NOT_JUDGED,
)
from harness.judging.error_model import UNRESOLVED_CLASS as UNRESOLVED
from harness.judging.quantities import TRAJECTORY, judged_max
from harness.judging.checks import CheckResult
from harness.validate.run import RunRecord, SceneValidation, as_dict

CSV_COLUMNS = ["scene", "engine", "check", "value", "tolerance", "unit", "passed", "detail", "classification", "order",
               "floor", "resolution", "requirement", "judged"]
MATRIX_PNG = "validation_matrix.png"
CONVERGENCE_PNG = "validation_convergence.png"
FILES = ("validation.md", "validation.csv", "validation.json", "validation.junit.xml", MATRIX_PNG, CONVERGENCE_PNG)

DECLARED = f"{MODEL_DIFFERENCE} (declared)"
RUN_FAILED = "run failed"    # a run that crashed, hung or blew up (its ``run`` check): nothing to judge
MODEL_FILE = "model file"    # a model file that disagrees with its scene (a failing ``model.*`` check)
#: The matrix's order of the classes, worst first (a cell shows its worst check's).
RANK = {DEFECT: 5, RUN_FAILED: 4, MODEL_FILE: 4, UNRESOLVED: 3, NOT_JUDGED: 3, MODEL_DIFFERENCE: 2, DECLARED: 1,
        CONVERGES: 0}
#: How a class reads in a matrix cell.
SHORT = {CONVERGES: "converges", DECLARED: "declared model diff.", MODEL_DIFFERENCE: "model diff.", DEFECT: "defect",
         UNRESOLVED: "unresolved", NOT_JUDGED: "not judged", RUN_FAILED: "run failed", MODEL_FILE: "model file"}
#: The matrix PNG's colour of each class.
COLOURS = {CONVERGES: "#a6d96a", DECLARED: "#abd9e9", MODEL_DIFFERENCE: "#fdae61", NOT_JUDGED: "#c2a5cf", UNRESOLVED: "#9e9ac8",
           DEFECT: "#d73027", RUN_FAILED: "#a50026", MODEL_FILE: "#f46d43"}
#: Each engine's colour in the convergence figure (the same in every report): the registry's
#: (``harness.engines.Declaration.colour``), the reference's black.
ENGINE_COLOURS = {"reference": "#000000", **{d.name: d.colour for d in DECLARATIONS if d.colour}}
FAIL_MARK = "✗"
NOT_RUN_MARK = "§"  # a matrix cell the scene excludes ([not_run] in its scene.toml)
REFERENCE = "reference"


# --------------------------------------------------------------------------- numbers


def _fmt(x: float | None) -> str:
    """A number in a table column: ``1.23e-04``; ``—`` where missing."""
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "—"
    if isinstance(x, float) and math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return "0" if x == 0 else f"{x:.2e}"


def _short(x: float | None) -> str:
    """A number in a matrix cell: two digits, a short exponent (``1.6e-3``); ``0``; ``—``."""
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "—"
    if x == 0:
        return "0"
    if math.isinf(x):
        return "inf"
    mantissa, exponent = f"{x:.1e}".split("e")
    return f"{mantissa}e{int(exponent)}"


def _order(p: float) -> str:
    if p is None or not math.isfinite(p):
        return "—"
    text = f"{p:.1f}"
    return "0.0" if text == "-0.0" else text


def _cell(text: str) -> str:
    """Text for a markdown table cell: a ``|`` (as in ``|E - E0|``) would end the cell."""
    return str(text).replace("|", "\\|")


def requirement(c: CheckResult) -> float:
    """The requirement on a judged check's value at the scene's step (its ``tolerance``), NaN where
    there is none (``inf``) or the check is not judged by convergence (``model.*``, ``run``: their
    ``tolerance`` is the file's rounding, or nothing)."""
    if c.check == "run" or c.check.startswith("model.") or not math.isfinite(c.tolerance):
        return float("nan")
    return float(c.tolerance)


def _name(check: str) -> str:
    """A check's name in a matrix cell: ``trajectory.`` left off (``orientation``)."""
    return check.removeprefix("trajectory.")


# --------------------------------------------------------------------------- classes and the matrix


def label(c: CheckResult) -> str:
    """The class a check counts as in the matrix: its ``classification``; for a failing check not
    judged by convergence ``run failed`` (``run``), ``model file`` (``model.*``) or ``not judged``
    (a value that could not be measured); "" for a passing ``model.*`` check."""
    if c.classification:
        return c.classification
    if c.passed:
        return ""
    if c.check == "run":
        return RUN_FAILED
    return MODEL_FILE if c.check.startswith("model.") else NOT_JUDGED


def size(c: CheckResult) -> float:
    """How large a check's error is, comparable across units: its value over its resolution
    (where both are known), else its value; a missing value counts as the largest."""
    if not math.isfinite(c.value):
        return math.inf
    if math.isfinite(c.resolution) and c.resolution > 0:
        return c.value / c.resolution
    return c.value


def dominant_check(checks: list[CheckResult]) -> CheckResult | None:
    """The check a matrix cell shows: among the failing checks (if any, else all) the one of the
    worst class (``RANK``), and within it the largest error against its resolution (``size``)."""
    if not checks:
        return None
    pool = [c for c in checks if not c.passed] or checks
    return max(pool, key=lambda c: (RANK.get(label(c), -1), size(c)))


def engines_of(results: list[SceneValidation]) -> list[str]:
    """The matrix's columns: ``reference`` first, then the engines in the order they ran (then any
    engine with checks but no run record, then any a scene excludes)."""
    seen: list[str] = []
    for v in results:
        for e in [r.engine for r in v.runs] + [c.engine for c in v.checks] + list(v.not_run):  # run order
            if e not in seen:
                seen.append(e)
    return sorted(seen, key=lambda e: (e != REFERENCE, seen.index(e)))


def _run(v: SceneValidation, engine: str) -> RunRecord | None:
    return next((r for r in v.runs if r.engine == engine), None)


def adaptive(v: SceneValidation, engine: str) -> bool:
    """Whether the engine's run of the scene is error-controlled (its levels are tolerances)."""
    r = _run(v, engine)
    return r is not None and r.rtol is not None


def matrix(results: list[SceneValidation]) -> tuple[list[str], dict[tuple[str, str], dict]]:
    """Engines (columns) and, per (scene, engine) that has checks: ``passed`` (every check),
    ``label`` (the dominant check's class), ``check`` (its ``CheckResult``, ``dominant_check``),
    ``adaptive`` (an error-controlled run: its order is in the tolerance), ``count`` and
    ``failed`` (numbers of checks)."""
    engines = engines_of(results)
    cells = {}
    for v in results:
        for e in engines:
            checks = [c for c in v.checks if c.engine == e]
            if not checks:
                continue
            d = dominant_check(checks)
            cells[(v.scene, e)] = {"passed": all(c.passed for c in checks), "label": label(d) or CONVERGES, "check": d,
                                   "adaptive": adaptive(v, e), "count": len(checks),
                                   "failed": sum(not c.passed for c in checks)}
    return engines, cells


def _order_text(c: CheckResult, is_adaptive: bool) -> str:
    """``p=2.0`` (in the step), ``q=1.0`` (in the tolerance), ``at res.`` (at the resolution), or ""."""
    if math.isfinite(c.order):
        return f"{'q' if is_adaptive else 'p'}={_order(c.order)}"
    if c.classification == CONVERGES and math.isfinite(c.resolution) and c.value <= NOISE * c.resolution:
        return "at res."
    return ""


def _error_text(c: CheckResult) -> str:
    return " ".join(x for x in (_short(c.value), c.unit) if x)


def cell_text(cell: dict) -> str:
    """A matrix cell in markdown: ``converges p=2.0 · 1.6e-3 rad orientation``; failing:
    ``**✗ defect** p=0.4 · 2.1e-2 rel position``."""
    c, lab = cell["check"], cell["label"]
    head = SHORT.get(lab, lab)
    if not cell["passed"]:
        head = f"**{FAIL_MARK} {head}**"
    if lab == RUN_FAILED:
        return f"{head} · {_cell(c.detail.split(':', 1)[0])}"
    if lab == MODEL_FILE:
        return f"{head} · {_short(c.value)} {c.unit} `{c.check}`".replace("  ", " ")
    order = _order_text(c, cell["adaptive"])
    text = f"{head}{' ' + order if order else ''} · {_error_text(c)} `{_name(c.check)}`"
    req = requirement(c)
    if not c.passed and math.isfinite(req) and c.value > req:
        text += f" > req. {_short(req)}"
    return text


def matrix_lines(results: list[SceneValidation]) -> list[str]:
    """The markdown matrix, a line counting its cells by class, and its legend."""
    engines, cells = matrix(results)
    lines = ["| scene | " + " | ".join(engines) + " |", "|---|" + "---|" * len(engines)]
    for v in results:
        row = []
        for e in engines:
            cell = cells.get((v.scene, e))
            if cell is None:
                row.append(f"not run [{NOT_RUN_MARK}](#{_anchor(v)})" if e in v.not_run else "—")
                continue
            row.append(cell_text(cell))
        verdict = "" if v.passed else f" **{FAIL_MARK}**"
        lines.append(f"| [{v.scene}](#{_anchor(v)}){verdict} | " + " | ".join(row) + " |")
    counts = {}
    for cell in cells.values():
        counts[cell["label"]] = counts.get(cell["label"], 0) + 1
    failing = sum(not cell["passed"] for cell in cells.values())
    tally = ", ".join(f"{counts[k]} {SHORT[k]}" for k in sorted(counts, key=lambda k: -RANK.get(k, -1)) if k in SHORT)
    legend = ("Cell: the worst class over the scene's checks on that engine (defect > run failed, model file > not "
              "judged > undeclared model diff. > declared model diff. > converges; the worst failing check where one "
              f"fails: **{FAIL_MARK}**), then the observed order of the check that dominates (the largest error over its "
              "resolution; p in the step, q in the tolerance of an error-controlled run, `at res.`: at the resolution) "
              "and its error at the scene's step (rel: over the scene's scale; `trajectory.` left off).")
    if any(v.not_run for v in results):
        legend += (f" not run {NOT_RUN_MARK}: the scene's `[not_run]` says why the engine cannot state it; the "
                   "scene's section below gives the reason.")
    lines += ["", f"Cells: {tally}; {failing} failing." if cells else "No cell was judged.", "", legend]
    return lines


def _anchor(v: SceneValidation) -> str:
    return f"{v.scene}--{'pass' if v.passed else 'fail'}"  # GitHub heading anchor of "## <scene> — PASS"


def matrix_png(results: list[SceneValidation]) -> bytes:
    """The class matrix as a picture: each cell coloured by its class (``COLOURS``), labelled
    with the class, the dominant check's error and unit, its name and the observed order;
    failing cells outlined and in bold; grey where the engine did not run."""
    from matplotlib.colors import to_rgb
    from matplotlib.patches import Patch, Rectangle

    engines, cells = matrix(results)
    scenes = [v.scene for v in results]
    image = np.ones((max(len(scenes), 1), max(len(engines), 1), 3))
    for i, s in enumerate(scenes):
        for j, e in enumerate(engines):
            cell = cells.get((s, e))
            image[i, j] = to_rgb(COLOURS.get(cell["label"], "#ffffff")) if cell else to_rgb("#eeeeee")
    fig = new_figure(2.1 * max(len(engines), 1) + 2.6, 0.62 * max(len(scenes), 1) + 1.9)
    ax = fig.subplots()
    ax.imshow(image, aspect="auto")
    for i, s in enumerate(scenes):
        for j, e in enumerate(engines):
            cell = cells.get((s, e))
            if cell is None:
                ax.text(j, i, "not run" if e in results[i].not_run else "—", ha="center", va="center", fontsize=8,
                        color="#555555")
                continue
            c, lab = cell["check"], cell["label"]
            head = SHORT.get(lab, lab) if cell["passed"] else f"{FAIL_MARK} {SHORT.get(lab, lab)}"
            if lab == RUN_FAILED:
                body = c.detail.split(":", 1)[0]
            else:
                order = _order_text(c, cell["adaptive"])
                body = f"{_error_text(c)} {_name(c.check)}" + (f"\n{order}" if order else "")
            ax.text(j, i, f"{head}\n{body}", ha="center", va="center", fontsize=8,
                    fontweight="normal" if cell["passed"] else "bold", linespacing=1.1)
            if not cell["passed"]:
                ax.add_patch(Rectangle((j - 0.48, i - 0.48), 0.96, 0.96, fill=False, edgecolor="black", linewidth=1.6))
    ax.set_xticks(range(len(engines)), engines, fontsize=9)
    ax.set_yticks(range(len(scenes)), scenes, fontsize=9)
    ax.xaxis.tick_top()
    ax.set_xticks(np.arange(-0.5, len(engines)), minor=True)
    ax.set_yticks(np.arange(-0.5, len(scenes)), minor=True)
    ax.grid(which="minor", color="white", linewidth=2)
    ax.tick_params(which="minor", length=0)
    total = sum(len(v.checks) for v in results)
    failed = sum(not c.passed for v in results for c in v.checks)
    ax.set_title(f"harness validate: {total - failed} of {total} checks hold; per cell the worst class, the error "
                 "at the scene's step of the check that dominates, its observed order", fontsize=9, pad=24)
    shown = [k for k in RANK if any(cell["label"] == k for cell in cells.values())]
    handles = [Patch(facecolor=COLOURS[k], edgecolor="none", label=SHORT[k]) for k in shown]
    handles.append(Patch(facecolor="white", edgecolor="black", linewidth=1.6, label=f"{FAIL_MARK} a check fails"))
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.01), ncol=min(len(handles), 4), fontsize=8,
              frameon=False)
    return png_bytes(fig, dpi=110, bbox_inches="tight")


# --------------------------------------------------------------------------- engine against engine


def _adaptive_defaults(results: list[SceneValidation]) -> str:
    """``"Drake's default, and "``: the engines whose runs are error-controlled (their scenes'
    default integrator), as the convergence figure's caption names them ("" for none)."""
    engines = list(dict.fromkeys(r.engine for v in results for r in v.runs
                                 if r.rtol is not None and r.engine in DECLARATIONS_BY_NAME))
    if not engines:
        return ""
    names = [f"{display(e)}'s" for e in engines]
    which = names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]
    return f"{which} default{'s' if len(names) > 1 else ''}, and "


def cross_lines(results: list[SceneValidation]) -> list[str]:
    """The engines against each other, per scene and pair: each judged trajectory quantity's
    difference extrapolated to zero step (``cross_extrapolated``) beside its difference at the
    scene's step (``cross``, over the reference's motion scales; raw SI where those are missing)."""
    rows = []
    for v in results:
        pairs = list(dict.fromkeys(list(v.cross) + list(v.cross_extrapolated)))
        for k, pair in enumerate(pairs):
            extrapolated = v.cross_extrapolated.get(pair, {})
            raw = v.cross.get(pair, {})
            at_step = judged_max(raw, v.scales) if raw and v.scales else {}
            cells = []
            for q in TRAJECTORY:
                x0 = extrapolated.get(q.check)
                cells.append(_difference(x0))
                if at_step:
                    cells.append(_fmt(at_step.get(q.name)))
                else:
                    found = raw.get(f"{q.name}_max")
                    cells.append(f"{_fmt(found)} {q.unit}" if found is not None else "—")
            scene = f"[{v.scene}](#{_anchor(v)})" if k == 0 else ""
            rows.append(f"| {scene} | {pair} | " + " | ".join(cells) + " |")
    if not rows:
        return []
    head = " | ".join(f"{q.name.replace('_', ' ')} ({q.judged_unit}) → 0 | at h" for q in TRAJECTORY)
    return ["## Engine against engine", "",
            "Each pair's largest difference over bodies and samples, extrapolated to zero step (→ 0: what remains "
            "between the two engines' models once their steps are gone; from the scene's level and the second one, "
            "with the order and ratio of the engine whose second level moved more) and at the scene's step (at h), "
            "in the checks' units (rel over the reference's motion scales, orientation in rad). **Bold**: above "
            f"{NOISE * JUDGING_RESOLUTION:.0e}, {NOISE:g} times the judging resolution; — where a pair has no second "
            "level to extrapolate from.", "",
            f"| scene | pair | {head} |", "|---|---|" + "---|" * (2 * len(TRAJECTORY))] + rows + [""]


def _difference(x: float | None) -> str:
    if x is None:
        return "—"
    text = _fmt(x)
    return f"**{text}**" if math.isfinite(x) and x > NOISE * JUDGING_RESOLUTION else text


# --------------------------------------------------------------------------- error against step


def plotted_check(v: SceneValidation) -> str | None:
    """The check a scene's convergence panel shows: ``trajectory.position`` where an engine has it
    at two levels or more, else the engine check (not the reference's) with the largest error
    against its resolution; None where no check has levels."""
    leveled = [c for c in v.checks if len(c.levels) >= 2]
    if any(c.check == "trajectory.position" for c in leveled):
        return "trajectory.position"
    engines = [c for c in leveled if c.engine != REFERENCE] or leveled
    return max(engines, key=size).check if engines else None


def _formal_order(v: SceneValidation, engine: str) -> float | None:
    """The formal order of the method the engine's run used (``Integrator.order``), None where
    unknown."""
    r = _run(v, engine)
    if r is None:
        return None
    try:
        from harness.engines import integrator
        from harness.judging.checks import run_engine

        return float(integrator(run_engine(engine), r.integrator).order)
    except Exception:  # noqa: BLE001 - an engine not installed here: no slope hint
        return None


def convergence_png(results: list[SceneValidation]) -> bytes:
    """Error against step, a small log-log panel per scene (``plotted_check``) of each fixed-step
    engine's error at its levels (the scene's level filled, the others open; a failing check
    drawn with a cross), a dashed line of its method's formal order through the scene's level, the
    resolution dotted; beside it, on its own axis, the error-controlled runs against their
    tolerance (Drake's default; the reference's own ``exact`` where it has no such check)."""
    from matplotlib.lines import Line2D
    from matplotlib.ticker import NullLocator

    scenes = [(v, plotted_check(v)) for v in results]
    scenes = [(v, q) for v, q in scenes if q is not None]
    engines = engines_of(results)
    others = iter(["#8c564b", "#e377c2", "#17becf", "#bcbd22", "#7f7f7f"] * 4)
    colour = {e: ENGINE_COLOURS.get(e) or next(others) for e in engines}
    ncols = max(1, min(3, len(scenes)))
    nrows = max(1, math.ceil(len(scenes) / ncols))
    height = 2.9 * nrows + 0.7
    fig = new_figure(5.0 * ncols, height)
    if not scenes:
        fig.text(0.5, 0.5, "no check was judged at more than one level", ha="center", va="center", fontsize=10)
        return png_bytes(fig, dpi=100)
    outer = fig.add_gridspec(nrows, ncols, wspace=0.22, hspace=0.62, left=0.06, right=0.99, bottom=0.6 / height,
                             top=1.0 - 0.75 / height)
    used = set()
    for k, (v, check) in enumerate(scenes):
        pair = outer[divmod(k, ncols)].subgridspec(1, 2, width_ratios=[3.0, 1.2], wspace=0.06)
        ax = fig.add_subplot(pair[0])
        axt = fig.add_subplot(pair[1], sharey=ax)
        unit, resolutions, steps, tols, reference_exact = "", [], set(), set(), False
        for e in engines:
            c = next((x for x in v.checks if x.engine == e and x.check == check and len(x.levels) >= 2), None)
            if c is None and e == REFERENCE:
                c = next((x for x in v.checks if x.engine == e and x.check == "exact" and len(x.levels) >= 2), None)
                reference_exact = c is not None
            if c is None:
                continue
            pts = sorted((s, y) for s, y in c.levels if s > 0 and math.isfinite(y) and y > 0)
            if not pts:
                continue
            is_adaptive = adaptive(v, e)
            target = axt if is_adaptive else ax
            (tols if is_adaptive else steps).update(s for s, _ in pts)
            if c.check == check:
                unit = unit or c.unit
                if math.isfinite(c.resolution):
                    resolutions.append(c.resolution)
            xs, ys = zip(*pts)
            target.plot(xs, ys, "-", color=colour[e], linewidth=1.2, marker="o", markersize=4, markerfacecolor="white")
            s0, y0 = c.levels[0]
            if s0 > 0 and math.isfinite(y0) and y0 > 0:
                target.plot([s0], [y0], marker="o" if c.passed else "X", markersize=6 if c.passed else 9,
                            color=colour[e], markeredgecolor="black" if not c.passed else colour[e], linestyle="")
                p = 1.0 if is_adaptive else _formal_order(v, e)
                if p:
                    lo, hi = min(xs) / 1.3, max(xs) * 1.3
                    target.plot([lo, hi], [y0 * (lo / s0) ** p, y0 * (hi / s0) ** p], "--", color=colour[e],
                                linewidth=0.8, alpha=0.5)
            used.add(e)
        if resolutions:
            res = float(np.median(resolutions))
            for a in (ax, axt):
                a.axhline(res, color="#777777", linestyle=":", linewidth=1.0)
        ax.set_yscale("log")
        for a, levels, what in ((ax, steps, "step (s)"), (axt, tols, "tolerance")):
            a.set_xscale("log")
            a.xaxis.set_minor_locator(NullLocator())
            a.set_xticks(sorted(levels), [f"{x:g}" for x in sorted(levels)])
            a.set_xlabel(what, fontsize=8)
            a.tick_params(labelsize=8)
            a.grid(True, which="major", linewidth=0.4, alpha=0.5)
        if len(tols) > 2:
            axt.tick_params(axis="x", labelrotation=40)
        axt.tick_params(labelleft=False)
        ax.set_title(f"{v.scene}: {_name(check)}" + (f" ({unit})" if unit else ""), fontsize=9, loc="left")
        if reference_exact and check != "exact":
            axt.set_xlabel("tolerance\n(reference: exact)", fontsize=8)
        if not [ln for ln in axt.lines if ln.get_linestyle() != ":"]:
            axt.text(0.5, 0.5, "none", transform=axt.transAxes, ha="center", va="center", fontsize=8, color="#777777")
        if not [ln for ln in ax.lines if ln.get_linestyle() != ":"]:
            ax.text(0.5, 0.5, "no fixed-step run", transform=ax.transAxes, ha="center", va="center", fontsize=8,
                    color="#777777")
    handles = [Line2D([], [], color=colour[e], marker="o", label=e) for e in engines if e in used]
    handles += [Line2D([], [], color="#555555", linestyle="--", linewidth=0.8, label="formal order's slope"),
                Line2D([], [], color="#777777", linestyle=":", label="resolution"),
                Line2D([], [], color="#555555", marker="o", linestyle="", label="scene's level"),
                Line2D([], [], color="#555555", marker="o", markerfacecolor="white", linestyle="", label="other levels"),
                Line2D([], [], color="#555555", marker="X", markeredgecolor="black", linestyle="",
                       label="scene's level, check fails")]
    fig.legend(handles=handles, loc="center left", bbox_to_anchor=(1.0, 0.5), fontsize=8, frameon=False)
    fig.suptitle("Error against step: per scene, fixed-step runs against their step (left), error-controlled runs "
                 f"against their tolerance and {LOOSER:g}x it (right)", fontsize=10, y=1.0 - 0.15 / height)
    return png_bytes(fig, dpi=100, bbox_inches="tight")


# --------------------------------------------------------------------------- markdown


def _parameters_line(v: SceneValidation) -> str:
    parts = []
    for k, val in v.parameters.items():
        if k in v.overrides:
            parts.append(f"**{k} = {val}** (default {v.overrides[k]['default']})")
        else:
            parts.append(f"{k} = {val}")
    head = "Parameters (scene.toml defaults" + (", **bold**: set by --set, or following a set one (its builder's FOLLOWS)" if v.overrides else "") + "): "
    return head + ", ".join(parts)


def _model_lines(v: SceneValidation) -> list[str]:
    """One line per engine whose model file agrees; failing ``model.*`` checks stay in the table."""
    out, built = [], []
    for e in engines_of([v]):
        model = [c for c in v.checks if c.engine == e and c.check.startswith("model.")]
        if not model:
            continue
        if e in DECLARATIONS_BY_NAME and not declaration(e).reads:  # no file: its system as built
            built.append(display(e))
        bad = [c for c in model if not c.passed]
        source = model[0].detail.split(" vs scene.toml defaults", 1)[0]  # "<file> as written", or Exudyn's build
        if bad:
            out.append(f"- {e} ({source}): **{len(bad)} of {len(model)} quantities disagree** "
                       f"({', '.join(c.check for c in bad)}): see the table")
        else:
            bodies = {c.check.split(".")[1] for c in model if c.check.count(".") == 2}
            w = max(model, key=lambda c: c.value / c.tolerance if c.tolerance > 0 else c.value)
            out.append(f"- {e} ({source}): all {len(model)} quantities of {len(bodies)} "
                       f"{'body' if len(bodies) == 1 else 'bodies'} agree; "
                       f"worst {_fmt(w.value)} {w.unit} (`{w.check}`, tolerance {_fmt(w.tolerance)})")
    if out:
        out = ["Model files as written"
               + (f" ({', '.join(built)}: {'its system' if len(built) == 1 else 'their systems'} as built from the "
                  "description)" if built else "") + " against the scene.toml "
               "defaults (mass, centre of mass, inertia, joint position, type and axis per body; gravity where the "
               "model states it):", ""] + out + [""]
    return out


def warning_lines(v: SceneValidation) -> list[str]:
    """The scene's "Engine warnings" section: per run whose engine reported warnings
    (``RunRecord.warnings``, ``{"count", "first"}``), how many and the first; empty when none did."""
    out = []
    for r in v.runs:
        count = int((r.warnings or {}).get("count", 0) or 0)
        if count:
            out.append(f"- {r.engine} ({r.integrator}): {count} warning{'s' if count != 1 else ''}; "
                       f"first: {_cell(r.warnings.get('first', ''))}")
    return ["Engine warnings (captured during the run, not printed):", ""] + out + [""] if out else []


def _levels_of(v: SceneValidation, engine: str) -> str:
    """The levels an engine's run was judged at (the scene's first): steps in s, or tolerances."""
    levels = max((c.levels for c in v.checks if c.engine == engine), key=len, default=())
    return ", ".join(f"{s:g}" for s, _ in levels) if levels else "—"


def _class_cell(c: CheckResult) -> str:
    lab = label(c)
    if c.passed:
        return lab or "ok"
    return f"**{FAIL_MARK} {lab}**" if lab else f"**{FAIL_MARK}**"


def check_rows(v: SceneValidation) -> list[str]:
    """The scene's check table (the agreeing ``model.*`` checks are summarised above it)."""
    out = ["| engine | check | value | unit | class | order | floor | resolution | requirement | reason | note |",
           "|---|---|---|---|---|---|---|---|---|---|---|"]
    for c in v.checks:
        if c.check.startswith("model.") and c.passed:
            continue  # summarised above
        req = requirement(c)
        if c.check.startswith("model."):  # held to the file's rounding, not judged by convergence
            req = c.tolerance
        reason = c.judged or ("" if c.passed else c.detail)
        note = c.detail if c.judged or c.passed else ""
        out.append(f"| {c.engine} | {c.check} | {_fmt(c.value)} | {c.unit} | {_class_cell(c)} | {_order(c.order)} | "
                   f"{_fmt(c.floor)} | {_fmt(c.resolution)} | {'' if math.isnan(req) else _fmt(req)} | "
                   f"{_cell(reason)} | {_cell(note)} |")
    return out


def markdown(results: list[SceneValidation], prov: dict) -> str:
    """The human-readable report."""
    total = sum(len(v.checks) for v in results)
    failed = sum(not c.passed for v in results for c in v.checks)
    lines = [
        "# Validation report",
        "",
        f"Made {prov['date_utc']} with {made_with(prov)}."
        + (f" The run took {prov['wall_s']} s wall on {prov.get('cpus', '?')} CPUs." if "wall_s" in prov else ""),
        "",
        f"**{total - failed} of {total} checks hold; {failed} fail.** Reproduce with `{command_line()}`.",
        "",
    ]
    lines += matrix_lines(results)
    lines += [
        "",
        "How each check is judged (`harness/judging/`): the run is repeated at twice the scene's step (and at half "
        f"of it where those two leave the class open) or, error-controlled, at a {LOOSER:g} times looser tolerance; "
        "the check's values at those levels give its observed order, the floor that does not shrink with the step "
        "and the resolution below which nothing is resolved. *converges*: the error falls at about the method's order "
        "or sits at the resolution; *model difference*: a floor, which passes only where the scene declares the "
        "engine's model different (declared) and within its bound; *defect*: an order far below the method's, an "
        "error that grows with refinement, a non-finite value; *unresolved*: an error of the motion's own size at the "
        "scene's step (a chaotic or fast motion the step does not resolve); *not judged*: no second level ran to the "
        "end. A "
        "requirement (the scene's `[requirements]` or `--requirements`) bounds a check's value at the scene's step. "
        f"Trajectories are judged against the {display(REFERENCE_ENGINE)} solver with SciPy DOP853 at rtol = atol = 1e-12 (row "
        "`reference`, itself judged against the exact solution). Units: `rel` a ratio (drifts over the energy or "
        "momentum scale, trajectory errors over the motion scales, `harness.judging.quantities`), else SI.",
        "",
    ]
    lines += cross_lines(results)
    lines += ["## Error against step", "",
              f"![error against step]({CONVERGENCE_PNG})", "",
              "Per scene: each engine's `trajectory.position` error (else the check named in the panel) at the levels it "
              "was run at, the scene's level filled (a cross where the check fails), the slope of the method's formal "
              f"order dashed through it, the resolution dotted; error-controlled runs ({_adaptive_defaults(results)}the "
              f"reference's own `exact`) on the narrow axis against their tolerance. The class matrix as a picture: "
              f"`{MATRIX_PNG}`.", ""]
    for v in results:
        lines += [f"## {v.scene} — {'PASS' if v.passed else 'FAIL'}", ""]
        lines += [_parameters_line(v), ""]
        for e, why in v.not_run.items():
            lines += [f"Not run on {e} {NOT_RUN_MARK}: {why} (`[not_run]` in the scene's scene.toml).", ""]
        if v.tolerance_changes:
            lines += ["Requirements changed by the requirements file: " + "; ".join(v.tolerance_changes), ""]
        lines += ["| run | integrator | dt (s) | rtol | levels (s, or tolerance) | status | steps | wall (s) | settings |",
                  "|---|---|---|---|---|---|---|---|---|"]
        for r in v.runs:
            rtol = f"{r.rtol:g}" if r.rtol else "—"
            dt = "adaptive" if r.rtol else f"{r.dt:g}"
            steps = "—" if r.steps != r.steps else f"{r.steps:.0f}"
            lines.append(f"| {r.engine} | {r.integrator} | {dt} | {rtol} | {_levels_of(v, r.engine)} | "
                         f"{r.status}{': ' + _cell(r.message) if r.message else ''} | "
                         f"{steps} | {r.wall_s:.2f} | {_cell(r.settings)} |")
        lines.append("")
        lines += warning_lines(v)
        lines += _model_lines(v)
        lines += check_rows(v)
        if v.cross:
            lines += ["", "Engine against engine at the scene's step, raw (max over bodies and samples):", "",
                      "| pair | position (m) | orientation (rad) | velocity (m/s) | angular velocity (rad/s) |", "|---|---|---|---|---|"]
            for pair, e in v.cross.items():
                lines.append(f"| {pair} | {_fmt(e.get('position_max'))} | {_fmt(e.get('orientation_max'))} | "
                             f"{_fmt(e.get('velocity_max'))} | {_fmt(e.get('angular_velocity_max'))} |")
        lines.append("")
    return "\n".join(lines)


# --------------------------------------------------------------------------- CSV, JSON, JUnit


def checks_frame(results: list[SceneValidation]) -> pd.DataFrame:
    """One row per check (``CSV_COLUMNS``; ``requirement``: the bound on a judged check's value at
    the scene's step, empty where none)."""
    rows = [{**{k: getattr(c, k) for k in CSV_COLUMNS if hasattr(c, k)}, "requirement": requirement(c)}
            for v in results for c in v.checks]
    return pd.DataFrame(rows, columns=CSV_COLUMNS)


def payload(results: list[SceneValidation], prov: dict) -> dict:
    """``validation.json``: provenance, verdict, the class matrix (per scene and engine: class,
    passed, the dominant check, its value, unit and order) and every scene (``as_dict``)."""
    _, cells = matrix(results)
    table: dict[str, dict] = {}
    for (scene, engine), cell in cells.items():
        c = cell["check"]
        table.setdefault(scene, {})[engine] = {"class": cell["label"], "passed": cell["passed"], "check": c.check,
                                               "value": c.value, "unit": c.unit, "order": c.order,
                                               "order_in": "tolerance" if cell["adaptive"] else "step",
                                               "checks": cell["count"], "failed": cell["failed"]}
    return {"provenance": prov, "passed": all(v.passed for v in results), "matrix": table,
            "scenes": [as_dict(v) for v in results]}


#: Wall-clock budget (s) of drawing the convergence figure in its worker.
FIGURE_TIMEOUT = 300.0


def write_reports(results: list[SceneValidation], prov: dict, out_dir: Path) -> list[Path]:
    """Write the report set (``FILES``) into ``out_dir`` as one set; returns their paths. The
    convergence figure is drawn in a worker process beside the rest (``harness.validate.workers``:
    it dies with this process), the slowest part of the report."""
    from harness.validate.workers import open_workers

    with open_workers(2) as workers:
        workers.start("convergence", convergence_png, (results,), FIGURE_TIMEOUT)
        matrix = matrix_png(results)
        text = {"validation.md": markdown(results, prov),
                "validation.csv": checks_frame(results).to_csv(index=False),
                "validation.json": json.dumps(payload(results, prov), indent=2, default=_json_default, allow_nan=True),
                "validation.junit.xml": junit_xml(results, prov)}
        ((_, drawn),) = workers.wait()
    if drawn.status != "ok":
        raise RuntimeError(f"drawing {CONVERGENCE_PNG}: {drawn.status}: {drawn.message}")
    files = {**text, MATRIX_PNG: matrix, CONVERGENCE_PNG: drawn.value}
    assert tuple(files) == FILES
    return atomic.write_set(Path(out_dir), files)


def junit_xml(results: list[SceneValidation], prov: dict) -> str:
    """JUnit XML: a test suite per scene, a test case per engine x check (``classname`` =
    ``scene.engine``); a failure's message is the check's class and the verdict's reason (the
    detail for a run or model check), its type ``run``, ``model``, ``requirement`` or the class,
    its text the check's detail and levels; an engine the scene excludes (``[not_run]``) is one
    skipped case saying why."""
    suites = ET.Element("testsuites", name="harness validate")
    for v in results:
        failures = sum(not c.passed for c in v.checks)
        wall = sum(r.wall_s for r in v.runs)
        suite = ET.SubElement(suites, "testsuite", name=v.scene, tests=str(len(v.checks) + len(v.not_run)),
                              failures=str(failures), errors="0", skipped=str(len(v.not_run)), time=f"{wall:.3f}",
                              timestamp=prov["date_utc"])
        props = ET.SubElement(suite, "properties")
        for key in (*(d.name for d in DECLARATIONS if d.library), "numpy", "scipy", "python", "machine"):
            if key in prov:
                ET.SubElement(props, "property", name=key, value=str(prov[key]))
        for e, why in v.not_run.items():  # the scene excludes the engine ([not_run]): a skipped case, with why
            case = ET.SubElement(suite, "testcase", classname=f"{v.scene}.{e}", name="not_run")
            ET.SubElement(case, "skipped", message=why)
        for c in v.checks:
            case = ET.SubElement(suite, "testcase", classname=f"{v.scene}.{c.engine}", name=c.check)
            if not c.passed:
                failure = ET.SubElement(case, "failure", message=f"{label(c)}: {c.judged or c.detail}",
                                        type=_failure_type(c))
                text = [f"{_fmt(c.value)} {c.unit}".strip(), c.detail]
                if c.levels:
                    text.append("levels: " + ", ".join(f"{_fmt(y)} at {s:g}" for s, y in c.levels))
                failure.text = "; ".join(t for t in text if t)
    ET.indent(suites)
    return '<?xml version="1.0" encoding="utf-8"?>\n' + ET.tostring(suites, encoding="unicode") + "\n"


def _failure_type(c: CheckResult) -> str:
    if c.check == "run":
        return "run"
    if c.check.startswith("model."):
        return "model"
    if "beyond the requirement" in c.judged:
        return "requirement"
    return label(c)


def _json_default(o):
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    return str(o)
