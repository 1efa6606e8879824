"""Scene processing: the SP-POMDP of Zhang, Sridharan & Wyatt 2015 (Sec. III-B, Fig. 3), a hierarchy of two
POMDPs that decides whether the target is in one view's image. Pure numpy, no I/O; randomness only
through passed Generators.

**The image.** A view gives ``n`` regions of interest (ROIs). When the target is in view, one ROI (at
a uniformly random place) holds it; every other ROI holds a *distractor*, drawn independently from a
distribution over appearances (the room's other objects, :func:`distractors`). An appearance is the
value every operator would see; operator ``k`` applied to a ROI of true value ``u`` reports ``o``
with probability ``C_k[u, o]`` (its confusion table), independently of every other application.

**Lower level (LL): one ROI.** States: the target's appearance (``s = 0``) and each distinct distractor
appearance (``s = 1..``), with prior ``P(s = 0) = 1/2`` and the rest in proportion to the
distractor distribution. Actions: apply an operator not yet applied to this ROI (cost ``c_k``), or
answer *target* / *not target* (cost ``error_cost`` times the probability the answer is wrong).
The belief after a set ``h`` of (operator, value) pairs is ``b_h(s) ∝ P(s) Π_{(k,o)∈h} C_k[u_s(k), o]``
and does not depend on their order, so the LL is solved *exactly* by value iteration over the
finite set of reachable beliefs (at most ``Π_k (1 + |values_k|)`` of them), written unnormalised::

    W(h) = min( error_cost · min(m_0(h), Σ_{s>0} m_s(h)),                      answer
                min_k  c_k Σ_s m_s(h) + Σ_o W(h ∪ {(k, o)}) )                   apply k ∉ h
    m_s(h) = P(s) Π_{(k,o)∈h} C_k[u_s(k), o]          (V(h) = W(h) / Σ_s m_s(h))

Ties go to answering (fewer operators), then to the lower operator index. The policy's outcome per
state -- the probability of each (answer, time) -- is read off its tree (:class:`LowLevelPolicy`).

**Higher level (HL): the image.** States: the target in ROI ``i`` (``i = 1..n``) or in none; prior
``P(none) = 1 - π``, ``P(i) = π / n`` (``π``: ``prior_present``). Action: process a ROI with the LL
policy, which answers *target* with probability ``α`` if the ROI holds the target and ``β`` if it holds
a distractor (the LL outcome averaged over the distractor distribution) -- the HL's observation
model. Each ROI is processed at most once; unprocessed ROIs are exchangeable, so the HL belief after
``m`` ROIs of which ``y`` answered *target* is, up to a common factor::

    none: 1 - π      each yes-ROI: (π/n) α/β      each no-ROI: (π/n) (1-α)/(1-β)      each unprocessed: π/n

Termination (the paper's "until a decision is made about the presence or absence of the target"):
report *present* when ``P(present) = 1 - P(none)`` reaches ``present_threshold``, *absent* when it
falls to ``absent_threshold``; when every ROI is processed or the elapsed time reaches the scene's
``time_limit``, report *present* iff ``P(present) >= 1/2``.

**Outcome** (:class:`SceneOutcome`): ``P(report present | target in view)``, ``P(report present | not)``,
the expected processing time and operator applications in both cases -- computed exactly by
propagating the distribution of (ROIs processed, yes answers, target's ROI processed, elapsed time)
through the HL, the elapsed time being a sum of operator costs. These are the VS-POMDP's observation
model and time cost of the view (:class:`SceneRates`). :func:`simulate_scene` runs the same two
policies on a sampled image (the simulated world's side, and the Monte Carlo check of the outcome).

Reading taken where the paper is terse: each operator at most once per ROI and each ROI at most once
per image (so that the policies are finite and the HL model with ``(α, β)`` is exact for
distractors drawn independently); the LL prior ``1/2`` (an LL knows nothing of the other ROIs).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from beliefloc.errors import DomainError, InvalidValueError

SAY_TARGET = -1
SAY_OTHER = -2
"""The LL's answers, as actions of :attr:`LowLevelPolicy.actions`."""
_TIME_DIGITS = 9
"""Elapsed times are sums of operator costs; rounded to this many digits to merge equal sums."""
MAX_HL_STATES = 20_000
"""The most (ROIs processed, answers, target seen, elapsed time) states the higher level's exact outcome
may hold at once; many ROIs and operators with unrelated costs could otherwise make it explode."""

