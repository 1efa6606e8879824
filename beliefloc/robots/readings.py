"""Raw sensor readings -> observations: what a real robot measured, binned into the observation of
an action of a compiled map, exactly as :mod:`beliefloc.semantic_map.compile` bins the map's own
geometry. Pure functions of the map's sensor specifications; no I/O.

A raw reading, per sensor type (the JSON values of ``beliefloc localize``'s protocol,
``docs/localize-protocol.md``):

* **scan** -- a range in metres per beam, in the order of the sensor's ``beams`` (a one-beam scan
  may give the number alone). A range ``d`` falls in bin ``k`` when ``bins[k-1] < d <= bins[k]``
  (``bins[-1] = 0``), with compile.py's tolerance: the bin is ``bisect_left(bins, d - 1e-9)``.
  Beyond the last edge, ``null`` or ``Infinity`` is ``no_wall``. A negative range, NaN, a boolean
  or a string is refused. Or **a whole scan** (issue 27), ``sensor_msgs/LaserScan``'s numbers:
  ``{"angle_min", "angle_increment", "ranges", "range_min", "range_max"}`` (radians
  counter-clockwise from the heading, REP 103; metres, ``null`` for no return, REP 117), at most
  :data:`MAX_SCAN_BEAMS` ranges (:func:`parse_full_scan`), and optionally the laser's pose on the
  base, ``"mount": [x, y, yaw]`` (:data:`SCAN_MOUNT`; else the base's centre). Its beams at the
  sensor's angles are binned as above (the nearest ray,
  :func:`beliefloc.ros.sensors.beam_ranges`'s selection), and :meth:`ReadingBinner.full_scans`
  keeps the whole scan for a filter that scores it in full.
* **look** -- the classes detected, a list of class names (a class listed twice counts once). A
  sensor with ``angle_bins`` needs the viewing angle of each: ``{class: angle}`` in radians (its
  sign does not matter), binned like the range of a scan by ``bisect_left(angle_bins, |angle|° -
  1e-9)``; an angle beyond the last edge is outside the sensor's field of view and counts as not
  seen. A class the sensor does not look for is refused.
* **here** -- the class of the robot's cell, one of the sensor's classes.

A perception action reads its own sensor; an actuation action reads the map's passive sensors, in
the map's order. :class:`ReadingBinner` joins their parts into the action's observation index.
"""

from __future__ import annotations

import bisect
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from beliefloc.errors import InvalidValueError, ModelError
from beliefloc.model import Action, Model
from beliefloc.semantic_map.schema import SemanticMap, here_classes
from beliefloc.semantic_map.sections import HereSensor, LookSensor, ScanSensor, Sensor

if TYPE_CHECKING:
    from beliefloc.continuous.likelihood_field import Scan

MAX_SCAN_BEAMS = 10_000
"""The most ranges a whole-scan reading may carry (a 2-D lidar gives a few hundred to a few
thousand; more is taken for a malformed reply rather than read)."""
SCAN_FIELDS = ("angle_min", "angle_increment", "ranges", "range_min", "range_max")
"""The keys of a whole-scan reading, ``sensor_msgs/LaserScan``'s names."""
SCAN_MOUNT = "mount"
"""A whole scan's optional field: the laser's pose on the base, ``[x, y, yaw]`` (metres, radians,
REP 103), as the ROS link knows it; without it the ranges are from the base's centre and the angles
from its heading."""

EDGE_TOLERANCE = 1e-9
"""A value within this of a bin's upper edge is in that bin (compile.py's ``- 1e-9``)."""

RawReading = Any
"""A sensor's raw reading as decoded from JSON: numbers, ``None``, strings, lists, dicts."""


@dataclass(frozen=True)
class SensorSlot:
    """One sensor an action reads, and where its parts sit in the action's observation model."""

    name: str
    sensor: Sensor
    classes: tuple[str, ...]
    """The classes a look or here sensor reports (empty for a scan)."""
    first_part: int
    n_parts: int

    def part_names(self) -> list[str]:
        """The names compile.py gives the sensor's observation parts."""
        sensor = self.sensor
        if isinstance(sensor, LookSensor):
            return [f"{self.name}.{cls}" for cls in sensor.classes]
        if isinstance(sensor, ScanSensor):
            return [f"{self.name}@{angle:g}" for angle in sensor.beams] if sensor.multi_beam else [self.name]
        return [self.name]

    def value_counts(self) -> list[int]:
        """How many readings each part has, as compile.py builds it."""
        sensor = self.sensor
        if isinstance(sensor, LookSensor):
            return [1 + (len(sensor.angle_bins) if sensor.angle_bins else 1)] * len(sensor.classes)
        if isinstance(sensor, ScanSensor):
            return [len(sensor.bins) + 1] * len(sensor.beams)
        return [len(self.classes)]


