"""Localizing a robot that acts and perceives: Colledanchise et al.'s Algorithm 1, ``Main``.

::

    b <- the start belief
    while max(b) < threshold:
        if there is no plan: plan with best-first search from b (the closed list is kept)
        send the plan's next action a; the robot executes it and answers with raw readings
        o <- the readings binned into an observation of a (beliefloc.robots.readings)
        b <- update(b, a, o)                     b'(s_j) ∝ O_a[j, o] Σ_i T_a[i, j] b(s_i)
        if o differs from the observation the plan expected: drop the plan (replan next time)

**Surprise** (:mod:`beliefloc.robots.surprise`): beside the belief, the loop tracks how well the
readings fit it. When they stop fitting -- a kidnapped robot, something not on the map, a map unlike
the world -- the belief is never declared localized: it is re-spread (mixed half and half with the
uniform belief, AMCL's recovery) at most ``recoveries`` times, then the loop ends ``inconsistent``.
The result says which happened (``recoveries``) and how well the last readings fit
(``model_confidence``), beside the belief's maximum.

The planning is :class:`~beliefloc.simulation.strategies.PlanningStrategy`'s, exactly as in a
simulated episode; the robot is anything with ``act(command) -> raw readings``
(:class:`ReadingRobot`): a real one over ``beliefloc localize``'s line protocol
(:class:`beliefloc.robots.line_protocol.LineRobot`), or a simulated one (:class:`SimulatedReadingRobot`).
The loop ends with an honest :class:`~beliefloc.simulation.strategies.EpisodeStatus`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Protocol

import numpy as np

from beliefloc.belief import most_likely
from beliefloc.errors import ImpossibleObservationError, InvalidValueError, ReplyError
from beliefloc.model import Action, GridLayout, Model
from beliefloc.planning.best_first import PlanResult
from beliefloc.planning.successors import SuccessorEvaluator
from beliefloc.planning.telling import few_places, needed_evidence, telling_macros, which_place_evidence
from beliefloc.pose import PoseEstimate, belief_places, belief_pose
from beliefloc.robots.belief_filter import BeliefFilter, ModelFilter
from beliefloc.robots.odometry import MotionReport, ReportingRobot, motion
from beliefloc.robots.readings import RawReading, ReadingBinner
from beliefloc.robots.surprise import DeclarationCheck, SurpriseCheck
from beliefloc.simulation.robot import SimulatedRobot
from beliefloc.simulation.settings import DEFAULT_MAX_STEPS, StrategyName
from beliefloc.simulation.strategies import EpisodeStatus, GiveUp, PlannerSettings, PlanningStrategy, Strategy


@dataclass(frozen=True)
class Command:
    """What the loop asks the robot to do next."""

    seq: int
    """1 for the first action, then 2, 3, ...; the robot's reply carries it back."""
    action: Action
    expected: int | None
    """The observation the plan expects after the action; None when the action reads no sensor."""
    plan: PlanResult | None
    """The plan made just before this action (the first plan or a replan); None when the action
    continues the current plan."""


class ReadingRobot(Protocol):
    """A robot that executes an action and answers with the raw readings of the sensors the action
    reads, by sensor name (:meth:`beliefloc.robots.readings.ReadingBinner.sensors`; empty when it reads none)."""

    def act(self, command: Command) -> Mapping[str, RawReading]: ...


@dataclass(frozen=True)
class LocalizeStep:
    """One action done: what was asked, what was observed, the belief after it."""

    command: Command
    observation: int | None
    probability: float
    """``p(o | a, b)`` before the update (1 when nothing was observed)."""
    belief: np.ndarray
    peak: float | None = None
    """The probability compared with the threshold after it (:meth:`BeliefFilter.peak`); None: the
    most likely state's."""

    @property
    def surprised(self) -> bool:
        """The observation differs from the one the plan expected: the plan is dropped."""
        return self.observation != self.command.expected


