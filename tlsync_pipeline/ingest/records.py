"""The record type every log reader returns: timed positions with per-line provenance."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tlsync_pipeline.errors import InputError

GEODETIC = "geodetic"  # values are latitude, longitude (degrees), height above the WGS84 ellipsoid (m)
LOCAL = "local"  # values are x, y, z metres in the log's own frame


@dataclass(frozen=True)
class LogRecords:
    """What a reader found in one log, in file order.

    t: float64 (N,) seconds, POSIX UTC for GPS logs (``utc`` True), the log's
    own clock otherwise; values: float64 (N, 3), lat/lon/alt (``frame`` GEODETIC)
    or x/y/z metres (``frame`` LOCAL); line: int64 (N,) 1-based provenance of
    each record, counted in ``unit`` ("line", "track point", "message");
    dropped: reason -> provenance numbers of the lines left out; ignored: lines
    that carry no position (other sentences, comments, waypoints); warnings:
    things the user should know about the whole log.
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

    def __len__(self) -> int:
        return len(self.t)

    def where(self, i: int) -> str:
        """``path:line`` (or ``path: <unit> n``) of record i, for messages."""
        return where(self.path, int(self.line[i]), self.unit)


def where(path: Path, number: int, unit: str = "line") -> str:
    """``path:12`` for lines, ``path: track point 12`` for other units."""
    return f"{path}:{number}" if unit == "line" else f"{path}: {unit} {number}"


def make_records(path, fmt, frame, rows, lines, unit="line", utc=True, dropped=None, ignored=0, warnings=()) -> LogRecords:
    """LogRecords from a list of (t, a, b, c) rows and their provenance numbers."""
    data = np.asarray(rows, dtype=np.float64).reshape(-1, 4)
    return LogRecords(
        Path(path), fmt, frame, data[:, 0].copy(), data[:, 1:].copy(), np.asarray(lines, dtype=np.int64).reshape(-1),
        unit, utc, dict(dropped or {}), ignored, tuple(warnings),
    )


def check_geodetic(path: Path, lat: float, lon: float, alt: float, number: int, unit: str = "line") -> None:
    """InputError naming the line when a parsed fix is impossible (not mere line noise)."""
    if not -90.0 <= lat <= 90.0:
        raise InputError(f"{where(path, number, unit)}: latitude {lat!r} out of range [-90, 90]")
    if not -180.0 <= lon <= 180.0:
        raise InputError(f"{where(path, number, unit)}: longitude {lon!r} out of range [-180, 180]")
    if not -12_000.0 <= alt <= 100_000.0:
        raise InputError(f"{where(path, number, unit)}: altitude {alt!r} m is not a plausible height above the ellipsoid")
