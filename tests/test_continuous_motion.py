"""The odometry motion model: Table 5.6 sampled, and the grid prediction against it."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from beliefloc.continuous.motion import (
    OdometryNoise,
    compose,
    grid_yaws,
    odometry_parts,
    predict_grid,
    region_kernel,
    relative,
    sample_odometry,
)
from beliefloc.model import GridLayout, MapFrame

NOISELESS = OdometryNoise(0.0, 0.0, 0.0, 0.0)
_pose = st.tuples(
    st.floats(-50, 50, allow_nan=False), st.floats(-50, 50, allow_nan=False), st.floats(-math.pi, math.pi)
)


@settings(max_examples=50, deadline=None)
@given(start=_pose, end=_pose)
def test_relative_and_compose_are_inverse(start: tuple[float, float, float], end: tuple[float, float, float]) -> None:
    delta = relative(np.array(start), np.array(end))
    back = compose(np.array([start]), delta)[0]
    assert back[:2] == pytest.approx(end[:2], abs=1e-9)
    assert math.remainder(back[2] - end[2], 2 * math.pi) == pytest.approx(0.0, abs=1e-9)


def test_noiseless_sample_is_the_composition() -> None:
    rng = np.random.default_rng(0)
    poses = np.array([[1.0, 2.0, 0.3], [-4.0, 0.5, -2.0], [0.0, 0.0, math.pi]])
    delta = (0.4, 0.1, 0.25)
    assert sample_odometry(poses, delta, NOISELESS, rng) == pytest.approx(compose(poses, delta), abs=1e-12)


def test_sampled_spread_is_table_5_6() -> None:
    """Over many draws, translation and the two turns have Table 5.6's standard deviations."""
    noise = OdometryNoise(0.1, 0.05, 0.2, 0.02)
    delta = (0.5, 0.0, 0.4)
    parts = odometry_parts(delta, noise)
    assert parts.sd_trans == pytest.approx(math.sqrt(0.2 * 0.25 + 0.02 * 0.4**2))
    assert parts.sd_rot1 == pytest.approx(math.sqrt(0.05 * 0.25))
    samples = sample_odometry(np.zeros((40_000, 3)), delta, noise, np.random.default_rng(1))
    trans = np.hypot(samples[:, 0], samples[:, 1])
    assert trans.mean() == pytest.approx(0.5, abs=0.01)
    assert trans.std() == pytest.approx(parts.sd_trans, rel=0.03)
    total_turn = np.hypot(parts.sd_rot1, parts.sd_rot2)
    assert samples[:, 2].mean() == pytest.approx(0.4, abs=0.01)
    assert samples[:, 2].std() == pytest.approx(total_turn, rel=0.03)


def test_driving_backwards_is_not_a_noisy_half_turn() -> None:
    """AMCL's reduced angle: rot1 = pi (reversing) contributes no rotation noise."""
    parts = odometry_parts((-0.3, 0.0, 0.0), OdometryNoise(1.0, 0.0, 0.0, 0.0))
    assert abs(parts.rot1) == pytest.approx(math.pi)
    assert parts.sd_rot1 == pytest.approx(0.0, abs=1e-12)


@settings(max_examples=40, deadline=None)
@given(shift=st.floats(-5, 5), sigma=st.floats(0, 3))
def test_region_kernel_is_a_distribution_centred_on_the_shift(shift: float, sigma: float) -> None:
    first, weights = region_kernel(shift, sigma)
    assert weights.sum() == pytest.approx(1.0)
    assert np.all(weights >= 0)
    mean = float(np.dot(first + np.arange(weights.size), weights))
    assert mean == pytest.approx(shift, abs=0.02)


def test_region_kernel_splits_a_fractional_shift_linearly() -> None:
    first, weights = region_kernel(0.3, 0.0)
    assert first <= 0
    assert weights[-first] == pytest.approx(0.7, abs=0.02)
    assert weights[-first + 1] == pytest.approx(0.3, abs=0.02)


def _centroid(layer: np.ndarray) -> tuple[float, float]:
    r, c = np.mgrid[0 : layer.shape[0], 0 : layer.shape[1]]
    total = layer.sum()
    return float((r * layer).sum() / total), float((c * layer).sum() / total)


