"""The statistics of the benchmarks, in one place: means, sample standard deviations, medians, paired
tests and paired means, with the formatting their tables share.

Two conventions for "no values", each kept from the scripts that used it: :func:`mean` and :func:`sd`
give ``nan`` (the search benchmark's tables print it, and arithmetic on it stays a float), while
:func:`mean_or_none` and :func:`median_or_none` give ``None`` (the planning tables print "—").

numpy and scipy are imported only by :func:`paired_p`: the planning benchmarks import this module
before they set ``OPENBLAS_NUM_THREADS=1``, which must come before numpy's first import.
"""

from __future__ import annotations

import math
import statistics
import warnings
from collections.abc import Iterable, Sequence

DASH = "—"
"""What a table shows for a value that could not be computed (no values)."""


def mean(values: Iterable[float]) -> float:
    """The arithmetic mean (``statistics.fmean``); ``nan`` when there are no values."""
    data = list(values)
    return statistics.fmean(data) if data else math.nan


def mean_or_none(values: Iterable[float]) -> float | None:
    """The arithmetic mean (``statistics.fmean``); ``None`` when there are no values."""
    data = list(values)
    return statistics.fmean(data) if data else None


def median_or_none(values: Iterable[float]) -> float | None:
    """The median (``statistics.median``, the mean of the middle two for an even count); ``None`` when
    there are no values."""
    data = list(values)
    return statistics.median(data) if data else None


def sd(values: Sequence[float]) -> float:
    """The sample standard deviation (``statistics.stdev``: n - 1 in the denominator, ddof = 1);
    ``nan`` for fewer than two values."""
    return statistics.stdev(values) if len(values) > 1 else math.nan


def standard_error(values: Sequence[float]) -> float:
    """The standard error of the mean, ``sd / sqrt(n)``; ``nan`` for one value."""
    return sd(values) / math.sqrt(len(values))


def paired_p(x: Sequence[float], y: Sequence[float]) -> float | None:
    """Two-sided Wilcoxon signed-rank p on pairs (``scipy.stats.wilcoxon`` with its defaults: zero
    differences dropped); None when every pair ties."""
    import numpy as np
    from scipy.stats import wilcoxon

    a, b = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if not np.any(a != b):
        return None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return float(wilcoxon(a, b).pvalue)


def difference_ci(differences: Sequence[float], confidence: float = 0.95) -> tuple[float, float, float] | None:
    """The mean of paired differences and its t-based confidence interval (n - 1 degrees of freedom);
    None for fewer than two pairs."""
    from scipy.stats import t

    n = len(differences)
    if n < 2:
        return None
    centre = mean(differences)
    half = float(t.ppf(0.5 + confidence / 2, n - 1)) * standard_error(differences) if sd(differences) > 0 else 0.0
    return centre, centre - half, centre + half


def win_counts(pairs: Iterable[tuple[float, float]]) -> tuple[int, int]:
    """How many pairs ``(this, reference)`` have this lower (cheaper) and how many have it higher (dearer);
    ties count in neither."""
    data = list(pairs)
    return sum(a < b for a, b in data), sum(a > b for a, b in data)


def fmt(value: float | None, digits: int = 2) -> str:
    """``value`` with ``digits`` decimals, or "—" for None."""
    return DASH if value is None else f"{value:.{digits}f}"


def paired_means(pairs: Sequence[tuple[float, float]], *, wins: bool = False) -> str:
    """``this / reference (n=...)``: the means of paired values, two decimals; with ``wins``, how often
    this was lower (cheaper) and higher (dearer). "—" when there are no pairs."""
    if not pairs:
        return DASH
    text = f"{fmt(mean_or_none([a for a, _ in pairs]))} / {fmt(mean_or_none([b for _, b in pairs]))} (n={len(pairs)}"
    if wins:
        cheaper, dearer = win_counts(pairs)
        text += f"; cheaper {cheaper}, dearer {dearer}"
    return text + ")"


def clopper_pearson(k: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """The exact (Clopper-Pearson) two-sided interval of a proportion: ``k`` successes of ``n``
    (``(0, 1)`` for ``n = 0``)."""
    if n == 0:
        return 0.0, 1.0
    from scipy.stats import beta

    alpha = 1.0 - confidence
    low = 0.0 if k == 0 else float(beta.ppf(alpha / 2, k, n - k + 1))
    high = 1.0 if k == n else float(beta.ppf(1 - alpha / 2, k + 1, n - k))
    return low, high
