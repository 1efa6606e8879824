"""Answers Nav2 accepts: ``pose --format ros`` read as ``ros2 topic pub`` reads it (``yaml.safe_load``,
then field by field against the ``.msg`` definitions of Humble, Jazzy, Kilted and the latest, through
rosbags typestores), checked as AMCL checks an ``/initialpose``; the modes and the localized verdict
of the pure core (beliefloc.pose); the non-negative covariance; refusals, ``--force``, the stamp, the
rounding, and ``--format posearray``."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from beliefloc.cli.app import app
from beliefloc.cli.pose import DEFAULT_SECOND_MODE_SHARE, stamp_ns
from beliefloc.errors import EXIT_BAD_INPUT, EXIT_NEGATIVE
from beliefloc.model import GridLayout, MapFrame, Model, StateSpace
from beliefloc.planning.settings import DEFAULT_THRESHOLD
from beliefloc.pose import (
    SECOND_MODE_SHARE,
    belief_modes,
    belief_pose,
    gathered_modes,
    localization,
    nonnegative_covariance,
)
from beliefloc.ros.messages import NOW, rounded, to_typed

from .conftest import MAPS

rosbags_typesys = pytest.importorskip("rosbags.typesys")

KITCHEN = str(MAPS / "kitchen.yaml")
NOW_NS = 1_700_000_000_250_000_000
"""The time a test's ``ros2 topic pub`` publishes at."""
STORES = ["ROS2_HUMBLE", "ROS2_JAZZY", "ROS2_KILTED", "LATEST"]
"""rosbags' message definitions of Humble, Jazzy, Kilted and the latest release (Rolling's stand-in)."""
AMCL_SEEDS = (0, 1, 6, 7, 35)
"""The covariance entries AMCL's handleInitialPose copies into its filter (x, y and yaw)."""
MAX_COVARIANCE = 1e6
"""The magnitude issue ros-navigation/navigation2#5611 proposed AMCL refuse above."""


@pytest.fixture(scope="module", params=STORES)
def typestore(request: pytest.FixtureRequest) -> Any:
    return rosbags_typesys.get_typestore(getattr(rosbags_typesys.Stores, request.param))


def write_belief(tmp_path: Path, masses: dict[str, float], name: str = "belief.json") -> str:
    path = tmp_path / name
    path.write_text(json.dumps(masses))
    return str(path)


def pose_cli(runner: CliRunner, *args: str) -> Any:
    return runner.invoke(app, ["pose", KITCHEN, *args])


def as_published(typestore: Any, text: str, msgtype: str) -> Any:
    """What ``ros2 topic pub TOPIC MSGTYPE "$(text)"`` publishes: the YAML read with ``yaml.safe_load``,
    every field assigned against the message definition (unknown fields refused), ``now`` expanded."""
    body = yaml.safe_load(text)
    assert isinstance(body, dict)
    typed = to_typed(typestore, msgtype, body, now_ns=NOW_NS)
    return typestore.deserialize_cdr(typestore.serialize_cdr(typed, msgtype), msgtype)


def amcl_refusal(msg: Any, *, global_frame: str = "map", extent: tuple[float, float, float, float]) -> str | None:
    """Why Nav2's AMCL would ignore this /initialpose, or None: an empty or foreign frame_id (every
    release); a pose off the map (PR #4416); a covariance entry not finite, negative (Rolling, PR
    #5683) or above 1e6 in magnitude (#5611); and what pf_init needs to draw particles: the x-y block
    it copies ([0], [1], [6], [7]) positive semi-definite and the yaw variance [35] >= 0."""
    frame = msg.header.frame_id.lstrip("/")
    if not frame or frame != global_frame:
        return f"frame_id {msg.header.frame_id!r}"
    x0, y0, x1, y1 = extent
    position = msg.pose.pose.position
    if not (x0 <= position.x <= x1 and y0 <= position.y <= y1):
        return "off the map"
    cov = np.asarray(msg.pose.covariance, dtype=np.float64)
    if not np.all(np.isfinite(cov)):
        return "a covariance entry is not finite"
    if np.any(cov < 0.0):
        return "a negative covariance entry"
    if np.any(np.abs(cov) > MAX_COVARIANCE):
        return "a covariance entry above 1e6"
    block = cov.reshape(6, 6)[:2, :2]
    if np.linalg.eigvalsh(block).min() < 0.0 or cov[35] < 0.0:
        return "AMCL's x-y-yaw covariance cannot be drawn from"
    q = msg.pose.pose.orientation
    if abs(math.hypot(q.x, q.y, q.z, q.w) - 1.0) > 1e-6:
        return "the orientation is not a unit quaternion"
    return None


