"""Writing a :class:`~beliefloc.model.Model` as Cassandra's ``.pomdp`` text (:func:`write_pomdp`,
:func:`pomdp_text`).

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
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import numpy as np
import scipy.sparse as sp

from beliefloc.errors import ModelError, OutputError
from beliefloc.model import Action, Model
from beliefloc.pomdp_format.names import FORMAT_VERSION, PREFIX, format_number, identifiers
from beliefloc.source.atomic_write import write_atomically

DISCOUNT = 0.95
"""Localization has no discount of its own; 0.95 is the conventional value solvers expect."""


@dataclass(frozen=True)
class ExportSummary:
    """What :func:`write_pomdp` wrote: the path and the sizes of the POMDP."""

    output: str
    states: int
    actions: int
    observations: int

    def as_json(self) -> dict[str, str | int]:
        """What ``export --json`` prints."""
        return {
            "output": self.output,
            "states": self.states,
            "actions": self.actions,
            "observations": self.observations,
        }


def pomdp_blocks(model: Model) -> Iterator[str]:
    """The text of ``model`` in Cassandra's format, in blocks of whole lines (see module docs)."""
    return _blocks(model, _names(model))


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
    except OutputError as exc:
        raise OutputError(f"{path}: cannot write the .pomdp file ({exc.reason})", exc.reason) from None
    return summary


@dataclass(frozen=True)
class _Names:
    """The identifiers written for a model, and which union column each action's observations use."""

    states: list[str]
    actions: list[str]
    observation_names: list[str]
    observations: list[str]
    columns: list[list[int]]


def _names(model: Model) -> _Names:
    """The identifiers of ``model``; ``observations:`` is the union of the actions' observations."""
    union: dict[str, int] = {}
    columns = []
    for action in model.actions:
        columns.append([union.setdefault(name, len(union)) for name in action.observation.names()])
    observation_names = list(union)
    return _Names(
        states=identifiers(model.states.names, PREFIX["states"]),
        actions=identifiers([a.name for a in model.actions], PREFIX["actions"]),
        observation_names=observation_names,
        observations=identifiers(observation_names, PREFIX["observations"]),
        columns=columns,
    )


def _blocks(model: Model, names: _Names) -> Iterator[str]:
    # checked before any text is produced: a model that cannot be written yields nothing at all
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


def _header(model: Model, names: _Names) -> str:
    """The comment header: a few words for a human, then the ``# beliefloc-...`` lines."""
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
        *_grid_lines(model),
        *_name_lines(model, names),
        *_action_lines(model, names),
    ]
    return "\n".join(lines) + "\n\n"


def _grid_lines(model: Model) -> list[str]:
    """``beliefloc-grid``, one ``beliefloc-layout`` per row and one ``beliefloc-landmark`` each."""
    grid = model.grid
    if grid is None:
        return []
    spec = {"rows": grid.rows, "cols": grid.cols, "headings": grid.headings, "cell_size": grid.cell_size}
    return [
        f"# beliefloc-grid {json.dumps(spec)}",
        *("# beliefloc-layout " + "".join("." if f else "#" for f in row) for row in grid.free.tolist()),
        *(f"# beliefloc-landmark {json.dumps([c, r, k])}" for c, r, k in grid.landmarks),
    ]


def _name_lines(model: Model, names: _Names) -> list[str]:
    """One ``beliefloc-name`` per state, action and observation: its original name."""
    lines: list[str] = []
    for kind, idents, originals in (
        ("state", names.states, model.states.names),
        ("action", names.actions, [a.name for a in model.actions]),
        ("observation", names.observations, names.observation_names),
    ):
        lines.extend(
            f"# beliefloc-name {kind} {ident} {json.dumps(name)}" for ident, name in zip(idents, originals, strict=True)
        )
    return lines


def _action_lines(model: Model, names: _Names) -> list[str]:
    """One ``beliefloc-action`` per action: its kind, its own observations in order, its aliases."""
    lines: list[str] = []
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
    return lines


def _preamble(names: _Names) -> str:
    """``discount:``, ``values:``, the declarations and ``start:``."""
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
    """:func:`format_number`, once per distinct value: a large model repeats a few probabilities."""
    text = cache.get(value)
    if text is None:
        text = cache[value] = format_number(value)
    return text


def _transition_block(action: Action, ident: str, states: list[str], cache: dict[float, str]) -> str:
    """``T: a`` + ``identity`` for a perception action, else one line per non-zero of T."""
    if action.transition is None:
        return f"\nT: {ident}\nidentity\n"
    rows, cols, vals = _entries(action.transition)
    lines = [
        f"T: {ident} : {states[i]} : {states[j]} {_fmt(p, cache)}\n" for i, j, p in zip(rows, cols, vals, strict=True)
    ]
    return "\n" + "".join(lines)


def _observation_block(action: Action, ident: str, names: _Names, columns: list[int], cache: dict[float, str]) -> str:
    """``O: a : * : none 1.0`` for an action that senses nothing, else one line per non-zero of O."""
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
