"""Region observation models (issue 26): a state's reading probabilities are the average over its
cell × heading sector of a sensor with continuous noise.

The reference is a plain Monte Carlo over continuous poses: draw a pose uniformly in the state's
cell and heading sector, cast the beam one pose at a time, draw the reading from the continuous
noise model (Gaussian error, random and short components), bin it. The region model's row must
match the frequencies within the Monte Carlo's error plus the quadrature's (sub-samples are a
``k × k × m`` midpoint rule, not random draws).
"""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pydantic import ValidationError

from beliefloc import compile_model
from beliefloc.continuous.raycast import cast_rays
from beliefloc.semantic_map import SemanticMap, layout_of, regions

BINS = [0.4, 1.0, 1.8]


def _map(layout: list[str], scan: dict[str, Any], look: dict[str, Any] | None = None) -> dict[str, Any]:
    data: dict[str, Any] = {
        "name": "small",
        "grid": {"rows": len(layout), "cols": len(layout[0]), "headings": 4, "cell_size": 0.6},
        "layout": "\n".join(layout),
        "actions": {m: {} for m in ("forward", "backward", "rotate_cw", "rotate_ccw")},
        "sensors": {"scan": {"type": "scan", "bins": BINS, **scan}},
    }
    if look is not None:
        data["sensors"]["look"] = {"type": "look", "classes": ["box"], **look}
        data["landmarks"] = [{"class": "box", "cell": [0, 0]}]
    return data


def _monte_carlo_scan(
    smap: SemanticMap, state: int, n: int, sigma: float, random: float, short: float, rng: np.random.Generator
) -> np.ndarray:
    """Frequencies of the readings of ``state``'s region, one continuous pose at a time."""
    layout = layout_of(smap)
    image = regions.blocked_image(~layout.free, layout.cell_size)
    cell, h = divmod(state, layout.headings)
    r, c = divmod(int(layout.free_cells[cell]), layout.cols)
    s = layout.cell_size
    counts = np.zeros(len(BINS) + 1)
    edges = np.array([0.0, *BINS])
    for _ in range(n):
        x = (c + rng.uniform()) * s
        y = (layout.rows - r - 1 + rng.uniform()) * s
        yaw = math.pi / 2 - 2 * math.pi * h / layout.headings + rng.uniform(-0.5, 0.5) * 2 * math.pi / layout.headings
        i, j = image.pixel_of(x, y)
        if image.blocked[int(i), int(j)]:
            continue
        true = float(cast_rays(image, x, y, yaw, BINS[-1] + 4 * sigma + 1.0))
        u = rng.uniform()
        if u < random:
            reading = int(rng.integers(len(BINS) + 1))
        elif u < random + short:
            limit = min(true, BINS[-1])
            z = rng.uniform(0.0, limit)
            reading = int(np.searchsorted(BINS, z, side="left"))
        else:
            z = true + rng.normal(0.0, sigma) if math.isfinite(true) else math.inf
            reading = int(np.searchsorted(edges[1:], z, side="left")) if z > 0 else 0
        counts[reading] += 1
    return counts / counts.sum()


LAYOUTS = st.lists(st.text(alphabet="..#", min_size=4, max_size=4), min_size=3, max_size=4).filter(
    lambda rows: sum(row.count(".") for row in rows) >= 2
)


@settings(max_examples=12, deadline=None)
@given(layout=LAYOUTS, pick=st.integers(0, 10_000), seed=st.integers(0, 2**31))
def test_region_scan_rows_match_a_monte_carlo_over_continuous_poses(layout: list[str], pick: int, seed: int) -> None:
    sigma, random, short = 0.05, 0.05, 0.1
    scan = {"sub_samples": 7, "yaw_samples": 9, "sigma": sigma, "random": random, "short": short}
    smap = SemanticMap.model_validate(_map(layout, scan))
    model = compile_model(smap)
    part = model.action("scan").observation.parts[0]
    state = pick % model.n_states
    row = part.confusion[part.truth[state]]
    mc = _monte_carlo_scan(smap, state, 3000, sigma, random, short, np.random.default_rng(seed))
    # 3,000 draws: a frequency's standard error is at most 0.009; the 7 × 7 × 9 midpoint rule and
    # the rows' rounding to 1/200 add a few hundredths where a wall edge crosses the region
    assert np.abs(row - mc).sum() <= 0.12, (layout, state, row, mc)
    assert (row > 0).all()  # with random readings nothing zeroes a state


