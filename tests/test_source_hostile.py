"""Hand-edited and hostile input files: read under the YAML 1.2 core schema, refused with a line.

Every input file (maps, domains, belief files) is read by :mod:`beliefloc.source`. A file may be
shared or downloaded: whatever it holds, reading it gives data or a :class:`BeliefLocError` naming
``file:line:col`` -- never a traceback, a native crash, a hang or gigabytes of memory.
tests/data/fuzz/yaml/ holds one small file per cause; what must not be checked in (30,000 levels of
nesting) is written by the tests.
"""

from __future__ import annotations

import math
import os
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from beliefloc.errors import (
    EXIT_BAD_INPUT,
    BeliefFileError,
    BeliefLocError,
    DomainError,
    FieldError,
    InputFileError,
    LimitError,
    MapError,
)
from beliefloc.files.belief_file import load_belief
from beliefloc.knowledge import load_domain
from beliefloc.semantic_map import load_map
from beliefloc.source import Source, limits, parse_source, read_source, read_text, resolve_plain

from .conftest import DATA, MAPS, ROOT

FUZZ = DATA / "fuzz" / "yaml"

MAP = """\
name: tiny
grid: {rows: 1, cols: 2, headings: 1}
actions:
  right: {cost: 1, failure: 0.1}
"""


def parse(text: str) -> Any:
    return parse_source(text, Path("t.yaml"), MapError).data


