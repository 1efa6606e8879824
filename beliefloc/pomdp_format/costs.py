"""An action's cost from the :class:`~beliefloc.pomdp_format.rewards.Reward` records of its ``R:``
statements.

A localization model has one cost per action, so every action's reward must end up one constant
``r`` -- ``R: a : * : * : * r``, possibly repeated by later entries, or the same ``r`` given for
every pair of states, as pomdp_py writes it -- which becomes the cost ``-r`` (``+r`` with
``values: cost``). An action without ``R:`` costs 0. A reward that depends on the state or the
observation, and a negative cost, are refused.
"""

from __future__ import annotations

import numpy as np

from beliefloc.pomdp_format.parser import ParsedFile
from beliefloc.pomdp_format.rewards import Reward

_MAX_COVERAGE = 50_000_000
"""Largest |S|^2 for which per-state rewards are checked to cover every pair of states."""


def action_cost(parsed: ParsedFile, rewards: list[Reward], ident: str) -> float:
    """The cost of action ``ident``: minus its one reward (or its one cost with ``values: cost``).

    The reward is one constant when the last ``R: a : * : * : * r`` is followed only by entries
    giving ``r`` again, or when every entry gives the same ``r`` and together they cover every
    start and end state (pomdp_py writes one ``R: a : s : s' : * r`` per pair).
    """
    preamble = parsed.preamble
    last = max((i for i, r in enumerate(rewards) if r.everywhere), default=None)
    value = rewards[last].low if last is not None else rewards[0].low if rewards else 0.0
    unsupported = (
        f"the reward of action {ident!r} depends on the state or observation; beliefloc models have one cost "
        f"per action, so state-dependent rewards are unsupported (give 'R: {ident} : * : * : * -COST')"
    )
    for reward in rewards[(last + 1 if last is not None else 0) :]:
        if not reward.low == reward.high == value:
            raise parsed.error(reward.line, f"R: {unsupported}")
    if last is None and value != 0.0 and not _covers_everything(rewards, preamble.size("states")):
        raise parsed.error(rewards[0].line, f"R: {unsupported}; here some states are left at 0")
    cost = (value if preamble.values_cost else -value) + 0.0  # + 0.0 turns -0.0 into 0.0
    if cost < 0:
        line = rewards[last].line if last is not None else preamble.declared["actions"].line
        word = "cost" if preamble.values_cost else "reward"
        raise parsed.error(
            line, f"R: action {ident!r} has a {word} of {value:g}, a negative cost; beliefloc needs costs >= 0"
        )
    return cost


def _covers_everything(rewards: list[Reward], n: int) -> bool:
    """Whether the rewards that hold for every observation together cover every pair of states."""
    if n * n > _MAX_COVERAGE:
        return False
    covered = np.zeros((n, n), dtype=bool)
    for reward in rewards:
        if reward.every_observation:
            covered[
                slice(None) if reward.start is None else reward.start,
                slice(None) if reward.end is None else reward.end,
            ] = True
    return bool(covered.all())
