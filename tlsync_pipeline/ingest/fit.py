"""Garmin FIT files (watches, bike computers, action cameras), read with fitdecode.

Fixes come from ``record`` messages (activities) or ``gps_metadata``
messages (action cameras such as the VIRB), whichever has more positions.
Positions are semicircles (degrees = semicircles x 180 / 2^31); height is
``enhanced_altitude`` (else ``altitude``), metres above mean sea level (the
device's barometric height, calibrated to GPS/elevation data). Messages
without a position (no fix) are dropped. ``gps_accuracy`` (m), where
logged, is kept and used as the per-fix sigma.

Times: a FIT ``date_time`` is UTC seconds since 1989-12-31 (fitdecode gives
a datetime); values below 0x10000000 count from the device's power-on
instead. Such device times go to UTC through the file's
``timestamp_correlation`` message (UTC = device time - system_timestamp +
timestamp, with their fractional parts); without one they stay on the
device clock: offsets work, UTC does not. ``timestamp_ms`` /
``fractional_timestamp`` add sub-second parts where present.
"""

from __future__ import annotations

import datetime as dt
import math
import warnings
from pathlib import Path

import numpy as np

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.ingest.reader import Reader
from tlsync_pipeline.ingest.records import GEODETIC, MSL, LogRecords, check_geodetic, make_records, sort_by_time

SEMICIRCLE_DEG = 180.0 / 2**31
NO_POSITION = "no position (no fix)"
NO_TIME = "no timestamp"
SOURCES = ("record", "gps_metadata")


def _sniff(head: bytes) -> bool:
    return len(head) >= 12 and head[0] in (12, 14) and head[8:12] == b".FIT"


def _seconds(value, fraction: float) -> tuple[float, bool] | None:
    """(seconds, is UTC) of a FIT time field value (datetime = UTC, number = device clock)."""
    if isinstance(value, dt.datetime):
        return value.timestamp() + fraction, True
    if isinstance(value, (int, float)) and math.isfinite(value):
        return float(value) + fraction, False
    return None


def read_fit(path: str | Path) -> LogRecords:
    """Read the timed positions of a FIT file; see the module notes."""
    path = Path(path)
    import fitdecode

    messages: dict[str, list] = {name: [] for name in SOURCES}
    correlation = None
    try:
        with warnings.catch_warnings(record=True) as crc_warnings, fitdecode.FitReader(str(path), check_crc=fitdecode.CrcCheck.WARN) as reader:
            warnings.simplefilter("always")
            for frame in reader:
                if not isinstance(frame, fitdecode.FitDataMessage):
                    continue
                if frame.name in messages:
                    messages[frame.name].append({f.name: f.value for f in frame.fields})
                elif frame.name == "timestamp_correlation" and correlation is None:
                    correlation = {f.name: f.value for f in frame.fields}
    except Exception as exc:  # fitdecode raises FitError subclasses, struct and value errors on damaged files
        raise InputError(f"{path}: not a readable FIT file: {type(exc).__name__}: {exc}") from None
    source = max(SOURCES, key=lambda name: sum(1 for m in messages[name] if m.get("position_lat") is not None))
    offset = None
    if correlation is not None:
        at_utc = _seconds(correlation.get("timestamp"), float(correlation.get("fractional_timestamp") or 0.0))
        device = _seconds(correlation.get("system_timestamp"), float(correlation.get("fractional_system_timestamp") or 0.0))
        if at_utc is not None and device is not None and at_utc[1]:
            offset = at_utc[0] - device[0]
    rows, numbers, sigma = [], [], []
    dropped: dict[str, list[int]] = {}
    device_times = 0
    for number, m in enumerate(messages[source], start=1):
        fraction = float(m.get("fractional_timestamp") or 0.0) + float(m.get("timestamp_ms") or 0.0) * 1e-3
        when = _seconds(m.get("utc_timestamp") or m.get("timestamp"), fraction)
        lat, lon = m.get("position_lat"), m.get("position_long")
        height = m.get("enhanced_altitude")
        height = m.get("altitude") if height is None else height
        if lat is None or lon is None:
            dropped.setdefault(NO_POSITION, []).append(number)
            continue
        if when is None:
            dropped.setdefault(NO_TIME, []).append(number)
            continue
        t, is_utc = when
        if not is_utc:
            device_times += 1
            if offset is not None:
                t += offset
        lat, lon = float(lat) * SEMICIRCLE_DEG, float(lon) * SEMICIRCLE_DEG
        h = float(height) if isinstance(height, (int, float)) else 0.0
        check_geodetic(path, lat, lon, h, number, f"{source} message")
        rows.append([t, lat, lon, h])
        numbers.append(number)
        accuracy = m.get("gps_accuracy")
        sigma.append(float(accuracy) if isinstance(accuracy, (int, float)) else math.nan)
    utc = device_times == 0 or offset is not None
    notes = [f"{w.message} (read on; the content may be damaged)" for w in crc_warnings[:1]]
    if device_times and offset is not None:
        notes.append(f"{device_times} fix times on the device clock put on UTC by timestamp_correlation")
    elif device_times and device_times < len(rows):
        raise InputError(f"{path}: {source} messages mix UTC and device-clock times and there is no timestamp_correlation to join them")
    rows, numbers, sigma = sort_by_time(rows, numbers, sigma)
    sig = np.asarray(sigma, dtype=float)
    return make_records(
        path, "fit", GEODETIC, rows, numbers, unit=f"{source} message", utc=utc, dropped=dropped, warnings=notes,
        altitude=MSL, sigma=None if not len(sig) or np.isnan(sig).all() else sig,
        clock=None if utc else "device clock since power-on (s)",
    )


READER = Reader("fit", "Garmin FIT (bytes 8-11 '.FIT')", read_fit, _sniff)
