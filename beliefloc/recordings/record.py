"""Writing a localization run as a ROS 2 recording (MCAP) that Foxglove, RViz and ``ros2 bag`` open.

``track MAP --bag RUN --record OUT`` and ``simulate MAP --record OUT.mcap`` write, as ROS 2 messages
(:mod:`beliefloc.ros.messages`, serialized with ``rosbags``, rosbag2 metadata version 8):

- ``/map`` ``nav_msgs/msg/OccupancyGrid``: the map, once, QoS transient local;
- ``/scan`` ``sensor_msgs/msg/LaserScan``: the laser's readings (see the recorders);
- ``/odom`` ``nav_msgs/msg/Odometry``: the base's pose in ``odom``;
- ``/tf``, ``/tf_static`` ``tf2_msgs/msg/TFMessage``: the frames (see the recorders);
- ``/beliefloc/belief`` ``geometry_msgs/msg/PoseArray``: the likely states, most likely first;
- ``/beliefloc/belief_cells`` ``visualization_msgs/msg/MarkerArray``: the cells shaded by probability;
- ``/beliefloc/pose`` ``geometry_msgs/msg/PoseWithCovarianceStamped``: the belief as a pose.

(A ROS 2 topic has one type, so the PoseArray and the MarkerArray of the belief are two topics.)

**Where it is written.** ``OUT.mcap`` is one MCAP file (it holds the rosbag2 metadata too, so
``ros2 bag play OUT.mcap`` plays it; older Humble releases need ``-s mcap``); any other ``OUT`` is a rosbag2
folder (``OUT/metadata.yaml`` and ``OUT/OUT.mcap``). The recording is built in a temporary folder
beside ``OUT`` and renamed into place when whole: an error or Ctrl-C leaves nothing.

**The map** (:func:`map_from_occupancy`, :func:`map_from_grid`): a map with an occupancy image
gives its pixels as beliefloc reads them (free 0, occupied 100, unknown -1; the saver's unknown
grey is unknown by the default rule), at the image's resolution and origin; a hand-written grid
gives one cell per grid cell (free 0, blocked 100) inside a border of occupied cells for the grid's
edge, which is a wall to moves and scans. Its QoS is transient local (depth 1, reliable), as Nav2's
map server offers it, so that a player re-publishes it latched and RViz's Map display shows it.

**The belief** (:func:`belief_messages`): the PoseArray holds the states whose probability is at
least :data:`LIKELY_SHARE` of the most likely one's, most likely first -- up to :data:`MAX_POSES`;
when more qualify, a stratified sample of them by probability (:func:`likely_states`), so a flat
belief shows spread over the map (each state's pose: its cell's centre and its heading's yaw). The
marker is one ``CUBE_LIST`` (namespace ``belief``, id 0, replaced at every update): a flat orange
square per cell whose mass (summed over headings) is at least :data:`SHADE_SHARE` of the largest
cell's, its opacity the cell's mass over the largest; when more than :data:`MAX_CELLS` cells
qualify, squares of 2 x 2, 4 x 4... cells, each with their summed mass (:func:`shading`), so the
whole belief is drawn, more coarsely. The pose is :func:`beliefloc.pose.belief_pose` (a grid
model) or the grid filter's refined pose and covariance (``track --bag``).

The message bodies come from pure functions (:func:`map_from_occupancy`, :func:`belief_messages`,
...); :class:`RecordingWriter` and :func:`open_recording` write them; :class:`TrackRecorder`
(``track --bag``) and :class:`EpisodeRecorder` (``simulate``) follow a run and say what each topic
holds there. docs/ros-recordings.md is the user's page.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from beliefloc.continuous.motion import compose, relative
from beliefloc.errors import OutputError
from beliefloc.model import GridLayout
from beliefloc.pose import Pose, belief_pose, state_pose
from beliefloc.ros import messages as ros
from beliefloc.semantic_map.occupancy_map import Occupancy, OccupancyMap

if TYPE_CHECKING:
    from beliefloc.continuous.grid_filter import GridFilter, Update
    from beliefloc.model import Model
    from beliefloc.recordings.reader import Recording
    from beliefloc.recordings.replay import TrackResult
    from beliefloc.semantic_map import SemanticMap
    from beliefloc.simulation.episode import EpisodeRecord, StepRecord

MCAP_SUFFIX = ".mcap"
"""An output named so is one MCAP file; any other name is a rosbag2 folder."""
MAP_TOPIC = "/map"
SCAN_TOPIC = "/scan"
ODOM_TOPIC = "/odom"
TF_TOPIC = "/tf"
TF_STATIC_TOPIC = "/tf_static"
BELIEF_TOPIC = "/beliefloc/belief"
BELIEF_CELLS_TOPIC = "/beliefloc/belief_cells"
POSE_TOPIC = "/beliefloc/pose"
MAP_FRAME, ODOM_FRAME, BASE_FRAME = "map", "odom", "base_link"

OCCUPANCY_GRID = "nav_msgs/msg/OccupancyGrid"
LASER_SCAN = "sensor_msgs/msg/LaserScan"
ODOMETRY = "nav_msgs/msg/Odometry"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"
POSE_ARRAY = "geometry_msgs/msg/PoseArray"
MARKER_ARRAY = "visualization_msgs/msg/MarkerArray"
POSE_WITH_COVARIANCE = "geometry_msgs/msg/PoseWithCovarianceStamped"

LATCHED_TOPICS = (MAP_TOPIC, TF_STATIC_TOPIC)
"""Offered with transient-local durability (latched), as Nav2's map server and tf2's static
broadcaster offer them."""
MAX_POSES = 200
"""The most states in a ``/beliefloc/belief`` PoseArray."""
SAMPLE_SEED = 0
"""Seeds the stratified sample of :func:`likely_states` (a recording is the same for the same run)."""
LIKELY_SHARE = 0.01
"""A state is in the PoseArray when its probability is at least this share of the largest."""
MAX_CELLS = 2500
"""The most squares in the belief's marker (a Python object per square: about 0.1 s per update at
this size); more qualifying cells are drawn as blocks of cells (:func:`shading`)."""
SHADE_SHARE = 1e-3
"""A cell is drawn when its mass is at least this share of the largest cell's (fainter is invisible)."""
BELIEF_COLOUR = (1.0, 0.45, 0.0)
"""The cells' colour (orange); the opacity is the cell's mass over the largest cell's."""


