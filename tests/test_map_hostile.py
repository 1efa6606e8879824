"""Hostile and careless maps (tests/data/fuzz/maps/, one small file per cause): each is refused with
one paragraph naming the file, line and field, exit code 2 and no traceback, before anything large
is allocated; or, for a map that is valid but cannot work as meant, loaded with a warning.

The causes: booleans written for numbers; the internal field names ``class_`` and ``from_``; a Look
class no landmark has (a warning); observation names that would collide; models too large for
:data:`beliefloc.source.limits.MODEL_ENTRIES` and geometry too slow for
:data:`beliefloc.source.limits.GEOMETRY_TESTS`; numbers that are not finite or out of range; an annotation
without a state; a file of another kind given as a map.
"""

from __future__ import annotations

import itertools
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from beliefloc.cli.app import app
from beliefloc.errors import EXIT_BAD_INPUT, FieldError, MapError
from beliefloc.model import NOTHING
from beliefloc.semantic_map import compile_model, load_map
from beliefloc.semantic_map.observations import (
    HUGE,
    ObservationSet,
    PartGroup,
    PartSpec,
    check_names,
    check_size,
)

from .conftest import DATA, MAPS, ROOT

FUZZ = DATA / "fuzz" / "maps"


@dataclass(frozen=True)
class Case:
    file: str
    field: str
    """The field path the message names, after ``FILE:LINE:COL:``."""
    message: str
    """A regex searched in the rest of the message."""
    line: int

    def __str__(self) -> str:
        return self.file.removesuffix(".yaml")


