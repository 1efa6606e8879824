"""Contingent plans: a policy that branches on what each perception returns (LAO* over beliefs).

Best-first search (:mod:`beliefloc.planning.best_first`) returns one path under the observations it
expects and replans when the world differs. Here the plan is an AND-OR graph:

* an *OR node* is a belief; the policy picks one action there. Equal beliefs (to :data:`_MERGE` in total)
  are one node, whichever path reaches them (looking then scanning, or scanning then looking), so what the
  search learns about a belief serves every path to it, and a branch may lead back to a belief met before
  (a loop);
* the action's *branches* are its observations ``o`` with ``p(o | a, b) > 0``, each leading to the
  successor belief (an action that observes nothing has one branch of probability 1);
* a *goal* leaf holds ``max(b) >= threshold`` and costs nothing more.

The value of a node is the expected cost to reach the goal under the model,
``V(b) = min_a [γ(a) + Σ_o p(o | a, b) V(b'_o)]``, and the policy is the minimising action at every
node. LAO* (Hansen & Zilberstein 2001) grows the graph one expansion at a time: it expands the
frontier node of the current best policy with the most expected cost at stake (reach probability ×
estimate), backs the values up through every node that leads to it, and stops when the best policy
has no frontier node left (the policy is *complete*) or a budget runs out.

**Incremental bookkeeping.** The reach of a node is its expected number of visits under the best policy
(at a leaf: the probability of ending there). It is kept up to date rather than recomputed by a walk
over the whole policy per expansion: when a backup changes a node's best action, the node's reach is
taken from the old action's branches and given to the new one's, and the change flows down only as far
as reaches change (:meth:`_Search._flow`); the policy's frontier leaves wait in a heap by reach ×
estimate (ties: the more likely, then the older node). The search before this (a walk per expansion,
loops cut where they close, ties to the first in the walk) is kept as :class:`_TraversalSearch`, the
reference the tests compare with.

**The estimate at the frontier** is the paper's entropy, put in units of cost (:meth:`_Search.estimate`,
:func:`information_prices`): entropy among states that read alike is priced at a move plus a look,
entropy of which reading the robot will get at a look alone. ``Heuristic.ZERO`` estimates 0 instead:
admissible, so a complete policy is then the least expected cost over all policies (feasible on small
maps only).

**Pruning.** A belief the robot reaches with probability below ``prune_below`` (through the best
policy's branches from the start) is not expanded: it keeps its estimate in the expected cost, and
when the robot meets it, it replans (:class:`beliefloc.simulation.strategies.ContingentStrategy`).
So a policy has at most ``1 / prune_below`` frontier leaves. Default :data:`DEFAULT_PRUNE_BELOW`.

**Loops.** A branch back to the node it leaves, with probability ``q``, is solved at once: the
action's expected cost is ``(γ(a) + Σ_other p V) / (1 - q)``, that of repeating it until it leads
elsewhere; longer loops are solved by backing the values up again until they agree. An action that
always comes back (a look at states that all read alike) is worth nothing, and beliefs from which no
policy leaves for sure (look-alike states no action tells apart) are dead ends, worth nothing too
(:meth:`_Search._dead_ends`); such a belief is a *loop* leaf, where the robot replans.

**Planning on.** :class:`PolicyPlanner` keeps its graph from one plan call to the next, as the
paper's robot keeps its closed list: a call from a belief the graph has already (one the robot reached
by following the policy) starts from every value and expansion earlier calls made below it, and spends
its ``max_expansions`` deeper. :func:`plan_policy` is one call on a fresh planner.

**Honest ends.** :attr:`PlanStatus.FOUND`: the policy is complete (every leaf is a goal or a pruned
belief). :attr:`PlanStatus.BUDGET_EXCEEDED`: the expansion or time budget ran out first; the policy
then has *frontier* leaves, valued by the estimate (a robot following it plans on at every step until
its policy is complete, :class:`beliefloc.simulation.strategies.ContingentStrategy`).
:attr:`PlanStatus.NO_PLAN`: the start is a dead end.
"""

from __future__ import annotations

import collections
import enum
import functools
import heapq
import itertools
import math
import time
import warnings
import weakref
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from types import ModuleType
from typing import Any

import numpy as np
import scipy.sparse

from beliefloc.belief import entropy, predict, uniform
from beliefloc.model import Action, Model
from beliefloc.planning.best_first import BeliefCache, PlanStatus, SearchProgress
from beliefloc.planning.ec2 import full_parts, signature
from beliefloc.planning.settings import (
    DEFAULT_MAX_EXPANSIONS,
    DEFAULT_PRUNE_BELOW,
    DEFAULT_THRESHOLD,
    DEFAULT_TIME_LIMIT,
    Heuristic,
)
from beliefloc.planning.successors import SuccessorEvaluator, reading_keys
from beliefloc.source.located import gc_paused
from beliefloc.source.sparse_kernels import csr_matvec as _csr_matvec

lao: ModuleType | None
"""LAO*'s bookkeeping compiled (``_lao.c``: :meth:`_Search._revise`'s and :meth:`_Search._flow`'s loops,
the same numbers in the same order; setup.py builds it where a C compiler is found), or None: the Python
loops below. Setting it to None (tests, a comparison) makes the searches take the Python ones."""
try:
    from beliefloc.planning import _lao as lao
except ImportError:  # pragma: no cover - an install without the extension
    lao = None

_CACHE_BYTES = 256 * 2**20
_PROGRESS_EVERY = 64
_MAX_REVISIONS = 100_000
"""Backups per expansion while the loops' values settle (each a walk up one path)."""
_TRAP_CHECK = 2_000
"""Backups in one revision after which the search looks for beliefs no policy can leave."""
_MAX_FLOW = 200_000
"""Changes of reach placed by one :meth:`_Search._flow` before it recomputes the reaches by a traversal."""
_SETTLED_REACH = 1e-9
"""A change of reach smaller than this (relative) is not passed on: it stops a change that goes round a
loop of the policy."""
_CANCELLED = 1e-10
"""A reach that a change takes away to less than this share of the change is taken away entirely: what
is left is the rounding of sums made in another order (a node left out of the policy has no reach)."""
_TRUSTED_REACH = 1e-6
"""Reaches placed by :meth:`_Search._flow` are right to about :data:`_SETTLED_REACH` of the reaches they add
to, and a node the policy no longer reaches can keep a remainder of that size. A tip whose reach is below
this, or no tip at all, is checked by one traversal of the policy (:meth:`_Search._retrace`) before it is
believed: a remainder of 6e-18 on a node out of the policy was expanded as a tip, and the search ended
"out of budget" with a complete policy."""
_INFORMATIVE = 1e-9
"""Less expected information than this (nats) from the uniform belief counts as none."""
_SAME = 1e-12
"""Values closer than this (relative) are settled: the backups stop passing them on."""
_MERGE = 3e-6
"""Beliefs closer than this in total (the sum over states of the differences) are one node. Each
probability is cut to a multiple of ``_MERGE / n`` (n states) and equal cuts are the same belief, so two
beliefs of one node differ by less than ``_MERGE / n`` in every state. Why not exact equality: repeated
looks leave tiny probabilities behind (a false positive of 0.01 leaves 10^-8 after four looks) that
differ from path to path, and beliefs that differ only in them would never merge: on the hallway LAO*
expanded 44,167 beliefs, 5,283 of them distinct to 10^-6 (benchmarks/results/contingent.md, 2026-11-27).
The expected cost of a policy is linear in the belief, so a merged branch's cost differs from its own
belief's by at most ``_MERGE`` times the largest cost from one state; on the hallway the expected cost
agreed to 10 digits with the exact merge. On a large model the search finds fewer of the beliefs it may
merge (:meth:`_Search._key`)."""
_BATCH_ENTRIES = 2**16
"""A model whose likelihoods of every action and observation (states × rows) have at most this many entries
has the successors of a belief computed as one matrix (:meth:`_Search._successors`); a larger one, one by
one."""
_SUMMARY_DIGITS = 9
"""On a large model, beliefs are compared only with those of the same maximum and projection to this many
digits (:meth:`_Search._key`)."""
_HASH_SEED = 28
"""The seed of the random weights that turn a belief's cut probabilities into one integer key."""
_DENSE_CHAIN = 1_000
"""A policy of at most this many nodes has its chance of ending at a leaf that is not a goal solved densely
(:func:`_absorbed`: 8 MB and a few milliseconds at most)."""


