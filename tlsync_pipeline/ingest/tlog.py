"""MAVLink telemetry logs (``.tlog``, as Mission Planner and QGroundControl save them), read with pymavlink.

A tlog is a stream of MAVLink packets, each after an 8-byte big-endian
stamp: the ground station's receive time (UTC microseconds), which lags the
fix by the radio link's latency and jitter. Fix times come from the
autopilot instead: ``GPS_RAW_INT.time_usec`` is the fix time on the
autopilot's boot clock (or UTC when over ~30 years), put on UTC by the boot
clock -> UTC offset that ``SYSTEM_TIME`` (``time_unix_usec`` with
``time_boot_ms``) reports, the median over each boot. Only the messages of
the sender of the most GPS_RAW_INT (the autopilot's system and component)
are used: ground stations and companion computers send SYSTEM_TIME with
their own clocks. The autopilot may
reboot mid-log: a boot clock that falls back by more than a second, to less
than half its value, starts a new boot with its own offset (smaller steps
back are packets the link repeated). A boot without any SYSTEM_TIME UTC takes the
median offset of the receive stamps instead, and the report warns.
``fix_type`` < 3 is dropped. ``alt_ellipsoid`` (mm) is used when the
autopilot fills it (not all zero), else ``alt`` (mm above MSL). ``h_acc``
(mm) is the per-fix sigma; ``eph`` (HDOP x 100), ``satellites_visible`` and
``fix_type`` are kept. Only the first GPS (``GPS_RAW_INT``) is read.
"""

from __future__ import annotations

import struct
from dataclasses import replace
from pathlib import Path

import numpy as np

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.ingest.reader import Reader
from tlsync_pipeline.ingest.records import ELLIPSOID, GEODETIC, MSL, LogRecords, check_geodetic, make_records

UNIT = "GPS_RAW_INT message"
NO_FIX = "fix_type < 3 (no 3D fix)"
NO_TIME = "time_usec 0 (no fix time)"
UTC_US = 1e15  # a time_usec above this (2001 onwards) is already UTC, not a boot clock
REBOOT_S = 1.0


def _sniff(head: bytes) -> bool:
    """Two consecutive records: a stamp between 2000 and 2100 and a MAVLink v1 (0xFE) or v2 (0xFD) start byte."""
    if len(head) < 17 or head[8] not in (0xFE, 0xFD):
        return False
    stamp = struct.unpack(">Q", head[:8])[0] * 1e-6
    if not 946684800 <= stamp <= 4102444800:
        return False
    length = (
        head[9] + (8 if head[8] == 0xFE else 12) + (13 if head[8] == 0xFD and len(head) > 10 and head[10] & 1 else 0)
    )
    nxt = 8 + length
    if len(head) < nxt + 9:
        return True
    return (
        head[nxt + 8] in (0xFE, 0xFD) and 946684800 <= struct.unpack(">Q", head[nxt : nxt + 8])[0] * 1e-6 <= 4102444800
    )


def read_tlog(path: str | Path) -> LogRecords:
    """Read GPS_RAW_INT fixes with UTC from SYSTEM_TIME; see the module notes."""
    path = Path(path)
    from pymavlink import mavutil

    events: dict[tuple[int, int], list] = {}  # (system, component) -> [(type, message number, dict, receive time)]
    log = None
    try:
        log = mavutil.mavlogfile(str(path), robust_parsing=True)
        number = 0
        while True:
            msg = log.recv_match(type=["GPS_RAW_INT", "SYSTEM_TIME"])
            if msg is None:
                break
            number += msg.get_type() == "GPS_RAW_INT"
            source = (msg.get_srcSystem(), msg.get_srcComponent())
            events.setdefault(source, []).append(
                (msg.get_type(), number, msg.to_dict(), float(getattr(msg, "_timestamp", np.nan)))
            )
    except Exception as exc:  # pymavlink raises struct/index errors on damaged streams
        raise InputError(f"{path}: not a readable MAVLink telemetry log: {type(exc).__name__}: {exc}") from None
    finally:
        if log is not None:
            log.close()
    gps_count = {source: sum(e[0] == "GPS_RAW_INT" for e in evs) for source, evs in events.items()}
    if not gps_count or max(gps_count.values()) == 0:
        raise InputError(f"{path}: no GPS_RAW_INT messages in this telemetry log")
    source = max(gps_count, key=lambda key: gps_count[key])
    fixes, offsets = split_boots(events[source])
    records = tlog_records(path, fixes, offsets)
    others = [s for s, n in gps_count.items() if n and s != source]
    if others:
        note = (
            f"GPS_RAW_INT from {len(others) + 1} senders; read system {source[0]} component {source[1]} (the most "
            f"messages)"
        )
        records = replace(records, warnings=(*records.warnings, note))
    return records


