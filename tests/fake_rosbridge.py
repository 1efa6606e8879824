"""A fake ``rosbridge_server`` for the live link's tests: the rosbridge v2 JSON protocol over a
websocket (``websockets``), with the continuous simulated robot of issue 26 behind it.

It speaks the part of the protocol a client of a robot needs (rosbridge v2.0, ROSBRIDGE_PROTOCOL.md):
``advertise``/``unadvertise`` and ``publish`` from the client, ``subscribe``/``unsubscribe`` to the
server's topics, and ``publish`` from the server to each subscriber; an op it does not know is
answered with a ``status`` message of level ``error``, as rosbridge does. Every message a client
publishes is kept in :attr:`FakeRosbridge.published` (topic, body), in order.

The robot: a :class:`~beliefloc.continuous.world.ContinuousRobot` whose base follows the last
``/cmd_vel`` (held until the next one: no watchdog, so a client that never says stop leaves it
driving). Simulated time runs ``speedup`` times faster than the wall clock: each step integrates
``dt`` simulated seconds, then publishes ``/odom`` (``nav_msgs/Odometry``, frame ``odom``, child
``base_link``), every ``scan_every`` steps ``/scan`` (``sensor_msgs/LaserScan``; ``+inf`` sent as
``null``, as rosbridge's JSON encoder does) and the detections of a Look on the detection topic.

Faults, for the bad cases: ``stuck`` (the base ignores ``/cmd_vel``), ``silent`` (topics never
published), ``scan_frame`` (the scan's ``frame_id``), ``drop_after_cmd`` (close every connection
once after that many ``/cmd_vel`` messages; new connections are accepted).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import math
import threading
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from websockets.asyncio.server import ServerConnection, serve
from websockets.exceptions import ConnectionClosed

from beliefloc.continuous.world import ContinuousRobot, ContinuousWorld, LaserSpec, MotionError, WorldConfig
from beliefloc.robots.continuous_robot import ContinuousReadingRobot
from beliefloc.robots.readings import ReadingBinner
from beliefloc.semantic_map import SemanticMap, compile_model, regions

LASER = LaserSpec(
    beams=360, angle_min=-math.pi, angle_max=math.pi * 179 / 180, range_min=0.05, range_sd=0.01, mount=(0.0, 0.0, 0.0)
)
"""One beam a degree all round, from the base's centre (frame ``base_link``)."""


def kitchen_like_world(smap: SemanticMap, rng: np.random.Generator) -> ContinuousWorld:
    """The world of a hand-drawn map (its blocked cells, the grid's edge a wall) or of its occupancy
    map, with a gentle base: motion errors of 2 % of each small step."""
    config = WorldConfig(
        laser=LASER,
        motion_error=MotionError(translation=0.02, rotation=0.02, per_turn=0.0, per_metre=0.0),
        odometry_error=MotionError(translation=0.005, rotation=0.005, per_turn=0.0, per_metre=0.0),
        robot_radius=0.1,
    )
    if smap.occupancy_map is not None:
        return ContinuousWorld(smap.occupancy_map, config, rng)
    k = 24  # pixels of 1/24 cell (5 cm on the kitchen): a cell's worth of pixel is too coarse for a robot
    blocked = np.kron(~np.asarray(smap.free, dtype=bool), np.ones((k, k), dtype=bool))
    return ContinuousWorld(regions.blocked_image(blocked, smap.grid.cell_size / k), config, rng)


@dataclass
class Faults:
    stuck: bool = False
    silent: frozenset[str] = frozenset()
    scan_frame: str = "base_link"
    drop_after_cmd: int | None = None


@dataclass
class _Client:
    socket: ServerConnection
    subscriptions: set[str] = field(default_factory=set)


