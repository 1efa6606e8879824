"""``schema``: the JSON Schema of map and domain files, for editors (completion, hover, checks as you type).

The schema is generated from the very pydantic models that validate the files
(:class:`~beliefloc.semantic_map.SemanticMap`, :class:`~beliefloc.knowledge.Domain`), then made into
JSON Schema draft-07, the dialect yaml-language-server (VS Code's YAML extension, Neovim's yamlls,
Helix, ...) understands best: ``definitions`` instead of ``$defs``, tuples as ``items`` lists,
a discriminated union as ``if``/``then``. The models' field docstrings become the descriptions an
editor shows on hover.

Some rules are the loaders' and not the models' (``rows``/``cols`` come from an occupancy image, a
landmark has a ``cell`` or ``x``/``y``, one way of drawing rooms, action names fixed by
``headings``, a domain's ``search:`` shaped by whether it has ``map:``): they are added below, each
rule written once. What JSON Schema cannot say (the characters of a layout against the grid's size,
cross references between sections) stays with ``beliefloc validate``.
"""

from __future__ import annotations

import ast
import copy
import inspect
import itertools
import json
import re
import sys
import textwrap
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from beliefloc.cli.common import boundary, check_output
from beliefloc.errors import UsageError

if TYPE_CHECKING:
    from pydantic import BaseModel

JsonObject = dict[str, Any]

DRAFT_07 = "http://json-schema.org/draft-07/schema#"
KINDS = ("map", "domain")
_REF_PREFIX = "#/definitions/"
_ROLE = re.compile(r":(?:class|mod|func|attr|meth|data):`~?([^`]+)`")
_CODE_ASIDE = re.compile(r"\s*\((?:see )?:(?:mod|func|attr|meth):`[^`]+`\)")
"""A parenthesis that only points at the code, ``(:mod:`beliefloc.semantic_map.load`)``: dropped for editors."""


# --- the command ------------------------------------------------------------------------------------


@boundary
def schema_command(
    kind: Annotated[str, typer.Argument(metavar="map|domain", help="Which file format.", show_default=False)],
    output: Annotated[
        Path | None,
        typer.Option(
            "-o",
            "--output",
            metavar="FILE.json",
            help="Write the schema to this .json file instead of stdout.",
            show_default=False,
        ),
    ] = None,
) -> None:
    """Print the JSON Schema of map or domain files, for editors.

    The schema (JSON Schema draft-07) gives completion, hover text and checks as you type. Point
    yaml-language-server (VS Code's YAML extension, Neovim, Helix, ...) at it with a first line such
    as '# yaml-language-server: $schema=../schemas/map.schema.json' (a path relative to
    the YAML file). The shipped schemas/map.schema.json and schemas/domain.schema.json are this
    output. Layout characters and cross references are left to 'beliefloc validate'.

    Examples:

    \b
      beliefloc schema map -o map.schema.json
      beliefloc schema domain
    """
    if kind not in KINDS:
        raise UsageError(f"unknown kind {kind!r}: 'beliefloc schema map' or 'beliefloc schema domain'")
    if output is not None:
        check_output("-o", output, (".json",))
    text = schema_text(kind)
    if output is None:
        sys.stdout.write(text)
        return
    from beliefloc.source.atomic_write import write_atomically

    write_atomically(output, lambda handle: handle.write(text), binary=False)
    typer.echo(f"wrote {output}")


def register(app: typer.Typer) -> None:
    app.command("schema")(schema_command)


def schema_text(kind: str) -> str:
    """The schema of ``kind`` (``map`` or ``domain``) as the command prints it."""
    schema = map_schema() if kind == "map" else domain_schema()
    return json.dumps(schema, indent=2, ensure_ascii=True) + "\n"


# --- the map --------------------------------------------------------------------------------------


