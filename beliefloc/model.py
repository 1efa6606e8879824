"""The compiled belief model (Colledanchise Defs. 1-7): states, and for every action a transition
and an observation model, plus costs. No I/O here; see :mod:`beliefloc.files.model_file` and
:mod:`beliefloc.pomdp_format` for files.

Conventions
-----------
* ``T[i, j] = P(s_j | s_i, a)`` -- a scipy CSR matrix whose rows sum to 1. A perception action has
  ``transition = None``, meaning the identity (perceiving does not move the robot).
* ``O[j, o] = P(o | s_j, a)`` evaluated at the state *reached*. Observations are stored factored:
  an :class:`ObservationModel` is a product of independent :class:`ObservationPart` s (one per Look
  class, one per Scan, ...), so ``O[j, o] = prod_p C_p[truth_p[j], o_p]``. A joint observation index
  is mixed-radix over the parts, the first part most significant. An action with no parts has the
  single observation ``none`` with probability 1.
"""

from __future__ import annotations

import enum
import hashlib
import math
import re
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, overload

import numpy as np

from beliefloc.errors import InvalidValueError

if TYPE_CHECKING:
    import scipy.sparse as sp

NONE_OBSERVATION = "none"
"""The one observation of an action that senses nothing."""
NOTHING = "nothing"
"""Joint observation name when every part reads its silent value (e.g. no class seen)."""
_MAX_LISTED = 12


class ActionKind(enum.Enum):
    ACTUATION = "actuation"
    PERCEPTION = "perception"


@dataclass(frozen=True, eq=False)
class ObservationPart:
    """One independent component of an observation.

    ``confusion[v, w] = P(reading w | true value v)``; ``truth[j]`` is the true value in state j.
    ``values[w]`` names reading w; an empty name is *silent*: it is left out of joint names (Look's
    "not seen"), so a joint observation reads ``chair+potted_plant`` or ``nothing``.
    """

    name: str
    values: tuple[str, ...]
    truth: np.ndarray
    confusion: np.ndarray
    aliases: dict[str, int] = field(default_factory=dict)
    """Extra spellings accepted on the command line, e.g. ``window_seen`` or ``window_not_seen``."""

    @property
    def n_values(self) -> int:
        return len(self.values)


