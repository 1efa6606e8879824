"""Cassandra's ``.pomdp`` text format: export a :class:`~beliefloc.model.Model`, read one back.

This is the format of pomdp-solve (A. R. Cassandra, "POMDP file format", pomdp.org), also read by
SARSOP/APPL, POMDPs.jl's POMDPFiles and pomdp_py. A localization model is a POMDP without
rewards (DESIGN.md), so the mapping is direct: ``T[a][i, j] = P(s_j | s_i, a)``,
``O[a][j, o] = P(o | s_j, a)`` at the state reached, and a cost ``gamma(a)`` becomes the reward
``-gamma(a)``.

Writing (:func:`write_pomdp`, :func:`pomdp_text`)
-------------------------------------------------
::

    # ... a comment header; '# beliefloc-...' lines restore names and the grid (see below)
    discount: 0.95
    values: reward
    states: s0_0 s0_1 s1_0 s1_1
    actions: right look
    observations: none nothing window
    start: uniform
    T: right : s0_0 : s0_0 0.2           one line per non-zero of an actuation action's T
    T: right : s0_0 : s0_1 0.8
    T: look                              a perception action: T is the identity
    identity
    O: right : * : none 1.0              an actuation action without passive sensors
    O: look : s0_0 : nothing 0.9         one line per non-zero O[s', o]
    R: right : * : * : * -10.0           the cost, as a negative reward

* ``discount: 0.95``: localization has no discount of its own (an episode ends when the robot
  knows where it is); 0.95 is the conventional value solvers expect.
* ``observations:`` is the union of every action's observation names, in first-use order; an
  actuation action that senses nothing observes ``none`` with probability 1.
* Identifiers must match ``[a-zA-Z][a-zA-Z0-9_-]*`` and must not be one of the format's keywords,
  so names are sanitised deterministically: every other character becomes ``_``, a name that does
  not start with a letter gets a prefix (``s`` for states, ``a`` for actions, ``o`` for
  observations), a keyword gets a trailing ``_``, and a name that collides with an earlier one gets
  ``_2``, ``_3``, ... State ``1,2,0`` is written ``s1_2_0``, observation ``chair+potted_plant``
  ``chair_potted_plant``, ``wall_0.2-0.8`` ``wall_0_2-0_8``, ``0`` ``o0``.
* Numbers are written with Python's shortest round-tripping ``repr`` and always with a decimal
  point (``1.0e-05``, never ``1e-05``), as the spec asks, so reading the file back gives the very
  same floats.
* The file is written to a temporary file and renamed into place: a failure never leaves a
  half-written file.

The ``# beliefloc-...`` comment lines, which other tools ignore, carry what the format cannot:
``beliefloc-format 1``, ``beliefloc-model "name"``, ``beliefloc-grid {"rows", "cols", "headings",
"cell_size"}``, one ``beliefloc-layout ..#.`` line per grid row (``.`` free, ``#`` blocked), one
``beliefloc-landmark ["class", row, col]`` per landmark, ``beliefloc-name KIND IDENT "original"``
for every state, action and observation, and ``beliefloc-action {"action", "kind",
"observations", "aliases"}`` giving each action's kind and own observations in order. Reading them
back restores the model exactly: names, kinds, observation order and the grid.

Reading (:func:`read_pomdp`, :func:`parse_pomdp`)
-------------------------------------------------
Supported forms (everything pomdp-solve's grammar accepts for a POMDP, except state-dependent
rewards):

* comments from ``#`` to the end of the line, anywhere; statements may span lines (a matrix's
  numbers, a long ``states:`` list) and ``:`` needs no surrounding spaces;
* the preamble ``discount: F``, ``values: reward|cost``, ``states:``, ``actions:``,
  ``observations:`` -- each a count (``states: 5``, elements then named ``0``..``4``) or a list of
  identifiers -- in any order, before the first ``T:``, ``O:`` or ``R:``; an element may always be
  referred to by its number as well as by its name;
* ``start: uniform``, ``start: p1 ... pn``, ``start: STATE``, ``start include: S...``,
  ``start exclude: S...`` (the start belief is only used by ``reset``; beliefloc's start is
  chosen on the command line);
* ``T: a : s : s' p``; ``T: a : s`` followed by a row of |S| probabilities, ``uniform`` or
  ``reset``; ``T: a`` followed by an |S| x |S| matrix, ``uniform`` or ``identity``;
* ``O: a : s' : o p``; ``O: a : s'`` followed by a row of |Omega| probabilities or ``uniform``;
  ``O: a`` followed by an |S| x |Omega| matrix, ``uniform`` or (when |Omega| = |S|) ``identity``;
* ``R: a : s : s' : o r``, ``R: a : s : s'`` + a row, ``R: a : s`` + a matrix, as long as the
  reward does not depend on the state or observation: every action's reward must end up one
  constant -- ``R: a : * : * : * -1.0``, possibly repeated by later entries, or the same value
  given for every pair of states (pomdp_py writes one ``R: a : s : s' : * r`` per pair) -- which
  becomes its cost ``-r`` (``+r`` with ``values: cost``); an action without ``R:`` costs 0. A
  state-dependent reward (the tiger's ``R: open-left : tiger-left ...``) is refused with a
  :class:`~beliefloc.errors.ModelError`, and so is a positive reward (a negative cost);
* ``*`` for any action, state or observation; a later entry overrides an earlier one, and an entry
  that is never given is 0; a whole matrix (``T: a`` + ...) replaces every earlier entry of it.

Every row of T and of O must sum to 1 (within ``1e-6``). An action whose T is the identity becomes a
perception action (``transition=None``), any other an actuation action -- unless a
``beliefloc-action`` comment says otherwise. An action's observation model is one
:class:`~beliefloc.model.ObservationPart` named after the action whose values are the
observations it gives a non-zero probability somewhere (in the order of ``observations:``, or the
comment's order), with one distinct row of the |S| x k table per group of states that observe
alike (``truth[j]`` picks state j's row, so ``matrix()`` is the file's table exactly); an action
whose only observation is ``none`` gets no parts at all. The observation ``nothing`` is the part's
silent value, so it is still typed ``nothing``. Every problem is a
:class:`~beliefloc.errors.ModelError` reading ``file:line: what is wrong``.
"""

from __future__ import annotations

import hashlib
import json
import re
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

