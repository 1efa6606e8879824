"""Macro actions (Khalvati & Mackworth Algorithm 2, Appendix): the backward Dijkstra over pairs
against a literal transcription of the paper's rounds and against brute-force search; the file;
the commands; the localizability verdict."""

from __future__ import annotations

import itertools
import json
from collections import deque

import numpy as np
import pytest
import typer

from beliefloc import compile_model, load_map
from beliefloc.cli.macros import register as register_macros
from beliefloc.errors import InvalidValueError, ModelError
from beliefloc.files.macro_file import load_macros, save_macros
from beliefloc.model import Model
from beliefloc.planning.ec2 import full_parts, observation_difference, pair_context
from beliefloc.planning.macros import (
    MacroSearch,
    MacroTable,
    build_macros,
    expected_path,
    indistinguishable_pairs,
    macro_candidates,
    pair_macros,
    search_macros,
)
from beliefloc.semantic_map import SemanticMap
from beliefloc.simulation.strategies import EpisodeStatus, SharedWork

from .conftest import MAPS


def _model(name: str) -> Model:
    return compile_model(load_map(MAPS / name))


def _random_world(seed: int, costs: bool = False) -> Model:
    """A small random deterministic world: compass moves that never fail, a noise-free 'here'
    sensor with two or three labels, some blocked cells."""
    rng = np.random.default_rng(seed)
    rows, cols = int(rng.integers(2, 5)), int(rng.integers(3, 6))
    free = rng.random((rows, cols)) > 0.2
    free[0, 0] = True
    layout = "\n".join("".join("." if f else "#" for f in row) for row in free)
    labels = "\n".join("".join(str(int(v)) for v in row) for row in rng.integers(0, 2 + seed % 2, size=(rows, cols)))
    actions = {
        name: {"cost": int(rng.integers(1, 4)) if costs else 1, "failure": 0}
        for name in ("up", "down", "left", "right")
        if rng.random() < 0.85 or name == "up"
    }
    return compile_model(
        SemanticMap.model_validate(
            {
                "name": f"random{seed}",
                "grid": {"rows": rows, "cols": cols, "headings": 1},
                "layout": layout,
                "actions": actions,
                "sensors": {"here": {"type": "here", "labels": labels, "passive": True, "as_action": False}},
            }
        )
    )


def _distinguishable(model: Model, gamma: float, i: int, j: int) -> bool:
    return i != j and bool(observation_difference(full_parts(model), np.array([i]), np.array([j]))[0] > gamma)


def _algorithm2_literal(model: Model, gamma: float) -> dict[tuple[int, int], float]:
    """Algorithm 2, line by line: rounds over every pair and action; each round sets the macros of
    the pairs of least cost. Returns the cost of every pair's macro (inf: never set)."""
    ctx = pair_context(model, gamma)
    n = model.n_states
    pairs = list(itertools.combinations(range(n), 2))
    macro: dict[tuple[int, int], float | None] = dict.fromkeys(pairs)  # None is the empty set
    for i, j in pairs:  # lines 3-6
        if _distinguishable(model, gamma, i, j):
            macro[(i, j)] = 0.0
    moving = [a for a, act in enumerate(model.actions) if act.transition is not None]
    min_set = [None]
    while min_set:  # line 8
        min_set, min_cost = [], float("inf")
        for (i, j), a in itertools.product(pairs, moving):  # line 11
            if macro[(i, j)] is not None:
                continue
            fi, fj = int(ctx.fstar[a, i]), int(ctx.fstar[a, j])
            key = (min(fi, fj), max(fi, fj))
            if fi == fj or macro[key] is None:  # line 12
                continue
            cost = float(ctx.costs[a]) + float(macro[key])  # type: ignore[arg-type]
            if cost == min_cost:  # lines 13-17
                min_set.append((i, j))
            if cost < min_cost:  # lines 18-25
                min_set, min_cost = [(i, j)], cost
        for pair in min_set:  # lines 29-33
            macro[pair] = min_cost
    return {p: (float("inf") if c is None else c) for p, c in macro.items() if not _distinguishable(model, gamma, *p)}


