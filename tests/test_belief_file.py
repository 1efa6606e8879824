"""Belief files: validated against the model's states, with lines in errors."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from beliefloc import compile_model, load_map
from beliefloc.errors import BeliefFileError
from beliefloc.files.belief_file import load_belief

from .conftest import MAPS


@pytest.fixture(scope="module")
def window():
    return compile_model(load_map(MAPS / "window-2x2.yaml"))


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "belief.yaml"
    path.write_text(text)
    return path


def test_missing_states_are_zero(window, tmp_path: Path) -> None:
    belief, warnings = load_belief(window, write(tmp_path, '"1,0": 0.25\n"1,1": 0.75\n'))
    np.testing.assert_allclose(belief, [0, 0, 0.25, 0.75])
    assert warnings == []


def test_unnormalised_is_normalised_with_a_warning(window, tmp_path: Path) -> None:
    belief, warnings = load_belief(window, write(tmp_path, '"0,0": 1\n"0,1": 3\n'))
    np.testing.assert_allclose(belief, [0.25, 0.75, 0, 0])
    assert len(warnings) == 1 and "sum to 4" in warnings[0]


def test_unknown_state_names_its_line(window, tmp_path: Path) -> None:
    path = write(tmp_path, '"0,0": 0.5\n"5,5": 0.5\n')
    with pytest.raises(BeliefFileError, match=r"belief.yaml:2:1: 5,5: unknown state '5,5'"):
        load_belief(window, path)


def test_negative_probability_names_its_line(window, tmp_path: Path) -> None:
    with pytest.raises(BeliefFileError, match=r"belief.yaml:2:8: 0,1: should be greater than or equal to 0"):
        load_belief(window, write(tmp_path, '"0,0": 0.5\n"0,1": -0.5\n'))


def test_all_zero_is_an_error(window, tmp_path: Path) -> None:
    with pytest.raises(BeliefFileError, match="every probability is 0"):
        load_belief(window, write(tmp_path, '"0,0": 0\n'))


def test_cell_spreads_over_headings(tmp_path: Path) -> None:
    text = (MAPS / "window-2x2.yaml").read_text().replace("headings: 1", "headings: 4")
    text = text.replace("right: {cost: 10, failure: 0.2}", "forward: {cost: 10, failure: 0.2}")
    (tmp_path / "m.yaml").write_text(text)
    model = compile_model(load_map(tmp_path / "m.yaml"))
    belief, _ = load_belief(model, write(tmp_path, '"1,1": 1.0\n'))
    assert belief[-4:].tolist() == [0.25] * 4


def test_track_json_output_is_accepted(window, tmp_path: Path) -> None:
    path = tmp_path / "b.json"
    path.write_text(json.dumps({"steps": [], "belief": {"0,0": 0.0, "0,1": 0.5, "1,0": 0.5, "1,1": 0.0}}))
    belief, _ = load_belief(window, path)
    np.testing.assert_allclose(belief, [0, 0.5, 0.5, 0])
