"""``macros``: Khalvati & Mackworth's macro actions (Algorithm 2) and the localizability test."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.markup import escape

from beliefloc.cli.common import boundary, check_output, for_option, open_model, print_json
from beliefloc.cli.options import GammaOption, JsonOption, ModelArgument
from beliefloc.errors import EXIT_NEGATIVE, OutputError, UsageError
from beliefloc.render import stderr_console, stdout_console

if TYPE_CHECKING:
    from beliefloc.model import Model
    from beliefloc.planning.macros import MacroTable

macros_app = typer.Typer(
    name="macros",
    help="Macro actions over pairs of states that no sensor tells apart, and the localizability test.",
    short_help="Macro actions for look-alike states; is a map localizable?",
    no_args_is_help=True,
    rich_markup_mode=None,
)


@macros_app.command("build", short_help="Build a map's macro table and say if it is localizable.")
@boundary
def build(
    source: ModelArgument,
    output: Annotated[Path, typer.Option("--output", "-o", metavar="FILE.npz", help="Where to write the macro table.")],
    gamma: GammaOption = None,
    json_output: JsonOption = False,
) -> None:
    """Find, for every pair of states that look alike, the cheapest actions that tell them apart.

    Reports the pairs, the macros and their lengths, and the localizability verdict: the classes of
    states that no sequence of actions ever tells apart (in the noise-free model). The table is
    written either way; exit code 1 when the map is not fully localizable.

    Examples:

    \b
      beliefloc macros build maps/corridors.yaml -o corridors-macros.npz
      beliefloc macros build maps/ladder-symmetric.yaml -o ladder-macros.npz   # exits 1: half-turn twins
    """
    from beliefloc.files.macro_file import save_macros
    from beliefloc.files.model_sources import MODEL_SUFFIX
    from beliefloc.planning.ec2 import pair_context
    from beliefloc.planning.macros import build_macros, check_gamma
    from beliefloc.render.ec2 import classes_table, macro_summary_table
    from beliefloc.render.progress import progress_bar
    from beliefloc.source.file_kinds import MACROS

    check_output("-o", output, (MODEL_SUFFIX,), (source,), MACROS)
    model = open_model(source)
    with progress_bar(stderr_console()) as progress:
        task = progress.add_task("pairs settled", total=None)

        def advance(done: int, total: int) -> None:
            progress.update(task, completed=done, total=total)

        with for_option("--gamma"):
            context = pair_context(model, gamma)
            check_gamma(model, context)
        table = build_macros(model, context=context, progress=advance)  # a map too big for a table: not --gamma's
    try:
        save_macros(table, output, model=model)
    except OutputError as exc:
        raise OutputError(f"-o {output}: cannot write the macro table ({exc.reason})", exc.reason) from None
    summary = table.summary()
    classes = [[model.states.name(s) for s in c] for c in table.never_classes()]
    if json_output:
        print_json({**summary, "never_distinguishable_classes": classes, "output": str(output)})
    else:
        out = stdout_console()
        out.print(macro_summary_table(summary, f"macros of {model.name} -> {output}"))
        if classes:
            out.print(classes_table(classes))
        else:
            out.print("localizable: every pair of states can be told apart by some sequence of actions")
    if classes:
        stderr_console().print(
            f"[bold]not localizable:[/] from the {sum(map(len, classes))} states of these {len(classes)} classes "
            f"the robot can never tell where it is ({summary['never_distinguishable_pairs']} pairs of "
            f"{escape(model.name)} no sequence of actions distinguishes)"
        )
        raise typer.Exit(EXIT_NEGATIVE)


@macros_app.command("show", short_help="Summarise a macro table or explain one pair's macro.")
@boundary
def show(
    macros: Annotated[Path, typer.Argument(metavar="MACROS", help="A table from 'macros build'.", show_default=False)],
    pair: Annotated[
        tuple[str, str] | None,
        typer.Option("--pair", metavar="A B", help="Show the macro of this pair of states.", show_default=False),
    ] = None,
    model_path: Annotated[
        Path | None,
        typer.Option(
            "--model",
            metavar="MAP|MODEL",
            help="The map or model it was built from (default: the one it names).",
            show_default=False,
        ),
    ] = None,
    output: Annotated[
        Path | None,
        typer.Option(
            "-o",
            "--output",
            metavar="FILE.png|FILE.svg",
            help="Also draw the localizability verdict as a picture (needs matplotlib: pip install "
            "'beliefloc[plots]'): every state of a never-distinguishable pair as an arrow at its pose on the map, "
            "a line linking each pair.",
            show_default=False,
        ),
    ] = None,
    json_output: JsonOption = False,
) -> None:
    """Summarise a macro table, or print one pair's macro with the expected path of both states.

    With -o the states the robot can never tell apart are also drawn on the map, and one line says
    what was written.

    Examples:

    \b
      beliefloc macros show corridors-macros.npz --pair 1,2,1 1,12,1
      beliefloc macros show ladder-macros.npz -o ladder-never.png
    """
    from beliefloc.files.macro_file import load_macros, read_header
    from beliefloc.planning.macros import explain_pair, longest_macros
    from beliefloc.render.ec2 import longest_macros_table, macro_path_table, macro_summary_table

    if output is not None:
        from beliefloc.render.figures import PICTURE_SUFFIXES, pyplot
        from beliefloc.source.file_kinds import IMAGE

        inputs = (macros, *(() if model_path is None else (model_path,)))
        check_output("-o", output, PICTURE_SUFFIXES, inputs, IMAGE)
        pyplot()  # matplotlib missing: say so before any work
    header, _ = read_header(macros)
    if model_path is None:
        if not header.get("source"):
            raise UsageError(f"{macros}: the table does not name its map; give it with --model MAP|MODEL")
        model_path = Path(header["source"])
    model = open_model(model_path)
    table = load_macros(macros, model)
    out = stdout_console()
    never_told_apart = False
    if pair is None:
        summary = table.summary()
        longest = longest_macros(model, table)
        if json_output:
            print_json({**summary, "longest": longest})
        else:
            out.print(macro_summary_table(summary, f"macros of {model.name} ({macros})"))
            if longest:
                out.print(longest_macros_table(longest))
    else:
        with for_option("--pair"):
            i, j = (model.states.index(name) for name in pair)
            explained = explain_pair(model, table, i, j)
        never_told_apart = explained.cost is None
        if json_output:
            print_json(explained.as_json())
        else:
            out.print(escape(explained.verdict))
            if explained.steps:
                title = f"macro of ({pair[0]}, {pair[1]}): {' '.join(explained.actions)}, cost {explained.cost:g}"
                out.print(macro_path_table(title, list(explained.steps)))
    if output is not None:
        _write_picture(output, model, table)
        (stderr_console() if json_output else out).print(f"wrote {escape(str(output))}", soft_wrap=True)
    if never_told_apart:
        raise typer.Exit(EXIT_NEGATIVE)


def _write_picture(output: Path, model: Model, table: MacroTable) -> None:
    from beliefloc.render.figures import save_figure
    from beliefloc.render.picture_macros import macros_figure

    if model.grid is None:
        raise UsageError(f"-o {output}: model {model.name} has no grid to draw (an imported .pomdp); drop -o")
    with macros_figure(model, table) as fig:
        save_figure(fig, output)


def register(app: typer.Typer) -> None:
    app.add_typer(macros_app, name="macros")
