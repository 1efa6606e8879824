"""Issue 27, "the same laser model in the loop", on the ROS link: with ``localize --rosbridge
--filter lattice`` a scan sensor is answered with the whole LaserScan and the laser's mount (the
whole-scan reading's ``mount`` field), binned for the model as the beams are and scored in full by
the lattice filter with that mount."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from beliefloc import compile_model, load_map
from beliefloc.belief import uniform
from beliefloc.continuous.lattice_scan import LatticeScanModel
from beliefloc.errors import InvalidValueError, ReplyError
from beliefloc.model import Model
from beliefloc.robots.belief_filter import LatticeFilter
from beliefloc.robots.readings import ReadingBinner, full_scan_ranges
from beliefloc.ros.sensors import Scan, beam_ranges, whole_scan_reading
from beliefloc.semantic_map.sections import ScanSensor

from .conftest import MAPS

TB3 = MAPS / "tb3-sandbox.yaml"


@pytest.fixture(scope="module")
def tb3() -> ReadingBinner:
    smap = load_map(TB3)
    return ReadingBinner(smap, compile_model(smap))


def _laser_scan(rng: np.random.Generator, n: int = 720) -> Scan:
    """A LaserScan of the TurtleBot4's kind: a full turn, a quarter no return, some NaN and -inf."""
    ranges = rng.uniform(0.2, 3.4, n)
    ranges[rng.random(n) < 0.25] = math.inf
    ranges[rng.choice(n, 5, replace=False)] = math.nan
    ranges[rng.choice(n, 5, replace=False)] = -math.inf
    return Scan("rplidar_link", 0, -3.124, (3.1416 + 3.124) / (n - 1), 0.15, 3.5, tuple(ranges.tolist()))


def test_a_laserscan_becomes_a_whole_scan_reading_by_rep_117() -> None:
    scan = Scan("laser", 0, -1.0, 0.5, 0.15, 12.0, (1.0, math.inf, math.nan, -math.inf, -2.0, 13.0))
    reading = whole_scan_reading(scan, (-0.04, 0.01, math.pi / 2), "/scan")
    assert reading == {
        "angle_min": -1.0,
        "angle_increment": 0.5,
        "ranges": [1.0, None, None, 0.0, None, 13.0],
        "range_min": 0.15,
        "range_max": 12.0,
        "mount": [-0.04, 0.01, math.pi / 2],
    }


@pytest.mark.parametrize(
    ("scan", "says"),
    [
        (Scan("laser", 0, 0.0, 0.1, 0.1, math.inf, (1.0, 2.0)), "range_max inf"),
        (Scan("laser", 0, 0.0, 0.0, 0.1, 5.0, (1.0,)), "'angle_increment' is 0"),
        (Scan("laser", 0, 0.0, 0.1, 5.0, 5.0, (1.0, 2.0)), "range_min < range_max"),
    ],
)
def test_a_laserscan_that_cannot_be_read_whole_is_refused_naming_the_topic(scan: Scan, says: str) -> None:
    with pytest.raises(ReplyError, match=f"^topic /scan: .*{says}"):
        whole_scan_reading(scan, (0.0, 0.0, 0.0), "/scan")


@pytest.mark.parametrize("seed", range(4))
def test_a_mounted_whole_scan_bins_as_the_link_reads_its_beams(tb3: ReadingBinner, seed: int) -> None:
    """The laser at +90° and 4 cm back (the TurtleBot4's): the whole scan with its mount bins to the
    observation the link's beam-by-beam reading gives."""
    rng = np.random.default_rng(seed)
    scan = _laser_scan(rng)
    mount = (-0.04, 0.0, math.pi / 2)
    action = tb3.model.action("scan")
    beams = [float(b) for b in tb3.describe(action)[0]["beams"]]
    by_beam = tb3.observation(action, {"scan": beam_ranges(scan, beams, mount, "/scan")})
    whole = whole_scan_reading(scan, mount, "/scan")
    assert tb3.observation(action, {"scan": whole}) == by_beam
    ((got, got_mount),) = tb3.full_scans(action, {"scan": whole}).values()
    assert got_mount == mount and got.ranges.size == len(scan.ranges)
    sensor = tb3.sensors(action)[0].sensor
    assert isinstance(sensor, ScanSensor)
    link = beam_ranges(scan, beams, mount, "/scan")
    assert full_scan_ranges(sensor, got, mount) == link
    assert full_scan_ranges(sensor, got) != link  # without the mount, other rays: the mount matters


@pytest.mark.parametrize("mount", [[0.1, 0.2], [0.0, 0.0, "up"], "front", [0.0, math.inf, 0.0]])
def test_a_bad_mount_is_refused_naming_the_field(tb3: ReadingBinner, mount: Any) -> None:
    whole = whole_scan_reading(_laser_scan(np.random.default_rng(0)), (0.0, 0.0, 0.0), "/scan")
    whole["mount"] = mount
    with pytest.raises(InvalidValueError, match=r"^scan: 'mount' should be the laser's pose on the base"):
        tb3.observation("scan", {"scan": whole})


