"""One exception family for everything the library reports to a user.

The CLI catches :class:`BeliefLocError` at one boundary and turns it into a message on stderr and
the exit code in :attr:`BeliefLocError.exit_code`; any other exception is a bug and keeps its
traceback.
"""

from __future__ import annotations

from collections.abc import Sequence

Path = tuple[str | int, ...]
"""A location inside a structured file: keys and list indices from the root."""

EXIT_NEGATIVE = 1
"""A negative answer: no plan, not localizable, not found."""
EXIT_BAD_INPUT = 2
"""Bad input or usage."""


class BeliefLocError(Exception):
    """Base of every error reported to a user. The message is one readable paragraph."""

    exit_code: int = EXIT_BAD_INPUT


class InputFileError(BeliefLocError):
    """A hand-written input file is broken; the message names the file, line, column and field."""


class MapError(InputFileError):
    """A semantic map file is invalid."""


class OccupancyMapError(MapError):
    """A ROS/Nav2 occupancy map (map YAML + image) or region mask cannot be read; the message names
    the YAML file, the line and the field (for an image problem: the image file and the ``image`` line)."""


class BeliefFileError(InputFileError):
    """A belief file is invalid."""


class DomainError(InputFileError):
    """A domain file is invalid."""


class KnowledgeBaseError(BeliefLocError):
    """A knowledge base cannot be grounded or solved."""


class ModelError(BeliefLocError):
    """A compiled model file or a .pomdp file cannot be used (stale, unreadable, unsupported)."""


class InvalidValueError(BeliefLocError, ValueError):
    """A value handed to the library is not one it can use: an unknown state, action or room, a
    probability outside [0, 1], a malformed step. The message speaks of the value, never of a
    command-line option: the CLI adds the option's name (``cli.common.for_option``)."""


class OutputError(BeliefLocError):
    """A file cannot be written (a folder that vanished, a full disk, no permission); nothing was
    left half written. ``reason`` is the system's word for why."""

    def __init__(self, message: str, reason: str = "") -> None:
        super().__init__(message)
        self.reason = reason


class LimitError(BeliefLocError):
    """An input is larger than a documented bound (:mod:`beliefloc.source.limits`); the message names the
    bound and the environment variable that raises it."""


class UsageError(BeliefLocError):
    """A command-line argument is wrong; raised by the CLI only, with the option's name."""


class ReplyError(BeliefLocError):
    """A robot's reply to an action (``beliefloc localize``'s line protocol) is malformed, out of
    order, missing or cannot be binned; the message names the reply."""


class ImpossibleObservationError(BeliefLocError):
    """An observation has probability zero under the current belief.

    Bayes' rule is undefined there (0/0); rather than return NaN we stop and say why.
    """


class FieldError(Exception):
    """A validation failure at a known place in a file, raised by cross-reference checks.

    Deliberately *not* a ValueError: pydantic lets it through unchanged, so the loader can map
    ``path`` to the YAML line where the offending value was written.
    """

    def __init__(self, path: Sequence[str | int], message: str, *, row: int | None = None, column: int = 0) -> None:
        super().__init__(message)
        self.path: Path = tuple(path)
        self.message = message
        self.row = row
        """For a character grid written as a block (``layout: |``): the row (0-based, blank lines
        skipped) and column of the culprit, so the message points at that very character."""
        self.column = column


class FieldErrors(Exception):
    """Several :class:`FieldError` found in one file, reported together (``validate`` lists every
    problem of a file in one run, up to :data:`beliefloc.source.validation.MAX_ERRORS_SHOWN`)."""

    def __init__(self, errors: Sequence[FieldError]) -> None:
        super().__init__("; ".join(e.message for e in errors))
        self.errors: list[FieldError] = list(errors)


def raise_collected(errors: Sequence[FieldError]) -> None:
    """Raise the one error, or all of them together; nothing when there are none."""
    if len(errors) == 1:
        raise errors[0]
    if errors:
        raise FieldErrors(errors)


class RecordingError(InputFileError):
    """A ROS recording (a rosbag2 folder or file, a ROS 1 ``.bag``) cannot be localized from: the
    message names the bag, the topic and what is wrong with it."""
