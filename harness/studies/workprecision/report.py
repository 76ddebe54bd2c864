"""Reports of a work-precision sweep: ``workprecision.md``, ``workprecision.csv`` and one
log-log figure per scene, ``workprecision/<scene>.png``; written as one set
(``harness.io.atomic.write_set``: all old or all new) and stamped with the provenance of the
run, the command that made it, its wall time and the machine's load.

``workprecision.md`` opens with the targets (``targets_section``: per scene the in-house time
over MuJoCo RK4's at equal state error, from the head to head, and the batched throughput over
``mujoco.rollout``'s, each "met", "not met", "not reached by MuJoCo" or "not run (why)"), then how
the sweep was run, the interpolated times, the head to head, the batch, where the time went
(``walls_section``), and one section per scene (figure, times to each target, each curve's error
model: its class (converges, model difference, defect, unresolved, not judged), observed order and floor, with
its wall time and why it stopped).

The figures are laid out with fixed margins, not ``tight_layout``: it measured every tick label
again and took 1.0 of the 2.4 s a figure took (18 figures: 0.9 s each now)."""

from __future__ import annotations

import math
from pathlib import Path

from harness.io import atomic
from harness.engines import DECLARATIONS, ENGINE_NAMES, ENGINES, REFERENCE_ENGINE, display
from harness.studies.workprecision.run import (BASE, BASELINE, BASELINE_RK4, NOT_REACHED_BASELINE, NOT_REACHED_EITHER,
                                               NOT_REACHED_REFERENCE, REF, ROLLOUT, TARGET_RATIO, TARGET_THROUGHPUT, TARGETS,
                                               SceneSweep, SweepOptions, by_curve, observed_order, points_table,
                                               time_table)
from harness.io.figures import new_figure, png_bytes

_MARKERS = "os^vDP*Xhp<>"
#: The engines whose points time the engine's whole run (neither the baseline nor the reference engine).
OTHERS = tuple(e for e in ENGINE_NAMES if e not in (BASELINE, REFERENCE_ENGINE))
SAME_ERROR_RTOL = 1e-6   # two curves with errors this close at every common parameter ...
SAME_TIME_FACTOR = 2.0   # ... and median run times within this factor lie on top of each other


def _fmt(x: float, spec: str = ".3g") -> str:
    return "—" if x is None or not math.isfinite(x) else format(x, spec)


def _style(label: str, index: int) -> dict:
    """A curve's line: the colour and dash its engine declares for it
    (``harness.engines.Declaration.curves``; black and solid for a curve it does not declare)."""
    engine, _, rest = label.partition(" ")
    method, _, variant = rest.partition(" ")
    variant = variant.strip("()")
    declared = [c for c in (ENGINES[engine].curves if engine in ENGINES else ())
                if c.integrator == method and c.variant == variant]
    color, dashed = (declared[0].colour, declared[0].dashed) if declared else ("black", False)
    return {"color": color, "linestyle": "--" if dashed else "-", "marker": _MARKERS[index % len(_MARKERS)],
            "markersize": 4, "linewidth": 1.4}


