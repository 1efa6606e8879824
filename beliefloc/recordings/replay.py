"""Replaying a recording through the grid filter: the belief over a whole run.

:func:`track_recording` feeds each scan of a :class:`~beliefloc.recordings.reader.Recording` to a
:class:`~beliefloc.continuous.grid_filter.GridFilter` in stamp order: the odometry pose interpolated
at the scan's stamp, the base's turn during the sweep (de-skew: each beam rotated by the yaw the
base had turned when it was measured), the update gate. The result is a :class:`TrackResult`: one
timeline entry per filter update, the final verdict, pose and covariance, and the modes left when
the run did not say enough.

No I/O: the recording is already read.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from beliefloc.continuous.grid_filter import FilterConfig, FilterMode, GridFilter, Update
from beliefloc.continuous.likelihood_field import Scan, select_beams
from beliefloc.continuous.motion import compose, relative
from beliefloc.model import GridLayout
from beliefloc.recordings.reader import Recording
from beliefloc.semantic_map.occupancy_map import OccupancyMap


@dataclass(frozen=True)
class TrackResult:
    """The belief over a recorded run."""

    updates: tuple[Update, ...]
    localized: bool
    """The final verdict: one mode holds the threshold and the last scans fit it."""
    localized_at: int | None
    """The stamp (ns) of the first update of the final localized streak, or None."""
    pose: tuple[float, float, float]
    """Map-frame ``(x, y, yaw)`` at the last scan: the last update's refined pose moved by the
    odometry since that update (scans the gate let pass still move the robot)."""
    covariance: np.ndarray
    """6x6, ROS's ``PoseWithCovariance`` layout."""
    modes: tuple[FilterMode, ...]
    """The final belief's modes (the first refined), most probable first."""
    reason: str | None
    """Why the run ended not localized; None when localized."""
    scans: int
    """Scans read (updates are the scans the gate let through)."""

    def as_json(self) -> dict[str, object]:
        """``{"localized", "pose": {x, y, yaw, covariance}, "timeline": [...]}`` -- the shape of
        ``track --bag --json``; ``"modes"`` and ``"reason"`` are added when not localized."""
        x, y, yaw = self.pose
        out: dict[str, object] = {
            "localized": self.localized,
            "pose": {"x": x, "y": y, "yaw": yaw, "covariance": [float(v) + 0.0 for v in self.covariance.ravel()]},
            "timeline": [u.as_json() for u in self.updates],
        }
        if not self.localized:
            out["modes"] = [m.as_json() for m in self.modes]
            out["reason"] = self.reason
        return out


def filter_for(occupancy: OccupancyMap, recording: Recording, config: FilterConfig) -> GridFilter:
    """A filter whose lattice reaches the recording's longest beam from the base."""
    range_max = max(s.range_max for s in recording.scans)
    if config.laser.laser_max_range is not None:
        range_max = min(range_max, config.laser.laser_max_range)
    reach = range_max + math.hypot(recording.mount[0], recording.mount[1]) + 0.05
    return GridFilter(occupancy, config, reach=reach)


def track_recording(
    occupancy: OccupancyMap,
    recording: Recording,
    config: FilterConfig,
    *,
    on_scan: Callable[[int, Update | None], None] | None = None,
    grid_filter: GridFilter | None = None,
) -> TrackResult:
    """Run the filter over every scan of ``recording``; ``on_scan(stamp, update or None)`` is
    called after each scan (for a progress bar)."""
    grid = grid_filter or filter_for(occupancy, recording, config)
    stamps = np.array([s.stamp for s in recording.scans], dtype=np.int64)
    odometry = recording.odometry_at(stamps)
    updates: list[Update] = []
    for n, message in enumerate(recording.scans):
        rate = recording.yaw_rate(message.stamp)
        update: Update | None = None
        if grid.wants_update(odometry[n], rate):
            scan = Scan(
                message.angle_min, message.angle_increment, message.ranges, message.range_min, message.range_max
            )
            beams = select_beams(scan, config.laser, recording.mount, recording.yaw_offsets(message))
            update = grid.update(message.stamp, odometry[n], beams)
            updates.append(update)
        if on_scan is not None:
            on_scan(message.stamp, update)
    last = updates[-1]
    localized = last.localized
    localized_at = None
    if localized:
        first = len(updates) - 1
        while first > 0 and updates[first - 1].localized:
            first -= 1
        localized_at = updates[first].stamp
    reason: str | None = None
    if not localized:
        if last.max_probability < config.threshold:
            count = len(last.modes)
            reason = (
                f"no place holds {config.threshold:g} of the belief: the best holds {last.max_probability:.3f}, "
                f"{count} mode{'s' if count != 1 else ''} remain"
            )
        elif grid.fit.why_not() is not None:
            reason = grid.fit.why_not()
        else:
            rival = grid.rivals[0] if grid.rivals else None
            where = f" (near x {rival[0]:.2f}, y {rival[1]:.2f}, yaw {rival[2]:.2f})" if rival else ""
            reason = (
                f"another place{where} explains the last scans about as well as the best pose (by "
                f"{last.rival_gap:.1f} nats, {config.rival_margin:g} per beam needed): the run did not tell them apart"
            )
    # the pose at the end of the bag: the last update's, moved by the odometry since
    since = relative(grid.last_odometry, odometry[-1]) if grid.last_odometry is not None else np.zeros(3)
    end = compose(np.array([[last.x, last.y, last.yaw]]), since)[0]
    return TrackResult(
        updates=tuple(updates),
        localized=localized,
        localized_at=localized_at,
        pose=(float(end[0]), float(end[1]), float(end[2])),
        covariance=grid.covariance((last.x, last.y, last.yaw)),
        modes=last.modes,
        reason=reason,
        scans=len(recording.scans),
    )


def belief_on_layout(grid: GridFilter, layout: GridLayout) -> np.ndarray:
    """The filter's belief moved onto another grid's states (a beliefloc map's, for ``pose``): each
    filter state's mass goes to the layout cell holding its cell's centre and the layout heading
    nearest its yaw; mass on a cell that is not a state of the layout is dropped and the rest
    renormalised (uniform if nothing is left). A vector over ``layout``'s states (free cells in
    row-major order times headings)."""
    b = grid.belief
    k, r, c = np.nonzero(b)
    mass = b[k, r, c]
    rows, cols = layout.cell_at(grid.cell_x[r, c], grid.cell_y[r, c])
    if layout.headings > 1:
        step = 2 * math.pi / layout.headings
        # layout heading h has map yaw frame.yaw + pi/2 - h step; invert and round
        h = np.rint((layout.frame.yaw + math.pi / 2 - grid.map_yaws[k]) / step).astype(np.int64) % layout.headings
    else:
        h = np.zeros_like(k)
    inside = (rows >= 0) & (rows < layout.rows) & (cols >= 0) & (cols < layout.cols)
    rows, cols, h, mass = rows[inside], cols[inside], h[inside], mass[inside]
    free = layout.free[rows, cols]
    rows, cols, h, mass = rows[free], cols[free], h[free], mass[free]
    cell = np.searchsorted(layout.free_cells, rows * layout.cols + cols)
    n_states = len(layout.free_cells) * layout.headings
    out = np.bincount(cell * layout.headings + h, weights=mass, minlength=n_states)
    total = float(out.sum())
    if not total > 0:
        return np.full(n_states, 1.0 / n_states)
    projected: np.ndarray = out / total
    return projected
