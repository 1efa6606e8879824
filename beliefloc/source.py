"""Hand-written YAML/JSON input files, validated with pydantic, with errors that point at the line.

The one way every input file (maps, belief files, domains) is read:

1. :func:`read_text` refuses anything that is not a regular file of a sane size before reading it.
2. :func:`read_source` reads the YAML (JSON is YAML) from the parser's events, without recursion,
   into plain Python data under the YAML 1.2 core schema (``on``, ``yes``, ``1:30`` and
   ``2001-12-14`` are text; ``010`` is ten), remembering where (line, column) each value and key was
   written, keyed by its path from the root. Nesting deeper than :data:`~beliefloc.limits.NESTING`
   and more values than :data:`~beliefloc.limits.YAML_NODES` (counting every use of an alias in
   full) are refused before they are built.
3. :func:`validate_source` runs a pydantic model over the data. A pydantic error's ``loc`` or a
   :class:`~beliefloc.errors.FieldError`'s ``path`` is mapped back to the line, so a message reads
   ``maps/kitchen.yaml:14:5: sensors.look.false_positive: should be less than or equal to 1, got 1.5``.
"""

from __future__ import annotations

import contextlib
import gc
import hashlib
import math
import os
import re
import stat
import sys
import types
import typing
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path as FilePath
from typing import Any, NoReturn, TypeVar

import yaml
from pydantic import BaseModel, ValidationError
from yaml.events import (
    AliasEvent,
    DocumentStartEvent,
    MappingEndEvent,
    MappingStartEvent,
    ScalarEvent,
    SequenceEndEvent,
    SequenceStartEvent,
    StreamEndEvent,
)

from beliefloc import limits
from beliefloc.errors import BeliefLocError, FieldError, InputFileError, LimitError, Path

_Model = TypeVar("_Model", bound=BaseModel)
_MAX_ERRORS_SHOWN = 6

_new_parser: Callable[[str], Any]
try:  # libyaml's parser: several times faster on large generated maps, and (unlike its composer) not recursive
    from yaml._yaml import CParser as _CParser

    _new_parser = _CParser
except ImportError:  # pragma: no cover - pyyaml built without libyaml; its Python parser is not recursive either
    _new_parser = yaml.SafeLoader


@contextlib.contextmanager
def _gc_paused() -> Iterator[None]:
    """Pause the cyclic garbage collector while building many small acyclic objects.

    A 10^6-state generated map is ~600,000 YAML values; every few hundred allocations the collector
    would walk all the objects alive so far, which made reading such a file quadratic (5 s instead
    of 1 s). Nothing built here is cyclic, so nothing is left for the collector to find.
    """
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was_enabled:
            gc.enable()


@dataclass(frozen=True)
class Source:
    """A parsed input file: its data and where each part of it was written."""

    path: FilePath
    data: Any
    sha256: str
    value_marks: dict[Path, tuple[int, int]] = field(default_factory=dict)
    key_marks: dict[Path, tuple[int, int]] = field(default_factory=dict)
    block_rows: dict[Path, list[tuple[int, int]]] = field(default_factory=dict)
    """For block scalars (``layout: |``): (line, indentation) of each non-blank content line."""
    aliases: dict[Path, Path] = field(default_factory=dict)
    """Where a value that was not written at its own path was written: an alias (``b: *a``) maps
    ``("b",)`` to the anchor's path, a key merged in by ``<<: *base`` maps ``("m", "k")`` to
    ``("base", "k")``. Values are shared, not copied, so this stays as small as the file."""

    def locate(self, path: Path, *, key: bool = False) -> tuple[Path, tuple[int, int]]:
        """The part of ``path`` that exists in the file and its (line, column), both 1-based.

        Elements that are not in the file (a pydantic union tag, say) are skipped; a path that
        leads nowhere resolves to its longest existing prefix. With ``key``, the line of the key
        rather than of its value, when the key was written.
        """
        found, _, mark = self._resolve(path, key=key)
        return found, mark

    def _resolve(self, path: Path, *, key: bool = False) -> tuple[Path, Path, tuple[int, int]]:
        """(the part of ``path`` found, where it was written, its line and column)."""
        values, keys, aliases = self.value_marks, self.key_marks, self.aliases
        found: Path = ()
        written: Path = ()
        value_mark = values.get(())
        key_mark: tuple[int, int] | None = None
        for element in path:
            candidate = (*written, element)
            if candidate not in values and candidate not in aliases and candidate not in keys:
                if isinstance(element, (int, float)):
                    candidate = (*written, str(element))  # a key written as a number: paths spell it as text
                elif element == "[key]":  # pydantic: the key itself is wrong, not its value
                    key = True
                    continue
                else:  # a list the model turned into a mapping (rooms: [kitchen, study]): the item
                    items = _data_at(self.data, found)
                    if isinstance(items, list) and element in items:
                        candidate = (*written, items.index(element))
            target = self._follow(candidate, stop_at=values)
            if target in values:
                value_mark, key_mark = values[target], keys.get(target)
            elif candidate in keys:  # a key whose value has no mark of its own
                value_mark = key_mark = keys[candidate]
            else:
                continue  # not in the file: a union tag, or a key the file lacks
            found = (*found, element)
            written = self._follow(candidate)
        mark = key_mark if key and key_mark is not None else value_mark
        return found, written, mark if mark is not None else (1, 1)

    def _follow(self, path: Path, *, stop_at: dict[Path, Any] | None = None) -> Path:
        """``path`` through aliases and merges to where its value was written (to its first mark
        with ``stop_at``)."""
        for _ in range(len(self.aliases) + 1):  # aliases cannot loop (a value cannot contain itself), but be sure
            if (stop_at is not None and path in stop_at) or path not in self.aliases:
                break
            path = self.aliases[path]
        return path

    def error(self, path: Path, message: str, error_cls: type[InputFileError], *, key: bool = False) -> InputFileError:
        """An error naming this file, the line and column of ``path``, and the field."""
        return error_cls(self.format(path, message, key=key))

    def format(self, path: Path, message: str, *, key: bool = False, row: int | None = None, column: int = 0) -> str:
        """``file:line:col: field.path: message``; with ``row``, the line of that row of a block."""
        found, written, (line, col) = self._resolve(path, key=key)
        rows = self.block_rows.get(written, self.block_rows.get(found))
        if row is not None and rows is not None and 0 <= row < len(rows):
            line, col = rows[row][0], rows[row][1] + column + 1
        where = format_path(found)
        return f"{self.path}:{line}:{col}: {where + ': ' if where else ''}{message}"


