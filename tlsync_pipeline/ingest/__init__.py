"""The ingest stage: target logs (GPX, NMEA, CSV, odometry, ROS bags) to a constant-rate local trajectory.

``read_log`` picks the reader; ``ingest`` (pure) turns its records into a
``Trajectory`` and an ``IngestReport``; ``tlsync_pipeline.pipeline.stages.ingest`` is
the file edge (project keys, artefacts).
"""

from __future__ import annotations

from pathlib import Path

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.ingest.csvlog import read_csv_log
from tlsync_pipeline.ingest.detect import FORMATS, detect_format
from tlsync_pipeline.ingest.gpx import read_gpx
from tlsync_pipeline.ingest.nmea import read_nmea
from tlsync_pipeline.ingest.process import (
    IngestParams,
    IngestReport,
    RigidTransform,
    ingest,
)
from tlsync_pipeline.ingest.records import LogRecords
from tlsync_pipeline.ingest.rosbag import read_rosbag


def read_log(path: str | Path, fmt: str = "auto", topic: str | None = None) -> LogRecords:
    """Read a log with the reader for ``fmt`` ("auto": detected from the content)."""
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: file not found")
    if fmt == "auto":
        fmt = detect_format(path)
    if fmt == "gpx":
        return read_gpx(path)
    if fmt == "nmea":
        return read_nmea(path)
    if fmt in ("csv", "odometry"):
        return read_csv_log(path, fmt)
    if fmt == "rosbag":
        return read_rosbag(path, topic)
    raise InputError(f"{path}: unknown log format {fmt!r}; expected auto or one of {', '.join(FORMATS)}")


__all__ = ["FORMATS", "IngestParams", "IngestReport", "LogRecords", "RigidTransform", "detect_format", "ingest", "read_log"]
