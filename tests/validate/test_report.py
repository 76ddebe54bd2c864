"""The validation report: the scene x engine class matrix first (worst class, the dominant check's
error at the scene's step and its observed order, failing cells marked), the engines against
each other extrapolated to zero step, the error-against-step figure, per-scene check tables with
class, order, floor, resolution, requirement and reason; CSV/JSON/JUnit carrying the same."""

import json
import math
import struct
import xml.etree.ElementTree as ET

import pandas as pd
import pytest

from harness.validate.report import (
    CSV_COLUMNS,
    FILES,
    cell_text,
    convergence_png,
    dominant_check,
    label,
    markdown,
    matrix,
    plotted_check,
    write_reports,
)
from harness.judging.checks import CheckResult
from harness.validate.run import RunRecord, SceneValidation

PNG = b"\x89PNG\r\n\x1a\n"
PROV = {"date_utc": "2026-01-01 00:00:00 UTC", "harness": "test", "mujoco": "m", "pinocchio": "p", "numpy": "n",
        "scipy": "s", "python": "3", "machine": "x"}
OLD_CSV_COLUMNS = ["scene", "engine", "check", "value", "tolerance", "unit", "passed", "detail"]
NAN, INF = float("nan"), float("inf")


def judged(scene, engine, name, value, unit="rel", cls="converges", order=NAN, floor=0.0, resolution=1e-9,
           passed=True, reason="", levels=(), tol=INF, detail=""):
    """A check as ``judge_convergence`` leaves it (levels: (step, value), the scene's first)."""
    return CheckResult(scene, engine, name, value, tol, unit, passed, detail, cls, order, floor, resolution, reason,
                       tuple(levels))