import numpy as np
import scipy.sparse as sp

from beliefloc.errors import ModelError
from beliefloc.model import (
    NONE_OBSERVATION,
    NOTHING,
    Action,
    ActionKind,
    GridLayout,
    Model,
    ObservationModel,
    ObservationPart,
    SourceInfo,
    StateSpace,
)
from beliefloc.model_file import write_atomically
from beliefloc.source import read_text

DISCOUNT = 0.95
"""Localization has no discount of its own; 0.95 is the conventional value solvers expect."""
FORMAT_VERSION = 1
"""Version of the ``# beliefloc-...`` comment lines."""
TOLERANCE = 1e-6
"""How far from 1 a row of T or O may sum."""
RESERVED = frozenset(
    {
        "discount",
        "values",
        "states",
        "actions",
        "observations",
        "T",
        "O",
        "R",
        "uniform",
        "identity",
        "reward",
        "cost",
        "start",
        "include",
        "exclude",
        "reset",
    }
)
"""The format's keywords: never identifiers."""

_IDENTIFIER = re.compile(r"[A-Za-z][A-Za-z0-9_-]*\Z")
_NOT_IDENTIFIER_CHAR = re.compile(r"[^A-Za-z0-9_-]")
_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*(?:[eE][+-]?\d+)?|\.\d+(?:[eE][+-]?\d+)?)\Z")
_STATEMENTS = frozenset({"discount", "values", "states", "actions", "observations", "start", "T", "O", "R"})
_KINDS = ("states", "actions", "observations")
_SINGULAR = {"states": "state", "actions": "action", "observations": "observation"}
_PREFIX = {"states": "s", "actions": "a", "observations": "o"}
_MAX_SHOWN = 6
_MAX_COVERAGE = 50_000_000
"""Largest |S|^2 for which per-state rewards are checked to cover every pair of states."""


# ------------------------------------------------------------------------------------------------
# Writing
# ------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ExportSummary:
    """What :func:`write_pomdp` wrote: the path and the sizes of the POMDP."""

    output: str
    states: int
    actions: int
    observations: int


def identifiers(names: Sequence[str], prefix: str) -> list[str]:
    """Sanitise ``names`` into distinct identifiers ``[a-zA-Z][a-zA-Z0-9_-]*`` (see module docs).

    Deterministic: the same names in the same order always give the same identifiers.
    """
    used: set[str] = set()
    out: list[str] = []
    for name in names:
        base = _NOT_IDENTIFIER_CHAR.sub("_", name)
        if not base or not ("a" <= base[0].lower() <= "z"):
            base = prefix + base
        if base in RESERVED:
            base += "_"
        ident, k = base, 2
        while ident in used:
            ident, k = f"{base}_{k}", k + 1
        used.add(ident)
        out.append(ident)
    return out


def format_number(value: float) -> str:
    """The shortest text that reads back as ``value``, with a decimal point (``1.0e-05``)."""
    text = repr(float(value))
    if "e" in text:
        mantissa, _, exponent = text.partition("e")
        if "." not in mantissa:
            text = f"{mantissa}.0e{exponent}"
    elif "." not in text:  # pragma: no cover - repr(float) always has '.', 'e', 'inf' or 'nan'
        text += ".0"
    return text


@dataclass(frozen=True)
class _Names:
    """The identifiers written for a model, and which union column each action's observations use."""

    states: list[str]
    actions: list[str]
    observation_names: list[str]
    observations: list[str]
    columns: list[list[int]]


def _names(model: Model) -> _Names:
    union: dict[str, int] = {}
    columns = []
    for action in model.actions:
        columns.append([union.setdefault(name, len(union)) for name in action.observation.names()])
    observation_names = list(union)
    return _Names(
        states=identifiers(model.states.names, _PREFIX["states"]),
        actions=identifiers([a.name for a in model.actions], _PREFIX["actions"]),
        observation_names=observation_names,
        observations=identifiers(observation_names, _PREFIX["observations"]),
        columns=columns,
    )


def pomdp_blocks(model: Model) -> Iterator[str]:
    """The text of ``model`` in Cassandra's format, in blocks of whole lines (see module docs)."""
    return _blocks(model, _names(model))


def _blocks(model: Model, names: _Names) -> Iterator[str]:
    for action in model.actions:
        if not np.isfinite(action.cost):
            raise ModelError(f"action {action.name!r} has cost {action.cost}; a .pomdp file needs a finite cost")
    yield _header(model, names)
    yield _preamble(names)
    cache: dict[float, str] = {}
    for action, ident in zip(model.actions, names.actions, strict=True):
        yield _transition_block(action, ident, names.states, cache)
    for action, ident, columns in zip(model.actions, names.actions, names.columns, strict=True):
        yield _observation_block(action, ident, names, columns, cache)
    rewards = []
    for action, ident in zip(model.actions, names.actions, strict=True):
        reward = format_number(-action.cost) if action.cost != 0 else "0.0"
        rewards.append(f"R: {ident} : * : * : * {reward}\n")
    yield "\n" + "".join(rewards)


def pomdp_text(model: Model) -> str:
    """The whole ``.pomdp`` file of ``model`` as one string."""
    return "".join(pomdp_blocks(model))


def write_pomdp(model: Model, path: str | Path) -> ExportSummary:
    """Write ``model`` to ``path`` in Cassandra's format, atomically (a failure leaves no file)."""
    path = Path(path)
    names = _names(model)
    summary = ExportSummary(str(path), model.n_states, len(model.actions), len(names.observations))

    def write(handle: IO[str]) -> None:
        for block in _blocks(model, names):
            handle.write(block)

    try:
        write_atomically(path, write, binary=False)
    except OSError as exc:
        raise ModelError(f"{path}: cannot write the .pomdp file ({exc.strerror or exc})") from None
    return summary


