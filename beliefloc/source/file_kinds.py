"""What kind of beliefloc file something is, so that a file given in the wrong place is named.

``beliefloc validate domains/home.yaml`` should say *domains/home.yaml is a knowledge-base domain,
not a map*, not list the domain's keys as unknown map keys. The readers of maps, domains, belief
files, models and macro tables ask this module what they were given when it is not what they
expect:

>>> kind_of_data({"name": "home", "rooms": {}, "classes": {}, "objects": {}})
'a knowledge-base domain'
>>> not_a("domains/home.yaml", DOMAIN, MAP)
'domains/home.yaml is a knowledge-base domain, not a map'

:func:`kind_of_data` looks at parsed YAML or JSON (or a model file's JSON header),
:func:`kind_of_path` at a file name's suffix only, :func:`kind_of` at both. Each returns one of the
noun phrases below, or None when it cannot tell. Pure: no file is opened here.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import PurePath

MAP = "a map"
"""A semantic map, ``maps/*.yaml`` (docs/map-format.md)."""
DOMAIN = "a knowledge-base domain"
"""A domain, ``domains/*.yaml`` (docs/domain-format.md)."""
BELIEF = "a belief file"
"""States to probabilities, or the JSON of ``beliefloc track --json``."""
OCCUPANCY = "a ROS/Nav2 occupancy map YAML"
"""``map_saver``'s YAML (image, resolution, origin, thresholds), which a map names with ``occupancy:``."""
KNOWLEDGE_BASE = "a knowledge base (.lp)"
"""An ASP program for clingo, ``kb/*.lp``."""
MODEL = "a compiled model"
"""Written by ``beliefloc build`` (``.npz``)."""
MACROS = "a macro table"
"""Written by ``beliefloc macros build`` (``.npz``)."""
MODEL_OR_MACROS = "a compiled model or macro table (.npz)"
"""A ``.npz`` file, when only its name is known."""
POMDP = "a Cassandra .pomdp file"
IMAGE = "an image"
"""A PGM, PNG, BMP, ... (an occupancy map's picture, or a picture ``beliefloc`` drew)."""
RECORDING = "a ROS recording (MCAP)"
"""An ``.mcap`` file: a recording ``track --bag`` reads, or ``--record`` writes."""

KINDS = (MAP, DOMAIN, BELIEF, OCCUPANCY, KNOWLEDGE_BASE, MODEL, MACROS, MODEL_OR_MACROS, POMDP, IMAGE, RECORDING)

_MAP_KEYS = frozenset(
    {"grid", "layout", "landmarks", "actions", "sensors", "annotations", "occupancy", "occupancy_rule"}
)
"""Top-level keys only a map has (``name``, ``description`` and ``rooms`` are a domain's too)."""
_DOMAIN_KEYS = frozenset({"classes", "objects", "defaults", "target", "steps", "kb", "map", "robot", "search"})
"""Top-level keys only a domain has (docs/domain-format.md)."""
_OCCUPANCY_KEYS = frozenset({"image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode"})
"""The keys of a ROS map YAML (nav2_map_server's ``loadMapYaml``)."""
_STATE = re.compile(r"^\s*-?\d+\s*,\s*-?\d+\s*(,\s*-?\d+\s*)?$")
"""A state's name, ``"3,4,0"``, or a cell's, ``"3,4"``."""
_HEADER_FORMATS = {"beliefloc-model": MODEL, "beliefloc-macros": MACROS}
"""The ``format`` of an ``.npz`` file's JSON header (beliefloc.files.model_file, beliefloc.files.macro_file)."""

_SUFFIXES = {
    ".lp": KNOWLEDGE_BASE,
    ".npz": MODEL_OR_MACROS,
    ".pomdp": POMDP,
    ".mcap": RECORDING,
    **dict.fromkeys((".pgm", ".png", ".bmp", ".jpg", ".jpeg", ".gif", ".tif", ".tiff", ".ppm", ".webp"), IMAGE),
}


def kind_of_data(data: object) -> str | None:
    """The kind of file whose parsed content is ``data`` (YAML or JSON, or an ``.npz`` file's
    header), as a noun phrase (:data:`MAP`, :data:`DOMAIN`, ...); None when it is none of them
    recognisably.

    A map is told by the keys only maps have (``grid``, ``actions``, ``sensors``, ...), a domain by
    those only domains have (``classes``, ``objects``, ``kb``, ...), an occupancy map YAML by
    ``image``, ``resolution``, ``origin``... When keys of several kinds are there, the kind with the
    most wins (a map with one stray key is still a map); a tie is None. A belief file maps state
    names (``"3,4,0"``, ``"3,4"``) to numbers, or has such a mapping under ``belief`` (the JSON of
    ``beliefloc track --json``). A model or macro file's header is told by its ``format``.
    """
    if not isinstance(data, Mapping) or not data:
        return None
    header = data.get("format")
    if isinstance(header, str) and header in _HEADER_FORMATS:
        return _HEADER_FORMATS[header]
    if _is_belief(data.get("belief")) or _is_belief(data):  # ``track --json`` has steps: too
        return BELIEF
    keys = {key for key in data if isinstance(key, str)}
    scores = {
        MAP: len(keys & _MAP_KEYS),
        DOMAIN: len(keys & _DOMAIN_KEYS),
        OCCUPANCY: len(keys & _OCCUPANCY_KEYS),
    }
    best = max(scores.values())
    if best > 0:
        winners = [kind for kind, score in scores.items() if score == best]
        return winners[0] if len(winners) == 1 else None
    return None


def _is_belief(data: object) -> bool:
    """A non-empty mapping from state names to numbers."""
    return (
        isinstance(data, Mapping)
        and bool(data)
        and all(isinstance(key, str) and _STATE.match(key) for key in data)
        and all(isinstance(value, (int, float)) and not isinstance(value, bool) for value in data.values())
    )


def kind_of_path(path: str | PurePath) -> str | None:
    """The kind of file ``path`` names by its suffix alone (``.lp``, ``.npz``, ``.pomdp``, an
    image); None for ``.yaml``, ``.json`` and anything else, whose content says what they are."""
    return _SUFFIXES.get(PurePath(path).suffix.lower())


def kind_of(path: str | PurePath, data: object = None) -> str | None:
    """The kind of file ``path`` is: by its suffix, else by its parsed content ``data``."""
    return kind_of_path(path) or kind_of_data(data)


def not_a(path: str | PurePath, found: str, expected: str) -> str:
    """The message for a file of the wrong kind: ``domains/home.yaml is a knowledge-base domain,
    not a map``. ``found`` and ``expected`` are noun phrases such as :data:`DOMAIN` and :data:`MAP`."""
    return f"{path} is {found}, not {expected}"
