"""The sections of a semantic map file: the grid, landmarks, actions, sensors, rooms and annotations.

Each is a frozen pydantic model checked on its own; :class:`~beliefloc.semantic_map.schema.SemanticMap`
puts them together and checks what refers across sections. Every field is documented in
``docs/map-format.md``.
"""

from __future__ import annotations

import collections
import math
from typing import Annotated, Any, Literal, TypeVar

from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    field_validator,
    model_validator,
)

from beliefloc.semantic_map import observations

_T = TypeVar("_T", int, float)

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
NO_ROOM = FREE
"""In a room layout, a free cell in no room (blocked cells stay ``#``)."""


SubSamples = Annotated[int, Field(strict=True, ge=1, le=7)]
"""Positions per axis a region model averages over a cell (``k × k``)."""
YawSamples = Annotated[int, Field(strict=True, ge=1, le=9)]
"""Yaw offsets a region model averages over a heading's sector."""


def _pick(value: _T | None, real: _T, exact: _T, real_place: bool) -> _T:
    """A region-model field: the file's value, else the value for a real place (``real``, what a 2D
    lidar and an object detector are like) when ``real_place``, else the papers' exact model.

    :func:`beliefloc.semantic_map.compile.compile_model` asks for the exact model by default
    (``real_place=False``) for every map: the planners' signature grouping and EC2's gamma range are
    built on few distinct reading rows, which region rows are not yet (see docs/map-format.md)."""
    if value is not None:
        return value
    return real if real_place else exact


class StrictModel(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True)


def _no_boolean(value: Any) -> Any:
    """YAML's true and false are not the numbers 1 and 0 (a Literal would take them)."""
    if isinstance(value, bool):
        raise ValueError(f"should be a number, got {str(value).lower()}")
    return value


class Grid(StrictModel):
    rows: Integer = Field(ge=1, le=100_000)
    """On a map with ``occupancy:``, rows and cols come from the image (the loader fills them in)."""
    cols: Integer = Field(ge=1, le=100_000)
    cell_size: CellSize = 1.0
    """Side of a cell in meters; ranges and scan bins are in meters too."""
    headings: Annotated[Literal[1, 4, 8], BeforeValidator(_no_boolean)] = 4
    """1: no orientation, compass moves; 4 or 8: a triangle per heading, heading 0 = north and the
    index counting clockwise, as the papers number them (heading h has yaw π/2 − h·2π/headings)."""
    robot_radius: Length | None = None
    """Occupancy maps: a cell is a state only when a disc of this radius on its centre touches no
    occupied or unknown pixel (:mod:`beliefloc.semantic_map.occupancy_grid`). Default 0."""


class Landmark(StrictModel):
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


class ActionSpec(StrictModel):
    cost: Cost = 1.0
    failure: Probability = 0.0
    """Probability that the move fails and the robot stays where it is."""