def format_path(path: Path) -> str:
    """``("sensors", "look", "classes", 2)`` -> ``sensors.look.classes[2]``."""
    text = ""
    for element in path:
        if isinstance(element, int):
            text += f"[{element}]"
        else:
            text += f".{element}" if text else str(element)
    return text


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
    :data:`~beliefloc.limits.INPUT_BYTES` bytes are read, whatever size the file claims."""
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


def read_source(path: str | FilePath, error_cls: type[InputFileError]) -> Source:
    """Read and parse a YAML (or JSON) file, keeping the marks of every key and value."""
    text, raw = read_text(path, error_cls)
    return parse_source(text, FilePath(path), error_cls, sha256=hashlib.sha256(raw).hexdigest())


def parse_source(text: str, path: FilePath, error_cls: type[InputFileError], *, sha256: str | None = None) -> Source:
    """Parse YAML text that came from ``path`` (used for messages only)."""
    reader = _Reader(path, error_cls, text)
    with _gc_paused():
        data = reader.read()
    digest = sha256 or hashlib.sha256(text.encode()).hexdigest()
    if data is None and not reader.value_marks:
        return Source(path=path, data=None, sha256=digest)
    return Source(path, data, digest, reader.value_marks, reader.key_marks, reader.block_rows, reader.aliases)


# --- YAML 1.2 core schema -----------------------------------------------------------------------

_CORE_WORDS: dict[str, Any] = {
    **dict.fromkeys(("", "~", "null", "Null", "NULL")),
    **dict.fromkeys(("true", "True", "TRUE"), True),
    **dict.fromkeys(("false", "False", "FALSE"), False),
    **{
        sign + word: value
        for sign, value in (("", math.inf), ("+", math.inf), ("-", -math.inf))
        for word in (".inf", ".Inf", ".INF")
    },
    **dict.fromkeys((".nan", ".NaN", ".NAN"), math.nan),
}
"""Plain scalars that are not text, other than numbers. Everything not here and not a number is
text: ``on``, ``off``, ``yes``, ``no``, ``y``, ``n`` (YAML 1.1 booleans) among them."""
_NOT_A_WORD = object()
_NUMBER_START = frozenset("0123456789+-.")
_DECIMAL = re.compile(r"[-+]?[0-9]+\Z").match
_OCTAL = re.compile(r"0o[0-7]+\Z").match
_HEX = re.compile(r"0x[0-9a-fA-F]+\Z").match
_FLOAT = re.compile(r"[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?\Z").match
_INT_DIGITS = getattr(sys, "get_int_max_str_digits", lambda: 4300)() or 4300


def resolve_plain(text: str) -> Any:
    """The value of a plain (unquoted, untagged) scalar under the YAML 1.2 core schema.

    ``010`` is 10 (not 8 as in YAML 1.1), ``0o17`` 15, ``0x1F`` 31, ``1_000``, ``1:30`` and
    ``2001-12-14`` are text. Raises ValueError for an integer of more digits than Python converts."""
    word = _CORE_WORDS.get(text, _NOT_A_WORD)
    if word is not _NOT_A_WORD:
        return word
    if text[0] not in _NUMBER_START:
        return text
    if _DECIMAL(text):
        return int(text)
    if _FLOAT(text):
        return float(text)
    if _OCTAL(text):
        return int(text[2:], 8)
    if _HEX(text):
        return int(text[2:], 16)
    return text


_YAML_TAG = "tag:yaml.org,2002:"
_STR_TAGS = frozenset({"!", f"{_YAML_TAG}str"})
_MAP_TAGS = frozenset({None, "!", f"{_YAML_TAG}map"})
_SEQ_TAGS = frozenset({None, "!", f"{_YAML_TAG}seq"})


def _tag_name(tag: str) -> str:
    return "!!" + tag[len(_YAML_TAG) :] if tag.startswith(_YAML_TAG) else tag


def _tagged(tag: str, text: str) -> Any:
    """A scalar with an explicit tag (``!!int 3``); ValueError says what is wrong with it."""
    name = tag[len(_YAML_TAG) :] if tag.startswith(_YAML_TAG) else None
    if name == "str":
        return text
    plain = resolve_plain(text) if text else None
    if name == "int" and isinstance(plain, int) and not isinstance(plain, bool):
        return plain
    if name == "float" and isinstance(plain, (int, float)) and not isinstance(plain, bool):
        return float(plain)
    if name == "bool" and isinstance(plain, bool):
        return plain
    if name == "null" and plain is None:
        return None
    if name in ("int", "float", "bool", "null"):
        kinds = {"int": "an integer", "float": "a number", "bool": "true or false", "null": "null (~)"}
        raise ValueError(f"{text!r} is not {kinds[name]}, as its tag !!{name} says")
    raise ValueError(
        f"the tag {_tag_name(tag)} is not supported here; write the value without a tag "
        "(text, a number, true/false, a list or a mapping)"
    )


# --- composing the data from the parser's events, without recursion ---------------------------------

_NO_KEY: Any = object()
"""A mapping's frame is waiting for a key."""
_MERGE: Any = object()
"""A mapping's frame is waiting for the value of ``<<`` (a merge key)."""
_UNFINISHED: Any = object()
"""An anchor whose value is still being read: an alias to it would make the value contain itself."""
_MERGE_HELP = "'<<' merges mappings into this one: write '<<: *name' for an anchored mapping (&name), or a list of them"


