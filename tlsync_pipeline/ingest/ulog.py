"""PX4 ULog (``.ulg``): the GNSS receiver's fixes, read with pyulog.

The topic is ``vehicle_gps_position`` (``sensor_gps`` in newer PX4), the
receiver's own fixes, never the estimator's output. Positions are 1e-7 degree
integers ``lat``/``lon`` with heights in millimetres (``alt`` above MSL,
``alt_ellipsoid`` above the ellipsoid), or, since PX4 1.14, float
``latitude_deg``/``longitude_deg``/``altitude_msl_m``/``altitude_ellipsoid_m``.
Heights are ellipsoidal when the log has them (not all zero), MSL otherwise.
Times: ``time_utc_usec`` (UTC from the receiver) where non-zero; a log
without it is on the boot clock (``timestamp``, microseconds since the
autopilot started): offsets work, UTC does not. Fixes with ``fix_type`` < 3
(no 3D fix) are dropped. ``eph`` (horizontal 1-sigma, m) is the per-fix
sigma; ``epv``, ``fix_type``, ``satellites_used`` and ``hdop`` are kept.
With several receivers (multi-instance topics) the instance with the most
3D fixes is read and the report says so.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.ingest.reader import Reader
from tlsync_pipeline.ingest.records import ELLIPSOID, GEODETIC, MSL, LogRecords, check_geodetic, make_records

MAGIC = b"ULog\x01\x12\x35"
TOPICS = ("vehicle_gps_position", "sensor_gps")
UNIT = "GPS message"
NO_FIX = "fix_type < 3 (no 3D fix)"
NO_UTC = "no UTC (time_utc_usec 0) in a log that has UTC elsewhere"
QUALITY = ("eph", "epv", "fix_type", "satellites_used", "hdop")


def _columns(data: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, str]:
    """(lat, lon, height, msl height) in degrees and metres, and the height reference, from either field layout."""
    if "latitude_deg" in data:
        lat, lon = data["latitude_deg"].astype(float), data["longitude_deg"].astype(float)
        msl = data["altitude_msl_m"].astype(float)
        ellipsoid = data.get("altitude_ellipsoid_m")
        ellipsoid = None if ellipsoid is None else ellipsoid.astype(float)
    else:
        lat, lon = data["lat"].astype(float) * 1e-7, data["lon"].astype(float) * 1e-7
        msl = data["alt"].astype(float) * 1e-3
        ellipsoid = data.get("alt_ellipsoid")
        ellipsoid = None if ellipsoid is None else ellipsoid.astype(float) * 1e-3
    if ellipsoid is not None and np.any(ellipsoid != 0):
        return lat, lon, ellipsoid, msl, ELLIPSOID
    return lat, lon, msl, msl, MSL


def read_ulog(path: str | Path) -> LogRecords:
    """Read the 3D fixes of the GNSS topic; see the module notes."""
    path = Path(path)
    from pyulog import ULog

    try:
        ulog = ULog(str(path), list(TOPICS), disable_str_exceptions=True)
    except Exception as exc:  # pyulog raises bare Exceptions, struct and index errors on damaged files
        raise InputError(f"{path}: not a readable PX4 ULog file: {exc}") from None
    found = [
        d
        for d in ulog.data_list
        if d.name in TOPICS and len(d.data.get("timestamp", ())) and {"fix_type"} <= set(d.data)
    ]
    if not found:
        raise InputError(
            f"{path}: no GNSS fixes in this ULog (no {' or '.join(TOPICS)} topic); was a GPS connected and logged?"
        )
    best = max(found, key=lambda d: int(np.count_nonzero(d.data["fix_type"] >= 3)))
    warnings = []
    if len(found) > 1:
        warnings.append(
            f"{len(found)} GNSS instances in the log; read {best.name} instance {best.multi_id} (the most 3D fixes)"
        )
    data = best.data
    try:
        lat, lon, height, _, altitude = _columns(data)
    except KeyError as exc:
        raise InputError(
            f"{path}: {best.name} has no field {exc.args[0]!r}; expected lat/lon/alt or "
            f"latitude_deg/longitude_deg/altitude_msl_m"
        ) from None
    boot = data["timestamp"].astype(float) * 1e-6
    utc_us = data.get("time_utc_usec", np.zeros(len(boot))).astype(float)
    numbers = np.arange(1, len(boot) + 1)
    fix = data["fix_type"] >= 3
    dropped = {NO_FIX: numbers[~fix].tolist()} if (~fix).any() else {}
    has_utc = bool((utc_us[fix] > 0).any())
    if has_utc:
        no_utc = fix & (utc_us <= 0)
        if no_utc.any():
            dropped[NO_UTC] = numbers[no_utc].tolist()
        fix &= utc_us > 0
        t = utc_us * 1e-6
    else:
        t = boot
        warnings.append(
            "no UTC in the GNSS messages (time_utc_usec 0): times are the autopilot's boot clock; offsets work, UTC "
            "does not"
        )
    keep = fix & np.isfinite(lat) & np.isfinite(lon) & np.isfinite(height)
    for i in np.flatnonzero(keep):
        check_geodetic(path, lat[i], lon[i], height[i], int(numbers[i]), f"{best.name} {UNIT}")
    rows = np.column_stack([t, lat, lon, height])[keep]
    quality = {name: data[name].astype(float)[keep] for name in QUALITY if name in data}
    sigma = data["eph"].astype(float)[keep] if "eph" in data else None
    order = np.argsort(rows[:, 0], kind="stable")
    return make_records(
        path,
        "ulog",
        GEODETIC,
        rows[order],
        numbers[keep][order],
        unit=f"{best.name} {UNIT}",
        utc=has_utc,
        dropped=dropped,
        warnings=warnings,
        altitude=altitude,
        sigma=None if sigma is None else sigma[order],
        quality={k: v[order] for k, v in quality.items()},
        clock=None if has_utc else "PX4 boot clock (s)",
    )


READER = Reader("ulog", "PX4 ULog (magic 'ULog')", read_ulog, lambda head: head.startswith(MAGIC))