Appearance = tuple[int, ...]
"""The value index each operator would see on a ROI (axis: operator)."""
History = tuple[tuple[int, int], ...]
"""(operator, reported value) pairs applied to one ROI, sorted by operator."""


@dataclass(frozen=True)
class Operator:
    """A visual operator: ``confusion[u, o] = P(reports o | true value u)`` (rows sum to 1)."""

    name: str
    cost: float
    values: tuple[str, ...]
    confusion: np.ndarray


@dataclass(frozen=True)
class SceneModel:
    """A validated scene model as numbers (:func:`scene_model` builds it from a domain)."""

    operators: tuple[Operator, ...]
    appearance: Mapping[str, Appearance]
    """Class -> its appearance (every class that has one, inherited ones resolved)."""
    background: Appearance
    rois: int
    error_cost: float = 10.0
    prior_present: float = 0.5
    present_threshold: float = 0.8
    absent_threshold: float = 0.2
    time_limit: float = 5.0

    def look(self, cls: str) -> Appearance:
        """The appearance of class ``cls``; :class:`InvalidValueError` when it has none (a class that no
        object of the domain has may be searched for, and need not look like anything)."""
        found = self.appearance.get(cls)
        if found is None:
            raise InvalidValueError(
                f"class {cls!r} has no appearance in the domain's scene model: give it, or an ancestor, an entry "
                "under scene.appearance (docs/domain-format.md, 'Scene model'), or analyse views with the fixed "
                "detector"
            )
        return found

    def describe(self, look: Appearance) -> str:
        """``colour=grey shape=box`` for an appearance."""
        return " ".join(f"{op.name}={op.values[v]}" for op, v in zip(self.operators, look, strict=True))


def scene_model(domain: Any) -> SceneModel | None:
    """The numeric scene model of a validated :class:`~beliefloc.knowledge.domain.Domain` (None without ``scene:``)."""
    section = domain.scene
    if section is None:
        return None
    operators = []
    for name, op in section.operators.items():
        values = op.values
        table = np.array([[row.get(v, 0.0) for v in values] for row in op.confusion.values()], dtype=float)
        operators.append(Operator(name, float(op.cost), values, table))

    def index(seen: Mapping[str, str]) -> Appearance:
        return tuple(op.values.index(seen[op.name]) for op in operators)

    appearance = {}
    for cls in domain.classes:
        seen = section.look_of(cls, domain.classes)
        if seen is not None:
            appearance[cls] = index(seen)
    return SceneModel(
        operators=tuple(operators),
        appearance=appearance,
        background=index(section.background),
        rois=section.rois,
        error_cost=section.error_cost,
        prior_present=section.prior_present,
        present_threshold=section.present_threshold,
        absent_threshold=section.absent_threshold,
        time_limit=section.time_limit,
    )


Distractors = tuple[tuple[Appearance, float], ...]
"""Distinct distractor appearances with their probabilities (summing to 1), sorted: a cache key."""


def distractors(model: SceneModel, classes: Sequence[str]) -> Distractors:
    """The distractor distribution of a room holding objects of ``classes`` (one entry per object):
    each object equally likely; a room with no objects shows only background."""
    looks = [model.look(cls) for cls in classes] or [model.background]
    counts: dict[Appearance, int] = {}
    for look in looks:
        counts[look] = counts.get(look, 0) + 1
    return tuple(sorted((look, count / len(looks)) for look, count in counts.items()))


