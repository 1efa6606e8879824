"""``kb check`` and ``kb answer``: ground and solve a domain's knowledge base with clingo."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.markup import escape

from beliefloc.cli.common import boundary, print_json, warn
from beliefloc.cli.prior import DefaultsOption, DomainArgument, KbOption, SeenOption, parse_seen
from beliefloc.errors import UsageError
from beliefloc.render import stdout_console

if TYPE_CHECKING:
    from beliefloc.knowledge import AnswerSet, KnowledgeBase

JsonOption = Annotated[bool, typer.Option("--json", help="Print machine-readable JSON on stdout.")]

kb_app = typer.Typer(
    name="kb",
    help="Knowledge bases in ASP (clingo): check them and see what the robot believes.",
    no_args_is_help=True,
    rich_markup_mode=None,
)


def _open(
    domain_file: Path, kb: list[Path] | None, seen: list[str] | None, defaults: bool
) -> tuple[KnowledgeBase, AnswerSet]:
    from beliefloc.knowledge import KnowledgeBase, load_domain

    base = KnowledgeBase(load_domain(domain_file), kb or [], use_defaults=defaults)
    for observation in parse_seen(seen):
        base.observe(observation)
    answer = base.answer()
    for message in base.warnings:
        warn(f"clingo: {message}")
    return base, answer


@kb_app.command()
@boundary
def check(
    domain_file: DomainArgument,
    kb: KbOption = None,
    seen: SeenOption = None,
    defaults: DefaultsOption = True,
    json_output: JsonOption = False,
) -> None:
    """Validate a domain, ground and solve its knowledge base; exit 2 if it is broken or inconsistent.

    Example: beliefloc kb check domains/home.yaml
    """
    base, answer = _open(domain_file, kb, seen, defaults)
    located = answer.located()
    summary = {
        "domain": base.domain.name,
        "files": [str(f) for f in base.files],
        "consistent": True,
        "answer_sets": answer.models,
        "rooms": len(answer.rooms),
        "classes": len(answer.classes),
        "objects": len(answer.members),
        "located": len(located),
        "ground_seconds": answer.timings.ground,
        "solve_seconds": answer.timings.solve,
        "warnings": list(base.warnings),
    }
    if json_output:
        print_json(summary)
        return
    several = "" if answer.models == 1 else f" ({answer.models} answer sets: their cautious consequences are used)"
    stdout_console().print(
        f"[green]ok[/] {escape(str(domain_file))}: {escape(base.domain.name)}, consistent{several}; "
        f"{len(answer.rooms)} rooms, {len(answer.classes)} classes, {len(located)} of {len(answer.members)} objects "
        f"located at step {answer.last_step}; grounded in {answer.timings.ground * 1000:.1f} ms, "
        f"solved in {answer.timings.solve * 1000:.1f} ms",
        soft_wrap=True,
    )


@kb_app.command()
@boundary
def answer(
    domain_file: DomainArgument,
    step: Annotated[
        int | None, typer.Option("--step", help="The step to show (default: the last).", show_default=False)
    ] = None,
    kb: KbOption = None,
    seen: SeenOption = None,
    defaults: DefaultsOption = True,
    json_output: JsonOption = False,
) -> None:
    """Print the answer set's holds atoms at a step, grouped by fluent, and the ab atoms of defaults.

    Example: beliefloc kb answer domains/home.yaml --kb kb/books.lp --step 1
    """
    from beliefloc.render.knowledge import answer_table

    _, result = _open(domain_file, kb, seen, defaults)
    shown = result.last_step if step is None else step
    if not 1 <= shown <= result.last_step:
        raise UsageError(f"--step {shown}: the domain has steps 1..{result.last_step}")
    if json_output:
        print_json(
            {
                "step": shown,
                "answer_sets": result.models,
                "holds": {group: [str(lit) for lit in lits] for group, lits in result.grouped(shown).items()},
                "ab": list(result.abnormal),
            }
        )
        return
    stdout_console().print(answer_table(result, shown))


def register(app: typer.Typer) -> None:
    app.add_typer(kb_app, name="kb")
