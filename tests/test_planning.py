"""Best-first search in belief space (Colledanchise Algorithm 1, Plan)."""

from __future__ import annotations

import json
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from beliefloc import compile_model, load_map, uniform, update
from beliefloc.belief import entropy, point
from beliefloc.cli.app import app
from beliefloc.errors import EXIT_NEGATIVE
from beliefloc.model import Model
from beliefloc.planning import best_first
from beliefloc.planning.best_first import ClosedList, PlanStatus, belief_key, plan
from beliefloc.planning.settings import Heuristic
from beliefloc.planning.successors import SuccessorEvaluator
from beliefloc.semantic_map.schema import SemanticMap

from .conftest import MAPS, TWINS


def model_of(data: dict[str, Any]) -> Model:
    return compile_model(SemanticMap.model_validate(data))


def replay(model: Model, belief: np.ndarray, steps: Any) -> np.ndarray:
    for step in steps:
        belief, _ = update(model, belief, step.action, step.observation)
    return belief


def test_fig4_perfect_window_world_plan():
    model = compile_model(load_map(MAPS / "window-2x2-perfect.yaml"))
    result = plan(model, uniform(4))
    assert result.status is PlanStatus.FOUND
    assert [(s.action, s.observation) for s in result.steps] in (
        [("look", "nothing"), ("right", None)],
        [("look", "window"), ("right", None)],
    )
    assert result.cost == 11
    assert result.belief is not None and result.belief.max() == 1.0


@pytest.mark.parametrize("heuristic", list(Heuristic))
def test_every_heuristic_finds_a_plan_that_replays_to_the_goal(heuristic: Heuristic):
    model = compile_model(load_map(MAPS / "kitchen.yaml"))
    result = plan(model, uniform(model.n_states), heuristic=heuristic)
    assert result.found
    final = replay(model, uniform(model.n_states), result.steps)
    assert final.max() >= 0.95
    np.testing.assert_allclose(final, result.belief)
    assert result.steps[-1].max_belief == pytest.approx(final.max())


def test_the_paper_plans_start_with_a_perception_action():
    """Sec. VII-B: from the uniform belief, the kitchen's and the hallway's plans begin by perceiving."""
    for name in ("kitchen.yaml", "hallway.yaml"):
        model = compile_model(load_map(MAPS / name))
        first = plan(model, uniform(model.n_states)).steps[0]
        assert not model.action(first.action).is_actuation, name


def test_heuristic_formulas():
    assert Heuristic.ENTROPY_MAX_PROB(2.0, 0.5, 0.25) == pytest.approx(16.0)
    assert Heuristic.ENTROPY_PROB(2.0, 0.5, 0.25) == pytest.approx(8.0)
    assert Heuristic.ZERO(2.0, 0.5, 0.25) == 0.0


def test_two_states_no_action_separates_is_no_plan():
    result = plan(model_of(TWINS), uniform(2))
    assert result.status is PlanStatus.NO_PLAN
    assert result.expanded >= 1 and result.steps == ()


def test_budget_gives_up_honestly_with_the_best_partial_plan():
    model = compile_model(load_map(MAPS / "window-2x2.yaml"))
    result = plan(model, uniform(4), max_expansions=2)
    assert result.status is PlanStatus.BUDGET_EXCEEDED
    assert not result.found and not result.complete and result.partial
    assert result.belief is None and result.expanded == 2
    data = result.as_json(model)
    assert data["complete"] is False and data["found"] is False and data["cost"] is None


@pytest.mark.parametrize(("name", "budget"), [("kitchen.yaml", 1), ("kitchen.yaml", 5), ("window-2x2.yaml", 2)])
def test_anytime_answer_is_the_first_step_of_the_node_searched_next(
    monkeypatch: pytest.MonkeyPatch, name: str, budget: int
):
    """The partial plan of a search out of budget ends at the belief a search with one more
    expansion expands last: the open node of least f, the best partial plan by its estimate."""
    model = compile_model(load_map(MAPS / name))
    start = uniform(model.n_states)
    partial = plan(model, start, max_expansions=budget)
    assert partial.partial and partial.steps
    first = partial.steps[0]
    assert model.actions[first.action_index].name == first.action  # an action of the model
    evaluator = SuccessorEvaluator(model)
    expanded: list[np.ndarray] = []
    original = evaluator.evaluate
    monkeypatch.setattr(evaluator, "evaluate", lambda b, *kept: expanded.append(b.copy()) or original(b, *kept))
    plan(model, start, max_expansions=budget + 1, evaluator=evaluator)
    assert len(expanded) == budget + 1
    reached = start
    for step in partial.steps:
        reached, _ = update(model, reached, model.actions[step.action_index], step.observation_index)
    np.testing.assert_allclose(reached, expanded[-1], atol=1e-12)


