"""An engine is named in two places only: its folder ``harness/engines/<engine>/`` and the
registry ``harness/engines/__init__.py`` (its ``Declaration``: name, display name, library,
model files, capabilities, curves). Everything else asks the registry. Like the scene-name guard
(``tests/references/test_scene_names.py``) the sources are parsed, not grepped: identifiers,
imports and string constants count, comments and docstrings (which may cite an engine as an
example) do not.

The exceptions, each with why (``EXCEPTIONS``): a study that is about one engine's own settings
names it in one constant of that study; the loaders' tools name the loaders (the importers' known
behaviour is per loader) and the witnesses that build the system from the description; the
model layer's joint table and MJCF reader, which the registry (a higher layer) cannot serve."""

from __future__ import annotations

import ast
import re
from dataclasses import dataclass
from pathlib import Path

import pytest

from harness.engines import DECLARATIONS, ENGINE_NAMES, IDEAL, LOADERS, SOFT, declaration, get_engine

ROOT = Path(__file__).resolve().parents[2]
SOURCES = (ROOT / "harness", ROOT / "references")
REGISTRY = ROOT / "harness" / "engines"  # the registry and the engines' own folders

ALL = frozenset(ENGINE_NAMES)
#: The loaders (``Declaration.reads``) and the witnesses of their reading (the engines that build
#: the system from the scene's description, ``reads`` empty): what the loader tools compare.
LOADER_TOOLS = frozenset(LOADERS) | frozenset(d.name for d in DECLARATIONS if not d.reads)


@dataclass(frozen=True)
class Exception_:
    """Where an engine may be named outside the registry: ``path`` (a file or a folder, from the
    repository's root), ``definition`` (the one top-level constant or function of that file that
    may name it; "" for the whole file), ``engines`` (which names) and ``why``."""

    path: str
    definition: str
    engines: frozenset
    why: str


EXCEPTIONS = (
    Exception_("harness/studies/rolling/__init__.py", "SETTINGS_ENGINE", ALL,
               "the rolling study measures MuJoCo's contact settings (solref, solimp, cone, impratio), "
               "which no other engine has"),
    Exception_("harness/studies/loops/__init__.py", "SOFT_LOOP_ENGINE", ALL,
               "the loop study varies MuJoCo's <connect> solref/solimp, which no other engine has"),
    Exception_("harness/studies/workprecision/__init__.py", "BASELINE", ALL,
               "the work-precision targets are set against MuJoCo RK4 and mujoco.rollout"),
    Exception_("harness/tools/check", "", LOADER_TOOLS, "the importers' known behaviour is per loader"),
    Exception_("harness/tools/zoo.py", "", LOADER_TOOLS, "the importers' known behaviour is per loader"),
    Exception_("harness/tools/witnesses.py", "", LOADER_TOOLS,
               "check's witnesses: the engines that build the system from the description, against the loaders"),
    Exception_("harness/tools/loaded_models.py", "", LOADER_TOOLS,
               "what each loader holds after reading a file, as only check reads it back"),
    Exception_("harness/tools/dynamics_terms.py", "", LOADER_TOOLS,
               "each loader's mass matrix and bias forces, in its own API (check, inspect)"),
    Exception_("harness/tools/inspection.py", "", LOADER_TOOLS,
               "harness inspect: each loader's reading of the scene's files, and the cross-loads"),
    Exception_("harness/cli/tools.py", "", LOADER_TOOLS,
               "the loader tools' command line: its help says what each loader reads"),
    Exception_("harness/model/joints.py", "", ALL,
               "the one table of joint kinds, each kind's name in each engine's vocabulary (CONTRIBUTING's "
               "joint recipe); the model layer cannot ask the registry (a higher layer)"),
    Exception_("harness/model/from_model_file.py", "", frozenset(LOADERS),
               "a scene without code is read from its file by MuJoCo's compiler (the MJCF and URDF reader); "
               "the model layer cannot ask the registry"),
    Exception_("harness/model/input_files.py", "_check_urdf_references", ALL,
               "<mujoco><compiler meshdir> is an element of the URDF file, not the engine"),
    Exception_("harness/model/model_files.py", "mjcf_text", ALL,
               "<mujoco> is the root element of the MJCF a generated scene's files hold, not the engine"),
    Exception_("references/errata.py", "", ALL, "an erratum cites the engines' runs that confirm it (its record's prose)"),
)

