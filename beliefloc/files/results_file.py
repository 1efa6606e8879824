"""Results files (``--out FILE.jsonl``): a sweep's results, one JSON line per finished unit, that
survive the sweep being killed.

The first line is a header (:func:`header`): the format, the beliefloc version, the command, the
unit (``episode`` or ``trial``), how many units the sweep has and the settings that decide the
results. Each following line is one unit's result, in unit order (unit ``k`` on line ``k + 2``,
its index under the unit's key), written whole and flushed as the unit ends. Without wall-clock
values (``--no-timings``) two runs of the same command write the same bytes.

Resuming (:func:`read_results`, :func:`differences`): the lines already in the file are kept and
their units not run again; a last line cut short by the kill (or not JSON) is dropped and its unit
run again; a file whose header differs from the new run's is refused, naming what differs.
Appending to a file is not atomic, by design: what was written stays, whatever happens next.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any, TypeVar

from beliefloc import __version__
from beliefloc.errors import InputFileError
from beliefloc.source.limits import INPUT_BYTES, LARGEST_COUNT

FORMAT = "beliefloc-results"
FORMAT_VERSION = 1
SUFFIX = ".jsonl"


class ResultsFileError(InputFileError):
    """A results file that cannot be read or resumed: not one, damaged, or written with other settings."""


def header(command: str, unit: str, total: int, settings: Mapping[str, Any]) -> dict[str, Any]:
    """The first line of a results file. ``settings``: everything that decides the results (JSON
    values), compared key by key on resuming."""
    return {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "beliefloc": __version__,
        "command": command,
        "unit": unit,
        "total": total,
        "settings": dict(settings),
    }


def digest(path: Path) -> str:
    """The SHA-256 of a file's bytes (an input of the sweep, recorded in its settings)."""
    import hashlib

    return hashlib.sha256(path.read_bytes()).hexdigest()


def dumps(data: Any) -> str:
    """One line of a results file (no newline): compact JSON, no NaN."""
    return json.dumps(data, separators=(",", ":"), allow_nan=False)


@dataclass(frozen=True)
class ResultsContent:
    """What a results file holds."""

    header: dict[str, Any]
    results: list[dict[str, Any]]
    """The whole result lines, in unit order (unit ``k`` is ``results[k]``)."""
    kept_bytes: int
    """The length of the header and of the whole result lines: a resumed run appends from here."""
    torn: bool
    """The file ended in a line cut short (or not JSON), left out of :attr:`results`."""

    @property
    def unit(self) -> str:
        return str(self.header["unit"])

    @property
    def total(self) -> int:
        return int(self.header["total"])


def read_results(path: Path) -> ResultsContent:
    """The header and the whole result lines of the results file ``path`` (for ``--resume``, which
    continues after them; :func:`scan_results` reads them one at a time instead of holding them).

    A :class:`ResultsFileError` for a file that is not one (no beliefloc header on its first line),
    a damaged line before the last, or a result line out of order."""
    scan = scan_results(path)
    results = [line for _, line in scan.lines()]
    return ResultsContent(scan.header, results, scan.kept_bytes, scan.torn)


@dataclass
class ResultsScan:
    """A results file read one result line at a time (:meth:`lines`), for ``summarize`` of a file of
    millions of lines: its memory does not grow with the file. The header is read and checked when
    the scan is made; :attr:`count`, :attr:`kept_bytes` and :attr:`torn` are final once
    :meth:`lines` has been gone through."""

    path: Path
    header: dict[str, Any]
    header_bytes: int
    count: int = 0
    """Whole result lines read so far."""
    kept_bytes: int = 0
    torn: bool = False

    @property
    def unit(self) -> str:
        return str(self.header["unit"])

    @property
    def total(self) -> int:
        return int(self.header["total"])

    def lines(self) -> Iterator[tuple[int, dict[str, Any]]]:
        """``(line number, result)`` of every whole result line in unit order; a damaged line before
        the last, a unit out of order or more units than the header's total is a :class:`ResultsFileError`;
        a last line cut short (or not JSON) is left out and marks the scan :attr:`torn`."""
        path, unit, total = self.path, self.unit, self.total
        self.count, self.kept_bytes, self.torn = 0, self.header_bytes, False
        with path.open("rb") as file:
            file.seek(self.header_bytes)
            number = 1
            while True:
                raw = file.readline()
                if not raw:
                    return
                number += 1
                if not raw.endswith(b"\n"):
                    self.torn = True  # what follows the last newline: a line cut short
                    return
                line = _parse(raw)
                if not isinstance(line, dict):
                    if not file.read(1):
                        self.torn = True  # the last line is damaged: redo its unit
                        return
                    raise ResultsFileError(f"{path}:{number}: not a JSON object: the file is damaged")
                if line.get(unit) != self.count:
                    found = _printable(repr(line.get(unit)))[:40]
                    raise ResultsFileError(
                        f"{path}:{number}: expected {unit} {self.count}, found {found}: the file is damaged"
                    )
                if self.count >= total:
                    raise ResultsFileError(f"{path}: holds more than the {total} {unit}s of its header")
                self.count += 1
                self.kept_bytes += len(raw)
                yield number, line


