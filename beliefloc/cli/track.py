"""``track``: Markov localization over a logged sequence of actions and observations."""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated

import typer

from beliefloc.cli.common import boundary, initial_belief, print_json, warn_if_too_wide
from beliefloc.cli.options import BeliefOption, CompactOption, JsonOption, ModelArgument, TopOption
from beliefloc.render import stdout_console

if TYPE_CHECKING:
    pass


StepsArgument = Annotated[
    list[str],
    typer.Argument(
        metavar="STEP...",
        help="ACTION or ACTION=OBSERVATION, in order. A perception action needs its observation; "
        "an actuation action without one is a prediction only.",
        show_default=False,
    ),
]


@boundary
def track(
    source: ModelArgument,
    steps: StepsArgument,
    belief_spec: BeliefOption = "uniform",
    compact: CompactOption = None,
    final_only: Annotated[
        bool, typer.Option("--final-only", "--quiet", "-q", help="Draw only the final belief.")
    ] = False,
    top: TopOption = 5,
    json_output: JsonOption = False,
) -> None:
    """Localize over a log: apply each action and observation to the belief (Bayes filter).

    Prints the belief after every step, with p(o | a, b), the probability of what was observed.

    Example: beliefloc track maps/window-2x2.yaml look=window_seen right
    """
    from beliefloc.belief import by_state_name
    from beliefloc.model_sources import open_model
    from beliefloc.render.belief_grid import belief_view
    from beliefloc.render.drawing import uses_color
    from beliefloc.render.state_tables import belief_summary, step_header, summary_line
    from beliefloc.tracking import resolve_steps, track_beliefs

    model = open_model(source)
    belief = initial_belief(model, belief_spec)
    resolved = resolve_steps(model, steps)  # every step checked before the output starts
    if json_output:
        tracked = list(track_beliefs(model, belief, resolved))
        print_json(
            {
                "steps": [t.as_json(model) for t in tracked],
                "belief": by_state_name(model, tracked[-1].belief),
            }
        )
        return
    console = stdout_console()
    color = uses_color(console)
    width = console.width
    warn_if_too_wide(model.grid, compact, width, color)
    for t in track_beliefs(model, belief, resolved):
        if t.number > 1:
            console.print()
        console.print(step_header(t.number, t.step.text, t.step.action.name, t.step.observation, t.probability))
        if t.number == len(resolved):
            view = belief_view(model, t.belief, compact=compact, width=width, color=color, top=top)
            console.print(view, crop=False)
        elif final_only:
            console.print(summary_line(model, t.belief))
        elif model.grid is None:
            console.print(belief_summary(model, t.belief, top=top, color=color))
        else:
            view = belief_view(model, t.belief, compact=compact, width=width, color=color, top=0, legend=False)
            console.print(view, crop=False)


def register(app: typer.Typer) -> None:
    app.command()(track)
