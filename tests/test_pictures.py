"""Belief pictures (render.picture_belief) and ``show -o`` / ``plan -o``.

Pixel tests render a figure of known size and read the PNG back: a state's shade is read at a point
inside its triangle, found through the axes' ``transData`` (map-frame metres -> display pixels).
The golden SVG is recorded with ``python -m pytest tests/test_pictures.py --update-golden`` (and
must be, after a matplotlib upgrade that changes its SVG output); review it by opening it.
"""

from __future__ import annotations

import ast
import dataclasses
import functools
import io
import math
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from beliefloc import compile_model, load_map, uniform
from beliefloc.cli.app import app
from beliefloc.errors import EXIT_BAD_INPUT
from beliefloc.model import MapFrame, Model
from beliefloc.planning.best_first import plan
from beliefloc.render.figures import INSTALL_HINT, figure, figure_bytes
from beliefloc.render.picture_belief import (
    belief_figure,
    draw_belief,
    draw_path,
    expected_states,
    mark_pose,
    plan_figure,
    state_centroid,
    state_polygons,
)

from .conftest import MAPS, ROOT

pytest.importorskip("matplotlib")
Image = pytest.importorskip("PIL.Image")

GOLDEN = Path(__file__).resolve().parent / "golden"


# --- geometry --------------------------------------------------------------------------------------


def _polygon_area(vertices: np.ndarray) -> float:
    x, y = vertices[:, 0], vertices[:, 1]
    return float(abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))) / 2)


@pytest.mark.parametrize("headings", [1, 4, 8])
@pytest.mark.parametrize("frame", [MapFrame(), MapFrame(2.0, -1.0, 0.7)])
def test_state_shapes_tile_their_cell_and_point_at_their_heading(headings: int, frame: MapFrame) -> None:
    """Oracle: a plain loop over the states of a small grid. A cell's shapes have the cell's area
    between them, and the direction from the cell's centre to a shape's centroid is the heading's
    map-frame yaw."""
    model = _grid_model(headings)
    grid = dataclasses.replace(model.grid, frame=frame)
    polygons = state_polygons(grid, np.arange(grid.n_states))
    assert polygons.shape == (grid.n_states, 4, 2)
    area = {}
    for state in range(grid.n_states):
        row, col, heading = (int(v) for v in grid.cell_heading(state))
        area[(row, col)] = area.get((row, col), 0.0) + _polygon_area(polygons[state])
        cx, cy = grid.cell_centre(row, col)
        x, y = state_centroid(grid, state)
        if headings == 1:
            assert (x, y) == pytest.approx((float(cx), float(cy)))
        else:
            yaw = math.atan2(y - float(cy), x - float(cx))
            assert math.cos(yaw - float(grid.heading_yaw(heading))) == pytest.approx(1.0)
    assert list(area.values()) == pytest.approx([grid.cell_size**2] * len(area))


def test_expected_states_follow_the_most_likely_successor() -> None:
    """Oracle: the dense row of T and its first maximum."""
    smap = load_map(MAPS / "kitchen.yaml")
    model = compile_model(smap)
    actions = ["forward", "look", "rotate_cw", "forward", "forward", "scan"]
    for start in range(model.n_states):
        expected = [start]
        for name in actions:
            action = model.action(name)
            state = expected[-1]
            if action.transition is not None:
                state = int(np.argmax(action.transition.toarray()[state]))
            expected.append(state)
        assert expected_states(model, start, actions) == expected
    grid = model.grid
    assert grid is not None
    centre_north = grid.state_of(1, 1, 0)
    assert expected_states(model, centre_north, ["forward"]) == [centre_north, grid.state_of(0, 1, 0)]


# --- pixels ----------------------------------------------------------------------------------------


