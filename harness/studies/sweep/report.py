"""Reports of ``harness sweep``: ``<scene>_sweep.csv`` (one row per point x engine),
``<scene>_sweep.md`` (how it was made, the largest error per engine, the table) and
``<scene>_sweep.png``: for a 1-D grid, log10 of each engine's largest dimensionless error at the
scene's step (``PointResult.error``) against the parameter, a line per engine; for a 2-D grid, one
heatmap of it per engine; for a random sweep, a scatter (against the parameter with one key, else
over the first two keys, coloured by it). A point that fails a check (``validate``'s verdict) is
marked with a red edge and the letter of its worst failing class (``CLASS_LETTER``); a point whose
run did not end ok (or was refused) is drawn as a grey cross / cell with a letter (``_LETTER``).
All three files are written as one set (``harness.io.atomic.write_set``)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from harness.engines import REFERENCE_ENGINE, display
from harness.io import atomic
from harness.io.figures import new_figure, png_bytes
from harness.studies.sweep.run import CLASS_ORDER, DECLARED, DIMENSIONLESS, PointResult, SweepRun

REF = display(REFERENCE_ENGINE)  # the reference engine, as the report writes it
MAX_TABLE_ROWS = 400  # rows of the markdown table; the CSV always has them all
_LETTER = {"crashed": "X", "timeout": "T", "error": "!", "blowup": "B", "failed": "F", "unsupported": "U",
           "not run": "-", "refused": "R"}
#: The letter of a failing point's worst failing class: a defect, unresolved (L: the run lost the
#: motion), not judged, an undeclared model
#: difference, a declared one beyond its bound, and a converging check beyond the scene's requirement.
CLASS_LETTER = {"defect": "D", "unresolved": "L", "not judged": "N", "model difference": "M", DECLARED: "Md",
                "converges": "Q"}
FAIL_COLOR = "red"


def _fmt(x, digits: int = 2) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "—"
    if isinstance(x, float) and math.isinf(x):
        return "∞"
    return f"{x:.{digits}e}" if (abs(x) < 1e-2 or abs(x) >= 1e4) and x != 0 else f"{x:.{digits + 1}g}"


def _letter(r: PointResult) -> str:
    return _LETTER.get(r.status.split(":")[0], "?")


def _class_letter(r: PointResult) -> str:
    """The letter of a failing point's worst failing class (``CLASS_LETTER``), "" for a passing one."""
    return CLASS_LETTER.get(r.failing_class, "?") if r.failing else ""


def _log_error(r: PointResult) -> float:
    """log10 of the largest dimensionless error for a run that ended ok with one, else NaN (an
    error of 0 is drawn at 1e-17, below round-off)."""
    if r.status != "ok" or not math.isfinite(r.error):
        return float("nan")
    return math.log10(max(r.error, 1e-17))


def _failing_text(r: PointResult, limit: int | None = None) -> str:
    """``check [class]: reason`` of each failing check, joined by `` | ``; reasons cut to ``limit``
    characters (None: whole)."""
    out = []
    for check, cls, why in r.failing:
        if limit is not None and len(why) > limit:
            why = why[:limit - 3] + "..."
        head = f"{check} [{cls}]" if cls else check
        out.append(f"{head}: {why}" if why else head)
    return " | ".join(out)


def frame(run: SweepRun) -> pd.DataFrame:
    """One row per point x engine: the swept values (one column per key, the parameter's unit),
    engine, integrator, status, passed, classification (the worst class of the run's checks),
    error and error_check (the largest dimensionless error and its check), failed_checks, checks,
    failing (``check [class]: reason`` of each failing check, `` | ``-separated),
    trajectory_error, energy_drift, no_value (checks without a value), reference (status of the
    point's reference run), wall_s, message."""
    rows = []
    for r in run.rows:
        row = {"scene": run.scene, "point": r.point}
        row.update({a.key: v for a, v in zip(run.axes, r.values)})
        row.update(engine=r.engine, integrator=r.integrator, status=r.status, passed=r.passed,
                   classification=r.classification, error=r.error, error_check=r.error_check,
                   failed_checks=r.failed_checks, checks=r.checks, failing=_failing_text(r),
                   trajectory_error=r.trajectory_error, energy_drift=r.energy_drift,
                   no_value=";".join(r.no_value), reference=r.reference, wall_s=r.wall_s,
                   message=" ".join(r.message.split()))
        rows.append(row)
    return pd.DataFrame(rows)


