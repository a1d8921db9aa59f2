"""The "refined" sync method (default): robust line search, then continuous-time refinement.

The trajectory is first smoothed (cross-validated smoothing spline,
refine.smooth_trajectory); the line search (line_search.py) finds the line
in the voting space; the refinement (refine.py) re-estimates it from the
tracked positions with its uncertainty. When the refinement fails or
disagrees with the votes the line-search line is kept, with a warning.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from tlsync_pipeline.errors import SyncError
from tlsync_pipeline.sync.identify.refine import Refinement, refine_line, sigma_weights
from tlsync_pipeline.sync.kernels.line_search import LineSearch, find_line
from tlsync_pipeline.sync.kernels.ransac import distance_to_line
from tlsync_pipeline.sync.kernels.slope import SlopePrior, slope_prior
from tlsync_pipeline.sync.model.clock import image_speed
from tlsync_pipeline.sync.model.log_model import LogModel
from tlsync_pipeline.sync.model.methods import RefinedKind, RefinedParams
from tlsync_pipeline.sync.model.params import SyncParams
from tlsync_pipeline.sync.solve.log_bias import (
    BiasCamera,
    LogBias,
    fit_log_bias,
    fit_log_bias_measured,
    fit_white_log,
    shared_fixes,
    white_knots,
    with_common_shift,
)
from tlsync_pipeline.sync.solve.methods import CameraData
from tlsync_pipeline.sync.solve.slow_motion import BiasSpread, bias_time_spread
from tlsync_pipeline.sync.timeline import CameraLine, ErrorBudget, LineSearchSummary, LogBiasSummary, RefinementSummary
from tlsync_pipeline.trajectory import PiecewiseTrajectory, Trajectory

# Weak-case thresholds (flags in timeline.json).
FEW_INLIER_FRAMES = 30
ALONG_RAY = 0.15
# The refinement regrows its frame set to tracked frames within GATE_EPS x eps_px
# of the fitted projection: a tight gate keeps only frames whose calibration
# error happens to agree with a biased line (eps_t x3 at S_c = 8 px).
GATE_EPS = 10.0
SUPPORT_KEPT = 0.5
MIN_SPEED_FRAMES = 10  # consecutive tracked frames needed to measure the target's image speed
MAX_APART_FRAMES = 300.0  # a rival line is never required to be farther than this (frames)


class RefinedMethod(RefinedKind):
    """Line search over the votes, refinement on the tracked positions, fallback with a warning (name, parameters,
    smoothing: RefinedKind)."""

    def fit(self, data: CameraData, trajectory: Trajectory, params: SyncParams, options: RefinedParams) -> CameraLine:
        votes, track = data.votes, data.track
        prior = slope_prior(data.fps, trajectory.rate, params.rate_sigma)
        try:
            search = find_line(
                votes.sample,
                data.vote_clock,
                votes.dist,
                params.delta,
                params.p,
                options.r_min,
                params.seed,
                prior=prior,
                apart=_radius_frames(data),
            )
        except ValueError as exc:
            raise SyncError(f"camera {data.name}: {exc} ({len(votes)} votes)") from None
        start = np.zeros(len(track), dtype=bool)
        start[np.searchsorted(track.frame, votes.frame[search.inliers].astype(np.int64))] = True
        flags, warnings = [], []
        refinement = None
        try:
            refinement = _refine(
                data, PiecewiseTrajectory(trajectory), search.alpha, search.beta, start, options, prior
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
        budget = None
        if fallback or refinement is None:
            alpha, beta = search.alpha, search.beta
            cov = _line_search_cov(search, votes.sample[search.inliers])
            if refinement is not None:  # the two fits disagree: either may be right, the interval spans both
                gap = np.array([refinement.alpha - search.alpha, refinement.beta - search.beta])
                cov = cov + np.outer(gap, gap)
        else:
            alpha, beta, cov = refinement.alpha, refinement.beta, refinement.cov
            budget = error_budget(refinement, data.track_clock, np.zeros((2, 2)))
        if search.support < FEW_INLIER_FRAMES:
            flags.append("few_inliers")
        if refinement is not None and refinement.perpendicular < ALONG_RAY:
            flags.append("along_ray")
        rival = search.rival or (None, None)
        summary = LineSearchSummary(
            search.alpha, search.beta, search.support, search.runner_up, search.thinned, search.hypotheses, *rival
        )
        refinement_summary = None
        if refinement is not None:
            refinement_summary = RefinementSummary(
                refinement.frames_used, refinement.scale_px, refinement.perpendicular, refinement.converged
            )
        on_line = int(
            (distance_to_line(votes.sample, data.vote_clock, alpha, beta) <= params.delta).sum()
        )  # as the voting chart counts them
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
            budget=budget,
        )

    def refine_with_log_bias(
        self,
        cameras: dict[str, CameraData],
        lines: dict[str, CameraLine],
        trajectory: Trajectory,
        params: SyncParams,
        options: RefinedParams,
        model: LogModel,
    ) -> tuple[dict[str, CameraLine], LogBias | None]:
        """Every camera's line refined together with the log's bias (sync/solve/log_bias.py), their intervals including
        it.

        Under a log without a bias, or one whose bias the cameras' pixels
        measure below its white noise (fit_log_bias_measured), cameras that
        see the target at the same time are fitted with the log's white error
        at each fix instead (_white_shared, fit_white_log); without such
        cameras, under a log without a bias, the lines stay as they are.

        Cameras whose own refinement was not kept (a fallback) keep their line.
        A camera whose refinement on the corrected log loses its frames or
        does not converge (the estimate made its line slide) leaves the joint
        fit, which is redone with the others; it keeps its own line, its
        interval grown by the bias at its prior. When no camera's line
        survives, the lines stay as they were and the bias is at its prior.
        """
        path = PiecewiseTrajectory(trajectory)
        shared = _white_shared(cameras, lines, path, model)
        white = not model.has_bias
        if white and not shared:
            return lines, None
        own: dict[str, Refinement] = {}
        for name, line in lines.items():
            if line.refined:
                data = cameras[name]
                try:
                    start = _near_line(data, path, line.alpha, line.beta, GATE_EPS * data.eps_px)
                    own[name] = _refine(
                        data,
                        path,
                        line.alpha,
                        line.beta,
                        start,
                        options,
                        slope_prior(data.fps, trajectory.rate, params.rate_sigma),
                    )
                except ValueError:
                    continue
        if not own or trajectory.rate is None:
            return lines, None
        rate = trajectory.rate
        joint = {
            n: _bias_camera(
                cameras[n], path, r, options.f_scale_px, slope_prior(cameras[n].fps, rate, params.rate_sigma)
            )
            for n, r in own.items()
        }
        first = None  # the bias's fit on every camera, when it was made to decide
        if shared and not white:
            first = fit_log_bias_measured(list(joint.values()), path, rate, model, options.f_scale_px)
            below = first.model.bias_m < first.model.white_m  # the pixels measured a bias below the white noise
            if below and white_knots(list(joint.values()), path) is not None:
                white, model, first = True, replace(first.model, bias_m=0.0, bias_vertical_m=0.0), None

        def fitted(names: list[str], estimate: bool = True) -> LogBias | None:
            chosen = [joint[n] for n in names]
            if white:
                return fit_white_log(chosen, path, rate, model, options.f_scale_px, estimate)
            if estimate:
                return fit_log_bias_measured(chosen, path, rate, model, options.f_scale_px)
            return fit_log_bias(chosen, path, rate, bias.model, options.f_scale_px, estimate=False)

        kept, again = list(own), {}
        while kept:
            found, first = (fitted(kept) if first is None else first), None
            if found is None:
                return lines, None
            bias = found
            again = (
                _refit_on_corrected(cameras, {n: own[n] for n in kept}, bias, trajectory, params, options, white)
                if bias.converged
                else {}
            )
            if len(again) == len(kept):
                break
            kept = list(again)
        at_prior = bias if len(again) == len(own) else fitted(list(joint), estimate=False)
        if at_prior is None:
            return lines, None
        if white:
            shift = _own_time_sd(cameras, own, rate)
            bias, at_prior = with_common_shift(bias, rate, shift), with_common_shift(at_prior, rate, shift)
        if not again:
            bias = replace(at_prior, estimate=bias.estimate)
        out = dict(lines)
        for name, r in own.items():
            fit, source = (again[name], bias) if name in again else (r, at_prior)
            middle = _visit_middle(cameras[name].track_clock[fit.used], fit.alpha, fit.beta)
            estimate, se = source.at(np.array([middle]))[0], source.std_at(middle)
            spread = _spread(cameras[name], path, fit, se)
            log_cov = _with_spread(source.line_cov(name, name), middle, spread)
            out[name] = replace(
                lines[name],
                alpha=fit.alpha,
                beta=fit.beta,
                cov=fit.cov + log_cov + (_pose_cov(cameras[name], path, fit) if white else 0.0),
                budget=error_budget(fit, cameras[name].track_clock, log_cov),
                log_bias=LogBiasSummary(
                    tuple(map(float, estimate)),  # type: ignore[arg-type]
                    tuple(map(float, se)),  # type: ignore[arg-type]
                    source.observability(middle),
                    None if spread is None else spread.speed_m_s,
                    None if spread is None else spread.frames,
                ),
            )
        return out, bias


MATERIAL = 0.5  # the log's part of a line's std, over the rest's, from which the log's white noise is fitted
MIN_SHARED_FIXES = 3  # fix intervals in a row in which two cameras see the target: their white error fitted


def _white_shared(
    cameras: dict[str, CameraData], lines: dict[str, CameraLine], path: PiecewiseTrajectory, model: LogModel
) -> bool:
    """Whether the log's white noise is fitted with the lines (fit_white_log): the log has white noise, and for at
    least MIN_SHARED_FIXES intervals between its fixes in a row two or more cameras see the target, on whose line the
    log's noise weighs (_log_material) at least twice as much as their pose's uncertainty (_pose_frames): the fit
    takes out the log's error the cameras share, not their poses' (on the shared-view crowd with GCPs declared exact,
    poses 0.1-0.4 m off, fitted anyway: 4 of 6 seeds worse)."""
    if model.white_m <= 0:
        return False
    visits = [
        (cameras[n].track_clock - line.beta) / line.alpha
        for n, line in lines.items()
        if line.refined
        and line.budget is not None
        and _log_material(line.budget)
        and _pose_frames(cameras[n], path, line.alpha, line.beta) <= MATERIAL * line.budget.log_frames
    ]
    return len(visits) >= 2 and shared_fixes(visits, path) >= MIN_SHARED_FIXES


def _pose_cov(data: CameraData, path: PiecewiseTrajectory, fit: Refinement) -> np.ndarray:
    """A surveyed pose's uncertainty as its camera's beta variance (_pose_frames on the frames its refinement used): a
    pose error moves a camera's view of the path as a time shift the residuals cannot show; the fit of the log's white
    error takes out what the cameras share, which leaves each pose's own error in the pair."""
    out = np.zeros((2, 2))
    out[1, 1] = _pose_frames(data, path, fit.alpha, fit.beta, fit.used) ** 2
    return out