@functools.cache
def _grid_model(headings: int) -> Model:
    """A 3x4 grid of 1 m cells with one blocked cell (1, 1) and a door at (0, 0)."""
    actions = {"forward": {"failure": 0.1}, "rotate_cw": {}} if headings > 1 else {"up": {}, "right": {}}
    data = {
        "name": "pixels",
        "grid": {"rows": 3, "cols": 4, "headings": headings, "cell_size": 1.0},
        "layout": "....\n.#..\n....\n",
        "landmarks": [{"class": "door", "cell": [0, 0]}],
        "actions": actions,
        "sensors": {"look": {"type": "look", "classes": ["door"], "false_positive": 0.1, "false_negative": 0.1}},
    }
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "pixels.yaml"
        path.write_text(yaml.safe_dump(data), encoding="utf-8")
        return compile_model(load_map(path))


def _render(draw: object, size: tuple[float, float] = (6.0, 5.0)) -> tuple[np.ndarray, object, object]:
    """``(rgb pixels, figure, axes)``: ``draw(ax)`` on a figure of ``size`` inches, as a PNG read back."""
    with figure(*size) as fig:
        ax = fig.add_subplot()
        draw(ax)  # type: ignore[operator]
        data = figure_bytes(fig, ".png")  # draws the figure: the transforms are final
        pixels = np.asarray(Image.open(io.BytesIO(data)).convert("RGB")).astype(np.int64)
        return pixels, fig, ax


def _pixel(pixels: np.ndarray, ax: object, x: float, y: float) -> np.ndarray:
    """The RGB of map-frame point (x, y): ``transData`` gives display pixels from the lower left,
    the PNG counts rows from the top."""
    px, py = ax.transData.transform((x, y))  # type: ignore[attr-defined]
    return pixels[pixels.shape[0] - 1 - round(py), round(px)]


def _inside(grid: object, state: int) -> tuple[float, float]:
    """A point well inside the state's triangle, off the heading's axis (where the most likely
    state's arrow lies): 60 % of the way from the triangle's first edge corner to its centroid."""
    vertices = state_polygons(grid, [state])[0]  # type: ignore[arg-type]
    cx, cy = state_centroid(grid, state)  # type: ignore[arg-type]
    return 0.6 * cx + 0.4 * float(vertices[1, 0]), 0.6 * cy + 0.4 * float(vertices[1, 1])


def _luminance(rgb: np.ndarray) -> float:
    return float(0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2])


@pytest.mark.parametrize("headings", [4, 8])
def test_more_probability_is_darker_and_zero_is_unshaded(headings: int) -> None:
    model = _grid_model(headings)
    grid = model.grid
    assert grid is not None
    belief = np.linspace(1.0, 2.0, model.n_states) ** 4
    belief[::3] = 0.0  # exactly 0: left white
    belief[5] = 40.0  # the most likely state
    belief /= belief.sum()
    pixels, _, ax = _render(lambda ax: draw_belief(ax, model, belief, colorbar=False))
    shades = np.array([_luminance(_pixel(pixels, ax, *_inside(grid, s))) for s in range(model.n_states)])
    assert int(np.argmin(shades)) == 5
    zero = belief == 0.0
    for state in np.flatnonzero(zero):
        assert tuple(_pixel(pixels, ax, *_inside(grid, int(state)))) == (255, 255, 255)
    assert shades[~zero].max() < 250  # the faintest non-zero state is shaded
    positive = np.flatnonzero(~zero)
    order = positive[np.argsort(belief[positive])]
    assert np.all(np.diff(shades[order]) <= 1.0)  # monotone: more probability, no lighter


def test_a_blocked_cell_is_drawn_grey_where_the_layout_has_one() -> None:
    model = _grid_model(4)
    grid = model.grid
    assert grid is not None
    pixels, _, ax = _render(lambda ax: draw_belief(ax, model, uniform(model.n_states), colorbar=False))
    x, y = grid.cell_centre(1, 1)  # the '#'
    patch = [_pixel(pixels, ax, float(x) + dx, float(y) + dy) for dx in (-0.3, 0.0, 0.3) for dy in (-0.3, 0.0, 0.3)]
    mean = np.mean(patch, axis=0)
    assert 60 < mean.mean() < 200  # grey with hatching
    assert np.ptp(mean) < 8  # no hue: not a belief shade
    free = _pixel(pixels, ax, *_inside(grid, grid.state_of(1, 2, 0)))
    assert np.ptp(free) > 40  # a shaded free cell is coloured


