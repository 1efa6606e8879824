"""Paired object-search trials (Zhang, Sridharan & Wyatt 2015, Sec. IV-A): every arm -- a policy, a
metareasoning, a static or dynamic knowledge base, a revision -- on the same seeded worlds,
targets, knowledge and noise. Records are plain data; :func:`summarize` computes the statistics.

One trial ``t`` of a run seeded ``s`` (streams: :func:`~beliefloc.object_search.trials.trial_rng`):

1. the ground truth and the target (:func:`~beliefloc.object_search.world.sample_world`); absent
   with probability ``absent_fraction``;
2. the robot's knowledge: a fraction ``knowledge`` of the other objects' true rooms; its knowledge
   base (clingo) and the target class's room prior (Eq. 2-5), with or without the domain's defaults;
3. each arm runs Algorithm 1 (:func:`~beliefloc.object_search.loop.run_search`) with fresh
   generators of the same streams: the target's detections, the Beta samples, the other objects'
   detections. A dynamic arm commits what it sees to its own copy of the knowledge base (arms that
   commit the same facts share the solved priors, :data:`~beliefloc.object_search.dynamic.PriorCache`).

This module builds knowledge bases, so it reads ``kb/*.lp`` through clingo; it prints nothing.
The API for benchmarks::

    from beliefloc.knowledge import load_domain
    from beliefloc.object_search.experiment import Arm, TrialSettings, run_trials, summarize
    from beliefloc.object_search.settings import Metareasoning, Revision
    arms = [Arm("pomdp", Metareasoning.NONE),                        # static KB (H2)
            Arm("pomdp", Metareasoning.NONE, dynamic_kb=True),       # dynamic KB
            Arm("pomdp", Metareasoning.NONE, Revision.TRUST)]        # trust factors
    records = run_trials(load_domain("domains/home.yaml"), arms, trials=100, seed=0,
                         settings=TrialSettings(knowledge=0.2, defaults=False))
    summarize(records)["pomdp/none/dynamic/reuse"].mean_accuracy
    [o.error_cells for r in records for o in r.outcomes if o.arm == arms[1].name]   # for a CDF

``TrialRecord.outcomes`` are in the order of ``arms``; cells are indices into the search space
(``search_space(domain).cell_name(i)`` names them, :mod:`beliefloc.object_search.domain_space`).
Each record gives its JSON form (``as_json``). An arm may set its own time limit, τ+, τ-, Beta
and trust factors (``Arm("pomdp", Metareasoning.NONE, time_limit=60)``), so arms differing only
in them share a trial's knowledge base; ``TrialSettings(world_detector=...)`` makes the world
noisier than the robot's model; :func:`room_hit` and :func:`trial_world` serve the paper benchmark
(``python -m benchmarks.search_paper``).
"""

from __future__ import annotations

import math
import statistics
import time
from array import array
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from beliefloc.errors import InvalidValueError
from beliefloc.knowledge.domain import Domain
from beliefloc.object_search.domain_space import search_space
from beliefloc.object_search.dynamic import KbLink, PriorCache, objects_dynamic
from beliefloc.object_search.existence import ExistenceBelief
from beliefloc.object_search.loop import Verdict, run_search
from beliefloc.object_search.policy import POLICIES
from beliefloc.object_search.posterior import Detector, TrustFactor
from beliefloc.object_search.scene_views import SceneSetup
from beliefloc.object_search.settings import (
    COMMIT_THRESHOLD,
    Metareasoning,
    Revision,
    Scenes,
    check_commit_threshold,
    check_fraction,
    check_time_limit,
    wall_clock,
)
from beliefloc.object_search.space import SearchSpace
from beliefloc.object_search.trials import Stream, robot_domain, sample_known, trial_rng, unknown_objects
from beliefloc.object_search.world import P_TYPICAL, SceneTarget, SimulatedTarget, World, sample_world, typical_rooms
from beliefloc.source.record_fields import (
    flag_field,
    list_field,
    mapping_field,
    number_field,
    optional_number_field,
    optional_text_field,
    shown,
    text_field,
    whole_field,
)


