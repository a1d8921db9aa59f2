"""Camera clocks: frame indices, or presentation times for variable frame rates.

A video whose presentation times (track ``time_s``) are regular keeps its
frame indices as the clock of its line, as in the paper. When they are
irregular (phones, action cameras: intervals that vary from frame to frame),
the line is fitted on the camera's clock in seconds, expressed in units of
its nominal frame interval: clock = time_s * fps. A camera line
clock = alpha * sample + beta is then a relation between the camera's and
the target's clocks in seconds, and frame maps go through the video's own
table of presentation times (``frame_map``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from trackers.track import Track

# Presentation times are irregular when they leave the best constant-rate
# line by more than this fraction of the mean frame interval.
IRREGULAR = 0.25


@dataclass(frozen=True)
class CameraClock:
    """Clock coordinate (frames) of each tracked row; fps: nominal rate; vfr: whether from time_s."""

    frames: np.ndarray
    fps: float | None
    vfr: bool
    jitter: float = 0.0

    def details(self) -> dict:
        """Entries for timeline.json (only for variable-frame-rate cameras)."""
        if not self.vfr:
            return {}
        return {"clock": "time_s", "clock_fps": self.fps, "time_jitter_frames": self.jitter}


def camera_clock(track: Track, fps: float | None) -> CameraClock:
    """The clock a camera's line is fitted on.

    Frame indices unless the track has irregular presentation times; then
    time_s * fps, with fps the given nominal rate or the mean rate of the
    times.
    """
    frames = track.frame.astype(np.float64)
    if track.time_s is None or len(track) < 3:
        return CameraClock(frames, fps, False)
    slope, intercept = np.polyfit(frames, track.time_s, 1)
    if not slope > 0:
        return CameraClock(frames, fps, False)
    jitter = float(np.max(np.abs(track.time_s - (slope * frames + intercept))) / slope)
    if jitter <= IRREGULAR:
        return CameraClock(frames, fps, False)
    rate = fps if fps else 1.0 / slope
    return CameraClock(track.time_s * rate, rate, True, jitter)


def frame_map(frames_a: np.ndarray, times_a: np.ndarray, frames_b: np.ndarray, times_b: np.ndarray, a: float, b: float) -> np.ndarray:
    """Fractional frame of B shown at each frame of A, given time_B = a * time_A + b (seconds).

    times_*: presentation times of the listed frames (increasing); NaN
    outside B's recorded times.
    """
    t_b = a * np.asarray(times_a, dtype=np.float64) + b
    out = np.interp(t_b, times_b, np.asarray(frames_b, dtype=np.float64))
    out[(t_b < times_b[0]) | (t_b > times_b[-1])] = np.nan
    return out
