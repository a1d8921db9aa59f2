"""NMEA 0183 logs: GGA for position and height, RMC for the date.

Height: GGA gives the antenna altitude above mean sea level (the geoid) and
the geoid separation N (geoid above the WGS84 ellipsoid); the ellipsoidal
height tlsync uses is altitude + N. A GGA without N is taken with N = 0 and
a warning (its heights are then above the geoid, off by a constant in a small
area, which moves the whole trajectory up or down).

Lines are checked strictly (a ``$``, a two-letter talker, the sentence type,
fields, ``*`` and a correct two-digit hex checksum); lines that fail are
line noise and are dropped and counted with the reason. Any talker is
accepted (GP, GN, GL, GA, GB, BD, GQ, GI...). GGA fix quality 0 means no fix
and is dropped. RMC's date places GGA's time of day on the calendar; a time
of day that falls by more than 12 h is a day rollover. Without any dated RMC
the times are seconds from 1970-01-01 plus the time of day (with a warning).

The common GGA and RMC lines are split by hand (checksum by XOR over the
bytes, fields by ``split``): pynmea2 parsing costs ~16 us a line plus as much
again to read its fields, too slow for long logs. Every line the fast path
does not accept is handed to pynmea2 (strict checksum check), so its
grammar decides what is a sentence.
"""

from __future__ import annotations

import datetime as dt
from functools import reduce
from operator import xor
from pathlib import Path

import pynmea2

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.ingest.records import GEODETIC, LogRecords, check_geodetic, make_records

HALF_DAY_S = 43_200.0
BAD_CHECKSUM = "bad checksum"
NOT_NMEA = "not an NMEA sentence"
CUT = "cut mid-line (the file ends without a newline)"
NO_FIX = "GGA fix quality 0 (no fix)"
BAD_FIELDS = "malformed GGA fields"
NO_TIME = "GGA without time"


def _checksum_ok(body: str, checksum: str) -> bool:
    try:
        return reduce(xor, body.encode("latin-1"), 0) == int(checksum, 16) and len(checksum) == 2
    except ValueError:
        return False


def _split(line: str) -> tuple[str, list[str]] | None:
    """(sentence type, fields) of a well-formed checksummed line, None otherwise."""
    start = line.rfind("$")
    star = line.rfind("*")
    if start < 0 or star < start or len(line) - star < 3:
        return None
    if not _checksum_ok(line[start + 1 : star], line[star + 1 : star + 3]) or line[star + 3 :].strip():
        return None
    fields = line[start + 1 : star].split(",")
    head = fields[0]
    if len(head) != 5 or not head.isalnum():
        return None
    return head[2:], fields[1:]


def _tod(text: str) -> float:
    """Seconds of day from hhmmss[.sss]."""
    if len(text) < 6 or not text[:6].isdigit():
        raise ValueError(text)
    h, m, s = int(text[:2]), int(text[2:4]), float(text[4:])
    if h > 23 or m > 59 or not 0 <= s < 61:
        raise ValueError(text)
    return h * 3600.0 + m * 60.0 + s


def _angle(text: str, hemi: str, positive: str, negative: str) -> float:
    """Degrees from (d)ddmm.mmmm and a hemisphere letter; ValueError when malformed."""
    dot = text.find(".")
    head = dot if dot >= 0 else len(text)
    if head < 3 or hemi not in (positive, negative):
        raise ValueError(text)
    minutes = float(text[head - 2 :])
    if not 0 <= minutes < 60:
        raise ValueError(text)
    value = int(text[: head - 2]) + minutes / 60.0
    return -value if hemi == negative else value


def _date_days(text: str) -> int:
    """Days since 1970-01-01 of an RMC ddmmyy date (years 1980-2079)."""
    if len(text) != 6 or not text.isdigit():
        raise ValueError(text)
    year = int(text[4:]) + (2000 if int(text[4:]) < 80 else 1900)
    return (dt.date(year, int(text[2:4]), int(text[:2])) - dt.date(1970, 1, 1)).days