@dataclass(frozen=True, eq=False)
class ObservationModel:
    """``P(o | s)`` for every joint observation ``o`` of one action, stored factored."""

    n_states: int
    parts: tuple[ObservationPart, ...] = ()

    def __post_init__(self) -> None:
        for part in self.parts:
            if part.truth.shape != (self.n_states,):
                raise ValueError(f"part {part.name}: truth has shape {part.truth.shape}, not ({self.n_states},)")
            if part.confusion.shape[1] != part.n_values:
                raise ValueError(f"part {part.name}: confusion has {part.confusion.shape[1]} columns")

    @cached_property
    def radix(self) -> tuple[int, ...]:
        return tuple(part.n_values for part in self.parts)

    @property
    def n_observations(self) -> int:
        return math.prod(self.radix)

    def decode(self, o: int) -> tuple[int, ...]:
        """Joint index -> the reading of each part."""
        if not 0 <= o < self.n_observations:
            raise IndexError(o)
        digits = []
        for base in reversed(self.radix):
            o, digit = divmod(o, base)
            digits.append(digit)
        return tuple(reversed(digits))

    def encode(self, readings: Sequence[int]) -> int:
        o = 0
        for base, digit in zip(self.radix, readings, strict=True):
            o = o * base + digit
        return o

    def name(self, o: int) -> str:
        if not self.parts:
            return NONE_OBSERVATION
        tokens = [p.values[w] for p, w in zip(self.parts, self.decode(o), strict=True) if p.values[w]]
        return "+".join(tokens) if tokens else NOTHING

    def names(self) -> list[str]:
        return [self.name(o) for o in range(self.n_observations)]

    def index(self, text: str) -> int:
        """Parse an observation name: ``chair+potted_plant``, ``window_seen``, ``nothing``, ``no_wall``."""
        text = text.strip()
        if not self.parts:
            if text in (NONE_OBSERVATION, NOTHING, ""):
                return 0
            raise InvalidValueError(f"observation {text!r}: this action observes nothing (use 'none' or omit it)")
        whole = any(text in p.values or text in p.aliases for p in self.parts)  # e.g. imported names with '+'
        if text in (NOTHING, NONE_OBSERVATION) and not whole:
            tokens: list[str] = []
        else:
            tokens = [text] if whole else [t.strip() for t in text.split("+")]
        options = [self._readers(token) for token in tokens]
        for token, readers in zip(tokens, options, strict=True):
            if not readers:
                which = f"{token!r} is not a reading; " if len(tokens) > 1 else ""
                raise InvalidValueError(f"unknown observation {text!r}: {which}{self.choices()}")
        readings = self._assign(options, 0, {})
        if readings is None:
            silent_free = [p.name for p in self.parts if "" not in p.values]
            need = f" ({', '.join(silent_free)} must read something)" if silent_free else ""
            raise InvalidValueError(f"observation {text!r} cannot be read one token per part{need}: {self.choices()}")
        return self.encode(
            [readings.get(p, part.values.index("") if "" in part.values else 0) for p, part in enumerate(self.parts)]
        )

    def _readers(self, token: str) -> list[tuple[int, int]]:
        """(part, reading) pairs that ``token`` can stand for."""
        out = []
        for p, part in enumerate(self.parts):
            w = part.values.index(token) if token and token in part.values else part.aliases.get(token)
            if w is not None:
                out.append((p, w))
        return out

    def _assign(self, options: list[list[tuple[int, int]]], i: int, chosen: dict[int, int]) -> dict[int, int] | None:
        """Give every token its own part (backtracking, parts tried in order) so that each part
        without a silent value gets a reading; None if impossible. A joint name has at most one
        token per part, so the search is tiny."""
        if i == len(options):
            complete = all(p in chosen or "" in part.values for p, part in enumerate(self.parts))
            return dict(chosen) if complete else None
        for p, w in options[i]:
            if p not in chosen:
                chosen[p] = w
                found = self._assign(options, i + 1, chosen)
                del chosen[p]
                if found is not None:
                    return found
        return None

    def choices(self) -> str:
        """The observations, listed when few, else how to write one (for error messages)."""
        if self.n_observations <= _MAX_LISTED:
            return "expected one of " + ", ".join(self.names())
        parts = "; ".join(f"{p.name}: {', '.join(v or '(not seen)' for v in p.values)}" for p in self.parts)
        return f"join one reading per part with '+' ({parts})"

    def likelihood(self, o: int, states: np.ndarray | None = None) -> np.ndarray:
        """``O[:, o]``: P(o | s_j) for every state (or for ``states``), a new float64 array."""
        readings = self.decode(o)
        out: np.ndarray | None = None
        for part, w in zip(self.parts, readings, strict=True):
            truth = part.truth if states is None else part.truth[states]
            column = part.confusion[:, w][truth]
            out = column if out is None else out * column
        if out is None:
            return np.ones(self.n_states if states is None else len(states))
        return out.astype(np.float64, copy=False)

    def likelihood_matrix(self, states: np.ndarray) -> np.ndarray:
        """Dense ``O[states, :]`` with shape (len(states), n_observations)."""
        table = np.ones((len(states), 1))
        for part in self.parts:
            block = part.confusion[part.truth[states]]  # (len(states), n_values)
            table = (table[:, :, None] * block[:, None, :]).reshape(len(states), -1)
        return table

    def probabilities(self, predicted: np.ndarray) -> np.ndarray:
        """``p(o) = sum_j predicted_j O[j, o]`` for every o (Colledanchise's ``p(obs | act, b)``).

        States with the same true readings share a row of O, so we sum the belief per distinct
        signature first: a 10^6-state belief becomes a handful of rows.
        """
        support = np.flatnonzero(predicted)
        if not self.parts:
            return np.array([predicted[support].sum()])
        key = np.zeros(len(support), dtype=np.int64)
        for part in self.parts:
            key = key * part.confusion.shape[0] + part.truth[support]
        signatures, first, inverse = np.unique(key, return_index=True, return_inverse=True)
        mass = np.bincount(inverse.ravel(), weights=predicted[support], minlength=len(signatures))
        result: np.ndarray = mass @ self.likelihood_matrix(support[first])
        return result

    def matrix(self) -> sp.csr_matrix:
        """The full ``|S| x |Omega|`` observation matrix, sparse (for export and comparison)."""
        import scipy.sparse as sp  # here, not at import: reading a map needs no scipy

        if not self.parts:
            return sp.csr_matrix(np.ones((self.n_states, 1)))
        states = np.arange(self.n_states)
        rows = []
        for start in range(0, self.n_states, 4096):
            rows.append(sp.csr_matrix(self.likelihood_matrix(states[start : start + 4096])))
        return sp.vstack(rows).tocsr()

    def true_observation(self, state: int) -> int:
        """The most likely reading of every part in ``state`` (the noise-free observation)."""
        return self.encode([int(np.argmax(p.confusion[p.truth[state]])) for p in self.parts])