class _Frame:
    """A mapping or list being read."""

    __slots__ = ("anchor", "count_before", "data", "is_map", "key", "key_element", "merge_role", "merges", "path")

    def __init__(self, is_map: bool, path: Path, anchor: str | None, count_before: int, merge_role: bool) -> None:
        self.is_map = is_map
        self.data: Any = {} if is_map else []
        self.path = path
        self.anchor = anchor
        self.count_before = count_before
        self.merge_role = merge_role
        """This collection is the value of ``<<``: it is merged into its parent, not stored in it."""
        self.key: Any = _NO_KEY
        self.key_element: str | int = ""
        self.merges: list[tuple[dict[Any, Any], Path]] | None = None


class _Reader:
    """Plain data from YAML text, with the marks of every key and value by path."""

    def __init__(self, path: FilePath, error_cls: type[InputFileError], text: str) -> None:
        self.path = path
        self.error_cls = error_cls
        self.text = text
        self.value_marks: dict[Path, tuple[int, int]] = {}
        self.key_marks: dict[Path, tuple[int, int]] = {}
        self.block_rows: dict[Path, list[tuple[int, int]]] = {}
        self.aliases: dict[Path, Path] = {}
        self.anchors: dict[str, Any] = {}
        """name -> (value, number of values it counts for, path where written), or _UNFINISHED."""
        self.count = 0
        self._lines: list[str] | None = None

    # messages

    def fail(self, mark: Any, message: str) -> NoReturn:
        """Raise the file's error at a parser's mark (0-based)."""
        self.fail_at((mark.line + 1, mark.column + 1), message)

    def fail_at(self, where: tuple[int, int], message: str) -> NoReturn:
        """Raise the file's error at a (1-based) line and column."""
        raise self.error_cls(f"{self.path}:{where[0]}:{where[1]}: {message}")

    def _too_many(self, mark: Any) -> NoReturn:
        limits.YAML_NODES.check(self.count, f"{self.path}:{mark.line + 1}:{mark.column + 1}")
        raise AssertionError("unreachable: the count is above the limit")  # pragma: no cover

    def lines(self) -> list[str]:
        """The text's lines, split where YAML splits them."""
        if self._lines is None:
            self._lines = re.split(r"\r\n|[\r\n\x85\u2028\u2029]", self.text)
        return self._lines

    # reading

    def read(self) -> Any:
        try:
            parser = _new_parser(self.text)
        except yaml.YAMLError as exc:  # pragma: no cover - the parser reads lazily
            raise self.error_cls(_syntax_message(self.path, self.lines(), exc)) from None
        try:
            return self._events(parser)
        except yaml.YAMLError as exc:
            raise self.error_cls(_syntax_message(self.path, self.lines(), exc)) from None
        finally:
            parser.dispose()

    def _events(self, parser: Any) -> Any:
        """The data of the one document in the parser's events: one flat loop over the event kinds,
        with an explicit stack of the collections being read (no recursion, however deep the input)."""
        get_event = parser.get_event
        values = self.value_marks
        node_limit = limits.YAML_NODES.value
        depth_limit = limits.NESTING.value
        stack: list[_Frame] = []
        top: _Frame | None = None
        root: Any = None
        path: Path
        documents = 0
        while True:
            event = get_event()
            kind = type(event)
            if kind is ScalarEvent:
                self.count += 1
                if self.count > node_limit:
                    self._too_many(event.start_mark)
                if event.tag is None:
                    text = event.value
                    if event.implicit[0]:  # plain: resolved by the YAML 1.2 core schema
                        try:
                            value = resolve_plain(text)
                        except ValueError:
                            self.fail(
                                event.start_mark,
                                f"an integer of {len(text):,} digits is longer than the {_INT_DIGITS:,} digits "
                                "Python reads; write it in quotes if it is text",
                            )
                        if top is not None and top.key is _NO_KEY and top.is_map and text == "<<":
                            value = _MERGE
                    else:
                        value = text
                elif event.tag in _STR_TAGS:
                    value = event.value
                else:
                    try:
                        value = _tagged(event.tag, event.value)
                    except ValueError as exc:
                        self.fail(event.start_mark, str(exc))
                mark = event.start_mark
                if top is None:
                    root = value
                    path = ()
                    values[path] = (mark.line + 1, mark.column + 1)
                elif top.key is _NO_KEY and top.is_map:
                    self._key(top, value, mark)
                    path = (*top.path, top.key_element)
                else:
                    if top.key is _MERGE:
                        self.fail(mark, f"{_MERGE_HELP}; got {_shown(value)}")
                    path = (*top.path, top.key_element) if top.is_map else (*top.path, len(top.data))
                    values[path] = (mark.line + 1, mark.column + 1)
                    if event.style in ("|", ">"):
                        self.block_rows[path] = self._content_rows(event)
                    if top.is_map:
                        top.data[top.key] = value
                        top.key = _NO_KEY
                    else:
                        top.data.append(value)
                if event.anchor is not None:
                    self.anchors[event.anchor] = (value, 1, path)
            elif kind is MappingStartEvent or kind is SequenceStartEvent:
                is_map = kind is MappingStartEvent
                mark = event.start_mark
                if len(stack) >= depth_limit:
                    limits.NESTING.check(len(stack) + 1, f"{self.path}:{mark.line + 1}:{mark.column + 1}")
                if event.tag not in (_MAP_TAGS if is_map else _SEQ_TAGS):
                    self.fail(
                        mark, f"the tag {_tag_name(event.tag)} is not supported here; write the value without a tag"
                    )
                merge_role = False
                if top is None:
                    path = ()
                elif top.is_map:
                    if top.key is _NO_KEY:
                        self.fail(mark, "a key must be a plain value (text or a number), not a mapping or a list")
                    merge_role = top.key is _MERGE
                    path = (*top.path, "<<" if merge_role else top.key_element)
                else:
                    path = (*top.path, len(top.data))
                values[path] = (mark.line + 1, mark.column + 1)
                if event.anchor is not None:
                    self.anchors[event.anchor] = _UNFINISHED
                top = _Frame(is_map, path, event.anchor, self.count, merge_role)
                stack.append(top)
                self.count += 1
                if self.count > node_limit:
                    self._too_many(mark)
            elif kind is MappingEndEvent or kind is SequenceEndEvent:
                frame = stack.pop()
                top = stack[-1] if stack else None
                data = frame.data
                if frame.merges is not None:
                    data = self._merged(frame)
                if frame.anchor is not None:
                    self.anchors[frame.anchor] = (data, self.count - frame.count_before, frame.path)
                if top is None:
                    root = data
                elif frame.merge_role:
                    self._add_merge(top, data, frame.path, values[frame.path], listed=not frame.is_map)
                elif top.is_map:
                    top.data[top.key] = data
                    top.key = _NO_KEY
                else:
                    top.data.append(data)
            elif kind is AliasEvent:
                self._alias(top, event)
                if top is None:
                    root = self.anchors[event.anchor][0]  # pragma: no cover - an alias cannot start a document
            elif kind is DocumentStartEvent:
                documents += 1
                if documents > 1:
                    self.fail(
                        event.start_mark,
                        "a second YAML document starts here (after '---'); a file holds one document",
                    )
            elif kind is StreamEndEvent:
                return root

    def _key(self, top: _Frame, key: Any, mark: Any) -> None:
        """``key`` (a scalar or an alias to one) was read where ``top`` waits for a key."""
        if key is _MERGE:
            if top.merges is not None:
                self.fail(
                    mark, f"{format_path((*top.path, '<<'))}: duplicate key '<<' (merge every mapping in one list)"
                )
            top.merges = []
            top.key = _MERGE
            return
        if key is None or not isinstance(key, (str, int, float)):
            got = "empty (null)" if key is None else "a mapping" if isinstance(key, dict) else "a list"
            self.fail(mark, f"a key must be a plain value (text or a number), got {got}")
        if key in top.data:
            where = format_path((*top.path, str(key)))
            self.fail(mark, f"{where}: duplicate key {key!r} (YAML would silently keep only the last one)")
        top.key = key
        top.key_element = key if isinstance(key, str) else str(key)
        self.key_marks[(*top.path, top.key_element)] = (mark.line + 1, mark.column + 1)

    def _alias(self, top: _Frame | None, event: Any) -> None:
        name, mark = event.anchor, event.start_mark
        anchor = self.anchors.get(name)
        if anchor is None:
            self.fail(mark, f"*{name}: no anchor &{name} is defined before this alias")
        if anchor is _UNFINISHED:
            self.fail(mark, f"*{name} is inside the value anchored &{name}: a value cannot contain itself")
        value, size, written = anchor
        self.count += size
        if self.count > limits.YAML_NODES.value:
            self._too_many(mark)
        if top is None:  # pragma: no cover - the parser needs an anchor first
            return
        if top.is_map and top.key is _NO_KEY:
            self._key(top, value, mark)
            return
        if top.key is _MERGE:
            self._add_merge(top, value, written, (mark.line + 1, mark.column + 1), listed=isinstance(value, list))
            return
        path = (*top.path, top.key_element) if top.is_map else (*top.path, len(top.data))
        self.value_marks[path] = (mark.line + 1, mark.column + 1)
        self.aliases[path] = written
        if top.is_map:
            top.data[top.key] = value
            top.key = _NO_KEY
        else:
            top.data.append(value)

    def _add_merge(self, top: _Frame, value: Any, written: Path, where: tuple[int, int], *, listed: bool) -> None:
        """The value of ``<<`` in ``top``: a mapping, or a list of mappings, to merge."""
        assert top.merges is not None
        top.key = _NO_KEY
        if isinstance(value, dict):
            top.merges.append((value, written))
            return
        if listed and isinstance(value, list):
            for index, item in enumerate(value):
                item_path = (*written, index)
                if not isinstance(item, dict):
                    item_where = self.value_marks.get(item_path, where)
                    self.fail_at(item_where, f"{_MERGE_HELP}; got {_shown(item)} in the list")
                top.merges.append((item, self._follow(item_path)))
            return
        self.fail_at(where, f"{_MERGE_HELP}; got {_shown(value)}")

    def _follow(self, path: Path) -> Path:
        for _ in range(len(self.aliases) + 1):
            if path not in self.aliases:
                break
            path = self.aliases[path]
        return path

    def _merged(self, frame: _Frame) -> dict[Any, Any]:
        """The mapping with its ``<<`` sources merged in, as PyYAML orders them: a key written in the
        mapping wins over a merged one, an earlier source over a later one."""
        assert frame.merges is not None
        explicit: dict[Any, Any] = frame.data
        merged: dict[Any, Any] = {}
        origin: dict[Any, Path] = {}
        for source, written in reversed(frame.merges):
            for key, value in source.items():
                merged[key] = value
                origin[key] = written
        result: dict[Any, Any] = {}
        for key, value in merged.items():
            if key in explicit:
                result[key] = explicit[key]
            else:
                result[key] = value
                element = key if isinstance(key, str) else str(key)
                self.aliases[(*frame.path, element)] = (*origin[key], element)
        for key, value in explicit.items():
            if key not in result:
                result[key] = value
        return result

    def _content_rows(self, event: Any) -> list[tuple[int, int]]:
        """(1-based line, indentation) of each non-blank line of a block scalar's content."""
        lines = self.lines()
        first, last = event.start_mark.line + 1, min(event.end_mark.line, len(lines) - 1)
        return [
            (i + 1, len(lines[i]) - len(lines[i].lstrip()))
            for i in range(first, last + 1)
            if lines[i].strip() and not lines[i].lstrip().startswith("#")
        ]


