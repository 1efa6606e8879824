"""What every command shares: the one error boundary, opening MAP|MODEL|.pomdp, beliefs, JSON."""

from __future__ import annotations

import functools
import json
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, ParamSpec, TypeVar

import numpy as np
import typer
from rich.markup import escape

from beliefloc.belief import uniform
from beliefloc.belief_file import load_belief
from beliefloc.errors import BeliefLocError, UsageError
from beliefloc.model import Model
from beliefloc.render import stderr_console

if TYPE_CHECKING:
    from beliefloc.semantic_map import SemanticMap

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


PRIOR_PREFIX = "prior:"
BELIEF_HELP = (
    "'uniform', a YAML/JSON file {state: probability}, or prior:DOMAIN: where the domain's knowledge base "
    "says the robot is (its rooms must be the map's)."
)


def initial_belief(model: Model, spec: str, smap: SemanticMap | None = None) -> np.ndarray:
    """``--belief``: ``uniform``, a YAML/JSON file ``{state: probability}``, or ``prior:DOMAIN``.

    ``prior:DOMAIN`` is the robot's room prior from the domain's knowledge base spread over the
    rooms of ``model``'s map (``smap``, else the map the model was compiled from, see
    :func:`source_map`): see :mod:`beliefloc.knowledge.robot`.
    """
    if spec == "uniform":
        return uniform(model.n_states)
    if spec.startswith(PRIOR_PREFIX):
        return robot_prior_belief(model, Path(spec.removeprefix(PRIOR_PREFIX)), smap)
    belief, warnings = load_belief(model, Path(spec))
    for message in warnings:
        warn(message)
    return belief


def source_map(model: Model) -> SemanticMap:
    """The map ``model`` was compiled from, read again and checked to be the very same file.

    Raises :class:`UsageError` for a model without a map (a .pomdp import) or whose map cannot be
    read or has changed since the model was built."""
    from beliefloc.semantic_map import load_map

    source = model.source
    if source is None or model.grid is None:
        raise UsageError(f"model {model.name!r} was not compiled from a map (an imported .pomdp?), so it has no rooms")
    if not Path(source.path).is_file():
        raise UsageError(
            f"model {model.name!r} was compiled from {source.path}, which is not there any more; use the map itself"
        )
    smap = load_map(source.path)
    if smap.source is None or smap.source.sha256 != source.sha256:
        raise UsageError(f"{source.path} has changed since model {model.name!r} was built from it; rebuild the model")
    return smap


def robot_prior_belief(model: Model, domain_file: Path, smap: SemanticMap | None = None) -> np.ndarray:
    """``--belief prior:DOMAIN``: the domain's rooms must be the rooms of ``model``'s map; the map's
    cells give each room's states (the domain may reference another copy of the map)."""
    from beliefloc.knowledge import KnowledgeBase, load_domain
    from beliefloc.knowledge.domain import room_mismatch
    from beliefloc.knowledge.robot import DEFAULT_WEIGHT, prior_from_answer, spread_over_states
    from beliefloc.semantic_map import room_states

    where = f"--belief prior:{domain_file}"
    domain = load_domain(domain_file)
    smap = smap if smap is not None else source_map(model)
    label = smap.source.path if smap.source is not None else smap.name
    if not smap.rooms:
        raise UsageError(f"{where}: {label} has no rooms, so the knowledge base's rooms have no cells there")
    extra, missing = room_mismatch(domain.rooms, smap.rooms)
    if extra or missing:
        parts = [f"not rooms of the map: {', '.join(extra)}"] if extra else []
        parts += [f"rooms of the map the domain lacks: {', '.join(missing)}"] if missing else []
        raise UsageError(f"{where}: the domain's rooms must be those of {label}; " + "; ".join(parts))
    assert model.grid is not None  # source_map checked it, and a map's model always has one
    try:
        states = room_states(smap.rooms, model.grid)
    except ValueError as exc:
        raise UsageError(f"{where}: {label} does not fit model {model.name!r}: {exc}") from None
    base = KnowledgeBase(domain)
    weight = domain.robot.weight if domain.robot is not None else DEFAULT_WEIGHT
    covered = sum(len(s) for s in states.values())
    try:
        prior = prior_from_answer(base.answer(), weight=weight, outside=covered < model.n_states)
        belief = spread_over_states(prior, states, model.n_states)
    except ValueError as exc:
        raise UsageError(f"{where}: {exc}") from None
    for message in base.warnings:
        warn(f"clingo: {message}")
    if prior.message:
        warn(prior.message)
    return belief


def print_json(data: Any) -> None:
    """Plain JSON on stdout, no decoration: the stable interface for scripts."""
    sys.stdout.write(json.dumps(data, indent=2, allow_nan=False) + "\n")


def belief_dict(model: Model, belief: np.ndarray) -> dict[str, float]:
    """Every state with its probability, in state order."""
    return {name: float(p) for name, p in zip(model.states.names, belief.tolist(), strict=True)}
