"""The ingest stage: target logs (GNSS receivers, autopilots, robots, cameras) to a constant-rate local trajectory.

``read_log`` picks the reader (tlsync_pipeline.ingest.registry, detected from
the content unless named); ``ingest`` (pure) turns its records into a
``Trajectory`` and an ``IngestReport``; ``tlsync_pipeline.pipeline.stages.ingest``
is the file edge (project keys, artefacts).
"""

from __future__ import annotations

from pathlib import Path

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.inputs import regular_file
from tlsync_pipeline.ingest.detect import detect_format
from tlsync_pipeline.ingest.process import (
    IngestParams,
    IngestReport,
    RigidTransform,
    ingest,
)
from tlsync_pipeline.ingest.records import ALTITUDE_REFERENCES, LogRecords
from tlsync_pipeline.ingest.registry import BY_NAME, FORMATS


def read_log(path: str | Path, fmt: str = "auto", topic: str | None = None) -> LogRecords:
    """Read a log with the reader for ``fmt`` ("auto": detected from the content)."""
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: file not found")
    if not path.is_dir():
        regular_file(path, what="log")
    if fmt == "auto":
        fmt = detect_format(path)
    reader = BY_NAME.get(fmt)
    if reader is None:
        raise InputError(f"{path}: unknown log format {fmt!r}; expected auto or one of {', '.join(FORMATS)}")
    if path.is_dir() and not reader.topics:
        raise InputError(f"{path}: a folder; the {fmt} reader reads a file")
    if reader.topics:
        return reader.read(path, topic)
    if topic is not None:
        raise InputError(f"{path}: --topic (or [target] topic) applies to ROS bags; this is a {fmt} log")
    return reader.read(path)


__all__ = ["ALTITUDE_REFERENCES", "FORMATS", "IngestParams", "IngestReport", "LogRecords", "RigidTransform", "detect_format", "ingest", "read_log"]
