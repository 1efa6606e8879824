"""``beliefloc localize``'s line protocol: one JSON object per line each way.

beliefloc writes an ``action`` message (:func:`action_message`), the robot executes the action and
answers with one line, ``{"seq": N, "readings": {SENSOR: RAW, ...}}``; at the end beliefloc writes
a ``result`` message (or an ``error`` message when a reply cannot be used). Every message is
described, with examples, in ``docs/localize-protocol.md``; the raw readings are binned by
:mod:`beliefloc.robots.readings`.

:class:`LineRobot` is the :class:`~beliefloc.robots.localize.ReadingRobot` on the other end of two line
streams. It reads exactly one line per action (never ahead) and checks it before anything else
uses it: JSON, an object with the right sequence number, no unknown key; a line that is not is a
:class:`~beliefloc.errors.ReplyError` naming the line.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping
from typing import Any

from beliefloc.errors import InvalidValueError, ReplyError
from beliefloc.model import Model
from beliefloc.robots.localize import Command, Localization
from beliefloc.robots.odometry import MotionReport, motion, parse_report
from beliefloc.robots.readings import RawReading, ReadingBinner

PROTOCOL_VERSION = 1
MAX_LINE_CHARS = 1 << 20
"""A reply longer than this (1 MiB) is refused: no reading needs it."""
REPLY_KEYS = ("seq", "readings", "odometry", "blocked")
"""``odometry`` and ``blocked`` are optional (:mod:`beliefloc.robots.odometry`); protocol 1 replies have neither."""

ReadLine = Callable[[int], str]
"""``readline(limit)`` of a text stream: one line with its newline, at most ``limit`` characters,
``""`` at the end of input."""
WriteLine = Callable[[str], None]
"""Writes one line (the newline is added) and flushes it."""


def action_message(command: Command, binner: ReadingBinner) -> dict[str, Any]:
    """The ``action`` message: the action, what it asks the robot to do, the sensors to read and the
    readings the plan expects (raw, in the middle of the expected bins)."""
    action = command.action
    expected = None
    if command.expected is not None:
        expected = {
            "observation": action.observation.name(command.expected),
            "readings": binner.example(action, command.expected),
        }
    return {
        "message": "action",
        "protocol": PROTOCOL_VERSION,
        "seq": command.seq,
        "action": action.name,
        "kind": action.kind.value,
        "motion": motion(binner.model.grid, action),
        "sensors": binner.describe(action),
        "expected": expected,
        "planned": command.plan is not None,
    }


def result_message(outcome: Localization, model: Model) -> dict[str, Any]:
    """The last line when the loop ends: :meth:`Localization.as_json`."""
    return {"message": "result", "protocol": PROTOCOL_VERSION, **outcome.as_json(model)}


def error_message(text: str) -> dict[str, Any]:
    """The last line when a reply cannot be used (the same paragraph goes to stderr)."""
    return {"message": "error", "protocol": PROTOCOL_VERSION, "error": text}


def _constant(name: str) -> float:
    """JSON's non-standard constants as Python writes them: ``Infinity`` is a range with no wall;
    NaN is no reading at all."""
    if name == "NaN":
        raise ValueError("NaN is not a reading")
    return math.inf if name == "Infinity" else -math.inf


def _integer(text: str) -> int:
    """A JSON integer in a reply: at most 18 digits (a 311-digit range is no reading; as a float it
    would overflow)."""
    if len(text.lstrip("-")) > 18:
        raise ValueError(f"a {len(text.lstrip('-'))}-digit integer is out of range for any reading")
    return int(text)


class LineRobot:
    """A robot on the other end of two line streams (see the module)."""

    def __init__(
        self, binner: ReadingBinner, read_line: ReadLine, write_line: WriteLine, *, source: str = "stdin"
    ) -> None:
        self.binner = binner
        self.read_line = read_line
        self.write_line = write_line
        self.source = source
        self.lines_read = 0
        self._report: MotionReport | None = None

    def motion_report(self) -> MotionReport | None:
        """What the last reply said the robot did (odometry, blocked), or None."""
        return self._report

    def send(self, message: Mapping[str, Any]) -> None:
        self.write_line(json.dumps(message, allow_nan=False))

    def act(self, command: Command) -> Mapping[str, RawReading]:
        self.send(action_message(command, self.binner))
        return self.reply(command)

    def finish(self, outcome: Localization) -> None:
        self.send(result_message(outcome, self.binner.model))

    def reply(self, command: Command) -> Mapping[str, RawReading]:
        """Read and check the one line that answers ``command``: its readings, by sensor name."""
        what = f"the reply to action {command.seq} ({command.action.name})"
        try:
            line = self.read_line(MAX_LINE_CHARS + 1)
        except UnicodeDecodeError as exc:
            raise ReplyError(
                f"{self.source} line {self.lines_read + 1}, {what}: not UTF-8 text ({exc.reason})"
            ) from None
        except TimeoutError as exc:  # the reader's --reply-timeout: exc says how long it waited
            raise ReplyError(f"{self.source}: no reply to action {command.seq} ({command.action.name}) {exc}") from None
        if line == "":
            raise ReplyError(f"{self.source} ended before {what}")
        self.lines_read += 1
        where = f"{self.source} line {self.lines_read}, {what}"
        if len(line) > MAX_LINE_CHARS:
            raise ReplyError(f"{where}: longer than {MAX_LINE_CHARS} characters")
        text = line.strip()
        example = f'{{"seq": {command.seq}, "readings": {{...}}}}'
        if not text:
            raise ReplyError(f"{where}: an empty line; expected one JSON object such as {example}")
        try:
            data = json.loads(text, parse_constant=_constant, parse_int=_integer)
        except ValueError as exc:
            raise ReplyError(f"{where}: not JSON ({exc}); expected one JSON object such as {example}") from None
        except RecursionError:
            raise ReplyError(f"{where}: JSON nested too deeply") from None
        if not isinstance(data, dict):
            raise ReplyError(f"{where}: a JSON object such as {example} was expected, got {_kind(data)}")
        unknown = [key for key in data if key not in REPLY_KEYS]
        if unknown:
            raise ReplyError(
                f"{where}: unknown key {unknown[0]!r}; a reply has 'seq' and 'readings', and after a move "
                "optionally 'odometry' and 'blocked'"
            )
        seq = data.get("seq")
        if isinstance(seq, bool) or not isinstance(seq, int):
            raise ReplyError(f"{where}: 'seq' should be the action's sequence number {command.seq}, got {seq!r}")
        if seq != command.seq:
            raise ReplyError(
                f"{where}: out of order: 'seq' is {seq}, but the action waiting for a reply is {command.seq}"
            )
        try:
            self._report = parse_report(data, command.action, self.binner.model.grid)
        except InvalidValueError as exc:
            raise ReplyError(f"{where}: {exc}") from None
        readings = data.get("readings", {})
        if not isinstance(readings, dict):
            raise ReplyError(
                f"{where}: 'readings' should map each sensor's name to its raw reading, got {_kind(readings)}"
            )
        return readings


def _kind(value: object) -> str:
    names = {list: "a list", str: "a string", int: "a number", float: "a number", bool: "a boolean", dict: "an object"}
    return "null" if value is None else names.get(type(value), type(value).__name__)
