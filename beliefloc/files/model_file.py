"""Saving and loading compiled models: a versioned ``.npz`` file that records the hash of its map.

A model file holds a JSON header (format, version, names, costs, the grid, the source map's
absolute path and sha256) and the arrays (CSR transitions, observation truths and confusion
tables, the grid's free cells and landmarks). Version 2 keeps the landmarks in an array
(``grid_landmarks``: class index, row, column) instead of the header's list of triples, which
pydantic took 0.45-0.75 s to validate for a 10^7-state world's million objects; version 1 files
are still read. Model files are shared like maps, so reading one trusts nothing in it:

* the archive is read member by member, never with pickles, each member's size checked before a
  byte is decompressed (:mod:`beliefloc.files.npz_archive`);
* the header is validated field by field (:class:`_ModelHeader`), and its sizes against
  :data:`~beliefloc.source.limits.MODEL_ENTRIES`, before any array is read;
* every array must be the one the header announces -- its key, type and shape -- and hold what a
  model can use: CSR index arrays inside the states (scipy would write out of bounds otherwise),
  ``indptr`` rising from 0 to the number of entries, finite probabilities in [0, 1], transition rows
  and confusion rows summing to 1, true values inside their confusion table.

Any problem is a :class:`~beliefloc.errors.ModelError` naming the file and the field. A file of
another format is named (``x.npz is a macro table, not a compiled model``), one of another version
refused with how to rebuild it, and a model whose source map has changed since it was built
(stale) refused; when the map is gone, a warning says it cannot be checked.

Writes are whole or nothing (:mod:`beliefloc.source.atomic_write`).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import queue
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, Literal

import numpy as np
import scipy.sparse as sp
from pydantic import BaseModel, ConfigDict, Field, StrictBool, StrictInt, StrictStr

from beliefloc.errors import ModelError
from beliefloc.files.npz_archive import Archive, open_versioned, write_stored
from beliefloc.model import (
    Action,
    ActionKind,
    GridLayout,
    Landmark,
    LandmarkTable,
    MapFrame,
    Model,
    ObservationModel,
    ObservationPart,
    SourceInfo,
    StateSpace,
)
from beliefloc.source import limits, threads
from beliefloc.source.atomic_write import write_atomically
from beliefloc.source.sparse_kernels import csr_matvec as _csr_matvec

FORMAT = "beliefloc-model"
VERSION = 2
SUFFIX = ".npz"
FILE_LABEL = "beliefloc model file"
"""What a file that is not even an archive is said not to be."""
TOLERANCE = 1e-6
"""How far from 1 a row of a transition or confusion table may sum."""
_THREADED_FROM = 2**18
"""States from which a model's moves are read side by side (fewer take milliseconds)."""

Warn = Callable[[str], None]

# --- writing ---------------------------------------------------------------------------------------


def write_versioned(
    path: str | Path, header: dict[str, Any], arrays: dict[str, np.ndarray], *, compress: bool = True
) -> None:
    """Write a JSON ``header`` (with its ``format`` and ``version``) and ``arrays`` as one ``.npz``,
    deflated (``np.savez_compressed``) or, with ``compress=False``, stored, each array's data aligned in
    the file (:func:`~beliefloc.files.npz_archive.write_stored`: a file about eight times larger for a
    model, mapped from the file when read: no inflating and no copy)."""
    text = json.dumps(header, allow_nan=False).encode()
    contents = {**arrays, "header": np.frombuffer(text, dtype=np.uint8)}

    def write(handle: Any) -> None:
        if compress:
            np.savez_compressed(handle, allow_pickle=False, **contents)
        else:
            write_stored(handle, contents)

    write_atomically(Path(path), write)


# --- the model header ------------------------------------------------------------------------------

_Name = Field(min_length=1)
_Finite = Field(allow_inf_nan=False)
_SHA256 = Field(pattern=r"^[0-9a-f]{64}$")


class StrictHeader(BaseModel):
    """A JSON header's fields, validated strictly: no conversions, no NaN or infinity."""

    model_config = ConfigDict(extra="ignore", strict=True, allow_inf_nan=False)


