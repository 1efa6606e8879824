"""``init``: a commented starting map or domain that validates, to copy from rather than write from scratch."""

from __future__ import annotations

import contextlib
import os
import re
import shlex
import tempfile
from importlib import resources
from pathlib import Path
from typing import Annotated

import typer

from beliefloc.cli.common import boundary, check_output, warn
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

    Examples:

    \b
      beliefloc init map lab
      beliefloc init domain office -o office-domain.yaml
    """
    if kind not in KINDS:
        raise UsageError(f"unknown kind {kind!r}: 'beliefloc init map NAME' or 'beliefloc init domain NAME'")
    if not _NAME.match(name):
        hint = f"; the file is NAME.yaml, so write {Path(name).stem!r}" if name.endswith((".yaml", ".yml")) else ""
        raise UsageError(f"NAME {name!r}: use letters, digits, _ and - (at most 64){hint}")
    target = output if output is not None else Path(f"{name}.yaml")
    option = "-o" if output is not None else "NAME"
    check_output(option, target, (".yaml", ".yml"))
    if target.exists() or target.is_symlink():
        raise UsageError(f"{option} {target}: already exists; init never overwrites a file: name another one")
    pointer, found = _schema_pointer(kind, target) if schema is None else (schema, True)
    text = _render(kind, name, target, pointer)
    _write_new(target, text, kind)
    check = "beliefloc validate" if kind == "map" else "beliefloc kb check"
    typer.echo(f"wrote {target} (check it with: {check} {shlex.quote(str(target))})")
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


def _write_new(target: Path, text: str, kind: str) -> None:
    """Write ``text`` to ``target`` all at once: through a temporary file beside it, checked with the
    real loader, then linked into place -- which fails, rather than overwrite, if the file appeared."""
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
        _check(staged, kind)
        try:
            os.link(staged, target)
        except FileExistsError:
            raise UsageError(f"{target}: already exists; init never overwrites a file: name another one") from None
        except OSError:  # a file system without hard links: create exclusively
            _create_exclusively(target, text)
    finally:
        with contextlib.suppress(FileNotFoundError):
            staged.unlink()


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


def _check(path: Path, kind: str) -> None:
    """The starting file validates with the loader every command uses (else the template is broken)."""
    if kind == "map":
        from beliefloc.semantic_map import load_map

        load_map(path)
    else:
        from beliefloc.knowledge import load_domain

        load_domain(path)