BOOLEAN = r"should be (a number|an integer)|valid (number|integer)"
LIMIT = r"is more than the limit of [\d,]+; if the input is what you meant, raise it with the environment variable "
CASES = [
    # 1. booleans are never numbers
    Case("bool_rows.yaml", "grid.rows", BOOLEAN, 3),
    Case("bool_headings.yaml", "grid.headings", r"should be a number, got true", 3),
    Case("bool_cell.yaml", "landmarks[0].cell[0]", BOOLEAN, 5),
    Case("bool_cost.yaml", "actions.up.cost", BOOLEAN, 5),
    Case("bool_failure.yaml", "actions.up.failure", BOOLEAN, 5),
    Case("bool_range.yaml", "sensors.look.range", BOOLEAN, 9),
    Case("bool_bins.yaml", "sensors.scan.bins[1]", BOOLEAN, 7),
    Case("bool_beams.yaml", "sensors.scan.beams[1]", BOOLEAN, 7),
    Case("bool_rectangle.yaml", "rooms.rectangles.kitchen.from[1]", BOOLEAN, 8),
    Case("bool_polygon.yaml", "rooms.polygons.kitchen[2][1]", BOOLEAN, 8),
    Case(
        "annotation_angle_bool.yaml",
        "annotations[0].look.chair",
        r"viewing angle must be a number of degrees within ±45",
        10,
    ),
    # 2. internal field names
    Case(
        "internal_class_key.yaml",
        "landmarks[0].class_",
        r"unknown key 'class_'; expected one of: cell, class, name, x, y",
        5,
    ),
    Case(
        "internal_from_key.yaml",
        "rooms.rectangles.kitchen[0].from_",
        r"unknown key 'from_'; expected one of: from, to",
        8,
    ),
    # 4. observation names are unique
    Case(
        "class_named_nothing.yaml",
        "sensors.look.classes[1]",
        r"'nothing' is the observation of look when nothing is seen; name the class otherwise",
        10,
    ),
    Case(
        "scan_bins_print_same.yaml",
        "sensors.scan.bins[1]",
        r"0\.2000001 m prints as 0\.2 in observation names, as does the edge before it \(0\.2\), so a reading "
        r"would be named like '0\.2-0\.2'; space the edges further apart",
        7,
    ),
    Case(
        "angle_bins_print_same.yaml",
        "sensors.look.angle_bins[1]",
        r"18\.0000001 degrees prints as 18 in observation names",
        9,
    ),
    Case(
        "passive_same_class.yaml",
        "sensors.back.classes[0]",
        r"the observation 'door' of every move \(each reads the passive sensors front, back together\) would "
        r"mean two things: front\.door not seen, back\.door=door; or front\.door=door, back\.door not seen",
        10,
    ),
    Case(
        "class_like_alias.yaml",
        "sensors.look.classes[1]",
        r"'door_seen' would mean a reading of look\.door and one of look\.door_seen in look",
        10,
    ),
    # 5. bounded sizes, before anything is allocated
    Case(
        "grid_3000x3000.yaml",
        "sensors.look.classes",
        r"36,000,000 states and 9 observations over 2 actions \(look: 8, 2\^3: one for each set of its 3 classes "
        r"seen\): 324,000,012 states × observations " + LIMIT + "BELIEFLOC_MAX_MODEL_ENTRIES=N$",
        7,
    ),
    Case(
        "grid_100000x100000.yaml",
        "grid",
        r"a 100,000 × 100,000 grid has room for 10,000,000,000 states, each with an observation: "
        r"10,000,000,000 states × observations " + LIMIT + "BELIEFLOC_MAX_MODEL_ENTRIES=N$",
        3,
    ),
    Case(
        "look_24_classes.yaml",
        "sensors.look.classes",
        r"36 states and 16,777,217 observations over 2 actions \(look: 16,777,216, 2\^24: .*" + LIMIT,
        7,
    ),
    Case(
        "look_40_classes.yaml",
        "sensors.look.classes",
        r"\(look: 1,099,511,627,776, 2\^40: one for each set of its 40 classes seen\).*" + LIMIT,
        7,
    ),
    Case(
        "passive_looks.yaml",
        "sensors.look0.passive",
        r"36 states and 268,435,456 observations over 1 action \(forward: 268,435,456, each reads the passive "
        r"sensors look0, .*, look13 together\).*" + LIMIT + "BELIEFLOC_MAX_MODEL_ENTRIES=N$",
        7,
    ),
    Case(
        "occupancy_cell_size_small.yaml",
        "grid.cell_size",
        r"a 15,350 × 30,200 grid with 8 headings has room for 3,708,560,000 states.*" + LIMIT,
        4,
    ),
    Case(
        "occupancy_cell_size_tiny.yaml",
        "grid.cell_size",
        r"should be a number of metres from 0\.001 to 1e\+09, got 1e-320",
        4,
    ),
    Case(
        "occupancy_radius_huge.yaml",
        "grid.robot_radius",
        r"a robot radius of 10 m is 200 pixels of 0\.05 m, tested around each of 7,502 cells: 1,218,392,318 "
        r"geometry tests " + LIMIT + "BELIEFLOC_MAX_GEOMETRY_TESTS=N$",
        4,
    ),
    Case("cell_size_tiny.yaml", "grid.cell_size", r"greater than or equal to 0\.001, got 1e-320", 3),
    Case("cost_huge.yaml", "actions.forward.cost", r"less than or equal to 1000000, got 1e\+308", 5),
    Case("range_infinite.yaml", "sensors.look.range", r"finite number, got inf", 9),
    Case("fov_nan.yaml", "sensors.look.fov", r"finite number, got nan", 9),
    Case("landmark_x_huge.yaml", "landmarks[0].x", r"\(1e\+300, 0\.5\) is off the 2x2 grid of 1 m cells", 5),
    # 6. an annotation without a state
    Case(
        "annotation_without_state.yaml",
        "annotations[0]",
        r"names no state: give state: 'r,c,h' \(or 'r,c' for a whole cell\) or states: \[\.\.\.\]",
        10,
    ),
]
VALID = {"unseen_class.yaml"}
ELSEWHERE = {"polygon_corners_over_limit.yaml", "occupancy_8m_states.yaml"}
"""Corpus files whose cases need a lowered limit or seconds of work: tests/test_hostile_round3_bounds.py."""


def _message_ok(text: str, path: Path | str, case: Case) -> None:
    prefix = f"{path}:{case.line}:"
    assert text.startswith(prefix), text
    rest = re.sub(r"^\d+: ", "", text[len(prefix) :])
    assert rest.startswith(f"{case.field}: "), text
    assert re.search(case.message, rest[len(case.field) + 2 :]), text


