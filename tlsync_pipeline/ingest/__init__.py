"""The ingest stage: target logs (GNSS receivers, autopilots, robots, cameras) to a constant-rate local trajectory.

``read_log`` (ingest/read.py) picks the reader (tlsync_pipeline.ingest.registry,
detected from the content unless named); ``ingest`` (pure, ingest/process.py)
turns its records into a ``Trajectory`` and an ``IngestReport``;
``tlsync_pipeline.pipeline.stages.ingest`` is the file edge (project keys,
artefacts). The names below are imported on first use (a command that reads
no log loads no reader); the package's own modules import from the modules
themselves, so that a stage's code (its cache key) is what it runs.
"""

from __future__ import annotations

import importlib
from typing import Any

_WHERE = {
    "ALTITUDE_REFERENCES": "tlsync_pipeline.ingest.records",
    "LogRecords": "tlsync_pipeline.ingest.records",
    "FORMATS": "tlsync_pipeline.ingest.registry",
    "detect_format": "tlsync_pipeline.ingest.detect",
    "IngestParams": "tlsync_pipeline.ingest.params",
    "IngestReport": "tlsync_pipeline.ingest.report",
    "RigidTransform": "tlsync_pipeline.ingest.params",
    "ingest": "tlsync_pipeline.ingest.process",
    "read_log": "tlsync_pipeline.ingest.read",
}

__all__ = [
    "ALTITUDE_REFERENCES",
    "FORMATS",
    "IngestParams",
    "IngestReport",
    "LogRecords",
    "RigidTransform",
    "detect_format",
    "ingest",
    "read_log",
]


def __getattr__(name: str) -> Any:
    if name not in _WHERE:
        raise AttributeError(f"module 'tlsync_pipeline.ingest' has no attribute {name!r}")
    return getattr(importlib.import_module(_WHERE[name]), name)
