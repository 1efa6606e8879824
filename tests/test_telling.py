"""Telling look-alike places apart (beliefloc.planning.telling): the evidence a reading gives, the
macro's search against brute force on small random worlds, and the places it is asked about."""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np
import pytest

from beliefloc.planning.telling import TellingMacro, few_places, telling_macros, which_place_evidence

# a 3 x 3 world of cells, compass moves N E S W that stay where a wall is
_MOVES = ((-1, 0), (0, 1), (1, 0), (0, -1))


def _world(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(fstar, costs, table)``: actions 0-3 the moves (cost 1 or 2), action 4 a reading (cost 1)
    whose one part reads one of three values, alike in most cells."""
    rng = np.random.default_rng(seed)
    rows = cols = 3
    wall = rng.random((rows, cols, 4)) < 0.25
    fstar = np.tile(np.arange(rows * cols), (5, 1))
    for r, c, k in itertools.product(range(rows), range(cols), range(4)):
        dr, dc = _MOVES[k]
        if 0 <= r + dr < rows and 0 <= c + dc < cols and not wall[r, c, k]:
            fstar[k, r * cols + c] = (r + dr) * cols + c + dc
    costs = np.array([1.0, 2.0, 1.0, 2.0, 1.0])
    common = np.array([0.8, 0.1, 0.1])
    table = np.tile(common, (rows * cols, 1))
    for s in rng.choice(rows * cols, size=3, replace=False):
        table[s] = rng.dirichlet(np.ones(3))
    return fstar, costs, table


def telling_macro(*args: Any, **kwargs: Any) -> TellingMacro | None:
    found = telling_macros(*args, **kwargs)
    return found[0] if found else None


def _kl(p: np.ndarray, q: np.ndarray) -> float:
    return float(np.sum(p * np.log(p / q)))


def test_the_evidence_of_a_reading_is_the_mean_log_likelihood_ratio_of_the_true_place() -> None:
    p, q = np.array([0.7, 0.2, 0.1]), np.array([0.2, 0.5, 0.3])
    weights = np.array([0.9, 0.1])
    expected = 0.9 * _kl(p, q) + 0.1 * _kl(q, p)
    assert which_place_evidence([np.stack([p, q])], weights) == pytest.approx(expected, rel=1e-12)
    # two independent parts add; two places that read alike give none
    assert which_place_evidence([np.stack([p, q])] * 2, weights) == pytest.approx(2 * expected, rel=1e-12)
    assert which_place_evidence([np.stack([p, p])], weights) == pytest.approx(0.0, abs=1e-15)


@pytest.mark.parametrize("seed", range(12))
def test_the_macro_is_the_best_evidence_per_cost_of_every_move_sequence(seed: int) -> None:
    """Against brute force: every sequence of up to 6 moves along which the two places never meet,
    then the reading; worth ``min(evidence, needed) / cost``."""
    fstar, costs, table = _world(seed)
    rng = np.random.default_rng(100 + seed)
    a, b = (int(s) for s in rng.choice(9, size=2, replace=False))
    weights = np.array([0.9, 0.1])
    goal = 0.99
    needed = math.log(goal / (1 - goal)) - math.log(0.9 / 0.1)
    places = [(np.array([a]), np.array([0.9 * 0.995])), (np.array([b]), np.array([0.1 * 0.995]))]
    macro = telling_macro(fstar, costs, range(4), {4: [table]}, places, goal)

    best = 0.0
    for length in range(7):
        for path in itertools.product(range(4), repeat=length):
            x, y, merged = a, b, False
            for move in path:
                x, y = int(fstar[move, x]), int(fstar[move, y])
                merged |= x == y
            if merged:
                continue
            evidence = which_place_evidence([table[[x, y]]], weights)
            best = max(best, min(evidence, needed) / (sum(costs[m] for m in path) + costs[4]))
    if best == 0.0:
        assert macro is None
        return
    assert macro is not None
    assert macro.reading == 4
    x, y = a, b
    for move in macro.moves:
        x, y = int(fstar[move, x]), int(fstar[move, y])
    assert macro.evidence == pytest.approx(which_place_evidence([table[[x, y]]], weights), rel=1e-9)
    assert macro.cost == pytest.approx(sum(costs[m] for m in macro.moves) + costs[4])
    assert min(macro.evidence, needed) / macro.cost == pytest.approx(best, rel=1e-9)


def test_a_reading_already_taken_there_and_a_move_found_blocked_there_are_not_offered_again() -> None:
    """A corridor of five cells, the places at cells 1 and 3: they read alike except at the ends,
    where a reading tells them apart -- well at cell 0 (the first place's end), a little at cell 4."""
    n = 5
    fstar = np.tile(np.arange(n), (3, 1))
    fstar[0, 1:] = np.arange(n - 1)  # west
    fstar[1, :-1] = np.arange(1, n)  # east
    costs = np.array([1.0, 1.0, 1.0])
    table = np.tile([0.5, 0.5], (n, 1))
    table[0] = [0.99, 0.01]
    table[4] = [0.4, 0.6]
    places = [(np.array([1]), np.array([0.6])), (np.array([3]), np.array([0.39]))]
    west = telling_macro(fstar, costs, [0, 1], {2: [table]}, places, 0.99)
    assert west is not None and west.moves == (0,) and west.reading == 2  # one step west: the first place's end
    # the west move was found blocked where the robot stands: not west first (the best left is a
    # detour by the east wall, which shifts the places until the first one reaches cell 0)
    blocked = telling_macro(fstar, costs, [0, 1], {2: [table]}, places, 0.99, lambda path: {0} if not path else set())
    assert blocked is not None and blocked.moves == (1, 1, 0, 0, 0)
    # the reading was already taken one step west (the robot was there): a second step west, the
    # first place stopped by the wall at cell 0 and the second one closing in, reads there again
    read = telling_macro(fstar, costs, [0, 1], {2: [table]}, places, 0.99, lambda path: {2} if path == (0,) else set())
    assert read is not None and read.moves == (0, 0)
    # nothing reads differently anywhere: no macro
    flat = np.tile([0.5, 0.5], (n, 1))
    assert telling_macro(fstar, costs, [0, 1], {2: [flat]}, places, 0.99) is None


def test_a_place_reads_as_the_mixture_of_its_states() -> None:
    """Two places whose likeliest states read differently, but whose mixtures read alike, are not
    told apart by that reading (the mirror twins' cells are off by one)."""
    fstar = np.tile(np.arange(4), (1, 1))
    costs = np.array([1.0, 1.0])
    table = np.array([[0.9, 0.1], [0.1, 0.9], [0.1, 0.9], [0.9, 0.1]])
    sharp = [(np.array([0]), np.array([0.9])), (np.array([1]), np.array([0.09]))]
    assert telling_macro(fstar, costs, [0], {1: [table]}, sharp, 0.99) is not None
    spread = [(np.array([0, 1]), np.array([0.45, 0.45])), (np.array([2, 3]), np.array([0.045, 0.045]))]
    assert telling_macro(fstar, costs, [0], {1: [table]}, spread, 0.99) is None


def test_the_best_macros_come_best_first_each_to_its_own_node() -> None:
    for seed in range(6):
        fstar, costs, table = _world(seed)
        places = [(np.array([0]), np.array([0.9])), (np.array([8]), np.array([0.095]))]
        found = telling_macros(fstar, costs, range(4), {4: [table]}, places, 0.99, count=4)
        likeliest = 0.9 / 0.995
        needed = math.log(99) - math.log(likeliest / (1 - likeliest))
        worth = [min(m.evidence, needed) / m.cost for m in found]
        assert worth == sorted(worth, reverse=True)
        assert len({m.moves for m in found}) == len(found)
        if found:
            assert found[0] == telling_macro(fstar, costs, range(4), {4: [table]}, places, 0.99)


def test_two_readings_of_equal_worth_at_one_node_are_both_offered() -> None:
    """Two sensors that read the same at every node: each node offers both, in action order."""
    fstar, costs, table = _world(1)
    costs = np.append(costs, 1.0)
    fstar = np.vstack([fstar, np.arange(9)])
    places = [(np.array([0]), np.array([0.9])), (np.array([8]), np.array([0.095]))]
    found = telling_macros(fstar, costs, range(4), {4: [table], 5: [table]}, places, 0.99, count=6)
    assert found and [m.reading for m in found[:2]] == [4, 5] and found[0].moves == found[1].moves


def test_few_places_is_a_pair_that_holds_the_goal_between_them() -> None:
    def place(mass: float) -> tuple[np.ndarray, np.ndarray]:
        return np.array([0]), np.array([mass])

    pair = few_places([place(0.004), place(0.9), place(0.096)], 0.99)
    assert pair is not None and [float(m.sum()) for _, m in pair] == [0.9, 0.096]
    assert few_places([place(0.995), place(0.005)], 0.99) is None  # one place holds the goal
    assert few_places([place(0.6), place(0.3), place(0.1)], 0.99) is None  # three places
    assert few_places([place(0.6), place(0.3), place(0.1)], 0.99, most=3) is not None
