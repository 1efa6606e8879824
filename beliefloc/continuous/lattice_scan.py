"""A whole laser scan scored at every pose of a pose lattice (issue 27: "the same laser model in the
loop").

A ``localize`` reply may carry a whole scan (:func:`beliefloc.robots.readings.parse_full_scan`)
instead of the few beams a map's scan sensor bins. The lattice filter then scores it with the
likelihood field the grid filter of ``track --bag`` uses (:mod:`beliefloc.continuous.likelihood_field`:
AMCL's ``likelihood_field`` model, its hit / random mixture, ``max_beams`` evenly spread valid
readings, no-return and out-of-range readings skipped), on the lattice's own image -- what rays stop
at, in the grid frame -- at every lattice pose.

**A lattice pose stands for the sub-cell and yaw step around it**, as the lattice's tables widen
each sensor's noise by it (:mod:`beliefloc.semantic_map.lattice_sensors`): beam ``b`` of range ``z``
scores with ``sigma_b = hypot(sigma_hit, spacing / √12, z · yaw_step / √12)``. End points are looked
up at the nearest pixel of the distance field, whose pixels are at most :data:`FIELD_RESOLUTION`
(a coarser image -- a hand-drawn grid's, one pixel a cell -- is split into finer pixels first, so
that a hit on a wall's face is near it, not half a cell off). A pixel's distance is to the nearest
blocked pixel's *edge* (centre to centre less half a pixel, as the world's clearance): a ray stops
on a pixel's face, and whether its end point rounds into the wall or the free pixel before it must
not matter -- measured to centres, the two sides of a symmetric room differed by 14 nats for one
scan (half a pixel on every beam). Beyond the image the distance is the cap.

Pure numpy/scipy, no I/O. Loops run over chunks of poses, never over poses one by one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from beliefloc.continuous.image import OccupancyImage
from beliefloc.continuous.likelihood_field import LaserModel, Scan, distance_field, select_beams
from beliefloc.continuous.pose_lattice import PoseLattice

EFFECTIVE_BEAMS = 10
"""A whole scan's log-likelihood counts as this many independent beams, however many are scored: the
robot is never exactly at a lattice pose, and every beam of one scan shares that offset (measured on
the depot with 360-beam scans: at the full 60 beams a look-alike aisle 2.9 m away was declared at
p = 0.98 after four scans)."""
LATTICE_LASER = LaserModel(max_beams=60)
"""The laser model the lattice scores whole scans with: AMCL's mixture and 60 beams
(``max_beams``), ``sigma_hit`` as the grid filter's (:class:`LaserModel`), widened by the lattice."""
FIELD_RESOLUTION = 0.025
"""Metres: the coarsest pixel of the distance field (well under any beam's ``sigma_b``)."""
CHUNK = 1_000_000
"""Pose × beam end points looked up at once (bounded memory: a few arrays of this many floats)."""


@dataclass(eq=False)
class LatticeScanModel:
    """The likelihood field of ``lattice``'s image, scoring whole scans at its poses (see the module)."""

    lattice: PoseLattice
    laser: LaserModel = LATTICE_LASER
    image: OccupancyImage = field(init=False)
    """The lattice's image, its pixels split to at most :data:`FIELD_RESOLUTION`."""
    distance: np.ndarray = field(init=False)
    """Metres from each pixel of :attr:`image` to the nearest blocked one (capped)."""

    def __post_init__(self) -> None:
        image = self.lattice.image
        split = max(1, math.ceil(image.resolution / FIELD_RESOLUTION - 1e-9))
        if split > 1:
            blocked = np.repeat(np.repeat(np.asarray(image.blocked), split, axis=0), split, axis=1)
            image = OccupancyImage(blocked, image.resolution / split, image.origin)
        self.image = image
        centres = distance_field(image, self.laser.likelihood_max_dist + image.resolution / 2)
        self.distance = np.maximum(centres - np.float32(image.resolution / 2), np.float32(0.0))

    def beam_sigmas(self, ranges: np.ndarray) -> np.ndarray:
        """Each beam's sigma: ``sigma_hit`` widened by the lattice's spacing and yaw step."""
        root12 = math.sqrt(12.0)
        spread = self.lattice.spacing / root12
        turn = self.lattice.yaw_step / root12 if self.lattice.shape[0] > 1 else 0.0
        out: np.ndarray = np.sqrt(self.laser.sigma_hit**2 + spread**2 + (np.asarray(ranges) * turn) ** 2)
        return out

    def log_likelihood(self, scan: Scan, mount: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> np.ndarray:
        """``log p(scan | pose)`` at every valid lattice pose, shape ``(n_poses,)``; the laser at
        ``mount`` on the base (``(x, y, yaw)``, REP 103). A scan with no valid reading scores 0
        everywhere (it says nothing)."""
        beams = select_beams(scan, self.laser, mount)
        poses = self.lattice.pose_array
        out = np.zeros(len(poses))
        if beams.count == 0:
            return out
        sigma = self.beam_sigmas(beams.ranges).astype(np.float32)
        scale = (-0.5 / sigma**2).astype(np.float32)
        floor = np.float32(self.laser.z_rand / beams.range_max)
        z_hit = np.float32(self.laser.z_hit)
        image = self.image
        height, width = self.distance.shape
        cap = np.float32(self.laser.likelihood_max_dist)
        bx, by = beams.x[None, :], beams.y[None, :]
        step = max(1, CHUNK // beams.count)
        for start in range(0, len(poses), step):
            p = poses[start : start + step]
            c, s = np.cos(p[:, 2:3]), np.sin(p[:, 2:3])
            ex = p[:, 0:1] + c * bx - s * by
            ey = p[:, 1:2] + s * bx + c * by
            i, j = image.pixel_of(ex, ey)
            inside = (i >= 0) & (i < height) & (j >= 0) & (j < width)
            d = np.full(i.shape, cap, dtype=np.float32)
            d[inside] = self.distance[i[inside], j[inside]]
            out[start : start + step] = np.log(z_hit * np.exp(scale * d * d) + floor).sum(axis=1)
        # the beams of one scan share the lattice pose's error: they count as EFFECTIVE_BEAMS readings
        out *= min(1.0, EFFECTIVE_BEAMS / beams.count)
        return out