class _PartHeader(StrictHeader):
    name: StrictStr
    values: list[StrictStr] = Field(min_length=1)
    aliases: dict[StrictStr, StrictInt]


class _ActionHeader(StrictHeader):
    name: StrictStr = _Name
    kind: Literal["actuation", "perception"]
    cost: float = Field(ge=0.0, allow_inf_nan=False)
    transition: StrictBool
    parts: list[StrictInt]


class _FrameHeader(StrictHeader):
    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0


class _GridHeader(StrictHeader):
    rows: StrictInt = Field(ge=1)
    cols: StrictInt = Field(ge=1)
    headings: StrictInt = Field(ge=1)
    cell_size: float = Field(gt=0.0, allow_inf_nan=False)
    landmarks: list[tuple[StrictStr, StrictInt, StrictInt]] = []
    """Version 1: the landmarks themselves. Version 2: empty (array ``grid_landmarks``)."""
    landmark_classes: list[StrictStr] = []
    """Version 2: the class names ``grid_landmarks`` indexes."""
    frame: _FrameHeader = _FrameHeader()


class _SourceHeader(StrictHeader):
    path: StrictStr = _Name
    sha256: StrictStr = _SHA256


class _ModelHeader(StrictHeader):
    format: Literal["beliefloc-model"]
    version: Literal[1, 2]
    name: StrictStr
    n_states: StrictInt = Field(ge=1)
    state_names: list[StrictStr] | None
    grid: _GridHeader | None
    source: _SourceHeader | None
    actions: list[_ActionHeader] = Field(min_length=1)
    parts: list[_PartHeader]
    fingerprint: StrictStr


# --- saving and loading models ---------------------------------------------------------------------


def _landmark_table(landmarks: Sequence[Landmark]) -> tuple[list[str], np.ndarray]:
    """The landmarks' classes in the order they first appear, and a row (class index, row, column) a landmark.
    A loaded model's :class:`LandmarkTable` is renumbered as it is, without its triples (a 10^7-state world's
    1.09 million made 0.5 s of ``build MODEL.npz --uncompressed``): the same file as from the triples."""
    if isinstance(landmarks, LandmarkTable):
        names, table = landmarks.as_table()
        codes = table[:, 0].astype(np.int64)
        _, first = np.unique(codes, return_index=True)
        used = codes[np.sort(first)]  # class indices in order of first appearance
        renumber = np.zeros(len(names), dtype=np.int64)
        renumber[used] = np.arange(len(used))
        out = table.astype(np.int64)
        out[:, 0] = renumber[codes]
        return [names[k] for k in used.tolist()], out
    classes = list(dict.fromkeys(cls for cls, _, _ in landmarks))
    index = {cls: k for k, cls in enumerate(classes)}
    out = np.zeros((len(landmarks), 3), dtype=np.int64)
    if landmarks:
        out[:, 0] = [index[cls] for cls, _, _ in landmarks]
        out[:, 1:] = [(r, c) for _, r, c in landmarks]
    return classes, out


def save_model(model: Model, path: str | Path, *, compress: bool = True) -> None:
    """Write ``model`` to ``path`` (conventionally ``*.npz``). The source map is recorded by its
    absolute path, so the model can be checked against it from any folder. ``compress=False`` stores
    the arrays uncompressed: about eight times the file (130 MB instead of 16 MB for a generated
    10^6-state world), read in 0.1 s instead of 0.3 s (no zlib inflating)."""
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
    classes: list[str] = []
    if grid is not None:
        arrays["grid_free"] = grid.free
        classes, landmarks = _landmark_table(grid.landmarks)
        arrays["grid_landmarks"] = landmarks
    source = model.source
    header = {
        "format": FORMAT,
        "version": VERSION,
        "name": model.name,
        "n_states": model.n_states,
        "state_names": None if grid is not None else model.states.names,
        "grid": None if grid is None else {**grid.describe(), "landmark_classes": classes},
        "source": None if source is None else {"path": absolute(source.path), "sha256": source.sha256},
        "actions": actions_meta,
        "parts": parts_meta,
        "fingerprint": model.fingerprint(),
    }
    write_versioned(path, header, arrays, compress=compress)


