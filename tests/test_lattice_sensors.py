"""What a scan beam reads at a pose-lattice pose (issue 26): the distribution averaged over the
square and yaw step the pose stands for, so that a robot anywhere in them is explained."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from beliefloc import compile_model, load_map
from beliefloc.continuous.pose_lattice import PoseLattice
from beliefloc.continuous.raycast import cast_rays
from beliefloc.semantic_map import compile as compile_
from beliefloc.semantic_map import lattice_sensors, regions
from beliefloc.semantic_map.schema import SemanticMap
from beliefloc.semantic_map.sections import ScanSensor

TB3 = Path(__file__).resolve().parent.parent / "maps" / "tb3-sandbox.yaml"


@pytest.fixture(scope="module")
def tb3() -> tuple[SemanticMap, PoseLattice, ScanSensor]:
    smap = load_map(TB3)
    model = compile_model(smap)
    assert model.grid is not None
    lattice = lattice_sensors.make_lattice(smap, model.grid)
    sensor = next(s for s in smap.sensors.values() if isinstance(s, ScanSensor))
    return smap, lattice, sensor


def _true_bin_probability(
    tables: list[np.ndarray], sensor: ScanSensor, lattice: PoseLattice, rng: np.random.Generator, n: int
) -> np.ndarray:
    """For ``n`` robots placed uniformly in the square and yaw step of random lattice poses: the
    probability each beam's table gives the bin of the range the robot truly reads (no noise)."""
    poses = lattice.pose_array
    index = rng.integers(0, len(poses), n)
    robot = poses[index] + rng.uniform(-0.5, 0.5, (n, 3)) * [lattice.spacing, lattice.spacing, lattice.yaw_step]
    bins = np.asarray(sensor.bins)
    out = []
    for angle, table in zip(sensor.beams, tables, strict=True):
        ranges = cast_rays(lattice.image, robot[:, 0], robot[:, 1], robot[:, 2] + math.radians(angle), 20.0)
        out.append(table[index, np.searchsorted(bins, ranges)])
    return np.concatenate(out)


