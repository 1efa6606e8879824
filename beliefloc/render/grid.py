"""Beliefs drawn on the map's grid, in the style of Colledanchise et al. Fig. 5.

Every state is a cell and a heading. A *full* cell is a 3x3 block of "pixels": the centre marks
the cell (grey, or a landmark's letter), the pixel towards a compass point is that heading's
probability (heading 0 = north, clockwise; with 4 headings only N, E, S, W; with headings 1 all
eight show the cell). On a colour terminal two pixel rows share one text line through the
half-block ``▀`` (foreground = upper pixel, background = lower pixel), so a cell is 3 characters
by 2 lines, the fourth pixel row being the gap between grid rows. Without colour a pixel is a
shade character and a cell 4 characters (one of gap) by 3 lines.

A *compact* cell is 2 characters: the shade of the cell's total probability, an arrow for its most
likely heading and the landmark's letter. ``compact=None`` picks full when it fits the width.

Shades are relative to the largest probability drawn: 8 steps of ``max / 8``, any non-zero
probability at least the first step, exactly 0 left blank. The palette is viridis (dark purple to
yellow), which keeps its order on dark and light terminals and for most colour-blind readers;
the most likely state is red, as the current state is in the paper.

:func:`room_plan` draws a map's rooms: box-drawing lines where one room meets another (or a wall,
or a free cell in no room), blocked cells shaded, and each room's name written in it -- or its
letter, listed below the plan, when the name does not fit.

Functions here only observe a belief; they return rich renderables and never print.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from rich.console import Console, Group, RenderableType
from rich.table import Table
from rich.text import Text

from beliefloc.belief import entropy, most_likely
from beliefloc.model import GridLayout, Model

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
_SEVERAL = "+"
"""Letter of a cell holding landmarks of more than one class."""


@dataclass(frozen=True)
class _Shape:
    """Characters per cell, lines per cell, and where the cell's centre and row label are."""

    width: int
    height: int
    centre: int
    label_line: int


_COMPACT = _Shape(2, 1, 0, 0)
_FULL_COLOR = _Shape(3, 2, 1, 0)
_FULL_PLAIN = _Shape(4, 3, 1, 1)

Pixel = tuple[str, str]
"""One character and its rich style."""


# --- decisions shared by the grid and its legend ------------------------------------------------


def grid_width(grid: GridLayout, *, compact: bool, color: bool = True) -> int:
    """Characters per line of :func:`belief_grid` (row labels on both sides included)."""
    label = len(str(grid.rows - 1)) + 1
    return 2 * label + grid.cols * _shape(compact, color).width


def resolve_compact(grid: GridLayout, compact: bool | None, width: int, *, color: bool = True) -> bool:
    """``compact`` if given; otherwise compact exactly when the full grid is wider than ``width``."""
    if compact is not None:
        return compact
    return grid_width(grid, compact=False, color=color) > width


def uses_color(console: Console) -> bool:
    """Whether ``console`` shows colours (not when piped, or with NO_COLOR set)."""
    return console.color_system is not None and not console.no_color


def _shape(compact: bool, color: bool) -> _Shape:
    if compact:
        return _COMPACT
    return _FULL_COLOR if color else _FULL_PLAIN


def class_letters(classes: Sequence[str]) -> dict[str, str]:
    """A distinct one-character mark per landmark class: its initial when free, else another letter."""
    letters: dict[str, str] = {}
    used = {_SEVERAL}
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


def _levels(values: np.ndarray, top: float) -> np.ndarray:
    """0 for exactly 0, else 1..LEVELS in steps of ``top / LEVELS`` (any positive value at least 1)."""
    if top <= 0.0:
        return np.zeros(values.shape, dtype=np.int64)
    scaled = np.ceil(values / top * LEVELS - 1e-9)  # 0.2 / 0.8 * 8 is 2.0000000000000004
    levels: np.ndarray = np.where(values > 0.0, np.clip(scaled, 1, LEVELS), 0).astype(np.int64)
    return levels


def _ink(background: str | None) -> str:
    """Black or white text, whichever reads on ``background``."""
    if background is None:
        return ""
    if background == HIGHLIGHT or background in PALETTE[:4]:
        return "bold white"
    return "bold black"


