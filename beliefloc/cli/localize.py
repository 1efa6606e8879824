"""``localize``: act, perceive and replan with a real robot over a line protocol on stdin/stdout."""

from __future__ import annotations

import contextlib
import dataclasses
import enum
import json
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.markup import escape

from beliefloc.cli.common import belief_inputs, boundary, check_output, initial_belief, warn
from beliefloc.cli.localize_ros import (
    CmdVelTopicOption,
    DetectionsTopicOption,
    DetectionsTypeOption,
    LaserFrameOption,
    LaserPoseOption,
    MarginOption,
    MaxSpeedOption,
    MaxTurnOption,
    MotionTimeoutOption,
    OdomTopicOption,
    RobotRadiusOption,
    RosbridgeOption,
    RosTimeoutOption,
    ScanTopicOption,
    SettleOption,
)
from beliefloc.cli.options import (
    BeliefOption,
    HeuristicOption,
    HWeightOption,
    MaxExpansionsOption,
    PlannerOption,
    PlanTimeLimitOption,
    ThresholdOption,
    resolve_heuristic,
    whole,
)
from beliefloc.errors import EXIT_NEGATIVE, BeliefLocError, ReplyError, UsageError
from beliefloc.planning.settings import (
    DEFAULT_MAX_EXPANSIONS,
    DEFAULT_THRESHOLD,
    DEFAULT_TIME_LIMIT,
    DEFAULT_WEIGHT,
    Planner,
)
from beliefloc.render import stderr_console
from beliefloc.simulation.settings import DEFAULT_MAX_STEPS

if TYPE_CHECKING:
    import numpy as np

    from beliefloc.model import Model
    from beliefloc.pose import PoseEstimate
    from beliefloc.robots.line_protocol import LineRobot
    from beliefloc.robots.localize import LocalizeStep
    from beliefloc.semantic_map import SemanticMap

MapArgument = Annotated[
    Path,
    typer.Argument(
        metavar="MAP",
        help="A map (.yaml): its sensors' specifications bin the robot's raw readings. A model built from it "
        "(.npz) works too while the map is unchanged; a .pomdp file has no sensor specifications.",
        show_default=False,
    ),
]


DEFAULT_REPLY_TIMEOUT = 300.0
"""``--reply-timeout``: seconds to wait for one reply; long enough for a slow robot's move and scan."""


def _timed_reader(seconds: float) -> Callable[[int], str]:
    """``readline(limit)`` on stdin that raises :class:`TimeoutError` when no whole line came within
    ``seconds``: reads the file descriptor itself (select, then os.read) so that nothing waits in a
    buffer select cannot see. Without a file descriptor (a test's stdin): ``sys.stdin.readline``."""
    import select

    try:
        fd = sys.stdin.fileno()
    except (AttributeError, OSError, ValueError):
        return sys.stdin.readline
    pending = bytearray()
    ended = False

    def read_line(limit: int) -> str:
        nonlocal ended
        deadline = time.monotonic() + seconds
        while b"\n" not in pending and len(pending) <= 4 * limit and not ended:
            remaining = deadline - time.monotonic()
            if remaining <= 0 or not select.select([fd], [], [], remaining)[0]:
                raise TimeoutError(f"within {seconds:g} s (--reply-timeout)")
            chunk = os.read(fd, 65536)
            if chunk:
                pending.extend(chunk)
            else:
                ended = True
        end = pending.find(b"\n")
        size = end + 1 if end >= 0 else len(pending)
        line = bytes(pending[:size])
        del pending[:size]
        if len(line) > 4 * limit:
            return line[: 4 * limit].decode("utf-8", "replace")  # too long, whatever it holds
        return line.decode("utf-8")

    return read_line


class BeliefFilterKind(str, enum.Enum):
    """``localize --filter``: the belief kept between actions (:mod:`beliefloc.robots.belief_filter`)."""

    AUTO = "auto"
    LATTICE = "lattice"
    STATES = "states"