def results():
    """alpha passes: a fourth-order in-house run, Exudyn of order 2 (its orientation dominates),
    MuJoCo with a declared model difference, the reference and Drake error-controlled. beta fails:
    Pinocchio a defect, MuJoCo an undeclared model difference, Exudyn's run crashed, a model file
    that disagrees, a check beyond its requirement; Drake is not run there."""
    a = SceneValidation("alpha", {"m": 1.0, "F0": 2.0}, overrides={"F0": {"value": 2.0, "default": 0.0}})
    a.runs = [RunRecord("alpha", "reference", "DOP853", 0.01, 1e-12, 1.0, "ok", "", 0.1, 10.0),
              RunRecord("alpha", "inhouse", "rk4", 0.001, None, 1.0, "ok", "", 0.1, 1000.0),
              RunRecord("alpha", "mujoco", "RK4", 0.001, None, 1.0, "ok", "", 0.1, 1000.0),
              RunRecord("alpha", "exudyn", "GeneralizedAlpha", 0.001, None, 1.0, "ok", "", 0.1, 1000.0),
              RunRecord("alpha", "drake", "RK5", 0.001, 1e-13, 1.0, "ok", "", 0.1, 4000.0)]
    a.checks = [
        judged("alpha", "reference", "exact", 5e-12, "rad", reason="at the resolution (1.0e-09 rad)",
               levels=[(1e-12, 5e-12), (1e-10, 6e-12)]),
        CheckResult("alpha", "mujoco", "model.bar.mass", 0.0, 1e-6, "rel", True,
                    "alpha.xml as written vs scene.toml defaults: ok"),
        judged("alpha", "inhouse", "trajectory.position", 1.8e-8, order=4.02, reason="order 4.02 (method's 4)",
               levels=[(0.001, 1.8e-8), (0.002, 2.9e-7)]),
        judged("alpha", "mujoco", "trajectory.position", 4.5e-6, cls="model difference (declared)", order=-0.001,
               floor=4.5e-6, reason="soft loop constraints: floor 4.5e-06 of scale within its bound 1e-04",
               levels=[(0.001, 4.5e-6), (0.002, 4.4e-6), (0.0005, 4.5e-6)]),
        judged("alpha", "mujoco", "constraint.position", 1e-17, "m", resolution=1e-10,
               levels=[(0.001, 1e-17), (0.002, 1e-17)]),
        judged("alpha", "exudyn", "trajectory.position", 1.5e-3, order=2.0, levels=[(0.001, 1.5e-3), (0.002, 6e-3)]),
        judged("alpha", "exudyn", "trajectory.orientation", 1.6e-3, "rad", order=2.0,
               levels=[(0.001, 1.6e-3), (0.002, 6.4e-3)]),
        judged("alpha", "exudyn", "closure.velocity", 1.5e-4, "m/s", order=2.0, resolution=1.2e-8,
               levels=[(0.001, 1.5e-4), (0.002, 6e-4)]),
        judged("alpha", "drake", "trajectory.position", 8.7e-11, levels=[(1e-13, 8.7e-11), (1e-11, 6e-9)]),
        judged("alpha", "drake", "exact", 3e-9, "rad", order=0.93, levels=[(1e-13, 3e-9), (1e-11, 2.1e-7)],
               tol=1e-6, reason="order 0.93 in the tolerance"),
    ]
    a.cross = {"inhouse vs exudyn": {"position_max": 3e-3, "orientation_max": 1.6e-3, "velocity_max": 4e-4,
                                     "angular_velocity_max": 0.1},
               "mujoco vs drake": {"position_max": 9e-6, "orientation_max": 6e-5, "velocity_max": 1e-5,
                                   "angular_velocity_max": 1e-3}}
    a.cross_extrapolated = {"inhouse vs exudyn": {"trajectory.position": 0.0, "trajectory.orientation": 2e-12,
                                                  "trajectory.velocity": 0.0, "trajectory.angular_velocity": 0.0},
                            "mujoco vs drake": {"trajectory.position": 4.5e-6, "trajectory.orientation": 6.3e-5,
                                                "trajectory.velocity": 7e-6, "trajectory.angular_velocity": 2.9e-5}}
    a.scales = {"length": 2.0, "velocity": 4.0, "angular_velocity": 10.0}
    b = SceneValidation("beta", {"m": 1.0}, not_run={"drake": "no rolling contact in Drake's plant"},
                        tolerance_changes=["exact <= 1e-06 (added)"])
    b.runs = [RunRecord("beta", "reference", "DOP853", 0.01, 1e-12, 1.0, "ok", "", 0.1, 10.0),
              RunRecord("beta", "pinocchio", "rkmk4", 0.001, None, 1.0, "ok", "", 0.1, 1000.0)]
    b.checks = [
        judged("beta", "reference", "energy_drift", 1e-13, levels=[(1e-12, 1e-13), (1e-10, 1e-13)]),
        CheckResult("beta", "pinocchio", "model.bar2.inertia", 0.9994, 1e-6, "rel", False,
                    "beta.urdf as written vs ..."),
        judged("beta", "pinocchio", "trajectory.position", 2.1e-2, cls="defect", order=0.31, passed=False,
               reason="order 0.31 where the method's is 4", levels=[(0.001, 2.1e-2), (0.002, 2.6e-2)]),
        judged("beta", "pinocchio", "exact", 2e-6, "rad", order=4.0, passed=False, tol=1e-6,
               reason="2.00e-06 rad beyond the requirement 1.00e-06 rad; order 4.00 (method's 4)",
               levels=[(0.001, 2e-6), (0.002, 3.2e-5)]),
        judged("beta", "mujoco", "trajectory.orientation", 3e-4, "rad", cls="model difference", order=0.02,
               floor=2.9e-4, passed=False, reason="a floor of 2.90e-04 rad that does not shrink with the step; "
               "not declared by the scene", levels=[(0.001, 3e-4), (0.002, 3e-4)]),
        judged("beta", "mujoco", "energy_drift", 5e-5, cls="not judged", floor=NAN, passed=False,
               reason="no other level ran to the end: order unknown", levels=[(0.001, 5e-5), (0.002, NAN)]),
        CheckResult("beta", "exudyn", "run", NAN, 0.0, "", False, "crashed: segmentation fault"),
    ]
    return [a, b]


def cells():
    return matrix(results())[1]