@dataclass(frozen=True)
class Localization:
    """How localization ended, with the final belief."""

    status: EpisodeStatus
    belief: np.ndarray
    steps: int
    cost: float
    replans: int
    plan_seconds: tuple[float, ...]
    reason: str = ""
    """Why the loop stopped short, in words (empty when localized)."""
    model_confidence: float = 1.0
    """How well the last readings fit the belief (:attr:`SurpriseCheck.confidence`, in [0, 1])."""
    recoveries: int = 0
    """How many times the readings stopped fitting and the belief was re-spread."""
    peak: float | None = None
    """The probability compared with the threshold (:meth:`BeliefFilter.peak`: with a pose lattice,
    the probability that the robot is within the declared state's reach); None: the most likely
    state's probability."""
    state: int | None = None
    """The state declared (:meth:`BeliefFilter.declared`); None: the most likely one."""
    estimate: PoseEstimate | None = None
    """The pose reported when localized, where the filter knows it finer than the declared state's
    centre and heading (:meth:`BeliefFilter.pose_estimate`: the pose lattice's); None: the state's
    pose (:meth:`pose_estimate`)."""

    @property
    def localized(self) -> bool:
        return self.status is EpisodeStatus.LOCALIZED

    @property
    def declared(self) -> tuple[int, float]:
        """The state declared (or the most likely one) and the probability compared with the threshold."""
        state, probability = most_likely(self.belief)
        if self.state is not None:
            state = self.state
        if self.peak is not None:
            probability = self.peak
        return state, probability

    def pose_estimate(self, model: Model) -> PoseEstimate | None:
        """The pose to report (what AMCL is given): :attr:`estimate`, else the declared state's pose
        with the belief's covariance (:func:`beliefloc.pose.belief_pose`); None without a grid."""
        if self.estimate is not None:
            return self.estimate
        return None if model.grid is None else belief_pose(model, self.belief, self.declared[0])

    def as_json(self, model: Model) -> dict[str, Any]:
        """The outcome as plain data: the declared state, its probability and the pose to report
        (:meth:`pose_estimate`) when localized, else null; ``max_belief`` either way."""
        state, probability = self.declared
        done = self.localized
        estimate = self.pose_estimate(model) if done else None
        return {
            "status": self.status.value,
            "localized": done,
            "state": model.states.name(state) if done else None,
            "probability": probability if done else None,
            "pose": None if estimate is None else estimate.as_json(),
            "max_belief": probability,
            "steps": self.steps,
            "cost": self.cost,
            "replans": self.replans,
            "model_confidence": self.model_confidence,
            "recoveries": self.recoveries,
        }


OnStep = Callable[[LocalizeStep], None]
_GIVE_UP_REASONS = {
    EpisodeStatus.NO_PLAN: "every belief reachable from here was searched and none reaches the threshold: "
    "some states cannot be told apart",
    EpisodeStatus.BUDGET_EXCEEDED: "the planner's budget (expansions or seconds) ran out before it found a plan",
}
DEFAULT_RECOVERIES = 1
"""How many times ``localize`` re-spreads a belief whose readings stopped fitting before it ends
``inconsistent``."""
RIVAL_SHARE = 0.2
"""A belief is declared when its reach holds the threshold and at most this share of the rest lies
beyond the declared state's promise (:meth:`BeliefFilter.elsewhere`; 0.01 at a threshold of 0.95).
What the reach leaves out is mostly the place's own spread -- a cell or a sector farther than the
reach, still inside the promise -- and harmless; what lies beyond the promise is a look-alike place,
and declaring while it holds much is how a wrong answer comes out sure. Measured on tb3-sandbox: with
half the rest allowed (0.025), one episode in 300 with 10 % spurious beams was declared at p = 0.959
on a place 0.92 m and 108 degrees from the truth while 0.034 of the belief stayed on the truth's
place; at 0.5, two of 400 ec2-macros episodes still were (the truth's place held 0.017, and a 180
degree twin 3.3 m away); at 0.2 both are refused."""


CANDIDATES = 8
"""How many of the best macros over a place's likeliest units :class:`LookAlikes` judges again by the
whole place."""
KEEP_GOING = 0.95
"""A telling macro under way (:class:`LookAlikes`) goes on while its two places hold this much."""
SECURING_GAIN = 0.01
"""The least rise of the declared probability per unit of cost that :func:`securing_move` takes an
action for; below it, the action that tells the most (traced on the depot: readings each expected to
add 0.001-0.01, taken at every heading while each turn cost the reach 0.01, drained it from 0.9 to
0.77 in 30 actions)."""
NEIGHBOUR_CELLS = 3.0
"""Places whose likeliest states lie within this many cells (and one heading) of each other are one
place's spread, not look-alikes (:meth:`LookAlikes.one_place`)."""


def planning_goal(settings: PlannerSettings, tracker: BeliefFilter) -> PlannerSettings:
    """The settings the planner plans with: ``settings`` for the model's own filter; for a filter
    whose planning belief gathers each place into one mode (:attr:`BeliefFilter.gathers_places`),
    a goal of one place holding all but what a declaration may leave on look-alike places
    (``1 - RIVAL_SHARE (1 - threshold)``: 0.99 at 0.95). Planning to the threshold itself, the
    planner's goal was met while a look-alike still held 2-5 %, and the loop's one-step choice
    (:func:`informative_move`) that took over could not lead the robot to where the two places
    differ: tb3-sandbox's mirror twins kept episodes at the step limit at the right place."""
    if not tracker.gathers_places:
        return settings
    return replace(settings, threshold=max(settings.threshold, 1.0 - RIVAL_SHARE * (1.0 - settings.threshold)))


