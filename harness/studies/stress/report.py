"""Reports of ``harness stress``: ``stress.md`` (the stability map), ``stress.csv`` (every run),
``stress_map.csv`` (one row per variant x engine/integrator) and plots under ``stress/``.

All files are written as one set (``harness.io.atomic.write_set``: a reader sees all old or all
new files; nothing is written if the folder is not writable). Plots use matplotlib's Agg canvas.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Callable

import numpy as np
import pandas as pd

from harness.engines import REFERENCE_ENGINE, display
from harness.io import atomic
from harness.io.figures import new_figure, png_bytes
from harness.studies.stress.run import (DIVERGED, FAILURE_MODES, QUANTITIES, MapRow, StressRun, TrialResult, Variant,
                                        judging_class)
from harness.validate.workers import effective_jobs, run_cases

REF = display(REFERENCE_ENGINE)  # the reference engine, as the report writes it
PLOT_DIR = "stress"
DIVERGENCE_COLUMNS = ("exact", "position", "orientation", "velocity", "energy")


# ------------------------------------------------------------------------------------ tables
def _fmt(x, digits: int = 2) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "—"
    return f"{x:.{digits}e}" if (abs(x) < 1e-2 or abs(x) >= 1e4) and x != 0 else f"{x:.{digits + 1}g}"


def _time(x) -> str:
    return "—" if x is None else f"{x:.4g}"


def trials_frame(run: StressRun) -> pd.DataFrame:
    """Every run (references included) as one row; skipped variants as rows with status
    ``skipped``. Times in s; errors dimensionless (see ``harness.studies.stress.run``)."""
    rows = []
    by_name = {v.name: v for v in run.variants}
    for r in run.trials:
        v = by_name[r.spec.variant]
        row = {
            "variant": v.name, "scene": v.scene, "group": v.group, "engine": r.spec.engine,
            "integrator": r.spec.integrator, "role": r.spec.role, "dt": r.spec.dt, "t_end": r.spec.t_end,
            "save_every": r.spec.save_every, "rtol": r.spec.rtol if r.spec.role in ("adaptive", "reference") else np.nan,
            "status": r.status, "stable": r.stable, "mode": r.mode, "accurate": r.accurate, "error": r.error,
            "error_kind": r.error_kind, "energy_error": r.energy_error, "constraint": r.constraint,
            "t_reached": r.t_reached, "t_fail": r.t_fail, "drift_class": r.drift_class, "drift_p": r.drift_p,
        }
        for q in QUANTITIES:
            row[f"max_{q}"] = r.max_errors.get(q, np.nan)
        for q in QUANTITIES:
            row[f"diverge_{q}"] = r.divergence.get(q, np.nan) if q in r.divergence else np.nan
        row.update({"steps": r.steps, "rhs_evals": r.rhs_evals, "wall_s": r.wall_s, "message": r.message})
        rows.append(row)
    for name, reason in run.skipped.items():
        v = by_name[name]
        rows.append({"variant": name, "scene": v.scene, "group": v.group, "status": "skipped", "message": reason})
    return pd.DataFrame(rows)


def map_frame(run: StressRun) -> pd.DataFrame:
    """One row per variant x engine/integrator: the stability map in numbers."""
    rows = []
    for m in run.rows:
        n = m.nominal
        row = {
            "variant": m.variant, "engine": m.engine, "integrator": m.integrator, "t_end": m.t_end, "kind": m.kind,
            "stable_dt": m.stable_dt, "censored": m.censored, "h_rate": _h_rate(run, m),
            "unstable_dt": m.unstable_dt, "mode": m.mode, "error_at_stable": m.error, "error_kind": m.error_kind,
            "accurate_at_stable": m.accurate, "mean_step": m.step if m.kind == "adaptive" else np.nan,
            "nominal_dt": n.spec.dt if n else np.nan, "nominal_mode": n.mode if n else "",
            "nominal_error": n.error if n else np.nan, "nominal_class": judging_class(n),
            "nominal_drift": n.drift_class if n else "",
            "nominal_drift_p": n.drift_p if n else np.nan, "not_run": m.unsupported,
        }
        for q in QUANTITIES:
            row[f"nominal_diverge_{q}"] = (n.divergence.get(q) if n and q in n.divergence else np.nan)
        row["trials"] = len(m.trials)
        row["notes"] = "; ".join(m.notes)
        rows.append(row)
    return pd.DataFrame(rows)


def _h_rate(run: StressRun, m: MapRow) -> float:
    rate = run.rates.get(m.variant, float("nan"))
    step = m.stable_dt if m.kind == "fixed" else m.step
    return float(step * rate) if step is not None and math.isfinite(step) else float("nan")


def map_cell(m: MapRow) -> str:
    """Compact cell of the map: largest stable step and the failure mode just above it; ``not
    run`` when the engine/integrator does not model the variant's scene (``MapRow.unsupported``)."""
    if m.unsupported:
        return NOT_RUN
    code = FAILURE_MODES.get(m.mode, "")
    if m.kind == "adaptive":
        n = m.nominal
        if n is None or not n.stable:
            return f"fails {code}".strip()
        return f"~{_fmt(m.step)} ✓" if n.accurate else f"~{_fmt(m.step)} ✗acc"
    if m.stable_dt is None:
        return f"<{_fmt(m.unstable_dt)} {code}".strip() if m.unstable_dt else f"— {code}".strip()
    if m.censored:
        return f"≥{_fmt(m.stable_dt)}"
    return f"{_fmt(m.stable_dt)} {code}".strip()


