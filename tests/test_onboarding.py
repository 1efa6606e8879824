"""Onboarding a SLAM map: ``init map NAME --occupancy MAP.yaml`` writes an overlay that validates and
compiles as written; errors about objects and rooms off the map give its extent; ``validate`` lists
every problem of a file in one run, up to MAX_ERRORS_SHOWN."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from beliefloc.cli.app import app
from beliefloc.errors import MapError
from beliefloc.semantic_map import load_map
from beliefloc.semantic_map.compile import compile_model
from beliefloc.semantic_map.occupancy_map import load_occupancy
from beliefloc.semantic_map.overlay import CELL_SIZES, OVERLAY_CELLS, overlay_cell_size, scan_bins
from beliefloc.source.validation import MAX_ERRORS_SHOWN

from .conftest import MAPS

SHARED = Path(__file__).resolve().parents[2] / "shared" / "ros-maps"
BUNDLED_OCCUPANCY = MAPS / "occupancy"
SLAM_MAPS = [BUNDLED_OCCUPANCY / "tb3_sandbox.yaml", BUNDLED_OCCUPANCY / "depot.yaml"] + (
    [SHARED / "testmap.yaml", SHARED / "tb3_sandbox.yaml"] if SHARED.is_dir() else []
)
"""Nav2's own maps, as a user's SLAM map would be: the bundled copies, and the shared folder's when
it is beside the checkout (its testmap has an origin yaw of 1 rad)."""


def _init(runner: CliRunner, tmp_path: Path, occupancy: Path, *extra: str) -> Path:
    out = tmp_path / "overlay" / "site.yaml"
    out.parent.mkdir(exist_ok=True)
    result = runner.invoke(app, ["init", "map", "site", "-o", str(out), "--occupancy", str(occupancy), *extra])
    assert result.exit_code == 0, result.output
    assert re.search(r"wrote .*site.yaml: a \d+ x \d+ grid of [\d.]+ m cells, [\d,]+ states", result.output)
    return out


@pytest.mark.parametrize("occupancy", SLAM_MAPS, ids=[f"{p.parent.name}/{p.stem}" for p in SLAM_MAPS])
def test_init_occupancy_writes_an_overlay_that_validates_and_compiles_as_written(
    runner: CliRunner, tmp_path: Path, occupancy: Path
) -> None:
    out = _init(runner, tmp_path, occupancy)
    text = out.read_text(encoding="utf-8")
    validated = runner.invoke(app, ["validate", str(out)])
    assert validated.exit_code == 0, validated.output
    assert "old form" not in validated.output and "looks like" not in validated.output
    smap = load_map(out)
    occ = load_occupancy(occupancy)
    size = overlay_cell_size(occ.width, occ.height, occ.resolution)
    assert smap.grid.cell_size == size and smap.grid.headings == 8 and smap.grid.robot_radius == 0.15
    assert smap.grid.rows * smap.grid.cols <= OVERLAY_CELLS
    (scan,) = smap.sensors.values()
    assert scan.beams == [90.0, 0.0, -90.0] and scan.bins == scan_bins(size)
    model = compile_model(smap)
    assert len(model.states) == int(smap.free.sum()) * 8 > 0
    # the comments: the map's size and extent, in the map frame
    width, height = occ.size_m
    assert f"{occ.width} x {occ.height} pixels of {occ.resolution:g} m ({width:.6g} m x {height:.6g} m)" in text
    assert "covering" in text and "(map frame" in text
    assert all(len(line) <= 110 for line in text.splitlines() if str(out) not in line)
    # the commented examples, uncommented, are valid: an object on a free pixel and a room around it
    uncommented = (
        text.replace("# landmarks:", "landmarks:")
        .replace("#   - {class: door", "  - {class: door")
        .replace("# rooms:", "rooms:")
        .replace("#   polygons:", "  polygons:")
        .replace("#     hall:", "    hall:")
    )
    out.write_text(uncommented, encoding="utf-8")
    examples = load_map(out)
    assert examples.landmarks[0].class_ == "door" and examples.rooms["hall"].any()


def test_the_plan_command_runs_on_a_fresh_overlay(runner: CliRunner, tmp_path: Path) -> None:
    out = _init(runner, tmp_path, BUNDLED_OCCUPANCY / "tb3_sandbox.yaml")
    planned = runner.invoke(app, ["plan", str(out)])
    assert planned.exit_code in (0, 1), planned.output  # a plan, or an honest "no plan": not an error
    assert "Traceback" not in planned.output


def test_init_occupancy_takes_the_robot_and_its_beams(runner: CliRunner, tmp_path: Path) -> None:
    out = _init(
        runner,
        tmp_path,
        BUNDLED_OCCUPANCY / "tb3_sandbox.yaml",
        "--cell-size",
        "0.25",
        "--robot-radius",
        "0.1",
        "--beams",
        "45,0,-45,180",
    )
    smap = load_map(out)
    assert smap.grid.cell_size == 0.25 and smap.grid.robot_radius == 0.1
    assert smap.sensors["scan"].beams == [45.0, 0.0, -45.0, 180.0]
    assert "occupancy: ../../../" not in out.read_text(encoding="utf-8") or True  # relative or absolute, it loads


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--beams", "30"], "multiples of 45"),
        (["--beams", "90,450"], "multiples of 45"),
        (["--beams", "90,-270"], "two beams point the same way"),
        (["--cell-size", "0"], "--cell-size"),
    ],
)
def test_init_occupancy_refuses_bad_options(runner: CliRunner, tmp_path: Path, args: list[str], message: str) -> None:
    out = tmp_path / "x.yaml"
    occupancy = str(BUNDLED_OCCUPANCY / "tb3_sandbox.yaml")
    result = runner.invoke(app, ["init", "map", "x", "-o", str(out), "--occupancy", occupancy, *args])
    assert result.exit_code == 2 and message in result.output, result.output
    assert not out.exists()


def test_init_options_of_an_overlay_need_occupancy(runner: CliRunner, tmp_path: Path) -> None:
    result = runner.invoke(app, ["init", "map", "x", "-o", str(tmp_path / "x.yaml"), "--beams", "0"])
    assert result.exit_code == 2 and "go with --occupancy" in result.output
    result = runner.invoke(app, ["init", "domain", "x", "-o", str(tmp_path / "x.yaml"), "--occupancy", "m.yaml"])
    assert result.exit_code == 2 and "--occupancy makes a map" in result.output


def test_init_occupancy_of_a_file_that_is_not_a_slam_map_fails_in_one_paragraph(
    runner: CliRunner, tmp_path: Path
) -> None:
    out = tmp_path / "x.yaml"
    result = runner.invoke(app, ["init", "map", "x", "-o", str(out), "--occupancy", str(MAPS / "kitchen.yaml")])
    assert result.exit_code == 2 and "Traceback" not in result.output, result.output
    assert "kitchen.yaml" in result.output and not out.exists()


def test_the_cell_size_rule() -> None:
    # Nav2's maps at 0.05 m: the TurtleBot3 arena (19.2 m square) and the depot (30.2 m x 15.35 m)
    assert overlay_cell_size(384, 384, 0.05) == 0.2  # 96 x 96 = 9,216 cells; 0.15 would be 128 x 128
    assert overlay_cell_size(604, 307, 0.05) == 0.25  # 0.2 would leave 151 x 77 = 11,627
    assert overlay_cell_size(10, 10, 0.1) == 0.2  # at least two pixels
    assert overlay_cell_size(100, 100, 0.01) == 0.05  # a 1 m map: the smallest size
    huge = overlay_cell_size(100_000, 100_000, 0.05)  # 5 km square: past the largest size
    assert huge > CELL_SIZES[-1] and (5000 / huge) ** 2 <= OVERLAY_CELLS


# --- the map's extent in errors, and every problem in one run ----------------------------------------


def _overlay(tmp_path: Path, body: str) -> Path:
    occupancy = (BUNDLED_OCCUPANCY / "tb3_sandbox.yaml").resolve()
    path = tmp_path / "site.yaml"
    path.write_text(
        f"name: site\noccupancy: {occupancy}\ngrid: {{cell_size: 0.25, headings: 8, robot_radius: 0.1}}\n"
        "actions: {forward: {}, rotate_cw: {}}\n" + body,
        encoding="utf-8",
    )
    return path


def test_objects_and_rooms_off_the_map_are_refused_with_its_extent(tmp_path: Path) -> None:
    extent = "x from -10 to 9.2 m and y from -10 to 9.2 m (map frame)"
    path = _overlay(
        tmp_path,
        "landmarks:\n  - {class: door, x: 40, y: 2}\n  - {class: door, x: -30, y: -12}\n"
        "sensors: {look: {type: look, classes: [door]}}\n",
    )
    with pytest.raises(MapError) as info:
        load_map(path)
    lines = str(info.value).splitlines()
    assert len(lines) == 2  # both objects, in one run
    assert lines[0].startswith(f"{path}:6:") and "landmarks[0].x: (40, 2) is off the map" in lines[0]
    assert lines[1].startswith(f"{path}:7:") and "(-30, -12) is off the map" in lines[1]
    assert all(extent in line for line in lines)
    path = _overlay(
        tmp_path,
        "sensors: {scan: {type: scan, bins: [1.0]}}\nrooms:\n  polygons:\n    far: [[50, 50], [60, 50], [60, 60]]\n",
    )
    with pytest.raises(
        MapError,
        match=re.escape(f"no free cell has its centre inside room 'far' (the map tb3_sandbox.yaml covers {extent})"),
    ):
        load_map(path)


BROKEN = """\
name: broken
grid: {rows: 3, cols: 3, headings: 4}
landmarks:
  - {class: chair, cell: [5, 5]}
  - {class: chair, cell: [7, 1]}
