"""``beliefloc localize``: the act-perceive-replan loop (:mod:`beliefloc.robots.localize`), its line protocol
(:mod:`beliefloc.robots.line_protocol`) and the command, end to end with a robot in another process."""

from __future__ import annotations

import io
import json
import math
import re
import subprocess
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from beliefloc import compile_model, load_map, uniform
from beliefloc.cli.app import app
from beliefloc.errors import EXIT_BAD_INPUT, EXIT_NEGATIVE, ReplyError
from beliefloc.model import Model
from beliefloc.pose import nonnegative_covariance, state_pose
from beliefloc.robots.belief_filter import ModelFilter
from beliefloc.robots.line_protocol import MAX_LINE_CHARS, LineRobot, action_message
from beliefloc.robots.localize import (
    Command,
    LookAlikes,
    Places,
    SimulatedReadingRobot,
    informative_move,
    keeping_moves,
    localize,
    planning_goal,
    securing_move,
)
from beliefloc.robots.odometry import MotionReport
from beliefloc.robots.readings import RawReading, ReadingBinner
from beliefloc.semantic_map import SemanticMap
from beliefloc.simulation.robot import SimulatedRobot
from beliefloc.simulation.strategies import EpisodeStatus, PlannerSettings

from .conftest import MAPS, ROOT, TWINS

KITCHEN = str(MAPS / "kitchen.yaml")
LAMP = {
    "name": "lamp",
    "grid": {"rows": 1, "cols": 2, "headings": 1},
    "landmarks": [{"class": "door", "cell": [0, 1]}],
    "actions": {"up": {"cost": 1}},
    "sensors": {"look": {"type": "look", "classes": ["door", "lamp"], "range": 0}},
}
"""Two cells told apart by a perfect look for a door; no lamp anywhere, so seeing one is impossible."""


@pytest.fixture(scope="module")
def kitchen() -> tuple[Model, ReadingBinner]:
    smap = load_map(KITCHEN)
    model = compile_model(smap)
    return model, ReadingBinner(smap, model)


def _of(data: dict[str, Any]) -> tuple[Model, ReadingBinner]:
    smap = SemanticMap.model_validate(data)
    model = compile_model(smap)
    return model, ReadingBinner(smap, model)


class Scripted:
    """A robot that answers every perception action with the same reading of its sensor, and
    every actuation action with an acknowledgement."""

    def __init__(self, readings: Mapping[str, RawReading]) -> None:
        self.readings = readings
        self.commands: list[Command] = []

    def act(self, command: Command) -> Mapping[str, RawReading]:
        self.commands.append(command)
        action = command.action
        return {} if action.is_actuation else {action.name: self.readings[action.name]}


# --- the loop ------------------------------------------------------------------------------------


@pytest.mark.parametrize("seed", range(4))
def test_a_simulated_robot_answering_raw_readings_is_localized(kitchen: Any, seed: int) -> None:
    model, binner = kitchen
    start = model.states.index("1,1,1")
    world = SimulatedRobot(model, start, np.random.default_rng(seed))
    seen: list[int] = []
    outcome = localize(
        model,
        uniform(model.n_states),
        SimulatedReadingRobot(world, binner),
        binner,
        on_step=lambda step: seen.append(step.command.seq),
    )
    assert outcome.status is EpisodeStatus.LOCALIZED
    assert int(np.argmax(outcome.belief)) == world.state
    assert seen == list(range(1, outcome.steps + 1))
    data = outcome.as_json(model)
    assert data["state"] == model.states.name(world.state)
    assert data["pose"]["x"] == state_pose(model.grid, world.state).x  # type: ignore[arg-type]


class _RivalFilter(ModelFilter):
    """The model's filter with a look-alike place that holds ``rival`` of the belief beyond the
    declared state's promise, whatever the readings."""

    def __init__(self, model: Model, rival: float) -> None:
        super().__init__(model)
        self.rival = rival

    def elsewhere(self) -> float:
        return self.rival


class _KeptFilter(ModelFilter):
    """The model's filter whose moves keep the given declared probabilities."""

    def __init__(self, model: Model, kept: Mapping[str, float]) -> None:
        super().__init__(model)
        self.kept = kept

    def peak_after(self, move: Any) -> float:
        return self.kept[move.name]


