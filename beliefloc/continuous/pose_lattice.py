"""A belief over poses finer than the model's states: the filter that keeps an off-grid robot's true
pose alive (issue 26).

A model state (cell, heading) stands for a whole region: every position in the cell, every yaw in
the heading's sector. The papers' model reads each state at one exact pose; the region model
averages over the region. Neither can follow a real robot for long: its offset from the cell
centre and heading *persists* from one place to the next (it drove one cell along a yaw 20° off
the heading), so its readings are not independent draws from the region -- averaging makes each
reading vague, the exact pose makes it wrong.

The **pose lattice** splits every cell into ``k × k`` sub-cells and every heading sector into ``m``
yaws (``m`` odd, so the heading's own yaw is one of them): a lattice of ``(H·m) × (R·k) × (C·k)``
poses, of which the *valid* ones lie in a state's cell on a pixel the robot can stand on. The
filter's belief is over the valid poses; the model's belief is its sum over each state's poses
(:meth:`PoseLattice.coarse`), so the planner, the threshold and every report keep working on the
model's states. Each update is Bayes' rule at the lattice's resolution:

* **motion**: the odometry the robot reported, or the commanded motion, with the odometry noise
  model (:func:`beliefloc.continuous.motion.predict_grid`: a shift and a blur per yaw) -- the offset
  is carried along, not re-drawn. Without odometry a commanded move may be stopped by what the map
  blocks: a pose whose straight path meets a pixel the robot cannot stand on stays where it is
  (:meth:`PoseLattice.blocked`), and a reported ``blocked`` flag weighs the poses by it;
* **readings**: each observation part's likelihood at every valid pose
  (:class:`LatticeFilter`'s tables, built by :mod:`beliefloc.semantic_map.lattice_sensors` from a
  sensor with continuous noise), multiplied in.

Pure numpy/scipy, no I/O. Loops run over yaws and kernel taps, never over poses.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from scipy import ndimage

from beliefloc.continuous.image import OccupancyImage
from beliefloc.continuous.motion import OdometryNoise, grid_yaws, predict_grid
from beliefloc.errors import ImpossibleObservationError
from beliefloc.model import GridLayout, wrap_angle

TARGET_SPACING = 0.1
"""Metres between lattice positions the resolution aims at (a lidar's few centimetres of noise
and a robot's off-centre stance are resolved; finer costs memory without changing a verdict)."""
TARGET_YAW_DEG = 10.0
"""Degrees between lattice yaws the resolution aims at (at 3 m a 10° yaw error moves a beam's
end point by half a metre)."""
MAX_POSES = 1_000_000
"""At most this many valid lattice poses by default: the resolution is coarsened (yaws first, then
positions) until the lattice fits."""
STAY = 0.02
"""A commanded move without odometry leaves the robot where it was with at least this probability
(a wheel that slipped, a move refused): the pose it would have reached is not the only one kept."""
REACH_CELLS = 1.0
"""A state is declared with the probability that the robot is within this many cells and
:data:`REACH_SECTORS` heading sectors of a centre (:meth:`LatticeFilter.declared`): the state's
own cell centre and heading, or the belief's mean pose around its mode. A robot on the border of
two cells or sectors is within reach of both; the promise stays inside what ``simulate --continuous``
judges wrong by (:data:`PROMISE_CELLS`, :data:`PROMISE_SECTORS`)."""
REACH_SECTORS = 0.75
PROMISE_CELLS = 1.5
"""What "localized at this state" promises of an off-grid robot: within this many cells of the
state's cell centre and :data:`PROMISE_SECTORS` sectors of its heading (issue 26's measure of a
wrong answer, ``simulate --continuous``'s ``WRONG_CELLS``). Every pose a declaration counts lies,
with the whole square and yaw step it stands for, inside it."""
PROMISE_SECTORS = 1.0
FLAG_FLOOR = 0.01
"""The least weight a pose keeps when a ``blocked`` flag contradicts it (the flag may be wrong)."""
TEMPER = 0.7
"""Readings count this much each in Bayes' rule (the likelihood to this power). The robot is never
exactly at a lattice pose, and a pose's tables are an average over the square and yaw step it stands
for (:mod:`beliefloc.semantic_map.lattice_sensors`): consecutive readings share what the average
misses, and counted as independent they make the belief surer than the evidence. Measured on the
mirror-symmetric TurtleBot3 sandbox, best-first, 180 episodes without clutter and 180 with 10 %
spurious beams: at full weight 2 of 120 declared the 180° twin; at 0.7 none of 360 (localized 92 %
and 83 %). (Before the tables were averaged over the pose's yaw step -- each scan beam read at the
pose's exact yaw -- 0.5 had declared the twin 3 times in 120 and 0.4 was needed.)"""
UNMAPPED_STOP = 0.2
"""With odometry: the weight of a pose whose commanded path the map leaves open when the robot says
it was stopped (something not on the map: a person, a chair)."""
FREE_PAST_WALL = 0.1
"""With odometry: the weight of a pose whose commanded path the map blocks when the robot says it
was not stopped (the lattice position is up to half a spacing from the true pose)."""


NEAR_CELLS = 3
"""The expected declaration after a reading (:meth:`LatticeFilter.declared_after`) is worked out
on the poses within this many cells of the most likely state: the promise (1.5 cells) and the
declared state's own drift within it."""


INFORMATION_POSES = 100_000
"""A belief over more poses than this has its readings' information (:meth:`LatticeFilter.information`)
estimated from :data:`INFORMATION_SAMPLE` of them (the depot's lattice: 10^6 poses)."""
INFORMATION_SAMPLE = 50_000


def row_moments(table: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(H, V)`` per row of a reading table ``table[x, o] = p(o | x)``: the entropy of the row and
    the variance of ``log p(o | x)`` under it (nats, nats²), rows of zero-probability readings
    included."""
    t = np.asarray(table, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        log = np.where(t > 0, np.log(np.where(t > 0, t, 1.0)), 0.0)
    entropy: np.ndarray = -(t * log).sum(axis=1)
    variance: np.ndarray = np.maximum((t * log * log).sum(axis=1) - entropy * entropy, 0.0)
    return entropy, variance


def mutual_information(probabilities: np.ndarray, expected_log_likelihood: float) -> float:
    """The mutual information (nats) between a reading and the robot's pose: the entropy of the
    reading under the belief (``probabilities``: ``p(o | belief)``) less the mean entropy of a
    reading at a known pose (``-expected_log_likelihood``: ``Σ_pose b(pose) H(O | pose)``)."""
    p = np.asarray(probabilities, dtype=np.float64)
    p = p[p > 0]
    total = float(p.sum())
    if not total > 0:
        return 0.0
    p = p / total
    return max(0.0, float(-(p * np.log(p)).sum()) + expected_log_likelihood)


SPARSE_SUPPORT = 0.25
"""A belief on more than this share of the poses has its readings' probabilities summed a group
of poses at a time (:func:`part_groups`); on fewer, over its poses directly."""


def joint_readings(
    tables: Sequence[np.ndarray], parts: Sequence[int], rows: np.ndarray, weights: np.ndarray
) -> np.ndarray:
    """``sum_p weights[p] prod_k tables[k][rows[p], o_k]`` over the parts ``parts`` (their joint
    order: the first part's reading the most significant digit), shape ``(n_1, n_2, ...)``; a
    scalar array (the weights' sum) for no parts. Chunked: the joint per pose is built whole."""
    dims = [tables[k].shape[1] for k in parts]
    if not parts:
        return np.asarray(float(weights.sum()))
    n_obs = math.prod(dims)
    out = np.zeros(n_obs)
    chunk = max(1, 2_000_000 // n_obs)
    for start in range(0, rows.size, chunk):
        some = rows[start : start + chunk]
        # the first part's readings weighted by the belief, times the other parts' joint readings,
        # summed over the poses in one contraction: the whole joint product per pose, then its
        # sum, took 2.5-4x as long on tb3-sandbox's three-beam Scan (einsum's own loop, not BLAS)
        first = tables[parts[0]][some] * weights[start : start + chunk][:, None]
        if len(parts) == 1:
            out += first.sum(axis=0)
            continue
        rest = tables[parts[1]][some].astype(np.float64)
        for k in parts[2:]:
            rest = (rest[:, :, None] * tables[k][some][:, None, :]).reshape(len(some), -1)
        out += np.einsum("pa,pb->ab", first, rest).ravel()
    return out.reshape(dims)


def part_groups(
    tables: Sequence[np.ndarray], sample: int = 4096
) -> tuple[list[np.ndarray], list[tuple[tuple[int, ...], np.ndarray]]]:
    """``(common, groups)``: each part's most common row (``common[k]``, among ``sample`` poses
    spread over the lattice) and the poses grouped by which parts read other than it (``groups``:
    the parts, ascending, and the poses' indices). Every pose is in exactly one group."""
    n = tables[0].shape[0]
    picks = np.linspace(0, n - 1, min(n, sample)).astype(np.int64)
    common: list[np.ndarray] = []
    code = np.zeros(n, dtype=np.int64)
    for k, table in enumerate(tables):
        rows, counts = np.unique(table[picks], axis=0, return_counts=True)
        row = rows[int(np.argmax(counts))]
        common.append(row.astype(np.float64))
        code |= (~(table == row).all(axis=1)).astype(np.int64) << k
    order = np.argsort(code, kind="stable")
    codes, starts = np.unique(code[order], return_index=True)
    bounds = [*starts.tolist(), n]
    groups = [
        (tuple(k for k in range(len(tables)) if c >> k & 1), order[bounds[i] : bounds[i + 1]])
        for i, c in enumerate(codes.tolist())
    ]
    return common, groups


def circular_mean(weights: np.ndarray, yaws: np.ndarray, otherwise: float) -> float:
    """The ``weights``-weighted circular mean of ``yaws`` (radians); ``otherwise`` where they cancel
    out (a mean resultant below 1e-9 of the weight: no mean direction)."""
    sin, cos = float(weights @ np.sin(yaws)), float(weights @ np.cos(yaws))
    return otherwise if math.hypot(sin, cos) < 1e-9 * float(weights.sum()) else math.atan2(sin, cos)


def lattice_resolution(
    layout: GridLayout, *, spacing: float = TARGET_SPACING, yaw_deg: float = TARGET_YAW_DEG, max_poses: int = MAX_POSES
) -> tuple[int, int]:
    """``(k, m)``: sub-cells per cell side and yaws per heading sector (odd) for ``layout``: of the
    lattices with at most ``max_poses`` poses in the states' cells, the one nearest to ``spacing``
    metres and ``yaw_deg`` degrees (least ``(spacing'/spacing)² + (yaw'/yaw_deg)²``, where a step
    finer than the aim counts as the aim)."""
    sector = 360.0 / layout.headings
    k_most = max(1, math.ceil(layout.cell_size / spacing))
    m_most = max(1, math.ceil(sector / yaw_deg)) if layout.headings > 1 else 1
    best: tuple[float, int, int] = (math.inf, 1, 1)
    for k in range(1, k_most + 1):
        for m in range(1, m_most + 2, 2):
            if layout.n_states * k * k * m > max_poses and (k, m) != (1, 1):
                continue
            yaw_step = sector / m if layout.headings > 1 else 0.0
            score = max(layout.cell_size / k / spacing, 1.0) ** 2 + max(yaw_step / yaw_deg, 1.0) ** 2
            if score < best[0]:
                best = (score, k, m)
    return best[1], best[2]


@dataclass(eq=False)
class PoseLattice:
    """The lattice of poses over ``layout``'s states (see the module). ``image``: what the robot
    cannot stand on and rays stop at, in the *grid* frame
    (:func:`beliefloc.semantic_map.regions.blocked_image`)."""

    layout: GridLayout
    image: OccupancyImage
    k: int
    m: int
    robot_radius: float = 0.0
    """Metres: a lattice position is a place the robot can be when its disc fits there (the pixel's
    clearance from anything blocked exceeds it), as :class:`~beliefloc.continuous.world.ContinuousWorld`
    decides."""
    shape: tuple[int, int, int] = field(init=False)
    """``(yaws, rows, cols)`` of the full lattice image."""
    flat: np.ndarray = field(init=False)
    """The valid poses' indices into the flattened lattice image."""
    state: np.ndarray = field(init=False)
    """Each valid pose's model state."""
    stand: np.ndarray = field(init=False)
    """``(rows, cols)``: the lattice positions that are valid."""
    roomy: np.ndarray = field(init=False)
    """``(rows, cols)``: the valid positions where the robot's disc fits wherever in the position's
    square it stands (clearance above the radius plus half a spacing): a path through them only is
    surely open, where a path through :attr:`stand` only may still stop a robot near a wall."""
    _blocked: dict[tuple[bool, tuple[tuple[float, float], ...]], np.ndarray] = field(init=False, default_factory=dict)

    def __post_init__(self) -> None:
        if self.k < 1 or self.m < 1 or self.m % 2 == 0:
            raise ValueError(f"a pose lattice needs k >= 1 and an odd m >= 1, got k={self.k}, m={self.m}")
        L = self.layout
        k, m, H = self.k, self.m, L.headings
        G = H * m
        rows, cols = L.rows * k, L.cols * k
        self.shape = (G, rows, cols)
        fine = L.cell_size / k
        in_state = np.repeat(np.repeat(L.free, k, axis=0), k, axis=1)
        x = (np.arange(cols) + 0.5) * fine
        y = (rows - np.arange(rows) - 0.5) * fine
        X, Y = np.meshgrid(x, y)
        i, j = self.image.pixel_of(X, Y)
        inside = (i >= 0) & (i < self.image.height) & (j >= 0) & (j < self.image.width)
        res = self.image.resolution
        clearance = np.maximum(ndimage.distance_transform_edt(~np.asarray(self.image.blocked)) * res - res / 2, 0.0)
        can_stand = np.zeros((rows, cols), dtype=bool)
        # a lattice position stands for the square around it: it is a place the robot can be when
        # some of that square is (a robot stopped at a wall is half a spacing nearer it than the
        # nearest position that holds the whole disc)
        can_stand[inside] = clearance[i[inside], j[inside]] > self.robot_radius - fine / 2
        roomy = np.zeros((rows, cols), dtype=bool)
        roomy[inside] = clearance[i[inside], j[inside]] > self.robot_radius + fine / 2
        # where the robot can stand outside every state's cell (the robot_radius rule removed the
        # cell, yet the robot fits off its centre): the nearest state cell within one cell holds it
        distance, (near_r, near_c) = ndimage.distance_transform_edt(~in_state, return_indices=True)
        owner_r, owner_c = near_r // k, near_c // k
        stand = can_stand & (distance <= k)
        # a state cell where the robot can stand nowhere keeps all its positions (as the region
        # model keeps its centre): every state has poses
        per_cell = (stand & in_state).reshape(L.rows, k, L.cols, k).any(axis=(1, 3))
        empty = np.repeat(np.repeat(L.free & ~per_cell, k, axis=0), k, axis=1)
        stand |= empty
        owner_r = np.where(empty, np.arange(rows)[:, None] // k, owner_r)
        owner_c = np.where(empty, np.arange(cols)[None, :] // k, owner_c)
        self.stand = stand
        self.roomy = roomy & stand
        # valid poses ordered by lattice yaw, then row, then column
        g = np.arange(G)
        heading = self.yaw_headings()
        r, c = np.nonzero(stand)
        cell_index = np.full(L.rows * L.cols, -1, dtype=np.int64)
        cell_index[L.free_cells] = np.arange(len(L.free_cells))
        cells = cell_index[owner_r[r, c] * L.cols + owner_c[r, c]]
        self.flat = (g[:, None] * rows * cols + (r * cols + c)[None, :]).ravel()
        self.state = (cells[None, :] * H + heading[:, None]).ravel()

    # --- sizes and frames -------------------------------------------------------------------------

    @property
    def n_poses(self) -> int:
        return int(self.flat.size)

    def yaw_headings(self) -> np.ndarray:
        """The model heading each lattice yaw lies in (its sector's centre yaw and the ``m // 2``
        yaws either side)."""
        G = self.layout.headings * self.m
        out: np.ndarray = ((np.arange(G) + (self.m - 1) // 2) // self.m) % self.layout.headings
        return out

    @property
    def spacing(self) -> float:
        """Metres between lattice positions."""
        return self.layout.cell_size / self.k

    @property
    def yaw_step(self) -> float:
        """Radians between lattice yaws."""
        return 2 * math.pi / self.shape[0]

    def yaws(self) -> np.ndarray:
        """Grid-frame yaw of each lattice yaw index (heading 0 up the grid, then clockwise)."""
        return grid_yaws(self.shape[0]) if self.shape[0] > 1 else np.array([math.pi / 2])

    @cached_property
    def pose_array(self) -> np.ndarray:
        """:meth:`poses`, computed once."""
        return self.poses()

    def poses(self) -> np.ndarray:
        """``(n_poses, 3)``: each valid pose's ``(x, y, yaw)`` in the grid frame."""
        _G, rows, cols = self.shape
        g, rc = np.divmod(self.flat, rows * cols)
        r, c = np.divmod(rc, cols)
        fine = self.spacing
        return np.stack([(c + 0.5) * fine, (rows - r - 0.5) * fine, self.yaws()[g]], axis=-1)

    # --- beliefs --------------------------------------------------------------------------------

    def coarse(self, fine: np.ndarray) -> np.ndarray:
        """The model's belief: each state's poses summed."""
        out: np.ndarray = np.bincount(self.state, weights=fine, minlength=self.layout.n_states)
        return out

    def from_coarse(self, belief: np.ndarray) -> np.ndarray:
        """A lattice belief with ``belief``'s mass per state spread evenly over the state's poses."""
        counts = np.bincount(self.state, minlength=self.layout.n_states).astype(np.float64)
        share = np.divide(belief, counts, out=np.zeros_like(belief, dtype=np.float64), where=counts > 0)
        fine: np.ndarray = share[self.state]
        total = fine.sum()
        if not total > 0:
            raise ValueError("the belief has no mass on a state the lattice holds")
        out: np.ndarray = fine / total
        return out

    def image_of(self, fine: np.ndarray) -> np.ndarray:
        out = np.zeros(self.shape)
        out.reshape(-1)[self.flat] = fine
        return out

    def gather(self, image: np.ndarray) -> np.ndarray:
        out: np.ndarray = image.reshape(-1)[self.flat]
        return out

    @cached_property
    def image_indices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(yaw, row, column)``: each valid pose's indices into the lattice image."""
        _G, rows, cols = self.shape
        g, rc = np.divmod(self.flat, rows * cols)
        r, c = np.divmod(rc, cols)
        return g, r, c

    @cached_property
    def _box(self) -> tuple[slice, slice, np.ndarray]:
        """``(rows, cols, flat)``: the bounding box of the valid positions and the valid poses'
        indices into a ``(yaws, box rows, box cols)`` image. Motions are worked out in the box
        alone: a map's lattice spans its whole image, and a floor is often a small part of it
        (tb3-sandbox: 5 % of 231 x 231), while mass moved outside the box lands on no valid pose
        and is dropped either way -- the same numbers for a twentieth of the work."""
        r, c = np.nonzero(self.stand)
        rows, cols = slice(int(r.min()), int(r.max()) + 1), slice(int(c.min()), int(c.max()) + 1)
        g, pr, pc = self.image_indices
        height, width = rows.stop - rows.start, cols.stop - cols.start
        flat = g * (height * width) + (pr - rows.start) * width + (pc - cols.start)
        return rows, cols, flat

    def _box_image_of(self, fine: np.ndarray) -> np.ndarray:
        """:meth:`image_of` within :attr:`_box`."""
        rows, cols, flat = self._box
        out = np.zeros((self.shape[0], rows.stop - rows.start, cols.stop - cols.start))
        out.reshape(-1)[flat] = fine
        return out

    def _box_gather(self, image: np.ndarray) -> np.ndarray:
        """:meth:`gather` from an image within :attr:`_box`."""
        out: np.ndarray = image.reshape(-1)[self._box[2]]
        return out

    def window(self, rows: slice, cols: slice) -> tuple[slice, slice, np.ndarray, np.ndarray]:
        """``(rows, cols, flat, poses)``: a part of the lattice image (clipped to it), the valid poses
        in it, and their indices into a ``(yaws, rows, cols)`` image of it -- where
        :meth:`predict` may be worked out when only the poses near some place matter."""
        _G, full_rows, full_cols = self.shape
        rows = slice(max(0, rows.start), min(full_rows, rows.stop))
        cols = slice(max(0, cols.start), min(full_cols, cols.stop))
        g, r, c = self.image_indices
        poses = np.flatnonzero((r >= rows.start) & (r < rows.stop) & (c >= cols.start) & (c < cols.stop))
        width = max(0, cols.stop - cols.start)
        flat = (
            g[poses] * (max(0, rows.stop - rows.start) * width)
            + (r[poses] - rows.start) * width
            + c[poses]
            - cols.start
        )
        return rows, cols, flat, poses

    # --- motion ---------------------------------------------------------------------------------

    def predict(
        self,
        fine: np.ndarray,
        deltas: Sequence[tuple[float, float, float]],
        noise: OdometryNoise,
        window: tuple[slice, slice, np.ndarray, np.ndarray] | None = None,
    ) -> np.ndarray:
        """``fine`` moved by a robot-frame delta per lattice yaw (``deltas[g]``; one delta for all
        when ``len(deltas) == 1``) with ``noise``; mass that lands where no valid pose is, is dropped.
        Unnormalised: the mass kept (0 when every pose moved off the valid ones). With a ``window``
        (:meth:`window`), only the mass within it, moved within it (the rest 0)."""
        if window is None:
            image = self._box_image_of(fine)
            rows, cols, _ = self._box
        else:
            rows, cols, flat, poses = window
            image = np.zeros((self.shape[0], rows.stop - rows.start, cols.stop - cols.start))
            image.reshape(-1)[flat] = fine[poses]
        G = self.shape[0]
        yaws = self.yaws()
        groups: dict[tuple[float, float, float], list[int]] = {}
        for g in range(G):
            dx, dy, dyaw = deltas[0] if len(deltas) == 1 else deltas[g]
            groups.setdefault((float(dx), float(dy), float(dyaw)), []).append(g)
        if len(groups) == 1:
            moved = predict_grid(image, yaws, self.spacing, next(iter(groups)), noise, normalize=False)
        else:
            moved = np.zeros_like(image)
            for delta, members in groups.items():
                part = np.zeros_like(image)
                part[members] = image[members]
                moved += predict_grid(part, yaws, self.spacing, delta, noise, normalize=False)
        moved *= self.stand[None, rows, cols]
        if window is None:
            return self._box_gather(moved)
        out = np.zeros(self.n_poses)
        out[poses] = moved.reshape(-1)[flat]
        return out

    def shifted(self, fine: np.ndarray, deltas: Sequence[tuple[float, float, float]]) -> np.ndarray:
        """``fine`` moved by a robot-frame delta per lattice yaw (as :meth:`predict`) to the nearest
        lattice pose, without noise: a quick look at where the mass goes (mass that lands where no
        valid pose is, is dropped; unnormalised)."""
        image = self._box_image_of(fine)
        box_rows, box_cols, _ = self._box
        _, rows, cols = image.shape
        moved = np.zeros_like(image)
        for g, (dr, dc, turned) in enumerate(self._steps(deltas).tolist()):
            r_lo, r_hi = max(0, dr), min(rows, rows + dr)
            c_lo, c_hi = max(0, dc), min(cols, cols + dc)
            if r_lo < r_hi and c_lo < c_hi:
                moved[turned, r_lo:r_hi, c_lo:c_hi] += image[g, r_lo - dr : r_hi - dr, c_lo - dc : c_hi - dc]
        moved *= self.stand[None, box_rows, box_cols]
        return self._box_gather(moved)

    def _steps(self, deltas: Sequence[tuple[float, float, float]]) -> np.ndarray:
        """Per lattice yaw ``g``: the rows and columns a robot-frame delta (``deltas[g]``, or the one
        for all) shifts a pose by, to the nearest lattice position, and the lattice yaw it ends at
        (``(G, 3)`` integers)."""
        G = self.shape[0]
        yaws = self.yaws()
        out = np.zeros((G, 3), dtype=np.int64)
        for g in range(G):
            dx, dy, dyaw = deltas[0] if len(deltas) == 1 else deltas[g]
            c, s = math.cos(yaws[g]), math.sin(yaws[g])
            out[g, 0] = round(-(s * dx + c * dy) / self.spacing)
            out[g, 1] = round((c * dx - s * dy) / self.spacing)
            out[g, 2] = (g - round(dyaw / self.yaw_step)) % G  # lattice yaws go clockwise
        return out

    def successors(self, deltas: Sequence[tuple[float, float, float]]) -> np.ndarray:
        """Per valid pose: the pose a robot-frame delta per lattice yaw (as :meth:`shifted`) takes it
        to, without noise; the pose itself where the map blocks the path (:meth:`blocked`) or the
        pose reached is not valid."""
        G, rows, cols = self.shape
        poses = np.arange(self.n_poses)
        index = np.full(G * rows * cols, -1, dtype=np.int64)
        index[self.flat] = poses
        g, rc = np.divmod(self.flat, rows * cols)
        r, c = np.divmod(rc, cols)
        shift = self._steps(deltas)
        to_r, to_c, to_g = r + shift[g, 0], c + shift[g, 1], shift[g, 2]
        inside = (to_r >= 0) & (to_r < rows) & (to_c >= 0) & (to_c < cols)
        target = np.where(inside, index[np.where(inside, to_g * rows * cols + to_r * cols + to_c, 0)], -1)
        out: np.ndarray = np.where(self.blocked(deltas) | (target < 0), poses, target)
        return out

    def blocked(self, deltas: Sequence[tuple[float, float, float]], *, maybe: bool = False) -> np.ndarray:
        """Per valid pose: whether the straight path of its robot-frame translation (``deltas[g]`` for
        lattice yaw ``g``; one for all when ``len(deltas) == 1``) meets a lattice position that is
        not valid or leaves the lattice -- the move is surely stopped there. ``maybe``: whether it
        meets one that is not :attr:`roomy` -- the move may be stopped (the robot stands anywhere in
        its position's square; near a wall the lattice cannot say). Checked at steps of half the
        spacing. Cached per motion."""
        motion = tuple((round(d[0], 9), round(d[1], 9)) for d in deltas)
        key = (maybe, motion)
        free = self.roomy if maybe else self.stand
        cached = self._blocked.get(key)
        if cached is not None:
            return cached
        G, rows, cols = self.shape
        yaws = self.yaws()
        out = np.zeros(self.shape, dtype=bool)
        for g in range(G):
            dx, dy = motion[0] if len(motion) == 1 else motion[g]
            c, s = math.cos(yaws[g]), math.sin(yaws[g])
            gx, gy = c * dx - s * dy, s * dx + c * dy
            steps = max(1, math.ceil(math.hypot(gx, gy) / (self.spacing / 2)))
            hit = np.zeros((rows, cols), dtype=bool)
            for f in np.linspace(0.0, 1.0, steps + 1)[1:]:
                dr, dc = round(-gy * f / self.spacing), round(gx * f / self.spacing)
                if abs(dr) > rows or abs(dc) > cols:
                    hit[:] = True
                    break
                # free[r + dr, c + dc] for every (r, c), off the lattice counting as blocked
                shifted = np.zeros((rows, cols), dtype=bool)
                r_lo, r_hi = max(0, -dr), min(rows, rows - dr)
                c_lo, c_hi = max(0, -dc), min(cols, cols - dc)
                if r_lo < r_hi and c_lo < c_hi:
                    shifted[r_lo:r_hi, c_lo:c_hi] = free[r_lo + dr : r_hi + dr, c_lo + dc : c_hi + dc]
                hit |= ~shifted
            out[g] = hit
        result = self.gather(out).astype(bool)
        self._blocked[key] = result
        return result


@dataclass(eq=False)
class LatticeFilter:
    """The Bayes filter over a :class:`PoseLattice` (see the module).

    ``tables[action]``: one ``(n_poses, n_values)`` array per observation part of the action, in
    the model's part order: the part's reading probabilities at each valid pose. ``motions[action]``:
    the commanded motion per lattice yaw (robot-frame deltas; absent for a perception action).
    ``noise``: the odometry noise model used for both reported and commanded motion."""

    lattice: PoseLattice
    tables: dict[str, list[np.ndarray]]
    motions: dict[str, list[tuple[float, float, float]]]
    noise: OdometryNoise
    temper: float = TEMPER
    """Each reading's likelihood is raised to this power in Bayes' rule (:data:`TEMPER`)."""
    mean_reach_too: bool = False
    """:meth:`declared` also weighs the reach around the belief's mean pose (:meth:`mean_reach`).
    Off by default: measured (benchmarks/results/offgrid.md, 2026-11-27 "depot7") it localized the
    depot in 5 of 10 episodes instead of 0, but declared the mirror twin of tb3-sandbox's pillars
    once in 20 episodes (p = 0.954, where the state's own reach stayed below 0.95)."""
    fine: np.ndarray = field(init=False)
    _entropy: dict[str, tuple[np.ndarray, np.ndarray]] = field(init=False, default_factory=dict)
    _groups: dict[str, tuple[list[np.ndarray], list[tuple[tuple[int, ...], np.ndarray]]]] = field(
        init=False, default_factory=dict
    )
    _successors: dict[str, np.ndarray] = field(init=False, default_factory=dict)

    def start(self, belief: np.ndarray) -> np.ndarray:
        """Start from the model's ``belief``; returns the model's belief (the lattice's, summed)."""
        self.fine = self.lattice.from_coarse(np.asarray(belief, dtype=np.float64))
        return self.belief

    @property
    def belief(self) -> np.ndarray:
        return self.lattice.coarse(self.fine)

    # --- motion ---------------------------------------------------------------------------------

    def predict(
        self,
        action: str,
        odometry: tuple[float, float, float] | None,
        blocked: bool | None,
        window: tuple[slice, slice, np.ndarray, np.ndarray] | None = None,
    ) -> None:
        """The motion of ``action``: by the reported ``odometry`` when given; else by the commanded
        motion, each pose whose path the map blocks staying where it is, weighed by the ``blocked``
        flag when given (see the module). Raises :class:`ImpossibleObservationError` when no pose is
        left (the motion takes every pose the robot may be in off the map). With a ``window``
        (:meth:`PoseLattice.window`) the mass outside it is dropped (a look at the poses near a
        place)."""
        fine = self.fine
        if odometry is not None:
            deltas = self.motions.get(action)
            if blocked is not None and deltas is not None:
                # the flag says whether the commanded path met something: the map's walls, or
                # something not on it (UNMAPPED_STOP); a pose that the map would stop is rarely not
                # stopped. Only a path the map surely leaves open or surely blocks weighs against a
                # pose: near a wall the robot's place within the lattice position decides (measured:
                # a robot stopped 2 cm from a pillar lost its true poses to a turned look-alike)
                if blocked:
                    fine = fine * np.where(self.lattice.blocked(deltas, maybe=True), 1.0, UNMAPPED_STOP)
                else:
                    fine = fine * np.where(self.lattice.blocked(deltas), FREE_PAST_WALL, 1.0)
            moved = self.lattice.predict(fine, [odometry], self.noise, window)
        else:
            deltas = self.motions.get(action)
            if deltas is None:
                return
            stuck = self.lattice.blocked(deltas)
            if blocked is None:
                goes = fine * (~stuck) * (1.0 - STAY)
                stays = fine * (stuck + STAY * ~stuck)
            elif blocked:  # stopped: a pose the map may stop stays (see above)
                goes = np.zeros_like(fine)
                stays = fine * np.where(self.lattice.blocked(deltas, maybe=True), 1.0, FLAG_FLOOR)
            else:
                goes = fine * np.where(stuck, FLAG_FLOOR, 1.0)
                stays = np.zeros_like(fine)
            moved = self.lattice.predict(goes, deltas, self.noise, window) if goes.any() else np.zeros_like(fine)
            if window is not None:
                moved[window[3]] += stays[window[3]]
            else:
                moved += stays
        total = moved.sum()
        if not total > 0:
            raise ImpossibleObservationError(f"{action}: the motion takes every pose the robot may be in off the map")
        self.fine = moved / total

    def peak_after(self, action: str) -> float:
        """The declared probability (:meth:`declared`) were the commanded move ``action`` made now
        and nothing read: how much of the reach the move's own noise leaves. The belief is not
        changed."""
        fine = self.fine
        try:
            self.predict(action, None, None)
            return self.declared()[1]
        except ImpossibleObservationError:
            return 0.0
        finally:
            self.fine = fine

    def declared_after(self, moves: Sequence[str], readings: Sequence[str | None]) -> list[float]:
        """For each of ``readings`` (None: no reading), the declared probability (the state's own
        reach, :meth:`state_reach`) expected after the commanded ``moves`` (with their noise,
        nothing reported, as :meth:`peak_after`) and that reading where they end: each joint
        reading's probability times the reach of the state the belief after it would declare.
        Worked out on the poses within :data:`NEAR_CELLS` cells of the most likely state after the
        moves: a belief near its declaration has next to nothing farther, and no reading makes a
        state farther than the promise the most likely one. The belief is not changed."""
        lattice = self.lattice
        k = lattice.k
        fine = self.fine
        if moves:
            # the moves worked out near the place alone: a move goes at most a cell's diagonal
            row, col, _heading = (int(v) for v in lattice.layout.cell_heading(int(np.argmax(self.belief))))
            reach = (NEAR_CELLS + 2 * len(moves)) * k
            window = lattice.window(
                slice(row * k - reach, row * k + k + reach), slice(col * k - reach, col * k + k + reach)
            )
        try:
            for move in moves:
                self.predict(move, None, None, window)
            moved = self.fine
        except ImpossibleObservationError:
            return [0.0] * len(readings)
        finally:
            self.fine = fine
        best = int(np.argmax(lattice.coarse(moved)))
        _g, r, c = lattice.image_indices
        row, col, _heading = (int(v) for v in lattice.layout.cell_heading(best))
        span = NEAR_CELLS * k + (k - 1) / 2
        near = np.flatnonzero(
            (np.abs(r - (row * k + (k - 1) / 2)) <= span) & (np.abs(c - (col * k + (k - 1) / 2)) <= span)
        )
        near = near[moved[near] > 0]
        return [self._declared_after_reading(best, near, moved[near], reading) for reading in readings]

    def _declared_after_reading(self, best: int, near: np.ndarray, weights: np.ndarray, reading: str | None) -> float:
        """:meth:`declared_after` for one reading, the belief ``weights`` on the poses ``near``
        (``best``: the most likely state before the reading)."""
        lattice = self.lattice
        tables = self.tables.get(reading, []) if reading is not None else []
        radius, turns = self._own_reach()
        g, r, c = lattice.image_indices
        unread = min(1.0, float(weights[self._within(best, g[near], r[near], c[near], radius, turns)].sum()))
        if not tables or not near.size:
            return unread
        joint = tables[0][near].astype(np.float64)
        for table in tables[1:]:
            joint = (joint[:, :, None] * table[near][:, None, :]).reshape(near.size, -1)
        seen = weights @ joint  # p(o), the near poses' share
        after = weights[:, None] * (joint**self.temper if self.temper != 1.0 else joint)
        totals = after.sum(axis=0)
        keep = (seen > 0) & (totals > 0)
        if not keep.any():
            return unread
        seen, after, totals = seen[keep], after[:, keep], totals[keep]
        # the most likely state after each reading: the poses' mass summed per state
        order = np.argsort(lattice.state[near], kind="stable")
        states = lattice.state[near][order]
        starts = np.flatnonzero(np.r_[True, states[1:] != states[:-1]])
        per_state = np.add.reduceat(after[order], starts, axis=0)
        declared = states[starts][np.argmax(per_state, axis=0)]
        peaks = np.zeros(seen.size)
        for state in np.unique(declared).tolist():
            columns = declared == state
            within = self._within(state, g[near], r[near], c[near], radius, turns)
            peaks[columns] = within @ after[:, columns] / totals[columns]
        return float(np.dot(seen, np.minimum(peaks, 1.0)) / seen.sum())

    # --- readings -------------------------------------------------------------------------------

    def likelihood(self, action: str, readings: Sequence[int], skip: Collection[int] = ()) -> np.ndarray:
        """``p(o | pose)`` at every valid pose for the part readings ``readings`` (the parts in
        ``skip`` left out)."""
        out = np.ones(self.lattice.n_poses)
        for part, (table, value) in enumerate(zip(self.tables[action], readings, strict=True)):
            if part not in skip:
                out *= table[:, value]
        return out

    def correct(
        self,
        action: str,
        readings: Sequence[int],
        log_likelihood: np.ndarray | None = None,
        replaces: Collection[int] = (),
    ) -> tuple[np.ndarray, float]:
        """Bayes' rule with the readings; ``(model belief, p(o | belief))``. Raises
        :class:`ImpossibleObservationError` when no pose could have read them.

        ``log_likelihood`` (per pose), when given, stands for the parts ``replaces`` in the update:
        a whole scan scored in full instead of its binned beams' tables (issue 27), tempered as the
        tables are. ``p(o | belief)`` stays the binned readings' own, so that what ``localize``'s
        fit checks compare it with (:meth:`probabilities`, :meth:`expected_log_likelihood`) is
        the same distribution."""
        likelihood = self.likelihood(action, readings)
        total = float(np.dot(self.fine, likelihood))
        if not total > 0:
            raise ImpossibleObservationError(f"{action}: no pose the robot may be at could read this")
        if log_likelihood is None:
            weighted = self.fine * likelihood**self.temper if self.temper != 1.0 else self.fine * likelihood
        else:
            own = likelihood if not replaces else self.likelihood(action, readings, replaces)
            with np.errstate(divide="ignore"):
                log = np.log(own) + np.asarray(log_likelihood, dtype=np.float64)
            held = (self.fine > 0) & np.isfinite(log)
            if not held.any():
                raise ImpossibleObservationError(f"{action}: no pose the robot may be at could read this scan")
            # relative to the best pose the robot may be at: no underflow however many beams
            weighted = np.where(
                held, self.fine * np.exp(self.temper * (np.where(held, log, 0.0) - log[held].max())), 0.0
            )
        self.fine = weighted / weighted.sum()
        return self.belief, total

    def probabilities(self, action: str, fine: np.ndarray | None = None) -> np.ndarray:
        """``p(o | belief)`` for every joint reading of ``action`` (the model's joint order: the
        first part's reading is the most significant digit); ``fine``: another lattice belief than
        the filter's."""
        tables = self.tables[action]
        if not tables:
            return np.ones(1)
        fine = self.fine if fine is None else fine
        support = np.flatnonzero(fine > 0)
        if len(tables) > 1 and support.size > SPARSE_SUPPORT * fine.size:
            return self._grouped_probabilities(action, fine)
        return joint_readings(tables, range(len(tables)), support, fine[support]).ravel()

    def _grouped_probabilities(self, action: str, fine: np.ndarray) -> np.ndarray:
        """:meth:`probabilities` over every pose, a group at a time (:func:`part_groups`): a group's
        parts at their common row are one outer product, the others a joint over its poses only. The
        depot's Look (six classes, 64 joint readings): most poses see none of the classes, and
        the whole joint per pose took 0.3 s a call."""
        tables = self.tables[action]
        groups = self._groups.get(action)
        if groups is None:
            groups = self._groups[action] = part_groups(tables)
        common, members = groups
        dims = [t.shape[1] for t in tables]
        out = np.zeros(dims)
        for parts, rows in members:
            weights = fine[rows]
            term = joint_readings(tables, parts, rows, weights).reshape(
                [dims[k] if k in parts else 1 for k in range(len(tables))]
            )
            for k, row in enumerate(common):
                if k not in parts:
                    term = term * row.reshape([dims[k] if j == k else 1 for j in range(len(tables))])
            out += term
        return out.ravel()

    def readings_after(self, places: Sequence[np.ndarray], moves: Sequence[str], action: str) -> list[np.ndarray]:
        """For each of ``places`` (model states): the distribution of ``action``'s joint reading were
        the robot there -- the belief restricted to the place's poses -- and the commanded ``moves``
        made first, each pose whose path the map blocks staying where it is (moved without noise,
        :meth:`PoseLattice.shifted`: a ranking, not a prediction). A place the moves take wholly off
        the map reads uniformly."""
        lattice = self.lattice
        out = []
        for states in places:
            fine = np.where(np.isin(lattice.state, states), self.fine, 0.0)
            for move in moves:
                deltas = self.motions.get(move)
                if deltas is not None:
                    stuck = lattice.blocked(deltas)
                    fine = lattice.shifted(fine * ~stuck, deltas) + fine * stuck
            total = float(fine.sum())
            if total > 0:
                out.append(self.probabilities(action, fine / total))
            else:
                n = int(np.prod([t.shape[1] for t in self.tables[action]]))
                out.append(np.full(n, 1.0 / n))
        return out

    def pose_successors(self, action: str) -> np.ndarray:
        """Per valid pose: the pose the commanded ``action`` takes it to without noise
        (:meth:`PoseLattice.successors`; itself for an action that does not move; computed once)."""
        out = self._successors.get(action)
        if out is None:
            deltas = self.motions.get(action)
            out = self.lattice.successors(deltas) if deltas is not None else np.arange(self.lattice.n_poses)
            self._successors[action] = out
        return out

    def expected_log_likelihood(self, action: str, fine: np.ndarray | None = None) -> float:
        """``-Σ_pose b(pose) H(O_a | pose)``: the mean log-likelihood of one reading of ``action`` were
        the robot where the belief says (``fine``: another lattice belief than the filter's)."""
        return -float(np.dot(self.fine if fine is None else fine, self._reading_entropy(action)))

    def _reading_entropy(self, action: str) -> np.ndarray:
        """``H(O_a | pose)`` at every valid pose (nats), computed once per action."""
        return self._reading_moments(action)[0]

    def _reading_moments(self, action: str) -> tuple[np.ndarray, np.ndarray]:
        """``(H(O_a | pose), Var[log p(O_a | pose)])`` at every valid pose, the parts independent
        (their entropies and variances add); computed once per action."""
        moments = self._entropy.get(action)
        if moments is None:
            entropy = np.zeros(self.lattice.n_poses)
            variance = np.zeros(self.lattice.n_poses)
            for table in self.tables[action]:
                h, v = row_moments(table)
                entropy += h
                variance += v
            moments = (entropy, variance)
            self._entropy[action] = moments
        return moments

    def log_likelihood_variance(self, action: str) -> float:
        """``Σ_pose b(pose) Var[log p(O_a | pose)]``: how much one reading's log-likelihood varies
        were the robot where the belief says."""
        return float(np.dot(self.fine, self._reading_moments(action)[1]))

    def information(self, action: str, fine: np.ndarray | None = None) -> float:
        """The expected information of one reading of ``action`` about the pose, in nats: the mutual
        information ``H(O_a) - Σ_pose b(pose) H(O_a | pose)`` under the lattice belief ``fine``
        (None: the filter's)."""
        fine = self.fine if fine is None else fine
        support = np.flatnonzero(fine > 0)
        if support.size > INFORMATION_POSES:
            # a systematic sample of the belief's poses, equally weighed (deterministic): the depot's
            # million poses read 64 looks each in 3.7 s; the sample in a tenth of that
            cdf = np.cumsum(fine[support])
            picks = np.searchsorted(cdf, (np.arange(INFORMATION_SAMPLE) + 0.5) / INFORMATION_SAMPLE * cdf[-1])
            poses, counts = np.unique(support[np.minimum(picks, support.size - 1)], return_counts=True)
            fine = np.zeros_like(fine)
            fine[poses] = counts / INFORMATION_SAMPLE
        return mutual_information(self.probabilities(action, fine), self.expected_log_likelihood(action, fine))

    def move_outlook(self, action: str, readings: Sequence[str]) -> tuple[float, list[float]]:
        """What the commanded move ``action`` would show (no odometry yet): the probability that it
        takes the robot somewhere (its path open on the map, :meth:`PoseLattice.blocked`), and the
        expected information (:meth:`information`) of each of ``readings`` taken where the robot
        lands, given that it moved (moved without noise, :meth:`PoseLattice.shifted`: a ranking of
        moves, 100x quicker than the noisy prediction). ``(0, zeros)`` for a move that surely stays or does not move."""
        deltas = self.motions.get(action)
        nothing = (0.0, [0.0] * len(readings))
        if deltas is None:
            return nothing
        goes = self.fine * ~self.lattice.blocked(deltas)
        p_moves = float(goes.sum())
        if not p_moves > 0:
            return nothing
        moved = self.lattice.shifted(goes / p_moves, deltas)
        total = float(moved.sum())
        if not total > 0:
            return nothing
        moved /= total
        return p_moves, [self.information(r, moved) for r in readings]

    def respread(self, weight: float = 0.5) -> np.ndarray:
        """Mix the belief with the uniform one over the valid poses (AMCL's recovery); the model's belief."""
        self.fine = (1.0 - weight) * self.fine + weight / self.lattice.n_poses
        self.fine /= self.fine.sum()
        return self.belief

    def declared(self) -> tuple[int, float]:
        """The state to declare and the probability that the robot is within its reach; the better
        (more mass) of two reaches, each inside the state's promise (:data:`PROMISE_CELLS`,
        :data:`PROMISE_SECTORS`) -- the second only with :attr:`mean_reach_too`:

        * **the state's own**: the most likely state, and the poses within :data:`REACH_CELLS`
          cells of its cell's centre and :data:`REACH_SECTORS` sectors of its heading
          (:meth:`state_reach`);
        * **the mean pose's**: the mean pose of the mass around the mode (the poses within the
          most likely state's promise: their mean position and circular-mean yaw), the state whose
          cell and sector hold that pose, and the poses within :data:`REACH_CELLS` cells and
          :data:`REACH_SECTORS` sectors of the mean pose that also lie -- with the whole square and
          yaw step each lattice pose stands for -- within the state's promise (:meth:`mean_reach`).
          A robot known to a few degrees but near a sector's edge has its mass split between two
          states' own reaches (the depot's 45° sectors: reaches of ±27° around sector centres,
          a belief 20° off one); the mean pose's reach follows the mass.

        The promise holds by construction: every pose counted by either reach lies within it, with
        the whole square and yaw step the lattice pose stands for (both reaches are clipped to it;
        the own reach is cut only where a cell has one lattice position), so the probability
        declared is at most the belief's probability that the robot is where ``simulate
        --continuous`` judges the declared state right. A robot on the border of
        two cells or sectors splits its mass between them however well its pose is known, and a
        corridor's readings place it along the corridor less well than across; the state's own
        mass says neither. (On a tie the state's own reach: the belief's most likely state, as
        every other report of the belief names it.)"""
        best = int(np.argmax(self.belief))
        own = self.state_reach(best)
        if not self.mean_reach_too:
            return best, own
        state, mass = self.mean_reach(best)
        return (state, mass) if mass > own * (1 + 1e-12) else (best, own)

    def state_reach(self, state: int) -> float:
        """The mass within :data:`REACH_CELLS` cells of ``state``'s cell centre and
        :data:`REACH_SECTORS` sectors of its heading."""
        return min(1.0, self._mass_around(state, *self._own_reach()))

    def _own_reach(self) -> tuple[float, int]:
        """A state's own reach in lattice steps: ``(radius, turns)``; a lattice pose's whole square
        and yaw step within the promise."""
        k, m = self.lattice.k, self.lattice.m
        radius = min(REACH_CELLS * k, PROMISE_CELLS * k - 1 / math.sqrt(2))
        turns = math.floor(min(REACH_SECTORS * m, PROMISE_SECTORS * m - 0.5) + 1e-9)
        return radius, turns

    def elsewhere(self, state: int) -> float:
        """The mass of the lattice poses beyond ``state``'s promise: farther than
        :data:`PROMISE_CELLS` cells from its cell's centre or :data:`PROMISE_SECTORS` sectors from
        its heading (a pose's own position and yaw; one on the edge counts as within). Were the
        robot there, declaring ``state`` would be the confidently wrong answer ``simulate
        --continuous`` counts: this is the belief's own probability of that."""
        k, m = self.lattice.k, self.lattice.m
        return max(0.0, 1.0 - self._mass_around(state, PROMISE_CELLS * k, math.floor(PROMISE_SECTORS * m + 1e-9)))

    def _mass_around(self, state: int, radius: float, turns: int) -> float:
        """The mass of the lattice poses within ``radius`` lattice steps of ``state``'s cell centre
        (a disc) and ``turns`` lattice yaws of its heading (every yaw with one heading)
        (:meth:`_within`), summed over a box of the lattice image."""
        lattice = self.lattice
        row, col, _heading = (int(v) for v in lattice.layout.cell_heading(state))
        k = lattice.k
        G, rows, cols = lattice.shape
        half = (k - 1) / 2  # the cell centre's offset from its first lattice position
        lo, hi = math.ceil(half - radius - 1e-9), math.floor(half + radius + 1e-9)
        r = np.arange(max(0, row * k + lo), min(rows, row * k + hi + 1))
        c = np.arange(max(0, col * k + lo), min(cols, col * k + hi + 1))
        if not (r.size and c.size):
            return 0.0
        box = lattice.image_of(self.fine)[:, r[0] : r[-1] + 1, c[0] : c[-1] + 1]
        inside = self._within(state, np.arange(G)[:, None, None], r[None, :, None], c[None, None, :], radius, turns)
        return float((box * inside).sum())

    def _within(self, state: int, g: np.ndarray, r: np.ndarray, c: np.ndarray, radius: float, turns: int) -> np.ndarray:
        """Whether the lattice poses at yaw index ``g``, row ``r`` and column ``c`` (arrays that
        broadcast) lie within ``radius`` lattice steps of ``state``'s cell centre and ``turns``
        lattice yaws of its heading (every yaw with one heading)."""
        lattice = self.lattice
        row, col, heading = (int(v) for v in lattice.layout.cell_heading(state))
        k, G = lattice.k, lattice.shape[0]
        half = (k - 1) / 2
        near: np.ndarray = np.hypot(r - (row * k + half), c - (col * k + half)) <= radius + 1e-9
        if lattice.layout.headings == 1:
            return near
        offset = (g - heading * lattice.m + G // 2) % G - G // 2
        out: np.ndarray = near & (offset >= -min(turns, G // 2)) & (offset <= min(turns, (G - 1) // 2))
        return out

    def mean_reach(self, mode: int) -> tuple[int, float]:
        """The state holding the mean pose of the mass within ``mode``'s promise, and the mass within
        :data:`REACH_CELLS` cells and :data:`REACH_SECTORS` sectors of that mean pose whose lattice
        squares and yaw steps lie wholly within the state's promise (see :meth:`declared`). ``mode``
        itself when the mean pose's cell is no state's."""
        lattice = self.lattice
        layout = lattice.layout
        k = lattice.k
        _G, rows, cols = lattice.shape
        cell, spacing = layout.cell_size, lattice.spacing
        sector = 2 * math.pi / layout.headings
        turning = layout.headings > 1
        row, col, _heading = (int(v) for v in layout.cell_heading(mode))
        # a window of the lattice image around the mode's cell that holds every pose either step
        # below looks at: the mean lies within the mode's promise, the reach within the state's
        w = math.ceil((2 * PROMISE_CELLS + 1) * k) + 1
        r = np.arange(max(0, row * k - w), min(rows, row * k + k + w))
        c = np.arange(max(0, col * k - w), min(cols, col * k + k + w))
        box = lattice.image_of(self.fine)[:, r[0] : r[-1] + 1, c[0] : c[-1] + 1]
        x = ((c + 0.5) * spacing)[None, None, :]
        y = ((rows - r - 0.5) * spacing)[None, :, None]
        yaws = lattice.yaws()[:, None, None]

        def within(cx: float, cy: float, cyaw: float, cells: float, sectors: float) -> np.ndarray:
            near: np.ndarray = np.hypot(x - cx, y - cy) <= cells * cell + 1e-9
            if not turning:
                return near
            out: np.ndarray = near & (
                np.abs(np.remainder(yaws - cyaw + math.pi, 2 * math.pi) - math.pi) <= sectors * sector + 1e-9
            )
            return out

        centre = self._centre
        around = box * within(*centre(mode), PROMISE_CELLS, PROMISE_SECTORS)
        total = float(around.sum())
        if not total > 0:
            return mode, 0.0
        mx = float((around * x).sum()) / total
        my = float((around * y).sum()) / total
        myaw = (
            math.atan2(float((around * np.sin(yaws)).sum()), float((around * np.cos(yaws)).sum())) if turning else 0.0
        )
        s_heading = round((math.pi / 2 - myaw) / sector) % layout.headings if turning else 0
        state = layout.state_of(layout.rows - 1 - math.floor(my / cell), math.floor(mx / cell), s_heading)
        if state < 0:
            return mode, 0.0
        # a lattice pose stands for a square of side `spacing` and a yaw step: all of it within the promise
        reach = within(mx, my, myaw, REACH_CELLS, REACH_SECTORS) & within(
            *centre(state),
            PROMISE_CELLS - spacing / math.sqrt(2) / cell,
            PROMISE_SECTORS - lattice.yaw_step / 2 / sector,
        )
        return state, min(1.0, float((box * reach).sum()))

    def _centre(self, state: int) -> tuple[float, float, float]:
        """``state``'s cell centre and heading yaw in the grid frame (the lattice yaw at its sector's middle)."""
        layout = self.lattice.layout
        row, col, heading = (int(v) for v in layout.cell_heading(state))
        yaw = float(self.lattice.yaws()[heading * self.lattice.m])
        return (col + 0.5) * layout.cell_size, (layout.rows - row - 0.5) * layout.cell_size, yaw

    def pose_estimate(self, state: int) -> tuple[tuple[float, float, float], np.ndarray]:
        """Where the robot is, finer than ``state``'s cell centre and heading: the mean position and
        circular-mean yaw of the mass within ``state``'s promise (:data:`PROMISE_CELLS`,
        :data:`PROMISE_SECTORS`), in the grid frame (metres; yaw counter-clockwise from the grid's
        +x); and the whole belief's ``3 x 3`` covariance over ``(x, y, yaw)`` about its own mean, by
        the law of total covariance over the lattice poses as :func:`beliefloc.pose.belief_pose`
        takes it over states: the spread between poses plus the square (``spacing² / 12`` a side)
        and yaw step (``step² / 12``) each pose stands for. With one heading the yaw is unknown: 0,
        its variance that of a uniform yaw, no cross terms.

        The state's own pose is a cell centre and a sector's middle: on the depot's 0.25 m cells
        and 45° sectors a robot known to 5 cm and 5° is reported up to 18 cm and 22° off, and AMCL
        starts from that."""
        lattice, layout = self.lattice, self.lattice.layout
        poses = lattice.pose_array
        weight = self.fine / self.fine.sum()
        turning = layout.headings > 1
        cell, sector = layout.cell_size, 2 * math.pi / layout.headings
        cx, cy, heading_yaw = self._centre(state)
        place = np.hypot(poses[:, 0] - cx, poses[:, 1] - cy) <= PROMISE_CELLS * cell + 1e-9
        if turning:
            place &= np.abs(wrap_angle(poses[:, 2] - heading_yaw)) <= PROMISE_SECTORS * sector + 1e-9
        held = weight * place
        yaw = heading_yaw if turning else 0.0
        x, y = cx, cy  # nothing within the promise: the state's own pose
        if held.sum() > 0:
            x, y = (float(held @ poses[:, i]) / float(held.sum()) for i in (0, 1))
            yaw = circular_mean(held, poses[:, 2], yaw) if turning else 0.0

        mean_x, mean_y = float(weight @ poses[:, 0]), float(weight @ poses[:, 1])
        dx, dy = poses[:, 0] - mean_x, poses[:, 1] - mean_y
        cov = np.zeros((3, 3))
        within = lattice.spacing**2 / 12.0
        cov[0, 0] = float(weight @ (dx * dx)) + within
        cov[1, 1] = float(weight @ (dy * dy)) + within
        cov[0, 1] = cov[1, 0] = float(weight @ (dx * dy))
        if turning:
            dyaw = wrap_angle(poses[:, 2] - circular_mean(weight, poses[:, 2], yaw))
            cov[2, 2] = float(weight @ (dyaw * dyaw)) + lattice.yaw_step**2 / 12.0
            cov[0, 2] = cov[2, 0] = float(weight @ (dx * dyaw))
            cov[1, 2] = cov[2, 1] = float(weight @ (dy * dyaw))
        else:
            cov[2, 2] = math.pi**2 / 3
        return (x, y, yaw), cov

    def peak(self) -> float:
        """The probability compared with the threshold: :meth:`declared`'s."""
        return self.declared()[1]