KITCHEN_EXTENT = (0.0, 0.0, 3.6, 3.6)
"""The kitchen: 3 x 3 cells of 1.2 m from the origin."""


# --- the pure core: modes, the verdict, the covariance ----------------------------------------------


def grid_model(rows: int, cols: int, headings: int = 4, cell_size: float = 1.0) -> Model:
    grid = GridLayout(rows, cols, headings, cell_size, np.ones((rows, cols), dtype=bool), frame=MapFrame())
    return Model("toy", StateSpace(grid.n_states, grid=grid), (), grid)


def on(model: Model, masses: dict[str, float]) -> np.ndarray:
    belief = np.zeros(model.n_states)
    for name, p in masses.items():
        belief[model.states.index(name)] = p
    return belief


def test_two_far_cells_are_two_modes_and_neighbours_one() -> None:
    model = grid_model(1, 6)
    far = belief_modes(model, on(model, {"0,0,1": 0.3, "0,5,1": 0.7}))
    described = [(model.states.name(m.state), m.probability, m.states) for m in far]
    assert described == [("0,5,1", 0.7, 1), ("0,0,1", 0.3, 1)]
    near = belief_modes(model, on(model, {"0,2,1": 0.3, "0,3,1": 0.7}))  # one cell apart: one mode
    assert [(model.states.name(m.state), m.probability, m.states) for m in near] == [("0,3,1", 1.0, 2)]
    two_cells = belief_modes(model, on(model, {"0,1,1": 0.3, "0,3,1": 0.7}))  # two cells apart: two
    assert [m.probability for m in two_cells] == [0.7, 0.3]


def test_gathered_modes_put_each_mode_on_its_best_state_and_keep_the_rest() -> None:
    model = grid_model(1, 9, headings=1)
    belief = on(model, {"0,0": 0.3, "0,1": 0.25, "0,4": 0.29, "0,8": 0.156, "0,6": 0.004})
    gathered = gathered_modes(model, belief)
    # the modes of the test below: 0,0 takes 0,1; 0,4 and 0,8 alone; 0,6 (0.004) is in no mode
    assert gathered == pytest.approx(on(model, {"0,0": 0.55, "0,4": 0.29, "0,8": 0.156, "0,6": 0.004}))


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_gathered_modes_keep_the_mass_and_each_modes_share(seed: int) -> None:
    model = grid_model(4, 5, headings=4)
    rng = np.random.default_rng(seed)
    belief = rng.dirichlet(np.full(model.n_states, 0.2))
    gathered = gathered_modes(model, belief)
    assert gathered.sum() == pytest.approx(1.0) and np.all(gathered >= 0) and np.all(np.isfinite(gathered))
    for mode in belief_modes(model, belief):
        assert gathered[mode.state] == pytest.approx(mode.probability)


def test_a_mode_keeps_to_neighbouring_headings() -> None:
    model = grid_model(1, 1, headings=4)
    modes = belief_modes(model, on(model, {"0,0,0": 0.4, "0,0,1": 0.2, "0,0,2": 0.3, "0,0,3": 0.1}))
    # from heading 0: headings 3, 0, 1 (one sector either way) -> 0.7; heading 2 alone -> 0.3
    assert [model.states.name(m.state) for m in modes] == ["0,0,0", "0,0,2"]
    assert [m.probability for m in modes] == pytest.approx([0.7, 0.3])


