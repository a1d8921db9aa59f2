"""The log formats' names, in the order content detection tries them: a leaf module, so that ``--format`` and
[target] format are checked without loading the readers (ingest/registry.py checks them against its READERS)."""

from __future__ import annotations

FORMATS = (
    "ulog",
    "dataflash",
    "tlog",
    "rosbag",
    "fit",
    "gopro",
    "gpx",
    "kml",
    "nmea",
    "rtklib",
    "srt",
    "dji",
    "tum",
    "csv",
    "odometry",
)
