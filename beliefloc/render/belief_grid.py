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
Shades and colours: :mod:`beliefloc.render.drawing`.

Functions here only observe a belief; they return rich renderables and never print.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from rich.console import Group, RenderableType
from rich.text import Text

from beliefloc.belief import most_likely
from beliefloc.model import GridLayout, Model
from beliefloc.render.drawing import (
    ARROWS,
    BLOCKED,
    CENTRE,
    COMPASS,
    HIGHLIGHT,
    LEVELS,
    PALETTE,
    PIXEL_OF_HEADING,
    PLAIN_SHADES,
    SEVERAL,
    Pixel,
    Shape,
    class_letters,
    column_labels,
    ink,
    shade_levels,
)
from beliefloc.render.state_tables import belief_summary

_COMPACT = Shape(2, 1, 0, 0)
_FULL_COLOR = Shape(3, 2, 1, 0)
_FULL_PLAIN = Shape(4, 3, 1, 1)


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


def _shape(compact: bool, color: bool) -> Shape:
    if compact:
        return _COMPACT
    return _FULL_COLOR if color else _FULL_PLAIN


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
        marks[(r, c)] = letters[cls] if marks.get((r, c), letters[cls]) == letters[cls] else SEVERAL
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


def _assemble(grid: GridLayout, shape: Shape, cells: list[list[Cell]]) -> Text:
    label = len(str(grid.rows - 1))
    columns = column_labels(grid.cols, shape, label + 1)
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


def _compact_cells(picture: _Picture, color: bool) -> list[list[Cell]]:
    grid = picture.grid
    totals = picture.probs.sum(axis=2)
    levels = shade_levels(totals, float(totals.max()))
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
                style = f"{ink(background)} on {background}" if background else "dim"
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
    levels = shade_levels(picture.probs, float(picture.probs.max()))
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
                cell[0][1] = (letter, f"{ink(background)} on {background}")
            row.append(cell)
        rows.append(row)
    return rows


def _solid_cell(picture: _Picture, r: int, c: int, level: int) -> Cell:
    """Headings 1: one block, two characters wide and three pixels high, centred in the cell."""
    letter = picture.marks.get((r, c))
    colour = HIGHLIGHT if picture.best[:2] == (r, c) else _colour(level)
    if colour is None:
        centre = (letter, f"{ink(CENTRE)} on {CENTRE}") if letter else ("▄", CENTRE)
        return [[(" ", ""), centre, (" ", "")], [(" ", ""), (" ", ""), (" ", "")]]
    centre = (letter, f"{ink(colour)} on {colour}") if letter else ("█", colour)
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
    levels = shade_levels(picture.probs, float(picture.probs.max()))
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
            listed.append(f"{SEVERAL} several classes")
        text.append("landmarks " + ", ".join(listed) + "\n")
    text.rstrip()
    return text


def _heading_diagram(headings: int) -> list[str]:
    grid = [["·", "·", "·"] for _ in range(3)] if headings == 8 else [[" ", "·", " "] for _ in range(3)]
    for h, (r, c) in enumerate(PIXEL_OF_HEADING[headings]):
        grid[r][c] = str(h)
    grid[1][1] = "·"
    return [" ".join(line) for line in grid]


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
