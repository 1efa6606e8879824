"""Cassandra's .pomdp format: export, import, round trips, hand-written files, errors, the CLI."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from beliefloc import compile_model, load_map, uniform, update
from beliefloc.belief import observation_probabilities
from beliefloc.cli.app import app
from beliefloc.errors import ModelError
from beliefloc.model import ActionKind, Model
from beliefloc.pomdp_format import (
    RESERVED,
    format_number,
    identifiers,
    parse_pomdp,
    pomdp_text,
    read_pomdp,
    write_pomdp,
)

from .conftest import DATA, MAPS, SMALL_MODEL_STATES

POMDP_DATA = DATA / "pomdp"

RICH_MAP = """\
name: rich
grid: {rows: 4, cols: 5, headings: 4, cell_size: 0.5}
layout: |
  .....
  .#..#
  .....
  ##...
landmarks:
  - {class: chair, cell: [0, 0]}
  - {class: fire_extinguisher, cell: [2, 4]}
  - {class: chair, cell: [3, 2]}
actions:
  forward: {cost: 10, failure: 0.1}
  rotate_cw: {cost: 5, failure: 0.05}
  rotate_ccw: {cost: 5}
sensors:
  look:
    type: look
    cost: 1
    classes: [chair, fire_extinguisher]
    false_positive: 0.05
    false_negative: 0.1
    angle_bins: [18, 30, 45]
  scan:
    type: scan
    cost: 2
    bins: [0.2, 0.8, 1.1]
    error: 0.1
  floor:
    type: here
    labels: |
      aabbb
      a#bb#
      ccccc
      ##ccc
    legend: {a: "0", b: "1", c: tile}
    error: 0.1
    passive: true
    as_action: false
