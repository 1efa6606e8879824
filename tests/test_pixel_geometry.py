"""Scan and Look over occupancy pixels against plain-loop references and against the cell versions.

The references know nothing of the kernels' method (run lengths, edge-crossing lists). They state the
blocking rule directly: intersect the segment with every pixel box near it (slab method), give each
blocked pixel a closed interval of the segment's parameter ``t`` and a side -- both sides for a pixel
whose inside the segment crosses, the side it lies on for one the segment only grazes along an edge
or touches at a corner -- and look for the first ``t > 0`` where blocked pixels touch from both
sides. Pixel units throughout: ``u = x / res`` along the columns, ``v = H - y / res`` down the rows.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from beliefloc.errors import InvalidValueError
from beliefloc.model import GridLayout
from beliefloc.semantic_map import geometry
from beliefloc.semantic_map import pixel_geometry as pg

TOL = 1e-9


# ------------------------------------------------------------------------------- the references


def _box_interval(
    p: tuple[float, float], d: tuple[float, float], t_end: float, i: int, j: int
) -> tuple[float, float] | None:
    """The closed ``t`` interval where ``p + t d`` (0 <= t <= t_end) meets pixel ``(i, j)``'s box."""
    lo, hi = (float(j), float(i)), (float(j + 1), float(i + 1))
    ta, tb = 0.0, t_end
    for axis in (0, 1):
        if d[axis] == 0.0:
            if p[axis] < lo[axis] - TOL or p[axis] > hi[axis] + TOL:
                return None
        else:
            t1, t2 = (lo[axis] - p[axis]) / d[axis], (hi[axis] - p[axis]) / d[axis]
            ta, tb = max(ta, min(t1, t2)), min(tb, max(t1, t2))
    if ta > tb + TOL:
        return None
    return ta, max(ta, tb)


def _touches(
    blocked: np.ndarray, p: tuple[float, float], d: tuple[float, float], t_end: float, except_ends: bool
) -> tuple[list[tuple[float, float]], list[tuple[float, float]]]:
    """Closed ``t`` intervals where blocked pixels (the outside too) touch the segment, on its left
    and on its right. With ``except_ends`` the pixels of its first and last stretch are skipped."""
    height, width = blocked.shape
    q = (p[0] + t_end * d[0], p[1] + t_end * d[1])
    left: list[tuple[float, float]] = []
    right: list[tuple[float, float]] = []
    # pixels near the segment; past the ring of outside pixels around the image nothing new can stop it
    i_lo = max(math.floor(min(p[1], q[1])) - 1, min(-1, math.floor(p[1]) - 1))
    i_hi = min(math.ceil(max(p[1], q[1])) + 1, max(height + 1, math.ceil(p[1]) + 1))
    j_lo = max(math.floor(min(p[0], q[0])) - 1, min(-1, math.floor(p[0]) - 1))
    j_hi = min(math.ceil(max(p[0], q[0])) + 1, max(width + 1, math.ceil(p[0]) + 1))
    for i in range(i_lo, i_hi):
        for j in range(j_lo, j_hi):
            if 0 <= i < height and 0 <= j < width and not blocked[i, j]:
                continue
            span = _box_interval(p, d, t_end, i, j)
            if span is None:
                continue
            a, b = span
            cross = d[0] * (i + 0.5 - p[1]) - d[1] * (j + 0.5 - p[0])
            if b - a > TOL:
                if except_ends and (a <= TOL or b >= t_end - TOL):
                    continue
                mid = (p[0] + (a + b) / 2 * d[0], p[1] + (a + b) / 2 * d[1])
                crosses_inside = j + TOL < mid[0] < j + 1 - TOL and i + TOL < mid[1] < i + 1 - TOL
                sides = "lr" if crosses_inside else ("l" if cross > 0 else "r")
            elif abs(cross) > TOL:
                sides = "l" if cross > 0 else "r"
            else:  # touched only at an end of the segment, in line with its centre: never counts
                continue
            if "l" in sides:
                left.append((a, b))
            if "r" in sides:
                right.append((a, b))
    return left, right


def _first_common(left: list[tuple[float, float]], right: list[tuple[float, float]]) -> float:
    """The first ``t > 0`` in both a left and a right interval (``inf`` if none)."""
    best = math.inf
    for a1, b1 in left:
        for a2, b2 in right:
            lo, hi = max(a1, a2), min(b1, b2)
            if lo <= hi + TOL and hi > TOL:
                best = min(best, max(lo, 0.0))
    return best


