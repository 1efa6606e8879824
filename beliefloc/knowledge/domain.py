"""The domain file format: pydantic models of ``domains/*.yaml``, loaded with file:line errors.

A domain says what the robot knows about a home or an office (Zhang, Sridharan & Wyatt 2015,
Sec. III-A): its rooms, the object class hierarchy (a tree), known object instances and the rooms
they are in, defaults with their exceptions, the target class, and what is known about where the
robot itself is (``robot:``). Every field is documented in ``docs/domain-format.md``. Validation
happens here, once; cross-reference checks raise :class:`~beliefloc.errors.FieldError` with the
path of the culprit so the loader names its line.

A domain may reference a semantic map (``map: ../maps/apartment.yaml``, relative to the domain
file): :func:`load_domain` then loads the map and checks that the domain's rooms are the map's
rooms, and the ``search:`` section takes its geometry from the map (:class:`MapSearch`).
"""

from __future__ import annotations

import bisect
import heapq
import os
import re
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal, overload

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    PrivateAttr,
    ValidationError,
    ValidationInfo,
    ValidatorFunctionWrapHandler,
    field_validator,
    model_validator,
)

from beliefloc.errors import DomainError, FieldError, InvalidValueError, KnowledgeBaseError, MapError
from beliefloc.knowledge.robot import DEFAULT_WEIGHT, ROBOT
from beliefloc.knowledge.scene_model import SceneSection
from beliefloc.source import Source, format_path, read_source, refuse_field_name, validate_source
from beliefloc.source.file_kinds import DOMAIN, kind_of_data, not_a

if TYPE_CHECKING:
    from beliefloc.semantic_map import SemanticMap

AspName = Annotated[str, Field(pattern=r"^[a-z][a-z0-9_]*$", max_length=64)]
"""Rooms, classes, objects and defaults become clingo constants: a lowercase letter, then
lowercase letters, digits and ``_`` (the paper's ``computer-access`` is written ``computer_access``)."""
ASP_NAME = re.compile(r"[a-z][a-z0-9_]{0,63}")
""":data:`AspName` as a regular expression (``fullmatch``), for names given on the command line."""

# Numbers are strict: ``true`` is not 1 and ``1.5`` is no count (a strict float still takes an int);
# NaN and infinity are refused everywhere, and every number has a range.
Flag = Annotated[bool, Field(strict=True)]
Count = Annotated[int, Field(strict=True)]
Probability = Annotated[float, Field(strict=True, allow_inf_nan=False)]
MAX_COST = 1e6
"""The largest cost, time limit or Beta parameter a domain may give (docs/map-format.md's bound on costs)."""
Amount = Annotated[float, Field(strict=True, allow_inf_nan=False, le=MAX_COST)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True)


def aliased_fields(model: type[BaseModel]) -> list[str]:
    """The Python names of ``model``'s fields that files write by another name (their alias)."""
    return [name for name, info in model.model_fields.items() if info.alias is not None and info.alias != name]


class Room(_Strict):
    accessible: Flag = True
    """The basic fluent ``accessible(R)`` at step 1 (``-holds(accessible(R), 1)`` when false)."""


class ObjectInstance(_Strict):
    class_: AspName = Field(alias="class")
    """The object's primary class (``is(O, C)``): a class of the hierarchy."""
    room: AspName | None = None
    """The room it is known to be in at step 1; omitted: unknown (a default may place it)."""
    on: AspName | None = None
    """Another object it stands on (``holds(on(O, P), 1)``); it is then in that object's room."""


class Default(_Strict):
    """``class`` objects are typically in ``room``, with the paper's three kinds of exceptions."""

    class_: AspName = Field(alias="class")
    room: AspName
    weak_exceptions: list[AspName] = Field(default_factory=list)
    """Classes whose instances are abnormal: the default says nothing about them."""
    possible_exceptions: list[AspName] = Field(default_factory=list)
    """Classes an instance is abnormal for unless it is known not to belong to them (the paper's
    second weak form, ``ab(d(X)) <- not -cookbook(X), book(X)``)."""
    strong_exceptions: list[AspName] = Field(default_factory=list)
    """Classes whose instances are known NOT to be in ``room`` (the paper's strong exception)."""


