"""Model files: round trip, stale detection, versions, atomic writes."""

from __future__ import annotations

import dataclasses
import json
import shutil
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from beliefloc import compile_model, load_map, uniform, update
from beliefloc.cli.app import app
from beliefloc.errors import ModelError, OutputError
from beliefloc.files import npz_archive
from beliefloc.files.model_file import load_model, save_model
from beliefloc.model import LandmarkTable

from .conftest import MAPS


@pytest.fixture
def window_copy(tmp_path: Path) -> Path:
    target = tmp_path / "window.yaml"
    shutil.copy(MAPS / "window-2x2.yaml", target)
    return target


def test_round_trip_keeps_every_number(tmp_path: Path, window_copy: Path) -> None:
    model = compile_model(load_map(window_copy))
    save_model(model, tmp_path / "w.npz")
    loaded = load_model(tmp_path / "w.npz")
    assert loaded.fingerprint() == model.fingerprint()
    assert loaded.states.names == model.states.names
    assert loaded.grid is not None and loaded.grid.landmarks == model.grid.landmarks  # type: ignore[union-attr]
    b1, p1 = update(model, uniform(4), "look", "window_seen")
    b2, p2 = update(loaded, uniform(4), "look", "window_seen")
    np.testing.assert_array_equal(b1, b2)
    assert p1 == p2


