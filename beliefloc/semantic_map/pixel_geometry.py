"""What a Scan reads and what a Look sees, over the pixels of an occupancy map instead of the cells.

The counterparts of :func:`~beliefloc.semantic_map.geometry.wall_distances` and
:func:`~beliefloc.semantic_map.geometry.viewing_angles_many`: the states are still the free cells of
a :class:`~beliefloc.model.GridLayout` times its headings, but walls are the map's blocked pixels
(occupied or unknown), ``blocked[i, j]`` with row 0 at the top of the image. Plain arrays in, plain
arrays out: no I/O, no dependence on how the map was read.

**Frames.** Everything is computed in the grid frame (metres; origin at the grid's lower-left corner,
which is also the image's; x along the columns, y up the rows). Inside, points are in *pixel units*
``u = x / res`` (along the columns) and ``v = H - y / res`` (down the rows from the image's top edge,
``H`` pixels high), so pixel ``(i, j)`` covers ``i <= v < i + 1``, ``j <= u < j + 1``, and a heading
vector ``(dr, dc)`` of :data:`~beliefloc.semantic_map.geometry.HEADING_VECTORS` is the direction
``(dv, du)`` itself. Coordinates within :data:`_EPS` of an integer are taken to lie on that pixel
edge: cells of 0.25 m over pixels of 0.05 m put every diagonal ray through pixel corners, and those
must not depend on rounding.

**The blocking rule** (one rule for rays and lines of sight; the cell versions' rule, made exact for
points that lie on pixel edges). A ray or segment is stopped at the first point after its start
where blocked pixels touch it *from both sides*. A pixel whose inside it crosses touches both sides;
a pixel it only grazes -- along an edge, or at a corner -- touches the side it lies on. So:

* a ray stops where it enters a blocked pixel (its entry point, on the pixel's edge);
* through a pixel corner it stops when the two pixels beside the corner are both blocked (a wall
  drawn diagonally has no gap), and passes a single blocked pixel touched at its corner;
* running along a pixel edge it passes a wall on one side and stops where blocked pixels meet it on
  both sides: two blocked pixels facing each other across the edge, or a corner with a blocked pixel
  on each side (blocked left before the corner, blocked right after it);
* the outside of the image is blocked (AMCL's ``map_calc_range`` also stops at the map's edge).
"""

from __future__ import annotations

import hashlib
import math
import threading
from collections import OrderedDict

import numpy as np

from beliefloc.errors import InvalidValueError
from beliefloc.model import GridLayout
from beliefloc.semantic_map.geometry import HEADING_VECTORS, cell_index_map

_EPS = 1e-9
"""Pixel units: a coordinate this close to an integer lies on a pixel edge. Double precision leaves
errors near 1e-12 on maps of thousands of pixels, far below it."""
_TOLERANCE = 1e-9
"""Metres and degrees: the slack of the range, field-of-view and ``max_distance`` comparisons, as in
:mod:`~beliefloc.semantic_map.geometry`."""
_CHUNK = 1 << 19
"""About how many (segment, edge crossing) entries :func:`pixel_line_of_sight` handles at once, and
how many (landmark, cell) pairs :func:`viewing_angles_metric` does; bounds their memory."""
_WIDTH_STEP = 32
"""Segments are grouped by their number of edge crossings rounded up to a multiple of this."""


# --------------------------------------------------------------------------------------- helpers


def _check_pixels(blocked: np.ndarray, resolution: float) -> np.ndarray:
    pixels = np.asarray(blocked)
    if pixels.ndim != 2 or pixels.shape[0] == 0 or pixels.shape[1] == 0:
        raise InvalidValueError(f"blocked pixels must be a non-empty 2-D array, got shape {pixels.shape}")
    if not (math.isfinite(resolution) and resolution > 0.0):
        raise InvalidValueError(f"resolution must be a positive number of metres per pixel, got {resolution}")
    return pixels.astype(bool, copy=False)


def _padded(blocked: np.ndarray) -> np.ndarray:
    """The pixels with a ring of blocked ones around: the outside of the map. Pixel ``(i, j)`` of
    ``blocked`` is ``(i + 1, j + 1)`` here, and pixel units shift by one."""
    height, width = blocked.shape
    padded = np.ones((height + 2, width + 2), dtype=bool)
    padded[1:-1, 1:-1] = blocked
    return padded


