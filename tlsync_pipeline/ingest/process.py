"""From log records to a constant-rate local metric trajectory: pure functions.

Order of work: fixes must come in time order (a step back is an error);
exact duplicates and repeated times are dropped; geodetic fixes go to ENU
metres at the origin (tlsync_pipeline.geodesy), local ones through the
optional rigid transform; spikes (implied speed above max_speed_mps from the
last kept fix) are rejected; gaps (intervals over 3x the median) are found;
the fixes are resampled onto t = t0 + k / rate by linear interpolation that
does not bridge intervals longer than max_gap_s (grid samples there are left
out, keeping their indices k); an optional Savitzky-Golay smoothing runs
over each unbroken run of grid samples. Per-fix sigmas (where the log states
them) are interpolated onto the same grid as the trajectory's weights.

Heights: the reader says what the log's heights are measured from
(ellipsoid, MSL, take-off point); the project may declare it instead
(``altitude_reference``) and give ``altitude_offset_m``, added to every
height to bring it onto the ellipsoidal heights the GCPs and the origin use.
A log whose heights are not ellipsoidal, with no offset given, is read as
it is and the report warns: its Up coordinate is off by a constant (the
geoid undulation, tens of metres, or the take-off point's height).
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import math
from dataclasses import dataclass

import numpy as np

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.geodesy import Origin, geodetic_to_enu
from tlsync_pipeline.ingest.params import IngestParams
from tlsync_pipeline.ingest.records import ALTITUDE_NAMES, ALTITUDE_REFERENCES, ELLIPSOID, GEODETIC, LogRecords
from tlsync_pipeline.ingest.report import GAP_FACTOR, Gap, IngestReport
from tlsync_pipeline.trajectory import Trajectory, grid_rate

HELD_MAX_S = (
    1.0  # a position repeated longer than this is a target standing still, not a receiver's fix held over frames
)
SPIKE_WINDOW_S = 0.1  # speeds are judged over at least this long (a receiver's update interval at 10 Hz)
DUPLICATE = "exact duplicate"
REPEATED_TIME = "repeated time, different position (first kept)"
FIRST_LINES = 5  # provenance numbers kept per drop reason in the report
MAX_SPAN_S = 1e8  # about 3 years: a longer log has a wrong time in it
MAX_SAMPLES = 50_000_000  # a trajectory longer than this is a wrong time or rate, not a log
SPIKE_BLOCK = 1 << 20  # fixes handled at once by reject_spikes and resample


def in_seconds_and_metres(records: LogRecords, time_unit: float, length_unit: float) -> LogRecords:
    """The records with times in seconds and local positions (or a geodetic log's heights) in metres."""
    if time_unit == 1.0 and length_unit == 1.0:
        return records
    values = records.values.copy()
    if records.frame == GEODETIC:
        values[:, 2] *= length_unit
    else:
        values *= length_unit
    return dataclasses.replace(records, t=records.t * time_unit, values=values)


@dataclass(frozen=True)
class _Fixes:
    """The fixes kept, in time order: times (s), values (the log's coordinates), positions (local metres, once
    placed), provenance numbers (lines, records), indices into the records, per-fix sigmas (m) or None."""

    t: np.ndarray
    values: np.ndarray
    xyz: np.ndarray
    numbers: np.ndarray
    index: np.ndarray
    sigma: np.ndarray | None

    def kept(self, keep: np.ndarray) -> _Fixes:
        sigma = None if self.sigma is None else self.sigma[keep]
        return _Fixes(self.t[keep], self.values[keep], self.xyz[keep], self.numbers[keep], self.index[keep], sigma)


def ingest(records: LogRecords, params: IngestParams = IngestParams()) -> tuple[Trajectory, IngestReport]:
    """The constant-rate local trajectory of a log and the report; InputError when unusable."""
    fixes, dropped = _ordered_fixes(in_seconds_and_metres(records, params.time_unit, params.length_unit))
    warnings = list(records.warnings)
    altitude = _altitude(records, params, warnings)
    if records.frame == GEODETIC and len(fixes.values) and not fixes.values[:, 2].any() and not altitude["offset_m"]:
        warnings.append(
            "every fix's height is 0: a log without heights (a 2D export?) lies on the reference surface, "
            "off the cameras' frame by the site's height; give a log with heights, or [target] altitude_offset_m"
        )
    values = fixes.values + np.array([0.0, 0.0, altitude["offset_m"]]) if altitude["offset_m"] else fixes.values
    xyz, origin, rule = _to_local(records, values, params, warnings)
    fixes = dataclasses.replace(fixes, values=values, xyz=xyz)
    keep = _without_spikes(records, fixes, params, dropped, warnings)
    if not keep.all():
        fixes = fixes.kept(keep)
    if origin is not None and rule == "first fix" and not keep[0]:  # the first fix was a spike: the first kept one
        origin = Origin(*map(float, fixes.values[0]))
        fixes = dataclasses.replace(
            fixes, xyz=geodetic_to_enu(fixes.values[:, 0], fixes.values[:, 1], fixes.values[:, 2], origin)
        )
    rate = params.rate or log_rate(fixes.t)
    max_gap = params.max_gap_s if params.max_gap_s is not None else GAP_FACTOR * median_interval(fixes.t)
    try:
        grid_index, grid_xyz, left_out = resample(fixes.t, fixes.xyz, rate, max_gap)
    except ValueError as exc:
        raise InputError(f"{records.path}: {exc}") from None
    if params.smoothing_s > 0:
        grid_xyz = smooth(grid_index, grid_xyz, params.smoothing_s * rate)
    trajectory = Trajectory(
        grid_index.astype(np.float64),
        grid_xyz,
        float(rate),
        float(fixes.t[0]),
        grid_sigmas(fixes.t, fixes.sigma, grid_index, rate),
    )
    origin_info = None if origin is None else {"lat": origin.lat, "lon": origin.lon, "alt": origin.alt, "rule": rule}
    gaps = [
        Gap(
            _where(records, fixes.numbers[i]),
            float(fixes.t[i]),
            float(fixes.t[i + 1]),
            float(fixes.t[i + 1] - fixes.t[i]),
            bool(fixes.t[i + 1] - fixes.t[i] <= max_gap),
        )
        for i in find_gaps(fixes.t)
    ]
    report = IngestReport(
        source=str(records.path),
        format=records.format,
        frame="ENU" if records.frame == GEODETIC else "local",
        fixes_read=len(records),
        fixes_used=len(fixes.t),
        samples=len(grid_index),
        rate=float(rate),
        t0=float(fixes.t[0]),
        t0_utc=_utc(fixes.t[0]) if records.utc else None,
        duration_s=float(grid_index[-1] / rate),
        extent_m=(grid_xyz.max(axis=0) - grid_xyz.min(axis=0)).round(3).tolist(),
        max_gap_s=float(max_gap),
        gaps=gaps,
        grid_left_out=int(left_out),
        dropped={
            reason: {"count": len(n), "first": list(n[:FIRST_LINES])}
            for reason, n in {**records.dropped, **dropped}.items()
        },
        unit=records.unit,
        ignored=records.ignored,
        origin=origin_info,
        params=_params_record(params),
        warnings=warnings,
        clock=records.clock,
        altitude=altitude if records.frame == GEODETIC else {},
        quality={
            name: _stats(column[fixes.index])
            for name, column in records.quality.items()
            if np.isfinite(column[fixes.index]).any()
        },
        sigma_m=None if fixes.sigma is None or trajectory.sigma is None else _sigma_summary(fixes.sigma),
        notes=list(records.notes),
        video_time_zero=records.video_time_zero,
        t0_local=_local(fixes.t[0]) if records.local_time and not records.utc else None,
        log_model=suggested_log_model(records, fixes.index),
    )
    return trajectory, report


# Fix qualities that mean an RTK (or better) solution: rtklib's Q, NMEA GGA's quality, PX4's and MAVLink's fix_type.
_RTK = {"Q": (1.0,), "quality": (4.0,), "fix_type": (6.0,)}
_DRONES = ("ulog", "dataflash", "tlog", "dji", "srt")
_LOCAL = ("tum", "odometry", "rosbag")


def suggested_log_model(records: LogRecords, used: np.ndarray) -> dict:
    """The error model (a preset of sync/model/log_model.py) the log's kind suggests, and why: "rtk" when most fixes
    used are
    RTK-fixed, "none" for local odometry, "drone" for flight controllers' and drones' logs, else "phone" (phones,
    watches, action cameras, handheld receivers)."""
    for column, fixed in _RTK.items():
        values = records.quality.get(column)
        if values is not None and np.isin(values[used], fixed).mean() > 0.5:
            return {"name": "rtk", "why": f"most fixes RTK-fixed ({column})"}
    if records.format in _LOCAL or records.frame != GEODETIC:
        return {"name": "none", "why": "local positions: no satellite bias"}
    if records.format in _DRONES:
        return {"name": "drone", "why": f"a drone's or flight controller's log ({records.format})"}
    return {"name": "phone", "why": f"a consumer receiver's log ({records.format})"}


def _ordered_fixes(records: LogRecords) -> tuple[_Fixes, dict[str, list[int]]]:
    """The log's fixes in time order without duplicates (not yet placed: xyz holds the values), and
    the drops by reason.
    """
    if len(records) == 0:
        raise InputError(_no_fix_message(records))
    t, values, numbers, dropped, index = order_and_dedupe(records)
    if len(t) < 2:
        raise InputError(f"{records.where(0)}: only one valid fix in the log; at least 2 are needed")
    if t[-1] - t[0] > MAX_SPAN_S:
        raise InputError(
            f"{records.path}: the log spans {(t[-1] - t[0]) / 86400:.0f} days ({_where(records, numbers[0])} to "
            f"{_where(records, numbers[-1])}): a time is wrong"
        )
    return _Fixes(t, values, values, numbers, index, None if records.sigma is None else records.sigma[index]), dropped


def _without_spikes(
    records: LogRecords, fixes: _Fixes, params: IngestParams, dropped: dict[str, list[int]], warnings: list[str]
) -> np.ndarray:
    """Which fixes to keep: those not implying a speed over max_speed_mps from the last kept one (the others recorded in
    ``dropped``).
    """
    if params.max_speed_mps is None:
        return np.ones(len(fixes.t), dtype=bool)
    rounding = None if records.rounding_m is None else records.rounding_m[fixes.index]
    keep = reject_spikes(fixes.t, fixes.xyz, params.max_speed_mps, rounding)
    if not keep.all():
        dropped[f"spike (implied speed over {params.max_speed_mps:g} m/s)"] = fixes.numbers[~keep].tolist()
        warnings.append(
            f"{int((~keep).sum())} of {len(keep)} fixes dropped as spikes (implied speed over "
            f"{params.max_speed_mps:g} m/s): "
            "if the target is that fast, raise [target] max_speed_mps (ingest-log --max-speed)"
        )
    if keep.sum() < 2:
        raise InputError(
            f"{records.path}: fewer than 2 fixes left after rejecting spikes over {params.max_speed_mps:g} m/s"
        )
    return keep


def _params_record(params: IngestParams) -> dict:
    """The ingest's parameters as the report records them."""
    return {
        "origin": params.origin
        if isinstance(params.origin, str)
        else [params.origin.lat, params.origin.lon, params.origin.alt],
        "rate": params.rate,
        "max_gap_s": params.max_gap_s,
        "max_speed_mps": params.max_speed_mps,
        "smoothing_s": params.smoothing_s,
        "transform": None
        if params.transform is None
        else {"R": params.transform.R.tolist(), "t": params.transform.t.tolist()},
        "altitude_reference": params.altitude_reference,
        "altitude_offset_m": params.altitude_offset_m,
        "time_unit": params.time_unit,
        "length_unit": params.length_unit,
    }


def _altitude(records: LogRecords, params: IngestParams, warnings: list[str]) -> dict:
    """The heights' reference (declared or the log's) and offset; warns when they are not ellipsoidal."""
    declared = params.altitude_reference
    if declared is not None and declared not in ALTITUDE_REFERENCES:
        raise InputError(f"altitude reference {declared!r}: expected one of {', '.join(ALTITUDE_REFERENCES)}")
    reference = declared or records.altitude
    offset = float(params.altitude_offset_m)
    if records.frame == GEODETIC and reference != ELLIPSOID and offset == 0.0:
        what = (
            "the geoid undulation (tens of metres)" if reference == "msl" else "the take-off point's ellipsoidal height"
        )
        warnings.append(
            f"heights are above {ALTITUDE_NAMES[reference]}, the GCPs and the origin above the WGS84 ellipsoid: Up is "
            f"off by {what}; "
            "give [target] altitude_offset_m (or declare altitude_reference if the log is wrong about it)"
        )
    return {"reference": reference, "source": "project" if declared else "log", "offset_m": offset}


def _stats(values: np.ndarray) -> dict:
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if not len(v):
        return {"min": None, "median": None, "max": None}
    return {"min": float(v.min()), "median": float(np.median(v)), "max": float(v.max())}


def _sigma_summary(sigma: np.ndarray) -> dict:
    v = sigma[np.isfinite(sigma)]
    return {"median": float(np.median(v)), "p95": float(np.percentile(v, 95)), "max": float(v.max())}


def grid_sigmas(t: np.ndarray, sigma: np.ndarray | None, grid_index: np.ndarray, rate: float) -> np.ndarray | None:
    """Per-sample sigma (m) on the grid: linear interpolation of the fixes' sigmas, unknown ones (NaN) filled
    with the median of the known; None when no fix states one."""
    if sigma is None:
        return None
    known = np.isfinite(sigma) & (sigma > 0)
    if not known.any():
        return None
    filled = np.where(known, sigma, np.median(sigma[known]))
    return np.interp(grid_index / rate, t - t[0], filled)


def _to_local(
    records: LogRecords, values: np.ndarray, params: IngestParams, warnings: list[str]
) -> tuple[np.ndarray, Origin | None, str | None]:
    """(local metres, origin, origin rule): ENU at the origin for geodetic logs, the rigid
    transform (if any) for local ones (origin None)."""
    if records.frame != GEODETIC:
        if isinstance(params.origin, Origin):
            warnings.append("the origin is not used: the log is already in local metres")
        return (values if params.transform is None else params.transform.apply(values)), None, None
    if params.transform is not None:
        raise InputError(f"{records.path}: a rigid transform applies to local (odometry) logs; this log is geodetic")
    if isinstance(params.origin, Origin):
        origin, rule = params.origin, "given"
    elif params.origin == "first":
        origin, rule = Origin(*map(float, values[0])), "first fix"
    else:
        raise InputError(f"{records.path}: origin {params.origin!r} must be resolved to coordinates before ingestion")
    return geodetic_to_enu(values[:, 0], values[:, 1], values[:, 2], origin), origin, rule


def order_and_dedupe(
    records: LogRecords,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, list[int]], np.ndarray]:
    """(t, values, provenance, drops, record indices kept): times checked non-decreasing, repeated times dropped.

    A time that goes backwards is an InputError naming both lines. Of fixes
    sharing a time the first is kept: an exact copy is a duplicate, a
    different position at the same time is counted apart.
    """
    t, values, numbers = records.t, records.values, records.line
    if not np.isfinite(t).all():
        raise InputError(f"{records.where(int(np.flatnonzero(~np.isfinite(t))[0]))}: time is not a finite number")
    step = np.diff(t)
    back = np.flatnonzero(step < 0)
    if len(back):
        k = int(back[0])
        raise InputError(
            f"{records.where(k + 1)}: time goes backwards: {_when(t[k + 1], records.utc)} after "
            f"{_when(t[k], records.utc)} "
            f"({records.where(k)}); a log must be in time order"
        )
    same = np.flatnonzero(step == 0) + 1
    dropped: dict[str, list[int]] = {}
    index = np.arange(len(t))
    if len(same):
        # Compare each repeat with the first fix of its run of equal times.
        first = np.maximum.accumulate(np.where(np.r_[True, step != 0], np.arange(len(t)), 0))
        exact = (values[same] == values[first[same]]).all(axis=1)
        if exact.any():
            dropped[DUPLICATE] = numbers[same[exact]].tolist()
        if (~exact).any():
            dropped[REPEATED_TIME] = numbers[same[~exact]].tolist()
        keep = np.ones(len(t), dtype=bool)
        keep[same] = False
        t, values, numbers, index = t[keep], values[keep], numbers[keep], index[keep]
    return t, values, numbers, dropped, index


