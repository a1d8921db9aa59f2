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

Quality: GGA's fix quality (1 GPS, 2 DGPS, 4 RTK fixed, 5 RTK float, ...)
and HDOP are kept for the report. A GST sentence with the same time of day
gives the fix's sigma, sqrt((lat error^2 + lon error^2) / 2) (m); HDOP is
not a sigma and is not used as one.

Well-formed lines take a fast path: checksums for the whole file at once
(XOR prefix sums in numpy), fields by ``split``, numbers converted column by
column. pynmea2 costs ~8 us a line to parse plus as much to read its fields,
too slow for long logs (docs/performance.md). Every line the fast path does
not accept is handed to pynmea2 (strict checksum check), whose grammar then
decides what is a sentence.
"""

from __future__ import annotations

import datetime as dt
import math
import re
from pathlib import Path

import numpy as np
import pynmea2

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.ingest.reader import Reader, text_of
from tlsync_pipeline.ingest.records import (
    GEODETIC,
    LogRecords,
    check_geodetic,
    make_records,
)

HALF_DAY_S = 43_200.0
BAD_CHECKSUM = "bad checksum"
NOT_NMEA = "not an NMEA sentence"
CUT = "cut mid-line (the file ends without a newline)"
NO_FIX = "GGA fix quality 0 (no fix)"
BAD_FIELDS = "malformed GGA fields"
NO_TIME = "GGA without time"
# Field positions (field 0 is talker + type) of what is read.
GGA_FIELDS = {"time": 1, "lat": 2, "ns": 3, "lon": 4, "ew": 5, "quality": 6, "hdop": 8, "alt": 9, "sep": 11}
RMC_FIELDS = {"time": 1, "status": 2, "date": 9}
_HEX = np.full(256, -1, dtype=np.int16)
_HEX[np.frombuffer(b"0123456789ABCDEF", dtype=np.uint8)] = np.arange(16)


def _checked(raw: bytes, starts: np.ndarray, ends: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(ok, '$' offset, '*' offset) per line: ok when the line is ``...$BODY*HH`` (then an optional CR)
    and HH, upper-case hex, is the XOR of BODY's bytes."""
    arr = np.frombuffer(raw, dtype=np.uint8)
    last = len(arr) - 1
    ends = ends - ((ends > starts) & (arr[np.clip(ends - 1, 0, last)] == 13))

    def last_before(positions: np.ndarray) -> np.ndarray:
        j = np.searchsorted(positions, ends) - 1
        return np.where(j >= 0, positions[np.maximum(j, 0)] if len(positions) else -1, -1)

    dollar, star = last_before(np.flatnonzero(arr == 36)), last_before(np.flatnonzero(arr == 42))
    ok = (dollar >= starts) & (star > dollar) & (star + 3 == ends)
    prefix = np.bitwise_xor.accumulate(arr)
    body = prefix[np.clip(star - 1, 0, last)] ^ prefix[np.clip(dollar, 0, last)]
    high, low = _HEX[arr[np.clip(star + 1, 0, last)]], _HEX[arr[np.clip(star + 2, 0, last)]]
    ok &= (high >= 0) & (low >= 0) & (body == high * 16 + low)
    return ok, dollar, star


def _floats(texts: list[str]) -> np.ndarray:
    """float64 array of the strings, NaN where one is not a number."""
    try:
        return np.array(texts, dtype=np.float64)
    except ValueError:
        out = np.full(len(texts), np.nan)
        for i, text in enumerate(texts):
            try:
                out[i] = float(text)
            except ValueError:
                pass
        return out


def _tod(texts: list[str]) -> np.ndarray:
    """Seconds of day from hhmmss[.sss] strings; NaN when malformed."""
    v = _floats(texts)
    h, m = np.floor(v / 10000), np.floor(v / 100) % 100
    sec = v - h * 10000 - m * 100
    good = (
        np.isfinite(v)
        & (v >= 0)
        & (h <= 23)
        & (m <= 59)
        & (sec < 61)
        & np.array([len(t) >= 6 for t in texts], dtype=bool)
    )
    return np.where(good, h * 3600 + m * 60 + sec, np.nan)


def _angle(texts: list[str], hemis: list[str], positive: str, negative: str) -> np.ndarray:
    """Degrees from (d)ddmm.mmmm strings and hemisphere letters; NaN when malformed."""
    v = _floats(texts)
    degrees = np.floor(v / 100)
    minutes = v - degrees * 100
    hemi = np.array(hemis, dtype=object)
    good = np.isfinite(v) & (v >= 0) & (minutes < 60) & ((hemi == positive) | (hemi == negative))
    return np.where(good, np.where(hemi == negative, -1.0, 1.0) * (degrees + minutes / 60.0), np.nan)


def _date_days(text: str, cache: dict[str, float]) -> float:
    """Days since 1970-01-01 of an RMC ddmmyy date (years 1980-2079), NaN when malformed."""
    if text not in cache:
        try:
            if len(text) != 6 or not text.isdigit():
                raise ValueError(text)
            year = int(text[4:]) + (2000 if int(text[4:]) < 80 else 1900)
            cache[text] = (dt.date(year, int(text[2:4]), int(text[:2])) - dt.date(1970, 1, 1)).days
        except ValueError:
            cache[text] = math.nan
    return cache[text]