def test_the_colour_bar_is_labelled_and_runs_light_to_dark() -> None:
    model = _grid_model(4)
    belief = np.arange(1.0, model.n_states + 1.0)
    belief /= belief.sum()
    with belief_figure(model, belief) as fig:
        figure_bytes(fig, ".png")
        assert len(fig.axes) == 2
        bar = fig.axes[1]
        assert bar.get_ylabel() == "probability"
        assert bar.get_ylim() == pytest.approx((0.0, belief.max()))
        pixels = np.asarray(Image.open(io.BytesIO(figure_bytes(fig, ".png"))).convert("RGB")).astype(np.int64)
    (x0, y0), (x1, y1) = bar.get_window_extent().get_points()
    column = int((x0 + x1) / 2)
    low = pixels[pixels.shape[0] - 1 - int(y0 + 3), column]
    high = pixels[pixels.shape[0] - 1 - int(y1 - 3), column]
    assert _luminance(low) > _luminance(high) + 100


def test_paths_and_poses_are_drawn_and_listed() -> None:
    model = _grid_model(4)
    grid = model.grid
    assert grid is not None
    states = [grid.state_of(2, 0, 1), grid.state_of(2, 1, 1), grid.state_of(2, 2, 1), grid.state_of(2, 2, 0)]

    def draw(ax: object) -> None:
        draw_belief(ax, model, uniform(model.n_states), colorbar=False)
        draw_path(ax, grid, states, style="true")
        mark_pose(ax, grid, states[-1], label="true pose")

    pixels, fig, ax = _render(draw)
    labels = [text.get_text() for text in fig.legends[0].get_texts()]  # type: ignore[attr-defined]
    assert {"true path", "true pose", "door", "blocked cell"} <= set(labels)
    assert any(label.startswith("most likely state 0,0,0 N") for label in labels)
    x, y = grid.cell_centre(2, 0)
    along = [_luminance(_pixel(pixels, ax, float(x) + dx, float(y))) for dx in np.linspace(0.1, 0.9, 30)]
    assert min(along) < 40  # the dashed black path between the cells' centres
    with pytest.raises(ValueError, match="unknown path style 'dotted'"):
        _render(lambda ax: draw_path(ax, grid, states, style="dotted"))


def test_a_model_without_a_grid_has_no_picture() -> None:
    model = dataclasses.replace(_grid_model(4), grid=None)
    with pytest.raises(ValueError, match="has no grid"), belief_figure(model, uniform(model.n_states)):
        pass


def test_the_plan_picture_has_its_path_and_step_table() -> None:
    smap = load_map(MAPS / "kitchen.yaml")
    model = compile_model(smap)
    grid = model.grid
    assert grid is not None
    start = np.zeros(model.n_states)
    start[[grid.state_of(2, 1, 0), grid.state_of(2, 1, 2)]] = [0.6, 0.4]
    result = plan(model, start)
    assert result.found and result.steps
    with plan_figure(model, start, result, smap=smap, title="kitchen plan") as fig:
        figure_bytes(fig, ".png")
        texts = [t.get_text() for sub in fig.subfigs for t in sub.texts]
        legend = [t.get_text() for sub in fig.subfigs for lg in sub.legends for t in lg.get_texts()]
    table = next(t for t in texts if t.startswith("step"))
    assert table.splitlines()[0].split() == ["step", "action", "expected", "observation", "max", "belief", "cost"]
    assert len(table.splitlines()) == len(result.steps) + 1
    for line, step in zip(table.splitlines()[1:], result.steps, strict=True):
        assert step.action in line and f"{step.cost:g}" in line
    assert "planned moves from the most likely state" in legend


