"""Editor support: the JSON Schemas of maps and domains (``beliefloc schema``), the modeline every
shipped file starts with, and the commented starting files of ``beliefloc init``.

The schemas are checked with an independent validator (jsonschema, draft-07), both ways: every
shipped map and domain passes, and files the loaders refuse for a reason a schema can state fail.
"""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path
from typing import Any

import jsonschema
import pytest
import yaml
from typer.testing import CliRunner

from beliefloc.cli.app import app
from beliefloc.cli.init import _schema_pointer
from beliefloc.errors import DomainError, MapError
from beliefloc.knowledge import load_domain
from beliefloc.semantic_map import load_map

from .conftest import MAPS, ROOT

DOMAINS = ROOT / "domains"
SCHEMAS = ROOT / "schemas"
MAP_FILES = sorted(MAPS.glob("*.yaml"))  # not maps/occupancy/: those are Nav2's files
DOMAIN_FILES = sorted(DOMAINS.glob("*.yaml"))
SHIPPED = [("map", path) for path in MAP_FILES] + [("domain", path) for path in DOMAIN_FILES]


def _printed(runner: CliRunner, kind: str) -> str:
    result = runner.invoke(app, ["schema", kind])
    assert result.exit_code == 0, result.output
    return result.stdout


@pytest.fixture(scope="module")
def schemas() -> dict[str, dict[str, Any]]:
    runner = CliRunner()
    return {kind: json.loads(_printed(runner, kind)) for kind in ("map", "domain")}


def _validator(schema: dict[str, Any]) -> jsonschema.Draft7Validator:
    return jsonschema.Draft7Validator(schema)


def _as_editor_sees(text: str) -> Any:
    """The file as a YAML language server hands it to the schema: YAML read as JSON data, so a key
    written ``1:`` (a region label) is the string "1". The modeline is a comment: nothing to strip."""
    return json.loads(json.dumps(yaml.safe_load(text)))


def _errors(schema: dict[str, Any], data: Any) -> list[str]:
    return [f"{'/'.join(map(str, e.absolute_path))}: {e.message}" for e in _validator(schema).iter_errors(data)]


def _places(schema: dict[str, Any], data: Any) -> list[str]:
    """Where the errors are, including those inside an anyOf (``rooms: Rooms | None``), which an
    editor reports from the branch that matches best."""
    found: list[str] = []
    pending = list(_validator(schema).iter_errors(data))
    while pending:
        error = pending.pop()
        found.append("/".join(map(str, error.absolute_path)))
        pending.extend(error.context or [])
    return found


# --- the schemas ------------------------------------------------------------------------------------


@pytest.mark.parametrize("kind", ["map", "domain"])
def test_the_shipped_schema_is_what_the_command_prints(runner: CliRunner, kind: str) -> None:
    """schemas/*.schema.json never drift from the models: regenerate with `beliefloc schema KIND -o ...`."""
    shipped = (SCHEMAS / f"{kind}.schema.json").read_text(encoding="utf-8")
    assert shipped == _printed(runner, kind), f"rerun: beliefloc schema {kind} -o schemas/{kind}.schema.json"


@pytest.mark.parametrize("kind", ["map", "domain"])
def test_the_schema_is_draft_07(schemas: dict[str, dict[str, Any]], kind: str) -> None:
    schema = schemas[kind]
    assert schema["$schema"] == "http://json-schema.org/draft-07/schema#"
    jsonschema.Draft7Validator.check_schema(schema)
    text = json.dumps(schema)
    for later in ("$defs", "prefixItems", "discriminator", "unevaluatedProperties", "$dynamicRef"):
        assert later not in text, f"{later} is not draft-07"
    for ref in re.findall(r'"\$ref": "([^"]+)"', text):
        assert ref.startswith("#/definitions/") and ref.removeprefix("#/definitions/") in schema["definitions"], ref


