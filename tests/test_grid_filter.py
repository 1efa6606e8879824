"""The grid filter and the surprise check: gating, localizing a robot in a room, refinement,
covariance, a kidnapped robot and a symmetric room."""

from __future__ import annotations

import math

import numpy as np
import pytest

from beliefloc.continuous.fit import FitConfig, FitTracker, inlier_fraction, surprise
from beliefloc.continuous.grid_filter import FilterConfig, GridFilter, clutter_share, trimmed_gap
from beliefloc.continuous.likelihood_field import LaserModel, Scan, select_beams
from beliefloc.continuous.motion import compose, relative
from beliefloc.continuous.raycast import cast_rays
from beliefloc.model import MapFrame
from beliefloc.semantic_map.occupancy_map import Occupancy, OccupancyMap

MOUNT = (0.0, 0.0, math.pi / 2)
ANGLES = np.linspace(-math.pi, math.pi, 360, endpoint=False)


def _map(pixels: np.ndarray) -> OccupancyMap:
    from pathlib import Path

    return OccupancyMap(Path("room.yaml"), Path("room.pgm"), 0.05, MapFrame(-1.0, -0.5, 0.0), pixels, "test")


def _room(symmetric: bool = False) -> OccupancyMap:
    """A 4 m x 3 m room; unless symmetric, a box in one corner and a pillar break its symmetry."""
    pixels = np.full((60, 80), Occupancy.FREE, dtype=np.uint8)
    pixels[0, :] = pixels[-1, :] = pixels[:, 0] = pixels[:, -1] = Occupancy.OCCUPIED
    if not symmetric:
        pixels[5:15, 8:22] = Occupancy.OCCUPIED
        pixels[40:44, 55:59] = Occupancy.OCCUPIED
    return _map(pixels)


def _beams(occupancy: OccupancyMap, pose: tuple[float, float, float], model: LaserModel):  # type: ignore[no-untyped-def]
    from beliefloc.continuous.image import OccupancyImage

    image = OccupancyImage.occupied_of(occupancy)
    laser = (pose[0], pose[1], pose[2] + MOUNT[2])
    ranges = cast_rays(image, laser[0], laser[1], laser[2] + ANGLES, 8.0)
    scan = Scan(float(ANGLES[0]), float(ANGLES[1] - ANGLES[0]), ranges, 0.1, 8.0)
    return select_beams(scan, model, MOUNT)


def _drive(grid: GridFilter, occupancy: OccupancyMap, poses: list[tuple[float, float, float]]) -> list:  # type: ignore[type-arg]
    """Feed the filter a scan at each pose with exact odometry (odom frame = map frame here)."""
    updates = []
    for n, pose in enumerate(poses):
        odom = np.array(pose)
        if grid.wants_update(odom, 0.0):
            updates.append(grid.update(n, odom, _beams(occupancy, pose, grid.config.laser)))
    return updates


def _path() -> list[tuple[float, float, float]]:
    start = (-0.2, 0.7, 0.1)
    return [(start[0] + 0.25 * step * math.cos(0.1), start[1] + 0.25 * step * math.sin(0.1), 0.1) for step in range(10)]


def test_localizes_in_an_asymmetric_room() -> None:
    occupancy = _room()
    grid = GridFilter(occupancy, FilterConfig(), reach=8.5)
    updates = _drive(grid, occupancy, _path())
    last = updates[-1]
    truth = _path()[-1]
    assert last.localized
    assert math.hypot(last.x - truth[0], last.y - truth[1]) < 0.05
    assert abs(math.remainder(last.yaw - truth[2], 2 * math.pi)) < math.radians(3)
    cov = grid.covariance((last.x, last.y, last.yaw))
    assert cov.shape == (6, 6)
    assert np.allclose(cov, cov.T)
    assert np.all(np.linalg.eigvalsh(cov[np.ix_([0, 1, 5], [0, 1, 5])]) > 0)
    assert math.sqrt(cov[0, 0]) < 0.1


