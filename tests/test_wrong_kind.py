"""A file given where another kind is expected is recognised and named, never half-read."""

from __future__ import annotations

import numpy as np
import pytest

from beliefloc.cli.app import app

from .conftest import MAPS, ROOT

KITCHEN = str(MAPS / "kitchen.yaml")
HOME = str(ROOT / "domains" / "home.yaml")


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    from typer.testing import CliRunner

    folder = tmp_path_factory.mktemp("kinds")
    macros = folder / "kitchen-macros.npz"
    assert CliRunner().invoke(app, ["macros", "build", KITCHEN, "-o", str(macros)]).exit_code == 0
    other = folder / "other.npz"
    np.savez(other, a=np.arange(3), b=np.ones(2))
    return {"macros": str(macros), "other": str(other)}


CASES = [
    (["plan", HOME], "home.yaml is a knowledge-base domain, not a map"),
    (["validate", str(ROOT / "kb" / "axioms.lp")], "axioms.lp is a knowledge base (.lp), not a map"),
    (["plan", str(MAPS / "occupancy" / "depot.yaml")], "depot.yaml is a ROS/Nav2 occupancy map YAML, not a map"),
    (["plan", KITCHEN, "--belief", KITCHEN], "kitchen.yaml is a map, not a belief file"),
    (["plan", KITCHEN, "--belief", HOME], "home.yaml is a knowledge-base domain, not a belief file"),
    (["plan", KITCHEN, "--belief", "{macros}"], "is a compiled model or macro table (.npz), not a belief file"),
    (["plan", KITCHEN, "--belief", "prior:"], "--belief prior:: names no domain"),
    (["simulate", KITCHEN, "-s", "ec2-macros", "--macros", KITCHEN], "kitchen.yaml is a map, not a macro table"),
    (["plan", "{macros}"], "kitchen-macros.npz is a macro table, not a compiled model"),
    (["plan", "{other}"], "other.npz is not a beliefloc model (it holds arrays: a, b)"),
    (
        ["simulate", str(MAPS / "hallway.yaml"), "-s", "ec2-macros", "--macros", "{macros}"],
        "a macro table for another map: it was built for",
    ),
]  # fmt: skip


@pytest.mark.parametrize(("args", "message"), CASES, ids=lambda v: " ".join(v)[:60] if isinstance(v, list) else None)
def test_a_file_of_another_kind_is_named(runner, files, args: list[str], message: str):
    result = runner.invoke(app, [a.format(**files) for a in args])
    assert result.exit_code == 2, result.output
    assert message in " ".join(result.stderr.split()), result.stderr
    assert "allow_pickle" not in result.output and "Traceback" not in result.output
