"""The synchronized player's data: per camera its line, its frames' presentation times and the projected path.

The report's player (player.js) runs on one shared position, the target
sample t_r (seconds: t0 + t_r / rate, UTC for GPS logs). For a camera it maps
t_r to the camera's clock with its line (clock = alpha t_r + beta), the clock
to the nearest frame (frame index, or presentation time x fps for VFR
cameras: the same rule as the frame map), and seeks its video to the middle
of that frame's display interval. The target's projected position is drawn
over each video from a table sampled on the target grid.

A recording that breaks (sync/identify/segments.py) brings its segment table: each
segment's frames, its shift (the clock units CameraClock.clock_at adds to its
frames: the player takes the nearest frame on each segment of known shift to
clock - shift and keeps the one the segment holds, as CameraClock.frames_at
does) and the target samples it spans; and its breaks, each at the sample
where it happened, drawn on the camera's strip.

Pure functions: typed values in, a JSON-ready dict out.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tlsync_pipeline.sync.model.clock import FrameTimes
from tlsync_pipeline.sync.timeline import CameraLine, Timeline
from tlsync_pipeline.trajectory import Trajectory

MAX_PATH_POINTS = 6000  # projected path samples per camera (the grid is thinned beyond)
REGULAR_TOLERANCE_S = 1e-6
GRID_TOLERANCE = 1e-3  # samples: a grid position is present when a trajectory sample lies this close


@dataclass(frozen=True)
class PlayerVideo:
    """One camera's playable file: its URL relative to report.html (None: no video), whether it is a proxy,
    its codec, and the presentation time (s) of each frame, as the browser's currentTime counts it."""

    src: str | None
    proxy: bool
    codec: str | None
    frame_times: np.ndarray


def encode_times(times: np.ndarray) -> dict:
    """Frame times compactly: {start, step, n} when regular, else {start, deltas_us} (integer microseconds)."""
    times = np.asarray(times, dtype=np.float64)
    if len(times) < 2:
        return {"start": float(times[0]) if len(times) else 0.0, "step": 0.0, "n": int(len(times))}
    step = (times[-1] - times[0]) / (len(times) - 1)
    if np.max(np.abs(times - (times[0] + step * np.arange(len(times))))) <= REGULAR_TOLERANCE_S:
        return {"start": float(times[0]), "step": float(step), "n": int(len(times))}
    micro = np.round((times - times[0]) * 1e6).astype(np.int64)
    return {"start": float(times[0]), "deltas_us": np.diff(micro).tolist()}


def decode_times(encoded: dict) -> np.ndarray:
    """The inverse of encode_times (what player.js does), to microseconds."""
    if "deltas_us" in encoded:
        return encoded["start"] + np.concatenate([[0], np.cumsum(encoded["deltas_us"])]) * 1e-6
    return encoded["start"] + encoded["step"] * np.arange(encoded["n"])


def recording_samples(line: CameraLine, frame_times: np.ndarray) -> tuple[float, float]:
    """The target samples at which a camera's first and last frames were taken (of a recording that breaks: its
    first and last frames of known offset)."""
    n = len(frame_times)
    table = FrameTimes(np.arange(n, dtype=np.float64), np.asarray(frame_times, dtype=np.float64))
    frames = np.arange(n, dtype=np.float64) if line.clock.segments else np.array([0.0, n - 1.0])
    samples = line.sample_at(frames, table)
    samples = samples[np.isfinite(samples)]
    return (float(samples.min()), float(samples.max())) if len(samples) else (0.0, 0.0)


def segment_table(line: CameraLine, frame_times: np.ndarray) -> list[dict]:
    """A recording's segments for the player: start, stop (frames, stop excluded), shift (clock units, None: unknown),
    source, and lo, hi: the target samples of its first and last frames; for a segment of unknown shift, the samples
    between the known segments around it (None: open), where the camera shows no picture rather than a wrong frame."""
    n = len(frame_times)
    table = FrameTimes(np.arange(n, dtype=np.float64), np.asarray(frame_times, dtype=np.float64))
    spans: list[tuple[float, float] | None] = []
    for seg in line.clock.segments:
        first, last = max(seg.start, 0), min(seg.stop, n) - 1
        known = seg.shift is not None and last >= first
        lo, hi = line.sample_at(np.array([first, last], dtype=np.float64), table) if known else (np.nan, np.nan)
        spans.append((float(lo), float(hi)) if known else None)
    rows = []
    for k, seg in enumerate(line.clock.segments):
        span = spans[k]
        if span is None:  # between the known segments around it
            before = [s[1] for s in spans[:k] if s is not None]
            after = [s[0] for s in spans[k + 1 :] if s is not None]
            lo, hi = (before[-1] if before else None), (after[0] if after else None)
        else:
            lo, hi = span
        row = {"start": seg.start, "stop": seg.stop, "shift": seg.shift, "source": seg.source}
        rows.append(row | {"lo": lo, "hi": hi})
    return rows


