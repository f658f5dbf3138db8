"""The version is stated once: CITATION.cff and the CHANGELOG agree with ffsm_pin.__version__."""

from __future__ import annotations

import re
from pathlib import Path

import yaml

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

import ffsm_pin

ROOT = Path(__file__).resolve().parents[1]


def test_citation_version_matches_package():
    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text())
    assert str(cff["version"]) == ffsm_pin.__version__
    assert cff["cff-version"] == "1.2.0"
    assert cff["references"][0]["journal"] == "Nonlinear Dynamics"


def test_changelog_newest_release_matches_package():
    text = (ROOT / "CHANGELOG.md").read_text()
    released = re.findall(r"^## (\d+\.\d+\.\d+)", text, flags=re.M)
    assert released and released[0] == ffsm_pin.__version__


def test_pyproject_reads_the_version_from_the_package():
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert "version" not in meta["project"] and "version" in meta["project"]["dynamic"]
    attr = meta["tool"]["setuptools"]["dynamic"]["version"]["attr"]
    assert attr == "ffsm_pin.__version__"
    # an SPDX expression and the file it names (PEP 639; the old table form is deprecated)
    assert meta["project"]["license"] == "BSD-3-Clause"
    assert meta["project"]["license-files"] == ["LICENSE"]
    assert "BSD 3-Clause" in (ROOT / "LICENSE").read_text()