def test_labels_and_the_dominant_check():
    a, b = results()
    assert [label(c) for c in b.checks] == ["converges", "model file", "defect", "converges", "model difference",
                                           "not judged", "run failed"]
    assert label(a.checks[1]) == ""  # a passing model check is not judged by convergence
    # Exudyn in alpha: everything converges; the largest error against its resolution dominates
    exudyn = [c for c in a.checks if c.engine == "exudyn"]
    assert dominant_check(exudyn).check == "trajectory.orientation"  # 1.6e6 resolutions > 1.5e6 > 1.2e4
    # MuJoCo in beta: "not judged" outranks an undeclared model difference (both failing)
    assert dominant_check([c for c in b.checks if c.engine == "mujoco"]).check == "energy_drift"
    # Pinocchio in beta: defect > model file > converges beyond its requirement
    assert dominant_check([c for c in b.checks if c.engine == "pinocchio"]).check == "trajectory.position"
    # a failing check outranks any passing one, whatever its class
    mujoco_alpha = [c for c in a.checks if c.engine == "mujoco"]
    assert dominant_check(mujoco_alpha).classification == "model difference (declared)"
    failing = judged("alpha", "mujoco", "exact", 2e-6, "rad", order=4.0, passed=False, tol=1e-6)
    assert dominant_check(mujoco_alpha + [failing]) is failing


def test_matrix_cells():
    engines, found = matrix(results())
    assert engines == ["reference", "inhouse", "mujoco", "exudyn", "drake", "pinocchio"]
    assert {k: (c["label"], c["passed"]) for k, c in found.items()} == {
        ("alpha", "reference"): ("converges", True), ("alpha", "inhouse"): ("converges", True),
        ("alpha", "mujoco"): ("model difference (declared)", True), ("alpha", "exudyn"): ("converges", True),
        ("alpha", "drake"): ("converges", True), ("beta", "reference"): ("converges", True),
        ("beta", "pinocchio"): ("defect", False), ("beta", "mujoco"): ("not judged", False),
        ("beta", "exudyn"): ("run failed", False)}
    assert found[("alpha", "drake")]["adaptive"] and not found[("alpha", "exudyn")]["adaptive"]
    assert found[("beta", "pinocchio")]["failed"] == 3 and found[("beta", "pinocchio")]["count"] == 3


def test_cell_texts():
    found = cells()
    assert cell_text(found[("alpha", "exudyn")]) == "converges p=2.0 · 1.6e-3 rad `orientation`"
    assert cell_text(found[("alpha", "inhouse")]) == "converges p=4.0 · 1.8e-8 rel `position`"
    assert cell_text(found[("alpha", "mujoco")]) == "declared model diff. p=0.0 · 4.5e-6 rel `position`"
    assert cell_text(found[("alpha", "reference")]) == "converges at res. · 5.0e-12 rad `exact`"
    assert cell_text(found[("alpha", "drake")]) == "converges q=0.9 · 3.0e-9 rad `exact`"  # order in the tolerance
    assert cell_text(found[("beta", "pinocchio")]) == "**✗ defect** p=0.3 · 2.1e-2 rel `position`"
    assert cell_text(found[("beta", "mujoco")]) == "**✗ not judged** · 5.0e-5 rel `energy_drift`"
    assert cell_text(found[("beta", "exudyn")]) == "**✗ run failed** · crashed"
    beyond = judged("beta", "inhouse", "exact", 2e-6, "rad", order=4.0, passed=False, tol=1e-6)
    text = cell_text({"check": beyond, "label": "converges", "passed": False, "adaptive": False})
    assert text == "**✗ converges** p=4.0 · 2.0e-6 rad `exact` > req. 1.0e-6"


def test_markdown_opens_with_the_class_matrix_then_engines_then_the_figure():
    md = markdown(results(), PROV)
    head = md.split("\n## ", 1)[0]
    table = [ln for ln in head.splitlines() if ln.startswith("| ")]
    assert table[0] == "| scene | reference | inhouse | mujoco | exudyn | drake | pinocchio |"
    alpha = next(ln for ln in table if ln.startswith("| [alpha]"))
    beta = next(ln for ln in table if ln.startswith("| [beta]"))
    assert alpha.startswith("| [alpha](#alpha--pass) | converges at res.") and "✗" not in alpha
    assert "| converges p=2.0 · 1.6e-3 rad `orientation` |" in alpha and alpha.endswith("| — |")
    assert beta.startswith("| [beta](#beta--fail) **✗** |")
    assert "| **✗ defect** p=0.3 · 2.1e-2 rel `position` |" in beta and "| not run [§](#beta--fail) |" in beta
    assert "Cells: 1 defect, 1 run failed, 1 not judged, 1 declared model diff., 5 converges; 3 failing." in head
    assert "(defect > run failed, model file > not judged > undeclared model diff. > declared" in head
    sections = [ln for ln in md.splitlines() if ln.startswith("## ")]
    assert sections == ["## Engine against engine", "## Error against step", "## alpha — PASS", "## beta — FAIL"]
    assert "![error against step](validation_convergence.png)" in md


