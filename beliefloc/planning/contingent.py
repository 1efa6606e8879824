"""Contingent plans: a policy tree that branches on what each perception returns (AO* over beliefs).

Best-first search (:mod:`beliefloc.planning.best_first`) returns one path under the observations it
expects and replans when the world differs. Here the plan is an AND-OR tree:

* an *OR node* is a belief; the policy picks one action there;
* the action's *branches* are its observations ``o`` with ``p(o | a, b) > 0``, each leading to the
  successor belief (an action that observes nothing has one branch of probability 1);
* a *goal* leaf holds ``max(b) >= threshold`` and costs nothing more.

The value of a node is the expected cost to reach the goal under the model,
``V(b) = min_a [γ(a) + Σ_o p(o | a, b) V(b'_o)]``, and the policy is the minimising action at every
node. AO* (Nilsson; Hansen & Zilberstein's LAO* for the loops, here cut instead) grows the tree
one expansion at a time: it expands the tip of the current best policy with the most expected cost
at stake (reach probability × estimate), backs the values up to the root, and stops when every tip
of the best policy is a goal (the policy is *complete*) or a budget runs out.

**The estimate at the frontier** is the paper's entropy, put in units of cost:
``h(b) = κ · H(b)`` (0 at a goal). ``κ`` (:func:`information_price`) is the price of a nat of
information the model can keep buying: the cheapest actuation plus the cheapest perception, divided
by the most information one action gives from the uniform belief. Looking twice in the same place
teaches little, so one perception's price would be too low; a move and a look can be repeated.
``Heuristic.ZERO`` estimates 0 instead: admissible, so a complete policy is then the least expected
cost over all policies (feasible on small maps only).

**Pruning.** A branch the robot reaches with probability below ``prune_below`` (the product of the
observation probabilities from the start) is not expanded: it keeps its estimate in the expected
cost, and when the robot meets it, it replans (:class:`beliefloc.simulation.strategies.ContingentStrategy`).
So a policy has at most ``1 / prune_below`` branching leaves. Default :data:`DEFAULT_PRUNE_BELOW`.

**Loops.** A branch whose belief equals (:func:`belief_key`) a belief on the path from the root is a
*loop* leaf, worth the expected cost of the node it repeats. A return to the node it leaves, with
probability ``q``, is solved at once: the action's expected cost is ``(γ(a) + Σ_other p V) / (1 - q)``,
that of repeating it until it leads elsewhere; returns further up are solved by backing the values up
again until they agree. An action that always comes back (a look at states that all read alike) is
worth nothing to a policy and never chosen; if a loop branch happens, the robot replans.

**Honest ends.** :attr:`PlanStatus.FOUND`: the policy is complete (every leaf is a goal, a pruned
branch or a loop branch). :attr:`PlanStatus.BUDGET_EXCEEDED`: the expansion or time budget ran out
first; the tree then has *frontier* leaves, valued by the estimate, and a robot following it
replans when it reaches one. :attr:`PlanStatus.NO_PLAN`: every action from the start loops.
"""

from __future__ import annotations

import enum
import heapq
import itertools
import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from beliefloc.belief import entropy, uniform
from beliefloc.model import Model
from beliefloc.planning.best_first import BeliefCache, PlanStatus, SearchProgress, belief_key
from beliefloc.planning.settings import (
    DEFAULT_MAX_EXPANSIONS,
    DEFAULT_PRUNE_BELOW,
    DEFAULT_THRESHOLD,
    DEFAULT_TIME_LIMIT,
    Heuristic,
)
from beliefloc.planning.successors import SuccessorEvaluator

_CACHE_BYTES = 256 * 2**20
_PROGRESS_EVERY = 64
_MAX_REVISIONS = 100_000
"""Backups per expansion while the loops' values settle (each a walk up one path)."""
_INFORMATIVE = 1e-9
"""Less expected information than this (nats) from the uniform belief counts as none."""
_SAME = 1e-12
"""Entropy and max(b) closer than this make a branch a loop candidate (then compared by key)."""


class LeafKind(enum.Enum):
    """Why a node of the policy has no action."""

    GOAL = "goal"
    """One state holds at least the threshold."""
    FRONTIER = "frontier"
    """The budget ran out before this belief was expanded: replan here."""
    PRUNED = "pruned"
    """An observation less likely than ``prune_below``: replan if it occurs."""
    LOOP = "loop"
    """The belief of a node on the path from the root again: replan if it occurs."""