_Successor = tuple[int, int | None, float, float, np.ndarray, int, float | Callable[[], float]]
"""What :meth:`_Search._successors` gives per successor: action, observation, probability, maximum, belief,
key and estimate (or a function that computes it)."""


class LeafKind(enum.Enum):
    """Why a node of the policy has no action."""

    GOAL = "goal"
    """One state holds at least the threshold."""
    FRONTIER = "frontier"
    """The budget ran out before this belief was expanded: replan here."""
    PRUNED = "pruned"
    """A belief reached with less probability than ``prune_below``: replan if it occurs."""
    LOOP = "loop"
    """A dead end: no policy leaves this belief for sure (its expected cost is infinite); replan if it
    occurs."""


class _Node:
    """A belief of the AND-OR graph under construction (an OR node). Equal beliefs (to :data:`_MERGE`)
    are one node, whichever path led to them."""

    __slots__ = (
        "best",
        "children",
        "exits",
        "leaf",
        "max_belief",
        "number",
        "origin",
        "parents",
        "q",
        "reach",
        "stale",
        "value",
    )

    def __init__(self, number: int, origin: tuple[_Node, int, int | None] | None, top: float) -> None:
        self.number = number
        self.origin = origin
        """The parent, action and observation the node was first reached by (its belief is recomputed
        along them when it is no longer cached); None at the root."""
        self.max_belief = top
        self.value = 0.0
        self.leaf: LeafKind | None = LeafKind.FRONTIER
        self.best = -1
        self.children: dict[int, list[tuple[float, int | None, _Node]]] = {}
        """Per action, its branches: (probability, observation, successor)."""
        self.exits: list[tuple[float, list[tuple[float, _Node]]] | None] = []
        """Per action index (None: no branch), the probability of a branch back to the node itself and the
        other branches as (probability, successor), in :attr:`children`'s order: what a backup reads."""
        self.q: list[float] = []
        """Per action index, its expected cost (:meth:`_Search._q`; infinite without branches or when it
        never leaves), as of the last backup that recomputed it."""
        self.stale: set[int] | None = None
        """The actions whose :attr:`q` a successor's change of value has made out of date."""
        self.parents: list[tuple[_Node, int]] = []
        """Per branch into the node: the node it leaves and its action."""
        self.reach = 0.0
        """The expected number of visits to the node under the best policy from the current start (at a
        leaf: the probability of ending there), kept up to date as the policy changes
        (:meth:`_Search._flow`)."""


if lao is not None:
    lao.setup(_Node, LeafKind.FRONTIER)


@dataclass(frozen=True)
class PolicyBranch:
    """One observation of a policy node's action."""

    observation: str | None
    """None for an action that observes nothing."""
    observation_index: int | None
    probability: float
    """``p(o | a, b)`` at the node."""
    node: PolicyNode


@dataclass(eq=False)
class PolicyNode:
    """A belief of the policy: an action with its branches, or a leaf. The policy is a graph: a belief
    reached by several paths is one node, and a branch may lead back to a node above it (the robot
    then carries on from there)."""

    number: int
    """The node's identity within its policy (the JSON's ``id``)."""
    expected_cost: float
    """Expected cost from here to the goal under the model (frontier and pruned leaves: the
    estimate)."""
    max_belief: float
    most_likely: int
    """The most likely state of this belief (its index)."""
    action: str | None
    """None at a leaf."""
    action_index: int | None
    leaf: LeafKind | None
    """None when the node acts."""
    branches: tuple[PolicyBranch, ...] = field(default=(), repr=False)
    """Set once every node of the policy exists (a branch may lead back up)."""

    def branch(self, observation: int | None) -> PolicyBranch | None:
        """The branch taken when ``observation`` is seen (None when the policy has none for it)."""
        for branch in self.branches:
            if branch.observation_index == observation:
                return branch
        return None

    def reachable(self) -> list[PolicyNode]:
        """This node and every node below it, each once, depth first in branch order."""
        seen = {self.number}
        order, stack = [], [self]
        while stack:
            node = stack.pop()
            order.append(node)
            for branch in reversed(node.branches):
                if branch.node.number not in seen:
                    seen.add(branch.node.number)
                    stack.append(branch.node)
        return order

    def size(self) -> int:
        """Distinct nodes from here down, itself and the leaves included."""
        return len(self.reachable())

    def as_json(self, model: Model) -> dict[str, Any]:
        """The policy from here as nested JSON: a node met again (by another path, or back up a loop)
        is ``{"id": n, "same_as": n, ...}`` after its first, full appearance."""
        shown: set[int] = set()

        def node_json(node: PolicyNode) -> dict[str, Any]:
            data: dict[str, Any] = {
                "id": node.number,
                "expected_cost": node.expected_cost,
                "max_belief": node.max_belief,
                "most_likely": model.states.name(node.most_likely),
            }
            if node.number in shown:
                data["same_as"] = node.number
                return data
            shown.add(node.number)
            if node.action is not None:
                data["action"] = node.action
                data["branches"] = [
                    {"observation": b.observation, "probability": b.probability, "node": node_json(b.node)}
                    for b in node.branches
                ]
            else:
                data["leaf"] = node.leaf.value if node.leaf is not None else None
            return data

        return node_json(self)


