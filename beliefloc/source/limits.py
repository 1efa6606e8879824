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

LARGEST_COUNT = 2**62
"""The largest count any outside integer may give: it fits a C ``long`` (``setrlimit``, numpy)."""


def read_count(text: str, name: str, *, lowest: int = 0, highest: int = LARGEST_COUNT) -> int:
    """The one reader for an integer from outside (an environment variable, a JSON reply, a
    command-line count): ASCII digits only, with ``_`` between digits allowed, from ``lowest`` to
    ``highest``; anything else raises :class:`ValueError` naming ``name`` and what it accepts.

    ``str.isdigit`` and ``int`` accept superscripts and other scripts' digits (``²``, ``١``) and
    ``int`` would spend quadratic time on a 10^6-digit string: the length is checked first.
    """
    accepts = f"it accepts a whole number from {lowest:,} to {highest:,} written in the digits 0-9"
    stripped = text.strip()
    digits = stripped.replace("_", "")
    grouped = not (stripped.startswith("_") or stripped.endswith("_") or "__" in stripped)
    if not (digits.isascii() and digits.isdigit() and grouped):
        shown = stripped[:40].encode("unicode_escape").decode("ascii")
        raise ValueError(f"{name}: '{shown}' is not a whole number; {accepts}")
    if len(digits.lstrip("0")) > len(str(highest)):
        raise ValueError(f"{name}: a {len(digits):,}-digit number is out of range; {accepts}")
    value = int(digits)
    if not lowest <= value <= highest:
        raise ValueError(f"{name}: {value:,} is out of range; {accepts}")
    return value


@dataclass(frozen=True)
class Limit:
    """A bound with a name for people, a default and the environment variable that overrides it."""

    what: str
    """What is counted, for messages: ``"bytes in an input file"``."""
    default: int
    variable: str
    highest: int = LARGEST_COUNT
    """The largest value the variable may take (what the system call it ends in accepts)."""

    @property
    def value(self) -> int:
        """The bound in force: the environment variable when it is set, else the default.

        A value that is not a whole number from 1 to :attr:`highest` in ASCII digits (``²``,
        ``1kB``, ``1e3``, ``-1``, ``0``) is refused with a :class:`~beliefloc.errors.LimitError`
        naming the variable, never replaced by the default: a user who lowers a bound must get it."""
        text = os.environ.get(self.variable)
        if text is None or not text.strip():
            return self.default
        from beliefloc.errors import LimitError

        try:
            return read_count(text, f"the environment variable {self.variable}", lowest=1, highest=self.highest)
        except ValueError as exc:
            raise LimitError(f"{exc}; it bounds the {self.what} (default {self.default:,})") from None

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

YAML_NODES = Limit("YAML values (after expanding aliases)", 4_000_000, "BELIEFLOC_MAX_YAML_NODES")
"""Values built from one YAML file, counting each use of an alias (``*name``) in full: a ten-line
file of nested aliases would otherwise expand to gigabytes. Each value read keeps its line and
column, about 0.3 KB and 4 µs a value (measured: 3,000,000 values in 11 s and 1.0 GB, 7,000,000 in
32 s and 2.1 GB), so the default keeps the reading of any file within about 20 s and 1.5 GB; a
generated 10^6-state map holds 0.7 million values."""

POLYGON_CORNERS = Limit("corners of room polygons", 100_000, "BELIEFLOC_MAX_POLYGON_CORNERS")
"""Corners of all the room polygons of one map (``rooms: {polygons: ...}``), counted before any is
read as a number or laid over the cells; a floor plan's rooms have tens to thousands."""

MODEL_ENTRIES = Limit("states × observations", 100_000_000, "BELIEFLOC_MAX_MODEL_ENTRIES")
"""The largest model: states times the observations of every action, summed over the actions, plus
each sensor part's table of readings (8 bytes an entry: 800 MB at the default). A map's size is
checked against it before any table is allocated; a .pomdp file's when its header has been read."""

MAP_STATES = Limit("states (cells × headings)", 4_000_000, "BELIEFLOC_MAX_MAP_STATES")
"""The largest grid of a map: rows × columns × headings, counted before its cells are laid out (an
occupancy image sets rows and columns: a 212 KB PNG of 7071 × 7071 pixels in cells of one pixel is 50
million). A state costs about 250 bytes and 5 µs to compile and write, whatever its observations
(measured: 8 million states in 19 s and 1.9 GB without sensors, 64 s and 2.4 GB with a scan and a
look), so the default keeps any map within about 1 GB; a generated 10^6-state map fits."""

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
