"""Issue 26, part 5: ``simulate --continuous``, episodes against a continuous simulated robot."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from beliefloc import compile_model, load_map
from beliefloc.belief import uniform
from beliefloc.cli.app import app
from beliefloc.continuous.likelihood_field import Scan
from beliefloc.errors import InvalidValueError
from beliefloc.model import Model
from beliefloc.robots.localize import Command, Places, SimulatedReadingRobot, localize, moved
from beliefloc.robots.odometry import MotionReport
from beliefloc.robots.readings import ReadingBinner
from beliefloc.simulation.continuous_episode import ContinuousSetup, heading_of, is_wrong, pose_errors, state_at
from beliefloc.simulation.episode import ContinuousOutcome, EpisodeRecord, EpisodeSweep, records_from_results
from beliefloc.simulation.robot import SimulatedRobot
from beliefloc.simulation.strategies import EpisodeStatus, PlannerSettings, SharedWork

from .conftest import MAPS

KITCHEN = str(MAPS / "kitchen.yaml")


def _kitchen_setup(clutter: float = 0.0) -> tuple[ContinuousSetup, Model]:
    smap = load_map(MAPS / "kitchen.yaml")
    return ContinuousSetup(smap, clutter=clutter), compile_model(smap)


def test_every_state_region_holds_its_own_centre_and_heading() -> None:
    model = compile_model(load_map(MAPS / "kitchen.yaml"))
    grid = model.grid
    assert grid is not None
    for state in range(0, model.n_states, 7):
        row, col, heading = grid.cell_heading(state)
        x, y = grid.cell_centre(row, col)
        yaw = float(grid.heading_yaw(heading))
        off = 0.49 * math.pi / grid.headings  # inside the sector, near its edge
        for d in (-off, 0.0, off):
            assert state_at(grid, np.array([float(x), float(y), yaw + d])) == state
        assert heading_of(grid, yaw) == int(heading)
        assert pose_errors(grid, state, np.array([float(x) + 0.3, float(y), yaw + 0.1])) == pytest.approx((0.3, 0.1))
    assert not is_wrong(grid, 1.5 * grid.cell_size, 2 * math.pi / grid.headings)
    assert is_wrong(grid, 1.5 * grid.cell_size + 1e-6, 0.0)
    assert is_wrong(grid, 0.0, 2 * math.pi / grid.headings + 1e-6)


@pytest.mark.parametrize("strategy", ["bestfirst", "contingent", "ec2-macros", "random"])
def test_an_episode_against_the_continuous_robot_records_its_true_pose_and_errors(strategy: str) -> None:
    setup, model = _kitchen_setup(clutter=0.1)
    grid = model.grid
    assert grid is not None
    shared = SharedWork.for_model(model)
    belief = np.full(model.n_states, 1.0 / model.n_states)
    settings = PlannerSettings(time_limit=2.0, lookahead=50)
    run = setup.run(
        model, strategy, seed=3, episode=1, start_belief=belief, settings=settings, shared=shared, max_steps=8
    )
    c = run.continuous
    assert c is not None and run.strategy == strategy
    assert run.steps <= 8 and len(run.trace) == run.steps
    final = model.states.index(run.final)
    assert (c.position_error, c.yaw_error) == pytest.approx(pose_errors(grid, final, np.array(c.true_pose)))
    # the pose reported: the lattice's within the declared state's promise, its errors its own
    assert run.pose is not None and run.pose.state == final
    reported = np.array([run.pose.pose.x, run.pose.pose.y, run.pose.pose.yaw])
    assert c.pose_position_error is not None and c.pose_yaw_error is not None
    assert (c.pose_position_error, c.pose_yaw_error) == pytest.approx(_apart(reported, np.array(c.true_pose)))
    off, turned = pose_errors(grid, final, reported)
    assert off <= 1.5 * grid.cell_size + 1e-9 and turned <= 2 * math.pi / grid.headings + 1e-9
    assert c.confidently_wrong == (
        run.status is EpisodeStatus.LOCALIZED and is_wrong(grid, c.position_error, c.yaw_error)
    )
    assert run.correct == (state_at(grid, np.array(c.true_pose)) == final)
    assert 0.0 <= c.model_confidence <= 1.0
    # the same seed and episode: the same episode
    again = setup.run(
        model, strategy, seed=3, episode=1, start_belief=belief, settings=settings, shared=shared, max_steps=8
    )
    assert again.continuous is not None and again.continuous.start_pose == c.start_pose
    if strategy != "contingent":  # the contingent planner's graph is shared and kept between episodes
        assert again.as_json(timings=False) == run.as_json(timings=False)


def _apart(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """Metres and radians between two map-frame poses, worked out here."""
    return math.hypot(a[0] - b[0], a[1] - b[1]), abs(math.remainder(a[2] - b[2], 2 * math.pi))


def test_the_start_pose_is_anywhere_in_free_space_with_any_yaw() -> None:
    setup, model = _kitchen_setup()
    sweep = EpisodeSweep(model, ("ec2",), seed=0, robot=setup, max_steps=1)
    shared = SharedWork.for_model(model)
    outcomes = [sweep.paired(e, shared)[0].continuous for e in range(40)]
    starts = np.array([c.start_pose for c in outcomes if c is not None])
    grid = model.grid
    assert grid is not None
    s = grid.cell_size
    # off the cell centres and off the headings
    gx, gy = grid.frame.to_grid(starts[:, 0], starts[:, 1])
    assert np.mean(np.hypot(gx / s % 1 - 0.5, gy / s % 1 - 0.5) > 0.05) > 0.5
    sector = 2 * math.pi / grid.headings
    off_heading = np.abs(np.remainder(starts[:, 2] - grid.frame.yaw + sector / 2, sector) - sector / 2)
    assert np.mean(off_heading > 0.01) > 0.8
    assert starts[:, 2].min() < -1.5 and starts[:, 2].max() > 1.5


def _record_json() -> dict[str, object]:
    outcome = ContinuousOutcome((1.0, 2.0, 0.5), (1.5, 2.0, 0.4), 0.25, 0.1, False, 0.8, 1)
    record = EpisodeRecord(
        "bestfirst", 0, "1,1,0", "1,2,0", "1,2,0", True, EpisodeStatus.LOCALIZED, 3.0, 3, 0, [0.1], 0.97
    )
    record.continuous = outcome
    return record.as_json()


def test_records_read_back_whole_and_strictly() -> None:
    data = _record_json()
    back = EpisodeRecord.from_json(json.loads(json.dumps(data)))
    assert back.continuous == ContinuousOutcome((1.0, 2.0, 0.5), (1.5, 2.0, 0.4), 0.25, 0.1, False, 0.8, 1)
    assert "pose_position_error" not in data["continuous"]  # type: ignore[operator]  # a record made before them
    reported = json.loads(json.dumps(data))
    reported["continuous"].update(pose_position_error=0.03, pose_yaw_error=0.05)
    assert EpisodeRecord.from_json(reported).continuous == ContinuousOutcome(
        (1.0, 2.0, 0.5), (1.5, 2.0, 0.4), 0.25, 0.1, False, 0.8, 1, 0.03, 0.05
    )
    alone = json.loads(json.dumps(reported))
    del alone["continuous"]["pose_yaw_error"]
    with pytest.raises(ValueError, match="come together"):
        EpisodeRecord.from_json(alone)
    plain = {k: v for k, v in data.items() if k != "continuous"}
    assert EpisodeRecord.from_json(plain).continuous is None  # a grid episode's record
    bad: list[tuple[str, object]] = [
        ("confidently_wrong", 1),
        ("position_error", float("nan")),
        ("position_error", -1.0),
        ("yaw_error", 4.0),
        ("true_pose", [1.0, 2.0]),
        ("true_pose", [1.0, "2", 0.0]),
        ("model_confidence", 1.5),
        ("recoveries", -1),
        ("surprise", 3),
        ("pose_position_error", -0.1),
        ("pose_yaw_error", 4.0),
        ("pose_yaw_error", "0.1"),
    ]
    for key, value in bad:
        broken = json.loads(json.dumps(reported))
        broken["continuous"][key] = value
        with pytest.raises(ValueError, match=key):
            EpisodeRecord.from_json(broken)
    missing = json.loads(json.dumps(data))
    del missing["continuous"]["recoveries"]
    with pytest.raises(ValueError, match="no field 'recoveries'"):
        EpisodeRecord.from_json(missing)
    with pytest.raises(ValueError, match="continuous"):
        records_from_results([{"episode": 0, "records": [{**data, "continuous": [1, 2]}]}])


@pytest.mark.slow
def test_simulate_continuous_on_the_command_line(runner, tmp_path: Path) -> None:
    out = tmp_path / "k.jsonl"
    args = ["simulate", KITCHEN, "-n", "2", "--continuous", "--clutter", "0.1", "--max-steps", "6", "--no-timings"]
    result = runner.invoke(app, [*args, "-s", "bestfirst", "-s", "ec2-macros", "--json", "--out", str(out)])
    assert result.exit_code in (0, 1), result.output
    episodes = json.loads(result.stdout)["episodes"]
    assert [e["strategy"] for e in episodes] == ["bestfirst", "ec2-macros"] * 2
    for e in episodes:
        assert set(e["continuous"]) >= {"true_pose", "position_error", "yaw_error", "confidently_wrong"}
    # paired: both strategies of an episode start from the same continuous pose
    assert episodes[0]["continuous"]["start_pose"] == episodes[1]["continuous"]["start_pose"]
    assert json.loads(out.read_text().splitlines()[0])["settings"]["continuous"] == {"clutter": 0.1}
    text = runner.invoke(app, [*args, "-s", "bestfirst"])
    assert "confidently wrong" in text.stdout
    # a damaged continuous field in the results file: refused whole, naming the line, exit 2
    lines = out.read_text().splitlines()
    line = json.loads(lines[1])
    line["records"][0]["continuous"]["yaw_error"] = "north"
    lines[1] = json.dumps(line)
    out.write_text("\n".join(lines) + "\n")
    resumed = runner.invoke(app, [*args, "-s", "bestfirst", "-s", "ec2-macros", "--out", str(out), "--resume"])
    assert resumed.exit_code == 2 and ":2:" in resumed.stderr and "yaw_error" in resumed.stderr


def test_the_summary_line_gives_the_median_distance_of_the_pose_reported_when_localized() -> None:
    """``simulate --continuous``'s last line: per strategy, the confidently wrong episodes and how far
    the pose reported was from the truth -- the median over the localized episodes only."""
    from beliefloc.cli.simulate import _continuous_line

    def record(status: EpisodeStatus, metres: float, radians: float) -> EpisodeRecord:
        r = EpisodeRecord("bestfirst", 0, "1,1,0", "1,2,0", "1,2,0", True, status, 3.0, 3, 0, [0.1], 0.97)
        r.continuous = ContinuousOutcome((1.0, 2.0, 0.5), (1.5, 2.0, 0.4), 0.25, 0.1, False, 0.8, 0, metres, radians)
        return r

    line = _continuous_line(
        [
            record(EpisodeStatus.LOCALIZED, 0.02, math.radians(1)),
            record(EpisodeStatus.LOCALIZED, 0.04, math.radians(3)),
            record(EpisodeStatus.STEP_LIMIT, 9.0, 3.0),
        ]
    )
    assert line == (
        "continuous robot: bestfirst: confidently wrong 0 of 3, the pose reported 0.03 m and 2° from the truth (median)"
    )


def test_simulate_continuous_full_scans_answers_whole_scans_scored_at_every_lattice_pose(
    runner, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``--full-scans BEAMS``: every scan reply is a whole scan of BEAMS rays, which the pose-lattice
    filter scores in full (counted here at the lattice's scan model), and the results file's header
    says so."""
    from beliefloc.continuous.lattice_scan import LatticeScanModel

    sizes: list[int] = []
    score = LatticeScanModel.log_likelihood

    def counted(self: LatticeScanModel, scan: Scan, *args: object) -> np.ndarray:
        sizes.append(scan.ranges.size)
        return score(self, scan, *args)  # type: ignore[arg-type]

    monkeypatch.setattr(LatticeScanModel, "log_likelihood", counted)
    out = tmp_path / "k.jsonl"
    sandbox = str(MAPS / "tb3-sandbox.yaml")  # a map whose plans scan (the kitchen's look first)
    args = ["simulate", sandbox, "-n", "1", "--continuous", "--full-scans", "90", "--max-steps", "3", "--no-timings"]
    result = runner.invoke(app, [*args, "--json", "--out", str(out)])
    assert result.exit_code in (0, 1), result.output
    (episode,) = json.loads(result.stdout)["episodes"]
    assert episode["steps"] >= 1 and "true_pose" in episode["continuous"]
    assert sizes and set(sizes) == {90}
    settings = json.loads(out.read_text().splitlines()[0])["settings"]
    assert settings["continuous"] == {"clutter": 0.0, "full_scans": 90}