# --- message bodies ----------------------------------------------------------------------------------


def _occupancy_values(classes: np.ndarray) -> np.ndarray:
    """:class:`Occupancy` classes -> ``OccupancyGrid`` values (free 0, occupied 100, unknown -1), int8."""
    values = np.full(classes.shape, -1, dtype=np.int8)
    values[classes == Occupancy.FREE] = 0
    values[classes == Occupancy.OCCUPIED] = 100
    return values


def map_from_occupancy(occupancy: OccupancyMap, ns: int = 0) -> ros.Message:
    """``/map`` from an occupancy image: a cell per pixel, as beliefloc reads it, rows flipped
    (the image's top row is the grid's last)."""
    data = _occupancy_values(occupancy.pixels)[::-1].ravel()
    f = occupancy.frame
    return ros.occupancy_grid(
        occupancy.resolution, occupancy.width, occupancy.height, Pose(f.x, f.y, f.yaw), data, ns=ns
    )


def map_from_grid(grid: GridLayout, ns: int = 0) -> ros.Message:
    """``/map`` from a hand-written grid: a cell per grid cell (free 0, blocked 100) inside a
    one-cell border of occupied cells (the grid's edge is a wall); the origin is the border's
    lower-left corner, one cell outside the grid's."""
    cells = np.full((grid.rows + 2, grid.cols + 2), 100, dtype=np.int8)
    cells[1:-1, 1:-1] = np.where(grid.free, 0, 100)
    s = grid.cell_size
    x, y = grid.frame.to_map(-s, -s)
    origin = Pose(float(x), float(y), grid.frame.yaw)
    return ros.occupancy_grid(s, grid.cols + 2, grid.rows + 2, origin, cells[::-1].ravel(), ns=ns)


