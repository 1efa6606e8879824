"""Every command, every path option: a bad path is exit 2 with one message, and nothing is written.

The commands and their path options are read from the command line itself (click's parameters of
``typer.main.get_command(app)``), so a new command or option is covered as soon as it exists. An
output option is pointed at a missing folder, at a folder, into a read-only folder (not as root,
whom permissions do not stop), at the command's own input, and at an existing file of another kind;
an input at a missing folder, at a folder, and at a file it may not read (not as root either). Each
run must exit 2, print no traceback, and leave every file as it was (none created, none modified).

A command needs a valid invocation around the path under test: :data:`BASE` gives one per command
(a new command without one fails :func:`test_every_command_has_a_base_invocation`, naming it).
"""

from __future__ import annotations

import hashlib
import os
import shutil
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
import typer
from typer.testing import CliRunner

from beliefloc.cli.app import app
from tests.conftest import MAPS, ROOT


def _permissions_enforced() -> bool:
    """Whether a read-only folder stops this process: not for root (``os.geteuid() == 0``), unless
    it runs without the capability to override them (``setpriv --bounding-set=-all``)."""
    with tempfile.TemporaryDirectory() as folder:
        locked = Path(folder) / "locked"
        locked.mkdir(mode=0o555)
        try:
            (locked / "probe").touch()
        except PermissionError:
            return True
        finally:
            locked.chmod(0o755)
        return False


PERMISSIONS_ENFORCED = _permissions_enforced()


@dataclass(frozen=True)
class Param:
    """A path parameter of a command: its name, how it is written, and whether it is written to."""

    command: tuple[str, ...]
    name: str
    flag: str | None
    """The option's flag (``-o``), None for a positional argument."""
    output: bool
    metavar: str

    @property
    def label(self) -> str:
        return f"{' '.join(self.command)}:{self.flag or self.name}"


_OUTPUT_NAMES = {"output", "record", "recording", "belief_out"}
_OUTPUT_FLAGS = {"-o", "--output", "--record", "--belief-out"}
_FILE_WORDS = ("FILE", "DOMAIN", "MAP", "MODEL", "MACROS")
"""A string option whose metavar has one of these names a file (``--belief uniform|FILE|...``)."""


def _commands(command: Any, prefix: tuple[str, ...] = ()) -> Iterator[tuple[tuple[str, ...], Any]]:
    subcommands = getattr(command, "commands", None)
    if subcommands is None:
        yield prefix, command
        return
    for name, sub in sorted(subcommands.items()):
        yield from _commands(sub, (*prefix, name))


def _is_path(param: Any) -> bool:
    annotation = str(param.type_descriptor.annotation)
    if "Path" in annotation:
        return True
    metavar = param.metavar or ""
    return any(word in metavar.split("|") or word in metavar for word in _FILE_WORDS if "PATH" not in metavar)


COMMANDS = dict(_commands(typer.main.get_command(app)))
PARAMS = [
    Param(
        path,
        p.name,
        None if p.param_type_name == "argument" else p.opts[0],
        p.name in _OUTPUT_NAMES or bool(set(p.opts) & _OUTPUT_FLAGS),
        p.metavar or "",
    )
    for path, command in COMMANDS.items()
    for p in command.params
    if _is_path(p)
]

# --- the invocations ------------------------------------------------------------------------------

BASE: dict[tuple[str, ...], dict[str, Any]] = {
    ("validate",): {"args": {"maps": "{map}"}},
    ("build",): {"args": {"map_file": "{map}"}, "options": {"-o": "{tmp}/out.npz"}},
    ("inspect",): {"args": {"source": "{map}"}},
    ("track",): {"args": {"source": "{map}", "steps": "forward"}},
    ("show",): {"args": {"source": "{map}"}},
    ("pose",): {"args": {"source": "{map}"}},
    ("plan",): {"args": {"source": "{map}"}},
    ("simulate",): {"args": {"map_file": "{map}"}, "extra": ["-n", "1", "--max-steps", "3"]},
    ("localize",): {"args": {"map_file": "{map}"}, "extra": ["--threshold", "0.02"]},  # localized at once
    ("select",): {"args": {"source": "{map}"}},
    ("prior",): {"args": {"domain_file": "{domain}"}},
    ("export",): {"args": {"source": "{map}"}, "options": {"-o": "{tmp}/out.pomdp"}},
    ("init",): {"args": {"kind": "map", "name": "lab"}, "options": {"-o": "{tmp}/lab.yaml"}},
    ("schema",): {"args": {"kind": "map"}},
    ("summarize",): {"args": {"results_file": "{map}"}},
    ("macros", "build"): {"args": {"source": "{map}"}, "options": {"--output": "{tmp}/out-macros.npz"}},
    ("macros", "show"): {"args": {"macros": "{macros}"}},
    ("kb", "check"): {"args": {"domain_file": "{domain}"}},
    ("kb", "answer"): {"args": {"domain_file": "{domain}"}},
    ("search", "run"): {"args": {"domain_file": "{domain}"}},
    ("search", "simulate"): {"args": {"domain_file": "{domain}"}, "extra": ["--trials", "1"]},
    ("generate", "gridworld"): {"options": {"-o": "{tmp}/world.yaml"}, "extra": ["--states", "100", "--seed", "0"]},
}
"""A valid invocation of every command: its positional arguments by name, options, other words."""

