"""``search run`` and ``search simulate``: knowledge-guided object search (Zhang, Sridharan & Wyatt 2015,
Algorithm 1) against a simulated world -- one search step by step, or paired trials with statistics.

Every choice and help text comes from the library's vocabulary (:mod:`beliefloc.object_search.settings`),
which imports nothing numeric; a command imports what it computes with when it runs. The records
give their own ``--json`` shapes; a command adds its wall-clock ``seconds``.
"""

from __future__ import annotations

import enum
import time
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, TypeVar

import typer
from rich.markup import escape

from beliefloc.cli.common import (
    boundary,
    check_output,
    check_record,
    check_sweep_options,
    for_option,
    positive_int,
    print_json,
    run_sweep,
    target_option,
    warn,
)
from beliefloc.cli.options import (
    DEFAULT_RECORD_FRAMES,
    AllowOutsideOption,
    DefaultsOption,
    DomainArgument,
    OutOption,
    RecordFramesOption,
    ResumeOption,
    SchedulerOption,
    SeedOption,
    TargetOption,
    TimingsOption,
    WorkersOption,
    number,
    whole,
)
from beliefloc.errors import EXIT_NEGATIVE, UsageError
from beliefloc.object_search.settings import (
    COMMIT_THRESHOLD,
    Metareasoning,
    PolicyName,
    Revision,
    Scenes,
    check_commit_threshold,
    check_time_limit,
    wall_clock,
)
from beliefloc.render import stderr_console, stdout_console

if TYPE_CHECKING:
    from rich.console import Console

    from beliefloc.object_search.loop import SearchRecord
    from beliefloc.object_search.posterior import TrustFactor
    from beliefloc.object_search.space import SearchSpace

search_app = typer.Typer(
    name="search",
    help="Knowledge-guided object search: an ASP room prior, a belief over cells, early termination.",
    short_help="Search a domain for an object with a simulated robot.",
    no_args_is_help=True,
    rich_markup_mode=None,
)

Choice = TypeVar("Choice", bound=enum.Enum)


def _names(vocabulary: type[enum.Enum]) -> str:
    return ", ".join(str(member.value) for member in vocabulary)


METAREASONING_OPTION = "--metareasoning/--strategy"
"""How error messages name ``--metareasoning`` (``--strategy``, its old name, still works)."""
METAREASONING_HELP = f"Existence metareasoning (Eq. 10-14): {_names(Metareasoning)}."
POLICY_HELP = "Action selection: " + "; ".join(f"{p.value} ({p.description})" for p in PolicyName) + "."
REVISION_HELP = f"How a revised prior meets the observations: {_names(Revision)}."
SCENES_HELP = "How a view's image is analysed: " + "; ".join(f"{s.value} ({s.description})" for s in Scenes) + "."

DynamicOption = Annotated[
    bool,
    typer.Option(
        "--dynamic-kb",
        help="Revise the knowledge base during the search: other objects seen with a room belief above "
        "--commit-threshold are committed and the target's prior recomputed (Algorithm 1, lines 7-10).",
    ),
]
# every float option refuses NaN and infinity (``number``), naming the option; ranges that depend on
# each other are checked by the library (``for_option``)
CommitOption = Annotated[
    float,
    typer.Option(
        "--commit-threshold",
        parser=number(),
        metavar="P",
        help="--dynamic-kb: an object's room belief above which it is committed (in (0.5, 1)).",
    ),
]
TrustWeightOption = Annotated[
    float,
    typer.Option(
        "--trust-weight", metavar="W", help="trust-factor revision: the weight w of the KB's belief (in [0, 1])."
    ),
]
TrustROption = Annotated[
    float,
    typer.Option(
        "--trust-r", metavar="R", help="trust-factor revision: the r of the r-norm (0 logarithmic, 1 linear; r >= 0)."
    ),
]
"""The trust factor checks both (NaN and infinity too) and names them together."""
TimeLimitOption = Annotated[
    float | None,
    typer.Option(
        "--time-limit",
        parser=number(),
        metavar="T",
        help="Time units (default: the domain's search.time_limit).",
        show_default=False,
    ),
]
"""``--record-frames``: as ``simulate --record``'s, two minutes of GIF at 0.6 s a frame."""


