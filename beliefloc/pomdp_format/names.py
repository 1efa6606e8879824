"""Names and numbers of the ``.pomdp`` format, shared by writing and reading.

The format's keywords, what an identifier and a number look like, how beliefloc turns any name
into an identifier (:func:`identifiers`) and a float into text that reads back as the same float
(:func:`format_number`), and the constants both directions agree on.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

FORMAT_VERSION = 1
"""Version of the ``# beliefloc-...`` comment lines."""
TOLERANCE = 1e-6
"""How far from 1 a row of T or O may sum."""
RESERVED = frozenset(
    {
        "discount",
        "values",
        "states",
        "actions",
        "observations",
        "T",
        "O",
        "R",
        "uniform",
        "identity",
        "reward",
        "cost",
        "start",
        "include",
        "exclude",
        "reset",
    }
)
"""The format's keywords: never identifiers."""

IDENTIFIER = re.compile(r"[A-Za-z][A-Za-z0-9_-]*\Z")
"""A whole identifier: a letter, then letters, digits, ``_`` or ``-``."""
NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*(?:[eE][+-]?\d+)?|\.\d+(?:[eE][+-]?\d+)?)\Z")
"""A whole number as the format writes it (no ``nan`` or ``inf``, which ``float()`` would accept)."""
_NOT_IDENTIFIER_CHAR = re.compile(r"[^A-Za-z0-9_-]")

KINDS = ("states", "actions", "observations")
"""The three kinds of declared elements, in the order messages list them."""
SINGULAR = {"states": "state", "actions": "action", "observations": "observation"}
PREFIX = {"states": "s", "actions": "a", "observations": "o"}
"""What :func:`identifiers` puts before a name that does not start with a letter."""


def identifiers(names: Sequence[str], prefix: str) -> list[str]:
    """Sanitise ``names`` into distinct identifiers ``[a-zA-Z][a-zA-Z0-9_-]*``.

    Every other character becomes ``_``, a name that does not start with a letter gets ``prefix``,
    a keyword gets a trailing ``_``, and a name that collides with an earlier one gets ``_2``,
    ``_3``, ... Deterministic: the same names in the same order always give the same identifiers.
    """
    used: set[str] = set()
    out: list[str] = []
    for name in names:
        base = _NOT_IDENTIFIER_CHAR.sub("_", name)
        if not base or not ("a" <= base[0].lower() <= "z"):
            base = prefix + base
        if base in RESERVED:
            base += "_"
        ident, k = base, 2
        while ident in used:
            ident, k = f"{base}_{k}", k + 1
        used.add(ident)
        out.append(ident)
    return out


def format_number(value: float) -> str:
    """The shortest text that reads back as ``value``, with a decimal point (``1.0e-05``)."""
    text = repr(float(value))
    if "e" in text:
        mantissa, _, exponent = text.partition("e")
        if "." not in mantissa:
            text = f"{mantissa}.0e{exponent}"
    elif "." not in text:  # pragma: no cover - repr(float) always has '.', 'e', 'inf' or 'nan'
        text += ".0"
    return text
