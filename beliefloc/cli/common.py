"""What every command shares: the one error boundary, messages, the start belief, JSON.

Imported when the command line is built, so it imports nothing numeric at module level: each
function imports what it computes with when it runs.
"""

from __future__ import annotations

import contextlib
import functools
import gc
import importlib.abc
import importlib.machinery
import json
import sys
from collections.abc import Callable, Iterator, Sequence
from importlib.machinery import ModuleSpec
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any, ParamSpec, TypeVar

import typer
from rich.markup import escape

from beliefloc.errors import EXIT_NEGATIVE, BeliefLocError, InvalidValueError, UsageError
from beliefloc.render import stderr_console

if TYPE_CHECKING:
    import numpy as np

    from beliefloc.files.results_file import ResultsContent
    from beliefloc.model import GridLayout, Model
    from beliefloc.pose import PoseEstimate
    from beliefloc.semantic_map import SemanticMap

P = ParamSpec("P")
R = TypeVar("R")


_SCIPY_NUMPY_CLONE = "scipy._lib.array_api_compat.numpy"
_NUMPY_UNUSED = ("f2py", "testing", "ma", "polynomial", "char", "rec", "ctypeslib")
"""NumPy's lazily loaded submodules that no command uses, left out of SciPy's copy of NumPy's namespace."""


class _LeanNumpyClone(importlib.abc.MetaPathFinder):
    """SciPy's array-API layer (``scipy._lib.array_api_compat.numpy``, loaded by every ``import
    scipy.sparse``) copies NumPy's namespace with ``from numpy import *`` and ``getattr`` over
    ``dir(numpy)``; both name NumPy's lazily loaded submodules, so it imports ``numpy.f2py``,
    ``numpy.testing``, ``numpy.ma``, ``numpy.polynomial`` and others that no command uses: 55 ms of the
    0.1 s that ``import scipy.sparse`` takes, 5 % of a 10^6-state ``plan --json``. While that one module
    runs, NumPy's ``__all__`` and ``__dir__`` leave out :data:`_NUMPY_UNUSED` (those not imported
    already); both are put back when it ends, raised or not. SciPy's copy then lacks those names (its
    own code asks for ``xp.testing`` only of CuPy and PyTorch); ``numpy.f2py`` and the others still
    import as ever when asked for. Installed by the command line only (:func:`lean_scipy_import`), once:
    a program that imports beliefloc gets SciPy as it is."""

    def find_spec(
        self, fullname: str, path: Sequence[str] | None, target: ModuleType | None = None
    ) -> ModuleSpec | None:
        if fullname != _SCIPY_NUMPY_CLONE:
            return None
        with contextlib.suppress(ValueError):
            sys.meta_path.remove(self)
        spec = importlib.machinery.PathFinder.find_spec(fullname, path, target)
        loader = None if spec is None else spec.loader
        if loader is None or not hasattr(loader, "exec_module"):
            return spec
        run = loader.exec_module

        def exec_module(module: ModuleType) -> None:
            import numpy

            names = getattr(numpy, "__all__", None)
            listing = numpy.__dict__.get("__dir__")
            if not isinstance(names, list) or not callable(listing):
                return run(module)  # a NumPy laid out otherwise: as it is
            left_out = {name for name in _NUMPY_UNUSED if f"numpy.{name}" not in sys.modules}
            numpy.__all__ = [name for name in names if name not in left_out]
            numpy.__dict__["__dir__"] = lambda: [name for name in listing() if name not in left_out]
            try:
                run(module)
            finally:
                numpy.__all__ = names
                numpy.__dict__["__dir__"] = listing

        loader.exec_module = exec_module  # type: ignore[method-assign]
        return spec


def lean_scipy_import() -> None:
    """Import SciPy, when a command first needs it, without the NumPy submodules it would load for
    nothing (:class:`_LeanNumpyClone`). Does nothing once SciPy's array-API layer is loaded."""
    if _SCIPY_NUMPY_CLONE not in sys.modules and not any(isinstance(f, _LeanNumpyClone) for f in sys.meta_path):
        sys.meta_path.insert(0, _LeanNumpyClone())