@dataclass(frozen=True, eq=False)
class PolicyResult:
    status: PlanStatus
    root: PolicyNode
    expanded: int
    generated: int
    seconds: float
    prices: InformationPrices
    """The estimate's costs per nat (0 with ``Heuristic.ZERO``)."""
    open_share: float
    """Probability of ending at a frontier, pruned or loop leaf (where the robot replans)."""

    @property
    def found(self) -> bool:
        """The policy is complete: every leaf is a goal, or a branch it chose not to plan for."""
        return self.status is PlanStatus.FOUND

    @property
    def expected_cost(self) -> float:
        return self.root.expected_cost

    def nodes(self) -> int:
        """Distinct nodes in the policy (leaves included)."""
        return self.root.size()

    def as_json(self, model: Model) -> dict[str, Any]:
        """What ``plan --policy --json`` prints: the status, the expected cost, the whole policy;
        ``"complete"`` is false when the budget ran out (frontier leaves are left, valued by the
        estimate), as in ``plan --json``."""
        return {
            "found": self.found,
            "complete": self.found,
            "status": self.status.value,
            "expected_cost": self.expected_cost,
            "open_probability": self.open_share,
            "price_per_nat": {"moving": self.prices.moving, "perceiving": self.prices.perceiving},
            "expanded": self.expanded,
            "generated": self.generated,
            "seconds": self.seconds,
            "policy": self.root.as_json(model),
        }


@dataclass(frozen=True)
class InformationPrices:
    """What a nat of information costs the frontier estimate (module docstring)."""

    moving: float
    """``κ``: (cheapest actuation + cheapest perception) / the most information one action gives from
    the uniform belief (its expected entropy reduction) -- a move and a look can be repeated."""
    perceiving: float
    """``ρ <= κ``: the cheapest perception / the most information a perception gives from the uniform
    belief -- what telling apart states that read differently costs, without moving."""


NO_PRICES = InformationPrices(0.0, 0.0)
"""``Heuristic.ZERO``: the frontier is estimated at 0."""


def information_prices(model: Model, evaluator: SuccessorEvaluator | None = None) -> InformationPrices:
    """``κ`` and ``ρ`` of ``model``. A model without actuation actions pays the perception alone, one
    without perception actions pays ``κ`` for everything, and one no action informs pays a nat at the
    cost of the cheapest cycle."""
    evaluator = evaluator or SuccessorEvaluator(model)
    start = uniform(model.n_states)
    before = entropy(start)
    gain = [0.0] * len(model.actions)
    for stats in evaluator.evaluate(start):
        gain[stats.action] += stats.probability * (before - stats.entropy)
    moves = [a.cost for a in model.actuation_actions]
    looks = [a.cost for a in model.perception_actions]
    cycle = (min(moves) if moves else 0.0) + (min(looks) if looks else 0.0)
    cycle = cycle or min(a.cost for a in model.actions)
    best = max(gain)
    moving = cycle / best if best > _INFORMATIVE else cycle
    perception_gain = max((g for g, a in zip(gain, model.actions, strict=True) if not a.is_actuation), default=0.0)
    if not looks or perception_gain <= _INFORMATIVE:
        return InformationPrices(moving, moving)
    return InformationPrices(moving, min(moving, min(looks) / perception_gain))


def _signature_groups(model: Model) -> tuple[np.ndarray, np.ndarray] | None:
    """States sorted by their noise-free readings of every sensor (:func:`~beliefloc.planning.ec2.signature`),
    with the group boundaries (None when no action observes). Planners are made often (31 in two
    contingent episodes on the depot): ranked pair by pair with ``np.unique(..., axis=1)`` this cost
    0.42 s a planner there, 9 % of the episodes' time."""
    parts = full_parts(model)
    if not parts:
        return None
    key = signature(parts, model.n_states)
    order = np.argsort(key, kind="stable")
    ordered = key[order]
    starts = np.flatnonzero(np.r_[True, ordered[1:] != ordered[:-1]])
    return order, starts


def _likelihood_columns(
    action: Action, n_states: int, signature: tuple[np.ndarray, np.ndarray] | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None] | None:
    """``O_a`` as ``(groups, columns, by_signature)``: ``O_a[j, o] = columns[groups[j], o]``, one row of
    ``columns`` per distinct reading of the action's parts, and ``by_signature[g, o]`` the same for the
    groups of :func:`_signature_groups` (which read every part alike: they are finer); None for an action
    that observes nothing."""
    parts = action.observation.parts
    if not parts:
        return None
    _, first, groups = np.unique(reading_keys(action, n_states), return_index=True, return_inverse=True)
    by_signature = None
    if signature is not None:
        order, starts = signature
        by_signature = action.observation.likelihood_matrix(order[starts])
    return groups.ravel().astype(np.intp), action.observation.likelihood_matrix(first), by_signature


def plan_policy(
    model: Model,
    belief: np.ndarray,
    *,
    threshold: float = DEFAULT_THRESHOLD,
    heuristic: Heuristic = Heuristic.ENTROPY_MAX_PROB,
    max_expansions: int = DEFAULT_MAX_EXPANSIONS,
    time_limit: float = DEFAULT_TIME_LIMIT,
    prune_below: float = DEFAULT_PRUNE_BELOW,
    evaluator: SuccessorEvaluator | None = None,
    prices: InformationPrices | None = None,
    progress: SearchProgress | None = None,
) -> PolicyResult:
    """The least-expected-cost policy LAO* finds from ``belief`` within the budgets (module docstring).

    ``prices`` are the estimate's (:func:`information_prices` when None; a caller that plans often
    computes them once per model; ignored with ``Heuristic.ZERO``). Deterministic: the same inputs
    give the same policy."""
    with gc_paused():  # until the graph is gone: the collector would walk all of it once more
        planner = PolicyPlanner(
            model, threshold=threshold, heuristic=heuristic, prune_below=prune_below, evaluator=evaluator, prices=prices
        )
        result = planner.plan(belief, max_expansions=max_expansions, time_limit=time_limit, progress=progress)
        del planner  # its graph unlinked and freed here (_unlink)
    return result


class PolicyPlanner:
    """LAO* that keeps its graph from one plan call to the next, as the paper's robot keeps its closed
    list: a robot that follows a policy to a leaf and plans again from there starts from everything
    the earlier calls learnt about the beliefs ahead of it (values and expansions), so each call's
    ``max_expansions`` deepens the search instead of redoing it. Deterministic: the same calls give the
    same policies."""

    _search_kind: type[_Search]

    def __init__(
        self,
        model: Model,
        *,
        threshold: float = DEFAULT_THRESHOLD,
        heuristic: Heuristic = Heuristic.ENTROPY_MAX_PROB,
        prune_below: float = DEFAULT_PRUNE_BELOW,
        evaluator: SuccessorEvaluator | None = None,
        prices: InformationPrices | None = None,
    ) -> None:
        evaluator = evaluator or SuccessorEvaluator(model)
        if heuristic is Heuristic.ZERO:
            prices = NO_PRICES
        elif prices is None:
            prices = information_prices(model, evaluator)
        self.prices = prices
        self._search = self._search_kind(model, evaluator, threshold, prices, prune_below)

    def plan(
        self,
        belief: np.ndarray,
        *,
        max_expansions: int = DEFAULT_MAX_EXPANSIONS,
        time_limit: float = DEFAULT_TIME_LIMIT,
        progress: SearchProgress | None = None,
    ) -> PolicyResult:
        """The best policy from ``belief`` after at most ``max_expansions`` more expansions (those of
        earlier calls count for nothing here) or ``time_limit`` seconds."""
        start = time.perf_counter()
        search = self._search
        generated = search.generated
        root = search.root(belief)
        status = PlanStatus.FOUND
        expanded = 0
        # the collector off while the graph grows: its nodes live on and point at each other, and the
        # collector, run every few hundred new objects, walked all of them again and again (a third of
        # the hallway's search, 2.4 -> 1.6 s of CPU without it); the search makes next to no garbage
        with gc_paused():
            while (tip := search.next_tip(root)) is not None:
                if expanded >= max_expansions or time.perf_counter() - start > time_limit:
                    status = PlanStatus.BUDGET_EXCEEDED
                    break
                search.expand(tip)
                expanded += 1
                if progress is not None and expanded % _PROGRESS_EVERY == 0:
                    progress(expanded, search.generated - generated, time.perf_counter() - start)
        if root.leaf is None and root.best < 0:
            status = PlanStatus.NO_PLAN
        policy, open_share = search.policy(root)
        seconds = time.perf_counter() - start
        return PolicyResult(status, policy, expanded, search.generated - generated, seconds, self.prices, open_share)


