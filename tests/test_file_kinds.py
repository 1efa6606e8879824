"""beliefloc.source.file_kinds: what kind of beliefloc file some parsed data or a file name is."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from beliefloc.source import file_kinds
from beliefloc.source.file_kinds import (
    BELIEF,
    DOMAIN,
    IMAGE,
    KNOWLEDGE_BASE,
    MACROS,
    MAP,
    MODEL,
    MODEL_OR_MACROS,
    OCCUPANCY,
    POMDP,
    kind_of,
    kind_of_data,
    kind_of_path,
    not_a,
)

from .conftest import DATA, MAPS, ROOT


def _yaml(path: Path) -> object:
    return yaml.safe_load(path.read_text(encoding="utf-8"))


@pytest.mark.parametrize("path", sorted(MAPS.glob("*.yaml")), ids=lambda p: p.name)
def test_every_bundled_map_is_a_map(path: Path):
    assert kind_of_data(_yaml(path)) == MAP


@pytest.mark.parametrize("path", sorted((ROOT / "domains").glob("*.yaml")), ids=lambda p: p.name)
def test_every_bundled_domain_is_a_domain(path: Path):
    assert kind_of_data(_yaml(path)) == DOMAIN


@pytest.mark.parametrize("path", sorted((MAPS / "occupancy").glob("*.yaml")), ids=lambda p: p.name)
def test_every_occupancy_yaml_is_one(path: Path):
    assert kind_of_data(_yaml(path)) == OCCUPANCY


def test_the_test_maps_are_maps_even_when_broken():
    """Every invalid map of the test corpus that is a mapping with a map's key is still a map."""
    for path in sorted((DATA / "invalid").glob("*.yaml")) + sorted((DATA / "fuzz" / "maps").glob("*.yaml")):
        try:
            data = _yaml(path)
        except yaml.YAMLError:
            continue
        if isinstance(data, dict) and data.keys() & {"grid", "actions", "sensors", "occupancy"}:
            assert kind_of_data(data) == MAP, path.name


def test_belief_files():
    assert kind_of_data({"3,4,0": 0.5, "3,4,1": 0.5}) == BELIEF
    assert kind_of_data({"0,0": 1}) == BELIEF
    assert kind_of_data({" 1 , 2 ": 0.25}) == BELIEF
    tracked = {"steps": [{"step": "look=window_seen"}], "belief": {"1,0": 0.5, "1,1": 0.5}, "pose": {"x": 0.5}}
    assert kind_of_data(tracked) == BELIEF, "beliefloc track --json, whose steps: is also a domain's key"
    assert kind_of_data(json.loads(json.dumps({"belief": {"0,0,1": 1.0}}))) == BELIEF


def test_not_beliefs():
    assert kind_of_data({"3,4,0": True}) is None, "a boolean is not a probability"
    assert kind_of_data({"kitchen": 0.5}) is None
    assert kind_of_data({"3,4,0": "half"}) is None
    assert kind_of_data({}) is None


def test_model_and_macro_headers():
    assert kind_of_data({"format": "beliefloc-model", "version": 3}) == MODEL
    assert kind_of_data({"format": "beliefloc-macros", "version": 1}) == MACROS
    assert kind_of_data({"format": "something-else"}) is None


def test_what_is_not_recognisable_is_none():
    for data in (None, 3, "robot(a).", [1, 2], {"name": "x"}, {"rooms": {}}, {"description": "?"}):
        assert kind_of_data(data) is None, data


def test_the_kind_with_most_keys_wins_and_a_tie_is_none():
    assert kind_of_data({"grid": {}, "actions": {}, "classes": {}}) == MAP
    assert kind_of_data({"classes": {}, "objects": {}, "layout": "."}) == DOMAIN
    assert kind_of_data({"grid": {}, "classes": {}}) is None


@pytest.mark.parametrize(
    ("name", "kind"),
    [
        ("kb/robot.lp", KNOWLEDGE_BASE),
        ("model.NPZ", MODEL_OR_MACROS),
        ("x/y/macros.npz", MODEL_OR_MACROS),
        ("tiger.pomdp", POMDP),
        ("maps/occupancy/depot.pgm", IMAGE),
        ("picture.png", IMAGE),
        ("maps/kitchen.yaml", None),
        ("belief.json", None),
        ("README", None),
    ],
)
def test_kind_of_path_looks_at_the_suffix_only(name: str, kind: str | None):
    assert kind_of_path(name) == kind
    assert kind_of_path(Path(name)) == kind


def test_kind_of_prefers_the_suffix_then_the_data():
    assert kind_of("kb/robot.lp", {"grid": {}}) == KNOWLEDGE_BASE
    assert kind_of("domains/home.yaml", _yaml(ROOT / "domains" / "home.yaml")) == DOMAIN
    assert kind_of("notes.yaml") is None


def test_not_a_message():
    assert not_a("domains/home.yaml", DOMAIN, MAP) == "domains/home.yaml is a knowledge-base domain, not a map"
    assert not_a(Path("maps/kitchen.yaml"), MAP, DOMAIN) == "maps/kitchen.yaml is a map, not a knowledge-base domain"


def test_every_kind_is_a_noun_phrase():
    assert len(set(file_kinds.KINDS)) == len(file_kinds.KINDS)
    for kind in file_kinds.KINDS:
        assert kind.split(" ", 1)[0] in ("a", "an"), kind


def test_it_opens_no_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """Pure: a name that does not exist is classified by its suffix alone."""
    monkeypatch.chdir(tmp_path)
    assert kind_of_path("nowhere/at/all.lp") == KNOWLEDGE_BASE
    assert not any(tmp_path.iterdir())