def boundary(command: Callable[P, R]) -> Callable[P, R]:
    """The CLI's one error boundary: a :class:`BeliefLocError` becomes a message on stderr and its
    exit code, and so do the failures that come from outside rather than from a bug (an output
    stream that cannot be written, a number too large, rich refusing markup; see
    :func:`outside_failure`); anything else is a bug and keeps its traceback."""

    @functools.wraps(command)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        try:
            result = command(*args, **kwargs)
            sys.stdout.flush()  # a full stdout is found here, not at exit where Python hides it
            return result
        except BeliefLocError as exc:
            report_error(exc)
            raise typer.Exit(exc.exit_code) from None
        except Exception as exc:
            fail_outside(exc)
            raise
        finally:
            gc.unfreeze()  # what open_model froze is the collector's again once the command is done

    return wrapper


def fail_outside(exc: Exception) -> None:
    """For an exception that input or the surroundings caused (:func:`outside_failure`): report it
    in one paragraph and raise ``typer.Exit(2)``; return for a bug, which the caller re-raises."""
    message = outside_failure(exc)
    if message is None:
        return
    _silence_stdout()
    report_error(UsageError(message))
    raise typer.Exit(UsageError.exit_code) from None


_STREAM_ERRNOS = frozenset({"ENOSPC", "EPIPE", "EIO", "EDQUOT", "EFBIG"})
"""Why writing stdout or stderr fails when the fault is where they lead (``> /dev/full``, a closed
pipe, a full disk), never in beliefloc."""


def outside_failure(exc: BaseException) -> str | None:
    """The one-paragraph message for an exception that input or the surroundings caused, or None
    for a bug (which keeps its traceback).

    - an :class:`OSError` while writing the output streams (stdout into ``/dev/full``);
    - an :class:`OverflowError`: a number from outside too large for a float or a C integer;
    - Python's limit on the digits of an integer (``int()`` of a 5,000-digit string);
    - rich's markup and rendering errors: a string from a file that rich would not print.
    """
    import errno as errno_names

    if isinstance(exc, OSError) and not isinstance(exc, FileNotFoundError):
        name = errno_names.errorcode.get(exc.errno or 0, "")
        if name in _STREAM_ERRNOS and _raised_writing_streams(exc):
            return f"cannot write the output: {exc.strerror or name} (is the disk or the pipe full or closed?)"
        return None
    if isinstance(exc, OverflowError):
        return f"a number is too large to be used here ({exc}); give a smaller value"
    if isinstance(exc, ValueError) and "limit" in str(exc) and "integer string conversion" in str(exc):
        return "a number has more digits than any count or size beliefloc accepts; give a smaller value"
    from rich.errors import MarkupError, NotRenderableError

    if isinstance(exc, (MarkupError, NotRenderableError)):
        return f"a value read from a file could not be printed ({exc}); check the file's text fields"
    return None


def _raised_writing_streams(exc: OSError) -> bool:
    """Whether ``exc`` came from writing stdout/stderr rather than a file: beliefloc writes its
    files through :mod:`beliefloc.source.atomic_write` (an :class:`OutputError`), and an error on a
    named file carries its name; a write to a standard stream carries none."""
    return exc.filename is None and exc.filename2 is None


def _silence_stdout() -> None:
    """After stdout failed, point it at /dev/null so Python's exit does not fail flushing it again."""
    import os

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):
        pass


@contextlib.contextmanager
def for_option(option: str) -> Iterator[None]:
    """The library speaks of values; the command line names the option the value came from:
    an :class:`InvalidValueError` raised inside becomes a :class:`UsageError` that starts with
    ``option``."""
    try:
        yield
    except InvalidValueError as exc:
        raise UsageError(f"{option}: {exc}") from None


