"""The localizability verdict as a picture (PNG or SVG): the states the robot can never tell apart,
drawn as linked arrows on the map.

A macro table (:class:`~beliefloc.planning.macros.MacroTable`) knows the pairs of states that no
sequence of actions distinguishes in the noise-free model (:meth:`~beliefloc.planning.macros.MacroTable.never`).
The picture draws the map as the belief pictures do (:func:`beliefloc.render.picture_belief.draw_belief`,
with no belief: blocked cells hatched, landmarks, on small grids every state's triangle outlined), then

* **every state of a never-distinguishable pair** as an arrow at its pose: in its heading's
  triangle of its cell, pointing along its heading (a dot with one heading, where there is no yaw);
* **every never-distinguishable pair** as a straight line between its two states' arrows.

States linked directly or through others form a class (:meth:`~beliefloc.planning.macros.MacroTable.never_classes`):
the arrows and links of a class share a colour, the classes cycling through ten. The colour only
helps to follow a link; the link itself says which states look alike. A map the robot can always
localize in has no arrows and no links, and its title says so.

The functions here only observe a model and a table; matplotlib is reached through
:mod:`beliefloc.render.figures`. :func:`drawn_links` and :func:`drawn_states` count what a figure
holds (a test's view of the picture, without reading pixels).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import AbstractContextManager, contextmanager
from typing import TYPE_CHECKING, Any

import numpy as np

from beliefloc.model import GridLayout, Model
from beliefloc.planning.macros import MacroTable
from beliefloc.render.figures import add_lines, figure
from beliefloc.render.picture_belief import draw_belief, figure_size, state_polygons

if TYPE_CHECKING:
    from matplotlib.figure import Figure

LINKS_GID = "never-distinguishable-links"
"""The ``gid`` of the links' collection (also its id in an SVG)."""
STATES_GID = "never-distinguishable-states"
"""The ``gid`` of the arrows (or dots) of the linked states."""
CLASS_COLOURS = (
    "#d62728",
    "#1f77b4",
    "#2ca02c",
    "#9467bd",
    "#ff7f0e",
    "#8c564b",
    "#e377c2",
    "#17becf",
    "#7f7f7f",
    "#bcbd22",
)
"""A class's colour, cycling (matplotlib's tab10, red first)."""
WIDE = 0.75
"""As :data:`beliefloc.render.picture_belief.WIDE`: a wider map gets its legend under it."""
_Z_LINKS, _Z_STATES = 6, 7


def never_pairs(table: MacroTable) -> tuple[np.ndarray, np.ndarray]:
    """The two states of every never-distinguishable pair, ``(i, j)`` with ``i < j``, in the table's order."""
    never = table.never()
    return table.pair_i[never].astype(np.int64), table.pair_j[never].astype(np.int64)


def verdict_title(model: Model, table: MacroTable) -> str:
    """Two lines: the map and the verdict, then how many pairs, states and classes; e.g.
    ``ladder-symmetric: not localizable`` / ``60 pairs of states never told apart (120 states, 60 classes)``."""
    classes = table.never_classes()
    if not classes:
        return f"{model.name}: localizable\nevery pair of states can be told apart by some sequence of actions"
    pairs = len(table.never())
    states = sum(map(len, classes))
    return (
        f"{model.name}: not localizable\n{pairs} pair{'s' if pairs != 1 else ''} of states never told apart "
        f"({states} states, {len(classes)} class{'es' if len(classes) != 1 else ''})"
    )


