"""Semantic maps: the YAML file format, loading with line numbers, compiling to a Model."""

from beliefloc.semantic_map.compile import MapSummary, compile_model, describe_map, layout_of, room_states
from beliefloc.semantic_map.load import load_map
from beliefloc.semantic_map.schema import SemanticMap

__all__ = ["MapSummary", "SemanticMap", "compile_model", "describe_map", "layout_of", "load_map", "room_states"]
