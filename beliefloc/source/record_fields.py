"""The fields of a record read back from a results file (``--resume``, ``summarize``), checked as
strictly as the file's header: a boolean is never a number, text is never a number, a count is a whole
number in range, a number is finite. Each reader raises :class:`ValueError` naming the field; the
results-file reader turns it into a one-paragraph error naming the file and line."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from typing import Any

LARGEST_WHOLE = 2**62


def shown(value: Any) -> str:
    """``value`` as the file writes it (JSON: ``true``, ``"1"``), cut to 40 characters."""
    try:
        text = json.dumps(value, allow_nan=False)
    except (TypeError, ValueError):
        text = repr(value)
    return text if len(text) <= 40 else f"{text[:37]}..."


def text_field(data: Mapping[str, Any], key: str) -> str:
    """A string field: a number or a list is no name."""
    value = data[key]
    if not isinstance(value, str):
        raise ValueError(f"{key}: {shown(value)} is not a string")
    return value


def optional_text_field(data: Mapping[str, Any], key: str) -> str | None:
    """A string field that may be null."""
    return None if data[key] is None else text_field(data, key)


def whole_field(data: Mapping[str, Any], key: str) -> int:
    """A count from 0 to 2**62 written as a JSON integer (not ``true``, not ``1.0``, not ``"1"``)."""
    value = data[key]
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= LARGEST_WHOLE:
        raise ValueError(f"{key}: {shown(value)} is not a whole number from 0 to 2**62")
    return value


def number_field(data: Mapping[str, Any], key: str, name: str = "") -> float:
    """A finite number written as a JSON number (not ``true``, not ``"0.5"``); ``name``: how messages
    call the field (default: its key)."""
    value = data[key]
    key = name or key
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError(f"{key}: {shown(value)} is not a number")
    if isinstance(value, int) and value.bit_length() > 1000:  # float() would overflow; str() may be refused
        raise ValueError(f"{key}: a number of over 300 digits is out of range")
    number = float(value)
    if not math.isfinite(number):
        raise ValueError(f"{key}: {shown(value)} is not a finite number")
    return number


def optional_number_field(data: Mapping[str, Any], key: str) -> float | None:
    """A finite number that may be null."""
    return None if data[key] is None else number_field(data, key)


def flag_field(data: Mapping[str, Any], key: str) -> bool:
    """``true`` or ``false`` (not 1, not ``"yes"``)."""
    value = data[key]
    if not isinstance(value, bool):
        raise ValueError(f"{key}: {shown(value)} is not true or false")
    return value


def mapping_field(data: Mapping[str, Any], key: str) -> Mapping[str, Any]:
    """A JSON object field."""
    value = data[key]
    if not isinstance(value, dict):
        raise ValueError(f"{key}: {shown(value)} is not an object")
    return value


def list_field(data: Mapping[str, Any], key: str) -> list[Any]:
    """A JSON list field."""
    value = data[key]
    if not isinstance(value, list):
        raise ValueError(f"{key}: {shown(value)} is not a list")
    return value