MAX_PLACE = 1_000_000
"""The largest row or column of a cell on a plane of rooms."""
Pair = tuple[Annotated[Count, Field(ge=0, le=MAX_PLACE)], Annotated[Count, Field(ge=0, le=MAX_PLACE)]]
"""``[row, col]`` on the plane, in cells."""
Size = tuple[Annotated[Count, Field(ge=1, le=1000)], Annotated[Count, Field(ge=1, le=1000)]]
"""``[rows, cols]`` of a room, in cells."""


class RobotStart(_Strict):
    room: AspName
    cell: Pair
    """``[row, col]`` inside the room, from its top-left cell ``[0, 0]``."""


class DetectorSettings(_Strict):
    """The detector analysing one view: ``p(present | target in view)`` and ``p(present | not)``."""

    true_positive: Annotated[Probability, Field(gt=0, le=1)] = 0.9
    false_positive: Annotated[Probability, Field(ge=0, lt=1)] = 0.1
    """p(FP); the true-negative rate p(TN) is 1 - p(FP)."""
    view: Annotated[Count, Field(ge=1, le=99)] = 3
    """The side of the square of cells a view covers, centred on the robot's cell (odd): a camera does
    not see through walls -- on a plane of rooms the square is clipped to the robot's room, on a map
    a cell behind a blocked cell is not seen."""


class Costs(_Strict):
    travel: Annotated[Amount, Field(ge=0)] = 0.5
    """Time units per cell of distance between view points: straight-line on a plane of rooms, the
    shortest path through free cells on a map (a diagonal step counts sqrt 2)."""
    analysis: Annotated[Amount, Field(gt=0)] = 1.0
    """Time units to analyse one view."""


class Existence(_Strict):
    """The Beta(alpha', beta') prior of the target existing in the domain (Eq. 8)."""

    alpha: Annotated[Amount, Field(gt=0)] = 6.0
    beta: Annotated[Amount, Field(gt=0)] = 2.0


class SearchSettings(_Strict):
    """What every ``search:`` section has: the sensor, the costs, the limits of a search."""

    sensor: DetectorSettings = Field(default_factory=DetectorSettings)
    costs: Costs = Field(default_factory=Costs)
    time_limit: Annotated[Amount, Field(gt=0)] = 100.0
    existence: Existence = Field(default_factory=Existence)
    tau_found: Annotated[Probability, Field(gt=0, lt=1)] = 0.8
    """tau+: stop with Found when one cell's belief exceeds it."""
    tau_absent: Annotated[Probability, Field(gt=0, lt=1)] = 0.7
    """tau-: stop with NotFound when p(not E) exceeds it."""


class PlaneSearch(SearchSettings):
    """The ``search:`` section of a domain without a map: rooms as grids of cells placed on a plane,
    where the robot starts, and its sensor."""

    room_size: Size = (5, 5)
    """``[rows, cols]`` of every room not listed in ``room_sizes``."""
    room_sizes: dict[AspName, Size] = Field(default_factory=dict)
    placement: dict[AspName, Pair]
    """Every room's top-left cell on the plane; travel cost grows with the distance on this plane."""
    robot_start: RobotStart

    @field_validator("robot_start", mode="before")
    @classmethod
    def _start_in_a_room(cls, value: Any) -> Any:
        if isinstance(value, list):
            raise ValueError("write {room: R, cell: [row, col]}; a cell [row, col] of a map needs map: in the domain")
        return value

    def size_of(self, room: str) -> tuple[int, int]:
        return self.room_sizes.get(room, self.room_size)


PLANE_ONLY = ("room_size", "room_sizes", "placement")
"""Keys of a plane ``search:`` that a domain with ``map:`` must not have: the map gives the cells."""


class MapSearch(SearchSettings):
    """The ``search:`` section of a domain that references a map: the rooms' cells, the walls and
    the distances come from the map, so there is no placement or room size; the robot starts on a
    free cell of the map."""

    model_config = ConfigDict(extra="allow", frozen=True, populate_by_name=True)
    robot_start: Pair
    """``[row, col]``: a free cell of one of the map's rooms."""

    @field_validator("robot_start", mode="before")
    @classmethod
    def _start_on_the_map(cls, value: Any) -> Any:
        if isinstance(value, dict):
            raise ValueError("with map:, the robot starts on a free cell of the map: write [row, col]")
        return value