def test_the_exact_settings_are_the_papers_model() -> None:
    """``sub_samples: 1`` and σ 0 give the same truth and confusion as a map without the fields."""
    layout = ["....", ".#..", "...."]
    plain = compile_model(SemanticMap.model_validate(_map(layout, {}, {"fov": 90, "range": 2.0})))
    exact_fields = {"sub_samples": 1, "yaw_samples": 1, "sigma": 0.0, "random": 0.0, "short": 0.0}
    look_fields = {"fov": 90, "range": 2.0, "sub_samples": 1, "yaw_samples": 1, "fov_edge": 0.0, "range_edge": 0.0}
    explicit = compile_model(SemanticMap.model_validate(_map(layout, exact_fields, look_fields)))
    for a, b in zip(plain.actions, explicit.actions, strict=True):
        for p, q in zip(a.observation.parts, b.observation.parts, strict=True):
            assert np.array_equal(p.confusion[p.truth], q.confusion[q.truth])


def test_an_exact_region_with_noise_matches_the_binned_gaussian() -> None:
    """One sub-pose and σ > 0: the row is the Gaussian's mass between the bin edges at the centre's range."""
    layout = ["....", "...."]
    smap = SemanticMap.model_validate(_map(layout, {"sigma": 0.1}))
    model = compile_model(smap)
    part = model.action("scan").observation.parts[0]
    east_from_00 = 0 * 4 + 1  # cell (0, 0) facing east: the grid's edge 3.5 cells away = 2.1 m: no wall
    north_from_00 = 0  # facing north: the edge half a cell away, 0.3 m
    assert part.confusion[part.truth[east_from_00]][-1] == pytest.approx(1.0, abs=0.01)
    row = part.confusion[part.truth[north_from_00]]
    from scipy.special import ndtr

    expect = np.array([ndtr(1.0), ndtr(7.0) - ndtr(1.0), 0.0, 0.0])
    assert row == pytest.approx(expect, abs=0.006)


def test_look_detection_fades_at_the_edge_of_the_field_of_view() -> None:
    """A soft edge: a landmark at the fov's edge is seen about half the time."""
    spec = regions.detection_probability(np.array([1.0, 1.0, 1.0]), np.array([0.0, 45.0, 60.0]), 90.0, 5.0, 3.0, 0.2)
    assert spec[0] == pytest.approx(1.0) and spec[1] == pytest.approx(0.5) and spec[2] < 1e-6
    step = regions.detection_probability(np.array([1.0, 6.0]), np.array([44.0, 0.0]), 90.0, 5.0, 0.0, 0.0)
    assert list(step) == [1.0, 0.0]


def test_a_landmark_in_the_robots_own_cell_is_not_always_seen() -> None:
    """The region model settles the protocol question: the detector does not see behind itself."""
    layout = ["...", "..."]
    look = {"fov": 60, "range": 3.0, "sub_samples": 3, "yaw_samples": 3}
    model = compile_model(SemanticMap.model_validate(_map(layout, {}, look)))
    part = model.action("look").observation.parts[0]
    seen = part.confusion[part.truth[:4], 1]  # the four headings of cell (0, 0), where the box is
    assert seen.min() < 0.9 and seen.max() > 0.0


def test_noise_parameters_out_of_range_are_rejected() -> None:
    with pytest.raises(ValidationError, match="random \\+ short"):
        SemanticMap.model_validate(_map(["..", ".."], {"random": 0.7, "short": 0.5}))
    with pytest.raises(ValidationError):
        SemanticMap.model_validate(_map(["..", ".."], {"sub_samples": 0}))
    with pytest.raises(ValidationError):
        SemanticMap.model_validate(_map(["..", ".."], {"sigma": -0.1}))