def test_a_confirmation_moves_only_where_the_belief_keeps_the_threshold(kitchen: Any) -> None:
    """Among the moves, those that keep the threshold by their own prediction; the one that keeps
    the most when none does."""
    model, _ = kitchen
    moves = list(model.actuation_actions)
    assert len(moves) >= 2
    kept = {m.name: 0.9 for m in moves} | {moves[1].name: 0.96}
    assert keeping_moves(_KeptFilter(model, kept), moves, 0.95) == [moves[1]]
    kept = {m.name: 0.5 for m in moves} | {moves[0].name: 0.93, moves[1].name: 0.94}
    assert keeping_moves(_KeptFilter(model, kept), moves, 0.95) == [moves[1]]
    assert keeping_moves(_KeptFilter(model, {m.name: 0.97 for m in moves}), moves, 0.95) == moves


def test_the_model_filter_keeps_what_the_commanded_move_predicts(kitchen: Any) -> None:
    model, _ = kitchen
    tracker = ModelFilter(model)
    belief = np.zeros(model.n_states)
    belief[model.states.index("1,1,1")] = 1.0
    tracker.start(belief)
    for move in model.actuation_actions:
        expected = float((move.transition.T @ belief).max())
        assert tracker.peak_after(move) == pytest.approx(expected, abs=1e-12)
    assert tracker.belief is belief


def test_a_filter_that_gathers_places_plans_until_look_alikes_hold_what_a_declaration_may_leave(kitchen: Any) -> None:
    """The model's filter plans to the threshold; one whose planning belief gathers places plans
    until one place holds all but RIVAL_SHARE of the rest (0.99 at 0.95): the look-alike a
    declaration may not leave is the planner's to remove, not the loop's one-step choice's."""
    model, _ = kitchen
    settings = PlannerSettings(threshold=0.95)
    assert planning_goal(settings, ModelFilter(model)) is settings

    class Gathering(ModelFilter):
        gathers_places = True

    goal = planning_goal(settings, Gathering(model))
    assert goal.threshold == pytest.approx(0.99)
    assert goal == PlannerSettings(threshold=goal.threshold)  # nothing else changed
    assert planning_goal(PlannerSettings(threshold=0.999), Gathering(model)).threshold == pytest.approx(0.9998)


@pytest.mark.parametrize("rival", [0.008, 0.012])
def test_a_belief_is_not_declared_while_a_look_alike_holds_more_than_a_fifth_of_the_rest(
    kitchen: Any, rival: float
) -> None:
    """At a threshold of 0.95 a look-alike beyond the promise may hold at most 0.01 (RIVAL_SHARE of
    the 0.05 the threshold leaves): the same robot is localized with 0.008 there, not with 0.012."""
    model, binner = kitchen
    start = model.states.index("1,1,1")
    world = SimulatedRobot(model, start, np.random.default_rng(0))
    outcome = localize(
        model,
        uniform(model.n_states),
        SimulatedReadingRobot(world, binner),
        binner,
        settings=PlannerSettings(threshold=0.95),
        belief_filter=_RivalFilter(model, rival),
        max_steps=60,
    )
    assert outcome.localized is (rival <= 0.01)
    if not outcome.localized:
        assert outcome.status is EpisodeStatus.STEP_LIMIT and outcome.belief.max() >= 0.95


def test_a_reading_taken_here_is_replaced_by_the_action_that_tells_the_most(kitchen: Any) -> None:
    """The planner, planning on states whose readings it counts as independent, asks for a reading
    already taken where the robot stands: the loop's stand-in is the most informative action per
    cost (:func:`informative_move`), never a move into a wall or back to where it read."""
    model, _ = kitchen
    grid = model.grid
    assert grid is not None
    rows, _, headings = grid.cell_heading(np.arange(model.n_states))
    # the robot faces the north wall from the top row: forward surely stays
    facing = ((rows == 0) & (headings == 0)).astype(float)
    tracker = ModelFilter(model)
    tracker.start(facing / facing.sum())
    places = Places(grid)
    places.add("look")
    places.add("scan")
    moves = model.actuation_actions
    action, reading = informative_move(tracker, model, places, moves, np.random.default_rng(0))
    assert action.is_actuation and action.name != "forward"
    assert reading is not None and not reading.is_actuation
    # turned clockwise and read there: turning back would read the same again, so it is not chosen
    places.after_move(MotionReport(odometry=(0.0, 0.0, -math.pi / 2)))
    places.add("look")
    places.add("scan")
    assert places.after(model.action("rotate_ccw")) == {"look", "scan"}
    action, _ = informative_move(tracker, model, places, moves, np.random.default_rng(0))
    assert action.name not in ("forward", "rotate_ccw")
    # a reading not yet taken here that tells something costs a tenth of a move: it comes first; the
    # scan, which reads the same wall from all three cells, tells nothing: a move does
    unread = [model.action("look"), model.action("scan")]
    action, reading = informative_move(tracker, model, Places(grid), moves, np.random.default_rng(0), unread)
    assert action.name == "look" and reading is None
    action, _ = informative_move(tracker, model, Places(grid), moves, np.random.default_rng(0), unread[1:])
    assert action.is_actuation