_MAP_FIELDS = {
    "name": "The map's name: letters, digits, '_' and '-'.",
    "description": "Free text.",
    "grid": "The grid: rows, cols, cell_size (metres), headings (1, 4 or 8).",
    "layout": (
        "One line per row, one character per cell: '.' free, '#' blocked (write it as a block, 'layout: |'). "
        "Blocked cells are not states; they stop moves, block views and are walls for Scan. Omitted: every "
        "cell is free. Not with occupancy:."
    ),
    "landmarks": "Objects the robot recognises: {class: chair, cell: [row, col]} or {class: chair, x: 3.2, y: 1.5}.",
    "actions": (
        "The actuation actions, name -> {cost, failure}: forward, backward, rotate_cw, rotate_ccw (headings 4 or "
        "8) or up, down, left, right (headings 1)."
    ),
    "sensors": "The perception actions, name -> a sensor of type look, scan or here.",
    "annotations": (
        "Expected observations written by hand, overriding what is computed: {state: '1,1,0', look: [chair]}."
    ),
    "rooms": (
        "Named rooms: layout (a letter per cell) with a legend, rectangles of cells, or on an occupancy map a "
        "region mask with labels or polygons in metres."
    ),
}
_GRID_FIELDS = {
    "rows": "Rows of cells (south is down). On a map with occupancy: they come from the image: leave them out.",
    "cols": "Columns of cells (east is right). On a map with occupancy: they come from the image: leave them out.",
}
_ACTION_FIELDS = {"cost": "The action's cost (a perception action's too)."}
_SENSOR_FIELDS = {
    "type": "look: which classes are seen; scan: distance to the wall ahead, binned; here: the class of the cell.",
    "cost": "The cost of using the sensor as a perception action.",
}
_LANDMARK_FIELDS = {
    "class": "The class the robot's detector reports: letters, digits, '_' and '-'.",
    "cell": "[row, col], 0-based from the top-left cell; or give x and y instead.",
    "x": "Map-frame metres (east), with y instead of cell: what RViz's Publish Point gives.",
    "y": "Map-frame metres (north), with x instead of cell.",
}
_ROOMS_FIELDS = {
    "layout": "Like the map's layout: a legend letter per cell of a room, '.' a free cell in no room, '#' blocked.",
    "rectangles": "Room name -> {from: [r0, c0], to: [r1, c1]} (both corners included), or a list of them.",
}
_ANNOTATION_FIELDS = {
    "state": "One state 'row,col,heading', or a whole cell 'row,col'.",
    "states": "Several states at once.",
}