def read_nmea(path: str | Path) -> LogRecords:
    """Read GGA fixes (with RMC dates) from an NMEA 0183 log; see the module notes."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise InputError(f"{path}: cannot read: {exc.strerror or exc}") from None
    text = raw.decode("latin-1")
    if not text.strip():
        raise InputError(f"{path}: empty log")
    lines = text.split("\n")
    cut_last = not text.endswith("\n")
    if not cut_last:
        lines.pop()
    dropped: dict[str, list[int]] = {}
    ignored = 0
    # Events in file order: ("G", tod, line, lat, lon, h) or ("R", tod, line, days).
    events: list[tuple] = []
    missing_sep = 0
    for number, line in enumerate(lines, start=1):
        parts = _split(line)
        if parts is None:
            parts = _slow_split(line)
        if isinstance(parts, str):
            if not line.strip():
                continue
            reason = CUT if (cut_last and number == len(lines)) else parts
            dropped.setdefault(reason, []).append(number)
            continue
        kind, f = parts
        if kind == "GGA":
            if len(f) < 11:
                dropped.setdefault(BAD_FIELDS, []).append(number)
                continue
            if f[5] in ("", "0"):
                dropped.setdefault(NO_FIX, []).append(number)
                continue
            if not f[0]:
                dropped.setdefault(NO_TIME, []).append(number)
                continue
            try:
                tod = _tod(f[0])
                lat = _angle(f[1], f[2], "N", "S")
                lon = _angle(f[3], f[4], "E", "W")
                height = float(f[8])
                if f[10]:
                    height += float(f[10])
                else:
                    missing_sep += 1
            except ValueError:
                dropped.setdefault(BAD_FIELDS, []).append(number)
                continue
            check_geodetic(path, lat, lon, height, number)
            events.append(("G", tod, number, lat, lon, height))
        elif kind == "RMC":
            try:
                events.append(("R", _tod(f[0]), number, _date_days(f[8]), f[1] == "A"))
            except (ValueError, IndexError):
                ignored += 1  # an RMC without a usable date still says nothing we need
        else:
            ignored += 1
    rows, numbers, warnings = _place_on_calendar(events, path)
    if missing_sep:
        warnings.append(f"{missing_sep} GGA sentence(s) without geoid separation: their heights are above mean sea level, not the WGS84 ellipsoid")
    return make_records(path, "nmea", GEODETIC, rows, numbers, dropped=dropped, ignored=ignored, warnings=warnings)


def _slow_split(line: str) -> tuple[str, list[str]] | str:
    """pynmea2's verdict on a line the fast path refused: (type, fields) or the reason to drop it."""
    if not line.strip():
        return NOT_NMEA
    try:
        msg = pynmea2.parse(line.strip(), check=True)
    except pynmea2.ChecksumError:
        return BAD_CHECKSUM
    except (pynmea2.ParseError, ValueError, AttributeError, TypeError, IndexError):
        return NOT_NMEA
    kind = getattr(msg, "sentence_type", "")
    return kind, list(getattr(msg, "data", []))


def _place_on_calendar(events: list[tuple], path: Path) -> tuple[list, list, list[str]]:
    """POSIX times of the GGA fixes: RMC dates anchor the days, rollovers advance them.

    Each dated RMC sets the date from its line on (and for the fixes before the
    first one); active (status A) RMCs are preferred to void ones.
    """
    days, day, previous = [], 0, None
    for event in events:
        if previous is not None and event[1] < previous - HALF_DAY_S:
            day += 1
        previous = event[1]
        days.append(day)
    anchors = [(i, e[3] - days[i]) for i, e in enumerate(events) if e[0] == "R" and e[4]]
    if not anchors:
        anchors = [(i, e[3] - days[i]) for i, e in enumerate(events) if e[0] == "R"]
    warnings = []
    if not anchors and events:
        warnings.append("no RMC sentence with a date: times are the time of day on 1970-01-01, not true UTC dates")
    rows, numbers = [], []
    base = anchors[0][1] if anchors else 0
    k = 0
    for i, event in enumerate(events):
        while k < len(anchors) and anchors[k][0] <= i:
            base = anchors[k][1]
            k += 1
        if event[0] == "G":
            rows.append(((base + days[i]) * 86400.0 + event[1], event[3], event[4], event[5]))
            numbers.append(event[2])
    return rows, numbers, warnings
