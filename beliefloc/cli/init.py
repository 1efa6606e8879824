"""``init``: a commented starting map or domain that validates, to copy from rather than write from scratch."""

from __future__ import annotations

import contextlib
import math
import os
import re
import shlex
import tempfile
from importlib import resources
from pathlib import Path
from typing import Annotated

import typer

from beliefloc.cli.common import boundary, check_output, warn
from beliefloc.cli.options import number
from beliefloc.errors import UsageError

KINDS = ("map", "domain")
_NAME = re.compile(r"^[A-Za-z0-9_\-]{1,64}$")
SCHEMAS_FOLDER = "schemas"
"""Where ``init`` looks for ``<kind>.schema.json``, in the new file's folder and the folders above it
(as in the beliefloc repository: ``schemas/map.schema.json`` beside ``maps/``)."""


@boundary
def init_command(
    kind: Annotated[str, typer.Argument(metavar="map|domain", help="What to start.", show_default=False)],
    name: Annotated[
        str,
        typer.Argument(
            metavar="NAME", help="Its name (letters, digits, _ and -); the file is NAME.yaml.", show_default=False
        ),
    ],
    output: Annotated[
        Path | None,
        typer.Option(
            "-o",
            "--output",
            metavar="FILE.yaml",
            help="Write to this .yaml file instead of NAME.yaml here.",
            show_default=False,
        ),
    ] = None,
    schema: Annotated[
        str | None,
        typer.Option(
            "--schema",
            metavar="PATH|URL",
            help="What the first line points the editor at. Default: the nearest schemas/KIND.schema.json in "
            "the file's folder or above (relative to the file), else KIND.schema.json beside it.",
            show_default=False,
        ),
    ] = None,
    occupancy: Annotated[
        Path | None,
        typer.Option(
            "--occupancy",
            metavar="MAP.yaml",
            help="A map: an overlay on this SLAM map (map_server's YAML): cells sized from the map's size, "
            "8 headings, a laser; the map's extent in a comment.",
            show_default=False,
        ),
    ] = None,
    cell_size: Annotated[
        float | None,
        typer.Option(
            "--cell-size",
            metavar="M",
            parser=number(low=0.001, high=1e9),
            help="With --occupancy: the cell size in metres instead of the one chosen from the map's size.",
            show_default=False,
        ),
    ] = None,
    robot_radius: Annotated[
        float,
        typer.Option(
            "--robot-radius",
            metavar="M",
            parser=number(low=0.0, high=1e9),
            help="With --occupancy: the robot's radius in metres.",
        ),
    ] = 0.15,
    beams: Annotated[
        str,
        typer.Option(
            "--beams",
            metavar="DEG,DEG,...",
            help="With --occupancy: the laser's beams, degrees counter-clockwise from the heading (90 is left), "
            "multiples of 45.",
        ),
    ] = "90,0,-90",
) -> None:
    """Write a commented, valid starting map or domain.

    It never overwrites a file. The map is a small room with a layout, two landmarks, a look and a
    scan sensor and actions with costs; the domain has rooms, classes, objects, defaults, a target
    and the robot's dock. Each field has a short comment; docs/map-format.md and
    docs/domain-format.md describe them all.

    The first line, '# yaml-language-server: $schema=...', gives an editor with a YAML language
    server completion and checks as you type. It points at the nearest schemas/KIND.schema.json
    (so inside the beliefloc repository, the shipped schema); elsewhere at KIND.schema.json beside
    the file, which 'beliefloc schema KIND -o FILE' writes (init says so).

    With --occupancy MAP.yaml (a SLAM map as map_server saves it), the map is an overlay on it:
    the grid comes from the image, the cell size is the smallest of 0.05, 0.1, 0.15, 0.2, 0.25,
    0.3, 0.4, 0.5, 0.75, 1, 1.5, 2, 3, 5, 10 m that is at least two pixels and leaves at most
    10,000 cells (--cell-size overrides it); 8 headings, the four moves, a laser with --beams
    binned at 1, 2, 4 and 8 cells; the map's extent in map-frame metres in a comment, with
    commented examples of an object and a room there. It validates as written.

    Examples:

    \b
      beliefloc init map lab
      beliefloc init map arena --occupancy maps/occupancy/tb3_sandbox.yaml
      beliefloc init domain office -o office-domain.yaml
    """
    if kind not in KINDS:
        raise UsageError(f"unknown kind {kind!r}: 'beliefloc init map NAME' or 'beliefloc init domain NAME'")
    if occupancy is None and (cell_size is not None or robot_radius != 0.15 or beams != "90,0,-90"):
        raise UsageError("--cell-size, --robot-radius and --beams go with --occupancy MAP.yaml")
    if occupancy is not None and kind != "map":
        raise UsageError("--occupancy makes a map: 'beliefloc init map NAME --occupancy MAP.yaml'")
    beam_angles = _beams(beams) if occupancy is not None else []
    if not _NAME.match(name):
        hint = f"; the file is NAME.yaml, so write {Path(name).stem!r}" if name.endswith((".yaml", ".yml")) else ""
        raise UsageError(f"NAME {name!r}: use letters, digits, _ and - (at most 64){hint}")
    target = output if output is not None else Path(f"{name}.yaml")
    option = "-o" if output is not None else "NAME"
    check_output(option, target, (".yaml", ".yml"))
    if target.exists() or target.is_symlink():
        raise UsageError(f"{option} {target}: already exists; init never overwrites a file: name another one")
    pointer, found = _schema_pointer(kind, target) if schema is None else (schema, True)
    if occupancy is None:
        text = _render(kind, name, target, pointer)
    else:
        text = _render_overlay(name, target, pointer, occupancy, cell_size, robot_radius, beam_angles)
    summary = _write_new(target, text, kind)
    check = "beliefloc validate" if kind == "map" else "beliefloc kb check"
    typer.echo(f"wrote {target}{summary} (check it with: {check} {shlex.quote(str(target))})")
    if not found:
        warn(
            f"{target}: its first line points the editor at {pointer}, beside it; write that file with: "
            f"beliefloc schema {kind} -o {shlex.quote(str(target.parent / pointer))}"
        )


