"""Ray casting: the grid traversal against a plain march along each ray, and exact cases."""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from beliefloc.continuous import raycast
from beliefloc.continuous.image import OccupancyImage
from beliefloc.continuous.raycast import cast_rays, cast_scan
from beliefloc.model import MapFrame


def _march(image: OccupancyImage, x: float, y: float, angle: float, max_range: float, step: float) -> float:
    """The oracle: walk the ray in tiny steps until a blocked pixel, the image's edge or max_range."""
    t = 0.0
    while t <= max_range:
        i, j = image.pixel_of(x + t * math.cos(angle), y + t * math.sin(angle))
        if not (0 <= i < image.height and 0 <= j < image.width):
            return math.inf
        if image.blocked[i, j]:
            return t
        t += step
    return math.inf


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**31),
    yaw=st.sampled_from([0.0, 0.4, -2.0]),
    resolution=st.sampled_from([0.05, 0.1]),
)
def test_traversal_matches_a_fine_march(seed: int, yaw: float, resolution: float) -> None:
    rng = np.random.default_rng(seed)
    blocked = rng.random((23, 31)) < 0.08
    image = OccupancyImage(blocked, resolution, MapFrame(-0.7, 0.3, yaw))
    u, v = rng.uniform(0, 31, 20), rng.uniform(0, 23, 20)
    x, y = image.to_map(u, v)
    angles = rng.uniform(-math.pi, math.pi, 20)
    fast = cast_rays(image, x, y, angles, max_range=2.0)
    step = resolution / 200
    for n in range(20):
        slow = _march(image, float(x[n]), float(y[n]), float(angles[n]), 2.0, step)
        if math.isinf(slow) and math.isinf(fast[n]):
            continue
        if not math.isinf(fast[n]) and abs(fast[n] - slow) > 2 * step:
            # the march may step over a pixel the ray only grazes at its corner
            hu, hv = image.to_pixel(x[n] + fast[n] * math.cos(angles[n]), y[n] + fast[n] * math.sin(angles[n]))
            corner = np.hypot(hu - np.round(hu), hv - np.round(hv)) * resolution
            assert corner < 4 * step, (n, slow, fast[n])
            continue
        if math.isinf(fast[n]) != math.isinf(slow):
            # a ray that ends right at max_range may fall either side of it by a step
            assert abs(min(slow, fast[n]) - 2.0) < 2 * step
        else:
            assert fast[n] == pytest.approx(slow, abs=2 * step)


def test_wall_along_an_axis_is_read_exactly() -> None:
    blocked = np.zeros((10, 10), dtype=bool)
    blocked[:, 7] = True  # column 7: x in [0.7, 0.8) at 0.1 m per pixel
    image = OccupancyImage(blocked, 0.1, MapFrame(0.0, 0.0, 0.0))
    assert cast_rays(image, 0.23, 0.55, 0.0, 5.0) == pytest.approx(0.47)
    assert cast_rays(image, 0.23, 0.55, math.pi / 6, 5.0) == pytest.approx(0.47 / math.cos(math.pi / 6))
    assert cast_rays(image, 0.75, 0.55, 1.0, 5.0) == 0.0  # starts inside the wall
    assert math.isinf(cast_rays(image, 0.23, 0.55, math.pi, 5.0))  # leaves the image
    assert math.isinf(cast_rays(image, 0.23, 0.55, 0.0, 0.4))  # beyond max_range
    assert math.isinf(cast_rays(image, -3.0, 0.55, 0.0, 5.0))  # starts outside


def test_scan_shape_and_sensor_frame() -> None:
    blocked = np.zeros((20, 20), dtype=bool)
    blocked[0, :] = blocked[-1, :] = blocked[:, 0] = blocked[:, -1] = True
    image = OccupancyImage(blocked, 0.1, MapFrame(0.0, 0.0, 0.0))
    poses = np.array([[1.0, 1.0, 0.0], [1.0, 1.0, math.pi / 2]])
    angles = np.array([0.0, math.pi / 2])
    ranges = cast_scan(image, poses, angles, 10.0)
    assert ranges.shape == (2, 2)
    assert ranges[0, 1] == pytest.approx(ranges[1, 0])  # beam +90° of a robot facing east looks north
    assert ranges[0, 0] == pytest.approx(0.9)  # east wall is column 19: x = 1.9


