"""A belief as a picture (PNG or SVG): the map, its rooms and landmarks, and the belief drawn as
Colledanchise et al.'s Fig. 5 -- every cell split into one triangle per heading -- in map-frame metres.

Everything is drawn in the **map frame** (ROS ``map``: x east, y north, metres, axes equal), also
for a grid whose frame is rotated: cells, triangles and the occupancy image are then drawn rotated.

* **The map.** The occupancy image when the map has one (free white, occupied black, unknown
  mid-grey), placed by its origin; otherwise the grid's blocked cells, hatched grey.
* **Rooms.** A dashed line along the border of each room's cells, the name at the cell deepest
  inside the room.
* **Landmarks.** One marker shape per class (white with a black edge), listed in the legend.
* **The belief.** A state is a triangle of its cell pointing at its heading: 4 headings split the
  cell along its diagonals; 8 headings give an octagon of 8 triangles (the cell's corners stay
  blank); one heading fills a square. The shade is the state's probability on reversed viridis from
  0 (light yellow) to ``vmax`` (dark purple; default the largest probability): more is darker, on
  a perceptually uniform scale, with a colour bar labelled "probability". A probability of exactly 0
  is left unshaded. On small grids every triangle has a thin outline, so the split shows.
* **The most likely state** (:func:`beliefloc.pose.belief_pose`): a red arrow at its cell centre
  along its heading (a red ring with headings 1, where the yaw is unknown).

Every artist is one collection or one image, whatever the size of the map: a 10^5-state belief
is one ``PolyCollection``. matplotlib itself is reached only through :mod:`beliefloc.render.figures`.

The functions here only observe a model and a belief: they draw on an axes or yield a figure, and
the caller writes it (:func:`beliefloc.render.figures.save_figure`).
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from contextlib import AbstractContextManager, contextmanager
from typing import TYPE_CHECKING, Any

import numpy as np

from beliefloc.model import GridLayout, Model
from beliefloc.render.drawing import COMPASS
from beliefloc.render.figures import add_image, add_polygons, figure

if TYPE_CHECKING:
    from matplotlib.figure import Figure  # types only: matplotlib is imported by render/figures.py

    from beliefloc.planning.best_first import PlanResult
    from beliefloc.semantic_map import SemanticMap

CMAP = "viridis_r"
"""More probability is darker; perceptually uniform, and readable by most colour-blind readers."""
MOST_LIKELY_COLOUR = "#d62728"
"""Red, as the current state is in the paper's Fig. 5."""
MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*", "h", "<", ">", "p", "8", "d", "H")
"""A landmark class's marker, in the order the classes first appear; shapes repeat past 15 classes."""
OUTLINE_CELLS = 1600
"""Grids of at most this many cells draw every triangle's outline and the cell borders."""
RASTERIZE_POLYGONS = 20_000
"""More triangles than this are rasterized in an SVG (a few hundred KB instead of tens of MB)."""
WIDE = 0.75
"""A map whose height / width is below this gets its colour bar and legend under it, else beside it."""
_AXES_INCHES = 6.0
"""The longer side of the map's axes."""
_LEGEND_COLUMNS = 3
_CAPTION_LINE = 0.16
"""Inches per caption line (8-point type)."""
_MIN_AXES_INCHES = 1.6
_MARKER_POINTS = 8.4
"""A landmark marker's width at most (points)."""
_PATH_STYLES: dict[str, dict[str, Any]] = {
    "plan": {"color": "#1f77b4", "linestyle": "-", "marker": "o", "label": "planned path"},
    "true": {"color": "black", "linestyle": "--", "marker": "s", "label": "true path"},
    "robot": {"color": "#ff7f0e", "linestyle": ":", "marker": "D", "label": "robot's estimate"},
}
_FREE, _UNKNOWN, _OCCUPIED = 1.0, 0.5, 0.0
_LEGEND_ATTR = "_beliefloc_legend"
_Z_MAP, _Z_BLOCKED, _Z_BELIEF, _Z_GRID, _Z_ROOMS, _Z_MARKS, _Z_PATH, _Z_POSE, _Z_TEXT = range(9)


# --- geometry: where a state is drawn ------------------------------------------------------------


