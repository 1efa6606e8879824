"""Where the robot probably is (issue 7): the knowledge base's facts and defaults about the robot's
room, the rule that turns them into a start belief, ``prior --robot`` and ``--belief prior:DOMAIN``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from beliefloc import compile_model, load_map
from beliefloc.errors import DomainError, InvalidValueError
from beliefloc.knowledge import (
    OUTSIDE,
    KnowledgeBase,
    domain_from_data,
    domain_robot_prior,
    load_domain,
    robot_room_prior,
    robot_rooms,
    robot_start_belief,
    spread_over_states,
)
from beliefloc.knowledge.robot import check_weight, robot_prior_from_answer
from beliefloc.semantic_map import room_states

from .conftest import DATA, MAPS, ROOT

APARTMENT_MAP = MAPS / "apartment.yaml"
APARTMENT = ROOT / "domains" / "apartment.yaml"
TWO_ROOMS = DATA / "rooms" / "two-rooms.yaml"
TWO_ROOMS_DOMAIN = DATA / "rooms" / "two-rooms-domain.yaml"
ROOMS = ("bedroom", "study", "corridor", "living_room", "kitchen")


def _domain(robot: dict[str, Any] | None, **extra: Any) -> dict[str, Any]:
    data: dict[str, Any] = {"name": "flat", "rooms": list(ROOMS), "classes": {"object": None, "cup": "object"}}
    if robot is not None:
        data["robot"] = robot
    data.update(extra)
    return data


def _believed(robot: dict[str, Any] | None, **extra: Any) -> tuple[str, ...]:
    return robot_rooms(KnowledgeBase(domain_from_data(_domain(robot, **extra))).answer())


# --- the knowledge base: facts, the dock default and its exception ---------------------------------


def test_the_robot_is_usually_at_its_dock() -> None:
    assert _believed({"dock": "kitchen"}) == ("kitchen",)


def test_a_sighting_beats_the_dock_default() -> None:
    assert _believed({"dock": "kitchen", "last_seen": "study"}) == ("study",)


def test_a_carried_robot_is_an_exception_to_the_dock_default() -> None:
    kb = KnowledgeBase(domain_from_data(_domain({"dock": "kitchen", "carried": True})))
    answer = kb.answer()
    assert robot_rooms(answer) == ()
    assert "ab(d_dock(robot))" in answer.abnormal


def test_a_carried_robot_is_where_it_was_last_seen() -> None:
    assert _believed({"dock": "kitchen", "carried": True, "last_seen": "bedroom"}) == ("bedroom",)


def test_nothing_known_about_the_robot() -> None:
    assert _believed(None) == ()
    assert _believed({}) == ()


def test_robot_facts_can_be_written_in_a_kb_file(tmp_path: Path) -> None:
    (tmp_path / "robot.lp").write_text("robot_dock(study).\n", encoding="utf-8")
    domain = domain_from_data(_domain(None, kb=["robot.lp"]), path=tmp_path / "flat.yaml")
    assert robot_rooms(KnowledgeBase(domain).answer()) == ("study",)


def test_the_robot_is_not_an_object() -> None:
    answer = KnowledgeBase(domain_from_data(_domain({"dock": "kitchen"}))).answer()
    assert "robot" not in answer.located()
    assert all("robot" not in counts for counts in answer.counts().values())


def test_the_sighting_holds_at_the_last_step_by_inertia() -> None:
    answer = KnowledgeBase(domain_from_data(_domain({"last_seen": "study"}, steps=4))).answer()
    assert [robot_rooms(answer, step) for step in (1, 2, 3, 4)] == [("study",)] * 4


# --- the rule --------------------------------------------------------------------------------------


def test_believed_rooms_share_w_and_the_others_share_the_rest() -> None:
    prior = robot_room_prior(ROOMS, ["kitchen"])
    assert prior.prior == pytest.approx(
        {"bedroom": 0.025, "study": 0.025, "corridor": 0.025, "living_room": 0.025, "kitchen": 0.9}
    )
    assert not prior.uniform and prior.message is None
    two = robot_room_prior(ROOMS, ["kitchen", "study"], weight=0.6)
    assert two.prior == pytest.approx(
        {"bedroom": 0.4 / 3, "study": 0.3, "corridor": 0.4 / 3, "living_room": 0.4 / 3, "kitchen": 0.3}
    )


def test_nothing_known_is_uniform_over_rooms_with_a_note() -> None:
    prior = robot_room_prior(ROOMS, [])
    assert prior.uniform and set(prior.prior.values()) == {0.2}
    assert prior.message is not None and "does not say where the robot is" in prior.message


def test_every_room_believed_shares_everything() -> None:
    assert robot_room_prior(["a", "b"], ["a", "b"], weight=0.7).prior == {"a": 0.5, "b": 0.5}


def test_cells_in_no_room_are_one_more_of_the_other_rooms() -> None:
    prior = robot_room_prior(["kitchen", "study"], ["kitchen"], outside=True)
    assert prior.rooms == ("kitchen", "study", OUTSIDE)
    assert prior.prior == pytest.approx({"kitchen": 0.9, "study": 0.05, OUTSIDE: 0.05})


@pytest.mark.parametrize(
    ("rooms", "believed", "weight", "message"),
    [
        ([], [], 0.9, "needs at least one"),
        (["a"], [], 0.0, r"must be in \(0, 1\]"),
        (["a"], [], 1.5, r"must be in \(0, 1\]"),
        (["a", "b"], ["garage"], 0.9, "puts the robot in garage, which is not a room of: a, b"),
    ],
)
def test_rule_refuses_bad_input(rooms: list[str], believed: list[str], weight: float, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        robot_room_prior(rooms, believed, weight=weight)


def test_spread_puts_exactly_w_on_the_kitchen_states() -> None:
    """The issue's acceptance test: the KB says the robot is in the kitchen -> 0.9 over its states."""
    smap = load_map(APARTMENT_MAP)
    model = compile_model(smap)
    assert model.grid is not None
    states = room_states(smap.rooms, model.grid)
    answer = KnowledgeBase(load_domain(APARTMENT)).answer()
    belief = spread_over_states(robot_prior_from_answer(answer), states, model.n_states)
    assert belief[states["kitchen"]].sum() == pytest.approx(0.9, abs=1e-12)
    assert belief.sum() == pytest.approx(1.0, abs=1e-12)
    for room, indices in states.items():
        expected = 0.9 if room == "kitchen" else 0.025
        assert belief[indices].sum() == pytest.approx(expected, abs=1e-12)
        assert np.ptp(belief[indices]) == 0.0, "uniform over the room's cells and headings"


