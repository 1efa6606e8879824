"""The grid filter of the real world: Fox, Burgard & Thrun's grid-based Markov localization with
AMCL's model family, over every pose at once.

The belief ``bel[k, r, c]`` is over headings ``k`` (beliefloc's: heading 0 up the map image, then
clockwise, :func:`~beliefloc.continuous.motion.grid_yaws`) × the cells ``(r, c)`` of a window of
the grid laid over the occupancy image (:mod:`beliefloc.semantic_map.occupancy_grid`; the window is
the bounding box of the cells that are states). Each update is Bayes' rule with the odometry
motion model and the laser's likelihood field::

    bel'(s')  = sum_s p(s' | s, u) bel(s)                 (predict_grid: u the odometry delta)
    bel''(s') = eta p(z | s') bel'(s')                    (LikelihoodField.scan_log_likelihood)

**When to update** (AMCL's ``update_min_d`` / ``update_min_a``): the first scan, then a scan when
the odometry has moved at least ``update_min_d`` metres or turned ``update_min_a`` radians since
the last update -- and every scan while the base turns faster than ``turning_rate`` (a turn sweeps
the scan over new walls quickly; its sweeps are de-skewed by the caller).

**Verdicts.** After each update the belief's *modes* are found (the best state, the mass within
``mode_radius`` and ``mode_yaw`` of it, then the best state outside that, ...). The robot is
*localized* only when the first mode holds at least ``threshold`` of the mass AND the recent scans
fit its pose (:mod:`beliefloc.continuous.fit`) AND no rival place explains them about as well
(:attr:`FilterConfig.rival_margin`; the comparison is clutter-trimmed, :func:`trimmed_gap`: the
evidence that a few unmapped objects could have made is set aside, an object seen in every scan
counted once -- but never a beam that at the rival's pose would have passed through one of its
walls, which no object does, :attr:`FilterConfig.wall_tolerance`; in the verdict both ways: what
objects at the best place could have made in the rival's favour is set aside too), in updates in a
row counted by the motion between them (:attr:`FilterConfig.distinct_updates`) -- on the current
scan, or on the remembered ones (:attr:`FilterConfig.history`), each place carried back along the
odometry with the drift and the pose that fit them best (:attr:`FilterConfig.odometry_drift`). A
place told apart stays localized while the belief follows it and no rival does better (the evidence
that told it apart does not expire when its scans leave the memory). When the scans stop fitting a
confident belief, a little uniform mass is mixed back in (AMCL's recovery; Fox et al.'s
re-spreading), so that a kidnapped robot can be found again.

**The pose** is the best state's refined against the field: a local search over continuous
``(x, y, yaw)`` around the state's cell centre and heading, scored beam by beam with ``sigma_hit``.
Its covariance is the belief's (the law of total covariance, as :func:`beliefloc.pose.belief_pose`:
between states plus the cell's and sector's own spread).

Pure numpy/scipy, no I/O.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize

from beliefloc.continuous.fit import FitConfig, FitTracker, inlier_fraction, surprise
from beliefloc.continuous.image import OccupancyImage
from beliefloc.continuous.likelihood_field import Beams, CellWindow, LaserModel, LikelihoodField
from beliefloc.continuous.motion import OdometryNoise, compose, grid_yaws, odometry_parts, predict_grid, relative
from beliefloc.continuous.raycast import cast_rays_within
from beliefloc.model import wrap_angle
from beliefloc.semantic_map.occupancy_grid import free_cells
from beliefloc.semantic_map.occupancy_map import OccupancyMap


@dataclass(frozen=True)
class FilterConfig:
    """The grid filter's parameters; the defaults suit a TurtleBot-sized robot with a 2-D lidar."""

    cell_size: float = 0.1
    """Metres: the side of a cell (a state's position region)."""
    headings: int = 36
    """Heading sectors (36: 10° each)."""
    robot_radius: float = 0.15
    """Metres: a cell is a state when a disc of this radius on its centre touches no occupied or
    unknown pixel (:func:`~beliefloc.semantic_map.occupancy_grid.free_cells`)."""
    odometry: OdometryNoise = field(default_factory=OdometryNoise)
    """AMCL's ``alpha1..alpha4`` (0.2 each)."""
    laser: LaserModel = field(default_factory=LaserModel)
    """AMCL's likelihood field parameters."""
    fit: FitConfig = field(default_factory=FitConfig)
    update_min_d: float = 0.25
    """Metres of odometry translation between updates (AMCL ``update_min_d``, Nav2's 0.25)."""
    update_min_a: float = 0.2
    """Radians of odometry rotation between updates (AMCL ``update_min_a``, Nav2's 0.2)."""
    turning_rate: float = 0.1
    """Rad/s: while the base turns faster than this, every scan updates."""
    threshold: float = 0.95
    """The mass the first mode must hold to call the robot localized."""
    mode_radius: float = 0.5
    """Metres: states this close to a mode's best state (and within :attr:`mode_yaw`) are the mode."""
    mode_yaw: float = math.radians(30.0)
    """Radians: the heading half-width of a mode."""
    max_modes: int = 5
    """Modes listed at most."""
    rival_margin: float = 0.05
    """Nats per beam: a rival place whose refined pose explains the scan within this of the best's
    refined pose makes the scan ambiguous; localized needs :attr:`distinct_updates` unambiguous
    updates in a row. *Rivals* are the places the belief once held (a mode of at least
    :attr:`rival_min` beyond ``mode_radius`` of the best, or a former best), carried along by the
    odometry even after their mass is gone, until the scans rule them out (:attr:`rival_drop`). The
    belief alone is not trusted here: its states are scored at points, and a place that happens to
    lie between them loses about 2 nats per scan against its twin (measured on the near-symmetric
    TurtleBot3 sandbox, where the wrong twin went to p = 1 in 30 updates while the refined poses
    explained the scans alike)."""
    rival_min: float = 1e-3
    """The mass a mode must hold once to become a rival."""
    rival_drop: float = 0.3
    """Nats per beam: a rival explained worse than the best by this much, :attr:`distinct_updates`
    updates in a row, is ruled out by the scans and forgotten."""
    max_rivals: int = 8
    """Rivals carried at most (the closest to the best's likelihood kept)."""
    history: int = 20
    """Updates remembered (odometry and beams) for the global rival search: before a place is
    called, every state of the map is scored against the current scan (not only those the belief
    still holds), the best other places are refined, and each is scored over these updates -- its
    pose carried back along the odometry -- against the best's. One that the remembered scans do
    not rule out (within ``rival_drop`` per beam) becomes a rival. Measured: without it, a coarse
    filter (0.2 m cells) on a short depot run pruned the true place in its first updates and
    declared a look-alike aisle 15 m away."""
    history_margin: float = 1.0
    """Nats per remembered update: a place is also told apart from every rival when, over the
    remembered updates (each rival carried back along the odometry), it explains the scans better
    by ``history_margin * history`` nats (20) however few updates are remembered yet, and no rival
    explains the current scan better by ``rival_margin`` per beam, in :attr:`distinct_updates`
    updates in a row -- the earlier scans (a room passed, a corner turned) decide what the current
    one in a self-similar corridor cannot. Measured before: with the margin per update remembered
    (4 nats over the first 4 updates) and one update enough, a heavily cluttered depot run was
    declared 21 m from the truth in updates whose neighbours had a rival ahead by 100 nats."""
    global_candidates: int = 20
    """Places the global rival search refines and checks against the remembered scans: the best
    local maxima of the current scan's score beyond ``mode_radius`` of the best. On a cluttered
    scan the true place need not be near the top: measured on the depot with forty discs (seed
    105), the truth ranked 3rd to 25th among the places of single scans (its cell-centre score 10-21
    nats below the best's), while the belief held a look-alike 21 m away; with 5 candidates it was
    never a rival, and once the trim kept the beams that cross a rival's walls
    (:attr:`wall_tolerance`) the look-alike was told apart from the other, wrong, rivals."""
    odometry_drift: tuple[float, float, float] = (0.08, 0.05, 0.08)
    """The largest systematic odometry errors the remembered comparison allows for: relative error
    of the distance driven, relative error of the angle turned, radians of yaw error per metre
    driven. Each place's pose is carried back along the odometry through the remembered updates
    with the drift (within these bounds) that best explains their scans, found by a coordinate
    search (:meth:`GridFilter._drift_fit`). Without it, 5 m of a 2 %-and-0.02 rad/m odometry put the
    true pose 0.25 m and 5.5° off at the oldest update, it explained those scans 120 nats worse
    than at the truth, and in a self-similar corridor a look-alike 4.5 m along, to which the same
    drift happened to do less harm, won the remembered comparison by up to 62 nats. (0, 0, 0):
    the odometry as measured."""
    remembered_sigma: float = 0.05
    """Metres: the end points' standard deviation when remembered scans are scored (the laser's
    ``sigma_hit``). Measured: 0.1 -- for poses carried back being known less well -- let a heavily
    cluttered depot run (held-out seed 404) be declared 25 m from the truth: with the drift and the
    pose fitted, at 0.05 the truth explained the remembered scans 80-155 nats better than the
    look-alike, at 0.1 that lead drowned in +-60 nats of clutter."""
    global_check_every: int = 5
    """While a place holds the threshold, the global rival search runs again every this many updates."""
    distinct_updates: int = 3
    """Unambiguous updates in a row that localized needs -- counted by the motion they follow: an
    update counts in full after the odometry moved ``update_min_d`` or turned ``update_min_a``
    since the last one, and by its share of that otherwise (:meth:`GridFilter.update_weight`). The
    scans of a turn update the belief one after another, 0.075 rad apart at 0.6 rad/s and 8 Hz,
    and see the same walls and the same clutter: three of them are not three confirmations.
    Measured: on the depot with forty discs (held-out seed 414) three such updates at the start
    of a turn declared a look-alike 16.5 m away before the global search had made the truth a
    rival; counted by motion, the streak is not complete before the truth is a rival and is ahead."""
    recovery_alpha: float = 0.02
    """The uniform mass mixed in after an update whose scans do not fit a confident belief, or that a
    rival explains far better (by ``rival_drop`` per beam) than the belief's best place."""
    sub_poses: bool = False
    """Score each state as the best of four sub-poses a quarter cell from its centre
    (:meth:`LikelihoodField.scan_log_likelihood`): less bias towards places that happen to align
    with the cells, at 4x the laser update's cost. Off by default: with the rivals guarding the
    verdict, 10 generated depot and sandbox runs ended the same with and without (0 confidently
    wrong updates, depot within 4 cm), and one update over 10^6 states takes 0.036 s instead of 0.14 s."""
    negligible: float = 1e-12
    """States whose probability is below this fraction of the most probable state's are set to 0
    after an update (27 nats of evidence would be needed to bring one back), so that prediction
    and scoring run only over the box of states that still matter."""
    clutter_objects: int = 2
    """Unmapped objects (people, chairs) that may stand where the rival place's map has no wall.
    Every comparison of the best place with a rival (the streak of unambiguous updates, the
    remembered updates, ruling a rival out) sets aside the evidence in the best's favour that this
    many objects could have made (:func:`trimmed_gap`): a place is only told apart by evidence
    that clutter could not have made. Measured before: on the TurtleBot3 sandbox two discs by the
    wall where the mirror twin has a wall gave the twin 2.5 nats per beam, 5 nats per scan, in
    every scan (a persistent object is no independent evidence), and the twin was declared at 3.6 m
    and 180° from the truth (3 of 235 runs with ten discs; 3 of 16 depot runs with forty). An
    object only stops a beam short: the beams that would have crossed the rival's walls are never
    set aside (:attr:`wall_tolerance`)."""
    clutter_extent: float = 0.8
    """Metres: the size of one unmapped object -- beams whose end points (at the rival's pose, in
    the map) lie within this of the object's most favourable beam are set aside with it."""
    wall_tolerance: float = 0.15
    """Metres: a beam in the best place's favour whose ray, with the robot at the rival place, would
    have crossed one of the rival's walls more than this before its end point is never set aside
    as clutter (:meth:`GridFilter._walled`): an object only stops a beam short. (3 ``sigma_hit``: an end
    point this near beyond a wall's face is a hit on it.) Negative: no beam is exempt."""
    beam_weight: float = 1.0
    """Exponent on each beam's likelihood (1: beams independent, Table 6.3). Below 1 tempers the
    update for beams that are not independent."""

    def __post_init__(self) -> None:
        checks = {
            "cell_size": self.cell_size > 0,
            "headings": self.headings >= 1,
            "robot_radius": self.robot_radius >= 0,
            "update_min_d": self.update_min_d >= 0,
            "update_min_a": self.update_min_a >= 0,
            "turning_rate": self.turning_rate > 0,
            "threshold": 0 < self.threshold <= 1,
            "mode_radius": self.mode_radius > 0,
            "mode_yaw": self.mode_yaw > 0,
            "max_modes": self.max_modes >= 1,
            "rival_margin": self.rival_margin >= 0,
            "rival_min": 0 < self.rival_min < 1,
            "rival_drop": self.rival_drop >= self.rival_margin,
            "max_rivals": self.max_rivals >= 0,
            "history": self.history >= 1,
            "global_check_every": self.global_check_every >= 1,
            "global_candidates": self.global_candidates >= 1,
            "history_margin": self.history_margin > 0,
            "odometry_drift": True,
            "remembered_sigma": self.remembered_sigma > 0,
            "distinct_updates": self.distinct_updates >= 1,
            "recovery_alpha": 0 <= self.recovery_alpha < 1,
            "beam_weight": 0 < self.beam_weight <= 1,
            "clutter_objects": self.clutter_objects >= 0,
            "clutter_extent": self.clutter_extent >= 0,
            "wall_tolerance": True,
            "negligible": 0 <= self.negligible < 1,
        }
        for name, ok in checks.items():
            value = getattr(self, name)
            finite = all(math.isfinite(v) for v in value) if isinstance(value, tuple) else math.isfinite(value)
            if not ok or not finite:
                raise ValueError(f"FilterConfig.{name}: {value} is out of range")
        if len(self.odometry_drift) != 3 or min(self.odometry_drift) < 0:
            raise ValueError(f"FilterConfig.odometry_drift: {self.odometry_drift} is out of range")