def test_updates_are_gated_by_motion() -> None:
    occupancy = _room()
    grid = GridFilter(occupancy, FilterConfig(update_min_d=0.25, update_min_a=0.2), reach=8.5)
    assert grid.wants_update(np.zeros(3), 0.0)  # the first scan
    grid.update(0, np.zeros(3), _beams(occupancy, (0.5, 0.6, 0.0), grid.config.laser))
    assert not grid.wants_update(np.array([0.1, 0.0, 0.05]), 0.0)
    assert grid.wants_update(np.array([0.26, 0.0, 0.0]), 0.0)
    assert grid.wants_update(np.array([0.0, 0.0, 0.21]), 0.0)
    assert grid.wants_update(np.array([0.0, 0.0, 0.05]), 0.3)  # turning: every scan


def test_refinement_finds_the_pose_between_cells() -> None:
    occupancy = _room()
    grid = GridFilter(occupancy, FilterConfig(), reach=8.5)
    truth = (1.237, 0.873, 0.41)
    beams = _beams(occupancy, truth, grid.config.laser)
    refined = grid.refine((1.2, 0.85, 0.35), beams)
    assert math.hypot(refined[0] - truth[0], refined[1] - truth[1]) < 0.02
    assert abs(refined[2] - truth[2]) < math.radians(1)


def test_a_symmetric_room_is_never_declared_localized() -> None:
    """A plain rectangle looks the same from a pose and its 180-degree twin: the filter must not
    call either, whatever the belief's mass does."""
    occupancy = _room(symmetric=True)
    grid = GridFilter(occupancy, FilterConfig(), reach=8.5)
    updates = _drive(grid, occupancy, _path())
    assert not any(u.localized for u in updates)
    assert len(updates[-1].modes) >= 2


def test_a_kidnapped_robot_is_not_localized_where_it_was() -> None:
    occupancy = _room()
    grid = GridFilter(occupancy, FilterConfig(), reach=8.5)
    updates = _drive(grid, occupancy, _path())
    assert updates[-1].localized
    # carried to the other side of the room; the odometry says it only turned in place
    odom = np.array(_path()[-1])
    after = []
    for n in range(6):
        odom = odom + np.array([0.0, 0.0, 0.25])
        pose = (2.3, 0.0, math.pi + 0.25 * n)
        after.append(grid.update(100 + n, odom, _beams(occupancy, pose, grid.config.laser)))
    first = after[0]
    assert first.beams > 0
    assert first.fraction < grid.config.fit.min_inlier_fraction or first.surprise < grid.config.fit.min_surprise
    assert not first.localized
    for u in after:
        wrong = math.hypot(u.x - _path()[-1][0], u.y - _path()[-1][1]) < 0.5
        assert not (u.localized and wrong)


def test_fit_numbers() -> None:
    assert inlier_fraction(np.array([0.0, 0.1, 0.5, 1.0]), 0.2) == 0.5
    assert inlier_fraction(np.array([]), 0.2) == 1.0
    ll = np.array([-10.0, -50.0])
    assert surprise(np.array([1.0, 0.0]), ll, 10) == pytest.approx(0.0)
    assert surprise(np.array([0.0, 1.0]), ll, 10) == pytest.approx(-4.0)
    tracker = FitTracker(FitConfig(window=2, min_inlier_fraction=0.6))
    tracker.add(0.9, 0.0)
    assert not tracker.fits() and "only 1" in (tracker.why_not() or "")
    tracker.add(0.8, 0.0)
    assert tracker.fits() and tracker.why_not() is None
    tracker.add(0.2, 0.0)
    assert not tracker.fits() and "fit the best pose poorly" in (tracker.why_not() or "")