def scan_bin(bins: Sequence[float], distance: float) -> int:
    """The bin of a range in metres: ``k`` with ``bins[k-1] < d <= bins[k]`` (1e-9 tolerance),
    ``len(bins)`` (``no_wall``) beyond the last edge or for ``inf``."""
    return bisect.bisect_left(bins, distance - EDGE_TOLERANCE)


def angle_bin(angle_bins: Sequence[float], degrees: float) -> int | None:
    """The part reading of a class seen at ``degrees`` off the heading: ``1 + k`` for bin ``k`` of
    ``angle_bins`` (degrees, upper edges); None beyond the last edge (not in view)."""
    k = bisect.bisect_left(angle_bins, abs(degrees) - EDGE_TOLERANCE)
    return None if k >= len(angle_bins) else 1 + k


class ReadingBinner:
    """Bins raw readings into observation indices for the actions of ``model``, compiled from
    ``smap`` (or from the same file: a model built by ``beliefloc build``).

    Raises :class:`ModelError` when the model's observation parts are not the ones the map's
    sensors give (a model compiled from another map).
    """

    def __init__(self, smap: SemanticMap, model: Model) -> None:
        self.smap = smap
        self.model = model
        self._slots: dict[str, tuple[SensorSlot, ...]] = {}
        for action in model.actions:
            slots = self._sensors_of(action)
            names = [n for slot in slots for n in slot.part_names()]
            counts = [c for slot in slots for c in slot.value_counts()]
            parts = action.observation.parts
            if names != [p.name for p in parts] or counts != [p.n_values for p in parts]:
                raise ModelError(
                    f"model {model.name!r} does not match map {smap.name!r}: action {action.name!r} observes "
                    f"{[p.name for p in parts]}, the map's sensors give {names}; use a model compiled from this map"
                )
            self._slots[action.name] = slots

    def _sensors_of(self, action: Action) -> tuple[SensorSlot, ...]:
        sensors = self.smap.sensors
        if action.is_actuation:
            if action.name not in self.smap.actions:
                raise ModelError(
                    f"model {self.model.name!r} has action {action.name!r}, which map {self.smap.name!r} has not"
                )
            chosen = [(name, s) for name, s in sensors.items() if s.passive]
        else:
            if action.name not in sensors:
                raise ModelError(
                    f"model {self.model.name!r} has sensor {action.name!r}, which map {self.smap.name!r} has not"
                )
            chosen = [(action.name, sensors[action.name])]
        slots = []
        first = 0
        for name, sensor in chosen:
            classes: tuple[str, ...] = ()
            if isinstance(sensor, LookSensor):
                classes, n_parts = tuple(sensor.classes), len(sensor.classes)
            elif isinstance(sensor, ScanSensor):
                n_parts = len(sensor.beams)
            else:
                classes, n_parts = tuple(here_classes(sensor, self.smap)), 1
            slots.append(SensorSlot(name, sensor, classes, first, n_parts))
            first += n_parts
        return tuple(slots)

    def sensors(self, action: str | Action) -> tuple[SensorSlot, ...]:
        """The sensors ``action`` reads: its own for a perception action, the passive ones for an
        actuation action (none when the map has none)."""
        name = action if isinstance(action, str) else action.name
        self.model.action(name)  # an unknown action is an InvalidValueError listing the actions
        return self._slots[name]

    def observation(self, action: str | Action, readings: Mapping[str, RawReading]) -> int | None:
        """The observation index of ``readings`` (sensor name -> raw reading) after ``action``;
        None when the action reads no sensor (then ``readings`` must be empty).

        Raises :class:`InvalidValueError` naming the sensor for a missing or unexpected sensor and
        for a reading of the wrong shape or type, a NaN or a class the sensor does not know.
        """
        act = self.model.action(action) if isinstance(action, str) else action
        slots = self.sensors(act)
        expected = [slot.name for slot in slots]
        form = f", e.g. readings {json.dumps(self.example(act, 0))}" if slots else ""  # what a reply looks like
        extra = [name for name in readings if name not in expected]
        if extra:
            reads = f"reads only {', '.join(expected)}" if expected else "reads no sensor"
            raise InvalidValueError(f"unexpected reading of {', '.join(map(repr, extra))}: {act.name!r} {reads}{form}")
        missing = [name for name in expected if name not in readings]
        if missing:
            raise InvalidValueError(
                f"no reading of {', '.join(map(repr, missing))}: {act.name!r} reads {', '.join(expected)}{form}"
            )
        if not slots:
            return None
        digits: list[int] = []
        for slot in slots:
            try:
                digits.extend(_bin(slot, readings[slot.name]))
            except InvalidValueError as exc:
                raise InvalidValueError(f"{slot.name}: {exc}") from None
        return act.observation.encode(digits)

    def full_scans(
        self, action: str | Action, readings: Mapping[str, RawReading]
    ) -> dict[str, tuple[Scan, tuple[float, float, float]]]:
        """The whole scans among ``readings`` of ``action``'s scan sensors (sensor name -> the scan
        and the laser's mount on the base, :data:`SCAN_MOUNT`; the sensors read beam by beam are not
        in it). Raises :class:`InvalidValueError` naming the sensor and field for a malformed one (as
        :meth:`observation` does)."""
        out: dict[str, tuple[Scan, tuple[float, float, float]]] = {}
        for slot in self.sensors(action):
            raw = readings.get(slot.name)
            if isinstance(slot.sensor, ScanSensor) and isinstance(raw, Mapping):
                try:
                    out[slot.name] = (parse_full_scan(raw), parse_scan_mount(raw))
                except InvalidValueError as exc:
                    raise InvalidValueError(f"{slot.name}: {exc}") from None
        return out

    def example(self, action: str | Action, observation: int | None) -> dict[str, RawReading]:
        """Raw readings that :meth:`observation` bins to ``observation``: the middle of each range or
        angle bin, ``None`` for ``no_wall``. (What the protocol sends as the expected reading, and
        how a simulated robot answers.)"""
        act = self.model.action(action) if isinstance(action, str) else action
        slots = self.sensors(act)
        if not slots or observation is None:
            return {}
        digits = act.observation.decode(observation)
        return {slot.name: _example(slot, digits[slot.first_part : slot.first_part + slot.n_parts]) for slot in slots}

    def describe(self, action: str | Action) -> list[dict[str, Any]]:
        """What the robot side needs to read the sensors of ``action``, as plain data. Angles are in
        radians, counter-clockwise from the heading (ROS REP 103: positive is to the left)."""
        return [self._describe(slot) for slot in self.sensors(action)]

    def _describe(self, slot: SensorSlot) -> dict[str, Any]:
        sensor = slot.sensor
        data: dict[str, Any] = {"name": slot.name, "type": sensor.type}
        if isinstance(sensor, ScanSensor):
            data["beams"] = [0.0 + math.radians(b) for b in sensor.beams]  # counter-clockwise, as the map's; no -0.0
            data["bins"] = list(sensor.bins)
        elif isinstance(sensor, LookSensor):
            data["classes"] = list(slot.classes)
            data["angle_bins"] = None if sensor.angle_bins is None else [math.radians(a) for a in sensor.angle_bins]
            data["fov"] = math.radians(sensor.effective_fov(self.smap.grid.headings))
            data["range"] = sensor.range
        else:
            data["classes"] = list(slot.classes)
        return data