def test_engine_against_engine_extrapolated_beside_the_scenes_step():
    md = markdown(results(), PROV)
    part = md.split("## Engine against engine")[1].split("\n## ")[0]
    rows = [ln for ln in part.splitlines() if ln.startswith("| ")]
    assert rows[0].startswith("| scene | pair | position (rel) → 0 | at h | orientation (rad) → 0 | at h |")
    # judged over the reference's scales: 3e-3 m / 2 m, 4e-4 m/s / 4 m/s, 0.1 rad/s / 10 rad/s
    assert rows[1] == ("| [alpha](#alpha--pass) | inhouse vs exudyn | 0 | 1.50e-03 | 2.00e-12 | 1.60e-03 | 0 | "
                       "1.00e-04 | 0 | 1.00e-02 |")
    # what remains once the steps are gone is bold where it is resolved (above 10x the judging resolution)
    assert rows[2] == ("|  | mujoco vs drake | **4.50e-06** | 4.50e-06 | **6.30e-05** | 6.00e-05 | **7.00e-06** | "
                       "2.50e-06 | **2.90e-05** | 1.00e-04 |")
    assert "[beta]" not in part  # no pair there


def test_per_scene_check_table():
    md = markdown(results(), PROV)
    alpha = md.split("## alpha — PASS")[1].split("\n## ")[0]
    beta = md.split("## beta — FAIL")[1]
    header = next(ln for ln in alpha.splitlines() if ln.startswith("| engine | check |"))
    assert header == ("| engine | check | value | unit | class | order | floor | resolution | requirement | reason | "
                      "note |")

    def row(text, engine, check):
        line = next(ln for ln in text.splitlines() if ln.startswith(f"| {engine} | {check} |"))
        return [c.strip() for c in line.strip("|").split("|")]

    assert row(alpha, "exudyn", "trajectory.orientation")[2:9] == ["1.60e-03", "rad", "converges", "2.0", "0",
                                                                  "1.00e-09", ""]  # no requirement: blank
    assert row(alpha, "drake", "exact")[8:10] == ["1.00e-06", "order 0.93 in the tolerance"]
    mujoco = row(alpha, "mujoco", "trajectory.position")
    assert mujoco[4:7] == ["model difference (declared)", "0.0", "4.50e-06"] and mujoco[9].startswith("soft loop")
    assert row(beta, "pinocchio", "trajectory.position")[4:6] == ["**✗ defect**", "0.3"]
    assert row(beta, "mujoco", "energy_drift")[4:7] == ["**✗ not judged**", "—", "—"]
    assert row(beta, "exudyn", "run")[4] == "**✗ run failed**" and "crashed" in row(beta, "exudyn", "run")[9]
    assert row(beta, "pinocchio", "model.bar2.inertia")[2:5] == ["9.99e-01", "rel", "**✗ model file**"]
    # the runs with their levels; parameters; requirement changes; model files summarised
    assert "| mujoco | RK4 | 0.001 | — | 0.001, 0.002, 0.0005 | ok |" in alpha
    assert "| drake | RK5 | adaptive | 1e-13 | 1e-13, 1e-11 | ok |" in alpha
    assert "**F0 = 2.0** (default 0.0)" in md and "m = 1.0" in md
    assert "Requirements changed by the requirements file: exact <= 1e-06 (added)" in beta
    assert "- mujoco (alpha.xml as written): all 1 quantities of 1 body agree" in alpha
    assert not any(ln.startswith("| mujoco | model.bar.mass") for ln in md.splitlines())


