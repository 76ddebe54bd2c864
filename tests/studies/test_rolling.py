"""``harness rolling-study``: the study runs and its report is written (``--quick``)."""

from __future__ import annotations

import pytest

from harness.cli.main import main


@pytest.mark.slow
def test_rolling_study_quick_writes_the_report(tmp_path):
    code = main(["rolling-study", "--quick", "--out-dir", str(tmp_path)])
    assert code == 0
    text = (tmp_path / "rolling_disk.md").read_text()
    assert "MuJoCo defaults" in text and "printed" in text and "**(best)**" in text
    for name in ("rolling_disk.json", "rolling_disk_settings.png", "rolling_disk_lean.png", "rolling_disk_threshold.png"):
        assert (tmp_path / name).is_file()


def test_an_engine_that_does_not_model_the_disk_is_not_run_in_the_threshold_study(monkeypatch):
    """An "unsupported" run neither falls nor rolls: it is "not run" in the threshold table and
    does not count for or against the threshold."""
    from harness.measure.trajectory import unsupported
    from harness.engines import load_scene
    from harness.studies.rolling import report
    from harness.studies.rolling import run as rolling

    real = rolling.run

    def pretend(scene, engine, t_end, **kw):
        if engine == "pinocchio":  # as an engine without rolling contacts would answer
            return unsupported("pinocchio", "rkmk4", ["disk"], "no rolling contacts"), 0.0
        return real(scene, engine, t_end, **kw)

    monkeypatch.setattr(rolling, "run", pretend)
    scene = load_scene("rolling_disk")
    result = rolling.StudyResult(scene)
    rolling.threshold_study(scene, result, [2.0], ["inhouse", "pinocchio"], 0.05)
    by_engine = {r["engine"]: r for r in result.threshold}
    assert by_engine["pinocchio"]["fell"] is None and by_engine["pinocchio"]["status"] == "unsupported"
    assert isinstance(by_engine["inhouse"]["fell"], bool)
    result.thresholds = {"correct": 1.0}
    lines = report.threshold_lines(result)
    row = next(line for line in lines if line.startswith("| 2.000 |"))
    assert row.rstrip(" |").endswith("not run")
    assert rolling.threshold_agrees(result.threshold) == (by_engine["inhouse"]["fell"] != by_engine["inhouse"]["predicted_stable"])


def test_each_mujoco_setting_is_classified_in_the_judging_vocabulary():
    """``setting_models`` on fabricated rows: the best settings at the scene's step and at finer
    steps (solref 2 steps each) are one step ladder with an error model (first order: a defect by
    the error model, the declared soft contact by the verdict); an RK4 row at the scene's step far
    above the ideal engines' error there is a model difference (soft contact), one close to it not
    judged, a first-order row not judged; the report's table shows the classes."""
    from harness.engines import load_scene
    from harness.studies.rolling import report
    from harness.studies.rolling import run as rolling

    scene = load_scene("rolling_disk")
    dt = scene.dt
    result = rolling.StudyResult(scene)
    result.engines = [{"case": "steady_circle", "engine": e, "status": "ok", "position": 4e-7}
                      for e in ("inhouse", "pinocchio", "exudyn")]
    rows = dict(rolling.settings_rows(dt))
    best = rows[rolling.BEST_LABEL]
    finer = {k: v for k, v in rows.items() if k.startswith("as written, step")}

    def row(label, options, position):
        return {"setting": label, "options": options,
                "steady_circle": {"status": "ok", "position": position, "samples": 101}}

    result.settings = [row(rolling.BEST_LABEL, best, 3e-5),
                       *(row(k, v, 3e-5 * v["timestep"] / dt) for k, v in finer.items()),
                       row("RK4", rows["RK4"], 1e-3), row("scene MJCF as written", None, 1e-6),
                       row("implicitfast", rows["implicitfast"], 1e-3)]
    models = rolling.setting_models(result)
    ladder = models[rolling.BEST_LABEL]
    assert ladder["class"] == "defect" and ladder["order"] == pytest.approx(1.0)
    assert "model difference (declared), passes" in ladder["reason"]
    assert all(models[k]["class"] == "defect" for k in finer)
    assert models["RK4"]["class"] == "model difference" and "2.5e+03x the ideal" in models["RK4"]["reason"]
    assert models["scene MJCF as written"]["class"] == "not judged"
    assert models["implicitfast"]["class"] == "not judged"
    text = "\n".join(report.class_lines(result))
    assert "| 4 | RK4 | 1.0e-03 | model difference | soft contact" in text
    assert f"| 1 | {rolling.BEST_LABEL} | 3.0e-05 | defect (1.00) | step ladder 0.25, 0.1, 0.05 ms" in text