def target_option(target: str | None) -> str:
    """How an error about ``--target`` names it: ``--target 'x'``, or ``--target`` when the domain's
    own target was used."""
    return "--target" if target is None else f"--target {target!r}"


def report_error(exc: BeliefLocError) -> None:
    stderr_console().print(
        f"[bold red]error:[/] {escape(escape_controls(str(exc)))}", soft_wrap=True
    )  # one line per error


def warn(message: str) -> None:
    stderr_console().print(f"[yellow]warning:[/] {escape(escape_controls(message))}", soft_wrap=True)


PRIOR_PREFIX = "prior:"


def initial_belief(model: Model, spec: str, smap: SemanticMap | None = None) -> np.ndarray:
    """``--belief``: ``uniform``, a YAML/JSON file ``{state: probability}``, or ``prior:DOMAIN``.

    ``prior:DOMAIN`` is the robot's room prior from the domain's knowledge base spread over the
    rooms of ``model``'s map (``smap``, else the map the model was compiled from, see
    :func:`source_map`): see :func:`beliefloc.knowledge.robot_start_belief`.
    """
    from beliefloc.belief import uniform
    from beliefloc.files.belief_file import load_belief

    if spec == "uniform":
        return uniform(model.n_states)
    if spec.startswith(PRIOR_PREFIX):
        from beliefloc.knowledge import load_domain, robot_start_belief

        if not spec.removeprefix(PRIOR_PREFIX).strip():
            raise UsageError(f"--belief {spec}: names no domain; write prior:DOMAIN, e.g. prior:domains/apartment.yaml")
        domain_file = Path(spec.removeprefix(PRIOR_PREFIX))
        domain = load_domain(domain_file)
        with for_option(f"--belief {PRIOR_PREFIX}{domain_file}"):
            start = robot_start_belief(model, domain, smap)
        for message in start.warnings:
            warn(message)
        return start.belief
    belief, warnings = load_belief(model, Path(spec))
    for message in warnings:
        warn(message)
    return belief


def initial_belief_and_pose(model: Model, spec: str) -> tuple[np.ndarray, PoseEstimate | None]:
    """``--belief`` as :func:`initial_belief` reads it, and the pose a ``localize --belief-out`` run
    wrote beside a belief file (the pose lattice's estimate,
    :func:`beliefloc.files.belief_file.load_belief_and_pose`), checked against the model and the
    belief, both from one reading of the file; None for ``uniform``, ``prior:DOMAIN`` and a file without one."""
    from beliefloc.files.belief_file import load_belief_and_pose

    if spec == "uniform" or spec.startswith(PRIOR_PREFIX):
        return initial_belief(model, spec), None
    belief, warnings, pose = load_belief_and_pose(model, Path(spec))
    for message in warnings:
        warn(message)
    return belief, pose


def open_model(path: Path) -> Model:
    """A map, model or .pomdp file (:func:`beliefloc.files.model_sources.open_model`), with what reading
    the map has to say (an occupancy map's unknown grey, say) printed as warnings."""
    from beliefloc.files.model_sources import open_model as open_any
    from beliefloc.source.located import gc_paused

    # A map and its model are hundreds of thousands of small objects that live as long as the command
    # (a 10^6-state map: 300,000): built without the cyclic collector, then frozen out of its reach
    # (reference counting still frees them), instead of being walked by each of its later passes --
    # 0.5 s of CPU in `plan` of a 10^6-state map. The command's boundary unfreezes them.
    with gc_paused():
        model = open_any(path, on_warning=warn)
        gc.freeze()
    return model