def coinciding(groups: dict[str, list], key: str = "state_max") -> dict[str, str]:
    """Curves that would hide one another in the plot: ``{label: earlier label}`` for each curve
    whose errors (``key``) equal an earlier curve's at every parameter (dt or tolerance) both ran
    (at least two; relative difference <= ``SAME_ERROR_RTOL``) and whose median run times there
    are within ``SAME_TIME_FACTOR`` of the earlier's, e.g. MuJoCo's ``rollout`` and ``loop``
    variants of one integrator (the same steps: the same errors, times ~1.1x apart), or two
    integrators that happen to coincide on a scene (MuJoCo's Euler and implicitfast without
    velocity-dependent forces)."""
    labels = list(groups)
    out: dict[str, str] = {}
    for j, label in enumerate(labels):
        mine = {p.param: p for p in groups[label] if p.ok and math.isfinite(getattr(p, key))}
        for other in labels[:j]:
            if other in out:
                continue  # match against the curve drawn in full
            theirs = {p.param: p for p in groups[other] if p.ok and math.isfinite(getattr(p, key))}
            common = sorted(set(mine) & set(theirs))
            if len(common) < 2:
                continue
            same_error = all(abs(getattr(mine[c], key) - getattr(theirs[c], key))
                             <= SAME_ERROR_RTOL * max(abs(getattr(theirs[c], key)), 1e-300) for c in common)
            ratios = sorted(mine[c].time_s / theirs[c].time_s for c in common if theirs[c].time_s > 0)
            close_in_time = bool(ratios) and 1.0 / SAME_TIME_FACTOR <= ratios[len(ratios) // 2] <= SAME_TIME_FACTOR
            if same_error and close_in_time:
                out[label] = other
                break
    return out


def curve_styles(groups: dict[str, list]) -> dict[str, tuple[str, dict]]:
    """Legend label and line style of each curve (``_style``); a curve that coincides with an
    earlier one (``coinciding``) is drawn under it, dotted, with larger open markers, and its
    legend says "same errors as <earlier>", so that neither hides the other."""
    same = coinciding(groups)
    out = {}
    for i, label in enumerate(groups):
        style = _style(label, i)
        legend = label
        if label in same:
            style.update(linestyle=":", markerfacecolor="none", markersize=8, markeredgewidth=1.2, zorder=1.5)
            legend = f"{label} (same errors as {same[label]})"
        else:
            style.setdefault("zorder", 2.5)
        out[label] = (legend, style)
    return out


def plot_scene(sweep: SceneSweep, provenance: dict) -> bytes:
    """The scene's figure as PNG bytes: state error (max over saved steps) and energy error
    against run time, log-log, one curve per engine/integrator(/variant); curves that lie on top
    of each other are told apart (``curve_styles``)."""
    groups = by_curve(sweep.points)
    styles = curve_styles(groups)
    fig = new_figure(15, 7.5)
    axes = fig.subplots(1, 2)
    for ax, key, title in ((axes[0], "state_max", "state error (max over saved steps)"),
                           (axes[1], "energy_max", "energy error (max over saved steps)")):
        for label, pts in groups.items():
            good = sorted((p for p in pts if p.ok and math.isfinite(getattr(p, key)) and getattr(p, key) > 0),
                          key=lambda p: p.param, reverse=True)
            if not good:
                continue
            legend, style = styles[label]
            ax.plot([p.time_s for p in good], [max(getattr(p, key), 1e-16) for p in good], label=legend, **style)
        for target in TARGETS:
            ax.axhline(target, color="grey", linewidth=0.8, linestyle=":")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(f"run time (s, median; {BASE} rollout: time inside rollout)")
        ax.set_ylabel(title)
        ax.set_ylim(1e-14, 10.0)
        ax.grid(True, which="major", alpha=0.3)
        ax.set_title(title)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=4, fontsize=9, frameon=False)
    fig.suptitle(f"{sweep.scene}: work-precision, t_end = {sweep.t_end:g} s, errors at {len(_saves(sweep))} saved "
                 "times — " + "".join(f"{d.display} {provenance.get(d.name, '?')}, " for d in DECLARATIONS if d.library)
                 + f"{provenance.get('date_utc', '')}", fontsize=11)
    fig.subplots_adjust(left=0.06, right=0.99, bottom=0.23, top=0.9, wspace=0.18)  # as tight_layout(rect=(0, 0.14, 1, 0.95)), at half the cost
    return png_bytes(fig, dpi=110)


def class_cell(model) -> str:
    """A curve's class and observed order as its table shows them: ``converges (3.98)``; the
    order left out where none was measured (``converges`` at the resolution, ``not judged``)."""
    order = model.observed_order
    return f"{model.classification} ({order:.2f})" if math.isfinite(order) else model.classification


def _capital(text: str) -> str:
    """``text`` with its first letter upper case ("in-house" -> "In-house", "MuJoCo" kept)."""
    return text[:1].upper() + text[1:]


def _saves(sweep: SceneSweep) -> range:
    return range(int(round(sweep.t_end / sweep.save_every)) + 1)