def map_schema() -> JsonObject:
    """The JSON Schema (draft-07) of a semantic map file."""
    from beliefloc.semantic_map import schema as models
    from beliefloc.semantic_map import sections

    schema = _generate(models.SemanticMap)
    defs = schema["definitions"]
    _describe(defs, "SemanticMap", models.SemanticMap, _MAP_FIELDS, root=schema)
    _title(
        schema,
        "beliefloc map",
        "A semantic map: the grid, walls, landmarks, actions and sensors. See docs/map-format.md.",
    )
    for name, model, extra in (
        ("Grid", sections.Grid, _GRID_FIELDS),
        ("Landmark", sections.Landmark, _LANDMARK_FIELDS),
        ("ActionSpec", sections.ActionSpec, _ACTION_FIELDS),
        ("LookSensor", sections.LookSensor, _SENSOR_FIELDS),
        ("ScanSensor", sections.ScanSensor, _SENSOR_FIELDS),
        ("HereSensor", sections.HereSensor, _SENSOR_FIELDS),
        ("RoomRectangle", sections.RoomRectangle, {}),
        ("Rooms", sections.Rooms, _ROOMS_FIELDS),
        ("Annotation", sections.Annotation, _ANNOTATION_FIELDS),
    ):
        _describe(defs, name, model, extra)
    props = schema["properties"]

    # layout: the only characters a layout may hold (its size against the grid is validate's job)
    _non_null(props["layout"]).update(
        pattern=r"^[.#\s]*$", patternErrorMessage="One character per cell: '.' free, '#' blocked."
    )

    # grid: rows and cols come from the image on an occupancy map, and are required otherwise;
    # robot_radius and occupancy go together, and layout does not go with occupancy
    defs["Grid"].pop("required", None)
    moves = sections.MOVES_BY_HEADINGS
    compass, turning = list(moves[1]), list(dict.fromkeys([*moves[4], *moves[8]]))
    occupancy_given = {"required": ["occupancy"], "properties": {"occupancy": {"type": "string"}}}
    # ``errorMessage`` is yaml-language-server's (other validators ignore it); a property whose
    # schema is false reads "Property rows is not allowed."
    schema["allOf"] = [
        {
            "if": occupancy_given,
            "then": {
                "properties": {
                    "grid": {"properties": {"rows": False, "cols": False}},
                    "layout": {
                        "type": "null",
                        "errorMessage": "A map with occupancy: takes its free cells from the image: drop layout.",
                    },
                }
            },
            "else": {
                "properties": {
                    "grid": {
                        "required": ["rows", "cols"],
                        "properties": {
                            "robot_radius": {
                                "type": "null",
                                "errorMessage": "robot_radius applies to a map with occupancy: only.",
                            }
                        },
                    }
                }
            },
        },
        # action names are fixed by the grid's headings
        {
            "if": {
                "required": ["grid"],
                "properties": {"grid": {"required": ["headings"], "properties": {"headings": {"const": 1}}}},
            },
            "then": {"properties": {"actions": {"propertyNames": {"enum": compass}}}},
            "else": {"properties": {"actions": {"propertyNames": {"enum": turning}}}},
        },
    ]
    actions = props["actions"]
    spec = actions.pop("additionalProperties")
    actions["properties"] = {name: copy.deepcopy(spec) for name in [*turning, *compass]}
    actions["additionalProperties"] = False
    actions["minProperties"] = 1

    # a landmark has a cell, or x and y in metres (the loader fills in its cell), never both
    landmark = defs["Landmark"]
    landmark.pop("required")
    landmark["required"] = ["class"]
    for axis in ("x", "y"):
        landmark["properties"][axis] = {**_non_null(landmark["properties"][axis]), **_keep_docs(landmark, axis)}
        landmark["properties"][axis].pop("default", None)
    xy_given = {"anyOf": [{"required": ["x"]}, {"required": ["y"]}]}
    landmark["if"] = {"required": ["cell"]}
    landmark["then"] = {"properties": {"x": False, "y": False}}
    landmark["else"] = {"if": xy_given, "then": {"required": ["x", "y"]}, "else": {"required": ["cell"]}}

    # rooms: the loader refuses unknown keys; one way of drawing them
    rooms = defs["Rooms"]
    rooms["additionalProperties"] = False
    rooms["oneOf"] = [
        {"required": ["layout", "legend"]},
        {"required": ["rectangles"]},
        {"required": ["mask", "labels"]},
        {"required": ["polygons"]},
    ]
    _non_null(rooms["properties"]["legend"])["propertyNames"] = {
        "pattern": r"^[^.#\s]$",
        "patternErrorMessage": "A room's letter: one character other than '.' and '#'.",
    }
    _non_null(rooms["properties"]["labels"])["propertyNames"] = {"pattern": r"^-?[0-9]+$"}
    _non_null(rooms["properties"]["polygons"])["additionalProperties"]["minItems"] = 3

    # the old form of angles (semantic_map/angles.py): still read, with a warning; an editor marks it
    from beliefloc.semantic_map.angles import OLD_KEYS

    for kind, definition in (("look", "LookSensor"), ("scan", "ScanSensor")):
        properties = defs[definition]["properties"]
        for old, new in OLD_KEYS[kind].items():
            was = "degrees clockwise from the heading" if old == "beams" else "degrees"
            properties[old] = {
                **{k: v for k, v in properties[new].items() if k not in ("title", "description", "default")},
                "deprecated": True,
                "description": f"The old form ({was}), read as before with a warning: write {new} "
                "(docs/map-format.md, Angles).",
            }
            defs[definition].setdefault("not", {"anyOf": []})["anyOf"].append({"required": [old, new]})

    # an annotation names its state(s); its other keys are sensor names
    annotation = defs["Annotation"]
    annotation["anyOf"] = [{"required": ["state"]}, {"required": ["states"]}]
    annotation["propertyNames"] = {"pattern": props["name"]["pattern"]}  # sensor names are Names
    return schema


# --- the domain -----------------------------------------------------------------------------------


