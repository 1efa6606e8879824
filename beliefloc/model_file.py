"""Saving and loading compiled models: a versioned ``.npz`` file that records the hash of its map.

A model file holds a JSON header (format, version, names, costs, the grid, the source map's path
and sha256) and the arrays (CSR transitions, observation truths and confusion tables). Loading
refuses a file of another format or version, and a model whose source map has changed since it
was built (stale). Writes go to a temporary file renamed into place, so a failed write never
leaves a half-written model.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sp

from beliefloc.errors import ModelError
from beliefloc.model import (
    Action,
    ActionKind,
    GridLayout,
    MapFrame,
    Model,
    ObservationModel,
    ObservationPart,
    SourceInfo,
    StateSpace,
)

FORMAT = "beliefloc-model"
VERSION = 1
SUFFIX = ".npz"


def write_atomically(path: Path, write: Any, *, binary: bool = True) -> None:
    """Call ``write(file)`` on a temporary file beside ``path`` and rename it into place."""
    path = Path(path)
    directory = path.parent if str(path.parent) else Path(".")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=directory)
    try:
        os.fchmod(fd, _file_mode())  # as open() would create it, not mkstemp's private 0600
        with os.fdopen(fd, "wb" if binary else "w") as handle:
            write(handle)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _file_mode() -> int:
    """0o666 less the umask."""
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


def write_versioned(path: str | Path, header: dict[str, Any], arrays: dict[str, np.ndarray]) -> None:
    """Write a JSON ``header`` (with its ``format`` and ``version``) and ``arrays`` as one ``.npz``."""
    contents = {**arrays, "header": np.frombuffer(json.dumps(header).encode(), dtype=np.uint8)}

    def write(handle: Any) -> None:
        np.savez_compressed(handle, allow_pickle=False, **contents)

    write_atomically(Path(path), write)


def read_versioned(
    path: str | Path, file_format: str, version: int, *, kind: str, rebuild: str
) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """The header and arrays of a file written by :func:`write_versioned`; a :class:`ModelError`
    if it is missing, not such a file (``kind``), or of another version (``rebuild`` says how to
    make a new one)."""
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as npz:
            arrays = {key: npz[key] for key in npz.files}
    except FileNotFoundError:
        raise ModelError(f"{path}: no such file") from None
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        raise ModelError(f"{path}: not a {kind} ({exc})") from None
    try:
        header = json.loads(arrays.pop("header").tobytes())
    except (KeyError, ValueError):
        raise ModelError(f"{path}: not a {kind} (no header)") from None
    if not isinstance(header, dict) or header.get("format") != file_format:
        raise ModelError(f"{path}: not a {kind}")
    if header.get("version") != version:
        raise ModelError(
            f"{path}: {kind} version {header.get('version')}, but this beliefloc reads version {version}; "
            f"rebuild it with '{rebuild}'"
        )
    return header, arrays


def save_model(model: Model, path: str | Path) -> None:
    """Write ``model`` to ``path`` (conventionally ``*.npz``)."""
    arrays: dict[str, np.ndarray] = {}
    part_ids: dict[int, int] = {}  # passive parts are shared by actions: store each once
    parts_meta: list[dict[str, Any]] = []
    actions_meta: list[dict[str, Any]] = []
    for i, action in enumerate(model.actions):
        refs = []
        for part in action.observation.parts:
            if id(part) not in part_ids:
                j = len(parts_meta)
                part_ids[id(part)] = j
                parts_meta.append({"name": part.name, "values": list(part.values), "aliases": part.aliases})
                arrays[f"part{j}_truth"] = part.truth
                arrays[f"part{j}_confusion"] = part.confusion
            refs.append(part_ids[id(part)])
        if action.transition is not None:
            t = action.transition
            arrays[f"action{i}_indptr"] = t.indptr
            arrays[f"action{i}_indices"] = t.indices
            arrays[f"action{i}_data"] = t.data
        actions_meta.append(
            {
                "name": action.name,
                "kind": action.kind.value,
                "cost": action.cost,
                "transition": action.transition is not None,
                "parts": refs,
            }
        )
    grid = model.grid
    if grid is not None:
        arrays["grid_free"] = grid.free
    header = {
        "format": FORMAT,
        "version": VERSION,
        "name": model.name,
        "n_states": model.n_states,
        "state_names": None if grid is not None else model.states.names,
        "grid": None if grid is None else {**grid.describe(), "landmarks": [list(lm) for lm in grid.landmarks]},
        "source": None if model.source is None else {"path": model.source.path, "sha256": model.source.sha256},
        "actions": actions_meta,
        "parts": parts_meta,
        "fingerprint": model.fingerprint(),
    }
    write_versioned(path, header, arrays)


def load_model(path: str | Path, *, check_source: bool = True) -> Model:
    """Read a model file. Raises :class:`ModelError` if it is not one, is of another version, or
    (with ``check_source``) its source map has changed since it was built."""
    path = Path(path)
    header, arrays = read_versioned(
        path, FORMAT, VERSION, kind="beliefloc model file", rebuild=f"beliefloc build MAP -o {path}"
    )
    model = _from_header(header, arrays)
    if check_source and model.source is not None:
        check_fresh(model.source, path)
    return model


def check_fresh(source: SourceInfo, model_path: Path) -> None:
    """Raise if the map a model was built from has changed since (a stale model)."""
    candidates = [Path(source.path), model_path.parent / Path(source.path).name]
    for candidate in candidates:
        if candidate.is_file():
            digest = hashlib.sha256(candidate.read_bytes()).hexdigest()
            if digest != source.sha256:
                raise ModelError(
                    f"{model_path}: stale model: {candidate} has changed since the model was built; "
                    f"rebuild it with 'beliefloc build {candidate} -o {model_path}'"
                )
            return


def _from_header(header: dict[str, Any], arrays: dict[str, np.ndarray]) -> Model:
    n = int(header["n_states"])
    parts = [
        ObservationPart(
            meta["name"],
            tuple(meta["values"]),
            arrays[f"part{j}_truth"],
            arrays[f"part{j}_confusion"],
            {str(k): int(v) for k, v in meta["aliases"].items()},
        )
        for j, meta in enumerate(header["parts"])
    ]
    actions = []
    for i, meta in enumerate(header["actions"]):
        transition = None
        if meta["transition"]:
            transition = sp.csr_matrix(
                (arrays[f"action{i}_data"], arrays[f"action{i}_indices"], arrays[f"action{i}_indptr"]),
                shape=(n, n),
            )
        observation = ObservationModel(n, tuple(parts[j] for j in meta["parts"]))
        actions.append(Action(meta["name"], ActionKind(meta["kind"]), float(meta["cost"]), transition, observation))
    grid = None
    if header["grid"] is not None:
        g = header["grid"]
        grid = GridLayout(
            g["rows"],
            g["cols"],
            g["headings"],
            g["cell_size"],
            arrays["grid_free"].astype(bool),
            tuple((str(c), int(r), int(k)) for c, r, k in g["landmarks"]),
            MapFrame(**{k: float(v) for k, v in g.get("frame", {}).items()}),
        )
    states = StateSpace(n, grid=grid, names=header["state_names"])
    source = None if header["source"] is None else SourceInfo(**header["source"])
    return Model(header["name"], states, tuple(actions), grid, source)