def _bin(slot: SensorSlot, raw: RawReading) -> list[int]:
    """The reading of each of the sensor's parts."""
    sensor = slot.sensor
    if isinstance(sensor, ScanSensor):
        return _bin_scan(sensor, raw)
    if isinstance(sensor, LookSensor):
        return _bin_look(sensor, raw)
    return [_bin_here(sensor, slot.classes, raw)]


def parse_full_scan(raw: Mapping[str, Any]) -> Scan:
    """A whole-scan reading (see the module) as a :class:`~beliefloc.continuous.likelihood_field.Scan`
    (``null`` ranges as ``+inf``). Raises :class:`InvalidValueError` naming the field that is missing,
    unknown or not a usable value."""
    from beliefloc.continuous.likelihood_field import Scan

    unknown = [key for key in raw if key not in SCAN_FIELDS and key != SCAN_MOUNT]
    if unknown:
        raise InvalidValueError(
            f"a whole scan has no field {', '.join(map(repr, unknown))}: give {', '.join(SCAN_FIELDS)} "
            f"(and optionally {SCAN_MOUNT!r})"
        )
    missing = [key for key in SCAN_FIELDS if key not in raw]
    if missing:
        raise InvalidValueError(f"a whole scan needs {', '.join(map(repr, missing))} (of {', '.join(SCAN_FIELDS)})")
    numbers: dict[str, float] = {}
    for key in ("angle_min", "angle_increment", "range_min", "range_max"):
        value = raw[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            unit = "radians" if key.startswith("angle") else "metres"
            raise InvalidValueError(f"'{key}' should be a finite number of {unit}, got {_show(value)}")
        numbers[key] = float(value)
    if numbers["angle_increment"] == 0.0:
        raise InvalidValueError("'angle_increment' is 0: the beams' angles must differ (either sign)")
    if numbers["range_min"] < 0:
        raise InvalidValueError(f"'range_min' cannot be negative, got {numbers['range_min']:g}")
    if not numbers["range_min"] < numbers["range_max"]:
        raise InvalidValueError(
            f"'range_max' ({numbers['range_max']:g}) should exceed 'range_min' ({numbers['range_min']:g})"
        )
    ranges = raw["ranges"]
    if not isinstance(ranges, list) or not ranges:
        raise InvalidValueError(
            f"'ranges' should be a non-empty list of metres or null (no return), got {_show(ranges)}"
        )
    if len(ranges) > MAX_SCAN_BEAMS:
        raise InvalidValueError(f"'ranges' has {len(ranges)} readings, more than the {MAX_SCAN_BEAMS} read")
    values: list[float | None] = []
    for k, value in enumerate(ranges):
        if value is None:
            values.append(None)
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float)) or math.isnan(value) or value < 0:
            raise InvalidValueError(
                f"'ranges[{k}]' should be a non-negative number of metres or null (no return), got {_show(value)}"
            )
        values.append(float(value))
    return Scan.from_values(
        numbers["angle_min"], numbers["angle_increment"], values, numbers["range_min"], numbers["range_max"]
    )