"""


@pytest.fixture(scope="module")
def window() -> Model:
    return compile_model(load_map(MAPS / "window-2x2.yaml"))


@pytest.fixture(scope="module")
def rich(tmp_path_factory: pytest.TempPathFactory) -> Model:
    path = tmp_path_factory.mktemp("maps") / "rich.yaml"
    path.write_text(RICH_MAP)
    return compile_model(load_map(path))


def assert_same_model(original: Model, read: Model) -> None:
    """Same states, actions (names, kinds, costs), T, observation names and O, and grid."""
    assert read.name == original.name
    assert read.states.names == original.states.names
    assert [(a.name, a.kind, a.cost) for a in read.actions] == [(a.name, a.kind, a.cost) for a in original.actions]
    for a, b in zip(original.actions, read.actions, strict=True):
        assert (a.transition is None) == (b.transition is None), a.name
        if a.transition is not None and b.transition is not None:
            np.testing.assert_array_equal(a.transition.toarray(), b.transition.toarray())
        assert b.observation.names() == a.observation.names(), a.name
        np.testing.assert_allclose(
            b.observation.matrix().toarray(), a.observation.matrix().toarray(), rtol=0, atol=1e-12
        )
    if original.grid is None:
        assert read.grid is None
    else:
        assert read.grid is not None
        g, h = original.grid, read.grid
        assert (h.rows, h.cols, h.headings, h.cell_size, h.landmarks) == (
            g.rows,
            g.cols,
            g.headings,
            g.cell_size,
            g.landmarks,
        )
        np.testing.assert_array_equal(h.free, g.free)
        assert read.states.grid is h


# --- round trips -----------------------------------------------------------------------------------


@pytest.mark.parametrize("which", ["window", "rich"])
def test_round_trip_restores_the_model(which: str, request: pytest.FixtureRequest, tmp_path: Path) -> None:
    model: Model = request.getfixturevalue(which)
    out = tmp_path / f"{which}.pomdp"
    summary = write_pomdp(model, out)
    assert summary.states == model.n_states
    assert summary.actions == len(model.actions)
    assert_same_model(model, read_pomdp(out))


@pytest.mark.parametrize("map_file", sorted(MAPS.glob("*.yaml")), ids=lambda p: p.name)
def test_shipped_maps_round_trip(map_file: Path) -> None:
    model = compile_model(load_map(map_file))
    if model.n_states > SMALL_MODEL_STATES:
        pytest.skip(f"{model.n_states} states: the text of every O entry is too long for a unit test")
    assert_same_model(model, parse_pomdp(pomdp_text(model), "shipped.pomdp"))


def test_rich_map_exercises_the_interesting_names(rich: Model) -> None:
    names = {name for action in rich.actions for name in action.observation.names()}
    assert {"chair@0-18+fire_extinguisher@18-30", "wall_0.2-0.8", "0", "tile", "nothing"} <= names
    text = pomdp_text(rich)
    assert "# beliefloc-name observation chair_0-18_fire_extinguisher_18-30 " in text
    assert '# beliefloc-name observation wall_0_2-0_8 "wall_0.2-0.8"' in text
    assert '# beliefloc-name observation o0 "0"' in text
    assert '# beliefloc-name state s0_0_0 "0,0,0"' in text
    assert "# beliefloc-layout .#..#" in text
    assert "# beliefloc-layout ##..." in text


def test_round_trip_of_a_model_without_grid(tmp_path: Path) -> None:
    tiger = read_pomdp(POMDP_DATA / "tiger.pomdp")
    write_pomdp(tiger, tmp_path / "again.pomdp")
    assert_same_model(tiger, read_pomdp(tmp_path / "again.pomdp"))


_EXPORT_SCRIPT = """
import sys
from beliefloc import compile_model, load_map
from beliefloc.pomdp_format import pomdp_text
sys.stdout.buffer.write(pomdp_text(compile_model(load_map(sys.argv[1]))).encode())
"""

WINDOW_EXPORT_SHA256 = "4736e74240b5e2aec46dd252269a8b2115a1fbc48352f7ca385b7b05c468e57d"
"""sha256 of ``pomdp_text`` of maps/window-2x2.yaml, pinned (test_window_export_text reads its lines);
a deliberate change to the export updates it."""


def _export_in_a_new_process(map_path: Path, hash_seed: str) -> bytes:
    """``pomdp_text`` of the map at ``map_path``, computed by a fresh interpreter with ``PYTHONHASHSEED=hash_seed``."""
    env = {**os.environ, "PYTHONHASHSEED": hash_seed}
    result = subprocess.run(
        [sys.executable, "-c", _EXPORT_SCRIPT, str(map_path)], env=env, capture_output=True, timeout=300, check=False
    )
    assert result.returncode == 0, result.stderr.decode()
    return result.stdout


def test_export_is_deterministic(rich: Model, window: Model, tmp_path: Path) -> None:
    """A fresh process under two hash seeds writes this process's bytes (nothing depends on the order
    of a set or on string hashes), and the window map's export is the pinned one."""
    (tmp_path / "rich.yaml").write_text(RICH_MAP)
    expected = pomdp_text(rich).encode()
    for hash_seed in ("0", "4242"):
        assert _export_in_a_new_process(tmp_path / "rich.yaml", hash_seed) == expected
    assert hashlib.sha256(pomdp_text(window).encode()).hexdigest() == WINDOW_EXPORT_SHA256


def test_window_export_text(window: Model) -> None:
    text = pomdp_text(window)
    body = [line for line in text.splitlines() if line and not line.startswith("#")]
    assert body[:6] == [
        "discount: 0.95",
        "values: reward",
        "states: s0_0 s0_1 s1_0 s1_1",
        "actions: right look",
        "observations: none nothing window",
        "start: uniform",
    ]
    assert "T: right : s0_0 : s0_1 0.8" in body
    assert "T: right : s0_1 : s0_1 1.0" in body
    assert body[body.index("T: look") + 1] == "identity"
    assert "O: right : * : none 1.0" in body
    assert "O: look : s1_0 : window 0.8" in body
    assert "R: right : * : * : * -10.0" in body
    assert "R: look : * : * : * -1.0" in body
    assert not any(" 0.0" in line for line in body if line.startswith(("T:", "O:")))  # only non-zeros
    assert "localization has no discount of its own" in text.lower()