class RobotKnowledge(_Strict):
    """What the knowledge base is told about where the robot is (``kb/robot.lp``)."""

    dock: AspName | None = None
    """The room of the robot's dock: the default "the robot is usually at its dock" (step 1)."""
    last_seen: AspName | None = None
    """Where the robot was last seen: ``holds(in(robot, R), 1)``, which beats the default."""
    carried: Flag = False
    """The robot was carried off its dock: a weak exception, the dock default says nothing."""
    weight: Annotated[Probability, Field(gt=0.0, le=1.0)] = DEFAULT_WEIGHT
    """w: the share of the start belief on the rooms the knowledge base puts the robot in."""


class Domain(_Strict):
    """A validated domain: every cross-reference checked, the class hierarchy a tree."""

    name: Annotated[str, Field(min_length=1, max_length=128)]
    description: str = ""
    rooms: dict[AspName, Room]
    classes: dict[AspName, AspName | None]
    """Class -> parent class; the one root has no parent (``object:`` with nothing after it)."""
    objects: dict[AspName, ObjectInstance] = Field(default_factory=dict)
    defaults: dict[AspName, Default] = Field(default_factory=dict)
    target: AspName | None = None
    """The class searched for when none is named (see :meth:`resolve_target`)."""
    steps: Count = Field(default=2, ge=1, le=100)
    """Time steps 1..steps: step 1 is the initial knowledge; observations go to the last step."""
    kb: list[str] = Field(default_factory=list)
    """Extra ``.lp`` files of this domain, relative to the domain file."""
    map: str | None = None
    """A semantic map (``maps/*.yaml``), relative to the domain file, whose rooms are the domain's."""
    robot: RobotKnowledge | None = None
    """Where the robot probably is: the facts of its room prior and start belief
    (:mod:`beliefloc.knowledge.robot_start`)."""
    search: PlaneSearch | None = None
    """The geometry for object search (``beliefloc search``) on a plane of rooms; knowledge-only
    domains leave it out. Always None when the domain references a map: see :attr:`map_search`."""
    map_search: MapSearch | None = Field(default=None, alias="search")
    """The ``search:`` section of a domain with ``map:``: the geometry comes from the map."""

    scene: SceneSection | None = None
    """The scene model of object search: visual operators, what each class looks like, ROIs per view.
    Without one, the fixed detector of the search section analyses a view."""

    _path: Path | None = PrivateAttr(default=None)
    _map: SemanticMap | None = PrivateAttr(default=None)
    _allow_outside: bool = PrivateAttr(default=False)

    # ``search:`` is read as one of two models, chosen by whether the domain has ``map:`` (declared
    # above, so validated first); both fields are named ``search`` in the file and in messages.
    @field_validator("search", mode="wrap")
    @classmethod
    def _plane_search(cls, value: Any, handler: ValidatorFunctionWrapHandler, info: ValidationInfo) -> Any:
        return None if info.data.get("map") is not None else handler(value)

    @field_validator("map_search", mode="wrap")
    @classmethod
    def _map_search(cls, value: Any, handler: ValidatorFunctionWrapHandler, info: ValidationInfo) -> Any:
        return handler(value) if info.data.get("map") is not None else None

    @model_validator(mode="before")
    @classmethod
    def _no_internal_names(cls, data: Any) -> Any:
        """The Python names of fields that files write by another name -- ``map_search`` (files
        write ``search:``), ``class_`` of an object or a default -- refused where they are written.
        Here, for the whole file: a nested model's own check would lose the path (and code may
        still build an :class:`ObjectInstance` by its Python names)."""
        if not isinstance(data, dict):
            return data
        for name in aliased_fields(cls):
            refuse_field_name(cls, data, name)
        for section, model in (("objects", ObjectInstance), ("defaults", Default)):
            entries = data.get(section)
            for key, value in entries.items() if isinstance(entries, dict) else ():
                for name in aliased_fields(model):
                    try:
                        refuse_field_name(model, value, name)
                    except FieldError as exc:
                        raise FieldError((section, key, *exc.path), exc.message) from None
        return data

    @field_validator("rooms", mode="before")
    @classmethod
    def _rooms(cls, value: Any) -> Any:
        # ``bedroom:`` with nothing after it is a room with the default settings
        if isinstance(value, dict):
            return {k: ({} if v is None else v) for k, v in value.items()}
        if isinstance(value, list):
            for index, name in enumerate(value):
                if not isinstance(name, str):
                    raise FieldError(("rooms", index), f"a room is a name, got {_kind_of(name)}")
                if name in value[:index]:
                    raise FieldError(("rooms", index), f"room {name!r} is listed twice")
            return {k: {} for k in value}
        return value

    @field_validator("kb", mode="before")
    @classmethod
    def _kb_names(cls, value: Any) -> Any:
        for index, name in enumerate(value if isinstance(value, list) else []):
            if isinstance(name, str) and (not name.strip() or "\0" in name):
                raise FieldError(("kb", index), "not a usable file name")
        return value

    @model_validator(mode="after")
    def _check_references(self) -> Domain:
        if not self.rooms:
            raise FieldError(("rooms",), "a domain needs at least one room")
        self._check_reserved()
        if not self.classes:
            raise FieldError(("classes",), "a domain needs a class hierarchy (class: parent)")
        clash = sorted(set(self.rooms) & set(self.classes))
        if clash:
            raise FieldError(("classes", clash[0]), f"{clash[0]!r} is both a room and a class")
        for child, parent in self.classes.items():
            if parent is not None and parent not in self.classes:
                raise FieldError(("classes", child), f"unknown parent class {parent!r}{_hint(parent, self.classes)}")
        self._raise_cycle()
        roots = [c for c, p in self.classes.items() if p is None]
        if len(roots) > 1:  # none at all is impossible without a cycle
            raise FieldError(
                ("classes", roots[1]), f"several root classes ({', '.join(roots)}); the hierarchy must be one tree"
            )
        names = set(self.rooms) | set(self.classes)
        for name, obj in self.objects.items():
            if name in names:
                raise FieldError(("objects", name), f"{name!r} is already a room or a class")
            if obj.class_ not in self.classes:
                raise FieldError(
                    ("objects", name, "class"), f"unknown class {obj.class_!r}{_hint(obj.class_, self.classes)}"
                )
            if obj.room is not None and obj.room not in self.rooms:
                raise FieldError(("objects", name, "room"), f"unknown room {obj.room!r}{_hint(obj.room, self.rooms)}")
            if obj.on is not None:
                if obj.on not in self.objects:
                    raise FieldError(("objects", name, "on"), f"unknown object {obj.on!r}")
                if obj.on == name:
                    raise FieldError(("objects", name, "on"), "an object cannot be on itself")
        for name, default in self.defaults.items():
            if default.class_ not in self.classes:
                raise FieldError(
                    ("defaults", name, "class"),
                    f"unknown class {default.class_!r}{_hint(default.class_, self.classes)}",
                )
            if default.room not in self.rooms:
                raise FieldError(
                    ("defaults", name, "room"), f"unknown room {default.room!r}{_hint(default.room, self.rooms)}"
                )
            for key in ("weak_exceptions", "possible_exceptions", "strong_exceptions"):
                for index, cls in enumerate(getattr(default, key)):
                    if cls not in self.classes:
                        raise FieldError(
                            ("defaults", name, key, index), f"unknown class {cls!r}{_hint(cls, self.classes)}"
                        )
        if self.target is not None and self.target not in self.classes:
            raise FieldError(("target",), f"unknown target class {self.target!r}{_hint(self.target, self.classes)}")
        if self.scene is not None:
            needed: dict[str, tuple[str | int, ...]] = {}
            if self.target is not None:
                needed[self.target] = ("target",)
            for name, obj in self.objects.items():
                needed.setdefault(obj.class_, ("objects", name, "class"))
            self.scene.check(self.classes, needed)
        if self.search is not None:
            self._check_search(self.search)
        if self.map_search is not None:
            self._check_map_search(self.map_search)
        if self.robot is not None:
            for key in ("dock", "last_seen"):
                room = getattr(self.robot, key)
                if room is not None and room not in self.rooms:
                    raise FieldError(("robot", key), f"unknown room {room!r}{_hint(room, self.rooms)}")
        return self

    def _check_reserved(self) -> None:
        for key in ("rooms", "classes", "objects"):
            if ROBOT in getattr(self, key):
                raise FieldError(
                    (key, ROBOT),
                    f"{ROBOT!r} is the robot itself (kb/robot.lp, the domain's robot: section); give this another name",
                )

    def _check_map_search(self, search: MapSearch) -> None:
        for key in search.model_extra or {}:
            if key in PLANE_ONLY:
                raise FieldError(
                    ("search", key),
                    f"a domain with map: takes every room's cells from the map; drop {key}",
                )
            expected = ", ".join(sorted(MapSearch.model_fields))
            raise FieldError(("search", key), f"unknown key {key!r}; expected one of: {expected}")
        _check_sensor(search.sensor)

    def _check_search(self, search: PlaneSearch) -> None:
        for key in ("placement", "room_sizes"):
            for room in getattr(search, key):
                if room not in self.rooms:
                    raise FieldError(("search", key, room), f"unknown room {room!r}{_hint(room, self.rooms)}")
        missing = [room for room in self.rooms if room not in search.placement]
        if missing:
            raise FieldError(
                ("search", "placement"), f"every room needs a place on the plane; missing: {', '.join(missing)}"
            )
        overlap = _overlapping({room: (*search.placement[room], *search.size_of(room)) for room in self.rooms})
        if overlap is not None:
            first, second = overlap
            raise FieldError(("search", "placement", first), f"room {first!r} overlaps room {second!r}")
        _check_sensor(search.sensor)
        start = search.robot_start
        if start.room not in self.rooms:
            raise FieldError(
                ("search", "robot_start", "room"), f"unknown room {start.room!r}{_hint(start.room, self.rooms)}"
            )
        rows, cols = search.size_of(start.room)
        if not (start.cell[0] < rows and start.cell[1] < cols):
            raise FieldError(
                ("search", "robot_start", "cell"),
                f"cell {list(start.cell)} is outside room {start.room!r} ({rows} x {cols} cells)",
            )

    def _raise_cycle(self) -> None:
        """A cycle of the hierarchy, named from the first class that leads into it; linear: a class
        whose way up was walked once is not walked again."""
        done: set[str] = set()
        for start in self.classes:
            path: dict[str, int] = {}
            current: str | None = start
            while current is not None and current not in done:
                if current in path:
                    cycle = [*list(path)[path[current] :], current]
                    raise FieldError(("classes", start), f"cycle in the class hierarchy: {' -> '.join(cycle)}")
                path[current] = len(path)
                current = self.classes.get(current)
            done.update(path)

    @property
    def path(self) -> Path | None:
        """The file the domain was read from (None when built in code)."""
        return self._path

    @property
    def folder(self) -> Path:
        """The folder of the domain file (the working folder when built in code): its ``kb:`` files
        and their ``#include`` must be in this folder's tree unless :attr:`allow_outside`."""
        return self._path.parent if self._path is not None else Path.cwd()

    @property
    def allow_outside(self) -> bool:
        """Whether the knowledge base may read files outside :attr:`folder`'s tree (``--allow-outside``)."""
        return self._allow_outside

    @property
    def map_file(self) -> Path | None:
        """The referenced map, resolved relative to the domain file (None without ``map:``)."""
        if self.map is None:
            return None
        base = self._path.parent if self._path is not None else Path.cwd()
        return Path(os.path.normpath(base / self.map))

    @property
    def search_settings(self) -> SearchSettings | None:
        """The sensor, costs and limits of the ``search:`` section, of either kind (None without one)."""
        return self.search if self.search is not None else self.map_search

    @property
    def semantic_map(self) -> SemanticMap | None:
        """The referenced map, loaded and checked against the domain by :func:`load_domain`."""
        return self._map

    def kb_files(self) -> list[Path]:
        """The domain's own ``.lp`` files, resolved relative to the domain file."""
        return [self.folder / name for name in self.kb]

    @overload
    def resolve_target(self, target: str | None, *, allow_any: Literal[False] = False) -> str: ...
    @overload
    def resolve_target(self, target: str | None, *, allow_any: bool) -> str | None: ...
    def resolve_target(self, target: str | None, *, allow_any: bool = False) -> str | None:
        """The class searched for: ``target``, else the domain's :attr:`target`; a class of the domain.

        With ``allow_any``, ``"any"`` or no target at all is None (a random object per trial).
        Raises :class:`InvalidValueError` for an unknown class (the message lists the classes; the
        caller names the value it was given), or when neither names one.
        """
        chosen = target or self.target
        if allow_any and chosen in (None, "any"):
            return None
        classes = ", ".join(sorted(self.classes))
        if chosen is None:
            where = f"{self._path}: " if self._path is not None else ""
            raise InvalidValueError(
                f"{where}no target class given and the domain names none; expected one of: {classes}"
            )
        if chosen not in self.classes:
            raise InvalidValueError(f"unknown class; expected one of: {classes}")
        return chosen


