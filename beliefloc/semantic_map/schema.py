"""The semantic map file format: pydantic models of ``maps/*.yaml``.

Every field is documented in ``docs/map-format.md``. Validation happens here, once; code downstream
works on the frozen, checked :class:`SemanticMap`. Cross-reference checks (a landmark on a blocked
cell, an annotation naming an unknown class) raise :class:`~beliefloc.errors.FieldError` with the path
of the offending value, so the loader can name its line.
"""

from __future__ import annotations

import collections
import math
import re
from functools import cached_property
from typing import TYPE_CHECKING, Annotated, Any, Literal

import numpy as np
from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    PrivateAttr,
    ValidationInfo,
    field_validator,
    model_validator,
)

from beliefloc.errors import FieldError
from beliefloc.limits import GEOMETRY_TESTS, MODEL_ENTRIES
from beliefloc.model import MapFrame, SourceInfo
from beliefloc.semantic_map import observations
from beliefloc.semantic_map.observations import ObservationSet, PartGroup, PartSpec
from beliefloc.semantic_map.occupancy_grid import free_cells, grid_shape, rooms_from_mask, rooms_from_polygons
from beliefloc.source import refuse_field_name

if TYPE_CHECKING:
    from beliefloc.occupancy import OccupancyMap

MAX_COST = 1e6
"""The largest cost of an action: plans add costs up, and a sum must stay a finite number."""
MAX_METRES = 1e9
"""The largest length or map-frame coordinate, in metres (UTM coordinates fit)."""
MIN_CELL_SIZE = 1e-3
"""The smallest ``cell_size``, in metres."""

# Numbers are strict: YAML's true and false are booleans, never 1 and 0 (a strict float still
# takes an integer). Every float that enters arithmetic is finite and bounded.
Integer = Annotated[int, Field(strict=True)]
Probability = Annotated[float, Field(strict=True, ge=0.0, le=1.0, allow_inf_nan=False)]
Cost = Annotated[float, Field(strict=True, ge=0.0, le=MAX_COST, allow_inf_nan=False)]
Length = Annotated[float, Field(strict=True, ge=0.0, le=MAX_METRES, allow_inf_nan=False)]
"""Metres, from 0."""
CellSize = Annotated[float, Field(strict=True, ge=MIN_CELL_SIZE, le=MAX_METRES, allow_inf_nan=False)]
Coordinate = Annotated[float, Field(strict=True, ge=-MAX_METRES, le=MAX_METRES, allow_inf_nan=False)]
"""A map-frame x or y, in metres."""
Degrees = Annotated[float, Field(strict=True, allow_inf_nan=False)]
Name = Annotated[str, Field(pattern=r"^[A-Za-z0-9_\-]+$", max_length=64)]
"""Class, action and sensor names: they become parts of observation names on the command line."""

FREE, BLOCKED = ".", "#"
MOVES_BY_HEADINGS: dict[int, tuple[str, ...]] = {
    1: ("up", "down", "left", "right"),
    4: ("forward", "backward", "rotate_cw", "rotate_ccw"),
    8: ("forward", "backward", "rotate_cw", "rotate_ccw"),
}
_NAME_CHAR = re.compile(r"^[A-Za-z0-9_\-]$")
NO_ROOM = FREE
"""In a room layout, a free cell in no room (blocked cells stay ``#``)."""
_STATE_RE = re.compile(r"^\s*(-?\d+)\s*,\s*(-?\d+)\s*(?:,\s*(-?\d+)\s*)?$")


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True)


def _no_boolean(value: Any) -> Any:
    """YAML's true and false are not the numbers 1 and 0 (a Literal would take them)."""
    if isinstance(value, bool):
        raise ValueError(f"should be a number, got {str(value).lower()}")
    return value


