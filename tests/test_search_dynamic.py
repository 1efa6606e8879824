"""Zhang, Sridharan & Wyatt 2015: revising the prior (re-use, discard, trust factors), the dynamic knowledge
base of Algorithm 1 lines 7-10, and rooms the robot cannot enter."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from beliefloc.errors import DomainError
from beliefloc.knowledge import Domain, KnowledgeBase, Observation, domain_from_data, load_domain
from beliefloc.object_search.domain_space import search_space
from beliefloc.object_search.dynamic import DynamicKnowledge, KbLink, ObjectTracker
from beliefloc.object_search.existence import ExistenceBelief
from beliefloc.object_search.loop import SearchRecord, cell_prior, initial_prior, run_search, seeded_search
from beliefloc.object_search.policy import POLICIES
from beliefloc.object_search.posterior import CellBelief, Detector, TrustFactor
from beliefloc.object_search.settings import Metareasoning, Revision
from beliefloc.object_search.space import SearchSpace
from beliefloc.object_search.world import SimulatedObjects, SimulatedTarget

from .conftest import DATA

LOCKED = DATA / "search-locked.yaml"

# -- revising the prior: the documented posteriors on a small case ------------------------------------

PRIOR = np.array([0.25, 0.25, 0.5])
LIKELIHOOD = np.array([0.9, 0.9, 0.2])  # one miss of a view over cell 2 with p_TP 0.8, p_FP 0.1
NEW_PRIOR = np.array([0.6, 0.2, 0.2])


def observed(trust: TrustFactor | None = None) -> CellBelief:
    return CellBelief.start(PRIOR, trust).observe(LIKELIHOOD)


def test_reuse_discard_and_trust_factor_give_the_documented_posteriors() -> None:
    # Eq. 7 before the revision: [0.225, 0.225, 0.1] / 0.55
    np.testing.assert_allclose(observed().posterior, np.array([0.225, 0.225, 0.1]) / 0.55)
    # re-use: the kept likelihood times the new prior, [0.54, 0.18, 0.04] / 0.76
    np.testing.assert_allclose(
        observed().revise(NEW_PRIOR, Revision.REUSE).posterior, np.array([0.54, 0.18, 0.04]) / 0.76
    )
    # discard: the new prior alone
    np.testing.assert_allclose(observed().revise(NEW_PRIOR, Revision.DISCARD).posterior, NEW_PRIOR)
    # trust factors (w = 0.5, r = 0): sqrt(b_kb · b_pomdp), b_pomdp = likelihood / 2.0 = [0.45, 0.45, 0.1]
    pooled = observed().revise(NEW_PRIOR, Revision.TRUST).posterior
    by_hand = np.sqrt(NEW_PRIOR * np.array([0.45, 0.45, 0.1]))
    np.testing.assert_allclose(pooled, by_hand / by_hand.sum())
    assert pooled[2] > observed().revise(NEW_PRIOR, Revision.REUSE).posterior[2]  # tempered: the miss weighs less


def test_trust_factor_pool_by_hand() -> None:
    # from the start, logarithmic, w = 0.5: sqrt([0.25, 0.25, 0.5] · [0.45, 0.45, 0.1]) normalised = [3/8, 3/8, 1/4]
    np.testing.assert_allclose(observed(TrustFactor(0.5, 0.0)).posterior, [0.375, 0.375, 0.25])
    # linear (r = 1): 0.5 · [0.25, 0.25, 0.5] + 0.5 · [0.45, 0.45, 0.1] = [0.35, 0.35, 0.3]
    np.testing.assert_allclose(observed(TrustFactor(0.5, 1.0)).posterior, [0.35, 0.35, 0.3])
    # r = 2: sqrt(0.5 · (kb² + ob²)), normalised
    r2 = np.sqrt(0.5 * (PRIOR**2 + np.array([0.45, 0.45, 0.1]) ** 2))
    np.testing.assert_allclose(observed(TrustFactor(0.5, 2.0)).posterior, r2 / r2.sum())


@pytest.mark.parametrize("r", [0.0, 1.0, 3.0])
def test_trust_weights_at_the_ends_give_one_source(r: float) -> None:
    np.testing.assert_allclose(observed(TrustFactor(1.0, r)).posterior, PRIOR, atol=1e-12)
    np.testing.assert_allclose(observed(TrustFactor(0.0, r)).posterior, LIKELIHOOD / LIKELIHOOD.sum(), atol=1e-12)


def test_linear_pooling_cannot_reach_tau_plus() -> None:
    """The documented ceiling: b(i) <= (1 - w) + w · max b_kb, whatever the observations say."""
    belief = CellBelief.start(np.full(10, 0.1), TrustFactor(0.5, 1.0))
    for _ in range(200):
        belief = belief.observe(np.where(np.arange(10) == 3, 0.9, 0.1))
    assert belief.posterior.max() <= 0.5 + 0.5 * 0.1 + 1e-12 < 0.8
    assert CellBelief.start(np.full(10, 0.1), TrustFactor(0.5, 0.0)).observe(
        np.where(np.arange(10) == 3, 0.9**20, 0.1**20)
    ).posterior[3] == pytest.approx(1.0)


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.floats(0.0, 1.0), min_size=2, max_size=8),
    st.lists(st.floats(-30.0, 30.0), min_size=8, max_size=8),
    st.floats(0.0, 1.0),
    st.sampled_from([0.0, 0.5, 1.0, 2.0]),
)
def test_the_pool_is_a_distribution_on_the_kb_support(kb: list[float], logs: list[float], w: float, r: float) -> None:
    prior = np.array(kb)
    if prior.sum() == 0:
        prior[0] = 1.0
    prior = prior / prior.sum()
    pooled = TrustFactor(w, r).pool(prior, np.array(logs[: len(prior)]))
    assert np.all(np.isfinite(pooled)) and pooled.sum() == pytest.approx(1.0) and np.all(pooled >= 0)
    assert np.all(pooled[prior == 0] == 0)  # the pool never puts the target where the KB's prior rules it out


def test_trust_factor_rejects_bad_weights() -> None:
    with pytest.raises(ValueError, match="weight"):
        TrustFactor(1.5)
    with pytest.raises(ValueError, match="r >= 0"):
        TrustFactor(0.5, -1.0)


@pytest.mark.parametrize("present", [True, False])
def test_the_fast_view_update_equals_eq6(present: bool) -> None:
    detector = Detector(0.8, 0.1)
    cells = np.array([1, 4])
    mask = np.zeros(6, dtype=bool)
    mask[cells] = True
    prior = np.array([0.1, 0.2, 0.3, 0.1, 0.2, 0.1])
    for trust in (None, TrustFactor(0.3, 0.0), TrustFactor(0.3, 1.0)):
        fast = CellBelief.start(prior, trust).observe_view(cells, present, detector)
        full = CellBelief.start(prior, trust).observe(detector.likelihood(mask, present))
        np.testing.assert_allclose(fast.posterior, full.posterior)


def test_a_perfect_detector_rules_cells_out_without_nan() -> None:
    perfect = Detector(1.0, 0.0)
    belief = CellBelief.start(np.full(4, 0.25)).observe_view(np.array([0, 1]), True, perfect)
    np.testing.assert_allclose(belief.posterior, [0.5, 0.5, 0, 0])
    belief = belief.observe_view(np.array([0, 1]), False, perfect)  # impossible given E: the prior is kept
    assert np.all(np.isfinite(belief.posterior))


# -- the dynamic knowledge base on a small hand-made domain -----------------------------------------


def small_domain(**search: Any) -> Domain:
    return domain_from_data(
        {
            "name": "small",
            "rooms": ["a", "b"],
            "classes": {"object": None, "kitchenware": "object", "cup": "kitchenware", "plate": "kitchenware"},
            "objects": {"plate1": {"class": "plate"}, "plate2": {"class": "plate"}, "cup1": {"class": "cup"}},
            "target": "cup",
            "search": {
                "room_size": [1, 3],
                "placement": {"a": [0, 0], "b": [0, 4]},
                "robot_start": {"room": "a", "cell": [0, 1]},
                "sensor": {"true_positive": 0.99, "false_positive": 0.01, "view": 1},
                **search,
            },
        }
    )


def test_committing_an_object_changes_the_prior_as_eq_2_to_5_say() -> None:
    domain = small_domain()
    built: list[KnowledgeBase] = []

    def make_kb() -> KnowledgeBase:
        built.append(KnowledgeBase(domain))
        return built[-1]

    assert KnowledgeBase(domain).prior("cup").uniform  # nothing known: [0.5, 0.5]
    link = KbLink(make_kb, "cup", ("a", "b"))
    # plate1 in b: psi = (ln 1 + 1) / (W_1 W_2) = 1 / 2 (plate -> kitchenware, the LCA, has 2 children);
    # a has no support and gets the floor 0.01
    np.testing.assert_allclose(link.commit("plate1", "b"), [0.01, 0.99])
    # plate2 in a: both rooms have alpha 0.5
    np.testing.assert_allclose(link.commit("plate2", "a"), [0.5, 0.5])
    assert link.committed == [("plate1", "b"), ("plate2", "a")] and len(built) == 1
    assert link.commit("plate1", "b") is None  # already committed
    # a second search with the same knowledge shares the solved priors: no new knowledge base
    other = KbLink(make_kb, "cup", ("a", "b"), cache=link.cache)
    np.testing.assert_allclose(other.commit("plate1", "b"), [0.01, 0.99])
    assert len(built) == 1
    # ... until it commits something new: then it builds its own and replays its commits
    np.testing.assert_allclose(other.commit("plate2", "b"), [0.01, 0.99])
    assert len(built) == 2 and built[1].observations[0].obj == "plate1"


def test_the_tracker_commits_an_object_seen_in_one_room() -> None:
    space = search_space(small_domain())  # one-cell views, p_TP 0.99, p_FP 0.01, six cells
    tracker = ObjectTracker.for_space(space, ["plate1", "plate2"])
    commits = tracker.observe(np.array([space.parse_cell("b:0,2")]), np.array([True, False]))
    beliefs = tracker.room_beliefs()
    # plate1 seen: (99 + 2) / (99 + 5) = 0.971 in room b > 0.9; plate2 missed there: 2.0101 / 5.0101 = 0.401
    assert beliefs[0, 1] == pytest.approx(101 / 104) and beliefs[1, 1] == pytest.approx((2 + 1 / 99) / (5 + 1 / 99))
    assert commits == [("plate1", 1)] and list(tracker.active) == [False, True]


def test_tracker_threshold_and_inactive_objects() -> None:
    space = search_space(small_domain(sensor={"true_positive": 0.9, "false_positive": 0.1, "view": 1}))
    tracker = ObjectTracker.for_space(space, ["plate1"])
    cell = np.array([space.parse_cell("b:0,0")])
    assert tracker.observe(cell, np.array([True])) == []  # likelihood ratio 9: (9 + 2) / (9 + 5) = 0.79
    assert tracker.observe(cell, np.array([True])) == [("plate1", 1)]  # 81: (81 + 2) / (81 + 5) = 0.965
    assert not tracker.active[0]
    assert tracker.observe(cell, np.array([True])) == []  # committed once
    with pytest.raises(ValueError, match="commit threshold"):
        ObjectTracker.for_space(space, ["plate1"], threshold=0.3)


def dynamic_search(domain: Domain, revision: Revision, seed: int) -> tuple[SearchSpace, SearchRecord]:
    """A search for a cup on b:0,1, where plate1 stands too; plate2 is on a:0,2 (one-cell views)."""
    space = search_space(domain)
    names = ["plate1", "plate2"]
    where = np.array([space.parse_cell("b:0,1"), space.parse_cell("a:0,2")])
    objects = SimulatedObjects(tuple(names), where, space.detector, np.random.default_rng(seed))
    link = KbLink(lambda: KnowledgeBase(domain), "cup", space.rooms)
    record = run_search(
        space,
        np.array([0.5, 0.5]),
        SimulatedTarget(space.parse_cell("b:0,1"), space.detector, np.random.default_rng(seed + 100)),
        POLICIES["pomdp"],
        ExistenceBelief(6, 2, Metareasoning.NONE),
        keep_beliefs=True,
        revision=revision,
        dynamic=DynamicKnowledge(ObjectTracker.for_space(space, names), objects, link),
    )
    return space, record


@pytest.mark.parametrize("revision", [Revision.REUSE, Revision.DISCARD, Revision.TRUST])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_each_commit_revises_the_cell_belief_as_documented(revision: Revision, seed: int) -> None:
    """Replay the search: every belief is Eq. 7 (or the pool) of the likelihood kept since the last reset
    and the prior of the knowledge base holding the commits so far (an oracle KB built afresh)."""
    domain = small_domain()
    space, record = dynamic_search(domain, revision, seed)
    assert record.dynamic_kb and record.commits, "the plates must be seen and committed"
    committed: list[Observation] = []
    prior = cell_prior(space, np.array([0.5, 0.5]))
    likelihood = np.ones(space.n_cells)
    for step in record.steps:
        likelihood = likelihood * space.detector.likelihood(space.in_view(step.view), step.present)
        if step.commits:
            committed += [Observation(obj, room) for obj, room in step.commits]
            rooms = KnowledgeBase(domain, observations=committed).prior("cup").prior
            prior = cell_prior(space, np.array([rooms["a"], rooms["b"]]))
            if revision is Revision.DISCARD:
                likelihood = np.ones(space.n_cells)  # reset to 1, this step's observation included
        if revision is Revision.TRUST:
            expected = TrustFactor().pool(prior, np.log(likelihood))
        else:
            expected = likelihood * prior / (likelihood * prior).sum()
        np.testing.assert_allclose(step.belief, expected, atol=1e-12)


def test_pomdp_only_ignores_the_knowledge_base() -> None:
    domain = small_domain()
    space = search_space(domain)
    calls: list[int] = []

    def factory(place: np.random.Generator, detect: np.random.Generator) -> DynamicKnowledge:
        calls.append(1)
        objects = SimulatedObjects(("plate1",), np.array([space.parse_cell("b:0,1")]), space.detector, detect)
        link = KbLink(lambda: KnowledgeBase(domain), "cup", space.rooms)
        return DynamicKnowledge(ObjectTracker.for_space(space, ["plate1"]), objects, link)

    record = seeded_search(
        space, np.array([0.5, 0.5]), POLICIES["pomdp-only"], Metareasoning.NONE, seed=0, dynamic=factory
    )
    assert calls and not record.dynamic_kb and record.commits == ()


# -- rooms the robot cannot enter ---------------------------------------------------------------------


@pytest.fixture(scope="module")
def locked() -> SearchSpace:
    return search_space(load_domain(LOCKED))


def test_a_locked_room_gets_no_views(locked: SearchSpace) -> None:
    store = locked.rooms.index("store")
    in_store = locked.room_of_cell == store
    views = locked.views.toarray() > 0
    assert not views[in_store].any()  # no view point there covers anything
    assert not views[:, in_store].any()  # and no view elsewhere sees into it
    np.testing.assert_array_equal(locked.reachable, ~in_store)
    assert list(locked.accessible) == [True, True, False]


def test_the_prior_of_a_locked_room_goes_to_the_others(locked: SearchSpace) -> None:
    # the knowledge base's prior for a cup: office 0.4, lab 0.2, store 0.4 (cup2 is known to be in the store)
    cells = cell_prior(locked, np.array([0.4, 0.2, 0.4]))
    per_room = [cells[locked.room_of_cell == k].sum() for k in range(3)]
    np.testing.assert_allclose(per_room, [2 / 3, 1 / 3, 0.0])
    uniform = initial_prior(locked, np.array([0.4, 0.2, 0.4]), POLICIES["pomdp-only"])
    np.testing.assert_allclose(uniform, np.where(locked.reachable, 1 / 18, 0.0))
    with pytest.raises(ValueError, match="rooms the robot can enter"):
        cell_prior(locked, np.array([0.0, 0.0, 1.0]))


@pytest.mark.parametrize("policy", list(POLICIES))
def test_searches_never_look_into_a_locked_room(locked: SearchSpace, policy: str) -> None:
    for seed in range(4):
        record = seeded_search(
            locked, np.array([0.4, 0.2, 0.4]), POLICIES[policy], Metareasoning.EXPECTATION, seed=seed
        )
        assert record.true_cell is not None and locked.reachable[record.true_cell]
        assert all(locked.reachable[step.view] for step in record.steps)
        assert record.initial_belief[~locked.reachable].sum() == 0.0


def test_a_robot_starting_in_a_locked_room_is_a_usage_error() -> None:
    domain = load_domain(LOCKED)
    spec = domain.search
    assert spec is not None
    moved = domain.model_copy(
        update={
            "search": spec.model_copy(update={"robot_start": spec.robot_start.model_copy(update={"room": "store"})})
        }
    )
    with pytest.raises(DomainError, match="starts in 'store'"):
        search_space(moved)


def test_closed_form_of_a_miss_in_the_pool() -> None:
    """One more by hand: the log pool with w = 0.25 weighs the KB a quarter."""
    belief = observed(TrustFactor(0.25, 0.0)).posterior
    raw = np.array([0.25**0.25 * 0.45**0.75, 0.25**0.25 * 0.45**0.75, 0.5**0.25 * 0.1**0.75])
    np.testing.assert_allclose(belief, raw / raw.sum())
    assert math.isclose(belief.sum(), 1.0)
