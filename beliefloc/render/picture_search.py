"""An object search as a picture (PNG or SVG) or an animation (GIF, or PNG frames): the cell belief,
the views taken, the robot's path, and the room prior beside it as a bar chart.

One picture shows the search after step ``k`` (:func:`search_figure`; ``k = 0`` is before the first
view, the last ``k`` the whole search), drawn on the plane of rooms, or on the map's grid for a
domain with ``map:`` (:class:`~beliefloc.object_search.map_space.MapSearchSpace`). Row 0 is at the
top, as in the terminal drawing (:func:`beliefloc.render.search.belief_plane`):

* **The belief.** Every cell of a room is a square shaded by its probability on reversed viridis
  from 0 (light yellow) to the largest probability of that step (dark purple): more is darker, as
  in :mod:`beliefloc.render.picture_belief`, with a colour bar. A room the robot cannot enter is
  hatched grey (it holds no belief).
* **The map** (with ``map:``): walls dark grey, free cells in no room light grey, a dashed border
  round each room; the map's rows and columns on the axes (the numbers ``--target-cell`` takes).
* **Room names** where they hide nothing: on a plane of rooms in the blank row above the room (or
  above the plane), on a map on the run of wall next to the room (a room's own outer wall first).
* **The views.** The view point of every step taken so far, a circle when the detector said
  *absent* and a filled triangle when it said *present*; a dotted line round every cell some view
  covered, and a thick line round the cells of the last view.
* **The robot's path**: from its start (a hollow square) through the view points in order, round
  walls on a map (the shortest path it travels); the robot itself a diamond on the last view.
* **The target's true cell** (the simulator knows it, the robot does not): a cross; **the most
  likely cell**: a thick red square round it.
* **Beside it**, per room, the knowledge base's room prior (hatched) and the belief of that step
  summed over the room's cells (solid), with their values.

Shapes, line styles and hatches carry the meaning, each listed in the legend; colour only repeats
it. The functions here only observe a search record; :mod:`beliefloc.render.figures` reaches
matplotlib and writes the files.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator, Sequence
from contextlib import AbstractContextManager, contextmanager
from dataclasses import dataclass, replace
from pathlib import PurePath
from typing import TYPE_CHECKING, Any

import numpy as np

from beliefloc.object_search.loop import SearchRecord, Verdict
from beliefloc.object_search.map_space import MapSearchSpace
from beliefloc.object_search.space import SearchSpace
from beliefloc.render.figures import add_lines, add_polygons, figure, figure_bytes
from beliefloc.render.search import plane_labels

if TYPE_CHECKING:
    from matplotlib.figure import Figure

CMAP = "viridis_r"
"""More probability is darker (as in the belief pictures of :mod:`beliefloc.render.picture_belief`)."""
MOST_LIKELY_COLOUR = "#d62728"
WALL_COLOUR = "#4d4d4d"
OUTSIDE_COLOUR = "#d9d9d9"
"""A free cell in no room."""
CLOSED_COLOUR = "#bdbdbd"
ROOM_BORDER_COLOUR = "#c51b7d"
PATH_COLOUR = "#ff7f0e"
VIEW_COLOUR = "#1f77b4"
PRIOR_COLOUR = "#9ecae1"
ROOM_BELIEF_COLOUR = "#3f007d"
_MAP_INCHES = 6.0
"""The longer side of the belief's axes."""
_MIN_MAP_INCHES = 2.4
_BARS_INCHES = 2.6
_FONT = 8.0
_Z_CELLS, _Z_ROOMS, _Z_SEEN, _Z_PATH, _Z_VIEW, _Z_BEST, _Z_MARKS, _Z_TEXT = range(1, 9)


@dataclass(frozen=True)
class Canvas:
    """The grid a search is drawn on: the plane of rooms or the map, ``rows x cols`` squares of one
    unit, cell ``(r, c)`` spanning ``x`` in ``[c, c + 1]`` and ``y`` in ``[r, r + 1]`` (y downwards)."""

    rows: int
    cols: int
    where: np.ndarray
    """``where[i] = (row, col)`` of the space's cell i on the canvas (int, shape (cells, 2))."""
    on_map: bool
    margins: tuple[int, int] = (0, 0)
    """Rows kept blank above and below the grid for room names (:func:`name_spots`)."""


