"""Saving and loading macro tables: a versioned ``.npz`` file that records the model's fingerprint.

A macro table is derived from a model (its ``f*``, costs and sensors), so it is only valid for that
model: the file records :meth:`Model.fingerprint` and loading it for another model -- or for the same
map edited since -- is refused. The file also records the source map's path, so ``macros show`` can
find the model. Writes are atomic (:func:`beliefloc.model_file.write_atomically`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from beliefloc.errors import ModelError
from beliefloc.model import Model
from beliefloc.model_file import read_versioned, write_versioned
from beliefloc.planning.macros import MacroTable

FORMAT = "beliefloc-macros"
VERSION = 1
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


def save_macros(table: MacroTable, path: str | Path, *, model: Model | None = None) -> None:
    """Write ``table`` to ``path`` (conventionally ``*.npz``); ``model`` names its source map."""
    source = None if model is None or model.source is None else model.source.path
    header = {
        "format": FORMAT,
        "version": VERSION,
        "model": None if model is None else model.name,
        "source": source,
        "fingerprint": table.fingerprint,
        "n_states": table.n_states,
        "gamma": table.gamma,
        "actions": list(table.action_names),
        "seconds": table.seconds,
    }
    write_versioned(path, header, {name: getattr(table, name) for name in _ARRAYS})


def read_header(path: str | Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """The header and arrays of a macro file, checked for format and version."""
    header, arrays = read_versioned(
        path, FORMAT, VERSION, kind="beliefloc macro file", rebuild=f"beliefloc macros build MAP -o {path}"
    )
    missing = [name for name in _ARRAYS if name not in arrays]
    if missing:
        raise ModelError(f"{path}: broken macro file (missing {', '.join(missing)})")
    return header, arrays


def load_macros(path: str | Path, model: Model) -> MacroTable:
    """The macro table in ``path``, refused unless it was built for exactly ``model``."""
    header, arrays = read_header(path)
    if header["fingerprint"] != model.fingerprint():
        built_for = header.get("source") or header.get("model") or "another model"
        raise ModelError(
            f"{path}: stale macro table: it was built for {built_for} as it was then, not for this "
            f"{model.name} (the model's numbers differ); rebuild it with 'beliefloc macros build MAP -o {path}'"
        )
    return MacroTable(
        n_states=int(header["n_states"]),
        gamma=float(header["gamma"]),
        action_names=tuple(header["actions"]),
        fingerprint=str(header["fingerprint"]),
        seconds=float(header.get("seconds", 0.0)),
        **{name: arrays[name] for name in _ARRAYS},
    )