def test_without_beliefloc_comments_the_numbers_survive(rich: Model) -> None:
    """Other tools drop our comments: the identifiers become the names, the numbers stay."""
    text = "\n".join(line for line in pomdp_text(rich).splitlines() if not line.startswith("# beliefloc-"))
    read = parse_pomdp(text, "plain.pomdp")
    assert read.name == "plain"
    assert read.grid is None
    assert read.states.names == identifiers(rich.states.names, "s")
    assert [(a.name, a.kind, a.cost) for a in read.actions] == [(a.name, a.kind, a.cost) for a in rich.actions]
    for a, b in zip(rich.actions, read.actions, strict=True):
        if a.transition is not None:
            assert b.transition is not None
            np.testing.assert_array_equal(a.transition.toarray(), b.transition.toarray())
        assert b.observation.names() == identifiers(a.observation.names(), "o")
        np.testing.assert_allclose(b.observation.matrix().toarray(), a.observation.matrix().toarray(), atol=1e-12)


def test_beliefs_agree_after_the_round_trip(rich: Model, tmp_path: Path) -> None:
    write_pomdp(rich, tmp_path / "rich.pomdp")
    read = read_pomdp(tmp_path / "rich.pomdp")
    b1 = b2 = uniform(rich.n_states)
    for action in ["look", "forward", "scan", "rotate_cw", "look"]:
        p1 = observation_probabilities(rich.action(action), b1)
        p2 = observation_probabilities(read.action(action), b2)
        np.testing.assert_allclose(p1, p2, atol=1e-12)
        o = int(np.argmax(p1))  # the most likely observation, by index (same order in both models)
        b1, q1 = update(rich, b1, action, o)
        b2, q2 = update(read, b2, action, o)
        np.testing.assert_allclose(b1, b2, atol=1e-12)
        assert q1 == pytest.approx(q2, abs=1e-12)


def test_observation_names_still_parse(window: Model, tmp_path: Path) -> None:
    write_pomdp(window, tmp_path / "w.pomdp")
    read = read_pomdp(tmp_path / "w.pomdp")
    for text in ["window", "window_seen", "nothing", "window_not_seen"]:
        b1, p1 = update(window, uniform(4), "look", text)
        b2, p2 = update(read, uniform(4), "look", text)
        np.testing.assert_array_equal(b1, b2)
        assert p1 == p2
    b1, _ = update(window, uniform(4), "right", "none")
    b2, _ = update(read, uniform(4), "right", "none")
    np.testing.assert_array_equal(b1, b2)


def test_actuation_without_sensors_has_no_parts(window: Model, tmp_path: Path) -> None:
    write_pomdp(window, tmp_path / "w.pomdp")
    right = read_pomdp(tmp_path / "w.pomdp").action("right")
    assert right.kind is ActionKind.ACTUATION
    assert right.observation.parts == ()


def test_imported_observation_model_shape(window: Model, tmp_path: Path) -> None:
    write_pomdp(window, tmp_path / "w.pomdp")
    look = read_pomdp(tmp_path / "w.pomdp").action("look")
    (part,) = look.observation.parts
    assert part.name == "look"
    assert part.values == ("", "window")  # 'nothing' is the silent value
    np.testing.assert_allclose(part.confusion.sum(axis=1), 1.0)
    np.testing.assert_array_equal(part.confusion[part.truth], look.observation.matrix().toarray())


# --- what a strict reader sees -----------------------------------------------------------------------

_FLOAT = r"\d+\.\d+(?:e[+-]?\d+)?"  # the spec: a digit before and after the decimal point
_ID = r"[A-Za-z][A-Za-z0-9_-]*"
_STRICT_LINES = [
    rf"discount: {_FLOAT}",
    r"values: reward",
    rf"(?:states|actions|observations):(?: {_ID})+",
    r"start: uniform",
    rf"T: {_ID} : {_ID} : {_ID} {_FLOAT}",
    rf"T: {_ID}",
    r"identity",
    rf"O: {_ID} : (?:{_ID}|\*) : {_ID} {_FLOAT}",
    rf"R: {_ID} : \* : \* : \* -?{_FLOAT}",
]


