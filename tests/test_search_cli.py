"""``beliefloc search simulate`` and the newer options of ``search run``: paired trials, JSON, progress, errors."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from typer.testing import CliRunner

from beliefloc.cli.app import app
from beliefloc.errors import EXIT_BAD_INPUT, EXIT_NEGATIVE, InvalidValueError
from beliefloc.object_search.settings import Metareasoning, PolicyName, Revision

from .conftest import DATA, ROOT

HOME = ROOT / "domains" / "home.yaml"
PRINTER = ROOT / "domains" / "printer-example.yaml"
LOCKED = DATA / "search-locked.yaml"
SIMULATE = ["search", "simulate", str(HOME), "-n", "3", "-s", "none,expectation", "--absent-fraction", "0.5"]


def test_simulate_json_is_byte_identical_for_the_same_seed(runner: CliRunner) -> None:
    args = [*SIMULATE, "--json", "--no-timings", "--seed", "4"]
    first, second = runner.invoke(app, args), runner.invoke(app, args)
    assert first.exit_code == 0, first.output
    assert first.stdout == second.stdout
    data = json.loads(first.stdout)
    assert [arm["name"] for arm in data["arms"]] == ["pomdp/expectation/static/reuse", "pomdp/none/static/reuse"][::-1]
    assert len(data["records"]) == 3 and data["seconds"] is None
    assert all(o["seconds"] is None for r in data["records"] for o in r["outcomes"].values())
    other = runner.invoke(app, [*SIMULATE, "--json", "--no-timings", "--seed", "5"])
    assert other.stdout != first.stdout


def test_simulate_json_records_paired_trials(runner: CliRunner) -> None:
    out = runner.invoke(app, [*SIMULATE, "--json", "--seed", "1"])
    data = json.loads(out.stdout)
    for record in data["records"]:
        assert set(record["outcomes"]) == {"pomdp/none/static/reuse", "pomdp/expectation/static/reuse"}
        assert record["target_class"] == "printer" and record["target"].startswith("printer")
        assert (record["true_cell"] is None) == (not record["present"])
        assert sum(record["room_prior"].values()) == pytest.approx(1.0)
    assert data["seconds"] > 0
    summary = data["summary"]["pomdp/none/static/reuse"]
    assert summary["trials"] == 3 and summary["not_found"] == 0


def test_the_progress_bar_goes_to_stderr_never_into_json(runner: CliRunner, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("TTY_COMPATIBLE", "1")  # rich draws the bar as if stderr were a terminal
    monkeypatch.setenv("TTY_INTERACTIVE", "1")
    out = runner.invoke(app, [*SIMULATE, "-n", "4", "--json", "--no-timings"])
    assert out.exit_code == 0, out.output
    json.loads(out.stdout)  # stdout is the JSON document and nothing else
    assert "trials" in out.stderr and "4/4" in out.stderr


def test_simulate_prints_a_table_per_arm(runner: CliRunner) -> None:
    out = runner.invoke(
        app,
        [
            "search",
            "simulate",
            str(HOME),
            "-n",
            "2",
            "-p",
            "pomdp",
            "-p",
            "pomdp-only",
            "--revision",
            "reuse,trust-factor",
            "--dynamic-kb",
            "--knowledge",
            "0.2",
            "--no-defaults",
        ],
    )
    assert out.exit_code == 0, out.output
    assert "2 paired trials on home" in out.stdout and "KB dynamic" in out.stdout and "defaults off" in out.stdout
    for row in ("pomdp reuse", "pomdp trust-factor", "pomdp-only reuse", "every arm: metareasoning expectation"):
        assert row in out.stdout


def test_simulate_any_target(runner: CliRunner) -> None:
    out = runner.invoke(app, ["search", "simulate", str(HOME), "-n", "3", "--target", "any", "--json", "--seed", "2"])
    data = json.loads(out.stdout)
    assert data["settings"]["target"] is None
    assert len({r["target_class"] for r in data["records"]}) > 1


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--trials", "0"], "--trials"),
        (["--knowledge", "1.5"], "--knowledge"),
        (["--absent-fraction", "-0.1"], "--absent-fraction"),
        (["--strategy", "guess"], "--strategy 'guess'"),
        (["-s", "none,guess"], "--strategy 'guess'"),
        (["--policy", "astar"], "--policy 'astar'"),
        (["--revision", "forget"], "--revision 'forget'"),
        (["--target", "unicorn"], "--target 'unicorn': unknown class"),
        (["--time-limit", "0"], "--time-limit: a time limit must be positive"),
        (["--commit-threshold", "0.2"], "--commit-threshold: the commit threshold must be between 0.5 and 1"),
        (["--commit-threshold", "1"], "--commit-threshold: the commit threshold must be between 0.5 and 1"),
        (["--trust-r", "inf"], "--trust-weight / --trust-r"),
        (["--trust-weight", "2"], "--trust-weight"),
    ],
)
def test_simulate_bad_arguments_exit_2(runner: CliRunner, args: list[str], message: str) -> None:
    out = runner.invoke(app, ["search", "simulate", str(HOME), *args])
    assert out.exit_code == EXIT_BAD_INPUT, out.output
    assert message in out.stderr and "Traceback" not in out.output
    assert out.stdout == ""


def test_simulate_needs_a_findable_target_and_a_search_section(runner: CliRunner) -> None:
    out = runner.invoke(app, ["search", "simulate", str(HOME), "--target", "bedding", "-n", "1"])
    assert out.exit_code == 0, out.output  # pillows and blankets are bedding
    out = runner.invoke(app, ["search", "simulate", str(LOCKED), "--target", "laptop", "-n", "1", "--json"])
    assert out.exit_code == 0, out.output
    out = runner.invoke(app, ["search", "simulate", str(LOCKED), "--target", "electronics", "-n", "1"])
    assert out.exit_code == 0
    out = runner.invoke(app, ["search", "simulate", str(DATA / "invalid_domains" / "search" / "overlap.yaml")])
    assert out.exit_code == EXIT_BAD_INPUT and ":9:14: " in out.stderr


def test_a_locked_room_is_reported_and_never_a_target_cell(runner: CliRunner) -> None:
    out = runner.invoke(app, ["search", "run", str(LOCKED), "--seed", "1", "--json"])
    assert out.exit_code in (0, EXIT_NEGATIVE), out.output
    assert "store: marked 'accessible: false'" in out.stderr
    data = json.loads(out.stdout)
    assert not data["true_cell"].startswith("store") and all(not s["view"].startswith("store") for s in data["steps"])
    out = runner.invoke(app, ["search", "run", str(LOCKED), "--target-cell", "store:1,1"])
    assert out.exit_code == EXIT_BAD_INPUT and "cannot enter" in out.stderr


def test_run_dynamic_kb_commits_and_shows_them(runner: CliRunner) -> None:
    out = runner.invoke(app, ["search", "run", str(HOME), "--dynamic-kb", "--seed", "1", "--json", "--no-timings"])
    assert out.exit_code in (0, EXIT_NEGATIVE), out.output
    data = json.loads(out.stdout)
    assert data["dynamic_kb"] and data["revision"] == "reuse" and data["seconds"] is None
    commits = [fact for step in data["steps"] for fact in step["commits"]]
    assert commits and all(room in data["room_prior"] for _, room in commits)
    text = runner.invoke(app, ["search", "run", str(HOME), "--dynamic-kb", "--seed", "1"])
    assert "committed to the KB" in text.stdout and " in " in text.stdout
    shown = runner.invoke(app, ["search", "run", str(HOME), "--dynamic-kb", "--seed", "1", "--show"])
    assert "KB += " in shown.stdout


def test_discard_without_dynamic_kb_is_warned(runner: CliRunner) -> None:
    out = runner.invoke(app, ["search", "simulate", str(HOME), "-n", "1", "--revision", "reuse,discard"])
    assert out.exit_code == 0 and "changes nothing without --dynamic-kb" in out.stderr


def test_run_trust_factor_and_bad_revision(runner: CliRunner) -> None:
    out = runner.invoke(app, ["search", "run", str(PRINTER), "--revision", "trust-factor", "--json", "--seed", "2"])
    assert out.exit_code in (0, EXIT_NEGATIVE) and json.loads(out.stdout)["revision"] == "trust-factor"
    out = runner.invoke(app, ["search", "run", str(PRINTER), "--revision", "forget"])
    assert out.exit_code == EXIT_BAD_INPUT and "--revision 'forget'" in out.stderr


@pytest.mark.parametrize("spelling", [["-m", "none,upper-bound"], ["--metareasoning", "none", "-s", "upper-bound"]])
def test_metareasoning_and_its_old_name_strategy_are_one_option(runner: CliRunner, spelling: list[str]) -> None:
    base = ["search", "simulate", str(HOME), "-n", "2", "--json", "--no-timings", "--seed", "3"]
    old = runner.invoke(app, [*base, "--strategy", "none,upper-bound"])
    new = runner.invoke(app, [*base, *spelling])
    assert old.exit_code == new.exit_code == 0, new.output
    assert new.stdout == old.stdout
    assert [arm["strategy"] for arm in json.loads(new.stdout)["arms"]] == ["none", "upper-bound"]
    run = runner.invoke(app, ["search", "run", str(HOME), "--metareasoning", "none", "--json", "--no-timings"])
    assert json.loads(run.stdout)["strategy"] == "none"


@pytest.mark.parametrize("command", ["run", "simulate"])
def test_every_choice_the_library_has_is_offered(runner: CliRunner, command: str) -> None:
    out = runner.invoke(app, ["search", command, "--help"], env={"COLUMNS": "300"})
    assert out.exit_code == 0
    for vocabulary in (Metareasoning, PolicyName, Revision):
        assert all(member.value in out.stdout for member in vocabulary), vocabulary


def test_the_library_names_values_and_the_command_line_names_the_option(runner: CliRunner) -> None:
    from beliefloc.knowledge import load_domain
    from beliefloc.object_search.domain_space import search_space

    with pytest.raises(InvalidValueError, match=r"^'kitchen:9,9': outside room 'kitchen' \(5 x 5 cells"):
        search_space(load_domain(HOME)).parse_cell("kitchen:9,9")
    out = runner.invoke(app, ["search", "run", str(HOME), "--target-cell", "kitchen:9,9"])
    assert out.exit_code == EXIT_BAD_INPUT
    assert "--target-cell: 'kitchen:9,9': outside room 'kitchen'" in out.stderr


def test_the_search_commands_load_neither_scipy_nor_clingo() -> None:
    code = (
        "import sys, beliefloc.object_search.settings; light = 'numpy' not in sys.modules; "
        "import beliefloc.cli.search; print(light, sorted({'scipy', 'clingo'} & set(sys.modules)))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["True", "[]"]
