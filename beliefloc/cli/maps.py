"""``validate``, ``build`` and ``inspect``: maps and compiled models."""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.markup import escape

from beliefloc.cli.common import boundary, check_output, open_model, print_json, report_error, warn
from beliefloc.cli.options import JsonOption, ModelArgument
from beliefloc.errors import EXIT_BAD_INPUT, BeliefLocError, OutputError, UsageError
from beliefloc.files.model_sources import MODEL_SUFFIX
from beliefloc.render import stdout_console

if TYPE_CHECKING:
    from beliefloc.semantic_map import SemanticMap


def validate(
    maps: Annotated[list[Path], typer.Argument(metavar="MAP...", help="Map files to check.", show_default=False)],
    json_output: JsonOption = False,
) -> None:
    """Check map files and print a one-line summary of each valid one (its grid, states, actions,
    sensors and rooms).

    Example:

    \b
      beliefloc validate maps/*.yaml
    """
    from beliefloc.semantic_map import describe_map, load_map

    results = []
    for path in maps:
        try:
            smap = load_map(path, on_warning=warn)
            summary = describe_map(smap)
        except BeliefLocError as exc:
            results.append({"file": str(path), "valid": False, "error": str(exc)})
            if not json_output:
                report_error(exc)
            continue
        result = {
            "file": str(path),
            "valid": True,
            "error": None,
            "name": summary.name,
            "states": summary.n_states,
            "actions": summary.action_names,
            "rooms": {name: int(mask.sum()) for name, mask in smap.rooms.items()},
        }
        results.append(result)
        if not json_output:
            grid = summary.grid
            where = f"{grid.rows}x{grid.cols} grid, "
            observed = ", ".join(
                f"{a.name}: {a.observation.n_observations} observations" for a in summary.perception_actions
            )
            stdout_console().print(
                f"[green]ok[/] {escape(str(path))}: {escape(summary.name)}, {where}{summary.n_states} states, "
                f"{len(summary.actuation_actions)} actuation actions"
                + (f", {escape(observed)}" if observed else "")
                + escape(_rooms_summary(smap)),
                soft_wrap=True,
            )
    if json_output:
        print_json(results)
    if not all(r["valid"] for r in results):
        raise typer.Exit(EXIT_BAD_INPUT)


def _rooms_summary(smap: SemanticMap) -> str:
    """``, 5 rooms (bedroom, study, ...)`` and how many free cells are in none; empty without rooms."""
    import numpy as np

    rooms = smap.rooms
    if not rooms:
        return ""
    in_rooms = np.logical_or.reduce(list(rooms.values()))
    outside = int((smap.free & ~in_rooms).sum())
    text = f", {len(rooms)} room{'s' if len(rooms) != 1 else ''} ({', '.join(rooms)})"
    if outside:
        text += f" and {outside} free cell{'s' if outside != 1 else ''} in no room"
    return text


@boundary
def build(
    map_file: Annotated[Path, typer.Argument(metavar="MAP", help="The map to compile.", show_default=False)],
    output: Annotated[
        Path, typer.Option("-o", "--output", metavar="FILE.npz", help="Model file to write.", show_default=False)
    ],
    uncompressed: Annotated[
        bool,
        typer.Option(
            "--uncompressed",
            help="Store the arrays without compressing them: a file about eight times larger that loads faster "
            "(no inflating; for worlds of a million states and more).",
        ),
    ] = False,
    json_output: JsonOption = False,
) -> None:
    """Compile a map into a model file (transition and observation matrices).

    Example:

    \b
      beliefloc build maps/kitchen.yaml -o kitchen.npz
      beliefloc build maps/kitchen.yaml -o kitchen-stored.npz --uncompressed
    """
    from beliefloc.files.model_file import save_model
    from beliefloc.model import model_summary
    from beliefloc.render.tables import model_table
    from beliefloc.source.file_kinds import MODEL

    if output.suffix.lower() != MODEL_SUFFIX:
        raise UsageError(f"-o {output}: a model file must end in {MODEL_SUFFIX}")
    check_output("-o", output, (MODEL_SUFFIX,), (map_file,), MODEL)
    start = time.perf_counter()
    model = open_model(map_file)
    seconds = time.perf_counter() - start
    try:
        save_model(model, output, compress=not uncompressed)
    except OutputError as exc:
        raise OutputError(f"-o {output}: cannot write the model ({exc.reason})", exc.reason) from None
    summary = model_summary(model)
    if json_output:
        print_json({**summary, "output": str(output), "seconds": seconds})
    else:
        console = stdout_console()
        console.print(model_table(summary, seconds))
        console.print(f"wrote {escape(str(output))}")


@boundary
def inspect(
    source: ModelArgument,
    json_output: JsonOption = False,
) -> None:
    """Show a model's states, actions, observations, sizes, sparsity and build time.

    Example:

    \b
      beliefloc inspect maps/kitchen.yaml
    """
    from beliefloc.model import model_summary
    from beliefloc.render.tables import model_table

    start = time.perf_counter()
    model = open_model(source)
    seconds = time.perf_counter() - start
    summary = model_summary(model)
    if json_output:
        print_json({**summary, "seconds": seconds})
    else:
        stdout_console().print(model_table(summary, seconds))


def register(app: typer.Typer) -> None:
    app.command(short_help="Check map files; summarise each valid one.")(validate)
    app.command(short_help="Compile a map into a model file (.npz).")(build)
    app.command(short_help="Show a model's states, actions, observations and sizes.")(inspect)