@pytest.mark.parametrize("which", ["window", "rich"])
def test_export_fits_the_strict_grammar(which: str, request: pytest.FixtureRequest) -> None:
    """Every line is a comment, blank, or one of the forms of Cassandra's grammar; identifiers are
    not keywords; a 'T: a' line is followed by 'identity'; declarations come first."""
    text = pomdp_text(request.getfixturevalue(which))
    patterns = [re.compile(p + r"\Z") for p in _STRICT_LINES]
    body = [line for line in text.splitlines() if line.strip() and not line.startswith("#")]
    for line in body:
        assert any(p.match(line) for p in patterns), line
        if line.startswith(("states:", "actions:", "observations:", "T:", "O:", "R:")):
            names = [t for t in line.split(":", 1)[1].split() if re.fullmatch(_ID, t)]
            assert not set(names) & RESERVED, line
    assert [line.split(":")[0] for line in body[:6]] == [
        "discount",
        "values",
        "states",
        "actions",
        "observations",
        "start",
    ]
    for i, line in enumerate(body):
        if re.fullmatch(rf"T: {_ID}", line):
            assert body[i + 1] == "identity"
    assert "\t" not in text and "\r" not in text
    text.encode("ascii")


@given(st.lists(st.text(max_size=12), max_size=20))
def test_identifiers_are_valid_and_distinct(names: list[str]) -> None:
    idents = identifiers(names, "o")
    assert len(set(idents)) == len(idents) == len(names)
    for ident in idents:
        assert re.fullmatch(_ID, ident) and ident not in RESERVED
    assert identifiers(names, "o") == idents


def test_identifiers_examples() -> None:
    assert identifiers(["1,2,0", "0,0"], "s") == ["s1_2_0", "s0_0"]
    assert identifiers(["chair+potted_plant", "wall_0.2-0.8", "fire_extinguisher@18-30", "0"], "o") == [
        "chair_potted_plant",
        "wall_0_2-0_8",
        "fire_extinguisher_18-30",
        "o0",
    ]
    assert identifiers(["a+b", "a_b", "a.b"], "o") == ["a_b", "a_b_2", "a_b_3"]
    assert identifiers(["reset", "T", "uniform"], "o") == ["reset_", "T_", "uniform_"]


@pytest.mark.parametrize(
    ("value", "text"),
    [(0.8, "0.8"), (1.0, "1.0"), (1e-05, "1.0e-05"), (2.5e-07, "2.5e-07"), (-10.0, "-10.0"), (1e20, "1.0e+20")],
)
def test_format_number(value: float, text: str) -> None:
    assert format_number(value) == text
    assert float(text) == value


# --- hand-written files ------------------------------------------------------------------------------


def test_tiger() -> None:
    tiger = read_pomdp(POMDP_DATA / "tiger.pomdp")
    assert tiger.name == "tiger"
    assert tiger.states.names == ["tiger-left", "tiger-right"]
    assert tiger.grid is None
    listen, left, right = tiger.actions
    assert (listen.name, listen.kind, listen.cost, listen.transition) == ("listen", ActionKind.PERCEPTION, 1.0, None)
    assert (left.name, left.kind, left.cost) == ("open-left", ActionKind.ACTUATION, 10.0)
    assert right.cost == 10.0
    assert left.transition is not None
    np.testing.assert_array_equal(left.transition.toarray(), [[0.5, 0.5], [0.5, 0.5]])
    assert listen.observation.names() == ["hear-left", "hear-right"]
    np.testing.assert_array_equal(listen.observation.matrix().toarray(), [[0.85, 0.15], [0.15, 0.85]])
    np.testing.assert_array_equal(left.observation.matrix().toarray(), [[0.5, 0.5], [0.5, 0.5]])
    belief, p = update(tiger, uniform(2), "listen", "hear-left")
    assert p == pytest.approx(0.5)
    np.testing.assert_allclose(belief, [0.85, 0.15])
    belief, p = update(tiger, belief, "listen", "hear-left")
    np.testing.assert_allclose(belief, [0.85**2 / (0.85**2 + 0.15**2), 0.15**2 / (0.85**2 + 0.15**2)])