def test_bad_range_is_refused() -> None:
    image = OccupancyImage(np.zeros((2, 2), dtype=bool), 0.1, MapFrame())
    with pytest.raises(ValueError, match="max_range"):
        cast_rays(image, 0.0, 0.0, 0.0, math.inf)


@contextlib.contextmanager
def _leap_from(rays: int) -> Iterator[None]:
    """Cast with :data:`raycast.LEAP_FROM` set to ``rays`` (1: always leap; huge: never)."""
    saved = raycast.LEAP_FROM
    raycast.LEAP_FROM = rays
    try:
        yield
    finally:
        raycast.LEAP_FROM = saved


def _walls(rng: np.random.Generator, height: int, width: int, density: float) -> np.ndarray:
    """Random blocked pixels and two one-pixel diagonal walls (rays meet their corners)."""
    blocked = rng.random((height, width)) < density
    n = min(height, width) - 4
    k = np.arange(n)
    blocked[2 + k, 2 + k] = True
    blocked[height - 3 - k // 2, width // 2 + k // 2] = True
    return blocked


def _awkward_rays(
    rng: np.random.Generator, image: OccupancyImage, n: int, yaw: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``n`` rays (map-frame starts and angles) from two pixels around the image and within it, half of
    them starting on half or whole pixels (pixel edges and corners), two thirds at angles in steps of
    15 degrees from the frame's yaw (along pixel edges, through corners)."""
    u, v = rng.uniform(-2, image.width + 2, n), rng.uniform(-2, image.height + 2, n)
    u[: n // 2], v[: n // 2] = np.round(u[: n // 2] * 2) / 2, np.round(v[: n // 2] * 2) / 2
    x, y = image.to_map(u, v)
    angles = rng.uniform(-math.pi, math.pi, n)
    angles[: 2 * n // 3] = rng.integers(0, 24, 2 * n // 3) * math.pi / 12 + yaw
    return x, y, angles


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**31), density=st.sampled_from([0.0, 0.01, 0.06]), yaw=st.sampled_from([0.0, 0.3]))
def test_leaping_through_open_space_reads_the_ranges_of_the_step_by_step_traversal(
    seed: int, density: float, yaw: float
) -> None:
    """Many rays leap by the distance transform; the ranges are those of one step per pixel, also for
    rays through pixel corners and along pixel edges (starts on half and whole pixels, angles in
    steps of 15 degrees) and for rays that leave the image or their reach."""
    rng = np.random.default_rng(seed)
    image = OccupancyImage(_walls(rng, 37, 53, density), 0.05, MapFrame(-0.3, 0.2, yaw))
    n = 3000
    x, y, angles = _awkward_rays(rng, image, n, yaw)
    reach = rng.uniform(0.2, 2.0, n)
    with _leap_from(1):
        leaping = raycast.cast_rays_within(image, x, y, angles, reach)
    with _leap_from(10**9):
        stepping = raycast.cast_rays_within(image, x, y, angles, reach)
    with np.errstate(invalid="ignore"):  # inf - inf
        close = (np.isinf(leaping) & np.isinf(stepping)) | (np.abs(leaping - stepping) < 1e-9)
    at_reach = np.abs(np.where(np.isfinite(stepping), stepping, leaping) - reach) < 1e-9  # either side of it
    assert (close | at_reach).all(), np.flatnonzero(~(close | at_reach))[:5]
    assert np.isfinite(stepping).sum() > n // 10  # the walls are met


@pytest.mark.parametrize("cell_size", [0.25, 0.1, 0.15])
def test_rays_from_cell_centres_read_the_exact_models_ranges(cell_size: float) -> None:
    """The blocking rule at pixel corners and edges is the exact model's (pixel_geometry): cells of
    0.25 m over 0.05 m pixels send every diagonal ray through pixel corners, cells of 0.1 m put the
    centres on pixel corners and the axis-aligned rays along pixel edges."""
    from beliefloc.model import GridLayout
    from beliefloc.semantic_map import pixel_geometry, regions

    rng = np.random.default_rng(7)
    resolution = 0.05
    blocked = _walls(rng, 36, 54, 0.04)
    rows, cols = round(36 * resolution / cell_size), round(54 * resolution / cell_size)
    layout = GridLayout(rows, cols, 8, cell_size, np.ones((rows, cols), dtype=bool), (), MapFrame())
    exact = pixel_geometry.ray_distances(blocked, resolution, layout, 1.5)
    image = regions.blocked_image(blocked, resolution)
    poses, _ = regions.sub_poses(layout, image, regions.RegionSpec(1, 1))
    for leap_from in (1, 10**9):
        with _leap_from(leap_from):
            got = cast_rays(image, poses[:, 0, 0], poses[:, 0, 1], poses[:, 0, 2], 1.5 + 1e-9)
        with np.errstate(invalid="ignore"):  # inf - inf
            same = (np.isinf(exact) & np.isinf(got)) | (np.abs(exact - got) < 1e-9)
        assert same.all(), (leap_from, np.flatnonzero(~same)[:5])


def test_each_ray_stops_at_its_own_reach() -> None:
    blocked = np.zeros((10, 10), dtype=bool)
    blocked[:, 7] = True  # x in [0.7, 0.8)
    image = OccupancyImage(blocked, 0.1, MapFrame(0.0, 0.0, 0.0))
    got = raycast.cast_rays_within(image, 0.23, 0.55, 0.0, np.array([0.3, 0.48, 0.6, -1.0]))
    assert math.isinf(got[0]) and got[1] == pytest.approx(0.47) and got[2] == pytest.approx(0.47)
    assert math.isinf(got[3])


@pytest.mark.parametrize("leap", [1, 10**9])
def test_rays_cast_in_parts_on_threads_read_the_same_bits(monkeypatch: pytest.MonkeyPatch, leap: int) -> None:
    """Many rays are cast in parts, one a thread: each ray's walk is its own, so the ranges are the
    very bits of one cast in one thread, whatever the parts (uneven ones included)."""
    from concurrent.futures import ThreadPoolExecutor

    from beliefloc.source import threads

    rng = np.random.default_rng(3)
    image = OccupancyImage(_walls(rng, 37, 53, 0.02), 0.05, MapFrame(0.1, -0.2, 0.3))
    n = 4001
    x, y = image.to_map(rng.uniform(-2, 55, n), rng.uniform(-2, 39, n))
    angles, reach = rng.uniform(-math.pi, math.pi, n), rng.uniform(0.2, 2.0, n)
    monkeypatch.setattr(threads, "_POOL", None)
    monkeypatch.setattr(threads, "_POOL_MADE", True)
    with _leap_from(leap):
        alone = raycast.cast_rays_within(image, x, y, angles, reach)
        monkeypatch.setattr(raycast, "THREADED_FROM", 1)
        for workers in (2, 3):
            with ThreadPoolExecutor(workers) as pool:
                monkeypatch.setattr(threads, "_POOL", pool)
                parts = raycast.cast_rays_within(image, x, y, angles, reach)
            assert parts.tobytes() == alone.tobytes()
    assert np.isfinite(alone).sum() > n // 10


@pytest.mark.skipif(raycast.compiled is None, reason="the compiled walk is not built")
@settings(max_examples=20, deadline=None)
@given(
    seed=st.integers(0, 2**31),
    density=st.sampled_from([0.0, 0.01, 0.06, 0.3]),
    yaw=st.sampled_from([0.0, 0.3, -math.pi / 2]),
)
def test_the_compiled_walk_reads_the_numpy_walk_s_very_bits(seed: int, density: float, yaw: float) -> None:
    """``_raycast.c`` walks each ray alone through the same steps and leaps: every range is NumPy's
    bit for bit -- rays from blocked pixels, from outside the image, along pixel edges and through
    corners (starts on half and whole pixels, angles in steps of 15 degrees), past their reach."""
    rng = np.random.default_rng(seed)
    image = OccupancyImage(_walls(rng, 41, 47, density), 0.05, MapFrame(-0.3, 0.2, yaw))
    n = 5000
    x, y, angles = _awkward_rays(rng, image, n, yaw)
    reach = rng.uniform(0.05, 3.0, n)
    saved = raycast.compiled
    with _leap_from(1):
        compiled = raycast.cast_rays_within(image, x, y, angles, reach)
        try:
            raycast.compiled = None
            numpy_walk = raycast.cast_rays_within(image, x, y, angles, reach)
        finally:
            raycast.compiled = saved
    assert compiled.tobytes() == numpy_walk.tobytes()
    assert np.isfinite(compiled).sum() > n // 20


@pytest.mark.skipif(raycast.compiled is None, reason="the compiled walk is not built")
def test_the_compiled_walk_refuses_arrays_that_do_not_fit() -> None:
    """Nothing past a buffer is read: a ray index out of range, a ray outside the image, arrays of
    other lengths or types are a ValueError or TypeError, not a crash."""
    assert raycast.compiled is not None
    blocked = np.zeros((4, 5), dtype=bool)
    clearance = np.zeros((4, 5))
    floats = [np.zeros(2) for _ in range(7)]
    ints = [np.ones(2, dtype=np.int64), np.ones(2, dtype=np.int64)]
    edges = [np.zeros(2, dtype=bool), np.zeros(2, dtype=bool)]
    state = [
        np.ones(2, dtype=np.int64),
        np.ones(2, dtype=np.int64),
        *(np.zeros(2) for _ in range(3)),
        np.full(2, np.inf),
    ]

    def walk(walking: np.ndarray, *, col: np.ndarray | None = None, image: np.ndarray = clearance) -> None:
        cols = state[0] if col is None else col
        assert raycast.compiled is not None
        raycast.compiled.walk(blocked, image, *floats, *ints, *edges, cols, *state[1:], walking)

    walk(np.array([0, 1]))  # fits: a walk in an empty image runs off its edge
    with pytest.raises(ValueError, match="walking ray"):
        walk(np.array([2]))
    with pytest.raises(ValueError, match="walking ray"):
        walk(np.array([0]), col=np.array([7, 1]))
    with pytest.raises(ValueError, match="one shape"):
        walk(np.array([0]), image=np.zeros((5, 4)))
    with pytest.raises(ValueError, match="col"):
        walk(np.array([0]), col=np.ones(3, dtype=np.int64))
    with pytest.raises(TypeError, match="walking"):
        walk(np.array([0.0]))


# --- discs met exactly ----------------------------------------------------------------------------


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    count=st.integers(1, 5),
)
def test_a_ray_meets_a_disc_where_marching_along_it_first_enters_one(seed: int, count: int) -> None:
    """:func:`raycast.ray_disc_distances` against a plain march along each ray in steps of 1 mm."""
    rng = np.random.default_rng(seed)
    discs = np.column_stack([rng.uniform(-3, 3, count), rng.uniform(-3, 3, count), rng.uniform(0.05, 0.5, count)])
    x, y, angle = rng.uniform(-4, 4, 20), rng.uniform(-4, 4, 20), rng.uniform(-math.pi, math.pi, 20)
    got = raycast.ray_disc_distances(x, y, angle, discs, 6.0)
    t = np.arange(0.0, 6.0, 1e-3)
    px = x[:, None, None] + t[None, :, None] * np.cos(angle)[:, None, None]
    py = y[:, None, None] + t[None, :, None] * np.sin(angle)[:, None, None]
    inside = (np.hypot(px - discs[:, 0], py - discs[:, 1]) <= discs[:, 2]).any(axis=2)
    for i in range(len(x)):
        hits = np.flatnonzero(inside[i])
        if hits.size:
            assert got[i] == pytest.approx(t[hits[0]], abs=1.5e-3)
        else:
            assert got[i] == math.inf or got[i] > 6.0 - 1e-3


def test_a_small_disc_on_a_hand_drawn_grid_blocks_itself_not_its_cell() -> None:
    """A hand-drawn grid's world has one pixel a cell (the hallway's 1.5 m): a disc of 0.19 m drawn into
    that image blocked its whole cell and cut the hallway in two (a confident mirror answer followed).
    Rays meet the disc itself."""
    from beliefloc import load_map
    from beliefloc.continuous.world import WorldConfig
    from beliefloc.simulation.continuous_episode import world_of

    from .conftest import MAPS

    world = world_of(load_map(MAPS / "hallway.yaml"), WorldConfig(), np.random.default_rng(0))
    world.clutter_discs = np.array([[3.66, 0.6, 0.19]])
    # along the hallway, past the disc: the east end wall, 6 m from the west end
    assert float(world.cast(2.78, 1.14, 0.0, 12.0)) == pytest.approx(6.0 - 2.78, abs=1e-9)
    # straight at it: its edge
    assert float(world.cast(2.78, 0.6, 0.0, 12.0)) == pytest.approx(3.66 - 0.19 - 2.78, abs=1e-9)