# --- lower level -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class LowLevelPolicy:
    """The LL policy of one ROI: the action at every reachable history, and its outcome per state."""

    looks: tuple[Appearance, ...]
    """The states' appearances: the target's first, then the distractors'."""
    prior: np.ndarray
    """``P(s)`` (axis: state)."""
    actions: Mapping[History, int]
    """History -> an operator index, :data:`SAY_TARGET` or :data:`SAY_OTHER`."""
    value: float
    """The policy's expected cost from the empty history (time + error_cost x P(wrong))."""
    likelihoods: tuple[np.ndarray, ...]
    """``likelihoods[k][s, o] = C_k[u_s(k), o]`` (axes: state, value)."""
    outcomes: tuple[tuple[tuple[float, float, float, float], ...], ...]
    """Per state: ``(time, operators, P(answer target), P(answer not target))`` per distinct (time,
    operators) pair of the policy's leaves."""

    def answer_target(self, state: int) -> float:
        """``P(the LL answers target | state)``."""
        return float(sum(p for _, _, p, _ in self.outcomes[state]))

    def expected_time(self, state: int) -> float:
        return float(sum(t * (py + pn) for t, _, py, pn in self.outcomes[state]))

    def expected_operators(self, state: int) -> float:
        return float(sum(k * (py + pn) for _, k, py, pn in self.outcomes[state]))


def solve_low_level(
    model: SceneModel, target: Appearance, mix: Distractors, *, apply_all: bool = False
) -> LowLevelPolicy:
    """Exact value iteration over the LL's reachable beliefs (module docstring). ``apply_all``: the
    baseline that applies every operator, in order, and then gives the likelier answer."""
    looks = (target, *(look for look, _ in mix))
    prior = np.array([0.5, *(0.5 * p for _, p in mix)], dtype=float)
    likelihoods = tuple(op.confusion[np.array([look[k] for look in looks])] for k, op in enumerate(model.operators))
    costs = [op.cost for op in model.operators]
    actions: dict[History, int] = {}
    memo: dict[History, float] = {}

    def masses(history: History) -> np.ndarray:
        m = prior.copy()
        for k, o in history:
            m = m * likelihoods[k][:, o]
        return m

    def solve(history: History) -> float:
        if history in memo:
            return memo[history]
        m = masses(history)
        total = float(m.sum())
        target_mass, other_mass = float(m[0]), total - float(m[0])
        best = model.error_cost * min(target_mass, other_mass)
        action = SAY_OTHER if other_mass >= target_mass else SAY_TARGET
        used = {k for k, _ in history}
        if apply_all and len(used) < len(costs):
            k = len(used)
            best = costs[k] * total + sum(
                solve(tuple(sorted((*history, (k, o))))) for o in range(likelihoods[k].shape[1])
            )
            memo[history], actions[history] = best, k
            return best
        for k in range(len(costs)):
            if k in used or total <= 0.0:
                continue
            value = costs[k] * total
            for o in range(likelihoods[k].shape[1]):
                if value >= best:
                    break
                value += solve(tuple(sorted((*history, (k, o)))))
            if value < best - 1e-12 * max(1.0, best):
                best, action = value, k
        memo[history] = best
        actions[history] = action
        return best

    value = solve(())
    outcomes = _ll_outcomes(actions, likelihoods, costs, len(looks))
    return LowLevelPolicy(looks, prior, actions, value, likelihoods, outcomes)


def _ll_outcomes(
    actions: Mapping[History, int], likelihoods: tuple[np.ndarray, ...], costs: list[float], states: int
) -> tuple[tuple[tuple[float, float, float, float], ...], ...]:
    """Walk the policy's tree carrying ``P(history | s)`` for every state at once."""
    table: dict[tuple[float, int], np.ndarray] = {}  # (time, operators) -> (states, 2)
    stack: list[tuple[History, np.ndarray, float]] = [((), np.ones(states), 0.0)]
    while stack:
        history, reach, elapsed = stack.pop()
        action = actions.get(history, SAY_OTHER)
        if action < 0:
            key = (round(elapsed, _TIME_DIGITS), len(history))
            cell = table.setdefault(key, np.zeros((states, 2)))
            cell[:, 0 if action == SAY_TARGET else 1] += reach
            continue
        for o in range(likelihoods[action].shape[1]):
            branch = reach * likelihoods[action][:, o]
            if branch.any():
                stack.append((tuple(sorted((*history, (action, o)))), branch, elapsed + costs[action]))
    keys = sorted(table)
    return tuple(
        tuple((t, float(k), float(table[t, k][s, 0]), float(table[t, k][s, 1])) for t, k in keys) for s in range(states)
    )


