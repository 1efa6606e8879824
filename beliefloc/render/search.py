"""Object search traces: one line per step, the cell belief drawn on the plane or the map, the verdict.

The plane shows every room at its placement, two characters per cell, blank between rooms, and
each room's name above it (:func:`plane_labels`). A cell's shade is its probability relative to
the largest one drawn (viridis, as in :mod:`beliefloc.render.belief_grid`); ``R`` marks the robot,
``*`` the most likely cell (red), ``T`` the simulated target's true cell (the simulator knows it;
the robot does not). Without colour a cell is a shade character and its mark.

A search on a map (:class:`~beliefloc.object_search.map_space.MapSearchSpace`) is drawn on the
map's grid, with its row and column numbers (the numbers ``--target-cell`` takes): walls grey
(``##`` without colour), a free cell in no room ``·``, a cell of a room the robot cannot enter
``×``, and a room's cells shaded and lettered with the room's letter (listed below the grid)
where no mark stands.

:func:`search_legend` says what the marks, shades and letters mean (``search run --show`` prints
it once, above the first drawing). Functions here only observe a search record; they return rich
renderables and never print.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING

import numpy as np
from rich import box
from rich.console import JustifyMethod
from rich.table import Table
from rich.text import Text

from beliefloc.object_search.loop import SearchRecord, Step, Verdict
from beliefloc.object_search.map_space import MapSearchSpace
from beliefloc.object_search.scene import SceneModel, SceneTrace
from beliefloc.object_search.space import SearchSpace
from beliefloc.render.drawing import BLOCKED, HIGHLIGHT, LEVELS, PALETTE, PLAIN_SHADES

if TYPE_CHECKING:
    from beliefloc.object_search.experiment import ArmSummary

_VERDICT_STYLE = {Verdict.FOUND: "bold green", Verdict.NOT_FOUND: "bold yellow", Verdict.TIME_LIMIT: "bold red"}


def step_line(space: SearchSpace, step: Step) -> Text:
    """``step 3: study:2,3 (2.1 time units) present  p(E) 0.812  max b 0.441 at study:1,3``."""
    text = Text(f"step {step.index:>3}: ")
    text.append(f"{space.cell_name(step.view):<16}", style="bold")
    text.append(f" +{step.cost:5.1f} = {step.time:6.1f}  ")
    text.append("present" if step.present else "absent ", style="green" if step.present else "dim")
    text.append(f"  p(E) {step.p_exists:.3f}  max b {step.best_belief:.3f} at {space.cell_name(step.best_cell)}")
    if step.commits:
        text.append("  KB += " + ", ".join(f"{obj} in {room}" for obj, room in step.commits), style="cyan")
    return text


def scene_lines(model: SceneModel, trace: SceneTrace) -> Text:
    """The image of one view as the SP-POMDP processed it: per ROI the operators applied (with what each
    reported), the lower level's answer and the higher level's belief that the target is in the image::

        ROI 1: colour grey, shape box → target  P(present) 0.79  HL 0.59 0.07 0.07 0.07 | none 0.21
        ROI 2 (target): shape box → not target  P(present) 0.66  HL ...
        report present after 2 of 4 ROIs, 5 operators, 1.0 time units
    """
    text = Text()
    for roi in trace.rois:
        text.append(f"    ROI {roi.roi + 1}")
        if roi.holds_target:
            text.append(" (target)", style="bold")
        applied = ", ".join(f"{model.operators[k].name} {model.operators[k].values[o]}" for k, o in roi.applied)
        text.append(f": {applied or 'no operator'} → ")
        text.append("target" if roi.said_target else "not target", style="green" if roi.said_target else "dim")
        text.append(f"  P(present) {roi.present_belief:.2f}")
        if roi.belief:
            *rois, none = roi.belief
            text.append("  HL " + " ".join(f"{b:.2f}" for b in rois) + f" | none {none:.2f}", style="dim")
        text.append("\n")
    text.append(
        f"    report {'present' if trace.present else 'absent'} after {len(trace.rois)} of {model.rois} ROIs, "
        f"{trace.operators} operators, {trace.time:.1f} time units"
    )
    return text


def belief_plane(
    space: SearchSpace,
    belief: np.ndarray,
    *,
    robot: int | None = None,
    target: int | None = None,
    color: bool = True,
) -> Text:
    """The belief over every room's cells, drawn where the rooms are on the plane (or on the map's
    grid, :func:`belief_map`)."""
    if isinstance(space, MapSearchSpace):
        return belief_map(space, belief, robot=robot, target=target, color=color)
    rows = space.plane[:, 0].astype(int)
    cols = space.plane[:, 1].astype(int)
    top, best, levels = _shading(belief)
    at = {(int(r), int(c)): i for i, (r, c) in enumerate(zip(rows, cols, strict=True))}
    in_row, before = plane_labels(space)

    def draw_cell(cell: int) -> None:
        mark = "R" if cell == robot else "T" if cell == target else "*" if cell == best else ""
        _append_cell(text, mark, None, int(levels[cell]), cell == best, color)

    text = Text()
    for r in range(int(rows.max()) + 1):
        if r in before:
            _append_line(text, {}, before[r], draw_cell)
        row_cells = {c: cell for (row, c), cell in at.items() if row == r}
        _append_line(text, row_cells, in_row.get(r, []), draw_cell)
    legend = ", ".join(
        f"{room} {float(belief[space.room_of_cell == i].sum()):.3f}" for i, room in enumerate(space.rooms)
    )
    text.append(f"rooms: {legend}; max b {top:.3f} at {space.cell_name(best)}", style="dim")
    return text


Label = tuple[int, str]
"""A room's name and the plane column it starts at."""


