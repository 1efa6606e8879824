"""``prior``: the room prior of a target class from a domain's knowledge base (Zhang et al. Sec. III-C1).

The computation is :mod:`beliefloc.knowledge`'s (imported when the command runs: it loads clingo);
this module composes it and prints.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated

import typer
from rich.markup import escape

from beliefloc.cli.common import boundary, for_option, print_json, target_option, warn
from beliefloc.cli.options import (
    AllowOutsideOption,
    DefaultsOption,
    DomainArgument,
    JsonOption,
    KbOption,
    SeenOption,
    TargetOption,
    number,
)
from beliefloc.errors import UsageError

if TYPE_CHECKING:
    from pathlib import Path

    from beliefloc.knowledge import Domain, Observation


@boundary
def prior(
    domain_file: DomainArgument,
    target: TargetOption = None,
    robot: Annotated[
        bool,
        typer.Option(
            "--robot",
            help="Where the robot itself is (the domain's robot: section, kb/robot.lp) instead of a target: "
            "the start belief of --belief prior:DOMAIN, by room.",
        ),
    ] = False,
    weight: Annotated[
        float | None,
        typer.Option(
            "--weight",
            parser=number(),
            metavar="W",
            help="--robot: w, the share of the rooms the knowledge base puts the robot in, 0 < w <= 1 "
            "(default: the domain's robot.weight, else 0.9).",
            show_default=False,
        ),
    ] = None,
    kb: KbOption = None,
    seen: SeenOption = None,
    defaults: DefaultsOption = True,
    floor: Annotated[
        float,
        typer.Option(
            "--floor", parser=number(above=0.0), metavar="P", help="Prior of a room with no support (below 1/rooms)."
        ),
    ] = 0.01,
    explain: Annotated[
        bool, typer.Option("--explain", help="Show every psi term: class, count, LCA, H, the W's.")
    ] = False,
    allow_outside: AllowOutsideOption = False,
    json_output: JsonOption = False,
) -> None:
    """The prior over rooms for a target class: alpha (Eq. 4) and alpha / alpha_0 (Eq. 5); with
    --robot, the prior over rooms of where the robot is.

    The first example is the paper's worked example (Sec. III-C1): alpha = [0.250, 1.141, 0.375],
    prior [0.142, 0.646, 0.212].

    Examples:

    \b
      beliefloc prior domains/printer-example.yaml --target printer --explain
      beliefloc prior domains/home.yaml --target printer --seen textbook1=bedroom --json
      beliefloc prior domains/apartment.yaml --robot
    """
    from beliefloc.knowledge import KnowledgeBase, load_domain
    from beliefloc.render import stdout_console
    from beliefloc.render.knowledge import prior_table, psi_table

    domain = load_domain(domain_file, allow_outside=allow_outside)
    observations = _observations(seen)
    if robot:
        if target is not None or explain:
            raise UsageError("--robot prints where the robot is; drop --target and --explain (they are about objects)")
        _robot_prior(domain, kb, observations, defaults, weight, json_output)
        return
    if weight is not None:
        raise UsageError("--weight is the robot's prior weight: use it with --robot")
    with for_option(target_option(target)):
        chosen = domain.resolve_target(target)
    base = KnowledgeBase(domain, kb or [], use_defaults=defaults)
    for observation in observations:
        base.observe(observation)
    with for_option(f"--floor {floor:g}"):
        result = base.prior(chosen, floor=floor)
    for message in base.warnings:
        warn(f"clingo: {message}")
    if result.message:
        warn(result.message)
    if json_output:
        print_json(result.as_json())
        return
    console = stdout_console()
    console.print(prior_table(result, f"where is a {escape(result.target)}? ({escape(domain.name)})"))
    if explain:
        console.print(psi_table(result))


def _observations(seen: list[str] | None) -> list[Observation]:
    """``--seen OBJECT=ROOM``/``OBJECT:CLASS=ROOM`` -> observations (:meth:`Observation.parse`)."""
    from beliefloc.knowledge import Observation

    observations = []
    for spec in seen or []:
        with for_option(f"--seen {spec!r}"):
            observations.append(Observation.parse(spec))
    return observations


def _robot_prior(
    domain: Domain,
    kb: list[Path] | None,
    observations: list[Observation],
    defaults: bool,
    weight: float | None,
    json_output: bool,
) -> None:
    """``prior --robot``: the robot's room prior (:func:`beliefloc.knowledge.domain_robot_prior`)."""
    from beliefloc.knowledge import check_weight, domain_robot_prior
    from beliefloc.render import stdout_console
    from beliefloc.render.knowledge import robot_prior_table

    if weight is not None:
        with for_option("--weight"):
            check_weight(weight)
    result = domain_robot_prior(
        domain, observations=observations, kb_files=kb or [], use_defaults=defaults, weight=weight
    )
    for message in result.warnings:
        warn(message)
    if json_output:
        print_json(result.as_json())
        return
    title = f"where is the robot? ({escape(domain.name)}, step {result.step})"
    stdout_console().print(robot_prior_table(result.prior, title, result.cells))


def register(app: typer.Typer) -> None:
    app.command(short_help="The prior over rooms of a target class, or of the robot.")(prior)
