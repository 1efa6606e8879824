"""Angles in map files: one convention, and the old form still read as before.

**The convention** (ROS REP 103), the same in map files, on the wire and in the docs: an angle turns
counter-clockwise, positive to the robot's left. The wire (``localize``'s protocol, ROS messages)
carries radians. A map file writes degrees, always in a key that names the unit: ``beams_deg``
(a scan's beam directions off the heading), ``fov_deg``, ``angle_bins_deg`` and ``fov_edge_deg``
(a look's field of view, viewing-angle bins and fade); a viewing angle in an annotation, whose key is
a class name, carries its unit in its value: ``{fire_extinguisher: 16.9deg}``. The occupancy map's
``origin`` yaw is radians, as map_server writes it. Heading indices are not angles: heading 0 is north
and the index counts clockwise, as the papers number them (heading ``h`` has yaw
``π/2 − h·2π/headings``).

**The old form** -- ``beams`` in degrees *clockwise* from the heading, ``fov``, ``angle_bins``,
``fov_edge`` in degrees without a unit, and bare-number viewing angles -- is read exactly as before
(the same numbers, so the same model), turned into the new form here, before validation.
:func:`new_form` says where each was written and how the line reads in the new form; the loader
warns with it (file:line, not an error).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any

from beliefloc.errors import FieldError, Path
from beliefloc.semantic_map.sections import as_number as number

OLD_KEYS: dict[str, dict[str, str]] = {
    "scan": {"beams": "beams_deg"},
    "look": {"fov": "fov_deg", "angle_bins": "angle_bins_deg", "fov_edge": "fov_edge_deg"},
}
"""Sensor type -> old key -> its new key. Only ``beams`` changes its numbers (its sign)."""

_WITH_UNIT = re.compile(r"^\s*([-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?)\s*deg\s*$")
"""A viewing angle with its unit: ``16.9deg``."""


@dataclass(frozen=True)
class OldForm:
    """An angle written in the old form: where, and what it is in the new form."""

    path: Path
    """The old key as the file wrote it (``("sensors", "scan", "beams")``)."""
    key: str
    """The key written on that line (``beams``; for an annotation, the sensor's name)."""
    new_text: str
    """The key and value in the new form: ``beams_deg: [90, 0, -90]``."""
    what: str
    """What the old form meant, for the warning."""


def shown(value: float) -> str:
    """A number as a map file would write it: ``90``, ``16.9``."""
    return str(int(value)) if value.is_integer() and abs(value) < 1e15 else repr(value)


def degrees_with_unit(value: Any) -> float | None:
    """``"16.9deg"`` -> 16.9; None when ``value`` is not a number with the unit ``deg``."""
    if not isinstance(value, str):
        return None
    match = _WITH_UNIT.match(value)
    return float(match[1]) if match and math.isfinite(float(match[1])) else None


def looks_like_radians(values: list[float]) -> bool:
    """Degrees that look like radians: every one within 2π and one of them not a whole number of
    degrees (``[0.3, 0.5, 0.8]``; ``[1, 2, 3]`` may well be degrees)."""
    return all(abs(v) <= 2 * math.pi for v in values) and any(not float(v).is_integer() for v in values)


def renamed_paths(data: Any) -> dict[Path, Path]:
    """New path -> the old path it was written at, for every old sensor key of ``data``: an error
    found on the new key then points at the line the file wrote."""
    renamed: dict[Path, Path] = {}
    for name, sensor in _sensors(data):
        for old, new in OLD_KEYS.get(str(sensor.get("type")), {}).items():
            if old in sensor and new not in sensor:
                renamed[("sensors", name, new)] = ("sensors", name, old)
    return renamed


def new_form(data: dict[str, Any]) -> tuple[dict[str, Any], list[OldForm]]:
    """``data`` with every old-form angle in the new form (a new dict; ``data`` is not changed),
    and where each old one was written. Numbers that cannot be read are moved to the new key
    unchanged, for validation to refuse (at the old key's line: :func:`renamed_paths`)."""
    found: list[OldForm] = []
    sensors = data.get("sensors")
    if isinstance(sensors, dict):
        sensors = {name: _sensor_new_form(str(name), sensor, found) for name, sensor in sensors.items()}
        data = {**data, "sensors": sensors}
    annotations = data.get("annotations")
    if isinstance(annotations, list) and isinstance(sensors, dict):
        looks = {
            name
            for name, sensor in sensors.items()
            if isinstance(sensor, dict) and sensor.get("type") == "look" and sensor.get("angle_bins_deg") is not None
        }
        data = {**data, "annotations": [_annotation_new_form(i, a, looks, found) for i, a in enumerate(annotations)]}
    return data, found


def _sensors(data: Any) -> list[tuple[str, dict[str, Any]]]:
    sensors = data.get("sensors") if isinstance(data, dict) else None
    if not isinstance(sensors, dict):
        return []
    return [(str(name), sensor) for name, sensor in sensors.items() if isinstance(sensor, dict)]


def _sensor_new_form(name: str, sensor: Any, found: list[OldForm]) -> Any:
    if not isinstance(sensor, dict):
        return sensor
    keys = OLD_KEYS.get(str(sensor.get("type")), {})
    if not any(old in sensor for old in keys):
        return sensor
    sensor = dict(sensor)
    for old, new in keys.items():
        if old not in sensor:
            continue
        path = ("sensors", name, old)
        if new in sensor:
            raise FieldError(path, f"give {new} (the new form) or the old {old}, not both")
        value = sensor.pop(old)
        converted, text, what = _convert(old, value)
        sensor[new] = converted
        if text is not None:
            found.append(OldForm(path, old, f"{new}: {text}", what))
    return sensor


def _convert(old: str, value: Any) -> tuple[Any, str | None, str]:
    """An old sensor value in the new form, how the new form writes it (None when it is not
    numbers: validation says what is wrong), and what the old form meant."""
    if old == "beams":
        what = (
            "beams in degrees clockwise from the heading is the old form; the new form, beams_deg, turns "
            "counter-clockwise (REP 103: positive is to the left), so a beam's sign changes"
        )
        numbers = [number(v) for v in value] if isinstance(value, list) else [None]
        if any(n is None for n in numbers):
            return value, None, what
        turned = [0.0 - n for n in numbers if n is not None]  # counter-clockwise; 0.0 - 0 is 0, not -0.0
        return turned, "[" + ", ".join(shown(n) for n in turned) + "]", what
    what = f"{old} in degrees without the unit in its key is the old form; the new form is {old}_deg"
    if isinstance(value, list):
        numbers = [number(v) for v in value]
        if any(n is None for n in numbers):
            return value, None, what
        return value, "[" + ", ".join(shown(n) for n in numbers if n is not None) + "]", what
    n = number(value)
    return value, None if n is None else shown(n), what


def _annotation_new_form(i: int, annotation: Any, looks: set[str], found: list[OldForm]) -> Any:
    """Viewing angles written ``16.9deg`` as numbers; a bare number (the old form) is kept and noted."""
    if not isinstance(annotation, dict):
        return annotation
    changed = dict(annotation)
    for key in looks & set(annotation):
        reading = annotation[key]
        if not isinstance(reading, dict):
            continue
        values: dict[Any, Any] = {}
        bare = False
        for cls, angle in reading.items():
            with_unit = degrees_with_unit(angle)
            if with_unit is not None:
                values[cls] = with_unit
            else:
                values[cls] = angle
                bare = bare or number(angle) is not None
        changed[key] = values
        if bare:
            text = ", ".join(
                f"{cls}: {shown(n)}deg" if (n := number(v)) is not None else f"{cls}: {v}" for cls, v in values.items()
            )
            found.append(
                OldForm(
                    ("annotations", i, key),
                    key,
                    f"{key}: {{{text}}}",
                    "a viewing angle without a unit is the old form; the new form writes it with one, like 25deg",
                )
            )
    return changed


def rewritten_line(line: str, column: int, old: OldForm) -> str | None:
    """``line`` with the old key and value at ``column`` (1-based, where the key starts) in the new
    form, keeping what comes before and after (a comment); None when the value does not end on the
    line (a block list)."""
    start = column - 1
    rest = line[start:]
    match = re.match(rf"{re.escape(old.key)}\s*:\s*(\[[^\]\n]*\]|\{{[^{{}}\n]*\}}|[^\s,#}}\]]+)", rest)
    if match is None:
        return None
    return line[:start] + old.new_text + rest[match.end() :]