# --- higher level ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class SceneOutcome:
    """What the SP-POMDP's solution says about one kind of view (the VS-POMDP's observation model)."""

    true_positive: float
    """P(report present | target in view)."""
    false_positive: float
    """P(report present | target not in view)."""
    time_in: float
    """Expected processing time with the target in view."""
    time_out: float
    """... and without it."""
    operators_in: float
    """Expected operator applications with the target in view."""
    operators_out: float
    alpha: float
    """The LL's P(answer target | the ROI holds the target)."""
    beta: float
    """The LL's P(answer target | the ROI holds a distractor)."""
    low_level: LowLevelPolicy = field(repr=False, compare=False)
    apply_all: bool = False
    """The baseline: every operator on every ROI, the likelier answer at the end (no thresholds, no
    time limit)."""


def hl_present(model: SceneModel, alpha: float, beta: float, processed: int, yes: int) -> float:
    """The HL belief that the target is in the image after ``processed`` ROIs, ``yes`` of which answered
    *target* (module docstring)."""
    n, pi = model.rois, model.prior_present
    with np.errstate(divide="ignore", invalid="ignore"):
        yes_weight = alpha / beta if beta > 0 else (np.inf if alpha > 0 else 1.0)
        no_weight = (1 - alpha) / (1 - beta) if beta < 1 else (np.inf if alpha < 1 else 1.0)
    if yes and not np.isfinite(yes_weight):
        return 1.0
    if processed - yes and not np.isfinite(no_weight):
        return 1.0
    present = pi / n * (yes * yes_weight + (processed - yes) * no_weight + (n - processed))
    return float(present / (present + 1.0 - pi))


def hl_belief(model: SceneModel, alpha: float, beta: float, answers: Sequence[bool]) -> np.ndarray:
    """The HL belief over (target in ROI 1..n, none) after the first ``len(answers)`` ROIs answered
    ``answers`` (True: target), for display. Axis: ROI, then ``none`` last."""
    n, pi = model.rois, model.prior_present
    weights = np.full(n + 1, pi / n)
    weights[n] = 1.0 - pi
    for i, said in enumerate(answers):
        like = np.full(n + 1, beta if said else 1.0 - beta)
        like[i] = alpha if said else 1.0 - alpha
        weights = weights * like
    total = weights.sum()
    result: np.ndarray = weights / total if total > 0 else weights
    return result


def _decision(
    model: SceneModel, present: float, processed: int, elapsed: float, apply_all: bool = False
) -> bool | None:
    """The HL's termination rule: True present, False absent, None go on. ``apply_all``: only when
    every ROI is processed."""
    if apply_all:
        return present >= 0.5 if processed >= model.rois else None
    if present >= model.present_threshold:
        return True
    if present <= model.absent_threshold:
        return False
    if processed >= model.rois or elapsed >= model.time_limit - 1e-9:
        return present >= 0.5
    return None


def solve_scene(model: SceneModel, target: Appearance, mix: Distractors, *, apply_all: bool = False) -> SceneOutcome:
    """The SP-POMDP's outcome for a view whose distractors follow ``mix`` (module docstring);
    ``apply_all``: the baseline that applies every operator to every ROI."""
    ll = solve_low_level(model, target, mix, apply_all=apply_all)
    weights = np.array([p for _, p in mix], dtype=float)
    target_rows = ll.outcomes[0]
    # the distractor's (time, ops) outcomes, averaged over the distractor distribution
    merged: dict[tuple[float, float], list[float]] = {}
    for s, w in enumerate(weights, start=1):
        for t, k, py, pn in ll.outcomes[s]:
            entry = merged.setdefault((t, k), [0.0, 0.0])
            entry[0] += w * py
            entry[1] += w * pn
    distractor_rows = tuple((t, k, py, pn) for (t, k), (py, pn) in sorted(merged.items()))
    alpha = sum(py for _, _, py, _ in target_rows)
    beta = sum(py for _, _, py, _ in distractor_rows)
    rows = (target_rows, distractor_rows)
    tp, t_in, k_in = _propagate(model, alpha, beta, *rows, in_view=True, apply_all=apply_all)
    fp, t_out, k_out = _propagate(model, alpha, beta, *rows, in_view=False, apply_all=apply_all)
    return SceneOutcome(tp, fp, t_in, t_out, k_in, k_out, alpha, beta, ll, apply_all)


