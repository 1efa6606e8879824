"""Object search on a semantic map (issue 7): a domain with ``map:`` searches the map's room cells,
travels along shortest paths round walls, and does not see through walls.

``tests/data/map-search/wall-hides.yaml`` (drawn in its header) is small enough to check by hand:
a pillar and a wall that hide cells, a doorway in no room that the way between the rooms goes through.
"""

from __future__ import annotations

import heapq
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from rich.console import Console
from typer.testing import CliRunner

from beliefloc import compile_model, load_map
from beliefloc.cli.app import app
from beliefloc.errors import EXIT_BAD_INPUT, EXIT_NEGATIVE, DomainError, InvalidValueError
from beliefloc.knowledge import domain_from_data, load_domain
from beliefloc.object_search.domain_space import search_space
from beliefloc.object_search.loop import accuracy
from beliefloc.object_search.map_space import MapSearchSpace
from beliefloc.planning.best_first import plan
from beliefloc.render.search import belief_map, belief_plane

from .conftest import DATA, MAPS, ROOT

HERE = DATA / "map-search"
WALL_MAP = HERE / "wall-hides.yaml"
WALL_DOMAIN = HERE / "wall-hides-domain.yaml"
APARTMENT = ROOT / "domains" / "apartment.yaml"
APARTMENT_PLANE = HERE / "apartment-plane.yaml"


@pytest.fixture(scope="module")
def walls() -> MapSearchSpace:
    space = search_space(load_domain(WALL_DOMAIN))
    assert isinstance(space, MapSearchSpace)
    return space


@pytest.fixture(scope="module")
def apartment() -> MapSearchSpace:
    space = search_space(load_domain(APARTMENT))
    assert isinstance(space, MapSearchSpace)
    return space


def _domain_file(tmp_path: Path, name: str = "d.yaml", **changes: Any) -> Path:
    """wall-hides-domain.yaml with ``changes`` at the top level, next to a copy of its map."""
    data = yaml.safe_load(WALL_DOMAIN.read_text(encoding="utf-8"))
    data.update(changes)
    if not (tmp_path / "wall-hides.yaml").exists():
        (tmp_path / "wall-hides.yaml").write_text(WALL_MAP.read_text(encoding="utf-8"), encoding="utf-8")
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return path


# --- cells and their names -------------------------------------------------------------------------


def test_cells_are_the_free_cells_of_the_rooms(walls: MapSearchSpace) -> None:
    smap = load_map(WALL_MAP)
    assert walls.rooms == ("west", "east")
    assert walls.n_cells == 11 + 12  # the pillar is no cell, nor is the doorway (in no room)
    for cell in range(walls.n_cells):
        r, c = walls.local[cell]
        assert smap.rooms[walls.rooms[walls.room_of_cell[cell]]][r, c]
        assert walls.cell_at[r, c] == cell
    assert walls.cell_at[1, 3] == -1 and walls.free[1, 3] and walls.passable[1, 3]
    # room by room, row-major inside a room
    assert walls.cell_name(0) == "west:0,0" and walls.cell_name(11) == "east:0,4"
    assert walls.cell_name(walls.start) == "west:2,2"


def test_the_apartment_searches_every_cell_of_its_rooms(apartment: MapSearchSpace) -> None:
    smap = load_map(MAPS / "apartment.yaml")
    assert apartment.n_cells == int(smap.free.sum()) == 75  # every free cell is in a room
    counts = {room: len(apartment.cells_of(k)) for k, room in enumerate(apartment.rooms)}
    assert counts == {name: int(mask.sum()) for name, mask in smap.rooms.items()}
    assert apartment.cell_name(apartment.start) == "corridor:5,6"
    assert apartment.room_shape(apartment.rooms.index("kitchen")) == (3, 4)