class _Node:
    """A node of the AND-OR tree under construction (an OR node: one belief)."""

    __slots__ = (
        "action",
        "best",
        "children",
        "entropy",
        "key",
        "leaf",
        "max_belief",
        "number",
        "observation",
        "parent",
        "probability",
        "reach",
        "repeats",
        "value",
    )

    def __init__(
        self,
        number: int,
        parent: _Node | None,
        action: int,
        observation: int | None,
        probability: float,
        entropy: float,
        max_belief: float,
    ) -> None:
        self.number = number
        self.parent = parent
        self.action = action
        self.observation = observation
        self.probability = probability
        self.reach: float = probability * (parent.reach if parent is not None else 1.0)
        self.entropy = entropy
        self.max_belief = max_belief
        self.value = 0.0
        self.leaf: LeafKind | None = LeafKind.FRONTIER
        self.key: bytes | None = None
        self.best = -1
        self.children: dict[int, list[_Node]] = {}
        self.repeats: _Node | None = None
        """A loop leaf: the node on its path whose belief it has."""


@dataclass(frozen=True)
class PolicyBranch:
    """One observation of a policy node's action."""

    observation: str | None
    """None for an action that observes nothing."""
    observation_index: int | None
    probability: float
    """``p(o | a, b)`` at the node."""
    node: PolicyNode


