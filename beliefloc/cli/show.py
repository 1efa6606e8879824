"""``show``: a belief drawn on the map."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.markup import escape

from beliefloc.cli.common import (
    PRIOR_PREFIX,
    belief_inputs,
    boundary,
    check_output,
    initial_belief,
    open_with_map,
    print_json,
    warn_if_too_wide,
)
from beliefloc.cli.options import BeliefOption, CompactOption, JsonOption, ModelArgument, TopOption
from beliefloc.render import stdout_console

if TYPE_CHECKING:
    import numpy as np

    from beliefloc.model import Model
    from beliefloc.semantic_map import SemanticMap

PictureOption = Annotated[
    Path | None,
    typer.Option(
        "-o",
        "--output",
        metavar="FILE.png|FILE.svg",
        help="Write the belief as a picture (needs matplotlib: pip install 'beliefloc[plots]') "
        "instead of drawing it in the terminal.",
        show_default=False,
    ),
]


@boundary
def show(
    source: ModelArgument,
    belief_spec: BeliefOption = "uniform",
    compact: CompactOption = None,
    top: TopOption = 5,
    json_output: JsonOption = False,
    output: PictureOption = None,
) -> None:
    """Draw a belief on the map: a shade per cell and heading, landmarks, the most likely state;
    and the map's rooms (their borders and names) when it has some.

    Heading 0 is north, clockwise. A model without a grid (an imported .pomdp) is shown as a table
    of its most probable states.

    With -o the picture is written to FILE (.png or .svg, in map-frame metres: the occupancy image,
    rooms, landmarks, a triangle per state shaded darker for more probability, the most likely
    state's arrow) instead of the terminal grid, and one line says so; --json still prints its JSON.

    Examples:

    \b
      beliefloc show maps/window-2x2.yaml --compact
      beliefloc show maps/apartment.yaml --belief prior:domains/apartment.yaml
      beliefloc show maps/kitchen.yaml -o kitchen.png
    """
    from beliefloc.belief import by_state_name, entropy, most_likely
    from beliefloc.pose import pose_json
    from beliefloc.render.belief_grid import belief_view
    from beliefloc.render.drawing import uses_color
    from beliefloc.render.room_plan import room_legend, room_plan

    if output is not None:
        from beliefloc.render.figures import PICTURE_SUFFIXES, pyplot

        check_output("-o", output, PICTURE_SUFFIXES, inputs=(source, *belief_inputs(belief_spec)))
        pyplot()  # matplotlib missing: say so before any work
    model, smap = open_with_map(source)
    belief = initial_belief(model, belief_spec, smap)
    rooms = smap.rooms if smap is not None else {}
    if output is not None:
        _write_picture(output, model, belief, smap, _describe(belief_spec, model))
        if not json_output:
            stdout_console().print(f"wrote {escape(str(output))}", soft_wrap=True)
    if json_output:
        state, p = most_likely(belief)
        data: dict[str, object] = {
            "belief": by_state_name(model, belief),
            "most_likely": {"state": model.states.name(state), "probability": p, "pose": pose_json(model, belief)},
            "entropy": entropy(belief),
        }
        if rooms and model.grid is not None:
            from beliefloc.semantic_map import room_states

            states = room_states(rooms, model.grid)
            data["rooms"] = {name: float(belief[indices].sum()) for name, indices in states.items()}
        print_json(data)
        return
    if output is not None:
        return
    console = stdout_console()
    color = uses_color(console)
    warn_if_too_wide(model.grid, compact, console.width, color)
    title = _describe(belief_spec, model)
    if rooms and model.grid is not None:
        letters = _room_letters(smap) if smap is not None else None
        console.print(f"{model.name}: {len(rooms)} rooms", style="bold")
        console.print(room_plan(model.grid, rooms, letters=letters, width=console.width, color=color), crop=False)
        console.print(room_legend(model.grid, rooms, letters=letters, width=console.width), crop=False)
    view = belief_view(model, belief, compact=compact, width=console.width, color=color, top=top, title=title)
    console.print(view, crop=False)


def _describe(belief_spec: str, model: Model) -> str:
    """The title of the grid and of the picture: the map, where the belief comes from, its size."""
    if belief_spec == "uniform":
        where = "uniform belief"
    elif belief_spec.startswith(PRIOR_PREFIX):
        where = f"the robot's prior from {belief_spec.removeprefix(PRIOR_PREFIX)}"
    else:
        where = f"belief from {belief_spec}"
    return f"{model.name}: {where} over {model.n_states} states"


def _write_picture(output: Path, model: Model, belief: np.ndarray, smap: SemanticMap | None, title: str) -> None:
    from beliefloc.errors import UsageError
    from beliefloc.render.figures import save_figure
    from beliefloc.render.picture_belief import belief_figure

    if model.grid is None:
        raise UsageError(f"-o {output}: model {model.name} has no grid to draw (an imported .pomdp); drop -o")
    with belief_figure(model, belief, smap=smap, title=title) as fig:
        save_figure(fig, output)


def _room_letters(smap: SemanticMap) -> dict[str, str] | None:
    """The letters of a room layout's legend, so that the plan uses the map's own letters."""
    spec = smap.room_spec
    if spec is None or spec.legend is None:
        return None
    return {name: letter for letter, name in spec.legend.items()}


def register(app: typer.Typer) -> None:
    app.command(short_help="Draw a belief on the map.")(show)
