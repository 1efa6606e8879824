"""beliefloc: plan what to do and what to look at in belief space.

Staged API (each stage callable without the CLI)::

    semantic_map = load_map("maps/kitchen.yaml")     # validated, frozen
    model = compile_model(semantic_map)              # sparse T and factored O per action
    belief, p = update(model, uniform(model.n_states), "look", "nothing")
"""

from beliefloc.belief import entropy, most_likely, predict, uniform, update
from beliefloc.errors import BeliefLocError
from beliefloc.model import Model
from beliefloc.semantic_map import compile_model, load_map

__version__ = "0.1.0"

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