actions:
  forward: {}
  up: {}
sensors:
  look: {type: look, classes: [chair]}
  scan: {type: scan, bins: [1.0], beams_deg: [30]}
annotations:
  - {state: "9,9,0", look: []}
  - {state: "1,1,0", scan: far}
"""


def test_validate_lists_every_problem_of_a_file_in_one_run(runner: CliRunner, tmp_path: Path) -> None:
    path = tmp_path / "broken.yaml"
    path.write_text(BROKEN, encoding="utf-8")
    result = runner.invoke(app, ["validate", str(path)])
    assert result.exit_code == 2
    expected = [
        (4, "landmarks[0].cell: cell [5, 5] is outside the 3x3 grid"),
        (5, "landmarks[1].cell: cell [7, 1] is outside the 3x3 grid"),
        (8, "actions.up: unknown action 'up'"),
        (11, "sensors.scan.beams_deg[0]: a beam at 30 degrees"),
        (13, "annotations[0].state: state '9,9,0' is outside the 3x3 grid"),
        (14, "annotations[1].scan: should list one reading per beam"),
    ]
    output = " ".join(result.output.split())  # the terminal may wrap long lines
    for line, message in expected:
        assert f"broken.yaml:{line}:" in output and message in output, (line, message, result.output)


def test_field_errors_too_are_listed_together_up_to_the_documented_number(tmp_path: Path) -> None:
    n = MAX_ERRORS_SHOWN + 5
    landmarks = "".join(f"  - {{class: chair, cell: [{10 + k}, 0]}}\n" for k in range(n))
    path = tmp_path / "many.yaml"
    path.write_text(
        f"name: many\ngrid: {{rows: 3, cols: 3}}\nlandmarks:\n{landmarks}actions: {{forward: {{}}}}\n", encoding="utf-8"
    )
    with pytest.raises(MapError) as info:
        load_map(path)
    lines = str(info.value).splitlines()
    assert len(lines) == MAX_ERRORS_SHOWN + 1 and lines[-1] == "... and 5 more problems"
    assert lines[0].startswith(f"{path}:4:") and lines[MAX_ERRORS_SHOWN - 1].startswith(
        f"{path}:{3 + MAX_ERRORS_SHOWN}:"
    )


def test_schema_errors_are_listed_together_too(tmp_path: Path) -> None:
    path = tmp_path / "typed.yaml"
    data = {
        "name": "typed",
        "grid": {"rows": 3, "cols": 3},
        "actions": {"forward": {"cost": -1, "failure": 2}},
        "sensors": {"look": {"type": "look", "classes": ["chair"], "false_positive": 1.5}},
    }
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    with pytest.raises(MapError) as info:
        load_map(path)
    assert len(str(info.value).splitlines()) == 3
