"""Pictures of object search (``search run -o`` / ``--record``) and of the localizability verdict
(``macros show -o``), and the legend of ``search run --show``: pixels read at known places, bytes
compared between runs, artists counted, bad outputs refused before any work."""

from __future__ import annotations

import io
import json
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from beliefloc.cli.app import app
from beliefloc.errors import EXIT_BAD_INPUT, EXIT_NEGATIVE
from beliefloc.files.model_sources import open_model
from beliefloc.knowledge import KnowledgeBase, load_domain
from beliefloc.object_search.domain_space import search_space
from beliefloc.object_search.loop import SearchRecord, seeded_search
from beliefloc.object_search.map_space import MapSearchSpace
from beliefloc.object_search.policy import POLICIES
from beliefloc.object_search.settings import Metareasoning
from beliefloc.object_search.space import SearchSpace
from beliefloc.planning.macros import build_macros

from .conftest import MAPS, ROOT

pytest.importorskip("matplotlib")
Image = pytest.importorskip("PIL.Image")

from beliefloc.render.figures import figure_bytes  # noqa: E402
from beliefloc.render.picture_macros import drawn_links, drawn_states, macros_figure, never_pairs  # noqa: E402
from beliefloc.render.picture_search import (  # noqa: E402
    VIEW_COLOUR,
    canvas,
    cell_centre,
    frame_steps,
    name_spots,
    search_figure,
)

HOME = ROOT / "domains" / "home.yaml"
APARTMENT = ROOT / "domains" / "apartment.yaml"
LADDER = MAPS / "ladder-symmetric.yaml"
QUICK = ["search", "run", str(HOME), "--target-cell", "study:1,3"]
"""Found in 8 steps: views study:3,2 and study:2,1 say absent, then study:1,3 present."""


@pytest.fixture(scope="module")
def home_search() -> tuple[SearchSpace, SearchRecord]:
    """A search of the home, seed 0, with every step's belief kept."""
    domain = load_domain(HOME)
    space = search_space(domain)
    prior = space.over_rooms(KnowledgeBase(domain, use_defaults=True).prior(domain.resolve_target(None)).prior)
    record = seeded_search(space, prior, POLICIES["pomdp"], Metareasoning.EXPECTATION, seed=0, keep_beliefs=True)
    return space, record


def _rendered(space: SearchSpace, record: SearchRecord, step: int | None) -> tuple[object, list[np.ndarray]]:
    """The PNG of :func:`search_figure` as an RGB array, and each cell's inset box of pixels (the
    middle 60 % of its square, away from the borders drawn along its edges)."""
    with search_figure(space, record, step=step) as fig:
        fig.canvas.draw()  # lays the figure out, as saving does
        ax = fig.axes[0]
        data = figure_bytes(fig, ".png")
        height = fig.canvas.get_width_height()[1]
        boxes = []
        for cell in range(space.n_cells):
            x, y = cell_centre(space, cell)
            (x0, y0), (x1, y1) = ax.transData.transform([(x - 0.3, y - 0.3), (x + 0.3, y + 0.3)])
            boxes.append(np.array([min(x0, x1), height - max(y0, y1), max(x0, x1), height - min(y0, y1)]))
    image = np.asarray(Image.open(io.BytesIO(data)).convert("RGB"))
    return image, [image[int(b[1]) : int(b[3]), int(b[0]) : int(b[2])] for b in boxes]


def _mode(pixels: np.ndarray) -> tuple[int, int, int]:
    counts = Counter(map(tuple, pixels.reshape(-1, 3).tolist()))
    colour: tuple[int, int, int] = counts.most_common(1)[0][0]
    return colour


def _luminance(colour: tuple[int, int, int]) -> float:
    r, g, b = colour
    return 0.2126 * r + 0.7152 * g + 0.0722 * b


def _share_of(pixels: np.ndarray, hex_colour: str, tolerance: int = 40) -> float:
    target = np.array([int(hex_colour[k : k + 2], 16) for k in (1, 3, 5)])
    close = np.abs(pixels.reshape(-1, 3).astype(int) - target).max(axis=1) <= tolerance
    return float(close.mean())


# --- the picture, read pixel by pixel ----------------------------------------------------------------


@pytest.mark.parametrize("step", [2, None])
def test_the_most_likely_cell_is_drawn_darkest(home_search: tuple[SearchSpace, SearchRecord], step: int | None) -> None:
    space, record = home_search
    k = len(record.steps) if step is None else step
    belief = record.steps[k - 1].belief
    assert belief is not None
    _, boxes = _rendered(space, record, step)
    shade = {cell: _luminance(_mode(boxes[cell])) for cell in np.flatnonzero(space.reachable).tolist()}
    best = int(np.argmax(belief))
    assert shade[best] == min(shade.values())
    least = int(np.argmin(belief))
    assert shade[least] > shade[best] + 60, "less belief is lighter"