def canvas(space: SearchSpace) -> Canvas:
    """Where ``space``'s cells are drawn (see :class:`Canvas`)."""
    where = np.rint(space.plane).astype(np.int64)
    if isinstance(space, MapSearchSpace):
        rows, cols = space.shape
        grid = Canvas(rows, cols, where, True)
    else:
        grid = Canvas(int(where[:, 0].max()) + 1, int(where[:, 1].max()) + 1, where, False)
    rows_used = [spot.row for spot in _name_spots(space, grid).values()]
    margins = (int(any(r < 0 for r in rows_used)), int(any(r >= grid.rows for r in rows_used)))
    return replace(grid, margins=margins)


def cell_centre(space: SearchSpace, cell: int) -> tuple[float, float]:
    """Data coordinates ``(x, y)`` of the centre of ``cell`` on the belief's axes: the point a test
    reads the cell's shade at (``ax.transData`` takes it to pixels)."""
    r, c = canvas(space).where[cell]
    return float(c) + 0.5, float(r) + 0.5


def frame_steps(n_steps: int, limit: int | None = None) -> list[int]:
    """The steps an animation of a search of ``n_steps`` steps shows: 0 (before the first view) to
    ``n_steps``; past ``limit`` frames, step 0 and the last ``limit - 1`` steps (how it ends), as
    ``simulate --record`` keeps an episode's."""
    if limit is not None and limit < 1:
        raise ValueError(f"a frame limit must be at least 1, got {limit}")
    if limit is None or limit > n_steps:
        return list(range(n_steps + 1))
    return [0, *range(n_steps - limit + 2, n_steps + 1)]


def search_figure(
    space: SearchSpace, record: SearchRecord, *, step: int | None = None, heading: str = ""
) -> AbstractContextManager[Figure]:
    """A figure of ``record`` after ``step`` steps (default: all of them): the belief with the views,
    the path and the marks on the left, the room prior and room belief on the right (see the module
    docstring); ``heading`` is the title's first line (the domain and target, say), the step or the
    verdict its second. Closed when the ``with`` block ends; the belief's axes are ``fig.axes[0]``.
    The steps' beliefs must have been kept (``keep_beliefs``), else ValueError."""
    return _search_figure(space, record, step=len(record.steps) if step is None else step, heading=heading)


def frame_pngs(space: SearchSpace, record: SearchRecord, steps: Sequence[int], *, heading: str = "") -> Iterator[bytes]:
    """PNG bytes of :func:`search_figure` after each of ``steps``, one figure at a time."""
    for k in steps:
        with search_figure(space, record, step=k, heading=heading) as fig:
            yield figure_bytes(fig, ".png")


def figure_size(space: SearchSpace) -> tuple[float, float, float]:
    """``(width, height, map_width)`` in inches: the belief's axes sized from the canvas's aspect
    ratio (longer side 6 inches), the bar chart beside it, room for the titles, the colour bar
    under the belief and the legend under everything."""
    grid = canvas(space)
    rows, cols = grid.rows + sum(grid.margins), grid.cols
    if cols >= rows:
        aw, ah = _MAP_INCHES, max(_MIN_MAP_INCHES, _MAP_INCHES * rows / cols)
    else:
        aw, ah = max(_MIN_MAP_INCHES, _MAP_INCHES * cols / rows), _MAP_INCHES
    return aw + _BARS_INCHES + 1.4, ah + 2.9, aw


