"""Verdicts before search: goals that no plan can reach, known in the time ``macros build`` needs.

Best-first search proves that there is no plan only by searching every reachable belief, which on a
map with look-alike places takes until the budget runs out. Two cheap arguments settle the common
cases first. Both are *sound*: when they say "unreachable" no plan exists; when they cannot tell,
they say nothing and the search runs as before.

**Twins.** Two states are twins when they read alike on every sensor and, under every action, move
alike: the same probability of the intended move (the rest of the mass stays put, as a map's
``failure`` does) to two states that are again twins and not the same state. Twins are the greatest
set of indistinguishable pairs closed under the actions (Khalvati & Mackworth's never-separable
pairs, without the pairs whose states meet: meeting helps localization). Whatever the robot does
and sees, the belief mass that started on one twin follows branches that are matched, with equal
probabilities and equal likelihoods, by the mass that started on the other, which always sits on
another state. So if the start belief's support can be split into twin pairs whose masses are within
a ratio ``m <= 1`` of each other, no state ever holds more than ``1 / (1 + m)``: a threshold above
that is out of reach (with a uniform belief: above 1/2).

**Certainty.** A threshold of 1 needs every other state ruled out. When every reading has some
probability in every state (noisy sensors) and every move may fail and stay put, no state ever
leaves the support: from a belief on two or more states, 1 is out of reach.

Pure numpy; no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from beliefloc.model import Model
from beliefloc.planning.ec2 import full_parts, most_likely_successors, signature
from beliefloc.planning.macros import count_indistinguishable_pairs, indistinguishable_pairs, sorted_distinct

MAX_TWIN_PAIRS = 2_000_000
"""Above this many look-alike pairs the twin check is skipped (it would cost more than it saves)."""
_TOLERANCE = 1e-12


@dataclass(frozen=True)
class Unreachable:
    """Why no plan can take the start belief to ``threshold``."""

    threshold: float
    bound: float
    """No reachable belief gives any state more than this."""
    reason: str
    """One sentence, for people."""
    look_alikes: tuple[tuple[int, int], ...] = ()
    """Twin pairs that split the start belief (all of them), by state index."""


def twin_pairs(model: Model, max_pairs: int = MAX_TWIN_PAIRS) -> tuple[np.ndarray, np.ndarray] | None:
    """All twin pairs ``(i, j)``, ``i < j`` (module docstring), or None when the model's moves are
    not of the supported form (each row: the intended successor and possibly staying put) or there
    are more than ``max_pairs`` look-alike pairs to examine."""
    n = model.n_states
    sig = signature(full_parts(model), n)
    if count_indistinguishable_pairs(sig) > max_pairs:
        return None
    pi, pj = indistinguishable_pairs(sig)
    if len(pi) == 0:
        return pi, pj
    fstar, pstar = most_likely_successors(model)
    if not _moves_stay_or_go(model, fstar):
        return None
    keys = pi.astype(np.int64) * n + pj
    n_pairs = len(pi)
    dead = np.zeros(n_pairs, dtype=bool)
    src_parts, dst_parts = [], []
    for k, action in enumerate(model.actions):
        if action.transition is None:
            continue
        fi, fj = fstar[k, pi], fstar[k, pj]
        lo, hi = np.minimum(fi, fj), np.maximum(fi, fj)
        alike = (lo != hi) & (sig[lo] == sig[hi]) & (np.abs(pstar[k, pi] - pstar[k, pj]) <= _TOLERANCE)
        dead |= ~alike
        src = np.flatnonzero(alike)
        dst = np.searchsorted(keys, lo[alike].astype(np.int64) * n + hi[alike])
        keep = src != dst
        src_parts.append(src[keep])
        dst_parts.append(dst[keep])
    src = np.concatenate(src_parts) if src_parts else np.zeros(0, dtype=np.int64)
    dst = np.concatenate(dst_parts) if dst_parts else np.zeros(0, dtype=np.int64)
    # a pair whose successor is not a twin is not one either: spread "dead" backwards along the moves
    order = np.argsort(dst, kind="stable")
    rev_src = src[order]
    rev_ptr = np.zeros(n_pairs + 1, dtype=np.int64)
    np.cumsum(np.bincount(dst, minlength=n_pairs), out=rev_ptr[1:])
    frontier = np.flatnonzero(dead)
    while len(frontier):
        starts, ends = rev_ptr[frontier], rev_ptr[frontier + 1]
        counts = ends - starts
        total = int(counts.sum())
        if total == 0:
            break
        edge = np.repeat(starts - np.cumsum(counts) + counts, counts) + np.arange(total)
        pred = sorted_distinct(rev_src[edge])
        frontier = pred[~dead[pred]]
        dead[frontier] = True
    return pi[~dead], pj[~dead]


def _moves_stay_or_go(model: Model, fstar: np.ndarray) -> bool:
    """Every move's row holds its intended successor (the likeliest) and at most the state itself."""
    n = model.n_states
    for k, action in enumerate(model.actions):
        t = action.transition
        if t is None:
            continue
        t = t.tocsr()
        per_row = np.diff(t.indptr)
        if per_row.max(initial=0) > 2:
            return False
        rows = np.repeat(np.arange(n), per_row)
        if not np.all((t.indices == fstar[k, rows]) | (t.indices == rows)):
            return False
        two = np.flatnonzero(per_row == 2)
        if np.any(fstar[k, two] == two):  # staying is the likelier branch: the pairing below would not hold
            return False
    return True


