"""One angle convention (REP 103: counter-clockwise positive; degrees in map files only in keys that
say so), and the old form of map files read exactly as before, with a warning that shows the line in
the new form (beliefloc/semantic_map/angles.py, docs/map-format.md "Angles")."""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from beliefloc.cli.app import app
from beliefloc.errors import MapError
from beliefloc.model import Model
from beliefloc.robots.readings import ReadingBinner
from beliefloc.semantic_map import SemanticMap, load_map
from beliefloc.semantic_map.angles import OLD_KEYS
from beliefloc.semantic_map.compile import compile_model

from .conftest import MAPS

BUNDLED = sorted(MAPS.glob("*.yaml"))


def _old_form(data: dict[str, Any], folder: Path) -> dict[str, Any]:
    """A map's data written in the old form: beams in degrees clockwise, the angle keys without
    ``_deg``, viewing angles as bare numbers; the files it names made absolute."""
    data = dict(data)
    for key in ("occupancy",):
        if key in data:
            data[key] = str((folder / data[key]).resolve())
    rooms = data.get("rooms")
    if isinstance(rooms, dict) and "mask" in rooms:
        data["rooms"] = {**rooms, "mask": str((folder / rooms["mask"]).resolve())}
    sensors = {}
    for name, sensor in data.get("sensors", {}).items():
        sensor = dict(sensor)
        for old, new in OLD_KEYS.get(sensor["type"], {}).items():
            if new in sensor:
                value = sensor.pop(new)
                sensor[old] = [0 - v for v in value] if old == "beams" else value
        sensors[name] = sensor
    data["sensors"] = sensors
    annotations = []
    for annotation in data.get("annotations", []):
        annotation = {
            key: {c: float(str(a).removesuffix("deg")) for c, a in value.items()}
            if isinstance(value, dict) and all(str(a).endswith("deg") for a in value.values()) and value
            else value
            for key, value in annotation.items()
        }
        annotations.append(annotation)
    if annotations:
        data["annotations"] = annotations
    return data


def _same_model(a: Model, b: Model) -> None:
    """Every number and name of two models is identical (not close: identical)."""
    assert [s for s in a.states.names] == [s for s in b.states.names]
    assert [x.name for x in a.actions] == [y.name for y in b.actions]
    for x, y in zip(a.actions, b.actions, strict=True):
        assert (x.kind, x.cost) == (y.kind, y.cost)
        assert (x.transition is None) == (y.transition is None)
        if x.transition is not None and y.transition is not None:
            for part in ("data", "indices", "indptr"):
                np.testing.assert_array_equal(getattr(x.transition, part), getattr(y.transition, part))
        for p, q in zip(x.observation.parts, y.observation.parts, strict=True):
            assert (p.name, p.values, p.aliases) == (q.name, q.values, q.aliases)
            np.testing.assert_array_equal(p.truth, q.truth)
            np.testing.assert_array_equal(p.confusion, q.confusion)
        assert len(x.observation.parts) == len(y.observation.parts)


@pytest.mark.parametrize("path", BUNDLED, ids=[p.stem for p in BUNDLED])
def test_every_bundled_map_is_in_the_new_form_and_compiles_the_same_in_the_old(path: Path, tmp_path: Path) -> None:
    """The migration changed no number: each bundled map, written back in the old form, compiles to
    the very same model; the new form reads without a warning, the old one warns per old key."""
    new_warnings: list[str] = []
    new = load_map(path, on_warning=new_warnings.append)
    assert not [w for w in new_warnings if "old form" in w]
    data = yaml.safe_load(path.read_text(encoding="utf-8"))
    old_data = _old_form(data, path.parent)
    old_path = tmp_path / path.name
    old_path.write_text(yaml.safe_dump(old_data, sort_keys=False), encoding="utf-8")
    old_warnings: list[str] = []
    old = load_map(old_path, on_warning=old_warnings.append)
    _same_model(compile_model(new), compile_model(old))
    angle_keys = sum(
        1 for s in data.get("sensors", {}).values() for new_key in OLD_KEYS.get(s["type"], {}).values() if new_key in s
    )
    with_units = sum(
        1 for a in data.get("annotations", []) for v in a.values() if isinstance(v, dict) and v and "deg" in str(v)
    )
    assert len([w for w in old_warnings if "old form" in w]) == angle_keys + with_units


