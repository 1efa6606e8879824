"""The ``scene:`` section of a domain file: what the robot's visual operators report about the regions
of interest (ROIs) of a view's image (Zhang, Sridharan & Wyatt 2015, Sec. III-B, Fig. 3: the
scene-processing SP-POMDP). Pydantic models only; the numbers are solved in
:mod:`beliefloc.object_search.scene`.

A scene model has:

* ``operators``: the visual operators (e.g. dominant colour, shape), each with a time ``cost`` and a
  ``confusion`` table ``confusion[true][reported] = P(operator reports `reported` | the ROI's true value is
  `true`)``. The operator's values are the table's rows; each row sums to 1 and names only those values.
* ``appearance``: per object class, the value each operator would see on a ROI holding an object of
  that class (every operator named). A class without its own entry looks like its nearest ancestor
  that has one; every class the domain's objects have, and the target class, must get an appearance.
* ``background``: what the operators see on a ROI that holds no object (a view of a room with no other
  objects shows only background ROIs).
* ``rois``: how many ROIs a view's image gives: the target's (when it is in view) among distractors
  drawn from the room's other objects.
* ``error_cost``: the lower-level POMDP's cost, in time units, of a wrong "target" / "not target"
  answer about one ROI (what trades operator time against reliability).
* ``prior_present``, ``present_threshold``, ``absent_threshold``, ``time_limit``: the higher-level
  POMDP's prior that the target is in the image, and its termination rule: report *present* when
  its belief that the target is in the image reaches ``present_threshold``, *absent* when it falls to
  ``absent_threshold``, else, when every ROI is processed or ``time_limit`` is spent, the likelier.

Cross-references (classes, operators, values) are checked by :meth:`SceneSection.check`, which the
domain calls with its class hierarchy, so that an error names the line of the culprit.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field

from beliefloc.errors import FieldError

Name = Annotated[str, Field(pattern=r"^[a-z][a-z0-9_]*$", max_length=64)]
Probability = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=0.0, le=1.0)]
Time = Annotated[float, Field(strict=True, allow_inf_nan=False, gt=0.0, le=1e6)]
ROW_TOLERANCE = 1e-6
"""How far a confusion row's sum may be from 1."""
MAX_ROIS = 32
MAX_OPERATORS = 8
MAX_VALUES = 32
MAX_LL_BELIEFS = 100_000
"""The most beliefs the lower level's exact solution may visit, ``Π_k (1 + values of operator k)``:
every subset of operators with every combination of their reports (three operators of four values: 125)."""


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class OperatorSection(_Strict):
    """One visual operator: its time and its confusion table."""

    cost: Time
    """Time units to apply the operator to one region of interest (ROI)."""
    confusion: Annotated[dict[Name, dict[Name, Probability]], Field(min_length=2, max_length=MAX_VALUES)]
    """true value: {reported value: probability}. The rows are the operator's values; each row sums to 1,
    and a value left out of a row has probability 0."""

    @property
    def values(self) -> tuple[str, ...]:
        """The operator's values, in the order of the table's rows."""
        return tuple(self.confusion)


