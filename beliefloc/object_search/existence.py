"""Does the target exist at all? Metareasoning with a Beta meta-density (Zhang, Sridharan & Wyatt
2015, Sec. III-D, Eq. 8-14). Pure numpy/scipy; randomness only through a passed Generator.

``θ = P(E)`` has a Beta(α', β') density (Eq. 8): α' and β' count support for and against the
target's existence, from the answer set and from historical data of comparable domains. Each
detection ``o`` multiplies the kept likelihoods (Eq. 12) by (Eq. 9)::

    p(o+ | E)  = Σ_{i∈FoV} p_TP b(i) + p_FP Σ_{i∉FoV} b(i)     p(o+ | ¬E) = p_FP
    p(o- | E)  = Σ_{i∈FoV} (1 - p_TP) b(i) + p_TN Σ_{i∉FoV} b(i)   p(o- | ¬E) = p_TN

with ``b`` the cell belief assuming the target exists. For one θ the posterior is (Eq. 11, in closed
form over the whole sequence) ``p_θ(E | o) = θ L_E / (θ L_E + (1 - θ) L_¬E)``, and Eq. 10 averages it
over the Beta. Three approximations (:class:`~beliefloc.object_search.settings.Metareasoning`; its
``none`` is no metareasoning at all):

* ``expectation``: θ = α' / (α' + β'), the Beta's mean;
* ``upper-bound``: θ = the Beta's ``value_ub`` quantile (0.9 in the paper);
* ``sampling``: Monte-Carlo samples θ_j from the Beta; the sample count follows Eq. 14,
  ``N = (z σ / (μ - τ-))²`` over the samples' p_j(¬E | o), with z = 1.645 (90 % confidence).

Reading taken where the text is terse: Eq. 14's σ and μ are the standard deviation and mean of the
current samples' ``p_j(¬E | o)``; N is capped (``max_samples``) because it diverges as μ → τ-.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from beliefloc.errors import InvalidValueError
from beliefloc.object_search.settings import Metareasoning

Z_90 = 1.645
VALUE_UB = 0.9
DEFAULT_SAMPLES = 100
MAX_SAMPLES = 20_000


def detection_likelihoods(
    belief: np.ndarray, in_view: np.ndarray, present: bool, true_positive: float, false_positive: float
) -> tuple[float, float]:
    """Eq. 9: ``(p(o | E), p(o | ¬E))`` for one detection, ``belief`` over cells given E."""
    viewed = float(belief[in_view].sum())
    if present:
        return true_positive * viewed + false_positive * (1.0 - viewed), false_positive
    true_negative = 1.0 - false_positive
    return (1.0 - true_positive) * viewed + true_negative * (1.0 - viewed), true_negative


def posterior_existence(theta: np.ndarray | float, log_like_e: float, log_like_not_e: float) -> np.ndarray:
    """Eq. 11 over the whole sequence: ``p_θ(E | o_1:t)`` for each θ (vectorised)."""
    theta = np.asarray(theta, dtype=float)
    shift = max(log_like_e, log_like_not_e)
    le, lne = math.exp(log_like_e - shift), math.exp(log_like_not_e - shift)
    num = theta * le
    result: np.ndarray = num / (num + (1.0 - theta) * lne)
    return result


@dataclass
class ExistenceBelief:
    """The kept sequence likelihoods given E and ¬E (Eq. 12) and the chosen approximation (``metareasoning``)."""

    alpha: float
    beta: float
    metareasoning: Metareasoning = Metareasoning.EXPECTATION
    tau_minus: float = 0.7
    value_ub: float = VALUE_UB
    rng: np.random.Generator | None = None
    initial_samples: int = DEFAULT_SAMPLES
    max_samples: int = MAX_SAMPLES
    log_like_e: float = 0.0
    log_like_not_e: float = 0.0
    samples: np.ndarray = field(default_factory=lambda: np.empty(0))
    _quantile: tuple[tuple[float, float, float], float] | None = field(default=None, init=False, repr=False)

    def __post_init__(self) -> None:
        if not (self.alpha > 0 and self.beta > 0):
            raise InvalidValueError("the Beta's parameters must be positive")
        if self.metareasoning is Metareasoning.SAMPLING:
            if self.rng is None:
                raise InvalidValueError("sampling metareasoning needs a seeded numpy Generator")
            self.samples = self.rng.beta(self.alpha, self.beta, size=self.initial_samples)

    @property
    def theta(self) -> float:
        """The single prior P(E) of the expectation and upper-bound approximations."""
        if self.metareasoning is Metareasoning.UPPER_BOUND:
            key = (self.alpha, self.beta, self.value_ub)
            if self._quantile is None or self._quantile[0] != key:  # the quantile costs ~0.1 ms: once per search
                from scipy.stats import beta  # lazy: scipy.stats is slow to import

                self._quantile = (key, float(beta.ppf(self.value_ub, self.alpha, self.beta)))
            return self._quantile[1]
        return self.alpha / (self.alpha + self.beta)

    def observe(self, like_e: float, like_not_e: float) -> None:
        """Eq. 12: one more detection's likelihoods given E and ¬E."""
        self.log_like_e += math.log(like_e) if like_e > 0 else -math.inf
        self.log_like_not_e += math.log(like_not_e) if like_not_e > 0 else -math.inf
        if self.metareasoning is Metareasoning.SAMPLING:
            self._resample()

    def probability_exists(self) -> float:
        """Eq. 10 under the chosen approximation (1 without metareasoning, ``none``)."""
        if self.metareasoning is Metareasoning.NONE:
            return 1.0
        if self.metareasoning is Metareasoning.SAMPLING:
            return float(posterior_existence(self.samples, self.log_like_e, self.log_like_not_e).mean())
        return float(posterior_existence(self.theta, self.log_like_e, self.log_like_not_e))

    def required_samples(self) -> int:
        """Eq. 14: samples needed to decide ``p(¬E) > τ-`` with 90 % confidence (capped)."""
        not_e = 1.0 - posterior_existence(self.samples, self.log_like_e, self.log_like_not_e)
        gap = float(not_e.mean()) - self.tau_minus
        spread = float(not_e.std(ddof=1)) if len(not_e) > 1 else 0.0
        if gap == 0.0:
            return self.max_samples
        return min(self.max_samples, max(len(self.samples), math.ceil((Z_90 * spread / gap) ** 2)))

    def _resample(self) -> None:
        assert self.rng is not None
        needed = self.required_samples()
        if needed > len(self.samples):
            extra = self.rng.beta(self.alpha, self.beta, size=needed - len(self.samples))
            self.samples = np.concatenate([self.samples, extra])
