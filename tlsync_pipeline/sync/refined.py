"""The "refined" sync method (default): robust line search, then continuous-time refinement.

The trajectory is first smoothed (cross-validated smoothing spline,
refine.smooth_trajectory); the line search (line_search.py) finds the line
in the voting space; the refinement (refine.py) re-estimates it from the
tracked positions with its uncertainty. When the refinement fails or
disagrees with the votes the line-search line is kept, with a warning.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tlsync_pipeline.errors import SyncError
from tlsync_pipeline.sync.line_search import LineSearch, find_line
from tlsync_pipeline.sync.methods import CameraData
from tlsync_pipeline.sync.params import SyncParams, param
from tlsync_pipeline.sync.ransac import distance_to_line
from tlsync_pipeline.sync.refine import Refinement, refine_line, smooth_trajectory
from tlsync_pipeline.sync.slope import slope_prior
from tlsync_pipeline.sync.timeline import CameraLine, LineSearchSummary, RefinementSummary
from tlsync_pipeline.trajectory import PiecewiseTrajectory, Trajectory

# Weak-case thresholds (flags in timeline.json).
FEW_INLIER_FRAMES = 30
ALONG_RAY = 0.15
# The refinement regrows its frame set to tracked frames within GATE_EPS x eps_px
# of the fitted projection: a tight gate keeps only frames whose calibration
# error happens to agree with a biased line (eps_t x3 at S_c = 8 px).
GATE_EPS = 10.0
SUPPORT_KEPT = 0.5


@dataclass(frozen=True)
class RefinedParams:
    """r_min: smallest inlier ratio the line search must find; f_scale_px: robust loss
    scale of the refinement (pixels); smooth_trajectory: smooth the logged trajectory
    first; model_error_px: pixel error of the calibration and log that the
    intervals allow for."""

    r_min: float = param(0.01, "ratio")
    f_scale_px: float = param(3.0, "positive")
    smooth_trajectory: bool = param(True, "boolean")
    model_error_px: float = param(3.0, "non_negative")


@dataclass(frozen=True)
class Smoothing:
    """The refined method's trajectory preparation: smooth the logged trajectory or not (RefinedParams.smooth_trajectory)."""

    smooth_trajectory: bool


class RefinedMethod:
    """Line search over the votes, refinement on the tracked positions, fallback with a warning."""

    name = "refined"
    params_type = RefinedParams

    def preparation(self, options: RefinedParams) -> Smoothing:
        return Smoothing(options.smooth_trajectory)

    def prepare_trajectory(self, trajectory: Trajectory, preparation: Smoothing) -> Trajectory:
        """The trajectory smoothed run by run (unless smooth_trajectory is off)."""
        return smooth_trajectory(trajectory) if preparation.smooth_trajectory else trajectory

    def fit(self, data: CameraData, trajectory: Trajectory, params: SyncParams, options: RefinedParams) -> CameraLine:
        votes, track = data.votes, data.track
        prior = slope_prior(data.fps, trajectory.rate, params.rate_sigma)
        try:
            search = find_line(votes.sample, data.vote_clock, votes.dist, params.delta, params.p, options.r_min, params.seed, prior=prior)
        except ValueError as exc:
            raise SyncError(f"camera {data.name}: {exc} ({len(votes)} votes)") from None
        start = np.zeros(len(track), dtype=bool)
        start[np.searchsorted(track.frame, votes.frame[search.inliers].astype(np.int64))] = True
        flags, warnings = [], []
        refinement = None
        try:
            refinement = refine_line(
                data.camera,
                data.track_clock,
                track.xy,
                PiecewiseTrajectory(trajectory),
                search.alpha,
                search.beta,
                start,
                options.f_scale_px,
                GATE_EPS * params.eps_px,
                options.model_error_px,
                prior,
                None if track.w is None or track.h is None else np.column_stack([track.w, track.h]),
            )
        except ValueError as exc:
            warnings.append(f"refinement not possible ({exc}); using the line-search line")
        if refinement is not None:
            reason = _disagreement(refinement, search, data, params.delta)
            if not refinement.converged:
                reason = f"refinement did not converge ({refinement.message})"
            if reason:
                warnings.append(f"{reason}; using the line-search line")
        fallback = bool(warnings)
        if fallback or refinement is None:
            alpha, beta = search.alpha, search.beta
            cov = _line_search_cov(search, votes.sample[search.inliers])
        else:
            alpha, beta, cov = refinement.alpha, refinement.beta, refinement.cov
        if search.support < FEW_INLIER_FRAMES:
            flags.append("few_inliers")
        if refinement is not None and refinement.perpendicular < ALONG_RAY:
            flags.append("along_ray")
        rival = search.rival or (None, None)
        summary = LineSearchSummary(search.alpha, search.beta, search.support, search.runner_up, search.thinned, search.hypotheses, *rival)
        refinement_summary = None
        if refinement is not None:
            refinement_summary = RefinementSummary(refinement.frames_used, refinement.scale_px, refinement.perpendicular, refinement.converged)
        on_line = int((distance_to_line(votes.sample, data.vote_clock, alpha, beta) <= params.delta).sum())  # as the voting chart counts them
        return data.line(
            alpha,
            beta,
            on_line,
            search.residual_rms,
            cov=cov,
            flags=tuple(flags),
            warnings=tuple(warnings),
            refined=not fallback,
            line_search=summary,
            refinement=refinement_summary,
        )


def _disagreement(refinement: Refinement, search: LineSearch, data: CameraData, delta: float) -> str:
    """Why the refined line cannot be trusted over the line-search one, or ''.

    The refined line must keep at least SUPPORT_KEPT of the distinct frames
    whose votes lie within 4 delta of the line-search line: a refinement
    that slid to another pass of the path loses them. (Comparing the lines'
    ends against the refinement's standard error rejected good refinements
    when the line search's few inliers left its slope loose.)
    """
    votes = data.votes

    def near(alpha: float, beta: float) -> int:
        return np.unique(votes.frame[distance_to_line(votes.sample, data.vote_clock, alpha, beta) <= 4 * delta]).size

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
