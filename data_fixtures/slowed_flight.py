"""A real flight slowed down: its log and its cameras' tracks under a monotone warp of time.

A flight's geometry (the path, the cameras, what each tracked) is kept and
time is stretched: the drone flies the same path ``slow`` times slower and,
every ``hover_every_s`` seconds of the original flight, holds still for
``hover_s`` seconds (``time_warp``); or only the fast parts are stretched,
so that the drone never flies faster than a speed (``speed_cap_warp``: a
flight that hovers and creeps). The log is resampled at its own rate on the new time
(linear between the original fixes); each camera keeps its clock (its
frame rate and drift: the true line's slope) and sees at each of its new
frames what it saw at the original instant (the track interpolated between
two tracked frames next to each other, dropped elsewhere). The cameras'
true lines, and so the pairs' truth, follow from the warp. A slow or
hovering target is where a metre-level log's bias becomes seconds of
timing, and a pass's votes spread over many lines.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from data_fixtures.scene import pairs_of_lines
from tlsync_pipeline.sync.solve.methods import CameraInput
from tlsync_pipeline.sync.timeline import Relation
from tlsync_pipeline.trajectory import Trajectory
from trackers.track import Track


@dataclass(frozen=True)
class TimeWarp:
    """A piecewise-linear map from the original flight's time t to the slowed one's T (seconds from the log's first
    fix): knots (t_k, T_k) with T increasing and t non-decreasing (t constant over a hover), and ``slow`` times the
    time beyond the knots."""

    t: np.ndarray
    warped: np.ndarray
    slow: float

    def forward(self, t: np.ndarray | float) -> np.ndarray:
        """T of original times t (the start of a hover where one begins)."""
        t = np.asarray(t, dtype=np.float64)
        before, after = self.warped[0] + self.slow * (t - self.t[0]), self.warped[-1] + self.slow * (t - self.t[-1])
        return np.where(t < self.t[0], before, np.where(t > self.t[-1], after, np.interp(t, self.t, self.warped)))

    def inverse(self, warped: np.ndarray | float) -> np.ndarray:
        """The original time t at slowed times T."""
        w = np.asarray(warped, dtype=np.float64)
        before, after = self.t[0] + (w - self.warped[0]) / self.slow, self.t[-1] + (w - self.warped[-1]) / self.slow
        return np.where(
            w < self.warped[0], before, np.where(w > self.warped[-1], after, np.interp(w, self.warped, self.t))
        )


def speed_cap_warp(t: np.ndarray, xyz: np.ndarray, max_speed: float) -> TimeWarp:
    """The warp that stretches each interval between two fixes (times t, s; positions xyz, metres) where the target
    flies faster than ``max_speed`` (m/s) to that speed, and keeps the slower ones (and the time outside the log)."""
    t = np.asarray(t, dtype=np.float64)
    speed = np.linalg.norm(np.diff(xyz, axis=0), axis=1) / np.diff(t)
    warped = t[0] + np.concatenate([[0.0], np.cumsum(np.diff(t) * np.maximum(1.0, speed / max_speed))])
    return TimeWarp(t, warped, 1.0)


def time_warp(duration_s: float, slow: float, hover_s: float = 0.0, hover_every_s: float = 0.0) -> TimeWarp:
    """The warp of a flight of ``duration_s`` seconds: every second ``slow`` seconds long, and a hover of ``hover_s``
    seconds at every multiple of ``hover_every_s`` (0: none) inside the flight."""
    hovers = np.arange(hover_every_s, duration_s, hover_every_s) if hover_s > 0 and hover_every_s > 0 else np.empty(0)
    t = np.concatenate([[0.0], np.repeat(hovers, 2), [duration_s]])
    held = np.concatenate([[0.0], np.tile([0.0, hover_s], len(hovers)), [0.0]])
    warped = slow * t + np.cumsum(held)
    return TimeWarp(t, warped, slow)


@dataclass(frozen=True)
class SlowedFlight:
    """The slowed flight's cameras, log, true lines (camera clock = alpha x sample + beta) and frame counts."""

    cameras: dict[str, CameraInput]
    trajectory: Trajectory
    lines: dict[str, Relation]
    n_frames: dict[str, int]

    def pairs(self) -> dict[str, Relation]:
        """Each ordered pair's truth "A->B": B's frame = alpha x A's frame + beta."""
        return pairs_of_lines(self.lines)