@pytest.mark.parametrize(
    ("extra", "says"),
    [
        (["--full-scans", "90"], "--continuous"),
        (["--continuous", "--full-scans", "0"], "--full-scans"),
        (["--continuous", "--full-scans", "10001"], "--full-scans"),
        (["--clutter", "0.1"], "--continuous"),
        (["--continuous", "--world", KITCHEN], "--world"),
        (["--continuous", "--start", "1,1,0"], "--start"),
        (["--continuous", "--clutter", "1.5"], "--clutter"),
        (["--obstacles", "3"], "--continuous"),
        (["--continuous", "--obstacles", "-1"], "--obstacles"),
        (["--continuous", "--obstacles", "1001"], "--obstacles"),
    ],
)
def test_continuous_options_out_of_place_are_refused(runner, extra: list[str], says: str) -> None:
    result = runner.invoke(app, ["simulate", KITCHEN, "-n", "1", *extra])
    assert result.exit_code == 2 and says in result.stderr
    assert "Traceback" not in result.output


def test_full_scans_on_a_map_without_a_scan_sensor_is_refused(runner) -> None:
    result = runner.invoke(
        app, ["simulate", str(MAPS / "khalvati-example1.yaml"), "--continuous", "--full-scans", "90"]
    )
    assert result.exit_code == 2 and "--full-scans" in result.stderr and "no scan sensor" in result.stderr
    assert "Traceback" not in result.output