def test_the_views_taken_are_marked_and_later_ones_are_not(home_search: tuple[SearchSpace, SearchRecord]) -> None:
    space, record = home_search
    k = 3
    _, boxes = _rendered(space, record, k)
    taken = {s.view for s in record.steps[:k]}
    later = {s.view for s in record.steps[k:]} - taken - {space.start}
    assert taken and later
    for view in taken:
        assert _share_of(boxes[view], VIEW_COLOUR) > 0.03 or view == record.steps[k - 1].view, view
    last_view_cells = set(space.view_cells(record.steps[k - 1].view).tolist())
    for view in later - last_view_cells:
        assert _share_of(boxes[view], VIEW_COLOUR) == 0.0, view
    _, before = _rendered(space, record, 0)
    assert all(_share_of(before[view], VIEW_COLOUR) == 0.0 for view in taken)


def test_room_names_stand_where_no_cell_is() -> None:
    for domain_file in (HOME, APARTMENT):
        space = search_space(load_domain(domain_file))
        grid = canvas(space)
        spots = name_spots(space)
        assert set(spots) == set(space.rooms), domain_file
        cells = {(int(r), int(c)) for r, c in grid.where}
        for room, spot in spots.items():
            under = {(int(spot.row), c) for c in range(int(spot.left), int(spot.right))}
            assert not under & cells, room
            if isinstance(space, MapSearchSpace):
                assert spot.on_wall and all(not space.free[r, c] for r, c in under), room


def test_frames_keep_the_start_and_the_last_steps() -> None:
    assert frame_steps(4) == [0, 1, 2, 3, 4]
    assert frame_steps(4, 10) == [0, 1, 2, 3, 4]
    assert frame_steps(10, 4) == [0, 8, 9, 10]
    assert frame_steps(10, 1) == [0]
    with pytest.raises(ValueError, match="at least 1"):
        frame_steps(3, 0)


def test_a_search_without_kept_beliefs_cannot_be_drawn() -> None:
    domain = load_domain(HOME)
    space = search_space(domain)
    record = seeded_search(space, np.full(4, 0.25), POLICIES["pomdp"], Metareasoning.EXPECTATION, seed=0)
    with pytest.raises(ValueError, match="keep_beliefs"), search_figure(space, record):
        pass


# --- the command line --------------------------------------------------------------------------------


def test_search_run_writes_the_same_svg_twice(runner: CliRunner, tmp_path: Path) -> None:
    first, second = tmp_path / "a.svg", tmp_path / "b.svg"
    for path in (first, second):
        out = runner.invoke(app, [*QUICK, "-o", str(path)])
        assert out.exit_code == 0, out.output
        assert f"wrote {path}" in out.stdout
    assert first.read_bytes() == second.read_bytes()
    assert first.read_bytes().lstrip().startswith(b"<?xml")


def test_search_run_on_a_map_writes_a_png(runner: CliRunner, tmp_path: Path) -> None:
    picture = tmp_path / "apartment.png"
    out = runner.invoke(app, ["search", "run", str(APARTMENT), "--target-cell", "living_room:8,3", "-o", str(picture)])
    assert out.exit_code in (0, EXIT_NEGATIVE), out.output
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_the_gif_has_a_frame_per_step_and_one_before(runner: CliRunner, tmp_path: Path) -> None:
    gif = tmp_path / "search.gif"
    out = runner.invoke(app, [*QUICK, "--record", str(gif), "--json"])
    assert out.exit_code == 0, out.output
    steps = len(json.loads(out.stdout)["steps"])
    assert f"in {steps + 1} frames" in out.stderr
    with Image.open(gif) as image:
        assert image.n_frames == steps + 1


def test_record_into_a_folder_keeps_at_most_the_frames_asked(runner: CliRunner, tmp_path: Path) -> None:
    folder = tmp_path / "frames"
    out = runner.invoke(app, [*QUICK, "--record", str(folder), "--record-frames", "3"])
    assert out.exit_code == 0, out.output
    assert sorted(p.name for p in folder.iterdir()) == ["frame-000.png", "frame-001.png", "frame-002.png"]
    assert "the start and the last 2 of" in out.stdout


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["-o", "{tmp}/search.pdf"], "unknown kind of file"),
        (["-o", "{tmp}/missing/search.png"], "does not exist"),
        (["-o", "{tmp}"], "unknown kind of file"),
        (["-o", "{tmp}/folder.png"], "is a folder"),
        (["--record", "{tmp}/search.mp4"], "unknown kind of file"),
        (["--record", "{tmp}/missing/search.gif"], "does not exist"),
        (["--record", "{tmp}/notes"], "holds other files than frames"),
        (["--record", "{tmp}/search.gif", "--record-frames", "0"], "must be a positive integer"),
        (["--record", "{tmp}/search.gif", "--record-frames", "two"], "must be a positive integer"),
        (["--record-frames", "3"], "needs --record"),
    ],
)
def test_bad_outputs_exit_2_and_write_nothing(runner: CliRunner, tmp_path: Path, args: list[str], message: str) -> None:
    (tmp_path / "folder.png").mkdir()
    (tmp_path / "notes").mkdir()
    (tmp_path / "notes" / "todo.txt").write_text("keep me")
    before = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*"))
    out = runner.invoke(app, [*QUICK, *(a.format(tmp=tmp_path) for a in args)])
    assert out.exit_code == EXIT_BAD_INPUT, out.output
    assert message in out.stderr and len(out.stderr.strip().splitlines()) == 1
    assert out.stdout == ""
    assert sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*")) == before


