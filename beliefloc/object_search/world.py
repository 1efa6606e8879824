"""The search space of object search and a simulated target (Zhang, Sridharan & Wyatt 2015, Sec. III-B).

Pure numpy; randomness only through a passed Generator. Two roles kept apart (DESIGN.md):

* :class:`SearchSpace` is the robot's *model*: cells (each room a grid placed on a plane), the room
  of each cell, view points and the field of view of each, travel distances between view points.
* :class:`SimulatedTarget` is the *world*: it knows where the target is (or that it is absent) and
  answers a view with present/absent at the detector's rates.

Cells are numbered room by room (in the domain's room order), row-major inside a room. There is
one view point per cell: the robot stands on the cell and analyses the square of ``view x view``
cells centred on it, clipped to its room (a camera does not see through walls). So
``views[v, i]`` is True when view ``v`` covers cell ``i`` (axes: view, cell), and view ``v`` stands
on cell ``v``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from beliefloc.errors import UsageError
from beliefloc.knowledge.domain import Domain
from beliefloc.knowledge.domain import SearchSpace as SearchSpec
from beliefloc.object_search.posterior import Detector


@dataclass(frozen=True)
class SearchSpace:
    """Cells, rooms, views and distances of a domain's ``search:`` section."""

    rooms: tuple[str, ...]
    room_of_cell: np.ndarray
    """``room_of_cell[i]``: index into ``rooms`` (int, shape (cells,))."""
    local: np.ndarray
    """``local[i] = (row, col)`` of cell i inside its room (int, shape (cells, 2))."""
    plane: np.ndarray
    """``plane[i] = (row, col)`` of cell i on the plane (float, shape (cells, 2))."""
    views: np.ndarray
    """``views[v, i]``: view v covers cell i (bool, shape (views, cells))."""
    start: int
    """The cell (= view point) the robot starts on."""
    detector: Detector
    travel_cost: float
    """Time units per cell of straight-line distance."""
    analysis_cost: float
    """Time units per analysed view."""

    @property
    def n_cells(self) -> int:
        return len(self.room_of_cell)

    def distances_from(self, cell: int) -> np.ndarray:
        """Euclidean distance on the plane (in cells) from ``cell`` to every view point."""
        delta = self.plane - self.plane[cell]
        result: np.ndarray = np.hypot(delta[:, 0], delta[:, 1])
        return result

    def action_costs(self, cell: int) -> np.ndarray:
        """Time of going from ``cell`` to each view point and analysing the view there."""
        result: np.ndarray = self.travel_cost * self.distances_from(cell) + self.analysis_cost
        return result

    def cell_name(self, cell: int) -> str:
        """``room:row,col``, the form ``--target-cell`` takes."""
        row, col = self.local[cell]
        return f"{self.rooms[self.room_of_cell[cell]]}:{row},{col}"

    def parse_cell(self, spec: str) -> int:
        """``ROOM:ROW,COL`` -> cell index; :class:`UsageError` naming what is wrong."""
        room, sep, where = spec.partition(":")
        row_text, comma, col_text = where.partition(",")
        if not sep or not comma or not row_text.strip().isdigit() or not col_text.strip().isdigit():
            raise UsageError(f"{spec!r}: write ROOM:ROW,COL, e.g. study:2,3")
        if room not in self.rooms:
            raise UsageError(f"{spec!r}: unknown room {room!r}; expected one of: {', '.join(self.rooms)}")
        index = self.rooms.index(room)
        matches = np.flatnonzero(
            (self.room_of_cell == index) & (self.local[:, 0] == int(row_text)) & (self.local[:, 1] == int(col_text))
        )
        if len(matches) == 0:
            rows = int(self.local[self.room_of_cell == index, 0].max()) + 1
            cols = int(self.local[self.room_of_cell == index, 1].max()) + 1
            raise UsageError(f"{spec!r}: outside room {room!r} ({rows} x {cols} cells, rows and columns from 0)")
        return int(matches[0])

    def room_shape(self, room: int) -> tuple[int, int]:
        cells = self.local[self.room_of_cell == room]
        return int(cells[:, 0].max()) + 1, int(cells[:, 1].max()) + 1


def search_space(domain: Domain) -> SearchSpace:
    """Build the search space of a validated domain; :class:`UsageError` if it has no ``search:``."""
    if domain.search is None:
        raise UsageError(f"domain {domain.name!r} has no 'search:' section (rooms as cells, sensor, robot start)")
    return build_space(list(domain.rooms), domain.search)


def build_space(rooms: list[str], spec: SearchSpec) -> SearchSpace:
    """Cells room by room, row-major; one view point per cell (see the module docstring)."""
    room_of_cell, local, plane = [], [], []
    for index, room in enumerate(rooms):
        rows, cols = spec.size_of(room)
        top, left = spec.placement[room]
        r, c = np.divmod(np.arange(rows * cols), cols)
        room_of_cell.append(np.full(rows * cols, index))
        local.append(np.stack([r, c], axis=1))
        plane.append(np.stack([r + top, c + left], axis=1).astype(float))
    room_arr = np.concatenate(room_of_cell)
    local_arr = np.concatenate(local)
    half = spec.sensor.view // 2
    same_room = room_arr[:, None] == room_arr[None, :]
    near = np.abs(local_arr[:, None, :] - local_arr[None, :, :]).max(axis=2) <= half
    start_room = rooms.index(spec.robot_start.room)
    start = int(
        np.flatnonzero(
            (room_arr == start_room)
            & (local_arr[:, 0] == spec.robot_start.cell[0])
            & (local_arr[:, 1] == spec.robot_start.cell[1])
        )[0]
    )
    return SearchSpace(
        rooms=tuple(rooms),
        room_of_cell=room_arr,
        local=local_arr,
        plane=np.concatenate(plane),
        views=same_room & near,
        start=start,
        detector=Detector(spec.sensor.true_positive, spec.sensor.false_positive),
        travel_cost=spec.costs.travel,
        analysis_cost=spec.costs.analysis,
    )


@dataclass
class SimulatedTarget:
    """The world's side: where the target is (``None``: absent) and a seeded detector."""

    cell: int | None
    detector: Detector
    rng: np.random.Generator

    @classmethod
    def at_random(
        cls, space: SearchSpace, rng: np.random.Generator, detector_rng: np.random.Generator
    ) -> SimulatedTarget:
        """The target in a cell drawn uniformly over all cells."""
        return cls(int(rng.integers(space.n_cells)), space.detector, detector_rng)

    def detect(self, in_view: np.ndarray) -> bool:
        """Analyse a view (a boolean mask over cells): True for ``present``."""
        seen = self.cell is not None and bool(in_view[self.cell])
        rate = self.detector.true_positive if seen else self.detector.false_positive
        return bool(self.rng.random() < rate)