class SceneSection(_Strict):
    """The scene model of object search: visual operators, what each class looks like, ROIs per view
    (docs/domain-format.md, Scene model)."""

    rois: Annotated[int, Field(strict=True, ge=1, le=MAX_ROIS)] = 4
    """Regions of interest per view: the target's (when in view) among distractors from the room's objects."""
    operators: Annotated[dict[Name, OperatorSection], Field(min_length=1, max_length=MAX_OPERATORS)]
    """The visual operators, by name: each with a time cost and a confusion table."""
    appearance: dict[Name, dict[Name, Name]]
    """class: {operator: value}, what every operator sees on a ROI holding an object of the class; a class
    without an entry looks like its nearest ancestor with one."""
    background: dict[Name, Name]
    """operator: value, what every operator sees on a ROI holding no object."""
    error_cost: Time = 10.0
    """The lower level's cost, in time units, of a wrong target / not-target answer about one ROI."""
    prior_present: Annotated[Probability, Field(gt=0.0, lt=1.0)] = 0.5
    """The higher level's prior that the target is in the image."""
    present_threshold: Annotated[Probability, Field(gt=0.0, lt=1.0)] = 0.8
    """Report present when the belief that the target is in the image reaches this."""
    absent_threshold: Annotated[Probability, Field(gt=0.0, lt=1.0)] = 0.2
    """Report absent when the belief that the target is in the image falls to this."""
    time_limit: Time = 5.0
    """Time units the higher level may spend on one view's image; then it reports the likelier answer."""

    def check(self, classes: dict[str, str | None], needed: dict[str, tuple[str | int, ...]]) -> None:
        """Cross-references, against the domain's class hierarchy (class -> parent). ``needed``: every
        class that must look like something, with the path of what needs it (an object's class, the
        target). Raises :class:`FieldError` at the culprit."""
        if self.absent_threshold >= self.present_threshold:
            raise FieldError(
                ("scene", "absent_threshold"),
                f"must be below present_threshold ({self.present_threshold:g}), got {self.absent_threshold:g}",
            )
        beliefs = math.prod(1 + len(op.confusion) for op in self.operators.values())
        if beliefs > MAX_LL_BELIEFS:
            raise FieldError(
                ("scene", "operators"),
                f"too many operators and values to plan over exactly: {beliefs:,} beliefs of one ROI (the product "
                f"of 1 + each operator's values), at most {MAX_LL_BELIEFS:,}; use fewer operators or values",
            )
        for name, op in self.operators.items():
            values = op.values
            for true, row in op.confusion.items():
                where: tuple[str | int, ...] = ("scene", "operators", name, "confusion", true)
                for reported in row:
                    if reported not in values:
                        raise FieldError(
                            (*where, reported),
                            f"unknown value {reported!r} of operator {name!r}; its values are its table's rows: "
                            + ", ".join(values),
                        )
                total = math.fsum(row.values())
                if abs(total - 1.0) > ROW_TOLERANCE:
                    raise FieldError(where, f"a confusion row must sum to 1, got {total:.6g}")
        for cls, seen in self.appearance.items():
            if cls not in classes:
                raise FieldError(("scene", "appearance", cls), f"unknown class {cls!r}{_hint(classes)}")
            self._check_look(seen, ("scene", "appearance", cls))
        self._check_look(self.background, ("scene", "background"))
        for cls, path in needed.items():
            if self.look_of(cls, classes) is None:
                raise FieldError(
                    ("scene", "appearance"),
                    f"class {cls!r} (at {_dotted(path)}) has no appearance: give it, or one of its ancestors, "
                    "an entry under scene.appearance",
                )

    def _check_look(self, seen: dict[str, str], where: tuple[str | int, ...]) -> None:
        for op, value in seen.items():
            if op not in self.operators:
                raise FieldError((*where, op), f"unknown operator {op!r}{_hint(self.operators)}")
            values = self.operators[op].values
            if value not in values:
                raise FieldError(
                    (*where, op), f"unknown value {value!r} of operator {op!r}; expected one of: {', '.join(values)}"
                )
        missing = [op for op in self.operators if op not in seen]
        if missing:
            raise FieldError(where, f"say what every operator sees; missing: {', '.join(missing)}")

    def look_of(self, cls: str, classes: dict[str, str | None]) -> dict[str, str] | None:
        """The appearance of class ``cls``: its own entry, else its nearest ancestor's (None: none has one)."""
        current: str | None = cls
        seen: set[str] = set()
        while current is not None and current not in seen:
            if current in self.appearance:
                return self.appearance[current]
            seen.add(current)
            current = classes.get(current)
        return None


def _hint(known: Mapping[str, object]) -> str:
    options = sorted(known)
    return "; expected one of: " + ", ".join(options[:12]) + (", ..." if len(options) > 12 else "")


def _dotted(path: tuple[str | int, ...]) -> str:
    return ".".join(str(p) for p in path)
