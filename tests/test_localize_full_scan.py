"""A ``localize`` reply carrying a whole scan (issue 27, "the same laser model in the loop"): binned
as the per-beam form for the model, scored in full by the lattice filter."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from beliefloc import compile_model, load_map
from beliefloc.belief import uniform
from beliefloc.continuous.lattice_scan import LatticeScanModel
from beliefloc.continuous.likelihood_field import Scan
from beliefloc.continuous.pose_lattice import LatticeFilter as LatticeCore
from beliefloc.continuous.world import ContinuousRobot
from beliefloc.errors import InvalidValueError
from beliefloc.robots.belief_filter import LatticeFilter, ModelFilter
from beliefloc.robots.continuous_robot import ContinuousReadingRobot
from beliefloc.robots.localize import localize
from beliefloc.robots.readings import MAX_SCAN_BEAMS, ReadingBinner
from beliefloc.simulation.continuous_episode import ContinuousSetup, is_wrong, pose_errors, state_at
from beliefloc.simulation.strategies import PlannerSettings

ROOT = Path(__file__).resolve().parent.parent
TB3 = ROOT / "maps" / "tb3-sandbox.yaml"
KITCHEN = ROOT / "maps" / "kitchen.yaml"


@pytest.fixture(scope="module")
def tb3() -> ReadingBinner:
    smap = load_map(TB3)
    return ReadingBinner(smap, compile_model(smap))


def _whole(
    beams: dict[float, float | None], n: int, rng: np.random.Generator, clockwise: bool = False
) -> dict[str, Any]:
    """A whole scan of ``n`` rays around the robot with ``beams[degrees]`` on the ray at that angle and
    random ranges (some no return) elsewhere."""
    increment = (-1 if clockwise else 1) * 2 * math.pi / n
    start = math.pi if clockwise else -math.pi
    ranges: list[float | None] = [None if rng.uniform() < 0.2 else float(rng.uniform(0.05, 5.0)) for _ in range(n)]
    for degrees, value in beams.items():
        k = round((math.radians(degrees) - start) / increment) % n
        ranges[k] = value
    return {"angle_min": start, "angle_increment": increment, "ranges": ranges, "range_min": 0.1, "range_max": 3.5}


@pytest.mark.parametrize("seed", range(6))
def test_a_whole_scan_is_binned_as_the_per_beam_form_at_the_same_ranges(tb3: ReadingBinner, seed: int) -> None:
    rng = np.random.default_rng(seed)
    scan = tb3.model.action("scan")
    values = [None if rng.uniform() < 0.25 else float(rng.uniform(0.1, 3.4)) for _ in range(3)]
    by_angle = dict(zip((90.0, 0.0, -90.0), values, strict=True))  # the map's beams_deg
    per_beam = tb3.observation(scan, {"scan": values})
    for n, clockwise in ((360, False), (720, True), (7, False)):
        whole = _whole(by_angle, n, rng, clockwise)
        assert tb3.observation(scan, {"scan": whole}) == per_beam, (n, clockwise)
        assert set(tb3.full_scans(scan, {"scan": whole})) == {"scan"}
    assert tb3.full_scans(scan, {"scan": values}) == {}


def test_rep_117_limits_bin_as_the_ros_link_reads_them(tb3: ReadingBinner) -> None:
    """Nearer than ``range_min``: a wall right there (0 m); beyond ``range_max``, ``Infinity`` or
    ``null``: no wall -- as :func:`beliefloc.ros.sensors.beam_ranges` reads a LaserScan."""
    scan = tb3.model.action("scan")
    whole = _whole({90.0: 0.05, 0.0: 9.0, -90.0: math.inf}, 360, np.random.default_rng(0))
    assert tb3.observation(scan, {"scan": whole}) == tb3.observation(scan, {"scan": [0.0, None, None]})


BAD: list[tuple[dict[str, Any], str]] = [
    ({"angle_increment": 0.0}, "'angle_increment' is 0"),
    ({"angle_min": None}, "'angle_min' should be a finite number of radians"),
    ({"angle_increment": "0.1"}, "'angle_increment' should be a finite number"),
    ({"range_min": -0.1}, "'range_min' cannot be negative"),
    ({"range_min": 4.0}, "'range_max' (3.5) should exceed 'range_min' (4)"),
    ({"range_max": True}, "'range_max' should be a finite number of metres"),
    ({"ranges": []}, "'ranges' should be a non-empty list"),
    ({"ranges": [1.0, -2.0]}, "'ranges[1]' should be a non-negative number"),
    ({"ranges": [1.0, "far"]}, "'ranges[1]' should be a non-negative number"),
    ({"ranges": [0.5] * (MAX_SCAN_BEAMS + 1)}, f"more than the {MAX_SCAN_BEAMS} read"),
    ({"intensities": []}, "a whole scan has no field 'intensities'"),
    ({"angle_increment": 0.01}, "the sensor's beam at 90° (counter-clockwise from the heading) is outside the scan"),
]


@pytest.mark.parametrize(("change", "message"), BAD)
def test_a_malformed_whole_scan_is_one_line_naming_the_sensor_and_field(
    tb3: ReadingBinner, change: dict[str, Any], message: str
) -> None:
    whole = {"angle_min": 0.0, "angle_increment": 0.1, "ranges": [1.0] * 63, "range_min": 0.1, "range_max": 3.5}
    whole.update(change)
    with pytest.raises(InvalidValueError) as caught:
        tb3.observation("scan", {"scan": whole})
    text = str(caught.value)
    assert text.startswith("scan: ") and message in text and "\n" not in text


def test_a_missing_field_is_named(tb3: ReadingBinner) -> None:
    with pytest.raises(InvalidValueError, match=r"^scan: a whole scan needs 'range_min', 'range_max'"):
        tb3.observation("scan", {"scan": {"angle_min": 0.0, "angle_increment": 0.1, "ranges": [1.0]}})
    with pytest.raises(InvalidValueError, match=r"^scan: 'angle_increment' is 0"):
        tb3.full_scans(
            "scan", {"scan": {"angle_min": 0, "angle_increment": 0, "ranges": [1], "range_min": 0, "range_max": 1}}
        )


def test_a_bad_whole_scan_on_the_wire_exits_2_with_one_paragraph() -> None:
    """The command line: every scan answered with a zero ``angle_increment`` -> exit 2, one
    paragraph on stderr naming the action, the sensor and the field; no traceback."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "beliefloc", "localize", str(TB3), "--max-steps", "20", "-q"],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    assert proc.stdin is not None and proc.stdout is not None and proc.stderr is not None
    bad = {"angle_min": 0.0, "angle_increment": 0.0, "ranges": [1.0, 2.0], "range_min": 0.1, "range_max": 3.5}
    for line in proc.stdout:
        message = json.loads(line)
        if message["message"] != "action":
            break
        readings = {s["name"]: bad for s in message["sensors"]}
        proc.stdin.write(json.dumps({"seq": message["seq"], "readings": readings}) + "\n")
        proc.stdin.flush()
    code = proc.wait(timeout=120)
    err = proc.stderr.read().strip()
    assert code == 2, err
    assert "scan: 'angle_increment' is 0" in err and "Traceback" not in err
    assert "\n\n" not in err