def _shown(value: Any) -> str:
    """A value as a message shows it after "got"."""
    if isinstance(value, bool):
        return f"{'true' if value else 'false'} (a boolean)"
    if value is None:
        return "an empty value (null)"
    if isinstance(value, dict):
        return "a mapping"
    if isinstance(value, list):
        return f"a list of {len(value)} item{'s' if len(value) != 1 else ''}"
    if isinstance(value, str):
        return repr(value if len(value) <= 60 else value[:57] + "...")
    if isinstance(value, int) and abs(value) >= 10**40:
        return f"an integer of {len(str(abs(value))):,} digits"
    return repr(value)


# --- YAML syntax errors in plain words ------------------------------------------------------------

_TAB_MESSAGE = "a tab indents this line; YAML indents with spaces only"


def _syntax_message(path: FilePath, lines: list[str], exc: yaml.YAMLError) -> str:
    """``file:line:col: YAML syntax error: ...`` from libyaml's (or PyYAML's) error."""
    if isinstance(exc, yaml.reader.ReaderError):
        before = "\n".join(lines)[: exc.position]
        line = before.count("\n") + 1
        column = len(before) - (before.rfind("\n") + 1) + 1
        character = exc.character if isinstance(exc.character, int) else ord(exc.character or "\0")
        return f"{path}:{line}:{column}: YAML syntax error: the control character #x{character:04x} is not allowed here"
    if not isinstance(exc, yaml.MarkedYAMLError):
        return f"{path}: YAML syntax error: {exc}"
    problem = exc.problem or "invalid YAML"
    mark = exc.problem_mark or exc.context_mark
    line, column = (mark.line + 1, mark.column + 1) if mark else (1, 1)
    begun = exc.context_mark
    text = lines[line - 1] if 0 < line <= len(lines) else ""
    here = text[column - 1] if 0 < column <= len(text) else ""
    cannot_start = problem.startswith("found character") and problem.endswith("cannot start any token")
    if problem == "found a tab character that violates indentation" or (cannot_start and here == "\t"):
        if text[: column - 1].strip():
            return f"{path}:{line}:{column}: YAML syntax error: a tab here; YAML separates and indents with spaces only"
        return f"{path}:{line}:{column}: YAML syntax error: {_TAB_MESSAGE}"
    if cannot_start and here:
        return (
            f"{path}:{line}:{column}: YAML syntax error: {here!r} cannot start a value; "
            "put the value in quotes if it is text"
        )
    if problem == "could not find expected ':'" and begun is not None:
        line, column = begun.line + 1, begun.column + 1
        written = lines[begun.line][begun.column :].strip() if begun.line < len(lines) else ""
        shown = repr(written if len(written) <= 40 else written[:37] + "...")
        return (
            f"{path}:{line}:{column}: YAML syntax error: a colon is missing: {shown} is not followed by ':' "
            "(a mapping's lines are 'key: value'), or the line is indented wrongly"
        )
    if problem.startswith("mapping values are not allowed"):
        return (
            f"{path}:{line}:{column}: YAML syntax error: a colon is misplaced here: 'key: value' cannot start in "
            "the middle of a value. A value that contains ': ' needs quotes; otherwise a colon is missing on an "
            "earlier line, or this line is indented too deep"
        )
    if problem == "found unexpected end of stream" and begun is not None and "quoted" in (exc.context or ""):
        return f"{path}:{begun.line + 1}:{begun.column + 1}: YAML syntax error: the quote opened here is never closed"
    if problem == "did not find expected key" and begun is not None and "block mapping" in (exc.context or ""):
        return (
            f"{path}:{line}:{column}: YAML syntax error: expected a 'key: value' line here, indented like the keys "
            f"of the mapping that starts at line {begun.line + 1}, column {begun.column + 1}; is this line indented "
            "wrongly, or something left over after a value?"
        )
    context = f" ({exc.context})" if exc.context else ""
    if begun is not None and exc.problem_mark is not None and begun.line != exc.problem_mark.line:
        context = f" ({exc.context or 'what'} started at line {begun.line + 1}, column {begun.column + 1})"
    return f"{path}:{line}:{column}: YAML syntax error: {problem}{context}"