OUTPUT_SUFFIX = {
    ("build", "output"): ".npz",
    ("export", "output"): ".pomdp",
    ("init", "output"): ".yaml",
    ("schema", "output"): ".json",
    ("macros", "build", "output"): ".npz",
    ("localize", "belief_out"): ".json",
    ("generate", "gridworld", "output"): ".yaml",
}
"""The suffix an output is written with, where its metavar does not say (``FILE.png|FILE.svg`` does)."""


def _suffix(param: Param) -> str:
    known = OUTPUT_SUFFIX.get((*param.command, param.name))
    if known is not None:
        return known
    for word in param.metavar.split("|"):
        if "." in word:
            return "." + word.rsplit(".", 1)[1].lower()
    return ".out"


@dataclass(frozen=True)
class Files:
    tmp: Path
    map: Path
    domain: Path
    macros: Path
    model: Path
    belief: Path

    def fill(self, text: str) -> str:
        return text.format(
            tmp=self.tmp, map=self.map, domain=self.domain, macros=self.macros, model=self.model, belief=self.belief
        )


@pytest.fixture
def files(tmp_path: Path, built: dict[str, bytes]) -> Files:
    """The inputs, copied into the test's own folder (a command that writes over its input must
    only ever hurt a copy), and the folders the cases point at."""
    inputs = tmp_path / "inputs"
    inputs.mkdir()
    shutil.copy(MAPS / "kitchen.yaml", inputs / "kitchen.yaml")
    shutil.copy(ROOT / "domains" / "home.yaml", inputs / "home.yaml")
    (inputs / "kitchen-macros.npz").write_bytes(built["macros"])
    (inputs / "kitchen.npz").write_bytes(built["model"])
    (inputs / "belief.json").write_text('{"0,0,0": 1.0}\n')
    return Files(
        tmp_path,
        inputs / "kitchen.yaml",
        inputs / "home.yaml",
        inputs / "kitchen-macros.npz",
        inputs / "kitchen.npz",
        inputs / "belief.json",
    )


@pytest.fixture(scope="module")
def built(tmp_path_factory: pytest.TempPathFactory) -> dict[str, bytes]:
    """A model and a macro table of the kitchen (the bytes: each test writes its own copy)."""
    from beliefloc import compile_model, load_map
    from beliefloc.files.macro_file import save_macros
    from beliefloc.files.model_file import save_model
    from beliefloc.planning.macros import build_macros

    folder = tmp_path_factory.mktemp("built")
    shutil.copy(MAPS / "kitchen.yaml", folder / "kitchen.yaml")
    model = compile_model(load_map(folder / "kitchen.yaml"))
    save_model(model, folder / "kitchen.npz")
    save_macros(build_macros(model), folder / "kitchen-macros.npz", model=model)
    return {"model": (folder / "kitchen.npz").read_bytes(), "macros": (folder / "kitchen-macros.npz").read_bytes()}


def _invocation(param: Param, value: str, files: Files) -> list[str]:
    base = BASE[param.command]
    command = COMMANDS[param.command]
    words = list(param.command)
    for p in command.params:
        if p.param_type_name != "argument":
            continue
        given = value if p.name == param.name else base.get("args", {}).get(p.name)
        if given is not None:
            words.append(files.fill(given))
    options = {flag: files.fill(v) for flag, v in base.get("options", {}).items()}
    if param.flag is not None:
        same = next(p for p in command.params if p.name == param.name)
        for flag in same.opts:
            options.pop(flag, None)
        options[param.flag] = value
    for flag, v in options.items():
        words += [flag, v]
    return words + [files.fill(w) for w in base.get("extra", [])]


def _main_input(param: Param, files: Files) -> Path | None:
    """The file the command reads first (its map, domain or macro table), or None."""
    args = BASE[param.command].get("args", {})
    for value in args.values():
        if value in ("{map}", "{domain}", "{macros}"):
            return Path(files.fill(value))
    return None


def _other_kind(param: Param, files: Files) -> Path | None:
    """An existing file with the output's suffix but of another kind than the command writes."""
    suffix = _suffix(param)
    if suffix == ".npz":
        return files.macros if param.command == ("build",) else files.model
    if suffix in (".yaml", ".yml"):
        return files.domain  # a domain, where a map is written
    if param.command == ("localize",):
        return files.domain  # a domain, where a belief file is written
    if suffix == ".json":
        return files.belief  # a belief file, where a schema is written
    return None


