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
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from tlsync_pipeline.csvtable import Columns, Table, cell_number, describe_cell, write_rows
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.inputs import quote

UP = np.array([0.0, 0.0, 1.0])  # the world's up axis: trajectories are local ENU metres
GRID_BLOCK = 1 << 20  # times handled at once by grid_rate
MIN_RUN = 4  # samples a run needs to be interpolated (a cubic spline)
GAP_SAMPLES = 1.5  # consecutive samples further apart than this (grid units) are a gap, never bridged


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


def grid_rate(t: np.ndarray) -> float:
    """The rate (Hz) of the constant-rate grid that times t (seconds, increasing) sit on.

    1 / median interval, then refined: over the short steps (up to 10
    intervals) whose length is a whole number of intervals, rate = intervals /
    seconds (so rounded time stamps, e.g. 1/15 s written to the millisecond,
    average out); then by least squares over all the times when every one
    sits on that grid (gaps allowed).
    """
    t = np.asarray(t, dtype=np.float64)
    step = np.diff(t)
    rate = 1.0 / float(np.median(step))
    whole = np.round(step * rate)
    short = (whole >= 1) & (whole <= 10) & (np.abs(step * rate - whole) < 0.25)
    if short.any():
        rate = float(whole[short].sum() / step[short].sum())
    on_grid, ie, ee = True, 0.0, 0.0
    for lo in range(0, len(t), GRID_BLOCK):  # in blocks: a day at 100 Hz needs no temporaries of its size
        elapsed = t[lo : lo + GRID_BLOCK] - t[0]
        index = np.round(elapsed * rate)
        on_grid = on_grid and bool(np.abs(elapsed * rate - index).max() < 0.1)
        ie, ee = ie + float(index @ elapsed), ee + float(elapsed @ elapsed)
    return ie / ee if on_grid else rate


def trajectory_from_times(
    t: np.ndarray, xyz: np.ndarray, rate: float | None = None, sigma: np.ndarray | None = None
) -> Trajectory:
    """A trajectory whose grid is set by its times t (seconds, strictly increasing), with optional sigmas (m).

    rate defaults to grid_rate(t); t0 = t[0].
    """
    t = np.asarray(t, dtype=np.float64)
    if rate is None:
        rate = grid_rate(t)
    return Trajectory((t - t[0]) * rate, np.asarray(xyz, dtype=np.float64), rate, float(t[0]), sigma)


class PiecewiseTrajectory:
    """The trajectory model: C2 interpolation (cubic spline) over each contiguous run of grid samples.

    Runs are separated by gaps of more than GAP_SAMPLES; runs of fewer than
    MIN_RUN samples are left out. Used by the fit (sync/identify/refine.py) and the pictures.
    """

    def __init__(self, trajectory: Trajectory):
        from scipy.interpolate import make_interp_spline  # loaded by the stages that interpolate, not for every command

        sample, xyz = trajectory.sample, trajectory.xyz
        cuts = np.flatnonzero(np.diff(sample) > GAP_SAMPLES) + 1
        self.sample, self.sigmas = sample, trajectory.sigma
        self.runs = []
        for idx in np.split(np.arange(len(sample)), cuts):
            if len(idx) >= MIN_RUN:
                self.runs.append(
                    (sample[idx[0]], sample[idx[-1]], make_interp_spline(sample[idx], xyz[idx], k=3, axis=0))
                )
        self.starts = np.array([r[0] for r in self.runs])
        self.ends = np.array([r[1] for r in self.runs])

    def run_of(self, s: np.ndarray) -> np.ndarray:
        """Index of the run containing each s, or -1."""
        k = np.searchsorted(self.starts, s, side="right") - 1
        inside = (k >= 0) & (s <= self.ends[np.clip(k, 0, None)]) if len(self.runs) else np.zeros(len(s), bool)
        return np.where(inside, k, -1)

    def sigma(self, s: np.ndarray) -> np.ndarray | None:
        """Per-sample sigma (m) at s, linearly interpolated; None when the trajectory has none."""
        return None if self.sigmas is None else np.interp(s, self.sample, self.sigmas)

    def __call__(self, s: np.ndarray, run: np.ndarray, nu: int = 0) -> np.ndarray:
        """Positions (or derivatives) at s, evaluated on the given runs, clamped to them."""
        if len(self.runs) == 1:  # most logs: no run to pick
            lo, hi, spline = self.runs[0]
            return spline(np.clip(s, lo, hi), nu=nu)
        out = np.empty((len(s), 3))
        for k in np.unique(run):
            sel = run == k
            lo, hi, spline = self.runs[k]
            out[sel] = spline(np.clip(s[sel], lo, hi), nu=nu)
        return out

    def positions(self, s) -> np.ndarray:
        """Positions (m) at continuous samples s: (N, 3), NaN outside the runs (before, after, in a gap)."""
        s = np.atleast_1d(np.asarray(s, dtype=np.float64))
        run = self.run_of(s)
        out = np.full((len(s), 3), np.nan)
        inside = run >= 0
        out[inside] = self(s[inside], run[inside])
        return out


def stranded(trajectory: Trajectory) -> int:
    """The most samples in one stretch of consecutive runs shorter than MIN_RUN (the interpolation leaves them out):
    a part of the log sampled at another rate than its grid's, or broken by dropouts."""
    lengths = np.diff(np.r_[0, np.flatnonzero(np.diff(trajectory.sample) > GAP_SAMPLES) + 1, len(trajectory)])
    short = np.where(lengths < MIN_RUN, lengths, 0)
    streak = np.cumsum(short) - np.maximum.accumulate(np.where(short == 0, np.cumsum(short), 0))
    return int(streak.max(initial=0))