# --- validation -----------------------------------------------------------------------------------


def validate_source(
    source: Source,
    model_cls: type[_Model],
    error_cls: type[InputFileError],
    *,
    context: dict[str, Any] | None = None,
) -> _Model:
    """Validate ``source.data`` into ``model_cls``; every failure names file, line and field."""
    if source.data is None:
        raise error_cls(f"{source.path}: the file is empty")
    try:
        with _gc_paused():
            return model_cls.model_validate(source.data, context=context)
    except FieldError as exc:
        raise error_cls(source.format(exc.path, exc.message, row=exc.row, column=exc.column)) from None
    except ValidationError as exc:
        messages = [_describe(source, model_cls, error) for error in exc.errors()]
        shown = messages[:_MAX_ERRORS_SHOWN]
        if len(messages) > len(shown):
            shown.append(f"... and {len(messages) - len(shown)} more problems")
        raise error_cls("\n".join(shown)) from None


def refuse_field_name(model_cls: type[BaseModel], data: Any, name: str) -> None:
    """Raise when ``data`` uses the Python name of a field that files must write by its alias.

    ``populate_by_name`` lets code build a model with the field's own name; a file may not."""
    if isinstance(data, dict) and name in data:
        keys = sorted({f.alias or key for key, f in model_cls.model_fields.items()})
        raise FieldError((name,), f"unknown key {name!r}; expected one of: {', '.join(keys)}")


