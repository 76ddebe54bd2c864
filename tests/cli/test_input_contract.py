"""Bad input that once ended in a traceback or was silently accepted (issue #29): one line on
stderr, exit 2, nothing written; and ``harness`` alone, ``harness --version``."""

import shutil

import pytest

from harness.cli.main import main
from harness.model.scene import MODELS_DIR, builder_names


def _one_line_exit_2(capsys, args, *fragments):
    code = main(args)
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert code == 2, err
    assert len(lines) == 1 and lines[0].startswith("harness: error:"), err
    assert "Traceback" not in err
    for fragment in fragments:
        assert fragment in lines[0], lines[0]
    return lines[0]


@pytest.mark.parametrize("args", [
    ["check", "--mjcf", str(MODELS_DIR / "torque_free" / "torque_free.xml"), "--seed", "-5"],
    ["inspect", "torque_free", "--seed", "-1"],
    ["sweep", "plate_pendulum", "--random", "theta0=0:1", "--samples", "2", "--seed", "-3"],
])
def test_a_negative_seed_is_one_line(tmp_path, capsys, args):
    out = tmp_path / "out"
    _one_line_exit_2(capsys, args + ["--out-dir", str(out)] if args[0] != "inspect" else args,
                     "--seed", "integer >= 0")
    assert not out.exists()


@pytest.mark.parametrize("scene,builder", [("three_link_chain", "__init__"), ("torque_free", "__init__"),
                                           ("torque_free", "_private")])
def test_a_builder_that_is_no_builder_module_names_the_choices(tmp_path, capsys, scene, builder):
    models = tmp_path / "models"
    shutil.copytree(MODELS_DIR / scene, models / scene)
    toml = models / scene / "scene.toml"
    text = toml.read_text()
    toml.write_text(text.replace(f'name = "{scene}"\n', f'name = "{scene}"\nbuilder = "{builder}"\n', 1))
    out = tmp_path / "x.csv"
    line = _one_line_exit_2(capsys, ["simulate", scene, "--engine", "inhouse", "--models-dir", str(models),
                                     "--out", str(out)], f"builder = '{builder}'", "torque_free, ")
    assert all(name in line for name in builder_names()) and "__init__," not in line
    assert not out.exists()


@pytest.mark.parametrize("name", ["../models/torque_free", "torque_free/", "sub/torque_free", "..", "."])
def test_a_scene_name_that_is_no_plain_folder_name_is_refused(tmp_path, capsys, name):
    models = tmp_path / "models"
    shutil.copytree(MODELS_DIR / "torque_free", models / "sub" / "torque_free")
    shutil.copytree(MODELS_DIR / "torque_free", models / "torque_free")
    out = tmp_path / "x.csv"
    _one_line_exit_2(capsys, ["simulate", name, "--engine", "inhouse", "--t-end", "0.01", "--models-dir",
                              str(models), "--out", str(out)], "not a plain folder name")
    assert not out.exists()
    reports = tmp_path / "reports"
    _one_line_exit_2(capsys, ["validate", "--scenes", name, "--engines", "inhouse", "--models-dir", str(models),
                              "--out-dir", str(reports)], "not a plain folder name")
    assert not reports.exists()


@pytest.mark.parametrize("command", [["simulate", "torque_free", "--engine", "inhouse", "--t-end", "0.01"],
                                     ["validate", "--scenes", "torque_free", "--engines", "inhouse"],
                                     ["inspect", "torque_free"]])
def test_a_key_set_twice_is_refused(tmp_path, capsys, command):
    out = tmp_path / "out"
    where = {"simulate": ["--out", str(out)], "validate": ["--out-dir", str(out)]}.get(command[0], [])
    _one_line_exit_2(capsys, command + ["--set", "I1=1.1", "--set", "I1=1.2"] + where, "--set I1 is given twice")
    assert not out.exists()


def test_harness_alone_prints_the_command_list_and_exits_2(capsys):
    assert main([]) == 2
    out = capsys.readouterr()
    assert out.out == "" and "the following arguments are required" not in out.err
    for command in ("scenes", "simulate", "validate", "stress", "sweep", "zoo", "check"):
        assert f"    {command}" in out.err
    assert "usage: harness" in out.err and "Traceback" not in out.err


def test_version_prints_the_package_version(capsys):
    from importlib.metadata import version

    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0
    assert capsys.readouterr().out.strip() == f"harness {version('harness')}"


def test_the_description_names_every_registered_engine():
    from harness.cli.main import build_parser
    from harness.engines import ENGINE_NAMES

    description = build_parser().description
    assert all(name in description for name in ENGINE_NAMES)
