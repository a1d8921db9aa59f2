"""The units of a log's times and positions, and whether a trajectory moves like a real target in seconds and metres.

``[target] time_unit`` and ``length_unit`` name the units a log's time
column and its local positions (or heights) were written in; tlsync works in
seconds and metres. ``implausible_motion`` is the check that runs before any
fit: a target logged once every few minutes that creeps at millimetres per
second, or one that moves faster than any aircraft, is a log in another unit.
"""

from __future__ import annotations

import math

import numpy as np

# Seconds per unit of a log's time column, by name.
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9, "min": 60.0, "h": 3600.0}
# Metres per unit of a log's positions, by name (us_ft: the US survey foot).
LENGTH_UNITS = {"m": 1.0, "km": 1000.0, "cm": 0.01, "mm": 0.001, "ft": 0.3048, "us_ft": 1200.0 / 3937.0, "in": 0.0254}

SLOWEST_MPS = 0.02  # a target whose 90th-percentile speed is below this, ...
SPARSEST_S = 1.0  # ... logged less often than once a second, is a log in milliseconds (or one that never moves)
FASTEST_MPS = 400.0  # a median moving speed above this is faster than any target tlsync follows
MOVING_MPS = 0.05  # a step slower than this is a pause, left out of the median speed


def unit_scale(value: object, units: dict[str, float], what: str) -> float:
    """The factor to SI of a unit given by name (one of ``units``) or as a positive number (SI units per unit);
    ValueError otherwise.
    """
    if isinstance(value, str) and value in units:
        return units[value]
    if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) and value > 0:
        return float(value)
    raise ValueError(f"expected one of {', '.join(units)} or a positive number ({what} per unit), got {value!r}")


def implausible_motion(t: np.ndarray, xyz: np.ndarray) -> str | None:
    """Why a trajectory (t seconds, xyz metres) cannot be a target's in those units, with the fix; None when it can.

    The message names the column (``t``, or ``t`` and ``x, y, z``) and the
    ``[target]`` key that fixes it; the caller names the file.
    """
    t, xyz = np.asarray(t, dtype=np.float64), np.asarray(xyz, dtype=np.float64)
    if len(t) < 3:
        return None
    dt = np.diff(t)
    ok = dt > 0
    if ok.sum() < 2:
        return None
    speed = np.linalg.norm(np.diff(xyz, axis=0), axis=1)[ok] / dt[ok]
    interval = float(np.median(dt[ok]))
    fastest = float(np.percentile(speed, 90))
    if fastest < SLOWEST_MPS and interval >= SPARSEST_S:
        unit = next((name for name in ("ms", "us", "ns") if interval * TIME_UNITS[name] <= 10.0), "ns")
        word = {"ms": "milliseconds", "us": "microseconds", "ns": "nanoseconds"}[unit]
        return (
            f"column t: in seconds, one sample every {interval:.3g} s and the target at {fastest:.2g} m/s at most "
            f'({word}?); set [target] time_unit = "{unit}"'
        )
    moving = speed[speed > MOVING_MPS]
    if len(moving) and float(np.median(moving)) > FASTEST_MPS:
        return (
            f"columns t, x, y, z: in seconds and metres the target moves at {float(np.median(moving)):.3g} m/s; "
            f"set [target] time_unit (minutes?) or length_unit (mm, cm?)"
        )
    return None