def check_output(
    option: str, path: Path, suffixes: tuple[str, ...], inputs: tuple[Path, ...] = (), kind: str | None = None
) -> None:
    """An output file a command is about to write, checked before any work so that nothing is half
    done: a known suffix, an existing folder that can be written in, not a folder, not one of the
    command's ``inputs`` (a hard link to one counts), and not an existing file of another kind.

    ``kind`` (a noun phrase of :mod:`beliefloc.source.file_kinds`: ``MODEL``, ``MACROS``, ``MAP``...) is
    what the command writes: an existing file of that kind is replaced, any other refused (an empty
    file is always replaced). Without ``kind``, the suffix says what is written, and an existing
    file that is recognisably something else -- a map, a domain, a belief file, a model -- is refused."""
    import os

    from beliefloc.source.file_kinds import kind_of_path, not_a

    if path.suffix.lower() not in suffixes:
        raise UsageError(f"{option} {path}: unknown kind of file; expected one of: {', '.join(suffixes)}")
    folder = path.parent
    if not folder.is_dir():
        raise UsageError(f"{option} {path}: the folder {folder} does not exist")
    if path.is_dir():
        raise UsageError(f"{option} {path}: is a folder; name a file in it")
    resolved = path.resolve()
    for source in inputs:
        same = resolved == source.resolve()
        if not same and path.exists() and source.exists():
            try:
                same = os.path.samefile(path, source)
            except OSError:
                same = False
        if same:
            raise UsageError(f"{option} {path}: is an input of the command; name another file")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise UsageError(f"{option} {path}: cannot write in the folder {folder} (permission denied)")
    if not (path.exists() or path.is_symlink()):
        return
    if not path.is_file():
        raise UsageError(f"{option} {path}: exists and is not a regular file; name another file")
    if not os.access(path, os.W_OK):
        raise UsageError(f"{option} {path}: the file is read-only; name another file, or make it writable")
    if path.stat().st_size == 0:
        return
    found = existing_kind(path)
    if kind is not None and found != kind:
        what = not_a(path, found, kind) if found is not None else f"the file exists and is not {kind}"
        raise UsageError(f"{option} {path}: {what}; name another file (or remove it first)")
    if kind is None and found is not None and found != kind_of_path(path):
        raise UsageError(f"{option} {path}: {path} is {found}; name another file (or remove it first)")


def existing_kind(path: Path) -> str | None:
    """What an existing file is, as a noun phrase of :mod:`beliefloc.source.file_kinds`: a ``.npz`` file by
    its header (a model, a macro table, or an archive beliefloc did not write), a YAML or JSON file
    by its content (a map, a domain, a belief file...), anything else by its suffix; None when it
    cannot be told (an unreadable or unrecognisable YAML file, an unknown suffix)."""
    from beliefloc.errors import InputFileError
    from beliefloc.source import file_kinds

    by_suffix = file_kinds.kind_of_path(path)
    if by_suffix == file_kinds.MODEL_OR_MACROS:
        from beliefloc.files.npz_archive import file_format

        found = file_kinds.kind_of_data({"format": file_format(path)})
        return found if found is not None else "an .npz archive that beliefloc did not write"
    if by_suffix is not None:
        return by_suffix
    if path.suffix.lower() not in (".yaml", ".yml", ".json"):
        return None
    from beliefloc.source import read_source

    try:
        data = read_source(path, InputFileError).data
    except BeliefLocError:
        return None
    return file_kinds.kind_of_data(data)


def positive_int(option: str, text: str) -> int:
    """A count given on the command line (a frame limit, say): a UsageError unless a positive integer."""
    from beliefloc.source.limits import LARGEST_COUNT, read_count

    try:
        return read_count(text, option, lowest=1)
    except ValueError as exc:
        shown = text if len(text) <= 40 else f"({len(text):,} characters)"
        too_large = "out of range" in str(exc) and text.strip() not in ("0", "")
        most = f" of at most {LARGEST_COUNT:,}" if too_large else ""
        raise UsageError(f"{option} {shown}: must be a positive integer{most}") from None


