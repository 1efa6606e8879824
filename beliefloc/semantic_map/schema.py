"""The semantic map file format: :class:`SemanticMap`, the pydantic model of ``maps/*.yaml``.

Every field is documented in ``docs/map-format.md``. Validation happens here, once; code downstream
works on the frozen, checked :class:`SemanticMap`. Cross-reference checks (a landmark on a blocked
cell, an annotation naming an unknown class) raise :class:`~beliefloc.errors.FieldError` with the path
of the offending value, so the loader can name its line. The sections it is made of live in
:mod:`~beliefloc.semantic_map.sections`, the room checks in :mod:`~beliefloc.semantic_map.room_checks`,
what an occupancy map fills in before validation in :mod:`~beliefloc.semantic_map.occupancy_section`.
"""

from __future__ import annotations

import math
import re
from functools import cached_property
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from pydantic import (
    BaseModel,
    Field,
    PrivateAttr,
    ValidationInfo,
    model_validator,
)

from beliefloc.errors import FieldError, raise_collected
from beliefloc.model import MapFrame, SourceInfo
from beliefloc.semantic_map import angles, observations
from beliefloc.semantic_map.observations import ObservationSet, PartGroup, PartSpec
from beliefloc.semantic_map.occupancy_grid import free_cells, rooms_from_mask, rooms_from_polygons
from beliefloc.semantic_map.occupancy_section import grid_from_occupancy, landmark_cells, too_much_geometry
from beliefloc.semantic_map.room_checks import check_corner_count, check_rooms
from beliefloc.semantic_map.sections import (
    BLOCKED,
    FREE,
    MAX_METRES,
    MOVES_BY_HEADINGS,
    ActionSpec,
    Annotation,
    Grid,
    HereSensor,
    Landmark,
    LookSensor,
    Name,
    RoomRectangle,
    Rooms,
    ScanSensor,
    Sensor,
    StrictModel,
    TaggedSensor,
    grid_lines,
)
from beliefloc.source import refuse_field_name
from beliefloc.source.limits import GEOMETRY_TESTS, MODEL_ENTRIES

if TYPE_CHECKING:
    from beliefloc.semantic_map.occupancy_map import OccupancyMap


_NAME_CHAR = re.compile(r"^[A-Za-z0-9_\-]$")
_STATE_RE = re.compile(r"^\s*(-?\d+)\s*,\s*(-?\d+)\s*(?:,\s*(-?\d+)\s*)?$")


