"""GPS time to UTC: the GPS week/time-of-week epoch and the leap-second table.

GPS time (GPST) runs without leap seconds from 1980-01-06 00:00:00 UTC; UTC =
GPST - (leap seconds in force). The table lists, for each step, the UTC date
from which it holds and GPST - UTC from then on (IERS Bulletin C; the last
step was 2017-01-01, to 18 s, and none has been announced since).
"""

from __future__ import annotations

import calendar

import numpy as np

GPS_EPOCH_POSIX = 315964800.0  # 1980-01-06 00:00:00 UTC in POSIX seconds
WEEK_S = 604800.0

_STEPS = (  # (UTC date the offset holds from, GPST - UTC in seconds)
    ((1981, 7, 1), 1),
    ((1982, 7, 1), 2),
    ((1983, 7, 1), 3),
    ((1985, 7, 1), 4),
    ((1988, 1, 1), 5),
    ((1990, 1, 1), 6),
    ((1991, 1, 1), 7),
    ((1992, 7, 1), 8),
    ((1993, 7, 1), 9),
    ((1994, 7, 1), 10),
    ((1996, 1, 1), 11),
    ((1997, 7, 1), 12),
    ((1999, 1, 1), 13),
    ((2006, 1, 1), 14),
    ((2009, 1, 1), 15),
    ((2012, 7, 1), 16),
    ((2015, 7, 1), 17),
    ((2017, 1, 1), 18),
)
# Each step's start as GPST in POSIX-like seconds (the UTC instant plus the new offset).
_STEP_GPST = np.array([calendar.timegm((*date, 0, 0, 0)) + offset for date, offset in _STEPS], dtype=np.float64)
_OFFSETS = np.array([offset for _, offset in _STEPS], dtype=np.float64)


def leap_seconds(gpst_posix) -> np.ndarray | float:
    """GPST - UTC (s) in force at GPS time(s) given as POSIX-like seconds (GPS epoch = 315964800)."""
    g = np.asarray(gpst_posix, dtype=np.float64)
    k = np.searchsorted(_STEP_GPST, g, side="right") - 1
    out = np.where(k >= 0, _OFFSETS[np.clip(k, 0, None)], 0.0)
    return float(out) if out.ndim == 0 else out


def gpst_to_utc(gpst_posix) -> np.ndarray | float:
    """UTC POSIX seconds of GPS time(s) given as POSIX-like seconds (no leap seconds since 1980)."""
    g = np.asarray(gpst_posix, dtype=np.float64)
    out = g - leap_seconds(g)
    return float(out) if out.ndim == 0 else out


def week_tow_to_utc(week, tow_s) -> np.ndarray | float:
    """UTC POSIX seconds of a GPS week (full, not modulo 1024) and time of week (s)."""
    return gpst_to_utc(
        GPS_EPOCH_POSIX + np.asarray(week, dtype=np.float64) * WEEK_S + np.asarray(tow_s, dtype=np.float64)
    )
