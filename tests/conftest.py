"""Shared fixtures: paths to the bundled files, a CLI runner."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

ROOT = Path(__file__).resolve().parent.parent
MAPS = ROOT / "maps"
DATA = Path(__file__).resolve().parent / "data"
SMALL_MODEL_STATES = 1000
"""The most states of a bundled map that a test checks against a plain Python loop over every state
(an oracle) or a full text round trip; the occupancy maps (tens of thousands of states) are covered
by the vectorised checks of test_bundled_maps.py."""

TWINS = {
    "name": "twins",
    "grid": {"rows": 1, "cols": 2, "headings": 1},
    "actions": {"up": {"cost": 1}, "down": {"cost": 1}},
    "sensors": {"look": {"type": "look", "classes": ["door"], "false_positive": 0.1, "false_negative": 0.1}},
}
"""Two cells nothing can tell apart: moving up or down bumps, looking sees no door anywhere."""


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--update-golden", action="store_true", help="Rewrite tests/golden/ from the current outputs.")


@pytest.fixture
def update_golden(request: pytest.FixtureRequest) -> bool:
    return bool(request.config.getoption("--update-golden"))


@pytest.fixture
def runner(monkeypatch: pytest.MonkeyPatch) -> CliRunner:
    monkeypatch.setenv("COLUMNS", "120")
    return CliRunner()
