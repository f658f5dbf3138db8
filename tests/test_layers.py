"""The package's layers import downwards only (ffsm_pin/__init__.py, docs/api.md "Layout"):
robot, attitude -> model -> control -> scenario -> sim -> sweep. A module may import its own
layer and the layers below it, never one above; the deprecated aliases of moved modules are
the only exception (they point at the new place, wherever it is)."""

from __future__ import annotations

import ast
import importlib
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "ffsm_pin"
# layer of each subpackage, bottom up; modules at the top level (errors, _arrays, ...) are 0
LAYERS = {"robot": 1, "attitude": 1, "model": 2, "control": 3, "scenario": 4, "sim": 5,
          "sweep": 6}  # fmt: skip
# the scenario modules that moved out of sim/ (aliases of their new place for one release)
MOVED = {
    "ffsm_pin.sim.scenario": "ffsm_pin.scenario.spec",
    "ffsm_pin.sim.scenario_file": "ffsm_pin.scenario.file",
    "ffsm_pin.sim.scenario_schema": "ffsm_pin.scenario.schema",
    "ffsm_pin.sim.trajectory": "ffsm_pin.scenario.trajectory",
}


def _module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _layer(module: str) -> int:
    parts = module.split(".")
    return LAYERS.get(parts[1], 0) if len(parts) > 1 else 0


def _imports(path: Path, module: str):
    """Every ffsm_pin module that ``path`` imports (absolute or relative), with the line."""
    is_pkg = path.name == "__init__.py"
    base = module.split(".") if is_pkg else module.split(".")[:-1]
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                target = ".".join(
                    base[: len(base) - node.level + 1] + ([node.module] if node.module else [])
                )
            else:
                target = node.module or ""
            if target.startswith("ffsm_pin"):
                yield target, node.lineno
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("ffsm_pin"):
                    yield alias.name, node.lineno


def test_imports_run_downwards():
    upward = []
    for path in sorted(PACKAGE.rglob("*.py")):
        module = _module_name(path)
        text = path.read_text()
        # the top level (its public names, loaded lazily) and the deprecated aliases of moved
        # modules, which point at the new place wherever it is
        if module == "ffsm_pin" or (ast.get_docstring(ast.parse(text)) or "").startswith(
            "Deprecated"
        ):
            continue
        for target, line in _imports(path, module):
            if _layer(target) > _layer(module):
                upward.append(f"{path.relative_to(PACKAGE.parent)}:{line} imports {target}")
    assert not upward, "imports that run upwards:\n" + "\n".join(upward)


@pytest.mark.parametrize(("old", "new"), sorted(MOVED.items()))
def test_moved_scenario_modules_still_import_with_a_warning(old, new):
    sys.modules.pop(old, None)
    with pytest.warns(DeprecationWarning, match=new.replace(".", r"\.")):
        module = importlib.import_module(old)
    assert module is importlib.import_module(new)
