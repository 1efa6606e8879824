"""``T:`` and ``O:`` statements, read into the :class:`Entries` of each action's table.

The two statements have the same three forms and differ only in their columns (next states for
T, observations for O) and in the keywords a row may be (``reset`` only for T):

* ``T: a : s : s' p`` -- one entry, or a block of them when ``s`` or ``s'`` is ``*``;
* ``T: a : s`` and a row of probabilities, ``uniform`` or ``reset``;
* ``T: a`` and a whole matrix, ``uniform`` or ``identity`` (which replaces every earlier entry).

Entries are only collected here; their checks (probabilities, rows summing to 1) are made when the
model is built, where the last entry given for a cell is known. How many a statement gives (a ``*``
or a whole matrix gives many) is counted against :data:`~beliefloc.source.limits.MODEL_ENTRIES` before
they are made (:meth:`~beliefloc.pomdp_format.preamble.Preamble.spend`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from beliefloc.pomdp_format.names import NUMBER, RESERVED
from beliefloc.pomdp_format.preamble import Preamble
from beliefloc.pomdp_format.statements import Statement, numbers


class Entries:
    """The entries of one action's T or O in file order; a later entry overrides an earlier one.

    Single entries (``T: a : s : s' p``, the bulk of an exported file) go to Python lists, blocks
    to arrays; :meth:`arrays` puts them together once, when the model is built.
    """

    def __init__(self) -> None:
        self.rows: list[int] = []
        self.cols: list[int] = []
        self.vals: list[float] = []
        self.lines: list[int] = []
        self.chunks: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []
        self.first_line: int | None = None

    def add(self, row: int, col: int, value: float, line: int) -> None:
        self.rows.append(row)
        self.cols.append(col)
        self.vals.append(value)
        self.lines.append(line)
        if self.first_line is None:
            self.first_line = line

    def add_arrays(self, rows: np.ndarray, cols: np.ndarray, vals: np.ndarray, lines: np.ndarray | int) -> None:
        self._flush()  # keeps the single entries given so far before this block, in file order
        line_array = np.broadcast_to(np.asarray(lines, dtype=np.int64), rows.shape)
        self.chunks.append((rows.astype(np.int64), cols.astype(np.int64), vals.astype(np.float64), line_array))
        if self.first_line is None and len(rows):
            self.first_line = int(line_array[0])

    def clear(self) -> None:
        """A whole matrix is being given: it overrides every earlier entry."""
        self.rows, self.cols, self.vals, self.lines = [], [], [], []
        self.chunks = []

    def _flush(self) -> None:
        if self.rows:
            self.chunks.append(
                (
                    np.array(self.rows, dtype=np.int64),
                    np.array(self.cols, dtype=np.int64),
                    np.array(self.vals, dtype=np.float64),
                    np.array(self.lines, dtype=np.int64),
                )
            )
            self.rows, self.cols, self.vals, self.lines = [], [], [], []

    def arrays(self, n_cols: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Rows, columns, values and lines, one entry per (row, column): the last one given."""
        self._flush()
        if not self.chunks:
            empty = np.zeros(0, dtype=np.int64)
            return empty, empty, np.zeros(0), empty
        rows, cols, vals, lines = (np.concatenate(arrays) for arrays in zip(*self.chunks, strict=True))
        key = rows * n_cols + cols
        _, last_reversed = np.unique(key[::-1], return_index=True)
        if len(last_reversed) < len(key):
            keep = np.sort(len(key) - 1 - last_reversed)
            rows, cols, vals, lines = rows[keep], cols[keep], vals[keep], lines[keep]
        return rows, cols, vals, lines


class Table(NamedTuple):
    """How a statement's table is laid out: what its columns are and which keywords a row may be."""

    columns: str
    row_keywords: tuple[str, ...]


TABLES = {"T": Table("states", ("uniform", "reset")), "O": Table("observations", ("uniform",))}
"""The layout of T (rows: states, columns: next states) and O (rows: states reached, columns: observations)."""


def read_table(st: Statement, preamble: Preamble, actions: list[int], tables: list[Entries]) -> None:
    """A ``T:`` or ``O:`` statement about ``actions``, into their ``tables``."""
    table = TABLES[st.tokens[0]]
    targets = [tables[a] for a in actions]
    tokens = st.tokens
    if len(tokens) > 3 and tokens[3] == ":":
        row = preamble.ref("states", st, 4)
        if len(tokens) > 5 and tokens[5] == ":":
            _read_entry(st, preamble, table, row, targets)
        else:
            _read_row(st, preamble, table, row, targets)
        return
    for entries in targets:  # 'T: a' + a whole matrix: it replaces every earlier entry
        entries.clear()
    _read_matrix(st, preamble, table, targets)


def _read_entry(st: Statement, preamble: Preamble, table: Table, row: int | None, targets: list[Entries]) -> None:
    """``T: a : s : s' p``: one entry, or a block of entries when ``s`` or ``s'`` is ``*``."""
    col = preamble.ref(table.columns, st, 6)
    n_rows = preamble.size("states") if row is None else 1
    n_cols = preamble.size(table.columns) if col is None else 1
    preamble.spend(st, n_rows * n_cols * len(targets))
    if len(st.tokens) == 8 and row is not None and col is not None:
        try:  # the fast path for the one-entry lines that make up most of a large file
            p = float(st.tokens[7])
        except ValueError:
            p = float(numbers(st, 7, 1, st.head(7))[0])
        for entries in targets:
            entries.add(row, col, p, st.line)
        return
    p = float(numbers(st, 7, 1, st.head(7))[0])
    rows, cols = _block(row, col, preamble.size("states"), preamble.size(table.columns))
    for entries in targets:
        entries.add_arrays(rows, cols, np.full(len(rows), p), st.line)


def _read_row(st: Statement, preamble: Preamble, table: Table, row: int | None, targets: list[Entries]) -> None:
    """``T: a : s`` and a row: ``s``'s row, or every row for ``*``."""
    n, k = preamble.size("states"), preamble.size(table.columns)
    preamble.spend(st, k * (n if row is None else 1) * len(targets))
    values = _row(st, preamble, 5, k, st.head(5), table.row_keywords)
    starts = np.arange(n) if row is None else np.array([row])
    rows = np.repeat(starts, k)
    cols = np.tile(np.arange(k), len(starts))
    for entries in targets:
        entries.add_arrays(rows, cols, np.tile(values, len(starts)), _row_lines(st, 5, k, starts))


def _read_matrix(st: Statement, preamble: Preamble, table: Table, targets: list[Entries]) -> None:
    """``T: a`` and a whole matrix, ``uniform`` or ``identity``."""
    n, k = preamble.size("states"), preamble.size(table.columns)
    preamble.spend(st, (n if st.tokens[3:] == ["identity"] else n * k) * len(targets))
    if st.tokens[3:] == ["identity"]:
        if k != n:  # only O can have another number of columns
            raise st.error(st.line, f"O: identity needs as many observations as states ({n}), but there are {k}")
        diagonal = np.arange(n)
        for entries in targets:
            entries.add_arrays(diagonal, diagonal, np.ones(n), st.line)
        return
    matrix = _matrix(st, 3, n, k, st.head(3))
    rows, cols = np.divmod(np.arange(n * k), k)
    for entries in targets:
        entries.add_arrays(rows, cols, matrix, _matrix_lines(st, 3, n * k))


def _row(st: Statement, preamble: Preamble, start: int, size: int, what: str, keywords: tuple[str, ...]) -> np.ndarray:
    rest = st.tokens[start:]
    if rest == ["uniform"] and "uniform" in keywords:
        return np.full(size, 1.0 / size)
    if rest == ["reset"] and "reset" in keywords:
        n = preamble.size("states")
        return preamble.start if preamble.start is not None else np.full(n, 1.0 / n)
    if len(rest) == 1 and rest[0] in RESERVED:
        raise st.error(
            st.line,
            f"{what}: {rest[0]!r} cannot follow here; expected {size} probabilities or "
            + " or ".join(repr(k) for k in keywords),
        )
    return numbers(st, start, size, what)


def _matrix(st: Statement, start: int, n_rows: int, n_cols: int, what: str) -> np.ndarray:
    rest = st.tokens[start:]
    if rest == ["uniform"]:
        return np.full(n_rows * n_cols, 1.0 / n_cols)
    if not rest or rest[0] in RESERVED or not NUMBER.match(rest[0]):
        found = repr(rest[0]) if rest else "nothing"
        raise st.error(
            st.line_at(start),
            f"{what}: expected ':' and a state, or a whole {n_rows} x {n_cols} matrix ('uniform', 'identity' "
            f"or {n_rows * n_cols} numbers), found {found}",
        )
    return numbers(st, start, n_rows * n_cols, f"{what} (a {n_rows} x {n_cols} matrix)")


def _row_lines(st: Statement, start: int, size: int, rows: np.ndarray) -> np.ndarray | int:
    """The line of every entry a row gives to ``rows`` (one line when the statement has one)."""
    if st.token_lines is None:
        return st.line
    lines = np.array([st.line_at(start + j) for j in range(size)], dtype=np.int64)
    return np.tile(lines, len(rows))


def _matrix_lines(st: Statement, start: int, size: int) -> np.ndarray | int:
    """The line of every entry of a whole matrix (one line when the statement has one)."""
    if st.token_lines is None:
        return st.line
    return np.array([st.line_at(start + j) for j in range(size)], dtype=np.int64)


def _block(row: int | None, col: int | None, n_rows: int, n_cols: int) -> tuple[np.ndarray, np.ndarray]:
    """Every (row, column) named by two references, ``None`` standing for ``*``."""
    rows = np.arange(n_rows) if row is None else np.array([row])
    cols = np.arange(n_cols) if col is None else np.array([col])
    return np.repeat(rows, len(cols)), np.tile(cols, len(rows))