def reject_spikes(t: np.ndarray, xyz: np.ndarray, max_speed: float, rounding: np.ndarray | None = None) -> np.ndarray:
    """Mask of fixes kept: each fix must be reachable from the last kept one at <= max_speed (m/s).

    Reachable: within max_speed x (the time between them + how long the earlier one's position had been held,
    up to HELD_MAX_S; at least SPIKE_WINDOW_S) + the rounding of both (rounding: per-fix m, from the printed
    precision). A log written
    per video frame repeats each receiver fix over several frames, then moves by a whole update in one frame
    interval; its coordinates' rounding (1.1 m steps at 5 decimals) over 20 ms would read as 100 m/s. The time
    held is the earlier fix's, whichever way the walk goes. Heights held over frames move by a whole update too.
    The walk starts at the first fix whose next two steps are both plausible
    (so a bad first fix does not condemn the rest) and runs forwards and
    backwards from there. Since the allowed distance grows with the time since
    the last kept fix, the walk recovers after a jump.
    """
    n = len(t)
    if n < 2:
        return np.ones(n, dtype=bool)
    slack = np.zeros(n) if rounding is None else np.nan_to_num(np.asarray(rounding, dtype=float))
    starts = _run_starts(xyz)
    ok = _plausible_steps(t, xyz, max_speed, slack, starts)
    if ok.all():
        return np.ones(n, dtype=bool)
    bad = np.flatnonzero(~ok)
    both = np.flatnonzero(ok[:-1] & ok[1:])
    start = int(both[0]) if len(both) else int(np.flatnonzero(ok)[0]) if ok.any() else 0
    keep = np.zeros(n, dtype=bool)
    keep[start] = True
    held = np.empty(n)
    for lo in range(0, n, SPIKE_BLOCK):
        held[lo : lo + SPIKE_BLOCK] = _held(t, starts, lo, min(n, lo + SPIKE_BLOCK))

    def reachable(i: int, last: int) -> bool:
        span = abs(float(t[i]) - float(t[last])) + float(held[min(i, last)])
        allowed = max_speed * max(span, SPIKE_WINDOW_S) + float(slack[i]) + float(slack[last])
        return math.dist(xyz[i].tolist(), xyz[last].tolist()) <= allowed

    # The walk from the last kept fix, one fix at a time only after a step that is not plausible: where the last
    # kept fix is the previous one and the steps are plausible, every fix up to the next implausible step is kept.
    i, last = start + 1, start
    while i < n:
        if last == i - 1 and ok[i - 1]:
            j = int(bad[np.searchsorted(bad, i - 1)]) if bad[-1] >= i - 1 else n - 1  # steps i-1 .. j-1 plausible
            keep[i : j + 1] = True
            i, last = j + 1, j
        else:
            if reachable(i, last):
                keep[i], last = True, i
            i += 1
    i, last = start - 1, start
    while i >= 0:
        if last == i + 1 and ok[i]:
            b = int(bad[np.searchsorted(bad, i) - 1]) if bad[0] < i else -1  # steps b+1 .. i plausible
            keep[b + 1 : i + 1] = True
            i, last = b, b + 1
        else:
            if reachable(i, last):
                keep[i], last = True, i
            i -= 1
    return keep


