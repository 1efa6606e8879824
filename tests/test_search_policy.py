"""The greedy baseline of Zhang et al. Table I (policy.py): the view that would most raise the belief in
the most likely cell, were the target there -- against a plain loop, and run to a verdict. And what
``python -m benchmarks.search_paper`` needs of experiment.py: arms with their own search parameters,
the room accuracy of ASP alone (H1)."""

from __future__ import annotations

import numpy as np
import pytest

from beliefloc.knowledge import domain_prior, load_domain
from beliefloc.object_search.domain_space import search_space
from beliefloc.object_search.experiment import Arm, TrialSettings, room_hit, run_trials, trial_world
from beliefloc.object_search.loop import Verdict, seeded_search
from beliefloc.object_search.policy import POLICIES
from beliefloc.object_search.posterior import Detector, TrustFactor
from beliefloc.object_search.settings import Metareasoning, PolicyName, Revision
from beliefloc.object_search.space import SearchSpace
from beliefloc.object_search.world import typical_rooms

from .conftest import ROOT

PRINTER = ROOT / "domains" / "printer-example.yaml"


@pytest.fixture(scope="module")
def printer() -> tuple[SearchSpace, np.ndarray]:
    domain = load_domain(PRINTER)
    space = search_space(domain)
    prior = domain_prior(domain, "printer")
    return space, np.array([prior.prior[room] for room in space.rooms])


def test_every_policy_name_has_a_registry_entry() -> None:
    assert list(POLICIES) == [name.value for name in PolicyName]
    for name in PolicyName:
        policy = POLICIES[name.value]
        assert policy.name is name and policy.description == name.description and name.description


def greedy_scores_by_loop(space: SearchSpace, belief: np.ndarray, cell: int) -> np.ndarray:
    """Σ_o p(o | target on cell, v) · b'(cell | v, o) for every view, by Bayes' rule on whole vectors."""
    tp, fp = space.detector.true_positive, space.detector.false_positive
    scores = np.zeros(space.n_cells)
    for view in range(space.n_cells):
        in_view = space.in_view(view)
        for present in (True, False):
            like = np.where(in_view, tp, fp) if present else np.where(in_view, 1 - tp, 1 - fp)
            if (like * belief).sum() > 0:
                scores[view] += like[cell] * (like * belief / (like * belief).sum())[cell]
    return scores


def test_greedy_takes_the_view_that_most_raises_the_most_likely_cell(printer: tuple[SearchSpace, np.ndarray]) -> None:
    space, _ = printer
    rng = np.random.default_rng(3)
    for _ in range(5):
        belief = rng.dirichlet(np.full(space.n_cells, 0.3))
        best = int(np.argmax(belief))
        robot = int(rng.integers(space.n_cells))
        scores = greedy_scores_by_loop(space, belief, best)
        chosen = POLICIES["greedy"].select(space, belief, robot)
        assert scores[chosen] == pytest.approx(scores.max())


def test_greedy_puts_a_clear_leader_at_the_edge_of_its_view(printer: tuple[SearchSpace, np.ndarray]) -> None:
    """Standing on the leader would raise its eight neighbours with it; the chosen view covers the
    leader and as little other belief as any view covering it."""
    space, _ = printer
    leader = space.parse_cell("study:2,2")
    belief = np.full(space.n_cells, 0.5 / (space.n_cells - 1))
    belief[leader] = 0.5
    chosen = POLICIES["greedy"].select(space, belief, space.start)
    covering = [v for v in range(space.n_cells) if space.in_view(v)[leader]]
    assert chosen in covering and chosen != leader
    assert len(space.view_cells(chosen)) == min(len(space.view_cells(v)) for v in covering)


def test_greedy_separates_a_corner_from_the_cell_every_view_of_it_also_covers(
    printer: tuple[SearchSpace, np.ndarray],
) -> None:
    """Every 3x3 view covering a room's corner covers its diagonal neighbour too: tied, the two are
    told apart only by a view of the neighbour without the corner."""
    space, _ = printer
    corner, diagonal = space.parse_cell("study:0,0"), space.parse_cell("study:1,1")
    assert all(space.in_view(v)[diagonal] for v in range(space.n_cells) if space.in_view(v)[corner])
    belief = np.full(space.n_cells, 0.1 / (space.n_cells - 2))
    belief[[corner, diagonal]] = 0.45
    chosen = space.in_view(POLICIES["greedy"].select(space, belief, space.start))
    assert chosen[corner] != chosen[diagonal]


def test_greedy_localises_targets(printer: tuple[SearchSpace, np.ndarray]) -> None:
    """The first version (stand on the most likely cell) stalled with two or more cells tied at 0.5 or below."""
    space, prior = printer
    near = 0
    for name in ("study:0,0", "study:2,3", "bedroom:4,4", "kitchen:1,0"):
        cell = space.parse_cell(name)
        for seed in range(3):
            record = seeded_search(
                space, prior, POLICIES["greedy"], Metareasoning.NONE, seed=seed, target_cell=cell, time_limit=200
            )
            assert record.verdict is Verdict.FOUND, (name, seed, record.verdict)
            assert record.error_cells is not None
            near += record.error_cells < 1.5  # the cell or a neighbour (p_FP = 0.1: two false alarms can mislead)
    assert near >= 10


