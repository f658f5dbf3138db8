"""The package's imports (ffsm_pin/__init__.py, docs/api.md):

* layers import downwards only: robot, attitude -> model -> control -> scenario -> sim ->
  sweep. A module may import its own layer and the layers below it, never one above, except
  for annotations under ``if TYPE_CHECKING:`` (which never run: the controller interface names
  the scenario type it is handed this way);
* no import cycle among the package's modules, neither through the imports that run when a
  module is loaded nor through those deferred into functions (imports under
  ``if TYPE_CHECKING:`` never run and do not count);
* the module paths removed in 0.2.0 (CHANGELOG.md, "old path -> new path") are gone and their
  new places import;
* no module is longer than :data:`MAX_LINES` lines, except those of :data:`STILL_TO_SPLIT`.
"""

from __future__ import annotations

import ast
import importlib
import re
from collections.abc import Iterator, Mapping
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "ffsm_pin"
# layer of each subpackage, bottom up; modules at the top level (errors, _arrays, ...) are 0
LAYERS = {"robot": 1, "attitude": 1, "model": 2, "control": 3, "scenario": 4, "sim": 5,
          "sweep": 6}  # fmt: skip
MODULE, FUNCTION, TYPE_CHECKING = "module", "function", "type-checking"


def _module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {_module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def _layer(module: str) -> int:
    parts = module.split(".")
    return LAYERS.get(parts[1], 0) if len(parts) > 1 else 0


def _known(target: str, modules: Mapping[str, object]) -> str:
    """The module a dotted name lives in: the longest prefix that is a module."""
    while target not in modules and "." in target:
        target = target.rsplit(".", 1)[0]
    return target


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _imports(
    source: str, module: str, is_pkg: bool, modules: Mapping[str, object] = MODULES
) -> Iterator[tuple[str, int, str]]:
    """Every ffsm_pin module that ``source`` (the text of ``module``) imports, absolute or
    relative, with the line and where the import runs: :data:`MODULE` (when the module is
    loaded), :data:`FUNCTION` (deferred into a function) or :data:`TYPE_CHECKING` (never)."""
    base = module.split(".") if is_pkg else module.split(".")[:-1]

    def visit(node: ast.AST, where: str) -> Iterator[tuple[str, int, str]]:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.ImportFrom):
                if child.level:
                    stem = base[: len(base) - child.level + 1]
                    prefix = ".".join(stem + ([child.module] if child.module else []))
                else:
                    prefix = child.module or ""
                if prefix.startswith("ffsm_pin"):
                    # `from . import period`: the submodule; `from .x import name`: x
                    targets = {_known(f"{prefix}.{a.name}", modules) for a in child.names}
                    for target in sorted(targets):
                        yield target, child.lineno, where
            elif isinstance(child, ast.Import):
                for alias in child.names:
                    if alias.name.startswith("ffsm_pin"):
                        yield _known(alias.name, modules), child.lineno, where
            elif isinstance(child, ast.If) and _is_type_checking(child.test):
                for stmt in child.body:
                    yield from visit(ast.Module(body=[stmt], type_ignores=[]), TYPE_CHECKING)
                for stmt in child.orelse:
                    yield from visit(ast.Module(body=[stmt], type_ignores=[]), where)
            elif isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
                yield from visit(child, TYPE_CHECKING if where == TYPE_CHECKING else FUNCTION)
            else:
                yield from visit(child, where)

    yield from visit(ast.parse(source), MODULE)


def _graph(kinds: set[str]) -> dict[str, set[str]]:
    """module -> the package's modules it imports, counting the imports of ``kinds``."""
    graph: dict[str, set[str]] = {}
    for module, path in MODULES.items():
        found = _imports(path.read_text(), module, path.name == "__init__.py")
        graph[module] = {t for t, _, where in found if where in kinds and t != module}
    return graph


