"""``track``: Markov localization over a logged sequence of actions and observations."""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Annotated, Any

import numpy as np
import typer

from beliefloc.belief import update
from beliefloc.cli.common import belief_dict, boundary, initial_belief, open_model, print_json
from beliefloc.cli.show import BeliefOption, CompactOption, JsonOption, SourceArgument, TopOption, warn_if_too_wide
from beliefloc.errors import ImpossibleObservationError, UsageError
from beliefloc.model import Action, Model
from beliefloc.render import stdout_console
from beliefloc.render.grid import belief_summary, belief_view, step_header, summary_line, uses_color

STEP_FORM = "should be ACTION or ACTION=OBSERVATION, e.g. 'right' or 'look=window_seen'"


@dataclass(frozen=True)
class Step:
    """One logged step, checked against a model."""

    text: str
    """As written on the command line."""
    action: Action
    observation: str | None
    """As written; None when nothing was observed (prediction only)."""
    index: int | None
    """The observation's index in ``action.observation``; None when nothing was observed."""


def parse_step(text: str) -> tuple[str, str | None]:
    """``"look=window_seen"`` -> ``("look", "window_seen")``; ``"right"`` -> ``("right", None)``.

    Raises :class:`UsageError` for an empty action, an empty observation or a second ``=``; the
    caller says which step it was.
    """
    action, sep, observation = text.partition("=")
    action, observation = action.strip(), observation.strip()
    if not action or any(ch.isspace() for ch in action) or (sep and not observation) or "=" in observation:
        raise UsageError(STEP_FORM)
    return action, (observation if sep else None)


def resolve_steps(model: Model, texts: Sequence[str]) -> list[Step]:
    """Check every step against ``model`` before any is applied, so a typo in the last step fails
    before the output starts. Messages name the step: ``step 2 'lookk=window': unknown action ...``.

    A perception action must say what it observed. An actuation action may: with passive sensors
    their joint reading, otherwise ``none``; without an observation the step is a prediction only.
    """
    steps = []
    for number, text in enumerate(texts, start=1):
        try:
            name, observation = parse_step(text)
            action = model.action(name)
            if observation is None:
                if not action.is_actuation:
                    raise UsageError(
                        f"{name!r} is a perception action, so the step must say what it observed, "
                        f"e.g. '{name}={action.observation.name(0)}'; {action.observation.choices()}"
                    )
                index = None
            else:
                index = action.observation.index(observation)
        except UsageError as exc:
            raise UsageError(f"step {number} {text!r}: {exc}") from None
        steps.append(Step(text, action, observation, index))
    return steps


@dataclass(frozen=True)
class Tracked:
    number: int
    """1 for the first step."""
    step: Step
    probability: float | None
    """``p(o | a, b)`` before the step; None when nothing was observed."""
    belief: np.ndarray
    """The belief after the step."""


def track_beliefs(model: Model, belief: np.ndarray, steps: Sequence[Step]) -> Iterator[Tracked]:
    """The Bayes filter over ``steps`` (see :func:`beliefloc.belief.update`), one belief per step,
    lazily so that a caller can show the steps before a failing one.

    An observation impossible under the belief raises :class:`ImpossibleObservationError` naming
    the step.
    """
    for number, step in enumerate(steps, start=1):
        try:
            belief, p = update(model, belief, step.action, step.index)
        except ImpossibleObservationError as exc:
            raise ImpossibleObservationError(f"step {number} {step.text!r}: {exc}") from None
        yield Tracked(number, step, None if step.index is None else p, belief)


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
    source: SourceArgument,
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
    model = open_model(source)
    belief = initial_belief(model, belief_spec)
    resolved = resolve_steps(model, steps)
    if json_output:
        tracked = list(track_beliefs(model, belief, resolved))
        print_json(
            {
                "steps": [_step_json(model, t) for t in tracked],
                "belief": belief_dict(model, tracked[-1].belief),
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


def _step_json(model: Model, tracked: Tracked) -> dict[str, Any]:
    return {
        "step": tracked.step.text,
        "action": tracked.step.action.name,
        "observation": tracked.step.observation,
        "probability": tracked.probability,
        "belief": belief_dict(model, tracked.belief),
    }


def register(app: typer.Typer) -> None:
    app.command()(track)
