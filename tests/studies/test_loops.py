"""``harness loop-study``: the closed-loop study runs and writes its report (``--quick``), and
its pure parts: the MuJoCo variants' rewriting of the loop equalities, the verdict, the
findings generated from the numbers."""

from __future__ import annotations

import json
import math
import os
import shutil

import numpy as np
import pytest

from harness.cli.main import main
from harness.model.errors import InputError
from harness.model.scene import MODELS_DIR
from harness.engines import load_scene
from harness.studies.loops import report
from harness.studies.loops import run as loops

WRITTEN = {"cut": ((0.002, 1.0), (0.9999, 0.9999, 0.001, 0.5, 2.0)),
           "cut_2": ((0.002, 1.0), (0.9999, 0.9999, 0.001, 0.5, 2.0))}


@pytest.mark.slow
def test_loop_study_quick_writes_the_report(tmp_path):
    # three of the five loop scenes (a folder of copies): bricard and the Andrews squeezer (at
    # 1e-5 s steps) would triple the time and add nothing the machinery is tested on; the full
    # study (reports/loop_closure.md) runs every one
    models = tmp_path / "models"
    for name in ("four_bar", "slider_crank", "four_bar_near_singular"):
        shutil.copytree(MODELS_DIR / name, models / name)
    code = main(["loop-study", "--quick", "--models-dir", str(models), "--out-dir", str(tmp_path)])
    assert code == 0
    text = (tmp_path / "loop_closure.md").read_text()
    assert "Reproduce with `harness loop-study --quick" in text and "**yes**" in text
    for scene in ("four_bar", "slider_crank", "four_bar_near_singular"):
        assert f"## {scene}:" in text and (tmp_path / f"loop_closure_{scene}.png").is_file()
    assert "| Drake | not run |" in text and "MuJoCo's default solref/solimp" in text
    data = json.loads((tmp_path / "loop_closure.json").read_text())
    assert data["failures"] == [] and data["quick"] is True
    for scene in data["scenes"]:
        runs = scene["runs"]
        assert {r["dt"] for r in runs} == {2 * scene["dt_s"], scene["dt_s"]}
        assert all(r["status"] == "ok" for r in runs)
        ideal = [r for r in runs if loops.VARIANT[r["variant"]].ideal]
        assert len(ideal) == 6 and all(r["closure_position"] < 1e-9 for r in ideal)
        soft = [r for r in runs if r["variant"] == "mujoco_defaults"]
        # MuJoCo's default, soft equality leaves a gap far above round-off
        assert all(r["closure_position"] > 1e-6 for r in soft)


# ------------------------------------------------------------------ MuJoCo variants
def test_mujoco_defaults_are_what_a_connect_without_settings_gets():
    import mujoco

    m = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><site name="a"/><body name="b"><joint type="hinge"/><geom size=".1" mass="1"/>'
        '<site name="c" pos="0.1 0 0"/></body></worldbody><equality><connect site1="a" site2="c"/></equality></mujoco>')
    assert tuple(m.eq_solref[0]) == loops.DEFAULT_SOLREF
    assert np.allclose(m.eq_solimp[0], loops.DEFAULT_SOLIMP)


def test_variant_settings():
    assert loops.variant_settings("written", 1e-3, WRITTEN) is None
    two = loops.variant_settings("two_dt", 2.5e-4, WRITTEN)
    assert two == {n: ((5e-4, 1.0), WRITTEN[n][1]) for n in WRITTEN}
    direct = {"cut": ((-1e6, -200.0), (0.9, 0.95, 0.001, 0.5, 2.0))}  # stiffness/damping form: ratio 1
    assert loops.variant_settings("two_dt", 1e-3, direct)["cut"][0] == (2e-3, 1.0)
    assert loops.variant_settings("defaults", 1e-3, WRITTEN) == {
        n: (loops.DEFAULT_SOLREF, loops.DEFAULT_SOLIMP) for n in WRITTEN}
    assert loops.variant_settings("default_solimp", 1e-3, WRITTEN) == {
        n: ((0.002, 1.0), loops.DEFAULT_SOLIMP) for n in WRITTEN}
    with pytest.raises(ValueError):
        loops.variant_settings("stiff", 1e-3, WRITTEN)


