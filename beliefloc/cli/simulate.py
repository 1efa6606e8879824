"""``simulate``: whole episodes -- act, perceive, update, replan -- against a simulated robot."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.markup import escape

from beliefloc.cli.common import (
    belief_inputs,
    boundary,
    check_record,
    check_ros_recording,
    check_sweep_options,
    initial_belief,
    open_model,
    open_with_map,
    positive_int,
    print_json,
    refuse_unreachable,
    run_sweep,
    warn,
    warn_if_too_wide,
)
from beliefloc.cli.options import (
    DEFAULT_RECORD_FRAMES,
    BeliefOption,
    CompactOption,
    GammaOption,
    HeuristicOption,
    HWeightOption,
    JsonOption,
    LookaheadOption,
    MacrosOption,
    MaxExpansionsOption,
    ModelArgument,
    OutOption,
    PlanTimeLimitOption,
    PruneBelowOption,
    RecordFramesOption,
    ResumeOption,
    SchedulerOption,
    SeedOption,
    ThresholdOption,
    TimingsOption,
    WorkersOption,
    resolve_heuristic,
    whole,
)
from beliefloc.errors import EXIT_NEGATIVE, UsageError
from beliefloc.planning.settings import (
    DEFAULT_MAX_EXPANSIONS,
    DEFAULT_PRUNE_BELOW,
    DEFAULT_THRESHOLD,
    DEFAULT_TIME_LIMIT,
    DEFAULT_WEIGHT,
    Planner,
)
from beliefloc.render import stderr_console, stdout_console
from beliefloc.simulation.settings import DEFAULT_MAX_STEPS, MAX_OBSTACLES, StrategyName

if TYPE_CHECKING:
    import numpy as np
    from rich.console import Console

    from beliefloc.model import Model
    from beliefloc.recordings.record import EpisodeRecorder
    from beliefloc.render.picture_episode import TraceRecorder
    from beliefloc.semantic_map import SemanticMap
    from beliefloc.simulation.continuous_episode import ContinuousSetup
    from beliefloc.simulation.episode import EpisodeRecord, EpisodeSweep, StepRecord

"""``--record-frames``: a GIF of 200 frames at 0.6 s a frame lasts two minutes."""

MAX_FULL_SCAN_BEAMS = 10_000
"""``--full-scans``: the most rays of a whole scan (the most a reply may carry, ``readings.MAX_SCAN_BEAMS``)."""
MAX_EPISODES = 100_000_000
"""The most episodes ``-n`` takes: far more than a sweep of a day, far fewer than ``2**200``."""


@boundary
def simulate(
    map_file: ModelArgument,
    episodes: Annotated[
        int,
        typer.Option(
            "--episodes",
            "-n",
            parser=whole(low=1, high=MAX_EPISODES),
            metavar="N",
            help=f"How many episodes (at most {MAX_EPISODES:,}).",
        ),
    ] = 1,
    seed: SeedOption = 0,
    start: Annotated[
        str,
        typer.Option(
            "--start",
            metavar="STATE|random|prior",
            help="The robot's true start state; 'random': uniform per episode; 'prior': drawn per episode from "
            "the start belief (--belief), e.g. the knowledge base's prior.",
        ),
    ] = "random",
    strategy: Annotated[
        list[str] | None,
        typer.Option(
            "--strategy",
            "-s",
            metavar="NAME",
            help=f"Repeat to compare: {', '.join(s.value for s in StrategyName)}.",
            show_default=StrategyName.BESTFIRST.value,
        ),
    ] = None,
    belief: BeliefOption = "uniform",
    threshold: ThresholdOption = DEFAULT_THRESHOLD,
    heuristic: HeuristicOption = None,
    h_weight: HWeightOption = DEFAULT_WEIGHT,
    max_expansions: MaxExpansionsOption = DEFAULT_MAX_EXPANSIONS,
    time_limit: PlanTimeLimitOption = DEFAULT_TIME_LIMIT,
    lookahead: LookaheadOption = None,
    prune_below: PruneBelowOption = DEFAULT_PRUNE_BELOW,
    max_steps: Annotated[
        int,
        typer.Option(
            "--max-steps",
            "--max-actions",
            parser=whole(low=1),
            metavar="N",
            help="Stop an episode after this many actions (the paper: 500).",
        ),
    ] = DEFAULT_MAX_STEPS,
    macros: MacrosOption = None,
    gamma: GammaOption = None,
    world: Annotated[
        Path | None,
        typer.Option(
            "--world",
            metavar="MAP|MODEL",
            help="Simulate the robot in this model instead (same states).",
            show_default=False,
        ),
    ] = None,
    continuous: Annotated[
        bool,
        typer.Option(
            "--continuous",
            help="Episodes against a continuous simulated robot instead of one drawn from the model: a true pose "
            "anywhere in free space with any yaw, motion noise (5 % of a move's length, 2° a turn), ray-cast ranges "
            "(2 cm noise), detections by field of view, range and line of sight; it answers as a robot on "
            "localize's line protocol would (readings, odometry, blocked), and each episode runs localize's loop "
            "(surprise check, re-spread, 'inconsistent'). Records carry the true pose, the position and yaw error "
            "of the state declared and of the pose reported, and whether the episode was confidently wrong.",
        ),
    ] = False,
    clutter: Annotated[
        float,
        typer.Option(
            "--clutter",
            min=0.0,
            max=0.99,
            metavar="FRACTION",
            help="With --continuous: the share of Scan beams that read a random range (unmapped obstacles).",
        ),
    ] = 0.0,
    obstacles: Annotated[
        int,
        typer.Option(
            "--obstacles",
            parser=whole(low=0, high=MAX_OBSTACLES),
            metavar="N",
            help="With --continuous: N unmapped obstacles, discs of 0.1-0.3 m radius (people, boxes) placed "
            "anywhere in free space afresh each episode, away from the start; they stop rays and the robot.",
            show_default=False,
        ),
    ] = 0,
    full_scans: Annotated[
        int,
        typer.Option(
            "--full-scans",
            parser=whole(low=1, high=MAX_FULL_SCAN_BEAMS),
            metavar="BEAMS",
            help="With --continuous: the robot answers each scan with a whole scan of BEAMS rays around it "
            f"(at most {MAX_FULL_SCAN_BEAMS:,}; a 2-D lidar's, as a real robot may reply), which the pose-lattice "
            "filter scores in full with the likelihood field; without it, only the map's beams.",
            show_default=False,
        ),
    ] = 0,
    show: Annotated[bool, typer.Option("--show", help="Print the belief grid after every step.")] = False,
    record: Annotated[
        Path | None,
        typer.Option(
            "--record",
            metavar="FILE.gif|DIR|FILE.mcap",
            help="Animate one episode (the first strategy's): the belief after every step, the true pose and "
            "path, the action and observation as each frame's title; an animated GIF, or numbered PNG frames "
            "(frame-000.png, …) in the folder DIR (created; an existing DIR must hold nothing but frames). "
            "FILE.mcap: the episode as ROS 2 messages for Foxglove, RViz or 'ros2 bag play' instead "
            "(docs/ros-recordings.md).",
            show_default=False,
        ),
    ] = None,
    record_episode: Annotated[
        str | None,
        typer.Option(
            "--record-episode",
            metavar="K",
            help="Which episode --record animates, counted from 1 as the output numbers them.",
            show_default="1",
        ),
    ] = None,
    record_frames: RecordFramesOption = None,
    compact: CompactOption = None,
    workers: WorkersOption = 1,
    scheduler: SchedulerOption = None,
    out_file: OutOption = None,
    resume: ResumeOption = False,
    timings: TimingsOption = True,
    json_output: JsonOption = False,
) -> None:
    """Run localization episodes: every strategy from the same seeded starts (paired trials).

    Exit code 1 when an episode (of any strategy) does not end localized, or when the start belief
    lies on look-alike states that no strategy can tell apart (said before any episode runs).

    Episode e draws its random numbers from generators keyed by (--seed, e) only, so --workers N
    and --scheduler give the same results as one process. --show and --record draw in this
    process: they need --workers 1 and no --scheduler. --out writes a line per episode (every
    strategy's record) as it ends; --resume continues such a file after a crash or a kill.

    Examples:

    \b
      beliefloc simulate maps/kitchen.yaml --show
      beliefloc simulate maps/kitchen.yaml -n 50 -s bestfirst -s uniform -s random
      beliefloc simulate maps/hallway.yaml -n 10 -s bestfirst -s contingent
      beliefloc simulate maps/corridors.yaml -n 20 -s ec2-macros -s ec2 --max-actions 500   # exits 1
      beliefloc simulate maps/apartment.yaml -n 20 --belief prior:domains/apartment.yaml --start prior
      beliefloc simulate maps/kitchen.yaml -n 3 --record episode.gif --record-episode 2
      beliefloc simulate maps/kitchen.yaml -n 40 --workers 2 --out kitchen.jsonl --no-timings
      beliefloc simulate maps/kitchen.yaml -n 60 --workers 2 --out kitchen-60.jsonl --resume
      beliefloc simulate maps/kitchen.yaml -n 3 --continuous --clutter 0.1 -s bestfirst -s ec2-macros
    """
    from beliefloc.files.results_file import header
    from beliefloc.render.belief_grid import belief_view
    from beliefloc.render.drawing import uses_color
    from beliefloc.render.plan import plan_table, summary_table
    from beliefloc.simulation.episode import EpisodeSweep, records_from_results, strategy_name, summarize
    from beliefloc.simulation.strategies import EpisodeStatus, PlannerSettings

    chosen_heuristic = resolve_heuristic(Planner.BESTFIRST, heuristic, h_weight)
    names = [strategy_name(name) for name in strategy or [StrategyName.BESTFIRST.value]]
    inputs = [map_file, *(p for p in (world, macros) if p is not None), *belief_inputs(belief)]
    _warn_unused(
        names,
        {
            "--lookahead": lookahead is not None,
            "--prune-below": prune_below != DEFAULT_PRUNE_BELOW,
            "--gamma": gamma is not None,
            "--macros": macros is not None,
        },
    )
    _check_in_process(show, record, resume, workers, scheduler)
    check_sweep_options(workers, scheduler, out_file, resume, tuple(inputs))
    recording = _recording(record, record_episode, record_frames, episodes, inputs)
    _check_continuous(continuous, clutter, world, start, full_scans, obstacles)
    wants_map = recording is not None or continuous
    model, smap = open_with_map(map_file) if wants_map else (open_model(map_file), None)
    robot = _continuous_robot(map_file, model, smap, clutter, full_scans, obstacles) if continuous else None
    start_belief = initial_belief(model, belief, smap)
    refuse_unreachable(model, start_belief, threshold, json_output)
    start_state = None if start in ("random", "prior") else model.states.index(start)
    world_model = _world(world, model) if world is not None else None
    table = None
    if macros is not None:
        from beliefloc.files.macro_file import load_macros

        table = load_macros(macros, model)
    settings = PlannerSettings(
        threshold,
        chosen_heuristic,
        max_expansions,
        time_limit,
        gamma=gamma,
        macros=table,
        weight=h_weight,
        lookahead=lookahead,
        prune_below=prune_below,
    )

    recorder: TraceRecorder | EpisodeRecorder | None = None
    if recording is not None and recording.ros:
        recorder = _ros_recorder(model, smap, names[0].value, recording, start_belief)
    elif recording is not None:
        from beliefloc.render.figures import pyplot
        from beliefloc.render.picture_episode import TraceRecorder

        if model.grid is None:
            raise UsageError(f"--record {recording.path}: model {model.name} has no grid to draw an episode on")
        pyplot()  # matplotlib missing: say so now, not after the episodes
        recorder = TraceRecorder(names[0].value, recording.episode, start_belief, limit=recording.frames)

    out = stdout_console()
    color = uses_color(out)
    if show and not json_output:
        warn_if_too_wide(model.grid, compact, out.width, color)
        out.print(belief_view(model, start_belief, compact=compact, width=out.width, color=color, title="start belief"))

    def on_step(record: EpisodeRecord, step: StepRecord, current: np.ndarray) -> None:
        if step.plan is not None:
            what = "plan" if record.steps == 1 else "replan"
            out.print(
                plan_table(
                    step.plan, f"{record.strategy}, episode {record.episode + 1}: {what} ({step.plan.seconds:.3f} s)"
                )
            )
        seen = "" if step.observation is None else f" → {step.observation} (p = {step.probability:.3g})"
        out.print(
            belief_view(
                model,
                current,
                compact=compact,
                width=out.width,
                color=color,
                legend=False,
                title=f"{record.strategy}, episode {record.episode + 1}, step {record.steps}: "
                f"{step.action}{seen}   [true state {step.true_state}]",
            )
        )

    def on_any_step(record: EpisodeRecord, step: StepRecord, current: np.ndarray) -> None:
        if show and not json_output:
            on_step(record, step, current)
        if recorder is not None:
            recorder.on_step(record, step, current)

    def on_episode(record: EpisodeRecord) -> None:
        if recorder is not None:
            recorder.on_episode(record)

    sweep = EpisodeSweep(
        model,
        tuple(n.value for n in names),
        seed=seed,
        start=start_state,
        start_belief=start_belief,
        start_distribution=start_belief if start == "prior" else None,
        world=world_model,
        settings=settings,
        max_steps=max_steps,
        timings=timings,
        robot=robot,
    )
    hooked = (show and not json_output) or recorder is not None
    results = run_sweep(
        sweep,
        workers=workers,
        scheduler=scheduler,
        out=out_file,
        resume=resume,
        head=header(
            "simulate",
            "episode",
            episodes,
            _settings(map_file, world, macros, belief, start, sweep, continuous, clutter, full_scans, obstacles),
        ),
        serial_start=((lambda: sweep.runner(on_step=on_any_step, on_episode=on_episode)) if hooked else None),
        progress=not show,
    )
    records = records_from_results(results)
    summary = summarize(records)
    if json_output:
        print_json(
            {
                "episodes": [data for result in results for data in result["records"]],
                "summary": {name: s.as_json(timings=timings) for name, s in summary.items()},
            }
        )
    else:
        if show or episodes == 1:
            for r in records:
                out.print(_episode_line(r))
        out.print(summary_table(summary, threshold))
        if continuous:
            out.print(_continuous_line(records))
    if recording is not None and recorder is not None:
        _write_recording(model, smap, recorder, recording, stderr_console() if json_output else out)
    if any(r.status is not EpisodeStatus.LOCALIZED for r in records):
        raise typer.Exit(EXIT_NEGATIVE)


_USED_BY = {
    "--lookahead": (StrategyName.CONTINGENT,),
    "--prune-below": (StrategyName.CONTINGENT,),
    "--gamma": (StrategyName.EC2, StrategyName.EC2_MACROS),
    "--macros": (StrategyName.EC2_MACROS,),
}
"""The options that only some strategies read."""


def _warn_unused(names: list[StrategyName], given: dict[str, bool]) -> None:
    """An option given for strategies that do not run would be silently ignored: say so."""
    for option, users in _USED_BY.items():
        if given[option] and not set(users) & set(names):
            wanted = " or ".join(f"-s {u.value}" for u in users)
            warn(f"{option} is ignored: it is for {wanted}, which this run does not use")


def _check_in_process(show: bool, record: Path | None, resume: bool, workers: int, scheduler: str | None) -> None:
    """--show and --record follow every step in this process: not with other workers, nor (--record)
    with --resume, where the recorded episode may already be in the file."""
    elsewhere = f"--workers {workers}" if workers != 1 else None
    if scheduler is not None:
        elsewhere = f"--scheduler {scheduler}"
    for option, given in (("--show", show), ("--record", record is not None)):
        if given and elsewhere is not None:
            raise UsageError(f"{option}: draws every step in this process; leave out {elsewhere} (or {option})")
    if record is not None and resume:
        raise UsageError(
            f"--record {record}: --resume may not run the recorded episode again; record in a run of its own"
        )


def _settings(
    map_file: Path,
    world: Path | None,
    macros: Path | None,
    belief: str,
    start: str,
    sweep: EpisodeSweep,
    continuous: bool = False,
    clutter: float = 0.0,
    full_scans: int = 0,
    obstacles: int = 0,
) -> dict[str, object]:
    """What decides a run's results, for the header of its --out file: the inputs (and their bytes'
    digests), the strategies and every planner setting (and, for a continuous robot only, its
    clutter, whole scans and unmapped obstacles: the header of a grid run is as before)."""
    from beliefloc.files.results_file import digest

    settings = sweep.settings
    assert settings is not None
    files = {"map": map_file, "world": world, "macros": macros}
    belief_file = belief_inputs(belief)
    return {
        **{key: None if path is None else str(path) for key, path in files.items()},
        **{f"{key}_sha256": None if path is None else digest(path) for key, path in files.items()},
        "belief": belief,
        "belief_sha256": digest(belief_file[0]) if belief_file and belief_file[0].is_file() else None,
        "start": start,
        "strategies": list(sweep.strategies),
        "seed": sweep.seed,
        "threshold": settings.threshold,
        "heuristic": settings.heuristic.value,
        "h_weight": settings.weight,
        "max_expansions": settings.max_expansions,
        "time_limit": settings.time_limit,
        "gamma": settings.gamma,
        "max_steps": sweep.max_steps,
        "timings": sweep.timings,
        **(
            {
                "continuous": {
                    "clutter": clutter,
                    **({"full_scans": full_scans} if full_scans else {}),
                    **({"obstacles": obstacles} if obstacles else {}),
                }
            }
            if continuous
            else {}
        ),
    }


def _check_continuous(
    continuous: bool, clutter: float, world: Path | None, start: str, full_scans: int = 0, obstacles: int = 0
) -> None:
    """--continuous's company: its own robot and starts; --clutter, --full-scans and --obstacles only with it."""
    if not continuous:
        if clutter:
            raise UsageError(f"--clutter {clutter:g}: is for the continuous robot; add --continuous")
        if full_scans:
            raise UsageError(f"--full-scans {full_scans}: is for the continuous robot; add --continuous")
        if obstacles:
            raise UsageError(f"--obstacles {obstacles}: is for the continuous robot; add --continuous")
        return
    if world is not None:
        raise UsageError(f"--world {world}: --continuous simulates its own robot on the map; leave out one of them")
    if start != "random":
        raise UsageError(
            f"--start {start}: a continuous robot starts anywhere in free space with any yaw; leave out --start"
        )


