"""Reading a knowledge base's ``.lp`` files before clingo sees them.

clingo is never handed a file of the user's to open. Every ``.lp`` file of a domain (``kb:``), of
``--kb`` and every file they ``#include`` is read here: only a regular file (not a folder, a FIFO or
``/dev/zero``), no more than :data:`~beliefloc.source.limits.INPUT_BYTES` in all, UTF-8 text (clingo's
messages quote the program, and a message that is not UTF-8 crashes its Python binding). The text
is scanned with clingo's own lexical rules (comments ``%``, ``%* *%``, ``#!``; strings) for the
directives that reach outside the program:

* ``#include "file".`` is resolved relative to the file that writes it (clingo itself tries the
  working directory first). A file outside the folder tree the knowledge base belongs to (the
  domain file's folder for ``kb:`` and its includes, a ``--kb`` file's own folder for its
  includes), an absolute path or one through ``..`` that leaves the tree is refused unless
  ``allow_outside``;
* ``#script`` (Python or Lua code), ``#include <incmode>`` (a Lua script) and ``#theory``
  definitions are refused, with the line: a knowledge base is data, not code.

What clingo loads is a private copy of the text that was checked, with each ``#include`` pointing
at the copy of the included file (:class:`Program`); clingo's messages name the copies, and
:meth:`Program.shown` puts the original names back.
"""

from __future__ import annotations

import atexit
import bisect
import hashlib
import os
import re
import shutil
import tempfile
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

from beliefloc.errors import KnowledgeBaseError, LimitError
from beliefloc.source import limits, not_regular_file, read_text
from beliefloc.source.file_kinds import KNOWLEDGE_BASE, kind_of_path

NOT_LP = "is {} a knowledge base? --kb and kb: take ASP programs (kb/*.lp)"
OUTSIDE_HINT = "--allow-outside reads it anyway"
"""How to read a file outside the folder tree: the command-line option, or the library's parameter."""


@dataclass(frozen=True)
class Directive:
    """A ``#include``, ``#script`` or ``#theory`` found in a program's text."""

    kind: str
    """``include``, ``library`` (``#include <name>.``), ``script``, ``theory``, ``malformed`` (an
    ``#include`` not followed by a file name in quotes) or ``non_ascii`` (a character outside a
    comment or a string that clingo cannot read; the scan stops there)."""
    line: int
    column: int
    name: str = ""
    """The file name of an include (unquoted), the library of ``#include <name>``."""
    span: tuple[int, int] = (0, 0)
    """Where the quoted file name is in the text (start, end), to point it at a copy."""


# clingo's lexer (libgringo/src/input/nongroundlexer.xch): a string is "..." with the escapes \" \\ \n
# and no line break; a keyword is # and letters, digits or _ (the longest match: #includes is no #include).
_STRING = re.compile(r'"(?:[^\\"\n]|\\"|\\\\|\\n)*"')
_KEYWORD = re.compile(r"#[a-zA-Z0-9_]*")
_SKIP = re.compile(r'[^"%#]+')
_IDENTIFIER = re.compile(r"[_']*[a-z]['A-Za-z0-9_]*")
_NON_ASCII = re.compile(r"[^\x00-\x7f]")
_BLOCK_TOKEN = re.compile(r"\*%|%\*|%")


def _unquote(token: str) -> str:
    """A string token's text, as clingo reads it."""
    return re.sub(r"\\(.)", lambda m: "\n" if m.group(1) == "n" else m.group(1), token[1:-1])


