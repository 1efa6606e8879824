"""A :class:`~beliefloc.model.Model` from a :class:`~beliefloc.pomdp_format.parser.ParsedFile`.

Each action gets its checked T and O (:mod:`~beliefloc.pomdp_format.matrices`) and its cost
(:mod:`~beliefloc.pomdp_format.costs`). An action whose T is the identity becomes a perception
action (``transition=None``), any other an actuation action -- unless a ``beliefloc-action``
comment says otherwise. The beliefloc comments then restore the original names, the model's name
and the grid, once checked against the declarations.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.sparse as sp

from beliefloc.model import Action, ActionKind, GridLayout, Model, SourceInfo, StateSpace
from beliefloc.pomdp_format.costs import action_cost
from beliefloc.pomdp_format.matrices import checked_matrix, is_identity, observation_model
from beliefloc.pomdp_format.names import KINDS, SINGULAR
from beliefloc.pomdp_format.parser import Body, ParsedFile


def build_model(parsed: ParsedFile, source: SourceInfo | None) -> Model:
    """The model ``parsed`` describes; ``source`` is recorded as where it was read from."""
    body = _body(parsed)
    names = {kind: _originals(parsed, kind) for kind in KINDS}
    action_idents = parsed.preamble.declared["actions"].names
    actions = tuple(_action(parsed, body, a, ident, names) for a, ident in enumerate(action_idents))
    for ident, (_, line) in parsed.notes.actions.items():
        if ident not in parsed.preamble.lookup["actions"]:
            raise parsed.error(
                line, f"beliefloc-action: unknown action {ident!r}; {parsed.preamble.describe('actions')}"
            )
    n = parsed.preamble.size("states")
    grid = _grid(parsed, names["states"])
    states = StateSpace(n, grid=grid) if grid is not None else StateSpace(n, names=names["states"])
    model_name = parsed.notes.model_name or Path(parsed.path).stem
    return Model(model_name, states, actions, grid, source)


def _body(parsed: ParsedFile) -> Body:
    """The body; a file with a preamble and no T:, O: or R: at all has an empty one."""
    if parsed.body is None:
        missing = [k for k in KINDS if k not in parsed.preamble.declared]
        if missing:
            raise parsed.error(parsed.last_line, f"the file never declares {', '.join(m + ':' for m in missing)}")
    return parsed.begin_body("T", parsed.last_line)


def _action(parsed: ParsedFile, body: Body, a: int, ident: str, names: dict[str, list[str]]) -> Action:
    """Action ``a`` (written ``ident``), with its original name from ``names``."""
    transition = checked_matrix(parsed, body.transitions[a], a, parsed.preamble.size("states"), "T")
    kind = _kind(parsed, ident, transition)
    name = names["actions"][a]
    observation = observation_model(parsed, body.observations[a], a, ident, name, names["observations"])
    cost = action_cost(parsed, body.rewards[a], ident)
    return Action(name, kind, cost, None if kind is ActionKind.PERCEPTION else transition, observation)


def _kind(parsed: ParsedFile, ident: str, transition: sp.csr_matrix) -> ActionKind:
    """Perception if T is the identity, unless the action's ``beliefloc-action`` comment says otherwise."""
    identity = is_identity(transition)
    noted = parsed.notes.actions.get(ident)
    if noted is None:
        return ActionKind.PERCEPTION if identity else ActionKind.ACTUATION
    kind = ActionKind(noted[0]["kind"])
    if kind is ActionKind.PERCEPTION and not identity:
        raise parsed.error(
            noted[1], f"beliefloc-action: {ident!r} is a perception action, but its T is not the identity"
        )
    return kind


def _originals(parsed: ParsedFile, kind: str) -> list[str]:
    """The declared names of ``kind``, with the original names from beliefloc-name comments."""
    declared = parsed.preamble.declared[kind]
    noted = parsed.notes.names[kind]
    for ident, (_, line) in noted.items():
        if ident not in parsed.preamble.lookup[kind]:
            raise parsed.error(
                line, f"beliefloc-name: unknown {SINGULAR[kind]} {ident!r}; {parsed.preamble.describe(kind)}"
            )
    originals = [noted[i][0] if i in noted else i for i in declared.names]
    if len(set(originals)) != len(originals):
        seen: set[str] = set()
        for ident, original in zip(declared.names, originals, strict=True):
            if original in seen:
                line = noted[ident][1] if ident in noted else declared.line
                raise parsed.error(line, f"beliefloc-name: two {kind} are named {original!r}")
            seen.add(original)
    return originals


def _grid(parsed: ParsedFile, state_names: list[str]) -> GridLayout | None:
    """The grid of the beliefloc-grid, -layout and -landmark comments, if its states are the declared ones."""
    notes = parsed.notes
    if notes.grid is None:
        if notes.layout or notes.landmarks:
            raise parsed.error(
                parsed.last_line, "beliefloc-layout or beliefloc-landmark comments without beliefloc-grid"
            )
        return None
    g, line = notes.grid, notes.grid_line
    rows, cols = g["rows"], g["cols"]
    if len(notes.layout) != rows or any(len(row) != cols for row in notes.layout):
        raise parsed.error(line, f"beliefloc-grid: expected {rows} beliefloc-layout rows of {cols} cells each")
    free = np.array([[ch == "." for ch in row] for row in notes.layout], dtype=bool)
    for cls, r, c in notes.landmarks:
        if not (0 <= r < rows and 0 <= c < cols):
            raise parsed.error(line, f"beliefloc-landmark: {cls} at [{r}, {c}] is outside the {rows}x{cols} grid")
    grid = GridLayout(rows, cols, g["headings"], float(g["cell_size"]), free, tuple(notes.landmarks))
    n = parsed.preamble.size("states")
    declared = parsed.preamble.declared["states"]
    if grid.n_states != n or StateSpace(n, grid=grid).names != state_names:
        raise parsed.error(
            line,
            f"beliefloc-grid: the grid has {grid.n_states} states, which are not the {n} states declared on line "
            f"{declared.line}; remove the beliefloc comments or restore the states",
        )
    return grid
