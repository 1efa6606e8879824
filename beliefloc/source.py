"""Hand-written YAML/JSON input files, validated with pydantic, with errors that point at the line.

The one way every input file (maps, belief files, domains) is read:

1. :func:`read_source` composes the YAML into nodes and builds plain Python data, remembering
   where (line, column) each value and key was written, keyed by its path from the root.
2. :func:`validate_source` runs a pydantic model over the data. A pydantic error's ``loc`` or a
   :class:`~beliefloc.errors.FieldError`'s ``path`` is mapped back to the line, so a message reads
   ``maps/kitchen.yaml:14:5: sensors.look.false_positive: should be less than or equal to 1, got 1.5``.
"""

from __future__ import annotations

import contextlib
import gc
import hashlib
import types
import typing
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path as FilePath
from typing import Any, TypeVar

import yaml
from pydantic import BaseModel, ValidationError

from beliefloc.errors import BeliefLocError, FieldError, InputFileError, Path

_Model = TypeVar("_Model", bound=BaseModel)
_MAX_ERRORS_SHOWN = 6

try:  # the C composer is several times faster on large generated maps
    _Loader: type[yaml.SafeLoader] = yaml.CSafeLoader  # type: ignore[assignment,unused-ignore]
except AttributeError:  # pragma: no cover - pyyaml built without libyaml
    _Loader = yaml.SafeLoader


@contextlib.contextmanager
def _gc_paused() -> Iterator[None]:
    """Pause the cyclic garbage collector while building many small acyclic objects.

    A 10^6-state generated map is ~600,000 YAML nodes; every few hundred allocations the collector
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


_STR_TAG = "tag:yaml.org,2002:str"
_PLAIN_SCALAR_TAGS = frozenset(f"tag:yaml.org,2002:{name}" for name in ("int", "float", "bool", "null"))


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

    def locate(self, path: Path, *, key: bool = False) -> tuple[Path, tuple[int, int]]:
        """The part of ``path`` that exists in the file and its (line, column), both 1-based.

        Elements that are not in the file (a pydantic union tag, say) are skipped; a path that
        leads nowhere resolves to its longest existing prefix.
        """
        found: Path = ()
        for element in path:
            candidate = (*found, element)
            if candidate in self.value_marks:
                found = candidate
        marks = self.key_marks if key and found in self.key_marks else self.value_marks
        return found, marks.get(found, (1, 1))

    def error(self, path: Path, message: str, error_cls: type[InputFileError], *, key: bool = False) -> InputFileError:
        """An error naming this file, the line and column of ``path``, and the field."""
        return error_cls(self.format(path, message, key=key))

    def format(self, path: Path, message: str, *, key: bool = False, row: int | None = None, column: int = 0) -> str:
        """``file:line:col: field.path: message``; with ``row``, the line of that row of a block."""
        found, (line, col) = self.locate(path, key=key)
        rows = self.block_rows.get(found)
        if row is not None and rows is not None and 0 <= row < len(rows):
            line, col = rows[row][0], rows[row][1] + column + 1
        column = col
        where = format_path(found)
        return f"{self.path}:{line}:{column}: {where + ': ' if where else ''}{message}"


def format_path(path: Path) -> str:
    """``("sensors", "look", "classes", 2)`` -> ``sensors.look.classes[2]``."""
    text = ""
    for element in path:
        if isinstance(element, int):
            text += f"[{element}]"
        else:
            text += f".{element}" if text else str(element)
    return text


def read_text(path: str | FilePath, error_cls: type[BeliefLocError]) -> tuple[str, bytes]:
    """A UTF-8 text file and its bytes; every failure is ``error_cls`` naming the file."""
    file_path = FilePath(path)
    try:
        raw = file_path.read_bytes()
    except FileNotFoundError:
        raise error_cls(f"{file_path}: no such file") from None
    except IsADirectoryError:
        raise error_cls(f"{file_path}: is a directory, not a file") from None
    except OSError as exc:
        raise error_cls(f"{file_path}: cannot be read ({exc.strerror})") from None
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
    try:
        with _gc_paused():
            node = yaml.compose(text, Loader=_Loader)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line, column = (mark.line + 1, mark.column + 1) if mark else (1, 1)
        problem = exc.problem or "invalid YAML"
        context = f" ({exc.context})" if exc.context else ""
        begun = exc.context_mark
        if begun is not None and exc.problem_mark is not None and begun.line != exc.problem_mark.line:
            context = f" ({exc.context or 'what'} started at line {begun.line + 1}, column {begun.column + 1})"
        raise error_cls(f"{path}:{line}:{column}: YAML syntax error: {problem}{context}") from None
    except yaml.YAMLError as exc:
        raise error_cls(f"{path}: YAML syntax error: {exc}") from None
    digest = sha256 or hashlib.sha256(text.encode()).hexdigest()
    if node is None:
        return Source(path=path, data=None, sha256=digest)
    builder = _Builder(path, error_cls, text)
    with _gc_paused():
        data = builder.build(node, ())
    return Source(path, data, digest, builder.value_marks, builder.key_marks, builder.block_rows)


class _Builder:
    """Turns composed YAML nodes into plain data while recording marks by path."""

    def __init__(self, path: FilePath, error_cls: type[InputFileError], text: str) -> None:
        self.path = path
        self.text = text
        self.block_rows: dict[Path, list[tuple[int, int]]] = {}
        self.error_cls = error_cls
        self.constructor = yaml.constructor.SafeConstructor()
        self.value_marks: dict[Path, tuple[int, int]] = {}
        self.key_marks: dict[Path, tuple[int, int]] = {}

    def _where(self, node: yaml.Node) -> tuple[int, int]:
        return node.start_mark.line + 1, node.start_mark.column + 1

    def construct(self, node: yaml.Node) -> Any:
        """``constructor.construct_object(node, deep=True)``, with the common scalars done directly
        (the same constructor functions, without the bookkeeping meant for collections)."""
        if isinstance(node, yaml.ScalarNode):
            if node.tag == _STR_TAG:
                return node.value  # what construct_yaml_str returns for a scalar
            if node.tag in _PLAIN_SCALAR_TAGS:
                return self.constructor.yaml_constructors[node.tag](self.constructor, node)
        return self.constructor.construct_object(node, deep=True)

    def _content_rows(self, node: yaml.ScalarNode) -> list[tuple[int, int]]:
        """(1-based line, indentation) of each non-blank line of a block scalar's content."""
        lines = self.text.splitlines()
        first, last = node.start_mark.line + 1, min(node.end_mark.line, len(lines) - 1)
        return [
            (i + 1, len(lines[i]) - len(lines[i].lstrip()))
            for i in range(first, last + 1)
            if lines[i].strip() and not lines[i].lstrip().startswith("#")
        ]

    def build(self, node: yaml.Node, path: Path) -> Any:
        mark = node.start_mark
        self.value_marks[path] = (mark.line + 1, mark.column + 1)
        if isinstance(node, yaml.MappingNode):
            self.constructor.flatten_mapping(node)  # resolves YAML merge keys (<<)
            result: dict[Any, Any] = {}
            for key_node, value_node in node.value:
                key = self.construct(key_node)
                if not isinstance(key, (str, int, float, bool)) or key is None:
                    line, column = self._where(key_node)
                    raise self.error_cls(f"{self.path}:{line}:{column}: a key must be a plain value")
                if key in result:
                    line, column = self._where(key_node)
                    where = format_path((*path, str(key)))
                    raise self.error_cls(
                        f"{self.path}:{line}:{column}: {where}: duplicate key {key!r} "
                        "(YAML would silently keep only the last one)"
                    )
                child = (*path, key if isinstance(key, str) else str(key))
                self.key_marks[child] = self._where(key_node)
                result[key] = self.build(value_node, child)
            return result
        if isinstance(node, yaml.SequenceNode):
            return [self.build(item, (*path, index)) for index, item in enumerate(node.value)]
        if isinstance(node, yaml.ScalarNode) and node.style in ("|", ">"):
            self.block_rows[path] = self._content_rows(node)
        try:
            return self.construct(node)
        except yaml.constructor.ConstructorError as exc:
            line, column = self._where(node)
            raise self.error_cls(f"{self.path}:{line}:{column}: {exc.problem}") from None


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