class Grid(_Strict):
    rows: Integer = Field(ge=1, le=100_000)
    """On a map with ``occupancy:``, rows and cols come from the image (the loader fills them in)."""
    cols: Integer = Field(ge=1, le=100_000)
    cell_size: CellSize = 1.0
    """Side of a cell in meters; ranges and scan bins are in meters too."""
    headings: Annotated[Literal[1, 4, 8], BeforeValidator(_no_boolean)] = 4
    """1: no orientation, compass moves; 4 or 8: a triangle per heading, 0 = north, clockwise."""
    robot_radius: Length | None = None
    """Occupancy maps: a cell is a state only when a disc of this radius on its centre touches no
    occupied or unknown pixel (:mod:`beliefloc.semantic_map.occupancy_grid`). Default 0."""


class Landmark(_Strict):
    """An object of a class the robot recognises: at a ``cell`` ``[row, col]``, or at ``x``, ``y`` in
    map-frame metres (what RViz's Publish Point gives; the loader fills in its cell)."""

    class_: Name = Field(alias="class")
    cell: tuple[Integer, Integer]
    x: Coordinate | None = None
    y: Coordinate | None = None
    name: str | None = None
    """Optional label for humans (shown by ``beliefloc show``)."""

    @property
    def position(self) -> tuple[float, float] | None:
        """Map-frame metres, when the file gave them."""
        return None if self.x is None or self.y is None else (self.x, self.y)


class ActionSpec(_Strict):
    cost: Cost = 1.0
    failure: Probability = 0.0
    """Probability that the move fails and the robot stays where it is."""


class _SensorBase(_Strict):
    cost: Cost = 1.0
    passive: bool = False
    """Also observe after every actuation action (Khalvati's setting)."""
    as_action: bool = True
    """Offer the sensor as a perception action of its own."""


class LookSensor(_SensorBase):
    """Which of ``classes`` are seen, each independently with false positives and negatives."""

    type: Literal["look"]
    classes: list[Name]
    false_positive: Probability = 0.0
    false_negative: Probability = 0.0
    range: Length | None = None
    """Meters between cell centres; unlimited when omitted."""
    fov: Annotated[Degrees, Field(gt=0.0, le=360.0)] | None = None
    """Field of view in degrees, centred on the heading. Default 90 (360 on maps with headings 1)."""
    angle_bins: list[Annotated[Degrees, Field(gt=0.0, le=180.0)]] | None = None
    """Upper edges (degrees) of viewing-angle bins: [18, 30, 45] reports 0-18, 18-30 or 30-45."""
    occlusion: bool = True
    """Blocked cells between the robot and a landmark hide it."""

    @field_validator("classes")
    @classmethod
    def _classes(cls, value: list[str]) -> list[str]:
        if not value:
            raise ValueError("a look sensor needs at least one class, or it has no observations")
        counts = collections.Counter(value)
        duplicates = sorted(c for c, n in counts.items() if n > 1)
        if duplicates:
            raise ValueError(f"classes listed twice: {', '.join(duplicates)}")
        return value

    @field_validator("angle_bins")
    @classmethod
    def _bins(cls, value: list[float] | None) -> list[float] | None:
        if value is not None:
            if not value:
                raise ValueError("angle_bins needs at least one edge, e.g. [18, 30, 45]")
            if any(b >= a for a, b in zip(value[1:], value[:-1], strict=False)):
                raise ValueError(f"angle_bins must be strictly increasing, got {value}")
        return value

    def effective_fov(self, headings: int) -> float:
        if headings == 1:
            return 360.0
        if self.fov is not None:
            return self.fov
        return 2.0 * self.angle_bins[-1] if self.angle_bins else 90.0