def _snap(a: np.ndarray) -> np.ndarray:
    """Coordinates within :data:`_EPS` of an integer, made that integer."""
    nearest = np.rint(a)
    snapped: np.ndarray = np.where(np.abs(a - nearest) < _EPS, nearest, a)
    return snapped


def _to_pixels(xy: np.ndarray, resolution: float, height: int) -> tuple[np.ndarray, np.ndarray]:
    """Grid-frame metres -> padded pixel units ``(u, v)`` (``v`` down from the padded top edge)."""
    u = _snap(xy[:, 0] / resolution) + 1.0
    v = height - _snap(xy[:, 1] / resolution) + 1.0
    return u, v


# ------------------------------------------------------------------------------------ ray casting


def ray_distances(
    blocked: np.ndarray,
    resolution: float,
    layout: GridLayout,
    max_distance: float,
    *,
    key: str | None = None,
) -> np.ndarray:
    """Metres from each state's cell centre to the first blocked pixel straight ahead, ``inf``
    beyond ``max_distance``: :func:`~beliefloc.semantic_map.geometry.wall_distances` over pixels.

    ``result[cell * H + h]`` (``H = layout.headings``, cells = ``layout.free_cells``) is ``t`` such
    that the ray ``p(t) = centre + t * (dc, -dr) / |(dr, dc)|`` (grid-frame metres; ``(dr, dc)`` =
    ``HEADING_VECTORS[H][h]``, so 8 headings give the diagonals at 45 degrees) is first stopped by the
    module's blocking rule at ``p(t)``: the entry point of the first blocked pixel it enters, or the
    pinched corner, or the edge of the image. ``blocked[i, j]`` (row 0 at the top) is True for an
    occupied or unknown pixel of side ``resolution`` metres. A centre standing on a blocked pixel, or
    outside the image, reads 0. When pixels and cells coincide (``resolution == cell_size``,
    ``blocked == ~layout.free``) this is exactly ``wall_distances``: it, too, measures to the near
    edge of the blocking cell, ``(k - 1/2)`` steps for a wall ``k`` cells ahead.

    **Against AMCL.** ``map_calc_range`` (amcl/map/map_range.c) walks one beam at a time with
    Bresenham's line from the pixel holding the pose to the pixel at ``max_range``, stops at the first
    pixel that is off the map, occupied or unknown (``occ_state > -1``) -- checking the start pixel too
    -- and returns the distance between the *centres* of the start pixel and that pixel, or
    ``max_range`` when none is met. Followed here: unknown and off-map pixels block, a blocked start
    pixel reads 0, nothing within range reads "no wall" (here ``inf``, as ``wall_distances``).
    Different: (1) the traversal is exact (every pixel the ray's inside crosses, the Amanatides-Woo
    order) where Bresenham visits one pixel per column and can slip through a diagonal wall or skip a
    pixel the beam clips; corners and edges follow the blocking rule; (2) the distance is measured from
    the true start point (the cell centre, not the centre of its pixel) to the blocked pixel's entry
    point, not to its centre -- the definition that agrees with ``wall_distances``; AMCL's reads half
    a pixel longer on average, up to about one; (3) AMCL's beams start anywhere at any angle; here the
    directions are the headings only, which is what makes the method below possible.

    **Method.** No ray is walked. Per heading, the image is flipped (and, for a diagonal, mirrored)
    so that the ray points up (``dv = -1``) or up-right (``dv = -1, du = 1``). Then, for every pixel:
    going up, the nearest blocked pixel at or above it in its column (and, for rays along a column
    edge, the nearest corner of that edge where both sides are blocked) -- a cumulative maximum down
    the columns; going up-right, how many free pixels a ray entering the pixel crosses before it is
    stopped, for each of the three ways a ray can cross a pixel at 45 degrees (through its corners,
    leaving by its top edge first, or by its right edge first) -- one sweep down the rows. Each ray is
    then one look-up and a closed form for the entry time. Time ``O(headings * (pixels + states))``,
    memory ``O(pixels + states)``: a handful of ``int32`` images and a few arrays per state, never
    ``states x ray length``, so no chunks are needed.

    **Cache.** With a ``key`` (say the occupancy image's sha256) the result is kept in a small
    in-process LRU cache (:data:`RAY_CACHE_ENTRIES` results, at most :data:`RAY_CACHE_BYTES` bytes),
    keyed by ``key`` together with the image shape, ``resolution``, the grid's shape, cell size,
    headings and free cells, and ``max_distance``; the caller vouches that equal keys mean equal
    pixels. Each call returns a new array. :func:`clear_ray_cache` empties the cache and
    :func:`ray_cache_info` reports it. Without a key nothing is cached.

    Raises :class:`~beliefloc.errors.InvalidValueError` for a layout with one heading (a scan looks
    ahead; ``wall_distances`` has no answer for it either) or malformed pixels.
    """
    pixels = _check_pixels(blocked, resolution)
    if layout.headings == 1:
        raise InvalidValueError("a scan looks ahead, but the layout has headings: 1 (no heading)")
    if layout.headings not in HEADING_VECTORS:
        raise InvalidValueError(f"a layout has 1, 4 or 8 headings, got {layout.headings}")
    if not max_distance >= 0.0:
        raise InvalidValueError(f"max_distance must be at least 0, got {max_distance}")
    cache_key: tuple[object, ...] | None = None
    if key is not None:
        free = np.ascontiguousarray(layout.free, dtype=bool)
        cache_key = (
            key,
            pixels.shape,
            float(resolution),
            layout.rows,
            layout.cols,
            float(layout.cell_size),
            layout.headings,
            hashlib.sha256(np.packbits(free).tobytes()).hexdigest(),
            float(max_distance),
        )
        cached = _RAY_CACHE.get(cache_key)
        if cached is not None:
            return cached.copy()
    result = _ray_distances(pixels, resolution, layout, max_distance)
    if cache_key is not None:
        _RAY_CACHE.put(cache_key, result.copy())
    return result


