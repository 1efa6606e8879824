"""What a map's sensors read at every pose of a pose lattice (:mod:`beliefloc.continuous.pose_lattice`).

The lattice filter needs, for each observation part of each sensor, the probability of each of the
part's readings at each lattice pose. They are the region model's distributions
(:mod:`beliefloc.semantic_map.regions`) taken at the lattice's poses instead of averaged over a
state's region, with the sensor's continuous noise -- the map's values, else a real sensor's
(:meth:`~beliefloc.semantic_map.sections.ScanSensor.region` with ``real_place``) -- widened by the
lattice's own spacing (a lattice pose stands for the sub-cell and yaw step around it):

* **Scan**, per beam: the ray cast from the pose; Gaussian range error
  ``hypot(sigma, spacing / √12)`` across the bin edges, mixed with ``short`` and with ``random`` (at
  least :data:`MIN_RANDOM`; a random range is uniform over :data:`RANDOM_RANGE` metres, so most
  random readings say ``no_wall``); then the scan's ``error``.
* **Look**, per class: detection by field of view and range with soft edges
  (``hypot(fov_edge, yaw step / √12)`` degrees, ``hypot(range_edge, spacing / √12)`` metres) and line
  of sight; the smallest viewing angle among the landmarks seen; then ``false_positive`` and
  ``false_negative`` as the model applies them.
* **Here** (the class of the robot's cell): the model's own rows, the same at every pose of a cell.

Every reading that some pose can give keeps at least a share of :data:`FLOOR` at every pose, so no
reading removes a pose outright: a reading the world gives and the map does not (a person in front of the laser) weighs
against a pose, it does not erase the truth.

Annotated readings (a map's ``readings:`` for listed states) are not used: they say what the papers'
model reads at a state's exact pose, and a lattice pose reads what the geometry gives.

Pure numpy/scipy, no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from beliefloc.continuous.pose_lattice import PoseLattice, lattice_resolution
from beliefloc.continuous.raycast import cast_rays
from beliefloc.model import Action, GridLayout, Model
from beliefloc.semantic_map import compile as compile_
from beliefloc.semantic_map import regions
from beliefloc.semantic_map.schema import SemanticMap
from beliefloc.semantic_map.sections import LookSensor, ScanSensor
from beliefloc.source import threads

MIN_RANDOM = 0.1
"""The least share of a scan beam's readings taken as random, whatever the map says: a robot among
people and furniture reads them (AMCL's ``z_rand``)."""
RANDOM_RANGE = 12.0
"""Metres: a random reading is uniform over this range (a 2-D lidar's, e.g. an RPLIDAR's), so most
fall beyond the last bin -- as an unmapped obstacle's or a spurious return's do."""
FLOOR = 1e-3
"""The share of every part's distribution spread evenly over its readings at every pose."""
SUB_SAMPLES = 2
"""A scan beam's distribution at a lattice pose is averaged over this many positions per axis of
the square the pose stands for (:func:`lattice_sub_offsets`) ..."""
YAW_SAMPLES = 3
"""... times this many yaws across its yaw step."""
FILL_BLOCK = 256
"""Positions whose scan readings :func:`scan_tables` works out at a time."""
THREADED_FROM = 50_000
"""Rays (positions x angles) from which :func:`scan_tables` splits its positions over threads."""
DEFAULT_ROBOT_RADIUS = 0.1
"""Metres: the robot's disc when the map gives no ``robot_radius`` (a hand-drawn grid)."""


def make_lattice(smap: SemanticMap, layout: GridLayout, max_poses: int | None = None) -> PoseLattice:
    """The pose lattice of ``smap``'s states at :func:`~beliefloc.continuous.pose_lattice.lattice_resolution`."""
    kwargs = {} if max_poses is None else {"max_poses": max_poses}
    k, m = lattice_resolution(layout, **kwargs)
    return PoseLattice(layout, compile_.region_image(smap, layout), k, m, robot_radius(smap))


def robot_radius(smap: SemanticMap) -> float:
    """Metres: the map's ``robot_radius``, else :data:`DEFAULT_ROBOT_RADIUS`."""
    radius = smap.grid.robot_radius if smap.grid is not None else None
    return float(radius) if radius else DEFAULT_ROBOT_RADIUS


def _widen(*parts: float) -> float:
    return float(math.sqrt(sum(p * p for p in parts)))


@dataclass(frozen=True, eq=False)
class BeamSamples:
    """What each beam of a scan sensor reads from the sub-poses a lattice pose stands for
    (:func:`lattice_sub_offsets`): the ray-cast ranges behind both the binned tables
    (:func:`scan_tables`) and the score of a measured range (:meth:`log_likelihood`)."""

    ranges: np.ndarray
    """``(angles, positions, shifts)`` ranges (``inf``: nothing within :attr:`reach`): a pose's rays at
    one angle lie side by side, which is how :meth:`log_likelihood` reads them."""
    which: np.ndarray
    """``(lattice yaws, yaw offsets, beams)``: the angle each beam's ray takes."""
    weights: np.ndarray
    """``(positions, shifts)``: each sub-position's share of its position (:func:`_standing_weights`)."""
    n_turns: int
    sigma: float
    """The range noise, widened by the sub-square's spread."""
    random: float
    short: float
    """The share of short readings among those that are not random."""
    bins: np.ndarray
    reach: float

    def log_likelihood(self, beam: int, measured: float, poses: np.ndarray) -> np.ndarray:
        """``ln p(z | pose)`` of beam ``beam``'s measured range ``z`` (metres) at the lattice poses
        ``poses`` (indices): the density of ``z`` (per metre) averaged over the
        pose's sub-poses, each reading its ray-cast range ``r`` with the noise ``N(r, σ)``, short
        readings uniform below ``r`` and random ones uniform over :data:`RANDOM_RANGE` mixed in as
        :func:`scan_tables` mixes them. Where the binned tables only know that 1.62 m is in
        [1.5, 3) m, this knows it to the noise: on the depot (one beam) a look-alike 20 cm away is told
        apart by one reading."""
        n_positions = self.weights.shape[0]
        order = np.asarray(poses, dtype=np.intp)
        if order.size == 0:
            return np.zeros(0)
        sorted_poses = bool(np.all(order[1:] >= order[:-1]))
        if not sorted_poses:
            order = np.sort(order)
        g, p = np.divmod(order, n_positions)
        last = float(self.bins[-1])
        cut = 12.0 * self.sigma  # beyond it the Gaussian is e^-72 of its peak: lost beside the rest
        peak = (1.0 - self.short) / (self.sigma * math.sqrt(2.0 * math.pi))
        mean = np.empty(order.size)
        # a lattice yaw at a time: its poses' rays at each of its angles lie side by side (taken, not
        # gathered element by element: 20x faster), and the passes stay within the cache
        bounds = np.flatnonzero(np.r_[True, g[1:] != g[:-1], True])
        for lo, hi in zip(bounds[:-1].tolist(), bounds[1:].tolist(), strict=True):
            at = p[lo:hi]
            angles = self.which[g[lo], :, beam]
            r = np.empty((len(angles), hi - lo, self.ranges.shape[2]))  # (yaw offsets, poses, shifts)
            for t, angle in enumerate(angles.tolist()):
                np.take(self.ranges[angle], at, axis=0, out=r[t])
            limit = np.minimum(r, last)  # nothing within reach: short readings anywhere below the last edge
            density = np.where(measured < limit, self.short / np.maximum(limit, 1e-3), 0.0)
            np.subtract(r, measured, out=r)
            close = np.flatnonzero(np.abs(r, out=r) < cut)
            apart = r.ravel()[close] / self.sigma
            density.flat[close] += peak * np.exp(-0.5 * apart * apart)
            # the sub-poses' shares: each shift's standing weight, the yaw offsets alike
            mean[lo:hi] = np.einsum("ps,tps->p", np.take(self.weights, at, axis=0), density)
        mean /= self.n_turns
        out: np.ndarray = np.log((1.0 - self.random) * mean + self.random / RANDOM_RANGE)
        if not sorted_poses:
            out = out[np.searchsorted(order, np.asarray(poses, dtype=np.intp))]
        return out


def beam_samples(sensor: ScanSensor, lattice: PoseLattice, poses: np.ndarray) -> BeamSamples:
    """Every beam's ray from every sub-pose of every lattice position (:data:`SUB_SAMPLES` positions per
    axis, the ones on a blocked pixel left out, times :data:`YAW_SAMPLES` yaws). Beams a whole number of
    yaw offsets apart share their rays (tb3-sandbox's beams at -90, 0 and 90 degrees: one cast in three)."""
    _, _, sigma, random, short = sensor.region(real_place=True)
    random = max(random, MIN_RANDOM)
    # what the sub-poses leave of the square: each stands for a square of side spacing / SUB_SAMPLES
    sigma = _widen(sigma, lattice.spacing / SUB_SAMPLES / math.sqrt(12.0))
    bins = np.asarray(sensor.bins, dtype=np.float64)
    reach = float(bins[-1]) + 4.0 * sigma
    G = lattice.shape[0]
    n_positions = lattice.n_poses // G
    xy = poses[:n_positions, :2]  # the valid poses are every lattice yaw at each valid position
    offsets = lattice_sub_offsets(lattice, SUB_SAMPLES, YAW_SAMPLES)
    shifts = np.unique(offsets[:, :2], axis=0)
    turns = np.unique(offsets[:, 2])
    # each ray's direction: lattice yaw + yaw offset + beam angle
    direction = lattice.yaws()[:, None, None] + turns[None, :, None] + np.radians(sensor.beams)[None, None, :]
    rounded = np.round(np.mod(direction, 2 * math.pi), 9)
    _, first, which = np.unique(
        np.where(rounded >= np.round(2 * math.pi, 9), 0.0, rounded), return_index=True, return_inverse=True
    )
    angles = direction.ravel()[first]
    weights = _standing_weights(lattice, xy, shifts)
    ranges = np.full((len(angles), n_positions, len(shifts)), np.inf)  # 96 MB on the depot
    for s, (dx, dy) in enumerate(shifts):
        held = np.flatnonzero(weights[:, s] > 0)
        if held.size:
            cast = cast_rays(lattice.image, xy[held, 0, None] + dx, xy[held, 1, None] + dy, angles[None, :], reach)
            cast[cast > reach] = np.inf
            ranges[:, held, s] = cast.T
    return BeamSamples(
        ranges, which.reshape(direction.shape), weights, len(turns), sigma, random, short / (1.0 - random), bins, reach
    )


def scan_tables(
    sensor: ScanSensor, lattice: PoseLattice, poses: np.ndarray, samples: BeamSamples | None = None
) -> list[np.ndarray]:
    """One ``(n_poses, len(bins) + 1)`` table per beam of ``sensor``: the readings' distribution
    averaged over the square and yaw step each lattice pose stands for (:func:`beam_samples`, or
    ``samples`` already cast)."""
    samples = samples if samples is not None else beam_samples(sensor, lattice, poses)
    bins, sigma, random = samples.bins, samples.sigma, samples.random
    confusion = compile_.scan_confusion(sensor)
    # a random reading is a range uniform over [0, RANDOM_RANGE]: mostly beyond the last bin
    edges = np.minimum(np.r_[0.0, bins, max(RANDOM_RANGE, float(bins[-1]))], max(RANDOM_RANGE, float(bins[-1])))
    anywhere = np.diff(edges) / edges[-1]
    G = lattice.shape[0]
    n_positions = samples.weights.shape[0]
    dist = np.zeros((len(sensor.beams), G, n_positions, len(bins) + 1))

    def fill(first: int, last: int) -> None:
        """The distributions of positions ``first .. last - 1``: each position's own sums, in the same
        order however the positions are split -- here into blocks of :data:`FILL_BLOCK` positions, whose
        temporaries stay in the cache (whole, a thread's half of the depot made five of 0.5 GB each)."""
        for lo in range(first, last, FILL_BLOCK):
            hi = min(last, lo + FILL_BLOCK)
            for s, weight in enumerate(samples.weights.T):
                held = lo + np.flatnonzero(weight[lo:hi] > 0)
                if not held.size:
                    continue
                ranges = samples.ranges[:, held, s].T  # (positions, angles)
                readings = regions.scan_distribution(ranges, bins, sigma, 0.0, samples.short)
                share = weight[held, None] / samples.n_turns
                for b in range(len(sensor.beams)):
                    for t in range(samples.n_turns):
                        dist[b][:, held] += readings[:, samples.which[:, t, b], :].transpose(1, 0, 2) * share

    # the positions in parts, one a thread: NumPy lets go of the interpreter in these passes (the
    # depot: 7 of the 13 s its lattice tables took on one core)
    pool = threads.pool() if n_positions * samples.ranges.shape[0] >= THREADED_FROM else None
    if pool is None:
        fill(0, n_positions)
    else:
        bounds = np.linspace(0, n_positions, threads.size() + 1).astype(np.int64).tolist()
        list(pool.map(fill, bounds[:-1], bounds[1:]))
    tables = []
    for b in range(len(sensor.beams)):
        rows = (1.0 - random) * dist[b].reshape(-1, len(bins) + 1) + random * anywhere
        tables.append(_floored(rows @ confusion))
    return tables


def lattice_sub_offsets(lattice: PoseLattice, sub_samples: int, yaw_samples: int) -> np.ndarray:
    """``(n, 3)`` offsets ``(dx, dy, dyaw)`` of the sub-poses of a lattice pose: ``sub_samples``
    positions per axis at the midpoints of a split of its square (side :attr:`PoseLattice.spacing`),
    times ``yaw_samples`` yaws at the midpoints of a split of its yaw step. A lattice pose stands for
    all of them: its own exact pose alone explains a robot 4 cm and 4° away badly wherever a beam
    grazes a pillar or meets a wall at a slant (tb3-sandbox: the true reading 10^-2 to 10^-4 as likely
    at the nearest lattice pose as at the best one, and the mirror twin declared)."""
    k = max(1, int(sub_samples))
    m = max(1, int(yaw_samples)) if lattice.shape[0] > 1 else 1
    along = ((np.arange(k) + 0.5) / k - 0.5) * lattice.spacing
    turn = ((np.arange(m) + 0.5) / m - 0.5) * lattice.yaw_step if m > 1 else np.zeros(1)
    dx, dy, dyaw = np.meshgrid(along, along, turn, indexing="ij")
    return np.stack([dx.ravel(), dy.ravel(), dyaw.ravel()], axis=-1)


def _standing_weights(lattice: PoseLattice, xy: np.ndarray, shifts: np.ndarray) -> np.ndarray:
    """``(n_positions, n_shifts)``: each sub-position's share of its lattice position -- equal among
    the sub-positions on a pixel the rays can start from (not blocked, in the image); a position
    with none keeps the sub-position nearest its own (the robot stood there: a ray from a blocked
    pixel reads 0, and its readings would be the floor's)."""
    image = lattice.image
    x = xy[:, 0][:, None] + shifts[None, :, 0]
    y = xy[:, 1][:, None] + shifts[None, :, 1]
    i, j = image.pixel_of(x, y)
    inside = (i >= 0) & (i < image.height) & (j >= 0) & (j < image.width)
    free = np.zeros(inside.shape, dtype=bool)
    free[inside] = ~np.asarray(image.blocked)[i[inside], j[inside]]
    none = ~free.any(axis=1)
    if none.any():
        free[none, int(np.argmin(np.hypot(shifts[:, 0], shifts[:, 1])))] = True
    weights: np.ndarray = free / free.sum(axis=1, keepdims=True)
    return weights


def look_tables(
    sensor: LookSensor, smap: SemanticMap, layout: GridLayout, lattice: PoseLattice, poses: np.ndarray
) -> list[np.ndarray]:
    """One ``(n_poses, n_values)`` table per class of ``sensor``."""
    _, _, fov_edge, range_edge = sensor.region(real_place=True)
    fov_edge = _widen(fov_edge, math.degrees(lattice.yaw_step) / math.sqrt(12.0))
    range_edge = _widen(range_edge, lattice.spacing / math.sqrt(12.0))
    fov = sensor.effective_fov(layout.headings)
    bins = np.array(sensor.angle_bins) if sensor.angle_bins else None
    confusion = compile_.look_confusion(sensor)
    stands = np.ones(len(poses), dtype=bool)
    tables = []
    for cls in sensor.classes:
        xy = compile_.landmarks_xy(smap, layout, cls)
        dist = regions.look_distribution(
            lattice.image,
            poses,
            stands,
            xy,
            layout.headings == 1,
            fov,
            sensor.range,
            sensor.occlusion,
            bins,
            fov_edge,
            range_edge if sensor.range is not None else 0.0,
        )
        tables.append(_floored(dist @ confusion))
    return tables


def model_tables(action: Action, first: int, count: int, lattice: PoseLattice) -> list[np.ndarray]:
    """The model's own rows for parts ``first .. first + count`` of ``action``, at every pose of each state."""
    out = []
    for part in action.observation.parts[first : first + count]:
        rows = np.asarray(part.confusion, dtype=np.float64)[np.asarray(part.truth)[lattice.state]]
        out.append(_floored(rows))
    return out


def _floored(dist: np.ndarray) -> np.ndarray:
    d = np.clip(np.asarray(dist, dtype=np.float64), 0.0, None)
    d /= d.sum(axis=1, keepdims=True)
    # a reading no pose can give (a class with no landmark and no false positives) stays impossible
    possible = d.max(axis=0) > 0
    out: np.ndarray = ((1.0 - FLOOR) * d + FLOOR * possible / possible.sum()).astype(np.float32)
    return out


def sensor_tables(
    smap: SemanticMap,
    model: Model,
    lattice: PoseLattice,
    slots_of: dict[str, list[tuple[str, int, int]]],
    samples: dict[str, BeamSamples] | None = None,
) -> dict[str, list[np.ndarray]]:
    """The tables of every action: ``slots_of[action] = [(sensor name, first part, n_parts), ...]``
    (the sensors the action reads, in the model's part order). A sensor read by several actions is
    computed once. ``samples``, when given, receives each scan sensor's :class:`BeamSamples`."""
    layout = model.grid
    assert layout is not None
    poses = lattice.poses()
    by_sensor: dict[str, list[np.ndarray]] = {}
    out: dict[str, list[np.ndarray]] = {}
    for action in model.actions:
        tables: list[np.ndarray] = []
        for name, first, count in slots_of.get(action.name, []):
            sensor = smap.sensors[name]
            if name not in by_sensor:
                if isinstance(sensor, ScanSensor):
                    cast = beam_samples(sensor, lattice, poses)
                    if samples is not None:
                        samples[name] = cast
                    by_sensor[name] = scan_tables(sensor, lattice, poses, cast)
                elif isinstance(sensor, LookSensor):
                    by_sensor[name] = look_tables(sensor, smap, layout, lattice, poses)
                else:
                    by_sensor[name] = model_tables(action, first, count, lattice)
            tables.extend(by_sensor[name])
        out[action.name] = tables
    return out