def test_the_tricky_fields_of_the_map_schema(schemas: dict[str, dict[str, Any]]) -> None:
    schema = schemas["map"]
    defs = schema["definitions"]
    assert "class" in defs["Landmark"]["properties"] and "class_" not in json.dumps(schema)  # the alias
    assert "from" in defs["RoomRectangle"]["properties"]
    sensor = schema["properties"]["sensors"]["additionalProperties"]
    assert sensor["properties"]["type"]["enum"] == ["here", "look", "scan"]
    for model in ("LookSensor", "ScanSensor", "HereSensor"):
        assert defs[model]["additionalProperties"] is False, model
    assert defs["Landmark"]["properties"]["cell"]["items"] == [{"type": "integer"}, {"type": "integer"}]
    assert "description" in defs["ScanSensor"]["properties"]["bins"]  # from the field docstrings
    assert "rooms" in schema["properties"] and "room_spec" not in json.dumps(schema)


def test_the_descriptions_are_plain_text(schemas: dict[str, dict[str, Any]]) -> None:
    """No reStructuredText left in what an editor shows on hover."""
    text = json.dumps(schemas)
    assert "``" not in text and ":class:" not in text and ":mod:" not in text


# --- every shipped file --------------------------------------------------------------------------------


@pytest.mark.parametrize(("kind", "path"), SHIPPED, ids=lambda v: getattr(v, "name", v))
def test_a_shipped_file_names_its_schema_on_its_first_line(kind: str, path: Path) -> None:
    first = path.read_text(encoding="utf-8").splitlines()[0]
    match = re.fullmatch(r"# yaml-language-server: \$schema=(\S+)", first)
    assert match, f"{path.name} should start with '# yaml-language-server: $schema=...'"
    assert (path.parent / match[1]).resolve() == SCHEMAS / f"{kind}.schema.json"


@pytest.mark.parametrize(("kind", "path"), SHIPPED, ids=lambda v: getattr(v, "name", v))
def test_a_shipped_file_passes_its_schema(schemas: dict[str, dict[str, Any]], kind: str, path: Path) -> None:
    assert _errors(schemas[kind], _as_editor_sees(path.read_text(encoding="utf-8"))) == []


# --- files the schema refuses, as the loaders do ---------------------------------------------------------


def _kitchen() -> dict[str, Any]:
    return _as_editor_sees((MAPS / "kitchen.yaml").read_text(encoding="utf-8"))  # type: ignore[no-any-return]


def _broken_maps() -> list[tuple[str, dict[str, Any], str]]:
    """(what is wrong, the map, where the schema should say so)."""
    cases = []

    def case(what: str, where: str, change: Any) -> None:
        data = _kitchen()
        change(data)
        cases.append((what, data, where))

    case("an unknown top-level key", "", lambda d: d.update(walls=[]))
    case("an unknown sensor type", "sensors/look/type", lambda d: d["sensors"]["look"].update(type="sonar"))
    case("a scan's key on a look sensor", "sensors/look", lambda d: d["sensors"]["look"].update(bins=[1.0]))
    case(
        "a probability as text",
        "sensors/look/false_positive",
        lambda d: d["sensors"]["look"].update(false_positive="low"),
    )
    case("a probability above 1", "sensors/scan/error", lambda d: d["sensors"]["scan"].update(error=1.5))
    case("a sensor without a type", "sensors/scan", lambda d: d["sensors"]["scan"].pop("type"))
    case("a cost as a boolean", "actions/forward/cost", lambda d: d["actions"]["forward"].update(cost=True))
    case("a compass move with headings 4", "actions", lambda d: d["actions"].update(up={"cost": 1}))
    case("a landmark with a cell and x, y", "landmarks/0", lambda d: d["landmarks"][0].update(x=0.5, y=0.5))
    case(
        "a landmark with x and no y",
        "landmarks/0",
        lambda d: d["landmarks"].__setitem__(0, {"class": "chair", "x": 0.5}),
    )
    case("a landmark with neither cell nor x, y", "landmarks/0", lambda d: d["landmarks"][0].pop("cell"))
    case("a landmark with a class misspelt", "landmarks/0", lambda d: d["landmarks"][0].update(klass="x"))
    case("a cell of three numbers", "landmarks/0/cell", lambda d: d["landmarks"][0].update(cell=[0, 1, 2]))
    case("a grid without rows", "grid", lambda d: d["grid"].pop("rows"))
    case("a layout with another character", "layout", lambda d: d.update(layout="...\n.x.\n...\n"))
    case("headings 3", "grid/headings", lambda d: d["grid"].update(headings=3))
    case(
        "two ways of drawing rooms",
        "rooms",
        lambda d: d.update(
            rooms={"rectangles": {"a": {"from": [0, 0], "to": [0, 0]}}, "polygons": {"b": [[0, 0], [1, 0], [1, 1]]}}
        ),
    )
    case("an unknown key under rooms", "rooms", lambda d: d.update(rooms={"rectangles": {}, "colours": {}}))
    return cases


