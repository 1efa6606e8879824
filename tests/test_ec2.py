"""Pairwise action selection (Khalvati & Mackworth Eq. 5-10): the kernels against plain loops,
Example 1 through the library and the CLI."""

from __future__ import annotations

import itertools
import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from beliefloc import compile_model, load_map
from beliefloc.cli.select import select_command
from beliefloc.model import Model
from beliefloc.planning.ec2 import (
    Candidate,
    candidate_weight,
    default_gamma,
    gamma_bounds,
    hypotheses,
    most_likely_successors,
    observation_difference,
    pair_context,
    select,
)
from beliefloc.semantic_map import SemanticMap

from .conftest import MAPS
from .test_bundled_maps import KHALVATI_BELIEF, KHALVATI_S, KHALVATI_WEIGHTS


def _model(name: str) -> Model:
    return compile_model(load_map(MAPS / name))


def _khalvati_belief(model: Model) -> np.ndarray:
    belief = np.zeros(model.n_states)
    for label, name in KHALVATI_S.items():
        belief[model.states.index(name)] = KHALVATI_BELIEF[label]
    return belief


def _eq5_plain(action_obs, i: int, j: int) -> float:
    """Eq. 5 literally, enumerating every joint observation."""
    o = action_obs.matrix().toarray()
    return 0.5 * float(np.sum(o[i] * (1 - o[j]) + o[j] * (1 - o[i])))


@pytest.mark.parametrize("name", ["kitchen.yaml", "hallway.yaml", "window-2x2.yaml", "khalvati-example1.yaml"])
def test_factorised_difference_equals_eq5(name: str):
    model = _model(name)
    rng = np.random.default_rng(0)
    for action in model.actions:
        i = rng.integers(model.n_states, size=15)
        j = rng.integers(model.n_states, size=15)
        fast = observation_difference(action.observation.parts, i, j)
        for k in range(15):
            assert fast[k] == pytest.approx(_eq5_plain(action.observation, int(i[k]), int(j[k]))), action.name


def test_most_likely_successor_breaks_ties_towards_the_lowest_state():
    smap = SemanticMap.model_validate(
        {"name": "tie", "grid": {"rows": 1, "cols": 3, "headings": 1}, "actions": {"right": {"failure": 0.5}}}
    )
    fstar, pstar = most_likely_successors(compile_model(smap))
    assert fstar[0].tolist() == [0, 1, 2]  # 0.5 stay / 0.5 move: the lower index, staying
    assert pstar[0].tolist() == [0.5, 0.5, 1.0]


def _weights_plain(model: Model, belief: np.ndarray, gamma: float) -> dict[str, float]:
    """Algorithm 1 literally: every pair, every action, Eq. 8 summed (Eq. 9)."""
    fstar, pstar = most_likely_successors(model)
    support = np.flatnonzero(belief > 0)
    out = {}
    for a, action in enumerate(model.actions):
        w = 0.0
        for si, sj in itertools.combinations(support.tolist(), 2):
            fi, fj = fstar[a, si], fstar[a, sj]
            if _eq5_plain(action.observation, fi, fj) > gamma:
                w += belief[si] * belief[sj] * min(pstar[a, si], pstar[a, sj]) / action.cost
        out[action.name] = w
    return out


def test_example1_weights_and_choice():
    model = _model("khalvati-example1.yaml")
    result = select(pair_context(model), _khalvati_belief(model))
    assert result.as_dict() == pytest.approx(KHALVATI_WEIGHTS)
    assert result.chosen_name == "right"


@pytest.mark.parametrize("name", ["kitchen.yaml", "hallway.yaml", "window-2x2.yaml"])
def test_weights_match_the_plain_loop(name: str):
    model = _model(name)
    rng = np.random.default_rng(1)
    ctx = pair_context(model)
    for _ in range(3):
        belief = rng.random(model.n_states) * (rng.random(model.n_states) < 0.5)
        belief /= belief.sum()
        assert select(ctx, belief).as_dict() == pytest.approx(_weights_plain(model, belief, ctx.gamma))


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(0.0, 1.0), min_size=36, max_size=36), st.floats(0.05, 0.95))
def test_grouped_sum_equals_pairwise_sum(values, gamma_position):
    """The O(m log m) signature-group sum equals the O(m^2) pairwise one for any belief."""
    model = _model("kitchen.yaml")
    belief = np.array(values)
    if belief.sum() == 0:
        return
    belief = belief / belief.sum()
    lo, hi = gamma_bounds(model)
    exact = pair_context(model)
    assert all(e for e, parts in zip(exact.exact, exact.parts, strict=True) if parts)
    states = hypotheses(belief)
    for a in range(len(model.actions)):
        fast = candidate_weight(exact, Candidate((a,)), states, belief)
        slow_ctx = pair_context(model, lo + (hi - lo) * gamma_position)
        object.__setattr__(slow_ctx, "exact", tuple(False for _ in slow_ctx.exact))
        assert fast == pytest.approx(candidate_weight(slow_ctx, Candidate((a,)), states, belief), abs=1e-12)


