"""YAML read as YAML 1.2 core schema, from the parser's events, without recursion, into data and marks."""

from __future__ import annotations

import hashlib
import math
import re
import sys
from collections.abc import Callable
from pathlib import Path as FilePath
from typing import Any, NoReturn

import yaml
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

from beliefloc.errors import InputFileError, Path
from beliefloc.source import limits
from beliefloc.source.files import read_text
from beliefloc.source.located import Source, format_path, gc_paused, shown_value

_new_parser: Callable[[str], Any]
try:  # libyaml's parser: several times faster on large generated maps, and (unlike its composer) not recursive
    from yaml._yaml import CParser as _CParser

    _new_parser = _CParser
except ImportError:  # pragma: no cover - pyyaml built without libyaml; its Python parser is not recursive either
    _new_parser = yaml.SafeLoader


def read_source(path: str | FilePath, error_cls: type[InputFileError]) -> Source:
    """Read and parse a YAML (or JSON) file, keeping the marks of every key and value."""
    text, raw = read_text(path, error_cls)
    digest = hashlib.sha256(raw).hexdigest()
    try:
        return parse_source(text, FilePath(path), error_cls, sha256=digest)
    except error_cls:
        if FilePath(path).suffix.lower() != ".json":
            raise
        data = _plain_json(text)  # what YAML cannot read but JSON can: a key of over 1,024 characters
        if data is _NOT_JSON:
            raise
        return Source(FilePath(path), data, digest)


_NOT_JSON = object()


def _plain_json(text: str) -> Any:
    """``text`` read by :mod:`json` (a JSON file YAML refused: PyYAML takes no key longer than 1,024
    characters), or ``_NOT_JSON`` when it is not JSON either, repeats a key, holds NaN or nests deeper
    than :data:`~beliefloc.source.limits.NESTING`. Without marks: an error names the key's path."""
    import json

    def pairs(items: list[tuple[str, Any]]) -> dict[str, Any]:
        out = dict(items)
        if len(out) != len(items):
            raise ValueError("a repeated key")
        return out

    def constant(name: str) -> Any:
        raise ValueError(f"{name} is not JSON")

    try:
        data = json.loads(text, object_pairs_hook=pairs, parse_constant=constant)
    except (ValueError, RecursionError):
        return _NOT_JSON
    depth, level = 0, [(data, 1)]
    while level:
        value, here = level.pop()
        depth = max(depth, here)
        if isinstance(value, dict):
            level.extend((v, here + 1) for v in value.values())
        elif isinstance(value, list):
            level.extend((v, here + 1) for v in value)
    return _NOT_JSON if depth > limits.NESTING.value else data


def parse_source(text: str, path: FilePath, error_cls: type[InputFileError], *, sha256: str | None = None) -> Source:
    """Parse YAML text that came from ``path`` (used for messages only)."""
    reader = _Reader(path, error_cls, text)
    with gc_paused():
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
                        self.fail(mark, f"{_MERGE_HELP}; got {shown_value(value)}")
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
                    self.fail_at(item_where, f"{_MERGE_HELP}; got {shown_value(item)} in the list")
                top.merges.append((item, self._follow(item_path)))
            return
        self.fail_at(where, f"{_MERGE_HELP}; got {shown_value(value)}")

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
    if problem.startswith("exceeded maximum nesting depth"):  # libyaml >= 0.2.6 (PyYAML 6.0.4) scans ahead
        return (
            f"{path}:{line}:{column}: more levels of nesting than the YAML parser reads ({problem}); "
            f"beliefloc reads at most {limits.NESTING.value} (BELIEFLOC_MAX_NESTING)"
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