def _choice(name: str, default: Choice, option: str) -> Choice:
    """One name of ``default``'s vocabulary (a UsageError listing them otherwise)."""
    vocabulary = type(default)
    allowed = [str(member.value) for member in vocabulary]
    if name not in allowed:
        raise UsageError(f"{option} {name!r}: expected one of: {', '.join(allowed)}")
    return vocabulary(name)


def _choices(values: list[str] | None, default: Choice, option: str) -> list[Choice]:
    """A repeatable option that also takes comma lists (``-m none -m expectation,sampling``), deduplicated."""
    chosen: list[Choice] = []
    for value in values or [str(default.value)]:
        for part in value.split(","):
            member = _choice(part.strip(), default, option)
            if member not in chosen:
                chosen.append(member)
    return chosen


def _trust(weight: float, r: float) -> TrustFactor:
    from beliefloc.object_search.posterior import TrustFactor

    with for_option("--trust-weight / --trust-r"):
        trust = TrustFactor(weight, r)
    return trust


def _check_search_options(
    revisions: list[Revision], dynamic_kb: bool, commit_threshold: float, time_limit: float | None
) -> None:
    with for_option("--commit-threshold"):
        check_commit_threshold(commit_threshold)
    if time_limit is not None:
        with for_option("--time-limit"):
            check_time_limit(time_limit)
    if not dynamic_kb and Revision.DISCARD in revisions:
        warn("--revision discard changes nothing without --dynamic-kb: the prior is never revised")


def _scene_mode(name: str | None, has_model: bool) -> Scenes:
    """``--scenes``: the SP-POMDP by default when the domain has a scene model, else the fixed detector."""
    mode = _choice(name, Scenes.PLANNED, "--scenes") if name is not None else None
    return _check_scene_modes([mode] if mode is not None else [], has_model)[0]


def _check_scene_modes(modes: list[Scenes], has_model: bool) -> list[Scenes]:
    if not modes:
        return [Scenes.PLANNED if has_model else Scenes.FIXED]
    if not has_model and any(mode is not Scenes.FIXED for mode in modes):
        raise UsageError(
            "--scenes planned and all need a scene model (a scene: section in the domain file, "
            "docs/domain-format.md); this domain has none, so only --scenes fixed applies"
        )
    return modes


def _warn_closed_rooms(space: SearchSpace) -> None:
    if space.closed_rooms:
        warn(
            f"{', '.join(space.closed_rooms)}: marked 'accessible: false': the robot does not search there, and "
            "the room prior of the other rooms is renormalised"
        )