def test_trimmed_gap_sets_aside_what_a_few_objects_could_have_made() -> None:
    """Twelve beams over two scans. In the first pose's favour: beams 2 and 3 of each scan (+2.5
    nats each), whose end points at the second pose lie together (one object seen in both scans),
    and beam 9 of the first (+1.0) far from them; beam 5 of each scan is in the second's favour
    (-2.0). Untrimmed the first pose wins by 7 nats; one object sets aside the four beams by it
    (10 nats), a second object beam 9 too."""
    theirs = np.full((2, 6), -1.0)
    mine = theirs.copy()
    mine[:, [2, 3]] += 2.5
    mine[:, 5] -= 2.0
    x = np.array([[0.0, 5.0, 3.0, 3.2, 9.0, 1.0], [0.0, 7.0, 3.1, 3.3, 9.0, 1.0]])
    y = np.zeros((2, 6))
    mine[0, 4] += 1.0  # end point (9, 0): far from the object at x ~3
    assert float((mine - theirs).sum()) == pytest.approx(7.0)
    assert trimmed_gap(mine, theirs, x, y, 0, 0.8) == pytest.approx(7.0)
    assert trimmed_gap(mine, theirs, x, y, 1, 0.8) == pytest.approx(-3.0)
    assert trimmed_gap(mine, theirs, x, y, 2, 0.8) == pytest.approx(-4.0)
    # an object's extent: with 0.05 m only the single best beam goes with each object
    assert trimmed_gap(mine, theirs, x, y, 1, 0.05) == pytest.approx(4.5)
    # beams in the second pose's favour are never set aside
    assert trimmed_gap(theirs, mine, x, y, 2, 0.8) == pytest.approx(-7.0 - 4.0)
    assert trimmed_gap(np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0), 2, 0.8) == 0.0
    # beams no object could have made are kept: with beams 2 and 3 of the first scan fixed, the
    # first object is centred on the second scan's beams and sets aside only those two (5 nats)
    fixed = np.zeros((2, 6), dtype=bool)
    fixed[0, [2, 3]] = True
    assert trimmed_gap(mine, theirs, x, y, 1, 0.8, fixed) == pytest.approx(2.0)
    assert trimmed_gap(mine, theirs, x, y, 2, 0.8, fixed) == pytest.approx(1.0)
    assert trimmed_gap(mine, theirs, x, y, 2, 0.8, np.ones((2, 6), dtype=bool)) == pytest.approx(7.0)


def test_clutter_share_is_what_objects_at_the_other_pose_could_have_made() -> None:
    """The verdict's gap trims both ways: ``clutter_share(d, ...)`` of the beams in the first pose's
    favour, and ``clutter_share(-d, ...)`` (end points at the first pose) of those in the second's.
    Same twelve beams as above: one object takes the four beams by x ~3 (10 nats), a second beam 9
    (1 nat); the other way, beam 5 of each scan (end points at x = 1, together: one object, 4 nats)."""
    d = np.zeros((2, 6))
    d[:, [2, 3]] = 2.5
    d[:, 5] = -2.0
    d[0, 4] = 1.0
    x = np.array([[0.0, 5.0, 3.0, 3.2, 9.0, 1.0], [0.0, 7.0, 3.1, 3.3, 9.0, 1.0]])
    y = np.zeros((2, 6))
    assert clutter_share(d, x, y, 1, 0.8) == pytest.approx(10.0)
    assert clutter_share(d, x, y, 2, 0.8) == pytest.approx(11.0)
    assert clutter_share(-d, x, y, 2, 0.8) == pytest.approx(4.0)
    assert clutter_share(d, x, y, 0, 0.8) == 0.0
    trimmed = trimmed_gap(d, np.zeros_like(d), x, y, 2, 0.8)
    assert float(d.sum()) - clutter_share(d, x, y, 2, 0.8) == pytest.approx(trimmed)


def _drifted(steps: list[tuple[float, float, float]], scale: float, yaw_per_metre: float) -> list[np.ndarray]:
    """Odometry poses from true steps ``(dx, dy, dyaw)`` (robot frame): each step reported
    ``scale`` times as long, its turn off by ``yaw_per_metre`` per metre driven."""
    odom = [np.zeros(3)]
    for dx, dy, dyaw in steps:
        reported = (dx * scale, dy * scale, dyaw + yaw_per_metre * math.hypot(dx, dy))
        odom.append(compose(odom[-1][None, :], reported)[0])
    return odom


def _drifted_drive() -> tuple[GridFilter, list[np.ndarray], list[np.ndarray]]:
    """``(grid, truth, odometry)``: 2.75 m round the room's box, the odometry reporting 5 % more
    distance and 0.06 rad per metre of turn that did not happen."""
    occupancy = _room()
    grid = GridFilter(occupancy, FilterConfig(), reach=8.5)
    truth = [np.array([0.2, 1.2, -0.3])]
    steps = [(0.25, 0.0, 0.05 if n < 6 else 0.12) for n in range(11)]
    for step in steps:
        truth.append(compose(truth[-1][None, :], step)[0])
    odometry = _drifted(steps, 1.05, 0.06)
    for n, (pose, odom) in enumerate(zip(truth, odometry, strict=True)):
        grid.update(n, odom, _beams(occupancy, tuple(pose), grid.config.laser))
    return grid, truth, odometry