def _reference_rays(blocked: np.ndarray, resolution: float, layout: GridLayout, max_distance: float) -> np.ndarray:
    """One ray at a time, per the blocking rule."""
    height = blocked.shape[0]
    s = layout.cell_size
    out = []
    for flat in layout.free_cells.tolist():
        r, c = divmod(flat, layout.cols)
        p = ((c + 0.5) * s / resolution, height - (layout.rows - r - 0.5) * s / resolution)
        for dr, dc in geometry.HEADING_VECTORS[layout.headings]:
            step = math.hypot(dr, dc) * resolution  # metres per unit of t
            t_end = (max_distance + 2 * resolution) / step
            if not (0 <= p[0] <= blocked.shape[1] and 0 <= p[1] <= height):
                t = 0.0  # a centre off the image stands on an off-map pixel
            else:
                t = _first_common(*_touches(blocked, p, (float(dc), float(dr)), t_end, except_ends=False))
            distance = t * step
            out.append(distance if distance <= max_distance + 1e-9 else math.inf)
    return np.array(out)


def _reference_clear(blocked: np.ndarray, resolution: float, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    height = blocked.shape[0]
    out = []
    for (x0, y0), (x1, y1) in zip(start.tolist(), end.tolist(), strict=True):
        p = (x0 / resolution, height - y0 / resolution)
        d = (x1 / resolution - p[0], height - y1 / resolution - p[1])
        if d == (0.0, 0.0):
            out.append(True)
            continue
        out.append(_first_common(*_touches(blocked, p, d, 1.0, except_ends=True)) >= 1.0 - TOL)
    return np.array(out, dtype=bool)


def _reference_viewing_angles(
    layout: GridLayout,
    blocked: np.ndarray,
    resolution: float,
    landmarks: np.ndarray,
    view_range: float | None,
    fov: float,
    occlusion: bool,
) -> set[tuple[int, int, float]]:
    """(state, landmark, angle) triples, landmark by landmark, cell by cell, heading by heading."""
    s, h_count = layout.cell_size, layout.headings
    found = set()
    for k, (x, y) in enumerate(landmarks.tolist()):
        lr, lc = layout.rows - 1 - math.floor(y / s), math.floor(x / s)
        for cell, flat in enumerate(layout.free_cells.tolist()):
            r, c = divmod(flat, layout.cols)
            cx, cy = (c + 0.5) * s, (layout.rows - r - 0.5) * s
            own = (r, c) == (lr, lc)
            if not own:
                if view_range is not None and math.hypot(x - cx, y - cy) > view_range + 1e-9:
                    continue
                if occlusion and not _reference_clear(blocked, resolution, np.array([[cx, cy]]), np.array([[x, y]]))[0]:
                    continue
            bearing = math.degrees(math.atan2(x - cx, y - cy))
            for h in range(h_count):
                angle = 0.0 if own or h_count == 1 else abs((bearing - h * 360.0 / h_count + 180.0) % 360.0 - 180.0)
                if angle <= fov / 2 + 1e-9:
                    found.add((cell * h_count + h, k, round(angle, 6)))
    return found


# ------------------------------------------------------------------------------- random inputs


def _random_case(rng: np.random.Generator, headings: tuple[int, ...] = (4, 8)) -> tuple[np.ndarray, float, GridLayout]:
    """Pixels and a grid over them: a random ratio of cell size to resolution (nice ones put cell
    centres on pixel edges and corners, odd ones anywhere), a grid that may stop short of the image or
    reach past it, random free cells."""
    height, width = int(rng.integers(1, 13)), int(rng.integers(1, 13))
    blocked = rng.random((height, width)) < rng.choice([0.0, 0.15, 0.3, 0.5])
    cell_size = float(rng.choice([1.0, 0.6, 0.25]))
    ratio = float(rng.choice([1.0, 2.0, 3.0, 5.0, 2.5, 0.5, 1.5, 4.0 / 3.0, 2.37, 1.618, 0.77]))
    resolution = cell_size / ratio
    rows = max(1, math.ceil(height * resolution / cell_size - 1e-9) + int(rng.integers(-1, 2)))
    cols = max(1, math.ceil(width * resolution / cell_size - 1e-9) + int(rng.integers(-1, 2)))
    free = rng.random((rows, cols)) > rng.choice([0.0, 0.3])
    layout = GridLayout(rows, cols, int(rng.choice(headings)), cell_size, free)
    return blocked, resolution, layout


def _random_points(rng: np.random.Generator, n: int, height: int, width: int, resolution: float) -> np.ndarray:
    """Grid-frame metres: anywhere, on pixel edges, corners and centres, a little off the image."""
    u = rng.uniform(-0.5, width + 0.5, n)
    v = rng.uniform(-0.5, height + 0.5, n)
    snap = rng.random((2, n))
    u = np.where(snap[0] < 0.5, np.round(u * 2) / 2, u)  # half the time an edge or a centre line
    v = np.where(snap[1] < 0.5, np.round(v * 2) / 2, v)
    return np.stack([u * resolution, v * resolution], axis=1)


# ---------------------------------------------------------------------------------- ray casting


def test_ray_distances_equal_the_per_pixel_reference() -> None:
    rng = np.random.default_rng(11)
    for _ in range(120):
        blocked, resolution, layout = _random_case(rng)
        max_distance = float(rng.choice([0.0, 0.4, 1.0, 2.5, 30.0])) * layout.cell_size
        got = pg.ray_distances(blocked, resolution, layout, max_distance)
        expected = _reference_rays(blocked, resolution, layout, max_distance)
        assert got.shape == (layout.n_states,)
        np.testing.assert_array_equal(np.isinf(got), np.isinf(expected))
        np.testing.assert_allclose(got[np.isfinite(got)], expected[np.isfinite(expected)], rtol=0, atol=1e-7)


def _generic_ray(u: float, v: float, dr: int, dc: int) -> bool:
    """The ray neither runs along a pixel edge nor through a pixel corner."""

    def near_integer(a: float) -> bool:
        return abs(a - round(a)) < 1e-6

    if dr == 0:
        return not near_integer(v)
    if dc == 0:
        return not near_integer(u)
    return not near_integer(u + v if dr != dc else u - v)


def test_ray_distances_equal_small_steps_along_generic_rays() -> None:
    """The brief's oracle: march in steps of resolution / 50 until a blocked pixel, on rays that run
    along no edge and through no corner (where sampling cannot decide)."""
    rng = np.random.default_rng(12)
    checked = 0
    for _ in range(25):
        blocked, resolution, layout = _random_case(rng)
        resolution = layout.cell_size / float(rng.choice([2.37, 1.618, 0.77, 3.3]))
        max_distance = 6.0 * layout.cell_size
        got = pg.ray_distances(blocked, resolution, layout, max_distance).reshape(-1, layout.headings)
        height, width = blocked.shape
        s = layout.cell_size
        for n, flat in enumerate(layout.free_cells.tolist()):
            r, c = divmod(flat, layout.cols)
            u0, v0 = (c + 0.5) * s / resolution, height - (layout.rows - r - 0.5) * s / resolution
            for h, (dr, dc) in enumerate(geometry.HEADING_VECTORS[layout.headings]):
                if not _generic_ray(u0, v0, dr, dc):
                    continue
                step = 1.0 / 50.0 / math.hypot(dr, dc)  # pixels of t per sample: res / 50 along the ray
                k = 0
                while True:
                    u, v = u0 + k * step * dc, v0 + k * step * dr
                    i, j = math.floor(v), math.floor(u)
                    if not (0 <= i < height and 0 <= j < width) or blocked[i, j]:
                        break
                    k += 1
                    if k * step * math.hypot(dr, dc) * resolution > max_distance + resolution:
                        break
                metres_per_t = math.hypot(dr, dc) * resolution
                found = k * step * metres_per_t
                value = got[n, h]
                if found > max_distance + resolution / 50:
                    assert value == math.inf or value >= max_distance - resolution / 50
                else:
                    assert found - resolution / 50 - 1e-9 <= value <= found + 1e-9
                checked += 1
    assert checked > 500


def test_ray_distances_equal_wall_distances_when_pixels_are_cells() -> None:
    """``wall_distances`` measures to the near edge of the blocking cell, ``(k - 1/2)`` steps; the
    pixel version measures to the blocked pixel's entry point: the same point when they coincide."""
    rng = np.random.default_rng(13)
    for _ in range(150):
        rows, cols = int(rng.integers(1, 20)), int(rng.integers(1, 20))
        free = rng.random((rows, cols)) > rng.choice([0.0, 0.2, 0.45])
        layout = GridLayout(rows, cols, int(rng.choice([4, 8])), float(rng.choice([1.0, 0.6, 0.25, 0.05])), free)
        max_distance = float(rng.choice([0.3, 1.0, 2.0, 4.5, 50.0])) * layout.cell_size
        expected = geometry.wall_distances(layout, max_distance)
        got = pg.ray_distances(~free, layout.cell_size, layout, max_distance)
        np.testing.assert_array_equal(np.isinf(got), np.isinf(expected))
        np.testing.assert_allclose(got[np.isfinite(got)], expected[np.isfinite(expected)], rtol=0, atol=1e-9)


def _corridor_layout(rows: int, cols: int, headings: int, cell_size: float) -> GridLayout:
    return GridLayout(rows, cols, headings, cell_size, np.ones((rows, cols), dtype=bool))


def test_a_ray_leaving_the_map_stops_at_its_edge() -> None:
    blocked = np.zeros((2, 10), dtype=bool)
    layout = _corridor_layout(1, 5, 4, 0.2)  # cells of 2 x 2 pixels of 0.1 m
    got = pg.ray_distances(blocked, 0.1, layout, 5.0).reshape(5, 4)
    # from the centre of cell 1 (x = 0.3, y = 0.1): 0.1 up, 0.7 right, 0.1 down, 0.3 left
    np.testing.assert_allclose(got[1], [0.1, 0.7, 0.1, 0.3])


def test_rays_along_a_pixel_edge() -> None:
    """Cells of two pixels put every centre on a pixel corner: the rays up run along a column edge."""
    layout = _corridor_layout(4, 1, 4, 2.0)  # one column of cells, centres at x = 1; cell 3's at v = 7
    up = 0
    # a wall on one side of the edge only: grazed, not crossed
    one_side = np.zeros((8, 2), dtype=bool)
    one_side[1:4, 0] = True
    assert pg.ray_distances(one_side, 1.0, layout, 20.0).reshape(4, 4)[3, up] == 7.0  # to the top of the map
    # pixels on both sides of the edge: stopped where they begin (the bottom of row 2, v = 3)
    both = np.zeros((8, 2), dtype=bool)
    both[2, :] = True
    assert pg.ray_distances(both, 1.0, layout, 20.0).reshape(4, 4)[3, up] == 4.0  # from v = 7 to v = 3
    # blocked left below a corner and right above it: a diagonal wall across the edge, stopped at v = 4
    crossed = np.zeros((8, 2), dtype=bool)
    crossed[4, 0] = crossed[3, 1] = True
    assert pg.ray_distances(crossed, 1.0, layout, 20.0).reshape(4, 4)[3, up] == 3.0
    # the same pixels apart: no corner is shared, the ray passes between them
    apart = np.zeros((8, 2), dtype=bool)
    apart[5, 0] = apart[3, 1] = True
    assert pg.ray_distances(apart, 1.0, layout, 20.0).reshape(4, 4)[3, up] == 7.0


def test_a_diagonal_ray_through_a_corner_between_two_blocked_pixels_stops_there() -> None:
    layout = _corridor_layout(1, 1, 8, 1.0)
    pixels = np.zeros((4, 4), dtype=bool)  # cell of 4 x 4 pixels of 0.25 m, centre on the corner (2, 2)
    north_east = 1
    pinched = pixels.copy()
    pinched[0, 2] = pinched[1, 3] = True  # the two pixels beside the corner (v = 1, u = 3)
    got = pg.ray_distances(pinched, 0.25, layout, 5.0).reshape(8)
    assert got[north_east] == pytest.approx(math.sqrt(2) * 0.25)
    single = pixels.copy()
    single[0, 2] = True  # one of them only: touched at its corner, passed
    got = pg.ray_distances(single, 0.25, layout, 5.0).reshape(8)
    assert got[north_east] == pytest.approx(2 * math.sqrt(2) * 0.25)  # to the map's corner


def test_max_distance_cuts_off_to_inf() -> None:
    blocked = np.zeros((2, 10), dtype=bool)
    blocked[:, 7] = True  # wall entered at x = 0.7
    layout = _corridor_layout(1, 1, 4, 0.2)  # centre at x = 0.1
    east = 1
    assert pg.ray_distances(blocked, 0.1, layout, 0.6)[east] == pytest.approx(0.6)  # exactly at the limit
    assert pg.ray_distances(blocked, 0.1, layout, 0.6 - 1e-6)[east] == math.inf
    assert pg.ray_distances(blocked, 0.1, layout, 0.0)[east] == math.inf


def test_a_centre_on_a_blocked_pixel_or_off_the_image_reads_zero() -> None:
    blocked = np.zeros((3, 6), dtype=bool)  # 2.4 m x 1.2 m at 0.4 m
    blocked[1, 1] = True  # under the centre of cell 0 (x = 0.5, y = 0.5: u = 1.25, v = 1.75)
    layout = _corridor_layout(1, 3, 4, 1.0)  # cell 2's centre, x = 2.5, is past the image's right edge
    got = pg.ray_distances(blocked, 0.4, layout, 10.0).reshape(3, 4)
    assert (got[0] == 0.0).all() and (got[2] == 0.0).all()
    np.testing.assert_allclose(got[1], [0.7, 0.9, 0.5, 0.7])  # cell 1, free: west to the blocked pixel


def test_one_heading_has_no_scan() -> None:
    """A scan looks ahead; with headings 1 there is no ahead (the schema refuses a scan sensor on such
    a map, and ``wall_distances`` has no answer either)."""
    layout = _corridor_layout(2, 2, 1, 1.0)
    with pytest.raises(InvalidValueError, match="a scan looks ahead, but the layout has headings: 1"):
        pg.ray_distances(np.zeros((2, 2), dtype=bool), 1.0, layout, 3.0)


@pytest.mark.parametrize(
    ("blocked", "resolution", "message"),
    [
        (np.zeros(3, dtype=bool), 1.0, "non-empty 2-D array"),
        (np.zeros((0, 3), dtype=bool), 1.0, "non-empty 2-D array"),
        (np.zeros((2, 2), dtype=bool), 0.0, "resolution must be a positive number"),
        (np.zeros((2, 2), dtype=bool), math.nan, "resolution must be a positive number"),
    ],
)
def test_malformed_pixels_are_refused(blocked: np.ndarray, resolution: float, message: str) -> None:
    layout = _corridor_layout(2, 2, 4, 1.0)
    with pytest.raises(InvalidValueError, match=message):
        pg.ray_distances(blocked, resolution, layout, 3.0)
    with pytest.raises(InvalidValueError, match=message):
        pg.pixel_line_of_sight(blocked, resolution, np.zeros((1, 2)), np.ones((1, 2)))


def test_inputs_are_not_changed() -> None:
    rng = np.random.default_rng(3)
    blocked, resolution, layout = _random_case(rng)
    before, free_before = blocked.copy(), layout.free.copy()
    pg.ray_distances(blocked, resolution, layout, 3.0)
    starts = _random_points(rng, 20, blocked.shape[0], blocked.shape[1], resolution)
    ends = _random_points(rng, 20, blocked.shape[0], blocked.shape[1], resolution)
    starts_before = starts.copy()
    pg.pixel_line_of_sight(blocked, resolution, starts, ends)
    pg.viewing_angles_metric(layout, blocked, resolution, ends, 2.0, 90.0, True)
    np.testing.assert_array_equal(blocked, before)
    np.testing.assert_array_equal(layout.free, free_before)
    np.testing.assert_array_equal(starts, starts_before)


# ------------------------------------------------------------------------------------ the cache


def test_the_cache_keys_on_content_and_returns_new_arrays() -> None:
    pg.clear_ray_cache()
    rng = np.random.default_rng(4)
    blocked, resolution, layout = _random_case(rng, headings=(8,))
    first = pg.ray_distances(blocked, resolution, layout, 2.0, key="map-a")
    assert pg.ray_cache_info()["misses"] == 1 and pg.ray_cache_info()["entries"] == 1
    first[:] = -1.0  # the caller's copy, not the cached one
    again = pg.ray_distances(blocked, resolution, layout, 2.0, key="map-a")
    assert pg.ray_cache_info()["hits"] == 1
    np.testing.assert_array_equal(again, pg.ray_distances(blocked, resolution, layout, 2.0))
    pg.ray_distances(blocked, resolution, layout, 2.5, key="map-a")  # another max_distance: a miss
    fewer = GridLayout(layout.rows, layout.cols, 8, layout.cell_size, np.zeros_like(layout.free))
    assert len(pg.ray_distances(blocked, resolution, fewer, 2.0, key="map-a")) == 0  # other free cells: a miss
    assert pg.ray_cache_info()["misses"] == 3
    pg.ray_distances(blocked, resolution, layout, 2.0)  # no key: not cached
    assert pg.ray_cache_info()["entries"] == 3
    pg.clear_ray_cache()
    assert pg.ray_cache_info() == {"entries": 0, "bytes": 0, "hits": 0, "misses": 0}


def test_the_cache_is_bounded_least_recently_used_first() -> None:
    cache = pg._RayCache(max_entries=2, max_bytes=100)
    cache.put(("a",), np.zeros(2))
    cache.put(("b",), np.zeros(2))
    assert cache.get(("a",)) is not None  # a is now the most recent
    cache.put(("c",), np.zeros(2))
    assert cache.get(("b",)) is None and cache.get(("a",)) is not None
    cache.put(("big",), np.zeros(20))  # over the byte bound on its own: not kept
    assert cache.get(("big",)) is None
    cache.put(("d",), np.zeros(11))  # 88 bytes: with a's 16 over the bound, a goes
    assert cache.info()["entries"] == 1 and cache.info()["bytes"] == 88


# -------------------------------------------------------------------------------- line of sight


def test_pixel_line_of_sight_equals_the_per_pixel_reference() -> None:
    rng = np.random.default_rng(21)
    for _ in range(150):
        height, width = int(rng.integers(1, 11)), int(rng.integers(1, 11))
        blocked = rng.random((height, width)) < rng.choice([0.1, 0.3, 0.5])
        resolution = float(rng.choice([1.0, 0.05, 0.3]))
        starts = _random_points(rng, 25, height, width, resolution)
        ends = _random_points(rng, 25, height, width, resolution)
        ends[:5] = starts[:5] + rng.choice([0.0, resolution], size=(5, 2))  # axis-parallel and short ones
        got = pg.pixel_line_of_sight(blocked, resolution, starts, ends)
        np.testing.assert_array_equal(got, _reference_clear(blocked, resolution, starts, ends))
        np.testing.assert_array_equal(got, pg.pixel_line_of_sight(blocked, resolution, ends, starts))


def test_pixel_line_of_sight_equals_the_cell_version_between_cell_centres() -> None:
    rng = np.random.default_rng(22)
    for _ in range(60):
        rows, cols = int(rng.integers(1, 15)), int(rng.integers(1, 15))
        free = rng.random((rows, cols)) > 0.3
        rr, cc = rng.integers(rows, size=40), rng.integers(cols, size=40)
        lr, lc = int(rng.integers(rows)), int(rng.integers(cols))
        expected = geometry._line_of_sight(free, rr, cc, lr, lc)
        s = float(rng.choice([1.0, 0.25]))
        starts = np.stack([(cc + 0.5) * s, (rows - rr - 0.5) * s], axis=1)
        ends = np.tile([(lc + 0.5) * s, (rows - lr - 0.5) * s], (40, 1))
        np.testing.assert_array_equal(pg.pixel_line_of_sight(~free, s, starts, ends), expected)


@pytest.mark.parametrize(
    ("pixels", "start", "end", "clear"),
    [
        # (u, v) pixel units, v down from the top; resolution 1
        (["...", ".#.", "..."], (0.5, 1.5), (2.5, 1.5), False),  # through a blocked pixel
        (["...", ".#.", "..."], (0.5, 1.5), (1.5, 1.5), True),  # ending on it: the end pixel is excepted
        (["...", "##.", "..."], (0.5, 1.5), (2.5, 1.5), False),  # a landmark behind a wall
        (["...", ".#.", "..."], (0.5, 1.5), (1.5, 0.5), True),  # touching (1, 1)'s corner only
        (["#..", ".#.", "..."], (0.5, 1.5), (1.5, 0.5), False),  # between (0, 0) and (1, 1) at their corner
        ([".#.", "#..", "..."], (0.5, 0.5), (2.5, 2.5), False),  # between (0, 1) and (1, 0) at their corner
        ([".#.", "#..", "..."], (0.5, 2.5), (2.5, 0.5), True),  # past each of them at a corner
        (["#..", "...", "..."], (1.0, 2.5), (1.0, 0.5), True),  # along an edge, a wall on one side
        (["##.", "...", "..."], (1.0, 2.5), (1.0, 0.5), True),  # ... both sides blocked, but in the end pixels
        (["...", "##.", "..."], (1.0, 2.5), (1.0, 0.5), False),  # ... both sides blocked between the ends
        (["...", "#..", ".#.", "...", "..."], (1.0, 5.0), (1.0, 0.0), False),  # ... a diagonal wall across it
        (["...", "#..", "...", ".#.", "..."], (1.0, 5.0), (1.0, 0.0), True),  # ... one side only at every point
        (["..."], (-2.5, 0.5), (1.5, 0.5), False),  # from outside the map, across its edge
        (["..."], (-0.5, 0.5), (1.5, 0.5), True),  # ... starting in the outside pixel next to it: an end pixel
        (["..."], (0.5, 0.0), (2.5, 0.0), True),  # along the map's top edge: the outside on one side
    ],
)
def test_line_of_sight_cases(
    pixels: list[str], start: tuple[float, float], end: tuple[float, float], clear: bool
) -> None:
    blocked = np.array([[ch == "#" for ch in line] for line in pixels])
    height = blocked.shape[0]
    xy0 = np.array([[start[0], height - start[1]]])
    xy1 = np.array([[end[0], height - end[1]]])
    assert bool(pg.pixel_line_of_sight(blocked, 1.0, xy0, xy1)[0]) is clear
    assert bool(pg.pixel_line_of_sight(blocked, 1.0, xy1, xy0)[0]) is clear
    assert bool(_reference_clear(blocked, 1.0, xy0, xy1)[0]) is clear


def test_line_of_sight_chunks_give_the_same_answer(monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(23)
    blocked = rng.random((30, 40)) < 0.2
    starts = _random_points(rng, 300, 30, 40, 0.1)
    ends = _random_points(rng, 300, 30, 40, 0.1)
    whole = pg.pixel_line_of_sight(blocked, 0.1, starts, ends)
    monkeypatch.setattr(pg, "_CHUNK", 7)
    monkeypatch.setattr(pg, "_WIDTH_STEP", 3)
    np.testing.assert_array_equal(pg.pixel_line_of_sight(blocked, 0.1, starts, ends), whole)


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.lists(st.booleans(), min_size=5, max_size=5), min_size=5, max_size=5),
    st.lists(st.integers(-2, 12).map(lambda k: k / 2), min_size=4, max_size=4),
)
def test_line_of_sight_is_symmetric_and_clear_on_an_empty_map(rows: list[list[bool]], ends: list[float]) -> None:
    """On edges, corners and centres (half-pixel positions), a segment and its reverse agree, and
    nothing but the outside blocks an empty map."""
    blocked = np.array(rows)
    start, end = np.array([ends[:2]]), np.array([ends[2:]])
    assert pg.pixel_line_of_sight(blocked, 1.0, start, end)[0] == pg.pixel_line_of_sight(blocked, 1.0, end, start)[0]
    inside = all(0.0 <= e <= 5.0 for e in ends)
    if inside:
        assert pg.pixel_line_of_sight(np.zeros((5, 5), dtype=bool), 1.0, start, end)[0]


