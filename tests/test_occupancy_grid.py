"""Cells over an occupancy map's pixels (beliefloc.semantic_map.occupancy_grid): the state rule against
a plain-loop reference, worked examples, rooms from a region mask and from polygons."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from beliefloc.model import MapFrame
from beliefloc.semantic_map.occupancy_grid import (
    free_cells,
    grid_shape,
    rooms_from_mask,
    rooms_from_polygons,
)


def _reference_free(blocked: np.ndarray, resolution: float, cell_size: float, radius: float) -> np.ndarray:
    """The module's rule, pixel by pixel and cell by cell."""
    height, width = blocked.shape
    rows, cols = grid_shape(height, width, resolution, cell_size)
    free = np.ones((rows, cols), dtype=bool)
    for r in range(rows):
        for c in range(cols):
            cx, cy = (c + 0.5) * cell_size, (rows - r - 0.5) * cell_size  # grid frame, metres
            # the pixel under the centre must be inside and free
            j, i = math.floor(cx / resolution), height - 1 - math.floor(cy / resolution)
            if not (0 <= i < height and 0 <= j < width) or blocked[i, j]:
                free[r, c] = False
                continue
            for i in range(height):
                for j in range(width):
                    px, py = (j + 0.5) * resolution, (height - i - 0.5) * resolution
                    in_cell = (
                        c * cell_size <= px < (c + 1) * cell_size
                        and (rows - 1 - r) * cell_size <= py < (rows - r) * cell_size
                    )
                    if blocked[i, j] and (in_cell or math.hypot(px - cx, py - cy) < radius - 1e-9 * resolution):
                        free[r, c] = False
            # the outside of the map within the radius: any pixel position off the image that close
            reach = math.ceil(radius / resolution) + 1
            j0, i0 = math.floor(cx / resolution), height - 1 - math.floor(cy / resolution)
            for i in range(i0 - reach, i0 + reach + 1):
                for j in range(j0 - reach, j0 + reach + 1):
                    if 0 <= i < height and 0 <= j < width:
                        continue
                    px, py = (j + 0.5) * resolution, (height - i - 0.5) * resolution
                    if math.hypot(px - cx, py - cy) < radius - 1e-9 * resolution:
                        free[r, c] = False
    return free


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    height=st.integers(1, 9),
    width=st.integers(1, 9),
    resolution=st.sampled_from([0.05, 0.1, 0.25]),
    ratio=st.sampled_from([0.5, 1.0, 1.5, 2.0, 3.0, 2.5]),
    radius=st.sampled_from([0.0, 0.05, 0.12, 0.3]),
    density=st.floats(0.0, 0.4),
)
def test_free_cells_follow_the_rule(seed, height, width, resolution, ratio, radius, density):
    blocked = np.random.default_rng(seed).random((height, width)) < density
    cell_size = resolution * ratio
    assert np.array_equal(
        free_cells(blocked, resolution, cell_size, radius), _reference_free(blocked, resolution, cell_size, radius)
    )


def test_a_wall_keeps_the_robot_at_its_radius():
    """2x2-pixel cells on an 8x8 image whose right column is a wall. Cell (1, 2) has its centre at
    (5, 5) pixels from the lower-left corner: 2.5 from the wall's pixel centres (x = 7.5), 3.5 from
    the outside above the image and 5.5 from the others."""
    blocked = np.zeros((8, 8), dtype=bool)
    blocked[:, 7] = True
    assert free_cells(blocked, 1.0, 2.0, 0.0)[:, 3].tolist() == [False] * 4  # the wall's own cells
    assert free_cells(blocked, 1.0, 2.0, 0.0)[:, :3].all()
    assert free_cells(blocked, 1.0, 2.0, 2.4)[1, 2]
    assert not free_cells(blocked, 1.0, 2.0, 2.6)[1, 2]


def test_the_outside_of_the_map_is_unknown_space():
    """A 3x3-pixel image under 2x2-pixel cells: the grid covers 4x4 pixels; the cells reaching past
    the image have their centres on no pixel and are not states."""
    blocked = np.zeros((3, 3), dtype=bool)
    assert grid_shape(3, 3, 1.0, 2.0) == (2, 2)
    # cell (1, 0) covers pixel rows 1-2 (from the top) and columns 0-1: centre at pixel corner (1, 2)
    assert free_cells(blocked, 1.0, 2.0, 0.0).tolist() == [[False, False], [True, False]]


def test_rooms_from_a_region_mask_follow_the_centre_pixel():
    values = np.array([[1, 1, 2, 2], [1, 1, 2, 2], [0, 0, 2, 2], [0, 0, 2, 2]])
    free = np.ones((2, 2), dtype=bool)
    rooms = rooms_from_mask(values, {1: "office", 2: "hall"}, 1.0, 2.0, free)
    assert rooms["office"].tolist() == [[True, False], [False, False]]
    assert rooms["hall"].tolist() == [[False, True], [False, True]]


def test_rooms_from_polygons_in_a_rotated_frame():
    """A quarter turn: the grid's x axis points up the map's y axis."""
    free = np.ones((2, 2), dtype=bool)
    frame = MapFrame(10.0, 0.0, math.pi / 2)
    # cell (1, 0): grid centre (0.5, 0.5) -> map (9.5, 0.5); cell (0, 1): grid (1.5, 1.5) -> map (8.5, 1.5)
    rooms = rooms_from_polygons({"a": [(9.0, 0.0), (10.0, 0.0), (10.0, 1.0), (9.0, 1.0)]}, frame, 1.0, free)
    assert rooms["a"].tolist() == [[False, False], [True, False]]
    rooms = rooms_from_polygons({"b": [(8.0, 1.0), (9.0, 1.0), (9.0, 2.0), (8.0, 2.0)]}, frame, 1.0, free)
    assert rooms["b"].tolist() == [[False, True], [False, False]]


@pytest.mark.parametrize(("height", "width", "resolution", "cell", "shape"), [(307, 604, 0.05, 0.25, (62, 121))])
def test_grid_shape_covers_the_image(height, width, resolution, cell, shape):
    assert grid_shape(height, width, resolution, cell) == shape
