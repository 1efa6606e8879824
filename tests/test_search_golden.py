"""Golden outputs of seeded object searches: ``search run`` and ``search simulate`` with ``--json --no-timings``.

Same mechanism as ``tests/test_golden.py``: a deliberate change of behaviour is recorded with
``python -m pytest tests/test_search_golden.py --update-golden`` and reviewed in the diff of
``tests/golden/search-*.json``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from beliefloc.cli.app import app
from beliefloc.errors import EXIT_NEGATIVE

from .conftest import DATA, ROOT

GOLDEN = Path(__file__).resolve().parent / "golden"
HOME = str(ROOT / "domains" / "home.yaml")

CASES: dict[str, tuple[list[str], int]] = {
    "search-run-home-seed0": (["search", "run", HOME, "--seed", "0"], 0),
    "search-run-home-absent-sampling": (
        ["search", "run", HOME, "--seed", "3", "--absent", "--strategy", "sampling"],
        1,
    ),
    "search-run-home-dynamic-seed1": (["search", "run", HOME, "--seed", "1", "--dynamic-kb"], 0),
    "search-run-locked-trust": (
        ["search", "run", str(DATA / "search-locked.yaml"), "--seed", "2", "--revision", "trust-factor"],
        0,
    ),
    "search-simulate-home-seed0": (
        ["search", "simulate", HOME, "-n", "4", "-s", "none,upper-bound", "--absent-fraction", "0.5", "--dynamic-kb"],
        0,
    ),
}


def _rounded(data: Any) -> Any:
    if isinstance(data, dict):
        return {k: _rounded(v) for k, v in data.items()}
    if isinstance(data, list):
        return [_rounded(v) for v in data]
    if isinstance(data, float):
        return round(data, 10)  # last-bit differences between BLAS builds are not behaviour
    return data


@pytest.mark.parametrize("name", list(CASES))
def test_search_golden(runner: CliRunner, update_golden: bool, name: str) -> None:
    args, exit_code = CASES[name]
    result = runner.invoke(app, [*args, "--json", "--no-timings"])
    assert result.exit_code == exit_code, result.output
    assert exit_code in (0, EXIT_NEGATIVE)
    actual = _rounded(json.loads(result.stdout))
    path = GOLDEN / f"{name}.json"
    if update_golden or not path.exists():
        path.write_text(json.dumps(actual, indent=1, sort_keys=True) + "\n")
        if not update_golden:
            pytest.fail(f"{path.name} did not exist; it was written now: review and commit it")
    assert actual == json.loads(path.read_text()), f"{name} changed; if intended, rerun with --update-golden"