OLD_CORRIDORS = """\
name: hand_edited
grid: {rows: 3, cols: 4, cell_size: 1.0, headings: 4}
layout: |
  ####
  #..#
  ####
actions:
  forward: {cost: 1}
  rotate_cw: {cost: 1}      # +90 degrees
sensors:
  range:
    type: scan
    beams: [-90, 0, 90]     # left, ahead, right
    bins: [0.5, 1.5]
  look:
    type: look
    classes: [door]
    fov: 60                 # degrees
    angle_bins: [10, 30]
landmarks:
  - {class: door, cell: [1, 2]}
annotations:
  - {state: "1,1,1", look: {door: 12.5}}   # measured
"""

NEW_CORRIDORS = """\
name: hand_edited
grid: {rows: 3, cols: 4, cell_size: 1.0, headings: 4}
layout: |
  ####
  #..#
  ####
actions:
  forward: {cost: 1}
  rotate_cw: {cost: 1}
sensors:
  range:
    type: scan
    beams_deg: [90, 0, -90]
    bins: [0.5, 1.5]
  look:
    type: look
    classes: [door]
    fov_deg: 60
    angle_bins_deg: [10, 30]
landmarks:
  - {class: door, cell: [1, 2]}
annotations:
  - {state: "1,1,1", look: {door: 12.5deg}}
"""


def test_a_hand_edited_old_form_file_reads_as_before_with_its_lines_in_the_new_form(tmp_path: Path) -> None:
    old_path, new_path = tmp_path / "old.yaml", tmp_path / "new.yaml"
    old_path.write_text(OLD_CORRIDORS, encoding="utf-8")
    new_path.write_text(NEW_CORRIDORS, encoding="utf-8")
    warnings: list[str] = []
    old = load_map(old_path, on_warning=warnings.append)
    new_warnings: list[str] = []
    new = load_map(new_path, on_warning=new_warnings.append)
    assert new_warnings == []
    _same_model(compile_model(old), compile_model(new))
    assert old.sensors["range"].beams == [90.0, 0.0, -90.0]  # counter-clockwise inside, as on the wire
    assert len(warnings) == 4
    beams, fov, bins, viewing = warnings
    assert beams.startswith(f"{old_path}:13:5: sensors.range.beams: beams in degrees clockwise")
    assert "write line 13 as `beams_deg: [90, 0, -90]     # left, ahead, right`" in beams
    assert fov.startswith(f"{old_path}:18:5: sensors.look.fov: ") and "`fov_deg: 60                 # degrees`" in fov
    assert bins.startswith(f"{old_path}:19:5: sensors.look.angle_bins: ") and "`angle_bins_deg: [10, 30]`" in bins
    assert viewing.startswith(f"{old_path}:23:22: annotations[0].look: ")
    assert '`- {state: "1,1,1", look: {door: 12.5deg}}   # measured`' in viewing
    assert all("\n" not in w for w in warnings)  # one paragraph each


def test_the_validate_command_prints_the_warning_and_succeeds(runner: CliRunner, tmp_path: Path) -> None:
    path = tmp_path / "old.yaml"
    path.write_text(OLD_CORRIDORS, encoding="utf-8")
    result = runner.invoke(app, ["validate", str(path)])
    assert result.exit_code == 0, result.output
    assert "beams_deg: [90, 0, -90]" in result.output and "old form" in result.output


def test_the_wire_and_the_observation_names_follow_the_new_convention() -> None:
    smap = load_map(MAPS / "corridors.yaml")
    model = compile_model(smap)
    forward = model.action("forward")
    assert [p.name for p in forward.observation.parts] == ["range@90", "range@0", "range@-90"]  # left first
    (scan,) = ReadingBinner(smap, model).describe("forward")
    assert scan["beams"] == pytest.approx([math.pi / 2, 0.0, -math.pi / 2])
    # a wall close on the left only: the left beam (90, counter-clockwise) reads it
    left = forward.observation.index("wall_0-0.5@90+no_wall@0+no_wall@-90")
    assert ReadingBinner(smap, model).observation(forward, {"range": [0.3, None, None]}) == left


