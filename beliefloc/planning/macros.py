"""Minimum-cost macro actions over pairs of states: Khalvati & Mackworth, Sec. V and Algorithm 2.

Pure numpy, no I/O (files: :mod:`beliefloc.files.macro_file`).

**The pair graph.** A node is an unordered pair of states ``{s_i, s_j}`` that no sensor tells apart
where they stand: their noise-free readings of every sensor are equal (the paper's ``d <= gamma``;
:mod:`beliefloc.planning.ec2` explains why, with the default gamma, that is the same). An actuation
action ``a`` leads from ``{s_i, s_j}`` to ``{f*(s_i, a), f*(s_j, a)}`` at the cost ``C(s_i, s_j, a)``
(Eq. 7). A pair whose successor is distinguishable is done after ``a``; one whose two states meet
(``f*(s_i, a) = f*(s_j, a)``, ``d = 0``) is a dead end, as in the paper. Perception actions do not
move, so they never lead anywhere new.

**Algorithm 2 as a shortest path.** The paper's rounds define every pair's macro by the least cost
of reaching a distinguishable pair, settling the cheapest pairs of each round first -- Dijkstra's
algorithm with the distinguishable pairs as sources, run *backwards* along the actions. Here it runs
level by level: all pairs whose tentative cost is the current minimum are settled at once, and their
predecessors under every action are relaxed with numpy. Each pair is touched about once per action;
``tests/test_macros.py`` keeps a literal transcription of the paper's rounds as the reference.

**Only the indistinguishable pairs exist.** States are grouped by their signature (the noise-free
readings of every sensor); the pairs are those inside a group, enumerated with numpy -- never an
``|S| x |S|`` array. For each pair we store its cost, its first action and the pair it leads to, so
every macro is recovered by following pointers. Pairs that no sequence distinguishes (cost ``inf``)
are the localizability verdict: if the robot is in one of them, it can never tell which.

Ties: on equal cost the first action in model order wins, then the successor found first.

**Too many pairs for a table.** A map whose sensors leave more than :data:`DEFAULT_MAX_PAIRS` pairs
alike (the depot's one-beam scan: 206 million) gets no table; a selection asks only for the pairs of its
top hypotheses, and :class:`MacroSearch` finds each one's macro when first asked, by a Dijkstra forward
from the pair over the same graph (:func:`search_macros`): the same least costs as the table's.
"""

from __future__ import annotations

import heapq
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, Protocol

import numpy as np
import scipy.sparse as sp

from beliefloc.errors import InvalidValueError
from beliefloc.model import Model
from beliefloc.planning.ec2 import PairContext, gamma_bounds, pair_context

DEFAULT_MAX_PAIRS = 100_000_000
"""Refuse maps with more indistinguishable pairs than this (about 3 GB of tables)."""
_EPS = 1e-9

Progress = Callable[[int, int], None]
"""``progress(pairs_settled, pairs_total)``."""


