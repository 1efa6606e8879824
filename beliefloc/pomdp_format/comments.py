"""The ``# beliefloc-...`` comments of a ``.pomdp`` file, read into :class:`Annotations`.

Other tools ignore these comments; beliefloc writes them (:mod:`beliefloc.pomdp_format.writer`) to
keep what the format cannot: the model's name, the grid, the original names, each action's kind
and the order of its own observations. Each comment is checked on its own here; whether it fits
the declarations is checked when the model is built.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from beliefloc.errors import LimitError
from beliefloc.pomdp_format.names import FORMAT_VERSION, KINDS, SINGULAR
from beliefloc.pomdp_format.statements import Comment
from beliefloc.source import limits


@dataclass
class Annotations:
    """What the ``# beliefloc-...`` comments say."""

    model_name: str | None = None
    grid: dict[str, Any] | None = None
    grid_line: int = 0
    layout: list[str] = field(default_factory=list)
    landmarks: list[tuple[str, int, int]] = field(default_factory=list)
    names: dict[str, dict[str, tuple[str, int]]] = field(default_factory=lambda: {k: {} for k in KINDS})
    """kind -> identifier -> (original name, line)"""
    actions: dict[str, tuple[dict[str, Any], int]] = field(default_factory=dict)
    """action identifier -> (the beliefloc-action object, line)"""


def read_comment(notes: Annotations, comment: Comment) -> None:
    """Add what ``comment`` says to ``notes``; a malformed comment is an error at its line."""
    keyword, _, rest = comment.text.partition(" ")
    rest = rest.strip()
    if keyword == "beliefloc-format":
        if rest != str(FORMAT_VERSION):
            raise comment.error(f"beliefloc-format {rest}: this beliefloc reads version {FORMAT_VERSION} comments")
        return
    depth = nesting(rest)
    if depth > limits.NESTING.value:
        raise LimitError(limits.exceeded(limits.NESTING, depth, f"{comment.path}:{comment.line}: {keyword}"))
    try:
        reader = _READERS.get(keyword)
        if reader is None:
            raise ValueError(f"unknown beliefloc comment {keyword!r}")
        reader(notes, rest, comment.line)
    except (ValueError, TypeError, RecursionError) as exc:  # json.JSONDecodeError is a ValueError
        raise comment.error(f"{keyword}: {exc}") from None


_JSON_STRING = re.compile(r'"(?:[^"\\]|\\.)*"')


def nesting(text: str) -> int:
    """How deeply the brackets of JSON ``text`` nest (outside its strings), counted without
    parsing it: a line of ten thousand ``[`` must not reach the recursive parser."""
    if "[" not in text and "{" not in text:
        return 0
    codes = np.frombuffer(_JSON_STRING.sub("", text).encode("utf-8", "replace"), dtype=np.uint8)
    steps = np.isin(codes, (ord("["), ord("{"))).astype(np.int64) - np.isin(codes, (ord("]"), ord("}")))
    return int(np.cumsum(steps).max(initial=0))


def _loads(text: str) -> Any:
    """JSON without ``NaN`` and ``Infinity``, which the format's numbers never are."""
    return json.loads(text, parse_constant=_no_constant)


def _no_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a number")


def _model(notes: Annotations, rest: str, line: int) -> None:
    notes.model_name = _json_str(_loads(rest))


def _grid(notes: Annotations, rest: str, line: int) -> None:
    grid = _loads(rest)
    if not isinstance(grid, dict) or set(grid) != {"rows", "cols", "headings", "cell_size"}:
        raise ValueError('expected {"rows", "cols", "headings", "cell_size"}')
    if not all(
        isinstance(grid[k], int) and not isinstance(grid[k], bool) and grid[k] >= 1
        for k in ("rows", "cols", "headings")
    ):
        raise ValueError("rows, cols and headings must be positive integers")
    size = grid["cell_size"]
    if isinstance(size, bool) or not isinstance(size, (int, float)) or not (size > 0 and math.isfinite(size)):
        raise ValueError("cell_size must be a positive number")
    notes.grid, notes.grid_line = grid, line


def _layout(notes: Annotations, rest: str, line: int) -> None:
    if not rest or set(rest) - {".", "#"}:
        raise ValueError("a layout row is made of '.' (free) and '#' (blocked)")
    notes.layout.append(rest)


def _landmark(notes: Annotations, rest: str, line: int) -> None:
    value = _loads(rest)
    if not (
        isinstance(value, list)
        and len(value) == 3
        and isinstance(value[0], str)
        and all(isinstance(v, int) for v in value[1:])
    ):
        raise ValueError('expected ["class", row, col]')
    notes.landmarks.append((value[0], value[1], value[2]))


def _name(notes: Annotations, rest: str, line: int) -> None:
    kind, _, rest = rest.partition(" ")
    ident, _, original = rest.strip().partition(" ")
    kinds = {SINGULAR[k]: k for k in KINDS}
    if kind not in kinds or not ident:
        raise ValueError("expected 'beliefloc-name state|action|observation IDENT \"original name\"'")
    names = notes.names[kinds[kind]]
    if ident in names:
        raise ValueError(f"{kind} {ident!r} is named twice (first on line {names[ident][1]})")
    names[ident] = (_json_str(_loads(original)), line)


def _action(notes: Annotations, rest: str, line: int) -> None:
    info = _loads(rest)
    if not (
        isinstance(info, dict)
        and isinstance(info.get("action"), str)
        and info.get("kind") in ("actuation", "perception")
        and isinstance(info.get("observations"), list)
        and all(isinstance(o, str) for o in info["observations"])
        and isinstance(info.get("aliases", {}), dict)
        and all(isinstance(v, str) for v in info.get("aliases", {}).values())
    ):
        raise ValueError('expected {"action": IDENT, "kind": "actuation"|"perception", "observations": [IDENT, ...]}')
    if info["action"] in notes.actions:
        raise ValueError(f"action {info['action']!r} is described twice")
    notes.actions[info["action"]] = (info, line)


_READERS: dict[str, Callable[[Annotations, str, int], None]] = {
    "beliefloc-model": _model,
    "beliefloc-grid": _grid,
    "beliefloc-layout": _layout,
    "beliefloc-landmark": _landmark,
    "beliefloc-name": _name,
    "beliefloc-action": _action,
}
"""The reader of each comment keyword but ``beliefloc-format`` (whose error has its own wording)."""


def _json_str(value: object) -> str:
    if not isinstance(value, str):
        raise ValueError(f"expected a JSON string, found {json.dumps(value)}")
    return value
