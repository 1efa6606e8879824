"""The control loop of Zhang, Sridharan & Wyatt 2015, Algorithm 1: select, execute, update, revise, decide.

Each iteration (line numbers of Algorithm 1)::

    4   v_t  = policy(b_{t-1}, robot)                          choose a view
    5   o_t  = world.detect(view v_t)                          travel + analysis time units (with a
                                                               scene model: the SP-POMDP's report
                                                               and its processing time, scene.py)
    11  p(o_t | E), p(o_t | ¬E)   from b_{t-1}                 Eq. 9 (the predictive likelihood)
    6   b_t ∝ b_ob · b_kb, b_ob *= O(·, v_t, o_t)              Eq. 6-7 (CellBelief.observe_view)
    7   the other objects' detections in v_t; an object whose  dynamic KB only (dynamic.py)
        room belief passes the commit threshold is committed
    8-9 KB changed: b_kb = new room prior (Eq. 5) spread,      CellBelief.revise: reuse, discard
        b_t recomputed from it (Eq. 7)                         or trust-factor
    12  p(E | o_1:t)                                           Eq. 10-12 (ExistenceBelief)
    14  p(¬E | o_1:t) > τ-        -> NOT_FOUND
    16  max(b_t) > τ+             -> FOUND (the most likely cell)
        time ≥ time limit         -> TIME_LIMIT (the most likely cell is reported)

Eq. 9 is evaluated on the belief *before* ``o_t`` is folded in, so the product over steps is the
likelihood of the whole sequence, ``p(o_1:t | E)``, as Eq. 12 keeps it.

Rooms the robot cannot enter (``accessible: false``): the knowledge base's prior still gives them
their share (Eq. 2-5 do not read the ``accessible`` fluent), but the robot can never look there,
so a belief kept on them could never reach τ+ nor let p(¬E) grow. The search therefore conditions
on the rooms it can enter: :func:`cell_prior` gives the other rooms nothing and renormalises.

Accuracy (Sec. IV: "falls off as a Gaussian function of the distance between the reported location
and the ground truth"): ``exp(-d² / (2 σ²))`` with ``d`` the Euclidean distance on the plane in
cells and σ = :data:`ACCURACY_SIGMA` = 2 cells (a neighbour scores 0.88, two cells away 0.61, four
0.14; the paper does not give σ). A NOT_FOUND verdict scores 1 when the target is absent and 0
when it is present; reporting a cell when the target is absent scores 0.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from beliefloc.errors import InvalidValueError
from beliefloc.object_search.dynamic import DynamicFactory, DynamicKnowledge
from beliefloc.object_search.existence import ExistenceBelief, detection_likelihoods
from beliefloc.object_search.policy import Policy
from beliefloc.object_search.posterior import CellBelief, TrustFactor, spread_room_prior
from beliefloc.object_search.scene import SceneModel, SceneTrace
from beliefloc.object_search.settings import Metareasoning, PolicyName, Revision, check_time_limit
from beliefloc.object_search.space import SearchSpace
from beliefloc.object_search.world import SceneTarget, SimulatedTarget

ACCURACY_SIGMA = 2.0
"""σ of the Gaussian accuracy fall-off, in cells."""
TAU_FOUND = 0.8
TAU_ABSENT = 0.7
TIME_LIMIT = 100.0


class Verdict(str, enum.Enum):
    """How a search ended (lines 14-16 of Algorithm 1, and the time limit)."""

    FOUND = "found"
    """One cell's belief passed τ+: the target is there."""
    NOT_FOUND = "not-found"
    """p(¬E) passed τ-: the target is probably not in the domain."""
    TIME_LIMIT = "time-limit"
    """The time ran out; the most likely cell is reported."""