def _check_sensor(sensor: DetectorSettings) -> None:
    if sensor.view % 2 == 0:
        raise FieldError(
            ("search", "sensor", "view"),
            f"a view is a square centred on the robot: its side must be odd, got {sensor.view}",
        )
    if sensor.true_positive <= sensor.false_positive:
        raise FieldError(
            ("search", "sensor", "true_positive"),
            f"a detection must be likelier with the target in view: true_positive {sensor.true_positive} "
            f"<= false_positive {sensor.false_positive}",
        )


def room_mismatch(domain_rooms: Any, map_rooms: Any) -> tuple[list[str], list[str]]:
    """(rooms of the domain that the map lacks, rooms of the map that the domain lacks), in order."""
    extra = [room for room in domain_rooms if room not in map_rooms]
    missing = [room for room in map_rooms if room not in domain_rooms]
    return extra, missing


def check_against_map(domain: Domain, smap: SemanticMap, label: str) -> None:
    """The domain's rooms are the map's rooms; ``search.robot_start`` is a free cell of the map.

    Raises :class:`FieldError` naming the rooms that differ; ``label`` names the map in messages.
    """
    if not smap.rooms:
        raise FieldError(
            ("map",), f"{label} has no rooms: give it a rooms: section (docs/map-format.md) for the domain to use"
        )
    extra, missing = room_mismatch(domain.rooms, smap.rooms)
    if extra or missing:
        parts = []
        if extra:
            parts.append(f"not rooms of the map: {', '.join(extra)}")
        if missing:
            parts.append(f"rooms of the map missing here: {', '.join(missing)}")
        path: tuple[str, ...] = ("rooms", extra[0]) if extra else ("rooms",)
        raise FieldError(path, f"the rooms must be those of {label} ({', '.join(smap.rooms)}); " + "; ".join(parts))
    search = domain.map_search
    if search is not None:
        r, c = search.robot_start
        g = smap.grid
        if not (r < g.rows and c < g.cols):
            raise FieldError(
                ("search", "robot_start"), f"cell [{r}, {c}] is outside the {g.rows}x{g.cols} grid of {label}"
            )
        if not smap.free[r, c]:
            raise FieldError(("search", "robot_start"), f"cell [{r}, {c}] is blocked on {label}")
        if not any(mask[r, c] for mask in smap.rooms.values()):
            raise FieldError(
                ("search", "robot_start"),
                f"cell [{r}, {c}] is in no room of {label}: the robot starts on a cell of a room, where it can "
                "analyse a view (cells in no room are only travelled through)",
            )


