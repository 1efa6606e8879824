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
    return step_lines(step_file_text(file_path), str(file_path))


def step_file_text(file_path: Path) -> str:
    """A step file's text, after :func:`read_step_file`'s guards."""
    if file_path.is_file() and file_path.stat().st_size > MAX_STEP_FILE_BYTES:
        raise InputFileError(
            f"{file_path}: larger than {MAX_STEP_FILE_BYTES // 2**20} MiB, the most a step file may be"
        )
    if file_path.exists() and not file_path.is_file() and not file_path.is_dir():
        raise InputFileError(f"{file_path}: not a regular file")
    text, _ = read_text(file_path, InputFileError)
    return text


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
        steps.append(_resolve(model, text, label))
        known[text] = steps[-1]
    return steps


def _resolve(model: Model, text: str, label: str) -> Step:
    """One step's ``text`` checked against ``model``; a message names it by ``label``."""
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
    return Step(text, action, observation, index, label)


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


@dataclass(frozen=True)
class StepLog:
    """A logged run held compactly: a log of a million lines repeats a few steps, so each distinct
    step is checked and kept once (``steps``, in the order they first appear) and each logged step
    is the index of its distinct step (``codes``). Built by :func:`argument_log`, :func:`text_log`
    or :func:`read_step_log`; replayed by :func:`track_chunks`."""

    steps: tuple[Step, ...]
    codes: np.ndarray
    """int32, one per logged step: its index in ``steps``."""
    lines: np.ndarray | None = None
    """int32, one per logged step: its line in the step file ``source``; None for arguments."""
    source: str = ""

    def __len__(self) -> int:
        return len(self.codes)

    def step(self, i: int) -> Step:
        """The ``i``-th logged step (from 0), labelled as messages name it."""
        step = self.steps[int(self.codes[i])]
        if self.lines is None:
            label = f"step {i + 1} {step.text!r}"
        else:
            label = f"{self.source}:{int(self.lines[i])}: {step.text!r}"
        return Step(step.text, step.action, step.observation, step.index, label)


def argument_log(model: Model, texts: Sequence[str]) -> StepLog:
    """The steps given as arguments, checked (:func:`resolve_steps`)."""
    steps = resolve_steps(model, texts)
    distinct: dict[str, int] = {}
    for step in steps:
        distinct.setdefault(step.text, len(distinct))
    firsts = {step.text: step for step in reversed(steps)}
    ordered = tuple(firsts[text] for text in distinct)
    return StepLog(ordered, np.array([distinct[step.text] for step in steps], dtype=np.int32))


def text_log(model: Model, text: str, name: str) -> StepLog:
    """The steps of a step file's ``text`` (read from ``name``) as :func:`step_lines` and
    :func:`resolve_steps` read and check them, with the same messages, but each distinct line
    looked at once and the log held compactly (:class:`StepLog`)."""
    lines = text.splitlines()
    by_line: dict[str, int] = {}  # each distinct raw line, in the order they first appear -> its step, or -1
    by_text: dict[str, int] = {}
    steps: list[Step] = []
    for line in dict.fromkeys(lines):
        step = line.split(COMMENT, 1)[0].strip()
        code = -1 if not step else by_text.get(step)
        if code is None:
            number = lines.index(line) + 1  # its first line: the first one a message can name
            code = by_text[step] = len(steps)
            steps.append(_resolve(model, step, f"{name}:{number}: {step!r}"))
        by_line[line] = code
    every = np.fromiter(map(by_line.__getitem__, lines), dtype=np.int32, count=len(lines))
    kept = every >= 0
    if not kept.any():
        raise InvalidValueError(
            f"{name}: no steps, only blank lines and comments; write one step per line, e.g. look=nothing"
        )
    return StepLog(tuple(steps), every[kept], (np.flatnonzero(kept) + 1).astype(np.int32), name)


def read_step_log(model: Model, path: str | Path) -> StepLog:
    """A step file read (:func:`read_step_file`'s guards and messages) and checked (:func:`text_log`)."""
    file_path = Path(path)
    return text_log(model, step_file_text(file_path), str(file_path))


@dataclass(frozen=True)
class TrackedChunk:
    """Consecutive steps of a log after the Bayes filter: :func:`track_chunks`."""

    start: int
    """The first step's place in the log, from 0."""
    codes: np.ndarray
    """Each step's index in :attr:`StepLog.steps`."""
    probabilities: np.ndarray
    """``p(o | a, b)`` before each step; 1.0 where nothing was observed (see the step's ``index``)."""
    beliefs: np.ndarray
    """``(steps, states)``: the belief after each step."""