def _ray_distances(blocked: np.ndarray, resolution: float, layout: GridLayout, max_distance: float) -> np.ndarray:
    height, width = blocked.shape
    padded = _padded(blocked)
    row, col = np.divmod(layout.free_cells, layout.cols)
    s = layout.cell_size
    centres = np.stack([(col + 0.5) * s, (layout.rows - row - 0.5) * s], axis=1)
    u, v = _to_pixels(centres, resolution, height)
    outside = (u < 1.0) | (u > width + 1.0) | (v < 1.0) | (v > height + 1.0)
    u, v = np.clip(u, 1.0, width + 1.0), np.clip(v, 1.0, height + 1.0)  # only to keep look-ups valid
    result = np.empty((len(row), layout.headings))
    for h, (dr, dc) in enumerate(HEADING_VECTORS[layout.headings]):
        distance = _stop_time(padded, v, u, dr, dc) * (math.hypot(dr, dc) * resolution)
        distance[outside] = 0.0
        result[:, h] = np.where(distance <= max_distance + _TOLERANCE, distance, np.inf)
    flat: np.ndarray = result.ravel()
    return flat


def _stop_time(padded: np.ndarray, v: np.ndarray, u: np.ndarray, dr: int, dc: int) -> np.ndarray:
    """Pixel steps (along the larger of ``|dv|, |du|``) until rays from ``(v, u)`` heading
    ``(dr, dc)`` stop. Turns the image so that the ray goes up or up-right; a turn of the image is a
    turn of the coordinates, and pixel interiors, edges and corners map onto their like."""
    if dr == 0 or dc == 0:
        if dr == 0:  # transpose: the column direction becomes the row direction
            padded, v, u, dr, dc = padded.T, u, v, dc, dr
        if dr > 0:  # flip upside down
            padded, v = padded[::-1], padded.shape[0] - v
        return _stop_up(padded, v, u)
    if dr > 0:
        padded, v = padded[::-1], padded.shape[0] - v
    if dc < 0:
        padded, u = padded[:, ::-1], padded.shape[1] - u
    if padded.shape[0] > padded.shape[1]:
        # mirror in the anti-diagonal (keeps up-right up-right) so that the sweep has fewer rows
        padded, v, u = padded[::-1, ::-1].T, padded.shape[1] - u, padded.shape[0] - v
    return _stop_up_right(np.ascontiguousarray(padded), v, u)


