"""Reading map files: YAML -> validated :class:`SemanticMap`, with file:line errors.

A map with ``occupancy:`` names a ROS/Nav2 occupancy map (and ``rooms: {mask: ...}`` a region mask)
beside it: those files are read first, relative to the map's folder, and handed to validation, which
takes the grid's size, free cells and frame from them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

from beliefloc.errors import MapError
from beliefloc.model import SourceInfo
from beliefloc.semantic_map.angles import OldForm, renamed_paths, rewritten_line
from beliefloc.semantic_map.schema import SemanticMap
from beliefloc.source import Source, read_source, read_text, validate_source
from beliefloc.source.file_kinds import MAP, kind_of_data, kind_of_path, not_a

Warn = Callable[[str], None]


def load_map(path: str | Path, *, on_warning: Warn | None = None) -> SemanticMap:
    """Read and validate a semantic map; raises :class:`MapError` naming file, line and field.

    A file of another kind (a domain, a belief file, an occupancy map's YAML, a knowledge base...)
    is refused as such: ``domains/home.yaml is a knowledge-base domain, not a map``.

    What validation has to say goes to ``on_warning``: an angle in the old form, with its line in
    the new form (:mod:`~beliefloc.semantic_map.angles`); a Look class no landmark has, with the
    file, line and field; a likely unit mistake (also before an error it may explain); what the
    occupancy map's reading has to say (unknown grey counted as unknown, a NaN yaw), prefixed with
    the occupancy map's file."""
    other = kind_of_path(path)
    if other is not None:
        raise MapError(not_a(path, other, MAP))
    source = read_source(path, MapError)
    other = kind_of_data(source.data)
    if other is not None and other != MAP:
        raise MapError(not_a(source.path, other, MAP))
    if not isinstance(source.data, dict):
        raise MapError(f"{source.path}:1:1: a map file is a YAML mapping (name:, grid:, actions:, ...)")
    context = _files_named(source)
    warnings: list[tuple[tuple[str | int, ...], str]] = []
    unit_warnings: list[tuple[tuple[str | int, ...], str]] = []
    old_forms: list[OldForm] = []
    context["warnings"] = warnings
    context["unit_warnings"] = unit_warnings
    context["old_forms"] = old_forms
    renamed = renamed_paths(source.data)
    located = replace(source, renamed=renamed) if renamed else source
    try:
        smap = validate_source(located, SemanticMap, MapError, context=context)
    except MapError:
        if on_warning is not None:  # a unit mistake may be why: say so before the error
            for where, message in unit_warnings:
                on_warning(source.format(where, message))
        raise
    smap._source = SourceInfo(str(source.path), source.sha256)
    if on_warning is not None:
        for message in old_form_warnings(source, old_forms):
            on_warning(message)
        for where, message in unit_warnings:
            on_warning(source.format(where, message))
        for where, message in warnings:
            on_warning(source.format(where, message))
        occupancy = smap.occupancy_map
        if occupancy is not None:
            for message in occupancy.warnings:
                on_warning(f"{occupancy.yaml_path}: {message}")
    return smap


def _files_named(source: Source) -> dict[str, Any]:
    """The occupancy map and region mask the map file names, read (validation needs their pixels)."""
    data = source.data
    assert isinstance(data, dict)
    named = data.get("occupancy")
    if named is None:
        return {}
    from beliefloc.semantic_map.occupancy_map import (  # Pillow: only for these maps
        RULE_NAMES,
        OccupancyRule,
        load_occupancy,
        load_region_mask,
    )

    target = _beside(source, ("occupancy",), named, "a ROS map YAML file (map_saver's), e.g. depot.yaml")
    rule_text = data.get("occupancy_rule", OccupancyRule.BELIEFLOC.value)
    try:
        rule = OccupancyRule(rule_text)
    except ValueError:
        choices = ", ".join(RULE_NAMES)
        raise MapError(source.format(("occupancy_rule",), f"should be one of: {choices}; got {rule_text!r}")) from None
    occupancy = load_occupancy(target, rule=rule)
    context: dict[str, Any] = {"occupancy": occupancy}
    rooms = data.get("rooms")
    if isinstance(rooms, dict) and rooms.get("mask") is not None:
        mask = _beside(source, ("rooms", "mask"), rooms["mask"], "a region-mask YAML file beside the map")
        context["region_mask"] = load_region_mask(mask, like=occupancy)
    return context


def _beside(source: Source, where: tuple[str, ...], named: object, what: str) -> Path:
    """The file ``named`` at ``where`` in the map, relative to the map's folder; refused at its line
    when it is not a path or not a file."""
    if not isinstance(named, str) or not named.strip():
        raise MapError(source.format(where, f"should be the path of {what}"))
    target = (source.path.parent / named).resolve()
    if not target.is_file():
        problem = "is a folder, not a file" if target.is_dir() else "does not exist"
        raise MapError(source.format(where, f"{named}: {target} {problem}"))
    return target


def old_form_warnings(source: Source, old_forms: list[OldForm]) -> list[str]:
    """One paragraph per angle written in the old form: where, what it meant, and its line in the
    new form (:mod:`~beliefloc.semantic_map.angles`)."""
    if not old_forms:
        return []
    lines = read_text(source.path, MapError)[0].splitlines()
    messages = []
    for old in sorted(old_forms, key=lambda old: source.locate(old.path, key=True)[1]):
        _, (line, column) = source.locate(old.path, key=True)
        text = lines[line - 1] if 0 < line <= len(lines) else ""
        new_line = rewritten_line(text, column, old)
        shown = (new_line if new_line is not None else old.new_text).strip()
        messages.append(
            source.format(
                old.path,
                f"{old.what}. It is read as before (the same model); write line {line} as `{shown}` "
                "(docs/map-format.md, Angles)",
                key=True,
            )
        )
    return messages
