"""Every command's help: laid out to be read and copied, and every example in it runs as written."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
import typer.main

from beliefloc.cli.app import app

from .conftest import ROOT

_PLACEHOLDER = re.compile(r"<(?:str|int|float|bool|path|list\[[^\]]*\]|[a-z]+ range)>")
"""A Python type where a metavar belongs (choices, ``<json|ros>``, are fine)."""
_EXITS = re.compile(r"#\s*exits (\d)")


def _commands() -> list[tuple[list[str], Any]]:
    """Every command, groups and leaves, in the order ``beliefloc --help`` lists them (typer's own
    click: a group is what has subcommands)."""
    found: list[tuple[list[str], Any]] = []

    def walk(path: list[str], command: Any) -> None:
        found.append((path, command))
        for name, sub in getattr(command, "commands", {}).items():
            walk([*path, name], sub)

    walk([], typer.main.get_command(app))
    return found


COMMANDS = _commands()
LEAVES = [(path, c) for path, c in COMMANDS if not hasattr(c, "commands")]


def _help(runner, path: list[str]) -> str:
    result = runner.invoke(app, [*path, "--help"], env={"COLUMNS": "80"})
    assert result.exit_code == 0, result.output
    return result.stdout


def examples_of(text: str) -> list[str]:
    """The lines of the block that follows ``Example:`` or ``Examples:`` in a help text."""
    lines = text.splitlines()
    for index, line in enumerate(lines):
        if line.strip() in ("Example:", "Examples:"):
            block = []
            for following in lines[index + 1 :]:
                if block and not following.strip():
                    break
                if following.strip():
                    block.append(following.strip())
            return block
    return []


@pytest.mark.parametrize("path", [p for p, _ in COMMANDS], ids=lambda p: " ".join(p) or "beliefloc")
def test_help_reads_well(runner, path):
    text = _help(runner, path)
    listing = text.split("Commands:", 1)[1] if "Commands:" in text else ""
    assert "..." not in listing, f"a summary is cut short:\n{listing}"
    options = text.split("Arguments:", 1)[-1] if "Arguments:" in text else text.split("Options:", 1)[-1]
    assert not _PLACEHOLDER.findall(options), f"a Python type shows as a placeholder:\n{options}"
    broken = [line for line in text.splitlines() if re.search(r"\w-$", line)]
    assert not broken, f"lines broken at a hyphen: {broken}"


@pytest.mark.parametrize("path", [p for p, _ in LEAVES], ids=lambda p: " ".join(p))
def test_every_command_shows_an_example(runner, path):
    assert examples_of(_help(runner, path)), f"beliefloc {' '.join(path)} --help has no example"


@pytest.mark.slow
def test_every_help_example_runs_as_written(runner, tmp_path: Path):
    """In one folder holding the bundled maps, domains and knowledge bases, in the order the help
    lists the commands (an example may use a file an earlier one wrote): each exits 0, or the code
    its ``# exits N`` comment says."""
    for folder in ("maps", "domains", "kb", "schemas"):
        shutil.copytree(ROOT / folder, tmp_path / folder)
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"}
    env.pop("COLUMNS", None)
    ran = 0
    for path, _ in LEAVES:
        for line in examples_of(_help(runner, path)):
            expected = int(match.group(1)) if (match := _EXITS.search(line)) else 0
            result = subprocess.run(
                ["bash", "-c", line], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300
            )
            assert result.returncode == expected, f"{line}\nexit {result.returncode}\n{result.stderr[-2000:]}"
            assert "Traceback" not in result.stderr, line
            ran += 1
    assert ran >= len(LEAVES)


def test_every_limit_is_documented_in_the_readme():
    from beliefloc.source import limits

    readme = (ROOT / "README.md").read_text()
    bounds = [value for value in vars(limits).values() if isinstance(value, limits.Limit)]
    assert len(bounds) >= 10
    for bound in bounds:
        assert f"`{bound.variable}`" in readme, f"{bound.variable} is not in the README's table of limits"


NUMBER_OPTIONS = [
    (["plan", "maps/kitchen.yaml"], ["--threshold", "--h-weight", "--time-limit"]),
    (["simulate", "maps/kitchen.yaml"], ["--threshold", "--h-weight", "--time-limit", "--gamma"]),
    (["localize", "maps/kitchen.yaml"], ["--threshold", "--h-weight", "--time-limit"]),
    (["select", "maps/kitchen.yaml"], ["--gamma"]),
    (["prior", "domains/home.yaml"], ["--floor", "--weight"]),
    (["search", "run", "domains/home.yaml"], ["--time-limit", "--commit-threshold", "--trust-weight", "--trust-r"]),
    (["search", "simulate", "domains/home.yaml"], ["--knowledge", "--absent-fraction", "--time-limit"]),
    (["generate", "gridworld", "--states", "100", "--seed", "1", "-o", "w.yaml"], ["--rotation-failure"]),
]


@pytest.mark.parametrize(("base", "option"), [(b, o) for b, options in NUMBER_OPTIONS for o in options])
@pytest.mark.parametrize("value", ["nan", "inf", "-inf"])
def test_number_options_refuse_nan_and_infinity(runner, tmp_path: Path, monkeypatch, base, option, value):
    monkeypatch.chdir(tmp_path)
    for folder in ("maps", "domains", "kb"):
        (tmp_path / folder).symlink_to(ROOT / folder)
    result = runner.invoke(app, [*base, option, value], input="")
    assert result.exit_code == 2, result.output
    assert option in result.output + result.stderr and "Traceback" not in result.output
    assert not (tmp_path / "w.yaml").exists()


def test_the_command_table_names_every_command_and_its_module():
    """`beliefloc CMD` registers CMD's module alone (beliefloc.cli.app.COMMANDS): the table must name
    every command the full app has, in its order, each with the module that registers it."""
    from beliefloc.cli.app import COMMANDS as TABLE
    from beliefloc.cli.app import make_app

    full = typer.main.get_command(app)
    assert sorted(full.commands) == sorted(TABLE)  # type: ignore[attr-defined]
    for name, module in TABLE.items():
        lean = typer.main.get_command(make_app(name))
        alone = {n for n, m in TABLE.items() if m == module}
        assert set(lean.commands) == alone, (name, module)  # type: ignore[attr-defined]


@pytest.mark.parametrize("path", [p for p, _ in COMMANDS if p], ids=lambda p: " ".join(p))
def test_a_command_alone_has_the_help_it_has_among_all(runner, path):
    from beliefloc.cli.app import command_word, make_app

    word = command_word(path)
    assert word == path[0]
    lean = runner.invoke(make_app(word), [*path, "--help"], env={"COLUMNS": "80"})
    assert lean.exit_code == 0 and lean.stdout == _help(runner, path)


@pytest.mark.parametrize(
    ("args", "word"),
    [
        (["plan", "maps/kitchen.yaml"], "plan"),
        (["--version"], None),
        (["--help", "macros", "build"], "macros"),
        (["plna", "maps/kitchen.yaml"], None),  # the whole app says there is no such command
        ([], None),
    ],
)
def test_the_command_word_is_the_first_that_is_not_an_option(args, word):
    from beliefloc.cli.app import command_word

    assert command_word(args) == word


def test_a_mistyped_command_is_told_apart_from_the_others(tmp_path: Path):
    result = subprocess.run(
        [sys.executable, "-m", "beliefloc", "plna", "maps/kitchen.yaml"], cwd=ROOT, capture_output=True, text=True
    )
    assert result.returncode == 2 and "plna" in result.stderr and "Traceback" not in result.stderr
