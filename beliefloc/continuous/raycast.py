"""Ray casting on an occupancy image: the range a perfect laser reads, for many rays at once.

Each ray walks the pixels it crosses in order (Amanatides & Woo's grid traversal, "A fast voxel
traversal algorithm for ray tracing", 1987), all rays together: one numpy step per pixel boundary
crossed, vectorised over the rays still travelling (the loop runs over steps along a ray, never over
rays or poses). The range is the distance from the ray's start to where it is first stopped --
exact for the image's square pixels -- by the exact model's blocking rule
(:mod:`beliefloc.semantic_map.pixel_geometry`): where blocked pixels touch the ray from both sides.
It stops where it enters a blocked pixel; through a pixel corner, where the two pixels beside the
corner are both blocked (a diagonal wall has no gap; a lone pixel touched at its corner does not
stop it); along a pixel edge, where blocked pixels meet it on both sides. Points within 1e-9 pixels
of a pixel edge lie on it, so those cases do not depend on rounding (cells of 0.25 m over pixels of
0.05 m send every diagonal ray from a cell's centre through pixel corners).

Many rays at once (:data:`LEAP_FROM` or more) also *leap* through open space, as sphere tracing does:
a pixel whose centre is ``e`` pixels from the nearest blocked pixel's centre (the image's Euclidean
distance transform) has no blocked pixel within ``e - √2`` of any point in it, so a ray there may
jump ``e - 1.5`` pixels at once and resume the traversal where it lands. The ranges are the same
(up to rounding, ~1e-12 m); the loop runs a few steps per ray instead of one per pixel crossed.

Many more rays (:data:`THREADED_FROM`) are cast in parts, one per thread of
:func:`beliefloc.source.threads.pool`: each ray's walk is its own, so the ranges are the same bits, and
NumPy's steps release the interpreter's lock. The depot's lattice tables (a million poses) were
built in 21 s on one thread, 13 s on two.

The leaping walk is compiled where setup.py could build ``_raycast.c`` (:data:`compiled`): each ray
walked alone to its end through the same steps and leaps, the very bits of NumPy's walk, without a
NumPy pass per step for every ray together (the depot's rays: 5.8 -> 2.3 s of the lattice's 9.5 -> 5.9 s
on two cores). The rays' start (:class:`_Rays`) is set up by NumPy either way.

Round things the image does not show (a simulated world's unmapped discs) are met exactly, not drawn into
its pixels: :func:`ray_disc_distances`.

NumPy (scipy's distance transform for the leaps) and the optional compiled walk, no I/O.
"""

from __future__ import annotations

import itertools
import math
import weakref
from types import ModuleType

import numpy as np

from beliefloc.continuous.image import OccupancyImage
from beliefloc.source import threads

compiled: ModuleType | None
"""The compiled walk (``_raycast.c``; setup.py builds it where a C compiler is found), or None: NumPy's
steps, the same ranges. Setting it to None (tests, a comparison) makes later casts take NumPy's."""
try:
    from beliefloc.continuous import _raycast as compiled
except ImportError:  # pragma: no cover - an install without the extension
    compiled = None

LEAP_FROM = 4096
"""Rays cast together from which the traversal leaps through open space (fewer rays do not pay for
the image's distance transform, which is computed once per image and kept while the image lives)."""
THREADED_FROM = 50_000
"""Rays cast together from which they are cast in parts on :func:`beliefloc.source.threads.pool` (fewer do not
pay for the threads)."""
_LEAP_MIN = 1.0
"""Pixels: a ray leaps where it may jump at least this far, else steps to the next pixel."""
_CORNER = 1e-9
"""Pixels: a ray whose next column and row boundaries are this close passes through their corner
(rounding alone separates them by ~1e-13 pixels)."""
_AXIS = 1e-12
"""A direction component smaller than this is 0: the ray is parallel to the other axis."""
_CLEARANCE: weakref.WeakKeyDictionary[OccupancyImage, np.ndarray] = weakref.WeakKeyDictionary()


