"""Object search with a scene model (issue 31): the command line's --scenes, --show and --json, and the
correlated world of --correlation."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from beliefloc.cli.app import app
from beliefloc.errors import EXIT_BAD_INPUT
from beliefloc.knowledge import load_domain
from beliefloc.object_search.domain_space import search_space
from beliefloc.object_search.experiment import Arm, TrialSettings, run_trials
from beliefloc.object_search.settings import Metareasoning, Scenes
from beliefloc.object_search.world import class_rooms, place_objects

from .conftest import DATA, ROOT

HOME = str(ROOT / "domains" / "home.yaml")


@pytest.fixture
def runner(monkeypatch: pytest.MonkeyPatch) -> CliRunner:
    monkeypatch.setenv("COLUMNS", "120")
    return CliRunner()


def test_run_shows_rois_operators_and_the_high_level_belief(runner: CliRunner) -> None:
    result = runner.invoke(app, ["search", "run", HOME, "--seed", "0", "--show", "--time-limit", "6"])
    assert result.exit_code in (0, 1), result.output
    assert "ROI 1" in result.output and "P(present)" in result.output and "| none" in result.output
    assert "report " in result.output and "operators," in result.output
    assert "colour" in result.output


def test_run_json_carries_each_image(runner: CliRunner) -> None:
    result = runner.invoke(app, ["search", "run", HOME, "--seed", "0", "--json", "--no-timings"])
    data = json.loads(result.stdout)
    steps = data["steps"]
    assert data["operators_applied"] == sum(s["scene"]["operators_applied"] for s in steps)
    assert data["processing_time"] == pytest.approx(sum(s["scene"]["processing_time"] for s in steps))
    assert data["processing_time"] < data["time"]  # the rest is travel
    for step in steps:
        assert step["observation"] == step["scene"]["report"]
        assert step["cost"] >= step["scene"]["processing_time"] - 1e-9


def test_fixed_detector_keeps_the_old_json(runner: CliRunner) -> None:
    result = runner.invoke(app, ["search", "run", HOME, "--seed", "0", "--json", "--scenes", "fixed"])
    data = json.loads(result.stdout)
    assert "operators_applied" not in data and "scene" not in data["steps"][0]


def test_simulate_reports_processing_beside_travel(runner: CliRunner) -> None:
    args = ["search", "simulate", HOME, "-n", "2", "-s", "none", "--scenes", "planned,all", "--json", "--no-timings"]
    data = json.loads(runner.invoke(app, args).stdout)
    planned, everything = "pomdp/none/static/reuse@scenes=planned", "pomdp/none/static/reuse@scenes=all"
    for record in data["records"]:
        for name in (planned, everything):
            outcome = record["outcomes"][name]
            assert isinstance(outcome["operators_applied"], int)
            assert 0 < outcome["processing_time"] <= outcome["time"]
        assert record["outcomes"][everything]["operators_applied"] == 12 * record["outcomes"][everything]["steps"]
    table = runner.invoke(app, ["search", "simulate", HOME, "-n", "2"]).output
    assert "travel" in table and "+scenes" in table


def test_scenes_need_a_scene_model(runner: CliRunner) -> None:
    locked = str(DATA / "search-locked.yaml")
    result = runner.invoke(app, ["search", "run", locked, "--scenes", "planned"])
    assert result.exit_code == EXIT_BAD_INPUT
    assert "--scenes planned and all need a scene model" in result.output
    result = runner.invoke(app, ["search", "run", HOME, "--scenes", "some"])
    assert result.exit_code == EXIT_BAD_INPUT and "expected one of: planned, all, fixed" in result.output


def test_a_target_class_that_looks_like_nothing(runner: CliRunner) -> None:
    result = runner.invoke(app, ["search", "run", HOME, "--target", "object"])
    assert result.exit_code == EXIT_BAD_INPUT
    assert "--target 'object': class 'object' has no appearance" in result.output.replace("\n", "")
    assert runner.invoke(app, ["search", "run", HOME, "--target", "object", "--scenes", "fixed"]).exit_code in (0, 1)


def test_home_classes_have_the_rooms_of_their_defaults() -> None:
    homes = class_rooms(load_domain(HOME))
    assert homes["printer"] == homes["computer"] == homes["textbook"] == "study"
    assert homes["cookbook"] == homes["cup"] == "kitchen"  # cookbook: its own default beats the books'
    assert homes["pillow"] == "bedroom" and homes["remote"] == "living_room"
    # no default: where the file puts most magazines -- one in each of bedroom, study, living room: the first
    assert homes["magazine"] == "bedroom"


def test_a_fully_correlated_world_puts_every_object_home() -> None:
    domain = load_domain(HOME)
    space = search_space(domain)
    homes = class_rooms(domain)
    rooms, cells = place_objects(domain, space, {}, np.random.default_rng(0), correlation=1.0)
    assert all(rooms[name] == homes[obj.class_] for name, obj in domain.objects.items())
    assert all(space.rooms[space.room_of_cell[cells[name]]] == rooms[name] for name in rooms)
    loose, _ = place_objects(domain, space, {}, np.random.default_rng(0), correlation=0.0)
    assert all(loose[name] != homes[obj.class_] for name, obj in domain.objects.items())


def test_the_correlated_world_reaches_the_room_prior_at_full_knowledge() -> None:
    domain = load_domain(HOME)
    settings = TrialSettings(knowledge=1.0, defaults=False, correlation=1.0)
    records = run_trials(domain, [Arm("pomdp", Metareasoning.NONE, scenes=Scenes.FIXED)], trials=5, settings=settings)
    space = search_space(domain)
    for record in records:
        assert record.true_room is not None
        assert int(np.argmax(record.room_prior)) == space.rooms.index(record.true_room)
