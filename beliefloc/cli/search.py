"""``search run`` and ``search simulate``: knowledge-guided object search (Zhang, Sridharan & Wyatt 2015,
Algorithm 1) against a simulated world -- one search step by step, or paired trials with statistics."""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.markup import escape

from beliefloc.cli.common import boundary, print_json, warn
from beliefloc.cli.prior import DefaultsOption, DomainArgument, TargetOption, resolve_target
from beliefloc.errors import EXIT_NEGATIVE, UsageError
from beliefloc.render import stderr_console, stdout_console

if TYPE_CHECKING:
    import numpy as np

    from beliefloc.knowledge import Domain, KnowledgeBase
    from beliefloc.object_search.dynamic import DynamicKnowledge
    from beliefloc.object_search.experiment import Arm, TrialRecord, TrialSettings
    from beliefloc.object_search.loop import DynamicFactory, SearchRecord
    from beliefloc.object_search.posterior import TrustFactor
    from beliefloc.object_search.world import SearchSpace

search_app = typer.Typer(
    name="search",
    help="Knowledge-guided object search: an ASP room prior, a belief over cells, early termination.",
    no_args_is_help=True,
    rich_markup_mode=None,
)

STRATEGY_NAMES = ("expectation", "upper-bound", "sampling", "none")
REVISION_NAMES = ("reuse", "discard", "trust-factor")

DynamicOption = Annotated[
    bool,
    typer.Option(
        "--dynamic-kb",
        help="Revise the knowledge base during the search: other objects seen with a room belief above "
        "--commit-threshold are committed and the target's prior recomputed (Algorithm 1, lines 7-10).",
    ),
]
CommitOption = Annotated[
    float,
    typer.Option(
        "--commit-threshold", help="--dynamic-kb: an object's room belief above which it is committed (in (0.5, 1))."
    ),
]
TrustWeightOption = Annotated[
    float,
    typer.Option("--trust-weight", min=0.0, max=1.0, help="trust-factor revision: the weight w of the KB's belief."),
]
TrustROption = Annotated[
    float,
    typer.Option("--trust-r", min=0.0, help="trust-factor revision: the r of the r-norm (0 logarithmic, 1 linear)."),
]
TimeLimitOption = Annotated[
    float | None,
    typer.Option("--time-limit", help="Time units (default: the domain's search.time_limit).", show_default=False),
]
TimingsOption = Annotated[
    bool,
    typer.Option("--timings/--no-timings", help="Include wall-clock seconds in --json (off: byte-identical reruns)."),
]


def _choices(values: list[str] | None, default: str, allowed: tuple[str, ...], option: str) -> list[str]:
    """A repeatable option that also takes comma lists (``-s none -s expectation,sampling``), deduplicated."""
    chosen: list[str] = []
    for value in values or [default]:
        for part in value.split(","):
            name = part.strip()
            if name not in allowed:
                raise UsageError(f"{option} {name!r}: expected one of: {', '.join(allowed)}")
            if name not in chosen:
                chosen.append(name)
    return chosen


def _trust(weight: float, r: float) -> TrustFactor:
    from beliefloc.object_search.posterior import TrustFactor

    try:
        return TrustFactor(weight, r)
    except ValueError as exc:
        raise UsageError(f"--trust-weight / --trust-r: {exc}") from None


def _check_revision_options(revisions: list[str], dynamic_kb: bool, commit_threshold: float) -> None:
    if not 0.5 < commit_threshold < 1.0:
        raise UsageError(f"--commit-threshold must be between 0.5 and 1 (exclusive), got {commit_threshold:g}")
    if not dynamic_kb and "discard" in revisions:
        warn("--revision discard changes nothing without --dynamic-kb: the prior is never revised")


def _domain_and_target(domain_file: Any, target: str | None, *, allow_any: bool = False) -> tuple[Domain, str | None]:
    from beliefloc.knowledge import load_domain

    domain = load_domain(domain_file)
    return domain, resolve_target(domain_file, domain, target, allow_any=allow_any)


def _warn_closed_rooms(domain: Domain) -> None:
    closed = [name for name, room in domain.rooms.items() if not room.accessible]
    if closed:
        warn(
            f"{', '.join(closed)}: marked 'accessible: false': the robot does not search there, and the room "
            "prior of the other rooms is renormalised"
        )