_PATTERN_WORDS = {
    r"^[A-Za-z0-9_\-]+$": "should use only letters, digits, '_' and '-'",
    r"^[a-z][a-z0-9_]*$": "should start with a lowercase letter and use only lowercase letters, digits and '_'",
}
"""The patterns of the schemas' names (semantic_map/schema.py, knowledge/domain.py), in words."""

_KIND_WORDS = {
    "int_type": "should be an integer",
    "int_parsing": "should be an integer",
    "int_from_float": "should be a whole number",
    "float_type": "should be a number",
    "float_parsing": "should be a number",
    "bool_type": "should be true or false",
    "bool_parsing": "should be true or false",
    "string_type": "should be text",
    "dict_type": "should be a mapping ('key: value' lines or {key: value})",
    "model_type": "should be a mapping ('key: value' lines or {key: value})",
    "model_attributes_type": "should be a mapping ('key: value' lines or {key: value})",
    "list_type": "should be a list",
    "tuple_type": "should be a list",
    "set_type": "should be a list",
    "finite_number": "should be a finite number",
}
"""pydantic's error types whose own message speaks of Python ("a valid dictionary or instance of")."""


def _describe(source: Source, model_cls: type[BaseModel], error: Any) -> str:
    loc: Path = tuple(error["loc"])
    kind = error["type"]
    given = error.get("input")
    ctx = error.get("ctx") or {}
    on_key = bool(loc) and loc[-1] == "[key]"
    if on_key:
        loc = loc[:-1]
    if (on_key or kind == "invalid_key") and loc and isinstance(given, (str, int, float)):
        # pydantic writes a key True as 1 in the loc; the file's paths spell keys as text
        loc, on_key = (*loc[:-1], given if isinstance(given, str) else str(given)), True
        if kind in ("string_type", "invalid_key"):
            return source.format(loc, f"a key should be text, got {_shown(given)}; write it in quotes", key=True)
    if kind == "extra_forbidden":
        key = loc[-1]
        expected = _field_names(_models_at(model_cls, loc[:-1]))
        hint = f"; expected one of: {', '.join(expected)}" if expected else ""
        return source.format(loc, f"unknown key {key!r}{hint}", key=True)
    if kind == "missing" and loc and isinstance(loc[-1], int):  # a fixed-size tuple with too few items
        given_items = _data_at(source.data, loc[:-1])
        size = _tuple_size(_annotations_at(model_cls, loc[:-1]))
        got = f", got {len(given_items)}" if isinstance(given_items, list) else ""
        wanted = f"{size} items" if size is not None else f"at least {loc[-1] + 1} items"
        return source.format(loc[:-1], f"should have {wanted}{got}")
    if kind == "missing":
        found, _ = source.locate(loc[:-1])
        return source.format(found, f"required key {loc[-1]!r} is missing")
    if kind in ("union_tag_invalid", "union_tag_not_found"):
        # a discriminated union (a sensor's type): say which kinds exist, at the 'type' key
        key = str(ctx.get("discriminator", "type")).strip("'")
        kinds = ", ".join(_tags(_models_at(model_cls, loc), key))
        noun = f"{loc[-2].rstrip('s')} " if len(loc) >= 2 and isinstance(loc[-2], str) else ""
        if kind == "union_tag_not_found":
            return source.format(loc, f"required key {key!r} is missing; it says which kind: {kinds}")
        tag = ctx.get("tag", given)
        return source.format((*loc, key), f"unknown {noun}{key} {tag!r}; expected one of: {kinds}")
    message = _plain_message(kind, str(error["msg"]), ctx, given, lambda: _annotations_at(model_cls, loc))
    return source.format(loc, message, key=on_key)