def test_the_last_mile_takes_what_raises_the_declaration_most_per_cost(kitchen: Any) -> None:
    """Once the planner's goal is met but not the declaration's, the loop takes the action expected
    to raise the declared probability the most per cost (:func:`securing_move`): between two states
    that one sensor tells apart and the other reads alike, that sensor's reading; nothing when no
    action is expected to raise it (each expectation is the filter's, here exact)."""
    model, _ = kitchen
    grid = model.grid
    assert grid is not None
    look, scan = model.action("look"), model.action("scan")
    truth_look = np.array([look.observation.true_observation(s) for s in range(model.n_states)])
    truth_scan = np.array([scan.observation.true_observation(s) for s in range(model.n_states)])
    pairs = [
        (a, b)
        for a in range(model.n_states)
        for b in range(a + 1, min(model.n_states, a + 40))
        if truth_look[a] != truth_look[b] and truth_scan[a] == truth_scan[b]
    ]
    first, second = pairs[0]
    belief = np.zeros(model.n_states)
    belief[[first, second]] = 0.5
    tracker = ModelFilter(model)
    tracker.start(belief)
    moves = model.actuation_actions
    chosen = securing_move(tracker, model, Places(grid), moves, [scan, look])
    assert chosen == (look, None)
    expected_look, expected_scan = tracker.declared_after((), [look, scan])
    assert expected_look > 0.9 and expected_scan == pytest.approx(0.5, abs=0.02)
    # read both here, the belief sure of one state: nothing raises it
    sure = np.zeros(model.n_states)
    sure[first] = 1.0
    tracker.start(sure)
    places = Places(grid)
    places.add("look")
    places.add("scan")
    assert securing_move(tracker, model, places, moves, []) is None
    assert securing_move(tracker, model, places, [], []) is None


def test_modes_a_cell_or_two_apart_are_one_place_and_look_alikes_are_not() -> None:
    """A place known to a few tenths of a metre parts into modes a cell or two apart: those are one
    place's spread (:meth:`LookAlikes.one_place`), which the loop secures rather than leading them
    apart by macros; modes farther apart, or a heading sector and more turned, are look-alikes; one
    mode that holds the goal alone is neither."""
    smap = load_map(MAPS / "tb3-sandbox.yaml")
    model = compile_model(smap)
    grid = model.grid
    assert grid is not None

    def beside(dc: int, turn: int = 0, state: int | None = None) -> int:
        r, c, h = (int(v) for v in grid.cell_heading(centre if state is None else state))
        return grid.state_of(r, c + dc, (h + turn) % grid.headings)

    # a cell with free cells 2, 3 and 5 columns east of it
    centre = next(s for s in range(model.n_states) if min(beside(dc, state=s) for dc in (2, 3, 5)) >= 0)

    tracker = ModelFilter(model)
    places = Places(grid)

    def one_place(other: int, share: float = 0.3) -> bool:
        belief = np.zeros(model.n_states)
        belief[centre], belief[other] = 1.0 - share, share
        tracker.start(belief)
        return LookAlikes(model, tracker, places, 0.99).one_place()

    assert one_place(beside(2))
    assert one_place(beside(3, turn=1))
    assert not one_place(beside(5))
    assert not one_place(beside(2, turn=4))
    assert not one_place(beside(2), share=0.005)  # the first mode holds the goal alone


def test_a_move_found_blocked_is_remembered_by_the_way_it_drives(kitchen: Any) -> None:
    """A step back found blocked facing one way is a step forward blocked once turned round on the
    spot (the telling macros turned round and drove into the same wall); a cell away, neither."""
    model, _ = kitchen
    grid = model.grid
    assert grid is not None
    places = Places(grid, model.actuation_actions)
    places.add("backward")  # stopped where it stands
    assert "backward" in places.here() and "forward" not in places.here()
    places.after_move(MotionReport(odometry=(0.0, 0.0, math.pi)))
    assert "forward" in places.here() and "backward" not in places.here()
    assert "backward" in places.after(model.action("rotate_cw"), model.action("rotate_cw"))
    places.after_move(MotionReport(odometry=(grid.cell_size, 0.0, 0.0)))
    assert not places.here() & {"forward", "backward"}


