"""Pairwise action selection: Khalvati & Mackworth, Sec. IV (the EC2 edge weights) and Sec. VI.

Pure numpy, no I/O. The quantities, with their equations:

* **Observation difference** (Eq. 5) between the states ``s_i`` and ``s_j`` for an observation model
  ``O``: ``d(s_i, s_j) = 1/2 sum_o [p(o|s_i)(1 - p(o|s_j)) + p(o|s_j)(1 - p(o|s_i))]``, which equals
  ``1 - sum_o p(o|s_i) p(o|s_j)``. For a factored observation (``O[j, o] = prod_p C_p[t_p[j], o_p]``)
  that sum factorises: ``sum_o p(o|s_i) p(o|s_j) = prod_p G_p[t_p[i], t_p[j]]`` with the part's
  *overlap* ``G_p = C_p C_pᵀ``, so no joint observation is ever enumerated.
  Which sensors observe: an actuation action's observation (the passive sensors) at the state it
  reaches, a perception action's own sensor. Two states are *distinguishable* when ``d > gamma``.
* **Most likely successor** (Eq. 6) ``f*(s, a) = argmax_s' T_a[s, s']``, ties broken towards the
  lowest state index; ``p*(s, a) = T_a[s, f*(s, a)]``. A perception action has ``f*(s, a) = s``.
* **Pair cost** (Eq. 7) ``C(s_i, s_j, a) = max(C(s_i, a), C(s_j, a))`` -- an action costs the same
  in every state here, so it is the action's cost (for a macro, Eq. 13: the sum of its costs).
* **Edge weight** (Eq. 8) ``w(s_i, s_j, a) = Bel(s_i) Bel(s_j) min(p*(s_i, a), p*(s_j, a)) / C``
  for the pairs whose successors are distinguishable, **action weight** (Eq. 9) the sum over pairs
  ``i < j``, and the choice (Eq. 10) the heaviest action (ties: the first in candidate order).
* **Macros** (Eq. 12-14): ``f*`` and ``p*`` compose along the sequence (``p*`` multiplies), the
  cost adds. A macro ends where the pair is distinguishable by *everything observable there* (all
  sensors, passive or not: :func:`full_parts`), as in Algorithm 2 of :mod:`beliefloc.planning.macros`.

**The threshold gamma.** For a set of parts, two states with the same noise-free readings differ
by at most ``same_max = 1 - prod_p min_v G_p[v, v]``, and two states whose readings differ in some
part by at least ``diff_min = min_p min_{v != w} (1 - G_p[v, w])`` (the other factors are <= 1).
The default gamma is halfway between the largest ``same_max`` and the smallest ``diff_min`` over the
model's observation models (:func:`gamma_bounds`): with it, *distinguishable* means exactly *the
noise-free readings differ*, whatever the sensors' noise -- 0.5 for noise-free sensors, about 0.55
for the three-beam 5 %-error scan of ``maps/corridors.yaml``. (The paper suggests a value "very close
to the probability of the most probable observation"; for a binary reading with 5 % error that is
0.95, above the 0.905 difference of two states reading 0 and 1, so nothing would be distinguishable.)
Inside that range the weights are computed per signature group in ``O(m log m)``; a gamma outside
it falls back to the exact pairwise ``O(m^2)`` sum.

**Many hypotheses (Sec. VII-B).** The paper keeps only the states whose probability is above a
threshold as the hypotheses. Here: the states with ``Bel >= min_belief`` (default: every state
with positive belief), and at most ``max_hypotheses`` of them, the most likely first (ties: lower
index). The weights are then those of the belief restricted to the hypotheses.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from beliefloc.model import Model, ObservationPart, StateSpace

DEFAULT_MAX_HYPOTHESES = 400
"""Sec. VII-B: keep at most this many of the most likely states as hypotheses."""
_FALLBACK_GAMMA = 0.5


# --- observation differences (Eq. 5) -----------------------------------------------------------


def overlap(part: ObservationPart) -> np.ndarray:
    """``G[v, w] = sum_o C[v, o] C[w, o]``: the probability that two states with true values v and
    w give the same reading of this part."""
    c = np.asarray(part.confusion, dtype=np.float64)
    result: np.ndarray = c @ c.T
    return result


def observation_difference(parts: Sequence[ObservationPart], i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Eq. 5 for the state pairs ``(i[k], j[k])``: ``1 - prod_p G_p[t_p[i], t_p[j]]``, a new array.

    No parts (an action that observes nothing): ``d = 0``, nothing is ever distinguishable.
    """
    i, j = np.asarray(i), np.asarray(j)
    same = np.ones(np.broadcast(i, j).shape)
    for part in parts:
        same = same * overlap(part)[part.truth[i], part.truth[j]]
    result: np.ndarray = 1.0 - same
    return result