@search_app.command()
@boundary
def run(
    domain_file: DomainArgument,
    target: TargetOption = None,
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
            "--target-cell",
            help="Put the target at ROOM:ROW,COL: inside the room on a plane of rooms, the map's row and column "
            "for a domain with map: (default: a random cell).",
            show_default=False,
        ),
    ] = None,
    absent: Annotated[bool, typer.Option("--absent", help="The target is nowhere in the domain.")] = False,
    defaults: DefaultsOption = True,
    dynamic_kb: DynamicOption = False,
    revision: Annotated[
        str,
        typer.Option("--revision", help=f"How a revised prior meets the observations: {', '.join(REVISION_NAMES)}."),
    ] = "reuse",
    commit_threshold: CommitOption = 0.9,
    trust_weight: TrustWeightOption = 0.5,
    trust_r: TrustROption = 0.0,
    time_limit: TimeLimitOption = None,
    show: Annotated[
        bool,
        typer.Option(
            "--show", help="Draw the belief over the rooms' cells after every step (on the map's grid with map:)."
        ),
    ] = False,
    timings: TimingsOption = True,
    json_output: Annotated[bool, typer.Option("--json", help="Print the steps and verdict as JSON on stdout.")] = False,
) -> None:
    """Search a domain for a target with a simulated robot; print every step and the verdict.

    With --dynamic-kb the domain's objects without a room are placed in the simulated world (where
    the defaults put them, or at random) and committed to the knowledge base when seen.

    Exit code 0 when found, 1 when the robot gives up (not found) or runs out of time.

    Example: beliefloc search run domains/home.yaml --target printer --seed 3 --show

    Example: beliefloc search run domains/home.yaml --dynamic-kb --revision discard

    Example: beliefloc search run domains/apartment.yaml --target-cell kitchen:7,9 --show
    """
    import numpy as np

    from beliefloc.object_search.existence import ExistenceStrategy
    from beliefloc.object_search.loop import Verdict, seeded_search
    from beliefloc.object_search.policy import POLICIES
    from beliefloc.object_search.posterior import Revision
    from beliefloc.object_search.world import search_space
    from beliefloc.render.grid import uses_color
    from beliefloc.render.search import belief_plane, step_line, steps_table, verdict_text

    if strategy not in STRATEGY_NAMES:
        raise UsageError(f"--strategy {strategy!r}: expected one of: {', '.join(STRATEGY_NAMES)}")
    if policy not in POLICIES:
        raise UsageError(f"--policy {policy!r}: expected one of: {', '.join(POLICIES)}")
    if revision not in REVISION_NAMES:
        raise UsageError(f"--revision {revision!r}: expected one of: {', '.join(REVISION_NAMES)}")
    _check_revision_options([revision], dynamic_kb, commit_threshold)
    if absent and target_cell is not None:
        raise UsageError("--absent and --target-cell contradict each other; give one")
    if time_limit is not None and time_limit <= 0:
        raise UsageError(f"--time-limit must be positive, got {time_limit}")
    domain, chosen = _domain_and_target(domain_file, target)
    assert chosen is not None
    space = search_space(domain)
    spec = domain.search_settings
    assert spec is not None  # search_space raised otherwise
    cell = space.parse_cell(target_cell) if target_cell is not None else None
    if cell is not None and not space.reachable[cell]:
        raise UsageError(f"--target-cell {target_cell}: the robot cannot enter that room (accessible: false)")
    _warn_closed_rooms(domain)
    from beliefloc.knowledge import KnowledgeBase

    kb = KnowledgeBase(domain, use_defaults=defaults)
    result = kb.prior(chosen)
    if result.message:
        warn(result.message)
    room_prior = np.array([result.prior[room] for room in space.rooms])
    started = time.perf_counter()
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
        revision=Revision(revision),
        trust=_trust(trust_weight, trust_r),
        dynamic=_run_dynamic(domain, space, kb, chosen, commit_threshold) if dynamic_kb else None,
    )
    seconds = time.perf_counter() - started
    if json_output:
        data = _run_json(
            space, record, domain.name, chosen, seed, dict(zip(space.rooms, room_prior.tolist(), strict=True))
        )
        data["seconds"] = seconds if timings else None
        print_json(data)
    else:
        console = stdout_console()
        kb_text = f", dynamic KB ({revision})" if dynamic_kb else f", {revision}" if revision != "reuse" else ""
        on_map = f" on {escape(str(domain.map_file))}" if domain.map_file is not None else ""
        console.print(
            f"searching {escape(domain.name)}{on_map} for a {escape(chosen)}: {policy} policy, {strategy} metareasoning"
            f"{kb_text}, seed {seed}; room prior "
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


def _run_dynamic(
    domain: Domain, space: SearchSpace, kb: KnowledgeBase, target: str, threshold: float
) -> DynamicFactory:
    """``search run --dynamic-kb``: the domain's objects placed in the world (the target is another,
    anonymous instance); the robot tracks those the domain gives no room; commits go to ``kb``."""
    from beliefloc.object_search.dynamic import KbLink
    from beliefloc.object_search.experiment import objects_dynamic, typical_rooms
    from beliefloc.object_search.trials import place_objects

    typical = typical_rooms(domain)
    names = [name for name, spec in domain.objects.items() if spec.room is None]

    def factory(place_rng: np.random.Generator, detect_rng: np.random.Generator) -> DynamicKnowledge:
        _, cells = place_objects(domain, space, typical, place_rng)
        link = KbLink(lambda: kb, target, space.rooms)
        return objects_dynamic(space, cells, names, link, detect_rng, threshold=threshold)

    return factory


def _run_json(
    space: SearchSpace, record: SearchRecord, domain: str, target: str, seed: int, room_prior: dict[str, float]
) -> dict[str, Any]:
    def name(cell: int | None) -> str | None:
        return None if cell is None else space.cell_name(cell)

    return {
        "domain": domain,
        "target": target,
        "policy": record.policy,
        "strategy": record.strategy,
        "revision": record.revision,
        "dynamic_kb": record.dynamic_kb,
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
                "commits": [list(fact) for fact in s.commits],
            }
            for s in record.steps
        ],
        "verdict": record.verdict.value,
        "time": record.time,
        "reported_cell": name(record.reported_cell),
        "error_cells": record.error_cells,
        "accuracy": record.accuracy,
        "rejected_commits": [list(fact) for fact in record.rejected],
    }