def read_nmea(path: str | Path) -> LogRecords:
    """Read GGA fixes (with RMC dates) from an NMEA 0183 log; see the module notes."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise InputError(f"{path}: cannot read: {exc.strerror or exc}") from None
    if not raw.strip():
        raise InputError(f"{path}: empty log")
    text = raw.decode("latin-1")  # one character per byte: byte offsets are text offsets
    newlines = np.flatnonzero(np.frombuffer(raw, dtype=np.uint8) == 10)
    cut_last = not raw.endswith(b"\n")
    starts, ends = np.r_[0, newlines + 1], np.r_[newlines, len(raw)]
    if not cut_last:
        starts, ends = starts[:-1], ends[:-1]
    ok, dollar, star = _checked(raw, starts, ends)
    dropped: dict[str, list[int]] = {}
    ignored = 0
    # Columns of strings (not lists per line: those would keep the garbage collector busy).
    gga: dict[str, list] = {name: [] for name in ("line", *GGA_FIELDS)}
    rmc: dict[str, list] = {name: [] for name in ("line", *RMC_FIELDS)}
    gst: dict[str, tuple[str, str]] = {}  # time of day -> (lat error, lon error) text
    n_lines = len(starts)
    for i, good, a, b in zip(range(n_lines), ok.tolist(), dollar.tolist(), star.tolist()):
        fields = text[a + 1 : b].split(",") if good else None
        if fields is None or len(fields[0]) != 5 or not fields[0].isalnum():
            line = text[starts[i] : ends[i]]
            if not line.strip():
                continue
            parts = _slow_split(line)
            if isinstance(parts, str):
                dropped.setdefault(CUT if (cut_last and i == n_lines - 1) else parts, []).append(i + 1)
                continue
            kind, fields = parts[0], [""] + parts[1]
        else:
            kind = fields[0][2:]
        if kind == "GGA":
            if len(fields) < 12:
                dropped.setdefault(BAD_FIELDS, []).append(i + 1)
                continue
            gga["line"].append(i + 1)
            for name, j in GGA_FIELDS.items():
                gga[name].append(fields[j])
        elif kind == "GST" and len(fields) >= 8:
            gst[fields[1]] = (fields[6], fields[7])
        elif kind == "RMC" and len(fields) >= 10:
            rmc["line"].append(i + 1)
            for name, j in RMC_FIELDS.items():
                rmc[name].append(fields[j])
        else:
            ignored += 1  # other sentences, and RMCs too short to carry a date
    fixes, missing_sep = _gga_fixes(path, gga, dropped)
    days, rmc_lines, rmc_tod, rmc_active, unusable = _rmc_dates(rmc)
    ignored += unusable  # an RMC without a usable time and date says nothing we need
    rows, numbers, warnings = _place_on_calendar(fixes, rmc_lines, rmc_tod, days, rmc_active)
    if missing_sep:
        warnings.append(
            f"{missing_sep} GGA sentence(s) without geoid separation: their heights are above mean sea level, not the "
            f"WGS84 ellipsoid"
        )
    for lines in dropped.values():
        lines.sort()
    dated = len(rmc_lines) > 0  # without a dated RMC the times are not true UTC
    quality, sigma = _quality(gga, gst, numbers)
    return make_records(
        path,
        "nmea",
        GEODETIC,
        rows,
        numbers,
        utc=dated,
        dropped=dropped,
        ignored=ignored,
        warnings=warnings,
        sigma=sigma,
        quality=quality,
    )


def _quality(
    gga: dict[str, list], gst: dict[str, tuple[str, str]], numbers
) -> tuple[dict[str, np.ndarray], np.ndarray | None]:
    """({"quality", "hdop"} per fix, GST sigma per fix or None) for the fixes at GGA lines ``numbers``."""
    index = {line: i for i, line in enumerate(gga["line"])}
    rows = [index[int(n)] for n in numbers]
    quality = {
        "quality": _floats([gga["quality"][i] for i in rows]),
        "hdop": _floats([gga["hdop"][i] or "nan" for i in rows]),
    }
    if not gst:
        return quality, None
    errors = [gst.get(gga["time"][i], ("", "")) for i in rows]
    lat, lon = _floats([e[0] or "nan" for e in errors]), _floats([e[1] or "nan" for e in errors])
    return quality, np.sqrt((lat**2 + lon**2) / 2)


def _gga_fixes(path: Path, gga: dict[str, list], dropped: dict[str, list[int]]) -> tuple[np.ndarray, int]:
    """(N, 5) line, time of day, lat, lon, ellipsoidal height of the valid GGA fixes; drops counted."""
    numbers = np.array(gga["line"], dtype=np.int64)
    quality = np.array(gga["quality"], dtype=object)
    no_fix = (quality == "") | (quality == "0")
    no_time = ~no_fix & (np.array(gga["time"], dtype=object) == "")
    if no_fix.any():
        dropped.setdefault(NO_FIX, []).extend(numbers[no_fix].tolist())
    if no_time.any():
        dropped.setdefault(NO_TIME, []).extend(numbers[no_time].tolist())
    use = np.flatnonzero(~(no_fix | no_time)).tolist()
    pick = (lambda name: [gga[name][i] for i in use]) if len(use) < len(numbers) else (lambda name: gga[name])
    seps = pick("sep")
    missing_sep = seps.count("")
    fixes = np.column_stack(
        [
            numbers[use].astype(np.float64),
            _tod(pick("time")),
            _angle(pick("lat"), pick("ns"), "N", "S"),
            _angle(pick("lon"), pick("ew"), "E", "W"),
            _floats(pick("alt")) + _floats([s or "0" for s in seps]),
        ]
    ).reshape(-1, 5)
    good = np.isfinite(fixes).all(axis=1)
    if not good.all():
        dropped.setdefault(BAD_FIELDS, []).extend(int(n) for n in fixes[~good, 0])
        fixes = fixes[good]
    impossible = (
        (np.abs(fixes[:, 2]) > 90) | (np.abs(fixes[:, 3]) > 180) | (fixes[:, 4] < -12_000) | (fixes[:, 4] > 100_000)
    )
    if impossible.any():
        row = fixes[np.flatnonzero(impossible)[0]]
        check_geodetic(path, row[2], row[3], row[4], int(row[0]))
    return fixes, missing_sep


def _rmc_dates(rmc: dict[str, list]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
    """(date as days since 1970, line, time of day, active) of the RMCs with a usable time and date."""
    cache: dict[str, float] = {}
    days = np.array([_date_days(d, cache) for d in rmc["date"]], dtype=np.float64) if rmc["date"] else np.zeros(0)
    tod = _tod(rmc["time"])
    good = np.isfinite(tod) & np.isfinite(days)
    lines = np.array(rmc["line"], dtype=np.float64)
    active = np.array(rmc["status"], dtype=object) == "A"
    return (
        days[good],
        lines[good],
        tod[good],
        np.asarray(active, dtype=bool).reshape(-1)[good],
        len(good) - int(good.sum()),
    )


def _slow_split(line: str) -> tuple[str, list[str]] | str:
    """pynmea2's verdict on a line the fast path refused: (type, fields) or the reason to drop it."""
    try:
        msg = pynmea2.parse(line.strip(), check=True)
    except pynmea2.ChecksumError:
        return BAD_CHECKSUM
    except (pynmea2.ParseError, ValueError, AttributeError, TypeError, IndexError):
        return NOT_NMEA
    kind = getattr(msg, "sentence_type", "")
    return kind, [str(v) for v in getattr(msg, "data", [])]


