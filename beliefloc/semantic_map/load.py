"""Reading map files: YAML -> validated :class:`SemanticMap`, with file:line errors."""

from __future__ import annotations

from pathlib import Path

from beliefloc.errors import MapError
from beliefloc.model import SourceInfo
from beliefloc.semantic_map.schema import SemanticMap
from beliefloc.source import read_source, validate_source


def load_map(path: str | Path) -> SemanticMap:
    """Read and validate a semantic map; raises :class:`MapError` naming file, line and field."""
    source = read_source(path, MapError)
    if not isinstance(source.data, dict):
        raise MapError(f"{source.path}:1:1: a map file is a YAML mapping (name:, grid:, actions:, ...)")
    smap = validate_source(source, SemanticMap, MapError)
    smap._source = SourceInfo(str(source.path), source.sha256)
    return smap
