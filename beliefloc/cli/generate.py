"""``generate``: maps made at random, e.g. the grid worlds of Colledanchise et al. 2020, Sec. VII-A."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape

from beliefloc.cli.common import boundary, check_output, for_option, print_json
from beliefloc.cli.options import JsonOption
from beliefloc.errors import UsageError
from beliefloc.files.model_sources import MAP_SUFFIXES
from beliefloc.render import stdout_console
from beliefloc.simulation.settings import CLASSES, MOVE_FAILURE, SeenModel

generate_app = typer.Typer(
    name="generate",
    help="Make maps at random (the random grid worlds of Colledanchise et al. 2020, Sec. VII-A).",
    short_help="Make random maps (Colledanchise et al.'s grid worlds).",
    no_args_is_help=True,
    rich_markup_mode=None,
)

_COUNT = re.compile(r"^\s*(\d+)\s*(?:(?:e|E|\*\*|\^)\s*(\d+))?\s*$")


def parse_count(text: str) -> int:
    """``1000``, ``1e3`` or ``10^3`` -> 1000 (the paper writes sizes as powers of ten)."""
    match = _COUNT.match(text)
    if not match:
        raise typer.BadParameter(f"{text!r} is not a whole number (e.g. 1000, 1e3 or 10^3)")
    base, exponent = int(match[1]), match[2]
    if exponent is None:
        return base
    if len(exponent) > 2:
        raise typer.BadParameter(f"{text!r} is far too large")
    scientific = "e" in text.lower()  # 1e3 = 1 * 10^3; otherwise 10^3 or 10**3
    power: int = (10 if scientific else base) ** int(exponent)
    return base * power if scientific else power


@generate_app.command(short_help="Write a random grid world as a map file.")
@boundary
def gridworld(
    states: Annotated[
        int,
        typer.Option(
            "--states",
            parser=parse_count,
            metavar="N",
            help="About how many states (1000, 1e3 or 10^3); the grid is round(sqrt(N/4)) on a side.",
            show_default=False,
        ),
    ],
    seed: Annotated[
        int, typer.Option("--seed", min=0, metavar="S", help="Seed of numpy.random.default_rng.", show_default=False)
    ],
    output: Annotated[Path, typer.Option("-o", "--output", metavar="MAP", help="Map file to write (.yaml).")],
    seen_model: Annotated[
        SeenModel,
        typer.Option(
            "--seen-model",
            help="objects: place objects and derive what is seen from range and field of view; "
            "states: random states see each class, as the authors' code (the paper's Tables I-II).",
        ),
    ] = SeenModel.OBJECTS,
    rotation_failure: Annotated[
        float,
        typer.Option(
            "--rotation-failure",
            metavar="P",
            help="Failure of the rotations (the paper's text: 0.02 like every move; the authors' code: 0, "
            "a rotation always turns).",
        ),
    ] = MOVE_FAILURE,
    json_output: JsonOption = False,
) -> None:
    """Write a random grid world as a map file, as in Colledanchise's experiments (Sec VII-A).

    An open grid of round(sqrt(N/4)) x round(sqrt(N/4)) cells with 4 headings each, object classes
    A, B, C, D, a look with false positive and negative rates 0.01 (cost 1), and moves forward,
    backward, rotate_cw, rotate_ccw (failure 0.02, cost 10; with --rotation-failure 0 rotations always
    turn, as in the authors' code). The same seed writes the same file, byte for byte; an existing
    file is replaced.

    Example:

    \b
      beliefloc generate gridworld --states 1000 --seed 1 --seen-model states -o world.yaml
    """
    if output.suffix.lower() not in MAP_SUFFIXES:
        raise UsageError(f"{output}: a map file must end in .yaml or .yml")
    import numpy as np

    from beliefloc.simulation.gridworld import generate_gridworld, grid_side, gridworld_yaml
    from beliefloc.source import file_kinds
    from beliefloc.source.atomic_write import write_atomically

    check_output("-o", output, MAP_SUFFIXES, (), file_kinds.MAP)

    with for_option("--states"):
        grid_side(states)
    with for_option("--rotation-failure"):
        world = generate_gridworld(states, np.random.default_rng(seed), seen_model, rotation_failure=rotation_failure)
    data = gridworld_yaml(world, seed=seed).encode()

    write_atomically(output, lambda handle: handle.write(data))
    annotations = world.annotations() if seen_model is SeenModel.STATES else []
    if seen_model is SeenModel.OBJECTS:
        what = f"{len(world.landmarks)} objects"
    else:
        what = f"{len(annotations)} annotations over {sum(len(s) for _, s in annotations)} states"
    if json_output:
        print_json(
            {
                "output": str(output),
                "states": world.n_states,
                "rows": world.rows,
                "cols": world.cols,
                "seen_model": seen_model.value,
                "rotation_failure": rotation_failure,
                "seed": seed,
                "classes": list(CLASSES),
                "objects": len(world.landmarks),
                "annotations": len(annotations),
            }
        )
    else:
        stdout_console().print(
            f"wrote {escape(str(output))}: {world.n_states} states ({world.rows}x{world.cols} grid x 4 headings), "
            f"seen model {seen_model.value}, {what}, seed {seed}",
            soft_wrap=True,  # one line, whatever the terminal's width
        )


def register(app: typer.Typer) -> None:
    """Adds the ``generate`` group to the app."""
    app.add_typer(generate_app)
