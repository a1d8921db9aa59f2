"""ROS bags (ROS 1 ``.bag``, ROS 2 folders with sqlite3 or MCAP storage, bare ``.mcap`` files).

Topics read: sensor_msgs/NavSatFix, nav_msgs/Odometry, geometry_msgs/PoseStamped
and PoseWithCovarianceStamped. Read with the pure-Python ``rosbags`` package
(the optional extra ``tlsync[rosbag]``; no ROS installation needed). When
several topics fit and none is named, the error lists them (``--topic``).
Times are the messages' header stamps (the bag's receive time when a stamp
is zero); messages are sorted by stamp, since a bag stores them in arrival
order. Stamps before 2000 are a simulation or boot clock, not UTC: offsets
work, UTC does not. NavSatFix altitude is above the WGS84 ellipsoid by the
message's definition; fixes with status -1 (no fix) are dropped; a known
position covariance gives the per-fix sigma sqrt((var_E + var_N) / 2).
Odometry and pose positions are local metres (the covariance's x/y
variances give the sigma), placed in the world frame by the project's rigid
transform.
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
    sort_by_time,
)

ODOMETRY = "nav_msgs/msg/Odometry"
NAVSATFIX = "sensor_msgs/msg/NavSatFix"
POSE = "geometry_msgs/msg/PoseStamped"
POSE_COV = "geometry_msgs/msg/PoseWithCovarianceStamped"
MSGTYPES = (NAVSATFIX, ODOMETRY, POSE, POSE_COV)
UTC_FROM_S = 946684800.0  # stamps before 2000-01-01 are not UTC
UNIT = "message"
NO_FIX = "NavSatFix status -1 (no fix)"


def stamp_seconds(stamp, receive_ns: int) -> float:
    """Seconds of a builtin_interfaces/Time, or the receive time (ns) when the stamp is zero."""
    sec = float(stamp.sec) + float(stamp.nanosec) * 1e-9
    return sec if sec > 0 else receive_ns * 1e-9


def odometry_row(msg, receive_ns: int = 0) -> tuple[float, float, float, float]:
    """(t, x, y, z) of a nav_msgs/Odometry or geometry_msgs/Pose(WithCovariance)Stamped message."""
    pose = msg.pose.pose if hasattr(msg.pose, "pose") else msg.pose
    p = pose.position
    return stamp_seconds(msg.header.stamp, receive_ns), float(p.x), float(p.y), float(p.z)


def local_sigma(msg) -> float:
    """sqrt((var_x + var_y) / 2) (m) from a pose covariance, NaN when there is none or it is not positive."""
    covariance = getattr(msg.pose, "covariance", None)
    if covariance is None or len(covariance) < 8 or not covariance[0] > 0 or not covariance[7] > 0:
        return float("nan")
    return float(np.sqrt((covariance[0] + covariance[7]) / 2))


def navsatfix_row(msg, receive_ns: int = 0) -> tuple[float, float, float, float] | None:
    """(t, lat, lon, alt) of a sensor_msgs/NavSatFix message, None when it has no fix."""
    if msg.status.status < 0:
        return None
    return stamp_seconds(msg.header.stamp, receive_ns), float(msg.latitude), float(msg.longitude), float(msg.altitude)


def navsatfix_sigma(msg) -> float:
    """sqrt((var_E + var_N) / 2) (m) when the covariance is known (type > 0), else NaN."""
    c = msg.position_covariance
    if msg.position_covariance_type <= 0 or not c[0] > 0 or not c[4] > 0:
        return float("nan")
    return float(np.sqrt((c[0] + c[4]) / 2))


def read_rosbag(path: str | Path, topic: str | None = None) -> LogRecords:
    """Read the NavSatFix, Odometry or pose messages of one topic (the only such topic when not given)."""
    path = Path(path)
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise InputError(f"{path}: reading ROS bags needs the optional extra: pip install 'tlsync[rosbag]'") from None
    bag = path.parent if path.is_file() and (path.parent / "metadata.yaml").exists() else path
    try:
        with AnyReader([bag], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
            usable = {c.topic: c.msgtype for c in reader.connections if c.msgtype in MSGTYPES}
            counts = {t: sum(c.msgcount for c in reader.connections if c.topic == t) for t in usable}
            found = (
                ", ".join(f"{t} ({m.rsplit('/', 1)[-1]}, {counts[t]} messages)" for t, m in sorted(usable.items()))
                or "none"
            )
            if topic is None:
                if len(usable) != 1:
                    raise InputError(
                        f"{path}: {'several' if usable else 'no'} NavSatFix/Odometry/PoseStamped topics: {found}; "
                        f"name one with --topic (or [target] topic)"
                    )
                topic = next(iter(usable))
            if topic not in usable:
                raise InputError(f"{path}: no NavSatFix/Odometry/PoseStamped topic {topic!r}; usable topics: {found}")
            msgtype = usable[topic]
            connections = [c for c in reader.connections if c.topic == topic]
            rows, numbers, sigmas = [], [], []
            dropped: dict[str, list[int]] = {}
            for number, (conn, receive_ns, raw) in enumerate(reader.messages(connections=connections), start=1):
                msg = reader.deserialize(raw, conn.msgtype)
                row = navsatfix_row(msg, receive_ns) if msgtype == NAVSATFIX else odometry_row(msg, receive_ns)
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
                sigmas.append(navsatfix_sigma(msg) if msgtype == NAVSATFIX else local_sigma(msg))
    except InputError:
        raise
    except Exception as exc:  # rosbags raises its own errors, sqlite3/struct errors on damaged files
        raise InputError(f"{path}: cannot read as a ROS bag: {exc}") from None
    rows, numbers, sigmas = sort_by_time(rows, numbers, sigmas)
    frame = GEODETIC if msgtype == NAVSATFIX else LOCAL
    utc = bool(rows) and rows[0][0] >= UTC_FROM_S
    sigma = np.asarray(sigmas, dtype=float)
    return make_records(
        path,
        "rosbag",
        frame,
        rows,
        numbers,
        unit=f"{topic} {UNIT}",
        utc=utc,
        dropped=dropped,
        sigma=sigma if np.isfinite(sigma).any() else None,
        clock=None if utc else "ROS time before 2000: a simulation or boot clock (s)",
    )


BAG_MAGIC = (b"#ROSBAG V2.0", b"\x89MCAP", b"SQLite format 3\x00")
READER = Reader(
    "rosbag",
    "ROS bag (ROS 1 .bag, ROS 2 folder with metadata.yaml, .db3 or .mcap)",
    read_rosbag,
    lambda head: head.startswith(BAG_MAGIC),
    topics=True,
)