class SemanticMap(StrictModel):
    name: Name
    description: str | None = None
    occupancy: str | None = None
    """A ROS/Nav2 occupancy map (its YAML file, relative to this one) instead of a ``layout``: the
    grid's rows, columns, free cells and frame come from it (:mod:`beliefloc.semantic_map.occupancy_map`)."""
    occupancy_rule: Literal["beliefloc", "nav2", "nav2-humble", "nav2-jazzy"] = "beliefloc"
    """``beliefloc``: Nav2 Jazzy's reading, but the saver's unknown grey is unknown even where Nav2's
    ``free_thresh`` would call it free; ``nav2-humble`` / ``nav2-jazzy``: that Nav2 release's reading
    exactly; ``nav2``: the current Nav2 LTS's, Jazzy (see :mod:`beliefloc.semantic_map.occupancy_map`)."""
    grid: Grid
    layout: str | None = None
    landmarks: list[Landmark] = Field(default_factory=list)
    actions: dict[str, ActionSpec]
    sensors: dict[Name, TaggedSensor] = Field(default_factory=dict)
    annotations: list[Annotation] = Field(default_factory=list)
    room_spec: Rooms | None = Field(default=None, alias="rooms")
    """The ``rooms:`` section as written; :attr:`rooms` gives each room's cells."""
    _source: SourceInfo | None = PrivateAttr(default=None)
    _occupancy: OccupancyMap | None = PrivateAttr(default=None)
    _region_mask: np.ndarray | None = PrivateAttr(default=None)

    @property
    def occupancy_map(self) -> OccupancyMap | None:
        """The occupancy map named by ``occupancy:`` (set by ``load_map``)."""
        return self._occupancy

    @property
    def region_mask(self) -> np.ndarray | None:
        """The region mask named by ``rooms.mask`` (set by ``load_map``): pixel value k is region k."""
        return self._region_mask

    @property
    def frame(self) -> MapFrame:
        """Where the grid sits in the map frame: the occupancy map's origin, else the identity."""
        return self._occupancy.frame if self._occupancy is not None else MapFrame()

    @property
    def source(self) -> SourceInfo | None:
        """The file this map was read from (set by ``load_map``), for stale-model detection."""
        return self._source

    @model_validator(mode="before")
    @classmethod
    def _no_internal_names(cls, data: Any, info: ValidationInfo) -> Any:
        refuse_field_name(cls, data, "room_spec")  # files write ``rooms:``
        if not isinstance(data, dict):
            return data
        _refuse_internal_names(data)
        check_corner_count(data)
        context = info.context or {}
        data, old_forms = angles.new_form(data)
        if isinstance(context.get("old_forms"), list):
            context["old_forms"].extend(old_forms)
        occupancy: OccupancyMap | None = context.get("occupancy")
        if occupancy is not None:
            data = grid_from_occupancy(data, occupancy)
        return landmark_cells(data, occupancy)

    # --- derived geometry -----------------------------------------------------------------------
    @cached_property
    def free(self) -> np.ndarray:
        """``free[r, c]`` is True where the robot can be (the layout's '.'; on an occupancy map the
        cells :func:`~beliefloc.semantic_map.occupancy_grid.free_cells` admits)."""
        if self._occupancy is not None:
            occ = self._occupancy
            radius = self.grid.robot_radius or 0.0
            return free_cells(occ.blocked(), occ.resolution, self.grid.cell_size, radius)
        if self.layout is None:
            return np.ones((self.grid.rows, self.grid.cols), dtype=bool)
        lines = grid_lines(self.layout)
        return np.array([[ch == FREE for ch in line] for line in lines], dtype=bool)

    @cached_property
    def rooms(self) -> dict[str, np.ndarray]:
        """Room name -> ``mask[r, c]``, True on the room's cells; in the order written. Empty
        when the map has no ``rooms:``. The masks are disjoint and cover only free cells."""
        spec = self.room_spec
        shape = (self.grid.rows, self.grid.cols)
        if spec is None:
            return {}
        if spec.mask is not None and spec.labels is not None and self._region_mask is not None:
            assert self._occupancy is not None  # a mask needs the map: checked at validation
            resolution = self._occupancy.resolution
            return rooms_from_mask(self._region_mask, spec.labels, resolution, self.grid.cell_size, self.free)
        if spec.polygons is not None:
            return rooms_from_polygons(spec.polygons, self.frame, self.grid.cell_size, self.free)
        if spec.rectangles is not None:
            masks = {}
            for name, rectangles in spec.rectangles.items():
                mask = np.zeros(shape, dtype=bool)
                for rect in rectangles if isinstance(rectangles, list) else [rectangles]:
                    (r0, c0), (r1, c1) = rect.from_, rect.to
                    mask[r0 : r1 + 1, c0 : c1 + 1] = True
                masks[name] = mask
            return masks
        assert spec.layout is not None and spec.legend is not None  # checked at validation
        letters = np.array([list(line) for line in grid_lines(spec.layout)])
        return {name: letters == letter for letter, name in spec.legend.items()}

    @property
    def classes(self) -> list[str]:
        """Every class a sensor or landmark mentions, in first-mention order."""
        seen: dict[str, None] = {}
        for sensor in self.sensors.values():
            if isinstance(sensor, LookSensor):
                seen.update(dict.fromkeys(sensor.classes))
        seen.update(dict.fromkeys(lm.class_ for lm in self.landmarks))
        return list(seen)

    def parse_state(self, text: str) -> tuple[int, int, int | None]:
        """``"r,c"`` or ``"r,c,h"`` -> (r, c, h or None); raises ValueError with the reason."""
        match = _STATE_RE.match(text)
        if not match:
            raise ValueError(f"state {text!r} should be 'row,col' or 'row,col,heading'")
        r, c = int(match[1]), int(match[2])
        h = None if match[3] is None else int(match[3])
        g = self.grid
        if not (0 <= r < g.rows and 0 <= c < g.cols):
            raise ValueError(f"state {text!r} is outside the {g.rows}x{g.cols} grid")
        if not self.free[r, c]:
            raise ValueError(f"state {text!r} is on a blocked cell")
        if h is not None and not 0 <= h < g.headings:
            if g.headings == 1:
                raise ValueError(f"state {text!r} has a heading, but the map has headings: 1")
            raise ValueError(f"state {text!r}: heading must be 0..{g.headings - 1}")
        return r, c, h

    # --- cross-reference checks -----------------------------------------------------------------
    @model_validator(mode="after")
    def _check(self, info: ValidationInfo) -> SemanticMap:
        context = info.context or {}
        self._occupancy = context.get("occupancy")
        self._region_mask = context.get("region_mask")
        self._check_occupancy()
        self._warn_units(context.get("unit_warnings"))
        g = self.grid
        if self._occupancy is None:  # an occupancy map's grid was checked as its size was worked out
            observations.check_grid(g.rows, g.cols, g.headings, ("grid",), states=False)
        self._check_layout()
        if not self.free.any():
            if self._occupancy is not None:
                radius = self.grid.robot_radius or 0.0
                raise FieldError(
                    ("grid", "cell_size"),
                    f"no cell of {self.grid.cell_size:g} m has only free pixels and room for a robot of radius "
                    f"{radius:g} m: the map has no states; try a smaller cell_size or robot_radius",
                )
            raise FieldError(("layout",), "every cell is blocked: the map has no states")
        # the checks below are independent: every problem they find is reported in one run
        errors = [*self._check_landmarks(), *self._check_actions(), *self._check_sensors()]
        for check in (self._check_observations, lambda: check_rooms(self)):
            try:
                check()
            except FieldError as exc:
                errors.append(exc)
        errors.extend(self._check_annotations())
        self._warn_unseen_classes(context.get("warnings"))
        raise_collected(errors)
        return self

    def _check_occupancy(self) -> None:
        if self.occupancy is None:
            if self.grid.robot_radius is not None:
                raise FieldError(
                    ("grid", "robot_radius"), "applies to a map with occupancy: (a hand-drawn layout has no pixels)"
                )
            return
        if self._occupancy is None:
            raise FieldError(("occupancy",), "the occupancy map was not read: load the map file with load_map")
        if self.layout is not None:
            raise FieldError(("layout",), "a map with occupancy: takes its free cells from the image; drop layout")

    def _check_layout(self) -> None:
        if self.layout is None:
            return
        lines = grid_lines(self.layout)
        g = self.grid
        if len(lines) != g.rows:
            raise FieldError(("layout",), f"has {len(lines)} rows, but grid.rows is {g.rows}")
        for r, line in enumerate(lines):
            if len(line) != g.cols:
                raise FieldError(("layout",), f"row {r} has {len(line)} cells, but grid.cols is {g.cols}", row=r)
            for c, ch in enumerate(line):
                if ch not in (FREE, BLOCKED):
                    raise FieldError(
                        ("layout",),
                        f"row {r} has {ch!r}; use '{FREE}' for free and '{BLOCKED}' for blocked",
                        row=r,
                        column=c,
                    )

    def _check_landmarks(self) -> list[FieldError]:
        g = self.grid
        errors = []
        for i, lm in enumerate(self.landmarks):
            r, c = lm.cell
            if not (0 <= r < g.rows and 0 <= c < g.cols):
                errors.append(
                    FieldError(("landmarks", i, "cell"), f"cell [{r}, {c}] is outside the {g.rows}x{g.cols} grid")
                )
            elif self._occupancy is None and not self.free[r, c]:
                errors.append(FieldError(("landmarks", i, "cell"), f"cell [{r}, {c}] is blocked in the layout"))
        return errors

    def _check_actions(self) -> list[FieldError]:
        allowed = MOVES_BY_HEADINGS[self.grid.headings]
        if not self.actions:
            return [FieldError(("actions",), f"no actuation actions; expected some of: {', '.join(allowed)}")]
        errors = []
        for name in self.actions:
            if name not in allowed:
                errors.append(
                    FieldError(
                        ("actions", name),
                        f"unknown action {name!r} for a map with headings: {self.grid.headings}; "
                        f"expected some of: {', '.join(allowed)}",
                    )
                )
            if name in self.sensors:
                errors.append(FieldError(("sensors", name), f"{name!r} is both an action and a sensor"))
        return errors

    def _check_sensors(self) -> list[FieldError]:
        """The first problem of each sensor."""
        errors = []
        for name, sensor in self.sensors.items():
            try:
                self._check_sensor(name, sensor)
            except FieldError as exc:
                errors.append(exc)
        return errors

    def _check_sensor(self, name: str, sensor: Sensor) -> None:
        g = self.grid
        if isinstance(sensor, ScanSensor) and g.headings == 1:
            raise FieldError(("sensors", name, "type"), "a scan looks ahead, but the map has headings: 1 (no heading)")
        if isinstance(sensor, HereSensor):
            self._check_here(name, sensor)
        if isinstance(sensor, ScanSensor) and g.headings > 1:
            step = 360.0 / g.headings
            for k, angle in enumerate(sensor.beams):
                if abs(angle / step - round(angle / step)) > 1e-9:
                    radians = angles.looks_like_radians([angle])
                    raise FieldError(
                        ("sensors", name, "beams_deg", k),
                        f"a beam at {angle:g} degrees (counter-clockwise) falls between headings; with headings: "
                        f"{g.headings} use multiples of {step:g}"
                        + ("; it looks like radians: beams_deg is in degrees" if radians else ""),
                    )
        if isinstance(sensor, LookSensor) and sensor.angle_bins and g.headings > 1:
            half = sensor.effective_fov(g.headings) / 2.0
            if half > sensor.angle_bins[-1] + 1e-9:
                raise FieldError(
                    ("sensors", name, "fov_deg"),
                    f"a field of view of {2 * half:g} degrees sees up to {half:g} degrees off axis, but the "
                    f"angle_bins_deg stop at {sensor.angle_bins[-1]:g}; drop fov_deg or add a bin edge of {half:g}",
                )
        if not isinstance(sensor, HereSensor):
            self._check_edges(name, sensor)
        if not sensor.passive and not sensor.as_action:
            raise FieldError(
                ("sensors", name, "as_action"),
                "a sensor that is neither passive nor an action is never used",
            )

    def observation_sets(self, *, named: bool = False) -> list[ObservationSet]:
        """The observations of the model's actions, from the map alone: the moves' (the joint
        readings of the passive sensors, or the one observation ``none``), then each sensor's that
        is offered as an action. With ``named``, each set's parts with their readings' names, as
        :mod:`~beliefloc.semantic_map.compile` builds them (ask only once the sizes are known to
        be within the limits: a Look's names are built per class)."""
        groups = {name: _sensor_groups(name, sensor, self) for name, sensor in self.sensors.items()}
        parts = {name: _sensor_parts(name, sensor, self) if named else () for name, sensor in self.sensors.items()}
        passive = [name for name, sensor in self.sensors.items() if sensor.passive]
        widest = max(passive, key=lambda name: ObservationSet(name, groups[name], ()).n_observations, default=None)
        moves = ObservationSet(
            "the moves",
            tuple(g for name in passive for g in groups[name]),
            ("sensors", widest, "passive") if widest is not None else ("actions",),
            f"each reads the passive sensors {', '.join(passive)} together" if passive else "",
            moves=tuple(self.actions),
            parts=tuple(p for name in passive for p in parts[name]),
        )
        own = [
            ObservationSet(name, groups[name], _defining_field(name, sensor), _explain(sensor, self), parts=parts[name])
            for name, sensor in self.sensors.items()
            if sensor.as_action
        ]
        return [moves, *own]

    def _check_observations(self) -> None:
        """The model's size, before anything is allocated; then that observation names are unique.
        Then the work of Look's geometry (landmarks against the cells in range)."""
        n_states = int(self.free.sum()) * self.grid.headings
        observations.check_size(n_states, self.observation_sets(), MODEL_ENTRIES)
        g = self.grid
        turns = f" with {g.headings} headings" if g.headings > 1 else ""
        observations.check_states(n_states, f"a {g.rows:,} × {g.cols:,} grid{turns}, its free cells", ("grid",))
        for action in self.observation_sets(named=True):
            observations.check_names(action)
        for name, sensor in self.sensors.items():
            if isinstance(sensor, LookSensor):
                self._check_look_work(name, sensor, n_states)

    def _check_look_work(self, name: str, sensor: LookSensor, n_states: int) -> None:
        """Each landmark of a class the sensor looks for is tested against every state in range."""
        classes = set(sensor.classes)
        landmarks = sum(1 for lm in self.landmarks if lm.class_ in classes)
        g = self.grid
        states = n_states
        if sensor.range is not None:
            reach = min(math.floor(sensor.range / g.cell_size + 1e-9) + 1, max(g.rows, g.cols))
            states = min(n_states, (2 * reach + 1) ** 2 * g.headings)
        tests = landmarks * states
        if tests > GEOMETRY_TESTS.value:
            where = "range" if sensor.range is not None else "classes"
            raise FieldError(
                ("sensors", name, where),
                too_much_geometry(tests, f"{landmarks:,} landmarks, each seen from up to {states:,} states"),
            )

    def _warn_units(self, warnings: list[tuple[tuple[str | int, ...], str]] | None) -> None:
        """Likely unit mistakes, which are warnings and not errors (docs/map-format.md, Angles): an
        angle in degrees that looks like radians, an origin yaw in radians that looks like degrees, a
        cell larger than the occupancy map."""
        if warnings is None:
            return
        for name, sensor in self.sensors.items():
            if isinstance(sensor, LookSensor) and sensor.fov is not None and sensor.fov <= 2 * math.pi:
                warnings.append(
                    (
                        ("sensors", name, "fov_deg"),
                        f"a field of view of {sensor.fov:g} degrees looks like radians ({math.degrees(sensor.fov):.4g} "
                        "degrees); fov_deg is in degrees",
                    )
                )
            if isinstance(sensor, LookSensor) and sensor.angle_bins and angles.looks_like_radians(sensor.angle_bins):
                shown = ", ".join(f"{math.degrees(b):.4g}" for b in sensor.angle_bins)
                warnings.append(
                    (
                        ("sensors", name, "angle_bins_deg"),
                        f"{sensor.angle_bins} look like radians ([{shown}] degrees); angle_bins_deg is in degrees",
                    )
                )
        occupancy = self._occupancy
        if occupancy is None:
            return
        yaw = occupancy.frame.yaw
        if abs(yaw) > 2 * math.pi:
            warnings.append(
                (
                    ("occupancy",),
                    f"the origin yaw of {occupancy.yaml_path.name} is {yaw:g}, which looks like degrees: map_server "
                    f"reads it in radians ({yaw:g} rad is {math.degrees(yaw) % 360:.4g} degrees, counter-clockwise)",
                )
            )
        width, height = occupancy.size_m
        if self.grid.cell_size > min(width, height):
            warnings.append(
                (
                    ("grid", "cell_size"),
                    f"a cell of {self.grid.cell_size:g} m is larger than the occupancy map ({width:g} m x "
                    f"{height:g} m): cell_size is in metres",
                )
            )

    def _warn_unseen_classes(self, warnings: list[tuple[tuple[str | int, ...], str]] | None) -> None:
        """A Look class that no landmark has, and that no annotation says is seen, is never seen."""
        if warnings is None:
            return
        placed = {lm.class_ for lm in self.landmarks}
        for name, sensor in self.sensors.items():
            if not isinstance(sensor, LookSensor):
                continue
            annotated: set[str] = set()
            for annotation in self.annotations:
                reading = annotation.readings.get(name)
                if isinstance(reading, (list, dict)):
                    annotated.update(str(c) for c in reading)
            for i, cls in enumerate(sensor.classes):
                if cls not in placed and cls not in annotated:
                    warnings.append(
                        (("sensors", name, "classes", i), f"no landmark is a {cls!r}; the sensor will never see one")
                    )

    def _check_edges(self, name: str, sensor: LookSensor | ScanSensor) -> None:
        """Bin edges print with 6 significant digits in observation names: two that print the same
        would name a reading ``wall_0.2-0.2``."""
        edges = sensor.bins if isinstance(sensor, ScanSensor) else sensor.angle_bins or []
        at = observations.same_label(edges)
        if at is None:
            return
        key, unit = ("bins", "m") if isinstance(sensor, ScanSensor) else ("angle_bins_deg", "degrees")
        before = edges[at - 1] if at > 0 else 0.0
        shown = observations.label(edges[at])
        raise FieldError(
            ("sensors", name, key, at),
            f"{edges[at]!r} {unit} prints as {shown} in observation names, as does the edge before it "
            f"({before!r}), so a reading would be named like '{observations.label(before)}-{shown}'; "
            "space the edges further apart",
        )

    def _check_here(self, name: str, sensor: HereSensor) -> None:
        if sensor.labels is None:
            if sensor.legend is not None:
                raise FieldError(("sensors", name, "legend"), "a legend needs labels")
            return
        lines = grid_lines(sensor.labels)
        g = self.grid
        path = ("sensors", name, "labels")
        if len(lines) != g.rows:
            raise FieldError(path, f"has {len(lines)} rows, but grid.rows is {g.rows}")
        for r, line in enumerate(lines):
            if len(line) != g.cols:
                raise FieldError(path, f"row {r} has {len(line)} cells, but grid.cols is {g.cols}", row=r)
            if sensor.legend is None:
                for c, ch in enumerate(line):
                    if self.free[r, c] and not _NAME_CHAR.match(ch):
                        raise FieldError(
                            path,
                            f"row {r} has {ch!r}, which is not a class name (letters, digits, _ and -); "
                            "name it in a legend, e.g. legend: {'+': door}",
                            row=r,
                            column=c,
                        )
            else:
                for c, ch in enumerate(line):
                    if self.free[r, c] and ch not in sensor.legend:
                        raise FieldError(path, f"row {r} has {ch!r}, which the legend does not name", row=r, column=c)

    def _check_annotations(self) -> list[FieldError]:
        """The first problem of each annotation."""
        errors = []
        for i, annotation in enumerate(self.annotations):
            try:
                self._check_annotation(i, annotation)
            except FieldError as exc:
                errors.append(exc)
        return errors

    def _check_annotation(self, i: int, annotation: Annotation) -> None:
        if annotation.state is not None and annotation.states is not None:
            raise FieldError(("annotations", i, "states"), "give either state: 'r,c,h' or states: [...], not both")
        if annotation.state is None and annotation.states is None:
            raise FieldError(
                ("annotations", i),
                "names no state: give state: 'r,c,h' (or 'r,c' for a whole cell) or states: [...], "
                "e.g. {state: '1,1,0', look: [chair]}",
            )
        for name, where in annotation.targets:
            try:
                self.parse_state(name)
            except ValueError as exc:
                raise FieldError(("annotations", i, *where), str(exc)) from None
        if not annotation.readings:
            raise FieldError(("annotations", i), "names no sensor; e.g. {state: '1,1,0', look: [chair]}")
        for key, value in annotation.readings.items():
            path = ("annotations", i, key)
            sensor = self.sensors.get(key)
            if sensor is None:
                known = ", ".join(self.sensors) or "none"
                raise FieldError(path, f"unknown sensor {key!r}; the map's sensors are: {known}")
            _check_reading(sensor, value, path, self)


