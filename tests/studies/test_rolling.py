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
    from harness.model.scene import load_scene
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