def test_spread_covers_the_cells_in_no_room() -> None:
    smap = load_map(TWO_ROOMS)
    model = compile_model(smap)
    assert model.grid is not None
    states = room_states(smap.rooms, model.grid)
    belief = spread_over_states(
        robot_room_prior(["kitchen", "study"], ["kitchen"], outside=True), states, model.n_states
    )
    doorway = [model.states.index(f"1,2,{h}") for h in range(4)]
    assert belief[doorway].sum() == pytest.approx(0.05)
    assert belief[states["kitchen"]].sum() == pytest.approx(0.9)


def test_spread_refuses_a_room_without_cells() -> None:
    prior = robot_room_prior(["kitchen", "garage"], ["kitchen"])
    with pytest.raises(ValueError, match="no cells for room 'garage'"):
        spread_over_states(prior, {"kitchen": np.arange(4)}, 4)


def test_spread_refuses_states_in_no_room_without_a_share() -> None:
    prior = robot_room_prior(["kitchen"], ["kitchen"])
    with pytest.raises(ValueError, match="2 states are in no room"):
        spread_over_states(prior, {"kitchen": np.arange(4)}, 6)


# --- domains that reference a map ------------------------------------------------------------------


def test_a_domain_loads_its_map_relative_to_itself() -> None:
    domain = load_domain(APARTMENT)
    assert domain.map_file is not None and domain.map_file.resolve() == APARTMENT_MAP.resolve()
    assert domain.semantic_map is not None and list(domain.semantic_map.rooms) == list(domain.rooms)
    assert domain.search is None and domain.map_search is not None
    assert domain.map_search.robot_start == (5, 6)


def test_domain_from_data_checks_the_rooms_against_the_map(tmp_path: Path) -> None:
    data = yaml.safe_load(TWO_ROOMS_DOMAIN.read_text(encoding="utf-8"))
    assert domain_from_data(data, path=TWO_ROOMS_DOMAIN).semantic_map is not None
    data["rooms"] = ["kitchen", "pantry"]
    with pytest.raises(DomainError, match=r"not rooms of the map: pantry; rooms of the map missing here: study"):
        domain_from_data(data, path=TWO_ROOMS_DOMAIN)