@dataclass(frozen=True)
class FilterMode:
    """One place the filter's belief holds: its best state's (refined, for the first) pose and its mass (the
    discrete models' counterpart is :class:`beliefloc.pose.Mode`)."""

    x: float
    y: float
    yaw: float
    probability: float

    def as_json(self) -> dict[str, float]:
        return {"x": self.x, "y": self.y, "yaw": self.yaw, "probability": self.probability}


@dataclass(frozen=True)
class Update:
    """What one filter update found."""

    stamp: int
    """The scan's header stamp, integer nanoseconds."""
    x: float
    y: float
    yaw: float
    """The refined pose of the belief's best state (map frame)."""
    max_probability: float
    """The mass of the first mode (see :attr:`FilterConfig.mode_radius`)."""
    localized: bool
    fraction: float
    """The inlier fraction of this update's beams at the pose."""
    surprise: float
    """Nats per beam (see :func:`beliefloc.continuous.fit.surprise`)."""
    modes: tuple[FilterMode, ...]
    beams: int
    recovered: bool = False
    """Uniform mass was mixed back in after this update (the scans did not fit a confident belief)."""
    rival_gap: float = math.inf
    """Nats: how much better the best pose explains the scan than the best rival place's (refined),
    clutter-trimmed (:func:`trimmed_gap`); inf with no rival."""
    remembered_gap: float = math.inf
    """Nats: the same over the remembered updates (each rival carried back along the odometry)."""

    def as_json(self) -> dict[str, object]:
        """A timeline entry of ``track --bag --json``."""
        return {
            "stamp": self.stamp,
            "x": self.x,
            "y": self.y,
            "yaw": self.yaw,
            "max_probability": self.max_probability,
            "localized": self.localized,
        }