def test_cell_names_round_trip_in_map_coordinates(apartment: MapSearchSpace) -> None:
    assert all(apartment.parse_cell(apartment.cell_name(i)) == i for i in range(apartment.n_cells))
    kitchen = apartment.parse_cell("kitchen:7,9")
    assert apartment.parse_cell("7,9") == kitchen and tuple(apartment.local[kitchen]) == (7, 9)


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("east:0,0", r"\[0, 0\] is in 'west', not 'east'"),
        ("1,3", r"\[1, 3\] of \S+wall-hides\.yaml is a free cell in no room \(the target is only in rooms\)"),
        ("west:1,1", r"\[1, 1\] of \S+ is blocked"),
        ("4,0", r"\[4, 0\] is outside the 4x7 grid"),
        ("garage:1,1", r"unknown room 'garage'; expected one of: west, east"),
        ("west", r"write ROOM:ROW,COL in the map's rows and columns, e.g. west:2,2"),
    ],
)
def test_bad_cell_names_say_what_is_there(walls: MapSearchSpace, spec: str, message: str) -> None:
    with pytest.raises(InvalidValueError, match=message):
        walls.parse_cell(spec)


# --- views ------------------------------------------------------------------------------------------


def _seen(space: MapSearchSpace, frm: tuple[int, int]) -> set[tuple[int, int]]:
    cell = space.parse_cell(f"{frm[0]},{frm[1]}")
    return {(int(r), int(c)) for r, c in space.local[space.view_cells(cell)]}


def test_walls_hide_cells(walls: MapSearchSpace) -> None:
    from_west_edge = _seen(walls, (1, 0))
    assert (1, 2) not in from_west_edge  # the pillar (1, 1) is straight between
    assert {(1, 0), (2, 0), (0, 0), (3, 1)} <= from_west_edge
    from_middle = _seen(walls, (2, 2))
    assert (2, 4) not in from_middle and (1, 4) not in from_middle  # the wall (2, 3) is between
    assert {(2, 0), (2, 1), (3, 2)} <= from_middle
    # a view is not clipped to the robot's room: through the doorway the robot sees the east room
    assert (1, 4) in _seen(walls, (1, 2))


def test_views_are_in_the_square_and_see_their_own_cell(walls: MapSearchSpace, apartment: MapSearchSpace) -> None:
    for space, half in ((walls, 2), (apartment, 1)):
        views = space.views.toarray().astype(bool)
        assert views[np.arange(space.n_cells), np.arange(space.n_cells)].all()
        near = np.abs(space.local[:, None, :] - space.local[None, :, :]).max(axis=2) <= half
        assert not (views & ~near).any()


def test_without_walls_a_view_is_the_whole_square_across_rooms(tmp_path: Path) -> None:
    smap = yaml.safe_load(WALL_MAP.read_text(encoding="utf-8"))
    del smap["layout"]
    smap["rooms"] = {"rectangles": {"west": {"from": [0, 0], "to": [3, 2]}, "east": {"from": [0, 3], "to": [3, 6]}}}
    (tmp_path / "wall-hides.yaml").write_text(yaml.safe_dump(smap), encoding="utf-8")
    space = search_space(load_domain(_domain_file(tmp_path)))
    near = np.abs(space.local[:, None, :] - space.local[None, :, :]).max(axis=2) <= 2
    np.testing.assert_array_equal(space.views.toarray().astype(bool), near)


# --- travel -----------------------------------------------------------------------------------------


def _plain_shortest_paths(passable: np.ndarray, source: tuple[int, int]) -> dict[tuple[int, int], float]:
    """Dijkstra cell by cell: 8 moves, a diagonal sqrt 2 and only with both cells beside it passable."""
    rows, cols = passable.shape
    best = {source: 0.0}
    heap = [(0.0, source)]
    while heap:
        d, (r, c) = heapq.heappop(heap)
        if d > best[(r, c)]:
            continue
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                r2, c2 = r + dr, c + dc
                if (dr, dc) == (0, 0) or not (0 <= r2 < rows and 0 <= c2 < cols) or not passable[r2, c2]:
                    continue
                if dr and dc and not (passable[r + dr, c] and passable[r, c + dc]):
                    continue
                step = d + (math.sqrt(2.0) if dr and dc else 1.0)
                if step < best.get((r2, c2), math.inf):
                    best[(r2, c2)] = step
                    heapq.heappush(heap, (step, (r2, c2)))
    return best


