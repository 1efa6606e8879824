"""Region observation models: a state is its cell × its heading sector, not one point.

The papers' model (:mod:`beliefloc.semantic_map.compile`) gives each state the reading of one exact
pose -- its cell's centre and its heading -- blurred by a small confusion rate. A real robot is
anywhere in the cell and a few degrees off the heading, so a state's reading probabilities here are
the **average over sub-poses of the region** of what a sensor with continuous noise reports:

* **Sub-poses.** ``sub_samples`` positions per axis, evenly spread over the cell (``k × k``, at the
  centres of a ``k × k`` split), times ``yaw_samples`` yaw offsets evenly spread over the heading's
  sector (``360 / headings`` degrees; none on a map with one heading). A sub-pose on a blocked
  pixel is not a place the robot can be and is left out; a state whose every sub-pose is blocked
  keeps its centre. ``sub_samples: 1, yaw_samples: 1`` is the centre and the heading: the exact pose.
* **Scan** (one beam at ``heading yaw + beam angle`` (counter-clockwise), cast over the same blocked pixels as the exact
  model: :mod:`beliefloc.continuous.raycast`): the reading is a mixture, as AMCL's beam model
  (Thrun et al., Probabilistic Robotics §6.3):

  - with ``1 − random − short``: the true range plus a Gaussian error of standard deviation
    ``sigma``; a bin gets the Gaussian's mass between its edges (below 0 counts in the first bin,
    beyond the last edge is ``no_wall``); nothing within the last edge (``inf``) reads ``no_wall``;
  - with ``short``: an unmapped obstacle in front, uniform over ``[0, min(range, last edge))``;
  - with ``random``: any reading, every bin equally likely.

  Then the scan's ``error`` (another bin, spread evenly) is applied as before. ``sigma: 0``,
  ``random: 0``, ``short: 0`` and one sub-pose give exactly the papers' model.
* **Look**: a landmark at distance ``d`` and viewing angle ``a`` from a sub-pose is detected with
  probability ``Φ((fov/2 − |a|) / fov_edge) · Φ((range − d) / range_edge)`` when nothing blocks the
  line of sight (a step when an edge is 0). A landmark in the robot's own cell is *not* always seen:
  it is seen when it is in the field of view from where the robot stands (a real detector does not
  see behind itself). With several landmarks of a class the reading is the smallest viewing angle
  among those detected (their detections independent). Then ``false_positive`` and
  ``false_negative`` apply as before.

Rows are quantised (:data:`STEP`) with a floor (:data:`FLOOR`) wherever the continuous model gives
any mass, so a reading the region can produce never zeroes a state, and states share a handful of
distinct rows (the model stores one row per distinct distribution: ``ObservationPart.truth`` indexes
``confusion``).

Every heading and yaw offset of a cell's sub-pose position casts from the same point: a scan casts
each distinct direction (heading yaw − offset + beam angle, shared by beams that coincide at some
heading) once per position, and a Look computes distances, bearings, the range fade and the line
of sight once per position (cast to the landmark, no further), only the viewing angle per yaw.

Pure numpy/scipy, no I/O. Vectorised over states × sub-poses; the loops are over beams, landmarks of a
class and the steps of a ray.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import special

from beliefloc.continuous.image import OccupancyImage
from beliefloc.continuous.motion import grid_yaws
from beliefloc.continuous.raycast import cast_rays, cast_rays_within
from beliefloc.model import GridLayout, MapFrame

STEP = 1.0 / 200.0
"""Reading probabilities are rounded to multiples of this (then renormalised)."""
FLOOR = 1.0 / 1000.0
"""A reading with any probability under the continuous model keeps at least this much."""
_CHUNK = 1 << 21
"""Sub-pose rays (a scan) or sub-pose × landmark pairs (a Look) computed at once: the depot at the
real-robot values is one or two such chunks; the largest specs (7 × 7 positions × 9 yaws) stay
within a few hundred MiB."""


@dataclass(frozen=True)
class RegionSpec:
    """How a sensor averages over a state's region (the map's ``sub_samples`` and ``yaw_samples``)."""

    sub_samples: int = 1
    yaw_samples: int = 1

    @property
    def exact(self) -> bool:
        return self.sub_samples == 1 and self.yaw_samples == 1


def blocked_image(blocked: np.ndarray, resolution: float) -> OccupancyImage:
    """The blocked pixels (row 0 at the top) in the *grid* frame, padded by one blocked pixel all
    round, so that the image's edge stops a ray as it does in the exact model."""
    padded = np.pad(np.asarray(blocked, dtype=bool), 1, constant_values=True)
    return OccupancyImage(padded, resolution, MapFrame(-resolution, -resolution, 0.0))


