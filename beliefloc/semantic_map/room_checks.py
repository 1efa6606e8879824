"""The checks of a map's ``rooms:`` section: one way of drawing rooms, every room non-empty, on free
cells, no two rooms overlapping; each error names the field where it was written."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from beliefloc.errors import FieldError
from beliefloc.semantic_map.occupancy_section import map_extent, too_much_geometry
from beliefloc.semantic_map.sections import BLOCKED, FREE, NO_ROOM, Grid, RoomRectangle, Rooms, grid_lines
from beliefloc.source.limits import GEOMETRY_TESTS, POLYGON_CORNERS

if TYPE_CHECKING:
    from beliefloc.semantic_map.occupancy_map import OccupancyMap


class RoomsOfAMap(Protocol):
    """What the room checks read of a :class:`~beliefloc.semantic_map.schema.SemanticMap` (which
    calls them from its validator, so they cannot import it)."""

    @property
    def room_spec(self) -> Rooms | None: ...
    @property
    def grid(self) -> Grid: ...
    @property
    def free(self) -> np.ndarray: ...
    @property
    def rooms(self) -> dict[str, np.ndarray]: ...
    @property
    def occupancy_map(self) -> OccupancyMap | None: ...
    @property
    def region_mask(self) -> np.ndarray | None: ...


def check_rooms(smap: RoomsOfAMap) -> None:
    spec = smap.room_spec
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
        _check_room_rectangles(smap, spec.rectangles)
    elif region:
        _check_room_mask(smap)
    elif spec.polygons is not None:
        _check_room_polygons(smap, spec.polygons)
    elif not letters:
        raise FieldError(("rooms",), "give layout with a legend (a letter per cell), rectangles, mask or polygons")
    elif spec.layout is None or spec.legend is None:
        missing = "legend" if spec.legend is None else "layout"
        example = "{K: kitchen}" if missing == "legend" else "a letter per cell, like the map's layout"
        raise FieldError(("rooms",), f"a room layout needs a {missing} ({example}); or give rectangles")
    else:
        _check_room_layout(smap, spec.layout, spec.legend)


def _check_room_mask(smap: RoomsOfAMap) -> None:
    spec = smap.room_spec
    assert spec is not None
    if spec.mask is None or spec.labels is None:
        missing = "mask (a region map YAML beside this file)" if spec.mask is None else "labels ({1: aisle_a})"
        raise FieldError(("rooms",), f"a region mask needs both mask and labels; {missing} is missing")
    if smap.occupancy_map is None:
        raise FieldError(("rooms", "mask"), "a region mask belongs to a map with occupancy:; use rectangles")
    if smap.region_mask is None:
        raise FieldError(("rooms", "mask"), "the region mask was not read: load the map file with load_map")
    names: dict[str, int] = {}
    for value, name in spec.labels.items():
        if name in names:
            raise FieldError(("rooms", "labels", value), f"room {name!r} already has the value {names[name]}")
        names[name] = value
    for name, mask in smap.rooms.items():
        if not mask.any():
            value = names[name]
            raise FieldError(
                ("rooms", "labels", value),
                f"no cell of the map has its centre on a pixel of value {value} in {spec.mask}: room {name!r} "
                "would be empty (the mask's values are what Nav2 publishes for it: its YAML must say mode: raw "
                "for a pixel painted grey k to be value k)",
            )


def check_corner_count(data: Any) -> None:
    """The corners of a map's room polygons (``rooms: {polygons: {name: [[x, y], ...]}}``) as
    written, counted before any is validated or laid over the cells: refused past
    :data:`~beliefloc.source.limits.POLYGON_CORNERS` at the room whose corners cross it."""
    rooms = data.get("rooms") if isinstance(data, dict) else None
    polygons = rooms.get("polygons") if isinstance(rooms, dict) else None
    if not isinstance(polygons, dict):
        return
    limit, total = POLYGON_CORNERS.value, 0
    for name, vertices in polygons.items():
        total += len(vertices) if isinstance(vertices, list) else 0
        if total > limit:
            raise FieldError(
                ("rooms", "polygons", name),
                f"the room polygons have {total:,} corners up to room {str(name)[:40]!r}, more than the limit "
                f"of {limit:,} {POLYGON_CORNERS.what} in one map; if the input is what you meant, raise it with "
                f"the environment variable {POLYGON_CORNERS.variable}=N",
            )


def _check_room_polygons(smap: RoomsOfAMap, polygons: dict[str, list[tuple[float, float]]]) -> None:
    if not polygons:
        raise FieldError(("rooms", "polygons"), "no rooms; e.g. dock: [[0, 0], [4, 0], [4, 3], [0, 3]]")
    corners = sum(len(vertices) for vertices in polygons.values())
    cells = smap.grid.rows * smap.grid.cols
    if corners * cells > GEOMETRY_TESTS.value:
        raise FieldError(
            ("rooms", "polygons"),
            too_much_geometry(corners * cells, f"{corners:,} corners, each tested against {cells:,} cells"),
        )
    for name, vertices in polygons.items():
        if len(vertices) < 3:
            raise FieldError(("rooms", "polygons", name), f"room {name!r} needs at least three corners [x, y]")
        if not all(math.isfinite(v) for corner in vertices for v in corner):
            raise FieldError(("rooms", "polygons", name), f"room {name!r} has a corner that is not a number")
    owner = np.full(smap.free.shape, "", dtype=object)
    for name, mask in smap.rooms.items():
        if not mask.any():
            occupancy = smap.occupancy_map
            where = f" (the map {occupancy.yaml_path.name} covers {map_extent(occupancy)})" if occupancy else ""
            raise FieldError(("rooms", "polygons", name), f"no free cell has its centre inside room {name!r}{where}")
        taken = np.argwhere(mask & (owner != ""))
        if len(taken):
            r, c = (int(v) for v in taken[0])
            raise FieldError(
                ("rooms", "polygons", name), f"room {name!r} overlaps room {owner[r, c]!r} at cell [{r}, {c}]"
            )
        owner[mask] = name


def _check_room_rectangles(smap: RoomsOfAMap, rooms: dict[str, RoomRectangle | list[RoomRectangle]]) -> None:
    g = smap.grid
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
            blocked = np.argwhere(~smap.free[r0 : r1 + 1, c0 : c1 + 1])
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


def _check_room_layout(smap: RoomsOfAMap, layout: str, legend: dict[str, str]) -> None:
    g = smap.grid
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
    lines = grid_lines(layout)
    path = ("rooms", "layout")
    if len(lines) != g.rows:
        raise FieldError(path, f"has {len(lines)} rows, but grid.rows is {g.rows}")
    used: set[str] = set()
    for r, line in enumerate(lines):
        if len(line) != g.cols:
            raise FieldError(path, f"row {r} has {len(line)} cells, but grid.cols is {g.cols}", row=r)
        for c, ch in enumerate(line):
            free = bool(smap.free[r, c])
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