@pytest.mark.parametrize("name", ["walls", "apartment"])
def test_distances_are_shortest_paths(name: str, request: pytest.FixtureRequest) -> None:
    space: MapSearchSpace = request.getfixturevalue(name)
    for cell in range(space.n_cells):
        plain = _plain_shortest_paths(space.passable, (int(space.local[cell, 0]), int(space.local[cell, 1])))
        expected = [plain.get((int(r), int(c)), math.inf) for r, c in space.local]
        np.testing.assert_allclose(space.distances_from(cell), expected, rtol=1e-12)


def test_the_way_round_a_wall_is_longer_than_the_straight_line(walls: MapSearchSpace) -> None:
    here, behind = walls.parse_cell("2,2"), walls.parse_cell("2,4")
    # (2,2) -> (1,2) -> (1,3) the doorway -> (1,4) -> (2,4): no diagonal past the wall's corners
    assert walls.distances_from(here)[behind] == 4.0
    assert walls.action_costs(here)[behind] == 0.5 * 4.0 + 1.0
    assert accuracy(walls, behind, here) == pytest.approx(math.exp(-(4.0**2) / (2 * 2.0**2)))
    assert not walls.distances_from(here).flags.writeable, "kept distances are read-only"


# --- closed and cut-off rooms, starts, missing sections -----------------------------------------------


def test_a_closed_room_is_neither_entered_nor_seen(tmp_path: Path) -> None:
    space = search_space(load_domain(_domain_file(tmp_path, rooms={"west": {}, "east": {"accessible": False}})))
    assert isinstance(space, MapSearchSpace)
    east = space.room_of_cell == space.rooms.index("east")
    assert not space.reachable[east].any() and space.reachable[~east].all()
    assert np.isinf(space.distances_from(space.start)[east]).all()
    assert space.views[:, np.flatnonzero(east)].nnz == 0 and space.views[np.flatnonzero(east)].nnz == 0
    assert space.passable[1, 3], "the doorway, in no room, stays passable"


def test_a_start_in_a_closed_room_is_refused(tmp_path: Path) -> None:
    path = _domain_file(tmp_path, rooms={"west": {"accessible": False}, "east": {}})
    with pytest.raises(DomainError, match="the robot starts in 'west', a room marked 'accessible: false'"):
        search_space(load_domain(path))


def test_a_room_cut_off_from_the_start_is_an_error(tmp_path: Path) -> None:
    smap = yaml.safe_load(WALL_MAP.read_text(encoding="utf-8"))
    smap["layout"] = smap["layout"].replace(".#.....", ".#.#...")  # wall up the doorway
    smap["rooms"]["layout"] = smap["rooms"]["layout"].replace("W#W.EEE", "W#W#EEE")
    (tmp_path / "wall-hides.yaml").write_text(yaml.safe_dump(smap), encoding="utf-8")
    with pytest.raises(DomainError, match=r"cell \[0, 4\] of room 'east' cannot be reached from the robot's start"):
        search_space(load_domain(_domain_file(tmp_path)))


def test_a_start_in_no_room_is_a_domain_error_at_its_line(tmp_path: Path) -> None:
    path = _domain_file(tmp_path, search={"robot_start": [1, 3]})
    with pytest.raises(DomainError, match=r"d\.yaml:\d+:\d+: search\.robot_start: cell \[1, 3\] is in no room of"):
        load_domain(path)


