"""The SP-POMDP (issue 31, beliefloc/object_search/scene.py): the lower level's policy against an
enumeration of every policy, the higher level's outcome against a Monte Carlo of the simulated image,
perfect operators as a perfect detector, and scene models that must be refused at their line."""

from __future__ import annotations

import itertools
import math
import re

import numpy as np
import pytest
from typer.testing import CliRunner

from beliefloc.cli.app import app
from beliefloc.errors import EXIT_BAD_INPUT, DomainError
from beliefloc.knowledge import load_domain
from beliefloc.object_search.domain_space import search_space
from beliefloc.object_search.scene import (
    SAY_OTHER,
    SAY_TARGET,
    Operator,
    SceneModel,
    distractors,
    hl_present,
    sample_image,
    scene_model,
    simulate_scene,
    solve_low_level,
    solve_scene,
)
from beliefloc.object_search.scene_views import SceneSetup
from beliefloc.object_search.settings import Scenes

from .conftest import DATA, ROOT

COLOUR = np.array([[0.9, 0.1], [0.3, 0.7]])
SHAPE = np.array([[0.8, 0.2], [0.25, 0.75]])


def two_operators(error_cost: float = 10.0, rois: int = 3) -> SceneModel:
    """Two binary operators; the target is (0, 0), a distractor (1, 0) or (1, 1)."""
    return SceneModel(
        operators=(Operator("colour", 0.4, ("a", "b"), COLOUR), Operator("shape", 0.7, ("x", "y"), SHAPE)),
        appearance={"target": (0, 0), "near": (1, 0), "far": (1, 1)},
        background=(1, 1),
        rois=rois,
        error_cost=error_cost,
    )


def _enumerated_costs(model: SceneModel, prior: np.ndarray, looks: list[tuple[int, int]]) -> list[float]:
    """The expected cost of every deterministic LL policy on two operators, by plain loops over the
    states and the reports: a policy either answers now, or applies one operator and then, for each
    report, answers or applies the other one and answers for each report."""
    ops = model.operators
    answers = (SAY_TARGET, SAY_OTHER)

    def wrong(answer: int, state: int) -> float:
        return model.error_cost * float((answer == SAY_TARGET) != (state == 0))

    costs = []
    for answer in answers:  # answer at once
        costs.append(sum(prior[s] * wrong(answer, s) for s in range(len(looks))))
    for first in (0, 1):
        second = 1 - first
        n1, n2 = len(ops[first].values), len(ops[second].values)
        # per first report: ("answer", a) or ("apply", answers per second report)
        branches: list[list[tuple[str, tuple[int, ...]]]] = []
        for _ in range(n1):
            options: list[tuple[str, tuple[int, ...]]] = [("answer", (a,)) for a in answers]
            options += [("apply", combo) for combo in itertools.product(answers, repeat=n2)]
            branches.append(options)
        for plan in itertools.product(*branches):
            total = 0.0
            for s, look in enumerate(looks):
                for o1 in range(n1):
                    p1 = ops[first].confusion[look[first], o1]
                    kind, chosen = plan[o1]
                    cost = ops[first].cost
                    if kind == "answer":
                        total += prior[s] * p1 * (cost + wrong(chosen[0], s))
                        continue
                    for o2 in range(n2):
                        p2 = ops[second].confusion[look[second], o2]
                        total += prior[s] * p1 * p2 * (cost + ops[second].cost + wrong(chosen[o2], s))
            costs.append(total)
    return costs


def _policy_cost(model: SceneModel, policy, prior: np.ndarray) -> float:  # type: ignore[no-untyped-def]
    """The expected cost of a solved policy, walking its tree state by state."""
    total = 0.0
    for s in range(len(prior)):
        stack = [((), 1.0, 0.0)]
        while stack:
            history, p, spent = stack.pop()
            action = policy.actions[history]
            if action < 0:
                wrong = (action == SAY_TARGET) != (s == 0)
                total += prior[s] * p * (spent + model.error_cost * wrong)
                continue
            op = model.operators[action]
            for o in range(len(op.values)):
                q = policy.likelihoods[action][s, o]
                stack.append((tuple(sorted((*history, (action, o)))), p * q, spent + op.cost))
    return total


