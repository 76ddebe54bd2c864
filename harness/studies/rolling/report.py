"""The rolling-disk study's report: ``rolling_disk.md``, ``rolling_disk.json`` and the plots
``rolling_disk_settings.png``, ``rolling_disk_lean.png``, ``rolling_disk_threshold.png``.

``write_reports(result, out, prov, quick)`` writes them from a ``harness.studies.rolling.run``
result as one set (``harness.io.atomic.write_set``: all old or all new, nothing written if the
folder is not writable) and returns the paths of the PNGs.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from harness.io import atomic
from harness.engines import REFERENCE_ENGINE, display, made_with
from harness.studies.rolling.run import IDEAL_ENGINES, SETTINGS_ENGINE, SETTINGS_NAME, threshold_agrees

SOFT = SETTINGS_NAME  # the engine whose contact settings the study measures, as the report writes it
REF = display(REFERENCE_ENGINE)  # the reference engine, as the report writes it
LEAN_HELD = 1e-11  # rad: the errata line names the ideal engines whose steady circle kept its lean this close


def write_reports(result, out: Path, prov: dict, quick: bool, command: str | None = None) -> list[Path]:
    """Write the study's Markdown, JSON and PNGs into ``out`` as one set; returns the PNG paths.
    ``command``: the "Reproduce with" command (default ``harness.io.provenance.command_line()``).
    ``InputError`` if ``out`` cannot be written (the old files are then kept)."""
    out = Path(out)
    atomic.check_writable(out)
    figures = plot_files(result)
    pngs = [out / name for name in figures]
    files: dict[str, bytes | str] = dict(figures)
    files["rolling_disk.md"] = markdown(result, prov, pngs, quick, command)
    files["rolling_disk.json"] = json.dumps(as_json(result), indent=2, default=str, allow_nan=True)
    atomic.write_set(out, files)
    return pngs


def _e(x) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "—"
    return f"{x:.1e}"


def best_setting(result) -> dict:
    """The settings row with the smallest steady-circle position error at the scene's step; of
    rows within 2 % of it, the first listed (the fewest changes from MuJoCo's defaults)."""
    rows = [r for r in result.settings if r["options"] is not None and r["options"].get("timestep") == result.scene.dt]

    def err(r):
        e = r["steady_circle"].get("position", math.inf)
        return e if e == e else math.inf

    if not rows:
        return None
    least = min(err(r) for r in rows)
    return next(r for r in rows if err(r) <= 1.02 * least)


def markdown(result, prov: dict, pngs: list[Path], quick: bool, command: str | None = None) -> str:
    """The report; ``command`` is the "Reproduce with" command (default
    ``harness.io.provenance.command_line()``, the command this process was started with)."""
    if command is None:
        from harness.io.provenance import command_line

        command = command_line()
    th = result.thresholds
    scene = result.scene
    p = scene.params
    lines = [
        "# Rolling disk: how close each engine comes to ideal rolling",
        "",
        f"Made {prov['date_utc']} with {made_with(prov)}. Reproduce with `{command}`"
        + (" (this is a `--quick` smoke run: short horizons, few rows)." if quick else "."),
        "",
        f"Scene `rolling_disk` (`models/rolling_disk/`): a uniform coin, m = {p['mass']:g} kg, R = {p['R'] * 1e3:g} mm, "
        f"half-thickness h = {p['h'] * 1e3:g} mm, rolling without slip on its lower rim edge on the plane z = 0, "
        f"g = {p['g']:g} m/s². Step {scene.dt:g} s for every engine ("
        + ", ".join(f"{display(e)} `{scene.integrators[e]}`" for e in IDEAL_ENGINES if e in scene.integrators)
        + f", {SOFT} as its MJCF says), samples every "
        f"{scene.save_every:g} s. Judged against the {REF} solver with DOP853 at rtol = atol = 1e-12.",
        "",
        "Measures: **energy** max |E − E0| over the energy scale (rolling without slip does no work); **slip** the "
        "largest horizontal speed of the disk's material point at the contact point (m/s); **penetration** the "
        "largest depth of the contact point below the floor (m); **position** the largest centre-of-mass error over "
        "the length scale; **orientation** the largest geodesic angle error (rad); **force** the largest error of "
        "the contact force over the force scale (t > 0); **lean** max |θ − θ0| (rad; the steady circle keeps it 0).",
        "",
        "## Every case on every engine",
        "",
    ]
    from harness.studies.rolling.run import cases

    docs = {c.name: c for c in cases(scene, quick)}
    for case in dict.fromkeys(r["case"] for r in result.engines):
        c = docs[case]
        lines += [f"### {case} ({c.t_end:g} s)", "", c.doc + ".", "",
                  "| engine | status | energy | slip (m/s) | penetration (m) | position | orientation (rad) | force | lean (rad) | wall (s) |",
                  "|---|---|---|---|---|---|---|---|---|---|"]
        for r in (r for r in result.engines if r["case"] == case):
            lines.append(f"| {r['engine']} | {r['status']} | {_e(r.get('energy'))} | {_e(r.get('slip'))} | "
                         f"{_e(r.get('penetration'))} | {_e(r.get('position'))} | {_e(r.get('orientation'))} | "
                         f"{_e(r.get('force'))} | {_e(r.get('lean'))} | {r['wall_s']:.2f} |")
        lines.append("")
    best = best_setting(result)
    lines += [
        f"## {SOFT}'s contact settings",
        "",
        f"{SOFT} has no rolling constraint: the coin is a `cylinder` geom on a `plane` with frictional soft contact. "
        f"Each row starts from {SOFT}'s own defaults (Euler, 2 ms, pyramidal cone, impratio 1, noslip 0, condim 3, "
        "friction 1, solref 0.02 1, solimp 0.9 0.95 0.001) and changes what it says; the step is the scene's unless the "
        "row says otherwise. Cases: the steady circle (S) and the free transient (T), 1 s each.",
        "",
        "| # | setting | S slip (m/s) | S penetration (m) | S energy | S position | S orientation | S lean | S force | "
        "T slip | T penetration | T energy | T position | T orientation |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for i, r in enumerate(result.settings, 1):
        a, b = r.get("steady_circle", {}), r.get("transient", {})
        mark = " **(best)**" if r is best else ""
        lines.append(f"| {i} | {r['setting']}{mark} | {_e(a.get('slip'))} | {_e(a.get('penetration'))} | {_e(a.get('energy'))} | "
                     f"{_e(a.get('position'))} | {_e(a.get('orientation'))} | {_e(a.get('lean'))} | {_e(a.get('force'))} | "
                     f"{_e(b.get('slip'))} | {_e(b.get('penetration'))} | {_e(b.get('energy'))} | {_e(b.get('position'))} | "
                     f"{_e(b.get('orientation'))} |")
    lines += [""] + class_lines(result)
    lines += [
        "",
        f"What matters, in order. (1) The contact stiffness `solref`. {SOFT}'s default time constant, 0.02 s, lets the "
        "7.5 g coin sink 0.55–0.65 mm into the floor (4–5 % of R); the coin then rolls on a smaller, shifting radius, "
        "the material point at the ideal contact point slips at about 1 cm/s (of the order of ω × depth) and 11–17 % "
        f"of the energy is gone after 1 s. A time constant of 2 steps (the smallest {SOFT} takes without clamping it) "
        "cuts the penetration by three orders of magnitude and slip, energy loss and orbit error by 40–65 times; "
        "`solimp` 0.99 0.999 (impedance near 1) gains another factor 3. (2) The integrator. RK4 against "
        "implicitfast at the same step and stiff contact: the orbit error of implicitfast (first order) is 15–17 "
        "times larger (with the soft default contact the contact error dominates and the integrators are alike). "
        "(3) The friction cone. Elliptic with impratio 100 takes another 25 % off slip and energy loss; noslip "
        "iterations halve the energy loss of the soft default contact but change nothing once the contact is "
        "stiff: the remaining slip is the step's, not the friction solver's. (4) condim must stay 3: torsional "
        "friction (condim 4 or 6) resists the spin about the contact normal that a turning disk needs, and the "
        "steady circle becomes a straight fall (position error ≈ 3 over the length scale). A friction coefficient "
        "of 10 with the pyramidal cone breaks the contact: the coin sinks through the floor. Once everything else is "
        "set, the step decides: slip, energy loss and orbit error fall in proportion to it, the penetration with "
        "its square (last two rows, best settings with solref at 2 steps). The scene's MJCF holds the best row at "
        "the scene's step (it repeats it as 'scene MJCF as written').",
        "",
        "## Stability of straight rolling: Ex. 5.3.3 against the correct threshold",
        "",
        f"A thick disk rolls straight on one rim edge at the balance tilt θ* = atan(R/h) = {th['balance_tilt']:.4f} rad "
        "(the centre right above the contact point). Linearising the correct Newton–Euler equations about it "
        "(`references/rolling_disk.py`) gives stability iff Ω² > m g l D / (C (C + mR²)(C + m l²)), "
        "l = √(R² + h²), D = A C + A m R² + C m h² (A, C the transverse and axial moments about the centre), v = R Ω. "
        "For a thin disk Ω_c² = m g R A/(C (C + mR²)); uniform (A = mR²/4, C = mR²/2): v_c² = g R/3.",
        "",
        f"* correct, this coin (h = {p['h'] * 1e3:g} mm): **v_c = {th['correct']:.4f} m/s**",
        f"* correct, thin disk (h = 0): v_c = √(gR/3) = {th['thin']:.4f} m/s",
        f"* printed (Ex. 5.3.3): v > √(gR)/3 = {th['printed']:.4f} m/s — wrong: its heading equation φ̈ = 6(v/R)ξ̇ "
        "comes from substituting the rolling constraint into T (Ex. 5.2.3); the correct one is φ̈ = 2(v/R)ξ̇.",
        "",
        f"Runs: straight rolling from θ* − {th['delta']:g} rad, {th['t_end']:g} s; 'falls' when the lean deviation "
        f"exceeds 0.1 rad or the disk lies flat. Predicted: from the linearisation (ω² of the lean).",
        "",
    ]
    lines += threshold_lines(result)
    for path in pngs:
        lines += [f"![{path.stem}]({path.name})", ""]
    lines += [
        "## Textbook errata shown here",
        "",
        "* Ex. 4.7.2 prints `v = 4 g r² cos β / ((6r + R cos β) sin β)`; the right side is a speed squared. Its moment "
        "line uses r as the lever arm of the contact force about the centre; it is R. Verified: the steady spin of "
        f"`harness.references.rolling_disk.steady_spin` keeps the lean constant to {LEAN_HELD:g} rad in the "
        f"{_lean_held(result)} runs, and reduces to the printed expression (as v²) for h = 0.",
        "* Ex. 5.2.3 substitutes the nonholonomic rolling constraint into T before applying Lagrange's equations "
        "(Ex. 5.2.1 warns against this): its φ and ψ equations (and the 'conserved' ∂T/∂φ̇, ∂T/∂ψ̇) are wrong; the θ "
        "equation happens to be right.",
        f"* Ex. 5.3.3: v > √(gR)/3 ({th['printed']:.3f} m/s for R = 14 mm) is wrong; the correct threshold is "
        f"√(gR/3) = {th['thin']:.3f} m/s for a thin disk ({th['correct']:.4f} m/s for this 2 mm-thick coin).",
        "",
    ]
    return "\n".join(lines)



def _lean_held(result) -> str:
    """The ideal engines whose steady-circle run kept its lean within ``LEAN_HELD``, as the
    report writes them ("in-house and Pinocchio"); "no ideal engine's" when none did."""
    held = [display(r["engine"]) for r in result.engines
            if r["case"] == "steady_circle" and r["engine"] in IDEAL_ENGINES and r.get("lean", math.inf) <= LEAN_HELD]
    if not held:
        return "no ideal engine's"
    return held[0] if len(held) == 1 else ", ".join(held[:-1]) + " and " + held[-1]


def class_lines(result) -> list[str]:
    """Each settings row's steady-circle position error in the judging vocabulary
    (``harness.studies.rolling.run.setting_models``): its class and why."""
    from harness.studies.rolling.run import setting_models

    models = setting_models(result)
    if not models:
        return []
    ideal = next(iter(models.values()))["ideal"]
    lines = ["Each row's steady-circle position error (S position) judged as `harness validate` judges a check "
             "(`harness.judging.error_model`): where a row has levels (the best settings at the scene's step and at "
             "finer steps, solref 2 steps each) by its error model against the step (order, floor, class); every "
             "other RK4 row at the scene's step has one step only, so no order: its error is set against the ideal "
             f"engines' at the same step ({_e(ideal)}, {', '.join(display(e) for e in IDEAL_ENGINES)}: they converge at "
             "their order, so their error is the step's share), and more than 10× it is a **model difference**: the soft "
             f"contact ({SOFT} has no rolling constraint; the scene declares it: `[model_differences.{SETTINGS_ENGINE}]`). "
             "First-order "
             "integrators and other steps are not judged (their step error is not the ideal engines').", "",
             "| # | setting | S position | class | why |", "|---|---|---|---|---|"]
    for i, r in enumerate(result.settings, 1):
        m = models.get(r["setting"])
        if m is None:
            continue
        cls = m["class"] + (f" ({m['order']:.2f})" if math.isfinite(m["order"]) else "")
        if math.isfinite(m["floor"]) and m["floor"] > 0:
            cls += f", floor {m['floor']:.1e}"
        lines.append(f"| {i} | {r['setting']} | {_e(r.get('steady_circle', {}).get('position'))} | {cls} | {m['reason']} |")
    return lines


def threshold_lines(result) -> list[str]:
    """The threshold table (per speed and engine: falls or rolls on, with the largest lean
    deviation in rad; "not run" for an engine whose run was "unsupported") and whether every
    engine that ran agrees with the correct threshold."""
    th = result.thresholds
    engines = list(dict.fromkeys(r["engine"] for r in result.threshold))
    lines = ["| speed (m/s) | v / v_c | printed says | correct says | "
             + " | ".join(f"{e} (max lean dev, rad)" for e in engines) + " |",
             "|---|---|---|---|" + "---|" * len(engines)]
    for v in dict.fromkeys(r["speed"] for r in result.threshold):
        rows = [r for r in result.threshold if r["speed"] == v]
        cells = " | ".join("not run" if r["fell"] is None else f"{'falls' if r['fell'] else 'rolls on'} ({r['max_lean']:.2g})"
                           for r in rows)
        lines.append(f"| {v:.3f} | {v / th['correct']:.3f} | {'stable' if rows[0]['printed_stable'] else 'unstable'} | "
                     f"{'stable' if rows[0]['predicted_stable'] else 'unstable'} | {cells} |")
    ran = [r for r in result.threshold if r["fell"] is not None]  # "not run": the engine does not model the scene
    agree = threshold_agrees(result.threshold)
    between = [r for r in ran if r["printed_stable"] and not r["predicted_stable"]]
    lines += [
        "",
        f"Every engine agrees with the correct threshold on every speed: **{agree}**. "
        + (f"Between the printed and the correct threshold ({len(between)} runs) the printed one predicts stable "
           f"rolling; {'every engine shows the disk falling' if all(r['fell'] for r in between) else 'not every engine shows a fall'}."
           if between else ""),
        "",
    ]
    return lines

def plots(result, out: Path) -> list[Path]:
    """Write the PNG figures of the study into ``out`` as one set; returns their paths."""
    return atomic.write_set(Path(out), plot_files(result))


def plot_files(result) -> dict[str, bytes]:
    """The PNG figures of the study: file name -> PNG bytes, in the report's order."""
    import numpy as np

    from harness.io.figures import new_figure, png_bytes

    files: dict[str, bytes] = {}
    # 1. settings: position error against slip
    fig = new_figure(8, 5.5)
    ax = fig.subplots()
    for i, r in enumerate(result.settings):
        a = r.get("steady_circle", {})
        if a.get("position") is None or a.get("slip") is None:
            continue
        ax.loglog(a["slip"], a["position"], "o")
        ax.annotate(str(i + 1), (a["slip"], a["position"]), fontsize=8, xytext=(3, 3), textcoords="offset points")
    ax.set_xlabel("max slip speed at the contact (m/s)")
    ax.set_ylabel("max position error / length scale")
    ax.set_title(f"{SOFT} contact settings, steady circle (numbers: rows of the table)")
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    files["rolling_disk_settings.png"] = png_bytes(fig, dpi=110)
    # 2. lean over time, steady circle and transient
    fig = new_figure(11, 4.2)
    axes = fig.subplots(1, 2)
    for ax, case in zip(axes, ("steady_circle", "transient")):
        for key, (t, th) in result.series.items():
            if key[0] == case and len(t):
                ax.plot(t, th, label=key[1], lw=1.2)
        ax.set_title(case)
        ax.set_xlabel("t (s)")
        ax.set_ylabel("θ: axis from vertical (rad)")
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
    fig.tight_layout()
    files["rolling_disk_lean.png"] = png_bytes(fig, dpi=110)
    # 3. threshold: max lean deviation vs speed
    th = result.thresholds
    fig = new_figure(11, 4.2)
    axes = fig.subplots(1, 2)
    ax = axes[0]
    for engine in dict.fromkeys(r["engine"] for r in result.threshold):
        rows = [r for r in result.threshold if r["engine"] == engine]
        ax.semilogy([r["speed"] for r in rows], [max(r["max_lean"], 1e-6) for r in rows], "o-", label=engine)
    ax.axvline(th["printed"], color="r", ls="--", label=f"printed √(gR)/3 = {th['printed']:.3f}")
    ax.axvline(th["correct"], color="g", ls="-", label=f"correct v_c = {th['correct']:.4f}")
    ax.axhline(0.1, color="k", lw=0.6, ls=":")
    ax.set_xlabel("rolling speed (m/s)")
    ax.set_ylabel(f"max |θ − θ*| in {th['t_end']:g} s (rad)")
    ax.set_title("straight rolling: does the coin fall?")
    ax.legend(fontsize=7)
    ax = axes[1]
    speeds = sorted(dict.fromkeys(r["speed"] for r in result.threshold))
    pick = [v for v in speeds if v < th["correct"]][-1:] + [v for v in speeds if v > th["correct"]][:1]
    for key, (t, dev) in result.series.items():
        if key[0] == "threshold" and key[2] in pick and len(t):
            ax.semilogy(t, np.maximum(dev, 1e-7), label=f"{key[1]}, v = {key[2]:.2f}")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("|θ − θ*| (rad)")
    ax.set_title("just below and just above v_c")
    ax.legend(fontsize=7)
    fig.tight_layout()
    files["rolling_disk_threshold.png"] = png_bytes(fig, dpi=110)
    return files


def as_json(result) -> dict:
    from harness.studies.rolling.run import setting_models

    return {"parameters": result.scene.params, "dt": result.scene.dt, "engines": result.engines,
            "settings": result.settings, "setting_classes": setting_models(result), "thresholds": result.thresholds,
            "threshold_runs": result.threshold}