@dataclass(frozen=True, eq=False)
class Action:
    name: str
    kind: ActionKind
    cost: float
    transition: sp.csr_matrix | None
    """``T[i, j] = P(s_j | s_i, a)``; None for a perception action (the identity)."""
    observation: ObservationModel

    @property
    def is_actuation(self) -> bool:
        return self.kind is ActionKind.ACTUATION

    @cached_property
    def transition_transposed(self) -> sp.csr_matrix | None:
        """``T_aᵀ`` as CSR, kept once: prediction is ``T_aᵀ b``, and rebuilding the transpose's
        wrapper on every call was a third of the planner's successor time."""
        return None if self.transition is None else self.transition.T.tocsr()


def wrap_angle(angle: np.ndarray | float) -> np.ndarray:
    """``angle`` (radians) wrapped to (-pi, pi]."""
    wrapped: np.ndarray = math.pi - np.mod(math.pi - np.asarray(angle, dtype=np.float64), 2 * math.pi)
    return wrapped


@dataclass(frozen=True)
class MapFrame:
    """The pose of a grid's lower-left corner in the map frame (ROS ``map``): metres and a yaw in
    radians, counter-clockwise. An occupancy map's ``origin`` [x, y, yaw] is exactly this."""

    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0

    @property
    def is_identity(self) -> bool:
        return self.x == 0.0 and self.y == 0.0 and self.yaw == 0.0

    def to_map(self, gx: np.ndarray | float, gy: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """Grid-frame metres -> map-frame metres (rotate by yaw, then translate)."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        gx, gy = np.asarray(gx, dtype=np.float64), np.asarray(gy, dtype=np.float64)
        return self.x + c * gx - s * gy, self.y + s * gx + c * gy

    def to_grid(self, x: np.ndarray | float, y: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """Map-frame metres -> grid-frame metres (the inverse of :meth:`to_map`)."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        dx, dy = np.asarray(x, dtype=np.float64) - self.x, np.asarray(y, dtype=np.float64) - self.y
        return c * dx + s * dy, -s * dx + c * dy

    def as_json(self) -> dict[str, float]:
        return {"x": self.x, "y": self.y, "yaw": self.yaw}


Landmark = tuple[str, int, int]
"""A landmark on a grid: its class, row and column."""


class LandmarkTable(Sequence[Landmark]):
    """A grid's landmarks kept as a table of class indices, rows and columns (a model file's
    ``grid_landmarks``), made into :data:`Landmark` triples only when one is asked for. A 10^7-state
    world has 1.09 million landmarks, and building their tuples took 0.5 s of every command reading
    its model, though planning never looks at them."""

    def __init__(self, classes: Sequence[str], table: np.ndarray) -> None:
        self._classes = tuple(classes)
        self._table = table

    def __len__(self) -> int:
        return len(self._table)

    def as_table(self) -> tuple[tuple[str, ...], np.ndarray]:
        """The class names and the table (class index, row, column) it reads, without making triples."""
        return self._classes, self._table

    @cached_property
    def _triples(self) -> tuple[Landmark, ...]:
        from beliefloc.source.located import gc_paused

        with gc_paused():  # a million tuples that live on (the collector walked them: 0.25 s at 10^7)
            names = np.array(self._classes, dtype=object)[self._table[:, 0]].tolist()
            return tuple(zip(names, self._table[:, 1].tolist(), self._table[:, 2].tolist(), strict=True))

    @overload
    def __getitem__(self, index: int) -> Landmark: ...
    @overload
    def __getitem__(self, index: slice) -> tuple[Landmark, ...]: ...
    def __getitem__(self, index: int | slice) -> Landmark | tuple[Landmark, ...]:
        return self._triples[index]

    def __iter__(self) -> Iterator[Landmark]:
        return iter(self._triples)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Sequence):
            return NotImplemented
        return len(self) == len(other) and self._triples == tuple(other)

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return f"LandmarkTable({len(self)} landmarks)"