@dataclass(frozen=True)
class Arm:
    """One way of searching, compared with the others on the same trials."""

    policy: str
    """A name of :data:`~beliefloc.object_search.policy.POLICIES`."""
    metareasoning: Metareasoning = Metareasoning.EXPECTATION
    revision: Revision = Revision.REUSE
    dynamic_kb: bool = False
    time_limit: float | None = None
    """This arm's own search parameters (None: the run's :class:`TrialSettings`, else the domain's), so
    that arms differing only in them share a trial's world and knowledge base: the baseline of H3 at
    several time limits, the Beta's (α', β') and τ- of Fig. 8."""
    tau_found: float | None = None
    tau_absent: float | None = None
    alpha: float | None = None
    beta: float | None = None
    trust: TrustFactor | None = None
    """The trust factors of this arm's ``trust-factor`` revision (None: the settings')."""
    scenes: Scenes | None = None
    """How views are analysed (None: the SP-POMDP when the domain has a scene model, else the fixed detector)."""

    def __post_init__(self) -> None:
        if self.policy not in POLICIES:
            raise InvalidValueError(f"unknown policy {self.policy!r}; expected one of: {', '.join(POLICIES)}")

    def overrides(self) -> dict[str, float]:
        """The search parameters this arm sets itself (keys of :func:`search_parameters`)."""
        own = {
            "time_limit": self.time_limit,
            "tau_found": self.tau_found,
            "tau_absent": self.tau_absent,
            "alpha": self.alpha,
            "beta": self.beta,
        }
        return {key: value for key, value in own.items() if value is not None}

    @property
    def name(self) -> str:
        """``policy/metareasoning/static|dynamic/revision``, e.g. ``pomdp/expectation/static/reuse``, then
        ``@key=value`` for each parameter the arm sets itself, e.g. ``pomdp/none/static/reuse@time_limit=60``."""
        name = f"{self.policy}/{self.metareasoning.value}/{self.kb}/{self.revision.value}"
        for key, value in self.overrides().items():
            name += f"@{key}={value:g}"
        if self.trust is not None:
            name += f"@trust={self.trust.weight:g},{self.trust.r:g}"
        if self.scenes is not None:
            name += f"@scenes={self.scenes.value}"
        return name

    @property
    def kb(self) -> str:
        """``dynamic`` or ``static``: whether the arm commits what it sees to its knowledge base."""
        return "dynamic" if self.dynamic_kb else "static"

    def as_json(self) -> dict[str, Any]:
        """The arm as JSON (``strategy``: the metareasoning, the key's historical name)."""
        return {
            "name": self.name,
            "policy": self.policy,
            "strategy": self.metareasoning.value,
            "kb": self.kb,
            "revision": self.revision.value,
        }


@dataclass(frozen=True)
class TrialSettings:
    """What every trial of a run shares. ``None`` for the search parameters: the domain's ``search:``."""

    knowledge: float = 0.4
    """Fraction of the other objects whose true room the robot knows (the paper's % of domain knowledge)."""
    defaults: bool = True
    """The robot's knowledge base uses the domain file's defaults."""
    absent_fraction: float = 0.0
    """Probability that a trial's target is absent (H3: 0.5)."""
    target: str | None = None
    """The target class; None: any object of the domain, drawn per trial."""
    p_typical: float = P_TYPICAL
    commit_threshold: float = COMMIT_THRESHOLD
    trust: TrustFactor = field(default_factory=TrustFactor)
    """The trust factors of the ``trust-factor`` revision."""
    time_limit: float | None = None
    tau_found: float | None = None
    tau_absent: float | None = None
    alpha: float | None = None
    beta: float | None = None
    correlation: float | None = None
    """The class-to-room ties of a correlated world (:func:`~beliefloc.object_search.world.place_objects`):
    every object in its class's home room with this probability; None: the domain's placement with
    ``p_typical``."""
    world_detector: Detector | None = None
    """The simulated world's detector when it is noisier than the robot's model (``space.detector``,
    the domain's ``sensor:``), for the target and the other objects alike: Sec. IV-A's "some extra
    noise was added to the observations received by the robot" (H2, Fig. 6). None: the model's."""

    def __post_init__(self) -> None:
        for name in ("knowledge", "absent_fraction", "p_typical"):
            check_fraction(name, getattr(self, name))
        if self.correlation is not None:
            check_fraction("the correlation", self.correlation)
        check_commit_threshold(self.commit_threshold)
        if self.time_limit is not None:
            check_time_limit(self.time_limit)

    def as_json(self, domain: Domain) -> dict[str, Any]:
        """The settings as JSON, with the search parameters they
        give on ``domain`` (:func:`search_parameters`)."""
        return {
            "knowledge": self.knowledge,
            "defaults": self.defaults,
            "absent_fraction": self.absent_fraction,
            "target": self.target,
            "p_typical": self.p_typical,
            **({} if self.correlation is None else {"correlation": self.correlation}),
            "commit_threshold": self.commit_threshold,
            "trust": {"weight": self.trust.weight, "r": self.trust.r},
            **search_parameters(domain, self),
        }