@contextmanager
def _search_figure(space: SearchSpace, record: SearchRecord, *, step: int, heading: str) -> Iterator[Figure]:
    if not 0 <= step <= len(record.steps):
        raise ValueError(f"step {step} of a search of {len(record.steps)} steps")
    belief = _belief_after(record, step)
    width, height, map_width = figure_size(space)
    with figure(width, height) as fig:
        fig.set_layout_engine("constrained")
        grid = fig.add_gridspec(1, 2, width_ratios=(map_width, _BARS_INCHES))
        ax = fig.add_subplot(grid[0, 0])
        bars = fig.add_subplot(grid[0, 1])
        draw_search(ax, space, record, step=step, belief=belief)
        draw_room_bars(bars, space, record, belief)
        fig.suptitle(f"{heading}\n{_step_title(space, record, step)}" if heading else _step_title(space, record, step))
        handles, labels = ax.get_legend_handles_labels()
        more, more_labels = bars.get_legend_handles_labels()
        legend = fig.legend(
            handles + more,
            labels + more_labels,
            loc="outside lower center",
            ncol=3,
            fontsize=_FONT,
            frameon=False,
        )
        for handle in legend.legend_handles:
            if handle is not None and hasattr(handle, "set_markersize"):
                handle.set_markersize(9.0)  # the map's markers are sized to its cells
        yield fig


def _belief_after(record: SearchRecord, step: int) -> np.ndarray:
    if step == 0:
        return np.asarray(record.initial_belief, dtype=np.float64)
    kept = record.steps[step - 1].belief
    if kept is None:
        raise ValueError("the search's beliefs were not kept: run it with keep_beliefs=True to draw it")
    return np.asarray(kept, dtype=np.float64)


def _step_title(space: SearchSpace, record: SearchRecord, step: int) -> str:
    n = len(record.steps)
    if step == n and n:
        what = {Verdict.FOUND: "found", Verdict.NOT_FOUND: "not found", Verdict.TIME_LIMIT: "time limit"}
        text = f"{what[record.verdict]}"
        if record.reported_cell is not None:
            text += f" at {space.cell_name(record.reported_cell)}"
        true = "absent" if record.true_cell is None else space.cell_name(record.true_cell)
        return f"{text} after {n} steps, {record.time:.1f} time units (true cell: {true})"
    if step == 0:
        return f"before the first view (the search takes {n} steps)"
    s = record.steps[step - 1]
    seen = "present" if s.present else "absent"
    return (
        f"step {step} of {n}: view {space.cell_name(s.view)} says {seen}; p(E) {s.p_exists:.3f}, "
        f"max b {s.best_belief:.3f} at {space.cell_name(s.best_cell)}"
    )


# --- the belief's axes ---------------------------------------------------------------------------


def draw_search(
    ax: Any, space: SearchSpace, record: SearchRecord, *, step: int | None = None, belief: np.ndarray | None = None
) -> None:
    """The belief after ``step`` steps (default: all) on ``ax`` with the map, the rooms, the views,
    the path and the marks of the module docstring, a colour bar under it, each mark labelled for
    a legend (``ax.get_legend_handles_labels()``)."""
    k = len(record.steps) if step is None else step
    b = _belief_after(record, k) if belief is None else np.asarray(belief, dtype=np.float64)
    if b.shape != (space.n_cells,):
        raise ValueError(f"a belief over {space.n_cells} cells was expected, got shape {b.shape}")
    grid = canvas(space)
    ax.set_aspect("equal")
    ax.set_xlim(0.0, grid.cols)
    ax.set_ylim(grid.rows + grid.margins[1], -grid.margins[0])  # row 0 at the top
    if grid.on_map:
        assert isinstance(space, MapSearchSpace)
        _draw_map(ax, space, grid)
    else:
        ax.set_axis_off()
    shading = _draw_cells(ax, space, grid, b)
    _draw_room_borders(ax, space, grid)
    steps = record.steps[:k]
    views = [s.view for s in steps]
    seen = np.zeros(space.n_cells, dtype=bool)
    for v in views:
        seen[space.view_cells(v)] = True
    last = space.view_cells(views[-1]) if views else np.zeros(0, dtype=np.int64)
    style = {"linestyle": (0, (1, 1.5)), "linewidth": 1.2}
    _outline(ax, grid, grid.where[seen], color="black", label="cells a view covered", **style)
    _outline(
        ax, grid, grid.where[last], color=VIEW_COLOUR, linewidth=2.6, linestyle="solid", label="cells of the last view"
    )
    cell_pts = _cell_points(ax, grid)
    _draw_path(ax, space, grid, [space.start, *views], cell_pts)
    _draw_views(ax, grid, steps, cell_pts)
    _draw_marks(ax, space, grid, b, record, robot=views[-1] if views else space.start, cell_pts=cell_pts)
    _draw_room_names(ax, space, grid, cell_pts)
    bar = ax.figure.colorbar(shading, ax=ax, location="bottom", shrink=0.7, aspect=35, pad=0.02)
    bar.set_label("probability of the cell (0 is lightest)", fontsize=_FONT)
    bar.ax.tick_params(labelsize=_FONT)


