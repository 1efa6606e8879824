"""The compiled passes for large beliefs (``beliefloc/planning/_fused.c``, issue 28): predictions and Bayes
updates bit for bit as NumPy's and SciPy's, entropies and group sums to a few ulps, the same plans, and
no read or write outside the vectors whatever the arguments."""

from __future__ import annotations

import math
import shutil
import sysconfig
import threading

import numpy as np
import pytest

from beliefloc import compile_model, load_map
from beliefloc.belief import entropy, predict
from beliefloc.planning import best_first, successors
from beliefloc.planning.successors import SuccessorEvaluator
from beliefloc.simulation.gridworld import generate_gridworld, gridworld_yaml
from beliefloc.source import threads

from .conftest import MAPS


def _compiler() -> bool:
    command = (sysconfig.get_config_var("CC") or "cc").split()[0]
    return shutil.which(command) is not None


def test_the_compiled_passes_are_built_where_a_compiler_is():
    """setup.py builds the extension as optional: a broken build would only make the search slower, so
    this says so wherever a C compiler is found (CI's machines have one)."""
    if not _compiler():
        pytest.skip("no C compiler: the NumPy passes are used")
    assert successors.fused is not None


fused = successors.fused
needs_fused = pytest.mark.skipif(fused is None, reason="the compiled passes are not built")
REL = 1e-13
"""Entropies and group sums: another summation order and logarithm, a few ulps per entry."""


def _world(tmp_path, states: int, seed: int):
    world = tmp_path / f"world-{states}-{seed}.yaml"
    world.write_text(
        gridworld_yaml(generate_gridworld(states, np.random.default_rng(seed)), seed=seed), encoding="utf-8"
    )
    return compile_model(load_map(world))