def trimmed_gap(
    mine: np.ndarray,
    theirs: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    objects: int,
    extent: float,
    fixed: np.ndarray | None = None,
) -> float:
    """How much better one pose explains some beams than another, robust to clutter: ``sum_b
    (mine_b - theirs_b)`` over the beams' log-likelihoods at the two poses (any shape, e.g. scans x
    beams), less what ``objects`` unmapped objects standing where the second pose's map has no wall
    could have made. Greedily: the beam most in the first pose's favour, and every beam in its
    favour whose end point at the second pose (map-frame ``x``, ``y``) lies within ``extent`` metres
    of that beam's, are set aside; then again, ``objects`` times. An object seen in every scan
    of a remembered run is one object: it is set aside in all of them at once. ``fixed`` (optional,
    boolean, the beams' shape): beams no object could have made -- never set aside, nor taken as an
    object's centre."""
    d = (np.asarray(mine, dtype=np.float64) - np.asarray(theirs, dtype=np.float64)).ravel()
    return float(d.sum()) - clutter_share(d, x, y, objects, extent, fixed)


def clutter_share(
    d: np.ndarray, x: np.ndarray, y: np.ndarray, objects: int, extent: float, fixed: np.ndarray | None = None
) -> float:
    """Of the positive entries of ``d`` (beams' log-likelihood differences in one pose's favour), the
    sum that ``objects`` unmapped objects standing at the *other* pose could have made -- beams
    ending (map-frame ``x``, ``y`` at that pose) within ``extent`` of each other, taken greedily
    from the largest (see :func:`trimmed_gap`); ``fixed`` beams are never taken."""
    favour = np.maximum(np.ravel(d), 0.0)
    if fixed is not None:
        favour[np.ravel(fixed)] = 0.0
    ex, ey = np.ravel(x), np.ravel(y)
    share = 0.0
    for _ in range(objects):
        if favour.size == 0:
            break
        b = int(np.argmax(favour))
        if favour[b] <= 0.0:
            break
        near = np.hypot(ex - ex[b], ey - ey[b]) <= extent
        near &= favour > 0.0
        share += float(favour[near].sum())
        favour[near] = 0.0
    return share