def _cell_points(ax: Any, grid: Canvas) -> float:
    """About how many points a cell spans in the figure (for marker and font sizes)."""
    width, height = ax.figure.get_size_inches()
    spec = ax.get_subplotspec()
    ratios = spec.get_gridspec().get_width_ratios() if spec is not None else None
    share = ratios[0] / sum(ratios) if ratios else 1.0
    inches = min(width * share * 0.92 / grid.cols, (height - 2.9) / (grid.rows + sum(grid.margins)))
    return float(max(4.0, 72.0 * inches))


def _squares(where: np.ndarray) -> np.ndarray:
    """The unit squares of canvas cells ``where`` (an ``(n, 2)`` array of rows and columns), ``(n, 4, 2)``."""
    r = where[:, 0].astype(np.float64)
    c = where[:, 1].astype(np.float64)
    xs = np.stack([c, c + 1, c + 1, c], axis=1)
    ys = np.stack([r, r, r + 1, r + 1], axis=1)
    return np.stack([xs, ys], axis=2)


def _draw_map(ax: Any, space: MapSearchSpace, grid: Canvas) -> None:
    walls = np.argwhere(~space.free)
    if len(walls):
        add_polygons(ax, _squares(walls), facecolor=WALL_COLOUR, zorder=_Z_CELLS, label="wall")
    outside = np.argwhere(space.free & (space.cell_at < 0))
    if len(outside):
        add_polygons(
            ax,
            _squares(outside),
            facecolor=OUTSIDE_COLOUR,
            edgecolor="white",
            linewidth=0.5,
            zorder=_Z_CELLS,
            label="free, in no room",
        )
    for axis, n in ((ax.xaxis, grid.cols), (ax.yaxis, grid.rows)):
        ticks = _ticks(n)
        axis.set_ticks(ticks + 0.5, [str(t) for t in ticks.tolist()])
    ax.tick_params(labelsize=_FONT, length=2, top=True, labeltop=True, bottom=False, labelbottom=False)
    ax.set_xlabel(f"column of {PurePath(space.map_name).name}", fontsize=_FONT)
    ax.xaxis.set_label_position("top")
    ax.set_ylabel("row", fontsize=_FONT)


def _ticks(n: int) -> np.ndarray:
    step = next(s for s in (1, 2, 5, 10, 20, 50, 100, 200, 500, 1000, 10**9) if n / s <= 16)
    return np.arange(0, n, step, dtype=np.int64)


def _draw_cells(ax: Any, space: SearchSpace, grid: Canvas, belief: np.ndarray) -> Any:
    """The open rooms' cells shaded by ``belief``, closed rooms hatched; returns the shading (the
    colour bar's mappable)."""
    open_cells = space.reachable
    top = float(belief.max())
    small = grid.rows * grid.cols <= 2500
    shading = add_polygons(
        ax,
        _squares(grid.where[open_cells]),
        values=belief[open_cells],
        cmap=CMAP,
        vmin=0.0,
        vmax=top if top > 0 else 1.0,
        edgecolor="white" if small else "none",
        linewidth=0.4 if small else 0.0,
        zorder=_Z_CELLS,
    )
    if not open_cells.all():
        add_polygons(
            ax,
            _squares(grid.where[~open_cells]),
            facecolor=CLOSED_COLOUR,
            edgecolor="#7f7f7f",
            linewidth=0.0,
            hatch="xx",
            zorder=_Z_CELLS,
            label="a room the robot cannot enter",
        )
    return shading


