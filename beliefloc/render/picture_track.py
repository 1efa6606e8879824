"""The picture of ``track --bag -o``: the occupancy map, the final belief over the cells (summed over
headings), the path of the belief's best pose over the run, and the final pose."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from beliefloc.continuous.grid_filter import GridFilter
from beliefloc.recordings.replay import TrackResult
from beliefloc.render.figures import add_image, figure, save_figure

_FREE, _OCCUPIED, _UNKNOWN = 1.0, 0.0, 0.75


def write_track_picture(path: Path, grid: GridFilter, result: TrackResult, title: str) -> None:
    """Draw and write (atomically) the picture of a tracked run."""
    from beliefloc.semantic_map.occupancy_map import Occupancy

    occupancy = grid.occupancy
    width_m, height_m = occupancy.size_m
    aspect = height_m / width_m if width_m > 0 else 1.0
    inches = 9.0
    with figure(inches, max(3.0, min(14.0, inches * aspect + 1.0))) as fig:
        ax = fig.add_subplot(1, 1, 1)
        greys = np.full(occupancy.pixels.shape, _UNKNOWN, dtype=np.float32)
        greys[occupancy.pixels == Occupancy.FREE] = _FREE
        greys[occupancy.pixels == Occupancy.OCCUPIED] = _OCCUPIED
        frame = occupancy.frame
        add_image(ax, greys, width=width_m, height=height_m, x=frame.x, y=frame.y, yaw=frame.yaw, zorder=0)
        # the belief over the window's cells, as an RGBA overlay whose alpha grows with the mass
        w = grid.window
        cells = grid.belief.sum(axis=0)
        top = float(cells.max()) if cells.size else 0.0
        if top > 0:
            rgba = np.zeros((*cells.shape, 4), dtype=np.float32)
            rgba[..., 0] = 0.85
            rgba[..., 1] = 0.1
            rgba[..., 2] = 0.1
            rgba[..., 3] = np.sqrt(cells / top) * 0.9
            gx0, gy0 = w.col0 * w.cell_size, (w.grid_rows - w.row0 - w.rows) * w.cell_size
            x0, y0 = frame.to_map(gx0, gy0)
            add_image(
                ax,
                rgba,
                width=w.cols * w.cell_size,
                height=w.rows * w.cell_size,
                x=float(x0),
                y=float(y0),
                yaw=frame.yaw,
                zorder=2,
            )
        if result.updates:
            xs = [u.x for u in result.updates]
            ys = [u.y for u in result.updates]
            ax.plot(xs, ys, color="#1f5fbf", linewidth=1.2, zorder=3, label="best pose at each update")
            sure = [u for u in result.updates if u.localized]
            if sure:
                ax.scatter([u.x for u in sure], [u.y for u in sure], s=6, color="#1f9f3f", zorder=4, label="localized")
        rivals = [m for m in result.modes[1:] if m.probability > 0]
        if rivals and not result.localized:
            ax.scatter(
                [m.x for m in rivals],
                [m.y for m in rivals],
                s=120,
                facecolors="none",
                edgecolors="#d07010",
                linewidths=1.5,
                zorder=5,
                label="other places left",
            )
        x, y, yaw = result.pose
        length = max(0.3, 0.04 * max(width_m, height_m))
        colour = "#1f9f3f" if result.localized else "#d07010"
        ax.annotate(
            "",
            xy=(x + length * math.cos(yaw), y + length * math.sin(yaw)),
            xytext=(x, y),
            arrowprops={"arrowstyle": "-|>", "color": colour, "linewidth": 2.0},
            zorder=5,
        )
        ax.scatter([x], [y], s=30, color=colour, zorder=5, label="final pose" if result.localized else "best guess")
        cx, cy = frame.to_map(np.array([0.0, width_m, width_m, 0.0]), np.array([0.0, 0.0, height_m, height_m]))
        ax.set_xlim(float(cx.min()), float(cx.max()))
        ax.set_ylim(float(cy.min()), float(cy.max()))
        ax.set_aspect("equal")
        ax.set_xlabel("x (m, map frame)")
        ax.set_ylabel("y (m)")
        ax.set_title(title, fontsize=9)
        ax.legend(loc="upper right", fontsize=7)
        fig.tight_layout()
        save_figure(fig, path)