def parse_scan_mount(raw: Mapping[str, Any]) -> tuple[float, float, float]:
    """A whole scan's :data:`SCAN_MOUNT` (the base's centre when it has none). Raises
    :class:`InvalidValueError` naming the field when it is not three finite numbers."""
    if SCAN_MOUNT not in raw:
        return (0.0, 0.0, 0.0)
    value = raw[SCAN_MOUNT]
    if (
        not isinstance(value, list)
        or len(value) != 3
        or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)
    ):
        raise InvalidValueError(
            f"'{SCAN_MOUNT}' should be the laser's pose on the base, [x, y, yaw] in metres and radians, "
            f"got {_show(value)}"
        )
    return (float(value[0]), float(value[1]), float(value[2]))


def full_scan_ranges(
    sensor: ScanSensor, scan: Scan, mount: tuple[float, float, float] = (0.0, 0.0, 0.0)
) -> list[float | None]:
    """The ranges of ``sensor``'s beams in a whole scan taken by a laser at ``mount`` on the base:
    the nearest ray to each, from the base's centre (:func:`beliefloc.ros.sensors.beam_ranges`:
    ``null``, ``+inf`` or beyond ``range_max`` is no wall, below ``range_min`` a wall right there).
    Raises :class:`InvalidValueError` for a beam the scan does not cover."""
    from beliefloc.ros import sensors as ros

    as_ros = ros.Scan(
        "", 0, scan.angle_min, scan.angle_increment, scan.range_min, scan.range_max, tuple(scan.ranges.tolist())
    )
    beams = [math.radians(b) for b in sensor.beams]  # counter-clockwise, as describe() gives them
    for theta, degrees in zip(beams, sensor.beams, strict=True):
        if ros.beam_index(as_ros, math.remainder(theta - mount[2], 2 * math.pi)) is None:
            end = math.degrees(as_ros.angle(len(as_ros.ranges) - 1))
            raise InvalidValueError(
                f"'ranges': the sensor's beam at {degrees:g}° (counter-clockwise from the heading) is outside the "
                f"scan, which covers {math.degrees(scan.angle_min):.4g}° to {end:.4g}°"
            )
    return ros.beam_ranges(as_ros, beams, mount, "")