def test_default_gamma_lies_between_the_bounds():
    for name in ("kitchen.yaml", "hallway.yaml", "khalvati-example1.yaml", "corridors.yaml"):
        model = _model(name)
        lo, hi = gamma_bounds(model)
        assert lo <= default_gamma(model) < hi
    assert default_gamma(_model("khalvati-example1.yaml")) == 0.5  # noise-free: halfway between 0 and 1


def test_hypotheses_keep_the_most_likely():
    belief = np.array([0.1, 0.4, 0.0, 0.2, 0.3])
    assert hypotheses(belief).tolist() == [0, 1, 3, 4]
    assert hypotheses(belief, max_hypotheses=2).tolist() == [1, 4]
    assert hypotheses(belief, min_belief=0.25).tolist() == [1, 4]


def test_no_weight_means_no_choice():
    model = _model("khalvati-example1.yaml")
    belief = np.zeros(model.n_states)
    belief[model.states.index("1,1")] = 1.0
    assert select(pair_context(model), belief).chosen is None


# --- the command ----------------------------------------------------------------------------------


@pytest.fixture
def s1_s4(tmp_path):
    path = tmp_path / "s1-s4.json"
    path.write_text(json.dumps({KHALVATI_S[k]: v for k, v in KHALVATI_BELIEF.items()}))
    return path


def _app():
    import typer

    app = typer.Typer()
    app.command()(select_command)
    return app


def test_cli_select_prints_example1(runner, s1_s4):
    result = runner.invoke(_app(), [str(MAPS / "khalvati-example1.yaml"), "--belief", str(s1_s4)])
    assert result.exit_code == 0, result.output
    lines = {line.split()[0]: line.split()[1:] for line in result.stdout.splitlines() if line.strip()}
    assert lines["up"] == ["0.16"] and lines["down"] == ["0.24"] and lines["left"] == ["0.21"]
    assert lines["right"] == ["0.25", "chosen"]
    assert "chosen: right" in result.stdout


def test_cli_select_json_and_explain(runner, s1_s4):
    args = [str(MAPS / "khalvati-example1.yaml"), "--belief", str(s1_s4), "--json", "--explain"]
    result = runner.invoke(_app(), args)
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert data["weights"] == {"up": 0.16, "down": 0.24, "left": 0.21, "right": 0.25}
    assert data["chosen"] == "right"
    pairs = {frozenset((e["s_i"], e["s_j"])) for e in data["edges"]["right"]}
    assert pairs == {frozenset((KHALVATI_S[i], KHALVATI_S[j])) for i, j in [("s1", "s4"), ("s2", "s4"), ("s3", "s4")]}
    text = runner.invoke(_app(), [*args[:-2], "--explain"])
    assert "edges of right: 3" in text.stdout


def test_cli_select_with_nothing_to_gain_exits_1(runner, tmp_path):
    belief = tmp_path / "one.json"
    belief.write_text('{"1,1": 1.0}')
    result = runner.invoke(_app(), [str(MAPS / "khalvati-example1.yaml"), "--belief", str(belief)])
    assert result.exit_code == 1
    assert "no candidate has a positive weight" in result.stderr


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(0, 40), max_size=60), st.integers(0, 1))
def test_counted_ranks_and_pair_counts_equal_the_sorted_ones(values, shift):
    """ec2's ranks of small non-negative values (counted) are np.unique's inverse, and so are those of
    values the count does not take (sorted); the look-alike pair count by counting equals the sorted one."""
    from beliefloc.planning import ec2
    from beliefloc.planning.macros import count_indistinguishable_pairs

    array = np.array(values, dtype=np.int64) + shift * (ec2._COUNTED_RANGE - 20)
    _, inverse = np.unique(array, return_inverse=True)
    ranked = ec2._rank(array)
    assert ranked.dtype == np.int64 and np.array_equal(ranked, inverse.ravel())
    _, counts = np.unique(array, return_counts=True)
    expected = int((counts * (counts - 1) // 2).sum())
    assert count_indistinguishable_pairs(ranked) == expected
    assert count_indistinguishable_pairs(array) == expected


def _signature_part_by_part(parts, n_states: int) -> np.ndarray:
    """ec2.signature as it was: ranked after each part."""
    from beliefloc.planning.ec2 import _rank

    key = np.zeros(n_states, dtype=np.int64)
    for part in parts:
        key = _rank(key * part.confusion.shape[0] + part.truth.astype(np.int64))
    return key


@pytest.mark.parametrize("name", ["kitchen.yaml", "corridors.yaml", "tb3-sandbox.yaml", "window-2x2.yaml"])
def test_signature_ranked_once_equals_ranked_part_by_part(name: str):
    """Few values in all: the parts' values combined and ranked once give the ranks that ranking
    after every part gives, for all the model's parts and for each action's."""
    from beliefloc.planning.ec2 import full_parts, signature

    model = compile_model(load_map(MAPS / name))
    part_sets = [full_parts(model)] + [action.observation.parts for action in model.actions]
    for parts in part_sets:
        fast = signature(parts, model.n_states)
        assert fast.dtype == np.int64
        assert np.array_equal(fast, _signature_part_by_part(parts, model.n_states))