@dataclass(frozen=True)
class ArmOutcome:
    """One arm's search in one trial."""

    arm: str
    verdict: Verdict
    time: float
    """Localisation time in simulation units (travel + analysis)."""
    steps: int
    reported_cell: int | None
    error_cells: float | None
    """Distance between the reported and the true cell (None when either is missing)."""
    accuracy: float
    commits: tuple[tuple[str, str], ...]
    """``(object, room)`` facts committed to the knowledge base (dynamic arms)."""
    seconds: float
    """Wall-clock time of the search."""
    operators_applied: int | None = None
    """Operator applications over every view's image (None: the fixed detector)."""
    processing_time: float | None = None
    """Time spent processing images, part of :attr:`time` (the rest is travel); None: the fixed detector."""

    def as_json(self, space: SearchSpace, *, timings: bool = True) -> dict[str, Any]:
        """The outcome as JSON (without ``arm``, its key in the trial's ``outcomes``); cells
        named by ``space``; ``seconds`` None without ``timings``; ``operators_applied`` and
        ``processing_time`` only with a scene model."""
        data = {
            "verdict": self.verdict.value,
            "time": self.time,
            "steps": self.steps,
            "reported_cell": None if self.reported_cell is None else space.cell_name(self.reported_cell),
            "error_cells": self.error_cells,
            "accuracy": self.accuracy,
            "commits": [list(fact) for fact in self.commits],
            "seconds": wall_clock(self.seconds, timings),
        }
        if self.operators_applied is not None:
            data["operators_applied"] = self.operators_applied
            data["processing_time"] = self.processing_time
        return data

    @classmethod
    def from_json(cls, arm: str, data: dict[str, Any], space: SearchSpace | None = None) -> ArmOutcome:
        """The outcome :meth:`as_json` gave ``data``; its reported cell is read back with ``space``
        (None without: the statistics of :func:`summarize` do not need it); ``seconds`` NaN when
        the JSON has no clock values."""
        reported = optional_text_field(data, "reported_cell")
        commits = list_field(data, "commits")
        if not all(isinstance(f, list) and len(f) == 2 and all(isinstance(x, str) for x in f) for f in commits):
            raise ValueError("commits: not a list of [object, room] pairs of names")
        applied = data.get("operators_applied")
        return cls(
            arm=arm,
            verdict=Verdict(text_field(data, "verdict")),
            time=number_field(data, "time"),
            steps=whole_field(data, "steps"),
            reported_cell=None if reported is None or space is None else space.parse_cell(reported),
            error_cells=optional_number_field(data, "error_cells"),
            accuracy=number_field(data, "accuracy"),
            commits=tuple((obj, room) for obj, room in commits),
            seconds=math.nan if data["seconds"] is None else number_field(data, "seconds"),
            operators_applied=None if applied is None else whole_field(data, "operators_applied"),
            processing_time=None if data.get("processing_time") is None else number_field(data, "processing_time"),
        )


