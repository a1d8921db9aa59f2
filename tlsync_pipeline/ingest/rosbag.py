"""ROS bags (ROS 1 ``.bag``, ROS 2 folders): nav_msgs/Odometry and sensor_msgs/NavSatFix.

Read with the pure-Python ``rosbags`` package (the optional extra
``tlsync[rosbag]``; no ROS installation needed). Times are the messages'
header stamps (the bag's receive time when a stamp is zero); messages are
sorted by stamp, since a bag stores them in arrival order. NavSatFix
altitude is above the WGS84 ellipsoid by the message's definition; fixes
with status -1 (no fix) are dropped. Odometry positions (pose.pose.position)
are local metres, placed in the world frame by the project's rigid transform.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.ingest.reader import Reader
from tlsync_pipeline.ingest.records import (
    GEODETIC,
    LOCAL,
    LogRecords,
    check_geodetic,
    make_records,
)

ODOMETRY = "nav_msgs/msg/Odometry"
NAVSATFIX = "sensor_msgs/msg/NavSatFix"
UNIT = "message"
NO_FIX = "NavSatFix status -1 (no fix)"


def stamp_seconds(stamp, receive_ns: int) -> float:
    """Seconds of a builtin_interfaces/Time, or the receive time (ns) when the stamp is zero."""
    sec = float(stamp.sec) + float(stamp.nanosec) * 1e-9
    return sec if sec > 0 else receive_ns * 1e-9


def odometry_row(msg, receive_ns: int = 0) -> tuple[float, float, float, float]:
    """(t, x, y, z) of a nav_msgs/Odometry message."""
    p = msg.pose.pose.position
    return stamp_seconds(msg.header.stamp, receive_ns), float(p.x), float(p.y), float(p.z)


def navsatfix_row(msg, receive_ns: int = 0) -> tuple[float, float, float, float] | None:
    """(t, lat, lon, alt) of a sensor_msgs/NavSatFix message, None when it has no fix."""
    if msg.status.status < 0:
        return None
    return stamp_seconds(msg.header.stamp, receive_ns), float(msg.latitude), float(msg.longitude), float(msg.altitude)


def read_rosbag(path: str | Path, topic: str | None = None) -> LogRecords:
    """Read the Odometry or NavSatFix messages of one topic (the only such topic when not given)."""
    path = Path(path)
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise InputError(f"{path}: reading ROS bags needs the optional extra: pip install 'tlsync[rosbag]'") from None
    bag = path.parent if path.is_file() and (path.parent / "metadata.yaml").exists() else path
    try:
        with AnyReader([bag], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
            usable = {c.topic: c.msgtype for c in reader.connections if c.msgtype in (ODOMETRY, NAVSATFIX)}
            if topic is None:
                if len(usable) != 1:
                    found = ", ".join(f"{t} ({m})" for t, m in sorted(usable.items())) or "none"
                    raise InputError(f"{path}: {'several' if usable else 'no'} Odometry/NavSatFix topics ({found}); name one with --topic (or [target] topic)")
                topic = next(iter(usable))
            if topic not in usable:
                raise InputError(f"{path}: no Odometry/NavSatFix topic {topic!r}; usable topics: {', '.join(sorted(usable)) or 'none'}")
            msgtype = usable[topic]
            connections = [c for c in reader.connections if c.topic == topic]
            rows, numbers, dropped = [], [], {}
            for number, (conn, receive_ns, raw) in enumerate(reader.messages(connections=connections), start=1):
                msg = reader.deserialize(raw, conn.msgtype)
                row = odometry_row(msg, receive_ns) if msgtype == ODOMETRY else navsatfix_row(msg, receive_ns)
                if row is None:
                    dropped.setdefault(NO_FIX, []).append(number)
                    continue
                if not np.isfinite(row).all():
                    dropped.setdefault("non-finite position", []).append(number)
                    continue
                if msgtype == NAVSATFIX:
                    check_geodetic(path, row[1], row[2], row[3], number, f"{topic} {UNIT}")
                rows.append(row)
                numbers.append(number)
    except InputError:
        raise
    except Exception as exc:  # rosbags raises its own errors, sqlite3/struct errors on damaged files
        raise InputError(f"{path}: cannot read as a ROS bag: {exc}") from None
    order = np.argsort([r[0] for r in rows], kind="stable")
    rows, numbers = [rows[i] for i in order], [numbers[i] for i in order]
    frame = GEODETIC if msgtype == NAVSATFIX else LOCAL
    return make_records(path, "rosbag", frame, rows, numbers, unit=f"{topic} {UNIT}", dropped=dropped)


BAG_MAGIC = (b"#ROSBAG V2.0", b"\x89MCAP", b"SQLite format 3\x00")
READER = Reader("rosbag", "ROS bag (ROS 1 .bag, ROS 2 folder with metadata.yaml, .db3 or .mcap)", read_rosbag, lambda head: head.startswith(BAG_MAGIC), topics=True)