def _pose_frames(
    data: CameraData, path: PiecewiseTrajectory, alpha: float, beta: float, used: np.ndarray | None = None
) -> float:
    """The std (frames) of a camera's clock that its pose's stds (camera.json) explain: the pixels the target's
    projection moves by (focal length x the larger of the rotation's std and the centre's over the target's median
    depth: a survey's centre and rotation errors trade against each other on the ground it was surveyed on) over the
    target's median image speed, on its tracked frames (``used``: those, None: all) under the line; 0 for a pose
    without stds."""
    info = data.camera.pose_info
    if info is None or info.center_std_m is None or info.rotation_std_deg is None:
        return 0.0
    used = np.ones(len(data.track_clock), bool) if used is None else used
    clock = data.track_clock[used]
    s = (clock - beta) / alpha
    run = path.run_of(s)
    speed = image_speed(clock, data.track.xy[used], quantile=0.5)
    if speed is None or not (run >= 0).any():
        return 0.0
    depth = float(np.median(np.linalg.norm(path(s[run >= 0], run[run >= 0]) - data.camera.center, axis=1)))
    pixels = float(data.camera.K[0, 0]) * max(math.radians(info.rotation_std_deg), info.center_std_m / depth)
    return pixels / speed


def _log_material(budget: ErrorBudget) -> bool:
    """Whether the log's part of a line's clock std is at least MATERIAL of the rest's (tracking and calibration)."""
    return budget.log_frames >= MATERIAL * math.hypot(budget.tracking_frames, budget.calibration_frames)