def _plain_message(
    kind: str, message: str, ctx: dict[str, Any], given: Any, annotations: Callable[[], list[Any]]
) -> str:
    """pydantic's message for an error, in the words of someone writing YAML."""
    if kind in ("value_error", "assertion_error"):
        for prefix in ("Value error, ", "Assertion failed, "):
            message = message.removeprefix(prefix)
        return message
    if kind in _KIND_WORDS:
        message = _KIND_WORDS[kind]
        if kind == "string_type" and isinstance(given, (int, float)) and not isinstance(given, bool):
            message += " (write it in quotes)"
    elif kind == "string_pattern_mismatch":
        pattern = str(ctx.get("pattern", ""))
        message = _PATTERN_WORDS.get(pattern, f"does not have the form this field takes (the pattern {pattern})")
        if given == "":
            return f"should not be empty; it {message}"
    elif kind in ("too_long", "too_short"):
        count = ctx.get("actual_length")
        bound = ctx.get("max_length" if kind == "too_long" else "min_length")
        size = _tuple_size(annotations()) if ctx.get("field_type") == "Tuple" else None
        if size is not None:
            message = f"should have {size} item{'s' if size != 1 else ''}"
        else:
            message = (
                f"should have {'at most' if kind == 'too_long' else 'at least'} {bound} item{'s' if bound != 1 else ''}"
            )
        return f"{message}, got {count}" if count is not None else message
    elif kind == "string_too_long" and isinstance(given, str):
        return f"should have at most {ctx.get('max_length')} characters, got {len(given):,}"
    elif kind == "string_too_short" and isinstance(given, str):
        wanted = ctx.get("min_length")
        return "should not be empty" if wanted == 1 else f"should have at least {wanted} characters, got {len(given)}"
    else:
        message = message.replace(" after validation", "")
        if message.startswith("Input should"):
            message = "should" + message[len("Input should") :]
        elif message.startswith(("String should", "List should", "Tuple should", "Dictionary should")):
            message = "should" + message.split("should", 1)[1]
    if " got " in f" {message}":
        return message
    return f"{message}, got {_shown(given)}"


