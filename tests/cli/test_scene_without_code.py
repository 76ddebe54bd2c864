"""A scene folder copied under a new name, with only data (scene.toml, MJCF, URDF, README), runs
``harness validate --models-dir`` on every engine; what it lacks is one line and exit 2."""

import json
import shutil

import pytest

from harness.cli.main import main
from harness.engines import ENGINE_NAMES
from harness.measure import exact
from harness.model.scene import MODELS_DIR, has_builder

EXAMPLE = "three_link_chain"


def copy_example(tmp_path, name="my_chain", t_end="0.5"):
    """The example folder copied as ``name`` under ``tmp_path/models``, its horizon cut to
    ``t_end`` s (the tolerances, measured over the example's 4 s, hold over less)."""
    models = tmp_path / "models"
    shutil.copytree(MODELS_DIR / EXAMPLE, models / name)
    path = models / name / "scene.toml"
    text = path.read_text()
    assert f'name = "{EXAMPLE}"' in text and "t_end = 4.0" in text
    path.write_text(text.replace(f'name = "{EXAMPLE}"', f'name = "{name}"').replace("t_end = 4.0", f"t_end = {t_end}"))
    return models


def copy_with_one_file(tmp_path, name, keep, t_end="0.2"):
    """``copy_example`` with one model file only: ``keep`` (``mjcf`` or ``urdf``) stays, the other
    file and its keys (``urdf_root_joint`` goes with the URDF) leave the folder and scene.toml."""
    models = copy_example(tmp_path, name, t_end)
    folder = models / name
    drop = {"mjcf": ("urdf", f"{EXAMPLE}.urdf"), "urdf": ("mjcf", f"{EXAMPLE}.xml")}[keep]
    (folder / drop[1]).unlink()
    keys = (drop[0],) + (("urdf_root_joint",) if drop[0] == "urdf" else ())
    path = folder / "scene.toml"
    lines = path.read_text().splitlines(keepends=True)
    path.write_text("".join(ln for ln in lines if not ln.startswith(tuple(f"{k} = " for k in keys))))
    return models


def one_line_error(capsys, fragment):
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("harness: error:") and fragment in lines[0], err


@pytest.mark.slow
def test_a_copied_folder_validates_on_every_engine(tmp_path, capsys):
    models = copy_example(tmp_path)
    assert not has_builder("my_chain") and exact.reference_module("my_chain") is None  # data only
    out = tmp_path / "out"
    code = main(["validate", "--models-dir", str(models), "--scenes", "my_chain", "--out-dir", str(out), "--quiet"])
    printed = capsys.readouterr().out
    assert code == 0, printed
    assert "my_chain: PASS" in printed
    report = json.loads((out / "validation.json").read_text())
    (scene,) = report["scenes"]
    not_run = set(scene.get("not_run", {}))   # PyBullet: a reaction floor of unfound cause (the scene says)
    assert {r["engine"] for r in scene["runs"]} | not_run == {"reference", *ENGINE_NAMES}
    assert all(r["status"] == "ok" for r in scene["runs"] if r["engine"] not in not_run)
    for engine in set(ENGINE_NAMES) - not_run:  # every engine judged on the checks a scene without code declares
        checks = {c["check"] for c in scene["checks"] if c["engine"] == engine}
        assert {"energy_drift", "trajectory.position", "constraint.position", "reaction.force"} <= checks, engine
    model_engines = {c["engine"] for c in scene["checks"] if c["check"].startswith("model.")}
    assert model_engines == {"mujoco", "pinocchio", "drake", "exudyn", "pybullet"}  # both files checked against the description


def test_simulate_reaches_the_mapped_parameters(tmp_path, capsys):
    import pandas as pd

    models = copy_example(tmp_path)
    csv = tmp_path / "run.csv"
    code = main(["simulate", "my_chain", "--engine", "pinocchio", "--models-dir", str(models), "--t-end", "0.01",
                 "--set", "q1=0", "--set", "q2=0", "--set", "q3=0", "--set", "c3=0,0,-0.1", "--out", str(csv)])
    assert code == 0, capsys.readouterr()
    first = pd.read_csv(csv).iloc[0]
    assert first["link3.z"] == pytest.approx(-1.0)  # 0.5 + 0.4 below the origin, then its centre of mass 0.1 lower


@pytest.mark.parametrize("edit,fragment", [
    (lambda folder: [(folder / f"{EXAMPLE}.{s}").unlink() for s in ("xml", "urdf")], "no model file: neither"),
    (lambda folder: _replace(folder / "scene.toml", '"body.link3.mass"', '"body.link4.mass"'),
     f"[parameters] m3 sets 'body.link4.mass': {EXAMPLE}.xml has no body 'link4'"),
    (lambda folder: _replace(folder / f"{EXAMPLE}.xml", '<joint name="hinge3"', '<joint name="roll" axis="0 0 1"/><joint name="hinge3"'),
     "body 'link3' has 2 joints (roll, hinge3): the harness gives every body one joint"),
], ids=["no model file", "unknown body", "two joints"])
def test_what_a_copy_lacks_is_one_line_and_exit_2(tmp_path, capsys, edit, fragment):
    models = copy_example(tmp_path)
    edit(models / "my_chain")
    code = main(["validate", "--models-dir", str(models), "--scenes", "my_chain", "--engines", "mujoco",
                 "--out-dir", str(tmp_path / "out"), "--quiet"])
    assert code == 2
    one_line_error(capsys, fragment)
    assert not (tmp_path / "out").exists()


