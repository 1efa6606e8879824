"""The progress bar of a sweep (``simulate``, ``search simulate``), with its ETA, on stderr."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager

from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)


@contextmanager
def sweep_progress(
    console: Console, description: str, total: int, done: int = 0, *, shown: bool = True
) -> Iterator[Callable[[], None]]:
    """A callback that counts one finished unit. The bar shows units done of ``total`` (``done`` of
    them before this run: a resumed sweep), elapsed time and the time remaining; transient, and not
    drawn at all when ``console`` is not a terminal or ``shown`` is False (every backend: the client counts)."""
    progress = Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        TextColumn("ETA"),
        TimeRemainingColumn(),
        console=console,
        transient=True,
        disable=not (shown and console.is_terminal),  # a pipe or a log gets nothing, not even a blank line
    )
    task = progress.add_task(description, total=total, completed=done, visible=total - done > 1)

    def advance() -> None:
        progress.advance(task)

    with progress:
        yield advance