def test_modes_are_sorted_by_mass_and_stop_below_one_percent() -> None:
    model = grid_model(1, 9, headings=1)
    belief = on(model, {"0,0": 0.3, "0,1": 0.25, "0,4": 0.29, "0,8": 0.156, "0,6": 0.004})
    modes = belief_modes(model, belief)
    # greedy: 0,0 takes 0,1 (0.55); 0,4 (0.29); 0,8 (0.156); 0.004 is left, below 1 %
    assert [(model.states.name(m.state), m.probability) for m in modes] == [
        ("0,0", pytest.approx(0.55)),
        ("0,4", pytest.approx(0.29)),
        ("0,8", pytest.approx(0.156)),
    ]
    assert len(belief_modes(model, belief, max_modes=2)) == 2


def modes_by_loop(model: Model, belief: np.ndarray) -> list[tuple[int, float]]:
    """The greedy definition one state at a time (the oracle of the vectorised one)."""
    grid = model.grid
    assert grid is not None
    b = belief / belief.sum()
    left = {i for i in range(model.n_states) if b[i] > 0}
    found = []
    while len(found) < 10 and sum(b[i] for i in left) >= 0.01:
        best = min(left, key=lambda i: (-b[i], i))
        r0, c0, h0 = grid.cell_heading(best)
        members = []
        for i in sorted(left):
            r, c, h = grid.cell_heading(i)
            turn = abs(int(h) - int(h0)) % grid.headings
            close = math.dist((float(r), float(c)), (float(r0), float(c0))) * grid.cell_size <= 1.5 * grid.cell_size
            if close and min(turn, grid.headings - turn) <= 1:
                members.append(i)
        found.append((best, float(sum(b[i] for i in members))))
        left -= set(members)
    found.sort(key=lambda pair: -pair[1])
    return found


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), headings=st.sampled_from([1, 4, 8]))
def test_modes_match_the_loop(seed: int, headings: int) -> None:
    model = grid_model(4, 5, headings=headings, cell_size=0.5)
    rng = np.random.default_rng(seed)
    belief = rng.random(model.n_states) ** 6 * (rng.random(model.n_states) < 0.3)
    if belief.sum() == 0:
        belief[0] = 1.0
    got = [(m.state, m.probability) for m in belief_modes(model, belief)]
    expected = modes_by_loop(model, belief)
    assert [s for s, _ in got] == [s for s, _ in expected]
    assert [p for _, p in got] == pytest.approx([p for _, p in expected])


def test_localized_needs_the_threshold_and_no_second_place() -> None:
    model = grid_model(1, 6)
    sure = localization(model, on(model, {"0,0,1": 0.97, "0,5,1": 0.03}), min_probability=0.95)
    assert sure.localized and sure.reasons == ()
    unsure = localization(model, on(model, {"0,0,1": 0.6, "0,5,1": 0.4}), min_probability=0.95)
    assert not unsure.localized and len(unsure.reasons) == 2
    assert unsure.reasons[0] == "the most likely state 0,0,1 holds 0.6 of the belief, less than 0.95"
    assert unsure.reasons[1].startswith("a second place holds 0.4 of the belief (the most likely state's place 0.6)")
    lowered = localization(model, on(model, {"0,0,1": 0.6, "0,5,1": 0.4}), min_probability=0.5)
    assert not lowered.localized and len(lowered.reasons) == 1  # the second place still refuses it
    # the same mass next door is one place: localized under a lowered threshold
    spread = localization(model, on(model, {"0,0,1": 0.6, "0,1,1": 0.4}), min_probability=0.5)
    assert spread.localized and [m.probability for m in spread.modes] == [1.0]
    assert DEFAULT_SECOND_MODE_SHARE == SECOND_MODE_SHARE  # the CLI's copy of the default