def _header(model: Model, names: _Names) -> str:
    lines = [
        f"# {model.name}: a localization POMDP exported by beliefloc.",
        "#",
        "# States are where the robot may be; every action has a transition and an observation model,",
        "# evaluated at the state reached. An action's cost is written as a negative reward.",
        "# Localization has no discount of its own (an episode ends when the robot knows where it is):",
        f"# discount {DISCOUNT} is the conventional value solvers expect.",
        "#",
        "# The '# beliefloc-...' lines below keep the original names (identifiers here may only use",
        "# letters, digits, '_' and '-') and the grid, so that 'beliefloc' reads the model back",
        "# exactly. Other tools ignore them as comments.",
        "#",
        f"# beliefloc-format {FORMAT_VERSION}",
        f"# beliefloc-model {json.dumps(model.name)}",
    ]
    grid = model.grid
    if grid is not None:
        spec = {"rows": grid.rows, "cols": grid.cols, "headings": grid.headings, "cell_size": grid.cell_size}
        lines.append(f"# beliefloc-grid {json.dumps(spec)}")
        lines.extend("# beliefloc-layout " + "".join("." if f else "#" for f in row) for row in grid.free.tolist())
        lines.extend(f"# beliefloc-landmark {json.dumps([c, r, k])}" for c, r, k in grid.landmarks)
    for kind, idents, originals in (
        ("state", names.states, model.states.names),
        ("action", names.actions, [a.name for a in model.actions]),
        ("observation", names.observations, names.observation_names),
    ):
        lines.extend(
            f"# beliefloc-name {kind} {ident} {json.dumps(name)}" for ident, name in zip(idents, originals, strict=True)
        )
    for action, ident, columns in zip(model.actions, names.actions, names.columns, strict=True):
        info: dict[str, Any] = {
            "action": ident,
            "kind": action.kind.value,
            "observations": [names.observations[c] for c in columns],
        }
        parts = action.observation.parts
        if len(parts) == 1 and parts[0].aliases:  # one part: reading w is joint observation w
            info["aliases"] = {alias: names.observations[columns[w]] for alias, w in parts[0].aliases.items()}
        lines.append(f"# beliefloc-action {json.dumps(info)}")
    return "\n".join(lines) + "\n\n"


def _preamble(names: _Names) -> str:
    return (
        f"discount: {format_number(DISCOUNT)}\n"
        "values: reward\n"
        f"states: {' '.join(names.states)}\n"
        f"actions: {' '.join(names.actions)}\n"
        f"observations: {' '.join(names.observations)}\n"
        "start: uniform\n"
    )


def _entries(matrix: sp.csr_matrix) -> tuple[list[int], list[int], list[float]]:
    """Row, column and value of every non-zero, row by row (a new canonical copy; input untouched)."""
    m = sp.csr_matrix(matrix, copy=True)
    m.sum_duplicates()
    rows = np.repeat(np.arange(m.shape[0]), np.diff(m.indptr))
    keep = m.data != 0
    return rows[keep].tolist(), m.indices[keep].tolist(), m.data[keep].tolist()


def _fmt(value: float, cache: dict[float, str]) -> str:
    text = cache.get(value)
    if text is None:
        text = cache[value] = format_number(value)
    return text


def _transition_block(action: Action, ident: str, states: list[str], cache: dict[float, str]) -> str:
    if action.transition is None:
        return f"\nT: {ident}\nidentity\n"
    rows, cols, vals = _entries(action.transition)
    lines = [
        f"T: {ident} : {states[i]} : {states[j]} {_fmt(p, cache)}\n" for i, j, p in zip(rows, cols, vals, strict=True)
    ]
    return "\n" + "".join(lines)


def _observation_block(action: Action, ident: str, names: _Names, columns: list[int], cache: dict[float, str]) -> str:
    observation = action.observation
    if not observation.parts:
        return f"\nO: {ident} : * : {names.observations[columns[0]]} 1.0\n"
    rows, cols, vals = _entries(observation.matrix())
    obs = [names.observations[c] for c in columns]
    states = names.states
    lines = [
        f"O: {ident} : {states[j]} : {obs[o]} {_fmt(p, cache)}\n" for j, o, p in zip(rows, cols, vals, strict=True)
    ]
    return "\n" + "".join(lines)


# ------------------------------------------------------------------------------------------------
# Reading
# ------------------------------------------------------------------------------------------------


def read_pomdp(path: str | Path) -> Model:
    """Read a Cassandra ``.pomdp`` file (see the module docs for the forms supported)."""
    path = Path(path)
    text, raw = read_text(path, ModelError)
    return parse_pomdp(text, path, source=SourceInfo(str(path), hashlib.sha256(raw).hexdigest()))


def parse_pomdp(text: str, path: str | Path = "<string>", *, source: SourceInfo | None = None) -> Model:
    """A model from the text of a ``.pomdp`` file; ``path`` is only used in messages and as the
    model's name when the file does not say it."""
    parser = _Parser(str(path))
    parser.parse(text)
    return parser.model(source)


@dataclass
class _Statement:
    """One statement: its tokens (``:`` is a token) and the line of each token."""

    tokens: list[str]
    line: int
    token_lines: list[int] | None = None

    def line_at(self, i: int) -> int:
        if self.token_lines is None or not self.token_lines:
            return self.line
        return self.token_lines[min(i, len(self.token_lines) - 1)]


class _Entries:
    """The entries of one action's T or O in file order; a later entry overrides an earlier one."""

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
        self._flush()
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


@dataclass(frozen=True)
class _Reward:
    """One ``R:`` statement as one action sees it: where it applies (None for every state) and its
    smallest and largest value."""

    start: int | None
    end: int | None
    every_observation: bool
    low: float
    high: float
    line: int

    @property
    def everywhere(self) -> bool:
        """One value for every start state, end state and observation."""
        return self.start is None and self.end is None and self.every_observation and self.low == self.high


@dataclass
class _Annotations:
    """What the ``# beliefloc-...`` comments say."""

    model_name: str | None = None
    grid: dict[str, Any] | None = None
    grid_line: int = 0
    layout: list[str] = field(default_factory=list)
    landmarks: list[tuple[str, int, int]] = field(default_factory=list)
    names: dict[str, dict[str, tuple[str, int]]] = field(default_factory=lambda: {k: {} for k in _KINDS})
    actions: dict[str, tuple[dict[str, Any], int]] = field(default_factory=dict)


