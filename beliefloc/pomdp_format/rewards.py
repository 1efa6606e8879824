"""``R:`` statements, read into :class:`Reward` records.

beliefloc models have one cost per action, so a reward is only kept as where it applies and its
smallest and largest value: enough to tell, when the model is built, whether an action's rewards
come down to one constant (:mod:`beliefloc.pomdp_format.costs`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from beliefloc.pomdp_format.preamble import Preamble
from beliefloc.pomdp_format.statements import Statement, numbers


@dataclass(frozen=True)
class Reward:
    """One ``R:`` statement as one action sees it: where it applies (None for every state) and its
    smallest and largest value."""

    start: int | None
    end: int | None
    every_observation: bool
    low: float
    high: float
    line: int

    @property
    def everywhere(self) -> bool:
        """One value for every start state, end state and observation."""
        return self.start is None and self.end is None and self.every_observation and self.low == self.high


def read_reward(st: Statement, preamble: Preamble) -> Reward:
    """``R: a : s : s' : o r``, ``R: a : s : s'`` and a row, or ``R: a : s`` and a matrix."""
    tokens = st.tokens
    n, k = preamble.size("states"), preamble.size("observations")
    if len(tokens) <= 3 or tokens[3] != ":":
        raise st.error(
            st.line,
            "R: a matrix after 'R: <action>' is the MDP form; a POMDP's reward names a start state "
            "('R: a : * : * : * -1.0')",
        )
    start = preamble.ref("states", st, 4)
    end: int | None = None
    every_observation = True
    if len(tokens) > 5 and tokens[5] == ":":
        end = preamble.ref("states", st, 6)
        if len(tokens) > 7 and tokens[7] == ":":  # R: a : s : s' : o r
            every_observation = preamble.ref("observations", st, 8) is None
            values = numbers(st, 9, 1, st.head(9), signed=True)
        else:  # R: a : s : s'  + a row over observations
            values = numbers(st, 7, k, st.head(7), signed=True)
    else:  # R: a : s  + a matrix over end states and observations
        values = numbers(st, 5, n * k, st.head(5), signed=True)
    if not np.isfinite(values).all():
        raise st.error(st.line, "R: rewards must be finite numbers")
    return Reward(start, end, every_observation, float(values.min()), float(values.max()), st.line)