def _run_starts(xyz: np.ndarray) -> np.ndarray:
    """The first fix of each run of fixes at one position (indices, increasing)."""
    n = len(xyz)
    moved = np.ones(n, dtype=bool)
    for lo in range(0, n - 1, SPIKE_BLOCK):
        hi = min(n - 1, lo + SPIKE_BLOCK)
        moved[lo + 1 : hi + 1] = (xyz[lo + 1 : hi + 1] != xyz[lo:hi]).any(axis=1)
    return np.flatnonzero(moved)


def _held(t: np.ndarray, starts: np.ndarray, lo: int, hi: int) -> np.ndarray:
    """How long the positions of fixes lo .. hi - 1 were repeated (s; from the first to the last fix of each one's run,
    at most HELD_MAX_S); starts: _run_starts."""
    run = np.searchsorted(starts, np.arange(lo, hi), side="right") - 1
    end = np.where(run + 1 < len(starts), starts[np.minimum(run + 1, len(starts) - 1)] - 1, len(t) - 1)
    return np.minimum(t[end] - t[starts[run]], HELD_MAX_S)


def _plausible_steps(
    t: np.ndarray, xyz: np.ndarray, max_speed: float, slack: np.ndarray, starts: np.ndarray
) -> np.ndarray:
    """Whether each step (fix i to i + 1) is within max_speed x max(its time + how long fix i was held, SPIKE_WINDOW_S)
    + both fixes' rounding (m); in blocks of SPIKE_BLOCK fixes, so that a day's log needs no temporaries of its size."""
    n = len(t)
    ok = np.empty(n - 1, dtype=bool)
    for lo in range(0, n - 1, SPIKE_BLOCK):
        hi = min(n - 1, lo + SPIKE_BLOCK)
        step = np.linalg.norm(np.diff(xyz[lo : hi + 1], axis=0), axis=1)
        allowed = max_speed * np.maximum(np.diff(t[lo : hi + 1]) + _held(t, starts, lo, hi), SPIKE_WINDOW_S)
        ok[lo:hi] = step <= allowed + slack[lo:hi] + slack[lo + 1 : hi + 1]
    return ok