def test_output_may_not_be_the_domain(runner: CliRunner, tmp_path: Path) -> None:
    domain = tmp_path / "home.gif"
    domain.write_bytes(HOME.read_bytes())
    out = runner.invoke(app, ["search", "run", str(domain), "--record", str(domain)])
    assert out.exit_code == EXIT_BAD_INPUT and "is an input of the command" in out.stderr
    assert domain.read_bytes() == HOME.read_bytes()


# --- the terminal -----------------------------------------------------------------------------------


def test_show_prints_a_legend_and_the_room_names(runner: CliRunner) -> None:
    out = runner.invoke(app, [*QUICK, "--show"])
    assert out.exit_code == 0, out.output
    lines = out.stdout.splitlines()
    legend = next(k for k, line in enumerate(lines) if line.startswith("marks "))
    assert "R the robot" in lines[legend] and "T the target's true cell" in lines[legend]
    assert "the most likely cell" in lines[legend + 1]
    assert lines[legend + 2].startswith("shade ") and "up to max b" in lines[legend + 2]
    assert out.stdout.count("marks ") == 1, "the legend is printed once"
    assert all(len(line) <= 80 for line in lines[legend : legend + 4])
    assert lines[legend + 4].split() == ["bedroom", "study"]  # over the top rooms
    assert "kitchen     living_room" in out.stdout  # on the blank row between the rooms


def test_show_on_a_map_explains_its_marks(runner: CliRunner) -> None:
    out = runner.invoke(app, ["search", "run", str(APARTMENT), "--target-cell", "living_room:8,3", "--show"])
    assert "wall" in out.stdout and "free, in no room" in out.stdout and "a letter on each cell" in out.stdout


# --- the localizability picture ---------------------------------------------------------------------


def test_macros_show_draws_a_link_per_never_distinguishable_pair(runner: CliRunner, tmp_path: Path) -> None:
    table_file, picture = tmp_path / "ladder.npz", tmp_path / "ladder.png"
    built = runner.invoke(app, ["macros", "build", str(LADDER), "-o", str(table_file)])
    assert built.exit_code == EXIT_NEGATIVE, built.output  # not localizable
    out = runner.invoke(app, ["macros", "show", str(table_file), "-o", str(picture)])
    assert out.exit_code == 0, out.output
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and f"wrote {picture}" in out.stdout

    model = open_model(LADDER)
    table = build_macros(model, None)
    i, j = never_pairs(table)
    assert len(i) == 60 == table.summary()["never_distinguishable_pairs"]
    with macros_figure(model, table) as fig:
        assert drawn_links(fig) == len(i)
        assert drawn_states(fig) == len(np.unique(np.concatenate([i, j]))) == 120
        assert "not localizable" in fig.axes[0].get_title()


def test_a_localizable_map_has_no_links() -> None:
    model = open_model(MAPS / "hallway.yaml")
    table = build_macros(model, None)
    with macros_figure(model, table) as fig:
        assert drawn_links(fig) == 0 and drawn_states(fig) == 0
        assert "localizable" in fig.axes[0].get_title() and "not" not in fig.axes[0].get_title()


def test_macros_show_svg_is_deterministic_and_bad_output_is_refused(runner: CliRunner, tmp_path: Path) -> None:
    table_file = tmp_path / "ladder.npz"
    runner.invoke(app, ["macros", "build", str(LADDER), "-o", str(table_file)])
    svgs = [tmp_path / "a.svg", tmp_path / "b.svg"]
    for path in svgs:
        assert runner.invoke(app, ["macros", "show", str(table_file), "-o", str(path), "--json"]).exit_code == 0
    assert svgs[0].read_bytes() == svgs[1].read_bytes()
    out = runner.invoke(app, ["macros", "show", str(table_file), "-o", str(tmp_path / "x.jpg")])
    assert out.exit_code == EXIT_BAD_INPUT and "unknown kind of file" in out.stderr
    assert not (tmp_path / "x.jpg").exists()
