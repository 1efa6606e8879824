"""Oracle tests: the vectorised kernels against plain loops, and the geometry against hand counts.

STYLE.md habit 6: keep a plain-loop reference of each vectorised kernel in the test and compare.
The references below loop over states and observation parts one number at a time; the geometry
cases are small enough to work out on paper (the comments give the arithmetic).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from pydantic import ValidationError

from beliefloc import compile_model, load_map, uniform, update
from beliefloc.belief import observation_probabilities, predict
from beliefloc.errors import FieldError
from beliefloc.model import Model, ObservationModel
from beliefloc.semantic_map import SemanticMap, geometry, layout_of

from .conftest import MAPS, SMALL_MODEL_STATES

INF = math.inf


def _compile(data: dict[str, Any]) -> Model:
    return compile_model(SemanticMap.model_validate(data))


def _map(rows: int, cols: int, headings: int = 4, **extra: Any) -> dict[str, Any]:
    moves = ("up", "down", "left", "right") if headings == 1 else ("forward", "backward", "rotate_cw", "rotate_ccw")
    failure = extra.pop("failure", 0.0)
    data: dict[str, Any] = {
        "name": "hand",
        "grid": {"rows": rows, "cols": cols, "headings": headings, "cell_size": extra.pop("cell_size", 1.2)},
        "actions": {m: {"failure": failure} for m in moves},
    }
    data.update(extra)
    return data


# --- plain-loop references ------------------------------------------------------------------------


def ref_likelihood(obs: ObservationModel, o: int) -> np.ndarray:
    """O[j, o] = prod over parts p of C_p[truth_p[j], reading_p(o)], one state at a time."""
    readings = obs.decode(o)
    out = np.empty(obs.n_states)
    for j in range(obs.n_states):
        p = 1.0
        for part, w in zip(obs.parts, readings, strict=True):
            p *= float(part.confusion[int(part.truth[j]), w])
        out[j] = p
    return out


def ref_matrix(obs: ObservationModel, states: list[int]) -> np.ndarray:
    table = np.empty((len(states), obs.n_observations))
    for row, j in enumerate(states):
        for o in range(obs.n_observations):
            p = 1.0
            for part, w in zip(obs.parts, obs.decode(o), strict=True):
                p *= float(part.confusion[int(part.truth[j]), w])
            table[row, o] = p
    return table


def ref_predict(model: Model, action: str, belief: np.ndarray) -> np.ndarray:
    """predicted[j] = sum_i T[i, j] b[i] (the identity for a perception action)."""
    act = model.action(action)
    if act.transition is None:
        return belief.copy()
    dense = act.transition.toarray()
    n = model.n_states
    out = np.zeros(n)
    for i in range(n):
        for j in range(n):
            out[j] += dense[i, j] * belief[i]
    return out


def ref_probabilities(model: Model, action: str, belief: np.ndarray) -> np.ndarray:
    obs = model.action(action).observation
    predicted = ref_predict(model, action, belief)
    out = np.zeros(obs.n_observations)
    for o in range(obs.n_observations):
        column = ref_likelihood(obs, o)
        for j in range(model.n_states):
            out[o] += predicted[j] * column[j]
    return out


def ref_update(model: Model, belief: np.ndarray, action: str, o: int) -> tuple[np.ndarray, float]:
    predicted = ref_predict(model, action, belief)
    column = ref_likelihood(model.action(action).observation, o)
    weighted = [predicted[j] * column[j] for j in range(model.n_states)]
    total = sum(weighted)
    return np.array([w / total for w in weighted]), total


def _oracle_models() -> list[tuple[str, Model]]:
    bundled = [(p.stem, compile_model(load_map(p))) for p in sorted(MAPS.glob("*.yaml"))]
    models = [(name, model) for name, model in bundled if model.n_states <= SMALL_MODEL_STATES]
    # blocked cells, 8 headings, a passive Look with angle bins and a Scan, noisy moves
    hand = _map(
        3,
        4,
        headings=8,
        failure=0.1,
        layout="..#.\n....\n.#..",
        landmarks=[{"class": "chair", "cell": [0, 0]}, {"class": "door", "cell": [2, 3]}],
        sensors={
            "look": {
                "type": "look",
                "classes": ["chair", "door"],
                "angle_bins": [20, 45],
                "false_positive": 0.05,
                "false_negative": 0.1,
                "passive": True,
            },
            "scan": {"type": "scan", "bins": [0.5, 1.0, 2.0], "error": 0.2},
            "here": {"type": "here", "error": 0.1, "default": "floor"},
        },
    )
    models.append(("hand-8", _compile(hand)))
    return models


ORACLE_MODELS = _oracle_models()
ORACLE_IDS = [name for name, _ in ORACLE_MODELS]


def _random_belief(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    belief = rng.dirichlet(np.ones(n))
    belief[rng.random(n) < 0.3] = 0.0  # some states ruled out, as in a real belief
    return belief / belief.sum() if belief.sum() > 0 else uniform(n)


# --- the observation kernels ----------------------------------------------------------------------


@pytest.mark.parametrize(("name", "model"), ORACLE_MODELS, ids=ORACLE_IDS)
def test_likelihood_matches_the_loop(name: str, model: Model):
    for action in model.actions:
        obs = action.observation
        for o in range(obs.n_observations):
            np.testing.assert_allclose(obs.likelihood(o), ref_likelihood(obs, o), err_msg=f"{action.name} {o}")
            subset = np.arange(0, model.n_states, 3)
            np.testing.assert_allclose(obs.likelihood(o, subset), ref_likelihood(obs, o)[subset])


@pytest.mark.parametrize(("name", "model"), ORACLE_MODELS, ids=ORACLE_IDS)
def test_likelihood_matrix_and_matrix_match_the_loop(name: str, model: Model):
    states = list(range(model.n_states))
    for action in model.actions:
        obs = action.observation
        expected = ref_matrix(obs, states)
        np.testing.assert_allclose(obs.likelihood_matrix(np.array(states)), expected, err_msg=action.name)
        np.testing.assert_allclose(obs.matrix().toarray(), expected, err_msg=action.name)


@pytest.mark.parametrize(("name", "model"), ORACLE_MODELS, ids=ORACLE_IDS)
def test_probabilities_match_the_loop(name: str, model: Model):
    belief = _random_belief(model.n_states, seed=len(name))
    for action in model.actions:
        expected = ref_probabilities(model, action.name, belief)
        np.testing.assert_allclose(observation_probabilities(action, belief), expected, atol=1e-12)
        predicted = predict(action, belief)
        np.testing.assert_allclose(predicted, ref_predict(model, action.name, belief), atol=1e-12)
        np.testing.assert_allclose(action.observation.probabilities(predicted), expected, atol=1e-12)


@pytest.mark.parametrize(("name", "model"), ORACLE_MODELS, ids=ORACLE_IDS)
def test_update_matches_the_loop(name: str, model: Model):
    belief = _random_belief(model.n_states, seed=7 + len(name))
    before = belief.copy()
    for action in model.actions:
        probabilities = ref_probabilities(model, action.name, belief)
        for o in np.flatnonzero(probabilities > 1e-12):
            posterior, p = update(model, belief, action.name, int(o))
            expected, q = ref_update(model, belief, action.name, int(o))
            assert p == pytest.approx(q, rel=1e-9)
            np.testing.assert_allclose(posterior, expected, atol=1e-12)
            by_name, _ = update(model, belief, action.name, action.observation.name(int(o)))
            np.testing.assert_array_equal(by_name, posterior)
    np.testing.assert_array_equal(belief, before)  # inputs are never modified


def test_true_observation_is_the_argmax_of_each_part():
    model = dict(ORACLE_MODELS)["hand-8"]
    for action in model.actions:
        obs = action.observation
        for j in range(model.n_states):
            expected = obs.encode([int(np.argmax(p.confusion[int(p.truth[j])])) for p in obs.parts])
            assert obs.true_observation(j) == expected
            assert int(np.argmax(ref_matrix(obs, [j])[0])) == expected


# --- Scan: wall distances -------------------------------------------------------------------------


def ref_wall_distance(free: np.ndarray, r: int, c: int, dr: int, dc: int, cell_size: float) -> float:
    """Walk cell by cell until a blocked cell, the grid's edge, or (diagonally) a corner between two
    blocked cells: (k - 0.5) steps."""
    step = math.hypot(dr, dc) * cell_size
    k = 1
    while True:
        r2, c2 = r + k * dr, c + k * dc
        if not (0 <= r2 < free.shape[0] and 0 <= c2 < free.shape[1]) or not free[r2, c2]:
            return (k - 0.5) * step
        if dr and dc and not free[r2 - dr, c2] and not free[r2, c2 - dc]:
            return (k - 0.5) * step
        k += 1


def _layout(rows: int, cols: int, headings: int, layout: str | None = None, cell_size: float = 1.2):
    data = _map(rows, cols, headings, cell_size=cell_size)
    if layout is not None:
        data["layout"] = layout
    return layout_of(SemanticMap.model_validate(data))


def _state(grid, r: int, c: int, h: int = 0) -> int:
    state = grid.state_of(r, c, h)
    assert state >= 0
    return state


def test_wall_distances_in_the_kitchen_grid():
    grid = _layout(3, 3, 4)
    d = geometry.wall_distances(grid, 1.5)
    assert d[_state(grid, 0, 1, 0)] == pytest.approx(0.6)  # facing the edge next to it: half a cell
    assert d[_state(grid, 2, 0, 3)] == pytest.approx(0.6)
    for h in range(4):  # the centre: 1.5 cells = 1.8 m to every wall, beyond the last bin
        assert d[_state(grid, 1, 1, h)] == INF
    assert d[_state(grid, 0, 0, 1)] == INF  # along the north wall: 2.5 cells = 3.0 m
    far = geometry.wall_distances(grid, 10.0)
    assert far[_state(grid, 1, 1, 2)] == pytest.approx(1.8)
    assert far[_state(grid, 0, 0, 1)] == pytest.approx(3.0)


@pytest.mark.parametrize("headings", [4, 8])
@pytest.mark.parametrize("layout", [None, "..#.\n....\n.#..\n....", "...#\n..#.\n....\n#..."])
def test_wall_distances_match_the_walk(headings: int, layout: str | None):
    grid = _layout(4, 4, headings, layout, cell_size=0.7)
    d = geometry.wall_distances(grid, 100.0)
    rows, cols, heads = grid.cell_heading(np.arange(grid.n_states))
    for s, (r, c, h) in enumerate(zip(rows.tolist(), cols.tolist(), heads.tolist(), strict=True)):
        dr, dc = geometry.HEADING_VECTORS[headings][h]
        assert d[s] == pytest.approx(ref_wall_distance(grid.free, r, c, dr, dc, 0.7)), (r, c, h)


def test_wall_distance_on_a_diagonal_and_at_a_blocked_cell():
    grid = _layout(3, 3, 8, "...\n.#.\n...")
    d = geometry.wall_distances(grid, 5.0)
    diagonal = math.sqrt(2) * 1.2
    assert d[_state(grid, 0, 0, 1)] == pytest.approx(0.5 * diagonal)  # NE from a corner: the edge
    assert d[_state(grid, 0, 0, 3)] == pytest.approx(0.5 * diagonal)  # SE: the blocked centre
    assert d[_state(grid, 0, 1, 4)] == pytest.approx(0.6)  # S: the blocked centre
    assert d[_state(grid, 2, 0, 2)] == pytest.approx(3.0)  # E along the south row


def test_a_diagonal_beam_stops_at_a_diagonal_wall():
    grid = _layout(3, 3, 8, "..#\n.#.\n...")  # a diagonal wall: (0,2) and (1,1) touch at a corner
    d = geometry.wall_distances(grid, 5.0)
    diagonal = math.sqrt(2) * 1.2
    # from (1,2) facing NW the beam would pass between (0,2) and (1,1): no gap, the wall is at the corner
    assert d[_state(grid, 1, 2, 7)] == pytest.approx(0.5 * diagonal)
    # from (2,1) facing NE it passes the corner of (1,1) and the free (2,2): on to the grid's edge
    assert d[_state(grid, 2, 1, 1)] == pytest.approx(1.5 * diagonal)


def test_scan_reading_on_a_bin_edge_is_the_bin_below():
    """A wall exactly at an upper edge reads that bin: 0.8 m with bins [0.2, 0.8, ...]."""
    data = _map(1, 3, cell_size=1.6, sensors={"scan": {"type": "scan", "bins": [0.2, 0.8, 1.1, 1.5]}})
    scan = _compile(data).action("scan").observation
    grid = _compile(data).grid
    assert grid is not None
    assert scan.name(scan.true_observation(_state(grid, 0, 0, 0))) == "wall_0.2-0.8"  # 0.8 m north
    assert scan.name(scan.true_observation(_state(grid, 0, 0, 1))) == "no_wall"  # 2.5 * 1.6 = 4 m east


# --- Look: field of view, range, occlusion ----------------------------------------------------------


def _seen(grid, landmark, view_range, fov, occlusion=True) -> dict[str, float]:
    states, angles = geometry.viewing_angles(grid, landmark, view_range, fov, occlusion)
    names = [f"{r},{c},{h}" for r, c, h in zip(*(a.tolist() for a in grid.cell_heading(states)), strict=True)]
    return dict(zip(names, angles.tolist(), strict=True))


def test_look_fov_90_and_range_in_a_3x3_grid():
    grid = _layout(3, 3, 4)
    seen = _seen(grid, (0, 1), 2.0, 90.0)
    assert seen["1,1,0"] == pytest.approx(0.0)  # straight ahead, 1.2 m
    assert "1,1,1" not in seen  # facing east, the chair is 90 degrees to the left
    assert seen["1,0,0"] == pytest.approx(45.0)  # 1.7 m at 45 degrees: on the edge of a 90 fov
    assert "2,1,0" not in seen  # 2.4 m: out of range
    assert "2,0,0" not in seen  # 2.68 m
    for h in range(4):
        assert seen[f"0,1,{h}"] == 0.0  # its own cell is always in view
    assert "2,2,3" not in seen  # facing west from the far corner: 63 degrees off axis
    assert set(seen) == {"1,1,0", "1,0,0", "1,0,1", "1,2,0", "1,2,3", "0,0,1", "0,2,3"} | {f"0,1,{h}" for h in range(4)}
    narrow = _seen(grid, (0, 1), 2.5, 60.0)
    assert "1,0,0" not in narrow  # 45 degrees is outside a 60-degree field of view
    assert narrow["2,1,0"] == pytest.approx(0.0)  # 2.4 m: in range now


def test_look_range_0_sees_only_the_own_cell():
    grid = _layout(2, 2, 1)
    assert set(_seen(grid, (1, 0), 0.0, 360.0)) == {"1,0,0"}


def test_look_is_occluded_by_a_blocked_cell():
    grid = _layout(1, 3, 4, ".#.")
    assert "0,0,1" not in _seen(grid, (0, 2), None, 90.0)
    assert _seen(grid, (0, 2), None, 90.0, occlusion=False)["0,0,1"] == 0.0
    open_grid = _layout(1, 3, 4)
    assert open_grid.free.all()
    assert _seen(open_grid, (0, 2), None, 90.0)["0,0,1"] == 0.0


def _clear_by_brute_force(free: np.ndarray, start: tuple[int, int], end: tuple[int, int]) -> bool:
    """The line-of-sight rule, one blocked cell and one corner at a time: the segment between the
    centres may not cross the inside of a blocked cell (Liang-Barsky clipping, positive length) other
    than its end cells, nor pass a corner whose two cells beside the segment are both blocked."""
    (r0, c0), (r1, c1) = start, end
    dr, dc = r1 - r0, c1 - c0
    if dr == dc == 0:
        return True
    rows, cols = free.shape
    for r in range(rows):
        for c in range(cols):
            if free[r, c] or (r, c) in (start, end):
                continue
            t0, t1, inside = 0.0, 1.0, True
            for p, q in ((-dr, r0 - r + 0.5), (dr, r - r0 + 0.5), (-dc, c0 - c + 0.5), (dc, c - c0 + 0.5)):
                if p == 0:
                    inside = inside and q > 0
                elif p < 0:
                    t0 = max(t0, q / p)
                else:
                    t1 = min(t1, q / p)
            if inside and t1 - t0 > 1e-9:
                return False
    for k in range(rows - 1):
        for m in range(cols - 1):
            y, x = k + 0.5, m + 0.5
            if dr * (x - c0) != dc * (y - r0):
                continue  # not on the line
            t = ((y - r0) * dr + (x - c0) * dc) / (dr * dr + dc * dc)
            beside = ((k, m + 1), (k + 1, m)) if (dr > 0) == (dc > 0) else ((k, m), (k + 1, m + 1))
            if 0 < t < 1 and not any(free[cell] for cell in beside):
                return False
    return True


def test_line_of_sight_is_exact_on_random_layouts():
    rng = np.random.default_rng(7)
    checked = 0
    for _ in range(150):
        rows, cols = (int(n) for n in rng.integers(1, 9, size=2))
        free = rng.random((rows, cols)) > rng.choice([0.2, 0.4])
        rr, cc = (a.ravel() for a in np.mgrid[0:rows, 0:cols])
        lr, lc = int(rng.integers(rows)), int(rng.integers(cols))
        got = geometry._line_of_sight(free, rr, cc, lr, lc)
        for i in range(len(rr)):
            assert got[i] == _clear_by_brute_force(free, (int(rr[i]), int(cc[i])), (lr, lc)), (free, rr[i], cc[i])
            checked += 1
    assert checked > 3000


@pytest.mark.parametrize(
    ("layout", "start", "end", "clear"),
    [
        # a diagonal wall has no gap: the segment (1,1)-(2,0) passes the corner between (1,0) and (2,1)
        (".#\n#.\n.#", (1, 1), (2, 0), False),
        # one blocked cell touched only at its corner does not hide anything
        ("..\n#.\n..", (1, 1), (2, 0), True),
        # crossed for a short stretch near its corner: sampling 4 points a cell missed this one
        (".#.#.\n...#.\n.#.#.\n#.##.\n#....", (4, 1), (1, 2), False),
        ("...\n.#.\n...", (0, 0), (2, 2), False),  # straight through the centre of a blocked cell
    ],
)
def test_line_of_sight_cases(layout: str, start: tuple[int, int], end: tuple[int, int], clear: bool):
    free = np.array([[ch == "." for ch in row] for row in layout.split("\n")])
    assert bool(geometry._line_of_sight(free, np.array([start[0]]), np.array([start[1]]), *end)[0]) is clear
    assert bool(geometry._line_of_sight(free, np.array([end[0]]), np.array([end[1]]), *start)[0]) is clear


def test_look_with_angle_bins_uses_the_bin_whose_upper_edge_is_reached():
    data = _map(
        1,
        4,
        sensors={"look": {"type": "look", "classes": ["chair"], "angle_bins": [18, 30, 45]}},
        annotations=[
            {"state": "0,0,0", "look": {"chair": 18}},
            {"state": "0,0,1", "look": {"chair": 18.5}},
            {"state": "0,0,2", "look": {"chair": -45}},
            {"state": "0,0,3", "look": {"chair": 0}},
            {"state": "0,1", "look": {}},
        ],
    )
    model = _compile(data)
    look = model.action("look").observation
    names = {s: look.name(look.true_observation(model.states.index(s))) for s in ("0,0,0", "0,0,1", "0,0,2", "0,0,3")}
    assert names == {
        "0,0,0": "chair@0-18",
        "0,0,1": "chair@18-30",
        "0,0,2": "chair@30-45",
        "0,0,3": "chair@0-18",
    }
    for h in range(4):
        assert look.true_observation(model.states.index(f"0,1,{h}")) == 0


def test_look_confusion_tables():
    data = _map(
        1,
        2,
        landmarks=[{"class": "chair", "cell": [0, 0]}],
        sensors={
            "plain": {"type": "look", "classes": ["chair"], "false_positive": 0.1, "false_negative": 0.2},
            "binned": {
                "type": "look",
                "classes": ["chair"],
                "angle_bins": [10, 45],
                "false_positive": 0.1,
                "false_negative": 0.2,
            },
        },
    )
    model = _compile(data)
    plain = model.action("plain").observation.parts[0].confusion
    np.testing.assert_allclose(plain, [[0.9, 0.1], [0.2, 0.8]])
    binned = model.action("binned").observation.parts[0].confusion
    np.testing.assert_allclose(binned, [[0.9, 0.05, 0.05], [0.2, 0.8, 0.0], [0.2, 0.0, 0.8]])


def test_annotations_override_the_geometry_in_the_hallway():
    model = compile_model(load_map(MAPS / "hallway.yaml"))
    look = model.action("look").observation
    # the extinguisher's landmark is in cell [0, 3], but facing north from there it is out of view
    assert look.true_observation(model.states.index("0,3,0")) == 0
    assert look.name(look.true_observation(model.states.index("0,3,2"))) == "fire_extinguisher@18-30"
    # cells further away keep the geometry: facing east it is on the axis
    assert look.name(look.true_observation(model.states.index("0,0,2"))) == "fire_extinguisher@0-18"


# --- moves ------------------------------------------------------------------------------------------


def test_moves_at_the_border_bump_and_stay():
    grid = _layout(3, 3, 4, "...\n...\n.#.")
    forward = geometry.motion_targets(grid, "forward")
    backward = geometry.motion_targets(grid, "backward")
    s = lambda r, c, h: _state(grid, r, c, h)  # noqa: E731
    assert forward[s(0, 1, 0)] == s(0, 1, 0)  # north edge
    assert forward[s(1, 1, 0)] == s(0, 1, 0)
    assert forward[s(1, 1, 2)] == s(1, 1, 2)  # the cell south of it is blocked
    assert forward[s(1, 2, 1)] == s(1, 2, 1)  # east edge
    assert forward[s(1, 2, 3)] == s(1, 1, 3)  # west, keeping the heading
    assert backward[s(1, 1, 0)] == s(1, 1, 0)  # backward from facing north goes south: blocked
    assert backward[s(1, 1, 1)] == s(1, 0, 1)
    assert backward[s(0, 0, 2)] == s(0, 0, 2)  # backward from facing south goes north: the edge


def test_rotations_wrap_around():
    for headings in (4, 8):
        grid = _layout(2, 2, headings)
        cw = geometry.motion_targets(grid, "rotate_cw")
        ccw = geometry.motion_targets(grid, "rotate_ccw")
        last = headings - 1
        assert cw[_state(grid, 1, 1, last)] == _state(grid, 1, 1, 0)
        assert ccw[_state(grid, 1, 1, 0)] == _state(grid, 1, 1, last)
        np.testing.assert_array_equal(ccw[cw], np.arange(grid.n_states))


def test_diagonal_and_compass_moves():
    grid = _layout(3, 3, 8)
    forward = geometry.motion_targets(grid, "forward")
    backward = geometry.motion_targets(grid, "backward")
    assert forward[_state(grid, 1, 1, 1)] == _state(grid, 0, 2, 1)  # NE
    assert forward[_state(grid, 0, 2, 1)] == _state(grid, 0, 2, 1)  # NE from the NE corner: bump
    assert backward[_state(grid, 1, 1, 1)] == _state(grid, 2, 0, 1)  # SW, still facing NE
    assert forward[_state(grid, 1, 1, 5)] == _state(grid, 2, 0, 5)  # SW
    compass = _layout(2, 2, 1)
    right = geometry.motion_targets(compass, "right")
    up = geometry.motion_targets(compass, "up")
    assert right[_state(compass, 0, 0)] == _state(compass, 0, 1)
    assert right[_state(compass, 0, 1)] == _state(compass, 0, 1)
    assert up[_state(compass, 1, 0)] == _state(compass, 0, 0)
    assert up[_state(compass, 0, 0)] == _state(compass, 0, 0)


def test_a_diagonal_move_does_not_pass_through_a_diagonal_wall():
    grid = _layout(3, 3, 8, "..#\n.#.\n...")  # (0,2) and (1,1) touch at a corner
    forward = geometry.motion_targets(grid, "forward")
    backward = geometry.motion_targets(grid, "backward")
    assert forward[_state(grid, 1, 2, 7)] == _state(grid, 1, 2, 7)  # NW into the wall's corner: stays
    assert backward[_state(grid, 0, 1, 7)] == _state(grid, 0, 1, 7)  # and back the other way
    assert forward[_state(grid, 2, 1, 1)] == _state(grid, 1, 2, 1)  # past one blocked corner: moves


@pytest.mark.parametrize("failure", [0.0, 0.02, 0.3, 0.5, 1.0])
def test_failure_mass_stays_on_the_diagonal(failure: float):
    model = _compile(_map(3, 3, 4, failure=failure, layout="...\n.#.\n..."))
    for action in model.actuation_actions:
        t = action.transition
        assert t is not None and t.has_sorted_indices
        targets = geometry.motion_targets(model.grid, action.name)
        expected = np.zeros((model.n_states, model.n_states))
        for i, j in enumerate(targets.tolist()):
            expected[i, j] += 1.0 - failure
            expected[i, i] += failure
        np.testing.assert_allclose(t.toarray(), expected, err_msg=action.name)
        assert t.getnnz(axis=1).max() <= 2


# --- regressions: bugs found while writing these tests, now fixed -------------------------------------


def test_angle_bins_narrower_than_the_fov_are_rejected():
    data = _map(
        5,
        5,
        landmarks=[{"class": "chair", "cell": [0, 4]}],
        sensors={"look": {"type": "look", "classes": ["chair"], "angle_bins": [18, 30, 45], "fov": 120}},
    )
    with pytest.raises((ValidationError, FieldError)):
        SemanticMap.model_validate(data)


def test_here_default_class_nothing_round_trips():
    """A here sensor's default class is 'nothing', the same word as the all-silent joint name."""
    data = _map(2, 2, headings=1, landmarks=[{"class": "window", "cell": [1, 0]}], sensors={"here": {"type": "here"}})
    obs = _compile(data).action("here").observation
    assert obs.names() == ["nothing", "window"]
    assert [obs.index(name) for name in obs.names()] == [0, 1]