@boundary
def localize(
    map_file: MapArgument,
    belief: BeliefOption = "uniform",
    threshold: ThresholdOption = DEFAULT_THRESHOLD,
    planner: PlannerOption = Planner.BESTFIRST,
    heuristic: HeuristicOption = None,
    h_weight: HWeightOption = DEFAULT_WEIGHT,
    max_expansions: MaxExpansionsOption = DEFAULT_MAX_EXPANSIONS,
    time_limit: PlanTimeLimitOption = DEFAULT_TIME_LIMIT,
    max_steps: Annotated[
        int, typer.Option("--max-steps", parser=whole(low=1), metavar="N", help="Stop after this many actions.")
    ] = DEFAULT_MAX_STEPS,
    confirm: Annotated[
        bool,
        typer.Option(
            "--confirm",
            help="Declare a belief that reaches the threshold only if it still holds it after a move and a "
            "reading from where the move leads (docs/localize-protocol.md, Surprise): a robot off the cell "
            "centres is not declared on one reading that only a wrong state explains.",
        ),
    ] = False,
    belief_filter: Annotated[
        BeliefFilterKind,
        typer.Option(
            "--filter",
            case_sensitive=False,
            help="The belief between actions: 'lattice' follows the robot's pose finer than the states (sub-cell "
            "positions and sub-sector yaws, the sensors' continuous noise): for a real robot off the cell centres, "
            "best with odometry in the replies (docs/localize-protocol.md); 'localized' then means within one cell "
            "and 3/4 of a heading sector of the state declared; with --rosbridge it reads each LaserScan whole, "
            "scored at every lattice pose by the likelihood field. 'states' is the papers' filter over the map's "
            "states (a robot at the cell centres, turning by whole headings). 'auto': lattice on a map with an "
            "occupancy image (a real floor, ray-cast sensors), states on a hand-drawn grid (sensors defined per "
            "cell, as the papers' worlds are).",
        ),
    ] = BeliefFilterKind.AUTO,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress on stderr.")] = False,
    reply_timeout: Annotated[
        float,
        typer.Option(
            "--reply-timeout",
            metavar="SECONDS",
            min=0.001,
            max=1e6,
            help="Give up (exit 2, naming the action) when the robot has not answered an action within this time.",
        ),
    ] = DEFAULT_REPLY_TIMEOUT,
    belief_out: Annotated[
        Path | None,
        typer.Option(
            "--belief-out",
            metavar="FILE",
            help="Also write the final belief there ({state: probability}, as 'track --json' gives it): "
            "'beliefloc pose MAP --belief FILE --format ros' turns it into AMCL's initial pose.",
            show_default=False,
        ),
    ] = None,
    rosbridge: RosbridgeOption = None,
    scan_topic: ScanTopicOption = "/scan",
    odom_topic: OdomTopicOption = "/odom",
    cmd_vel_topic: CmdVelTopicOption = "/cmd_vel",
    detections_topic: DetectionsTopicOption = None,
    detections_type: DetectionsTypeOption = "vision_msgs/Detection2DArray",
    laser_frame: LaserFrameOption = None,
    laser_pose: LaserPoseOption = None,
    robot_radius: RobotRadiusOption = None,
    margin: MarginOption = 0.1,
    max_speed: MaxSpeedOption = 0.2,
    max_turn_speed: MaxTurnOption = 0.6,
    motion_timeout: MotionTimeoutOption = 30.0,
    settle: SettleOption = 0.5,
    ros_timeout: RosTimeoutOption = 10.0,
) -> None:
    """Localize a real robot: plan, send it an action, read what it sensed, update, replan when surprised.

    The robot's program talks to beliefloc over a line protocol, one JSON object per line
    (docs/localize-protocol.md). beliefloc writes each action on stdout -- what to do, the sensors to
    read, the readings the plan expects -- and reads one reply per action on stdin,
    {"seq": N, "readings": {SENSOR: RAW}}, with raw readings: a scan's ranges in metres, the classes a
    look detected, the class a here sensor reads. beliefloc bins them with the map's sensor model. The
    last line is the result: the most likely state and its map-frame pose when localized. Progress goes
    to stderr; stdout carries only protocol lines.

    With --rosbridge ws://HOST:9090 beliefloc drives a ROS robot itself through rosbridge_server
    (docs/rosbridge.md): each action a short /cmd_vel motion closed on odometry, the scan's beams and
    a detector's classes as readings, the belief published as a PoseArray and /initialpose when
    localized; the result line goes to stdout. Whatever ends the session, the robot is told to stop.

    "Localized" is declared only while the last readings fit the belief: each, on the geometric mean, at
    least half as likely as the model expects (model confidence 0.5 or more). Readings that fit much
    worse re-spread the belief once, then end the run "inconsistent" (docs/localize-protocol.md, Surprise).

    Exit code 0 localized; 1 not localized (no plan, gave up, step limit, an impossible observation, the
    readings stopped fitting the map: inconsistent); 2 a bad map or option, or a reply that is not valid
    (the message names the line).

    Examples:

    \b
      printf '%s\\n' '{"seq": 1, "readings": {"look": []}}' '{"seq": 2, "readings": {}}' > replies.jsonl
      beliefloc localize maps/window-2x2-perfect.yaml < replies.jsonl   # a robot that saw no window, then moved
      beliefloc localize maps/window-2x2-perfect.yaml --quiet --belief-out belief.json < replies.jsonl
    """
    from beliefloc.robots.line_protocol import LineRobot, error_message
    from beliefloc.robots.localize import localize as run
    from beliefloc.robots.readings import ReadingBinner
    from beliefloc.simulation.strategies import EpisodeStatus, PlannerSettings

    chosen = resolve_heuristic(planner, heuristic, h_weight)
    from beliefloc.cli import localize_ros

    link = localize_ros.bridge_settings(
        rosbridge,
        scan_topic=scan_topic,
        odom_topic=odom_topic,
        cmd_vel_topic=cmd_vel_topic,
        detections_topic=detections_topic,
        detections_type=detections_type,
        laser_frame=laser_frame,
        laser_pose=laser_pose,
        robot_radius=robot_radius,
        margin=margin,
        max_speed=max_speed,
        max_turn=max_turn_speed,
        motion_timeout=motion_timeout,
        settle=settle,
        ros_timeout=ros_timeout,
    )
    if belief_out is not None:
        from beliefloc.source import file_kinds

        inputs = (map_file, *belief_inputs(belief))
        check_output("--belief-out", belief_out, (".json", ".yaml", ".yml"), inputs, file_kinds.BELIEF)
    smap, model = _open_map(map_file)
    binner = ReadingBinner(smap, model)
    tracker = None
    err = stderr_console()
    if belief_filter is BeliefFilterKind.AUTO:
        belief_filter = BeliefFilterKind.LATTICE if smap.occupancy_map is not None else BeliefFilterKind.STATES
    if belief_filter is BeliefFilterKind.LATTICE and model.grid is not None:
        from beliefloc.robots.belief_filter import LatticeFilter

        # a large floor's tables take seconds (the depot's million poses: 5-9 s): say what the wait is
        if not quiet:
            err.print("pose lattice: casting its rays and reading tables...", highlight=False, soft_wrap=True)
        began = time.perf_counter()
        tracker = LatticeFilter(binner)
        if not quiet:
            lattice = tracker.lattice
            err.print(
                f"pose lattice: {lattice.n_poses:,} poses ({lattice.k} x {lattice.k} a cell, {lattice.m} yaws a "
                f"sector), ready in {time.perf_counter() - began:.1f} s",
                highlight=False,
                soft_wrap=True,
            )
    start = initial_belief(model, belief, smap)
    settings = PlannerSettings(threshold, chosen, max_expansions, time_limit, weight=h_weight)

    def on_step(step: LocalizeStep) -> None:
        if quiet:
            return
        command = step.command
        action = command.action
        if command.plan is not None:
            what = "plan" if command.seq == 1 else "replan"
            # out of budget: the best partial plan so far, whose first step the robot does now
            partial = ", incomplete: its first step, then plan again" if command.plan.partial else ""
            err.print(
                f"{what}: {len(command.plan.steps)} actions, cost {command.plan.cost:g} ({command.plan.seconds:.2f} s"
                f"{partial})"
            )
        seen = ""
        if step.observation is not None:
            seen = f" → {escape(action.observation.name(step.observation))} (p = {step.probability:.3g})"
            if step.surprised and command.expected is not None:
                seen += f", expected {escape(action.observation.name(command.expected))}"
        peak = step.peak if step.peak is not None else float(step.belief.max())
        err.print(f"{command.seq}. {escape(action.name)}{seen}; max p = {peak:.3f}", highlight=False)

    if rosbridge is not None:
        from beliefloc.cli import localize_ros

        link = localize_ros.with_map_radius(link, robot_radius, smap.grid.robot_radius)
        if tracker is not None:  # the lattice filter scores a whole LaserScan in full: send it all
            link = dataclasses.replace(link, whole_scans=True)
        outcome = localize_ros.run(rosbridge, link, model, start, binner, settings, max_steps, on_step, tracker)
    else:
        robot = LineRobot(binner, _timed_reader(reply_timeout), _write_line, source="stdin")
        try:
            outcome = run(
                model,
                start,
                robot,
                binner,
                settings=settings,
                max_steps=max_steps,
                on_step=on_step,
                confirm=confirm,
                belief_filter=tracker,
            )
        except ReplyError as exc:
            _try_send(robot, error_message(str(exc)))
            raise
        robot.finish(outcome)
    if belief_out is not None:
        _write_belief(belief_out, model, outcome.belief, outcome.estimate if outcome.localized else None)
    if outcome.localized:
        if not quiet:
            data = outcome.as_json(model)
            err.print(f"localized: {data['state']} (p = {data['probability']:.3f}) after {outcome.steps} actions")
        return
    status = outcome.status.value.replace("_", " ")
    hint = {
        EpisodeStatus.BUDGET_EXCEEDED: "; raise --max-expansions or --time-limit, or lower --threshold",
        EpisodeStatus.STEP_LIMIT: "; raise --max-steps",
    }.get(outcome.status, "")
    reason = f": {outcome.reason}{hint}" if outcome.reason else ""
    err.print(f"[bold]not localized, {status}[/]{escape(reason)} (max p = {outcome.declared[1]:.3f})")
    raise typer.Exit(EXIT_NEGATIVE)