def cast_rays(
    image: OccupancyImage,
    x: np.ndarray | float,
    y: np.ndarray | float,
    angle: np.ndarray | float,
    max_range: float,
) -> np.ndarray:
    """The distance (metres) along each ray to the first blocked pixel, or ``+inf`` when none is
    within ``max_range`` or the ray leaves the image first (outside the image nothing is known to
    block it).

    ``x``, ``y`` (map-frame metres, the ray's start) and ``angle`` (map-frame radians) broadcast
    together; the result has their broadcast shape. A ray starting in a blocked pixel reads 0;
    one starting outside the image reads ``+inf``."""
    if not (max_range > 0 and math.isfinite(max_range)):
        raise ValueError(f"max_range must be a positive number of metres, got {max_range}")
    return cast_rays_within(image, x, y, angle, max_range)


def cast_rays_within(
    image: OccupancyImage,
    x: np.ndarray | float,
    y: np.ndarray | float,
    angle: np.ndarray | float,
    reach: np.ndarray | float,
) -> np.ndarray:
    """:func:`cast_rays` with a reach of its own for each ray (metres, broadcast with the rays; a
    ray whose reach is not positive reads ``+inf`` unless it starts in a blocked pixel): what a
    line of sight needs, which ends at its target."""
    bx, by, ba, br = np.broadcast_arrays(
        np.asarray(x, dtype=np.float64),
        np.asarray(y, dtype=np.float64),
        np.asarray(angle, dtype=np.float64),
        np.asarray(reach, dtype=np.float64),
    )
    shape = bx.shape
    u0, v0 = image.to_pixel(bx.ravel(), by.ravel())
    theta = ba.ravel() - image.origin.yaw
    limit = br.ravel() / image.resolution
    clearance = _clearance(image) if u0.size >= LEAP_FROM else None
    u0, v0 = np.asarray(u0, dtype=np.float64), np.asarray(v0, dtype=np.float64)
    pool = threads.pool() if u0.size >= THREADED_FROM else None
    if pool is None:
        t = _traverse(image.blocked, u0, v0, theta, limit, clearance)
    else:
        bounds = np.linspace(0, u0.size, threads.size() + 1).astype(np.int64).tolist()
        parts = [slice(a, b) for a, b in itertools.pairwise(bounds)]
        others = [pool.submit(_traverse, image.blocked, u0[p], v0[p], theta[p], limit[p], clearance) for p in parts[1:]]
        first = parts[0]
        t = np.concatenate([_traverse(image.blocked, u0[first], v0[first], theta[first], limit[first], clearance)]
                           + [other.result() for other in others])  # fmt: skip
    out: np.ndarray = (t * image.resolution).reshape(shape)
    return out


def _clearance(image: OccupancyImage) -> np.ndarray:
    """Per pixel, how far (pixels) a ray may go from any point in it without entering a blocked
    pixel: the distance from its centre to the nearest blocked pixel's centre less 1.5 (≥ √2, the
    two half-diagonals), at least 0."""
    known = _CLEARANCE.get(image)
    if known is not None:
        return known
    from scipy import ndimage

    blocked = image.blocked
    if blocked.any():
        edt = ndimage.distance_transform_edt(~blocked)
        clearance = np.maximum(np.asarray(edt, dtype=np.float64) - 1.5, 0.0)
    else:  # nothing blocks: a leap this long leaves the image
        clearance = np.full(blocked.shape, float(blocked.shape[0] + blocked.shape[1]))
    clearance.flags.writeable = False
    _CLEARANCE[image] = clearance
    return clearance