def _overlapping(boxes: dict[str, tuple[int, int, int, int]]) -> tuple[str, str] | None:
    """Two rooms whose boxes (row, col, rows, cols) overlap, the one listed later first; None when
    none do. A sweep over the rows: the boxes that span the current row cannot overlap each other,
    so their column ranges are disjoint and sorted, and a new box is checked against one neighbour
    (n log n, where every pair would be n²)."""
    order = {room: index for index, room in enumerate(boxes)}
    spans: list[tuple[int, int, str]] = []  # (first column, end column, room) of the active boxes, sorted
    ending: list[tuple[int, int, int, str]] = []  # (end row, first column, end column, room)
    for room in sorted(boxes, key=lambda r: (boxes[r][0], order[r])):
        row, col, rows, cols = boxes[room]
        while ending and ending[0][0] <= row:
            _, c, e, gone = heapq.heappop(ending)
            spans.pop(bisect.bisect_left(spans, (c, e, gone)))
        at = bisect.bisect_left(spans, (col + cols,))  # the spans starting before this box ends
        if at > 0 and spans[at - 1][1] > col:
            other = spans[at - 1][2]
            return (room, other) if order[room] > order[other] else (other, room)
        bisect.insort(spans, (col, col + cols, room))
        heapq.heappush(ending, (row + rows, col, col + cols, room))
    return None