def _continuous_robot(
    map_file: Path, model: Model, smap: SemanticMap | None, clutter: float, full_scans: int = 0, obstacles: int = 0
) -> ContinuousSetup:
    from beliefloc.simulation.continuous_episode import ContinuousSetup

    if smap is None or model.grid is None:
        raise UsageError(f"--continuous: {map_file} is a model without its map; give the map file (.yaml)")
    if full_scans and not any(sensor.type == "scan" for sensor in smap.sensors.values()):
        raise UsageError(f"--full-scans {full_scans}: {map_file} has no scan sensor to answer with whole scans")
    return ContinuousSetup(smap, clutter=clutter, full_scans=full_scans, obstacles=obstacles)


def _continuous_line(records: list[EpisodeRecord]) -> str:
    """Per strategy: how many episodes were confidently wrong, and how far the pose reported was from
    the true pose in the localized ones (the median)."""
    import math

    import numpy as np

    from beliefloc.simulation.strategies import EpisodeStatus

    parts = []
    for name in dict.fromkeys(r.strategy for r in records):
        mine = [r.continuous for r in records if r.strategy == name and r.continuous is not None]
        wrong = sum(c.confidently_wrong for c in mine)
        line = f"{name}: confidently wrong {wrong} of {len(mine)}"
        off = [
            (c.pose_position_error, c.pose_yaw_error)
            for r in records
            if r.strategy == name and r.status is EpisodeStatus.LOCALIZED and (c := r.continuous) is not None
            if c.pose_position_error is not None and c.pose_yaw_error is not None
        ]
        if off:
            metres, radians = np.median(np.array(off), axis=0)
            line += f", the pose reported {metres:.2f} m and {math.degrees(radians):.0f}° from the truth (median)"
        parts.append(line)
    return escape("continuous robot: " + "; ".join(parts))


