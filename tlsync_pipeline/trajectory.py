"""The target's 3D trajectory and its CSV file.

Positions are in the local metric world frame (metres, East-North-Up for GPS).
Each position has a sample coordinate t_r on the trajectory's constant-rate
grid: t_r = (t - t0) * rate, 0-based. A file without times is taken as already
on that grid (t_r = 0, 1, 2, ...). Samples missing in a gap keep their grid
positions: t_r values are never renumbered. An optional per-sample sigma
(metres, the log's stated horizontal 1-sigma position uncertainty) weights
the sub-frame refinement: samples with a large sigma count less.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tlsync_pipeline.errors import InputError


@dataclass(frozen=True)
class Trajectory:
    """Target positions on a constant-rate sample grid.

    sample: float64 (N,) strictly increasing grid coordinates t_r;
    xyz: float64 (N, 3) metres; rate: samples per second, or None when the
    file had no times; t0: time of sample 0 in seconds (POSIX UTC seconds for
    GPS logs), or None; sigma: float64 (N,) metres per sample, or None when
    the log states no uncertainty.
    """

    sample: np.ndarray
    xyz: np.ndarray
    rate: float | None = None
    t0: float | None = None
    sigma: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.sample)

    def seconds(self, sample: np.ndarray | float) -> np.ndarray | float | None:
        """Time in seconds of grid coordinate(s) t_r, or None without a rate."""
        if self.rate is None:
            return None
        return (self.t0 or 0.0) + np.asarray(sample) / self.rate


def trajectory_from_times(t: np.ndarray, xyz: np.ndarray, rate: float | None = None, sigma: np.ndarray | None = None) -> Trajectory:
    """A trajectory whose grid is set by its times t (seconds).

    rate defaults to 1 / median interval, refined by least squares when the
    times sit on a regular grid (with or without gaps) so that rounding in
    the written times does not bias it; t0 = t[0]; t must increase strictly.
    """
    t = np.asarray(t, dtype=np.float64)
    if rate is None:
        rate = 1.0 / float(np.median(np.diff(t)))
        elapsed = t - t[0]
        index = np.round(elapsed * rate)
        if np.abs(elapsed * rate - index).max() < 0.1:
            rate = float(index @ elapsed / (elapsed @ elapsed))
    return Trajectory((t - t[0]) * rate, np.asarray(xyz, dtype=np.float64), rate, float(t[0]), sigma)


def read_trajectory(path: str | Path) -> Trajectory:
    """Read a trajectory CSV with columns ``x,y,z``, optional ``t`` (seconds) and ``sigma`` (metres, > 0)."""
    path = Path(path)
    try:
        with path.open(newline="", encoding="utf-8") as handle:
            rows = list(csv.reader(handle))
    except FileNotFoundError:
        raise InputError(f"{path}: file not found") from None
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise InputError(f"{path}: cannot read as CSV: {exc}") from None
    if not rows or not any(c.strip() for c in rows[0]):
        raise InputError(f"{path}: empty file; expected a header 'x,y,z' or 't,x,y,z'")
    header = [c.strip() for c in rows[0]]
    if {"lat", "lon"} <= set(header):
        raise InputError(f"{path}:1: this is a geodetic log (lat/lon): convert it to local metres with `tlsync ingest-log`")
    missing = [c for c in ("x", "y", "z") if c not in header]
    if missing:
        raise InputError(f"{path}:1: header {','.join(header)!r} lacks column(s) {', '.join(missing)}; expected x,y,z with optional t")
    wanted = (["t"] if "t" in header else []) + ["x", "y", "z"] + (["sigma"] if "sigma" in header else [])
    index = [header.index(c) for c in wanted]
    values, lines = [], []
    for line_no, row in enumerate(rows[1:], start=2):
        if not row or all(not c.strip() for c in row):
            continue
        if len(row) != len(header):
            raise InputError(f"{path}:{line_no}: expected {len(header)} fields, got {len(row)}")
        record = []
        for col, i in zip(wanted, index):
            try:
                v = float(row[i])
            except ValueError:
                raise InputError(f"{path}:{line_no}: column '{col}': not a number: {row[i]!r}") from None
            if not math.isfinite(v):
                raise InputError(f"{path}:{line_no}: column '{col}': {row[i]} is not a finite number")
            if col == "sigma" and v <= 0:
                raise InputError(f"{path}:{line_no}: column 'sigma': {row[i]} m; a sigma must be positive")
            record.append(v)
        values.append(record)
        lines.append(line_no)
    if len(values) < 2:
        raise InputError(f"{path}: the trajectory has {len(values)} sample(s); at least 2 are needed")
    data = np.asarray(values)
    sigma = data[:, -1].copy() if "sigma" in header else None
    if "t" not in header:
        return Trajectory(np.arange(len(data), dtype=np.float64), data[:, :3], sigma=sigma)
    t = data[:, 0]
    step = np.diff(t)
    bad = np.flatnonzero(step <= 0)
    if len(bad):
        k = bad[0]
        what = "repeats" if step[k] == 0 else "goes backwards"
        raise InputError(f"{path}:{lines[k + 1]}: time {t[k + 1]:g} s {what} (previous line {lines[k]}: {t[k]:g} s); times must increase")
    return trajectory_from_times(t, data[:, 1:4], sigma=sigma)


def write_trajectory(trajectory: Trajectory, path: str | Path) -> None:
    """Write the trajectory CSV: ``t,x,y,z`` when the rate is known, else ``x,y,z``; then ``sigma`` when known."""
    t = trajectory.seconds(trajectory.sample)
    columns, fmt, data = ["x", "y", "z"], ["%.4f"] * 3, [trajectory.xyz]
    if t is not None:
        columns, fmt, data = ["t", *columns], ["%.6f", *fmt], [t, *data]
    if trajectory.sigma is not None:
        columns, fmt, data = [*columns, "sigma"], [*fmt, "%.4f"], [*data, trajectory.sigma]
    with Path(path).open("w", newline="", encoding="utf-8") as handle:
        handle.write(",".join(columns) + "\n")
        np.savetxt(handle, np.column_stack(data), fmt=fmt, delimiter=",")
