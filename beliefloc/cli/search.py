"""``search run``: one simulated knowledge-guided object search (Zhang, Sridharan & Wyatt 2015, Algorithm 1)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.markup import escape

from beliefloc.cli.common import boundary, print_json, warn
from beliefloc.cli.prior import DefaultsOption, DomainArgument
from beliefloc.errors import EXIT_NEGATIVE, UsageError
from beliefloc.render import stdout_console

if TYPE_CHECKING:
    from beliefloc.object_search.loop import SearchRecord
    from beliefloc.object_search.world import SearchSpace

search_app = typer.Typer(
    name="search",
    help="Knowledge-guided object search: an ASP room prior, a belief over cells, early termination.",
    no_args_is_help=True,
    rich_markup_mode=None,
)

STRATEGY_NAMES = ("expectation", "upper-bound", "sampling", "none")


@search_app.command()
@boundary
def run(
    domain_file: DomainArgument,
    target: Annotated[
        str | None,
        typer.Option(
            "--target", "-t", help="The class searched for (default: the domain's `target`).", show_default=False
        ),
    ] = None,
    strategy: Annotated[
        str, typer.Option("--strategy", help=f"Existence metareasoning (Eq. 10-14): {', '.join(STRATEGY_NAMES)}.")
    ] = "expectation",
    policy: Annotated[str, typer.Option("--policy", help="Action selection: pomdp, greedy, pomdp-only.")] = "pomdp",
    seed: Annotated[
        int, typer.Option("--seed", help="Seeds the target's place, the detections, the Beta samples.")
    ] = 0,
    target_cell: Annotated[
        str | None,
        typer.Option(
            "--target-cell", help="Put the target at ROOM:ROW,COL (default: a random cell).", show_default=False
        ),
    ] = None,
    absent: Annotated[bool, typer.Option("--absent", help="The target is nowhere in the domain.")] = False,
    defaults: DefaultsOption = True,
    time_limit: Annotated[
        float | None,
        typer.Option("--time-limit", help="Time units (default: the domain's search.time_limit).", show_default=False),
    ] = None,
    show: Annotated[
        bool, typer.Option("--show", help="Draw the belief over the rooms' cells after every step.")
    ] = False,
    json_output: Annotated[bool, typer.Option("--json", help="Print the steps and verdict as JSON on stdout.")] = False,
) -> None:
    """Search a domain for a target with a simulated robot; print every step and the verdict.

    Exit code 0 when found, 1 when the robot gives up (not found) or runs out of time.

    Example: beliefloc search run domains/home.yaml --target printer --seed 3 --show
    """
    import numpy as np

    from beliefloc.knowledge import domain_prior, load_domain
    from beliefloc.object_search.existence import ExistenceStrategy
    from beliefloc.object_search.loop import Verdict, seeded_search
    from beliefloc.object_search.policy import POLICIES
    from beliefloc.object_search.world import search_space
    from beliefloc.render.grid import uses_color
    from beliefloc.render.search import belief_plane, step_line, steps_table, verdict_text

    if strategy not in STRATEGY_NAMES:
        raise UsageError(f"--strategy {strategy!r}: expected one of: {', '.join(STRATEGY_NAMES)}")
    if policy not in POLICIES:
        raise UsageError(f"--policy {policy!r}: expected one of: {', '.join(POLICIES)}")
    if absent and target_cell is not None:
        raise UsageError("--absent and --target-cell contradict each other; give one")
    if time_limit is not None and time_limit <= 0:
        raise UsageError(f"--time-limit must be positive, got {time_limit}")
    domain = load_domain(domain_file)
    chosen = target or domain.target
    if chosen is None:
        raise UsageError(f"{domain_file}: no target: give --target CLASS (the domain names none)")
    if chosen not in domain.classes:
        raise UsageError(f"--target {chosen!r}: unknown class; expected one of: {', '.join(sorted(domain.classes))}")
    space = search_space(domain)
    spec = domain.search
    assert spec is not None  # search_space raised otherwise
    cell = space.parse_cell(target_cell) if target_cell is not None else None
    result = domain_prior(domain, chosen, use_defaults=defaults)
    if result.message:
        warn(result.message)
    room_prior = np.array([result.prior[room] for room in space.rooms])
    record = seeded_search(
        space,
        room_prior,
        POLICIES[policy],
        ExistenceStrategy(strategy),
        seed=seed,
        target_cell=cell,
        absent=absent,
        alpha=spec.existence.alpha,
        beta=spec.existence.beta,
        tau_found=spec.tau_found,
        tau_absent=spec.tau_absent,
        time_limit=spec.time_limit if time_limit is None else time_limit,
        keep_beliefs=show,
    )
    if json_output:
        print_json(
            _as_json(space, record, domain.name, chosen, seed, dict(zip(space.rooms, room_prior.tolist(), strict=True)))
        )
    else:
        console = stdout_console()
        console.print(
            f"searching {escape(domain.name)} for a {escape(chosen)}: {policy} policy, {strategy} metareasoning, "
            f"seed {seed}; room prior "
            + ", ".join(f"{escape(r)} {p:.3f}" for r, p in zip(space.rooms, room_prior.tolist(), strict=True)),
            soft_wrap=True,
        )
        if show:
            color = uses_color(console)
            console.print(
                belief_plane(space, record.initial_belief, robot=space.start, target=record.true_cell, color=color)
            )
            for step in record.steps:
                console.print(step_line(space, step))
                assert step.belief is not None
                console.print(belief_plane(space, step.belief, robot=step.view, target=record.true_cell, color=color))
        else:
            console.print(steps_table(space, record))
        console.print(verdict_text(space, record))
    if record.verdict is not Verdict.FOUND:
        raise typer.Exit(EXIT_NEGATIVE)


def _as_json(
    space: SearchSpace, record: SearchRecord, domain: str, target: str, seed: int, room_prior: dict[str, float]
) -> dict[str, Any]:
    def name(cell: int | None) -> str | None:
        return None if cell is None else space.cell_name(cell)

    return {
        "domain": domain,
        "target": target,
        "policy": record.policy,
        "strategy": record.strategy,
        "seed": seed,
        "room_prior": room_prior,
        "true_cell": name(record.true_cell),
        "steps": [
            {
                "step": s.index,
                "view": space.cell_name(s.view),
                "observation": "present" if s.present else "absent",
                "cost": s.cost,
                "time": s.time,
                "p_exists": s.p_exists,
                "max_belief": s.best_belief,
                "most_likely": space.cell_name(s.best_cell),
            }
            for s in record.steps
        ],
        "verdict": record.verdict.value,
        "time": record.time,
        "reported_cell": name(record.reported_cell),
        "error_cells": record.error_cells,
        "accuracy": record.accuracy,
    }


def register(app: typer.Typer) -> None:
    app.add_typer(search_app, name="search")