def test_files_csv_json_junit(tmp_path):
    paths = write_reports(results(), PROV, tmp_path)
    assert [p.name for p in paths] == list(FILES) == ["validation.md", "validation.csv", "validation.json",
                                                      "validation.junit.xml", "validation_matrix.png",
                                                      "validation_convergence.png"]
    frame = pd.read_csv(tmp_path / "validation.csv")
    assert list(frame.columns)[:len(OLD_CSV_COLUMNS)] == OLD_CSV_COLUMNS and list(frame.columns) == CSV_COLUMNS
    assert "regression_only" not in frame.columns and "margin" not in frame.columns
    row = frame[(frame.scene == "alpha") & (frame.check == "trajectory.position") & (frame.engine == "mujoco")].iloc[0]
    assert row.classification == "model difference (declared)" and row.floor == pytest.approx(4.5e-6)
    assert row.order == pytest.approx(-0.001) and row.resolution == pytest.approx(1e-9)
    assert math.isnan(row.requirement) and row.tolerance == INF
    assert frame[(frame.engine == "drake") & (frame.check == "exact")].iloc[0].requirement == pytest.approx(1e-6)
    data = json.loads((tmp_path / "validation.json").read_text())
    assert not data["passed"] and set(data["provenance"]) == set(PROV)
    assert data["matrix"]["beta"]["pinocchio"] == {"class": "defect", "passed": False, "check": "trajectory.position",
                                                   "value": 2.1e-2, "unit": "rel", "order": 0.31, "order_in": "step",
                                                   "checks": 3, "failed": 3}
    assert data["matrix"]["alpha"]["drake"]["order_in"] == "tolerance"
    alpha = data["scenes"][0]
    assert {"scene", "passed", "parameters", "runs", "checks", "cross_engine", "cross_engine_extrapolated"} <= set(alpha)
    assert alpha["parameter_overrides"] == {"F0": {"value": 2.0, "default": 0.0}}
    check = next(c for c in alpha["checks"] if c["engine"] == "mujoco" and c["check"] == "trajectory.position")
    assert check["levels"] == [[0.001, 4.5e-6], [0.002, 4.4e-6], [0.0005, 4.5e-6]]
    assert check["tolerance"] == INF and "regression_only" not in check and "margin" not in check
    model = next(c for c in alpha["checks"] if c["check"] == "model.bar.mass")
    assert model["classification"] == "" and math.isnan(model["order"])  # NaN and inf survive as JSON's NaN/Infinity
    suites = ET.parse(tmp_path / "validation.junit.xml").getroot().findall("testsuite")
    failed = {(c.get("classname"), c.get("name")): c.find("failure") for s in suites for c in s.findall("testcase")
              if c.find("failure") is not None}
    assert {k: f.get("type") for k, f in failed.items()} == {
        ("beta.pinocchio", "model.bar2.inertia"): "model", ("beta.pinocchio", "trajectory.position"): "defect",
        ("beta.pinocchio", "exact"): "requirement", ("beta.mujoco", "trajectory.orientation"): "model difference",
        ("beta.mujoco", "energy_drift"): "not judged", ("beta.exudyn", "run"): "run"}
    defect = failed[("beta.pinocchio", "trajectory.position")]
    assert defect.get("message") == "defect: order 0.31 where the method's is 4"
    assert "levels: 2.10e-02 at 0.001, 2.60e-02 at 0.002" in defect.text
    assert failed[("beta.exudyn", "run")].get("message") == "run failed: crashed: segmentation fault"
    for name in ("validation_matrix.png", "validation_convergence.png"):
        assert (tmp_path / name).read_bytes().startswith(PNG)
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporary or staging files left


def _png_size(data: bytes) -> tuple[int, int]:
    return struct.unpack(">II", data[16:24])


def test_convergence_figure_panels_and_size():
    a, b = results()
    assert plotted_check(a) == "trajectory.position" and plotted_check(b) == "trajectory.position"
    only_exact = SceneValidation("gamma", {}, checks=[c for c in a.checks if c.check in ("exact", "closure.velocity")])
    assert plotted_check(only_exact) == "closure.velocity"  # an engine's largest error against its resolution
    assert plotted_check(SceneValidation("delta", {}, checks=[a.checks[1]])) is None  # nothing has levels
    one = _png_size(convergence_png([a]))
    four = _png_size(convergence_png([a, b, a, b]))  # two rows of three panels
    assert four[0] > 1.5 * one[0] and four[1] > 1.5 * one[1]  # a column and a row more; one legend
    assert convergence_png([]).startswith(PNG)


def test_engine_warnings_get_their_own_section_when_present():
    a, b = results()
    a.runs[2] = RunRecord("alpha", "mujoco", "RK4", 0.001, None, 1.0, "ok", "", 0.1, 1000.0,
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
    from harness.engines import load_scene
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
    from dataclasses import replace

    from harness.io.provenance import provenance
    from harness.engines import load_scene
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