class ScanSensor(_SensorBase):
    """Distance to the wall or blocked cell in front, binned; 'no_wall' beyond the last bin."""

    type: Literal["scan"]
    bins: list[Annotated[Length, Field(gt=0.0)]]
    """Upper edges in meters: [0.2, 0.8, 1.1, 1.5] gives wall_0-0.2 ... wall_1.1-1.5 and no_wall."""
    error: Probability = 0.0
    """Probability of reading another bin, spread evenly over the others."""
    beams: list[Annotated[Degrees, Field(gt=-360.0, lt=360.0)]] = Field(default_factory=lambda: [0.0])
    """Directions of the beams in degrees, relative to the heading (clockwise positive), each read
    independently with the same bins and error: ``[-90, 0, 90]`` looks left, ahead and right.
    Multiples of 360/headings. The default ``[0]`` is one beam straight ahead."""

    @field_validator("beams")
    @classmethod
    def _beams(cls, value: list[float]) -> list[float]:
        if not value:
            raise ValueError("a scan needs at least one beam, e.g. [0] (straight ahead)")
        turns = [v % 360.0 for v in value]
        if len(set(turns)) != len(turns):
            raise ValueError(f"beams point the same way twice: {value}")
        return value

    @property
    def multi_beam(self) -> bool:
        return self.beams != [0.0]

    @field_validator("bins")
    @classmethod
    def _bins(cls, value: list[float]) -> list[float]:
        if not value:
            raise ValueError("a scan sensor needs at least one bin edge, e.g. [0.2, 0.8, 1.1, 1.5]")
        if any(b >= a for a, b in zip(value[1:], value[:-1], strict=False)):
            raise ValueError(f"bins must be strictly increasing, got {value}")
        return value

    def observation_names(self) -> list[str]:
        return list(observations.scan_values(self.bins))


class HereSensor(_SensorBase):
    """The class of the robot's current cell (Colledanchise's Window, Khalvati's 0/1 labels)."""

    type: Literal["here"]
    labels: str | None = None
    """One character per cell, a row per line (like ``layout``); omitted: from landmarks."""
    legend: dict[str, Name] | None = None
    """Character -> class name; omitted: the character itself is the class."""
    default: Name = "nothing"
    """Class of a cell with no landmark, when ``labels`` is omitted."""
    error: Probability = 0.0
    """Probability of reading another class, spread evenly over the others."""


Sensor = LookSensor | ScanSensor | HereSensor
"""A perception action's sensor; the map file says which by ``type``."""
_TaggedSensor = Annotated[Sensor, Field(discriminator="type")]

RoomName = Annotated[str, Field(pattern=r"^[a-z][a-z0-9_]*$", max_length=64)]
"""A lowercase letter, then lowercase letters, digits and ``_``: the room names of a domain's
knowledge base (clingo constants), so that a domain can reference the map's rooms."""


class RoomRectangle(_Strict):
    """``{from: [r0, c0], to: [r1, c1]}``: the cells from ``[r0, c0]`` to ``[r1, c1]``, both corners included."""

    from_: tuple[Integer, Integer] = Field(alias="from")
    to: tuple[Integer, Integer]


class Rooms(_Strict):
    """Named rooms: a letter per cell (``layout`` with a ``legend``) or ``rectangles`` of cells.

    Every room has at least one cell, its cells are free, and rooms do not overlap; free cells in
    no room are allowed (a doorway, say).
    """

    model_config = ConfigDict(extra="allow", frozen=True, populate_by_name=True)
    layout: str | None = None
    """Like the map's ``layout``: a legend letter per cell of a room, '.' for a free cell in no
    room, '#' for a blocked cell."""
    legend: dict[str, RoomName] | None = None
    """Letter -> room name: ``{K: kitchen}``."""
    rectangles: dict[RoomName, RoomRectangle | list[RoomRectangle]] | None = None
    """Room name -> a rectangle, or a list of them (an L-shaped room)."""
    mask: str | None = None
    """Occupancy maps: a region mask in the Nav2 costmap-filter style -- a second map YAML and image
    with the map's size, resolution and origin, where pixel value k means region k -- relative to
    this file; ``labels`` names the regions. A cell is in the room its centre's pixel says."""
    labels: dict[Integer, RoomName] | None = None
    """``{1: aisle_a, 2: dock}``: the room of each pixel value of ``mask``."""
    polygons: dict[RoomName, list[tuple[Coordinate, Coordinate]]] | None = None
    """Room name -> its outline, ``[[x, y], ...]`` in map-frame metres (at least three corners). A
    cell is in the room when its centre is inside."""

    @field_validator("legend", mode="before")
    @classmethod
    def _digit_letters(cls, value: Any) -> Any:
        # YAML reads ``1: bedroom`` with an integer key; the room layout has the character '1'
        if isinstance(value, dict):
            return {str(k) if isinstance(k, int) and not isinstance(k, bool) else k: v for k, v in value.items()}
        return value