def test_written_settings_are_read_from_the_mjcf():
    from harness.engines.mujoco.model import read_spec

    scene = load_scene("four_bar_near_singular")
    names = loops.loop_equalities(scene)
    assert names == ["cut", "cut_2"]
    written = loops.written_settings(read_spec(scene.mjcf), names)
    assert written["cut"][0] == (0.0005, 1.0) and written["cut_2"][1][:3] == (0.9999, 0.9999, 0.001)
    with pytest.raises(InputError, match="no equality named 'nope'"):
        loops.written_settings(read_spec(scene.mjcf), ["nope"])


def test_the_variant_mjcf_changes_the_loop_equalities_and_nothing_else(tmp_path):
    import mujoco

    from harness.engines.mujoco.model import load_mjcf

    scene = load_scene("slider_crank")
    assert loops.soft_variant(scene, None, tmp_path, "x") is scene
    settings = loops.variant_settings("two_dt", 1e-4, WRITTEN)
    variant = loops.soft_variant(scene, settings, tmp_path, "two_dt")
    assert variant.mjcf.parent == tmp_path and variant.mjcf != scene.mjcf
    model = scene.multibody()
    a, b = load_mjcf(scene.mjcf, model), load_mjcf(variant.mjcf, model)
    for i in range(b.neq):
        name = mujoco.mj_id2name(b, mujoco.mjtObj.mjOBJ_EQUALITY, i)
        assert tuple(b.eq_solref[i]) == (2e-4, 1.0), name
        assert np.allclose(b.eq_solimp[i], a.eq_solimp[i])
    for field in ("body_mass", "body_inertia", "body_pos", "body_ipos", "site_pos", "jnt_axis", "actuator_gear"):
        assert np.array_equal(getattr(a, field), getattr(b, field)), field
    with pytest.raises(InputError, match="no equality named 'other'"):
        loops.soft_variant(scene, {"other": WRITTEN["cut"]}, tmp_path, "bad")


def test_the_variant_mjcf_with_the_files_own_settings_runs_exactly_as_the_file(tmp_path):
    """The rewriting (MuJoCo's own writer) changes nothing MuJoCo runs: with the file's own
    settings the trajectory is bit for bit the file's."""
    from harness.engines import get_engine
    from harness.engines.base import RunSettings
    from harness.engines.mujoco.model import read_spec

    scene = load_scene("four_bar")
    written = loops.written_settings(read_spec(scene.mjcf), loops.loop_equalities(scene))
    same = loops.soft_variant(scene, written, tmp_path, "same")
    settings = RunSettings(0.05, scene.dt, 0.01, "RK4")
    a = get_engine("mujoco").simulate(scene, settings)
    b = get_engine("mujoco").simulate(same, settings)
    assert a.ok and b.ok and np.array_equal(a.p_WCm_W, b.p_WCm_W) and np.array_equal(a.quat_WB, b.quat_WB)


def test_describe_settings():
    assert loops.describe_settings(WRITTEN) == "solref 0.002 1, solimp 0.9999 0.9999 0.001 0.5 2"
    mixed = {"cut": WRITTEN["cut"], "cut_2": ((0.02, 1.0), WRITTEN["cut"][1])}
    assert loops.describe_settings(mixed).startswith("cut: solref 0.002 1") and "cut_2: solref 0.02 1" in loops.describe_settings(mixed)


def test_forced_scenes_are_saved_at_every_step():
    assert loops.save_interval(load_scene("slider_crank"), 5e-4) == 5e-4
    four_bar = load_scene("four_bar")
    assert loops.save_interval(four_bar, 5e-4) == four_bar.save_every