@dataclass(frozen=True, eq=False)
class MacroTable:
    """Every indistinguishable pair's macro, as pointers. Arrays are indexed by pair number; pairs
    are sorted by ``pair_i * n_states + pair_j`` with ``pair_i < pair_j``."""

    n_states: int
    gamma: float
    action_names: tuple[str, ...]
    fingerprint: str
    pair_i: np.ndarray
    pair_j: np.ndarray
    cost: np.ndarray
    """Least cost of a sequence that makes the pair distinguishable; ``inf`` when there is none."""
    first_action: np.ndarray
    """Index into ``action_names``; -1 when never distinguishable."""
    next_pair: np.ndarray
    """The pair ``(f*(s_i, a), f*(s_j, a))`` reached, or -1 when that pair is distinguishable."""
    length: np.ndarray
    """Number of basic actions of the macro (0 when never distinguishable)."""
    macro_id: np.ndarray
    """Which distinct action sequence the pair's macro is (-1 when never distinguishable)."""
    macro_first: np.ndarray
    """Per distinct macro: its first action."""
    macro_next: np.ndarray
    """Per distinct macro: the distinct macro that follows its first action, or -1."""
    seconds: float = 0.0

    @property
    def n_pairs(self) -> int:
        return len(self.pair_i)

    @property
    def n_macros(self) -> int:
        return len(self.macro_first)

    def find(self, i: np.ndarray | int, j: np.ndarray | int) -> np.ndarray:
        """The pair numbers of ``(i, j)`` (either order), -1 where the pair is not in the table."""
        a, b = np.minimum(i, j), np.maximum(i, j)
        key = np.asarray(a, dtype=np.int64) * self.n_states + np.asarray(b, dtype=np.int64)
        keys = self.keys
        pos = np.searchsorted(keys, key)
        pos = np.minimum(pos, max(len(keys) - 1, 0))
        found = (len(keys) > 0) & (keys[pos] == key) if len(keys) else np.zeros(np.shape(key), dtype=bool)
        result: np.ndarray = np.where(found & (a != b), pos, -1)
        return result

    @cached_property
    def keys(self) -> np.ndarray:
        """``pair_i * n_states + pair_j``, sorted (computed once: :meth:`find` runs every step)."""
        keys: np.ndarray = self.pair_i.astype(np.int64) * self.n_states + self.pair_j.astype(np.int64)
        return keys

    def macro_ids(self, i: np.ndarray, j: np.ndarray) -> np.ndarray:
        """The distinct macro of each pair ``(i, j)``, -1 where the pair has none or is not in the table."""
        pairs = self.find(i, j)
        ids: np.ndarray = (
            np.where(pairs >= 0, self.macro_id[np.maximum(pairs, 0)], -1)
            if self.n_pairs
            else np.full(np.shape(pairs), -1)
        )
        return ids

    def tie_keys(self, ids: np.ndarray) -> np.ndarray:
        return ids

    def sequence(self, macro: int) -> tuple[int, ...]:
        """The action indices of distinct macro ``macro``."""
        out = []
        while macro >= 0:
            out.append(int(self.macro_first[macro]))
            macro = int(self.macro_next[macro])
        return tuple(out)

    def pair_sequence(self, pair: int) -> tuple[int, ...]:
        """The actions of a pair's macro (empty when never distinguishable)."""
        return self.sequence(int(self.macro_id[pair])) if pair >= 0 else ()

    def never(self) -> np.ndarray:
        """Pair numbers that can never be distinguished."""
        return np.flatnonzero(~np.isfinite(self.cost))

    def never_classes(self) -> list[list[int]]:
        """The states of never-distinguishable pairs, grouped (connected by such pairs), each sorted,
        the classes in order of their first state."""
        from scipy.sparse.csgraph import connected_components  # here: it imports scipy.sparse.linalg (0.1 s)

        never = self.never()
        if len(never) == 0:
            return []
        i, j = self.pair_i[never], self.pair_j[never]
        graph = sp.coo_matrix((np.ones(len(never)), (i, j)), shape=(self.n_states, self.n_states)).tocsr()
        _, labels = connected_components(graph, directed=False)
        involved = sorted_distinct(np.concatenate([i, j]))
        classes: dict[int, list[int]] = {}
        for s in involved.tolist():
            classes.setdefault(int(labels[s]), []).append(s)
        return sorted(classes.values(), key=lambda c: c[0])

    def summary(self) -> dict[str, float | int]:
        """The numbers ``macros build`` reports."""
        ok = np.isfinite(self.cost)
        lengths = self.length[ok]
        return {
            "states": self.n_states,
            "indistinguishable_pairs": self.n_pairs,
            "macros": self.n_macros,
            "pairs_with_macro": int(ok.sum()),
            "max_length": int(lengths.max()) if len(lengths) else 0,
            "mean_length": float(lengths.mean()) if len(lengths) else 0.0,
            "never_distinguishable_pairs": int((~ok).sum()),
            "gamma": self.gamma,
            "seconds": self.seconds,
        }


