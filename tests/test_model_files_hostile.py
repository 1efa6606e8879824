"""Hostile model files, macro tables, .pomdp files and belief files, and outputs that must not be
clobbered: every one is refused with one message naming the file and the field (exit 2), never a
traceback, never a crash, never a wrong answer.

* crafted ``.npz`` models (index arrays past the states made scipy write out of bounds: SIGSEGV in
  ``plan``, ``track``, ``simulate``), run through the CLI in a subprocess, so a crash shows as a
  signal rather than taking pytest down;
* every check of a model or macro file (keys, types, shapes, ranges, sums, header fields, sizes
  from the zip directory and the ``.npy`` headers before anything is decompressed);
* stale models and macro tables, from any folder; a map that is gone is a warning;
* ``.pomdp`` declarations too large to allocate, nesting, malformed headers;
* belief files whose probabilities overflow;
* outputs: atomic writes, SIGTERM, stale temporaries, files of another kind.

The small files of ``tests/data/fuzz/npz`` and ``tests/data/fuzz/pomdp`` are a corpus of such
inputs (see the README there); each must be refused by ``beliefloc inspect``.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import time
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from typer.testing import CliRunner

from beliefloc import compile_model, load_map
from beliefloc.cli.app import app
from beliefloc.errors import BeliefFileError, BeliefLocError, LimitError, ModelError
from beliefloc.files.belief_file import load_belief
from beliefloc.files.macro_file import load_macros, read_header, save_macros
from beliefloc.files.model_file import load_model, save_model
from beliefloc.model import Model
from beliefloc.planning.macros import build_macros
from beliefloc.pomdp_format import parse_pomdp, pomdp_text
from beliefloc.source.atomic_write import sweep_stale_temporaries, write_atomically

from .conftest import DATA, MAPS, ROOT

FUZZ = DATA / "fuzz"
Arrays = dict[str, np.ndarray]


# --- helpers -------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def window() -> Model:
    return compile_model(load_map(MAPS / "window-2x2.yaml"))


@pytest.fixture(scope="module")
def kitchen() -> Model:
    return compile_model(load_map(MAPS / "kitchen.yaml"))


@pytest.fixture(scope="module")
def kitchen_arrays(tmp_path_factory: pytest.TempPathFactory, kitchen: Model) -> tuple[dict[str, Any], Arrays]:
    """The header and arrays of a kitchen model file (with no source map, so never stale)."""
    path = tmp_path_factory.mktemp("kitchen") / "k.npz"
    save_model(kitchen, path)
    return _contents(path, source=None)


def _contents(path: Path, **changes: Any) -> tuple[dict[str, Any], Arrays]:
    with np.load(path, allow_pickle=False) as npz:
        arrays = {key: npz[key] for key in npz.files}
    header = json.loads(arrays.pop("header").tobytes())
    header.update(changes)
    return header, arrays


def _write(path: Path, header: dict[str, Any] | str, arrays: Arrays) -> Path:
    """An .npz file of ``arrays`` and a JSON ``header`` (a string: written as it is)."""
    text = header if isinstance(header, str) else json.dumps(header)
    contents = {**arrays, "header": np.frombuffer(text.encode(), dtype=np.uint8)}
    np.savez(path, **contents)  # type: ignore[arg-type]  # allow_pickle: the pickle cases need it
    return path


def _crafted(tmp_path: Path, base: tuple[dict[str, Any], Arrays], change: Callable[[dict[str, Any], Arrays], None]):
    header, arrays = json.loads(json.dumps(base[0])), {k: v.copy() for k, v in base[1].items()}
    change(header, arrays)
    return _write(tmp_path / "crafted.npz", header, arrays)


def _run(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    """``beliefloc ARGS`` in a new process: a crash is a negative return code, not a dead pytest."""
    env = {**os.environ, "COLUMNS": "120"}
    return subprocess.run(
        [sys.executable, "-m", "beliefloc", *args], capture_output=True, text=True, cwd=cwd, env=env, timeout=300
    )


def _refused(result: Any, *fragments: str) -> None:
    output = result.stdout + result.stderr if isinstance(result, subprocess.CompletedProcess) else result.output
    output += "" if isinstance(result, subprocess.CompletedProcess) else result.stderr
    code = result.returncode if isinstance(result, subprocess.CompletedProcess) else result.exit_code
    assert code == 2, f"exit {code}: {output}"
    assert "Traceback" not in output, output
    for fragment in fragments:
        assert fragment in output, output


# --- 1. crafted models through the CLI --------------------------------------------------------------


def _indices_past_the_states(header: dict[str, Any], arrays: Arrays) -> None:
    arrays["action0_indices"] = np.full_like(arrays["action0_indices"], 1_000_000)


def _rows_summing_to_097(header: dict[str, Any], arrays: Arrays) -> None:
    arrays["action0_data"] = arrays["action0_data"] * 0.97


@pytest.mark.slow
@pytest.mark.parametrize(
    "command", [["plan"], ["track", "--belief", "uniform", "forward"], ["simulate", "-n", "1", "--max-steps", "3"]]
)
def test_crafted_index_arrays_are_refused_not_a_crash(tmp_path: Path, kitchen_arrays: Any, command: list[str]) -> None:
    """Indices past the states crashed scipy (SIGSEGV); a row summing to 0.97 gave a belief summing to
    0.97 with exit 0."""
    path = _crafted(tmp_path, kitchen_arrays, _indices_past_the_states)
    _refused(_run(command[0], str(path), *command[1:]), "crafted.npz", "action0_indices", "outside the 36 states")
    path = _crafted(tmp_path, kitchen_arrays, _rows_summing_to_097)
    _refused(_run(command[0], str(path), *command[1:]), "crafted.npz", "action0_data", "sum to 0.97, not 1")


def _empty_row(row: int) -> Callable[[dict[str, Any], Arrays], None]:
    """Transition row ``row`` of action 0 emptied (its entries dropped): its sum is 0."""

    def change(header: dict[str, Any], arrays: Arrays) -> None:
        indptr, indices, data = (arrays[f"action0_{k}"] for k in ("indptr", "indices", "data"))
        start, stop = int(indptr[row]), int(indptr[row + 1])
        arrays["action0_indices"] = np.delete(indices, np.s_[start:stop])
        arrays["action0_data"] = np.delete(data, np.s_[start:stop])
        arrays["action0_indptr"] = np.r_[indptr[: row + 1], indptr[row + 1 :] - (stop - start)].astype(indptr.dtype)

    return change


def _set(key: str, value: Any) -> Callable[[dict[str, Any], Arrays], None]:
    def change(header: dict[str, Any], arrays: Arrays) -> None:
        arrays[key] = value(arrays[key]) if callable(value) else value

    return change


def _header(**fields: Any) -> Callable[[dict[str, Any], Arrays], None]:
    def change(header: dict[str, Any], arrays: Arrays) -> None:
        for dotted, value in fields.items():
            target: Any = header
            *parents, last = dotted.split("__")
            for name in parents:
                target = target[int(name)] if isinstance(target, list) else target[name]
            if isinstance(target, list):
                target[int(last)] = value
            else:
                target[last] = value

    return change


def _negative_index(a: np.ndarray) -> np.ndarray:
    a = a.copy()
    a[3] = -1
    return a


def _decreasing(a: np.ndarray) -> np.ndarray:
    a = a.copy()
    a[5] = a[7]
    return a


def _with_nan(a: np.ndarray) -> np.ndarray:
    a = a.copy()
    a[0] = np.nan
    return a


def _above_one(a: np.ndarray) -> np.ndarray:
    a = a.copy()
    a[0] = 1.5
    return a


def _truth_past_confusion(a: np.ndarray) -> np.ndarray:
    a = a.copy()
    a[4] = 7
    return a


def _drop(key: str) -> Callable[[dict[str, Any], Arrays], None]:
    def change(header: dict[str, Any], arrays: Arrays) -> None:
        del arrays[key]

    return change


def _row0(a: np.ndarray, row: list[int]) -> np.ndarray:
    a = a.copy()
    a[0] = row
    return a


def _version_1(landmark: list[Any]) -> Callable[[dict[str, Any], Arrays], None]:
    """The file as version 1 wrote it (the landmarks in the header), with ``landmark`` among them."""

    def change(header: dict[str, Any], arrays: Arrays) -> None:
        header["version"] = 1
        del header["grid"]["landmark_classes"]
        header["grid"]["landmarks"] = [landmark]
        del arrays["grid_landmarks"]

    return change


def _block_a_cell(header: dict[str, Any], arrays: Arrays) -> None:
    free = arrays["grid_free"].copy()
    free[1, 1] = False
    arrays["grid_free"] = free


CORRUPTIONS: dict[str, tuple[Callable[[dict[str, Any], Arrays], None], str]] = {
    "indices past the states": (_indices_past_the_states, "action0_indices (forward): entry 0 is state 1000000"),
    "negative index": (_set("action0_indices", _negative_index), "entry 3 is state -1"),
    "indptr not from 0": (_set("action0_indptr", lambda a: a + 1), "action0_indptr (forward) starts at 1, not 0"),
    "indptr decreasing": (_set("action0_indptr", _decreasing), "action0_indptr (forward) decreases"),
    "indptr past the entries": (
        _set("action0_indptr", lambda a: np.append(a[:-1], a[-1] + 5).astype(a.dtype)),
        "array action0_indices has shape (60,), expected (65,)",
    ),
    "indptr too short": (_set("action0_indptr", lambda a: a[:-1]), "action0_indptr has shape (36,), expected (37,)"),
    "probability NaN": (_set("action0_data", _with_nan), "action0_data (forward): entry 0 is nan, not a probability"),
    "probability 1.5": (_set("action0_data", _above_one), "entry 0 is 1.5, not a probability"),
    "rows summing to 0.97": (_rows_summing_to_097, "sum to 0.97, not 1"),
    "an empty last row": (_empty_row(35), "from state 2,2,3 sum to 0, not 1"),
    "an empty row in the middle": (_empty_row(7), "sum to 0, not 1"),
    "data as integers": (_set("action0_data", lambda a: a.astype(np.int64)), "holds int64, not floating-point"),
    "truth past the confusion rows": (_set("part0_truth", _truth_past_confusion), "outside the 2 rows"),
    "confusion row not summing to 1": (_set("part4_confusion", lambda a: a * 0.5), "part4_confusion: row 0 sums to"),
    "confusion of other readings": (_set("part4_confusion", lambda a: a[:, :3]), "expected (n, 5)"),
    "truth of other states": (_set("part0_truth", lambda a: a[:30]), "part0_truth has shape (30,), expected (36,)"),
    "n_states differs": (_header(n_states=37), "grid_free has 9 free cells, which with 4 headings are not the 37"),
    "grid free cells differ": (_block_a_cell, "8 free cells, which with 4 headings are not the 36 states"),
    "a missing array": (_drop("part2_truth"), "missing arrays: part2_truth"),
    "an unexpected array": (_set("extra", np.zeros(3)), "unexpected arrays: extra"),
    "a cost that is text": (_header(actions__0__cost="10"), "header field actions[0].cost"),
    "a negative cost": (_header(actions__0__cost=-1.0), "header field actions[0].cost"),
    "a perception action that moves": (_header(actions__4__transition=True), "a perception action that has"),
    "a part that is not there": (_header(actions__4__parts=[0, 9]), "actions[4].parts[1]: no part 9"),
    "two actions named alike": (_header(actions__1__name="forward"), "two actions are named 'forward'"),
    "an alias past the values": (_header(parts__0__aliases={"seen": 5}), "parts[0].aliases.seen: 5 is not one"),
    "a landmark off the grid": (_set("grid_landmarks", lambda a: _row0(a, [0, 9, 9])), "at [9, 9] is outside the 3x3"),
    "a landmark of no class": (_set("grid_landmarks", lambda a: _row0(a, [7, 0, 0])), "grid_landmarks[0]: class 7"),
    "landmarks as floats": (_set("grid_landmarks", lambda a: a.astype(np.float64)), "holds float64, not integers"),
    "landmarks of two columns": (_set("grid_landmarks", lambda a: a[:, :2]), "expected (n, 3)"),
    "landmarks in a version 2 header": (
        _header(grid__landmarks=[["chair", 0, 0]]),
        "grid.landmarks: a version 2 model keeps them in array grid_landmarks",
    ),
    "a version 1 landmark off the grid": (_version_1(["chair", 9, 9]), "chair at [9, 9] is outside the 3x3"),
    "no grid nor names": (_header(grid=None), "neither a grid nor state names"),
    "a grid of text": (_header(grid__rows="3"), "header field grid.rows"),
    "a source without a hash": (_header(source={"path": "/x.yaml", "sha256": "nope"}), "header field source.sha256"),
    "n_states zero": (_header(n_states=0), "header field n_states"),
}


@pytest.mark.parametrize("name", list(CORRUPTIONS))
def test_every_corruption_is_named(tmp_path: Path, kitchen_arrays: Any, name: str) -> None:
    change, fragment = CORRUPTIONS[name]
    path = _crafted(tmp_path, kitchen_arrays, change)
    with pytest.raises(ModelError) as caught:
        load_model(path)
    message = str(caught.value)
    assert message.startswith(f"{path}: broken beliefloc model file: "), message
    assert fragment in message, message
    assert "rebuild it with 'beliefloc build" in message


@pytest.mark.parametrize("side_by_side", [False, True])
def test_moves_checked_side_by_side_name_the_first_broken_one(
    tmp_path: Path, kitchen_arrays: Any, kitchen: Model, monkeypatch: pytest.MonkeyPatch, side_by_side: bool
) -> None:
    """A large model's moves are read and checked on the thread pool; a file whose later moves are broken
    in two ways is refused naming the first of them, as when they are checked one after the other, and a
    sound file reads into the same model either way (stored and mapped, so the checksums run there too)."""
    from beliefloc.files import model_file

    monkeypatch.setattr(model_file, "_THREADED_FROM", 0 if side_by_side else 10**12)
    moves = [i for i, action in enumerate(kitchen.actions) if action.transition is not None]
    assert len(moves) >= 3
    first, second = moves[1], moves[2]

    def break_two(header: dict[str, Any], arrays: Arrays) -> None:
        arrays[f"action{first}_data"] = arrays[f"action{first}_data"] * 0.97
        arrays[f"action{second}_indices"] = np.full_like(arrays[f"action{second}_indices"], 1_000_000)

    named = rf"array action{first}_data \(\w+\): the probabilities .* sum to 0\.97, not 1"
    with pytest.raises(ModelError, match=named):
        load_model(_crafted(tmp_path, kitchen_arrays, break_two))
    sound = tmp_path / "sound.npz"
    save_model(kitchen, sound, compress=False)
    assert load_model(sound, check_source=False).fingerprint() == kitchen.fingerprint()


def test_the_corruptions_exit_2_through_the_cli(runner: CliRunner, tmp_path: Path, kitchen_arrays: Any) -> None:
    for name, (change, fragment) in CORRUPTIONS.items():
        path = _crafted(tmp_path, kitchen_arrays, change)
        result = runner.invoke(app, ["inspect", str(path)])
        assert result.exit_code == 2, (name, result.output)
        assert fragment in result.stderr and "Traceback" not in result.output, (name, result.stderr)


def test_a_pickled_array_is_never_loaded(tmp_path: Path, kitchen_arrays: Any) -> None:
    """Object arrays need pickle, which runs code: refused from the .npy header, and numpy's
    'allow_pickle' hint never reaches the user."""
    path = _crafted(tmp_path, kitchen_arrays, _set("part0_truth", np.array([{"x": 1}] * 36, dtype=object)))
    with pytest.raises(ModelError, match=r"part0_truth holds Python objects") as caught:
        load_model(path)
    assert "allow_pickle" not in str(caught.value)


def test_an_array_announcing_a_huge_shape_is_refused_before_allocating(tmp_path: Path, kitchen_arrays: Any) -> None:
    """A .npy header may claim 10^12 entries over a few bytes: the claim is checked against the
    member's size in the zip directory before anything is allocated."""
    header, arrays = kitchen_arrays
    path = _write(tmp_path / "huge.npz", header, arrays)
    member = io.BytesIO()
    np.lib.format.write_array_header_1_0(member, {"descr": "<f8", "fortran_order": False, "shape": (10**12,)})
    member.write(b"\0" * 64)
    _replace_member(path, "action0_data.npy", member.getvalue())
    with pytest.raises(ModelError, match=r"array action0_data has shape \(1000000000000,\), expected \(60,\)"):
        load_model(path)
    member = io.BytesIO()
    np.lib.format.write_array_header_1_0(member, {"descr": "|u1", "fortran_order": False, "shape": (10**12,)})
    member.write(b"{}")
    _replace_member(path, "header.npy", member.getvalue())
    with pytest.raises(ModelError, match=r"array header: its header announces 1,000,000,000,000 bytes"):
        load_model(path)


