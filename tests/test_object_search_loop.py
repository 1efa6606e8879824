"""Zhang, Sridharan & Wyatt 2015, Algorithm 1: the search space, the policies, the control loop, ``search run``."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from typer.testing import CliRunner

from beliefloc.cli.app import app
from beliefloc.errors import EXIT_BAD_INPUT, EXIT_NEGATIVE, DomainError, InvalidValueError
from beliefloc.knowledge import domain_from_data, domain_prior, load_domain
from beliefloc.object_search.domain_space import search_space
from beliefloc.object_search.loop import SearchRecord, Verdict, accuracy, seeded_search
from beliefloc.object_search.policy import POLICIES, entropy, expected_entropy
from beliefloc.object_search.settings import Metareasoning
from beliefloc.object_search.space import SearchSpace
from beliefloc.object_search.world import SimulatedTarget

from .conftest import DATA, ROOT

HOME = ROOT / "domains" / "home.yaml"
PRINTER = ROOT / "domains" / "printer-example.yaml"
INVALID = DATA / "invalid_domains" / "search"  # their messages are checked in test_knowledge_invalid_domains.py


@pytest.fixture(scope="module")
def home() -> tuple[SearchSpace, np.ndarray]:
    domain = load_domain(HOME)
    space = search_space(domain)
    prior = domain_prior(domain, "printer")
    return space, np.array([prior.prior[room] for room in space.rooms])


def cells_of(space: SearchSpace, room: str) -> list[int]:
    return [int(i) for i in np.flatnonzero(space.room_of_cell == space.rooms.index(room))]


def search(
    home: tuple[SearchSpace, np.ndarray], policy: str = "pomdp", metareasoning: str = "none", **kwargs: Any
) -> SearchRecord:
    space, prior = home
    return seeded_search(space, prior, POLICIES[policy], Metareasoning(metareasoning), **kwargs)


# -- the search space -----------------------------------------------------------------------------


@pytest.mark.parametrize("path", [HOME, PRINTER], ids=lambda p: p.stem)
def test_shipped_domains_have_a_search_space(path: Path) -> None:
    space = search_space(load_domain(path))
    assert space.n_cells == 25 * len(space.rooms)
    views = space.views.toarray().astype(bool)
    assert views.shape == (space.n_cells, space.n_cells)
    assert views[np.arange(space.n_cells), np.arange(space.n_cells)].all()  # a view covers its own cell
    same_room = space.room_of_cell[:, None] == space.room_of_cell[None, :]
    assert not (views & ~same_room).any()  # no view through walls
    assert views.sum(axis=1).max() == 9 and views.sum(axis=1).min() == 4  # 3x3, 2x2 in corners
    # the same square, cell by cell (an oracle for the offset-by-offset construction)
    for view in range(space.n_cells):
        near = np.abs(space.local - space.local[view]).max(axis=1) <= 1
        np.testing.assert_array_equal(views[view], near & same_room[view])
        np.testing.assert_array_equal(space.view_cells(view), np.flatnonzero(views[view]))


def test_home_is_the_papers_100_cells_and_travel_grows_with_distance(home: tuple[SearchSpace, np.ndarray]) -> None:
    space, _ = home
    assert space.n_cells == 100 and space.rooms == ("bedroom", "study", "kitchen", "living_room")
    start = space.start
    assert space.cell_name(start) == "living_room:2,2"
    bedroom_far = space.parse_cell("bedroom:0,0")
    living_near = space.parse_cell("living_room:2,3")
    costs = space.action_costs(start)
    assert costs[start] == pytest.approx(space.analysis_cost)
    assert costs[living_near] < costs[bedroom_far]
    assert space.distances_from(start)[bedroom_far] == pytest.approx(np.hypot(8, 8))


def test_cell_names_round_trip_and_bad_ones_are_usage_errors(home: tuple[SearchSpace, np.ndarray]) -> None:
    space, _ = home
    assert all(space.parse_cell(space.cell_name(i)) == i for i in range(space.n_cells))
    for spec, message in (("study", "ROOM:ROW,COL"), ("garage:1,1", "unknown room"), ("study:5,0", "outside")):
        with pytest.raises(InvalidValueError, match=message):
            space.parse_cell(spec)


def test_a_domain_without_search_section_is_a_usage_error() -> None:
    domain = domain_from_data({"name": "t", "rooms": ["a"], "classes": {"object": None}})
    with pytest.raises(DomainError, match="no 'search:' section"):
        search_space(domain)


def test_simulated_target_answers_at_the_detector_rates(home: tuple[SearchSpace, np.ndarray]) -> None:
    space, _ = home
    cell = space.parse_cell("study:2,2")
    target = SimulatedTarget(cell, space.detector, np.random.default_rng(0))
    hits = np.mean([target.detect(space.view_cells(cell)) for _ in range(4000)])
    false = np.mean([target.detect(space.in_view(space.parse_cell("kitchen:2,2"))) for _ in range(4000)])
    assert hits == pytest.approx(0.9, abs=0.02) and false == pytest.approx(0.1, abs=0.02)


# -- the policies -----------------------------------------------------------------------------------


def test_expected_entropy_matches_a_plain_loop(home: tuple[SearchSpace, np.ndarray]) -> None:
    space, _ = home
    rng = np.random.default_rng(1)
    belief = rng.dirichlet(np.full(space.n_cells, 0.3))
    belief[5] = 0.0
    belief /= belief.sum()
    fast = expected_entropy(space, belief)
    tp, fp = space.detector.true_positive, space.detector.false_positive
    for view in (0, 12, 37, 99):
        total = 0.0
        for present in (True, False):
            like = np.array(
                [
                    (tp if present else 1 - tp) if space.views[view, i] > 0 else (fp if present else 1 - fp)
                    for i in range(100)
                ]
            )
            p_obs = float((like * belief).sum())
            post = like * belief / p_obs
            total += p_obs * -sum(p * np.log(p) for p in post if p > 0)
        assert fast[view] == pytest.approx(total)
    assert (fast <= entropy(belief) + 1e-9).all()  # information never hurts on average


def test_greedy_looks_at_the_most_likely_cell(home: tuple[SearchSpace, np.ndarray]) -> None:
    space, _ = home
    belief = np.full(space.n_cells, 0.5 / 99)
    belief[42] = 0.5
    assert space.in_view(POLICIES["greedy"].select(space, belief, space.start))[42]  # more in test_search_policy.py


@pytest.mark.parametrize("name", list(POLICIES))
def test_every_policy_runs_to_a_verdict(name: str) -> None:
    domain = load_domain(PRINTER)
    space = search_space(domain)
    prior = domain_prior(domain, "printer")
    record = seeded_search(
        space,
        np.array([prior.prior[r] for r in space.rooms]),
        POLICIES[name],
        Metareasoning.EXPECTATION,
        seed=0,
        target_cell=space.parse_cell("study:1,3"),
    )
    assert record.verdict in Verdict and record.steps
    assert record.time == pytest.approx(sum(s.cost for s in record.steps))
    assert all(np.isfinite(s.p_exists) and 0 <= s.p_exists <= 1 for s in record.steps)


def test_pomdp_only_starts_uniform(home: tuple[SearchSpace, np.ndarray]) -> None:
    record = search(home, "pomdp-only", seed=0)
    assert np.allclose(record.initial_belief, 1 / 100)
    assert not np.allclose(search(home, "pomdp", seed=0).initial_belief, 1 / 100)


# -- the control loop -------------------------------------------------------------------------------


def test_same_seed_same_search(home: tuple[SearchSpace, np.ndarray]) -> None:
    for metareasoning in ("sampling", "expectation"):
        first, second = (
            search(home, metareasoning=metareasoning, seed=7),
            search(home, metareasoning=metareasoning, seed=7),
        )
        assert first.steps == second.steps and first.verdict == second.verdict and first.true_cell == second.true_cell
    assert [search(home, seed=s).true_cell for s in range(4)] != [search(home, seed=7).true_cell] * 4


@pytest.mark.parametrize("name", ["study:0,0", "study:2,2", "study:4,3", "study:1,4"])
def test_a_target_in_the_kb_s_most_likely_room_is_found(home: tuple[SearchSpace, np.ndarray], name: str) -> None:
    space, prior = home
    assert space.rooms[int(np.argmax(prior))] == "study"
    cell = space.parse_cell(name)
    for seed in range(3):
        record = search(home, seed=seed, target_cell=cell)
        assert record.verdict is Verdict.FOUND, (seed, record.verdict)
        assert record.accuracy > 0.5


def test_an_absent_target_is_given_up_early_only_with_metareasoning(home: tuple[SearchSpace, np.ndarray]) -> None:
    for seed in range(5):
        with_meta = search(home, metareasoning="expectation", seed=seed, absent=True)
        assert with_meta.verdict is Verdict.NOT_FOUND and with_meta.time < 100
        assert with_meta.accuracy == 1.0 and with_meta.reported_cell is None
        baseline = search(home, metareasoning="none", seed=seed, absent=True)
        assert baseline.verdict is not Verdict.NOT_FOUND
        assert baseline.accuracy == 0.0
        assert all(s.p_exists == 1.0 for s in baseline.steps)


def test_upper_bound_is_slower_to_give_up_than_expectation(home: tuple[SearchSpace, np.ndarray]) -> None:
    """The upper bound's prior θ is the 0.9 quantile, above the Beta's mean (Sec. IV-A, H3)."""
    for seed in range(3):
        ub = search(home, metareasoning="upper-bound", seed=seed, absent=True)
        ex = search(home, metareasoning="expectation", seed=seed, absent=True)
        assert ub.verdict is Verdict.NOT_FOUND
        assert len(ub.steps) >= len(ex.steps)


def test_pomdp_needs_no_more_time_than_greedy_on_average(home: tuple[SearchSpace, np.ndarray]) -> None:
    space, _ = home
    study = cells_of(space, "study")
    pomdp, greedy = [], []
    for seed in range(6):
        cell = study[(7 * seed) % len(study)]
        pomdp.append(search(home, "pomdp", seed=seed, target_cell=cell).time)
        greedy.append(search(home, "greedy", seed=seed, target_cell=cell).time)
    assert np.mean(pomdp) <= np.mean(greedy)


def test_the_kb_prior_speeds_up_a_search_in_the_likely_room(home: tuple[SearchSpace, np.ndarray]) -> None:
    space, _ = home
    study = cells_of(space, "study")
    with_kb = [search(home, "pomdp", seed=s, target_cell=study[(3 * s) % 25]).time for s in range(6)]
    without = [search(home, "pomdp-only", seed=s, target_cell=study[(3 * s) % 25]).time for s in range(6)]
    assert np.mean(with_kb) < np.mean(without)


def test_time_limit_reports_the_most_likely_cell(home: tuple[SearchSpace, np.ndarray]) -> None:
    record = search(home, seed=0, target_cell=home[0].parse_cell("bedroom:0,0"), time_limit=5.0)
    assert record.verdict is Verdict.TIME_LIMIT and record.time >= 5.0
    assert record.reported_cell == record.steps[-1].best_cell


def test_accuracy_is_a_gaussian_of_the_distance_in_cells(home: tuple[SearchSpace, np.ndarray]) -> None:
    space, _ = home
    a, b = space.parse_cell("study:0,0"), space.parse_cell("study:0,2")
    assert accuracy(space, a, a) == 1.0
    assert accuracy(space, a, b) == pytest.approx(np.exp(-4 / 8))  # d = 2 cells, σ = 2
    assert accuracy(space, None, None) == 1.0 and accuracy(space, None, a) == 0.0 and accuracy(space, a, None) == 0.0


# -- the command ---------------------------------------------------------------------------------------


def test_cli_found_exits_0_and_prints_steps(runner: CliRunner) -> None:
    out = runner.invoke(app, ["search", "run", str(PRINTER), "--target-cell", "study:1,3", "--strategy", "none"])
    assert out.exit_code == 0, out.output
    assert "found at study:" in out.stdout and "p(E)" in out.stdout and "study" in out.stdout


def test_cli_show_draws_the_rooms(runner: CliRunner) -> None:
    out = runner.invoke(app, ["search", "run", str(PRINTER), "--target-cell", "study:1,3", "--show"])
    assert out.exit_code == 0, out.output
    assert out.stdout.count("rooms: bedroom") >= 2 and "step   1:" in out.stdout


def test_cli_absent_exits_1_with_json(runner: CliRunner) -> None:
    out = runner.invoke(app, ["search", "run", str(HOME), "--absent", "--json", "--seed", "2"])
    assert out.exit_code == EXIT_NEGATIVE, out.output
    data = json.loads(out.stdout)
    assert data["verdict"] == "not-found" and data["true_cell"] is None and data["reported_cell"] is None
    assert data["steps"][0]["step"] == 1 and set(data["room_prior"]) == {"bedroom", "study", "kitchen", "living_room"}
    assert data["time"] == pytest.approx(data["steps"][-1]["time"])


def test_cli_time_limit_exits_1(runner: CliRunner) -> None:
    out = runner.invoke(app, ["search", "run", str(HOME), "--time-limit", "3", "--strategy", "none", "--json"])
    assert out.exit_code == EXIT_NEGATIVE and json.loads(out.stdout)["verdict"] == "time-limit"


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--policy", "astar"], "--policy 'astar'"),
        (["--strategy", "guess"], "--strategy 'guess'"),
        (["--absent", "--target-cell", "study:0,0"], "contradict"),
        (["--target-cell", "garage:0,0"], "unknown room 'garage'"),
        (["--target", "unicorn"], "unknown class"),
    ],
)
def test_cli_bad_usage_exits_2(runner: CliRunner, args: list[str], message: str) -> None:
    out = runner.invoke(app, ["search", "run", str(HOME), *args])
    assert out.exit_code == EXIT_BAD_INPUT, out.output
    assert message in out.stderr and "Traceback" not in out.output


def test_cli_broken_domain_exits_2(runner: CliRunner) -> None:
    out = runner.invoke(app, ["search", "run", str(INVALID / "overlap.yaml")])
    assert out.exit_code == EXIT_BAD_INPUT and ":9:14: " in out.stderr