def test_a_search_out_of_time_stops_at_the_next_pop_even_on_a_duplicate(monkeypatch: pytest.MonkeyPatch):
    """The clock is read at every pop: once the budget is spent, one more node is popped (a
    duplicate or not) and the search ends with the best partial plan, however many duplicates wait."""
    import gc
    import types

    from beliefloc.planning import best_first

    model = compile_model(load_map(MAPS / "kitchen.yaml"))
    reads = {"n": 0, "late": 15}
    keys: list[int] = []

    def clock() -> float:
        reads["n"] += 1
        return 0.0 if reads["n"] < reads["late"] else 10.0

    original_key = best_first.belief_key
    monkeypatch.setattr(best_first, "time", types.SimpleNamespace(perf_counter=clock))
    monkeypatch.setattr(best_first, "belief_key", lambda b, *work: keys.append(reads["n"]) or original_key(b, *work))
    result = plan(model, uniform(model.n_states), time_limit=1.0)
    assert result.status is PlanStatus.BUDGET_EXCEEDED and result.partial
    assert model.actions[result.steps[0].action_index].name == result.steps[0].action
    assert sum(n >= reads["late"] for n in keys) == 1  # the pop that saw the clock run out, no more
    assert gc.isenabled()  # the collector paused during the search is back on


def test_anytime_answer_before_any_expansion_is_the_start_best_child():
    model = compile_model(load_map(MAPS / "kitchen.yaml"))
    start = uniform(model.n_states)
    result = plan(model, start, max_expansions=0)
    assert result.partial and len(result.steps) == 1 and result.expanded == 1
    h = Heuristic.ENTROPY_MAX_PROB
    scores = [
        model.actions[s.action].cost + h(s.entropy, s.max_belief, s.probability)
        for s in SuccessorEvaluator(model).evaluate(start)
    ]
    best = SuccessorEvaluator(model).evaluate(start)[int(np.argmin(scores))]
    assert (result.steps[0].action_index, result.steps[0].observation_index) == (best.action, best.observation)


@pytest.mark.parametrize("budget", [None, 3])
def test_path_probability_is_the_product_of_the_steps_and_of_the_bayes_updates(budget: int | None):
    model = compile_model(load_map(MAPS / "kitchen.yaml"))
    start = uniform(model.n_states)
    result = plan(model, start) if budget is None else plan(model, start, max_expansions=budget)
    assert result.steps
    data = result.as_json(model)
    product = float(np.prod([step["probability"] for step in data["steps"]]))
    assert data["path_probability"] == pytest.approx(product, rel=1e-12)
    belief, chained = start, 1.0
    for step in result.steps:
        belief, p = update(model, belief, model.actions[step.action_index], step.observation_index)
        chained *= p
    assert result.path_probability == pytest.approx(chained, rel=1e-9)


def test_already_localized_is_an_empty_plan():
    model = compile_model(load_map(MAPS / "window-2x2.yaml"))
    result = plan(model, point(4, 2))
    assert result.found and result.steps == () and result.cost == 0.0


def test_belief_key_tolerance():
    b = np.array([0.1, 0.2, 0.3, 0.4])
    assert belief_key(b) == belief_key(b + np.array([1e-13, -1e-13, 0.0, 0.0]))
    assert belief_key(b) != belief_key(np.array([0.1 + 1e-6, 0.2 - 1e-6, 0.3, 0.4]))
    assert belief_key(np.array([1.0, 0.0])) != belief_key(np.array([0.0, 1.0]))


def test_kept_closed_list_spares_the_successor_computations(monkeypatch: pytest.MonkeyPatch):
    model = compile_model(load_map(MAPS / "kitchen.yaml"))
    evaluator = SuccessorEvaluator(model)
    calls = []
    original = evaluator.evaluate
    monkeypatch.setattr(evaluator, "evaluate", lambda b, *kept: calls.append(1) or original(b, *kept))
    memory = ClosedList()
    first = plan(model, uniform(model.n_states), memory=memory, evaluator=evaluator)
    n_first = len(calls)
    again = plan(model, uniform(model.n_states), memory=memory, evaluator=evaluator)
    assert [s.action for s in again.steps] == [s.action for s in first.steps]
    assert n_first == first.expanded and len(calls) == n_first  # nothing recomputed