def absolute(path: str | Path) -> str:
    """``path`` made absolute and canonical (symbolic links resolved), as files record their sources."""
    return os.path.realpath(path)


def load_model(path: str | Path, *, check_source: bool = True, on_warning: Warn | None = None) -> Model:
    """Read a model file, checking every field and array (see the module docs). Raises
    :class:`ModelError` if it is not one, is of another version, is broken, or (with
    ``check_source``) its source map has changed since it was built; when that map is not there
    any more, ``on_warning`` is told that the model cannot be checked."""
    from beliefloc.source.file_kinds import MODEL

    path = Path(path)
    with open_versioned(
        path, FORMAT, VERSION, label=FILE_LABEL, kind=MODEL, rebuild=f"beliefloc build MAP -o {path}", older=(1,)
    ) as archive:
        header = archive.validate(_ModelHeader)
        if header.source is not None:
            archive.rebuild = f"beliefloc build {header.source.path} -o {path}"
        model = _ModelReader(archive, header).model()
    if check_source and model.source is not None:
        check_fresh(model.source, path, on_warning=on_warning)
    return model


def check_fresh(source: SourceInfo, model_path: Path, *, on_warning: Warn | None = None) -> None:
    """Raise if the map a model was built from has changed since (a stale model); tell
    ``on_warning`` when that map is not there any more, so nothing can be checked.

    The map is looked for where the model records it (an absolute path; an older model's relative
    path from the working folder or the model's folder), then beside the model under its name,
    which counts only when its content is the very same (the map moved with the model)."""
    model_path = Path(model_path)
    recorded = Path(source.path)
    candidates = [recorded] if recorded.is_absolute() else [recorded, model_path.parent / recorded]
    for candidate in candidates:
        digest = _digest(candidate)
        if digest is None:
            continue
        if digest != source.sha256:
            raise ModelError(
                f"{model_path}: stale model: {candidate} has changed since the model was built; "
                f"rebuild it with 'beliefloc build {candidate} -o {model_path}'"
            )
        return
    beside = model_path.parent / recorded.name
    note = ""
    if all(beside != c for c in candidates):
        digest = _digest(beside)
        if digest == source.sha256:
            return  # the map moved with the model
        if digest is not None:
            note = f" ({beside}, beside the model, has the same name but other content)"
    if on_warning is not None:
        on_warning(
            f"{model_path}: cannot check whether the model is stale: the map it was built from, {recorded}, "
            f"is not there any more (moved or deleted){note}; if that map changed, rebuild the model from it"
        )


def _digest(path: Path) -> str | None:
    """The sha256 of a regular file, read in chunks; None when there is no such file to read."""
    try:
        if not path.is_file():
            return None
        digest = hashlib.sha256()
        with open(path, "rb") as handle:
            for chunk in iter(lambda: handle.read(1 << 20), b""):
                digest.update(chunk)
    except (OSError, ValueError):
        return None
    return digest.hexdigest()