def test_nonnegative_covariance_moves_a_negative_correlation_onto_the_variances() -> None:
    cov = np.zeros((6, 6))
    cov[:2, :2] = [[1.56, -1.44], [-1.44, 1.56]]
    cov[5, 5], cov[0, 5], cov[5, 0] = 0.2, 0.1, 0.1
    out = np.array(nonnegative_covariance(tuple(cov.ravel()))).reshape(6, 6)
    assert out[0, 1] == out[1, 0] == 0.0
    assert out[0, 0] == out[1, 1] == pytest.approx(3.0)
    assert out[0, 5] == 0.1 and out[5, 5] == 0.2  # positive entries are kept
    positive = tuple(float(v) for v in np.eye(6).ravel())
    assert nonnegative_covariance(positive) == positive


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_nonnegative_covariance_is_a_wider_covariance(seed: int) -> None:
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(3, 3))
    small = a @ a.T
    cov = np.zeros((6, 6))
    cov[np.ix_([0, 1, 5], [0, 1, 5])] = small
    out = np.array(nonnegative_covariance(tuple(cov.ravel()))).reshape(6, 6)
    assert np.all(out >= 0.0)
    assert np.allclose(out, out.T)
    assert np.linalg.eigvalsh(out - cov).min() >= -1e-12  # never narrower than the belief's
    assert np.linalg.eigvalsh(out).min() >= -1e-12


# --- the message, as ros2 topic pub and AMCL read it -----------------------------------------------


def test_a_localized_belief_is_a_message_every_release_reads_and_amcl_takes(
    runner: CliRunner, tmp_path: Path, typestore: Any
) -> None:
    belief = write_belief(tmp_path, {"0,1,0": 0.976, "1,1,0": 0.024})  # the kitchen story's end
    result = pose_cli(runner, "--belief", belief, "--format", "ros")
    assert result.exit_code == 0, result.output
    msg = as_published(typestore, result.stdout, "geometry_msgs/msg/PoseWithCovarianceStamped")
    assert msg.header.frame_id == "map"
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (1_700_000_000, 250_000_000)  # "now"
    assert (msg.pose.pose.position.x, msg.pose.pose.position.y, msg.pose.pose.position.z) == (1.8, 3.0, 0.0)
    assert 2 * math.atan2(msg.pose.pose.orientation.z, msg.pose.pose.orientation.w) == pytest.approx(math.pi / 2)
    assert amcl_refusal(msg, extent=KITCHEN_EXTENT) is None
    assert all(msg.pose.covariance[i] > 0 for i in (0, 7, 35))


@pytest.mark.parametrize(
    ("masses", "negative"),
    [
        ({"0,0,1": 0.5, "2,2,1": 0.5}, -1.44),  # two modes in opposite corners
        ({"0,1,0": 0.5, "1,2,0": 0.5}, -0.36),  # diagonal neighbours: one mode, a tilted spread
    ],
)
def test_the_covariance_amcl_gets_has_no_negative_entry(
    runner: CliRunner, tmp_path: Path, typestore: Any, masses: dict[str, float], negative: float
) -> None:
    belief = write_belief(tmp_path, masses)
    plain = json.loads(pose_cli(runner, "--belief", belief).stdout)["pose"]["covariance"]
    assert plain[1] == plain[6] == pytest.approx(negative)  # the belief's own x-y covariance
    result = pose_cli(runner, "--belief", belief, "--format", "ros", "--force")
    assert result.exit_code == 0, result.output
    msg = as_published(typestore, result.stdout, "geometry_msgs/msg/PoseWithCovarianceStamped")
    cov = np.asarray(msg.pose.covariance)
    assert np.all(cov >= 0.0) and amcl_refusal(msg, extent=KITCHEN_EXTENT) is None
    assert cov[1] == cov[6] == 0.0
    assert cov[0] == pytest.approx(plain[0] - negative) and cov[7] == pytest.approx(plain[7] - negative)
    assert cov[35] == pytest.approx(plain[35])


