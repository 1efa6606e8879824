"""What every drawing on the map's grid shares: the palette and its shades, landmark letters,
the shape of a cell in characters, and the column labels above a grid.

Shades are relative to the largest probability drawn: 8 steps of ``max / 8``, any non-zero
probability at least the first step, exactly 0 left blank. The palette is viridis (dark purple to
yellow), which keeps its order on dark and light terminals and for most colour-blind readers;
the most likely state is red, as the current state is in the paper.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from rich.console import Console

LEVELS = 8
"""Shade steps between 0 and the largest probability drawn."""
PALETTE = ("#440154", "#46327e", "#365c8d", "#277f8e", "#1fa187", "#4ac16d", "#a0da39", "#fde725")
"""Viridis, one colour per level 1..8."""
PLAIN_SHADES = "░░▒▒▓▓██"
"""Level 1..8 without colour."""
HIGHLIGHT = "#ff0000"
CENTRE = "#8a8a8a"
BLOCKED = "#767676"
COMPASS: dict[int, tuple[str, ...]] = {
    1: ("",),
    4: ("N", "E", "S", "W"),
    8: ("N", "NE", "E", "SE", "S", "SW", "W", "NW"),
}
ARROWS: dict[int, str] = {1: " ", 4: "↑→↓←", 8: "↑↗→↘↓↙←↖"}
PIXEL_OF_HEADING: dict[int, tuple[tuple[int, int], ...]] = {
    # (row, col) in the 3x3 block, for heading 0, 1, ...
    1: ((0, 0), (0, 1), (0, 2), (1, 2), (2, 2), (2, 1), (2, 0), (1, 0)),
    4: ((0, 1), (1, 2), (2, 1), (1, 0)),
    8: ((0, 1), (0, 2), (1, 2), (2, 2), (2, 1), (2, 0), (1, 0), (0, 0)),
}
SEVERAL = "+"
"""Letter of a cell holding landmarks of more than one class."""


@dataclass(frozen=True)
class Shape:
    """Characters per cell, lines per cell, and where the cell's centre and row label are."""

    width: int
    height: int
    centre: int
    label_line: int


_COMPACT = Shape(2, 1, 0, 0)
_FULL_COLOR = Shape(3, 2, 1, 0)
_FULL_PLAIN = Shape(4, 3, 1, 1)

Pixel = tuple[str, str]
"""One character and its rich style."""


def uses_color(console: Console) -> bool:
    """Whether ``console`` shows colours (not when piped, or with NO_COLOR set)."""
    return console.color_system is not None and not console.no_color


def class_letters(classes: Sequence[str]) -> dict[str, str]:
    """A distinct one-character mark per landmark class: its initial when free, else another letter."""
    letters: dict[str, str] = {}
    used = {SEVERAL}
    for cls in classes:
        if cls in letters:
            continue
        alnum = [ch for ch in cls if ch.isalnum()]
        candidates = [ch.upper() for ch in alnum] + [ch.lower() for ch in alnum]
        candidates += [chr(c) for c in range(ord("A"), ord("Z") + 1)] + [chr(c) for c in range(ord("a"), ord("z") + 1)]
        candidates += list("0123456789")
        letter = next((ch for ch in candidates if ch not in used), "?")
        used.add(letter)
        letters[cls] = letter
    return letters


def shade_levels(values: np.ndarray, top: float) -> np.ndarray:
    """0 for exactly 0, else 1..LEVELS in steps of ``top / LEVELS`` (any positive value at least 1)."""
    if top <= 0.0:
        return np.zeros(values.shape, dtype=np.int64)
    scaled = np.ceil(values / top * LEVELS - 1e-9)  # 0.2 / 0.8 * 8 is 2.0000000000000004
    levels: np.ndarray = np.where(values > 0.0, np.clip(scaled, 1, LEVELS), 0).astype(np.int64)
    return levels


def ink(background: str | None) -> str:
    """Black or white text, whichever reads on ``background``."""
    if background is None:
        return ""
    if background == HIGHLIGHT or background in PALETTE[:4]:
        return "bold white"
    return "bold black"


def column_labels(cols: int, shape: Shape, indent: int) -> str:
    """Column numbers ending at each cell's centre; every 1, 2, 5, 10, ... so that they never touch."""
    widest = len(str(cols - 1))
    step = next(s for s in _label_steps() if s * shape.width >= widest + 1)
    line = [" "] * (indent + cols * shape.width + widest)
    for c in range(0, cols, step):
        digits = str(c)
        end = indent + c * shape.width + shape.centre + 1
        line[end - len(digits) : end] = digits
    return "".join(line).rstrip()


def _label_steps() -> list[int]:
    return [m * 10**e for e in range(7) for m in (1, 2, 5)]