def _beliefs(n: int, rng: np.random.Generator) -> list[np.ndarray]:
    """Dense, with holes (zero entries), uniform, one state, and a wide spread of magnitudes."""
    full = rng.random(n)
    holes = full.copy()
    holes[rng.random(n) < 0.5] = 0.0
    holes[0] = 1.0
    one = np.zeros(n)
    one[n // 2] = 1.0
    spread = np.exp(rng.uniform(-600.0, 0.0, n))
    return [b / b.sum() for b in (full, holes, np.ones(n), one, spread)]


def _models(tmp_path):
    names = ("kitchen.yaml", "corridors.yaml", "tb3-sandbox.yaml", "window-2x2.yaml")
    return [compile_model(load_map(MAPS / name)) for name in names] + [_world(tmp_path, 4000, 2)]


@needs_fused
def test_predictions_bit_for_bit_with_their_entropy_and_maximum(tmp_path):
    """``T_aᵀ b`` from T_a's rows (scattered) and from the transpose's rows (gathered) is SciPy's product
    bit for bit; the entropy and maximum taken with it are ``entropy()``'s and ``max()``'s."""
    rng = np.random.default_rng(3)
    checked = 0
    for model in _models(tmp_path):
        for action in model.actions:
            if action.transition is None:
                continue
            forward, transposed = action.transition, action.transition_transposed
            for belief in _beliefs(model.n_states, rng):
                expected = predict(action, belief)
                for matrix, by_source in ((forward, True), (transposed, False)):
                    for stats in (True, False):
                        out = np.full(model.n_states, np.nan)
                        xlogx, peak, nan = fused.predict_stats(
                            matrix.indptr, matrix.indices, matrix.data, belief, out, stats, by_source
                        )
                        assert out.tobytes() == expected.tobytes()
                        assert not nan
                        if stats:
                            assert -xlogx == pytest.approx(entropy(expected), rel=REL, abs=1e-300)
                            assert peak == float(expected.max())
                        checked += 1
    assert checked > 100


@needs_fused
def test_a_beliefs_entropy_and_maximum():
    rng = np.random.default_rng(4)
    for n in (1, 3, 4, 5, 1023, 1024, 1025, 5000):
        for belief in _beliefs(n, rng):
            xlogx, peak, nan = fused.belief_stats(belief)
            assert -xlogx == pytest.approx(entropy(belief), rel=REL, abs=1e-300)
            assert (peak, nan) == (float(belief.max()), 0)
    holed = np.array([0.5, np.nan, 0.5])
    assert fused.belief_stats(holed)[2]


@needs_fused
def test_group_sums_whole_and_in_parts(tmp_path):
    """Each signature group's mass, mass-log-mass and maximum are NumPy's; over two parts of the states,
    combined, the same to a few ulps (the maximum exactly)."""
    rng = np.random.default_rng(5)
    checked = 0
    for model in _models(tmp_path):
        evaluator = SuccessorEvaluator(model)
        evaluator._fused = fused
        for groups in evaluator._groups:
            if groups is None or groups.label is None:
                continue
            for belief in _beliefs(model.n_states, rng):
                mass, mass_log_mass, peak = evaluator._group_sums(groups, belief)
                whole = evaluator._fused_group_sums(groups, belief)
                cut = model.n_states // 3
                first = evaluator._fused_group_sums(groups, belief, 0, cut)
                second = evaluator._fused_group_sums(groups, belief, cut, None)
                assert whole is not None and first is not None and second is not None
                for sums in (whole, successors._combined(first, second)):
                    np.testing.assert_allclose(sums[0], mass, rtol=REL, atol=1e-300)
                    np.testing.assert_allclose(sums[1], mass_log_mass, rtol=REL, atol=1e-300)
                    assert sums[2].tobytes() == peak.tobytes()
                checked += 1
    assert checked > 10


@needs_fused
@pytest.mark.parametrize("label_type", [np.uint8, np.uint16, np.intp])
def test_bayes_updates_bit_for_bit(label_type):
    """``b * column[label]`` and its sum, as NumPy's product and ``np.add.reduce`` (its pairwise tree), with
    labels of a byte, two bytes or eight (a large model's evaluator keeps the narrowest)."""
    rng = np.random.default_rng(6)
    for n in (1, 7, 8, 9, 127, 128, 129, 136, 1000, 4097, 65_537):
        column = rng.random(300 if label_type is np.uint16 else 5)
        column[1] = 0.0
        label = rng.integers(0, len(column), n).astype(label_type)
        for belief in _beliefs(n, rng):
            out = np.empty(n)
            total = fused.weighted_sum(belief, column, label, out)
            expected = belief * column[label]
            assert out.tobytes() == expected.tobytes()
            assert total.hex() == float(np.add.reduce(expected)).hex()


@needs_fused
def test_group_sums_read_labels_of_any_width_alike():
    """The same groups' sums, to the bit, from labels of one, two or eight bytes."""
    rng = np.random.default_rng(9)
    for n in (1, 1023, 1025, 5000):
        label = rng.integers(0, 200, n)
        for belief in _beliefs(n, rng):
            found = []
            for label_type in (np.uint8, np.uint16, np.intp):
                sums = np.empty(200), np.empty(200), np.empty(200)
                assert fused.group_stats(belief, label.astype(label_type), *sums) == 0
                found.append(b"".join(part.tobytes() for part in sums))
            assert found[0] == found[1] == found[2]


@needs_fused
def test_search_keys_round_as_numpy_does():
    rng = np.random.default_rng(7)
    resolution = float(best_first.KEY_RESOLUTION)
    for n in (1, 5, 1000):
        for belief in _beliefs(n, rng):
            belief = belief.copy()
            belief[0] = 2.5 / resolution  # a tie: to even
            whole = np.empty(n, dtype=np.int32)
            peak, fits = fused.round_key(belief, resolution, whole)
            assert fits and peak == float(belief.max())
            assert whole.tobytes() == np.rint(belief * resolution).astype(np.int32).tobytes()
    whole = np.empty(2, dtype=np.int32)
    assert not fused.round_key(np.array([0.5, 3.0]), resolution, whole)[1]  # 3 * 2^30 does not fit
    assert not fused.round_key(np.array([0.5, np.nan]), resolution, whole)[1]


@needs_fused
@pytest.mark.parametrize("n", [2**20 + 1, 2**20 + 13, 3 * 2**19 + 7])
def test_bayes_updates_and_keys_taken_in_two_halves_are_the_whole_s_bits(monkeypatch, n):
    """Past SPLIT_FROM entries a Bayes update's product and pairwise sum, and a search key's rounding,
    run as two halves on two threads: the same bits as one pass (the pairwise tree's own top split;
    each entry rounded alone), whatever the length's remainder."""
    from concurrent.futures import ThreadPoolExecutor

    rng = np.random.default_rng(n)
    belief = rng.random(n)
    belief /= belief.sum()
    column = rng.random(7)
    label = rng.integers(0, 7, n).astype(np.int64)
    one_out, one_whole = np.empty(n), np.empty(n, dtype=np.int32)
    one_total = fused.weighted_sum(belief, column, label, one_out)
    one_peak, one_fits = fused.round_key(belief, float(best_first.KEY_RESOLUTION), one_whole)
    assert one_total == float(np.add.reduce(belief * column[label]))  # NumPy's pairwise sum, bit for bit
    with ThreadPoolExecutor(2) as pool:
        monkeypatch.setattr(threads, "_POOL", pool)
        monkeypatch.setattr(threads, "_POOL_MADE", True)
        out, whole = np.empty(n), np.empty(n, dtype=np.int32)
        total = successors.fused_weighted_sum(fused, belief, column, label, out)
        peak, fits = best_first._fused_round_key(fused, belief, whole)
    assert total == one_total and out.tobytes() == one_out.tobytes()
    assert (peak, fits) == (one_peak, one_fits) and whole.tobytes() == one_whole.tobytes()
    belief[n - 3] = np.nan  # the second half's NaN: the key does not fit
    with ThreadPoolExecutor(2) as pool:
        monkeypatch.setattr(threads, "_POOL", pool)
        assert best_first._fused_round_key(fused, belief, whole)[1] is False


@needs_fused
def test_bad_arguments_raise_and_touch_nothing_outside():
    """Indices past the vectors, rows that run backwards or past the entries, vectors of other lengths or
    types: an exception, never a read or write outside a buffer."""
    indptr = np.array([0, 1, 2], dtype=np.int32)
    data = np.array([1.0, 1.0])
    belief = np.array([0.5, 0.5])
    out = np.zeros(2)
    with pytest.raises(ValueError, match="out of range"):
        fused.predict_stats(indptr, np.array([0, 7], dtype=np.int32), data, belief, out, True, True)
    with pytest.raises(ValueError, match="out of range"):
        fused.predict_stats(indptr, np.array([0, -1], dtype=np.int32), data, belief, out, True, False)
    with pytest.raises(ValueError, match="out of range"):
        fused.predict_stats(np.array([0, 2, 1], dtype=np.int32), np.array([0, 1], dtype=np.int32), data, belief,
                            out, True, True)  # fmt: skip
    with pytest.raises(ValueError, match="out of range"):
        fused.predict_stats(np.array([0, 1, 9], dtype=np.int32), np.array([0, 1], dtype=np.int32), data, belief,
                            out, True, False)  # fmt: skip
    with pytest.raises(ValueError, match="do not fit"):
        fused.predict_stats(indptr, np.array([0, 1], dtype=np.int64), data, belief, out, True, True)
    with pytest.raises(ValueError, match="do not fit"):
        fused.predict_stats(indptr, np.array([0, 1], dtype=np.int32), data, belief, np.zeros(5), True, False)
    with pytest.raises(TypeError):
        fused.predict_stats(indptr, np.array([0, 1], dtype=np.int32), data, belief.astype(np.float32), out, True, True)
    with pytest.raises((TypeError, ValueError, BufferError)):
        fused.belief_stats(np.zeros((4, 4))[:, 0])  # not contiguous
    groups = np.zeros(1)
    for label_type in (np.uint8, np.uint16, np.intp):
        with pytest.raises(ValueError, match="not a group"):
            fused.group_stats(belief, np.array([0, 3], dtype=label_type), groups, groups.copy(), groups.copy())
        with pytest.raises(ValueError, match="not a group"):
            fused.weighted_sum(belief, np.array([1.0]), np.array([0, 1], dtype=label_type), out)
    with pytest.raises(TypeError):  # labels of another type are not read as one of these
        fused.group_stats(belief, np.array([0, 0], dtype=np.int32), groups, groups.copy(), groups.copy())
    with pytest.raises((TypeError, ValueError, BufferError)):
        fused.weighted_sum(belief, np.array([1.0]), np.array([0, 0], dtype=np.intp), np.zeros(4)[::2])
    with pytest.raises(ValueError, match="do not fit"):
        fused.weighted_sum(belief, np.array([1.0]), np.array([0, 0], dtype=np.intp), np.zeros(3))


@needs_fused
@pytest.mark.parametrize("pool", (True, False))
def test_expansions_match_the_numpy_passes(tmp_path, monkeypatch, pool):
    """Every successor of the compiled passes, with and without threads: the same actions and readings as
    the NumPy passes', the same probabilities, entropies and maxima to a few ulps; with and without
    threads the same bits."""
    model = _world(tmp_path, 4000, 3)
    monkeypatch.setattr(successors, "_LARGE_BYTES", 0)
    if not pool:
        monkeypatch.setattr(threads, "_POOL", None)
        monkeypatch.setattr(threads, "_POOL_MADE", True)
    rng = np.random.default_rng(8)
    compiled = SuccessorEvaluator(model)
    monkeypatch.setattr(successors, "fused", None)
    plain = SuccessorEvaluator(model)
    for belief in _beliefs(model.n_states, rng):
        got = compiled.evaluate(belief)
        expected = plain.evaluate(belief)
        assert [(s.action, s.observation) for s in got] == [(s.action, s.observation) for s in expected]
        for g, e in zip(got, expected, strict=True):
            assert g.probability == pytest.approx(e.probability, rel=1e-12)
            assert g.entropy == pytest.approx(e.entropy, rel=1e-12, abs=1e-12)
            assert g.max_belief == pytest.approx(e.max_belief, rel=1e-12)
        for index, action in enumerate(model.actions):
            if action.transition is not None:
                assert compiled.successor(belief, index, None).tobytes() == predict(action, belief).tobytes()
        # a look's Bayes updates: the compiled evaluator's narrow labels, NumPy's intp ones, the same bits
        looks = [(s.action, s.observation) for s in expected if s.observation is not None]
        assert looks and any(g is not None and g.label is not None and g.label.itemsize == 1 for g in compiled._groups)
        for index, observation in looks[:6]:
            by_compiled = compiled.successor(belief, index, observation)
            assert by_compiled.tobytes() == plain.successor(belief, index, observation).tobytes()
    # the signature order the compiled evaluator does not keep, sorted again when a NumPy pass asks: the same
    for narrow, wide in zip(compiled._groups, plain._groups, strict=True):
        assert (narrow is None) == (wide is None)
        if narrow is not None and wide is not None:
            assert narrow._order is None and wide._order is not None
            assert narrow.order.tobytes() == wide.order.tobytes()


@needs_fused
@pytest.mark.parametrize(("states", "seed"), [(400, 1), (4000, 1), (4000, 5)])
def test_searches_find_the_same_plans(tmp_path, monkeypatch, states, seed):
    """The search on the compiled passes finds the NumPy passes' plan: the same steps, cost and effort,
    the numbers to a few ulps."""
    model = _world(tmp_path, states, seed)
    start = np.full(model.n_states, 1.0 / model.n_states)
    monkeypatch.setattr(successors, "_LARGE_BYTES", 0)
    monkeypatch.setattr(best_first, "_RECYCLE_BYTES", 0)
    compiled = best_first.plan(model, start.copy(), max_expansions=400, time_limit=60.0)
    monkeypatch.setattr(successors, "fused", None)
    plain = best_first.plan(model, start.copy(), max_expansions=400, time_limit=60.0)
    assert plain.expanded > 4
    assert compiled.status is plain.status
    assert (compiled.expanded, compiled.generated, compiled.cost) == (plain.expanded, plain.generated, plain.cost)
    assert [(s.action, s.observation, s.cost) for s in compiled.steps] == [
        (s.action, s.observation, s.cost) for s in plain.steps
    ]
    for c, p in zip(compiled.steps, plain.steps, strict=True):
        assert math.isclose(c.probability, p.probability, rel_tol=1e-12)
        assert math.isclose(c.max_belief, p.max_belief, rel_tol=1e-12)


@needs_fused
def test_a_forked_child_makes_its_own_threads(tmp_path):
    """A process forked after a search has its parent's pool object but none of its threads: it makes a
    new pool instead of waiting forever on the old one."""
    import multiprocessing

    model = _world(tmp_path, 400, 1)
    pool = threads.pool()
    if pool is None:
        pytest.skip("one core: no pool")
    meeting = threading.Barrier(pool._max_workers)  # every thread of the parent's pool started
    for task in [pool.submit(meeting.wait, 10) for _ in range(pool._max_workers)]:
        task.result()
    context = multiprocessing.get_context("fork")
    with context.Pool(1) as workers:
        result = workers.apply_async(_evaluate_large, (model,))
        assert result.get(timeout=30) > 0


def _evaluate_large(model) -> int:
    successors._LARGE_BYTES = 0
    belief = np.full(model.n_states, 1.0 / model.n_states)
    return len(SuccessorEvaluator(model).evaluate(belief))


def test_a_vector_filled_on_two_cores_is_filled():
    vector = np.empty(1_000_001)
    assert threads.filled(vector, 0.25) is vector
    assert (vector == 0.25).all()


def test_a_task_of_the_pool_that_splits_its_work_does_it_itself():
    """A task of the pool that fills a new vector on "two cores" must not wait on the pool: with every thread
    of the pool doing so, none would be left to run the halves."""
    pool = threads.pool()
    if pool is None:
        pytest.skip("one core: no pool")
    workers = pool._max_workers
    meeting = threading.Barrier(workers)

    def task(value: float) -> np.ndarray:
        meeting.wait(10)  # every thread of the pool in one of these tasks
        return threads.filled(np.empty(10_001), value)

    filled = [job.result(timeout=30) for job in [pool.submit(task, float(i)) for i in range(workers)]]
    for value, vector in enumerate(filled):
        assert (vector == value).all()