def unreachable_goal(model: Model, belief: np.ndarray, threshold: float) -> Unreachable | None:
    """Why no plan from ``belief`` reaches ``threshold``, when that is known without search."""
    support = np.flatnonzero(belief > 0)
    if len(support) < 2 or float(belief.max()) >= threshold:
        return None
    certain = _certainty_out_of_reach(model, threshold)
    if certain is not None:
        return certain
    twins = twin_pairs(model)
    if twins is None or len(twins[0]) == 0:
        return None
    matching = _match(twins, support)
    if matching is None:
        return None
    a, b = matching[:, 0], matching[:, 1]
    ratio = float(np.min(np.minimum(belief[a], belief[b]) / np.maximum(belief[a], belief[b])))
    bound = 1.0 / (1.0 + ratio)
    if threshold <= bound + _TOLERANCE:
        return None
    pairs = tuple((int(i), int(j)) for i, j in matching)
    return Unreachable(
        threshold,
        bound,
        f"the start belief lies on {len(pairs)} pair{'s' if len(pairs) != 1 else ''} of look-alike states: "
        "each pair reads alike on every sensor and moves alike under every action, so no sequence of actions "
        f"and observations tells them apart, and no state can ever hold more than {bound:.3g}",
        pairs,
    )


def _certainty_out_of_reach(model: Model, threshold: float) -> Unreachable | None:
    if threshold < 1.0:
        return None
    for action in model.actions:
        t = action.transition
        if t is not None and np.any(t.diagonal() <= 0):
            return None  # a move that surely leaves a state can rule it out
        for part in action.observation.parts:
            used = np.unique(part.truth)
            if np.any(part.confusion[used] <= 0):
                return None  # a reading impossible in some state rules that state out
    return Unreachable(
        threshold,
        1.0,
        "every sensor reading has some probability in every state and every move may fail and stay put, "
        "so no state is ever ruled out and none can hold probability 1; use a threshold below 1",
    )


def _match(twins: tuple[np.ndarray, np.ndarray], support: np.ndarray) -> np.ndarray | None:
    """A perfect matching of ``support`` by twin pairs (greedy, in pair order), or None."""
    inside = np.zeros(max(int(support.max()), int(twins[1].max(initial=0))) + 1, dtype=bool)
    inside[support] = True
    pi, pj = twins
    keep = inside[pi] & inside[pj]
    used = np.zeros_like(inside)
    chosen: list[tuple[int, int]] = []
    for i, j in zip(pi[keep].tolist(), pj[keep].tolist(), strict=True):
        if not used[i] and not used[j]:
            used[i] = used[j] = True
            chosen.append((i, j))
    if 2 * len(chosen) != len(support):
        return None
    return np.array(chosen, dtype=np.int64)