@search_app.command()
@boundary
def simulate(
    domain_file: DomainArgument,
    trials: Annotated[int, typer.Option("--trials", "-n", min=1, help="How many paired trials.")] = 10,
    knowledge: Annotated[
        float,
        typer.Option(
            "--knowledge", min=0.0, max=1.0, help="Fraction of the other objects whose true room the robot knows."
        ),
    ] = 0.4,
    defaults: DefaultsOption = True,
    dynamic_kb: DynamicOption = False,
    strategy: Annotated[
        list[str] | None,
        typer.Option(
            "--strategy",
            "-s",
            help=f"Repeat or list with commas to compare: {', '.join(STRATEGY_NAMES)}.",
            show_default="expectation",
        ),
    ] = None,
    policy: Annotated[
        list[str] | None,
        typer.Option(
            "--policy", "-p", help="Repeat or list with commas: pomdp, greedy, pomdp-only.", show_default="pomdp"
        ),
    ] = None,
    revision: Annotated[
        list[str] | None,
        typer.Option(
            "--revision",
            help=f"Repeat or list with commas: {', '.join(REVISION_NAMES)}.",
            show_default="reuse",
        ),
    ] = None,
    target: Annotated[
        str | None,
        typer.Option(
            "--target",
            "-t",
            help="The target class, or 'any' for a random object per trial (default: the domain's `target`, else any).",
            show_default=False,
        ),
    ] = None,
    absent_fraction: Annotated[
        float,
        typer.Option("--absent-fraction", min=0.0, max=1.0, help="Probability that a trial's target is absent."),
    ] = 0.0,
    time_limit: TimeLimitOption = None,
    commit_threshold: CommitOption = 0.9,
    trust_weight: TrustWeightOption = 0.5,
    trust_r: TrustROption = 0.0,
    seed: Annotated[int, typer.Option("--seed", min=0, help="Seeds the worlds, the knowledge and the noise.")] = 0,
    timings: TimingsOption = True,
    json_output: Annotated[
        bool, typer.Option("--json", help="Print every trial and the summary as JSON on stdout.")
    ] = False,
) -> None:
    """Paired trials: every policy x strategy x revision on the same seeded worlds, targets and noise.

    Each trial places every object of the domain (where the domain says, else where its defaults
    say with probability 0.8, else at random), hides one of them as the target, and gives the robot
    the true rooms of a random --knowledge fraction of the others. Prints localisation time,
    accuracy and verdicts per arm.

    Example: beliefloc search simulate domains/home.yaml -n 200 -s none,expectation,sampling --absent-fraction 0.5

    Example: beliefloc search simulate domains/home.yaml -n 100 --knowledge 0.2 --no-defaults --dynamic-kb
    """
    from beliefloc.object_search.existence import ExistenceStrategy
    from beliefloc.object_search.experiment import Arm, TrialSettings, run_trials, summarize
    from beliefloc.object_search.policy import POLICIES
    from beliefloc.object_search.posterior import Revision
    from beliefloc.object_search.world import search_space
    from beliefloc.render.progress import progress_bar
    from beliefloc.render.search import trials_table

    strategies = _choices(strategy, "expectation", STRATEGY_NAMES, "--strategy")
    policies = _choices(policy, "pomdp", tuple(POLICIES), "--policy")
    revisions = _choices(revision, "reuse", REVISION_NAMES, "--revision")
    _check_revision_options(revisions, dynamic_kb, commit_threshold)
    if time_limit is not None and time_limit <= 0:
        raise UsageError(f"--time-limit must be positive, got {time_limit}")
    domain, chosen = _domain_and_target(domain_file, target, allow_any=True)
    space = search_space(domain)
    _warn_closed_rooms(domain)
    arms: list[Arm] = [
        Arm(p, ExistenceStrategy(s), Revision(r), dynamic_kb) for p in policies for s in strategies for r in revisions
    ]
    settings = TrialSettings(
        knowledge=knowledge,
        defaults=defaults,
        absent_fraction=absent_fraction,
        target=chosen,
        commit_threshold=commit_threshold,
        trust=_trust(trust_weight, trust_r),
        time_limit=time_limit,
    )
    started = time.perf_counter()
    with progress_bar(stderr_console()) as progress:
        task = progress.add_task("trials", total=trials, visible=trials > 1)
        records = run_trials(
            domain, arms, trials=trials, seed=seed, settings=settings, on_trial=lambda _: progress.advance(task)
        )
    seconds = time.perf_counter() - started
    summary = summarize(records)
    if json_output:
        print_json(_simulate_json(domain, space, arms, settings, records, summary, seed, seconds, timings))
        return
    what = "any object" if chosen is None else f"a {chosen}"
    title = (
        f"{trials} paired trials on {domain.name}, looking for {what}: knowledge {knowledge:g}, defaults "
        f"{'on' if defaults else 'off'}, target absent with probability {absent_fraction:g}, seed {seed}"
    )
    stdout_console().print(trials_table(summary, escape(title)))


