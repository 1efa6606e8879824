"""Raw readings -> observations (:mod:`beliefloc.robots.readings`), checked against the observation names
that :meth:`ObservationModel.index` parses and against compile.py's own binning of the geometry."""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from beliefloc import compile_model, load_map
from beliefloc.errors import InvalidValueError, ModelError
from beliefloc.model import Model
from beliefloc.robots.readings import ReadingBinner, scan_bin
from beliefloc.semantic_map import SemanticMap, geometry
from beliefloc.semantic_map.sections import ScanSensor

from .conftest import MAPS

BUNDLED = ["kitchen", "hallway", "window-2x2", "khalvati-example1", "corridors", "apartment"]


@functools.cache
def _binner(name: str) -> tuple[SemanticMap, Model, ReadingBinner]:
    smap = load_map(MAPS / f"{name}.yaml")
    model = compile_model(smap)
    return smap, model, ReadingBinner(smap, model)


@pytest.fixture(scope="module")
def kitchen() -> tuple[SemanticMap, Model, ReadingBinner]:
    return _binner("kitchen")


@pytest.mark.parametrize("name", BUNDLED)
def test_every_observation_round_trips_through_its_example_reading(name: str) -> None:
    """For every action and observation, the example raw reading bins back to that observation."""
    _, model, binner = _binner(name)
    for action in model.actions:
        if not action.observation.parts:
            assert binner.example(action, None) == {}
            assert binner.observation(action, {}) is None
            continue
        for o in range(action.observation.n_observations):
            readings = binner.example(action, o)
            assert binner.observation(action, readings) == o, (action.name, action.observation.name(o), readings)


@pytest.mark.parametrize(
    ("metres", "name"),
    [
        (0.0, "wall_0-0.2"),
        (0.2, "wall_0-0.2"),  # an upper edge belongs to its bin
        (0.2 + 1e-10, "wall_0-0.2"),  # within compile.py's 1e-9 tolerance
        (0.2001, "wall_0.2-0.8"),
        (0.6, "wall_0.2-0.8"),
        (1, "wall_0.8-1.1"),
        (1.5, "wall_1.1-1.5"),
        (1.51, "no_wall"),
        (1.8, "no_wall"),
        (None, "no_wall"),
        (math.inf, "no_wall"),
    ],
)
def test_scan_ranges_bin_like_the_observation_names(kitchen: Any, metres: float | None, name: str) -> None:
    _, model, binner = kitchen
    scan = model.action("scan")
    expected = scan.observation.index(name)
    assert binner.observation("scan", {"scan": metres}) == expected
    assert binner.observation("scan", {"scan": [metres]}) == expected  # one range per beam


@pytest.mark.parametrize("name", ["kitchen", "hallway", "corridors"])
def test_true_ranges_bin_to_compiles_true_readings(name: str) -> None:
    """The oracle: the metres from every state's cell centre to the wall, binned here, are the
    readings compile.py computed for that state (beyond the last bin too: no_wall)."""
    smap, model, _ = _binner(name)
    layout = model.grid
    assert layout is not None
    (sensor_name, sensor), *_ = [(n, s) for n, s in smap.sensors.items() if isinstance(s, ScanSensor)]
    ahead = geometry.wall_distances(layout, 100.0)
    action = model.action(sensor_name) if sensor.as_action else model.actuation_actions[0]
    parts = action.observation.parts
    for k, angle in enumerate(sensor.beams):
        # beams turn counter-clockwise (REP 103); beam_distances counts heading steps clockwise
        beam = geometry.beam_distances(layout, ahead, round(-angle / (360.0 / layout.headings)))
        binned = np.array([scan_bin(sensor.bins, float(d)) for d in beam])
        np.testing.assert_array_equal(binned, parts[k].truth)


def test_multi_beam_scan_bins_each_beam_in_order() -> None:
    _, model, binner = _binner("corridors")
    forward = model.action("forward")
    expected = forward.observation.index("wall_0-0.5@90+no_wall@0+wall_0.5-1.5@-90")  # left, ahead, right
    assert binner.observation(forward, {"range": [0.3, None, 1.0]}) == expected


@pytest.mark.parametrize(
    ("classes", "name"),
    [
        ([], "nothing"),
        (["chair"], "chair"),
        (["chair", "potted_plant"], "potted_plant+chair"),
        (["potted_plant", "chair", "chair"], "chair+potted_plant"),  # a class listed twice counts once
    ],
)
def test_look_classes_bin_like_the_observation_names(kitchen: Any, classes: list[str], name: str) -> None:
    _, model, binner = kitchen
    assert binner.observation("look", {"look": classes}) == model.action("look").observation.index(name)


@pytest.mark.parametrize(
    ("degrees", "name"),
    [
        (0.0, "fire_extinguisher@0-18"),
        (18.0, "fire_extinguisher@0-18"),
        (-25.0, "fire_extinguisher@18-30"),  # the sign does not matter
        (28.1, "fire_extinguisher@18-30"),
        (44.9, "fire_extinguisher@30-45"),
        (50.0, "nothing"),  # outside the field of view the map gives the sensor
    ],
)
def test_look_viewing_angles_in_radians_bin_like_the_names(degrees: float, name: str) -> None:
    _, model, binner = _binner("hallway")
    raw = {"fire_extinguisher": math.radians(degrees)}
    assert binner.observation("look", {"look": raw}) == model.action("look").observation.index(name)
    assert binner.observation("look", {"look": {}}) == model.action("look").observation.index("nothing")