def _brute_force(model: Model, gamma: float, i: int, j: int) -> float:
    """Breadth-first search over action sequences (unit costs): the length of the shortest one
    after which the pair is distinguishable; inf when none exists."""
    ctx = pair_context(model, gamma)
    moving = [a for a, act in enumerate(model.actions) if act.transition is not None]
    queue, seen = deque([(i, j, 0)]), {(i, j)}
    while queue:
        a_state, b_state, depth = queue.popleft()
        for a in moving:
            x, y = int(ctx.fstar[a, a_state]), int(ctx.fstar[a, b_state])
            if x == y:
                continue
            if _distinguishable(model, gamma, x, y):
                return float(depth + 1)
            if (x, y) not in seen:
                seen.add((x, y))
                queue.append((x, y, depth + 1))
    return float("inf")


def _costs(table, model: Model) -> dict[tuple[int, int], float]:
    return {(int(i), int(j)): float(c) for i, j, c in zip(table.pair_i, table.pair_j, table.cost, strict=True)}


@pytest.mark.parametrize("seed", range(12))
def test_macros_are_optimal_against_brute_force(seed: int):
    """The Appendix's theorem: in a deterministic world every macro is a least-cost sequence, and
    a pair is never distinguishable exactly when no sequence distinguishes it."""
    model = _random_world(seed)
    table = build_macros(model)
    costs = _costs(table, model)
    for (i, j), cost in costs.items():
        assert cost == _brute_force(model, table.gamma, i, j), (i, j)
    # the macro itself does what it claims: following f* it ends on a distinguishable pair
    ctx = pair_context(model)
    for p in np.flatnonzero(np.isfinite(table.cost)).tolist():
        actions = table.pair_sequence(p)
        assert len(actions) == table.length[p]
        assert sum(float(ctx.costs[a]) for a in actions) == pytest.approx(table.cost[p])
        end_i = expected_path(ctx, int(table.pair_i[p]), actions)[-1]
        end_j = expected_path(ctx, int(table.pair_j[p]), actions)[-1]
        assert _distinguishable(model, table.gamma, end_i, end_j)


@pytest.mark.parametrize("seed", range(8))
def test_dijkstra_equals_the_literal_rounds_of_algorithm2(seed: int):
    model = _random_world(seed, costs=True)
    table = build_macros(model)
    assert _costs(table, model) == _algorithm2_literal(model, table.gamma)


@pytest.mark.parametrize("name", ["khalvati-example1.yaml", "kitchen.yaml", "hallway.yaml", "window-2x2.yaml"])
def test_bundled_maps_against_the_literal_rounds(name: str):
    model = _model(name)
    table = build_macros(model)
    assert _costs(table, model) == _algorithm2_literal(model, table.gamma)


def test_pairs_come_from_signature_groups_only():
    signature = np.array([3, 1, 3, 3, 1, 7])
    i, j = indistinguishable_pairs(signature)
    assert list(zip(i.tolist(), j.tolist(), strict=True)) == [(0, 2), (0, 3), (1, 4), (2, 3)]


def test_window_world_merges_are_dead_ends():
    """'right' takes both cells of a row to the same cell: the pair is never told apart (the paper's
    d(s, s) = 0), although the robot then knows where it is."""
    model = _model("window-2x2.yaml")
    table = build_macros(model)
    names = [[model.states.name(s) for s in c] for c in table.never_classes()]
    assert names == [["0,0", "0,1"], ["1,0", "1,1"]]


def test_gamma_outside_the_exact_range_is_refused():
    with pytest.raises(InvalidValueError, match="outside"):
        build_macros(_model("khalvati-example1.yaml"), gamma=1.0)


def test_macro_candidates_come_from_likely_pairs():
    model = _model("khalvati-example1.yaml")
    table = build_macros(model)
    belief = np.zeros(model.n_states)
    belief[[model.states.index("0,1"), model.states.index("0,4")]] = 0.5
    assert macro_candidates(table, np.flatnonzero(belief), belief) == [table.pair_sequence(int(table.find(1, 4)))]


# --- the file -------------------------------------------------------------------------------------


def test_file_round_trip_and_stale_refusal(tmp_path):
    model = _model("khalvati-example1.yaml")
    table = build_macros(model)
    path = tmp_path / "m.npz"
    save_macros(table, path, model=model)
    again = load_macros(path, model)
    for name in ("pair_i", "pair_j", "cost", "first_action", "next_pair", "macro_id", "macro_first"):
        np.testing.assert_array_equal(getattr(again, name), getattr(table, name))
    other = _model("kitchen.yaml")
    with pytest.raises(ModelError, match=r"macro table for another map: it was built for .*khalvati-example1\.yaml"):
        load_macros(path, other)
    (tmp_path / "junk.npz").write_bytes(b"nope")
    with pytest.raises(ModelError, match="not a beliefloc macro file"):
        load_macros(tmp_path / "junk.npz", model)