def localize(
    model: Model,
    belief: np.ndarray,
    robot: ReadingRobot,
    binner: ReadingBinner,
    *,
    settings: PlannerSettings | None = None,
    max_steps: int = DEFAULT_MAX_STEPS,
    evaluator: SuccessorEvaluator | None = None,
    on_step: OnStep | None = None,
    surprise: SurpriseCheck | None = None,
    recoveries: int = DEFAULT_RECOVERIES,
    strategy: Callable[[PlannerSettings], Strategy] | None = None,
    repeat_readings: bool = False,
    rng: np.random.Generator | None = None,
    confirm: bool = False,
    belief_filter: BeliefFilter | None = None,
) -> Localization:
    """Plan, act, perceive and replan until one state holds ``settings.threshold`` (see the module).

    ``strategy``: makes the strategy that chooses the actions (any of ``simulate``'s,
    :func:`beliefloc.simulation.strategies.make_strategy`) from the planner's settings the loop gives
    it (:func:`planning_goal`); a fresh one after every re-spread, since a
    policy planned for the belief before it does not hold for the belief after. None: best-first with
    replanning (:class:`PlanningStrategy`), ``localize``'s own.

    **One reading per place** (unless ``repeat_readings``): a perception action already read since
    the last move is not sent again. The model treats two readings as independent given the state,
    but a robot that has not moved reads the same pose again: its second reading repeats the first
    one's offset from the cell centre and heading, and counting it twice makes the belief surer than
    the evidence (the hallway: two Looks from one spot declared a pose 150° off). Likewise a move
    the robot reported blocked where it stood (:func:`moved`) is not sent again from there: the
    belief is the same, and a planner that does not know the wall would ask for it forever. When the
    strategy asks for either -- or for a move back to where the reading it plans next was taken --
    the loop takes the action expected to tell the most per cost instead (:func:`informative_move`:
    a reading not yet taken here, or a move and then the reading it is made for), and starts a fresh
    strategy from the belief after it. Once the planner's belief (the gathered modes) holds the
    planner's goal (:func:`planning_goal`) but no state's reach holds the threshold, what is left to
    learn -- which side of a cell or sector border -- is not in the planner's model: the loop takes
    the action expected to raise the declared probability the most per cost
    (:func:`securing_move`), or, when none is expected to, the one that tells the most.
    (``rng``, seeded ``0`` when None, draws a move only when no action is expected to tell anything.)

    **Two look-alike places** (a filter that gathers places, such as the pose lattice): once two
    places hold the planner's goal between them, the robot follows the macro that tells them apart
    best per cost by the filter's own tables (:class:`LookAlikes`), not the planner.

    **Confirmation** (``confirm``): a belief that reaches the threshold is not declared at once. The
    robot first makes a move (the most informative of those that keep the threshold by themselves,
    :func:`keeping_moves`) and takes a reading from where it lands; the state
    is declared only if the belief still holds the threshold (and the declaration check passes)
    after it. One reading that only a wrong state explains -- an off-grid pose read as another
    cell's, a landmark where the map has none -- lifts a belief over the threshold; a second one,
    from another place, rarely agrees with the same wrong state. Nor is a belief declared while the
    last readings fit it poorly (:attr:`~beliefloc.robots.surprise.SurpriseCheck.confident`): the robot
    moves and reads on until they fit again.

    **The belief** between actions is ``belief_filter``'s (:mod:`beliefloc.robots.belief_filter`):
    None is the model's own (``T_a`` and ``O_a`` over its states); a
    :class:`~beliefloc.robots.belief_filter.LatticeFilter` follows a real robot's pose finer than
    the states. The planner and the threshold see the model's belief either way.

    A reply the binner cannot use raises :class:`ReplyError` naming the action; an observation the
    model says cannot happen ends the loop with ``IMPOSSIBLE_OBSERVATION`` (the belief before it is
    kept), as do no plan, a planner out of budget and ``max_steps`` actions, each with its status.
    """
    settings = settings or PlannerSettings()
    tracker: BeliefFilter = belief_filter if belief_filter is not None else ModelFilter(model)
    chosen = planning_goal(settings, tracker)

    def best_first(planner: PlannerSettings) -> Strategy:
        return PlanningStrategy(StrategyName.BESTFIRST.value, model, planner, evaluator or SuccessorEvaluator(model))

    make = strategy or best_first
    chooser = make(chosen)
    done_seconds: list[float] = []
    done_replans = 0
    steps, cost, reason = 0, 0.0, ""
    status = EpisodeStatus.LOCALIZED
    check = surprise if surprise is not None else SurpriseCheck()
    belief = tracker.start(belief)
    declaration = DeclarationCheck()
    declaration.start(tracker.peak())
    recovered = 0
    places = Places(model.grid, model.actuation_actions)  # the readings taken, and the moves blocked, and where
    moves = model.actuation_actions
    draw = rng if rng is not None else np.random.default_rng(0)
    confirmed = not confirm
    confirming = False  # a confirmation move was made; its reading comes next
    pending: Action | None = None  # the reading an informative move was made for
    report: MotionReport | None = None
    # beyond the reach's threshold, what a declaration risks: the belief's own probability that the
    # robot is beyond the declared state's promise (a look-alike place) -- at most half the rest
    risk = RIVAL_SHARE * (1.0 - settings.threshold)
    lookalikes = LookAlikes(model, tracker, places, chosen.threshold)
    last: Action | None = None  # the action done last

    def at_threshold() -> bool:
        return tracker.peak() >= settings.threshold and tracker.elsewhere() <= risk

    while not (at_threshold() and declaration.explains(tracker.peak()) and confirmed and check.confident):
        if steps >= max_steps:
            status, reason = EpisodeStatus.STEP_LIMIT, f"{steps} actions done, the most allowed"
            if at_threshold() and confirmed and not check.confident:
                reason += (
                    f"; the belief held the threshold, but the last readings fit it too poorly to declare it "
                    f"(confidence {check.confidence:.2f}, below {check.declare_at:g})"
                )
            break
        read_here = places.here()
        untried = [m for m in moves if m.name not in read_here]
        forced: Action | None = None
        promised, pending = pending, None
        if confirm and (confirming or at_threshold()):
            unread = [a for a in model.perception_actions if a.name not in read_here]
            if confirming and unread:  # the move was made: its reading, the one expected to tell the most
                forced = informative_move(tracker, model, places, (), draw, unread)[0]
            elif untried:  # at the threshold: move first (or again, when the move left the robot in place)
                # moves to where a reading is still to be taken: the confirmation's reading comes next
                fresh = [m for m in untried if places.unread_after(m, model.perception_actions)]
                keeping = keeping_moves(tracker, fresh or untried, settings.threshold)
                forced = informative_move(tracker, model, places, keeping, draw)[0]
            else:
                status = EpisodeStatus.NO_PLAN
                reason = "the belief reached the threshold, but every move was blocked: the state cannot be confirmed"
                break
        view = tracker.planning_belief()
        confirming_now = forced is not None
        if forced is None and promised is not None and promised.name not in read_here and moved(report, model.grid):
            forced = promised  # the reading the last move was made for (see informative_move)
        if forced is None and (view.max() >= chosen.threshold or (tracker.gathers_places and lookalikes.one_place())):
            # one place holds the threshold once its neighbouring cells are gathered (or its spread
            # parts into modes a cell or two apart), yet no state's reach does: the planner's goal is
            # met, and what is left -- where in the place, which side of a cell or sector border --
            # is not in its model. The action that raises the declaration most, else the most
            # informative one
            unread = [a for a in model.perception_actions if a.name not in read_here]
            if unread or untried:
                forced, pending = securing_move(tracker, model, places, untried, unread) or informative_move(
                    tracker, model, places, untried, draw, unread
                )
        if forced is None and tracker.gathers_places:
            # a few look-alike places hold the planner's goal between them: lead them to where a reading
            # tells them apart, by the lattice's tables (see LookAlikes)
            forced = lookalikes.next_action(read_here, last, moved(report, model.grid))
        if forced is not None:
            decision, action, planned = forced.name, forced, None
        else:
            choice = chooser.next_action(view)
            if isinstance(choice, GiveUp):
                status, reason = choice.status, _GIVE_UP_REASONS.get(choice.status, "")
                break
            decision = choice
            planned = chooser.current_step if isinstance(chooser, PlanningStrategy) else None
            action = model.action(decision)
            if not repeat_readings and action.is_actuation and isinstance(chooser, PlanningStrategy):
                # a move planned for the reading after it, which was already taken where the move
                # leads (turned away and back): the planner does not know it is used up
                following = chooser.following_step
                if following is not None and following.action in places.after(action):
                    read_here = read_here | {action.name}
        substituted = forced is not None or (not repeat_readings and action.name in read_here)
        if substituted and forced is None and not untried:
            status = EpisodeStatus.NO_PLAN
            reason = "every reading was taken where the robot stands and every move was blocked: nothing more to learn"
            break
        if substituted and forced is None:  # the same reading again from the same place: see above
            unread = [a for a in model.perception_actions if a.name not in read_here]
            (action, pending), planned = informative_move(tracker, model, places, untried, draw, unread), None
        command = Command(steps + 1, action, None if planned is None else planned.observation_index, chooser.new_plan)
        readings = robot.act(command)
        try:
            observation = binner.observation(action, readings)
        except InvalidValueError as exc:
            raise ReplyError(f"the reply to action {command.seq} ({action.name}): {exc}") from None
        report = robot.motion_report() if isinstance(robot, ReportingRobot) else None
        before = tracker.peak() if action.is_actuation else 0.0
        try:
            tracker.predict(action, report)
        except InvalidValueError as exc:
            raise ReplyError(f"the reply to action {command.seq} ({action.name}): {exc}") from None
        except ImpossibleObservationError as exc:
            status, reason = EpisodeStatus.IMPOSSIBLE_OBSERVATION, f"action {command.seq}: {exc}"
            break
        if action.is_actuation:
            declaration.moved(before, tracker.peak())
        expected = tracker.probabilities(action) if observation is not None else None
        try:
            belief, probability = tracker.correct(action, observation, readings)
        except ImpossibleObservationError as exc:
            status, reason = EpisodeStatus.IMPOSSIBLE_OBSERVATION, f"action {command.seq}: {exc}"
            break
        steps += 1
        cost += action.cost
        last = action
        if action.is_actuation and moved(report, model.grid):
            places.after_move(report)
        else:  # a reading taken here, or a move that left the robot where it was (blocked)
            places.add(action.name)
        if confirming_now:
            assert forced is not None
            confirming = forced.is_actuation and moved(report, model.grid)
            # the reading after the move: the belief now stands (still at the threshold) or falls
            confirmed = not forced.is_actuation and at_threshold()
        elif not at_threshold():
            confirmed = not confirm
        if substituted:
            done_seconds += chooser.plan_seconds
            done_replans += chooser.replans + 1
            chooser = make(chosen)  # its plan expected the reading, not this move: plan afresh
        if expected is not None and observation is not None:
            check.observe(expected, observation)
            declaration.observe(
                probability, tracker.expected_log_likelihood(action), tracker.log_likelihood_variance(action)
            )
            if not check.fits or (tracker.peak() >= settings.threshold and not declaration.explains(tracker.peak())):
                if recovered >= recoveries:
                    status = EpisodeStatus.INCONSISTENT
                    reason = (
                        f"action {command.seq}: the readings stopped fitting the belief (fit {check.fit:.2g} over the "
                        f"last {len(check.ratios)} readings; the most likely state's path explains them "
                        f"{declaration.deficit(tracker.peak()):.1f} nats worse than expected) after {recovered} "
                        "re-spread(s): the world is not the map's model (a kidnapped robot, an unmapped "
                        "obstacle, or sensors noisier than it says)"
                    )
                    if on_step is not None:  # the action was done: its step is shown, then the loop ends
                        on_step(LocalizeStep(command, observation, probability, belief, tracker.peak()))
                    break
                belief = tracker.respread()
                check.reset()
                declaration.start(tracker.peak())
                recovered += 1
                done_seconds += chooser.plan_seconds
                done_replans += chooser.replans + 1
                chooser = make(chosen)  # a re-spread belief is not the planned one: plan afresh
                if on_step is not None:
                    on_step(LocalizeStep(command, observation, probability, belief, tracker.peak()))
                continue
        if substituted:
            if on_step is not None:
                on_step(LocalizeStep(command, observation, probability, belief, tracker.peak()))
            continue
        chooser.observed(
            decision, observation, tracker.planning_belief()
        )  # an unexpected observation: the plan is dropped
        if on_step is not None:
            on_step(LocalizeStep(command, observation, probability, belief, tracker.peak()))
    declared_state, declared_probability = tracker.declared()
    return Localization(
        status,
        belief,
        steps,
        cost,
        done_replans + chooser.replans,
        tuple(done_seconds + chooser.plan_seconds),
        reason,
        check.confidence,
        recovered,
        peak=declared_probability,
        state=declared_state,
        estimate=tracker.pose_estimate(declared_state, declared_probability)
        if status is EpisodeStatus.LOCALIZED
        else None,
    )


