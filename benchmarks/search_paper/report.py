"""The markdown report being written, its plots, and the measures and formats the sections share."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from beliefloc.object_search.experiment import ArmOutcome
from beliefloc.object_search.loop import Verdict


@dataclass
class Report:
    """The markdown's lines, in order, and the figures to draw."""

    lines: list[str] = field(default_factory=list)
    plots: dict[str, Callable[[Any], None]] = field(default_factory=dict)
    """Figure name -> a function drawing it on a matplotlib Axes (or a Figure, for two axes)."""

    def add(self, *lines: str) -> None:
        self.lines.extend(lines)


def meta_accuracy(outcome: ArmOutcome, present: bool) -> float:
    """H3's accuracy: a time limit is "target not found" (Sec. III-B: "... or a time limit is exceeded
    (i.e., target is not found)"), right when the target is absent; a found cell scores the Gaussian
    fall-off (0 when the target is absent)."""
    if outcome.verdict is Verdict.FOUND:
        return outcome.accuracy
    return 0.0 if present else 1.0


def meta_accuracies(mine: Sequence[ArmOutcome], present: Sequence[bool]) -> list[float]:
    return [meta_accuracy(o, p) for o, p in zip(mine, present, strict=True)]


def time_to_reach(curve: Sequence[tuple[float, float]], level: float) -> str:
    """The baseline's mean time at which its accuracy first reaches ``level`` (linear interpolation
    between its time limits; ``curve`` is (time, accuracy) by increasing limit)."""
    for k, (t, a) in enumerate(curve):
        if a >= level:
            if k == 0:
                return f"≤ {t:.1f}"
            t0, a0 = curve[k - 1]
            return f"≈ {t0 + (t - t0) * (level - a0) / (a - a0):.1f}"
    return f"never (at most {max(a for _, a in curve):.3f})"


def p_value(value: float | None) -> str:
    """A p-value in scientific notation, or "no difference" when every pair tied."""
    return "no difference" if value is None else f"{value:.1e}"


def percent(value: float) -> str:
    """A fraction as a percentage with one decimal, or "-" for nan."""
    return "-" if math.isnan(value) else f"{100 * value:.1f} %"
