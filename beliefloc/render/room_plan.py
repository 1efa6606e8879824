"""A map's rooms drawn on its grid: box-drawing lines where one room meets another (or a wall,
or a free cell in no room), blocked cells shaded, and each room's name written in it -- or its
letter, listed below the plan, when the name does not fit.

Functions here only observe a map; they return rich renderables and never print.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from rich.text import Text

from beliefloc.model import GridLayout
from beliefloc.render.drawing import BLOCKED, Pixel, Shape, class_letters, column_labels

_BOX = {
    # (up, down, left, right) -> the box-drawing character joining those lines at a corner
    (False, False, False, False): " ",
    (True, True, False, False): "│",
    (False, False, True, True): "─",
    (False, True, False, True): "┌",
    (False, True, True, False): "┐",
    (True, False, False, True): "└",
    (True, False, True, False): "┘",
    (True, True, False, True): "├",
    (True, True, True, False): "┤",
    (False, True, True, True): "┬",
    (True, False, True, True): "┴",
    (True, True, True, True): "┼",
    (True, False, False, False): "╵",
    (False, True, False, False): "╷",
    (False, False, True, False): "╴",
    (False, False, False, True): "╶",
}
_NO_ROOM_DOT = "·"
_WALL = -1
"""Region of a blocked cell (and of everything beyond the grid's edge); 0 is a free cell in no room."""


def room_plan_width(grid: GridLayout, cell_width: int) -> int:
    """Characters per line of :func:`room_plan` with cells ``cell_width`` characters wide."""
    label = len(str(grid.rows - 1))
    return 2 * (label + 1) + grid.cols * (cell_width + 1) + 1


def room_plan(
    grid: GridLayout,
    rooms: Mapping[str, np.ndarray],
    *,
    letters: Mapping[str, str] | None = None,
    width: int = 80,
    color: bool = True,
) -> Text:
    """The rooms on the grid: a line wherever two cells belong to different rooms (a blocked cell
    and a free cell in no room count as regions of their own), names written inside.

    ``rooms`` maps a room to its cell mask (:attr:`SemanticMap.rooms`). Cells are 3 characters
    wide when that fits in ``width``, else 2 or 1. A room whose name does not fit on its widest
    row shows ``letters[room]`` (default: a distinct letter per room) and :func:`room_legend`
    lists it.
    """
    region = _regions(grid, rooms)
    cell_width = next((w for w in (3, 2) if room_plan_width(grid, w) <= width), 1)
    label = len(str(grid.rows - 1))
    wall = ("▒", BLOCKED) if color else ("#", "")
    lines: list[list[Pixel]] = []
    for line in range(2 * grid.rows + 1):
        pixels: list[Pixel] = []
        r = line // 2
        if line % 2 == 0:  # the border between grid rows r - 1 and r
            for c in range(grid.cols + 1):
                pixels.append(_corner(region, r, c, wall))
                if c < grid.cols:
                    above, below = _region_at(region, r - 1, c), _region_at(region, r, c)
                    if above != below:
                        pixels.extend([("─", "")] * cell_width)
                    else:
                        pixels.extend([wall if above == _WALL else (" ", "")] * cell_width)
        else:
            for c in range(grid.cols + 1):
                left, right = _region_at(region, r, c - 1), _region_at(region, r, c)
                if left != right:
                    pixels.append(("│", ""))
                else:
                    pixels.append(wall if left == _WALL else (" ", ""))
                if c < grid.cols:
                    pixels.extend(_room_cell(right, cell_width, wall, color))
        lines.append(pixels)
    marks = _room_marks(grid, rooms, letters)
    for name, mask in rooms.items():
        _write_name(lines, mask, name, marks[name], cell_width, color)
    text = Text(no_wrap=True, overflow="ignore")
    columns = column_labels(grid.cols, Shape(cell_width + 1, 1, cell_width // 2 + 1, 0), label + 1)
    text.append(columns + "\n", style="dim")
    for line, pixels in enumerate(lines):
        tag = f"{line // 2:>{label}}" if line % 2 == 1 else " " * label
        text.append(tag + " ", style="dim")
        for char, style in pixels:
            text.append(char, style=style or None)
        if tag.strip():
            text.append(" " + tag.strip(), style="dim")
        text.append("\n")
    text.rstrip()
    return text


def room_legend(
    grid: GridLayout,
    rooms: Mapping[str, np.ndarray],
    *,
    letters: Mapping[str, str] | None = None,
    width: int = 80,
) -> Text:
    """Each room with its number of cells, its letter first when :func:`room_plan` wrote the
    letter instead of the name; and how many free cells are in no room."""
    cell_width = next((w for w in (3, 2) if room_plan_width(grid, w) <= width), 1)
    marks = _room_marks(grid, rooms, letters)
    entries = []
    for name, mask in rooms.items():
        fits = _name_run(mask, name, cell_width) is not None
        cells = int(mask.sum())
        entries.append(f"{'' if fits else marks[name] + ' '}{name} {cells} cell{'s' if cells != 1 else ''}")
    in_rooms = np.zeros((grid.rows, grid.cols), dtype=bool)
    for mask in rooms.values():
        in_rooms |= mask
    outside = int((grid.free & ~in_rooms).sum())
    if outside:
        entries.append(f"{_NO_ROOM_DOT} {outside} free cell{'s' if outside != 1 else ''} in no room")
    lines = ["rooms    "]
    for k, entry in enumerate(entries):
        piece = f" {entry}{',' if k < len(entries) - 1 else ''}"
        if len(lines[-1]) + len(piece) > max(width, 40) and lines[-1].strip() != "rooms":
            lines.append(" " * 9)
        lines[-1] += piece
    return Text("\n".join(lines))


def _regions(grid: GridLayout, rooms: Mapping[str, np.ndarray]) -> np.ndarray:
    region = np.where(grid.free, 0, _WALL).astype(np.int64)
    for k, mask in enumerate(rooms.values(), start=1):
        region[mask & grid.free] = k
    return region


def _region_at(region: np.ndarray, r: int, c: int) -> int:
    if 0 <= r < region.shape[0] and 0 <= c < region.shape[1]:
        return int(region[r, c])
    return _WALL


def _corner(region: np.ndarray, r: int, c: int, wall: Pixel) -> Pixel:
    """The corner between cells (r-1, c-1), (r-1, c), (r, c-1) and (r, c)."""
    nw, ne = _region_at(region, r - 1, c - 1), _region_at(region, r - 1, c)
    sw, se = _region_at(region, r, c - 1), _region_at(region, r, c)
    key = (nw != ne, sw != se, nw != sw, ne != se)
    if not any(key) and nw == _WALL:
        return wall
    return (_BOX[key], "")


def _room_cell(region: int, cell_width: int, wall: Pixel, color: bool) -> list[Pixel]:
    if region == _WALL:
        return [wall] * cell_width
    if region == 0:  # a free cell in no room
        dot = (_NO_ROOM_DOT, "dim" if color else "")
        pad = (cell_width - 1) // 2
        return [(" ", "")] * pad + [dot] + [(" ", "")] * (cell_width - 1 - pad)
    return [(" ", "")] * cell_width


def _room_marks(grid: GridLayout, rooms: Mapping[str, np.ndarray], letters: Mapping[str, str] | None) -> dict[str, str]:
    chosen = class_letters(list(rooms))
    return {name: (letters or {}).get(name, chosen[name]) for name in rooms}


def _name_run(mask: np.ndarray, name: str, cell_width: int) -> tuple[int, int, int] | None:
    """Where ``name`` fits: (row, first col, last col) of a run of the room's cells on one row
    wide enough, the row nearest the room's middle first; None when no run is wide enough."""
    rows = np.flatnonzero(mask.any(axis=1))
    middle = (rows[0] + rows[-1]) / 2.0
    best: tuple[float, int, int, int] | None = None
    for r in rows.tolist():
        cells = np.flatnonzero(mask[r])
        breaks = np.flatnonzero(np.diff(cells) > 1)
        starts = np.concatenate([[cells[0]], cells[breaks + 1]])
        ends = np.concatenate([cells[breaks], [cells[-1]]])
        for start, end in zip(starts.tolist(), ends.tolist(), strict=True):
            span = (end - start + 1) * (cell_width + 1) - 1
            if len(name) <= span:
                key = (abs(r - middle), r, start, end)
                if best is None or key < best:
                    best = key
    return None if best is None else best[1:]


def _write_name(lines: list[list[Pixel]], mask: np.ndarray, name: str, mark: str, cell_width: int, color: bool) -> None:
    """Write the room's name (or its mark) centred on a run of its cells."""
    run = _name_run(mask, name, cell_width)
    text = name
    if run is None:
        text = mark
        run = _name_run(mask, mark, cell_width)
        if run is None:  # pragma: no cover - a one-character mark always fits a cell
            return
    r, start, end = run
    first = start * (cell_width + 1) + 1
    span = (end - start + 1) * (cell_width + 1) - 1
    offset = first + (span - len(text)) // 2
    line = lines[2 * r + 1]
    for k, char in enumerate(text):
        line[offset + k] = (char, "bold" if color else "")