class _Scanner:
    """Comments and strings skipped the way clingo's lexer skips them; directives collected."""

    def __init__(self, text: str) -> None:
        self.text = text
        self.pos = 0
        self.found: list[Directive] = []
        self._line_starts: list[int] | None = None

    def where(self, offset: int) -> tuple[int, int]:
        """1-based (line, column) of ``offset``."""
        if self._line_starts is None:
            self._line_starts = [0, *(m.end() for m in re.finditer("\n", self.text))]
        row = bisect.bisect_right(self._line_starts, offset) - 1
        return row + 1, offset - self._line_starts[row] + 1

    def skip_comment(self) -> bool:
        """Skip the comment at ``pos`` (``%...``, ``#!...``, a nested ``%* ... *%``); False when none."""
        text, pos = self.text, self.pos
        if text.startswith("%*", pos):
            depth, pos = 1, pos + 2
            while depth and pos < len(text):
                match = _BLOCK_TOKEN.search(text, pos)
                if match is None:
                    pos = len(text)
                    break
                token, pos = match.group(), match.end()
                if token == "*%":
                    depth -= 1
                elif token == "%*":
                    depth += 1
                elif token == "%":  # a line comment inside the block: its *% does not count
                    end = text.find("\n", pos)
                    pos = len(text) if end < 0 else end
            self.pos = pos
            return True
        if text.startswith("%", pos) or text.startswith("#!", pos):
            end = text.find("\n", pos)
            self.pos = len(text) if end < 0 else end
            return True
        return False

    def skip_blank(self) -> None:
        """Skip white space and comments."""
        while self.pos < len(self.text):
            if self.text[self.pos] in " \t\r\n":
                self.pos += 1
            elif not self.skip_comment():
                return

    def scan(self) -> list[Directive]:
        text = self.text
        while self.pos < len(text):
            skipped = _SKIP.match(text, self.pos)
            if skipped is not None:
                foreign = _NON_ASCII.search(text, self.pos, skipped.end())
                if foreign is not None:  # clingo's lexer error would quote a piece of it: not UTF-8
                    self.found.append(Directive("non_ascii", *self.where(foreign.start()), foreign.group()))
                    self.pos = len(text)
                    return self.found
                self.pos = skipped.end()
                continue
            char = text[self.pos]
            if char == '"':
                string = _STRING.match(text, self.pos)
                self.pos = string.end() if string is not None else self.pos + 1  # a lone " is one bad character
            elif self.skip_comment():
                continue
            elif char == "#":
                keyword = _KEYWORD.match(text, self.pos)
                assert keyword is not None
                start, self.pos = self.pos, keyword.end()
                word = keyword.group()
                if word == "#include":
                    self._include(start)
                elif word in ("#script", "#theory"):
                    self.found.append(Directive(word[1:], *self.where(start)))
            else:  # pragma: no cover - _SKIP takes every other character
                self.pos += 1
        return self.found

    def _include(self, start: int) -> None:
        line, column = self.where(start)
        self.skip_blank()
        text, pos = self.text, self.pos
        string = _STRING.match(text, pos)
        if string is not None:
            self.pos = string.end()
            self.found.append(Directive("include", line, column, _unquote(string.group()), string.span()))
            return
        if text.startswith("<", pos):
            self.pos += 1
            self.skip_blank()
            name = _IDENTIFIER.match(text, self.pos)
            self.found.append(Directive("library", line, column, name.group() if name else ""))
            return
        self.found.append(Directive("malformed", line, column))


def directives(text: str) -> list[Directive]:
    """The ``#include``, ``#script`` and ``#theory`` directives of a program, in order."""
    return _Scanner(text).scan()


@dataclass(frozen=True)
class ProgramFile:
    """One file of a program, read and checked."""

    shown: str
    """How messages name it: as given, or relative to the file that includes it."""
    real: Path
    """Its real path (links followed)."""
    text: str
    loaded: Path
    """What clingo loads: the private copy (a shipped file: itself)."""


@dataclass
class Program:
    """The files of a knowledge base, as clingo loads them."""

    files: list[ProgramFile] = field(default_factory=list)
    """Every file read, the includes after the file that includes them."""
    top: list[Path] = field(default_factory=list)
    """What to give ``Control.load``, in order (includes are reached through the copies)."""

    @property
    def digest(self) -> str:
        """A hash of every file's text, in order: the same program gives the same digest."""
        h = hashlib.sha256()
        for f in self.files:
            h.update(f.shown.encode() + b"\0" + f.text.encode("utf-8", "surrogatepass") + b"\0")
        return h.hexdigest()

    def shown(self, message: str) -> str:
        """``message`` with the copies' names put back to the files' own."""
        return _COPIES.shown(message)


