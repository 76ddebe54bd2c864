"""A system lives in two places only: its folder in ``models/`` and its module in ``references/``
(plus at most one builder, ``harness/model/builders/<scene>.py``). The harness's own code names no
scene: no per-scene tables, overrides or special cases. The rolling-disk study
(``harness/studies/rolling/`` and its command ``harness/cli/rolling.py``) is a study of that one
system and may name it. Docstrings and comments may cite a scene as an example; code may not."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

from harness.model.scene import available_scenes

ROOT = Path(__file__).resolve().parents[2]
HARNESS = ROOT / "harness"
ALLOWED = (HARNESS / "model" / "builders", HARNESS / "studies" / "rolling", HARNESS / "cli" / "rolling.py")
SCENES = available_scenes()


def _sources() -> list[Path]:
    return sorted(p for p in HARNESS.rglob("*.py")
                  if "__pycache__" not in p.parts and not any(p.is_relative_to(a) for a in ALLOWED))


def test_every_scene_has_its_folder_and_reference_module():
    for name in SCENES:
        assert (ROOT / "models" / name / "scene.toml").is_file()
        assert (ROOT / "references" / f"{name}.py").is_file(), f"no references/{name}.py"


def test_builders_are_one_module_per_scene_at_most():
    builders = {p.stem for p in (HARNESS / "model" / "builders").glob("*.py") if p.stem != "__init__"}
    assert builders <= set(SCENES), sorted(builders - set(SCENES))


def _code_words(tree: ast.AST):
    """(line, text) of every identifier and every string constant that is not a docstring."""
    docstrings = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) and isinstance(first.value.value, str):
                docstrings.add(id(first.value))
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docstrings:
            yield node.lineno, node.value
        elif isinstance(node, ast.Name):
            yield node.lineno, node.id
        elif isinstance(node, ast.Attribute):
            yield node.lineno, node.attr


@pytest.mark.parametrize("path", _sources(), ids=lambda p: str(p.relative_to(ROOT)))
def test_the_harness_names_no_scene(path):
    """Parsed, not grepped: identifiers and string constants count, comments and docstrings not."""
    pattern = re.compile(r"(?<![A-Za-z0-9])(" + "|".join(map(re.escape, sorted(SCENES, key=len, reverse=True))) + r")(?![A-Za-z0-9_])")
    found = sorted({f"{path.relative_to(ROOT)}:{line}: {m.group(1)}"
                    for line, text in _code_words(ast.parse(path.read_text())) for m in pattern.finditer(text)})
    assert not found, "scene names in code outside models/, references/ and the builders:\n" + "\n".join(found)