def lowered(trajectory: Trajectory, metres: float) -> Trajectory:
    """The trajectory ``metres`` lower along the world's up axis (the logged point brought down to the tracked one)."""
    return replace(trajectory, xyz=trajectory.xyz - metres * UP)


def read_trajectory(path: str | Path) -> Trajectory:
    """Read a trajectory CSV with columns ``x,y,z``, optional ``t`` (seconds) and ``sigma`` (metres, > 0).

    Read in chunks into arrays (tlsync_pipeline.csvtable): a UTF-8 byte-order
    mark is skipped, ``;`` tables may write decimal commas (Excel).
    """
    with Table(path, "trajectory CSV") as table:
        path, header = table.path, table.names
        if not table.header.strip():
            raise InputError(f"{path}: empty file; expected a header 'x,y,z' or 't,x,y,z'")
        if {"lat", "lon"} <= set(header):
            raise InputError(
                f"{path}:{table.header_no}: this is a geodetic log (lat/lon): convert it to local metres with `tlsync "
                f"ingest-log`"
            )
        missing = [c for c in ("x", "y", "z") if c not in header]
        if missing:
            raise InputError(
                f"{path}:{table.header_no}: header {quote(table.delimiter.join(header))} lacks column(s) "
                f"{', '.join(missing)}; expected x,y,z with optional t"
            )
        wanted = (["t"] if "t" in header else []) + ["x", "y", "z"] + (["sigma"] if "sigma" in header else [])
        index = [header.index(c) for c in wanted]
        groups = {
            "xyz": (wanted.index("x"), wanted.index("x") + 3),
            **({"t": (0, 1)} if "t" in wanted else {}),
            **({"sigma": (len(wanted) - 1, len(wanted))} if "sigma" in wanted else {}),
        }
        rows: Columns | None = None
        numbers: list[np.ndarray | range] = []
        for values, lines in table.chunks(
            index, lambda rows, first: _parse_rows(path, rows, first, table.delimiter, header, wanted, index)
        ):
            if "sigma" in wanted and (values[:, -1] <= 0).any():
                k = int(np.argmax(values[:, -1] <= 0))
                raise InputError(f"{path}:{lines[k]}: column 'sigma': {values[k, -1]:g} m; a sigma must be positive")
            rows = rows or Columns(groups, table.expected_rows())
            rows.add(values)
            numbers.append(lines)
    if rows is None or rows.n < 2:
        raise InputError(f"{path}: the trajectory has {0 if rows is None else rows.n} sample(s); at least 2 are needed")
    xyz = rows.get("xyz")
    sigma = rows.get("sigma")[:, 0] if "sigma" in groups else None
    if "t" not in groups:
        return Trajectory(np.arange(len(xyz), dtype=np.float64), xyz, sigma=sigma)
    t = rows.get("t")[:, 0]
    step = np.diff(t)
    bad = np.flatnonzero(step <= 0)
    if len(bad):
        k = bad[0]
        line = np.concatenate([np.asarray(n, dtype=np.int64) for n in numbers])
        what = "repeats" if step[k] == 0 else "goes backwards"
        raise InputError(
            f"{path}:{line[k + 1]}: time {t[k + 1]:g} s {what} (previous line {line[k]}: {t[k]:g} s); times must "
            f"increase"
        )
    del rows, step
    return trajectory_from_times(t, xyz, sigma=sigma)


def _parse_rows(
    path: Path, rows: list[str], first: int, delimiter: str, header: list[str], wanted: list[str], index: list[int]
) -> tuple[np.ndarray, np.ndarray]:
    """The trajectory rows a chunk's lines hold, line by line (blank lines skipped), and their line numbers; the first
    bad one an InputError.
    """
    values, lines = [], []
    try:
        cells_of = list(csv.reader(rows, delimiter=delimiter))
    except csv.Error as exc:
        raise InputError(f"{path}: cannot read as CSV: {exc}") from None
    for line_no, row in enumerate(cells_of, start=first):
        if not row or all(not c.strip() for c in row):
            continue
        if len(row) != len(header):
            raise InputError(f"{path}:{line_no}: expected {len(header)} fields, got {len(row)}")
        record = []
        for col, i in zip(wanted, index):
            try:
                v = cell_number(row[i], delimiter)
            except ValueError:
                raise InputError(f"{path}:{line_no}: column '{col}': not a number ({describe_cell(row[i])})") from None
            if not math.isfinite(v):
                raise InputError(f"{path}:{line_no}: column '{col}': not a finite number ({describe_cell(row[i])})")
            if col == "sigma" and v <= 0:
                raise InputError(f"{path}:{line_no}: column 'sigma': {v:g} m; a sigma must be positive")
            record.append(v)
        values.append(record)
        lines.append(line_no)
    return np.asarray(values, dtype=np.float64).reshape(-1, len(wanted)), np.asarray(lines, dtype=np.int64)


def write_trajectory(trajectory: Trajectory, path: str | Path) -> None:
    """Write the trajectory CSV: ``t,x,y,z`` when the rate is known, else ``x,y,z``; then ``sigma`` when known.

    t with 6 decimals (us), metres with 4 (0.1 mm).
    """
    t = trajectory.seconds(trajectory.sample)
    names, decimals, columns = ["x", "y", "z"], [4] * 3, list(trajectory.xyz.T)
    if t is not None:
        names, decimals, columns = ["t", *names], [6, *decimals], [np.asarray(t), *columns]
    if trajectory.sigma is not None:
        names, decimals, columns = [*names, "sigma"], [*decimals, 4], [*columns, trajectory.sigma]
    with Path(path).open("wb") as handle:
        handle.write((",".join(names) + "\n").encode())
        write_rows(handle, columns, decimals)
