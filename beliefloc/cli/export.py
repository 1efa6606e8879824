"""``export``: write a model in Cassandra's ``.pomdp`` format for other POMDP solvers."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape

from beliefloc.cli.common import boundary, check_output, open_model, print_json
from beliefloc.cli.options import JsonOption, ModelArgument
from beliefloc.errors import UsageError
from beliefloc.files.model_sources import POMDP_SUFFIX
from beliefloc.render import stdout_console


@boundary
def export(
    source: ModelArgument,
    output: Annotated[
        Path, typer.Option("-o", "--output", metavar="FILE.pomdp", help="The file to write.", show_default=False)
    ],
    json_output: JsonOption = False,
) -> None:
    """Write a model in Cassandra's .pomdp format (pomdp-solve, SARSOP, POMDPs.jl, pomdp_py).

    Costs become negative rewards and the discount is 0.95 (localization has none of its own).
    Names are turned into identifiers the format accepts (state 1,2,0 becomes s1_2_0); comment
    lines keep the original names and the grid, so beliefloc reads the file back exactly.

    Example:

    \b
      beliefloc export maps/window-2x2.yaml -o window.pomdp
    """
    from beliefloc.pomdp_format import write_pomdp
    from beliefloc.source.file_kinds import POMDP

    if output.suffix.lower() != POMDP_SUFFIX:
        raise UsageError(f"-o {output}: the exported file must end in {POMDP_SUFFIX}")
    if not output.parent.is_dir():
        raise UsageError(f"-o {output}: cannot write there: the folder {output.parent} does not exist")
    check_output("-o", output, (POMDP_SUFFIX,), (source,), POMDP)

    model = open_model(source)
    summary = write_pomdp(model, output)
    if json_output:
        print_json(summary.as_json())
    else:
        stdout_console().print(
            f"wrote {escape(summary.output)}: {summary.states} states, {summary.actions} actions, "
            f"{summary.observations} observations"
        )


def register(app: typer.Typer) -> None:
    """Adds the command to the app."""
    app.command(short_help="Write a model as a Cassandra .pomdp file.")(export)
