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

import numpy as np

from beliefloc.continuous.pose_lattice import PoseLattice, lattice_resolution
from beliefloc.continuous.raycast import cast_rays
from beliefloc.model import Action, GridLayout, Model
from beliefloc.semantic_map import compile as compile_
from beliefloc.semantic_map import regions
from beliefloc.semantic_map.schema import SemanticMap
from beliefloc.semantic_map.sections import LookSensor, ScanSensor

MIN_RANDOM = 0.1
"""The least share of a scan beam's readings taken as random, whatever the map says: a robot among
people and furniture reads them (AMCL's ``z_rand``)."""
RANDOM_RANGE = 12.0
"""Metres: a random reading is uniform over this range (a 2-D lidar's, e.g. an RPLIDAR's), so most
fall beyond the last bin -- as an unmapped obstacle's or a spurious return's do."""
FLOOR = 1e-3
DEFAULT_ROBOT_RADIUS = 0.1
"""Metres: the robot's disc when the map gives no ``robot_radius`` (a hand-drawn grid)."""
"""The share of every part's distribution spread evenly over its readings at every pose."""


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


def scan_tables(sensor: ScanSensor, lattice: PoseLattice, poses: np.ndarray) -> list[np.ndarray]:
    """One ``(n_poses, len(bins) + 1)`` table per beam of ``sensor``."""
    _, _, sigma, random, short = sensor.region(real_place=True)
    random = max(random, MIN_RANDOM)
    sigma = _widen(sigma, lattice.spacing / math.sqrt(12.0))
    bins = np.asarray(sensor.bins, dtype=np.float64)
    reach = float(bins[-1]) + 4.0 * sigma
    confusion = compile_.scan_confusion(sensor)
    # a random reading is a range uniform over [0, RANDOM_RANGE]: mostly beyond the last bin
    edges = np.minimum(np.r_[0.0, bins, max(RANDOM_RANGE, float(bins[-1]))], max(RANDOM_RANGE, float(bins[-1])))
    anywhere = np.diff(edges) / edges[-1]
    tables = []
    for angle in sensor.beams:
        ranges = cast_rays(lattice.image, poses[:, 0], poses[:, 1], poses[:, 2] + math.radians(angle), reach)
        ranges[ranges > reach] = np.inf
        dist = (1.0 - random) * regions.scan_distribution(ranges, bins, sigma, 0.0, short / (1.0 - random))
        dist += random * anywhere
        tables.append(_floored(dist @ confusion))
    return tables


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
    smap: SemanticMap, model: Model, lattice: PoseLattice, slots_of: dict[str, list[tuple[str, int, int]]]
) -> dict[str, list[np.ndarray]]:
    """The tables of every action: ``slots_of[action] = [(sensor name, first part, n_parts), ...]``
    (the sensors the action reads, in the model's part order). A sensor read by several actions is
    computed once."""
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
                    by_sensor[name] = scan_tables(sensor, lattice, poses)
                elif isinstance(sensor, LookSensor):
                    by_sensor[name] = look_tables(sensor, smap, layout, lattice, poses)
                else:
                    by_sensor[name] = model_tables(action, first, count, lattice)
            tables.extend(by_sensor[name])
        out[action.name] = tables
    return out
