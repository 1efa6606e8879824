"""Random grid worlds of Colledanchise et al. 2020, Sec. VII-A, as map files. Pure: no file I/O;
all randomness comes from the :class:`numpy.random.Generator` passed in.

The world is an open ``side x side`` grid (no layout walls) with ``side = round(sqrt(N / 4))`` as
in the authors' experiments (10^2 states -> 5x5, 10^3 -> 16x16, 10^4 -> 50x50), 4 headings per
cell (the paper's four triangles), four object classes ``A, B, C, D`` (the authors' names), a
``look`` perception action (cost 1, false positive and negative 0.01, so all ``2^4`` seen /
not-seen combinations are its observations) and the actuation actions ``forward``, ``backward``,
``rotate_cw``, ``rotate_ccw`` (cost 10, failure 0.02, as the paper's text says of every move).

``rotation_failure`` sets the rotations' failure apart. The authors' released code (their
``gridworld_triangles.cpp``) gives a rotation probability 0.98 of turning and no other outcome, so
once a belief is normalised, and in their simulated robot, a rotation never fails:
``rotation_failure=0`` is the setting their Tables I and II were measured in.

What ``look`` sees in each state comes from one of two *seen models*:

``objects`` (the default)
    Objects are placed on the map and beliefloc derives what is seen from geometry. For each class
    independently, a count drawn uniformly from ``[1, max(1, cells // 8)]`` and that many distinct
    random cells hold an object of that class (objects of different classes may share a cell).
    On average a class has ``cells / 16`` objects, a cell ``1/4`` of an object in total. The look
    sensor sees an object within :data:`LOOK_RANGE_CELLS` cells (between centres) and within a
    field of view of :data:`LOOK_FOV` degrees centred on the heading; the robot's own cell is seen
    from every heading. On average a state sees one or two classes (15-30% of the states see
    nothing; the number of objects is random), and the seen/not-seen pattern varies enough from
    cell to cell that nearly every state can be told apart from every other by some sequence of
    moves and looks (``tests/test_generate.py`` checks this).

``states`` (the setting of the paper's Tables I and II)
    The authors' released code (``miccol/ICRA2020Experiments``, ``src/workspace.cpp``): for each
    class independently, a count drawn uniformly from ``[0, n_states)`` and then that many distinct
    random *states* (not cells) see that class. There is no geometry; the map lists, for each
    non-empty subset of classes, the states that see exactly that subset as an annotation. State
    ``i`` is ``"r,c,h"`` with ``i = (r * cols + c) * 4 + h``, the same cell-major numbering with
    four consecutive headings as the authors' ``(y * size_x + x) * 4 + orientation``.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from beliefloc.errors import InvalidValueError
from beliefloc.simulation.settings import CLASSES, MOVE_FAILURE, SeenModel

HEADINGS = 4
MOVES = ("forward", "backward", "rotate_cw", "rotate_ccw")
MOVE_COST = 10.0
LOOK_COST = 1.0
LOOK_NOISE = 0.01
"""False positive and false negative rate of every class."""
LOOK_RANGE_CELLS = 2
"""``objects`` model: how far the look sensor sees, in cells (the map's range is this x cell_size)."""
LOOK_FOV = 90.0
"""``objects`` model: the look sensor's field of view in degrees."""
CELL_SIZE = 1.0
MIN_STATES = HEADINGS
"""One cell with its four headings."""
MAX_STATES = 10**7
"""A 1581x1581 grid; beyond that the map file alone is hundreds of megabytes."""
_WRAP = 100
"""Soft width of the generated file's long flow lists."""


@dataclass(frozen=True, eq=False)
class GridWorld:
    """A generated world, before it is written as a map."""

    requested_states: int
    side: int
    seen_model: SeenModel
    landmarks: tuple[tuple[str, int, int], ...] = ()
    """``objects``: (class, row, col), sorted by class, then row and column."""
    seen_states: dict[str, np.ndarray] = field(default_factory=dict)
    """``states``: for each class, the sorted indices of the states that see it."""
    rotation_failure: float = MOVE_FAILURE
    """Failure of ``rotate_cw`` and ``rotate_ccw`` (``forward`` and ``backward`` keep :data:`MOVE_FAILURE`)."""

    @property
    def rows(self) -> int:
        return self.side

    @property
    def cols(self) -> int:
        return self.side

    @property
    def n_states(self) -> int:
        return self.side * self.side * HEADINGS

    def annotations(self) -> list[tuple[tuple[str, ...], np.ndarray]]:
        """``states``: each non-empty subset of classes with the sorted states that see exactly it.

        Subsets come in a fixed order (by size, then in class order); empty groups are left out.
        """
        mask = np.zeros(self.n_states, dtype=np.int64)
        for bit, cls in enumerate(CLASSES):
            if cls in self.seen_states:
                mask[self.seen_states[cls]] |= 1 << bit
        out = []
        for size in range(1, len(CLASSES) + 1):
            for subset in itertools.combinations(range(len(CLASSES)), size):
                value = sum(1 << bit for bit in subset)
                states = np.flatnonzero(mask == value)
                if len(states):
                    out.append((tuple(CLASSES[bit] for bit in subset), states))
        return out


def grid_side(n_states: int) -> int:
    """Side of the square grid for about ``n_states`` states: ``round(sqrt(n_states / 4))``."""
    if not MIN_STATES <= n_states <= MAX_STATES:
        raise InvalidValueError(
            f"the number of states must be between {MIN_STATES} (one cell with {HEADINGS} headings) and "
            f"{MAX_STATES:,}, got {n_states}"
        )
    return max(1, round(math.sqrt(n_states / HEADINGS)))


def generate_gridworld(
    n_states: int,
    rng: np.random.Generator,
    seen_model: SeenModel = SeenModel.OBJECTS,
    *,
    rotation_failure: float = MOVE_FAILURE,
) -> GridWorld:
    """A random world of Sec. VII-A with about ``n_states`` states (see the module docstring).
    ``rotation_failure`` draws nothing: the same generator state gives the same objects or seen states."""
    if not 0.0 <= rotation_failure < 1.0:
        raise InvalidValueError(f"a rotation's failure probability must be in [0, 1), got {rotation_failure:g}")
    side = grid_side(n_states)
    if seen_model is SeenModel.OBJECTS:
        return GridWorld(
            n_states, side, seen_model, landmarks=_place_objects(side, rng), rotation_failure=rotation_failure
        )
    n = side * side * HEADINGS
    seen: dict[str, np.ndarray] = {}
    for cls in CLASSES:
        count = int(rng.integers(0, n))
        seen[cls] = np.sort(rng.choice(n, size=count, replace=False))
    return GridWorld(n_states, side, seen_model, seen_states=seen, rotation_failure=rotation_failure)


def _place_objects(side: int, rng: np.random.Generator) -> tuple[tuple[str, int, int], ...]:
    cells = side * side
    most = max(1, cells // 8)
    landmarks: list[tuple[str, int, int]] = []
    for cls in CLASSES:
        count = int(rng.integers(1, most + 1))
        chosen = np.sort(rng.choice(cells, size=count, replace=False))
        rows, cols = np.divmod(chosen, side)
        landmarks.extend((cls, r, c) for r, c in zip(rows.tolist(), cols.tolist(), strict=True))
    return tuple(landmarks)


def map_name(world: GridWorld, seed: int) -> str:
    return f"gridworld-{world.n_states}-{world.seen_model.value}-seed{seed}"


def gridworld_yaml(world: GridWorld, *, seed: int) -> str:
    """The world as a map file (YAML text), with a commented header saying how it was made."""
    rotations = "" if world.rotation_failure == MOVE_FAILURE else f" --rotation-failure {world.rotation_failure:g}"
    lines = [
        f"# Generated by: beliefloc generate gridworld --states {world.requested_states} --seed {seed} "
        f"--seen-model {world.seen_model.value}{rotations}",
        f"# (numpy.random.default_rng({seed}); the same command writes the same file, byte for byte.)",
        "#",
        f"# A random grid world of Colledanchise et al. 2020, Sec. VII-A: an open {world.rows}x{world.cols} grid "
        "(side round(sqrt(N/4)))",
        f"# with {HEADINGS} headings per cell, object classes {', '.join(CLASSES)}, a look (cost {LOOK_COST:g}) "
        f"with false positive and negative",
        f"# rates {LOOK_NOISE:g}, and moves {', '.join(MOVES)} with cost {MOVE_COST:g} and failure {MOVE_FAILURE:g}.",
    ]
    if world.rotation_failure != MOVE_FAILURE:
        lines.append(
            f"# Rotations fail with probability {world.rotation_failure:g} instead (the authors' code: a rotation "
            "always turns)."
        )
    if world.seen_model is SeenModel.OBJECTS:
        counts = ", ".join(f"{cls} {sum(1 for lm in world.landmarks if lm[0] == cls)}" for cls in CLASSES)
        lines += [
            "#",
            "# Seen model 'objects': for each class, 1..max(1, cells // 8) objects in distinct random cells",
            f"# ({counts}); the look sees an object within {LOOK_RANGE_CELLS} cells and {LOOK_FOV:g} degrees "
            "of the heading.",
        ]
    else:
        counts = ", ".join(f"{cls} {len(world.seen_states[cls])}" for cls in CLASSES)
        lines += [
            "#",
            "# Seen model 'states', as the authors' code (miccol/ICRA2020Experiments, workspace.cpp): per class,",
            f"# a count uniform in [0, {world.n_states}) and that many distinct random states see it ({counts}).",
            "# Each annotation lists the states that see exactly its classes; the other states see nothing.",
        ]
    description = (
        f"Random grid world of Colledanchise et al. 2020 Sec. VII-A ({world.seen_model.value} seen model, seed {seed})"
    )
    lines += [
        f"name: {map_name(world, seed)}",
        f"description: {_quote(description)}",
        f"grid: {{rows: {world.rows}, cols: {world.cols}, cell_size: {CELL_SIZE:g}, headings: {HEADINGS}}}",
    ]
    if world.landmarks:
        lines.append("landmarks:")
        lines += [f"  - {{class: {cls}, cell: [{r}, {c}]}}" for cls, r, c in world.landmarks]
    lines.append("actions:")
    for move in MOVES:
        failure = world.rotation_failure if move.startswith("rotate") else MOVE_FAILURE
        lines.append(f"  {move}: {{cost: {MOVE_COST:g}, failure: {failure:g}}}")
    lines += [
        "sensors:",
        "  look:",
        "    type: look",
        f"    cost: {LOOK_COST:g}",
        f"    classes: [{', '.join(CLASSES)}]",
        f"    false_positive: {LOOK_NOISE:g}",
        f"    false_negative: {LOOK_NOISE:g}",
    ]
    if world.seen_model is SeenModel.OBJECTS:
        lines += [f"    range: {LOOK_RANGE_CELLS * CELL_SIZE:g}", f"    fov_deg: {LOOK_FOV:g}"]
    else:
        annotations = world.annotations()
        if annotations:
            lines.append("annotations:")
        cols = world.cols
        for classes, states in annotations:
            cell, heading = np.divmod(states, HEADINGS)
            row, col = np.divmod(cell, cols)
            names = [f'"{r},{c},{h}"' for r, c, h in zip(row.tolist(), col.tolist(), heading.tolist(), strict=True)]
            lines.append(f"  - look: [{', '.join(classes)}]")
            lines += _flow_list("    states: ", names, indent=6)
    return "\n".join(lines) + "\n"


def _flow_list(prefix: str, items: Sequence[str], *, indent: int) -> list[str]:
    """A YAML flow sequence ``[a, b, ...]`` wrapped at about :data:`_WRAP` characters."""
    out: list[str] = []
    line = prefix + "["
    for i, item in enumerate(items):
        token = item + ("," if i < len(items) - 1 else "")
        if len(line) + 1 + len(token) > _WRAP and not line.endswith("["):
            out.append(line)
            line = " " * indent + token
        else:
            line += ("" if line.endswith("[") else " ") + token
    out.append(line + "]")
    return out


def _quote(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'