@search_app.command(short_help="Search a domain for a target, step by step; print the verdict.")
@boundary
def run(
    domain_file: DomainArgument,
    target: TargetOption = None,
    metareasoning: Annotated[
        str, typer.Option("--metareasoning", "--strategy", metavar="NAME", help=METAREASONING_HELP)
    ] = Metareasoning.EXPECTATION.value,
    policy: Annotated[str, typer.Option("--policy", metavar="NAME", help=POLICY_HELP)] = PolicyName.POMDP.value,
    seed: SeedOption = 0,
    target_cell: Annotated[
        str | None,
        typer.Option(
            "--target-cell",
            metavar="ROOM:ROW,COL",
            help="Put the target at ROOM:ROW,COL: inside the room on a plane of rooms, the map's row and column "
            "for a domain with map: (default: a random cell).",
            show_default=False,
        ),
    ] = None,
    absent: Annotated[bool, typer.Option("--absent", help="The target is nowhere in the domain.")] = False,
    defaults: DefaultsOption = True,
    allow_outside: AllowOutsideOption = False,
    dynamic_kb: DynamicOption = False,
    revision: Annotated[str, typer.Option("--revision", metavar="NAME", help=REVISION_HELP)] = Revision.REUSE.value,
    commit_threshold: CommitOption = COMMIT_THRESHOLD,
    trust_weight: TrustWeightOption = 0.5,
    trust_r: TrustROption = 0.0,
    time_limit: TimeLimitOption = None,
    scenes: Annotated[
        str | None, typer.Option("--scenes", metavar="NAME", help=SCENES_HELP, show_default=False)
    ] = None,
    show: Annotated[
        bool,
        typer.Option(
            "--show",
            help="Draw the belief over the rooms' cells after every step (on the map's grid with map:); with a "
            "scene model, the ROIs processed, the operators applied and the higher level's belief.",
        ),
    ] = False,
    output: Annotated[
        Path | None,
        typer.Option(
            "-o",
            "--output",
            metavar="FILE.png|FILE.svg",
            help="Also draw the search as a picture (needs matplotlib: pip install 'beliefloc[plots]'): the "
            "belief over the cells at the end, the views taken, the robot's path, and the room prior beside it.",
            show_default=False,
        ),
    ] = None,
    recording: Annotated[
        Path | None,
        typer.Option(
            "--record",
            metavar="FILE.gif|DIR",
            help="Animate the search, the picture of -o after every step: an animated GIF, or numbered PNG "
            "frames (frame-000.png, …) in the folder DIR (created; an existing DIR must hold nothing but frames).",
            show_default=False,
        ),
    ] = None,
    record_frames: RecordFramesOption = None,
    timings: TimingsOption = True,
    json_output: Annotated[bool, typer.Option("--json", help="Print the steps and verdict as JSON on stdout.")] = False,
) -> None:
    """Search a domain for a target with a simulated robot; print every step and the verdict.

    With --dynamic-kb the domain's objects without a room are placed in the simulated world (where
    the defaults put them, or at random) and committed to the knowledge base when seen.

    With -o the search is also drawn as a picture, and with --record animated step by step (as
    --show draws it in the terminal); one line says what was written.

    A domain with a scene model (scene:) analyses every view with the SP-POMDP: per view, the ROIs
    processed, the operators applied and the higher level's belief are shown with --show and given
    in --json; --scenes fixed uses the search: section's detector instead.

    Exit code 0 when found, 1 when the robot gives up (not found) or runs out of time.

    Examples:

    \b
      beliefloc search run domains/home.yaml --target printer --seed 3 --show
      beliefloc search run domains/home.yaml --dynamic-kb --revision discard   # exits 1
      beliefloc search run domains/apartment.yaml --target-cell kitchen:7,9 --show
      beliefloc search run domains/home.yaml --seed 3 -o search.png --record search.gif
      beliefloc search run domains/home.yaml --seed 3 --scenes fixed   # the fixed detector
    """
    from beliefloc.knowledge import KnowledgeBase, load_domain
    from beliefloc.object_search.domain_space import search_space
    from beliefloc.object_search.dynamic import dynamic_factory
    from beliefloc.object_search.loop import Verdict, seeded_search
    from beliefloc.object_search.policy import POLICIES
    from beliefloc.render.drawing import uses_color
    from beliefloc.render.search import (
        belief_plane,
        scene_lines,
        search_legend,
        step_line,
        steps_table,
        verdict_text,
    )

    gif, frame_limit = _check_pictures(domain_file, output, recording, record_frames)
    chosen_metareasoning = _choice(metareasoning, Metareasoning.EXPECTATION, METAREASONING_OPTION)
    chosen_policy = POLICIES[_choice(policy, PolicyName.POMDP, "--policy").value]
    chosen_revision = _choice(revision, Revision.REUSE, "--revision")
    _check_search_options([chosen_revision], dynamic_kb, commit_threshold, time_limit)
    trust = _trust(trust_weight, trust_r)
    if absent and target_cell is not None:
        raise UsageError("--absent and --target-cell contradict each other; give one")
    domain = load_domain(domain_file, allow_outside=allow_outside)
    with for_option(target_option(target)):
        chosen = domain.resolve_target(target)
    space = search_space(domain)
    settings = domain.search_settings
    assert settings is not None  # search_space raised otherwise
    cell = None
    if target_cell is not None:
        with for_option("--target-cell"):
            cell = space.target_cell(target_cell)
    _warn_closed_rooms(space)
    mode = _scene_mode(scenes, domain.scene is not None)
    setup = None
    if mode is not Scenes.FIXED:
        from beliefloc.object_search.scene_views import SceneSetup
        from beliefloc.object_search.world import typical_rooms

        setup = SceneSetup.of(domain, typical_rooms(domain))
        assert setup is not None  # _scene_mode refused planned/all without a scene model
        with for_option(target_option(target)):
            space = setup.space(space, chosen, mode)
    kb = KnowledgeBase(domain, use_defaults=defaults)
    result = kb.prior(chosen)
    if result.message:
        warn(result.message)
    room_prior = space.over_rooms(result.prior)
    started = time.perf_counter()
    record = seeded_search(
        space,
        room_prior,
        chosen_policy,
        chosen_metareasoning,
        seed=seed,
        target_cell=cell,
        absent=absent,
        alpha=settings.existence.alpha,
        beta=settings.existence.beta,
        tau_found=settings.tau_found,
        tau_absent=settings.tau_absent,
        time_limit=settings.time_limit if time_limit is None else time_limit,
        keep_beliefs=show or output is not None or recording is not None,
        revision=chosen_revision,
        trust=trust,
        dynamic=dynamic_factory(domain, space, kb, chosen, threshold=commit_threshold) if dynamic_kb else None,
        scene=None if setup is None else setup.world(),
    )
    seconds = time.perf_counter() - started
    if json_output:
        print_json(
            {**record.as_json(space, domain=domain.name, target=chosen), "seconds": wall_clock(seconds, timings)}
        )
    else:
        console = stdout_console()
        if dynamic_kb:
            kb_text = f", dynamic KB ({chosen_revision.value})"
        else:
            kb_text = f", {chosen_revision.value}" if chosen_revision is not Revision.REUSE else ""
        on_map = f" on {escape(str(domain.map_file))}" if domain.map_file is not None else ""
        console.print(
            f"searching {escape(domain.name)}{on_map} for a {escape(chosen)}: {record.policy.value} policy, "
            f"{record.metareasoning.value} metareasoning{kb_text}, seed {seed}; room prior "
            + ", ".join(f"{escape(r)} {p:.3f}" for r, p in zip(space.rooms, room_prior.tolist(), strict=True)),
            soft_wrap=True,
        )
        if show:
            color = uses_color(console)
            console.print(search_legend(space, color=color))
            console.print(
                belief_plane(space, record.initial_belief, robot=space.start, target=record.true_cell, color=color)
            )
            for step in record.steps:
                console.print(step_line(space, step))
                if step.scene is not None and record.scene_model is not None:
                    console.print(scene_lines(record.scene_model, step.scene))
                assert step.belief is not None
                console.print(belief_plane(space, step.belief, robot=step.view, target=record.true_cell, color=color))
        else:
            console.print(steps_table(space, record))
        console.print(verdict_text(space, record))
    heading = (
        f"{domain.name}: searching for a {chosen} ({record.policy.value} policy, "
        f"{record.metareasoning.value} metareasoning, seed {seed})"
    )
    said = stderr_console() if json_output else stdout_console()
    if output is not None:
        _write_picture(output, space, record, heading, said)
    if recording is not None and frame_limit is not None:
        _write_recording(recording, gif, frame_limit, space, record, heading, said)
    if record.verdict is not Verdict.FOUND:
        raise typer.Exit(EXIT_NEGATIVE)


