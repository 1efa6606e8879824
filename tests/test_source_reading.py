"""Reading YAML with marks: the data is what the YAML 1.2 core schema says (PyYAML's safe loader
follows YAML 1.1 where they differ: ``yes``, ``1_000``, dates, ``0o17``)."""

from __future__ import annotations

import gc
from pathlib import Path

import pytest
import yaml

from beliefloc.errors import MapError
from beliefloc.source import parse_source

TEXT = """\
base: &base {cost: 10, failure: 0.02}
forward: {<<: *base, label: x}
plain: [1, -2, 0x1f, 0o17, 1_000, 1.5, .5, 1e3, -.inf, .nan, true, False, yes, no, ~, null, "", text]
quoted: ["1", '2.5', "true", "null"]
when: 2001-12-14
3: int key
1.5: float key
true: bool key
block: |
  two
  lines
"""


def _same(a: object, b: object) -> bool:
    if isinstance(a, float) and isinstance(b, float) and a != a and b != b:
        return True  # nan
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    return type(a) is type(b) and a == b


EXPECTED = {
    "base": {"cost": 10, "failure": 0.02},
    "forward": {"cost": 10, "failure": 0.02, "label": "x"},
    "plain": [
        *(1, -2, 31, 15, "1_000", 1.5, 0.5, 1000.0, float("-inf"), float("nan")),
        *(True, False, "yes", "no", None, None, "", "text"),
    ],
    "quoted": ["1", "2.5", "true", "null"],
    "when": "2001-12-14",
    3: "int key",
    1.5: "float key",
    True: "bool key",
    "block": "two\nlines\n",
}


def test_data_is_the_yaml_1_2_core_schema() -> None:
    source = parse_source(TEXT, Path("t.yaml"), MapError)
    assert _same(source.data, EXPECTED)
    # where YAML 1.1 (PyYAML's safe loader) differs, and only there
    old = yaml.safe_load(TEXT)
    differs = {i for i, (a, b) in enumerate(zip(source.data["plain"], old["plain"], strict=True)) if not _same(a, b)}
    assert differs == {3, 4, 7, 12, 13}  # 0o17, 1_000, 1e3 (text to PyYAML), yes, no
    assert old["when"] != source.data["when"]
    assert source.value_marks[("plain", 2)] == (3, 16)
    assert source.key_marks[("forward",)] == (2, 1)


@pytest.mark.parametrize("enabled", [True, False])
def test_the_garbage_collector_is_left_as_it_was(enabled: bool) -> None:
    was = gc.isenabled()
    try:
        (gc.enable if enabled else gc.disable)()
        parse_source(TEXT, Path("t.yaml"), MapError)
        assert gc.isenabled() is enabled
        with pytest.raises(MapError, match="YAML syntax error"):
            parse_source("a: [1, 2", Path("t.yaml"), MapError)
        assert gc.isenabled() is enabled
    finally:
        (gc.enable if was else gc.disable)()
