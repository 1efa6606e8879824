"""Compile a validated :class:`SemanticMap` into a :class:`Model` (Colledanchise Defs. 1-7).

Build time and memory are linear in the number of states: transitions are CSR with at most two
entries per row, and observations are stored factored (see :mod:`beliefloc.model`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from beliefloc.model import (
    Action,
    ActionKind,
    GridLayout,
    Model,
    ObservationModel,
    ObservationPart,
    SourceInfo,
    StateSpace,
)
from beliefloc.semantic_map import geometry, pixel_geometry
from beliefloc.semantic_map.observations import label, look_values, scan_values
from beliefloc.semantic_map.schema import SemanticMap, here_classes
from beliefloc.semantic_map.sections import HereSensor, LookSensor, ScanSensor, Sensor, grid_lines

if TYPE_CHECKING:  # the region models need scipy; validating a map must not load it
    from beliefloc.continuous.image import OccupancyImage
    from beliefloc.semantic_map.regions import RegionSpec


def layout_of(smap: SemanticMap) -> GridLayout:
    g = smap.grid
    landmarks = tuple((lm.class_, lm.cell[0], lm.cell[1]) for lm in smap.landmarks)
    return GridLayout(g.rows, g.cols, g.headings, g.cell_size, smap.free.copy(), landmarks, smap.frame)


def room_states(rooms: Mapping[str, np.ndarray], layout: GridLayout) -> dict[str, np.ndarray]:
    """Room name -> the sorted indices of its states (every heading of every cell of the room).

    ``rooms`` is :attr:`SemanticMap.rooms` (a cell mask per room); ``layout`` the grid of the model
    the states belong to (``model.grid``). Raises ValueError when a mask does not fit the grid or
    covers a cell that is not a state there (a model compiled from another map).
    """
    index = geometry.cell_index_map(layout)
    out = {}
    for name, mask in rooms.items():
        if mask.shape != (layout.rows, layout.cols):
            raise ValueError(
                f"room {name!r} is drawn on a {mask.shape[0]}x{mask.shape[1]} grid, not {layout.rows}x{layout.cols}"
            )
        cells = index[mask]
        if (cells < 0).any():
            r, c = (int(x) for x in np.argwhere(mask & ~layout.free)[0])
            raise ValueError(f"cell [{r}, {c}] of room {name!r} is not a free cell of the model's grid")
        states = (np.sort(cells)[:, None] * layout.headings + np.arange(layout.headings)[None, :]).ravel()
        out[name] = states.astype(np.int64, copy=False)
    return out


def compile_model(smap: SemanticMap, source: SourceInfo | None = None) -> Model:
    """The model of ``smap``: an actuation action per map action (observing the passive sensors),
    then a perception action per sensor offered as an action."""
    layout = layout_of(smap)
    n = layout.n_states
    perception, passive = _sensor_actions(smap, layout)
    actions: list[Action] = []
    for name, spec in smap.actions.items():
        targets = geometry.motion_targets(layout, name)
        actions.append(
            Action(
                name=name,
                kind=ActionKind.ACTUATION,
                cost=spec.cost,
                transition=geometry.transition_matrix(targets, spec.failure),
                observation=ObservationModel(n, passive),
            )
        )
    return Model(
        name=smap.name,
        states=StateSpace(n, grid=layout),
        actions=(*actions, *perception),
        grid=layout,
        source=source if source is not None else smap.source,
    )


@dataclass(frozen=True)
class MapSummary:
    """What ``validate`` reports of a map without building its transition matrices (they are the
    only part of compiling that needs scipy, and a valid map always has them)."""

    name: str
    grid: GridLayout
    actuation_actions: tuple[str, ...]
    perception_actions: tuple[Action, ...]
    """The sensors offered as actions, with their observation models, as :func:`compile_model` builds them."""

    @property
    def n_states(self) -> int:
        return self.grid.n_states

    @property
    def action_names(self) -> list[str]:
        """In the model's order: the actuation actions, then the perception actions."""
        return [*self.actuation_actions, *(a.name for a in self.perception_actions)]


def describe_map(smap: SemanticMap) -> MapSummary:
    """The sizes of ``smap``'s model: its grid, states, actions and each sensor's observations."""
    layout = layout_of(smap)
    perception, _ = _sensor_actions(smap, layout)
    return MapSummary(smap.name, layout, tuple(smap.actions), tuple(perception))