class GridFilter:
    """The belief over a map's free cells × headings and its updates."""

    def __init__(self, occupancy: OccupancyMap, config: FilterConfig, *, reach: float) -> None:
        """``reach`` (metres): the farthest beam end point from the base that is scored (the laser's
        maximum range plus its mount offset)."""
        self.config = config
        self.occupancy = occupancy
        free = free_cells(occupancy.blocked(), occupancy.resolution, config.cell_size, config.robot_radius)
        if not free.any():
            raise ValueError(
                f"no cell of {config.cell_size:g} m is a state: the robot's radius {config.robot_radius:g} m fits "
                "nowhere in the map's free space"
            )
        rows = np.flatnonzero(free.any(axis=1))
        cols = np.flatnonzero(free.any(axis=0))
        self.window = CellWindow(
            config.cell_size,
            free.shape[0],
            int(rows[0]),
            int(cols[0]),
            int(rows[-1] - rows[0] + 1),
            int(cols[-1] - cols[0] + 1),
        )
        w = self.window
        self.free = np.ascontiguousarray(free[w.row0 : w.row0 + w.rows, w.col0 : w.col0 + w.cols])
        """``free[r, c]`` over the window: the cell is a state."""
        self.yaws = grid_yaws(config.headings)
        """Heading ``k``'s yaw in the grid frame (the map frame's yaw less the map origin's)."""
        self.field = LikelihoodField(
            OccupancyImage.walls_of(occupancy), w, config.laser, reach, config.headings, sub_poses=config.sub_poses
        )
        gx, gy = w.centres_grid()
        self.cell_x, self.cell_y = occupancy.frame.to_map(gx, gy)
        """Map-frame centres of the window's cells, ``(rows, cols)``."""
        self.map_yaws = wrap_angle(self.yaws + occupancy.frame.yaw)
        """Heading ``k``'s yaw in the map frame."""
        self.belief = self.uniform()
        self.fit = FitTracker(config.fit)
        self.last_odometry: np.ndarray | None = None
        self.updates = 0
        self.distinct_streak = 0.0
        """Updates in a row in which no rival place explained the scan about as well as the best,
        each counted by :meth:`update_weight`."""
        self.told_streak = 0.0
        """Updates in a row in which the remembered scans told the best from every rival
        (:attr:`FilterConfig.history_margin`), each counted by :meth:`update_weight`."""
        self.led_streak = 0.0
        """Updates in a row in which a rival explained the scan better than the best by
        :attr:`FilterConfig.rival_margin` per beam, each counted by :meth:`update_weight`."""
        self._was_localized = False
        self.rivals: list[list[float]] = []
        """Rival places: ``[x, y, yaw, strikes]`` (map frame), carried by the odometry; ``strikes``
        counts the updates in a row in which the scans ruled the place out."""
        self._last_best: tuple[float, float, float] | None = None
        self._history: deque[tuple[np.ndarray, Beams]] = deque(maxlen=config.history)
        self._remembered_beams: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = {}
        """The remembered updates' beams concatenated, per stride (:meth:`_remembered_scores`)."""
        self._steps: tuple[np.ndarray, np.ndarray] | None = None
        """The remembered odometry's steps (:meth:`_remembered_steps`)."""
        self._since_global = math.inf

    @property
    def n_states(self) -> int:
        return int(self.free.sum()) * self.config.headings

    def uniform(self) -> np.ndarray:
        """The uniform belief over the states (``(headings, rows, cols)``)."""
        b = np.broadcast_to(self.free, (self.config.headings, *self.free.shape)).astype(np.float64)
        uniform: np.ndarray = b / b.sum()
        return uniform

    # --- the update ---------------------------------------------------------------------------

    def wants_update(self, odometry: np.ndarray, angular_speed: float) -> bool:
        """Whether a scan at odometry pose ``odometry`` (odom frame) should update the belief."""
        if self.last_odometry is None:
            return True
        c = self.config
        delta = relative(self.last_odometry, np.asarray(odometry, dtype=np.float64))
        return bool(
            math.hypot(delta[0], delta[1]) >= c.update_min_d
            or abs(delta[2]) >= c.update_min_a
            or abs(angular_speed) >= c.turning_rate
        )

    def update_weight(self, odometry: np.ndarray) -> float:
        """How much an update at odometry pose ``odometry`` counts towards the streaks of
        :attr:`FilterConfig.distinct_updates`: 1 for the first update and for one after the odometry
        moved ``update_min_d`` or turned ``update_min_a`` since the last (what gates an update when
        the base is not turning fast), else the larger share of either."""
        c = self.config
        if self.last_odometry is None:
            return 1.0
        delta = relative(self.last_odometry, np.asarray(odometry, dtype=np.float64))
        shares = []
        if c.update_min_d > 0:
            shares.append(math.hypot(delta[0], delta[1]) / c.update_min_d)
        if c.update_min_a > 0:
            shares.append(abs(delta[2]) / c.update_min_a)
        return min(1.0, max(shares)) if shares else 1.0

    def update(self, stamp: int, odometry: np.ndarray, beams: Beams) -> Update:
        """Predict by the odometry since the last update (none for the first) and correct by the
        scan's ``beams``; returns what the updated belief says."""
        c = self.config
        odom = np.asarray(odometry, dtype=np.float64).reshape(3)
        weight = self.update_weight(odom)
        predicted = self.belief
        if self.last_odometry is not None:
            d = relative(self.last_odometry, odom)
            predicted = self._predict((float(d[0]), float(d[1]), float(d[2])))
            if self.rivals:
                moved = compose(np.array([r[:3] for r in self.rivals]), d)
                for rival, pose in zip(self.rivals, moved, strict=True):
                    rival[:3] = [float(v) for v in pose]
            if self._last_best is not None:
                self._last_best = tuple(float(v) for v in compose(np.array([self._last_best]), d)[0])  # type: ignore[assignment]
            if not predicted.sum() > 0:  # everything moved into walls: start over
                predicted = self.uniform()
        self.last_odometry = odom
        box, ll = self._log_likelihood(beams, predicted)
        r0, r1, c0, c1 = box
        inside = predicted[:, r0:r1, c0:c1]
        surprise_per_beam = surprise(inside, ll, beams.count)  # no mass outside the box
        top = float(ll.max())
        posterior = np.zeros_like(predicted)
        posterior[:, r0:r1, c0:c1] = inside * np.exp(ll - top)
        total = float(posterior.sum())
        if not total > 0:  # the readings ruled out every predicted state: keep the readings' verdict
            uniform = self.uniform()
            box, ll = self._log_likelihood(beams, uniform)
            r0, r1, c0, c1 = box
            top = float(ll.max())
            posterior = np.zeros_like(predicted)
            posterior[:, r0:r1, c0:c1] = uniform[:, r0:r1, c0:c1] * np.exp(ll - top)
            total = float(posterior.sum())
        posterior /= total
        if c.negligible > 0:
            posterior[posterior < c.negligible * float(posterior.max())] = 0.0
        self.belief = posterior
        self.updates += 1
        modes = self.modes()
        x, y, yaw = self.refine((modes[0].x, modes[0].y, modes[0].yaw), beams)
        best = FilterMode(x, y, yaw, modes[0].probability)
        modes = (best, *modes[1:])
        previous = self._last_best  # the last update's best, carried by the odometry
        continued = (
            previous is not None
            and math.hypot(best.x - previous[0], best.y - previous[1]) <= c.mode_radius
            and abs(wrap_angle(best.yaw - previous[2])) <= c.mode_yaw
        )
        self._remember_rivals(best, modes[1:])
        self._history.append((odom, beams))
        self._remembered_beams.clear()
        self._steps = None
        self._since_global += 1
        if best.probability >= c.threshold and self._since_global >= c.global_check_every:
            self._search_rivals(best, beams)
            self._since_global = 0
        elif best.probability < c.threshold:
            self._since_global = math.inf
        gap, remembered_gap, raw_gap = self.rival_gap(best, beams)
        if beams.count and gap >= c.rival_margin * beams.count:
            self.distinct_streak += weight
        else:
            self.distinct_streak = 0.0
        if remembered_gap >= c.history_margin * c.history and gap > -c.rival_margin * beams.count:
            self.told_streak += weight
        else:
            self.told_streak = 0.0
        told_apart = self.told_streak >= c.distinct_updates - 1e-9
        distances = self.field.end_point_distances(np.array([best.x, best.y, best.yaw]), beams)
        fraction = inlier_fraction(distances, c.fit.inlier_distance)
        self.fit.add(fraction, surprise_per_beam)
        fits = self.fit.fits()
        if beams.count and gap < -c.rival_margin * beams.count:
            self.led_streak += weight
        else:
            self.led_streak = 0.0
        # A place told apart stays so while the belief follows it: a rival must now do better, not
        # merely as well -- lead on the scans (led_streak) or on the remembered ones.
        held = (
            self._was_localized
            and continued
            and self.led_streak < c.distinct_updates - 1e-9
            and remembered_gap > -c.history_margin * c.history
        )
        distinct = self.distinct_streak >= c.distinct_updates - 1e-9 or told_apart or held
        localized = bool(best.probability >= c.threshold and fits and distinct)
        self._was_localized = localized
        recovered = False
        unfit = best.probability >= c.threshold and not fits and len(self.fit.fractions) >= c.fit.window
        outdone = beams.count > 0 and raw_gap < -c.rival_drop * beams.count  # a rival explains the scan far better
        if (unfit or outdone) and c.recovery_alpha > 0:
            self.belief = (1 - c.recovery_alpha) * self.belief + c.recovery_alpha * self.uniform()
            recovered = True
        return Update(
            stamp=int(stamp),
            x=best.x,
            y=best.y,
            yaw=best.yaw,
            max_probability=best.probability,
            localized=localized,
            fraction=fraction,
            surprise=surprise_per_beam,
            modes=modes,
            beams=beams.count,
            recovered=recovered,
            rival_gap=gap,
            remembered_gap=remembered_gap,
        )

    def _box(self, belief: np.ndarray, margin: int) -> tuple[int, int, int, int]:
        """``(r0, r1, c0, c1)``: the window's rows and columns holding mass, grown by ``margin``."""
        cells: np.ndarray = np.any(belief, axis=0)
        rows = np.flatnonzero(cells.any(axis=1))
        cols = np.flatnonzero(cells.any(axis=0))
        if rows.size == 0:
            return 0, self.free.shape[0], 0, self.free.shape[1]
        return (
            max(0, int(rows[0]) - margin),
            min(self.free.shape[0], int(rows[-1]) + margin + 1),
            max(0, int(cols[0]) - margin),
            min(self.free.shape[1], int(cols[-1]) + margin + 1),
        )

    def _predict(self, delta: tuple[float, float, float]) -> np.ndarray:
        """:func:`predict_grid` over the box of states holding mass, grown by the motion's reach."""
        c = self.config
        parts = odometry_parts(delta, c.odometry)
        reach = parts.trans + 5.0 * (parts.sd_trans + parts.trans * parts.sd_rot1)
        margin = math.ceil(reach / c.cell_size) + 3
        r0, r1, c0, c1 = self._box(self.belief, margin)
        out = np.zeros_like(self.belief)
        out[:, r0:r1, c0:c1] = predict_grid(
            self.belief[:, r0:r1, c0:c1], self.yaws, c.cell_size, delta, c.odometry, self.free[r0:r1, c0:c1]
        )
        return out

    def _log_likelihood(self, beams: Beams, predicted: np.ndarray) -> tuple[tuple[int, int, int, int], np.ndarray]:
        """``(box, ll)``: the box ``(r0, r1, c0, c1)`` of the window's cells where the predicted belief
        holds mass, and the scan's log-likelihood (times ``beam_weight``) over its states, ``-inf``
        on headings without mass and on cells that are not states. Shape ``(headings, r1-r0, c1-c0)``."""
        c = self.config
        r0, r1, c0, c1 = self._box(predicted, 0)
        active: np.ndarray = np.any(predicted.reshape(predicted.shape[0], -1), axis=1)
        ll = self.field.scan_log_likelihood(beams, self.yaws, active=active, region=(r0, r1, c0, c1)).astype(np.float64)
        if c.beam_weight != 1.0:
            ll *= c.beam_weight
        ll[~active] = -np.inf
        ll[:, ~self.free[r0:r1, c0:c1]] = -np.inf
        return (r0, r1, c0, c1), ll

    # --- reading the belief ----------------------------------------------------------------------

    def modes(self) -> tuple[FilterMode, ...]:
        """The belief's modes, most probable first: each the best state left (its cell centre and
        heading yaw), and the mass within :attr:`FilterConfig.mode_radius` and
        :attr:`FilterConfig.mode_yaw` of it (then removed); until a mode holds less than 1 %."""
        c = self.config
        rest = self.belief.copy()
        headings = c.headings
        reach = math.ceil(c.mode_radius / c.cell_size)
        dr, dc = np.mgrid[-reach : reach + 1, -reach : reach + 1]
        disk = np.hypot(dr, dc) * c.cell_size <= c.mode_radius
        sector = 2 * math.pi / headings
        yaw_reach = min(headings // 2, math.floor(c.mode_yaw / sector + 1e-9))
        found: list[FilterMode] = []
        rows, cols = self.free.shape
        for _ in range(c.max_modes):
            k, r, col = (int(v) for v in np.unravel_index(int(np.argmax(rest)), rest.shape))
            if rest[k, r, col] <= 0:
                break
            ks = np.arange(k - yaw_reach, k + yaw_reach + 1) % headings
            ks = np.unique(ks)
            r0, r1 = max(0, r - reach), min(rows, r + reach + 1)
            c0, c1 = max(0, col - reach), min(cols, col + reach + 1)
            mask = disk[r0 - r + reach : r1 - r + reach, c0 - col + reach : c1 - col + reach]
            patch = rest[ks, r0:r1, c0:c1]
            mass = float((patch * mask).sum())
            rest[ks, r0:r1, c0:c1] = patch * ~mask
            pose = self.state_pose(int(k), int(r), int(col))
            found.append(FilterMode(pose[0], pose[1], pose[2], mass))
            if mass < 0.01 and found:
                break
        return tuple(found)

    def _remember_rivals(self, best: FilterMode, others: tuple[FilterMode, ...]) -> None:
        """Add as rivals the modes holding at least ``rival_min`` and the former best, when they lie
        beyond ``mode_radius`` of the best and of every rival already carried."""
        c = self.config
        candidates = [(m.x, m.y, m.yaw) for m in others if m.probability >= c.rival_min]
        if self._last_best is not None:
            candidates.append(self._last_best)
        self._last_best = (best.x, best.y, best.yaw)
        for x, y, yaw in candidates:
            if math.hypot(x - best.x, y - best.y) <= c.mode_radius:
                continue
            if any(math.hypot(x - r[0], y - r[1]) <= c.mode_radius for r in self.rivals):
                continue
            self.rivals.append([x, y, yaw, 0.0])

    def _search_rivals(self, best: FilterMode, beams: Beams) -> None:
        """The global rival search (:attr:`FilterConfig.history`): score every state against the
        scan, take the :attr:`FilterConfig.global_candidates` best places beyond ``mode_radius`` of
        ``best`` (by suppression, as :meth:`modes`), refine them, and add as rivals those the
        remembered scans do not rule out."""
        c = self.config
        if beams.count == 0:
            return
        ll = self.field.scan_log_likelihood(beams, self.yaws)
        ll[:, ~self.free] = -np.inf
        far = np.hypot(self.cell_x - best.x, self.cell_y - best.y) > c.mode_radius
        ll[:, ~far] = -np.inf
        reach = math.ceil(c.mode_radius / c.cell_size)
        rows, cols = self.free.shape
        candidates = []
        for _ in range(c.global_candidates):
            k, r, col = (int(v) for v in np.unravel_index(int(np.argmax(ll)), ll.shape))
            if not np.isfinite(ll[k, r, col]):
                break
            candidates.append(self.state_pose(k, r, col))
            ll[
                :, max(0, r - reach) : min(rows, r + reach + 1), max(0, col - reach) : min(cols, col + reach + 1)
            ] = -np.inf
        if not candidates:
            return
        mine = self._history_beams((best.x, best.y, best.yaw))[0]
        total_beams = sum(b.count for _, b in self._history)
        refined_all = [self.refine(pose, beams) for pose in candidates]
        refined_all = [p for p in refined_all if math.hypot(p[0] - best.x, p[1] - best.y) > c.mode_radius]
        past = [self._history_beams(p) for p in refined_all]
        fixed = self._walled_all([(mine, theirs, ox, oy, x, y) for theirs, x, y, ox, oy in past])
        for refined, (theirs, x, y, _, _), kept in zip(refined_all, past, fixed, strict=True):
            if trimmed_gap(mine, theirs, x, y, c.clutter_objects, c.clutter_extent, kept) > c.rival_drop * total_beams:
                continue  # the remembered scans rule it out
            if any(math.hypot(refined[0] - r[0], refined[1] - r[1]) <= c.mode_radius for r in self.rivals):
                continue
            self.rivals.append([refined[0], refined[1], refined[2], 0.0])

    def _history_beams(
        self, pose: tuple[float, float, float]
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(ll, x, y, ox, oy)``: the remembered scans' beam log-likelihoods, map-frame end points
        and the base's map-frame position at each beam's scan, for the robot near ``pose`` now,
        carried back along the odometry to each remembered update -- the pose and the odometry's
        drift those that explain the remembered scans best (:meth:`_history_fit`; the scans'
        beams concatenated)."""
        if not self._history:
            return np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0)
        backs = self._carried_back(pose, self._history_fit(pose)[None, :])[0]
        counts = [beams.count for _, beams in self._history]
        ll, x, y = self._remembered_scores(backs[None])
        ox, oy = np.repeat(backs[:, 0], counts), np.repeat(backs[:, 1], counts)
        return ll[0], x[0], y[0], ox, oy

    def _carried_back(self, pose: tuple[float, float, float], fits: np.ndarray) -> np.ndarray:
        """``(D, H, 3)``: the robot carried back from now along the odometry to each of the ``H``
        remembered updates, for each of ``D`` fits ``(s, t, e, dx, dy, dyaw)``: now at ``pose``
        moved by ``(dx, dy, dyaw)`` (map frame), each odometry step ``(x, y, yaw)`` between
        remembered updates taken as ``((1 + s) x, (1 + s) y, (1 + t) yaw + e |(x, y)|)``."""
        steps, length = self._remembered_steps()
        f = np.asarray(fits, dtype=np.float64).reshape(-1, 1, 6)
        turns = steps[:, 2] * (1 + f[..., 1]) + f[..., 2] * length  # (D, H-1)
        # The remembered odometry poses rebuilt from the drifted steps, in the oldest one's frame:
        # yaws by a cumulative sum, positions by summing each step turned by the yaw before it.
        yaw = np.concatenate([np.zeros((f.shape[0], 1)), np.cumsum(turns, axis=1)], axis=1)  # (D, H)
        c, s = np.cos(yaw[:, :-1]), np.sin(yaw[:, :-1])
        dx, dy = steps[:, 0] * (1 + f[..., 0]), steps[:, 1] * (1 + f[..., 0])
        zero = np.zeros((f.shape[0], 1))
        x = np.concatenate([zero, np.cumsum(c * dx - s * dy, axis=1)], axis=1)
        y = np.concatenate([zero, np.cumsum(s * dx + c * dy, axis=1)], axis=1)
        rebuilt = np.stack([x, y, yaw], axis=-1)  # (D, H, 3)
        back = relative(rebuilt[:, -1:, :], rebuilt)  # each remembered pose seen from the last
        px, py, pyaw = (np.asarray(pose, dtype=np.float64)[None, None, :] + f[..., 3:]).transpose(2, 0, 1)
        cp, sp = np.cos(pyaw), np.sin(pyaw)
        out = np.empty_like(back)
        out[..., 0] = px + cp * back[..., 0] - sp * back[..., 1]
        out[..., 1] = py + sp * back[..., 0] + cp * back[..., 1]
        out[..., 2] = wrap_angle(pyaw + back[..., 2])
        return out

    def _remembered_steps(self) -> tuple[np.ndarray, np.ndarray]:
        """``(steps, length)``: the odometry's step from each remembered update to the next
        ``(H-1, 3)`` and its distance ``(H-1,)``, kept until the next update."""
        if self._steps is None:
            odoms = np.array([odom for odom, _ in self._history])
            steps = relative(odoms[:-1], odoms[1:])
            self._steps = steps, np.hypot(steps[:, 0], steps[:, 1])
        return self._steps

    def _remembered_scores(
        self, backs: np.ndarray, stride: int = 1, *, coarse: bool = False
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(ll, x, y)``, each ``(P, beams)``: the log-likelihoods (:attr:`FilterConfig.remembered_sigma`)
        and map-frame end points of the remembered updates' beams (every ``stride``-th of each
        scan) for the base at ``backs`` ``(P, H, 3)``; ``coarse``: read at the nearest pixel
        (:meth:`LikelihoodField.nearest_log_likelihood`)."""
        if stride not in self._remembered_beams:
            history = self._history
            counts = [beams.x[::stride].size for _, beams in history]
            self._remembered_beams[stride] = (
                np.concatenate([beams.x[::stride] for _, beams in history]),
                np.concatenate([beams.y[::stride] for _, beams in history]),
                np.repeat(np.arange(len(history)), counts),
                np.repeat([beams.range_max for _, beams in history], counts),
            )
        bx, by, which, range_max = self._remembered_beams[stride]
        c, s = np.cos(backs[..., 2])[:, which], np.sin(backs[..., 2])[:, which]
        x = backs[..., 0][:, which] + c * bx - s * by
        y = backs[..., 1][:, which] + s * bx + c * by
        score = self.field.nearest_log_likelihood if coarse else self.field.point_log_likelihood
        sd = self.config.remembered_sigma
        first = float(range_max[0]) if range_max.size else 0.0
        if range_max.size and bool((range_max == first).all()):  # one range_max, as a rule
            return score(x, y, sd, first), x, y
        ll = np.empty(x.shape)
        for value in np.unique(range_max):
            same = range_max == value
            ll[:, same] = score(x[:, same], y[:, same], sd, float(value))
        return ll, x, y

    def _history_fit(self, pose: tuple[float, float, float]) -> np.ndarray:
        """``(s, t, e, dx, dy, dyaw)`` (:meth:`_carried_back`): the odometry drift within
        :attr:`FilterConfig.odometry_drift` and the move of ``pose`` within a cell and 2° under which
        the remembered scans fit best. ``pose`` was refined on the current scan alone, which in a
        corridor barely says where along it; each place compared gets its own best fit. A
        coordinate search on every other beam, each parameter over 7 values across its range (none
        first: ties keep the odometry as measured), then over 5 values a third as wide around the
        best, twice, the end points read at the nearest pixel; then :meth:`_polished_fit`."""
        c = self.config
        best = np.zeros(6)
        if len(self._history) < 2:
            return best
        steps, length = self._remembered_steps()
        driven, turned = float(length.sum()), float(np.abs(steps[:, 2]).sum())
        drift = np.asarray(c.odometry_drift, dtype=np.float64)
        # A drift whose whole range moves the oldest pose by less than 5 mm or 0.1° is left alone.
        drift = drift * (np.array([driven, turned, driven]) * drift > np.array([0.005, 0.002, 0.002]))
        bounds = np.concatenate([drift, [c.cell_size, c.cell_size, math.radians(2.0)]])
        # Each stage: the yaw per metre and the yaw now together (they trade off: both turn the
        # oldest scans), then each other parameter alone; each stage a third as wide as the last.
        groups = ((2, 5), (0,), (1,), (3,), (4,))
        score = -math.inf
        for stage in range(3):
            width = 3.0**-stage
            for group in groups:
                axes = [a for a in group if bounds[a] > 0]
                if not axes:
                    continue
                grids = []
                for a in axes:
                    values = best[a] + np.linspace(-1, 1, 7 if stage == 0 else 5) * width * bounds[a]
                    values = values[np.abs(values) <= bounds[a] + 1e-12]
                    grids.append(values[np.argsort(np.abs(values - best[a]), kind="stable")])  # the current first
                mesh = np.meshgrid(*grids, indexing="ij")
                fits = np.repeat(best[None, :], mesh[0].size, axis=0)
                for a, values in zip(axes, mesh, strict=True):
                    fits[:, a] = values.ravel()
                backs = self._carried_back(pose, fits)
                totals = self._remembered_scores(backs, stride=2, coarse=True)[0].sum(axis=1)
                k = int(np.argmax(totals))
                if totals[k] > score:
                    score = float(totals[k])
                    best = fits[k]
        return self._polished_fit(pose, best, bounds)

    def _polished_fit(self, pose: tuple[float, float, float], start: np.ndarray, bounds: np.ndarray) -> np.ndarray:
        """``start`` (:meth:`_history_fit`'s coarse search) refined by a few Gauss-Newton steps
        (SciPy's bounded trust-region least squares) on every other remembered beam, read
        bilinearly: each beam's residual ``sqrt(2 (log p_max - log p))`` (squares that sum to the
        log-likelihood's shortfall, ``d / sigma`` near a wall). A grid search's last step is a
        fraction of the range; on a corridor the remembered scans' fit still moved by 30-120 nats
        within it, as much as places 4 m apart differ, and ranked look-alikes by where the grid's
        points fell (issue 27's corridor seed 103)."""
        free = bounds > 0
        if not free.any():
            return start
        scale = bounds[free]
        _, _, _, range_max = self._remembered_beams[2]
        model = self.field.model
        top = np.log(model.z_hit + model.z_rand / range_max)

        step = 1e-3  # of each parameter's range: a forward difference

        def residuals_at(zs: np.ndarray) -> np.ndarray:
            fits = np.repeat(start[None, :], zs.shape[0], axis=0)
            fits[:, free] = zs * scale
            ll = self._remembered_scores(self._carried_back(pose, fits), stride=2)[0]
            out: np.ndarray = np.sqrt(np.maximum(2.0 * (top - ll), 0.0))
            return out

        def jacobian(z: np.ndarray) -> np.ndarray:
            # the differences all in one batch of fits: one carry-back and one field read
            zs = np.vstack([z, z + step * np.eye(z.size)])
            r = residuals_at(zs)
            out: np.ndarray = ((r[1:] - r[0]) / step).T
            return out

        def residuals(z: np.ndarray) -> np.ndarray:
            out: np.ndarray = residuals_at(z[None, :])[0]
            return out

        z0 = np.clip(start[free] / scale, -1.0, 1.0)
        solved = optimize.least_squares(residuals, z0, jac=jacobian, bounds=(-1.0, 1.0), method="trf", max_nfev=12)
        best = start.copy()
        best[free] = solved.x * scale
        return best

    def _walled(
        self, mine: np.ndarray, theirs: np.ndarray, ox: np.ndarray, oy: np.ndarray, x: np.ndarray, y: np.ndarray
    ) -> np.ndarray | None:
        """The beams in the first pose's favour (``mine > theirs``) that with the robot at the second
        pose -- its base at ``(ox, oy)``, the beams ending at ``(x, y)`` -- would have passed through
        one of its map's walls more than :attr:`FilterConfig.wall_tolerance` before their end point.
        An unmapped object can only stop a beam short; none can carry it through a wall, so what
        these beams say against the second pose is evidence no clutter made (:func:`trimmed_gap`'s
        ``fixed``). None when the tolerance is negative (no beam exempt)."""
        return self._walled_all([(mine, theirs, ox, oy, x, y)])[0]

    def _walled_all(
        self, groups: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]]
    ) -> list[np.ndarray | None]:
        """:meth:`_walled` of several ``(mine, theirs, ox, oy, x, y)`` at once: one ray cast for all
        their beams (a cast's cost is mostly per step along the longest ray, not per ray)."""
        tol = self.config.wall_tolerance
        if tol < 0 or not groups:
            return [None] * len(groups)
        starts, xs, ys, ends_x, ends_y, picks = [], [], [], [], [], []
        for mine, theirs, ox, oy, x, y in groups:
            favoured = np.flatnonzero(np.ravel(mine) > np.ravel(theirs))
            picks.append(favoured)
            xs.append(np.ravel(ox)[favoured])
            ys.append(np.ravel(oy)[favoured])
            ends_x.append(np.ravel(x)[favoured])
            ends_y.append(np.ravel(y)[favoured])
            starts.append(favoured.size)
        bx, by = np.concatenate(xs), np.concatenate(ys)
        dx, dy = np.concatenate(ends_x) - bx, np.concatenate(ends_y) - by
        reach = np.hypot(dx, dy) - tol
        crossed = np.zeros(bx.size, dtype=bool)
        if bx.size:
            stopped = cast_rays_within(self.field.image, bx, by, np.arctan2(dy, dx), reach)
            crossed = np.isfinite(stopped) & (reach > 0)
        out: list[np.ndarray | None] = []
        offset = 0
        for (mine, _, _, _, _, _), favoured, count in zip(groups, picks, starts, strict=True):
            mask = np.zeros(np.size(mine), dtype=bool)
            mask[favoured] = crossed[offset : offset + count]
            offset += count
            out.append(mask)
        return out

    def rival_gap(self, best: FilterMode, beams: Beams) -> tuple[float, float, float]:
        """``(now, remembered, raw)``: ``min`` over the rivals farther than ``mode_radius`` from
        ``best`` of how much better ``best``'s pose explains the scan than the rival's refined pose,
        clutter-trimmed (:func:`trimmed_gap`, the beams :meth:`_walled` kept); of the same over the
        remembered updates (:meth:`_history_beams`, each rival carried back along the odometry); and
        of the plain difference of the scan's log-likelihoods. inf with no rival. Refines every
        rival's pose in place, forgets rivals the scans have ruled out (:attr:`FilterConfig.rival_drop`,
        trimmed too) and keeps the :attr:`FilterConfig.max_rivals` closest."""
        if beams.count == 0:
            return math.inf, math.inf, math.inf
        c = self.config
        best_pose = np.array([[best.x, best.y, best.yaw]])
        mine = self.field.beam_log_likelihoods(best_pose, beams)[0]
        mine_x, mine_y = (v[0] for v in self.field.end_points(best_pose, beams))
        mine_remembered, mx, my, mox, moy = self._history_beams((best.x, best.y, best.yaw))
        kept: list[tuple[float, list[float]]] = []
        gap = remembered = raw = math.inf
        rivals = []  # (refined pose, strikes so far), beyond mode_radius of the best (else the best's own place)
        for rival in self.rivals:
            pose = self.refine((rival[0], rival[1], rival[2]), beams)
            if math.hypot(pose[0] - best.x, pose[1] - best.y) > c.mode_radius:
                rivals.append((pose, rival[3]))
        now = [self.field.beam_log_likelihoods(np.array([p]), beams)[0] for p, _ in rivals]
        ends = [self.field.end_points(np.array([p]), beams) for p, _ in rivals]
        past = [self._history_beams(p) for p, _ in rivals]
        n = beams.count
        here_x, here_y = np.full(n, best.x), np.full(n, best.y)
        # Beams in the best's favour no object at the rival could have made, and (the other way)
        # beams in the rival's favour no object at the best could have made.
        fixed = self._walled_all(
            [
                (mine, theirs, np.full(n, p[0]), np.full(n, p[1]), x, y)
                for (p, _), theirs, (x, y) in zip(rivals, now, ends, strict=True)
            ]
            + [(mine_remembered, theirs, ox, oy, x, y) for theirs, x, y, ox, oy in past]
            + [(theirs, mine, here_x, here_y, mine_x, mine_y) for theirs in now]
            + [(theirs, mine_remembered, mox, moy, mx, my) for theirs, *_ in past]
        )
        m = len(rivals)
        for i, ((pose, strikes), theirs, (x, y), (h_theirs, hx, hy, _, _)) in enumerate(
            zip(rivals, now, ends, past, strict=True)
        ):
            difference = trimmed_gap(mine, theirs, x, y, c.clutter_objects, c.clutter_extent, fixed[i])
            strikes = strikes + 1 if difference > c.rival_drop * n else 0.0
            if strikes >= c.distinct_updates:
                continue  # ruled out by the scans
            # The verdict's gap allows clutter at both places: what objects at the best place could
            # have made in the rival's favour is set aside too.
            own = clutter_share(theirs - mine, mine_x, mine_y, c.clutter_objects, c.clutter_extent, fixed[2 * m + i])
            gap = min(gap, difference + own)
            raw = min(raw, float(mine.sum() - theirs.sum()))
            h_difference = trimmed_gap(
                mine_remembered, h_theirs, hx, hy, c.clutter_objects, c.clutter_extent, fixed[m + i]
            )
            h_own = clutter_share(
                h_theirs - mine_remembered, mx, my, c.clutter_objects, c.clutter_extent, fixed[3 * m + i]
            )
            remembered = min(remembered, h_difference + h_own)
            kept.append((difference, [pose[0], pose[1], pose[2], strikes]))
        kept.sort(key=lambda item: item[0])
        self.rivals = [r for _, r in kept[: c.max_rivals]]
        return gap, remembered, raw

    def state_pose(self, k: int, r: int, c: int) -> tuple[float, float, float]:
        """Map-frame pose of window state ``(k, r, c)``: its cell's centre and heading's yaw."""
        return float(self.cell_x[r, c]), float(self.cell_y[r, c]), float(self.map_yaws[k])

    def refine(self, start: tuple[float, float, float], beams: Beams, rounds: int = 4) -> tuple[float, float, float]:
        """A pose finer than a cell: from ``start`` (a state's pose), a local search over continuous
        ``(x, y, yaw)`` -- a 5 x 5 x 7 lattice spanning a cell and a heading sector either side,
        then three times again at 0.4 of the span around the best (a final step of 3 mm and 0.2°)
        -- maximising the scan's log-likelihood with ``sigma_hit``
        (:meth:`LikelihoodField.pose_log_likelihood`)."""
        if beams.count == 0:
            return start
        c = self.config
        best = np.array(start, dtype=np.float64)
        span_xy, span_yaw = c.cell_size, 2 * math.pi / c.headings
        for _ in range(rounds):
            ox = np.linspace(-span_xy, span_xy, 5)
            oyaw = np.linspace(-span_yaw, span_yaw, 7)
            gx, gy, gyaw = np.meshgrid(ox, ox, oyaw, indexing="ij")
            poses = np.stack([best[0] + gx.ravel(), best[1] + gy.ravel(), best[2] + gyaw.ravel()], axis=1)
            scores = self.field.pose_log_likelihood(poses, beams)
            best = poses[int(np.argmax(scores))]
            span_xy *= 0.4
            span_yaw *= 0.4
        return float(best[0]), float(best[1]), float(wrap_angle(best[2]))

    def covariance(self, pose: tuple[float, float, float] | None = None) -> np.ndarray:
        """The belief's 6x6 ROS covariance over ``(x, y, z, rot_x, rot_y, rot_z)``: between the states
        (about the belief's mean; the yaw circular) plus within one (``cell²/12`` per axis,
        ``sector²/12`` for the yaw), as :func:`beliefloc.pose.belief_pose` computes it."""
        c = self.config
        b = self.belief
        cell_mass = b.sum(axis=0)
        heading_mass = b.sum(axis=(1, 2))
        x, y = self.cell_x, self.cell_y
        mx, my = float((cell_mass * x).sum()), float((cell_mass * y).sum())
        dx, dy = x - mx, y - my
        cov = np.zeros((6, 6))
        cell_var = c.cell_size**2 / 12.0
        cov[0, 0] = float((cell_mass * dx * dx).sum()) + cell_var
        cov[1, 1] = float((cell_mass * dy * dy).sum()) + cell_var
        cov[0, 1] = cov[1, 0] = float((cell_mass * dx * dy).sum())
        s, co = float(heading_mass @ np.sin(self.map_yaws)), float(heading_mass @ np.cos(self.map_yaws))
        centre = math.atan2(s, co) if math.hypot(s, co) > 1e-9 else (pose[2] if pose else 0.0)
        dyaw = wrap_angle(self.map_yaws - centre)
        cov[5, 5] = float(heading_mass @ (dyaw * dyaw)) + (2 * math.pi / c.headings) ** 2 / 12.0
        per_heading_x = (b * dx[None]).sum(axis=(1, 2))
        per_heading_y = (b * dy[None]).sum(axis=(1, 2))
        cov[0, 5] = cov[5, 0] = float(per_heading_x @ dyaw)
        cov[1, 5] = cov[5, 1] = float(per_heading_y @ dyaw)
        return cov