def _data_at(data: Any, path: Path) -> Any:
    """The value at ``path`` in ``data``, or None."""
    for element in path:
        if isinstance(data, dict) and element in data:
            data = data[element]
            continue
        if not isinstance(data, list) or not isinstance(element, int) or not 0 <= element < len(data):
            return None
        data = data[element]
    return data


def _tuple_size(annotations: list[Any]) -> int | None:
    """The number of items of a fixed-size tuple among ``annotations`` (``tuple[int, int]``: 2)."""
    for annotation in annotations:
        for inner in _unwrap(annotation):
            args = typing.get_args(inner)
            if typing.get_origin(inner) is tuple and args and Ellipsis not in args:
                return len(args)
    return None


def _field(model: type[BaseModel], name: str) -> Any:
    """The annotation of the field a file writes as ``name`` (its alias, or its own name)."""
    fields = model.model_fields
    if name in fields and fields[name].alias in (None, name):
        return fields[name].annotation
    for info in fields.values():
        if info.alias == name:
            return info.annotation
    return fields[name].annotation if name in fields else None


def _annotations_at(model_cls: type[BaseModel], loc: Path) -> list[Any]:
    """Best effort: the annotations that may sit at ``loc`` (several for a union)."""
    candidates: list[Any] = [model_cls]
    for element in loc:
        next_candidates: list[Any] = []
        for candidate in candidates:
            for inner in _unwrap(candidate):
                if isinstance(inner, type) and issubclass(inner, BaseModel):
                    annotation = _field(inner, element) if isinstance(element, str) else None
                    if annotation is not None:
                        next_candidates.append(annotation)
                    elif isinstance(element, str) and element in _tags([inner], "type"):
                        next_candidates.append(inner)  # pydantic puts a union member's tag in the loc
                else:
                    origin = typing.get_origin(inner)
                    args = typing.get_args(inner)
                    if origin is tuple and args and Ellipsis not in args:
                        if isinstance(element, int) and 0 <= element < len(args):
                            next_candidates.append(args[element])
                    elif origin in (list, tuple) and args:
                        next_candidates.append(args[0])
                    elif origin is dict and len(args) == 2:
                        next_candidates.append(args[1])
        candidates = next_candidates
    return candidates


def _models_at(model_cls: type[BaseModel], loc: Path) -> list[type[BaseModel]]:
    """Best effort: the pydantic models that may sit at ``loc`` (several for a union)."""
    return [
        m
        for c in _annotations_at(model_cls, loc)
        for m in _unwrap(c)
        if isinstance(m, type) and issubclass(m, BaseModel)
    ]


def _field_names(models: list[type[BaseModel]]) -> list[str]:
    """The keys a mapping may have, when exactly one model sits there."""
    if len(models) != 1:
        return []
    return sorted({f.alias or n for n, f in models[0].model_fields.items()})  # two fields may share an alias


def _tags(models: list[type[BaseModel]], key: str) -> list[str]:
    """The values of a Literal discriminator field ``key`` over union members."""
    tags: list[str] = []
    for model in models:
        field_info = model.model_fields.get(key)
        if field_info is not None and typing.get_origin(field_info.annotation) is typing.Literal:
            tags.extend(str(v) for v in typing.get_args(field_info.annotation))
    return tags


def _unwrap(annotation: Any) -> list[Any]:
    """Members of a Union/Optional/Annotated annotation, else the annotation itself."""
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        return _unwrap(typing.get_args(annotation)[0])
    if origin is typing.Union or origin is types.UnionType:
        out: list[Any] = []
        for arg in typing.get_args(annotation):
            out.extend(_unwrap(arg))
        return out
    return [annotation]