def _bin_scan(sensor: ScanSensor, raw: RawReading) -> list[int]:
    n = len(sensor.beams)
    if isinstance(raw, Mapping):
        raw = full_scan_ranges(sensor, parse_full_scan(raw), parse_scan_mount(raw))
    if isinstance(raw, list):
        ranges = raw
        if len(ranges) != n:
            raise InvalidValueError(f"got {len(ranges)} ranges, but the scan has {n} beam{'s' if n > 1 else ''}")
    elif n == 1:
        ranges = [raw]
    else:
        raise InvalidValueError(f"should be a list of {n} ranges in metres, one per beam, got {_show(raw)}")
    out = []
    for k, value in enumerate(ranges):
        where = f"beam {k}: " if n > 1 else ""
        if value is None:
            out.append(len(sensor.bins))
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise InvalidValueError(
                f"{where}a range should be a number of metres or null (no wall), got {_show(value)}"
            )
        if math.isnan(value):
            raise InvalidValueError(f"{where}a range should be a number of metres or null (no wall), got NaN")
        if value < 0:
            raise InvalidValueError(f"{where}a range cannot be negative, got {value:g}")
        out.append(scan_bin(sensor.bins, float(value)))
    return out


def _bin_look(sensor: LookSensor, raw: RawReading) -> list[int]:
    known = ", ".join(sensor.classes)
    if sensor.angle_bins is None:
        if not isinstance(raw, list) or not all(isinstance(c, str) for c in raw):
            raise InvalidValueError(f"should be a list of the classes detected (of {known}), got {_show(raw)}")
        seen = set(raw)
        _check_classes(seen, sensor.classes)
        return [1 if cls in seen else 0 for cls in sensor.classes]
    if not isinstance(raw, dict):
        raise InvalidValueError(
            f"this look sensor bins viewing angles: give {{class: angle in radians}} for each class detected "
            f"(of {known}), got {_show(raw)}"
        )
    _check_classes(set(raw), sensor.classes)
    bins = sensor.angle_bins
    readings = []
    for cls in sensor.classes:
        if cls not in raw:
            readings.append(0)
            continue
        angle = raw[cls]
        if isinstance(angle, bool) or not isinstance(angle, (int, float)) or not math.isfinite(angle):
            raise InvalidValueError(
                f"the viewing angle of {cls!r} should be a finite number of radians, got {_show(angle)}"
            )
        readings.append(angle_bin(bins, math.degrees(angle)) or 0)
    return readings


def _check_classes(seen: set[str], classes: Sequence[str]) -> None:
    unknown = sorted(seen - set(classes))
    if unknown:
        listed = ", ".join(map(repr, unknown))
        raise InvalidValueError(f"{listed}: not a class this sensor looks for ({', '.join(classes)})")


def _bin_here(sensor: HereSensor, classes: Sequence[str], raw: RawReading) -> int:
    if not isinstance(raw, str):
        raise InvalidValueError(
            f"should be the class of the robot's cell as a string ({', '.join(classes)}), got {_show(raw)}"
        )
    if raw not in classes:
        raise InvalidValueError(f"{raw!r} is not a class this sensor reads ({', '.join(classes)})")
    return classes.index(raw)


def _example(slot: SensorSlot, digits: Sequence[int]) -> RawReading:
    sensor = slot.sensor
    if isinstance(sensor, ScanSensor):
        edges = [0.0, *sensor.bins]
        ranges = [None if d >= len(sensor.bins) else (edges[d] + edges[d + 1]) / 2 for d in digits]
        return ranges
    if isinstance(sensor, LookSensor):
        if sensor.angle_bins is None:
            return [cls for cls, d in zip(sensor.classes, digits, strict=True) if d]
        edges = [0.0, *sensor.angle_bins]
        return {
            cls: math.radians((edges[d - 1] + edges[d]) / 2) for cls, d in zip(sensor.classes, digits, strict=True) if d
        }
    return slot.classes[digits[0]]


def _show(value: RawReading) -> str:
    """A raw value as the robot wrote it, shortened."""
    try:
        text = json.dumps(value)
    except (TypeError, ValueError):
        text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."