def slowed_flight(
    cameras: dict[str, CameraInput],
    trajectory: Trajectory,
    lines: dict[str, Relation],
    n_frames: dict[str, int],
    warp: TimeWarp,
) -> SlowedFlight:
    """The flight under ``warp``. lines: each camera's true line against the log's samples; the log has a rate."""
    rate = trajectory.rate
    assert rate is not None, "the log needs times"
    t = trajectory.sample / rate
    new_t = np.arange(0.0, float(warp.forward(t[-1])) + 0.5 / rate, 1.0 / rate)
    original = warp.inverse(new_t)
    xyz = np.column_stack([np.interp(original, t, trajectory.xyz[:, k]) for k in range(3)])
    log = Trajectory(new_t * rate, xyz, rate, trajectory.t0)
    out_cameras, out_lines, out_frames = {}, {}, {}
    for name, inputs in cameras.items():
        line = lines[name]
        start = float(warp.forward((0.0 - line.beta) / line.alpha / rate))  # the video's first frame, slowed time
        beta = -line.alpha * rate * start
        end = float(warp.forward((n_frames[name] - line.beta) / line.alpha / rate))
        frames = np.arange(max(int(np.ceil(line.alpha * rate * end + beta)), 1))
        source = line.alpha * rate * warp.inverse((frames - beta) / line.alpha / rate) + line.beta
        assert inputs.track is not None
        out_cameras[name] = replace(inputs, track=_resampled(inputs.track, frames, source))
        out_lines[name] = Relation(line.alpha, beta)
        out_frames[name] = len(frames)
    return SlowedFlight(out_cameras, log, out_lines, out_frames)


def _resampled(track: Track, frames: np.ndarray, source: np.ndarray) -> Track:
    """The track at new frames, each showing the original (fractional) frame ``source``: interpolated between the two
    original frames around it when both were tracked, dropped otherwise."""
    nearest = np.round(source)
    source = np.where(np.abs(source - nearest) < 1e-6, nearest, source)  # a frame shown as it was, not rounded off
    tracked = np.zeros(int(track.frame.max()) + 2, dtype=bool)
    tracked[track.frame] = True
    lo = np.floor(source).astype(np.int64)
    keep = (lo >= 0) & (lo + 1 < len(tracked))
    keep[keep] = tracked[lo[keep]] & (tracked[lo[keep] + 1] | (source[keep] == lo[keep]))
    x = np.interp(source[keep], track.frame, track.x)
    y = np.interp(source[keep], track.frame, track.y)
    return Track(frames[keep].astype(np.int64), x, y)


def cropped(flight: SlowedFlight, share: float) -> SlowedFlight:
    """The flight with each camera's video cut to ``share`` (0-1] of its visit (the span of its tracked frames): of n
    cameras, the k-th's window starts k/(n-1) of the way along what the cut leaves out (the first camera keeps its
    visit's start, the last its end). Frames are renumbered from the window's first; lines and frame counts follow."""
    cameras, lines, n_frames = {}, {}, {}
    last = max(len(flight.cameras) - 1, 1)
    for k, (name, inputs) in enumerate(flight.cameras.items()):
        track, line = inputs.track, flight.lines[name]
        assert track is not None
        span = float(track.frame[-1] - track.frame[0])
        first = int(track.frame[0] + round(k / last * (1.0 - share) * span))
        end = first + int(round(share * span))
        keep = (track.frame >= first) & (track.frame <= end)
        cameras[name] = replace(inputs, track=Track(track.frame[keep] - first, track.x[keep], track.y[keep]))
        lines[name] = Relation(line.alpha, line.beta - first)
        n_frames[name] = end - first + 1
    return replace(flight, cameras=cameras, lines=lines, n_frames=n_frames)


def slow_part(flight: SlowedFlight, max_speed: float) -> SlowedFlight:
    """The flight with each camera's track cut to the frames where the target (by its true line, on the log) moves
    slower than ``max_speed`` (metres per second): cameras that see only its hovers and slow stretches."""
    log = flight.trajectory
    assert log.rate is not None, "the log needs times"
    speed = np.linalg.norm(np.gradient(log.xyz, axis=0), axis=1) * log.rate / np.gradient(log.sample)
    cameras = {}
    for name, inputs in flight.cameras.items():
        track, line = inputs.track, flight.lines[name]
        assert track is not None
        keep = np.interp((track.frame - line.beta) / line.alpha, log.sample, speed) < max_speed
        cameras[name] = replace(inputs, track=Track(track.frame[keep], track.x[keep], track.y[keep]))
    return replace(flight, cameras=cameras)