class _Copies:
    """Private copies of checked program text, one folder per process, removed at exit.

    A file has one copy for the life of the process (a name per real path), rewritten when its
    text changes: an include of a file already included points at the same copy, so clingo skips
    it as it would skip the file itself."""

    def __init__(self) -> None:
        self.folder: Path | None = None
        self.owner = 0
        self.paths: dict[Path, Path] = {}
        self.texts: dict[Path, str] = {}
        """Copy -> the SHA-256 of the text written to it."""
        self.names: dict[str, str] = {}
        self._pattern: re.Pattern[str] | None = None

    def _folder(self, shown: str) -> Path:
        if self.folder is None or self.owner != os.getpid():
            try:
                self.folder = Path(tempfile.mkdtemp(prefix="beliefloc-kb-"))
            except OSError as exc:
                raise self._cannot(shown, exc) from None
            self.owner = os.getpid()
            self.paths, self.texts, self.names = {}, {}, {}
            self._pattern = re.compile(re.escape(str(self.folder) + os.sep) + r"\d+\.lp")
            atexit.register(_remove, self.folder, self.owner)
        return self.folder

    @staticmethod
    def _cannot(shown: str, exc: OSError) -> KnowledgeBaseError:
        return KnowledgeBaseError(
            f"{shown}: cannot write a private copy for clingo in {tempfile.gettempdir()} ({exc.strerror or exc}); "
            "set TMPDIR to a folder you can write"
        )

    def path_for(self, real: Path, shown: str) -> Path:
        """The copy of the file ``real`` (named ``shown`` in messages), not written yet."""
        folder = self._folder(shown)
        path = self.paths.get(real)
        if path is None:
            path = folder / f"{len(self.paths)}.lp"
            self.paths[real] = path
            self.names[str(path)] = shown
        return path

    def write(self, path: Path, text: str, shown: str) -> None:
        """Write ``text`` to the copy ``path`` unless it holds it already."""
        digest = hashlib.sha256(text.encode("utf-8", "surrogatepass")).hexdigest()
        if self.texts.get(path) == digest and path.is_file():
            return
        try:
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | getattr(os, "O_NOFOLLOW", 0), 0o600)
            with os.fdopen(fd, "w", encoding="utf-8", newline="") as stream:
                stream.write(text)
        except OSError as exc:
            raise self._cannot(shown, exc) from None
        self.texts[path] = digest

    def shown(self, message: str) -> str:
        if self._pattern is None or not self.names:
            return message
        return self._pattern.sub(lambda m: self.names.get(m.group(), m.group()), message)


def _remove(folder: Path, owner: int) -> None:
    if os.getpid() == owner:  # a forked child leaves its parent's copies alone
        shutil.rmtree(folder, ignore_errors=True)


_COPIES = _Copies()


@dataclass(frozen=True)
class Root:
    """A file to read and the folder tree its includes (and itself, when ``contains_self``) must stay in."""

    path: Path
    folder: Path | None
    """None: a shipped file, trusted and loaded as it is."""
    owner: str = ""
    """What the folder belongs to, for messages: ``the domain file domains/home.yaml``."""
    contains_self: bool = False


def outside(path: Path, folder: Path) -> bool:
    """Whether ``path`` (links followed) is outside ``folder``'s tree."""
    real, top = os.path.realpath(path), os.path.realpath(folder)
    try:
        return os.path.commonpath([real, top]) != top
    except ValueError:  # different drives
        return True


def check_place(name: str, base: Path, root: Path | None, owner: str, *, allow_outside: bool) -> str | None:
    """Why the file ``name``, written in a file of the folder ``base``, may not be read (None: it may):
    an absolute path, or a path out of ``root``'s folder tree, unless ``allow_outside``."""
    if allow_outside or root is None:
        return None
    if os.path.isabs(name):
        return f"is an absolute path; name the file relative to {owner} ({OUTSIDE_HINT})"
    if outside(base / name, root):
        return f"is outside the folder {root} of {owner} ({OUTSIDE_HINT})"
    return None


def check_file(path: Path, shown: str) -> None:
    """Raise :class:`KnowledgeBaseError` unless ``path`` is a regular file (not read)."""
    try:
        info = os.stat(path)
    except FileNotFoundError:
        raise KnowledgeBaseError(f"{shown}: no such knowledge-base file") from None
    except (OSError, ValueError) as exc:
        text = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise KnowledgeBaseError(f"{shown}: cannot be read ({text})") from None
    problem = not_regular_file(info.st_mode)
    if problem is not None:
        raise KnowledgeBaseError(f"{shown}: {problem}")
    kind = kind_of_path(path)
    if kind is not None and kind != KNOWLEDGE_BASE:
        raise KnowledgeBaseError(f"{shown} is {kind}, not {KNOWLEDGE_BASE}")


def read_program(roots: Iterable[Root], *, allow_outside: bool = False) -> Program:
    """Read, check and copy every file of a program (see the module docstring).

    Raises :class:`KnowledgeBaseError` naming the file (and the line of a directive), or
    :class:`LimitError` when the files hold more than :data:`~beliefloc.source.limits.INPUT_BYTES` in all.
    """
    program = Program()
    budget = _Budget()
    done: set[Path] = set()
    read: dict[Path, Path] = {}
    for root in roots:
        real = Path(os.path.realpath(root.path))
        if real in done:
            continue
        done.add(real)
        if root.folder is None:  # shipped with beliefloc: loaded as it is
            program.top.append(root.path)
            continue
        shown = str(root.path)
        if root.contains_self and not allow_outside and outside(root.path, root.folder):
            raise KnowledgeBaseError(f"{shown} is outside the folder {root.folder} of {root.owner} ({OUTSIDE_HINT})")
        program.top.append(_read_tree(root, program, budget, read, allow_outside))
    return program


