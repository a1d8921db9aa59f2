"""The record type every log reader returns: timed positions with per-line provenance."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tlsync_pipeline.errors import InputError

GEODETIC = "geodetic"  # values are latitude, longitude (degrees), height (m, see ALTITUDE_REFERENCES)
LOCAL = "local"  # values are x, y, z metres in the log's own frame

# What a geodetic log's heights are measured from.
ELLIPSOID = "ellipsoid"  # the WGS84 ellipsoid (GNSS receivers' native height; the GCPs' reference)
MSL = "msl"  # mean sea level (the geoid): ellipsoid height minus the geoid undulation, tens of metres
TAKEOFF = "takeoff"  # the take-off point (barometric height of a drone): a relative height
ALTITUDE_REFERENCES = (ELLIPSOID, MSL, TAKEOFF)
ALTITUDE_NAMES = {ELLIPSOID: "the WGS84 ellipsoid", MSL: "mean sea level (MSL)", TAKEOFF: "the take-off point"}


@dataclass(frozen=True)
class LogRecords:
    """What a reader found in one log, in file order.

    t: float64 (N,) seconds, POSIX UTC for GPS logs (``utc`` True), the log's
    own clock otherwise; values: float64 (N, 3), lat/lon/alt (``frame`` GEODETIC)
    or x/y/z metres (``frame`` LOCAL); line: int64 (N,) 1-based provenance of
    each record, counted in ``unit`` ("line", "track point", "message");
    dropped: reason -> provenance numbers of the lines left out; ignored: lines
    that carry no position (other sentences, comments, waypoints); warnings:
    things the user should know about the whole log; altitude: what the heights
    are measured from (one of ALTITUDE_REFERENCES; local logs: ELLIPSOID, unused);
    sigma: float64 (N,) horizontal 1-sigma position uncertainty (m) of each
    record as the receiver states it, NaN where unknown, None when the log
    states none; quality: per-record quality columns kept for the report
    (name -> float64 (N,), e.g. RTKLIB "Q", "sdn", ULog "eph"); clock: for
    ``utc`` False, what the times count (e.g. "boot clock"): offsets work,
    UTC does not; notes: how the reader read the file where a choice was made
    (the time base, sub-second source, lat/lon order, precision), for the
    report; video_time_zero: for logs written in or beside a video (GoPro
    GPMF, DJI SRT), the log's time (seconds, on ``t``'s clock) at the video's
    time 0, None for other logs; video_zero_spread_s: how far the file's own
    evidence lets video_time_zero be off (s), None when it says nothing;
    rounding_m: float64 (N,) the largest horizontal error of each record from
    the printed precision of its coordinates alone (m; half the diagonal of
    one step of the last decimal), None when negligible; local_time: ``t``
    counts a local wall clock with no zone (seconds since 1970 of the local
    date and time), printed as a local date.
    """

    path: Path
    format: str
    frame: str
    t: np.ndarray
    values: np.ndarray
    line: np.ndarray
    unit: str = "line"
    utc: bool = True
    dropped: dict[str, list[int]] = field(default_factory=dict)
    ignored: int = 0
    warnings: tuple[str, ...] = ()
    altitude: str = ELLIPSOID
    sigma: np.ndarray | None = None
    quality: dict[str, np.ndarray] = field(default_factory=dict)
    clock: str = "UTC"
    notes: tuple[str, ...] = ()
    video_time_zero: float | None = None
    video_zero_spread_s: float | None = None
    rounding_m: np.ndarray | None = None
    local_time: bool = False

    def __len__(self) -> int:
        return len(self.t)

    def where(self, i: int) -> str:
        """``path:line`` (or ``path: <unit> n``) of record i, for messages."""
        return where(self.path, int(self.line[i]), self.unit)


def where(path: Path, number: int, unit: str = "line") -> str:
    """``path:12`` for lines, ``path: track point 12`` for other units."""
    return f"{path}:{number}" if unit == "line" else f"{path}: {unit} {number}"


def make_records(path, fmt, frame, rows, lines, **options) -> LogRecords:
    """LogRecords from a list of (t, a, b, c) rows and their provenance numbers; ``options``: records_of_columns's
    keywords (sigma, quality, rounding_m: one value per row).
    """
    data = np.asarray(rows, dtype=np.float64).reshape(-1, 4)
    return records_of_columns(path, fmt, frame, data[:, 0].copy(), data[:, 1:].copy(), lines, **options)


def records_of_columns(
    path,
    fmt,
    frame,
    t,
    values,
    lines,
    unit="line",
    utc=True,
    dropped=None,
    ignored=0,
    warnings=(),
    altitude=ELLIPSOID,
    sigma=None,
    quality=None,
    clock=None,
    notes=(),
    video_time_zero=None,
    video_zero_spread_s=None,
    rounding_m=None,
    local_time=False,
) -> LogRecords:
    """LogRecords from times (N,) and values (N, 3), kept as they are (no copy when float64), as make_records."""
    t = np.asarray(t, dtype=np.float64).reshape(-1)
    values = np.asarray(values, dtype=np.float64).reshape(-1, 3)
    n = len(t)
    sigma = None if sigma is None else np.asarray(sigma, dtype=np.float64).reshape(n)
    quality = {name: np.asarray(v, dtype=np.float64).reshape(n) for name, v in (quality or {}).items()}
    return LogRecords(
        Path(path),
        fmt,
        frame,
        t,
        values,
        np.asarray(lines, dtype=np.int64).reshape(-1),
        unit,
        utc,
        dict(dropped or {}),
        ignored,
        tuple(warnings),
        altitude,
        sigma,
        quality,
        "UTC" if utc else clock or "the log's own clock",
        tuple(notes),
        None if video_time_zero is None else float(video_time_zero),
        None if video_zero_spread_s is None else float(video_zero_spread_s),
        None if rounding_m is None else np.asarray(rounding_m, dtype=np.float64).reshape(n),
        bool(local_time),
    )


def sort_by_time(rows: list, numbers: list, *columns: list) -> tuple[list, ...]:
    """rows, numbers and any parallel columns reordered by the rows' times (stable)."""
    order = sorted(range(len(rows)), key=lambda i: rows[i][0])
    return tuple([seq[i] for i in order] for seq in (rows, numbers, *columns))