def test_every_corpus_file_has_a_case():
    assert sorted(p.name for p in FUZZ.glob("*.yaml")) == sorted({c.file for c in CASES} | VALID | ELSEWHERE)


@pytest.mark.parametrize("case", CASES, ids=str)
def test_corpus_file_says_what_it_holds_on_its_first_line(case: Case):
    assert (FUZZ / case.file).read_text(encoding="utf-8").startswith("# ")


@pytest.mark.parametrize("case", CASES, ids=str)
def test_load_map_refuses_with_file_line_and_field(case: Case):
    path = FUZZ / case.file
    with pytest.raises(MapError) as info:
        load_map(path)
    text = str(info.value)
    assert info.value.exit_code == EXIT_BAD_INPUT
    first = text.splitlines()[0]  # pydantic's own checks may list a second problem on a line of its own
    _message_ok(first, path, case)


@pytest.mark.parametrize("case", CASES, ids=str)
def test_cli_validate_exits_2_with_the_message(case: Case, runner, monkeypatch: pytest.MonkeyPatch):
    monkeypatch.chdir(ROOT)
    relative = (FUZZ / case.file).relative_to(ROOT)
    result = runner.invoke(app, ["validate", str(relative)])
    assert result.exit_code == EXIT_BAD_INPUT, result.output
    assert isinstance(result.exception, SystemExit), "a message, not a traceback"
    assert "Traceback" not in result.output
    assert result.stdout == ""
    text = result.stderr.removeprefix("error: ")
    first = " ".join(text.split("\n" + str(relative))[0].split())  # rich wraps long lines
    _message_ok(first, relative, case)


# --- 1. booleans ------------------------------------------------------------------------------------


def _kitchen_like(**grid: object) -> dict[str, object]:
    return {
        "name": "k",
        "grid": {"rows": 2, "cols": 2, "headings": 4, **grid},
        "actions": {"forward": {"cost": 1}},
    }


@pytest.mark.parametrize("value", [True, False])
def test_no_number_field_takes_a_boolean(tmp_path: Path, value: bool):
    """Every number of a full map, replaced by a boolean in turn, is refused at its own path."""
    import yaml

    text = (MAPS / "kitchen.yaml").read_text(encoding="utf-8")
    data = yaml.safe_load(text)
    paths = list(_number_paths(data))
    assert len(paths) > 20
    for where in paths:
        changed = yaml.safe_load(text)
        holder = changed
        for key in where[:-1]:
            holder = holder[key]
        holder[where[-1]] = value
        path = tmp_path / "map.yaml"
        path.write_text(yaml.safe_dump(changed), encoding="utf-8")
        with pytest.raises(MapError) as info:
            load_map(path)
        shown = ".".join(str(k) for k in where)
        assert str(value).lower() in str(info.value), (shown, str(info.value))


def _number_paths(data: object, at: tuple[object, ...] = ()):
    if isinstance(data, dict):
        for key, value in data.items():
            yield from _number_paths(value, (*at, key))
    elif isinstance(data, list):
        for k, value in enumerate(data):
            yield from _number_paths(value, (*at, k))
    elif isinstance(data, (int, float)) and not isinstance(data, bool):
        yield at


def test_integers_and_floats_still_load(tmp_path: Path):
    """Strict numbers still take what YAML gives: an integer where a float is expected."""
    path = tmp_path / "m.yaml"
    path.write_text(
        "name: m\ngrid: {rows: 2, cols: 3, cell_size: 2, headings: 4}\n"
        "landmarks: [{class: door, x: 1, y: 3}]\n"
        "actions: {forward: {cost: 3, failure: 0}}\n"
        "sensors: {look: {type: look, classes: [door], range: 5, fov: 180}, scan: {type: scan, bins: [1, 2]}}\n",
        encoding="utf-8",
    )
    smap = load_map(path)
    assert smap.grid.cell_size == 2.0
    assert smap.landmarks[0].cell == (0, 0)