@dataclass(frozen=True)
class BeliefStates:
    """A belief laid out for drawing: every state's pose and probability, every cell's centre and mass."""

    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    probability: np.ndarray
    """``(N,)`` over the states (map frame)."""
    cell_x: np.ndarray
    cell_y: np.ndarray
    cell_mass: np.ndarray
    """``(M,)`` over the cells: the states' mass summed over headings."""
    cell_size: float


def grid_belief_states(grid: GridLayout, belief: np.ndarray) -> BeliefStates:
    """A grid model's belief (``belief[i]`` over its states: free cells row-major, times headings)."""
    b = np.asarray(belief, dtype=np.float64)
    rows, cols = np.divmod(grid.free_cells, grid.cols)
    cx, cy = grid.cell_centre(rows, cols)
    state = np.arange(b.size)
    row, col, heading = grid.cell_heading(state)
    x, y = grid.cell_centre(row, col)
    return BeliefStates(
        x, y, grid.heading_yaw(heading), b, cx, cy, b.reshape(-1, grid.headings).sum(axis=1), grid.cell_size
    )


def filter_belief_states(
    belief: np.ndarray, cell_x: np.ndarray, cell_y: np.ndarray, yaws: np.ndarray, cell_size: float
) -> BeliefStates:
    """A grid filter's belief ``belief[k, r, c]`` (heading ``k``, window cell ``(r, c)``), with the
    cells' map-frame centres ``cell_x[r, c]``, ``cell_y[r, c]`` and the headings' yaws ``yaws[k]``.
    Only the states with mass are kept."""
    k, r, c = np.nonzero(belief)
    cell_mass = belief.sum(axis=0)
    cr, cc = np.nonzero(cell_mass)
    return BeliefStates(
        cell_x[r, c],
        cell_y[r, c],
        yaws[k],
        belief[k, r, c],
        cell_x[cr, cc],
        cell_y[cr, cc],
        cell_mass[cr, cc],
        cell_size,
    )


def likely_states(probability: np.ndarray, share: float = LIKELY_SHARE, limit: int = MAX_POSES) -> np.ndarray:
    """Indices of the states whose probability is at least ``share`` of the largest, most probable
    first (ties in index order). When more than ``limit`` qualify, a stratified sample of them by
    probability, as a particle filter resamples (each state once; the strata's offsets drawn from a
    generator seeded :data:`SAMPLE_SEED`, so the same belief gives the same poses): a flat belief
    then shows spread over every place it holds, not the first ``limit`` states of one corner."""
    p = np.asarray(probability, dtype=np.float64)
    if p.size == 0 or not float(p.max()) > 0:
        return np.zeros(0, dtype=np.int64)
    kept = np.flatnonzero(p >= share * float(p.max()))
    if kept.size > limit:
        cumulative = np.cumsum(p[kept])
        jitter = np.random.default_rng(SAMPLE_SEED).random(limit)  # stratified: no aliasing with the lattice
        marks = (np.arange(limit) + jitter) * (cumulative[-1] / limit)
        kept = np.unique(kept[np.minimum(np.searchsorted(cumulative, marks), kept.size - 1)])
    order: np.ndarray = kept[np.argsort(-p[kept], kind="stable")]
    return order


@dataclass(frozen=True)
class Shading:
    """The squares of the belief's marker: centres, side and mass (the largest first)."""

    x: np.ndarray
    y: np.ndarray
    mass: np.ndarray
    side: float


