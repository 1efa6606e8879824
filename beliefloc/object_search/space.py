"""The robot's model of object search: the search space (Zhang, Sridharan & Wyatt 2015, Sec. III-B).

Pure numpy/scipy, no randomness. :class:`SearchSpace` holds what the robot knows of the place it
searches: cells (each room a grid placed on a plane), the room of each cell, view points and the
field of view of each, travel distances between view points, which rooms the robot can enter. The
simulated world that answers its views is :mod:`beliefloc.object_search.world`; building the space
of a domain, on its plane of rooms or on its map, is :func:`beliefloc.object_search.domain_space.search_space`.

Cells are numbered room by room (in the domain's room order), row-major inside a room. There is
one view point per cell: the robot stands on the cell and analyses the square of ``view x view``
cells centred on it, clipped to its room (a camera does not see through walls). ``views`` is a
sparse CSR matrix, ``views[v, i] = 1`` when view ``v`` covers cell ``i`` (axes: view, cell), and
view ``v`` stands on cell ``v``: at 10^4 cells a dense matrix would hold 10^8 entries for about
9 x 10^4 that are set.

A domain that references a map (``map:``) gets a :class:`~beliefloc.object_search.map_space.MapSearchSpace`
instead: the cells of the map's rooms, shortest paths round walls, views that walls cut short
(:mod:`beliefloc.object_search.map_space`); everything downstream sees a :class:`SearchSpace`.

A room marked ``accessible: false`` keeps its cells (the room prior and the drawings still have
them) but the robot cannot stand there: its view points cover nothing and are never chosen
(:attr:`SearchSpace.reachable`), and no view from another room sees into it.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

from beliefloc.errors import DomainError, InvalidValueError
from beliefloc.knowledge.domain import Domain, PlaneSearch
from beliefloc.object_search.posterior import Detector

if TYPE_CHECKING:
    from beliefloc.object_search.scene import SceneRates


def cell_numbers(row_text: str, col_text: str) -> tuple[int, int] | None:
    """The row and column of a cell written ``ROW,COL``, or None unless both are 1 to 18 ASCII digits
    (``str.isdigit`` and ``int`` would also read ``١,١`` or ``²,³`` as a cell)."""
    row, col = row_text.strip(), col_text.strip()
    if not all(0 < len(t) <= 18 and t.isascii() and t.isdigit() for t in (row, col)):
        return None
    return int(row), int(col)


@dataclass(frozen=True, eq=False)
class SearchSpace:
    """Cells, rooms, views and distances of a domain's ``search:`` section."""

    rooms: tuple[str, ...]
    room_of_cell: np.ndarray
    """``room_of_cell[i]``: index into ``rooms`` (int, shape (cells,))."""
    local: np.ndarray
    """``local[i] = (row, col)`` of cell i inside its room (int, shape (cells, 2))."""
    plane: np.ndarray
    """``plane[i] = (row, col)`` of cell i on the plane (float, shape (cells, 2))."""
    views: sp.csr_matrix
    """``views[v, i] = 1.0``: view v covers cell i (sparse CSR float, shape (views, cells))."""
    start: int
    """The cell (= view point) the robot starts on."""
    detector: Detector
    travel_cost: float
    """Time units per cell of straight-line distance."""
    analysis_cost: float
    """Time units per analysed view."""
    accessible: np.ndarray = field(default_factory=lambda: np.ones(0, dtype=bool))
    """``accessible[k]``: the robot can enter room k (bool, shape (rooms,)); empty means all."""

    scene: SceneRates | None = None
    """The SP-POMDP's outcome per view (:mod:`beliefloc.object_search.scene`) when the domain has a scene
    model: it replaces :attr:`detector` and :attr:`analysis_cost` (see :meth:`rates`, :meth:`analysis_time`).
    None: the fixed detector analyses every view in ``analysis_cost``."""

    def __post_init__(self) -> None:
        if len(self.accessible) == 0:
            object.__setattr__(self, "accessible", np.ones(len(self.rooms), dtype=bool))

    def rates(self) -> tuple[np.ndarray | float, np.ndarray | float]:
        """``(P(present | target in view), P(present | not))``: numbers for the fixed detector, arrays
        over views (axis: view) with a scene model."""
        if self.scene is None:
            return self.detector.true_positive, self.detector.false_positive
        return self.scene.true_positive, self.scene.false_positive

    def view_detector(self, view: int) -> Detector:
        """The detector of one view: the fixed one, or the scene model's rates for that view."""
        if self.scene is None:
            return self.detector
        return Detector(float(self.scene.true_positive[view]), float(self.scene.false_positive[view]))

    def analysis_time(self, p_in: np.ndarray) -> np.ndarray | float:
        """The expected time to analyse each view, when view v holds the target with probability
        ``p_in[v]``: ``analysis_cost``, or the scene model's expected processing time."""
        if self.scene is None:
            return self.analysis_cost
        return self.scene.expected_time(p_in)

    @property
    def n_cells(self) -> int:
        return len(self.room_of_cell)

    @cached_property
    def reachable(self) -> np.ndarray:
        """``reachable[v]``: view point v is in a room the robot can enter (bool, shape (views,))."""
        result: np.ndarray = self.accessible[self.room_of_cell]
        return result

    def view_cells(self, view: int) -> np.ndarray:
        """The cells view ``view`` covers (sorted int indices)."""
        start, end = self.views.indptr[view], self.views.indptr[view + 1]
        result: np.ndarray = self.views.indices[start:end]
        return result

    def in_view(self, view: int) -> np.ndarray:
        """The cells view ``view`` covers, as a boolean mask over cells."""
        mask = np.zeros(self.n_cells, dtype=bool)
        mask[self.view_cells(view)] = True
        return mask

    @cached_property
    def _plane_axes(self) -> tuple[np.ndarray, np.ndarray]:
        return np.ascontiguousarray(self.plane[:, 0]), np.ascontiguousarray(self.plane[:, 1])

    def distances_from(self, cell: int) -> np.ndarray:
        """Euclidean distance on the plane (in cells) from ``cell`` to every view point."""
        rows, cols = self._plane_axes
        result: np.ndarray = np.hypot(rows - rows[cell], cols - cols[cell])
        return result

    def action_costs(self, cell: int) -> np.ndarray:
        """Time of going from ``cell`` to each view point and analysing the view there."""
        result: np.ndarray = self.travel_cost * self.distances_from(cell) + self.analysis_cost
        return result

    def cells_of(self, room: int) -> np.ndarray:
        """The cells of room ``room`` (index into ``rooms``)."""
        return np.flatnonzero(self.room_of_cell == room)

    @property
    def closed_rooms(self) -> tuple[str, ...]:
        """The rooms the robot cannot enter (``accessible: false``), in room order."""
        return tuple(room for room, open_ in zip(self.rooms, self.accessible.tolist(), strict=True) if not open_)

    def over_rooms(self, by_room: Mapping[str, float]) -> np.ndarray:
        """A room prior ``{room: p}`` as a vector over :attr:`rooms` (float, shape (rooms,))."""
        return np.array([by_room[room] for room in self.rooms], dtype=float)

    def cell_name(self, cell: int) -> str:
        """``room:row,col``, the form :meth:`parse_cell` reads."""
        row, col = self.local[cell]
        return f"{self.rooms[self.room_of_cell[cell]]}:{row},{col}"

    def parse_cell(self, text: str) -> int:
        """``ROOM:ROW,COL`` -> cell index; :class:`InvalidValueError` naming what is wrong."""
        room, sep, where = text.partition(":")
        row_text, comma, col_text = where.partition(",")
        numbers = cell_numbers(row_text, col_text) if comma else None
        if not sep or numbers is None:
            raise InvalidValueError(f"{text!r}: write ROOM:ROW,COL, e.g. study:2,3")
        if room not in self.rooms:
            raise InvalidValueError(f"{text!r}: unknown room {room!r}; expected one of: {', '.join(self.rooms)}")
        index = self.rooms.index(room)
        matches = np.flatnonzero(
            (self.room_of_cell == index) & (self.local[:, 0] == numbers[0]) & (self.local[:, 1] == numbers[1])
        )
        if len(matches) == 0:
            rows, cols = self.room_shape(index)
            raise InvalidValueError(f"{text!r}: outside room {room!r} ({rows} x {cols} cells, rows and columns from 0)")
        return int(matches[0])

    def target_cell(self, text: str) -> int:
        """:meth:`parse_cell`, for a cell the target may be put on: one of a room the robot can enter
        (:class:`InvalidValueError` otherwise)."""
        cell = self.parse_cell(text)
        if not self.reachable[cell]:
            room = self.rooms[self.room_of_cell[cell]]
            raise InvalidValueError(f"{text!r}: the robot cannot enter room {room!r} (accessible: false)")
        return cell

    def room_shape(self, room: int) -> tuple[int, int]:
        cells = self.local[self.room_of_cell == room]
        return int(cells[:, 0].max()) + 1, int(cells[:, 1].max()) + 1


