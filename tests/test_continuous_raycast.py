"""Ray casting: the grid traversal against a plain march along each ray, and exact cases."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

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
