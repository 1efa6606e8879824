"""``show``: a belief drawn on the map."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import typer

from beliefloc.cli.common import PRIOR_PREFIX, boundary, initial_belief, open_model, print_json, warn, warn_if_too_wide
from beliefloc.cli.options import BeliefOption, CompactOption, JsonOption, ModelArgument, TopOption
from beliefloc.render import stdout_console

if TYPE_CHECKING:
    from beliefloc.model import Model
    from beliefloc.semantic_map import SemanticMap


@boundary
def show(
    source: ModelArgument,
    belief_spec: BeliefOption = "uniform",
    compact: CompactOption = None,
    top: TopOption = 5,
    json_output: JsonOption = False,
) -> None:
    """Draw a belief on the map: a shade per cell and heading, landmarks, the most likely state;
    and the map's rooms (their borders and names) when it has some.

    Heading 0 is north, clockwise. A model without a grid (an imported .pomdp) is shown as a table
    of its most probable states.

    Example: beliefloc show maps/window-2x2.yaml --compact
    Example: beliefloc show maps/apartment.yaml --belief prior:domains/apartment.yaml
    """
    from beliefloc.belief import by_state_name, entropy, most_likely
    from beliefloc.pose import pose_json
    from beliefloc.render.belief_grid import belief_view
    from beliefloc.render.drawing import uses_color
    from beliefloc.render.room_plan import room_legend, room_plan

    model, smap = _open(source)
    belief = initial_belief(model, belief_spec, smap)
    rooms = smap.rooms if smap is not None else {}
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
    console = stdout_console()
    color = uses_color(console)
    warn_if_too_wide(model.grid, compact, console.width, color)
    if belief_spec == "uniform":
        where = "uniform belief"
    elif belief_spec.startswith(PRIOR_PREFIX):
        where = f"the robot's prior from {belief_spec.removeprefix(PRIOR_PREFIX)}"
    else:
        where = f"belief from {belief_spec}"
    title = f"{model.name}: {where} over {model.n_states} states"
    if rooms and model.grid is not None:
        letters = _room_letters(smap) if smap is not None else None
        console.print(f"{model.name}: {len(rooms)} rooms", style="bold")
        console.print(room_plan(model.grid, rooms, letters=letters, width=console.width, color=color), crop=False)
        console.print(room_legend(model.grid, rooms, letters=letters, width=console.width), crop=False)
    view = belief_view(model, belief, compact=compact, width=console.width, color=color, top=top, title=title)
    console.print(view, crop=False)


def _open(source: Path) -> tuple[Model, SemanticMap | None]:
    """The model, and the map it comes from when there is one (to draw its rooms)."""
    from beliefloc.errors import BeliefLocError
    from beliefloc.model_sources import MAP_SUFFIXES, source_map

    if source.suffix.lower() in MAP_SUFFIXES:
        from beliefloc.semantic_map import compile_model, load_map

        smap = load_map(source, on_warning=warn)
        return compile_model(smap), smap
    model = open_model(source)
    if model.grid is None or model.source is None:
        return model, None
    try:
        return model, source_map(model)
    except BeliefLocError:  # the map moved or changed: draw the belief without rooms
        return model, None


def _room_letters(smap: SemanticMap) -> dict[str, str] | None:
    """The letters of a room layout's legend, so that the plan uses the map's own letters."""
    spec = smap.room_spec
    if spec is None or spec.legend is None:
        return None
    return {name: letter for letter, name in spec.legend.items()}


def register(app: typer.Typer) -> None:
    app.command()(show)
