"""The header of a ``.pomdp`` file: ``states:``, ``actions:``, ``observations:``, ``discount:``,
``values:`` and ``start:``, read into a :class:`Preamble`.

The preamble is also what gives a later statement's references a meaning: :meth:`Preamble.ref`
turns a name, a number or ``*`` into an element, and :meth:`Preamble.describe` says what was
declared when a reference is wrong.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from beliefloc.errors import LimitError
from beliefloc.pomdp_format.names import IDENTIFIER, NUMBER, RESERVED, SINGULAR, TOLERANCE
from beliefloc.pomdp_format.statements import Statement, expect_colon, numbers
from beliefloc.source import limits

_MAX_SHOWN = 6
"""How many declared names a message about an unknown one lists."""


class Declared(NamedTuple):
    """The elements of one kind: their names, the line declaring them, and whether they were counted."""

    names: list[str]
    line: int
    numbered: bool


class Preamble:
    """What the header declares, filled statement by statement."""

    def __init__(self) -> None:
        self.declared: dict[str, Declared] = {}
        self.lookup: dict[str, dict[str, int]] = {}
        """kind -> name -> index"""
        self.values_cost = False
        """``values: cost``: the R: numbers are costs, not rewards."""
        self.start: np.ndarray | None = None
        """The start belief, if ``start:`` gave one (only ``reset`` uses it)."""
        self.entries = 0
        """How many table entries the T: and O: statements have given so far (see :meth:`spend`)."""

    def size(self, kind: str) -> int:
        return len(self.declared[kind].names)

    # --- references ------------------------------------------------------------------------------
    def ref(self, kind: str, st: Statement, i: int) -> int | None:
        """The element of ``kind`` named by token ``i`` (a name or a number), or None for ``*``."""
        if len(st.tokens) <= i or st.tokens[i] == ":":
            found = repr(st.tokens[i]) if len(st.tokens) > i else "the end of the statement"
            article = "an" if kind[0] in "ao" else "a"
            raise st.error(
                st.line_at(i),
                f"{st.tokens[0]}: expected {article} {SINGULAR[kind]} (a name, a number or '*'), found {found}",
            )
        token = st.tokens[i]
        index = self.lookup[kind].get(token)
        if index is not None:
            return index
        if token == "*":
            return None
        names = self.declared[kind].names
        if token.isascii() and token.isdigit():
            if len(token) <= _MAX_DIGITS and int(token) < len(names):
                return int(token)
            raise st.error(
                st.line_at(i),
                f"{SINGULAR[kind]} number {_shown(token)} is out of range: there are {len(names)} {kind} "
                f"(0..{len(names) - 1})",
            )
        raise st.error(st.line_at(i), f"unknown {SINGULAR[kind]} {token!r}; {self.describe(kind)}")

    def describe(self, kind: str) -> str:
        """What was declared of ``kind``, for a message about a wrong reference."""
        names, line, numbered = self.declared[kind]
        if numbered:
            return f"the {kind} are numbered 0..{len(names) - 1} (line {line})"
        shown = ", ".join(names[:_MAX_SHOWN]) + (", ..." if len(names) > _MAX_SHOWN else "")
        return f"the {kind} declared on line {line} are {shown}"

    def actions_of(self, st: Statement) -> list[int]:
        """The actions a ``T:``, ``O:`` or ``R:`` statement is about (every one for ``*``)."""
        expect_colon(st, 1, st.tokens[0])
        action = self.ref("actions", st, 2)
        return list(range(self.size("actions"))) if action is None else [action]

    # --- statements ------------------------------------------------------------------------------
    def declare(self, st: Statement, kind: str) -> None:
        """``states:``, ``actions:`` or ``observations:``: a count or a list of names."""
        if kind in self.declared:
            raise st.error(st.line, f"{kind}: declared twice (first on line {self.declared[kind].line})")
        expect_colon(st, 1, kind)
        items = st.tokens[2:]
        if not items:
            raise st.error(st.line, f"{kind}: needs a number or a list of names")
        if len(items) == 1 and items[0].isascii() and items[0].isdigit():
            count = int(items[0]) if len(items[0]) <= _MAX_DIGITS else None
            if count is not None and count < 1:
                raise st.error(st.line, f"{kind}: there must be at least one, found {count}")
            _check_count(st, kind, count)
            names, numbered = [str(i) for i in range(count or 0)], True
        else:
            _check_count(st, kind, len(items))
            _check_names(st, kind, items)
            names, numbered = items, False
        self.declared[kind] = Declared(names, st.line, numbered)
        self.lookup[kind] = {name: i for i, name in enumerate(names)}

    def check_sizes(self, st: Statement) -> None:
        """Once states, actions and observations are all declared (``st`` is the first statement
        after them): every action's T and O have a row per state, O a column per observation, so the
        sizes are checked against :data:`~beliefloc.source.limits.MODEL_ENTRIES` before any table is made."""
        n, a, k = self.size("states"), self.size("actions"), self.size("observations")
        limit = limits.MODEL_ENTRIES
        for count, what in ((n * k, f"{n:,} states × {k:,} observations"), (n * a, f"{n:,} states × {a:,} actions")):
            if count > limit.value:
                raise LimitError(
                    f"{st.path}:{st.line}: the declared {what} make {count:,} table entries, more than the limit of "
                    f"{limit.value:,} {limit.what}; if the input is what you meant, raise it with the environment "
                    f"variable {limit.variable}=N"
                )

    def spend(self, st: Statement, count: int) -> None:
        """Count ``count`` more table entries given by ``st`` (a ``*`` or a whole matrix gives many),
        refused past :data:`~beliefloc.source.limits.MODEL_ENTRIES` before they are made."""
        self.entries += count
        limit = limits.MODEL_ENTRIES
        if self.entries > limit.value:
            raise LimitError(
                f"{st.path}:{st.line}: the T: and O: statements so far give {self.entries:,} entries, more than the "
                f"limit of {limit.value:,} ({limit.what}); if the input is what you meant, raise it with the "
                f"environment variable {limit.variable}=N"
            )

    def discount(self, st: Statement) -> None:
        """``discount: F``: checked, then ignored (localization has no discount of its own)."""
        expect_colon(st, 1, "discount")
        value = float(numbers(st, 2, 1, "discount:")[0])
        if not 0.0 <= value <= 1.0:
            raise st.error(st.line, f"discount: must be between 0 and 1, found {value:g}")

    def values(self, st: Statement) -> None:
        """``values: reward`` or ``values: cost``."""
        expect_colon(st, 1, "values")
        if st.tokens[2:] not in (["reward"], ["cost"]):
            raise st.error(st.line, f"values: must be 'reward' or 'cost', found {' '.join(st.tokens[2:])!r}")
        self.values_cost = st.tokens[2] == "cost"

    def start_belief(self, st: Statement) -> None:
        """``start: uniform``, ``start: STATE``, ``start: p1 ... pn``, ``start include|exclude: S...``."""
        if "states" not in self.declared:
            raise st.error(st.line, "start: comes before states: is declared")
        n = self.size("states")
        tokens = st.tokens
        if len(tokens) > 1 and tokens[1] in ("include", "exclude"):
            self.start = self._start_subset(st)
            return
        expect_colon(st, 1, "start")
        rest = tokens[2:]
        if rest == ["uniform"]:
            self.start = np.full(n, 1.0 / n)
        elif len(rest) == 1 and not NUMBER.match(rest[0]):
            state = self.ref("states", st, 2)
            self.start = np.full(n, 1.0 / n) if state is None else np.eye(1, n, state).ravel()
        else:
            start = numbers(st, 2, n, "start:")
            _check_probabilities(start, st, "start:")
            if abs(start.sum() - 1.0) > TOLERANCE:
                raise st.error(st.line, f"start: the probabilities sum to {start.sum():.9g}, not 1")
            self.start = start

    def _start_subset(self, st: Statement) -> np.ndarray:
        """``start include: S...`` or ``start exclude: S...``: uniform over the states chosen."""
        tokens = st.tokens
        expect_colon(st, 2, f"start {tokens[1]}")
        chosen = np.zeros(self.size("states"), dtype=bool)
        if len(tokens) == 3:
            raise st.error(st.line, f"start {tokens[1]}: needs at least one state")
        for i in range(3, len(tokens)):
            state = self.ref("states", st, i)
            chosen[slice(None) if state is None else state] = True
        if tokens[1] == "exclude":
            chosen = ~chosen
        if not chosen.any():
            raise st.error(st.line, "start exclude: leaves no state")
        start: np.ndarray = chosen / chosen.sum()
        return start


_MAX_DIGITS = 18
"""A count or number longer than this is out of any range (and ``int()`` of 5,000 digits raises)."""


def _shown(token: str) -> str:
    """A number as a message shows it: ``12345...(5,000 digits)`` when it is long."""
    return token if len(token) <= _MAX_DIGITS else f"{token[:_MAX_DIGITS]}...({len(token):,} digits)"


def _check_count(st: Statement, kind: str, count: int | None) -> None:
    """Refuse more elements than :data:`~beliefloc.source.limits.MODEL_ELEMENTS` (None: too many digits to count)."""
    limit = limits.MODEL_ELEMENTS
    if count is None or count > limit.value:
        amount = f"{count:,} {kind}" if count is not None else f"a count of {len(st.tokens[2]):,} digits"
        raise LimitError(
            f"{st.path}:{st.line}: {kind}: {amount} is more than the limit of {limit.value:,} {limit.what}; "
            f"if the input is what you meant, raise it with the environment variable {limit.variable}=N"
        )


def _check_names(st: Statement, kind: str, names: list[str]) -> None:
    """Refuse a keyword, an invalid identifier or a name listed twice."""
    seen: set[str] = set()
    for j, name in enumerate(names):
        where = st.line_at(2 + j)
        if name in RESERVED:
            raise st.error(where, f"{kind}: {name!r} is a keyword of the format and cannot be a name")
        if not IDENTIFIER.match(name):
            raise st.error(
                where,
                f"{kind}: {name!r} is not a valid name (a letter, then letters, digits, '_' or '-'); "
                "give either a count or names",
            )
        if name in seen:
            raise st.error(where, f"{kind}: {name!r} is listed twice")
        seen.add(name)


def _check_probabilities(values: np.ndarray, st: Statement, what: str) -> None:
    bad = np.flatnonzero(~((values >= 0.0) & (values <= 1.0)))
    if len(bad):
        raise st.error(st.line, f"{what} {values[bad[0]]:g} is not a probability (between 0 and 1)")
