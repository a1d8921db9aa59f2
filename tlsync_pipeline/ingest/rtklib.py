"""RTKLIB solution files (``.pos``, from rnx2rtkp / RTKPOST / RTKNAVI / str2str), latitude/longitude/height output.

Header lines start with ``%``. Times are GPS time (GPST) unless the column
header names UTC (or JST, UTC + 9 h); GPST goes to UTC with the leap-second
table. Two time layouts occur, also in one tool's output over the years:
calendar ``2019/02/19 14:37:08.000`` and GPS week + time of week
``2041 225428.000``, the latter also without any header. Heights are above
the ellipsoid unless the header says ``geodetic`` (above the geoid, MSL).
Latitude/longitude in degrees or as ``d m s`` (header ``latitude(d'")``);
fields split on blanks or commas. Columns after the position: Q (1 fix, 2
float, 3 SBAS, 4 DGPS, 5 single, 6 PPP; 0 or absent = no solution, dropped),
ns (satellites), sdn/sde/sdu (1-sigma north/east/up, m), then covariances,
age and ratio. The per-fix sigma is sqrt((sdn^2 + sde^2) / 2) (m per
horizontal axis). ECEF (x/y/z-ecef) and ENU baseline outputs are not read:
re-run RTKLIB with ``out-solformat = llh``.
"""

from __future__ import annotations

import calendar
import io
import math
import re
import warnings
from pathlib import Path

import numpy as np

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.ingest.gps_time import GPS_EPOCH_POSIX, WEEK_S, gpst_to_utc
from tlsync_pipeline.ingest.reader import Reader, text_of
from tlsync_pipeline.ingest.records import (
    ELLIPSOID,
    GEODETIC,
    MSL,
    LogRecords,
    check_geodetic_rows,
    records_of_columns,
)

NO_SOLUTION = "Q 0 (no solution)"
MALFORMED = "malformed line"
QUALITY_NAMES = {1: "fix", 2: "float", 3: "SBAS", 4: "DGPS", 5: "single", 6: "PPP"}
_WEEK_TOW = re.compile(
    r"^\s*\d{3,4}[\s,]+\d+(\.\d*)?[\s,]+-?\d+\.\d+[\s,]+-?\d+\.\d+[\s,]+-?\d+\.\d+[\s,]+[0-6][\s,]+\d+"
)
_SEPARATORS = str.maketrans(",/:", "   ")  # a solution line's fields, split on blanks
_CALENDAR = re.compile(r"^\s*\d{4}/\d{1,2}/\d{1,2}[\s,]+\d{1,2}:\d{1,2}:\d{1,2}(\.\d*)?[\s,]+-?\d+(\.\d+)?[\s,]")


def _sniff(head: bytes) -> bool:
    text = text_of(head)
    if text is None:
        return False
    lines = [line for line in text.split("\n")[:60] if line.strip()]
    if any(
        line.startswith("%") and re.search(r"latitude\(|x-ecef\(|e-baseline\(|\(lat/lon/height=", line)
        for line in lines
    ):
        return True
    data = [line for line in lines if not line.startswith("%")][:3]
    return bool(data) and all(_WEEK_TOW.match(line) or _CALENDAR.match(line) for line in data)


def _header(path: Path, lines: list[str]) -> tuple[str, str, bool]:
    """(time system "GPST"/"UTC"/"JST", height reference, lat/lon as d m s) from the % lines."""
    system, altitude, dms = "GPST", ELLIPSOID, False
    for number, line in enumerate(lines, start=1):
        if not line.startswith("%"):
            continue
        if "/geodetic" in line:
            altitude = MSL
        if re.search(r"x-ecef\(|e-baseline\(|n-baseline\(", line):
            raise InputError(
                f"{path}:{number}: an RTKLIB ECEF or baseline solution; tlsync reads the lat/lon/height output "
                f"(out-solformat = llh)"
            )
        if "latitude(" in line:
            found = re.match(r"%\s*(GPST|UTC|JST)\b", line)
            system = found.group(1) if found else system
            dms = "latitude(d'\")" in line or "latitude(dms)" in line
    return system, altitude, dms


