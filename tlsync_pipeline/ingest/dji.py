"""DJI flight logs as CSV: AirData exports, and the ``OSD.*`` layout of TXTlogToCSVtool / CsvView / PhantomHelp.

**AirData layout.**
Columns: ``time(millisecond)`` (the flight's own clock), ``datetime(utc)``
(whole seconds), ``latitude``, ``longitude``, heights in feet (``(feet)``)
or metres (``(meters)``/``(m)``): ``altitude_above_seaLevel`` (MSL: the
take-off point's ground elevation plus the barometric height) when present,
else ``height_above_takeoff`` (relative to the take-off point). Quality:
``satellites`` and ``gpslevel`` are kept.

Time: ``datetime(utc)`` has whole seconds and jitters by up to a second
against ``time(millisecond)``; UTC = time(millisecond) / 1000 + c per
recording run, c from the whole seconds (tlsync_pipeline.ingest.clocks). A
recording pause (both clocks jump) or a restart of time(millisecond) starts
a new run with its own c; that makes the UTC good to about 0.1 s, time
differences inside a run exact. Some exports write ``datetime(utc)`` with
milliseconds (``2024-09-11 05:47:13.200``): then c is the median of
datetime - time(millisecond) per run, as good as those milliseconds. Rows
with latitude and longitude 0 (before the first fix) are dropped.

**OSD layout** (``OSD.latitude``, ``OSD.longitude``, ``OSD.height [m]`` or
``[ft]``, ``CUSTOM.updateTime``, optionally with ``CUSTOM.date``): times are
the app's clock, to the millisecond: UTC when the column says ``[UTC]``,
else the phone's local time, whose zone the file does not state (offsets
work, UTC does not). Height is ``OSD.height``, barometric above the take-off
point. Rows with ``OSD.isGPSused`` False or latitude and longitude 0 are
dropped; ``OSD.gpsNum`` and ``OSD.gpsLevel`` are kept.
"""

from __future__ import annotations

import csv
import datetime as dt
import io
import math
from pathlib import Path

import numpy as np

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.ingest.clocks import onto_coarse_clock, whole_second_uncertainty
from tlsync_pipeline.ingest.reader import Reader, text_of
from tlsync_pipeline.ingest.records import GEODETIC, MSL, TAKEOFF, LogRecords, check_geodetic, make_records

NO_FIX = "latitude and longitude 0 (no fix yet)"
NO_GPS = "GPS not used (OSD.isGPSused False, or latitude and longitude 0)"
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
    airdata = {"time(millisecond)", "latitude", "longitude"} <= header and "datetime(utc)" in header
    return airdata or {"osd.latitude", "osd.longitude"} <= header


def _height_column(header: list[str]) -> tuple[int, float, str]:
    """(column, metres per unit, reference) of the height to use."""
    for prefix, reference in (("altitude_above_sealevel", MSL), ("height_above_takeoff", TAKEOFF)):
        for i, name in enumerate(header):
            if name.startswith(prefix + "("):
                unit = name[len(prefix) + 1 : -1]
                return i, FEET if unit in ("feet", "ft") else 1.0, reference
    raise InputError("no height column: expected altitude_above_seaLevel(feet) or height_above_takeoff(feet)")