def split_boots(events: list) -> tuple[list, list]:
    """(fixes as (boot, number, dict, receive time), offsets as (boot, UTC - boot clock s)) of one sender's
    messages in file order. A boot clock falling back by more than REBOOT_S and to less than half its
    value starts a new boot; smaller steps back are packets repeated or delayed by the link."""
    fixes, offsets = [], []
    boot_index, last_boot = 0, None
    for kind, number, d, receive in events:
        if kind == "SYSTEM_TIME":
            boot_s = d["time_boot_ms"] * 1e-3
        else:
            boot_s = d["time_usec"] * 1e-6 if 0 < d["time_usec"] < UTC_US else None
        if boot_s is not None:
            if last_boot is not None and boot_s < min(last_boot - REBOOT_S, 0.5 * last_boot):
                boot_index += 1
            last_boot = boot_s
        if kind == "SYSTEM_TIME":
            if d["time_unix_usec"] > UTC_US:
                offsets.append((boot_index, d["time_unix_usec"] * 1e-6 - boot_s))
        else:
            fixes.append((boot_index, number, d, receive))
    return fixes, offsets


def tlog_records(path: Path, fixes: list[tuple[int, int, dict, float]], offsets: list[tuple[int, float]]) -> LogRecords:
    """LogRecords of (boot, number, GPS_RAW_INT dict, receive time) with (boot, UTC - boot clock) offsets."""
    boots = np.array([f[0] for f in fixes])
    numbers = np.array([f[1] for f in fixes])
    field = lambda name: np.array([float(f[2].get(name, 0)) for f in fixes])  # noqa: E731
    fix_type, time_usec, received = field("fix_type"), field("time_usec"), np.array([f[3] for f in fixes])
    lat, lon = field("lat") * 1e-7, field("lon") * 1e-7
    ellipsoid, msl = field("alt_ellipsoid") * 1e-3, field("alt") * 1e-3
    dropped, warnings = {}, []
    fix = fix_type >= 3
    if (~fix).any():
        dropped[NO_FIX] = numbers[~fix].tolist()
    if (fix & (time_usec <= 0)).any():
        dropped[NO_TIME] = numbers[fix & (time_usec <= 0)].tolist()
        fix &= time_usec > 0
    t = np.where(time_usec >= UTC_US, time_usec * 1e-6, np.nan)
    by_boot: dict[int, list] = {}
    for boot, offset in offsets:
        by_boot.setdefault(boot, []).append(offset)
    for boot in np.unique(boots):
        mine = (boots == boot) & (time_usec > 0) & (time_usec < UTC_US)
        if not mine.any():
            continue
        if boot in by_boot:
            t[mine] = time_usec[mine] * 1e-6 + float(np.median(by_boot[boot]))
        else:
            t[mine] = time_usec[mine] * 1e-6 + float(np.nanmedian(received[mine] - time_usec[mine] * 1e-6))
            warnings.append(
                f"boot {boot + 1}: no SYSTEM_TIME UTC; fix times put on UTC by the ground station's receive stamps "
                f"(off by the link latency)"
            )
    if len(np.unique(boots)) > 1:
        warnings.append(
            f"the autopilot rebooted {len(np.unique(boots)) - 1} time(s) during the log; each boot's clock is put on "
            f"UTC separately"
        )
    keep = fix & np.isfinite(t)
    use_ellipsoid = keep.any() and bool(np.all(ellipsoid[keep] != 0))
    height, altitude = (ellipsoid, ELLIPSOID) if use_ellipsoid else (msl, MSL)
    for i in np.flatnonzero(keep):
        check_geodetic(path, lat[i], lon[i], height[i], int(numbers[i]), UNIT)
    h_acc = field("h_acc") * 1e-3
    quality = {
        "fix_type": fix_type,
        "eph": field("eph"),
        "satellites_visible": field("satellites_visible"),
        "h_acc": h_acc,
    }
    order = np.argsort(t[keep], kind="stable")
    rows = np.column_stack([t, lat, lon, height])[keep][order]
    sigma = np.where(h_acc > 0, h_acc, np.nan)[keep][order]
    return make_records(
        path,
        "tlog",
        GEODETIC,
        rows,
        numbers[keep][order],
        unit=UNIT,
        dropped=dropped,
        warnings=warnings,
        altitude=altitude,
        sigma=None if np.isnan(sigma).all() else sigma,
        quality={k: v[keep][order] for k, v in quality.items()},
    )


READER = Reader("tlog", "MAVLink telemetry log .tlog (8-byte stamps before MAVLink packets)", read_tlog, _sniff)
