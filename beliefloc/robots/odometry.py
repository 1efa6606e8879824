"""What the robot says it did: odometry and a blocked flag in a ``localize`` reply (issue 26).

A reply to a move may carry ``"odometry": {"dx": m, "dy": m, "dyaw": rad}`` -- the motion the wheels
measured since the previous reply, in the robot frame at that reply (REP 103: x forward, y left, yaw
counter-clockwise) -- and ``"blocked": true/false`` (the move was stopped by something). Replies
without them are protocol 1's and keep working: the belief is predicted by the commanded action's
``T_a``.

* **Odometry given**: the belief is predicted by the measured motion under the odometry noise model
  (Probabilistic Robotics Table 5.6, AMCL's alpha1..4: :func:`beliefloc.continuous.motion.predict_grid`,
  a shift and a blur per heading), not by ``T_a``; mass moved onto cells that are not states is
  dropped (the robot is somewhere it can be).
* **Only a blocked flag**: ``T_a[i, i]`` is the probability that the move leaves state ``i`` where it
  is (a wall, a removed cell, a failure). ``blocked: true`` weighs each state by it (at least
  :data:`FLAG_FLOOR`: the flag itself may be wrong) and the robot stayed; ``blocked: false`` weighs
  by ``1 - T_a[i, i]`` (same floor), then predicts by ``T_a``.

Bad values (NaN, infinite, beyond what the action could do, a flag on a perception action) are
refused by :func:`parse_report` with a message naming the field.

Pure numpy, no I/O.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from beliefloc.belief import predict
from beliefloc.errors import InvalidValueError
from beliefloc.model import Action, GridLayout

FLAG_FLOOR = 0.01
"""The least weight a state keeps when the blocked flag contradicts it."""
REACH = 3.0
"""Odometry may report at most this many times the commanded move's length (the cell's diagonal
for a move, half a turn more for a rotation); more is absurd."""


@dataclass(frozen=True)
class MotionReport:
    """What the robot said it did for one action."""

    odometry: tuple[float, float, float] | None = None
    blocked: bool | None = None


@runtime_checkable
class ReportingRobot(Protocol):
    """A robot that can say what it did after :meth:`act` (the line protocol's :class:`LineRobot`)."""

    def motion_report(self) -> MotionReport | None: ...


def parse_report(data: Mapping[str, object], action: Action, grid: GridLayout | None) -> MotionReport | None:
    """The ``odometry`` and ``blocked`` keys of a reply (None when neither is there). Raises
    :class:`InvalidValueError` naming the field for a value that cannot be used."""
    if "odometry" not in data and "blocked" not in data:
        return None
    if not action.is_actuation:
        key = "odometry" if "odometry" in data else "blocked"
        raise InvalidValueError(f"'{key}': {action.name} is a perception action; only a move may report {key}")
    odometry = None
    if "odometry" in data:
        raw = data["odometry"]
        if not isinstance(raw, dict) or set(raw) != {"dx", "dy", "dyaw"}:
            raise InvalidValueError('\'odometry\' should be an object {"dx": m, "dy": m, "dyaw": rad}')
        values = []
        for key in ("dx", "dy", "dyaw"):
            value = raw[key]
            if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
                raise InvalidValueError(f"'odometry.{key}' should be a finite number, got {value!r}")
            values.append(float(value))
        step = grid.cell_size * math.sqrt(2.0) if grid is not None else math.inf
        if math.hypot(values[0], values[1]) > REACH * step:
            raise InvalidValueError(
                f"'odometry': a motion of {math.hypot(values[0], values[1]):.3g} m is beyond what {action.name} "
                f"could do (at most {REACH:g} × {step:.3g} m)"
            )
        if abs(values[2]) > math.pi:
            raise InvalidValueError(f"'odometry.dyaw' should be within [-pi, pi] radians, got {values[2]!r}")
        odometry = (values[0], values[1], values[2])
    blocked = None
    if "blocked" in data:
        flag = data["blocked"]
        if not isinstance(flag, bool):
            raise InvalidValueError(f"'blocked' should be true or false, got {flag!r}")
        blocked = flag
    return MotionReport(odometry, blocked)


def predict_reported(
    action: Action, belief: np.ndarray, report: MotionReport | None, grid: GridLayout | None, noise: object = None
) -> np.ndarray:
    """The belief after ``action`` given what the robot reported (see the module); ``T_a`` when it
    reported nothing."""
    if report is None or grid is None:
        return predict(action, belief)
    if report.odometry is not None:
        return predict_odometry(belief, grid, report.odometry, noise)
    if report.blocked is None:
        return predict(action, belief)
    assert action.transition is not None
    stays = np.asarray(action.transition.diagonal(), dtype=np.float64)
    weight = np.maximum(stays if report.blocked else 1.0 - stays, FLAG_FLOOR)
    weighted = belief * weight
    weighted /= weighted.sum()
    if report.blocked:
        return weighted
    return predict(action, weighted)


def predict_odometry(
    belief: np.ndarray, grid: GridLayout, delta: tuple[float, float, float], noise: object = None
) -> np.ndarray:
    """``belief`` (states ``cell * H + h``) predicted by the odometry ``delta`` with
    :func:`beliefloc.continuous.motion.predict_grid`."""
    from beliefloc.continuous.motion import OdometryNoise, grid_yaws, predict_grid

    odometry_noise = noise if isinstance(noise, OdometryNoise) else OdometryNoise()
    H = grid.headings
    rows, cols = np.divmod(grid.free_cells, grid.cols)
    image = np.zeros((H, grid.rows, grid.cols))
    per_state = belief.reshape(-1, H)  # (cells, headings)
    image[:, rows, cols] = per_state.T
    yaws = grid_yaws(H) if H > 1 else np.array([math.pi / 2])
    moved = predict_grid(image, yaws, grid.cell_size, delta, odometry_noise, free=grid.free)
    out: np.ndarray = moved[:, rows, cols].T.reshape(-1)
    total = out.sum()
    if not total > 0:  # everything moved off the states: the odometry disagrees with the map
        raise InvalidValueError("'odometry': the reported motion takes every state the robot may be in off the map")
    out /= total
    return out


def motion(grid: GridLayout | None, action: Action) -> dict[str, float] | None:
    """What an actuation action asks the robot to do, in metres and radians (counter-clockwise
    positive): ``{"turn": θ}`` for a rotation (``2π/headings``), ``{"advance": ±s}`` for forward and
    backward (one cell of ``s`` metres along the heading), ``{"x": dx, "y": dy}`` for a compass move
    (map-frame metres). None for a perception action or a model without a grid.

    **Diagonals.** beliefloc does not know the robot's heading, and on an 8-heading grid a move
    along a diagonal heading goes to the diagonal neighbour's centre (``s·√2`` away, as the model's
    ``T_a`` says). The message therefore carries both distances on an 8-heading grid:
    ``{"advance": ±s, "advance_diagonal": ±s·√2}``; the robot drives ``advance_diagonal`` when its
    heading is a diagonal one (NE, SE, SW, NW), ``advance`` otherwise: always to the centre of the
    next cell along its heading."""
    if grid is None or not action.is_actuation:
        return None
    step = grid.cell_size
    if action.name in ("rotate_cw", "rotate_ccw"):
        turn = 2 * math.pi / grid.headings
        return {"turn": turn if action.name == "rotate_ccw" else -turn}
    if action.name in ("forward", "backward"):
        sign = 1.0 if action.name == "forward" else -1.0
        if grid.headings == 8:
            return {"advance": sign * step, "advance_diagonal": sign * step * math.sqrt(2.0)}
        return {"advance": sign * step}
    grid_step = {"up": (0.0, step), "down": (0.0, -step), "left": (-step, 0.0), "right": (step, 0.0)}.get(action.name)
    if grid_step is None:
        return None
    yaw = grid.frame.yaw
    dx, dy = grid_step
    return {"x": math.cos(yaw) * dx - math.sin(yaw) * dy, "y": math.sin(yaw) * dx + math.cos(yaw) * dy}