def test_unmapped_obstacles_stop_rays_and_the_robot_and_leave_the_start_alone() -> None:
    """``obstacles``: discs the map does not show, drawn afresh for each episode from its own generator,
    away from the start; the start itself is the episode's start without them (paired episodes)."""
    smap = load_map(MAPS / "tb3-sandbox.yaml")
    model = compile_model(smap)
    plain, cluttered = ContinuousSetup(smap), ContinuousSetup(smap, obstacles=6)
    stopped = 0
    for episode in range(3):
        robot, _, _ = cluttered.robot(model, 5, episode)
        world = robot.world
        discs = world.clutter_discs.copy()
        assert discs.shape == (6, 3)
        assert np.all((discs[:, 2] >= 0.1) & (discs[:, 2] <= 0.3))
        x, y = float(robot.pose[0]), float(robot.pose[1])
        assert np.all(np.hypot(discs[:, 0] - x, discs[:, 1] - y) >= 0.5)
        alone, _, _ = plain.robot(model, 5, episode)
        assert np.array_equal(alone.pose, robot.pose) and len(alone.world.clutter_discs) == 0
        for dx, dy, radius in discs:
            # the robot cannot stand on one, and a ray from beside it stops at its edge (or nearer)
            assert not world.can_stand(np.array([dx]), np.array([dy]))[0]
            hit = float(world.cast(dx - radius - 0.3, dy, 0.0, 5.0))
            assert hit <= 0.3 + 1e-9
            alone_disc = np.sum(np.hypot(discs[:, 0] - dx, discs[:, 1] - dy) < discs[:, 2] + radius + 0.7) == 1
            if alone_disc and float(alone.world.cast(dx - radius - 0.3, dy, 0.0, 5.0)) > 0.3:
                assert hit == pytest.approx(0.3, abs=1e-9)  # the map has nothing there: the disc stopped it
                stopped += 1
        again, _, _ = cluttered.robot(model, 5, episode)
        assert np.array_equal(again.world.clutter_discs, discs)
    assert stopped >= 3
    with pytest.raises(InvalidValueError, match="obstacles"):
        ContinuousSetup(smap, obstacles=-1)


