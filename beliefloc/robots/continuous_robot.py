"""A continuous simulated robot behind ``localize``'s robot interface (issue 26).

:class:`ContinuousReadingRobot` answers :class:`~beliefloc.robots.localize.Command` s as a robot on
the line protocol would: it executes the action message's ``motion`` on a
:class:`~beliefloc.continuous.world.ContinuousRobot` (a true pose anywhere, motion noise, stopped
where the map or clutter blocks it), then reads its sensors from the true pose -- Scan beams ray-cast
with range noise on the world's image (clutter included), Look detections by field of view, range and
line of sight -- and reports its odometry and whether it was blocked (:class:`MotionReport`). It works
from the same action message the line protocol sends (:func:`~beliefloc.robots.line_protocol.action_message`),
so an episode in process and one through :class:`~beliefloc.robots.line_protocol.LineRobot` are the
same episode.

With ``full_scans=n`` a scan sensor answers a whole scan of ``n`` beams around the robot (the
reply form of issue 27: ``angle_min``, ``angle_increment``, ``ranges`` with ``null`` for no return,
``range_min``, ``range_max``; a return nearer than ``range_min`` as 0), as a lidar does.

Headings: the robot knows its own yaw; on an 8-heading grid it drives ``advance_diagonal`` when its
yaw is nearer a diagonal heading (the protocol's contract).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from beliefloc.continuous.world import ContinuousRobot, laser_pose
from beliefloc.errors import InvalidValueError
from beliefloc.model import GridLayout
from beliefloc.robots.localize import Command
from beliefloc.robots.odometry import MotionReport
from beliefloc.robots.readings import RawReading, ReadingBinner
from beliefloc.semantic_map.schema import SemanticMap


class ContinuousReadingRobot:
    """See the module. ``landmarks``: map-frame ``(class, x, y)``; ``report_odometry``: whether replies
    carry odometry (else only the blocked flag, or nothing with ``report_blocked=False``: protocol 1)."""

    def __init__(
        self,
        robot: ContinuousRobot,
        smap: SemanticMap,
        binner: ReadingBinner,
        *,
        report_odometry: bool = True,
        report_blocked: bool = True,
        full_scans: int = 0,
    ) -> None:
        if full_scans < 0:
            raise InvalidValueError(f"full_scans: {full_scans} is not a number of beams (0: the map's beams only)")
        self.full_scans = full_scans
        self.robot = robot
        self.smap = smap
        self.binner = binner
        grid = binner.model.grid
        if grid is None:
            raise InvalidValueError("a continuous robot needs a model with a grid")
        self.grid: GridLayout = grid
        self.report_odometry = report_odometry
        self.report_blocked = report_blocked
        self._report: MotionReport | None = None

    def motion_report(self) -> MotionReport | None:
        return self._report

    def act(self, command: Command) -> Mapping[str, RawReading]:
        from beliefloc.robots.line_protocol import action_message

        return self.answer(action_message(command, self.binner))

    def answer(self, message: Mapping[str, Any]) -> dict[str, RawReading]:
        """Execute an ``action`` message (as the line protocol sends it); the raw readings."""
        self._report = None
        motion = message.get("motion")
        if motion:
            measured, blocked = self.robot.drive(self._command(motion))
            odometry = tuple(float(v) for v in measured) if self.report_odometry else None
            if odometry is not None or self.report_blocked:
                self._report = MotionReport(odometry, blocked if self.report_blocked else None)  # type: ignore[arg-type]
        return {sensor["name"]: self._read(sensor) for sensor in message.get("sensors", [])}

    def reply(self, message: Mapping[str, Any]) -> dict[str, Any]:
        """The line-protocol reply to ``message`` (JSON-ready)."""
        readings = self.answer(message)
        out: dict[str, Any] = {"seq": message["seq"], "readings": readings}
        if self._report is not None:
            if self._report.odometry is not None:
                dx, dy, dyaw = self._report.odometry
                out["odometry"] = {"dx": dx, "dy": dy, "dyaw": dyaw}
            if self._report.blocked is not None:
                out["blocked"] = self._report.blocked
        return out

    # --- motion ---------------------------------------------------------------------------------

    def _heading(self) -> int:
        grid = self.grid
        step = 2 * math.pi / grid.headings
        offset = grid.frame.yaw + math.pi / 2 - float(self.robot.pose[2])
        return round(offset / step) % grid.headings

    def _command(self, motion: Mapping[str, float]) -> tuple[float, float, float]:
        if "turn" in motion:
            return (0.0, 0.0, float(motion["turn"]))
        if "advance" in motion:
            diagonal = "advance_diagonal" in motion and self._heading() % 2 == 1
            return (float(motion["advance_diagonal" if diagonal else "advance"]), 0.0, 0.0)
        yaw = float(self.robot.pose[2])  # a compass move in map-frame metres, into the robot frame
        x, y = float(motion["x"]), float(motion["y"])
        return (math.cos(yaw) * x + math.sin(yaw) * y, -math.sin(yaw) * x + math.cos(yaw) * y, 0.0)

    # --- sensors --------------------------------------------------------------------------------

    def _read(self, sensor: Mapping[str, Any]) -> RawReading:
        spec = self.smap.sensors[sensor["name"]]
        kind = sensor["type"]
        if kind == "scan":
            return self._scan(spec)
        if kind == "look":
            return self._look(spec)
        raise InvalidValueError(f"sensor {sensor['name']!r}: a continuous robot has no {kind} sensor")

    def _scan(self, spec: Any) -> list[float | None] | dict[str, Any]:
        pose = self.robot.pose
        mount = self.robot.world.config.laser.mount
        if any(mount):  # a laser off the base's centre or turned on it (unknown to the map): it reads from there
            pose = laser_pose(pose.reshape(1, 3), mount)[0]
        if self.full_scans:
            n = self.full_scans
            laser = self.robot.world.config.laser
            increment = 2 * math.pi / n
            ranges = self.robot.world.scan_ranges(
                np.repeat(pose.reshape(1, 3), n, axis=0), -math.pi + increment * np.arange(n)
            )
            return {
                "angle_min": -math.pi,
                "angle_increment": increment,
                "ranges": [None if r == math.inf else max(float(r), 0.0) for r in ranges],
                "range_min": laser.range_min,
                "range_max": laser.range_max,
            }
        angles = np.radians(np.asarray(spec.beams, dtype=np.float64))  # counter-clockwise, as the laser's
        ranges = self.robot.world.scan_ranges(np.repeat(pose.reshape(1, 3), len(angles), axis=0), angles)
        return [None if r == math.inf else max(float(r), 0.0) for r in ranges]

    def _look(self, spec: Any) -> list[str] | dict[str, float]:
        x, y, yaw = (float(v) for v in self.robot.pose)
        fov = math.radians(spec.effective_fov(self.grid.headings)) / 2
        seen: dict[str, float] = {}
        for landmark in self.smap.landmarks:
            if landmark.class_ not in spec.classes:
                continue
            lx, ly = self._landmark_xy(landmark)
            d = math.hypot(lx - x, ly - y)
            angle = abs(math.remainder(math.atan2(ly - y, lx - x) - yaw, 2 * math.pi)) if d > 1e-9 else 0.0
            if self.grid.headings == 1:
                angle = 0.0
            if angle > fov + 1e-9 or (spec.range is not None and d > spec.range):
                continue
            if spec.occlusion and d > 1e-9:
                free = float(self.robot.world.cast(x, y, math.atan2(ly - y, lx - x), d + 1.0))
                if free < d - self.robot.world.image.resolution:
                    continue
            seen[landmark.class_] = min(seen.get(landmark.class_, math.inf), angle)
        if spec.angle_bins:
            return seen
        return sorted(seen)

    def _landmark_xy(self, landmark: Any) -> tuple[float, float]:
        if landmark.position is not None:
            return float(landmark.position[0]), float(landmark.position[1])
        r, c = landmark.cell
        s = self.grid.cell_size
        gx, gy = (c + 0.5) * s, (self.grid.rows - r - 0.5) * s
        mx, my = self.grid.frame.to_map(gx, gy)
        return float(mx), float(my)
