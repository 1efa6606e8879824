"""``show``: a belief drawn on the map."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from beliefloc.belief import entropy, most_likely
from beliefloc.cli.common import belief_dict, boundary, initial_belief, open_model, print_json, warn
from beliefloc.model import GridLayout
from beliefloc.render import stdout_console
from beliefloc.render.grid import belief_view, grid_width, resolve_compact, uses_color

SourceArgument = Annotated[
    Path, typer.Argument(metavar="MAP|MODEL", help="A map, model (.npz) or .pomdp file.", show_default=False)
]
BeliefOption = Annotated[
    str,
    typer.Option(
        "--belief",
        metavar="uniform|FILE",
        help="The belief to start from: 'uniform' or a YAML/JSON file {state: probability} "
        "(the output of 'track --json' works too).",
    ),
]
CompactOption = Annotated[
    bool | None,
    typer.Option(
        "--compact/--full",
        help="Force compact cells (2 characters: cell shade, arrow of the most likely heading) or full "
        "cells (a pixel per heading). Default: full when it fits the terminal.",
        show_default=False,
    ),
]
TopOption = Annotated[int, typer.Option("--top", min=0, help="How many of the most likely states to list.")]
JsonOption = Annotated[bool, typer.Option("--json", help="Print machine-readable JSON on stdout.")]


@boundary
def show(
    source: SourceArgument,
    belief_spec: BeliefOption = "uniform",
    compact: CompactOption = None,
    top: TopOption = 5,
    json_output: JsonOption = False,
) -> None:
    """Draw a belief on the map: a shade per cell and heading, landmarks, the most likely state.

    Heading 0 is north, clockwise. A model without a grid (an imported .pomdp) is shown as a table
    of its most probable states.

    Example: beliefloc show maps/window-2x2.yaml --compact
    """
    model = open_model(source)
    belief = initial_belief(model, belief_spec)
    if json_output:
        state, p = most_likely(belief)
        print_json(
            {
                "belief": belief_dict(model, belief),
                "most_likely": {"state": model.states.name(state), "probability": p},
                "entropy": entropy(belief),
            }
        )
        return
    console = stdout_console()
    color = uses_color(console)
    warn_if_too_wide(model.grid, compact, console.width, color)
    where = "uniform belief" if belief_spec == "uniform" else f"belief from {belief_spec}"
    title = f"{model.name}: {where} over {model.n_states} states"
    view = belief_view(model, belief, compact=compact, width=console.width, color=color, top=top, title=title)
    console.print(view, crop=False)


def warn_if_too_wide(grid: GridLayout | None, compact: bool | None, width: int, color: bool) -> None:
    """A warning when even the chosen form of the grid is wider than the terminal."""
    if grid is None:
        return
    chosen = resolve_compact(grid, compact, width, color=color)
    needed = grid_width(grid, compact=chosen, color=color)
    if needed > width:
        hint = "" if chosen else "; --compact is narrower"
        warn(f"the grid is {needed} characters wide but the terminal has {width}: lines will wrap{hint}")


def register(app: typer.Typer) -> None:
    app.command()(show)