def _boundary(grid: Canvas, where: np.ndarray) -> list[np.ndarray]:
    """The unit segments between the canvas cells ``where`` and the cells not in it."""
    mask = np.zeros((grid.rows, grid.cols), dtype=bool)
    mask[where[:, 0], where[:, 1]] = True
    padded = np.pad(mask, 1)
    segments: list[np.ndarray] = []
    r, c = np.nonzero(padded[:-1, 1:-1] != padded[1:, 1:-1])  # between rows r - 1 and r
    for row, col in zip(r.tolist(), c.tolist(), strict=True):
        segments.append(np.array([[col, row], [col + 1, row]], dtype=np.float64))
    r, c = np.nonzero(padded[1:-1, :-1] != padded[1:-1, 1:])  # between columns c - 1 and c
    for row, col in zip(r.tolist(), c.tolist(), strict=True):
        segments.append(np.array([[col, row], [col, row + 1]], dtype=np.float64))
    return segments


def _outline(ax: Any, grid: Canvas, where: np.ndarray, *, label: str, **style: Any) -> None:
    add_lines(ax, _boundary(grid, where), colors=style.pop("color"), zorder=_Z_SEEN, label=label, **style)


def _draw_room_borders(ax: Any, space: SearchSpace, grid: Canvas) -> None:
    segments: list[np.ndarray] = []
    for index in range(len(space.rooms)):
        segments += _boundary(grid, grid.where[space.room_of_cell == index])
    add_lines(
        ax,
        segments,
        colors=ROOM_BORDER_COLOUR,
        linewidth=1.6,
        linestyle=(0, (4, 2)),
        zorder=_Z_ROOMS,
        label="room border",
    )


def _route(space: SearchSpace, cells: Sequence[int]) -> np.ndarray:
    """Canvas ``(x, y)`` points of the robot's path through ``cells`` in order: straight lines on a
    plane of rooms (its travel distance), the shortest path round walls on a map."""
    grid = canvas(space)
    centres = grid.where[list(cells)][:, ::-1].astype(np.float64) + 0.5
    if not isinstance(space, MapSearchSpace) or len(cells) < 2:
        return centres
    from scipy.sparse.csgraph import dijkstra

    nodes = np.argwhere(space.passable)  # the graph's nodes: passable cells, row-major
    sources = sorted({int(space.node_of_cell[a]) for a in cells[:-1]})
    _, predecessors = dijkstra(space.graph, directed=True, indices=np.array(sources), return_predecessors=True)
    points = [centres[0]]
    for a, b in itertools.pairwise(cells):
        source, node = int(space.node_of_cell[a]), int(space.node_of_cell[b])
        row = predecessors[sources.index(source)]
        leg = []
        while node != source and node >= 0:
            leg.append(node)
            node = int(row[node])
        for n in reversed(leg):
            points.append(nodes[n][::-1].astype(np.float64) + 0.5)
    return np.array(points)


def _draw_path(ax: Any, space: SearchSpace, grid: Canvas, cells: list[int], cell_pts: float) -> None:
    start = grid.where[cells[0]][::-1] + 0.5
    ax.plot(
        [start[0]],
        [start[1]],
        linestyle="none",
        marker="s",
        markersize=max(5.0, 0.55 * cell_pts),
        markerfacecolor="none",
        markeredgecolor="black",
        markeredgewidth=1.6,
        zorder=_Z_MARKS,
        label="robot's start",
    )
    points = _route(space, cells) if len(cells) > 1 else np.zeros((0, 2))  # an entry in the legend either way
    ax.plot(
        points[:, 0],
        points[:, 1],
        color=PATH_COLOUR,
        linewidth=2.2,
        linestyle="-",
        zorder=_Z_PATH,
        solid_capstyle="round",
        label="robot's path",
    )


def _draw_views(ax: Any, grid: Canvas, steps: Sequence[Any], cell_pts: float) -> None:
    for present, marker, label in ((False, "o", "view point: absent"), (True, "^", "view point: present")):
        at = [s.view for s in steps if s.present == present]  # every frame has both legend entries
        xy = grid.where[at][:, ::-1] + 0.5 if at else np.zeros((0, 2))
        ax.plot(
            xy[:, 0],
            xy[:, 1],
            linestyle="none",
            marker=marker,
            markersize=max(5.0, 0.32 * cell_pts),
            markerfacecolor=VIEW_COLOUR if present else "white",
            markeredgecolor=VIEW_COLOUR,
            markeredgewidth=1.4,
            zorder=_Z_VIEW,
            label=label,
        )