def test_successor_statistics_match_the_bayes_update():
    model = compile_model(load_map(MAPS / "kitchen.yaml"))
    rng = np.random.default_rng(3)
    belief = rng.random(model.n_states) * (rng.random(model.n_states) < 0.5)
    belief /= belief.sum()
    for stats in SuccessorEvaluator(model).evaluate(belief):
        posterior, p = update(model, belief, model.actions[stats.action], stats.observation)
        assert stats.probability == pytest.approx(p, abs=1e-12)
        assert stats.entropy == pytest.approx(entropy(posterior), abs=1e-9)
        assert stats.max_belief == pytest.approx(posterior.max(), abs=1e-12)
        if model.actions[stats.action].transition is None and stats.observation is not None:
            assert stats.change == pytest.approx(np.abs(posterior - belief).sum(), abs=1e-12)
        else:
            assert stats.change is None  # a move's successor is another belief, not a reading of this one


FAINT_LOOK = {
    "name": "faint",
    "grid": {"rows": 1, "cols": 2, "headings": 1},
    "landmarks": [{"class": "door", "cell": [0, 0]}],
    "actions": {"up": {"cost": 1}, "down": {"cost": 1}},
    "sensors": {
        "look": {"type": "look", "classes": ["door"], "range": 0.0, "false_positive": 0.49999999, "false_negative": 0.5}
    },
}
"""Two cells a look barely tells apart: "door" has likelihood 0.5 in the first and 0.49999999 in the
second, so a reading moves the belief by about 2e-9; moving up or down bumps."""


def test_a_reading_that_barely_moves_the_belief_is_the_belief_again(monkeypatch: pytest.MonkeyPatch):
    model = model_of(FAINT_LOOK)
    start = np.array([0.9, 0.1])
    result = plan(model, start)
    # the two bumps are the only children: no reading is pushed, and nothing else is reachable
    assert result.status is PlanStatus.NO_PLAN and result.generated == 2
    # the least-cost searches keep every reading: looks after looks, until the budget runs out
    for least_cost in (
        plan(model, start, heuristic=Heuristic.ZERO, max_expansions=50),
        plan(model, start, weight=0.5, max_expansions=50),
    ):
        assert least_cost.status is PlanStatus.BUDGET_EXCEEDED and least_cost.generated > 50
    monkeypatch.setattr(best_first, "UNINFORMATIVE_READING", 0.0)
    monkeypatch.setattr(best_first, "REPEATED_READING", 0.0)
    without = plan(model, start, max_expansions=50)
    assert without.status is PlanStatus.BUDGET_EXCEEDED and without.generated > 50


def test_a_reading_that_barely_moves_the_belief_is_kept_when_it_reaches_the_goal():
    model = model_of(FAINT_LOOK)
    result = plan(model, np.array([0.95 - 5e-10, 0.05 + 5e-10]))
    assert result.found and [(s.action, s.observation) for s in result.steps] == [("look", "door")]
    assert result.belief is not None and result.belief.max() >= 0.95


def test_readings_that_barely_move_the_belief_spare_expansions_not_the_plan(monkeypatch: pytest.MonkeyPatch):
    """The kitchen's noisy look repeated at one spot: its likeliest reading moves the belief less each time."""
    model = compile_model(load_map(MAPS / "kitchen.yaml"))
    start = uniform(model.n_states)
    spared = plan(model, start)
    monkeypatch.setattr(best_first, "REPEATED_READING", best_first.UNINFORMATIVE_READING)
    once = plan(model, start)  # looks repeated at one spot searched as any other reading
    monkeypatch.setattr(best_first, "UNINFORMATIVE_READING", 0.0)
    monkeypatch.setattr(best_first, "REPEATED_READING", 0.0)
    every = plan(model, start)
    assert spared.found and once.found and every.found
    assert spared.steps == once.steps == every.steps
    assert spared.expanded < once.expanded < every.expanded


SLOW_LOOK = {
    **FAINT_LOOK,
    "name": "slow",
    "sensors": {
        "look": {"type": "look", "classes": ["door"], "range": 0.0, "false_positive": 0.4996, "false_negative": 0.5}
    },
}
"""FAINT_LOOK with "door" at likelihood 0.5 against 0.4996: a reading moves the belief by about 1e-4, more
than UNINFORMATIVE_READING and less than REPEATED_READING."""