ALTITUDE_RANGE_M = (-12_000.0, 100_000.0)  # plausible heights above the ellipsoid


def check_geodetic(path: Path, lat: float, lon: float, alt: float, number: int, unit: str = "line") -> None:
    """InputError naming the line when a parsed fix is impossible (not mere line noise)."""
    if not -90.0 <= lat <= 90.0:
        raise InputError(f"{where(path, number, unit)}: latitude {lat!r} out of range [-90, 90]")
    if not -180.0 <= lon <= 180.0:
        raise InputError(f"{where(path, number, unit)}: longitude {lon!r} out of range [-180, 180]")
    if not ALTITUDE_RANGE_M[0] <= alt <= ALTITUDE_RANGE_M[1]:
        raise InputError(
            f"{where(path, number, unit)}: altitude {alt!r} m is not a plausible height above the ellipsoid"
        )


def check_geodetic_rows(
    path: Path, lat: np.ndarray, lon: np.ndarray, alt: np.ndarray, numbers, unit: str = "line"
) -> None:
    """check_geodetic on the first impossible fix of arrays of fixes (numbers: their provenance), if any."""
    bad = ~(
        (np.abs(lat) <= 90.0) & (np.abs(lon) <= 180.0) & (alt >= ALTITUDE_RANGE_M[0]) & (alt <= ALTITUDE_RANGE_M[1])
    )
    if bad.any():
        k = int(np.argmax(bad))
        check_geodetic(path, float(lat[k]), float(lon[k]), float(alt[k]), int(numbers[k]), unit)
