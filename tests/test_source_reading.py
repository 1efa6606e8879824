"""Reading YAML with marks: the fast paths give what PyYAML's safe loader gives."""

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


def test_data_equals_safe_load() -> None:
    source = parse_source(TEXT, Path("t.yaml"), MapError)
    assert _same(source.data, yaml.safe_load(TEXT))
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
