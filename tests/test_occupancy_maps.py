"""Semantic maps on ROS/Nav2 occupancy maps: the grid, landmarks in metres, rooms from a mask or
polygons, sensors that see the pixels, the bundled depot and TurtleBot3 arena, and every bad input
as one message naming file, line and field."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from typer.testing import CliRunner

from beliefloc.cli.app import app
from beliefloc.errors import MapError
from beliefloc.semantic_map import compile_model, load_map

from .conftest import MAPS

FREE, WALL, GREY = 254, 0, 205


def _occupancy(
    folder: Path,
    pixels: np.ndarray,
    *,
    name: str = "room",
    origin: str = "[0.0, 0.0, 0.0]",
    resolution: float = 0.1,
    free_thresh: float = 0.196,
    extra: str = "",
) -> Path:
    Image.fromarray(pixels.astype(np.uint8)).save(folder / f"{name}.pgm")
    path = folder / f"{name}.yaml"
    path.write_text(
        f"image: {name}.pgm\nresolution: {resolution}\norigin: {origin}\nnegate: 0\n"
        f"occupied_thresh: 0.65\nfree_thresh: {free_thresh}\n{extra}",
        encoding="utf-8",
    )
    return path


def _room(height: int = 20, width: int = 30) -> np.ndarray:
    """A room of ``height x width`` pixels with a one-pixel wall all round and an inner wall."""
    pixels = np.full((height, width), FREE)
    pixels[0, :] = pixels[-1, :] = pixels[:, 0] = pixels[:, -1] = WALL
    pixels[5:15, 15] = WALL  # from pixel row 5 to 14, column 15 (x 1.5-1.6 m)
    return pixels


def _map(folder: Path, body: str, *, occupancy: str = "room.yaml") -> Path:
    path = folder / "map.yaml"
    path.write_text(
        f"""name: test
occupancy: {occupancy}
grid: {{cell_size: 0.5, headings: 4}}
actions:
  forward: {{cost: 1}}
  rotate_cw: {{cost: 1}}
{body}""",
        encoding="utf-8",
    )
    return path


@pytest.fixture
def room(tmp_path: Path) -> Path:
    _occupancy(tmp_path, _room())
    return tmp_path


# --- the grid ---------------------------------------------------------------------------------------


def test_the_grid_comes_from_the_image(room: Path) -> None:
    """30 x 20 pixels of 0.1 m under cells of 0.5 m: 6 columns and 4 rows; a cell is free when all
    its 25 pixels are: the border cells touch the wall pixels, the inner wall takes two more."""
    smap = load_map(_map(room, ""))
    assert (smap.grid.rows, smap.grid.cols) == (4, 6)
    expected = np.zeros((4, 6), dtype=bool)
    expected[1:3, 1:5] = True
    expected[1:3, 3] = False  # the inner wall's pixel column 15 lies in cell column 3 (x 1.5-2.0 m)
    assert smap.free.tolist() == expected.tolist()
    assert compile_model(smap).n_states == 6 * 4


def test_the_robot_radius_keeps_it_from_the_walls(room: Path) -> None:
    """Cell (1, 2) has its centre at (1.25, 1.25) m: 0.3 m from the inner wall's pixel centres at
    x = 1.55 m, so it stays a state for a radius of 0.29 m and not for 0.31 m."""
    body = ""
    path = _map(room, body)
    text = path.read_text(encoding="utf-8").replace("headings: 4}", "headings: 4, robot_radius: 0.29}")
    path.write_text(text, encoding="utf-8")
    assert load_map(path).free[1, 2]
    path.write_text(text.replace("0.29", "0.31"), encoding="utf-8")
    assert not load_map(path).free[1, 2]


def test_the_frame_is_the_maps_origin_and_rotates(tmp_path: Path) -> None:
    _occupancy(tmp_path, _room(), origin="[2.0, 3.0, 1.0]")
    smap = load_map(
        _map(
            tmp_path,
            "landmarks:\n  - {{class: box, x: {!r}, y: {!r}}}\n".format(*_rotated(0.75, 0.75)),
        )
    )
    assert smap.frame.yaw == 1.0 and (smap.frame.x, smap.frame.y) == (2.0, 3.0)
    model = compile_model(smap)
    assert model.grid is not None and model.grid.frame == smap.frame
    # grid-frame (0.75, 0.75) m is cell column 1, row 4 - 1 - 1 = 2
    assert smap.landmarks[0].cell == (2, 1)
    x, y = model.grid.cell_centre(2, 1)
    assert (float(x), float(y)) == pytest.approx(_rotated(0.75, 0.75))


def _rotated(gx: float, gy: float) -> tuple[float, float]:
    c, s = math.cos(1.0), math.sin(1.0)
    return 2.0 + c * gx - s * gy, 3.0 + s * gx + c * gy


# --- landmarks and sensors ---------------------------------------------------------------------------


def test_landmarks_in_metres_get_their_cell_and_are_seen_through_the_pixels(room: Path) -> None:
    """A box at (2.25, 1.25) m, behind the inner wall (x 1.5-1.6 m, y 0.5-1.5 m) seen from the west."""
    body = """landmarks:
  - {class: box, x: 2.25, y: 1.25}
