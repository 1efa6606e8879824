"""Where is the target? A belief over cells from a knowledge-base prior and kept observation
likelihoods (Zhang, Sridharan & Wyatt 2015, Sec. III-C2, Eq. 6-7). Pure numpy, no I/O.

The target never moves, so the likelihood of the whole observation sequence can be kept per cell::

    b_ob[i] = prod_j O(s_i, a_j, o_j)                     (Eq. 6)
    b[i]   ∝ b_ob[i] · b_kb[i]                            (Eq. 7)

where ``b_kb`` spreads each room's prior over its cells. ``b_ob`` is kept in logs and only up to a
constant factor: a detection multiplies every cell out of view by the same number, so the fast
update (:meth:`CellBelief.observe_view`) adds ``log(L_in / L_out)`` to the viewed cells only; Eq. 7
normalises, so nothing downstream can tell.

When the knowledge base is revised and gives a new room prior (Algorithm 1, lines 7-10), the
posterior is recomputed in one of three ways (:class:`~beliefloc.object_search.settings.Revision`):

* ``reuse`` -- Eq. 7 with the kept likelihood (*observation re-use*, the paper's choice);
* ``discard`` -- Eq. 7 with the likelihood reset to 1 (*observation discard*, strictly Bayesian
  after a commitment);
* ``trust-factor`` -- the earlier approach the paper compares against in H2 (Zhang, Sridharan &
  Bao 2012, ref. [32]): not Bayes' rule but a weighted *r-norm* average of the KB's belief and the
  POMDP's own belief, see :class:`TrustFactor`. It keeps the likelihood like ``reuse``.

A detection analyses the cells in the robot's field of view and reports ``present`` or
``absent``: ``P(present | target in a viewed cell) = p_TP`` and ``P(present | elsewhere) = p_FP``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from beliefloc.errors import InvalidValueError
from beliefloc.object_search.settings import Revision


@dataclass(frozen=True)
class TrustFactor:
    """The trust-factor merge of Zhang, Sridharan & Bao 2012 as Zhang et al. 2015 describe it (Sec. III-C,
    IV-A H2): "weighted averaging of [the ASP-based] distribution and the POMDP belief distribution using
    the r-norm measure" -- "a generalized form of linear and logarithmic averaging methods" (Cooke 1991,
    ref. [5]). Our reading, per cell ``i``::

        b(i) ∝ ( w · b_kb(i)^r + (1 - w) · b_pomdp(i)^r )^(1/r)       r > 0
        b(i) ∝ b_kb(i)^w · b_pomdp(i)^(1 - w)                         r = 0 (the limit: logarithmic pool)

    ``w`` is the relative trust in the knowledge base, ``b_kb`` the room prior spread over cells and
    ``b_pomdp`` the POMDP's belief on its own: the kept likelihood (Eq. 6) under a uniform prior over
    the cells ``b_kb`` allows. r = 1 is linear averaging.

    The defaults (w = 0.5, r = 0) are ours; the paper gives neither. Linear pooling with w = 0.5 can
    never reach τ+ = 0.8: ``b(i) <= (1 - w) + w · max b_kb``. The logarithmic pool can, but it
    tempers both sources, so it needs more evidence than Bayes' rule for the same confidence -- and an
    ASP belief that is wrong keeps its weight however much the observations say (the paper's remark
    that "an incorrect ASP-based belief [can] overwhelm the POMDP belief").
    """

    weight: float = 0.5
    """w: the trust in the knowledge base's belief; the POMDP's belief gets 1 - w."""
    r: float = 0.0
    """The exponent of the r-norm: 0 logarithmic, 1 linear."""

    def __post_init__(self) -> None:
        if not (0.0 <= self.weight <= 1.0) or not (self.r >= 0.0 and math.isfinite(self.r)):
            raise InvalidValueError(
                f"trust factor: need 0 <= weight <= 1 and r >= 0, got weight {self.weight}, r {self.r}"
            )

    def pool(self, kb: np.ndarray, log_likelihood: np.ndarray) -> np.ndarray:
        """The pooled belief from ``b_kb`` and the kept log-likelihood (both over cells); sums to 1."""
        support = kb > 0
        log_ob = np.where(support, log_likelihood, -np.inf)
        log_ob = log_ob - log_ob.max()
        ob = np.exp(log_ob)
        total = ob.sum()
        log_ob -= math.log(total)
        ob /= total
        w = self.weight
        if self.r == 0.0:
            with np.errstate(divide="ignore", invalid="ignore"):
                log_pooled = np.where(support, w * np.log(np.where(support, kb, 1.0)) + (1.0 - w) * log_ob, -np.inf)
            log_pooled -= log_pooled.max()
            pooled = np.exp(log_pooled)
        else:
            pooled = (w * kb**self.r + (1.0 - w) * ob**self.r) ** (1.0 / self.r)
        result: np.ndarray = pooled / pooled.sum()
        return result


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

    def log_ratio(self, present: bool) -> float:
        """``log(O(in view, o) / O(out of view, o))``: what one detection adds to a viewed cell's log-likelihood."""
        if present:
            return math.log(self.true_positive / self.false_positive) if self.false_positive > 0 else math.inf
        if self.true_positive >= 1.0:
            return -math.inf
        return math.log((1.0 - self.true_positive) / (1.0 - self.false_positive))


