"""The ``beliefloc`` command: one typer app, a module per command group."""

from __future__ import annotations

import ctypes
import gc
import importlib
import os
import sys
from typing import Any

import typer

from beliefloc import __version__

COMMANDS: dict[str, str] = {
    "validate": "maps",
    "build": "maps",
    "inspect": "maps",
    "track": "track",
    "show": "show",
    "pose": "pose",
    "plan": "plan",
    "simulate": "simulate",
    "summarize": "summarize",
    "localize": "localize",
    "select": "select",
    "macros": "macros",
    "prior": "prior",
    "kb": "kb",
    "search": "search",
    "export": "export",
    "generate": "generate",
    "init": "init",
    "schema": "schema",
}
"""Each command (or command group) and the module of ``beliefloc.cli`` that registers it, in the order
``beliefloc --help`` lists them (tests/test_help.py checks the table against the modules). A run of one
command registers its module alone (:func:`make_app`): building all of them cost 0.03-0.08 s of typer's
work and 0.05 s of imports before every command (0.1 s of a 1 s ``plan MODEL.npz --json`` at 10^6)."""


def _plain_help() -> None:
    """Two changes to how typer lays out help, for text that can be copied from the terminal:

    - lines never break inside a word at a hyphen (``--max-`` / ``actions``);
    - an argument's metavar (``MAP|MODEL``, ``STEP...``) already says what it is, so typer's Python
      type (``<path>``, ``<list[str]>``) is not added after it.

    Both reach into typer's formatting: when a typer release moves them, help keeps typer's layout,
    and ``tests/test_help.py``, which checks the result on every command, fails."""
    import textwrap

    try:
        from typer._click import _textwrap
        from typer.core import TyperArgument

        shown_type = TyperArgument.display_type_rich
    except (ImportError, AttributeError):  # pragma: no cover - another typer
        return

    class _Wrapper(_textwrap.TextWrapper):
        def __init__(self, *args: Any, **kwargs: Any) -> None:
            kwargs.setdefault("break_on_hyphens", False)
            textwrap.TextWrapper.__init__(self, *args, **kwargs)

    def display_type(self: Any, ctx: Any) -> str | None:
        return None if self.metavar is not None else shown_type(self, ctx)

    _textwrap.TextWrapper = _Wrapper  # type: ignore[misc]
    TyperArgument.display_type_rich = display_type  # type: ignore[method-assign]


def _version(value: bool) -> None:
    if value:
        typer.echo(f"beliefloc {__version__}")
        raise typer.Exit()


def _root(
    version: bool = typer.Option(False, "--version", callback=_version, is_eager=True, help="Print the version."),
) -> None:
    """beliefloc."""


def make_app(command: str | None = None) -> typer.Typer:
    """The ``beliefloc`` typer app with every command, or with ``command``'s module alone (a name of
    :data:`COMMANDS`): what running that command needs, its help and errors the same."""
    app = typer.Typer(
        name="beliefloc",
        help=(
            "Plan what to do and what to look at in belief space: active robot localization on "
            "semantic maps.\n\nExit codes: 0 done, 1 a negative answer (no plan, not localizable, "
            "not found), 2 bad input or usage."
        ),
        no_args_is_help=True,
        add_completion=False,
        pretty_exceptions_enable=False,
        rich_markup_mode=None,
    )
    app.callback()(_root)
    modules = dict.fromkeys(COMMANDS.values()) if command is None else {COMMANDS[command]: None}
    for name in modules:
        importlib.import_module(f"beliefloc.cli.{name}").register(app)
    return app


def command_word(args: list[str]) -> str | None:
    """The command a command line runs: its first word that is not an option (the root's options,
    ``--version`` and ``--help``, take no value), when it is one of :data:`COMMANDS`."""
    word = next((a for a in args if not a.startswith("-")), None)
    return word if word in COMMANDS else None


_plain_help()
_full_app: typer.Typer | None = None


def __getattr__(name: str) -> Any:
    """``app``: the app with every command, built on first use (``from beliefloc.cli.app import app``)."""
    global _full_app
    if name == "app":
        if _full_app is None:
            _full_app = make_app()
        return _full_app
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3  # glibc's mallopt parameters (malloc.h)


def _keep_freed_memory() -> None:
    """Have glibc keep freed blocks of any size for reuse. By default a block above 32 MB is mapped from
    the kernel on its own and unmapped when freed, so a search over 10^7 states, which frees and takes
    80 MB beliefs all along, paid the kernel for fresh zeroed pages each time: 40 such vectors (8 alive)
    took 0.7-2.1 s here, 0.3 s reused. The process keeps the memory it has freed until it ends (its peak
    does not grow: freed blocks are what later ones are cut from). Only where the C library is glibc."""
    try:
        if not (os.confstr("CS_GNU_LIBC_VERSION") or "").startswith("glibc"):
            return
        libc = ctypes.CDLL(None)
        libc.mallopt(_M_MMAP_THRESHOLD, 1 << 30)
        libc.mallopt(_M_TRIM_THRESHOLD, (1 << 31) - 1)
    except (OSError, ValueError, AttributeError):  # pragma: no cover - not glibc, or no mallopt
        return


def main() -> None:
    """Run the command line; what escapes a command's :func:`~beliefloc.cli.common.boundary` (help
    or usage text written to a full stdout, a command that reports its own errors) meets the same
    rules here."""
    from beliefloc.cli.common import fail_outside, lean_scipy_import

    # One BLAS thread unless the user says otherwise (read when numpy loads, which no command has
    # yet): beliefloc's vectors are at most 10^7 long, and on a busy two-core machine threads made a
    # dot product of 10^5 a hundred times slower (a tb3-sandbox localize episode 11 -> 19 s).
    for variable in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "VECLIB_MAXIMUM_THREADS"):
        os.environ.setdefault(variable, "1")
    _keep_freed_memory()
    lean_scipy_import()
    try:
        try:
            make_app(command_word(sys.argv[1:]))()
        finally:
            sys.stdout.flush()  # a full stdout is found here, not at exit where Python hides it
            # The interpreter's exit runs the cyclic collector over every object still alive (typer's,
            # pydantic's and rich's, the model's): 60-85 ms of a 1 s `plan --json` on a 10^6-state
            # model. Frozen, they are out of its reach; they are freed at exit as before (what holds
            # a file or a process is closed by its context manager or by atexit, not by the collector).
            gc.freeze()
    except Exception as exc:
        try:
            fail_outside(exc)
        except typer.Exit as stop:
            sys.exit(stop.exit_code)
        raise