def _check_pictures(
    domain_file: Path, output: Path | None, record: Path | None, record_frames: str | None
) -> tuple[bool, int | None]:
    """``-o``, ``--record`` and ``--record-frames``, checked before any work (nothing is searched
    for a picture that could not be written): whether the recording is a GIF, and its frame limit
    (None without ``--record``)."""
    if record is None and record_frames is not None:
        raise UsageError(f"--record-frames {record_frames}: needs --record FILE.gif|DIR")
    if output is None and record is None:
        return False, None
    from beliefloc.render.figures import PICTURE_SUFFIXES, pyplot

    if output is not None:
        check_output("-o", output, PICTURE_SUFFIXES, (domain_file,))
    gif, limit = False, None
    if record is not None:
        limit = DEFAULT_RECORD_FRAMES if record_frames is None else positive_int("--record-frames", record_frames)
        gif = check_record("--record", record, (domain_file,))
    pyplot()  # matplotlib missing: say so before any work
    return gif, limit


def _write_picture(output: Path, space: SearchSpace, record: SearchRecord, heading: str, said: Console) -> None:
    from beliefloc.render.figures import save_figure
    from beliefloc.render.picture_search import search_figure

    with search_figure(space, record, heading=heading) as fig:
        save_figure(fig, output)
    said.print(f"wrote {escape(str(output))}", soft_wrap=True)


def _write_recording(
    path: Path, gif: bool, limit: int, space: SearchSpace, record: SearchRecord, heading: str, said: Console
) -> None:
    from beliefloc.render.figures import save_gif
    from beliefloc.render.picture_episode import save_frames
    from beliefloc.render.picture_search import frame_pngs, frame_steps

    steps = frame_steps(len(record.steps), limit)
    frames = list(frame_pngs(space, record, steps, heading=heading))
    if gif:
        save_gif(frames, path)
    else:
        save_frames(frames, path)
    n = len(record.steps)
    kept = "" if len(frames) == n + 1 else f": the start and the last {len(frames) - 1} of {n} steps"
    said.print(escape(f"recorded the search in {len(frames)} frames{kept} → {path}"), soft_wrap=True)