def _traverse(
    blocked: np.ndarray,
    u0: np.ndarray,
    v0: np.ndarray,
    theta: np.ndarray,
    limit: np.ndarray,
    clearance: np.ndarray | None,
) -> np.ndarray:
    """Pixels along each ray (start ``(u0, v0)`` in pixel coordinates, direction ``theta``) to the
    first blocked pixel it enters, ``inf`` beyond ``limit`` (pixels) or out of the image; leaps by
    ``clearance`` where given."""
    rays = _Rays(blocked, u0, v0, theta, limit)
    walking = rays.start()
    if clearance is None:
        while walking.size:
            walking = rays.step(walking)
        return rays.result
    if compiled is not None:  # the same walk, a ray at a time in C: the same bits (_raycast.c)
        floats = [np.ascontiguousarray(a, dtype=np.float64) for a in (rays.u0, rays.v0, rays.du, rays.dv)]
        compiled.walk(
            np.ascontiguousarray(blocked, dtype=np.bool_),
            np.ascontiguousarray(clearance, dtype=np.float64),
            floats[0],
            floats[1],
            floats[2],
            floats[3],
            np.ascontiguousarray(rays.delta_c, dtype=np.float64),
            np.ascontiguousarray(rays.delta_r, dtype=np.float64),
            np.ascontiguousarray(rays.limit, dtype=np.float64),
            np.ascontiguousarray(rays.step_c, dtype=np.int64),
            np.ascontiguousarray(rays.step_r, dtype=np.int64),
            np.ascontiguousarray(rays.edge_c, dtype=np.bool_),
            np.ascontiguousarray(rays.edge_r, dtype=np.bool_),
            rays.col,
            rays.row,
            rays.next_c,
            rays.next_r,
            rays.t,
            rays.result,
            np.ascontiguousarray(walking, dtype=np.int64),
        )
        return rays.result
    flying = _Flight(rays, walking[:0], np.zeros(0))
    while walking.size or flying.size:
        up, t_up = walking[:0], np.zeros(0)
        if walking.size:  # a ray in a pixel with room around it leaps from where it is
            jump = clearance[rays.height - 1 - rays.row[walking], rays.col[walking]]
            leaps = jump >= _LEAP_MIN
            if leaps.any():
                up = walking[leaps]
                t_up = rays.t[up] + jump[leaps]
                walking = walking[~leaps]
            walking = rays.step(walking)
        if flying.size or up.size:
            walking = np.concatenate([walking, flying.leap(clearance, _Flight(rays, up, t_up))])
    return rays.result


class _Flight:
    """The rays leaping through open space, their start, direction, reach and ``t`` kept side by
    side (contiguous: a leap reads no other ray's state)."""

    def __init__(self, rays: _Rays, index: np.ndarray, t: np.ndarray):
        self.rays = rays
        self.index = index
        self.u0, self.v0 = rays.u0[index], rays.v0[index]
        self.du, self.dv = rays.du[index], rays.dv[index]
        self.limit = rays.limit[index]
        self.t = t

    @property
    def size(self) -> int:
        return int(self.index.size)

    def leap(self, clearance: np.ndarray, joining: _Flight) -> np.ndarray:
        """One leap of every ray by the clearance of the pixel it is in, then the rays ``joining``
        (which have just leapt from where they walked) are added. Returns the rays that stop
        leaping, their traversal restarted where they are; the rays that left the image or their
        reach are dropped (they read ``inf``)."""
        rays = self.rays
        u = self.u0 + self.t * self.du
        v = self.v0 + self.t * self.dv
        c = np.floor(u).astype(np.int64)
        r = np.floor(v).astype(np.int64)
        going = (self.t <= self.limit) & (c >= 0) & (c < rays.width) & (r >= 0) & (r < rays.height)
        jump = clearance[rays.height - 1 - np.clip(r, 0, rays.height - 1), np.clip(c, 0, rays.width - 1)]
        more = going & (jump >= _LEAP_MIN)
        stop = going & ~more
        landed: np.ndarray = self.index[stop]
        rays.t[landed] = self.t[stop]
        rays.restart(landed, self.t[stop], u[stop], v[stop])
        landed = landed[rays._inside(rays.col[landed], rays.row[landed])]  # on the image's edge, leaving it
        self.t += jump
        every = more.all()
        for name in ("index", "u0", "v0", "du", "dv", "limit", "t"):
            mine = getattr(self, name)
            setattr(self, name, np.concatenate([mine if every else mine[more], getattr(joining, name)]))
        return landed