def full_parts(model: Model) -> tuple[ObservationPart, ...]:
    """Every distinct observation part of the model: what can be observed in a state, by moving
    (passive sensors) or by perceiving (each sensor offered as an action)."""
    seen: dict[int, ObservationPart] = {}
    for action in model.actions:
        for part in action.observation.parts:
            seen.setdefault(id(part), part)
    return tuple(seen.values())


def signature(parts: Sequence[ObservationPart], n_states: int) -> np.ndarray:
    """A small integer per state, equal for two states exactly when every part's noise-free
    (true) value is equal. Compacted after each part, so it never overflows; when all the parts'
    values together number fewer than 2^24, the states' values are combined first and ranked once
    (the same ranks: ranking after each part keeps the combined values' order; 10^6 states, four
    parts: one counting rank instead of four)."""
    key = np.zeros(n_states, dtype=np.int64)
    if math.prod(part.confusion.shape[0] for part in parts) < _COUNTED_RANGE:
        for part in parts:
            key *= part.confusion.shape[0]
            # inside its table, as in every loaded model; added as it is read (no int64 copy: 80 MB at 10^7 states)
            np.add(key, part.truth, out=key, casting="unsafe")
        return _rank(key) if parts else key
    for part in parts:
        combined = key * part.confusion.shape[0] + part.truth.astype(np.int64)
        key = _rank(combined)
    return key


def _rank(values: np.ndarray) -> np.ndarray:
    """Each value's rank among the distinct values (``np.unique``'s inverse, as int64). Non-negative
    values below 2^24 are ranked by counting, not sorting (at 10^6 states, 4 ms instead of 60)."""
    if values.size and int(values.min()) >= 0 and int(values.max()) < _COUNTED_RANGE:
        present = np.bincount(values) > 0
        rank = np.cumsum(present, dtype=np.int64) - 1
        ranked: np.ndarray = rank[values]
        return ranked
    _, inverse = np.unique(values, return_inverse=True)
    return inverse.ravel().astype(np.int64)


_COUNTED_RANGE = 1 << 24


def difference_bounds(parts: Sequence[ObservationPart]) -> tuple[float, float]:
    """``(same_max, diff_min)`` of the module docstring for one set of parts."""
    same = 1.0
    diff_min = 1.0
    for part in parts:
        g = overlap(part)
        same *= float(np.min(np.diag(g)))
        if g.shape[0] > 1:
            off = g[~np.eye(g.shape[0], dtype=bool)]
            diff_min = min(diff_min, float(1.0 - off.max()))
    return 1.0 - same, diff_min


def gamma_bounds(model: Model) -> tuple[float, float]:
    """The range ``[lo, hi)`` of gamma in which *distinguishable* means *different noise-free
    readings* for every observation model of ``model`` and for all its sensors together."""
    sets = [a.observation.parts for a in model.actions] + [full_parts(model)]
    bounds = [difference_bounds(parts) for parts in sets if parts]
    if not bounds:
        return 0.0, 1.0
    return max(b[0] for b in bounds), min(b[1] for b in bounds)


def default_gamma(model: Model) -> float:
    """Halfway between :func:`gamma_bounds` (0.5 when the sensors are too noisy for any gamma to
    separate exactly by noise-free readings)."""
    lo, hi = gamma_bounds(model)
    return (lo + hi) / 2.0 if lo < hi else _FALLBACK_GAMMA


# --- most likely successors (Eq. 6) --------------------------------------------------------------


def most_likely_successors(model: Model) -> tuple[np.ndarray, np.ndarray]:
    """``(fstar, pstar)``, each of shape ``(n_actions, n_states)``: ``fstar[a, s] = f*(s, a)`` (ties:
    the lowest state index) and ``pstar[a, s] = P(f*(s, a) | s, a)``."""
    n = model.n_states
    fstar = np.empty((len(model.actions), n), dtype=np.int64)
    pstar = np.empty((len(model.actions), n), dtype=np.float64)
    for k, action in enumerate(model.actions):
        t = action.transition
        if t is None:
            fstar[k], pstar[k] = np.arange(n), 1.0
            continue
        t = t.tocsr()
        rows = np.repeat(np.arange(n), np.diff(t.indptr))
        order = np.lexsort((t.indices, -t.data, rows))  # per row: largest probability, then lowest column
        first = np.ones(len(order), dtype=bool)
        first[1:] = rows[order][1:] != rows[order][:-1]
        chosen = order[first]
        fstar[k, rows[chosen]] = t.indices[chosen]
        pstar[k, rows[chosen]] = t.data[chosen]
    return fstar, pstar