def test_a_look_repeated_at_one_spot_whose_reading_barely_moves_the_belief_is_not_searched(
    monkeypatch: pytest.MonkeyPatch,
):
    model = model_of(SLOW_LOOK)
    start = np.array([0.9, 0.1])
    result = plan(model, start)
    # the start's children (two bumps, two readings of the first look) and the bumps of each reading: the
    # readings of a second look are not pushed, so the search ends having searched all it would
    assert result.status is PlanStatus.NO_PLAN and (result.expanded, result.generated) == (3, 8)
    monkeypatch.setattr(best_first, "REPEATED_READING", best_first.UNINFORMATIVE_READING)
    looking = plan(model, start, max_expansions=50)  # ~900 looks, each moving the belief by 1e-4, would do
    assert looking.status is PlanStatus.BUDGET_EXCEEDED and looking.generated > 50
    assert all(step.action == "look" for step in looking.steps)


def test_plan_cli_not_localizable_no_plan_and_gave_up_exit_1(runner, tmp_path: Path):
    twins = tmp_path / "twins.yaml"
    twins.write_text(yaml.safe_dump(TWINS))
    result = runner.invoke(app, ["plan", str(twins)])
    assert result.exit_code == EXIT_NEGATIVE
    assert "not localizable" in result.stderr and "Look-alike states: 0,0 ~ 0,1." in result.stderr
    # three look-alike cells cannot be split into twin pairs: the search itself proves there is no plan
    triplets = tmp_path / "triplets.yaml"
    triplets.write_text(yaml.safe_dump({**TWINS, "name": "triplets", "grid": {"rows": 1, "cols": 3, "headings": 1}}))
    result = runner.invoke(app, ["plan", str(triplets)])
    assert result.exit_code == EXIT_NEGATIVE
    assert "no plan" in result.stderr and "cannot be told apart" in result.stderr
    result = runner.invoke(app, ["plan", str(MAPS / "window-2x2.yaml"), "--max-expansions", "2"])
    assert result.exit_code == EXIT_NEGATIVE
    assert "gave up" in result.stderr and "best partial plan" in " ".join(result.stderr.split())
    assert "incomplete plan for" in result.stdout and "path probability" in result.stdout


def test_plan_cli_json(runner):
    result = runner.invoke(app, ["plan", str(MAPS / "window-2x2-perfect.yaml"), "--json"])
    assert result.exit_code == 0
    data = json.loads(result.stdout)
    assert data["found"] is True and data["cost"] == 11
    assert [s["action"] for s in data["steps"]] == ["look", "right"]
    assert data["steps"][1]["observation"] is None and data["steps"][1]["max_belief"] == 1.0
    assert set(data) >= {"found", "cost", "steps", "expanded", "seconds"}


def test_plan_cli_uniform_rejects_a_heuristic(runner):
    args = ["plan", str(MAPS / "kitchen.yaml"), "--search", "uniform", "--heuristic", "entropy-prob"]
    result = runner.invoke(app, args)
    assert result.exit_code == 2
    assert "h = 0" in result.stderr


def test_weight_must_be_positive():
    model = compile_model(load_map(MAPS / "window-2x2-perfect.yaml"))
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(ValueError, match="weight"):
            plan(model, uniform(4), weight=bad)


@pytest.mark.parametrize(
    "args",
    [
        ["plan", "--h-weight", "0"],
        ["plan", "--h-weight", "-1"],
        ["plan", "--search", "uniform", "--h-weight", "0.5"],
        ["simulate", "--h-weight", "0"],
    ],
)
def test_weight_cli_rejects_what_it_cannot_use(runner, args: list[str]):
    result = runner.invoke(app, [args[0], str(MAPS / "kitchen.yaml"), *args[1:]])
    assert result.exit_code == 2
    assert "--h-weight" in result.stderr and "Traceback" not in result.output


def test_weight_reaches_the_planner_of_every_episode(runner):
    """--h-weight below 1 changes which plans simulate executes; the run stays reproducible."""
    base = ["simulate", str(MAPS / "kitchen.yaml"), "-n", "2", "--json", "--no-timings"]
    plain = runner.invoke(app, base)
    weighted = [runner.invoke(app, [*base, "--h-weight", "0.1"]) for _ in range(2)]
    assert plain.exit_code == 0 and weighted[0].exit_code == 0
    assert weighted[0].stdout == weighted[1].stdout
    assert json.loads(plain.stdout)["episodes"] != json.loads(weighted[0].stdout)["episodes"]


# --- property: uniform-cost plans are never costlier; both replay through `track` to the goal ------