#: Each engine's names: registered name, display name and library (``pydrake``).
WORDS = sorted({w for d in DECLARATIONS for w in (d.name, d.display, d.library) if w}, key=len, reverse=True)
PATTERN = re.compile(r"(?<![A-Za-z0-9])(" + "|".join(map(re.escape, WORDS)) + r")(?![A-Za-z0-9])", re.IGNORECASE)


def _sources() -> list[Path]:
    return sorted(p for root in SOURCES for p in root.rglob("*.py")
                  if "__pycache__" not in p.parts and not p.is_relative_to(REGISTRY))


def _code_words(tree: ast.AST):
    """(line, text) of every identifier, imported name and string constant that is not a docstring."""
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
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            yield node.lineno, node.name
        elif isinstance(node, ast.arg):
            yield node.lineno, node.arg
        elif isinstance(node, ast.keyword) and node.arg:
            yield node.lineno, node.arg
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            if isinstance(node, ast.ImportFrom) and node.module:
                yield node.lineno, node.module
            for alias in node.names:
                yield node.lineno, alias.name
                if alias.asname:
                    yield node.lineno, alias.asname


def _definition_lines(tree: ast.Module, name: str) -> range:
    """The lines of top-level constant or function ``name`` (empty when there is none)."""
    for node in tree.body:
        named = (isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)) and node.name == name) or (
            isinstance(node, (ast.Assign, ast.AnnAssign))
            and any(isinstance(t, ast.Name) and t.id == name for t in (node.targets if isinstance(node, ast.Assign)
                                                                         else [node.target])))
        if named:
            return range(node.lineno, node.end_lineno + 1)
    return range(0)


def _engine_of(word: str) -> str:
    return next(d.name for d in DECLARATIONS if word.lower() in {w.lower() for w in (d.name, d.display, d.library) if w})


def leaks(relative: str, source: str, exceptions=EXCEPTIONS) -> list[str]:
    """``"<path>:<line>: <word>"`` for every engine name in the code of ``source`` (the file at
    ``relative``, from the repository's root) that no exception allows."""
    tree = ast.parse(source)
    mine = [e for e in exceptions if relative == e.path or relative.startswith(e.path.rstrip("/") + "/")]
    allowed = [(e.engines, _definition_lines(tree, e.definition) if e.definition else None) for e in mine]
    found = set()
    for line, text in _code_words(tree):
        for m in PATTERN.finditer(text):
            engine = _engine_of(m.group(1))
            if any(engine in names and (lines is None or line in lines) for names, lines in allowed):
                continue
            found.add(f"{relative}:{line}: {m.group(1)}")
    return sorted(found)


@pytest.mark.parametrize("path", _sources(), ids=lambda p: str(p.relative_to(ROOT)))
def test_no_engine_is_named_outside_the_registry(path):
    """Parsed, not grepped: identifiers, imports and string constants count, comments and docstrings not."""
    found = leaks(str(path.relative_to(ROOT)), path.read_text())
    assert not found, ("engine names in code outside harness/engines/ (ask harness.engines, or state the exception "
                       "in tests/engines/test_engine_names.py with why):\n" + "\n".join(found))


def test_the_guard_fails_on_a_planted_name(tmp_path):
    """A name planted in code fails (in a module without an exception, and in an excepted one outside
    its constant); the same name in a docstring or a comment does not."""
    relative = "harness/validate/run.py"
    source = (ROOT / relative).read_text()
    assert leaks(relative, source) == []
    planted = tmp_path / "run.py"
    planted.write_text(source + '\n\ndef planted():\n    """Runs MuJoCo."""  # and Drake\n    return "mujoco"\n')
    found = leaks(relative, planted.read_text())
    assert len(found) == 1 and found[0].endswith(": mujoco"), found
    assert leaks(relative, source + "\nimport pinocchio  # noqa\n") == [f"{relative}:{source.count(chr(10)) + 2}: pinocchio"]
    study = "harness/studies/rolling/__init__.py"
    text = (ROOT / study).read_text()
    assert leaks(study, text) == []
    assert leaks(study, text + '\nOTHER = "Drake"\n') == [f"{study}:{text.count(chr(10)) + 2}: Drake"]
    assert leaks(study, text, exceptions=()) != []  # the constant itself names an engine: only its exception allows it


