"""CSV logs: geodetic ``time,lat,lon,alt`` or local ``t,x,y,z`` (also odometry ``time,x,y,z``).

The header names the columns, in any order; aliases: time = t, timestamp;
lat = latitude; lon = lng, longitude; alt = altitude, height, ele (height
above the WGS84 ellipsoid, metres). The delimiter is the first of ``,``,
``;`` or tab found in the header. Times are POSIX seconds or ISO 8601 (UTC
when no offset is given); for a local log any seconds clock. Lines starting
with ``#`` are comments. A row that cannot be read (wrong field count, not a
number) is line noise: dropped and counted. A row that reads but is
impossible (latitude out of range) is an error.
"""

from __future__ import annotations

import datetime as dt
import math
from pathlib import Path

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.inputs import quote
from tlsync_pipeline.ingest.reader import Reader, text_of
from tlsync_pipeline.ingest.records import (
    GEODETIC,
    LOCAL,
    LogRecords,
    check_geodetic,
    make_records,
)

ALIASES = {
    "time": ("time", "t", "timestamp"),
    "lat": ("lat", "latitude"),
    "lon": ("lon", "lng", "longitude"),
    "alt": ("alt", "altitude", "height", "ele"),
    "x": ("x",),
    "y": ("y",),
    "z": ("z",),
}
CUT = "cut mid-line (the file ends without a newline)"


def header_columns(header: str) -> tuple[str, dict[str, int]]:
    """(delimiter, canonical column name -> index) of a header line."""
    delimiter = next((d for d in (",", ";", "\t") if d in header), ",")
    names = [c.strip().strip('"').lower() for c in header.split(delimiter)]
    columns = {}
    for canonical, aliases in ALIASES.items():
        for i, name in enumerate(names):
            if name in aliases and canonical not in columns:
                columns[canonical] = i
    return delimiter, columns


def parse_time(text: str) -> tuple[float, bool]:
    """(seconds, is ISO 8601) of a POSIX-seconds or ISO 8601 time; ValueError otherwise."""
    try:
        value = float(text)
    except ValueError:
        text = text.strip()
        when = dt.datetime.fromisoformat(text[:-1] + "+00:00" if text[-1:] in "Zz" and text else text)  # 'Z': Python < 3.11
        if when.tzinfo is None:
            when = when.replace(tzinfo=dt.timezone.utc)
        return when.timestamp(), True
    if not math.isfinite(value):
        raise ValueError(text)
    return value, False


def read_csv_log(path: str | Path, fmt: str = "csv") -> LogRecords:
    """Read a CSV log; ``fmt`` "odometry" insists on a local x,y,z log."""
    path = Path(path)
    try:
        text = path.read_bytes().decode("utf-8-sig", errors="replace")
    except OSError as exc:
        raise InputError(f"{path}: cannot read: {exc.strerror or exc}") from None
    lines = text.split("\n")
    cut_last = not text.endswith("\n")
    if not cut_last:
        lines.pop()
    header_no = next((i for i, line in enumerate(lines) if line.strip() and not line.lstrip().startswith("#")), None)
    if header_no is None:
        raise InputError(f"{path}: empty log")
    delimiter, columns = header_columns(lines[header_no])
    geodetic = "lat" in columns and "lon" in columns
    if fmt == "odometry" and geodetic:
        raise InputError(f"{path}:{header_no + 1}: an odometry log has columns time,x,y,z, not lat/lon (use --format csv)")
    wanted = ["time", "lat", "lon", "alt"] if geodetic else ["time", "x", "y", "z"]
    missing = [c for c in wanted if c not in columns and not (c == "alt" and geodetic)]
    if missing:
        raise InputError(
            f"{path}:{header_no + 1}: header {quote(lines[header_no].strip())} lacks column(s) {', '.join(missing)}; "
            "expected time,lat,lon,alt (geodetic) or t,x,y,z (local metres)"
        )
    width = len(lines[header_no].split(delimiter))
    index = [columns.get(c) for c in wanted]
    rows, numbers = [], []
    dropped: dict[str, list[int]] = {}
    iso = False
    comments = 0
    for number, line in enumerate(lines[header_no + 1 :], start=header_no + 2):
        if not line.strip():
            continue
        if line.lstrip().startswith("#"):
            comments += 1
            continue
        cells = line.rstrip("\r").split(delimiter)
        reason = None
        if len(cells) != width:
            reason = f"expected {width} fields"
        else:
            try:
                t, was_iso = parse_time(cells[columns["time"]].strip().strip('"'))
                iso |= was_iso
            except (ValueError, OverflowError, OSError):
                reason = "unreadable time"
            else:
                values = []
                for name, i in zip(wanted[1:], index[1:]):
                    try:
                        v = 0.0 if i is None else float(cells[i])
                    except ValueError:
                        v = math.nan
                    if not math.isfinite(v):
                        reason = f"column {name!r} not a number"
                        break
                    values.append(v)
        if reason is not None:
            if cut_last and number == len(lines):
                reason = CUT
            dropped.setdefault(reason, []).append(number)
            continue
        if geodetic:
            check_geodetic(path, values[0], values[1], values[2], number)
        rows.append([t, *values])
        numbers.append(number)
    warnings = []
    if geodetic and "alt" not in columns:
        warnings.append("no altitude column: heights set to 0 m (on the ellipsoid); the Up coordinate means nothing")
    frame = GEODETIC if geodetic else LOCAL
    return make_records(path, "odometry" if fmt == "odometry" else "csv", frame, rows, numbers, utc=geodetic or iso, dropped=dropped, ignored=comments, warnings=warnings)


def _sniff(head: bytes) -> bool:
    """A header (after # comments) naming a time and lat/lon or x/y/z columns."""
    text = text_of(head)
    if text is None:
        return False
    header = next((line for line in text.split("\n")[:50] if line.strip() and not line.lstrip().startswith("#")), "")
    _, columns = header_columns(header)
    return "time" in columns and ({"lat", "lon"} <= set(columns) or {"x", "y", "z"} <= set(columns))


READER = Reader("csv", "CSV with a header time,lat,lon,alt or t,x,y,z", read_csv_log, _sniff)
ODOMETRY_READER = Reader("odometry", "odometry CSV time,x,y,z (by name only: --format odometry)", lambda path: read_csv_log(path, "odometry"), None)
