"""``track``: Markov localization over a logged sequence of actions and observations."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from beliefloc.cli.common import boundary, initial_belief, open_model, warn, warn_if_too_wide
from beliefloc.cli.options import BeliefOption, CompactOption, JsonOption, ModelArgument, TopOption
from beliefloc.errors import UsageError
from beliefloc.render import stdout_console

if TYPE_CHECKING:
    from beliefloc.model import Model
    from beliefloc.robots.tracking import StepLog


StepsArgument = Annotated[
    list[str] | None,
    typer.Argument(
        metavar="STEP...",
        help="ACTION or ACTION=OBSERVATION, in order. A perception action needs its observation; "
        "an actuation action without one is a prediction only.",
        show_default=False,
    ),
]
StepsFileOption = Annotated[
    str | None,
    typer.Option(
        "--steps",
        metavar="FILE|-",
        help="Read the steps from FILE ('-': stdin), one per line; blank lines and # comments are skipped. "
        "Instead of STEP... arguments, to replay a logged run.",
        show_default=False,
    ),
]
STDIN = "-"


@boundary
def track(
    source: ModelArgument,
    steps: StepsArgument = None,
    steps_file: StepsFileOption = None,
    belief_spec: BeliefOption = "uniform",
    compact: CompactOption = None,
    final_only: Annotated[
        bool, typer.Option("--final-only", "--quiet", "-q", help="Draw only the final belief.")
    ] = False,
    top: TopOption = 5,
    json_output: JsonOption = False,
    bag: Annotated[
        Path | None,
        typer.Option(
            "--bag",
            metavar="RUN",
            help="Localize over a ROS recording instead of STEP...: a rosbag2 folder (sqlite3 or MCAP) or a ROS 1 "
            ".bag, on MAP's occupancy map (a map_server YAML, or a beliefloc map with occupancy:), from the uniform "
            "belief. Exit 1 when the run does not say where the robot is.",
            show_default=False,
        ),
    ] = None,
    scan_topic: Annotated[
        str | None,
        typer.Option(
            "--scan-topic",
            metavar="TOPIC",
            help="--bag: the LaserScan topic (default: the only one).",
            show_default=False,
        ),
    ] = None,
    odom_topic: Annotated[
        str | None,
        typer.Option(
            "--odom-topic",
            metavar="TOPIC",
            help="--bag: the Odometry topic, or /tf (default: the only Odometry topic, else odom -> base on /tf).",
            show_default=False,
        ),
    ] = None,
    laser_pose: Annotated[
        str | None,
        typer.Option(
            "--laser-pose",
            metavar="X,Y,YAW",
            help="--bag: the laser's pose on the base (metres, radians) instead of /tf_static's.",
            show_default=False,
        ),
    ] = None,
    belief_out: Annotated[
        Path | None,
        typer.Option(
            "--belief-out",
            metavar="FILE.json",
            help="--bag: write the final belief over MAP's states (a beliefloc map) for "
            "'beliefloc pose MAP --belief FILE'.",
            show_default=False,
        ),
    ] = None,
    output: Annotated[
        Path | None,
        typer.Option(
            "-o",
            "--output",
            metavar="FILE.png|FILE.svg",
            help="--bag: a picture of the final belief and the path "
            "(needs matplotlib: pip install 'beliefloc[plots]').",
            show_default=False,
        ),
    ] = None,
    record: Annotated[
        Path | None,
        typer.Option(
            "--record",
            metavar="OUT.mcap|DIR",
            help="--bag: write the run as ROS 2 messages (the map, the bag's scans and odometry, the belief and "
            "pose at every update) for Foxglove, RViz or 'ros2 bag play': one MCAP file OUT.mcap (replaced if it "
            "exists), or a new rosbag2 folder DIR (docs/ros-recordings.md).",
            show_default=False,
        ),
    ] = None,
    cell_size: Annotated[
        float, typer.Option("--cell-size", metavar="M", help="--bag: the filter's cell side in metres.")
    ] = 0.1,
    headings: Annotated[int, typer.Option("--headings", metavar="N", help="--bag: the filter's heading sectors.")] = 36,
    robot_radius: Annotated[
        float | None,
        typer.Option(
            "--robot-radius",
            metavar="M",
            help="--bag: a cell is a state when a disc of this radius on its centre is free "
            "[default: the map's robot_radius, else 0.15].",
            show_default=False,
        ),
    ] = None,
) -> None:
    """Localize over a log: apply each action and observation to the belief (Bayes filter).

    Prints the belief after every step, with p(o | a, b), the probability of what was observed (a
    log of more than 1,000 steps: a one-line summary per step and the final belief drawn);
    --json also gives the final belief's most likely state as a map-frame pose with a covariance.

    With --bag RUN, the log is a ROS recording (LaserScan, odometry, /tf_static) and MAP an occupancy
    map: the grid filter of the real world (AMCL's odometry and likelihood-field models over every
    pose at once) runs from the uniform belief; it prints when the robot was localized and its final
    pose (--json: {"localized", "pose": {x, y, yaw, covariance}, "timeline": [...]}), or "not
    localized" with the places that remain (exit 1). For example, with map_saver's my_map.yaml and
    a rosbag2 folder my_run/: beliefloc track my_map.yaml --bag my_run/ --json > track.json

    Examples:

    \b
      beliefloc track maps/window-2x2.yaml look=window_seen right
      printf 'look=nothing   # a step per line, # comments\\nforward\\n' > run.log
      beliefloc track maps/kitchen.yaml --steps run.log
      cat run.log | beliefloc track maps/kitchen.yaml --steps - --json
    """
    if bag is not None:
        _track_bag(
            source,
            bag,
            steps,
            steps_file,
            scan_topic,
            odom_topic,
            laser_pose,
            belief_out,
            output,
            json_output,
            cell_size,
            headings,
            robot_radius,
            record,
        )
        return
    for name, value in (
        ("--scan-topic", scan_topic),
        ("--odom-topic", odom_topic),
        ("--laser-pose", laser_pose),
        ("--belief-out", belief_out),
        ("-o", output),
        ("--record", record),
    ):
        if value is not None:
            raise UsageError(f"{name} goes with --bag RUN (a ROS recording)")
    from beliefloc.render.belief_grid import belief_view
    from beliefloc.render.drawing import uses_color
    from beliefloc.render.state_tables import belief_summary, print_step_summaries, step_header
    from beliefloc.robots.tracking import track_chunks

    written = _steps(steps, steps_file)
    model = open_model(source)
    belief = initial_belief(model, belief_spec)
    log = _step_log(model, written)  # every step checked before the output starts
    if json_output:
        from beliefloc.cli.track_steps import print_json_steps

        print_json_steps(model, belief, log)
        return
    total = len(log)
    if not final_only and total > DRAW_EVERY_STEP_UP_TO:
        final_only = True
        warn(
            f"{total:,} steps (more than {DRAW_EVERY_STEP_UP_TO:,}): each step gets its one-line summary "
            "and only the final belief its map, as with --final-only; --json gives every belief"
        )
    console = stdout_console()
    color = uses_color(console)
    width = console.width
    warn_if_too_wide(model.grid, compact, width, color)
    for chunk in track_chunks(model, belief, log):
        count = len(chunk.codes)
        drawn = 0
        if final_only:  # a step is two lines, and a steps file may hold a million steps
            drawn = count - (chunk.start + count == total)
            print_step_summaries(
                console,
                model,
                log.steps,
                chunk.start + 1,
                chunk.codes[:drawn],
                chunk.probabilities[:drawn],
                chunk.beliefs[:drawn],
            )
        for i in range(drawn, count):
            number = chunk.start + i + 1
            step = log.steps[int(chunk.codes[i])]
            probability = None if step.index is None else float(chunk.probabilities[i])
            after = chunk.beliefs[i]
            if number > 1:
                console.print()
            console.print(step_header(number, step.text, step.action.name, step.observation, probability))
            if number == total:
                view = belief_view(model, after, compact=compact, width=width, color=color, top=top)
                console.print(view, crop=False)
            elif model.grid is None:
                console.print(belief_summary(model, after, top=top, color=color))
            else:
                view = belief_view(model, after, compact=compact, width=width, color=color, top=0, legend=False)
                console.print(view, crop=False)


DRAW_EVERY_STEP_UP_TO = 1000
"""Without --final-only, a log of more steps than this prints as with it (a map per step of a
million-step log would be hours of output no one reads)."""


def _track_bag(
    source: Path,
    bag: Path,
    steps: list[str] | None,
    steps_file: str | None,
    scan_topic: str | None,
    odom_topic: str | None,
    laser_pose: str | None,
    belief_out: Path | None,
    output: Path | None,
    json_output: bool,
    cell_size: float,
    headings: int,
    robot_radius: float | None,
    record: Path | None,
) -> None:
    from beliefloc.cli.track_bag import track_bag
    from beliefloc.continuous.grid_filter import FilterConfig

    if steps or steps_file is not None:
        raise UsageError("--bag RUN replaces STEP... and --steps: give one or the other")
    try:
        config = FilterConfig(
            cell_size=cell_size, headings=headings, robot_radius=0.15 if robot_radius is None else robot_radius
        )
    except ValueError as exc:
        raise UsageError(f"--cell-size / --headings / --robot-radius: {exc}") from None
    track_bag(
        source,
        bag,
        scan_topic=scan_topic,
        odom_topic=odom_topic,
        laser_pose_text=laser_pose,
        belief_out=belief_out,
        output=output,
        json_output=json_output,
        config=config,
        robot_radius_given=robot_radius is not None,
        record=record,
    )


def _steps(arguments: list[str] | None, steps_file: str | None) -> list[str] | tuple[str, str]:
    """The steps from the arguments, or the text of ``--steps FILE|-`` and its name: one or the other."""
    from beliefloc.robots.tracking import MAX_STEP_FILE_BYTES, step_file_text

    if steps_file is None:
        if not arguments:
            raise UsageError("no steps: give them as STEP... arguments or one per line with --steps FILE|-")
        return arguments
    if arguments:
        raise UsageError(f"--steps {steps_file}: give the steps either as STEP... arguments or with --steps, not both")
    if steps_file != STDIN:
        return step_file_text(Path(steps_file)), str(Path(steps_file))
    try:
        text = sys.stdin.read(MAX_STEP_FILE_BYTES + 1)
    except UnicodeDecodeError as exc:
        raise UsageError(f"--steps -: stdin is not UTF-8 text ({exc.reason})") from None
    if len(text) > MAX_STEP_FILE_BYTES:
        raise UsageError(f"--steps -: stdin holds more than {MAX_STEP_FILE_BYTES // 2**20} MiB of steps, the most read")
    return text, "<stdin>"


def _step_log(model: Model, written: list[str] | tuple[str, str]) -> StepLog:
    """The steps checked against ``model``: the arguments, or the lines of a step file's text."""
    from beliefloc.robots.tracking import argument_log, text_log

    if isinstance(written, tuple):
        return text_log(model, *written)
    return argument_log(model, written)


def register(app: typer.Typer) -> None:
    app.command(short_help="Update a belief over a log of actions and observations.")(track)