@dataclass
class Places:
    """Where the robot has read what, by its odometry (relative to where the loop began): a reading
    from within a quarter cell and a quarter heading sector of an earlier one of the same action is
    taken *here* again, even when the robot moved away and came back (turned and turned back). A move
    without odometry (protocol 1) is taken at its word: the robot is somewhere new, the memory is
    forgotten."""

    grid: GridLayout | None
    moves: Sequence[Action] = ()
    """The moves along the heading, whose blocking is remembered by direction (below)."""
    pose: tuple[float, float, float] = (0.0, 0.0, 0.0)
    done: list[tuple[str, float, float, float]] = field(default_factory=list)

    def after_move(self, report: MotionReport | None) -> None:
        if report is None or report.odometry is None:
            if report is None or report.blocked is not True:
                self.done.clear()
            return
        dx, dy, dyaw = report.odometry
        x, y, yaw = self.pose
        c, s = math.cos(yaw), math.sin(yaw)
        self.pose = (x + c * dx - s * dy, y + s * dx + c * dy, yaw + dyaw)

    def after(self, *moves: Action) -> set[str]:
        """The actions already done from (near) where the commanded ``moves``, one after the other,
        would take the robot (turns and moves along the heading, by their commanded motion; empty
        when one is a compass move, whose motion in the odometry's frame is unknown)."""
        x, y, yaw = self.pose
        for move in moves:
            asked = motion(self.grid, move)
            if not asked or not ("turn" in asked or "advance" in asked):
                return set()
            dx, dyaw = float(asked.get("advance", 0.0)), float(asked.get("turn", 0.0))
            x, y, yaw = x + math.cos(yaw) * dx, y + math.sin(yaw) * dx, yaw + dyaw
        return self.here((x, y, yaw))

    def unread_after(self, move: Action, readings: Sequence[Action]) -> list[Action]:
        """Those of ``readings`` not yet taken where the commanded ``move`` would take the robot."""
        done = self.after(move)
        return [a for a in readings if a.name not in done]

    def add(self, name: str) -> None:
        self.done.append((name, *self.pose))

    def here(self, pose: tuple[float, float, float] | None = None) -> set[str]:
        """The actions already done from (near) the present pose (or ``pose``); and of
        :attr:`moves`, those that drive the way a move found blocked here drove, whatever the robot's
        heading then (a step back blocked facing north is a step forward blocked facing south)."""
        grid = self.grid
        cell = grid.cell_size / 4 if grid is not None else 0.0
        sector = (2 * math.pi / grid.headings if grid is not None and grid.headings > 1 else math.inf) / 4
        x, y, yaw = self.pose if pose is None else pose
        near = [(name, pyaw) for name, px, py, pyaw in self.done if math.hypot(px - x, py - y) < cell]
        out = {name for name, pyaw in near if abs(math.remainder(pyaw - yaw, 2 * math.pi)) < sector}
        ways = {m.name: way for m in self.moves if (way := self._way(m)) is not None}
        stopped = [pyaw + ways[name] for name, pyaw in near if name in ways]
        for name, way in ways.items():
            if any(abs(math.remainder(yaw + way - d, 2 * math.pi)) < sector for d in stopped):
                out.add(name)
        return out

    def _way(self, move: Action) -> float | None:
        """The direction a move along the heading drives, relative to the heading (0 or π); None
        for a turn or a compass move."""
        asked = motion(self.grid, move) or {}
        advance = float(asked.get("advance", 0.0))
        return None if advance == 0.0 else (0.0 if advance > 0 else math.pi)