# --- the context of a selection ------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class PairContext:
    """What every selection needs, computed once per model: ``f*``, ``p*``, the observation
    signature of every action at every state, and gamma."""

    model: Model
    gamma: float
    fstar: np.ndarray
    """``(n_actions, n_states)``: Eq. 6."""
    pstar: np.ndarray
    costs: np.ndarray
    """``costs[a]``: C(s, a), the same in every state."""
    signatures: np.ndarray
    """``(n_actions, n_states)``: the signature of action a's observation at a state (reached)."""
    full_signature: np.ndarray
    """The signature of every sensor at a state: where a macro ends."""
    exact: tuple[bool, ...]
    """Per action (and last: the full set), whether gamma separates exactly by signature."""
    parts: tuple[tuple[ObservationPart, ...], ...] = field(repr=False)
    """Per action its observation parts, and last the full set."""

    @property
    def action_names(self) -> list[str]:
        return [a.name for a in self.model.actions]


def pair_context(model: Model, gamma: float | None = None) -> PairContext:
    """Precompute ``f*``, ``p*`` and signatures; gamma defaults to :func:`default_gamma`."""
    g = default_gamma(model) if gamma is None else float(gamma)
    fstar, pstar = most_likely_successors(model)
    n = model.n_states
    parts = (*tuple(a.observation.parts for a in model.actions), full_parts(model))
    cache: dict[tuple[int, ...], np.ndarray] = {}
    sigs = []
    for p in parts:
        key = tuple(id(x) for x in p)
        if key not in cache:
            cache[key] = signature(p, n)
        sigs.append(cache[key])
    exact = []
    for p in parts:
        lo, hi = difference_bounds(p) if p else (0.0, 0.0)
        exact.append(bool(p) and lo <= g < hi)
    return PairContext(
        model=model,
        gamma=g,
        fstar=fstar,
        pstar=pstar,
        costs=np.array([a.cost for a in model.actions], dtype=np.float64),
        signatures=np.stack(sigs[:-1]) if model.actions else np.zeros((0, n), dtype=np.int64),
        full_signature=sigs[-1],
        exact=tuple(exact),
        parts=parts,
    )


# --- candidates and weights (Eq. 8-10, 12-14) ---------------------------------------------------


@dataclass(frozen=True)
class Candidate:
    """A basic action (one index) or a macro (several), by action indices into ``model.actions``."""

    actions: tuple[int, ...]
    macro: bool = False

    def name(self, names: Sequence[str]) -> str:
        if not self.macro:
            return names[self.actions[0]]
        return "macro:" + ",".join(names[a] for a in self.actions)


@dataclass(frozen=True)
class Selection:
    """The weight of every candidate and the chosen one (None when no weight is positive)."""

    candidates: tuple[Candidate, ...]
    names: tuple[str, ...]
    weights: np.ndarray
    chosen: int | None
    hypotheses: np.ndarray
    """The states the weights were computed on (Sec. VII-B)."""

    @property
    def chosen_name(self) -> str | None:
        return None if self.chosen is None else self.names[self.chosen]

    def as_dict(self) -> dict[str, float]:
        """Weights by candidate name, rounded to 12 decimals (0.16, not 0.16000000000000003)."""
        return {name: round(float(w), 12) for name, w in zip(self.names, self.weights.tolist(), strict=True)}


def hypotheses(
    belief: np.ndarray, *, min_belief: float = 0.0, max_hypotheses: int = DEFAULT_MAX_HYPOTHESES
) -> np.ndarray:
    """Sec. VII-B: the states with ``Bel > 0`` and ``Bel >= min_belief``, at most ``max_hypotheses``
    of them, the most likely first (ties: lower index); returned sorted by state index."""
    support = np.flatnonzero((belief > 0.0) & (belief >= min_belief))
    if len(support) > max_hypotheses:
        order = np.lexsort((support, -belief[support]))
        support = np.sort(support[order[:max_hypotheses]])
    return support


def candidate_outcome(
    ctx: PairContext, candidate: Candidate, states: np.ndarray
) -> tuple[np.ndarray, np.ndarray, float]:
    """Eq. 12-14: the most likely end state of each of ``states``, its probability, and the cost."""
    end = states.copy()
    p = np.ones(len(states))
    cost = 0.0
    for a in candidate.actions:
        p = p * ctx.pstar[a, end]
        end = ctx.fstar[a, end]
        cost += float(ctx.costs[a])
    return end, p, cost


def _parts_index(ctx: PairContext, candidate: Candidate) -> int:
    """Which observation parts judge the end pair: the action's own, or for a macro all sensors."""
    return len(ctx.parts) - 1 if candidate.macro else candidate.actions[0]


def _signature_of(ctx: PairContext, k: int) -> np.ndarray:
    return ctx.full_signature if k == len(ctx.parts) - 1 else ctx.signatures[k]