def read_rtklib(path: str | Path) -> LogRecords:
    """Read every solution line; see the module notes.

    A file whose solution lines are all alike (one time layout, degrees, the same fields, numbers where numbers
    belong) is parsed at once by NumPy; any other line by line, with the same result.
    """
    path = Path(path)
    try:
        text = path.read_bytes().decode("utf-8", errors="replace")
    except OSError as exc:
        raise InputError(f"{path}: cannot read: {exc.strerror or exc}") from None
    lines = text.splitlines()
    system, altitude, dms = _header(path, lines)
    numbers = np.array(
        [n for n, line in enumerate(lines, start=1) if line.strip() and not line.startswith("%")], dtype=np.int64
    )
    ignored = len(lines) - len(numbers)
    solutions = None if dms else _solutions_at_once([lines[n - 1] for n in numbers], system)
    malformed: list[int] = []
    if solutions is None:
        solutions, numbers, malformed = _solutions_line_by_line(lines, numbers, system, dms)
    t, lat, lon, h, q, ns, sdn, sde, sdu = solutions.reshape(-1, 9).T
    dropped = {MALFORMED: malformed} if malformed else {}
    if (q == 0).any():
        dropped[NO_SOLUTION] = numbers[q == 0].tolist()
    dropped = dict(sorted(dropped.items(), key=lambda item: item[1][0]))  # reasons in the order the file shows them
    kept = q != 0
    numbers, t, lat, lon, h = numbers[kept], t[kept], lat[kept], lon[kept], h[kept]
    check_geodetic_rows(path, lat, lon, h, numbers)
    quality = {"Q": q[kept], "ns": ns[kept], "sdn": sdn[kept], "sde": sde[kept], "sdu": sdu[kept]}
    warnings = []
    counts = {QUALITY_NAMES.get(int(v), str(int(v))): n for v, n in zip(*np.unique(quality["Q"], return_counts=True))}
    if counts:
        warnings.append(
            "solutions: "
            + ", ".join(f"{n} {name}" for name, n in counts.items())
            + " (Q kept in the report; sigmas weight the refinement)"
        )
    if system == "GPST":
        warnings.append("times are GPST: converted to UTC with the leap seconds in force")
    sigma = np.sqrt((quality["sdn"] * quality["sdn"] + quality["sde"] * quality["sde"]) / 2)
    return records_of_columns(
        path,
        "rtklib",
        GEODETIC,
        t,
        np.column_stack([lat, lon, h]),
        numbers,
        dropped=dropped,
        ignored=ignored,
        warnings=warnings,
        altitude=altitude,
        sigma=None if not len(sigma) or np.isnan(sigma).all() else sigma,
        quality=quality,
    )


def _solutions_line_by_line(
    lines: list[str], numbers: np.ndarray, system: str, dms: bool
) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """(solutions (n, 9): UTC s, lat, lon, height, Q, ns, sdn, sde, sdu; their line numbers; malformed lines)."""
    solutions, read, malformed = [], [], []
    for number in numbers.tolist():
        parsed = _solution(lines[number - 1].replace(",", " ").split(), system, dms)
        if parsed is None:
            malformed.append(number)
            continue
        t, lat, lon, h, q, rest = parsed
        solutions.append([t, lat, lon, h, q, *(rest[i] if len(rest) > i else math.nan for i in range(4))])
        read.append(number)
    return np.array(solutions, dtype=np.float64).reshape(-1, 9), np.array(read, dtype=np.int64), malformed