class _Rays:
    """The traversal's state of every ray (pixel coordinates, rows counted up from the bottom)."""

    def __init__(self, blocked: np.ndarray, u0: np.ndarray, v0: np.ndarray, theta: np.ndarray, limit: np.ndarray):
        self.blocked = blocked
        self.height, self.width = blocked.shape
        self.limit = limit
        du, dv = np.cos(theta), np.sin(theta)
        du[np.abs(du) < _AXIS] = 0.0  # cos(pi / 2) is 6e-17: the ray is parallel to the axis
        dv[np.abs(dv) < _AXIS] = 0.0
        # a start on a pixel edge is put on it exactly; a ray along a pixel edge runs between two
        # columns (rows), and its column (row) is the one to the right of (above) the edge
        u_line, v_line = np.round(u0), np.round(v0)
        on_c, on_r = np.abs(u0 - u_line) <= _CORNER, np.abs(v0 - v_line) <= _CORNER
        self.edge_c = (du == 0) & on_c
        self.edge_r = (dv == 0) & on_r
        self.edges = bool(self.edge_c.any() or self.edge_r.any())
        u0 = np.where(on_c, u_line, u0)
        v0 = np.where(on_r, v_line, v0)
        self.u0, self.v0, self.du, self.dv = u0, v0, du, dv
        self.step_c = np.where(self.du > 0, 1, -1)
        self.step_r = np.where(self.dv > 0, 1, -1)
        with np.errstate(divide="ignore"):
            self.delta_c = np.where(self.du != 0, 1.0 / np.abs(self.du), np.inf)
            self.delta_r = np.where(self.dv != 0, 1.0 / np.abs(self.dv), np.inf)
        self.result = np.full(u0.size, np.inf)
        self.t = np.zeros(u0.size)
        self.col, self.row = self._pixel(u0, v0, du, dv)  # the pixel entered just after the start
        self.next_c = self._crossing(self.col, u0, self.du, self.delta_c, self.t)
        self.next_r = self._crossing(self.row, v0, self.dv, self.delta_r, self.t)

    @staticmethod
    def _crossing(index: np.ndarray, u: np.ndarray, du: np.ndarray, delta: np.ndarray, t: np.ndarray) -> np.ndarray:
        """The ray parameter (pixels from the start) of the next boundary along one axis, for rays at
        coordinate ``u`` (parameter ``t``) in pixel ``index`` on that axis, moving ``du`` along it."""
        with np.errstate(invalid="ignore"):  # inf * 0 where a ray runs along the other axis
            ahead = np.where(du > 0, (index + 1 - u) * delta, np.where(du < 0, (u - index) * delta, np.inf))
        out: np.ndarray = t + ahead
        return out

    def _inside(self, col: np.ndarray, row: np.ndarray) -> np.ndarray:
        inside: np.ndarray = (col >= 0) & (col < self.width) & (row >= 0) & (row < self.height)
        return inside

    @staticmethod
    def _pixel(u: np.ndarray, v: np.ndarray, du: np.ndarray, dv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The pixel a ray at ``(u, v)`` is in just after that point (on a boundary: the one it enters)."""
        c = np.where(du >= 0, np.floor(u), np.ceil(u) - 1).astype(np.int64)
        r = np.where(dv >= 0, np.floor(v), np.ceil(v) - 1).astype(np.int64)
        return c, r

    def start(self) -> np.ndarray:
        """The rays that start inside the image and are not stopped at once (they read 0): the
        pixel they start into is blocked (the one after the start, if it lies on a pixel edge or
        corner); along a pixel edge, the pixels on both sides of it are."""
        inside = self._inside(self.col, self.row)
        start_blocked = np.zeros(inside.shape, dtype=bool)
        start_blocked[inside] = self.blocked[self.height - 1 - self.row[inside], self.col[inside]]
        if self.edges:
            k = np.flatnonzero(inside & (self.edge_c | self.edge_r))
            start_blocked[k] &= self._blocked_at(self.col[k] - self.edge_c[k], self.row[k] - self.edge_r[k])
        self.result[start_blocked] = 0.0
        return np.flatnonzero(inside & ~start_blocked)

    def _blocked_at(self, col: np.ndarray, row: np.ndarray) -> np.ndarray:
        """Whether pixel ``(col, row)`` is blocked; outside the image: no."""
        there = self._inside(col, row)
        out = np.zeros(col.shape, dtype=bool)
        out[there] = self.blocked[self.height - 1 - row[there], col[there]]
        return out

    def step(self, active: np.ndarray) -> np.ndarray:
        """Move each ray of ``active`` into its next pixel; the rays still travelling.

        The blocking rule of :mod:`beliefloc.semantic_map.pixel_geometry` (the exact model's): a
        ray is stopped where blocked pixels touch it from both sides. It enters a pixel: that
        pixel. Through a pixel corner (its next column and row boundaries within :data:`_CORNER` of
        each other): the pixel diagonally ahead, or the two pixels beside the corner both. Along a
        pixel edge: at a boundary where a blocked pixel before or after it touches each side."""
        nc, nr = self.next_c[active], self.next_r[active]
        col, row = self.col[active], self.row[active]
        corner = np.abs(nc - nr) <= _CORNER
        cross_c = (nc < nr) | corner
        cross_r = (nr < nc) | corner
        t_new = np.minimum(nc, nr)
        c = col + np.where(cross_c, self.step_c[active], 0)
        r = row + np.where(cross_r, self.step_r[active], 0)
        self.col[active], self.row[active], self.t[active] = c, r, t_new
        self.next_c[active] = np.where(cross_c, nc + self.delta_c[active], nc)
        self.next_r[active] = np.where(cross_r, nr + self.delta_r[active], nr)
        beyond = t_new > self.limit[active]
        inside = self._inside(c, r)
        hit = np.zeros(active.size, dtype=bool)
        look = ~beyond & inside
        hit[look] = self.blocked[self.height - 1 - r[look], c[look]]
        corner &= ~beyond & ~hit
        if corner.any():
            k = np.flatnonzero(corner)
            hit[k] = self._blocked_at(c[k], row[k]) & self._blocked_at(col[k], r[k])
        if self.edges:
            k = np.flatnonzero(~beyond & (self.edge_c[active] | self.edge_r[active]))
            if k.size:
                ec, er = self.edge_c[active[k]], self.edge_r[active[k]]
                here = self._blocked_at(col[k], row[k]) | self._blocked_at(c[k], r[k])
                across = self._blocked_at(col[k] - ec, row[k] - er) | self._blocked_at(c[k] - ec, r[k] - er)
                hit[k] = here & across
        self.result[active[hit]] = t_new[hit]
        kept: np.ndarray = active[~(beyond | ~inside | hit)]
        return kept

    def restart(self, rays: np.ndarray, t: np.ndarray, u: np.ndarray, v: np.ndarray) -> None:
        """The traversal state of ``rays`` at ``(u, v)``, parameter ``t``: the pixel each is in just
        after that point (on a boundary: the one it enters), and its next boundaries."""
        du, dv = self.du[rays], self.dv[rays]
        c, r = self._pixel(u, v, du, dv)
        self.next_c[rays] = self._crossing(c, u, du, self.delta_c[rays], t)
        self.next_r[rays] = self._crossing(r, v, dv, self.delta_r[rays], t)
        self.col[rays], self.row[rays] = c, r


def cast_scan(
    image: OccupancyImage,
    poses: np.ndarray,
    beam_angles: np.ndarray,
    max_range: float,
) -> np.ndarray:
    """Ranges of a laser at every pose: ``ranges[n, b]`` for the sensor at ``poses[n] = (x, y, yaw)``
    (map frame) and the beam at ``beam_angles[b]`` (radians in the sensor frame). ``+inf`` where
    nothing is within ``max_range`` (see :func:`cast_rays`)."""
    p = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    angles = np.asarray(beam_angles, dtype=np.float64).reshape(1, -1)
    return cast_rays(image, p[:, :1], p[:, 1:2], p[:, 2:3] + angles, max_range)


def ray_disc_distances(
    x: np.ndarray | float, y: np.ndarray | float, angle: np.ndarray | float, discs: np.ndarray, max_range: float
) -> np.ndarray:
    """The distance (metres) along each ray to the first of ``discs`` (rows ``(x, y, radius)``, map frame)
    it meets, or ``+inf`` when none lies within ``max_range``; a ray starting inside a disc reads 0.
    Exact for any disc, however small beside an image's pixels. ``x``, ``y`` and ``angle`` broadcast
    together, as :func:`cast_rays`'s do."""
    x, y, angle = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float), np.asarray(angle, float))
    disc = np.asarray(discs, dtype=np.float64).reshape(-1, 3)
    if not len(disc):
        return np.full(x.shape, np.inf)
    # |o + t u - c|² = r²  ->  t² + 2 b t + k = 0 with b = (o - c)·u, k = |o - c|² - r²
    fx, fy = x[..., None] - disc[:, 0], y[..., None] - disc[:, 1]
    b = fx * np.cos(angle)[..., None] + fy * np.sin(angle)[..., None]
    k = fx * fx + fy * fy - disc[:, 2] ** 2
    reach = b * b - k
    with np.errstate(invalid="ignore"):
        near = -b - np.sqrt(reach)  # the nearer crossing; a start outside a disc has both crossings on one side
    t = np.where(k <= 0.0, 0.0, np.where((reach >= 0.0) & (near >= 0.0), near, np.inf))
    first: np.ndarray = t.min(axis=-1)
    return np.where(first <= max_range, first, np.inf)
