"""The belief ``localize`` keeps between actions, behind one interface: the model's own states, or a
pose lattice finer than them (issue 26).

* :class:`ModelFilter` -- the papers' filter: ``T_a`` (or the reported odometry, or the blocked
  flag: :func:`beliefloc.robots.odometry.predict_reported`) then ``O_a``, over the model's states.
  Right for a robot that is where the model says: a simulated grid robot, the papers' worlds.
* :class:`LatticeFilter` -- a real robot: the belief over a lattice of poses finer than the states
  (:mod:`beliefloc.continuous.pose_lattice`), its readings scored by the sensors' continuous models
  (:mod:`beliefloc.semantic_map.lattice_sensors`). A robot off the cell centres and headings keeps
  its offset from place to place; this filter carries it, so the true pose is not explained away by
  a confusion rate. The planner still sees the model's belief (the lattice's, summed per state).

Either answers :meth:`start`, :meth:`predict`, :meth:`probabilities`, :meth:`correct`,
:meth:`expected_log_likelihood`, :meth:`respread`, :meth:`declared` (the state to declare and the
probability the threshold is compared with) and :meth:`peak` (that probability), all in the model's
terms.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Protocol

import numpy as np

from beliefloc.belief import correct, predict
from beliefloc.continuous.motion import OdometryNoise
from beliefloc.continuous.pose_lattice import LatticeFilter as LatticeCore
from beliefloc.continuous.pose_lattice import PoseLattice, mutual_information
from beliefloc.errors import InvalidValueError
from beliefloc.model import Action, GridLayout, Model
from beliefloc.pose import gathered_modes
from beliefloc.robots.odometry import MotionReport, motion, predict_reported
from beliefloc.robots.readings import RawReading, ReadingBinner
from beliefloc.robots.surprise import expected_log_likelihood, reading_moments, respread
from beliefloc.semantic_map.sections import ScanSensor

if TYPE_CHECKING:
    from beliefloc.continuous.lattice_scan import LatticeScanModel
    from beliefloc.pose import PoseEstimate
    from beliefloc.semantic_map.lattice_sensors import BeamSamples


class BeliefFilter(Protocol):
    """What ``localize``'s loop asks of the belief it keeps (see the module)."""

    belief: np.ndarray
    """The belief over the model's states (a lattice's, summed per state)."""
    gathers_places: bool
    """Whether :meth:`planning_belief` gathers each place's spread into one mode, so that a
    look-alike place is a mode of its own (:func:`beliefloc.robots.localize.planning_goal`)."""

    def start(self, belief: np.ndarray) -> np.ndarray: ...

    def predict(self, action: Action, report: MotionReport | None) -> None: ...

    def probabilities(self, action: Action) -> np.ndarray: ...

    def correct(
        self, action: Action, observation: int | None, readings: Mapping[str, RawReading] | None = None
    ) -> tuple[np.ndarray, float]: ...

    def expected_log_likelihood(self, action: Action) -> float: ...

    def log_likelihood_variance(self, action: Action) -> float: ...

    def respread(self) -> np.ndarray: ...

    def declared(self) -> tuple[int, float]: ...

    def peak(self) -> float: ...

    def elsewhere(self) -> float: ...

    def pose_estimate(self, state: int, probability: float) -> PoseEstimate | None:
        """The pose to report for ``state`` declared at ``probability``, when the filter knows it
        finer than the state's own pose; None: the state's pose (:func:`beliefloc.pose.belief_pose`)."""
        ...

    def peak_after(self, move: Action) -> float: ...

    def declared_after(self, moves: Sequence[Action], readings: Sequence[Action | None]) -> list[float]: ...

    def planning_belief(self) -> np.ndarray: ...

    def information(self, action: Action) -> float: ...

    def move_outlook(self, move: Action, readings: Sequence[Action]) -> tuple[float, list[float]]: ...

    def macro_graph(self) -> tuple[np.ndarray, list[list[np.ndarray]]]: ...

    def place_units(self, states: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...

    def readings_after(
        self, places: Sequence[np.ndarray], moves: Sequence[Action], reading: Action
    ) -> list[np.ndarray]: ...


class ModelFilter:
    """The model's own filter (see the module)."""

    gathers_places = False

    def __init__(self, model: Model) -> None:
        self.model = model
        self.belief = np.ones(model.n_states) / model.n_states

    def start(self, belief: np.ndarray) -> np.ndarray:
        self.belief = belief
        return belief

    def predict(self, action: Action, report: MotionReport | None) -> None:
        self.belief = predict_reported(action, self.belief, report, self.model.grid)

    def probabilities(self, action: Action) -> np.ndarray:
        return action.observation.probabilities(self.belief)

    def correct(
        self, action: Action, observation: int | None, readings: Mapping[str, RawReading] | None = None
    ) -> tuple[np.ndarray, float]:
        """The binned ``observation`` (a whole scan among ``readings`` counts by its binned beams:
        the model's states read only those)."""
        self.belief, probability = correct(action, self.belief, observation)
        return self.belief, probability

    def expected_log_likelihood(self, action: Action) -> float:
        return expected_log_likelihood(action, self.belief)

    def log_likelihood_variance(self, action: Action) -> float:
        return reading_moments(action, self.belief)[1]

    def respread(self) -> np.ndarray:
        self.belief = respread(self.belief)
        return self.belief

    def declared(self) -> tuple[int, float]:
        """The most likely state and its probability: what the threshold is compared with."""
        state = int(np.argmax(self.belief))
        return state, float(self.belief[state])

    def peak(self) -> float:
        return self.declared()[1]

    def elsewhere(self) -> float:
        """0: a state is one exact pose, and the papers' rule -- one state holds the threshold -- is
        the whole of what is declared."""
        return 0.0

    def pose_estimate(self, state: int, probability: float) -> PoseEstimate | None:
        """None: the model knows no pose finer than a state's."""
        return None

    def peak_after(self, move: Action) -> float:
        """The most likely state's probability were the commanded ``move`` made now (``T_a``)."""
        return float(predict_reported(move, self.belief, None, self.model.grid).max())

    def declared_after(self, moves: Sequence[Action], readings: Sequence[Action | None]) -> list[float]:
        """For each of ``readings`` (None: none), the most likely state's probability expected after
        ``moves`` (``T_a``) and that reading: ``sum_o max_s b'(s) O(o | s)``."""
        belief = self.belief
        for move in moves:
            belief = predict_reported(move, belief, None, self.model.grid)
        support = np.flatnonzero(belief > 0)
        out = []
        for reading in readings:
            if reading is None or not support.size:
                out.append(float(belief.max()))
                continue
            joint = reading.observation.likelihood_matrix(support) * belief[support][:, None]
            out.append(float(joint.max(axis=0).sum() / joint.sum()))
        return out

    def planning_belief(self) -> np.ndarray:
        """The belief itself: the planner's goal is the threshold's."""
        return self.belief

    def information(self, action: Action) -> float:
        """The expected information (nats) of one reading of ``action`` about the state
        (:func:`~beliefloc.continuous.pose_lattice.mutual_information`)."""
        return mutual_information(
            action.observation.probabilities(self.belief), expected_log_likelihood(action, self.belief)
        )

    def move_outlook(self, move: Action, readings: Sequence[Action]) -> tuple[float, list[float]]:
        """The probability that ``move`` takes the robot elsewhere (``1 - T_a[s, s]`` under the
        belief), and the expected information (:func:`~beliefloc.continuous.pose_lattice.mutual_information`) of each of
        ``readings`` taken where it lands, given that it moved."""
        nothing = (0.0, [0.0] * len(readings))
        if move.transition is None:
            return nothing
        stays = np.asarray(move.transition.diagonal(), dtype=np.float64)
        goes = self.belief * (1.0 - stays)
        p_moves = float(goes.sum())
        if not p_moves > 0:
            return nothing
        moved = predict(move, goes / p_moves)
        return p_moves, [
            mutual_information(r.observation.probabilities(moved), expected_log_likelihood(r, moved)) for r in readings
        ]

    def macro_graph(self) -> tuple[np.ndarray, list[list[np.ndarray]]]:
        """What a telling macro (:mod:`beliefloc.planning.telling`) searches over: per action, each
        state's most likely successor (``(n_actions, n_states)``), and per action, its observation
        parts' tables by state (``(n_states, n_values)`` each; none for a move)."""
        from beliefloc.planning.ec2 import most_likely_successors

        return most_likely_successors(self.model)[0], [
            [part.confusion[part.truth] for part in action.observation.parts] for action in self.model.actions
        ]

    def place_units(self, states: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """A place (``states``) in :meth:`macro_graph`'s units: the states and the belief on each."""
        return states, self.belief[states]

    def readings_after(
        self, places: Sequence[np.ndarray], moves: Sequence[Action], reading: Action
    ) -> list[np.ndarray]:
        """For each of ``places`` (states): the distribution of ``reading``'s observation were the
        robot there (the belief restricted to them) and ``moves`` made first (``T_a``)."""
        out = []
        for states in places:
            belief = np.zeros_like(self.belief)
            belief[states] = self.belief[states]
            for move in moves:
                belief = predict(move, belief)
            total = float(belief.sum())
            out.append(reading.observation.probabilities(belief / total if total > 0 else belief))
        return out


PLACE_POSES = 16
"""How many of a place's likeliest lattice poses a telling macro leads along (the rest hold little)."""


def tracker_noise(grid: GridLayout) -> OdometryNoise:
    """The motion noise the lattice filter assumes, a little wider than a real base's: 10 % of a
    move's length, 4° per heading step turned, 0.05 rad of yaw per metre driven."""
    turn = 2 * math.pi / grid.headings if grid.headings > 1 else math.pi / 2
    return OdometryNoise(alpha1=(math.radians(4.0) / turn) ** 2, alpha2=0.05**2, alpha3=0.1**2, alpha4=0.0)


def commanded_deltas(grid: GridLayout, action: Action, lattice: PoseLattice) -> list[tuple[float, float, float]] | None:
    """The robot-frame motion ``action`` commands from each lattice yaw (one for all when the same),
    as the line protocol's ``motion`` says it (:func:`beliefloc.robots.odometry.motion`); None
    for an action that does not move."""
    asked = motion(grid, action)
    if not asked:
        return None
    if "turn" in asked:
        return [(0.0, 0.0, float(asked["turn"]))]
    if "advance" in asked:
        if "advance_diagonal" not in asked:
            return [(float(asked["advance"]), 0.0, 0.0)]
        heading = lattice.yaw_headings()
        return [
            (float(asked["advance_diagonal"] if h % 2 == 1 else asked["advance"]), 0.0, 0.0) for h in heading.tolist()
        ]
    # a compass move: map-frame metres, into the grid frame, then into each yaw's robot frame
    yaw0 = grid.frame.yaw
    x, y = float(asked["x"]), float(asked["y"])
    gx, gy = math.cos(yaw0) * x + math.sin(yaw0) * y, -math.sin(yaw0) * x + math.cos(yaw0) * y
    yaws = lattice.yaws()
    return [(math.cos(a) * gx + math.sin(a) * gy, -math.sin(a) * gx + math.cos(a) * gy, 0.0) for a in yaws.tolist()]


MEASURED_SUPPORT = 1e-12
"""A measured range is scored at the lattice poses holding at least this share of the most likely one's
mass; the others are dropped (their mass goes to 0, as a particle filter drops its least likely
particles; the motion noise spreads mass back around the belief, and a robot that is not where the belief
is shows up in the fit check). Scoring a beam costs 12 sub-poses a pose: the depot has 1,003,520 poses."""


class LatticeFilter:
    """The pose-lattice filter behind the :class:`BeliefFilter` interface (see the module)."""

    gathers_places = True

    def __init__(
        self,
        binner: ReadingBinner,
        *,
        max_poses: int | None = None,
        noise: OdometryNoise | None = None,
        mean_reach: bool = False,
    ) -> None:
        """``mean_reach``: declare by the reach around the belief's mean pose too
        (:attr:`beliefloc.continuous.pose_lattice.LatticeFilter.mean_reach_too`)."""
        from beliefloc.semantic_map.lattice_sensors import make_lattice, sensor_tables

        model = binner.model
        grid = model.grid
        if grid is None:
            raise InvalidValueError(f"model {model.name!r} has no grid: a pose lattice needs cells and headings")
        self.model = model
        self.binner = binner
        self._scan_model: LatticeScanModel | None = None
        self._samples: dict[str, BeamSamples] = {}
        lattice = make_lattice(binner.smap, grid, max_poses)
        slots = {a.name: [(s.name, s.first_part, s.n_parts) for s in binner.sensors(a)] for a in model.actions}
        tables = sensor_tables(binner.smap, model, lattice, slots, self._samples)
        motions = {}
        for action in model.actuation_actions:
            deltas = commanded_deltas(grid, action, lattice)
            if deltas is not None:
                motions[action.name] = deltas
        self.core = LatticeCore(lattice, tables, motions, noise or tracker_noise(grid), mean_reach_too=mean_reach)
        self.belief = self.core.start(np.ones(model.n_states) / model.n_states)
        self._declared: tuple[int, float] | None = None
        self._elsewhere: float | None = None
        self._planning: np.ndarray | None = None
        self._graph: tuple[np.ndarray, list[list[np.ndarray]]] | None = None

    @property
    def lattice(self) -> PoseLattice:
        return self.core.lattice

    def start(self, belief: np.ndarray) -> np.ndarray:
        self.belief = self.core.start(belief)
        self._declared = None
        self._elsewhere = None
        self._planning = None
        return self.belief

    def predict(self, action: Action, report: MotionReport | None) -> None:
        if not action.is_actuation:
            return
        odometry = report.odometry if report is not None else None
        blocked = report.blocked if report is not None else None
        self.core.predict(action.name, odometry, blocked)
        self.belief = self.core.belief
        self._declared = None
        self._elsewhere = None
        self._planning = None

    def probabilities(self, action: Action) -> np.ndarray:
        return self.core.probabilities(action.name)

    def correct(
        self, action: Action, observation: int | None, readings: Mapping[str, RawReading] | None = None
    ) -> tuple[np.ndarray, float]:
        """Bayes' rule with the binned ``observation``; a whole scan among the raw ``readings``
        (:meth:`~beliefloc.robots.readings.ReadingBinner.full_scans`) is scored in full by the
        likelihood field (:mod:`beliefloc.continuous.lattice_scan`) instead of its binned beams'
        tables. The probability returned is the binned observation's either way."""
        if observation is None:
            return self.belief, 1.0
        digits = action.observation.decode(observation)
        scans = self.binner.full_scans(action, readings) if readings else {}
        beams = self._measured_beams(action, readings) if readings and not scans else []
        if beams:
            # the poses that hold mass (a pose at 1e-12 of the best one cannot matter to this update)
            fine = self.core.fine
            held = np.flatnonzero(fine > MEASURED_SUPPORT * fine.max())
            log = np.full(self.lattice.n_poses, -np.inf)
            log[held] = 0.0
            for samples, beam, measured, _ in beams:
                log[held] += samples.log_likelihood(beam, measured, held)
            self.belief, probability = self.core.correct(action.name, digits, log, [part for *_, part in beams])
        elif scans:
            if self._scan_model is None:
                from beliefloc.continuous.lattice_scan import LatticeScanModel

                self._scan_model = LatticeScanModel(self.lattice)
            log = np.zeros(self.lattice.n_poses)
            replaces: list[int] = []
            for slot in self.binner.sensors(action):
                if slot.name in scans:
                    scan, mount = scans[slot.name]
                    log += self._scan_model.log_likelihood(scan, mount)
                    replaces.extend(range(slot.first_part, slot.first_part + slot.n_parts))
            self.belief, probability = self.core.correct(action.name, digits, log, replaces)
        else:
            self.belief, probability = self.core.correct(action.name, digits)
        self._declared = None
        self._elsewhere = None
        self._planning = None
        return self.belief, probability

    def expected_log_likelihood(self, action: Action) -> float:
        return self.core.expected_log_likelihood(action.name)

    def _measured_beams(
        self, action: Action, readings: Mapping[str, RawReading]
    ) -> list[tuple[BeamSamples, int, float, int]]:
        """The beams of ``action``'s scans read one by one whose measured range lies within the last bin
        edge: ``(the sensor's samples, beam, range, observation part)``. A beam that read nothing, or
        beyond the last edge, keeps its bin's table."""
        out = []
        for slot in self.binner.sensors(action):
            raw = readings.get(slot.name)
            samples = self._samples.get(slot.name)
            if samples is None or not isinstance(slot.sensor, ScanSensor):
                continue
            values = [raw] if isinstance(raw, (int, float)) else raw  # a one-beam scan may be the number alone
            if not isinstance(values, (list, tuple)):
                continue
            for beam, value in enumerate(values):
                # ranges the binner accepted (it raised on any other); a bool is no range
                if isinstance(value, (int, float)) and not isinstance(value, bool) and 0.0 <= value <= samples.bins[-1]:
                    out.append((samples, beam, float(value), slot.first_part + beam))
        return out

    def log_likelihood_variance(self, action: Action) -> float:
        return self.core.log_likelihood_variance(action.name)

    def respread(self) -> np.ndarray:
        self.belief = self.core.respread()
        self._declared = None
        self._elsewhere = None
        self._planning = None
        return self.belief

    def declared(self) -> tuple[int, float]:
        """The state to declare and the probability that the robot is within its reach: one cell and
        ¾ of a sector of the most likely state (or, with ``mean_reach``, of the belief's mean pose
        around it when that holds more), never beyond the state's promise (1.5 cells, one sector)
        (:meth:`beliefloc.continuous.pose_lattice.LatticeFilter.declared`)."""
        if self._declared is None:
            self._declared = self.core.declared()
        return self._declared

    def peak(self) -> float:
        return self.declared()[1]

    def elsewhere(self) -> float:
        """The probability that the robot is beyond the declared state's promise (1.5 cells, one
        sector): that declaring it now would be confidently wrong, by the belief's own account
        (:meth:`beliefloc.continuous.pose_lattice.LatticeFilter.elsewhere`)."""
        if self._elsewhere is None:
            self._elsewhere = self.core.elsewhere(self.declared()[0])
        return self._elsewhere

    def pose_estimate(self, state: int, probability: float) -> PoseEstimate:
        """The lattice's mean pose within ``state``'s promise and the lattice belief's covariance, in
        the map frame (:meth:`beliefloc.continuous.pose_lattice.LatticeFilter.pose_estimate`)."""
        from beliefloc.pose import grid_frame_estimate

        pose, covariance = self.core.pose_estimate(state)
        return grid_frame_estimate(self.lattice.layout, state, probability, pose, covariance)

    def peak_after(self, move: Action) -> float:
        """The declared probability were the commanded ``move`` made now, nothing read
        (:meth:`beliefloc.continuous.pose_lattice.LatticeFilter.peak_after`)."""
        return self.core.peak_after(move.name) if move.is_actuation else self.peak()

    def declared_after(self, moves: Sequence[Action], readings: Sequence[Action | None]) -> list[float]:
        """For each of ``readings`` (None: none), the declared probability expected after the
        commanded ``moves`` and that reading
        (:meth:`beliefloc.continuous.pose_lattice.LatticeFilter.declared_after`)."""
        return self.core.declared_after([m.name for m in moves], [r.name if r is not None else None for r in readings])

    def planning_belief(self) -> np.ndarray:
        """The belief the planner plans from: each of its modes (:func:`beliefloc.pose.belief_modes`,
        states within 1.5 cells and one heading of the mode's best one) gathered on its best state.
        The threshold is compared with the mass within a state's reach (:meth:`declared`), not with
        one state's: planning from the belief itself, the planner would spend the robot's moves
        telling neighbouring cells apart -- which the exact model says a reading can, and an off-grid
        robot's readings cannot -- instead of the places far apart that still share the belief (the
        mirror twin of a symmetric floor)."""
        if self._planning is None:
            self._planning = gathered_modes(self.model, self.belief)
        return self._planning

    def information(self, action: Action) -> float:
        """The expected information (nats) of one reading of ``action`` about the pose
        (:meth:`beliefloc.continuous.pose_lattice.LatticeFilter.information`)."""
        return self.core.information(action.name)

    def move_outlook(self, move: Action, readings: Sequence[Action]) -> tuple[float, list[float]]:
        """The probability that the commanded ``move`` takes the robot elsewhere (its path open on
        the map), and the expected information of each of ``readings`` taken where it lands, given
        that it moved (:meth:`beliefloc.continuous.pose_lattice.LatticeFilter.move_outlook`)."""
        return self.core.move_outlook(move.name, [r.name for r in readings])

    def macro_graph(self) -> tuple[np.ndarray, list[list[np.ndarray]]]:
        """What a telling macro (:mod:`beliefloc.planning.telling`) searches over, by lattice pose:
        per action, the pose it takes each pose to without noise
        (:meth:`beliefloc.continuous.pose_lattice.LatticeFilter.pose_successors`), and per action,
        its reading parts' tables by pose (why not by the states: :class:`~beliefloc.robots.localize.LookAlikes`)."""
        if self._graph is None:
            core = self.core
            actions = self.model.actions
            self._graph = (
                np.stack([core.pose_successors(a.name) for a in actions]),
                [[np.asarray(t, dtype=np.float64) for t in core.tables.get(a.name, [])] for a in actions],
            )
        return self._graph

    def place_units(self, states: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """A place (``states``) in :meth:`macro_graph`'s units: its :data:`PLACE_POSES` likeliest
        lattice poses and the belief on each."""
        lattice = self.lattice
        poses = np.flatnonzero(np.isin(lattice.state, states) & (self.core.fine > 0))
        mass = self.core.fine[poses]
        keep = np.argsort(-mass, kind="stable")[:PLACE_POSES]
        return poses[keep], mass[keep]

    def readings_after(
        self, places: Sequence[np.ndarray], moves: Sequence[Action], reading: Action
    ) -> list[np.ndarray]:
        """For each of ``places`` (states): the distribution of ``reading``'s joint reading were the
        robot among the lattice poses of the place, and ``moves`` made first, each pose stopped where
        the map blocks its path (:meth:`beliefloc.continuous.pose_lattice.LatticeFilter.readings_after`)."""
        return self.core.readings_after(places, [m.name for m in moves], reading.name)