def draw_never_pairs(ax: Any, model: Model, table: MacroTable) -> None:
    """On ``ax`` (a map already drawn in map-frame metres): the arrows of the states of the
    never-distinguishable pairs and a line for each pair (see the module docstring), labelled for a
    legend. ValueError when the model has no grid or the table is of another number of states."""
    grid = _grid(model)
    if table.n_states != model.n_states:
        raise ValueError(f"a table of {table.n_states} states does not fit model {model.name!r} ({model.n_states})")
    classes = table.never_classes()
    if not classes:
        return
    colour_of = np.full(model.n_states, -1, dtype=np.int64)
    for k, members in enumerate(classes):
        colour_of[members] = k % len(CLASS_COLOURS)
    limits = ax.get_xlim(), ax.get_ylim()  # the map's; scatter and quiver would rescale to the arrows
    i, j = never_pairs(table)
    states = np.unique(np.concatenate([i, j])) if len(i) else np.zeros(0, dtype=np.int64)
    centres = _centres(grid, states)
    where = {int(s): centres[k] for k, s in enumerate(states.tolist())}
    segments = [np.array([where[int(a)], where[int(b)]]) for a, b in zip(i.tolist(), j.tolist(), strict=True)]
    add_lines(
        ax,
        segments,
        colors=[CLASS_COLOURS[colour_of[a]] for a in i.tolist()] or "black",
        linewidth=1.0,
        alpha=0.6,
        zorder=_Z_LINKS,
        label="never told apart\n(a line per pair)",
        gid=LINKS_GID,
    )
    colours = [CLASS_COLOURS[colour_of[s]] for s in states.tolist()]
    label = "a state another state\nalways looks like"
    if grid.headings == 1:
        dots = ax.scatter(
            centres[:, 0],
            centres[:, 1],
            s=36,
            c=colours or "black",
            edgecolors="black",
            linewidths=0.6,
            zorder=_Z_STATES,
            label=label,
        )
        dots.set_gid(STATES_GID)
        ax.set_xlim(*limits[0])
        ax.set_ylim(*limits[1])
        return
    yaw = np.asarray(grid.heading_yaw(grid.cell_heading(states)[2]), dtype=np.float64)
    length = 0.32 * grid.cell_size
    arrows = ax.quiver(
        centres[:, 0],
        centres[:, 1],
        length * np.cos(yaw),
        length * np.sin(yaw),
        color=colours,
        angles="xy",
        scale_units="xy",
        scale=1.0,
        units="xy",
        width=0.05 * grid.cell_size,
        headwidth=3.2,
        headlength=3.2,
        headaxislength=2.8,
        pivot="middle",
        edgecolor="black",
        linewidth=0.4,
        zorder=_Z_STATES,
    )
    arrows.set_gid(STATES_GID)
    ax.set_xlim(*limits[0])
    ax.set_ylim(*limits[1])
    ax.plot(  # the legend's entry: a quiver has no handle of its own
        [],
        [],
        linestyle="none",
        marker=r"$\rightarrow$",
        markersize=12,
        color=CLASS_COLOURS[0],
        label=label + "\n(an arrow along its heading)",
    )


def _grid(model: Model) -> GridLayout:
    if model.grid is None:
        raise ValueError(f"model {model.name!r} has no grid to draw")
    return model.grid


def _centres(grid: GridLayout, states: np.ndarray) -> np.ndarray:
    """Map-frame ``(x, y)`` of each state's triangle's centroid (its cell's centre with one heading)."""
    if len(states) == 0:
        return np.zeros((0, 2))
    vertices = state_polygons(grid, states)
    distinct = vertices if grid.headings == 1 else vertices[:, :3]
    centres: np.ndarray = distinct.mean(axis=1)
    return centres


def _extent(grid: GridLayout) -> tuple[float, float, float, float]:
    w, h = grid.cols * grid.cell_size, grid.rows * grid.cell_size
    x, y = grid.frame.to_map(np.array([0.0, w, w, 0.0]), np.array([0.0, 0.0, h, h]))
    return float(np.min(x)), float(np.max(x)), float(np.min(y)), float(np.max(y))


@contextmanager
def _macros_figure(model: Model, table: MacroTable, title: str | None) -> Iterator[Figure]:
    grid = _grid(model)
    extent = _extent(grid)
    width, height, below = figure_size(extent)
    with figure(width, height - (0.3 if below else 0.0)) as fig:  # no colour bar under a wide map
        fig.set_layout_engine("constrained")
        ax = fig.add_subplot()
        draw_belief(ax, model, np.zeros(model.n_states), colorbar=False)
        draw_never_pairs(ax, model, table)
        ax.set_title(title if title is not None else verdict_title(model, table), fontsize=10)
        for legend in list(fig.legends):  # the map's legend, rebuilt with the arrows and links
            legend.remove()
        handles, labels = ax.get_legend_handles_labels()
        if below:
            fig.legend(
                handles, labels, loc="outside lower center", ncol=min(2, len(handles)), fontsize=8, frameon=False
            )
        else:
            fig.legend(handles, labels, loc="outside right upper", fontsize=8, frameon=False)
        yield fig


def macros_figure(model: Model, table: MacroTable, *, title: str | None = None) -> AbstractContextManager[Figure]:
    """A figure of ``model``'s map with the never-distinguishable pairs of ``table`` (see the module
    docstring), sized from the map's aspect ratio, titled with the verdict (:func:`verdict_title`)
    unless ``title`` is given; closed when the ``with`` block ends."""
    return _macros_figure(model, table, title)


def drawn_links(fig: Any) -> int:
    """How many pair links ``fig`` holds (the segments of its :data:`LINKS_GID` collections)."""
    return sum(
        len(artist.get_segments()) for ax in fig.axes for artist in ax.collections if artist.get_gid() == LINKS_GID
    )


def drawn_states(fig: Any) -> int:
    """How many linked states ``fig`` holds as arrows or dots (its :data:`STATES_GID` artists)."""
    return sum(
        len(artist.get_offsets()) for ax in fig.axes for artist in ax.collections if artist.get_gid() == STATES_GID
    )