@dataclass(frozen=True)
class _Recording:
    """What ``--record`` asked for, checked."""

    path: Path
    gif: bool
    """A GIF file, else a folder of PNG frames."""
    episode: int
    """0-based."""
    frames: int
    ros: bool = False
    """A ROS recording (FILE.mcap), not pictures."""


def _recording(
    path: Path | None, episode: str | None, frames: str | None, episodes: int, inputs: list[Path]
) -> _Recording | None:
    """``--record`` and its options, checked before any work: nothing is simulated for a recording
    that could not be written."""
    if path is None:
        for option, value in (("--record-episode", episode), ("--record-frames", frames)):
            if value is not None:
                raise UsageError(f"{option} {value}: needs --record FILE.gif|DIR")
        return None
    limit = DEFAULT_RECORD_FRAMES if frames is None else positive_int("--record-frames", frames)
    k = 1 if episode is None else positive_int("--record-episode", episode)
    if k > episodes:
        raise UsageError(
            f"--record-episode {k}: the run has {episodes} episode{'' if episodes == 1 else 's'} (--episodes)"
        )
    if path.suffix.lower() == ".mcap":
        if frames is not None:
            raise UsageError(f"--record-frames {frames}: is for pictures; a ROS recording ({path}) keeps every step")
        check_ros_recording("--record", path, tuple(inputs), folder=False)
        return _Recording(path, False, k - 1, limit, ros=True)
    return _Recording(path, check_record("--record", path, tuple(inputs)), k - 1, limit)


