"""Zhang, Sridharan & Wyatt 2015: the cell posterior (Eq. 6-7) and existence metareasoning (Eq. 8-14)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import beta as beta_dist

from beliefloc.object_search.existence import (
    ExistenceBelief,
    detection_likelihoods,
    posterior_existence,
)
from beliefloc.object_search.posterior import CellBelief, Detector, spread_room_prior
from beliefloc.object_search.settings import Metareasoning, Revision

BELIEF = np.array([0.5, 0.3, 0.2])
IN_VIEW = np.array([True, False, False])


def test_eq9_by_hand():
    # present: 0.9 * 0.5 (in view) + 0.1 * 0.5 (elsewhere) = 0.5; given ¬E only false positives: 0.1
    assert detection_likelihoods(BELIEF, IN_VIEW, True, 0.9, 0.1) == pytest.approx((0.5, 0.1))
    # absent: 0.1 * 0.5 + 0.9 * 0.5 = 0.5; given ¬E a true negative: 0.9
    assert detection_likelihoods(BELIEF, IN_VIEW, False, 0.9, 0.1) == pytest.approx((0.5, 0.9))


def test_eq11_iterated_equals_the_kept_likelihood_form():
    theta = 0.75
    iterated = theta
    for like_e, like_not_e in [(0.5, 0.9), (0.5, 0.9)]:
        iterated = like_e * iterated / (like_e * iterated + like_not_e * (1 - iterated))
    assert iterated == pytest.approx(0.3125 / 0.65)  # 0.48077, by hand
    kept = posterior_existence(theta, np.log(0.25), np.log(0.81))
    assert float(kept) == pytest.approx(iterated)


def test_expectation_strategy_uses_the_beta_mean():
    belief = ExistenceBelief(6, 2, Metareasoning.EXPECTATION)
    assert belief.theta == pytest.approx(0.75)
    belief.observe(0.5, 0.9)
    assert belief.probability_exists() == pytest.approx(0.625)


def test_upper_bound_prior_is_the_0_9_quantile():
    belief = ExistenceBelief(6, 2, Metareasoning.UPPER_BOUND)
    assert beta_dist.cdf(belief.theta, 6, 2) == pytest.approx(0.9)
    assert belief.theta > 0.75  # above the mean: slower to give up


def test_sampling_converges_to_expectation_as_the_variance_shrinks():
    """The paper's limit statement: with a narrow Beta, MC sampling gives the expectation's answer."""
    gaps = []
    for scale in (1, 100, 10_000):
        rng = np.random.default_rng(0)
        mc = ExistenceBelief(6 * scale, 2 * scale, Metareasoning.SAMPLING, rng=rng, initial_samples=2000)
        ex = ExistenceBelief(6 * scale, 2 * scale, Metareasoning.EXPECTATION)
        for _ in range(3):
            mc.observe(0.5, 0.9)
            ex.observe(0.5, 0.9)
        gaps.append(abs(mc.probability_exists() - ex.probability_exists()))
    assert gaps[-1] < 1e-3 and gaps[-1] < gaps[0]


def test_eq14_draws_more_samples_near_the_threshold():
    rng = np.random.default_rng(1)
    belief = ExistenceBelief(2, 2, Metareasoning.SAMPLING, tau_minus=0.5, rng=rng, initial_samples=50)
    belief.observe(0.5, 0.9)
    not_e = 1 - posterior_existence(belief.samples[:50], belief.log_like_e, belief.log_like_not_e)
    wanted = int(np.ceil((1.645 * not_e.std(ddof=1) / (not_e.mean() - 0.5)) ** 2))
    assert len(belief.samples) == min(belief.max_samples, max(50, wanted))


def test_none_strategy_never_doubts():
    belief = ExistenceBelief(1, 30, Metareasoning.NONE)
    belief.observe(0.01, 0.99)
    assert belief.probability_exists() == 1.0


def test_sampling_needs_a_generator():
    with pytest.raises(ValueError, match="seeded"):
        ExistenceBelief(6, 2, Metareasoning.SAMPLING)


def test_room_prior_spread_over_cells():
    spread = spread_room_prior(np.array([0.2, 0.8]), np.array([0, 0, 1, 1, 1, 1]))
    np.testing.assert_allclose(spread, [0.1, 0.1, 0.2, 0.2, 0.2, 0.2])


def test_eq7_posterior_and_revision_reuse_vs_discard():
    detector = Detector(true_positive=0.8, false_positive=0.1)
    belief = CellBelief.start(np.array([0.25, 0.25, 0.5]))
    belief = belief.observe(detector.likelihood(np.array([False, False, True]), present=False))
    # likelihood [0.9, 0.9, 0.2] times prior [0.25, 0.25, 0.5] -> [0.225, 0.225, 0.1] / 0.55
    np.testing.assert_allclose(belief.posterior, [0.225 / 0.55, 0.225 / 0.55, 0.1 / 0.55])
    new_prior = np.array([0.6, 0.2, 0.2])
    reused = belief.revise(new_prior, Revision.REUSE).posterior
    discarded = belief.revise(new_prior, Revision.DISCARD).posterior
    # re-use keeps the evidence against cell 2: [0.54, 0.18, 0.04] / 0.76; discard is the prior itself
    np.testing.assert_allclose(reused, [0.54 / 0.76, 0.18 / 0.76, 0.04 / 0.76])
    np.testing.assert_allclose(discarded, new_prior)


def test_long_searches_do_not_underflow():
    detector = Detector(true_positive=0.9, false_positive=0.05)
    belief = CellBelief.start(np.full(4, 0.25))
    for _ in range(2000):
        belief = belief.observe(detector.likelihood(np.array([True, False, False, False]), present=False))
    post = belief.posterior
    assert np.all(np.isfinite(post)) and post.sum() == pytest.approx(1.0) and post[0] < 1e-100