def _draw_marks(
    ax: Any, space: SearchSpace, grid: Canvas, belief: np.ndarray, record: SearchRecord, *, robot: int, cell_pts: float
) -> None:
    best = int(np.argmax(belief))
    add_polygons(
        ax,
        _squares(grid.where[[best]]),
        facecolor="none",
        edgecolor=MOST_LIKELY_COLOUR,
        linewidth=2.8,
        zorder=_Z_BEST,
        label=f"most likely cell {space.cell_name(best)} (p={belief[best]:.3g})",
    )
    x, y = grid.where[robot][::-1] + 0.5
    ax.plot(
        [x],
        [y],
        linestyle="none",
        marker="D",
        markersize=max(5.0, 0.42 * cell_pts),
        markerfacecolor=PATH_COLOUR,
        markeredgecolor="black",
        markeredgewidth=1.2,
        zorder=_Z_MARKS,
        label="robot",
    )
    if record.true_cell is not None:
        x, y = grid.where[record.true_cell][::-1] + 0.5
        ax.plot(
            [x],
            [y],
            linestyle="none",
            marker="X",
            markersize=max(5.0, 0.5 * cell_pts),
            markerfacecolor="white",
            markeredgecolor="black",
            markeredgewidth=1.2,
            zorder=_Z_MARKS,
            label="target's true cell (the simulator's)",
        )


# --- room names ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class NameSpot:
    """Where a room's name is drawn: the canvas row and the columns ``[left, right)`` it is centred on,
    and whether it stands on a wall (light text) or on the blank page (dark text)."""

    row: float
    left: float
    right: float
    on_wall: bool


def name_spots(space: SearchSpace) -> dict[str, NameSpot]:
    """Where each room's name goes (see the module docstring). On a plane of rooms: the blank row
    above the room, or the margin above the plane for a room on its top row
    (:func:`beliefloc.render.search.plane_labels`). On a map: the longest run of wall along the
    room's top or bottom side, or of the margin above or below the map where the room touches its
    edge -- one that touches no other room first. A room with no such place has no name on the
    picture (the bar chart beside it names every room)."""
    return _name_spots(space, canvas(space))


def _name_spots(space: SearchSpace, grid: Canvas) -> dict[str, NameSpot]:
    if not grid.on_map:
        in_row, before = plane_labels(space)
        spots: dict[str, NameSpot] = {}
        # the terminal's blank rows, and the row above the plane (a name the terminal puts on a line
        # of its own between two rooms has no room in a picture: the bar chart names the room)
        for row, labels in [*in_row.items(), *((-1, labels) for r, labels in before.items() if r == 0)]:
            for left, room in labels:
                index = space.rooms.index(room)
                cols = grid.where[space.room_of_cell == index][:, 1]
                spots[room] = NameSpot(float(row), float(left), float(cols.max()) + 1.0, False)
        return spots
    assert isinstance(space, MapSearchSpace)
    rows = grid.rows
    owner = np.full((rows + 2, grid.cols), -1, dtype=np.int64)  # a margin row above and below
    owner[grid.where[:, 0] + 1, grid.where[:, 1]] = space.room_of_cell
    blank = np.ones((rows + 2, grid.cols), dtype=bool)  # where a name hides nothing: walls, margins
    blank[1:-1] = ~space.free
    spots = {}
    for index, room in enumerate(space.rooms):
        candidates: list[tuple[int, int, int, int, int]] = []  # (exclusive, length, above, row, left)
        mine = owner == index
        for direction, above in ((-1, 1), (1, 0)):
            side = np.zeros_like(mine)  # the blank cells next to the room on this side
            if direction < 0:
                side[:-1] = mine[1:]
            else:
                side[1:] = mine[:-1]
            side &= blank
            for r in np.flatnonzero(side.any(axis=1)).tolist():
                beyond = r + direction
                for left, right in _runs(side[r]):
                    others = owner[beyond, left:right] if 0 <= beyond < rows + 2 else np.full(right - left, -1)
                    exclusive = int(not ((others >= 0) & (others != index)).any())
                    candidates.append((exclusive, right - left, above, r, left))
        if candidates:
            _, length, _, row, left = max(candidates, key=lambda t: (t[0], t[1], t[2], -t[3], -t[4]))
            on_wall = 0 < row <= rows
            spots[room] = NameSpot(float(row - 1), float(left), float(left + length), on_wall)
    return spots


