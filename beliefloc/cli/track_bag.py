"""``track MAP --bag RUN``: global localization over a ROS recording with the grid filter.

Composes :mod:`beliefloc.recordings` (reading the bag, replaying it) and
:mod:`beliefloc.continuous.grid_filter`; prints through :mod:`beliefloc.render`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

import typer
from rich.markup import escape

from beliefloc.cli.common import check_output, check_ros_recording, print_json, warn
from beliefloc.cli.options import parse_laser_pose
from beliefloc.errors import MapError, UsageError

if TYPE_CHECKING:
    from rich.console import Console

    from beliefloc.continuous.grid_filter import FilterConfig, GridFilter, Update
    from beliefloc.model import GridLayout
    from beliefloc.recordings.reader import Recording
    from beliefloc.recordings.record import TrackRecorder
    from beliefloc.recordings.replay import TrackResult
    from beliefloc.semantic_map.occupancy_map import OccupancyMap

BELIEF_OUT_SUFFIXES = (".json",)
MAX_MAP_YAML_BYTES = 1 << 20


def read_map(path: Path, *, layout: bool = False) -> tuple[OccupancyMap, GridLayout | None, float | None, bool]:
    """The occupancy map of MAP -- a plain map_server YAML or a beliefloc map with ``occupancy:`` --,
    the beliefloc map's grid layout (compiled only when ``layout`` is asked; else None), its robot
    radius (None if unset) and whether MAP is a beliefloc map."""
    import yaml

    from beliefloc.semantic_map import compile_model, load_map
    from beliefloc.semantic_map.occupancy_map import load_occupancy
    from beliefloc.source import file_kinds

    data: object = None
    if path.is_file() and path.stat().st_size <= MAX_MAP_YAML_BYTES:
        try:
            data = yaml.safe_load(path.read_text(encoding="utf-8"))
        except (yaml.YAMLError, UnicodeDecodeError, OSError):
            data = None  # the loaders below say what is wrong
    if file_kinds.kind_of_data(data) == file_kinds.OCCUPANCY:
        occupancy = load_occupancy(path)
        for note in occupancy.warnings:
            warn(note)
        return occupancy, None, None, False
    smap = load_map(path, on_warning=warn)
    occupancy_map = smap.occupancy_map
    if occupancy_map is None:
        raise MapError(
            f"{path}: has no occupancy: a recording is localized on an occupancy map; give the map_server YAML "
            "or a beliefloc map with occupancy:"
        )
    grid = compile_model(smap).grid if layout else None
    return occupancy_map, grid, smap.grid.robot_radius, True


def track_bag(
    map_path: Path,
    bag: Path,
    *,
    scan_topic: str | None,
    odom_topic: str | None,
    laser_pose_text: str | None,
    belief_out: Path | None,
    output: Path | None,
    json_output: bool,
    config: FilterConfig,
    robot_radius_given: bool,
    record: Path | None = None,
) -> None:
    """The command's body; raises BeliefLocError on bad input, typer.Exit(1) when not localized."""
    from dataclasses import replace

    from beliefloc.recordings.reader import read_recording
    from beliefloc.recordings.replay import belief_on_layout, filter_for, track_recording
    from beliefloc.render import stderr_console, stdout_console
    from beliefloc.render.progress import progress_bar
    from beliefloc.source import file_kinds

    laser_pose = parse_laser_pose(laser_pose_text) if laser_pose_text is not None else None
    if output is not None:
        from beliefloc.render.figures import PICTURE_SUFFIXES, pyplot

        check_output("-o", output, PICTURE_SUFFIXES, inputs=(map_path, bag))
        pyplot()  # matplotlib missing: say so before any work
    if belief_out is not None:
        check_output("--belief-out", belief_out, BELIEF_OUT_SUFFIXES, inputs=(map_path, bag), kind=file_kinds.BELIEF)
    if record is not None:
        check_ros_recording("--record", record, (map_path, bag))
    occupancy, layout, map_radius, is_beliefloc_map = read_map(map_path, layout=belief_out is not None)
    if belief_out is not None and not is_beliefloc_map:
        raise UsageError(
            f"--belief-out {belief_out}: {map_path} is a plain map_server YAML, whose states 'beliefloc pose' cannot "
            "name; write a beliefloc map with 'occupancy: " + map_path.name + "' and give that as MAP"
        )
    if map_radius is not None and not robot_radius_given:
        config = replace(config, robot_radius=map_radius)
    recording = read_recording(bag, scan_topic=scan_topic, odom_topic=odom_topic, laser_pose=laser_pose)
    for note in recording.warnings:
        warn(note)
    try:
        grid = filter_for(occupancy, recording, config)
    except ValueError as exc:
        raise UsageError(f"{map_path}: {exc}") from None

    start, end = recording.start, recording.end
    total = max(1e-9, (end - start) / 1e9)
    progress = progress_bar(stderr_console())
    with progress, _recorder(record, recording, grid) as recorder:
        task = progress.add_task("bag time (s)", total=round(total, 1))

        def advance(stamp: int, update: Update | None) -> None:
            if recorder is not None:
                recorder.on_scan(stamp, update)
            progress.update(task, completed=round((stamp - start) / 1e9, 1))

        result = track_recording(occupancy, recording, config, on_scan=advance, grid_filter=grid)
        if recorder is not None:
            recorder.finish(result)
    if record is not None:
        stderr_console().print(escape(f"recorded the run as ROS 2 messages → {record}"), soft_wrap=True)

    if output is not None:
        from beliefloc.render.picture_track import write_track_picture

        verdict = "localized" if result.localized else "not localized"
        write_track_picture(output, grid, result, f"{bag.name} on {map_path.name}: {verdict}")
    if belief_out is not None and layout is not None:
        from beliefloc.model import StateSpace
        from beliefloc.source.atomic_write import write_atomically

        vector = belief_on_layout(grid, layout)
        states = StateSpace(len(vector), grid=layout)
        named = {states.name(int(i)): float(vector[i]) for i in (vector > 1e-12).nonzero()[0]}
        text = json.dumps({"belief": named, **result.as_json()}, indent=1) + "\n"
        write_atomically(belief_out, lambda handle: handle.write(text), binary=False)
    if json_output:
        print_json(result.as_json())
    else:
        _print_summary(stdout_console(), map_path, bag, recording, grid, result, start)
    if not result.localized:
        raise typer.Exit(1)