@dataclass(frozen=True)
class Step:
    """One iteration: where the robot went, what it saw, and the beliefs after."""

    index: int
    view: int
    """The view point (= the cell the robot stands on)."""
    present: bool
    cost: float
    """Travel and analysis time of this step."""
    time: float
    """Time units used so far."""
    p_exists: float
    best_cell: int
    best_belief: float
    belief: np.ndarray | None = None
    """The cell belief after the step (only with ``keep_beliefs``)."""
    commits: tuple[tuple[str, str], ...] = ()
    """``(object, room)`` facts committed to the knowledge base at this step (dynamic KB)."""
    scene: SceneTrace | None = None
    """The view's image as the SP-POMDP processed it (with a scene model; None: the fixed detector)."""

    def as_json(self, space: SearchSpace, model: SceneModel | None = None) -> dict[str, Any]:
        """The step as JSON, cells named by ``space``; with a scene model, the image processed (``scene``)."""
        data = {
            "step": self.index,
            "view": space.cell_name(self.view),
            "observation": "present" if self.present else "absent",
            "cost": self.cost,
            "time": self.time,
            "p_exists": self.p_exists,
            "max_belief": self.best_belief,
            "most_likely": space.cell_name(self.best_cell),
            "commits": [list(fact) for fact in self.commits],
        }
        if self.scene is not None and model is not None:
            data["scene"] = self.scene.as_json(model)
        return data


@dataclass(frozen=True)
class SearchRecord:
    """A whole search as plain data."""

    policy: PolicyName
    metareasoning: Metareasoning
    steps: tuple[Step, ...]
    verdict: Verdict
    time: float
    reported_cell: int | None
    """The cell claimed (FOUND, TIME_LIMIT); None for NOT_FOUND."""
    true_cell: int | None
    """Where the target was; None when absent."""
    error_cells: float | None
    """Distance between the reported and the true cell, when both exist."""
    accuracy: float
    initial_belief: np.ndarray
    revision: Revision = Revision.REUSE
    dynamic_kb: bool = False
    rejected: tuple[tuple[str, str], ...] = ()
    """Commits the knowledge base refused (it would have had no answer set)."""
    room_prior: np.ndarray = field(default_factory=lambda: np.zeros(0))
    """The knowledge base's room prior the search was given (axis: the space's rooms)."""
    seed: int | None = None
    """The seed of :func:`seeded_search` (None: the generators were handed in)."""
    scene_model: SceneModel | None = None
    """The scene model that processed the views (None: the fixed detector)."""

    @property
    def operators_applied(self) -> int | None:
        """Operator applications over every view's image (None without a scene model)."""
        if self.scene_model is None:
            return None
        return sum(step.scene.operators for step in self.steps if step.scene is not None)

    @property
    def processing_time(self) -> float | None:
        """Time spent processing images (None without a scene model); the rest of :attr:`time` is travel."""
        if self.scene_model is None:
            return None
        return float(sum(step.scene.time for step in self.steps if step.scene is not None))

    @property
    def commits(self) -> tuple[tuple[str, str], ...]:
        """Every fact committed to the knowledge base, in order."""
        return tuple(fact for step in self.steps for fact in step.commits)

    def as_json(self, space: SearchSpace, *, domain: str, target: str) -> dict[str, Any]:
        """The search as JSON (a caller adds the wall-clock ``seconds`` it measured): cells
        named by ``space`` (:meth:`SearchSpace.cell_name`), the search of ``domain`` for ``target``.
        The key ``strategy`` is the metareasoning (the name the JSON has always had)."""

        def name(cell: int | None) -> str | None:
            return None if cell is None else space.cell_name(cell)

        data: dict[str, Any] = {
            "domain": domain,
            "target": target,
            "policy": self.policy.value,
            "strategy": self.metareasoning.value,
            "revision": self.revision.value,
            "dynamic_kb": self.dynamic_kb,
            "seed": self.seed,
            "room_prior": dict(zip(space.rooms, self.room_prior.tolist(), strict=True)),
            "true_cell": name(self.true_cell),
            "steps": [step.as_json(space, self.scene_model) for step in self.steps],
            "verdict": self.verdict.value,
            "time": self.time,
            "reported_cell": name(self.reported_cell),
            "error_cells": self.error_cells,
            "accuracy": self.accuracy,
            "rejected_commits": [list(fact) for fact in self.rejected],
        }
        if self.scene_model is not None:
            data["operators_applied"] = self.operators_applied
            data["processing_time"] = self.processing_time
        return data


