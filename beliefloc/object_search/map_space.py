"""Object search on a semantic map: the search space of a domain with ``map:`` (issue 7).

A domain that references a map (``map: ../maps/apartment.yaml``) takes its rooms' cells, its walls
and its distances from the map instead of rectangles placed on a plane
(:func:`~beliefloc.object_search.space.build_space`). :class:`MapSearchSpace` is a
:class:`~beliefloc.object_search.space.SearchSpace`, so the loop, the policies, the trials and the
drawings use it unchanged. The choices:

* **Cells** are the free cells of the map's rooms: the target is in a room, and the robot stands on
  a cell of a room to analyse a view (view v stands on cell v, as on the plane). They are numbered
  room by room in the domain's room order, row-major inside a room, and named by their map
  coordinates: ``kitchen:7,9`` is row 7, column 9 of the map's grid (``7,9`` alone names it too).
* **Free cells in no room** (a doorway the map's ``rooms:`` leaves out, say) are neither cells nor
  view points: the target is never there and the robot never stops there, but it travels through
  them. The domain file is checked to start the robot on a cell of a room.
* **Travel**: the robot moves from a free cell to any of its 8 neighbours, a straight step being 1
  cell and a diagonal one sqrt 2, never across the corner of a blocked cell (a diagonal step needs
  both cells beside it free). :meth:`MapSearchSpace.distances_from` is the length of the shortest
  such path (Dijkstra, ``scipy.sparse.csgraph``), in cells: on an open floor the octile distance,
  within 8 % of the straight line a plane of rooms uses; across a wall, the way round.
* **Views**: the ``view x view`` square centred on the robot's cell, less the cells a wall hides. A
  cell is seen when the segment between the two cell centres crosses no blocked cell: the
  line-of-sight test of a Look (:func:`beliefloc.semantic_map.geometry.viewing_angles_many`). A
  view is not clipped to the robot's room: from a doorway the robot sees into both rooms.
* **Rooms marked** ``accessible: false`` keep their cells (the room prior and the drawings have
  them), but the robot neither stands on nor travels through them and no view covers them, as on
  the plane. Every cell of the other rooms must be reachable from the robot's start: a room cut
  off by walls or by closed rooms is an error that names it.
* **Accuracy** (:func:`beliefloc.object_search.loop.accuracy`) reads the same distance: the
  Gaussian fall-off of the shortest path from the reported cell to the true one, so a cell on the
  other side of a wall is as far away as the robot would have to walk.

Distances are computed per source cell when first asked for and kept, up to about
:data:`CACHE_NUMBERS` floats: a search asks for them from the cells the robot stands on, and the
trials of one run share the space.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from beliefloc.errors import DomainError, InvalidValueError
from beliefloc.knowledge.domain import Domain
from beliefloc.model import GridLayout
from beliefloc.object_search.posterior import Detector
from beliefloc.object_search.space import SearchSpace, cell_numbers
from beliefloc.semantic_map.geometry import viewing_angles_many

CACHE_NUMBERS = 1 << 22
"""About how many distances (float64) :meth:`MapSearchSpace.distances_from` keeps: 32 MiB."""
_STEPS = ((0, 1, 1.0), (1, 0, 1.0), (1, 1, math.sqrt(2.0)), (1, -1, math.sqrt(2.0)))
"""Half of the 8 moves (the other half are their reverses): row step, column step, length."""


@dataclass(frozen=True, eq=False, kw_only=True)
class MapSearchSpace(SearchSpace):
    """A search space on a map's grid (see the module docstring); ``local`` and ``plane`` hold each
    cell's map coordinates."""

    map_name: str
    free: np.ndarray
    """``free[r, c]``: the map's free cells (bool, shape (rows, cols))."""
    passable: np.ndarray
    """``passable[r, c]``: the robot may travel through: free and in no closed room (bool, (rows, cols))."""
    cell_at: np.ndarray
    """``cell_at[r, c]``: the cell on row r, column c of the map, -1 for a wall or a free cell in no
    room (int, shape (rows, cols))."""
    graph: sp.csr_matrix
    """The moves between passable cells (nodes: the passable cells in row-major order), weighted by
    their length; one entry per direction."""
    node_of_cell: np.ndarray
    """``node_of_cell[i]``: cell i's node in ``graph``, -1 in a closed room (int, shape (cells,))."""
    _distances: OrderedDict[int, np.ndarray] = field(default_factory=OrderedDict, init=False, repr=False)

    @property
    def shape(self) -> tuple[int, int]:
        """``(rows, cols)`` of the map's grid."""
        rows, cols = self.free.shape
        return int(rows), int(cols)

    def distances_from(self, cell: int) -> np.ndarray:
        """Length in cells of the shortest path from ``cell`` to every cell (see the module
        docstring); ``inf`` where no path goes (a closed room). Read-only: the array is kept."""
        kept = self._distances.get(cell)
        if kept is not None:
            self._distances.move_to_end(cell)
            return kept
        result = np.full(self.n_cells, np.inf)
        node = int(self.node_of_cell[cell])
        if node < 0:
            result[cell] = 0.0
        else:
            from scipy.sparse.csgraph import dijkstra

            from_node = dijkstra(self.graph, directed=True, indices=np.array([node]))[0]
            on_graph = self.node_of_cell >= 0
            result[on_graph] = from_node[self.node_of_cell[on_graph]]
        result.setflags(write=False)
        self._distances[cell] = result
        while len(self._distances) > max(16, CACHE_NUMBERS // max(1, self.n_cells)):
            self._distances.popitem(last=False)
        return result

    def parse_cell(self, text: str) -> int:
        """``ROOM:ROW,COL`` or ``ROW,COL`` in map coordinates -> cell index; :class:`InvalidValueError`
        saying what is there instead (a wall, another room, a free cell in no room)."""
        room, sep, where = text.rpartition(":")
        row_text, comma, col_text = where.partition(",")
        numbers = cell_numbers(row_text, col_text) if comma else None
        if numbers is None:
            example = self.cell_name(self.start)
            raise InvalidValueError(f"{text!r}: write ROOM:ROW,COL in the map's rows and columns, e.g. {example}")
        if sep and room not in self.rooms:
            raise InvalidValueError(f"{text!r}: unknown room {room!r}; expected one of: {', '.join(self.rooms)}")
        r, c = numbers
        rows, cols = self.shape
        if not (r < rows and c < cols):
            raise InvalidValueError(f"{text!r}: [{r}, {c}] is outside the {rows}x{cols} grid of {self.map_name}")
        cell = int(self.cell_at[r, c])
        if cell < 0:
            what = "a free cell in no room (the target is only in rooms)" if self.free[r, c] else "blocked"
            raise InvalidValueError(f"{text!r}: [{r}, {c}] of {self.map_name} is {what}")
        actual = self.rooms[self.room_of_cell[cell]]
        if sep and actual != room:
            raise InvalidValueError(f"{text!r}: [{r}, {c}] is in {actual!r}, not {room!r}")
        return cell

    def room_shape(self, room: int) -> tuple[int, int]:
        """Rows and columns of the room's bounding box on the map."""
        cells = self.local[self.room_of_cell == room]
        low, high = cells.min(axis=0), cells.max(axis=0)
        return int(high[0] - low[0]) + 1, int(high[1] - low[1]) + 1


def map_search_space(domain: Domain) -> MapSearchSpace:
    """The search space of a validated domain with ``map:`` (see the module docstring);
    :class:`DomainError` when it has no ``search:`` section, the robot starts in a closed room, or a
    cell of an open room cannot be reached."""
    smap = domain.semantic_map
    settings = domain.map_search
    label = str(domain.map_file) if domain.map_file is not None else str(domain.map)
    if settings is None:
        raise DomainError(
            f"domain {domain.name!r} is on the map {label} but has no 'search:' section: add one with "
            "robot_start: [row, col], a cell of a room (docs/domain-format.md, 'A domain on a map')"
        )
    if smap is None:
        raise InvalidValueError(
            f"domain {domain.name!r}: its map {label} was not loaded; read the domain with load_domain"
        )
    rooms = list(domain.rooms)
    closed = [name for name in rooms if not domain.rooms[name].accessible]
    masks = smap.rooms
    coords = [np.argwhere(masks[name]) for name in rooms]  # row-major
    room_of_cell = np.concatenate([np.full(len(rc), k) for k, rc in enumerate(coords)])
    where = np.concatenate(coords)
    n = len(where)
    cell_at = np.full(smap.free.shape, -1, dtype=np.int64)
    cell_at[where[:, 0], where[:, 1]] = np.arange(n)
    accessible = np.array([name not in closed for name in rooms], dtype=bool)
    open_cell = accessible[room_of_cell]
    passable = smap.free.copy()
    passable[where[~open_cell, 0], where[~open_cell, 1]] = False
    graph, node_at = travel_graph(passable)
    r, c = settings.robot_start
    start = int(cell_at[r, c])  # a cell of a room: checked when the domain was loaded
    start_room = rooms[room_of_cell[start]]
    if start_room in closed:
        raise DomainError(
            f"domain {domain.name!r}: the robot starts in {start_room!r}, a room marked 'accessible: false'; "
            "start it in a room it can search"
        )
    space = MapSearchSpace(
        rooms=tuple(rooms),
        room_of_cell=room_of_cell,
        local=where,
        plane=where.astype(float),
        views=map_views(smap.free, cell_at, open_cell, settings.sensor.view),
        start=start,
        detector=Detector(settings.sensor.true_positive, settings.sensor.false_positive),
        travel_cost=settings.costs.travel,
        analysis_cost=settings.costs.analysis,
        accessible=accessible,
        map_name=label,
        free=smap.free,
        passable=passable,
        cell_at=cell_at,
        graph=graph,
        node_of_cell=np.where(open_cell, node_at[where[:, 0], where[:, 1]], -1),
    )
    cut_off = np.flatnonzero(np.isinf(space.distances_from(start)) & open_cell)
    if len(cut_off):
        room = rooms[room_of_cell[cut_off[0]]]
        cr, cc = (int(x) for x in where[cut_off[0]])
        raise DomainError(
            f"domain {domain.name!r}: cell [{cr}, {cc}] of room {room!r} cannot be reached from the robot's start "
            f"[{r}, {c}] on {label} (walls, or rooms marked 'accessible: false', are in the way); open a doorway "
            f"or mark {room!r} 'accessible: false'"
        )
    return space


def travel_graph(passable: np.ndarray) -> tuple[sp.csr_matrix, np.ndarray]:
    """The 8-neighbour moves between passable cells (see the module docstring) and ``node_at[r, c]``,
    the node of each passable cell (row-major), -1 elsewhere."""
    rows, cols = passable.shape
    node_at = np.full((rows, cols), -1, dtype=np.int64)
    node_at[passable] = np.arange(int(passable.sum()))
    heads, tails, lengths = [], [], []
    for dr, dc, length in _STEPS:
        # cells (r, c) whose neighbour (r + dr, c + dc) is inside the grid
        r0, r1 = 0, rows - dr
        c0, c1 = max(0, -dc), cols - max(0, dc)
        here = passable[r0:r1, c0:c1]
        there = passable[r0 + dr : r1 + dr, c0 + dc : c1 + dc]
        ok = here & there
        if dr and dc:  # no cutting a blocked cell's corner
            ok &= passable[r0 + dr : r1 + dr, c0:c1] & passable[r0:r1, c0 + dc : c1 + dc]
        a = node_at[r0:r1, c0:c1][ok]
        b = node_at[r0 + dr : r1 + dr, c0 + dc : c1 + dc][ok]
        heads += [a, b]
        tails += [b, a]
        lengths += [np.full(2 * len(a), length)]
    n = int(passable.sum())
    graph = sp.csr_matrix(
        (np.concatenate(lengths), (np.concatenate(heads), np.concatenate(tails))), shape=(n, n), dtype=float
    )
    return graph, node_at


def map_views(free: np.ndarray, cell_at: np.ndarray, open_cell: np.ndarray, view: int) -> sp.csr_matrix:
    """``views[v, i] = 1`` when cell i is in the ``view x view`` square around cell v and in sight of
    it (see the module docstring); only cells of open rooms see and are seen. ``cell_at[r, c]`` is the
    cell on the map's row r, column c, or -1 (sparse CSR, shape (cells, cells)).

    Built with the Look's line-of-sight test: the cells of open rooms are the "landmarks", and every
    free cell within ``half x sqrt 2`` of one (the square's corners) is tested; the square is then
    cut out of that disc."""
    rows, cols = free.shape
    n = len(open_cell)
    half = view // 2
    where = np.zeros((n, 2), dtype=np.int64)
    on_map = np.argwhere(cell_at >= 0)
    where[cell_at[on_map[:, 0], on_map[:, 1]]] = on_map
    layout = GridLayout(rows, cols, 1, 1.0, free)
    seen_cells = np.flatnonzero(open_cell)
    states, _, which = viewing_angles_many(layout, where[seen_cells], half * math.sqrt(2.0), 360.0, True)
    viewer_rc = np.stack(np.divmod(layout.free_cells[states], cols), axis=1)
    viewer = cell_at[viewer_rc[:, 0], viewer_rc[:, 1]]
    seen = seen_cells[which]
    keep = (np.abs(viewer_rc - where[seen]).max(axis=1) <= half) & (viewer >= 0)
    keep[keep] &= open_cell[viewer[keep]]
    views = sp.csr_matrix((np.ones(int(keep.sum())), (viewer[keep], seen[keep])), shape=(n, n))
    views.sum_duplicates()  # also sorts the indices
    views.data[:] = 1.0
    return views
