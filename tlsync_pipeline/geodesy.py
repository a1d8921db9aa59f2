"""Geodetic (WGS84 latitude, longitude, ellipsoidal height) <-> local East-North-Up metres.

The one conversion tlsync uses for target logs and ground control points
alike, so cameras and trajectory share one world frame. Implemented with
PROJ's topocentric conversion through pyproj.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
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