@dataclass(frozen=True)
class _Picture:
    """The belief laid out on the grid: ``probs[r, c, h]``, landmark marks, the most likely state."""

    grid: GridLayout
    probs: np.ndarray
    marks: dict[tuple[int, int], str]
    best: tuple[int, int, int]


def _picture(model: Model, belief: np.ndarray) -> _Picture:
    grid = model.grid
    if grid is None:
        raise ValueError(f"model {model.name!r} has no grid to draw; use top_states_table")
    h = grid.headings
    probs = np.zeros((grid.rows * grid.cols, h))
    probs[grid.free_cells] = np.asarray(belief, dtype=np.float64).reshape(-1, h)
    letters = class_letters([cls for cls, _, _ in grid.landmarks])
    marks: dict[tuple[int, int], str] = {}
    for cls, r, c in grid.landmarks:
        marks[(r, c)] = letters[cls] if marks.get((r, c), letters[cls]) == letters[cls] else _SEVERAL
    state, _ = most_likely(belief)
    best = tuple(int(x) for x in grid.cell_heading(state))
    return _Picture(grid, probs.reshape(grid.rows, grid.cols, h), marks, (best[0], best[1], best[2]))


# --- the grid -------------------------------------------------------------------------------------


def belief_grid(
    model: Model, belief: np.ndarray, *, compact: bool | None = None, width: int = 80, color: bool = True
) -> Text:
    """The belief on the map, with row and column indices around it.

    ``compact=None`` draws full cells when they fit in ``width`` characters. ``color=False`` draws
    shades with characters instead of colours (for pipes and files). Raises ValueError when the
    model has no grid.
    """
    picture = _picture(model, belief)
    grid = picture.grid
    compact = resolve_compact(grid, compact, width, color=color)
    shape = _shape(compact, color)
    if compact:
        cells = _compact_cells(picture, color)
    elif color:
        cells = _full_color_cells(picture)
    else:
        cells = _full_plain_cells(picture)
    return _assemble(grid, shape, cells)


Cell = list[list[Pixel]]
"""``height`` lines of ``width`` characters."""


def _assemble(grid: GridLayout, shape: _Shape, cells: list[list[Cell]]) -> Text:
    label = len(str(grid.rows - 1))
    columns = _column_labels(grid.cols, shape, label + 1)
    text = Text(no_wrap=True, overflow="ignore")
    text.append(columns + "\n", style="dim")
    for r in range(grid.rows):
        for line in range(shape.height):
            tag = f"{r:>{label}}" if line == shape.label_line else " " * label
            text.append(tag + " ", style="dim")
            for c in range(grid.cols):
                for char, style in cells[r][c][line]:
                    text.append(char, style=style or None)
            text.append(" " + tag.strip().ljust(label), style="dim")
            text.append("\n")
    text.append(columns, style="dim")
    return text


def _column_labels(cols: int, shape: _Shape, indent: int) -> str:
    """Column numbers ending at each cell's centre; every 1, 2, 5, 10, ... so that they never touch."""
    widest = len(str(cols - 1))
    step = next(s for s in _steps() if s * shape.width >= widest + 1)
    line = [" "] * (indent + cols * shape.width + widest)
    for c in range(0, cols, step):
        digits = str(c)
        end = indent + c * shape.width + shape.centre + 1
        line[end - len(digits) : end] = digits
    return "".join(line).rstrip()


def _steps() -> list[int]:
    return [m * 10**e for e in range(7) for m in (1, 2, 5)]


