"""The belief as words and numbers: the most likely states in a table, a one-line summary,
a state described by its cell and heading, the header of a tracked step.

Functions here only observe a belief; they return rich renderables and never print.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from rich.console import Console, Group, RenderableType
from rich.control import strip_control_codes
from rich.table import Table
from rich.text import Text

from beliefloc.belief import entropy, most_likely
from beliefloc.model import Model
from beliefloc.render.drawing import COMPASS, HIGHLIGHT, PALETTE

if TYPE_CHECKING:
    from beliefloc.robots.tracking import Step


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
    ties = int(np.count_nonzero(np.abs(belief - p) <= 1e-9 * abs(p))) - 1  # np.isclose(rtol=1e-9, atol=0), cheaper
    h = entropy(belief)
    name = strip_control_codes(model.states.name(state))  # as Text does, so the span fits
    tie = f" (tied with {ties} other{'s' if ties > 1 else ''})" if ties else ""
    # one Text from the whole line, its styles as spans: track prints a line per step of long logs
    text = Text(f"most likely {name}  p = {p:.4g}{tie}   entropy {h:.4g} nats")
    text.stylize("bold red", 12, 12 + len(name))
    return text


def belief_summary(model: Model, belief: np.ndarray, *, top: int = 5, color: bool = True) -> Group:
    """The most likely state, the entropy, and a table of the ``top`` most likely states."""
    parts: list[RenderableType] = [summary_line(model, belief)]
    if top > 0:
        parts.append(top_states_table(model, belief, top=top, color=color))
    return Group(*parts)


def step_header(number: int, step: str, action: str, observation: str | None, probability: float | None) -> Text:
    """``step 2: look=window_seen   p(window_seen | look, b) = 0.45``."""
    head = strip_control_codes(f"step {number}: {step}")  # as Text does, so the span fits
    if observation is None or probability is None:
        text = Text(f"{head}   nothing observed: prediction only")
    else:
        text = Text(f"{head}   p({observation} | {action}, b) = {probability:.4g}")
    text.stylize("bold", 0, len(head))
    return text


def summary_lines(model: Model, beliefs: np.ndarray) -> list[str]:
    """``summary_line(model, b).plain`` for each row ``b`` of ``beliefs``, the rows at once: the most
    likely state, ties and entropy computed with the same operations, so the same digits."""
    k = len(beliefs)
    if k == 0:
        return []
    states = beliefs.argmax(axis=1)
    p = beliefs[np.arange(k), states]
    ties = np.count_nonzero(np.abs(beliefs - p[:, None]) <= 1e-9 * np.abs(p)[:, None], axis=1) - 1
    h = np.empty(k)
    positive = (beliefs > 0.0).all(axis=1)
    full = beliefs[positive]
    h[positive] = -(full * np.log(full)).sum(axis=1)  # each row as entropy() sums it: contiguous, pairwise
    for row in np.flatnonzero(~positive).tolist():
        h[row] = entropy(beliefs[row])
    names: dict[int, str] = {}
    lines = []
    for state, most, tied, nats in zip(states.tolist(), p.tolist(), ties.tolist(), h.tolist(), strict=True):
        name = names.get(state)
        if name is None:
            name = names[state] = strip_control_codes(model.states.name(state))
        tie = f" (tied with {tied} other{'s' if tied > 1 else ''})" if tied else ""
        lines.append(f"most likely {name}  p = {most:.4g}{tie}   entropy {nats:.4g} nats")
    return lines


def print_step_summaries(
    console: Console,
    model: Model,
    steps: Sequence[Step],
    first: int,
    codes: np.ndarray,
    probabilities: np.ndarray,
    beliefs: np.ndarray,
) -> None:
    """What ``track --final-only`` prints for steps ``first``, ``first + 1``, ... (numbered from
    1): each step's :func:`step_header` and :func:`summary_line`, a blank line before every step
    but the first, as :func:`~beliefloc.render.print_lines` prints them. ``codes`` index ``steps``;
    ``probabilities[i]`` is ignored for a step that observed nothing.

    On a console without styles (a file or a pipe) the lines are built as plain text, a few
    microseconds a step, and written at once; a line that is not plain printable ASCII within the
    width is measured and, if too wide, printed by rich, wrapped as ``console.print`` wraps it."""
    from rich.cells import cell_len

    from beliefloc.render import print_lines

    if console.is_terminal or console.color_system is not None:
        batch: list[Text] = []
        for i, (code, p) in enumerate(zip(codes.tolist(), probabilities.tolist(), strict=True)):
            step = steps[code]
            number = first + i
            shown = None if step.index is None else p
            batch.extend(
                [Text()] * (number > 1) + [step_header(number, step.text, step.action.name, step.observation, shown)]
            )
            batch.append(summary_line(model, beliefs[i]))
        print_lines(console, batch)
        return
    summaries = summary_lines(model, beliefs)
    heads = [strip_control_codes(step.text) for step in steps]
    tails = [
        "   nothing observed: prediction only"
        if step.index is None or step.observation is None
        else strip_control_codes(f"   p({step.observation} | {step.action.name}, b) = ")
        for step in steps
    ]
    observed = [step.index is not None and step.observation is not None for step in steps]
    width = console.width
    out: list[str] = []
    for i, (code, p, summary) in enumerate(zip(codes.tolist(), probabilities.tolist(), summaries, strict=True)):
        number = first + i
        header = (
            f"step {number}: {heads[code]}{tails[code]}{p:.4g}"
            if observed[code]
            else f"step {number}: {heads[code]}{tails[code]}"
        )
        if number > 1:
            out.append("\n")
        for line, which in ((header, 0), (summary, 1)):
            if (line.isascii() and line.isprintable() and len(line) <= width) or (
                "\n" not in line and cell_len(line) <= width
            ):
                out.append(line + "\n")
                continue
            console.file.write("".join(out))
            out.clear()
            step = steps[code]
            text = (
                step_header(number, step.text, step.action.name, step.observation, p if observed[code] else None)
                if which == 0
                else summary_line(model, beliefs[i])
            )
            console.print(text)
    console.file.write("".join(out))
