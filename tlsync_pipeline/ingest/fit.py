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
instead. A fix's time is its ``timestamp`` plus the sub-second part the
message carries, ``timestamp_ms`` (ms: the VIRB's ``gps_metadata``) or
``fractional_timestamp`` (1/32768 s); without either it has whole seconds.
Device times go to UTC through the file's ``timestamp_correlation`` (UTC -
device time = timestamp - system_timestamp, each with its sub-second part:
``timestamp_ms`` / ``system_timestamp_ms`` as the VIRB writes them, or
``fractional_timestamp`` / ``fractional_system_timestamp``); without one,
through the whole-second ``utc_timestamp`` a VIRB writes in each
``gps_metadata`` (the offset from the whole seconds,
tlsync_pipeline.ingest.clocks: within 0.05 s at 10 Hz); without either they
stay on the device clock: offsets work, UTC does not. ``utc_timestamp`` is
never a fix's time itself: it has whole seconds, and the ``timestamp_ms``
beside it belongs to ``timestamp``. The report states which sub-second
source and which UTC anchor were used.
"""

from __future__ import annotations

import datetime as dt
import math
import warnings
from pathlib import Path

import numpy as np

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.ingest.clocks import onto_coarse_clock, whole_second_uncertainty
from tlsync_pipeline.ingest.reader import Reader
from tlsync_pipeline.ingest.records import GEODETIC, MSL, LogRecords, check_geodetic, make_records, sort_by_time

SEMICIRCLE_DEG = 180.0 / 2**31
NO_POSITION = "no position (no fix)"
NO_TIME = "no timestamp"
SOURCES = ("record", "gps_metadata")
RUN_BREAK_S = 2.5  # a jump of utc_timestamp - device time beyond this starts a new run


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

    messages: dict[str, list[dict]] = {name: [] for name in SOURCES}
    correlation = None
    try:
        with (
            warnings.catch_warnings(record=True) as crc_warnings,
            fitdecode.FitReader(str(path), check_crc=fitdecode.CrcCheck.WARN) as reader,
        ):
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
    offset, anchor = _correlation_offset(correlation)
    rows: list[list[float]] = []
    numbers: list[int] = []
    sigma: list[float] = []
    dropped: dict[str, list[int]] = {}
    coarse: list[float] = []
    fractions: set[str | None] = set()
    device_times = 0
    for number, m in enumerate(messages[source], start=1):
        fraction, unit = _fraction(m.get("timestamp_ms"), m.get("fractional_timestamp"))
        when = _seconds(m.get("timestamp"), fraction)
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
        fractions.add(unit)
        if not is_utc:
            device_times += 1
            if offset is not None:
                t += offset
        lat, lon = float(lat) * SEMICIRCLE_DEG, float(lon) * SEMICIRCLE_DEG
        h = float(height) if isinstance(height, (int, float)) else 0.0
        check_geodetic(path, lat, lon, h, number, f"{source} message")
        rows.append([t, lat, lon, h])
        numbers.append(number)
        utc_whole = _seconds(m.get("utc_timestamp"), 0.0)
        coarse.append(utc_whole[0] if utc_whole is not None and utc_whole[1] else math.nan)
        accuracy = m.get("gps_accuracy")
        sigma.append(float(accuracy) if isinstance(accuracy, (int, float)) else math.nan)
    units = sorted(u for u in fractions if u)
    notes = [
        f"fix times: {source} timestamp "
        + (
            f"+ {' / '.join(units)}"
            if units
            else "in whole seconds (the messages have no timestamp_ms or fractional_timestamp)"
        )
    ]
    whole = np.asarray(coarse, dtype=float)
    if device_times and offset is not None:
        notes.append(
            f"device clock put on UTC by timestamp_correlation ({anchor}): UTC - device clock = {offset:.3f} s"
        )
    elif device_times == len(rows) > 0 and np.isfinite(whole).all():
        data = np.asarray(rows)
        device = data[:, 0].copy()
        data[:, 0], run = onto_coarse_clock(device, whole, whole_seconds=True, break_s=RUN_BREAK_S)
        rows, offset = data.tolist(), float(np.median(data[:, 0] - device))
        notes.append(
            f"device clock put on UTC by the whole-second utc_timestamp of each {source} (no timestamp_correlation; "
            f"{int(run[-1]) + 1} run(s), within {whole_second_uncertainty(device):.2f} s)"
        )
    utc = device_times == 0 or offset is not None
    if device_times and not utc and device_times < len(rows):
        raise InputError(
            f"{path}: {source} messages mix UTC and device-clock times and there is no timestamp_correlation to join "
            f"them"
        )
    problems = [f"{w.message} (read on; the content may be damaged)" for w in crc_warnings[:1]]
    known = np.isfinite(whole)
    if device_times and utc and known.any():
        lag = float(np.median(whole[known] - np.asarray(rows)[known, 0]))
        if not -1.5 < lag < 0.5:
            problems.append(
                f"the fixes' own utc_timestamp is {lag:+.1f} s (median) from their times put on UTC: the "
                f"timestamp_correlation and the receiver disagree"
            )
    rows, numbers, sigma = sort_by_time(rows, numbers, sigma)
    sig = np.asarray(sigma, dtype=float)
    return make_records(
        path,
        "fit",
        GEODETIC,
        rows,
        numbers,
        unit=f"{source} message",
        utc=utc,
        dropped=dropped,
        warnings=problems,
        altitude=MSL,
        sigma=None if not len(sig) or np.isnan(sig).all() else sig,
        clock=None if utc else "device clock since power-on (s)",
        notes=notes,
    )


def _fraction(ms, fractional) -> tuple[float, str | None]:
    """(sub-second part of a message's timestamp in s, the field it came from)."""
    if isinstance(ms, (int, float)) and math.isfinite(ms):
        return float(ms) * 1e-3, "timestamp_ms"
    if isinstance(fractional, (int, float)) and math.isfinite(fractional):
        return float(fractional), "fractional_timestamp"
    return 0.0, None


def _correlation_offset(correlation: dict | None) -> tuple[float | None, str | None]:
    """(UTC - device clock in s, the sub-second fields used) from a timestamp_correlation message."""
    if correlation is None:
        return None, None
    utc_fraction, utc_unit = _fraction(correlation.get("timestamp_ms"), correlation.get("fractional_timestamp"))
    device_fraction, device_unit = _fraction(
        correlation.get("system_timestamp_ms"), correlation.get("fractional_system_timestamp")
    )
    utc = _seconds(correlation.get("timestamp"), utc_fraction)
    device = _seconds(correlation.get("system_timestamp"), device_fraction)
    if utc is None or device is None or not utc[1]:
        return None, None
    names = {
        "timestamp_ms": "timestamp_ms and system_timestamp_ms",
        "fractional_timestamp": "fractional_timestamp and fractional_system_timestamp",
    }
    return utc[0] - device[0], names.get(utc_unit or device_unit or "", "whole seconds")


READER = Reader("fit", "Garmin FIT (bytes 8-11 '.FIT')", read_fit, _sniff)