@st.composite
def small_maps(draw: st.DrawFn) -> dict[str, Any]:
    rows, cols = draw(st.integers(1, 3)), draw(st.integers(1, 3))
    headings = draw(st.sampled_from([1, 4]))
    cells = [[r, c] for r in range(rows) for c in range(cols)]
    landmarks = draw(st.lists(st.sampled_from(cells), min_size=1, max_size=3, unique_by=tuple))
    classes = ["a", "b"]
    moves = ["up", "down", "left", "right"] if headings == 1 else ["forward", "backward", "rotate_cw"]
    failure = draw(st.sampled_from([0.0, 0.1]))
    noise = draw(st.sampled_from([0.0, 0.05]))
    return {
        "name": "random",
        "grid": {"rows": rows, "cols": cols, "headings": headings},
        "landmarks": [{"class": classes[i % 2], "cell": cell} for i, cell in enumerate(landmarks)],
        "actions": {m: {"cost": draw(st.sampled_from([1, 10])), "failure": failure} for m in moves},
        "sensors": {
            "look": {
                "type": "look",
                "classes": classes,
                "range": 1.0,
                "false_positive": noise,
                "false_negative": noise,
                "cost": 1,
            }
        },
    }


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=small_maps())
def test_uniform_cost_is_never_costlier_and_both_plans_replay(runner, data: dict[str, Any]):
    model = model_of(data)
    start = uniform(model.n_states)
    best = plan(model, start, max_expansions=3000)
    cheapest = plan(model, start, heuristic=Heuristic.ZERO, max_expansions=3000)
    assume(best.found and cheapest.found)
    assert cheapest.cost <= best.cost + 1e-9
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "map.yaml"
        path.write_text(yaml.safe_dump(data))
        for result in (best, cheapest):
            steps = [s.action if s.observation is None else f"{s.action}={s.observation}" for s in result.steps]
            if not steps:
                continue
            out = runner.invoke(app, ["track", str(path), "--json", *steps])
            assert out.exit_code == 0, out.output
            assert max(json.loads(out.stdout)["belief"].values()) >= 0.95


@settings(max_examples=30, deadline=None)
@given(data=small_maps())
def test_a_tiny_weight_finds_the_least_cost_plan(data: dict[str, Any]):
    """f = g + w·h with w -> 0 orders beliefs by g: the plan costs what uniform-cost search's costs
    (costs are whole numbers here, and w·h stays far below 1)."""
    model = model_of(data)
    start = uniform(model.n_states)
    cheapest = plan(model, start, heuristic=Heuristic.ZERO, max_expansions=3000)
    weighted = plan(model, start, weight=1e-12, max_expansions=3000)
    assume(cheapest.found and weighted.found)
    assert weighted.cost == cheapest.cost
    assert replay(model, start, weighted.steps).max() >= 0.95


def test_plan_cli_json_of_an_incomplete_plan_and_policy(runner):
    """Issue 28: out of budget, --json still carries the best partial plan, marked incomplete, with its
    path probability; a policy out of budget is marked incomplete beside its expected cost."""
    result = runner.invoke(app, ["plan", str(MAPS / "kitchen.yaml"), "--max-expansions", "2", "--json"])
    assert result.exit_code == EXIT_NEGATIVE
    data = json.loads(result.stdout)
    assert data["complete"] is False and data["status"] == "budget_exceeded" and data["steps"]
    assert data["path_probability"] == pytest.approx(float(np.prod([s["probability"] for s in data["steps"]])))
    result = runner.invoke(app, ["plan", str(MAPS / "kitchen.yaml"), "--policy", "--max-expansions", "2", "--json"])
    assert result.exit_code == EXIT_NEGATIVE
    policy = json.loads(result.stdout)
    assert policy["complete"] is False and policy["expected_cost"] > 0


def test_plan_cli_flags_a_path_below_the_floor(runner):
    """The kitchen's plan expects two observations seen together with probability 0.026 (< 0.05):
    flagged; the perfect window world's plan is as likely as its JSON says, and above the floor."""
    from beliefloc.planning.settings import PATH_PROBABILITY_FLOOR

    for name, flagged in (("kitchen.yaml", True), ("window-2x2-perfect.yaml", False)):
        data = json.loads(runner.invoke(app, ["plan", str(MAPS / name), "--json"]).stdout)
        assert (data["path_probability"] < PATH_PROBABILITY_FLOOR) is flagged
        text = " ".join(runner.invoke(app, ["plan", str(MAPS / name)]).stdout.split())
        assert f"path probability {data['path_probability']:.3g}" in text
        assert ("unlikely path" in text) is flagged
