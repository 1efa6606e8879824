"""Validating parsed data with a pydantic model; every failure in plain words at its line."""

from __future__ import annotations

import types
import typing
from collections.abc import Callable
from typing import Any, TypeVar

from pydantic import BaseModel, ValidationError

from beliefloc.errors import FieldError, FieldErrors, InputFileError, Path
from beliefloc.source.located import Source, data_at, gc_paused, shown_value

_Model = TypeVar("_Model", bound=BaseModel)
MAX_ERRORS_SHOWN = 20
"""The most problems of one file a message lists (then "... and N more problems")."""


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
        with gc_paused():
            return model_cls.model_validate(source.data, context=context)
    except FieldError as exc:
        raise error_cls(source.format(exc.path, exc.message, row=exc.row, column=exc.column)) from None
    except FieldErrors as exc:
        found = [source.format(e.path, e.message, row=e.row, column=e.column) for e in exc.errors]
        raise error_cls(_listed(found)) from None
    except ValidationError as exc:
        raise error_cls(_listed([_describe(source, model_cls, error) for error in exc.errors()])) from None


def _listed(messages: list[str]) -> str:
    """Every problem on its own line, at most :data:`MAX_ERRORS_SHOWN` of them."""
    shown = messages[:MAX_ERRORS_SHOWN]
    if len(messages) > len(shown):
        shown.append(f"... and {len(messages) - len(shown)} more problems")
    return "\n".join(shown)


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
            return source.format(loc, f"a key should be text, got {shown_value(given)}; write it in quotes", key=True)
    if kind == "extra_forbidden":
        key = loc[-1]
        expected = _field_names(_models_at(model_cls, loc[:-1]))
        hint = f"; expected one of: {', '.join(expected)}" if expected else ""
        return source.format(loc, f"unknown key {key!r}{hint}", key=True)
    if kind == "missing" and loc and isinstance(loc[-1], int):  # a fixed-size tuple with too few items
        given_items = data_at(source.data, loc[:-1])
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
    return f"{message}, got {shown_value(given)}"


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