# ------------------------------------------------------------------ scenes and bad input
def test_only_scenes_with_loops_are_studied_and_none_is_bad_input(tmp_path, capsys):
    import shutil

    names = [s.name for s in loops.loop_scenes()]
    assert {"four_bar", "slider_crank", "four_bar_near_singular"} <= set(names)
    assert "heavy_top" not in names
    shutil.copytree(MODELS_DIR / "heavy_top", tmp_path / "models" / "heavy_top")
    with pytest.raises(InputError, match="no scene with a closed kinematic loop"):
        loops.loop_scenes(tmp_path / "models")
    out = tmp_path / "out"
    assert main(["loop-study", "--models-dir", str(tmp_path / "models"), "--out-dir", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no scene with a closed kinematic loop" in err and not out.exists()
    assert main(["loop-study", "--jobs", "-1", "--out-dir", str(out)]) == 2
    assert main(["loop-study", "--timeout", "0", "--out-dir", str(out)]) == 2


def test_planned_runs_leave_out_what_a_scene_does_not_run():
    scene = load_scene("four_bar")
    run_variants = [v for v in loops.VARIANTS if v.engine not in scene.not_run]
    assert loops.planned_runs([scene], quick=True) == 2 * len(run_variants)
    assert loops.planned_runs([scene]) == 4 * len(run_variants)


def _fake_case(scene, engine, integrator, dt, t_end, save):
    """A stand-in for ``run_case``: no simulation; Pinocchio's worker dies of a signal."""
    if engine == "pinocchio":
        os.kill(os.getpid(), 9)
    gap = 1e-14 if engine in ("inhouse", "exudyn") else 1e-7
    return {"status": "ok", "message": "", "wall_s": 0.0, "settings": "", **loops.measure_nan(),
            "closure_position": gap, "closure_velocity": 1e-12, "energy": 1e-9, "exact": dt ** 4}


def test_a_crashing_engine_is_that_runs_status_not_the_studys_end(monkeypatch):
    monkeypatch.setattr(loops, "run_case", _fake_case)
    study = loops.loop_study(quick=True, scenes=[load_scene("four_bar")], jobs=2, timeout=30)
    (s,) = study.scenes
    crashed = [r for r in s.rows if r["variant"] == "pinocchio"]
    assert len(crashed) == 2 and all(r["status"] == "crashed" and "SIGKILL" in r["message"] for r in crashed)
    assert all(r["status"] == "ok" for r in s.rows if r["variant"] != "pinocchio")
    assert s.not_run == {e: scene_not_run("four_bar", e) for e in ("drake", "pybullet")}
    bad = loops.failures(study)
    assert len(bad) == 2 and all("Pinocchio rkmk4" in line and "crashed" in line for line in bad)
    lines = report.table_lines(s)
    assert any(line.startswith("| Pinocchio rkmk4 | crashed |") for line in lines)
    assert {line.split(" | ")[0] for line in lines if "| not run |" in line} == {"| Drake", "| PyBullet"}


def scene_not_run(scene: str, engine: str) -> str:
    return load_scene(scene).not_run[engine]


# ------------------------------------------------------------------ verdict and findings
def _study(rows: dict[str, list[tuple]], scene: str = "four_bar", written=WRITTEN) -> loops.LoopStudy:
    """A study of one scene from ``{variant: [(gap m, exact rad), ...]}`` at the steps 2, 1,
    1/2, 1/4 dt (velocity 1e-12 m/s, energy 1e-9)."""
    sc = load_scene(scene)
    steps = [f * sc.dt for f in loops.FACTORS]
    s = loops.SceneStudy(sc, steps, [sc.save_every] * len(steps), written)
    for key, values in rows.items():
        v = loops.VARIANT[key]
        for f, dt, (gap, ex) in zip(loops.FACTORS, steps, values):
            s.rows.append({"variant": key, "label": loops.full_label(v, loops.integrator_of(sc, v)), "engine": v.engine,
                           "integrator": loops.integrator_of(sc, v), "factor": f, "dt": dt, "save_every": sc.save_every,
                           "loop_settings": "", "status": "ok", "message": "", "wall_s": 0.1, "settings": "",
                           **loops.measure_nan(), "closure_position": gap, "closure_velocity": 1e-12, "energy": 1e-9,
                           "exact": ex, "exact_unit": "rad"})
    return loops.LoopStudy([s], None, loops.FACTORS, False, 2, 300.0)


def test_failures_judge_the_ideal_engines_closure_and_every_runs_status():
    ok = {"inhouse": [(1e-14, 1e-6)] * 4, "mujoco_written": [(1e-6, 1e-5)] * 4}
    assert loops.failures(_study(ok)) == []  # MuJoCo's gap is not held to the ideal bound
    study = _study({**ok, "pinocchio": [(1e-14, 1e-6), (1e-14, 1e-6), (2e-9, 1e-6), (math.nan, 1e-6)]})
    bad = loops.failures(study)
    assert len(bad) == 2 and "2.00e-09 m" in bad[0] and "nan" in bad[1]
    study.scenes[0].rows[0]["status"] = "timeout"
    assert any("in-house rk4" in line and "timeout" in line for line in loops.failures(study))


def test_loglog_slope():
    steps = [2e-3, 1e-3, 5e-4, 2.5e-4]
    assert loops.loglog_slope(steps, [h ** 4 for h in steps]) == pytest.approx(4.0)
    assert loops.loglog_slope(steps, [3e-7] * 4) == pytest.approx(0.0, abs=1e-12)
    assert loops.loglog_slope(steps, [h ** 2 if i else math.nan for i, h in enumerate(steps)]) == pytest.approx(2.0)
    assert math.isnan(loops.loglog_slope(steps, [1.0, 0.0, math.nan, -1.0]))


def test_findings_follow_the_numbers():
    steps = [f * 1e-3 for f in loops.FACTORS]
    flat = {"inhouse": [(1e-14, 1e-6 * (h / 1e-3) ** 4) for h in steps],
            "mujoco_written": [(1.1e-6, 3e-6), (2.6e-7, 6e-7), (2.5e-7, 6e-7), (2.6e-7, 6e-7)],
            "mujoco_two_dt": [(1.1e-6, 3e-6), (2.6e-7, 6e-7), (6.5e-8, 1.5e-7), (1.6e-8, 4e-8)],
            "mujoco_defaults": [(2e-4, 6e-4)] * 4}
    study = _study(flat)
    text = " ".join(report.findings(study.scenes[0], study))
    assert "In-house rk4_compiled keeps the loop closed below 1e-9 m at every step" in text and "round-off" in text
    assert "observed order 4.0" in text
    # an error that stops falling (the reference's accuracy) is not given an order
    study = _study(dict(flat, inhouse=[(1e-14, e) for e in (1.6e-11, 1.1e-11, 1.1e-11, 1.1e-11)]))
    text_floor = " ".join(report.findings(study.scenes[0], study))
    assert "1.1e-11 (in-house, no longer falling: 1.1e-11 from 1 ms down)" in text_floor and "order 0." not in text_floor
    assert "follows the constraint's softness, not the step" in text  # the written gap is flat below 2 ms
    assert "At 2 ms the file's time constant is below 2·dt" in text
    assert "shrinks with the step as dt^2.0" in text
    assert "769× the MJCF's, whatever the step" in text
    # the same study with a written gap that follows the step: no such claim
    steep = dict(flat, mujoco_written=[(1.1e-6, 3e-6), (2.6e-7, 6e-7), (6.5e-8, 1.5e-7), (1.6e-8, 4e-8)])
    study = _study(steep)
    text = " ".join(report.findings(study.scenes[0], study))
    assert "not the step" not in text and "the gap goes as dt^2.0" in text
    # an ideal engine above the bound is named
    study = _study(dict(flat, inhouse=[(1e-14, 1e-6), (3e-9, 1e-7), (1e-14, 1e-8), (1e-14, 1e-9)]))
    assert ("In-house rk4_compiled does not keep the loop closed below 1e-9 m: its largest gap is 3.0e-09 m."
            in report.findings(study.scenes[0], study))


def test_a_variant_scene_is_compared_with_the_scene_it_varies():
    base = _study({"inhouse": [(1e-14, e) for e in (4e-8, 2e-9, 1.2e-10, 8e-12)]}).scenes[0]
    near = _study({"inhouse": [(1e-14, e) for e in (1e-7, 4e-9, 2.4e-10, 1.6e-11)]}, scene="four_bar_near_singular").scenes[0]
    study = loops.LoopStudy([base, near], None, loops.FACTORS, False, 2, 300.0)
    text = " ".join(report.findings(near, study))
    # four_bar_near_singular steps 0.5, 0.25 ms are four_bar's 0.5, 0.25 ms: errors 1e-7/1.2e-10, 4e-9/8e-12
    assert ("The ideal engines' errors are larger than on `four_bar`: at the steps both `four_bar_near_singular` and "
            "`four_bar` run (0.5, 0.25 ms)") in text
    assert "500–833× (in-house)" in text
    # the other way round the errors are smaller: no such claim
    study = loops.LoopStudy([near, base], None, loops.FACTORS, False, 2, 300.0)
    base.scene, near.scene = near.scene, base.scene
    assert "larger" not in " ".join(report.findings(base, study))


def test_the_report_is_written_from_a_study(tmp_path):
    study = _study({"inhouse": [(1e-14, 1e-6)] * 4, "mujoco_written": [(1e-6, 1e-5)] * 4})
    study.scenes[0].not_run["drake"] = "no loop constraints"
    prov = {"date_utc": "2000-01-01 00:00:00 UTC", "mujoco": "x", "machine": "m"}
    pngs = report.write_reports(study, tmp_path, prov, command="harness loop-study")
    assert [p.name for p in pngs] == ["loop_closure_four_bar.png"] and pngs[0].is_file()
    text = (tmp_path / "loop_closure.md").read_text()
    assert "Reproduce with `harness loop-study`." in text and "| Drake | not run |" in text
    assert "closure gap (m), 2 ms | 1 ms | 0.5 ms | 0.25 ms |" in text
    data = json.loads((tmp_path / "loop_closure.json").read_text())
    assert data["scenes"][0]["not_run"] == {"drake": "no loop constraints"} and len(data["scenes"][0]["runs"]) == 8


def test_a_gap_that_stops_falling_is_a_floor_and_the_floors_follow_the_compliance():
    steps = [2e-3, 1e-3, 5e-4, 2.5e-4]
    assert report.levels_off(steps, [1e-6, 2.9e-7, 6.4e-9, 6.4e-9]) == (6.4e-9, 5e-4)
    assert report.levels_off(steps, [7e-6] * 4) == (7e-6, 2e-3)
    assert report.levels_off(steps, [1e-6, 2.5e-7, 6e-8, 1.5e-8]) is None
    study = _study({"mujoco_written": [(6.5e-8, 1e-5), (1.6e-8, 1e-5), (6.4e-9, 1e-5), (6.4e-9, 1e-5)],
                    "mujoco_default_solimp": [(2.9e-5, 1e-3), (7.2e-6, 1e-3), (7.2e-6, 1e-3), (7.2e-6, 1e-3)],
                    "mujoco_defaults": [(5e-4, 3.1)] * 4})
    text = " ".join(report.findings(study.scenes[0], study))
    assert "a ratio of 1125×, that of their compliances (1 − d0)/d0, 1111×" in text
    assert "levelling off at 6.4e-09 m from 0.5 ms down" in text
    assert "exact error 3.1e+00 rad (≈ π" in text  # a saturated angle error is not compared
    # floors whose ratio is not the compliances' are stated, not explained
    study = _study({"mujoco_written": [(6.5e-8, 1e-5), (1.6e-8, 1e-5), (6.4e-9, 1e-5), (6.4e-9, 1e-5)],
                    "mujoco_default_solimp": [(2.9e-5, 1e-3), (7.2e-7, 1e-3), (7.2e-7, 1e-3), (7.2e-7, 1e-3)]})
    text = " ".join(report.findings(study.scenes[0], study))
    assert "a ratio of 112× (the compliances (1 − d0)/d0 differ by 1111×)" in text and "not a step error" not in text


def test_each_engine_and_measure_gets_its_error_model():
    """``error_models`` (``harness.judging.error_model``): the ideal engine's closure gap at
    round-off converges (at the resolution) and its exact error at its integrator's order; MuJoCo's
    gap that stays put is a model difference with its floor, one falling at dt^2 with RK4 a defect
    by the error model, both within the bound four_bar declares for MuJoCo's soft loop constraints;
    a blow-up at the scene's step is a defect, a timeout there not judged. The report's table shows
    the classes."""
    steps = [f * 1e-3 for f in loops.FACTORS]
    study = _study({"inhouse": [(1e-14, 1e-6 * (h / 1e-3) ** 4) for h in steps],
                    "mujoco_written": [(1e-6, 3e-6), (1e-6, 3e-6), (1e-6, 3e-6), (1e-6, 3e-6)],
                    "mujoco_two_dt": [(4e-6, 3e-6), (1e-6, 7.5e-7), (2.5e-7, 1.9e-7), (6.25e-8, 4.7e-8)],
                    "pinocchio": [(1e-14, 1e-6)] * 4, "exudyn": [(1e-14, 1e-6)] * 4})
    s = study.scenes[0]
    models = loops.error_models(s, 1.0)
    assert models[("inhouse", "closure_position")].classification == "converges"
    exact = models[("inhouse", "exact")]
    assert exact.classification == "converges" and exact.observed_order == pytest.approx(4.0)
    assert exact.levels[0].step == s.scene.dt  # the scene's step first
    flat = models[("mujoco_written", "closure_position")]
    assert flat.classification == "model difference" and flat.floor == pytest.approx(1e-6, rel=1e-6) and flat.unit == "m"
    steep = models[("mujoco_two_dt", "closure_position")]
    assert steep.classification == "defect" and steep.observed_order == pytest.approx(2.0)
    for r in s.rows:
        if r["variant"] == "pinocchio" and r["dt"] == s.scene.dt:
            r["status"], r["closure_position"] = "blowup", math.nan
        if r["variant"] == "exudyn" and r["dt"] == s.scene.dt:
            r["status"] = "timeout"
    models = loops.error_models(s, 1.0)
    assert models[("pinocchio", "closure_position")].classification == "defect"
    assert models[("exudyn", "closure_position")].classification == "not judged"
    table = "\n".join(report.model_lines(s, study))
    assert "| engine / variant | class (order) of closure gap (m) |" in table
    assert "| MuJoCo RK4, MJCF's solref/solimp | model difference (0.00), floor 1.0e-06 m — declared, within its bound 0.0005 |" in table
    assert "defect (2.00) — declared, within its bound 0.0005" in table and "| in-house rk4_compiled | converges | converges | converges (4.00) |" in table
    data = report.as_json(study, {"date_utc": "x"}, "harness loop-study")
    assert any(m["variant"] == "mujoco_two_dt" and m["measure"] == "closure_position" and m["class"] == "defect"
               for m in data["scenes"][0]["error_models"])