def _runs(flags: np.ndarray) -> list[tuple[int, int]]:
    """``[start, end)`` of every run of True in a 1-D array."""
    padded = np.concatenate([[False], flags, [False]]).astype(np.int8)
    edges = np.flatnonzero(np.diff(padded))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def _draw_room_names(ax: Any, space: SearchSpace, grid: Canvas, cell_pts: float) -> None:
    """Each room's name at its spot: light on a wall, dark on the blank page, centred over its run
    on a map, from the room's left edge on a plane of rooms, next to the room it names."""
    for room, spot in name_spots(space).items():
        width_pts = (spot.right - spot.left) * cell_pts
        size = min(9.0, max(5.0, width_pts / (0.62 * max(len(room), 1))), 0.8 * cell_pts)
        x, ha = ((spot.left + spot.right) / 2, "center") if grid.on_map else (spot.left + 0.05, "left")
        if spot.on_wall:
            y, va, colour = spot.row + 0.5, "center", "white"
        elif spot.row < grid.rows:  # above its room, hugging it
            y, va, colour = spot.row + 0.92, "bottom", "black"
        else:  # in the margin under the map
            y, va, colour = spot.row + 0.08, "top", "black"
        ax.text(x, y, room, ha=ha, va=va, fontsize=size, color=colour, weight="bold", zorder=_Z_TEXT)


# --- the bar chart ------------------------------------------------------------------------------


def room_belief(space: SearchSpace, belief: np.ndarray) -> np.ndarray:
    """The cell belief summed over each room's cells (axis: ``space.rooms``)."""
    return np.bincount(space.room_of_cell, weights=belief, minlength=len(space.rooms))


def draw_room_bars(ax: Any, space: SearchSpace, record: SearchRecord, belief: np.ndarray) -> None:
    """Per room, the knowledge base's room prior (hatched) and ``belief`` summed over the room
    (solid), as horizontal bars with their values, the first room at the top."""
    n = len(space.rooms)
    y = np.arange(n, dtype=np.float64)
    prior = np.asarray(record.room_prior, dtype=np.float64)
    now = room_belief(space, belief)
    height = 0.38
    if len(prior) == n:
        ax.barh(
            y - height / 2,
            prior,
            height,
            color=PRIOR_COLOUR,
            edgecolor="black",
            linewidth=0.6,
            hatch="//",
            label="room prior (knowledge base)",
        )
    ax.barh(
        y + height / 2,
        now,
        height,
        color=ROOM_BELIEF_COLOUR,
        edgecolor="black",
        linewidth=0.6,
        label="belief summed over the room",
    )
    for k in range(n):
        if len(prior) == n:
            ax.text(prior[k] + 0.02, y[k] - height / 2, f"{prior[k]:.3f}", va="center", fontsize=_FONT - 1)
        ax.text(now[k] + 0.02, y[k] + height / 2, f"{now[k]:.3f}", va="center", fontsize=_FONT - 1)
    names = [room if space.accessible[k] else f"{room}\n(closed)" for k, room in enumerate(space.rooms)]
    ax.set_yticks(y, names)
    ax.set_ylim(n - 0.4, -0.6)
    ax.set_xlim(0.0, 1.25)
    ax.set_xticks([0.0, 0.5, 1.0])
    ax.tick_params(labelsize=_FONT)
    ax.set_xlabel("probability of the room", fontsize=_FONT)
    ax.set_title("rooms", fontsize=_FONT + 1)
    for side in ("top", "right"):
        ax.spines[side].set_visible(False)