def plane_labels(space: SearchSpace) -> tuple[dict[int, list[Label]], dict[int, list[Label]]]:
    """Where each room's name goes on a plane of rooms, starting over the room's left column: on the
    plane row just above the room when no cell is there over the room (``in_row[row]``), else on a
    line of its own inserted above the room's top row (``before[row]``) when no room crosses that
    line. A room with neither place has no name drawn (the line under the plane lists every room)."""
    plane = space.plane.astype(int)
    occupied = {(int(r), int(c)) for r, c in plane}
    extents = []
    for index in range(len(space.rooms)):
        cells = plane[space.room_of_cell == index]
        extents.append((int(cells[:, 0].min()), int(cells[:, 0].max()), int(cells[:, 1].min()), int(cells[:, 1].max())))
    in_row: dict[int, list[Label]] = {}
    before: dict[int, list[Label]] = {}
    for room, (top, _, left, right) in zip(space.rooms, extents, strict=True):
        if top > 0 and not any((top - 1, c) in occupied for c in range(left, right + 1)):
            in_row.setdefault(top - 1, []).append((left, room))
        elif not any(t < top <= b for t, b, _, _ in extents):
            before.setdefault(top, []).append((left, room))
    return in_row, before


def _append_line(text: Text, cells: Mapping[int, int], labels: list[Label], draw_cell: Callable[[int], None]) -> None:
    """One line of the plane: ``cells`` (column -> cell, two characters each) and room names (bold,
    each cut one character short of whatever comes next on the line)."""
    starts = sorted(
        [(2 * c, "cell", str(cell)) for c, cell in cells.items()] + [(2 * c, "label", n) for c, n in labels]
    )
    position = 0
    for k, (start, kind, what) in enumerate(starts):
        if start < position:
            continue  # under a name cut short, or two names at one column: the first wins
        text.append(" " * (start - position))
        if kind == "cell":
            draw_cell(int(what))
            position = start + 2
            continue
        limit = starts[k + 1][0] - start - 1 if k + 1 < len(starts) else len(what)
        shown = what if len(what) <= limit else what[: max(limit - 1, 0)] + "…"
        text.append(shown, style="bold")
        position = start + len(shown)
    text.append("\n")


def belief_map(
    space: MapSearchSpace,
    belief: np.ndarray,
    *,
    robot: int | None = None,
    target: int | None = None,
    color: bool = True,
) -> Text:
    """The belief over the cells of a map's rooms, drawn on the map's grid (see the module docstring)."""
    rows, cols = space.shape
    top, best, levels = _shading(belief)
    letters = room_letters(space.rooms)
    label = len(str(rows - 1))
    text = Text(no_wrap=True, overflow="ignore")
    indent = " " * (label + 1)
    if cols > 10:  # the tens over the units, one digit per cell
        text.append(
            indent + "".join(f"{(c // 10) % 10 if c >= 10 else ' ':<2}" for c in range(cols)) + "\n", style="dim"
        )
    text.append(indent + "".join(f"{c % 10:<2}" for c in range(cols)) + "\n", style="dim")
    for r in range(rows):
        text.append(f"{r:>{label}} ", style="dim")
        for c in range(cols):
            cell = int(space.cell_at[r, c])
            if cell < 0:
                if not space.free[r, c]:
                    text.append("  " if color else "##", style=f"on {BLOCKED}" if color else "")
                else:
                    text.append("· ", style="dim")
                continue
            room = int(space.room_of_cell[cell])
            if not space.accessible[room]:
                text.append("× ", style="dim")
                continue
            mark = "R" if cell == robot else "T" if cell == target else "*" if cell == best else ""
            _append_cell(text, mark, letters[room], int(levels[cell]), cell == best, color)
        text.append(f" {r}\n", style="dim")
    legend = ", ".join(
        f"{letters[i]} {room} {float(belief[space.room_of_cell == i].sum()):.3f}" for i, room in enumerate(space.rooms)
    )
    text.append(f"rooms: {legend}; max b {top:.3f} at {space.cell_name(best)}", style="dim")
    return text


