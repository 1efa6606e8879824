"""Tables of models and maps."""

from __future__ import annotations

from typing import Any

from rich.table import Table


def model_table(summary: dict[str, Any], seconds: float | None = None) -> Table:
    """The actions of a model with their sizes and sparsity."""
    grid = summary["grid"]
    caption = f"{summary['states']} states"
    if grid is not None:
        caption += (
            f" on a {grid['rows']}x{grid['cols']} grid ({grid['free_cells']} free cells x "
            f"{grid['headings']} headings, cells of {grid['cell_size']:g} m, {grid['landmarks']} landmarks)"
        )
    if seconds is not None:
        caption += f"; built in {seconds:.3f} s"
    table = Table(title=f"model {summary['name']}", caption=caption, title_justify="left")
    table.add_column("action")
    table.add_column("kind")
    table.add_column("cost", justify="right")
    table.add_column("observations", justify="right")
    table.add_column("observed parts")
    table.add_column("T non-zeros", justify="right")
    table.add_column("T density", justify="right")
    for action in summary["actions"]:
        table.add_row(
            action["name"],
            action["kind"],
            f"{action['cost']:g}",
            str(action["observations"]),
            ", ".join(action["observation_parts"]) or "none",
            "identity" if action["kind"] == "perception" else str(action["transition_nonzeros"]),
            "" if action["kind"] == "perception" else f"{action['transition_density']:.2e}",
        )
    return table