def _where(run: SweepRun, r: PointResult) -> str:
    return ", ".join(f"{a.key} = {v:.4g}" + (f" {a.unit}" if a.unit else "") for a, v in zip(run.axes, r.values))


def headline(run: SweepRun) -> list[str]:
    """Per engine: the point of the largest error (among the runs that ended ok) and its check,
    how many points fall in each class, how many fail a check, and how many runs did not end ok
    or were refused."""
    out = ["| engine | integrator | largest error | at | check | classes (points) | points failing a check | "
           "runs not ok | refused |", "|---|---|---|---|---|---|---|---|---|"]
    for e in run.engines:
        rows = run.of(e)
        ran = [r for r in rows if r.status == "ok"]
        worst = max(ran, key=lambda r: r.error if not math.isnan(r.error) else -math.inf, default=None)
        failing = sum(1 for r in ran if not r.passed)
        not_ok = sum(1 for r in rows if r.status not in ("ok", "not run") and not r.refused)
        refused = sum(1 for r in rows if r.refused)
        unjudged = [r for r in ran if r.no_value]
        integ = next((r.integrator for r in rows if r.integrator), "")
        if all(r.status == "not run" for r in rows):
            out.append(f"| {e} | — | not run: {rows[0].message if rows else ''} | | | | | | |")
            continue
        counts = {c: sum(1 for r in ran if r.classification == c) for c in reversed(CLASS_ORDER)}
        classes = ", ".join(f"{c} {n}" for c, n in counts.items() if n) or "—"
        out.append(f"| {e} | {integ} | {_fmt(worst.error) if worst else '—'} | "
                   f"{_where(run, worst) if worst else '—'} | {(worst.error_check or '—') if worst else '—'} | "
                   f"{classes} | {failing}/{len(rows)}" + (f" ({len(unjudged)} with a check without a value: "
                                                            f"{', '.join(sorted({c for r in unjudged for c in r.no_value}))})"
                                                            if unjudged else "") + f" | {not_ok} | {refused} |")
    return out