def test_old_and_new_key_together_is_an_error_at_the_old_key(tmp_path: Path) -> None:
    path = tmp_path / "both.yaml"
    path.write_text(NEW_CORRIDORS.replace("    fov_deg: 60\n", "    fov_deg: 60\n    fov: 60\n"), encoding="utf-8")
    with pytest.raises(
        MapError, match=r"both.yaml:19:\d+: sensors.look.fov: give fov_deg \(the new form\) or the old fov"
    ):
        load_map(path)


def test_an_old_form_value_that_is_wrong_is_refused_at_its_own_line(tmp_path: Path) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(OLD_CORRIDORS.replace("beams: [-90, 0, 90]", "beams: [-90, 0, 45]"), encoding="utf-8")
    with pytest.raises(MapError, match=r"bad.yaml:13:\d+: sensors.range.beams\[2\]: a beam at -45 degrees"):
        load_map(path)


def test_a_model_built_in_code_from_old_keys_reads_them_as_before() -> None:
    data = yaml.safe_load(OLD_CORRIDORS)
    old_forms: list[Any] = []
    smap = SemanticMap.model_validate(data, context={"old_forms": old_forms})
    assert smap.sensors["range"].beams == [90.0, 0.0, -90.0]
    assert [o.key for o in old_forms] == ["beams", "fov", "angle_bins", "look"]


# --- likely unit mistakes: warnings, not errors ---------------------------------------------------------


def _warnings(tmp_path: Path, text: str) -> list[str]:
    path = tmp_path / "units.yaml"
    path.write_text(text, encoding="utf-8")
    found: list[str] = []
    load_map(path, on_warning=found.append)
    return found


def test_degrees_that_look_like_radians_warn(tmp_path: Path) -> None:
    text = (
        NEW_CORRIDORS.replace("fov_deg: 60", "fov_deg: 1.57")
        .replace("angle_bins_deg: [10, 30]", "angle_bins_deg: [0.3, 0.8]")
        .replace("door: 12.5deg", "door: 0.2deg")
    )
    found = _warnings(tmp_path, text)
    assert any(
        re.search(
            r"units.yaml:18:\d+: sensors.look.fov_deg: a field of view of 1.57 degrees looks like radians "
            r"\(89.95 degrees\)",
            w,
        )
        for w in found
    ), found
    assert any("sensors.look.angle_bins_deg: [0.3, 0.8] look like radians" in w for w in found), found


def test_a_beam_in_radians_is_an_error_that_says_so(tmp_path: Path) -> None:
    path = tmp_path / "rad.yaml"
    path.write_text(NEW_CORRIDORS.replace("beams_deg: [90, 0, -90]", "beams_deg: [1.5708, 0]"), encoding="utf-8")
    with pytest.raises(MapError, match=r"falls between headings.*looks like radians: beams_deg is in degrees"):
        load_map(path)


def test_an_origin_yaw_in_degrees_and_a_cell_larger_than_the_map_warn(tmp_path: Path) -> None:
    source = MAPS / "occupancy" / "tb3_sandbox.yaml"
    occupancy = yaml.safe_load(source.read_text(encoding="utf-8"))
    occupancy["origin"] = [-10.0, -10.0, 90]
    occupancy["image"] = str((source.parent / occupancy["image"]).resolve())
    (tmp_path / "yawed.yaml").write_text(yaml.safe_dump(occupancy), encoding="utf-8")
    overlay = (
        "name: yawed\noccupancy: yawed.yaml\ngrid: {cell_size: 0.25, headings: 8}\n"
        "actions: {forward: {}, rotate_cw: {}}\nsensors: {scan: {type: scan, bins: [1.0]}}\n"
    )
    found = _warnings(tmp_path, overlay)
    assert any("occupancy: the origin yaw of yawed.yaml is 90, which looks like degrees" in w for w in found), found
    path = tmp_path / "huge.yaml"
    path.write_text(overlay.replace("cell_size: 0.25", "cell_size: 25"), encoding="utf-8")
    huge: list[str] = []
    with pytest.raises(MapError):  # one cell over the whole map: no state; the warning says why
        load_map(path, on_warning=huge.append)
    assert any(
        "grid.cell_size: a cell of 25 m is larger than the occupancy map (19.2 m x 19.2 m)" in w for w in huge
    ), huge
