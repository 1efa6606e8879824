"""Grid geometry, vectorised over states: moves, what a Look sees, how far a Scan reads.

Conventions (also in ``docs/map-format.md``):

* Rows grow downwards (south), columns eastwards. Heading 0 is north and headings count clockwise:
  with 4 headings 0 N, 1 E, 2 S, 3 W; with 8 headings 0 N, 1 NE, 2 E, ... 7 NW.
* States are the free cells in row-major order, times headings: ``state = cell * H + heading``.
* The robot stands at its cell's centre. Distances are between cell centres, in meters.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from beliefloc.model import GridLayout

if TYPE_CHECKING:
    import scipy.sparse as sp

HEADING_VECTORS: dict[int, tuple[tuple[int, int], ...]] = {
    1: ((0, 0),),
    4: ((-1, 0), (0, 1), (1, 0), (0, -1)),
    8: ((-1, 0), (-1, 1), (0, 1), (1, 1), (1, 0), (1, -1), (0, -1), (-1, -1)),
}
COMPASS_MOVES: dict[str, tuple[int, int]] = {"up": (-1, 0), "down": (1, 0), "left": (0, -1), "right": (0, 1)}


def cell_index_map(layout: GridLayout) -> np.ndarray:
    """``index[r, c]`` = the free cell's position in ``layout.free_cells``, or -1 if blocked."""
    index = np.full(layout.rows * layout.cols, -1, dtype=np.int64)
    index[layout.free_cells] = np.arange(len(layout.free_cells))
    return index.reshape(layout.rows, layout.cols)


def motion_targets(layout: GridLayout, motion: str) -> np.ndarray:
    """The intended next state of every state under a noise-free ``motion``. A move into a blocked
    cell, off the grid, or diagonally between two blocked cells that touch at a corner stays put."""
    h_count = layout.headings
    n_cells = len(layout.free_cells)
    heading = np.tile(np.arange(h_count), n_cells)
    cell = np.repeat(np.arange(n_cells), h_count)
    if motion in ("rotate_cw", "rotate_ccw"):
        step = 1 if motion == "rotate_cw" else -1
        return cell * h_count + (heading + step) % h_count
    if motion in COMPASS_MOVES:
        dr_one, dc_one = COMPASS_MOVES[motion]
        dr = np.full(len(cell), dr_one)
        dc = np.full(len(cell), dc_one)
    else:
        vectors = np.array(HEADING_VECTORS[h_count])
        sign = 1 if motion == "forward" else -1
        dr, dc = sign * vectors[heading, 0], sign * vectors[heading, 1]
    index = cell_index_map(layout)
    # the shift depends on the heading, so shift per state: expand cells to states
    row, col = np.divmod(layout.free_cells[cell], layout.cols)
    r2, c2 = row + dr, col + dc
    inside = (r2 >= 0) & (r2 < layout.rows) & (c2 >= 0) & (c2 < layout.cols)
    hit = index[np.where(inside, r2, 0), np.where(inside, c2, 0)]
    open_way = inside & (hit >= 0)
    # a diagonal step between two blocked cells that touch at the corner would go through a wall
    diagonal = open_way & (dr != 0) & (dc != 0)
    side_a = index[np.where(diagonal, r2, 0), np.where(diagonal, col, 0)] >= 0
    side_b = index[np.where(diagonal, row, 0), np.where(diagonal, c2, 0)] >= 0
    open_way &= ~(diagonal & ~side_a & ~side_b)
    target_cell = np.where(open_way, hit, cell)
    return target_cell * h_count + heading


def transition_matrix(targets: np.ndarray, failure: float) -> sp.csr_matrix:
    """``T[i, targets[i]] = 1 - failure`` and ``T[i, i] += failure``: a failed move stays put."""
    import scipy.sparse as sp  # here, not at import: validating a map builds no matrix

    n = len(targets)
    stays = targets == np.arange(n)
    indptr = np.zeros(n + 1, dtype=np.int64)
    per_row = np.where(stays | (failure == 0.0), 1, 2)
    np.cumsum(per_row, out=indptr[1:])
    indices = np.empty(indptr[-1], dtype=np.int32)
    data = np.empty(indptr[-1], dtype=np.float64)
    first = indptr[:-1]
    if failure == 0.0:
        indices[first] = targets
        data[first] = 1.0
    else:
        two = ~stays
        # rows with two entries keep their column indices sorted
        lo = np.minimum(targets, np.arange(n))
        hi = np.maximum(targets, np.arange(n))
        indices[first[two]] = lo[two]
        indices[first[two] + 1] = hi[two]
        target_first = targets[two] < np.arange(n)[two]
        data[first[two]] = np.where(target_first, 1.0 - failure, failure)
        data[first[two] + 1] = np.where(target_first, failure, 1.0 - failure)
        indices[first[stays]] = targets[stays]
        data[first[stays]] = 1.0
    return sp.csr_matrix((data, indices, indptr), shape=(n, n))


