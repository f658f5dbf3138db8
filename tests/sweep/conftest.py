"""Fixtures of the campaign tests: ``campaign_file(text, name="campaign.toml") -> Path``."""

from __future__ import annotations

from pathlib import Path

import pytest


@pytest.fixture
def campaign_file(tmp_path: Path):
    def write(text: str, name: str = "campaign.toml") -> Path:
        path = tmp_path / name
        path.write_text(text, encoding="utf-8")
        return path

    return write