def _region_setup(layout: list[str], sub: int, yaw: int) -> tuple[Any, Any, regions.RegionSpec]:
    smap = SemanticMap.model_validate(_map(layout, {}))
    grid = layout_of(smap)
    return grid, regions.blocked_image(~grid.free, grid.cell_size), regions.RegionSpec(sub, yaw)


@settings(max_examples=10, deadline=None)
@given(layout=LAYOUTS, sub=st.integers(1, 4), yaw=st.integers(1, 3))
def test_region_scans_are_the_average_over_every_sub_pose_cast_one_at_a_time(
    layout: list[str], sub: int, yaw: int
) -> None:
    """The fast path (one ray per position and direction, shared by beams and headings, leaping
    through open space) against the plain one: every sub-pose's beam cast step by step, its reading
    distribution, averaged with the sub-poses' weights."""
    from beliefloc.continuous import raycast

    grid, image, spec = _region_setup(layout, sub, yaw)
    bins, sigma, random, short = np.array(BINS), 0.05, 0.05, 0.1
    beams = [90.0, 0.0, -90.0, 30.0]
    saved = raycast.LEAP_FROM
    try:
        raycast.LEAP_FROM = 1
        fast = regions.region_scans(grid, image, spec, beams, bins, sigma, random, short)
        raycast.LEAP_FROM = 10**9
        poses, weight = regions.sub_poses(grid, image, spec)
        reach = BINS[-1] + 4 * sigma
        for beam, got in zip(beams, fast, strict=True):
            ranges = cast_rays(image, poses[..., 0], poses[..., 1], poses[..., 2] + math.radians(beam), reach)
            ranges[ranges > reach] = np.inf
            plain = np.einsum("nk,nkv->nv", weight, regions.scan_distribution(ranges, bins, sigma, random, short))
            np.testing.assert_allclose(got, plain, atol=1e-12)
            assert np.allclose(got.sum(axis=1), 1.0)
    finally:
        raycast.LEAP_FROM = saved


def test_scan_distribution_is_the_gaussian_between_the_bin_edges_mixed_with_random_and_short() -> None:
    """One range, written out: the Gaussian's mass per bin, the short part uniform below the range."""
    from scipy.special import ndtr

    r, sigma, random, short = 0.9, 0.1, 0.05, 0.1
    edges = [-math.inf, *BINS, math.inf]
    gauss = np.array([ndtr((hi - r) / sigma) - ndtr((lo - r) / sigma) for lo, hi in itertools.pairwise(edges)])
    below = np.array([0.4, 0.5, 0.0, 0.0]) / 0.9  # uniform over [0, 0.9): 0-0.4, 0.4-0.9
    expect = (1 - random - short) * gauss + short * below + random / 4
    got = regions.scan_distribution(np.array([[r, math.inf]]), np.array(BINS), sigma, random, short)
    np.testing.assert_allclose(got[0, 0], expect, atol=1e-12)
    no_wall = (1 - random - short) * np.array([0, 0, 0, 1.0]) + short * np.array([0.4, 0.6, 0.8, 0]) / 1.8 + random / 4
    np.testing.assert_allclose(got[0, 1], no_wall, atol=1e-12)


@settings(max_examples=10, deadline=None)
@given(layout=LAYOUTS, sub=st.integers(1, 3), yaw=st.integers(1, 3), bins=st.booleans(), occlusion=st.booleans())
def test_region_look_shared_per_position_equals_look_distribution_at_every_sub_pose(
    layout: list[str], sub: int, yaw: int, bins: bool, occlusion: bool
) -> None:
    """Distances, bearings and lines of sight computed once per position give what the per-pose
    :func:`regions.look_distribution` gives at each sub-pose, averaged."""
    grid, image, spec = _region_setup(layout, sub, yaw)
    free = np.argwhere(grid.free)
    landmarks = (free[[0, -1]][:, ::-1] + 0.5) * grid.cell_size  # (col, row) -> x, y of two free cells
    landmarks[:, 1] = grid.rows * grid.cell_size - landmarks[:, 1]
    angle_bins = np.array([20.0, 45.0]) if bins else None
    args = (landmarks, 120.0, 1.5, occlusion, angle_bins, 5.0, 0.2)
    shared = regions.region_look(grid, image, spec, *args)
    poses, weight = regions.sub_poses(grid, image, spec)
    per_pose = regions.look_distribution(image, poses, weight > 0, landmarks, False, *args[1:])
    np.testing.assert_allclose(shared, np.einsum("nk,nkv->nv", weight, per_pose), atol=1e-12)
    assert np.allclose(shared.sum(axis=1), 1.0)