def _best(rows: list[dict], predicate, target: float) -> tuple[str, float]:
    key = f"t({target:g})"
    cands = [(r[key], r["label"]) for r in rows if predicate(r["label"]) and math.isfinite(r[key])]
    if not cands:
        return "—", float("nan")
    t, label = min(cands)
    return label, t


def markdown(results: list[SceneSweep], provenance: dict, options: SweepOptions,
             load: tuple[float, float] | None = None, command: str | None = None, wall_s: float | None = None) -> str:
    """The report (see the module docstring). ``command``: the "Reproduce with" command (default
    ``harness.io.provenance.command_line()``, the command this process was started with);
    ``load``: the 1-minute load average before and after the sweep; ``wall_s``: the sweep's wall
    time (s)."""
    if command is None:
        from harness.io.provenance import command_line

        command = command_line()
    lines = ["# Work-precision: error against run time", ""]
    lines.append(f"Reproduce with `{command}`. Made with " + ", ".join(f"{k} {v}" for k, v in provenance.items()) + ".")
    run_line = []
    if wall_s is not None:
        run_line.append(f"The sweep took {wall_s:.0f} s wall ({wall_s / 60:.1f} min) for {len(results)} scenes")
    if load:
        run_line.append(f"load average of the machine (1 min) before and after: {load[0]:.2f}, {load[1]:.2f} "
                        "(other processes share the cores: compare times within one report only)")
    if run_line:
        lines.append("; ".join(run_line) + ".")
    lines += [""] + targets_section(results, options) + [""]
    lines += ["## How the sweep was run", "",
              "Each point is one run: one warm-up (which gives the errors), then the median (and minimum) of "
              f"{options.repeats} timed runs (one only when the warm-up took more than {options.slow_run_s:g} s). "
              "Errors are against the reference at the saved times (`harness/studies/workprecision/run.py` defines them): "
              "state error = max over bodies and saved steps of max(|Δp|/L, geodesic angle, |Δv|/V, |Δω|/Ω); "
              f"energy and momentum errors relative to their scales. Times: {BASE} `rollout` = time inside "
              f"`{ROLLOUT}`; {BASE} `loop` = the harness's Python stepping loop (with reading each saved "
              f"sample); {', '.join(display(e) for e in OTHERS)} and {REF} `per-state` = the engine's run; {REF} "
              "`compiled` = the compiled integrator alone (compiled before the clock starts). Raw points: `workprecision.csv`.", "",
              budget_text(options), ""]
    lines += per_state_lines(results, options)
    summary = [f"## {_capital(REF)} against {BASE} RK4, interpolated on the curves", "",
               "Time each reaches a target state error, interpolated in log-log on its curve (the head to head "
               "below times recorded runs again instead).", "",
               f"| scene | target | best {REF} (time) | {BASE} RK4 rollout | ratio | {BASE} RK4 loop | ratio |",
               "|---|---|---|---|---|---|---|"]
    body: list[str] = []
    for sweep in results:
        rows = time_table(sweep)
        for target in TARGETS:
            ih_label, ih_t = _best(rows, lambda s: s.split()[0] == REFERENCE_ENGINE, target)
            _, mr_t = _best(rows, lambda s: s == BASELINE_RK4["rollout"], target)
            _, ml_t = _best(rows, lambda s: s == BASELINE_RK4["loop"], target)
            summary.append(f"| {sweep.scene} | {target:g} | {ih_label} ({_fmt(ih_t)} s) | {_fmt(mr_t)} s | "
                           f"{_fmt(ih_t / mr_t if mr_t else float('nan'), '.2f')} | {_fmt(ml_t)} s | "
                           f"{_fmt(ih_t / ml_t if ml_t else float('nan'), '.2f')} |")
        body += [f"## {sweep.scene}", "",
                 f"Horizon {sweep.t_end:g} s, errors at {len(_saves(sweep))} saved times (every {sweep.save_every:g} s). "
                 f"Reference: {sweep.reference}."]
        for what, value in sweep.reference_checks.items():
            body.append(f"Reference against the closed form — {what}: {_fmt(value, '.2e')}.")
        if sweep.skipped:
            body += ["", "Not run on this scene (the method does not model it; no points, not a failure):", ""]
            body += [f"- {label}: {why}" for label, why in sweep.skipped.items()]
        same = coinciding(by_curve(sweep.points))
        body += ["", f"![{sweep.scene}](workprecision/{sweep.scene}.png)", ""]
        if same:
            body += ["In the figure, " + "; ".join(f"{a} has the same errors as {b}" for a, b in same.items())
                     + f" (equal to {SAME_ERROR_RTOL:g} relative at every step or tolerance both ran, times within "
                     f"{SAME_TIME_FACTOR:g}x): each is drawn dotted with open markers under the curve it coincides with.",
                     ""]
        body += ["Time to reach a state error, interpolated on each curve (ratio: to the fastest curve; "
                 "— never reached in the sweep):", "",
                 "| curve | " + " | ".join(f"t @ {t:g} (s) | ratio" for t in TARGETS) + " |",
                 "|---|" + "---|---|" * len(TARGETS)]
        for r in sorted(rows, key=lambda r: (not math.isfinite(r[f"t({TARGETS[0]:g})"]), r[f"t({TARGETS[0]:g})"])):
            body.append(f"| {r['label']} | " + " | ".join(f"{_fmt(r[f't({t:g})'])} | {_fmt(r[f'ratio({t:g})'], '.1f')}"
                                                        for t in TARGETS) + " |")
        body += ["", "Error model of each curve (`harness.judging.error_model`, as validate judges its checks): the state "
                 "error at the curve's finest resolved points (up to three, above 10x the resolution: the reference's "
                 f"accuracy {options.error_floor:g} or the round-off N·eps), fitted as C·h^p + F against the step "
                 "(adaptive: against the tolerance, order 1). Class: converges (the error falls at about the method's "
                 "order, or sits at the resolution), model difference (a floor F that does not shrink with the step: "
                 "soft constraints or contact), defect (an order far below the method's, an error growing with "
                 "refinement), unresolved (an error of the motion's own size: nothing to fit), not judged (one sound "
                 "point or none). Order: the observed order of the "
                 "finest two levels; effective order (adaptive): -slope of log error against log accepted steps.", "",
                 "| curve | nominal | class (order) | floor | levels (dt or tol) | effective order | best state error "
                 "| runs failed | wall (s) | stopped |",
                 "|---|---|---|---|---|---|---|---|---|---|"]
        for label, pts in by_curve(sweep.points).items():
            o = observed_order(pts, options.error_floor)
            best = min((p.state_max for p in pts if p.ok), default=float("nan"))
            bad = sum(not p.ok for p in pts)
            log = sweep.curves.get(label, {})
            m = o["model"]
            floor = _fmt(m.floor, ".1e") if m.floor > 0 else ("0" if m.floor == 0 else "—")
            body.append(f"| {label} | {pts[0].nominal_order} | {class_cell(m)} | {floor} | {o['range'] or '—'} | "
                        f"{_fmt(o.get('steps_order', float('nan')), '.2f')} | {_fmt(best, '.1e')} | {bad} | "
                        f"{_fmt(log.get('wall_s', float('nan')), '.2f')} | {log.get('stop', '—')} |")
        over = overhead_rows(sweep)
        if over:
            body += ["", f"{BASE} through the harness's stepping loop against `{ROLLOUT}` (medians over the "
                     "timesteps both ran; the first ratio is the harness's own overhead):", "",
                     "| integrator | loop / rollout | rollout with conversion / rollout | loop with model compile / loop | timesteps |",
                     "|---|---|---|---|---|"]
            for integrator, lr, rc, lc, n in over:
                body.append(f"| {integrator} | {lr:.2f} | {rc:.2f} | {lc:.2f} | {n} |")
        failed = [p for p in sweep.points if not p.ok]
        if failed:
            body += ["", "Failed or blown-up runs (recorded points):", ""]
            for p in failed:
                body.append(f"- {p.label} at {p.param:.3g}: {p.status} — {p.message or 'non-finite error'}")
        body.append("")
    lines += summary + [""] + h2h_section(results) + [""] + batch_section(results) + [""] + walls_section(results) + [""] + body
    return "\n".join(lines) + "\n"


