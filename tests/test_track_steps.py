"""``beliefloc track --steps FILE|-``: a logged run replayed from a step file, and the final pose."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from beliefloc import compile_model, load_map
from beliefloc.cli.app import app
from beliefloc.errors import EXIT_BAD_INPUT, ImpossibleObservationError, InputFileError, InvalidValueError
from beliefloc.pose import belief_pose
from beliefloc.robots.tracking import StepLine, read_step_file, resolve_steps, step_lines, track_beliefs

from .conftest import MAPS

KITCHEN = str(MAPS / "kitchen.yaml")
STORY = ["look=nothing", "scan=no_wall", "rotate_ccw", "look=potted_plant", "forward", "scan=wall_0.2-0.8"]
LOG = """\
# Colledanchise Sec. VII-B, Experiment 1
look=nothing          # from the centre, facing east

scan=no_wall
rotate_ccw
   look=potted_plant
forward
scan=wall_0.2-0.8
"""


def test_step_lines_skip_blank_lines_and_comments() -> None:
    lines = step_lines(LOG, "run.log")
    assert [line.text for line in lines] == STORY
    assert lines[0] == StepLine("look=nothing", "run.log:2: 'look=nothing'")
    assert lines[2].label == "run.log:5: 'rotate_ccw'"


def test_a_file_of_comments_has_no_steps() -> None:
    with pytest.raises(InvalidValueError, match=r"^run.log: no steps, only blank lines and comments"):
        step_lines("# nothing yet\n\n", "run.log")


def test_messages_name_the_file_and_line() -> None:
    model = compile_model(load_map(MAPS / "window-2x2-perfect.yaml"))
    lines = step_lines("look=window_seen\nright\n\nlook=nothing\n", "run.log")
    with pytest.raises(InvalidValueError, match=r"^run.log:2: 'lookk': unknown action 'lookk'"):
        resolve_steps(model, step_lines("right\nlookk\n", "run.log"))
    steps = resolve_steps(model, lines)
    with pytest.raises(
        ImpossibleObservationError, match=r"^run.log:4: 'look=nothing': observation 'nothing' after 'look' has pro"
    ):
        list(track_beliefs(model, np.full(4, 0.25), steps))


def test_read_step_file_guards_the_file(tmp_path: Path) -> None:
    with pytest.raises(InputFileError, match=r"missing.log: no such file"):
        read_step_file(tmp_path / "missing.log")
    with pytest.raises(InputFileError, match=r": is a folder, not a file"):
        read_step_file(tmp_path)
    (tmp_path / "bad.log").write_bytes(b"look=nothing\n\xff\n")
    with pytest.raises(InputFileError, match=r"bad.log:2: not UTF-8 text"):
        read_step_file(tmp_path / "bad.log")


def _json(runner: CliRunner, *args: str, stdin: str | None = None) -> dict[str, object]:
    result = runner.invoke(app, ["track", KITCHEN, "--json", *args], input=stdin)
    assert result.exit_code == 0, result.output
    data: dict[str, object] = json.loads(result.stdout)
    return data


def test_a_step_file_and_stdin_replay_the_arguments(runner: CliRunner, tmp_path: Path) -> None:
    log = tmp_path / "run.log"
    log.write_text(LOG)
    from_arguments = _json(runner, *STORY)
    assert _json(runner, "--steps", str(log)) == from_arguments
    assert _json(runner, "--steps", "-", stdin=LOG) == from_arguments


def test_track_json_gives_the_pose_of_the_final_belief(runner: CliRunner) -> None:
    data = _json(runner, *STORY)
    model = compile_model(load_map(KITCHEN))
    belief = [data["belief"][name] for name in model.states.names]  # type: ignore[index]
    expected = belief_pose(model, np.array(belief)).as_json()
    pose = data["pose"]
    assert isinstance(pose, dict) and set(pose) == set(expected)
    assert [pose[k] for k in ("x", "y", "yaw")] == pytest.approx([expected[k] for k in ("x", "y", "yaw")])
    assert pose["covariance"] == pytest.approx(expected["covariance"])
    assert (data["pose"]["x"], data["pose"]["y"]) == pytest.approx((1.8, 3.0))  # type: ignore[index]  # "0,1,0"


@pytest.mark.parametrize(
    ("args", "stdin", "message"),
    [
        (["--steps", "{log}", "look=nothing"], None, "--steps {log}: give the steps either as STEP... arguments or"),
        ([], None, "no steps: give them as STEP... arguments or one per line with --steps FILE|-"),
        (["--steps", "-"], "look=nothing\nlookk=x\n", "<stdin>:2: 'lookk=x': unknown action 'lookk'"),
        (["--steps", "-"], "# only a comment\n", "<stdin>: no steps, only blank lines and comments"),
        (["--steps", "{log}"], None, "run.log:8: 'scan=wal': unknown observation 'wal'"),
        (["--steps", "{missing}"], None, "missing.log: no such file"),
    ],
)
def test_bad_steps_exit_2_naming_file_and_line(
    runner: CliRunner, tmp_path: Path, args: list[str], stdin: str | None, message: str
) -> None:
    log = tmp_path / "run.log"
    log.write_text(LOG.replace("scan=wall_0.2-0.8", "scan=wal"))
    names = {"log": str(log), "missing": str(tmp_path / "missing.log")}
    result = runner.invoke(app, ["track", KITCHEN, *(a.format(**names) for a in args)], input=stdin)
    assert result.exit_code == EXIT_BAD_INPUT
    assert isinstance(result.exception, SystemExit)
    stderr = " ".join(result.stderr.split())
    assert stderr.startswith("error: ") and message.format(**names) in stderr
    assert result.stdout == ""


def test_a_model_without_grid_has_a_null_pose(runner: CliRunner, monkeypatch: pytest.MonkeyPatch) -> None:
    """An imported .pomdp has no grid, so its states have no pose: ``"pose": null``, as ``show`` says."""
    from beliefloc.files import model_sources

    from .test_render import rooms_model

    monkeypatch.setattr(model_sources, "open_model", lambda path, **_: rooms_model())
    result = runner.invoke(app, ["track", "rooms.pomdp", "stay", "--json"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["pose"] is None