@pytest.mark.parametrize("error_cost", [0.5, 2.0, 6.0, 10.0, 40.0])
def test_low_level_policy_is_the_cheapest_of_all_policies(error_cost: float) -> None:
    model = two_operators(error_cost)
    mix = distractors(model, ["near", "far", "far"])
    policy = solve_low_level(model, model.look("target"), mix)
    looks = list(policy.looks)
    costs = _enumerated_costs(model, policy.prior, looks)
    assert len(costs) == 2 + 2 * (2 + 4) ** 2  # answer now; or either operator first, 6 choices per report
    assert policy.value == pytest.approx(min(costs), rel=1e-12)
    assert _policy_cost(model, policy, policy.prior) == pytest.approx(policy.value, rel=1e-12)


def test_low_level_trades_operators_for_reliability() -> None:
    cheap_errors = solve_low_level(two_operators(0.5), (0, 0), distractors(two_operators(), ["near", "far"]))
    dear_errors = solve_low_level(two_operators(40.0), (0, 0), distractors(two_operators(), ["near", "far"]))
    assert cheap_errors.actions[()] < 0  # errors cost less than any operator: answer at once
    assert dear_errors.actions[()] >= 0
    assert dear_errors.expected_operators(0) > cheap_errors.expected_operators(0)
    assert dear_errors.answer_target(0) > cheap_errors.answer_target(0) or cheap_errors.answer_target(0) in (0.0, 1.0)


def _monte_carlo(model: SceneModel, mix_classes: list[str], target_in_view: bool, n: int, seed: int):  # type: ignore[no-untyped-def]
    outcome = solve_scene(model, model.look("target"), distractors(model, mix_classes))
    rng = np.random.default_rng(seed)
    pool = [model.look(c) for c in mix_classes]
    present = time = operators = 0.0
    for _ in range(n):
        looks, where = sample_image(model, model.look("target") if target_in_view else None, pool, rng)
        trace = simulate_scene(model, outcome, looks, where, rng)
        present += trace.present
        time += trace.time
        operators += trace.operators
    return outcome, present / n, time / n, operators / n


@pytest.mark.parametrize(("in_view", "seed"), [(True, 1), (False, 2)])
def test_high_level_outcome_matches_a_monte_carlo_of_the_image(in_view: bool, seed: int) -> None:
    model = two_operators(10.0, rois=3)
    classes = ["near", "far", "far", "near", "far"]
    n = 6000
    outcome, p, time, operators = _monte_carlo(model, classes, in_view, n, seed)
    exact = outcome.true_positive if in_view else outcome.false_positive
    assert 0.0 < exact < 1.0
    assert abs(p - exact) < 4 * math.sqrt(exact * (1 - exact) / n)
    assert time == pytest.approx(outcome.time_in if in_view else outcome.time_out, rel=0.03)
    assert operators == pytest.approx(outcome.operators_in if in_view else outcome.operators_out, rel=0.03)


def test_apply_all_applies_every_operator_to_every_roi() -> None:
    model = two_operators(10.0, rois=3)
    mix = distractors(model, ["near", "far"])
    everything = solve_scene(model, (0, 0), mix, apply_all=True)
    planned = solve_scene(model, (0, 0), mix)
    assert everything.operators_in == pytest.approx(6.0) and everything.operators_out == pytest.approx(6.0)
    assert everything.time_out == pytest.approx(3 * (0.4 + 0.7))
    assert planned.operators_out < everything.operators_out


def test_high_level_belief_and_thresholds() -> None:
    model = two_operators()
    assert hl_present(model, 0.9, 0.1, 0, 0) == pytest.approx(model.prior_present)
    assert hl_present(model, 0.9, 0.1, 1, 1) > hl_present(model, 0.9, 0.1, 0, 0) > hl_present(model, 0.9, 0.1, 1, 0)
    # an uninformative lower level (alpha = beta) never moves the belief
    assert hl_present(model, 0.4, 0.4, 3, 2) == pytest.approx(model.prior_present)