def median_interval(t: np.ndarray) -> float:
    """Median interval between fixes (s)."""
    return float(np.median(np.diff(t)))


def log_rate(t: np.ndarray) -> float:
    """The log's own rate (Hz): trajectory.grid_rate, snapped to a multiple of 1 mHz when within 1 ppm of one.

    Ingest chooses the grid it resamples onto, so a round rate is kept when
    the log allows it.
    """
    rate = grid_rate(t)
    snapped = round(rate, 3)
    return snapped if snapped > 0 and abs(rate - snapped) <= 1e-6 * rate else rate


def find_gaps(t: np.ndarray, factor: float = GAP_FACTOR) -> np.ndarray:
    """Indices i where t[i + 1] - t[i] exceeds factor x the median interval."""
    step = np.diff(t)
    return np.flatnonzero(step > factor * median_interval(t))


def resample(t: np.ndarray, xyz: np.ndarray, rate: float, max_gap_s: float) -> tuple[np.ndarray, np.ndarray, int]:
    """(grid indices k, positions at t[0] + k / rate, grid positions left out).

    Linear interpolation between the fixes around each grid time; a grid time
    inside an interval longer than max_gap_s is left out unless a fix falls on
    it (within 1 us). Indices keep their place (never renumbered). Work and
    memory grow with the samples kept, not with the time spanned. ValueError
    when more than MAX_SAMPLES would be made.
    """
    elapsed = t - t[0]
    kf = elapsed * rate
    if not kf[-1] < MAX_SAMPLES:
        raise ValueError(
            f"{elapsed[-1]:.6g} s at {rate:g} Hz is over {MAX_SAMPLES:,} samples: check the log's times or give a "
            f"lower rate"
        )
    tol = 1e-6 * rate
    nearest = np.round(kf).astype(np.int64)
    if _on_own_grid(kf, nearest, elapsed, tol, max_gap_s):
        k = nearest  # a log on its own grid, no sample missing: its fixes' indices (what the general case makes)
    else:
        fixed = np.abs(kf - nearest) <= tol
        lo = np.ceil(kf[:-1] - tol).astype(np.int64)
        hi = np.floor(kf[1:] + tol).astype(np.int64)
        counts = np.where(np.diff(elapsed) <= max_gap_s, np.maximum(hi - lo + 1, 0), 0)
        total = int(counts.sum())
        if total > MAX_SAMPLES:
            raise ValueError(
                f"{elapsed[-1]:.6g} s at {rate:g} Hz is over {MAX_SAMPLES:,} samples: "
                "check the log's times or give a lower rate"
            )
        inside = np.repeat(lo - np.cumsum(counts) + counts, counts) + np.arange(total)
        del lo, hi, counts
        # sorted, then duplicates out: np.unique's hashing took 4 s a million samples
        k = np.sort(np.concatenate([inside, nearest[fixed]]))
        k = k[np.r_[True, k[1:] != k[:-1]]]
        del nearest, fixed
    last = float(kf[-1])
    del kf
    grid = np.empty((len(k), 3))
    for block in range(0, len(k), SPIKE_BLOCK):
        at = k[block : block + SPIKE_BLOCK] / rate
        for j in range(3):
            grid[block : block + SPIKE_BLOCK, j] = np.interp(at, elapsed, xyz[:, j])
    return k, grid, int(np.floor(last + tol)) + 1 - len(k)