def test_the_posearray_is_the_modes_every_release_reads(runner: CliRunner, tmp_path: Path, typestore: Any) -> None:
    belief = write_belief(tmp_path, {"0,0,1": 0.3, "2,2,1": 0.6, "2,1,1": 0.1})
    result = pose_cli(runner, "--belief", belief, "--format", "posearray")
    assert result.exit_code == 0, result.output
    msg = as_published(typestore, result.stdout, "geometry_msgs/msg/PoseArray")
    assert msg.header.frame_id == "map" and msg.header.stamp.sec == 1_700_000_000
    # two modes: 2,2 with its neighbour 2,1 (0.7), then 0,0 (0.3); each at its best state's pose
    assert [(p.position.x, p.position.y) for p in msg.poses] == [(3.0, 0.6), (0.6, 3.0)]
    modes = json.loads(pose_cli(runner, "--belief", belief).stdout)["modes"]
    assert [m["probability"] for m in modes] == pytest.approx([0.7, 0.3])


# --- refusals, --force, the stamp, the rounding ------------------------------------------------------


def test_no_belief_is_the_uniform_belief_and_refused(runner: CliRunner) -> None:
    result = pose_cli(runner, "--format", "ros")
    assert result.exit_code == EXIT_NEGATIVE
    assert result.stdout == ""
    assert "not localized: no --belief given, so the uniform belief" in result.stderr
    assert "Modes: " in result.stderr and "--force" in result.stderr
    assert pose_cli(runner, "--format", "ros", "--force").exit_code == 0


def test_a_belief_below_the_threshold_is_refused_with_its_modes(runner: CliRunner, tmp_path: Path) -> None:
    belief = write_belief(tmp_path, {"0,1,0": 0.9, "1,1,0": 0.1})
    result = pose_cli(runner, "--belief", belief, "--format", "ros")
    assert result.exit_code == EXIT_NEGATIVE and result.stdout == ""
    stderr = " ".join(result.stderr.split())
    assert f"holds 0.9 of the belief, less than {DEFAULT_THRESHOLD:g}" in stderr
    assert "Modes: 0,1,0 at (1.800, 3.000, yaw 1.571) holds 1 (2 states)" in stderr
    assert pose_cli(runner, "--belief", belief, "--format", "ros", "--min-probability", "0.9").exit_code == 0


def test_a_second_place_is_refused_even_under_a_low_threshold(runner: CliRunner, tmp_path: Path) -> None:
    belief = write_belief(tmp_path, {"0,0,1": 0.7, "2,2,1": 0.3})
    args = ["--belief", belief, "--format", "ros", "--min-probability", "0.5"]
    result = pose_cli(runner, *args)
    assert result.exit_code == EXIT_NEGATIVE
    assert "a second place holds 0.3 of the belief" in " ".join(result.stderr.split())
    assert pose_cli(runner, *args, "--max-second-mode", "0.3").exit_code == 0
    forced = pose_cli(runner, *args, "--force")
    assert forced.exit_code == 0 and yaml.safe_load(forced.stdout)["pose"]["pose"]["position"]["x"] == 0.6


def test_json_reports_the_verdict_and_the_modes_without_refusing(runner: CliRunner, tmp_path: Path) -> None:
    belief = write_belief(tmp_path, {"0,0,1": 0.5, "2,2,1": 0.5})
    result = pose_cli(runner, "--belief", belief)
    assert result.exit_code == 0
    data = json.loads(result.stdout)
    assert data["localized"] is False and len(data["reasons"]) == 2
    assert [(m["x"], m["y"], m["probability"], m["states"]) for m in data["modes"]] == [
        (0.6, 3.0, 0.5, 1),
        (3.0, 0.6, 0.5, 1),
    ]