@dataclass
class LookAlikes:
    """Khalvati & Mackworth's pairwise action selection for the end of a search: once a few places
    (at most :data:`~beliefloc.planning.telling.MAX_PLACES`, modes of the planning belief) hold the
    planner's ``goal`` between them, the robot follows the macro that tells them apart best per
    unit of cost (:func:`beliefloc.planning.telling.telling_macros`) -- its moves, then its reading --
    judged by the filter's own units and tables (:meth:`BeliefFilter.macro_graph`: the lattice's
    poses), not the model's states.

    Why: the planner plans with the model's exact tables. On tb3-sandbox a pixel of saved wall moves
    a cell centre's reading across a bin edge, so the planner expects one scan near the arena's
    centre to tell the 180° mirror twins apart, and the lattice (a laser with 2 cm of error) reads
    the same from both: an episode replanned for 140 steps with the twin at 0.1 and ended at the
    step limit, at the right place. The walls' asymmetries tell them apart; this macro goes there.
    (By the states -- a place's cells moved whole by their most likely successors and read as the
    average of their poses -- the macros of an episode traced expected 3-4 nats from their reading
    where the lattice expected 0.01-0.4: which part of a cell is free differs between mirror twins
    where the robot's own pose reads the same from both, and a pillar that stops a cell's centre
    does not stop the robot beside it.)

    A macro is followed to its end, then a new one is chosen; sooner when one of its moves left the
    robot where it was (a pillar the place's cell centre passes and the robot, off the centre, does
    not) or its next action was already done here (a reading taken, a move found blocked). Chosen
    afresh after every action instead, the macros of an episode traced flipped between two of equal
    worth, forward and back, for 30 actions.
    """

    model: Model
    tracker: BeliefFilter
    places: Places
    goal: float
    _going: bool = False
    _left: list[Action] = field(default_factory=list)
    """The macro's actions still to do."""
    _given: Action | None = None

    def next_action(self, read_here: set[str], last: Action | None, last_moved: bool) -> Action | None:
        """The next action of the macro under way or of a new one; None when the belief is not down to
        two places or no reading within reach is expected to tell them apart. ``read_here``: the
        actions already done where the robot stands; ``last``: the action done last, and whether it
        moved the robot."""
        belief = self.tracker.belief
        found = [(members, belief[members]) for _, members in belief_places(self.model, belief)]
        # begun when two places hold the goal, the macros go on while they hold KEEP_GOING: a move's
        # noise lends a third place 1-3 % until the next reading takes it back, and the planner's
        # step in between undid the macro's
        places = few_places(found, KEEP_GOING if self._going else self.goal)
        self._going = places is not None
        stale = last is not self._given or (last is not None and last.is_actuation and not last_moved)
        if places is None or stale or (self._left and self._left[0].name in read_here):
            self._left.clear()
        if places is not None and not self._left:
            self._left = self._macro(places)
        self._given = self._left.pop(0) if self._left else None
        return self._given

    def one_place(self) -> bool:
        """Whether the fewest places that hold the goal between them are one place's spread: two or
        more, each mode's likeliest state within :data:`NEIGHBOUR_CELLS` cells and one heading of
        the likeliest one's. A place known to a few tenths of a metre parts into modes a cell or two
        apart (a mode gathers 1.5 cells); no macro tells those apart -- a reading that places the
        robot within the place does (:func:`securing_move`). On the depot the macros led such
        neighbours about for 30 actions at a time while the declared reach stayed at 0.7-0.88."""
        grid = self.model.grid
        if grid is None:
            return False
        modes = sorted(
            (mode for mode, _ in belief_places(self.model, self.tracker.belief)), key=lambda m: -m.probability
        )
        held = np.cumsum([mode.probability for mode in modes])
        count = int(np.searchsorted(held, self.goal - 1e-12)) + 1
        if count < 2 or count > len(modes):
            return False
        first = modes[0]
        _, _, heading = grid.cell_heading(first.state)
        for mode in modes[1:count]:
            _, _, other = grid.cell_heading(mode.state)
            turn = int(abs(int(other) - int(heading))) % grid.headings
            apart = math.hypot(mode.pose.x - first.pose.x, mode.pose.y - first.pose.y) / grid.cell_size
            if apart > NEIGHBOUR_CELLS + 1e-9 or min(turn, grid.headings - turn) > 1:
                return False
        return True

    def _macro(self, places: list[tuple[np.ndarray, np.ndarray]]) -> list[Action]:
        """The best of the :data:`CANDIDATES` best macros over the filter's own units (states, or
        lattice poses: :meth:`BeliefFilter.macro_graph`), judged again by the filter's account of
        where each whole place goes (:meth:`BeliefFilter.readings_after`); empty when none is
        expected to tell anything."""
        model = self.model
        graph, tables = self.tracker.macro_graph()
        index = {a.name: k for k, a in enumerate(model.actions)}

        def taken(path: tuple[int, ...]) -> set[int]:
            return {index[name] for name in self.places.after(*(model.actions[k] for k in path)) if name in index}

        masses = np.array([float(mass.sum()) for _, mass in places])
        units = []
        for (states, _), total in zip(places, masses, strict=True):
            members, mass = self.tracker.place_units(states)
            units.append((members, mass * (total / mass.sum())))
        candidates = telling_macros(
            graph,
            np.array([a.cost for a in model.actions], dtype=np.float64),
            [index[a.name] for a in model.actuation_actions],
            {index[a.name]: tables[index[a.name]] for a in model.perception_actions},
            units,
            self.goal,
            taken,
            count=CANDIDATES,
        )
        weights = masses / masses.sum()
        needed = needed_evidence(weights, self.goal)
        best: list[Action] = []
        best_worth = 0.0
        for macro in candidates:
            moves = [model.actions[k] for k in macro.moves]
            reading = model.actions[macro.reading]
            read = self.tracker.readings_after([states for states, _ in places], moves, reading)
            worth = min(which_place_evidence([np.stack(read)], weights), needed) / macro.cost
            if worth > best_worth * (1 + 1e-9) + 1e-12:
                best, best_worth = [*moves, reading], worth
        return best


