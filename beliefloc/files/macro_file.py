"""Saving and loading macro tables: a versioned ``.npz`` file that records the model's fingerprint.

A macro table is derived from a model (its ``f*``, costs and sensors), so it is only valid for that
model: the file records :meth:`Model.fingerprint` and loading it for another model is refused. The
file also records the map it was built from (absolute path and sha256), so that ``macros show``
finds the model, and so that the refusal says what happened: a table *for another map*, or a
*stale* table, built for this very map before it was edited.

Reading trusts nothing in the file (:func:`beliefloc.files.npz_archive.open_versioned`): the header is
validated field by field and every array checked before use -- pairs inside the states and sorted,
actions and pairs that exist, macros that end (each one's follower made before it), lengths that
count down along a pair's macro. Writes are atomic (:func:`beliefloc.source.atomic_write.write_atomically`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import Field, StrictInt, StrictStr

from beliefloc.errors import ModelError
from beliefloc.files.model_file import StrictHeader, absolute, write_versioned
from beliefloc.files.npz_archive import Archive, open_versioned
from beliefloc.model import Model
from beliefloc.planning.macros import MacroTable
from beliefloc.source import limits

FORMAT = "beliefloc-macros"
VERSION = 1
FILE_LABEL = "beliefloc macro file"
_ARRAYS = (
    "pair_i",
    "pair_j",
    "cost",
    "first_action",
    "next_pair",
    "length",
    "macro_id",
    "macro_first",
    "macro_next",
)


class MacroHeader(StrictHeader):
    """The JSON header of a macro file."""

    format: Literal["beliefloc-macros"]
    version: Literal[1]
    model: StrictStr | None = None
    """The name of the model it was built for."""
    source: StrictStr | None = None
    """The map (or .pomdp file) that model was compiled from: an absolute path."""
    source_sha256: StrictStr | None = Field(default=None, pattern=r"^[0-9a-f]{64}$")
    fingerprint: StrictStr = Field(pattern=r"^[0-9a-f]{64}$")
    n_states: StrictInt = Field(ge=1)
    gamma: float = Field(ge=0.0, le=1.0, allow_inf_nan=False)
    actions: list[StrictStr] = Field(min_length=1)
    seconds: float = Field(default=0.0, ge=0.0, allow_inf_nan=False)


def save_macros(table: MacroTable, path: str | Path, *, model: Model | None = None) -> None:
    """Write ``table`` to ``path`` (conventionally ``*.npz``); ``model`` names its source map."""
    source = None if model is None else model.source
    header = {
        "format": FORMAT,
        "version": VERSION,
        "model": None if model is None else model.name,
        "source": None if source is None else absolute(source.path),
        "source_sha256": None if source is None else source.sha256,
        "fingerprint": table.fingerprint,
        "n_states": table.n_states,
        "gamma": table.gamma,
        "actions": list(table.action_names),
        "seconds": table.seconds,
    }
    write_versioned(path, header, {name: getattr(table, name) for name in _ARRAYS})


def read_header(path: str | Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """The header and arrays of a macro file, every field and array checked (for any model: that
    the table is for a given model is :func:`load_macros`'s check)."""
    header, arrays = _read(Path(path))
    return header.model_dump(), arrays


def _read(path: Path) -> tuple[MacroHeader, dict[str, np.ndarray]]:
    from beliefloc.source.file_kinds import MACROS

    rebuild = f"beliefloc macros build MAP -o {path}"
    with open_versioned(path, FORMAT, VERSION, label=FILE_LABEL, kind=MACROS, rebuild=rebuild) as archive:
        header = archive.validate(MacroHeader)
        if header.source is not None:
            archive.rebuild = f"beliefloc macros build {header.source} -o {path}"
        limits.MODEL_ENTRIES.check(header.n_states, f"{path}: header field n_states")
        if len(set(header.actions)) != len(header.actions):
            raise archive.broken("header field actions: an action is listed twice")
        archive.expect(_ARRAYS)
        arrays = _Checks(archive, header).arrays()
    return header, arrays


class _Checks:
    """The arrays of a macro table, each checked against the header and the others."""

    def __init__(self, archive: Archive, header: MacroHeader) -> None:
        self.archive = archive
        self.n = header.n_states
        self.n_actions = len(header.actions)

    def arrays(self) -> dict[str, np.ndarray]:
        archive, n = self.archive, self.n
        pair_i = self._ints("pair_i", (None,))
        pairs = len(pair_i)
        pair_j = self._ints("pair_j", (pairs,))
        self._inside("pair_i", pair_i, 0, n - 1, f"a state (there are {n:,})")
        self._inside("pair_j", pair_j, 0, n - 1, f"a state (there are {n:,})")
        if pairs and not (pair_i < pair_j).all():
            raise archive.broken(f"array pair_i: pair {int(np.flatnonzero(pair_i >= pair_j)[0])} is not i < j")
        keys = pair_i * n + pair_j
        if pairs > 1 and not (np.diff(keys) > 0).all():
            raise archive.broken("arrays pair_i and pair_j: the pairs are not sorted, or a pair is listed twice")
        cost = archive.array("cost", "f", (pairs,)).astype(np.float64, copy=False)
        if np.isnan(cost).any() or (cost < 0).any() or np.isneginf(cost).any():
            raise archive.broken("array cost: a cost is not a number >= 0 (or inf: never told apart)")
        never = ~np.isfinite(cost)
        first_action = self._ints("first_action", (pairs,))
        self._inside("first_action", first_action, -1, self.n_actions - 1, "an action or -1")
        next_pair = self._ints("next_pair", (pairs,))
        self._inside("next_pair", next_pair, -1, pairs - 1, "a pair or -1")
        length = self._ints("length", (pairs,))
        self._inside("length", length, 0, max(pairs, 1), "a number of actions")
        macro_id = self._ints("macro_id", (pairs,))
        macro_first = self._ints("macro_first", (None,))
        macros = len(macro_first)
        self._inside("macro_id", macro_id, -1, macros - 1, "a macro or -1")
        self._inside("macro_first", macro_first, 0, self.n_actions - 1, "an action")
        macro_next = self._ints("macro_next", (macros,))
        if macros and not ((macro_next >= -1) & (macro_next < np.arange(macros))).all():
            m = int(np.flatnonzero(~((macro_next >= -1) & (macro_next < np.arange(macros))))[0])
            raise archive.broken(f"array macro_next: macro {m} is followed by {int(macro_next[m])}, not an earlier one")
        ends = never == (first_action < 0)
        ends &= never == (macro_id < 0)
        ends &= never == (length == 0)
        if not ends.all():
            p = int(np.flatnonzero(~ends)[0])
            raise archive.broken(
                f"pair {p}: its cost, first action, macro and length disagree on whether it can be told apart"
            )
        follows = next_pair >= 0
        step = np.where(follows, length[np.maximum(next_pair, 0)] + 1, np.where(never, 0, 1))
        if not (step == length).all():
            p = int(np.flatnonzero(step != length)[0])
            raise archive.broken(f"array length: pair {p}'s macro is not one action longer than the pair it leads to")
        return {
            "pair_i": pair_i,
            "pair_j": pair_j,
            "cost": cost,
            "first_action": first_action,
            "next_pair": next_pair,
            "length": length,
            "macro_id": macro_id,
            "macro_first": macro_first,
            "macro_next": macro_next,
        }

    def _ints(self, key: str, shape: tuple[int | None, ...]) -> np.ndarray:
        return self.archive.integers(key, shape).astype(np.int64, copy=False)

    def _inside(self, key: str, values: np.ndarray, low: int, high: int, what: str) -> None:
        bad = np.flatnonzero((values < low) | (values > high))
        if len(bad):
            k = int(bad[0])
            raise self.archive.broken(f"array {key}: entry {k} is {int(values[k])}, not {what}")


def load_macros(path: str | Path, model: Model) -> MacroTable:
    """The macro table in ``path``, refused unless it was built for exactly ``model``: a table for
    another map says so, one for this map as it was before an edit is *stale*."""
    from beliefloc.source import file_kinds

    path = Path(path)
    by_suffix = file_kinds.kind_of_path(path)
    if by_suffix not in (None, file_kinds.MODEL_OR_MACROS):
        raise ModelError(file_kinds.not_a(path, by_suffix, file_kinds.MACROS))
    if path.suffix.lower() in (".yaml", ".yml", ".json"):  # a hand-written file: say which kind
        from beliefloc.errors import InputFileError
        from beliefloc.source import read_source

        try:
            found = file_kinds.kind_of_data(read_source(path, InputFileError).data) or "a text file"
        except InputFileError:
            found = "a text file"
        raise ModelError(file_kinds.not_a(path, found, file_kinds.MACROS))
    header, arrays = _read(path)
    names = tuple(a.name for a in model.actions)
    if header.fingerprint != model.fingerprint() or header.n_states != model.n_states or tuple(header.actions) != names:
        raise ModelError(_not_for(path, header, model))
    return MacroTable(
        n_states=header.n_states,
        gamma=float(header.gamma),
        action_names=tuple(header.actions),
        fingerprint=header.fingerprint,
        seconds=float(header.seconds),
        **arrays,
    )


def _not_for(path: Path, header: MacroHeader, model: Model) -> str:
    """Why the table in ``path`` is not for ``model``: built for another map, or stale."""
    this = model.source.path if model.source is not None else None
    if header.source is not None and this is not None:
        same = absolute(header.source) == absolute(this)
    else:
        same = header.model is not None and header.model == model.name
    if same:
        where = this or f"model {model.name}"
        return (
            f"{path}: stale macro table: it was built for {where} before it changed (the model's numbers "
            f"differ now); rebuild it with 'beliefloc macros build {this or 'MAP'} -o {path}'"
        )
    built_for = header.source or (f"model {header.model}" if header.model else "another model")
    given = f"{this} (model {model.name})" if this else f"model {model.name}"
    return (
        f"{path}: a macro table for another map: it was built for {built_for}, not for {given}; give the "
        f"table built for this map, or build one with 'beliefloc macros build {this or 'MAP'} -o NEW.npz'"
    )