def check_kb_name(name: str, folder: Path, owner: str, *, allow_outside: bool) -> str | None:
    """Why the ``kb:`` file ``name`` of a domain in ``folder`` cannot be used (None: it can): outside
    the folder's tree (unless ``allow_outside``), missing, a folder or a special file."""
    from beliefloc.knowledge.files import check_file, check_place

    problem = check_place(name, folder, folder, owner, allow_outside=allow_outside)
    if problem is not None:
        return f"{name} {problem}"
    try:
        check_file(folder / name, name)
    except KnowledgeBaseError as exc:
        return str(exc)
    return None


def _kind_of(value: Any) -> str:
    """What a value written where a name belongs is, for messages."""
    if isinstance(value, bool):
        return f"{str(value).lower()} (a boolean)"
    if isinstance(value, dict):
        return "a mapping"
    if isinstance(value, list):
        return "a list"
    return repr(value)


def _hint(name: str, known: Any) -> str:
    options = sorted(known)
    shown = ", ".join(options[:12]) + (", ..." if len(options) > 12 else "")
    return f"; expected one of: {shown}"


def load_domain(path: str | Path, *, allow_outside: bool = False) -> Domain:
    """Read and validate a domain file; raises :class:`DomainError` naming file, line and field.

    The ``kb:`` files must be in the domain file's folder tree (``../../etc/passwd`` and absolute
    paths are refused) unless ``allow_outside`` (the command line's ``--allow-outside``); a
    missing file, a folder or a special file (a FIFO, ``/dev/zero``) is refused here, naming its line.
    """
    source = read_source(path, DomainError)
    kind = kind_of_data(source.data)
    if kind is not None and kind != DOMAIN:
        raise DomainError(
            f"{not_a(source.path, kind, DOMAIN)} (a domain has rooms:, classes:, objects:, ...: docs/domain-format.md)"
        )
    if not isinstance(source.data, dict):
        raise DomainError(f"{source.path}:1:1: a domain file is a YAML mapping (name:, rooms:, classes:, ...)")
    domain = validate_source(source, Domain, DomainError)
    domain._path = Path(path)
    domain._allow_outside = allow_outside
    _check_kb(domain, source)
    _attach_map(domain, source)
    return domain