def _sensor_groups(name: str, sensor: Sensor, smap: SemanticMap) -> tuple[PartGroup, ...]:
    """How many parts a sensor's observations have, and how many readings each: its sizes."""
    at: tuple[str | int, ...] = ("sensors", name)
    if isinstance(sensor, LookSensor):
        n = len(sensor.angle_bins) + 1 if sensor.angle_bins else 2
        return (PartGroup(name, n, len(sensor.classes), (*at, "classes")),)
    if isinstance(sensor, ScanSensor):
        return (PartGroup(name, len(sensor.bins) + 1, len(sensor.beams), (*at, "bins")),)
    where = (*at, "legend") if sensor.legend is not None else (*at, "labels") if sensor.labels is not None else at
    return (PartGroup(name, len(here_classes(sensor, smap)), 1, where),)


def _sensor_parts(name: str, sensor: Sensor, smap: SemanticMap) -> tuple[PartSpec, ...]:
    """The parts of a sensor's observations, named as :mod:`~beliefloc.semantic_map.compile` names them."""
    at: tuple[str | int, ...] = ("sensors", name)
    if isinstance(sensor, LookSensor):
        parts = []
        bins = sensor.angle_bins
        for i, cls in enumerate(sensor.classes):
            values, aliases = observations.look_values(cls, bins)
            where = (*at, "classes", i)

            def value_where(w: int, where: tuple[str | int, ...] = where) -> tuple[str | int, ...]:
                return (*at, "angle_bins_deg", w - 1) if bins and w > 0 else where

            parts.append(PartSpec(f"{name}.{cls}", values, aliases, where, value_where, name))
        return tuple(parts)
    if isinstance(sensor, ScanSensor):
        n_bins = len(sensor.bins)

        def bin_where(w: int) -> tuple[str | int, ...]:
            return (*at, "bins", w) if w < n_bins else (*at, "bins")

        if not sensor.multi_beam:
            return (PartSpec(name, observations.scan_values(sensor.bins), {}, (*at, "bins"), bin_where, name),)
        return tuple(
            PartSpec(
                f"{name}@{observations.label(angle)}",
                observations.scan_values(sensor.bins, observations.label(angle)),
                {},
                (*at, "beams_deg", k),
                bin_where,
                name,
            )
            for k, angle in enumerate(sensor.beams)
        )
    where = (*at, "legend") if sensor.legend is not None else (*at, "labels") if sensor.labels is not None else at
    return (PartSpec(name, tuple(here_classes(sensor, smap)), {}, where, lambda w: where, name),)