def test_a_map_domain_without_search_says_so(runner: CliRunner) -> None:
    path = DATA / "rooms" / "two-rooms-domain.yaml"
    with pytest.raises(DomainError, match=r"is on the map \S+two-rooms\.yaml but has no 'search:' section"):
        search_space(load_domain(path))
    out = runner.invoke(app, ["search", "run", str(path), "--target", "cup"])
    assert out.exit_code == EXIT_BAD_INPUT and "robot_start: [row, col]" in " ".join(out.stderr.split())


def test_a_domain_with_neither_search_nor_map_names_both() -> None:
    domain = domain_from_data({"name": "bare", "rooms": ["a"], "classes": {"object": None}})
    with pytest.raises(DomainError, match=r"either a 'search:' section that places the rooms .* or 'map:'"):
        search_space(domain)


# --- the command line ---------------------------------------------------------------------------------


def test_search_run_on_the_apartment_is_reproducible(runner: CliRunner) -> None:
    args = ["search", "run", str(APARTMENT), "--seed", "4", "--json", "--no-timings"]
    first, second = runner.invoke(app, args), runner.invoke(app, args)
    assert first.exit_code in (0, EXIT_NEGATIVE), first.output
    assert first.stdout == second.stdout and first.exit_code == second.exit_code
    data = json.loads(first.stdout)
    assert (first.exit_code == 0) == (data["verdict"] == "found")
    assert list(data["room_prior"]) == ["bedroom", "study", "corridor", "living_room", "kitchen"]
    assert all(step["view"].split(":")[0] in data["room_prior"] for step in data["steps"])


@pytest.mark.parametrize("cell", ["kitchen:7,9", "7,9"])
def test_search_run_puts_the_target_on_a_map_cell(runner: CliRunner, cell: str) -> None:
    out = runner.invoke(app, ["search", "run", str(APARTMENT), "--target-cell", cell, "--json", "--no-timings"])
    assert out.exit_code in (0, EXIT_NEGATIVE), out.output
    assert json.loads(out.stdout)["true_cell"] == "kitchen:7,9"


def test_search_run_refuses_a_wall_for_a_target(runner: CliRunner) -> None:
    out = runner.invoke(app, ["search", "run", str(APARTMENT), "--target-cell", "kitchen:7,7"])
    assert out.exit_code == EXIT_BAD_INPUT and "Traceback" not in out.output
    assert "[7, 7] of" in out.stderr and "is blocked" in out.stderr


def test_search_run_show_draws_the_map(runner: CliRunner) -> None:
    out = runner.invoke(app, ["search", "run", str(APARTMENT), "--seed", "0", "--show"])
    assert out.exit_code in (0, EXIT_NEGATIVE), out.output
    lines = out.stdout.splitlines()
    assert any(line.startswith(" 5 ") and line.endswith(" 5") for line in lines), "row numbers on both sides"
    assert "b bedroom" in out.stdout and "k kitchen" in out.stdout


def test_search_simulate_on_the_apartment_is_reproducible(runner: CliRunner) -> None:
    args = ["search", "simulate", str(APARTMENT), "-n", "3", "-p", "pomdp,greedy", "--json", "--no-timings"]
    first, second = runner.invoke(app, args), runner.invoke(app, args)
    assert first.exit_code == 0, first.output
    assert first.stdout == second.stdout
    data = json.loads(first.stdout)
    assert data["settings"]["time_limit"] == 100 and data["summary"]["pomdp/expectation/static/reuse"]["trials"] == 3
    for record in data["records"]:
        room, _, where = record["true_cell"].partition(":")
        r, c = (int(x) for x in where.split(","))
        assert room == record["true_room"] and load_map(MAPS / "apartment.yaml").rooms[room][r, c]


# --- drawing ------------------------------------------------------------------------------------------