def domain_from_data(data: dict[str, Any], path: Path | None = None, *, allow_outside: bool = False) -> Domain:
    """A domain from plain data (tests, generated domains); errors without line numbers.

    ``path`` is where the domain would live: a ``map:`` and the ``kb:`` files are resolved relative to it."""
    try:
        domain = Domain.model_validate(data)
    except FieldError as exc:
        raise DomainError(f"{format_path(exc.path)}: {exc.message}") from None
    except ValidationError as exc:
        problems = [f"{format_path(tuple(e['loc']))}: {e['msg']}" for e in exc.errors()]
        raise DomainError("\n".join(problems[:6])) from None
    except ValueError as exc:
        raise DomainError(str(exc)) from None
    domain._path = path
    domain._allow_outside = allow_outside
    _check_kb(domain, None)
    _attach_map(domain, None)
    return domain


def _check_kb(domain: Domain, source: Source | None) -> None:
    """Every ``kb:`` file is a regular file in the domain's folder tree (:func:`check_kb_name`)."""
    owner = f"the domain file {domain.path}" if domain.path is not None else "the working folder"
    for index, name in enumerate(domain.kb):
        problem = check_kb_name(name, domain.folder, owner, allow_outside=domain.allow_outside)
        if problem is not None:
            where: tuple[str | int, ...] = ("kb", index)
            if source is None:
                raise DomainError(f"kb[{index}]: {problem}")
            raise DomainError(source.format(where, problem))


def _attach_map(domain: Domain, source: Source | None) -> None:
    """Load the referenced map (if any) and check the domain against it."""
    map_file = domain.map_file
    if map_file is None:
        return
    from beliefloc.semantic_map import load_map

    def fail(path: tuple[str | int, ...], message: str) -> DomainError:
        if source is None:
            return DomainError(f"{'.'.join(str(p) for p in path)}: {message}")
        return DomainError(source.format(path, message))

    try:
        smap = load_map(map_file)
    except MapError as exc:
        raise fail(("map",), f"cannot use the map: {exc}") from None
    try:
        check_against_map(domain, smap, str(map_file))
    except FieldError as exc:
        raise fail(exc.path, exc.message) from None
    domain._map = smap