def state_polygons(grid: GridLayout, states: np.ndarray | Sequence[int]) -> np.ndarray:
    """Map-frame vertices of each state's shape, an array ``(n, 4, 2)``.

    A state ``(r, c, h)`` of ``H`` headings is the part of its cell seen from the centre between the
    directions ``90° - 360° h / H ± 180° / H`` (grid frame; heading 0 up the grid, clockwise): with 4
    headings the triangle between the centre and a side (the cell split along its diagonals); with 8
    a thin triangle towards a side's middle, or towards a corner a kite that reaches into the corner,
    so that the 8 shapes tile the cell. Vertices: the centre, where the sector's edges leave the cell,
    and the corner between them (the centre again for a triangle). With headings 1, the cell's square.
    """
    states = np.asarray(states, dtype=np.int64).ravel()
    row, col, heading = grid.cell_heading(states)
    half = grid.cell_size / 2.0
    cx = (col + 0.5) * grid.cell_size
    cy = (grid.rows - row - 0.5) * grid.cell_size
    if grid.headings == 1:
        offsets = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]]) * half
        gx = cx[:, None] + offsets[None, :, 0]
        gy = cy[:, None] + offsets[None, :, 1]
    else:
        sector = 2 * math.pi / grid.headings
        centre = math.pi / 2 - sector * heading.astype(np.float64)
        edges = []
        for side in (1.0, -1.0):  # counter-clockwise edge first: the polygon runs clockwise
            angle = centre + side * sector / 2
            c, s = np.cos(angle), np.sin(angle)
            scale = half / np.maximum(np.abs(c), np.abs(s))  # where the ray leaves the square
            edges.append((c * scale, s * scale))
        c, s = np.cos(centre), np.sin(centre)
        diagonal = np.isclose(np.abs(c), np.abs(s))  # 8 headings: the sector holds a corner
        zero = np.zeros_like(cx)
        third_x = np.where(diagonal, np.sign(c) * half, 0.0)
        third_y = np.where(diagonal, np.sign(s) * half, 0.0)
        dx = np.stack([zero, edges[0][0], third_x, edges[1][0]], axis=1)
        dy = np.stack([zero, edges[0][1], third_y, edges[1][1]], axis=1)
        # a triangle: centre, edge, centre, edge would cross itself; repeat the last edge point instead
        dx[~diagonal, 2], dy[~diagonal, 2] = dx[~diagonal, 3], dy[~diagonal, 3]
        gx, gy = cx[:, None] + dx, cy[:, None] + dy
    x, y = grid.frame.to_map(gx, gy)
    return np.stack([x, y], axis=2)


