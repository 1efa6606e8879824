"""Markov localization over a log: the steps a robot took and what it saw, checked against a
model, then the Bayes filter over them (:func:`beliefloc.belief.update`).

A step is written ``ACTION`` or ``ACTION=OBSERVATION``: a perception action must say what it
observed; an actuation action may (with passive sensors their joint reading, otherwise ``none``),
and without an observation it is a prediction only. A *step file* holds one step per line, so that
a logged run can be replayed (:func:`read_step_file`, :func:`step_lines`).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from beliefloc.belief import by_state_name, update
from beliefloc.errors import ImpossibleObservationError, InputFileError, InvalidValueError
from beliefloc.model import Action, Model
from beliefloc.source import read_text

STEP_FORM = "should be ACTION or ACTION=OBSERVATION, e.g. 'right' or 'look=window_seen'"
COMMENT = "#"
"""Starts a comment in a step file, to the end of the line (no action or observation name has it)."""
MAX_STEP_FILE_BYTES = 64 * 2**20
"""A step file larger than this (64 MiB, some million steps) is refused before it is read."""


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
    label: str = ""
    """How messages name the step: ``step 2 'right'``, or ``steps.log:4: 'right'`` for a step file."""


@dataclass(frozen=True)
class StepLine:
    """A step as written in a step file: the text and where."""

    text: str
    label: str
    """``FILE:LINE: 'TEXT'``, how messages name it."""


def step_lines(text: str, name: str) -> list[StepLine]:
    """The steps of a step file's ``text`` (read from ``name``), one per line; blank lines and
    comments (from ``#`` to the end of the line) are skipped. Raises :class:`InvalidValueError`
    when no step is left."""
    steps = []
    for number, line in enumerate(text.splitlines(), start=1):
        step = line.split(COMMENT, 1)[0].strip()
        if step:
            steps.append(StepLine(step, f"{name}:{number}: {step!r}"))
    if not steps:
        raise InvalidValueError(
            f"{name}: no steps, only blank lines and comments; write one step per line, e.g. look=nothing"
        )
    return steps


def read_step_file(path: str | Path) -> list[StepLine]:
    """The steps of a step file (:func:`step_lines`); a file that is missing, not a regular file,
    larger than :data:`MAX_STEP_FILE_BYTES` or not UTF-8 is an :class:`InputFileError` naming it."""
    file_path = Path(path)
    if file_path.is_file() and file_path.stat().st_size > MAX_STEP_FILE_BYTES:
        raise InputFileError(
            f"{file_path}: larger than {MAX_STEP_FILE_BYTES // 2**20} MiB, the most a step file may be"
        )
    if file_path.exists() and not file_path.is_file() and not file_path.is_dir():
        raise InputFileError(f"{file_path}: not a regular file")
    text, _ = read_text(file_path, InputFileError)
    return step_lines(text, str(file_path))


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


def resolve_steps(model: Model, texts: Sequence[str | StepLine]) -> list[Step]:
    """Check every step against ``model`` before any is applied, so a typo in the last step fails
    before the output starts. Messages name the step: ``step 2 'lookk=window': unknown action ...``,
    or for a line of a step file ``steps.log:4: 'lookk=window': unknown action ...``.

    A perception action must say what it observed. An actuation action may: with passive sensors
    their joint reading, otherwise ``none``; without an observation the step is a prediction only.
    """
    steps = []
    known: dict[str, Step] = {}  # a long log repeats a few steps: each text is checked once
    for number, written in enumerate(texts, start=1):
        text, label = (written.text, written.label) if isinstance(written, StepLine) else (written, "")
        label = label or f"step {number} {text!r}"
        same = known.get(text)
        if same is not None:
            steps.append(Step(text, same.action, same.observation, same.index, label))
            continue
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
            raise InvalidValueError(f"{label}: {exc}") from None
        steps.append(Step(text, action, observation, index, label))
        known[text] = steps[-1]
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
            label = step.label or f"step {number} {step.text!r}"
            raise ImpossibleObservationError(f"{label}: {exc}") from None
        yield Tracked(number, step, None if step.index is None else p, belief)