def test_transitions_keep_the_arrays_read(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The sparse transitions hold the very arrays read from the file: SciPy copies an index array that
    is a view into a larger buffer (as a byte buffer was: 0.6 s for the transitions of 10^7 states)."""
    model = compile_model(load_map(MAPS / "corridors.yaml"))
    save_model(model, tmp_path / "c.npz")
    read: list[np.ndarray] = []
    original = npz_archive.Archive.array

    def recorded(self: npz_archive.Archive, *args: Any, **kwargs: Any) -> np.ndarray:
        array = original(self, *args, **kwargs)
        read.append(array)
        return array

    monkeypatch.setattr(npz_archive.Archive, "array", recorded)
    loaded = load_model(tmp_path / "c.npz", check_source=False)
    moves = [a.transition for a in loaded.actions if a.transition is not None]
    assert moves
    for transition in moves:
        for array in (transition.indptr, transition.indices, transition.data):
            assert any(np.shares_memory(array, source) for source in read)


def test_stale_model_is_refused(tmp_path: Path, window_copy: Path) -> None:
    save_model(compile_model(load_map(window_copy)), tmp_path / "w.npz")
    window_copy.write_text(window_copy.read_text().replace("false_positive: 0.1", "false_positive: 0.05"))
    with pytest.raises(ModelError, match=r"stale model: .*window\.yaml has changed"):
        load_model(tmp_path / "w.npz")
    assert load_model(tmp_path / "w.npz", check_source=False).n_states == 4


def test_a_version_1_file_reads_as_it_did(tmp_path: Path) -> None:
    """Version 1 kept the landmarks in the header; such a file still loads, landmark for landmark."""
    model = compile_model(load_map(MAPS / "kitchen.yaml"))
    assert model.grid is not None and len({cls for cls, _, _ in model.grid.landmarks}) > 1
    path = tmp_path / "k.npz"
    save_model(model, path)
    with np.load(path) as npz:
        arrays = {k: npz[k] for k in npz.files}
    header = json.loads(arrays["header"].tobytes())
    assert header["version"] == 2 and "landmarks" not in header["grid"]
    header["version"] = 1
    del header["grid"]["landmark_classes"]
    header["grid"]["landmarks"] = [list(lm) for lm in model.grid.landmarks]
    del arrays["grid_landmarks"]
    arrays["header"] = np.frombuffer(json.dumps(header).encode(), dtype=np.uint8)
    np.savez(path, **arrays)  # type: ignore[arg-type]
    loaded = load_model(path)
    assert loaded.grid is not None and loaded.grid.landmarks == model.grid.landmarks
    assert loaded.fingerprint() == model.fingerprint()


@given(
    st.lists(
        st.tuples(st.sampled_from(["chair", "door", "sink", "ä"]), st.integers(0, 2), st.integers(0, 2)), max_size=12
    )
)
@settings(max_examples=25, deadline=None)
def test_landmarks_round_trip_in_their_order(landmarks: list[tuple[str, int, int]]) -> None:
    """Version 2's landmark array gives back the very tuples, in order, whatever the classes' order."""
    model = compile_model(load_map(MAPS / "kitchen.yaml"))
    assert model.grid is not None
    grid = dataclasses.replace(model.grid, landmarks=tuple(landmarks))
    model = dataclasses.replace(model, grid=grid)
    with tempfile.TemporaryDirectory() as folder:
        save_model(model, Path(folder) / "m.npz")
        loaded = load_model(Path(folder) / "m.npz")
    assert loaded.grid is not None and loaded.grid.landmarks == tuple(landmarks)
    assert tuple(landmarks) == loaded.grid.landmarks and list(loaded.grid.landmarks) == landmarks
    assert [loaded.grid.landmarks[i] for i in range(len(landmarks))] == landmarks


def test_a_loaded_model_makes_its_landmark_triples_only_when_asked(tmp_path: Path) -> None:
    """Planning never looks at the landmarks: reading a model keeps them as the file's table (a
    10^7-state world's 1.09 million triples took 0.5 s to build)."""
    model = compile_model(load_map(MAPS / "kitchen.yaml"))
    save_model(model, tmp_path / "m.npz")
    loaded = load_model(tmp_path / "m.npz")
    assert loaded.grid is not None and model.grid is not None
    table = loaded.grid.landmarks
    assert len(table) == len(model.grid.landmarks) > 0 and "_triples" not in vars(table)
    assert table == model.grid.landmarks and table[0] == model.grid.landmarks[0]
    assert table != model.grid.landmarks[1:] and table != "not landmarks"


@given(
    st.lists(st.tuples(st.integers(0, 3), st.integers(0, 2), st.integers(0, 2)), max_size=12),
    st.permutations(["chair", "door", "sink", "ä"]),
)
@settings(max_examples=25, deadline=None)
def test_a_landmark_table_is_saved_as_its_triples_would_be(rows: list[tuple[int, int, int]], names: list[str]) -> None:
    """``build MODEL.npz``: a loaded model's landmark table is written without making its triples, and the
    file is the one the triples give (classes in the order they first appear, unused ones left out)."""
    model = compile_model(load_map(MAPS / "kitchen.yaml"))
    assert model.grid is not None
    array = np.array(rows, dtype=np.int32).reshape(-1, 3)
    table = LandmarkTable(names, array)
    triples = tuple(LandmarkTable(names, array))
    with tempfile.TemporaryDirectory() as folder:
        written = {}
        for kind, landmarks in (("table", table), ("triples", triples)):
            grid = dataclasses.replace(model.grid, landmarks=landmarks)
            save_model(dataclasses.replace(model, grid=grid), Path(folder) / f"{kind}.npz")
            with np.load(Path(folder) / f"{kind}.npz") as npz:
                written[kind] = (npz["grid_landmarks"], json.loads(npz["header"].tobytes())["grid"]["landmark_classes"])
    assert "_triples" not in vars(table)  # saving did not make them
    assert np.array_equal(written["table"][0], written["triples"][0])
    assert written["table"][0].dtype == written["triples"][0].dtype
    assert written["table"][1] == written["triples"][1]


def test_other_version_is_refused(tmp_path: Path, window_copy: Path) -> None:
    path = tmp_path / "w.npz"
    save_model(compile_model(load_map(window_copy)), path)
    with np.load(path) as npz:
        arrays = {k: npz[k] for k in npz.files}
    header = json.loads(arrays["header"].tobytes())
    header["version"] = 99
    arrays["header"] = np.frombuffer(json.dumps(header).encode(), dtype=np.uint8)
    np.savez(path, **arrays)  # type: ignore[arg-type]
    with pytest.raises(ModelError, match=r"version 99.*rebuild"):
        load_model(path)


@pytest.mark.parametrize("content", [b"", b"not a zip", b"PK\x03\x04garbage"])
def test_not_a_model_file(tmp_path: Path, content: bytes) -> None:
    path = tmp_path / "x.npz"
    path.write_bytes(content)
    with pytest.raises(ModelError, match="not a beliefloc model file"):
        load_model(path)


def test_failed_write_leaves_no_file(tmp_path: Path, window_copy: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    model = compile_model(load_map(window_copy))

    def broken(*args: object, **kwargs: object) -> None:
        raise OSError("disk full")

    monkeypatch.setattr(np, "savez_compressed", broken)
    with pytest.raises(OutputError, match="disk full"):
        save_model(model, tmp_path / "w.npz")
    assert list(tmp_path.iterdir()) == [window_copy]


def test_build_and_inspect_cli(runner, tmp_path: Path, window_copy: Path) -> None:
    out = tmp_path / "w.npz"
    result = runner.invoke(app, ["build", str(window_copy), "-o", str(out), "--json"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["states"] == 4
    result = runner.invoke(app, ["inspect", str(out), "--json"])
    assert result.exit_code == 0
    summary = json.loads(result.stdout)
    assert [a["name"] for a in summary["actions"]] == ["right", "look"]
    assert summary["actions"][0]["transition_nonzeros"] == 6
    window_copy.write_text(window_copy.read_text() + "\n# edited\n")
    result = runner.invoke(app, ["inspect", str(out)])
    assert result.exit_code == 2
    assert "stale model" in result.stderr


def test_build_refuses_other_suffix(runner, tmp_path: Path) -> None:
    result = runner.invoke(app, ["build", str(MAPS / "window-2x2.yaml"), "-o", str(tmp_path / "w.model")])
    assert result.exit_code == 2
    assert "must end in .npz" in result.stderr
    assert not (tmp_path / "w.model").exists()


def test_written_files_are_readable_by_others(tmp_path: Path, window_copy: Path) -> None:
    """write_atomically must not keep mkstemp's private 0600 mode."""
    import os

    umask = os.umask(0o022)
    try:
        save_model(compile_model(load_map(window_copy)), tmp_path / "w.npz")
    finally:
        os.umask(umask)
    assert (tmp_path / "w.npz").stat().st_mode & 0o777 == 0o644


def _compression(path: Path) -> set[int]:
    import zipfile

    with zipfile.ZipFile(path) as archive:
        return {info.compress_type for info in archive.infolist()}


def _in_a_mapped_file(array: np.ndarray) -> bool:
    """Whether the array's memory is a memory-mapped file's (its chain of bases ends at an mmap)."""
    import mmap

    base: Any = array
    while isinstance(base, np.ndarray) and base.base is not None:
        base = base.base
    return isinstance(base, memoryview) and isinstance(base.obj, mmap.mmap)


def test_uncompressed_model_reads_the_same(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A model stored uncompressed (``compress=False``) is read straight from the file, not through
    zlib, into the same numbers as the compressed file; the file is larger."""
    import zipfile

    model = compile_model(load_map(MAPS / "corridors.yaml"))
    deflated, stored = tmp_path / "deflated.npz", tmp_path / "stored.npz"
    save_model(model, deflated)
    save_model(model, stored, compress=False)
    assert _compression(deflated) == {zipfile.ZIP_DEFLATED}
    assert _compression(stored) == {zipfile.ZIP_STORED}
    assert stored.stat().st_size > deflated.stat().st_size
    direct: list[str] = []
    original = npz_archive.Archive._stored

    def counted(self: npz_archive.Archive, key: str, *args: Any) -> tuple[np.ndarray, memoryview | None]:
        direct.append(key)
        return original(self, key, *args)

    monkeypatch.setattr(npz_archive.Archive, "_stored", counted)
    old = load_model(deflated, check_source=False)
    assert direct == []  # a compressed file: inflated as before
    new = load_model(stored, check_source=False)
    assert "action0_data" in direct and "header" in direct
    assert new.fingerprint() == old.fingerprint() == model.fingerprint()
    # written aligned, so mapped from the file (no copy); the deflated file's arrays are their own
    pairs = zip(old.actions, new.actions, strict=True)
    moves = [(a.transition, b.transition) for a, b in pairs if a.transition is not None]
    assert moves
    for inflated, mapped in moves:
        assert mapped is not None and inflated is not None
        assert _in_a_mapped_file(mapped.data) and _in_a_mapped_file(mapped.indices)
        assert not _in_a_mapped_file(inflated.data)
    # any .npz reader reads the stored file
    with np.load(stored) as npz:
        assert npz["action0_data"].tobytes() == new.actions[0].transition.data.tobytes()  # type: ignore[union-attr]
    for a, b in zip(old.actions, new.actions, strict=True):
        if a.transition is not None:
            assert b.transition is not None
            for name in ("indptr", "indices", "data"):
                x, y = getattr(a.transition, name), getattr(b.transition, name)
                assert x.dtype == y.dtype and x.tobytes() == y.tobytes()
        for p, q in zip(a.observation.parts, b.observation.parts, strict=True):
            assert p.truth.tobytes() == q.truth.tobytes() and p.confusion.tobytes() == q.confusion.tobytes()


def test_uncompressed_model_with_a_changed_bit_is_refused(tmp_path: Path) -> None:
    """A stored array whose bytes changed (one low bit of a probability: still a probability, and the
    row still sums to 1 within the tolerance) is caught by the member's CRC-32, as zipfile would (an
    array of 30 kB: read straight from the file, not by zipfile)."""
    model = compile_model(load_map(MAPS / "tb3-sandbox.yaml"))
    path = tmp_path / "stored.npz"
    save_model(model, path, compress=False)
    transition = next(a.transition for a in model.actions if a.transition is not None)
    raw = bytearray(path.read_bytes())
    at = raw.find(transition.data.tobytes())
    assert at > 0
    raw[at] ^= 1  # the lowest bit of the first probability's mantissa (little-endian)
    path.write_bytes(bytes(raw))
    with pytest.raises(ModelError, match=r"broken .*array action\d_data: its data does not match its checksum"):
        load_model(path, check_source=False)


def test_build_uncompressed_cli(runner, tmp_path: Path, window_copy: Path) -> None:
    import zipfile

    out = tmp_path / "w.npz"
    result = runner.invoke(app, ["build", str(window_copy), "-o", str(out), "--uncompressed", "--json"])
    assert result.exit_code == 0, result.output
    assert _compression(out) == {zipfile.ZIP_STORED}
    plans = []
    for model_file in (out, tmp_path / "z.npz"):
        if model_file != out:
            assert runner.invoke(app, ["build", str(window_copy), "-o", str(model_file)]).exit_code == 0
        result = runner.invoke(app, ["plan", str(model_file), "--json"])
        assert result.exit_code in (0, 1), result.output
        plan = json.loads(result.stdout)
        plan.pop("seconds")
        plans.append(plan)
    assert plans[0] == plans[1]


def test_a_model_stored_by_np_savez_reads_the_same(tmp_path: Path) -> None:
    """A stored archive that another writer made (``np.savez``: no alignment of the data) is read into the
    same numbers, member by member mapped where its data happens to be aligned and read where not."""
    import zipfile

    model = compile_model(load_map(MAPS / "tb3-sandbox.yaml"))
    path = tmp_path / "m.npz"
    save_model(model, path)
    with np.load(path) as npz:
        arrays = {k: npz[k] for k in npz.files}
    np.savez(path, **arrays)  # type: ignore[arg-type]
    assert _compression(path) == {zipfile.ZIP_STORED}
    loaded = load_model(path, check_source=False)
    assert loaded.fingerprint() == model.fingerprint()


@pytest.mark.parametrize("index_type", [np.int32, np.int64])
def test_transition_row_sums_by_scipys_kernel_are_reduceats(index_type, monkeypatch):
    """The row sums a model file's transitions are checked by (SciPy's row-by-row kernel against ones)
    are those of the reduceat code it replaced, empty rows (0) and a last empty run included: the same
    bits for rows of up to two entries, within an ulp for longer ones (reduceat adds a row's first
    entry last); the check allows 1e-6."""
    from beliefloc.files import model_file

    rng = np.random.default_rng(7)
    n = 200
    counts = rng.integers(0, 5, n)
    counts[[0, 57, 58, n - 3, n - 2, n - 1]] = 0
    indptr = np.r_[0, np.cumsum(counts)].astype(index_type)
    nnz = int(indptr[-1])
    indices = rng.integers(0, n, nnz).astype(index_type)
    data = rng.random(nnz)
    steps = np.diff(indptr)

    def sums() -> np.ndarray:
        reader = model_file._ModelReader.__new__(model_file._ModelReader)
        reader.n, reader._ones, out = n, np.ones(n), np.full(n, np.nan)
        first = reader._row_sums(indptr, indices, data, steps, out).copy()
        again = reader._row_sums(indptr, indices, data * 0.5, steps, out)  # the vector reused: zeroed again
        np.testing.assert_allclose(again, first * 0.5, rtol=1e-15)
        return first

    assert model_file._csr_matvec is not None
    by_kernel = sums()
    monkeypatch.setattr(model_file, "_csr_matvec", None)
    by_reduceat = sums()
    np.testing.assert_allclose(by_kernel, by_reduceat, rtol=4e-16, atol=0.0)
    short = steps <= 2
    np.testing.assert_array_equal(by_kernel[short], by_reduceat[short])
    assert by_kernel[[0, 57, 58, n - 1]].tolist() == [0.0] * 4