@pytest.mark.parametrize(
    ("given_stamp", "sec", "nanosec"),
    [("1700000000.25", 1_700_000_000, 250_000_000), ("12", 12, 0), ("0", 0, 0), ("5.000000001", 5, 1)],
)
def test_a_given_stamp(runner: CliRunner, tmp_path: Path, given_stamp: str, sec: int, nanosec: int) -> None:
    belief = write_belief(tmp_path, {"0,1,0": 1.0})
    result = pose_cli(runner, "--belief", belief, "--format", "ros", "--stamp", given_stamp)
    assert result.exit_code == 0, result.output
    assert yaml.safe_load(result.stdout)["header"]["stamp"] == {"sec": sec, "nanosec": nanosec}


def test_the_stamp_is_now_by_default(runner: CliRunner, tmp_path: Path) -> None:
    belief = write_belief(tmp_path, {"0,1,0": 1.0})
    result = pose_cli(runner, "--belief", belief, "--format", "ros")
    assert yaml.safe_load(result.stdout)["header"] == {"stamp": NOW, "frame_id": "map"}
    assert stamp_ns("now") == NOW


@pytest.mark.parametrize("bad", ["yesterday", "-1", "1.0000000001", "1e9", ""])
def test_a_bad_stamp_is_refused(runner: CliRunner, tmp_path: Path, bad: str) -> None:
    belief = write_belief(tmp_path, {"0,1,0": 1.0})
    result = pose_cli(runner, "--belief", belief, "--format", "ros", "--stamp", bad)
    assert result.exit_code == EXIT_BAD_INPUT
    assert "--stamp" in result.stderr and "Traceback" not in result.output


def test_numbers_are_rounded_to_nine_decimals(runner: CliRunner, tmp_path: Path) -> None:
    belief = write_belief(tmp_path, {"1,1,1": 0.97, "1,2,1": 0.03})
    plain = json.loads(pose_cli(runner, "--belief", belief).stdout)
    assert plain["pose"]["x"] == 1.7999999999999998  # (1 + 0.5) * 1.2 in floating point
    result = pose_cli(runner, "--belief", belief, "--format", "ros")
    assert result.exit_code == 0, result.output
    assert "1.7999999999999998" not in result.stdout and "x: 1.8," in result.stdout
    for number in re.findall(r"-?\d+\.(\d+)", result.stdout):
        assert len(number) <= 9, number
    assert rounded({"a": [-1e-12, 0.1 + 0.2], "b": 3, "c": "now"}) == {"a": [0.0, 0.3], "b": 3, "c": "now"}
    assert math.copysign(1.0, rounded(-1e-12)) == 1.0  # no -0.0


def test_to_typed_expands_now_only_with_a_time_and_refuses_what_is_not_a_message(typestore: Any) -> None:
    body = {"header": {"stamp": NOW, "frame_id": "map"}, "poses": []}
    with pytest.raises(TypeError, match="needs the time it stands for"):
        to_typed(typestore, "geometry_msgs/msg/PoseArray", body)
    assert to_typed(typestore, "geometry_msgs/msg/PoseArray", body, now_ns=7).header.stamp.nanosec == 7
    with pytest.raises(TypeError, match="should be a mapping"):
        to_typed(typestore, "geometry_msgs/msg/PoseArray", {"header": "auto"})
    with pytest.raises(KeyError, match="has no field seq"):
        to_typed(typestore, "std_msgs/msg/Header", {"seq": 1})  # ROS 1's field


def test_belief_pose_is_unchanged_by_the_message(tmp_path: Path) -> None:
    """The JSON keeps the belief's own covariance; only the ROS message is made non-negative."""
    model = grid_model(3, 3)
    belief = on(model, {"0,0,1": 0.5, "2,2,1": 0.5})
    estimate = belief_pose(model, belief)
    assert estimate.matrix[0, 1] < 0
    assert np.array(nonnegative_covariance(estimate.covariance)).min() == 0.0
