"""``CONTRIBUTING.md`` stays true: every path it names exists, and every scene, engine and study
in the tree follows the recipe it gives."""

from __future__ import annotations

import importlib
import re
from pathlib import Path

import pytest

from harness.engines import ENGINE_MODULES
from harness.model.scene import available_scenes
from harness.engines import load_scene

ROOT = Path(__file__).resolve().parents[1]
TEXT = (ROOT / "CONTRIBUTING.md").read_text()
STUDIES = sorted(p.name for p in (ROOT / "harness" / "studies").iterdir() if (p / "__init__.py").is_file())


def _named_paths() -> list[str]:
    paths = re.findall(r"`((?:harness|models|references|tests|reports)/[^`\s]*|pyproject\.toml)`", TEXT)
    return sorted({p for p in paths if "<" not in p and "*" not in p})


@pytest.mark.parametrize("path", _named_paths())
def test_every_named_path_exists(path):
    assert (ROOT / path).exists(), f"CONTRIBUTING.md names {path}, which does not exist"


@pytest.mark.parametrize("scene", available_scenes())
def test_scene_follows_the_recipe(scene):
    folder = ROOT / "models" / scene
    for name in ("scene.toml", "README.md"):
        assert (folder / name).is_file(), f"models/{scene}/{name}"
    s = load_scene(scene)
    assert s.mjcf.is_file() and s.urdf.is_file()
    if s.generated:  # "N copies of a unit": its files are written from the description, none kept here
        assert not (folder / s.mjcf.name).exists() and not (folder / s.urdf.name).exists()
    system = s.builder or scene
    assert (ROOT / "references" / f"{system}.py").is_file() or "exact" not in s.checks
    if s.from_model_file:  # "A scene without code": no builder, every parameter mapped onto the model file
        assert not (ROOT / "harness" / "model" / "builders" / f"{system}.py").exists()
        assert all(p.sets for p in s.parameters.values())
        return
    assert (ROOT / "harness" / "model" / "builders" / f"{system}.py").is_file()
    assert (ROOT / "tests" / "references" / f"test_{system}.py").is_file(), f"tests/references/test_{system}.py"


@pytest.mark.parametrize("engine", sorted(ENGINE_MODULES))
def test_engine_follows_the_recipe(engine):
    folder = ROOT / "harness" / "engines" / engine
    assert (folder / "__init__.py").is_file() and (folder / "model.py").is_file()
    assert ENGINE_MODULES[engine].startswith(f"harness.engines.{engine}")
    module = importlib.import_module(ENGINE_MODULES[engine])
    assert module.ENGINE.name == engine
    for scene in available_scenes():  # a default integrator, or the scene says why the engine does not run it
        s = load_scene(scene)
        assert engine in s.integrators or engine in s.not_run, f"models/{scene}/scene.toml: no default integrator for {engine}"


@pytest.mark.parametrize("study", STUDIES)
def test_study_follows_the_recipe(study):
    folder = ROOT / "harness" / "studies" / study
    assert (folder / "run.py").is_file() and (folder / "report.py").is_file()
    assert (ROOT / "harness" / "cli" / f"{study}.py").is_file()
    assert (ROOT / "tests" / "studies" / f"test_{study}.py").is_file()
    assert f"harness.cli import {study}" in (ROOT / "harness" / "cli" / "main.py").read_text()



def test_the_engine_recipe_touches_harness_only_in_the_engines_and_the_loader_tools():
    """An engine's addition touches ``harness/``'s code only in its folder and the registry (and,
    for a loader ``check`` and ``zoo`` compare, those tools; the stress catalogue is data): every
    other module asks the registry (``tests/engines/test_engine_names.py``)."""
    section = TEXT[TEXT.index("## An engine"):TEXT.index("## A study")]
    paths = re.findall(r"`(harness/[^`\s]*)`", section)
    allowed = ("harness/engines/", "harness/tools/check/", "harness/tools/zoo.py", "harness/studies/stress/catalogue.toml")
    assert paths and all(p.startswith(allowed) for p in paths), paths