def _pair_min_sum(b: np.ndarray, p: np.ndarray, group: np.ndarray) -> float:
    """``sum_{i<j, group_i = group_j} b_i b_j min(p_i, p_j)`` in O(m log m): sorted by group and by
    decreasing p, each element meets the earlier ones of its group, whose p is no smaller."""
    if len(b) < 2:
        return 0.0
    order = np.lexsort((-p, group))
    bs, ps, gs = b[order], p[order], group[order]
    cum = np.cumsum(bs)
    start = np.ones(len(gs), dtype=bool)
    start[1:] = gs[1:] != gs[:-1]
    base = np.maximum.accumulate(np.where(start, np.arange(len(gs)), 0))
    before_group = np.where(base > 0, cum[base - 1], 0.0)
    earlier = cum - bs - before_group
    return float(np.sum(bs * ps * earlier))


def candidate_weight(ctx: PairContext, candidate: Candidate, states: np.ndarray, belief: np.ndarray) -> float:
    """Eq. 9: the sum of Eq. 8 over the pairs ``i < j`` of ``states`` whose end states are
    distinguishable (``d > gamma``)."""
    end, p, cost = candidate_outcome(ctx, candidate, states)
    b = belief[states]
    k = _parts_index(ctx, candidate)
    if ctx.exact[k]:
        sig = _signature_of(ctx, k)[end]
        total = _pair_min_sum(b, p, np.zeros(len(b), dtype=np.int64)) - _pair_min_sum(b, p, sig)
        return max(total, 0.0) / cost
    parts = ctx.parts[k]
    if not parts:
        return 0.0
    ii, jj = np.triu_indices(len(states), 1)
    d = observation_difference(parts, end[ii], end[jj])
    w = b[ii] * b[jj] * np.minimum(p[ii], p[jj]) * (d > ctx.gamma)
    return float(w.sum()) / cost


def select(
    ctx: PairContext,
    belief: np.ndarray,
    macros: Sequence[tuple[int, ...]] = (),
    *,
    min_belief: float = 0.0,
    max_hypotheses: int = DEFAULT_MAX_HYPOTHESES,
) -> Selection:
    """Algorithm 1 (basic actions) or 3 (with ``macros``): every candidate's weight and Eq. 10's
    choice. Basic actions come first in model order, then the macros in the order given."""
    states = hypotheses(belief, min_belief=min_belief, max_hypotheses=max_hypotheses)
    candidates = [Candidate((a,)) for a in range(len(ctx.model.actions))]
    seen = set()
    for m in macros:
        if len(m) > 1 and m not in seen:  # a one-action macro is the basic action itself
            seen.add(m)
            candidates.append(Candidate(tuple(m), macro=True))
    names = ctx.action_names
    weights = np.array([candidate_weight(ctx, c, states, belief) for c in candidates])
    chosen = int(np.argmax(weights)) if len(weights) and weights.max() > 0.0 else None
    return Selection(tuple(candidates), tuple(c.name(names) for c in candidates), weights, chosen, states)


@dataclass(frozen=True)
class Edge:
    """One edge of Fig. 2: the pair, where the candidate takes each state, and Eq. 8's factors."""

    i: int
    j: int
    end_i: int
    end_j: int
    difference: float
    belief_product: float
    min_probability: float
    cost: float

    @property
    def weight(self) -> float:
        return self.belief_product * self.min_probability / self.cost

    def as_json(self, names: StateSpace) -> dict[str, str | float]:
        """What ``select --explain --json`` prints for the edge, states by name."""
        return {
            "s_i": names.name(self.i),
            "s_j": names.name(self.j),
            "f_i": names.name(self.end_i),
            "f_j": names.name(self.end_j),
            "difference": self.difference,
            "belief_product": self.belief_product,
            "min_probability": self.min_probability,
            "cost": self.cost,
            "weight": self.weight,
        }


def edges(ctx: PairContext, candidate: Candidate, states: np.ndarray, belief: np.ndarray) -> list[Edge]:
    """The edges behind a candidate's weight (pairs with ``d > gamma`` and positive belief), the
    heaviest first: the plain pairwise version, for ``select --explain``."""
    end, p, cost = candidate_outcome(ctx, candidate, states)
    parts = ctx.parts[_parts_index(ctx, candidate)]
    out = []
    ii, jj = np.triu_indices(len(states), 1)
    d = observation_difference(parts, end[ii], end[jj]) if parts else np.zeros(len(ii))
    for k in np.flatnonzero(d > ctx.gamma).tolist():
        i, j = int(ii[k]), int(jj[k])
        out.append(
            Edge(
                int(states[i]),
                int(states[j]),
                int(end[i]),
                int(end[j]),
                float(d[k]),
                float(belief[states[i]] * belief[states[j]]),
                float(min(p[i], p[j])),
                cost,
            )
        )
    out.sort(key=lambda e: (-e.weight, e.i, e.j))
    return out
