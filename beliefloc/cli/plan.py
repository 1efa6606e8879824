"""``plan``: best-first search in belief space (Colledanchise et al., Algorithm 1's Plan)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.markup import escape

from beliefloc.cli.common import (
    belief_inputs,
    boundary,
    check_output,
    initial_belief,
    open_model,
    open_with_map,
    print_json,
    refuse_unreachable,
)
from beliefloc.cli.options import (
    BeliefOption,
    HeuristicOption,
    HWeightOption,
    JsonOption,
    MaxExpansionsOption,
    ModelArgument,
    PlannerOption,
    PlanTimeLimitOption,
    PruneBelowOption,
    ThresholdOption,
    resolve_heuristic,
    whole,
)
from beliefloc.errors import EXIT_NEGATIVE, UsageError
from beliefloc.planning.settings import (
    DEFAULT_MAX_EXPANSIONS,
    DEFAULT_PRUNE_BELOW,
    DEFAULT_THRESHOLD,
    DEFAULT_TIME_LIMIT,
    DEFAULT_WEIGHT,
    Heuristic,
    Planner,
)
from beliefloc.render import stderr_console, stdout_console

if TYPE_CHECKING:
    import numpy as np

    from beliefloc.model import Model

PolicyOption = Annotated[
    bool,
    typer.Option(
        "--policy",
        help="Plan a contingent policy instead of one path: it branches on every observation, with the "
        "least expected cost LAO* finds (--planner uniform: the exact least, small maps only).",
    ),
]
DEFAULT_POLICY_DEPTH = 4
PolicyDepthOption = Annotated[
    int,
    typer.Option(
        "--policy-depth",
        parser=whole(low=1),
        metavar="N",
        help="--policy: levels of the policy printed on the terminal (--json prints all of it).",
    ),
]
PlanPictureOption = Annotated[
    Path | None,
    typer.Option(
        "-o",
        "--output",
        metavar="FILE.png|FILE.svg",
        help="Also write a picture: the start belief with the plan drawn on it and its steps under it "
        "(needs matplotlib: pip install 'beliefloc[plots]'). Written only when a plan is found.",
        show_default=False,
    ),
]


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
    policy: PolicyOption = False,
    policy_depth: PolicyDepthOption = DEFAULT_POLICY_DEPTH,
    prune_below: PruneBelowOption = DEFAULT_PRUNE_BELOW,
    json_output: JsonOption = False,
    output: PlanPictureOption = None,
) -> None:
    """Find actions and observations that take the belief to one state with probability >= threshold.

    Exit code 1 when there is no plan: the start belief lies on look-alike states that no sequence of
    actions tells apart (known before any search, as 'macros build' knows it), every reachable belief
    was searched, or the search gave up. A --threshold that no belief can reach (1 with noisy
    sensors) is refused with exit code 2. When the budget runs out, the best partial plan found is
    shown (its first step is the action a robot would take now; --json: "complete": false), with exit
    code 1.

    Under the plan, its path probability: the probability that the robot sees every expected
    observation of the path (the product of the p(o|a,b) column). A path below 0.05 is flagged as
    unlikely: its cost is one branch's, not what localizing is expected to cost (--policy gives that).

    With -o, a picture of the start belief (as `show -o` draws it) with the plan on it: the moves
    as a path from the most likely state, each move going as intended (the most likely successor),
    the perceptions starred and numbered by step, and the step table (action, expected observation,
    max belief, cost) under the map.

    With --policy, a contingent plan: a policy whose perceptions branch on what they return (a
    belief reached by several paths is one node; a branch may lead back to a belief above), each
    leaf a goal, a belief too unlikely to plan for (--prune-below), or, when the budget ran out
    first, a frontier where the robot would plan again (exit code 1: the policy is not complete).
    --json prints the whole policy with each branch's probability and expected cost; a node met
    again appears as {"id": n, "same_as": n}.

    Examples:

    \b
      beliefloc plan maps/kitchen.yaml --threshold 0.95
      beliefloc plan maps/kitchen.yaml --policy --policy-depth 2 --prune-below 0.05
      beliefloc plan maps/apartment.yaml --belief prior:domains/apartment.yaml
      beliefloc plan maps/kitchen.yaml -o kitchen-plan.svg
    """
    from beliefloc.planning.best_first import PlanStatus, plan
    from beliefloc.planning.settings import PATH_PROBABILITY_FLOOR
    from beliefloc.render.plan import effort_line, path_line, plan_table
    from beliefloc.render.progress import search_progress

    chosen = resolve_heuristic(planner, heuristic, h_weight)
    if policy:
        if output is not None:
            raise UsageError("--policy -o: a picture shows one path, a policy branches; drop -o or --policy")
        if h_weight != DEFAULT_WEIGHT or heuristic not in (None, Heuristic.ZERO):
            raise UsageError(
                "--policy estimates the cost at its frontier from the entropy (or zero with --planner uniform); "
                "--heuristic and --h-weight are best-first's: drop them"
            )
    elif prune_below != DEFAULT_PRUNE_BELOW or policy_depth != DEFAULT_POLICY_DEPTH:
        raise UsageError("--prune-below and --policy-depth shape a contingent plan: add --policy")
    smap = None
    if output is not None:
        from beliefloc.render.figures import PICTURE_SUFFIXES, pyplot

        check_output("-o", output, PICTURE_SUFFIXES, inputs=(source, *belief_inputs(belief)))
        pyplot()  # matplotlib missing: say so before any work
        model, smap = open_with_map(source)
        if model.grid is None:
            raise UsageError(f"-o {output}: model {model.name} has no grid to draw (an imported .pomdp); drop -o")
    else:
        model = open_model(source)
    start = initial_belief(model, belief, smap)
    refuse_unreachable(model, start, threshold, json_output)
    if policy:
        _plan_policy(
            model,
            start,
            threshold=threshold,
            heuristic=chosen,
            max_expansions=max_expansions,
            time_limit=time_limit,
            prune_below=prune_below,
            depth=policy_depth,
            json_output=json_output,
        )
        return
    with search_progress(stderr_console(), time_limit) as progress:
        result = plan(
            model,
            start,
            threshold=threshold,
            heuristic=chosen,
            max_expansions=max_expansions,
            time_limit=time_limit,
            weight=h_weight,
            progress=progress,
        )
    title = f"plan for {model.name}: cost {result.cost:g}, {len(result.steps)} steps"
    if output is not None and result.found:
        from beliefloc.render.figures import save_figure
        from beliefloc.render.picture_belief import plan_figure

        with plan_figure(model, start, result, smap=smap, title=title) as fig:
            save_figure(fig, output)
    if json_output:
        print_json(result.as_json(model))
    else:
        out = stdout_console()
        if result.found:
            if not result.steps:
                out.print(f"already localized: one state holds at least {threshold:g}")
            else:
                out.print(plan_table(result, title))
        elif result.partial:
            out.print(plan_table(result, f"incomplete plan for {model.name}: cost {result.cost:g} so far"))
        if result.steps:
            out.print(path_line(result, PATH_PROBABILITY_FLOOR))
        out.print(effort_line(result))
        if output is not None and result.found:
            out.print(f"wrote {escape(str(output))}", soft_wrap=True)
    if result.status is PlanStatus.NO_PLAN:
        stderr_console().print(
            f"[bold]no plan:[/] every belief reachable from the start was searched and none gives one state "
            f"probability >= {threshold:g}; some states of {escape(model.name)} cannot be told apart."
        )
        raise typer.Exit(EXIT_NEGATIVE)
    if result.status is PlanStatus.BUDGET_EXCEEDED:
        stderr_console().print(
            f"[bold]gave up:[/] the search budget ran out ({result.expanded} expansions, {result.seconds:.1f} s) "
            "before a complete plan was found"
            + ("; the steps shown are the best partial plan by its estimate" if result.partial else "")
            + "; raise --max-expansions or --time-limit, or lower --threshold."
        )
        raise typer.Exit(EXIT_NEGATIVE)


def _plan_policy(
    model: Model,
    start: np.ndarray,
    *,
    threshold: float,
    heuristic: Heuristic,
    max_expansions: int,
    time_limit: float,
    prune_below: float,
    depth: int,
    json_output: bool,
) -> None:
    """``plan --policy``: the contingent planner, its policy printed (``depth`` levels on the terminal)."""
    from beliefloc.planning.best_first import PlanStatus
    from beliefloc.planning.contingent import plan_policy
    from beliefloc.render.plan import policy_line, policy_tree
    from beliefloc.render.progress import search_progress

    with search_progress(stderr_console(), time_limit) as progress:
        result = plan_policy(
            model,
            start,
            threshold=threshold,
            heuristic=heuristic,
            max_expansions=max_expansions,
            time_limit=time_limit,
            prune_below=prune_below,
            progress=progress,
        )
    if json_output:
        print_json(result.as_json(model))
    else:
        out = stdout_console()
        title = f"policy for {model.name}: expected cost {result.expected_cost:.2f}"
        out.print(policy_tree(result, model, title, depth))
        out.print(policy_line(result))
    if result.status is PlanStatus.NO_PLAN:
        stderr_console().print(
            "[bold]no plan:[/] no policy from the start belief reaches the goal or the search's frontier for "
            f"sure: it is a dead end, with states of {escape(model.name)} that no action tells apart."
        )
        raise typer.Exit(EXIT_NEGATIVE)
    if result.status is PlanStatus.BUDGET_EXCEEDED:
        stderr_console().print(
            f"[bold]gave up:[/] the budget ran out ({result.expanded} expansions, {result.seconds:.1f} s) before "
            f"the policy was complete: with probability {result.open_share:.3f} it ends at a leaf where the robot "
            "would plan again; raise --max-expansions or --time-limit, or raise --prune-below."
        )
        raise typer.Exit(EXIT_NEGATIVE)


def register(app: typer.Typer) -> None:
    app.command("plan", short_help="Plan actions until one state holds the threshold.")(plan_command)