def _cycles(graph: Mapping[str, set[str]]) -> list[list[str]]:
    """The import cycles of ``graph``: one path a -> ... -> a per strongly connected group of
    two or more modules (Tarjan's algorithm), sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    groups: list[list[str]] = []

    def connect(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                connect(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                groups.append(sorted(group))

    for v in sorted(graph):
        if v not in index:
            connect(v)
    return sorted(_path_through(graph, set(g), g[0]) for g in groups)


def _path_through(graph: Mapping[str, set[str]], group: set[str], start: str) -> list[str]:
    """A cycle start -> ... -> start inside ``group`` (breadth-first: a shortest one)."""
    previous: dict[str, str] = {}
    frontier = [start]
    while frontier:
        nxt = []
        for v in frontier:
            for w in sorted(graph[v] & group):
                if w == start:
                    path = [v]
                    while path[-1] != start:
                        path.append(previous[path[-1]])
                    return [start, *reversed(path[:-1]), start]
                if w not in previous:
                    previous[w] = v
                    nxt.append(w)
        frontier = nxt
    raise AssertionError(f"no cycle through {start}")  # pragma: no cover


def test_imports_run_downwards():
    upward = []
    for module, path in MODULES.items():
        if module == "ffsm_pin":  # the top level: its public names, loaded lazily
            continue
        for target, line, where in _imports(path.read_text(), module, path.name == "__init__.py"):
            if _layer(target) > _layer(module) and where != TYPE_CHECKING:
                upward.append(f"{path.relative_to(ROOT)}:{line} imports {target}")
    assert not upward, "imports that run upwards:\n" + "\n".join(upward)


@pytest.mark.parametrize(
    "kinds", [{MODULE}, {MODULE, FUNCTION}], ids=["when-loaded", "with-deferred"]
)
def test_no_import_cycle(kinds):
    """A cycle through imports that run when a module is loaded fails at import time for one
    of its orders; one closed by a deferred import (inside a function) still ties two modules
    together. Break it by moving the shared piece into a module both import, or by importing
    a name needed only for annotations under ``if TYPE_CHECKING:``."""
    cycles = _cycles(_graph(kinds))
    assert not cycles, "import cycles:\n" + "\n".join(" -> ".join(c) for c in cycles)


def test_the_cycle_finder_sees_what_it_must():
    """The parser tells the three kinds of import apart and the cycle finder reports cycles
    (the two tests above could otherwise pass by seeing nothing)."""
    modules = dict.fromkeys(["ffsm_pin.a", "ffsm_pin.b", "ffsm_pin.c", "ffsm_pin.pkg"])
    source = (
        "from typing import TYPE_CHECKING\n"
        "from . import b\n"
        "from .c import name\n"
        "if TYPE_CHECKING:\n"
        "    from .pkg import Thing\n"
        "def f():\n"
        "    import ffsm_pin.pkg.inner\n"
    )
    found = sorted((t, w) for t, _, w in _imports(source, "ffsm_pin.a", False, modules))
    assert found == [
        ("ffsm_pin.b", MODULE),
        ("ffsm_pin.c", MODULE),
        ("ffsm_pin.pkg", FUNCTION),
        ("ffsm_pin.pkg", TYPE_CHECKING),
    ]
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}, "e": {"e"}}
    assert _cycles(graph) == [["a", "b", "c", "a"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []
    # the package as it is: a deferred import is seen as one (sim/result.py draws figures)
    deferred = _graph({FUNCTION})
    assert any(targets for targets in deferred.values())


def _removed_paths() -> list[tuple[str, str]]:
    """(old, new) module paths of the CHANGELOG's 0.2.0 table "old path -> new path"."""
    text = (ROOT / "CHANGELOG.md").read_text()
    section = text.split("\n## 0.2.0", 1)[1].split("\n## ", 1)[0]
    rows = re.findall(r"^ *\| `(ffsm_pin[\w.]*)`[^|]*\| `(ffsm_pin[\w.]*)`", section, flags=re.M)
    assert len(rows) >= 15, "the CHANGELOG's 0.2.0 table of removed module paths"
    return rows


@pytest.mark.parametrize(("old", "new"), _removed_paths())
def test_removed_module_paths_are_gone(old, new):
    with pytest.raises(ImportError):
        importlib.import_module(old)
    importlib.import_module(new)
    assert old not in MODULES


#: The most lines a module of the package may have (issue 36: modules by concern).
MAX_LINES = 500
#: Modules still over :data:`MAX_LINES`, to be split by concern (each leaves this list when it
#: is; a new module over the limit is not added here but split).
STILL_TO_SPLIT: set[str] = set()


def _lines(path: Path) -> int:
    return len(path.read_text().splitlines())


def test_no_module_is_longer_than_the_limit():
    too_long = {
        str(p.relative_to(ROOT)): _lines(p)
        for p in MODULES.values()
        if _lines(p) > MAX_LINES and str(p.relative_to(ROOT)) not in STILL_TO_SPLIT
    }
    assert not too_long, f"modules over {MAX_LINES} lines (split them by concern): {too_long}"


@pytest.mark.parametrize("module", sorted(STILL_TO_SPLIT))
def test_the_modules_still_to_split_are_still_too_long(module):
    """A module split since leaves :data:`STILL_TO_SPLIT`, so the limit holds for it too."""
    path = ROOT / module
    assert path.is_file(), f"{module} is gone: remove it from STILL_TO_SPLIT"
    assert _lines(path) > MAX_LINES, f"{module} is within the limit: remove it from STILL_TO_SPLIT"
