"""Validation: checks per scene, isolation of a crashing engine, reports, JUnit, tolerance file."""

import json
import os
import signal
import xml.etree.ElementTree as ET

import pytest

from harness.cli.main import main
from harness.engines.mujoco.engine import MujocoEngine
from harness.model.scene import load_scene
from harness.validate.run import validate

SHORT = {"t_end": 0.5}


def short(name, **overrides):
    from dataclasses import replace

    return replace(load_scene(name, overrides), t_end=0.5)


def test_validate_passes_and_checks_only_what_the_scene_needs():
    (res,) = validate([short("heavy_top")], ["mujoco"], jobs=1)
    names = {c.check for c in res.checks if c.engine == "mujoco"}
    assert res.passed, [c for c in res.checks if not c.passed]
    assert "momentum_drift.Lz" in names and "momentum_drift.L3" in names
    assert not any(n.startswith("momentum_drift.p") for n in names)  # gravity and the tip act
    assert "constraint.position" in names and "exact" in names


def test_forced_pendulum_checks_energy_balance_not_conservation():
    (res,) = validate([short("double_pendulum", F0=2.0, omega_f=3.0)], ["pinocchio"], jobs=1)
    names = {c.check for c in res.checks if c.engine == "pinocchio"}
    assert "energy_balance" in names and "energy_drift" not in names
    assert res.passed, [c for c in res.checks if not c.passed]


def test_a_killed_engine_worker_leaves_the_other_results(monkeypatch):
    def die(self, scene, settings):
        os.kill(os.getpid(), signal.SIGKILL)

    monkeypatch.setattr(MujocoEngine, "simulate", die)  # inherited by the forked worker
    (res,) = validate([short("torque_free")], ["mujoco", "pinocchio"], jobs=2)
    run = [c for c in res.checks if c.engine == "mujoco"]
    assert len(run) == 1 and run[0].check == "run" and not run[0].passed
    assert "crashed" in run[0].detail
    pin_checks = [c for c in res.checks if c.engine == "pinocchio"]
    assert len(pin_checks) > 5 and all(c.passed for c in pin_checks)


def test_a_hanging_engine_times_out(monkeypatch):
    import time

    monkeypatch.setattr(MujocoEngine, "simulate", lambda self, s, st: time.sleep(60))
    (res,) = validate([short("torque_free")], ["mujoco"], jobs=1, timeout=3.0)
    assert [c.detail.split(":")[0] for c in res.checks if c.engine == "mujoco"] == ["timeout"]


def test_cli_writes_reports_junit_and_exit_codes(tmp_path, capsys):
    out = tmp_path / "reports"
    code = main(["validate", "--scenes", "heavy_top", "--engines", "mujoco", "--out-dir", str(out)])
    assert code == 0, capsys.readouterr()
    data = json.loads((out / "validation.json").read_text())
    assert data["passed"] and data["provenance"]["mujoco"]
    suite = ET.parse(out / "validation.junit.xml").getroot().find("testsuite")
    assert suite.get("name") == "heavy_top" and int(suite.get("failures")) == 0
    cases = suite.findall("testcase")
    assert {c.get("classname") for c in cases} == {"heavy_top.reference", "heavy_top.mujoco"}
    assert "MuJoCo" in (out / "validation.md").read_text()

    tol = tmp_path / "tol.toml"
    tol.write_text("[heavy_top.energy_drift]\nmujoco = 1e-16\n")
    code = main(["validate", "--scenes", "heavy_top", "--engines", "mujoco", "--tolerances", str(tol), "--out-dir", str(out)])
    assert code == 1
    suite = ET.parse(out / "validation.junit.xml").getroot().find("testsuite")
    failed = [c for c in suite.findall("testcase") if c.find("failure") is not None]
    assert [(c.get("classname"), c.get("name")) for c in failed] == [("heavy_top.mujoco", "energy_drift")]
    assert "energy_drift.mujoco: 1e-08 -> 1e-16" in (out / "validation.md").read_text()


@pytest.mark.parametrize("text,fragment", [
    ("[heavy_top.energy_drift]\nmujco = 1e-9\n", "has no tolerance 'mujco'"),
    ("[heavy_top.enrgy]\nmujoco = 1e-9\n", "has no check 'enrgy'"),
    ("[heavy_tops.energy_drift]\nmujoco = 1e-9\n", "unknown scene 'heavy_tops'"),
    ("[heavy_top.energy_drift]\nmujoco = -1\n", "must be positive"),
    ("[heavy_top", "malformed TOML"),
])
def test_bad_tolerance_file(tmp_path, capsys, text, fragment):
    tol = tmp_path / "tol.toml"
    tol.write_text(text)
    code = main(["validate", "--scenes", "heavy_top", "--tolerances", str(tol), "--out-dir", str(tmp_path / "r")])
    err = capsys.readouterr().err
    assert code == 2 and fragment in err and str(tol) in err and err.count("\n") == 1
    assert not (tmp_path / "r").exists()