def _labels(run: StressRun) -> list[str]:
    """Engine/integrator labels in registry order (engines, then each engine's integrators)."""
    from harness.engines import ENGINE_NAMES, get_engine

    def key(m: MapRow):
        known = list(get_engine(m.engine).integrators)
        return (ENGINE_NAMES.index(m.engine), known.index(m.integrator) if m.integrator in known else len(known))

    out: list[str] = []
    for m in sorted(run.rows, key=key):
        if m.label not in out:
            out.append(m.label)
    return out


def _linestyle(label: str) -> str:
    """The line style of an "<engine>/<integrator>" label: its engine's (``Declaration.linestyle``)."""
    from harness.engines import ENGINES

    engine = label.split("/")[0]
    return ENGINES[engine].linestyle if engine in ENGINES else "-"


def _adaptive_methods(run: StressRun) -> str:
    """`` (in-house: RK45 and DOP853; Drake: RK3, RK5 and Radau3)``: the error-controlled
    methods of ``run``'s map by engine, as the report's definitions name them ("" for none)."""
    from harness.engines import get_engine

    by_engine: dict[str, list[str]] = {}
    for label in _labels(run):
        engine, _, method = label.partition("/")
        table = get_engine(engine).integrators
        if method in table and table[method].adaptive and method not in by_engine.setdefault(engine, []):
            by_engine[engine].append(method)
    parts = [f"{display(e)}: {_and(ms)}" for e, ms in by_engine.items() if ms]
    return f" ({'; '.join(parts)})" if parts else ""


def _and(items: list[str]) -> str:
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def _row_of(run: StressRun, variant: str, label: str) -> MapRow | None:
    for m in run.rows:
        if m.variant == variant and m.label == label:
            return m
    return None


def _rows_of(run: StressRun, variant: str) -> list[MapRow]:
    return [m for m in run.rows if m.variant == variant]


def _exact_measures(run: StressRun) -> str:
    """What ``exact`` measures for each scene of the run's variants that checks it: the scene's
    ``exact_error_series`` (``references/<scene>.py``), described by its docstring."""
    from harness.measure import exact

    scenes = list(dict.fromkeys(v.scene for v in run.variants if "exact" in v.references))
    text = "the closed form's error per sample, `exact_error_series` of `references/<scene>.py`"
    described = [f"{s}: {exact.series_description(s) or 'see references/' + s + '.py'}" for s in scenes]
    return text + (": " + "; ".join(described) if described else "")