def _own_time_sd(cameras: dict[str, CameraData], own: dict[str, Refinement], rate: float) -> float:
    """The least std (seconds of the log) of a camera's own clock at the middle of its visit, as its refinement on the
    log as logged gives it: what the cameras together know of the log's own time when the fit of the log's white
    error tells them apart (a fix's error along the path is a time shift every camera that leans on it shares)."""
    sds = []
    for name, r in own.items():
        middle = _visit_middle(cameras[name].track_clock[r.used], r.alpha, r.beta)
        g = np.array([middle, 1.0])
        sds.append(float(np.sqrt(max(g @ r.cov @ g, 0.0))) / (r.alpha * rate))
    return min(sds)


def _spread(data: CameraData, path: PiecewiseTrajectory, fit: Refinement, bias_sd_m: np.ndarray) -> BiasSpread | None:
    """The clock spread a bias of ``bias_sd_m`` explains at the target's speed on the frames the camera's line used
    (sync/solve/slow_motion.py); None without a frame rate or enough moving frames."""
    if data.fps is None:
        return None
    used = fit.used
    return bias_time_spread(
        data.camera, data.track_clock[used], data.track.xy[used], path, fit.alpha, fit.beta, bias_sd_m, data.fps
    )


def _with_spread(log_cov: np.ndarray, middle: float, spread: BiasSpread | None) -> np.ndarray:
    """The log's part of a line's (alpha, beta) covariance, its clock std at the visit's middle sample raised to the
    spread the bias explains at the target's own speed where the joint fit's linearisation (the log's speed under the
    line) says less: a shift of the whole clock, beta alone."""
    if spread is None:
        return log_cov
    at = np.array([middle, 1.0])
    missing = spread.frames**2 - float(at @ log_cov @ at)
    if not missing > 0:
        return log_cov
    return log_cov + np.array([[0.0, 0.0], [0.0, missing]])


