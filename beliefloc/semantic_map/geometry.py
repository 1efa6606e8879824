"""Grid geometry, vectorised over states: moves, what a Look sees, how far a Scan reads.

Conventions (also in ``docs/map-format.md``):

* Rows grow downwards (south), columns eastwards. Heading 0 is north and headings count clockwise:
  with 4 headings 0 N, 1 E, 2 S, 3 W; with 8 headings 0 N, 1 NE, 2 E, ... 7 NW.
* States are the free cells in row-major order, times headings: ``state = cell * H + heading``.
* The robot stands at its cell's centre. Distances are between cell centres, in meters.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp

from beliefloc.model import GridLayout

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
    """The intended next state of every state under a noise-free ``motion``."""
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
    target_cell = np.where(inside & (hit >= 0), hit, cell)
    return target_cell * h_count + heading


def transition_matrix(targets: np.ndarray, failure: float) -> sp.csr_matrix:
    """``T[i, targets[i]] = 1 - failure`` and ``T[i, i] += failure``: a failed move stays put."""
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
    lr, lc = landmark
    h_count = layout.headings
    index = cell_index_map(layout)
    if view_range is None:
        r0, r1, c0, c1 = 0, layout.rows, 0, layout.cols
    else:
        reach = math.floor(view_range / layout.cell_size + 1e-9)
        r0, r1 = max(0, lr - reach), min(layout.rows, lr + reach + 1)
        c0, c1 = max(0, lc - reach), min(layout.cols, lc + reach + 1)
    rr, cc = np.mgrid[r0:r1, c0:c1]
    rr, cc = rr.ravel(), cc.ravel()
    cells = index[rr, cc]
    keep = cells >= 0
    rr, cc, cells = rr[keep], cc[keep], cells[keep]
    dy, dx = (rr - lr).astype(float), (lc - cc).astype(float)  # north, east components towards it
    distance = np.hypot(dx, dy) * layout.cell_size
    if view_range is not None:
        keep = distance <= view_range + 1e-9
        rr, cc, cells, dx, dy, distance = rr[keep], cc[keep], cells[keep], dx[keep], dy[keep], distance[keep]
    if occlusion and not layout.free.all():
        visible = _line_of_sight(layout.free, rr, cc, lr, lc)
        rr, cc, cells, dx, dy, distance = (
            rr[visible],
            cc[visible],
            cells[visible],
            dx[visible],
            dy[visible],
            distance[visible],
        )
    bearing = np.degrees(np.arctan2(dx, dy))  # clockwise from north
    headings = np.arange(h_count)
    if h_count == 1:
        relative = np.zeros((len(cells), 1))
    else:
        relative = (bearing[:, None] - headings[None, :] * (360.0 / h_count) + 180.0) % 360.0 - 180.0
    relative = np.abs(relative)
    relative[distance == 0.0, :] = 0.0
    seen = relative <= fov / 2.0 + 1e-9
    states = (cells[:, None] * h_count + headings[None, :])[seen]
    return states, relative[seen]


def _line_of_sight(free: np.ndarray, rr: np.ndarray, cc: np.ndarray, lr: int, lc: int) -> np.ndarray:
    """True where the segment between cell centres crosses no blocked cell (endpoints excluded)."""
    span = int(np.max(np.maximum(np.abs(rr - lr), np.abs(cc - lc)), initial=0))
    samples = max(2, 4 * span + 1)
    t = (np.arange(1, samples) / samples)[None, :]
    pr = np.floor(rr[:, None] + t * (lr - rr[:, None]) + 0.5).astype(np.int64)
    pc = np.floor(cc[:, None] + t * (lc - cc[:, None]) + 0.5).astype(np.int64)
    endpoint = ((pr == rr[:, None]) & (pc == cc[:, None])) | ((pr == lr) & (pc == lc))
    blocked = ~free[pr, pc] & ~endpoint
    visible: np.ndarray = ~blocked.any(axis=1)
    return visible


def wall_distances(layout: GridLayout, max_distance: float) -> np.ndarray:
    """Meters from each state's cell centre to the first blocked cell or grid edge straight ahead,
    ``inf`` beyond ``max_distance``. The wall is taken at the near edge of the blocking cell:
    ``(k - 0.5)`` steps for a wall k cells ahead (a step is ``cell_size``, times sqrt 2 diagonally)."""
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
            hit = pending[wall]
            distance = (k - 0.5) * step
            if distance <= max_distance + 1e-9:
                result[hit * h_count + h] = distance
            pending = pending[~wall]
    return result