def test_perfect_operators_are_a_perfect_detector() -> None:
    eye = np.eye(2)
    model = SceneModel(
        operators=(Operator("colour", 0.4, ("a", "b"), eye), Operator("shape", 0.7, ("x", "y"), eye)),
        appearance={"target": (0, 0), "near": (1, 0), "other": (0, 1)},
        background=(1, 1),
        rois=4,
    )
    outcome = solve_scene(model, (0, 0), distractors(model, ["near", "other", "other"]))
    assert outcome.alpha == 1.0 and outcome.beta == 0.0
    assert outcome.true_positive == pytest.approx(1.0) and outcome.false_positive == pytest.approx(0.0)
    rng = np.random.default_rng(0)
    pool = [(1, 0), (0, 1)]
    for in_view in (True, False):
        for _ in range(50):
            looks, where = sample_image(model, (0, 0) if in_view else None, pool, rng)
            assert simulate_scene(model, outcome, looks, where, rng).present is in_view


def test_home_views_are_solved_and_cached() -> None:
    domain = load_domain(ROOT / "domains" / "home.yaml")
    space = search_space(domain)
    setup = SceneSetup(domain, scene_model(domain), {"printer1": "study", "computer1": "study"})  # type: ignore[arg-type]
    planned = setup.space(space, "printer", Scenes.PLANNED)
    assert setup.space(space, "printer", Scenes.PLANNED) is planned  # cached
    assert planned.scene is not None
    tp, fp = planned.rates()
    assert isinstance(tp, np.ndarray) and tp.shape == (space.n_cells,)
    assert np.all(tp > fp)
    # rooms with no expected objects look alike (background only): one solution, shared
    assert len(setup.solver(Scenes.PLANNED)._cache) == 2
    assert setup.space(space, "printer", Scenes.FIXED) is space


INVALID = DATA / "invalid_domains" / "scene"
BAD = [
    ("unknown_operator.yaml", 16, r"scene\.appearance\.book\.shape: unknown operator 'shape'; expected one of: colour"),
    ("confusion_row.yaml", 13, r"scene\.operators\.colour\.confusion\.dark: a confusion row must sum to 1, got 1\.1"),
    ("no_appearance.yaml", 15, r"scene\.appearance: class 'book' \(at objects\.book1\.class\) has no appearance"),
    ("unknown_value.yaml", 16, r"scene\.appearance\.book\.colour: unknown value 'red' of operator 'colour'"),
]


def test_every_bad_scene_model_has_a_case() -> None:
    assert sorted(b[0] for b in BAD) == sorted(p.name for p in INVALID.glob("*.yaml"))


@pytest.mark.parametrize(("name", "line", "message"), BAD, ids=[b[0] for b in BAD])
def test_bad_scene_models_are_refused_at_their_line(name: str, line: int, message: str) -> None:
    path = INVALID / name
    with pytest.raises(DomainError, match=rf"{re.escape(str(path))}:{line}:\d+: {message}"):
        load_domain(path)
    result = CliRunner().invoke(app, ["kb", "check", str(path)])
    assert result.exit_code == EXIT_BAD_INPUT
    assert f"{name}:{line}:" in result.output.replace("\n", "")
    assert "Traceback" not in result.output


def test_a_scene_model_too_large_to_solve_exactly_is_refused() -> None:
    from beliefloc.knowledge.domain import domain_from_data

    values = [f"v{i}" for i in range(10)]
    table = {v: {w: (1.0 if v == w else 0.0) for w in values} for v in values}
    operators = {f"op{k}": {"cost": 0.1, "confusion": table} for k in range(6)}
    look = {f"op{k}": "v0" for k in range(6)}
    data = {
        "name": "big",
        "rooms": ["kitchen"],
        "classes": {"object": None, "cup": "object"},
        "objects": {"cup1": {"class": "cup"}},
        "scene": {"operators": operators, "appearance": {"cup": look}, "background": look},
    }
    with pytest.raises(DomainError, match=r"scene\.operators: too many operators and values .* 1,771,561 beliefs"):
        domain_from_data(data)