sensors:
  look: {type: look, classes: [box], fov: 90, range: 5}
"""
    smap = load_map(_map(room, body))
    assert smap.landmarks[0].cell == (1, 4)
    model = compile_model(smap)
    look = model.action("look").observation.parts[0]
    behind_the_wall = model.states.index("1,1,1")  # facing east from (0.75, 1.25): the wall is in between
    assert look.truth[behind_the_wall] == 0
    beside = model.states.index("1,4,0")  # the box's own cell sees it from every heading
    assert look.truth[beside] == 1


def test_a_scan_reads_the_pixels(room: Path) -> None:
    """From cell (2, 1) (centre (0.75, 0.75) m) facing east the ray enters the inner wall's pixel
    column at x = 1.5 m: 0.75 m; facing north the wall row at y = 1.9 m: 1.15 m."""
    body = "sensors:\n  scan: {type: scan, bins: [0.5, 1.0, 1.5]}\n"
    model = compile_model(load_map(_map(room, body)))
    scan = model.action("scan").observation
    east, north = model.states.index("2,1,1"), model.states.index("2,1,0")
    assert scan.name(scan.true_observation(east)) == "wall_0.5-1"
    assert scan.name(scan.true_observation(north)) == "wall_1-1.5"


# --- rooms -------------------------------------------------------------------------------------------


def test_rooms_from_a_region_mask(room: Path) -> None:
    mask = np.zeros((20, 30))
    mask[:, :15] = 1
    mask[:, 15:] = 2
    _occupancy(room, mask, name="rooms", extra="mode: raw\n")
    smap = load_map(_map(room, "rooms:\n  mask: rooms.yaml\n  labels: {1: west, 2: east}\n"))
    assert smap.rooms["west"].sum() == 4 and smap.rooms["east"].sum() == 2
    assert not (smap.rooms["west"] & smap.rooms["east"]).any()


def test_rooms_from_polygons(room: Path) -> None:
    body = (
        "rooms:\n  polygons:\n    west: [[0, 0], [1.5, 0], [1.5, 2], [0, 2]]\n"
        "    east: [[2, 0], [3, 0], [3, 2], [2, 2]]\n"
    )
    smap = load_map(_map(room, body))
    assert smap.rooms["west"].sum() == 4 and smap.rooms["east"].sum() == 2


# --- bad input: one message naming file, line and field -------------------------------------------


@pytest.mark.parametrize(
    ("body", "occupancy", "message"),
    [
        ("", "nowhere.yaml", r"map\.yaml:2:\d+: occupancy: nowhere\.yaml: .* does not exist"),
        ("layout: |\n  ..\n", "room.yaml", r"map\.yaml:\d+:\d+: layout: a map with occupancy: takes its free cells"),
        (
            "landmarks:\n  - {class: box, x: 1.55, y: 1.0}\n",
            "room.yaml",
            r"landmarks\[0\]\.x: \(1\.55, 1\) is on an occupied",
        ),
        ("landmarks:\n  - {class: box, x: 9.0, y: 1.0}\n", "room.yaml", r"landmarks\[0\]\.x: \(9, 1\) is off the map"),
        ("landmarks:\n  - {class: box, x: 1.0}\n", "room.yaml", r"landmarks\[0\]: has x but no y"),
        (
            "occupancy_rule: ros\n",
            "room.yaml",
            r"occupancy_rule: should be one of: beliefloc, nav2, nav2-humble, nav2-jazzy; got 'ros'",
        ),
        ("rooms:\n  labels: {1: a}\n", "room.yaml", r"rooms: a region mask needs both mask and labels"),
        (
            "rooms:\n  polygons:\n    a: [[0, 0], [1, 0]]\n",
            "room.yaml",
            r"rooms\.polygons\.a: room 'a' needs at least three",
        ),
    ],
    ids=["missing", "layout", "on-wall", "off-map", "x-only", "rule", "mask-labels", "polygon"],
)
def test_bad_input_names_the_place(room: Path, body: str, occupancy: str, message: str) -> None:
    with pytest.raises(MapError, match=message):
        load_map(_map(room, body, occupancy=occupancy))


def test_rows_and_cols_come_from_the_image(room: Path) -> None:
    path = _map(room, "")
    path.write_text(path.read_text(encoding="utf-8").replace("grid: {", "grid: {rows: 3, "), encoding="utf-8")
    with pytest.raises(MapError, match=r"map\.yaml:3:\d+: grid\.rows: comes from the occupancy image"):
        load_map(path)


def test_a_robot_radius_needs_an_occupancy_map(tmp_path: Path) -> None:
    path = tmp_path / "hand.yaml"
    path.write_text(
        "name: hand\ngrid: {rows: 2, cols: 2, robot_radius: 0.2}\nactions:\n  forward: {cost: 1}\n", encoding="utf-8"
    )
    with pytest.raises(MapError, match=r"grid\.robot_radius: applies to a map with occupancy"):
        load_map(path)


def test_no_free_cell_at_this_cell_size(room: Path) -> None:
    path = _map(room, "")
    path.write_text(path.read_text(encoding="utf-8").replace("cell_size: 0.5", "cell_size: 2.0"), encoding="utf-8")
    with pytest.raises(MapError, match=r"grid\.cell_size: no cell of 2 m has only free pixels"):
        load_map(path)


def test_a_mask_that_does_not_fit_names_both_files(room: Path) -> None:
    _occupancy(room, np.ones((20, 30)), name="rooms", resolution=0.05, extra="mode: raw\n")
    with pytest.raises(MapError, match=r"rooms\.yaml.*room\.yaml|room\.yaml.*rooms\.yaml"):
        load_map(_map(room, "rooms:\n  mask: rooms.yaml\n  labels: {1: all}\n"))


def test_the_cli_says_it_in_one_paragraph_and_writes_nothing(room: Path, tmp_path: Path) -> None:
    path = _map(room, "landmarks:\n  - {class: box, x: 9.0, y: 1.0}\n")
    out = tmp_path / "model.npz"
    result = CliRunner().invoke(app, ["build", str(path), "-o", str(out)])
    assert result.exit_code == 2
    assert "is off the map" in result.stderr and "Traceback" not in result.output
    assert not out.exists()


# --- the saver's grey and the bundled maps ------------------------------------------------------


def test_the_savers_grey_is_unknown_unless_the_map_says_nav2(tmp_path: Path) -> None:
    """A strip of grey 205 beside the room under free_thresh 0.25 (Nav2's default): beliefloc reads
    it as unknown and warns; occupancy_rule: nav2 reads it as free."""
    pixels = np.full((10, 20), FREE)
    pixels[:, 10:] = GREY
    _occupancy(tmp_path, pixels, free_thresh=0.25)
    warnings: list[str] = []
    smap = load_map(_map(tmp_path, ""), on_warning=warnings.append)
    assert not smap.free[:, 2:].any() and smap.free[:, :2].any()
    assert len(warnings) == 1 and "100 pixels" in warnings[0] and "occupancy_rule: nav2" in warnings[0]
    nav2 = load_map(_map(tmp_path, "occupancy_rule: nav2\n"), on_warning=warnings.append)
    assert nav2.free[:, 2:].any() and len(warnings) == 1


def test_the_map_file_names_the_nav2_release_it_reads_as(tmp_path: Path) -> None:
    """A strip of grey 153 under free_thresh 0.4: occ = 1 - 153/255 = 0.4, on the threshold. Jazzy
    (<= in float32) reads it free, Humble (< in double) unknown; nav2 is Jazzy, and so is the default."""
    pixels = np.full((10, 20), FREE)
    pixels[:, 10:] = 153
    _occupancy(tmp_path, pixels, free_thresh=0.4)
    strip_free = {}
    for rule in ("", "beliefloc", "nav2", "nav2-jazzy", "nav2-humble"):
        smap = load_map(_map(tmp_path, f"occupancy_rule: {rule}\n" if rule else ""))
        assert smap.free[:, :2].any()
        strip_free[rule] = bool(smap.free[:, 2:].any())
    assert strip_free == {"": True, "beliefloc": True, "nav2": True, "nav2-jazzy": True, "nav2-humble": False}


def test_the_depot_as_shipped() -> None:
    warnings: list[str] = []
    smap = load_map(MAPS / "depot.yaml", on_warning=warnings.append)
    assert (smap.grid.rows, smap.grid.cols) == (62, 121)  # 15.35 m x 30.2 m under 0.25 m cells
    assert "8894 pixels" in warnings[0]
    assert set(smap.rooms) == {"open_floor", "pillar_hall", "shelves"}
    assert all(mask.any() for mask in smap.rooms.values())
    model = compile_model(smap)
    assert model.n_states == int(smap.free.sum()) * 8
    # every landmark sits on a free pixel of its cell
    for landmark in smap.landmarks:
        assert landmark.position is not None
        row, col = model.grid.cell_at(*landmark.position) if model.grid else (None, None)
        assert (int(row), int(col)) == landmark.cell


def test_the_cli_localizes_on_the_arena(tmp_path: Path) -> None:
    """tb3-sandbox.yaml is localizable, as its comment says: macros build exits 0."""
    result = CliRunner().invoke(app, ["macros", "build", str(MAPS / "tb3-sandbox.yaml"), "-o", str(tmp_path / "m.npz")])
    assert result.exit_code == 0, result.output
    assert "localizable: every pair of states can be told apart" in " ".join(result.stdout.split())


def test_the_readmes_slam_map_example_validates(tmp_path: Path) -> None:
    """The README's "Your own SLAM map" file, pointed at the depot's occupancy map, is a valid map."""
    readme = (MAPS.parent / "README.md").read_text(encoding="utf-8")
    section = readme[readme.index("## Your own SLAM map") :]
    block = section[section.index("```yaml\n") + len("```yaml\n") : section.index("```\n", section.index("```yaml"))]
    occupancy = MAPS / "occupancy" / "depot.yaml"
    (tmp_path / "lab-beliefloc.yaml").write_text(block.replace("lab.yaml", str(occupancy)), encoding="utf-8")
    smap = load_map(tmp_path / "lab-beliefloc.yaml")
    assert smap.name == "lab" and compile_model(smap).n_states > 0
