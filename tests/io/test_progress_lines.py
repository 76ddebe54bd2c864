"""Where stderr is not a terminal, every long command prints one line per finished case
(``[n/total] <case> <status> <wall> s``, harness.io.progress), and nothing with --quiet (issue #29)."""

import re
import shutil

import pytest

from harness.cli.main import main
from harness.io import progress
from harness.model.scene import MODELS_DIR

LINE = re.compile(r"^\[(\d+)/(\d+)\] (.+)$")


@pytest.fixture(autouse=True)
def _not_quiet():
    progress.set_quiet(False)
    yield
    progress.set_quiet(False)


def progress_lines(err: str) -> list[re.Match]:
    return [m for m in map(LINE.match, err.splitlines()) if m]


def assert_counts_up(lines, total: int) -> None:
    assert [int(m[1]) for m in lines] == list(range(1, total + 1))
    assert {int(m[2]) for m in lines} == {total}


def test_validate_prints_one_line_per_finished_case(tmp_path, capsys):
    code = main(["validate", "--scenes", "torque_free", "--engines", "inhouse", "--out-dir", str(tmp_path / "r")])
    err = capsys.readouterr().err
    assert code == 0, err
    lines = progress_lines(err)
    assert_counts_up(lines, 2)
    assert re.fullmatch(r"torque_free reference ok \d+\.\d s", lines[0][3])
    assert re.fullmatch(r"torque_free inhouse ok \d+\.\d s", lines[1][3])


def test_quiet_prints_no_progress_line(tmp_path, capsys):
    code = main(["validate", "--scenes", "torque_free", "--engines", "inhouse", "--quiet",
                 "--out-dir", str(tmp_path / "r")])
    assert code == 0 and progress_lines(capsys.readouterr().err) == []


def test_sweep_prints_one_line_per_finished_run(tmp_path, capsys):
    code = main(["sweep", "torque_free", "--random", "I1=1:2", "--samples", "2", "--engines", "inhouse",
                 "--t-end", "1", "--out-dir", str(tmp_path / "s")])
    err = capsys.readouterr().err
    assert code == 0, err
    lines = progress_lines(err)
    assert_counts_up(lines, 4)  # each point's reference and in-house run
    assert all(re.search(r"^torque_free \[\d/2\] I1=\S+ (reference|inhouse) ok \d+\.\d s$", m[3]) for m in lines)


def test_check_prints_one_line_per_stage(tmp_path, capsys):
    code = main(["check", "--mjcf", str(MODELS_DIR / "torque_free" / "torque_free.xml"), "--free-runs", "2",
                 "--t-end", "0.1", "--out-dir", str(tmp_path / "c")])
    err = capsys.readouterr().err
    assert code in (0, 1), err  # the verdict is not this test's
    lines = progress_lines(err)
    assert_counts_up(lines, 6)  # loads, witnesses, dynamics terms, 2 free motions, witness runs
    assert lines[0][3].startswith("torque_free loaded: MuJoCo ok")
    assert lines[3][3].startswith("torque_free free motion 1/2 ")


def test_rolling_study_prints_one_line_per_finished_run(tmp_path, capsys):
    code = main(["rolling-study", "--quick", "--out-dir", str(tmp_path / "r")])
    err = capsys.readouterr().err
    assert code in (0, 1), err
    lines = progress_lines(err)
    assert len(lines) >= 10
    assert_counts_up(lines, len(lines))
    assert lines[0][3].startswith("steady_circle reference ok") and "threshold" in lines[-1][3]


def test_zoo_prints_one_line_per_finished_model(tmp_path, capsys):
    folder = tmp_path / "models"
    folder.mkdir()
    for name in ("torque_free", "heavy_top"):
        shutil.copy(MODELS_DIR / name / f"{name}.xml", folder / f"{name}.xml")
    code = main(["zoo", str(folder), "--jobs", "1", "--out-dir", str(tmp_path / "z")])
    err = capsys.readouterr().err
    assert code == 0, err
    lines = progress_lines(err)
    assert_counts_up(lines, 2)
    assert {m[3].split()[0] for m in lines} == {"torque_free", "heavy_top"}
