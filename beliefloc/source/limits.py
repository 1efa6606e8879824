"""The documented bounds on what beliefloc reads, checked before it allocates or parses.

Maps, domains, knowledge bases and model files are shared between people and downloaded with
papers' code: reading one must never crash the process, hang it or exhaust the machine. Each limit
has a default that fits every real map we know of with room to spare, and an environment variable
that raises (or lowers) it for the one run that needs it. An error that hits a limit says which
one and how to raise it (:func:`exceeded`).

Imports nothing numeric: the command line reads these when it starts.
"""

from __future__ import annotations

import os
from dataclasses import dataclass


@dataclass(frozen=True)
class Limit:
    """A bound with a name for people, a default and the environment variable that overrides it."""

    what: str
    """What is counted, for messages: ``"bytes in an input file"``."""
    default: int
    variable: str

    @property
    def value(self) -> int:
        """The bound in force: the environment variable when it is set to a positive integer."""
        text = os.environ.get(self.variable, "").strip().replace("_", "")
        if text.isdigit() and int(text) > 0:
            return int(text)
        return self.default

    def check(self, count: int, where: str) -> None:
        """Raise :class:`~beliefloc.errors.LimitError` when ``count`` is above the bound."""
        if count > self.value:
            from beliefloc.errors import LimitError

            raise LimitError(exceeded(self, count, where))


def exceeded(limit: Limit, count: int | None, where: str) -> str:
    """``where: 3,000,000 states × observations is more than the limit of 50,000,000 ...``."""
    amount = f"{count:,} {limit.what}" if count is not None else f"more {limit.what}"
    return (
        f"{where}: {amount} is more than the limit of {limit.value:,}; "
        f"if the input is what you meant, raise it with the environment variable {limit.variable}=N"
    )


INPUT_BYTES = Limit("bytes in an input file", 256 * 1024 * 1024, "BELIEFLOC_MAX_INPUT_BYTES")
"""Maps, domains, belief files, knowledge bases, .pomdp files: a generated 10^6-state map is ~40 MB."""

NESTING = Limit("levels of nesting", 64, "BELIEFLOC_MAX_NESTING")
"""YAML and JSON structure depth (a map needs 5); deeper input crashes native parsers."""

YAML_NODES = Limit("YAML values (after expanding aliases)", 20_000_000, "BELIEFLOC_MAX_YAML_NODES")
"""Values built from one YAML file, counting each use of an alias (``*name``) in full: a ten-line
file of nested aliases would otherwise expand to gigabytes."""

MODEL_ENTRIES = Limit("states × observations", 100_000_000, "BELIEFLOC_MAX_MODEL_ENTRIES")
"""The largest model: states times the observations of every action, summed over the actions, plus
each sensor part's table of readings (8 bytes an entry: 800 MB at the default). A map's size is
checked against it before any table is allocated; a .pomdp file's when its header has been read."""

MODEL_FILE_BYTES = Limit("bytes in a model or macro file, uncompressed", 4 * 1024**3, "BELIEFLOC_MAX_MODEL_BYTES")
""".npz arrays are checked against it from their headers, before they are decompressed."""

GROUNDING_SECONDS = Limit("seconds of grounding and solving", 60, "BELIEFLOC_MAX_KB_SECONDS")
"""Time budget for clingo on one knowledge base (the shipped ones need well under a second)."""

GROUNDING_BYTES = Limit("bytes of memory for clingo", 4 * 1024**3, "BELIEFLOC_MAX_KB_BYTES")
"""Memory budget for grounding and solving one knowledge base."""

GEOMETRY_TESTS = Limit("geometry tests", 200_000_000, "BELIEFLOC_MAX_GEOMETRY_TESTS")
"""Work of laying a map's cells over its geometry, counted before it starts: an occupancy map's
``robot_radius`` tests every cell against each pixel offset within the radius, a room polygon every
cell against each of its corners, a Look sensor every landmark of its classes against each state in
range (a few seconds at the default)."""

MODEL_FILE_ARRAYS = Limit("arrays in a model or macro file", 100_000, "BELIEFLOC_MAX_MODEL_ARRAYS")
"""Members of a model or macro ``.npz`` archive (a model has three for each moving action and two for
each sensor part), counted from the archive's directory before any member is read."""

MODEL_ELEMENTS = Limit("states, actions or observations", 10_000_000, "BELIEFLOC_MAX_MODEL_ELEMENTS")
"""The most states, actions or observations a ``.pomdp`` file may declare (``states: 1000000000``
is a short line), checked before any name or table is made; a generated 10^6-state map fits."""