def _propagate(
    model: SceneModel,
    alpha: float,
    beta: float,
    target_rows: Sequence[tuple[float, float, float, float]],
    distractor_rows: Sequence[tuple[float, float, float, float]],
    *,
    in_view: bool,
    apply_all: bool = False,
) -> tuple[float, float, float]:
    """``(P(report present), E[time], E[operators])`` through the HL, exactly: the distribution of
    (processed, yes, target processed, elapsed) moves forward one ROI at a time."""
    n = model.rois
    # the elapsed time only matters when the scene's time limit can be reached: else keep it out of the state
    longest = max(t for rows in (target_rows, distractor_rows) for t, _, _, _ in rows)
    timed = apply_all is False and n * longest >= model.time_limit - 1e-9
    frontier: dict[tuple[int, int, bool, float], float] = {(0, 0, False, 0.0): 1.0}
    present = time = operators = 0.0
    beliefs = {(m, y): hl_present(model, alpha, beta, m, y) for m in range(n + 1) for y in range(m + 1)}
    while frontier:
        nxt: dict[tuple[int, int, bool, float], float] = {}
        for (m, y, seen, elapsed), p in frontier.items():
            decided = _decision(model, beliefs[m, y], m, elapsed, apply_all)
            if decided is not None:
                present += p * decided
                continue
            p_target = (1.0 / (n - m)) if (in_view and not seen) else 0.0
            for rows, q, is_target in ((target_rows, p_target, True), (distractor_rows, 1.0 - p_target, False)):
                if q <= 0.0:
                    continue
                for t, k, py, pn in rows:
                    time += p * q * (py + pn) * t
                    operators += p * q * (py + pn) * k
                    at = round(elapsed + t, _TIME_DIGITS) if timed else 0.0
                    for said, pr in ((1, py), (0, pn)):
                        if pr > 0.0:
                            key = (m + 1, y + said, seen or is_target, at)
                            nxt[key] = nxt.get(key, 0.0) + p * q * pr
        if len(nxt) > MAX_HL_STATES:
            raise DomainError(
                f"the scene model is too large to solve exactly: {len(nxt):,} states of the higher level after "
                f"{next(iter(nxt))[0]} ROIs (at most {MAX_HL_STATES:,}); use fewer ROIs, fewer operators, or "
                "operator costs that are multiples of one another"
            )
        frontier = nxt
    return present, time, operators


class SceneSolver:
    """:func:`solve_scene` with a cache keyed by (target appearance, distractor distribution): the model
    (ROI count and all) is the solver's, so a view is solved once per kind."""

    def __init__(self, model: SceneModel, *, apply_all: bool = False) -> None:
        self.model = model
        self.apply_all = apply_all
        self._cache: dict[tuple[Appearance, Distractors], SceneOutcome] = {}

    def outcome(self, target_class: str, room_classes: Sequence[str]) -> SceneOutcome:
        target = self.model.look(target_class)
        mix = distractors(self.model, room_classes)
        key = (target, mix)
        found = self._cache.get(key)
        if found is None:
            found = solve_scene(self.model, target, mix, apply_all=self.apply_all)
            self._cache[key] = found
        return found


# --- the rates of every view ----------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class SceneRates:
    """The SP-POMDP's outcome for every view (axis: view), the VS-POMDP's per-view observation model."""

    true_positive: np.ndarray
    false_positive: np.ndarray
    time_in: np.ndarray
    time_out: np.ndarray
    target_class: str
    outcomes: tuple[SceneOutcome, ...]
    """One outcome per room (axis: the space's rooms)."""
    room_classes: tuple[tuple[str, ...], ...]
    """The classes of the distractor objects the robot expects in each room."""

    def expected_time(self, p_in: np.ndarray) -> np.ndarray:
        """The expected processing time of every view when it holds the target with probability ``p_in``."""
        result: np.ndarray = p_in * self.time_in + (1.0 - p_in) * self.time_out
        return result