class _Parser:
    def __init__(self, path: str) -> None:
        self.path = path
        self.values_cost = False
        self.declared: dict[str, tuple[list[str], int, bool]] = {}
        """kind -> (names, line, numbered)"""
        self.lookup: dict[str, dict[str, int]] = {}
        self.body_line: int | None = None
        self.start: np.ndarray | None = None
        self.transitions: list[_Entries] = []
        self.observations: list[_Entries] = []
        self.rewards: list[list[_Reward]] = []
        self.notes = _Annotations()
        self.last_line = 1

    def error(self, line: int, message: str) -> ModelError:
        return ModelError(f"{self.path}:{line}: {message}")

    # --- lines into statements -------------------------------------------------------------------
    def parse(self, text: str) -> None:
        pending: list[tuple[list[str], int]] = []
        lineno = 0
        for lineno, raw_line in enumerate(text.split("\n"), 1):
            line = raw_line
            cut = line.find("#")
            if cut >= 0:
                comment = line[cut + 1 :].strip()
                if comment.startswith("beliefloc-"):
                    self._annotation(comment, lineno)
                line = line[:cut]
            if ":" in line:
                line = line.replace(":", " : ")
            tokens = line.split()
            if not tokens:
                continue
            if tokens[0] in _STATEMENTS:
                if pending:
                    self._statement(pending)
                pending = [(tokens, lineno)]
            elif pending:
                pending.append((tokens, lineno))
            else:
                raise self.error(
                    lineno,
                    f"expected a statement (discount:, values:, states:, actions:, observations:, start:, T:, O: "
                    f"or R:), found {tokens[0]!r}",
                )
        if pending:
            self._statement(pending)
        self.last_line = max(lineno - 1 if text.endswith("\n") else lineno, 1)

    def _statement(self, pending: list[tuple[list[str], int]]) -> None:
        if len(pending) == 1:
            tokens, line = pending[0]
            statement = _Statement(tokens, line)
        else:
            tokens, token_lines = [], []
            for chunk, line in pending:
                tokens.extend(chunk)
                token_lines.extend([line] * len(chunk))
            statement = _Statement(tokens, pending[0][1], token_lines)
        head = statement.tokens[0]
        if head == "T":
            self._transition(statement)
        elif head == "O":
            self._observation(statement)
        elif head == "R":
            self._reward(statement)
        elif head in _KINDS:
            self._declaration(statement, head)
        elif head == "discount":
            self._discount(statement)
        elif head == "values":
            self._values(statement)
        else:
            self._start(statement)

    # --- small readers ---------------------------------------------------------------------------
    def _colon(self, st: _Statement, i: int, after: str) -> None:
        if len(st.tokens) <= i or st.tokens[i] != ":":
            found = repr(st.tokens[i]) if len(st.tokens) > i else "the end of the statement"
            raise self.error(st.line_at(i), f"expected ':' after {after}, found {found}")

    def _ref(self, kind: str, st: _Statement, i: int) -> int | None:
        """The element of ``kind`` named by token ``i`` (a name or a number), or None for ``*``."""
        if len(st.tokens) <= i or st.tokens[i] == ":":
            found = repr(st.tokens[i]) if len(st.tokens) > i else "the end of the statement"
            article = "an" if kind[0] in "ao" else "a"
            raise self.error(
                st.line_at(i),
                f"{st.tokens[0]}: expected {article} {_SINGULAR[kind]} (a name, a number or '*'), found {found}",
            )
        token = st.tokens[i]
        index = self.lookup[kind].get(token)
        if index is not None:
            return index
        if token == "*":
            return None
        names = self.declared[kind][0]
        if token.isdigit():
            if int(token) < len(names):
                return int(token)
            raise self.error(
                st.line_at(i),
                f"{_SINGULAR[kind]} number {token} is out of range: there are {len(names)} {kind} "
                f"(0..{len(names) - 1})",
            )
        raise self.error(st.line_at(i), f"unknown {_SINGULAR[kind]} {token!r}; {self._describe(kind)}")

    def _describe(self, kind: str) -> str:
        names, line, numbered = self.declared[kind]
        if numbered:
            return f"the {kind} are numbered 0..{len(names) - 1} (line {line})"
        shown = ", ".join(names[:_MAX_SHOWN]) + (", ..." if len(names) > _MAX_SHOWN else "")
        return f"the {kind} declared on line {line} are {shown}"

    def _numbers(self, st: _Statement, start: int, count: int, what: str, *, signed: bool = False) -> np.ndarray:
        tokens = st.tokens[start:]
        if signed and ("-" in tokens or "+" in tokens):  # '- 1.0' is a sign and a number
            tokens = _join_signs(tokens)
        if len(tokens) != count:
            where = st.line_at(start + count) if len(tokens) > count else st.line_at(len(st.tokens) - 1)
            raise self.error(where, f"{what} needs {count} number{'s' if count != 1 else ''}, found {len(tokens)}")
        for j, token in enumerate(tokens):
            if not _NUMBER.match(token):
                raise self.error(st.line_at(start + j), f"{what}: expected a number, found {token!r}")
        return np.array(tokens, dtype=np.float64)

    def _size(self, kind: str) -> int:
        return len(self.declared[kind][0])

    def _begin_body(self, st: _Statement) -> None:
        if self.body_line is None:
            missing = [k for k in _KINDS if k not in self.declared]
            if missing:
                raise self.error(
                    st.line,
                    f"{st.tokens[0]}: comes before the preamble declared {', '.join(m + ':' for m in missing)}; "
                    "the preamble (discount:, values:, states:, actions:, observations:) must come first",
                )
            n_actions = self._size("actions")
            self.transitions = [_Entries() for _ in range(n_actions)]
            self.observations = [_Entries() for _ in range(n_actions)]
            self.rewards = [[] for _ in range(n_actions)]
            self.body_line = st.line

    # --- preamble --------------------------------------------------------------------------------
    def _declaration(self, st: _Statement, kind: str) -> None:
        if self.body_line is not None:
            raise self.error(st.line, f"{kind}: must come before the first T:, O: or R: (line {self.body_line})")
        if kind in self.declared:
            raise self.error(st.line, f"{kind}: declared twice (first on line {self.declared[kind][1]})")
        self._colon(st, 1, kind)
        items = st.tokens[2:]
        if not items:
            raise self.error(st.line, f"{kind}: needs a number or a list of names")
        if len(items) == 1 and items[0].isdigit():
            count = int(items[0])
            if count < 1:
                raise self.error(st.line, f"{kind}: there must be at least one, found {count}")
            names, numbered = [str(i) for i in range(count)], True
        else:
            seen: dict[str, int] = {}
            for j, name in enumerate(items):
                where = st.line_at(2 + j)
                if name in RESERVED:
                    raise self.error(where, f"{kind}: {name!r} is a keyword of the format and cannot be a name")
                if not _IDENTIFIER.match(name):
                    raise self.error(
                        where,
                        f"{kind}: {name!r} is not a valid name (a letter, then letters, digits, '_' or '-'); "
                        "give either a count or names",
                    )
                if name in seen:
                    raise self.error(where, f"{kind}: {name!r} is listed twice")
                seen[name] = j
            names, numbered = items, False
        self.declared[kind] = (names, st.line, numbered)
        self.lookup[kind] = {name: i for i, name in enumerate(names)}

    def _discount(self, st: _Statement) -> None:
        self._colon(st, 1, "discount")
        value = float(self._numbers(st, 2, 1, "discount:")[0])
        if not 0.0 <= value <= 1.0:
            raise self.error(st.line, f"discount: must be between 0 and 1, found {value:g}")

    def _values(self, st: _Statement) -> None:
        self._colon(st, 1, "values")
        if st.tokens[2:] not in (["reward"], ["cost"]):
            raise self.error(st.line, f"values: must be 'reward' or 'cost', found {' '.join(st.tokens[2:])!r}")
        self.values_cost = st.tokens[2] == "cost"

    def _start(self, st: _Statement) -> None:
        if "states" not in self.declared:
            raise self.error(st.line, "start: comes before states: is declared")
        n = self._size("states")
        tokens = st.tokens
        if len(tokens) > 1 and tokens[1] in ("include", "exclude"):
            self._colon(st, 2, f"start {tokens[1]}")
            chosen = np.zeros(n, dtype=bool)
            if len(tokens) == 3:
                raise self.error(st.line, f"start {tokens[1]}: needs at least one state")
            for i in range(3, len(tokens)):
                state = self._ref("states", st, i)
                chosen[slice(None) if state is None else state] = True
            if tokens[1] == "exclude":
                chosen = ~chosen
            if not chosen.any():
                raise self.error(st.line, "start exclude: leaves no state")
            self.start = chosen / chosen.sum()
            return
        self._colon(st, 1, "start")
        rest = tokens[2:]
        if rest == ["uniform"]:
            self.start = np.full(n, 1.0 / n)
        elif len(rest) == 1 and not _NUMBER.match(rest[0]):
            state = self._ref("states", st, 2)
            self.start = np.full(n, 1.0 / n) if state is None else np.eye(1, n, state).ravel()
        else:
            start = self._numbers(st, 2, n, "start:")
            self._check_probabilities(start, st, "start:")
            if abs(start.sum() - 1.0) > TOLERANCE:
                raise self.error(st.line, f"start: the probabilities sum to {start.sum():.9g}, not 1")
            self.start = start

    def _check_probabilities(self, values: np.ndarray, st: _Statement, what: str) -> None:
        bad = np.flatnonzero(~((values >= 0.0) & (values <= 1.0)))
        if len(bad):
            raise self.error(st.line, f"{what} {values[bad[0]]:g} is not a probability (between 0 and 1)")

    # --- T, O, R ---------------------------------------------------------------------------------
    def _actions(self, st: _Statement) -> list[int]:
        self._begin_body(st)
        self._colon(st, 1, st.tokens[0])
        action = self._ref("actions", st, 2)
        return list(range(self._size("actions"))) if action is None else [action]

    def _transition(self, st: _Statement) -> None:
        actions = self._actions(st)
        n = self._size("states")
        tokens = st.tokens
        if len(tokens) > 3 and tokens[3] == ":":
            start = self._ref("states", st, 4)
            if len(tokens) > 5 and tokens[5] == ":":  # T: a : s : s' p
                end = self._ref("states", st, 6)
                if len(tokens) == 8 and start is not None and end is not None:
                    try:
                        p = float(tokens[7])
                    except ValueError:
                        p = float(self._numbers(st, 7, 1, _head(st, 7))[0])
                    for a in actions:
                        self.transitions[a].add(start, end, p, st.line)
                    return
                p = float(self._numbers(st, 7, 1, _head(st, 7))[0])
                rows, cols = _block(start, end, n, n)
                for a in actions:
                    self.transitions[a].add_arrays(rows, cols, np.full(len(rows), p), st.line)
                return
            row = self._row(st, 5, n, _head(st, 5), ("uniform", "reset"))  # T: a : s  + a row
            starts = np.arange(n) if start is None else np.array([start])
            rows = np.repeat(starts, n)
            cols = np.tile(np.arange(n), len(starts))
            for a in actions:
                self.transitions[a].add_arrays(rows, cols, np.tile(row, len(starts)), self._row_lines(st, 5, n, starts))
            return
        for a in actions:  # T: a  + a whole matrix
            self.transitions[a].clear()
        if tokens[3:] == ["identity"]:
            diagonal = np.arange(n)
            for a in actions:
                self.transitions[a].add_arrays(diagonal, diagonal, np.ones(n), st.line)
            return
        matrix = self._matrix(st, 3, n, n, _head(st, 3))
        rows, cols = np.divmod(np.arange(n * n), n)
        for a in actions:
            self.transitions[a].add_arrays(rows, cols, matrix, self._matrix_lines(st, 3, n * n))

    def _observation(self, st: _Statement) -> None:
        actions = self._actions(st)
        n, k = self._size("states"), self._size("observations")
        tokens = st.tokens
        if len(tokens) > 3 and tokens[3] == ":":
            end = self._ref("states", st, 4)
            if len(tokens) > 5 and tokens[5] == ":":  # O: a : s' : o p
                obs = self._ref("observations", st, 6)
                if len(tokens) == 8 and end is not None and obs is not None:
                    try:
                        p = float(tokens[7])
                    except ValueError:
                        p = float(self._numbers(st, 7, 1, _head(st, 7))[0])
                    for a in actions:
                        self.observations[a].add(end, obs, p, st.line)
                    return
                p = float(self._numbers(st, 7, 1, _head(st, 7))[0])
                rows, cols = _block(end, obs, n, k)
                for a in actions:
                    self.observations[a].add_arrays(rows, cols, np.full(len(rows), p), st.line)
                return
            row = self._row(st, 5, k, _head(st, 5), ("uniform",))  # O: a : s'  + a row
            ends = np.arange(n) if end is None else np.array([end])
            rows = np.repeat(ends, k)
            cols = np.tile(np.arange(k), len(ends))
            for a in actions:
                self.observations[a].add_arrays(rows, cols, np.tile(row, len(ends)), self._row_lines(st, 5, k, ends))
            return
        for a in actions:  # O: a  + a whole matrix
            self.observations[a].clear()
        if tokens[3:] == ["identity"]:
            if k != n:
                raise self.error(st.line, f"O: identity needs as many observations as states ({n}), but there are {k}")
            diagonal = np.arange(n)
            for a in actions:
                self.observations[a].add_arrays(diagonal, diagonal, np.ones(n), st.line)
            return
        matrix = self._matrix(st, 3, n, k, _head(st, 3))
        rows, cols = np.divmod(np.arange(n * k), k)
        for a in actions:
            self.observations[a].add_arrays(rows, cols, matrix, self._matrix_lines(st, 3, n * k))

    def _row(self, st: _Statement, start: int, size: int, what: str, keywords: tuple[str, ...]) -> np.ndarray:
        rest = st.tokens[start:]
        if rest == ["uniform"] and "uniform" in keywords:
            return np.full(size, 1.0 / size)
        if rest == ["reset"] and "reset" in keywords:
            n = self._size("states")
            return self.start if self.start is not None else np.full(n, 1.0 / n)
        if len(rest) == 1 and rest[0] in RESERVED:
            raise self.error(
                st.line,
                f"{what}: {rest[0]!r} cannot follow here; expected {size} probabilities or "
                + " or ".join(repr(k) for k in keywords),
            )
        return self._numbers(st, start, size, what)

    def _matrix(self, st: _Statement, start: int, n_rows: int, n_cols: int, what: str) -> np.ndarray:
        rest = st.tokens[start:]
        if rest == ["uniform"]:
            return np.full(n_rows * n_cols, 1.0 / n_cols)
        if not rest or rest[0] in RESERVED or not _NUMBER.match(rest[0]):
            found = repr(rest[0]) if rest else "nothing"
            raise self.error(
                st.line_at(start),
                f"{what}: expected ':' and a state, or a whole {n_rows} x {n_cols} matrix ('uniform', 'identity' "
                f"or {n_rows * n_cols} numbers), found {found}",
            )
        return self._numbers(st, start, n_rows * n_cols, f"{what} (a {n_rows} x {n_cols} matrix)")

    @staticmethod
    def _row_lines(st: _Statement, start: int, size: int, rows: np.ndarray) -> np.ndarray | int:
        if st.token_lines is None:
            return st.line
        lines = np.array([st.line_at(start + j) for j in range(size)], dtype=np.int64)
        return np.tile(lines, len(rows))

    @staticmethod
    def _matrix_lines(st: _Statement, start: int, size: int) -> np.ndarray | int:
        if st.token_lines is None:
            return st.line
        return np.array([st.line_at(start + j) for j in range(size)], dtype=np.int64)

    def _reward(self, st: _Statement) -> None:
        actions = self._actions(st)
        tokens = st.tokens
        n, k = self._size("states"), self._size("observations")
        if len(tokens) <= 3 or tokens[3] != ":":
            raise self.error(
                st.line,
                "R: a matrix after 'R: <action>' is the MDP form; a POMDP's reward names a start state "
                "('R: a : * : * : * -1.0')",
            )
        start = self._ref("states", st, 4)
        end: int | None = None
        every_observation = True
        if len(tokens) > 5 and tokens[5] == ":":
            end = self._ref("states", st, 6)
            if len(tokens) > 7 and tokens[7] == ":":  # R: a : s : s' : o r
                every_observation = self._ref("observations", st, 8) is None
                values = self._numbers(st, 9, 1, _head(st, 9), signed=True)
            else:  # R: a : s : s'  + a row over observations
                values = self._numbers(st, 7, k, _head(st, 7), signed=True)
        else:  # R: a : s  + a matrix over end states and observations
            values = self._numbers(st, 5, n * k, _head(st, 5), signed=True)
        if not np.isfinite(values).all():
            raise self.error(st.line, "R: rewards must be finite numbers")
        reward = _Reward(start, end, every_observation, float(values.min()), float(values.max()), st.line)
        for a in actions:
            self.rewards[a].append(reward)

    # --- beliefloc comments ----------------------------------------------------------------------
    def _annotation(self, comment: str, line: int) -> None:
        keyword, _, rest = comment.partition(" ")
        rest = rest.strip()
        notes = self.notes
        try:
            if keyword == "beliefloc-format":
                if rest != str(FORMAT_VERSION):
                    raise self.error(
                        line, f"beliefloc-format {rest}: this beliefloc reads version {FORMAT_VERSION} comments"
                    )
            elif keyword == "beliefloc-model":
                notes.model_name = _json_str(json.loads(rest))
            elif keyword == "beliefloc-grid":
                grid = json.loads(rest)
                if not isinstance(grid, dict) or set(grid) != {"rows", "cols", "headings", "cell_size"}:
                    raise ValueError('expected {"rows", "cols", "headings", "cell_size"}')
                if not all(isinstance(grid[k], int) and grid[k] >= 1 for k in ("rows", "cols", "headings")):
                    raise ValueError("rows, cols and headings must be positive integers")
                if not isinstance(grid["cell_size"], (int, float)) or not grid["cell_size"] > 0:
                    raise ValueError("cell_size must be a positive number")
                notes.grid, notes.grid_line = grid, line
            elif keyword == "beliefloc-layout":
                if not rest or set(rest) - {".", "#"}:
                    raise ValueError("a layout row is made of '.' (free) and '#' (blocked)")
                notes.layout.append(rest)
            elif keyword == "beliefloc-landmark":
                value = json.loads(rest)
                if not (
                    isinstance(value, list)
                    and len(value) == 3
                    and isinstance(value[0], str)
                    and all(isinstance(v, int) for v in value[1:])
                ):
                    raise ValueError('expected ["class", row, col]')
                notes.landmarks.append((value[0], value[1], value[2]))
            elif keyword == "beliefloc-name":
                kind, _, rest = rest.partition(" ")
                ident, _, original = rest.strip().partition(" ")
                kinds = {_SINGULAR[k]: k for k in _KINDS}
                if kind not in kinds or not ident:
                    raise ValueError("expected 'beliefloc-name state|action|observation IDENT \"original name\"'")
                names = notes.names[kinds[kind]]
                if ident in names:
                    raise ValueError(f"{kind} {ident!r} is named twice (first on line {names[ident][1]})")
                names[ident] = (_json_str(json.loads(original)), line)
            elif keyword == "beliefloc-action":
                info = json.loads(rest)
                if not (
                    isinstance(info, dict)
                    and isinstance(info.get("action"), str)
                    and info.get("kind") in ("actuation", "perception")
                    and isinstance(info.get("observations"), list)
                    and all(isinstance(o, str) for o in info["observations"])
                    and isinstance(info.get("aliases", {}), dict)
                    and all(isinstance(v, str) for v in info.get("aliases", {}).values())
                ):
                    raise ValueError(
                        'expected {"action": IDENT, "kind": "actuation"|"perception", "observations": [IDENT, ...]}'
                    )
                if info["action"] in notes.actions:
                    raise ValueError(f"action {info['action']!r} is described twice")
                notes.actions[info["action"]] = (info, line)
            else:
                raise ValueError(f"unknown beliefloc comment {keyword!r}")
        except (ValueError, TypeError) as exc:  # json.JSONDecodeError is a ValueError
            raise self.error(line, f"{keyword}: {exc}") from None

    # --- the model -------------------------------------------------------------------------------
    def model(self, source: SourceInfo | None) -> Model:
        if self.body_line is None:
            missing = [k for k in _KINDS if k not in self.declared]
            if missing:
                raise self.error(self.last_line, f"the file never declares {', '.join(m + ':' for m in missing)}")
            self._begin_body(_Statement(["T"], self.last_line))
        n = self._size("states")
        names = {kind: self._originals(kind) for kind in _KINDS}
        action_idents = self.declared["actions"][0]
        actions = []
        for a, ident in enumerate(action_idents):
            noted = self.notes.actions.get(ident)
            transition = self._matrix_of(self.transitions[a], a, n, "T")
            identity = _is_identity(transition)
            if noted is None:
                kind = ActionKind.PERCEPTION if identity else ActionKind.ACTUATION
            else:
                kind = ActionKind(noted[0]["kind"])
                if kind is ActionKind.PERCEPTION and not identity:
                    raise self.error(
                        noted[1], f"beliefloc-action: {ident!r} is a perception action, but its T is not the identity"
                    )
            name = names["actions"][a]
            observation = self._observation_model(a, ident, name, n, names["observations"])
            actions.append(
                Action(
                    name,
                    kind,
                    self._cost(a, ident),
                    None if kind is ActionKind.PERCEPTION else transition,
                    observation,
                )
            )
        for ident, (_, line) in self.notes.actions.items():
            if ident not in self.lookup["actions"]:
                raise self.error(line, f"beliefloc-action: unknown action {ident!r}; {self._describe('actions')}")
        grid = self._grid(names["states"])
        states = StateSpace(n, grid=grid) if grid is not None else StateSpace(n, names=names["states"])
        model_name = self.notes.model_name or Path(self.path).stem
        return Model(model_name, states, tuple(actions), grid, source)

    def _originals(self, kind: str) -> list[str]:
        """The declared names of ``kind``, with the original names from beliefloc-name comments."""
        idents = self.declared[kind][0]
        noted = self.notes.names[kind]
        for ident, (_, line) in noted.items():
            if ident not in self.lookup[kind]:
                raise self.error(line, f"beliefloc-name: unknown {_SINGULAR[kind]} {ident!r}; {self._describe(kind)}")
        originals = [noted[i][0] if i in noted else i for i in idents]
        if len(set(originals)) != len(originals):
            seen: set[str] = set()
            for ident, original in zip(idents, originals, strict=True):
                if original in seen:
                    line = noted[ident][1] if ident in noted else self.declared[kind][1]
                    raise self.error(line, f"beliefloc-name: two {kind} are named {original!r}")
                seen.add(original)
        return originals

    def _matrix_of(self, entries: _Entries, a: int, n_cols: int, which: str) -> sp.csr_matrix:
        """An action's T (``which='T'``) or O as CSR, checked: probabilities, rows summing to 1."""
        n = self._size("states")
        action = self.declared["actions"][0][a]
        rows, cols, vals, lines = entries.arrays(n_cols)
        bad = np.flatnonzero(~((vals >= 0.0) & (vals <= 1.0)))
        if len(bad):
            i = bad[np.argmin(lines[bad])]
            raise self.error(int(lines[i]), f"{which}: {vals[i]:g} is not a probability (between 0 and 1)")
        sums = np.bincount(rows, weights=vals, minlength=n)
        wrong = np.flatnonzero(np.abs(sums - 1.0) > TOLERANCE)
        if len(wrong):
            state = int(wrong[0])
            state_name = self.declared["states"][0][state]
            touched = lines[rows == state]
            line = int(touched.max()) if len(touched) else entries.first_line or self.declared["actions"][1]
            if len(vals) == 0:
                hint = f" (for a perception action write 'T: {action}' and then 'identity')" if which == "T" else ""
                raise self.error(line, f"{which}: no probabilities are given for action {action!r}{hint}")
            role = "from state" if which == "T" else "in state"
            what = "next states" if which == "T" else "observations"
            raise self.error(
                line,
                f"{which}: for action {action!r} {role} {state_name!r}, the probabilities of the {what} sum to "
                f"{sums[state]:.9g}, not 1" + (f" ({len(wrong)} rows are wrong)" if len(wrong) > 1 else ""),
            )
        keep = vals != 0.0
        matrix = sp.csr_matrix((vals[keep], (rows[keep], cols[keep])), shape=(n, n_cols))
        matrix.sum_duplicates()
        return matrix

    def _observation_model(
        self, a: int, ident: str, name: str, n: int, observation_names: list[str]
    ) -> ObservationModel:
        matrix = self._matrix_of(self.observations[a], a, self._size("observations"), "O")
        used = np.unique(matrix.indices)
        noted = self.notes.actions.get(ident)
        if noted is None:
            columns = used.tolist()
            aliases_by_ident: dict[str, str] = {}
        else:
            info, line = noted
            lookup = self.lookup["observations"]
            columns = []
            for obs in info["observations"]:
                if obs not in lookup:
                    raise self.error(
                        line, f"beliefloc-action: unknown observation {obs!r}; {self._describe('observations')}"
                    )
                columns.append(lookup[obs])
            if len(set(columns)) != len(columns):
                raise self.error(line, f"beliefloc-action: {ident!r} lists an observation twice")
            missing = sorted(set(used.tolist()) - set(columns))
            if missing:
                obs_name = self.declared["observations"][0][missing[0]]
                raise self.error(
                    line,
                    f"beliefloc-action: O gives action {ident!r} the observation {obs_name!r}, which this comment "
                    "does not list",
                )
            aliases_by_ident = dict(info.get("aliases", {}))
        names = [observation_names[c] for c in columns]
        if names == [NONE_OBSERVATION]:
            return ObservationModel(n)
        table = matrix[:, columns].toarray()
        confusion, truth = _distinct_rows(table)
        position = {c: w for w, c in enumerate(columns)}
        lookup = self.lookup["observations"]
        aliases = {
            alias: position[lookup[obs]]
            for alias, obs in aliases_by_ident.items()
            if obs in lookup and lookup[obs] in position
        }
        values = tuple("" if v == NOTHING else v for v in names)
        return ObservationModel(n, (ObservationPart(name, values, truth, confusion, aliases),))

    def _cost(self, a: int, ident: str) -> float:
        """The action's cost: minus its one reward (or its one cost with ``values: cost``).

        The reward is one constant when the last ``R: a : * : * : * r`` is followed only by entries
        giving ``r`` again, or when every entry gives the same ``r`` and together they cover every
        start and end state (pomdp_py writes one ``R: a : s : s' : * r`` per pair).
        """
        rewards = self.rewards[a]
        last = max((i for i, r in enumerate(rewards) if r.everywhere), default=None)
        value = rewards[last].low if last is not None else rewards[0].low if rewards else 0.0
        unsupported = (
            f"the reward of action {ident!r} depends on the state or observation; beliefloc models have one cost "
            f"per action, so state-dependent rewards are unsupported (give 'R: {ident} : * : * : * -COST')"
        )
        for reward in rewards[(last + 1 if last is not None else 0) :]:
            if not reward.low == reward.high == value:
                raise self.error(reward.line, f"R: {unsupported}")
        if last is None and value != 0.0 and not self._covers_everything(rewards):
            raise self.error(rewards[0].line, f"R: {unsupported}; here some states are left at 0")
        cost = (value if self.values_cost else -value) + 0.0  # + 0.0 turns -0.0 into 0.0
        if cost < 0:
            line = rewards[last].line if last is not None else self.declared["actions"][1]
            word = "cost" if self.values_cost else "reward"
            raise self.error(
                line, f"R: action {ident!r} has a {word} of {value:g}, a negative cost; beliefloc needs costs >= 0"
            )
        return cost

    def _covers_everything(self, rewards: list[_Reward]) -> bool:
        n = self._size("states")
        if n * n > _MAX_COVERAGE:
            return False
        covered = np.zeros((n, n), dtype=bool)
        for reward in rewards:
            if reward.every_observation:
                covered[
                    slice(None) if reward.start is None else reward.start,
                    slice(None) if reward.end is None else reward.end,
                ] = True
        return bool(covered.all())

    def _grid(self, state_names: list[str]) -> GridLayout | None:
        notes = self.notes
        if notes.grid is None:
            if notes.layout or notes.landmarks:
                raise self.error(
                    self.last_line, "beliefloc-layout or beliefloc-landmark comments without beliefloc-grid"
                )
            return None
        g, line = notes.grid, notes.grid_line
        rows, cols = g["rows"], g["cols"]
        if len(notes.layout) != rows or any(len(row) != cols for row in notes.layout):
            raise self.error(line, f"beliefloc-grid: expected {rows} beliefloc-layout rows of {cols} cells each")
        free = np.array([[ch == "." for ch in row] for row in notes.layout], dtype=bool)
        for cls, r, c in notes.landmarks:
            if not (0 <= r < rows and 0 <= c < cols):
                raise self.error(line, f"beliefloc-landmark: {cls} at [{r}, {c}] is outside the {rows}x{cols} grid")
        grid = GridLayout(rows, cols, g["headings"], float(g["cell_size"]), free, tuple(notes.landmarks))
        n = self._size("states")
        if grid.n_states != n or StateSpace(n, grid=grid).names != state_names:
            raise self.error(
                line,
                f"beliefloc-grid: the grid has {grid.n_states} states, which are not the {n} states declared on line "
                f"{self.declared['states'][1]}; remove the beliefloc comments or restore the states",
            )
        return grid