CHUNK_STEPS = 512
"""Steps a chunk holds, at most: a few hundred kB for the kitchen's 36 states. Larger chunks were
slower: each chunk's arrays (and ``track --json``'s text) were memory the kernel had to map anew."""
CHUNK_VALUES = 1 << 18
"""Beliefs' values a chunk holds, at most (2 MB): a map of 50,000 states gets chunks of 5 steps."""


def track_chunks(model: Model, belief: np.ndarray, log: StepLog, size: int | None = None) -> Iterator[TrackedChunk]:
    """:func:`track_beliefs` over a :class:`StepLog`, ``size`` steps at a time (default:
    :data:`CHUNK_STEPS`, fewer for a large map: :data:`CHUNK_VALUES`), with the same
    beliefs bit for bit and the same messages: a million-step log spends a few microseconds a step.

    Each distinct action's ``T_aᵀ`` is held as ``(width, states)`` arrays of its CSR rows padded with
    zeros, so that ``T_aᵀ b`` is a gather, a product and ``width - 1`` additions in scipy's own order
    (each row summed from its first stored entry on; ``x + 0.0 * b_0`` is ``x``), and each distinct
    observation's likelihood column is computed once. When a step's observation is impossible, the
    steps before it come as a last, shorter chunk, then :class:`ImpossibleObservationError` naming
    the step."""
    kernels = [_kernel(step) for step in log.steps]
    add = np.add.reduce
    current = np.ascontiguousarray(belief, dtype=np.float64)
    n = len(current)
    if size is None:
        size = max(1, min(CHUNK_STEPS, CHUNK_VALUES // max(n, 1)))
    for start in range(0, len(log), size):
        codes = log.codes[start : start + size]
        beliefs = np.empty((len(codes), n))
        probabilities = np.ones(len(codes))
        for k, code in enumerate(codes.tolist()):
            gather, weights, likelihood = kernels[code]
            if gather is None:
                predicted = current
            elif len(gather) == 0:
                predicted = np.zeros(n)
            else:
                products = weights * current[gather]
                predicted = products[0] if len(products) == 1 else products[0] + products[1]
                for more in products[2:]:
                    predicted += more
            row = beliefs[k]
            if likelihood is None:
                row[:] = predicted
            else:
                weighted = predicted * likelihood
                total = float(add(weighted))  # weighted.sum(), without its Python frames
                if not total > 0.0:
                    if k:
                        yield TrackedChunk(start, codes[:k], probabilities[:k], beliefs[:k])
                    _impossible(model, current, log.step(start + k))
                np.divide(weighted, total, out=row)
                probabilities[k] = total
            current = row
        yield TrackedChunk(start, codes, probabilities, beliefs)


_Kernel = tuple["np.ndarray | None", "np.ndarray | None", "np.ndarray | None"]


def _kernel(step: Step) -> _Kernel:
    """``(gather, weights, likelihood)`` of a step for :func:`track_chunks`: ``T_aᵀ``'s rows padded
    to one width (None for a perception action) and ``O_a[:, o]`` (None when nothing was observed)."""
    likelihood = None if step.index is None else step.action.observation.likelihood(step.index)
    transposed = step.action.transition_transposed
    if transposed is None:
        return None, None, likelihood
    n = transposed.shape[0]
    counts = np.diff(transposed.indptr)
    width = int(counts.max()) if n else 0
    rows = np.repeat(np.arange(n), counts)
    place = np.arange(transposed.nnz) - np.repeat(transposed.indptr[:-1], counts)  # each entry's rank in its row
    gather = np.zeros((width, n), dtype=np.intp)
    weights = np.zeros((width, n))
    gather[place, rows] = transposed.indices
    weights[place, rows] = transposed.data
    return gather, weights, likelihood


def _impossible(model: Model, belief: np.ndarray, step: Step) -> None:
    """Raise the error :func:`track_beliefs` raises for ``step`` on ``belief``."""
    try:
        update(model, belief, step.action, step.index)
    except ImpossibleObservationError as exc:
        raise ImpossibleObservationError(f"{step.label}: {exc}") from None
    raise AssertionError(f"{step.label}: the filter found the observation impossible, the belief update did not")
