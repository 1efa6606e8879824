"""Belief files: ``{state: probability}`` in YAML or JSON, validated against a model's states.

Missing states get 0. ``"row,col"`` on a map with headings names the whole cell, its probability
split evenly over the headings. A file whose probabilities do not sum to 1 is normalised and a
warning is returned; every probability must be a finite number >= 0, and their sum finite (1e308
twice is not) and positive, else the error names the line. The output of ``beliefloc track
--json`` (``{"belief": {...}, ...}``) is accepted too, so a tracked belief can be fed to the next
command.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Annotated

import numpy as np
from pydantic import Field, RootModel

from beliefloc.errors import BeliefFileError, InvalidValueError
from beliefloc.model import Model
from beliefloc.source import Source, read_source, validate_source

_SUM_TOLERANCE = 1e-6


class _BeliefMapping(RootModel[dict[str, Annotated[float, Field(ge=0.0, allow_inf_nan=False, strict=True)]]]):
    pass


def load_belief(model: Model, path: str | Path) -> tuple[np.ndarray, list[str]]:
    """The belief in ``path`` as a vector over ``model``'s states, and any warnings."""
    from beliefloc.source import file_kinds

    by_suffix = file_kinds.kind_of_path(path)
    if by_suffix is not None:
        raise BeliefFileError(file_kinds.not_a(path, by_suffix, file_kinds.BELIEF))
    source = read_source(path, BeliefFileError)
    data = source.data
    found = file_kinds.kind_of_data(data)
    if found is not None and found != file_kinds.BELIEF:
        raise BeliefFileError(file_kinds.not_a(path, found, file_kinds.BELIEF))
    prefix: tuple[str, ...] = ()
    if isinstance(data, dict) and isinstance(data.get("belief"), dict):
        data, prefix = data["belief"], ("belief",)
    inner = Source(
        source.path, data, source.sha256, _strip(source.value_marks, prefix), _strip(source.key_marks, prefix)
    )
    if not isinstance(data, dict):
        raise BeliefFileError(f"{source.path}:1:1: a belief file maps states to probabilities, e.g. {{'0,0,1': 0.5}}")
    mapping = validate_source(inner, _BeliefMapping, BeliefFileError).root
    belief = np.zeros(model.n_states)
    running = 0.0
    for name, probability in mapping.items():
        try:
            states = model.states.indices(str(name))
        except InvalidValueError as exc:
            raise inner.error((str(name),), str(exc), BeliefFileError, key=True) from None
        running += probability
        if not math.isfinite(running):
            raise inner.error(
                (str(name),),
                f"the probabilities add up to more than {sys.float_info.max:.4g}, the largest number there is; "
                "give probabilities (at most 1 each), or smaller weights",
                BeliefFileError,
            )
        belief[states] += probability / len(states)
    total = float(belief.sum())
    if not total > 0.0 or not math.isfinite(total):
        raise inner.error((), "every probability is 0; a belief needs some mass", BeliefFileError)
    warnings = []
    if abs(total - 1.0) > _SUM_TOLERANCE:
        warnings.append(f"{source.path}: probabilities sum to {total:.6g}, not 1; normalised")
    return belief / total, warnings


def _strip(
    marks: dict[tuple[str | int, ...], tuple[int, int]], prefix: tuple[str, ...]
) -> dict[tuple[str | int, ...], tuple[int, int]]:
    if not prefix:
        return marks
    n = len(prefix)
    return {key[n:]: mark for key, mark in marks.items() if key[:n] == prefix}