@dataclass
class _Budget:
    used: int = 0

    def spend(self, count: int, shown: str) -> None:
        self.used += count
        limit = limits.INPUT_BYTES
        if self.used > limit.value:
            raise LimitError(limits.exceeded(limit, self.used, f"{shown} (with the other files of the knowledge base)"))


def _read_one(path: Path, shown: str) -> str:
    check_file(path, shown)
    try:
        text, _ = read_text(path, KnowledgeBaseError)
    except KnowledgeBaseError as exc:
        message = str(exc).replace(str(path), shown, 1)
        if path.suffix.lower() != ".lp" and "not UTF-8" in message:
            message += f"; {NOT_LP.format(shown)}"
        raise KnowledgeBaseError(message) from None
    if "\0" in text:
        line = text.count("\n", 0, text.index("\0")) + 1
        raise KnowledgeBaseError(f"{shown}:{line}: a NUL character: not a text file")
    return text


def _read_tree(root: Root, program: Program, budget: _Budget, read: dict[Path, Path], allow_outside: bool) -> Path:
    """Read ``root.path`` and every file it includes (each once); returns the copy clingo loads.

    Iterative, so that a long chain of includes cannot exhaust the stack. Each ``#include`` is
    pointed at the copy of its file (padded so that the columns after it keep their place)."""
    assert root.folder is not None
    top_real = Path(os.path.realpath(root.path))
    if top_real in read:  # included by a file loaded before: loaded again, as clingo would
        return read[top_real]
    pending: list[tuple[Path, str, str]] = [(root.path, str(root.path), "")]
    while pending:
        path, shown, via = pending.pop()
        real = Path(os.path.realpath(path))
        if real in read:
            continue
        copy = _COPIES.path_for(real, shown)
        read[real] = copy
        try:
            text = _read_one(path, shown)
        except KnowledgeBaseError as exc:
            raise KnowledgeBaseError(f"{via}{exc}") from None
        budget.spend(len(text), shown)
        pieces: list[str] = []
        last = 0
        for directive in directives(text):
            where = f"{shown}:{directive.line}:{directive.column}"
            try:
                target = _include_target(directive, where, path.parent, root, allow_outside)
            except KnowledgeBaseError as exc:
                if path.suffix.lower() != ".lp" and directive.kind in ("non_ascii", "malformed", "library"):
                    raise KnowledgeBaseError(f"{exc}; {NOT_LP.format(shown)}") from None
                raise
            target_real = Path(os.path.realpath(target))
            target_shown = os.path.normpath(str(target))
            start, end = directive.span
            pieces += [text[last:start], f'"{_COPIES.path_for(target_real, target_shown)}"'.ljust(end - start)]
            last = end
            if target_real not in read:
                pending.append((target, target_shown, f'{where}: #include "{directive.name}": '))
        _COPIES.write(copy, "".join([*pieces, text[last:]]), shown)
        program.files.append(ProgramFile(shown, real, text, copy))
    return read[top_real]


def _include_target(directive: Directive, where: str, base: Path, root: Root, allow_outside: bool) -> Path:
    """The file an ``#include`` names, relative to ``base``; raises for every other directive."""
    if directive.kind == "non_ascii":
        raise KnowledgeBaseError(
            f"{where}: {directive.name!r} is not ASCII: clingo reads names, numbers and symbols in ASCII only "
            '(other characters may stand in a % comment or a "string")'
        )
    if directive.kind == "script":
        raise KnowledgeBaseError(
            f"{where}: #script: beliefloc does not run code embedded in a knowledge base (Python or Lua); "
            "write the rules in ASP"
        )
    if directive.kind == "theory":
        raise KnowledgeBaseError(f"{where}: #theory: theory definitions are not supported in a knowledge base")
    if directive.kind == "library":
        if directive.name == "incmode":
            raise KnowledgeBaseError(
                f"{where}: #include <incmode>: clingo's incremental mode is a Lua script, which beliefloc does not run"
            )
        raise KnowledgeBaseError(f'{where}: #include <{directive.name}>: include a file: #include "file.lp".')
    if directive.kind == "malformed":
        raise KnowledgeBaseError(f'{where}: #include: write the file name in quotes: #include "file.lp".')
    name = directive.name
    quoted = f'#include "{name}"'
    if not name or "\0" in name or "\n" in name:
        raise KnowledgeBaseError(f"{where}: {quoted}: not a usable file name")
    problem = check_place(name, base, root.folder, root.owner, allow_outside=allow_outside)
    if problem is not None:
        raise KnowledgeBaseError(f"{where}: {quoted}: {problem}")
    return base / name
