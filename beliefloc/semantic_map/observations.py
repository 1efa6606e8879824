"""The observations a map's model will have, worked out from the map alone, before any geometry.

Validation (:meth:`SemanticMap._check <beliefloc.semantic_map.schema.SemanticMap>`) uses this module
twice:

* **Sizes.** An action's observations are the joint readings of its parts (a Look has a part per
  class, so ``2^k`` observations for ``k`` classes; a Scan a part per beam; every move observes the
  parts of all passive sensors together). The model's size is its states times the observations of
  all its actions, plus the tables of reading probabilities (``n × n`` for a part of ``n``
  readings); it is checked against :data:`beliefloc.source.limits.MODEL_ENTRIES` before anything is
  allocated.
* **Names.** The name of a joint observation joins its parts' readings with ``+`` in part order,
  leaving out the silent ones (Look's "not seen"), or is ``nothing`` when every part is silent
  (:meth:`beliefloc.model.ObservationModel.name`). Two different readings must never print the
  same name: :func:`check_names` finds any pair that would, exactly.

:mod:`beliefloc.semantic_map.compile` names the readings with the same functions
(:func:`look_values`, :func:`scan_values`), so what is checked here is what is built.

Pure Python on strings and counts: no numpy, no geometry.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

from beliefloc.errors import FieldError, Path
from beliefloc.model import NOTHING
from beliefloc.source.limits import MAP_STATES, MODEL_ENTRIES, Limit


def label(value: float) -> str:
    """A number as it appears in an observation name: ``0.2``, ``18``, ``1e+06``."""
    return f"{value:g}" if math.isfinite(value) else "inf"


def look_values(cls: str, angle_bins: Sequence[float] | None) -> tuple[tuple[str, ...], dict[str, int]]:
    """The readings of a Look's part for class ``cls`` (the first, ``""``, is "not seen") and the
    other spellings the command line accepts (``door_seen``, ``door_not_seen``)."""
    if not angle_bins:
        return ("", cls), {f"{cls}_seen": 1, f"{cls}_not_seen": 0}
    edges = [0.0, *angle_bins]
    values = ("", *(f"{cls}@{label(lo)}-{label(hi)}" for lo, hi in itertools.pairwise(edges)))
    return values, {f"{cls}_not_seen": 0}


def same_label(edges: Sequence[float]) -> int | None:
    """The first ``k`` whose edge ``edges[k]`` prints as the one before it (``0`` before the first):
    bins that close would read ``wall_0.2-0.2``. None when every edge prints apart."""
    previous = label(0.0)
    for k, edge in enumerate(edges):
        if label(edge) == previous:
            return k
        previous = label(edge)
    return None


def scan_values(bins: Sequence[float], beam: str | None = None) -> tuple[str, ...]:
    """The readings of a Scan beam: ``wall_0-0.2``, ..., ``no_wall``; with ``beam`` (a multi-beam
    scan's angle in degrees counter-clockwise, ``90`` for the left beam) each is suffixed ``@90``."""
    edges = [0.0, *bins]
    names = [*(f"wall_{label(lo)}-{label(hi)}" for lo, hi in itertools.pairwise(edges)), "no_wall"]
    return tuple(names if beam is None else (f"{name}@{beam}" for name in names))


@dataclass(frozen=True)
class PartSpec:
    """One independent part of a sensor's observations, as :class:`~beliefloc.model.ObservationPart`
    will have it, with where in the map file it comes from."""

    name: str
    """``look.door``, ``scan``, ``scan@90``, ``here``."""
    values: tuple[str, ...]
    """The readings' names; ``""`` is a silent reading (left out of joint names)."""
    aliases: Mapping[str, int]
    where: Path
    """The field that makes this part: a Look's class, a Scan's bins or beam, a Here sensor."""
    value_where: Callable[[int], Path]
    """The field that names reading ``w`` (a Scan bin's upper edge, say)."""
    sensor: str

    @property
    def n_values(self) -> int:
        return len(self.values)


@dataclass(frozen=True)
class PartGroup:
    """``count`` parts of ``n_values`` readings each, made by one field: what sizes are counted
    from, without naming a reading (a Look of 40 classes is one group, not 40 parts)."""

    name: str
    n_values: int
    count: int
    where: Path


HUGE = 2**1024
"""Counts at least this large are not worked out exactly (``2^1,000,000`` observations would take a
while to multiply): they are far beyond any limit anyway."""


@dataclass(frozen=True)
class ObservationSet:
    """The observations of one action of the model (or of every move: the passive sensors' joint
    readings): how many, and, once they are known to be few enough, their parts' names."""

    action: str
    groups: tuple[PartGroup, ...]
    where: Path
    """The field to name when this action's observations are too many."""
    explain: str = ""
    """Why it has so many, for that message: ``2^30: one for each set of its 30 classes seen``."""
    moves: tuple[str, ...] = ()
    """For the moves' observations (the passive sensors' joint readings): the actuation actions."""
    parts: tuple[PartSpec, ...] = field(default=())
    """The parts with their readings' names (for :func:`check_names`)."""

    @property
    def n_observations(self) -> int:
        """The number of joint readings, or :data:`HUGE` when it is at least that."""
        return _product(self.groups)


def _product(groups: Sequence[PartGroup]) -> int:
    if sum(g.count * math.log2(g.n_values) for g in groups if g.n_values > 1) >= 1024:
        return HUGE
    return math.prod(g.n_values**g.count for g in groups)


def check_size(n_states: int, sets: Sequence[ObservationSet], limit: Limit = MODEL_ENTRIES) -> None:
    """Raise :class:`FieldError` when the model would have more than ``limit`` entries: its states
    times the observations of every action, plus the reading-probability tables of its parts (each
    group counted once, though the passive sensors' parts are in two actions)."""
    per_action = [s.n_observations for s in sets for _ in (s.moves or (s.action,))]
    observations = sum(per_action)
    unique = list({id(g): g for s in sets for g in s.groups}.values())
    tables = sum(g.count * g.n_values**2 for g in unique)
    total = n_states * observations + tables
    if total <= limit.value:
        return
    widest = max(unique, key=lambda g: g.n_values, default=None)
    if widest is not None and widest.n_values**2 > n_states * observations:
        n = _count(widest.n_values)
        lead = f"the {n} readings of {widest.name} need a {n} × {n} table of reading probabilities"
        raise FieldError(widest.where, _too_many(limit, total, lead))
    biggest = max(sets, key=lambda s: s.n_observations, default=None)
    actions = f"{len(per_action)} action" + ("s" if len(per_action) > 1 else "")
    states = f"{n_states:,} state" + ("s" if n_states != 1 else "")
    lead = f"{states} and {_count(observations)} observations over {actions}"
    if biggest is None or biggest.n_observations == 1 or n_states * len(per_action) > limit.value:
        raise FieldError(("grid",), _too_many(limit, total, lead))
    who = ", ".join(biggest.moves) if biggest.moves else biggest.action
    detail = f"{who}: {_count(biggest.n_observations)}" + (f", {biggest.explain}" if biggest.explain else "")
    raise FieldError(biggest.where, _too_many(limit, total, f"{lead} ({detail})"))


def check_grid(
    rows: int, cols: int, headings: int, where: Path, limit: Limit = MODEL_ENTRIES, *, states: bool = True
) -> None:
    """Raise :class:`FieldError` when a grid has room for more states than ``limit`` allows, or more
    cells × headings than :data:`~beliefloc.source.limits.MAP_STATES` (checked before its cells are
    laid out; an occupancy map's grid, whose cells are laid over the pixels; ``states`` False: not the
    latter, which a plain grid checks on its free cells, :func:`check_states`)."""
    upper = rows * cols * headings
    turns = f" with {headings} headings" if headings > 1 else ""
    if upper > limit.value:
        lead = f"a {rows:,} × {cols:,} grid{turns} has room for {upper:,} states, each with an observation"
        raise FieldError(where, _too_many(limit, upper, lead))
    if states:
        check_states(upper, f"a {rows:,} × {cols:,} grid{turns}", where)


def check_states(count: int, lead: str, where: Path) -> None:
    """Raise :class:`FieldError` when a map has more states (or room for more: cells × headings)
    than :data:`~beliefloc.source.limits.MAP_STATES`."""
    if count > MAP_STATES.value:
        raise FieldError(where, _too_many(MAP_STATES, count, lead))


def _too_many(limit: Limit, count: int, lead: str) -> str:
    return (
        f"{lead}: {_count(count)} {limit.what} is more than the limit of {limit.value:,}; "
        f"if the input is what you meant, raise it with the environment variable {limit.variable}=N"
    )


def _count(n: int) -> str:
    """``1,234`` for a count that prints, ``about 10^40`` for one that does not."""
    if n < 10**18:
        return f"{n:,}"
    if n >= HUGE:
        return "more than 10^308"
    return f"about 10^{int((n.bit_length() - 1) * math.log10(2))}"


def check_names(observations: ObservationSet) -> None:
    """Raise :class:`FieldError` when two different readings of one action would have the same
    name, naming the field that makes the later of the two."""
    parts = observations.parts
    whose = f"every move ({observations.explain})" if observations.moves else observations.action
    for part in parts:  # within a part: two readings of one name
        first: dict[str, int] = {}
        for w, value in enumerate(part.values):
            if value in first:
                raise FieldError(
                    part.value_where(w),
                    f"two readings of {part.name} would both be named {value!r}: {_why_same(value)}",
                )
            first[value] = w
    if parts and all("" in p.values for p in parts):  # the reading of nothing at all is "nothing"
        for part in parts:
            if NOTHING in part.values:
                raise FieldError(
                    part.value_where(part.values.index(NOTHING)),
                    f"{NOTHING!r} is the observation of {whose} when nothing is seen; name the class otherwise",
                )
    clash = _ambiguous(parts)
    if clash is not None:
        first_reading, second_reading = clash
        name = _joint_name(parts, first_reading)
        differ = [p for p in range(len(parts)) if first_reading[p] != second_reading[p]]
        blame = parts[differ[-1]]

        def what(reading: list[int]) -> str:
            said = [(parts[p].name, parts[p].values[reading[p]]) for p in differ]
            return ", ".join(f"{name}={value}" if value else f"{name} not seen" for name, value in said)

        raise FieldError(
            blame.where,
            f"the observation {name!r} of {whose} would mean two things: {what(first_reading)}; or "
            f"{what(second_reading)}. Observation names must be unique: give the sensors different classes, "
            "or make one of them not passive",
        )
    spellings: dict[str, list[tuple[int, bool]]] = {}  # the command line's: a value or an alias
    for p, part in enumerate(parts):
        for text in (v for v in part.values if v):
            spellings.setdefault(text, []).append((p, False))
        for text in part.aliases:
            spellings.setdefault(text, []).append((p, True))
    for text, users in spellings.items():
        owners = sorted({p for p, _ in users})
        if len(owners) > 1 and any(alias for _, alias in users):
            raise FieldError(
                parts[owners[-1]].where,
                f"{text!r} would mean a reading of {parts[owners[0]].name} and one of {parts[owners[-1]].name} in "
                f"{whose}; name the classes so that neither is the other with _seen or _not_seen",
            )


def _why_same(value: str) -> str:
    if value.startswith("wall_") or "@" in value:
        return "two edges print the same (6 significant digits); space them further apart"
    return "name them differently"


def _joint_name(parts: Sequence[PartSpec], reading: Sequence[int]) -> str:
    tokens = [part.values[w] for part, w in zip(parts, reading, strict=True) if part.values[w]]
    return "+".join(tokens) if tokens else NOTHING


def _ambiguous(parts: Sequence[PartSpec]) -> tuple[list[int], list[int]] | None:
    """Two different readings (one value index per part) whose names are the same, or None.

    A joint name is the sequence of the non-silent readings, in part order (no reading contains
    ``+``). Two copies of the parts are walked side by side, each either passing a part silently or
    both emitting the same name from their current parts; the first part where they differ is
    where one copy is silent and the other is not. They collide when both reach the end. A state is
    (copy 1's part, copy 2's part, whether copy 2 still owes a reading of its part): at most
    ``2 (n+1)^2`` states, each visited once.
    """
    n = len(parts)
    silent = [part.values.index("") if "" in part.values else None for part in parts]
    index = [{v: w for w, v in enumerate(part.values) if v} for part in parts]
    State = tuple[int, int, bool]
    # a step: (next state, (part, value) chosen by copy 1 or None, (part, value) chosen by copy 2 or None)
    parent: dict[State, tuple[State | None, tuple[int, int] | None, tuple[int, int] | None]] = {}
    stack: list[State] = []
    for p in range(n):
        silent_p = silent[p]
        if silent_p is not None and len(index[p]):
            start = (p + 1, p, True)
            if start not in parent:
                parent[start] = (None, (p, silent_p), None)
                stack.append(start)
    end: State | None = None
    while stack:
        state = stack.pop()
        i, j, owes = state
        if i == n and j == n and not owes:
            end = state
            break
        steps: list[tuple[State, tuple[int, int] | None, tuple[int, int] | None]] = []
        silent_i = silent[i] if i < n else None
        silent_j = silent[j] if j < n else None
        if silent_i is not None:
            steps.append(((i + 1, j, owes), (i, silent_i), None))
        if silent_j is not None and not owes:
            steps.append(((i, j + 1, False), None, (j, silent_j)))
        if i < n and j < n:
            small, large = (index[i], index[j]) if len(index[i]) <= len(index[j]) else (index[j], index[i])
            for value in small:
                if value in large:
                    steps.append(((i + 1, j + 1, False), (i, index[i][value]), (j, index[j][value])))
        for nxt, one, two in steps:
            if nxt not in parent:
                parent[nxt] = (state, one, two)
                stack.append(nxt)
    if end is None:
        return None
    first, second = [0] * n, [0] * n
    at: State | None = end
    while at is not None:
        previous, one, two = parent[at]
        if one is not None:
            first[one[0]] = one[1]
        if two is not None:
            second[two[0]] = two[1]
        if previous is None:  # the start: copy 1 silent at p, copy 2 owes part p (set above by its step)
            p = at[1]
            for q in range(p):  # before p the two readings agree; the silent reading stands for both
                silent_q = silent[q]
                first[q] = second[q] = 0 if silent_q is None else silent_q
        at = previous
    return first, second