def _compact_cells(picture: _Picture, color: bool) -> list[list[Cell]]:
    grid = picture.grid
    totals = picture.probs.sum(axis=2)
    levels = _levels(totals, float(totals.max()))
    spread = picture.probs.max(axis=2) - picture.probs.min(axis=2)
    heading = picture.probs.argmax(axis=2)
    arrows = ARROWS[grid.headings]
    best_r, best_c, _ = picture.best
    rows: list[list[Cell]] = []
    for r in range(grid.rows):
        row: list[Cell] = []
        for c in range(grid.cols):
            if not grid.free[r, c]:
                row.append([[("▒", BLOCKED), ("▒", BLOCKED)] if color else [("#", ""), ("#", "")]])
                continue
            level = int(levels[r, c])
            letter = picture.marks.get((r, c), "")
            arrow = ""
            if level == 0:
                arrow = "·"
            elif grid.headings > 1 and spread[r, c] > 1e-12 * totals[r, c]:
                arrow = arrows[int(heading[r, c])]
            best = (r, c) == (best_r, best_c)
            if color:
                background = HIGHLIGHT if best else (PALETTE[level - 1] if level else None)
                chars = (arrow + letter).ljust(2)
                style = f"{_ink(background)} on {background}" if background else "dim"
                row.append([[(chars[0], style), (chars[1], style)]])
            else:
                shade = PLAIN_SHADES[level - 1] if level else "·"
                second = "@" if best else (letter or (arrow if level else "") or " ")
                row.append([[(shade, ""), (second, "")]])
        rows.append(row)
    return rows


def _pixels(picture: _Picture, r: int, c: int, levels: np.ndarray) -> list[list[int]]:
    """The 3x3 block of cell (r, c): a level 0..8 per heading pixel, -1 elsewhere, -2 for the
    most likely state."""
    h = picture.grid.headings
    block = [[-1, -1, -1], [-1, -1, -1], [-1, -1, -1]]
    best_r, best_c, best_h = picture.best
    for i, (pr, pc) in enumerate(PIXEL_OF_HEADING[h]):
        heading = i if h > 1 else 0
        is_best = (r, c, heading) == (best_r, best_c, best_h)
        block[pr][pc] = -2 if is_best else int(levels[r, c, heading])
    return block


def _full_color_cells(picture: _Picture) -> list[list[Cell]]:
    grid = picture.grid
    levels = _levels(picture.probs, float(picture.probs.max()))
    rows: list[list[Cell]] = []
    for r in range(grid.rows):
        row: list[Cell] = []
        for c in range(grid.cols):
            if not grid.free[r, c]:
                # hatched: a checkerboard of grey pixels
                colours: list[list[str | None]] = [
                    [BLOCKED if (i + j) % 2 == 0 else None for j in range(3)] for i in range(4)
                ]
                row.append(_half_blocks(colours))
                continue
            if grid.headings == 1:
                row.append(_solid_cell(picture, r, c, int(levels[r, c, 0])))
                continue
            block = _pixels(picture, r, c, levels)
            colours = [[_colour(v) for v in line] for line in block]
            colours[1][1] = CENTRE
            colours.append([None, None, None])
            cell = _half_blocks(colours)
            letter = picture.marks.get((r, c))
            if letter:
                background = colours[0][1] or CENTRE
                cell[0][1] = (letter, f"{_ink(background)} on {background}")
            row.append(cell)
        rows.append(row)
    return rows


def _solid_cell(picture: _Picture, r: int, c: int, level: int) -> Cell:
    """Headings 1: one block, two characters wide and three pixels high, centred in the cell."""
    letter = picture.marks.get((r, c))
    colour = HIGHLIGHT if picture.best[:2] == (r, c) else _colour(level)
    if colour is None:
        centre = (letter, f"{_ink(CENTRE)} on {CENTRE}") if letter else ("▄", CENTRE)
        return [[(" ", ""), centre, (" ", "")], [(" ", ""), (" ", ""), (" ", "")]]
    centre = (letter, f"{_ink(colour)} on {colour}") if letter else ("█", colour)
    return [[("▐", colour), centre, ("▌", colour)], [("▝", colour), ("▀", colour), ("▘", colour)]]


def _colour(value: int) -> str | None:
    if value == -2:
        return HIGHLIGHT
    if value <= 0:
        return None
    return PALETTE[value - 1]


def _half_blocks(colours: list[list[str | None]]) -> Cell:
    """Pairs of pixel rows as half-block characters."""
    lines: Cell = []
    for top_row, bottom_row in zip(colours[0::2], colours[1::2], strict=True):
        line: list[Pixel] = []
        for top, bottom in zip(top_row, bottom_row, strict=True):
            if top is None and bottom is None:
                line.append((" ", ""))
            elif top is None:
                line.append(("▄", str(bottom)))
            elif bottom is None or bottom == top:
                line.append(("▀" if bottom is None else "█", top))
            else:
                line.append(("▀", f"{top} on {bottom}"))
        lines.append(line)
    return lines