def search_legend(space: SearchSpace, *, color: bool = True) -> Text:
    """What the marks, shades and letters of :func:`belief_plane` mean, in lines of at most 80
    characters: printed once above the drawings of ``search run --show``."""
    pad = " " * 10
    text = Text("marks     ")
    text.append("R", style="bold")
    text.append(" the robot   ")
    text.append("T", style="bold")
    text.append(" the target's true cell (known to the simulator only)\n" + pad)
    if color:
        text.append("* ", style=f"bold white on {HIGHLIGHT}")
    else:
        text.append("█*")
    text.append(" the most likely cell (R or T instead when one stands there)\n")
    text.append("shade     ")
    if color:
        for colour in PALETTE:
            text.append("  ", style=f"on {colour}")
    else:
        text.append(PLAIN_SHADES)
    text.append("  a cell's belief in 8 steps up to max b (under the grid)\n")
    if isinstance(space, MapSearchSpace):
        text.append("map       ")
        text.append("  " if color else "##", style=f"on {BLOCKED}" if color else "")
        text.append(" wall   · free, in no room   × a room the robot cannot enter\n")
        text.append("rooms     a letter on each cell of a room (listed under the grid)")
    else:
        text.append("rooms     named above the room")
        if space.closed_rooms:
            text.append("; ")
            text.append("  " if color else "..", style="on grey23" if color else "")
            text.append(" a room the robot cannot enter")
    return text


def _shading(belief: np.ndarray) -> tuple[float, int, np.ndarray]:
    """``max(b)``, its cell, and every cell's shade level (0: no belief, 1..LEVELS relative to the max)."""
    top = float(belief.max())
    levels = np.where(belief > 0, np.clip(np.ceil(belief / top * LEVELS - 1e-9), 1, LEVELS), 0).astype(int)
    return top, int(np.argmax(belief)), levels


def _append_cell(text: Text, mark: str, fill: str | None, level: int, best: bool, color: bool) -> None:
    """One cell, two characters: the mark (R, T, *) or ``fill`` (a room letter; None: blank in colour,
    the shade without it) on the belief's shade."""
    if color:
        background = HIGHLIGHT if best else PALETTE[level - 1] if level else "grey23"
        ink = "white" if background == HIGHLIGHT or background in PALETTE[:4] else "black"
        text.append(f"{mark or fill or ' '} ", style=f"{'bold ' if mark or fill is None else ''}{ink} on {background}")
    else:
        shade = PLAIN_SHADES[level - 1] if level else "."
        text.append(f"{shade}{mark or fill or shade}")


def room_letters(rooms: tuple[str, ...]) -> list[str]:
    """A distinct lowercase letter per room: its initial when free, else another letter of its name,
    else any (uppercase letters are the marks R, T)."""
    used: set[str] = set()
    out = []
    for room in rooms:
        candidates = [ch for ch in room if ch.isalpha() and ch.islower()] + [chr(c) for c in range(97, 123)]
        letter = next((ch for ch in candidates if ch not in used), "?")
        used.add(letter)
        out.append(letter)
    return out


def steps_table(space: SearchSpace, record: SearchRecord) -> Table:
    """Every step of a search in one table."""
    table = Table(
        title=f"{record.policy.value} search, {record.metareasoning.value} metareasoning",
        title_justify="left",
        box=box.SIMPLE_HEAD,  # no side borders: a step with map cell names fits 80 columns
        show_edge=False,
        pad_edge=False,
        collapse_padding=True,
    )
    columns: tuple[tuple[str, JustifyMethod], ...] = (
        ("step", "right"),
        ("view", "left"),
        ("cost", "right"),
        ("time", "right"),
        ("observation", "left"),
        ("p(E)", "right"),
        ("max b", "right"),
        ("at", "left"),
    )
    widest = max(len(space.cell_name(i)) for i in range(space.n_cells))
    for name, justify in columns:
        # cell names stay whole (the numbers column shrink first)
        table.add_column(name, justify=justify, min_width=widest if name in ("view", "at") else None)
    if record.dynamic_kb:
        table.add_column("committed to the KB", justify="left")
    for step in record.steps:
        extra = [", ".join(f"{obj} in {room}" for obj, room in step.commits)] if record.dynamic_kb else []
        table.add_row(
            str(step.index),
            space.cell_name(step.view),
            f"{step.cost:.1f}",
            f"{step.time:.1f}",
            "present" if step.present else "absent",
            f"{step.p_exists:.3f}",
            f"{step.best_belief:.3f}",
            space.cell_name(step.best_cell),
            *extra,
        )
    return table


