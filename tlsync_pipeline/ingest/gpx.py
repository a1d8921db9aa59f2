"""GPX 1.0 and 1.1 logs: the track points of every track and segment.

Parsed with gpxpy, which knows both schema versions and their namespaces and
reads the ISO 8601 time variants devices write (fractions, offsets, 'Z').
Waypoints and routes are planned positions, not a log: they are ignored.
Segments are put in the order of their first times (merged recordings);
points inside a segment keep their order.
GPX <ele> is taken as the height above the WGS84 ellipsoid, as the GPX schema
defines it (some devices write heights above the geoid instead). Times
without an offset are taken as UTC.
"""

from __future__ import annotations

import ast
import datetime as dt
import re
from pathlib import Path

import gpxpy
import gpxpy.gpx

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.ingest.reader import Reader, text_of, xml_root
from tlsync_pipeline.ingest.records import (
    GEODETIC,
    LogRecords,
    check_geodetic,
    make_records,
)

UNIT = "track point"
NO_TIME = "track point without time"
NO_ELE = "track point without elevation"


def read_gpx(path: str | Path) -> LogRecords:
    """Read every track point with a time; see the module notes."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise InputError(f"{path}: cannot read: {exc.strerror or exc}") from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise InputError(f"{path}:{line}: not UTF-8 text (byte {raw[exc.start]:#04x})") from None
    if not text.strip():
        raise InputError(f"{path}: empty log")
    try:
        gpx = gpxpy.parse(text)
    except Exception as exc:  # gpxpy raises GPXException but lets some XML/attribute errors through
        error_line = _error_line(str(exc), text)
        at = f"{path}:{error_line}" if error_line else str(path)
        hint = (
            " (the file may be cut short)"
            if not text.rstrip().endswith(">") or "unclosed" in str(exc) or "no element found" in str(exc)
            else ""
        )
        raise InputError(f"{at}: not a valid GPX file{hint}: {exc}") from None
    rows: list[list[float]] = []
    numbers: list[int] = []
    dropped: dict[str, list[int]] = {}
    no_ele = []
    number = 0
    segment_of = []  # segment ordinal of each row
    for segment_index, segment in enumerate(seg for track in gpx.tracks for seg in track.segments):
        for point in segment.points:
            number += 1
            if point.time is None:
                dropped.setdefault(NO_TIME, []).append(number)
                continue
            try:
                lat, lon = float(point.latitude), float(point.longitude)
                ele = float(point.elevation) if point.elevation is not None else None
                when = point.time if point.time.tzinfo else point.time.replace(tzinfo=dt.timezone.utc)
                t = when.timestamp()
            except (TypeError, ValueError, OverflowError):
                dropped.setdefault("malformed track point", []).append(number)
                continue
            check_geodetic(path, lat, lon, 0.0 if ele is None else ele, number, UNIT)
            if ele is None:
                no_ele.append(len(rows))
            rows.append([t, lat, lon, 0.0 if ele is None else ele])
            numbers.append(number)
            segment_of.append(segment_index)
    warnings = []
    if no_ele and len(no_ele) == len(rows):
        warnings.append(
            "no track point has an elevation: heights set to 0 m (on the ellipsoid); the Up coordinate means nothing"
        )
    elif no_ele:
        dropped[NO_ELE] = [numbers[i] for i in no_ele]
        keep = sorted(set(range(len(rows))) - set(no_ele))
        rows, numbers, segment_of = [rows[i] for i in keep], [numbers[i] for i in keep], [segment_of[i] for i in keep]
    rows, numbers = _segments_in_time_order(rows, numbers, segment_of)
    others = len(gpx.waypoints) + sum(len(r.points) for r in gpx.routes)
    if others:
        warnings.append(f"{others} waypoint(s) and route point(s) ignored (only track points are a log)")
    return make_records(
        path, "gpx", GEODETIC, rows, numbers, unit=UNIT, dropped=dropped, ignored=others, warnings=warnings
    )


def _segments_in_time_order(rows: list, numbers: list, segment_of: list) -> tuple[list, list]:
    """Rows with whole segments ordered by their first time (points inside a segment keep their order).

    Tracks merged from several recordings are not always in time order;
    segments that overlap in time still show up as time going backwards.
    """
    first: dict[int, float] = {}
    for row, seg in zip(rows, segment_of):
        first.setdefault(seg, row[0])
    order = sorted(range(len(rows)), key=lambda i: (first[segment_of[i]], segment_of[i], i))
    return [rows[i] for i in order], [numbers[i] for i in order]


def _error_line(message: str, text: str) -> int | None:
    """The line a gpxpy error is about: from the XML parser's "line N", else where the bad value is."""
    found = re.search(r"line (\d+)", message)
    if found:
        return int(found.group(1))
    quoted = re.search(r"could not convert string to float: ('.*'|\".*\")", message)
    try:
        value = ast.literal_eval(quoted.group(1)) if quoted else None
    except (ValueError, SyntaxError):
        value = None
    if value and value in text:
        return text[: text.index(value)].count("\n") + 1
    missing = re.search(r"(latitude|longitude) is mandatory", message)
    if missing:
        attribute = "lat" if missing.group(1) == "latitude" else "lon"
        point = re.search(rf"<(trkpt|wpt|rtept)\b(?![^>]*\b{attribute}\s*=)[^>]*>", text)
        if point:
            return text[: point.start()].count("\n") + 1
    return None


def _sniff(head: bytes) -> bool:
    text = text_of(head)
    return text is not None and text.startswith("<") and xml_root(text) == "gpx"


READER = Reader("gpx", "GPX (XML root <gpx>)", read_gpx, _sniff)