def _full_plain_cells(picture: _Picture) -> list[list[Cell]]:
    grid = picture.grid
    levels = _levels(picture.probs, float(picture.probs.max()))
    rows: list[list[Cell]] = []
    for r in range(grid.rows):
        row: list[Cell] = []
        for c in range(grid.cols):
            if not grid.free[r, c]:
                row.append([[("#", ""), ("#", ""), ("#", ""), (" ", "")] for _ in range(3)])
                continue
            block = _pixels(picture, r, c, levels)
            chars = [["@" if v == -2 else (PLAIN_SHADES[v - 1] if v > 0 else " ") for v in line] for line in block]
            chars[1][1] = picture.marks.get((r, c), "·")
            row.append([[(ch, "") for ch in [*line, " "]] for line in chars])
        rows.append(row)
    return rows


# --- legend and summary --------------------------------------------------------------------------


def belief_legend(
    model: Model, belief: np.ndarray, *, compact: bool | None = None, width: int = 80, color: bool = True
) -> Text:
    """What the shades, marks, arrows and letters of :func:`belief_grid` mean (lines of at most
    80 characters)."""
    grid = model.grid
    if grid is None:
        raise ValueError(f"model {model.name!r} has no grid")
    compact = resolve_compact(grid, compact, width, color=color)
    pad = " " * 10
    text = Text()
    # shades
    if compact:
        top = float(_picture(model, belief).probs.sum(axis=2).max())
        what = "cell probability"
    else:
        top = float(np.max(belief))
        what = "state probability"
    text.append("shade     ")
    if color:
        for colour in PALETTE:
            text.append("██", style=colour)
    else:
        text.append(PLAIN_SHADES)
    text.append(f"  {what}: steps of {top / LEVELS:.2g} up to {top:.3g}\n{pad}")
    # marks
    if color:
        text.append("██", style=HIGHLIGHT)
    else:
        text.append("@")
    text.append(" most likely state" + ("'s cell" if compact else "") + "   ")
    if compact:
        text.append("·", style="dim" if color else "")
        text.append(" probability 0   ")
    elif color:
        text.append("▄", style=CENTRE)
        text.append(" cell centre, blank around it: 0   ")
    else:
        text.append("· cell centre, blank: 0   ")
    text.append("▒▒" if color else "##", style=BLOCKED if color else "")
    text.append(" blocked\n")
    # headings
    names = COMPASS[grid.headings]
    if grid.headings == 1:
        text.append("heading   none: a state is a cell, named row,col\n")
    elif compact:
        arrows = ARROWS[grid.headings]
        text.append("heading   arrow = the cell's most likely heading, none if all are equal:\n")
        text.append(pad + "  ".join(f"{arrows[h]} {h} {names[h]}" for h in range(grid.headings)) + "\n")
    else:
        notes = [
            "the pixel towards a compass point is that heading: ",
            ", ".join(f"{h} {names[h]}" for h in range(grid.headings)),
            "(clockwise from north); states are named row,col,heading",
        ]
        for i, line in enumerate(_heading_diagram(grid.headings)):
            text.append(("heading   " if i == 0 else pad) + line + "   " + notes[i] + "\n")
    # landmarks
    letters = class_letters([cls for cls, _, _ in grid.landmarks])
    if letters:
        classes_at: dict[tuple[int, int], set[str]] = {}
        for cls, r, c in grid.landmarks:
            classes_at.setdefault((r, c), set()).add(cls)
        listed = [f"{letter} {cls}" for cls, letter in letters.items()]
        if any(len(v) > 1 for v in classes_at.values()):
            listed.append(f"{_SEVERAL} several classes")
        text.append("landmarks " + ", ".join(listed) + "\n")
    text.rstrip()
    return text


def _heading_diagram(headings: int) -> list[str]:
    grid = [["·", "·", "·"] for _ in range(3)] if headings == 8 else [[" ", "·", " "] for _ in range(3)]
    for h, (r, c) in enumerate(PIXEL_OF_HEADING[headings]):
        grid[r][c] = str(h)
    grid[1][1] = "·"
    return [" ".join(line) for line in grid]