def plane_search_space(domain: Domain) -> SearchSpace:
    """The search space of a validated domain without ``map:``, on its plane of rooms.
    :class:`DomainError` if it has no ``search:`` or the robot starts in a room it cannot enter."""
    settings = domain.search
    if settings is None:
        raise DomainError(
            f"domain {domain.name!r} has no 'search:' section, which object search needs: either a 'search:' "
            "section that places the rooms on a plane (placement, robot_start: {room: R, cell: [row, col]}), or "
            "'map:' (a semantic map with rooms) and a 'search:' section with robot_start: [row, col] "
            "(docs/domain-format.md, 'Object search')"
        )
    closed = [name for name, room in domain.rooms.items() if not room.accessible]
    start_room = settings.robot_start.room
    if start_room in closed:
        raise DomainError(
            f"domain {domain.name!r}: the robot starts in {start_room!r}, a room marked 'accessible: false'; "
            "start it in a room it can search"
        )
    return build_space(list(domain.rooms), settings, inaccessible=closed)


def build_space(rooms: list[str], settings: PlaneSearch, *, inaccessible: Collection[str] = ()) -> SearchSpace:
    """Cells room by room, row-major; one view point per cell (see the module docstring).

    The views are built offset by offset of the ``view x view`` window, room by room: O(cells x view²)."""
    half = settings.sensor.view // 2
    room_of_cell, local, plane, viewers, covered = [], [], [], [], []
    base = 0
    for index, room in enumerate(rooms):
        rows, cols = settings.size_of(room)
        top, left = settings.placement[room]
        r, c = np.divmod(np.arange(rows * cols), cols)
        room_of_cell.append(np.full(rows * cols, index))
        local.append(np.stack([r, c], axis=1))
        plane.append(np.stack([r + top, c + left], axis=1).astype(float))
        if room not in inaccessible:
            ids = base + np.arange(rows * cols)
            for dr in range(-half, half + 1):
                for dc in range(-half, half + 1):
                    inside = (r + dr >= 0) & (r + dr < rows) & (c + dc >= 0) & (c + dc < cols)
                    viewers.append(ids[inside])
                    covered.append(base + (r[inside] + dr) * cols + c[inside] + dc)
        base += rows * cols
    room_arr = np.concatenate(room_of_cell)
    local_arr = np.concatenate(local)
    n = len(room_arr)
    view_rows = np.concatenate(viewers) if viewers else np.zeros(0, dtype=int)
    view_cols = np.concatenate(covered) if covered else np.zeros(0, dtype=int)
    views = sp.csr_matrix((np.ones(len(view_rows)), (view_rows, view_cols)), shape=(n, n))
    views.sort_indices()
    start_room = rooms.index(settings.robot_start.room)
    start = int(
        np.flatnonzero(
            (room_arr == start_room)
            & (local_arr[:, 0] == settings.robot_start.cell[0])
            & (local_arr[:, 1] == settings.robot_start.cell[1])
        )[0]
    )
    return SearchSpace(
        rooms=tuple(rooms),
        room_of_cell=room_arr,
        local=local_arr,
        plane=np.concatenate(plane),
        views=views,
        start=start,
        detector=Detector(settings.sensor.true_positive, settings.sensor.false_positive),
        travel_cost=settings.costs.travel,
        analysis_cost=settings.costs.analysis,
        accessible=np.array([room not in inaccessible for room in rooms], dtype=bool),
    )