def test_tiger_numbered_with_every_form() -> None:
    tiger = read_pomdp(POMDP_DATA / "tiger-numbered.pomdp")
    named = read_pomdp(POMDP_DATA / "tiger.pomdp")
    assert tiger.states.names == ["0", "1"]
    assert [a.name for a in tiger.actions] == ["0", "1", "2"]
    assert [a.kind for a in tiger.actions] == [a.kind for a in named.actions]
    assert [a.cost for a in tiger.actions] == [1.0, 10.0, 10.0]  # values: cost
    for a, b in zip(tiger.actions, named.actions, strict=True):
        if a.transition is not None and b.transition is not None:
            np.testing.assert_array_equal(a.transition.toarray(), b.transition.toarray())
        np.testing.assert_array_equal(a.observation.matrix().toarray(), b.observation.matrix().toarray())
    assert tiger.action("0").observation.names() == ["0", "1"]
    belief, _ = update(tiger, uniform(2), "0", "0")
    np.testing.assert_allclose(belief, [0.85, 0.15])


def test_pomdp_py_style_file() -> None:
    """pomdp_py writes every T and O entry, zeros included, and one R per (s, a, s')."""
    text = "discount: 0.950000000\nvalues: reward\nstates: a b\nactions: stay go\nobservations: x y\n"
    text += "start: 0.500000000 0.500000000\n"
    for s, t, p in [("a", "a", 1), ("a", "b", 0), ("b", "a", 0), ("b", "b", 1)]:
        text += f"T : stay : {s} : {t} {p:.9f}\nT : go : {s} : {t} {1 - p:.9f}\n"
    for act in ["stay", "go"]:
        text += f"O : {act} : a : x 0.900000000\nO : {act} : a : y 0.100000000\n"
        text += f"O : {act} : b : x 0.000000000\nO : {act} : b : y 1.000000000\n"
    for s in "ab":
        for t in "ab":
            text += f"R : stay : {s} : {t} : *  -1.000000000\nR : go : {s} : {t} : *  -3.000000000\n"
    model = parse_pomdp(text, "py.pomdp")
    assert [(a.name, a.kind, a.cost) for a in model.actions] == [
        ("stay", ActionKind.PERCEPTION, 1.0),
        ("go", ActionKind.ACTUATION, 3.0),
    ]
    np.testing.assert_array_equal(model.action("go").observation.matrix().toarray(), [[0.9, 0.1], [0.0, 1.0]])


def test_start_forms_and_reset() -> None:
    head = "states: a b c\nactions: go\nobservations: o\n"
    tail = "T: go : * reset\nO: go : * : o 1.0\n"
    for start, row in [
        ("start: b", [0, 1, 0]),
        ("start include: a c", [0.5, 0, 0.5]),
        ("start exclude: a", [0, 0.5, 0.5]),
        ("start: 0.2 0.3 0.5", [0.2, 0.3, 0.5]),
        ("", [1 / 3, 1 / 3, 1 / 3]),
    ]:
        transition = parse_pomdp(head + start + "\n" + tail).action("go").transition
        assert transition is not None
        np.testing.assert_allclose(transition.toarray(), [row] * 3)


def test_observation_identity_and_wildcards() -> None:
    model = parse_pomdp("states: 3\nactions: a\nobservations: 3\nT: a identity\nO: a identity\nR: a : * : * : * 0\n")
    (action,) = model.actions
    assert action.kind is ActionKind.PERCEPTION and action.cost == 0.0
    np.testing.assert_array_equal(action.observation.matrix().toarray(), np.eye(3))


def test_source_is_recorded(tmp_path: Path, window: Model) -> None:
    write_pomdp(window, tmp_path / "w.pomdp")
    read = read_pomdp(tmp_path / "w.pomdp")
    assert read.source is not None and read.source.path == str(tmp_path / "w.pomdp")


# --- broken files ------------------------------------------------------------------------------------

PREAMBLE = "discount: 0.95\nvalues: reward\nstates: a b\nactions: go look\nobservations: x y\n"  # lines 1-5
GOOD_BODY = "T: go : * : b 1.0\nT: look identity\nO: * : * : x 1.0\n"  # lines 6-8

