"""``plan``: best-first search in belief space (Colledanchise et al., Algorithm 1's Plan)."""

from __future__ import annotations

import typer
from rich.markup import escape

from beliefloc.cli.common import boundary, initial_belief, open_model, print_json
from beliefloc.cli.options import (
    BeliefOption,
    HeuristicOption,
    HWeightOption,
    JsonOption,
    MaxExpansionsOption,
    ModelArgument,
    PlannerOption,
    PlanTimeLimitOption,
    ThresholdOption,
    resolve_heuristic,
)
from beliefloc.errors import EXIT_NEGATIVE
from beliefloc.planning.settings import (
    DEFAULT_MAX_EXPANSIONS,
    DEFAULT_THRESHOLD,
    DEFAULT_TIME_LIMIT,
    DEFAULT_WEIGHT,
    Planner,
)
from beliefloc.render import stderr_console, stdout_console


@boundary
def plan_command(
    source: ModelArgument,
    belief: BeliefOption = "uniform",
    threshold: ThresholdOption = DEFAULT_THRESHOLD,
    planner: PlannerOption = Planner.BESTFIRST,
    heuristic: HeuristicOption = None,
    h_weight: HWeightOption = DEFAULT_WEIGHT,
    max_expansions: MaxExpansionsOption = DEFAULT_MAX_EXPANSIONS,
    time_limit: PlanTimeLimitOption = DEFAULT_TIME_LIMIT,
    json_output: JsonOption = False,
) -> None:
    """Find actions and observations that take the belief to one state with probability >= threshold.

    Exit code 1 when there is no plan (every reachable belief was searched) or the search gave up.

    Example: beliefloc plan maps/kitchen.yaml --threshold 0.95
    Example: beliefloc plan maps/apartment.yaml --belief prior:domains/apartment.yaml
    """
    from beliefloc.planning.best_first import PlanStatus, plan
    from beliefloc.render.plan import effort_line, plan_table

    chosen = resolve_heuristic(planner, heuristic, h_weight)
    model = open_model(source)
    start = initial_belief(model, belief)
    result = plan(
        model,
        start,
        threshold=threshold,
        heuristic=chosen,
        max_expansions=max_expansions,
        time_limit=time_limit,
        weight=h_weight,
    )
    if json_output:
        print_json(result.as_json(model))
    else:
        out = stdout_console()
        if result.found:
            title = f"plan for {model.name}: cost {result.cost:g}, {len(result.steps)} steps"
            if not result.steps:
                out.print(f"already localized: one state holds at least {threshold:g}")
            else:
                out.print(plan_table(result, title))
        out.print(effort_line(result))
    if result.status is PlanStatus.NO_PLAN:
        stderr_console().print(
            f"[bold]no plan:[/] every belief reachable from the start was searched and none gives one state "
            f"probability >= {threshold:g}; some states of {escape(model.name)} cannot be told apart."
        )
        raise typer.Exit(EXIT_NEGATIVE)
    if result.status is PlanStatus.BUDGET_EXCEEDED:
        stderr_console().print(
            f"[bold]gave up:[/] the search budget ran out ({result.expanded} expansions, {result.seconds:.1f} s) "
            "before a plan was found; raise --max-expansions or --time-limit, or lower --threshold."
        )
        raise typer.Exit(EXIT_NEGATIVE)


def register(app: typer.Typer) -> None:
    app.command("plan")(plan_command)