OUTPUT_CASES = ("missing-folder", "folder", "read-only", "proc", "input", "other-kind")
"""``proc``: a folder no process may create files in, root included (/proc): the write itself fails."""
INPUT_CASES = ("missing-folder", "folder", "unreadable")


def _value(param: Param, case: str, files: Files) -> str | None:
    """The path ``case`` points ``param`` at (making the folders it needs), None when the case does
    not apply."""
    tmp = files.tmp
    suffix = _suffix(param) if param.output else ".yaml"
    if case == "missing-folder":
        return str(tmp / "missing" / f"x{suffix}")
    if case == "folder":
        folder = tmp / f"folder{suffix}"
        folder.mkdir()
        (folder / "keep.txt").write_text("not to be touched\n")
        return str(folder)
    if case == "read-only":
        folder = tmp / "read-only"
        folder.mkdir()
        folder.chmod(0o555)
        return str(folder / f"x{suffix}")
    if case == "proc":
        return f"/proc/beliefloc-test-{os.getpid()}{suffix}" if Path("/proc").is_dir() else None
    if case == "unreadable":
        base = BASE[param.command].get("args", {}).get(param.name)
        original = Path(files.fill(base)) if base in ("{map}", "{domain}", "{macros}") else files.map
        unreadable = tmp / f"unreadable{original.suffix}"
        shutil.copy(original, unreadable)
        unreadable.chmod(0)
        return str(unreadable)
    if case == "input":
        found = _main_input(param, files)
        return None if found is None else str(found)
    if case == "other-kind":
        found = _other_kind(param, files)
        return None if found is None else str(found)
    raise AssertionError(case)


def _snapshot(root: Path) -> dict[str, tuple[Any, ...]]:
    """Every file and folder under ``root``: its kind, size, mode and content hash."""
    seen: dict[str, tuple[Any, ...]] = {}
    for path in sorted(root.rglob("*")):
        info = path.lstat()
        if path.is_file():
            seen[str(path.relative_to(root))] = ("file", info.st_size, info.st_mtime_ns, _sha(path))
        else:
            seen[str(path.relative_to(root))] = ("dir", info.st_mode)
    return seen


def _sha(path: Path) -> str | None:
    try:
        return hashlib.sha256(path.read_bytes()).hexdigest()
    except PermissionError:  # the unreadable input: its size and time tell it is untouched
        return None


KNOWN_FAILURES: dict[tuple[str, str], str] = {}
"""(param label, case) -> why it fails today: a command whose CLI file does not check its path yet.
Strict xfails: fixing the command turns them into failures, so the entry is removed then."""


def _cases() -> Iterator[Any]:
    for param in PARAMS:
        for case in OUTPUT_CASES if param.output else INPUT_CASES:
            marks = []
            if case in ("read-only", "unreadable") and not PERMISSIONS_ENFORCED:
                marks.append(pytest.mark.skip(reason="root ignores permissions (os.geteuid() == 0)"))
            reason = KNOWN_FAILURES.get((param.label, case))
            if reason is not None:
                marks.append(pytest.mark.xfail(strict=True, reason=reason))
            yield pytest.param(param, case, id=f"{param.label}:{case}", marks=marks)


def test_every_command_has_a_base_invocation() -> None:
    missing = sorted(" ".join(path) for path in COMMANDS if path not in BASE)
    assert not missing, f"add a valid invocation of {', '.join(missing)} to BASE"
    outputs = sorted(p.label for p in PARAMS if p.output)
    assert "build:-o" in outputs and "macros build:--output" in outputs and "simulate:--record" in outputs


@pytest.mark.slow
@pytest.mark.parametrize(("param", "case"), list(_cases()))
def test_bad_path_is_refused_and_nothing_is_written(param: Param, case: str, files: Files) -> None:
    value = _value(param, case, files)
    if value is None:
        pytest.skip(f"{case} does not apply to {param.label}")
    words = _invocation(param, value, files)
    before = _snapshot(files.tmp)
    try:
        result = CliRunner().invoke(app, words, input="")
        after = _snapshot(files.tmp)
    finally:
        for folder in files.tmp.rglob("*"):
            folder.chmod(0o755 if folder.is_dir() else 0o644)  # so that pytest can remove them
    output = result.output + result.stderr
    shown = f"beliefloc {' '.join(words)}: exit {result.exit_code}\n{output}"
    assert "Traceback" not in output, shown
    assert result.exception is None or isinstance(result.exception, SystemExit), f"{shown}\n{result.exception!r}"
    assert result.exit_code == 2, shown
    assert after == before, f"{shown}\nchanged files: {sorted(set(after.items()) ^ set(before.items()))}"