def _defining_field(name: str, sensor: Sensor) -> tuple[str | int, ...]:
    """The field that says how many observations a sensor has."""
    if isinstance(sensor, LookSensor):
        return ("sensors", name, "classes")
    if isinstance(sensor, ScanSensor):
        return ("sensors", name, "beams_deg" if sensor.multi_beam and len(sensor.bins) < 2 else "bins")
    return ("sensors", name, "legend" if sensor.legend is not None else "labels" if sensor.labels else "type")


def _explain(sensor: Sensor, smap: SemanticMap) -> str:
    """Why a sensor has as many observations as it has, for a message."""
    if isinstance(sensor, LookSensor):
        k = len(sensor.classes)
        if sensor.angle_bins:
            angles = len(sensor.angle_bins)
            return f"{angles + 1}^{k}: not seen or one of {angles} angles, for each of {k} classes"
        return f"2^{k}: one for each set of its {k} classes seen"
    if isinstance(sensor, ScanSensor):
        beams = len(sensor.beams)
        per_beam = f"{len(sensor.bins) + 1:,} readings"
        return f"{per_beam} for each of {beams} beams" if beams > 1 else per_beam
    return f"{len(here_classes(sensor, smap)):,} classes"


def _check_reading(
    sensor: LookSensor | ScanSensor | HereSensor, value: Any, path: tuple[str | int, ...], smap: SemanticMap
) -> None:
    if isinstance(sensor, LookSensor):
        if sensor.angle_bins is None:
            if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
                raise FieldError(path, f"should be a list of classes seen, e.g. [{sensor.classes[0]}]")
            classes = value
        else:
            if not isinstance(value, dict):
                raise FieldError(
                    path, f"should map each class seen to its viewing angle, e.g. {{{sensor.classes[0]}: 25deg}}"
                )
            classes = list(value)
            for cls_name, angle in value.items():
                if (
                    isinstance(angle, bool)
                    or not isinstance(angle, (int, float))
                    or not 0 <= abs(angle) <= sensor.angle_bins[-1]
                ):
                    raise FieldError(
                        (*path, cls_name),
                        f"viewing angle must be a number of degrees within ±{sensor.angle_bins[-1]:g}, e.g. 25deg",
                    )
        for cls_name in classes:
            if cls_name not in sensor.classes:
                raise FieldError(
                    path, f"unknown class {cls_name!r}; this sensor looks for: {', '.join(sensor.classes)}"
                )
    elif isinstance(sensor, ScanSensor):
        names = sensor.observation_names()
        if sensor.multi_beam:
            if not isinstance(value, list) or len(value) != len(sensor.beams):
                raise FieldError(path, f"should list one reading per beam ({len(sensor.beams)}), e.g. [0.5, no_wall]")
            readings = [(v, (*path, k)) for k, v in enumerate(value)]
        else:
            readings = [(value, path)]
        for reading, where in readings:
            if isinstance(reading, bool) or not (
                (isinstance(reading, (int, float)) and 0 <= reading <= MAX_METRES)
                or (isinstance(reading, str) and reading in names)
            ):
                raise FieldError(where, f"should be a distance in meters or one of: {', '.join(names)}")
    else:
        if not isinstance(value, str) or value not in here_classes(sensor, smap):
            raise FieldError(
                path, f"unknown class {value!r}; this sensor reads: {', '.join(here_classes(sensor, smap))}"
            )


