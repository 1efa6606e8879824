"""``select``: Khalvati & Mackworth's pairwise action selection (Eq. 8-10, Algorithms 1 and 3)."""

from __future__ import annotations

from typing import Annotated, Any

import typer

from beliefloc.cli.common import boundary, initial_belief, open_model, print_json
from beliefloc.cli.options import BeliefOption, GammaOption, JsonOption, MacrosOption, ModelArgument, whole
from beliefloc.errors import EXIT_NEGATIVE
from beliefloc.planning.settings import DEFAULT_MAX_HYPOTHESES, SelectionRule
from beliefloc.render import stderr_console, stdout_console

MAX_EDGES_SHOWN = 20


@boundary
def select_command(
    source: ModelArgument,
    belief: BeliefOption = "uniform",
    rule: Annotated[
        SelectionRule,
        typer.Option("--rule", "--strategy", help="The selection rule: EC2 edge weights (--strategy: the old name)."),
    ] = SelectionRule.EC2,
    macros: MacrosOption = None,
    gamma: GammaOption = None,
    max_hypotheses: Annotated[
        int,
        typer.Option(
            "--max-hypotheses",
            parser=whole(low=2),
            metavar="N",
            help="Keep at most this many most likely states (Sec. VII-B).",
        ),
    ] = DEFAULT_MAX_HYPOTHESES,
    explain: Annotated[bool, typer.Option("--explain", help="Show the edges (pairs) behind each weight.")] = False,
    json_output: JsonOption = False,
) -> None:
    """Weigh every action (and macro) by the pairs of likely states it tells apart; choose the heaviest.

    w(a) = sum over pairs whose most likely successors are distinguishable of
    Bel(s_i) Bel(s_j) min(p(f*(s_i,a)|s_i,a), p(f*(s_j,a)|s_j,a)) / C(s_i,s_j,a).
    Exit code 1 when no candidate has a positive weight (Algorithm 1 would then move at random).

    Example:

    \b
      printf '{"1,1": 0.2, "3,1": 0.2, "2,3": 0.1, "3,4": 0.5}' > s1-s4.json
      beliefloc select maps/khalvati-example1.yaml --belief s1-s4.json --explain
    """
    from beliefloc.planning.ec2 import edges, pair_context, select
    from beliefloc.planning.macros import macro_candidates
    from beliefloc.render.ec2 import edges_table, weights_table

    model = open_model(source)
    start = initial_belief(model, belief)
    table = None
    if macros is not None:
        from beliefloc.files.macro_file import load_macros

        table = load_macros(macros, model)
    ctx = pair_context(model, gamma if gamma is not None else (table.gamma if table is not None else None))
    candidates = []
    if table is not None:
        from beliefloc.planning.ec2 import hypotheses

        states = hypotheses(start, max_hypotheses=max_hypotheses)
        candidates = macro_candidates(table, states, start)
    result = select(ctx, start, candidates, max_hypotheses=max_hypotheses)
    weights = result.as_dict()
    explained: dict[str, list[dict[str, Any]]] = {}
    if explain:
        names = model.states
        for candidate, name in zip(result.candidates, result.names, strict=True):
            explained[name] = [e.as_json(names) for e in edges(ctx, candidate, result.hypotheses, start)]
    if json_output:
        data: dict[str, Any] = {
            "weights": weights,
            "chosen": result.chosen_name,
            "gamma": ctx.gamma,
            "strategy": rule.value,
            "hypotheses": len(result.hypotheses),
        }
        if explain:
            data["edges"] = explained
        print_json(data)
    else:
        out = stdout_console()
        title = f"{rule.value} on {model.name}: {len(result.hypotheses)} hypotheses, gamma {ctx.gamma:.3g}" + (
            f", {len(result.candidates) - len(model.actions)} macros" if table is not None else ""
        )
        out.print(weights_table(weights, result.chosen_name, title))
        for name, rows in explained.items():
            out.print(edges_table(name, rows[:MAX_EDGES_SHOWN], min(len(rows), MAX_EDGES_SHOWN), len(rows)))
        if result.chosen_name is not None:
            out.print(f"chosen: {result.chosen_name}")
    if result.chosen is None:
        stderr_console().print(
            "[bold]no candidate has a positive weight:[/] no action tells any two likely states apart"
            + (" (Algorithm 1 would move at random; try --macros)" if table is None else "")
        )
        raise typer.Exit(EXIT_NEGATIVE)


def register(app: typer.Typer) -> None:
    app.command("select", short_help="Choose an action by pairwise edge weights (Khalvati).")(select_command)