# --- the commands ---------------------------------------------------------------------------------


def _app() -> typer.Typer:
    app = typer.Typer()

    @app.callback()
    def _root() -> None: ...

    register_macros(app)
    return app


def test_cli_build_json_and_show(runner, tmp_path):
    out = tmp_path / "k.npz"
    result = runner.invoke(_app(), ["macros", "build", str(MAPS / "khalvati-example1.yaml"), "-o", str(out), "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    keys = {"states", "indistinguishable_pairs", "macros", "max_length", "never_distinguishable_pairs", "seconds"}
    assert keys <= set(data)
    assert data["states"] == 36 and data["never_distinguishable_pairs"] == 0
    shown = runner.invoke(_app(), ["macros", "show", str(out), "--pair", "1,1", "3,1"])
    assert shown.exit_code == 0, shown.output
    assert "1,1 and 3,1 look alike; 1 action tells them apart" in shown.stdout
    assert "up" in shown.stdout
    summary = runner.invoke(_app(), ["macros", "show", str(out)])
    assert summary.exit_code == 0 and "the longest macros" in summary.stdout


def test_cli_build_names_gamma_only_for_gammas_error(runner, tmp_path):
    out = tmp_path / "k.npz"
    result = runner.invoke(
        _app(), ["macros", "build", str(MAPS / "khalvati-example1.yaml"), "-o", str(out), "--gamma", "1"]
    )
    assert result.exit_code == 2 and "--gamma" in result.output and "outside" in result.output
    assert not out.exists()


def test_cli_build_reports_the_unlocalizable_classes(runner, tmp_path):
    out = tmp_path / "w.npz"
    result = runner.invoke(_app(), ["macros", "build", str(MAPS / "window-2x2.yaml"), "-o", str(out)])
    assert result.exit_code == 1
    assert "not localizable" in result.stderr and "can never tell where it is" in result.stderr
    assert "0,0  0,1" in result.stdout
    assert out.exists()  # written all the same


# --- the corridors and the symmetric ladder -------------------------------------------------------


def test_symmetric_ladder_classes_are_the_half_turn_images():
    model = _model("ladder-symmetric.yaml")
    table = build_macros(model)
    grid = model.grid
    assert grid is not None
    classes = table.never_classes()
    assert classes and all(len(c) == 2 for c in classes)
    for a, b in classes:
        ra, ca, ha = (int(x) for x in grid.cell_heading(a))
        rb, cb, hb = (int(x) for x in grid.cell_heading(b))
        assert (rb, cb, hb) == (grid.rows - 1 - ra, grid.cols - 1 - ca, (ha + 2) % 4)


def test_corridors_need_macros_and_are_localizable():
    model = _model("corridors.yaml")
    table = build_macros(model)
    summary = table.summary()
    assert summary["never_distinguishable_pairs"] == 0
    assert summary["max_length"] >= 5  # long corridors: single moves do not help


@pytest.mark.parametrize("seed", range(3))
def test_ec2_macros_localizes_in_the_corridors(seed: int):
    from beliefloc.simulation.episode import run_episode

    model = _model("corridors.yaml")
    start = model.states.index("1,10,1")  # mid corridor, facing east
    belief = np.full(model.n_states, 1.0 / model.n_states)
    record = run_episode(model, "ec2-macros", start, belief, seed=seed, max_steps=500)
    assert record.status is EpisodeStatus.LOCALIZED, record


# --- macros searched per pair (maps whose table would be too big) ----------------------------------


def _check_searched(model: Model) -> None:
    """Every pair's searched macro costs what the table's does, is None exactly where the table has
    none, and does what it claims: it ends on a told-apart pair, never passing through one."""
    table = build_macros(model)
    ctx = pair_context(model)
    searched = search_macros(ctx, table.pair_i, table.pair_j, max_settled=10**9)
    for p, actions in enumerate(searched):
        if actions is None:
            assert not np.isfinite(table.cost[p]), p
            continue
        assert sum(float(ctx.costs[a]) for a in actions) == pytest.approx(table.cost[p])
        path_i = expected_path(ctx, int(table.pair_i[p]), actions)
        path_j = expected_path(ctx, int(table.pair_j[p]), actions)
        told = [_distinguishable(model, table.gamma, a, b) for a, b in zip(path_i, path_j, strict=True)]
        assert told[-1] and not any(told[:-1]), p
        assert all(a != b for a, b in zip(path_i[:-1], path_j[:-1], strict=True))  # no merged pair on the way


@pytest.mark.parametrize("seed", range(10))
def test_searched_macros_cost_what_the_table_says(seed: int):
    _check_searched(_random_world(seed, costs=seed % 2 == 1))


@pytest.mark.parametrize("name", ["corridors.yaml", "window-2x2.yaml", "ladder-symmetric.yaml", "tb3-sandbox.yaml"])
def test_searched_macros_on_the_bundled_maps(name: str):
    _check_searched(_model(name))


def test_a_search_gives_up_within_its_budget():
    """On the symmetric ladder some pairs are never told apart; with a budget of one settled pair
    only the one-action macros are found."""
    model = _model("corridors.yaml")
    table = build_macros(model)
    ctx = pair_context(model)
    searched = search_macros(ctx, table.pair_i, table.pair_j, max_settled=1)
    lengths = {len(a) for a in searched if a is not None}
    assert lengths == {1}
    assert sum(a is None for a in searched) == int((table.length > 1).sum())


def test_the_search_stands_in_for_a_table_too_big():
    model = _model("corridors.yaml")
    ctx = pair_context(model)
    assert isinstance(pair_macros(model, ctx), MacroTable)
    search = pair_macros(model, ctx, max_pairs=10)
    assert isinstance(search, MacroSearch)
    with pytest.raises(InvalidValueError, match="ec2-macros"):  # a table refused says what can do without one
        build_macros(model, max_pairs=10)
    table = build_macros(model)
    rng = np.random.default_rng(4)
    belief = rng.dirichlet(np.ones(model.n_states) * 0.3)
    top = np.argsort(-belief, kind="stable")[:12]
    ii, jj = np.triu_indices(len(top), 1)
    i, j = top[ii], top[jj]
    costs = ctx.costs
    by_search = [sum(costs[list(search.sequence(m))]) if m >= 0 else None for m in search.macro_ids(i, j).tolist()]
    by_table = [sum(costs[list(table.sequence(m))]) if m >= 0 else None for m in table.macro_ids(i, j).tolist()]
    assert by_search == by_table and any(c is not None for c in by_search)
    # the candidates start with the macro of the most probable pair that has one, as with the table
    weight = np.where(np.array([c is not None for c in by_table]), belief[i] * belief[j], -1.0)
    heaviest = int(np.argmax(weight))
    states = np.flatnonzero(belief > 0)
    first_by_table = macro_candidates(table, states, belief)[0]
    first_by_search = macro_candidates(search, states, belief)[0]
    assert first_by_table == table.sequence(
        int(table.macro_ids(i[heaviest : heaviest + 1], j[heaviest : heaviest + 1])[0])
    )
    assert sum(costs[list(first_by_search)]) == by_table[heaviest]


def test_searched_candidates_do_not_depend_on_what_was_asked_before():
    model = _model("corridors.yaml")
    ctx = pair_context(model)
    rng = np.random.default_rng(9)
    beliefs = [rng.dirichlet(np.ones(model.n_states) * 0.2) for _ in range(3)]
    fresh, used = MacroSearch(ctx), MacroSearch(ctx)
    for belief in beliefs[:2]:
        macro_candidates(used, np.flatnonzero(belief > 0), belief)
    last = beliefs[2]
    assert macro_candidates(used, np.flatnonzero(last > 0), last) == macro_candidates(
        fresh, np.flatnonzero(last > 0), last
    )


@pytest.mark.parametrize("seed", range(2))
def test_ec2_macros_localizes_in_the_corridors_with_searched_macros(seed: int):
    from beliefloc.simulation.episode import run_episode

    model = _model("corridors.yaml")
    shared = SharedWork.for_model(model)
    shared._macros[None] = MacroSearch(shared.pair_context(None))
    start = model.states.index("1,10,1")
    belief = np.full(model.n_states, 1.0 / model.n_states)
    record = run_episode(model, "ec2-macros", start, belief, seed=seed, max_steps=500, shared=shared)
    assert record.status is EpisodeStatus.LOCALIZED, record
