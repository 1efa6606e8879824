"""The options more than one command takes, defined once.

Choices and defaults come from the library's vocabulary modules (``planning.settings``,
``simulation.settings``), which import nothing numeric: building the command line loads neither
numpy nor scipy nor clingo. A command imports what it computes with when it runs.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Annotated

import typer

from beliefloc.cli.common import for_option
from beliefloc.errors import UsageError
from beliefloc.planning.settings import DEFAULT_WEIGHT, Heuristic, Planner, check_weight, heuristic_for

# --- numbers ---------------------------------------------------------------------------------------


def number(
    *, low: float | None = None, high: float | None = None, above: float | None = None
) -> Callable[[str | float], float]:
    """A parser for a float option (typer's ``parser=``): finite, at least ``low``, more than ``above``,
    at most ``high``; the message says so in words (click's ranges let NaN through)."""
    if low is not None and high is not None:
        wanted = f"a number from {low:g} to {high:g}"
    elif above is not None:
        wanted = f"a number greater than {above:g}"
    elif low is not None:
        wanted = f"a number of {low:g} or more"
    else:
        wanted = "a finite number"

    def parse(text: str | float) -> float:
        if isinstance(text, (int, float)):
            return float(text)  # the default, given by the code
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        ok = (
            math.isfinite(value)
            and (low is None or value >= low)
            and (above is None or value > above)
            and (high is None or value <= high)
        )
        if not ok:
            raise typer.BadParameter(f"must be {wanted}, got {text!r}")
        return value

    return parse


def whole(*, low: int = 0, high: int | None = None) -> Callable[[str | int], int]:
    """A parser for an integer option (typer's ``parser=``) from ``low`` to ``high`` (by default the
    largest count beliefloc takes from outside), read by :func:`beliefloc.source.limits.read_count`:
    ASCII digits only, range checked before ``int`` sees a long string."""
    from beliefloc.source.limits import LARGEST_COUNT, read_count

    def parse(text: str | int) -> int:
        if isinstance(text, int):
            return text  # the default, given by the code
        try:
            return read_count(text, "the value", lowest=low, highest=LARGEST_COUNT if high is None else high)
        except ValueError as exc:
            raise typer.BadParameter(str(exc).removeprefix("the value: ")) from None

    return parse


# --- what a command reads --------------------------------------------------------------------------

ModelArgument = Annotated[
    Path,
    typer.Argument(metavar="MAP|MODEL", help="A map (.yaml), a model (.npz) or a .pomdp file.", show_default=False),
]
BELIEF_HELP = (
    "The belief to start from: 'uniform', a YAML/JSON file {state: probability} (the output of 'track --json' "
    "works too), or prior:DOMAIN: where the domain's knowledge base says the robot is (its rooms must be the map's)."
)
BeliefOption = Annotated[str, typer.Option("--belief", metavar="uniform|FILE|prior:DOMAIN", help=BELIEF_HELP)]
DomainArgument = Annotated[
    Path, typer.Argument(metavar="DOMAIN", help="A domain file (domains/*.yaml).", show_default=False)
]
MacrosOption = Annotated[
    Path | None,
    typer.Option(
        "--macros",
        metavar="FILE.npz",
        help="A macro table from 'beliefloc macros build' (ec2-macros: default built for the model in memory).",
        show_default=False,
    ),
]

# --- how a command prints --------------------------------------------------------------------------

JsonOption = Annotated[bool, typer.Option("--json", help="Print machine-readable JSON on stdout.")]
TimingsOption = Annotated[
    bool,
    typer.Option("--timings/--no-timings", help="Include wall-clock seconds in --json (off: byte-identical reruns)."),
]
CompactOption = Annotated[
    bool | None,
    typer.Option(
        "--compact/--full",
        help="Force compact cells (2 characters: cell shade, arrow of the most likely heading) or full "
        "cells (a pixel per heading). Default: full when it fits the terminal.",
        show_default=False,
    ),
]
TopOption = Annotated[
    int, typer.Option("--top", parser=whole(low=0), metavar="N", help="How many of the most likely states to list.")
]

DEFAULT_RECORD_FRAMES = 200
"""At most this many frames in a --record animation, unless --record-frames says otherwise."""
RecordFramesOption = Annotated[
    str | None,
    typer.Option(
        "--record-frames",
        metavar="N",
        help="At most N frames for --record: the start and the last N-1 steps of a longer run.",
        show_default=str(DEFAULT_RECORD_FRAMES),
    ),
]

# --- randomness --------------------------------------------------------------------------------------

SeedOption = Annotated[
    int, typer.Option("--seed", parser=whole(low=0), metavar="N", help="Seeds every random number of the run.")
]

# --- planning (plan, simulate) ---------------------------------------------------------------------

ThresholdOption = Annotated[
    float,
    typer.Option(
        "--threshold",
        parser=number(low=0.0, high=1.0),
        metavar="P",
        help="Goal: one state holds at least this probability.",
    ),
]
PlannerOption = Annotated[
    Planner,
    typer.Option(
        "--planner",
        "--search",
        help="Best-first (with a heuristic) or uniform-cost search (--search is the old name).",
    ),
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
        parser=number(above=0.0),
        metavar="W",
        help="Best-first ranks beliefs by g + W·h; 1 is the paper's. Below 1 the actions' costs count more: "
        "cheaper plans from a longer search.",
    ),
]
MaxExpansionsOption = Annotated[
    int,
    typer.Option(
        "--max-expansions", parser=whole(low=1), metavar="N", help="Give up after expanding this many beliefs."
    ),
]
PlanTimeLimitOption = Annotated[
    float,
    typer.Option(
        "--time-limit", parser=number(above=0.0), metavar="SECONDS", help="Give up after this many seconds of search."
    ),
]

LookaheadOption = Annotated[
    int | None,
    typer.Option(
        "--lookahead",
        parser=whole(low=1),
        metavar="N",
        help="contingent: beliefs expanded per plan call. The robot follows the policy's branches, plans "
        "on from its belief at every step while the policy has unexpanded leaves, and plans again at a leaf "
        "that is not a goal; the search keeps what it learnt for the whole episode. "
        "Default: 30,000 / states, at least 32.",
        show_default=False,
    ),
]
PruneBelowOption = Annotated[
    float,
    typer.Option(
        "--prune-below",
        parser=number(low=0.0, high=1.0),
        metavar="P",
        help="Contingent plans: branches reached with less probability than this are not planned for; the "
        "robot plans again if it gets there (0: plan for every observation).",
    ),
]


def resolve_heuristic(planner: Planner, heuristic: Heuristic | None, weight: float) -> Heuristic:
    """The library's heuristic for ``--planner``, ``--heuristic`` and ``--h-weight``; an error names
    the options that contradict each other."""
    with for_option("--h-weight"):
        check_weight(weight)
    given = [f"--planner {planner.value}"]
    given += [f"--heuristic {heuristic.value}"] if heuristic is not None else []
    given += [f"--h-weight {weight:g}"] if weight != DEFAULT_WEIGHT else []
    with for_option(" ".join(given)):
        return heuristic_for(planner, heuristic, weight)


GammaOption = Annotated[
    float | None,
    typer.Option(
        "--gamma",
        parser=number(low=0.0, high=1.0),
        metavar="D",
        help="EC2: two states are distinguishable when their observation difference (Eq. 5) exceeds this. "
        "Default: halfway between the largest difference of two states with equal noise-free readings "
        "and the smallest of two with different ones.",
        show_default=False,
    ),
]

# --- knowledge bases (prior, kb, search) -----------------------------------------------------------

AllowOutsideOption = Annotated[
    bool,
    typer.Option(
        "--allow-outside",
        help="Read the domain's kb: files and the #include of every .lp file even when they are outside the "
        "folder of the file that names them (an absolute path, ../..): only for files you trust.",
    ),
]
"""Every command that reads a domain's knowledge base takes it (kb, prior, search)."""
TargetOption = Annotated[
    str | None,
    typer.Option(
        "--target",
        "-t",
        metavar="CLASS",
        help="The class searched for (default: the domain's `target`).",
        show_default=False,
    ),
]
KbOption = Annotated[
    list[Path] | None,
    typer.Option(
        "--kb",
        metavar="FILE.lp",
        help="An extra .lp file, added to kb/axioms.lp and the domain's own (repeatable).",
        show_default=False,
    ),
]
SeenOption = Annotated[
    list[str] | None,
    typer.Option(
        "--seen",
        metavar="OBJECT=ROOM",
        help="An observed fact OBJECT=ROOM (OBJECT:CLASS=ROOM for a new object), at the last step (repeatable).",
        show_default=False,
    ),
]
DefaultsOption = Annotated[
    bool, typer.Option("--defaults/--no-defaults", help="Use the domain file's defaults (those in .lp files stay).")
]

# --- sweeps (simulate, search simulate) ------------------------------------------------------------

WorkersOption = Annotated[
    int,
    typer.Option(
        "--workers",
        "-j",
        parser=whole(low=0),
        metavar="N",
        help="Run the episodes in N worker processes (0: one per core; 1: in this process). The results are "
        "the same on every backend.",
    ),
]
SchedulerOption = Annotated[
    str | None,
    typer.Option(
        "--scheduler",
        metavar="tcp://HOST:PORT",
        help="Run on the workers of this Dask scheduler (needs pip install 'beliefloc[dask]'); the workers "
        "must run the same beliefloc version.",
        show_default=False,
    ),
]
OutOption = Annotated[
    Path | None,
    typer.Option(
        "--out",
        metavar="FILE.jsonl",
        help="Write a results file: a header line with the settings, then one JSON line per finished unit, in "
        "order, flushed as it ends ('beliefloc summarize FILE.jsonl' reads it, even while the run goes on).",
        show_default=False,
    ),
]
ResumeOption = Annotated[
    bool,
    typer.Option(
        "--resume",
        help="With --out: continue a run that stopped; the units already in the file are not run again (the "
        "file must have been written with the same settings).",
    ),
]


def parse_laser_pose(text: str) -> tuple[float, float, float]:
    """``"X,Y,YAW"`` (metres, metres, radians) -> a tuple; UsageError naming --laser-pose."""
    parts = [p.strip() for p in text.split(",")]
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        values = ()
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise UsageError(
            f"--laser-pose {text!r}: give the laser's pose on the base as X,Y,YAW (metres, metres, radians), "
            "e.g. -0.04,0,1.5708"
        )
    return values[0], values[1], values[2]
