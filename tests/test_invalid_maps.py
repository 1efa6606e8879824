"""Broken maps and the message each must give (tests/data/invalid/, one small file per mistake).

Every case is checked twice: through the library (``load_map`` raises :class:`MapError`) and through
the CLI (``beliefloc validate FILE`` exits 2 with the message and no traceback). A message is one
paragraph: ``FILE:LINE:COL: field.path: what is wrong``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import pytest

from beliefloc.cli.app import app
from beliefloc.errors import EXIT_BAD_INPUT, MapError
from beliefloc.semantic_map import load_map

from .conftest import DATA, ROOT

INVALID = DATA / "invalid"


@dataclass(frozen=True)
class Case:
    file: str
    line: int
    column: int
    field: str | None
    """The field path the message names (None: the mistake is not in a field, e.g. YAML syntax)."""
    message: str
    """A regex searched in the message after ``FILE:LINE:COL:``."""

    def __str__(self) -> str:
        return self.file.removesuffix(".yaml")


CASES = [
    Case(
        "yaml_syntax.yaml", 4, 8, None, r"YAML syntax error: did not find expected ',' or '\}' \(while parsing a flow"
    ),
    Case("duplicate_key.yaml", 6, 3, "grid.cols", r"duplicate key 'cols' \(YAML would silently keep only the last"),
    Case("not_a_mapping.yaml", 1, 1, None, r"a map file is a YAML mapping \(name:, grid:, actions:"),
    Case(
        "unknown_top_level_key.yaml",
        6,
        1,
        "sensor",
        r"unknown key 'sensor'; expected one of: actions, annotations, description, grid, landmarks, layout, name, "
        r"occupancy, occupancy_rule, rooms, sensors$",
    ),
    Case("unknown_sensor_key.yaml", 10, 5, "sensors.look.rnage", r"unknown key 'rnage'"),
    Case("missing_grid.yaml", 2, 1, None, r"required key 'grid' is missing"),
    Case("wrong_type_rows.yaml", 4, 9, "grid.rows", r"should be an integer, got 'three'"),
    Case("headings_3.yaml", 6, 13, "grid.headings", r"should be 1, 4 or 8, got 3"),
    Case("probability_above_one.yaml", 10, 21, "sensors.look.false_positive", r"less than or equal to 1, got 1\.5"),
    Case("negative_probability.yaml", 5, 29, "actions.right.failure", r"greater than or equal to 0, got -0\.1"),
    Case("negative_cost.yaml", 6, 11, "actions.right.cost", r"greater than or equal to 0, got -10"),
    Case("layout_row_count.yaml", 4, 9, "layout", r"has 2 rows, but grid\.rows is 3"),
    Case("layout_row_too_wide.yaml", 6, 3, "layout", r"row 1 has 4 cells, but grid\.cols is 3"),
    Case("layout_unknown_character.yaml", 6, 4, "layout", r"row 1 has 'x'; use '\.' for free and '#' for blocked"),
    Case("every_cell_blocked.yaml", 4, 9, "layout", r"every cell is blocked: the map has no states"),
    Case("landmark_outside_grid.yaml", 6, 27, "landmarks[1].cell", r"cell \[2, 0\] is outside the 2x2 grid"),
    Case("landmark_on_blocked_cell.yaml", 8, 26, "landmarks[0].cell", r"cell \[1, 1\] is blocked in the layout"),
    Case(
        "action_for_other_headings.yaml",
        6,
        7,
        "actions.up",
        r"unknown action 'up' for a map with headings: 4; expected some of: forward, backward, rotate_cw, rotate_ccw",
    ),
    Case(
        "unknown_sensor_type.yaml",
        8,
        11,
        "sensors.ranger.type",
        r"unknown sensor type 'lidar'; expected one of: look, scan, here",
    ),
    Case(
        "sensor_without_type.yaml",
        8,
        5,
        "sensors.scan",
        r"required key 'type' is missing; it says which kind: look, scan, here",
    ),
    Case(
        "look_without_classes.yaml",
        9,
        14,
        "sensors.look.classes",
        r"a look sensor needs at least one class, or it has no observations",
    ),
    Case(
        "scan_bins_not_increasing.yaml",
        9,
        11,
        "sensors.scan.bins",
        r"bins must be strictly increasing, got \[0\.2, 1\.1, 0\.8, 1\.5\]",
    ),
    Case("scan_without_headings.yaml", 8, 11, "sensors.scan.type", r"a scan looks ahead, but the map has headings: 1"),
    Case(
        "here_label_not_in_legend.yaml",
        12,
        9,
        "sensors.here.labels",
        r"row 1 has '2', which the legend does not name",
    ),
    Case(
        "annotation_unknown_class.yaml",
        10,
        28,
        "annotations[1].look",
        r"unknown class 'sofa'; this sensor looks for: chair, screen",
    ),
    Case(
        "annotation_unknown_sensor.yaml",
        10,
        13,
        "annotations[0].camera",
        r"unknown sensor 'camera'; the map's sensors are: look",
    ),
    Case(
        "annotation_state_outside_grid.yaml",
        10,
        24,
        "annotations[1].states[1]",
        r"state '5,0,0' is outside the 2x2 grid",
    ),
    Case(
        "annotation_state_malformed.yaml",
        9,
        13,
        "annotations[0].state",
        r"state 'north-east corner' should be 'row,col' or 'row,col,heading'",
    ),
    Case(
        "annotation_heading_out_of_range.yaml", 9, 13, "annotations[0].state", r"state '1,1,4': heading must be 0\.\.3"
    ),
    # rooms (issue 7): a letter layout with a legend, or rectangles
    Case(
        "rooms_unknown_letter.yaml",
        9,
        6,
        "rooms.layout",
        r"row 1 has 'X', which the legend does not name \(K: kitchen, S: study\); '\.' is a free cell in no room",
    ),
    Case(
        "rooms_letter_on_blocked.yaml",
        11,
        7,
        "rooms.layout",
        r"row 0 has 'K' on a blocked cell of the layout; write '#'",
    ),
    Case(
        "rooms_wall_on_free_cell.yaml",
        11,
        7,
        "rooms.layout",
        r"row 0 has '#' on a free cell of the layout; write '\.' for a free cell in no room",
    ),
    Case(
        "rooms_unused_letter.yaml",
        10,
        27,
        "rooms.legend.S",
        r"no cell of rooms\.layout has 'S': room 'study' would be empty",
    ),
    Case(
        "rooms_unknown_key.yaml",
        9,
        10,
        "rooms.legnd",
        r"unknown key 'legnd'; expected one of: layout, legend \(a letter per cell\), rectangles, mask with labels, "
        r"or polygons",
    ),
    Case(
        "rooms_capital_name.yaml",
        9,
        15,
        "rooms.legend.K",
        r"should start with a lowercase letter and use only lowercase letters, digits and '_', got 'Kitchen'",
    ),
    Case(
        "rooms_both_forms.yaml",
        11,
        5,
        "rooms.rectangles",
        r"give one way of drawing rooms, not layout and rectangles",
    ),
    Case("rooms_rectangle_outside.yaml", 9, 31, "rooms.rectangles.study.to", r"cell \[3, 2\] is outside the 3x3 grid"),
    Case(
        "rooms_rectangle_blocked.yaml",
        12,
        14,
        "rooms.rectangles.kitchen",
        r"cell \[1, 1\] of room 'kitchen' is blocked in the layout: room cells must be free",
    ),
    Case(
        "rooms_empty_rectangle.yaml",
        8,
        33,
        "rooms.rectangles.kitchen.to",
        r"the rectangle from \[2, 0\] to \[0, 2\] is empty",
    ),
    Case(
        "rooms_overlap.yaml",
        11,
        9,
        "rooms.rectangles.study[1]",
        r"room 'study' overlaps room 'kitchen' at cell \[2, 1\]",
    ),
]


def _check_message(text: str, path: Path, case: Case) -> None:
    prefix = f"{path}:{case.line}:{case.column}: "
    assert text.startswith(prefix), text
    rest = text[len(prefix) :]
    if case.field is not None:
        assert rest.startswith(f"{case.field}: "), text
        rest = rest[len(case.field) + 2 :]
    assert re.search(case.message, rest), text


def test_every_file_has_a_case():
    assert sorted(p.name for p in INVALID.glob("*.yaml")) == sorted(c.file for c in CASES)
    assert len(CASES) >= 18


@pytest.mark.parametrize("case", CASES, ids=str)
def test_file_says_what_is_broken_on_its_first_line(case: Case):
    first = (INVALID / case.file).read_text(encoding="utf-8").splitlines()[0]
    assert first.startswith("# ")


@pytest.mark.parametrize("case", CASES, ids=str)
def test_load_map_names_file_line_and_field(case: Case):
    path = INVALID / case.file
    with pytest.raises(MapError, match=case.message) as info:
        load_map(path)
    text = str(info.value)
    assert "\n" not in text, "one paragraph"
    assert info.value.exit_code == EXIT_BAD_INPUT
    _check_message(text, path, case)


@pytest.mark.parametrize("case", CASES, ids=str)
def test_cli_validate_exits_2_with_the_message(case: Case, runner, monkeypatch: pytest.MonkeyPatch):
    monkeypatch.chdir(ROOT)
    relative = (INVALID / case.file).relative_to(ROOT)
    result = runner.invoke(app, ["validate", str(relative)])
    assert result.exit_code == EXIT_BAD_INPUT, result.output
    assert isinstance(result.exception, SystemExit), "a traceback, not a message"
    assert "Traceback" not in result.output
    assert result.stdout == ""
    # rich wraps long lines on the terminal (see test_cli_message_is_one_line below): unwrap first
    text = " ".join(result.stderr.split())
    assert text.startswith("error: ")
    _check_message(text.removeprefix("error: "), relative, case)


def test_cli_validate_reports_every_broken_file_and_still_checks_the_good_ones(runner):
    good = ROOT / "maps" / "window-2x2.yaml"
    bad = INVALID / "headings_3.yaml"
    result = runner.invoke(app, ["validate", str(bad), str(good)])
    assert result.exit_code == EXIT_BAD_INPUT
    assert f"ok {good}" in " ".join(result.stdout.split())
    assert f"{bad}:6:13:" in " ".join(result.stderr.split())


def test_missing_file_is_a_message(runner, tmp_path: Path):
    missing = tmp_path / "nowhere.yaml"
    with pytest.raises(MapError, match="no such file"):
        load_map(missing)
    result = runner.invoke(app, ["validate", str(missing)])
    assert result.exit_code == EXIT_BAD_INPUT
    assert isinstance(result.exception, SystemExit)


# --- messages made better after the first version of these tests ---------------------------------


def test_unknown_key_in_a_sensor_lists_the_sensor_keys():
    with pytest.raises(MapError, match=r"unknown key 'rnage'; expected one of: .*\brange\b"):
        load_map(INVALID / "unknown_sensor_key.yaml")


def test_unknown_sensor_type_names_the_type_field():
    path = INVALID / "unknown_sensor_type.yaml"
    with pytest.raises(MapError, match=r"unknown sensor type 'lidar'; expected one of: look, scan, here") as info:
        load_map(path)
    assert str(info.value).startswith(f"{path}:8:11: sensors.ranger.type: ")


def test_sensor_without_type_says_type_is_required():
    with pytest.raises(MapError, match=r"required key 'type' is missing.*look, scan, here"):
        load_map(INVALID / "sensor_without_type.yaml")


def test_yaml_syntax_error_says_where_the_unclosed_mapping_starts():
    with pytest.raises(MapError, match=r"line 3"):
        load_map(INVALID / "yaml_syntax.yaml")


def test_layout_error_points_at_the_offending_row():
    path = INVALID / "layout_row_too_wide.yaml"
    with pytest.raises(MapError, match=rf"^{re.escape(str(path))}:6:"):
        load_map(path)


def test_cli_message_is_one_line(runner, monkeypatch: pytest.MonkeyPatch):
    monkeypatch.chdir(ROOT)
    result = runner.invoke(app, ["validate", "tests/data/invalid/unknown_top_level_key.yaml"])
    assert result.exit_code == EXIT_BAD_INPUT
    assert result.stderr.count("\n") == 1, result.stderr