def overhead_rows(sweep: SceneSweep) -> list[tuple[str, float, float, float, int]]:
    """Per MuJoCo integrator, medians over the timesteps both variants ran: stepping-loop time
    over rollout time (the harness's Python overhead), rollout total (with the conversion to
    maximal coordinates) over rollout time, loop total (with compiling the model) over loop time."""
    import statistics

    out = []
    pts = [p for p in sweep.points if p.engine == BASELINE and p.ok]
    for integrator in dict.fromkeys(c.integrator for c in ENGINES[BASELINE].curves):
        roll = {p.param: p for p in pts if p.integrator == integrator and p.variant == "rollout"}
        loop = {p.param: p for p in pts if p.integrator == integrator and p.variant == "loop"}
        common = sorted(set(roll) & set(loop))
        if not common:
            continue
        out.append((integrator,
                    statistics.median(loop[d].time_s / roll[d].time_s for d in common),
                    statistics.median(roll[d].time_total_s / roll[d].time_s for d in common),
                    statistics.median(loop[d].time_total_s / loop[d].time_s for d in common),
                    len(common)))
    return out


def h2h_section(results: list[SceneSweep]) -> list[str]:
    rows = [(r.scene, h) for r in results for h in r.head_to_head]
    if not rows:
        return []
    out = ["## Head to head at equal state error (timed in alternation)", "",
           f"For each target, the cheapest recorded {REF} run and {BASE} RK4 run that reach it are timed again "
           "in alternation (rounds: at least 3, up to 5 while they take less than 2 s; medians), so that both see "
           f"the same machine load; {BASE}'s loop is timed at the rollout run's dt. Ratio < 1: the {REF} solver "
           f"is faster. Where `{ROLLOUT}` cannot run a scene (prescribed forces), {BASE} RK4 is its loop.", "",
           f"| scene | target | {REF} run | error | time (s) | {BASE} RK4 run | error | time (s) | ratio | "
           f"{BASE} RK4 loop time (s) | ratio to loop | rounds |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for scene, h in rows:
        if h.get("status") != "ok":
            target = h.get("target")
            out.append(f"| {scene} | {_fmt(target, 'g') if target else '—'} | {h.get('status')} | | | | | | | | | |")
            continue
        side = h.get(BASELINE, "rollout")
        ih, mj = h[REFERENCE_ENGINE], h[BASELINE_RK4[side]]
        ml = h.get(BASELINE_RK4["loop"])
        out.append(f"| {scene} | {h['target']:g} | {ih['label']} at {ih['param']:.3g} | {ih['state_max']:.1e} | "
                   f"{ih['time_s']:.4g} | {side} dt {mj['param']:.3g} | {mj['state_max']:.1e} | {mj['time_s']:.4g} | "
                   f"{h['ratio']:.2f} | {_fmt(ml['time_s'] if ml else float('nan'), '.4g')} | "
                   f"{_fmt(h.get('ratio_loop', float('nan')), '.2f')} | {h.get('rounds', '—')} |")
    return out


MET, NOT_MET, NOT_REACHED, NOT_RUN = "met", "not met", f"not reached by {BASE}", "not run"


def _h2h_cell(h: dict | None) -> dict:
    """The target cell of one head-to-head row: ``{"status", "value", "note"}`` (``status`` one of
    ``MET``, ``NOT_MET``, ``NOT_REACHED``, ``NOT_RUN``)."""
    nan = float("nan")
    if h is None:
        return {"status": NOT_RUN, "value": nan, "note": f"no head to head ({BASE} and the {REF} engine both needed)"}
    status = h.get("status", "")
    if status == "ok":
        ratio = h["ratio"]
        note = f"against {BASE}'s loop: {ROLLOUT} cannot run this scene" if h.get(BASELINE) == "loop" else ""
        return {"status": MET if ratio <= TARGET_RATIO else NOT_MET, "value": ratio, "note": note}
    if status in (NOT_REACHED_BASELINE, NOT_REACHED_EITHER):
        return {"status": NOT_REACHED, "value": nan, "note": ""}
    if status == NOT_REACHED_REFERENCE:
        return {"status": NOT_MET, "value": nan, "note": f"the {REF} solver did not reach it in the sweep"}
    return {"status": NOT_RUN, "value": nan, "note": status}


def _batch_cell(b: dict | None) -> dict:
    nan = float("nan")
    if not b:
        return {"status": NOT_RUN, "value": nan, "note": "no batch benchmark (--batch 0, or an engine not selected)"}
    if "compiled_steps_per_s" not in b:
        return {"status": NOT_RUN, "value": nan, "note": str(b.get("status", ""))}
    ratio = b["compiled_steps_per_s"] / b[f"{BASELINE}_steps_per_s"]
    note = "" if b.get("status") == "ok" else str(b.get("status"))
    return {"status": MET if ratio >= TARGET_THROUGHPUT and not note else NOT_MET, "value": ratio, "note": note}


def _baseline_best(sweep: SceneSweep, side: str) -> str:
    """How far MuJoCo RK4 (``side``: "rollout" or "loop") got: its best state error and why its
    curve stopped."""
    label = BASELINE_RK4[side]
    best = min((p.state_max for p in sweep.points if p.label == label and p.ok), default=float("nan"))
    stop = sweep.curves.get(label, {}).get("stop")
    return f"best {_fmt(best, '.1e')}" + (f", {stop}" if stop else "") if math.isfinite(best) else ""


def target_rows(results: list[SceneSweep], targets=TARGETS) -> list[dict]:
    """Per scene, the targets of the in-house solver against MuJoCo: ``{"scene", target: cell for
    each of ``targets`` (head-to-head ratio <= ``TARGET_RATIO``), "batch": cell (throughput ratio at
    threads = cores >= ``TARGET_THROUGHPUT``)}``, each cell ``{"status": "met" / "not met" /
    "not reached by MuJoCo" / "not run", "value", "note"}``."""
    out = []
    for sweep in results:
        by_target = {h.get("target"): h for h in sweep.head_to_head}
        row: dict = {"scene": sweep.scene}
        for target in targets:
            h = by_target.get(target)
            if h is None and sweep.head_to_head and "target" not in sweep.head_to_head[0]:
                h = sweep.head_to_head[0]  # the whole head to head failed: one row says why
            row[target] = _h2h_cell(h)
            if row[target]["status"] == NOT_REACHED:
                row[target]["note"] = _baseline_best(sweep, (h or {}).get(BASELINE, "rollout"))
        row["batch"] = _batch_cell(sweep.batch)
        out.append(row)
    return out


def _cell_text(cell: dict, spec: str) -> str:
    status, value, note = cell["status"], cell["value"], cell["note"]
    if status in (MET, NOT_MET):
        text = f"{status} ({_fmt(value, spec)})" if math.isfinite(value) else status
        return text + (f" — {note}" if note else "")
    if status == NOT_RUN:
        return f"not run ({note})" if note else "not run"
    return f"{status} ({note})" if note else status


def targets_section(results: list[SceneSweep], options: SweepOptions, targets=TARGETS) -> list[str]:
    """The "Targets" table: per scene, the in-house time over MuJoCo RK4's at equal state error
    (head to head) at each target, and the batched throughput over ``mujoco.rollout``'s."""
    rows = target_rows(results, targets)
    out = ["## Targets", "",
           f"{_capital(REF)} time over {BASE} RK4's at equal state error (head to head, below): target ≤ {TARGET_RATIO:g} at "
           + " and ".join(f"{t:g}" for t in targets) + f" on every scene {BASE} reaches; batched throughput of the "
           f"compiled {REF} RK4 over `{ROLLOUT}`'s (threads = cores): target ≥ {TARGET_THROUGHPUT:g}×. "
           f"Where {BASE} RK4 does not reach a target, its best state error and why its curve stopped are given "
           "(\"error stalled\": its error no longer falls as its step is halved, e.g. on soft loop or contact "
           "constraints).", "",
           "| scene | " + " | ".join(f"ratio at {t:g}" for t in targets) + " | batched throughput ratio |",
           "|---|" + "---|" * (len(targets) + 1)]
    for row in rows:
        out.append(f"| {row['scene']} | " + " | ".join(_cell_text(row[t], ".2f") for t in targets)
                   + f" | {_cell_text(row['batch'], '.2f')} |")
    counts = []
    for key, what in [(t, f"ratio at {t:g}") for t in targets] + [("batch", "throughput")]:
        cells = [r[key]["status"] for r in rows]
        judged = cells.count(MET) + cells.count(NOT_MET)
        others = [f"{cells.count(c)} {c}" for c in (NOT_REACHED, NOT_RUN) if cells.count(c)]
        counts.append(f"{what}: met on {cells.count(MET)} of {judged} scenes judged"
                      + (f" ({', '.join(others)})" if others else ""))
    out += ["", "; ".join(counts) + "."]
    return out


def budget_text(options: SweepOptions) -> str:
    """What the sweep's refinement rules were (``run`` module docstring)."""
    def b(v):
        return "no budget" if v is None else f"{v:g} s"

    start = ("from the save interval" if options.coarsest_dt is None
             else f"from {options.coarsest_dt:g} × the scene's dt")
    return (f"Refinement: timesteps halved {start} down to save/2^{options.dt_levels - 1}, tolerances "
            f"{max(options.tolerances):g} to {min(options.tolerances):g}; a curve stops when its next point would "
            f"exceed its time budget (warm-up, repeats and errors of all its points: {b(options.curve_budget_s)}; "
            f"{b(options.key_budget_s)} for the curves the targets are measured on, {BASE} RK4 and the {REF} DOP853, "
            f"{b(options.reach_budget_s)} while one still converges at its order towards a target it must reach; "
            f"{b(options.loop_budget_s)} for {BASE}'s other loop variants), after a run slower than {options.max_run_s:g} s, "
            f"once its state error is below {options.stop_error:g}, when its error stalls or its runs fail. Each "
            "curve's wall time and why it stopped are in its scene's order table.")


def per_state_lines(results: list[SceneSweep], options: SweepOptions) -> list[str]:
    """Where the per-state in-house curves ran and where the sweep left them out."""
    omitted = [r.scene for r in results if any("per-state" in k for k in r.omitted)]
    ran = [r.scene for r in results if any(p.variant == "per-state" for p in r.points)]
    if not omitted and not ran:
        return []
    text = f"Per-state {REF} curves (the readable oracle, NumPy per step): "
    if options.per_state == "uncovered":
        text += ("swept only where the compiled form does not model the scene"
                 + (f" ({', '.join(ran)})" if ran else " (none: it models every scene of this run)")
                 + "; `--per-state all` sweeps them everywhere.")
    elif options.per_state == "none":
        text += "not swept (`--per-state none`)."
    else:
        text += "swept on every scene (`--per-state all`)."
    return [text, ""]


def walls_section(results: list[SceneSweep]) -> list[str]:
    """Where the sweep's time went: per scene its stages and its three most expensive curves."""
    rows = [r for r in results if r.walls]
    if not rows:
        return []
    out = ["## Where the time went", "",
           "Wall time per scene (s): the reference (with its check against the scene's closed form, where there "
           "is one), all curves, the head to head, the batch benchmark, and the curves that took longest (their "
           "points' warm-ups, timed repeats and errors). The figures and the CSV are written after the sweep.", "",
           "| scene | total | reference | curves | head to head | batch | longest curves |",
           "|---|---|---|---|---|---|---|"]
    for r in rows:
        w = r.walls
        top = sorted(r.curves.items(), key=lambda kv: -kv[1]["wall_s"])[:3]
        out.append(f"| {r.scene} | {_fmt(w.get('total', float('nan')), '.1f')} | {_fmt(w.get('reference', float('nan')), '.2f')} | "
                   f"{_fmt(w.get('curves', float('nan')), '.1f')} | {_fmt(w.get('head_to_head', float('nan')), '.1f')} | "
                   f"{_fmt(w.get('batch', float('nan')), '.1f')} | "
                   + ", ".join(f"{k} {v['wall_s']:.1f}" for k, v in top) + " |")
    total = {k: sum(r.walls.get(k, 0.0) for r in rows) for k in ("total", "reference", "curves", "head_to_head", "batch")}
    out.append(f"| all | {total['total']:.1f} | {total['reference']:.2f} | {total['curves']:.1f} | "
               f"{total['head_to_head']:.1f} | {total['batch']:.1f} | |")
    kernels = sum(r.walls.get("kernels", 0.0) for r in rows)
    if kernels:
        out += ["", f"Loading the compiled {REF} kernels before the scenes (compiling them, when Numba's cache does "
                f"not hold them) took {kernels:.1f} s, outside the scenes' totals."]
    return out


def batch_section(results: list[SceneSweep]) -> list[str]:
    rows = [r.batch for r in results if r.batch]
    if not rows:
        return []
    out = ["## Batched throughput: RK4 over many initial conditions", "",
           "Same batch of initial conditions (joint coordinates perturbed, `workprecision.batch_initial_states`), "
           f"same dt (the scene's), same number of steps, all timed in alternation (medians of up to 3 rounds): `{ROLLOUT}` "
           f"against the compiled {REF} RK4 (`rk4_compiled`'s kernel, `compiled.solver.run_batch`: one "
           "trajectory after another on each thread), each with threads = cores and with one thread. "
           "Trajectory-steps per second = nbatch × nstep / median wall time; nbatch is sized from a calibration run "
           "so that the timed runs fit the batch's time budget (at most `--batch`, at least one per thread). Ratios "
           "compare equal thread counts. "
           f"Last column: largest state difference between the {BASE} and the {REF} batch at the end "
           "(relative, as the state error). On scenes with loop joints or rolling contacts the perturbed initial "
           f"states break the constraints, which each engine restores its own way ({BASE}'s soft constraints, the "
           f"{REF} projection), so the two batches follow different motions there (differences of order 1); both "
           "still take nbatch × nstep RK4 steps.", "",
           f"| scene | nbatch × nstep | dt (s) | threads | rollout (steps/s) | {REF} compiled (steps/s) | "
           f"compiled / rollout | rollout 1 thread | compiled 1 thread | ratio 1 thread | {BASE} vs {REF} |",
           "|---|---|---|---|---|---|---|---|---|---|---|"]
    for b in rows:
        if "compiled_steps_per_s" not in b:
            out.append(f"| {b.get('scene')} | — | — | — | — | — | — | — | — | — | {b.get('status')} |")
            continue
        out.append(f"| {b['scene']} | {b['nbatch']} × {b['nstep']} | {b['dt']:g} | {b['threads']} | "
                   f"{b[f'{BASELINE}_steps_per_s']:.3g} | {b['compiled_steps_per_s']:.3g} | "
                   f"{b['compiled_steps_per_s'] / b[f'{BASELINE}_steps_per_s']:.2f} | {b[f'{BASELINE}_1thread_steps_per_s']:.3g} | "
                   f"{b['compiled_1thread_steps_per_s']:.3g} | "
                   f"{b['compiled_1thread_steps_per_s'] / b[f'{BASELINE}_1thread_steps_per_s']:.2f} | "
                   f"{b['max_state_difference']:.1e} |")
    return out


def write_reports(results: list[SceneSweep], provenance: dict, options: SweepOptions, out_dir: Path,
                  load: tuple[float, float] | None = None, command: str | None = None,
                  wall_s: float | None = None) -> list[Path]:
    """Write ``workprecision.md``, ``workprecision.csv`` and ``workprecision/<scene>.png`` under
    ``out_dir`` as one set (``harness.io.atomic.write_set``: all old or all new); returns the
    paths. ``command``: the "Reproduce with" command (default
    ``harness.io.provenance.command_line()``). ``InputError`` if ``out_dir`` cannot be written
    (the old files are then kept)."""
    out_dir = Path(out_dir)
    atomic.check_writable(out_dir)
    table = points_table(results)
    header = "# " + "; ".join(f"{k}: {v}" for k, v in provenance.items()) + "\n"
    files: dict[str, bytes | str] = {
        "workprecision.md": markdown(results, provenance, options, load, command, wall_s),
        "workprecision.csv": header + table.to_csv(index=False),
    }
    for sweep in results:
        files[f"workprecision/{sweep.scene}.png"] = plot_scene(sweep, provenance)
    return atomic.write_set(out_dir, files)


__all__ = ["markdown", "plot_scene", "target_rows", "targets_section", "write_reports"]
