"""``harness benchmark``: the problems the scenes reproduce, a run that writes both files, and the
figures the report states (from the runs it made, never typed in)."""

import csv
import math

import pytest

from harness.cli.main import main
from harness.references import pendulum
from harness.studies.benchmarks.report import FIELDS, markdown
from harness.studies.benchmarks.run import EngineResult, ProblemResult, benchmark_scenes


def test_the_benchmark_scenes_are_those_whose_reference_states_one():
    names = benchmark_scenes()
    assert {"pendulum", "andrews_squeezer", "bricard"} <= set(names)
    assert "torque_free" not in names  # a textbook system, no published benchmark
    assert pendulum.BENCHMARK["problem"] == "IFToMM A01" and 0 < pendulum.BENCHMARK["required"] < 1


@pytest.mark.slow  # worker processes
def test_a_run_measures_each_engine_and_writes_both_files(tmp_path, capsys):
    """On A01 with two engines: each engine's error at the scene's step is validate's exact check
    (agreement in digits over the 1 m pendulum), its time to the required 1e-3 is measured, the
    baseline's ratio is 1 (of the sweep's times and of validate's run at the scene's step), and the
    report and the CSV carry the same numbers."""
    out = tmp_path / "out"
    code = main(["benchmark", "--scenes", "pendulum", "--engines", "inhouse,mujoco", "--quick", "--quiet",
                 "--out-dir", str(out)])
    assert code == 0, capsys.readouterr().out
    rows = list(csv.DictReader((out / "benchmarks.csv").open()))
    assert tuple(rows[0]) == FIELDS and {r["engine"] for r in rows} == {"inhouse", "mujoco"}
    for r in rows:
        assert r["problem"] == "IFToMM A01" and r["passed"] == "True"
        err = float(r["exact"])
        assert 0 < err < 1e-6 and float(r["digits"]) == pytest.approx(-math.log10(err), rel=1e-9)  # L = 1 m
    mujoco = next(r for r in rows if r["engine"] == "mujoco")
    assert float(mujoco["ratio_to_baseline"]) == pytest.approx(1.0) and float(mujoco["time_s"]) > 0
    # validate's own run at the scene's step, timed and set against the baseline's in the same run
    assert float(mujoco["step_ratio_to_baseline"]) == pytest.approx(1.0)
    for r in rows:
        assert float(r["step_wall_s"]) > 0
    text = (out / "benchmarks.md").read_text()
    assert "## IFToMM A01: simple pendulum (`pendulum`)" in text and f"{float(mujoco['exact']):.2e} m" in text


def test_the_report_names_an_engine_not_run_and_an_accuracy_not_reached():
    problem = ProblemResult("bricard", "IFToMM A04", "Bricard's mechanism", "energy", 1e-3, None,
                            engines=[EngineResult("exudyn", "GeneralizedAlpha", 1e-5, "rad", 5.0, "converges", True)],
                            not_run={"drake": "no loop constraint"})
    text = markdown([problem], {"date_utc": "today"}, command="harness benchmark")
    assert "| Exudyn | `GeneralizedAlpha` | 1.00e-05 rad | 5.0 | converges | — | not reached | — |" in text
    assert "not run: no loop constraint" in text


def test_a_linearisation_problem_draws_its_eigenvalues_against_speed():
    """The bicycle's published eigenvalues and an engine's (here the published ones again, standing
    for a perfect linearisation) are drawn, and the report shows the figure."""
    from harness.engines import load_scene
    from harness.references import bicycle
    from harness.studies.benchmarks.report import eigenvalue_png

    scene = load_scene("bicycle")
    speeds = [0.0, 5.0]
    published = bicycle.published_eigenvalues(scene, speeds)
    assert published.shape == (2, 4) and published[1].real.max() < 0.0  # self-stable at 5 m/s
    problem = ProblemResult("bicycle", "Whipple bicycle", "the bicycle", "M, C1, K0, K2", 1e-3, None,
                            eigenvalues={"speeds": speeds, "published": published, "fine_speeds": speeds,
                                         "fine_published": published, "inhouse": published})
    assert eigenvalue_png(problem).startswith(b"\x89PNG")
    assert "![eigenvalues](benchmarks_bicycle_eigenvalues.png)" in markdown([problem], {"date_utc": "today"}, command="x")