def test_a_robot_anywhere_in_a_lattice_pose_reads_what_its_table_expects(
    tb3: tuple[SemanticMap, PoseLattice, ScanSensor], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Plain Monte Carlo over continuous poses: the bin a robot in a pose's square and yaw step reads
    is rarely one its table calls unlikely. The pose's exact reading alone (one sub-pose) fails
    where a beam grazes a pillar or meets a wall at a slant -- 2.5 % of such readings under 0.05,
    which is how tb3-sandbox's mirror twin came to be declared."""
    _, lattice, sensor = tb3
    poses = lattice.pose_array
    averaged = _true_bin_probability(
        lattice_sensors.scan_tables(sensor, lattice, poses), sensor, lattice, np.random.default_rng(3), 4000
    )
    monkeypatch.setattr(lattice_sensors, "SUB_SAMPLES", 1)
    monkeypatch.setattr(lattice_sensors, "YAW_SAMPLES", 1)
    exact = _true_bin_probability(
        lattice_sensors.scan_tables(sensor, lattice, poses), sensor, lattice, np.random.default_rng(3), 4000
    )
    assert float((averaged < 0.05).mean()) < 0.006
    assert float((exact < 0.05).mean()) > 0.015


def test_beams_that_share_rays_read_the_plain_average_over_the_sub_poses(
    tb3: tuple[SemanticMap, PoseLattice, ScanSensor],
) -> None:
    """The tables cast each ray once where beams a whole number of yaw offsets apart meet the same
    direction; the result is the plain average over each pose's sub-poses, beam by beam."""
    _, lattice, sensor = tb3
    tables = lattice_sensors.scan_tables(sensor, lattice, lattice.pose_array)
    rng = np.random.default_rng(5)
    some = rng.choice(lattice.n_poses, 300, replace=False)
    poses = lattice.pose_array[some]
    _, _, sigma, random, short = sensor.region(real_place=True)
    random = max(random, lattice_sensors.MIN_RANDOM)
    sigma = math.hypot(sigma, lattice.spacing / lattice_sensors.SUB_SAMPLES / math.sqrt(12.0))
    bins = np.asarray(sensor.bins)
    reach = float(bins[-1]) + 4.0 * sigma
    top = max(lattice_sensors.RANDOM_RANGE, float(bins[-1]))
    anywhere = np.diff(np.minimum(np.r_[0.0, bins, top], top)) / top
    offsets = lattice_sensors.lattice_sub_offsets(lattice, lattice_sensors.SUB_SAMPLES, lattice_sensors.YAW_SAMPLES)
    # a sub-pose on a blocked pixel does not count (the lattice's positions have one free at least)
    image = lattice.image
    i, j = image.pixel_of(poses[:, 0, None] + offsets[None, :, 0], poses[:, 1, None] + offsets[None, :, 1])
    weight = ~np.asarray(image.blocked)[i, j]
    weight = weight / weight.sum(axis=1, keepdims=True)
    for angle, table in zip(sensor.beams, tables, strict=True):
        dist = np.zeros((len(poses), len(bins) + 1))
        for (dx, dy, dyaw), w in zip(offsets, weight.T, strict=True):
            ranges = cast_rays(
                lattice.image, poses[:, 0] + dx, poses[:, 1] + dy, poses[:, 2] + dyaw + math.radians(angle), reach
            )
            ranges[ranges > reach] = np.inf
            dist += w[:, None] * regions.scan_distribution(ranges, bins, sigma, 0.0, short / (1.0 - random))
        expected = (1.0 - random) * dist + random * anywhere
        expected = expected @ compile_.scan_confusion(sensor)
        expected = (1.0 - lattice_sensors.FLOOR) * expected + lattice_sensors.FLOOR / expected.shape[1]
        np.testing.assert_allclose(table[some], expected, atol=1e-6)


def test_scan_tables_built_in_parts_on_threads_are_the_same_bits(
    tb3: tuple[SemanticMap, PoseLattice, ScanSensor], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The tables' positions are split over threads (uneven parts included) and into blocks (any size);
    each position's sums are its own, taken in the same order, so the tables are the very bits of one
    thread's."""
    from concurrent.futures import ThreadPoolExecutor

    from beliefloc.source import threads

    _, lattice, sensor = tb3
    samples = lattice_sensors.beam_samples(sensor, lattice, lattice.pose_array)
    monkeypatch.setattr(threads, "_POOL", None)
    monkeypatch.setattr(threads, "_POOL_MADE", True)
    alone = lattice_sensors.scan_tables(sensor, lattice, lattice.pose_array, samples)
    monkeypatch.setattr(lattice_sensors, "THREADED_FROM", 1)
    for workers in (2, 3):
        with ThreadPoolExecutor(workers) as pool:
            monkeypatch.setattr(threads, "_POOL", pool)
            parts = lattice_sensors.scan_tables(sensor, lattice, lattice.pose_array, samples)
        assert len(parts) == len(alone) == len(sensor.beams)
        for got, want in zip(parts, alone, strict=True):
            assert got.tobytes() == want.tobytes()
    assert samples.weights.shape[0] % 6 != 0  # the two parts or the three are uneven
    monkeypatch.setattr(threads, "_POOL", None)
    for block in (7, 10**9):
        monkeypatch.setattr(lattice_sensors, "FILL_BLOCK", block)
        blocks = lattice_sensors.scan_tables(sensor, lattice, lattice.pose_array, samples)
        assert [t.tobytes() for t in blocks] == [t.tobytes() for t in alone]


def _brute_density(z: float, beam: float, poses: np.ndarray, sensor: ScanSensor, lattice: PoseLattice) -> np.ndarray:
    """``p(z | pose)`` of a measured range, pose by pose: a ray cast from every sub-pose, its reading
    ``N(r, σ)``, short readings uniform below ``r`` (or the last edge), random ones uniform over
    RANDOM_RANGE."""
    _, _, sigma, random, short = sensor.region(real_place=True)
    random = max(random, lattice_sensors.MIN_RANDOM)
    short = short / (1.0 - random)
    sigma = math.hypot(sigma, lattice.spacing / lattice_sensors.SUB_SAMPLES / math.sqrt(12.0))
    last = float(sensor.bins[-1])
    reach = last + 4.0 * sigma
    offsets = lattice_sensors.lattice_sub_offsets(lattice, lattice_sensors.SUB_SAMPLES, lattice_sensors.YAW_SAMPLES)
    image = lattice.image
    i, j = image.pixel_of(poses[:, 0, None] + offsets[None, :, 0], poses[:, 1, None] + offsets[None, :, 1])
    weight = ~np.asarray(image.blocked)[i, j]
    weight = weight / weight.sum(axis=1, keepdims=True)
    density = np.zeros(len(poses))
    for (dx, dy, dyaw), w in zip(offsets, weight.T, strict=True):
        r = cast_rays(image, poses[:, 0] + dx, poses[:, 1] + dy, poses[:, 2] + dyaw + math.radians(beam), reach)
        hit = np.where(r <= reach, np.exp(-0.5 * ((z - r) / sigma) ** 2) / (sigma * math.sqrt(2 * math.pi)), 0.0)
        limit = np.minimum(np.where(r <= reach, r, last), last)
        density += w * ((1.0 - short) * hit + short * (z < limit) / limit)
    return (1.0 - random) * density + random / lattice_sensors.RANDOM_RANGE


def test_a_measured_range_is_scored_by_the_ranges_of_the_poses_sub_poses(
    tb3: tuple[SemanticMap, PoseLattice, ScanSensor],
) -> None:
    """:meth:`BeamSamples.log_likelihood` (rays cast once, shared between beams and shifts, gathered by
    pose) is the density of the measured range computed pose by pose from rays cast from each sub-pose."""
    _, lattice, sensor = tb3
    samples = lattice_sensors.beam_samples(sensor, lattice, lattice.pose_array)
    rng = np.random.default_rng(6)
    some = rng.choice(lattice.n_poses, 300, replace=False)
    poses = lattice.pose_array[some]
    for beam, angle in enumerate(sensor.beams):
        for z in (0.05, 0.4, 1.0, 1.73, float(sensor.bins[-1]) - 0.01):
            np.testing.assert_allclose(
                np.exp(samples.log_likelihood(beam, z, some)),
                _brute_density(z, angle, poses, sensor, lattice),
                rtol=1e-9,
                atol=1e-12,
            )


def test_a_measured_ranges_density_over_a_bin_is_the_bins_probability(
    tb3: tuple[SemanticMap, PoseLattice, ScanSensor],
) -> None:
    """The two models of a beam agree: integrated over a bin, the measured range's density gives the
    probability the binned table has for that bin (before its confusion and floor)."""
    _, lattice, sensor = tb3
    samples = lattice_sensors.beam_samples(sensor, lattice, lattice.pose_array)
    tables = lattice_sensors.scan_tables(sensor, lattice, lattice.pose_array, samples)
    confusion = compile_.scan_confusion(sensor)
    some = np.random.default_rng(7).choice(lattice.n_poses, 200, replace=False)
    edges = np.r_[0.0, np.asarray(sensor.bins, dtype=np.float64)]
    for beam in range(len(sensor.beams)):
        table = tables[beam][some].astype(np.float64)
        raw = (table - lattice_sensors.FLOOR / table.shape[1]) / (1.0 - lattice_sensors.FLOOR)
        raw = raw @ np.linalg.inv(confusion)  # the bins' probabilities before the confusion
        for k in range(1, len(edges) - 1):  # bin 0 also holds the noise's mass below 0 m
            z = np.linspace(edges[k], edges[k + 1], 2001)
            density = np.array([np.exp(samples.log_likelihood(beam, float(v), some)) for v in z])
            mass = (0.5 * (density[1:] + density[:-1]) * np.diff(z)[:, None]).sum(axis=0)  # trapezoids
            np.testing.assert_allclose(mass, raw[:, k], atol=5e-4)