@pytest.mark.slow
def test_simulate_continuous_with_unmapped_obstacles_on_the_command_line(runner, tmp_path: Path) -> None:
    out = tmp_path / "k.jsonl"
    args = ["simulate", KITCHEN, "-n", "1", "--continuous", "--obstacles", "4", "--max-steps", "5", "--no-timings"]
    result = runner.invoke(app, [*args, "--json", "--out", str(out)])
    assert result.exit_code in (0, 1), result.output
    (episode,) = json.loads(result.stdout)["episodes"]
    assert "true_pose" in episode["continuous"]
    assert json.loads(out.read_text().splitlines()[0])["settings"]["continuous"] == {"clutter": 0.0, "obstacles": 4}


# --- one reading per place (localize) ------------------------------------------------------------


class _Still:
    """A robot that never moves (every move blocked, odometry 0) and reads the same thing every time:
    what a robot in a corner reading one spot would answer."""

    def __init__(self, readings: dict[str, object], report: MotionReport) -> None:
        self.readings = readings
        self.report = report
        self.commands: list[Command] = []
        self._last: Command | None = None

    def act(self, command: Command) -> dict[str, object]:
        self.commands.append(command)
        self._last = command
        action = command.action
        return {} if action.is_actuation else {action.name: self.readings[action.name]}

    def motion_report(self) -> MotionReport | None:
        assert self._last is not None
        return self.report if self._last.action.is_actuation else None


