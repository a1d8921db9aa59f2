"""GPS logs (GPX, NMEA 0183, CSV) of a known ENU trajectory, written as devices write them.

Positions are the trajectory's ENU metres at ``origin`` converted to WGS84
with tlsync's geodesy; times are ``start_utc + sample / rate`` (POSIX
seconds). Rounding as devices do: GPX and CSV 1e-7 degree (<= 6 mm) and
1 mm heights; NMEA ``minute_decimals`` decimals of arc-minutes (5: <= 9 mm
north) and ``alt_decimals`` for the altitude above the geoid, with a constant
geoid separation. Samples absent from the trajectory (gaps) are absent from
the logs. ``corrupt`` lists 0-based sample indices whose line is damaged in
the written NMEA/CSV log (NMEA: a flipped digit, so a bad checksum; CSV: a
field cut off).
"""

from __future__ import annotations

import datetime as dt
from functools import reduce
from operator import xor
from pathlib import Path

import numpy as np

from tlsync_pipeline.geodesy import Origin, enu_to_geodetic
from tlsync_pipeline.trajectory import Trajectory

GEOID_SEPARATION_M = 47.25  # geoid above the ellipsoid, written in every GGA


def log_fixes(trajectory: Trajectory, origin: Origin, start_utc: float | dt.datetime) -> tuple[np.ndarray, np.ndarray]:
    """(POSIX times (N,), lat/lon/height (N, 3)) of the trajectory's samples."""
    if trajectory.rate is None:
        raise ValueError("the trajectory needs a rate to be written as a timed log")
    start = start_utc.timestamp() if isinstance(start_utc, dt.datetime) else float(start_utc)
    return start + trajectory.sample / trajectory.rate, enu_to_geodetic(trajectory.xyz, origin)


def _iso(t: float) -> str:
    return (
        dt.datetime.fromtimestamp(round(t, 3), dt.timezone.utc)
        .isoformat(timespec="milliseconds")
        .replace("+00:00", "Z")
    )


def write_gpx_log(path, trajectory: Trajectory, origin: Origin, start_utc, version: str = "1.1") -> Path:
    """A GPX track, one segment per unbroken run of samples (a gap starts a new segment)."""
    t, geo = log_fixes(trajectory, origin, start_utc)
    ns = "http://www.topografix.com/GPX/1/1" if version == "1.1" else "http://www.topografix.com/GPX/1/0"
    out = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<gpx version="{version}" creator="tlsync data_fixtures" xmlns="{ns}">',
        '<wpt lat="47.0" lon="8.0"><name>ignored waypoint</name></wpt>',
        "<trk><name>target</name>",
    ]
    breaks = set((np.flatnonzero(np.diff(trajectory.sample) > 1.5) + 1).tolist())
    out.append("<trkseg>")
    for i, (ti, (lat, lon, h)) in enumerate(zip(t, geo)):
        if i in breaks:
            out.append("</trkseg><trkseg>")
        out.append(f'<trkpt lat="{lat:.7f}" lon="{lon:.7f}"><ele>{h:.3f}</ele><time>{_iso(ti)}</time></trkpt>')
    out += ["</trkseg>", "</trk>", "</gpx>", ""]
    path = Path(path)
    path.write_text("\n".join(out), encoding="utf-8")
    return path


def _nmea(body: str) -> str:
    return f"${body}*{reduce(xor, body.encode('ascii'), 0):02X}"


def _dm(value: float, degree_digits: int, decimals: int, hemispheres: str) -> str:
    hemi = hemispheres[0] if value >= 0 else hemispheres[1]
    value = abs(value)
    minutes = round(value * 60.0, decimals)
    degrees, minutes = divmod(minutes, 60.0)
    return f"{int(degrees):0{degree_digits}d}{minutes:0{3 + decimals}.{decimals}f},{hemi}"