@dataclass(frozen=True)
class TrialRecord:
    """One paired trial: its ground truth, what the robot knew, and every arm's outcome."""

    index: int
    target: str
    target_class: str
    present: bool
    true_room: str | None
    true_cell: int | None
    known: int
    """How many objects' rooms the robot knew."""
    room_prior: tuple[float, ...]
    """The knowledge base's room prior for the target class (axis: the space's rooms)."""
    outcomes: tuple[ArmOutcome, ...]
    seconds: float
    """Wall-clock time of the whole trial (world, knowledge base, every arm)."""

    def as_json(self, space: SearchSpace, *, timings: bool = True) -> dict[str, Any]:
        """The trial as JSON: cells and rooms named by ``space``, the
        outcomes by arm; wall-clock ``seconds`` None without ``timings``."""
        return {
            "trial": self.index,
            "target": self.target,
            "target_class": self.target_class,
            "present": self.present,
            "true_room": self.true_room,
            "true_cell": None if self.true_cell is None else space.cell_name(self.true_cell),
            "known": self.known,
            "room_prior": dict(zip(space.rooms, self.room_prior, strict=True)),
            "outcomes": {o.arm: o.as_json(space, timings=timings) for o in self.outcomes},
            "seconds": wall_clock(self.seconds, timings),
        }

    @classmethod
    def from_json(cls, data: dict[str, Any], space: SearchSpace | None = None) -> TrialRecord:
        """The record :meth:`as_json` gave ``data``; its cells are read back with ``space`` (None
        without: enough for :func:`summarize`); ``seconds`` NaN when the JSON has no clock values."""
        if not isinstance(data, dict):
            raise ValueError(f"{shown(data)} is not a JSON object")
        true_cell = optional_text_field(data, "true_cell")
        prior = mapping_field(data, "room_prior")
        outcomes = mapping_field(data, "outcomes")
        for arm, outcome in outcomes.items():
            if not isinstance(outcome, dict):
                raise ValueError(f"outcomes.{arm}: {shown(outcome)} is not an object")
        return cls(
            index=whole_field(data, "trial"),
            target=text_field(data, "target"),
            target_class=text_field(data, "target_class"),
            present=flag_field(data, "present"),
            true_room=optional_text_field(data, "true_room"),
            true_cell=None if true_cell is None or space is None else space.parse_cell(true_cell),
            known=whole_field(data, "known"),
            room_prior=tuple(number_field(prior, room, f"room_prior.{room}") for room in prior),
            outcomes=tuple(ArmOutcome.from_json(arm, o, space) for arm, o in outcomes.items()),
            seconds=math.nan if data["seconds"] is None else number_field(data, "seconds"),
        )


@dataclass(frozen=True)
class TrialSweep:
    """Paired trials as a sweep (:mod:`beliefloc.simulation.sweep`): unit ``t`` is trial ``t`` (every arm), its
    result :meth:`TrialRecord.as_json`. A trial depends on (``seed``, ``t``) only
    (:func:`~beliefloc.object_search.trials.trial_rng`), so any worker may run it. A worker reads the
    domain's knowledge-base files (``kb/*.lp``) from its own disk: on a cluster they must be at the
    same paths."""

    domain: Domain
    arms: tuple[Arm, ...]
    seed: int
    settings: TrialSettings
    timings: bool = True
    scenes: bool = True
    """Analyse views with the domain's scene model, if it has one (False: the fixed detector for every arm)."""

    def runner(self) -> Callable[[int], dict[str, Any]]:
        """The search space and typical rooms shared by a worker's trials, and the runner of one trial."""
        space = search_space(self.domain)
        typical = typical_rooms(self.domain)
        scenes = SceneSetup.of(self.domain, typical) if self.scenes else None

        def run(index: int) -> dict[str, Any]:
            record = run_trial(
                self.domain,
                space,
                typical,
                self.arms,
                index=index,
                seed=self.seed,
                settings=self.settings,
                scenes=scenes,
            )
            return record.as_json(space, timings=self.timings)

        return run


