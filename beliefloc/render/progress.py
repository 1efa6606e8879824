"""A progress bar for long runs, on stderr."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn


def progress_bar(console: Console) -> Progress:
    """Transient: it disappears when done and is not drawn when stderr is not a terminal."""
    return Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        console=console,
        transient=True,
        disable=not console.is_terminal,  # a pipe or a log gets nothing, not even a blank line
    )


SEARCH_QUIET_SECONDS = 1.0
"""A search shows its progress line only once it has run this long."""


@contextmanager
def search_progress(console: Console, time_limit: float) -> Iterator[Callable[[int, int, float], None]]:
    """A callback for :func:`beliefloc.planning.best_first.plan` that draws one transient line on
    ``console`` -- beliefs expanded and generated, seconds of the time limit -- once the search has
    run for :data:`SEARCH_QUIET_SECONDS`; nothing when the console is not a terminal."""
    progress = Progress(
        TextColumn("searching"),
        BarColumn(),
        TextColumn("{task.fields[effort]}"),
        console=console,
        transient=True,
        disable=not console.is_terminal,
    )
    task = progress.add_task("search", total=time_limit, visible=False, effort="")

    def update(expanded: int, generated: int, seconds: float) -> None:
        if seconds < SEARCH_QUIET_SECONDS:
            return
        effort = f"{expanded:,} beliefs expanded, {generated:,} generated, {seconds:.0f} of {time_limit:g} s"
        progress.update(task, completed=seconds, visible=True, effort=effort)

    with progress:
        yield update
