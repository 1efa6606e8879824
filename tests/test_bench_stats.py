"""``benchmarks/stats.py``, the statistics every benchmark shares, against values worked out by hand and
against numpy / scipy.stats."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats as scipy_stats

from benchmarks.stats import (
    DASH,
    difference_ci,
    fmt,
    mean,
    mean_or_none,
    median_or_none,
    paired_means,
    paired_p,
    sd,
    standard_error,
    win_counts,
)

SAMPLE = [2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0]
"""Mean 5, squared deviations summing to 32: sample variance 32 / 7, population variance 32 / 8 = 4."""


def test_mean_by_hand_and_on_no_values() -> None:
    assert mean(SAMPLE) == 5.0
    assert mean(x for x in (1, 2, 3, 4)) == 2.5  # any iterable, ints and bools too
    assert mean([True, False, False, True]) == 0.5
    assert math.isnan(mean([]))
    assert mean_or_none(SAMPLE) == 5.0
    assert mean_or_none([]) is None


def test_median_by_hand() -> None:
    assert median_or_none([3.0, 1.0, 2.0]) == 2.0
    assert median_or_none([4.0, 1.0, 3.0, 2.0]) == 2.5  # the mean of the middle two
    assert median_or_none([]) is None


def test_sd_is_the_sample_standard_deviation() -> None:
    assert sd(SAMPLE) == pytest.approx(math.sqrt(32 / 7))  # n - 1, not the population's 2.0
    assert sd(SAMPLE) == pytest.approx(float(np.std(SAMPLE, ddof=1)))
    assert math.isnan(sd([1.0]))
    assert math.isnan(sd([]))


def test_standard_error_against_scipy() -> None:
    assert standard_error(SAMPLE) == pytest.approx(math.sqrt(32 / 7) / math.sqrt(8))
    assert standard_error(SAMPLE) == pytest.approx(float(scipy_stats.sem(SAMPLE)))


def test_paired_p_is_the_two_sided_wilcoxon_signed_rank_test() -> None:
    # five pairs, every difference positive and distinct: the exact two-sided p is 2 / 2^5
    assert paired_p([1.0, 2.0, 3.0, 4.0, 5.0], [0.0, 0.0, 0.0, 0.0, 0.0]) == pytest.approx(0.0625)
    rng = np.random.default_rng(7)
    x = rng.normal(10.0, 2.0, size=40)
    y = x + rng.normal(0.5, 1.0, size=40)
    assert paired_p(x.tolist(), y.tolist()) == pytest.approx(float(scipy_stats.wilcoxon(x, y).pvalue))
    # a tied pair is dropped, as scipy does by default (zero_method="wilcox")
    x2, y2 = [*x.tolist(), 3.0], [*y.tolist(), 3.0]
    expected = float(scipy_stats.wilcoxon(x2, y2, zero_method="wilcox").pvalue)
    assert paired_p(x2, y2) == pytest.approx(expected)


def test_paired_p_when_every_pair_ties() -> None:
    assert paired_p([1.0, 2.0, 3.0], [1.0, 2.0, 3.0]) is None


def test_win_counts() -> None:
    assert win_counts([(1.0, 2.0), (3.0, 3.0), (5.0, 4.0), (0.0, 9.0)]) == (2, 1)
    assert win_counts(iter([])) == (0, 0)


def test_fmt() -> None:
    assert fmt(None) == DASH == "—"
    assert fmt(1.234) == "1.23"
    assert fmt(61.0, 1) == "61.0"
    assert fmt(2.5, 0) == "2"  # Python rounds half to even


def test_paired_means() -> None:
    pairs = [(10.0, 12.0), (20.0, 17.0), (30.0, 31.0), (5.0, 5.0)]
    assert paired_means(pairs) == "16.25 / 16.25 (n=4)"
    assert paired_means(pairs, wins=True) == "16.25 / 16.25 (n=4; cheaper 2, dearer 1)"
    assert paired_means([(1.0, 2.0)]) == "1.00 / 2.00 (n=1)"
    assert paired_means([]) == DASH
    assert paired_means([], wins=True) == DASH


def test_difference_ci_is_scipys_one_sample_t_interval():
    differences = [-3.0, 1.5, -7.25, 0.0, -2.0, 4.0, -11.0]
    centre, low, high = difference_ci(differences, 0.95) or (0.0, 0.0, 0.0)
    expected = scipy_stats.ttest_1samp(differences, 0.0).confidence_interval(0.95)
    assert centre == pytest.approx(sum(differences) / len(differences))
    assert (low, high) == pytest.approx((expected.low, expected.high))
    assert difference_ci([1.0]) is None
    assert difference_ci([2.0, 2.0, 2.0]) == (2.0, 2.0, 2.0)
