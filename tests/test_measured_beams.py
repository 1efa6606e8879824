"""The lattice filter scores a beam's measured range, not only its bin (issue 26): a range the robot
measured to centimetres tells look-alike poses apart that the bins (0.5 / 1.5 / 3 / 6 m on the depot)
cannot; a beam that read nothing, or beyond the last edge, keeps its bin's table."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from beliefloc import compile_model, load_map
from beliefloc.belief import uniform
from beliefloc.robots.belief_filter import LatticeFilter
from beliefloc.robots.readings import ReadingBinner
from beliefloc.simulation.continuous_episode import ContinuousSetup

TB3 = Path(__file__).resolve().parent.parent / "maps" / "tb3-sandbox.yaml"


@pytest.fixture(scope="module")
def tb3() -> tuple[ReadingBinner, ContinuousSetup]:
    smap = load_map(TB3)
    return ReadingBinner(smap, compile_model(smap)), ContinuousSetup(smap, range_noise=0.0)


def _beams_at(setup: ContinuousSetup, binner: ReadingBinner, pose: np.ndarray) -> list[float | None]:
    """The scan's beams as a robot at lattice pose ``pose`` (grid frame) reads them, in metres."""
    grid = binner.model.grid
    assert grid is not None
    x, y, yaw = (float(v) for v in pose)
    mx, my = grid.frame.to_map(x, y)
    world = setup.world(np.random.default_rng(0))
    sensor = binner.smap.sensors["scan"]
    angles = np.radians(np.asarray(sensor.beams, dtype=np.float64))
    ranges = world.scan_ranges(np.tile([float(mx), float(my), yaw + grid.frame.yaw], (len(angles), 1)), angles)
    return [float(r) if math.isfinite(r) and r > 0 else None for r in ranges]


def test_measured_ranges_tell_more_than_their_bins(tb3: tuple[ReadingBinner, ContinuousSetup]) -> None:
    """From a uniform belief, the scan a robot reads at a lattice pose: scored by its measured ranges,
    the poses within 10 cm and 10 degrees of the truth gain more than when only the bins count; the
    probability returned is the binned observation's either way (what the fit check compares)."""
    binner, setup = tb3
    scan = binner.model.action("scan")
    measured = LatticeFilter(binner)
    binned = LatticeFilter(binner)
    lattice = measured.lattice
    poses = lattice.pose_array
    rng = np.random.default_rng(4)
    checked = 0
    gains = []
    for truth in rng.choice(lattice.n_poses, 12, replace=False).tolist():
        readings = _beams_at(setup, binner, poses[truth])
        if not any(r is not None and r < binner.smap.sensors["scan"].bins[-1] for r in readings):
            continue  # nothing within the last edge: the bins alone (tested below)
        observation = binner.observation(scan, {"scan": readings})
        for tracker in (measured, binned):
            tracker.start(uniform(binner.model.n_states))
        _, p_measured = measured.correct(scan, observation, {"scan": readings})
        _, p_binned = binned.correct(scan, observation)
        assert p_measured == pytest.approx(p_binned)
        turned = np.abs(np.remainder(poses[:, 2] - poses[truth, 2] + math.pi, 2 * math.pi) - math.pi)
        near = (np.hypot(*(poses[:, :2] - poses[truth, :2]).T) < 0.1) & (turned < math.radians(10))
        gains.append(measured.core.fine[near].sum() / binned.core.fine[near].sum())
        assert np.isclose(measured.core.fine.sum(), 1.0) and (measured.core.fine >= 0).all()
        checked += 1
    assert checked >= 6
    assert min(gains) > 1.0 and float(np.median(gains)) > 3.0


def test_a_beam_beyond_the_last_edge_or_without_a_return_keeps_its_bin(
    tb3: tuple[ReadingBinner, ContinuousSetup],
) -> None:
    binner, _ = tb3
    scan = binner.model.action("scan")
    last = binner.smap.sensors["scan"].bins[-1]
    readings = [None, last + 0.5, None]
    observation = binner.observation(scan, {"scan": readings})
    a, b = LatticeFilter(binner), LatticeFilter(binner)
    a.correct(scan, observation, {"scan": readings})
    b.correct(scan, observation)
    assert a.core.fine.tobytes() == b.core.fine.tobytes()


def test_a_one_beam_scan_may_be_the_number_alone() -> None:
    """The protocol lets a one-beam scan give its range alone: ``0.63`` is ``[0.63]``."""
    smap = load_map(Path(__file__).resolve().parent.parent / "maps" / "kitchen.yaml")
    binner = ReadingBinner(smap, compile_model(smap))
    scan = binner.model.action("scan")
    observation = binner.observation(scan, {"scan": 0.63})
    a, b = LatticeFilter(binner), LatticeFilter(binner)
    a.correct(scan, observation, {"scan": 0.63})
    b.correct(scan, observation, {"scan": [0.63]})
    assert a.core.fine.tobytes() == b.core.fine.tobytes()
    c = LatticeFilter(binner)
    c.correct(scan, observation)  # the bin alone
    assert a.core.fine.tobytes() != c.core.fine.tobytes()
