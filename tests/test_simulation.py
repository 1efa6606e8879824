"""Episodes: act, perceive, update, replan (Colledanchise Algorithm 1, Main) against a simulated robot."""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

from beliefloc import compile_model, load_map, uniform
from beliefloc.cli.app import app
from beliefloc.errors import EXIT_NEGATIVE
from beliefloc.semantic_map.schema import SemanticMap
from beliefloc.simulation.episode import EpisodeRecord, run_episode, run_experiment, summarize
from beliefloc.simulation.robot import SimulatedRobot
from beliefloc.simulation.settings import StrategyName
from beliefloc.simulation.strategies import STRATEGIES, EpisodeStatus

from .conftest import MAPS, TWINS

SEEDS = range(8)


@pytest.fixture(scope="module")
def kitchen():
    return compile_model(load_map(MAPS / "kitchen.yaml"))


@pytest.fixture(scope="module")
def hallway():
    return compile_model(load_map(MAPS / "hallway.yaml"))


def test_simulated_robot_samples_the_model():
    """Right moves with 0.8 and stays with 0.2 (Fig. 2); Look sees a window with 0.8 / 0.1 (Fig. 3)."""
    model = compile_model(load_map(MAPS / "window-2x2.yaml"))
    rng = np.random.default_rng(0)
    moved = 0
    seen = {True: 0, False: 0}
    for _ in range(4000):
        robot = SimulatedRobot(model, model.states.index("0,0"), rng)
        robot.act("right")
        moved += robot.state == model.states.index("0,1")
        robot.state = model.states.index("1,0")  # a window cell
        seen[True] += model.action("look").observation.name(robot.act("look") or 0) == "window"
        robot.state = model.states.index("0,1")  # no window
        seen[False] += model.action("look").observation.name(robot.act("look") or 0) == "window"
    assert moved / 4000 == pytest.approx(0.8, abs=0.03)
    assert seen[True] / 4000 == pytest.approx(0.8, abs=0.03)
    assert seen[False] / 4000 == pytest.approx(0.1, abs=0.03)


@pytest.mark.parametrize("strategy", list(STRATEGIES))
def test_every_strategy_localizes_the_kitchen(kitchen, strategy: str):
    """The registry's smoke test: each strategy, on the same seeded start."""
    record = run_episode(kitchen, strategy, kitchen.states.index("1,1,1"), uniform(kitchen.n_states), seed=1)
    assert record.status is EpisodeStatus.LOCALIZED
    assert record.max_belief >= 0.95
    assert record.steps == len(record.trace) > 0
    assert record.cost == pytest.approx(sum(kitchen.action(s.action).cost for s in record.trace))


@pytest.mark.parametrize("seed", SEEDS)
def test_kitchen_from_the_papers_start_localizes_correctly(kitchen, seed: int):
    """Exp. 1: the robot in the centre of the kitchen, no prior on its pose."""
    record = run_episode(kitchen, "bestfirst", kitchen.states.index("1,1,1"), uniform(kitchen.n_states), seed=seed)
    assert record.status is EpisodeStatus.LOCALIZED and record.correct, record


@pytest.mark.parametrize("seed", SEEDS)
def test_hallway_from_the_papers_start_localizes_correctly(hallway, seed: int):
    """Exp. 2: the robot at the extinguisher's end of the hallway, facing the wall."""
    record = run_episode(hallway, "bestfirst", hallway.states.index("0,3,0"), uniform(hallway.n_states), seed=seed)
    assert record.status is EpisodeStatus.LOCALIZED and record.correct, record


def test_replans_follow_surprises(kitchen):
    records = run_experiment(kitchen, ["bestfirst"], episodes=10, seed=4)
    assert any(r.replans > 0 for r in records)
    for r in records:
        assert len(r.plan_seconds) == r.replans + 1
        planned = [s for s in r.trace if s.plan is not None]
        assert len(planned) == r.replans + 1


def test_paired_trials_share_starts(kitchen):
    records = run_experiment(kitchen, ["bestfirst", "random"], episodes=5, seed=9)
    by_episode: dict[int, set[str]] = {}
    for r in records:
        by_episode.setdefault(r.episode, set()).add(r.start)
    assert all(len(starts) == 1 for starts in by_episode.values())


def test_no_plan_is_an_honest_failure():
    twins = compile_model(SemanticMap.model_validate(TWINS))
    record = run_episode(twins, "bestfirst", 0, uniform(2), seed=0)
    assert record.status is EpisodeStatus.NO_PLAN and record.steps == 0 and record.max_belief == 0.5


def test_summary_uses_table_one_metric():
    def record(
        name: str, seconds: list[float], cost: float, status: EpisodeStatus = EpisodeStatus.LOCALIZED
    ) -> EpisodeRecord:
        return EpisodeRecord(name, 0, "s", "s", "s", True, status, cost, 3, len(seconds) - 1, seconds, 0.99)

    summary = summarize(
        [record("a", [1.0, 3.0], 10), record("a", [4.0], 20), record("a", [9.0], 99, EpisodeStatus.STEP_LIMIT)]
    )
    # per episode the mean over its plan calls (2, 4, 9), then the mean over episodes
    assert summary["a"].mean_plan_seconds == pytest.approx(5.0)
    assert summary["a"].mean_cost == pytest.approx(15.0)  # localized episodes only
    assert summary["a"].failures == {"step_limit": 1}
    assert summary["a"].mean_replans == pytest.approx(1 / 3)