class _SensorBase(StrictModel):
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
    fov: Annotated[Degrees, Field(gt=0.0, le=360.0)] | None = Field(default=None, alias="fov_deg")
    """Field of view in degrees (``fov_deg``), centred on the heading. Default 90 (360 on maps with
    headings 1). The old key ``fov`` is read as before, with a warning."""
    angle_bins: list[Annotated[Degrees, Field(gt=0.0, le=180.0)]] | None = Field(default=None, alias="angle_bins_deg")
    """Upper edges in degrees (``angle_bins_deg``) of viewing-angle bins, off the axis either way:
    [18, 30, 45] reports 0-18, 18-30 or 30-45. The old key ``angle_bins`` is read as before."""
    occlusion: bool = True
    """Blocked cells between the robot and a landmark hide it."""
    sub_samples: SubSamples | None = None
    """Region model (:mod:`beliefloc.semantic_map.regions`): positions per axis averaged over each
    cell (``k × k``). Default 1 (the cell's centre: the papers'
    exact model); 3 suits a real robot."""
    yaw_samples: YawSamples | None = None
    """Region model: yaw offsets averaged over each heading's sector. Default 1; 3 suits a
    real robot."""
    fov_edge: Annotated[Degrees, Field(ge=0.0, le=90.0)] | None = Field(default=None, alias="fov_edge_deg")
    """Region model (``fov_edge_deg``): degrees over which detection fades at the edge of the field of view (the σ of
    a Gaussian edge). Default 0 (a step); 3 suits a real
    detector."""
    range_edge: Annotated[Length, Field(le=100.0)] | None = None
    """Region model: metres over which detection fades at the range limit (σ). Default 0 (a step); 0.2
    suits a real detector."""

    def region(self, real_place: bool = False) -> tuple[int, int, float, float]:
        """``(sub_samples, yaw_samples, fov_edge, range_edge)`` with the defaults filled in."""
        return (
            _pick(self.sub_samples, 3, 1, real_place),
            _pick(self.yaw_samples, 3, 1, real_place),
            _pick(self.fov_edge, 3.0, 0.0, real_place),
            _pick(self.range_edge, 0.2, 0.0, real_place),
        )

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
                raise ValueError("angle_bins_deg needs at least one edge, e.g. [18, 30, 45]")
            if any(b >= a for a, b in zip(value[1:], value[:-1], strict=False)):
                raise ValueError(f"angle_bins_deg must be strictly increasing, got {value}")
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
    beams: list[Annotated[Degrees, Field(gt=-360.0, lt=360.0)]] = Field(
        default_factory=lambda: [0.0], alias="beams_deg"
    )
    """Directions of the beams in degrees (``beams_deg``), relative to the heading, counter-clockwise
    positive (REP 103), each read independently with the same bins and error: ``[90, 0, -90]`` looks
    left, ahead and right. Multiples of 360/headings. The default ``[0]`` is one beam straight
    ahead. The old key ``beams`` (degrees clockwise) is read as before, with a warning."""

    @field_validator("beams")
    @classmethod
    def _beams(cls, value: list[float]) -> list[float]:
        if not value:
            raise ValueError("a scan needs at least one beam, e.g. [0] (straight ahead)")
        turns = [v % 360.0 for v in value]
        if len(set(turns)) != len(turns):
            raise ValueError(f"beams point the same way twice: {value}")
        return value

    sub_samples: SubSamples | None = None
    """Region model (:mod:`beliefloc.semantic_map.regions`): positions per axis averaged over each
    cell. Default 1 (the papers' exact
    model); 3 suits a real robot."""
    yaw_samples: YawSamples | None = None
    """Region model: yaw offsets averaged over each heading's sector. Default 1; 3 suits a real
    robot."""
    sigma: Annotated[Length, Field(le=10.0)] | None = None
    """Region model: standard deviation of the range error in metres. Default 0; a 2D lidar's few
    centimetres (0.03) suit a real robot."""
    random: Probability | None = None
    """Region model: share of readings that are random (every bin alike; AMCL's ``z_rand``).
    Default 0; 0.05 suits a real lidar."""
    short: Probability | None = None
    """Region model: share of readings cut short by something not on the map, uniform before the
    true range (AMCL's ``z_short``). Default 0; 0.1 suits a real
    lidar among people and furniture."""

    @model_validator(mode="after")
    def _mixture(self) -> ScanSensor:
        if (self.random or 0.0) + (self.short or 0.0) > 1.0:
            raise ValueError(f"random + short must be at most 1, got {self.random} + {self.short}")
        return self

    def region(self, real_place: bool = False) -> tuple[int, int, float, float, float]:
        """``(sub_samples, yaw_samples, sigma, random, short)`` with the defaults filled in."""
        return (
            _pick(self.sub_samples, 3, 1, real_place),
            _pick(self.yaw_samples, 3, 1, real_place),
            _pick(self.sigma, 0.03, 0.0, real_place),
            _pick(self.random, 0.05, 0.0, real_place),
            _pick(self.short, 0.1, 0.0, real_place),
        )

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
TaggedSensor = Annotated[Sensor, Field(discriminator="type")]

RoomName = Annotated[str, Field(pattern=r"^[a-z][a-z0-9_]*$", max_length=64)]
"""A lowercase letter, then lowercase letters, digits and ``_``: the room names of a domain's
knowledge base (clingo constants), so that a domain can reference the map's rooms."""


class RoomRectangle(StrictModel):
    """``{from: [r0, c0], to: [r1, c1]}``: the cells from ``[r0, c0]`` to ``[r1, c1]``, both corners included."""

    from_: tuple[Integer, Integer] = Field(alias="from")
    to: tuple[Integer, Integer]


class Rooms(StrictModel):
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


def as_number(value: Any) -> float | None:
    """``value`` as a finite float, or None when it is not a number (booleans are not numbers)."""
    if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value):
        return float(value)
    return None


def grid_lines(text: str) -> list[str]:
    """Rows of a character grid: blank lines dropped, surrounding spaces stripped."""
    return [line.strip() for line in text.splitlines() if line.strip()]
