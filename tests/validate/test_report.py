"""The validation report: the scene x engine matrix first (verdict, worst margin, the check that
sets it), units in their own column, overrides and regression bounds marked, the PNG heatmap, and
CSV/JSON/JUnit keeping every column and field they had."""

import json
import math
import xml.etree.ElementTree as ET

import pandas as pd
import pytest

from harness.validate.report import (
    CSV_COLUMNS,
    markdown,
    matrix,
    worst_check,
    write_reports,
)
from harness.validate.run import CheckResult, RunRecord, SceneValidation

PNG = b"\x89PNG\r\n\x1a\n"
PROV = {"date_utc": "2026-01-01 00:00:00 UTC", "harness": "test", "mujoco": "m", "pinocchio": "p", "numpy": "n",
        "scipy": "s", "python": "3", "machine": "x"}
OLD_CSV_COLUMNS = ["scene", "engine", "check", "value", "tolerance", "unit", "passed", "detail"]


def check(scene, engine, name, value, tol, unit="rel", detail="", regression=False):
    return CheckResult(scene, engine, name, value, tol, unit, value <= tol, detail, regression)


def results():
    """Two scenes: one passing (a regression bound on mujoco), one failing on pinocchio."""
    a = SceneValidation("alpha", {"m": 1.0, "F0": 2.0}, overrides={"F0": {"value": 2.0, "default": 0.0}})
    a.runs = [RunRecord("alpha", "reference", "DOP853", 0.01, 1e-12, 1.0, "ok", "", 0.1, 10.0),
              RunRecord("alpha", "mujoco", "RK4", 0.001, None, 1.0, "ok", "", 0.1, 1000.0)]
    a.checks = [check("alpha", "reference", "energy_drift", 1e-13, 1e-10),
                check("alpha", "mujoco", "model.bar.mass", 0.0, 1e-6, detail="alpha.xml as written vs scene.toml defaults: ok"),
                check("alpha", "mujoco", "energy_drift", 5e-4, 2e-3, regression=True),
                check("alpha", "mujoco", "trajectory.orientation", 3e-3, 1.5e-2, unit="rad", regression=True),
                check("alpha", "mujoco", "constraint.position", 1e-12, 1e-9, unit="m")]
    b = SceneValidation("beta", {"m": 1.0})
    b.checks = [check("beta", "reference", "energy_drift", 1e-13, 1e-10),
                check("beta", "pinocchio", "model.bar2.inertia", 0.9994, 1e-6, detail="beta.urdf as written vs ..."),
                check("beta", "pinocchio", "trajectory.position", 5e-7, 1e-6),
                CheckResult("beta", "pinocchio", "run", float("nan"), 0.0, "", False, "crashed")]
    return [a, b]


def test_worst_check_prefers_failures_and_missing_values():
    a, b = results()
    assert worst_check([c for c in a.checks if c.engine == "mujoco"]).check == "energy_drift"  # 0.25 > 0.2 > 1e-3 > 0
    assert worst_check([c for c in b.checks if c.engine == "pinocchio"]).check == "run"  # NaN counts as the worst


def test_matrix_cells():
    engines, cells = matrix(results())
    assert engines == ["reference", "mujoco", "pinocchio"]
    cell = cells[("alpha", "mujoco")]
    assert cell["passed"] and cell["regression"] and cell["margin"] == pytest.approx(0.25)
    assert cell["worst"].check == "energy_drift"
    assert not cells[("beta", "pinocchio")]["passed"]
    assert ("beta", "mujoco") not in cells


def test_markdown_opens_with_the_matrix():
    md = markdown(results(), PROV)
    head, details = md.split("\n## ", 1)
    table = [ln for ln in head.splitlines() if ln.startswith("| ")]
    assert table[0] == "| scene | reference | mujoco | pinocchio |"
    alpha = next(ln for ln in table if ln.startswith("| [alpha]"))
    beta = next(ln for ln in table if ln.startswith("| [beta]"))
    assert "PASS 0.25" in alpha and "†" in alpha and alpha.endswith("| — |")
    assert "**FAIL** — `run`" in beta
    assert "(#alpha--pass)" in alpha and "(#beta--fail)" in beta
    assert details.startswith("alpha — PASS")


def test_units_have_their_own_column_and_marks():
    md = markdown(results(), PROV)
    rows = [ln for ln in md.splitlines() if ln.startswith(("| mujoco | ", "| pinocchio | ")) and ln.count(" | ") == 8]
    assert len(rows) == 6  # mujoco: 3 (the agreeing model check summarised), pinocchio: 3
    for ln in rows:  # check rows: engine check value tolerance unit margin result bound note
        cells = [c.strip() for c in ln.strip("|").split("|")]
        assert len(cells) == 9, ln
        assert cells[2] == "—" or float(cells[2]) >= 0  # the value column holds numbers only
        assert float(cells[3]) >= 0
        assert cells[4] in ("rel", "rad", "m", "")
    orientation = next(ln for ln in rows if "trajectory.orientation" in ln)
    assert "| 3.00e-03 | 1.50e-02 | rad | 0.2 | ok | regression † |" in orientation
    run_header = next(ln for ln in md.splitlines() if ln.startswith("| run |"))
    assert "| dt (s) | rtol |" in run_header
    ref_run = next(ln for ln in md.splitlines() if ln.startswith("| reference | DOP853"))
    assert "| adaptive | 1e-12 |" in ref_run
    assert "**F0 = 2.0** (default 0.0)" in md and "m = 1.0" in md
    # an agreeing model file is one line, a disagreeing quantity a row of the table
    assert "- mujoco (alpha.xml as written): all 1 quantities of 1 body agree" in md
    assert "| pinocchio | model.bar2.inertia | 9.99e-01 | 1.00e-06 | rel |" in md
    assert not any(ln.startswith("| mujoco | model.bar.mass") for ln in md.splitlines())