@pytest.mark.parametrize(("what", "data", "where"), _broken_maps(), ids=lambda v: v if isinstance(v, str) else "")
def test_the_map_schema_refuses_what_the_loader_refuses(
    schemas: dict[str, dict[str, Any]], tmp_path: Path, what: str, data: dict[str, Any], where: str
) -> None:
    places = _places(schemas["map"], data)
    assert places, f"the schema accepts {what}"
    assert any(place == where for place in places), places
    path = tmp_path / "broken.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    with pytest.raises(MapError):
        load_map(path)


def test_an_occupancy_map_takes_rows_and_cols_from_the_image(schemas: dict[str, dict[str, Any]]) -> None:
    depot = _as_editor_sees((MAPS / "depot.yaml").read_text(encoding="utf-8"))
    assert _errors(schemas["map"], depot) == []
    with_rows = copy.deepcopy(depot)
    with_rows["grid"]["rows"] = 10
    assert any(e.startswith("grid") for e in _errors(schemas["map"], with_rows))
    with_layout = copy.deepcopy(depot)
    with_layout["layout"] = "..\n..\n"
    assert _errors(schemas["map"], with_layout)
    radius = _kitchen()
    radius["grid"]["robot_radius"] = 0.2  # only with occupancy:
    assert _errors(schemas["map"], radius)


def test_the_map_schema_accepts_the_other_forms(schemas: dict[str, dict[str, Any]]) -> None:
    """Forms no shipped map uses: a landmark in metres on a hand-drawn map, compass moves, rooms as
    rectangles given as a list."""
    data = _kitchen()
    data["landmarks"][0] = {"class": "chair", "x": 0.6, "y": 0.6}
    data["rooms"] = {"rectangles": {"west": [{"from": [0, 0], "to": [2, 0]}], "east": {"from": [0, 2], "to": [2, 2]}}}
    assert _errors(schemas["map"], data) == []
    compass = {"name": "c", "grid": {"rows": 1, "cols": 2, "headings": 1}, "actions": {"up": {}, "left": {"cost": 2}}}
    assert _errors(schemas["map"], compass) == []


def _apartment() -> dict[str, Any]:
    return _as_editor_sees((DOMAINS / "apartment.yaml").read_text(encoding="utf-8"))  # type: ignore[no-any-return]


def _home() -> dict[str, Any]:
    return _as_editor_sees((DOMAINS / "home.yaml").read_text(encoding="utf-8"))  # type: ignore[no-any-return]


def test_the_domain_schema_refuses_what_the_loader_refuses(schemas: dict[str, dict[str, Any]], tmp_path: Path) -> None:
    cases: list[tuple[str, dict[str, Any], str]] = []
    data = _home()
    data["owner"] = "me"
    cases.append(("an unknown key", data, ""))
    data = _home()
    data["objects"]["cup_x"] = {"class": "Cup"}
    cases.append(("a name that is no clingo constant", data, "objects/cup_x/class"))
    data = _home()
    data["steps"] = "two"
    cases.append(("steps as text", data, "steps"))
    data = _home()
    data["search"]["robot_start"] = [0, 0]
    cases.append(("a map cell as the start on a plane", data, "search/robot_start"))
    for what, broken, where in cases:
        places = _places(schemas["domain"], broken)
        assert where in places, (what, places)
        path = tmp_path / "broken.yaml"
        path.write_text(yaml.safe_dump(broken, sort_keys=False), encoding="utf-8")
        with pytest.raises(DomainError):
            load_domain(path)