@dataclass(frozen=True, eq=False)
class GridLayout:
    """Where the states are on the map, for drawing and for naming states ``"row,col,heading"``.

    The grid's own frame has its origin at the lower-left corner of cell ``(rows - 1, 0)``, x along
    the columns, y up the rows (row 0 is the top): cell ``(r, c)`` covers
    ``c·s <= x < (c+1)·s`` and ``(rows-1-r)·s <= y < (rows-r)·s`` with ``s = cell_size``. Heading 0
    points up (+y, north), clockwise. :attr:`frame` places that frame in the map frame (ROS ``map``).
    """

    rows: int
    cols: int
    headings: int
    cell_size: float
    free: np.ndarray
    """``free[r, c]``; states are the free cells in row-major order, times headings."""
    landmarks: Sequence[Landmark] = ()
    frame: MapFrame = field(default_factory=lambda: MapFrame())
    """Where the grid's lower-left corner is in the map frame (the identity for a hand-written grid)."""

    def cell_centre(self, row: np.ndarray | int, col: np.ndarray | int) -> tuple[np.ndarray, np.ndarray]:
        """Map-frame metres of the centre of cell ``(row, col)`` (one or many)."""
        s = self.cell_size
        gx = (np.asarray(col, dtype=np.float64) + 0.5) * s
        gy = (self.rows - np.asarray(row, dtype=np.float64) - 0.5) * s
        return self.frame.to_map(gx, gy)

    def cell_at(self, x: np.ndarray | float, y: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """The ``(row, col)`` of the cell holding map-frame point ``(x, y)`` (may be off the grid)."""
        gx, gy = self.frame.to_grid(x, y)
        col = np.floor(gx / self.cell_size).astype(np.int64)
        row = self.rows - 1 - np.floor(gy / self.cell_size).astype(np.int64)
        return row, col

    def heading_yaw(self, heading: np.ndarray | int) -> np.ndarray:
        """Map-frame yaw (radians, counter-clockwise from +x, in (-pi, pi]) of heading ``h`` (0 =
        up the grid, clockwise). With one heading the yaw is unknown: 0 is returned."""
        h = np.asarray(heading, dtype=np.float64)
        if self.headings == 1:
            return np.zeros_like(h)
        return wrap_angle(self.frame.yaw + math.pi / 2 - 2 * math.pi * h / self.headings)

    @cached_property
    def free_cells(self) -> np.ndarray:
        """Flat indices ``r * cols + c`` of the free cells, sorted."""
        return np.flatnonzero(self.free.ravel())

    @cached_property
    def free_cell_centres(self) -> tuple[np.ndarray, np.ndarray]:
        """Map-frame ``(x, y)`` of every free cell's centre, in :attr:`free_cells`' order (a state's
        cell is ``state // headings``)."""
        row, col = np.divmod(self.free_cells, self.cols)
        return self.cell_centre(row, col)

    @property
    def n_states(self) -> int:
        return len(self.free_cells) * self.headings

    def describe(self) -> dict[str, object]:
        """Size and scale as plain data (for summaries and file headers); the frame when it is not
        the identity."""
        data: dict[str, object] = {
            "rows": self.rows,
            "cols": self.cols,
            "headings": self.headings,
            "cell_size": self.cell_size,
        }
        if not self.frame.is_identity:
            data["frame"] = self.frame.as_json()
        return data

    def cell_heading(self, state: int | np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(row, col, heading) of one or many states."""
        cell, heading = np.divmod(np.asarray(state), self.headings)
        row, col = np.divmod(self.free_cells[cell], self.cols)
        return row, col, heading

    def state_of(self, row: int, col: int, heading: int = 0) -> int:
        """Index of the state at a free cell and heading; -1 if the cell is not free."""
        if not (0 <= row < self.rows and 0 <= col < self.cols) or not self.free[row, col]:
            return -1
        cell = int(np.searchsorted(self.free_cells, row * self.cols + col))
        return cell * self.headings + heading


_STATE_NAME = re.compile(r"^\s*([0-9]{1,18})\s*,\s*([0-9]{1,18})\s*(?:,\s*([0-9]{1,18})\s*)?$", re.ASCII)
"""``r,c`` or ``r,c,h`` in ASCII digits only (``١,١,٠`` is no state, as in ``.pomdp`` files), at
most 18 of them so that a 5,000-digit row is an unknown state, not a trip to ``int``'s digit limit."""


class StateSpace:
    """State names and lookup. Grid states are named ``"r,c"`` (headings 1) or ``"r,c,h"``;
    names are computed on demand so a 10^6-state model does not hold 10^6 strings."""

    def __init__(self, n: int, *, grid: GridLayout | None = None, names: Sequence[str] | None = None) -> None:
        if grid is None and names is None:
            raise ValueError("a state space needs a grid or names")
        self.n = n
        self.grid = grid
        self._names = list(names) if names is not None else None
        if self._names is not None and len(self._names) != n:
            raise ValueError("wrong number of state names")

    def __len__(self) -> int:
        return self.n

    def name(self, i: int) -> str:
        if self._names is not None:
            return self._names[i]
        assert self.grid is not None
        r, c, h = self.grid.cell_heading(i)
        return f"{r},{c}" if self.grid.headings == 1 else f"{r},{c},{h}"

    @cached_property
    def names(self) -> list[str]:
        if self._names is not None:
            return self._names
        assert self.grid is not None
        r, c, h = self.grid.cell_heading(np.arange(self.n))
        if self.grid.headings == 1:
            return [f"{a},{b}" for a, b in zip(r.tolist(), c.tolist(), strict=True)]
        return [f"{a},{b},{d}" for a, b, d in zip(r.tolist(), c.tolist(), h.tolist(), strict=True)]

    @cached_property
    def _lookup(self) -> dict[str, int]:
        return {name: i for i, name in enumerate(self.names)}

    def __iter__(self) -> Iterator[str]:
        return iter(self.names)

    def indices(self, text: str) -> list[int]:
        """States named by ``text``. On a grid, ``"r,c"`` names every heading of a cell."""
        if self.grid is not None:
            match = _STATE_NAME.match(text)
            if match:
                r, c = int(match[1]), int(match[2])
                g = self.grid
                first = g.state_of(r, c)
                if first >= 0:
                    if match[3] is None:
                        return list(range(first, first + g.headings))
                    h = int(match[3])
                    if h < g.headings:
                        return [first + h]
        elif text.strip() in self._lookup:
            return [self._lookup[text.strip()]]
        shown = text if len(text) <= 80 else f"{text[:60]}… ({len(text):,} characters)"
        raise InvalidValueError(f"unknown state {shown!r}: {self._describe()}")

    def index(self, text: str) -> int:
        found = self.indices(text)
        if len(found) != 1:
            raise InvalidValueError(f"state {text!r} names a cell, not one state; add the heading, e.g. '{text},0'")
        return found[0]

    def _describe(self) -> str:
        if self.grid is not None:
            g = self.grid
            form = "'row,col'" if g.headings == 1 else f"'row,col,heading' with heading 0..{g.headings - 1}"
            return f"states are {form} on a free cell of the {g.rows}x{g.cols} grid"
        shown = ", ".join(self.names[:6])
        return f"states are {shown}{', ...' if self.n > 6 else ''}"


@dataclass(frozen=True, eq=False)
class SourceInfo:
    """What a model was compiled from, to detect a stale model file."""

    path: str
    sha256: str


@dataclass(frozen=True, eq=False)
class Model:
    name: str
    states: StateSpace
    actions: tuple[Action, ...]
    grid: GridLayout | None = None
    source: SourceInfo | None = None

    def __post_init__(self) -> None:
        names = [a.name for a in self.actions]
        if len(set(names)) != len(names):
            raise ValueError(f"duplicate action names: {names}")

    @property
    def n_states(self) -> int:
        return self.states.n

    @cached_property
    def _by_name(self) -> dict[str, Action]:
        return {a.name: a for a in self.actions}

    def action(self, name: str) -> Action:
        try:
            return self._by_name[name]
        except KeyError:
            raise InvalidValueError(
                f"unknown action {name!r}; this model's actions are: {', '.join(self._by_name)}"
            ) from None

    @property
    def actuation_actions(self) -> list[Action]:
        return [a for a in self.actions if a.is_actuation]

    @property
    def perception_actions(self) -> list[Action]:
        return [a for a in self.actions if not a.is_actuation]

    def fingerprint(self) -> str:
        """A content hash of the numbers (states, T, O, costs): equal models hash equal."""
        digest = hashlib.sha256()
        digest.update(str(self.n_states).encode())
        digest.update("\0".join(self.states.names).encode())
        for action in self.actions:
            digest.update(f"{action.name}\0{action.kind.value}\0{action.cost!r}".encode())
            if action.transition is not None:
                t = action.transition
                for array in (t.indptr, t.indices, t.data):
                    digest.update(np.ascontiguousarray(array).tobytes())
            for part in action.observation.parts:
                digest.update("\0".join(part.values).encode())
                digest.update(np.ascontiguousarray(part.truth, dtype=np.int64).tobytes())
                digest.update(np.ascontiguousarray(part.confusion, dtype=np.float64).tobytes())
        return digest.hexdigest()


def model_summary(model: Model) -> dict[str, object]:
    """Sizes and sparsity of a model, as plain data (for ``inspect`` and ``build``)."""
    n = model.n_states
    actions = []
    for action in model.actions:
        nnz = action.transition.nnz if action.transition is not None else n
        actions.append(
            {
                "name": action.name,
                "kind": action.kind.value,
                "cost": action.cost,
                "observations": action.observation.n_observations,
                "observation_parts": [p.name for p in action.observation.parts],
                "transition_nonzeros": nnz,
                "transition_density": nnz / (n * n) if n else 0.0,
            }
        )
    grid = model.grid
    return {
        "name": model.name,
        "states": n,
        "grid": None
        if grid is None
        else {**grid.describe(), "free_cells": len(grid.free_cells), "landmarks": len(grid.landmarks)},
        "actions": actions,
        "source": None if model.source is None else {"path": model.source.path, "sha256": model.source.sha256},
    }