# --- 3. a class no landmark has -------------------------------------------------------------------


def test_a_class_no_landmark_has_is_a_warning_naming_the_line():
    path = FUZZ / "unseen_class.yaml"
    warnings: list[str] = []
    smap = load_map(path, on_warning=warnings.append)
    assert smap.sensors["look"].classes == ["door", "plants"]  # type: ignore[union-attr]
    assert warnings == [
        f"{path}:9:38: sensors.look.classes[1]: no landmark is a 'plants'; the sensor will never see one"
    ]


def test_the_warning_is_printed_and_the_map_is_valid(runner, monkeypatch: pytest.MonkeyPatch):
    monkeypatch.chdir(ROOT)
    relative = (FUZZ / "unseen_class.yaml").relative_to(ROOT)
    result = runner.invoke(app, ["validate", str(relative)])
    assert result.exit_code == 0, result.output
    assert f"{relative}:9:38: sensors.look.classes[1]: no landmark is a 'plants'" in " ".join(result.stderr.split())
    assert result.stdout.startswith("ok ")


def test_an_annotated_class_is_not_warned_about(tmp_path: Path):
    """Annotations may say a class is seen (the generated maps of the 'states' model have no landmarks)."""
    path = tmp_path / "m.yaml"
    path.write_text(
        "name: m\ngrid: {rows: 1, cols: 2, headings: 1}\nactions: {up: {cost: 1}}\n"
        "sensors: {look: {type: look, classes: [A, B]}}\n"
        "annotations: [{state: '0,0', look: [A]}]\n",
        encoding="utf-8",
    )
    warnings: list[str] = []
    load_map(path, on_warning=warnings.append)
    assert len(warnings) == 1 and "no landmark is a 'B'" in warnings[0]


def test_bundled_maps_load_without_warnings_about_classes():
    for path in sorted(MAPS.glob("*.yaml")):
        warnings: list[str] = []
        load_map(path, on_warning=warnings.append)
        assert not [w for w in warnings if "no landmark" in w], warnings


# --- 4. observation names -------------------------------------------------------------------------


def _part(name: str, values: tuple[str, ...]) -> PartSpec:
    return PartSpec(name, values, {}, ("sensors", name), lambda w, n=name: ("sensors", n, w), name)


def _names_collide(parts: list[PartSpec]) -> bool:
    """By brute force: two different readings with the same joint name."""
    seen: set[str] = set()
    for reading in itertools.product(*(range(p.n_values) for p in parts)):
        tokens = [p.values[w] for p, w in zip(parts, reading, strict=True) if p.values[w]]
        name = "+".join(tokens) if tokens else NOTHING
        if name in seen:
            return True
        seen.add(name)
    return False


def test_a_silent_part_between_two_parts_that_share_readings_collides():
    """``x+y`` is A=x, B=y or B=x, C=y: a collision no pair of parts shows alone."""
    parts = [_part("a", ("", "x")), _part("b", ("x", "y")), _part("c", ("", "y"))]
    with pytest.raises(FieldError, match=r"the observation 'x\+y' of look would mean two things"):
        check_names(ObservationSet("look", (), ("sensors", "look"), parts=tuple(parts)))
    check_names(ObservationSet("look", (), ("sensors", "look"), parts=tuple(parts[:2])))  # A, B alone are fine


@settings(max_examples=300, deadline=None)
@given(
    st.lists(
        st.tuples(st.booleans(), st.sets(st.sampled_from(["x", "y", "z", "nothing"]), min_size=1, max_size=3)),
        min_size=1,
        max_size=4,
    )
)
def test_name_check_agrees_with_brute_force(spec: list[tuple[bool, set[str]]]):
    parts = [
        _part(f"p{k}", (("",) if silent else ()) + tuple(sorted(values))) for k, (silent, values) in enumerate(spec)
    ]
    collide = _names_collide(parts)
    try:
        check_names(ObservationSet("look", (), ("sensors", "look"), parts=tuple(parts)))
    except FieldError:
        assert collide
    else:
        assert not collide