def test_the_search_section_follows_map(schemas: dict[str, dict[str, Any]]) -> None:
    """With map:, search takes a map cell and no placement; without, a room and a cell on a plane."""
    on_map = _apartment()
    on_map["search"] = {"robot_start": [1, 1]}
    assert _errors(schemas["domain"], on_map) == []
    on_map["search"]["placement"] = {"kitchen": [0, 0]}
    assert any(e.startswith("search") for e in _errors(schemas["domain"], on_map))
    plane = _home()
    plane["search"]["robot_start"] = {"room": "study", "cell": [2, 2]}
    assert _errors(schemas["domain"], plane) == []
    plane["rooms"] = ["bedroom", "study", "kitchen", "living_room"]  # a list of room names works too
    assert _errors(schemas["domain"], plane) == []


# --- the command's edges ----------------------------------------------------------------------------------


def test_schema_writes_a_file(runner: CliRunner, tmp_path: Path) -> None:
    out = tmp_path / "map.schema.json"
    result = runner.invoke(app, ["schema", "map", "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert out.read_text(encoding="utf-8") == _printed(runner, "map")
    assert [p.name for p in tmp_path.iterdir()] == ["map.schema.json"]  # no temporary file left


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["schema", "maps"], "unknown kind 'maps'"),
        (["schema", "map", "-o", "schema.txt"], "expected one of: .json"),
        (["schema", "map", "-o", "no/such/folder/s.json"], "does not exist"),
    ],
)
def test_schema_refuses_bad_input(
    runner: CliRunner, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, args: list[str], message: str
) -> None:
    monkeypatch.chdir(tmp_path)
    result = runner.invoke(app, args)
    assert result.exit_code == 2
    assert message in result.stderr and "Traceback" not in result.output
    assert len(result.stderr.strip().splitlines()) == 1


# --- init --------------------------------------------------------------------------------------------


def test_init_writes_a_map_and_a_domain_that_load_and_plan(
    runner: CliRunner, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, schemas: dict[str, dict[str, Any]]
) -> None:
    monkeypatch.chdir(tmp_path)
    assert runner.invoke(app, ["init", "map", "lab"]).exit_code == 0
    assert runner.invoke(app, ["init", "domain", "office"]).exit_code == 0
    smap = load_map(tmp_path / "lab.yaml")
    assert smap.name == "lab" and smap.layout is not None and len(smap.landmarks) >= 2
    assert {type(s).__name__ for s in smap.sensors.values()} == {"LookSensor", "ScanSensor"}
    domain = load_domain(tmp_path / "office.yaml")
    assert domain.name == "office" and domain.target is not None
    for kind, name in (("map", "lab.yaml"), ("domain", "office.yaml")):
        text = (tmp_path / name).read_text(encoding="utf-8")
        assert text.splitlines()[0] == f"# yaml-language-server: $schema={kind}.schema.json"
        assert f"docs/{kind}-format.md" in text
        assert _errors(schemas[kind], _as_editor_sees(text)) == []
    planned = runner.invoke(app, ["plan", "lab.yaml"])
    assert planned.exit_code == 0, planned.output
    kb = runner.invoke(app, ["kb", "check", "office.yaml"])
    assert kb.exit_code == 0, kb.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["lab.yaml", "office.yaml"]  # nothing else


def test_init_tells_how_to_write_the_schema_it_points_at(runner: CliRunner, tmp_path: Path) -> None:
    result = runner.invoke(app, ["init", "map", "lab", "-o", str(tmp_path / "lab.yaml")])
    assert result.exit_code == 0
    assert "beliefloc schema map -o" in result.stderr and "map.schema.json" in result.stderr


def test_init_points_at_the_nearest_schemas_folder(runner: CliRunner, tmp_path: Path) -> None:
    (tmp_path / "schemas").mkdir()
    (tmp_path / "schemas" / "map.schema.json").write_text("{}", encoding="utf-8")
    (tmp_path / "maps").mkdir()
    result = runner.invoke(app, ["init", "map", "lab", "-o", str(tmp_path / "maps" / "lab.yml")])
    assert result.exit_code == 0, result.output
    first = (tmp_path / "maps" / "lab.yml").read_text(encoding="utf-8").splitlines()[0]
    assert first == "# yaml-language-server: $schema=../schemas/map.schema.json"
    assert result.stderr == ""