@dataclass(frozen=True)
class ArmSummary:
    """One arm's statistics over paired trials (:func:`summarize`); a mean or spread is None when
    there is nothing (or, for a standard deviation, one value) to compute it from."""

    arm: str
    trials: int
    found: int
    not_found: int
    time_limit: int
    """How many searches ended with each :class:`~beliefloc.object_search.loop.Verdict`."""
    mean_time: float | None
    stdev_time: float | None
    median_time: float | None
    """Localisation time in simulation units."""
    mean_accuracy: float | None
    stdev_accuracy: float | None
    mean_error_cells: float | None
    """Distance between the reported and the true cell, over the searches that have both."""
    within_4_cells: int
    """Searches that reported a cell within 4 cells of the target."""
    mean_steps: float | None
    mean_commits: float | None
    mean_seconds: float | None
    """Wall-clock seconds per search."""
    mean_operators: float | None = None
    """Operator applications per search (None: no scene model)."""
    mean_processing_time: float | None = None
    """Time processing images per search, part of ``mean_time`` (None: no scene model)."""

    def as_json(self, *, timings: bool = True) -> dict[str, Any]:
        """The statistics as JSON (without ``arm``, their key
        there); ``mean_seconds`` None without ``timings``; the scene's means only with a scene model."""
        data = {
            "trials": self.trials,
            "found": self.found,
            "not_found": self.not_found,
            "time_limit": self.time_limit,
            "mean_time": self.mean_time,
            "stdev_time": self.stdev_time,
            "median_time": self.median_time,
            "mean_accuracy": self.mean_accuracy,
            "stdev_accuracy": self.stdev_accuracy,
            "mean_error_cells": self.mean_error_cells,
            "within_4_cells": self.within_4_cells,
            "mean_steps": self.mean_steps,
            "mean_commits": self.mean_commits,
            "mean_seconds": wall_clock(self.mean_seconds, timings),
        }
        if self.mean_operators is not None:
            data["mean_operators"] = self.mean_operators
            data["mean_processing_time"] = self.mean_processing_time
        return data


def search_parameters(domain: Domain, settings: TrialSettings) -> dict[str, float]:
    """τ+, τ-, the time limit and the Beta's (α', β'): the settings', else the domain's ``search:``."""
    own = domain.search_settings
    assert own is not None  # search_space checked it
    return {
        "time_limit": own.time_limit if settings.time_limit is None else settings.time_limit,
        "tau_found": own.tau_found if settings.tau_found is None else settings.tau_found,
        "tau_absent": own.tau_absent if settings.tau_absent is None else settings.tau_absent,
        "alpha": own.existence.alpha if settings.alpha is None else settings.alpha,
        "beta": own.existence.beta if settings.beta is None else settings.beta,
    }


def run_trial(
    domain: Domain,
    space: SearchSpace,
    typical: dict[str, str],
    arms: Sequence[Arm],
    *,
    index: int,
    seed: int,
    settings: TrialSettings,
    scenes: SceneSetup | None = None,
) -> TrialRecord:
    """Trial ``index`` of a run seeded ``seed``: one world, one knowledge, every arm (see the module docstring).
    ``scenes``: the domain's scene model (:class:`~beliefloc.object_search.scene_views.SceneSetup`), which
    analyses the views of every arm but those whose :attr:`Arm.scenes` is ``fixed``."""
    from beliefloc.knowledge import KnowledgeBase

    started = time.perf_counter()
    world = trial_world(domain, space, typical, index=index, seed=seed, settings=settings)
    known = sample_known(domain, world, settings.knowledge, trial_rng(seed, index, Stream.KNOWLEDGE))
    robot = robot_domain(domain, world, known)

    def make_kb() -> KnowledgeBase:
        return KnowledgeBase(robot, use_defaults=settings.defaults)

    first = make_kb()
    room_prior = space.over_rooms(first.prior(world.target_class).prior)
    spare = [first]  # the first dynamic arm to commit continues from this one
    cache: PriorCache = {}
    names = unknown_objects(domain, world, known)
    params = search_parameters(domain, settings)
    world_detector = settings.world_detector or space.detector
    outcomes = []
    for arm in arms:
        arm_started = time.perf_counter()
        mode = arm.scenes or (Scenes.FIXED if scenes is None else Scenes.PLANNED)
        if mode is not Scenes.FIXED and scenes is None:
            raise InvalidValueError(f"arm {arm.name}: domain {domain.name!r} has no scene model (scene:)")
        arm_space = space if scenes is None else scenes.space(space, world.target_class, mode)
        target: SimulatedTarget | SceneTarget
        detections = trial_rng(seed, index, Stream.TARGET_DETECTIONS)
        if scenes is not None and arm_space.scene is not None:
            target = scenes.target(arm_space, world.target_cell, world.rooms, detections, instance=world.target)
        else:
            target = SimulatedTarget(world.target_cell, world_detector, detections)
        dynamic = None
        if arm.dynamic_kb:

            def next_kb() -> KnowledgeBase:
                return spare.pop() if spare else make_kb()

            dynamic = objects_dynamic(
                space,
                world.cells,
                names,
                KbLink(next_kb, world.target_class, space.rooms, cache=cache),
                trial_rng(seed, index, Stream.OBJECT_DETECTIONS),
                threshold=settings.commit_threshold,
                world_detector=world_detector,
            )
        own = {**params, **arm.overrides()}
        record = run_search(
            arm_space,
            room_prior,
            target,
            POLICIES[arm.policy],
            ExistenceBelief(
                own["alpha"],
                own["beta"],
                arm.metareasoning,
                tau_minus=own["tau_absent"],
                rng=trial_rng(seed, index, Stream.BETA_SAMPLES),
            ),
            tau_found=own["tau_found"],
            time_limit=own["time_limit"],
            revision=arm.revision,
            trust=arm.trust or settings.trust,
            dynamic=dynamic,
        )
        outcomes.append(
            ArmOutcome(
                arm=arm.name,
                verdict=record.verdict,
                time=record.time,
                steps=len(record.steps),
                reported_cell=record.reported_cell,
                error_cells=record.error_cells,
                accuracy=record.accuracy,
                commits=record.commits,
                seconds=time.perf_counter() - arm_started,
                operators_applied=record.operators_applied,
                processing_time=record.processing_time,
            )
        )
    return TrialRecord(
        index=index,
        target=world.target,
        target_class=world.target_class,
        present=world.present,
        true_room=world.target_room,
        true_cell=world.target_cell,
        known=len(known),
        room_prior=tuple(float(p) for p in room_prior),
        outcomes=tuple(outcomes),
        seconds=time.perf_counter() - started,
    )