def check_record(option: str, path: Path, inputs: tuple[Path, ...] = ()) -> bool:
    """An animation a command is about to write, checked before any work: True for an animated GIF,
    False for a folder of PNG frames (created, or one holding nothing but frames). A UsageError when
    it cannot be written: an input of the command, an unknown suffix, a missing parent folder or one
    that cannot be written in (the frames are made beside the folder, then renamed into place), a
    file where frames go, a folder holding other files."""
    import os

    from beliefloc.render.picture_episode import holds_only_frames
    from beliefloc.source.file_kinds import IMAGE

    if any(path.resolve() == source.resolve() for source in inputs):
        raise UsageError(f"{option} {path}: is an input of the command; name another file")
    if path.suffix.lower() == ".gif":
        check_output(option, path, (".gif",), inputs, IMAGE)
        return True
    if path.is_dir():
        if not holds_only_frames(path):
            raise UsageError(f"{option} {path}: the folder holds other files than frames; name a new folder")
    elif path.suffix:
        raise UsageError(f"{option} {path}: unknown kind of file; expected FILE.gif, or a folder DIR for PNG frames")
    elif path.exists() or path.is_symlink():
        raise UsageError(f"{option} {path}: is a file; name a folder for the frames, or FILE.gif")
    folder = path.parent
    if not folder.is_dir():
        raise UsageError(f"{option} {path}: the folder {folder} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK) or (path.is_dir() and not os.access(path, os.W_OK | os.X_OK)):
        raise UsageError(f"{option} {path}: cannot write the frames there (permission denied)")
    return False


MCAP_MAGIC = b"\x89MCAP0\r\n"
"""The first bytes of an MCAP file (an existing one is replaced, anything else refused)."""


def check_ros_recording(option: str, path: Path, inputs: tuple[Path, ...] = (), *, folder: bool = True) -> None:
    """A ROS recording a command is about to write (:mod:`beliefloc.recordings.record`), checked before
    any work: ``OUT.mcap`` as :func:`check_output` checks a file (an existing MCAP file is replaced,
    anything else refused); any other ``OUT`` (when ``folder``) a rosbag2 folder, which must not
    exist yet (as ``ros2 bag record -o`` wants it). Neither may lie inside an input (a bag folder)."""
    import os

    from beliefloc.source.file_kinds import RECORDING

    resolved = path.resolve()
    for source in inputs:
        if source.is_dir() and resolved.is_relative_to(source.resolve()):
            raise UsageError(f"{option} {path}: is inside {source}, an input of the command; name another place")
    if path.suffix.lower() == ".mcap":
        check_output(option, path, (".mcap",), inputs, RECORDING)
        if path.is_file() and path.stat().st_size > 0:
            with path.open("rb") as handle:
                if handle.read(len(MCAP_MAGIC)) != MCAP_MAGIC:
                    raise UsageError(f"{option} {path}: the file exists and is not an MCAP file; name another file")
        return
    if not folder:
        raise UsageError(f"{option} {path}: unknown kind of file; expected FILE.mcap")
    if path.exists() or path.is_symlink():
        raise UsageError(
            f"{option} {path}: exists; a rosbag2 folder is written new (remove it first), or name FILE.mcap"
        )
    parent = path.parent
    if not parent.is_dir():
        raise UsageError(f"{option} {path}: the folder {parent} does not exist")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise UsageError(f"{option} {path}: cannot write in the folder {parent} (permission denied)")


def belief_inputs(belief_spec: str) -> tuple[Path, ...]:
    """The files ``--belief`` reads (which ``-o`` must not overwrite)."""
    if belief_spec == "uniform":
        return ()
    return (Path(belief_spec.removeprefix(PRIOR_PREFIX)),)


def open_with_map(source: Path) -> tuple[Model, SemanticMap | None]:
    """The model, and the map it comes from when there is one (to draw its rooms and its occupancy
    image); None for a model without one, or whose map moved or changed."""
    from beliefloc.errors import BeliefLocError
    from beliefloc.files.model_sources import MAP_SUFFIXES, source_map

    if source.suffix.lower() in MAP_SUFFIXES:
        from beliefloc.semantic_map import compile_model, load_map

        smap = load_map(source, on_warning=warn)
        return compile_model(smap), smap
    model = open_model(source)
    if model.grid is None or model.source is None:
        return model, None
    try:
        return model, source_map(model)
    except BeliefLocError:  # the map moved or changed: draw the belief without it
        return model, None


def warn_if_too_wide(grid: GridLayout | None, compact: bool | None, width: int, color: bool) -> None:
    """A warning when even the chosen form of the belief grid is wider than the terminal."""
    from beliefloc.render.belief_grid import grid_width, resolve_compact

    if grid is None:
        return
    chosen = resolve_compact(grid, compact, width, color=color)
    needed = grid_width(grid, compact=chosen, color=color)
    if needed > width:
        hint = "" if chosen else "; --compact is narrower"
        warn(f"the grid is {needed} characters wide but the terminal has {width}: lines will wrap{hint}")


def print_json(data: Any) -> None:
    """Plain JSON on stdout, no decoration: the stable interface for scripts."""
    sys.stdout.write(json.dumps(data, indent=2, allow_nan=False) + "\n")


def refuse_unreachable(model: Model, start: np.ndarray, threshold: float, json_output: bool) -> None:
    """Before any search: exit 2 for a threshold no belief can reach, exit 1 with the look-alike states
    when the start belief can never be narrowed to one state (:mod:`beliefloc.planning.verdict`)."""
    from beliefloc.planning.verdict import unreachable_goal

    verdict = unreachable_goal(model, start, threshold)
    if verdict is None:
        return
    if not verdict.look_alikes:
        raise UsageError(f"--threshold {threshold:g}: no belief on {model.name} can reach it: {verdict.reason}")
    pairs = [(model.states.name(i), model.states.name(j)) for i, j in verdict.look_alikes]
    if json_output:
        print_json(
            {
                "found": False,
                "status": "not_localizable",
                "bound": verdict.bound,
                "reason": verdict.reason,
                "look_alikes": [list(pair) for pair in pairs],
            }
        )
    shown = "; ".join(f"{a} ~ {b}" for a, b in pairs[:_PAIRS_SHOWN])
    more = f"; … ({len(pairs)} pairs in all)" if len(pairs) > _PAIRS_SHOWN else ""
    stderr_console().print(
        escape(
            f"not localizable: no plan can take this start belief to {threshold:g}: {verdict.reason}. "
            f"Look-alike states: {shown}{more}."
        ),
        soft_wrap=True,
    )
    raise typer.Exit(EXIT_NEGATIVE)


_PAIRS_SHOWN = 6


# --- sweeps (simulate, search simulate) -------------------------------------------------------------


def check_sweep_options(
    workers: int, scheduler: str | None, out: Path | None, resume: bool, inputs: tuple[Path, ...]
) -> None:
    """``--workers``, ``--scheduler``, ``--out`` and ``--resume``, checked before any work: nothing is
    overwritten by a run that could not start. An existing ``--out`` file must be a results file
    (:mod:`beliefloc.files.results_file`): it is replaced, or continued with ``--resume``."""
    from beliefloc.errors import UsageError
    from beliefloc.files.results_file import SUFFIX, is_results_file

    if scheduler is not None and workers != 1:
        raise UsageError(f"--workers {workers} --scheduler {scheduler}: give one of them (the cluster has its own)")
    if scheduler is not None and not scheduler.strip():
        raise UsageError("--scheduler: names no address; write tcp://HOST:PORT")
    if out is None:
        if resume:
            raise UsageError("--resume: needs --out FILE.jsonl, the results file to continue")
        return
    check_output("--out", out, (SUFFIX,), inputs)
    if out.is_file() and out.stat().st_size > 0 and not is_results_file(out):
        raise UsageError(
            f"--out {out}: the file exists and is not a beliefloc results file; name another file (or remove it first)"
        )


def run_sweep(
    sweep: Any,
    *,
    workers: int,
    scheduler: str | None,
    out: Path | None,
    resume: bool,
    head: dict[str, Any],
    serial_start: Callable[[], Any] | None = None,
    progress: bool = True,
) -> list[dict[str, Any]]:
    """Every unit of ``sweep`` (:mod:`beliefloc.simulation.sweep`; ``head["total"]`` of them) on the backend of
    ``--workers`` and ``--scheduler``, their results in order. With ``--out``, a line per unit written
    as it ends, after the header -- or, with ``--resume``, after the units the file already holds,
    which are not run again (a file of other settings is refused first, naming what differs). A
    progress bar on stderr when it is a terminal. ``serial_start``: the runner of a run in this
    process (with per-step callbacks, say); ``progress`` False: no bar (the steps are drawn)."""
    from beliefloc.errors import OutputError, UsageError
    from beliefloc.files.results_file import ResultsWriter, differences, open_locked, read_results
    from beliefloc.render import stderr_console
    from beliefloc.render.sweep_progress import sweep_progress
    from beliefloc.simulation.sweep import backend, in_order

    total = int(head["total"])
    done: list[dict[str, Any]] = []
    found = None
    locked = None
    created = False
    if out is not None:
        created = not out.exists()
        locked = open_locked(out)  # before reading: a second sweep on the file is refused here
    try:
        if out is not None and resume and out.stat().st_size > 0:
            found = read_results(out)
            check_results(out, found)  # the whole file, before any unit is run or appended
            differ = differences(found.header, head)
            if differ:
                raise UsageError(f"--resume {out}: the file was written with other settings: {'; '.join(differ)}")
            done = list(found.results)
            if found.torn:
                warn(f"{out}: its last line was cut short; that {found.unit} is run again")
        indices = list(range(len(done), total))
        # a scheduler is reached now, or refused; a pool is no larger than the units or the cores allow
        runs_on = backend(workers, scheduler, start=serial_start, units=len(indices), on_note=warn)
    except BaseException:
        if locked is not None:
            locked.close()
            if created and out is not None:
                out.unlink(missing_ok=True)  # nothing half written is left behind
        raise
    writer = ResultsWriter(out, head, found, locked, created=created) if out is not None else None
    try:
        started = runs_on.run(sweep, indices) if indices else iter(())  # a pool starts before the bar's thread
        with sweep_progress(stderr_console(), f"{head['unit']}s", total, len(done), shown=progress) as advance:
            for _, result in in_order(_counting(started, advance), indices):
                done.append(result)
                if writer is not None:
                    writer.write(result)
        if writer is not None and not writer.still_there():
            raise OutputError(
                f"--out {out}: the results file was removed or replaced during the run; "
                f"the {len(done)} {head['unit']}s written to it are lost: run again with another --out"
            )
    finally:
        if writer is not None:
            writer.close()
        runs_on.close()
    return done


def check_results(path: Path, content: ResultsContent) -> None:
    """Every line of a results file read back as its command's records (``summarize``,
    ``--resume``): a :class:`ResultsFileError` naming the first line that is not one, before any work."""
    from beliefloc.files.results_file import ResultsFileError, check_lines

    command = content.header["command"]
    if command == "simulate":
        from beliefloc.simulation.episode import records_from_results

        check_lines(path, content, lambda line: records_from_results([line]))
    elif command == "search simulate":
        from beliefloc.object_search.experiment import TrialRecord

        check_lines(path, content, TrialRecord.from_json)
    else:
        raise ResultsFileError(
            f"{path}: written by '{escape_controls(str(command))[:60]}', which this beliefloc cannot read"
        )


def escape_controls(text: str) -> str:
    """``text`` with control characters written as escapes (``ESC[2J`` as ``\\x1b[2J``): what a
    file holds is shown, never obeyed by the terminal."""
    return "".join(c if c.isprintable() or c in "\n\t" else c.encode("unicode_escape").decode("ascii") for c in text)


def _counting(
    pairs: Iterator[tuple[int, dict[str, Any]]], advance: Callable[[], None]
) -> Iterator[tuple[int, dict[str, Any]]]:
    for pair in pairs:
        advance()
        yield pair