def scan_results(path: Path) -> ResultsScan:
    """The results file ``path`` with its header read and checked, its result lines to be read one at
    a time (:meth:`ResultsScan.lines`). Errors as :func:`read_results`."""
    if not path.is_file():
        raise ResultsFileError(f"{path}: not a regular file")
    INPUT_BYTES.check(path.stat().st_size, str(path))
    with path.open("rb") as file:
        first = file.readline(HEADER_BYTES + 1)
    if not first.endswith(b"\n"):
        if len(first) > HEADER_BYTES:
            raise ResultsFileError(f"{path}: its first line is longer than a header ({HEADER_BYTES:,} bytes)")
        raise ResultsFileError(f"{path}: not a beliefloc results file (no header line)")
    head = _parse(first)
    if not isinstance(head, dict) or head.get("format") != FORMAT:
        raise ResultsFileError(f"{path}: not a beliefloc results file (its first line is no {FORMAT} header)")
    if head.get("format_version") != FORMAT_VERSION:
        raise ResultsFileError(
            f"{path}: a results file of format version {_printable(str(head.get('format_version')))[:40]}; "
            f"this beliefloc reads version {FORMAT_VERSION}"
        )
    for key in ("command", "unit", "total", "settings"):
        if key not in head:
            raise ResultsFileError(f"{path}: the header has no {key!r}")
    _check_header(path, head)
    return ResultsScan(path, head, len(first), kept_bytes=len(first))


HEADER_BYTES = 16 * 1024 * 1024
"""The longest header line read (a header holds the settings: a few kilobytes)."""


def _check_header(path: Path, head: dict[str, Any]) -> None:
    """The header's fields have the types a sweep writes: checked before any line is used."""
    total = head["total"]
    if isinstance(total, bool) or not isinstance(total, int) or not 0 <= total <= LARGEST_COUNT:
        shown = json.dumps(total)[:40] if not isinstance(total, int) else f"a {len(str(total))}-digit number"
        raise ResultsFileError(f"{path}: the header's 'total' is {shown}; it must be a whole number of units")
    for key in ("command", "unit"):
        if not isinstance(head[key], str):
            raise ResultsFileError(f"{path}: the header's {key!r} is {json.dumps(head[key])[:40]}, not a string")
    if not isinstance(head["settings"], dict):
        raise ResultsFileError(f"{path}: the header's 'settings' is not a JSON object")


def check_lines(path: Path, content: ResultsContent, decode: Callable[[dict[str, Any]], object]) -> None:
    """Every result line decoded by ``decode`` (the command's record reader) before any work is
    done with the file: a :class:`ResultsFileError` naming the first line it refuses."""
    numbered = enumerate(content.results, start=2)
    for _ in decoded_lines(path, str(content.header["command"]), numbered, decode):
        pass


T = TypeVar("T")


def decoded_lines(
    path: Path, command: str, numbered: Iterable[tuple[int, dict[str, Any]]], decode: Callable[[dict[str, Any]], T]
) -> Iterator[T]:
    """``decode`` (the command's record reader) of each ``(line number, result)``, as they come: a
    :class:`ResultsFileError` naming the first line it refuses."""
    for number, line in numbered:
        try:
            yield decode(line)
        except (KeyError, TypeError, ValueError, AttributeError, OverflowError) as exc:
            what = f"no {exc.args[0]!r}" if isinstance(exc, KeyError) else str(exc)
            raise ResultsFileError(
                f"{path}:{number}: not a {command!r} result ({_printable(what)}): the file is damaged"
            ) from None


def _printable(text: str) -> str:
    """``text`` with control characters escaped (a terminal escape in a file stays inert)."""
    return "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in text)


def _parse(raw: bytes) -> Any:
    try:
        return json.loads(raw.decode("utf-8"))
    except (ValueError, UnicodeDecodeError, RecursionError):
        return None


def differences(found: Mapping[str, Any], wanted: Mapping[str, Any]) -> list[str]:
    """What differs between two headers, a phrase per key (``settings.seed: 0 in the file, 1 now``),
    nested keys joined by dots; the format keys are not compared (:func:`read_results` checks them)."""
    out: list[str] = []

    def walk(prefix: str, a: Any, b: Any) -> None:
        if isinstance(a, dict) and isinstance(b, dict):
            for key in dict.fromkeys([*a, *b]):
                walk(f"{prefix}.{key}" if prefix else str(key), a.get(key, _MISSING), b.get(key, _MISSING))
        elif a != b or type(a) is not type(b):
            out.append(f"{prefix}: {_shown(a)} in the file, {_shown(b)} now")

    skip = {"format", "format_version"}
    walk(
        "",
        {k: v for k, v in found.items() if k not in skip},
        {k: v for k, v in wanted.items() if k not in skip},
    )
    return out