def indistinguishable_pairs(signature: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """All pairs ``i < j`` with equal signature, sorted by ``i * n + j``; vectorised, never ``|S|^2``."""
    n = len(signature)
    order = np.lexsort((np.arange(n), signature))
    sig = signature[order]
    start = np.ones(n, dtype=bool)
    start[1:] = sig[1:] != sig[:-1]
    group_start = np.maximum.accumulate(np.where(start, np.arange(n), 0))
    sizes = np.diff(np.append(np.flatnonzero(start), n))
    group_end = np.repeat(np.flatnonzero(start) + sizes, sizes)  # one past the group's last position
    partners = group_end - np.arange(n) - 1  # later members of the group
    del group_start
    total = int(partners.sum())
    first = np.repeat(np.arange(n), partners)
    offset = np.arange(total, dtype=np.int64) - np.repeat(np.cumsum(partners) - partners, partners)
    second = first + 1 + offset
    a, b = order[first], order[second]
    i, j = np.minimum(a, b), np.maximum(a, b)
    key = i.astype(np.int64) * n + j
    sort = np.argsort(key, kind="stable")
    return i[sort].astype(np.int32), j[sort].astype(np.int32)


def sorted_distinct(values: np.ndarray) -> np.ndarray:
    """``np.unique`` of a 1-D array, by a sort: for integers with many distinct values NumPy 2.4's
    ``np.unique`` hashes, 40x slower than sorting (a million entries: 1.2 s against 0.03 s here)."""
    out = np.sort(np.ravel(values))
    if out.size > 1:
        keep = np.empty(out.size, dtype=bool)
        keep[0] = True
        np.not_equal(out[1:], out[:-1], out=keep[1:])
        out = out[keep]
    return out


def count_indistinguishable_pairs(signature: np.ndarray) -> int:
    if signature.size and int(signature.min()) >= 0 and int(signature.max()) < signature.size:
        counts = np.bincount(signature)  # a compact signature (ec2.signature's): counted, not sorted
        return int((counts * (counts - 1) // 2).sum())
    _, counts = np.unique(signature, return_counts=True)
    return int((counts * (counts - 1) // 2).sum())


def check_gamma(model: Model, ctx: PairContext) -> None:
    lo, hi = gamma_bounds(model)
    if not lo <= ctx.gamma < hi:
        raise InvalidValueError(
            f"gamma {ctx.gamma:g} is outside [{lo:.4g}, {hi:.4g}), the range in which 'distinguishable' means "
            "'different noise-free readings' for this model's sensors; macros are built on that grouping. "
            "Leave gamma unset for the default (the middle of the range)."
        )


def pair_macros(model: Model, context: PairContext, *, max_pairs: int = DEFAULT_MAX_PAIRS) -> PairMacros:
    """The macros a selection draws on: the whole table (Algorithm 2) when its pairs fit in
    ``max_pairs``, else a :class:`MacroSearch` that finds the pairs asked for."""
    if count_indistinguishable_pairs(context.full_signature) > max_pairs:
        check_gamma(model, context)
        return MacroSearch(context)
    return build_macros(model, context=context, max_pairs=max_pairs)


def build_macros(
    model: Model,
    gamma: float | None = None,
    *,
    context: PairContext | None = None,
    max_pairs: int = DEFAULT_MAX_PAIRS,
    progress: Progress | None = None,
) -> MacroTable:
    """Algorithm 2 as a backward Dijkstra over the indistinguishable pairs (module docstring)."""
    import time

    started = time.perf_counter()
    ctx = context if context is not None else pair_context(model, gamma)
    check_gamma(model, ctx)
    n = model.n_states
    sig = ctx.full_signature
    total = count_indistinguishable_pairs(sig)
    if total > max_pairs:
        raise InvalidValueError(
            f"{model.name}: {total:,} pairs of states look alike, more than the {max_pairs:,} a macro table "
            "may hold; give the robot a sensor that tells more places apart (`simulate -s ec2-macros` needs no "
            "table: it searches the macros of the pairs it meets)"
        )
    pi, pj = indistinguishable_pairs(sig)
    keys = pi.astype(np.int64) * n + pj
    n_pairs = len(pi)
    dist = np.full(n_pairs, np.inf)
    first = np.full(n_pairs, -1, dtype=np.int16)
    nxt = np.full(n_pairs, -1, dtype=np.int64)
    src_parts, dst_parts, act_parts = [], [], []
    moving = [k for k, a in enumerate(model.actions) if a.transition is not None]
    for a in moving:
        fi, fj = ctx.fstar[a, pi], ctx.fstar[a, pj]
        lo_s, hi_s = np.minimum(fi, fj), np.maximum(fi, fj)
        merged = lo_s == hi_s
        same = sig[lo_s] == sig[hi_s]
        done = ~same  # distinguishable after a: the macro ends here
        better = done & (ctx.costs[a] < dist - _EPS)
        dist[better] = ctx.costs[a]
        first[better] = a
        nxt[better] = -1
        inside = same & ~merged
        src = np.flatnonzero(inside)
        dst = np.searchsorted(keys, lo_s[inside] * n + hi_s[inside])
        keep = src != dst  # a self-loop never helps
        src_parts.append(src[keep])
        dst_parts.append(dst[keep])
        act_parts.append(np.full(int(keep.sum()), a, dtype=np.int16))
        del fi, fj, lo_s, hi_s, merged, same, done, better, inside
    src = np.concatenate(src_parts) if src_parts else np.zeros(0, dtype=np.int64)
    dst = np.concatenate(dst_parts) if dst_parts else np.zeros(0, dtype=np.int64)
    act = np.concatenate(act_parts) if act_parts else np.zeros(0, dtype=np.int16)
    del src_parts, dst_parts, act_parts
    order = np.argsort(dst, kind="stable")  # reverse adjacency: edges into each pair, action order kept
    rev_src, rev_act = src[order], act[order]
    rev_ptr = np.zeros(n_pairs + 1, dtype=np.int64)
    np.cumsum(np.bincount(dst, minlength=n_pairs), out=rev_ptr[1:])
    del src, dst, act, order

    settled = np.zeros(n_pairs, dtype=bool)
    length = np.zeros(n_pairs, dtype=np.int32)
    buckets: dict[float, list[np.ndarray]] = {}
    heap: list[float] = []
    for value in np.unique(dist[np.isfinite(dist)]).tolist():
        buckets[value] = [np.flatnonzero(dist == value)]
        heapq.heappush(heap, value)
    done_count = 0
    while heap:
        level = heapq.heappop(heap)
        frontier = sorted_distinct(np.concatenate(buckets.pop(level)))
        frontier = frontier[~settled[frontier] & (dist[frontier] == level)]
        if len(frontier) == 0:
            continue
        settled[frontier] = True
        follow = nxt[frontier]
        length[frontier] = 1 + np.where(follow >= 0, length[np.maximum(follow, 0)], 0)
        done_count += len(frontier)
        if progress is not None:
            progress(done_count, n_pairs)
        starts, ends = rev_ptr[frontier], rev_ptr[frontier + 1]
        counts = ends - starts
        if counts.sum() == 0:
            continue
        edge = np.repeat(starts - np.cumsum(counts) + counts, counts) + np.arange(int(counts.sum()))
        target = np.repeat(frontier, counts)
        pred, pa = rev_src[edge], rev_act[edge].astype(np.int64)
        cand = level + ctx.costs[pa]
        ok = ~settled[pred] & (cand < dist[pred] - _EPS)
        pred, pa, cand, target = pred[ok], pa[ok], cand[ok], target[ok]
        if len(pred) == 0:
            continue
        pick = np.lexsort((target, pa, cand, pred))  # per predecessor: cheapest, then first action
        pred, pa, cand, target = pred[pick], pa[pick], cand[pick], target[pick]
        firsts = np.ones(len(pred), dtype=bool)
        firsts[1:] = pred[1:] != pred[:-1]
        pred, pa, cand, target = pred[firsts], pa[firsts], cand[firsts], target[firsts]
        dist[pred] = cand
        first[pred] = pa
        nxt[pred] = target
        for value in np.unique(cand).tolist():
            if value not in buckets:
                buckets[value] = []
                heapq.heappush(heap, value)
            buckets[value].append(pred[cand == value])
    macro_id, macro_first, macro_next = _distinct_macros(first, nxt, length)
    return MacroTable(
        n_states=n,
        gamma=ctx.gamma,
        action_names=tuple(a.name for a in model.actions),
        fingerprint=model.fingerprint(),
        pair_i=pi,
        pair_j=pj,
        cost=dist,
        first_action=first,
        next_pair=nxt,
        length=length,
        macro_id=macro_id,
        macro_first=macro_first,
        macro_next=macro_next,
        seconds=time.perf_counter() - started,
    )


# --- the pairs asked for, searched when asked (maps whose table would be too big) -----------------

SEARCH_MAX_SETTLED = 512
"""A searched pair's budget: pairs settled before it is given up as having no macro. The depot's
hardest pairs settle under 200; a featureless floor, where no pair is ever told apart, settles the
budget for every pair asked (about 2,000 a selection)."""


class PairMacros(Protocol):
    """Where :func:`macro_candidates` gets a pair's macro: a whole table, or a search per pair."""

    def macro_ids(self, i: np.ndarray, j: np.ndarray) -> np.ndarray:
        """The macro of each pair ``(i, j)``, -1 where the pair has none (or is told apart already)."""
        ...

    def tie_keys(self, ids: np.ndarray) -> np.ndarray:
        """An order of macros for equally weighted pairs that does not depend on what was asked before."""
        ...

    def sequence(self, macro: int) -> tuple[int, ...]: ...


def search_macros(
    ctx: PairContext, pair_i: np.ndarray, pair_j: np.ndarray, *, max_settled: int = SEARCH_MAX_SETTLED
) -> list[tuple[int, ...] | None]:
    """Each pair's least-cost macro, by a Dijkstra forward from the pair over the same pair graph as
    :func:`build_macros` (the module docstring), every pair searched on its own; None when no macro
    was found within ``max_settled`` settled pairs -- never distinguishable, or too far to matter.

    The cost of every macro found equals the table's (``tests/test_macros.py``); on equal costs it
    may be another sequence than the table's. Nodes are ``pair number * n^2 + i * n + j``, so one
    vectorised search serves every pair asked for."""
    n = ctx.model.n_states
    sig = ctx.full_signature
    moving = [k for k, a in enumerate(ctx.model.actions) if a.transition is not None]
    count = len(pair_i)
    found: list[tuple[int, ...] | None] = [None] * count
    if count == 0 or not moving:
        return found
    span = np.int64(n) * n
    cheapest = float(ctx.costs[moving].min())
    start = np.arange(count, dtype=np.int64) * span + np.asarray(pair_i, dtype=np.int64) * n + np.asarray(pair_j)
    best = np.full(count, np.inf)
    last_node = np.full(count, -1, dtype=np.int64)
    last_action = np.full(count, -1, dtype=np.int64)
    settled_count = np.zeros(count, dtype=np.int64)
    settled = np.zeros(0, dtype=np.int64)
    # every settled node with the node and action it was reached from, one array per level
    tree: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    none = np.full(count, -1, dtype=np.int64)
    buckets: dict[float, list[tuple[np.ndarray, np.ndarray, np.ndarray]]] = {0.0: [(start, none, none)]}
    heap = [0.0]
    while heap:
        level = heapq.heappop(heap)
        keys, parents, actions = (np.concatenate(part) for part in zip(*buckets.pop(level), strict=True))
        pick = np.lexsort((actions, parents, keys))  # per node: the first parent, then the first action
        keys, parents, actions = keys[pick], parents[pick], actions[pick]
        firsts = np.ones(len(keys), dtype=bool)
        firsts[1:] = keys[1:] != keys[:-1]
        keys, parents, actions = keys[firsts], parents[firsts], actions[firsts]
        src = keys // span
        fresh = ~np.isin(keys, settled, assume_unique=True)
        fresh &= level + cheapest < best[src] - _EPS  # nothing from here can beat the macro found
        fresh &= settled_count[src] < max_settled
        keys, parents, actions, src = keys[fresh], parents[fresh], actions[fresh], src[fresh]
        if len(keys) == 0:
            continue
        settled = np.insert(settled, np.searchsorted(settled, keys), keys)  # both sorted, none in common
        np.add.at(settled_count, src, 1)
        tree.append((keys, parents, actions))
        fi, fj = (keys % span) // n, keys % n
        for a in moving:
            si, sj = ctx.fstar[a, fi], ctx.fstar[a, fj]
            lo, hi = np.minimum(si, sj), np.maximum(si, sj)
            cost = level + float(ctx.costs[a])
            told = sig[lo] != sig[hi]
            better = np.flatnonzero(told & (cost < best[src] - _EPS))
            if len(better):  # the first node of each pair's search (keys are sorted) ends its macro here
                _, first = np.unique(src[better], return_index=True)
                better = better[first]
                best[src[better]] = cost
                last_node[src[better]] = keys[better]
                last_action[src[better]] = a
            going = ~told & (lo != hi)  # a merged pair is a dead end
            if not going.any():
                continue
            nxt = src[going] * span + lo[going].astype(np.int64) * n + hi[going]
            if cost not in buckets:
                buckets[cost] = []
                heapq.heappush(heap, cost)
            buckets[cost].append((nxt, keys[going], np.full(len(nxt), a, dtype=np.int64)))
    done = np.flatnonzero(np.isfinite(best))
    if len(done) == 0:
        return found
    nodes, ups, via = (np.concatenate(part) for part in zip(*tree, strict=True))
    order = np.argsort(nodes)
    nodes, ups, via = nodes[order], ups[order], via[order]
    # walk every macro back to its pair at once, a step per round
    steps = [last_action[done]]
    node = last_node[done]
    while True:
        walking = node != start[done]
        if not walking.any():
            break
        at = np.searchsorted(nodes, node[walking])
        step = np.full(len(done), -1, dtype=np.int64)
        step[walking] = via[at]
        steps.append(step)
        node = node.copy()
        node[walking] = ups[at]
    table = np.stack(steps[::-1], axis=1)  # -1 before a shorter macro's first action
    for row, p in zip(table.tolist(), done.tolist(), strict=True):
        found[p] = tuple(a for a in row if a >= 0)
    return found


@dataclass(eq=False)
class MacroSearch:
    """The macros of the pairs asked for, each searched when first asked (:func:`search_macros`) and
    remembered: for a map whose look-alike pairs are too many for a :class:`MacroTable` (the depot's
    one-beam scan leaves 206 million), where a selection only ever asks for its top hypotheses'
    pairs. A pair's macro does not depend on what was asked before, so the runs stay reproducible."""

    context: PairContext
    max_settled: int = SEARCH_MAX_SETTLED
    _macro_of_pair: dict[int, int] = field(default_factory=dict)
    _sequences: list[tuple[int, ...]] = field(default_factory=list)
    _ids: dict[tuple[int, ...], int] = field(default_factory=dict)

    def macro_ids(self, i: np.ndarray, j: np.ndarray) -> np.ndarray:
        n = self.context.model.n_states
        sig = self.context.full_signature
        a, b = np.minimum(i, j).astype(np.int64), np.maximum(i, j).astype(np.int64)
        keys = a * n + b
        ask = (a != b) & (sig[a] == sig[b])
        new = sorted({k for k in keys[ask].tolist() if k not in self._macro_of_pair})
        if new:
            news = np.array(new, dtype=np.int64)
            for key, sequence in zip(
                new, search_macros(self.context, news // n, news % n, max_settled=self.max_settled), strict=True
            ):
                self._macro_of_pair[key] = -1 if sequence is None else self._id(sequence)
        return np.array(
            [self._macro_of_pair[k] if ok else -1 for k, ok in zip(keys.tolist(), ask.tolist(), strict=True)],
            dtype=np.int64,
        )

    def tie_keys(self, ids: np.ndarray) -> np.ndarray:
        order = sorted(set(ids.tolist()), key=lambda m: (len(self._sequences[m]), self._sequences[m]))
        rank = {m: r for r, m in enumerate(order)}
        return np.array([rank[m] for m in ids.tolist()], dtype=np.int64)

    def sequence(self, macro: int) -> tuple[int, ...]:
        return self._sequences[macro]

    def _id(self, sequence: tuple[int, ...]) -> int:
        if sequence not in self._ids:
            self._ids[sequence] = len(self._sequences)
            self._sequences.append(sequence)
        return self._ids[sequence]


def _distinct_macros(first: np.ndarray, nxt: np.ndarray, length: np.ndarray) -> tuple[np.ndarray, ...]:
    """Hash-cons the macros: a macro is (first action, the distinct macro after it). Shortest first,
    so the macro after the first action always has its id already."""
    macro_id = np.full(len(first), -1, dtype=np.int64)
    firsts: list[np.ndarray] = []
    nexts: list[np.ndarray] = []
    count = 0
    for k in np.unique(length[length > 0]).tolist():
        members = np.flatnonzero(length == k)
        follow = np.where(nxt[members] >= 0, macro_id[np.maximum(nxt[members], 0)], -1)
        combined = first[members].astype(np.int64) * (count + 2) + (follow + 1)
        unique, inverse = np.unique(combined, return_inverse=True)
        macro_id[members] = count + inverse.ravel()
        firsts.append(unique // (count + 2))
        nexts.append(unique % (count + 2) - 1)
        count += len(unique)
    macro_first = np.concatenate(firsts).astype(np.int16) if firsts else np.zeros(0, dtype=np.int16)
    macro_next = np.concatenate(nexts).astype(np.int64) if nexts else np.zeros(0, dtype=np.int64)
    return macro_id, macro_first, macro_next


def expected_path(ctx: PairContext, state: int, actions: tuple[int, ...]) -> list[int]:
    """Eq. 12: the states ``f*`` visits from ``state`` along ``actions`` (the start included)."""
    path = [state]
    for a in actions:
        path.append(int(ctx.fstar[a, path[-1]]))
    return path


def macro_candidates(
    table: PairMacros, states: np.ndarray, belief: np.ndarray, *, limit: int = 32
) -> list[tuple[int, ...]]:
    """Algorithm 3, line 2: the macros of the pairs of hypotheses, those of the most probable pairs
    first, at most ``limit`` distinct ones (Sec. VII-B's reduction, applied to the candidates)."""
    if len(states) < 2:
        return []
    top = states[np.lexsort((states, -belief[states]))][: max(2, min(len(states), 64))]
    ii, jj = np.triu_indices(len(top), 1)
    i, j = top[ii], top[jj]
    ids = table.macro_ids(i, j)
    ok = ids >= 0
    ids, weight = ids[ok], (belief[i] * belief[j])[ok]
    if len(ids) == 0:
        return []
    order = np.lexsort((table.tie_keys(ids), -weight))
    chosen: list[int] = []
    for macro in ids[order].tolist():
        if macro not in chosen:
            chosen.append(int(macro))
            if len(chosen) >= limit:
                break
    return [table.sequence(m) for m in chosen]


@dataclass(frozen=True)
class PairExplanation:
    """Why two states do or do not need a macro (``macros show --pair``): the macro's actions and
    cost, and the path each state is expected to take along it with what it reads at every step
    (``steps`` rows: action, state and reading from ``s_i``, state and reading from ``s_j``)."""

    s_i: str
    s_j: str
    verdict: str
    actions: tuple[str, ...] = ()
    cost: float | None = 0.0
    """None when no sequence of actions ever tells the two apart."""
    steps: tuple[dict[str, str], ...] = ()

    def as_json(self) -> dict[str, Any]:
        return {
            "s_i": self.s_i,
            "s_j": self.s_j,
            "actions": list(self.actions),
            "cost": self.cost,
            "steps": list(self.steps),
            "verdict": self.verdict,
        }


def explain_pair(model: Model, table: MacroTable, i: int, j: int) -> PairExplanation:
    """The macro of states ``i`` and ``j`` with both expected paths (Eq. 12), or why there is none."""
    names = model.states
    if i == j:
        raise InvalidValueError(f"a pair needs two states, got {names.name(i)} twice")
    s_i, s_j = names.name(i), names.name(j)
    p = int(table.find(i, j))
    if p < 0:
        return PairExplanation(s_i, s_j, f"{s_i} and {s_j} are distinguishable where they stand: no macro is needed")
    if not np.isfinite(table.cost[p]):
        return PairExplanation(s_i, s_j, f"{s_i} and {s_j} can never be told apart", cost=None)
    ctx = pair_context(model, table.gamma)
    actions = table.pair_sequence(p)
    path_i, path_j = expected_path(ctx, i, actions), expected_path(ctx, j, actions)
    steps = []
    for k, (a, b) in enumerate(zip(path_i, path_j, strict=True)):
        act = model.actions[actions[k - 1]] if k else None
        steps.append(
            {
                "action": act.name if act else "(start)",
                "at_i": names.name(a),
                "reads_i": act.observation.name(act.observation.true_observation(a)) if act else "-",
                "at_j": names.name(b),
                "reads_j": act.observation.name(act.observation.true_observation(b)) if act else "-",
            }
        )
    told = "action tells" if len(actions) == 1 else "actions tell"
    return PairExplanation(
        s_i,
        s_j,
        f"{s_i} and {s_j} look alike; {len(actions)} {told} them apart",
        tuple(model.actions[a].name for a in actions),
        float(table.cost[p]),
        tuple(steps),
    )


def longest_macros(model: Model, table: MacroTable, count: int = 10) -> list[dict[str, Any]]:
    """The ``count`` longest macros (longest first, then by pair), each with its pair and cost."""
    ok = np.flatnonzero(np.isfinite(table.cost))
    order = ok[np.lexsort((ok, -table.length[ok]))][:count]
    return [
        {
            "s_i": model.states.name(int(table.pair_i[p])),
            "s_j": model.states.name(int(table.pair_j[p])),
            "cost": float(table.cost[p]),
            "actions": [table.action_names[a] for a in table.pair_sequence(int(p))],
        }
        for p in order.tolist()
    ]