@pytest.mark.parametrize("n_values", [2, 5, 12])
def test_quantised_rows_by_key_are_those_of_comparing_every_rounded_row(n_values: int) -> None:
    rng = np.random.default_rng(n_values)
    dist = rng.dirichlet(np.full(n_values, 0.3), 5000)
    dist[::7] = np.round(dist[::7], 2)
    dist[::5] = dist[3]  # many rows alike
    dist[::11, 0] = 1e-4  # under the floor
    dist[::13, 1] = 0.0
    dist[:, -1] += 1e-3
    dist /= dist.sum(axis=1, keepdims=True)
    q = np.round(dist / regions.STEP) * regions.STEP
    q = np.where((dist > 1e-12) & (q < regions.FLOOR), regions.FLOOR, q)
    q /= q.sum(axis=1, keepdims=True)
    plain_rows, plain_index = np.unique(np.round(q, 12), axis=0, return_inverse=True)
    rows, index = regions.quantised_rows(dist)
    np.testing.assert_array_equal(rows, plain_rows / plain_rows.sum(axis=1, keepdims=True))
    np.testing.assert_array_equal(index, plain_index.ravel())
    assert len(rows) < len(dist)


@pytest.mark.parametrize("range_edge", [0.0, 0.02])
def test_positions_beyond_the_range_fade_are_skipped_without_changing_a_row(range_edge: float) -> None:
    """Beyond ``range + 40 range_edge`` (a step edge: beyond ``range``) every detection is exactly 0;
    skipping those positions gives the rows of computing them."""
    grid, image, spec = _region_setup(["....#...", "..#.....", "........"], 3, 3)
    landmarks = np.array([[0.3, 1.5], [4.5, 0.3]])
    args = (landmarks, 90.0, 1.0, True, np.array([20.0, 45.0]), 5.0, range_edge)
    skipping = regions.region_look(grid, image, spec, *args)
    saved = regions._range_cutoff
    try:
        regions._range_cutoff = lambda view_range, edge: math.inf  # type: ignore[assignment]
        everything = regions.region_look(grid, image, spec, *args)
    finally:
        regions._range_cutoff = saved
    np.testing.assert_allclose(skipping, everything, atol=1e-12)
    poses, _ = regions.sub_poses(grid, image, spec)
    d = np.hypot(poses[..., :1] - landmarks[:, 0], poses[..., 1:2] - landmarks[:, 1])
    assert (d > regions._range_cutoff(1.0, range_edge)).all(axis=-1).any()  # some positions were skipped


def test_a_few_cells_at_a_time_give_the_rows_of_all_at_once() -> None:
    """Region scans and looks go through the cells in chunks (bounded memory); the chunking changes
    no number."""
    grid, image, spec = _region_setup(["....#...", "..#.....", "........"], 3, 3)
    landmarks = np.array([[0.3, 1.5], [4.5, 0.3]])
    look_args = (landmarks, 90.0, 2.0, True, np.array([20.0, 45.0]), 5.0, 0.2)
    scan_args = ([0.0, 90.0], np.array(BINS), 0.05, 0.05, 0.1)
    whole = regions.region_scans(grid, image, spec, *scan_args), regions.region_look(grid, image, spec, *look_args)
    saved = regions._CHUNK
    try:
        regions._CHUNK = 500  # 2 cells of a scan, 1 of a look
        chunked = (
            regions.region_scans(grid, image, spec, *scan_args),
            regions.region_look(grid, image, spec, *look_args),
        )
    finally:
        regions._CHUNK = saved
    for a, b in zip([*whole[0], whole[1]], [*chunked[0], chunked[1]], strict=True):
        np.testing.assert_allclose(a, b, atol=1e-12)