def markdown(run: StressRun, prov: dict, plots: dict[str, str], command: str | None = None) -> str:
    """The report: how to read it, the map, the closing note, one section per variant.
    ``command``: the "Reproduce with" command (default ``harness.io.provenance.command_line()``,
    the command this process was started with)."""
    if command is None:
        from harness.io.provenance import command_line

        command = command_line()
    lines = ["# Stress: a stability map of every engine", ""]
    cat = run.catalogue
    n_runs = len(run.trials)
    lines += [
        f"Made from `{_rel(cat.path)}`{' (a `--quick` smoke run)' if run.quick else ''}: "
        f"{len(run.variants)} variants ({len(run.skipped)} skipped), {n_runs} runs in isolated worker processes "
        f"({run.jobs} at a time, {run.timeout:g} s timeout each), {run.wall_s:.0f} s wall. "
        f"Reproduce with `{command}`.",
        "",
        "| " + " | ".join(prov) + " |",
        "|" + "---|" * len(prov),
        "| " + " | ".join(str(v) for v in prov.values()) + " |",
        "",
        "## How to read it",
        "",
        "Definitions are in the docstring of `harness/studies/stress/run.py`; in short:",
        "",
        "* **Stable**: the run reaches its horizon with a finite state, no engine's bad-acceleration/state guard "
        "tripped (`badqacc`), "
        f"|E(t) - E(0)| <= {cat.bounds.energy_bound:g} x E_scale (E_scale = T(0) + M |g| l), speeds within "
        f"{cat.bounds.magnitude_bound:g} x the energy-scale speeds, and joint violation within "
        f"{cat.bounds.constraint_bound:g} x l (l: length scale). Stable does not mean accurate: a dissipative "
        "method can be stable and wrong.",
        "* **Failure modes** (code in the map; the one that shows first in time): "
        + ", ".join(f"`{c}` {m}" for m, c in FAILURE_MODES.items()) + ".",
        "* **Largest stable step**: bisection on log(dt) below the variant's `dt_max` "
        f"(at most {cat.bounds.search_steps} divisions by {cat.bounds.search_factor:g}, then "
        f"{cat.bounds.quick_bisect_iters if run.quick else cat.bounds.bisect_iters} bisections, stop at a ratio "
        f"<= {1 + cat.bounds.precision:g}); each trial in its own worker. `≥x`: stable at the largest step tried; "
        "`<x`: no stable step found down to x (step budget or search limit); `x E`: stable at x, failure mode E "
        f"at the next larger step tried. Error-controlled methods{_adaptive_methods(run)} run once (rtol in the "
        "catalogue, largest step the save interval): `~h` is their "
        f"mean step, `✓` accurate, `✗acc` stable but outside the band. The {REF} `rk4` and `DOP853` rows and "
        "the DOP853 references run their compiled twins (`rk4_compiled`: rk4's trajectory to round-off; "
        "`dop853_compiled`: the same method with its own step-size control).",
        f"* **Error**: `exact` ({_exact_measures(run)}), else the "
        f"largest relative trajectory error against the {REF} DOP853 reference (rtol 1e-12), else the energy "
        "error. **First divergence**: the first saved time a quantity leaves its band, at the nominal step. "
        "A nominal run that diverged (" + ", ".join(f"`{m}`" for m in DIVERGED) + ") is marked **defect (diverged: "
        "mode)**, the judging vocabulary of `harness validate` (`harness.judging.error_model`: non-finite at the "
        "scene's step is a defect); every other outcome keeps this study's own terms (a stable run has one step, "
        "no error model: its bands judge it; a blow-up above the largest stable step is the stability limit, not "
        "a defect).",
        "* **Energy drift** at the nominal step: slope p of log max_{s<=t}|E(s) - E(0)| against log t over the "
        "last two decades: `bounded` p < 0.3, `linear` 0.3 <= p <= 1.5 (p ~ 0.5 is a round-off random walk), "
        "`faster` p > 1.5 (`exponential` when log E-error is straighter in t than in log t).",
        "",
    ]
    lines += ["## Stability map", ""]
    if "map" in plots:
        lines += [f"![stability map]({plots['map']})", ""]
        lines += ["Map colours: viridis = log10(largest stable step x rate) (adaptive: of the mean step); "
                  + "; ".join(f"{MAP_COLOUR_NAMES[k]} = **{k}**: " + MAP_LEGEND[k].split(": ", 1)[1]
                              for k in MAP_COLOURS) + ".", ""]
    labels = _labels(run)
    if labels:
        lines += ["Largest stable step (s) and the failure mode above it, per engine/integrator:", ""]
        lines += ["| variant | " + " | ".join(labels) + " |", "|---|" + "---|" * len(labels)]
        for v in run.variants:
            if v.name in run.skipped:
                continue
            cells = []
            for label in labels:
                m = _row_of(run, v.name, label)
                cells.append(map_cell(m) if m else NOT_RUN)
            lines.append(f"| {v.name} | " + " | ".join(cells) + " |")
        lines.append("")
    not_run = [m for m in run.rows if m.unsupported and m.variant not in run.skipped]
    if not_run:
        lines += ["Not run (the engine/integrator does not model the variant's scene; no step was searched):", ""]
        lines += [f"* `{m.variant}` {m.label}: {m.unsupported}" for m in not_run]
        lines.append("")
    if run.skipped:
        lines += ["Skipped (listed in the catalogue, cannot run with the scenes at hand):", ""]
        lines += [f"* `{name}`: {reason}" for name, reason in run.skipped.items()]
        lines.append("")
    sweeps = [k for k in plots if k.startswith("sweep:")]
    if sweeps:
        lines += ["Largest stable step across each swept group:", ""]
        lines += [f"![{k[6:]}]({plots[k]})" for k in sweeps]
        lines.append("")
    lines += closing_note(run)
    lines += ["## Variants", ""]
    for v in run.variants:
        lines += _variant_section(run, v, plots)
    return "\n".join(lines) + "\n"