class _ModelReader:
    """The checks of a model file's header and arrays, in the order they can be made, and the model."""

    def __init__(self, archive: Archive, header: _ModelHeader) -> None:
        self.archive = archive
        self.header = header
        self.n = header.n_states
        self.states: StateSpace | None = None
        """Once the grid is read: for naming states in messages."""
        self._ones: np.ndarray | None = None
        """A vector of ``n`` ones for every transition's row sums (:meth:`_row_sums`), made by :meth:`model`."""
        self._scratch: queue.SimpleQueue[np.ndarray] = queue.SimpleQueue()
        """Vectors of ``n`` floats for row sums, one a thread that checks transitions (:meth:`model` makes them)."""

    def state(self, i: int) -> str:
        """State ``i`` for a message: its name when known."""
        return f"{i}" if self.states is None else self.states.name(i)

    def broken(self, what: str) -> ModelError:
        return self.archive.broken(what)

    def model(self) -> Model:
        h = self.header
        self._check_header()
        self.archive.expect(self._keys())
        grid = self._grid()
        states = self.states = StateSpace(self.n, grid=grid, names=h.state_names)
        parts = [self._part(j, meta) for j, meta in enumerate(h.parts)]
        # each move's arrays read and checked on the cores this process may use (the checks' passes and the
        # CRC-32 release the interpreter's lock: a 10^7-state world's four moves 1.0-1.5 s on one core); a
        # broken file names the first broken move, as one after the other would
        moves = [(i, meta.name) for i, meta in enumerate(h.actions) if meta.transition]
        pool = threads.pool() if self.n >= _THREADED_FROM else None
        if moves:
            # made in this thread: freed, their memory is what a search's first beliefs are cut from (made in
            # the pool's threads, it went back to the kernel, and at 10^7 states 240 MB were fresh pages again)
            self._ones = threads.filled(np.empty(self.n), 1.0) if pool is not None else np.ones(self.n)
            for _ in range(min(len(moves), threads.size()) if pool is not None else 1):
                self._scratch.put(np.empty(self.n))
        checked = (pool.map if pool is not None else map)(lambda move: self._transition(*move), moves)
        transitions = dict(zip([i for i, _ in moves], checked, strict=True))
        actions = []
        for i, meta in enumerate(h.actions):
            transition = transitions.get(i)
            observation = ObservationModel(self.n, tuple(parts[j] for j in meta.parts))
            actions.append(Action(meta.name, ActionKind(meta.kind), float(meta.cost), transition, observation))
        source = None if h.source is None else SourceInfo(h.source.path, h.source.sha256)
        return Model(h.name, states, tuple(actions), grid, source)

    # --- the header, before any array ----------------------------------------------------------
    def _check_header(self) -> None:
        h, n = self.header, self.n
        if h.grid is None and h.state_names is None:
            raise self.broken("the header has neither a grid nor state names")
        if h.state_names is not None:
            if len(h.state_names) != n:
                raise self.broken(f"header field state_names: {len(h.state_names):,} names for {n:,} states")
            if len(set(h.state_names)) != n:
                raise self.broken("header field state_names: a name is given twice")
        if h.grid is not None:
            g = h.grid
            limits.MODEL_ENTRIES.check(g.rows * g.cols * g.headings, f"{self.archive.path}: header field grid")
            if h.version >= 2 and g.landmarks:
                raise self.broken("header field grid.landmarks: a version 2 model keeps them in array grid_landmarks")
            # the common case, a million landmarks on the grid, checked by min and max (the loop that
            # names the first one outside took 0.46 s at 10^7 states)
            rows = [r for _, r, _ in g.landmarks]
            cols = [c for _, _, c in g.landmarks]
            inside = not rows or (min(rows) >= 0 and max(rows) < g.rows and min(cols) >= 0 and max(cols) < g.cols)
            for k, (cls, r, c) in enumerate(() if inside else g.landmarks):
                if not (0 <= r < g.rows and 0 <= c < g.cols):
                    raise self.broken(
                        f"header field grid.landmarks[{k}]: {cls} at [{r}, {c}] is outside the {g.rows}x{g.cols} grid"
                    )
        names = [a.name for a in h.actions]
        if len(set(names)) != len(names):
            twice = next(name for name in names if names.count(name) > 1)
            raise self.broken(f"header field actions: two actions are named {twice!r}")
        for j, part in enumerate(h.parts):
            if len(set(part.values)) != len(part.values):
                raise self.broken(f"header field parts[{j}].values: a value is listed twice")
            for alias, w in part.aliases.items():
                if not 0 <= w < len(part.values):
                    raise self.broken(
                        f"header field parts[{j}].aliases.{alias}: {w} is not one of the {len(part.values)} values"
                    )
        observations = 0
        for i, action in enumerate(h.actions):
            if action.transition != (action.kind == "actuation"):
                has = "has" if action.transition else "has no"
                raise self.broken(f"header field actions[{i}]: a {action.kind} action that {has} transition table")
            for k, j in enumerate(action.parts):
                if not 0 <= j < len(h.parts):
                    raise self.broken(f"header field actions[{i}].parts[{k}]: no part {j} (there are {len(h.parts)})")
            if len(set(action.parts)) != len(action.parts):
                raise self.broken(f"header field actions[{i}].parts: a part is listed twice")
            observations += math.prod(len(h.parts[j].values) for j in action.parts)
        limits.MODEL_ENTRIES.check(n * observations, f"{self.archive.path}: {n:,} states")

    def _keys(self) -> list[str]:
        h = self.header
        keys = [f"part{j}_{what}" for j in range(len(h.parts)) for what in ("truth", "confusion")]
        keys += [f"action{i}_{what}" for i, a in enumerate(h.actions) if a.transition for what in _CSR]
        if h.grid is not None:
            keys.append("grid_free")
            if h.version >= 2:
                keys.append("grid_landmarks")
        return keys

    # --- the arrays ----------------------------------------------------------------------------
    def _grid(self) -> GridLayout | None:
        g = self.header.grid
        if g is None:
            return None
        free = self.archive.array("grid_free", "biu", (g.rows, g.cols))
        if free.dtype.kind != "b":
            if free.size and not np.isin(free, (0, 1)).all():
                raise self.broken("array grid_free holds numbers other than 0 and 1")
            free = free.astype(bool)
        if int(free.sum()) * g.headings != self.n:
            raise self.broken(
                f"array grid_free has {int(free.sum()):,} free cells, which with {g.headings} "
                f"heading{'s' if g.headings != 1 else ''} are not the {self.n:,} states of header field n_states"
            )
        frame = MapFrame(g.frame.x, g.frame.y, g.frame.yaw)
        landmarks = tuple(g.landmarks) if self.header.version == 1 else self._landmarks(g)
        return GridLayout(g.rows, g.cols, g.headings, g.cell_size, free, landmarks, frame)

    def _landmarks(self, g: _GridHeader) -> Sequence[Landmark]:
        """Version 2's landmarks: array ``grid_landmarks`` (class index, row, column per object),
        checked against the header's classes and the grid."""
        table = self.archive.integers("grid_landmarks", (None, 3))
        if not table.size:
            return ()
        kinds, rows, cols = table[:, 0], table[:, 1], table[:, 2]
        bad = (kinds < 0) | (kinds >= len(g.landmark_classes))
        if bad.any():
            k = int(np.argmax(bad))
            raise self.broken(
                f"array grid_landmarks[{k}]: class {int(kinds[k])} is not one of the "
                f"{len(g.landmark_classes)} in header field grid.landmark_classes"
            )
        outside = (rows < 0) | (rows >= g.rows) | (cols < 0) | (cols >= g.cols)
        if outside.any():
            k = int(np.argmax(outside))
            raise self.broken(
                f"array grid_landmarks[{k}]: {g.landmark_classes[int(kinds[k])]} at [{int(rows[k])}, {int(cols[k])}] "
                f"is outside the {g.rows}x{g.cols} grid"
            )
        return LandmarkTable(g.landmark_classes, table)

    def _part(self, j: int, meta: _PartHeader) -> ObservationPart:
        values = len(meta.values)
        truth = self.archive.integers(f"part{j}_truth", (self.n,))
        confusion = self.archive.array(f"part{j}_confusion", "f", (None, values)).astype(np.float64, copy=False)
        rows = confusion.shape[0]
        if rows == 0:
            raise self.broken(f"array part{j}_confusion has no rows")
        _check_probabilities(self, f"part{j}_confusion", confusion.ravel())
        sums = confusion.sum(axis=1)
        wrong = np.flatnonzero(np.abs(sums - 1.0) > TOLERANCE)
        if len(wrong):
            v = int(wrong[0])
            raise self.broken(f"array part{j}_confusion: row {v} sums to {sums[v]:.9g}, not 1")
        if truth.size:
            low, high = int(truth.min()), int(truth.max())
            if low < 0 or high >= rows:
                bad = int(np.flatnonzero((truth < 0) | (truth >= rows))[0])
                raise self.broken(
                    f"array part{j}_truth: state {self.state(bad)} has true value {int(truth[bad])}, "
                    f"outside the {rows} rows of part{j}_confusion"
                )
        return ObservationPart(meta.name, tuple(meta.values), truth, confusion, dict(meta.aliases))

    def _transition(self, i: int, name: str) -> sp.csr_matrix:
        n, archive = self.n, self.archive
        indptr = archive.integers(f"action{i}_indptr", (n + 1,))
        nnz = int(indptr[-1])
        if int(indptr[0]) != 0:
            raise self.broken(f"array action{i}_indptr ({name}) starts at {int(indptr[0])}, not 0")
        steps = np.diff(indptr)
        if len(steps) and int(steps.min()) < 0:
            row = int(np.flatnonzero(steps < 0)[0])
            raise self.broken(f"array action{i}_indptr ({name}) decreases at state {self.state(row)}")
        indices = archive.integers(f"action{i}_indices", (nnz,))  # as many as action{i}_indptr says
        if nnz and (int(indices.min()) < 0 or int(indices.max()) >= n):
            k = int(np.flatnonzero((indices < 0) | (indices >= n))[0])
            raise self.broken(
                f"array action{i}_indices ({name}): entry {k} is state {int(indices[k])}, outside the {n:,} states"
            )
        data = archive.array(f"action{i}_data", "f", (nnz,)).astype(np.float64, copy=False)
        _check_probabilities(self, f"action{i}_data ({name})", data)
        sums = self._scratch.get()
        try:
            # each row's sum less 1, in place (|s - 1| > TOLERANCE, without two temporaries of n floats)
            deviation = np.subtract(self._row_sums(indptr, indices, data, steps, sums), 1.0, out=sums)
            wrong = np.flatnonzero((deviation > TOLERANCE) | (deviation < -TOLERANCE))
            if len(wrong):
                row = int(wrong[0])
                raise self.broken(
                    f"array action{i}_data ({name}): the probabilities of the next states from state "
                    f"{self.state(row)} sum to {1.0 + deviation[row]:.9g}, not 1"
                )
        finally:
            self._scratch.put(sums)
        return sp.csr_matrix((data, indices, indptr), shape=(n, n))

    def _row_sums(
        self, indptr: np.ndarray, indices: np.ndarray, data: np.ndarray, steps: np.ndarray, out: np.ndarray
    ) -> np.ndarray:
        """``out``: each row's sum of a transition whose ``indptr`` starts at 0 and never decreases, whose last
        entry is the length of ``indices`` and ``data``, and whose ``indices`` are states (checked before).

        SciPy's row-by-row product kernel against a vector of ones: each row's entries added from 0 in
        their order (``1.0 * p`` is ``p``), one pass over the arrays; the sums of reduceat within an ulp
        (it adds a row's first entry last), the same for rows of up to two entries. ``np.add.reduceat`` paid per row:
        69 against 21 ms a move at 10^7 states (0.2 s of reading that model). The ones, and ``out``, are
        vectors for every move, not fresh memory for each. Without the kernel (another SciPy)
        or for other types: reduceat over the rows that start before the end (those after are empty; the
        last row before them ends at the end), every empty row's sum then set to 0; the end searched for
        as a value of the index type (a Python int converted the whole index array first: 0.1 s at 10^7)."""
        n = self.n
        if (
            _csr_matvec is not None
            and data.dtype == np.float64
            and indptr.dtype == indices.dtype
            and indptr.dtype in (np.int32, np.int64)
            and indptr.flags.c_contiguous
            and indices.flags.c_contiguous
            and data.flags.c_contiguous
        ):
            assert self._ones is not None  # made with the scratch vectors
            out.fill(0.0)
            _csr_matvec(n, n, indptr, indices, data, self._ones, out)
            return out
        nnz = len(data)
        out.fill(0.0)
        starting = int(np.searchsorted(indptr[:-1], indptr.dtype.type(nnz)))
        if starting:
            out[:starting] = np.add.reduceat(data, indptr[:starting])
        out[steps == 0] = 0.0
        return out


_CSR = ("indptr", "indices", "data")


def _check_probabilities(reader: _ModelReader, name: str, values: np.ndarray) -> None:
    if not values.size or (values.min() >= 0.0 and values.max() <= 1.0):  # NaN fails both
        return  # two passes without temporaries (a 10^7-state model's 8 arrays: 0.2 -> 0.06 s)
    bad = int(np.flatnonzero(~((values >= 0.0) & (values <= 1.0)))[0])
    raise reader.broken(f"array {name}: entry {bad} is {float(values[bad])!r}, not a probability")