def register(app: typer.Typer) -> None:
    app.command("init")(init_command)


def _schema_pointer(kind: str, target: Path) -> tuple[str, bool]:
    """The ``$schema`` of a new file at ``target``, relative to its folder, and whether that file exists."""
    folder = target.parent.resolve()
    wanted = f"{kind}.schema.json"
    for place in (folder, *folder.parents):
        candidate = place / SCHEMAS_FOLDER / wanted
        if candidate.is_file():
            return Path(os.path.relpath(candidate, folder)).as_posix(), True
    return wanted, False


def _render(kind: str, name: str, target: Path, pointer: str) -> str:
    import yaml

    template = resources.files("beliefloc").joinpath("templates", f"{kind}.yaml").read_text(encoding="utf-8")
    scalar = yaml.safe_dump(name, default_flow_style=True).splitlines()[0]  # '123', 'null': quoted
    return template.replace("@SCHEMA@", pointer).replace("@FILE@", shlex.quote(str(target))).replace("@NAME@", scalar)


def _beams(text: str) -> list[float]:
    """``--beams 90,0,-90`` -> [90.0, 0.0, -90.0]: degrees, multiples of 45 (8 headings), each once."""
    values = []
    for part in text.split(","):
        try:
            value = float(part)
        except ValueError:
            value = math.nan
        if not math.isfinite(value) or value % 45 != 0 or abs(value) >= 360:
            raise UsageError(
                f"--beams {text!r}: give degrees counter-clockwise from the heading, multiples of 45 between "
                "-315 and 315, separated by commas, e.g. 90,0,-90 (left, ahead, right)"
            )
        values.append(value + 0.0)
    if len({v % 360 for v in values}) != len(values):
        raise UsageError(f"--beams {text!r}: two beams point the same way")
    return values


