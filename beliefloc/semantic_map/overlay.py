"""What ``beliefloc init map NAME --occupancy MAP.yaml`` chooses for an overlay on a SLAM map: the
cell size (from the map's size), the scan's bins (from the cell size) and where to put examples.

The cell-size rule: the smallest of :data:`CELL_SIZES` that is at least two of the map's pixels and
leaves at most :data:`OVERLAY_CELLS` cells (rows × cols) over the whole image; on a map too large
for the largest of them, the size that leaves :data:`OVERLAY_CELLS` cells, rounded up to one
significant digit. With 8 headings that is at most 80,000 states, fewer where the map is not free:
small enough to plan on in seconds, fine enough that a corridor is a few cells wide.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from beliefloc.semantic_map.occupancy_grid import grid_shape

if TYPE_CHECKING:
    from beliefloc.semantic_map.occupancy_map import OccupancyMap

CELL_SIZES = (0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.4, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 5.0, 10.0)
"""The cell sizes (metres) the rule picks from."""
OVERLAY_CELLS = 10_000
"""The most cells (rows × cols) the rule leaves over the map."""
BIN_CELLS = (1, 2, 4, 8)
"""The scan's bin edges, in cells: a wall within one cell, two, four, eight, or beyond."""


def overlay_cell_size(width_px: int, height_px: int, resolution: float) -> float:
    """The cell size for an overlay on a ``width_px`` × ``height_px`` map of ``resolution`` m/pixel."""
    for size in CELL_SIZES:
        if size < 2 * resolution - 1e-12:
            continue
        rows, cols = grid_shape(height_px, width_px, resolution, size)
        if rows * cols <= OVERLAY_CELLS:
            return size
    area = width_px * height_px * resolution * resolution
    wanted = math.sqrt(area / OVERLAY_CELLS)
    magnitude = 10.0 ** math.floor(math.log10(wanted))
    return math.ceil(wanted / magnitude) * magnitude


def scan_bins(cell_size: float) -> list[float]:
    """The scan's upper bin edges in metres for cells of ``cell_size``."""
    return [round(k * cell_size, 6) for k in BIN_CELLS]


def free_spot(occupancy: OccupancyMap) -> tuple[float, float] | None:
    """Map-frame metres of the free pixel nearest the image's centre (where an example object can
    stand), or None when no pixel is free."""
    free = np.argwhere(~occupancy.blocked())
    if len(free) == 0:
        return None
    centre = np.array([occupancy.height / 2.0, occupancy.width / 2.0])
    row, col = free[int(np.argmin(((free + 0.5 - centre) ** 2).sum(axis=1)))]
    x, y = occupancy.pixel_centre(int(row), int(col))
    return float(x), float(y)


def align_comments(text: str, column: int = 40) -> str:
    """Trailing ``# comments`` of the YAML lines (not of comment lines) start at ``column`` or,
    when the value is longer, two spaces after it."""
    lines = []
    for line in text.splitlines():
        at = line.find("  #")
        if line.lstrip().startswith("#") or at < 0:
            lines.append(line)
            continue
        value, comment = line[:at].rstrip(), line[at:].lstrip()
        lines.append(f"{value:<{column - 1}} {comment}" if len(value) < column - 1 else f"{value}  {comment}")
    return "\n".join(lines) + "\n"