def _refit_on_corrected(
    cameras: dict[str, CameraData],
    own: dict[str, Refinement],
    bias: LogBias,
    trajectory: Trajectory,
    params: SyncParams,
    options: RefinedParams,
    white: bool = False,
) -> dict[str, Refinement]:
    """Each camera's refinement on the log corrected by the bias, from its joint line: the cameras whose refit converged
    and kept at least SUPPORT_KEPT of its frames. ``white``: the bias is the log's white error at each fix
    (fit_white_log), which the correction removes: the corrected log has no sigmas left to weigh the frames by (what
    it leaves uncertain is the bias's posterior, LogBias.line_cov)."""
    corrected = PiecewiseTrajectory(
        _corrected_at_knots(trajectory, bias)
        if white
        else replace(trajectory, xyz=trajectory.xyz + bias.at(trajectory.sample))
    )
    out = {}
    for name, r in own.items():
        data = cameras[name]
        try:
            refit = _refine(
                data,
                corrected,
                *bias.lines[name],
                r.used,
                options,
                slope_prior(data.fps, trajectory.rate, params.rate_sigma),
            )
        except ValueError:
            continue
        if refit.converged and refit.frames_used >= SUPPORT_KEPT * r.frames_used:
            out[name] = refit
    return out


def _corrected_at_knots(trajectory: Trajectory, bias: LogBias) -> Trajectory:
    """The log corrected by the bias at its samples and at the knots between them (the bias is linear between knots:
    a knot between two fixes bends the path there), without sigmas: the knots took the log's white error."""
    path = PiecewiseTrajectory(trajectory)
    run = path.run_of(bias.knots)
    between = ~np.isin(bias.knots, trajectory.sample) & (run >= 0)
    sample = np.r_[trajectory.sample, bias.knots[between]]
    xyz = np.vstack([trajectory.xyz, path(bias.knots[between], run[between])])
    order = np.argsort(sample)
    return replace(trajectory, sample=sample[order], xyz=xyz[order] + bias.at(sample[order]), sigma=None)