def _render_overlay(
    name: str,
    target: Path,
    pointer: str,
    occupancy_path: Path,
    cell_size: float | None,
    robot_radius: float,
    beams: list[float],
) -> str:
    """The overlay template filled in from the occupancy map (read as every command reads it)."""
    import yaml

    from beliefloc.semantic_map.angles import shown
    from beliefloc.semantic_map.occupancy_grid import grid_shape
    from beliefloc.semantic_map.occupancy_map import load_occupancy
    from beliefloc.semantic_map.occupancy_section import map_corners, map_extent
    from beliefloc.semantic_map.overlay import align_comments, free_spot, overlay_cell_size, scan_bins

    occupancy = load_occupancy(occupancy_path)
    size = (
        cell_size
        if cell_size is not None
        else overlay_cell_size(occupancy.width, occupancy.height, occupancy.resolution)
    )
    rows, cols = grid_shape(occupancy.height, occupancy.width, occupancy.resolution, size)
    width, height = occupancy.size_m
    corners = map_corners(occupancy)
    spot = free_spot(occupancy)
    cx, cy = spot if spot is not None else (sum(x for x, _ in corners) / 4, sum(y for _, y in corners) / 4)
    side = 2 * size  # a square of 4 x 4 cells around the free spot
    room = [(cx + dx * side, cy + dy * side) for dx, dy in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    where, folder = occupancy_path.resolve(), target.parent.resolve()
    shared = os.path.commonpath([where, folder]) != where.anchor  # else an absolute path reads better
    relative = Path(os.path.relpath(where, folder)).as_posix() if shared else where.as_posix()

    def flow(values: list[float]) -> str:
        return "[" + ", ".join(shown(v) for v in values) + "]"

    scalar = yaml.safe_dump(name, default_flow_style=True).splitlines()[0]
    fields = {
        "@SCHEMA@": pointer,
        "@NAME_STEM@": shlex.quote(target.stem),
        "@FILE@": shlex.quote(str(target)),
        "@NAME@": scalar,
        "@OCCUPANCY_NAME@": occupancy_path.name,
        "@OCCUPANCY@": yaml.safe_dump(relative, default_flow_style=True).splitlines()[0],
        "@PIXELS@": f"{occupancy.width} x {occupancy.height}",
        "@RESOLUTION@": f"{occupancy.resolution:g}",
        "@WIDTH@": f"{width:.6g}",
        "@HEIGHT@": f"{height:.6g}",
        "@EXTENT@": map_extent(occupancy),
        "@CELL_SIZE@": shown(size),
        "@CELLS@": f"{rows} x {cols}",
        "@RADIUS@": shown(robot_radius),
        "@BEAMS@": flow(beams),
        "@BINS@": flow(scan_bins(size)),
        "@EXAMPLE_X@": f"{cx:.2f}",
        "@EXAMPLE_Y@": f"{cy:.2f}",
        "@EXAMPLE_ROOM@": "[" + ", ".join(f"[{x:.2f}, {y:.2f}]" for x, y in room) + "]",
    }
    template = resources.files("beliefloc").joinpath("templates", "overlay.yaml").read_text(encoding="utf-8")
    for key, value in fields.items():
        template = template.replace(key, value)
    return align_comments(template)


def _write_new(target: Path, text: str, kind: str) -> str:
    """Write ``text`` to ``target`` all at once: through a temporary file beside it, checked with the
    real loader, then linked into place -- which fails, rather than overwrite, if the file appeared.
    Returns what the check found, for the message (a map's states)."""
    from beliefloc.errors import OutputError
    from beliefloc.source.atomic_write import usual_file_mode

    try:
        fd, temporary = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    except OSError as exc:
        raise OutputError(f"{target}: cannot be written ({exc.strerror or exc}); nothing was written") from None
    staged = Path(temporary)
    try:
        try:
            os.chmod(temporary, usual_file_mode())
            with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as handle:
                handle.write(text)
        except OSError as exc:  # a full disk: the temporary is removed below, the target never made
            raise OutputError(f"{target}: cannot be written ({exc.strerror or exc}); nothing was written") from None
        summary = _check(staged, kind)
        try:
            os.link(staged, target)
        except FileExistsError:
            raise UsageError(f"{target}: already exists; init never overwrites a file: name another one") from None
        except OSError:  # a file system without hard links: create exclusively
            _create_exclusively(target, text)
    finally:
        with contextlib.suppress(FileNotFoundError):
            staged.unlink()
    return summary


def _create_exclusively(target: Path, text: str) -> None:
    """``text`` written to a new file ``target``; on a full disk the part written is removed."""
    from beliefloc.errors import OutputError

    try:
        handle = open(target, "x", encoding="utf-8", newline="\n")  # noqa: SIM115 - removed on failure below
    except FileExistsError:
        raise UsageError(f"{target}: already exists; init never overwrites a file: name another one") from None
    except OSError as exc:
        raise OutputError(f"{target}: cannot be written ({exc.strerror or exc}); nothing was written") from None
    try:
        with handle:
            handle.write(text)
    except OSError as exc:
        target.unlink(missing_ok=True)
        raise OutputError(f"{target}: cannot be written ({exc.strerror or exc}); nothing was written") from None


def _check(path: Path, kind: str) -> str:
    """The starting file validates with the loader every command uses (else the template is broken,
    or the occupancy map leaves no state)."""
    if kind == "map":
        from beliefloc.semantic_map import load_map

        smap = load_map(path)
        g = smap.grid
        states = int(smap.free.sum()) * g.headings
        return f": a {g.rows} x {g.cols} grid of {g.cell_size:g} m cells, {states:,} states"
    from beliefloc.knowledge import load_domain

    load_domain(path)
    return ""