@dataclass(frozen=True)
class PolicyNode:
    """A belief of the policy: an action with its branches, or a leaf."""

    expected_cost: float
    """Expected cost from here to the goal under the model (frontier and pruned leaves: the estimate;
    loop leaves: the expected cost of the node they repeat)."""
    max_belief: float
    most_likely: int
    """The most likely state of this belief (its index)."""
    action: str | None
    """None at a leaf."""
    action_index: int | None
    branches: tuple[PolicyBranch, ...]
    leaf: LeafKind | None
    """None when the node acts."""
    repeats_up: int | None = None
    """A loop leaf: its belief is that of the node this many levels above it (1: the node whose action
    led here), and its expected cost is that node's."""

    def branch(self, observation: int | None) -> PolicyBranch | None:
        """The branch taken when ``observation`` is seen (None when the policy has none for it)."""
        for branch in self.branches:
            if branch.observation_index == observation:
                return branch
        return None

    def size(self) -> int:
        """Nodes in the tree under this one, itself and the leaves included."""
        count, stack = 0, [self]
        while stack:
            node = stack.pop()
            count += 1
            stack.extend(b.node for b in node.branches)
        return count

    def as_json(self, model: Model) -> dict[str, Any]:
        data: dict[str, Any] = {
            "expected_cost": self.expected_cost,
            "max_belief": self.max_belief,
            "most_likely": model.states.name(self.most_likely),
        }
        if self.action is not None:
            data["action"] = self.action
            data["branches"] = [
                {"observation": b.observation, "probability": b.probability, "node": b.node.as_json(model)}
                for b in self.branches
            ]
        else:
            data["leaf"] = self.leaf.value if self.leaf is not None else None
            if self.repeats_up is not None:
                data["repeats_levels_up"] = self.repeats_up
        return data


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
        """Nodes in the policy tree (leaves included)."""
        return self.root.size()

    def as_json(self, model: Model) -> dict[str, Any]:
        """What ``plan --policy --json`` prints: the status, the expected cost, the whole tree."""
        return {
            "found": self.found,
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
    """States sorted by their noise-free readings of every sensor, with the group boundaries (None
    when no action observes)."""
    key = np.zeros(model.n_states, dtype=np.int64)
    observing = False
    for action in model.actions:
        for part in action.observation.parts:
            observing = True
            _, codes = np.unique(np.stack([key, part.truth.astype(np.int64)]), axis=1, return_inverse=True)
            key = codes.astype(np.int64).ravel()
    if not observing:
        return None
    order = np.argsort(key, kind="stable")
    ordered = key[order]
    starts = np.flatnonzero(np.r_[True, ordered[1:] != ordered[:-1]])
    return order, starts


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
    """The least-expected-cost policy AO* finds from ``belief`` within the budgets (module docstring).

    ``prices`` are the estimate's (:func:`information_prices` when None; a caller that plans often
    computes them once per model; ignored with ``Heuristic.ZERO``). Deterministic: the same inputs
    give the same tree."""
    start = time.perf_counter()
    evaluator = evaluator or SuccessorEvaluator(model)
    if heuristic is Heuristic.ZERO:
        prices = NO_PRICES
    elif prices is None:
        prices = information_prices(model, evaluator)
    search = _Search(model, evaluator, threshold, prices, prune_below)
    root = search.root(belief)
    status = PlanStatus.FOUND
    expanded = 0
    while True:
        tip = search.next_tip()
        if tip is None:
            break
        if expanded >= max_expansions or time.perf_counter() - start > time_limit:
            status = PlanStatus.BUDGET_EXCEEDED
            break
        search.expand(tip)
        expanded += 1
        if progress is not None and expanded % _PROGRESS_EVERY == 0:
            progress(expanded, search.generated, time.perf_counter() - start)
    if root.leaf is None and root.best < 0:
        status = PlanStatus.NO_PLAN
    policy, open_share = search.policy(root)
    return PolicyResult(status, policy, expanded, search.generated, time.perf_counter() - start, prices, open_share)


class _Search:
    """The tree, its tips and its backups."""

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
        self._tips: list[tuple[float, int, _Node]] = []
        self._loops_into: dict[int, list[_Node]] = {}
        """Loop leaves by the number of the node whose belief they repeat (above their parent)."""
        self._cache: BeliefCache | None = None

    def root(self, belief: np.ndarray) -> _Node:
        self._cache = BeliefCache(max(4, _CACHE_BYTES // max(1, belief.nbytes)))
        node = self._node(None, -1, None, 1.0, entropy(belief), float(belief.max()), belief)
        self._cache.put(node.number, belief)
        self._push(node)
        return node

    def _node(
        self,
        parent: _Node | None,
        action: int,
        observation: int | None,
        p: float,
        h: float,
        top: float,
        belief: np.ndarray | None = None,
    ) -> _Node:
        node = _Node(next(self._numbers), parent, action, observation, p, h, top)
        if top >= self.threshold:
            node.leaf, node.value = LeafKind.GOAL, 0.0
        elif self.kappa > 0.0:
            assert self._cache is not None
            if belief is None:
                belief = self.evaluator.successor(self.belief(parent), action, observation) if parent else None
            assert belief is not None
            self._cache.put(node.number, belief)
            node.value = self.estimate(belief, h)
        return node

    def estimate(self, belief: np.ndarray, h: float) -> float:
        """``κ · H(S | Σ) + ρ · H(Σ)``: the entropy within the groups of states that read alike (Σ, every
        sensor's noise-free reading) is paid at the price of moving and perceiving, the entropy of
        which group the robot is in at the price of perceiving alone."""
        groups = self._signature
        if groups is None:
            return self.kappa * h
        order, starts = groups
        mass = np.add.reduceat(belief[order], starts)
        mass = mass[mass > 0.0]
        between = max(0.0, float(-(mass * np.log(mass)).sum()))
        within = max(0.0, h - between)
        return self.kappa * within + self.perceiving * between

    def belief(self, node: _Node) -> np.ndarray:
        assert self._cache is not None
        chain = []
        while (cached := self._cache.get(node.number)) is None:
            chain.append(node)
            assert node.parent is not None
            node = node.parent
        current = cached
        for child in reversed(chain):
            current = self.evaluator.successor(current, child.action, child.observation)
            self._cache.put(child.number, current)
        return current

    def _push(self, node: _Node) -> None:
        heapq.heappush(self._tips, (-node.reach * max(node.value, 1e-300), node.number, node))

    def next_tip(self) -> _Node | None:
        """The frontier tip of the current best policy with the most expected cost at stake."""
        while self._tips:
            _, _, node = heapq.heappop(self._tips)
            if node.leaf is LeafKind.FRONTIER and self._in_policy(node):
                return node
        return None

    @staticmethod
    def _in_policy(node: _Node) -> bool:
        while node.parent is not None:
            if node.parent.best != node.action:
                return False
            node = node.parent
        return True

    def expand(self, node: _Node) -> None:
        belief = self.belief(node)
        node.key = belief_key(belief)
        node.leaf = None
        children: dict[int, list[_Node]] = {}
        for stats in self.evaluator.evaluate(belief):
            child = self._node(
                node, stats.action, stats.observation, stats.probability, stats.entropy, stats.max_belief
            )
            self.generated += 1
            if child.leaf is None or child.leaf is LeafKind.FRONTIER:
                if child.reach < self.prune_below:
                    child.leaf = LeafKind.PRUNED
                elif (repeated := self._repeated(child)) is not None:
                    child.leaf, child.repeats = LeafKind.LOOP, repeated
                    if repeated is not node:
                        self._loops_into.setdefault(repeated.number, []).append(child)
            children.setdefault(stats.action, []).append(child)
        node.children = children
        self._revise(node)

    def _repeated(self, child: _Node) -> _Node | None:
        """The node on the child's path with the child's belief, if any (compared by key when entropy
        and max agree)."""
        ancestor = child.parent
        key: bytes | None = None
        while ancestor is not None:
            if abs(ancestor.entropy - child.entropy) <= _SAME and abs(ancestor.max_belief - child.max_belief) <= _SAME:
                if key is None:
                    key = belief_key(self.belief(child))
                if key == ancestor.key:
                    return ancestor
            ancestor = ancestor.parent
        return None

    def _revise(self, node: _Node) -> None:
        """Back the values up from ``node``. A node whose value moved moves the loop leaves that repeat
        it, so their parents are backed up in turn until the values agree (the loops' equations solved
        by iteration, at most :data:`_MAX_REVISIONS` backups); then queue the new tips."""
        pending = [node]
        tops: dict[int, _Node] = {}
        for _ in range(_MAX_REVISIONS):
            if not pending:
                break
            top, moved = self._backup(pending.pop())
            tops[top.number] = top
            for changed in moved:
                pending.extend(leaf.parent for leaf in self._loops_into.get(changed.number, ()) if leaf.parent)
        for top in tops.values():
            self._push_tips(top)

    def _q(self, node: _Node, action: int) -> float:
        """``γ(a) + Σ p V``, where a loop branch is worth the node it repeats. Coming back here with
        probability ``q`` is solved at once: ``Q = (γ(a) + Σ_rest p V) / (1 - q)``. An action all of whose
        branches loop is worth nothing to a policy (infinite)."""
        here = 0.0
        total = self.costs[action]
        every_loop = True
        for branch in node.children[action]:
            if branch.repeats is node:
                here += branch.probability
                continue
            if branch.repeats is not None:
                total += branch.probability * branch.repeats.value
            else:
                every_loop = False
                total += branch.probability * branch.value
        if every_loop or here >= 1.0 - _SAME:
            return math.inf
        return total / (1.0 - here)

    def _backup(self, node: _Node) -> tuple[_Node, list[_Node]]:
        """New values from ``node`` up to the root (stopping where nothing moves); returns the highest
        node whose best action changed (``node`` itself when none above it did) and the nodes whose
        value moved."""
        changed = node
        moved = []
        current: _Node | None = node
        while current is not None:
            best, value = -1, math.inf
            for action in current.children:
                q = self._q(current, action)
                if q < value:
                    best, value = action, q
            if best != current.best:
                changed = current
            same_value = value == current.value or abs(value - current.value) <= _SAME * max(1.0, abs(value))
            if not same_value:
                moved.append(current)
            unchanged = best == current.best and same_value
            current.best, current.value = best, value
            if unchanged and current is not node:
                break
            current = current.parent
        return changed, moved

    def _push_tips(self, top: _Node) -> None:
        """Queue the frontier tips of the best policy under ``top``."""
        stack = [top]
        while stack:
            node = stack.pop()
            if node.leaf is LeafKind.FRONTIER:
                self._push(node)
            elif node.leaf is None and node.best >= 0:
                stack.extend(node.children[node.best])

    def policy(self, root: _Node) -> tuple[PolicyNode, float]:
        """The best policy as frozen nodes, and the probability of ending at an open leaf."""
        open_share = 0.0

        def freeze(node: _Node) -> PolicyNode:
            nonlocal open_share
            most_likely = int(np.argmax(self.belief(node)))
            if node.leaf is not None or node.best < 0:
                leaf = node.leaf or LeafKind.LOOP
                if leaf is not LeafKind.GOAL:
                    open_share += node.reach
                value, up = node.value, None
                if node.repeats is not None:
                    value, up = node.repeats.value, _levels_up(node, node.repeats)
                return PolicyNode(value, node.max_belief, most_likely, None, None, (), leaf, up)
            action = self.model.actions[node.best]
            branches = tuple(
                PolicyBranch(
                    None if child.observation is None else action.observation.name(child.observation),
                    child.observation,
                    child.probability,
                    freeze(child),
                )
                for child in node.children[node.best]
            )
            return PolicyNode(node.value, node.max_belief, most_likely, action.name, node.best, branches, None, None)

        return freeze(root), open_share


def _levels_up(leaf: _Node, repeated: _Node) -> int:
    """How many levels above ``leaf`` the node ``repeated`` is (1: its parent)."""
    levels, node = 0, leaf
    while node is not repeated:
        assert node.parent is not None
        node, levels = node.parent, levels + 1
    return levels