def test_passive_here_sensor_is_read_after_a_move() -> None:
    _, model, binner = _binner("khalvati-example1")
    up = model.action("up")
    assert binner.sensors(up)[0].name == "here"
    assert binner.observation(up, {"here": "1"}) == up.observation.index("1")
    assert binner.example(up, up.observation.index("0")) == {"here": "0"}


def test_describe_gives_beams_in_radians_counter_clockwise() -> None:
    _, _, binner = _binner("corridors")
    (scan,) = binner.describe("forward")
    assert scan["type"] == "scan" and scan["bins"] == [0.5, 1.5]
    assert scan["beams"] == pytest.approx([math.pi / 2, 0.0, -math.pi / 2])  # left, ahead, right
    assert math.copysign(1.0, scan["beams"][1]) == 1.0  # no -0.0 in the JSON


@pytest.mark.parametrize(
    ("action", "readings", "message"),
    [
        ("scan", {"scan": -0.5}, r"^scan: a range cannot be negative, got -0\.5$"),
        ("scan", {"scan": math.nan}, r"^scan: a range should be a number of metres or null \(no wall\), got NaN$"),
        ("scan", {"scan": True}, r"^scan: a range should be a number of metres or null \(no wall\), got true$"),
        ("scan", {"scan": "no_wall"}, r"got \"no_wall\"$"),
        ("scan", {"scan": [0.5, 0.6]}, r"^scan: got 2 ranges, but the scan has 1 beam$"),
        (
            "look",
            {"look": "chair"},
            r"^look: should be a list of the classes detected \(of potted_plant, .*got \"chair\"",
        ),
        ("look", {"look": ["sofa"]}, r"^look: 'sofa': not a class this sensor looks for \(potted_plant, fire_exting"),
        ("look", {}, r"^no reading of 'look': 'look' reads look, e\.g\. readings \{\"look\": \[\]\}$"),
        (
            "look",
            {"look": [], "scan": 1.0},
            r"^unexpected reading of 'scan': 'look' reads only look, "
            r"e\.g\. readings \{\"look\": \[\]\}$",
        ),
        ("forward", {"scan": 1.0}, r"^unexpected reading of 'scan': 'forward' reads no sensor$"),
    ],
)
def test_bad_readings_speak_of_the_value(kitchen: Any, action: str, readings: dict[str, Any], message: str) -> None:
    _, _, binner = kitchen
    with pytest.raises(InvalidValueError, match=message):
        binner.observation(action, readings)


@pytest.mark.parametrize(
    ("name", "action", "readings", "message"),
    [
        ("corridors", "forward", {"range": 0.5}, r"^range: should be a list of 3 ranges in metres, one per beam"),
        ("corridors", "forward", {"range": [0.5, None, "x"]}, r"^range: beam 2: a range should be a number"),
        ("hallway", "look", {"look": ["fire_extinguisher"]}, r"^look: this look sensor bins viewing angles"),
        ("hallway", "look", {"look": {"fire_extinguisher": None}}, r"viewing angle of 'fire_extinguisher' should"),
        ("khalvati-example1", "up", {"here": 1}, r"^here: should be the class of the robot's cell as a string"),
        ("khalvati-example1", "up", {"here": "2"}, r"^here: '2' is not a class this sensor reads \(0, 1\)$"),
    ],
)
def test_bad_readings_of_other_sensors(name: str, action: str, readings: dict[str, Any], message: str) -> None:
    _, _, binner = _binner(name)
    with pytest.raises(InvalidValueError, match=message):
        binner.observation(action, readings)


def test_a_model_of_another_map_is_refused(kitchen: Any) -> None:
    smap, _, _ = kitchen
    _, hallway, _ = _binner("hallway")
    with pytest.raises(ModelError, match=r"^model 'hallway' does not match map 'kitchen'"):
        ReadingBinner(smap, hallway)


@settings(max_examples=200, deadline=None)
@given(metres=st.floats(min_value=0.0, max_value=10.0))
def test_any_range_bins_to_the_name_of_its_bin(metres: float) -> None:
    """A property: the bin of a range is the one whose name's interval holds it."""
    smap, model, binner = _binner("kitchen")
    sensor = smap.sensors["scan"]
    assert isinstance(sensor, ScanSensor)
    names = sensor.observation_names()
    edges = [0.0, *sensor.bins]
    inside = [k for k in range(len(sensor.bins)) if edges[k] < metres <= edges[k + 1] or (k == 0 and metres == 0)]
    name = names[inside[0]] if inside else "no_wall"
    if any(abs(metres - e) < 1e-9 for e in edges):
        return  # on an edge the 1e-9 tolerance decides: the parametrised cases pin it
    assert binner.observation("scan", {"scan": metres}) == model.action("scan").observation.index(name)