def _simulate_json(
    domain: Domain,
    space: SearchSpace,
    arms: list[Arm],
    settings: TrialSettings,
    records: list[TrialRecord],
    summary: dict[str, dict[str, Any]],
    seed: int,
    seconds: float,
    timings: bool,
) -> dict[str, Any]:
    from beliefloc.object_search.experiment import search_parameters

    def name(cell: int | None) -> str | None:
        return None if cell is None else space.cell_name(cell)

    def clock(value: float | None) -> float | None:
        return value if timings else None

    return {
        "domain": domain.name,
        "seed": seed,
        "trials": len(records),
        "settings": {
            "knowledge": settings.knowledge,
            "defaults": settings.defaults,
            "absent_fraction": settings.absent_fraction,
            "target": settings.target,
            "p_typical": settings.p_typical,
            "commit_threshold": settings.commit_threshold,
            "trust": {"weight": settings.trust.weight, "r": settings.trust.r},
            **search_parameters(domain, settings),
        },
        "arms": [
            {
                "name": arm.name,
                "policy": arm.policy,
                "strategy": arm.strategy.value,
                "kb": "dynamic" if arm.dynamic_kb else "static",
                "revision": arm.revision.value,
            }
            for arm in arms
        ],
        "records": [
            {
                "trial": r.index,
                "target": r.target,
                "target_class": r.target_class,
                "present": r.present,
                "true_room": r.true_room,
                "true_cell": name(r.true_cell),
                "known": r.known,
                "room_prior": dict(zip(space.rooms, r.room_prior, strict=True)),
                "outcomes": {
                    o.arm: {
                        "verdict": o.verdict,
                        "time": o.time,
                        "steps": o.steps,
                        "reported_cell": name(o.reported_cell),
                        "error_cells": o.error_cells,
                        "accuracy": o.accuracy,
                        "commits": [list(fact) for fact in o.commits],
                        "seconds": clock(o.seconds),
                    }
                    for o in r.outcomes
                },
                "seconds": clock(r.seconds),
            }
            for r in records
        ],
        "summary": {
            arm: {k: (clock(v) if k == "mean_seconds" else v) for k, v in stats.items()}
            for arm, stats in summary.items()
        },
        "seconds": clock(seconds),
    }


def register(app: typer.Typer) -> None:
    app.add_typer(search_app, name="search")