def break_marks(line: CameraLine, frame_times: np.ndarray) -> list[dict]:
    """Each break of a recording at the target sample where it happened (its first frame after, else its last frame
    before, as the report's recordings chart places it): {sample, text}; breaks next to no frame of known offset are
    left out."""
    n = len(frame_times)
    table = FrameTimes(np.arange(n, dtype=np.float64), np.asarray(frame_times, dtype=np.float64))
    marks = []
    for b in line.breaks or ():
        after, before = line.sample_at(np.array([max(b.frame, 0), max(b.frame - 1, 0)], dtype=np.float64), table)
        where = after if np.isfinite(after) else before
        if np.isfinite(where):
            marks.append({"sample": float(where), "text": b.describe()})
    return marks


def projected_path(camera, trajectory: Trajectory, lo: float, hi: float) -> dict:
    """The target's projected image position on the grid samples in [lo, hi], thinned to MAX_PATH_POINTS.

    {start, step, uv}: sample of the first entry, samples between entries, and
    [u, v] pairs in tenths of a pixel (null where the target is absent, behind
    the camera, or more than one image size outside the view).
    """
    grid = trajectory.sample
    inside = grid[(grid >= np.floor(lo)) & (grid <= np.ceil(hi))]
    if len(inside) == 0:
        return {"start": lo, "step": 1.0, "uv": []}
    first, last = float(inside[0]), float(inside[-1])
    step = max(1.0, float(np.ceil((last - first + 1) / MAX_PATH_POINTS)))
    samples = np.arange(first, last + 0.5, step)
    index = np.clip(np.searchsorted(grid, samples - GRID_TOLERANCE), 0, len(grid) - 1)
    present = np.abs(grid[index] - samples) <= GRID_TOLERANCE
    uv = np.full((len(samples), 2), np.nan)
    if present.any():
        projected, valid = camera.project(trajectory.xyz[index[present]])
        w, h = camera.image_size
        near = (
            valid
            & (projected[:, 0] > -w)
            & (projected[:, 0] < 2 * w)
            & (projected[:, 1] > -h)
            & (projected[:, 1] < 2 * h)
        )
        uv[np.flatnonzero(present)[near]] = projected[near]
    flat = [None if np.isnan(value) else int(round(value * 10)) for value in uv.ravel()]
    return {"start": first, "step": step, "uv": flat}


def player_data(
    timeline: Timeline, cameras: dict, trajectory: Trajectory, videos: dict[str, PlayerVideo], utc: bool
) -> dict:
    """The JSON the player reads: the target clock, the shared range and per camera its line, times and path (and, for a
    recording that breaks, its segments and breaks).

    cameras: name -> Camera (calibration); videos: name -> PlayerVideo; utc:
    whether t0 + t_r / rate is POSIX time (GPS logs).
    """
    entries = []
    ranges = []
    for name, line in timeline.cameras.items():
        video = videos[name]
        lo, hi = recording_samples(line, video.frame_times)
        ranges.append((lo, hi))
        entry: dict = {
            "name": name,
            "src": video.src,
            "proxy": video.proxy,
            "codec": video.codec,
            "alpha": line.alpha,
            "beta": line.beta,
            "fps": line.fps or 0.0,
            "clock_fps": line.clock.fps if line.clock.vfr else None,
            "times": encode_times(video.frame_times),
            "size": list(cameras[name].image_size),
            "path": projected_path(cameras[name], trajectory, lo, hi),
        }
        if line.clock.segments:
            entry["segments"] = segment_table(line, video.frame_times)
            entry["breaks"] = break_marks(line, video.frame_times)
        entries.append(entry)
    return {
        "target": {
            "rate": timeline.target_rate or 1.0,
            "t0": timeline.target_t0 or 0.0,
            "utc": bool(utc),
            "seconds": timeline.target_rate is not None,
        },
        "range": [min(r[0] for r in ranges), max(r[1] for r in ranges)] if ranges else [0.0, 1.0],
        "reference": timeline.names[0] if timeline.names else None,
        "cameras": entries,
    }
