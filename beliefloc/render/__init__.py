"""Rendering: the only package that builds rich renderables. It observes; it never computes."""

from __future__ import annotations

import os

from rich.console import Console
from rich.text import Text


def stdout_console() -> Console:
    """Results go to stdout. Created per command (never at import) so tests can set COLUMNS."""
    return Console(highlight=False, soft_wrap=False, width=_width())


def stderr_console() -> Console:
    """Messages, warnings and progress go to stderr."""
    return Console(stderr=True, highlight=False, width=_width())


def _width() -> int | None:
    columns = os.environ.get("COLUMNS")
    return int(columns) if columns and columns.isascii() and columns.isdigit() and len(columns) < 6 else None


def print_lines(console: Console, lines: list[Text]) -> None:
    """Print ``lines``, each as ``console.print(line)`` would, at a fraction of its cost when the
    console draws no styles (a file or a pipe): a line that fits the width is written as it is, and
    only longer ones go through rich (to be wrapped). A run of a million tracked steps prints two
    million lines; rich's own path costs about 0.2 ms a line."""
    from rich.cells import cell_len

    if console.is_terminal or console.color_system is not None:
        for line in lines:
            console.print(line)
        return
    width = console.width
    for line in lines:
        plain = line.plain
        if "\n" not in plain and cell_len(plain) <= width:
            console.file.write(plain + "\n")
        else:
            console.print(line)