def _rel(path: Path) -> str:
    try:
        return str(Path(path).resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(path)


def _tagged(run: StressRun, tag: str) -> list[Variant]:
    return [v for v in run.variants if tag in v.tags]


def _extreme(run: StressRun, tag: str) -> list[Variant]:
    """The variants of ``tag`` with the largest sweep value in each group (all if no sweep)."""
    groups: dict[str, list[Variant]] = {}
    for v in _tagged(run, tag):
        groups.setdefault(v.group, []).append(v)
    out = []
    for vs in groups.values():
        swept = [v for v in vs if v.sweep is not None]
        out += [max(swept, key=lambda v: v.sweep)] if swept else vs
    return out


def _step_phrase(run: StressRun, m: MapRow) -> str:
    if m.unsupported:
        return f"not run: {m.unsupported}"
    if m.kind == "adaptive":
        n = m.nominal
        if n is None or not n.stable:
            return f"fails ({n.mode if n else 'no run'})"
        return f"adaptive, mean step {_fmt(m.step)} s, error {_fmt(n.error)}"
    rate = run.rates.get(m.variant, float("nan"))
    if m.stable_dt is None:
        return f"no stable step down to {_fmt(m.unstable_dt)} s ({m.mode})"
    s = f"{'≥ ' if m.censored else ''}{_fmt(m.stable_dt)} s (h·rate {_fmt(m.stable_dt * rate)})"
    s += f", error there {_fmt(m.error)}"
    s += ", stable at the largest step tried" if m.censored else f"; above it: {m.mode} at {_fmt(m.unstable_dt)} s"
    return s


def closing_note(run: StressRun) -> list[str]:
    """The closing note of the issue, as measured: fastest spin, stiffest spring, long horizons,
    Dzhanibekov divergence times."""
    out = ["## Closing note (as measured in this run)", ""]

    def block(title: str, variants: list[Variant], extra=None) -> None:
        if not variants:
            out.extend([f"**{title}**: no such variant in this run.", ""])
            return
        for v in variants:
            out.append(f"**{title}: `{v.name}`** — {v.doc}")
            out.append("")
            if v.name in run.skipped:
                out.extend([f"* not run: {run.skipped[v.name]}", ""])
                continue
            for m in _rows_of(run, v.name):
                line = f"* {m.label} (horizon {m.t_end:g} s): {_step_phrase(run, m)}"
                if extra:
                    line += extra(m)
                out.append(line)
            out.append("")

    def drift(m: MapRow) -> str:
        n = m.nominal
        if n is None or m.unsupported:
            return ""
        where = "of its run" if m.kind == "adaptive" else f"at the nominal step {_fmt(n.spec.dt)} s"
        if not n.stable:
            return f"; {where}: {n.mode}"
        return f"; energy drift {where}: **{n.drift_class}** (p = {n.drift_p:.2f}, max {_fmt(n.energy_error)})"

    block("Fastest spin", _extreme(run, "fast_spin"))
    block("Stiffest spring", _extreme(run, "stiff"))
    block("Long horizon", _tagged(run, "long"), drift)
    for v in _tagged(run, "flip"):
        out.append(f"**Dzhanibekov flip: `{v.name}`** — {v.doc} Time (s) at which each run, at its nominal step, "
                   f"first leaves the band (exact: {v.band['exact']:g}, see **Error** above; orientation: {v.band['orientation']:g} rad "
                   "from the DOP853 reference):")
        out.append("")
        if v.name in run.skipped:
            out.extend([f"* not run: {run.skipped[v.name]}", ""])
            continue
        ref = run.references.get(v.name)
        if ref is not None:
            out.append(f"* reference ({REF} DOP853, rtol 1e-12) vs exact: {_time(ref.divergence.get('exact'))} "
                       f"(max error {_fmt(ref.max_errors.get('exact'))})")
        for m in _rows_of(run, v.name):
            n = m.nominal
            if n is None:
                continue
            if m.unsupported:
                out.append(f"* {m.label}: not run: {m.unsupported}")
                continue
            d = n.divergence
            step = f"adaptive, rtol {n.spec.rtol:g}" if n.spec.role == "adaptive" else f"{_fmt(n.spec.dt)} s"
            out.append(f"* {m.label} ({step}): exact {_time(d.get('exact'))}, orientation "
                       f"{_time(d.get('orientation'))}, energy {_time(d.get('energy'))}"
                       + (f" ({n.mode})" if n.mode else ""))
        out.append("")
        out.append("(— : stays within the band over the whole horizon.)")
        out.append("")
    return out


def _variant_section(run: StressRun, v: Variant, plots: dict[str, str]) -> list[str]:
    out = [f"### {v.name}", "", v.doc, ""]
    sets = ", ".join(f"{k} = {val}" for k, val in v.params.items()) or "none"
    scale = ", ".join(f"{b} x {f:g}" for b, f in v.scale.items())
    horizon = f"{v.t_end:g} s" + "".join(f", {e} {t:g} s" for e, t in v.t_end_by_engine.items())
    out.append(f"Scene `{v.scene}`; overrides: {sets}" + (f"; mass/inertia scaled: {scale}" if scale else "")
               + f"; horizon {horizon}; saved every {v.save_every:g} s; nominal step {v.dt:g} s; largest step tried "
               f"{v.dt_max:g} s; references: {', '.join(v.references) or 'energy only'}; "
               f"rate for h·rate: {_fmt(run.rates.get(v.name))} rad/s.")
    out.append("")
    if v.name in run.skipped:
        out += [f"**Skipped**: {run.skipped[v.name]}", ""]
        return out
    band = ", ".join(f"{q} {v.band[q]:g}" for q in QUANTITIES)
    out += [f"Bands: {band}.", ""]
    cols = [q for q in DIVERGENCE_COLUMNS if _has(run, v, q)]
    drift = "long" in v.tags  # the drift class needs many periods: shown for the long horizons only
    out.append("| engine/integrator | largest stable step (s) | h·rate | above it | error there | nominal step (s) | "
               "error at nominal | first divergence at nominal (s): " + ", ".join(cols)
               + (" | energy drift at nominal" if drift else "") + " | notes |")
    out.append("|---" * (10 if drift else 9) + "|")
    ref = run.references.get(v.name)
    if ref is not None:
        out.append(_section_row("reference DOP853 1e-12", "—", "—", "—", "—", ref, cols, "", drift))
    for m in _rows_of(run, v.name):
        if m.unsupported:  # the reason is in the notes
            out.append(_section_row(m.label, NOT_RUN, "—", "—", "—", None, cols, "; ".join(m.notes), drift))
            continue
        if m.kind == "adaptive":
            step = f"adaptive, mean {_fmt(m.step)}"
            hr, above, err = _fmt(_h_rate(run, m)), "—", "—"
        else:
            step = ("≥ " if m.censored else "") + _fmt(m.stable_dt) if m.stable_dt is not None else f"< {_fmt(m.unstable_dt)}"
            hr = _fmt(_h_rate(run, m))
            above = f"{m.mode} at {_fmt(m.unstable_dt)}" if m.unstable_dt is not None else "—"
            err = f"{_fmt(m.error)} ({m.error_kind})" if m.stable_dt is not None else "—"
        out.append(_section_row(m.label, step, hr, above, err, m.nominal, cols, "; ".join(m.notes), drift))
    out.append("")
    if v.name in plots:
        out += [f"![{v.name}]({plots[v.name]})", ""]
    return out


def _has(run: StressRun, v: Variant, q: str) -> bool:
    if q == "energy":
        return True
    if q == "exact":
        return "exact" in v.references
    return "dop853" in v.references


def _section_row(label: str, step: str, hr: str, above: str, err: str, n: TrialResult | None, cols, notes: str,
                 with_drift: bool) -> str:
    if n is None:
        nominal = ["—", "—", "—", "—"]
    else:
        dt = "adaptive" if n.spec.role in ("adaptive", "reference") else _fmt(n.spec.dt)
        cls = judging_class(n) if n.spec.role != "reference" else ""
        e = f"{_fmt(n.error)}" + (f" (**{cls}**)" if cls else f" ({n.mode})" if n.mode else "")
        div = ", ".join(_time(n.divergence.get(q)) for q in cols)
        drift = f"{n.drift_class} (p {n.drift_p:.2f})" if n.drift_class else "—"
        nominal = [dt, e, div, drift]
    if not with_drift:
        nominal = nominal[:3]
    return "| " + " | ".join([label, step, hr, above, err] + nominal + [notes or ""]) + " |"


# ------------------------------------------------------------------------------------ plots
def _figure(w: float, h: float):
    return new_figure(w, h, tight_layout=True)


def _png(fig) -> bytes:
    """PNG at ``PLOT_DPI``, taking in a legend outside the axes."""
    return png_bytes(fig, dpi=PLOT_DPI, bbox_inches="tight", pad_inches=0.15)


NONE_STABLE, NOT_RUN = "none stable", "not run"
MAP_COLOURS = {NONE_STABLE: "#f4a582", NOT_RUN: "#d9d9d9"}  # salmon, light grey (stable cells: viridis)
MAP_COLOUR_NAMES = {NONE_STABLE: "salmon", NOT_RUN: "light grey"}
MAP_LEGEND = {
    NONE_STABLE: "no stable step found: every step tried failed (adaptive: its run failed)",
    NOT_RUN: "not run: the engine/integrator is not listed for the variant or does not model its scene, or the "
             "variant was skipped",
}


def cell_state(m: MapRow | None) -> str:
    """What a map cell means: ``"not run"`` (no row: the engine/integrator is not listed for the
    variant, or the variant was skipped; or a row whose runs came back "unsupported": the
    engine/integrator does not model the scene), ``"none stable"`` (searched, no stable step;
    adaptive: its one run failed), else ``"stable"``."""
    if m is None or m.unsupported:
        return NOT_RUN
    if m.kind == "adaptive":
        return "stable" if m.nominal is not None and m.nominal.stable else NONE_STABLE
    return "stable" if m.stable_dt is not None else NONE_STABLE


def map_cells(run: StressRun) -> tuple[list[str], list[str], list[list[str]], np.ndarray]:
    """The map's variants (skipped ones included), labels, cell states (``cell_state``) and
    colour values log10(h·rate) (NaN where no stable step or no rate)."""
    variants = [v.name for v in run.variants]
    labels = _labels(run)
    states = [[NOT_RUN for _ in labels] for _ in variants]
    z = np.full((len(variants), len(labels)), np.nan)
    for i, name in enumerate(variants):
        for j, label in enumerate(labels):
            m = None if name in run.skipped else _row_of(run, name, label)
            states[i][j] = cell_state(m)
            if states[i][j] == "stable":
                hr = _h_rate(run, m)
                z[i, j] = math.log10(hr) if math.isfinite(hr) and hr > 0 else np.nan
    return variants, labels, states, z


#: The smallest font of the plots a person reads (pt; at the saved ``PLOT_DPI`` 8 pt is 10 px).
MIN_FONT = 8.0
PLOT_DPI = 90
_CHAR_IN = 0.62 * MIN_FONT / 72  # the width of an average character at MIN_FONT (in), generous


def _text_width(texts, font: float = MIN_FONT) -> float:
    """The width (in) of the longest of ``texts`` at ``font`` pt (an estimate that errs wide)."""
    return max((len(str(t)) for t in texts), default=0) * _CHAR_IN * font / MIN_FONT


def map_figure(run: StressRun):
    """The stability map as a ``Figure`` sized to its content (``map_png``): one cell per
    variant x engine/integrator, the longer of the two lists down the rows (a row costs less room
    than a column), each column as wide as its widest text, fonts of at least ``MIN_FONT``, the
    legend below the axes and their tick labels, the colour bar right of them."""
    import textwrap

    import matplotlib
    from matplotlib.colors import to_rgba
    from matplotlib.patches import Patch

    variants, labels, states, z = map_cells(run)
    if not variants or not labels:
        return None
    text = [["" for _ in labels] for _ in variants]
    for i, name in enumerate(variants):
        for j, label in enumerate(labels):
            m = None if name in run.skipped else _row_of(run, name, label)
            if m is not None:
                text[i][j] = map_cell(m).replace("✓", "ok").replace("✗acc", "inacc").replace("≥", ">=")
            else:
                text[i][j] = "skipped" if name in run.skipped else "not run"
    transpose = len(labels) > len(variants)
    rows, cols = (labels, variants) if transpose else (variants, labels)
    if transpose:
        z = z.T
        states = [list(r) for r in zip(*states)]
        text = [list(r) for r in zip(*text)]
    font = MIN_FONT
    col_w = max(0.8, _text_width([t for r in text for t in r], font) + 0.3)
    row_h = 2.4 * font / 72
    ax_w, ax_h = col_w * len(cols), row_h * len(rows)
    rotate = _text_width(cols, font) > col_w - 0.1  # column names that do not fit across their column
    left = _text_width(rows, font) + 0.25
    bottom = (0.72 * _text_width(cols, font) if rotate else row_h) + 0.3  # 45-degree names: sin 45 of their length
    top, right = 0.55, 1.4
    width, height = left + ax_w + right, bottom + ax_h + top
    fig = new_figure(width, height)
    ax = fig.add_axes((left / width, bottom / height, ax_w / width, ax_h / height))
    cmap = matplotlib.colormaps["viridis"].with_extremes(bad=(0, 0, 0, 0))
    im = ax.imshow(np.ma.masked_invalid(z), cmap=cmap, aspect="auto", zorder=2)
    under = np.ones((len(rows), len(cols), 4))  # white: stable but no rate to colour by
    for i in range(len(rows)):
        for j in range(len(cols)):
            if states[i][j] in MAP_COLOURS:
                under[i, j] = to_rgba(MAP_COLOURS[states[i][j]])
    ax.imshow(under, aspect="auto", zorder=1)
    finite = z[np.isfinite(z)]
    mid = float(np.mean(finite)) if finite.size else 0.0
    for i in range(len(rows)):
        for j in range(len(cols)):
            ax.text(j, i, text[i][j], ha="center", va="center", fontsize=font, zorder=3,
                    color="white" if np.isfinite(z[i, j]) and z[i, j] < mid else "black")
    ax.set_xticks(range(len(cols)), cols, fontsize=font, **({"rotation": 45, "ha": "right",
                                                             "rotation_mode": "anchor"} if rotate else {}))
    ax.set_yticks(range(len(rows)), rows, fontsize=font)
    ax.set_xlabel("variant" if transpose else "engine/integrator", fontsize=font)
    ax.set_ylabel("engine/integrator" if transpose else "variant", fontsize=font)
    if finite.size:
        cax = fig.add_axes(((left + ax_w + 0.2) / width, bottom / height, 0.18 / width, ax_h / height))
        bar = fig.colorbar(im, cax=cax)
        bar.set_label("log10(stable step x rate)", fontsize=font)
        bar.ax.tick_params(labelsize=font)
    ax.set_title("Largest stable step (s) and failure mode above it", fontsize=font + 1)
    # the legend below everything the axes draw (their tick labels included), wrapped to the figure's width
    renderer = fig.canvas.get_renderer()
    below = ax.get_tightbbox(renderer).transformed(fig.transFigure.inverted()).y0
    chars = max(30, int((width - 0.6) / _CHAR_IN))
    handles = [Patch(facecolor=MAP_COLOURS[k], edgecolor="0.4", label=textwrap.fill(MAP_LEGEND[k], chars))
               for k in MAP_COLOURS]
    fig.legend(handles=handles, loc="upper left", bbox_to_anchor=(0.1 / width, below - 0.08 / height),
               fontsize=font, frameon=False, ncol=1)
    return fig


def map_png(run: StressRun) -> bytes | None:
    """Heat map: variant x engine/integrator, colour log10(h·rate) of the largest stable step
    (adaptive: of the mean step), ``MAP_COLOURS`` for cells with no stable step and cells not
    run (a legend, outside the axes, says which), text: the map cell (``map_figure``)."""
    fig = map_figure(run)
    return None if fig is None else png_bytes(fig, dpi=PLOT_DPI, bbox_inches="tight", pad_inches=0.15)


def variant_png(run: StressRun, v: Variant) -> bytes | None:
    """Error and energy error against time at the nominal step, one line per engine/integrator."""
    rows = [m for m in _rows_of(run, v.name) if m.nominal is not None and len(m.nominal.series_t)]
    ref = run.references.get(v.name)
    if not rows:
        return None
    long = "long" in v.tags
    energy_only = not v.references  # the error is the energy error: one panel
    entries = ([("reference DOP853", ref)] if ref is not None and len(ref.series_t) else []) + [(m.label, m.nominal) for m in rows]
    # each panel's legend right of it, one entry a line at MIN_FONT: the figure grows with the entries
    legend_w = _text_width([f"{label} (adaptive) energy_growth: bounded" for label, _ in entries]) + 0.6
    panel_h = max(3.0, 1.5 * MIN_FONT / 72 * (len(entries) + 1) + 0.4)
    if energy_only:
        fig = _figure(7 + legend_w, panel_h + 0.9)
        ax2 = fig.subplots()
        ax1 = ax2
    else:
        fig = _figure(7 + legend_w, 2 * panel_h + 0.9)
        ax1, ax2 = fig.subplots(2, 1, sharex=True)
    import matplotlib

    colors = matplotlib.colormaps["tab20"]
    for k, (label, n) in enumerate(entries):
        style = {"color": colors(k % 20), "lw": 1.0, "ls": _linestyle(label)}
        if label.startswith("reference"):
            style.update(color="k", lw=1.4, ls=":")
        t = n.series_t
        err = np.where(n.series_error > 0, n.series_error, np.nan)
        en = np.where(n.series_energy > 0, n.series_energy, np.nan)
        tag = f"{label} ({'adaptive' if n.spec.role in ('adaptive', 'reference') else _fmt(n.spec.dt)})" + (f" {n.mode}" if n.mode else "")
        if np.any(np.isfinite(err)) and not energy_only:
            ax1.plot(t, err, label=tag, **style)
        if np.any(np.isfinite(en)):
            name = tag if energy_only else label
            ax2.plot(t, en, label=(f"{name}: {n.drift_class}" if n.drift_class and long else name), **style)
    kind = entries[-1][1].error_kind or "error"
    band = v.band.get(kind if kind != "trajectory" else "position")
    for ax, b in (((ax1, band),) if not energy_only else ()) + ((ax2, v.band["energy"]),):
        ax.set_yscale("log")
        lo, hi = ax.get_ylim()
        if hi > 1e3:  # a blow-up leaves through the top instead of squashing the rest
            ax.set_ylim(lo, 1e3)
        if b:
            ax.axhline(b, color="r", lw=0.8, ls="--")
        if long:
            ax.set_xscale("log")
    outside = {"loc": "upper left", "bbox_to_anchor": (1.02, 1.0), "borderaxespad": 0.0, "fontsize": MIN_FONT,
               "frameon": False}
    if not energy_only:
        ax1.set_ylabel({"exact": "error vs exact", "trajectory": "max rel. error vs DOP853"}.get(kind, kind))
        ax1.legend(**outside)
    ax2.set_ylabel("|E - E0| / E_scale")
    ax2.set_xlabel("t (s)")
    ax1.set_title(f"{v.name}: at the nominal step (red: band)", fontsize=10)
    ax2.legend(**outside)
    return _png(fig)


def sweep_png(run: StressRun, group: str, variants: list[Variant]) -> bytes | None:
    """Largest stable step against the group's sweep value, one line per engine/integrator
    (open triangle: stable at the largest step tried, a lower bound)."""
    pts: dict[str, list[tuple[float, float, bool]]] = {}
    for v in sorted(variants, key=lambda v: v.sweep):
        for m in _rows_of(run, v.name):
            if m.kind == "fixed" and m.stable_dt is not None:
                pts.setdefault(m.label, []).append((v.sweep, m.stable_dt, m.censored))
    if not pts:
        return None
    fig = _figure(6.5 + _text_width(pts) + 0.6, max(4.5, 1.5 * MIN_FONT / 72 * (len(pts) + 1) + 0.9))
    ax = fig.subplots()
    for label, p in pts.items():
        x, y, c = zip(*p)
        line, = ax.plot(x, y, marker="o", lw=1.0, label=label, ls=_linestyle(label))
        cx = [a for a, cc in zip(x, c) if cc]
        cy = [b for b, cc in zip(y, c) if cc]
        if cx:
            ax.plot(cx, cy, ls="none", marker="^", mfc="none", ms=10, color=line.get_color())
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(next((v.sweep_label for v in variants if v.sweep_label), group))
    ax.set_ylabel("largest stable step (s)")
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0, fontsize=MIN_FONT, frameon=False)
    ax.set_title(f"{group} (triangle: stable at the largest step tried)", fontsize=10)
    return _png(fig)