@search_app.command(short_help="Paired trials of search strategies, with statistics.")
@boundary
def simulate(
    domain_file: DomainArgument,
    trials: Annotated[
        int, typer.Option("--trials", "-n", parser=whole(low=1), metavar="N", help="How many paired trials.")
    ] = 10,
    knowledge: Annotated[
        float,
        typer.Option(
            "--knowledge",
            parser=number(low=0.0, high=1.0),
            metavar="F",
            help="Fraction of the other objects whose true room the robot knows.",
        ),
    ] = 0.4,
    defaults: DefaultsOption = True,
    allow_outside: AllowOutsideOption = False,
    dynamic_kb: DynamicOption = False,
    metareasoning: Annotated[
        list[str] | None,
        typer.Option(
            "--metareasoning",
            "-m",
            "--strategy",
            "-s",
            metavar="NAME,...",
            help=f"Repeat or list with commas to compare: {_names(Metareasoning)}.",
            show_default=Metareasoning.EXPECTATION.value,
        ),
    ] = None,
    policy: Annotated[
        list[str] | None,
        typer.Option(
            "--policy",
            "-p",
            metavar="NAME,...",
            help=f"Repeat or list with commas: {_names(PolicyName)}.",
            show_default=PolicyName.POMDP.value,
        ),
    ] = None,
    revision: Annotated[
        list[str] | None,
        typer.Option(
            "--revision",
            metavar="NAME,...",
            help=f"Repeat or list with commas: {_names(Revision)}.",
            show_default=Revision.REUSE.value,
        ),
    ] = None,
    target: Annotated[
        str | None,
        typer.Option(
            "--target",
            "-t",
            metavar="CLASS|any",
            help="The target class, or 'any' for a random object per trial (default: the domain's `target`, else any).",
            show_default=False,
        ),
    ] = None,
    absent_fraction: Annotated[
        float,
        typer.Option(
            "--absent-fraction",
            parser=number(low=0.0, high=1.0),
            metavar="P",
            help="Probability that a trial's target is absent.",
        ),
    ] = 0.0,
    time_limit: TimeLimitOption = None,
    scenes: Annotated[
        list[str] | None,
        typer.Option(
            "--scenes",
            metavar="NAME,...",
            help="Repeat or list with commas to compare: " + SCENES_HELP[0].lower() + SCENES_HELP[1:],
            show_default=False,
        ),
    ] = None,
    correlation: Annotated[
        float | None,
        typer.Option(
            "--correlation",
            parser=number(low=0.0, high=1.0),
            metavar="RHO",
            help="A correlated world (the class-to-room ties of the paper's domain): every object is in its "
            "class's home room with probability RHO, else in another room (default: the domain's placement: "
            "where the file says, else its default's room with probability 0.8).",
            show_default=False,
        ),
    ] = None,
    commit_threshold: CommitOption = COMMIT_THRESHOLD,
    trust_weight: TrustWeightOption = 0.5,
    trust_r: TrustROption = 0.0,
    seed: SeedOption = 0,
    workers: WorkersOption = 1,
    scheduler: SchedulerOption = None,
    out_file: OutOption = None,
    resume: ResumeOption = False,
    timings: TimingsOption = True,
    json_output: Annotated[
        bool, typer.Option("--json", help="Print every trial and the summary as JSON on stdout.")
    ] = False,
) -> None:
    """Paired trials: every policy x metareasoning x revision on the same seeded worlds, targets and noise.

    Each trial places every object of the domain (where the domain says, else where its defaults
    say with probability 0.8, else at random), hides one of them as the target, and gives the robot
    the true rooms of a random --knowledge fraction of the others. Prints localisation time,
    accuracy and verdicts per arm.

    Trial t draws its random numbers from generators keyed by (--seed, t) only, so --workers N and
    --scheduler give the same results as one process (a cluster's workers must see the domain's
    .lp files at the same paths). --out writes a line per trial as it ends; --resume continues it.

    With a scene model the table adds the time spent processing images (the rest is travel) and the
    operator applications per search; the --json trials carry "operators_applied" and
    "processing_time". --correlation RHO builds correlated worlds instead (every object in its class's
    home room with probability RHO).

    Examples:

    \b
      beliefloc search simulate domains/home.yaml -n 200 -m none,expectation,sampling --absent-fraction 0.5
      beliefloc search simulate domains/home.yaml -n 100 --knowledge 0.2 --no-defaults --dynamic-kb
      beliefloc search simulate domains/home.yaml -n 100 --workers 2 --out home.jsonl --no-timings
      beliefloc search simulate domains/home.yaml -n 200 --scenes planned,all,fixed
      beliefloc search simulate domains/home.yaml -n 200 --knowledge 1 --no-defaults --correlation 0.97
    """
    from beliefloc.files.results_file import header
    from beliefloc.knowledge import load_domain
    from beliefloc.object_search.domain_space import search_space
    from beliefloc.object_search.experiment import Arm, TrialRecord, TrialSettings, TrialSweep, run_title, summarize
    from beliefloc.render.search import trials_table

    metareasonings = _choices(metareasoning, Metareasoning.EXPECTATION, METAREASONING_OPTION)
    policies = _choices(policy, PolicyName.POMDP, "--policy")
    revisions = _choices(revision, Revision.REUSE, "--revision")
    _check_search_options(revisions, dynamic_kb, commit_threshold, time_limit)
    check_sweep_options(workers, scheduler, out_file, resume, (domain_file,))
    trust = _trust(trust_weight, trust_r)
    domain = load_domain(domain_file, allow_outside=allow_outside)
    with for_option(target_option(target)):
        chosen = domain.resolve_target(target, allow_any=True)
    space = search_space(domain)
    _warn_closed_rooms(space)
    modes = _check_scene_modes(
        [] if scenes is None else _choices(scenes, Scenes.PLANNED, "--scenes"), domain.scene is not None
    )
    compared: list[Scenes | None] = list(modes) if len(modes) > 1 else [None]
    arms = [
        Arm(p.value, m, r, dynamic_kb, scenes=s)
        for s in compared
        for p in policies
        for m in metareasonings
        for r in revisions
    ]
    if any(mode is not Scenes.FIXED for mode in modes) and chosen is not None:
        from beliefloc.object_search.scene import scene_model

        model = scene_model(domain)
        assert model is not None
        with for_option(target_option(target)):
            model.look(chosen)
    settings = TrialSettings(
        knowledge=knowledge,
        defaults=defaults,
        absent_fraction=absent_fraction,
        target=chosen,
        commit_threshold=commit_threshold,
        trust=trust,
        time_limit=time_limit,
        correlation=correlation,
    )
    sweep = TrialSweep(domain, tuple(arms), seed, settings, timings=timings, scenes=modes != [Scenes.FIXED])
    head = header(
        "search simulate",
        "trial",
        trials,
        {
            "domain": str(domain_file),
            "files_sha256": _digests(domain_file, domain.kb_files()),
            "domain_name": domain.name,
            "seed": seed,
            "arms": [arm.as_json() for arm in arms],
            "trial_settings": settings.as_json(domain),
            "timings": timings,
        },
    )
    started = time.perf_counter()
    results = run_sweep(sweep, workers=workers, scheduler=scheduler, out=out_file, resume=resume, head=head)
    seconds = time.perf_counter() - started
    summary = summarize([TrialRecord.from_json(result) for result in results])
    if json_output:
        print_json(
            {
                "domain": domain.name,
                "seed": seed,
                "trials": len(results),
                "settings": settings.as_json(domain),
                "arms": [arm.as_json() for arm in arms],
                "records": results,
                "summary": {arm: stats.as_json(timings=timings) for arm, stats in summary.items()},
                "seconds": wall_clock(seconds, timings),
            }
        )
        return
    title = run_title(domain.name, trials, seed, settings.as_json(domain))
    stdout_console().print(trials_table(summary, escape(title)))


def _digests(domain_file: Path, kb_files: list[Path]) -> dict[str, str]:
    """The SHA-256 of the domain file and of each of its knowledge-base files, by path."""
    from beliefloc.files.results_file import digest

    return {str(path): digest(path) for path in [domain_file, *kb_files] if path.is_file()}


def register(app: typer.Typer) -> None:
    app.add_typer(search_app, name="search")