def _ladder(notched: bool) -> dict[str, Any]:
    """Two corridors joined by rungs, unchanged by a half turn -- but for one cell walled in at the
    east end of the south corridor when ``notched``."""
    south = "#......##" if notched else "#.......#"
    return {
        "name": "ladder",
        "grid": {"rows": 5, "cols": 9, "cell_size": 1.0, "headings": 4},
        "layout": "\n".join(["#########", "#.......#", "#.#.#.#.#", south, "#########"]),
        "actions": {name: {"cost": 1, "failure": 0.0} for name in ("forward", "backward", "rotate_cw", "rotate_ccw")},
        "sensors": {"scan": {"type": "scan", "cost": 1, "beams_deg": [90, 0, -90], "bins": [0.5, 1.5], "error": 0.05}},
    }


@pytest.mark.parametrize("truth", [0, 1])
def test_two_look_alike_places_are_led_to_where_a_reading_tells_them_apart(truth: int) -> None:
    """Khalvati & Mackworth's pairwise selection (:class:`LookAlikes`): a belief split 0.9 / 0.1
    between a state of the notched ladder and its image under the half turn -- the same readings
    everywhere but near the notch -- is led there and settled on the robot's own state, whichever of
    the two it is at; on the ladder without the notch nothing tells them apart, and no macro is offered."""

    class Gathering(ModelFilter):
        gathers_places = True

    for notched in (True, False):
        model, _ = _of(_ladder(notched))
        grid = model.grid
        assert grid is not None
        pair = [grid.state_of(1, 2, 1), grid.state_of(3, 6, 3)]  # east in the north corridor, its image
        belief = np.zeros(model.n_states)
        belief[pair] = [0.9, 0.1]
        tracker = Gathering(model)
        tracker.start(belief)
        places = Places(grid)
        lookalikes = LookAlikes(model, tracker, places, 0.99)
        if not notched:
            assert lookalikes.next_action(set(), None, True) is None
            continue
        robot = SimulatedRobot(model, pair[truth], np.random.default_rng(truth))
        action = None
        for _ in range(40):
            action = lookalikes.next_action(places.here(), action, True)
            if action is None:
                break
            observation = robot.act(action.name)
            tracker.predict(action, None)
            tracker.correct(action, observation)
            if action.is_actuation:
                places.after_move(None)
            else:
                places.add(action.name)
        assert tracker.belief.max() >= 0.99
        assert int(np.argmax(tracker.belief)) == robot.state


def test_the_first_command_carries_the_plan_and_its_expectation(kitchen: Any) -> None:
    model, binner = kitchen
    robot = SimulatedReadingRobot(SimulatedRobot(model, 0, np.random.default_rng(0)), binner)
    commands: list[Command] = []
    localize(model, uniform(model.n_states), robot, binner, on_step=lambda step: commands.append(step.command))
    first = commands[0]
    assert first.plan is not None and first.plan.found
    assert first.plan.steps[0].action == first.action.name
    assert first.expected == first.plan.steps[0].observation_index
    surprises = [c for c in commands[1:] if c.plan is not None]
    assert all(c.seq > 1 for c in surprises)  # a later plan is a replan


def test_an_already_localized_belief_needs_no_action(kitchen: Any) -> None:
    model, binner = kitchen
    belief = np.zeros(model.n_states)
    belief[3] = 1.0
    robot = Scripted({})
    outcome = localize(model, belief, robot, binner)
    assert outcome.localized and outcome.steps == 0 and robot.commands == []


@pytest.mark.parametrize(
    ("data", "readings", "max_steps", "status"),
    [
        (TWINS, {"look": []}, 10, EpisodeStatus.NO_PLAN),
        (LAMP, {"look": ["lamp"]}, 10, EpisodeStatus.IMPOSSIBLE_OBSERVATION),
        (None, {"look": [], "scan": 0.6}, 1, EpisodeStatus.STEP_LIMIT),
    ],
)
def test_the_loop_ends_with_an_honest_status(
    kitchen: Any, data: dict[str, Any] | None, readings: dict[str, Any], max_steps: int, status: EpisodeStatus
) -> None:
    model, binner = kitchen if data is None else _of(data)
    robot = Scripted(readings)
    outcome = localize(model, uniform(model.n_states), robot, binner, max_steps=max_steps)
    assert outcome.status is status
    assert not outcome.localized
    data_out = outcome.as_json(model)
    assert data_out["status"] == status.value and data_out["state"] is None and data_out["pose"] is None
    if status is EpisodeStatus.IMPOSSIBLE_OBSERVATION:
        assert outcome.reason.startswith("action 1: observation 'lamp' after 'look' has probability 0")


