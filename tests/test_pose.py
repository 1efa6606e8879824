"""Poses and covariances of beliefs (beliefloc.pose), ``beliefloc pose``, and the ``"pose"`` of every
``--json`` that reports a most likely state."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from beliefloc.cli.app import app
from beliefloc.errors import InvalidValueError
from beliefloc.model import GridLayout, MapFrame, Model, StateSpace, wrap_angle
from beliefloc.pose import (
    UNIFORM_YAW_VARIANCE,
    Pose,
    PoseEstimate,
    belief_pose,
    pose_json,
    state_pose,
)
from beliefloc.ros.messages import pose_with_covariance_stamped

from .conftest import DATA, MAPS

PI = math.pi
CELL = 1 / 12
"""Variance within a unit cell: ``s²/12``."""
SECTOR4 = (PI / 2) ** 2 / 12
"""Variance within one of 4 heading sectors: ``(2π/4)²/12``."""
X, Y, YAW = 0, 1, 5


def grid_model(
    rows: int = 2,
    cols: int = 2,
    headings: int = 4,
    *,
    cell_size: float = 1.0,
    frame: MapFrame | None = None,
    free: np.ndarray | None = None,
) -> Model:
    free = np.ones((rows, cols), dtype=bool) if free is None else free
    grid = GridLayout(rows, cols, headings, cell_size, free, frame=frame or MapFrame())
    return Model("toy", StateSpace(grid.n_states, grid=grid), (), grid)


def belief_on(model: Model, masses: dict[str, float]) -> np.ndarray:
    belief = np.zeros(model.n_states)
    for name, p in masses.items():
        belief[model.states.index(name)] = p
    return belief


# --- worked numbers on a 2x2 grid with 4 headings (unit cells, identity frame) ----------------------
# Cell centres: (0,0) -> (0.5, 1.5), (0,1) -> (1.5, 1.5), (1,0) -> (0.5, 0.5), (1,1) -> (1.5, 0.5).
# Heading yaws: 0 -> pi/2 (up), 1 -> 0, 2 -> -pi/2, 3 -> pi.


@pytest.mark.parametrize(
    ("name", "pose"),
    [
        ("0,0,0", Pose(0.5, 1.5, PI / 2)),
        ("0,1,1", Pose(1.5, 1.5, 0.0)),
        ("1,0,2", Pose(0.5, 0.5, -PI / 2)),
        ("1,1,3", Pose(1.5, 0.5, PI)),
    ],
)
def test_point_belief_is_the_cell_centre_and_heading_yaw(name: str, pose: Pose) -> None:
    model = grid_model()
    estimate = belief_pose(model, belief_on(model, {name: 1.0}))
    assert estimate.pose.x == pytest.approx(pose.x)
    assert estimate.pose.y == pytest.approx(pose.y)
    assert estimate.pose.yaw == pytest.approx(pose.yaw)
    assert estimate.state == model.states.index(name) and estimate.probability == 1.0
    expected = np.zeros((6, 6))
    expected[X, X] = expected[Y, Y] = CELL
    expected[YAW, YAW] = SECTOR4
    np.testing.assert_allclose(estimate.matrix, expected, atol=1e-15)


def test_state_pose_matches_the_layout() -> None:
    model = grid_model()
    assert model.grid is not None
    assert state_pose(model.grid, model.states.index("1,0,1")) == Pose(0.5, 0.5, 0.0)


def test_opposite_headings_use_the_circular_mean() -> None:
    """3/4 on heading 0 (yaw pi/2), 1/4 on heading 2 (-pi/2) of one cell: the circular mean is pi/2
    and the deviations are 0 and pi, so var = 1/4 · pi² (+ the sector); no x, y spread."""
    model = grid_model()
    estimate = belief_pose(model, belief_on(model, {"1,0,0": 0.75, "1,0,2": 0.25}))
    cov = estimate.matrix
    assert estimate.pose == Pose(0.5, 0.5, pytest.approx(PI / 2))
    assert cov[YAW, YAW] == pytest.approx(0.25 * PI**2 + SECTOR4)
    assert cov[X, X] == pytest.approx(CELL) and cov[Y, Y] == pytest.approx(CELL)
    assert cov[X, YAW] == 0.0 and cov[Y, YAW] == 0.0


def test_an_even_split_between_opposite_headings_centres_on_the_reported_yaw() -> None:
    """Half on pi/2, half on -pi/2: no circular mean; the most likely state's yaw (heading 0, the
    lowest index) is the centre, deviations 0 and pi: var = pi²/2, the limit of either side."""
    model = grid_model()
    even = belief_pose(model, belief_on(model, {"1,0,0": 0.5, "1,0,2": 0.5}))
    nearly = belief_pose(model, belief_on(model, {"1,0,0": 0.5 + 1e-6, "1,0,2": 0.5 - 1e-6}))
    assert even.pose.yaw == pytest.approx(PI / 2)
    assert even.matrix[YAW, YAW] == pytest.approx(0.5 * PI**2 + SECTOR4)
    assert nearly.matrix[YAW, YAW] == pytest.approx(even.matrix[YAW, YAW], rel=1e-5)


def test_yaw_deviations_wrap_across_pi() -> None:
    """Headings 2 (-pi/2) and 3 (pi), half each: the circular mean is -3pi/4 and both deviations
    are pi/4 in size (pi - (-3pi/4) = 7pi/4 wraps to -pi/4); the naive mean 0.25pi would give 9pi²/16."""
    model = grid_model()
    cov = belief_pose(model, belief_on(model, {"0,1,2": 0.5, "0,1,3": 0.5})).matrix
    assert cov[YAW, YAW] == pytest.approx(PI**2 / 16 + SECTOR4)


def test_two_cells_give_the_position_covariance() -> None:
    """1/4 on cell (0,0), 3/4 on (1,1), same heading: mean (1.25, 0.75); dx = (-0.75, 0.25),
    dy = (0.75, -0.25): xx = yy = 0.1875 = p(1 - p), xy = -0.1875."""
    model = grid_model()
    estimate = belief_pose(model, belief_on(model, {"0,0,1": 0.25, "1,1,1": 0.75}))
    cov = estimate.matrix
    assert estimate.pose == Pose(1.5, 0.5, 0.0)  # the mode, not the mean
    assert cov[X, X] == pytest.approx(0.1875 + CELL)
    assert cov[Y, Y] == pytest.approx(0.1875 + CELL)
    assert cov[X, Y] == pytest.approx(-0.1875) and cov[Y, X] == pytest.approx(-0.1875)
    assert cov[YAW, YAW] == pytest.approx(SECTOR4)
    assert cov[X, YAW] == pytest.approx(0.0) and cov[Y, YAW] == pytest.approx(0.0)


def test_position_and_yaw_covary() -> None:
    """Half on (0,0) heading 1 (yaw 0), half on (0,1) heading 0 (yaw pi/2): x and yaw grow
    together: mean x 1, mean yaw pi/4; dx = ∓0.5, dyaw = ∓pi/4: x-yaw = pi/8."""
    model = grid_model()
    cov = belief_pose(model, belief_on(model, {"0,0,1": 0.5, "0,1,0": 0.5})).matrix
    assert cov[X, YAW] == pytest.approx(PI / 8) and cov[YAW, X] == pytest.approx(PI / 8)
    assert cov[Y, YAW] == pytest.approx(0.0)
    assert cov[YAW, YAW] == pytest.approx(PI**2 / 16 + SECTOR4)


def test_a_rotated_frame_rotates_the_covariance() -> None:
    """Frame at (2, 3) turned by pi/2: grid (gx, gy) -> map (2 - gy, 3 + gx). The two-cell belief's
    grid deviations (-0.5, 0.5), (0.5, -0.5) become (-0.5, -0.5), (0.5, 0.5): xy changes sign."""
    model = grid_model(frame=MapFrame(2.0, 3.0, PI / 2))
    plain = grid_model()
    masses = {"0,0,0": 0.5, "1,1,0": 0.5}
    estimate = belief_pose(model, belief_on(model, masses))
    cov = estimate.matrix
    assert estimate.pose.x == pytest.approx(0.5) and estimate.pose.y == pytest.approx(3.5)
    assert estimate.pose.yaw == pytest.approx(PI)  # up the grid is -x in the map
    assert cov[X, Y] == pytest.approx(0.25)
    rotation = np.array([[0.0, -1.0], [1.0, 0.0]])
    grid_cov = belief_pose(plain, belief_on(plain, masses)).matrix[:2, :2]
    np.testing.assert_allclose(cov[:2, :2], rotation @ grid_cov @ rotation.T, atol=1e-12)


def test_one_heading_means_an_unknown_yaw() -> None:
    model = grid_model(headings=1, cell_size=0.5)
    estimate = belief_pose(model, belief_on(model, {"0,0": 0.5, "0,1": 0.5}))
    cov = estimate.matrix
    assert estimate.pose == Pose(0.25, 0.75, 0.0)
    assert cov[YAW, YAW] == pytest.approx(UNIFORM_YAW_VARIANCE) == PI**2 / 3
    assert cov[X, X] == pytest.approx(0.0625 + 0.25 / 12)  # dx = ±0.25, cell 0.5
    assert cov[X, YAW] == 0.0 and cov[Y, YAW] == 0.0


def test_a_model_without_a_grid_has_no_pose() -> None:
    model = Model("tiger", StateSpace(2, names=["left", "right"]), ())
    with pytest.raises(InvalidValueError, match="model tiger has no grid, so its states have no pose"):
        belief_pose(model, np.array([0.5, 0.5]))
    assert pose_json(model, np.array([0.5, 0.5])) is None


@pytest.mark.parametrize(
    ("belief", "message"),
    [(np.ones(3) / 3, "16 states"), (np.zeros(16), "positive sum"), (np.full(16, -1.0), "non-negative")],
)
def test_a_belief_that_does_not_fit_is_refused(belief: np.ndarray, message: str) -> None:
    with pytest.raises(InvalidValueError, match=message):
        belief_pose(grid_model(), belief)


def test_the_belief_is_not_modified() -> None:
    model = grid_model()
    belief = belief_on(model, {"0,0,0": 0.25, "1,1,1": 0.75})
    before = belief.copy()
    belief_pose(model, belief)
    np.testing.assert_array_equal(belief, before)


# --- against a plain loop, and properties on random beliefs ------------------------------------------


def loop_covariance(model: Model, belief: np.ndarray) -> tuple[np.ndarray, bool]:
    """The docstring's equations, one state at a time; and whether a yaw deviation is ±pi, whose
    sign (and so that of the position-yaw terms) rounding decides."""
    grid = model.grid
    assert grid is not None
    poses = [state_pose(grid, i) for i in range(model.n_states)]
    w = belief / belief.sum()
    mx = sum(p * q.x for p, q in zip(w, poses, strict=True))
    my = sum(p * q.y for p, q in zip(w, poses, strict=True))
    s = sum(p * math.sin(q.yaw) for p, q in zip(w, poses, strict=True))
    c = sum(p * math.cos(q.yaw) for p, q in zip(w, poses, strict=True))
    mode = int(np.argmax(belief))
    centre = poses[mode].yaw if math.hypot(s, c) < 1e-9 else math.atan2(s, c)
    cov = np.zeros((6, 6))
    antipodal = False
    for p, q in zip(w, poses, strict=True):
        d = np.zeros(6)
        d[X], d[Y] = q.x - mx, q.y - my
        if grid.headings > 1:
            d[YAW] = -((math.pi - (q.yaw - centre)) % (2 * math.pi) - math.pi)  # to (-pi, pi]
            antipodal |= bool(p > 0 and abs(d[YAW]) > math.pi - 1e-9)
        cov += p * np.outer(d, d)
    cov[X, X] += grid.cell_size**2 / 12
    cov[Y, Y] += grid.cell_size**2 / 12
    cov[YAW, YAW] += (2 * math.pi / grid.headings) ** 2 / 12 if grid.headings > 1 else math.pi**2 / 3
    return cov, antipodal


@st.composite
def models_and_beliefs(draw: st.DrawFn) -> tuple[Model, np.ndarray]:
    rows, cols = draw(st.integers(1, 4)), draw(st.integers(1, 4))
    headings = draw(st.sampled_from([1, 2, 4, 8]))
    free = np.array(draw(st.lists(st.booleans(), min_size=rows * cols, max_size=rows * cols))).reshape(rows, cols)
    free.flat[draw(st.integers(0, rows * cols - 1))] = True
    frame = MapFrame(
        draw(st.floats(-50, 50)), draw(st.floats(-50, 50)), draw(st.floats(-math.pi, math.pi, allow_nan=False))
    )
    model = grid_model(
        rows, cols, headings, cell_size=draw(st.sampled_from([0.05, 0.5, 1.0, 2.5])), frame=frame, free=free
    )
    weights = draw(
        st.lists(
            st.one_of(st.just(0.0), st.floats(1e-6, 1.0)), min_size=model.n_states, max_size=model.n_states
        ).filter(lambda w: sum(w) > 0)
    )
    belief = np.array(weights) / sum(weights)
    return model, belief


@settings(max_examples=150, deadline=None)
@given(models_and_beliefs())
def test_covariance_properties(case: tuple[Model, np.ndarray]) -> None:
    model, belief = case
    estimate = belief_pose(model, belief)
    cov = estimate.matrix
    assert len(estimate.covariance) == 36
    np.testing.assert_array_equal(cov, cov.T)
    for axis in (2, 3, 4):  # z, rot_x, rot_y
        assert not cov[axis].any() and not cov[:, axis].any()
    planar = cov[np.ix_([X, Y, YAW], [X, Y, YAW])]
    assert np.linalg.eigvalsh(planar).min() > 0.0  # never singular
    assert np.linalg.eigvalsh(cov).min() >= -1e-9
    expected, antipodal = loop_covariance(model, belief)
    if antipodal:  # a deviation of ±pi: the position-yaw terms' sign is a rounding's choice
        cov[[X, Y], YAW] = cov[YAW, [X, Y]] = expected[[X, Y], YAW] = expected[YAW, [X, Y]] = 0.0
    np.testing.assert_allclose(cov, expected, rtol=1e-9, atol=1e-9)
    assert model.grid is not None and estimate.pose == state_pose(model.grid, int(np.argmax(belief)))
    assert -math.pi < estimate.pose.yaw <= math.pi


def test_wrap_angle() -> None:
    np.testing.assert_allclose(wrap_angle(np.array([-PI, PI, 3 * PI, 0.5, -3.5 * PI])), [PI, PI, PI, 0.5, 0.5 * PI])


# --- the ROS message body ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("yaw", "z", "w"),
    [
        (0.0, 0.0, 1.0),
        (PI / 2, math.sqrt(0.5), math.sqrt(0.5)),
        (PI, 1.0, 0.0),
        (-PI / 2, -math.sqrt(0.5), math.sqrt(0.5)),
    ],
)
def test_ros_body(yaw: float, z: float, w: float) -> None:
    covariance = tuple(float(i) for i in range(36))
    body = pose_with_covariance_stamped(PoseEstimate(Pose(1.0, 2.0, yaw), covariance, 0, 1.0), frame_id="odom")
    assert body["header"] == {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": "odom"}
    pose = body["pose"]
    assert isinstance(pose, dict) and list(pose) == ["pose", "covariance"]
    assert pose["covariance"] == list(covariance)
    assert pose["pose"]["position"] == {"x": 1.0, "y": 2.0, "z": 0.0}
    orientation = pose["pose"]["orientation"]
    assert list(orientation) == ["x", "y", "z", "w"]
    assert orientation["x"] == 0.0 and orientation["y"] == 0.0
    assert orientation["z"] == pytest.approx(z) and orientation["w"] == pytest.approx(w, abs=1e-15)


def test_estimate_as_json_is_plain_data() -> None:
    model = grid_model()
    data = belief_pose(model, belief_on(model, {"0,0,1": 0.25, "1,1,1": 0.75})).as_json()
    assert list(data) == ["x", "y", "yaw", "covariance"]
    assert json.loads(json.dumps(data, allow_nan=False)) == data
    assert all(type(v) is float for v in data["covariance"])  # type: ignore[attr-defined]


# --- the command line ------------------------------------------------------------------------------


@pytest.fixture
def kitchen_belief(tmp_path: Path) -> Path:
    path = tmp_path / "belief.json"
    path.write_text(json.dumps({"1,1,1": 0.7, "1,2,1": 0.3}))
    return path


def test_pose_json(runner: CliRunner, kitchen_belief: Path) -> None:
    result = runner.invoke(app, ["pose", str(MAPS / "kitchen.yaml"), "--belief", str(kitchen_belief)])
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert data["state"] == "1,1,1" and data["probability"] == pytest.approx(0.7)
    assert list(data["pose"]) == ["x", "y", "yaw", "covariance"]
    assert data["pose"]["yaw"] == pytest.approx(0.0)  # heading 1 is east
    cov = np.array(data["pose"]["covariance"]).reshape(6, 6)
    assert cov[X, X] > cov[Y, Y] > 0  # the belief is split along a row: x spreads


def test_pose_ros_is_the_message_body(runner: CliRunner, kitchen_belief: Path) -> None:
    args = ["pose", str(MAPS / "kitchen.yaml"), "--belief", str(kitchen_belief)]
    result = runner.invoke(app, [*args, "--format", "ros", "--frame-id", "map", "--force"])  # 0.7: not localized
    assert result.exit_code == 0, result.output
    body = yaml.safe_load(result.stdout)
    assert body["header"] == {"stamp": "now", "frame_id": "map"}
    assert set(body["pose"]) == {"pose", "covariance"}
    assert set(body["pose"]["pose"]) == {"position", "orientation"}
    assert set(body["pose"]["pose"]["orientation"]) == {"x", "y", "z", "w"}
    assert len(body["pose"]["covariance"]) == 36
    floats = [*body["pose"]["covariance"], *body["pose"]["pose"]["position"].values()]
    assert all(type(v) is float for v in floats)  # float64 fields take no ints
    assert "!!" not in result.stdout
    plain = json.loads(runner.invoke(app, args).stdout)
    assert body["pose"]["covariance"] == pytest.approx(plain["pose"]["covariance"])
    assert body["pose"]["pose"]["position"]["x"] == pytest.approx(plain["pose"]["x"])


def test_pose_of_a_model_without_a_grid_is_refused(runner: CliRunner) -> None:
    result = runner.invoke(app, ["pose", str(DATA / "pomdp" / "tiger.pomdp")])
    assert result.exit_code == 2
    assert "has no grid, so its states have no pose" in result.stderr
    assert "Traceback" not in result.output


# --- the "pose" of the other --json outputs --------------------------------------------------------


def _is_pose(data: object) -> bool:
    return isinstance(data, dict) and list(data) == ["x", "y", "yaw", "covariance"] and len(data["covariance"]) == 36


def test_show_json_carries_the_pose(runner: CliRunner, kitchen_belief: Path) -> None:
    result = runner.invoke(app, ["show", str(MAPS / "kitchen.yaml"), "--belief", str(kitchen_belief), "--json"])
    assert result.exit_code == 0, result.output
    most_likely = json.loads(result.stdout)["most_likely"]
    assert most_likely["state"] == "1,1,1" and _is_pose(most_likely["pose"])
    pose = json.loads(runner.invoke(app, ["pose", str(MAPS / "kitchen.yaml"), "--belief", str(kitchen_belief)]).stdout)
    assert most_likely["pose"] == pose["pose"]


def test_show_json_without_a_grid_has_a_null_pose(runner: CliRunner) -> None:
    result = runner.invoke(app, ["show", str(DATA / "pomdp" / "tiger.pomdp"), "--json"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["most_likely"]["pose"] is None


def test_plan_json_carries_the_pose_of_the_expected_final_belief(runner: CliRunner) -> None:
    from beliefloc.files.model_sources import open_model
    from beliefloc.planning.best_first import plan

    result = runner.invoke(app, ["plan", str(MAPS / "window-2x2.yaml"), "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert _is_pose(data["pose"])
    model = open_model(MAPS / "window-2x2.yaml")
    found = plan(model, np.full(model.n_states, 1 / model.n_states))
    assert found.belief is not None
    assert data["pose"] == belief_pose(model, found.belief).as_json()
    assert data["pose"]["covariance"][35] == pytest.approx(UNIFORM_YAW_VARIANCE)  # one heading


def test_simulate_json_carries_the_final_pose(runner: CliRunner) -> None:
    args = ["simulate", str(MAPS / "window-2x2.yaml"), "-n", "2", "--seed", "0", "--json", "--no-timings"]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    for episode in json.loads(result.stdout)["episodes"]:
        assert _is_pose(episode["pose"])
        r, c = (int(v) for v in episode["final"].split(","))
        assert episode["pose"]["x"] == pytest.approx(c + 0.5) and episode["pose"]["y"] == pytest.approx(1.5 - r)
    assert runner.invoke(app, args).stdout == result.stdout