def test_the_lattice_filter_scores_a_whole_scan_with_its_mount(tb3: ReadingBinner) -> None:
    model: Model = tb3.model
    tracker = LatticeFilter(tb3)
    lattice = tracker.lattice
    scan = _laser_scan(np.random.default_rng(5))
    mount = (-0.04, 0.0, math.pi / 2)
    whole = whole_scan_reading(scan, mount, "/scan")
    action = model.action("scan")
    observation = tb3.observation(action, {"scan": whole})
    tracker.start(uniform(model.n_states))
    tracker.correct(action, observation, {"scan": whole})
    fine = tracker.core.fine.copy()
    # the same update by hand: the scan's log-likelihood with the mount, at the filter's temper
    ((parsed, _),) = tb3.full_scans(action, {"scan": whole}).values()
    log = LatticeScanModel(lattice).log_likelihood(parsed, mount)
    tracker.start(uniform(model.n_states))
    parts = len(tracker.core.tables["scan"])
    tracker.core.correct("scan", action.observation.decode(observation), log, range(parts))
    np.testing.assert_allclose(fine, tracker.core.fine)
    unmounted = LatticeScanModel(lattice).log_likelihood(parsed)
    assert not np.allclose(log, unmounted)  # the mount moved the end points


# --- on the live link (a fake rosbridge) -----------------------------------------------------------


def test_the_link_answers_a_scan_with_the_whole_laserscan_when_asked() -> None:
    pytest.importorskip("websockets")
    pytest.importorskip("roslibpy")
    from beliefloc.pose import state_pose
    from beliefloc.robots.localize import Command
    from beliefloc.ros.bridge import BridgeSettings, RosbridgeRobot, RoslibpyLink

    from .fake_rosbridge import LASER, kitchen_server

    smap = load_map(MAPS / "kitchen.yaml")
    model = compile_model(smap)
    binner = ReadingBinner(smap, model)
    assert model.grid is not None
    start = state_pose(model.grid, model.states.index("1,1,1"))
    with kitchen_server(0, (start.x, start.y, start.yaw), binner) as fake:
        settings = BridgeSettings(detections_topic="/detections", settle=0.05, timeout=2.0, whole_scans=True)
        robot = RosbridgeRobot(binner, RoslibpyLink(fake.url, 2.0), settings)
        try:
            readings = robot.act(Command(1, model.action("scan"), None, None))
        finally:
            robot.link.close()
        pose = fake.robot.pose
        truth = float(fake.robot.world.scan_ranges(pose.reshape(1, 3), np.zeros(1))[0])
    whole = readings["scan"]
    assert isinstance(whole, dict) and len(whole["ranges"]) == LASER.beams and whole["mount"] == [0.0, 0.0, 0.0]
    ((scan, mount),) = binner.full_scans("scan", readings).values()
    assert mount == (0.0, 0.0, 0.0) and scan.ranges.size == LASER.beams
    ahead = whole["ranges"][round((0.0 - whole["angle_min"]) / whole["angle_increment"])]
    assert ahead == pytest.approx(truth, abs=0.05)  # the ray straight ahead reads the world's range
    binner.observation("scan", readings)  # bins as any reply does


@pytest.mark.slow
def test_a_lattice_session_on_the_link_scores_whole_scans_and_localizes(runner: Any, monkeypatch: Any) -> None:
    """``localize --rosbridge --filter lattice``: each scan goes to the lattice filter whole (360 rays,
    counted at the scan model) and the session localizes the kitchen's robot where it is."""
    pytest.importorskip("websockets")
    pytest.importorskip("roslibpy")
    import json

    from beliefloc.cli.app import app
    from beliefloc.pose import nonnegative_covariance, state_pose

    from .fake_rosbridge import LASER, kitchen_server

    sizes: list[int] = []
    score = LatticeScanModel.log_likelihood

    def counted(self: LatticeScanModel, scan: Any, *args: Any) -> np.ndarray:
        sizes.append(scan.ranges.size)
        return score(self, scan, *args)

    monkeypatch.setattr(LatticeScanModel, "log_likelihood", counted)
    smap = load_map(MAPS / "kitchen.yaml")
    model = compile_model(smap)
    assert model.grid is not None
    start = state_pose(model.grid, model.states.index("1,1,1"))
    with kitchen_server(0, (start.x, start.y, start.yaw), ReadingBinner(smap, model)) as fake:
        args = ["localize", str(MAPS / "kitchen.yaml"), "--rosbridge", fake.url, "--detections-topic", "/detections"]
        fast = ["--settle", "0.05", "--ros-timeout", "2", "--motion-timeout", "5", "--quiet", "--filter", "lattice"]
        result = runner.invoke(app, [*args, *fast])
        pose = fake.robot.pose
        [initial] = fake.messages("/initialpose")
    assert result.exit_code == 0, result.output
    outcome = json.loads(result.stdout.strip().splitlines()[-1])
    assert outcome["localized"]
    x, y = model.grid.cell_centre(*(int(v) for v in outcome["state"].split(",")[:2]))
    assert math.hypot(float(x) - pose[0], float(y) - pose[1]) < model.grid.cell_size
    assert set(sizes) == {LASER.beams}
    # AMCL is given the pose the result reports: the lattice's, within the declared state's cell
    reported = outcome["pose"]
    position = initial["pose"]["pose"]["position"]
    assert (position["x"], position["y"]) == pytest.approx((reported["x"], reported["y"]), abs=1e-12)
    # its covariance as `pose --format ros` writes one: no negative entry, for Rolling's AMCL
    assert initial["pose"]["covariance"] == pytest.approx(
        nonnegative_covariance(tuple(reported["covariance"])), abs=1e-12
    )
    assert min(initial["pose"]["covariance"]) >= 0.0
    assert math.hypot(reported["x"] - pose[0], reported["y"] - pose[1]) < model.grid.cell_size
