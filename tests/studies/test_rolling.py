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
