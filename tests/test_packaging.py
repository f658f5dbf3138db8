"""The wheel holds every package of the source tree (pyproject lists them explicitly, because
the top-level urdf/ folder is installed as ``ffsm_pin.urdf``)."""

from __future__ import annotations

import sys
from pathlib import Path

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]


def test_every_package_is_installed():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    listed = set(config["packages"])
    found = {
        ".".join(init.parent.relative_to(ROOT).parts)
        for init in (ROOT / "ffsm_pin").rglob("__init__.py")
        if "__pycache__" not in init.parts
    }
    assert found <= listed, f"packages missing from pyproject.toml: {sorted(found - listed)}"
    assert "ffsm_pin.urdf" in listed and config["package-dir"]["ffsm_pin.urdf"] == "urdf"
    gone = listed - found - {"ffsm_pin.urdf"}
    assert not gone, f"pyproject.toml lists packages that no longer exist: {sorted(gone)}"