def write(tmp_path: Path, text: str, name: str = "map.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def run_cli(*args: str | Path, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    """The command in a fresh interpreter: a native crash there is a signal, not a failed test run."""
    return subprocess.run(
        [sys.executable, "-m", "beliefloc", *map(str, args)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env={**os.environ, "COLUMNS": "200", **(env or {})},
        timeout=300,  # a guard against a hang, not a timing assertion
    )


def assert_refused(result: subprocess.CompletedProcess[str], pattern: str) -> None:
    assert result.returncode == EXIT_BAD_INPUT, (result.returncode, result.stderr[-2000:])
    assert "Traceback" not in result.stderr
    assert re.search(pattern, " ".join(result.stderr.split())), result.stderr[-2000:]


# --- 1. the YAML 1.2 core schema -----------------------------------------------------------------

SCALARS: list[tuple[str, Any]] = [
    # booleans: only these six spellings
    *((text, True) for text in ("true", "True", "TRUE")),
    *((text, False) for text in ("false", "False", "FALSE")),
    *((text, text) for text in ("on", "off", "On", "OFF", "yes", "no", "Yes", "NO", "y", "n", "Y", "N", "tRUE")),
    # null: ~, null, Null, NULL and nothing
    *((text, None) for text in ("~", "null", "Null", "NULL", "")),
    ("nULL", "nULL"),
    # integers: decimal (a leading 0 is still decimal), 0o octal, 0x hex
    ("010", 10),
    ("-010", -10),
    ("+7", 7),
    ("0", 0),
    ("0o17", 15),
    ("0x1F", 31),
    ("0x1f", 31),
    ("0b101", "0b101"),
    ("0o18", "0o18"),
    ("0x", "0x"),
    ("-0x1F", "-0x1F"),
    ("1_000", "1_000"),  # YAML 1.1 read 1000
    ("1:30", "1:30"),  # YAML 1.1 read 90 (sexagesimal)
    ("190:20:30", "190:20:30"),
    ("2001-12-14", "2001-12-14"),  # YAML 1.1 read a date
    ("2001-12-14t21:59:43.10-05:00", "2001-12-14t21:59:43.10-05:00"),
    # floats
    ("1.5", 1.5),
    ("-1.5", -1.5),
    (".5", 0.5),
    ("1.", 1.0),
    ("1e3", 1000.0),  # YAML 1.1 (PyYAML) read text: its floats needed a dot
    ("1.5E-2", 0.015),
    ("+.inf", math.inf),
    (".Inf", math.inf),
    ("-.INF", -math.inf),
    ("1_000.5", "1_000.5"),
    ("1e", "1e"),
    ("e3", "e3"),
    (".", "."),
    ("1.2.3", "1.2.3"),
    ("inf", "inf"),
    ("nan", "nan"),
    ("0.1.2", "0.1.2"),
]


@pytest.mark.parametrize(("text", "expected"), SCALARS, ids=[repr(t) for t, _ in SCALARS])
def test_plain_scalars_follow_the_yaml_1_2_core_schema(text: str, expected: Any) -> None:
    value = parse(f"v: {text}\n")["v"]
    assert type(value) is type(expected) and value == expected
    if text:
        assert type(resolve_plain(text)) is type(expected)


@pytest.mark.parametrize("text", [".nan", ".NaN", ".NAN"])
def test_nan_is_a_float(text: str) -> None:
    value = parse(f"v: {text}\n")["v"]
    assert isinstance(value, float) and math.isnan(value)


def test_quoted_and_block_scalars_are_text() -> None:
    data = parse("a: '010'\nb: \"true\"\nc: 'on'\nd: |\n  yes\ne: \"~\"\n")
    assert data == {"a": "010", "b": "true", "c": "on", "d": "yes\n", "e": "~"}


def test_keys_follow_the_same_schema() -> None:
    data = parse("on: 1\noff: 2\nyes: 3\nno: 4\n010: 5\ntrue: 6\n")
    assert data == {"on": 1, "off": 2, "yes": 3, "no": 4, 10: 5, True: 6}


def test_explicit_tags_of_the_core_schema() -> None:
    data = parse("a: !!str 010\nb: !!int '7'\nc: !!float 1\nd: !!bool 'true'\ne: !!null ''\nf: ! on\n")
    assert data == {"a": "010", "b": 7, "c": 1.0, "d": True, "e": None, "f": "on"}
    assert type(data["c"]) is float


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("v: !!int x\n", r"t\.yaml:1:4: 'x' is not an integer, as its tag !!int says"),
        ("v: !!bool yes\n", r"t\.yaml:1:4: 'yes' is not true or false"),
        ("v: !!binary aGk=\n", r"t\.yaml:1:4: the tag !!binary is not supported here"),
        ("v: !!timestamp 2001-12-14\n", r"the tag !!timestamp is not supported"),
        ("v: !custom 1\n", r"the tag !custom is not supported"),
        ("v: !!set {a, b}\n", r"t\.yaml:1:4: the tag !!set is not supported"),
        ("v: !!python/object:os.system {}\n", r"the tag !!python/object:os.system is not supported"),
    ],
)
def test_other_tags_are_refused_at_their_line(text: str, message: str) -> None:
    with pytest.raises(MapError, match=message):
        parse(text)


def test_the_domain_field_on_is_the_key_on(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        "name: t\nrooms: [kitchen]\nclasses: {object: , cup: object, table: object}\n"
        "objects:\n  table1: {class: table, room: kitchen}\n  cup1: {class: cup, on: table1}\n",
        "domain.yaml",
    )
    domain = load_domain(path)
    assert domain.objects["cup1"].on == "table1"


def test_the_domain_field_on_with_an_unknown_object_points_at_it(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        "name: t\nrooms: [kitchen]\nclasses: {object: , cup: object}\nobjects:\n  cup1: {class: cup, on: no}\n",
        "domain.yaml",
    )
    with pytest.raises(DomainError, match=r"domain\.yaml:5:\d+: objects\.cup1\.on: unknown object 'no'"):
        load_domain(path)


def test_failure_yes_is_not_one(tmp_path: Path) -> None:
    path = write(tmp_path, MAP.replace("failure: 0.1", "failure: yes"))
    with pytest.raises(MapError, match=r"map\.yaml:4:29: actions\.right\.failure: should be a number, got 'yes'$"):
        load_map(path)


def test_a_leading_zero_is_decimal(tmp_path: Path) -> None:
    smap = load_map(write(tmp_path, MAP.replace("cols: 2", "cols: 010")))
    assert smap.grid.cols == 10


def test_an_integer_too_long_for_python_is_refused_at_its_line() -> None:
    with pytest.raises(MapError, match=r"t\.yaml:2:4: an integer of 5,000 digits is longer than"):
        parse("a: 1\nb: " + "9" * 5000 + "\n")
    assert parse("b: '" + "9" * 5000 + "'\n")["b"] == "9" * 5000  # quoted: text
    assert parse("b: 0x" + "f" * 5000 + "\n")["b"] == 16**5000 - 1  # Python has no limit for hex


# --- 2. nesting -----------------------------------------------------------------------------------


def test_nesting_30000_levels_deep_is_refused_without_a_crash(tmp_path: Path) -> None:
    flow = write(tmp_path, "[" * 30_000 + "]" * 30_000 + "\n", "flow.yaml")
    # libyaml 0.2.6 (PyYAML 6.0.4) scans flow brackets ahead and may stop at its own 1,000 levels first
    assert_refused(
        run_cli("show", flow),
        rf"{re.escape(str(flow))}:1:(65: 65 levels of nesting|\d+: more levels of nesting than the YAML parser) "
        r".*BELIEFLOC_MAX_NESTING",
    )
    mapping = write(tmp_path, "name: x\ngrid: " + "{a: " * 30_000 + "1" + "}" * 30_000 + "\n", "flow-map.yaml")
    assert_refused(run_cli("validate", mapping), r"flow-map\.yaml:2:\d+: 65 levels of nesting")
    block = write(tmp_path, "- " * 30_000 + "x\n", "block.yaml")
    assert_refused(run_cli("show", block), r"block\.yaml:1:129: 65 levels of nesting")


def test_deep_json_belief_file_is_refused_without_a_crash(tmp_path: Path) -> None:
    belief = write(tmp_path, '{"belief": ' + '{"a": ' * 30_000 + "1" + "}" * 30_001 + "\n", "deep.json")
    assert_refused(
        run_cli("show", MAPS / "window-2x2.yaml", "--belief", belief), r"deep\.json:1:\d+: 65 levels of nesting"
    )


def test_500_levels_is_a_message_not_a_recursion_error(tmp_path: Path) -> None:
    path = write(tmp_path, "name: x\ngrid: " + "[" * 500 + "]" * 500 + "\n")
    with pytest.raises(LimitError, match=r"map\.yaml:2:70: 65 levels of nesting is more than the limit of 64"):
        load_map(path)


def test_deep_block_mappings_are_refused_at_the_line_of_the_level_too_many() -> None:
    text = "".join("  " * level + "k:\n" for level in range(100)) + "  " * 100 + "v\n"
    with pytest.raises(LimitError, match=r"^t\.yaml:65:129: 65 levels of nesting") as info:
        parse(text)
    assert "BELIEFLOC_MAX_NESTING" in str(info.value)


def test_the_nesting_limit_is_inclusive_and_can_be_raised(monkeypatch: pytest.MonkeyPatch) -> None:
    limit = limits.NESTING.value
    assert limit == 64
    inside = "[" * limit + "]" * limit
    assert parse(inside) is not None
    with pytest.raises(LimitError):
        parse("[" + inside + "]")
    monkeypatch.setenv("BELIEFLOC_MAX_NESTING", "200")
    data = parse("[" * 150 + "]" * 150)
    for _ in range(149):
        data = data[0]
    assert data == []


# --- 3. aliases and merge keys --------------------------------------------------------------------


def test_billion_laughs_is_refused_before_it_is_built() -> None:
    path = FUZZ / "billion-laughs.yaml"
    with pytest.raises(
        LimitError, match=r"billion-laughs\.yaml:\d+:\d+: [\d,]+ YAML values \(after expanding alias"
    ) as info:
        read_source(path, MapError)
    assert "BELIEFLOC_MAX_YAML_NODES" in str(info.value)


def test_aliases_count_in_full(monkeypatch: pytest.MonkeyPatch) -> None:
    text = "a: &a [1, 2, 3, 4, 5, 6, 7, 8, 9]\nb: [" + ", ".join(["*a"] * 12) + "]\n"
    data = parse(text)
    assert data["b"][11] == list(range(1, 10))
    monkeypatch.setenv("BELIEFLOC_MAX_YAML_NODES", "100")  # 1 + 1 + 10 + 1 + 1 + 12 * 10 values
    with pytest.raises(LimitError, match=r"t\.yaml:2:\d+: 10\d YAML values \(after expanding aliases\)"):
        parse(text)


def test_an_alias_shares_the_anchor_and_points_at_both_places() -> None:
    text = "base: &b\n  cost: 10\n  classes: [x, y]\ncopy: *b\n"
    source = parse_source(text, Path("t.yaml"), MapError)
    assert source.data["copy"] == source.data["base"]
    assert source.locate(("copy",)) == (("copy",), (4, 7))  # the alias
    assert source.locate(("copy", "classes", 1)) == (("copy", "classes", 1), (3, 16))  # inside the anchor
    assert source.locate(("copy", "cost"), key=True) == (("copy", "cost"), (2, 3))


FUZZ_CASES = [
    ("self-alias.yaml", 5, 10, r"\*grid is inside the value anchored &grid: a value cannot contain itself"),
    ("self-alias-flow.yaml", 3, 20, r"\*rows is inside the value anchored &rows"),
    ("undefined-alias.yaml", 3, 7, r"\*nowhere: no anchor &nowhere is defined before this alias"),
    ("merge-int.yaml", 4, 15, r"'<<' merges mappings into this one: write '<<: \*name' .*; got 5$"),
    ("merge-list-of-ints.yaml", 5, 10, r"'<<' merges mappings .*; got 1 in the list$"),
    ("big-int.yaml", 3, 14, r"an integer of 5,000 digits is longer than the 4,300 digits Python reads"),
    ("tab-indent.yaml", 4, 1, r"YAML syntax error: a tab indents this line; YAML indents with spaces only"),
    ("missing-colon.yaml", 3, 1, r"YAML syntax error: a colon is missing: 'grid' is not followed by ':'"),
    ("misplaced-colon.yaml", 3, 18, r"YAML syntax error: a colon is misplaced here: .*needs quotes"),
    ("two-documents.yaml", 3, 1, r"a second YAML document starts here"),
    ("unknown-tag.yaml", 2, 7, r"the tag !!binary is not supported here"),
    ("collection-key.yaml", 3, 3, r"a key must be a plain value \(text or a number\), not a mapping or a list"),
    ("null-key.yaml", 3, 1, r"a key must be a plain value .*got empty \(null\)"),
    ("control-character.yaml", 2, 8, r"YAML syntax error: the control character #x0001 is not allowed"),
    ("unclosed-quote.yaml", 2, 7, r"YAML syntax error: the quote opened here is never closed"),
    ("deep-flow-65.yaml", 3, 70, r"65 levels of nesting is more than the limit of 64"),
    ("billion-laughs.yaml", 8, 16, r"YAML values \(after expanding aliases\) is more than the limit"),
]
"""tests/data/fuzz/yaml/: (file, line, column, what the message says)."""


@pytest.mark.parametrize(("file", "line", "column", "message"), FUZZ_CASES, ids=[c[0] for c in FUZZ_CASES])
def test_fuzz_corpus_file_is_refused_at_its_line(file: str, line: int, column: int, message: str) -> None:
    path = FUZZ / file
    with pytest.raises(BeliefLocError) as info:
        load_map(path)
    assert isinstance(info.value, (InputFileError, LimitError))
    text = str(info.value)
    assert text.startswith(f"{path}:{line}:{column}: "), text
    assert re.search(message, text), text
    assert "\n" not in text


def test_every_fuzz_file_is_in_the_table_and_says_its_cause_first() -> None:
    files = sorted(p.name for p in FUZZ.iterdir())
    assert files == sorted(case[0] for case in FUZZ_CASES)
    for path in FUZZ.iterdir():
        assert path.read_bytes().startswith(b"# "), path


def test_the_fuzz_corpus_through_the_cli_is_exit_2_without_a_traceback() -> None:
    result = run_cli("validate", *sorted(FUZZ.iterdir()))
    assert result.returncode == EXIT_BAD_INPUT
    assert "Traceback" not in result.stderr
    reported = [line for line in result.stderr.splitlines() if line.startswith("error: ")]
    assert len(reported) == len(list(FUZZ.iterdir())), result.stderr


def test_merge_keys_merge_and_written_keys_win() -> None:
    text = (
        "base: &base {cost: 10, failure: 0.02}\n"
        "other: &other {cost: 5, label: o}\n"
        "one: {<<: *base, cost: 3}\n"
        "two:\n  <<: [*other, *base]\n"
        "three: {cost: 1, <<: {failure: 0.5}}\n"
    )
    source = parse_source(text, Path("t.yaml"), MapError)
    assert source.data["one"] == {"cost": 3, "failure": 0.02}
    assert source.data["two"] == {"cost": 5, "failure": 0.02, "label": "o"}  # the earlier source wins
    assert source.data["three"] == {"cost": 1, "failure": 0.5}
    # a merged key points where it was written
    assert source.locate(("one", "failure")) == (("one", "failure"), (1, 33))
    assert source.locate(("one", "cost")) == (("one", "cost"), (3, 24))
    assert source.locate(("two", "label"), key=True) == (("two", "label"), (2, 25))
    assert source.locate(("three", "failure")) == (("three", "failure"), (6, 32))


def test_an_error_in_a_merged_value_names_the_merging_path_at_the_anchor_line(tmp_path: Path) -> None:
    text = MAP.replace(
        "  right: {cost: 1, failure: 0.1}\n", "  right: &move {cost: 1, failure: 1.5}\n  left: {<<: *move, cost: 2}\n"
    )
    message = _map_error(tmp_path, text)
    lines = message.splitlines()
    assert lines[0].endswith("map.yaml:4:35: actions.right.failure: should be less than or equal to 1, got 1.5")
    assert lines[1].endswith("map.yaml:4:35: actions.left.failure: should be less than or equal to 1, got 1.5")
    assert len(lines) == 2  # left's own cost (2) wins over the merged one and is fine


def test_duplicate_merge_keys_are_refused() -> None:
    with pytest.raises(MapError, match=r"t\.yaml:2:\d+: m\.<<: duplicate key '<<'"):
        parse("b: &b {a: 1}\nm: {<<: *b, <<: *b}\n")


def test_a_quoted_merge_key_is_an_ordinary_key() -> None:
    assert parse("m: {'<<': 1}\n") == {"m": {"<<": 1}}


# --- 4. what read_text opens ------------------------------------------------------------------------


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes here")
def test_a_fifo_is_refused_without_opening_it(tmp_path: Path) -> None:
    fifo = tmp_path / "map.yaml"
    os.mkfifo(fifo)
    with pytest.raises(MapError, match=r"map\.yaml: is a named pipe \(FIFO\), not a regular file"):
        read_text(fifo, MapError)  # opening a FIFO with no writer would block: this returns
    assert_refused(run_cli("validate", fifo), r"map\.yaml: is a named pipe")


@pytest.mark.parametrize("device", ["/dev/zero", "/dev/urandom", "/dev/null"])
def test_a_device_is_refused(device: str) -> None:
    if not os.path.exists(device):
        pytest.skip(f"no {device} here")
    with pytest.raises(MapError, match=rf"^{device}: is a character device"):
        load_map(device)


def test_a_folder_is_refused(tmp_path: Path) -> None:
    with pytest.raises(MapError, match=r": is a folder, not a file$"):
        load_map(tmp_path)


def test_a_missing_file_and_a_file_under_a_file(tmp_path: Path) -> None:
    with pytest.raises(MapError, match=r"nothere\.yaml: no such file$"):
        load_map(tmp_path / "nothere.yaml")
    plain = write(tmp_path, MAP)
    with pytest.raises(MapError, match=r"no such file$"):
        load_map(plain / "inside.yaml")


def test_a_file_larger_than_the_limit_is_refused_before_it_is_read(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = write(tmp_path, MAP)
    monkeypatch.setenv("BELIEFLOC_MAX_INPUT_BYTES", "20")
    with pytest.raises(LimitError, match=rf"map\.yaml: {len(MAP)} bytes in an input file is more than the limit of 20"):
        load_map(path)
    monkeypatch.setenv("BELIEFLOC_MAX_INPUT_BYTES", str(len(MAP)))
    assert load_map(path).name == "tiny"  # the limit itself is allowed


def test_a_file_whose_size_lies_is_read_no_further_than_the_limit(monkeypatch: pytest.MonkeyPatch) -> None:
    status = Path("/proc/self/status")
    if not status.is_file() or status.stat().st_size != 0:
        pytest.skip("no /proc file that says it is empty")
    text, _ = read_text(status, InputFileError)
    assert "Name:" in text  # read although its size is 0
    monkeypatch.setenv("BELIEFLOC_MAX_INPUT_BYTES", "10")
    with pytest.raises(LimitError, match=r"/proc/self/status: more bytes in an input file is more than the limit"):
        read_text(status, InputFileError)


def test_text_that_is_not_utf8_names_the_line(tmp_path: Path) -> None:
    path = tmp_path / "map.yaml"
    path.write_bytes(b"name: x\ngrid: \xff\n")
    with pytest.raises(MapError, match=r"map\.yaml:2: not UTF-8 text \(byte 14\)"):
        load_map(path)


# --- 5. messages in plain words ----------------------------------------------------------------------


def _map_error(tmp_path: Path, text: str) -> str:
    with pytest.raises(MapError) as info:
        load_map(write(tmp_path, text))
    return str(info.value)


def test_a_name_pattern_is_said_in_words(tmp_path: Path) -> None:
    message = _map_error(tmp_path, MAP + "landmarks:\n  - {class: 'a b', cell: [0, 0]}\n")
    assert message.endswith(
        "map.yaml:6:13: landmarks[0].class: should use only letters, digits, '_' and '-', got 'a b'"
    )


def test_a_lowercase_name_pattern_is_said_in_words(tmp_path: Path) -> None:
    path = write(tmp_path, "name: t\nrooms: [Kitchen]\nclasses: {object: }\n", "domain.yaml")
    with pytest.raises(DomainError) as info:
        load_domain(path)
    assert str(info.value) == (
        f"{path}:2:9: rooms.Kitchen: "
        "should start with a lowercase letter and use only lowercase letters, digits and '_', got 'Kitchen'"
    )


def test_a_dict_key_that_breaks_the_pattern_points_at_the_key(tmp_path: Path) -> None:
    text = MAP + "sensors:\n  'my look':\n    type: look\n    classes: [a]\n"
    message = _map_error(tmp_path, text)
    assert message.startswith(f"{tmp_path / 'map.yaml'}:6:3: sensors.my look: should use only letters"), message


def test_a_pair_with_three_items_says_so(tmp_path: Path) -> None:
    message = _map_error(tmp_path, MAP + "landmarks:\n  - {class: a, cell: [0, 1, 2]}\n")
    assert message.endswith("map.yaml:6:22: landmarks[0].cell: should have 2 items, got 3"), message
    message = _map_error(tmp_path, MAP + "landmarks:\n  - {class: a, cell: [0]}\n")
    assert message.endswith("map.yaml:6:22: landmarks[0].cell: should have 2 items, got 1"), message
    assert "Tuple" not in message and "after validation" not in message


def test_a_boolean_for_a_number_says_boolean(tmp_path: Path) -> None:
    message = _map_error(tmp_path, MAP.replace("cost: 1,", "cost: true,"))
    assert message.endswith("actions.right.cost: should be a number, got true (a boolean)"), message
    assert "valid" not in message


def test_a_word_for_an_integer(tmp_path: Path) -> None:
    message = _map_error(tmp_path, MAP.replace("rows: 1", "rows: one"))
    assert message.endswith("map.yaml:2:14: grid.rows: should be an integer, got 'one'"), message


def test_a_boolean_key_says_to_quote_it(tmp_path: Path) -> None:
    message = _map_error(tmp_path, MAP + "sensors:\n  true: {type: look, classes: [a]}\n")
    assert message.endswith(
        "map.yaml:6:3: sensors.True: a key should be text, got true (a boolean); write it in quotes"
    )


def test_messages_have_no_python_prefixes_and_one_got(tmp_path: Path) -> None:
    texts = [
        MAP.replace("headings: 1", "headings: 3"),
        MAP.replace("failure: 0.1", "failure: 1.5"),
        MAP.replace("cost: 1,", "cost: []"),
        MAP.replace("cost: 1,", "cost: {a: 1},"),
        MAP.replace("name: tiny", "name: ''"),
        MAP.replace("name: tiny", "name: " + "x" * 80),
        MAP.replace("name: tiny", "name: 5"),
    ]
    for text in texts:
        message = _map_error(tmp_path, text)
        for python in ("Value error", "Assertion failed", "Input should", "valid dictionary", "String should"):
            assert python not in message, message
        assert message.count("got ") <= 1, message


@pytest.mark.parametrize(
    ("text", "line", "column", "message"),
    [
        ("name: x\ngrid:\n\trows: 1\n", 3, 1, "a tab indents this line; YAML indents with spaces only"),
        ("name: x\ngrid:\n  rows: 1\n\tcols: 1\n", 4, 1, "a tab indents this line"),
        ("name: x\ngrid\n  rows: 1\n", 2, 1, "a colon is missing: 'grid' is not followed by ':'"),
        ("name: x\ngrid:\n  rows: 1\n  cols\n  headings: 1\n", 4, 3, "a colon is missing: 'cols'"),
        ("name x\ngrid: 1\n", 2, 5, "a colon is misplaced here"),
        ("name: a: b\n", 1, 8, "a colon is misplaced here"),
        ("name: x\ngrid:\n  rows: 1\n cols: 2\n", 4, 2, "expected a 'key: value' line here"),
        ("name: '@x'\ngrid: @x\n", 2, 7, "'@' cannot start a value; put the value in quotes"),
        ("name: x\ngrid: {rows: 1\n", 3, 1, r"did not find expected ',' or '}'"),
    ],
)
def test_syntax_errors_are_said_plainly_with_the_line(text: str, line: int, column: int, message: str) -> None:
    with pytest.raises(MapError) as info:
        parse(text)
    assert str(info.value).startswith(f"t.yaml:{line}:{column}: YAML syntax error: "), str(info.value)
    assert message in str(info.value)


# --- 6. locating a path -------------------------------------------------------------------------------


def test_a_path_that_is_not_in_the_file_points_at_its_nearest_ancestor() -> None:
    text = "# comment\n\nname: x\nrooms:\n  legend:\n    K: kitchen\n"
    source = parse_source(text, Path("t.yaml"), MapError)
    assert source.locate(("rooms", "legend", "Z")) == (("rooms", "legend"), (6, 5))
    assert source.locate(("rooms", "nothing", "deeper")) == (("rooms",), (5, 3))
    assert source.locate(("elsewhere",)) == ((), (3, 1))  # the root: where the first key is, not 1:1


def test_a_key_written_as_a_number_is_found_by_its_number() -> None:
    source = parse_source("rooms:\n  3: kitchen\n  true: x\n", Path("t.yaml"), MapError)
    assert source.locate(("rooms", 3)) == (("rooms", 3), (2, 6))
    assert source.locate(("rooms", "3"), key=True) == (("rooms", "3"), (2, 3))


def test_a_key_without_a_value_mark_is_found_by_its_key() -> None:
    source = Source(
        Path("t.yaml"), {"a": {"b": 1}}, "", {(): (1, 1), ("a",): (2, 3)}, {("a",): (2, 1), ("a", "b"): (15, 5)}
    )
    assert source.locate(("a", "b")) == (("a", "b"), (15, 5))
    assert source.format(("a", "b", "c"), "wrong") == "t.yaml:15:5: a.b: wrong"


def test_a_field_error_on_a_key_is_reported_at_its_line() -> None:
    text = "\n" * 14 + "rooms:\n  legend:\n    K: kitchen\n"
    source = parse_source(text, Path("t.yaml"), MapError)
    error = FieldError(("rooms", "legend", "K"), "no cell has 'K'")
    assert source.format(error.path, error.message, key=True) == "t.yaml:17:5: rooms.legend.K: no cell has 'K'"
    assert source.format(error.path, error.message) == "t.yaml:17:8: rooms.legend.K: no cell has 'K'"


def test_a_belief_file_error_names_the_state_line(tmp_path: Path) -> None:
    from beliefloc import compile_model

    model = compile_model(load_map(MAPS / "window-2x2.yaml"))
    path = write(tmp_path, '{"belief": {\n  "0,0": 0.5,\n  "9,9": 0.5\n}}\n', "belief.json")
    with pytest.raises(BeliefFileError, match=r"belief\.json:3:3: 9,9: "):
        load_belief(model, path)
