"""Simulated worlds and paired trials for object search (Zhang, Sridharan & Wyatt 2015, Sec. IV-A)."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

from beliefloc.errors import DomainError
from beliefloc.knowledge import Domain, KnowledgeBase, load_domain
from beliefloc.object_search.domain_space import search_space
from beliefloc.object_search.experiment import Arm, TrialRecord, TrialSettings, run_trials, summarize
from beliefloc.object_search.settings import Metareasoning, Revision
from beliefloc.object_search.space import SearchSpace
from beliefloc.object_search.trials import Stream, robot_domain, sample_known, trial_rng, unknown_objects
from beliefloc.object_search.world import P_TYPICAL, forbidden_rooms, instances_of, sample_world, typical_rooms

from .conftest import DATA, ROOT

HOME = ROOT / "domains" / "home.yaml"
LOCKED = DATA / "search-locked.yaml"
Setup = tuple[Domain, SearchSpace, dict[str, str]]
Paired = tuple[Domain, TrialSettings, list[TrialRecord]]


@pytest.fixture(scope="module")
def home() -> Setup:
    domain = load_domain(HOME)
    return domain, search_space(domain), typical_rooms(domain)


@pytest.fixture(scope="module")
def locked() -> Setup:
    domain = load_domain(LOCKED)
    return domain, search_space(domain), typical_rooms(domain)


# -- ground truth ---------------------------------------------------------------------------------


def test_typical_rooms_are_where_the_defaults_put_unknown_objects(home: Setup) -> None:
    _, _, typical = home
    assert typical["printer2"] == "study"  # computer_access_in_study
    assert typical["cookbook2"] == "kitchen"  # books_in_study's weak exception leaves cookbooks to their own default
    assert typical["textbook4"] == "study"
    assert typical["pillow1"] == "bedroom"  # a known object: where the file says


def test_every_object_is_placed_known_ones_where_the_domain_says(home: Setup) -> None:
    domain, space, typical = home
    world = sample_world(domain, space, typical, np.random.default_rng(0), target_class="printer")
    assert set(world.rooms) == set(domain.objects) == set(world.cells)
    for name, spec in domain.objects.items():
        if spec.room is not None:
            assert world.rooms[name] == spec.room
        assert space.rooms[space.room_of_cell[world.cells[name]]] == world.rooms[name]  # the cell is in the room
    assert world.target in instances_of(domain, "printer") and world.present
    assert world.target_cell == world.cells[world.target] and world.target_room == world.rooms[world.target]


def test_objects_with_a_default_are_in_their_typical_room_at_the_documented_rate(home: Setup) -> None:
    domain, space, typical = home
    unknown_with_default = [n for n, s in domain.objects.items() if s.room is None and n in typical]
    hits = total = 0
    rng = np.random.default_rng(1)
    for _ in range(200):
        world = sample_world(domain, space, typical, rng)
        hits += sum(world.rooms[n] == typical[n] for n in unknown_with_default)
        total += len(unknown_with_default)
    expected = P_TYPICAL + (1 - P_TYPICAL) / len(domain.rooms)  # 0.85 with four rooms
    assert hits / total == pytest.approx(expected, abs=0.015)


def test_objects_without_default_are_uniform_over_rooms(home: Setup) -> None:
    domain, space, _ = home
    counts: Counter[str] = Counter()
    rng = np.random.default_rng(2)
    for _ in range(400):
        world = sample_world(domain, space, {}, rng)  # no typical rooms: every unknown object is drawn uniformly
        counts[world.rooms["printer2"]] += 1
    assert set(counts) == set(domain.rooms) and min(counts.values()) > 70


def test_strong_exceptions_and_locked_rooms_shape_the_ground_truth(locked: Setup) -> None:
    domain, space, typical = locked
    assert forbidden_rooms(domain) == {"plate1": frozenset({"office"})}
    rng = np.random.default_rng(3)
    worlds = [sample_world(domain, space, typical, rng) for _ in range(100)]
    assert all(w.rooms["plate1"] == "lab" for w in worlds)  # not office (strong exception), not store (locked: Setup)
    assert all(w.rooms["cup2"] == "store" for w in worlds)  # the file says so
    assert all(w.rooms["cup1"] in ("office", "lab") for w in worlds)
    assert "cup2" not in {w.target for w in worlds}  # a target in a locked room could never be found
    assert all(w.target_room != "store" for w in worlds)


def test_no_findable_target_is_a_usage_error(locked: Setup) -> None:
    domain, space, typical = locked
    only_locked = domain.model_copy(update={"objects": {"cup2": domain.objects["cup2"]}})
    with pytest.raises(DomainError, match="no objects of class 'cup' the robot could find"):
        sample_world(only_locked, space, typical, np.random.default_rng(0), target_class="cup")


def test_an_absent_target_is_taken_out_of_the_world(home: Setup) -> None:
    domain, space, typical = home
    world = sample_world(domain, space, typical, np.random.default_rng(4), target_class="cup", absent=True)
    assert not world.present and world.target_cell is None and world.target_room is None
    assert world.target not in world.rooms and len(world.rooms) == len(domain.objects) - 1


# -- the robot's knowledge ------------------------------------------------------------------------


@pytest.mark.parametrize("fraction", [0.0, 0.4, 1.0])
def test_the_robot_knows_a_fraction_of_the_other_objects_never_the_target(home: Setup, fraction: float) -> None:
    domain, space, typical = home
    world = sample_world(domain, space, typical, np.random.default_rng(5), target_class="printer")
    known = sample_known(domain, world, fraction, np.random.default_rng(6))
    assert len(known) == round(fraction * (len(domain.objects) - 1)) and world.target not in known
    robot = robot_domain(domain, world, known)
    for name, spec in robot.objects.items():
        assert spec.room == (world.rooms[name] if name in known else None) and spec.on is None
    assert robot.path == domain.path and robot.defaults == domain.defaults  # the rest of the domain is kept
    assert set(unknown_objects(domain, world, known)) == set(domain.objects) - known - {world.target}
    located = KnowledgeBase(robot, use_defaults=False).answer().located(step=1)
    assert located == {name: world.rooms[name] for name in known}  # without defaults the KB knows just that


# -- paired trials -----------------------------------------------------------------------------------

ARMS = [
    Arm("pomdp", Metareasoning.NONE),
    Arm("pomdp", Metareasoning.EXPECTATION),
    Arm("pomdp-only", Metareasoning.NONE),
    Arm("pomdp", Metareasoning.NONE, Revision.TRUST),
]


@pytest.fixture(scope="module")
def paired() -> Paired:
    domain = load_domain(HOME)
    settings = TrialSettings(knowledge=0.4, absent_fraction=0.3)
    return domain, settings, run_trials(domain, ARMS, trials=8, seed=11, settings=settings)


def test_paired_trials_share_worlds_and_targets(paired: Paired) -> None:
    _, _, records = paired
    assert len(records) == 8 and {r.present for r in records} == {True, False}
    for record in records:
        assert [o.arm for o in record.outcomes] == [arm.name for arm in ARMS]
        if not record.present:
            assert record.true_cell is None and all(o.reported_cell is None or o.accuracy == 0 for o in record.outcomes)
    # the two arms that differ only in metareasoning choose the same views until one stops
    for record in records:
        none, expectation = record.outcomes[0], record.outcomes[1]
        if expectation.verdict == "found":
            assert (none.verdict, none.time, none.reported_cell) == (
                "found",
                expectation.time,
                expectation.reported_cell,
            )


def test_a_trial_depends_only_on_the_seed_and_its_index(paired: Paired) -> None:
    domain, settings, records = paired
    again = run_trials(domain, ARMS, trials=3, seed=11, settings=settings, first=5)
    strip = [[(o.arm, o.verdict, o.time, o.reported_cell, o.accuracy) for o in r.outcomes] for r in records[5:]]
    assert [[(o.arm, o.verdict, o.time, o.reported_cell, o.accuracy) for o in r.outcomes] for r in again] == strip
    assert [(r.target, r.true_cell, r.room_prior) for r in again] == [
        (r.target, r.true_cell, r.room_prior) for r in records[5:]
    ]
    other = run_trials(domain, ARMS[:1], trials=3, seed=12, settings=settings, first=5)
    assert [r.target for r in other] != [r.target for r in again] or [r.true_cell for r in other] != [
        r.true_cell for r in again
    ]


def test_trial_streams_are_independent_and_repeatable() -> None:
    first = trial_rng(1, 2, Stream.TARGET_DETECTIONS).random(3)
    assert np.array_equal(first, trial_rng(1, 2, Stream.TARGET_DETECTIONS).random(3))
    assert not np.array_equal(first, trial_rng(1, 2, Stream.BETA_SAMPLES).random(3))
    assert not np.array_equal(first, trial_rng(1, 3, Stream.TARGET_DETECTIONS).random(3))


def test_summary_counts_and_means(paired: Paired) -> None:
    _, _, records = paired
    summary = summarize(records)
    assert list(summary) == [arm.name for arm in ARMS]
    for name, stats in summary.items():
        mine = [o for r in records for o in r.outcomes if o.arm == name]
        assert stats.trials == 8 == stats.found + stats.not_found + stats.time_limit
        assert stats.mean_time == pytest.approx(np.mean([o.time for o in mine]))
        assert stats.mean_accuracy == pytest.approx(np.mean([o.accuracy for o in mine]))
    assert summary["pomdp/none/static/reuse"].not_found == 0  # no metareasoning: never gives up


def test_bad_settings_and_arms_are_refused() -> None:
    with pytest.raises(ValueError, match="knowledge must be in"):
        TrialSettings(knowledge=1.5)
    with pytest.raises(ValueError, match="unknown policy"):
        Arm("astar")
    with pytest.raises(ValueError, match="the same arm twice"):
        run_trials(load_domain(HOME), [Arm("pomdp"), Arm("pomdp")], trials=1)