def test_a_reading_the_binner_refuses_is_a_reply_error() -> None:
    model, binner = _of(LAMP)
    with pytest.raises(ReplyError, match=r"^the reply to action 1 \(look\): look: 'sofa': not a class this sensor"):
        localize(model, uniform(model.n_states), Scripted({"look": ["sofa"]}), binner)


def test_the_planner_settings_reach_the_planner(kitchen: Any) -> None:
    model, binner = kitchen
    robot = Scripted({})
    settings = PlannerSettings(max_expansions=1, anytime=False)
    outcome = localize(model, uniform(model.n_states), robot, binner, settings=settings)
    assert outcome.status is EpisodeStatus.BUDGET_EXCEEDED and robot.commands == []


@pytest.mark.parametrize("seed", range(3))
def test_out_of_budget_localize_acts_on_the_best_partial_plan_and_never_gives_up(kitchen: Any, seed: int) -> None:
    """Issue 28: one expansion a plan call never finds a whole plan on the kitchen, yet the robot acts
    on the best partial plans and is localized."""
    model, binner = kitchen
    world = SimulatedRobot(model, model.states.index("1,1,1"), np.random.default_rng(seed))
    commands: list[Command] = []
    outcome = localize(
        model,
        uniform(model.n_states),
        SimulatedReadingRobot(world, binner),
        binner,
        settings=PlannerSettings(max_expansions=1),
        on_step=lambda step: commands.append(step.command),
    )
    assert outcome.status is EpisodeStatus.LOCALIZED and int(np.argmax(outcome.belief)) == world.state
    plans = [c.plan for c in commands if c.plan is not None]
    assert plans and commands[0].plan is not None
    assert plans[0].partial and not plans[0].complete  # near the goal a call may find a whole plan
    assert all(p.partial or p.complete for p in plans)
    assert commands[0].action.name == commands[0].plan.steps[0].action


# --- the line protocol ---------------------------------------------------------------------------


def _command(model: Model, action: str, observation: str | None = None, seq: int = 1) -> Command:
    act = model.action(action)
    return Command(seq, act, None if observation is None else act.observation.index(observation), None)


def test_an_action_message_tells_the_robot_everything(kitchen: Any) -> None:
    model, binner = kitchen
    message = action_message(_command(model, "scan", "no_wall", seq=3), binner)
    assert message == {
        "message": "action",
        "protocol": 1,
        "seq": 3,
        "action": "scan",
        "kind": "perception",
        "motion": None,
        "sensors": [{"name": "scan", "type": "scan", "beams": [0.0], "bins": [0.2, 0.8, 1.1, 1.5]}],
        "expected": {"observation": "no_wall", "readings": {"scan": [None]}},
        "planned": False,
    }
    assert action_message(_command(model, "look", "chair"), binner)["expected"]["readings"] == {"look": ["chair"]}
    turn = action_message(_command(model, "rotate_cw"), binner)
    assert turn["motion"] == {"turn": pytest.approx(-math.pi / 2)}
    assert turn["sensors"] == [] and turn["expected"] is None and turn["kind"] == "actuation"
    assert action_message(_command(model, "backward"), binner)["motion"] == {"advance": -1.2}


def test_a_compass_move_is_a_map_frame_step() -> None:
    smap = load_map(MAPS / "khalvati-example1.yaml")
    model = compile_model(smap)
    message = action_message(_command(model, "up", "1"), ReadingBinner(smap, model))
    assert message["motion"] == {"x": 0.0, "y": 1.0}
    assert message["expected"] == {"observation": "1", "readings": {"here": "1"}}


def _robot(binner: ReadingBinner, replies: str) -> tuple[LineRobot, list[str]]:
    written: list[str] = []
    return LineRobot(binner, io.StringIO(replies).readline, written.append), written


def test_a_reply_is_read_one_line_at_a_time(kitchen: Any) -> None:
    model, binner = kitchen
    robot, written = _robot(binner, '{"seq": 1, "readings": {"scan": Infinity}}\n{"seq": 2}\nnot read yet\n')
    assert robot.act(_command(model, "scan", "no_wall")) == {"scan": math.inf}
    assert robot.act(_command(model, "forward", seq=2)) == {}
    assert [json.loads(line)["seq"] for line in written] == [1, 2]
    assert robot.lines_read == 2