def _on_own_grid(kf: np.ndarray, nearest: np.ndarray, elapsed: np.ndarray, tol: float, max_gap_s: float) -> bool:
    """Whether every fix sits on the grid (kf within tol of its nearest index), one index after the previous, at most
    max_gap_s after it; in blocks of SPIKE_BLOCK fixes."""
    for lo in range(0, len(kf), SPIKE_BLOCK):
        hi = min(len(kf), lo + SPIKE_BLOCK + 1)
        if not (
            (np.abs(kf[lo:hi] - nearest[lo:hi]) <= tol).all()
            and (np.diff(nearest[lo:hi]) == 1).all()
            and (np.diff(elapsed[lo:hi]) <= max_gap_s).all()
        ):
            return False
    return True


def smooth(index: np.ndarray, xyz: np.ndarray, window_samples: float) -> np.ndarray:
    """Savitzky-Golay (quadratic) smoothing over each run of consecutive grid indices."""
    from scipy.signal import (
        savgol_filter,
    )  # scipy.signal costs about 1 s of start-up in every process, and smoothing is off by default

    out = xyz.copy()
    window = int(round(window_samples)) | 1
    if window < 3:
        return out
    breaks = np.flatnonzero(np.diff(index) != 1) + 1
    for run in np.split(np.arange(len(index)), breaks):
        w = min(window, len(run) if len(run) % 2 else len(run) - 1)
        if w >= 3:
            out[run] = savgol_filter(xyz[run], w, min(2, w - 1), axis=0, mode="interp")
    return out