def _slug(text: str) -> str:
    return "".join(c if c.isalnum() else "_" for c in text).strip("_").lower()


def write_plots(run: StressRun, out_dir: Path) -> dict[str, str]:
    """Write the plots (one set); returns name -> path relative to ``out_dir`` (for the markdown)."""
    refs, files = plot_files(run)
    atomic.write_set(Path(out_dir), files)
    return refs


PLOT_TIMEOUT = 600.0  # s allowed to one worker's share of the figures


def _draw(todo: list[tuple[str, Callable, tuple]]) -> list[tuple[str, bytes | None]]:
    """Worker body: draw a share of the figures, ``[(key, PNG bytes or None)]``."""
    return [(key, fn(*args)) for key, fn, args in todo]


def plot_files(run: StressRun) -> tuple[dict[str, str], dict[str, bytes]]:
    """The plots: (name -> path relative to the report folder, for the markdown; that relative
    path -> PNG bytes). The figures are shared among worker processes, one per core
    (``harness.validate.workers.run_cases``: the workers inherit ``run``; one worker per share,
    not per figure, as each new process pays Matplotlib's first-figure setup, ~1 s; drawing the
    31 figures of the full catalogue took 30-35 s on one core)."""
    todo: list[tuple[str, str, Callable, tuple]] = [("map", "map.png", map_png, (run,))]
    groups: dict[str, list[Variant]] = {}
    for v in run.variants:
        if v.name not in run.skipped and v.sweep is not None:
            groups.setdefault(v.group, []).append(v)
    for group, vs in groups.items():
        if len(vs) >= 2:
            todo.append((f"sweep:{group}", f"sweep_{_slug(group)}.png", sweep_png, (run, group, vs)))
    for v in run.variants:
        if v.name not in run.skipped:
            todo.append((v.name, f"{v.name}.png", variant_png, (run, v)))
    shares = max(1, min(effective_jobs(None), len(todo)))
    cases = [(i, _draw, ([(key, fn, args) for key, _, fn, args in todo[i::shares]],)) for i in range(shares)]
    drawn: dict[str, bytes | None] = {}
    for i, outcome in run_cases(cases, shares, PLOT_TIMEOUT).items():
        if outcome.status != "ok":
            names = ", ".join(name for _, name, _, _ in todo[i::shares])
            raise RuntimeError(f"stress plots ({names}): {outcome.status}: {outcome.message}")
        drawn.update(outcome.value)
    out: dict[str, str] = {}
    files: dict[str, bytes] = {}
    for key, name, _, _ in todo:
        if drawn[key]:
            out[key] = f"{PLOT_DIR}/{name}"
            files[out[key]] = drawn[key]
    return out, files


def write_stress_reports(run: StressRun, prov: dict, out_dir: Path, command: str | None = None) -> list[Path]:
    """Write ``stress.md``, ``stress.csv``, ``stress_map.csv`` and the plots into ``out_dir`` as
    one set (``harness.io.atomic.write_set``); returns their paths. ``command``: the
    "Reproduce with" command (default ``harness.io.provenance.command_line()``). ``InputError``
    if ``out_dir`` cannot be written (the old files are then kept)."""
    out_dir = Path(out_dir)
    atomic.check_writable(out_dir)
    plots, figures = plot_files(run)
    files: dict[str, bytes | str] = {
        "stress.md": markdown(run, prov, plots, command),
        "stress.csv": trials_frame(run).to_csv(index=False),
        "stress_map.csv": map_frame(run).to_csv(index=False),
    }
    files.update(figures)
    return atomic.write_set(out_dir, files)
