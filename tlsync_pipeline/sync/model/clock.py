"""Camera clocks: frame indices, or presentation times for variable frame rates.

A video whose presentation times (track ``time_s``) are regular keeps its
frame indices as the clock of its line, as in the paper. When they are
irregular (phones, action cameras: intervals that vary from frame to frame),
the line is fitted on the camera's clock in seconds, expressed in units of
its nominal frame interval: clock = time_s * fps. A camera line
clock = alpha * sample + beta is then a relation between the camera's and
the target's clocks in seconds.

Frames and clock values are converted by ``CameraClock.clock_at`` and
``CameraClock.frames_at`` only: exactly through a table of presentation
times (``FrameTimes``: the video's own, or the tracked frames'), or, without
one, by the clock's linear approximation (frames at the nominal rate from
``origin_s``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from trackers.track import Track

# Presentation times are irregular when they leave the best constant-rate
# line by more than this fraction of the mean frame interval.
IRREGULAR = 0.25

FRAME = "frame"  # clock = 0-based frame index
TIME_S = "time_s"  # clock = presentation time (s) x fps


@dataclass(frozen=True)
class FrameTimes:
    """Presentation times of some of a camera's frames.

    frame: (K,) increasing 0-based frame indices; time_s: (K,) their
    presentation times (s), increasing. Every frame of the video (its own
    table) or the tracked frames (a track's ``time_s``). Between listed
    frames times are interpolated linearly; beyond them they continue at the
    clock's nominal rate.
    """

    frame: np.ndarray
    time_s: np.ndarray

    @classmethod
    def of_track(cls, track: Track) -> FrameTimes | None:
        """The tracked frames' presentation times, or None when the track has none."""
        if track.time_s is None or len(track) == 0:
            return None
        return cls(track.frame.astype(np.float64), np.asarray(track.time_s, dtype=np.float64))


@dataclass(frozen=True)
class Segment:
    """A stretch of a camera's frames on one steady clock, between breaks of its recording (sync/identify/segments.py).

    start, stop: its first frame and one past its last (0-based; the first
    segment reaches back and the last forward without end); shift: clock
    units added to its frames' clock values to put them on the camera's
    line, None when unknown (its frames then map to nothing); source: how
    the shift is known: "line" (the segment the line was fitted on),
    "votes" (the target's votes on it), "container" (the container's
    presentation times across the break), "unknown", "unresolved" (seen by
    the target, its shift not close to whole frames on a frame clock) or
    "frozen" (repeated pictures: no instant of their own); frames: the
    target's tracked frames on it.
    """

    start: int
    stop: int
    shift: float | None
    source: str
    frames: int = 0

    def to_dict(self) -> dict:
        return {
            "start": self.start,
            "stop": self.stop,
            "shift": self.shift,
            "source": self.source,
            "frames": self.frames,
        }

    @classmethod
    def from_dict(cls, entry: dict) -> Segment:
        shift = entry.get("shift")
        return cls(
            int(entry["start"]),
            int(entry["stop"]),
            None if shift is None else float(shift),
            str(entry["source"]),
            int(entry.get("frames", 0)),
        )


@dataclass(frozen=True)
class CameraClock:
    """The clock a camera's line is on.

    kind: FRAME (clock = frame index) or TIME_S (clock = presentation time
    x fps); fps: nominal frames per second (None when unknown; set for
    TIME_S clocks); origin_s: TIME_S clocks: presentation time (s) of frame 0
    for frames at the nominal rate (least squares over the tracked frames),
    used only without a table of presentation times; jitter_frames: largest
    departure of the tracked frames' times from the best constant-rate line
    (frame intervals); segments: the recording's stretches between breaks,
    each with its shift (``Segment``; empty: one steady recording). A frame
    in a segment of unknown shift has no clock value (NaN), and no clock
    value maps to it.
    """

    kind: str = FRAME
    fps: float | None = None
    origin_s: float = 0.0
    jitter_frames: float = 0.0
    segments: tuple[Segment, ...] = ()

    @property
    def vfr(self) -> bool:
        """Whether the clock is presentation time (variable frame rate)."""
        return self.kind == TIME_S

    def clock_at(self, frames, times: FrameTimes | None = None) -> np.ndarray:
        """Clock values (frame units) of 0-based (fractional) frames.

        Frame clocks: the frames themselves. TIME_S clocks: presentation
        time x fps, exact through ``times`` at listed frames, else the
        linear approximation.
        """
        frames = np.asarray(frames, dtype=np.float64)
        base = self._steady_clock(frames, times)
        if not self.segments:
            return base
        shift = np.full(frames.shape, np.nan)
        for k, seg in enumerate(self.segments):
            inside = self._inside(k, frames)
            shift[inside] = np.nan if seg.shift is None else seg.shift
        return base + shift

    def frames_at(self, clock, times: FrameTimes | None = None) -> np.ndarray:
        """0-based fractional frames at clock values; the inverse of ``clock_at`` (NaN: a value no frame holds, in a
        break of the recording or a segment of unknown shift)."""
        clock = np.asarray(clock, dtype=np.float64)
        if not self.segments:
            return self._steady_frames(clock, times)
        out = np.full(clock.shape, np.nan)
        for k, seg in enumerate(self.segments):
            if seg.shift is not None:
                frames = self._steady_frames(clock - seg.shift, times)
                take = np.isnan(out) & self._inside(k, frames)
                out[take] = frames[take]
        return out

    def _inside(self, k: int, frames: np.ndarray) -> np.ndarray:
        """Which (fractional) frames segment k holds: [start - 0.5, stop - 0.5), open at the recording's two ends."""
        seg = self.segments[k]
        low = -np.inf if k == 0 else seg.start - 0.5
        high = np.inf if k == len(self.segments) - 1 else seg.stop - 0.5
        return (frames >= low) & (frames < high)

    def _steady_clock(self, frames: np.ndarray, times: FrameTimes | None) -> np.ndarray:
        """clock_at without the segments' shifts."""
        if not self.vfr:
            return frames
        assert self.fps is not None, "a presentation-time clock has its fps"
        if times is None:
            return frames + self.origin_s * self.fps
        return _extended_interp(frames, times.frame, times.time_s, 1.0 / self.fps) * self.fps

    def _steady_frames(self, clock: np.ndarray, times: FrameTimes | None) -> np.ndarray:
        """frames_at without the segments' shifts."""
        if not self.vfr:
            return clock
        assert self.fps is not None, "a presentation-time clock has its fps"
        if times is None:
            return clock - self.origin_s * self.fps
        return _extended_interp(clock / self.fps, times.time_s, times.frame, self.fps)

    def seconds_at(self, clock, times: FrameTimes | None = None) -> np.ndarray:
        """Seconds since frame 0 on this camera's steady clock at clock values (needs fps)."""
        return (np.asarray(clock, dtype=np.float64) - self._steady_clock(np.float64(0.0), times)) / self.fps


def _extended_interp(x: np.ndarray, xp: np.ndarray, fp: np.ndarray, slope: float) -> np.ndarray:
    """np.interp inside [xp[0], xp[-1]]; beyond it straight lines of the given slope from the ends."""
    out = np.interp(x, xp, fp)
    out = np.where(x < xp[0], fp[0] + (x - xp[0]) * slope, out)
    return np.where(x > xp[-1], fp[-1] + (x - xp[-1]) * slope, out)


def camera_clock(track: Track, fps: float | None) -> CameraClock:
    """The clock a camera's line is fitted on.

    Frame indices unless the track has irregular presentation times; then
    time_s * fps, with fps the given nominal rate or the mean rate of the
    times.
    """
    frames = track.frame.astype(np.float64)
    if track.time_s is None or len(track) < 3:
        return CameraClock(FRAME, fps)
    slope, intercept = np.polyfit(frames, track.time_s, 1)
    if not slope > 0:
        return CameraClock(FRAME, fps)
    jitter = float(np.max(np.abs(track.time_s - (slope * frames + intercept))) / slope)
    if jitter <= IRREGULAR:
        return CameraClock(FRAME, fps)
    rate = fps if fps else 1.0 / slope
    origin = float(np.mean(track.time_s - frames / rate))
    return CameraClock(TIME_S, rate, origin, jitter)


def image_speed(clock: np.ndarray, xy: np.ndarray, quantile: float = 0.75) -> float | None:
    """A track's image speed, pixels per clock unit: the quantile of its steps over consecutive tracked frames (clock
    gaps of at most 2), at least 0.05; None without consecutive frames."""
    dc = np.diff(np.asarray(clock, dtype=np.float64))
    near = (dc > 0) & (dc <= 2.0)
    if not near.any():
        return None
    step = np.linalg.norm(np.diff(np.asarray(xy, dtype=np.float64), axis=0), axis=1)
    return max(float(np.quantile(step[near] / dc[near], quantile)), 0.05)