def scene_rates(
    solver: SceneSolver, target_class: str, room_of_view: np.ndarray, room_classes: Sequence[Sequence[str]]
) -> SceneRates:
    """Per view, the outcome of its room's scene (``room_classes[k]``: the distractor objects' classes in room k)."""
    outcomes = tuple(solver.outcome(target_class, classes) for classes in room_classes)
    tp = np.array([o.true_positive for o in outcomes])[room_of_view]
    fp = np.array([o.false_positive for o in outcomes])[room_of_view]
    t_in = np.array([o.time_in for o in outcomes])[room_of_view]
    t_out = np.array([o.time_out for o in outcomes])[room_of_view]
    return SceneRates(tp, fp, t_in, t_out, target_class, outcomes, tuple(tuple(c) for c in room_classes))


# --- simulation -------------------------------------------------------------------------------------


@dataclass(frozen=True)
class RoiTrace:
    """One ROI processed: what it held, the operators applied with what they reported, the LL's answer
    and the HL belief after it."""

    roi: int
    look: Appearance
    holds_target: bool
    applied: tuple[tuple[int, int], ...]
    """(operator, reported value) in the order applied."""
    said_target: bool
    present_belief: float
    """HL: P(target in the image) after this ROI."""
    belief: tuple[float, ...] = ()
    """HL: the belief over (target in ROI 1..n, in none) after this ROI (:func:`hl_belief`)."""


@dataclass(frozen=True)
class SceneTrace:
    """One image processed by the two policies."""

    present: bool
    time: float
    operators: int
    rois: tuple[RoiTrace, ...]
    target_roi: int | None

    def as_json(self, model: SceneModel) -> dict[str, Any]:
        return {
            "report": "present" if self.present else "absent",
            "processing_time": self.time,
            "operators_applied": self.operators,
            "rois": [
                {
                    "roi": r.roi,
                    "holds_target": r.holds_target,
                    "operators": [[model.operators[k].name, model.operators[k].values[o]] for k, o in r.applied],
                    "answer": "target" if r.said_target else "not-target",
                    "p_present": r.present_belief,
                    "hl_belief": list(r.belief),
                }
                for r in self.rois
            ],
        }


def sample_image(
    model: SceneModel, target: Appearance | None, room_looks: Sequence[Appearance], rng: np.random.Generator
) -> tuple[list[Appearance], int | None]:
    """The ROIs of one image: the target's (``target`` None: not in view) at a random place among
    distractors drawn uniformly (with replacement) from ``room_looks`` (background when empty)."""
    pool = list(room_looks) or [model.background]
    picks = rng.integers(len(pool), size=model.rois)
    looks = [pool[int(i)] for i in picks]
    where = None
    if target is not None:
        where = int(rng.integers(model.rois))
        looks[where] = target
    return looks, where


def simulate_scene(
    model: SceneModel,
    outcome: SceneOutcome,
    looks: Sequence[Appearance],
    target_roi: int | None,
    rng: np.random.Generator,
) -> SceneTrace:
    """Run the HL and LL policies of ``outcome`` on the ROIs ``looks`` (processed in order), drawing each
    operator's report from its confusion row."""
    ll = outcome.low_level
    answers: list[bool] = []
    traces = []
    elapsed, applied_total, yes = 0.0, 0, 0
    present = hl_present(model, outcome.alpha, outcome.beta, 0, 0)
    decided = _decision(model, present, 0, 0.0, outcome.apply_all)
    for i, look in enumerate(looks):
        if decided is not None:
            break
        history: History = ()
        order: list[tuple[int, int]] = []
        while True:
            action = ll.actions.get(history, SAY_OTHER)
            if action < 0:
                break
            op = model.operators[action]
            o = int(rng.choice(len(op.values), p=op.confusion[look[action]]))
            order.append((action, o))
            history = tuple(sorted((*history, (action, o))))
            elapsed += op.cost
        said = action == SAY_TARGET
        answers.append(said)
        yes += said
        applied_total += len(order)
        present = hl_present(model, outcome.alpha, outcome.beta, i + 1, yes)
        belief = hl_belief(model, outcome.alpha, outcome.beta, answers)
        traces.append(RoiTrace(i, look, target_roi == i, tuple(order), said, present, tuple(belief.tolist())))
        decided = _decision(model, present, i + 1, round(elapsed, _TIME_DIGITS), outcome.apply_all)
    assert decided is not None  # every ROI processed ends the image
    return SceneTrace(decided, elapsed, applied_total, tuple(traces), target_roi)
