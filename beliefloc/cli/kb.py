"""``kb check`` and ``kb answer``: ground and solve a domain's knowledge base with clingo.

:mod:`beliefloc.knowledge` (which loads clingo) is imported when a command runs."""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated

import typer
from rich.markup import escape

from beliefloc.cli.common import boundary, for_option, print_json, warn
from beliefloc.cli.options import AllowOutsideOption, DefaultsOption, DomainArgument, JsonOption, KbOption, SeenOption

if TYPE_CHECKING:
    from pathlib import Path

    from beliefloc.knowledge import KnowledgeBase

kb_app = typer.Typer(
    name="kb",
    help="Knowledge bases in ASP (clingo): check them and see what the robot believes.",
    short_help="Check ASP knowledge bases; see what the robot believes.",
    no_args_is_help=True,
    rich_markup_mode=None,
)


def _open(
    domain_file: Path, kb: list[Path] | None, seen: list[str] | None, defaults: bool, allow_outside: bool
) -> KnowledgeBase:
    """The domain's knowledge base with the ``--seen`` facts, solved; clingo's warnings shown."""
    from beliefloc.knowledge import KnowledgeBase, Observation, load_domain

    domain = load_domain(domain_file, allow_outside=allow_outside)
    observations = []
    for spec in seen or []:
        with for_option(f"--seen {spec!r}"):
            observations.append(Observation.parse(spec))
    base = KnowledgeBase(domain, kb or [], use_defaults=defaults)
    for observation in observations:
        base.observe(observation)
    base.answer()
    for message in base.warnings:
        warn(f"clingo: {message}")
    return base


@kb_app.command(short_help="Ground and solve a domain's knowledge base; is it consistent?")
@boundary
def check(
    domain_file: DomainArgument,
    kb: KbOption = None,
    seen: SeenOption = None,
    defaults: DefaultsOption = True,
    allow_outside: AllowOutsideOption = False,
    json_output: JsonOption = False,
) -> None:
    """Validate a domain, ground and solve its knowledge base; exit 2 if it is broken or inconsistent.

    Grounding and solving have a budget of time and memory (BELIEFLOC_MAX_KB_SECONDS,
    BELIEFLOC_MAX_KB_BYTES); the .lp files must stay in the folder of the file that names them
    unless --allow-outside is given (kb/README.md).

    It counts the rooms, classes and located objects of the answer set, and says how long grounding
    and solving took.

    Examples:

    \b
      beliefloc kb check domains/home.yaml
      beliefloc kb check domains/printer-example.yaml --kb kb/books.lp --json
    """
    from beliefloc.render import stdout_console

    summary = _open(domain_file, kb, seen, defaults, allow_outside).summary()
    if json_output:
        print_json(summary.as_json())
        return
    answer = summary.answer
    located = answer.located()
    several = "" if answer.models == 1 else f" ({answer.models} answer sets: their cautious consequences are used)"
    stdout_console().print(
        f"[green]ok[/] {escape(str(domain_file))}: {escape(summary.domain)}, consistent{several}; "
        f"{len(answer.rooms)} rooms, {len(answer.classes)} classes, {len(located)} of {len(answer.members)} objects "
        f"located at step {answer.last_step}; grounded in {answer.timings.ground * 1000:.1f} ms, "
        f"solved in {answer.timings.solve * 1000:.1f} ms",
        soft_wrap=True,
    )


@kb_app.command(short_help="Print what the robot believes at a step (the answer set).")
@boundary
def answer(
    domain_file: DomainArgument,
    step: Annotated[
        int | None,
        typer.Option("--step", metavar="N", help="The step to show (default: the last).", show_default=False),
    ] = None,
    kb: KbOption = None,
    seen: SeenOption = None,
    defaults: DefaultsOption = True,
    allow_outside: AllowOutsideOption = False,
    json_output: JsonOption = False,
) -> None:
    """Print the answer set's holds atoms at a step, grouped by fluent, and the ab atoms of defaults.

    At --step 1 it shows what the robot believes before it has observed anything.

    Examples:

    \b
      beliefloc kb answer domains/home.yaml --kb kb/books.lp --step 1
      beliefloc kb answer domains/printer-example.yaml --seen book1=bedroom --json
    """
    from beliefloc.render import stdout_console
    from beliefloc.render.knowledge import answer_table

    result = _open(domain_file, kb, seen, defaults, allow_outside).answer()
    with for_option(f"--step {step}"):
        shown = result.check_step(step)
    if json_output:
        print_json(result.as_json(shown))
        return
    stdout_console().print(answer_table(result, shown))


def register(app: typer.Typer) -> None:
    app.add_typer(kb_app, name="kb")