# ------------------------------------------------------------------------------- viewing angles


def _triples(states: np.ndarray, angles: np.ndarray, which: np.ndarray) -> set[tuple[int, int, float]]:
    return {(int(s), int(w), round(float(a), 6)) for s, a, w in zip(states, angles, which, strict=True)}


def test_viewing_angles_metric_equals_the_per_pixel_reference() -> None:
    rng = np.random.default_rng(31)
    for _ in range(40):
        blocked, resolution, layout = _random_case(rng, headings=(1, 4, 8))
        height, width = blocked.shape
        landmarks = _random_points(rng, int(rng.integers(1, 5)), height, width, resolution)
        view_range = None if rng.random() < 0.3 else float(rng.choice([0.0, 0.5, 1.0, 2.5])) * layout.cell_size
        fov = 360.0 if layout.headings == 1 else float(rng.choice([30.0, 90.0, 135.0, 360.0]))
        occlusion = bool(rng.random() < 0.7)
        states, angles, which = pg.viewing_angles_metric(
            layout, blocked, resolution, landmarks, view_range, fov, occlusion
        )
        expected = _reference_viewing_angles(layout, blocked, resolution, landmarks, view_range, fov, occlusion)
        assert _triples(states, angles, which) == expected
        assert len(states) == len(expected)  # no pair twice
        order = np.lexsort((states, which))
        np.testing.assert_array_equal(order, np.arange(len(order)))  # by landmark, then state