def shading(states: BeliefStates, share: float = SHADE_SHARE, limit: int = MAX_CELLS) -> Shading:
    """The cells whose mass is at least ``share`` of the largest cell's, as squares of one cell --
    or, when more than ``limit`` qualify, of 2 x 2, 4 x 4... cells (the smallest block that keeps
    ``limit`` squares or fewer), each square holding its cells' summed mass: the whole belief stays
    drawn, more coarsely. Blocks are taken on the cells' lattice in the map frame."""
    mass, s = states.cell_mass, states.cell_size
    if mass.size == 0 or not float(mass.max()) > 0:
        empty = np.zeros(0)
        return Shading(empty, empty, empty, s)
    cells = np.flatnonzero(mass >= share * float(mass.max()))
    if cells.size <= limit:  # the cells themselves, at their own centres
        cells = cells[np.argsort(-mass[cells], kind="stable")]
        return Shading(states.cell_x[cells], states.cell_y[cells], mass[cells], s)
    x0, y0 = float(states.cell_x.min()), float(states.cell_y.min())
    i = np.rint((states.cell_x - x0) / s).astype(np.int64)
    j = np.rint((states.cell_y - y0) / s).astype(np.int64)
    block = 1
    while True:
        block *= 2
        rows = int(j.max()) // block + 1
        unique, inverse = np.unique((i // block) * rows + j // block, return_inverse=True)
        summed = np.bincount(inverse.ravel(), weights=mass, minlength=unique.size)
        kept = np.flatnonzero(summed >= share * float(summed.max()))
        if kept.size <= limit:
            break
    kept = kept[np.argsort(-summed[kept], kind="stable")]
    bi, bj = unique[kept] // rows, unique[kept] % rows
    centre_x = x0 + (bi * block + (block - 1) / 2) * s
    centre_y = y0 + (bj * block + (block - 1) / 2) * s
    return Shading(centre_x, centre_y, summed[kept], block * s)


def belief_messages(states: BeliefStates, ns: int) -> tuple[ros.Message, ros.Message]:
    """``(PoseArray, MarkerArray)`` of a belief; see the module's docstring for what they hold."""
    likely = likely_states(states.probability)
    poses = [Pose(float(states.x[i]), float(states.y[i]), float(states.yaw[i])) for i in likely]
    squares = shading(states)
    r, g, b = BELIEF_COLOUR
    alpha = squares.mass / float(squares.mass[0]) if squares.mass.size else squares.mass
    marker = ros.cube_list_marker(
        zip(squares.x.tolist(), squares.y.tolist(), strict=True),
        ((r, g, b, float(a)) for a in alpha),
        squares.side,
        namespace="belief",
        ns=ns,
    )
    return ros.pose_array(poses, MAP_FRAME, ns), ros.marker_array([marker])


def pose_with_covariance(pose: Pose, covariance: Any, ns: int) -> ros.Message:
    """``/beliefloc/pose``: ``pose`` with the 36 numbers of ``covariance`` (ROS's layout)."""
    cov = [float(v) + 0.0 for v in np.asarray(covariance, dtype=np.float64).ravel()]
    return {
        "header": ros.header(MAP_FRAME, ns),
        "pose": {"pose": ros.pose(pose), "covariance": cov},
    }


# --- the writer ----------------------------------------------------------------------------------------


def is_single_file(path: Path) -> bool:
    """``OUT.mcap`` is one MCAP file; anything else a rosbag2 folder."""
    return path.suffix.lower() == MCAP_SUFFIX


class RecordingWriter:
    """Messages (plain bodies) to a ROS 2 recording in MCAP storage, serialized as they come:
    written at once into the recording :func:`open_recording` builds, or, made with no writer,
    kept (serialized) until :func:`write_recording` writes them -- for a run whose recording is
    only known to be wanted, or writable, at its end."""

    def __init__(self, writer: Any = None) -> None:
        from rosbags.typesys import Stores, get_typestore

        self._writer = writer
        self._typestore = get_typestore(Stores.ROS2_HUMBLE)
        self._connections: dict[str, Any] = {}
        self._kept: list[tuple[str, str, bytes, int]] = []
        self.counts: dict[str, int] = {}
        """Messages written per topic."""

    def write(self, topic: str, msgtype: str, body: ros.Message, ns: int) -> None:
        """Write ``body`` (a ``msgtype`` message) on ``topic`` at log time ``ns``."""
        typed = ros.to_typed(self._typestore, msgtype, body)
        data = bytes(self._typestore.serialize_cdr(typed, msgtype))
        self.counts[topic] = self.counts.get(topic, 0) + 1
        if self._writer is None:
            self._kept.append((topic, msgtype, data, int(ns)))
        else:
            self._emit(topic, msgtype, data, int(ns))

    def _emit(self, topic: str, msgtype: str, data: bytes, ns: int) -> None:
        connection = self._connections.get(topic)
        if connection is None:
            qos = (_latched_qos(),) if topic in LATCHED_TOPICS else ()
            connection = self._writer.add_connection(
                topic, msgtype, typestore=self._typestore, offered_qos_profiles=qos
            )
            self._connections[topic] = connection
        self._writer.write(connection, ns, data)

    def write_kept(self, into: RecordingWriter) -> None:
        """Write the messages kept by this writer (made without one) into ``into``."""
        for topic, msgtype, data, ns in self._kept:
            into._emit(topic, msgtype, data, ns)
            into.counts[topic] = into.counts.get(topic, 0) + 1


def _latched_qos() -> Any:
    from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

    zero = QosTime(0, 0)
    return Qos(
        QosHistory.KEEP_LAST,
        1,
        QosReliability.RELIABLE,
        QosDurability.TRANSIENT_LOCAL,
        zero,
        zero,
        QosLiveliness.AUTOMATIC,
        zero,
        False,
    )


@contextmanager
def open_recording(path: Path) -> Iterator[RecordingWriter]:
    """A :class:`RecordingWriter` whose recording becomes ``path`` when the block ends normally
    (an existing ``path`` is replaced: the caller checked it); on an error, Ctrl-C or SIGTERM
    nothing is left. A failed write is an :class:`OutputError` naming ``path``."""
    from rosbags.rosbag2 import StoragePlugin, Writer, WriterError

    from beliefloc.source.atomic_write import staging_folder

    path = Path(path)
    name = path.stem if is_single_file(path) else path.name
    with staging_folder(path) as staging:
        bag = staging / (name or "recording")
        try:
            writer = Writer(bag, version=8, storage_plugin=StoragePlugin.MCAP)
            writer.open()
        except (OSError, WriterError) as exc:
            raise _cannot_write(path, exc) from None
        try:
            yield RecordingWriter(writer)
            writer.close()
        except OSError as exc:
            raise _cannot_write(path, exc) from None
        try:
            if is_single_file(path):
                os.replace(bag / f"{bag.name}.mcap", path)
            else:
                os.rename(bag, path)
        except OSError as exc:
            raise _cannot_write(path, exc) from None


def write_recording(path: Path, kept: RecordingWriter) -> dict[str, int]:
    """Write the messages ``kept`` (a :class:`RecordingWriter` made without a writer) as the
    recording ``path``, whole or not at all; the messages per topic."""
    with open_recording(path) as out:
        kept.write_kept(out)
    return out.counts


def _cannot_write(path: Path, exc: Exception) -> OutputError:
    reason = getattr(exc, "strerror", None) or str(exc)
    return OutputError(f"{path}: the recording cannot be written ({reason}); nothing was written", reason)


# --- track --bag: the bag's scans and odometry, the filter's belief -------------------------------------


class TrackRecorder:
    """Writes ``track MAP --bag RUN``'s run while it goes: give :meth:`on_scan` to
    :func:`~beliefloc.recordings.replay.track_recording` and call :meth:`finish` with its result.

    Every scan of the bag goes to ``/scan`` as read (in the laser's frame; REP 117 values kept,
    as float32); every odometry pose to ``/odom`` (``odom`` -> the base frame; the twist is not in
    the reading, so it is zero) and to ``/tf``; the laser's mount to ``/tf_static``. At every filter
    update the belief goes to ``/beliefloc/belief`` and ``/beliefloc/belief_cells``, the update's
    refined pose and the belief's covariance to ``/beliefloc/pose``, and ``map -> odom`` to ``/tf``
    as AMCL publishes it (the refined pose composed with the inverse of the odometry at the scan).
    The last ``/beliefloc/pose`` is the run's answer (:attr:`TrackResult.pose
    <beliefloc.recordings.replay.TrackResult.pose>`), stamped with the last scan. Messages are
    logged at their header stamps."""

    def __init__(self, out: RecordingWriter, recording: Recording, grid: GridFilter) -> None:
        self.out = out
        self.recording = recording
        self.grid = grid
        self._next_scan = 0
        self._next_odom = 0
        self._odometry = recording.odometry_at(np.array([s.stamp for s in recording.scans], dtype=np.int64))
        start = recording.start
        occupancy = grid.occupancy
        out.write(MAP_TOPIC, OCCUPANCY_GRID, map_from_occupancy(occupancy, start), start)
        mx, my, myaw = recording.mount
        mount = ros.transform_stamped(recording.base_frame, recording.laser_frame, Pose(mx, my, myaw), start)
        out.write(TF_STATIC_TOPIC, TF_MESSAGE, ros.tf_message([mount]), start)

    def _odometry_until(self, stamp: int) -> None:
        rec = self.recording
        while self._next_odom < len(rec.odom_stamps) and int(rec.odom_stamps[self._next_odom]) <= stamp:
            k = self._next_odom
            ns = int(rec.odom_stamps[k])
            x, y, yaw = (float(v) for v in rec.odom_poses[k])
            p = Pose(x, y, yaw)
            self.out.write(ODOM_TOPIC, ODOMETRY, ros.odometry(p, ns, child_frame_id=rec.base_frame), ns)
            base = ros.transform_stamped(ODOM_FRAME, rec.base_frame, p, ns)
            self.out.write(TF_TOPIC, TF_MESSAGE, ros.tf_message([base]), ns)
            self._next_odom += 1

    def on_scan(self, stamp: int, update: Update | None) -> None:
        """``track_recording``'s ``on_scan``: called after every scan, in order."""
        n = self._next_scan
        self._next_scan += 1
        scan = self.recording.scans[n]
        self._odometry_until(stamp)
        body = ros.laser_scan(
            self.recording.laser_frame,
            stamp,
            angle_min=scan.angle_min,
            angle_increment=scan.angle_increment,
            ranges=scan.ranges.astype(np.float32),
            range_min=scan.range_min,
            range_max=scan.range_max,
            time_increment=scan.time_increment,
            scan_time=scan.scan_time,
        )
        self.out.write(SCAN_TOPIC, LASER_SCAN, body, stamp)
        if update is None:
            return
        g = self.grid
        poses, cells = belief_messages(
            filter_belief_states(g.belief, g.cell_x, g.cell_y, g.map_yaws, g.config.cell_size), stamp
        )
        self.out.write(BELIEF_TOPIC, POSE_ARRAY, poses, stamp)
        self.out.write(BELIEF_CELLS_TOPIC, MARKER_ARRAY, cells, stamp)
        best = np.array([update.x, update.y, update.yaw])
        odom_to_base = self._odometry[n]
        map_to_odom = compose(best[None], relative(odom_to_base, np.zeros(3)))[0]
        tf = ros.transform_stamped(MAP_FRAME, ODOM_FRAME, Pose(*(float(v) for v in map_to_odom)), stamp)
        self.out.write(TF_TOPIC, TF_MESSAGE, ros.tf_message([tf]), stamp)
        if n < len(self.recording.scans) - 1:  # the last scan's pose is the run's answer: see finish
            pose = Pose(update.x, update.y, update.yaw)
            self.out.write(
                POSE_TOPIC,
                POSE_WITH_COVARIANCE,
                pose_with_covariance(pose, g.covariance((update.x, update.y, update.yaw)), stamp),
                stamp,
            )

    def finish(self, result: TrackResult) -> None:
        """The odometry left after the last scan, and the run's answer on ``/beliefloc/pose``."""
        self._odometry_until(self.recording.end)
        last = self.recording.scans[-1].stamp
        x, y, yaw = result.pose
        self.out.write(
            POSE_TOPIC, POSE_WITH_COVARIANCE, pose_with_covariance(Pose(x, y, yaw), result.covariance, last), last
        )


# --- simulate: an episode on the grid ------------------------------------------------------------------

STEP_NS = 1_000_000_000
"""A grid simulation has no clock: step ``n`` (0: the start) is stamped ``(n + 1)`` seconds."""


@dataclass(frozen=True)
class _ScanBeam:
    """One beam of a map's Scan sensor, as an observation part."""

    topic: str
    slot: int
    """Its index in the topic's LaserScan."""
    edges: tuple[float, ...]
    """``(0, *bins)``: reading ``w`` is a wall in ``(edges[w], edges[w + 1]]``, the last no wall."""


@dataclass(frozen=True)
class _ScanLayout:
    angle_min: float
    increment: float
    slots: int
    range_max: float


def beam_angle(degrees: float) -> float:
    """A Scan beam's direction in a LaserScan: the map file's degrees, counter-clockwise from the
    heading (``beams_deg``, :class:`~beliefloc.semantic_map.sections.ScanSensor`), as radians
    counter-clockwise from the base's +x (REP 103), wrapped to [-pi, pi)."""
    return (math.radians(degrees) + math.pi) % (2 * math.pi) - math.pi


class EpisodeRecorder:
    """Writes one episode of a grid simulation while it runs: pass :meth:`on_step` and
    :meth:`on_episode` to the episode hooks (as :class:`beliefloc.render.picture_episode.TraceRecorder`).

    Frames: ``map`` -> ``odom`` on ``/tf_static`` is the robot's true start pose (the simulator's
    truth, not an estimate) and ``odom`` -> ``base_link`` on ``/tf`` and ``/odom`` its true motion
    since, so ``base_link`` in ``map`` is the true pose (a state's pose: its cell's centre and its
    heading's yaw) after every step. ``/scan`` (frame ``base_link``; ``/scan/NAME`` for each of
    several Scan sensors): what the simulated robot read, when a step reads a Scan sensor -- a grid
    sensor reads a distance *bin*, not a distance, so each beam's range is the middle of the bin
    read, ``+inf`` for ``no_wall`` (REP 117: nothing within ``range_max``, the last bin's edge), and
    NaN for the angles between beams (a LaserScan's beams are evenly spaced); the beams at their
    directions, every ``360 / headings`` degrees. After every step the belief goes to
    ``/beliefloc/belief``, ``/beliefloc/belief_cells`` and ``/beliefloc/pose`` (the last one is the
    episode's ``pose`` in ``simulate --json``). Look and Here readings have no ROS message here."""

    def __init__(
        self,
        out: RecordingWriter,
        model: Model,
        strategy: str,
        episode: int,
        start_belief: np.ndarray,
        smap: SemanticMap | None,
    ) -> None:
        if model.grid is None:
            raise ValueError(f"model {model.name!r} has no grid: its states have no pose")
        self.out = out
        self.model = model
        self.grid = model.grid
        self.strategy = strategy
        self.episode = episode
        self.start_belief = start_belief
        self._start: np.ndarray | None = None
        self._beams, self._layouts = _scan_beams(smap, self.grid.headings)
        occupancy = smap.occupancy_map if smap is not None else None
        body = map_from_occupancy(occupancy, STEP_NS) if occupancy is not None else map_from_grid(self.grid, STEP_NS)
        out.write(MAP_TOPIC, OCCUPANCY_GRID, body, STEP_NS)

    @property
    def recorded(self) -> bool:
        """The episode ran (its start, at least, is recorded)."""
        return self._start is not None

    @property
    def reads_scans(self) -> bool:
        """The map has a Scan sensor whose readings go to ``/scan``."""
        return bool(self._beams)

    def _mine(self, record: EpisodeRecord) -> bool:
        return record.strategy == self.strategy and record.episode == self.episode

    def _true_pose(self, state_name: str) -> np.ndarray:
        p = state_pose(self.grid, self.model.states.index(state_name))
        return np.array([p.x, p.y, p.yaw])

    def _begin(self, record: EpisodeRecord) -> None:
        start = self._true_pose(record.start)
        self._start = start
        static = ros.transform_stamped(MAP_FRAME, ODOM_FRAME, Pose(*(float(v) for v in start)), STEP_NS)
        self.out.write(TF_STATIC_TOPIC, TF_MESSAGE, ros.tf_message([static]), STEP_NS)
        self._state(record.start, self.start_belief, STEP_NS)

    def _state(self, true_state: str, belief: np.ndarray, ns: int) -> None:
        assert self._start is not None
        moved = relative(self._start, self._true_pose(true_state))
        p = Pose(*(float(v) for v in moved))
        self.out.write(ODOM_TOPIC, ODOMETRY, ros.odometry(p, ns), ns)
        self.out.write(TF_TOPIC, TF_MESSAGE, ros.tf_message([ros.transform_stamped(ODOM_FRAME, BASE_FRAME, p, ns)]), ns)
        poses, cells = belief_messages(grid_belief_states(self.grid, belief), ns)
        self.out.write(BELIEF_TOPIC, POSE_ARRAY, poses, ns)
        self.out.write(BELIEF_CELLS_TOPIC, MARKER_ARRAY, cells, ns)
        estimate = belief_pose(self.model, belief)
        body = pose_with_covariance(estimate.pose, estimate.covariance, ns)
        self.out.write(POSE_TOPIC, POSE_WITH_COVARIANCE, body, ns)

    def on_step(self, record: EpisodeRecord, step: StepRecord, belief: np.ndarray) -> None:
        """The episode hook ``on_step``: called after every step of every episode."""
        if not self._mine(record):
            return
        if self._start is None:
            self._begin(record)
        ns = (record.steps + 1) * STEP_NS
        if step.observation is not None:
            self._scan(step.action, step.observation, ns)
        self._state(step.true_state, belief, ns)

    def on_episode(self, record: EpisodeRecord) -> None:
        """The episode hook ``on_episode``: an episode of no step still records its start."""
        if self._mine(record) and self._start is None:
            self._begin(record)

    def _scan(self, action_name: str, observation: str, ns: int) -> None:
        observations = self.model.action(action_name).observation
        readings = observations.decode(observations.index(observation))
        ranges: dict[str, np.ndarray] = {}
        for part, w in zip(observations.parts, readings, strict=True):
            beam = self._beams.get(part.name)
            if beam is None:
                continue
            if beam.topic not in ranges:
                ranges[beam.topic] = np.full(self._layouts[beam.topic].slots, np.nan, dtype=np.float32)
            edges = beam.edges
            ranges[beam.topic][beam.slot] = (edges[w] + edges[w + 1]) / 2 if w + 1 < len(edges) else np.inf
        for topic, values in ranges.items():
            layout = self._layouts[topic]
            body = ros.laser_scan(
                BASE_FRAME,
                ns,
                angle_min=layout.angle_min,
                angle_increment=layout.increment,
                ranges=values,
                range_min=0.0,
                range_max=layout.range_max,
            )
            self.out.write(topic, LASER_SCAN, body, ns)


def _scan_beams(smap: SemanticMap | None, headings: int) -> tuple[dict[str, _ScanBeam], dict[str, _ScanLayout]]:
    """The observation parts of the map's Scan sensors (``NAME``, or ``NAME@ANGLE`` for a sensor
    of several beams, as :func:`beliefloc.semantic_map.compile` names them) and each topic's
    LaserScan layout."""
    from beliefloc.semantic_map.observations import label
    from beliefloc.semantic_map.sections import ScanSensor

    if smap is None:
        return {}, {}
    sensors = [(name, s) for name, s in smap.sensors.items() if isinstance(s, ScanSensor)]
    beams: dict[str, _ScanBeam] = {}
    layouts: dict[str, _ScanLayout] = {}
    increment = 2 * math.pi / headings
    for name, sensor in sensors:
        topic = SCAN_TOPIC if len(sensors) == 1 else f"{SCAN_TOPIC}/{name}"
        angles = [beam_angle(a) for a in sensor.beams]
        low = min(angles)
        slots = [round((a - low) / increment) for a in angles]
        layouts[topic] = _ScanLayout(low, increment, max(slots) + 1, float(sensor.bins[-1]))
        edges = (0.0, *(float(b) for b in sensor.bins))
        for angle, slot in zip(sensor.beams, slots, strict=True):
            part = f"{name}@{label(angle)}" if sensor.multi_beam else name
            beams[part] = _ScanBeam(topic, slot, edges)
    return beams, layouts