def markdown(run: SweepRun, prov: dict, png: str | None, command: str | None = None) -> str:
    """The report: how it was made, the headline, the figure, how to read it, every point."""
    if command is None:
        from harness.io.provenance import command_line

        command = command_line()
    axes = ", ".join(f"`{a.spec()}`" + (f" ({a.unit})" if a.unit else "") for a in run.axes)
    if run.mode == "grid":
        shape = " x ".join(str(a.n) for a in run.axes)
        how = f"a {shape}{'-point' if len(run.axes) == 1 else ''} grid over {axes}"
    else:
        how = f"{len(run.points)} random points over {axes} (seed {run.seed})"
    where = f"on the Dask scheduler at {run.dask}" if run.dask else f"{run.jobs} at a time"
    n_runs = sum(1 for r in run.rows if r.status != "not run" and not r.refused) + \
        len({r.point for r in run.rows if r.status != "not run" and not r.refused})
    lines = [f"# Sweep: {run.scene}", "",
             f"{how}; engines {', '.join(run.engines)}; horizon {run.t_end:g} s. {len(run.points)} points, "
             f"{n_runs} runs (each point's {REF} DOP853 reference and each engine) in isolated worker processes "
             f"({where}, {run.timeout:g} s timeout each), {run.wall_s:.1f} s wall. Reproduce with `{command}`.", "",
             "| " + " | ".join(prov) + " |", "|" + "---|" * len(prov),
             "| " + " | ".join(str(v) for v in prov.values()) + " |", "",
             "## Largest error per engine", ""]
    lines += headline(run)
    lines.append("")
    if png:
        lines += [f"![log10 largest error]({png})", ""]
    lines += ["## How to read it", "",
              "Each point is a case of `harness validate` with the swept parameters set: the engine at the scene's "
              f"default integrator and step, judged by the scene's own `[checks.*]` against the point's {REF} "
              "DOP853 reference (rtol 1e-12); definitions in the docstring of `harness/studies/sweep/run.py`.", "",
              "Each check of each run is judged by how its error converges (`harness validate`'s verdict: the "
              "engine rerun at twice the step, and half where undecided, or an error-controlled one at a 100x looser "
              "tolerance; `harness/judging/`), not by a tolerance:", "",
              "* **class**: the worst class of the run's checks, worst first: `defect` (an order far below the "
              "method's, an error growing with refinement, non-finite), `not judged` (no other level ran; or a check "
              "without a value), `model difference` (a floor that does not shrink with the step, not declared by the "
              "scene), `model difference (declared)` (the scene's `[model_differences.<engine>]`, passing within its "
              "bound), `converges` (the engine agrees with the physics);",
              "* **failing checks**: each failing check with its class and the verdict's reason (a `converges` check "
              "fails only beyond a requirement of the scene);",
              "* **error**: the largest value at the scene's step among the checks whose unit is dimensionless ("
              + ", ".join(f"`{u}`" if u else "none" for u in DIMENSIONLESS) + ": trajectory errors over the "
              "reference's motion scales and in rad, drifts over their scales, the closed form's error; not the "
              "checks in m, m/s, rad/s), and the **check** that sets it; the figure plots its log10. It is an "
              "error size, not a verdict: a check passes or fails by its class;",
              "* **trajectory error**: the largest `trajectory.*` value against the reference (position and velocity "
              "relative to the reference's motion scales, orientation in rad);",
              "* **energy drift**: `energy_drift` (max |E - E0| over the energy scale) or, forced, `energy_balance`;",
              "* **status**: `ok` (the run ended ok), the run's own (`blowup`, `failed`, `unsupported`), the worker's "
              "(`crashed`, `timeout`, `error`), `refused: <reason>` (the scene's builder refuses the point), "
              "`not run` (the scene's `[not_run]`).", "",
              "In the figure a point that fails a check has a red edge (a red x on a line) and the letter of its worst "
              "failing class: " + ", ".join(f"{v} {k}" for k, v in CLASS_LETTER.items() if k != "converges")
              + ", Q a converging check beyond the scene's requirement. A run that is not ok is a grey cross or "
              "cell with a letter: " + ", ".join(f"{v} {k}" for k, v in _LETTER.items()) + ". A check of a run "
              "that ended ok but got no value (e.g. a closed form that does not cover the point) fails the point as "
              "`not judged` and is named under `no value` in the table (why: the CSV's message).", ""]
    ref_bad = sorted({r.point for r in run.rows if r.reference not in ("", "ok") and not r.refused})
    if ref_bad:
        lines += [f"The reference run did not end ok at {len(ref_bad)} point(s) ({', '.join(str(i) for i in ref_bad[:20])}"
                  f"{' ...' if len(ref_bad) > 20 else ''}): their `trajectory.*` checks are missing or failed.", ""]
    lines += ["## Points", ""]
    keys = [a.key for a in run.axes]
    lines += ["| # | " + " | ".join(keys) + " | engine | status | class | error | check | failing checks | "
              "trajectory error | energy drift | wall (s) |", "|---" * (len(keys) + 10) + "|"]
    for r in run.rows[:MAX_TABLE_ROWS]:
        status = r.status if len(r.status) <= 60 else r.status[:57] + "..."
        failing = _failing_text(r, limit=120).replace("|", "\\|") or "—"
        lines.append(f"| {r.point} | " + " | ".join(f"{v:.4g}" for v in r.values)
                     + f" | {r.engine} | {status} | {r.classification or '—'} | {_fmt(r.error)} | "
                       f"{r.error_check or '—'}" + (f"; no value: {', '.join(r.no_value)}" if r.no_value else "")
                     + f" | {failing} | {_fmt(r.trajectory_error)} | {_fmt(r.energy_drift)} | {r.wall_s:.2f} |")
    if len(run.rows) > MAX_TABLE_ROWS:
        lines += ["", f"({len(run.rows) - MAX_TABLE_ROWS} more rows in `{run.scene}_sweep.csv`.)"]
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------------------------ figure
def _axis_label(a) -> str:
    return f"{a.key} ({a.unit})" if a.unit else a.key


def figure_png(run: SweepRun) -> bytes | None:
    """The figure of the sweep (see the module docstring); None when no engine ran."""
    engines = [e for e in run.engines if any(r.status != "not run" for r in run.of(e))]
    if not engines or not run.points:
        return None
    if run.mode == "grid" and len(run.axes) == 2:
        return _heatmaps(run, engines)
    if len(run.axes) == 1:
        return _lines(run, engines)
    return _scatters(run, engines)