def test_every_strategy_name_has_a_strategy():
    """The CLI offers the names of StrategyName; each must reach a strategy in the registry."""
    assert set(STRATEGIES) == set(StrategyName)


def test_same_seed_same_json_byte_for_byte(runner):
    args = ["simulate", str(MAPS / "kitchen.yaml"), "-n", "4", "--seed", "3", "--json", "--no-timings"]
    args += ["-s", "bestfirst", "-s", "random"]
    first, second = runner.invoke(app, args), runner.invoke(app, args)
    assert first.exit_code == 0, first.output
    assert first.stdout == second.stdout
    other = runner.invoke(app, [*args[:5], "4", *args[6:]])
    assert other.stdout != first.stdout


def test_simulate_json_schema(runner):
    result = runner.invoke(app, ["simulate", str(MAPS / "kitchen.yaml"), "-n", "2", "--json", "-s", "bestfirst"])
    assert result.exit_code == 0
    data = json.loads(result.stdout)
    episode = data["episodes"][0]
    assert {"start", "final", "correct", "cost", "steps", "replans", "plan_seconds"} <= set(episode)
    assert isinstance(episode["plan_seconds"], list) and len(episode["plan_seconds"]) == episode["replans"] + 1
    assert data["summary"]["bestfirst"]["episodes"] == 2


def test_simulate_show_tells_the_story(runner):
    result = runner.invoke(app, ["simulate", str(MAPS / "kitchen.yaml"), "--show", "--start", "1,1,1"])
    assert result.exit_code == 0
    out = result.stdout
    assert "start belief" in out and "plan" in out and "step 1:" in out
    assert "localized correctly" in out and "true state" in out


def test_simulate_says_which_options_no_chosen_strategy_reads(runner):
    kitchen = str(MAPS / "kitchen.yaml")
    result = runner.invoke(app, ["simulate", kitchen, "-n", "1", "--lookahead", "5", "--gamma", "0.1", "--json"])
    assert result.exit_code == 0
    assert "--lookahead is ignored: it is for -s contingent" in result.stderr
    assert "--gamma is ignored: it is for -s ec2 or -s ec2-macros" in result.stderr
    assert "--prune-below" not in result.stderr
    used = runner.invoke(
        app, ["simulate", kitchen, "-n", "1", "-s", "contingent", "-s", "ec2", "--lookahead", "50", "--gamma", "0.1"]
    )
    assert used.exit_code == 0 and "ignored" not in used.stderr


def test_simulate_unknown_strategy_and_failing_episodes(runner, tmp_path):
    result = runner.invoke(app, ["simulate", str(MAPS / "kitchen.yaml"), "-s", "astar"])
    assert result.exit_code == 2 and "unknown strategy 'astar'" in result.stderr
    twins = tmp_path / "twins.yaml"
    twins.write_text(yaml.safe_dump(TWINS))
    result = runner.invoke(app, ["simulate", str(twins)])
    assert result.exit_code == EXIT_NEGATIVE
    assert "not localizable" in result.stderr and result.stdout == ""  # said before any episode
    triplets = tmp_path / "triplets.yaml"  # no twin pairs: the episodes run, and their search finds no plan
    triplets.write_text(yaml.safe_dump({**TWINS, "name": "triplets", "grid": {"rows": 1, "cols": 3, "headings": 1}}))
    result = runner.invoke(app, ["simulate", str(triplets)])
    assert result.exit_code == EXIT_NEGATIVE
    assert "no plan" in result.stdout


def test_an_anytime_robot_doubles_its_budget_after_partial_plans_and_acts_on_their_first_step(
    kitchen, monkeypatch: pytest.MonkeyPatch
):
    """Issue 28: a plan call out of budget gives the best partial plan; the robot does its first step
    only, and the next call gets twice the seconds (up to max_time_limit), back to time_limit after a
    complete plan. The search's budget is forced by one expansion a call until the fourth call."""
    from beliefloc.planning import best_first
    from beliefloc.simulation import strategies

    limits: list[float] = []

    def forced(*args, **kwargs):  # type: ignore[no-untyped-def]
        limits.append(kwargs["time_limit"])
        if len(limits) <= 3:
            kwargs["max_expansions"] = 1
        return best_first.plan(*args, **kwargs)

    monkeypatch.setattr(strategies, "plan", forced)
    settings = strategies.PlannerSettings(time_limit=0.25, max_time_limit=0.6)
    record = run_episode(kitchen, "bestfirst", 5, uniform(kitchen.n_states), seed=0, settings=settings)
    assert record.status is EpisodeStatus.LOCALIZED
    assert limits[:4] == [0.25, 0.5, 0.6, 0.6]
    partial = [step.plan for step in record.trace[:3]]
    assert all(p is not None and p.partial for p in partial)  # a new plan before each of the first 3 actions
    assert [step.action for step in record.trace[:3]] == [p.steps[0].action for p in partial if p is not None]