class Annotation(BaseModel):
    """``{state: "1,1,0", look: [potted_plant]}``: the expected observation of a state, by hand.

    ``state`` names one state, or a whole cell (``"r,c"`` on a map with headings); ``states`` lists
    several (generated maps use it). Other keys are sensor names, checked against the map's sensors.
    """

    model_config = ConfigDict(extra="allow", frozen=True)
    state: str | None = None
    states: list[str] | None = None

    @property
    def readings(self) -> dict[str, Any]:
        return dict(self.model_extra or {})

    @property
    def targets(self) -> list[tuple[str, tuple[str | int, ...]]]:
        """Each state named, with the path of where it was written."""
        if self.state is not None:
            return [(self.state, ("state",))]
        return [(name, ("states", i)) for i, name in enumerate(self.states or [])]


class SemanticMap(_Strict):
    name: Name
    description: str | None = None
    occupancy: str | None = None
    """A ROS/Nav2 occupancy map (its YAML file, relative to this one) instead of a ``layout``: the
    grid's rows, columns, free cells and frame come from it (:mod:`beliefloc.occupancy`)."""
    occupancy_rule: Literal["beliefloc", "nav2"] = "beliefloc"
    """``beliefloc``: the saver's unknown grey is unknown even where Nav2's ``free_thresh`` would call
    it free; ``nav2``: Nav2's reading exactly."""
    grid: Grid
    layout: str | None = None
    landmarks: list[Landmark] = Field(default_factory=list)
    actions: dict[str, ActionSpec]
    sensors: dict[Name, _TaggedSensor] = Field(default_factory=dict)
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
        context = info.context or {}
        occupancy: OccupancyMap | None = context.get("occupancy")
        if occupancy is not None:
            data = _grid_from_occupancy(data, occupancy)
        return _landmark_cells(data, occupancy)

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
        lines = _grid_lines(self.layout)
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
        letters = np.array([list(line) for line in _grid_lines(spec.layout)])
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
        g = self.grid
        if self._occupancy is None:  # an occupancy map's grid was checked as its size was worked out
            observations.check_grid(g.rows, g.cols, g.headings, ("grid",))
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
        self._check_landmarks()
        self._check_actions()
        self._check_sensors()
        self._check_observations()
        self._check_annotations()
        self._warn_unseen_classes(context.get("warnings"))
        self._check_rooms()
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
        lines = _grid_lines(self.layout)
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

    def _check_landmarks(self) -> None:
        g = self.grid
        for i, lm in enumerate(self.landmarks):
            r, c = lm.cell
            if not (0 <= r < g.rows and 0 <= c < g.cols):
                raise FieldError(("landmarks", i, "cell"), f"cell [{r}, {c}] is outside the {g.rows}x{g.cols} grid")
            if self._occupancy is None and not self.free[r, c]:
                raise FieldError(("landmarks", i, "cell"), f"cell [{r}, {c}] is blocked in the layout")

    def _check_actions(self) -> None:
        allowed = MOVES_BY_HEADINGS[self.grid.headings]
        if not self.actions:
            raise FieldError(("actions",), f"no actuation actions; expected some of: {', '.join(allowed)}")
        for name in self.actions:
            if name not in allowed:
                raise FieldError(
                    ("actions", name),
                    f"unknown action {name!r} for a map with headings: {self.grid.headings}; "
                    f"expected some of: {', '.join(allowed)}",
                )
            if name in self.sensors:
                raise FieldError(("sensors", name), f"{name!r} is both an action and a sensor")

    def _check_sensors(self) -> None:
        g = self.grid
        for name, sensor in self.sensors.items():
            if isinstance(sensor, ScanSensor) and g.headings == 1:
                raise FieldError(
                    ("sensors", name, "type"), "a scan looks ahead, but the map has headings: 1 (no heading)"
                )
            if isinstance(sensor, HereSensor):
                self._check_here(name, sensor)
            if isinstance(sensor, ScanSensor) and g.headings > 1:
                step = 360.0 / g.headings
                for k, angle in enumerate(sensor.beams):
                    if abs(angle / step - round(angle / step)) > 1e-9:
                        raise FieldError(
                            ("sensors", name, "beams", k),
                            f"a beam at {angle:g} degrees falls between headings; with headings: {g.headings} "
                            f"use multiples of {step:g}",
                        )
            if isinstance(sensor, LookSensor) and sensor.angle_bins and g.headings > 1:
                half = sensor.effective_fov(g.headings) / 2.0
                if half > sensor.angle_bins[-1] + 1e-9:
                    raise FieldError(
                        ("sensors", name, "fov"),
                        f"a field of view of {2 * half:g} degrees sees up to {half:g} degrees off axis, but the "
                        f"angle_bins stop at {sensor.angle_bins[-1]:g}; drop fov or add a bin edge of {half:g}",
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
                _too_much_geometry(tests, f"{landmarks:,} landmarks, each seen from up to {states:,} states"),
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
        key, unit = ("bins", "m") if isinstance(sensor, ScanSensor) else ("angle_bins", "degrees")
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
        lines = _grid_lines(sensor.labels)
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

    def _check_annotations(self) -> None:
        for i, annotation in enumerate(self.annotations):
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

    def _check_rooms(self) -> None:
        spec = self.room_spec
        if spec is None:
            return
        if spec.model_extra:
            key = next(iter(spec.model_extra))
            raise FieldError(
                ("rooms", key),
                f"unknown key {key!r}; expected one of: layout, legend (a letter per cell), rectangles, "
                "mask with labels, or polygons",
            )
        letters = spec.layout is not None or spec.legend is not None
        region = spec.mask is not None or spec.labels is not None
        given = [
            name
            for name, on in (
                ("layout", letters),
                ("rectangles", spec.rectangles is not None),
                ("mask", region),
                ("polygons", spec.polygons is not None),
            )
            if on
        ]
        if len(given) > 1:
            raise FieldError(("rooms", given[1]), f"give one way of drawing rooms, not {' and '.join(given)}")
        if spec.rectangles is not None:
            self._check_room_rectangles(spec.rectangles)
        elif region:
            self._check_room_mask()
        elif spec.polygons is not None:
            self._check_room_polygons(spec.polygons)
        elif not letters:
            raise FieldError(("rooms",), "give layout with a legend (a letter per cell), rectangles, mask or polygons")
        elif spec.layout is None or spec.legend is None:
            missing = "legend" if spec.legend is None else "layout"
            example = "{K: kitchen}" if missing == "legend" else "a letter per cell, like the map's layout"
            raise FieldError(("rooms",), f"a room layout needs a {missing} ({example}); or give rectangles")
        else:
            self._check_room_layout(spec.layout, spec.legend)

    def _check_room_mask(self) -> None:
        spec = self.room_spec
        assert spec is not None
        if spec.mask is None or spec.labels is None:
            missing = "mask (a region map YAML beside this file)" if spec.mask is None else "labels ({1: aisle_a})"
            raise FieldError(("rooms",), f"a region mask needs both mask and labels; {missing} is missing")
        if self._occupancy is None:
            raise FieldError(("rooms", "mask"), "a region mask belongs to a map with occupancy:; use rectangles")
        if self._region_mask is None:
            raise FieldError(("rooms", "mask"), "the region mask was not read: load the map file with load_map")
        names: dict[str, int] = {}
        for value, name in spec.labels.items():
            if name in names:
                raise FieldError(("rooms", "labels", value), f"room {name!r} already has the value {names[name]}")
            names[name] = value
        for name, mask in self.rooms.items():
            if not mask.any():
                value = names[name]
                raise FieldError(
                    ("rooms", "labels", value),
                    f"no cell of the map has its centre on a pixel of value {value} in {spec.mask}: room {name!r} "
                    "would be empty",
                )

    def _check_room_polygons(self, polygons: dict[str, list[tuple[float, float]]]) -> None:
        if not polygons:
            raise FieldError(("rooms", "polygons"), "no rooms; e.g. dock: [[0, 0], [4, 0], [4, 3], [0, 3]]")
        corners = sum(len(vertices) for vertices in polygons.values())
        cells = self.grid.rows * self.grid.cols
        if corners * cells > GEOMETRY_TESTS.value:
            raise FieldError(
                ("rooms", "polygons"),
                _too_much_geometry(corners * cells, f"{corners:,} corners, each tested against {cells:,} cells"),
            )
        for name, vertices in polygons.items():
            if len(vertices) < 3:
                raise FieldError(("rooms", "polygons", name), f"room {name!r} needs at least three corners [x, y]")
            if not all(math.isfinite(v) for corner in vertices for v in corner):
                raise FieldError(("rooms", "polygons", name), f"room {name!r} has a corner that is not a number")
        owner = np.full(self.free.shape, "", dtype=object)
        for name, mask in self.rooms.items():
            if not mask.any():
                raise FieldError(("rooms", "polygons", name), f"no free cell has its centre inside room {name!r}")
            taken = np.argwhere(mask & (owner != ""))
            if len(taken):
                r, c = (int(v) for v in taken[0])
                raise FieldError(
                    ("rooms", "polygons", name), f"room {name!r} overlaps room {owner[r, c]!r} at cell [{r}, {c}]"
                )
            owner[mask] = name

    def _check_room_rectangles(self, rooms: dict[str, RoomRectangle | list[RoomRectangle]]) -> None:
        g = self.grid
        owner = np.full((g.rows, g.cols), "", dtype=object)
        if not rooms:
            raise FieldError(("rooms", "rectangles"), "no rooms; e.g. kitchen: {from: [1, 1], to: [3, 4]}")
        for name, rectangles in rooms.items():
            listed = isinstance(rectangles, list)
            items = rectangles if isinstance(rectangles, list) else [rectangles]
            if not items:
                raise FieldError(("rooms", "rectangles", name), "no rectangle: a room needs at least one cell")
            for k, rect in enumerate(items):
                path: tuple[str | int, ...] = ("rooms", "rectangles", name, *((k,) if listed else ()))
                for corner, (r, c) in (("from", rect.from_), ("to", rect.to)):
                    if not (0 <= r < g.rows and 0 <= c < g.cols):
                        raise FieldError((*path, corner), f"cell [{r}, {c}] is outside the {g.rows}x{g.cols} grid")
                (r0, c0), (r1, c1) = rect.from_, rect.to
                if r0 > r1 or c0 > c1:
                    raise FieldError(
                        (*path, "to"),
                        f"the rectangle from [{r0}, {c0}] to [{r1}, {c1}] is empty: 'to' is the bottom-right "
                        "corner, at or below and right of 'from'",
                    )
                blocked = np.argwhere(~self.free[r0 : r1 + 1, c0 : c1 + 1])
                if len(blocked):
                    r, c = int(blocked[0][0]) + r0, int(blocked[0][1]) + c0
                    raise FieldError(
                        path, f"cell [{r}, {c}] of room {name!r} is blocked in the layout: room cells must be free"
                    )
                taken = np.argwhere((owner[r0 : r1 + 1, c0 : c1 + 1] != "") & (owner[r0 : r1 + 1, c0 : c1 + 1] != name))
                if len(taken):
                    r, c = int(taken[0][0]) + r0, int(taken[0][1]) + c0
                    raise FieldError(path, f"room {name!r} overlaps room {owner[r, c]!r} at cell [{r}, {c}]")
                owner[r0 : r1 + 1, c0 : c1 + 1] = name

    def _check_room_layout(self, layout: str, legend: dict[str, str]) -> None:
        g = self.grid
        for letter in legend:
            if len(letter) != 1 or letter in (FREE, BLOCKED) or letter.isspace():
                raise FieldError(
                    ("rooms", "legend", letter),
                    f"{letter!r} should be one character other than '{FREE}' and '{BLOCKED}', e.g. K: kitchen",
                )
        named: dict[str, str] = {}
        for letter, name in legend.items():
            if name in named:
                raise FieldError(("rooms", "legend", letter), f"room {name!r} already has the letter {named[name]!r}")
            named[name] = letter
        lines = _grid_lines(layout)
        path = ("rooms", "layout")
        if len(lines) != g.rows:
            raise FieldError(path, f"has {len(lines)} rows, but grid.rows is {g.rows}")
        used: set[str] = set()
        for r, line in enumerate(lines):
            if len(line) != g.cols:
                raise FieldError(path, f"row {r} has {len(line)} cells, but grid.cols is {g.cols}", row=r)
            for c, ch in enumerate(line):
                free = bool(self.free[r, c])
                if ch == BLOCKED:
                    if free:
                        raise FieldError(
                            path,
                            f"row {r} has '{BLOCKED}' on a free cell of the layout; write '{NO_ROOM}' for a free "
                            "cell in no room, or a room's letter",
                            row=r,
                            column=c,
                        )
                elif not free:
                    raise FieldError(
                        path, f"row {r} has {ch!r} on a blocked cell of the layout; write '{BLOCKED}'", row=r, column=c
                    )
                elif ch != NO_ROOM:
                    if ch not in legend:
                        letters = ", ".join(f"{k}: {v}" for k, v in legend.items())
                        raise FieldError(
                            path,
                            f"row {r} has {ch!r}, which the legend does not name ({letters}); "
                            f"'{NO_ROOM}' is a free cell in no room",
                            row=r,
                            column=c,
                        )
                    used.add(ch)
        for letter, name in legend.items():
            if letter not in used:
                raise FieldError(
                    ("rooms", "legend", letter),
                    f"no cell of rooms.layout has {letter!r}: room {name!r} would be empty",
                )


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
                return (*at, "angle_bins", w - 1) if bins and w > 0 else where

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
                (*at, "beams", k),
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
        return ("sensors", name, "beams" if sensor.multi_beam and len(sensor.bins) < 2 else "bins")
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
                    path, f"should map each class seen to its viewing angle, e.g. {{{sensor.classes[0]}: 25}}"
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
                        f"viewing angle must be a number of degrees within ±{sensor.angle_bins[-1]:g}",
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


def _grid_from_occupancy(data: dict[str, Any], occupancy: OccupancyMap) -> dict[str, Any]:
    """The grid's rows and cols of a map with ``occupancy:``: as many cells of ``cell_size`` as it
    takes to cover the image. The file must not give them. Refused before any cell is laid out: a
    cell size too small for the limits (:data:`~beliefloc.limits.MODEL_ENTRIES`), a robot radius
    that would take too long to test (:data:`~beliefloc.limits.GEOMETRY_TESTS`)."""
    grid = data.get("grid")
    if not isinstance(grid, dict):
        return data  # the field validator says what is wrong
    for key in ("rows", "cols"):
        if key in grid:
            raise FieldError(("grid", key), f"comes from the occupancy image ({data.get('occupancy')}); drop it")
    written = grid.get("cell_size", 1.0)
    cell_size = _number(written)
    if cell_size is None or not MIN_CELL_SIZE <= cell_size <= MAX_METRES:  # no size of the grid without it
        shown = str(written).lower() if isinstance(written, bool) else repr(written)
        raise FieldError(
            ("grid", "cell_size"),
            f"should be a number of metres from {MIN_CELL_SIZE:g} to {MAX_METRES:g}, got {shown}: the cells of "
            f"the occupancy map {data.get('occupancy')} are laid out by it",
        )
    height, width = occupancy.pixels.shape
    rows, cols = grid_shape(height, width, occupancy.resolution, cell_size)
    headings = grid.get("headings", 4)
    turns = headings if headings in (1, 4, 8) and not isinstance(headings, bool) else 8
    observations.check_grid(rows, cols, turns, ("grid", "cell_size"))
    radius = _number(grid.get("robot_radius"))
    if radius is not None and 0 < radius <= MAX_METRES:
        reach = math.ceil(radius / occupancy.resolution) + 1  # the offsets occupancy_grid.free_cells tries
        tests = (2 * reach + 1) ** 2 * rows * cols
        if tests > GEOMETRY_TESTS.value:
            raise FieldError(
                ("grid", "robot_radius"),
                _too_much_geometry(
                    tests,
                    f"a robot radius of {radius:g} m is {radius / occupancy.resolution:,.0f} pixels of "
                    f"{occupancy.resolution:g} m, tested around each of {rows * cols:,} cells",
                ),
            )
    return {**data, "grid": {**grid, "rows": rows, "cols": cols}}


def _too_much_geometry(tests: int, lead: str) -> str:
    limit = GEOMETRY_TESTS
    return (
        f"{lead}: {tests:,} {limit.what} is more than the limit of {limit.value:,}; "
        f"if the input is what you meant, raise it with the environment variable {limit.variable}=N"
    )


def _landmark_cells(data: dict[str, Any], occupancy: OccupancyMap | None) -> dict[str, Any]:
    """The cell of every landmark written as ``x``, ``y`` in map-frame metres; a landmark off the map
    or (on an occupancy map) on an occupied pixel is refused where it was written."""
    landmarks, grid = data.get("landmarks"), data.get("grid")
    if not isinstance(landmarks, list) or not isinstance(grid, dict):
        return data
    rows, cols, size = (
        _number(grid.get(key, default)) for key, default in (("rows", None), ("cols", None), ("cell_size", 1.0))
    )
    if rows is None or cols is None or size is None or size <= 0:
        return data
    frame = occupancy.frame if occupancy is not None else MapFrame()
    filled = []
    for i, landmark in enumerate(landmarks):
        if not isinstance(landmark, dict) or ("x" not in landmark and "y" not in landmark):
            filled.append(landmark)
            continue
        if "cell" in landmark:
            raise FieldError(("landmarks", i, "cell"), "give a landmark's cell or its x and y, not both")
        if "x" not in landmark or "y" not in landmark:
            missing = "y" if "y" not in landmark else "x"
            raise FieldError(
                ("landmarks", i), f"has {'x' if missing == 'y' else 'y'} but no {missing}: give both, in metres"
            )
        x, y = _number(landmark["x"]), _number(landmark["y"])
        if x is None or y is None:
            filled.append(landmark)  # the field validator says what is wrong
            continue
        gx, gy = frame.to_grid(x, y)
        if occupancy is not None:
            height, width = occupancy.pixels.shape
            j, i_px = (
                math.floor(float(gx) / occupancy.resolution),
                height - 1 - math.floor(float(gy) / occupancy.resolution),
            )
            if not (0 <= i_px < height and 0 <= j < width):
                raise FieldError(("landmarks", i, "x"), f"({x:g}, {y:g}) is off the map {data.get('occupancy')}")
            if occupancy.blocked()[i_px, j]:
                raise FieldError(
                    ("landmarks", i, "x"),
                    f"({x:g}, {y:g}) is on an occupied or unknown pixel of {data.get('occupancy')}: put the object "
                    "on the free pixel in front of it, where the robot sees it from",
                )
        row = int(rows) - 1 - math.floor(float(gy) / size)  # rows and cols are whole: checked by the grid
        col = math.floor(float(gx) / size)
        if not (0 <= row < rows and 0 <= col < cols):
            raise FieldError(
                ("landmarks", i, "x"), f"({x:g}, {y:g}) is off the {rows:g}x{cols:g} grid of {size:g} m cells"
            )
        filled.append({**landmark, "cell": [row, col]})
    return {**data, "landmarks": filled}


def _number(value: Any) -> float | None:
    """``value`` as a finite float, or None when it is not a number (booleans are not numbers)."""
    if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value):
        return float(value)
    return None


def here_classes(sensor: HereSensor, smap: SemanticMap) -> list[str]:
    """The classes a ``here`` sensor can read, in a stable order."""
    if sensor.labels is not None:
        if sensor.legend is not None:
            return list(dict.fromkeys(sensor.legend.values()))
        lines = _grid_lines(sensor.labels)
        free = smap.free
        return sorted({ch for r, line in enumerate(lines) for c, ch in enumerate(line) if free[r, c]})
    return list(dict.fromkeys([sensor.default, *(lm.class_ for lm in smap.landmarks)]))


def _grid_lines(text: str) -> list[str]:
    """Rows of a character grid: blank lines dropped, surrounding spaces stripped."""
    return [line.strip() for line in text.splitlines() if line.strip()]
