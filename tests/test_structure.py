"""The module structure stays as ``CONTRIBUTING.md`` ("Layers") states it: no import cycle between
modules, and no import from a higher layer into a lower one.

What counts as an import: every ``import`` and ``from ... import`` statement in a module's source,
read with ``ast``, wherever it stands: at module level, inside a function or method (a lazy
import), under ``if TYPE_CHECKING:``, inside ``try``. A lazy or type-only import that exists to
dodge a cycle leaves the two modules just as entangled (neither can be read, tested or moved
without the other), so it is that cycle, and it counts. ``from package import name`` is an
import of the submodule ``package.name`` where one exists, else of ``package`` (its
``__init__``); the packages' ``__init__`` that importing a submodule also runs are not counted.
Imports by computed name (``importlib.import_module(f"...")``: the engine registry, the builders,
the references looked up by scene name) are not seen.

The modules are those of the installed package: ``harness/`` and the folders ``pyproject.toml``
installs inside it (``references/`` as ``harness.references``, ``models/``). A cycle between any
of them fails (a). The layers are read from one place, the table of ``CONTRIBUTING.md``'s
"Layers" section (``layers()``): a module of ``harness/<package>/`` may import only from packages
of lower layers (and its own); a package of the same layer or a higher one fails (b), as does a
package of ``harness/`` the table does not place. ``harness.references`` is outside the layers
(``CONTRIBUTING.md`` says why); the cycle check covers it.
"""

from __future__ import annotations

import ast
import re
from dataclasses import dataclass
from pathlib import Path

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover
    import tomli as tomllib


ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Import:
    """One import statement's target: ``source`` imports ``target`` at ``path:line``."""

    source: str
    target: str
    path: str
    line: int

    def __str__(self) -> str:
        return f"{self.path}:{self.line} imports {self.target}"


def package_folders(root: Path = ROOT) -> dict[str, Path]:
    """Package name -> folder of the installed package: ``harness`` and the folders
    ``pyproject.toml``'s ``package-dir`` puts inside it."""
    setuptools = tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"]
    return {"harness": root / "harness"} | {name: root / folder for name, folder in setuptools.get("package-dir", {}).items()}


def modules(root: Path = ROOT) -> dict[str, Path]:
    """Dotted module name -> its source file, for every module of the installed package."""
    out = {}
    for package, folder in package_folders(root).items():
        for path in sorted(folder.rglob("*.py")):
            parts = path.relative_to(folder).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out[".".join((package, *parts))] = path
    return out


def imports_of(name: str, path: Path, known: dict[str, Path], root: Path = ROOT) -> list[Import]:
    """The imports of module ``name`` (source ``path``) of modules in ``known``, in source order."""
    tree = ast.parse(path.read_text(), str(path))
    here = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    where = path.relative_to(root).as_posix()
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:  # relative: from the package, up level - 1
                base = ".".join(here[:len(here) - node.level + 1] + ([base] if base else []))
            targets = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in known else base for alias in node.names]
        else:
            continue
        found += [Import(name, t, where, node.lineno) for t in targets if t in known and t != name]
    return sorted(set(found), key=lambda i: (i.line, i.target))


def import_graph(root: Path = ROOT) -> dict[str, list[Import]]:
    """Module -> its imports of the package's modules (``imports_of``)."""
    known = modules(root)
    return {name: imports_of(name, path, known, root) for name, path in known.items()}


@dataclass(frozen=True)
class Cycle:
    """Modules that import each other, directly or through one another (a strongly connected
    component of more than one module): ``modules``; ``path``, the imports of a shortest cycle
    from the first of them back to it; ``imports``, every import between them."""

    modules: frozenset[str]
    path: tuple[Import, ...]
    imports: tuple[Import, ...]

    def __str__(self) -> str:
        """``a -> b -> a (a.py:3 imports b; b.py:40 imports a)``, then the group's other imports."""
        names = " -> ".join([self.path[0].source] + [imp.target for imp in self.path])
        text = f"{names} ({'; '.join(map(str, self.path))})"
        others = [imp for imp in self.imports if imp not in self.path]
        return text + (f"; in the same tangle: {'; '.join(map(str, others))}" if others else "")


def import_cycles(graph: dict[str, list[Import]]) -> list[Cycle]:
    """Every group of modules that import each other (``Cycle``), by first module; [] when none."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    groups: list[frozenset[str]] = []

    def visit(v: str) -> None:  # Tarjan's algorithm
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for imp in graph[v]:
            w = imp.target
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = set()
            while True:
                w = stack.pop()
                on_stack.discard(w)
                group.add(w)
                if w == v:
                    break
            if len(group) > 1:
                groups.append(frozenset(group))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return [Cycle(group, _shortest_cycle(graph, group),
                  tuple(imp for v in sorted(group) for imp in graph[v] if imp.target in group))
            for group in sorted(groups, key=min)]


def _shortest_cycle(graph: dict[str, list[Import]], group: frozenset[str]) -> tuple[Import, ...]:
    """A shortest cycle from the first module of ``group`` back to it, inside ``group``."""
    start = min(group)
    paths: dict[str, tuple[Import, ...]] = {start: ()}
    frontier = [start]
    while frontier:  # breadth first
        following = []
        for v in frontier:
            for imp in graph[v]:
                if imp.target == start:
                    return paths[v] + (imp,)
                if imp.target in group and imp.target not in paths:
                    paths[imp.target] = paths[v] + (imp,)
                    following.append(imp.target)
        frontier = following
    raise AssertionError(f"no cycle in {sorted(group)}")  # pragma: no cover - a component of >1 has one


def layers(text: str | None = None) -> dict[str, int]:
    """Package of ``harness/`` -> its layer (1 the lowest), from the table of ``CONTRIBUTING.md``'s
    "Layers" section: rows ``| <layer> | `harness/<package>/`, ... | ... |``."""
    text = (ROOT / "CONTRIBUTING.md").read_text() if text is None else text
    section = text.split("\n## Layers\n", 1)[1].split("\n## ", 1)[0]
    out = {}
    for row in re.finditer(r"^\|\s*(\d+)\s*\|([^|]*)\|", section, re.MULTILINE):
        for package in re.findall(r"`harness/(\w+)/`", row.group(2)):
            out[package] = int(row.group(1))
    return out


def _package(module: str) -> str | None:
    """``engines`` for ``harness.engines.mujoco.model``; None for ``harness`` itself."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else None


