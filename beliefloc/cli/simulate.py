"""``simulate``: whole episodes -- act, perceive, update, replan -- against a simulated robot."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.markup import escape

from beliefloc.cli.common import boundary, initial_belief, open_model, print_json, warn_if_too_wide
from beliefloc.cli.options import (
    BeliefOption,
    CompactOption,
    GammaOption,
    HeuristicOption,
    HWeightOption,
    JsonOption,
    MacrosOption,
    MaxExpansionsOption,
    ModelArgument,
    PlanTimeLimitOption,
    SeedOption,
    ThresholdOption,
    TimingsOption,
    resolve_heuristic,
)
from beliefloc.errors import EXIT_NEGATIVE, UsageError
from beliefloc.planning.settings import (
    DEFAULT_MAX_EXPANSIONS,
    DEFAULT_THRESHOLD,
    DEFAULT_TIME_LIMIT,
    DEFAULT_WEIGHT,
    Planner,
)
from beliefloc.render import stderr_console, stdout_console
from beliefloc.simulation.settings import DEFAULT_MAX_STEPS, StrategyName

if TYPE_CHECKING:
    import numpy as np

    from beliefloc.model import Model
    from beliefloc.simulation.episode import EpisodeRecord, StepRecord


@boundary
def simulate(
    map_file: ModelArgument,
    episodes: Annotated[int, typer.Option("--episodes", "-n", min=1, help="How many episodes.")] = 1,
    seed: SeedOption = 0,
    start: Annotated[
        str,
        typer.Option(
            "--start",
            metavar="STATE|random|prior",
            help="The robot's true start state; 'random': uniform per episode; 'prior': drawn per episode from "
            "the start belief (--belief), e.g. the knowledge base's prior.",
        ),
    ] = "random",
    strategy: Annotated[
        list[str] | None,
        typer.Option(
            "--strategy",
            "-s",
            help=f"Repeat to compare: {', '.join(s.value for s in StrategyName)}.",
            show_default=StrategyName.BESTFIRST.value,
        ),
    ] = None,
    belief: BeliefOption = "uniform",
    threshold: ThresholdOption = DEFAULT_THRESHOLD,
    heuristic: HeuristicOption = None,
    h_weight: HWeightOption = DEFAULT_WEIGHT,
    max_expansions: MaxExpansionsOption = DEFAULT_MAX_EXPANSIONS,
    time_limit: PlanTimeLimitOption = DEFAULT_TIME_LIMIT,
    max_steps: Annotated[
        int,
        typer.Option(
            "--max-steps", "--max-actions", min=1, help="Stop an episode after this many actions (the paper: 500)."
        ),
    ] = DEFAULT_MAX_STEPS,
    macros: MacrosOption = None,
    gamma: GammaOption = None,
    world: Annotated[
        Path | None,
        typer.Option("--world", help="Simulate the robot in this model instead (same states).", show_default=False),
    ] = None,
    show: Annotated[bool, typer.Option("--show", help="Print the belief grid after every step.")] = False,
    compact: CompactOption = None,
    timings: TimingsOption = True,
    json_output: JsonOption = False,
) -> None:
    """Run localization episodes: every strategy from the same seeded starts (paired trials).

    Exit code 1 when an episode of the first strategy does not end localized.

    Example: beliefloc simulate maps/kitchen.yaml --show
    Example: beliefloc simulate maps/kitchen.yaml -n 50 -s bestfirst -s uniform -s random
    Example: beliefloc simulate maps/corridors.yaml -n 20 -s ec2-macros -s ec2 --max-actions 500
    Example: beliefloc simulate maps/apartment.yaml -n 20 --belief prior:domains/apartment.yaml --start prior
    """
    from beliefloc.render.belief_grid import belief_view
    from beliefloc.render.drawing import uses_color
    from beliefloc.render.plan import plan_table, summary_table
    from beliefloc.render.progress import progress_bar
    from beliefloc.simulation.episode import run_experiment, strategy_name, summarize
    from beliefloc.simulation.strategies import EpisodeStatus, PlannerSettings

    chosen_heuristic = resolve_heuristic(Planner.BESTFIRST, heuristic, h_weight)
    names = [strategy_name(name) for name in strategy or [StrategyName.BESTFIRST.value]]
    model = open_model(map_file)
    start_belief = initial_belief(model, belief)
    start_state = None if start in ("random", "prior") else model.states.index(start)
    world_model = _world(world, model) if world is not None else None
    table = None
    if macros is not None:
        from beliefloc.macro_file import load_macros

        table = load_macros(macros, model)
    settings = PlannerSettings(
        threshold,
        chosen_heuristic,
        max_expansions,
        time_limit,
        gamma=gamma,
        macros=table,
        weight=h_weight,
    )

    out = stdout_console()
    color = uses_color(out)
    if show and not json_output:
        warn_if_too_wide(model.grid, compact, out.width, color)
        out.print(belief_view(model, start_belief, compact=compact, width=out.width, color=color, title="start belief"))

    def on_step(record: EpisodeRecord, step: StepRecord, current: np.ndarray) -> None:
        if step.plan is not None:
            what = "plan" if record.steps == 1 else "replan"
            out.print(
                plan_table(
                    step.plan, f"{record.strategy}, episode {record.episode + 1}: {what} ({step.plan.seconds:.3f} s)"
                )
            )
        seen = "" if step.observation is None else f" → {step.observation} (p = {step.probability:.3g})"
        out.print(
            belief_view(
                model,
                current,
                compact=compact,
                width=out.width,
                color=color,
                legend=False,
                title=f"{record.strategy}, episode {record.episode + 1}, step {record.steps}: "
                f"{step.action}{seen}   [true state {step.true_state}]",
            )
        )

    total = episodes * len(names)
    with progress_bar(stderr_console()) as progress:
        task = progress.add_task("episodes", total=total, visible=total > 1 and not show)
        records = run_experiment(
            model,
            names,
            episodes=episodes,
            seed=seed,
            start=start_state,
            start_belief=start_belief,
            start_distribution=start_belief if start == "prior" else None,
            world=world_model,
            settings=settings,
            max_steps=max_steps,
            on_step=on_step if show and not json_output else None,
            on_episode=lambda _: progress.advance(task),
        )
    summary = summarize(records)
    if json_output:
        print_json(
            {
                "episodes": [r.as_json(timings=timings) for r in records],
                "summary": {name: s.as_json(timings=timings) for name, s in summary.items()},
            }
        )
    else:
        if show or episodes == 1:
            for r in records:
                out.print(_episode_line(r))
        out.print(summary_table(summary, threshold))
    first = [r for r in records if r.strategy == names[0].value]
    if any(r.status is not EpisodeStatus.LOCALIZED for r in first):
        raise typer.Exit(EXIT_NEGATIVE)


def _world(path: Path, model: Model) -> Model:

    world = open_model(path)
    if world.states.names != model.states.names:
        raise UsageError(f"{path}: the world must have the same states as {model.name} (the robot's model)")
    return world


def _episode_line(r: EpisodeRecord) -> str:
    from beliefloc.simulation.strategies import EpisodeStatus

    verdict = "localized" if r.status is EpisodeStatus.LOCALIZED else r.status.value.replace("_", " ")
    right = "correctly" if r.correct else "WRONGLY"
    return escape(
        f"{r.strategy}, episode {r.episode + 1}: {verdict} {right} at {r.final} (p = {r.max_belief:.3f}; true "
        f"{r.true_final}, started at {r.start}) after {r.steps} steps, cost {r.cost:g}, {r.replans} replans"
    )


def register(app: typer.Typer) -> None:
    app.command()(simulate)
