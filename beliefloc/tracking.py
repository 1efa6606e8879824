"""Markov localization over a log: the steps a robot took and what it saw, checked against a
model, then the Bayes filter over them (:func:`beliefloc.belief.update`).

A step is written ``ACTION`` or ``ACTION=OBSERVATION``: a perception action must say what it
observed; an actuation action may (with passive sensors their joint reading, otherwise ``none``),
and without an observation it is a prediction only.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from beliefloc.belief import by_state_name, update
from beliefloc.errors import ImpossibleObservationError, InvalidValueError
from beliefloc.model import Action, Model

STEP_FORM = "should be ACTION or ACTION=OBSERVATION, e.g. 'right' or 'look=window_seen'"


@dataclass(frozen=True)
class Step:
    """One logged step, checked against a model."""

    text: str
    """As written on the command line."""
    action: Action
    observation: str | None
    """As written; None when nothing was observed (prediction only)."""
    index: int | None
    """The observation's index in ``action.observation``; None when nothing was observed."""


def parse_step(text: str) -> tuple[str, str | None]:
    """``"look=window_seen"`` -> ``("look", "window_seen")``; ``"right"`` -> ``("right", None)``.

    Raises :class:`InvalidValueError` for an empty action, an empty observation or a second ``=``; the
    caller says which step it was.
    """
    action, sep, observation = text.partition("=")
    action, observation = action.strip(), observation.strip()
    if not action or any(ch.isspace() for ch in action) or (sep and not observation) or "=" in observation:
        raise InvalidValueError(STEP_FORM)
    return action, (observation if sep else None)


def resolve_steps(model: Model, texts: Sequence[str]) -> list[Step]:
    """Check every step against ``model`` before any is applied, so a typo in the last step fails
    before the output starts. Messages name the step: ``step 2 'lookk=window': unknown action ...``.

    A perception action must say what it observed. An actuation action may: with passive sensors
    their joint reading, otherwise ``none``; without an observation the step is a prediction only.
    """
    steps = []
    for number, text in enumerate(texts, start=1):
        try:
            name, observation = parse_step(text)
            action = model.action(name)
            if observation is None:
                if not action.is_actuation:
                    raise InvalidValueError(
                        f"{name!r} is a perception action, so the step must say what it observed, "
                        f"e.g. '{name}={action.observation.name(0)}'; {action.observation.choices()}"
                    )
                index = None
            else:
                index = action.observation.index(observation)
        except InvalidValueError as exc:
            raise InvalidValueError(f"step {number} {text!r}: {exc}") from None
        steps.append(Step(text, action, observation, index))
    return steps


@dataclass(frozen=True)
class Tracked:
    number: int
    """1 for the first step."""
    step: Step
    probability: float | None
    """``p(o | a, b)`` before the step; None when nothing was observed."""
    belief: np.ndarray
    """The belief after the step."""

    def as_json(self, model: Model) -> dict[str, Any]:
        """What ``track --json`` prints for the step: as written, and the belief after it by state name."""
        return {
            "step": self.step.text,
            "action": self.step.action.name,
            "observation": self.step.observation,
            "probability": self.probability,
            "belief": by_state_name(model, self.belief),
        }


def track_beliefs(model: Model, belief: np.ndarray, steps: Sequence[Step]) -> Iterator[Tracked]:
    """The Bayes filter over ``steps`` (see :func:`beliefloc.belief.update`), one belief per step,
    lazily so that a caller can show the steps before a failing one.

    An observation impossible under the belief raises :class:`ImpossibleObservationError` naming
    the step.
    """
    for number, step in enumerate(steps, start=1):
        try:
            belief, p = update(model, belief, step.action, step.index)
        except ImpossibleObservationError as exc:
            raise ImpossibleObservationError(f"step {number} {step.text!r}: {exc}") from None
        yield Tracked(number, step, None if step.index is None else p, belief)