def _refuse_internal_names(data: dict[str, Any]) -> None:
    """``class_`` and ``from_`` are the Python names of fields that files write ``class`` and
    ``from``: refused where they are written, as ``room_spec`` is."""
    landmarks = data.get("landmarks")
    for i, landmark in enumerate(landmarks if isinstance(landmarks, list) else []):
        _refuse_at(("landmarks", i), Landmark, landmark, "class_")
    rooms = data.get("rooms")
    rectangles = rooms.get("rectangles") if isinstance(rooms, dict) else None
    for name, value in rectangles.items() if isinstance(rectangles, dict) else ():
        if isinstance(value, list):
            for k, rect in enumerate(value):
                _refuse_at(("rooms", "rectangles", str(name), k), RoomRectangle, rect, "from_")
        else:
            _refuse_at(("rooms", "rectangles", str(name)), RoomRectangle, value, "from_")


def _refuse_at(where: tuple[str | int, ...], model: type[BaseModel], data: Any, name: str) -> None:
    try:
        refuse_field_name(model, data, name)
    except FieldError as exc:
        raise FieldError((*where, *exc.path), exc.message) from None


def here_classes(sensor: HereSensor, smap: SemanticMap) -> list[str]:
    """The classes a ``here`` sensor can read, in a stable order."""
    if sensor.labels is not None:
        if sensor.legend is not None:
            return list(dict.fromkeys(sensor.legend.values()))
        lines = grid_lines(sensor.labels)
        free = smap.free
        return sorted({ch for r, line in enumerate(lines) for c, ch in enumerate(line) if free[r, c]})
    return list(dict.fromkeys([sensor.default, *(lm.class_ for lm in smap.landmarks)]))