def accuracy(space: SearchSpace, reported: int | None, true: int | None, sigma: float = ACCURACY_SIGMA) -> float:
    """The Gaussian fall-off of the module docstring."""
    if reported is None:
        return 1.0 if true is None else 0.0
    if true is None:
        return 0.0
    distance = float(space.distances_from(true)[reported])
    return math.exp(-(distance**2) / (2 * sigma**2))


def cell_prior(space: SearchSpace, room_prior: np.ndarray) -> np.ndarray:
    """``b_kb``: the room prior (axis: ``space.rooms``) restricted to the rooms the robot can enter,
    renormalised, and spread evenly over each room's cells (see the module docstring)."""
    reachable = np.where(space.accessible, np.asarray(room_prior, dtype=float), 0.0)
    total = reachable.sum()
    if not total > 0:
        raise ValueError("the room prior gives nothing to the rooms the robot can enter")
    return spread_room_prior(reachable / total, space.room_of_cell)


def initial_prior(space: SearchSpace, room_prior: np.ndarray, policy: Policy) -> np.ndarray:
    """``b_kb`` for a policy: :func:`cell_prior`, or uniform over the cells the robot can search for a
    policy without knowledge base."""
    if not policy.kb_prior:
        reachable = space.reachable.astype(float)
        uniform: np.ndarray = reachable / reachable.sum()
        return uniform
    return cell_prior(space, room_prior)


def run_search(
    space: SearchSpace,
    room_prior: np.ndarray,
    target: SimulatedTarget | SceneTarget,
    policy: Policy,
    existence: ExistenceBelief,
    *,
    tau_found: float = TAU_FOUND,
    time_limit: float = TIME_LIMIT,
    sigma: float = ACCURACY_SIGMA,
    keep_beliefs: bool = False,
    revision: Revision = Revision.REUSE,
    trust: TrustFactor | None = None,
    dynamic: DynamicKnowledge | None = None,
) -> SearchRecord:
    """Algorithm 1 until a verdict. ``existence`` is updated in place (it holds the MC samples);
    ``existence.tau_minus`` is τ-.

    ``revision`` says how a new room prior is combined with the kept likelihood (Eq. 7 with re-use
    or discard, or the trust-factor pool, which also applies from the start with ``trust`` or the
    default :class:`TrustFactor`). ``dynamic``: the other objects, the robot's tracker of them and
    the knowledge base to commit to (lines 7-10); None is a static KB. A policy without knowledge
    base (``pomdp-only``) ignores both. Deterministic given the generators of ``target``,
    ``existence`` and ``dynamic.objects``; ``dynamic`` is updated in place.
    """
    if not 0 < tau_found < 1:
        raise InvalidValueError(f"tau+ must be between 0 and 1 (exclusive), got {tau_found:g}")
    check_time_limit(time_limit)
    uses_kb = policy.kb_prior
    pooled = revision is Revision.TRUST and uses_kb
    cells = CellBelief.start(initial_prior(space, room_prior, policy), (trust or TrustFactor()) if pooled else None)
    start_belief = cells.posterior
    belief = start_belief
    robot, time = space.start, 0.0
    steps: list[Step] = []
    rejected: list[tuple[str, str]] = []
    while True:
        view = policy.select(space, belief, robot)
        travel = float(space.travel_cost * space.distances_from(robot)[view])
        view_cells = space.view_cells(view)
        detector = space.view_detector(view)
        scene = None
        if isinstance(target, SceneTarget):
            scene = target.analyse(view, view_cells)
            present, cost = scene.present, travel + scene.time
        else:
            present, cost = target.detect(view_cells), travel + space.analysis_cost
        like_e, like_not_e = detection_likelihoods(
            belief, view_cells, present, detector.true_positive, detector.false_positive
        )
        cells = cells.observe_view(view_cells, present, detector)
        commits: list[tuple[str, str]] = []
        if dynamic is not None and uses_kb:
            new_prior = None
            for name, room in dynamic.tracker.observe(view_cells, dynamic.objects.detect(view_cells)):
                fact = (name, space.rooms[room])
                revised = dynamic.link.commit(*fact)
                if revised is None:
                    rejected.append(fact)
                else:
                    commits.append(fact)
                    new_prior = revised
            if new_prior is not None:
                cells = cells.revise(cell_prior(space, new_prior), revision)
        belief = cells.posterior
        existence.observe(like_e, like_not_e)
        p_exists = existence.probability_exists()
        robot, time = view, time + cost
        best = int(np.argmax(belief))
        steps.append(
            Step(
                len(steps) + 1,
                view,
                present,
                cost,
                time,
                p_exists,
                best,
                float(belief[best]),
                belief if keep_beliefs else None,
                tuple(commits),
                scene,
            )
        )
        if 1.0 - p_exists > existence.tau_minus:
            verdict, reported = Verdict.NOT_FOUND, None
        elif belief[best] > tau_found:
            verdict, reported = Verdict.FOUND, best
        elif time >= time_limit:
            verdict, reported = Verdict.TIME_LIMIT, best
        else:
            continue
        break
    error = None
    if reported is not None and target.cell is not None:
        error = float(space.distances_from(target.cell)[reported])
    if dynamic is not None:
        dynamic.rejected.extend(rejected)
    return SearchRecord(
        policy=policy.name,
        metareasoning=existence.metareasoning,
        steps=tuple(steps),
        verdict=verdict,
        time=time,
        reported_cell=reported,
        true_cell=target.cell,
        error_cells=error,
        accuracy=accuracy(space, reported, target.cell, sigma),
        initial_belief=start_belief,
        revision=revision,
        dynamic_kb=dynamic is not None and uses_kb,
        rejected=tuple(rejected),
        room_prior=np.array(room_prior, dtype=float),
        scene_model=target.model if isinstance(target, SceneTarget) else None,
    )