def _write_belief(path: Path, model: Model, belief: np.ndarray, estimate: PoseEstimate | None) -> None:
    """The final belief as a belief file, written whole or not at all; with the pose lattice's
    estimate beside it (``"localized_pose"``: ``beliefloc pose --belief`` reports it instead of the state's centre)."""
    from beliefloc.belief import by_state_name
    from beliefloc.files.belief_file import POSE_KEY
    from beliefloc.source.atomic_write import write_atomically

    content: dict[str, object] = {"belief": by_state_name(model, belief)}
    if estimate is not None:
        content[POSE_KEY] = {
            "state": model.states.name(estimate.state),
            "probability": estimate.probability,
            **estimate.as_json(),
        }
    text = json.dumps(content, indent=2, allow_nan=False) + "\n"
    write_atomically(path, lambda handle: handle.write(text.encode()))


def _open_map(path: Path) -> tuple[SemanticMap, Model]:
    """The map and its model: from the map itself, or from a model built from it (checked unchanged)."""
    from beliefloc.files.model_sources import MAP_SUFFIXES, MODEL_SUFFIX, source_map
    from beliefloc.semantic_map import compile_model, load_map

    suffix = path.suffix.lower()
    if suffix in MAP_SUFFIXES:
        smap = load_map(path, on_warning=warn)
        return smap, compile_model(smap)
    if suffix == MODEL_SUFFIX:
        from beliefloc.files.model_file import load_model

        model = load_model(path, on_warning=warn)
        return source_map(model), model
    raise UsageError(
        f"MAP {path}: localize needs a map (.yaml), whose sensors' specifications bin the robot's raw readings "
        "(or a model built from one, .npz); a .pomdp file has none"
    )


def _write_line(text: str) -> None:
    """One protocol line on stdout, flushed at once; a closed pipe is the robot side gone."""
    try:
        sys.stdout.write(text + "\n")
        sys.stdout.flush()
    except BrokenPipeError:
        _silence_stdout()
        raise ReplyError("the robot side closed beliefloc's stdout before localization ended") from None


def _try_send(robot: LineRobot, message: dict[str, object]) -> None:
    """The error line for the robot side, when it is still listening."""
    with contextlib.suppress(BeliefLocError):
        robot.send(message)


def _silence_stdout() -> None:
    """After a broken pipe, point stdout at /dev/null so that the interpreter's last flush is quiet
    (the recipe of Python's signal documentation)."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):  # not a real file (under a test runner)
        pass


def register(app: typer.Typer) -> None:
    app.command(short_help="Localize a real robot over a line protocol.")(localize)