class FakeRosbridge:
    """See the module. ``start()`` serves on 127.0.0.1 (a free port: :attr:`url`) from a thread."""

    def __init__(
        self,
        robot: ContinuousRobot,
        reader: ContinuousReadingRobot | None = None,
        *,
        faults: Faults | None = None,
        dt: float = 0.05,
        speedup: float = 10.0,
        scan_every: int = 2,
        detection_topic: str = "/detections",
        detection_form: str = "vision",
        detection_sensor: str = "look",
    ) -> None:
        self.robot = robot
        self.reader = reader
        self.faults = faults or Faults()
        self.dt = dt
        self.speedup = speedup
        self.scan_every = scan_every
        self.detection_topic = detection_topic
        self.detection_form = detection_form
        self.detection_sensor = detection_sensor
        self.published: list[tuple[str, dict[str, Any]]] = []
        self.ops: list[dict[str, Any]] = []
        self.velocity = (0.0, 0.0)
        self.sim_time = 1000.0
        self.port = 0
        self.connections = 0
        self._cmds = 0
        self._dropped = False
        self._clients: list[_Client] = []
        self._lock = threading.Lock()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None
        self._ready = threading.Event()
        self._stop: asyncio.Event | None = None

    # --- life -----------------------------------------------------------------------------------

    @property
    def url(self) -> str:
        return f"ws://127.0.0.1:{self.port}"

    def start(self) -> FakeRosbridge:
        self._thread = threading.Thread(target=lambda: asyncio.run(self._main()), daemon=True)
        self._thread.start()
        if not self._ready.wait(10):
            raise RuntimeError("the fake rosbridge did not start")
        return self

    def stop(self) -> None:
        if self._loop is not None and self._stop is not None:
            self._loop.call_soon_threadsafe(self._stop.set)
        if self._thread is not None:
            self._thread.join(10)

    def __enter__(self) -> FakeRosbridge:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def messages(self, topic: str) -> list[dict[str, Any]]:
        with self._lock:
            return [body for name, body in self.published if name == topic]

    async def _main(self) -> None:
        self._loop = asyncio.get_running_loop()
        self._stop = asyncio.Event()
        async with serve(self._serve, "127.0.0.1", 0) as server:
            self.port = next(iter(server.sockets)).getsockname()[1]
            self._ready.set()
            stepping = asyncio.create_task(self._simulate())
            await self._stop.wait()
            stepping.cancel()

    # --- the protocol ---------------------------------------------------------------------------

    async def _serve(self, socket: ServerConnection) -> None:
        client = _Client(socket)
        self._clients.append(client)
        self.connections += 1
        try:
            async for raw in socket:
                try:
                    message = json.loads(raw)
                except ValueError:
                    await self._status(client, f"not JSON: {str(raw)[:60]}")
                    continue
                await self._handle(client, message)
        except ConnectionClosed:
            pass
        finally:
            self._clients.remove(client)

    async def _handle(self, client: _Client, message: Mapping[str, Any]) -> None:
        op = message.get("op")
        with self._lock:
            self.ops.append(dict(message))
        topic = str(message.get("topic", ""))
        if op == "subscribe":
            client.subscriptions.add(topic)
        elif op == "unsubscribe":
            client.subscriptions.discard(topic)
        elif op in ("advertise", "unadvertise"):
            pass
        elif op == "publish":
            body = message.get("msg", {})
            with self._lock:
                self.published.append((topic, body))
            if topic == "/cmd_vel":
                self.velocity = (float(body["linear"]["x"]), float(body["angular"]["z"]))
                self._cmds += 1
                drop = self.faults.drop_after_cmd
                if drop is not None and self._cmds >= drop and not self._dropped:
                    self._dropped = True
                    for other in list(self._clients):
                        await other.socket.close()
        else:
            await self._status(client, f"unknown op {op!r}")

    async def _status(self, client: _Client, text: str) -> None:
        await client.socket.send(json.dumps({"op": "status", "level": "error", "msg": text}))

    async def _send(self, topic: str, body: Mapping[str, Any]) -> None:
        if topic in self.faults.silent:
            return
        text = json.dumps({"op": "publish", "topic": topic, "msg": body})
        for client in list(self._clients):
            if topic in client.subscriptions:
                with contextlib.suppress(ConnectionClosed):
                    await client.socket.send(text)

    # --- the robot ------------------------------------------------------------------------------

    async def _simulate(self) -> None:
        step = 0
        while True:
            await asyncio.sleep(self.dt / self.speedup)
            forward, turn = self.velocity
            if (forward or turn) and not self.faults.stuck:
                self.robot.drive((forward * self.dt, 0.0, turn * self.dt))
            self.sim_time += self.dt
            step += 1
            await self._send("/odom", self._odometry())
            if step % self.scan_every == 0:
                await self._send("/scan", self._scan())
                if self.reader is not None:
                    await self._send(self.detection_topic, self._detections())

    def look(self) -> list[str]:
        """The classes the robot's detector sees now (:func:`_seen`)."""
        assert self.reader is not None
        return _seen(self.robot, self.reader.smap, self.detection_sensor)

    def _header(self, frame: str) -> dict[str, Any]:
        sec = int(self.sim_time)
        return {
            "stamp": {"sec": sec, "nanosec": round((self.sim_time - sec) * 1e9) % 1_000_000_000},
            "frame_id": frame,
        }

    def _odometry(self) -> dict[str, Any]:
        x, y, yaw = (float(v) for v in self.robot.odometry)
        forward, turn = self.velocity if not self.faults.stuck else (0.0, 0.0)
        return {
            "header": self._header("odom"),
            "child_frame_id": "base_link",
            "pose": {
                "pose": {
                    "position": {"x": x, "y": y, "z": 0.0},
                    "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)},
                },
                "covariance": [0.0] * 36,
            },
            "twist": {
                "twist": {"linear": {"x": forward, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": turn}},
                "covariance": [0.0] * 36,
            },
        }

    def _scan(self) -> dict[str, Any]:
        laser = self.robot.world.config.laser
        ranges = self.robot.scan()
        return {
            "header": self._header(self.faults.scan_frame),
            "angle_min": laser.angle_min,
            "angle_max": laser.angle_max,
            "angle_increment": laser.angle_increment,
            "time_increment": 0.0,
            "scan_time": laser.scan_time,
            "range_min": laser.range_min,
            "range_max": laser.range_max,
            "ranges": [None if not math.isfinite(r) else float(r) for r in ranges],
            "intensities": [],
        }

    def _detections(self) -> dict[str, Any]:
        classes = self.look()
        if self.detection_form == "string":
            return {"data": ", ".join(classes)}
        return {
            "header": self._header("camera"),
            "detections": [
                {"results": [{"hypothesis": {"class_id": name, "score": 0.9}, "pose": {}}], "bbox": {}}
                for name in classes
            ],
        }


def _seen(robot: ContinuousRobot, smap: SemanticMap, sensor_name: str) -> list[str]:
    """The classes a Look sees from the robot's true pose: a landmark within the sensor's field of
    view and range, or in the robot's own cell (the robot stands beside it; the map's model sees a
    landmark of the robot's cell whatever the heading). No occlusion: the test maps have no inner walls."""
    spec = smap.sensors[sensor_name]
    grid = smap.grid
    x, y, yaw = (float(v) for v in robot.pose)
    half_fov = math.radians(spec.effective_fov(grid.headings)) / 2
    layout = robot_layout(smap)
    seen = []
    for landmark in smap.landmarks:
        if landmark.class_ not in spec.classes:
            continue
        if landmark.position is not None:
            lx, ly = float(landmark.position[0]), float(landmark.position[1])
        else:
            lx, ly = (float(v) for v in layout.cell_centre(*landmark.cell))
        d = math.hypot(lx - x, ly - y)
        off = abs(math.remainder(math.atan2(ly - y, lx - x) - yaw, 2 * math.pi))
        own_cell = max(abs(lx - x), abs(ly - y)) < grid.cell_size / 2
        if own_cell or (off <= half_fov and (spec.range is None or d <= spec.range)):
            seen.append(landmark.class_)
    return sorted(set(seen))


def kitchen_server(seed: int, start: tuple[float, float, float], binner: ReadingBinner, **kwargs: Any) -> FakeRosbridge:
    """A fake rosbridge over the kitchen's continuous robot standing at ``start`` (map frame)."""
    smap = binner.smap
    world = kitchen_like_world(smap, np.random.default_rng(seed))
    robot = ContinuousRobot(world, start)
    return FakeRosbridge(robot, ContinuousReadingRobot(robot, smap, binner), **kwargs)


def robot_layout(smap: SemanticMap) -> Any:
    """The map's compiled grid layout (cached per map name: compiling is the slow part)."""
    if smap.name not in _LAYOUTS:
        _LAYOUTS[smap.name] = compile_model(smap).grid
    return _LAYOUTS[smap.name]


_LAYOUTS: dict[str, Any] = {}