def describe_state(model: Model, state: int) -> str:
    """``row 1, col 0, facing E (window)`` on a grid; the state's name otherwise."""
    grid = model.grid
    if grid is None:
        return model.states.name(state)
    r, c, h = (int(x) for x in grid.cell_heading(state))
    where = f"row {r}, col {c}"
    if grid.headings > 1:
        where += f", facing {COMPASS[grid.headings][h]}"
    classes = sorted({cls for cls, lr, lc in grid.landmarks if (lr, lc) == (r, c)})
    if classes:
        where += f" ({', '.join(classes)})"
    return where


def top_states(belief: np.ndarray, top: int) -> np.ndarray:
    """Indices of the ``top`` most likely states, most likely first (lower index first on ties)."""
    return np.argsort(-belief, kind="stable")[:top]


def top_states_table(model: Model, belief: np.ndarray, *, top: int = 10, color: bool = True) -> Table:
    """The most likely states with their probabilities and a bar."""
    table = Table(box=None, pad_edge=False, show_edge=False, header_style="bold")
    table.add_column("#", justify="right")
    table.add_column("state")
    table.add_column("probability", justify="right")
    table.add_column("", no_wrap=True)
    if model.grid is not None:
        table.add_column("where")
    peak = float(np.max(belief))
    for rank, state in enumerate(top_states(belief, top).tolist(), start=1):
        p = float(belief[state])
        bar_length = 0 if peak <= 0 else max(1, round(10 * p / peak)) if p > 0 else 0
        bar = Text("█" * bar_length, style=HIGHLIGHT if rank == 1 and color else ("" if not color else PALETTE[-3]))
        row: list[RenderableType] = [str(rank), model.states.name(state), f"{p:.4g}", bar]
        if model.grid is not None:
            row.append(describe_state(model, state))
        table.add_row(*row)
    return table


def summary_line(model: Model, belief: np.ndarray) -> Text:
    """``most likely 1,0  p = 0.4444 (tied with 1 other)   entropy 1.042 nats``."""
    state, p = most_likely(belief)
    ties = int(np.count_nonzero(np.isclose(belief, p, rtol=1e-9, atol=0.0))) - 1
    h = entropy(belief)
    text = Text("most likely ")
    text.append(model.states.name(state), style="bold red")
    tie = f" (tied with {ties} other{'s' if ties > 1 else ''})" if ties else ""
    text.append(f"  p = {p:.4g}{tie}   entropy {h:.4g} nats")
    return text


def belief_summary(model: Model, belief: np.ndarray, *, top: int = 5, color: bool = True) -> Group:
    """The most likely state, the entropy, and a table of the ``top`` most likely states."""
    parts: list[RenderableType] = [summary_line(model, belief)]
    if top > 0:
        parts.append(top_states_table(model, belief, top=top, color=color))
    return Group(*parts)


def belief_view(
    model: Model,
    belief: np.ndarray,
    *,
    compact: bool | None = None,
    width: int = 80,
    color: bool = True,
    top: int = 5,
    legend: bool = True,
    title: str | None = None,
) -> Group:
    """Title, grid, legend and summary; without a grid (an imported .pomdp), the summary with a
    table of at least the 10 most probable states."""
    parts: list[RenderableType] = [] if title is None else [Text(title, style="bold")]
    if model.grid is None:
        parts.append(belief_summary(model, belief, top=max(top, 10), color=color))
        return Group(*parts)
    parts.append(belief_grid(model, belief, compact=compact, width=width, color=color))
    if legend:
        parts.append(belief_legend(model, belief, compact=compact, width=width, color=color))
    parts.append(belief_summary(model, belief, top=top, color=color))
    return Group(*parts)


def step_header(number: int, step: str, action: str, observation: str | None, probability: float | None) -> Text:
    """``step 2: look=window_seen   p(window_seen | look, b) = 0.45``."""
    text = Text()
    text.append(f"step {number}: ", style="bold")
    text.append(step, style="bold")
    if observation is None or probability is None:
        text.append("   nothing observed: prediction only")
    else:
        text.append(f"   p({observation} | {action}, b) = {probability:.4g}")
    return text


# --- rooms ----------------------------------------------------------------------------------------

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
    columns = _column_labels(grid.cols, _Shape(cell_width + 1, 1, cell_width // 2 + 1, 0), label + 1)
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
