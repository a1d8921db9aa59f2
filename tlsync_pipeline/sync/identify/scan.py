"""Where to look in a long video: a coarse line from its keyframes, and the windows of frames to read in full.

A camera that records for an hour sees the target for a minute. The known
trajectory says where the target will be in the image but not when; the
keyframes, decoded alone for about a tenth of the cost of every frame, say
when to within a second or two:

1. coarse pass: every mover of the keyframes (about 4 s apart: every
   keyframe, or every k-th where they are closer; 2 s apart when those
   cannot decide; trackers.tracking.detect_keyframe_movers) votes as in identification (identify.
   candidate_votes); the line search, with the slope held by the frame
   rates (slope.py), finds the coarse line clock = alpha x sample + beta
   through the most keyframes (inlier band COARSE_DELTA, wider than the
   fine one: a keyframe's vote is off by up to half a sample), and a second
   search without the votes near it gives the best competing line;
2. windows: the frames at which the coarse line puts the target's
   projected path inside the image (widened by EDGE_SHARE of the image),
   widened by a margin (MARGIN_S seconds and three times the coarse line's
   scatter), each window starting at the keyframe before it (what is
   decoded from there is detected on too: the background model's warm-up);
   windows closer than a keyframe interval are merged; the fine pass
   (the track stage) decodes and detects every frame inside them only, and
   identification, voting and the fit then run as on a whole video.

The whole video is read instead (``ScanPlan.full``, with its reason) when
the video has no packet index, keyframes too close to save anything, the
target's path is in view for most of the video anyway, no slope prior
(``rate_sigma`` = 0 or no fps), too few keyframes on the coarse line, a
competing line nearly as strong, or windows that would cover most of the
video. An ``OffsetPrior`` (the camera's clock, e.g. its creation time
against the log's UTC) narrows the keyframes read to where the log can
be seen.

Frames are 0-based decoded frame indices; lines are on the camera clock
(clock.py: frames, or presentation time x fps for VFR videos).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from calibration.camera import Camera
from tlsync_pipeline.artefacts.scan import CoarseLine, ScanPlan
from tlsync_pipeline.errors import SyncError
from tlsync_pipeline.sync.identify.identify import IdentifyParams, candidate_votes, detections_clock
from tlsync_pipeline.sync.kernels.line_search import find_line
from tlsync_pipeline.sync.kernels.slope import slope_prior
from tlsync_pipeline.sync.model.clock import FRAME, CameraClock, FrameTimes, camera_clock
from tlsync_pipeline.trajectory import PiecewiseTrajectory, Trajectory
from trackers.detections import Detections
from trackers.track import Track
from trackers.video import merge_windows

COARSE_DELTA = 2.0  # inlier band of the coarse line: orthogonal distance in the voting space (frames and samples)
MIN_KEYFRAMES = 5  # keyframes on the coarse line below which it is not trusted
AMBIGUOUS = 0.5  # a competing line with this share of the coarse line's keyframes (or more): ambiguous
MIN_KEYFRAME_INTERVAL = (
    10  # frames between keyframes (median) below which reading keyframes costs about as much as every frame
)
MAX_SHARE = 0.75  # windows (or the path's time in view) covering more of the video than this: every frame is read
MARGIN_S = 0.5  # seconds around each window for the coarse line's error, beyond a keyframe interval
COARSE_STEPS_S = (
    4.0,
    2.0,
)  # seconds between the keyframes the coarse pass reads, about: first, then when that cannot decide
EDGE_SHARE = 0.05  # the image widened by this share of its size on each side: a target half in view is detected


@dataclass(frozen=True)
class OffsetPrior:
    """What the camera's clock says about its line: beta (camera clock at target sample 0) to within +-tolerance (camera
    clock units).
    """

    beta: float
    tolerance: float


def full_scan(
    n_frames: int, reason: str, coarse: CoarseLine | None = None, keyframes_read: int = 0, undecided: bool = False
) -> ScanPlan:
    """Every frame is read, for ``reason``."""
    return ScanPlan(True, reason, ((0, n_frames),), n_frames, coarse, keyframes_read, undecided)


def before_coarse(
    camera: Camera,
    trajectory: Trajectory,
    n_frames: int | None,
    keyframes: np.ndarray | None,
    fps: float | None,
    params: IdentifyParams,
) -> str | None:
    """Why the coarse pass would not pay (then every frame is read), checked before decoding anything; None when it may.

    n_frames, keyframes: the video's frame count and keyframe indices from
    its packet index (None: no index).
    """
    if n_frames is None or keyframes is None or len(keyframes) == 0:
        return "the video has no packet index to seek by"
    interval = _keyframe_interval(keyframes, n_frames)
    if interval < MIN_KEYFRAME_INTERVAL:
        return f"a keyframe every {interval:g} frames: reading keyframes would cost about as much as every frame"
    prior = slope_prior(fps, trajectory.rate, params.rate_sigma)
    if prior is None:
        return "no slope prior to hold the coarse line by ([sync] rate_sigma = 0, or no fps or log rate)"
    uv, valid = camera.project(trajectory.xyz)
    in_view = int((valid & _in_view(camera, uv)).sum())
    seen = in_view * prior.alpha
    if seen >= MAX_SHARE * n_frames:
        return (
            f"the target's path is in view for {in_view} log samples, about {seen:.0f} frames: "
            f"{min(1.0, seen / n_frames):.0%} of the video's {n_frames}"
        )
    read = len(keyframes[:: coarse_stride(keyframes, n_frames, fps, COARSE_STEPS_S[-1])])
    if read < 2 * MIN_KEYFRAMES:
        return f"only {read} keyframes {COARSE_STEPS_S[-1]:g} s or more apart: too few for a coarse line"
    return None


def coarse_stride(keyframes: np.ndarray, n_frames: int, fps: float | None, step_s: float) -> int:
    """Read every k-th keyframe, k such that they are about ``step_s`` seconds apart (1: every keyframe; also without an
    fps).
    """
    if not fps:
        return 1
    return max(1, int(round(step_s * fps / _keyframe_interval(keyframes, n_frames))))


def prior_slope(fps: float | None, trajectory: Trajectory, params: IdentifyParams) -> float:
    """The slope the frame rates give (camera frames per log sample; 1 without them), for placing
    the log in the video.
    """
    prior = slope_prior(fps, trajectory.rate, params.rate_sigma)
    return prior.alpha if prior is not None else (fps / trajectory.rate if fps and trajectory.rate else 1.0)


def keyframe_range(
    trajectory: Trajectory, alpha: float, prior: OffsetPrior | None, n_frames: int, margin: float
) -> tuple[int, int]:
    """Frames [start, stop) where the log can be seen under an offset prior (the whole video without one), widened by
    ``margin`` frames.

    Frame clocks: the range is in frames; for a presentation-time clock the
    prior's clock values are taken as frames (off by the video's start
    time x fps at most, inside the tolerance of any camera-clock prior).
    """
    if prior is None:
        return 0, n_frames
    lo = alpha * float(trajectory.sample[0]) + prior.beta - prior.tolerance - margin
    hi = alpha * float(trajectory.sample[-1]) + prior.beta + prior.tolerance + margin
    return int(np.clip(math.floor(lo), 0, n_frames)), int(np.clip(math.ceil(hi) + 1, 0, n_frames))


def coarse_line(
    camera: Camera,
    keyframe_movers: Detections,
    trajectory: Trajectory,
    fps: float | None,
    params: IdentifyParams,
    keyframes: np.ndarray,
    n_frames: int,
    prior: OffsetPrior | None = None,
) -> CoarseLine:
    """The coarse line from every mover of the keyframes (see the module docstring); SyncError naming why none can be
    trusted.

    keyframes: indices of the keyframes read (their count, and their
    interval, which sets the competing line's distance).
    """
    slope = slope_prior(fps, trajectory.rate, params.rate_sigma)
    if slope is None:
        raise SyncError("no slope prior to hold the coarse line by")
    if len(keyframe_movers) == 0:
        raise SyncError("no mover on any keyframe")
    votes, rows = candidate_votes(camera, keyframe_movers, trajectory, params.eps_px)
    _, row_clock = detections_clock(keyframe_movers, fps)
    sample, dist, clock, group = votes.sample, votes.dist, row_clock[rows], keyframe_movers.id[rows]
    if prior is not None:
        near = np.abs(clock - slope.alpha * sample - prior.beta) <= prior.tolerance
        sample, dist, clock, group = sample[near], dist[near], clock[near], group[near]
    try:
        search = find_line(
            sample, clock, dist, COARSE_DELTA, params.p, params.r_min, params.seed, group=group, prior=slope
        )
    except ValueError as exc:
        raise SyncError(f"no coarse line: {exc}") from None
    residual = clock - search.alpha * sample - search.beta
    on_line = search.inliers
    scatter = float(np.sqrt(np.mean(residual[on_line] ** 2))) if on_line.any() else float("nan")
    away = np.abs(residual) > margin_frames(fps, scatter) + _keyframe_interval(keyframes, n_frames)
    runner_up = 0
    if len(np.unique(sample[away])) >= 2:
        try:
            runner_up = find_line(
                sample[away],
                clock[away],
                dist[away],
                COARSE_DELTA,
                params.p,
                params.r_min,
                params.seed,
                group=group[away],
                prior=slope,
            ).support
        except ValueError:
            runner_up = 0
    return CoarseLine(
        float(search.alpha), float(search.beta), int(search.support), int(runner_up), len(keyframes), scatter
    )


def margin_frames(fps: float | None, scatter: float) -> float:
    """Frames added on each side of a window: MARGIN_S seconds and three times the coarse line's scatter (frames)."""
    return MARGIN_S * (fps or 30.0) + 3.0 * (scatter if math.isfinite(scatter) else 0.0)


def plan_windows(
    camera: Camera,
    trajectory: Trajectory,
    line: CoarseLine,
    clock: CameraClock,
    times: FrameTimes | None,
    n_frames: int,
    keyframes: np.ndarray,
    fps: float | None,
) -> ScanPlan:
    """The fine pass's windows under a trusted coarse line, or every frame when they would cover most of the video.

    times: every frame's presentation times (for a presentation-time clock), or None.
    """
    frames = np.arange(n_frames, dtype=np.float64)
    s = (clock.clock_at(frames, times) - line.beta) / line.alpha
    path = PiecewiseTrajectory(trajectory)
    xyz = path.positions(s)
    seen = np.isfinite(xyz[:, 0])
    if seen.any():
        uv, valid = camera.project(xyz[seen])
        seen[np.flatnonzero(seen)[~(valid & _in_view(camera, uv))]] = False
    margin = int(math.ceil(margin_frames(fps, line.scatter)))
    runs = _runs(seen)
    widened = [(max(0, a - margin), min(n_frames, b + margin)) for a, b in runs]
    starts = np.asarray(keyframes, dtype=np.int64)
    aligned = [
        (int(starts[max(0, int(np.searchsorted(starts, a, side="right")) - 1)]) if len(starts) else 0, b)
        for a, b in widened
    ]
    windows = tuple(merge_windows(aligned, gap=int(_keyframe_interval(keyframes, n_frames))))
    read = sum(b - a for a, b in windows)
    if not windows:
        return full_scan(n_frames, "the coarse line never puts the target's path in view", line, line.keyframes)
    if read > MAX_SHARE * n_frames:
        return full_scan(
            n_frames,
            f"the target is in view in {read / n_frames:.0%} of the video under the coarse line",
            line,
            line.keyframes,
        )
    return ScanPlan(False, "", windows, n_frames, line, line.keyframes)


def plan_scan(
    camera: Camera,
    keyframe_movers: Detections,
    trajectory: Trajectory,
    fps: float | None,
    params: IdentifyParams,
    keyframes: np.ndarray,
    n_frames: int,
    times: np.ndarray | None = None,
    prior: OffsetPrior | None = None,
    read: np.ndarray | None = None,
) -> ScanPlan:
    """The fine pass's plan from the coarse pass's movers: windows under a trusted coarse line, else every frame with
    the reason.

    keyframes: every keyframe of the video; read: those the coarse pass
    read (None: all); times: every frame's presentation time (s), or None.
    """
    read = np.asarray(keyframes if read is None else read)
    try:
        line = coarse_line(camera, keyframe_movers, trajectory, fps, params, read, n_frames, prior)
    except SyncError as exc:
        return full_scan(n_frames, f"coarse pass: {exc}", keyframes_read=len(read), undecided=True)
    if line.support < MIN_KEYFRAMES:
        return full_scan(
            n_frames,
            f"only {line.support} keyframes show the target on the coarse line (fewer than {MIN_KEYFRAMES})",
            line,
            len(read),
            undecided=True,
        )
    if line.runner_up >= AMBIGUOUS * line.support:
        return full_scan(
            n_frames,
            f"the coarse line is ambiguous: a competing line has {line.runner_up} keyframes against its {line.support}",
            line,
            len(read),
            undecided=True,
        )
    clock, table = _frame_clock(times, fps, n_frames)
    return plan_windows(camera, trajectory, line, clock, table, n_frames, keyframes, fps)


def _frame_clock(times: np.ndarray | None, fps: float | None, n_frames: int) -> tuple[CameraClock, FrameTimes | None]:
    """The camera clock of the whole video from its frames' presentation times (frame indices without them)."""
    if times is None or len(times) != n_frames:
        return CameraClock(FRAME, fps), None
    frames = np.arange(n_frames)
    clock = camera_clock(
        Track(frames, np.zeros(n_frames), np.zeros(n_frames), time_s=np.asarray(times, dtype=np.float64)), fps
    )
    return clock, FrameTimes(frames.astype(np.float64), np.asarray(times, dtype=np.float64)) if clock.vfr else None


def _keyframe_interval(keyframes: np.ndarray, n_frames: int) -> float:
    """The median number of frames between keyframes (the video's length for a single keyframe)."""
    keys = np.asarray(keyframes, dtype=np.int64)
    return float(np.median(np.diff(np.r_[keys, n_frames]))) if len(keys) else float(n_frames)


def _in_view(camera: Camera, uv: np.ndarray) -> np.ndarray:
    """Pixel positions inside the image widened by EDGE_SHARE of its size on each side."""
    w, h = camera.image_size
    x, y = uv[:, 0], uv[:, 1]
    return (x >= -EDGE_SHARE * w) & (x <= (1 + EDGE_SHARE) * w) & (y >= -EDGE_SHARE * h) & (y <= (1 + EDGE_SHARE) * h)


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) of each run of True."""
    edges = np.flatnonzero(np.diff(np.r_[0, mask.astype(np.int8), 0]))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2])]