def test_viewing_angles_metric_equals_the_cell_version_at_cell_centres() -> None:
    rng = np.random.default_rng(32)
    for _ in range(80):
        rows, cols = int(rng.integers(1, 18)), int(rng.integers(1, 18))
        free = rng.random((rows, cols)) > rng.choice([0.0, 0.2, 0.4])
        s = float(rng.choice([1.0, 0.6, 0.25]))
        layout = GridLayout(rows, cols, int(rng.choice([1, 4, 8])), s, free)
        picks = rng.integers(rows * cols, size=int(rng.integers(1, 8)))
        cells = np.stack(np.divmod(picks, cols), axis=1)  # landmarks on free and blocked cells alike
        view_range = None if rng.random() < 0.3 else float(rng.choice([0.0, 1.0, 1.5, 2.0, 3.7, 8.0])) * s
        fov = float(rng.choice([30.0, 90.0, 135.0, 360.0]))
        occlusion = bool(rng.random() < 0.7)
        expected = geometry.viewing_angles_many(layout, cells, view_range, fov, occlusion)
        xy = np.stack([(cells[:, 1] + 0.5) * s, (rows - cells[:, 0] - 0.5) * s], axis=1)
        got = pg.viewing_angles_metric(layout, ~free, s, xy, view_range, fov, occlusion)
        assert _triples(*got) == _triples(*expected)