ERROR_LABEL = "log10 largest error (rel / rad)"


def _lines(run: SweepRun, engines: list[str]) -> bytes:
    a = run.axes[0]
    fig = new_figure(7.0, 4.2)
    ax = fig.add_subplot(1, 1, 1)
    failed_any = False
    for k, e in enumerate(engines):
        rows = sorted(run.of(e), key=lambda r: r.values[0])
        x = np.array([r.values[0] for r in rows])
        y = np.array([_log_error(r) for r in rows])
        style = "o-" if run.mode == "grid" else "o"
        line, = ax.plot(x, y, style, ms=4, lw=1.2, label=e)
        bad = [r for r in rows if r.status != "ok"]
        for r in bad:  # at the top of the axes, in the engine's colour
            ax.plot([r.values[0]], [1.0 - 0.04 * (k + 1)], "x", color=line.get_color(), ms=7,
                    transform=ax.get_xaxis_transform())
            ax.annotate(_letter(r), (r.values[0], 1.0 - 0.04 * (k + 1)), xycoords=("data", "axes fraction"),
                        xytext=(4, -3), textcoords="offset points", fontsize=7, color=line.get_color())
        for r in rows:  # a failing point: a red x over it and its worst failing class
            if r.status == "ok" and r.failing and math.isfinite(_log_error(r)):
                failed_any = True
                ax.plot([r.values[0]], [_log_error(r)], "x", color=FAIL_COLOR, ms=9, mew=1.6)
                ax.annotate(_class_letter(r), (r.values[0], _log_error(r)), xytext=(4, 3), textcoords="offset points",
                            fontsize=8, color=FAIL_COLOR, weight="bold")
    if failed_any:
        ax.plot([], [], "x", color=FAIL_COLOR, ms=9, mew=1.6, label="fails a check (letter: its class)")
    if a.log:
        ax.set_xscale("log")
    ax.set_xlabel(_axis_label(a))
    ax.set_ylabel(ERROR_LABEL)
    ax.set_title(f"{run.scene}: largest dimensionless error at the scene's step, per engine", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return png_bytes(fig, 110)


def _norm(values: np.ndarray):
    from matplotlib.colors import Normalize

    finite = values[np.isfinite(values)]
    lo, hi = (float(finite.min()), float(finite.max())) if finite.size else (-1.0, 1.0)
    if lo == hi:
        lo, hi = lo - 0.5, hi + 0.5
    return Normalize(lo, hi), "viridis"


def _heatmaps(run: SweepRun, engines: list[str]) -> bytes:
    from matplotlib.patches import Rectangle

    ax0, ax1 = run.axes
    g0, g1 = ax0.grid(), ax1.grid()
    grids = {}
    for e in engines:
        z = np.full((len(g0), len(g1)), np.nan)
        for r in run.of(e):
            z.flat[r.point] = _log_error(r)
        grids[e] = z
    norm, cmap = _norm(np.concatenate([z.ravel() for z in grids.values()]))
    cols = min(3, len(engines))
    nrows = math.ceil(len(engines) / cols)
    fig = new_figure(4.2 * cols + 0.8, 3.6 * nrows)
    annotate = len(g0) * len(g1) <= 144
    image = None
    for k, e in enumerate(engines):
        ax = fig.add_subplot(nrows, cols, k + 1)
        ax.set_facecolor("0.8")
        image = ax.imshow(grids[e].T, origin="lower", aspect="auto", cmap=cmap, norm=norm)
        for r in run.of(e):
            i, j = np.unravel_index(r.point, (len(g0), len(g1)))
            if r.status != "ok":
                ax.text(i, j, _letter(r), ha="center", va="center", fontsize=8, color="0.2", weight="bold")
                continue
            if r.failing:  # a red edge and the worst failing class
                ax.add_patch(Rectangle((i - 0.5, j - 0.5), 1, 1, fill=False, edgecolor=FAIL_COLOR, lw=2.0))
            text = f"{r.error:.0e}" if annotate and math.isfinite(r.error) else ""
            mark = _class_letter(r) + ("?" if r.no_value else "")
            if text or mark:
                ax.text(i, j, f"{text}\n{mark}" if text and mark else text or mark, ha="center", va="center",
                        fontsize=6 if text else 8, color=FAIL_COLOR if r.failing else "k",
                        weight="bold" if mark else None, bbox={"boxstyle": "round,pad=0.1", "fc": "w", "alpha": 0.6,
                                                               "lw": 0})
        step0, step1 = max(1, len(g0) // 8), max(1, len(g1) // 8)
        ax.set_xticks(range(0, len(g0), step0), [f"{v:.3g}" for v in g0[::step0]], fontsize=7)
        ax.set_yticks(range(0, len(g1), step1), [f"{v:.3g}" for v in g1[::step1]], fontsize=7)
        ax.set_xlabel(_axis_label(ax0), fontsize=8)
        ax.set_ylabel(_axis_label(ax1), fontsize=8)
        integ = next((r.integrator for r in run.of(e) if r.integrator), "")
        ax.set_title(f"{e} {integ}", fontsize=9)
    if image is not None:
        fig.colorbar(image, ax=fig.axes, label=ERROR_LABEL, shrink=0.9)
    fig.suptitle(f"{run.scene}: log10 largest error; red edge: fails a check (letter: its class)", fontsize=10)
    return png_bytes(fig, 110)


def _scatters(run: SweepRun, engines: list[str]) -> bytes:
    ax0, ax1 = run.axes[0], run.axes[1]
    values = np.array([_log_error(r) for r in run.rows if r.engine in engines])
    norm, cmap = _norm(values)
    cols = min(3, len(engines))
    nrows = math.ceil(len(engines) / cols)
    fig = new_figure(4.2 * cols + 0.8, 3.6 * nrows)
    sc = None
    for k, e in enumerate(engines):
        ax = fig.add_subplot(nrows, cols, k + 1)
        rows = run.of(e)
        ok = [r for r in rows if math.isfinite(_log_error(r))]
        bad = [r for r in rows if r.status != "ok"]
        sc = ax.scatter([r.values[0] for r in ok], [r.values[1] for r in ok], c=[_log_error(r) for r in ok],
                        cmap=cmap, norm=norm, s=26, edgecolors=[FAIL_COLOR if r.failing else "k" for r in ok],
                        linewidths=[1.6 if r.failing else 0.3 for r in ok])
        for r in ok:
            if r.failing:
                ax.annotate(_class_letter(r), (r.values[0], r.values[1]), xytext=(4, 3), textcoords="offset points",
                            fontsize=7, color=FAIL_COLOR, weight="bold")
        if bad:
            ax.scatter([r.values[0] for r in bad], [r.values[1] for r in bad], marker="x", color="0.3", s=30)
        if ax0.log:
            ax.set_xscale("log")
        if ax1.log:
            ax.set_yscale("log")
        ax.set_xlabel(_axis_label(ax0), fontsize=8)
        ax.set_ylabel(_axis_label(ax1), fontsize=8)
        ax.set_title(e, fontsize=9)
    if sc is not None:
        fig.colorbar(sc, ax=fig.axes, label=ERROR_LABEL, shrink=0.9)
    extra = f" (first two of {len(run.axes)} keys)" if len(run.axes) > 2 else ""
    fig.suptitle(f"{run.scene}: log10 largest error{extra}; red edge: fails a check (letter: its class); "
                 "x: run not ok", fontsize=10)
    return png_bytes(fig, 110)


# ------------------------------------------------------------------------------------ files
def file_names(scene: str) -> tuple[str, str, str]:
    return f"{scene}_sweep.md", f"{scene}_sweep.csv", f"{scene}_sweep.png"


def write_sweep_reports(run: SweepRun, prov: dict, out_dir: Path, command: str | None = None) -> list[Path]:
    """Write ``<scene>_sweep.md``, ``.csv`` and ``.png`` into ``out_dir`` as one set; returns
    their paths. InputError if ``out_dir`` cannot be written (old files are then kept)."""
    out_dir = Path(out_dir)
    atomic.check_writable(out_dir)
    md, csv, png = file_names(run.scene)
    image = figure_png(run)
    files: dict[str, bytes | str] = {md: markdown(run, prov, png if image else None, command),
                                     csv: frame(run).to_csv(index=False)}
    if image:
        files[png] = image
    return atomic.write_set(out_dir, files)