def read_dji(path: str | Path, utc_offset_s: float | None = None) -> LogRecords:
    """Read a DJI CSV; utc_offset_s: local - UTC (s) of the OSD layout's app clock when it is local. See the module
    notes.
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
        try:
            text = raw.decode("utf-8-sig")
        except UnicodeDecodeError:
            text = raw.decode("latin-1")  # CsvView writes the phone's code page
    except OSError as exc:
        raise InputError(f"{path}: cannot read: {exc.strerror or exc}") from None
    reader = csv.reader(io.StringIO(text))
    try:
        header = [_normal(c) for c in next(reader)]
    except StopIteration:
        raise InputError(f"{path}: empty log") from None
    except csv.Error as exc:
        raise InputError(f"{path}:1: not a CSV header: {exc}") from None
    if "osd.latitude" in header:
        return _read_osd(path, header, reader, utc_offset_s)
    try:
        col = {name: header.index(name) for name in ("time(millisecond)", "datetime(utc)", "latitude", "longitude")}
        height, scale, altitude = _height_column(header)
    except ValueError as exc:
        raise InputError(f"{path}:1: missing column {str(exc).split(' ')[0]}; expected an AirData CSV export") from None
    except InputError as exc:
        raise InputError(f"{path}:1: {exc}") from None
    extras = {name: header.index(name) for name in ("satellites", "gpslevel") if name in header}
    parsed: list[tuple] = []
    dropped: dict[str, list[int]] = {}
    try:
        for number, row in enumerate(reader, start=2):
            if not row or not any(c.strip() for c in row):
                continue
            try:
                ms = float(row[col["time(millisecond)"]])
                when = (
                    dt.datetime.fromisoformat(row[col["datetime(utc)"]].strip())
                    .replace(tzinfo=dt.timezone.utc)
                    .timestamp()
                )
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
            parsed.append((number, ms * 1e-3, when, lat, lon, h, *extra))
    except csv.Error as exc:
        raise InputError(f"{path}:{reader.line_num}: not CSV: {exc}") from None
    data = np.array(parsed, dtype=float).reshape(-1, 6 + len(extras))
    whole_seconds = bool(np.all(data[:, 2] == np.floor(data[:, 2])))
    t, run = onto_coarse_clock(data[:, 1], data[:, 2], whole_seconds=whole_seconds, break_s=RUN_BREAK_S)
    runs = int(run[-1]) + 1 if len(run) else 0
    warnings = []
    if runs > 1:
        warnings.append(f"{runs} recording runs (pauses or clock restarts): each put on UTC separately")
    if altitude == TAKEOFF:
        warnings.append("heights are above the take-off point (no altitude_above_seaLevel column)")
    if utc_offset_s is not None:
        warnings.append("utc_offset is not used: an AirData CSV's datetime(utc) is UTC")
    rows = np.column_stack([t, data[:, 3:6]])
    quality = {name: data[:, 6 + k] for k, name in enumerate(extras)}
    note = (
        f"times: time(millisecond) put on UTC by the whole-second datetime(utc), one offset per run "
        f"(within {whole_second_uncertainty(data[:, 1]):.2f} s)"
        if whole_seconds
        else "times: time(millisecond) put on UTC by datetime(utc)'s milliseconds, one offset per run (the median)"
    )
    return make_records(
        path,
        "dji",
        GEODETIC,
        rows,
        data[:, 0].astype(int),
        dropped=dropped,
        warnings=warnings,
        altitude=altitude,
        quality=quality,
        notes=[note],
    )


_OSD_TIMES = (
    "%Y/%m/%d %H:%M:%S.%f",
    "%Y/%m/%d %H:%M:%S",
    "%m/%d/%Y %I:%M:%S.%f %p",
    "%m/%d/%Y %I:%M:%S %p",
    "%Y-%m-%d %H:%M:%S.%f",
    "%Y-%m-%d %H:%M:%S",
)


def _osd_time(text: str) -> float:
    """Seconds (as if UTC) of an OSD-layout time text; ValueError when no known layout fits."""
    for layout in _OSD_TIMES:
        try:
            return dt.datetime.strptime(text.strip(), layout).replace(tzinfo=dt.timezone.utc).timestamp()
        except ValueError:
            continue
    raise ValueError(text)


def _read_osd(path: Path, header: list[str], reader, utc_offset_s: float | None) -> LogRecords:
    """The OSD layout (see the module notes)."""

    def find(prefix: str) -> int | None:
        return next((i for i, name in enumerate(header) if name.startswith(prefix)), None)

    time_col, date_col = find("custom.updatetime"), find("custom.date")
    height_col = find("osd.height_[") if find("osd.height_[") is not None else find("osd.height")
    lat_col, lon_col = header.index("osd.latitude"), header.index("osd.longitude")
    if time_col is None or height_col is None:
        raise InputError(f"{path}:1: an OSD-layout DJI CSV needs CUSTOM.updateTime and OSD.height columns")
    scale = FEET if "[ft]" in header[height_col] else 1.0
    utc = header[time_col].endswith("[utc]")
    used, extras = find("osd.isgpsused"), {name: find(name) for name in ("osd.gpsnum", "osd.gpslevel")}
    rows, numbers = [], []
    dropped: dict[str, list[int]] = {}
    columns = {name: i for name, i in extras.items() if i is not None}
    quality: dict[str, list[float]] = {name: [] for name in columns}
    try:
        for number, row in enumerate(reader, start=2):
            if not row or not any(c.strip() for c in row):
                continue
            try:
                stamp = (
                    (row[date_col] + " " + row[time_col])
                    if date_col is not None and date_col != time_col
                    else row[time_col]
                )
                t = _osd_time(stamp)
                lat, lon, h = float(row[lat_col]), float(row[lon_col]), float(row[height_col]) * scale
            except (ValueError, IndexError, OverflowError):
                dropped.setdefault(MALFORMED, []).append(number)
                continue
            if not all(math.isfinite(v) for v in (lat, lon, h)):
                dropped.setdefault(MALFORMED, []).append(number)
                continue
            if (used is not None and used < len(row) and row[used].strip() == "False") or (lat == 0.0 and lon == 0.0):
                dropped.setdefault(NO_GPS, []).append(number)
                continue
            check_geodetic(path, lat, lon, h, number)
            rows.append([t, lat, lon, h])
            numbers.append(number)
            for name in quality:
                value = row[columns[name]] if columns[name] < len(row) else ""
                quality[name].append(float(value) if value.strip().replace(".", "", 1).isdigit() else math.nan)
    except csv.Error as exc:
        raise InputError(f"{path}:{reader.line_num}: not CSV: {exc}") from None
    warnings = []
    if utc_offset_s is not None and utc:
        warnings.append("utc_offset is not used: the CUSTOM.updateTime column is UTC")
    elif utc_offset_s is not None:
        rows = [[r[0] - utc_offset_s, *r[1:]] for r in rows]
        utc = True
    return make_records(
        path,
        "dji",
        GEODETIC,
        rows,
        numbers,
        utc=utc,
        dropped=dropped,
        altitude=TAKEOFF,
        quality=quality,
        warnings=warnings,
        clock=None if utc else "the DJI app's local clock (time zone not in the file)",
        local_time=not utc,
    )


READER = Reader(
    "dji",
    "DJI CSV (AirData: time(millisecond), datetime(utc), latitude, longitude; or OSD.latitude, OSD.longitude)",
    read_dji,
    _sniff,
    local_clock=True,
)
