"""Which reader a log needs, from its first bytes (never from its name alone)."""

from __future__ import annotations

import re
from pathlib import Path

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.ingest.csvlog import header_columns

FORMATS = ("gpx", "nmea", "csv", "odometry", "rosbag")
_NMEA = re.compile(r"\$[A-Z0-9]{5},[^\r\n]*\*[0-9A-Fa-f]{2}")
_BAG_MAGIC = (b"#ROSBAG V2.0", b"\x89MCAP", b"SQLite format 3\x00")


def detect_format(path: str | Path) -> str:
    """One of FORMATS for the log at path; InputError saying what was expected otherwise."""
    path = Path(path)
    if path.is_dir():
        if (path / "metadata.yaml").exists():
            return "rosbag"
        raise InputError(f"{path}: a folder, and not a ROS 2 bag (no metadata.yaml)")
    try:
        with path.open("rb") as handle:
            head = handle.read(65536)
    except FileNotFoundError:
        raise InputError(f"{path}: file not found") from None
    except OSError as exc:
        raise InputError(f"{path}: cannot read: {exc.strerror or exc}") from None
    if head.startswith(_BAG_MAGIC):
        return "rosbag"
    text = head.decode("latin-1").lstrip("\ufeff\xef\xbb\xbf \t\r\n")
    if not text.strip():
        raise InputError(f"{path}: empty log")
    if text.startswith("<?xml") or "<gpx" in text[:2000]:
        return "gpx"
    lines = [line for line in text.split("\n")[:50] if line.strip()]
    if any(_NMEA.search(line) for line in lines[:20]):
        return "nmea"
    header = next((line for line in lines if not line.lstrip().startswith("#")), "")
    _, columns = header_columns(header)
    if "time" in columns and ({"lat", "lon"} <= set(columns) or {"x", "y", "z"} <= set(columns)):
        return "csv"
    raise InputError(
        f"{path}: cannot detect the log format (first line {lines[0][:60]!r}); expected GPX (XML), NMEA 0183 "
        "($..GGA sentences), CSV with a header time,lat,lon,alt or t,x,y,z, or a ROS bag; give --format (or [target] format)"
    )
