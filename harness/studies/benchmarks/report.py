"""What ``harness benchmark`` writes: ``benchmarks.md`` (one table per problem: the published
figure, each engine's error and agreement in digits, its class, and the time to the required
accuracy against the baseline engine's), ``benchmarks.csv`` (one row per problem and engine) and,
for a problem published as a linearisation, ``benchmarks_<scene>_eigenvalues.png`` (the
eigenvalues against speed)."""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

from harness.engines import display, made_with
from harness.io import atomic
from harness.studies.benchmarks.run import ProblemResult
from harness.studies.workprecision.run import BASELINE

FIELDS = ("problem", "scene", "engine", "integrator", "check", "exact", "unit", "digits", "classification", "passed",
          "detail", "required", "time_s", "curve", "ratio_to_baseline", "step_wall_s", "step_ratio_to_baseline",
          "published_digits")


def _g(x, fmt: str = ".2g") -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "—"
    return format(x, fmt)


def _eigen_name(p: ProblemResult) -> str:
    return f"benchmarks_{p.scene}_eigenvalues.png"


def markdown(results: list[ProblemResult], prov: dict, command: str | None = None) -> str:
    """The report; ``command`` is the "Reproduce with" command (default: this process's)."""
    if command is None:
        from harness.io.provenance import command_line

        command = command_line()
    base = display(BASELINE)
    lines = [
        "# Published benchmarks: the IFToMM library and others, against every engine",
        "",
        f"Made {prov['date_utc']} with {made_with(prov)}. Reproduce with `{command}`.",
        "",
        "Per problem and engine: **error** the scene's `exact` check at the scene's step with the engine's default "
        "integrator (against the closed form or the verified reference of `references/<scene>.py`, in its unit), or, "
        "where the published figures are a linearisation, the largest relative error of the engine's own "
        "linearised coefficients against the published ones (`harness.engines.linearization`), "
        "**digits** the agreement, −log10(error / scale) (scale: the motion's length for m, 1 for rad), **class** "
        "how that error converges with the step (validate's error model; the dominant check's where the scene has no "
        "`exact` check), **time** the run time (s, median of "
        "repeated runs on this machine) of the engine's fastest work-precision curve to reach the problem's required "
        f"accuracy (the largest state error over the samples, relative to the scene's scales), and its ratio to "
        f"{base}'s fastest (`harness workprecision` on the same scenes, in the same run; a point of that sweep "
        "may take at most 60 s, so a problem whose every run is longer, A02, is reached there only by the fast "
        f"engines), and **run at the step** the wall time (s) of validate's one run at the scene's step, the "
        f"one the error column judges, with its ratio to {base}'s (the same validate run: two at a time on "
        "this machine).",
        "",
    ]
    for p in results:
        lines += [f"## {p.problem}: {p.title} (`{p.scene}`)", "",
                  f"Published: {p.published}."
                  + (f" The reference reproduces the published figure to {p.published_digits:.1f} digits."
                     if p.published_digits is not None else ""),
                  f"Required accuracy: {p.required:g} (state error relative to the scene's scales).", "",
                  "| engine | integrator | error at the scene's step | digits | class | time to required (s) | fastest curve "
                  f"| vs {base} | run at the step (s) | vs {base} |",
                  "|---|---|---|---|---|---|---|---|---|---|"]
        for r in p.engines:
            verdict = r.classification + (f" (`{r.check}`)" if r.check and r.check != "exact" else "") \
                + ("" if r.passed else " **✗**")
            error = "; ".join(x for x in ((f"{_g(r.exact, '.2e')} {r.unit}" if math.isfinite(r.exact) else ""), r.detail) if x)
            lines.append(f"| {display(r.engine)} | `{r.integrator}` | {error} | {_g(r.digits, '.1f')} "
                         f"| {verdict} | {_g(r.time_s, '.3g')} | {r.curve or 'not reached'} | {_g(r.ratio, '.2f')} "
                         f"| {_g(r.step_wall_s, '.3g')} | {_g(r.step_ratio, '.2f')} |")
        for engine, why in p.not_run.items():
            lines.append(f"| {display(engine)} | — | not run: {why} | | | | | | | |")
        lines.append("")
        if p.eigenvalues:
            lines += [f"Eigenvalues against speed, the published and each engine's own linearisation: "
                      f"`{_eigen_name(p)}`.", "", f"![eigenvalues]({_eigen_name(p)})", ""]
    return "\n".join(lines)


def eigenvalue_png(p: ProblemResult) -> bytes:
    """The eigenvalues' real and imaginary parts (1/s) against speed (m/s): the published ones as
    lines, each engine's own linearisation as markers."""
    import numpy as np

    from harness.io.figures import new_figure, png_bytes

    v = np.asarray(p.eigenvalues["speeds"])
    fig = new_figure(11, 4.6)
    axes = fig.subplots(1, 2)
    fine, published = np.asarray(p.eigenvalues["fine_speeds"]), np.asarray(p.eigenvalues["fine_published"])
    markers = iter("o^sdv")
    for ax, part, label in ((axes[0], np.real, "real part (1/s)"), (axes[1], np.imag, "imaginary part (1/s)")):
        for j in range(published.shape[1]):
            ax.plot(fine, part(published[:, j]), "k.", ms=1.5, label="published (Table 2's formulas)" if j == 0 else None)
        ax.axhline(0.0, color="grey", lw=0.6)
        ax.set_xlabel("forward speed v (m/s)")
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    for engine, values in p.eigenvalues.items():
        if engine in ("speeds", "published", "fine_speeds", "fine_published"):
            continue
        values = np.asarray(values)
        m = next(markers, "x")
        for ax, part in ((axes[0], np.real), (axes[1], np.imag)):
            for j in range(values.shape[1]):
                ax.plot(v, part(values[:, j]), m, ms=4, mfc="none", label=f"{display(engine)}'s linearisation" if j == 0 else None)
    axes[0].set_ylim(-10, 10)
    axes[0].legend(fontsize=8)
    fig.suptitle(f"{p.problem}: eigenvalues of upright straight running against speed")
    fig.tight_layout()
    return png_bytes(fig, dpi=110)


def rows(results: list[ProblemResult]) -> list[dict]:
    """One row per problem and engine (``FIELDS``)."""
    out = []
    for p in results:
        for r in p.engines:
            out.append({"problem": p.problem, "scene": p.scene, "engine": r.engine, "integrator": r.integrator,
                        "check": r.check, "exact": r.exact, "unit": r.unit, "digits": r.digits,
                        "classification": r.classification, "passed": r.passed, "detail": r.detail, "required": p.required, "time_s": r.time_s, "curve": r.curve,
                        "ratio_to_baseline": r.ratio, "step_wall_s": r.step_wall_s, "step_ratio_to_baseline": r.step_ratio,
                        "published_digits": p.published_digits})
    return out


def write_reports(results: list[ProblemResult], out: Path, prov: dict, command: str | None = None) -> list[Path]:
    """Write ``benchmarks.md`` and ``benchmarks.csv`` into ``out`` as one set; returns their paths.
    ``InputError`` if ``out`` cannot be written (the old files are then kept)."""
    out = Path(out)
    atomic.check_writable(out)
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=FIELDS, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows(results))
    files: dict[str, str | bytes] = {"benchmarks.md": markdown(results, prov, command), "benchmarks.csv": buf.getvalue()}
    files.update({_eigen_name(p): eigenvalue_png(p) for p in results if p.eigenvalues})
    atomic.write_set(out, files)
    return [out / name for name in files]