_DOMAIN_FIELDS = {
    "name": "The domain's name.",
    "description": "Free text.",
    "rooms": "The rooms: name -> {accessible: true|false}, or nothing after the name (bedroom:); or a list of names.",
    "objects": "Known object instances: name -> {class: C, room: R, on: O}.",
    "defaults": "Defaults with their exceptions: name -> {class: C, room: R, weak_exceptions: [...], ...}.",
    "target": "The class searched for when the command names none (--target).",
    "robot": "What is known about where the robot is: its dock, where it was last seen, whether it was carried.",
    "search": (
        "The geometry for object search (beliefloc search run): without map:, rooms as grids of cells on a plane "
        "(placement, room sizes) and the robot's start {room, cell}; with map:, the map gives the cells and the "
        "robot starts on a map cell [row, col]."
    ),
}


def domain_schema() -> JsonObject:
    """The JSON Schema (draft-07) of a domain file."""
    from beliefloc.knowledge import domain as models

    schema = _generate(models.Domain)
    defs = schema["definitions"]
    # ``search:`` is one of two models, chosen by ``map:`` (both fields are named search in files)
    plane = _generate(models.PlaneSearch)
    defs.update(plane.pop("definitions"))
    defs["PlaneSearch"] = plane
    _describe(defs, "Domain", models.Domain, _DOMAIN_FIELDS, root=schema)
    _title(
        schema,
        "beliefloc domain",
        "A knowledge base for object search and the robot's room prior: rooms, classes, objects, defaults. "
        "See docs/domain-format.md.",
    )
    for name, model in (
        ("Room", models.Room),
        ("ObjectInstance", models.ObjectInstance),
        ("Default", models.Default),
        ("RobotStart", models.RobotStart),
        ("DetectorSettings", models.DetectorSettings),
        ("Costs", models.Costs),
        ("Existence", models.Existence),
        ("PlaneSearch", models.PlaneSearch),
        ("MapSearch", models.MapSearch),
        ("RobotKnowledge", models.RobotKnowledge),
    ):
        _describe(defs, name, model, {})
    props = schema["properties"]
    defs["MapSearch"]["additionalProperties"] = False  # the loader refuses unknown keys, naming the plane's
    props["search"] = {"description": props["search"]["description"], "type": ["object", "null"]}
    map_given = {"required": ["map"], "properties": {"map": {"type": "string"}}}
    schema["allOf"] = [
        {
            "if": map_given,
            "then": {"properties": {"search": {"anyOf": [{"$ref": _REF_PREFIX + "MapSearch"}, {"type": "null"}]}}},
            "else": {"properties": {"search": {"anyOf": [{"$ref": _REF_PREFIX + "PlaneSearch"}, {"type": "null"}]}}},
        }
    ]
    # ``bedroom:`` with nothing after it is a room with the default settings; a list of names works too
    rooms = props["rooms"]
    room_or_nothing = {"anyOf": [rooms.pop("additionalProperties"), {"type": "null"}]}
    names = rooms.pop("propertyNames")
    as_mapping = {"type": "object", "propertyNames": names, "additionalProperties": room_or_nothing}
    as_list = {"type": "array", "items": {"type": "string", **names}}
    for key in ("type",):
        rooms.pop(key)
    rooms["anyOf"] = [as_mapping, as_list]
    return schema


# --- from pydantic to draft-07 --------------------------------------------------------------------


def _generate(model: type[BaseModel]) -> JsonObject:
    """``model``'s validation schema by alias, in draft-07 form, ``$schema`` first and definitions last."""
    raw = model.model_json_schema(by_alias=True, mode="validation", ref_template=_REF_PREFIX + "{model}")
    definitions = raw.pop("$defs", {})
    schema: JsonObject = {"$schema": DRAFT_07, **_draft07(raw)}
    schema["definitions"] = {name: _draft07(part) for name, part in sorted(definitions.items())}
    return schema


def _draft07(node: Any) -> Any:
    """Rewrite the 2020-12 parts pydantic emits: ``prefixItems`` tuples, ``discriminator`` unions,
    ``patternProperties`` keys; everything else is already draft-07."""
    if isinstance(node, list):
        return [_draft07(item) for item in node]
    if not isinstance(node, dict):
        return node
    node = {key: _draft07(value) for key, value in node.items()}
    if "prefixItems" in node:
        node["items"] = node.pop("prefixItems")
        node["additionalItems"] = False
    if "discriminator" in node and "oneOf" in node:
        node = _tagged_union(node)
    patterns = node.get("patternProperties")
    if isinstance(patterns, dict) and len(patterns) == 1 and "additionalProperties" not in node:
        # dict[Name, X]: pydantic refuses a key that does not match; patternProperties would let it through
        ((pattern, value),) = patterns.items()
        del node["patternProperties"]
        node["propertyNames"] = {"pattern": pattern, **node.get("propertyNames", {})}
        node["additionalProperties"] = value
    return node