@contextmanager
def _recorder(record: Path | None, recording: Recording, grid: GridFilter) -> Iterator[TrackRecorder | None]:
    """``--record``: the run's recorder, its recording moved into place when the run ends well."""
    if record is None:
        yield None
        return
    from beliefloc.recordings.record import TrackRecorder, open_recording

    with open_recording(record) as out:
        yield TrackRecorder(out, recording, grid)


def _print_summary(
    console: Console,
    map_path: Path,
    bag: Path,
    recording: Recording,
    grid: GridFilter,
    result: TrackResult,
    start: int,
) -> None:
    from rich.markup import escape

    mx, my, myaw = recording.mount
    console.print(
        escape(
            f"{bag}: {len(recording.scans)} scans on {recording.scan_topic}, odometry from "
            f"{recording.odometry_source}, laser {recording.laser_frame} at x {mx:.3f} y {my:.3f} yaw "
            f"{math.degrees(myaw):.1f}° on {recording.base_frame}"
        ),
        soft_wrap=True,
    )
    c = grid.config
    console.print(
        escape(
            f"{map_path}: {grid.n_states:,} states ({c.cell_size:g} m cells x {c.headings} headings), "
            f"{len(result.updates)} updates over {(recording.end - start) / 1e9:.1f} s"
        ),
        soft_wrap=True,
    )
    x, y, yaw = result.pose
    sd = [math.sqrt(max(0.0, float(result.covariance[i, i]))) for i in (0, 1, 5)]
    pose_text = (
        f"x {x:.3f} m, y {y:.3f} m, yaw {yaw:.3f} rad ({math.degrees(yaw):.1f}°); "
        f"sd x {sd[0]:.3f} m, y {sd[1]:.3f} m, yaw {math.degrees(sd[2]):.1f}°"
    )
    if result.localized and result.localized_at is not None:
        console.print(f"localized at {(result.localized_at - start) / 1e9:.1f} s of bag time")
        console.print(escape(f"final pose: {pose_text}"), soft_wrap=True)
        return
    console.print(escape(f"not localized: {result.reason}"), soft_wrap=True)
    console.print(escape(f"best guess: {pose_text}"), soft_wrap=True)
    for n, mode in enumerate(result.modes, start=1):
        console.print(
            f"  mode {n}: p {mode.probability:.3f} at x {mode.x:.2f} m, y {mode.y:.2f} m, "
            f"yaw {math.degrees(mode.yaw):.0f}°"
        )
