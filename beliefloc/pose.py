"""Poses in the map frame: where a state is, and a belief as a pose with a covariance.

Pure numpy, no I/O. A grid state ``(row, col, heading)`` stands for the robot somewhere in the
cell, facing somewhere in the heading's sector; its *pose* is the cell's centre and the heading's
yaw in the map frame (ROS ``map``, yaw counter-clockwise from +x), given by
:meth:`GridLayout.cell_centre` and :meth:`GridLayout.heading_yaw`.

A belief becomes a :class:`PoseEstimate`: the pose of its most likely state and a covariance in the
layout of ROS's ``geometry_msgs/PoseWithCovariance`` — what Nav2's AMCL takes on ``/initialpose``
(:func:`beliefloc.ros.messages.pose_with_covariance_stamped`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from beliefloc.errors import InvalidValueError
from beliefloc.model import GridLayout, Model, wrap_angle

ROS_AXES = ("x", "y", "z", "rot_x", "rot_y", "rot_z")
"""The axes of a ROS pose covariance, in order (``geometry_msgs/PoseWithCovariance``)."""

UNIFORM_YAW_VARIANCE = math.pi**2 / 3
"""Variance of a yaw uniform on (-pi, pi]: ``(2 pi)² / 12``; the yaw variance when the model has one
heading (the robot's yaw is then unknown)."""

DEGENERATE_RESULTANT = 1e-9
"""Below this mean resultant length the belief's yaws cancel out and have no circular mean."""


@dataclass(frozen=True)
class Pose:
    """A planar pose in the map frame: metres, and a yaw in radians (counter-clockwise from +x)."""

    x: float
    y: float
    yaw: float

    def as_json(self) -> dict[str, float]:
        return {"x": self.x, "y": self.y, "yaw": self.yaw}


def state_pose(grid: GridLayout, state: int) -> Pose:
    """The pose of grid state ``state``: its cell's centre and its heading's yaw (0 when the grid
    has one heading: the yaw is then unknown, see :func:`belief_pose`)."""
    row, col, heading = grid.cell_heading(state)
    x, y = grid.cell_centre(row, col)
    return Pose(float(x) + 0.0, float(y) + 0.0, float(grid.heading_yaw(heading)) + 0.0)  # + 0.0: no -0.0


@dataclass(frozen=True)
class PoseEstimate:
    """A belief as a pose: the pose of the most likely state and the belief's covariance.

    ``covariance`` is ROS's ``PoseWithCovariance.covariance``: 36 floats, the 6x6 matrix row-major
    over ``(x, y, z, rot_x, rot_y, rot_z)`` (:data:`ROS_AXES`); beliefloc is planar, so the rows and
    columns of ``z``, ``rot_x`` and ``rot_y`` are 0 and ``rot_z`` is the yaw.
    """

    pose: Pose
    covariance: tuple[float, ...]
    state: int
    """The most likely state (its index), whose pose :attr:`pose` is."""
    probability: float
    """Its probability."""

    @property
    def matrix(self) -> np.ndarray:
        """The covariance as a 6x6 array (a new one)."""
        return np.array(self.covariance, dtype=np.float64).reshape(6, 6)

    def as_json(self) -> dict[str, object]:
        """``{"x", "y", "yaw", "covariance": [36]}`` — the ``"pose"`` of every ``--json`` that names
        a most likely state (the state and its probability stay where that output already has them)."""
        return {**self.pose.as_json(), "covariance": list(self.covariance)}


def belief_pose(model: Model, belief: np.ndarray) -> PoseEstimate:
    """The pose of ``belief``'s most likely state (lowest index on ties) and the belief's covariance.

    Each state ``i`` (probability ``b_i``) has a cell centre ``(x_i, y_i)`` and a heading yaw
    ``θ_i``; within the state the robot is uniform on the cell (side ``s``) and, independently, on
    the heading's sector (width ``2π/H`` for ``H`` headings). By the law of total covariance the
    belief's covariance is the spread *between* states plus the mean spread *within* one::

        μ_x = Σ_i b_i x_i          μ_y = Σ_i b_i y_i          (the belief's mean position)
        θ̄  = atan2(Σ_i b_i sin θ_i, Σ_i b_i cos θ_i)        (circular mean of the yaw)
        d_i = (x_i - μ_x, y_i - μ_y, wrap(θ_i - θ̄))          wrap to (-π, π]
        Σ   = Σ_i b_i d_i d_iᵀ                                (between states)
            + R diag(s²/12, s²/12) Rᵀ ⊕ (2π/H)²/12          (within a state)

    ``R`` rotates the grid's axes into the map frame (the frame's yaw); ``s²/12`` is the variance
    of a uniform interval of length ``s`` (the cell is square, so this term is ``s²/12 I`` in any
    axes), ``(2π/H)²/12`` that of a uniform sector. The within-state term has no cross terms
    because position and heading are independent and uniform inside a state. It also makes the
    matrix positive definite on (x, y, yaw) even for a point belief, which AMCL needs to draw its
    particles.

    Choices:

    * The yaw is circular: its mean is the circular mean and deviations are wrapped, so a belief
      split between yaws 179° and -179° has a spread of 2°, not 358°. When the yaws cancel out
      (mean resultant length ``|Σ b_i e^{iθ_i}| < 1e-9``, e.g. half the mass on each of two
      opposite headings) the circular mean is undefined; the most likely state's yaw is used
      instead, which gives the yaw variance its limit from either side of such a split. A
      deviation of exactly π counts as +π (the wrap's interval is half-open).
    * The covariance is about the belief's mean, not about the reported pose: it describes the
      belief, whichever point is reported, and it is what AMCL computes from its particles. (The
      second moment about the reported mode would add ``(μ - pose)(μ - pose)ᵀ``.)
    * With one heading the model knows nothing of the yaw: the yaw variance is that of a yaw
      uniform on the circle, ``π²/3`` (:data:`UNIFORM_YAW_VARIANCE`), with no cross terms; the
      reported yaw is 0.

    Raises :class:`InvalidValueError` when the model has no grid (its states have no pose) or the
    belief does not fit it.
    """
    grid = model.grid
    if grid is None:
        raise InvalidValueError(f"model {model.name} has no grid, so its states have no pose")
    b = np.asarray(belief, dtype=np.float64)
    if b.shape != (model.n_states,):
        raise InvalidValueError(f"a belief over {model.n_states} states was expected, got shape {b.shape}")
    total = float(b.sum())
    if not math.isfinite(total) or total <= 0.0 or np.any(b < 0.0):
        raise InvalidValueError("the belief must be non-negative and finite with a positive sum")

    mode = int(np.argmax(b))
    support = np.flatnonzero(b > 0.0)
    weight = b[support] / total
    row, col, heading = grid.cell_heading(support)
    x, y = grid.cell_centre(row, col)
    mean_x, mean_y = float(weight @ x), float(weight @ y)
    mode_pose = state_pose(grid, mode)

    cov = np.zeros((6, 6))
    dx, dy = x - mean_x, y - mean_y
    cell_variance = grid.cell_size**2 / 12.0
    cov[0, 0] = float(weight @ (dx * dx)) + cell_variance
    cov[1, 1] = float(weight @ (dy * dy)) + cell_variance
    cov[0, 1] = cov[1, 0] = float(weight @ (dx * dy))
    if grid.headings == 1:
        cov[5, 5] = UNIFORM_YAW_VARIANCE
    else:
        yaw = grid.heading_yaw(heading)
        sin_sum, cos_sum = float(weight @ np.sin(yaw)), float(weight @ np.cos(yaw))
        cancelled = math.hypot(sin_sum, cos_sum) < DEGENERATE_RESULTANT
        centre = mode_pose.yaw if cancelled else math.atan2(sin_sum, cos_sum)
        dyaw = wrap_angle(yaw - centre)
        cov[5, 5] = float(weight @ (dyaw * dyaw)) + (2 * math.pi / grid.headings) ** 2 / 12.0
        cov[0, 5] = cov[5, 0] = float(weight @ (dx * dyaw))
        cov[1, 5] = cov[5, 1] = float(weight @ (dy * dyaw))
    return PoseEstimate(
        pose=mode_pose,
        covariance=tuple(float(v) + 0.0 for v in cov.ravel()),  # + 0.0: no -0.0 in the output
        state=mode,
        probability=float(b[mode] / total),
    )


def pose_json(model: Model, belief: np.ndarray) -> dict[str, object] | None:
    """The ``"pose"`` value of every ``--json`` that reports a most likely state:
    ``belief_pose(model, belief).as_json()``, or None (JSON ``null``) when the model has no grid."""
    return None if model.grid is None else belief_pose(model, belief).as_json()