def _stop_up(padded: np.ndarray, v: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Rays going up (``v`` decreasing). Inside column ``b``, starting in pixel ``(a, b)`` (``a =
    ceil(v) - 1``, the row entered just after the start): the first blocked pixel at or above is
    ``n = max{i <= a : blocked[i, b]}``, entered at ``v = n + 1``, so ``t = v0 - n - 1`` (0 when
    ``n = a``). Along the column edge ``u = j`` (pixels ``j - 1`` left and ``j`` right): stopped at
    once when both pixels of row ``a`` are blocked, else at the first corner ``v = m <= a`` with
    ``(L[m-1] | L[m]) & (R[m-1] | R[m])``, ``t = v0 - m``."""
    rows_n = padded.shape[0]
    index = np.arange(rows_n, dtype=np.int32)[:, None]
    a = np.ceil(v).astype(np.int64) - 1
    t = np.empty(len(v))
    on_edge = u == np.floor(u)
    inner = ~on_edge
    if inner.any():
        nearest = np.maximum.accumulate(np.where(padded, index, np.int32(-1)), axis=0)
        ai, bi = a[inner], np.floor(u[inner]).astype(np.int64)
        n = nearest[ai, bi]
        t[inner] = np.where(n == ai, 0.0, v[inner] - n - 1.0)
    if on_edge.any():
        left, right = padded[:, :-1], padded[:, 1:]  # edge j is between columns j - 1 and j: index j - 1
        corner = np.ones(left.shape, dtype=bool)  # corner[m]: the corner at v = m (row 0 is outside)
        corner[1:] = (left[1:] | left[:-1]) & (right[1:] | right[:-1])
        nearest_corner = np.maximum.accumulate(np.where(corner, index, np.int32(-1)), axis=0)
        ae, ej = a[on_edge], u[on_edge].astype(np.int64) - 1
        both = left[ae, ej] & right[ae, ej]
        t[on_edge] = np.where(both, 0.0, v[on_edge] - nearest_corner[ae, ej])
    return t


def _stop_up_right(padded: np.ndarray, v: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Rays going up-right (``dv = -1, du = 1``), ``t`` in pixel steps. The ray starts in pixel
    ``(a, b) = (ceil(v) - 1, floor(u))``; it reaches that pixel's top edge at ``tr = v0 - a`` and its
    right edge at ``tc = b + 1 - u0``.

    * ``tr == tc`` (``u + v`` an integer): the ray runs through pixel corners, pixel ``k`` of the
      diagonal entered at ``tr + k - 1``; :func:`_runs_up_right`'s ``diag`` counts the pixels it
      crosses before it is stopped, so ``t = tr + diag - 1``.
    * ``tr < tc``: it leaves by the top edge, then by the right edge, alternately; the ``k``-th pixel
      after the start is entered at ``tr + (k - 1) // 2`` (``k`` odd) or ``tc + (k - 2) // 2`` (``k``
      even), and ``up`` counts the free pixels, so ``t`` is the entry time of pixel ``k = up``.
    * ``tc < tr``: the same with ``right``, ``tc`` and ``tr`` swapped.
    """
    a = np.ceil(v).astype(np.int64) - 1
    b = np.floor(u).astype(np.int64)
    tr, tc = v - a, b + 1 - u
    through_corners = np.abs(tr - tc) < _EPS
    up, right, diag = _runs_up_right(padded, need_diag=bool(through_corners.any()))
    up_first = tr < tc
    k = np.where(up_first, up[a, b], right[a, b]).astype(np.int64)
    first, second = np.where(up_first, tr, tc), np.where(up_first, tc, tr)
    t = np.where(k % 2 == 1, first + (k - 1) // 2, second + (k - 2) // 2)
    if diag is not None:
        t = np.where(through_corners, tr + diag[a, b] - 1.0, t)
    stopped: np.ndarray = np.where(padded[a, b], 0.0, t)
    return stopped


def _runs_up_right(padded: np.ndarray, need_diag: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """For a ray at 45 degrees going up-right that is inside pixel ``(i, j)``, how many pixels it
    crosses (this one included) before it is stopped, 0 if ``(i, j)`` is blocked:

    * ``up[i, j]``: it leaves by the top edge next: ``up = 1 + right[i - 1, j]``;
    * ``right[i, j]``: it leaves by the right edge next: ``right = 1 + up[i, j + 1]``;
    * ``diag[i, j]``: it runs through the pixel's corners: ``diag = 1 + diag[i - 1, j + 1]``, or 1
      when the next pixel ``(i - 1, j + 1)`` is blocked or the corner is pinched (``(i - 1, j)`` and
      ``(i, j + 1)`` both blocked).

    The outside ring is blocked, so every run ends. One sweep down the rows (``up`` of a row needs
    the row above, ``right`` the same row's ``up``)."""
    rows_n, cols_n = padded.shape
    free = (~padded).astype(np.int32)
    up = np.zeros((rows_n, cols_n), dtype=np.int32)
    right = np.zeros((rows_n, cols_n), dtype=np.int32)
    diag: np.ndarray | None = None
    if need_diag:
        diag = np.zeros((rows_n, cols_n), dtype=np.int32)
        stops = np.ones((rows_n, cols_n), dtype=bool)
        stops[1:, :-1] = padded[:-1, 1:] | (padded[:-1, :-1] & padded[1:, 1:])
        go_on = (~stops).astype(np.int32)
    for i in range(1, rows_n - 1):
        np.multiply(free[i], right[i - 1] + 1, out=up[i])
        np.multiply(free[i, :-1], up[i, 1:] + 1, out=right[i, :-1])
        if diag is not None:
            np.multiply(free[i, :-1], diag[i - 1, 1:] * go_on[i, :-1] + 1, out=diag[i, :-1])
    return up, right, diag


# ---------------------------------------------------------------------------------- the cache

RAY_CACHE_ENTRIES = 8
"""At most this many :func:`ray_distances` results are cached ..."""
RAY_CACHE_BYTES = 256 << 20
"""... and at most this many bytes of them (the least recently used go first)."""


class _RayCache:
    """A small LRU map from a key to an array, bounded in entries and bytes; thread-safe."""

    def __init__(self, max_entries: int, max_bytes: int) -> None:
        self._max_entries, self._max_bytes = max_entries, max_bytes
        self._items: OrderedDict[tuple[object, ...], np.ndarray] = OrderedDict()
        self._lock = threading.Lock()
        self.hits = self.misses = 0

    def get(self, key: tuple[object, ...]) -> np.ndarray | None:
        with self._lock:
            value = self._items.get(key)
            if value is None:
                self.misses += 1
                return None
            self.hits += 1
            self._items.move_to_end(key)
            return value

    def put(self, key: tuple[object, ...], value: np.ndarray) -> None:
        with self._lock:
            if value.nbytes > self._max_bytes:
                return
            self._items[key] = value
            self._items.move_to_end(key)
            while len(self._items) > self._max_entries or sum(a.nbytes for a in self._items.values()) > self._max_bytes:
                self._items.popitem(last=False)

    def clear(self) -> None:
        with self._lock:
            self._items.clear()
            self.hits = self.misses = 0

    def info(self) -> dict[str, int]:
        with self._lock:
            return {
                "entries": len(self._items),
                "bytes": sum(a.nbytes for a in self._items.values()),
                "hits": self.hits,
                "misses": self.misses,
            }


_RAY_CACHE = _RayCache(RAY_CACHE_ENTRIES, RAY_CACHE_BYTES)


def clear_ray_cache() -> None:
    """Forget every cached :func:`ray_distances` result and reset the hit and miss counts."""
    _RAY_CACHE.clear()


def ray_cache_info() -> dict[str, int]:
    """``entries``, ``bytes``, ``hits`` and ``misses`` of the :func:`ray_distances` cache."""
    return _RAY_CACHE.info()


# ------------------------------------------------------------------------------- line of sight


def pixel_line_of_sight(blocked: np.ndarray, resolution: float, start_xy: np.ndarray, end_xy: np.ndarray) -> np.ndarray:
    """``clear[n]``: True where the segment from ``start_xy[n]`` to ``end_xy[n]`` (grid-frame metres,
    shape ``(n, 2)``) is not stopped by the module's blocking rule at any point strictly between its
    ends, the pixels of its first and last stretch counting as free (the end pixels themselves are
    excepted: a landmark may stand on an occupied pixel, a robot's centre on a pixel edge). Where an
    end lies on a pixel edge and the segment runs along that edge, both pixels beside the stretch are
    end pixels. Symmetric in its ends. Pixels outside the image are blocked.

    Exact, not sampled, as :func:`~beliefloc.semantic_map.geometry._line_of_sight` is for cells: the
    column edges ``u = k`` crossed at ``t = (k - u0) / du`` and the row edges ``v = k`` crossed at
    ``t = (k - v0) / dv`` (``0 < t < 1``) are listed, and at each crossing the pixel entered is
    checked -- or, where a row and a column edge are crossed at once, the pixel entered and the pinched
    corner, or, for a segment along an edge, the pixels on both sides. Every stretch of the segment
    begins at a crossing or at its start, so no sort is needed. Segments are grouped by their number of
    crossings and handled about :data:`_CHUNK` crossings at a time.
    """
    pixels = _check_pixels(blocked, resolution)
    start = np.asarray(start_xy, dtype=np.float64).reshape(-1, 2)
    end = np.asarray(end_xy, dtype=np.float64).reshape(-1, 2)
    if start.shape != end.shape:
        raise InvalidValueError(f"{len(start)} segment starts but {len(end)} ends")
    if not (np.isfinite(start).all() and np.isfinite(end).all()):
        raise InvalidValueError("segment ends must be finite grid-frame coordinates")
    padded = _padded(pixels)
    u0, v0 = _to_pixels(start, resolution, pixels.shape[0])
    u1, v1 = _to_pixels(end, resolution, pixels.shape[0])
    return _clear(padded, u0, v0, u1, v1)


def _clear(padded: np.ndarray, u0: np.ndarray, v0: np.ndarray, u1: np.ndarray, v1: np.ndarray) -> np.ndarray:
    """:func:`pixel_line_of_sight` in padded pixel units."""
    du, dv = u1 - u0, v1 - v0
    # the pixels of the first and the last stretch: a box of one or two pixels each, (row, col) ranges
    ends = (
        (*_stretch_pixels(v0, dv), *_stretch_pixels(u0, du)),
        (*_stretch_pixels(v1, -dv), *_stretch_pixels(u1, -du)),
    )
    n_cols, n_rows = _crossing_count(u0, u1), _crossing_count(v0, v1)
    width = np.maximum(n_cols, n_rows)
    group = -(-width // _WIDTH_STEP)
    clear = np.ones(len(u0), dtype=bool)
    transposed = np.ascontiguousarray(padded.T)  # for the column crossings: column first
    order = np.argsort(group, kind="stable")
    bounds = np.flatnonzero(np.diff(group[order])) + 1
    for members in np.split(order, bounds):
        if group[members[0]] == 0:  # no edge crossed: nothing between the end pixels
            continue
        span = int(width[members].max())
        step = max(1, _CHUNK // span)
        for lo in range(0, len(members), step):
            m = members[lo : lo + step]
            (r0, r1, c0, c1), (r2, r3, c2, c3) = ((part[m] for part in box) for box in ends)
            row_box = ((r0, r1, c0, c1), (r2, r3, c2, c3))  # (primary, secondary) = (row, col)
            col_box = ((c0, c1, r0, r1), (c2, c3, r2, r3))  # (primary, secondary) = (col, row)
            hit = _crossings_blocked(transposed, u0[m], v0[m], du[m], dv[m], n_cols[m], col_box)
            hit |= _crossings_blocked(padded, v0[m], u0[m], dv[m], du[m], n_rows[m], row_box)
            clear[m] = ~hit
    return clear


def _stretch_pixels(x: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Along one axis, the range ``[lo, hi]`` of pixel indices a segment occupies just after leaving
    coordinate ``x`` with direction ``d``: ``floor(x)`` going up, ``ceil(x) - 1`` going down, and
    both neighbours of an edge it runs along (``d == 0``, ``x`` an integer)."""
    fl = np.floor(x).astype(np.int64)
    on = (d == 0) & (x == fl)
    lo = np.where(d > 0, fl, np.where(d < 0, np.ceil(x).astype(np.int64) - 1, np.where(on, fl - 1, fl)))
    hi = np.where(on, fl, lo)
    return lo, hi


def _crossing_count(x0: np.ndarray, x1: np.ndarray) -> np.ndarray:
    """How many integers lie strictly between ``x0`` and ``x1``: the edges crossed along one axis."""
    lo, hi = np.minimum(x0, x1), np.maximum(x0, x1)
    count: np.ndarray = np.maximum(np.ceil(hi).astype(np.int64) - np.floor(lo).astype(np.int64) - 1, 0)
    return count


def _crossings_blocked(
    grid: np.ndarray,
    a0: np.ndarray,
    b0: np.ndarray,
    da: np.ndarray,
    db: np.ndarray,
    count: np.ndarray,
    ends: tuple[tuple[np.ndarray, ...], tuple[np.ndarray, ...]],
) -> np.ndarray:
    """Whether any crossing of an edge ``a = k`` stops the segment ``(a0, b0) + t (da, db)``, on
    ``grid[a, b]`` (a C-contiguous array indexed primary axis first). ``ends`` are the boxes
    ``(a_lo, a_hi, b_lo, b_hi)`` of the first and the last stretch's pixels, which count as free.

    The pixel entered at a crossing is never the first stretch's, and the two pixels beside a corner
    are no stretch's at all: only along an edge can both boxes matter."""
    n = len(a0)
    width = int(count.max(initial=0))
    if width == 0:
        return np.zeros(n, dtype=bool)
    rows_n, cols_n = grid.shape
    cells = grid.ravel()
    k = np.arange(width)[None, :]
    forward = da > 0
    step = np.where(forward, 1, -1)[:, None]
    edge = np.where(forward, np.floor(a0) + 1.0, np.ceil(a0) - 1.0)[:, None] + step * k  # a = edge, crossed
    slope = (db / np.where(da == 0, 1.0, da))[:, None]
    b = b0[:, None] + (edge - a0[:, None]) * slope
    b_floor = np.floor(b + _EPS)
    on_line = b - b_floor < _EPS  # within _EPS of the integer b_floor: the crossing is at a pixel corner
    b_int = b_floor.astype(np.int64)
    after = edge.astype(np.int64) - (~forward)[:, None]
    before = after - step

    def blocked_at(ai: np.ndarray, bi: np.ndarray, boxes: tuple[tuple[np.ndarray, ...], ...]) -> np.ndarray:
        flat = np.minimum(np.maximum(ai, 0), rows_n - 1) * cols_n + np.minimum(np.maximum(bi, 0), cols_n - 1)
        value: np.ndarray = cells[flat]
        for a_lo, a_hi, b_lo, b_hi in boxes:
            value &= ~((ai >= a_lo[:, None]) & (ai <= a_hi[:, None]) & (bi >= b_lo[:, None]) & (bi <= b_hi[:, None]))
        return value

    b_up = (db > 0)[:, None]
    # the secondary index of the pixel entered (at a corner: the one the segment heads into)
    b_after = b_int - (on_line & ~b_up)
    hit = blocked_at(after, b_after, ends[1:])
    if on_line.any():
        level = (db == 0)[:, None]
        corner, along = on_line & ~level, on_line & level
        hit &= ~along
        if corner.any():
            b_before = b_int - b_up
            hit |= corner & blocked_at(after, b_before, ()) & blocked_at(before, b_after, ())
        if along.any():
            left = blocked_at(before, b_int - 1, ends) | blocked_at(after, b_int - 1, ends)
            right = blocked_at(before, b_int, ends) | blocked_at(after, b_int, ends)
            hit |= along & left & right
    hit &= k < count[:, None]  # the padding of shorter segments
    return np.asarray(hit.any(axis=1), dtype=bool)


# ------------------------------------------------------------------------------ viewing angles


def viewing_angles_metric(
    layout: GridLayout,
    blocked: np.ndarray,
    resolution: float,
    landmarks_xy: np.ndarray,
    view_range: float | None,
    fov: float,
    occlusion: bool,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`~beliefloc.semantic_map.geometry.viewing_angles_many` for landmarks at grid-frame
    metric positions (``landmarks_xy[k] = (x, y)``, anywhere, not only at cell centres), occluded by
    pixels.

    Returns ``(states, angles, which)``: every (state, landmark) pair where the state sees the
    landmark, the viewing angle in degrees, and ``which`` = the landmark's position in
    ``landmarks_xy``; ordered by landmark, then state. State ``cell * H + h`` (centre ``c``, heading
    ``h`` of ``H``) sees landmark ``L`` when

    * ``|L - c| <= view_range`` (metres; ``None``: any distance),
    * ``angle = |wrap(bearing - h * 360 / H)| <= fov / 2``, with ``bearing = atan2(Lx - cx, Ly - cy)``
      in degrees clockwise from north (+y) and ``wrap`` into ``[-180, 180)``; with ``H = 1`` the angle
      is 0 (no heading) -- exactly the cell version's arithmetic;
    * with ``occlusion``, :func:`pixel_line_of_sight` from ``c`` to ``L`` is clear.

    A landmark inside the robot's own cell (by :meth:`GridLayout.cell_at`'s half-open rule) is seen
    from every heading at angle 0, whatever the range, field of view or pixels between: the cell
    version's rule for a landmark in the robot's cell (distance 0 there), kept because the robot's
    place within its cell is unknown. With landmarks at cell centres, ``resolution == cell_size`` and
    ``blocked == ~layout.free`` this equals ``viewing_angles_many`` (angles to rounding).

    The (landmark, cell) pairs come from each landmark's window of cells within range, a chunk of
    landmarks at a time (about :data:`_CHUNK` pairs); time and memory are linear in
    ``landmarks x window`` plus the line-of-sight work.
    """
    pixels = _check_pixels(blocked, resolution)
    landmarks = np.asarray(landmarks_xy, dtype=np.float64).reshape(-1, 2)
    if not np.isfinite(landmarks).all():
        raise InvalidValueError("landmark positions must be finite grid-frame coordinates")
    h_count, s = layout.headings, layout.cell_size
    empty = np.zeros(0, dtype=np.int64)
    if len(landmarks) == 0 or len(layout.free_cells) == 0:
        return empty, np.zeros(0), empty
    padded = _padded(pixels) if occlusion else None
    index = cell_index_map(layout)
    lc = np.floor(landmarks[:, 0] / s).astype(np.int64)
    lr = layout.rows - 1 - np.floor(landmarks[:, 1] / s).astype(np.int64)
    if view_range is None:
        # every free cell is a candidate: offsets from the landmark's cell to each of them
        free_r, free_c = np.divmod(layout.free_cells, layout.cols)
        per_landmark = len(free_r)
    else:
        reach = math.floor(view_range / s + 1e-9) + 1  # a centre within range is at most this many cells off
        dr_w, dc_w = np.mgrid[-reach : reach + 1, -reach : reach + 1]
        dr_w, dc_w = dr_w.ravel(), dc_w.ravel()
        per_landmark = len(dr_w)
    headings = np.arange(h_count)
    step = max(1, _CHUNK // per_landmark)
    out_states, out_angles, out_which = [], [], []
    for lo in range(0, len(landmarks), step):
        chunk = slice(lo, lo + step)
        if view_range is None:
            rr = np.broadcast_to(free_r, (len(lr[chunk]), per_landmark))
            cc = np.broadcast_to(free_c, rr.shape)
        else:
            rr, cc = lr[chunk, None] + dr_w[None, :], lc[chunk, None] + dc_w[None, :]
        inside = (rr >= 0) & (rr < layout.rows) & (cc >= 0) & (cc < layout.cols)
        cells = np.where(inside, index[np.where(inside, rr, 0), np.where(inside, cc, 0)], -1)
        k_idx, o_idx = np.nonzero(cells >= 0)
        r, c = rr[k_idx, o_idx], cc[k_idx, o_idx]
        k_all = k_idx + lo
        dx = landmarks[k_all, 0] - (c + 0.5) * s  # east and north components towards the landmark
        dy = landmarks[k_all, 1] - (layout.rows - r - 0.5) * s
        own = (r == lr[k_all]) & (c == lc[k_all])
        distance = np.hypot(dx, dy)
        keep = np.ones(len(own), dtype=bool) if view_range is None else own | (distance <= view_range + _TOLERANCE)
        if h_count == 1:
            relative = np.zeros((len(dx), 1))
        else:
            bearing = np.degrees(np.arctan2(dx, dy))  # clockwise from north
            relative = np.abs((bearing[:, None] - headings[None, :] * (360.0 / h_count) + 180.0) % 360.0 - 180.0)
        relative[own, :] = 0.0
        seen = relative <= fov / 2.0 + _TOLERANCE
        keep &= seen.any(axis=1)
        if padded is not None:
            check = keep & ~own
            if check.any():
                start = np.stack([(c[check] + 0.5) * s, (layout.rows - r[check] - 0.5) * s], axis=1)
                u0, v0 = _to_pixels(start, resolution, pixels.shape[0])
                u1, v1 = _to_pixels(landmarks[k_all[check]], resolution, pixels.shape[0])
                keep[check] = _clear(padded, u0, v0, u1, v1)
        pair, heading = np.nonzero(seen & keep[:, None])
        cell_of = cells[k_idx[pair], o_idx[pair]]
        out_states.append(cell_of * h_count + heading)
        out_angles.append(relative[pair, heading])
        out_which.append(k_all[pair])
    states, angles, which = np.concatenate(out_states), np.concatenate(out_angles), np.concatenate(out_which)
    order = np.lexsort((states, which))
    return states[order], angles[order], which[order]