def test_bundled_models_have_unique_observation_names():
    for path in sorted(MAPS.glob("*.yaml")):
        model = compile_model(load_map(path))
        for action in model.actions:
            names = action.observation.names()
            assert len(set(names)) == len(names), (path.name, action.name)


# --- 5. sizes -------------------------------------------------------------------------------------


def test_200000_scan_bins_are_refused_before_the_table_of_readings(tmp_path: Path):
    path = tmp_path / "bins.yaml"
    bins = ", ".join(f"{0.001 * (k + 1):.3f}" for k in range(200_000))
    path.write_text(
        f"name: b\ngrid: {{rows: 2, cols: 2, headings: 4}}\nactions: {{forward: {{cost: 1}}}}\n"
        f"sensors:\n  scan: {{type: scan, bins: [{bins}]}}\n",
        encoding="utf-8",
    )
    with pytest.raises(MapError) as info:
        load_map(path)
    assert str(info.value).startswith(f"{path}:5:28: sensors.scan.bins: the 200,001 readings of scan need a 200,001 × ")
    assert "BELIEFLOC_MAX_MODEL_ENTRIES" in str(info.value)


def test_the_limit_can_be_raised(monkeypatch: pytest.MonkeyPatch):
    """The size limit is the one documented: raising it lets a 24-class look through."""
    path = FUZZ / "look_24_classes.yaml"
    monkeypatch.setenv("BELIEFLOC_MAX_MODEL_ENTRIES", str(10**9))
    smap = load_map(path)
    sets = smap.observation_sets()
    assert [s.n_observations for s in sets] == [1, 2**24]
    monkeypatch.setenv("BELIEFLOC_MAX_MODEL_ENTRIES", str(36 * (2**24 + 1) + 24 * 4))  # exactly the model's size
    load_map(path)
    monkeypatch.setenv("BELIEFLOC_MAX_MODEL_ENTRIES", str(36 * (2**24 + 1) + 24 * 4 - 1))
    with pytest.raises(MapError, match="BELIEFLOC_MAX_MODEL_ENTRIES"):
        load_map(path)


def test_size_counts_what_compile_builds():
    """The sizes validation checks are those of the compiled model, for every bundled map."""
    for path in sorted(MAPS.glob("*.yaml")):
        smap = load_map(path)
        model = compile_model(smap)
        moves, *own = smap.observation_sets(named=True)
        built = {a.name: a.observation.n_observations for a in model.actions}
        for name in smap.actions:
            assert built[name] == moves.n_observations, (path.name, name)
            compiled = next(a for a in model.actions if a.name == name).observation.parts
            assert [p.values for p in compiled] == [p.values for p in moves.parts]
        for action in own:
            assert built[action.action] == action.n_observations, (path.name, action.action)
            compiled = next(a for a in model.actions if a.name == action.action).observation.parts
            assert [p.values for p in compiled] == [p.values for p in action.parts]


def test_check_size_names_the_grid_when_states_alone_are_too_many():
    sets = [
        ObservationSet("the moves", (), ("actions",), moves=("forward", "backward")),
        ObservationSet("look", (PartGroup("look", 2, 1, ("sensors", "look", "classes")),), ("sensors", "look")),
    ]
    with pytest.raises(FieldError) as info:
        check_size(40_000_000, sets)
    assert info.value.path == ("grid",)
    assert info.value.message.startswith("40,000,000 states and 4 observations over 3 actions: 160,000,004 states")


def test_a_look_of_100000_classes_is_refused_without_counting_its_observations(tmp_path: Path):
    """2^100,000 observations are not multiplied out: the count is reported as beyond 10^308."""
    path = tmp_path / "look.yaml"
    classes = ", ".join(f"c{k}" for k in range(100_000))
    path.write_text(
        f"name: l\ngrid: {{rows: 1, cols: 1, headings: 1}}\nactions: {{up: {{cost: 1}}}}\n"
        f"sensors: {{look: {{type: look, classes: [{classes}]}}}}\n",
        encoding="utf-8",
    )
    with pytest.raises(MapError, match=r"sensors\.look\.classes: 1 state and more than 10\^308 observations"):
        load_map(path)
    big = ObservationSet("look", (PartGroup("look", 2, 100_000, ("sensors", "look", "classes")),), ())
    assert big.n_observations == HUGE