def _tagged_union(node: JsonObject) -> JsonObject:
    """A pydantic discriminated union as an ``if``/``then`` per tag: an editor then checks a sensor
    against its own type only, and says which types exist when ``type`` is unknown."""
    discriminator = node.pop("discriminator")
    node.pop("oneOf")
    key, mapping = discriminator["propertyName"], discriminator["mapping"]
    return {
        **node,
        "type": "object",
        "required": [key],
        "properties": {key: {"enum": list(mapping)}},
        "allOf": [
            {
                "if": {"required": [key], "properties": {key: {"const": tag}}},
                "then": {"$ref": ref.replace("#/$defs/", _REF_PREFIX)},
            }
            for tag, ref in mapping.items()
        ],
    }


def _title(schema: JsonObject, title: str, description: str) -> None:
    """The root's title and description, and a note that the file is generated, right after ``$schema``."""
    rest = {key: value for key, value in schema.items() if key not in ("$schema", "title", "description")}
    schema.clear()
    schema.update(
        {
            "$schema": DRAFT_07,
            "$comment": f"Generated by 'beliefloc schema {title.split()[-1]}' from beliefloc's models; do not edit.",
            "title": title,
            "description": description,
            **rest,
        }
    )


def _non_null(prop: JsonObject) -> JsonObject:
    """The non-null branch of an ``X | None`` property (the property itself when it is not optional)."""
    for branch in prop.get("anyOf", []):
        if branch.get("type") != "null":
            return branch  # type: ignore[no-any-return]
    return prop


def _keep_docs(definition: JsonObject, name: str) -> JsonObject:
    prop = definition["properties"][name]
    return {key: prop[key] for key in ("title", "description") if key in prop}


def _describe(
    defs: JsonObject, name: str, model: type[BaseModel], extra: dict[str, str], *, root: JsonObject | None = None
) -> None:
    """Descriptions from the model's class and field docstrings (``extra`` fills fields without one),
    in plain text: the reStructuredText roles and double backquotes of the docstrings made simple."""
    target = root if root is not None else defs[name]
    if model.__doc__:
        target["description"] = _plain(model.__doc__)
    docs = _field_docstrings(model)
    aliases = {field.alias or key: key for key, field in model.model_fields.items()}
    for key, prop in target.get("properties", {}).items():
        text = extra.get(key) or docs.get(aliases.get(key, key))
        if text:
            prop["description"] = _plain(text)
            if "$ref" in prop:  # draft-07 ignores a $ref's siblings: wrap it
                prop["allOf"] = [{"$ref": prop.pop("$ref")}]


def _field_docstrings(model: type[BaseModel]) -> dict[str, str]:
    """Field name -> the docstring written under it, over ``model``'s bases too (nearest first)."""
    docs: dict[str, str] = {}
    for cls in reversed(model.__mro__):
        if cls.__module__.startswith("pydantic") or cls is object:
            continue
        try:
            tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
        except (OSError, TypeError):
            continue
        body = tree.body[0].body if tree.body and isinstance(tree.body[0], ast.ClassDef) else []
        for statement, following in itertools.pairwise(body):
            if (
                isinstance(statement, ast.AnnAssign)
                and isinstance(statement.target, ast.Name)
                and isinstance(following, ast.Expr)
                and isinstance(following.value, ast.Constant)
                and isinstance(following.value.value, str)
            ):
                docs[statement.target.id] = following.value.value
    return docs


def _plain(docstring: str) -> str:
    """A docstring as one line per paragraph, ``x`` and :class:`x` written `x`."""
    text = _CODE_ASIDE.sub("", inspect.cleandoc(docstring))
    text = _ROLE.sub(lambda m: f"`{m[1].rsplit('.', 1)[-1]}`", text)
    text = text.replace("``", "`")
    paragraphs = [" ".join(part.split()) for part in text.split("\n\n")]
    return "\n\n".join(p for p in paragraphs if p)