def test_a_class_both_looked_for_and_read_here_round_trips():
    data = _map(
        2,
        2,
        landmarks=[{"class": "chair", "cell": [0, 0]}],
        sensors={
            "look": {"type": "look", "classes": ["chair"], "passive": True},
            "here": {"type": "here", "passive": True},
        },
    )
    obs = _compile(data).action("forward").observation
    assert obs.names() == ["nothing", "chair", "chair+nothing", "chair+chair"]
    assert [obs.index(name) for name in obs.names()] == [0, 1, 2, 3]


def test_here_label_characters_must_be_names_without_a_legend():
    data = _map(1, 2, headings=1, sensors={"here": {"type": "here", "labels": "+a"}})
    with pytest.raises((ValidationError, FieldError)):
        SemanticMap.model_validate(data)


@pytest.mark.parametrize("path", sorted(MAPS.glob("*.yaml")), ids=lambda p: p.stem)
def test_describe_map_reports_what_compile_model_builds(path) -> None:
    """validate reports a map from describe_map, which builds no transition matrix: its sizes must
    be the compiled model's, action by action."""
    from beliefloc.semantic_map import describe_map

    smap = load_map(path)
    summary, model = describe_map(smap), compile_model(smap)
    assert summary.n_states == model.n_states
    assert summary.action_names == [a.name for a in model.actions]
    assert list(summary.actuation_actions) == [a.name for a in model.actuation_actions]
    assert [a.observation.n_observations for a in summary.perception_actions] == [
        a.observation.n_observations for a in model.perception_actions
    ]