def upward_imports(graph: dict[str, list[Import]], order: dict[str, int]) -> list[Import]:
    """The imports from a package into one of the same or a higher layer (``order``); packages
    outside ``order`` (``references``, ``models``) are outside the layers."""
    out = []
    for imports in graph.values():
        for imp in imports:
            a, b = _package(imp.source), _package(imp.target)
            if a != b and a in order and b in order and order[b] >= order[a]:
                out.append(imp)
    return out


# ------------------------------------------------------------------------------------ the tests
GRAPH = import_graph()


def test_modules_are_found_and_imports_read():
    """The scan sees what it must: the package's modules, and imports at module level, inside
    functions and under TYPE_CHECKING."""
    assert {"harness.model.scene", "harness.cli.main", "harness.references.rolling_disk"} <= set(GRAPH)
    targets = {imp.target for imp in GRAPH["harness.model.builders.rolling_disk"]}
    assert {"harness.model.rolling_contact", "harness.references.rolling_disk"} <= targets  # module level, lazy
    assert "harness.model.scene" in {imp.target for imp in GRAPH["harness.measure.exact"]}  # TYPE_CHECKING


def test_there_is_no_import_cycle():
    cycles = import_cycles(GRAPH)
    assert not cycles, "import cycles (move the piece both need to the module where it belongs):\n" + \
        "\n".join(map(str, cycles))



def test_every_package_has_a_layer():
    order = layers()
    packages = {p.name for p in (ROOT / "harness").iterdir() if (p / "__init__.py").is_file()}
    assert packages <= set(order), f"CONTRIBUTING.md's Layers table places no {sorted(packages - set(order))}"
    assert order["model"] < order["engines"] < order["validate"] < order["cli"]


def test_no_layer_imports_from_a_higher_one():
    order = layers()
    found = upward_imports(GRAPH, order)
    assert not found, "imports from the same or a higher layer (CONTRIBUTING.md, Layers):\n" + "\n".join(
        f"{imp} (layer {order[_package(imp.source)]} -> {order[_package(imp.target)]})" for imp in found)


# ------------------------------------------------------------------------------------ the test fails
def _tree(tmp_path: Path, files: dict[str, str]) -> Path:
    """A package ``harness`` with ``files`` (path under harness/ -> source) and a pyproject."""
    (tmp_path / "pyproject.toml").write_text("[tool.setuptools]\npackages = []\n")
    for rel, source in files.items():
        path = tmp_path / "harness" / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        for folder in [path.parent, *path.parent.parents]:
            if folder == tmp_path:
                break
            (folder / "__init__.py").touch()
        path.write_text(source)
    return tmp_path


def test_a_planted_cycle_is_found_and_named(tmp_path):
    """A cycle closed by a lazy import, one through three modules, and one closed by a
    TYPE_CHECKING import are each found; a one-way import is none."""
    root = _tree(tmp_path, {
        "model/a.py": "from harness.model.b import x\n",
        "model/b.py": "x = 1\ndef f():\n    from harness.model import a\n",
        "engines/p.py": "from . import q\n",
        "engines/q.py": "import harness.engines.r\n",
        "engines/r.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from harness.engines.p import T\n",
        "io/one_way.py": "from harness.model import a\n",
    })
    cycles = import_cycles(import_graph(root))
    assert [str(c) for c in cycles] == [
        "harness.engines.p -> harness.engines.q -> harness.engines.r -> harness.engines.p "
        "(harness/engines/p.py:1 imports harness.engines.q; harness/engines/q.py:1 imports harness.engines.r; "
        "harness/engines/r.py:3 imports harness.engines.p)",
        "harness.model.a -> harness.model.b -> harness.model.a "
        "(harness/model/a.py:1 imports harness.model.b; harness/model/b.py:3 imports harness.model.a)",
    ]


def test_a_planted_upward_import_is_found(tmp_path):
    """An import into a higher layer (lazy), and one into another package of the same layer, are
    each found; downward imports and imports inside a package are not."""
    root = _tree(tmp_path, {
        "model/a.py": "def f():\n    from harness.engines import base\n",
        "engines/base.py": "from harness.model import a\nfrom harness.engines import other\n",
        "engines/other.py": "",
        "studies/s.py": "from harness.tools import t\n",
        "tools/t.py": "from harness.engines.base import x\n",
    })
    order = layers("# Contributing\n\n## Layers\n\n| layer | packages |\n|---|---|\n"
                   "| 1 | `harness/model/` |\n| 2 | `harness/engines/` |\n| 3 | `harness/studies/`, `harness/tools/` |\n"
                   "\n## Next\n")
    assert order == {"model": 1, "engines": 2, "studies": 3, "tools": 3}
    assert [str(i) for i in upward_imports(import_graph(root), order)] == [
        "harness/model/a.py:2 imports harness.engines.base",
        "harness/studies/s.py:1 imports harness.tools.t",
    ]