def test_every_exception_is_used_and_says_why():
    """Each exception's file (or folder) and definition exist and still name an engine there: one
    that no longer does is dropped, not kept."""
    for e in EXCEPTIONS:
        where = ROOT / e.path
        assert where.exists(), e.path
        assert e.why.strip(), e.path
        files = sorted(where.rglob("*.py")) if where.is_dir() else [where]
        if e.definition:
            assert _definition_lines(ast.parse(where.read_text()), e.definition), f"{e.path}: no {e.definition}"
        unexcepted = [x for x in EXCEPTIONS if x is not e]
        assert any(leaks(str(f.relative_to(ROOT)), f.read_text(), unexcepted) for f in files), \
            f"{e.path} {e.definition}: names no engine any more: drop the exception"


def test_the_studies_exceptions_name_an_engine_that_has_what_the_study_measures():
    from harness.studies.loops import SOFT_LOOP_ENGINE
    from harness.studies.rolling import SETTINGS_ENGINE
    from harness.studies.workprecision import BASELINE

    assert declaration(SETTINGS_ENGINE).rolling == SOFT
    assert declaration(SOFT_LOOP_ENGINE).loops == SOFT
    assert declaration(BASELINE).library and any(c.variant == "rollout" for c in declaration(BASELINE).curves)


def test_the_registry_declares_what_the_engines_hold():
    """Each declaration names its engine's module, whose ``ENGINE`` has that name; the curves it
    declares are integrators the engine has; a loader has ``load_model_file``; one reference
    engine, with ideal loops and rolling (the comparison for every other)."""
    for d in DECLARATIONS:
        engine = get_engine(d.name)
        assert engine.name == d.name
        assert all(c.integrator in engine.integrators for c in d.curves), d.name
        assert bool(d.reads) == hasattr(engine, "load_model_file"), d.name
        assert all(f in ("mjcf", "urdf") for f in d.reads), d.name
    reference = [d for d in DECLARATIONS if d.reference]
    assert len(reference) == 1 and reference[0].loops == IDEAL and reference[0].rolling == IDEAL


def _readme_engines(text: str) -> dict[str, set[str]]:
    """The README's "Engines:" paragraph as ``{engine: its integrators}``: each backticked name
    outside parentheses followed by its parenthesised list, whose backticked words are its methods."""
    start = text.index("\nEngines: ") + len("\nEngines: ")
    para = text[start:text.index("`--set KEY=VALUE`", start)]
    out: dict[str, set[str]] = {}
    depth, i = 0, 0
    while i < len(para):
        m = re.compile(r"`(\w+)` \(").match(para, i) if depth == 0 else None
        if m:
            j, level = m.end(), 1
            while level:
                level += {"(": 1, ")": -1}.get(para[j], 0)
                j += 1
            out[m.group(1)] = set(re.findall(r"`(\w+)`", para[m.end():j - 1]))
            i = j
            continue
        depth += {"(": 1, ")": -1}.get(para[i], 0)
        i += 1
    return out


def test_the_readme_and_the_package_description_list_the_registered_engines():
    """The README's engine list (each engine with exactly its integrators, in registry order), its
    layout table (one folder per engine) and ``pyproject.toml``'s description are checked against
    the registry, as ``harness --help`` is generated from it."""
    readme = (ROOT / "README.md").read_text()
    listed = _readme_engines(readme)
    assert list(listed) == list(ENGINE_NAMES)
    for name, methods in listed.items():
        assert methods == set(get_engine(name).integrators), name
    row = next(line for line in readme.splitlines() if line.startswith("| `harness/engines/` |"))
    assert set(re.findall(r"`(\w+)/`", row)) >= set(ENGINE_NAMES)
    description = next(line for line in (ROOT / "pyproject.toml").read_text().splitlines()
                       if line.startswith("description"))
    assert all(d.display.lower() in description.lower() for d in DECLARATIONS), description


def test_the_help_names_every_registered_engine():
    from harness.cli.main import build_parser

    text = " ".join(build_parser().format_help().split())
    assert ", ".join(ENGINE_NAMES) in text
