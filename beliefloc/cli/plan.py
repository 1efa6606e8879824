"""``plan``: best-first search in belief space (Colledanchise et al., Algorithm 1's Plan)."""

from __future__ import annotations

import enum
import math
from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape

from beliefloc.cli.common import BELIEF_HELP, boundary, initial_belief, open_model, print_json
from beliefloc.errors import EXIT_NEGATIVE, UsageError
from beliefloc.planning.best_first import (
    DEFAULT_MAX_EXPANSIONS,
    DEFAULT_THRESHOLD,
    DEFAULT_TIME_LIMIT,
    DEFAULT_WEIGHT,
    Heuristic,
    PlanStatus,
    plan,
)
from beliefloc.render import stderr_console, stdout_console
from beliefloc.render.plan import plan_table, search_line


class Search(str, enum.Enum):
    bestfirst = "bestfirst"
    uniform = "uniform"


Threshold = Annotated[
    float, typer.Option("--threshold", min=0.0, max=1.0, help="Goal: one state holds at least this probability.")
]
HeuristicOption = Annotated[
    Heuristic | None,
    typer.Option(
        "--heuristic",
        help="h of best-first search: H(b)/(max(b)·p) (default), H(b)/p (the pseudocode), or zero.",
        show_default=False,
    ),
]
HWeightOption = Annotated[
    float,
    typer.Option(
        "--h-weight",
        help="Best-first ranks beliefs by g + W·h; 1 is the paper's. Below 1 the actions' costs count more: "
        "cheaper plans from a longer search.",
    ),
]
MaxExpansions = Annotated[
    int, typer.Option("--max-expansions", min=1, help="Give up after expanding this many beliefs.")
]
TimeLimit = Annotated[float, typer.Option("--time-limit", min=0.0, help="Give up after this many seconds of search.")]
BeliefOption = Annotated[str, typer.Option("--belief", metavar="uniform|FILE|prior:DOMAIN", help=BELIEF_HELP)]


def resolve_heuristic(search: Search, heuristic: Heuristic | None, weight: float = DEFAULT_WEIGHT) -> Heuristic:
    """``--search uniform`` is h = 0; ``--heuristic`` and ``--h-weight`` only apply to best-first search."""
    check_weight(weight)
    if search is Search.uniform:
        if heuristic not in (None, Heuristic.ZERO):
            raise UsageError("--search uniform is the search with h = 0; drop --heuristic or use --search bestfirst")
        if weight != DEFAULT_WEIGHT:
            raise UsageError("--search uniform is the search with h = 0, so --h-weight has nothing to scale; drop it")
        return Heuristic.ZERO
    return heuristic or Heuristic.ENTROPY_MAX_PROB


def check_weight(weight: float) -> None:
    if not (weight > 0.0 and math.isfinite(weight)):
        raise UsageError(f"--h-weight must be a positive number, got {weight:g}; for h = 0 use --search uniform")


@boundary
def plan_command(
    source: Annotated[
        Path, typer.Argument(metavar="MAP|MODEL", help="A map, model or .pomdp file.", show_default=False)
    ],
    belief: BeliefOption = "uniform",
    threshold: Threshold = DEFAULT_THRESHOLD,
    search: Annotated[
        Search, typer.Option("--search", help="Best-first (with a heuristic) or uniform-cost search.")
    ] = Search.bestfirst,
    heuristic: HeuristicOption = None,
    h_weight: HWeightOption = DEFAULT_WEIGHT,
    max_expansions: MaxExpansions = DEFAULT_MAX_EXPANSIONS,
    time_limit: TimeLimit = DEFAULT_TIME_LIMIT,
    json_output: Annotated[bool, typer.Option("--json", help="Print machine-readable JSON on stdout.")] = False,
) -> None:
    """Find actions and observations that take the belief to one state with probability >= threshold.

    Exit code 1 when there is no plan (every reachable belief was searched) or the search gave up.

    Example: beliefloc plan maps/kitchen.yaml --threshold 0.95
    Example: beliefloc plan maps/apartment.yaml --belief prior:domains/apartment.yaml
    """
    chosen = resolve_heuristic(search, heuristic, h_weight)
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
        print_json(
            {
                "found": result.found,
                "status": result.status.value,
                "cost": result.cost if result.found else None,
                "steps": [
                    {"action": s.action, "observation": s.observation, "max_belief": s.max_belief, "cost": s.cost}
                    for s in result.steps
                ],
                "expanded": result.expanded,
                "generated": result.generated,
                "seconds": result.seconds,
            }
        )
    else:
        out = stdout_console()
        if result.found:
            title = f"plan for {model.name}: cost {result.cost:g}, {len(result.steps)} steps"
            if not result.steps:
                out.print(f"already localized: one state holds at least {threshold:g}")
            else:
                out.print(plan_table(result, title))
        out.print(search_line(result))
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
