"""Beliefs: probability vectors over a model's states. Pure functions, no I/O, no randomness.

A belief ``b`` is a dense float64 vector with ``b[j] = P(s_j)``, non-negative, summing to 1.
Functions return new arrays and never modify their inputs.

Bayes filter for action ``a`` and observation ``o`` (Colledanchise Sec. III, Khalvati Eq. 3-4)::

    predicted[j] = sum_i T_a[i, j] b[i]                  (prediction; identity for perception)
    p(o | a, b)  = sum_j predicted[j] O_a[j, o]
    b'[j]        = predicted[j] O_a[j, o] / p(o | a, b)
"""

from __future__ import annotations

import numpy as np

from beliefloc.errors import ImpossibleObservationError
from beliefloc.model import Action, Model


def uniform(n_states: int) -> np.ndarray:
    """No prior knowledge: every state equally likely (global localization)."""
    return np.full(n_states, 1.0 / n_states)


def by_state_name(model: Model, belief: np.ndarray) -> dict[str, float]:
    """Every state's name with its probability, in state order (the shape belief files and
    ``--json`` outputs use)."""
    return {name: float(p) for name, p in zip(model.states.names, belief.tolist(), strict=True)}


def point(n_states: int, state: int) -> np.ndarray:
    """All the mass on one state."""
    belief = np.zeros(n_states)
    belief[state] = 1.0
    return belief


def predict(action: Action, belief: np.ndarray) -> np.ndarray:
    """``predicted = T_aᵀ b``: where the robot may be after ``action`` (before it observes)."""
    transposed = action.transition_transposed
    if transposed is None:
        return belief.copy()
    predicted: np.ndarray = transposed @ belief
    return predicted


def observation_probabilities(action: Action, belief: np.ndarray) -> np.ndarray:
    """``p(o | a, b)`` for every observation ``o`` of ``action``; sums to 1."""
    return action.observation.probabilities(predict(action, belief))


def update(
    model: Model, belief: np.ndarray, action: str | Action, observation: str | int | None
) -> tuple[np.ndarray, float]:
    """Apply ``action`` and then ``observation``; returns ``(posterior, p(o | a, b))``.

    ``observation=None`` means nothing was observed: the result is the prediction alone, with
    probability 1. An observation of probability zero under the belief raises
    :class:`ImpossibleObservationError` (Bayes' rule would divide 0 by 0).
    """
    act = model.action(action) if isinstance(action, str) else action
    return correct(act, predict(act, belief), observation)


def correct(action: Action, predicted: np.ndarray, observation: str | int | None) -> tuple[np.ndarray, float]:
    """Bayes' rule with ``O_a`` on a belief already predicted (``T_aᵀ b``, or a prediction from
    measured odometry): ``b' ∝ predicted ⊙ O_a[:, o]``; returns ``(posterior, p(o | a, b))``, or
    the prediction with probability 1 when ``observation`` is None. See :func:`update`."""
    if observation is None:
        return predicted, 1.0
    o = action.observation.index(observation) if isinstance(observation, str) else observation
    weighted = predicted * action.observation.likelihood(o)
    total = float(weighted.sum())
    if not total > 0.0:
        raise ImpossibleObservationError(
            f"observation {action.observation.name(o)!r} after {action.name!r} has probability 0 under the "
            "current belief: no state the robot may be in can produce it. Either the log is wrong, or "
            "the map's observations are noise-free where the sensor is not (give the sensor a small "
            "false_positive/false_negative or error rate)."
        )
    weighted /= total
    return weighted, total


def entropy(belief: np.ndarray) -> float:
    """Shannon entropy ``-sum_j b_j ln b_j`` in nats (0 ln 0 = 0)."""
    support = belief[belief > 0.0]
    return float(-(support * np.log(support)).sum())


def most_likely(belief: np.ndarray) -> tuple[int, float]:
    """The most likely state and its probability (the lowest index on ties)."""
    state = int(np.argmax(belief))
    return state, float(belief[state])


def normalise(weights: np.ndarray) -> np.ndarray:
    """A new belief proportional to non-negative ``weights``; raises ValueError if they sum to 0."""
    if np.any(weights < 0) or not np.all(np.isfinite(weights)):
        raise ValueError("weights must be finite and non-negative")
    total = float(weights.sum())
    if total <= 0.0:
        raise ValueError("weights sum to zero")
    return weights / total
