"""DJI flight logs as CSV exports from AirData (and tools writing the same columns).

Columns: ``time(millisecond)`` (the flight's own clock), ``datetime(utc)``
(whole seconds), ``latitude``, ``longitude``, heights in feet (``(feet)``)
or metres (``(meters)``/``(m)``): ``altitude_above_seaLevel`` (MSL: the
take-off point's ground elevation plus the barometric height) when present,
else ``height_above_takeoff`` (relative to the take-off point). Quality:
``satellites`` and ``gpslevel`` are kept.

Time: ``datetime(utc)`` has whole seconds and jitters by up to a second
against ``time(millisecond)``; UTC = time(millisecond) / 1000 + c per
recording run. Each row's d = datetime - time / 1000 lies in (c - 1, c]
when its datetime is the second it fell in, a second off when it jitters:
c is the mean of the d values in the one-second window holding the most
of them, plus half a second (the mean fraction of a second). A recording pause (both clocks
jump) or a restart of time(millisecond) starts a new run with its own c;
that makes the UTC good to about 0.1-0.2 s, time differences inside a run
exact. Rows with latitude and longitude 0 (before the first fix) are
dropped.
"""

from __future__ import annotations

import csv
import datetime as dt
import io
import math
from pathlib import Path

import numpy as np

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.ingest.reader import Reader, text_of
from tlsync_pipeline.ingest.records import GEODETIC, MSL, TAKEOFF, LogRecords, check_geodetic, make_records

NO_FIX = "latitude and longitude 0 (no fix yet)"
MALFORMED = "malformed row"
FEET = 0.3048
RUN_BREAK_S = 2.5  # a jump of datetime - time beyond this starts a new run


def _normal(name: str) -> str:
    return name.strip().lower().replace(" ", "_")


def _sniff(head: bytes) -> bool:
    text = text_of(head)
    if text is None:
        return False
    header = {_normal(c) for c in text.split("\n", 1)[0].split(",")}
    return {"time(millisecond)", "latitude", "longitude"} <= header and "datetime(utc)" in header


def _height_column(header: list[str]) -> tuple[int, float, str]:
    """(column, metres per unit, reference) of the height to use."""
    for prefix, reference in (("altitude_above_sealevel", MSL), ("height_above_takeoff", TAKEOFF)):
        for i, name in enumerate(header):
            if name.startswith(prefix + "("):
                unit = name[len(prefix) + 1 : -1]
                return i, FEET if unit in ("feet", "ft") else 1.0, reference
    raise InputError("no height column: expected altitude_above_seaLevel(feet) or height_above_takeoff(feet)")


def read_dji(path: str | Path) -> LogRecords:
    """Read an AirData-style DJI CSV; see the module notes."""
    path = Path(path)
    try:
        text = path.read_bytes().decode("utf-8-sig", errors="replace")
    except OSError as exc:
        raise InputError(f"{path}: cannot read: {exc.strerror or exc}") from None
    reader = csv.reader(io.StringIO(text))
    try:
        header = [_normal(c) for c in next(reader)]
    except StopIteration:
        raise InputError(f"{path}: empty log") from None
    except csv.Error as exc:
        raise InputError(f"{path}:1: not a CSV header: {exc}") from None
    try:
        col = {name: header.index(name) for name in ("time(millisecond)", "datetime(utc)", "latitude", "longitude")}
        height, scale, altitude = _height_column(header)
    except ValueError as exc:
        raise InputError(f"{path}:1: missing column {str(exc).split(' ')[0]}; expected an AirData CSV export") from None
    except InputError as exc:
        raise InputError(f"{path}:1: {exc}") from None
    extras = {name: header.index(name) for name in ("satellites", "gpslevel") if name in header}
    raw, dropped = [], {}
    try:
        for number, row in enumerate(reader, start=2):
            if not row or not any(c.strip() for c in row):
                continue
            try:
                ms = float(row[col["time(millisecond)"]])
                when = dt.datetime.fromisoformat(row[col["datetime(utc)"]].strip()).replace(tzinfo=dt.timezone.utc).timestamp()
                lat, lon = float(row[col["latitude"]]), float(row[col["longitude"]])
                h = float(row[height]) * scale
                extra = [float(row[i]) if row[i].strip() else math.nan for i in extras.values()]
            except (ValueError, IndexError, OverflowError):
                dropped.setdefault(MALFORMED, []).append(number)
                continue
            if not all(math.isfinite(v) for v in (ms, when, lat, lon, h)):
                dropped.setdefault(MALFORMED, []).append(number)
                continue
            if lat == 0.0 and lon == 0.0:
                dropped.setdefault(NO_FIX, []).append(number)
                continue
            check_geodetic(path, lat, lon, h, number)
            raw.append((number, ms * 1e-3, when, lat, lon, h, *extra))
    except csv.Error as exc:
        raise InputError(f"{path}:{reader.line_num}: not CSV: {exc}") from None
    data = np.array(raw, dtype=float).reshape(-1, 6 + len(extras))
    t, runs = utc_of_rows(data[:, 1], data[:, 2])
    warnings = []
    if runs > 1:
        warnings.append(f"{runs} recording runs (pauses or clock restarts): each put on UTC separately")
    if altitude == TAKEOFF:
        warnings.append("heights are above the take-off point (no altitude_above_seaLevel column)")
    rows = np.column_stack([t, data[:, 3:6]])
    quality = {name: data[:, 6 + k] for k, name in enumerate(extras)}
    return make_records(path, "dji", GEODETIC, rows, data[:, 0].astype(int), dropped=dropped, warnings=warnings, altitude=altitude, quality=quality)


def utc_of_rows(clock_s: np.ndarray, whole_utc_s: np.ndarray) -> tuple[np.ndarray, int]:
    """(UTC seconds of each row, number of runs) from the flight clock and the whole-second UTC column.

    Runs split where the clock goes back or datetime - clock jumps by more
    than RUN_BREAK_S; per run, UTC = clock + offset_of_run(datetime - clock).
    """
    if not len(clock_s):
        return clock_s.copy(), 0
    d = whole_utc_s - clock_s
    breaks = np.flatnonzero((np.diff(clock_s) < 0) | (np.abs(np.diff(d)) > RUN_BREAK_S)) + 1
    t = np.empty_like(clock_s)
    for run in np.split(np.arange(len(clock_s)), breaks):
        t[run] = clock_s[run] + offset_of_run(d[run])
    return t, len(breaks) + 1


def offset_of_run(d: np.ndarray) -> float:
    """UTC - clock from d = whole-second UTC - clock: the mean of the densest one-second window of d, plus 0.5 s."""
    d = np.sort(d)
    counts = np.searchsorted(d, d + 1.0, side="left") - np.arange(len(d))
    j = int(np.argmax(counts))
    return float(d[j : j + counts[j]].mean() + 0.5)


READER = Reader("dji", "DJI/AirData CSV (header with time(millisecond), datetime(utc), latitude, longitude)", read_dji, _sniff)
