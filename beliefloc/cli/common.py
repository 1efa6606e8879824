"""What every command shares: the one error boundary, opening MAP|MODEL|.pomdp, beliefs, JSON."""

from __future__ import annotations

import functools
import json
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any, ParamSpec, TypeVar

import numpy as np
import typer
from rich.markup import escape

from beliefloc.belief import uniform
from beliefloc.belief_file import load_belief
from beliefloc.errors import BeliefLocError, UsageError
from beliefloc.model import Model
from beliefloc.render import stderr_console

P = ParamSpec("P")
R = TypeVar("R")

MAP_SUFFIXES = (".yaml", ".yml")
POMDP_SUFFIX = ".pomdp"
MODEL_SUFFIX = ".npz"


def boundary(command: Callable[P, R]) -> Callable[P, R]:
    """The CLI's one error boundary: a :class:`BeliefLocError` becomes a message on stderr and its
    exit code; anything else is a bug and keeps its traceback."""

    @functools.wraps(command)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        try:
            return command(*args, **kwargs)
        except BeliefLocError as exc:
            report_error(exc)
            raise typer.Exit(exc.exit_code) from None

    return wrapper


def report_error(exc: BeliefLocError) -> None:
    stderr_console().print(f"[bold red]error:[/] {escape(str(exc))}", soft_wrap=True)  # one line per error


def warn(message: str) -> None:
    stderr_console().print(f"[yellow]warning:[/] {escape(message)}", soft_wrap=True)


def open_model(path: Path) -> Model:
    """A model from a map (``.yaml``), a compiled model (``.npz``) or a Cassandra ``.pomdp`` file."""
    suffix = path.suffix.lower()
    if suffix in MAP_SUFFIXES:
        from beliefloc.semantic_map import compile_model, load_map

        return compile_model(load_map(path))
    if suffix == MODEL_SUFFIX:
        from beliefloc.model_file import load_model

        return load_model(path)
    if suffix == POMDP_SUFFIX:
        from beliefloc.pomdp_format import read_pomdp

        return read_pomdp(path)
    raise UsageError(
        f"{path}: unknown kind of file; expected a map (.yaml), a model built by 'beliefloc build' "
        f"(.npz) or a Cassandra POMDP file (.pomdp)"
    )


def initial_belief(model: Model, spec: str) -> np.ndarray:
    """``--belief``: ``uniform`` or a YAML/JSON file ``{state: probability}``."""
    if spec == "uniform":
        return uniform(model.n_states)
    belief, warnings = load_belief(model, Path(spec))
    for message in warnings:
        warn(message)
    return belief


def print_json(data: Any) -> None:
    """Plain JSON on stdout, no decoration: the stable interface for scripts."""
    sys.stdout.write(json.dumps(data, indent=2, allow_nan=False) + "\n")


def belief_dict(model: Model, belief: np.ndarray) -> dict[str, float]:
    """Every state with its probability, in state order."""
    return {name: float(p) for name, p in zip(model.states.names, belief.tolist(), strict=True)}
