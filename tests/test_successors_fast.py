"""The planner's fast paths (issue 28, scale) give what the plain computations give, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from beliefloc import compile_model, load_map
from beliefloc.belief import entropy, predict
from beliefloc.planning import best_first, successors
from beliefloc.planning.best_first import belief_key
from beliefloc.planning.successors import SuccessorEvaluator
from beliefloc.simulation.gridworld import generate_gridworld, gridworld_yaml

from .conftest import MAPS

FAST_MAPS = ("kitchen.yaml", "corridors.yaml", "tb3-sandbox.yaml", "window-2x2.yaml")


@pytest.fixture(autouse=True)
def _numpy_passes(monkeypatch):
    """These are the NumPy passes' tests: the compiled ones (equal to a few ulps, not bit for bit) are
    tested in test_successors_compiled.py."""
    monkeypatch.setattr(successors, "fused", None)


def _successors(action, belief):
    """``(o, b')`` for every reading ``o`` of ``action`` possible from ``belief``: Bayes' rule the plain way."""
    for o in range(action.observation.n_observations if action.observation.parts else 0):
        expected = predict(action, belief) * action.observation.likelihood(o)
        if expected.sum() > 0.0:
            yield o, expected / expected.sum()


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


def test_belief_key_with_scratch_vectors_is_the_same_key():
    """The search's keys, written through reused scratch vectors, are the keys without them (a belief
    and a vector above 1 alike, and after the scratch held another belief)."""
    rng = np.random.default_rng(7)
    work = best_first.KeyWork((50,))
    for b in (*_beliefs(50, rng), np.r_[3.0, np.zeros(49)]):
        assert belief_key(b, work) == belief_key(b)
    assert belief_key(np.ones(3) / 3, work) == belief_key(np.ones(3) / 3)  # another shape: no scratch


@pytest.mark.parametrize("name", FAST_MAPS)
def test_predictions_into_recycled_vectors_bit_for_bit(name):
    """A prediction or successor written into a recycled vector (still holding an old belief's
    numbers) is predict()'s and the Bayes update's, bit for bit, whether or not the transpose that
    predict() uses has been built."""
    model = compile_model(load_map(MAPS / name))
    evaluator = SuccessorEvaluator(model)
    evaluator._large = True  # the path of 10^5 states and more (smaller ones call predict())
    rng = np.random.default_rng(5)
    for belief in _beliefs(model.n_states, rng):
        for _ in range(2):
            evaluator.recycle(rng.random(model.n_states))
        for index, action in enumerate(model.actions):
            # without the transpose (the CSC product over T's own arrays), then with it once predict() built it
            action.__dict__.pop("transition_transposed", None)
            without = evaluator._predict(action, belief).tobytes()
            assert "transition_transposed" not in action.__dict__
            assert without == predict(action, belief).tobytes()
            assert evaluator._predict(action, belief).tobytes() == without
            for o, expected in _successors(action, belief):
                evaluator.recycle(rng.random(model.n_states))
                assert evaluator.successor(belief, index, o).tobytes() == expected.tobytes()


@pytest.mark.parametrize(("states", "block"), [(400, None), (4000, None), (4000, 256)])
def test_a_search_that_recycles_beliefs_finds_the_same_plan(states, block, tmp_path, monkeypatch):
    """On a generated world of the paper's kind, with a cache of two beliefs (evictions at every pop,
    so recycled vectors everywhere), the search finds the plan it finds when nothing is recycled: the
    same steps, the same numbers bit for bit, the same effort and the same final belief. The large
    beliefs' path also sweeps entropies and group sums block by block (``block``: blocks of 256
    entries, so that the pairwise tree of blocks is several levels deep)."""
    world = tmp_path / "world.yaml"
    world.write_text(gridworld_yaml(generate_gridworld(states, np.random.default_rng(1)), seed=1), encoding="utf-8")
    model = compile_model(load_map(world))
    start = np.full(model.n_states, 1.0 / model.n_states)
    if block is not None:
        monkeypatch.setattr(successors, "_BLOCK", block)
    monkeypatch.setattr(best_first, "_CACHE_BYTES", 0)
    monkeypatch.setattr(best_first, "_CACHE_MIN_BELIEFS", 2)
    results = []
    for spare in (0, successors._SPARE_BELIEFS):
        monkeypatch.setattr(successors, "_SPARE_BELIEFS", spare)
        monkeypatch.setattr(best_first, "_RECYCLE_BYTES", 0 if spare else 2**62)  # these beliefs are small
        monkeypatch.setattr(successors, "_LARGE_BYTES", 0 if spare else 2**62)
        results.append(best_first.plan(model, start.copy(), max_expansions=400, time_limit=60.0))
    plain, recycled = results
    assert plain.expanded > 4
    assert recycled.status is plain.status
    assert (recycled.expanded, recycled.generated) == (plain.expanded, plain.generated)
    assert [(s.action, s.observation, s.probability.hex(), s.max_belief.hex(), s.cost) for s in recycled.steps] == [
        (s.action, s.observation, s.probability.hex(), s.max_belief.hex(), s.cost) for s in plain.steps
    ]
    if plain.belief is not None:
        assert recycled.belief is not None and recycled.belief.tobytes() == plain.belief.tobytes()


def test_belief_key_with_the_peak_is_the_same_key():
    """Given the belief's maximum, the key is rounded straight into 32 bits when it fits: the same key,
    for beliefs and for a vector above 1 (which falls back to the float key)."""
    rng = np.random.default_rng(8)
    work = best_first.KeyWork((40,))
    for b in (*_beliefs(40, rng), np.r_[3.0, np.zeros(39)], np.r_[-0.0, np.full(39, 1 / 39)]):
        assert belief_key(b, work, float(b.max())) == belief_key(b)


@pytest.mark.parametrize("block", (128, 1000, 4096))
def test_entropy_and_maximum_in_blocks_bit_for_bit(block, monkeypatch):
    """A prediction's entropy and maximum swept in blocks (the nodes of NumPy's pairwise-sum tree) are
    the whole-vector ones bit for bit, at lengths around the block and the tree's splits, with zero
    entries (the NaN fallback) and without."""
    monkeypatch.setattr(successors, "_BLOCK", block)
    rng = np.random.default_rng(11)
    for n in (1, 7, 127, 128, 129, 1000, 4095, 4097, 10_001, 65_537):
        for belief in _beliefs(n, rng):
            h, peak = successors._entropy_max(belief, np.empty_like(belief))
            assert h.hex() == entropy(belief).hex() == successors._entropy(belief).hex()
            assert peak == float(belief.max())


@pytest.mark.parametrize("block", (128, 1000))
def test_group_sums_in_blocks_bit_for_bit(block, monkeypatch, tmp_path):
    """Each signature group's mass, mass-log-mass and maximum swept in blocks equal np.add.reduceat's and
    np.maximum.reduceat's bit for bit: on the shipped maps (small groups, groups of one state) and on a
    generated world (groups of hundreds of states, several blocks each); None exactly when a belief has
    a zero entry (the whole-vector path takes it)."""
    monkeypatch.setattr(successors, "_BLOCK", block)
    world = tmp_path / "world.yaml"
    world.write_text(gridworld_yaml(generate_gridworld(4000, np.random.default_rng(2)), seed=2), encoding="utf-8")
    models = [compile_model(load_map(MAPS / name)) for name in FAST_MAPS] + [compile_model(load_map(world))]
    rng = np.random.default_rng(12)
    checked = 0
    for model in models:
        evaluator = SuccessorEvaluator(model)
        for index, groups in enumerate(evaluator._groups):
            if groups is None:
                continue
            rank = evaluator._rank(index, groups)
            assert np.array_equal(np.argsort(rank), groups.order)
            for belief in _beliefs(model.n_states, rng):
                fast = successors._group_sums(belief, groups, rank, *evaluator._buffers())
                plain = evaluator._group_sums(groups, belief)
                if fast is None:
                    assert not (belief > 0.0).all()
                    continue
                checked += 1
                for mine, numpy_s in zip(fast, plain, strict=True):
                    assert mine.tobytes() == numpy_s.tobytes()
    assert checked >= 2 * len(models)


@pytest.mark.parametrize("block", (128, 1000))
def test_bayes_update_in_blocks_bit_for_bit(block, monkeypatch, tmp_path):
    """A successor belief (the Bayes update) computed in blocks on the large beliefs' path, likelihoods
    gathered, multiplied and summed a block at a time, is predict() times the likelihood over its sum,
    bit for bit."""
    monkeypatch.setattr(successors, "_BLOCK", block)
    world = tmp_path / "world.yaml"
    world.write_text(gridworld_yaml(generate_gridworld(4000, np.random.default_rng(3)), seed=3), encoding="utf-8")
    rng = np.random.default_rng(13)
    checked = 0
    for model in (compile_model(load_map(MAPS / "tb3-sandbox.yaml")), compile_model(load_map(world))):
        evaluator = SuccessorEvaluator(model)
        evaluator._large = True
        for belief in _beliefs(model.n_states, rng)[:2]:
            for index, action in enumerate(model.actions):
                for o, expected in _successors(action, belief):
                    evaluator.recycle(rng.random(model.n_states))
                    assert evaluator.successor(belief, index, o).tobytes() == expected.tobytes()
                    checked += 1
    assert checked >= 8


@pytest.mark.parametrize("block", (7, 100, 2**15))
def test_key_and_peak_in_blocks_are_the_key_and_the_maximum(block, monkeypatch):
    """The key and the maximum taken together block by block are belief_key()'s key and belief.max():
    for beliefs, for a vector above 1 (the float key) and one with a NaN."""
    monkeypatch.setattr(best_first, "_KEY_BLOCK", block)
    rng = np.random.default_rng(14)
    for n in (1, 7, 99, 100, 101, 1000):
        work = best_first.KeyWork((n,))
        vectors = [*_beliefs(n, rng), np.r_[3.0, np.zeros(n - 1)], np.r_[np.full(n - 1, 1.0 / n), np.nan]]
        for b in vectors[:-1] if n == 1 else vectors:
            key, peak = best_first.key_and_peak(b, work)
            assert key == belief_key(b)
            assert peak == float(b.max()) or (np.isnan(peak) and np.isnan(b.max()))


def test_the_start_beliefs_entropy_and_maximum_bit_for_bit(monkeypatch):
    """The search's start estimate from :meth:`SuccessorEvaluator.entropy_max` (one blocked sweep for a
    large belief) is ``entropy(b)`` and ``b.max()`` bit for bit, zero entries included."""
    monkeypatch.setattr(successors, "_BLOCK", 128)
    model = compile_model(load_map(MAPS / "tb3-sandbox.yaml"))
    rng = np.random.default_rng(12)
    for large in (False, True):
        evaluator = SuccessorEvaluator(model)
        evaluator._large = large
        for belief in _beliefs(model.n_states, rng):
            h, peak = evaluator.entropy_max(belief)
            assert (h.hex(), peak) == (entropy(belief).hex(), float(belief.max()))


def test_the_belief_cache_holds_fewer_of_the_largest_beliefs():
    """Small beliefs: at least sixteen, more within 256 MB; recycled ones (1 MB and up): eight, whatever their
    size -- never more as beliefs grow."""
    sizes = [8 * n for n in (1, 400, 50_000, 131_071, 131_072, 10**6, 9_998_244, 10**8)]
    capacities = [best_first.cache_capacity(size) for size in sizes]
    assert capacities[:4] == [max(16, best_first._CACHE_BYTES // size) for size in sizes[:4]]
    assert capacities[4:] == [8, 8, 8, 8]
    assert capacities == sorted(capacities, reverse=True)
