"""The names of the localization strategies and the episode budget, with no numeric imports.

The registry :data:`beliefloc.simulation.strategies.STRATEGIES` has one entry per member of
:class:`StrategyName` (a test checks it), so the command line can offer the names without loading
the planners.
"""

from __future__ import annotations

import enum

# The random grid worlds' vocabulary (:mod:`beliefloc.simulation.gridworld`), here for the same reason.
CLASSES = ("A", "B", "C", "D")
"""The object classes of a random grid world, named as in the authors' code."""
MOVE_FAILURE = 0.02
"""The probability that a move of a random grid world fails, as the paper's text says of every move."""


class SeenModel(str, enum.Enum):
    """Where ``look`` gets what it sees in a random grid world: placed objects, or per-state draws
    as the authors did."""

    OBJECTS = "objects"
    STATES = "states"


MAX_OBSTACLES = 1000
"""A continuous robot's world holds at most this many unmapped obstacles (each a disc drawn into its image)."""

DEFAULT_MAX_STEPS = 200
"""An episode stops after this many actions."""


class StrategyName(str, enum.Enum):
    """A way of choosing the next action during a localization episode."""

    BESTFIRST = "bestfirst"
    """Colledanchise's Algorithm 1: plan with best-first search, act, replan when surprised."""
    UNIFORM = "uniform"
    """The same with uniform-cost search (h = 0): the paper's least-cost baseline."""
    RANDOM = "random"
    """The paper's baseline: a perception action, then a random move, in turn."""
    EC2 = "ec2"
    """Khalvati & Mackworth's Algorithm 1: the heaviest action by pairwise edge weights."""
    EC2_MACROS = "ec2-macros"
    """Their Algorithm 3: macro actions are candidates too."""
    CONTINGENT = "contingent"
    """A policy that branches on every observation (LAO* over beliefs), planned on while incomplete."""