@pytest.mark.parametrize(
    ("reply", "message"),
    [
        ("", r"^stdin ended before the reply to action 1 \(scan\)$"),
        ("\n", r"^stdin line 1, the reply to action 1 \(scan\): an empty line; expected one JSON object such as"),
        ("hello\n", r"^stdin line 1, the reply to action 1 \(scan\): not JSON \(Expecting value"),
        ("[1]\n", r": a JSON object such as \{\"seq\": 1, \"readings\": \{\.\.\.\}\} was expected, got a list$"),
        (
            '{"seq": 1, "reading": {}}\n',
            r": unknown key 'reading'; a reply has 'seq' and 'readings', and after a move optionally 'odometry' "
            r"and 'blocked'$",
        ),
        ('{"readings": {}}\n', r": 'seq' should be the action's sequence number 1, got None$"),
        ('{"seq": true}\n', r": 'seq' should be the action's sequence number 1, got True$"),
        ('{"seq": 2}\n', r": out of order: 'seq' is 2, but the action waiting for a reply is 1$"),
        (
            '{"seq": 1, "readings": [0.5]}\n',
            r": 'readings' should map each sensor's name to its raw reading, got a list$",
        ),
        ('{"seq": 1, "readings": {"scan": NaN}}\n', r": not JSON \(NaN is not a reading\)"),
        ('{"seq": 1, "readings": ' + "[" * 100_000 + "\n", r": (JSON nested too deeply|not JSON)"),
        ("x" * (MAX_LINE_CHARS + 10) + "\n", rf": longer than {MAX_LINE_CHARS} characters$"),
    ],
)
def test_a_bad_reply_names_its_line(kitchen: Any, reply: str, message: str) -> None:
    model, binner = kitchen
    robot, _ = _robot(binner, reply)
    with pytest.raises(ReplyError, match=message):
        robot.act(_command(model, "scan", "no_wall"))


def test_a_reply_that_is_not_utf8_names_its_line(kitchen: Any) -> None:
    model, binner = kitchen

    def read_line(limit: int) -> str:
        raise UnicodeDecodeError("utf-8", b"\xff", 0, 1, "invalid start byte")

    robot = LineRobot(binner, read_line, lambda line: None)
    with pytest.raises(ReplyError, match=r"^stdin line 1, the reply to action 1 \(scan\): not UTF-8 text"):
        robot.act(_command(model, "scan", "no_wall"))


# --- the command, in process ---------------------------------------------------------------------


def _lines(stdout: str) -> list[dict[str, Any]]:
    return [json.loads(line) for line in stdout.splitlines()]


def test_help_reads_well(runner: CliRunner) -> None:
    result = runner.invoke(app, ["localize", "--help"])
    assert result.exit_code == 0
    text = " ".join(result.stdout.split())
    assert "Examples: printf" in text and "| beliefloc localize" not in text
    assert "beliefloc localize maps/window-2x2-perfect.yaml < replies.jsonl" in text
    assert "docs/localize-protocol.md" in text
    for option in ("--belief", "--threshold", "--planner", "--heuristic", "--h-weight", "--max-expansions"):
        assert option in text
    assert "--time-limit" in text and "--max-steps" in text


def test_a_pomdp_file_is_refused(runner: CliRunner, tmp_path: Path) -> None:
    result = runner.invoke(app, ["localize", str(tmp_path / "rooms.pomdp")])
    assert result.exit_code == EXIT_BAD_INPUT
    assert "localize needs a map (.yaml)" in " ".join(result.stderr.split())
    assert result.stdout == ""


def test_a_built_model_works_while_its_map_is_unchanged(runner: CliRunner, tmp_path: Path) -> None:
    model_file = tmp_path / "kitchen.npz"
    assert runner.invoke(app, ["build", KITCHEN, "-o", str(model_file)]).exit_code == 0
    result = runner.invoke(app, ["localize", str(model_file)], input="")
    assert result.exit_code == EXIT_BAD_INPUT  # it got as far as the first action
    assert _lines(result.stdout)[0]["message"] == "action"


@pytest.mark.parametrize(
    ("data", "reply", "status"),
    [(TWINS, "", "no_plan"), (LAMP, '{"seq": 1, "readings": {"look": ["lamp"]}}\n', "impossible_observation")],
)
def test_not_localized_is_exit_1_with_a_result_line(
    runner: CliRunner, tmp_path: Path, data: dict[str, Any], reply: str, status: str
) -> None:
    path = tmp_path / "map.yaml"
    path.write_text(yaml.safe_dump(data))
    result = runner.invoke(app, ["localize", str(path)], input=reply)
    assert result.exit_code == EXIT_NEGATIVE, result.output
    last = _lines(result.stdout)[-1]
    assert last["message"] == "result" and last["status"] == status and last["localized"] is False
    assert last["state"] is None and last["pose"] is None
    assert f"not localized, {status.replace('_', ' ')}" in " ".join(result.stderr.split())


