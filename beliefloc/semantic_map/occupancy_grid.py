"""Cells laid over an occupancy map's pixels: which cells are states, and which room each is in.

The cells and the pixels share the grid frame of :class:`~beliefloc.model.GridLayout`: its origin is
the lower-left corner of the image (the ROS map's ``origin``), x along the columns, y up the rows.
Pixel ``(i, j)`` (row ``i`` from the top of an image ``H`` pixels high) covers
``j·res <= x < (j+1)·res`` and ``(H-1-i)·res <= y < (H-i)·res``; cell ``(r, c)`` of side ``s`` covers
``c·s <= x < (c+1)·s`` and ``(rows-1-r)·s <= y < (rows-r)·s``. The grid has as many cells as it
takes to cover the image, so the top row and the right column may reach past it: the outside of
the map is unknown space.

**The state rule.** A cell is a state when

1. every pixel whose centre lies in the cell is free,
2. the pixel under the cell's centre is free (this matters when cells are smaller than pixels), and
3. no occupied or unknown pixel -- nor the outside of the map -- has its centre closer than
   ``robot_radius`` to the cell's centre: the robot, a disc standing on the centre, fits.

Unknown space is never a place the robot can be; its edge counts as a wall.

Pure numpy, no I/O: the pixels come from :mod:`beliefloc.semantic_map.occupancy_map`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from beliefloc.model import MapFrame

_TIE = 1e-9
"""Distances (in pixels) within this of the robot's radius are ties: not closer than it."""


def grid_shape(height: int, width: int, resolution: float, cell_size: float) -> tuple[int, int]:
    """``(rows, cols)`` of the cells that cover an image of ``height x width`` pixels."""
    rows = max(1, math.ceil(height * resolution / cell_size - 1e-9))
    cols = max(1, math.ceil(width * resolution / cell_size - 1e-9))
    return rows, cols


def cell_centres_px(rows: int, cols: int, cell_size: float, resolution: float) -> tuple[np.ndarray, np.ndarray]:
    """The centre of every cell in the grid frame, in pixels: ``(u, v)`` with ``u`` along the
    columns and ``v`` up the rows from the image's lower-left corner. Arrays of shape ``(rows, cols)``."""
    r, c = np.mgrid[0:rows, 0:cols]
    return (c + 0.5) * cell_size / resolution, (rows - r - 0.5) * cell_size / resolution


def _pixel_under(u: np.ndarray, v: np.ndarray, height: int) -> tuple[np.ndarray, np.ndarray]:
    """``(i, j)`` of the pixel holding each point (row ``i`` from the top; pixels are half-open, so a
    point on the image's top or right edge is outside it)."""
    return height - 1 - np.floor(v).astype(np.int64), np.floor(u).astype(np.int64)


def free_cells(blocked: np.ndarray, resolution: float, cell_size: float, robot_radius: float) -> np.ndarray:
    """``free[r, c]``: cell ``(r, c)`` is a state by the module's rule. ``blocked[i, j]`` is True for an
    occupied or unknown pixel (row 0 at the top)."""
    height, width = blocked.shape
    rows, cols = grid_shape(height, width, resolution, cell_size)
    # 1. every pixel whose centre lies in the cell is free
    i, j = np.nonzero(blocked)
    cell_c = np.floor((j + 0.5) * resolution / cell_size).astype(np.int64)
    cell_r = rows - 1 - np.floor((height - i - 0.5) * resolution / cell_size).astype(np.int64)
    has_blocked = np.zeros(rows * cols, dtype=bool)
    has_blocked[cell_r * cols + cell_c] = True
    free = ~has_blocked.reshape(rows, cols)
    # 2. and 3. the pixel under the centre and every pixel centre within the robot's radius
    u, v = cell_centres_px(rows, cols, cell_size, resolution)
    i0, j0 = _pixel_under(u, v, height)
    reach = math.ceil(robot_radius / resolution) + 1 if robot_radius > 0 else 0
    radius_px = robot_radius / resolution
    for di in range(-reach, reach + 1):
        for dj in range(-reach, reach + 1):
            pi, pj = i0 + di, j0 + dj
            if (di, dj) != (0, 0):
                distance = np.hypot(pj + 0.5 - u, height - pi - 0.5 - v)
                near = distance < radius_px - _TIE  # a pixel exactly at the radius is not closer
                if not near.any():
                    continue
            else:
                near = np.ones_like(free)
            inside = (pi >= 0) & (pi < height) & (pj >= 0) & (pj < width)
            stopped = ~inside
            stopped[inside] = blocked[pi[inside], pj[inside]]
            free &= ~(near & stopped)
    return free


def rooms_from_mask(
    values: np.ndarray, labels: Mapping[int, str], resolution: float, cell_size: float, free: np.ndarray
) -> dict[str, np.ndarray]:
    """Room name -> ``mask[r, c]``: the free cells whose centre stands on a pixel of value ``k`` in
    the region mask (``values``, row 0 at the top), for each ``k: name`` of ``labels``."""
    height, width = values.shape
    rows, cols = free.shape
    i, j = _pixel_under(*cell_centres_px(rows, cols, cell_size, resolution), height)
    inside = (i >= 0) & (i < height) & (j >= 0) & (j < width)
    under = np.full((rows, cols), -1, dtype=np.int64)
    under[inside] = values[i[inside], j[inside]]
    return {name: (under == value) & free for value, name in labels.items()}


def rooms_from_polygons(
    polygons: Mapping[str, Sequence[tuple[float, float]]], frame: MapFrame, cell_size: float, free: np.ndarray
) -> dict[str, np.ndarray]:
    """Room name -> ``mask[r, c]``: the free cells whose centre lies inside the room's polygon
    (vertices in map-frame metres, even-odd rule; a centre exactly on an edge may fall either way)."""
    rows, cols = free.shape
    r, c = np.mgrid[0:rows, 0:cols]
    x, y = frame.to_map((c + 0.5) * cell_size, (rows - r - 0.5) * cell_size)
    return {name: _inside(np.asarray(vertices, dtype=np.float64), x, y) & free for name, vertices in polygons.items()}


def _inside(vertices: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Even-odd point-in-polygon test, vectorised over the points ``(x, y)``."""
    inside = np.zeros(x.shape, dtype=bool)
    n = len(vertices)
    for k in range(n):
        (x1, y1), (x2, y2) = vertices[k], vertices[(k + 1) % n]
        straddles = (y1 > y) != (y2 > y)
        if y1 == y2:
            continue
        crossing_x = x1 + (y - y1) * (x2 - x1) / (y2 - y1)
        inside ^= straddles & (x < crossing_x)
    return inside