def _runs_of_the_same_reading(commands: list[Command], still: bool) -> int:
    """How often a perception action repeats one already taken at this place (``still``: no move moves)."""
    here: set[str] = set()
    repeats = 0
    for c in commands:
        name = c.action.name
        if c.action.is_actuation and not still:
            here.clear()
            continue
        repeats += name in here
        here.add(name)
    return repeats


@pytest.mark.parametrize("report", [MotionReport((0.0, 0.0, 0.0), True), MotionReport(None, True)])
def test_a_robot_that_cannot_move_is_never_read_twice_nor_declared_on_repeats(report: MotionReport) -> None:
    smap = load_map(MAPS / "kitchen.yaml")
    model = compile_model(smap)
    binner = ReadingBinner(smap, model)
    robot = _Still({"look": ["chair"], "scan": 0.6}, report)
    outcome = localize(model, uniform(model.n_states), robot, binner, max_steps=30)
    assert _runs_of_the_same_reading(robot.commands, still=True) == 0
    assert not outcome.localized  # one look and one scan from one spot do not localize in the kitchen
    # the same robot, the readings counted as independent (the grid world's assumption): repeats happen
    again = _Still({"look": ["chair"], "scan": 0.6}, report)
    localize(model, uniform(model.n_states), again, binner, max_steps=30, repeat_readings=True)
    assert _runs_of_the_same_reading(again.commands, still=True) > 0


def test_moved_says_whether_the_sensors_read_a_new_place() -> None:
    grid = compile_model(load_map(MAPS / "kitchen.yaml")).grid
    assert grid is not None
    quarter = grid.cell_size / 4
    assert moved(None, grid)  # protocol 1: the robot is taken at its word
    assert moved(MotionReport(None, False), grid) and not moved(MotionReport(None, True), grid)
    assert moved(MotionReport((quarter, 0.0, 0.0), True), grid)  # stopped partway, but somewhere new
    assert not moved(MotionReport((quarter / 2, 0.0, 0.0), False), grid)
    assert moved(MotionReport((0.0, 0.0, math.radians(90) / 4), False), grid)
    assert not moved(MotionReport((0.0, 0.0, math.radians(5)), False), grid)


def test_places_remember_a_reading_when_the_robot_turns_back() -> None:
    grid = compile_model(load_map(MAPS / "kitchen.yaml")).grid
    places = Places(grid)
    places.add("scan")
    quarter_turn = math.pi / 2
    places.after_move(MotionReport((0.0, 0.0, quarter_turn), False))
    assert places.here() == set()  # facing another way: a new view
    places.after_move(MotionReport((0.0, 0.0, -quarter_turn + 0.05), False))
    assert places.here() == {"scan"}  # turned back: the same view
    places.after_move(MotionReport((1.2, 0.0, 0.0), False))
    assert places.here() == set()
    places.after_move(None)  # protocol 1: somewhere new, nothing remembered
    assert places.done == []


@pytest.mark.parametrize("seed", range(3))
def test_confirmation_moves_and_reads_again_before_declaring(seed: int) -> None:
    smap = load_map(MAPS / "kitchen.yaml")
    model = compile_model(smap)
    binner = ReadingBinner(smap, model)
    world = SimulatedRobot(
        model, int(np.random.default_rng(seed).integers(model.n_states)), np.random.default_rng(seed)
    )
    steps: list[tuple[bool, float]] = []
    outcome = localize(
        model,
        uniform(model.n_states),
        SimulatedReadingRobot(world, binner),
        binner,
        confirm=True,
        on_step=lambda step: steps.append((step.command.action.is_actuation, float(step.belief.max()))),
    )
    assert outcome.localized and int(np.argmax(outcome.belief)) == world.state
    first = next(i for i, (_, p) in enumerate(steps) if p >= 0.95)
    after = [move for move, _ in steps[first + 1 :]]
    assert after and after[0]  # a move first,
    assert not after[-1]  # and the declaration follows a reading


