"""The surprise check: do the readings fit the belief, or has the model stopped explaining them?

A peaked belief is not enough to call a robot localized: a wrong map, a kidnapped robot or a room
full of unmapped furniture all produce beliefs that collapse somewhere, and the collapse says
nothing about whether the place fits what the robot reads (Fox, Burgard & Thrun's "believability";
AMCL's ``recovery_alpha_*`` react to the same signal). Two numbers per update, both cheap:

- **inlier fraction** -- of the update's beams, the fraction whose end points, the robot at the
  belief's best pose, lie within ``inlier_distance`` of an obstacle on the map. The model (a hit
  mixture) expects most of them to when the pose is right; at a wrong pose they scatter. Clutter
  lowers it by the share of beams on unmapped things, no more.
- **surprise** -- ``log p(z | bel)`` per beam, the predictive log-likelihood of the readings under
  the predicted belief, less the same at the best state: ``(log sum_s bel(s) p(z|s) - log p(z|s*)) / B``.
  Near 0 when the belief put its mass where the readings fit; strongly negative when the readings
  were a surprise to the belief (the mass was elsewhere).

:class:`FitTracker` keeps the last few updates and says whether the recent scans fit; it is the
same for the grid filter and for a ``localize`` loop that gets whole scans.

Pure numpy, no I/O.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class FitConfig:
    """When readings fit: documented thresholds."""

    inlier_distance: float = 0.2
    """Metres: a beam fits when its end point is this close to a mapped obstacle (AMCL's
    ``laser_sigma_hit``: one standard deviation of a hit)."""
    min_inlier_fraction: float = 0.5
    """The recent updates fit when their mean inlier fraction is at least this (the latest one
    too). With a correct pose a lidar in an office fits 70-95 % of its beams; a wrong pose in a
    different-looking place 10-40 %."""
    min_surprise: float = -0.5
    """Nats per beam: the readings were a surprise to the belief below this (the latest update)."""
    window: int = 3
    """Updates looked at."""

    def __post_init__(self) -> None:
        if not (self.inlier_distance > 0 and math.isfinite(self.inlier_distance)):
            raise ValueError(f"FitConfig.inlier_distance must be > 0 metres, got {self.inlier_distance}")
        if not 0.0 <= self.min_inlier_fraction <= 1.0:
            raise ValueError(f"FitConfig.min_inlier_fraction must be in [0, 1], got {self.min_inlier_fraction}")
        if self.window < 1:
            raise ValueError(f"FitConfig.window must be at least 1, got {self.window}")


def inlier_fraction(distances: np.ndarray, inlier_distance: float) -> float:
    """The fraction of beams whose end point is within ``inlier_distance`` of an obstacle (1.0 for
    no beams: nothing contradicts the belief)."""
    d = np.asarray(distances, dtype=np.float64)
    return 1.0 if d.size == 0 else float(np.mean(d <= inlier_distance))


def surprise(predicted: np.ndarray, log_likelihood: np.ndarray, beams: int) -> float:
    """``(log sum_s bel(s) exp(L(s)) - max_s L(s)) / beams``: how much less the predicted belief
    expected the readings than its best state does, per beam (<= 0; 0 for a point belief on the
    best state). ``predicted`` and ``log_likelihood`` are arrays of the same shape (any), the belief
    summing to 1; states with ``L = -inf`` (not states) are ignored."""
    if beams <= 0:
        return 0.0
    b = np.asarray(predicted, dtype=np.float64)
    ll = np.asarray(log_likelihood, dtype=np.float64)
    top = float(ll.max())
    if not math.isfinite(top):
        return -math.inf
    mixed = float(np.sum(b * np.exp(ll - top)))
    if mixed <= 0.0:
        return -math.inf
    return math.log(mixed) / beams


@dataclass
class FitTracker:
    """The last :attr:`FitConfig.window` updates' inlier fractions and surprises."""

    config: FitConfig = field(default_factory=FitConfig)
    fractions: deque[float] = field(default_factory=deque)
    surprises: deque[float] = field(default_factory=deque)

    def add(self, fraction: float, surprise_per_beam: float) -> None:
        self.fractions.append(fraction)
        self.surprises.append(surprise_per_beam)
        while len(self.fractions) > self.config.window:
            self.fractions.popleft()
            self.surprises.popleft()

    def reset(self) -> None:
        self.fractions.clear()
        self.surprises.clear()

    @property
    def mean_fraction(self) -> float:
        return float(np.mean(self.fractions)) if self.fractions else 0.0

    def fits(self) -> bool:
        """The recent readings fit the belief's best pose: a full window, mean and latest inlier
        fraction at least :attr:`FitConfig.min_inlier_fraction`, and the latest readings no
        surprise to the belief (at least :attr:`FitConfig.min_surprise` per beam)."""
        c = self.config
        if len(self.fractions) < c.window:
            return False
        return (
            self.mean_fraction >= c.min_inlier_fraction
            and self.fractions[-1] >= c.min_inlier_fraction
            and self.surprises[-1] >= c.min_surprise
        )

    def why_not(self) -> str | None:
        """Why the readings do not fit, in words; None when they do."""
        c = self.config
        if len(self.fractions) < c.window:
            return f"only {len(self.fractions)} of the {c.window} updates the fit check needs"
        if self.fits():
            return None
        if self.surprises[-1] < c.min_surprise and self.mean_fraction >= c.min_inlier_fraction:
            return (
                f"the last scan surprised the belief ({self.surprises[-1]:.2f} nats per beam below its best state's, "
                f"at most {-c.min_surprise:g} allowed): its mass was elsewhere"
            )
        return (
            f"the last scans fit the best pose poorly: {100 * self.mean_fraction:.0f} % of beams within "
            f"{c.inlier_distance:g} m of a mapped obstacle (at least {100 * c.min_inlier_fraction:.0f} % needed)"
        )
