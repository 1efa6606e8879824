"""beliefloc: plan what to do and what to look at in belief space.

Staged API (each stage callable without the CLI)::

    semantic_map = load_map("maps/kitchen.yaml")     # validated, frozen
    model = compile_model(semantic_map)              # sparse T and factored O per action
    belief, p = update(model, uniform(model.n_states), "look", "nothing")

The names below are loaded when first used (PEP 562), so that importing a part of the package --
the command line above all -- does not load numpy and scipy until a command needs them.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from beliefloc.belief import entropy, most_likely, predict, uniform, update
    from beliefloc.errors import BeliefLocError
    from beliefloc.model import Model
    from beliefloc.semantic_map import compile_model, load_map

__version__ = "0.1.0"

_HOMES = {
    "BeliefLocError": "beliefloc.errors",
    "Model": "beliefloc.model",
    "compile_model": "beliefloc.semantic_map",
    "entropy": "beliefloc.belief",
    "load_map": "beliefloc.semantic_map",
    "most_likely": "beliefloc.belief",
    "predict": "beliefloc.belief",
    "uniform": "beliefloc.belief",
    "update": "beliefloc.belief",
}

__all__ = [
    "BeliefLocError",
    "Model",
    "__version__",
    "compile_model",
    "entropy",
    "load_map",
    "most_likely",
    "predict",
    "uniform",
    "update",
]


def __getattr__(name: str) -> Any:
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module 'beliefloc' has no attribute {name!r}")
    value = getattr(importlib.import_module(home), name)
    globals()[name] = value  # the next access is a plain lookup
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_HOMES])