def _place_on_calendar(
    fixes: np.ndarray, rmc_lines, rmc_tod, rmc_days, rmc_active
) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """POSIX times of the GGA fixes: RMC dates anchor the days, rollovers advance them.

    Events (GGA fixes and dated RMCs) in file order; a time of day falling by
    more than 12 h from the previous event is a new day. Each dated RMC sets
    the date from its line on (and for the fixes before the first one);
    active (status A) RMCs are preferred to void ones.
    """
    lines = np.r_[fixes[:, 0], rmc_lines]
    order = np.argsort(lines, kind="stable")
    tod = np.r_[fixes[:, 1], rmc_tod][order]
    is_gga = (np.arange(len(lines)) < len(fixes))[order]
    days = np.r_[0, np.cumsum(np.diff(tod) < -HALF_DAY_S)]
    anchors = np.r_[np.zeros(len(fixes), dtype=bool), rmc_active][order]
    if not anchors.any():
        anchors = ~is_gga
    date = np.r_[np.zeros(len(fixes)), rmc_days][order]
    warnings = []
    if anchors.any():
        base_at = np.where(anchors, date - days, np.nan)
        latest = np.maximum.accumulate(np.where(anchors, np.arange(len(lines)), -1))
        base = np.where(latest >= 0, base_at[np.maximum(latest, 0)], base_at[np.flatnonzero(anchors)[0]])
    else:
        base = np.zeros(len(lines))
        if len(fixes):
            warnings.append("no RMC sentence with a date: times are the time of day on 1970-01-01, not true UTC dates")
    t = (base + days) * 86400.0 + tod
    gga_rows = np.column_stack([t[is_gga], np.r_[fixes[:, 2:5], np.zeros((len(rmc_lines), 3))][order][is_gga]])
    return gga_rows, lines[order][is_gga].astype(np.int64), warnings


_SENTENCE = re.compile(r"\$[A-Z0-9]{5},[^\r\n]*\*[0-9A-Fa-f]{2}")


def _sniff(head: bytes) -> bool:
    """A checksummed sentence in the first 20 lines of a text file."""
    text = text_of(head)
    return text is not None and any(_SENTENCE.search(line) for line in text.split("\n")[:20])


READER = Reader("nmea", "NMEA 0183 ($..GGA sentences)", read_nmea, _sniff)