def _refine(
    data: CameraData,
    path: PiecewiseTrajectory,
    alpha: float,
    beta: float,
    start: np.ndarray,
    options: RefinedParams,
    prior: SlopePrior | None,
) -> Refinement:
    """The camera's refinement from a line and the frames it starts from (refine.refine_line with the method's
    settings).
    """
    track = data.track
    box = None if track.w is None or track.h is None else np.column_stack([track.w, track.h])
    return refine_line(
        data.camera,
        data.track_clock,
        track.xy,
        path,
        alpha,
        beta,
        start,
        options.f_scale_px,
        GATE_EPS * data.eps_px,
        options.model_error_px,
        prior,
        box,
    )


def _radius_frames(data: CameraData) -> float:
    """How many frames the vote radius spans along the target's image path (median image speed over consecutive tracked
    frames): a line within that of the best is the same answer seen through a wide radius, not a rival."""
    track = data.track
    step = np.diff(track.frame)
    moved = np.linalg.norm(np.diff(track.xy, axis=0), axis=1)
    consecutive = step == 1
    if consecutive.sum() < MIN_SPEED_FRAMES:
        return 0.0
    speed = float(np.median(moved[consecutive]))
    return float(min(data.eps_px / max(speed, 1e-6), MAX_APART_FRAMES))


def _near_line(data: CameraData, path: PiecewiseTrajectory, alpha: float, beta: float, gate_px: float) -> np.ndarray:
    """Which tracked frames lie within gate_px of the path projected under the line."""
    s = (data.track_clock - beta) / alpha
    run = path.run_of(s)
    on = np.flatnonzero(run >= 0)
    uv, valid = data.camera.project(path(s[on], run[on]))
    near = np.zeros(len(s), bool)
    near[on[valid]] = np.linalg.norm(uv[valid] - data.track.xy[on[valid]], axis=1) <= gate_px
    return near


def _visit_middle(clock: np.ndarray, alpha: float, beta: float) -> float:
    """The sample at the middle clock value of the frames used."""
    return (float(np.median(clock)) - beta) / alpha


def error_budget(refinement: Refinement, clock: np.ndarray, log_cov: np.ndarray) -> ErrorBudget:
    """Tracking, calibration and log parts of a camera's clock uncertainty (std, frames) at the middle of the frames the
    refinement used.

    log_cov: the part of the (alpha, beta) covariance the log's bias adds (zeros without a bias model); the log's
    part also holds its white noise averaged over the fixes (Refinement.cov_log_white).
    """
    middle = _visit_middle(clock[refinement.used], refinement.alpha, refinement.beta)
    g = np.array([middle, 1.0])

    def std(cov: np.ndarray) -> float:
        return float(np.sqrt(max(g @ cov @ g, 0.0)))

    statistical = refinement.cov - refinement.cov_model - refinement.cov_log_white
    return ErrorBudget(std(statistical), std(refinement.cov_model), std(log_cov + refinement.cov_log_white))


def _bias_camera(
    data: CameraData, path: PiecewiseTrajectory, refinement: Refinement, f_scale: float, prior: SlopePrior | None
) -> BiasCamera:
    """The frames a camera's refinement used, as the joint fit with the log's bias takes them."""
    clock, xy = data.track_clock[refinement.used], data.track.xy[refinement.used]
    s = (clock - refinement.beta) / refinement.alpha
    run = path.run_of(s)
    weight = np.ones(len(s))
    on = run >= 0
    weight[on] = sigma_weights(data.camera, path, s[on], run[on], f_scale)
    return BiasCamera(
        data.name,
        data.camera,
        clock,
        xy,
        weight,
        refinement.alpha,
        refinement.beta,
        refinement.cov_joint,
        prior,
        refinement.cov,
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
