"""Tables of knowledge-base priors and answer sets."""

from __future__ import annotations

from typing import TYPE_CHECKING

from rich.table import Table

if TYPE_CHECKING:  # the records only: rendering them needs no clingo
    from beliefloc.knowledge import AnswerSet, RobotPrior, RoomPrior


def prior_table(prior: RoomPrior, title: str) -> Table:
    """Rooms with alpha (Eq. 4) and the prior (Eq. 5)."""
    table = Table(title=title, title_justify="left")
    table.add_column("room")
    table.add_column("alpha", justify="right")
    table.add_column("prior", justify="right")
    table.add_column("support")
    for room in prior.rooms:
        terms = [t for t in prior.terms if t.room == room]
        if prior.uniform:
            note = "none (uniform)"
        elif room in prior.floored:
            note = "none (floor)"
        else:
            note = ", ".join(f"{t.count} {t.primary}" for t in terms)
        table.add_row(room, f"{prior.alpha[room]:.3f}", f"{prior.prior[room]:.3f}", note)
    return table


def robot_prior_table(prior: RobotPrior, title: str, cells: dict[str, int] | None = None) -> Table:
    """Rooms with the robot's prior, why each has it, and (on a map) its number of cells."""
    table = Table(title=title, title_justify="left")
    table.add_column("room")
    table.add_column("prior", justify="right")
    if cells is not None:
        table.add_column("cells", justify="right")
    table.add_column("knowledge base")
    others = len(prior.rooms) - len(prior.believed)
    for room in prior.rooms:
        if prior.uniform:
            note = "nothing known (uniform)"
        elif room in prior.believed:
            note = f"the robot is here: w = {prior.weight:g}" + (
                f" / {len(prior.believed)}" if len(prior.believed) > 1 else ""
            )
        else:
            note = f"elsewhere: (1 - w) / {others}" if others > 1 else "elsewhere: 1 - w"
        row = [room, f"{prior.prior[room]:.3f}"]
        if cells is not None:
            row.append(str(cells.get(room, 0)))
        table.add_row(*row, note)
    return table


def psi_table(prior: RoomPrior) -> Table:
    """Every psi term of Eq. 3-4: room, primary class, count a, LCA, H, W_1..W_H, psi."""
    table = Table(
        title=f"support for a {prior.target}: psi = (ln a + 1) / (W_1 x ... x W_H)",
        title_justify="left",
        caption="W_h: children of the class at height h on the way up from the primary class (h = 1) to the LCA",
    )
    for name in ("room", "class", "a", "LCA", "H", "W", "psi"):
        table.add_column(name, justify="right" if name in ("a", "H", "psi") else "left")
    for term in prior.terms:
        table.add_row(
            term.room,
            term.primary,
            str(term.count),
            term.lca,
            str(term.height),
            " x ".join(str(w) for w in term.weights),
            f"{term.psi:.3f}",
        )
    return table


def answer_table(answer: AnswerSet, step: int) -> Table:
    """The ``holds`` literals at ``step`` grouped by fluent, and the ``ab`` atoms."""
    caption = f"{answer.models} answer set" + ("" if answer.models == 1 else "s: their cautious consequences")
    table = Table(title=f"beliefs at step {step}", caption=caption, title_justify="left")
    table.add_column("fluent")
    table.add_column("n", justify="right")
    table.add_column("literals")
    for group, literals in answer.grouped(step).items():
        table.add_row(group, str(len(literals)), " ".join(str(lit) for lit in literals))
    if answer.abnormal:
        table.add_row("ab", str(len(answer.abnormal)), " ".join(answer.abnormal))
    return table