def test_files_keep_old_columns_and_fields(tmp_path):
    paths = write_reports(results(), PROV, tmp_path)
    assert [p.name for p in paths] == ["validation.md", "validation.csv", "validation.json", "validation.junit.xml",
                                       "validation_matrix.png"]
    frame = pd.read_csv(tmp_path / "validation.csv")
    assert list(frame.columns)[:len(OLD_CSV_COLUMNS)] == OLD_CSV_COLUMNS and list(frame.columns) == CSV_COLUMNS
    row = frame[(frame.scene == "alpha") & (frame.check == "trajectory.orientation")].iloc[0]
    assert bool(row.regression_only) and row.margin == pytest.approx(0.2)
    data = json.loads((tmp_path / "validation.json").read_text())
    assert not data["passed"] and set(data["provenance"]) == set(PROV)
    alpha = data["scenes"][0]
    assert {"scene", "passed", "parameters", "tolerance_changes", "runs", "checks", "cross_engine"} <= set(alpha)
    assert alpha["parameter_overrides"] == {"F0": {"value": 2.0, "default": 0.0}}
    assert set(OLD_CSV_COLUMNS) | {"regression_only", "margin"} <= set(alpha["checks"][0])
    beta_run = next(c for c in data["scenes"][1]["checks"] if c["check"] == "run")
    assert math.isnan(beta_run["margin"])
    suites = ET.parse(tmp_path / "validation.junit.xml").getroot().findall("testsuite")
    failed = [(c.get("classname"), c.get("name"), c.find("failure").get("type"))
              for s in suites for c in s.findall("testcase") if c.find("failure") is not None]
    assert failed == [("beta.pinocchio", "model.bar2.inertia", "model"), ("beta.pinocchio", "run", "run")]
    assert (tmp_path / "validation_matrix.png").read_bytes().startswith(PNG)
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporary or staging files left


def test_engine_warnings_get_their_own_section_when_present():
    a, b = results()
    a.runs[1] = RunRecord("alpha", "mujoco", "RK4", 0.001, None, 1.0, "ok", "", 0.1, 1000.0,
                          warnings={"count": 3, "first": "Nan, Inf or huge value in QACC at DOF 1. The simulation is unstable."})
    md = markdown([a, b], PROV)
    alpha = md.split("## alpha")[1].split("## beta")[0]
    assert "Engine warnings" in alpha
    assert "- mujoco (RK4): 3 warnings; first: Nan, Inf or huge value in QACC at DOF 1" in alpha
    assert "Engine warnings" not in md.split("## beta")[1]  # none reported: no section
    assert "Engine warnings" not in markdown(results(), PROV)


def test_validate_carries_the_engine_warnings_into_the_report(monkeypatch):
    """End to end through the worker: MuJoCo's ``stats["warnings"]`` reach the run record and the
    report."""
    from dataclasses import replace

    from harness.engines.mujoco.engine import MujocoEngine
    from harness.model.scene import load_scene
    from harness.validate.run import validate

    real = MujocoEngine.simulate

    def warned(self, scene, settings):
        traj = real(self, scene, settings)
        return replace(traj, stats={**traj.stats, "warnings": {"count": 2, "first": "Too many contacts | (test)"}})

    monkeypatch.setattr(MujocoEngine, "simulate", warned)
    (res,) = validate([replace(load_scene("torque_free"), t_end=0.5)], ["mujoco"], jobs=1)
    (record,) = [r for r in res.runs if r.engine == "mujoco"]
    assert record.warnings == {"count": 2, "first": "Too many contacts | (test)"}
    assert [r.warnings for r in res.runs if r.engine == "reference"] == [{}]  # the in-house engine reports none
    md = markdown([res], PROV)
    assert "- mujoco (RK4): 2 warnings; first: Too many contacts \\| (test)" in md


def test_an_engine_the_scene_excludes_is_reported_not_run_with_why(tmp_path):
    """rolling_disk excludes Drake ([not_run]): no Drake run or check, the matrix cell says "not
    run", the scene's section and the JSON say why, and JUnit has one skipped case."""
    import json

    from dataclasses import replace

    from harness.io.provenance import provenance
    from harness.model.scene import load_scene
    from harness.validate.report import write_reports
    from harness.validate.run import validate

    scene = load_scene("rolling_disk")
    short = replace(scene, t_end=0.05)
    (res,) = validate([short], ["drake", "pinocchio"], jobs=1)
    assert not [c for c in res.checks if c.engine == "drake"] and res.not_run == {"drake": scene.not_run["drake"]}
    write_reports([res], provenance(), tmp_path)
    md = (tmp_path / "validation.md").read_text()
    assert "| not run [" in md and "Not run on drake" in md and scene.not_run["drake"] in md
    assert json.loads((tmp_path / "validation.json").read_text())["scenes"][0]["not_run"]["drake"] == scene.not_run["drake"]
    junit = (tmp_path / "validation.junit.xml").read_text()
    assert 'skipped="1"' in junit and '<testcase classname="rolling_disk.drake" name="not_run">' in junit