def test_an_exact_check_without_closed_forms_is_one_line_and_exit_2(tmp_path, capsys):
    models = copy_example(tmp_path, t_end="0.1")
    _replace(models / "my_chain" / "scene.toml", "[checks.energy_drift]",
             "[checks.exact]\n\n[checks.energy_drift]")
    code = main(["validate", "--models-dir", str(models), "--scenes", "my_chain", "--engines", "mujoco",
                 "--out-dir", str(tmp_path / "out"), "--quiet"])
    assert code == 2
    one_line_error(capsys, "scene.toml: [checks.exact]: no exact check for scene 'my_chain': there is no module "
                           "harness.references.my_chain")


@pytest.mark.slow
@pytest.mark.parametrize("keep", ["urdf", "mjcf"])
def test_a_folder_with_one_model_file_validates_on_every_engine(tmp_path, capsys, keep):
    """Only a URDF: MuJoCo compiles the URDF itself; only an MJCF: Pinocchio and Drake read the
    MJCF. Every engine runs (or is listed not run with its reason), every engine's loaded model
    is checked against the description, and the checks hold."""
    name = f"only_{keep}"
    models = copy_with_one_file(tmp_path, name, keep)
    assert sorted(p.suffix for p in (models / name).glob(f"{EXAMPLE}.*")) == [".urdf" if keep == "urdf" else ".xml"]
    out = tmp_path / "out"
    code = main(["validate", "--models-dir", str(models), "--scenes", name, "--out-dir", str(out), "--quiet"])
    printed = capsys.readouterr().out
    assert code == 0, printed
    assert f"{name}: PASS" in printed
    (scene,) = json.loads((out / "validation.json").read_text())["scenes"]
    ran = {r["engine"] for r in scene["runs"] if r["status"] == "ok"}
    assert ran | set(scene.get("not_run", {})) == {"reference", *ENGINE_NAMES}, (ran, scene.get("not_run"))
    assert ran == {"reference", *ENGINE_NAMES} - set(scene.get("not_run", {}))  # every engine that runs it reads the one file
    model_engines = {c["engine"] for c in scene["checks"] if c["check"].startswith("model.")}
    assert model_engines == ran - {"reference", "inhouse"}  # every engine that runs it, the file's readers and Exudyn
    assert ("pybullet" in model_engines) == (keep == "urdf")  # PyBullet reads no MJCF: not run on the MJCF alone
    mujoco = {c["check"] for c in scene["checks"] if c["engine"] == "mujoco" and c["check"].startswith("model.")}
    assert {"model.link3.mass", "model.link3.axis", "model.link3.joint_type"} <= mujoco
    assert ("model.gravity" in mujoco) == (keep == "mjcf")  # a URDF cannot state gravity


def test_an_engine_that_cannot_read_the_one_file_is_listed_not_run(tmp_path, capsys, monkeypatch):
    from harness.engines.drake import model as drake_model
    from harness.model.errors import InputError

    def refuse(path, *args, **kwargs):
        raise InputError(f"{path}: Drake cannot read it: a planted refusal")

    monkeypatch.setattr(drake_model, "parse", refuse)
    models = copy_with_one_file(tmp_path, "only_mjcf", "mjcf", t_end="0.05")
    out = tmp_path / "out"
    code = main(["validate", "--models-dir", str(models), "--scenes", "only_mjcf", "--engines", "mujoco,drake",
                 "--out-dir", str(out), "--quiet"])
    assert code == 0, capsys.readouterr()
    (scene,) = json.loads((out / "validation.json").read_text())["scenes"]
    why = scene["not_run"]["drake"]
    assert why.startswith(f"cannot read the scene's only model file, {EXAMPLE}.xml: ") and "a planted refusal" in why
    assert not any(c["engine"] == "drake" for c in scene["checks"]) and "drake" not in {r["engine"] for r in scene["runs"]}
    assert "Not run on drake" in (out / "validation.md").read_text()


def test_a_scene_naming_no_model_file_is_one_line_and_exit_2(tmp_path, capsys):
    models = copy_with_one_file(tmp_path, "my_chain", "mjcf")
    _replace(models / "my_chain" / "scene.toml", f'mjcf = "{EXAMPLE}.xml"\n', "")
    code = main(["validate", "--models-dir", str(models), "--scenes", "my_chain", "--out-dir", str(tmp_path / "out"),
                 "--quiet"])
    assert code == 2
    one_line_error(capsys, "scene.toml: names no model file: give mjcf =")
    assert not (tmp_path / "out").exists()


def _replace(path, old, new):
    text = path.read_text()
    assert old in text, old
    path.write_text(text.replace(old, new, 1))


def test_simulate_refuses_a_missing_mjcf_instead_of_reading_the_urdf(tmp_path, capsys):
    models = copy_example(tmp_path)
    (models / "my_chain" / f"{EXAMPLE}.xml").unlink()
    csv = tmp_path / "run.csv"
    code = main(["simulate", "my_chain", "--engine", "inhouse", "--models-dir", str(models), "--t-end", "0.01",
                 "--out", str(csv)])
    assert code == 2
    one_line_error(capsys, f"its MJCF {EXAMPLE}.xml is not in")
    assert not csv.exists()