# --- the lattice filter --------------------------------------------------------------------------


def test_the_other_parts_of_the_action_keep_their_tables_and_the_scan_is_tempered() -> None:
    """An action reading a scan and a look: the whole scan's log-likelihood stands for the scan's
    part, the look's table still counts, both tempered; ``p(o | belief)`` is the binned one."""
    smap = load_map(KITCHEN)
    tracker = LatticeFilter(ReadingBinner(smap, compile_model(smap)))
    tables = tracker.core.tables
    lattice = tracker.lattice
    core = LatticeCore(lattice, {"both": [*tables["scan"], *tables["look"]]}, {}, tracker.core.noise)
    rng = np.random.default_rng(5)
    fine = rng.dirichlet(np.ones(lattice.n_poses))
    core.fine = fine.copy()
    digits = [1, 0, 1, 0, 0]  # scan wall_0.2-0.8; the look sees the fire extinguisher
    log = rng.normal(-40.0, 5.0, lattice.n_poses)
    _, probability = core.correct("both", digits, log, [0])
    look = np.prod([t[:, d] for t, d in zip(tables["look"], digits[1:], strict=True)], axis=0)
    expected = fine * (look * np.exp(log - log.max())) ** core.temper
    assert core.fine == pytest.approx(expected / expected.sum(), rel=1e-6)
    binned = np.prod([t[:, d] for t, d in zip(core.tables["both"], digits, strict=True)], axis=0)
    assert probability == pytest.approx(float(fine @ binned))


