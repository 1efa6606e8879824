"""Where is the target? A belief over cells from a knowledge-base prior and kept observation
likelihoods (Zhang, Sridharan & Wyatt 2015, Sec. III-C2, Eq. 6-7). Pure numpy, no I/O.

The target never moves, so the likelihood of the whole observation sequence can be kept per cell::

    b_ob[i] = prod_j O(s_i, a_j, o_j)                     (Eq. 6)
    b[i]   ∝ b_ob[i] · b_kb[i]                            (Eq. 7)

where ``b_kb`` spreads each room's prior over its cells. When the knowledge base is revised and
gives a new room prior, the posterior is recomputed from the kept likelihood (*observation re-use*,
the paper's choice) or from a likelihood reset to 1 (*observation discard*, strictly Bayesian).

A detection analyses the cells in the robot's field of view and reports ``present`` or
``absent``: ``P(present | target in a viewed cell) = p_TP`` and ``P(present | elsewhere) = p_FP``.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np


class Revision(enum.Enum):
    REUSE = "reuse"
    """Keep the observation likelihood when the prior changes (the paper's choice)."""
    DISCARD = "discard"
    """Reset the likelihood to 1 when the prior changes (Bayes-correct after a commitment)."""


@dataclass(frozen=True)
class Detector:
    """The visual detector's rates."""

    true_positive: float
    """P(present | the target is in a viewed cell)."""
    false_positive: float
    """P(present | the target is not in view); p(TN) = 1 - p(FP)."""

    def likelihood(self, in_view: np.ndarray, present: bool) -> np.ndarray:
        """``O(s_i, a, o)`` for every cell i; ``in_view`` is a boolean mask over cells."""
        if present:
            return np.where(in_view, self.true_positive, self.false_positive)
        return np.where(in_view, 1.0 - self.true_positive, 1.0 - self.false_positive)


def spread_room_prior(room_prior: np.ndarray, room_of_cell: np.ndarray) -> np.ndarray:
    """``b_kb``: each room's prior shared evenly by its cells (a room with no cells gets none)."""
    cells_per_room = np.bincount(room_of_cell, minlength=len(room_prior))
    per_cell = np.divide(room_prior, cells_per_room, out=np.zeros(len(room_prior)), where=cells_per_room > 0)
    spread: np.ndarray = per_cell[room_of_cell]
    spread /= spread.sum()
    return spread


@dataclass(frozen=True)
class CellBelief:
    """The knowledge-base prior over cells, the kept likelihood (in logs), and their posterior."""

    prior: np.ndarray
    log_likelihood: np.ndarray

    @classmethod
    def start(cls, prior: np.ndarray) -> CellBelief:
        return cls(prior / prior.sum(), np.zeros(len(prior)))

    @property
    def posterior(self) -> np.ndarray:
        """Eq. 7: ``b ∝ b_ob · b_kb`` (computed in logs so long searches do not underflow)."""
        with np.errstate(divide="ignore"):
            log_post = self.log_likelihood + np.log(self.prior)
        log_post -= log_post.max()
        post = np.exp(log_post)
        total: np.ndarray = post / post.sum()
        return total

    def observe(self, likelihood: np.ndarray) -> CellBelief:
        """Eq. 6: multiply one observation's likelihood into the kept product."""
        with np.errstate(divide="ignore"):
            return CellBelief(self.prior, self.log_likelihood + np.log(likelihood))

    def revise(self, prior: np.ndarray, revision: Revision = Revision.REUSE) -> CellBelief:
        """A new prior from a revised knowledge base; the kept likelihood is re-used or discarded."""
        kept = self.log_likelihood if revision is Revision.REUSE else np.zeros(len(prior))
        return CellBelief(prior / prior.sum(), kept)
