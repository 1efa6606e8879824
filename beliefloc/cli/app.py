"""The ``beliefloc`` command: one typer app, a module per command group."""

from __future__ import annotations

import typer

from beliefloc import __version__
from beliefloc.cli import (
    export,
    generate,
    init,
    kb,
    localize,
    macros,
    maps,
    plan,
    pose,
    prior,
    schema,
    search,
    select,
    show,
    simulate,
    track,
)

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


def _version(value: bool) -> None:
    if value:
        typer.echo(f"beliefloc {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(False, "--version", callback=_version, is_eager=True, help="Print the version."),
) -> None:
    """beliefloc."""


for module in (
    maps,
    track,
    show,
    pose,
    plan,
    simulate,
    localize,
    select,
    macros,
    prior,
    kb,
    search,
    export,
    generate,
    init,
    schema,
):
    module.register(app)


def main() -> None:
    app()
