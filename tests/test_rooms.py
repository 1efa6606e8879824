"""Rooms on semantic maps (issue 7): the two ways to write them, their cells and states, and how
``beliefloc show`` draws them. Broken rooms are in the table of tests/test_invalid_maps.py."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from rich.console import Console
from typer.testing import CliRunner

from beliefloc.cli.app import app
from beliefloc.errors import FieldError, MapError
from beliefloc.model import GridLayout
from beliefloc.render.room_plan import room_legend, room_plan, room_plan_width
from beliefloc.semantic_map import SemanticMap, compile_model, load_map, room_states

from .conftest import DATA, MAPS

TWO_ROOMS = DATA / "rooms" / "two-rooms.yaml"
APARTMENT = MAPS / "apartment.yaml"


def _map(rooms: dict[str, Any], layout: str | None = None, rows: int = 2, cols: int = 3) -> SemanticMap:
    data: dict[str, Any] = {
        "name": "rooms",
        "grid": {"rows": rows, "cols": cols, "headings": 4},
        "actions": {"forward": {}},
        "rooms": rooms,
    }
    if layout is not None:
        data["layout"] = layout
    return SemanticMap.model_validate(data)


# --- the rooms accessor ---------------------------------------------------------------------------


def test_letter_layout_gives_a_mask_per_room_in_legend_order() -> None:
    smap = _map({"layout": "KK.\nKSS", "legend": {"S": "study", "K": "kitchen"}})
    assert list(smap.rooms) == ["study", "kitchen"]
    assert smap.rooms["kitchen"].tolist() == [[True, True, False], [True, False, False]]
    assert smap.rooms["study"].tolist() == [[False, False, False], [False, True, True]]


def test_digits_are_letters_too() -> None:
    smap = _map({"layout": "12.\n112", "legend": {1: "bedroom", 2: "study"}})
    assert smap.rooms["study"].tolist() == [[False, True, False], [False, False, True]]


def test_rectangles_include_both_corners_and_several_make_one_room() -> None:
    smap = _map({"rectangles": {"hall": [{"from": [0, 0], "to": [1, 0]}, {"from": [0, 1], "to": [0, 2]}]}})
    assert smap.rooms["hall"].tolist() == [[True, True, True], [True, False, False]]


def test_rectangles_of_one_room_may_overlap_each_other() -> None:
    smap = _map({"rectangles": {"hall": [{"from": [0, 0], "to": [1, 1]}, {"from": [1, 1], "to": [1, 2]}]}})
    assert int(smap.rooms["hall"].sum()) == 5


def test_a_map_without_rooms_has_none() -> None:
    assert load_map(MAPS / "kitchen.yaml").rooms == {}


def test_the_apartment_rooms_written_as_rectangles_are_the_same_cells() -> None:
    letters = load_map(APARTMENT)
    data = yaml.safe_load(APARTMENT.read_text(encoding="utf-8"))
    data["rooms"] = {
        "rectangles": {
            "bedroom": {"from": [1, 1], "to": [3, 4]},
            "study": {"from": [1, 6], "to": [3, 11]},
            "corridor": [
                {"from": [5, 1], "to": [5, 11]},
                {"from": [4, 3], "to": [4, 3]},
                {"from": [4, 8], "to": [4, 8]},
                {"from": [6, 4], "to": [6, 4]},
                {"from": [6, 8], "to": [6, 8]},
            ],
            "living_room": {"from": [7, 1], "to": [9, 6]},
            "kitchen": {"from": [7, 8], "to": [9, 11]},
        }
    }
    rectangles = SemanticMap.model_validate(data)
    assert list(rectangles.rooms) == list(letters.rooms)
    for name, mask in letters.rooms.items():
        np.testing.assert_array_equal(rectangles.rooms[name], mask, err_msg=name)


def test_apartment_rooms_cover_every_free_cell_once() -> None:
    smap = load_map(APARTMENT)
    assert list(smap.rooms) == ["bedroom", "study", "corridor", "living_room", "kitchen"]
    count = sum(mask.astype(int) for mask in smap.rooms.values())
    np.testing.assert_array_equal(count, smap.free.astype(int))


def test_cells_in_no_room_are_allowed() -> None:
    smap = load_map(TWO_ROOMS)
    in_rooms = smap.rooms["kitchen"] | smap.rooms["study"]
    assert (smap.free & ~in_rooms).sum() == 1 and (smap.free & ~in_rooms)[1, 2]


# --- room states of a compiled model ---------------------------------------------------------------


def test_room_states_are_every_heading_of_every_cell_of_the_room() -> None:
    smap = load_map(APARTMENT)
    model = compile_model(smap)
    assert model.grid is not None
    states = room_states(smap.rooms, model.grid)
    assert {name: len(s) for name, s in states.items()} == {
        "bedroom": 48,
        "study": 72,
        "corridor": 60,
        "living_room": 72,
        "kitchen": 48,
    }
    names = [model.states.name(int(i)) for i in states["kitchen"]]
    expected = [f"{r},{c},{h}" for r in range(7, 10) for c in range(8, 12) for h in range(4)]
    assert names == expected
    everything = np.sort(np.concatenate(list(states.values())))
    np.testing.assert_array_equal(everything, np.arange(model.n_states))


def test_room_states_refuse_a_grid_of_another_shape_or_a_blocked_cell() -> None:
    mask = np.ones((2, 2), dtype=bool)
    with pytest.raises(ValueError, match=r"drawn on a 2x2 grid, not 3x3"):
        room_states({"hall": mask}, GridLayout(3, 3, 4, 1.0, np.ones((3, 3), dtype=bool)))
    free = np.array([[True, False], [True, True]])
    with pytest.raises(ValueError, match=r"cell \[0, 1\] of room 'hall' is not a free cell"):
        room_states({"hall": mask}, GridLayout(2, 2, 4, 1.0, free))


# --- drawing --------------------------------------------------------------------------------------

TWO_ROOMS_PLAN = """\
    0   1   2   3   4
  ┌───────┐###┌───────┐