def test_a_plane_domain_keeps_its_search_space() -> None:
    domain = load_domain(ROOT / "domains" / "home.yaml")
    assert domain.search is not None and domain.map_search is None and domain.semantic_map is None


# --- the library: a domain's robot prior and start belief ------------------------------------------


def test_a_domain_robot_prior_counts_the_cells_of_its_map() -> None:
    result = domain_robot_prior(load_domain(APARTMENT))
    assert result.prior.believed == ("kitchen",) and result.step == 2 and result.warnings == ()
    assert result.cells is not None and result.cells["kitchen"] == 12 and result.cells["study"] == 18
    assert OUTSIDE not in result.cells and result.prior.rooms == ROOMS


def test_a_domain_robot_prior_owns_its_json_shape() -> None:
    data = domain_robot_prior(load_domain(TWO_ROOMS_DOMAIN), weight=0.6).as_json()
    assert list(data) == ["rooms", "prior", "robot_in", "weight", "uniform", "cells", "answer_sets"]
    assert data["rooms"] == ["kitchen", "study", OUTSIDE] and data["cells"] == {"kitchen": 6, "study": 6, OUTSIDE: 1}
    assert data["robot_in"] == ["kitchen"] and data["weight"] == 0.6 and data["uniform"] is False
    assert data["prior"] == pytest.approx({"kitchen": 0.6, "study": 0.2, OUTSIDE: 0.2})
    assert json.loads(json.dumps(data)) == data


def test_a_domain_robot_prior_returns_its_warnings_instead_of_printing_them(capsys: pytest.CaptureFixture[str]) -> None:
    result = domain_robot_prior(load_domain(ROOT / "domains" / "home.yaml"))
    assert result.cells is None and result.prior.uniform
    assert len(result.warnings) == 1 and "does not say where the robot is" in result.warnings[0]
    assert capsys.readouterr() == ("", "")


@pytest.mark.parametrize("weight", [0.0, -0.5, 1.5])
def test_the_weight_is_checked_by_the_rule(weight: float) -> None:
    with pytest.raises(InvalidValueError, match=r"the weight w must be in \(0, 1\]"):
        check_weight(weight)
    with pytest.raises(InvalidValueError, match=r"the weight w must be in \(0, 1\]"):
        domain_robot_prior(load_domain(APARTMENT), weight=weight)
    assert check_weight(1.0) == 1.0


def test_the_start_belief_comes_with_its_prior_and_warnings() -> None:
    model = compile_model(load_map(TWO_ROOMS))
    start = robot_start_belief(model, load_domain(TWO_ROOMS_DOMAIN))
    assert start.prior.rooms == ("kitchen", "study", OUTSIDE) and start.warnings == ()
    assert start.belief.sum() == pytest.approx(1.0)


@pytest.mark.parametrize(
    ("source", "domain", "message"),
    [
        (MAPS / "kitchen.yaml", APARTMENT, r"^\S*kitchen\.yaml has no rooms"),
        (APARTMENT_MAP, ROOT / "domains" / "home.yaml", r"^the domain's rooms must be those of \S*apartment\.yaml; "),
    ],
    ids=["no-rooms", "missing-room"],
)
def test_the_start_belief_speaks_of_values_not_options(source: Path, domain: Path, message: str) -> None:
    with pytest.raises(InvalidValueError, match=message) as info:
        robot_start_belief(compile_model(load_map(source)), load_domain(domain))
    assert "--" not in str(info.value)


def test_a_room_only_the_kb_file_knows_has_no_cells(tmp_path: Path) -> None:
    data = yaml.safe_load(APARTMENT.read_text(encoding="utf-8"))
    data["map"] = str(APARTMENT_MAP)
    data["kb"] = ["garage.lp"]
    (tmp_path / "garage.lp").write_text("room(garage).\n", encoding="utf-8")
    (tmp_path / "flat.yaml").write_text(yaml.safe_dump(data), encoding="utf-8")
    model = compile_model(load_map(APARTMENT_MAP))
    with pytest.raises(InvalidValueError, match="no cells for room 'garage'"):
        robot_start_belief(model, load_domain(tmp_path / "flat.yaml"))


def test_the_field_name_behind_a_map_search_is_not_a_key_of_the_file() -> None:
    data = _domain(None, map_search={"robot_start": [0, 0]})
    with pytest.raises(
        DomainError, match=r"map_search: unknown key 'map_search'; expected one of: .*robot, rooms, scene, search"
    ):
        domain_from_data(data)
