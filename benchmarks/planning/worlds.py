"""The worlds of the planning benchmarks (this one and ``benchmarks/bench_weight.py``): episode ``e``'s
world seed, the world built and compiled from it, and a plan replayed on the uniform belief.

numpy and beliefloc are imported inside the functions, after :func:`settings.single_threaded`.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any


def world_seed(seed: int, episode: int) -> int:
    """The seed of episode ``episode``'s world (and of its start and noise)."""
    import numpy as np

    return int(np.random.SeedSequence([seed, episode]).generate_state(1)[0])


def build_model(states: int, wseed: int, directory: Path, rotation_failure: float | None = None) -> Any:
    """``beliefloc generate gridworld --states N --seed WSEED --seen-model states`` (with
    ``--rotation-failure`` when given), loaded and compiled."""
    import numpy as np

    from beliefloc.semantic_map import compile_model, load_map
    from beliefloc.simulation.gridworld import generate_gridworld, gridworld_yaml
    from beliefloc.simulation.settings import MOVE_FAILURE, SeenModel

    rotations = MOVE_FAILURE if rotation_failure is None else rotation_failure
    world = generate_gridworld(states, np.random.default_rng(wseed), SeenModel.STATES, rotation_failure=rotations)
    path = directory / f"world-{states}-{wseed}.yaml"
    path.write_text(gridworld_yaml(world, seed=wseed))
    model = compile_model(load_map(path))
    path.unlink()
    return model


def replay(model: Any, steps: Sequence[tuple[str, str | None]]) -> float:
    """``max(b)`` after applying a plan's actions and expected observations to the uniform belief."""
    from beliefloc.belief import uniform, update

    belief = uniform(model.n_states)
    for action, observation in steps:
        belief, _ = update(model, belief, action, observation)
    return float(belief.max())