def _solutions_at_once(lines: list[str], system: str) -> np.ndarray | None:
    """The solutions (n, 9) of solution lines that are all alike, parsed by NumPy; None for any line
    _solution would not read the same way (then the file goes line by line)."""
    if not lines:
        return None
    calendar_layout = "/" in lines[0].replace(",", " ").split()[0]
    text = "\n".join(lines)
    if text.count("/") != 2 * calendar_layout * len(lines) or text.count(":") != 2 * calendar_layout * len(lines):
        return None
    time_fields = 6 if calendar_layout else 2
    integers = [0, 1, 2, 3, 4] if calendar_layout else [0]
    table = io.StringIO(text.translate(_SEPARATORS))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # loadtxt's warning on an empty input
            values = np.loadtxt(table, ndmin=2, comments=None)
            columns = values.shape[1]
            if columns > time_fields + 3:
                integers.append(time_fields + 3)  # Q
            table.seek(0)
            np.loadtxt(table, dtype=np.int64, usecols=integers, ndmin=2, comments=None)
    except ValueError:
        return None
    if columns < time_fields + 3 or len(values) != len(lines):
        return None
    if calendar_layout:
        year, month, day, hour, minute, second = values[:, :6].T
        if not (((year >= 1) & (year <= 9999) & (month >= 1) & (month <= 12)).all()):
            return None
        first_of_month = (year - 1970).astype("datetime64[Y]").astype("datetime64[M]") + (month - 1).astype(
            "timedelta64[M]"
        )
        days = first_of_month.astype("datetime64[D]").astype(np.int64) + day.astype(np.int64) - 1
        seconds = (((days * 24 + hour.astype(np.int64)) * 60 + minute.astype(np.int64)) * 60).astype(np.float64)
        seconds = seconds + second
    else:
        week, tow = values[:, 0], values[:, 1]
        if not ((tow >= 0) & (tow < WEEK_S)).all():
            return None
        seconds = GPS_EPOCH_POSIX + week * WEEK_S + tow
    position = values[:, time_fields : time_fields + 3]
    if not (np.isfinite(seconds).all() and np.isfinite(position).all()):
        return None
    if system == "GPST":
        seconds = gpst_to_utc(seconds)
    elif system == "JST":
        seconds = seconds - 9 * 3600.0
    tail = values[:, time_fields + 3 : time_fields + 8]
    solutions = np.full((len(values), 9), math.nan)
    solutions[:, 0], solutions[:, 1:4], solutions[:, 4] = seconds, position, 0.0
    solutions[:, 4 : 4 + tail.shape[1]] = tail
    return solutions


def _solution(fields: list[str], system: str, dms: bool):
    """(UTC s, lat, lon, height, Q, [ns, sdn, sde, sdu, ...]) of one line's fields, None when they do not read."""
    try:
        if "/" in fields[0]:
            y, mo, d = (int(v) for v in fields[0].split("/"))
            hh, mm, ss = fields[1].split(":")
            seconds = calendar.timegm((y, mo, d, int(hh), int(mm), 0)) + float(ss)
        else:
            week, tow = int(fields[0]), float(fields[1])
            if not 0 <= tow < WEEK_S:
                return None
            seconds = GPS_EPOCH_POSIX + week * WEEK_S + tow
        if dms:
            lat = _dms(fields[2:5])
            lon = _dms(fields[5:8])
            h, tail = float(fields[8]), fields[9:]
        else:
            lat, lon, h, tail = float(fields[2]), float(fields[3]), float(fields[4]), fields[5:]
        q = int(tail[0]) if tail else 0
        rest = [float(v) for v in tail[1:]]
    except (ValueError, IndexError, OverflowError):
        return None
    if not all(math.isfinite(v) for v in (seconds, lat, lon, h)):
        return None
    if system == "GPST":
        seconds = float(gpst_to_utc(seconds))
    elif system == "JST":
        seconds -= 9 * 3600.0
    return seconds, lat, lon, h, q, rest


def _dms(fields: list[str]) -> float:
    d, m, s = (float(v) for v in fields)
    sign = -1.0 if fields[0].lstrip().startswith("-") else 1.0
    return sign * (abs(d) + m / 60.0 + s / 3600.0)


READER = Reader(
    "rtklib",
    "RTKLIB .pos solution (% header with latitude(deg), or GPS week + time of week lines)",
    read_rtklib,
    _sniff,
)