def viewing_angles(
    layout: GridLayout,
    landmark: tuple[int, int],
    view_range: float | None,
    fov: float,
    occlusion: bool,
) -> tuple[np.ndarray, np.ndarray]:
    """States that see ``landmark`` and the absolute viewing angle (degrees) from each.

    A landmark is seen from a state when the distance between cell centres is within
    ``view_range`` meters, the bearing is within ``fov / 2`` of the heading (any heading sees its
    own cell), and -- with ``occlusion`` -- no blocked cell lies on the segment between the centres.
    """
    states, angles, _ = viewing_angles_many(layout, np.array([landmark]), view_range, fov, occlusion)
    return states, angles


_CHUNK = 1 << 21
"""About how many (landmark, cell) pairs :func:`viewing_angles_many` handles at once."""
_SAME_TIME = 1e-9
"""Edge crossings closer in time than this are one corner; distinct crossings of segments between
cell centres differ by at least ``1 / (2 span^2)``."""


def viewing_angles_many(
    layout: GridLayout,
    landmarks: np.ndarray,
    view_range: float | None,
    fov: float,
    occlusion: bool,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`viewing_angles` for many landmarks at once (``landmarks[k] = (row, col)``).

    Returns ``(states, angles, which)``: every (state, landmark) pair where the state sees the
    landmark, its viewing angle, and ``which`` = the landmark's position in ``landmarks``.

    Distances and bearings depend only on the offset between cell and landmark, so they are
    computed once per offset in the ``(2 reach + 1)^2`` window; per landmark only clipping at the
    grid's edge, blocked cells and occlusion remain, done for a chunk of landmarks at a time. Time
    and memory are linear in ``landmarks x window``. The results are exactly those of one
    landmark at a time (same arithmetic, element by element).
    """
    landmarks = np.asarray(landmarks, dtype=np.int64).reshape(-1, 2)
    h_count = layout.headings
    empty = np.zeros(0, dtype=np.int64)
    if len(landmarks) == 0:
        return empty, np.zeros(0), empty
    if view_range is None:
        reach_r, reach_c = layout.rows - 1, layout.cols - 1
    else:
        reach = math.floor(view_range / layout.cell_size + 1e-9)
        reach_r = reach_c = reach
    # per offset (dr, dc) from the landmark to the cell: distance, and the relative angle per heading
    dr_grid, dc_grid = np.mgrid[-reach_r : reach_r + 1, -reach_c : reach_c + 1]
    dr_all, dc_all = dr_grid.ravel(), dc_grid.ravel()
    dy, dx = dr_all.astype(float), (-dc_all).astype(float)  # north, east components towards it
    distance = np.hypot(dx, dy) * layout.cell_size
    keep = np.ones(len(dr_all), dtype=bool) if view_range is None else distance <= view_range + 1e-9
    dr_all, dc_all, dx, dy, distance = dr_all[keep], dc_all[keep], dx[keep], dy[keep], distance[keep]
    bearing = np.degrees(np.arctan2(dx, dy))  # clockwise from north
    headings = np.arange(h_count)
    if h_count == 1:
        relative = np.zeros((len(dr_all), 1))
    else:
        relative = (bearing[:, None] - headings[None, :] * (360.0 / h_count) + 180.0) % 360.0 - 180.0
    relative = np.abs(relative)
    relative[distance == 0.0, :] = 0.0
    seen_offset = relative <= fov / 2.0 + 1e-9  # (offsets, headings)
    useful = seen_offset.any(axis=1)
    chebyshev = np.maximum(np.abs(dr_all), np.abs(dc_all))
    check_sight = occlusion and not layout.free.all()
    if not check_sight:  # offsets seen from no heading cannot contribute
        dr_all, dc_all, relative, seen_offset, chebyshev = (
            dr_all[useful],
            dc_all[useful],
            relative[useful],
            seen_offset[useful],
            chebyshev[useful],
        )
    index = cell_index_map(layout)
    width = max(1, len(dr_all))
    step = max(1, _CHUNK // width)
    out_states, out_angles, out_which = [], [], []
    for start in range(0, len(landmarks), step):
        lr = landmarks[start : start + step, 0][:, None]
        lc = landmarks[start : start + step, 1][:, None]
        rr, cc = lr + dr_all[None, :], lc + dc_all[None, :]  # (landmarks, offsets)
        inside = (rr >= 0) & (rr < layout.rows) & (cc >= 0) & (cc < layout.cols)
        cells = np.where(inside, index[np.where(inside, rr, 0), np.where(inside, cc, 0)], -1)
        valid = cells >= 0  # inside the grid, on a free cell, within range
        if check_sight:
            # the original samples each landmark's segments by its farthest candidate cell
            span = np.where(valid, chebyshev[None, :], 0).max(axis=1, initial=0)
            k_idx, o_idx = np.nonzero(valid)
            visible = _line_of_sight_pairs(
                layout.free, rr[k_idx, o_idx], cc[k_idx, o_idx], lr[k_idx, 0], lc[k_idx, 0], span[k_idx]
            )
            k_idx, o_idx = k_idx[visible], o_idx[visible]
            # offsets seen from no heading were kept only for the span; drop them now
            has = seen_offset[o_idx].any(axis=1)
            k_idx, o_idx = k_idx[has], o_idx[has]
        else:
            k_idx, o_idx = np.nonzero(valid)
        seen = seen_offset[o_idx]  # (pairs, headings)
        pair, heading = np.nonzero(seen)
        out_states.append(cells[k_idx[pair], o_idx[pair]] * h_count + heading)
        out_angles.append(relative[o_idx[pair], heading])
        out_which.append(k_idx[pair] + start)
    return np.concatenate(out_states), np.concatenate(out_angles), np.concatenate(out_which)


def _line_of_sight_pairs(
    free: np.ndarray, rr: np.ndarray, cc: np.ndarray, lr: np.ndarray, lc: np.ndarray, span: np.ndarray
) -> np.ndarray:
    """:func:`_line_of_sight` for (cell, landmark) pairs, each landmark sampled by its own ``span``,
    in chunks of about :data:`_CHUNK` (pair, sample) points."""
    visible = np.ones(len(rr), dtype=bool)
    for value in np.unique(span).tolist():
        group = np.flatnonzero(span == value)
        step = max(1, _CHUNK // (2 * int(value) + 1))
        for start in range(0, len(group), step):
            g = group[start : start + step]
            visible[g] = _line_of_sight(free, rr[g], cc[g], lr[g], lc[g], span=int(value))
    return visible


def _line_of_sight(
    free: np.ndarray,
    rr: np.ndarray,
    cc: np.ndarray,
    lr: int | np.ndarray,
    lc: int | np.ndarray,
    span: int | None = None,
) -> np.ndarray:
    """True where the segment between cell centres is clear: it crosses the inside of no blocked
    cell (its two end cells excepted) and passes no cell corner whose two other cells are both
    blocked (a diagonal wall has no gap). Touching a single blocked cell at its corner or edge is
    not crossing it.

    Exact, not sampled: the times at which the segment crosses row and column edges are sorted,
    and the cell in the middle of each stretch between them is checked. A row edge and a column
    edge crossed at the same time are a corner. ``span`` (at least the largest Chebyshev distance
    between the end cells, the default) sets how many edges are listed.
    """
    rr = np.asarray(rr, dtype=np.int64)
    cc = np.asarray(cc, dtype=np.int64)
    lr_all = np.broadcast_to(np.asarray(lr, dtype=np.int64), rr.shape)
    lc_all = np.broadcast_to(np.asarray(lc, dtype=np.int64), cc.shape)
    dr, dc = (lr_all - rr)[:, None], (lc_all - cc)[:, None]
    if span is None:
        span = int(np.max(np.maximum(np.abs(dr), np.abs(dc)), initial=0))
    if span == 0:
        return np.ones(len(rr), dtype=bool)
    # the k-th edge crossed along rows (columns) is crossed at t = (k - 1/2) / |dr|; 1 pads the list
    half = np.arange(1, span + 1)[None, :] - 0.5
    rows_n, cols_n = np.abs(dr), np.abs(dc)
    t_rows = np.where(half < rows_n, half / np.maximum(rows_n, 1), 1.0)
    t_cols = np.where(half < cols_n, half / np.maximum(cols_n, 1), 1.0)
    events = np.sort(np.concatenate([t_rows, t_cols], axis=1), axis=1)
    bounds = np.concatenate([np.zeros((len(rr), 1)), events, np.ones((len(rr), 1))], axis=1)
    start, length = bounds[:, :-1], np.diff(bounds, axis=1)
    stretch = length > _SAME_TIME
    mid = start + length / 2.0
    pr = np.floor(rr[:, None] + mid * dr + 0.5).astype(np.int64)
    pc = np.floor(cc[:, None] + mid * dc + 0.5).astype(np.int64)
    endpoint = ((pr == rr[:, None]) & (pc == cc[:, None])) | ((pr == lr_all[:, None]) & (pc == lc_all[:, None]))
    crossed = stretch & ~endpoint & ~free[pr, pc]
    # corners: the segment goes from cell (k, m) to its diagonal neighbour through the point
    # (k + 1/2, m + 1/2); the two cells beside it there are the other two around that point
    corner = ~stretch & (start > 0.0) & (start < 1.0)
    k = np.where(corner, np.rint(rr[:, None] + start * dr - 0.5), 0).astype(np.int64)
    m = np.where(corner, np.rint(cc[:, None] + start * dc - 0.5), 0).astype(np.int64)
    down_right = np.sign(dr) == np.sign(dc)
    beside = [(k, np.where(down_right, m + 1, m)), (k + 1, np.where(down_right, m, m + 1))]
    pinched = corner.copy()
    for r, c in beside:
        pinched &= ~free[np.where(corner, r, 0), np.where(corner, c, 0)]
    visible: np.ndarray = ~(crossed | pinched).any(axis=1)
    return visible


def wall_distances(layout: GridLayout, max_distance: float) -> np.ndarray:
    """Meters from each state's cell centre to the first blocked cell or grid edge straight ahead,
    ``inf`` beyond ``max_distance``. The wall is taken at the near edge of the blocking cell:
    ``(k - 0.5)`` steps for a wall k cells ahead (a step is ``cell_size``, times sqrt 2 diagonally).
    A diagonal beam also stops at a corner between two blocked cells, as Look's line of sight does:
    a wall drawn diagonally has no gaps."""
    h_count = layout.headings
    n_cells = len(layout.free_cells)
    row, col = np.divmod(layout.free_cells, layout.cols)
    result = np.full(n_cells * h_count, np.inf)
    for h, (dr, dc) in enumerate(HEADING_VECTORS[h_count]):
        step = math.hypot(dr, dc) * layout.cell_size
        max_steps = math.ceil(max_distance / step + 0.5) + 1
        pending = np.arange(n_cells)
        for k in range(1, max_steps + 1):
            if len(pending) == 0:
                break
            r2, c2 = row[pending] + k * dr, col[pending] + k * dc
            inside = (r2 >= 0) & (r2 < layout.rows) & (c2 >= 0) & (c2 < layout.cols)
            wall = ~inside
            wall[inside] = ~layout.free[r2[inside], c2[inside]]
            if dr and dc:  # the two cells beside the corner crossed on the way (inside when r2, c2 is)
                pinched = inside & ~layout.free[np.where(inside, r2 - dr, 0), np.where(inside, c2, 0)]
                pinched &= ~layout.free[np.where(inside, r2, 0), np.where(inside, c2 - dc, 0)]
                wall |= pinched
            hit = pending[wall]
            distance = (k - 0.5) * step
            if distance <= max_distance + 1e-9:
                result[hit * h_count + h] = distance
            pending = pending[~wall]
    return result


def beam_distances(layout: GridLayout, ahead: np.ndarray, offset: int) -> np.ndarray:
    """A beam turned ``offset`` headings clockwise from the robot's: for state (cell, h) the
    distance :func:`wall_distances` measured straight ahead at (cell, h + offset). ``offset`` 0
    returns ``ahead`` itself."""
    if offset % layout.headings == 0:
        return ahead
    h_count = layout.headings
    by_heading = ahead.reshape(-1, h_count)
    turned = (np.arange(h_count) + offset) % h_count
    result: np.ndarray = by_heading[:, turned].ravel()
    return result