# -- experiment.py: what the paper benchmark adds ----------------------------------------------------


def test_room_hit_breaks_ties_fairly() -> None:
    assert room_hit([0.1, 0.6, 0.3], 1) == 1.0 and room_hit([0.1, 0.6, 0.3], 2) == 0.0
    assert room_hit([0.1, 0.6, 0.3], 2, k=2) == 1.0 and room_hit([0.1, 0.6, 0.3], 0, k=2) == 0.0
    assert room_hit([0.25] * 4, 3) == 0.25 and room_hit([0.25] * 4, 0, k=2) == 0.5  # says nothing: chance
    assert room_hit([0.4, 0.2, 0.2, 0.2], 2, k=2) == pytest.approx(1 / 3)  # one of three tied for second
    with pytest.raises(ValueError, match="room index"):
        room_hit([0.5, 0.5], 2)


def test_arms_with_their_own_parameters_share_the_trials() -> None:
    domain = load_domain(ROOT / "domains" / "home.yaml")
    arms = [
        Arm("pomdp", Metareasoning.NONE),
        Arm("pomdp", Metareasoning.NONE, time_limit=100),  # the domain's own limit, set by the arm
        Arm("pomdp", Metareasoning.NONE, time_limit=4),
        Arm("pomdp", Metareasoning.EXPECTATION, tau_absent=0.85, alpha=30, beta=10),
        Arm("pomdp", Metareasoning.NONE, Revision.TRUST),
        Arm("pomdp", Metareasoning.NONE, Revision.TRUST, trust=TrustFactor(0.5, 0.0)),  # the default, set
    ]
    assert arms[2].name == "pomdp/none/static/reuse@time_limit=4"
    assert arms[3].name == "pomdp/expectation/static/reuse@tau_absent=0.85@alpha=30@beta=10"
    assert arms[5].name == "pomdp/none/static/trust-factor@trust=0.5,0"
    settings = TrialSettings(absent_fraction=0.5, tau_absent=0.85)
    upper = [Arm("pomdp", Metareasoning.UPPER_BOUND, alpha=a, beta=b) for a, b in ((6, 2), (30, 10))]
    more = [Arm("pomdp", Metareasoning.EXPECTATION), *upper]
    # the fixed detector: these arms' parameters were chosen for it
    records = run_trials(domain, [*arms, *more], trials=3, seed=1, settings=settings, scenes=False)
    fields = ("verdict", "time", "steps", "reported_cell")
    for record in records:
        default, same, short, beta_30_10, trust, same_trust, beta_6_2, upper_6_2, upper_30_10 = record.outcomes
        # the same mean 0.75: the expectation strategy cannot tell (6, 2) from (30, 10) (Sec. IV-A, Fig. 8)
        assert all(getattr(beta_30_10, f) == getattr(beta_6_2, f) for f in fields)
        assert all(getattr(default, f) == getattr(same, f) for f in fields)
        assert all(getattr(trust, f) == getattr(same_trust, f) for f in fields)
        assert short.steps < default.steps or default.time <= 4
        assert short.time < 4 + 10  # the step that crossed the limit ends it
        if not record.present:  # less variance, a lower 0.9 quantile of P(E): given up sooner
            assert upper_30_10.verdict == "not-found" and upper_30_10.time < upper_6_2.time
    assert any(not r.present for r in records)


def test_a_noisier_world_than_the_robot_s_model() -> None:
    """Fig. 6's "extra noise added to the observations": the world detects at its own rates, the robot
    still reasons with the domain's sensor."""
    domain = load_domain(ROOT / "domains" / "home.yaml")
    arms = [Arm("pomdp", Metareasoning.NONE), Arm("pomdp", Metareasoning.NONE, dynamic_kb=True)]

    def run(world: Detector | None) -> list[tuple[object, ...]]:
        settings = TrialSettings(knowledge=0.2, world_detector=world)
        records = run_trials(domain, arms, trials=2, seed=4, settings=settings)
        return [(o.verdict, o.time, o.reported_cell, o.commits) for r in records for o in r.outcomes]

    assert run(Detector(0.9, 0.1)) == run(None)  # home.yaml's sensor
    assert run(Detector(0.6, 0.4)) != run(None)


def test_trial_world_is_the_world_of_the_record() -> None:
    domain = load_domain(ROOT / "domains" / "home.yaml")
    space = search_space(domain)
    settings = TrialSettings(knowledge=0.2, absent_fraction=0.5)
    records = run_trials(
        domain, [Arm("pomdp", Metareasoning.EXPECTATION)], trials=4, seed=2, settings=settings, first=3
    )
    typical = typical_rooms(domain)
    for record in records:
        world = trial_world(domain, space, typical, index=record.index, seed=2, settings=settings)
        assert (world.target, world.present, world.target_cell, world.target_room) == (
            record.target,
            record.present,
            record.true_cell,
            record.true_room,
        )
