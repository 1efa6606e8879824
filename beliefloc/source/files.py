"""Reading an input file: only a regular file of a sane size, and only UTF-8 text."""

from __future__ import annotations

import os
import stat
from pathlib import Path as FilePath

from beliefloc.errors import BeliefLocError, LimitError
from beliefloc.source import limits

# --- reading the file ---------------------------------------------------------------------------

_READ_CHUNK = 1 << 20


def not_regular_file(mode: int) -> str | None:
    """Why a file of this ``st_mode`` cannot be read as text, or None for a regular file."""
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISDIR(mode):
        return "is a folder, not a file"
    if stat.S_ISFIFO(mode):
        return "is a named pipe (FIFO), not a regular file; save the input to a file first"
    if stat.S_ISCHR(mode):
        return "is a character device (like /dev/zero or a terminal), not a regular file"
    if stat.S_ISBLK(mode):
        return "is a block device (a disk), not a regular file"
    if stat.S_ISSOCK(mode):
        return "is a socket, not a regular file"
    return "is not a regular file"


def _cannot_read(file_path: FilePath, exc: OSError) -> str:
    if isinstance(exc, (FileNotFoundError, NotADirectoryError)):
        return f"{file_path}: no such file"
    if isinstance(exc, IsADirectoryError):
        return f"{file_path}: is a folder, not a file"
    if isinstance(exc, PermissionError):
        return f"{file_path}: cannot be read (permission denied)"
    return f"{file_path}: cannot be read ({exc.strerror or exc})"


def read_text(path: str | FilePath, error_cls: type[BeliefLocError]) -> tuple[str, bytes]:
    """A UTF-8 text file and its bytes; every failure is ``error_cls`` naming the file.

    Only a regular file is opened (a FIFO would block, /dev/zero never end), and no more than
    :data:`~beliefloc.source.limits.INPUT_BYTES` bytes are read, whatever size the file claims."""
    file_path = FilePath(path)
    limit = limits.INPUT_BYTES
    try:
        info = os.stat(file_path)
    except (OSError, ValueError) as exc:  # ValueError: a NUL in the name
        if isinstance(exc, ValueError):
            raise error_cls(f"{file_path!r}: not a usable file name") from None
        raise error_cls(_cannot_read(file_path, exc)) from None
    problem = not_regular_file(info.st_mode)
    if problem is not None:
        raise error_cls(f"{file_path}: {problem}")
    limit.check(info.st_size, str(file_path))
    budget = limit.value + 1  # one byte more than allowed: a file longer than it says is noticed
    try:
        fd = os.open(file_path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
        with os.fdopen(fd, "rb", buffering=0) as stream:
            problem = not_regular_file(os.fstat(stream.fileno()).st_mode)  # what was opened: it may have changed
            if problem is not None:
                raise error_cls(f"{file_path}: {problem}")
            chunks: list[bytes] = []
            total, want = 0, min(info.st_size + 1, budget)
            while total < budget:
                chunk = stream.read(min(want, budget - total))
                if not chunk:
                    break
                chunks.append(chunk)
                total += len(chunk)
                want = _READ_CHUNK
    except OSError as exc:
        raise error_cls(_cannot_read(file_path, exc)) from None
    raw = chunks[0] if len(chunks) == 1 else b"".join(chunks)
    if len(raw) >= budget:
        raise LimitError(limits.exceeded(limit, None, str(file_path)))
    try:
        return raw.decode("utf-8"), raw
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise error_cls(f"{file_path}:{line}: not UTF-8 text (byte {exc.start})") from None