def test_a_bad_reading_is_exit_2_with_an_error_line(runner: CliRunner, tmp_path: Path) -> None:
    path = tmp_path / "map.yaml"
    path.write_text(yaml.safe_dump(LAMP))
    result = runner.invoke(app, ["localize", str(path)], input='{"seq": 1, "readings": {"look": ["sofa"]}}\n')
    assert result.exit_code == EXIT_BAD_INPUT
    message = "the reply to action 1 (look): look: 'sofa': not a class this sensor looks for (door, lamp)"
    assert message in " ".join(result.stderr.split())
    assert _lines(result.stdout)[-1] == {"message": "error", "protocol": 1, "error": message}


# --- end to end: a robot in another process -------------------------------------------------------

ROBOT = r"""
import json, subprocess, sys

from beliefloc import compile_model, load_map
from beliefloc.semantic_map import geometry, pixel_geometry

map_path, start, *options = sys.argv[1:]
smap = load_map(map_path)
model = compile_model(smap)
grid = model.grid
state = model.states.index(start)  # the robot's secret
occupancy = smap.occupancy_map
if occupancy is None:  # metres to the wall, beyond the last bin too
    ahead = geometry.wall_distances(grid, 100.0)
else:  # a laser's ray over the pixels
    ahead = pixel_geometry.ray_distances(occupancy.blocked(), occupancy.resolution, grid, 100.0)
moves = {a.name: geometry.motion_targets(grid, a.name) for a in model.actuation_actions}
looks = {a.name: a.observation.parts for a in model.perception_actions}

beliefloc = subprocess.Popen(
    [sys.executable, "-m", "beliefloc", "localize", map_path, *options],
    stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
)
messages = []
while True:
    line = beliefloc.stdout.readline()
    if not line:
        break
    message = json.loads(line)
    messages.append(message)
    if message["message"] != "action":
        break
    if message["kind"] == "actuation":
        state = int(moves[message["action"]][state])  # a real robot's move succeeds
    readings = {}
    for sensor in message["sensors"]:
        if sensor["type"] == "scan":  # the true distance in metres, e.g. 1.8 (no_wall)
            readings[sensor["name"]] = [float(ahead[state])]
        else:  # the classes in view
            parts = looks[sensor["name"]]
            readings[sensor["name"]] = [c for c, p in zip(sensor["classes"], parts) if p.truth[state]]
    beliefloc.stdin.write(json.dumps({"seq": message["seq"], "readings": readings}) + "\n")
    beliefloc.stdin.flush()
_, stderr = beliefloc.communicate(timeout=60)
json.dump({"code": beliefloc.returncode, "true_state": model.states.name(state), "messages": messages,
           "stderr": stderr}, sys.stdout)
"""


@pytest.mark.parametrize("start", ["1,1,1", "2,2,3"])
def test_a_robot_in_another_process_is_localized(start: str) -> None:
    played = subprocess.run(
        [sys.executable, "-c", ROBOT, KITCHEN, start], capture_output=True, text=True, timeout=120, cwd=ROOT
    )
    assert played.returncode == 0, played.stderr
    run = json.loads(played.stdout)
    assert run["code"] == 0, run["stderr"]
    *actions, result = run["messages"]
    assert [a["seq"] for a in actions] == list(range(1, len(actions) + 1))
    assert all(a["message"] == "action" for a in actions) and actions[0]["planned"] is True
    assert result["message"] == "result" and result["status"] == "localized"
    assert result["state"] == run["true_state"]
    model = compile_model(load_map(KITCHEN))
    assert model.grid is not None
    pose = state_pose(model.grid, model.states.index(run["true_state"]))
    assert (result["pose"]["x"], result["pose"]["y"], result["pose"]["yaw"]) == pytest.approx(
        (pose.x, pose.y, pose.yaw)
    )
    assert len(result["pose"]["covariance"]) == 36
    assert result["steps"] == len(actions)
    assert "localized:" in run["stderr"]


