"""Validation report: ``validation.md`` (read by a person), ``validation_matrix.png`` (the scene x
engine matrix as a heatmap), ``validation.csv`` (one row per check), ``validation.json``
(everything, with provenance) and ``validation.junit.xml`` (one test case per scene x engine x
check, for CI systems). Written as one set (``harness.io.atomic.write_set``): a reader sees the old
set or the new one.

``validation.md`` opens with the scene x engine matrix: PASS/FAIL and the worst margin (value /
tolerance; 1 = at the tolerance) with the check that sets it (the worst failing check when one
fails). Then, per scene: the parameters (those set away from their ``scene.toml`` defaults
marked), the runs, the model files as written (``model.*`` checks, summarised when they agree),
every other check with its value, tolerance and unit each in its own column, an "Engine
warnings" list when an engine reported warnings during its run (``RunRecord.warnings``: MuJoCo's
captured C warnings, count and first message), and the engines against each other. A check whose tolerance is a regression bound (what the engine reaches, with
a margin, not what the physics demands: ``harness.validate.quantities.regression_only``) is
marked, in the matrix and in its row.
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
from harness.io.provenance import command_line, made_with
from harness.validate.run import CheckResult, SceneValidation, as_dict

CSV_COLUMNS = ["scene", "engine", "check", "value", "tolerance", "unit", "passed", "detail", "regression_only", "margin"]
REGRESSION_MARK = "†"
FILES = ("validation.md", "validation.csv", "validation.json", "validation.junit.xml", "validation_matrix.png")


def checks_frame(results: list[SceneValidation]) -> pd.DataFrame:
    """One row per check (``CSV_COLUMNS``; ``margin`` = value / tolerance)."""
    rows = [dict(c.__dict__, margin=c.margin) for v in results for c in v.checks]
    return pd.DataFrame(rows, columns=CSV_COLUMNS)


def _fmt(x: float) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "—"
    return f"{x:.2e}"


def _cell(text: str) -> str:
    """Text for a markdown table cell: a ``|`` (as in ``|E - E0|``) would end the cell."""
    return str(text).replace("|", "\\|")


def _fmt_margin(m: float) -> str:
    if m is None or math.isnan(m):
        return "—"
    if math.isinf(m):
        return "inf"
    return f"{m:.2g}"


# --------------------------------------------------------------------------- the matrix


def engines_of(results: list[SceneValidation]) -> list[str]:
    """The matrix's columns: ``reference`` first, then the engines in the order they ran (then any
    engine with checks but no run record, then any a scene excludes)."""
    seen: list[str] = []
    for v in results:
        for e in [r.engine for r in v.runs] + [c.engine for c in v.checks] + list(v.not_run):  # run order
            if e not in seen:
                seen.append(e)
    return sorted(seen, key=lambda e: (e != "reference", seen.index(e)))


def worst_check(checks: list[CheckResult]) -> CheckResult | None:
    """The check that sets a cell's verdict and margin: among failing checks (if any) the one
    with the largest margin (a missing value counts as the largest), else the largest margin."""
    if not checks:
        return None
    failing = [c for c in checks if not c.passed]
    pool = failing or checks

    def key(c: CheckResult) -> float:
        m = c.margin
        return math.inf if math.isnan(m) else m

    return max(pool, key=key)


NOT_RUN_MARK = "§"  # a matrix cell the scene excludes ([not_run] in its scene.toml)


def matrix(results: list[SceneValidation]) -> tuple[list[str], dict[tuple[str, str], dict]]:
    """Engines (columns) and, per (scene, engine) that has checks: ``passed``, ``worst`` (its
    ``CheckResult``), ``margin``, ``count`` and ``regression`` (any check there a regression bound)."""
    engines = engines_of(results)
    cells = {}
    for v in results:
        for e in engines:
            checks = [c for c in v.checks if c.engine == e]
            if not checks:
                continue
            w = worst_check(checks)
            cells[(v.scene, e)] = {"passed": all(c.passed for c in checks), "worst": w, "margin": w.margin,
                                   "count": len(checks), "regression": any(c.regression_only for c in checks)}
    return engines, cells


def matrix_lines(results: list[SceneValidation]) -> list[str]:
    """The markdown matrix and its legend."""
    engines, cells = matrix(results)
    lines = ["| scene | " + " | ".join(engines) + " |", "|---|" + "---|" * len(engines)]
    for v in results:
        row = []
        for e in engines:
            cell = cells.get((v.scene, e))
            if cell is None:
                row.append(f"not run [{NOT_RUN_MARK}](#{_anchor(v)})" if e in v.not_run else "—")
                continue
            verdict = "PASS" if cell["passed"] else "**FAIL**"
            mark = f" {REGRESSION_MARK}" if cell["regression"] else ""
            row.append(f"{verdict} {_fmt_margin(cell['margin'])} `{cell['worst'].check}`{mark}")
        lines.append(f"| [{v.scene}](#{_anchor(v)}) | " + " | ".join(row) + " |")
    legend = ("Each cell: the verdict of every check of that scene on that engine, the worst margin "
              "(value / tolerance; 1 = at the tolerance) and the check that sets it (the worst failing one when "
              "a check fails).")
    if any(v.not_run for v in results):
        legend += (f" not run {NOT_RUN_MARK}: the scene's `[not_run]` says why the engine cannot state it; the "
                   "scene's section below gives the reason.")
    if any(cell["regression"] for cell in cells.values()):
        legend += (f" {REGRESSION_MARK}: some of the cell's tolerances are regression bounds (what the engine reaches, "
                   "with a margin, not what the physics demands; rows marked `regression` below).")
    lines += ["", legend]
    return lines


def _anchor(v: SceneValidation) -> str:
    return f"{v.scene}--{'pass' if v.passed else 'fail'}"  # GitHub heading anchor of "## <scene> — PASS"


def matrix_png(results: list[SceneValidation]) -> bytes:
    """The scene x engine matrix as a heatmap: colour log10 of the worst margin of a passing cell
    (green far inside the tolerance, yellow at it), red for a failing cell, grey where the engine
    did not run; each cell labelled with verdict, margin and check."""
    from matplotlib.colors import LinearSegmentedColormap, Normalize

    engines, cells = matrix(results)
    scenes = [v.scene for v in results]
    lo, hi = -6.0, 0.0  # log10 margin: a passing cell lies in [lo, hi]; a failing one is drawn red ("over")
    data = np.full((len(scenes), len(engines)), np.nan)
    for i, s in enumerate(scenes):
        for j, e in enumerate(engines):
            cell = cells.get((s, e))
            if cell is not None:
                m = cell["margin"]
                data[i, j] = hi + 1.0 if (not cell["passed"] or not np.isfinite(m)) else np.log10(max(m, 10.0 ** lo))
    fig = new_figure(2.3 * max(len(engines), 1) + 2.4, 0.62 * max(len(scenes), 1) + 1.6, tight_layout=True)
    ax = fig.subplots()
    cmap = LinearSegmentedColormap.from_list("margin", ["#1a9850", "#a6d96a", "#fee08b"]).with_extremes(
        bad="#dddddd", over="#d73027")
    im = ax.imshow(np.ma.masked_invalid(data), cmap=cmap, norm=Normalize(lo, hi), aspect="auto")
    for i, s in enumerate(scenes):
        for j, e in enumerate(engines):
            cell = cells.get((s, e))
            if cell is None:
                ax.text(j, i, "not run", ha="center", va="center", fontsize=7)
                continue
            verdict = "PASS" if cell["passed"] else "FAIL"
            mark = f" {REGRESSION_MARK}" if cell["regression"] else ""
            ax.text(j, i, f"{verdict} {_fmt_margin(cell['margin'])}{mark}\n{cell['worst'].check}", ha="center",
                    va="center", fontsize=7, fontweight="normal" if cell["passed"] else "bold")
    ax.set_xticks(range(len(engines)), engines)
    ax.set_yticks(range(len(scenes)), scenes)
    ax.xaxis.tick_top()
    total = sum(len(v.checks) for v in results)
    failed = sum(not c.passed for v in results for c in v.checks)
    ax.set_title(f"harness validate: {total - failed} of {total} checks hold; worst margin = value / tolerance"
                 + (f" ({REGRESSION_MARK} regression bound)" if any(c["regression"] for c in cells.values()) else ""),
                 fontsize=9)
    bar = fig.colorbar(im, ax=ax, fraction=0.04, pad=0.02, extend="max")
    bar.set_label("log10(worst margin) of passing cells; red: FAIL", fontsize=8)
    return png_bytes(fig, dpi=110)


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
    out = []
    for e in engines_of([v]):
        model = [c for c in v.checks if c.engine == e and c.check.startswith("model.")]
        if not model:
            continue
        bad = [c for c in model if not c.passed]
        source = model[0].detail.split(" vs scene.toml defaults", 1)[0]  # "<file> as written", or Exudyn's build
        if bad:
            out.append(f"- {e} ({source}): **{len(bad)} of {len(model)} quantities disagree** "
                       f"({', '.join(c.check for c in bad)}): see the table")
        else:
            bodies = {c.check.split(".")[1] for c in model if c.check.count(".") == 2}
            w = worst_check(model)
            out.append(f"- {e} ({source}): all {len(model)} quantities of {len(bodies)} "
                       f"{'body' if len(bodies) == 1 else 'bodies'} agree; "
                       f"worst {_fmt(w.value)} {w.unit} (`{w.check}`, tolerance {_fmt(w.tolerance)})")
    if out:
        out = ["Model files as written (Exudyn: its system as built from the description) against the scene.toml "
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
        "Reference for trajectories: the in-house solver with SciPy DOP853 at rtol = atol = 1e-12 "
        "(row `reference`, itself checked against the exact solution). Relative drifts are over the "
        "scene's energy scale (max kinetic energy + range of potential energy) or momentum scale; "
        "relative trajectory errors over the motion scales (`harness.validate.quantities`). Units: "
        "`rel` a ratio, else SI.",
        "",
    ]
    for v in results:
        lines += [f"## {v.scene} — {'PASS' if v.passed else 'FAIL'}", ""]
        lines += [_parameters_line(v), ""]
        for e, why in v.not_run.items():
            lines += [f"Not run on {e} {NOT_RUN_MARK}: {why} (`[not_run]` in the scene's scene.toml).", ""]
        if v.tolerance_changes:
            lines += ["Tolerances changed by the tolerance file: " + "; ".join(v.tolerance_changes), ""]
        lines += ["| run | integrator | dt (s) | rtol | status | steps | wall (s) | settings |",
                  "|---|---|---|---|---|---|---|---|"]
        for r in v.runs:
            rtol = f"{r.rtol:g}" if r.rtol else "—"
            dt = "adaptive" if r.rtol else f"{r.dt:g}"
            steps = "—" if r.steps != r.steps else f"{r.steps:.0f}"
            lines.append(f"| {r.engine} | {r.integrator} | {dt} | {rtol} | {r.status}{': ' + r.message if r.message else ''} | "
                         f"{steps} | {r.wall_s:.2f} | {_cell(r.settings)} |")
        lines.append("")
        lines += warning_lines(v)
        lines += _model_lines(v)
        lines += ["| engine | check | value | tolerance | unit | margin | result | bound | note |",
                  "|---|---|---|---|---|---|---|---|---|"]
        for c in v.checks:
            if c.check.startswith("model.") and c.passed:
                continue  # summarised above
            bound = f"regression {REGRESSION_MARK}" if c.regression_only else ""
            lines.append(f"| {c.engine} | {c.check} | {_fmt(c.value)} | {_fmt(c.tolerance)} | {c.unit} | "
                         f"{_fmt_margin(c.margin)} | {'ok' if c.passed else '**FAIL**'} | {bound} | {_cell(c.detail)} |")
        if any(c.regression_only for c in v.checks):
            lines += ["", f"{REGRESSION_MARK} regression bound: the tolerance is what the engine reached when it was set, "
                      "with a margin (see the notes in the scene's scene.toml), so the check catches a regression, "
                      "not a departure from the physics."]
        if v.cross:
            lines += ["", "Engine against engine (max over bodies and samples):", "",
                      "| pair | position (m) | orientation (rad) | velocity (m/s) | angular velocity (rad/s) |", "|---|---|---|---|---|"]
            for pair, e in v.cross.items():
                lines.append(f"| {pair} | {_fmt(e.get('position_max'))} | {_fmt(e.get('orientation_max'))} | "
                             f"{_fmt(e.get('velocity_max'))} | {_fmt(e.get('angular_velocity_max'))} |")
        lines.append("")
    return "\n".join(lines)


def payload(results: list[SceneValidation], prov: dict) -> dict:
    """``validation.json``: provenance, verdict, every scene (``as_dict``; each check with its margin)."""
    scenes = []
    for v in results:
        d = as_dict(v)
        d["checks"] = [dict(row, margin=c.margin) for row, c in zip(d["checks"], v.checks)]
        scenes.append(d)
    return {"provenance": prov, "passed": all(v.passed for v in results), "scenes": scenes}


def write_reports(results: list[SceneValidation], prov: dict, out_dir: Path) -> list[Path]:
    """Write the report set (``FILES``) into ``out_dir`` as one set; returns their paths."""
    files = {
        "validation.md": markdown(results, prov),
        "validation.csv": checks_frame(results).to_csv(index=False),
        "validation.json": json.dumps(payload(results, prov), indent=2, default=_json_default, allow_nan=True),
        "validation.junit.xml": junit_xml(results, prov),
        "validation_matrix.png": matrix_png(results),
    }
    return atomic.write_set(Path(out_dir), files)


def junit_xml(results: list[SceneValidation], prov: dict) -> str:
    """JUnit XML: a test suite per scene, a test case per engine x check (``classname`` =
    ``scene.engine``), a failure element carrying value, tolerance and detail; an engine the
    scene excludes (``[not_run]``) is one skipped case saying why."""
    suites = ET.Element("testsuites", name="harness validate")
    for v in results:
        failures = sum(not c.passed for c in v.checks)
        wall = sum(r.wall_s for r in v.runs)
        suite = ET.SubElement(suites, "testsuite", name=v.scene, tests=str(len(v.checks) + len(v.not_run)),
                              failures=str(failures), errors="0", skipped=str(len(v.not_run)), time=f"{wall:.3f}",
                              timestamp=prov["date_utc"])
        props = ET.SubElement(suite, "properties")
        for key in ("mujoco", "pinocchio", "exudyn", "drake", "numpy", "scipy", "python", "machine"):
            if key in prov:
                ET.SubElement(props, "property", name=key, value=str(prov[key]))
        for e, why in v.not_run.items():  # the scene excludes the engine ([not_run]): a skipped case, with why
            case = ET.SubElement(suite, "testcase", classname=f"{v.scene}.{e}", name="not_run")
            ET.SubElement(case, "skipped", message=why)
        for c in v.checks:
            case = ET.SubElement(suite, "testcase", classname=f"{v.scene}.{c.engine}", name=c.check)
            if not c.passed:
                failure = ET.SubElement(case, "failure", message=f"{_fmt(c.value)} > {_fmt(c.tolerance)} {c.unit}".strip(),
                                        type=_failure_type(c))
                failure.text = c.detail
    ET.indent(suites)
    return '<?xml version="1.0" encoding="utf-8"?>\n' + ET.tostring(suites, encoding="unicode") + "\n"


def _failure_type(c: CheckResult) -> str:
    if c.check == "run":
        return "run"
    return "model" if c.check.startswith("model.") else "tolerance"


def _json_default(o):
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    return str(o)