def run_trials(
    domain: Domain,
    arms: Sequence[Arm],
    *,
    trials: int,
    seed: int = 0,
    settings: TrialSettings | None = None,
    on_trial: Callable[[TrialRecord], None] | None = None,
    first: int = 0,
    scenes: bool = True,
) -> list[TrialRecord]:
    """Trials ``first .. first + trials - 1`` (a trial depends only on ``seed`` and its index, so a run
    can be split and its parts joined), every arm on each. ``on_trial`` is called after each trial.
    ``scenes`` False: the fixed detector for every arm, whether or not the domain has a scene model."""
    if trials < 1 or not arms:
        raise InvalidValueError("need at least one trial and one arm")
    names = [arm.name for arm in arms]
    if len(set(names)) != len(names):
        raise InvalidValueError(f"the same arm twice: {', '.join(sorted(n for n in set(names) if names.count(n) > 1))}")
    settings = settings or TrialSettings()
    space = search_space(domain)
    typical = typical_rooms(domain)
    setup = SceneSetup.of(domain, typical) if scenes else None
    records = []
    for index in range(first, first + trials):
        record = run_trial(domain, space, typical, arms, index=index, seed=seed, settings=settings, scenes=setup)
        records.append(record)
        if on_trial is not None:
            on_trial(record)
    return records


def summarize(records: Iterable[TrialRecord]) -> dict[str, ArmSummary]:
    """Per arm, in the order the records first name them: trials, verdict counts, localisation time
    (mean, standard deviation, median), accuracy (mean, standard deviation), the error in cells of the
    reported cells, steps, commits, and wall-clock seconds per search (:class:`ArmSummary`). One pass,
    keeping only columns of numbers: ``summarize`` of a results file streams its records through here."""
    tallies: dict[str, _ArmTally] = {}
    for record in records:
        for outcome in record.outcomes:
            tally = tallies.get(outcome.arm)
            if tally is None:
                tally = tallies[outcome.arm] = _ArmTally()
            tally.add(outcome)
    return {arm: tally.summary(arm) for arm, tally in tallies.items()}


