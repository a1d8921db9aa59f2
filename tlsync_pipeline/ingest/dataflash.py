"""ArduPilot DataFlash logs (``.bin``): GPS fixes, read with pymavlink's DFReader.

``GPS`` messages (first receiver: instance ``I`` 0, or the messages named
``GPS`` in logs that name the second ``GPS2``) give ``Lat``/``Lng`` (degrees)
and ``Alt`` (metres above MSL); ``Status`` < 3 (no 3D fix) is dropped. UTC
comes from the GPS week ``GWk`` and milliseconds of week ``GMS`` minus the
leap seconds in force (tlsync_pipeline.ingest.gps_time); fixes with week 0
have no UTC and are dropped (a log where no fix has a week is read on the
boot clock ``TimeUS``: offsets work, UTC does not). Where ``GPA`` is logged
with a non-zero undulation ``Und`` (ArduPilot's: MSL height minus ellipsoidal
height, as the receiver reports both), heights are ellipsoidal, ``Alt -
Und``; otherwise they stay above MSL.
``GPA.HAcc`` (m) is the per-fix sigma; ``HDop``, ``NSats``, ``Status`` and
``GPA.VAcc`` are kept.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.ingest.gps_time import week_tow_to_utc
from tlsync_pipeline.ingest.reader import Reader
from tlsync_pipeline.ingest.records import ELLIPSOID, GEODETIC, MSL, LogRecords, check_geodetic, make_records

MAGIC = b"\xa3\x95\x80"  # message header, then the FMT message's own type 128
UNIT = "GPS message"
NO_FIX = "Status < 3 (no 3D fix)"
NO_WEEK = "GPS week 0 (no UTC yet)"


def read_dataflash(path: str | Path) -> LogRecords:
    """Read the first receiver's 3D fixes; see the module notes."""
    path = Path(path)
    from pymavlink.DFReader import DFReader_binary

    gps, gpa, log = [], {}, None
    try:
        log = DFReader_binary(str(path), zero_time_base=True)
        while True:
            msg = log.recv_match(type=["GPS", "GPA"])
            if msg is None:
                break
            d = msg.to_dict()
            if d.get("I", 0) != 0:
                continue
            if msg.get_type() == "GPS":
                gps.append(d)
            elif "TimeUS" in d:
                gpa[int(d["TimeUS"])] = d
    except InputError:
        raise
    except Exception as exc:  # DFReader raises struct, index and value errors on damaged logs
        raise InputError(f"{path}: not a readable ArduPilot DataFlash log: {type(exc).__name__}: {exc}") from None
    finally:
        if log is not None:
            log.close()
    if not gps:
        raise InputError(
            f"{path}: no GPS messages in this DataFlash log (was a GPS connected? is LOG_BITMASK logging GPS?)"
        )
    return dataflash_records(path, gps, gpa)


def dataflash_records(path: Path, gps: list[dict], gpa: dict[int, dict]) -> LogRecords:
    """LogRecords of GPS message dicts (DFReader's to_dict), with GPA dicts by TimeUS."""

    def column(name, *aliases, default=np.nan):
        for key in (name, *aliases):
            if key in gps[0]:
                return np.array([float(d.get(key, default)) for d in gps])
        return np.full(len(gps), default)

    numbers = np.arange(1, len(gps) + 1)
    status = column("Status")
    lat, lon, alt = column("Lat"), column("Lng", "Lon"), column("Alt")
    week, ms = column("GWk", "Week", default=0.0), column("GMS", "TimeMS", default=0.0)
    boot = column("TimeUS", default=np.nan) * 1e-6
    if np.isnan(boot).all():
        boot = column("TimeMS", default=np.nan) * 1e-3
    und, hacc, vacc = (
        np.array([float(gpa.get(int(d.get("TimeUS", -1)), {}).get(k, np.nan)) for d in gps])
        for k in ("Und", "HAcc", "VAcc")
    )
    dropped = {}
    fix = status >= 3
    if (~fix).any():
        dropped[NO_FIX] = numbers[~fix].tolist()
    has_utc = bool((week[fix] > 0).any())
    warnings = []
    if has_utc:
        if (fix & (week <= 0)).any():
            dropped[NO_WEEK] = numbers[fix & (week <= 0)].tolist()
        fix &= week > 0
        t = week_tow_to_utc(week, ms * 1e-3)
    else:
        t = boot
        warnings.append(
            "no GPS week in the fixes: times are the autopilot's boot clock (TimeUS); offsets work, UTC does not"
        )
    keep = fix & np.isfinite(lat) & np.isfinite(lon) & np.isfinite(alt) & np.isfinite(t)
    ellipsoidal = keep & np.isfinite(und) & (und != 0)
    if ellipsoidal[keep].all() and keep.any():
        height, altitude = alt - und, ELLIPSOID
    else:
        height, altitude = alt, MSL
        if ellipsoidal.any():
            warnings.append("GPA undulation logged for only some fixes: heights kept above MSL for all")
    for i in np.flatnonzero(keep):
        check_geodetic(path, lat[i], lon[i], height[i], int(numbers[i]), UNIT)
    rows = np.column_stack([t, lat, lon, height])[keep]
    quality = {"Status": status, "HDop": column("HDop"), "NSats": column("NSats"), "HAcc": hacc, "VAcc": vacc}
    return make_records(
        path,
        "dataflash",
        GEODETIC,
        rows,
        numbers[keep],
        unit=UNIT,
        utc=has_utc,
        dropped=dropped,
        warnings=warnings,
        altitude=altitude,
        sigma=None if np.isnan(hacc).all() else hacc[keep],
        quality={k: v[keep] for k, v in quality.items() if not np.isnan(v).all()},
        clock=None if has_utc else "ArduPilot boot clock (s)",
    )


READER = Reader(
    "dataflash",
    "ArduPilot DataFlash .bin (starts with its FMT table, bytes A3 95 80)",
    read_dataflash,
    lambda head: head.startswith(MAGIC),
)