def informative_move(
    tracker: BeliefFilter,
    model: Model,
    places: Places,
    moves: Sequence[Action],
    draw: np.random.Generator,
    readings: Sequence[Action] = (),
) -> tuple[Action, Action | None]:
    """The action expected to tell the most about the robot's place per unit of cost: one of
    ``readings`` (not yet taken here) by its expected information (:meth:`BeliefFilter.information`)
    over its cost, or one of ``moves`` (the ones not yet found blocked here) by the probability that
    it takes the robot elsewhere (:meth:`BeliefFilter.move_outlook`) times the best expected
    information of a reading not yet taken where it lands (:meth:`Places.after`), over the move's
    and the reading's cost. The planner plans on the model's states, whose readings it counts as
    independent: asked for a reading already taken here, the loop gave it a move drawn at random --
    on the kitchen 14 of an episode's 16 moves were such draws, many of them into a wall or back to
    where the robot had read. A draw from ``draw`` among ``moves`` when nothing is expected to tell
    anything. With a move, the reading it is made for (to be taken where the robot lands)."""
    best: tuple[Action, Action | None] | None = None
    best_value = 0.0
    for reading in readings:
        value = tracker.information(reading) / reading.cost if reading.cost > 0 else math.inf
        if value > best_value * (1 + 1e-9) + 1e-12:
            best, best_value = (reading, None), value
    for move in moves:
        after = places.unread_after(move, model.perception_actions)
        if not after:
            continue
        p_moves, information = tracker.move_outlook(move, after)
        values = [p_moves * i / (move.cost + r.cost) for i, r in zip(information, after, strict=True)]
        value = max(values)
        if value > best_value * (1 + 1e-9) + 1e-12:
            best, best_value = (move, after[values.index(value)]), value
    if best is None:
        return (moves[int(draw.integers(len(moves)))], None) if moves else (readings[0], None)
    return best


