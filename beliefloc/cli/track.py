"""``track``: Markov localization over a logged sequence of actions and observations."""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING, Annotated

import typer

from beliefloc.cli.common import boundary, initial_belief, open_model, print_json, warn_if_too_wide
from beliefloc.cli.options import BeliefOption, CompactOption, JsonOption, ModelArgument, TopOption
from beliefloc.errors import UsageError
from beliefloc.render import stdout_console

if TYPE_CHECKING:
    from beliefloc.robots.tracking import StepLine


StepsArgument = Annotated[
    list[str] | None,
    typer.Argument(
        metavar="STEP...",
        help="ACTION or ACTION=OBSERVATION, in order. A perception action needs its observation; "
        "an actuation action without one is a prediction only.",
        show_default=False,
    ),
]
StepsFileOption = Annotated[
    str | None,
    typer.Option(
        "--steps",
        metavar="FILE|-",
        help="Read the steps from FILE ('-': stdin), one per line; blank lines and # comments are skipped. "
        "Instead of STEP... arguments, to replay a logged run.",
        show_default=False,
    ),
]
STDIN = "-"


@boundary
def track(
    source: ModelArgument,
    steps: StepsArgument = None,
    steps_file: StepsFileOption = None,
    belief_spec: BeliefOption = "uniform",
    compact: CompactOption = None,
    final_only: Annotated[
        bool, typer.Option("--final-only", "--quiet", "-q", help="Draw only the final belief.")
    ] = False,
    top: TopOption = 5,
    json_output: JsonOption = False,
) -> None:
    """Localize over a log: apply each action and observation to the belief (Bayes filter).

    Prints the belief after every step, with p(o | a, b), the probability of what was observed;
    --json also gives the final belief's most likely state as a map-frame pose with a covariance.

    Examples:

    \b
      beliefloc track maps/window-2x2.yaml look=window_seen right
      printf 'look=nothing   # a step per line, # comments\\nforward\\n' > run.log
      beliefloc track maps/kitchen.yaml --steps run.log
      cat run.log | beliefloc track maps/kitchen.yaml --steps - --json
    """
    from beliefloc.belief import by_state_name
    from beliefloc.pose import pose_json
    from beliefloc.render.belief_grid import belief_view
    from beliefloc.render.drawing import uses_color
    from beliefloc.render.state_tables import belief_summary, step_header, summary_line
    from beliefloc.robots.tracking import resolve_steps, track_beliefs

    written = _steps(steps, steps_file)
    model = open_model(source)
    belief = initial_belief(model, belief_spec)
    resolved = resolve_steps(model, written)  # every step checked before the output starts
    if json_output:
        tracked = list(track_beliefs(model, belief, resolved))
        final = tracked[-1].belief
        print_json(
            {
                "steps": [t.as_json(model) for t in tracked],
                "belief": by_state_name(model, final),
                "pose": pose_json(model, final),
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


def _steps(arguments: list[str] | None, steps_file: str | None) -> list[str] | list[StepLine]:
    """The steps from the arguments or from ``--steps FILE|-``: one or the other."""
    from beliefloc.robots.tracking import MAX_STEP_FILE_BYTES, read_step_file, step_lines

    if steps_file is None:
        if not arguments:
            raise UsageError("no steps: give them as STEP... arguments or one per line with --steps FILE|-")
        return arguments
    if arguments:
        raise UsageError(f"--steps {steps_file}: give the steps either as STEP... arguments or with --steps, not both")
    if steps_file != STDIN:
        return read_step_file(steps_file)
    try:
        text = sys.stdin.read(MAX_STEP_FILE_BYTES + 1)
    except UnicodeDecodeError as exc:
        raise UsageError(f"--steps -: stdin is not UTF-8 text ({exc.reason})") from None
    if len(text) > MAX_STEP_FILE_BYTES:
        raise UsageError(f"--steps -: stdin holds more than {MAX_STEP_FILE_BYTES // 2**20} MiB of steps, the most read")
    return step_lines(text, "<stdin>")


def register(app: typer.Typer) -> None:
    app.command(short_help="Update a belief over a log of actions and observations.")(track)