def _ros_recorder(
    model: Model, smap: SemanticMap | None, strategy: str, recording: _Recording, start_belief: np.ndarray
) -> EpisodeRecorder:
    """``--record FILE.mcap``: the episode's recorder, keeping the messages until the run ends."""
    from beliefloc.recordings.record import EpisodeRecorder, RecordingWriter

    if model.grid is None:
        raise UsageError(f"--record {recording.path}: model {model.name} has no grid: its states have no pose")
    recorder = EpisodeRecorder(RecordingWriter(), model, strategy, recording.episode, start_belief, smap)
    if not recorder.reads_scans:
        why = "its map has no Scan sensor" if smap is not None else "the model's map is not at hand"
        warn(f"--record {recording.path}: no /scan topic: {why}")
    return recorder


def _write_recording(
    model: Model,
    smap: SemanticMap | None,
    recorder: TraceRecorder | EpisodeRecorder,
    recording: _Recording,
    console: Console,
) -> None:
    from beliefloc.recordings.record import EpisodeRecorder, write_recording

    if isinstance(recorder, EpisodeRecorder):
        if recorder.recorded:
            write_recording(recording.path, recorder.out)
            console.print(
                escape(
                    f"recorded {recorder.strategy}, episode {recorder.episode + 1} as ROS 2 messages → {recording.path}"
                ),
                soft_wrap=True,
            )
        return
    from beliefloc.render.figures import save_gif
    from beliefloc.render.picture_episode import episode_frames, save_frames

    trace = recorder.trace
    if trace is None:
        return
    frames = episode_frames(model, trace, smap=smap)
    if recording.gif:
        save_gif(frames, recording.path)
    else:
        save_frames(frames, recording.path)
    kept = (
        "" if len(frames) == trace.steps + 1 else f": the start and the last {len(frames) - 1} of {trace.steps} steps"
    )
    console.print(
        escape(
            f"recorded {trace.strategy}, episode {trace.episode + 1} in {len(frames)} frame"
            f"{'' if len(frames) == 1 else 's'}{kept} → {recording.path}"
        ),
        soft_wrap=True,
    )


def _world(path: Path, model: Model) -> Model:

    world = open_model(path)
    if world.states.names != model.states.names:
        raise UsageError(f"{path}: the world must have the same states as {model.name} (the robot's model)")
    return world


def _episode_line(r: EpisodeRecord) -> str:
    from beliefloc.simulation.strategies import EpisodeStatus

    verdict = "localized" if r.status is EpisodeStatus.LOCALIZED else r.status.value.replace("_", " ")
    right = "correctly" if r.correct else "WRONGLY"
    return escape(
        f"{r.strategy}, episode {r.episode + 1}: {verdict} {right} at {r.final} (p = {r.max_belief:.3f}; true "
        f"{r.true_final}, started at {r.start}) after {r.steps} steps, cost {r.cost:g}, {r.replans} replans"
    )


def register(app: typer.Typer) -> None:
    app.command(short_help="Run localization episodes; compare strategies.")(simulate)