class _Search:
    """The graph, its values, its best policy and that policy's tips."""

    def __init__(
        self,
        model: Model,
        evaluator: SuccessorEvaluator,
        threshold: float,
        prices: InformationPrices,
        prune_below: float,
    ) -> None:
        self.model = model
        self.evaluator = evaluator
        self.threshold = threshold
        self.kappa = prices.moving
        self.perceiving = prices.perceiving
        self.prune_below = prune_below
        self.costs = [a.cost for a in model.actions]
        self.generated = 0
        self._numbers = itertools.count()
        self._signature = _signature_groups(model)
        self._nodes: dict[int, list[_Node]] = {}
        """Every node that is not a goal, by the key of its belief (:meth:`_key`)."""
        self._quantum = _MERGE / max(1, model.n_states)
        self._weights = np.random.default_rng(_HASH_SEED).integers(0, 2**64, size=(model.n_states, 2), dtype=np.uint64)
        self._cut = (np.empty(model.n_states), np.empty(model.n_states, dtype=np.uint64))
        self._probe = np.random.default_rng(_HASH_SEED).random(model.n_states)
        self._cache = BeliefCache(max(4, _CACHE_BYTES // (8 * max(1, model.n_states))))
        self._starts: dict[int, np.ndarray] = {}
        """The beliefs of the nodes plans started from that no branch had reached."""
        self._signature_index: np.ndarray | None = None
        """Per state, its group of :attr:`_signature` (None when the model has none)."""
        self._signature_count = 0
        if self._signature is not None:
            order, starts = self._signature
            self._signature_count = len(starts)
            self._signature_index = np.empty(model.n_states, dtype=np.intp)
            self._signature_index[order] = np.repeat(np.arange(len(starts)), np.diff(np.r_[starts, len(order)]))
        self._likelihoods = [_likelihood_columns(action, model.n_states, self._signature) for action in model.actions]
        self._dense: np.ndarray | None = None
        """A row per action and observation (:attr:`_rows`): ``O_a[:, o]``, all ones for an action that
        observes nothing; when it has at most :data:`_BATCH_ENTRIES` entries (:meth:`_successors`), else None."""
        self._rows: list[tuple[int, int | None]] = []
        for index, table in enumerate(self._likelihoods):
            self._rows += [(index, None)] if table is None else [(index, o) for o in range(table[1].shape[1])]
        self._row_action = np.array([action for action, _ in self._rows], dtype=np.intp)
        self._row_observes = np.array([observation is not None for _, observation in self._rows])
        self._row_observation = [observation for _, observation in self._rows]
        self._stacked: scipy.sparse.csr_matrix | None = None
        """With :attr:`_dense`: every action's ``T_aᵀ`` stacked (the identity for one that does not move), so
        that one product predicts the belief under every action (:meth:`_predictions`)."""
        if len(self._rows) * model.n_states <= _BATCH_ENTRIES:
            self._dense = np.vstack(
                [np.ones((1, model.n_states)) if table is None else table[1][table[0]].T for table in self._likelihoods]
            )
            identity = scipy.sparse.identity(model.n_states, format="csr")
            stacked = scipy.sparse.vstack(
                [identity if a.transition_transposed is None else a.transition_transposed for a in model.actions],
                format="csr",
            )
            if _csr_matvec is not None and stacked.indptr.dtype == stacked.indices.dtype:
                self._stacked = stacked
        self._tips: list[tuple[float, float, int, _Node]] = []
        """The best policy's frontier leaves as a heap of ``(-reach × value, -reach, number, node)``; an entry
        whose reach is no longer the node's is stale (:meth:`next_tip` drops it)."""
        self._reached: list[_Node] = []
        """Every node whose reach was set since the current start was chosen."""
        self._exact = False
        """Whether the reaches are those of a traversal (:meth:`_retrace`), not changed since."""
        # the graph is a web of cycles (parents, children, loops): unlinked when the search goes, it is freed
        # there and then, instead of by the cycle collector's walk over all of it (_unlink)
        weakref.finalize(self, _unlink, self._nodes).atexit = False

    def root(self, belief: np.ndarray) -> _Node:
        """The node of ``belief`` (one the graph has already, or a new one) as the policy's start."""
        h, top = entropy(belief), float(belief.max())
        node = self._node(None, top, belief, self._key(belief, top), self.estimate(belief, h))
        if node.origin is None:  # every chain of recomputation ends at a start: never evicted
            self._starts[node.number] = belief
        for reached in self._reached:
            reached.reach = 0.0
        self._reached, self._tips = [], []
        self._flow({node: 1.0})
        return node

    def _node(
        self,
        origin: tuple[_Node, int, int | None] | None,
        top: float,
        belief: np.ndarray,
        key: int,
        value: float | Callable[[], float],
    ) -> _Node:
        """The node of ``belief``: the one that has it already, or a new goal or frontier node (``key``: the
        belief's :meth:`_key`; ``value``: its :meth:`estimate`, both ignored for a goal)."""
        if top >= self.threshold:
            node = _Node(next(self._numbers), origin, top)
            node.leaf = LeafKind.GOAL
            return node
        same = self._nodes.setdefault(key, [])
        if same and self._dense is not None:
            return same[0]  # the key of the cut itself: equal keys are equal cuts (_key)
        for existing in same:  # a summary's key (a large model) is shared by other beliefs: checked
            if float(np.abs(self.belief(existing) - belief).max()) <= self._quantum:
                return existing
        node = _Node(next(self._numbers), origin, top)
        same.append(node)
        self._cache.put(node.number, belief)
        node.value = value if isinstance(value, float) else value()
        return node

    def _key(self, belief: np.ndarray, top: float) -> int:
        """The belief's probabilities cut to multiples of :attr:`_quantum` (:data:`_MERGE`), as one integer:
        their dot products with two fixed random vectors of unsigned 64-bit weights (wrapping around), in two scratch
        arrays, side by side in 128 bits (:func:`_key128`). Two different cuts differ by a vector ``d`` of
        integers below 2^35 in size (a probability over a quantum of at least 3e-6 / 2^16); a dot product
        with random weights misses ``d`` only when ``w·d`` is 0 modulo 2^64: for the entry of ``d`` with the
        fewest factors of 2 (at most 34), a chance of at most 2^-30 (2^-64 when that entry is odd), 2^-60 for
        both products. So equal keys are taken for equal cuts (:meth:`_node`), with no comparison of beliefs.

        On a large model (one without :attr:`_dense`) that costs 100 µs at 50,000 states, more than the
        rest of a successor: there the key is the belief's maximum ``top`` and its projection on fixed random
        weights, to 9 digits (15 µs; the projection is einsum's loop, not BLAS's dot: a threaded dot of
        50,000 states took 15 ms on a loaded 2-core machine). Beliefs that differ by less than the merge
        tolerance but not by less than 10^-9 in that projection then stay apart, as they did before
        issue 28's merge tolerance."""
        if self._dense is None:
            projection = float(np.einsum("i,i->", belief, self._probe))
            return hash((round(top, _SUMMARY_DIGITS), round(projection, _SUMMARY_DIGITS)))
        scaled, cut = self._cut
        np.multiply(belief, 1.0 / self._quantum, out=scaled)
        cut[...] = scaled  # towards zero: probabilities are >= 0, so the floor
        first, second = (cut @ self._weights).tolist()  # unsigned integers wrap exactly, in any order of the sum
        return _key128(first, second)

    def estimate(self, belief: np.ndarray, h: float, mass: np.ndarray | None = None) -> float:
        """``κ · H(S | Σ) + ρ · H(Σ)``: the entropy within the groups of states that read alike (Σ, every
        sensor's noise-free reading) is paid at the price of moving and perceiving, the entropy of
        which group the robot is in at the price of perceiving alone. ``mass``: the belief's mass in
        each group, when the caller has it (:meth:`_successors`)."""
        groups = self._signature
        if self.kappa == 0.0:
            return 0.0
        if groups is None:
            return self.kappa * h
        if mass is None:
            order, starts = groups
            mass = np.add.reduceat(belief[order], starts)
        else:
            mass = mass / mass.sum()
        mass = mass[mass > 0.0]
        between = max(0.0, float(-(mass * np.log(mass)).sum()))
        within = max(0.0, h - between)
        return self.kappa * within + self.perceiving * between

    def belief(self, node: _Node) -> np.ndarray:
        chain = []
        while (cached := self._starts.get(node.number, self._cache.get(node.number))) is None:
            chain.append(node)
            assert node.origin is not None
            node = node.origin[0]
        current = cached
        for child in reversed(chain):
            assert child.origin is not None
            _, action, observation = child.origin
            current = self._successor(current, action, observation)
            self._cache.put(child.number, current)
        return current

    def expand(self, node: _Node) -> None:
        """Give ``node`` its actions' branches, then back the values up (:meth:`_revise`)."""
        belief = self.belief(node)
        node.leaf = None
        for action, observation, probability, top, successor, key, value in self._successors(belief):
            child = self._node((node, action, observation), top, successor, key, value)
            child.parents.append((node, action))
            node.children.setdefault(action, []).append((probability, observation, child))
            self.generated += 1
        node.exits = [None] * len(self.costs)
        for action, branches in node.children.items():
            here = 0.0
            for p, _, child in branches:
                if child is node:
                    here += p
            node.exits[action] = (here, [(p, child) for p, _, child in branches if child is not node])
        node.q = [math.inf] * len(self.costs)
        node.stale = set(node.children)
        self._reroute(self._revise(node))

    def _successors(self, belief: np.ndarray) -> Iterator[_Successor]:
        """Every successor of ``belief`` with non-zero probability, in action then observation order, as
        ``(action, observation, probability, maximum, belief, key, estimate)`` (:meth:`_key`,
        :meth:`estimate` or a function that computes it; both 0 for a goal). On a small model
        (:data:`_BATCH_ENTRIES`) all of them come from one matrix, a row per action and observation: the
        observation's likelihoods times the action's prediction, normalised row by row, each row's entropy,
        maximum, key and estimate in one go; otherwise one by one (:meth:`_one_by_one`)."""
        if self._dense is None:
            yield from self._one_by_one(belief)
            return
        predicted = self._predictions(belief)
        joint = self._dense * predicted[self._row_action]
        total = joint.sum(axis=1)
        rows: np.ndarray | None = None  # the rows of the possible successors, when some are not
        if total.min() > 0.0:
            posteriors = joint
            posteriors /= total[:, None]
        else:
            rows = np.flatnonzero(total > 0.0)
            posteriors = joint[rows] / total[rows, None]
            total = total[rows]
        h = np.maximum(0.0, -_xlogx(posteriors).sum(axis=1))
        tops = posteriors.max(axis=1)
        pairs = (posteriors * (1.0 / self._quantum)).astype(np.uint64) @ self._weights
        if self.kappa == 0.0:
            values = np.zeros(len(posteriors))
        elif self._signature is None:
            values = self.kappa * h
        else:
            order, starts = self._signature
            masses = np.add.reduceat(posteriors[:, order], starts, axis=1)  # not BLAS: threads cost more here
            between = np.maximum(0.0, -_xlogx(masses).sum(axis=1))
            values = self.kappa * np.maximum(0.0, h - between) + self.perceiving * between
        # a sum of 1 may round above it; an action that observes nothing has probability 1 exactly
        observes = self._row_observes if rows is None else self._row_observes[rows]
        probabilities = np.where(observes, np.minimum(total, 1.0), 1.0)
        yield from zip(
            self._row_action.tolist() if rows is None else self._row_action[rows].tolist(),
            self._row_observation if rows is None else [self._rows[row][1] for row in rows.tolist()],
            probabilities.tolist(),
            tops.tolist(),
            list(posteriors),
            [(first << 64) | second for first, second in pairs.tolist()],  # _key128, written out
            values.tolist(),
            strict=True,
        )

    def _predictions(self, belief: np.ndarray) -> np.ndarray:
        """``T_aᵀ b`` of every action, a row each: one call of SciPy's kernel over :attr:`_stacked` (its rows
        are those of each ``T_aᵀ``, so each entry is the same sum, bit for bit, as :func:`predict`'s),
        instead of a product per action through SciPy's operator (5 µs of dispatch each on the hallway,
        whose whole Bayes update takes 20 µs)."""
        stacked = self._stacked
        if stacked is None or _csr_matvec is None:
            return np.stack([predict(action, belief) for action in self.model.actions])
        out = np.zeros(stacked.shape[0])
        _csr_matvec(
            stacked.shape[0],
            stacked.shape[1],
            stacked.indptr,
            stacked.indices,
            stacked.data,
            np.ascontiguousarray(belief, dtype=np.float64),
            out,
        )
        return out.reshape(len(self.model.actions), -1)

    def _one_by_one(self, belief: np.ndarray) -> Iterator[_Successor]:
        """:meth:`SuccessorEvaluator.successors`, with each observation's likelihood column gathered from
        :attr:`_likelihoods` (the same numbers: ``O[j, o]`` is the product of the parts' confusion
        entries in both) instead of :meth:`ObservationModel.likelihood`, which decodes ``o`` and gathers
        every part's column: 1.3 ms of the 1.4 ms a successor of a depot belief (49,592 states) took.
        The estimate comes from each successor's mass in every group of :attr:`_signature` (the
        prediction's, times the observation's likelihood there: a group's worth of work instead of a
        belief's), and is computed only if the successor is a new node (here, a function)."""
        stats = self.evaluator.evaluate(belief)
        i = 0
        threshold = self.threshold
        for index, action in enumerate(self.model.actions):
            predicted = predict(action, belief)
            masses = None
            if self._signature_index is not None:
                masses = np.bincount(self._signature_index, weights=predicted, minlength=self._signature_count)
            table = self._likelihoods[index]
            if table is None:
                here = stats[i]
                if here.max_belief >= threshold:
                    yield index, None, 1.0, here.max_belief, predicted, 0, 0.0
                else:
                    value = functools.partial(self.estimate, predicted, here.entropy, masses)
                    yield index, None, 1.0, here.max_belief, predicted, self._key(predicted, here.max_belief), value
                i += 1
                continue
            groups, columns, by_signature = table
            while i < len(stats) and stats[i].action == index:
                here = stats[i]
                i += 1
                assert here.observation is not None
                weighted: np.ndarray = predicted * columns[:, here.observation][groups]
                weighted /= weighted.sum()
                if here.max_belief >= threshold:
                    yield index, here.observation, here.probability, here.max_belief, weighted, 0, 0.0
                    continue
                mass = None if masses is None or by_signature is None else masses * by_signature[:, here.observation]
                value = functools.partial(self.estimate, weighted, here.entropy, mass)
                key = self._key(weighted, here.max_belief)
                yield index, here.observation, here.probability, here.max_belief, weighted, key, value

    def _successor(self, belief: np.ndarray, action: int, observation: int | None) -> np.ndarray:
        """:meth:`SuccessorEvaluator.successor` by :attr:`_likelihoods` (see :meth:`_successors`)."""
        predicted = predict(self.model.actions[action], belief)
        table = self._likelihoods[action]
        if observation is None or table is None:
            return predicted
        groups, columns, _ = table
        weighted: np.ndarray = predicted * columns[:, observation][groups]
        weighted /= weighted.sum()
        return weighted

    def _q(self, node: _Node, action: int) -> float:
        """``γ(a) + Σ p V``. Coming back to ``node`` itself with probability ``q`` is solved at once:
        ``Q = (γ(a) + Σ_rest p V) / (1 - q)``; an action that always comes back is worth nothing to a
        policy (infinite)."""
        here = 0.0
        total = self.costs[action]
        for p, _, child in node.children[action]:
            if child is node:
                here += p
            else:
                total += p * child.value
        if here >= 1.0 - _SAME:
            return math.inf
        return total / (1.0 - here)

    def _revise(self, node: _Node) -> dict[_Node, int]:
        """Bellman backups from ``node`` to every node that leads to it, as long as values move: the
        equations of the loops among them solved by iteration (Gauss-Seidel, at most
        :data:`_MAX_REVISIONS` backups per expansion). Values that keep climbing after
        :data:`_TRAP_CHECK` backups are looked at once: beliefs from which no policy reaches a goal or the
        frontier for sure (:meth:`_dead_ends`) are worth nothing (infinite), which ends their climb.
        Returns the nodes whose best action changed, each with the action it had before.

        A backup recomputes only the actions a change of value has made stale (:attr:`_Node.q`), and a
        change is passed on to a node only where it can move its value: always under its best action;
        under another, not when the value rose (that action only got dearer), and when it fell only if the
        action, recomputed at once, is now at least as cheap as the best."""
        if lao is not None:
            changes: dict[_Node, int] = lao.revise(
                node, self.costs, self._dead_ends, _MAX_REVISIONS, _TRAP_CHECK, _SAME
            )
            return changes
        changed: dict[_Node, int] = {}
        costs = self.costs
        pending = collections.deque([node])
        queued = {node}
        first = True  # the expanded node's value went from the estimate to its backup: always passed on
        for backups in range(_MAX_REVISIONS):
            if not pending:
                break
            if backups == _TRAP_CHECK:
                for dead in self._dead_ends():
                    changed.setdefault(dead, dead.best)
                    dead.best, dead.value = -1, math.inf
                    self._pass_on(dead, True, pending, queued)
            current = pending.popleft()
            queued.discard(current)
            q, stale = current.q, current.stale
            if stale:
                exits = current.exits
                for action in stale:  # _q, written out: the hot loop
                    here, others = exits[action]  # type: ignore[misc]
                    if here >= 1.0 - _SAME:
                        q[action] = math.inf
                        continue
                    total = costs[action]
                    for p, child in others:
                        total += p * child.value
                    q[action] = total / (1.0 - here)
                current.stale = None
            value = min(q) if q else math.inf
            best = q.index(value) if value < math.inf else -1
            if best != current.best:
                changed.setdefault(current, current.best)
            current.best = best
            settled = value == current.value or abs(value - current.value) <= _SAME * max(1.0, abs(value))
            if settled and not first:
                continue
            first = False
            rose = value > current.value
            current.value = value
            for parent, action in current.parents:  # _pass_on, written out
                if parent in queued or rose or action == parent.best:
                    if parent.stale is None:
                        parent.stale = {action}
                    else:
                        parent.stale.add(action)
                    if parent not in queued and (not rose or action == parent.best):
                        queued.add(parent)
                        pending.append(parent)
                    continue
                # the value fell under an action that is not the parent's best: recomputed here, the parent
                # is backed up only if that action may now be its best
                here, others = parent.exits[action]  # type: ignore[misc]
                if here >= 1.0 - _SAME:
                    fell = math.inf
                else:
                    total = costs[action]
                    for p, child in others:
                        total += p * child.value
                    fell = total / (1.0 - here)
                parent.q[action] = fell
                if parent.stale is not None:
                    parent.stale.discard(action)
                # against the best action's own Q (its value may lag it by a settled 10^-12): the choice a
                # backup would make, ties to the first action included
                cheapest = parent.q[parent.best] if parent.best >= 0 else math.inf
                if fell < cheapest or (fell == cheapest and action < parent.best):
                    queued.add(parent)
                    pending.append(parent)
        return changed

    @staticmethod
    def _pass_on(node: _Node, rose: bool, pending: collections.deque[_Node], queued: set[_Node]) -> None:
        """``node``'s value changed (``rose``: went up): the actions that lead to it are stale, and their nodes
        queued for a backup, except where the value rose under an action that is not the node's best: that
        action's expected cost only rose, so the node's best action and value stay (the action is recomputed
        at the node's next backup)."""
        for parent, action in node.parents:
            if parent.stale is None:
                parent.stale = {action}
            else:
                parent.stale.add(action)
            if rose and action != parent.best:
                continue
            if parent not in queued:
                queued.add(parent)
                pending.append(parent)

    def _reroute(self, changed: dict[_Node, int]) -> None:
        """The reaches after the best action of each node of ``changed`` went from the one given there to
        its own: the node's reach leaves the old action's branches and flows down the new one's."""
        if lao is not None:
            self._flow(lao.reroute(changed))
            return
        pending: dict[_Node, float] = {}
        for node, old in changed.items():
            reach = node.reach
            if node.best == old or reach == 0.0:
                continue
            if old >= 0:
                for p, _, child in node.children[old]:
                    pending[child] = pending.get(child, 0.0) - reach * p
            if node.best >= 0:
                for p, _, child in node.children[node.best]:
                    pending[child] = pending.get(child, 0.0) + reach * p
        self._flow(pending)

    def _flow(self, pending: dict[_Node, float]) -> None:
        """Add each change of reach in ``pending`` to its node and pass it down the node's best action,
        weighted by the branches' probabilities, until every change is placed: only the part of the
        policy whose reach changes is visited. Around a loop of the policy a change comes back smaller
        each time; it stops when it is below :data:`_SETTLED_REACH` of the reach it adds to (a branch back
        to the node itself is summed at once). A frontier leaf whose reach changed goes (again) into
        :attr:`_tips`, once, when every change is placed. Should the changes go round a loop more than
        :data:`_MAX_FLOW` times (a loop the policy almost never leaves), the reaches are recomputed by one
        traversal of the policy instead (loops cut where they close, :meth:`best_policy`)."""
        self._exact = False
        if lao is not None:
            placed = lao.flow(pending, self._reached, _MAX_FLOW, _SETTLED_REACH, _CANCELLED, _SAME)
            if placed is None:
                self._retrace()
            else:
                self._push_tips(placed)
            return
        queue = collections.deque(pending)
        popleft, append, pop = queue.popleft, queue.append, pending.pop
        reached = self._reached
        frontier = LeafKind.FRONTIER
        tips: dict[_Node, None] = {}
        for _ in range(_MAX_FLOW):
            if not queue:
                self._push_tips(tips)
                return
            node = popleft()
            delta = pop(node)
            reach = node.reach
            if reach == 0.0:
                reached.append(node)
            reach += delta
            if delta < 0.0 and abs(reach) <= _CANCELLED * -delta:
                reach = 0.0  # all of it taken away: what is left is the sums' rounding
            node.reach = reach
            leaf = node.leaf
            if leaf is frontier:
                tips[node] = None
                continue
            if leaf is not None or node.best < 0 or abs(delta) <= _SETTLED_REACH * abs(reach):
                continue
            back, others = node.exits[node.best]  # type: ignore[misc]
            if back >= 1.0 - _SAME:  # an action that never leaves: no policy's (worth nothing, _q)
                continue
            if back > 0.0:  # the visits a branch back to the node itself adds, at once
                extra = delta * back / (1.0 - back)
                node.reach = reach + extra
                delta += extra
            for p, child in others:
                if child in pending:
                    pending[child] += delta * p
                else:
                    pending[child] = delta * p
                    append(child)
        self._retrace()

    def _push_tips(self, tips: Iterable[_Node]) -> None:
        """Each frontier leaf of ``tips`` (whose reach changed) into :attr:`_tips`, if it is reached with at
        least ``prune_below``."""
        for node in tips:
            if self._reached_enough(node.reach):
                heapq.heappush(self._tips, (-node.reach * node.value, -node.reach, node.number, node))

    def _reached_enough(self, reach: float) -> bool:
        """Whether a frontier leaf reached with ``reach`` is one to expand (else it is pruned)."""
        return reach >= self.prune_below and reach > 0.0

    def _leaf_reach(self, node: _Node, traversal: dict[int, float]) -> float:
        """The reach by which the search judged the frontier leaf ``node``: its own (:meth:`_flow`), which
        counts the visits of a loop that the traversal's (``traversal``, :meth:`best_policy`) cuts where it
        closes. With the traversal's, a leaf the search would expand next was shown pruned, and a policy
        out of budget had no frontier leaf."""
        return node.reach

    def _retrace(self) -> None:
        """Every reach and the tips anew, by one traversal of the best policy from the current start."""
        root = self._reached[0]
        for node in self._reached:
            node.reach = 0.0
        order, reach = self.best_policy(root)
        self._reached, self._tips = order, []
        for node in order:
            node.reach = reach[node.number]
            if node.leaf is LeafKind.FRONTIER and self._reached_enough(node.reach):
                heapq.heappush(self._tips, (-node.reach * node.value, -node.reach, node.number, node))
        self._exact = True

    def _dead_ends(self) -> list[_Node]:
        """Expanded nodes of finite value from which no policy ends at a goal or a frontier leaf with
        probability 1: the complement of the largest set whose nodes reach such a leaf by actions that
        never leave the set (almost-sure reachability, by shrinking the set until it holds)."""
        expanded = [n for same in self._nodes.values() for n in same if n.leaf is None and n.value < math.inf]
        alive = {n.number for n in expanded}
        while True:
            reached = _reaching_an_end([n for n in expanded if n.number in alive], alive)
            if reached == alive:
                return [n for n in expanded if n.number not in alive]
            alive = reached

    def best_policy(self, root: _Node) -> tuple[list[_Node], dict[int, float]]:
        """The nodes of the best policy from ``root`` in topological order (a node after every node that
        leads to it, loops cut where they close), and per node number the probability of reaching it
        along the branches that are not cut."""
        postorder: list[_Node] = []
        seen = {root.number}
        stack: list[tuple[_Node, Iterator[_Node]]] = [(root, self._policy_children(root))]
        while stack:
            node, children = stack[-1]
            for child in children:
                if child.number not in seen:
                    seen.add(child.number)
                    stack.append((child, self._policy_children(child)))
                    break
            else:
                stack.pop()
                postorder.append(node)
        order = postorder[::-1]
        position = {node.number: i for i, node in enumerate(order)}
        reach = dict.fromkeys(position, 0.0)
        reach[root.number] = 1.0
        for i, node in enumerate(order):
            if node.leaf is None and node.best >= 0:
                for p, _, child in node.children[node.best]:
                    if position[child.number] > i:
                        reach[child.number] += reach[node.number] * p
        return order, reach

    @staticmethod
    def _policy_children(node: _Node) -> Iterator[_Node]:
        if node.leaf is None and node.best >= 0:
            for _, _, child in node.children[node.best]:
                yield child

    def next_tip(self, root: _Node) -> _Node | None:
        """The frontier node of the best policy with the most expected cost at stake (reach × estimate;
        of equal ones the most likely, then the oldest), among those reached with at least
        ``prune_below``; None when there is none (the policy is complete). ``root`` is the start
        :meth:`root` returned: the reaches are kept for it."""
        while True:
            tips = self._tips
            while tips:
                _, negative, _, node = tips[0]
                if node.leaf is LeafKind.FRONTIER and node.reach == -negative:
                    break
                heapq.heappop(tips)
            found = tips[0][3] if tips else None
            if self._exact or (found is not None and found.reach > _TRUSTED_REACH):
                return found
            self._retrace()  # the reaches anew: then believed as they are

    def policy(self, root: _Node) -> tuple[PolicyNode, float]:
        """The best policy as a graph of :class:`PolicyNode`, and the probability of ending at a leaf
        that is not a goal (absorption in the policy's Markov chain, solved as a linear system)."""
        order, reach = self.best_policy(root)
        frozen: dict[int, PolicyNode] = {}
        for node in order:
            most_likely = int(np.argmax(self.belief(node)))
            if node.leaf is None and node.best >= 0:
                action = self.model.actions[node.best]
                frozen[node.number] = PolicyNode(
                    node.number, node.value, node.max_belief, most_likely, action.name, node.best, None
                )
            else:
                kind = node.leaf or LeafKind.LOOP
                if kind is LeafKind.FRONTIER and not self._reached_enough(self._leaf_reach(node, reach)):
                    kind = LeafKind.PRUNED
                frozen[node.number] = PolicyNode(
                    node.number, node.value, node.max_belief, most_likely, None, None, kind
                )
        position = {node.number: i for i, node in enumerate(order)}
        rows, cols, probabilities = [], [], []
        ends = np.zeros(len(order))
        for i, node in enumerate(order):
            policy_node = frozen[node.number]
            if policy_node.action_index is None:
                ends[i] = 0.0 if policy_node.leaf is LeafKind.GOAL else 1.0
                continue
            action = self.model.actions[node.best]
            branches = []
            for p, observation, child in node.children[node.best]:
                name = None if observation is None else action.observation.name(observation)
                branches.append(PolicyBranch(name, observation, p, frozen[child.number]))
                rows.append(i)
                cols.append(position[child.number])
                probabilities.append(p)
            policy_node.branches = tuple(branches)
        return frozen[root.number], _absorbed(ends, rows, cols, probabilities)


PolicyPlanner._search_kind = _Search


class _TraversalSearch(_Search):
    """The search before its bookkeeping was incremental (kept as the reference the tests and
    benchmarks/bench_contingent.py compare with): each tip is chosen by a traversal of the whole best
    policy, its reaches computed afresh along the branches in topological order (loops cut where they
    close), and of equal tips the first in that order is expanded."""

    def _flow(self, pending: dict[_Node, float]) -> None:
        pass

    def _leaf_reach(self, node: _Node, traversal: dict[int, float]) -> float:
        return traversal[node.number]

    def next_tip(self, root: _Node) -> _Node | None:
        order, reach = self.best_policy(root)
        best: _Node | None = None
        for node in order:
            here = reach[node.number]
            open_tip = node.leaf is LeafKind.FRONTIER and self._reached_enough(here)
            if open_tip and (best is None or here * node.value > reach[best.number] * best.value):
                best = node
        return best


class _TraversalPlanner(PolicyPlanner):
    """:class:`PolicyPlanner` with :class:`_TraversalSearch` (the reference)."""

    _search_kind = _TraversalSearch


def _unlink(nodes: dict[int, list[_Node]]) -> None:
    """Cut every link of a dropped search's graph (every node that is not a goal is in ``nodes``; a goal
    links only to the nodes it was reached from), so that it is freed as its last reference goes. Left to
    Python's cycle collector, a graph of 7,757 expansions (the hallway's policy, 745,000 objects) cost a
    walk of 0.3-0.7 s after the search had ended, a tenth of ``plan --policy``."""
    for same in nodes.values():
        for node in same:
            node.children, node.exits, node.parents, node.origin = {}, [], [], None
    nodes.clear()


def _key128(first: int, second: int) -> int:
    """Two wrapped unsigned 64-bit dot products as one integer: ``first`` above, ``second`` in the low 64 bits."""
    return (first << 64) | second


def _xlogx(values: np.ndarray) -> np.ndarray:
    """``x ln x`` of every entry, 0 where ``x`` is 0 (scipy.special.xlogy, without importing scipy.special:
    0.2 s of a plan command's start on the loaded machine). For probabilities: ``0 · ln 1`` is the 0 of a
    zero entry, and a NaN stays NaN."""
    return values * np.log(np.where(values > 0.0, values, 1.0))


def _ends(node: _Node) -> bool:
    """A leaf of finite value: a goal or a frontier belief."""
    return node.leaf is not None and node.value < math.inf


def _reaching_an_end(nodes: list[_Node], alive: set[int]) -> set[int]:
    """The numbers of ``nodes`` (those of ``alive``) that reach a leaf of finite value by actions whose
    every branch ends there or stays in ``alive``."""
    staying = {
        n.number: [b for b in n.children.values() if all(_ends(c) or c.number in alive for _, _, c in b)] for n in nodes
    }
    reached: set[int] = set()

    def reaches(node: _Node) -> bool:
        return any(any(_ends(c) or c.number in reached for _, _, c in b) for b in staying[node.number])

    queue = [n for n in nodes if reaches(n)]
    reached.update(n.number for n in queue)
    while queue:
        for parent, _ in queue.pop().parents:
            if parent.number in alive and parent.number not in reached and reaches(parent):
                reached.add(parent.number)
                queue.append(parent)
    return reached


def _absorbed(ends: np.ndarray, rows: list[int], cols: list[int], probabilities: list[float]) -> float:
    """The probability that the chain started in state 0 ends in a state whose ``ends`` is 1 (its
    transitions: ``rows -> cols`` with ``probabilities``; states without any end there). A chain of at
    most :data:`_DENSE_CHAIN` states is solved by NumPy; a larger one by SciPy's sparse solver, whose
    import (0.1 s, SciPy's dense linear algebra with it) a hallway's or a kitchen's policy does without."""
    n = len(ends)
    if n <= _DENSE_CHAIN:
        system = np.eye(n)
        np.subtract.at(system, (rows, cols), probabilities)  # two branches to one node add up, as in a CSR sum
        try:
            absorbed = np.linalg.solve(system, ends)
        except np.linalg.LinAlgError:
            return 1.0  # a loop the policy never leaves: it ends nowhere, so the robot replans
        return float(np.clip(absorbed[0], 0.0, 1.0))
    import scipy.sparse.linalg

    chain = scipy.sparse.csr_matrix((probabilities, (rows, cols)), shape=(n, n))
    sparse_system = (scipy.sparse.identity(n, format="csr") - chain).tocsc()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", scipy.sparse.linalg.MatrixRankWarning)
            absorbed = scipy.sparse.linalg.spsolve(sparse_system, ends)
    except scipy.sparse.linalg.MatrixRankWarning:
        return 1.0
    return float(np.clip(np.atleast_1d(absorbed)[0], 0.0, 1.0))
