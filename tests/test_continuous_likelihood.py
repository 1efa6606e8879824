"""The likelihood field: every state's score against a plain loop, REP 117 readings, the mixture's
floor, and the truth's state scoring best."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import ndimage

from beliefloc.continuous.image import OccupancyImage
from beliefloc.continuous.likelihood_field import (
    CellWindow,
    LaserModel,
    LikelihoodField,
    Scan,
    log_hit_mixture,
    select_beams,
)
from beliefloc.continuous.motion import grid_yaws
from beliefloc.continuous.raycast import cast_rays
from beliefloc.model import MapFrame


def _room() -> OccupancyImage:
    """A 3 m x 2 m room at 0.05 m, walls one pixel thick, a box and a pillar that break its symmetry."""
    blocked = np.zeros((40, 60), dtype=bool)
    blocked[0, :] = blocked[-1, :] = blocked[:, 0] = blocked[:, -1] = True
    blocked[5:12, 8:20] = True
    blocked[28:31, 44:47] = True
    return OccupancyImage(blocked, 0.05, MapFrame(1.0, -2.0, 0.0))


def _window(image: OccupancyImage, cell: float) -> CellWindow:
    rows = math.ceil(image.height * image.resolution / cell)
    cols = math.ceil(image.width * image.resolution / cell)
    return CellWindow(cell, rows, 1, 1, rows - 2, cols - 2)


def test_every_state_matches_a_plain_loop() -> None:
    """The sums of shifted phase images equal, state by state, the end points' field values
    computed one by one (the same lattice rounding of each beam's offset)."""
    image = _room()
    window = _window(image, 0.1)
    model = LaserModel(max_beams=7, region_sigma=False)
    field = LikelihoodField(image, window, model, reach=2.0, headings=8, sub_poses=False)
    rng = np.random.default_rng(0)
    scan = Scan(-math.pi, 2 * math.pi / 7, rng.uniform(0.2, 1.5, 7), 0.1, 8.0)
    beams = select_beams(scan, model, (0.05, 0.0, math.pi / 2))
    yaws = grid_yaws(8)
    fast = field.scan_log_likelihood(beams, yaws)
    step = field.step
    for k in range(8):
        c, s = math.cos(yaws[k]), math.sin(yaws[k])
        ex, ey = c * beams.x - s * beams.y, s * beams.x + c * beams.y
        dq, dp = np.rint(ex / step), np.rint(-ey / step)
        for r in range(window.rows):
            for col in range(window.cols):
                gx = (window.col0 + col + 0.5) * window.cell_size + dq * step
                gy = (window.grid_rows - window.row0 - r - 0.5) * window.cell_size - dp * step
                i = image.height - 0.5 - gy / image.resolution
                j = gx / image.resolution - 0.5
                padded = np.pad(field.distance, 2, constant_values=model.likelihood_max_dist)
                d = ndimage.map_coordinates(padded, [i + 2, j + 2], order=1, mode="nearest")
                expected = float(log_hit_mixture(d, model.sigma_hit, model, beams.range_max).sum())
                assert fast[k, r, col] == pytest.approx(expected, abs=1e-3)


def test_region_of_a_subset_is_the_same_numbers() -> None:
    image = _room()
    window = _window(image, 0.1)
    field = LikelihoodField(image, window, LaserModel(), reach=3.0, headings=12)
    scan = Scan(-math.pi, math.pi / 90, np.linspace(0.5, 2.0, 180), 0.1, 8.0)
    beams = select_beams(scan, LaserModel())
    full = field.scan_log_likelihood(beams, grid_yaws(12))
    part = field.scan_log_likelihood(beams, grid_yaws(12), region=(3, 9, 5, 20))
    assert part == pytest.approx(full[:, 3:9, 5:20])
    active = np.zeros(12, dtype=bool)
    active[[2, 7]] = True
    some = field.scan_log_likelihood(beams, grid_yaws(12), active=active)
    assert some[active] == pytest.approx(full[active])
    assert np.all(some[~active] == 0.0)


def test_the_true_pose_scores_best() -> None:
    image = _room()
    window = _window(image, 0.1)
    field = LikelihoodField(image, window, LaserModel(), reach=4.0, headings=36)
    laser_angles = np.linspace(-math.pi, math.pi, 360, endpoint=False)
    truth = (2.13, -1.32, 0.7)
    mount = (0.0, 0.0, math.pi / 2)
    ranges = cast_rays(image, truth[0], truth[1], truth[2] + mount[2] + laser_angles, 4.0)
    scan = Scan(-math.pi, laser_angles[1] - laser_angles[0], ranges, 0.1, 4.0)
    beams = select_beams(scan, LaserModel(), mount)
    ll = field.scan_log_likelihood(beams, grid_yaws(36))
    k, r, c = np.unravel_index(int(np.argmax(ll)), ll.shape)
    gx = (window.col0 + c + 0.5) * 0.1
    gy = (window.grid_rows - window.row0 - r - 0.5) * 0.1
    x, y = image.origin.to_map(gx, gy)
    assert math.hypot(float(x) - truth[0], float(y) - truth[1]) < 0.1
    assert abs(math.remainder(grid_yaws(36)[k] - truth[2], 2 * math.pi)) <= math.radians(10)
    # continuous poses: the truth beats a pose 10 cm away
    scores = field.pose_log_likelihood(np.array([truth, (truth[0] + 0.1, truth[1], truth[2])]), beams)
    assert scores[0] > scores[1]


def test_an_unexplained_beam_costs_a_bounded_amount() -> None:
    model = LaserModel()
    best = float(log_hit_mixture(np.array([0.0]), model.sigma_hit, model, 12.0)[0])
    worst = float(log_hit_mixture(np.array([2.0]), model.sigma_hit, model, 12.0)[0])
    assert np.isfinite(worst)
    assert best - worst == pytest.approx(math.log((model.z_hit + model.z_rand / 12) / (model.z_rand / 12)), rel=1e-4)


def test_rep_117_readings_and_the_beam_subsample() -> None:
    ranges = np.array([1.0, math.inf, -math.inf, math.nan, 0.05, 12.0, 13.0, 2.0] * 20)
    scan = Scan(0.0, 0.01, ranges, 0.1, 12.0)
    beams = select_beams(scan, LaserModel(max_beams=1000))
    assert beams.count == 40  # only the 1.0 and 2.0 readings
    assert set(np.round(beams.ranges, 6)) == {1.0, 2.0}
    few = select_beams(scan, LaserModel(max_beams=10))
    assert few.count == 10


def test_a_clockwise_scan_is_the_same_beams() -> None:
    rng = np.random.default_rng(3)
    ranges = rng.uniform(0.3, 5.0, 100)
    forward = Scan(-1.0, 0.02, ranges, 0.1, 12.0)
    backward = Scan(-1.0 + 0.02 * 99, -0.02, ranges[::-1], 0.1, 12.0)
    model = LaserModel(max_beams=100)
    a = select_beams(forward, model, (0.1, 0.0, 0.5))
    b = select_beams(backward, model, (0.1, 0.0, 0.5))
    order_a, order_b = np.lexsort((a.y, a.x)), np.lexsort((b.y, b.x))
    assert a.x[order_a] == pytest.approx(b.x[order_b])
    assert a.y[order_a] == pytest.approx(b.y[order_b])


def test_a_scan_from_plain_values() -> None:
    scan = Scan.from_values(-1.0, 0.5, [1.0, None, 2.0], 0.1, 5.0)
    assert np.isposinf(scan.ranges[1])
    with pytest.raises(ValueError, match="angle_increment"):
        Scan.from_values(-1.0, 0.0, [1.0], 0.1, 5.0)


def test_de_skew_rotates_each_beam_by_its_turn() -> None:
    scan = Scan(0.0, 1e-9, np.array([1.0, 1.0]), 0.1, 5.0)
    beams = select_beams(scan, LaserModel(), (0.0, 0.0, 0.0), yaw_offsets=np.array([0.0, math.pi / 2]))
    assert (beams.x[0], beams.y[0]) == pytest.approx((1.0, 0.0))
    assert (beams.x[1], beams.y[1]) == pytest.approx((0.0, 1.0), abs=1e-6)


def test_model_parameters_are_checked() -> None:
    with pytest.raises(ValueError, match="z_rand"):
        LaserModel(z_rand=0.0)
    with pytest.raises(ValueError, match="sigma_hit"):
        LaserModel(sigma_hit=-1.0)


def test_one_scan_from_plain_values_scores_poses() -> None:
    from beliefloc.continuous.likelihood_field import score_scan

    image = _room()
    field = LikelihoodField(image, _window(image, 0.1), LaserModel(), reach=4.0, headings=8)
    truth = (2.13, -1.32, 0.7)
    ranges = cast_rays(image, truth[0], truth[1], truth[2] + np.linspace(-math.pi, math.pi, 90, endpoint=False), 4.0)
    values = [None if math.isinf(r) else float(r) for r in ranges]
    scores = score_scan(field, np.array([truth, (2.4, -1.0, 0.7)]), -math.pi, 2 * math.pi / 90, values, 0.1, 4.0)
    assert scores.shape == (2,) and scores[0] > scores[1]


def test_the_nearest_pixel_reading_is_the_bilinear_one_at_pixel_centres() -> None:
    """``nearest_log_likelihood`` reads the pixel holding each point: at pixel centres (and off the
    image, the cap) it equals ``point_log_likelihood``; a point within a pixel reads its centre."""
    image = _room()
    field = LikelihoodField(image, _window(image, 0.1), LaserModel(), reach=2.0, headings=8, sub_poses=False)
    rng = np.random.default_rng(1)
    u = rng.integers(-3, image.width + 3, 200) + 0.5
    v = rng.integers(-3, image.height + 3, 200) + 0.5
    x, y = image.to_map(u, v)
    exact = field.point_log_likelihood(x, y, 0.1, 12.0)
    assert np.allclose(field.nearest_log_likelihood(x, y, 0.1, 12.0), exact, atol=1e-5)
    nudged_x, nudged_y = image.to_map(u + rng.uniform(-0.45, 0.45, 200), v + rng.uniform(-0.45, 0.45, 200))
    assert np.allclose(field.nearest_log_likelihood(nudged_x, nudged_y, 0.1, 12.0), exact, atol=1e-5)
