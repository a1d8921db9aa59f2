"""Synchronization of cameras against the target: votes, line fit, timeline.

Two methods (``[sync] method``): "paper", Brito et al.'s RANSAC as published,
and "refined" (default): robust line search (line_search.py), then
continuous-time refinement with uncertainty (refine.py), falling back to the
line-search line with a warning when the refinement fails or disagrees.

Pure functions from typed values to typed values; no file I/O here.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

import numpy as np

from calibration.camera import Camera
from tlsync_pipeline.errors import SyncError
from tlsync_pipeline.sync.clock import camera_clock
from tlsync_pipeline.sync.identify import Identification, identify_target
from tlsync_pipeline.sync.line_search import LineSearch, find_line
from tlsync_pipeline.sync.params import SyncParams
from tlsync_pipeline.sync.ransac import LineFit, distance_to_line, fit_line_ransac
from tlsync_pipeline.sync.refine import (
    PiecewiseTrajectory,
    Refinement,
    refine_line,
    smooth_trajectory,
)
from tlsync_pipeline.sync.timeline import CameraLine, Timeline
from tlsync_pipeline.sync.votes import Votes, compute_votes
from tlsync_pipeline.trajectory import Trajectory
from trackers.detections import Detections
from trackers.track import Track

# Weak-case thresholds of the refined method (flags in timeline.json).
FEW_INLIER_FRAMES = 30
AMBIGUOUS_RATIO = 0.5
ALONG_RAY = 0.15
# The refinement regrows its frame set to tracked frames within GATE_EPS x eps_px
# of the fitted projection: a tight gate keeps only frames whose calibration
# error happens to agree with a biased line (eps_t x3 at S_c = 8 px).
GATE_EPS = 10.0
SUPPORT_KEPT = 0.5


@dataclass(frozen=True)
class CameraInput:
    """What one camera brings: its calibration, its track and its frame rate (or None).

    detections: every mover of its video instead of a track (track None):
    the target is identified among them first (identify.py).
    """

    camera: Camera
    track: Track | None
    fps: float | None
    detections: Detections | None = None


@dataclass(frozen=True)
class CameraResult:
    """One camera's votes, fitted line and summary.

    fit: the paper's RANSAC fit (method "paper") or None; search and
    refinement: the refined method's pieces (refinement None on fallback).
    """

    votes: Votes
    fit: LineFit | None
    line: CameraLine
    search: LineSearch | None = None
    refinement: Refinement | None = None
    identification: Identification | None = None


def synchronize_camera(name: str, inputs: CameraInput, trajectory: Trajectory, params: SyncParams, logged: Trajectory | None = None) -> CameraResult:
    """Votes and the fitted line of one camera; SyncError if it cannot be synchronized.

    A camera with detections instead of a track is first identified (on the
    ``logged`` trajectory, before any smoothing: the assignment gate is a
    few pixels and smoothing rounds a walker's turns); its line is then
    fitted on the identified target's track, and the line's details carry
    the identification summary.
    """
    if inputs.track is None:
        found = identify_target(
            inputs.camera, inputs.detections, logged if logged is not None else trajectory, inputs.fps, params.eps_px, params.delta, params.p, params.r_min, params.seed, params.f_scale_px
        )
        result = synchronize_camera(name, replace(inputs, track=found.track, detections=None), trajectory, params)
        details = {**result.line.details, "identification": found.summary()}
        return replace(result, line=replace(result.line, details=details), identification=found)
    votes = compute_votes(inputs.camera, inputs.track, trajectory, params.eps_px)
    if params.method == "refined":
        return _synchronize_refined(name, inputs, trajectory, params, votes)
    try:
        fit = fit_line_ransac(votes.sample, votes.frame, params.delta, params.p, params.r, params.seed)
    except ValueError as exc:
        raise SyncError(f"camera {name}: {exc} ({len(votes)} votes)") from None
    line = CameraLine(name, fit.alpha, fit.beta, len(votes), fit.n_inliers, fit.residual_rms, inputs.fps)
    return CameraResult(votes, fit, line)


def _synchronize_refined(name: str, inputs: CameraInput, trajectory: Trajectory, params: SyncParams, votes: Votes) -> CameraResult:
    track = inputs.track
    clock = camera_clock(track, inputs.fps)
    # Votes carry frame indices; the line lives on the camera clock (frames, or time x fps for VFR).
    vote_clock = clock.frames[np.searchsorted(track.frame, votes.frame.astype(np.int64))]
    try:
        search = find_line(votes.sample, vote_clock, votes.dist, params.delta, params.p, params.r_min, params.seed)
    except ValueError as exc:
        raise SyncError(f"camera {name}: {exc} ({len(votes)} votes)") from None
    start = np.zeros(len(track), dtype=bool)
    start[np.searchsorted(track.frame, votes.frame[search.inliers].astype(np.int64))] = True
    flags, warnings = [], []
    refinement = None
    try:
        refinement = refine_line(
            inputs.camera, clock.frames, track.xy, PiecewiseTrajectory(trajectory), search.alpha, search.beta, start, params.f_scale_px, GATE_EPS * params.eps_px, params.model_error_px
        )
    except ValueError as exc:
        warnings.append(f"refinement not possible ({exc}); using the line-search line")
    if refinement is not None:
        reason = _disagreement(refinement, search, votes, vote_clock, params.delta)
        if not refinement.converged:
            reason = f"refinement did not converge ({refinement.message})"
        if reason:
            warnings.append(f"{reason}; using the line-search line")
    fallback = bool(warnings)
    if fallback:
        alpha, beta = search.alpha, search.beta
        cov = _line_search_cov(search, votes.sample[search.inliers])
    else:
        alpha, beta, cov = refinement.alpha, refinement.beta, refinement.cov
    if search.support < FEW_INLIER_FRAMES:
        flags.append("few_inliers")
    if search.runner_up >= AMBIGUOUS_RATIO * search.support:
        flags.append("ambiguous")
    if refinement is not None and refinement.perpendicular < ALONG_RAY:
        flags.append("along_ray")
    details = {
        "se_alpha": float(np.sqrt(cov[0, 0])),
        "se_beta": float(np.sqrt(cov[1, 1])),
        "cov": cov.tolist(),
        "flags": flags,
        "warnings": warnings,
        "refined": not fallback,
        "line_search": {
            "alpha": search.alpha,
            "beta": search.beta,
            "support_frames": search.support,
            "runner_up_frames": search.runner_up,
            "thinned_votes": search.thinned,
            "hypotheses": search.hypotheses,
        },
    }
    if refinement is not None:
        details["refinement"] = {
            "frames_used": refinement.frames_used,
            "scale_px": refinement.scale_px,
            "perpendicular": refinement.perpendicular,
            "converged": refinement.converged,
        }
    details.update(clock.details())
    fps = clock.fps if clock.fps is not None else inputs.fps
    line = CameraLine(name, alpha, beta, len(votes), search.n_inliers, search.residual_rms, fps, details)
    return CameraResult(votes, None, line, search, refinement)


def _disagreement(refinement: Refinement, search: LineSearch, votes: Votes, clock: np.ndarray, delta: float) -> str:
    """Why the refined line cannot be trusted over the line-search one, or ''.

    The refined line must keep at least SUPPORT_KEPT of the distinct frames
    whose votes lie within 4 delta of the line-search line: a refinement
    that slid to another pass of the path loses them. (Comparing the lines'
    ends against the refinement's standard error rejected good refinements
    when the line search's few inliers left its slope loose.)
    """

    def near(alpha: float, beta: float) -> int:
        return np.unique(votes.frame[distance_to_line(votes.sample, clock, alpha, beta) <= 4 * delta]).size

    before, after = near(search.alpha, search.beta), near(refinement.alpha, refinement.beta)
    if after < SUPPORT_KEPT * before:
        return f"refined line keeps {after} of the {before} frames whose votes support the line search"
    return ""


def _line_search_cov(search: LineSearch, inlier_samples: np.ndarray) -> np.ndarray:
    """Covariance of the line-search line: least squares with the inliers' residual spread.

    Conservative floor: residuals of at least delta / sqrt(3) (uniform within the band).
    """
    if len(inlier_samples) < 3:
        return np.full((2, 2), np.inf)
    design = np.column_stack([inlier_samples, np.ones(len(inlier_samples))])
    sigma2 = max(search.residual_rms**2, 0.5**2 / 3)
    try:
        return sigma2 * np.linalg.inv(design.T @ design)
    except np.linalg.LinAlgError:
        return np.full((2, 2), np.inf)


def synchronize(cameras: dict[str, CameraInput], trajectory: Trajectory, params: SyncParams) -> tuple[Timeline, dict[str, CameraResult]]:
    """The timeline of all cameras that can be synchronized.

    Cameras that cannot are listed in ``Timeline.failed`` with the reason.
    """
    results: dict[str, CameraResult] = {}
    failed: dict[str, str] = {}
    logged = trajectory
    if params.method == "refined" and params.smooth_trajectory:
        trajectory = smooth_trajectory(trajectory)
    for name, inputs in cameras.items():
        try:
            results[name] = synchronize_camera(name, inputs, trajectory, params, logged)
        except SyncError as exc:
            failed[name] = str(exc)
    timeline = Timeline(
        {name: r.line for name, r in results.items()},
        trajectory.rate,
        trajectory.t0,
        method=params.method,
        params=asdict(params),
        failed=failed,
    )
    return timeline, results