@pytest.mark.parametrize("headings", [4, 8, 36])
def test_grid_prediction_moves_each_heading_by_its_own_displacement(headings: int) -> None:
    """Mass at one cell of heading k moves by R(yaw_k)(dx, dy) / cell (rows down = -y), then turns
    by dyaw in heading steps -- the mean of the continuous motion."""
    cell = 0.1
    yaws = grid_yaws(headings)
    delta = (0.37, 0.05, 2 * math.pi / headings)
    for k in range(headings):
        belief = np.zeros((headings, 41, 41))
        belief[k, 20, 20] = 1.0
        out = predict_grid(belief, yaws, cell, delta, OdometryNoise(0.01, 0.01, 0.01, 0.01))
        assert out.sum() == pytest.approx(1.0)
        layer_mass = out.sum(axis=(1, 2))
        # clockwise headings: a counter-clockwise turn of one step goes to heading k - 1
        assert int(np.argmax(layer_mass)) == (k - 1) % headings
        r, c = _centroid(out.sum(axis=0))
        gx = math.cos(yaws[k]) * delta[0] - math.sin(yaws[k]) * delta[1]
        gy = math.sin(yaws[k]) * delta[0] + math.cos(yaws[k]) * delta[1]
        assert c - 20 == pytest.approx(gx / cell, abs=0.05)
        assert r - 20 == pytest.approx(-gy / cell, abs=0.05)


def test_grid_prediction_against_sampled_continuous_motion() -> None:
    """Poses uniform in one cell at heading k's yaw, moved by sample_odometry: the fraction ending
    in each cell matches the grid's prediction (the grid drops the axes' correlation, so cells are
    compared in total variation, loosely)."""
    cell, headings = 0.1, 8
    noise = OdometryNoise(0.2, 0.2, 0.2, 0.2)
    delta = (0.3, 0.0, 0.0)
    yaws = grid_yaws(headings)
    rng = np.random.default_rng(2)
    k = 1  # north-east: both axes move
    belief = np.zeros((headings, 31, 31))
    belief[k, 15, 15] = 1.0
    predicted = predict_grid(belief, yaws, cell, delta, noise).sum(axis=0)
    n = 200_000
    start = np.stack(
        [rng.uniform(15, 16, n) * cell, rng.uniform(15, 16, n) * cell, np.full(n, yaws[k])], axis=1
    )  # grid-frame metres: x = col, y = up; cell (15, 15) is row 31 - 1 - 15 = 15 from the top
    end = sample_odometry(start, delta, noise, rng)
    cols = np.floor(end[:, 0] / cell).astype(int)
    rows = 31 - 1 - np.floor(end[:, 1] / cell).astype(int)
    sampled = np.zeros((31, 31))
    np.add.at(sampled, (rows, cols), 1.0 / n)
    assert 0.5 * np.abs(sampled - predicted).sum() < 0.12
    assert _centroid(sampled) == pytest.approx(_centroid(predicted), abs=0.1)


def test_grid_prediction_keeps_to_free_cells_and_leaves_its_input() -> None:
    belief = np.full((4, 5, 5), 1.0 / 100)
    free = np.ones((5, 5), dtype=bool)
    free[:, 4] = False
    belief[:, :, 4] = 0.0
    belief /= belief.sum()
    before = belief.copy()
    out = predict_grid(belief, grid_yaws(4), 0.25, (0.25, 0.0, 0.0), OdometryNoise(), free)
    assert np.array_equal(belief, before)
    assert out[:, :, 4].sum() == 0.0
    assert out.sum() == pytest.approx(1.0)


@pytest.mark.parametrize("delta", [(0.5, 0.0, 0.0), (-0.3, 0.1, 0.2), (0.0, 0.0, math.pi / 2), (1.7, -0.4, -0.1)])
def test_a_wide_kernel_by_fft_moves_the_same_mass_as_by_shifted_adds(
    delta: tuple[float, float, float], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A 0.5 m move on a 0.1 m lattice has ~200 kernel taps, applied by FFT: the same belief as tap
    by tap (to 1e-12 of its largest value), never negative, and the same mass kept (some moves
    carry mass off the array) -- on a belief with a spike and tails down to 1e-30."""
    import beliefloc.continuous.motion as motion

    rng = np.random.default_rng(3)
    belief = rng.random((12, 40, 50)) ** 8 * 1e-3
    belief[5, 20, 25] = 1.0
    belief[:, :3, :] = 1e-30
    belief /= belief.sum()
    noise = OdometryNoise(0.2, 0.05, 0.2, 0.05)
    monkeypatch.setattr(motion, "FFT_TAPS", 10**9)
    taps = predict_grid(belief, grid_yaws(12), 0.1, delta, noise, normalize=False)
    monkeypatch.setattr(motion, "FFT_TAPS", 0)
    fft = predict_grid(belief, grid_yaws(12), 0.1, delta, noise, normalize=False)
    assert fft.min() >= 0.0
    assert np.abs(fft - taps).max() <= 1e-12 * taps.max()
    assert fft.sum() == pytest.approx(taps.sum(), rel=1e-12)


def test_grid_yaws_are_the_layouts_headings() -> None:
    layout = GridLayout(rows=2, cols=2, headings=8, cell_size=1.0, free=np.ones((2, 2), bool), frame=MapFrame(0, 0, 0))
    assert grid_yaws(8) == pytest.approx(layout.heading_yaw(np.arange(8)))


def test_noise_parameters_are_checked() -> None:
    with pytest.raises(ValueError, match="alpha3"):
        OdometryNoise(alpha3=-0.1)
