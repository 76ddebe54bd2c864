"""A plain (non-editable) install carries every scene, reference and catalogue.

``pyproject.toml`` installs the repository's ``models/`` and ``references/`` folders inside the
package (``harness.models``, ``harness.references``); these tests build the wheel, install it into
a bare folder and run the harness from there, away from the checkout.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover
    import tomli as tomllib

import pytest

from harness.model.scene import available_scenes

ROOT = Path(__file__).resolve().parents[1]


def test_every_package_folder_is_listed_in_pyproject():
    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    found = {".".join(p.parent.relative_to(ROOT).parts) for p in (ROOT / "harness").rglob("__init__.py")}
    assert found | {"harness.references", "harness.models"} == listed


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> Path:
    """The wheel built from this checkout, installed (without dependencies) into a bare folder."""
    tmp = tmp_path_factory.mktemp("wheel")
    src = tmp / "src"  # a copy, so that the build leaves nothing in the checkout
    src.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(ROOT / name, src / name)
    for name in ("harness", "models", "references"):
        shutil.copytree(ROOT / name, src / name, ignore=shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc"))
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check", "-q"]
    subprocess.run([*pip, "wheel", "--no-deps", "-w", str(tmp / "dist"), str(src)], check=True, capture_output=True)
    (wheel,) = (tmp / "dist").glob("harness-*.whl")
    subprocess.run([*pip, "install", "--no-deps", "--target", str(tmp / "site"), str(wheel)], check=True,
                   capture_output=True)
    return tmp


def _run_installed(installed: Path, *args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(installed / "site")}
    return subprocess.run([sys.executable, *args], cwd=installed, env=env, capture_output=True, text=True, timeout=300)


@pytest.mark.slow
def test_wheel_holds_every_scene_and_reference(installed):
    code = (
        "import harness, harness.references.errata as e\n"
        "from harness.model.scene import available_scenes, load_scene, MODELS_DIR\n"
        "from harness.studies.stress.run import DEFAULT_CATALOGUE\n"
        "from harness.tools.check import known_limitations as kl\n"
        "print(harness.__file__)\n"
        "print(','.join(available_scenes()))\n"
        "for s in available_scenes(): load_scene(s).multibody()\n"
        "print(DEFAULT_CATALOGUE.is_file(), e.ERRATA_PATH.is_file(), len(kl.table()) > 0)\n"
    )
    proc = _run_installed(installed, "-c", code)
    assert proc.returncode == 0, proc.stderr
    where, scenes, files = proc.stdout.strip().splitlines()
    assert Path(where).is_relative_to(installed / "site")
    assert scenes.split(",") == available_scenes() and len(available_scenes()) >= 9
    assert files == "True True True"   # the stress catalogue, the errata, check's known importer limitations


@pytest.mark.slow
def test_wheel_validates_a_scene(installed):
    """``--per-state``: the installed copy has a Numba cache of its own, and compiling the
    reference's kernel there would add a minute to the suite; the compiled kernels' source is in
    the wheel (checked here) and the compiled runs are tested from the checkout."""
    out = installed / "reports"
    proc = _run_installed(installed, "-m", "harness.cli.main", "validate", "--scenes", "rotating_plate",
                          "--engines", "mujoco", "--per-state", "--out-dir", str(out))
    assert proc.returncode == 0, proc.stderr
    assert (installed / "site" / "harness" / "engines" / "inhouse" / "compiled" / "kernels.py").is_file()
    assert "rotating_plate: PASS" in proc.stdout
    assert (out / "validation.json").is_file()