BROKEN = [
    pytest.param(
        PREAMBLE + "T: go : a : c 1.0\n",
        6,
        r"unknown state 'c'; the states declared on line 3 are a, b",
        id="unknown-state",
    ),
    pytest.param(PREAMBLE + GOOD_BODY + "T: jump : a : b 1.0\n", 9, r"unknown action 'jump'", id="unknown-action"),
    pytest.param(
        PREAMBLE + GOOD_BODY + "O: look : a : z 1.0\n", 9, r"unknown observation 'z'", id="unknown-observation"
    ),
    pytest.param(
        PREAMBLE + "T: go : a : a 0.5\nT: go : a : b 0.4\nT: go : b : b 1.0\nT: look identity\nO: * : * : x 1.0\n",
        7,
        r"T: for action 'go' from state 'a', the probabilities of the next states sum to 0.9, not 1",
        id="T-row-sum",
    ),
    pytest.param(
        PREAMBLE + "T: go : * : b 1.0\nT: look identity\nO: go : * : x 1.0\nO: look\n0.5 0.5\n0.5 0.6\n",
        11,
        r"O: for action 'look' in state 'b', the probabilities of the observations sum to 1.1, not 1",
        id="O-row-sum",
    ),
    pytest.param(
        PREAMBLE + GOOD_BODY + "T: go : a : b 1.5\n", 9, r"1.5 is not a probability", id="probability-above-1"
    ),
    pytest.param(PREAMBLE + "T: go : a : b abc\n", 6, r"expected a number, found 'abc'", id="not-a-number"),
    pytest.param(
        PREAMBLE + "T: go a : b 1.0\n",
        6,
        r"T: go: expected ':' and a state, or a whole 2 x 2 matrix .* found 'a'",
        id="missing-colon",
    ),
    pytest.param(PREAMBLE + "T: go\n1.0 0.0\n0.0\n", 8, r"needs 4 numbers, found 3", id="short-matrix"),
    pytest.param(
        PREAMBLE + "T: go : 5 : a 1.0\n", 6, r"state number 5 is out of range: there are 2 states", id="state-number"
    ),
    pytest.param(
        PREAMBLE + GOOD_BODY + "R: go : a : * : * -100\nR: go : b : * : * 10\n",
        10,
        r"R: the reward of action 'go' depends on the state or observation; .* state-dependent rewards are "
        r"unsupported",
        id="state-dependent-reward",
    ),
    pytest.param(PREAMBLE + GOOD_BODY + "R: go : * : * : * 5\n", 9, r"negative cost", id="positive-reward"),
    pytest.param(
        PREAMBLE + GOOD_BODY + "R: go : a : * : * -1\n", 9, r"here some states are left at 0", id="partial-reward"
    ),
    pytest.param(
        PREAMBLE + "T: look identity\nO: * : * : x 1.0\n",
        4,
        r"no probabilities are given for action 'go'",
        id="missing-T",
    ),
    pytest.param(
        "states: a\nT: go : a : a 1.0\nactions: go\n",
        2,
        r"comes before the preamble declared actions:, observations:",
        id="T-before-preamble",
    ),
    pytest.param(PREAMBLE + GOOD_BODY + "states: c\n", 9, r"states: must come before the first T:", id="late-preamble"),
    pytest.param("states: a a\n", 1, r"'a' is listed twice", id="duplicate-name"),
    pytest.param("states: 1a\n", 1, r"'1a' is not a valid name", id="bad-name"),
    pytest.param("states: a uniform\n", 1, r"'uniform' is a keyword", id="keyword-name"),
    pytest.param("discount: 0.95\n0.5\nhello\n", 2, r"discount: needs 1 number, found 3", id="stray-tokens"),
    pytest.param("hello: 3\n", 1, r"expected a statement .* found 'hello'", id="unknown-statement"),
    pytest.param("values: money\n", 1, r"values: must be 'reward' or 'cost'", id="bad-values"),
    pytest.param("discount: 1.5\n", 1, r"discount: must be between 0 and 1", id="bad-discount"),
    pytest.param(PREAMBLE + GOOD_BODY + "# beliefloc-model {not json\n", 9, r"beliefloc-model: ", id="bad-comment"),
    pytest.param(
        PREAMBLE + GOOD_BODY + '# beliefloc-name state c "c"\n',
        9,
        r"beliefloc-name: unknown state 'c'",
        id="comment-unknown-state",
    ),
    pytest.param(
        PREAMBLE + GOOD_BODY + '# beliefloc-grid {"rows": 1, "cols": 3, "headings": 1, "cell_size": 1.0}\n'
        "# beliefloc-layout ...\n",
        9,
        r"beliefloc-grid: the grid has 3 states, which are not the 2 states declared on line 3",
        id="comment-grid-mismatch",
    ),
    pytest.param(
        PREAMBLE + GOOD_BODY + '# beliefloc-action {"action": "go", "kind": "perception", "observations": ["x"]}\n',
        9,
        r"'go' is a perception action, but its T is not the identity",
        id="comment-kind-mismatch",
    ),
    pytest.param(
        "states: 2\nactions: 1\nobservations: 1\n", 2, r"no probabilities are given for action '0'", id="empty-body"
    ),
    pytest.param(PREAMBLE + "O: go : a\nidentity\n", 6, r"'identity' cannot follow here", id="identity-in-row"),
]


