"""The motion controller of the live link: one action as a short ``/cmd_vel`` motion closed on
odometry. Pure functions, no I/O: :mod:`beliefloc.ros.bridge` feeds them each odometry message.

A motion is a straight drive of ``distance`` metres (negative: backwards) or a turn in place of
``angle`` radians (counter-clockwise positive, REP 103), measured from the odometry pose where it
started (``progress = start ⊖ now``, the base's own frame at the start):

* **drive**: ``v = sign · clamp(gain · remaining, min_speed, max_speed)`` along the heading, and a
  heading hold ``ω = clamp(-gain · Δyaw, ±max_turn)`` so that the base goes straight;
* **turn**: ``ω = sign · clamp(gain · remaining, min_turn, max_turn)``;

done when the remaining distance or angle is within ``tolerance`` / ``turn_tolerance`` (or passed:
a motion never reverses to correct an overshoot; the odometry reports what was done). A proportional
slow-down with a floor is all a differential base needs for moves of a cell and turns of a heading;
the floor keeps the base from creeping at the end.

The obstacle stop (:func:`obstacle_ahead`): a drive stops when a return of the scan lies in the
corridor the base sweeps next: ahead (behind, going backwards) within ``radius + margin`` of the
base's centre and within ``radius`` of its centre line.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from beliefloc.errors import InvalidValueError


@dataclass(frozen=True)
class MotionLimits:
    """Speed limits and gains of the controller. Defaults: a TurtleBot's gentle speeds."""

    max_speed: float = 0.2
    """m/s: the fastest straight drive."""
    max_turn: float = 0.6
    """rad/s: the fastest turn."""
    min_speed: float = 0.03
    """m/s: the slowest drive near the goal (a base may not move at all below some speed)."""
    min_turn: float = 0.1
    """rad/s: the slowest turn near the goal."""
    gain: float = 1.5
    """1/s: velocity per unit of remaining distance or angle."""
    tolerance: float = 0.01
    """Metres: a drive is done this near its goal."""
    turn_tolerance: float = math.radians(1.0)
    """Radians: a turn is done this near its goal."""

    def __post_init__(self) -> None:
        for name in ("max_speed", "max_turn", "min_speed", "min_turn", "gain", "tolerance", "turn_tolerance"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise InvalidValueError(f"MotionLimits.{name} must be a number > 0, got {value}")
        if self.min_speed > self.max_speed or self.min_turn > self.max_turn:
            raise InvalidValueError("MotionLimits: a minimum speed is above its maximum")


@dataclass(frozen=True)
class Goal:
    """One motion: ``kind`` ``"drive"`` (``amount`` metres, forward positive) or ``"turn"`` (radians,
    counter-clockwise positive)."""

    kind: str
    amount: float

    def done_fraction(self, progress: tuple[float, float, float]) -> float:
        """How much of the goal ``progress`` (``(dx, dy, dyaw)`` from the start, unwrapped yaw for a
        turn) covers, signed: 1 is all of it, 0 nothing, negative the wrong way."""
        if self.amount == 0:
            return 1.0
        done = progress[0] if self.kind == "drive" else progress[2]
        return done / self.amount


def velocity(goal: Goal, progress: tuple[float, float, float], limits: MotionLimits) -> tuple[float, float] | None:
    """``(forward m/s, turn rad/s)`` toward ``goal`` after ``progress`` (see :meth:`Goal.done_fraction`),
    or None when the goal is reached (see the module)."""
    sign = 1.0 if goal.amount >= 0 else -1.0
    if goal.kind == "drive":
        remaining = (goal.amount - progress[0]) * sign
        if remaining <= limits.tolerance:
            return None
        speed = min(max(limits.gain * remaining, limits.min_speed), limits.max_speed)
        hold = min(max(-limits.gain * progress[2], -limits.max_turn), limits.max_turn)
        return sign * speed, hold
    remaining = (goal.amount - progress[2]) * sign
    if remaining <= limits.turn_tolerance:
        return None
    turn = min(max(limits.gain * remaining, limits.min_turn), limits.max_turn)
    return 0.0, sign * turn


def obstacle_ahead(
    points: np.ndarray | Iterable[tuple[float, float]], forward: bool, radius: float, margin: float
) -> float | None:
    """The distance of the nearest scan point (base frame, shape ``(N, 2)``) in the corridor the
    base drives into next (see the module), or None when it is clear."""
    xy = np.asarray(list(points) if not isinstance(points, np.ndarray) else points, dtype=np.float64).reshape(-1, 2)
    along = xy[:, 0] if forward else -xy[:, 0]
    inside = (along > 0.0) & (along <= radius + margin) & (np.abs(xy[:, 1]) <= radius)
    if not inside.any():
        return None
    return float(np.hypot(xy[inside, 0], xy[inside, 1]).min())
