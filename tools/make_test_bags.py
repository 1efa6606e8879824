"""Write the committed test recordings of ``track --bag`` (tests/data/bags/).

    PYTHONPATH=. python tools/make_test_bags.py

A short TurtleBot4-like run (720 beams, laser at +90 degrees through shell_link, drifting 20 Hz
odometry, clutter) on Nav2's depot, in rosbag2 sqlite3 and MCAP storage and as a ROS 1 bag, plus its
truth; and small broken recordings for the bad-input tests. Deterministic (seeded).
"""

from __future__ import annotations

import shutil
import sqlite3
from pathlib import Path

from beliefloc.recordings.scenarios import Scenario, short_plan, simulate_scenario, write_scenario
from beliefloc.semantic_map.occupancy_map import load_occupancy

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "tests" / "data" / "bags"
DEPOT = ROOT / "maps" / "occupancy" / "depot.yaml"


def main() -> None:
    if OUT.exists():
        shutil.rmtree(OUT)
    OUT.mkdir(parents=True)
    run = simulate_scenario(load_occupancy(DEPOT), Scenario("depot_short", short_plan(), seed=7))
    write_scenario(run, OUT, "depot_short", ("sqlite3", "mcap", "ros1"))
    # broken: a scan with a zero angle_increment, odometry that jumps 100 m, no LaserScan topic
    _edited_copies(run)
    # broken: a folder without metadata.yaml
    nometa = OUT / "broken_no_metadata"
    shutil.copytree(OUT / "broken_no_scan", nometa)
    (nometa / "metadata.yaml").unlink()
    # broken: a .db3 that is not a database
    corrupt = OUT / "broken_corrupt_db3"
    corrupt.mkdir()
    shutil.copy(OUT / "depot_short_sqlite3" / "metadata.yaml", corrupt / "metadata.yaml")
    (corrupt / "depot_short_sqlite3.db3").write_bytes(b"SQLite format 3\x00" + bytes(range(256)) * 8)
    total = sum(f.stat().st_size for f in OUT.rglob("*") if f.is_file())
    print(f"wrote {OUT} ({total / 1024:.0f} KiB)")


def _edited_copies(run) -> None:  # type: ignore[no-untyped-def]
    import dataclasses

    import numpy as np

    from beliefloc.recordings.writer import write_run

    few = dataclasses.replace(
        run,
        scan_stamps=run.scan_stamps[:3],
        ranges=run.ranges[:3],
        scan_truth=run.scan_truth[:3],
        odom_stamps=run.odom_stamps[:10],
        odom_poses=run.odom_poses[:10].copy(),
        odom_truth=run.odom_truth[:10],
    )
    jump = dataclasses.replace(few, odom_poses=few.odom_poses.copy())
    jump.odom_poses[6:, 0] += 100.0
    write_run(jump, OUT / "broken_odometry_jump", "mcap")
    write_run(few, OUT / "broken_no_scan", "mcap", scan_topic="/scan")
    _drop_topic(OUT / "broken_no_scan", "/scan")
    write_run(few, OUT / "broken_zero_increment", "sqlite3")
    db = next((OUT / "broken_zero_increment").glob("*.db3"))
    _zero_increment(db)
    _ = np


def _drop_topic(folder: Path, topic: str) -> None:
    """Rewrite an MCAP bag without ``topic`` (through rosbags' reader and writer)."""
    from rosbags.highlevel import AnyReader
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    tmp = folder.with_name(folder.name + "_tmp")
    with AnyReader([folder], default_typestore=store) as reader, Writer(
        tmp, version=8, storage_plugin=StoragePlugin.MCAP
    ) as writer:
        conns = {}
        for conn in reader.connections:
            if conn.topic != topic:
                conns[conn.id] = writer.add_connection(conn.topic, conn.msgtype, typestore=store)
        for conn, stamp, raw in reader.messages():
            if conn.id in conns:
                writer.write(conns[conn.id], stamp, raw)
    shutil.rmtree(folder)
    tmp.rename(folder)
    for f in folder.iterdir():
        if f.name.startswith(tmp.name):
            f.rename(folder / f.name.replace(tmp.name, folder.name))
    meta = folder / "metadata.yaml"
    meta.write_text(meta.read_text().replace(tmp.name, folder.name))


def _zero_increment(db: Path) -> None:
    """Set angle_increment of the second scan to 0 in place (its CDR bytes)."""
    import struct

    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    con = sqlite3.connect(db)
    topic_id = con.execute("SELECT id FROM topics WHERE name = '/scan'").fetchone()[0]
    rows = con.execute("SELECT id, data FROM messages WHERE topic_id = ? ORDER BY timestamp", (topic_id,)).fetchall()
    row_id, data = rows[1]
    msg = store.deserialize_cdr(data, "sensor_msgs/msg/LaserScan")
    msg.angle_increment = 0.0
    data = bytes(store.serialize_cdr(msg, "sensor_msgs/msg/LaserScan"))
    con.execute("UPDATE messages SET data = ? WHERE id = ?", (data, row_id))
    con.commit()
    con.close()
    _ = struct


if __name__ == "__main__":
    main()
