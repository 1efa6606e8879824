"""The lattice's whole-scan update by shifted field images (issue 27: a laser update over 10^5 poses
in milliseconds) scores every pose as the per-pose lookup does: the same pixels, the same mixture,
the same EFFECTIVE_BEAMS weighting; only each beam's sigma is rounded to a band."""

from __future__ import annotations

import math

import numpy as np
import pytest

from beliefloc.continuous.lattice_scan import BAND_RATIO, EFFECTIVE_BEAMS, LatticeScanModel
from beliefloc.continuous.likelihood_field import Scan, log_hit_mixture, select_beams
from beliefloc.continuous.pose_lattice import PoseLattice
from beliefloc.model import GridLayout
from beliefloc.semantic_map.regions import blocked_image


def _lattice(cell: float, pixel: float, k: int, m: int = 3, headings: int = 4, states_cols: int = 6) -> PoseLattice:
    """A small room (5 x 6 cells of ``cell`` metres, drawn at ``pixel`` metres) with a wall stub and
    a pillar, one cell blocked and the states in the first ``states_cols`` columns: a lattice of
    ``k x k`` positions per cell and ``m`` yaws a sector."""
    rows, cols = 5, 6
    per = round(cell / pixel)
    blocked = np.zeros((rows * per, cols * per), dtype=bool)
    blocked[: 2 * per, 3 * per : 3 * per + max(1, per // 4)] = True  # a wall stub from the top
    blocked[3 * per + per // 3 : 4 * per - per // 3, per + per // 3 : 2 * per - per // 3] = True  # a pillar
    free = np.ones((rows, cols), dtype=bool)
    free[0, 0] = False
    free[:, states_cols:] = False
    layout = GridLayout(rows, cols, headings, cell, free)
    return PoseLattice(layout, blocked_image(blocked, pixel), k, m)


def _scan(rng: np.random.Generator, n: int, *, aligned: bool = False) -> Scan:
    """``n`` readings over a full turn from a random start angle (``aligned``: from -pi, beams along
    the lattice's axes), a fifth no return (``None``), some below ``range_min``, one -inf and one NaN."""
    ranges: list[float | None] = [float(r) for r in rng.uniform(0.02, 4.5, n)]
    for i in rng.choice(n, n // 5, replace=False).tolist():
        ranges[i] = None
    for i in rng.choice(n, n // 10, replace=False).tolist():
        ranges[i] = float(rng.uniform(0.0, 0.1))  # below range_min
    ranges[int(rng.integers(n))] = -math.inf
    ranges[int(rng.integers(n))] = math.nan
    start = -math.pi if aligned else float(rng.uniform(-math.pi, math.pi))
    return Scan.from_values(start, 2 * math.pi / n, ranges, 0.1, 4.0)


def _mount(rng: np.random.Generator) -> tuple[float, float, float]:
    return float(rng.uniform(-0.1, 0.1)), float(rng.uniform(-0.1, 0.1)), float(rng.uniform(-math.pi, math.pi))


@pytest.mark.parametrize(
    ("cell", "pixel", "k", "groups"),
    [
        (0.4, 0.05, 4, 1),  # 0.1 m spacing, 0.025 m field pixels: 4 pixels a step
        (0.25, 0.05, 3, 1),  # 1/12 m spacing: the field is split to 1/120 m, 10 pixels a step
        (1.0, 1.0, 7, 7),  # 1/7 m spacing on 1/40 m pixels: 7 steps are 40 pixels, 49 offset groups
    ],
)
@pytest.mark.parametrize("seed", range(3))
def test_the_fast_update_scores_every_pose_as_the_per_pose_lookup(
    cell: float, pixel: float, k: int, groups: int, seed: int
) -> None:
    model = LatticeScanModel(_lattice(cell, pixel, k))
    assert model.offset_groups == groups
    rng = np.random.default_rng([27, seed])
    for n in (360, 40):  # more than max_beams (60): evenly spread; fewer: every valid reading
        scan, mount = _scan(rng, n), _mount(rng)
        fast = model.log_likelihood(scan, mount)
        same = model.log_likelihood_per_pose(scan, mount, banded=True)
        assert fast.shape == (model.lattice.n_poses,)
        assert np.ptp(same) > 1.0  # the scan tells poses apart
        np.testing.assert_allclose(fast, same, rtol=0, atol=2e-4)


@pytest.mark.parametrize("seed", range(3))
def test_beams_along_the_lattice_axes_differ_only_where_an_end_point_rounds_across_a_pixel_edge(seed: int) -> None:
    """Lattice positions lie on pixel edges (an even number of pixels a step): a beam along an axis
    ends on an edge, where either side is as right (rounding decides, in either computation): some
    poses differ, by a few hundredths of a nat (measured: up to 7 % of the poses, 0.05 nats)."""
    model = LatticeScanModel(_lattice(0.4, 0.05, 4))
    rng = np.random.default_rng([28, seed])
    scan = _scan(rng, 360, aligned=True)
    fast = model.log_likelihood(scan)
    same = model.log_likelihood_per_pose(scan, banded=True)
    differ = np.abs(fast - same) > 2e-4
    assert differ.mean() < 0.15
    assert np.abs(fast - same).max() < 0.1


@pytest.mark.parametrize("seed", range(4))
def test_sigma_bands_move_each_pose_by_less_than_their_bound_from_the_exact_sigmas(seed: int) -> None:
    """Against today's per-pose computation with every beam's exact sigma: each beam's term moves by
    at most the largest change of its mixture between its sigma and its band's (over every distance
    the field holds), and the scan by their sum at the EFFECTIVE_BEAMS weight."""
    model = LatticeScanModel(_lattice(0.4, 0.05, 4))
    rng = np.random.default_rng([29, seed])
    scan, mount = _scan(rng, 360), _mount(rng)
    fast = model.log_likelihood(scan, mount)
    exact = model.log_likelihood_per_pose(scan, mount)
    beams = select_beams(scan, model.laser, mount)
    sigma = model.beam_sigmas(beams.ranges)
    band = model.band_sigmas(beams.ranges)[1]
    assert np.all(np.abs(np.log(band / sigma)) <= math.log(BAND_RATIO) / 2 + 1e-9)
    d = np.linspace(0.0, model.laser.likelihood_max_dist, 4001)
    bound = sum(
        float(np.abs(log_hit_mixture(d, s, model.laser, 4.0) - log_hit_mixture(d, b, model.laser, 4.0)).max())
        for s, b in zip(sigma.tolist(), band.tolist(), strict=True)
    ) * min(1.0, EFFECTIVE_BEAMS / beams.count)
    difference = np.abs(fast - exact)
    assert difference.max() <= bound + 1e-3
    assert difference.mean() < 0.25 * bound  # the bound is the worst case: most poses are far under it
    assert int(np.argmax(fast)) in np.flatnonzero(exact >= exact.max() - bound)


def test_a_scan_with_no_valid_reading_scores_zero_everywhere() -> None:
    model = LatticeScanModel(_lattice(0.4, 0.05, 4))
    scan = Scan.from_values(0.0, 0.1, [None, 0.05, -math.inf, math.nan, 4.0, 7.0], 0.1, 4.0)
    assert not model.log_likelihood(scan).any()
    assert not model.log_likelihood_per_pose(scan).any()


def test_a_lattice_whose_spacing_no_pixel_count_makes_whole_is_scored_pose_by_pose() -> None:
    model = LatticeScanModel(_lattice(1.0, 1.0, 13))  # 40/13 pixels a step: no q <= 12 makes it whole
    assert model.offset_groups is None
    rng = np.random.default_rng(30)
    scan = _scan(rng, 90)
    np.testing.assert_array_equal(model.log_likelihood(scan), model.log_likelihood_per_pose(scan))


def test_band_images_are_built_once_and_reused_by_the_next_scan() -> None:
    model = LatticeScanModel(_lattice(0.4, 0.05, 4))
    rng = np.random.default_rng(31)
    scan = _scan(rng, 360)
    model.log_likelihood(scan)
    built = dict(model._bands)
    model.log_likelihood(scan)
    assert model._bands.keys() == built.keys() and all(model._bands[k] is v for k, v in built.items())


def test_a_short_laser_reads_only_the_field_around_the_lattice_and_still_scores_as_the_per_pose_lookup() -> None:
    """A 0.6 m laser in a 2.4 m room, the states in its left third: the mixture images cover the
    lattice's positions and 0.6 m around them, not the whole field, and every pose scores as the
    per-pose lookup."""
    model = LatticeScanModel(_lattice(0.4, 0.05, 4, states_cols=2))
    rng = np.random.default_rng(32)
    ranges = rng.uniform(0.05, 0.7, 360)
    ranges[rng.random(360) < 0.2] = np.inf
    scan = Scan(float(rng.uniform(-math.pi, math.pi)), 2 * math.pi / 360, ranges, 0.1, 0.6)
    mount = (0.05, -0.02, 1.0)
    fast = model.log_likelihood(scan, mount)
    (key,) = {key[2] for key in model._bands}
    i0, i1, j0, j1 = key
    assert (i1 - i0) * (j1 - j0) < 0.9 * model.distance.size
    np.testing.assert_allclose(fast, model.log_likelihood_per_pose(scan, mount, banded=True), rtol=0, atol=2e-4)
