"""Broken domain files and the message each must give (tests/data/invalid_domains/).

Each case is checked through the library (``load_domain`` raises :class:`DomainError`) and the CLI
(``beliefloc kb check FILE`` exits 2 with ``FILE:LINE:COL: field: message`` and no traceback).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import pytest
from typer.testing import CliRunner

from beliefloc.cli.app import app
from beliefloc.errors import EXIT_BAD_INPUT, DomainError
from beliefloc.knowledge import load_domain

from .conftest import DATA

INVALID = DATA / "invalid_domains"


@dataclass(frozen=True)
class Case:
    file: str
    line: int
    column: int
    message: str

    def __str__(self) -> str:
        return self.file.removesuffix(".yaml")


CASES = [
    Case("unknown_target.yaml", 6, 9, r"target: unknown target class 'printer'; expected one of: book, object"),
    Case("class_cycle.yaml", 5, 6, r"classes\.a: cycle in the class hierarchy: a -> b -> c -> a"),
    Case("object_unknown_room.yaml", 8, 30, r"objects\.book2\.room: unknown room 'garage'; expected one of: kitchen"),
    Case("object_unknown_class.yaml", 7, 17, r"objects\.cup1\.class: unknown class 'cup'"),
    Case("unknown_key.yaml", 6, 1, r"object: unknown key 'object'; expected one of: classes, defaults"),
    Case("unknown_parent.yaml", 5, 9, r"classes\.book: unknown parent class 'objet'"),
    Case("two_roots.yaml", 6, 9, r"classes\.thing: several root classes \(object, thing\)"),
    Case("bad_name.yaml", 2, 9, r"rooms\.Study: should start with a lowercase letter"),
    Case("default_unknown_room.yaml", 9, 11, r"defaults\.books_in_study\.room: unknown room 'libary'"),
    Case("exception_unknown_class.yaml", 10, 29, r"weak_exceptions\[1\]: unknown class 'cokbook'"),
    Case("room_and_class.yaml", 5, 10, r"classes\.study: 'study' is both a room and a class"),
    Case("not_a_mapping.yaml", 1, 1, r"a domain file is a YAML mapping"),
    Case("steps_zero.yaml", 5, 8, r"steps: should be greater than or equal to 1, got 0"),
    # the search: section of object search (issue 6)
    Case(
        "search/unknown_room.yaml",
        7,
        38,
        r"search\.placement\.garage: unknown room 'garage'; expected one of: kitchen, study",
    ),
    Case(
        "search/missing_room.yaml", 7, 14, r"search\.placement: every room needs a place on the plane; missing: kitchen"
    ),
    Case("search/overlap.yaml", 9, 14, r"search\.placement\.kitchen: room 'kitchen' overlaps room 'study'"),
    Case("search/start_outside.yaml", 8, 38, r"search\.robot_start\.cell: cell \[5, 0\] is outside room 'kitchen'"),
    Case("search/even_view.yaml", 9, 18, r"search\.sensor\.view: .*must be odd, got 2"),
    Case("search/rate_out_of_range.yaml", 10, 21, r"search\.sensor\.false_positive: should be less than 1, got 1\.5"),
    Case("search/detector_backwards.yaml", 9, 27, r"search\.sensor\.true_positive: .*0\.2 <= false_positive 0\.3"),
    Case("search/unknown_key.yaml", 9, 3, r"search\.sensr: unknown key 'sensr'; expected one of: costs, existence"),
    # the robot's room (issue 7)
    Case("robot_unknown_room.yaml", 7, 9, r"robot\.dock: unknown room 'garage'; expected one of: kitchen, study"),
    Case("robot_reserved.yaml", 7, 10, r"objects\.robot: 'robot' is the robot itself"),
    Case("robot_weight.yaml", 6, 32, r"robot\.weight: should be less than or equal to 1, got 1\.5"),
    # domains that reference a map (issue 7)
    Case(
        "map/extra_room.yaml",
        6,
        10,
        r"rooms\.garage: the rooms must be those of \S*two-rooms\.yaml \(kitchen, study\); "
        r"not rooms of the map: garage$",
    ),
    Case(
        "map/missing_room.yaml",
        5,
        3,
        r"rooms: the rooms must be those of \S*two-rooms\.yaml \(kitchen, study\); "
        r"rooms of the map missing here: study$",
    ),
    Case("map/map_without_rooms.yaml", 3, 6, r"map: \S*maps/kitchen\.yaml has no rooms: give it a rooms: section"),
    Case(
        "map/map_not_found.yaml", 3, 6, r"map: cannot use the map: \S*invalid_domains/map/two-rooms\.yaml: no such file"
    ),
    Case(
        "map/map_broken.yaml",
        3,
        6,
        r"map: cannot use the map: \S*rooms_overlap\.yaml:11:9: rooms\.rectangles\.study\[1\]: room 'study' overlaps",
    ),
    Case(
        "map/search_placement.yaml",
        9,
        14,
        r"search\.placement: a domain with map: takes every room's cells from the map; drop placement",
    ),
    Case(
        "map/search_start_blocked.yaml", 8, 16, r"search\.robot_start: cell \[0, 2\] is blocked on \S*two-rooms\.yaml"
    ),
    Case(
        "map/search_start_room.yaml",
        8,
        16,
        r"search\.robot_start: with map:, the robot starts on a free cell of the map: write \[row, col\]",
    ),
]


def test_every_file_has_a_case() -> None:
    """Every broken domain has its expected message: here, or (``scene/``) in tests/test_scene_pomdp.py."""
    files = [str(p.relative_to(INVALID)) for p in INVALID.rglob("*.yaml") if p.parent.name != "scene"]
    assert sorted(c.file for c in CASES) == sorted(files)


@pytest.mark.parametrize("case", CASES, ids=str)
def test_library_message(case: Case) -> None:
    path = INVALID / case.file
    with pytest.raises(DomainError) as info:
        load_domain(path)
    prefix = f"{path}:{case.line}:{case.column}: "
    assert str(info.value).startswith(prefix), str(info.value)
    assert re.search(case.message, str(info.value)[len(prefix) :]), str(info.value)


@pytest.mark.parametrize("case", CASES[:4], ids=str)
def test_cli_exit_2(case: Case, runner: CliRunner) -> None:
    out = runner.invoke(app, ["kb", "check", str(INVALID / case.file)])
    assert out.exit_code == EXIT_BAD_INPUT
    assert f":{case.line}:{case.column}: " in out.stderr and "Traceback" not in out.output
