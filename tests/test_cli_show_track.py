"""``beliefloc show`` and ``beliefloc track`` through the CLI, and the pure step parsing."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

from beliefloc import compile_model, load_map
from beliefloc.cli.app import app
from beliefloc.errors import InvalidValueError
from beliefloc.robots.tracking import parse_step, resolve_steps

from .conftest import MAPS
from .test_render import grid_map, write_map

WINDOW = str(MAPS / "window-2x2.yaml")
PERFECT = str(MAPS / "window-2x2-perfect.yaml")
ANSI = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")


@pytest.fixture(scope="module")
def big_map(tmp_path_factory: pytest.TempPathFactory) -> str:
    """30 x 30 cells with 8 headings: 6960 states."""
    return str(write_map(tmp_path_factory.mktemp("maps"), grid_map(30, 30, 8, name="big")))


def widest(text: str) -> int:
    return max(len(ANSI.sub("", line)) for line in text.splitlines())


def rows_apart(lines: list[str]) -> int:
    """Lines from the label of grid row 0 to that of row 29 (each labelled on both sides, once)."""
    first = [i for i, line in enumerate(lines) if re.match(r"^\s*0 .* 0\s*$", line)]
    last = [i for i, line in enumerate(lines) if re.match(r"^\s*29 .* 29\s*$", line)]
    assert len(first) == len(last) == 1
    return last[0] - first[0]


def json_of(result: object) -> dict[str, object]:
    stdout = result.stdout  # type: ignore[attr-defined]
    data = json.loads(stdout)
    assert isinstance(data, dict)
    return data


# --- parsing steps -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "parsed"),
    [
        ("right", ("right", None)),
        ("look=window_seen", ("look", "window_seen")),
        ("look=chair+potted_plant", ("look", "chair+potted_plant")),
        (" look = nothing ", ("look", "nothing")),
    ],
)
def test_parse_step(text: str, parsed: tuple[str, str | None]) -> None:
    assert parse_step(text) == parsed


@pytest.mark.parametrize("text", ["", "=window", "look=", "look=a=b", "lo ok=window"])
def test_parse_step_rejects_malformed_steps(text: str) -> None:
    with pytest.raises(InvalidValueError, match="ACTION or ACTION=OBSERVATION"):
        parse_step(text)


def test_resolve_steps_names_the_step() -> None:
    model = compile_model(load_map(WINDOW))
    steps = resolve_steps(model, ["look=window_seen", "right", "right=none"])
    assert [(s.action.name, s.observation, s.index) for s in steps] == [
        ("look", "window_seen", 1),
        ("right", None, None),
        ("right", "none", 0),
    ]
    with pytest.raises(InvalidValueError, match=r"^step 2 'lookk=window': unknown action 'lookk'"):
        resolve_steps(model, ["right", "lookk=window"])


# --- track -------------------------------------------------------------------------------------


def test_track_fig3_json(runner: CliRunner) -> None:
    result = runner.invoke(app, ["track", WINDOW, "look=window_seen", "--json"])
    assert result.exit_code == 0, result.output
    data = json_of(result)
    expected = {"0,0": 1 / 18, "0,1": 1 / 18, "1,0": 4 / 9, "1,1": 4 / 9}
    assert data["belief"] == pytest.approx(expected)
    assert data["steps"] == [
        {
            "step": "look=window_seen",
            "action": "look",
            "observation": "window_seen",
            "probability": pytest.approx(0.45),
            "belief": pytest.approx(expected),
        }
    ]


def test_track_json_without_observation_has_null_probability(runner: CliRunner) -> None:
    result = runner.invoke(app, ["track", WINDOW, "look=window_seen", "right", "right=none", "--json"])
    assert result.exit_code == 0, result.output
    steps = json_of(result)["steps"]
    assert isinstance(steps, list)
    assert [(s["observation"], s["probability"]) for s in steps] == [
        ("window_seen", pytest.approx(0.45)),
        (None, None),
        ("none", 1.0),
    ]
    assert all(list(s["belief"]) == ["0,0", "0,1", "1,0", "1,1"] for s in steps)
    assert steps[1]["belief"] == pytest.approx({"0,0": 1 / 90, "0,1": 0.1, "1,0": 4 / 45, "1,1": 0.8})


@pytest.mark.parametrize("steps", [["right", "look=window_seen"], ["look=window_seen", "right"]])
def test_track_perfect_world_localizes_either_way(runner: CliRunner, steps: list[str]) -> None:
    """Colledanchise Fig. 4: both orders leave one state at 1.0."""
    result = runner.invoke(app, ["track", PERFECT, *steps, "--json"])
    assert result.exit_code == 0, result.output
    assert json_of(result)["belief"] == pytest.approx({"0,0": 0.0, "0,1": 0.0, "1,0": 0.0, "1,1": 1.0})


def test_track_draws_every_step(runner: CliRunner) -> None:
    result = runner.invoke(app, ["track", WINDOW, "look=window_seen", "right"])
    assert result.exit_code == 0, result.output
    out = result.stdout
    assert "step 1: look=window_seen   p(window_seen | look, b) = 0.45" in out
    assert "step 2: right   nothing observed: prediction only" in out
    assert "most likely 1,0  p = 0.4444" in out
    assert "most likely 1,1  p = 0.8" in out
    assert out.count("W window") == 1  # the legend once, at the end
    assert widest(out) <= 120


def test_track_final_only(runner: CliRunner) -> None:
    result = runner.invoke(app, ["track", WINDOW, "look=window_seen", "right", "--final-only"])
    assert result.exit_code == 0, result.output
    assert result.stdout.count("shade") == 1
    assert "step 1: look=window_seen" in result.stdout and "most likely 1,0" in result.stdout


@pytest.mark.parametrize(
    ("source", "steps", "message"),
    [
        (WINDOW, ["look=window_seen", "look=a=b"], "step 2 'look=a=b': should be ACTION or ACTION=OBSERVATION"),
        (WINDOW, ["look=window_seen", "lookk=window"], "step 2 'lookk=window': unknown action 'lookk'"),
        (WINDOW, ["look=windw"], "step 1 'look=windw': unknown observation 'windw': expected one of nothing, window"),
        (WINDOW, ["right", "look"], "step 2 'look': 'look' is a perception action"),
        (WINDOW, ["right=window"], "step 1 'right=window': observation 'window': this action observes nothing"),
        (
            PERFECT,
            ["look=window_seen", "right", "look=nothing"],
            "step 3 'look=nothing': observation 'nothing' after 'look' has probability 0",
        ),
    ],
)
@pytest.mark.parametrize("json_output", [False, True])
def test_track_bad_steps_exit_2_naming_the_step(
    runner: CliRunner, source: str, steps: list[str], message: str, json_output: bool
) -> None:
    result = runner.invoke(app, ["track", source, *steps, *(["--json"] if json_output else [])])
    assert result.exit_code == 2
    assert isinstance(result.exception, SystemExit)
    stderr = " ".join(result.stderr.split())
    assert stderr.startswith("error: ")
    assert message in stderr
    assert "Traceback" not in result.output
    if json_output:
        assert result.stdout == ""


def test_track_shows_the_steps_before_an_impossible_observation(runner: CliRunner) -> None:
    result = runner.invoke(app, ["track", PERFECT, "look=window_seen", "right", "look=nothing"])
    assert result.exit_code == 2
    assert "step 2: right" in result.stdout and "step 3" not in result.stdout


def test_track_json_feeds_show(runner: CliRunner, tmp_path: Path) -> None:
    tracked = runner.invoke(app, ["track", WINDOW, "look=window_seen", "right", "--json"])
    belief = tmp_path / "belief.json"
    belief.write_text(tracked.stdout)
    result = runner.invoke(app, ["show", WINDOW, "--belief", str(belief), "--json"])
    assert result.exit_code == 0, result.output
    most_likely = json_of(result)["most_likely"]
    assert isinstance(most_likely, dict)
    assert most_likely["pose"]["x"] == 1.5 and most_likely["pose"]["y"] == 0.5  # cell 1,1's centre
    assert most_likely == {"state": "1,1", "probability": pytest.approx(0.8), "pose": most_likely["pose"]}


# --- show --------------------------------------------------------------------------------------


@pytest.mark.parametrize("source", [WINDOW, PERFECT])
@pytest.mark.parametrize("form", [[], ["--compact"], ["--full"]])
def test_show_window_maps(runner: CliRunner, source: str, form: list[str]) -> None:
    result = runner.invoke(app, ["show", source, *form])
    assert result.exit_code == 0, result.output
    assert "most likely 0,0  p = 0.25 (tied with 3 others)" in result.stdout
    assert "entropy 1.386 nats" in result.stdout
    assert "W window" in result.stdout
    assert widest(result.stdout) <= 120


def test_show_json(runner: CliRunner) -> None:
    result = runner.invoke(app, ["show", WINDOW, "--json"])
    assert result.exit_code == 0, result.output
    data = json_of(result)
    belief = data["belief"]
    assert isinstance(belief, dict)
    assert sum(belief.values()) == pytest.approx(1.0)
    third, yaw = pytest.approx(1 / 3), pytest.approx(3.28986813369645)  # 1/4 + 1/12 (cell); pi²/3 (one heading)
    covariance = [third, 0.0, 0, 0, 0, 0, 0.0, third, *[0] * 27, yaw]
    pose = {"x": 0.5, "y": 1.5, "yaw": 0.0, "covariance": covariance}
    assert data["most_likely"] == {"state": "0,0", "probability": 0.25, "pose": pose}
    assert data["entropy"] == pytest.approx(1.3862943611)


@pytest.mark.parametrize(
    ("columns", "form", "lines_per_row"),
    [("120", [], 1), ("120", ["--compact"], 1), ("200", ["--full"], 3), ("200", [], 3), ("80", [], 1)],
)
def test_show_big_map_fits_the_terminal(
    runner: CliRunner, monkeypatch: pytest.MonkeyPatch, big_map: str, columns: str, form: list[str], lines_per_row: int
) -> None:
    """Without colour (as under the test runner) a full cell is 4 characters wide, so it needs 126."""
    monkeypatch.setenv("COLUMNS", columns)
    result = runner.invoke(app, ["show", big_map, *form])
    assert result.exit_code == 0, result.output
    assert widest(result.stdout) <= int(columns)
    assert rows_apart(result.stdout.splitlines()) == 29 * lines_per_row
    assert "most likely 0,0,0" in result.stdout


@pytest.mark.parametrize(("form", "lines_per_row"), [([], 2), (["--full"], 2), (["--compact"], 1)])
def test_show_big_map_in_colour(
    runner: CliRunner, monkeypatch: pytest.MonkeyPatch, big_map: str, form: list[str], lines_per_row: int
) -> None:
    """With colour a full cell is 3 characters by 2 lines, so 30 columns fit in 120."""
    monkeypatch.setenv("FORCE_COLOR", "1")
    monkeypatch.setenv("COLORTERM", "truecolor")
    monkeypatch.delenv("NO_COLOR", raising=False)
    result = runner.invoke(app, ["track", big_map, "look=nothing", "forward", "look=chair", "-q", *form])
    assert result.exit_code == 0, result.output
    assert "\x1b[" in result.stdout
    assert widest(result.stdout) <= 120
    assert rows_apart([ANSI.sub("", line) for line in result.stdout.splitlines()]) == 29 * lines_per_row


def test_show_warns_when_even_the_forced_form_is_too_wide(
    runner: CliRunner, monkeypatch: pytest.MonkeyPatch, big_map: str
) -> None:
    monkeypatch.setenv("COLUMNS", "60")
    result = runner.invoke(app, ["show", big_map, "--full"])
    assert result.exit_code == 0
    assert "warning: the grid is 126 characters wide" in " ".join(result.stderr.split())


def test_show_unknown_file_kind_exits_2(runner: CliRunner, tmp_path: Path) -> None:
    path = tmp_path / "map.txt"
    path.write_text("")
    result = runner.invoke(app, ["show", str(path)])
    assert result.exit_code == 2
    assert isinstance(result.exception, SystemExit)
    assert "unknown kind of file" in result.stderr


@pytest.mark.parametrize("command", ["show", "track"])
def test_help_has_an_example(runner: CliRunner, command: str) -> None:
    result = runner.invoke(app, [command, "--help"])
    assert result.exit_code == 0
    assert f"Examples:\n\n    beliefloc {command} maps/window-2x2.yaml" in result.stdout


def test_show_and_track_a_model_without_grid(runner: CliRunner, monkeypatch: pytest.MonkeyPatch) -> None:
    """An imported .pomdp has named states and no grid: a table of the most probable states."""
    from beliefloc.files import model_sources

    from .test_render import rooms_model

    monkeypatch.setattr(model_sources, "open_model", lambda path, on_warning=None: rooms_model())
    result = runner.invoke(app, ["show", "rooms.pomdp"])
    assert result.exit_code == 0, result.output
    assert "most likely kitchen  p = 0.3333 (tied with 2 others)" in result.stdout
    assert all(name in result.stdout for name in ("kitchen", "hall", "office"))
    result = runner.invoke(app, ["track", "rooms.pomdp", "stay", "stay=none"])
    assert result.exit_code == 0, result.output
    assert "step 2: stay=none   p(none | stay, b) = 1" in result.stdout
    assert result.stdout.count("most likely kitchen") == 2


def test_a_long_log_prints_a_line_per_step_and_one_map(runner: CliRunner, tmp_path: Path) -> None:
    """Past DRAW_EVERY_STEP_UP_TO steps, track prints as --final-only does, and says so."""
    from beliefloc.cli.track import DRAW_EVERY_STEP_UP_TO

    log = tmp_path / "long.log"
    log.write_text("look=window_seen\nright\n" * (DRAW_EVERY_STEP_UP_TO // 2 + 1), encoding="utf-8")
    result = runner.invoke(app, ["track", WINDOW, "--steps", str(log)])
    assert result.exit_code == 0, result.output
    quiet = runner.invoke(app, ["track", WINDOW, "--steps", str(log), "--final-only"])
    assert result.stdout == quiet.stdout
    steps = DRAW_EVERY_STEP_UP_TO + 2
    assert result.stdout.count("\nstep ") + 1 == steps and result.stdout.count("shade") == 1  # one map, the last
    assert f"{steps:,} steps (more than" in result.stderr
