"""``prior``: the room prior of a target class from a domain's knowledge base (Zhang et al. Sec. III-C1)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.markup import escape

from beliefloc.cli.common import boundary, print_json, warn
from beliefloc.errors import UsageError
from beliefloc.render import stdout_console

if TYPE_CHECKING:
    from beliefloc.knowledge import Domain, KnowledgeBase, Observation

DomainArgument = Annotated[
    Path, typer.Argument(metavar="DOMAIN", help="A domain file (domains/*.yaml).", show_default=False)
]
TargetOption = Annotated[
    str | None,
    typer.Option("--target", "-t", help="The class searched for (default: the domain's `target`).", show_default=False),
]
KbOption = Annotated[
    list[Path] | None,
    typer.Option(
        "--kb", help="An extra .lp file, added to kb/axioms.lp and the domain's own (repeatable).", show_default=False
    ),
]
SeenOption = Annotated[
    list[str] | None,
    typer.Option(
        "--seen",
        help="An observed fact OBJECT=ROOM (OBJECT:CLASS=ROOM for a new object), at the last step (repeatable).",
        show_default=False,
    ),
]
DefaultsOption = Annotated[
    bool, typer.Option("--defaults/--no-defaults", help="Use the domain file's defaults (those in .lp files stay).")
]


def parse_seen(specs: list[str] | None) -> list[Observation]:
    """``OBJECT=ROOM`` or ``OBJECT:CLASS=ROOM`` -> observations."""
    from beliefloc.knowledge import Observation

    observations = []
    for spec in specs or []:
        what, sep, room = spec.partition("=")
        obj, _, cls = what.partition(":")
        if not sep or not obj.strip() or not room.strip():
            raise UsageError(f"--seen {spec!r}: write OBJECT=ROOM or OBJECT:CLASS=ROOM, e.g. --seen book5=kitchen")
        observations.append(Observation(obj.strip(), room.strip(), cls.strip() or None))
    return observations


def resolve_target(domain_file: Path, domain: Domain, target: str | None, *, allow_any: bool = False) -> str | None:
    """``--target``, else the domain's ``target``; a class of the domain. With ``allow_any``, ``any``
    or no target at all is None (a random object per trial)."""
    chosen = target or domain.target
    if allow_any and chosen in (None, "any"):
        return None
    if chosen is None:
        raise UsageError(f"{domain_file}: no target: give --target CLASS (the domain names none)")
    if chosen not in domain.classes:
        raise UsageError(f"--target {chosen!r}: unknown class; expected one of: {', '.join(sorted(domain.classes))}")
    return chosen


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
            min=0.0,
            max=1.0,
            help="--robot: w, the share of the rooms the knowledge base puts the robot in (default: the "
            "domain's robot.weight, else 0.9).",
            show_default=False,
        ),
    ] = None,
    kb: KbOption = None,
    seen: SeenOption = None,
    defaults: DefaultsOption = True,
    floor: Annotated[float, typer.Option("--floor", help="Prior of a room with no support (below 1/rooms).")] = 0.01,
    explain: Annotated[
        bool, typer.Option("--explain", help="Show every psi term: class, count, LCA, H, the W's.")
    ] = False,
    json_output: Annotated[bool, typer.Option("--json", help="Print machine-readable JSON on stdout.")] = False,
) -> None:
    """The prior over rooms for a target class: alpha (Eq. 4) and alpha / alpha_0 (Eq. 5); with
    --robot, the prior over rooms of where the robot is.

    Example: beliefloc prior domains/printer-example.yaml --target printer --explain
    Example: beliefloc prior domains/apartment.yaml --robot
    """
    from beliefloc.knowledge import KnowledgeBase, load_domain
    from beliefloc.render.knowledge import prior_table, psi_table

    domain = load_domain(domain_file)
    if robot:
        if target is not None or explain:
            raise UsageError("--robot prints where the robot is; drop --target and --explain (they are about objects)")
        _robot_prior(
            domain, KnowledgeBase(domain, kb or [], parse_seen(seen), use_defaults=defaults), weight, json_output
        )
        return
    if weight is not None:
        raise UsageError("--weight is the robot's prior weight: use it with --robot")
    chosen = resolve_target(domain_file, domain, target)
    assert chosen is not None
    base = KnowledgeBase(domain, kb or [], use_defaults=defaults)
    for observation in parse_seen(seen):
        base.observe(observation)
    result = base.prior(chosen, floor=floor)
    for message in base.warnings:
        warn(f"clingo: {message}")
    if result.message:
        warn(result.message)
    if json_output:
        print_json(
            {
                "rooms": list(result.rooms),
                "alpha": result.alpha,
                "prior": result.prior,
                "target": result.target,
                "uniform": result.uniform,
                "floored": list(result.floored),
                "answer_sets": result.models,
                "terms": [
                    {
                        "room": t.room,
                        "class": t.primary,
                        "count": t.count,
                        "lca": t.lca,
                        "height": t.height,
                        "weights": list(t.weights),
                        "psi": t.psi,
                    }
                    for t in result.terms
                ],
            }
        )
        return
    console = stdout_console()
    console.print(prior_table(result, f"where is a {escape(result.target)}? ({escape(domain.name)})"))
    if explain:
        console.print(psi_table(result))


def _robot_prior(domain: Domain, base: KnowledgeBase, weight: float | None, json_output: bool) -> None:
    """``prior --robot``: the robot's room prior (:mod:`beliefloc.knowledge.robot`)."""
    from beliefloc.knowledge.robot import DEFAULT_WEIGHT, OUTSIDE, prior_from_answer
    from beliefloc.render.knowledge import robot_prior_table

    if weight is not None and weight <= 0.0:
        raise UsageError(f"--weight must be above 0 (the rooms the knowledge base names get it), got {weight:g}")
    chosen = weight if weight is not None else (domain.robot.weight if domain.robot else DEFAULT_WEIGHT)
    smap = domain.semantic_map
    cells: dict[str, int] | None = None
    if smap is not None:
        cells = {room: int(mask.sum()) for room, mask in smap.rooms.items()}
        in_rooms = sum(cells.values())
        if in_rooms < int(smap.free.sum()):
            cells[OUTSIDE] = int(smap.free.sum()) - in_rooms
    answer = base.answer()
    try:
        result = prior_from_answer(answer, weight=chosen, outside=cells is not None and OUTSIDE in cells)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    for message in base.warnings:
        warn(f"clingo: {message}")
    if result.message:
        warn(result.message)
    if json_output:
        print_json(
            {
                "rooms": list(result.rooms),
                "prior": result.prior,
                "robot_in": list(result.believed),
                "weight": result.weight,
                "uniform": result.uniform,
                "cells": cells,
                "answer_sets": result.models,
            }
        )
        return
    title = f"where is the robot? ({escape(domain.name)}, step {answer.last_step})"
    stdout_console().print(robot_prior_table(result, title, cells))


def register(app: typer.Typer) -> None:
    app.command()(prior)