0 │       │###│       │ 0
  │       ├───┤       │
1 │kitchen│ · │ study │ 1
  │       ├───┤       │
2 │       │###│       │ 2
  └───────┘###└───────┘"""

TWO_ROOMS_NARROW = """\
   0 1 2 3 4
  ┌───┐#┌───┐
0 │   │#│   │ 0
  │   ├─┤   │
1 │ K │·│ S │ 1
  │   ├─┤   │
2 │   │#│   │ 2
  └───┘#└───┘"""


def _plain(renderable: Any, width: int = 100) -> str:
    console = Console(width=width, color_system=None, record=True)
    console.print(renderable)
    return "\n".join(line.rstrip() for line in console.export_text().splitlines())


def test_room_plan_draws_borders_and_names() -> None:
    smap = load_map(TWO_ROOMS)
    grid = compile_model(smap).grid
    assert grid is not None
    assert _plain(room_plan(grid, smap.rooms, width=80, color=False)) == TWO_ROOMS_PLAN
    assert _plain(room_legend(grid, smap.rooms, width=80)) == (
        "rooms     kitchen 6 cells, study 6 cells, · 1 free cell in no room"
    )


def test_room_plan_writes_letters_when_names_do_not_fit() -> None:
    smap = load_map(TWO_ROOMS)
    grid = compile_model(smap).grid
    assert grid is not None
    assert room_plan_width(grid, 2) > 15 == room_plan_width(grid, 1)
    assert _plain(room_plan(grid, smap.rooms, width=15, color=False)) == TWO_ROOMS_NARROW
    legend = _plain(room_legend(grid, smap.rooms, width=15, letters={"kitchen": "K", "study": "S"}))
    assert legend.splitlines()[0] == "rooms     K kitchen 6 cells,"
    assert "S study 6 cells" in legend


