"""The entries of an action's T and O, made into checked matrices; O made into an observation model.

Checks are made here, on the last entry given for every cell: each is a probability and each row
sums to 1 (within :data:`~beliefloc.pomdp_format.names.TOLERANCE`). An action's observation model
is one :class:`~beliefloc.model.ObservationPart` named after the action, with one distinct row of
its table per group of states that observe alike.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from beliefloc.model import NONE_OBSERVATION, NOTHING, ObservationModel, ObservationPart
from beliefloc.pomdp_format.names import TOLERANCE
from beliefloc.pomdp_format.parser import ParsedFile
from beliefloc.pomdp_format.tables import Entries


def checked_matrix(parsed: ParsedFile, entries: Entries, a: int, n_cols: int, which: str) -> sp.csr_matrix:
    """Action ``a``'s T (``which='T'``) or O as CSR, checked: probabilities, rows summing to 1."""
    preamble = parsed.preamble
    n = preamble.size("states")
    action = preamble.declared["actions"].names[a]
    rows, cols, vals, lines = entries.arrays(n_cols)
    bad = np.flatnonzero(~((vals >= 0.0) & (vals <= 1.0)))
    if len(bad):
        i = bad[np.argmin(lines[bad])]  # the first bad entry in the file, wherever its cell is
        raise parsed.error(int(lines[i]), f"{which}: {vals[i]:g} is not a probability (between 0 and 1)")
    sums = np.bincount(rows, weights=vals, minlength=n)
    wrong = np.flatnonzero(np.abs(sums - 1.0) > TOLERANCE)
    if len(wrong):
        state = int(wrong[0])
        state_name = preamble.declared["states"].names[state]
        touched = lines[rows == state]
        line = int(touched.max()) if len(touched) else entries.first_line or preamble.declared["actions"].line
        if len(vals) == 0:
            hint = f" (for a perception action write 'T: {action}' and then 'identity')" if which == "T" else ""
            raise parsed.error(line, f"{which}: no probabilities are given for action {action!r}{hint}")
        role = "from state" if which == "T" else "in state"
        what = "next states" if which == "T" else "observations"
        raise parsed.error(
            line,
            f"{which}: for action {action!r} {role} {state_name!r}, the probabilities of the {what} sum to "
            f"{sums[state]:.9g}, not 1" + (f" ({len(wrong)} rows are wrong)" if len(wrong) > 1 else ""),
        )
    keep = vals != 0.0
    matrix = sp.csr_matrix((vals[keep], (rows[keep], cols[keep])), shape=(n, n_cols))
    matrix.sum_duplicates()
    return matrix


def is_identity(matrix: sp.csr_matrix) -> bool:
    n = matrix.shape[0]
    return bool(
        matrix.nnz == n
        and np.array_equal(matrix.indptr, np.arange(n + 1))
        and np.array_equal(matrix.indices, np.arange(n))
        and np.all(matrix.data == 1.0)
    )


def observation_model(
    parsed: ParsedFile, entries: Entries, a: int, ident: str, name: str, observation_names: list[str]
) -> ObservationModel:
    """Action ``a``'s observation model from its O entries; ``name`` names its one part.

    The part's values are the observations O gives a non-zero probability somewhere, in the order
    of ``observations:`` or of the action's ``beliefloc-action`` comment; an action whose only
    observation is ``none`` has no part at all.
    """
    preamble = parsed.preamble
    n = preamble.size("states")
    matrix = checked_matrix(parsed, entries, a, preamble.size("observations"), "O")
    used = np.unique(matrix.indices)
    columns, aliases_by_ident = _own_observations(parsed, ident, used)
    names = [observation_names[c] for c in columns]
    if names == [NONE_OBSERVATION]:
        return ObservationModel(n)
    table = matrix[:, columns].toarray()
    confusion, truth = _distinct_rows(table)
    position = {c: w for w, c in enumerate(columns)}
    lookup = preamble.lookup["observations"]
    aliases = {
        alias: position[lookup[obs]]
        for alias, obs in aliases_by_ident.items()
        if obs in lookup and lookup[obs] in position
    }
    values = tuple("" if v == NOTHING else v for v in names)  # 'nothing' is the part's silent value
    return ObservationModel(n, (ObservationPart(name, values, truth, confusion, aliases),))


def _own_observations(parsed: ParsedFile, ident: str, used: np.ndarray) -> tuple[list[int], dict[str, str]]:
    """The columns of O that are the action's observations, in order, and its aliases (by identifier).

    Without a ``beliefloc-action`` comment they are the ``used`` columns; with one, the comment's
    list, which must name declared observations, once each, and every one O uses.
    """
    noted = parsed.notes.actions.get(ident)
    if noted is None:
        return used.tolist(), {}
    info, line = noted
    preamble = parsed.preamble
    lookup = preamble.lookup["observations"]
    columns = []
    for obs in info["observations"]:
        if obs not in lookup:
            raise parsed.error(
                line, f"beliefloc-action: unknown observation {obs!r}; {preamble.describe('observations')}"
            )
        columns.append(lookup[obs])
    if len(set(columns)) != len(columns):
        raise parsed.error(line, f"beliefloc-action: {ident!r} lists an observation twice")
    missing = sorted(set(used.tolist()) - set(columns))
    if missing:
        obs_name = preamble.declared["observations"].names[missing[0]]
        raise parsed.error(
            line,
            f"beliefloc-action: O gives action {ident!r} the observation {obs_name!r}, which this comment "
            "does not list",
        )
    return columns, dict(info.get("aliases", {}))


def _distinct_rows(table: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(confusion, truth)`` with ``confusion[truth] == table``: one row per distinct row of ``table``,
    in order of first appearance."""
    distinct, first, inverse = np.unique(table, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first)
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return distinct[order], rank[inverse.ravel()].astype(np.int64)
