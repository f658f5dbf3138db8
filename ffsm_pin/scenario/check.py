"""A scenario built in Python checked by the scenario file's schema (one validator for files
and Python alike): through its TOML document, :func:`scenario_document`."""

from __future__ import annotations

import dataclasses
import sys
from typing import Any

from . import schema
from .spec import Scenario
from .writer import scenario_to_toml

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib


def scenario_document(scenario: Scenario) -> dict[str, Any]:
    """The scenario as the document of its file (nested tables, TOML values): what
    :func:`scenario_to_toml` writes, read back; the form the schema validates."""
    return tomllib.loads(scenario_to_toml(scenario))


def check_scenario(scenario: Scenario) -> None:
    """Check a scenario built in Python with the scenario file's schema: one validator for
    files and Python alike (sizes for the robot's root and the task, ranges, funnels, MRP
    branches, ...). ``[controller.params]`` is the controller's own table and is not read.

    Raises
    ------
    ScenarioError
        The schema's one-line message, starting with the key that is wrong.
    """
    bare = dataclasses.replace(
        scenario, controller=dataclasses.replace(scenario.controller, params={})
    )
    schema.validate(scenario_document(bare))