# --- the command line ------------------------------------------------------------------------------


def test_show_writes_a_png(runner: CliRunner, tmp_path: Path) -> None:
    out = tmp_path / "kitchen.png"
    result = runner.invoke(app, ["show", str(MAPS / "kitchen.yaml"), "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert result.stdout.strip() == f"wrote {out}"
    image = Image.open(out)
    assert image.width > image.height * 0.8  # sized from the (square) map, with a colour bar beside it


def test_show_svg_is_deterministic_and_matches_the_golden(
    runner: CliRunner, tmp_path: Path, update_golden: bool
) -> None:
    outputs = []
    for name in ("a.svg", "b.svg"):
        result = runner.invoke(app, ["show", str(MAPS / "window-2x2.yaml"), "-o", str(tmp_path / name)])
        assert result.exit_code == 0, result.output
        outputs.append((tmp_path / name).read_bytes())
    assert outputs[0] == outputs[1]
    golden = GOLDEN / "show-window-2x2.svg"
    if update_golden:
        golden.write_bytes(outputs[0])
    assert outputs[0] == golden.read_bytes(), "rerun with --update-golden if the change is intended"


def test_plan_writes_a_picture(runner: CliRunner, tmp_path: Path) -> None:
    out = tmp_path / "plan.svg"
    result = runner.invoke(app, ["plan", str(MAPS / "window-2x2.yaml"), "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert out.read_bytes().startswith(b"<?xml")
    assert f"wrote {out}" in result.stdout


@pytest.mark.parametrize(
    ("target", "message"),
    [
        ("x.gif", "unknown kind of file; expected one of: .png, .svg"),
        ("missing/x.png", "the folder"),
        (str(MAPS / "kitchen.yaml"), "unknown kind of file"),
        (".", "unknown kind of file"),
    ],
)
@pytest.mark.parametrize("command", ["show", "plan"])
def test_a_bad_output_is_exit_2_and_writes_nothing(
    runner: CliRunner, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, command: str, target: str, message: str
) -> None:
    monkeypatch.chdir(tmp_path)
    before = (MAPS / "kitchen.yaml").read_bytes()
    result = runner.invoke(app, [command, str(MAPS / "kitchen.yaml"), "-o", target])
    assert result.exit_code == EXIT_BAD_INPUT
    assert result.stdout == ""
    assert len(result.stderr.strip().splitlines()) == 1
    assert message in result.stderr
    assert list(tmp_path.iterdir()) == []
    assert (MAPS / "kitchen.yaml").read_bytes() == before


def test_the_output_may_not_be_the_belief_file(runner: CliRunner, tmp_path: Path) -> None:
    belief = tmp_path / "b.png"  # not a belief file, but named as one: refused before it is read
    belief.write_bytes(b"not a picture")
    result = runner.invoke(app, ["show", str(MAPS / "kitchen.yaml"), "--belief", str(belief), "-o", str(belief)])
    assert result.exit_code == EXIT_BAD_INPUT
    assert "is an input of the command" in result.stderr
    assert belief.read_bytes() == b"not a picture"


@pytest.mark.parametrize("command", ["show", "plan"])
def test_without_matplotlib_the_picture_is_exit_2_with_the_pip_line(tmp_path: Path, command: str) -> None:
    out = tmp_path / "x.png"
    script = (
        "import sys; sys.modules['matplotlib'] = None\n"  # import matplotlib now raises ImportError
        "from beliefloc.cli.app import main\n"
        f"sys.argv = ['beliefloc', {command!r}, {str(MAPS / 'kitchen.yaml')!r}, '-o', {str(out)!r}]\n"
        "main()\n"
    )
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=ROOT, timeout=60)
    assert result.returncode == EXIT_BAD_INPUT, result.stderr
    assert INSTALL_HINT in " ".join(result.stderr.split())
    assert "Traceback" not in result.stderr
    assert not out.exists()


def _runtime_imports(tree: ast.AST) -> list[str]:
    """Modules imported by ``tree`` outside ``if TYPE_CHECKING:`` blocks."""
    names: list[str] = []
    for node in ast.iter_child_nodes(tree):
        if isinstance(node, ast.If) and isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING":
            names.extend(name for child in node.orelse for name in _runtime_imports(child))
            continue
        if isinstance(node, ast.Import):
            names.extend(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module is not None:
            names.append(node.module)
        names.extend(_runtime_imports(node))
    return names


def test_only_render_figures_imports_matplotlib() -> None:
    """The rule of render/figures.py: every other module reaches matplotlib through it (imports for
    type checking only are allowed)."""
    offenders = [
        str(path.relative_to(ROOT))
        for path in sorted((ROOT / "beliefloc").rglob("*.py"))
        if path != ROOT / "beliefloc" / "render" / "figures.py"
        and any(
            name.split(".")[0] == "matplotlib" for name in _runtime_imports(ast.parse(path.read_text(encoding="utf-8")))
        )
    ]
    assert offenders == []
    assert "matplotlib" in _runtime_imports(ast.parse((ROOT / "beliefloc/render/figures.py").read_text()))


def test_a_rotated_occupancy_map_is_drawn_in_the_map_frame(tmp_path: Path) -> None:
    """The TurtleBot3 arena with its origin turned by 0.5 rad: a pillar's unknown inside is grey, the
    free floor white (probability 0), and a state's triangle is shaded where the rotated grid puts it."""
    from beliefloc.semantic_map.occupancy_map import Occupancy

    (tmp_path / "occupancy").mkdir()
    source = ROOT / "maps" / "occupancy"
    (tmp_path / "occupancy" / "tb3_sandbox.pgm").write_bytes((source / "tb3_sandbox.pgm").read_bytes())
    text = (source / "tb3_sandbox.yaml").read_text().replace("-10.000000, 0.000000]", "-10.000000, 0.5]")
    assert "0.5]" in text
    (tmp_path / "occupancy" / "tb3_sandbox.yaml").write_text(text)
    (tmp_path / "rotated.yaml").write_text((MAPS / "tb3-sandbox.yaml").read_text())
    smap = load_map(tmp_path / "rotated.yaml")
    model = compile_model(smap)
    occupancy, grid = smap.occupancy_map, model.grid
    assert occupancy is not None and grid is not None and occupancy.frame.yaw == 0.5
    state = grid.state_of(*(int(v) for v in np.argwhere(grid.free)[len(np.argwhere(grid.free)) // 2]), 2)
    belief = np.zeros(model.n_states)
    belief[[0, state]] = 0.5  # state 0 is the most likely (lowest index): its arrow is elsewhere

    def deep(kind: Occupancy) -> tuple[float, float]:
        """The centre of a pixel of ``kind`` with 7x7 pixels of that kind around it, nearest the
        image's middle (a pillar's inside, a stretch of floor)."""
        same = occupancy.pixels == kind
        for di in range(-3, 4):
            for dj in range(-3, 4):
                same = same & np.roll(np.roll(occupancy.pixels == kind, di, axis=0), dj, axis=1)
        i, j = np.nonzero(same)
        k = int(np.argmin((i - occupancy.height / 2) ** 2 + (j - occupancy.width / 2) ** 2))
        x, y = occupancy.pixel_centre(i[k], j[k])
        return float(x), float(y)

    pixels, _, ax = _render(lambda ax: draw_belief(ax, model, belief, smap=smap, colorbar=False), (7.0, 7.0))
    assert tuple(_pixel(pixels, ax, *deep(Occupancy.UNKNOWN))) == (128, 128, 128)
    assert tuple(_pixel(pixels, ax, *deep(Occupancy.FREE))) == (255, 255, 255)
    assert _luminance(_pixel(pixels, ax, *_inside(grid, state))) < 60  # darkest purple
