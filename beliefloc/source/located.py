"""A parsed input file and where each of its parts was written: line and column by path."""

from __future__ import annotations

import contextlib
import gc
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path as FilePath
from typing import Any

from beliefloc.errors import InputFileError, Path


@contextlib.contextmanager
def gc_paused() -> Iterator[None]:
    """Pause the cyclic garbage collector while building many small objects that live on (and put it
    back as it was after).

    A 10^6-state generated map is ~600,000 YAML values; every few hundred allocations the collector
    would walk all the objects alive so far, which made reading such a file quadratic (5 s instead
    of 1 s). What is built under it must leave next to no cyclic garbage: nothing the parser builds is
    cyclic, and the contingent planner's graph, which is, is unlinked when its search goes.
    """
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was_enabled:
            gc.enable()


@dataclass(frozen=True)
class Source:
    """A parsed input file: its data and where each part of it was written."""

    path: FilePath
    data: Any
    sha256: str
    value_marks: dict[Path, tuple[int, int]] = field(default_factory=dict)
    key_marks: dict[Path, tuple[int, int]] = field(default_factory=dict)
    block_rows: dict[Path, list[tuple[int, int]]] = field(default_factory=dict)
    """For block scalars (``layout: |``): (line, indentation) of each non-blank content line."""
    aliases: dict[Path, Path] = field(default_factory=dict)
    """Where a value that was not written at its own path was written: an alias (``b: *a``) maps
    ``("b",)`` to the anchor's path, a key merged in by ``<<: *base`` maps ``("m", "k")`` to
    ``("base", "k")``. Values are shared, not copied, so this stays as small as the file."""
    renamed: dict[Path, Path] = field(default_factory=dict)
    """A key the loader renamed before validation -> the key the file wrote (a map's old-form
    ``beams`` is validated as ``beams_deg``): messages name, and point at, what the file wrote."""

    def locate(self, path: Path, *, key: bool = False) -> tuple[Path, tuple[int, int]]:
        """The part of ``path`` that exists in the file and its (line, column), both 1-based.

        Elements that are not in the file (a pydantic union tag, say) are skipped; a path that
        leads nowhere resolves to its longest existing prefix. With ``key``, the line of the key
        rather than of its value, when the key was written.
        """
        found, _, mark = self._resolve(path, key=key)
        return found, mark

    def _resolve(self, path: Path, *, key: bool = False) -> tuple[Path, Path, tuple[int, int]]:
        """(the part of ``path`` found, where it was written, its line and column)."""
        values, keys, aliases = self.value_marks, self.key_marks, self.aliases
        found: Path = ()
        written: Path = ()
        value_mark = values.get(())
        key_mark: tuple[int, int] | None = None
        for element in path:
            candidate = (*written, element)
            if candidate in self.renamed:
                candidate = self.renamed[candidate]
                element = candidate[-1]
            if candidate not in values and candidate not in aliases and candidate not in keys:
                if isinstance(element, (int, float)):
                    candidate = (*written, str(element))  # a key written as a number: paths spell it as text
                elif element == "[key]":  # pydantic: the key itself is wrong, not its value
                    key = True
                    continue
                else:  # a list the model turned into a mapping (rooms: [kitchen, study]): the item
                    items = data_at(self.data, found)
                    if isinstance(items, list) and element in items:
                        candidate = (*written, items.index(element))
            target = self._follow(candidate, stop_at=values)
            if target in values:
                value_mark, key_mark = values[target], keys.get(target)
            elif candidate in keys:  # a key whose value has no mark of its own
                value_mark = key_mark = keys[candidate]
            else:
                continue  # not in the file: a union tag, or a key the file lacks
            found = (*found, element)
            written = self._follow(candidate)
        mark = key_mark if key and key_mark is not None else value_mark
        return found, written, mark if mark is not None else (1, 1)

    def _follow(self, path: Path, *, stop_at: dict[Path, Any] | None = None) -> Path:
        """``path`` through aliases and merges to where its value was written (to its first mark
        with ``stop_at``)."""
        for _ in range(len(self.aliases) + 1):  # aliases cannot loop (a value cannot contain itself), but be sure
            if (stop_at is not None and path in stop_at) or path not in self.aliases:
                break
            path = self.aliases[path]
        return path

    def error(self, path: Path, message: str, error_cls: type[InputFileError], *, key: bool = False) -> InputFileError:
        """An error naming this file, the line and column of ``path``, and the field."""
        return error_cls(self.format(path, message, key=key))

    def format(self, path: Path, message: str, *, key: bool = False, row: int | None = None, column: int = 0) -> str:
        """``file:line:col: field.path: message``; with ``row``, the line of that row of a block."""
        found, written, (line, col) = self._resolve(path, key=key)
        rows = self.block_rows.get(written, self.block_rows.get(found))
        if row is not None and rows is not None and 0 <= row < len(rows):
            line, col = rows[row][0], rows[row][1] + column + 1
        where = format_path(found)
        return f"{self.path}:{line}:{col}: {where + ': ' if where else ''}{message}"


def format_path(path: Path) -> str:
    """``("sensors", "look", "classes", 2)`` -> ``sensors.look.classes[2]``."""
    text = ""
    for element in path:
        if isinstance(element, int):
            text += f"[{element}]"
        else:
            text += f".{element}" if text else str(element)
    return text


def data_at(data: Any, path: Path) -> Any:
    """The value at ``path`` in ``data``, or None."""
    for element in path:
        if isinstance(data, dict) and element in data:
            data = data[element]
            continue
        if not isinstance(data, list) or not isinstance(element, int) or not 0 <= element < len(data):
            return None
        data = data[element]
    return data


def shown_value(value: Any) -> str:
    """A value as a message shows it after "got"."""
    if isinstance(value, bool):
        return f"{'true' if value else 'false'} (a boolean)"
    if value is None:
        return "an empty value (null)"
    if isinstance(value, dict):
        return "a mapping"
    if isinstance(value, list):
        return f"a list of {len(value)} item{'s' if len(value) != 1 else ''}"
    if isinstance(value, str):
        return repr(value if len(value) <= 60 else value[:57] + "...")
    if isinstance(value, int) and abs(value) >= 10**40:
        return f"an integer of {len(str(abs(value))):,} digits"
    return repr(value)