def test_the_states_filter_reads_the_binned_beams_of_a_whole_scan(tb3: ReadingBinner) -> None:
    whole = _whole({90.0: 0.45, 0.0: None, -90.0: 1.5}, 360, np.random.default_rng(2))
    scan = tb3.model.action("scan")
    observation = tb3.observation(scan, {"scan": whole})
    a, b = ModelFilter(tb3.model), ModelFilter(tb3.model)
    assert a.correct(scan, observation, {"scan": whole})[0] == pytest.approx(b.correct(scan, observation)[0])


@pytest.mark.parametrize("path", [TB3, KITCHEN], ids=["tb3-sandbox", "kitchen"])
def test_one_whole_scan_puts_the_truth_among_the_most_likely_poses(path: Path) -> None:
    """From a uniform belief, one noiseless 360-ray scan taken at a lattice pose: that pose scores
    within 2 nats of the best (a symmetric twin may match it), and the belief around it gains.
    (The kitchen's image is one pixel a cell: its field is computed on finer pixels, distances to
    the walls' faces -- the square room's twins score alike.)"""
    smap = load_map(path)
    binner = ReadingBinner(smap, compile_model(smap))
    tracker = LatticeFilter(binner)
    lattice = tracker.lattice
    poses = lattice.pose_array
    grid = binner.model.grid
    assert grid is not None
    setup = ContinuousSetup(smap, range_noise=0.0)
    world = setup.world(np.random.default_rng(0))
    model = LatticeScanModel(lattice)
    rng = np.random.default_rng(11)
    for truth in rng.choice(lattice.n_poses, 5, replace=False).tolist():
        x, y, yaw = poses[truth]
        mx, my = grid.frame.to_map(x, y)
        map_yaw = yaw + grid.frame.yaw
        angles = -math.pi + 2 * math.pi / 360 * np.arange(360)
        ranges = world.scan_ranges(np.tile([float(mx), float(my), float(map_yaw)], (360, 1)), angles)
        scan = Scan(-math.pi, 2 * math.pi / 360, np.where(np.isneginf(ranges), 0.0, ranges), 0.01, 12.0)
        log = model.log_likelihood(scan)
        assert log.max() - log[truth] < 2.0
        turned = np.abs(np.remainder(poses[:, 2] - yaw + math.pi, 2 * math.pi) - math.pi)
        near = (np.hypot(poses[:, 0] - x, poses[:, 1] - y) < 0.3) & (turned < math.radians(20))
        tracker.start(uniform(binner.model.n_states))
        before = tracker.core.fine[near].sum()
        parts = len(tracker.core.tables["scan"])
        tracker.core.correct("scan", [0] * parts, log, range(parts))
        # a scan counts as EFFECTIVE_BEAMS (7) beams at the filter's weight (TEMPER, 0.7): still a
        # strong lift
        assert tracker.core.fine[near].sum() > 4 * before


@pytest.mark.slow
@pytest.mark.parametrize("path", [TB3, KITCHEN], ids=["tb3-sandbox", "kitchen"])
def test_a_continuous_robot_answering_whole_scans_localizes_and_is_never_confidently_wrong(path: Path) -> None:
    smap = load_map(path)
    model = compile_model(smap)
    setup = ContinuousSetup(smap, clutter=0.05)
    binner = setup.binner(model)
    tracker = LatticeFilter(binner)
    grid = model.grid
    assert grid is not None
    right = exact = 0
    episodes = 4
    for episode in range(episodes):
        world = setup.world(np.random.default_rng([27, episode]))
        robot = ContinuousRobot(world, world.random_poses(1)[0])
        reading = ContinuousReadingRobot(robot, smap, binner, full_scans=360)
        outcome = localize(
            model,
            uniform(model.n_states),
            reading,
            binner,
            settings=PlannerSettings(time_limit=0.5),
            max_steps=200,
            rng=np.random.default_rng([27, episode, 1]),
            confirm=True,
            belief_filter=tracker,
        )
        state = int(np.argmax(outcome.belief))
        position, yaw = pose_errors(grid, state, robot.pose)
        assert not (outcome.localized and is_wrong(grid, position, yaw)), (episode, position, yaw)
        # the right place: the truth within a cell of the declared cell's centre and within three
        # quarters of a heading sector of its heading (a robot on a border is declared either side)
        right += outcome.localized and position <= grid.cell_size and yaw <= 0.75 * 2 * math.pi / grid.headings
        exact += outcome.localized and state == state_at(grid, robot.pose)
    assert right == episodes
    assert exact >= episodes // 2