def test_remembered_scans_are_compared_with_the_odometry_drift_fitted() -> None:
    """A robot drives 2.75 m round the room's box while its odometry reports 5 % more distance
    and 0.06 rad per metre of turn that did not happen. Carried back along the odometry as
    measured, the true pose now lands 0.26 m and 9° off the truth at the oldest remembered scan;
    with the fitted drift within 2 cm and 1° at every one, and those scans fit it as well as
    the true poses."""
    grid, truth, odometry = _drifted_drive()
    assert len(grid._history) == len(truth)
    now = tuple(float(v) for v in truth[-1])
    measured = grid._carried_back(now, np.zeros((1, 6)))[0]
    fitted = grid._carried_back(now, grid._history_fit(now)[None, :])[0]
    off = relative(np.array(truth), measured)
    assert math.hypot(*off[0, :2]) > 0.2 and abs(off[0, 2]) > math.radians(8)
    error = relative(np.array(truth), fitted)
    assert np.hypot(error[:, 0], error[:, 1]).max() < 0.02
    assert np.abs(error[:, 2]).max() < math.radians(1.0)
    at_truth = grid._remembered_scores(np.array(truth)[None])[0].sum()
    assert grid._history_beams(now)[0].sum() >= at_truth - 5.0
    # the odometry as measured: the carry-back is the plain chain of relative poses
    chain = compose(np.repeat([now], len(odometry), axis=0), relative(odometry[-1], np.array(odometry)))
    assert np.allclose(measured, chain, atol=1e-9)


def test_the_remembered_fit_does_not_depend_on_where_it_starts() -> None:
    """Places are ranked by how well their fit explains the remembered scans, so the fit must
    reach its best wherever in the cell it starts: from poses up to 0.1 m and 1.7° off the truth
    now, every fit explains the drifted drive's remembered scans at least as well as the true
    poses (within 1 nat of 490). The grid search alone ended 35-220 nats short of that from
    these starts (issue 27's corridor seed 103 lost its verdict to such a shortfall)."""
    grid, truth, _ = _drifted_drive()
    at_truth = float(grid._remembered_scores(np.array(truth)[None])[0].sum())
    rng = np.random.default_rng(1)
    offsets = [np.zeros(3), np.array([0.1, -0.08, 0.02])] + [rng.uniform(-1, 1, 3) * [0.1, 0.1, 0.03] for _ in range(4)]
    for offset in offsets:
        start = tuple(float(v) for v in truth[-1] + offset)
        assert float(grid._history_beams(start)[0].sum()) >= at_truth - 1.0, offset


def test_beams_that_would_cross_a_wall_are_no_clutter() -> None:
    """``GridFilter._walled``: with the base at (1.5, 1.0) in the room (its top wall's face at
    y = 2.45), a beam ending at y = 2.0 stopped short in free space (an object may have stopped it),
    one ending at y = 2.8 would have crossed the wall (no object carries a beam through a wall), one
    ending 0.1 m past the wall's face is within the tolerance (a hit on the face); only beams in
    the first pose's favour are looked at; a negative tolerance exempts none."""
    occupancy = _room()
    grid = GridFilter(occupancy, FilterConfig(), reach=8.5)
    x = np.array([1.5, 1.5, 1.5, 1.5])
    y = np.array([2.0, 2.8, 2.55, 2.8])
    ox, oy = np.full(4, 1.5), np.full(4, 1.0)
    mine = np.array([0.0, 0.0, 0.0, -2.0])
    theirs = np.full(4, -1.0)
    walled = grid._walled(mine, theirs, ox, oy, x, y)
    assert walled is not None
    assert walled.tolist() == [False, True, False, False]
    off = GridFilter(occupancy, FilterConfig(wall_tolerance=-1.0), reach=8.5)
    assert off._walled(mine, theirs, ox, oy, x, y) is None


def test_config_is_checked() -> None:
    with pytest.raises(ValueError, match="threshold"):
        FilterConfig(threshold=1.5)
    with pytest.raises(ValueError, match="cell_size"):
        FilterConfig(cell_size=0.0)
    with pytest.raises(ValueError, match="clutter_objects"):
        FilterConfig(clutter_objects=-1)
    with pytest.raises(ValueError, match="odometry_drift"):
        FilterConfig(odometry_drift=(0.1, -0.1, 0.1))
    with pytest.raises(ValueError, match="remembered_sigma"):
        FilterConfig(remembered_sigma=0.0)
