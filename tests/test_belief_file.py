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


# --- the pose a localize run wrote beside its belief ---------------------------------------------


@pytest.fixture(scope="module")
def kitchen():
    return compile_model(load_map(MAPS / "kitchen.yaml"))


def _with_pose(model, tmp_path: Path, **changes: object) -> Path:
    """A belief file as ``localize --belief-out`` writes it with the pose lattice: state 0,1,1 at
    0.97 (2,1,2, two cells away, 0.03) and a pose 6 cm and 0.1 rad from its centre and heading."""
    from beliefloc.pose import state_pose

    centre = state_pose(model.grid, model.states.index("0,1,1"))
    cov = np.diag([0.01, 0.02, 0.0, 0.0, 0.0, 0.03])
    cov[0, 1] = cov[1, 0] = -0.004
    pose: dict[str, object] = {
        "state": "0,1,1",
        "probability": 0.96,
        "x": centre.x + 0.05,
        "y": centre.y - 0.04,
        "yaw": centre.yaw + 0.1,
        "covariance": cov.ravel().tolist(),
    }
    pose.update(changes)
    path = tmp_path / "belief.json"
    path.write_text(json.dumps({"belief": {"0,1,1": 0.97, "2,1,2": 0.03}, "localized_pose": pose}, indent=2) + "\n")
    return path


def test_the_pose_written_beside_a_belief_is_read_back_whole(kitchen, tmp_path: Path) -> None:
    from beliefloc.files.belief_file import load_belief_pose

    path = _with_pose(kitchen, tmp_path)
    belief, _ = load_belief(kitchen, path)
    estimate = load_belief_pose(kitchen, path, belief)
    assert estimate is not None and kitchen.states.name(estimate.state) == "0,1,1"
    assert estimate.probability == 0.96
    assert (estimate.pose.x, estimate.pose.y) == pytest.approx((1.85, 2.96))
    assert estimate.covariance[1] == -0.004  # as written: `pose --format ros` makes it non-negative
    plain = tmp_path / "plain.json"  # track --json's output has a "pose" of its own: not this one
    plain.write_text(json.dumps({"belief": {"0,1,1": 1.0}, "pose": {"x": 1.0}}))
    assert load_belief_pose(kitchen, plain, load_belief(kitchen, plain)[0]) is None


def test_the_belief_and_its_pose_come_from_one_reading_of_the_file(kitchen, tmp_path: Path, monkeypatch) -> None:
    """`pose --belief FILE` reads the file once: a file replaced between two readings (a localize run
    writing its next belief) would pair one run's belief with another's pose."""
    import beliefloc.files.belief_file as belief_file

    path = _with_pose(kitchen, tmp_path)
    belief, _ = load_belief(kitchen, path)
    alone = belief_file.load_belief_pose(kitchen, path, belief)
    reads: list[object] = []
    real = belief_file.read_source
    monkeypatch.setattr(belief_file, "read_source", lambda *a, **k: reads.append(a) or real(*a, **k))
    both, warnings, estimate = belief_file.load_belief_and_pose(kitchen, path)
    assert len(reads) == 1 and warnings == []
    assert np.array_equal(both, belief) and estimate == alone


@pytest.mark.parametrize(
    ("changes", "says"),
    [
        ({"state": "2,1,2"}, r"localized_pose\.state: '2,1,2' is not the belief's most likely state '0,1,1'"),
        ({"state": "9,9,0"}, r"localized_pose\.state: unknown state '9,9,0'"),
        ({"x": 4.0}, r"localized_pose\.x: \(4, 2\.96\) is 2\.\d+ m from state 0,1,1's cell centre"),
        ({"yaw": 2.0}, r"localized_pose\.yaw: 2 rad is more than one heading sector"),
        ({"x": "1.8"}, r"localized_pose\.x: "),
        ({"probability": 1.5}, r"localized_pose\.probability: "),
        ({"probability": 0.99}, r"localized_pose\.probability: 0\.99 is more than the belief holds around state 0,1,1"),
        ({"covariance": [0.0] * 35}, r"localized_pose\.covariance: "),
        ({"covariance": [0.1] + [0.0] * 34 + [-0.1]}, r"localized_pose\.covariance: not a covariance"),
        ({"covariance": [0.1, 0.2] + [0.0] * 34}, r"localized_pose\.covariance: not a covariance"),
        ({"z": 0.0}, r"localized_pose\.z: "),
    ],
)
def test_a_pose_that_does_not_fit_its_belief_is_refused_naming_the_line(
    kitchen, tmp_path: Path, changes: dict[str, object], says: str
) -> None:
    from beliefloc.files.belief_file import load_belief_pose

    path = _with_pose(kitchen, tmp_path, **changes)
    belief, _ = load_belief(kitchen, path)
    with pytest.raises(BeliefFileError, match=r"belief\.json:\d+:\d+: " + says):
        load_belief_pose(kitchen, path, belief)


def test_a_pose_lattice_s_declaration_stands_for_the_state_s_own_mass(kitchen, tmp_path: Path) -> None:
    """A robot on the border of two cells splits the states' mass (0.5 and 0.49 here) however well its
    pose is known: `pose` judges a written pose by the probability the lattice declared it at."""
    from beliefloc.files.belief_file import load_belief_pose
    from beliefloc.pose import localization

    path = tmp_path / "belief.json"
    written = json.loads(_with_pose(kitchen, tmp_path).read_text())
    written["belief"] = {"0,1,1": 0.5, "0,0,1": 0.49, "2,1,2": 0.01}
    path.write_text(json.dumps(written, indent=2))
    belief, _ = load_belief(kitchen, path)
    estimate = load_belief_pose(kitchen, path, belief)
    assert estimate is not None
    assert not localization(kitchen, belief, min_probability=0.95).localized
    verdict = localization(kitchen, belief, min_probability=0.95, declared=estimate)
    assert verdict.localized and verdict.probability == 0.96
    assert not localization(kitchen, belief, min_probability=0.97, declared=estimate).localized
