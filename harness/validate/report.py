"""Validation report: ``validation.md`` (read by a person), ``validation.csv`` (one row per
check), ``validation.json`` (everything, with provenance) and ``validation.junit.xml`` (one
test case per scene x engine x check, for CI systems). All written atomically."""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import pandas as pd

from harness.io import atomic
from harness.validate.run import SceneValidation, as_dict


def checks_frame(results: list[SceneValidation]) -> pd.DataFrame:
    rows = [c.__dict__ for v in results for c in v.checks]
    return pd.DataFrame(rows, columns=["scene", "engine", "check", "value", "tolerance", "unit", "passed", "detail"])


def _fmt(x: float) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "—"
    return f"{x:.2e}"


def markdown(results: list[SceneValidation], prov: dict) -> str:
    """The human-readable report."""
    total = sum(len(v.checks) for v in results)
    failed = sum(not c.passed for v in results for c in v.checks)
    lines = [
        "# Validation report",
        "",
        f"Made {prov['date_utc']} with MuJoCo {prov['mujoco']}, Pinocchio {prov['pinocchio']}, "
        f"NumPy {prov['numpy']}, SciPy {prov['scipy']}, Python {prov['python']} on {prov['machine']}.",
        "",
        f"**{total - failed} of {total} checks hold; {failed} fail.** Reproduce with `harness validate`.",
        "",
        "Reference for trajectories: the in-house solver with SciPy DOP853 at rtol = atol = 1e-12 "
        "(row `reference`, itself checked against the exact solution). Relative drifts are over the "
        "scene's energy scale (max kinetic energy + range of potential energy) or momentum scale.",
        "",
    ]
    for v in results:
        lines += [f"## {v.scene} — {'PASS' if v.passed else 'FAIL'}", ""]
        params = ", ".join(f"{k} = {val}" for k, val in v.parameters.items())
        lines += [f"Parameters: {params}", ""]
        if v.tolerance_changes:
            lines += ["Tolerances changed by the tolerance file: " + "; ".join(v.tolerance_changes), ""]
        lines += ["| run | integrator | dt (s) | status | steps | wall (s) | settings |", "|---|---|---|---|---|---|---|"]
        for r in v.runs:
            step = f"rtol {r.rtol:g}" if r.rtol else f"{r.dt:g}"
            steps = "—" if r.steps != r.steps else f"{r.steps:.0f}"
            lines.append(f"| {r.engine} | {r.integrator} | {step} | {r.status}{': ' + r.message if r.message else ''} | "
                         f"{steps} | {r.wall_s:.2f} | {r.settings} |")
        lines += ["", "| engine | check | value | tolerance | unit | result | note |", "|---|---|---|---|---|---|---|"]
        for c in v.checks:
            lines.append(f"| {c.engine} | {c.check} | {_fmt(c.value)} | {_fmt(c.tolerance)} | {c.unit} | "
                         f"{'ok' if c.passed else '**FAIL**'} | {c.detail} |")
        if v.cross:
            lines += ["", "Engine against engine (max over bodies and samples):", "",
                      "| pair | position (m) | orientation (rad) | velocity (m/s) | angular velocity (rad/s) |", "|---|---|---|---|---|"]
            for pair, e in v.cross.items():
                lines.append(f"| {pair} | {_fmt(e.get('position_max'))} | {_fmt(e.get('orientation_max'))} | "
                             f"{_fmt(e.get('velocity_max'))} | {_fmt(e.get('angular_velocity_max'))} |")
        lines.append("")
    return "\n".join(lines)


def write_reports(results: list[SceneValidation], prov: dict, out_dir: Path) -> list[Path]:
    """Write the three report files into ``out_dir``; returns their paths."""
    out_dir = Path(out_dir)
    md = markdown(results, prov)
    csv = checks_frame(results).to_csv(index=False)
    payload = {
        "provenance": prov,
        "passed": all(v.passed for v in results),
        "scenes": [as_dict(v) for v in results],
    }
    js = json.dumps(payload, indent=2, default=_json_default, allow_nan=True)
    xml = junit_xml(results, prov)
    paths = [out_dir / "validation.md", out_dir / "validation.csv", out_dir / "validation.json",
             out_dir / "validation.junit.xml"]
    for path, text in zip(paths, (md, csv, js, xml)):
        atomic.write_text(path, text)
    return paths


def junit_xml(results: list[SceneValidation], prov: dict) -> str:
    """JUnit XML: a test suite per scene, a test case per engine x check (``classname`` =
    ``scene.engine``), a failure element carrying value, tolerance and detail."""
    suites = ET.Element("testsuites", name="harness validate")
    for v in results:
        failures = sum(not c.passed for c in v.checks)
        wall = sum(r.wall_s for r in v.runs)
        suite = ET.SubElement(suites, "testsuite", name=v.scene, tests=str(len(v.checks)),
                              failures=str(failures), errors="0", time=f"{wall:.3f}", timestamp=prov["date_utc"])
        props = ET.SubElement(suite, "properties")
        for key in ("mujoco", "pinocchio", "numpy", "scipy", "python", "machine"):
            ET.SubElement(props, "property", name=key, value=str(prov[key]))
        for c in v.checks:
            case = ET.SubElement(suite, "testcase", classname=f"{v.scene}.{c.engine}", name=c.check)
            if not c.passed:
                failure = ET.SubElement(case, "failure", message=f"{_fmt(c.value)} > {_fmt(c.tolerance)} {c.unit}".strip(),
                                        type="tolerance" if c.check != "run" else "run")
                failure.text = c.detail
    ET.indent(suites)
    return '<?xml version="1.0" encoding="utf-8"?>\n' + ET.tostring(suites, encoding="unicode") + "\n"


def _json_default(o):
    try:
        import numpy as np

        if isinstance(o, np.generic):
            return o.item()
        if isinstance(o, np.ndarray):
            return o.tolist()
    except ImportError:  # pragma: no cover
        pass
    return str(o)