def sub_poses(layout: GridLayout, image: OccupancyImage, spec: RegionSpec) -> tuple[np.ndarray, np.ndarray]:
    """``(poses, weight)``: ``poses[s, k] = (x, y, yaw)`` in the grid frame for state ``s`` and
    sub-pose ``k``; ``weight[s, k]`` is ``1 / (its state's standing sub-poses)`` or 0 on a blocked
    pixel."""
    s = layout.cell_size
    H = layout.headings
    k = spec.sub_samples
    m = spec.yaw_samples if H > 1 else 1
    offsets = ((np.arange(k) + 0.5) / k - 0.5) * s
    ox, oy = (a.ravel() for a in np.meshgrid(offsets, offsets, indexing="xy"))
    yaw_offsets = ((np.arange(m) + 0.5) / m - 0.5) * (2 * math.pi / H) if H > 1 else np.zeros(1)
    cells = layout.free_cells
    row, col = np.divmod(cells, layout.cols)
    cx = (col + 0.5) * s
    cy = (layout.rows - row - 0.5) * s
    yaws = grid_yaws(H) if H > 1 else np.zeros(1)
    # states are cell-major: state = cell * H + h
    px = np.repeat(cx, H)[:, None, None] + ox[None, :, None] + 0 * yaw_offsets[None, None, :]
    py = np.repeat(cy, H)[:, None, None] + oy[None, :, None] + 0 * yaw_offsets[None, None, :]
    pyaw = np.tile(yaws, len(cells))[:, None, None] + 0 * ox[None, :, None] - yaw_offsets[None, None, :]
    n = len(cells) * H
    poses = np.stack([px.reshape(n, -1), py.reshape(n, -1), pyaw.reshape(n, -1)], axis=-1)
    i, j = image.pixel_of(poses[..., 0], poses[..., 1])
    inside = (i >= 0) & (i < image.height) & (j >= 0) & (j < image.width)
    stands = np.zeros(inside.shape, dtype=bool)
    stands[inside] = ~image.blocked[i[inside], j[inside]]
    centre = (k * k // 2) * m + m // 2 if k % 2 == 1 else None
    none = ~stands.any(axis=1)
    if none.any():  # keep the centre (or, with an even split, every sub-pose) of a fully blocked region
        if centre is not None:
            stands[none, centre] = True
        else:
            stands[none, :] = True
    weight = stands / stands.sum(axis=1, keepdims=True)
    return poses, weight


def scan_distribution(ranges: np.ndarray, bins: np.ndarray, sigma: float, random: float, short: float) -> np.ndarray:
    """``P(reading | true range)`` for an array of true ranges (``inf``: nothing within the last
    edge): shape ``ranges.shape + (len(bins) + 1,)``; the last reading is ``no_wall``."""
    r = np.asarray(ranges, dtype=np.float64)
    out = _scan_rows(r.ravel(), np.asarray(bins, dtype=np.float64), sigma, random, short)
    return out.reshape((*r.shape, out.shape[-1]))


def _scan_rows(r: np.ndarray, bins: np.ndarray, sigma: float, random: float, short: float) -> np.ndarray:
    """:func:`scan_distribution` of a flat array of ranges: the Gaussian's CDF once per bin edge."""
    n, edges = len(r), len(bins)
    last = float(bins[-1])
    finite = np.isfinite(r)
    hit = np.zeros((n, edges + 1))
    if sigma > 0:
        cdf = special.ndtr((bins[None, :] - np.where(finite, r, 0.0)[:, None]) / sigma)
        hit[:, 0] = cdf[:, 0]
        hit[:, 1:edges] = cdf[:, 1:] - cdf[:, :-1]
        hit[:, edges] = 1.0 - cdf[:, -1]
        del cdf
    else:
        index = np.searchsorted(bins, np.where(finite, r, np.inf) - 1e-9, side="left")
        hit[np.arange(n), index] = 1.0
    hit[~finite] = 0.0
    hit[~finite, edges] = 1.0
    # short: uniform over [0, min(r, last)): the share of each bin's span below that limit
    upper = np.r_[bins, np.inf]
    lower = np.r_[0.0, bins]
    reach = np.minimum(np.where(finite, r, last), last)[:, None]
    below = np.clip(np.minimum(upper, reach) - np.maximum(lower, 0.0), 0.0, None)
    with np.errstate(invalid="ignore", divide="ignore"):
        short_part = np.where(reach > 0, below / np.where(reach > 0, reach, 1.0), hit)
    del below
    out = (1.0 - random - short) * hit
    out += short * short_part
    out += random * (1.0 / (edges + 1))
    return out


def detection_probability(
    distance: np.ndarray,
    angle_deg: np.ndarray,
    fov: float,
    view_range: float | None,
    fov_edge: float,
    range_edge: float,
) -> np.ndarray:
    """The probability a landmark at ``distance`` (m) and viewing angle ``angle_deg`` (absolute
    degrees off the heading) is detected, line of sight aside."""
    half = fov / 2.0
    if fov >= 360.0:
        p_fov = np.ones_like(angle_deg)
    elif fov_edge > 0:
        p_fov = special.ndtr((half - angle_deg) / fov_edge)
    else:
        p_fov = (angle_deg <= half + 1e-9).astype(np.float64)
    if view_range is None:
        p_range = np.ones_like(distance)
    elif range_edge > 0:
        p_range = special.ndtr((view_range - distance) / range_edge)
    else:
        p_range = (distance <= view_range + 1e-9).astype(np.float64)
    out: np.ndarray = p_fov * p_range
    return out


def _range_cutoff(view_range: float, range_edge: float) -> float:
    """Metres beyond which a Look detects nothing: 40 range fades (σ) past its range (``Φ(-40)`` is
    exactly 0 in double precision), or its range with a step edge."""
    return view_range + (40.0 * range_edge if range_edge > 0 else 1e-9)


def quantised_rows(dist: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(rows, index)`` with ``rows[index] ≈ dist``: probabilities rounded to :data:`STEP`, any
    positive one kept at :data:`FLOOR` at least, rows renormalised, then made distinct.

    A row's rounding is one small integer per reading (its multiple of :data:`STEP`, or the floor);
    rows are first told apart by those integers packed into one key, then only one row per key is
    normalised and compared (the same rows and index as comparing every row)."""
    steps = np.rint(dist / STEP)
    code = np.where((dist > 1e-12) & (steps * STEP < FLOOR), -1.0, steps)  # -1: kept at the floor
    base = float(np.max(code, initial=0.0)) + 2.0
    if dist.shape[1] * math.log2(base) < 62:
        key = (code + 1.0).astype(np.int64) @ (np.int64(round(base)) ** np.arange(dist.shape[1], dtype=np.int64))
        _, first, by_key = np.unique(key, return_index=True, return_inverse=True)
    else:
        _, first, by_key = np.unique(code, axis=0, return_index=True, return_inverse=True)
    some = dist[first]
    q = np.round(some / STEP) * STEP
    q = np.where((some > 1e-12) & (q < FLOOR), FLOOR, q)
    q /= q.sum(axis=1, keepdims=True)
    rows, index = np.unique(np.round(q, 12), axis=0, return_inverse=True)
    rows = rows / rows.sum(axis=1, keepdims=True)
    return rows, index.ravel()[by_key.ravel()].astype(np.int32)


def region_scan(
    layout: GridLayout,
    image: OccupancyImage,
    spec: RegionSpec,
    beam_deg: float,
    bins: np.ndarray,
    sigma: float,
    random: float,
    short: float,
) -> np.ndarray:
    """The average reading distribution of every state's region for one beam (``beam_deg`` degrees
    counter-clockwise from the heading): shape ``(n_states, len(bins) + 1)``."""
    return region_scans(layout, image, spec, [beam_deg], bins, sigma, random, short)[0]


def region_scans(
    layout: GridLayout,
    image: OccupancyImage,
    spec: RegionSpec,
    beams_deg: Sequence[float],
    bins: np.ndarray,
    sigma: float,
    random: float,
    short: float,
    sub: tuple[np.ndarray, np.ndarray] | None = None,
) -> list[np.ndarray]:
    """:func:`region_scan` of each beam of a scan. Every heading and yaw offset of a cell's
    sub-pose position casts from the same point, and beam ``b`` at heading ``h`` points where beam
    ``b'`` at heading ``h'`` does when ``yaw_h + b = yaw_h' + b'``: each distinct direction is cast
    once per position, and its reading distribution computed once. ``sub``: :func:`sub_poses`'s
    result, when the caller has it."""
    poses, weight = sub if sub is not None else sub_poses(layout, image, spec)
    H = layout.headings
    kk = spec.sub_samples**2
    m = spec.yaw_samples if H > 1 else 1
    cells = len(layout.free_cells)
    grid = poses.reshape(cells, H, kk, m, 3)
    w = weight.reshape(cells, H, kk, m)
    # every cell and position has the same yaws (sub_poses: the heading's yaw less the offset)
    yaws = grid[0, :, 0, :, 2]
    beams = np.radians(np.asarray(beams_deg, dtype=np.float64))
    angles = (yaws[:, :, None] + beams[None, None, :]).ravel()  # (H, m, B)
    turn = 2 * math.pi
    key = np.round(np.mod(angles, turn) * 1e9).astype(np.int64) % round(turn * 1e9)
    _, first, inverse = np.unique(key, return_index=True, return_inverse=True)
    directions = angles[first]
    inverse = inverse.reshape(H, m, len(beams))
    standing = np.any(w > 0, axis=(1, 3))  # (cells, kk): a position any sub-pose stands on
    reach = float(bins[-1]) + 4.0 * sigma
    edges = np.asarray(bins, dtype=np.float64)
    n_values = len(bins) + 1
    out = [np.empty((cells, H, n_values)) for _ in beams]
    step = max(1, _CHUNK // (kk * len(directions)))  # cells at a time: bounded memory for any spec
    for lo in range(0, cells, step):
        part = slice(lo, lo + step)
        stand = standing[part]
        xy = grid[part, 0, :, 0, :2][stand]
        ranges = np.full((*stand.shape, len(directions)), np.inf)
        ranges[stand] = cast_rays(image, xy[:, :1], xy[:, 1:2], directions[None, :], reach)
        ranges[ranges > reach] = np.inf
        dist = _scan_rows(ranges.ravel(), edges, sigma, random, short).reshape((*ranges.shape, n_values))
        del ranges
        for b in range(len(beams)):
            per_sub = dist[:, :, inverse[:, :, b], :]  # (cells, kk, H, m, values)
            out[b][part] = np.einsum("chkm,ckhmv->chv", w[part], per_sub)
    return [o.reshape(cells * H, n_values) for o in out]


def region_look(
    layout: GridLayout,
    image: OccupancyImage,
    spec: RegionSpec,
    landmarks_xy: np.ndarray,
    fov: float,
    view_range: float | None,
    occlusion: bool,
    angle_bins: np.ndarray | None,
    fov_edge: float,
    range_edge: float,
    sub: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """The average distribution of a class's Look part over every state's region: column 0 "not
    seen", then one column (no ``angle_bins``) or one per angle bin. ``landmarks_xy`` in grid-frame
    metres; ``sub``: :func:`sub_poses`'s result, when the caller has it.

    A sub-pose's position is shared by every heading of its cell and every yaw offset: distances,
    bearings, the range fade and the line of sight to a landmark are computed once per position,
    only the viewing angle per yaw."""
    poses, weight = sub if sub is not None else sub_poses(layout, image, spec)
    H = layout.headings
    kk = spec.sub_samples**2
    m = spec.yaw_samples if H > 1 else 1
    cells = len(layout.free_cells)
    grid = poses.reshape(cells, H, kk, m, 3)
    xy = grid[:, 0, :, 0, :2].reshape(cells * kk, 2)
    yaws = grid[..., 2].transpose(0, 2, 1, 3).reshape(cells * kk, H * m)
    w = weight.reshape(cells, H, kk, m)
    stands = (w > 0).transpose(0, 2, 1, 3).reshape(cells * kk, H * m)
    n_values = 1 + (len(angle_bins) if angle_bins is not None else 1)
    out = np.empty((cells, H, n_values))
    step = max(1, _CHUNK // (kk * H * m * max(1, len(landmarks_xy))))  # cells at a time: bounded memory
    for lo in range(0, cells, step):
        part = slice(lo, lo + step)
        at = slice(lo * kk, (lo + step) * kk)
        seen = _look_at(
            image,
            xy[at],
            yaws[at],
            stands[at],
            landmarks_xy,
            H == 1,
            fov,
            view_range,
            occlusion,
            angle_bins,
            fov_edge,
            range_edge,
        )
        out[part] = np.einsum("chkm,ckhmv->chv", w[part], seen.reshape(-1, kk, H, m, n_values))
    return out.reshape(cells * H, n_values)


def look_distribution(
    image: OccupancyImage,
    poses: np.ndarray,
    stands: np.ndarray,
    landmarks_xy: np.ndarray,
    all_round: bool,
    fov: float,
    view_range: float | None,
    occlusion: bool,
    angle_bins: np.ndarray | None,
    fov_edge: float,
    range_edge: float,
) -> np.ndarray:
    """A class's Look reading distribution at each pose: ``poses[..., (x, y, yaw)]`` in the grid
    frame, ``stands[...]`` where a pose is one the robot can be in (elsewhere: nothing seen);
    ``all_round``: a map with one heading (every viewing angle is 0). Shape ``poses.shape[:-1] +
    (n_values,)``: column 0 "not seen", then one column (no ``angle_bins``) or one per angle bin."""
    poses = np.asarray(poses, dtype=np.float64)
    shape = poses.shape[:-1]
    flat = poses.reshape(-1, 3)
    sub = _look_at(
        image,
        flat[:, :2],
        flat[:, 2:3],
        np.broadcast_to(np.asarray(stands, dtype=bool), shape).reshape(-1, 1),
        landmarks_xy,
        all_round,
        fov,
        view_range,
        occlusion,
        angle_bins,
        fov_edge,
        range_edge,
    )
    return sub.reshape((*shape, sub.shape[-1]))


def _look_at(
    image: OccupancyImage,
    xy: np.ndarray,
    yaws: np.ndarray,
    stands: np.ndarray,
    landmarks_xy: np.ndarray,
    all_round: bool,
    fov: float,
    view_range: float | None,
    occlusion: bool,
    angle_bins: np.ndarray | None,
    fov_edge: float,
    range_edge: float,
) -> np.ndarray:
    """:func:`look_distribution` at ``P`` positions ``xy`` with ``Y`` yaws each (``yaws``, ``stands``:
    shape ``(P, Y)``): shape ``(P, Y, n_values)``. Distances, bearings and lines of sight are
    per position."""
    n_pos, n_yaw = yaws.shape
    n_values = 1 + (len(angle_bins) if angle_bins is not None else 1)
    if len(landmarks_xy) == 0:
        out = np.zeros((n_pos, n_yaw, n_values))
        out[..., 0] = 1.0
        return out
    x, y = xy[:, 0], xy[:, 1]
    standing = stands.any(axis=1)
    if view_range is not None:  # beyond the range fade's reach every landmark's detection is exactly 0
        cutoff = _range_cutoff(view_range, range_edge)
        near = np.zeros(n_pos, dtype=bool)
        for lx, ly in landmarks_xy:
            near |= np.hypot(lx - x, ly - y) <= cutoff
        near &= standing
        if not near.all():
            out = np.zeros((n_pos, n_yaw, n_values))
            out[..., 0] = 1.0  # nothing seen
            if near.any():
                out[near] = _look_at(
                    image,
                    xy[near],
                    yaws[near],
                    stands[near],
                    landmarks_xy,
                    all_round,
                    fov,
                    view_range,
                    occlusion,
                    angle_bins,
                    fov_edge,
                    range_edge,
                )
            return out
    probs, angles = [], []
    margin = 4.0 * range_edge if view_range is not None else 0.0
    for lx, ly in landmarks_xy:
        dx, dy = lx - x, ly - y
        d = np.hypot(dx, dy)
        bearing = np.arctan2(dy, dx)
        if all_round:
            a = np.zeros((n_pos, n_yaw))
        else:
            turn = np.mod(bearing[:, None] - yaws, 2 * math.pi)
            a = np.degrees(np.minimum(turn, 2 * math.pi - turn))
            a[d < 1e-9] = 0.0
        p = detection_probability(d[:, None], a, fov, view_range, fov_edge, range_edge)
        p = np.where(stands, p, 0.0)
        if occlusion:
            look = standing & (p > 0).any(axis=1)
            if view_range is not None:
                look &= d <= view_range + margin
            if look.any():
                # clear when the first blocked pixel is no nearer than the landmark less half a pixel
                near = d[look] - 1e-6 - image.resolution * 0.5
                cast = cast_rays_within(image, x[look], y[look], bearing[look], near)
                p[np.flatnonzero(look)[~(cast >= near)]] = 0.0
        probs.append(p)
        angles.append(a)
    P = np.stack(probs, axis=-1)  # (P, Y, L)
    A = np.stack(angles, axis=-1)
    if P.shape[-1] > 1:
        order = np.argsort(A, axis=-1)
        P = np.take_along_axis(P, order, axis=-1)
        A = np.take_along_axis(A, order, axis=-1)
    miss = np.cumprod(1.0 - P, axis=-1)
    before = np.concatenate([np.ones((n_pos, n_yaw, 1)), miss[..., :-1]], axis=-1)
    first = P * before  # P(the smallest-angle detected landmark is this one)
    sub = np.zeros((n_pos, n_yaw, n_values))
    sub[..., 0] = miss[..., -1]
    if angle_bins is None:
        sub[..., 1] = first.sum(axis=-1)
    else:
        col = np.searchsorted(angle_bins, A - 1e-9, side="left") + 1
        inside = col <= len(angle_bins)
        for v in range(1, n_values):
            sub[..., v] = (first * ((col == v) & inside)).sum(axis=-1)
        sub[..., 0] += (first * ~inside).sum(axis=-1)  # beyond the last bin: not reported
    return sub