class _Missing:
    def __repr__(self) -> str:
        return "absent"


_MISSING = _Missing()


def _shown(value: Any) -> str:
    return "absent" if value is _MISSING else json.dumps(value)


def open_locked(path: Path) -> IO[bytes]:
    """``path`` opened for writing (created when missing, never truncated here) and locked with
    ``flock``: a second sweep on the same file is refused naming the first one's pid, instead of
    both writing it."""
    import fcntl
    import os

    file = os.fdopen(os.open(path, os.O_RDWR | os.O_CREAT, 0o666), "r+b", buffering=0)  # a failed write: no buffer
    try:
        fcntl.flock(file.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        holder = _lock_holder(os.fstat(file.fileno()).st_ino)
        file.close()
        who = f"another beliefloc (pid {holder})" if holder else "another process"
        raise ResultsFileError(
            f"{path}: {who} is writing this results file; wait for it to end, or give another --out"
        ) from None
    return file


def _lock_holder(inode: int) -> int | None:
    """The pid holding a ``flock`` on the file of ``inode`` (Linux's /proc/locks), or None."""
    try:
        lines = Path("/proc/locks").read_text().splitlines()
    except OSError:
        return None
    for line in lines:
        fields = line.split()
        if len(fields) > 5 and fields[1] == "FLOCK" and fields[5].rsplit(":", 1)[-1] == str(inode):
            return int(fields[4]) if fields[4].isascii() and fields[4].isdigit() else None
    return None


class ResultsWriter:
    """Writes a results file line by line, each written through as it is written. A new file gets
    ``head`` first; a resumed one (``resume``: what :func:`read_results` found) is cut back to its
    whole lines and continued. ``file``: the file :func:`open_locked` opened (else it is opened
    and locked here). ``created``: the file did not exist before this run.

    A write that fails (a full disk) leaves the file with whole lines only: cut back to the end of
    the last whole result, or removed when this run created it and wrote no result; then an
    :class:`~beliefloc.errors.OutputError` names the file and what it still holds."""

    def __init__(
        self,
        path: Path,
        head: Mapping[str, Any],
        resume: ResultsContent | None = None,
        file: IO[bytes] | None = None,
        *,
        created: bool = False,
    ) -> None:
        self.path = path
        self._file: IO[bytes] = file if file is not None else open_locked(path)
        self._created = created
        kept = 0 if resume is None else resume.kept_bytes
        self._kept = kept
        """Bytes of whole lines in the file."""
        self._results = 0 if resume is None else len(resume.results)
        self._file.truncate(kept)
        self._file.seek(kept)
        if resume is None:
            self._write_line(head)
        else:
            self._created = False

    def still_there(self) -> bool:
        """Whether the file written is still at :attr:`path` (not removed or replaced meanwhile)."""
        import os

        try:
            return os.stat(self.path).st_ino == os.fstat(self._file.fileno()).st_ino
        except OSError:
            return False

    def write(self, data: Any) -> None:
        """One result, as a line."""
        self._write_line(data)
        self._results += 1

    def _write_line(self, data: Any) -> None:
        import os

        encoded = (dumps(data) + "\n").encode("utf-8")
        line = memoryview(encoded)
        fd = self._file.fileno()
        try:
            while line:
                line = line[os.write(fd, line) :]
        except OSError as exc:
            self._cut_back(exc)
        self._kept += len(encoded)

    def _cut_back(self, exc: OSError) -> None:
        """After a failed write: only whole lines stay (or no file, if this run made it and wrote no
        result); an :class:`OutputError` saying so."""
        import contextlib
        import os

        from beliefloc.errors import OutputError

        reason = exc.strerror or str(exc)
        if self._created and self._results == 0:
            self.path.unlink(missing_ok=True)
            self._file.close()
            raise OutputError(f"{self.path}: cannot be written ({reason}); nothing was written", reason)
        with contextlib.suppress(OSError):
            os.ftruncate(self._file.fileno(), self._kept)
        raise OutputError(
            f"{self.path}: cannot be written ({reason}); the file keeps the {self._results:,} whole results "
            "written before: make room and continue with --resume",
            reason,
        )

    def close(self) -> None:
        self._file.close()

    def __enter__(self) -> ResultsWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def is_results_file(path: Path) -> bool:
    """Whether ``path`` starts with a results file's header line (without reading the rest)."""
    try:
        with path.open("rb") as file:
            first = file.readline(1024 * 1024)
    except OSError:
        return False
    head = _parse(first)
    return isinstance(head, dict) and head.get("format") == FORMAT