def nmea_sentences(
    t: float,
    lat: float,
    lon: float,
    h: float,
    talker: str = "GP",
    minute_decimals: int = 5,
    alt_decimals: int = 2,
    quality: int = 1,
) -> tuple[str, str]:
    """(GGA, RMC) lines for one fix at POSIX time t, height h above the ellipsoid."""
    when = dt.datetime.fromtimestamp(round(t, 3), dt.timezone.utc)
    hms = when.strftime("%H%M%S") + f".{when.microsecond // 1000:03d}"
    la, lo = _dm(lat, 2, minute_decimals, "NS"), _dm(lon, 3, minute_decimals, "EW")
    alt = h - GEOID_SEPARATION_M
    gga = _nmea(f"{talker}GGA,{hms},{la},{lo},{quality},12,0.8,{alt:.{alt_decimals}f},M,{GEOID_SEPARATION_M:.2f},M,,")
    rmc = _nmea(f"{talker}RMC,{hms},A,{la},{lo},0.5,90.0,{when.strftime('%d%m%y')},,,A")
    return gga, rmc


def write_nmea_log(
    path,
    trajectory: Trajectory,
    origin: Origin,
    start_utc,
    talker: str = "GP",
    minute_decimals: int = 5,
    alt_decimals: int = 2,
    corrupt=(),
) -> Path:
    """GGA + RMC per fix (and a GSV now and then, which carries no position); CRLF line ends."""
    t, geo = log_fixes(trajectory, origin, start_utc)
    corrupt = set(corrupt)
    lines = []
    for i, (ti, (lat, lon, h)) in enumerate(zip(t, geo)):
        gga, rmc = nmea_sentences(ti, lat, lon, h, talker, minute_decimals, alt_decimals)
        if i in corrupt:
            digit = gga.index(",", 7) + 3
            gga = gga[:digit] + str((int(gga[digit]) + 1) % 10) + gga[digit + 1 :]
        lines += [gga, rmc]
        if i % 50 == 0:
            lines.append(_nmea("GPGSV,3,1,12,01,40,083,46,02,17,308,41,12,07,344,39,14,22,228,45"))
    path = Path(path)
    path.write_bytes(("\r\n".join(lines) + "\r\n").encode("ascii"))
    return path


def write_csv_log(path, trajectory: Trajectory, origin: Origin, start_utc, iso_times: bool = True, corrupt=()) -> Path:
    """``time,lat,lon,alt`` rows: ISO 8601 UTC times (or POSIX seconds), 1e-7 degree, mm heights."""
    t, geo = log_fixes(trajectory, origin, start_utc)
    corrupt = set(corrupt)
    rows = ["time,lat,lon,alt"]
    for i, (ti, (lat, lon, h)) in enumerate(zip(t, geo)):
        row = f"{_iso(ti) if iso_times else f'{ti:.3f}'},{lat:.7f},{lon:.7f},{h:.3f}"
        rows.append(row.rsplit(",", 1)[0] if i in corrupt else row)
    path = Path(path)
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


def walk_trajectory(
    seconds: float = 120.0, rate: float = 10.0, gap: tuple[float, float] | None = (50.0, 30.0), radius_m: float = 150.0
) -> Trajectory:
    """A smooth known path: a loop of radius_m at walking-to-cycling speed, height +-5 m.

    gap (start s, length s) removes the samples in [start, start + length)
    while keeping every other sample's grid index.
    """
    k = np.arange(int(round(seconds * rate)) + 1, dtype=np.float64)
    s = k / rate
    phase = 2 * np.pi * s / 300.0
    xyz = np.column_stack(
        [radius_m * np.sin(phase), radius_m * (1 - np.cos(phase)) + 0.5 * s, 5 * np.sin(2 * np.pi * s / 90.0)]
    )
    keep = np.ones(len(k), dtype=bool) if gap is None else ~((s >= gap[0]) & (s < gap[0] + gap[1]))
    return Trajectory(k[keep], xyz[keep], rate, 0.0)