def _replace_member(path: Path, name: str, data: bytes) -> None:
    with zipfile.ZipFile(path) as old:
        members = {info.filename: old.read(info) for info in old.infolist()}
    members[name] = data
    with zipfile.ZipFile(path, "w") as new:
        for member, content in members.items():
            new.writestr(member, content)


def test_sizes_are_checked_from_the_zip_directory(
    tmp_path: Path, kitchen_arrays: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A zip bomb (50 MB of zeros in a few kB) is refused from the sizes its directory declares."""
    header, arrays = kitchen_arrays
    path = _write(tmp_path / "bomb.npz", header, arrays)
    with zipfile.ZipFile(path, "a", compression=zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("padding.npy", b"\0" * 50_000_000)
    assert path.stat().st_size < 1_000_000
    monkeypatch.setenv("BELIEFLOC_MAX_MODEL_BYTES", "10000000")
    with pytest.raises(LimitError, match=r"bomb\.npz: 50,0\d\d,\d\d\d bytes .* BELIEFLOC_MAX_MODEL_BYTES"):
        load_model(path)
    monkeypatch.setenv("BELIEFLOC_MAX_MODEL_ARRAYS", "5")
    with pytest.raises(LimitError, match=r"arrays in a model or macro file.*BELIEFLOC_MAX_MODEL_ARRAYS"):
        load_model(path)


def test_a_model_too_large_for_its_observations_is_refused(
    tmp_path: Path, kitchen_arrays: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    header, arrays = kitchen_arrays
    path = _write(tmp_path / "k.npz", header, arrays)
    monkeypatch.setenv("BELIEFLOC_MAX_MODEL_ENTRIES", "100")
    with pytest.raises(LimitError, match=r"36 states: .* states × observations .*BELIEFLOC_MAX_MODEL_ENTRIES"):
        load_model(path)


def test_big_endian_and_narrow_types_still_load(tmp_path: Path, kitchen_arrays: Any, kitchen: Model) -> None:
    """Arrays of another byte order or width are numbers all the same."""
    header, arrays = kitchen_arrays
    changed = {k: (v.astype(v.dtype.newbyteorder(">")) if v.dtype.kind == "f" else v) for k, v in arrays.items()}
    changed["part0_truth"] = arrays["part0_truth"].astype(np.uint8)
    model = load_model(_write(tmp_path / "k.npz", header, changed))
    assert model.n_states == 36
    for a, b in zip(model.actions, kitchen.actions, strict=True):
        assert a.name == b.name and a.cost == b.cost
    np.testing.assert_array_equal(model.actions[0].transition.toarray(), kitchen.actions[0].transition.toarray())


@pytest.mark.parametrize(
    ("text", "fragment"),
    [
        ("[" * 100_000 + "]" * 100_000, "its header is not a JSON object"),
        ('{"format": "beliefloc-model", "version": 1, "n_states": NaN}', "header field"),
        ("not json", "its header is not a JSON object"),
        ('{"format": "something-else"}', "its header says format 'something-else'"),
    ],
)
def test_a_malformed_header_is_named(tmp_path: Path, kitchen_arrays: Any, text: str, fragment: str) -> None:
    path = _write(tmp_path / "h.npz", text, kitchen_arrays[1])
    with pytest.raises(ModelError, match=r"h\.npz") as caught:
        load_model(path)
    assert fragment in str(caught.value)


def test_an_archive_of_other_arrays_is_not_a_model(runner: CliRunner, tmp_path: Path) -> None:
    path = tmp_path / "x.npz"
    np.savez(path, a=np.zeros(2), b=np.ones(3))
    with pytest.raises(ModelError, match=r"^.*x\.npz is not a beliefloc model \(it holds arrays: a, b\)$"):
        load_model(path)
    _refused(runner.invoke(app, ["plan", str(path)]), "x.npz is not a beliefloc model (it holds arrays: a, b)")
    with pytest.raises(ModelError, match=r"x\.npz is not a beliefloc macro table \(it holds arrays: a, b\)"):
        read_header(path)


@pytest.mark.parametrize("content", [b"", b"not a zip", b"PK\x03\x04garbage", b"PK\x05\x06" + b"\0" * 18])
def test_not_an_archive_at_all(tmp_path: Path, content: bytes) -> None:
    path = tmp_path / "x.npz"
    path.write_bytes(content)
    with pytest.raises(ModelError, match=r"x\.npz:? (is )?not a beliefloc model"):  # an empty zip holds no arrays
        load_model(path)


def test_a_folder_or_a_missing_file(tmp_path: Path) -> None:
    (tmp_path / "d.npz").mkdir()
    with pytest.raises(ModelError, match=r"d\.npz: is a folder, not a beliefloc model file"):
        load_model(tmp_path / "d.npz")
    with pytest.raises(ModelError, match=r"m\.npz: no such file"):
        load_model(tmp_path / "m.npz")


def test_a_macro_table_for_a_model_and_a_model_for_a_macro_table(
    runner: CliRunner, tmp_path: Path, kitchen: Model
) -> None:
    model, macros = tmp_path / "k.npz", tmp_path / "k-macros.npz"
    save_model(kitchen, model)
    save_macros(build_macros(kitchen), macros, model=kitchen)
    _refused(runner.invoke(app, ["plan", str(macros)]), f"{macros} is a macro table, not a compiled model")
    _refused(
        runner.invoke(app, ["simulate", str(MAPS / "kitchen.yaml"), "--macros", str(model), "-n", "1"]),
        f"{model} is a compiled model, not a macro table",
    )
    _refused(runner.invoke(app, ["macros", "show", str(model)]), "is a compiled model, not a macro table")


# --- 2. macro tables ------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def kitchen_macros(tmp_path_factory: pytest.TempPathFactory, kitchen: Model) -> tuple[dict[str, Any], Arrays]:
    path = tmp_path_factory.mktemp("macros") / "m.npz"
    save_macros(build_macros(kitchen), path, model=kitchen)
    return _contents(path)


def _cycle(a: np.ndarray) -> np.ndarray:
    a = a.copy()
    a[0] = 0  # macro 0 followed by itself: following it would never end
    return a


MACRO_CORRUPTIONS: dict[str, tuple[Callable[[dict[str, Any], Arrays], None], str]] = {
    "a pair past the states": (_set("pair_j", lambda a: a + 100), "pair_j: entry 0 is"),
    "pairs out of order": (_set("pair_i", lambda a: a[::-1].copy()), "pair_i"),
    "a macro following itself": (_set("macro_next", _cycle), "macro_next: macro 0 is followed by 0"),
    "an action past the actions": (_set("macro_first", lambda a: a + 50), "macro_first: entry 0 is"),
    "a NaN cost": (_set("cost", lambda a: np.full_like(a, np.nan)), "array cost"),
    "lengths that do not count down": (_set("length", lambda a: a + 1), "array length"),
    "a pair pointing past the pairs": (_set("next_pair", lambda a: a + 10_000), "next_pair: entry"),
    "a missing array": (_drop("macro_id"), "missing arrays: macro_id"),
    "gamma above 1": (_header(gamma=2.0), "header field gamma"),
    "states as text": (_header(n_states="36"), "header field n_states"),
}


@pytest.mark.parametrize("name", list(MACRO_CORRUPTIONS))
def test_every_macro_corruption_is_named(tmp_path: Path, kitchen_macros: Any, kitchen: Model, name: str) -> None:
    change, fragment = MACRO_CORRUPTIONS[name]
    path = _crafted(tmp_path, kitchen_macros, change)
    with pytest.raises(ModelError) as caught:
        load_macros(path, kitchen)
    message = str(caught.value)
    assert message.startswith(f"{path}: broken beliefloc macro file: ") and fragment in message, message


def test_a_macro_table_for_another_map_is_not_called_stale(tmp_path: Path, kitchen: Model) -> None:
    path = tmp_path / "m.npz"
    save_macros(build_macros(kitchen), path, model=kitchen)
    hallway = compile_model(load_map(MAPS / "hallway.yaml"))
    with pytest.raises(ModelError, match=r"macro table for another map: it was built for .*kitchen\.yaml") as caught:
        load_macros(path, hallway)
    assert "stale" not in str(caught.value)


def test_a_macro_table_of_an_edited_map_is_stale(runner: CliRunner, tmp_path: Path) -> None:
    shutil.copy(MAPS / "kitchen.yaml", tmp_path / "kitchen.yaml")
    table = tmp_path / "m.npz"
    assert runner.invoke(app, ["macros", "build", str(tmp_path / "kitchen.yaml"), "-o", str(table)]).exit_code == 0
    text = (tmp_path / "kitchen.yaml").read_text()
    edited = text.replace("cost: 10", "cost: 11", 1)
    assert edited != text
    (tmp_path / "kitchen.yaml").write_text(edited)
    result = runner.invoke(app, ["select", str(tmp_path / "kitchen.yaml"), "--macros", str(table)])
    _refused(result, "stale macro table", "kitchen.yaml before it changed", "rebuild it with 'beliefloc macros build")


# --- 3. stale models ------------------------------------------------------------------------------


def test_a_stale_model_is_found_from_another_folder(tmp_path: Path) -> None:
    """The model records its map's absolute path: built with a relative path in one folder, it is
    checked from any other."""
    work = tmp_path / "work"
    work.mkdir()
    shutil.copy(MAPS / "window-2x2.yaml", work / "window.yaml")
    assert _run("build", "window.yaml", "-o", "w.npz", cwd=work).returncode == 0
    header, _ = _contents(work / "w.npz")
    assert header["source"]["path"] == str((work / "window.yaml").resolve())
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    assert _run("inspect", str(work / "w.npz"), cwd=elsewhere).returncode == 0
    (work / "window.yaml").write_text((work / "window.yaml").read_text().replace("0.1", "0.05"))
    _refused(_run("inspect", str(work / "w.npz"), cwd=elsewhere), "stale model", "window.yaml has changed")


def test_a_model_whose_map_is_gone_is_a_warning(runner: CliRunner, tmp_path: Path, window: Model) -> None:
    shutil.copy(MAPS / "window-2x2.yaml", tmp_path / "window.yaml")
    model = compile_model(load_map(tmp_path / "window.yaml"))
    save_model(model, tmp_path / "w.npz")
    (tmp_path / "window.yaml").unlink()
    warnings: list[str] = []
    assert load_model(tmp_path / "w.npz", on_warning=warnings.append).n_states == 4
    assert len(warnings) == 1 and "cannot check whether the model is stale" in warnings[0]
    assert "window.yaml, is not there any more" in warnings[0]
    result = runner.invoke(app, ["inspect", str(tmp_path / "w.npz")])
    assert result.exit_code == 0 and "warning:" in result.stderr and "cannot check" in result.stderr


def test_a_map_moved_with_its_model_is_still_checked(tmp_path: Path) -> None:
    """Model and map moved together: the map beside the model, of the very same content, counts."""
    first, second = tmp_path / "first", tmp_path / "second"
    first.mkdir()
    shutil.copy(MAPS / "window-2x2.yaml", first / "window.yaml")
    save_model(compile_model(load_map(first / "window.yaml")), first / "w.npz")
    first.rename(second)
    warnings: list[str] = []
    load_model(second / "w.npz", on_warning=warnings.append)
    assert warnings == []
    (second / "window.yaml").write_text((second / "window.yaml").read_text() + "# edited\n")
    load_model(second / "w.npz", on_warning=warnings.append)
    assert len(warnings) == 1 and "beside the model, has the same name but other content" in warnings[0]


# --- 4. .pomdp files ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "fragment"),
    [
        ("states: 1000000000\nactions: 1\nobservations: 1\n", "f.pomdp:1: states: 1,000,000,000 states is more"),
        ("states: 2\nactions: 1000000000\nobservations: 1\n", "f.pomdp:2: actions: 1,000,000,000 actions"),
        ("states: 2\nactions: 1\nobservations: 1000000000\n", "f.pomdp:3: observations: 1,000,000,000"),
        ("states: " + "9" * 5000 + "\n", "a count of 5,000 digits"),
        ("states: 100000\nactions: 1\nobservations: 5000\nT: 0\nidentity\n", "100,000 states × 5,000 observations"),
        ("states: 20000\nactions: 3\nobservations: 1\nT: * : * : * 0.00005\n", "f.pomdp:4: the T: and O: statements"),
        ("states: 12000\nactions: 1\nobservations: 1\nT: 0\nuniform\n", "144,000,000 entries"),
        ("# beliefloc-grid " + "[" * 100_000 + "\nstates: 2\n", "f.pomdp:1: beliefloc-grid: 100,000 levels of nesting"),
    ],
)
def test_pomdp_sizes_are_refused_before_allocating(text: str, fragment: str) -> None:
    with pytest.raises(LimitError) as caught:
        parse_pomdp(text, "f.pomdp")
    assert fragment in str(caught.value)
    assert "BELIEFLOC_MAX_" in str(caught.value)


@pytest.mark.parametrize(
    ("text", "fragment"),
    [
        ("states: ²\n", "'²' is not a valid name"),
        ("states: 2\nactions: 1\nobservations: 1\nT: 0 : ² : 0 1.0\n", "unknown state '²'"),
        ("states: 2\nactions: 1\nobservations: 1\nT: 0 : " + "9" * 5000 + " : 0 1.0\n", "(5,000 digits) is out of"),
        ('# beliefloc-grid {"rows": 1, "cols": 2, "headings": 1, "cell_size": Infinity}\n', "Infinity is not a"),
        ('# beliefloc-grid {"rows": true, "cols": 2, "headings": 1, "cell_size": 1}\n', "positive integers"),
        ("# beliefloc-model " + "[" * 50 + "]" * 50 + "\n", "beliefloc-model: expected a JSON string"),
    ],
)
def test_pomdp_malformed_headers_are_named(text: str, fragment: str) -> None:
    with pytest.raises(ModelError) as caught:
        parse_pomdp(text, "f.pomdp")
    assert fragment in str(caught.value)


_WEIRD = [
    "²",
    "٣",
    "9" * 5000,
    "1e999",
    "nan",
    "inf",
    "-1",
    "0",
    "*",
    ":",
    "uniform",
    "identity",
    "reset",
    "start",
    "include",
    "1000000000",
    "-",
    "{",
    "[" * 200,
    "\x00",
    '# beliefloc-grid {"rows": 1e999, "cols": 1, "headings": 1, "cell_size": 1}',
    '# beliefloc-action {"action": "x", "kind": "perception", "observations": [], "aliases": []}',
    "# beliefloc-name state s0 " + "[" * 3000,
]


def test_pomdp_mutations_never_raise_anything_else() -> None:
    """Random edits of two files (the tiger by hand, an export): a ModelError or LimitError each."""
    texts = [
        (DATA / "pomdp" / "tiger.pomdp").read_text(),
        pomdp_text(compile_model(load_map(MAPS / "window-2x2.yaml"))),
    ]
    rng = random.Random(7)
    for text in texts:
        lines = text.split("\n")
        for _ in range(400):
            edited = list(lines)
            for _ in range(rng.randint(1, 3)):
                i = rng.randrange(len(edited))
                tokens = edited[i].split(" ")
                tokens[rng.randrange(len(tokens))] = rng.choice(_WEIRD)
                edited[i] = " ".join(tokens)
            with contextlib.suppress(BeliefLocError):  # anything else fails the test
                parse_pomdp("\n".join(edited), "f.pomdp")


# --- 5. belief files ------------------------------------------------------------------------------


def test_probabilities_that_overflow_name_their_line(tmp_path: Path, window: Model) -> None:
    path = tmp_path / "b.yaml"
    path.write_text('"0,0": 1e308\n"0,1": 1e308\n')
    with pytest.raises(BeliefFileError, match=r"b\.yaml:2:8: 0,1: the probabilities add up to more than 1\.798e\+308"):
        load_belief(window, path)
    path.write_text('"0,0": 1e308\n"1,1": 0.5\n')
    belief, warnings = load_belief(window, path)  # large but finite: normalised
    assert np.isfinite(belief).all() and abs(belief.sum() - 1.0) < 1e-12 and warnings


@pytest.mark.parametrize("text", ["{}\n", '"0,0": 0\n', '"0,0": .inf\n', '"0,0": .nan\n', '"0,0": 1e999\n'])
def test_a_belief_without_finite_mass_is_an_error_with_a_line(tmp_path: Path, window: Model, text: str) -> None:
    path = tmp_path / "b.yaml"
    path.write_text(text)
    with pytest.raises(BeliefFileError, match=r"b\.yaml:1:\d+: "):
        load_belief(window, path)


# --- 6. outputs -----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (["build", "{map}", "-o", "/nonexistent/x.npz"], "the folder /nonexistent does not exist"),
        (["macros", "build", "{map}", "-o", "/nonexistent/dir/x.npz"], "the folder /nonexistent/dir does not exist"),
        (["macros", "build", "{map}", "-o", "/nonexistent/dir/x"], "unknown kind of file; expected one of: .npz"),
        (["macros", "build", "{map}", "-o", "{tmp}/folder.npz"], "is a folder"),
        (["macros", "build", "{map}", "-o", "{map}"], "unknown kind of file"),
        (["macros", "build", "{map}", "-o", "{model}"], "is a compiled model, not a macro table"),
        (["build", "{map}", "-o", "{macros}"], "is a macro table, not a compiled model"),
        (["build", "{map}", "-o", "{other}"], "an .npz archive that beliefloc did not write, not a compiled model"),
        (["export", "{map}", "-o", "{tmp}/folder.npz"], "must end in .pomdp"),
        (["macros", "show", "{macros}", "-o", "{tmp}/belief.png"], None),
    ],
)
def test_outputs_are_checked_before_any_work(runner: CliRunner, tmp_path: Path, args: list[str], fragment: str | None):
    shutil.copy(MAPS / "kitchen.yaml", tmp_path / "kitchen.yaml")
    kitchen = compile_model(load_map(tmp_path / "kitchen.yaml"))
    save_model(kitchen, tmp_path / "k.npz")
    save_macros(build_macros(kitchen), tmp_path / "m.npz", model=kitchen)
    np.savez(tmp_path / "other.npz", data=np.arange(3))
    (tmp_path / "folder.npz").mkdir()
    (tmp_path / "belief.png").mkdir()
    names = {"map": "kitchen.yaml", "model": "k.npz", "macros": "m.npz", "other": "other.npz"}
    words = [a.format(tmp=tmp_path, **{k: tmp_path / v for k, v in names.items()}) for a in args]
    before = {p: p.read_bytes() for p in tmp_path.iterdir() if p.is_file()}
    result = runner.invoke(app, words)
    _refused(result, *([fragment] if fragment else []))
    assert {p: p.read_bytes() for p in tmp_path.iterdir() if p.is_file()} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([*names.values(), "folder.npz", "belief.png"])


def test_an_output_of_the_same_kind_is_replaced(runner: CliRunner, tmp_path: Path) -> None:
    out = tmp_path / "k.npz"
    for _ in range(2):
        result = runner.invoke(app, ["build", str(MAPS / "kitchen.yaml"), "-o", str(out)])
        assert result.exit_code == 0, result.output
    table = tmp_path / "m.npz"
    for _ in range(2):
        result = runner.invoke(app, ["macros", "build", str(MAPS / "kitchen.yaml"), "-o", str(table)])
        assert result.exit_code == 0, result.output
    assert load_model(out).n_states == 36 and read_header(table)[0]["n_states"] == 36


def test_a_hard_link_to_the_input_is_the_input(runner: CliRunner, tmp_path: Path) -> None:
    shutil.copy(MAPS / "kitchen.yaml", tmp_path / "kitchen.yaml")
    save_model(compile_model(load_map(tmp_path / "kitchen.yaml")), tmp_path / "k.npz")
    os.link(tmp_path / "k.npz", tmp_path / "same.npz")
    before = (tmp_path / "k.npz").read_bytes()
    result = runner.invoke(app, ["build", str(tmp_path / "k.npz"), "-o", str(tmp_path / "same.npz")])
    _refused(result, "is an input of the command")
    assert (tmp_path / "k.npz").read_bytes() == before


def test_a_write_error_is_a_message(runner: CliRunner, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def full(*args: object, **kwargs: object) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(np, "savez_compressed", full)
    result = runner.invoke(app, ["build", str(MAPS / "kitchen.yaml"), "-o", str(tmp_path / "k.npz")])
    _refused(result, "cannot write the model (No space left on device)")
    assert list(tmp_path.iterdir()) == []


def test_stale_temporaries_are_swept_at_the_next_write(tmp_path: Path, window: Model) -> None:
    old, young = tmp_path / ".w.npz.abcd1234.tmp", tmp_path / ".w.npz.efgh5678.tmp"
    other, notes = tmp_path / ".v.npz.abcd1234.tmp", tmp_path / ".w.npz.notes.tmp"
    for path in (old, young, other, notes):
        path.write_bytes(b"left over")
    hours_ago = time.time() - 2 * 3600
    for path in (old, other, notes):
        os.utime(path, (hours_ago, hours_ago))
    save_model(window, tmp_path / "w.npz")
    assert not old.exists()
    assert young.exists() and other.exists() and notes.exists()  # too young, another output, not ours
    assert sweep_stale_temporaries(tmp_path / "w.npz", older_than=0) == [young]


_WRITER = """
import sys, time
from pathlib import Path
from beliefloc.source.atomic_write import write_atomically

def write(handle):
    handle.write(b"half a file")
    handle.flush()
    Path(sys.argv[2]).write_text("writing")
    while True:
        time.sleep(0.01)

write_atomically(Path(sys.argv[1]), write)
"""


@pytest.mark.skipif(not hasattr(signal, "SIGTERM") or sys.platform == "win32", reason="POSIX signals")
def test_sigterm_during_a_write_removes_the_temporary(tmp_path: Path) -> None:
    out, ready = tmp_path / "out" / "w.npz", tmp_path / "ready"
    out.parent.mkdir()
    process = subprocess.Popen([sys.executable, "-c", _WRITER, str(out), str(ready)], cwd=ROOT)
    try:
        deadline = time.monotonic() + 120  # a bound on waiting, not an assertion on time
        while not ready.exists() and process.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
        assert ready.exists(), "the writer never started writing"
        assert next(p.name for p in out.parent.iterdir()).startswith(".w.npz.")  # the temporary is there
        process.send_signal(signal.SIGTERM)
        assert process.wait(timeout=120) == -signal.SIGTERM  # ended by the signal, as it would have
    finally:
        if process.poll() is None:
            process.kill()
    assert list(out.parent.iterdir()) == []


@pytest.mark.skipif(not hasattr(signal, "SIGTERM") or sys.platform == "win32", reason="POSIX signals")
def test_sigterm_with_a_handler_of_the_program_fails_the_write(tmp_path: Path) -> None:
    """A program with its own SIGTERM handler gets it called; the write fails, nothing is left, and
    the program's handler is in place again."""
    received: list[int] = []
    original = signal.signal(signal.SIGTERM, lambda signum, frame: received.append(signum))
    mine = signal.getsignal(signal.SIGTERM)

    def write(handle: Any) -> None:
        handle.write(b"half")
        os.kill(os.getpid(), signal.SIGTERM)
        for _ in range(1000):  # the handler runs at the next bytecode
            time.sleep(0.001)

    try:
        with pytest.raises(InterruptedError, match="interrupted by signal"):
            write_atomically(tmp_path / "x.bin", write)
        assert received == [signal.SIGTERM]
        assert signal.getsignal(signal.SIGTERM) is mine
    finally:
        signal.signal(signal.SIGTERM, original)
    assert list(tmp_path.iterdir()) == []


def test_a_failed_write_of_any_kind_leaves_nothing(tmp_path: Path) -> None:
    def broken(handle: Any) -> None:
        handle.write(b"half")
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        write_atomically(tmp_path / "x.bin", broken)
    assert list(tmp_path.iterdir()) == []


# --- 7. the corpus --------------------------------------------------------------------------------


def _corpus(kind: str) -> list[Path]:
    return sorted(p for p in (FUZZ / kind).iterdir() if p.suffix == f".{kind}")


def test_the_corpus_is_there() -> None:
    assert len(_corpus("npz")) >= 8 and len(_corpus("pomdp")) >= 6


@pytest.mark.parametrize("path", _corpus("npz") + _corpus("pomdp"), ids=lambda p: p.name)
def test_every_corpus_file_is_refused(runner: CliRunner, path: Path) -> None:
    result = runner.invoke(app, ["inspect", str(path)])
    _refused(result, path.name)


@pytest.mark.parametrize("path", _corpus("npz"), ids=lambda p: p.name)
def test_corpus_models_do_not_crash_a_planner(path: Path) -> None:
    _refused(_run("plan", str(path)), path.name)


# --- 8. random corruption -------------------------------------------------------------------------


def _mutated_array(rng: random.Random, array: np.ndarray) -> np.ndarray:
    choice = rng.random()
    if choice < 0.2:
        return array.astype(rng.choice([np.int8, np.uint64, np.float32, np.int64, np.bool_, np.complex128]))
    if choice < 0.35:
        return array.reshape(-1)[: max(0, array.size - 1)]
    flat = array.copy().reshape(-1)
    if flat.size:
        i = rng.randrange(flat.size)
        if flat.dtype.kind == "f":
            flat[i] = rng.choice([np.nan, np.inf, -0.5, 2.0, 1e-300])
        elif flat.dtype.kind == "i":
            flat[i] = rng.choice([-1, min(10**6, np.iinfo(flat.dtype).max), np.iinfo(flat.dtype).max])
        elif flat.dtype.kind == "b":
            flat[i] = not flat[i]
    return flat.reshape(array.shape)


@pytest.mark.parametrize("kind", ["model", "macros"])
def test_random_corruption_is_always_a_model_error(tmp_path: Path, kitchen_arrays: Any, kitchen_macros: Any, kind):
    header, arrays = kitchen_arrays if kind == "model" else kitchen_macros
    rng = random.Random(11)
    raw_values: list[Any] = [-1, 0, 10**12, 1.5, "3", None, True, [], {}, float("inf")]
    path = tmp_path / "r.npz"
    for _ in range(150):
        h, a = json.loads(json.dumps(header)), dict(arrays)
        if rng.random() < 0.4:
            h[rng.choice(list(h))] = rng.choice(raw_values)
        else:
            key = rng.choice(list(a))
            a[key] = _mutated_array(rng, a[key])
        _write(path, json.dumps(h, allow_nan=True), a)
        data = bytearray(path.read_bytes())
        if rng.random() < 0.3:
            for _ in range(3):
                data[rng.randrange(len(data))] = rng.randrange(256)
            path.write_bytes(bytes(data))
        with contextlib.suppress(BeliefLocError):  # anything else fails the test
            if kind == "model":
                load_model(path, check_source=False)
            else:
                read_header(path)