def test_init_in_this_repository_points_at_the_shipped_schema() -> None:
    """Inside the checkout (maps/, domains/), the pointer is the one the bundled files carry."""
    for kind, folder, shipped in (("map", MAPS, MAP_FILES[0]), ("domain", DOMAINS, DOMAIN_FILES[0])):
        pointer, found = _schema_pointer(kind, folder / "new.yaml")
        assert found
        assert f"# yaml-language-server: $schema={pointer}" == shipped.read_text(encoding="utf-8").splitlines()[0]


def test_init_writes_the_schema_pointer_it_is_given(runner: CliRunner, tmp_path: Path) -> None:
    url = "https://example.org/beliefloc/domain.schema.json"
    out = tmp_path / "d.yaml"
    assert runner.invoke(app, ["init", "domain", "d", "-o", str(out), "--schema", url]).exit_code == 0
    assert out.read_text(encoding="utf-8").splitlines()[0] == f"# yaml-language-server: $schema={url}"


def test_init_quotes_a_name_yaml_would_read_as_another_type(runner: CliRunner, tmp_path: Path) -> None:
    for name in ("null", "123", "true"):
        out = tmp_path / f"{name}.yaml"
        assert runner.invoke(app, ["init", "map", name, "-o", str(out)]).exit_code == 0
        assert load_map(out).name == name


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["init", "room", "x"], "unknown kind 'room'"),
        (["init", "map", "lab.yaml"], "write 'lab'"),
        (["init", "map", "my lab"], "letters, digits"),
        (["init", "map", "lab", "-o", "lab.txt"], "expected one of: .yaml, .yml"),
        (["init", "domain", "d", "-o", "no/such/folder/d.yaml"], "does not exist"),
    ],
)
def test_init_refuses_bad_input(
    runner: CliRunner, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, args: list[str], message: str
) -> None:
    monkeypatch.chdir(tmp_path)
    result = runner.invoke(app, args)
    assert result.exit_code == 2
    assert message in result.stderr and "Traceback" not in result.output
    assert len(result.stderr.strip().splitlines()) == 1
    assert list(tmp_path.iterdir()) == []


def test_init_never_overwrites(runner: CliRunner, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "lab.yaml").write_text("mine\n", encoding="utf-8")
    (tmp_path / "d.yaml").mkdir()
    for args in (["init", "map", "lab"], ["init", "domain", "x", "-o", "lab.yaml"], ["init", "domain", "d"]):
        result = runner.invoke(app, args)
        assert result.exit_code == 2, args
        assert "lab.yaml" in result.stderr or "folder" in result.stderr
    assert (tmp_path / "lab.yaml").read_text(encoding="utf-8") == "mine\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.yaml", "lab.yaml"]


# --- help ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("command", ["schema", "init"])
def test_help_has_a_summary_that_fits(runner: CliRunner, command: str) -> None:
    """(tests/test_help.py runs every command's examples.)"""
    overview = runner.invoke(app, ["--help"])
    summary = next(line for line in overview.stdout.splitlines() if line.strip().startswith(command + " "))
    assert not summary.rstrip().endswith("..."), summary  # a one-line summary that fits


def test_an_overlay_init_writes_and_an_old_form_map_are_what_the_schema_says(
    runner: CliRunner, tmp_path: Path, schemas: dict[str, dict[str, Any]]
) -> None:
    """``init --occupancy`` writes a file the editor finds no fault in; a map in the old angle form
    is accepted too (its keys are marked deprecated), but not with both forms of one key."""
    out = tmp_path / "site.yaml"
    occupancy = str(MAPS / "occupancy" / "tb3_sandbox.yaml")
    assert runner.invoke(app, ["init", "map", "site", "-o", str(out), "--occupancy", occupancy]).exit_code == 0
    assert _errors(schemas["map"], _as_editor_sees(out.read_text(encoding="utf-8"))) == []
    old = yaml.safe_load((MAPS / "corridors.yaml").read_text(encoding="utf-8"))
    scan = old["sensors"]["range"]
    scan["beams"] = [-90, 0, 90]
    assert _errors(schemas["map"], _as_editor_sees(yaml.safe_dump({**old, "sensors": {"range": scan}}))) != []
    del scan["beams_deg"]
    assert _errors(schemas["map"], _as_editor_sees(yaml.safe_dump({**old, "sensors": {"range": scan}}))) == []
    assert schemas["map"]["definitions"]["ScanSensor"]["properties"]["beams"]["deprecated"] is True