def spread_room_prior(room_prior: np.ndarray, room_of_cell: np.ndarray) -> np.ndarray:
    """``b_kb``: each room's prior shared evenly by its cells (a room with no cells gets none)."""
    cells_per_room = np.bincount(room_of_cell, minlength=len(room_prior))
    per_cell = np.divide(room_prior, cells_per_room, out=np.zeros(len(room_prior)), where=cells_per_room > 0)
    spread: np.ndarray = per_cell[room_of_cell]
    spread /= spread.sum()
    return spread


@dataclass(frozen=True)
class CellBelief:
    """The knowledge-base prior over cells, the kept likelihood (in logs), and their posterior.

    ``trust`` None: the posterior is Eq. 7 (``reuse`` and ``discard``); otherwise the trust-factor pool.
    """

    prior: np.ndarray
    log_likelihood: np.ndarray
    trust: TrustFactor | None = None

    @classmethod
    def start(cls, prior: np.ndarray, trust: TrustFactor | None = None) -> CellBelief:
        return cls(prior / prior.sum(), np.zeros(len(prior)), trust)

    @cached_property
    def _log_prior(self) -> np.ndarray:
        with np.errstate(divide="ignore"):
            result: np.ndarray = np.log(self.prior)
        return result

    @cached_property
    def posterior(self) -> np.ndarray:
        """Eq. 7: ``b ∝ b_ob · b_kb`` (in logs so long searches do not underflow), or the trust-factor pool."""
        log_post = self.log_likelihood + self._log_prior
        top = log_post.max()
        if top == -np.inf:  # impossible given E (a perfect sensor ruled out every cell): keep the prior
            return self.prior
        if self.trust is not None:
            return self.trust.pool(self.prior, self.log_likelihood)
        log_post -= top
        post = np.exp(log_post)
        total: np.ndarray = post / post.sum()
        return total

    def observe(self, likelihood: np.ndarray) -> CellBelief:
        """Eq. 6: multiply one observation's likelihood (over all cells) into the kept product."""
        with np.errstate(divide="ignore"):
            return CellBelief(self.prior, self.log_likelihood + np.log(likelihood), self.trust)

    def observe_view(self, cells: np.ndarray, present: bool, detector: Detector) -> CellBelief:
        """Eq. 6 for one detection of the view covering ``cells`` (indices), up to a constant factor:
        only the viewed cells change, by ``log(L_in / L_out)`` (see the module docstring)."""
        kept = self.log_likelihood.copy()
        ratio = detector.log_ratio(present)
        if math.isfinite(ratio):
            kept[cells] += ratio
        elif ratio > 0:  # p_FP = 0: a detection rules out every cell out of view
            outside = np.ones(len(kept), dtype=bool)
            outside[cells] = False
            kept[outside] = -np.inf
        else:  # p_TP = 1: a miss rules out the viewed cells
            kept[cells] = -np.inf
        return CellBelief(self.prior, kept, self.trust)

    def revise(self, prior: np.ndarray, revision: Revision = Revision.REUSE) -> CellBelief:
        """A new prior from a revised knowledge base; the kept likelihood is re-used or discarded.

        ``trust-factor`` keeps the likelihood and pools with the new prior (with this belief's trust
        factors, or the defaults when it had none)."""
        kept = np.zeros(len(prior)) if revision is Revision.DISCARD else self.log_likelihood
        trust = (self.trust or TrustFactor()) if revision is Revision.TRUST else self.trust
        return CellBelief(prior / prior.sum(), kept, trust)
