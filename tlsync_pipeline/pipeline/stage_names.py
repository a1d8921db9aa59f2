"""The stages' names in the order they run, and those that run per camera: a leaf module, so that the command line
offers them without loading the stages (pipeline.graph checks them against its STAGE_SPECS)."""

from __future__ import annotations

STAGES = ("intrinsics", "clock", "ingest", "scan", "track", "calibrate", "identify", "vote", "sync", "export", "render")
PER_CAMERA = ("intrinsics", "clock", "scan", "track", "calibrate", "identify", "vote")
