"""An occupancy image placed in the map frame: what ray casting, the likelihood field and the
continuous simulated world read.

Pixel ``(i, j)`` (row ``i`` from the top of an image ``H`` pixels high) covers, in the grid frame of
:class:`~beliefloc.model.MapFrame` (origin at the image's lower-left corner, x along the columns,
y up the rows), ``j·res <= gx < (j+1)·res`` and ``(H-1-i)·res <= gy < (H-i)·res`` -- the convention
of :mod:`beliefloc.semantic_map.occupancy_map` and Nav2's map server. *Pixel coordinates* ``(u, v) = (gx, gy) / res``
are continuous: pixel ``(i, j)`` holds the points with ``floor(u) = j`` and ``floor(v) = H-1-i``.

Pure numpy, no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from beliefloc.model import MapFrame
from beliefloc.semantic_map.occupancy_map import Occupancy, OccupancyMap


@dataclass(frozen=True, eq=False)
class OccupancyImage:
    """A boolean image of what stops a ray, its resolution and its place in the map frame."""

    blocked: np.ndarray
    """``blocked[i, j]``: pixel ``(i, j)`` stops a ray (row 0 at the top, the largest y); bool, read-only."""
    resolution: float
    """Metres per pixel (> 0)."""
    origin: MapFrame
    """The pose of the image's lower-left corner in the map frame (Nav2's ``origin``)."""

    def __post_init__(self) -> None:
        blocked = self.blocked
        if not isinstance(blocked, np.ndarray) or blocked.ndim != 2 or blocked.dtype != np.bool_ or blocked.size == 0:
            raise ValueError("OccupancyImage.blocked must be a non-empty 2-D bool array")
        if not (math.isfinite(self.resolution) and self.resolution > 0):
            raise ValueError(f"OccupancyImage.resolution must be > 0, got {self.resolution}")
        frozen = blocked.view()
        frozen.flags.writeable = False
        object.__setattr__(self, "blocked", frozen)

    @classmethod
    def occupied_of(cls, occupancy: OccupancyMap) -> OccupancyImage:
        """The occupied pixels of a map (unknown space does not stop a ray: it is not an obstacle)."""
        return cls(np.asarray(occupancy.pixels == Occupancy.OCCUPIED), occupancy.resolution, occupancy.frame)

    @classmethod
    def walls_of(cls, occupancy: OccupancyMap) -> OccupancyImage:
        """The occupied pixels and the unknown pixels that touch free space (8-neighbourhood): what
        a laser in the map's free space hits. Unknown space is never a place the robot can be, so
        its edge counts as a wall -- a SLAM map's outline has gaps where its wall was seen poorly,
        and a real laser still hits the wall there."""
        from scipy import ndimage

        pixels = np.asarray(occupancy.pixels)
        free = pixels == Occupancy.FREE
        near_free = ndimage.binary_dilation(free, structure=np.ones((3, 3), dtype=bool))
        walls = (pixels == Occupancy.OCCUPIED) | ((pixels == Occupancy.UNKNOWN) & near_free)
        return cls(walls, occupancy.resolution, occupancy.frame)

    @classmethod
    def blocked_of(cls, occupancy: OccupancyMap) -> OccupancyImage:
        """The occupied and the unknown pixels of a map (:meth:`OccupancyMap.blocked`)."""
        return cls(np.array(occupancy.blocked()), occupancy.resolution, occupancy.frame)

    @property
    def height(self) -> int:
        return int(self.blocked.shape[0])

    @property
    def width(self) -> int:
        return int(self.blocked.shape[1])

    def to_pixel(self, x: np.ndarray | float, y: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """Map-frame metres -> continuous pixel coordinates ``(u, v)`` (``v`` up from the bottom)."""
        gx, gy = self.origin.to_grid(x, y)
        return gx / self.resolution, gy / self.resolution

    def to_map(self, u: np.ndarray | float, v: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """Continuous pixel coordinates ``(u, v)`` -> map-frame metres."""
        return self.origin.to_map(np.asarray(u, dtype=np.float64) * self.resolution, np.asarray(v) * self.resolution)

    def pixel_of(self, x: np.ndarray | float, y: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """``(i, j)`` of the pixel holding each map-frame point (may be outside the image)."""
        u, v = self.to_pixel(x, y)
        return self.height - 1 - np.floor(v).astype(np.int64), np.floor(u).astype(np.int64)

    def with_blocked(self, blocked: np.ndarray) -> OccupancyImage:
        """The same placement with another obstacle image of the same shape."""
        if blocked.shape != self.blocked.shape:
            raise ValueError(f"blocked image of shape {blocked.shape}, expected {self.blocked.shape}")
        return OccupancyImage(np.asarray(blocked, dtype=bool), self.resolution, self.origin)