def test_localize_confirm_on_the_command_line_moves_and_reads_before_declaring(runner) -> None:
    """window-2x2-perfect: Look sees nothing, a move right localizes (p = 1); with --confirm the robot
    is sent one more move and one more Look before the result."""
    replies = [{"look": []}, {}, {}, {"look": []}]
    text = "".join(json.dumps({"seq": k + 1, "readings": r}) + "\n" for k, r in enumerate(replies))
    plain = runner.invoke(app, ["localize", str(MAPS / "window-2x2-perfect.yaml"), "--quiet"], input=text)
    sent = [json.loads(line) for line in plain.stdout.splitlines()]
    assert plain.exit_code == 0 and [m["message"] for m in sent] == ["action", "action", "result"]
    confirmed = runner.invoke(
        app, ["localize", str(MAPS / "window-2x2-perfect.yaml"), "--quiet", "--confirm"], input=text
    )
    sent = [json.loads(line) for line in confirmed.stdout.splitlines()]
    actions = [m for m in sent if m["message"] == "action"]
    assert [a["kind"] for a in actions[2:]] == ["actuation", "perception"]
    assert sent[-1]["message"] == "result" and sent[-1]["steps"] == 4


def test_localize_progress_lines_show_the_probability_compared_with_the_threshold(runner) -> None:
    """Each action's line on stderr ends with ``max p``: the probability the threshold is compared
    with (here, on a hand-drawn grid, the most likely state's: 1 after the move that localizes)."""
    replies = [{"look": []}, {}]
    text = "".join(json.dumps({"seq": k + 1, "readings": r}) + "\n" for k, r in enumerate(replies))
    result = runner.invoke(app, ["localize", str(MAPS / "window-2x2-perfect.yaml")], input=text)
    assert result.exit_code == 0
    lines = [line for line in result.stderr.splitlines() if line[:1].isdigit()]
    assert len(lines) == 2 and all("max p = " in line for line in lines)
    assert lines[-1].endswith("max p = 1.000")


def test_a_laser_mounted_turned_reads_as_the_base_turned_would() -> None:
    """The continuous robot's laser may sit turned on its base (``LaserSpec.mount``; a robot whose map knows
    nothing of it): its beams are read from the laser's pose, as a mount-less robot turned that much reads them."""
    from beliefloc.continuous.world import ContinuousRobot, ContinuousWorld, LaserSpec, WorldConfig
    from beliefloc.robots.continuous_robot import ContinuousReadingRobot
    from beliefloc.semantic_map.occupancy_map import load_occupancy

    smap = load_map(MAPS / "tb3-sandbox.yaml")
    model = compile_model(smap)
    binner = ReadingBinner(smap, model)
    occupancy = load_occupancy(MAPS / "occupancy" / "tb3_sandbox.yaml")
    (spec,) = [s for s in smap.sensors.values() if s.type == "scan"]

    def reads(mount: tuple[float, float, float], pose: tuple[float, float, float]) -> list[float | None]:
        laser = LaserSpec(range_sd=0.0, range_min=0.01, mount=mount)
        world = ContinuousWorld(occupancy, WorldConfig(laser=laser), np.random.default_rng(0))
        robot = ContinuousReadingRobot(ContinuousRobot(world, pose), smap, binner)
        out = robot._scan(spec)
        assert isinstance(out, list)
        return out

    turned = reads((0.0, 0.0, 0.3), (0.2, -0.4, 1.0))
    assert turned == pytest.approx(reads((0.0, 0.0, 0.0), (0.2, -0.4, 1.3)), abs=1e-9)
    assert turned != pytest.approx(reads((0.0, 0.0, 0.0), (0.2, -0.4, 1.0)), abs=1e-3)


def test_localize_says_what_the_pose_lattice_s_wait_is_unless_quiet(runner) -> None:
    """Building a floor's pose lattice takes seconds (the depot's million poses: ~5 s before the first
    action): stderr says so before, and how large it is and how long it took after; ``--quiet`` keeps it
    silent. stdout carries only protocol lines either way."""
    loud = runner.invoke(app, ["localize", str(MAPS / "tb3-sandbox.yaml"), "--max-steps", "1"], input="")
    lines = [line for line in loud.stderr.splitlines() if line.startswith("pose lattice:")]
    assert len(lines) == 2 and "casting its rays" in lines[0]
    assert re.search(
        r"pose lattice: [\d,]+ poses \(\d+ x \d+ a cell, \d+ yaws a sector\), ready in [\d.]+ s$", lines[1]
    )
    assert all(json.loads(line)["message"] in ("action", "error") for line in loud.stdout.splitlines())
    quiet = runner.invoke(app, ["localize", str(MAPS / "tb3-sandbox.yaml"), "--max-steps", "1", "-q"], input="")
    assert "pose lattice" not in quiet.stderr