@pytest.mark.parametrize(("text", "line", "message"), BROKEN)
def test_broken_file(tmp_path: Path, text: str, line: int, message: str) -> None:
    path = tmp_path / "broken.pomdp"
    path.write_text(text)
    with pytest.raises(ModelError) as info:
        read_pomdp(path)
    text_of_error = str(info.value)
    assert text_of_error.startswith(f"{path}:{line}: "), text_of_error
    assert re.search(message, text_of_error), text_of_error
    assert "\n" not in text_of_error


def test_classic_tiger_rewards_are_refused(tmp_path: Path) -> None:
    classic = (POMDP_DATA / "tiger.pomdp").read_text()
    classic = classic.replace(
        "R: open-left : * : * : * -10.0",
        "R: open-left : tiger-left : * : * -100\nR: open-left : tiger-right : * : * 10",
    )
    lines = classic.splitlines()
    path = tmp_path / "classic.pomdp"
    path.write_text(classic)
    with pytest.raises(ModelError, match=r"state-dependent rewards are unsupported") as info:
        read_pomdp(path)
    assert str(info.value).startswith(f"{path}:{lines.index('R: open-left : tiger-right : * : * 10') + 1}: ")


def test_unreadable_files(tmp_path: Path) -> None:
    with pytest.raises(ModelError, match="no such file"):
        read_pomdp(tmp_path / "missing.pomdp")
    (tmp_path / "bin.pomdp").write_bytes(b"states: a\n\xff\xfe")
    with pytest.raises(ModelError, match=r"bin\.pomdp:2: not UTF-8"):
        read_pomdp(tmp_path / "bin.pomdp")


# --- the command -------------------------------------------------------------------------------------


def test_export_cli(runner, tmp_path: Path) -> None:
    out = tmp_path / "window.pomdp"
    result = runner.invoke(app, ["export", str(MAPS / "window-2x2.yaml"), "-o", str(out), "--json"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout) == {"output": str(out), "states": 4, "actions": 2, "observations": 3}
    assert out.is_file()
    result = runner.invoke(app, ["export", str(MAPS / "window-2x2.yaml"), "-o", str(out)])
    assert result.exit_code == 0
    assert "wrote" in result.stdout and "4 states" in result.stdout


def test_exported_file_works_with_inspect_and_beliefs(runner, tmp_path: Path, window: Model) -> None:
    out = tmp_path / "window.pomdp"
    assert runner.invoke(app, ["export", str(MAPS / "window-2x2.yaml"), "-o", str(out)]).exit_code == 0
    result = runner.invoke(app, ["inspect", str(out), "--json"])
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)
    assert summary["states"] == 4 and summary["grid"]["rows"] == 2
    assert [(a["name"], a["kind"], a["cost"]) for a in summary["actions"]] == [
        ("right", "actuation", 10.0),
        ("look", "perception", 1.0),
    ]
    read = read_pomdp(out)
    b1, p1 = update(window, uniform(4), "look", "window_seen")
    b2, p2 = update(read, uniform(4), "look", "window_seen")
    np.testing.assert_allclose(b2, [1 / 18, 1 / 18, 4 / 9, 4 / 9])
    np.testing.assert_array_equal(b1, b2)
    assert p1 == p2
    b1, _ = update(window, b1, "right", None)
    b2, _ = update(read, b2, "right", None)
    np.testing.assert_array_equal(b1, b2)


