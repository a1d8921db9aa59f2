"""Geodetic (WGS84 latitude, longitude, ellipsoidal height) <-> local East-North-Up metres.

The one conversion tlsync uses for target logs and ground control points
alike, so cameras and trajectory share one world frame. Implemented with
PROJ's topocentric conversion through pyproj.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from pyproj import Transformer


@dataclass(frozen=True)
class Origin:
    """The ENU frame's origin: degrees, degrees, metres above the WGS84 ellipsoid."""

    lat: float
    lon: float
    alt: float

    def __post_init__(self) -> None:
        # Plain floats: a numpy scalar's repr would corrupt the PROJ pipeline string.
        for name in ("lat", "lon", "alt"):
            object.__setattr__(self, name, float(getattr(self, name)))
        if not (-90.0 <= self.lat <= 90.0 and -180.0 <= self.lon <= 180.0 and np.isfinite(self.alt)):
            raise ValueError(f"origin out of range: lat={self.lat}, lon={self.lon}, alt={self.alt}")


@lru_cache(maxsize=16)
def _to_enu(origin: Origin) -> Transformer:
    from pyproj import Transformer  # loaded when a geodetic file is converted, not for every command

    return Transformer.from_pipeline(
        "+proj=pipeline +step +proj=unitconvert +xy_in=deg +xy_out=rad "
        "+step +proj=cart +ellps=WGS84 "
        f"+step +proj=topocentric +ellps=WGS84 +lat_0={origin.lat!r} +lon_0={origin.lon!r} +h_0={origin.alt!r}"
    )


def geodetic_to_enu(lat, lon, alt, origin: Origin) -> np.ndarray:
    """(N, 3) East, North, Up metres of WGS84 points (degrees, degrees, metres)."""
    lat, lon, alt = (np.asarray(v, dtype=np.float64) for v in (lat, lon, alt))
    east, north, up = _to_enu(origin).transform(lon, lat, alt)
    return np.column_stack([np.ravel(east), np.ravel(north), np.ravel(up)])


def enu_to_geodetic(enu: np.ndarray, origin: Origin) -> np.ndarray:
    """(N, 3) latitude, longitude (degrees), height (metres) of ENU points."""
    enu = np.asarray(enu, dtype=np.float64).reshape(-1, 3)
    lon, lat, alt = _to_enu(origin).transform(enu[:, 0], enu[:, 1], enu[:, 2], direction="INVERSE")
    return np.column_stack([lat, lon, alt])


FAR_M = 10_000.0  # geodetic points this far (horizontally) from where they should be are a slip, not a survey error
FOOT_M = 0.3048

# Common slips in a table of geodetic points, each with the edit that undoes it.
SLIPS = (
    ("latitude and longitude look swapped: exchange the lat and lon columns", lambda lat, lon: (lon, lat)),
    ("the longitude's sign looks wrong (west of Greenwich is negative)", lambda lat, lon: (lat, -lon)),
    ("the latitude's sign looks wrong (south of the equator is negative)", lambda lat, lon: (-lat, lon)),
    ("the signs of latitude and longitude look wrong (west and south are negative)", lambda lat, lon: (-lat, -lon)),
)


def horizontal_distance(lat, lon, origin: Origin) -> np.ndarray:
    """Horizontal distances (m) of WGS84 points (degrees) from ``origin``."""
    enu = geodetic_to_enu(lat, lon, np.full(np.shape(lat), origin.alt), origin)
    return np.hypot(enu[:, 0], enu[:, 1])


def likely_slip(lat, lon, near: Origin, limit_m: float = FAR_M) -> str | None:
    """Which common slip (latitude and longitude swapped, a sign) explains points that lie far from ``near``:
    the one whose edit brings every point within ``limit_m`` of it, in words; None when none does."""
    lat, lon = np.asarray(lat, dtype=np.float64), np.asarray(lon, dtype=np.float64)
    for words, undo in SLIPS:
        new_lat, new_lon = undo(lat, lon)
        if np.all(np.abs(new_lat) <= 90.0) and np.all(horizontal_distance(new_lat, new_lon, near) <= limit_m):
            return words
    return None


def heights_in_feet(alt, near: Origin, high_m: float = 300.0, tolerance_m: float = 100.0) -> bool:
    """Whether heights (m, as given) far above or below ``near`` would lie at its height if they were feet."""
    alt = np.asarray(alt, dtype=np.float64)
    return bool(abs(np.median(alt) - near.alt) > high_m and abs(np.median(alt) * FOOT_M - near.alt) <= tolerance_m)


def median_point(lat, lon, alt) -> Origin:
    """The per-coordinate median of WGS84 points: a reference that one wrong point does not move."""
    return Origin(float(np.median(lat)), float(np.median(lon)), float(np.median(alt)))
