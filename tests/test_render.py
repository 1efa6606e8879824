"""Beliefs drawn on the grid (render.belief_grid and its neighbours), rendered with a recording console."""

from __future__ import annotations

import functools
import tempfile
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from rich.console import Console, RenderableType

from beliefloc import compile_model, load_map, uniform, update
from beliefloc.model import Action, ActionKind, Model, ObservationModel, StateSpace
from beliefloc.render.belief_grid import belief_grid, belief_legend, belief_view, grid_width, resolve_compact
from beliefloc.render.drawing import HIGHLIGHT, class_letters
from beliefloc.render.state_tables import step_header, summary_line, top_states

from .conftest import MAPS


def grid_map(rows: int, cols: int, headings: int, *, name: str = "generated") -> dict[str, object]:
    """A map with a wall of blocked cells and a few landmarks, as the YAML data of a map file."""
    layout = [["." for _ in range(cols)] for _ in range(rows)]
    if rows >= 5:
        for c in range(1, cols - 1):
            if c % 4:
                layout[rows // 2][c] = "#"
    classes = ["chair", "table", "plant", "cabinet"]
    landmarks = []
    for i in range(min(8, rows * cols // 4)):
        r, c = (i * 7) % rows, (i * 11 + 3) % cols
        if layout[r][c] == ".":
            landmarks.append({"class": classes[i % len(classes)], "cell": [r, c]})
    actions = {"forward": {"failure": 0.1}, "rotate_cw": {}} if headings > 1 else {"up": {}, "right": {}}
    return {
        "name": name,
        "grid": {"rows": rows, "cols": cols, "headings": headings},
        "layout": "\n".join("".join(line) for line in layout),
        "landmarks": landmarks,
        "actions": actions,
        "sensors": {
            "look": {"type": "look", "classes": classes, "range": 3, "false_positive": 0.05, "false_negative": 0.1}
        },
    }


def write_map(tmp_path: Path, data: dict[str, object]) -> Path:
    path = tmp_path / f"{data['name']}.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def render(renderable: RenderableType, *, width: int = 120, color: bool = True) -> str:
    console = Console(
        record=True,
        width=width,
        force_terminal=color,
        color_system="truecolor" if color else None,
        file=open("/dev/null", "w"),  # noqa: SIM115 - closed with the console
    )
    console.print(renderable, crop=False)
    text = console.export_text(styles=False)
    console.file.close()
    return text


def lines_of(text: str) -> list[str]:
    return text.rstrip("\n").split("\n")


@pytest.fixture(scope="module")
def window() -> Model:
    return compile_model(load_map(MAPS / "window-2x2.yaml"))


@pytest.fixture(scope="module")
def big(tmp_path_factory: pytest.TempPathFactory) -> Model:
    path = write_map(tmp_path_factory.mktemp("maps"), grid_map(30, 30, 8, name="big"))
    return compile_model(load_map(path))


@pytest.fixture(scope="module")
def big_belief(big: Model) -> np.ndarray:
    belief = uniform(big.n_states)
    for action, observation in [("look", "nothing"), ("forward", None), ("look", "chair")]:
        belief, _ = update(big, belief, action, observation)
    return belief


def rooms_model() -> Model:
    """Three named states and no grid, like an imported .pomdp."""
    names = ["kitchen", "hall", "office"]
    stay = Action("stay", ActionKind.ACTUATION, 1.0, sp.csr_matrix(sp.identity(3)), ObservationModel(3))
    return Model("rooms", StateSpace(3, names=names), (stay,))


@pytest.fixture(scope="module")
def no_grid() -> Model:
    return rooms_model()


# --- choosing the form ----------------------------------------------------------------------------


def test_full_needs_three_characters_a_cell_in_colour_and_four_without(big: Model) -> None:
    assert big.grid is not None
    assert grid_width(big.grid, compact=False, color=True) == 2 * 3 + 30 * 3
    assert grid_width(big.grid, compact=False, color=False) == 2 * 3 + 30 * 4
    assert grid_width(big.grid, compact=True) == 2 * 3 + 30 * 2


def test_full_when_it_fits_compact_otherwise(big: Model) -> None:
    assert big.grid is not None
    assert resolve_compact(big.grid, None, 120) is False
    assert resolve_compact(big.grid, None, 80) is True
    assert resolve_compact(big.grid, None, 120, color=False) is True
    assert resolve_compact(big.grid, False, 20) is False
    assert resolve_compact(big.grid, True, 500) is True


def test_class_letters_are_initials_and_distinct() -> None:
    letters = class_letters(["window", "chair", "cabinet", "couch", "window"])
    assert letters == {"window": "W", "chair": "C", "cabinet": "A", "couch": "O"}
    many = class_letters([f"c{i}" for i in range(62)])
    assert len(set(many.values())) == 62  # every letter and digit


# --- the grid ------------------------------------------------------------------------------------


@pytest.mark.parametrize("color", [True, False])
@pytest.mark.parametrize("compact", [True, False])
def test_big_grid_has_the_width_it_announces(big: Model, big_belief: np.ndarray, compact: bool, color: bool) -> None:
    assert big.grid is not None
    text = render(belief_grid(big, big_belief, compact=compact, color=color), width=200, color=color)
    lines = lines_of(text)
    assert max(len(line) for line in lines) <= grid_width(big.grid, compact=compact, color=color)
    lines_per_row = 1 if compact else (2 if color else 3)
    assert len(lines) == 2 + 30 * lines_per_row


def test_column_labels_never_touch(big: Model, big_belief: np.ndarray) -> None:
    header = lines_of(render(belief_grid(big, big_belief, compact=True)))[0]
    assert header.split() == [str(c) for c in range(0, 30, 2)]
    header = lines_of(render(belief_grid(big, big_belief, compact=False)))[0]
    assert header.split() == [str(c) for c in range(30)]


def test_row_labels_on_both_sides(window: Model) -> None:
    lines = lines_of(render(belief_grid(window, uniform(4), compact=True, color=False)))
    assert lines[1].split()[0] == "0" and lines[1].split()[-1] == "0"
    assert lines[2].split()[0] == "1" and lines[2].split()[-1] == "1"


def test_plain_compact_window_grid(window: Model) -> None:
    """Shade of the cell, then '@' for the most likely state or the landmark's letter."""
    belief, _ = update(window, uniform(4), "look", "window_seen")  # [1/18, 1/18, 4/9, 4/9]
    lines = lines_of(render(belief_grid(window, belief, compact=True, color=False), color=False))
    assert lines[1] == "0 ░ ░  0"
    assert lines[2] == "1 █@█W 1"


def test_plain_full_marks_the_most_likely_heading(big: Model, big_belief: np.ndarray) -> None:
    grid = big.grid
    assert grid is not None
    state = int(np.argmax(big_belief))
    r, c, h = (int(x) for x in grid.cell_heading(state))
    lines = lines_of(render(belief_grid(big, big_belief, compact=False, color=False), width=200, color=False))
    offsets = {0: (0, 1), 1: (0, 2), 2: (1, 2), 3: (2, 2), 4: (2, 1), 5: (2, 0), 6: (1, 0), 7: (0, 0)}
    dr, dc = offsets[h]
    assert lines[1 + 3 * r + dr][3 + 4 * c + dc] == "@"
    assert sum(line.count("@") for line in lines) == 1


def test_blocked_cells_are_drawn_distinctly(big: Model, big_belief: np.ndarray) -> None:
    lines = lines_of(render(belief_grid(big, big_belief, compact=True, color=False), color=False))
    wall = lines[1 + 15]
    assert wall[3:5] != "##" and wall[5:11] == "######"
    colour = lines_of(render(belief_grid(big, big_belief, compact=True), width=120))
    assert "▒▒▒▒▒▒" in colour[1 + 15]


def test_landmark_letters_are_drawn(window: Model) -> None:
    for compact in (True, False):
        text = render(belief_grid(window, uniform(4), compact=compact))
        assert text.count("W") == 2


def test_most_likely_state_is_red(window: Model) -> None:
    belief, _ = update(window, uniform(4), "look", "window_seen")
    for compact in (True, False):
        grid = belief_grid(window, belief, compact=compact)
        red = [span for span in grid.spans if HIGHLIGHT in str(span.style)]
        assert red
        # the red marks sit on row 1 (the lines after the header)
        first = min(span.start for span in red)
        assert grid.plain[:first].count("\n") >= 2


def test_compact_arrow_is_the_most_likely_heading(tmp_path: Path) -> None:
    model = compile_model(load_map(write_map(tmp_path, grid_map(3, 3, 4, name="small4"))))
    assert model.grid is not None
    belief = np.zeros(model.n_states)
    belief[model.grid.state_of(1, 1, 1)] = 0.7  # east
    belief[model.grid.state_of(1, 1, 3)] = 0.1
    belief[model.grid.state_of(2, 2, 2)] = 0.2  # south
    lines = lines_of(render(belief_grid(model, belief, compact=True, color=False), color=False))
    assert lines[3][6:8] == "░↓"
    assert lines[2][4:6] == "█@"
    assert lines[1][2:4] == "·C"  # probability 0, a chair


@settings(max_examples=25, deadline=None)
@given(
    weights=st.lists(st.floats(0.0, 1.0), min_size=4 * 12, max_size=4 * 12).filter(lambda w: sum(w) > 0),
    compact=st.booleans(),
    color=st.booleans(),
)
def test_any_belief_renders_within_its_width(weights: list[float], compact: bool, color: bool) -> None:
    model = small4()
    belief = np.array(weights) / sum(weights)
    assert model.grid is not None
    text = render(belief_grid(model, belief, compact=compact, color=color), color=color)
    assert max(len(line) for line in lines_of(text)) <= grid_width(model.grid, compact=compact, color=color)


@functools.cache
def small4() -> Model:
    """A 3x4 map with 4 headings (cached: hypothesis does not mix with function-scoped fixtures)."""
    with tempfile.TemporaryDirectory() as folder:
        return compile_model(load_map(write_map(Path(folder), grid_map(3, 4, 4, name="small4"))))


# --- legend, summary, no grid -------------------------------------------------------------------


def test_legend_names_headings_letters_and_scale(big: Model, big_belief: np.ndarray) -> None:
    full = render(belief_legend(big, big_belief, compact=False))
    assert "0 N, 1 NE, 2 E, 3 SE, 4 S, 5 SW, 6 W, 7 NW" in full
    assert "C chair" in full and "T table" in full
    assert f"up to {float(big_belief.max()):.3g}" in full
    compact = render(belief_legend(big, big_belief, compact=True))
    assert "↑ 0 N" in compact and "↖ 7 NW" in compact
    assert max(len(line) for line in lines_of(full) + lines_of(compact)) <= 80


def test_legend_of_a_map_without_headings(window: Model) -> None:
    text = render(belief_legend(window, uniform(4)))
    assert "none: a state is a cell" in text
    assert "W window" in text


def test_summary_names_the_most_likely_state_and_entropy(window: Model) -> None:
    belief, _ = update(window, uniform(4), "look", "window_seen")
    text = render(summary_line(window, belief))
    assert "most likely 1,0" in text and "p = 0.4444" in text and "tied with 1 other" in text
    assert "entropy 1.042 nats" in text


def test_top_states_most_likely_first_lowest_index_on_ties() -> None:
    assert top_states(np.array([0.1, 0.3, 0.3, 0.2, 0.1]), 3).tolist() == [1, 2, 3]


def test_view_includes_grid_legend_and_top_states(window: Model) -> None:
    belief, _ = update(window, uniform(4), "look", "window_seen")
    text = render(belief_view(window, belief, width=120, top=3, title="window"))
    assert text.startswith("window\n")
    assert "shade" in text and "row 1, col 0 (window)" in text
    assert "0,0" not in text.split("most likely")[1]  # only the top 3 are listed


def test_model_without_grid_is_a_table(no_grid: Model) -> None:
    belief = np.array([0.2, 0.5, 0.3])
    text = render(belief_view(no_grid, belief))
    table_lines = [line.split()[:3] for line in lines_of(text)[2:]]
    assert table_lines == [["1", "hall", "0.5"], ["2", "office", "0.3"], ["3", "kitchen", "0.2"]]
    with pytest.raises(ValueError, match="no grid"):
        belief_grid(no_grid, belief)


def test_step_header() -> None:
    assert step_header(2, "look=window_seen", "look", "window_seen", 0.45).plain == (
        "step 2: look=window_seen   p(window_seen | look, b) = 0.45"
    )
    assert "prediction only" in step_header(1, "right", "right", None, None).plain


def _printed(table: RenderableType, width: int = 80) -> list[str]:
    console = Console(width=width, record=True, color_system=None)
    console.print(table)
    return console.export_text().splitlines()


def test_summary_tables_fit_80_columns_without_cutting_a_header() -> None:
    """The simulate and search simulate summaries at the width of a plain terminal: no '…'."""
    from dataclasses import replace

    from beliefloc.object_search.experiment import ArmSummary
    from beliefloc.render.plan import summary_table
    from beliefloc.render.search import trials_table
    from beliefloc.simulation.episode import StrategySummary

    row = StrategySummary(
        episodes=100,
        localized=97,
        correct=95,
        failures={"budget_exceeded": 2, "step_limit": 1},
        mean_plan_seconds=0.1234,
        stdev_plan_seconds=None,
        mean_replans=12.5,
        mean_cost=123.4,
        stdev_cost=45.6,
        mean_steps=23.4,
    )
    plan_lines = _printed(summary_table({"ec2-macros": row, "bestfirst": replace(row, failures={})}, 0.95))
    trial = ArmSummary(
        arm="pomdp/expectation/static/reuse",
        trials=1000,
        found=900,
        not_found=90,
        time_limit=10,
        mean_time=123.4,
        stdev_time=56.7,
        median_time=None,
        mean_accuracy=0.912,
        stdev_accuracy=None,
        mean_error_cells=None,
        within_4_cells=950,
        mean_steps=12.3,
        mean_commits=None,
        mean_seconds=None,
    )
    search_lines = _printed(trials_table({"pomdp/expectation/static/reuse": trial}, "trials"))
    for lines in (plan_lines, search_lines):
        assert all(len(line) <= 80 and "…" not in line for line in lines)
    assert any(line.startswith(" ec2-macros") and "123.4±45.6" in line for line in plan_lines)
    assert "not localized: ec2-macros: 2 budget_exceeded, 1 step_limit" in " ".join(plan_lines)
    assert any(line.startswith("pomdp ") for line in search_lines)  # one arm: the policy; the title has the rest
    assert "revision reuse" in " ".join(search_lines)


@pytest.mark.parametrize("width", [20, 80])
def test_print_lines_prints_what_one_print_a_line_prints(width: int) -> None:
    """The plain fast path of a file console gives the same text as rich, long lines wrapped."""
    import io

    from rich.console import Console
    from rich.text import Text

    from beliefloc.render import print_lines

    lines = [
        Text("step 1: forward", style="bold"),
        Text(),
        Text("a line much longer than twenty cells, wrapped"),
        Text("x"),
    ]
    fast, slow = io.StringIO(), io.StringIO()
    print_lines(Console(file=fast, width=width, highlight=False), lines)
    reference = Console(file=slow, width=width, highlight=False)
    for line in lines:
        reference.print(line)
    assert fast.getvalue() == slow.getvalue()
    assert ("wrapped\n" in fast.getvalue()) and (fast.getvalue().count("\n") > len(lines)) == (width == 20)
