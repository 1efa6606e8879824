"""Verdicts before search (planning/verdict.py): sound on random maps, complete on twin rooms."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from beliefloc.belief import uniform
from beliefloc.cli.app import app
from beliefloc.errors import EXIT_BAD_INPUT, EXIT_NEGATIVE
from beliefloc.model import Model
from beliefloc.planning.best_first import PlanStatus, plan
from beliefloc.planning.settings import Heuristic
from beliefloc.planning.verdict import twin_pairs, unreachable_goal
from beliefloc.semantic_map import SemanticMap, compile_model

from .conftest import MAPS

MOVES = {"up": {"cost": 1, "failure": 0}, "down": {"cost": 1, "failure": 0}, "left": {"cost": 1, "failure": 0},
         "right": {"cost": 1, "failure": 0}}  # fmt: skip


def model_of(data: dict[str, Any]) -> Model:
    return compile_model(SemanticMap.model_validate(data))


def room_map(cells: list[list[bool]], doors: list[tuple[int, int]], *, copies: int, noise: float = 0.0) -> dict:
    """``copies`` identical rooms side by side, walled apart: the same free cells and doors in each."""
    rows, cols = len(cells), len(cells[0])
    width = copies * (cols + 1) - 1
    layout = []
    for r in range(rows):
        line = "#".join("".join("." if cells[r][c] else "#" for c in range(cols)) for _ in range(copies))
        layout.append(line)
    landmarks = [
        {"class": "door", "cell": [r, k * (cols + 1) + c]} for k in range(copies) for r, c in doors if cells[r][c]
    ]
    return {
        "name": "rooms",
        "grid": {"rows": rows, "cols": width, "headings": 1},
        "layout": "\n".join(layout) + "\n",
        "landmarks": landmarks,
        "actions": MOVES,
        "sensors": {
            "look": {"type": "look", "classes": ["door"], "range": 0, "false_positive": noise, "false_negative": noise}
        },
    }


rooms = st.integers(1, 3).flatmap(
    lambda rows: st.integers(1, 3).flatmap(
        lambda cols: st.tuples(
            st.lists(st.lists(st.booleans(), min_size=cols, max_size=cols), min_size=rows, max_size=rows).filter(
                lambda cells: any(any(row) for row in cells)
            ),
            st.lists(st.tuples(st.integers(0, rows - 1), st.integers(0, cols - 1)), max_size=3),
        )
    )
)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(rooms)
def test_two_identical_rooms_are_never_localizable_from_a_uniform_belief(room):
    cells, doors = room
    model = model_of(room_map(cells, doors, copies=2))
    verdict = unreachable_goal(model, uniform(model.n_states), 0.95)
    assert verdict is not None and verdict.bound == pytest.approx(0.5)
    assert 2 * len(verdict.look_alikes) == model.n_states
    # and the search agrees: every reachable belief searched, none reaches the threshold
    result = plan(model, uniform(model.n_states), threshold=0.95, max_expansions=100_000, time_limit=60)
    assert result.status is PlanStatus.NO_PLAN


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(rooms, st.integers(1, 3), st.integers(0, 2**32 - 1))
def test_a_verdict_is_never_wrong(room, copies, seed):
    """Whenever it says "unreachable", the exhaustive search finds no plan (noise-free maps: the
    reachable beliefs are finitely many, so uniform-cost search ends)."""
    cells, doors = room
    model = model_of(room_map(cells, doors, copies=copies))
    rng = np.random.default_rng(seed)
    belief = rng.random(model.n_states) * (rng.random(model.n_states) < 0.7)
    if belief.sum() == 0:
        belief[0] = 1.0
    belief /= belief.sum()
    for threshold in (0.6, 0.95):
        verdict = unreachable_goal(model, belief, threshold)
        if verdict is None:
            continue
        assert verdict.bound < threshold
        result = plan(model, belief, threshold=threshold, heuristic=Heuristic.ZERO, max_expansions=200_000)
        assert result.status is PlanStatus.NO_PLAN


def test_rooms_that_differ_are_not_twins():
    data = room_map([[True, True]], [], copies=2)
    data["landmarks"] = [{"class": "door", "cell": [0, 0]}]  # only the first room has a door
    model = model_of(data)
    pairs = twin_pairs(model)
    assert pairs is not None and len(pairs[0]) == 0
    assert unreachable_goal(model, uniform(model.n_states), 0.95) is None


def test_a_lopsided_start_belief_can_still_be_localized():
    model = model_of(room_map([[True]], [], copies=2))
    belief = np.array([0.97, 0.03])
    assert unreachable_goal(model, belief, 0.95) is None  # 0.97 / (0.97 + 0.03) reaches 0.95
    verdict = unreachable_goal(model, np.array([0.9, 0.1]), 0.95)
    assert verdict is not None and verdict.bound == pytest.approx(0.9)


def test_certainty_needs_a_sensor_or_a_move_that_rules_states_out():
    kitchen = compile_model_file("kitchen.yaml")
    verdict = unreachable_goal(kitchen, uniform(kitchen.n_states), 1.0)
    assert verdict is not None and not verdict.look_alikes and "below 1" in verdict.reason
    perfect = compile_model_file("window-2x2-perfect.yaml")
    assert unreachable_goal(perfect, uniform(perfect.n_states), 1.0) is None
    noisy = model_of(room_map([[True, True]], [(0, 0)], copies=1, noise=0.1))
    assert unreachable_goal(noisy, uniform(noisy.n_states), 1.0) is None  # perfect moves still funnel into a wall


def compile_model_file(name: str) -> Model:
    from beliefloc.semantic_map import load_map

    return compile_model(load_map(MAPS / name))


def test_plan_and_simulate_say_not_localizable_before_searching(runner):
    ladder = str(MAPS / "ladder-symmetric.yaml")
    result = runner.invoke(app, ["plan", ladder])
    assert result.exit_code == EXIT_NEGATIVE
    assert result.stderr.startswith("not localizable:") and " ~ " in result.stderr
    result = runner.invoke(app, ["plan", ladder, "--json"])
    data = json.loads(result.stdout)
    assert result.exit_code == EXIT_NEGATIVE and data["status"] == "not_localizable" and data["bound"] == 0.5
    assert len(data["look_alikes"]) == 60
    result = runner.invoke(app, ["simulate", ladder, "-n", "3"])
    assert result.exit_code == EXIT_NEGATIVE and result.stderr.startswith("not localizable:")


def test_an_unreachable_threshold_is_refused(runner):
    result = runner.invoke(app, ["plan", str(MAPS / "kitchen.yaml"), "--threshold", "1"])
    assert result.exit_code == EXIT_BAD_INPUT
    assert "--threshold 1: no belief on kitchen can reach it" in result.stderr


def test_simulate_exit_code_does_not_depend_on_the_order_of_strategies(runner, tmp_path: Path):
    kitchen = str(MAPS / "kitchen.yaml")
    codes = set()
    for order in (["-s", "bestfirst", "-s", "random"], ["-s", "random", "-s", "bestfirst"]):
        result = runner.invoke(app, ["simulate", kitchen, "-n", "4", "--max-steps", "3", *order, "--json"])
        data = json.loads(result.stdout)
        for summary in data["summary"].values():
            assert summary["correct"] <= summary["localized"]
        codes.add(result.exit_code)
    assert codes == {EXIT_NEGATIVE}  # random does not localize in 3 steps, whichever comes first


def test_correct_never_exceeds_localized(runner):
    result = runner.invoke(app, ["simulate", str(MAPS / "corridors.yaml"), "-n", "20", "-s", "ec2", "--json"])
    summary = json.loads(result.stdout)["summary"]["ec2"]
    assert summary["correct"] <= summary["localized"] < summary["episodes"]


def test_yaml_room_map_is_a_valid_file(tmp_path: Path):
    path = tmp_path / "rooms.yaml"
    path.write_text(yaml.safe_dump(room_map([[True, False]], [(0, 0)], copies=2)))
    from beliefloc.semantic_map import load_map

    assert load_map(path).name == "rooms"


def test_a_long_search_shows_one_progress_line_on_a_terminal():
    import io

    from rich.console import Console

    from beliefloc.render.progress import search_progress

    def drawn(seconds: float, *, terminal: bool) -> str:
        out = io.StringIO()
        console = Console(file=out, force_terminal=terminal, width=100)
        with search_progress(console, time_limit=60) as progress:
            progress(512, 12_800, seconds)
        return out.getvalue()

    assert "512 beliefs expanded, 12,800 generated, 3 of 60 s" in drawn(3.0, terminal=True)
    assert "beliefs expanded" not in drawn(0.5, terminal=True)  # quiet for the first second
    assert drawn(3.0, terminal=False) == ""  # a pipe or a log file gets nothing


def test_plan_reports_its_progress_to_the_callback():
    model = compile_model_file("ladder-symmetric.yaml")  # no plan: the search runs until its budget
    calls: list[tuple[int, int, float]] = []
    plan(model, uniform(model.n_states), max_expansions=600, progress=lambda *a: calls.append(a))
    assert [e for e, _, _ in calls] == [256, 512] and all(g >= e and s >= 0 for e, g, s in calls)