def test_a_landmark_in_the_robots_own_cell_is_seen_from_every_heading() -> None:
    layout = _corridor_layout(3, 3, 4, 1.0)
    blocked = np.zeros((12, 12), dtype=bool)
    blocked[5, 4:8] = True  # a wall across the middle cell, between its centre and the landmark
    landmark = np.array([[1.5, 1.9]])  # in cell (1, 1), 0.4 m north of its centre, past the wall
    states, angles, which = pg.viewing_angles_metric(layout, blocked, 0.25, landmark, 0.1, 10.0, True)
    centre = layout.state_of(1, 1)
    assert states.tolist() == [centre, centre + 1, centre + 2, centre + 3]
    assert angles.tolist() == [0.0] * 4 and which.tolist() == [0] * 4


def test_a_landmark_on_an_occupied_pixel_is_visible_but_not_through_its_table() -> None:
    layout = GridLayout(1, 5, 4, 1.0, np.array([[True, True, True, True, True]]))
    blocked = np.zeros((4, 20), dtype=bool)
    blocked[1:3, 10:12] = True  # a table of 2 x 2 pixels in cell (0, 2)
    east_of = np.array([[2.88, 0.62]])  # on the table's top-right pixel
    states, _, _ = pg.viewing_angles_metric(layout, blocked, 0.25, east_of, None, 360.0, True)
    cells = sorted({int(s) // 4 for s in states})
    assert cells == [2, 3, 4]  # its own cell, and from the east; from the west the table is in the way


def test_viewing_angles_metric_chunks_give_the_same_answer(monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(33)
    blocked, resolution, layout = _random_case(rng, headings=(8,))
    landmarks = _random_points(rng, 6, blocked.shape[0], blocked.shape[1], resolution)
    whole = pg.viewing_angles_metric(layout, blocked, resolution, landmarks, 3.0, 120.0, True)
    monkeypatch.setattr(pg, "_CHUNK", 5)
    parts = pg.viewing_angles_metric(layout, blocked, resolution, landmarks, 3.0, 120.0, True)
    for a, b in zip(whole, parts, strict=True):
        np.testing.assert_array_equal(a, b)


def test_viewing_angles_metric_with_no_landmarks() -> None:
    layout = _corridor_layout(2, 2, 4, 1.0)
    states, angles, which = pg.viewing_angles_metric(
        layout, np.zeros((2, 2), dtype=bool), 1.0, np.zeros((0, 2)), 2.0, 90.0, True
    )
    assert len(states) == len(angles) == len(which) == 0


# ---------------------------------------------------------------------------------------- scale