def state_centroid(grid: GridLayout, state: int) -> tuple[float, float]:
    """Map-frame metres of the centroid of ``state``'s shape (:func:`state_polygons`): the point a
    test looks at to read the state's shade off a picture."""
    vertices = state_polygons(grid, [state])[0]
    x, y = vertices[:, 0], vertices[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y  # the shoelace formula (a repeated vertex adds nothing)
    area = cross.sum() / 2.0
    return float(((x + xn) * cross).sum() / (6 * area)), float(((y + yn) * cross).sum() / (6 * area))


def _corners(grid: GridLayout) -> tuple[np.ndarray, np.ndarray]:
    """Map-frame x and y of the grid's four outer corners."""
    w, h = grid.cols * grid.cell_size, grid.rows * grid.cell_size
    return grid.frame.to_map(np.array([0.0, w, w, 0.0]), np.array([0.0, 0.0, h, h]))


def _extent(grid: GridLayout, smap: SemanticMap | None) -> tuple[float, float, float, float]:
    """``(xmin, xmax, ymin, ymax)`` in map-frame metres: what is known of the map -- the free cells
    and the occupancy image's free and occupied pixels (unknown space all around a SLAM map is left
    out) -- with a margin of 3 %."""
    s = grid.cell_size
    rows = np.flatnonzero(grid.free.any(axis=1))
    cols = np.flatnonzero(grid.free.any(axis=0))
    if len(rows) == 0:
        gx0, gx1, gy0, gy1 = 0.0, grid.cols * s, 0.0, grid.rows * s
    else:
        gx0, gx1 = cols[0] * s, (cols[-1] + 1) * s
        gy0, gy1 = (grid.rows - rows[-1] - 1) * s, (grid.rows - rows[0]) * s
    occupancy = smap.occupancy_map if smap is not None else None
    if occupancy is not None:
        from beliefloc.semantic_map.occupancy_map import Occupancy

        known = occupancy.pixels != Occupancy.UNKNOWN
        i = np.flatnonzero(known.any(axis=1))
        j = np.flatnonzero(known.any(axis=0))
        if len(i):
            res, height = occupancy.resolution, occupancy.height
            # the image and the grid share the grid frame (origin at the image's lower-left corner)
            gx0, gx1 = min(gx0, j[0] * res), max(gx1, (j[-1] + 1) * res)
            gy0, gy1 = min(gy0, (height - i[-1] - 1) * res), max(gy1, (height - i[0]) * res)
    margin = 0.03 * max(gx1 - gx0, gy1 - gy0)
    gx0, gx1, gy0, gy1 = gx0 - margin, gx1 + margin, gy0 - margin, gy1 + margin
    xs, ys = grid.frame.to_map(np.array([gx0, gx1, gx1, gx0]), np.array([gy0, gy0, gy1, gy1]))
    return float(xs.min()), float(xs.max()), float(ys.min()), float(ys.max())


def _scale(grid: GridLayout, extent: tuple[float, float, float, float]) -> float:
    """The length of a pose arrow: 0.7 of a cell, or a 30th of the map when cells are tiny."""
    span = max(extent[1] - extent[0], extent[3] - extent[2])
    return max(0.7 * grid.cell_size, span / 30.0)


# --- the public drawing functions -----------------------------------------------------------------


def draw_belief(
    ax: Any,
    model: Model,
    belief: np.ndarray,
    *,
    smap: SemanticMap | None = None,
    colorbar: bool = True,
    vmax: float | None = None,
) -> None:
    """Draw ``model``'s map (``smap``'s occupancy image, rooms and landmarks when given) and
    ``belief`` on ``ax``: a triangle per state shaded by its probability, the most likely state as
    a red arrow, a colour bar labelled "probability" (``colorbar``) on the scale 0..``vmax`` (default:
    the belief's largest probability; pass the same ``vmax`` to every frame of an animation), a
    legend. Raises ValueError when the model has no grid."""
    grid = _grid(model)
    b = np.asarray(belief, dtype=np.float64)
    if b.shape != (model.n_states,):
        raise ValueError(f"a belief over {model.n_states} states was expected, got shape {b.shape}")
    extent = _extent(grid, smap)
    below = (extent[3] - extent[2]) < WIDE * (extent[1] - extent[0])
    ax.set_aspect("equal")
    occupancy = smap.occupancy_map if smap is not None else None
    if occupancy is not None:
        _draw_occupancy(ax, occupancy)
    else:
        _draw_blocked(ax, grid)
    top = float(b.max()) if vmax is None else float(vmax)
    shading = _draw_states(ax, grid, b, top if top > 0 else 1.0)
    if smap is not None:
        _draw_rooms(ax, grid, smap)
    _draw_landmarks(ax, grid, smap, extent)
    _draw_most_likely(ax, model, b, extent)
    ax.set_xlim(extent[0], extent[1])
    ax.set_ylim(extent[2], extent[3])
    ax.set_xlabel("x (m, map frame)")
    ax.set_ylabel("y (m, map frame)")
    if colorbar:
        bar = ax.figure.colorbar(
            shading, ax=ax, location="bottom" if below else "right", shrink=0.6 if below else 0.8, aspect=30
        )
        bar.set_label("probability")
    _legend(ax)


def draw_path(
    ax: Any, grid: GridLayout, states: Sequence[int], *, style: str = "plan", label: str | None = None
) -> None:
    """The cells of ``states`` (in order) joined by a line through their centres, with an arrow at
    the end along the last state's heading (along the last move with headings 1). ``style``:
    ``"plan"`` (a solid blue line), ``"true"`` (dashed black: the simulated robot's true states) or
    ``"robot"`` (dotted orange: the robot's most likely states); each has its own marker and
    legend entry (``label`` overrides the entry's text)."""
    if style not in _PATH_STYLES:
        raise ValueError(f"unknown path style {style!r}; expected one of {', '.join(_PATH_STYLES)}")
    if len(states) == 0:
        return
    spec = _PATH_STYLES[style]
    row, col, heading = grid.cell_heading(np.asarray(states, dtype=np.int64))
    x, y = grid.cell_centre(row, col)
    x, y = np.atleast_1d(x), np.atleast_1d(y)
    keep = np.ones(len(x), dtype=bool)  # a rotation stays in the cell: one vertex per visit
    keep[1:] = (np.diff(x) != 0) | (np.diff(y) != 0)
    px, py = x[keep], y[keep]
    ax.plot(
        px,
        py,
        color=spec["color"],
        linestyle=spec["linestyle"],
        linewidth=2.0,
        marker=spec["marker"],
        markersize=4,
        zorder=_Z_PATH,
        label=label or spec["label"],
    )
    length = 0.6 * grid.cell_size
    if grid.headings > 1:
        yaw = float(grid.heading_yaw(int(heading[-1])))
    elif len(px) > 1:
        yaw = math.atan2(py[-1] - py[-2], px[-1] - px[-2])
    else:
        return
    _arrow(
        ax, float(px[-1]), float(py[-1]), yaw, length, facecolor=spec["color"], edgecolor=spec["color"], zorder=_Z_PATH
    )
    _legend(ax)


def mark_pose(ax: Any, grid: GridLayout, state: int, *, label: str) -> None:
    """An arrow at ``state``'s pose -- its cell's centre, along its heading -- white with a thick
    black edge (the most likely state's arrow is red), listed in the legend as ``label``. With
    headings 1 (no yaw) a white square marker with a black edge instead."""
    from beliefloc.pose import state_pose

    pose = state_pose(grid, int(state))
    length = max(0.7 * grid.cell_size, _span(ax) / 30.0)
    if grid.headings == 1:
        ax.plot(
            [pose.x],
            [pose.y],
            marker="s",
            markersize=11,
            markerfacecolor="white",
            markeredgecolor="black",
            markeredgewidth=2,
            linestyle="none",
            zorder=_Z_POSE,
            label=label,
        )
    else:
        _arrow(ax, pose.x, pose.y, pose.yaw, length, facecolor="white", edgecolor="black", label=label, width=1.6)
    _legend(ax)


@contextmanager
def _belief_figure(
    model: Model,
    belief: np.ndarray,
    *,
    smap: SemanticMap | None = None,
    title: str | None = None,
    caption: str | None = None,
    legend_extra: int = 0,
) -> Iterator[Figure]:
    grid = _grid(model)
    extent = _extent(grid, smap)
    caption_lines = 0 if caption is None else caption.count("\n") + 1
    entries = _legend_entries(grid, smap) + legend_extra
    width, height, _ = figure_size(extent, caption_lines, entries)
    with figure(width, height) as fig:
        fig.set_layout_engine("constrained")
        part: Any = fig
        if caption is not None:  # the map (legend included) above, the caption in a part of its own
            below = caption_lines * _CAPTION_LINE + 0.3
            parts: Any = fig.subfigures(2, 1, height_ratios=[height - below, below])
            part, under = parts[0], parts[1]
            under.text(0.03, 1.0, caption, family="monospace", fontsize=8, va="top", ha="left")
        ax = part.add_subplot()
        draw_belief(ax, model, belief, smap=smap)
        part.suptitle(title if title is not None else f"{model.name}: belief over {model.n_states} states")
        yield fig


def _legend_entries(grid: GridLayout, smap: SemanticMap | None) -> int:
    """How many entries :func:`draw_belief`'s legend will have (for the figure's size)."""
    classes = {lm.class_ for lm in smap.landmarks} if smap is not None else {cls for cls, _, _ in grid.landmarks}
    has_image = smap is not None and smap.occupancy_map is not None
    rooms = 1 if smap is not None and smap.rooms else 0
    blocked = 1 if not grid.free.all() else 0
    return len(classes) + 1 + rooms + (3 if has_image else blocked)


def belief_figure(
    model: Model,
    belief: np.ndarray,
    *,
    smap: SemanticMap | None = None,
    title: str | None = None,
    caption: str | None = None,
) -> AbstractContextManager[Figure]:
    """A figure of ``belief`` on ``model``'s map (:func:`draw_belief` with a colour bar and legend),
    sized from the map's aspect ratio, closed when the ``with`` block ends. The map's axes are
    ``fig.axes[0]`` (draw paths and poses on it). ``title`` defaults to the model's name and size;
    ``caption`` is written under the axes in a fixed-width font (a table, say)."""
    return _belief_figure(model, belief, smap=smap, title=title, caption=caption)


def figure_size(
    extent: tuple[float, float, float, float], caption_lines: int = 0, legend_entries: int = 6
) -> tuple[float, float, bool]:
    """``(width, height, below)`` in inches for a map spanning ``extent`` (map-frame metres): the
    map's longer side 6 inches (the shorter at least 1.6), and room for the axis labels, the title,
    the colour bar -- under the map when it is wide (``below``), beside it otherwise --, the legend
    under everything (``legend_entries`` entries, three a line) and ``caption_lines`` lines of caption."""
    dx, dy = max(extent[1] - extent[0], 1e-9), max(extent[3] - extent[2], 1e-9)
    below = dy < WIDE * dx
    if dx >= dy:
        aw, ah = _AXES_INCHES, max(_MIN_AXES_INCHES, _AXES_INCHES * dy / dx)
    else:
        aw, ah = max(_MIN_AXES_INCHES, _AXES_INCHES * dx / dy), _AXES_INCHES
    legend = 0.2 * math.ceil(legend_entries / _LEGEND_COLUMNS) + 0.15
    width, height = (aw + 1.0, ah + 1.9) if below else (aw + 2.1, ah + 1.0)
    height += legend + (caption_lines * _CAPTION_LINE + 0.3 if caption_lines else 0.0)
    return width, height, below


# --- the plan drawn on the start belief ---------------------------------------------------------


def expected_states(model: Model, start: int, actions: Sequence[str]) -> list[int]:
    """The state after each of ``actions`` from ``start`` when every move goes as intended: the
    noise-free successor, ``argmax_j T_a[i, j]`` (the lowest such j on ties); a perception action
    leaves the state as it is. Returns ``[start, s_1, ..., s_n]``."""
    states = [int(start)]
    for name in actions:
        action = model.action(name)
        state = states[-1]
        if action.transition is not None:
            matrix = action.transition
            lo, hi = int(matrix.indptr[state]), int(matrix.indptr[state + 1])
            columns, weights = matrix.indices[lo:hi], matrix.data[lo:hi]
            if len(columns):
                best = weights.max()
                state = int(columns[weights == best].min())
        states.append(state)
    return states


def plan_caption(result: PlanResult) -> str:
    """The plan's steps as a fixed-width table: step, action, expected observation, max belief, cost."""
    rows = [("step", "action", "expected observation", "max belief", "cost")]
    for i, step in enumerate(result.steps, start=1):
        observation = step.observation if step.observation is not None else "-"
        rows.append((str(i), step.action, observation, f"{step.max_belief:.3f}", f"{step.cost:g}"))
    widths = [max(len(row[k]) for row in rows) for k in range(5)]
    lines = []
    for row in rows:
        cells = [row[k].rjust(widths[k]) if k in (0, 3, 4) else row[k].ljust(widths[k]) for k in range(5)]
        lines.append("  ".join(cells).rstrip())
    return "\n".join(lines)


@contextmanager
def _plan_figure(
    model: Model,
    belief: np.ndarray,
    result: PlanResult,
    *,
    smap: SemanticMap | None = None,
    title: str | None = None,
) -> Iterator[Figure]:
    from beliefloc.pose import belief_pose

    grid = _grid(model)
    start = belief_pose(model, belief).state
    actions = [step.action for step in result.steps]
    states = expected_states(model, start, actions)
    caption = plan_caption(result) if result.steps else "no steps: the start belief is already localized"
    with _belief_figure(model, belief, smap=smap, title=title, caption=caption, legend_extra=2) as fig:
        ax = fig.axes[0]
        if actions:
            draw_path(ax, grid, states, style="plan", label="planned moves from the most likely state")
            _mark_perceptions(ax, model, grid, states, actions)
        yield fig


def plan_figure(
    model: Model,
    belief: np.ndarray,
    result: PlanResult,
    *,
    smap: SemanticMap | None = None,
    title: str | None = None,
) -> AbstractContextManager[Figure]:
    """The start ``belief`` (:func:`belief_figure`) with ``result``'s plan drawn on it: the moves as a
    path from the most likely state (:func:`expected_states`), every perception marked where it is
    made and numbered by its step, and the step table as a caption under the map."""
    return _plan_figure(model, belief, result, smap=smap, title=title)


def _mark_perceptions(ax: Any, model: Model, grid: GridLayout, states: list[int], actions: list[str]) -> None:
    """A hollow star where each perception is made, with the steps made there ("2,4")."""
    at: dict[int, list[int]] = {}
    for step, name in enumerate(actions, start=1):
        if not model.action(name).is_actuation:
            at.setdefault(states[step], []).append(step)
    if not at:
        return
    where = sorted(at, key=lambda s: at[s][0])
    row, col, _ = grid.cell_heading(np.asarray(where, dtype=np.int64))
    x, y = grid.cell_centre(row, col)
    ax.plot(
        x,
        y,
        linestyle="none",
        marker="*",
        markersize=16,
        markerfacecolor="none",
        markeredgecolor="#1f77b4",
        markeredgewidth=1.8,
        zorder=_Z_POSE,
        label="perception (its steps)",
    )
    offset = 0.3 * grid.cell_size
    for state, px, py in zip(where, np.atleast_1d(x), np.atleast_1d(y), strict=True):
        ax.text(
            float(px) + offset,
            float(py) + offset,
            ",".join(str(s) for s in at[state]),
            fontsize=8,
            color="#1f77b4",
            weight="bold",
            zorder=_Z_TEXT,
            bbox={"boxstyle": "round,pad=0.15", "facecolor": "white", "edgecolor": "none", "alpha": 0.85},
        )
    _legend(ax)


# --- the parts of draw_belief ---------------------------------------------------------------------


def _grid(model: Model) -> GridLayout:
    if model.grid is None:
        raise ValueError(f"model {model.name!r} has no grid to draw")
    return model.grid


def _span(ax: Any) -> float:
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    return float(max(abs(x1 - x0), abs(y1 - y0)))


def _draw_occupancy(ax: Any, occupancy: Any) -> None:
    from beliefloc.semantic_map.occupancy_map import Occupancy

    greys = np.full(occupancy.pixels.shape, _UNKNOWN, dtype=np.float32)
    greys[occupancy.pixels == Occupancy.FREE] = _FREE
    greys[occupancy.pixels == Occupancy.OCCUPIED] = _OCCUPIED
    width, height = occupancy.size_m
    frame = occupancy.frame
    add_image(ax, greys, width=width, height=height, x=frame.x, y=frame.y, yaw=frame.yaw, zorder=_Z_MAP)
    for value, name in ((_FREE, "free"), (_OCCUPIED, "occupied"), (_UNKNOWN, "unknown")):
        ax.scatter([], [], marker="s", s=60, color=str(value), edgecolors="black", linewidths=0.5, label=name)


def _draw_blocked(ax: Any, grid: GridLayout) -> None:
    blocked = np.flatnonzero(~grid.free.ravel())
    if len(blocked):
        row, col = np.divmod(blocked, grid.cols)
        add_polygons(
            ax,
            _cell_squares(grid, row, col),
            facecolor="#9a9a9a",
            edgecolor="#4d4d4d",
            linewidth=0.0,
            hatch="///",
            zorder=_Z_BLOCKED,
            rasterized=len(blocked) > RASTERIZE_POLYGONS,
            label="blocked cell",
        )
    xs, ys = _corners(grid)
    ax.plot([*xs, xs[0]], [*ys, ys[0]], color="black", linewidth=1.0, zorder=_Z_GRID)


def _cell_squares(grid: GridLayout, row: np.ndarray, col: np.ndarray) -> np.ndarray:
    s = grid.cell_size
    gx0, gy0 = col * s, (grid.rows - row - 1) * s
    gx = np.stack([gx0, gx0 + s, gx0 + s, gx0], axis=1)
    gy = np.stack([gy0, gy0, gy0 + s, gy0 + s], axis=1)
    x, y = grid.frame.to_map(gx, gy)
    return np.stack([x, y], axis=2)


def _draw_states(ax: Any, grid: GridLayout, belief: np.ndarray, vmax: float) -> Any:
    """One collection of every state's triangle; returns it (the colour bar's mappable)."""
    small = grid.rows * grid.cols <= OUTLINE_CELLS
    states = np.arange(len(belief)) if small else np.flatnonzero(belief > 0.0)
    values = np.ma.masked_equal(belief[states], 0.0)  # exactly 0: transparent, unshaded
    collection = add_polygons(
        ax,
        state_polygons(grid, states),
        values=values,
        cmap=CMAP,
        vmin=0.0,
        vmax=vmax,
        edgecolor="#bdbdbd" if small else "none",
        linewidth=0.4 if small else 0.0,
        zorder=_Z_BELIEF,
        rasterized=len(states) > RASTERIZE_POLYGONS,
    )
    if small:
        _draw_cell_borders(ax, grid)
    return collection


def _draw_cell_borders(ax: Any, grid: GridLayout) -> None:
    """Every cell's border as one line (NaN-separated segments)."""
    w, h = grid.cols * grid.cell_size, grid.rows * grid.cell_size
    segments: list[tuple[float, float, float, float]] = []
    for c in range(grid.cols + 1):
        segments.append((c * grid.cell_size, 0.0, c * grid.cell_size, h))
    for r in range(grid.rows + 1):
        segments.append((0.0, r * grid.cell_size, w, r * grid.cell_size))
    _segments(ax, grid, np.array(segments), color="#8c8c8c", linewidth=0.6, zorder=_Z_GRID)


def _segments(ax: Any, grid: GridLayout, segments: np.ndarray, label: str | None = None, **style: Any) -> None:
    """Grid-frame segments ``(x0, y0, x1, y1)`` drawn as one map-frame line with NaN breaks."""
    if len(segments) == 0:
        return
    x0, y0 = grid.frame.to_map(segments[:, 0], segments[:, 1])
    x1, y1 = grid.frame.to_map(segments[:, 2], segments[:, 3])
    gap = np.full(len(segments), np.nan)
    xs = np.stack([x0, x1, gap], axis=1).ravel()
    ys = np.stack([y0, y1, gap], axis=1).ravel()
    ax.plot(xs, ys, label=label, solid_capstyle="butt", **style)


def _draw_rooms(ax: Any, grid: GridLayout, smap: SemanticMap) -> None:
    rooms = smap.rooms
    if not rooms:
        return
    s = grid.cell_size
    segments = []
    for mask in rooms.values():
        padded = np.pad(mask, 1)
        # horizontal borders: between grid rows r-1 and r (padded rows r and r+1)
        r, c = np.nonzero(padded[:-1, 1:-1] != padded[1:, 1:-1])
        y = (grid.rows - r) * s
        segments.append(np.stack([c * s, y, (c + 1) * s, y], axis=1))
        # vertical borders: between columns c-1 and c
        r, c = np.nonzero(padded[1:-1, :-1] != padded[1:-1, 1:])
        y0 = (grid.rows - r - 1) * s
        segments.append(np.stack([c * s, y0, c * s, y0 + s], axis=1))
    _segments(
        ax,
        grid,
        np.concatenate(segments).astype(np.float64),
        label="room border",
        color="#c51b7d",
        linewidth=2.0,
        linestyle=(0, (4, 2)),
        zorder=_Z_ROOMS,
    )
    for name, mask in rooms.items():
        deep_row, deep_col = _deepest_cell(mask)
        x, y = grid.cell_centre(deep_row, deep_col)
        ax.text(
            float(x),
            float(y),
            name,
            ha="center",
            va="center",
            fontsize=8,
            weight="bold",
            color="#8e0152",
            zorder=_Z_TEXT,
            bbox={"boxstyle": "round,pad=0.2", "facecolor": "white", "edgecolor": "#c51b7d", "alpha": 0.85},
        )


def _deepest_cell(mask: np.ndarray) -> tuple[int, int]:
    """The room's cell farthest (in cell steps, 4-neighbours) from its border, nearest the room's
    centroid among those: where its name goes, inside the room even when the room is not convex."""
    inside = mask.copy()
    last = inside
    while inside.any():
        last = inside
        padded = np.pad(inside, 1)
        inside = inside & padded[:-2, 1:-1] & padded[2:, 1:-1] & padded[1:-1, :-2] & padded[1:-1, 2:]
    rows, cols = np.nonzero(last)
    all_rows, all_cols = np.nonzero(mask)
    distance = (rows - all_rows.mean()) ** 2 + (cols - all_cols.mean()) ** 2
    k = int(np.argmin(distance))
    return int(rows[k]), int(cols[k])


def _landmark_points(grid: GridLayout, smap: SemanticMap | None) -> dict[str, list[tuple[float, float]]]:
    """Map-frame metres of every landmark by class: where the map file put it, else its cell's
    centre -- moved apart when several share a cell."""
    entries: list[tuple[str, tuple[int, int], tuple[float, float] | None]] = []
    if smap is not None:
        entries = [(lm.class_, (lm.cell[0], lm.cell[1]), lm.position) for lm in smap.landmarks]
    else:
        entries = [(cls, (r, c), None) for cls, r, c in grid.landmarks]
    in_cell: dict[tuple[int, int], int] = {}
    for _, cell, position in entries:
        if position is None:
            in_cell[cell] = in_cell.get(cell, 0) + 1
    seen: dict[tuple[int, int], int] = {}
    points: dict[str, list[tuple[float, float]]] = {}
    for cls, cell, position in entries:
        if position is None:
            k, n = seen.get(cell, 0), in_cell[cell]
            seen[cell] = k + 1
            gx = (cell[1] + 0.5 + (0.0 if n == 1 else 0.5 * ((k + 0.5) / n - 0.5))) * grid.cell_size
            gy = (grid.rows - cell[0] - 0.5) * grid.cell_size
            x, y = grid.frame.to_map(gx, gy)
            position = (float(x), float(y))
        points.setdefault(cls, []).append(position)
    return points


def _draw_landmarks(ax: Any, grid: GridLayout, smap: SemanticMap | None, extent: tuple[float, ...]) -> None:
    """A marker per landmark, one shape per class: ``_MARKER_POINTS`` wide, smaller when there are
    so many that they would cover the belief (at most 70 % of the mean spacing between landmarks,
    ``sqrt(area / count)``); the legend shows each shape at full size."""
    points_by_class = _landmark_points(grid, smap)
    count = sum(len(points) for points in points_by_class.values())
    if count == 0:
        return
    dx, dy = extent[1] - extent[0], extent[3] - extent[2]
    metres_px = min(ax.bbox.width / dx, ax.bbox.height / dy)  # the axes before the layout: near enough
    spacing_points = math.sqrt(dx * dy / count) * metres_px * 72.0 / ax.figure.dpi
    size = min(_MARKER_POINTS, max(2.5, 0.7 * spacing_points))
    for k, (cls, points) in enumerate(points_by_class.items()):
        xy = np.array(points)
        style = {
            "marker": MARKERS[k % len(MARKERS)],
            "facecolors": "white",
            "edgecolors": "black",
            "zorder": _Z_MARKS,
        }
        ax.scatter(xy[:, 0], xy[:, 1], s=size**2, linewidths=1.4 * size / _MARKER_POINTS, **style)
        ax.scatter([], [], s=_MARKER_POINTS**2, linewidths=1.4, label=cls.replace("_", " "), **style)


def _draw_most_likely(ax: Any, model: Model, belief: np.ndarray, extent: tuple[float, float, float, float]) -> None:
    from beliefloc.pose import belief_pose

    if not belief.sum() > 0:
        return
    grid = _grid(model)
    estimate = belief_pose(model, belief)
    pose = estimate.pose
    name = model.states.name(estimate.state)
    add_polygons(  # the state's own triangle (square) outlined, as the paper's red triangle
        ax,
        state_polygons(grid, [estimate.state]),
        facecolor="none",
        edgecolor=MOST_LIKELY_COLOUR,
        linewidth=2.0,
        zorder=_Z_POSE,
    )
    if grid.headings == 1:
        label = f"most likely state {name} (p={estimate.probability:.3g})"
        ax.plot(
            [pose.x],
            [pose.y],
            marker="o",
            markersize=13,
            markerfacecolor="none",
            markeredgecolor=MOST_LIKELY_COLOUR,
            markeredgewidth=2.5,
            linestyle="none",
            zorder=_Z_POSE,
            label=label,
        )
        return
    heading = COMPASS[grid.headings][int(grid.cell_heading(estimate.state)[2])]
    label = f"most likely state {name} {heading} (p={estimate.probability:.3g})"
    _arrow(
        ax, pose.x, pose.y, pose.yaw, _scale(grid, extent), facecolor=MOST_LIKELY_COLOUR, edgecolor="white", label=label
    )


def _arrow(
    ax: Any,
    x: float,
    y: float,
    yaw: float,
    length: float,
    *,
    facecolor: str,
    edgecolor: str,
    label: str | None = None,
    width: float = 1.0,
    zorder: float = _Z_POSE,
) -> None:
    """An arrow from ``(x, y)`` of ``length`` along ``yaw``, starting a little behind the point so
    that the point is in its middle."""
    dx, dy = length * math.cos(yaw), length * math.sin(yaw)
    ax.arrow(
        x - 0.4 * dx,
        y - 0.4 * dy,
        dx,
        dy,
        width=0.09 * length,
        head_width=0.36 * length,
        head_length=0.36 * length,
        length_includes_head=True,
        facecolor=facecolor,
        edgecolor=edgecolor,
        linewidth=width,
        zorder=zorder,
        label=label,
    )


def _legend(ax: Any) -> None:
    """The legend of everything labelled on ``ax``, rebuilt after each addition: the figure's
    legend, under everything (a constrained layout makes room for it), three entries a line."""
    handles, labels = ax.get_legend_handles_labels()
    if not handles:
        return
    fig = ax.figure
    previous = getattr(ax, _LEGEND_ATTR, None)
    if previous is not None and previous in fig.legends:
        previous.remove()
    legend = fig.legend(
        handles, labels, loc="outside lower center", ncol=min(_LEGEND_COLUMNS, len(handles)), fontsize=8, frameon=False
    )
    setattr(ax, _LEGEND_ATTR, legend)