def _sensor_actions(smap: SemanticMap, layout: GridLayout) -> tuple[list[Action], tuple[ObservationPart, ...]]:
    """The perception actions (one per sensor offered as an action), and the observation parts of
    the passive sensors, which every actuation action observes."""
    n = layout.n_states
    annotated = _annotated_states(smap, layout)
    parts = {name: _sensor_parts(name, sensor, smap, layout, annotated) for name, sensor in smap.sensors.items()}
    passive = tuple(p for name, sensor in smap.sensors.items() if sensor.passive for p in parts[name])
    perception = [
        Action(name, ActionKind.PERCEPTION, sensor.cost, None, ObservationModel(n, parts[name]))
        for name, sensor in smap.sensors.items()
        if sensor.as_action
    ]
    return perception, passive


def _annotated_states(smap: SemanticMap, layout: GridLayout) -> list[tuple[np.ndarray, dict[str, object]]]:
    """Each annotation as (the states it covers, its readings by sensor name).

    A name ``"r,c,h"`` covers one state, ``"r,c"`` every heading of the cell, in the order written.
    The names were checked by :meth:`SemanticMap.parse_state` when the map was validated; here the
    indices are computed for all of them at once (generated maps list 10^6 states).
    """
    index = geometry.cell_index_map(layout)
    h_count = layout.headings
    out = []
    for annotation in smap.annotations:
        names = [annotation.state] if annotation.state is not None else (annotation.states or [])
        rows, cols, heading = _parse_state_names(names)
        first = index[rows, cols] * h_count
        whole = heading < 0
        counts = np.where(whole, h_count, 1)
        ends = np.cumsum(counts)
        within = np.arange(int(ends[-1]) if len(ends) else 0) - np.repeat(ends - counts, counts)
        covered = np.repeat(first, counts) + np.where(np.repeat(whole, counts), within, np.repeat(heading, counts))
        out.append((covered.astype(np.int64, copy=False), annotation.readings))
    return out


