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
that a hit on a wall's face is near it, not half a cell off; finer still, up to :data:`MAX_SPLIT`
times, when that makes the lattice's spacing a whole number of pixels -- see below). A pixel's
distance is to the nearest blocked pixel's *edge* (centre to centre less half a pixel, as the
world's clearance): a ray stops on a pixel's face, and whether its end point rounds into the wall
or the free pixel before it must not matter -- measured to centres, the two sides of a symmetric
room differed by 14 nats for one scan (half a pixel on every beam). Beyond the image the distance is the cap.

**Every pose at once** (:meth:`LatticeScanModel.log_likelihood`), as the grid filter scores its
states (:mod:`beliefloc.continuous.likelihood_field`: a sum of shifted field images). The lattice's
positions are a regular grid: when ``q`` lattice steps are a whole number ``P`` of field pixels, the
positions whose row and column have the same remainder mod ``q`` -- one *sub-cell offset* group --
are a grid of stride ``P`` pixels, and for one yaw every beam's end point is a fixed pixel offset
from each of them. The scan's score over a group is then ``sum_b F_b[i_b + t P, j_b + s P]``: one
contiguous slice of each beam's mixture image ``F_b`` split in ``P x P`` phases, added per yaw,
group and beam (:func:`~beliefloc.continuous.likelihood_field.add_shifted`), never per pose. The
pixel of each end point is the one the per-pose lookup takes (:meth:`log_likelihood_per_pose`, kept
as the reference): both floor the same coordinates, so they differ only where an end point lies on a
pixel edge to within rounding. Each beam's ``sigma_b`` is rounded to the nearest of a geometric
ladder of bands (ratio :data:`BAND_RATIO`, from the shortest beam's sigma), one mixture image per
band, built on first use and kept: the only approximation, well under a pixel's shift of an end
point (tests/test_lattice_scan_fast.py bounds it). A lattice whose spacing is no such multiple of the
pixels (no ``q`` up to :data:`MAX_GROUP`) is scored pose by pose.

Pure numpy/scipy, no I/O. Loops run over yaws, offset groups and beams, or over chunks of poses;
never over poses one by one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from beliefloc.continuous.image import OccupancyImage
from beliefloc.continuous.likelihood_field import (
    Beams,
    LaserModel,
    Scan,
    add_shifted,
    distance_field,
    log_hit_mixture,
    phase_split,
    select_beams,
)
from beliefloc.continuous.pose_lattice import PoseLattice

EFFECTIVE_BEAMS = 7
"""A whole scan's log-likelihood counts as this many independent beams, however many are scored: the
robot is never exactly at a lattice pose, and every beam of one scan shares that offset (measured on
the depot with 360-beam scans: at the full 60 beams a look-alike aisle 2.9 m away was declared at
p = 0.98 after four scans). With the readings' weight (:data:`~beliefloc.continuous.pose_lattice.TEMPER`,
0.7) a scan weighs about 5 beams, as it did when measured (10 beams at 0.5: the depot 6 of 8
localized, none wrong)."""
LATTICE_LASER = LaserModel(max_beams=60)
"""The laser model the lattice scores whole scans with: AMCL's mixture and 60 beams
(``max_beams``), ``sigma_hit`` as the grid filter's (:class:`LaserModel`), widened by the lattice."""
FIELD_RESOLUTION = 0.025
"""Metres: the coarsest pixel of the distance field (well under any beam's ``sigma_b``)."""
CHUNK = 1_000_000
"""Pose × beam end points looked up at once (bounded memory: a few arrays of this many floats)."""
BAND_RATIO = 1.1
"""Successive sigma bands differ by this factor; a beam's sigma is rounded to the nearest band (at
most 4.9 % off, which moves a beam's log-likelihood by at most 0.12 nats -- less than half a pixel's
shift of its end point does at the narrowest sigma)."""
MAX_SPLIT = 4
"""The field's pixels are made at most this many times finer than :data:`FIELD_RESOLUTION` asks
when that makes the lattice's spacing a whole number of them (memory: this squared)."""
MAX_GROUP = 12
"""Else the fast path needs ``q <= MAX_GROUP`` lattice steps to make a whole number of field pixels
(``q²`` offset groups, each its own loop over yaws and beams)."""
MAX_BAND_IMAGES = 64
"""Mixture images kept at most (the cache is emptied beyond: a scan uses about 25 bands)."""


@dataclass(eq=False)
class LatticeScanModel:
    """The likelihood field of ``lattice``'s image, scoring whole scans at its poses (see the module)."""

    lattice: PoseLattice
    laser: LaserModel = LATTICE_LASER
    image: OccupancyImage = field(init=False)
    """The lattice's image, its pixels split to at most :data:`FIELD_RESOLUTION` (finer when that
    makes the lattice's spacing a whole number of them: :data:`MAX_SPLIT`)."""
    distance: np.ndarray = field(init=False)
    """Metres from each pixel of :attr:`image` to the nearest blocked one (capped)."""

    def __post_init__(self) -> None:
        image = self.lattice.image
        split = _field_split(image.resolution, self.lattice.spacing)
        if split > 1:
            blocked = np.repeat(np.repeat(np.asarray(image.blocked), split, axis=0), split, axis=1)
            image = OccupancyImage(blocked, image.resolution / split, image.origin)
        self.image = image
        centres = distance_field(image, self.laser.likelihood_max_dist + image.resolution / 2)
        self.distance = np.maximum(centres - np.float32(image.resolution / 2), np.float32(0.0))
        self._stride = _group_stride(self.lattice.spacing / image.resolution) if image.origin.yaw == 0.0 else None
        _G, rows, cols = self.lattice.shape
        stand_r, stand_c = np.nonzero(self.lattice.stand)
        self._box = (int(stand_r.min()), int(stand_r.max()) + 1, int(stand_c.min()), int(stand_c.max()) + 1)
        g, rc = np.divmod(self.lattice.flat, rows * cols)
        r, c = np.divmod(rc, cols)
        r0, r1, c0, c1 = self._box
        self._gather = (g * (r1 - r0) + (r - r0)) * (c1 - c0) + (c - c0)
        self._bands: dict[tuple[int, float, tuple[int, int, int, int]], np.ndarray] = {}

    @property
    def offset_groups(self) -> int | None:
        """``q``: the lattice's positions are scored in ``q x q`` offset groups (1: all at once);
        None: pose by pose (see the module)."""
        return None if self._stride is None else self._stride[0]

    def beam_sigmas(self, ranges: np.ndarray) -> np.ndarray:
        """Each beam's sigma: ``sigma_hit`` widened by the lattice's spacing and yaw step."""
        root12 = math.sqrt(12.0)
        spread = self.lattice.spacing / root12
        turn = self.lattice.yaw_step / root12 if self.lattice.shape[0] > 1 else 0.0
        out: np.ndarray = np.sqrt(self.laser.sigma_hit**2 + spread**2 + (np.asarray(ranges) * turn) ** 2)
        return out

    def band_sigmas(self, ranges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(band, sigma)`` per beam: :meth:`beam_sigmas` rounded (in log) to the nearest of the
        ladder ``sigma_0 * BAND_RATIO ** band``, ``sigma_0`` the sigma of a zero range."""
        exact = self.beam_sigmas(ranges)
        base = float(self.beam_sigmas(np.zeros(1))[0])
        band = np.maximum(np.rint(np.log(exact / base) / math.log(BAND_RATIO)), 0).astype(np.int64)
        sigma: np.ndarray = base * BAND_RATIO**band
        return band, sigma

    def log_likelihood(self, scan: Scan, mount: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> np.ndarray:
        """``log p(scan | pose)`` at every valid lattice pose, shape ``(n_poses,)``; the laser at
        ``mount`` on the base (``(x, y, yaw)``, REP 103). A scan with no valid reading scores 0
        everywhere (it says nothing). Shifted images (see the module); pose by pose when the
        lattice's spacing is no whole multiple of the field's pixels."""
        beams = select_beams(scan, self.laser, mount)
        if beams.count == 0:
            return np.zeros(self.lattice.n_poses)
        if self._stride is None:
            return self._per_pose(beams, self.beam_sigmas(beams.ranges))
        q, P = self._stride
        image, lattice = self.image, self.lattice
        bands, sigmas = self.band_sigmas(beams.ranges)
        # each band's image less its value at the cap, so that an end point off the image adds 0;
        # every beam's value at the cap is added at the end
        crop = self._crop(beams.range_max + math.hypot(mount[0], mount[1]))  # no valid end point is farther
        images = [
            self._band_image(int(n), float(sd), beams.range_max, P, crop) for n, sd in zip(bands, sigmas, strict=True)
        ]
        cap = np.full(1, self.laser.likelihood_max_dist, dtype=np.float32)
        off_image = sum(float(log_hit_mixture(cap, float(sd), self.laser, beams.range_max)[0]) for sd in sigmas)
        G, rows, _cols = lattice.shape
        r0, r1, c0, c1 = self._box
        full = np.zeros((G, r1 - r0, c1 - c0), dtype=np.float32)
        yaws = lattice.yaws()
        cos, sin = np.cos(yaws)[:, None], np.sin(yaws)[:, None]
        ex = cos * beams.x[None, :] - sin * beams.y[None, :]  # (G, B): end point offsets per yaw
        ey = sin * beams.x[None, :] + cos * beams.y[None, :]
        spacing = lattice.spacing
        for a in range(min(q, r1 - r0)):
            y = (rows - (r0 + a) - 0.5) * spacing
            for b in range(min(q, c1 - c0)):
                x = (c0 + b + 0.5) * spacing
                # the pixels the group's first position reads, as the per-pose lookup floors them; the
                # group's position (t, s) reads (i + t P, j + s P)
                i, j = image.pixel_of(x + ex, y + ey)
                starts_i, starts_j = (i - crop[0]).tolist(), (j - crop[2]).tolist()
                for g in range(G):
                    add_shifted(full[g, a::q, b::q], images, starts_i[g], starts_j[g], P, clip=True)
        out: np.ndarray = full.reshape(-1)[self._gather].astype(np.float64) + off_image
        # the beams of one scan share the lattice pose's error: they count as EFFECTIVE_BEAMS readings
        out *= min(1.0, EFFECTIVE_BEAMS / beams.count)
        return out

    def _crop(self, reach: float) -> tuple[int, int, int, int]:
        """``(i0, i1, j0, j1)``: the field's pixels within ``reach`` metres of a lattice position
        (its valid positions' bounding box), with a pixel's margin: every end point of a beam no
        longer than ``reach`` lies in them or off the image."""
        image, res = self.image, self.image.resolution
        rows = self.lattice.shape[1]
        r0, r1, c0, c1 = self._box
        spacing = self.lattice.spacing
        top, left = image.pixel_of(c0 * spacing - reach, (rows - r0) * spacing + reach)
        bottom, right = image.pixel_of(c1 * spacing + reach, (rows - r1) * spacing - reach)
        margin = 1 + math.ceil(spacing / res)
        height, width = self.distance.shape
        return (
            max(0, int(top) - margin),
            min(height, int(bottom) + margin + 1),
            max(0, int(left) - margin),
            min(width, int(right) + margin + 1),
        )

    def _band_image(
        self, band: int, sigma: float, range_max: float, stride: int, crop: tuple[int, int, int, int]
    ) -> np.ndarray:
        """The mixture image of one sigma band less its value at the cap, over the ``crop`` of the
        distance field (padded with the cap to a multiple of ``stride``), split in phases; cached."""
        key = (band, range_max, crop)
        cached = self._bands.get(key)
        if cached is None:
            if len(self._bands) >= MAX_BAND_IMAGES:
                self._bands.clear()
            i0, i1, j0, j1 = crop
            h, w = i1 - i0, j1 - j0
            cap = np.float32(self.laser.likelihood_max_dist)
            distance = self.distance[i0:i1, j0:j1]
            padded = np.pad(distance, ((0, -h % stride), (0, -w % stride)), constant_values=cap)
            mixture = log_hit_mixture(padded, sigma, self.laser, range_max)
            mixture -= log_hit_mixture(np.full(1, cap), sigma, self.laser, range_max)[0]
            cached = phase_split(mixture, stride)
            self._bands[key] = cached
        return cached

    def log_likelihood_per_pose(
        self, scan: Scan, mount: tuple[float, float, float] = (0.0, 0.0, 0.0), *, banded: bool = False
    ) -> np.ndarray:
        """:meth:`log_likelihood` computed pose by pose (in chunks): each end point looked up at its
        pixel of the distance field, each beam's exact sigma (``banded``: its band's, as the fast
        path). The reference the fast path is tested against, and its fallback."""
        beams = select_beams(scan, self.laser, mount)
        if beams.count == 0:
            return np.zeros(self.lattice.n_poses)
        sigma = self.band_sigmas(beams.ranges)[1] if banded else self.beam_sigmas(beams.ranges)
        return self._per_pose(beams, sigma)

    def _per_pose(self, beams: Beams, sigma: np.ndarray) -> np.ndarray:
        poses = self.lattice.pose_array
        out = np.zeros(len(poses))
        sigma = sigma.astype(np.float32)
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


def _field_split(resolution: float, spacing: float) -> int:
    """Field pixels per image pixel along each side: the fewest that make the pixel at most
    :data:`FIELD_RESOLUTION`, or, when a multiple of that (at most :data:`MAX_SPLIT` times) makes the
    lattice's spacing a whole number of pixels, that multiple (every lattice position then reads the
    field at the same phase: one offset group)."""
    base = max(1, math.ceil(resolution / FIELD_RESOLUTION - 1e-9))
    for factor in range(1, MAX_SPLIT + 1):
        if _group_stride(spacing / (resolution / (base * factor)), 1) is not None:
            return base * factor
    return base


def _group_stride(pixels_per_step: float, most: int = MAX_GROUP) -> tuple[int, int] | None:
    """``(q, P)``: the fewest lattice steps ``q`` (at most ``most``) that make a whole number ``P`` of
    field pixels; None when there are none."""
    for q in range(1, most + 1):
        whole = round(q * pixels_per_step)
        if whole >= 1 and abs(q * pixels_per_step - whole) <= 1e-6 * q * pixels_per_step:
            return q, whole
    return None