def _describe(source: Source, model_cls: type[BaseModel], error: Any) -> str:
    loc: Path = tuple(error["loc"])
    kind = error["type"]
    given = error.get("input")
    if kind == "extra_forbidden":
        key = loc[-1]
        expected = _field_names(_models_at(model_cls, loc[:-1]))
        hint = f"; expected one of: {', '.join(expected)}" if expected else ""
        return source.format(loc, f"unknown key {key!r}{hint}", key=True)
    if kind == "missing":
        found, _ = source.locate(loc[:-1])
        return source.format(found, f"required key {loc[-1]!r} is missing")
    if kind in ("union_tag_invalid", "union_tag_not_found"):
        # a discriminated union (a sensor's type): say which kinds exist, at the 'type' key
        key = str(error.get("ctx", {}).get("discriminator", "type")).strip("'")
        kinds = ", ".join(_tags(_models_at(model_cls, loc), key))
        noun = f"{loc[-2].rstrip('s')} " if len(loc) >= 2 and isinstance(loc[-2], str) else ""
        if kind == "union_tag_not_found":
            return source.format(loc, f"required key {key!r} is missing; it says which kind: {kinds}")
        tag = error.get("ctx", {}).get("tag", given)
        return source.format((*loc, key), f"unknown {noun}{key} {tag!r}; expected one of: {kinds}")
    message = str(error["msg"])
    for prefix in ("Value error, ", "Assertion failed, "):
        message = message.removeprefix(prefix)
    if message.startswith("Input should"):
        message = "should" + message[len("Input should") :]
    if kind not in ("value_error", "assertion_error") and isinstance(given, (str, int, float, bool)):
        message += f", got {given!r}"
    return source.format(loc, message)


def _models_at(model_cls: type[BaseModel], loc: Path) -> list[type[BaseModel]]:
    """Best effort: the pydantic models that may sit at ``loc`` (several for a union)."""
    candidates: list[Any] = [model_cls]
    for element in loc:
        next_candidates: list[Any] = []
        for candidate in candidates:
            for inner in _unwrap(candidate):
                if isinstance(inner, type) and issubclass(inner, BaseModel):
                    if isinstance(element, str) and element in inner.model_fields:
                        next_candidates.append(inner.model_fields[element].annotation)
                    elif isinstance(element, str) and element in _tags([inner], "type"):
                        next_candidates.append(inner)  # pydantic puts a union member's tag in the loc
                else:
                    origin = typing.get_origin(inner)
                    args = typing.get_args(inner)
                    if origin in (list, tuple) and args:
                        next_candidates.append(args[0])
                    elif origin is dict and len(args) == 2:
                        next_candidates.append(args[1])
        candidates = next_candidates
    return [m for c in candidates for m in _unwrap(c) if isinstance(m, type) and issubclass(m, BaseModel)]


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