def _parse_state_names(names: list[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows, columns and headings (-1 for a whole cell) of valid names ``"r,c"`` / ``"r,c,h"``.

    ASCII names are parsed as one byte array: digits are summed per number with their place
    values, numbers are split at commas and names at ``;`` (which no valid name contains). This
    is ~20x faster than splitting a million strings one by one, which is what other names get.
    """
    text = ";".join(names)
    if not names or not text.isascii():
        fields = [[int(f) for f in name.split(",")] for name in names]
        return (
            np.array([f[0] for f in fields], dtype=np.int64),
            np.array([f[1] for f in fields], dtype=np.int64),
            np.array([f[2] if len(f) == 3 else -1 for f in fields], dtype=np.int64),
        )
    data = np.frombuffer(text.encode("ascii"), dtype=np.uint8)
    digit = (data >= ord("0")) & (data <= ord("9"))
    comma, semicolon = data == ord(","), data == ord(";")
    keep = digit | comma | semicolon  # whitespace around the numbers goes
    data, digit, comma, semicolon = data[keep], digit[keep], comma[keep], semicolon[keep]
    number = np.cumsum(comma | semicolon)  # which number each byte belongs to
    n_numbers = int(number[-1]) + 1
    owner = number[digit]  # the digits of one number are consecutive
    per_number = np.bincount(owner, minlength=n_numbers)
    place = np.cumsum(per_number)[owner] - 1 - np.arange(len(owner))  # digits after this one
    weights = (data[digit] - ord("0")).astype(np.float64) * 10.0**place
    values = np.rint(np.bincount(owner, weights=weights, minlength=n_numbers)).astype(np.int64)
    name_of_comma = np.cumsum(semicolon)[comma]
    n_fields = np.bincount(name_of_comma, minlength=len(names)) + 1
    start = np.cumsum(n_fields) - n_fields
    heading = np.where(n_fields == 3, values[np.minimum(start + 2, n_numbers - 1)], -1)
    return values[start], values[start + 1], heading


def _sensor_parts(
    name: str,
    sensor: Sensor,
    smap: SemanticMap,
    layout: GridLayout,
    annotated: list[tuple[np.ndarray, dict[str, object]]],
) -> tuple[ObservationPart, ...]:
    pixels = _Pixels.of(smap)
    if isinstance(sensor, LookSensor):
        return _look_parts(name, sensor, smap, layout, annotated, pixels)
    if isinstance(sensor, ScanSensor):
        return _scan_parts(name, sensor, layout, annotated, pixels)
    return (_here_part(name, sensor, smap, layout, annotated),)


@dataclass(frozen=True, eq=False)
class _Pixels:
    """An occupancy map's pixels, which Look and Scan see through instead of the cells."""

    blocked: np.ndarray
    """Occupied or unknown, row 0 at the top of the image."""
    resolution: float
    key: str
    """The map's content hash, for the ray-cast cache."""

    @classmethod
    def of(cls, smap: SemanticMap) -> _Pixels | None:
        occupancy = smap.occupancy_map
        if occupancy is None:
            return None
        return cls(occupancy.blocked(), occupancy.resolution, occupancy.sha256)


def _noise(n_values: int, error: float) -> np.ndarray:
    """Read the true value with ``1 - error``, any other one with ``error / (n - 1)``."""
    if n_values == 1:
        return np.ones((1, 1))
    table = np.full((n_values, n_values), error / (n_values - 1))
    np.fill_diagonal(table, 1.0 - error)
    return table


def _look_parts(
    name: str,
    sensor: LookSensor,
    smap: SemanticMap,
    layout: GridLayout,
    annotated: list[tuple[np.ndarray, dict[str, object]]],
    pixels: _Pixels | None,
) -> tuple[ObservationPart, ...]:
    """One part per class. On a hand-drawn grid a landmark stands at its cell's centre and blocked
    cells hide it; on an occupancy map it stands where the file puts it (``x``, ``y``, else its
    cell's centre) and the pixels hide it."""
    n = layout.n_states
    fov = sensor.effective_fov(layout.headings)
    bins = np.array(sensor.angle_bins) if sensor.angle_bins else None
    sub, yaw, fov_edge, range_edge = sensor.region()
    region_exact = (sub, yaw, fov_edge, range_edge) == (1, 1, 0.0, 0.0)
    fp, fn = sensor.false_positive, sensor.false_negative
    region: _Region | None = None
    cells_by_class: dict[str, list[tuple[int, int]]] = {}
    for lm_class, lr, lc in layout.landmarks:
        cells_by_class.setdefault(lm_class, []).append((lr, lc))
    parts = []
    for cls in sensor.classes:
        best = np.full(n, np.inf)  # smallest viewing angle of any landmark of this class
        if cls in cells_by_class and pixels is None:
            cells = np.array(cells_by_class[cls], dtype=np.int64)
            states, angles, _ = geometry.viewing_angles_many(layout, cells, sensor.range, fov, sensor.occlusion)
            np.minimum.at(best, states, angles)
        elif cls in cells_by_class and pixels is not None:
            xy = _landmarks_xy(smap, layout, cls)
            states, angles, _ = pixel_geometry.viewing_angles_metric(
                layout, pixels.blocked, pixels.resolution, xy, sensor.range, fov, sensor.occlusion
            )
            np.minimum.at(best, states, angles)
        for states, readings in annotated:
            if name in readings:
                best[states] = _annotated_angle(readings[name], cls)
        truth = _angle_to_value(best, bins)
        values, aliases = look_values(cls, sensor.angle_bins)  # the names validation checked
        if bins is None:
            confusion = np.array([[1.0 - fp, fp], [fn, 1.0 - fn]])
        else:
            k = len(bins)
            confusion = np.zeros((k + 1, k + 1))
            confusion[0, 0], confusion[0, 1:] = 1.0 - fp, fp / k
            confusion[1:, 0] = fn
            confusion[1:, 1:] += np.eye(k) * (1.0 - fn)
        if not region_exact:
            if region is None:  # the image and the sub-poses, once for every class
                region = _Region.of(layout, pixels, sub, yaw)
            truth, confusion = _region_look(
                name,
                cls,
                sensor,
                smap,
                layout,
                annotated,
                region,
                fov,
                bins,
                (fov_edge, range_edge),
                confusion,
            )
        parts.append(ObservationPart(f"{name}.{cls}", values, truth, confusion, aliases))
    return tuple(parts)


def _region_image(layout: GridLayout, pixels: _Pixels | None) -> OccupancyImage:
    """What stops a ray for the region models, in the grid frame: the pixels, or the blocked cells."""
    from beliefloc.semantic_map import regions

    if pixels is None:
        return regions.blocked_image(~layout.free, layout.cell_size)
    return regions.blocked_image(pixels.blocked, pixels.resolution)


@dataclass(frozen=True, eq=False)
class _Region:
    """A sensor's region model set-up, shared by its parts: the image rays are cast over, the
    region spec and the sub-poses of every state (:func:`regions.sub_poses`)."""

    image: OccupancyImage
    spec: RegionSpec
    sub: tuple[np.ndarray, np.ndarray]

    @classmethod
    def of(cls, layout: GridLayout, pixels: _Pixels | None, sub_samples: int, yaw_samples: int) -> _Region:
        from beliefloc.semantic_map import regions

        image = _region_image(layout, pixels)
        spec = regions.RegionSpec(sub_samples, yaw_samples)
        return cls(image, spec, regions.sub_poses(layout, image, spec))


def _region_look(
    name: str,
    cls: str,
    sensor: LookSensor,
    smap: SemanticMap,
    layout: GridLayout,
    annotated: list[tuple[np.ndarray, dict[str, object]]],
    region: _Region,
    fov: float,
    bins: np.ndarray | None,
    fades: tuple[float, float],
    confusion: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """A Look part's ``(truth, confusion)`` under the region model: a distinct row per distribution."""
    from beliefloc.semantic_map import regions

    fov_edge, range_edge = fades
    xy = _landmarks_xy(smap, layout, cls) if any(c == cls for c, _, _ in layout.landmarks) else np.zeros((0, 2))
    dist = regions.region_look(
        layout,
        region.image,
        region.spec,
        xy,
        fov,
        sensor.range,
        sensor.occlusion,
        bins,
        fov_edge,
        range_edge,
        sub=region.sub,
    )
    for states, readings in annotated:  # an annotation is what the file says is read there
        if name in readings:
            value = _angle_to_value(np.array([_annotated_angle(readings[name], cls)]), bins)[0]
            dist[states] = np.eye(dist.shape[1])[value]
    return _rows(dist @ confusion)


def _rows(dist: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    from beliefloc.semantic_map import regions

    rows, index = regions.quantised_rows(dist)
    return index, rows


def _landmarks_xy(smap: SemanticMap, layout: GridLayout, cls: str) -> np.ndarray:
    """Grid-frame metres of the landmarks of class ``cls``: where the file put them, or the centre
    of their cell."""
    out = []
    for landmark in smap.landmarks:
        if landmark.class_ != cls:
            continue
        if landmark.position is not None:
            gx, gy = smap.frame.to_grid(*landmark.position)
            out.append((float(gx), float(gy)))
        else:
            r, c = landmark.cell
            out.append(((c + 0.5) * layout.cell_size, (layout.rows - r - 0.5) * layout.cell_size))
    return np.array(out, dtype=np.float64).reshape(-1, 2)


def _annotated_angle(reading: object, cls: str) -> float:
    if isinstance(reading, dict):
        angle = reading.get(cls)
        return float("inf") if angle is None else abs(float(angle))
    assert isinstance(reading, list)
    return 0.0 if cls in reading else float("inf")


def _angle_to_value(best: np.ndarray, bins: np.ndarray | None) -> np.ndarray:
    seen = np.isfinite(best)
    truth = np.zeros(len(best), dtype=np.int32)
    if bins is None:
        truth[seen] = 1
    else:
        truth[seen] = np.searchsorted(bins, best[seen] - 1e-9, side="left") + 1
    return truth


def _scan_parts(
    name: str,
    sensor: ScanSensor,
    layout: GridLayout,
    annotated: list[tuple[np.ndarray, dict[str, object]]],
    pixels: _Pixels | None,
) -> tuple[ObservationPart, ...]:
    """One independent part per beam. A single beam straight ahead (the default) is the part
    ``name`` with readings ``wall_0-0.2``, ...; with several beams each is ``name@angle`` and its
    readings are suffixed ``@angle`` (``wall_0-0.2@90``, degrees counter-clockwise: the left beam), so
    joint names stay unambiguous."""
    names = sensor.observation_names()
    bins = np.array(sensor.bins)
    sub, yaw, sigma, random, short = sensor.region()
    region_exact = (sub, yaw, sigma, random, short) == (1, 1, 0.0, 0.0, 0.0)
    region_dists: list[np.ndarray] | None = None
    if not region_exact:  # every beam at once: beams that point alike at some heading share their rays
        from beliefloc.semantic_map import regions

        region = _Region.of(layout, pixels, sub, yaw)
        region_dists = regions.region_scans(
            layout, region.image, region.spec, sensor.beams, bins, sigma, random, short, sub=region.sub
        )
        del region
    if pixels is None:
        distance = geometry.wall_distances(layout, sensor.bins[-1])
    else:  # rays cast over the pixels: unknown space and the map's edge stop them, as AMCL's do
        distance = pixel_geometry.ray_distances(
            pixels.blocked, pixels.resolution, layout, sensor.bins[-1], key=pixels.key
        )
    parts = []
    for k, angle in enumerate(sensor.beams):
        offset = round(-angle / (360.0 / layout.headings))  # heading steps clockwise; beams turn counter-clockwise
        beam = geometry.beam_distances(layout, distance, offset)
        truth = np.searchsorted(bins, beam - 1e-9, side="left").astype(np.int32)
        for states, readings in annotated:
            if name in readings:
                reading = readings[name]
                if sensor.multi_beam:
                    assert isinstance(reading, list)
                    reading = reading[k]
                if isinstance(reading, str):
                    truth[states] = names.index(reading)
                else:
                    truth[states] = int(np.searchsorted(bins, np.float64(float(reading)) - 1e-9))  # type: ignore[arg-type]
        confusion = _noise(len(names), sensor.error)
        if region_dists is not None:
            dist = region_dists[k]
            for states, readings in annotated:  # an annotated state reads what the file says
                if name in readings:
                    dist[states] = np.eye(len(names))[truth[states]]
            truth, confusion = _rows(dist @ confusion)
        if sensor.multi_beam:
            angle_label = label(angle)
            parts.append(
                ObservationPart(
                    f"{name}@{angle_label}",
                    scan_values(sensor.bins, angle_label),
                    truth,
                    confusion,
                )
            )
        else:
            parts.append(ObservationPart(name, tuple(names), truth, confusion))
    return tuple(parts)


def _here_part(
    name: str,
    sensor: HereSensor,
    smap: SemanticMap,
    layout: GridLayout,
    annotated: list[tuple[np.ndarray, dict[str, object]]],
) -> ObservationPart:
    classes = here_classes(sensor, smap)
    lookup = {cls: i for i, cls in enumerate(classes)}
    cell_class = np.full((layout.rows, layout.cols), lookup.get(sensor.default, 0), dtype=np.int32)
    if sensor.labels is not None:
        for r, line in enumerate(grid_lines(sensor.labels)):
            for c, ch in enumerate(line):
                if layout.free[r, c]:
                    cell_class[r, c] = lookup[sensor.legend[ch] if sensor.legend else ch]
    else:
        for lm_class, r, c in layout.landmarks:
            cell_class[r, c] = lookup[lm_class]
    truth = np.repeat(cell_class.ravel()[layout.free_cells], layout.headings).astype(np.int32)
    for states, readings in annotated:
        if name in readings:
            truth[states] = lookup[str(readings[name])]
    return ObservationPart(name, tuple(classes), truth, _noise(len(classes), sensor.error))


def region_image(smap: SemanticMap, layout: GridLayout) -> OccupancyImage:
    """What stops a ray and where the robot cannot stand, in the grid frame: the occupancy map's
    pixels, or the grid's blocked cells."""
    return _region_image(layout, _Pixels.of(smap))


def landmarks_xy(smap: SemanticMap, layout: GridLayout, cls: str) -> np.ndarray:
    """Grid-frame metres of the landmarks of class ``cls`` (empty ``(0, 2)`` when there are none)."""
    if not any(c == cls for c, _, _ in layout.landmarks):
        return np.zeros((0, 2))
    return _landmarks_xy(smap, layout, cls)


def scan_confusion(sensor: ScanSensor) -> np.ndarray:
    """A scan part's ``error``: the true bin with ``1 - error``, any other with ``error / (n - 1)``."""
    return _noise(len(sensor.bins) + 1, sensor.error)


def look_confusion(sensor: LookSensor) -> np.ndarray:
    """A look part's confusion from "not seen" / the true angle bin to the reading, with
    ``false_positive`` and ``false_negative``."""
    fp, fn = sensor.false_positive, sensor.false_negative
    if not sensor.angle_bins:
        return np.array([[1.0 - fp, fp], [fn, 1.0 - fn]])
    k = len(sensor.angle_bins)
    confusion = np.zeros((k + 1, k + 1))
    confusion[0, 0], confusion[0, 1:] = 1.0 - fp, fp / k
    confusion[1:, 0] = fn
    confusion[1:, 1:] += np.eye(k) * (1.0 - fn)
    return confusion