def _utc(seconds: float) -> str | None:
    try:
        return dt.datetime.fromtimestamp(float(seconds), dt.timezone.utc).isoformat().replace("+00:00", "Z")
    except (OverflowError, OSError, ValueError):
        return None


def _local(seconds: float) -> str | None:
    """A local wall clock's seconds (since 1970 of its date and time, no zone) as an ISO date without zone."""
    utc = _utc(seconds)
    return None if utc is None else utc[:-1]


def _when(seconds: float, utc: bool) -> str:
    return (_utc(seconds) if utc else None) or f"{seconds:.6f} s"


def _where(records: LogRecords, number: int) -> str:
    return f"line {number}" if records.unit == "line" else f"{records.unit} {number}"


def _no_fix_message(records: LogRecords) -> str:
    total = sum(len(n) for n in records.dropped.values())
    if not total:
        what = f"{records.ignored} line(s) without a position" if records.ignored else "nothing readable"
        return f"{records.path}: no position fix in the log ({what})" + "".join(f"; {w}" for w in records.warnings)
    reasons = "; ".join(
        f"{len(n)} {reason} ({_where(records, n[0])}{', ...' if len(n) > 1 else ''})"
        for reason, n in records.dropped.items()
    )
    return f"{records.path}: no valid fix; {total} {records.unit}(s) dropped: {reasons}"