def test_the_belief_is_drawn_on_the_map(walls: MapSearchSpace) -> None:
    belief = np.zeros(walls.n_cells)
    belief[walls.parse_cell("east:0,6")] = 1.0
    text = belief_plane(walls, belief, robot=walls.start, color=False)
    assert text.plain == belief_map(walls, belief, robot=walls.start, color=False).plain
    console = Console(width=80, color_system=None)
    with console.capture() as capture:
        console.print(text)
    lines = capture.get().splitlines()
    assert lines[0] == "  0 1 2 3 4 5 6 "
    assert lines[1] == "0 .w.w.w##.e.e█* 0"  # all the belief on the most likely cell
    assert lines[2] == "1 .w##.w· .e.e.e 1"  # the pillar, the doorway in no room
    assert lines[3] == "2 .w.w.R##.e.e.e 2"
    assert lines[5].startswith("rooms: w west 0.000, e east 1.000; max b 1.000 at east:0,6")


# --- the benchmark's plane twin, validate, the prior through plan ------------------------------------------


def test_the_plane_twin_of_the_apartment_differs_only_in_geometry() -> None:
    on_map, on_plane = load_domain(APARTMENT), load_domain(APARTMENT_PLANE)
    for key in ("rooms", "classes", "objects", "defaults", "target", "robot", "steps", "kb"):
        assert getattr(on_plane, key) == getattr(on_map, key), key
    assert on_plane.search is not None and on_map.map_search is not None
    for key in ("sensor", "costs", "time_limit", "existence", "tau_found", "tau_absent"):
        assert getattr(on_plane.search, key) == getattr(on_map.map_search, key), key
    smap = load_map(MAPS / "apartment.yaml")
    for room, mask in smap.rooms.items():
        rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
        if room != "corridor":  # the one room that is no rectangle
            assert on_plane.search.size_of(room) == (len(rows), len(cols)), room
            assert on_plane.search.placement[room] == (rows[0], cols[0]), room


def test_validate_mentions_the_rooms(runner: CliRunner) -> None:
    out = runner.invoke(app, ["validate", str(MAPS / "apartment.yaml"), str(DATA / "rooms" / "two-rooms.yaml")])
    assert out.exit_code == 0, out.output
    text = " ".join(out.stdout.split())
    assert "5 rooms (bedroom, study, corridor, living_room, kitchen)" in text
    assert "2 rooms (kitchen, study) and 1 free cell in no room" in text
    data = json.loads(runner.invoke(app, ["validate", "--json", str(MAPS / "apartment.yaml")]).stdout)
    assert data[0]["rooms"] == {"bedroom": 12, "study": 18, "corridor": 15, "living_room": 18, "kitchen": 12}
    kitchen = runner.invoke(app, ["validate", str(MAPS / "kitchen.yaml")])
    assert "room" not in kitchen.stdout


def test_plan_from_the_prior_starts_with_0_9_over_the_kitchen(runner: CliRunner) -> None:
    """The CLI's start belief is the rule's, built here by hand from the map's room masks: the
    kitchen's 48 states share 0.9, the other rooms 0.025 each over their states."""
    smap = load_map(MAPS / "apartment.yaml")
    model = compile_model(smap)
    belief = np.zeros(model.n_states)
    for index, name in enumerate(model.states):
        r, c, _ = (int(x) for x in name.split(","))
        room = next(room for room, mask in smap.rooms.items() if mask[r, c])
        share = 0.9 if room == "kitchen" else 0.025
        belief[index] = share / (4 * int(smap.rooms[room].sum()))
    expected = plan(model, belief)
    out = runner.invoke(app, ["plan", str(MAPS / "apartment.yaml"), "--belief", f"prior:{APARTMENT}", "--json"])
    assert out.exit_code == 0, out.output
    data = json.loads(out.stdout)
    assert data["cost"] == expected.cost != plan(model, np.full(model.n_states, 1 / model.n_states)).cost
    assert [(s["action"], s["observation"]) for s in data["steps"]] == [
        (s.action, s.observation) for s in expected.steps
    ]
    np.testing.assert_allclose([s["max_belief"] for s in data["steps"]], [s.max_belief for s in expected.steps])