@pytest.mark.slow
def test_a_robot_on_the_depot_gets_an_initial_pose_for_amcl(tmp_path: Path) -> None:
    """The README's path from a SLAM map to AMCL: localize with --belief-out on Nav2's depot (a robot
    in another process answering laser ranges cast over the pixels), then 'pose --format ros'."""
    depot, belief = str(ROOT / "maps" / "depot.yaml"), tmp_path / "belief.json"
    # the robot stands at cell centres and moves cell by cell: the papers' filter over the states
    run = _played(depot, "30,60,2", "--belief-out", str(belief), "--quiet", "--filter", "states")
    result = run["messages"][-1]
    assert result["status"] == "localized" and result["state"] == run["true_state"]
    ros = _beliefloc("pose", depot, "--belief", str(belief), "--format", "ros")
    assert ros.returncode == 0, ros.stderr
    message = yaml.safe_load(ros.stdout)
    assert message["header"]["frame_id"] == "map"
    position = message["pose"]["pose"]["position"]
    assert (position["x"], position["y"]) == pytest.approx((result["pose"]["x"], result["pose"]["y"]), abs=1e-9)
    # the message's covariance: the belief's, made non-negative for Rolling's AMCL, to 9 decimals
    safe = nonnegative_covariance(tuple(result["pose"]["covariance"]))
    assert message["pose"]["covariance"] == pytest.approx(safe, abs=1e-9)
    assert min(message["pose"]["covariance"]) >= 0.0


def _played(map_path: str, start: str, *options: str) -> dict[str, Any]:
    """``localize`` on ``map_path`` with ROBOT answering from ``start`` (a robot at cell centres, in
    another process); the run, checked to have ended with exit 0."""
    played = subprocess.run(
        [sys.executable, "-c", ROBOT, map_path, start, *options], capture_output=True, text=True, timeout=300, cwd=ROOT
    )
    assert played.returncode == 0, played.stderr
    run: dict[str, Any] = json.loads(played.stdout)
    assert run["code"] == 0, run["stderr"]
    return run


def _beliefloc(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "beliefloc", *args], capture_output=True, text=True, timeout=60, cwd=ROOT
    )


def _localize(stdin: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "beliefloc", "localize", KITCHEN],
        input=stdin,
        capture_output=True,
        text=True,
        timeout=30,
        cwd=ROOT,
    )


@pytest.mark.parametrize(
    ("stdin", "message"),
    [
        ("garbage\n", r"stdin line 1, the reply to action 1 \(\w+\): not JSON"),
        ('{"seq": 2}\n', r"stdin line 1, the reply to action 1 \(\w+\): out of order: 'seq' is 2"),
        ("", r"stdin ended before the reply to action 1 \(\w+\)"),
    ],
)
def test_a_bad_or_missing_reply_ends_the_process_with_exit_2(stdin: str, message: str) -> None:
    result = _localize(stdin)
    assert result.returncode == EXIT_BAD_INPUT
    stderr = " ".join(result.stderr.split())
    assert stderr.startswith("error: ") and "Traceback" not in stderr
    assert re.search(message, stderr), stderr
    first, last = _lines(result.stdout)
    assert first["message"] == "action" and first["seq"] == 1
    assert last["message"] == "error"


def test_a_lattice_run_s_pose_travels_with_its_belief_file_to_amcl(tmp_path: Path) -> None:
    """The README's path with the pose lattice: ``localize --belief-out`` writes the lattice's pose and
    the probability it was declared at beside the belief, and ``pose --belief`` reports that pose -- the
    result line's, not the state's cell centre -- in its JSON and in the message for /initialpose,
    judged localized by that probability (before, a robot declared at 0.976 on the depot was refused:
    its most likely state alone held 0.907, its place 0.994)."""
    depot, belief = str(ROOT / "maps" / "depot.yaml"), tmp_path / "belief.json"
    run = _played(depot, "30,60,2", "--belief-out", str(belief), "--quiet", "--filter", "lattice")
    result = run["messages"][-1]
    assert result["status"] == "localized"
    written = json.loads(belief.read_text())
    assert written["localized_pose"] == {
        "state": result["state"],
        "probability": result["probability"],
        **result["pose"],
    }
    shown = _beliefloc("pose", depot, "--belief", str(belief))
    assert shown.returncode == 0, shown.stderr
    pose = json.loads(shown.stdout)
    assert pose["state"] == result["state"] and pose["pose"] == result["pose"]
    ros = _beliefloc("pose", depot, "--belief", str(belief), "--format", "ros")
    assert ros.returncode == 0, ros.stderr
    position = yaml.safe_load(ros.stdout)["pose"]["pose"]["position"]
    assert (position["x"], position["y"]) == pytest.approx((result["pose"]["x"], result["pose"]["y"]), abs=1e-9)
