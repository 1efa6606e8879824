"""The planner's fast paths (issue 28, scale) give what the plain computations give, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from beliefloc import compile_model, load_map
from beliefloc.belief import entropy, predict
from beliefloc.planning import successors
from beliefloc.planning.best_first import belief_key
from beliefloc.planning.successors import SuccessorEvaluator

from .conftest import MAPS

FAST_MAPS = ("kitchen.yaml", "corridors.yaml", "tb3-sandbox.yaml", "window-2x2.yaml")


def _beliefs(n: int, rng: np.random.Generator) -> list[np.ndarray]:
    full = rng.random(n)
    holes = full.copy()
    holes[rng.random(n) < 0.5] = 0.0
    holes[0] = 1.0
    one = np.zeros(n)
    one[n // 2] = 1.0
    return [b / b.sum() for b in (full, holes, np.ones(n), one)]


@pytest.mark.parametrize("name", FAST_MAPS)
def test_likelihood_and_entropy_bit_for_bit(name):
    model = compile_model(load_map(MAPS / name))
    evaluator = SuccessorEvaluator(model)
    for a, action in enumerate(model.actions):
        if not action.observation.parts:
            continue
        for o in range(action.observation.n_observations):
            fast = evaluator._likelihood(a, o)
            assert fast.dtype == np.float64
            assert fast.tobytes() == action.observation.likelihood(o).tobytes()
    for belief in _beliefs(model.n_states, np.random.default_rng(3)):
        assert successors._entropy(belief) == entropy(belief)
        assert successors._entropy(belief, np.empty_like(belief)) == entropy(belief)


@pytest.mark.parametrize("name", FAST_MAPS)
def test_statistics_match_the_materialised_successors(name):
    """evaluate()'s statistics (scratch buffers, no copy for a perception) against each successor
    belief built with predict() and the likelihood, and the belief is left as it was."""
    model = compile_model(load_map(MAPS / name))
    evaluator = SuccessorEvaluator(model)
    for belief in _beliefs(model.n_states, np.random.default_rng(4)):
        before = belief.copy()
        kept: dict[int, np.ndarray] = {}
        stats = evaluator.evaluate(belief, kept)
        assert np.array_equal(belief, before)
        # the kept beliefs are the successors of the actions that observe nothing, bit for bit
        assert sorted(kept) == sorted(s.action for s in stats if s.observation is None)
        for index, kept_belief in kept.items():
            assert kept_belief is not belief
            assert kept_belief.tobytes() == evaluator.successor(belief, index, None).tobytes()
        assert evaluator.evaluate(belief) == stats
        pairs = list(evaluator.successors(belief))
        assert [s for s, _ in pairs] == stats
        for s, successor in pairs:
            action = model.actions[s.action]
            expected = predict(action, belief)
            if s.observation is not None:
                expected = expected * action.observation.likelihood(s.observation)
                expected /= expected.sum()
            assert successor.tobytes() == expected.tobytes()
            assert evaluator.successor(belief, s.action, s.observation).tobytes() == expected.tobytes()
            assert s.entropy == pytest.approx(entropy(expected), abs=1e-9)
            assert s.max_belief == pytest.approx(float(expected.max()), abs=1e-12)


def test_groups_match_a_plain_stable_sort():
    """The counted, radix-sorted groups of 16-bit signatures are those of a plain stable sort of the keys
    (the path signatures of 2^16 and more take)."""
    model = compile_model(load_map(MAPS / "tb3-sandbox.yaml"))
    action = next(a for a in model.actions if a.observation.parts)
    narrow = successors._groups(action, model.n_states)
    assert narrow is not None and narrow.label is not None
    parts = action.observation.parts
    key = np.zeros(model.n_states, dtype=np.int64)
    for part in parts:
        key = key * part.confusion.shape[0] + part.truth
    order = np.argsort(key, kind="stable")
    ordered = key[order]
    boundary = np.r_[True, ordered[1:] != ordered[:-1]]
    assert np.array_equal(narrow.order, order)
    assert np.array_equal(narrow.starts, np.flatnonzero(boundary))
    label = np.empty(model.n_states, dtype=np.intp)
    label[order] = np.cumsum(boundary) - 1
    assert np.array_equal(narrow.label, label)


def test_belief_key_classes():
    """Equal keys exactly when every entry rounds to the same multiple of 2^-30 (signed zeros alike)."""
    b = np.array([0.25, 0.25, 0.5, 0.0])
    assert belief_key(b) == belief_key(np.array([0.25, 0.25, 0.5, -0.0]))
    assert belief_key(b) == belief_key(np.array([0.25 + 1e-13, 0.25, 0.5, 1e-12]))
    assert belief_key(b) != belief_key(np.array([0.25, 0.25, 0.5 - 1e-6, 1e-6]))
    assert belief_key(b) != belief_key(np.array([0.25, 0.5, 0.25, 0.0]))


def test_belief_key_is_exact_on_the_rounded_entries():
    """The 32-bit form of the key: entries that round to different multiples of 2^-30 differ (the
    smallest step, one unit, and the largest value, 1), and a vector with an entry above 1 (not a
    belief: its rounded entries do not fit 32 bits) is keyed too, never like a belief."""
    step = 2.0**-30
    b = np.array([0.5, 0.5 - step, step, 0.0])
    assert belief_key(b) != belief_key(np.array([0.5, 0.5 - 2 * step, 2 * step, 0.0]))
    assert belief_key(np.array([1.0, 0.0])) != belief_key(np.array([1.0 - step, step]))
    assert belief_key(np.array([1.0, 0.0])) == belief_key(np.array([1.0 + 1e-12, 0.0]))
    big = np.array([3.0, 0.0])  # 3 * 2^30 would wrap around in 32 bits to -2^30, the rounding of -1
    assert belief_key(big) == belief_key(big.copy())
    assert belief_key(big) != belief_key(np.array([-1.0, 0.0]))