def test_room_plan_uses_the_given_letters() -> None:
    smap = load_map(TWO_ROOMS)
    grid = compile_model(smap).grid
    assert grid is not None
    text = _plain(room_plan(grid, smap.rooms, letters={"kitchen": "x", "study": "y"}, width=15, color=False))
    assert "│ x │·│ y │" in text


def test_room_plan_in_colour_has_the_same_characters() -> None:
    smap = load_map(APARTMENT)
    grid = compile_model(smap).grid
    assert grid is not None
    plain = _plain(room_plan(grid, smap.rooms, width=80, color=False))
    coloured = _plain(room_plan(grid, smap.rooms, width=80, color=True))
    assert coloured == plain.replace("#", "▒")
    assert all(name in plain for name in smap.rooms)


def test_show_draws_the_rooms_of_a_map(runner: CliRunner) -> None:
    out = runner.invoke(app, ["show", str(APARTMENT), "--compact"])
    assert out.exit_code == 0, out.output
    lines = out.stdout.splitlines()
    assert lines[0] == "apartment: 5 rooms"
    assert "living_room" in out.stdout and "┌" in out.stdout and "┘" in out.stdout
    assert "rooms     bedroom 12 cells, study 18 cells, corridor 15 cells, living_room 18 cells, kitchen 12 cells" in (
        out.stdout
    )
    assert "apartment: uniform belief over 300 states" in out.stdout


def test_show_of_a_map_without_rooms_draws_no_plan(runner: CliRunner) -> None:
    out = runner.invoke(app, ["show", str(MAPS / "kitchen.yaml")])
    assert out.exit_code == 0 and "rooms" not in out.stdout and "┌" not in out.stdout


def test_show_of_a_built_model_finds_the_rooms_of_its_map(runner: CliRunner, tmp_path: Path) -> None:
    model_file = tmp_path / "apartment.npz"
    assert runner.invoke(app, ["build", str(APARTMENT), "-o", str(model_file)]).exit_code == 0
    out = runner.invoke(app, ["show", str(model_file), "--compact"])
    assert out.exit_code == 0 and out.stdout.startswith("apartment: 5 rooms")


def test_show_json_gives_the_belief_of_each_room(runner: CliRunner) -> None:
    out = runner.invoke(app, ["show", str(APARTMENT), "--json"])
    rooms = json.loads(out.stdout)["rooms"]
    assert rooms == pytest.approx(
        {"bedroom": 0.16, "study": 0.24, "corridor": 0.2, "living_room": 0.24, "kitchen": 0.16}
    )


def test_the_field_name_behind_rooms_is_not_a_key_of_the_file(tmp_path: Path) -> None:
    path = tmp_path / "internal.yaml"
    path.write_text("name: x\ngrid: {rows: 1, cols: 1}\nactions: {forward: {}}\nroom_spec: {}\n", encoding="utf-8")
    with pytest.raises(
        MapError, match=r"internal\.yaml:4:12: room_spec: unknown key 'room_spec'; expected one of: .*rooms"
    ):
        load_map(path)


@pytest.mark.parametrize(
    ("rooms", "message"),
    [
        ({}, "give layout with a legend"),
        ({"layout": "KK.\nKK."}, r"a room layout needs a legend \({K: kitchen}\)"),
        ({"legend": {"K": "kitchen"}}, "a room layout needs a layout"),
        ({"rectangles": {}}, "no rooms"),
        ({"rectangles": {"hall": []}}, "no rectangle: a room needs at least one cell"),
        (
            {"layout": "K..\n...", "legend": {"K": "kitchen", "k": "kitchen"}},
            "room 'kitchen' already has the letter 'K'",
        ),
        ({"layout": "K..\n...", "legend": {"KK": "kitchen"}}, "'KK' should be one character other than"),
        ({"layout": "K..", "legend": {"K": "kitchen"}}, r"has 1 rows, but grid\.rows is 2"),
    ],
)
def test_other_room_mistakes(rooms: dict[str, Any], message: str) -> None:
    with pytest.raises(FieldError, match=message):
        _map(rooms)
