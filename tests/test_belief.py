"""The Bayes filter on the paper's worked examples (Colledanchise Figs. 2-4)."""

from __future__ import annotations

import numpy as np
import pytest

from beliefloc import compile_model, load_map, uniform, update
from beliefloc.belief import entropy, most_likely, observation_probabilities
from beliefloc.errors import ImpossibleObservationError

from .conftest import MAPS


@pytest.fixture(scope="module")
def window():
    return compile_model(load_map(MAPS / "window-2x2.yaml"))


def test_fig3_look_window_seen(window):
    """Fig. 3: uniform belief, Look with p_fp 0.1, p_fn 0.2, windows in the bottom row."""
    belief, p = update(window, uniform(4), "look", "window_seen")
    # P(seen) = 0.25 (0.8 + 0.8 + 0.1 + 0.1) = 0.45; window cells 0.2/0.45, others 0.025/0.45
    assert p == pytest.approx(0.45)
    np.testing.assert_allclose(belief, [1 / 18, 1 / 18, 4 / 9, 4 / 9])


def test_fig3_look_window_not_seen(window):
    belief, p = update(window, uniform(4), "look", "window_not_seen")
    assert p == pytest.approx(0.55)
    np.testing.assert_allclose(belief, [9 / 22, 9 / 22, 2 / 22, 2 / 22])


def test_fig2_right_moves_with_probability_0_8(window):
    belief, p = update(window, uniform(4), "right", None)
    assert p == 1.0
    np.testing.assert_allclose(belief, [0.05, 0.45, 0.05, 0.45])


def test_observation_probabilities_sum_to_one(window):
    probabilities = observation_probabilities(window.action("look"), uniform(4))
    np.testing.assert_allclose(probabilities, [0.55, 0.45])


def test_impossible_observation_is_a_named_error(window):
    certain = np.array([1.0, 0.0, 0.0, 0.0])
    perfect = compile_model(load_map(MAPS / "window-2x2-perfect.yaml"))
    with pytest.raises(ImpossibleObservationError, match="probability 0"):
        update(perfect, certain, "look", "window_seen")


def test_entropy_and_most_likely():
    assert entropy(uniform(4)) == pytest.approx(np.log(4))
    assert entropy(np.array([0.0, 1.0])) == 0.0
    assert most_likely(np.array([0.2, 0.5, 0.3])) == (1, 0.5)