SceneWorld = Callable[[SearchSpace, "int | None", np.random.Generator], SceneTarget]
"""Builds the world's side of a search with a scene model: (space with rates, target cell, generator)."""


def search_streams(seed: int) -> tuple[np.random.Generator, ...]:
    """The independent generators of one seeded search: the target's place, its detections, the Beta
    samples, the other objects' places and their detections (in that order)."""
    return tuple(np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(5))


def seeded_search(
    space: SearchSpace,
    room_prior: np.ndarray,
    policy: Policy,
    metareasoning: Metareasoning,
    *,
    seed: int,
    target_cell: int | None = None,
    absent: bool = False,
    alpha: float = 6.0,
    beta: float = 2.0,
    tau_found: float = TAU_FOUND,
    tau_absent: float = TAU_ABSENT,
    time_limit: float = TIME_LIMIT,
    keep_beliefs: bool = False,
    revision: Revision = Revision.REUSE,
    trust: TrustFactor | None = None,
    dynamic: DynamicFactory | None = None,
    scene: SceneWorld | None = None,
) -> SearchRecord:
    """One search from one seed (:func:`search_streams`), so two policies run on the same seed face
    the same target and the same noise (paired trials). ``dynamic`` builds the dynamic-KB parts;
    ``scene`` builds the world's images when ``space`` has a scene model's rates (else the fixed
    detector answers)."""
    place_rng, detect_rng, beta_rng, objects_rng, objects_detect_rng = search_streams(seed)
    target: SimulatedTarget | SceneTarget
    if absent:
        target = SimulatedTarget(None, space.detector, detect_rng)
    elif target_cell is not None:
        target = SimulatedTarget(target_cell, space.detector, detect_rng)
    else:
        target = SimulatedTarget.at_random(space, place_rng, detect_rng)
    if scene is not None and space.scene is not None:
        target = scene(space, target.cell, detect_rng)
    existence = ExistenceBelief(alpha, beta, metareasoning, tau_minus=tau_absent, rng=beta_rng)
    record = run_search(
        space,
        room_prior,
        target,
        policy,
        existence,
        tau_found=tau_found,
        time_limit=time_limit,
        keep_beliefs=keep_beliefs,
        revision=revision,
        trust=trust,
        dynamic=None if dynamic is None else dynamic(objects_rng, objects_detect_rng),
    )
    return replace(record, seed=seed)