def securing_move(
    tracker: BeliefFilter,
    model: Model,
    places: Places,
    moves: Sequence[Action],
    readings: Sequence[Action],
) -> tuple[Action, Action | None] | None:
    """The action expected to raise the declared probability (:meth:`BeliefFilter.peak`) the most
    per unit of cost, once the planner's goal is met and only the declaration is not: one of
    ``readings`` (not yet taken here), or one of ``moves`` and then a reading not yet taken where it
    lands, each judged by the declaration it is expected to leave
    (:meth:`BeliefFilter.declared_after`); with a move, the reading it is made for. None when none
    is expected to raise it by :data:`SECURING_GAIN` per unit of cost. What is left to learn there is
    where within the place the robot is -- on the depot (a scan binned at 0.5 / 1.5 / 3 / 6 m) which
    side of a cell's border -- and a reading's information about the whole pose,
    :func:`informative_move`'s measure, does not say how much of it falls within the declared reach:
    robots read and stepped back and forth for 300 actions at 0.75-0.9."""
    now = tracker.peak()
    best: tuple[Action, Action | None] | None = None
    best_gain = SECURING_GAIN
    options: list[tuple[Sequence[Action], Sequence[Action]]] = [((), readings)]
    options += [((move,), places.unread_after(move, model.perception_actions)) for move in moves]
    for moves_first, after in options:
        if not after:
            continue
        for reading, expected in zip(after, tracker.declared_after(moves_first, after), strict=True):
            cost = sum(m.cost for m in moves_first) + reading.cost
            gain = (expected - now) / cost if cost > 0 else 0.0
            if gain >= best_gain * (1 + 1e-9):
                best, best_gain = ((moves_first[0], reading) if moves_first else (reading, None)), gain
    return best


