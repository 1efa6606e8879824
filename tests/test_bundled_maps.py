"""Every bundled map loads, validates and compiles, and tells the story of its paper.

Shipped files are tests (STYLE.md, habit 10): each file in ``maps/`` is parametrised here, and the
worked examples of the papers are replayed on them: Colledanchise Fig. 4 and Sec. VII-B
Experiments 1-2, Khalvati & Mackworth Example 1.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest

from beliefloc import compile_model, load_map, uniform, update
from beliefloc.belief import most_likely, observation_probabilities
from beliefloc.cli.app import app
from beliefloc.model import Action, Model
from beliefloc.semantic_map import SemanticMap

from .conftest import MAPS

MAP_FILES = sorted(MAPS.glob("*.yaml"))


def _model(name: str) -> Model:
    return compile_model(load_map(MAPS / name))


def _noise_free_successor(action: Action, state: int) -> int:
    """Khalvati's f*(s, a) = argmax_s' P(s' | s, a); a perception action stays."""
    if action.transition is None:
        return state
    row = action.transition.getrow(state).toarray().ravel()
    return int(np.argmax(row))


def test_the_bundled_maps_are_there():
    names = {p.name for p in MAP_FILES}
    assert {"kitchen.yaml", "hallway.yaml", "khalvati-example1.yaml", "window-2x2.yaml"} <= names


# --- every file ---------------------------------------------------------------------------------


@pytest.mark.parametrize("path", MAP_FILES, ids=lambda p: p.name)
def test_loads_validates_and_compiles(path: Path):
    smap = load_map(path)
    assert isinstance(smap, SemanticMap)
    assert smap.source is not None and smap.source.path == str(path)
    model = compile_model(smap)
    assert model.n_states == int(smap.free.sum()) * smap.grid.headings
    assert model.source is smap.source
    assert [a.name for a in model.actuation_actions] == list(smap.actions)


@pytest.mark.parametrize("path", MAP_FILES, ids=lambda p: p.name)
def test_starts_with_a_comment_for_newcomers(path: Path):
    first = path.read_text(encoding="utf-8").splitlines()[0]
    assert first.startswith("# "), "a bundled map opens with a comment saying what it is and how to try it"


@pytest.mark.parametrize("path", MAP_FILES, ids=lambda p: p.name)
def test_transition_rows_sum_to_one(path: Path):
    model = compile_model(load_map(path))
    for action in model.actuation_actions:
        t = action.transition
        assert t is not None and t.shape == (model.n_states, model.n_states)
        assert (t.data >= 0).all(), action.name
        np.testing.assert_allclose(np.asarray(t.sum(axis=1)).ravel(), 1.0, err_msg=action.name)


@pytest.mark.parametrize("path", MAP_FILES, ids=lambda p: p.name)
def test_observation_rows_sum_to_one(path: Path):
    model = compile_model(load_map(path))
    for action in model.actions:
        o = action.observation.matrix()
        assert o.shape == (model.n_states, action.observation.n_observations)
        assert (o.data >= 0).all(), action.name
        np.testing.assert_allclose(np.asarray(o.sum(axis=1)).ravel(), 1.0, err_msg=action.name)


def test_cli_validate_accepts_every_bundled_map(runner):
    result = runner.invoke(app, ["validate", *map(str, MAP_FILES)])
    assert result.exit_code == 0, result.output
    for path in MAP_FILES:
        assert f"ok {path}" in " ".join(result.stdout.split())


# --- Colledanchise Fig. 4: perfect actions and observations ---------------------------------------


def _reachable_beliefs(model: Model, belief: np.ndarray, actions: list[str]) -> list[tuple[list[str], np.ndarray]]:
    """Every belief reached by ``actions``, one per observation sequence of non-zero probability."""
    frontier: list[tuple[list[str], np.ndarray]] = [([], belief)]
    for name in actions:
        action = model.action(name)
        successors = []
        for seen, b in frontier:
            probabilities = observation_probabilities(action, b)
            assert probabilities.sum() == pytest.approx(1.0)
            for o in np.flatnonzero(probabilities > 0):
                posterior, p = update(model, b, action, int(o))
                assert p == pytest.approx(probabilities[o])
                successors.append(([*seen, f"{name}={action.observation.name(int(o))}"], posterior))
        frontier = successors
    return frontier


@pytest.mark.parametrize("plan", [["right", "look"], ["look", "right"]], ids=", ".join)
def test_fig4_perfect_window_world_localizes_after_either_order(plan):
    model = _model("window-2x2-perfect.yaml")
    outcomes = _reachable_beliefs(model, uniform(model.n_states), plan)
    assert len(outcomes) == 2  # look reads window_seen or window_not_seen; right observes 'none'
    for steps, belief in outcomes:
        _, p = most_likely(belief)
        assert p == pytest.approx(1.0), (steps, belief)


# --- Colledanchise Sec. VII-B, Experiment 1: the kitchen ------------------------------------------

KITCHEN_TRUE_START = "1,1,1"  # the centre cell, facing east
KITCHEN_LOG = [
    ("look", "nothing"),
    ("scan", "no_wall"),
    ("rotate_ccw", None),
    ("look", "potted_plant"),
    ("forward", None),
    ("scan", "wall_0.2-0.8"),
]


def _replay_noise_free(model: Model, start: str, log: list[tuple[str, str | None]]) -> list[str]:
    """The true states along ``log`` when nothing fails, checking that each logged observation is
    the noise-free one there: the story is consistent with the true poses."""
    state = model.states.index(start)
    visited = []
    for name, observed in log:
        action = model.action(name)
        state = _noise_free_successor(action, state)
        if observed is not None:
            assert action.observation.name(action.observation.true_observation(state)) == observed, (name, state)
        visited.append(model.states.name(state))
    return visited


def test_kitchen_log_is_what_the_true_poses_observe():
    model = _model("kitchen.yaml")
    visited = _replay_noise_free(model, KITCHEN_TRUE_START, KITCHEN_LOG)
    assert visited == ["1,1,1", "1,1,1", "1,1,0", "1,1,0", "0,1,0", "0,1,0"]


def test_kitchen_story_localizes_the_robot():
    """Fig. 5 (a)-(g): after Look(potted plant) two states fit; Forward + Scan picks the true one."""
    model = _model("kitchen.yaml")
    assert model.n_states == 36
    belief = uniform(36)
    history = []
    for action, observation in KITCHEN_LOG:
        belief, _ = update(model, belief, action, observation)
        history.append(belief)
    names = model.states.names

    # Look: nothing -- the ten states that see no object share the mass
    assert np.count_nonzero(history[0] > 0.05) == 10
    # Scan: no_wall -- four states left, the true one among them
    top = {names[i] for i in np.flatnonzero(history[1] > 0.2)}
    assert top == {"1,1,1", "1,1,2", "1,2,2", "2,1,1"}
    # Look: potted_plant -- "two possible physical states match, with high probability"
    top = {names[i] for i in np.flatnonzero(history[3] > 0.45)}
    assert top == {"1,1,0", "2,1,0"}
    # Forward, Scan: wall_0.2-0.8 -- localized in the true final state (measured: 0.976)
    state, p = most_likely(belief)
    assert names[state] == "0,1,0"
    assert p >= 0.97


def _indistinguishable_classes(model: Model) -> list[list[str]]:
    """Classes of (start) states that no sequence of actions tells apart when nothing is noisy.

    Partition refinement (Khalvati's macro actions exist for a pair iff it ends up split): start
    from the noise-free readings of every perception action, then split states whose f*-successors
    under some actuation action fall into different classes (moves observe the passive sensors,
    which are in the signature too), until nothing changes. An empty result is sufficient for
    localization, not necessary: two states that a move merges (both bump into the same cell)
    are not told apart, yet afterwards the robot knows where it is (window-2x2 with 'right').
    """
    n = model.n_states
    signature = [
        tuple(a.observation.true_observation(s) for a in model.actions if a.transition is None)
        + tuple(a.observation.true_observation(_noise_free_successor(a, s)) for a in model.actuation_actions)
        for s in range(n)
    ]
    successors = [[_noise_free_successor(a, s) for s in range(n)] for a in model.actuation_actions]

    def relabel(keys: list[tuple[object, ...]]) -> list[int]:
        ids: dict[tuple[object, ...], int] = {}
        return [ids.setdefault(key, len(ids)) for key in keys]

    labels = relabel(signature)
    while True:
        refined = relabel([(labels[s], *(labels[f[s]] for f in successors)) for s in range(n)])
        if len(set(refined)) == len(set(labels)):
            break
        labels = refined
    classes: dict[int, list[str]] = {}
    for s, label in enumerate(labels):
        classes.setdefault(label, []).append(model.states.name(s))
    return [states for states in classes.values() if len(states) > 1]


def test_kitchen_states_with_equal_look_and_scan_are_separated_by_moving():
    model = _model("kitchen.yaml")
    look, scan = model.action("look").observation, model.action("scan").observation
    groups: dict[tuple[int, int], list[int]] = {}
    for s in range(model.n_states):
        groups.setdefault((look.true_observation(s), scan.true_observation(s)), []).append(s)
    ambiguous = [g for g in groups.values() if len(g) > 1]
    assert ambiguous, "the kitchen's corners should look alike to a single Look and Scan"
    # ... and yet every state can be told apart from every other one by moving and perceiving
    assert _indistinguishable_classes(model) == []


@pytest.mark.parametrize("name", ["hallway.yaml", "khalvati-example1.yaml"])
def test_every_state_can_be_told_apart(name: str):
    assert _indistinguishable_classes(_model(name)) == []


def test_window_world_without_perception_is_not_localizable():
    """The refinement above does find classes that cannot be split: no sensor, no localization."""
    smap = SemanticMap.model_validate(
        {"name": "blind", "grid": {"rows": 1, "cols": 3, "headings": 1}, "actions": {"right": {}, "left": {}}}
    )
    assert _indistinguishable_classes(compile_model(smap)) == [["0,0", "0,1", "0,2"]]


# --- Colledanchise Sec. VII-B, Experiment 2: the hallway ------------------------------------------

HALLWAY_TRUE_START = "0,3,0"  # the east end cell, facing north
HALLWAY_LOG = [
    ("scan", "wall_0.2-0.8"),
    ("rotate_cw", None),
    ("rotate_cw", None),
    ("look", "fire_extinguisher@18-30"),
]


def test_hallway_log_is_what_the_true_poses_observe():
    model = _model("hallway.yaml")
    visited = _replay_noise_free(model, HALLWAY_TRUE_START, HALLWAY_LOG)
    assert visited == ["0,3,0", "0,3,1", "0,3,2", "0,3,2"]


def test_hallway_only_one_state_sees_the_extinguisher_at_18_to_30_degrees():
    model = _model("hallway.yaml")
    look = model.action("look").observation
    seen = [model.states.name(s) for s in range(model.n_states) if look.name(look.true_observation(s)) != "nothing"]
    at_18_30 = [
        model.states.name(s)
        for s in range(model.n_states)
        if look.name(look.true_observation(s)) == "fire_extinguisher@18-30"
    ]
    assert at_18_30 == ["0,3,2"]
    assert len(seen) == 8


def test_hallway_story_localizes_the_robot():
    """Fig. 5 (h)-(m): Scan sees a wall, two clockwise rotations, Look sees the extinguisher at
    18-30 degrees: one state is left (measured: 0.979)."""
    model = _model("hallway.yaml")
    assert model.n_states == 32
    belief = uniform(32)
    history = []
    for action, observation in HALLWAY_LOG:
        belief, _ = update(model, belief, action, observation)
        history.append(belief)
    # Scan: wall_0.2-0.8 -- ten states face a wall 0.75 m ahead (N, S anywhere; E, W at the ends)
    assert np.count_nonzero(history[0] > 0.09) == 10
    assert history[0][history[0] > 0.09].sum() > 0.99
    state, p = most_likely(belief)
    assert model.states.name(state) == "0,3,2"
    assert p >= 0.97


# --- Khalvati & Mackworth, Example 1 --------------------------------------------------------------

KHALVATI_S = {"s1": "1,1", "s2": "3,1", "s3": "2,3", "s4": "3,4"}
KHALVATI_BELIEF = {"s1": 0.2, "s2": 0.2, "s3": 0.1, "s4": 0.5}
# Fig. 2 / Sec. IV-C: the pairs each action separates
KHALVATI_EDGES = {
    "up": {("s1", "s2"), ("s2", "s3"), ("s2", "s4")},
    "down": {("s1", "s3"), ("s1", "s4"), ("s2", "s3"), ("s2", "s4")},
    "right": {("s1", "s4"), ("s2", "s4"), ("s3", "s4")},
    "left": {("s1", "s2"), ("s1", "s4"), ("s2", "s3"), ("s3", "s4")},
}
KHALVATI_WEIGHTS = {"up": 0.16, "down": 0.24, "right": 0.25, "left": 0.21}


@pytest.fixture(scope="module")
def khalvati() -> Model:
    return _model("khalvati-example1.yaml")


def test_khalvati_s1_to_s4_all_read_0(khalvati):
    # the 'here' sensor is passive and not an action: a move observes the label of the cell reached
    assert [a.name for a in khalvati.actions] == ["up", "down", "left", "right"]
    here = khalvati.action("up").observation
    assert here.names() == ["0", "1"]
    for name in KHALVATI_S.values():
        state = khalvati.states.index(name)
        assert here.name(here.true_observation(state)) == "0", name


def _separated_pairs(model: Model, action: str) -> set[tuple[str, str]]:
    act = model.action(action)
    reading = {}
    for label, name in KHALVATI_S.items():
        reached = _noise_free_successor(act, model.states.index(name))
        reading[label] = act.observation.true_observation(reached)
    return {(i, j) for i, j in itertools.combinations(sorted(KHALVATI_S), 2) if reading[i] != reading[j]}


@pytest.mark.parametrize("action", ["up", "down", "right", "left"])
def test_khalvati_edges_of_fig2(khalvati, action):
    assert _separated_pairs(khalvati, action) == KHALVATI_EDGES[action]


@pytest.mark.parametrize("action", ["up", "down", "right", "left"])
def test_khalvati_action_weights_eq8_eq9(khalvati, action):
    """w(a) = sum over separated pairs of Bel(si) Bel(sj) min(p(f*|si,a), p(f*|sj,a)) / C(si,sj,a)."""
    act = khalvati.action(action)
    assert act.transition is not None
    weight = 0.0
    for i, j in _separated_pairs(khalvati, action):
        si, sj = khalvati.states.index(KHALVATI_S[i]), khalvati.states.index(KHALVATI_S[j])
        p_i = act.transition[si, _noise_free_successor(act, si)]
        p_j = act.transition[sj, _noise_free_successor(act, sj)]
        cost = act.cost  # Eq. 7: max(C(si, a), C(sj, a)); an action costs the same everywhere
        weight += KHALVATI_BELIEF[i] * KHALVATI_BELIEF[j] * min(p_i, p_j) / cost
    assert weight == pytest.approx(KHALVATI_WEIGHTS[action])


def test_khalvati_right_is_chosen_and_reading_0_localizes(khalvati):
    assert max(KHALVATI_WEIGHTS, key=KHALVATI_WEIGHTS.__getitem__) == "right"
    belief = np.zeros(khalvati.n_states)
    for label, name in KHALVATI_S.items():
        belief[khalvati.states.index(name)] = KHALVATI_BELIEF[label]
    after, p = update(khalvati, belief, "right", "0")
    assert p == pytest.approx(0.5)  # only s4 reads 0 after 'right'
    state, q = most_likely(after)
    assert khalvati.states.name(state) == "3,5" and q == pytest.approx(1.0)
