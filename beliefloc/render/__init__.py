"""Rendering: the only package that builds rich renderables. It observes; it never computes."""

from __future__ import annotations

import os

from rich.console import Console


def stdout_console() -> Console:
    """Results go to stdout. Created per command (never at import) so tests can set COLUMNS."""
    return Console(highlight=False, soft_wrap=False, width=_width())


def stderr_console() -> Console:
    """Messages, warnings and progress go to stderr."""
    return Console(stderr=True, highlight=False, width=_width())


def _width() -> int | None:
    columns = os.environ.get("COLUMNS")
    return int(columns) if columns and columns.isascii() and columns.isdigit() and len(columns) < 6 else None
