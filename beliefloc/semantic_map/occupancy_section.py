"""What a map with ``occupancy:`` takes from its image before validation: the grid's rows and columns,
and the cells of landmarks written in map-frame metres. Both are refused where written when they
cannot be worked out within the limits."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from beliefloc.errors import FieldError, raise_collected
from beliefloc.model import MapFrame
from beliefloc.semantic_map import observations
from beliefloc.semantic_map.occupancy_grid import grid_shape
from beliefloc.semantic_map.sections import MAX_METRES, MIN_CELL_SIZE, as_number
from beliefloc.source.limits import GEOMETRY_TESTS

if TYPE_CHECKING:
    from beliefloc.semantic_map.occupancy_map import OccupancyMap


def grid_from_occupancy(data: dict[str, Any], occupancy: OccupancyMap) -> dict[str, Any]:
    """The grid's rows and cols of a map with ``occupancy:``: as many cells of ``cell_size`` as it
    takes to cover the image. The file must not give them. Refused before any cell is laid out: a
    cell size too small for the limits (:data:`~beliefloc.source.limits.MODEL_ENTRIES`), a robot radius
    that would take too long to test (:data:`~beliefloc.source.limits.GEOMETRY_TESTS`)."""
    grid = data.get("grid")
    if not isinstance(grid, dict):
        return data  # the field validator says what is wrong
    for key in ("rows", "cols"):
        if key in grid:
            raise FieldError(("grid", key), f"comes from the occupancy image ({data.get('occupancy')}); drop it")
    written = grid.get("cell_size", 1.0)
    cell_size = as_number(written)
    if cell_size is None or not MIN_CELL_SIZE <= cell_size <= MAX_METRES:  # no size of the grid without it
        shown = str(written).lower() if isinstance(written, bool) else repr(written)
        raise FieldError(
            ("grid", "cell_size"),
            f"should be a number of metres from {MIN_CELL_SIZE:g} to {MAX_METRES:g}, got {shown}: the cells of "
            f"the occupancy map {data.get('occupancy')} are laid out by it",
        )
    height, width = occupancy.pixels.shape
    rows, cols = grid_shape(height, width, occupancy.resolution, cell_size)
    headings = grid.get("headings", 4)
    turns = headings if headings in (1, 4, 8) and not isinstance(headings, bool) else 8
    observations.check_grid(rows, cols, turns, ("grid", "cell_size"))
    radius = as_number(grid.get("robot_radius"))
    if radius is not None and 0 < radius <= MAX_METRES:
        reach = math.ceil(radius / occupancy.resolution) + 1  # the offsets occupancy_grid.free_cells tries
        tests = (2 * reach + 1) ** 2 * rows * cols
        if tests > GEOMETRY_TESTS.value:
            raise FieldError(
                ("grid", "robot_radius"),
                too_much_geometry(
                    tests,
                    f"a robot radius of {radius:g} m is {radius / occupancy.resolution:,.0f} pixels of "
                    f"{occupancy.resolution:g} m, tested around each of {rows * cols:,} cells",
                ),
            )
    return {**data, "grid": {**grid, "rows": rows, "cols": cols}}


def too_much_geometry(tests: int, lead: str) -> str:
    limit = GEOMETRY_TESTS
    return (
        f"{lead}: {tests:,} {limit.what} is more than the limit of {limit.value:,}; "
        f"if the input is what you meant, raise it with the environment variable {limit.variable}=N"
    )


def landmark_cells(data: dict[str, Any], occupancy: OccupancyMap | None) -> dict[str, Any]:
    """The cell of every landmark written as ``x``, ``y`` in map-frame metres; a landmark off the map
    or (on an occupancy map) on an occupied pixel is refused where it was written."""
    landmarks, grid = data.get("landmarks"), data.get("grid")
    if not isinstance(landmarks, list) or not isinstance(grid, dict):
        return data
    rows, cols, size = (
        as_number(grid.get(key, default)) for key, default in (("rows", None), ("cols", None), ("cell_size", 1.0))
    )
    if rows is None or cols is None or size is None or size <= 0:
        return data
    frame = occupancy.frame if occupancy is not None else MapFrame()
    filled = []
    errors = []
    for i, landmark in enumerate(landmarks):
        if not isinstance(landmark, dict) or ("x" not in landmark and "y" not in landmark):
            filled.append(landmark)
            continue
        if "cell" in landmark:
            raise FieldError(("landmarks", i, "cell"), "give a landmark's cell or its x and y, not both")
        if "x" not in landmark or "y" not in landmark:
            missing = "y" if "y" not in landmark else "x"
            raise FieldError(
                ("landmarks", i), f"has {'x' if missing == 'y' else 'y'} but no {missing}: give both, in metres"
            )
        x, y = as_number(landmark["x"]), as_number(landmark["y"])
        if x is None or y is None:
            filled.append(landmark)  # the field validator says what is wrong
            continue
        gx, gy = frame.to_grid(x, y)
        if occupancy is not None:
            height, width = occupancy.pixels.shape
            j, i_px = (
                math.floor(float(gx) / occupancy.resolution),
                height - 1 - math.floor(float(gy) / occupancy.resolution),
            )
            if not (0 <= i_px < height and 0 <= j < width):
                errors.append(
                    FieldError(
                        ("landmarks", i, "x"),
                        f"({x:g}, {y:g}) is off the map {data.get('occupancy')}, which covers {map_extent(occupancy)}",
                    )
                )
                continue
            if occupancy.blocked()[i_px, j]:
                errors.append(
                    FieldError(
                        ("landmarks", i, "x"),
                        f"({x:g}, {y:g}) is on an occupied or unknown pixel of {data.get('occupancy')}: put the "
                        "object on the free pixel in front of it, where the robot sees it from",
                    )
                )
                continue
        row = int(rows) - 1 - math.floor(float(gy) / size)  # rows and cols are whole: checked by the grid
        col = math.floor(float(gx) / size)
        if not (0 <= row < rows and 0 <= col < cols):
            errors.append(
                FieldError(
                    ("landmarks", i, "x"), f"({x:g}, {y:g}) is off the {rows:g}x{cols:g} grid of {size:g} m cells"
                )
            )
            continue
        filled.append({**landmark, "cell": [row, col]})
    raise_collected(errors)
    return {**data, "landmarks": filled}


def map_corners(occupancy: OccupancyMap) -> list[tuple[float, float]]:
    """The map-frame corners of the occupancy image: lower-left, lower-right, upper-right, upper-left."""
    width, height = occupancy.size_m
    corners = []
    for gx, gy in ((0.0, 0.0), (width, 0.0), (width, height), (0.0, height)):
        x, y = occupancy.frame.to_map(gx, gy)
        corners.append((float(x), float(y)))
    return corners


def map_extent(occupancy: OccupancyMap) -> str:
    """Where the occupancy map lies in the map frame, for a message: ``x from -10 to 9.2 m and y from
    -10 to 9.2 m``; with a yaw, its four corners."""
    corners = map_corners(occupancy)
    if occupancy.frame.yaw == 0.0:
        (x0, y0), _, (x1, y1), _ = corners
        return f"x from {x0:.6g} to {x1:.6g} m and y from {y0:.6g} to {y1:.6g} m (map frame)"
    shown = ", ".join(f"({x:.4g}, {y:.4g})" for x, y in corners)
    return f"the rectangle {shown} m (map frame, origin yaw {occupancy.frame.yaw:g} rad)"
