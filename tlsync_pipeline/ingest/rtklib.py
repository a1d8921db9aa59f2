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
import math
import re
from pathlib import Path

import numpy as np

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.ingest.gps_time import GPS_EPOCH_POSIX, WEEK_S, gpst_to_utc
from tlsync_pipeline.ingest.reader import Reader, text_of
from tlsync_pipeline.ingest.records import ELLIPSOID, GEODETIC, MSL, LogRecords, check_geodetic, make_records

NO_SOLUTION = "Q 0 (no solution)"
MALFORMED = "malformed line"
QUALITY_NAMES = {1: "fix", 2: "float", 3: "SBAS", 4: "DGPS", 5: "single", 6: "PPP"}
_WEEK_TOW = re.compile(
    r"^\s*\d{3,4}[\s,]+\d+(\.\d*)?[\s,]+-?\d+\.\d+[\s,]+-?\d+\.\d+[\s,]+-?\d+\.\d+[\s,]+[0-6][\s,]+\d+"
)
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
    """Read every solution line; see the module notes."""
    path = Path(path)
    try:
        text = path.read_bytes().decode("utf-8", errors="replace")
    except OSError as exc:
        raise InputError(f"{path}: cannot read: {exc.strerror or exc}") from None
    lines = text.splitlines()
    system, altitude, dms = _header(path, lines)
    rows, numbers, sigma = [], [], []
    quality: dict[str, list[float]] = {"Q": [], "ns": [], "sdn": [], "sde": [], "sdu": []}
    dropped: dict[str, list[int]] = {}
    ignored = 0
    for number, line in enumerate(lines, start=1):
        if not line.strip() or line.startswith("%"):
            ignored += 1
            continue
        fields = line.replace(",", " ").split()
        parsed = _solution(fields, system, dms)
        if parsed is None:
            dropped.setdefault(MALFORMED, []).append(number)
            continue
        t, lat, lon, h, q, rest = parsed
        if q == 0:
            dropped.setdefault(NO_SOLUTION, []).append(number)
            continue
        check_geodetic(path, lat, lon, h, number)
        sdn, sde, sdu = (rest[i] if len(rest) > i else math.nan for i in (1, 2, 3))
        rows.append([t, lat, lon, h])
        numbers.append(number)
        sigma.append(math.sqrt((sdn * sdn + sde * sde) / 2))
        for name, value in zip(("Q", "ns", "sdn", "sde", "sdu"), (q, rest[0] if rest else math.nan, sdn, sde, sdu)):
            quality[name].append(value)
    warnings = []
    counts = (
        {QUALITY_NAMES.get(int(q), str(int(q))): n for q, n in zip(*np.unique(quality["Q"], return_counts=True))}
        if rows
        else {}
    )
    if counts:
        warnings.append(
            "solutions: "
            + ", ".join(f"{n} {name}" for name, n in counts.items())
            + " (Q kept in the report; sigmas weight the refinement)"
        )
    if system == "GPST":
        warnings.append("times are GPST: converted to UTC with the leap seconds in force")
    sig = np.asarray(sigma, dtype=float)
    return make_records(
        path,
        "rtklib",
        GEODETIC,
        rows,
        numbers,
        dropped=dropped,
        ignored=ignored,
        warnings=warnings,
        altitude=altitude,
        sigma=None if not len(sig) or np.isnan(sig).all() else sig,
        quality=quality,
    )


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