def verdict_text(space: SearchSpace, record: SearchRecord) -> Text:
    """``found at study:1,3 after 12 steps, 23.5 time units (true cell study:1,3, accuracy 1.000)``; with a
    scene model, the travel and processing parts of the time and the operators applied."""
    text = Text()
    what = {Verdict.FOUND: "found", Verdict.NOT_FOUND: "not found", Verdict.TIME_LIMIT: "time limit"}[record.verdict]
    text.append(what, style=_VERDICT_STYLE[record.verdict])
    if record.reported_cell is not None:
        text.append(f" at {space.cell_name(record.reported_cell)}")
    elif record.verdict is Verdict.NOT_FOUND:
        text.append(" (the target is probably not in the domain)")
    text.append(f" after {len(record.steps)} steps, {record.time:.1f} time units")
    if record.processing_time is not None:
        travel = record.time - record.processing_time
        text.append(
            f" ({travel:.1f} travelling, {record.processing_time:.1f} processing images with "
            f"{record.operators_applied} operator applications)"
        )
    true = "absent" if record.true_cell is None else space.cell_name(record.true_cell)
    text.append(f" (true cell: {true}; accuracy {record.accuracy:.3f})", style="dim")
    return text


def trials_table(summary: Mapping[str, ArmSummary], title: str) -> Table:
    """Per arm of paired trials: verdicts (found / not found / time limit), localisation time (mean ±
    standard deviation), accuracy, reported cells within 4 cells of the truth, steps and
    knowledge-base commits.

    An arm is named ``policy/metareasoning/kb/revision``; the table shows the parts that differ between
    arms (the policy when there is one arm) -- the title says the rest, so the table fits 80 columns."""
    parts = [arm.split("/") for arm in summary]
    varying = [i for i in range(4) if len({p[i] for p in parts}) > 1] or [0]
    common = [f"{what} {parts[0][i]}" for i, what in enumerate(("policy", "metareasoning", "KB", "revision"))]
    shared = [common[i] for i in range(4) if i not in varying]
    if shared:
        title += "; every arm: " + ", ".join(shared)
    dynamic = any(p[2] == "dynamic" for p in parts)
    scenes = any(s.mean_operators is not None for s in summary.values())
    headers = ["n", "verdicts", "time", "accuracy", "≤ 4", "steps"]
    if scenes:  # one column, so that four arms still fit 80 columns
        headers.append("travel\n+scenes")
    if dynamic:
        headers.append("KB+")
    rows = []
    for s, part in zip(summary.values(), parts, strict=True):
        row = [
            " ".join(part[i] for i in varying),
            str(s.trials),
            f"{s.found}/{s.not_found}/{s.time_limit}",
            _pm(s.mean_time, s.stdev_time),
            "-" if s.mean_accuracy is None else f"{s.mean_accuracy:.3f}",
            str(s.within_4_cells),
            "-" if s.mean_steps is None else f"{s.mean_steps:.1f}",
        ]
        if scenes:
            if s.mean_processing_time is None or s.mean_time is None:
                row.append("-")
            else:
                row.append(f"{s.mean_time - s.mean_processing_time:.1f}+{s.mean_processing_time:.1f}")
        if dynamic:
            row.append("-" if part[2] == "static" or s.mean_commits is None else f"{s.mean_commits:.1f}")
        rows.append(row)
    table = Table(title=title, title_justify="left", box=box.SIMPLE_HEAD, show_edge=False, pad_edge=False)
    table.add_column("arm", no_wrap=True)
    for name in headers:  # short headers: 1,000 trials of four arms fit 80 columns
        table.add_column(name, justify="right", no_wrap=True)
    for row in rows:
        table.add_row(*row)
    table.caption = (
        "n: trials; verdicts: found / not found / time limit; time: simulation units, mean±sd; accuracy: a Gaussian of "
        "the error, σ = 2 cells; ≤ 4: searches that reported a cell within 4 cells of the target"
        + (
            "; travel+scenes: the mean time travelling + processing images (operators applied: --json)"
            if scenes
            else ""
        )
        + ("; KB+: facts committed to the knowledge base per search" if dynamic else "")
    )
    table.caption_justify = "left"
    return table


def _pm(mean: float | None, spread: float | None) -> str:
    if mean is None:
        return "-"
    return f"{mean:.1f}" + ("" if spread is None else f"±{spread:.1f}")