def keeping_moves(tracker: BeliefFilter, moves: Sequence[Action], threshold: float) -> list[Action]:
    """The confirmation's candidate moves: those after which, by the filter's own prediction, the
    belief still holds ``threshold`` before anything is read (:meth:`BeliefFilter.peak_after`); the
    one that keeps the most when none does. A move's noise spreads the belief it confirms: on the
    depot (0.25 m cells, a pose lattice of 0.125 m) the most informative move, a step back, took the
    reach from 0.968 to 0.80 by itself, the reading after it could not restore it, and the robot
    wandered 400 more actions without declaring; a turn kept 0.963 and the state was declared.
    ``localize`` offers only the moves to where a reading is still to be taken (when there are
    any): turning on the spot where every heading was read, the confirmation found nothing to read
    and turned again, 180 times on the kitchen."""
    kept = [(tracker.peak_after(move), move) for move in moves]
    holding = [move for peak, move in kept if peak >= threshold]
    return holding or [max(kept, key=lambda pair: pair[0])[1]]


def moved(report: MotionReport | None, grid: GridLayout | None) -> bool:
    """Whether a move took the robot somewhere its sensors read anew: unknown (protocol 1) counts as
    moved; a reported odometry of at least a quarter cell or a quarter heading sector; a blocked
    flag without odometry counts as not moved."""
    if report is None:
        return True
    if report.odometry is None:
        return report.blocked is not True
    dx, dy, dyaw = report.odometry
    cell = grid.cell_size if grid is not None else 0.0
    sector = 2 * math.pi / grid.headings if grid is not None and grid.headings > 1 else math.inf
    return math.hypot(dx, dy) >= cell / 4 or abs(dyaw) >= sector / 4


class SimulatedReadingRobot:
    """A :class:`SimulatedRobot` that answers with raw readings: for each sampled observation, the
    readings in the middle of its bins (:meth:`ReadingBinner.example`)."""

    def __init__(self, robot: SimulatedRobot, binner: ReadingBinner) -> None:
        self.robot = robot
        self.binner = binner

    def act(self, command: Command) -> Mapping[str, RawReading]:
        observation = self.robot.act(command.action.name)
        return self.binner.example(command.action, observation)
