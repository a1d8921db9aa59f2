"""A short trajectory inside a long log: the target rests behind every camera for hours before and after its visits.

The short trajectory (its times and positions) is interpolated (cubic
spline) onto the log's grid and placed in the middle; before and after it
the target rests at its first and last point with 1 cm of noise. Written
in blocks, so a day at 100 Hz (8.64 million rows) needs no more memory
than a million rows.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.interpolate import make_interp_spline

from tlsync_pipeline.trajectory import Trajectory

BLOCK = 1_000_000  # rows written at once


def write_long_log(short: Trajectory, path: str | Path, seconds: float, rate: float, seed: int = 1) -> Path:
    """Write ``t,x,y,z`` rows (t: seconds from 0) for ``seconds`` at ``rate`` Hz around ``short``."""
    assert short.rate is not None, "the short trajectory has times"
    times = short.sample / short.rate
    spline = make_interp_spline(times, short.xyz, k=3, axis=0)
    n = int(round(seconds * rate))
    start = n // 2
    inside = int(np.floor(times[-1] * rate)) + 1
    rng = np.random.default_rng(seed)
    path = Path(path)
    with path.open("w") as handle:
        handle.write("t,x,y,z\n")
        for lo in range(0, n, BLOCK):
            k = np.arange(lo, min(n, lo + BLOCK))
            rel = k - start
            xyz = np.where((rel < 0)[:, None], short.xyz[0], short.xyz[-1]) + rng.normal(0.0, 0.01, (len(k), 3))
            within = (rel >= 0) & (rel < inside)
            xyz[within] = spline(times[0] + rel[within] / rate)
            np.savetxt(handle, np.column_stack([k / rate, xyz]), fmt=["%.6f", "%.4f", "%.4f", "%.4f"], delimiter=",")
    return path