def _head(st: _Statement, end: int) -> str:
    """The statement's first tokens as written, e.g. ``T: go : a`` (for messages)."""
    return f"{st.tokens[0]}: {' '.join(st.tokens[2:end])}"


def _join_signs(tokens: list[str]) -> list[str]:
    out: list[str] = []
    sign = ""
    for token in tokens:
        if token in ("-", "+") and not sign:
            sign = token
            continue
        out.append(sign + token)
        sign = ""
    if sign:
        out.append(sign)
    return out


def _json_str(value: object) -> str:
    if not isinstance(value, str):
        raise ValueError(f"expected a JSON string, found {json.dumps(value)}")
    return value


def _block(row: int | None, col: int | None, n_rows: int, n_cols: int) -> tuple[np.ndarray, np.ndarray]:
    """Every (row, column) named by two references, ``None`` standing for ``*``."""
    rows = np.arange(n_rows) if row is None else np.array([row])
    cols = np.arange(n_cols) if col is None else np.array([col])
    return np.repeat(rows, len(cols)), np.tile(cols, len(rows))


def _is_identity(matrix: sp.csr_matrix) -> bool:
    n = matrix.shape[0]
    return bool(
        matrix.nnz == n
        and np.array_equal(matrix.indptr, np.arange(n + 1))
        and np.array_equal(matrix.indices, np.arange(n))
        and np.all(matrix.data == 1.0)
    )


def _distinct_rows(table: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(confusion, truth)`` with ``confusion[truth] == table``: one row per distinct row of ``table``,
    in order of first appearance."""
    distinct, first, inverse = np.unique(table, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first)
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return distinct[order], rank[inverse.ravel()].astype(np.int64)