def test_export_of_a_pomdp_file(runner, tmp_path: Path) -> None:
    out = tmp_path / "tiger.pomdp"
    result = runner.invoke(app, ["export", str(POMDP_DATA / "tiger-numbered.pomdp"), "-o", str(out), "--json"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["observations"] == 2
    assert "states: s0 s1" in out.read_text()
    assert read_pomdp(out).states.names == ["0", "1"]


@pytest.mark.parametrize(
    ("output", "message"),
    [("missing-dir/w.pomdp", "cannot write"), ("w.txt", "must end in .pomdp")],
)
def test_export_bad_output_leaves_nothing(runner, tmp_path: Path, output: str, message: str) -> None:
    result = runner.invoke(app, ["export", str(MAPS / "window-2x2.yaml"), "-o", str(tmp_path / output)])
    assert result.exit_code == 2
    assert message in result.stderr
    assert list(tmp_path.iterdir()) == []


def test_export_bad_input(runner, tmp_path: Path) -> None:
    (tmp_path / "bad.pomdp").write_text("states: a a\n")
    result = runner.invoke(app, ["export", str(tmp_path / "bad.pomdp"), "-o", str(tmp_path / "out.pomdp")])
    assert result.exit_code == 2
    assert "bad.pomdp:1: states: 'a' is listed twice" in result.stderr
    assert not (tmp_path / "out.pomdp").exists()


def test_failed_write_leaves_no_file(tmp_path: Path, window: Model, monkeypatch: pytest.MonkeyPatch) -> None:
    import beliefloc.pomdp_format.writer as writer

    def broken(*args: object) -> str:
        raise RuntimeError("disk full")

    write_pomdp(window, tmp_path / "w.pomdp")
    before = (tmp_path / "w.pomdp").read_text()
    monkeypatch.setattr(writer, "_observation_block", broken)  # fails half-way through the file
    with pytest.raises(RuntimeError, match="disk full"):
        write_pomdp(window, tmp_path / "w.pomdp")
    with pytest.raises(RuntimeError, match="disk full"):
        write_pomdp(window, tmp_path / "new.pomdp")
    assert [p.name for p in tmp_path.iterdir()] == ["w.pomdp"]  # no temporary file, no new file
    assert (tmp_path / "w.pomdp").read_text() == before  # the old file is untouched


def test_infinite_cost_is_refused_before_writing(tmp_path: Path, window: Model) -> None:
    actions = (dataclasses.replace(window.actions[0], cost=float("inf")), *window.actions[1:])
    model = dataclasses.replace(window, actions=actions)
    with pytest.raises(ModelError, match=r"'right' has cost inf; a \.pomdp file needs a finite cost"):
        write_pomdp(model, tmp_path / "w.pomdp")
    assert list(tmp_path.iterdir()) == []


# --- size ----------------------------------------------------------------------------------------------

BIG_MAP = """\
name: big
grid: {rows: 50, cols: 50, headings: 4}
landmarks:
  - {class: chair, cell: [10, 10]}
  - {class: plant, cell: [30, 40]}
actions:
  forward: {cost: 10, failure: 0.1}
  backward: {cost: 10, failure: 0.1}
  rotate_cw: {cost: 10, failure: 0.1}
  rotate_ccw: {cost: 10, failure: 0.1}
sensors:
  look: {type: look, classes: [chair, plant], false_positive: 0.05, false_negative: 0.1, range: 5}
  scan: {type: scan, bins: [1, 2, 3], error: 0.1, passive: true}
"""


def test_ten_thousand_states_in_seconds(tmp_path: Path) -> None:
    (tmp_path / "big.yaml").write_text(BIG_MAP)
    model = compile_model(load_map(tmp_path / "big.yaml"))
    assert model.n_states == 10_000
    start = time.perf_counter()
    write_pomdp(model, tmp_path / "big.pomdp")
    exported = time.perf_counter()
    read = read_pomdp(tmp_path / "big.pomdp")
    imported = time.perf_counter()
    assert exported - start < 10 and imported - exported < 10, (exported - start, imported - exported)
    assert read.grid is not None and read.n_states == model.n_states
    for a, b in zip(model.actions, read.actions, strict=True):
        if a.transition is not None and b.transition is not None:
            assert abs(a.transition - b.transition).max() == 0
        assert b.observation.names() == a.observation.names()
        assert abs(a.observation.matrix() - b.observation.matrix()).max() <= 1e-12