class _ArmTally:
    """One arm's searches so far, as counts and columns of numbers (8 bytes each)."""

    def __init__(self) -> None:
        self.verdicts = dict.fromkeys(Verdict, 0)
        self.times, self.accuracies, self.errors = array("d"), array("d"), array("d")
        self.steps, self.commits, self.seconds = array("d"), array("d"), array("d")
        self.operators, self.processing = array("d"), array("d")

    def add(self, o: ArmOutcome) -> None:
        self.verdicts[o.verdict] += 1
        self.times.append(o.time)
        self.accuracies.append(o.accuracy)
        if o.error_cells is not None:
            self.errors.append(o.error_cells)
        self.steps.append(o.steps)
        self.commits.append(len(o.commits))
        if not math.isnan(o.seconds):
            self.seconds.append(o.seconds)
        if o.operators_applied is not None:
            self.operators.append(o.operators_applied)
        if o.processing_time is not None:
            self.processing.append(o.processing_time)

    def summary(self, arm: str) -> ArmSummary:
        times = self.times
        return ArmSummary(
            arm=arm,
            trials=len(times),
            found=self.verdicts[Verdict.FOUND],
            not_found=self.verdicts[Verdict.NOT_FOUND],
            time_limit=self.verdicts[Verdict.TIME_LIMIT],
            mean_time=_mean(times),
            stdev_time=_stdev(times),
            median_time=statistics.median(times) if times else None,
            mean_accuracy=_mean(self.accuracies),
            stdev_accuracy=_stdev(self.accuracies),
            mean_error_cells=_mean(self.errors),
            within_4_cells=sum(e <= 4.0 for e in self.errors),
            mean_steps=_mean(self.steps),
            mean_commits=_mean(self.commits),
            mean_seconds=_mean(self.seconds),
            mean_operators=_mean(self.operators),
            mean_processing_time=_mean(self.processing),
        )


def run_title(domain: str, trials: int, seed: int, settings: dict[str, Any]) -> str:
    """One line saying what a run of paired trials did: ``settings`` is :meth:`TrialSettings.as_json`."""
    target = settings["target"]
    what = "any object" if target is None else f"a {target}"
    return (
        f"{trials} paired trials on {domain}, looking for {what}: knowledge {settings['knowledge']:g}, defaults "
        f"{'on' if settings['defaults'] else 'off'}, target absent with probability "
        f"{settings['absent_fraction']:g}, seed {seed}"
    )


def _mean(values: Sequence[float]) -> float | None:
    return statistics.fmean(values) if values else None


def _stdev(values: Sequence[float]) -> float | None:
    return statistics.stdev(values) if len(values) > 1 else None


def room_hit(room_prior: Sequence[float], true_room: int, k: int = 1) -> float:
    """ASP alone (Zhang et al. Sec. IV-A, H1, Fig. 4): the chance that room ``true_room`` (an index into
    ``room_prior``) is among the ``k`` rooms the prior ranks first, ties broken uniformly at random.

    With ``g`` rooms strictly more likely than the true one and ``e`` rooms as likely (itself
    included): ``clip((k - g) / e, 0, 1)``. A prior that says nothing (uniform over n rooms) scores
    ``k / n``, not whatever the order of the rooms in the file would give an ``argmax``."""
    prior = np.asarray(room_prior, dtype=float)
    if not 0 <= true_room < len(prior) or k < 1:
        raise InvalidValueError(f"need a room index in [0, {len(prior)}) and k >= 1, got {true_room} and {k}")
    level = prior[true_room]
    above = int(np.sum(prior > level + 1e-12))
    tied = int(np.sum(np.abs(prior - level) <= 1e-12))
    return float(min(1.0, max(0.0, (k - above) / tied)))


def trial_world(
    domain: Domain, space: SearchSpace, typical: dict[str, str], *, index: int, seed: int, settings: TrialSettings
) -> World:
    """The ground truth of trial ``index`` of a run seeded ``seed``: the world :func:`run_trial` builds
    (it calls this), to check records against it -- e.g. whether a dynamic arm's commits
    were right. ``typical``: :func:`typical_rooms`."""
    world_rng = trial_rng(seed, index, Stream.WORLD)
    absent = bool(world_rng.random() < settings.absent_fraction)
    return sample_world(
        domain,
        space,
        typical,
        world_rng,
        target_class=settings.target,
        absent=absent,
        p_typical=settings.p_typical,
        correlation=settings.correlation,
    )
