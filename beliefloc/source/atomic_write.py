"""Writing a file whole or not at all: through a temporary file beside it, renamed into place.

A failed write (a full disk, a folder no one may write in) is an :class:`~beliefloc.errors.OutputError`
naming the path and the reason, and leaves nothing behind; so does Ctrl-C, and SIGTERM or SIGHUP
remove the temporary before the signal ends the process. Temporaries left by a killed process
(SIGKILL) are swept at the next write of the same output. Models, macro tables, pictures, maps,
schemas and belief files go through :func:`write_atomically`; a folder of frames
(:func:`beliefloc.render.picture_episode.save_frames`) and ``init``, which must never replace a
file, have whole-or-nothing writes of their own; a results file (:mod:`beliefloc.files.results_file`) grows
a line at a time, by design, so that a killed sweep keeps what it finished.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import signal
import stat
import tempfile
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from types import FrameType
from typing import Any

from beliefloc.errors import OutputError

STALE_TEMPORARY_SECONDS = 3600
"""A temporary of an output older than this is left over from a killed write: the next write of the
same output removes it."""

_TEMPORARY_MIDDLE = re.compile(r"[a-z0-9_]{8}\Z")
"""What :func:`tempfile.mkstemp` puts between our prefix and suffix."""
_SIGNALS = tuple(getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name))
"""Signals that end the process during a write; the temporary is removed before it ends."""


def write_atomically(path: Path, write: Any, *, binary: bool = True) -> None:
    """Call ``write(file)`` on a temporary file beside ``path`` and rename it into place.

    On failure, Ctrl-C or SIGTERM the temporary file is removed (then the signal ends the process as
    it would have); temporaries of ``path`` left over from a killed process, older than
    :data:`STALE_TEMPORARY_SECONDS`, are removed first."""
    path = Path(path)
    directory = path.parent if str(path.parent) else Path(".")
    sweep_stale_temporaries(path)
    with _removed_on_signal() as temporaries:
        try:
            fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=directory)
        except OSError as exc:
            raise _cannot_write(path, exc) from None
        temporary = Path(tmp)
        temporaries.append(temporary)
        try:
            with os.fdopen(fd, "wb" if binary else "w") as handle:
                os.fchmod(handle.fileno(), usual_file_mode())  # as open() would create it, not mkstemp's 0600
                write(handle)
            os.replace(temporary, path)
        except OSError as exc:
            temporary.unlink(missing_ok=True)
            raise _cannot_write(path, exc) from None
        except BaseException:
            temporary.unlink(missing_ok=True)
            raise


@contextlib.contextmanager
def staging_folder(path: Path) -> Iterator[Path]:
    """A new empty folder beside output ``path`` (``.NAME.XXXXXXXX.tmp``) in which to build an output
    made of several files -- a rosbag2 folder, a file a library writes by name --, for the caller to
    rename into place before the block ends. The folder and whatever is left in it are removed when
    the block ends, normally or by an error, Ctrl-C or SIGTERM/SIGHUP (as :func:`write_atomically`
    does); a folder that cannot be made is an :class:`OutputError`."""
    path = Path(path)
    directory = path.parent if str(path.parent) else Path(".")
    with _removed_on_signal() as temporaries:
        try:
            staging = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".tmp", dir=directory))
        except OSError as exc:
            raise _cannot_write(path, exc) from None
        temporaries.append(staging)
        try:
            staging.chmod(0o777 & ~_umask())  # as mkdir would make it, not mkdtemp's private 0700
            yield staging
        finally:
            _remove(staging)


def _remove(temporary: Path) -> None:
    """Remove a temporary file or folder; never raises."""
    if temporary.is_dir() and not temporary.is_symlink():
        shutil.rmtree(temporary, ignore_errors=True)
    else:
        temporary.unlink(missing_ok=True)


def _umask() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return umask


def _cannot_write(path: Path, exc: OSError) -> OutputError:
    reason = exc.strerror or str(exc)
    return OutputError(f"{path}: cannot be written ({reason}); nothing was written", reason)


def sweep_stale_temporaries(path: Path, older_than: float = STALE_TEMPORARY_SECONDS) -> list[Path]:
    """Remove the temporaries ``.NAME.XXXXXXXX.tmp`` of output ``path`` older than ``older_than``
    seconds (a write killed with SIGKILL leaves one); the paths removed. Never raises."""
    path = Path(path)
    directory = path.parent if str(path.parent) else Path(".")
    prefix = f".{path.name}."
    removed: list[Path] = []
    now = time.time()
    try:
        entries = list(os.scandir(directory))
    except OSError:
        return removed
    for entry in entries:
        name = entry.name
        if not (name.startswith(prefix) and name.endswith(".tmp")):
            continue
        if not _TEMPORARY_MIDDLE.match(name[len(prefix) : -len(".tmp")]):
            continue
        try:
            info = entry.stat(follow_symlinks=False)
            if stat.S_ISREG(info.st_mode) and now - info.st_mtime > older_than:
                os.unlink(entry.path)
                removed.append(Path(entry.path))
        except OSError:
            continue
    return removed


class _Terminated(BaseException):
    """Raised by the signal handler inside a write, so the write's cleanup runs."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


@contextlib.contextmanager
def _removed_on_signal() -> Iterator[list[Path]]:
    """While a write runs, SIGTERM (and SIGHUP) remove the temporaries put in the list yielded, then
    end the process as they would have: by the signal, or by the handler the process had set (if
    that handler returns, the write fails with :class:`InterruptedError`). A signal the process
    ignores is left ignored; only the main thread can install handlers, elsewhere none is."""
    temporaries: list[Path] = []
    if threading.current_thread() is not threading.main_thread():
        yield temporaries
        return
    previous: dict[int, Any] = {}

    def handler(signum: int, frame: FrameType | None) -> None:
        raise _Terminated(signum)

    for signum in _SIGNALS:
        try:
            old = signal.getsignal(signum)
            if old is signal.SIG_IGN:
                continue
            signal.signal(signum, handler)
            previous[signum] = old
        except (OSError, ValueError):
            continue
    try:
        yield temporaries
    except _Terminated as stop:
        for temporary in temporaries:
            _remove(temporary)
        _restore(previous)
        old = previous.get(stop.signum)
        previous = {}
        if callable(old):
            old(stop.signum, None)
            raise InterruptedError(f"the write was interrupted by signal {stop.signum}") from None
        os.kill(os.getpid(), stop.signum)  # the default action: the process ends by the signal
        raise SystemExit(128 + stop.signum) from None  # pragma: no cover - only if the signal is blocked
    finally:
        _restore(previous)


def _restore(previous: dict[int, Any]) -> None:
    for signum, old in previous.items():
        with contextlib.suppress(OSError, ValueError, TypeError):
            signal.signal(signum, old if old is not None else signal.SIG_DFL)


def usual_file_mode() -> int:
    """0o666 less the umask: the mode open() gives a new file, not mkstemp's private 0600."""
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask
