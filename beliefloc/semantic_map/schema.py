"""The semantic map file format: pydantic models of ``maps/*.yaml``.

Every field is documented in ``docs/map-format.md``. Validation happens here, once; code downstream
works on the frozen, checked :class:`SemanticMap`. Cross-reference checks (a landmark on a blocked
cell, an annotation naming an unknown class) raise :class:`~beliefloc.errors.FieldError` with the path
of the offending value, so the loader can name its line.
"""

from __future__ import annotations

import itertools
import math
import re
from functools import cached_property
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, PrivateAttr, field_validator, model_validator

from beliefloc.errors import FieldError
from beliefloc.model import SourceInfo
from beliefloc.source import refuse_field_name

Probability = Annotated[float, Field(ge=0.0, le=1.0)]
Cost = Annotated[float, Field(ge=0.0, allow_inf_nan=False)]
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


class Grid(_Strict):
    rows: int = Field(ge=1, le=100_000)
    cols: int = Field(ge=1, le=100_000)
    cell_size: float = Field(default=1.0, gt=0.0, allow_inf_nan=False)
    """Side of a cell in meters; ranges and scan bins are in meters too."""
    headings: Literal[1, 4, 8] = 4
    """1: no orientation, compass moves; 4 or 8: a triangle per heading, 0 = north, clockwise."""


class Landmark(_Strict):
    class_: Name = Field(alias="class")
    cell: tuple[int, int]
    name: str | None = None
    """Optional label for humans (shown by ``beliefloc show``)."""


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
    range: float | None = Field(default=None, ge=0.0, allow_inf_nan=False)
    """Meters between cell centres; unlimited when omitted."""
    fov: float | None = Field(default=None, gt=0.0, le=360.0)
    """Field of view in degrees, centred on the heading. Default 90 (360 on maps with headings 1)."""
    angle_bins: list[Annotated[float, Field(gt=0.0, le=180.0)]] | None = None
    """Upper edges (degrees) of viewing-angle bins: [18, 30, 45] reports 0-18, 18-30 or 30-45."""
    occlusion: bool = True
    """Blocked cells between the robot and a landmark hide it."""

    @field_validator("classes")
    @classmethod
    def _classes(cls, value: list[str]) -> list[str]:
        if not value:
            raise ValueError("a look sensor needs at least one class, or it has no observations")
        duplicates = sorted({c for c in value if value.count(c) > 1})
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
    bins: list[Annotated[float, Field(gt=0.0, allow_inf_nan=False)]]
    """Upper edges in meters: [0.2, 0.8, 1.1, 1.5] gives wall_0-0.2 ... wall_1.1-1.5 and no_wall."""
    error: Probability = 0.0
    """Probability of reading another bin, spread evenly over the others."""
    beams: list[Annotated[float, Field(gt=-360.0, lt=360.0, allow_inf_nan=False)]] = Field(
        default_factory=lambda: [0.0]
    )
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
        edges = [0.0, *self.bins]
        names = [f"wall_{_fmt(lo)}-{_fmt(hi)}" for lo, hi in itertools.pairwise(edges)]
        return [*names, "no_wall"]


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

    from_: tuple[int, int] = Field(alias="from")
    to: tuple[int, int]


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
    grid: Grid
    layout: str | None = None
    landmarks: list[Landmark] = Field(default_factory=list)
    actions: dict[str, ActionSpec]
    sensors: dict[Name, _TaggedSensor] = Field(default_factory=dict)
    annotations: list[Annotation] = Field(default_factory=list)
    room_spec: Rooms | None = Field(default=None, alias="rooms")
    """The ``rooms:`` section as written; :attr:`rooms` gives each room's cells."""
    _source: SourceInfo | None = PrivateAttr(default=None)

    @property
    def source(self) -> SourceInfo | None:
        """The file this map was read from (set by ``load_map``), for stale-model detection."""
        return self._source

    @model_validator(mode="before")
    @classmethod
    def _no_internal_names(cls, data: Any) -> Any:
        refuse_field_name(cls, data, "room_spec")  # files write ``rooms:``
        return data

    # --- derived geometry -----------------------------------------------------------------------
    @cached_property
    def free(self) -> np.ndarray:
        """``free[r, c]`` is True where the robot can be (the layout's '.')."""
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
    def _check(self) -> SemanticMap:
        self._check_layout()
        if not self.free.any():
            raise FieldError(("layout",), "every cell is blocked: the map has no states")
        self._check_landmarks()
        self._check_actions()
        self._check_sensors()
        self._check_annotations()
        self._check_rooms()
        return self

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
            if not self.free[r, c]:
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
            if not sensor.passive and not sensor.as_action:
                raise FieldError(
                    ("sensors", name, "as_action"),
                    "a sensor that is neither passive nor an action is never used",
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
            if (annotation.state is None) == (annotation.states is None):
                raise FieldError(("annotations", i), "give either state: 'r,c,h' or states: [...], not both")
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
                f"unknown key {key!r}; expected one of: layout, legend (a letter per cell) or rectangles",
            )
        letters = spec.layout is not None or spec.legend is not None
        if letters and spec.rectangles is not None:
            raise FieldError(("rooms", "rectangles"), "give either layout with a legend or rectangles, not both")
        if spec.rectangles is not None:
            self._check_room_rectangles(spec.rectangles)
        elif not letters:
            raise FieldError(("rooms",), "give layout with a legend (a letter per cell) or rectangles")
        elif spec.layout is None or spec.legend is None:
            missing = "legend" if spec.legend is None else "layout"
            example = "{K: kitchen}" if missing == "legend" else "a letter per cell, like the map's layout"
            raise FieldError(("rooms",), f"a room layout needs a {missing} ({example}); or give rectangles")
        else:
            self._check_room_layout(spec.layout, spec.legend)

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
                if not isinstance(angle, (int, float)) or not 0 <= abs(angle) <= sensor.angle_bins[-1]:
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
                (isinstance(reading, (int, float)) and reading >= 0) or (isinstance(reading, str) and reading in names)
            ):
                raise FieldError(where, f"should be a distance in meters or one of: {', '.join(names)}")
    else:
        if not isinstance(value, str) or value not in here_classes(sensor, smap):
            raise FieldError(
                path, f"unknown class {value!r}; this sensor reads: {', '.join(here_classes(sensor, smap))}"
            )


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


def _fmt(value: float) -> str:
    return f"{value:g}" if math.isfinite(value) else "inf"