_ADDRESS_SPACE = """
import resource, sys
limit = 3 * 1024**3
resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
from beliefloc.cli.app import main
sys.argv = ["beliefloc", *sys.argv[1:]]
main()
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="RLIMIT_AS is Linux's")
@pytest.mark.parametrize(
    ("command", "file"),
    [("plan", "grid_3000x3000.yaml"), ("simulate", "look_24_classes.yaml"), ("validate", "grid_100000x100000.yaml")],
)
def test_refused_within_a_small_address_space(command: str, file: str):
    """Refused before allocating: the process never needs more than 3 GiB of address space (plan
    reached 3.6 GB of memory on the 3,000 x 3,000 grid before these checks)."""
    result = subprocess.run(
        [sys.executable, "-c", _ADDRESS_SPACE, command, str((FUZZ / file).relative_to(ROOT))],
        capture_output=True,
        text=True,
        cwd=ROOT,
        check=False,
    )
    assert result.returncode == EXIT_BAD_INPUT, result.stderr
    assert "Traceback" not in result.stderr and "MemoryError" not in result.stderr
    assert "is more than the limit of" in " ".join(result.stderr.split())


# --- 7. files of another kind ---------------------------------------------------------------------


@pytest.mark.parametrize(
    ("file", "kind"),
    [
        ("domains/home.yaml", "a knowledge-base domain"),
        ("maps/occupancy/depot.yaml", "a ROS/Nav2 occupancy map YAML"),
        ("kb/robot.lp", "a knowledge base (.lp)"),
        ("maps/occupancy/depot.pgm", "an image"),
    ],
)
def test_a_file_of_another_kind_is_named(file: str, kind: str, runner, monkeypatch: pytest.MonkeyPatch):
    monkeypatch.chdir(ROOT)
    with pytest.raises(MapError, match=rf"^{re.escape(file)} is {re.escape(kind)}, not a map$"):
        load_map(file)
    result = runner.invoke(app, ["validate", file])
    assert result.exit_code == EXIT_BAD_INPUT
    assert " ".join(result.stderr.split()) == f"error: {file} is {kind}, not a map"


def test_a_tracked_belief_is_named(tmp_path: Path, runner):
    belief = tmp_path / "belief.json"
    result = runner.invoke(app, ["track", str(MAPS / "window-2x2.yaml"), "look=window_seen", "--json"])
    assert result.exit_code == 0, result.output
    belief.write_text(result.stdout, encoding="utf-8")
    with pytest.raises(MapError, match=r"belief\.json is a belief file, not a map$"):
        load_map(belief)
    plain = tmp_path / "plain.yaml"
    plain.write_text("'0,0': 0.5\n'1,1': 0.5\n", encoding="utf-8")
    with pytest.raises(MapError, match=r"plain\.yaml is a belief file, not a map$"):
        load_map(plain)


def test_a_compiled_model_is_named(tmp_path: Path, runner):
    model = tmp_path / "kitchen.npz"
    result = runner.invoke(app, ["build", str(MAPS / "kitchen.yaml"), "-o", str(model)])
    assert result.exit_code == 0, result.output
    result = runner.invoke(app, ["validate", str(model)])
    assert result.exit_code == EXIT_BAD_INPUT
    assert "is a compiled model or macro table (.npz), not a map" in " ".join(result.stderr.split())


def test_a_broken_map_is_still_a_map(tmp_path: Path):
    """A map with a stray domain key gets the map's own message, not a file-kind one."""
    path = tmp_path / "m.yaml"
    path.write_text(
        "name: m\ngrid: {rows: 1, cols: 1, headings: 1}\nactions: {up: {}}\nclasses: {}\n", encoding="utf-8"
    )
    with pytest.raises(MapError, match=r"m\.yaml:4:1: classes: unknown key 'classes'"):
        load_map(path)
