"""A camera's pose from the target itself: no survey needed, and GCPs that are only roughly right still serve.

The target gives thousands of (pixel, 3D position) pairs, known up to the
camera's line clock = alpha * sample + beta that is being estimated. With
alpha held by the clock prior (sync/kernels/slope.py: the camera's fps over the log's
rate), only beta is unknown:

1. search over beta (``search_offsets``): for each candidate beta, each of
   SEARCH_POINTS tracked positions (spread over the track) is paired with
   the trajectory at its sample, and a pose is fitted to the pairs
   (OpenCV's SQPnP on distortion-free pixels, then twice again on the
   better half of the pairs, which is robust to a share of wrong
   positions); the candidate's support is the pairs the pose explains
   within the threshold. Under a log with a bias the pose and the log's
   bias over the visit are fitted together instead (sync/pose/pose_bias.py),
   and the support is what they explain less what the bias's prior costs.
   A coarse pass (3 x the threshold, steps of half
   the threshold over the track's image speed) and a fine pass around its
   best peaks;
2. the best CANDIDATES peaks of distinct offsets are fitted: pose, line
   (and the free intrinsics) jointly on every tracked position, with the
   GCPs as a prior (sync/pose/pose_fit.py); with GCPs, the pose the GCPs alone
   give and the line the votes find under it are one more candidate;
3. the fit with the most frames within the gate wins; the best fit at an
   offset more than DISTINCT_S away is the runner-up (its support is kept,
   as the line search keeps its runner-up's); under a log with a bias, a
   fit is distinct when it is not one timing with the winner (beyond the
   betas' stds and what the log's bias explains along the path), the
   runner-up is the distinct fit the track's evidence makes most probable,
   and the fits of one timing widen the line's interval
   (sync/pose/timing.py); an offset the search scores alike with its top
   that no fit is one timing with is then fitted too (``fitted_untested``):
   an offset no pose was fitted at would be a rival never weighed, and most
   such offsets are the best's timing seen through the coarse pass (their
   fit converges there) or poses the track's blocks rule out; with GCPs, only fits that
   keep the GCPs within GCP_AGREE of their sigmas count (a straight path
   explains the track from many poses, the GCPs tell them apart);
4. degenerate cases fail with a named cause and a remedy (``PoseError``),
   never with a confident wrong pose: too few frames, a path that is nearly
   a straight line in the image (the pose turns freely about it), two
   offsets with comparable support (under a log with a bias: a rival
   keeping RIVAL_PROBABILITY of the evidence), or a pose whose uncertainty
   is too large (under a log with a bias on a curved path only the
   timing must be determined). With GCPs the straightness and ambiguity tests are left to the
   uncertainty: the GCPs hold the pose where the path alone cannot;
5. with GCPs and their own pose (``_survey_and_target``) the evidence
   decides: the survey's error is measured from the GCPs' residuals under
   their own pose and under the track's (``measured_gcps``), GCPs the
   track's pose puts far off are named and left out, and the GCPs count as
   much against the track as the track's shared errors warrant. The joint
   pose wins when it keeps the GCPs and explains the track nearly as well
   as the track's own pose; otherwise the track's own pose is used (the
   GCPs that disagree named), and only when the track alone does not
   determine it either does the camera fail (gcp_conflict).

Without K (a camera.json with the image size only) the search fits a
projection matrix (DLT, normalised) instead of a pose, and the joint fit
frees the focal length, principal point and k1 with weak priors: what the
target determines (posterior std under half the prior's) is kept, the rest
is held. A target moving in a plane (a walker on flat ground) does not
determine the focal length: the search's DLT is degenerate there and the
camera fails with the cause ``planar_path``.

Clock values are the camera clock in frame units (sync/model/clock.py); pixels
as tracked (distorted); world metres.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import partial

import numpy as np
from scipy.optimize import minimize_scalar
from scipy.spatial import cKDTree

from calibration.camera import Camera, PoseInfo
from calibration.errors import CalibrationInputError
from calibration.extrinsics import Pose, pose_from_points
from calibration.lens import undistort_pixels
from tlsync_pipeline.errors import SyncError
from tlsync_pipeline.sync.identify.identify import (
    Identification,
    IdentifyParams,
    detections_clock,
    identify_target,
)
from tlsync_pipeline.sync.kernels.line_search import find_line
from tlsync_pipeline.sync.kernels.robust import msac, polish, trimmed
from tlsync_pipeline.sync.kernels.slope import SlopePrior, slope_prior
from tlsync_pipeline.sync.model.clock import FrameTimes, camera_clock, image_speed
from tlsync_pipeline.sync.model.log_model import PRIOR_LOG_SD, LogModel
from tlsync_pipeline.sync.pose.pose_bias import CUT, VisitBias, fit_with_bias
from tlsync_pipeline.sync.pose.pose_fit import (
    INTRINSICS,
    MODEL_ERROR_PX,
    GcpPrior,
    JointFit,
    fit_pose_and_line,
    reprojection_errors,
)
from tlsync_pipeline.sync.pose.pose_timing import PoseTiming
from tlsync_pipeline.sync.pose.timing import (
    DISTINCT_S,
    bias_frames,
    one_timing,
    rival_probability,
    timing_spread,
    untested_offsets,
)
from tlsync_pipeline.sync.pose.upright import is_upright, roll_deg
from tlsync_pipeline.trajectory import PiecewiseTrajectory, Trajectory
from trackers.detections import Detections
from trackers.track import Track

SEARCH_POINTS = 200  # tracked positions paired with the trajectory per candidate offset
COARSE = 3.0  # the coarse pass's threshold and step, in units of the fine pass's
FINE_PEAKS = 8  # coarse peaks searched finely
CANDIDATES = 6  # fine peaks fitted jointly
MIN_PAIRS = 12  # pairs on the trajectory a candidate offset needs
MIN_FRAMES = 20  # frames a pose from the target needs within the gate
STRAIGHT = 0.02  # smallest ratio of the image path's second to first singular value (below: a straight line)
NEARLY_STRAIGHT = 0.05  # a loose pose on a path below this ratio is put down to its straightness
# a distinct offset scoring this share of the best's score (msac at TIGHT median residuals) makes the pose ambiguous
AMBIGUOUS = 0.85
TIGHT = 3.0  # median residuals of the best fit within which frames count for the ambiguity test
LOG_GATE = 2.5  # under a metre-level log, the gate in units of the log's unabsorbed error seen in pixels
LOG_ROTATION = (
    4.0  # under a biased log on a nearly straight path: the rotation std allowed, in angles its error subtends
)
RIVAL_PROBABILITY = 0.01  # under a biased log, a rival pose the track's evidence leaves below this is no ambiguity
PROFILE_POINTS = 600  # tracked positions whose support with the log's bias fitted gives the timing (profile_beta)
PROFILE_SIGMAS = 3  # profile_beta looks this many of the fit's beta stds either side of it
GCP_AGREE = 3.0  # a pose agrees with the GCPs when their median error is within this many of their sigmas
SURVEY_SUPPORT = (
    0.9  # a pose from GCPs and track together must explain this share of the frames the track's own pose explains
)
CHI2_2_MEDIAN = 2.0 * np.log(2.0)  # median of a chi-square of 2 degrees of freedom
MEASURE_POINTS = (
    6  # GCPs (inliers of their pose) whose residuals measure the survey's error alone; fewer: not below the stated one
)
MIN_GCP_SIGMA_M = 0.005  # smallest survey error measured from a handful of GCPs (metres per coordinate)
MAX_ROTATION_STD_DEG = 3.0
MAX_CENTER_STD = 0.15  # of the median distance to the target
# An intrinsic the target determines: its posterior std below these (f: share of f; cx, cy: share of the image width;
# k1: absolute).
DETERMINED = {"f": 0.05, "cx": 0.02, "cy": 0.02, "k1": 0.05}
PLANAR = 0.02  # a log whose smallest spread is below this share of its largest moves in a plane
BATCH = 256  # candidate offsets whose trajectory positions are evaluated at once
MAX_TRACKLETS = 40  # movers' tracklets tried as the target's track, longest image paths first
MIN_TRACKLET_FRAMES = 12  # frames a mover's tracklet needs to be tried
TRACKLET_CANDIDATES = 2  # fits at distinct offsets of each tracklet under which the target is identified
CONFIRM_SHARE = 0.9  # two identifications are the same track when they share this share of the larger's detections
SETTLE_ROUNDS = 4  # rounds of settling the chosen track at most (``_settled``)
SETTLED_PX = 0.01  # the target's own points moving less than this (pixels) between rounds are settled

REMEDIES = {
    "no_clock": "give the camera's fps and a log with times, or 4 GCPs with gcp_sigma_m = 0 (their pose alone)",
    "too_few_frames": "record the target longer in this view, or add 4 GCPs (gcp = ...)",
    "straight_path": "walk a curved path through the view (turns, not a straight line), or add 4 GCPs (gcp = ...)",
    "ambiguous_offset": "walk a path through the view that does not repeat itself (turns of different shapes), or add "
    "4 GCPs (gcp = ...)",
    "pose_undetermined": "walk a curved path spread over the whole view, near and far, or add 4 GCPs (gcp = ...)",
    "gcp_conflict": "check the GCP file (each pixel against its world point) and gcp_sigma_m, and that the log is in "
    "the GCPs' frame",
    "no_fit": "check the intrinsics (K, dist) and that the log covers the video, or add 4 GCPs (gcp = ...)",
    "not_upright": "if the camera is mounted rolled that far, set [sync] upright_roll_deg = 180 (the upright prior "
    "off), or survey it (GCPs or a camera.json with its pose)",
    "planar_path": "calibrate the intrinsics with checkerboard photos (a target moving in a plane does not determine "
    "the focal length), or fly it at different heights",
}


class PoseError(SyncError):
    """The pose cannot be estimated from the target: ``cause`` (a key of REMEDIES), what was seen, and the remedy."""

    def __init__(self, camera: str, cause: str, detail: str):
        self.cause = cause
        self.remedy = REMEDIES[cause]
        super().__init__(f"camera {camera}: pose not determined from the target ({cause}): {detail}; {self.remedy}")


@dataclass(frozen=True)
class OffsetSearch:
    """The search over beta: the fine pass's offsets and supports (MSAC scores of the pairs, ``_Scorer.fit``), pairs per
    offset, threshold and steps; the coarse pass's offsets and supports (at COARSE times the threshold).
    """

    betas: np.ndarray
    support: np.ndarray
    pairs: int
    threshold_px: float
    coarse_step: float
    fine_step: float
    offsets_tried: int
    coarse_betas: np.ndarray
    coarse_support: np.ndarray
    fitted_at: tuple[float, ...] = ()  # offsets alike with the top a pose was then fitted from (``fitted_untested``)


@dataclass(frozen=True)
class Candidate:
    """A starting point for the joint fit: camera (pose), line, and where it comes from (``search`` or ``gcp``)."""

    camera: Camera
    alpha: float
    beta: float
    origin: str


@dataclass(frozen=True)
class TargetPose:
    """A camera's pose from the target.

    camera: the fitted camera (pose; intrinsics where they were free);
    fit: the winning joint fit; source: ``target`` or ``gcp+target``;
    runner_up / runner_up_beta: frames within ``tight_px`` (TIGHT median
    residuals of the winner) and beta of the best fit at a distinct offset (0 /
    NaN without one); tight_support: the winner's frames within tight_px;
    runner_up_ratio: the runner-up's MSAC score over the winner's (``msac``
    at tight_px: near 1 when both explain the track alike);
    search: the offset search;
    straightness: the image path's second to first singular value; gcp_pose:
    the camera from the GCPs alone (None without GCPs); moved_m / moved_deg:
    how far the pose moved from it; intrinsics: each intrinsic the fit was
    free to move: (value, std, determined); gcps_used: the GCPs as the fit
    counted them (their measured sigma and weight; None: as given);
    disagreeing: the GCPs that conflict with the track (the pose is then the
    track's alone, source ``target``); bias_beta: under a log with a bias, the
    beta the pose and the log's bias fitted together explain best
    (``profile_beta``), NaN otherwise; under a log with a bias also
    rival_probability: the runner-up's probability against the winner on
    the track's evidence (sync/pose/timing.py; NaN otherwise), and
    timing_spread: how far (clock units) the fits that are one timing with
    the winner lie from its beta (0 otherwise), which the line's interval
    carries, and untested: the offsets the search's coarse pass scores alike
    with its top that no fit is one timing with (sync/pose/timing.py,
    ``untested_offsets``; empty otherwise).
    """

    camera: Camera
    fit: JointFit
    source: str
    runner_up: int
    runner_up_beta: float
    tight_support: int
    tight_px: float
    runner_up_ratio: float
    search: OffsetSearch
    straightness: float
    gcp_pose: Camera | None = None
    moved_m: float = float("nan")
    moved_deg: float = float("nan")
    intrinsics: dict[str, tuple[float, float, bool]] | None = None
    gcps_used: GcpPrior | None = None
    disagreeing: tuple[str, ...] = ()
    bias_beta: float = float("nan")
    rival_probability: float = float("nan")
    timing_spread: float = 0.0
    untested: tuple[float, ...] = ()

    @property
    def support(self) -> int:
        return self.fit.support

    @property
    def line_cov(self) -> np.ndarray | None:
        """(2, 2) covariance of the fit's (alpha, beta) for the timing: the joint fit's, its beta variance raised to
        the survey's alone (JointFit.survey_line_cov) where the image path is a straight line (straightness under
        STRAIGHT): there the track cannot tell a pose moved along the path from a time shift, and the joint fit
        counts its faint evidence of the difference (the pass bench's straight crossings under GCPs 0.5-2 m off:
        beta 2-5 of its std off; their turning crossings, which determine the pose, keep the joint fit's)."""
        cov, survey = self.fit.line_cov, self.fit.survey_line_cov
        if cov is None or survey is None or not np.isfinite(survey[1, 1]) or self.straightness >= STRAIGHT:
            return cov
        out = np.array(cov, dtype=np.float64)
        out[1, 1] = max(out[1, 1], float(survey[1, 1]))
        return out

    @property
    def se_beta(self) -> float:
        """Std of the fit's beta (frames) for the timing (``line_cov``)."""
        cov = self.line_cov
        return float(np.sqrt(max(cov[1, 1], 0.0))) if cov is not None else self.fit.se_beta

    @property
    def timing(self) -> PoseTiming:
        """The line this pose gives its camera's timing (sync/pose/pose_timing.py)."""
        cov = self.line_cov
        return PoseTiming(
            self.fit.alpha,
            self.fit.beta,
            None if cov is None or not np.isfinite(cov).all() else np.array(cov, dtype=np.float64),
            self.se_beta,
            self.bias_beta,
            self.timing_spread,
        )

    def to_report(self, info: PoseInfo, gcps: GcpPrior | None = None) -> dict:
        """The pose from the target as calibration_report.json's ``target_pose`` (docs/calibration.md)."""
        fit = self.fit
        out: dict = {
            **info.to_dict(),
            "camera_center_m": fit.camera.center.tolist(),
            "alpha": fit.alpha,
            "beta": fit.beta,
            "se_beta": fit.se_beta,
            "frames": fit.support,
            "scale_px": fit.scale_px,
            "runner_up_ratio": self.runner_up_ratio,
            "runner_up_beta": None if not np.isfinite(self.runner_up_beta) else self.runner_up_beta,
            "rival_probability": None if not np.isfinite(self.rival_probability) else self.rival_probability,
            "timing_spread": self.timing_spread,
            "untested_betas": list(self.untested),
            "straightness": self.straightness,
            "timing": self.timing.to_dict(),
            "search": {
                "offsets_tried": self.search.offsets_tried,
                "threshold_px": self.search.threshold_px,
                "step_frames": self.search.fine_step,
            },
        }
        if self.gcp_pose is not None:
            out.update(moved_m=self.moved_m, moved_deg=self.moved_deg)
        if gcps is not None:
            before = gcps.errors_px(self.gcp_pose) if self.gcp_pose is not None else np.full(len(gcps.xyz), np.nan)
            after = gcps.errors_px(self.camera)
            names = gcps.names or tuple(str(k) for k in range(len(gcps.xyz)))
            used = self.gcps_used or gcps
            out.update(
                gcp_sigma_m=used.sigma_m,
                gcp_sigma_stated_m=gcps.sigma_m,
                gcp_weight=used.weight,
                gcps_disagree=list(self.disagreeing),
            )
            out["gcps"] = [
                {
                    "name": n,
                    "before_px": None if not np.isfinite(b) else float(b),
                    "after_px": None if not np.isfinite(a) else float(a),
                    "disagrees": n in self.disagreeing,
                }
                for n, b, a in zip(names, before, after)
            ]
        if self.intrinsics:
            out["intrinsics"] = {
                k: {"value": v, "std": sd, "determined": kept} for k, (v, sd, kept) in self.intrinsics.items()
            }
        return out


def pose_from_track(
    camera: Camera,
    clock: np.ndarray,
    xy: np.ndarray,
    path: PiecewiseTrajectory,
    prior: SlopePrior | None,
    fps: float | None,
    gate_px: float = 10.0,
    gcps: GcpPrior | None = None,
    gcp_camera: Camera | None = None,
    free: tuple[str, ...] = (),
    f_scale: float = 3.0,
    seed: int = 0,
    delta: float = 0.5,
    offsets: tuple[float, float] | None = None,
    log_model: LogModel | None = None,
    max_roll_deg: float | None = None,
) -> TargetPose:
    """The camera's pose (and line) from its track of the target; PoseError with the cause when it is not determined.

    camera: its intrinsics (its pose is ignored; without K, ``to_estimate``
    holds "intrinsics" and they are fitted too); clock / xy: (N,) camera
    clock and (N, 2) pixels of the tracked frames; path: the trajectory
    model (as the sync method prepares it); prior: the clock prior and fps
    the camera's nominal frame rate (both needed); gate_px: a frame
    supports a fit when its reprojection is within it; gcps / gcp_camera:
    GCPs as a prior and the camera they give alone (a starting candidate);
    free: intrinsics the fit may move (``f``, ``cx``, ``k1``); delta: the
    line search's band for the GCP candidate's line; offsets: the range of
    beta (clock units) the search covers (None: all the log allows);
    log_model: the log's error; with a bias, the search scores each offset
    with the log's bias over the visit fitted with the pose (sync/pose/pose_bias.py),
    and the fits' gate, loss scale and shared model error widen to the error
    a fixed pose cannot absorb over the track's span (``LogModel.unabsorbed_m``)
    as seen at the target's depth (``log_scales``); max_roll_deg: without
    GCPs, the upright-mount prior's tolerance (``ranked_pose``; None: off).
    """
    clock = np.asarray(clock, dtype=np.float64)
    xy = np.asarray(xy, dtype=np.float64)
    biased = log_model if log_model is not None and log_model.has_bias and fps else None
    log_m = biased.unabsorbed_m(float(np.ptp(clock)) / fps) if biased is not None and len(clock) and fps else 0.0
    unknown_k = "intrinsics" in camera.to_estimate
    if unknown_k:
        free = tuple(sorted(set(free) | {"f", "cx", "k1"}, key=INTRINSICS.index))
    if gcps is None or gcp_camera is None or free:
        try:
            search, fits = candidate_fits(
                camera,
                clock,
                xy,
                path,
                prior,
                fps,
                gate_px,
                gcps,
                gcp_camera,
                free,
                f_scale,
                seed,
                delta,
                offsets=offsets,
                log_model=biased,
            )
        except PoseError as exc:
            if exc.cause != "gcp_conflict" or free:
                raise
            # GCPs without a pose of their own (too few, too rough) that no pose of the track keeps: the track alone
            alone = pose_from_track(
                camera,
                clock,
                xy,
                path,
                prior,
                fps,
                gate_px,
                None,
                None,
                (),
                f_scale,
                seed,
                delta,
                offsets,
                log_model,
                max_roll_deg,
            )
            return replace(alone, disagreeing=_names(gcps))  # type: ignore[arg-type]
        result = ranked_pose(
            fits, search, xy, fps or 0.0, gcps is not None, gcp_camera, clock, path, biased, max_roll_deg=max_roll_deg
        )
        if result.untested and gcps is None:
            search, fits = fitted_untested(
                camera, clock, xy, path, prior, fps, gate_px, f_scale, free, search, fits, result.untested, biased
            )
            result = ranked_pose(
                fits, search, xy, fps or 0.0, False, None, clock, path, biased, max_roll_deg=max_roll_deg
            )
        if free:
            result = _settle_intrinsics(result, clock, xy, path, prior, gate_px, f_scale, gcps, free, unknown_k)
        check_determined(result, clock, path, gcps is not None, log_m, fps)
        if biased is not None and not free:
            result = replace(result, bias_beta=profile_beta(result.fit, clock, xy, path, biased, fps))  # type: ignore[arg-type]
        return result
    return _survey_and_target(
        camera, clock, xy, path, prior, fps, gate_px, gcps, gcp_camera, f_scale, seed, delta, offsets
    )


def _survey_and_target(
    camera: Camera,
    clock,
    xy,
    path,
    prior: SlopePrior | None,
    fps: float | None,
    gate_px: float,
    gcps: GcpPrior,
    gcp_camera: Camera,
    f_scale: float,
    seed: int,
    delta: float,
    offsets,
) -> TargetPose:
    """The pose from GCPs and track together, or from the track alone when they conflict (module docstring, step 5).

    The track alone is fitted first (the offset search's candidates, no
    GCP). The GCPs' error is measured (``measured_gcps``) from their
    residuals under their own pose and, when the track alone determines the
    pose, under the track's: the GCPs that the track's pose puts beyond
    GCP_AGREE of the latter disagree and are left out (the GCPs' own pose is
    then fitted to the others), and the smaller of the two sigmas is used.
    The GCPs count ``track_inflation`` times their information, since the
    fit counts every frame as independent while the track's errors are
    shared by neighbouring frames (the log's bias, the tracker's). A joint
    fit that keeps the GCPs within GCP_AGREE sigmas and explains
    SURVEY_SUPPORT of the frames the track alone explains wins (source
    ``gcp+target``); otherwise the track's own pose is used (source
    ``target``), naming the GCPs it puts beyond GCP_AGREE sigmas, when it is
    determined; else the camera fails (gcp_conflict, naming them).
    """
    name = camera.name
    prior, fps = _searchable(name, prior, fps, clock, MIN_FRAMES)
    search, starts = search_offsets(camera, clock, xy, path, prior.alpha, seed, offsets=offsets)
    alone = _fit_candidates(starts, clock, xy, path, prior, gate_px, f_scale, None, (), search.threshold_px, MIN_FRAMES)
    own: TargetPose | None = None
    why = PoseError(
        name,
        "no_fit",
        f"no offset of {search.offsets_tried} tried gives a pose that explains {MIN_FRAMES} tracked frames within "
        f"{gate_px:g} px",
    )
    if alone:
        try:
            own = ranked_pose(alone, search, xy, fps, False, gcp_camera)
            check_determined(own, clock, path, False)
        except PoseError as exc:
            own, why = None, exc
    used = measured_gcps(gcps, gcp_camera)
    start = gcp_camera  # the joint fit's start from the GCPs (their own pose refitted without those that disagree)
    outliers: tuple[str, ...] = ()
    if own is not None:
        seen = measured_gcps(gcps, own.camera, fitted=False)
        outliers = disagreeing_gcps(seen, own.camera)
        keep = np.array([n not in outliers for n in _names(gcps)])
        if outliers and keep.sum() >= 4:
            kept = _subset(gcps, keep)
            try:
                refit = pose_from_points(
                    kept.uv, kept.xyz, camera.K, camera.dist, camera.dist_model, 1e6, source="GCPs"
                )
                start = replace(gcp_camera, R=refit.R, t=refit.t)
            except CalibrationInputError:
                pass
            used, seen = measured_gcps(kept, start), measured_gcps(kept, own.camera, fitted=False)
        used = replace(used, sigma_m=min(used.sigma_m, seen.sigma_m))
    weighted = replace(used, weight=alone[0].track_inflation if alone else 1.0)
    candidates = [Candidate(f.camera, f.alpha, f.beta, "search") for f in alone[:CANDIDATES]]
    found = _gcp_candidate(start, clock, xy, path, prior, gate_px, delta, seed)
    if found is not None:
        candidates.append(found)
    joint = [
        f
        for f in _fit_candidates(
            candidates, clock, xy, path, prior, gate_px, f_scale, weighted, (), gate_px, MIN_FRAMES
        )
        if gcps_agree(weighted, f)
    ]
    if joint and (own is None or joint[0].support >= SURVEY_SUPPORT * own.support):
        result = _with_gcps(joint, search, xy, fps, gcp_camera, weighted, clock, path)
        return replace(result, disagreeing=tuple(n for n in _names(gcps) if n in outliers or n in result.disagreeing))
    if own is None:
        named = ", ".join(outliers) or "none alone"
        raise PoseError(
            name,
            "gcp_conflict",
            f"no pose keeps the GCPs within {GCP_AGREE:g} sigmas ({weighted.sigma_m:.2g} m; disagreeing: {named}) and "
            f"explains the track, and the track alone does not determine the pose ({why.cause})",
        )
    return replace(own, gcps_used=weighted, disagreeing=disagreeing_gcps(weighted, own.camera))


def _searchable(
    name: str, prior: SlopePrior | None, fps: float | None, clock: np.ndarray, min_frames: int
) -> tuple[SlopePrior, float]:
    """The slope prior and fps the offset search needs; PoseError without them or under ``min_frames`` tracked
    frames."""
    if prior is None or not fps:
        raise PoseError(
            name,
            "no_clock",
            "the camera's fps or the log's rate is unknown, so the offset cannot be searched with the slope held",
        )
    if len(clock) < min_frames:
        raise PoseError(name, "too_few_frames", f"{len(clock)} tracked frames, at least {min_frames} are needed")
    return prior, fps


def _names(gcps: GcpPrior) -> tuple[str, ...]:
    return gcps.names or tuple(str(k) for k in range(len(gcps.xyz)))


def _subset(gcps: GcpPrior, keep: np.ndarray) -> GcpPrior:
    names = tuple(n for n, k in zip(_names(gcps), keep) if k)
    return replace(gcps, uv=gcps.uv[keep], xyz=gcps.xyz[keep], names=names)


def _with_gcps(
    fits: list[JointFit], search: OffsetSearch, xy, fps, gcp_camera: Camera, gcps: GcpPrior, clock, path
) -> TargetPose:
    """The pose from GCPs and track together (checked), naming the GCPs it leaves beyond GCP_AGREE sigmas."""
    result = ranked_pose(fits, search, xy, fps or 0.0, True, gcp_camera)
    check_determined(result, clock, path, True)
    return replace(result, gcps_used=gcps, disagreeing=disagreeing_gcps(gcps, result.camera))


def disagreeing_gcps(gcps: GcpPrior, camera: Camera) -> tuple[str, ...]:
    """Names (or 0-based indices) of the GCPs that the camera puts beyond GCP_AGREE of their sigmas."""
    far = gcps.errors_px(camera) > GCP_AGREE * gcps.sigma_px(camera)
    return tuple(n for n, bad in zip(_names(gcps), far) if bad)


def candidate_fits(
    camera: Camera,
    clock: np.ndarray,
    xy: np.ndarray,
    path: PiecewiseTrajectory,
    prior: SlopePrior | None,
    fps: float | None,
    gate_px: float,
    gcps: GcpPrior | None,
    gcp_camera: Camera | None,
    free: tuple[str, ...],
    f_scale: float,
    seed: int,
    delta: float,
    min_frames: int = MIN_FRAMES,
    offsets: tuple[float, float] | None = None,
    log_model: LogModel | None = None,
) -> tuple[OffsetSearch, list[JointFit]]:
    """The offset search (within ``offsets``, clock units, when given) and the joint fits of its candidates (and the
    GCP candidate), best first (most frames within the gate).

    With GCPs only the fits that keep them within GCP_AGREE sigmas. log_model:
    a log with a bias (``pose_from_track``'s), or None. Raises PoseError when
    there is none (no_clock, too_few_frames, planar_path, no_fit, gcp_conflict).
    """
    name = camera.name
    prior, fps = _searchable(name, prior, fps, clock, min_frames)
    dlt = "intrinsics" in camera.to_estimate
    biased = log_model if log_model is not None and log_model.has_bias else None
    search, candidates = search_offsets(
        camera, clock, xy, path, prior.alpha, seed, dlt=dlt, offsets=offsets, log_model=biased, fps=fps
    )
    log_m = biased.unabsorbed_m(float(np.ptp(clock)) / fps) if biased is not None else 0.0
    if gcp_camera is not None:
        found = _gcp_candidate(gcp_camera, clock, xy, path, prior, gate_px, delta, seed)
        if found is not None:
            candidates.append(found)
    fits = _fit_candidates(
        candidates, clock, xy, path, prior, gate_px, f_scale, gcps, free, search.threshold_px, min_frames, log_m
    )
    if not fits and dlt and planarity(path) < PLANAR:
        raise PoseError(
            name,
            "planar_path",
            f"the camera has no K and the target moves in a plane (its height spread is {planarity(path):.3f} of its "
            f"extent)",
        )
    if not fits:
        raise PoseError(
            name,
            "no_fit",
            f"no offset of {search.offsets_tried} tried gives a pose that explains {MIN_FRAMES} tracked frames within "
            f"{gate_px:g} px",
        )
    if gcps is not None:
        fits = [f for f in fits if gcps_agree(gcps, f)]
        if not fits:
            raise PoseError(
                name,
                "gcp_conflict",
                f"no offset gives a pose that both explains the track and keeps the GCPs within {GCP_AGREE:g} sigmas "
                f"({gcps.sigma_m:.2g} m)",
            )
    return search, fits


def fitted_untested(
    camera: Camera,
    clock: np.ndarray,
    xy: np.ndarray,
    path: PiecewiseTrajectory,
    prior: SlopePrior | None,
    fps: float | None,
    gate_px: float,
    f_scale: float,
    free: tuple[str, ...],
    search: OffsetSearch,
    fits: list[JointFit],
    untested: tuple[float, ...],
    log_model: LogModel | None,
) -> tuple[OffsetSearch, list[JointFit]]:
    """The search with the ``untested`` offsets (clock units) a fit converged from marked as fitted at, and the fits
    with those fits (each started from the search's pose at its offset and the prior's slope), best first. A fit may
    converge to another offset (the best's timing, seen through the coarse pass): the offset was weighed all the same.
    An offset no fit converged from stays untested."""
    name = camera.name
    prior, fps = _searchable(name, prior, fps, clock, MIN_FRAMES)
    dlt = "intrinsics" in camera.to_estimate
    score, threshold = _offset_scorer(camera, clock, xy, path, prior.alpha, dlt, log_model, fps)
    log_m = log_model.unabsorbed_m(float(np.ptp(clock)) / fps) if log_model is not None else 0.0
    extra, fitted_at = [], list(search.fitted_at)
    for beta in untested:
        found = score.camera_at(camera, beta, threshold)
        if found is None:
            continue
        converged = _fit_candidates(
            [Candidate(found, prior.alpha, beta, "search")],
            clock,
            xy,
            path,
            prior,
            gate_px,
            f_scale,
            None,
            free,
            search.threshold_px,
            MIN_FRAMES,
            log_m,
        )
        if converged:
            extra += converged
            fitted_at.append(beta)
    fitted = sorted(fits + extra, key=lambda f: (-f.support, f.scale_px))
    return replace(search, fitted_at=tuple(fitted_at)), fitted


def _fit_candidates(
    candidates: list[Candidate],
    clock,
    xy,
    path,
    prior,
    gate_px: float,
    f_scale: float,
    gcps: GcpPrior | None,
    free,
    threshold_px: float,
    min_frames: int,
    log_m: float = 0.0,
) -> list[JointFit]:
    """The converged joint fits of the candidates (a search candidate starts from the frames within the search's
    threshold, the GCP candidate from those within the gate), best first (most frames within the gate); log_m: as
    ``pose_from_track``'s."""
    fits = []
    for candidate in candidates:
        gate, scale, shared = log_scales(
            candidate.camera, clock, path, candidate.alpha, candidate.beta, gate_px, f_scale, log_m
        )
        first = threshold_px if candidate.origin == "search" else gate_px
        first = max(first, gate) if gate > gate_px else first  # a metre-level log's wider gate
        start = reprojection_errors(candidate.camera, clock, xy, path, candidate.alpha, candidate.beta) <= first
        if start.sum() < min_frames // 2:
            continue
        try:
            fit = fit_pose_and_line(
                candidate.camera,
                clock,
                xy,
                path,
                candidate.alpha,
                candidate.beta,
                start,
                gate,
                scale,
                prior,
                gcps,
                free,
                model_error_px=shared,
            )
        except ValueError:
            continue
        if fit.converged:
            fits.append(fit)
    fits.sort(key=lambda f: (-f.support, f.scale_px))
    return fits


def log_scales(
    camera: Camera,
    clock,
    path: PiecewiseTrajectory,
    alpha: float,
    beta: float,
    gate_px: float,
    f_scale: float,
    log_m: float,
) -> tuple[float, float, float]:
    """A fit's gate, loss scale and shared model error (pixels) under a log whose error a fixed pose cannot absorb is
    log_m metres (per axis), seen at the target's median depth under the camera and line: LOG_GATE, 1 and 1 times it,
    never below gate_px, f_scale and MODEL_ERROR_PX (an RTK log keeps those)."""
    depth = median_depth(camera, clock, path, alpha, beta) if log_m > 0 else float("nan")
    if not depth > 0:
        return gate_px, f_scale, MODEL_ERROR_PX
    seen = 0.5 * (camera.K[0, 0] + camera.K[1, 1]) * log_m / depth
    return max(gate_px, LOG_GATE * seen), max(f_scale, seen), max(MODEL_ERROR_PX, seen)


def ranked_pose(
    fits: list[JointFit],
    search: OffsetSearch,
    xy: np.ndarray,
    fps: float,
    with_gcps: bool,
    gcp_camera: Camera | None,
    clock: np.ndarray | None = None,
    path: PiecewiseTrajectory | None = None,
    log_model: LogModel | None = None,
    max_roll_deg: float | None = None,
) -> TargetPose:
    """The best of the fits (first: most support) with its runner-up at a distinct offset, as a TargetPose (not yet
    checked).

    xy: the winner's tracked pixels (its straightness is measured on its inliers). Without a log bias (log_model None
    or without one) an offset more than DISTINCT_S away is distinct and the runner-up is the distinct fit of the best
    score. Under a log with a bias (clock, path and log_model given, fps known) a fit is distinct when it is not one
    timing with the winner (sync/pose/timing.py: beyond the betas' stds and what the bias along the path explains);
    the runner-up is the distinct fit the track's evidence makes most probable (``rival_probability``), the
    timing's spread is that of the fits that are one timing, and the offsets the search's coarse pass scores alike with
    its top that no fit is one timing with are kept (``untested_offsets``).

    max_roll_deg: the upright-mount prior (sync/pose/upright.py; None or with GCPs: off): the best is the first fit
    whose roll is within it, and every other fit, rolled or not, stays a possible runner-up with all its evidence (a
    rolled pose that explains the track at another offset still says the track is ambiguous). PoseError
    ``not_upright`` when no fit is within it, unless the track cannot pose the camera at all (a straight path:
    ``straight_path``, the rolls of its fits mean nothing).
    """
    upright = [k for k, f in enumerate(fits) if is_upright(f.camera.R, None if with_gcps else max_roll_deg)]
    if not upright:
        width = straightness(xy[fits[0].inliers])
        if width < STRAIGHT:
            raise PoseError(fits[0].camera.name, "straight_path", _straight_text(width))
        raise PoseError(
            fits[0].camera.name,
            "not_upright",
            f"every pose that explains the track is rolled more than {max_roll_deg:g} degrees (the best "
            f"{roll_deg(fits[0].camera.R):.0f}: the world's up not up in the image)",
        )
    best = fits[upright[0]]
    fits = [best] + [f for k, f in enumerate(fits) if k != upright[0]]
    tight = TIGHT * max(float(np.median(best.errors[best.inliers])), 0.5)
    biased = clock is not None and path is not None and log_model is not None and log_model.has_bias and fps > 0
    probability, spread = float("nan"), 0.0
    untested: tuple[float, ...] = ()
    if biased:
        bias = bias_frames(best, clock, path, log_model, fps / abs(best.alpha))  # type: ignore[arg-type]
        distinct = [f for f in fits if not one_timing(best, f, bias, fps)]
        odds = [rival_probability(best, f, clock, fps) for f in distinct]  # type: ignore[arg-type]
        runner = distinct[int(np.argmax(odds))] if distinct else None
        probability = max(odds, default=0.0)
        spread = timing_spread(best, fits, bias, fps)
        alike = untested_offsets(
            search.coarse_betas, search.coarse_support, search.pairs, fits, best, bias, fps, search.fitted_at
        )
        untested = tuple(float(b) for b in alike)
    else:
        distinct = [f for f in fits if abs(f.beta - best.beta) > DISTINCT_S * fps]
        runner = max(distinct, key=lambda f: msac(f.errors, tight)) if distinct else None
    result = TargetPose(
        best.camera,
        best,
        "gcp+target" if with_gcps else "target",
        runner.within(tight) if runner else 0,
        runner.beta if runner else float("nan"),
        best.within(tight),
        tight,
        msac(runner.errors, tight) / max(msac(best.errors, tight), 1e-9) if runner else 0.0,
        search,
        straightness(xy[best.inliers]),
        rival_probability=probability,
        timing_spread=spread,
        untested=untested,
    )
    if gcp_camera is not None:
        result = replace(
            result,
            gcp_pose=gcp_camera,
            moved_m=float(np.linalg.norm(result.camera.center - gcp_camera.center)),
            moved_deg=rotation_between(result.camera.R, gcp_camera.R),
        )
    return result


def _straight_text(ratio: float) -> str:
    return f"the target's path is nearly a straight line in the image (width {ratio:.3f} of its length)"


def profile_beta(
    fit: JointFit, clock: np.ndarray, xy: np.ndarray, path: PiecewiseTrajectory, log_model: LogModel, fps: float
) -> float:
    """The beta of the largest support of the pose and the log's bias over the track fitted together
    (sync/pose/pose_bias.py, PROFILE_POINTS tracked positions), within PROFILE_SIGMAS of the fit's beta std, at
    steps of a tenth of it, the peak interpolated by a parabola; the fit's beta when the profile has no peak inside.

    The rigid fit takes the log's wander over the visit as noise shared by blocks of frames, and its beta moves with
    it (on drone2 under a drone's GNSS: 0.3-9 frames off); with the wander fitted under its prior the peak was
    within 0-4.5 frames (seeds 0 and 2, every camera)."""
    if not np.isfinite(fit.se_beta) or fit.se_beta <= 0:
        return fit.beta
    camera = fit.camera
    rows = np.unique(np.linspace(0, len(clock) - 1, min(PROFILE_POINTS, len(clock))).round().astype(np.int64))
    c = clock[rows]
    ideal = undistort_pixels(xy[rows], camera.K, camera.dist, camera.dist_model, P=camera.K)
    score = _Scorer(camera.K, c, ideal, path, fit.alpha, False, VisitBias.over(c, fps, log_model))
    step = max(fit.se_beta / 10.0, 0.05)
    betas = fit.beta + step * np.arange(-10 * PROFILE_SIGMAS, 10 * PROFILE_SIGMAS + 1)
    support = score.many(betas, max(8.0, 0.01 * float(np.hypot(*camera.image_size))))
    k = int(np.argmax(support))
    if k == 0 or k == len(betas) - 1:
        return fit.beta
    left, mid, right = support[k - 1 : k + 2]
    curvature = left - 2 * mid + right
    return float(betas[k] + (0.5 * step * (left - right) / curvature if curvature < 0 else 0.0))


def check_determined(
    result: TargetPose,
    clock: np.ndarray,
    path: PiecewiseTrajectory,
    with_gcps: bool,
    log_m: float = 0.0,
    fps: float | None = None,
) -> None:
    """Raise PoseError when the pose is not determined (see the module docstring, step 4).

    log_m: as ``pose_from_track``'s. Without GCPs, two offsets are
    ambiguous when, under a log with a bias (the result's
    ``rival_probability`` measured), the track's evidence leaves the rival
    at least RIVAL_PROBABILITY (a rival being a fit that is not one timing
    with the winner, sync/pose/timing.py) or the search scores alike an
    offset no pose was fitted at (``untested``), otherwise when the runner-up
    scores AMBIGUOUS of the winner. Under a log with a bias (log_m > 0 and
    the camera's fps) the pose absorbs the log's error and serves the
    timing only (``pose_info``): on a path that is not nearly straight in
    the image (NEARLY_STRAIGHT) what must be determined is the timing, and
    a loose pose is no refusal: the fits that are one timing are one
    answer whose interval holds their spread (``timing_spread``) and beta's
    std, which carries the pose's looseness. A nearly straight path is
    explained as well by poses tens of metres off at wrong offsets with a
    tight beta (a walker under a drone's GNSS: 50-86 m off, beta's std 5
    frames, 31 s off): there the pose itself must be determined, its
    rotation as loose as LOG_ROTATION times the angle the log's error
    subtends at the target's depth."""
    fit, name = result.fit, result.camera.name
    if fit.support < MIN_FRAMES:
        raise PoseError(
            name, "too_few_frames", f"{fit.support} frames within the gate, at least {MIN_FRAMES} are needed"
        )
    if not with_gcps and result.straightness < STRAIGHT:
        raise PoseError(name, "straight_path", _straight_text(result.straightness))
    weighed = np.isfinite(result.rival_probability)
    if not with_gcps and weighed and result.rival_probability >= RIVAL_PROBABILITY:
        raise PoseError(
            name,
            "ambiguous_offset",
            f"a pose at another offset keeps {100 * result.rival_probability:.0f} % of the track's evidence "
            f"(beta {result.runner_up_beta:.1f} and {fit.beta:.1f}, beyond what the log's bias explains)",
        )
    if not with_gcps and result.untested:
        raise PoseError(
            name,
            "ambiguous_offset",
            f"the search scores {len(result.untested)} other offsets alike that no pose was fitted at (beta "
            f"{', '.join(f'{b:.0f}' for b in result.untested[:3])}{' ...' if len(result.untested) > 3 else ''}; "
            f"the best {fit.beta:.1f})",
        )
    if not with_gcps and not weighed and result.runner_up_ratio >= AMBIGUOUS:
        raise PoseError(
            name,
            "ambiguous_offset",
            f"two offsets explain the track alike (scores {result.runner_up_ratio:.2f} to 1, {result.runner_up} and "
            f"{result.tight_support} frames within {result.tight_px:.1f} px, "
            f"beta {result.runner_up_beta:.1f} and {fit.beta:.1f})",
        )
    if log_m > 0 and fps and result.straightness >= NEARLY_STRAIGHT:
        return
    depth = median_depth(fit.camera, clock[fit.inliers], path, fit.alpha, fit.beta)
    loose = []
    if not fit.rotation_std_deg <= max(MAX_ROTATION_STD_DEG, LOG_ROTATION * np.degrees(log_m / depth)):
        loose.append(f"rotation +-{fit.rotation_std_deg:.2g} deg")
    if not fit.center_std_m <= MAX_CENTER_STD * depth:
        loose.append(f"centre +-{fit.center_std_m:.2g} m at {depth:.0f} m")
    if loose:
        cause = "straight_path" if result.straightness < NEARLY_STRAIGHT else "pose_undetermined"
        raise PoseError(name, cause, "the track leaves the pose loose (" + ", ".join(loose) + ")")


def gcps_agree(gcps: GcpPrior, fit: JointFit) -> bool:
    """Whether the fitted pose keeps the GCPs within GCP_AGREE of their sigmas (median over the points: one bad point is
    allowed).
    """
    return bool(np.median(fit.gcp_errors_px / gcps.sigma_px(fit.camera)) <= GCP_AGREE)


def median_depth(camera: Camera, clock: np.ndarray, path: PiecewiseTrajectory, alpha: float, beta: float) -> float:
    """Median distance (metres, along the optical axis) of the target at the given frames under the line."""
    s = (clock - beta) / alpha
    run = path.run_of(s)
    on = run >= 0
    if not on.any():
        return float("nan")
    return float(np.median((path(s[on], run[on]) @ camera.R.T + camera.t)[:, 2]))


def planarity(path: PiecewiseTrajectory) -> float:
    """Smallest over largest singular value of the trajectory's centred sample positions (0: a plane)."""
    xyz = path.positions(np.arange(path.starts.min(), path.ends.max() + 1))
    xyz = xyz[np.isfinite(xyz[:, 0])]
    s = np.linalg.svd(xyz - xyz.mean(axis=0), compute_uv=False)
    return float(s[2] / s[0]) if s[0] > 0 else 0.0


def straightness(xy: np.ndarray) -> float:
    """Second over first singular value of the centred pixel positions (N, 2): 0 for points on one line."""
    if len(xy) < 3:
        return 0.0
    s = np.linalg.svd(xy - xy.mean(axis=0), compute_uv=False)
    return float(s[1] / s[0]) if s[0] > 0 else 0.0


def rotation_between(Ra: np.ndarray, Rb: np.ndarray) -> float:
    """Angle (degrees) of the rotation taking Ra to Rb."""
    cos = (np.trace(Ra @ Rb.T) - 1.0) / 2.0
    return float(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))


def search_offsets(
    camera: Camera,
    clock: np.ndarray,
    xy: np.ndarray,
    path: PiecewiseTrajectory,
    alpha: float,
    seed: int = 0,
    dlt: bool = False,
    offsets: tuple[float, float] | None = None,
    log_model: LogModel | None = None,
    fps: float | None = None,
) -> tuple[OffsetSearch, list[Candidate]]:
    """The search over beta with alpha held (module docstring, step 1): the fine pass and the CANDIDATES best peaks as
    cameras.

    dlt: fit a projection matrix (unknown intrinsics) instead of a pose; offsets: the range of beta searched (clock
    units), within what the log allows (None: all of it); log_model: a log with a bias, whose bias over the track is
    fitted with each offset's pose (sync/pose/pose_bias.py; the camera's fps gives the knots' seconds; None: a rigid
    pose).
    """
    score, threshold = _offset_scorer(camera, clock, xy, path, alpha, dlt, log_model, fps)
    speed = image_speed(clock, xy) or 1.0  # pixels per clock unit (1 without consecutive frames)
    fine = float(np.clip(0.5 * threshold / speed, 0.5, 2.0 * alpha))
    coarse = COARSE * fine
    c = score.clock
    lo = float(c.min() - alpha * path.ends.max())
    hi = float(c.max() - alpha * path.starts.min())
    if offsets is not None:
        lo, hi = max(lo, offsets[0]), min(hi, offsets[1])
    betas = np.arange(lo, hi + coarse, coarse)
    support = score.many(betas, COARSE * threshold)
    tried = len(betas)
    peaks = _peaks(support, FINE_PEAKS)
    fine_betas = (
        np.unique(
            np.concatenate([np.arange(betas[k] - 1.5 * coarse, betas[k] + 1.5 * coarse + fine, fine) for k in peaks])
        )
        if peaks
        else np.zeros(0)
    )
    fine_support = score.many(fine_betas, threshold)
    tried += len(fine_betas)
    search = OffsetSearch(fine_betas, fine_support, len(c), threshold, coarse, fine, tried, betas, support)
    candidates = []
    for k in _peaks(fine_support, CANDIDATES, separation=3 * coarse / fine):
        found = score.camera_at(camera, float(fine_betas[k]), threshold)
        if found is not None:
            candidates.append(Candidate(found, alpha, float(fine_betas[k]), "search"))
    return search, candidates


def _offset_scorer(
    camera: Camera,
    clock: np.ndarray,
    xy: np.ndarray,
    path: PiecewiseTrajectory,
    alpha: float,
    dlt: bool,
    log_model: LogModel | None,
    fps: float | None,
) -> tuple[_Scorer, float]:
    """The search's scorer of offsets on SEARCH_POINTS tracked positions spread over the track (``search_offsets``'s
    arguments), and its threshold (pixels: 1 % of the image's diagonal, at least 8)."""
    w, h = camera.image_size
    threshold = max(8.0, 0.01 * float(np.hypot(w, h)))
    rows = np.unique(np.linspace(0, len(clock) - 1, min(SEARCH_POINTS, len(clock))).round().astype(np.int64))
    c = clock[rows]
    ideal = xy[rows] if dlt else undistort_pixels(xy[rows], camera.K, camera.dist, camera.dist_model, P=camera.K)
    biased = log_model is not None and log_model.has_bias and fps and not dlt
    visit = VisitBias.over(c, fps, log_model) if biased else None  # type: ignore[arg-type]
    return _Scorer(camera.K, c, ideal, path, alpha, dlt, visit), threshold


def _peaks(support: np.ndarray, count: int, separation: float = 2.0) -> list[int]:
    """Indices of up to ``count`` local maxima of most support, each more than ``separation`` indices from those kept
    before.
    """
    order = np.argsort(-support, kind="stable")
    kept: list[int] = []
    for k in order:
        if support[k] < MIN_PAIRS or len(kept) == count:
            break
        if all(abs(int(k) - j) > separation for j in kept):
            kept.append(int(k))
    return kept


class _Scorer:
    """Support of candidate offsets: pose (or projection matrix) fitted to the pairs, trimmed twice, pairs within a
    threshold; under a log with a bias (``bias``), the pose and the log's bias over the visit fitted together
    (sync/pose/pose_bias.py, its support in the same units)."""

    def __init__(
        self,
        K: np.ndarray,
        clock: np.ndarray,
        ideal: np.ndarray,
        path: PiecewiseTrajectory,
        alpha: float,
        dlt: bool,
        bias: VisitBias | None = None,
    ):
        self.K, self.clock, self.ideal, self.path, self.alpha, self.dlt = K, clock, ideal, path, alpha, dlt
        self.bias = bias

    def pairs(self, beta: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The trajectory's positions and the pixels of the rows on it at ``beta``, and the mask of those rows."""
        s = (self.clock - beta) / self.alpha
        run = self.path.run_of(s)
        on = run >= 0
        return self.path(s[on], run[on]), self.ideal[on], on

    def many(self, betas: np.ndarray, threshold: float) -> np.ndarray:
        """(len(betas),) support of each offset."""
        out = np.zeros(len(betas))
        for first in range(0, len(betas), BATCH):
            chunk = betas[first : first + BATCH]
            s = (self.clock[None, :] - chunk[:, None]) / self.alpha
            run = self.path.run_of(s.ravel())
            on = run >= 0
            xyz = np.full((s.size, 3), np.nan)
            if on.any():
                xyz[on] = self.path(s.ravel()[on], run[on])
            xyz = xyz.reshape(len(chunk), len(self.clock), 3)
            on = on.reshape(len(chunk), -1)
            for k in range(len(chunk)):
                if on[k].sum() >= MIN_PAIRS:
                    out[first + k] = self.fit(xyz[k][on[k]], self.ideal[on[k]], threshold, on[k])[0]
        return out

    def fit(self, xyz: np.ndarray, uv: np.ndarray, threshold: float, on: np.ndarray | None = None):
        """(support, pose or projection) of one offset's pairs (``on``: the rows they are, for the bias's knots).

        The support is the truncated quadratic score of the pairs,
        sum(max(0, 1 - (error / threshold)^2)) (MSAC): pairs within the
        threshold count, the closer the more, so a track that several
        offsets explain within the threshold still ranks the one that
        explains it best first. Under a log with a bias: pose_bias.fit_with_bias's
        support at sigma threshold / CUT.
        """
        if self.bias is not None and on is not None:
            support, pose, _ = fit_with_bias(xyz, uv, self.K, self.bias, on, threshold / CUT, _pnp)
            return support, pose
        fitted = polish(_Pairs(xyz, uv, self.K, self.dlt), trimmed(0.5), 3, min_inliers=6, strict=True)
        if fitted is None:
            return 0, None
        return msac(fitted.residuals, threshold), fitted.model

    def camera_at(self, camera: Camera, beta: float, threshold: float) -> Camera | None:
        """The camera of the pose fitted at ``beta`` (with K and R, t from the projection matrix under DLT), or None."""
        import cv2

        xyz, uv, on = self.pairs(beta)
        if len(xyz) < MIN_PAIRS:
            return None
        _, model = self.fit(xyz, uv, threshold, on)
        if model is None:
            return None
        if self.dlt:
            K, R, t = _decompose(model, camera.image_size)
            if K is None:
                return None
            return Camera(
                camera.name, K, np.zeros(5), R, t, camera.image_size, camera.fps, camera.dist_model, dict(camera.extra)
            )
        rvec, tvec = model
        return Camera(
            camera.name,
            camera.K,
            camera.dist,
            cv2.Rodrigues(rvec)[0],
            tvec.ravel(),
            camera.image_size,
            camera.fps,
            camera.dist_model,
            dict(camera.extra),
        )


@dataclass(frozen=True)
class _Pairs:
    """One offset's pairs (trajectory point, ideal pixel) as the robust fit's model class (sync/kernels/robust.py): a
    model is a pose (rvec, tvec), or under DLT a projection matrix; a pair's residual is its pixel error."""

    xyz: np.ndarray
    uv: np.ndarray
    K: np.ndarray
    dlt: bool

    @property
    def rows(self) -> int:
        return len(self.xyz)

    def refit(self, rows: np.ndarray) -> object | None:
        return _dlt(self.xyz[rows], self.uv[rows]) if self.dlt else _pnp(self.xyz[rows], self.uv[rows], self.K)

    def residuals(self, model: object) -> np.ndarray:
        return _errors(model, self.xyz, self.uv, self.K, self.dlt)


def _pnp(xyz: np.ndarray, uv: np.ndarray, K: np.ndarray):
    """SQPnP's pose (rvec, tvec) of pairs, or None (no solution, or points too close together: OpenCV asserts)."""
    import cv2

    try:
        ok, rvec, tvec = cv2.solvePnP(xyz, uv, K, None, flags=cv2.SOLVEPNP_SQPNP)
    except cv2.error:
        return None
    return (rvec, tvec) if ok else None


def _errors(model, xyz: np.ndarray, uv: np.ndarray, K: np.ndarray, dlt: bool) -> np.ndarray:
    """Pixel error of each pair under a pose (rvec, tvec) or a projection matrix; inf behind the camera."""
    import cv2

    if dlt:
        h = xyz @ model[:, :3].T + model[:, 3]
    else:
        rvec, tvec = model
        h = (xyz @ cv2.Rodrigues(rvec)[0].T + tvec.ravel()) @ K.T
    with np.errstate(divide="ignore", invalid="ignore"):
        error = np.linalg.norm(h[:, :2] / h[:, 2:3] - uv, axis=1)
    return np.where((h[:, 2] > 0) & np.isfinite(error), error, 1e12)


def _dlt(xyz: np.ndarray, uv: np.ndarray) -> np.ndarray | None:
    """3x4 projection matrix from pairs by the normalised DLT (Hartley), its sign making depths positive; None when
    degenerate.
    """
    if len(xyz) < 6:
        return None
    mx, my = xyz.mean(axis=0), uv.mean(axis=0)
    sx = np.sqrt(3) / max(np.sqrt(((xyz - mx) ** 2).sum(axis=1).mean()), 1e-12)
    sy = np.sqrt(2) / max(np.sqrt(((uv - my) ** 2).sum(axis=1).mean()), 1e-12)
    X = np.column_stack([(xyz - mx) * sx, np.ones(len(xyz))])
    x = (uv - my) * sy
    A = np.zeros((2 * len(X), 12))
    A[0::2, 0:4] = X
    A[0::2, 8:12] = -x[:, :1] * X
    A[1::2, 4:8] = X
    A[1::2, 8:12] = -x[:, 1:] * X
    _, sv, vt = np.linalg.svd(A, full_matrices=False)
    if sv[-2] < 1e-9 * sv[0]:
        return None
    P = vt[-1].reshape(3, 4)
    T = np.diag([sx, sx, sx, 1.0])
    T[:3, 3] = -sx * mx
    Ti = np.array([[1 / sy, 0, my[0]], [0, 1 / sy, my[1]], [0, 0, 1.0]])
    P = Ti @ P @ T
    if np.median(xyz @ P[2, :3] + P[2, 3]) < 0:
        P = -P
    return P


def _decompose(P: np.ndarray, image_size: tuple[int, int]) -> tuple[np.ndarray | None, np.ndarray, np.ndarray]:
    """K (square pixels, no skew), R, t of a projection matrix; K None when it is not a camera's (negative focal, centre
    far outside).
    """
    import cv2

    K, R, centre = cv2.decomposeProjectionMatrix(P)[:3]
    signs = np.diag(np.sign(np.diag(K)))
    K, R = K @ signs, signs @ R
    if np.linalg.det(R) < 0:
        R = -R
    K = K / K[2, 2]
    centre = centre[:3, 0] / centre[3, 0]
    w, h = image_size
    f = 0.5 * (abs(K[0, 0]) + abs(K[1, 1]))
    if not (f > 0.1 * w and abs(K[0, 2] - w / 2) < w and abs(K[1, 2] - h / 2) < h):
        return None, R, -R @ centre
    K = np.array([[f, 0.0, K[0, 2]], [0.0, f, K[1, 2]], [0.0, 0.0, 1.0]])
    return K, R, -R @ centre


def measured_gcps(gcps: GcpPrior, camera: Camera, fitted: bool = True) -> GcpPrior:
    """The GCPs with the survey's error measured from their residuals under ``camera`` (their own pose; ``fitted``
    False: a pose fitted to something else, the track's).

    sigma (metres per coordinate; each point's click_px at its depth on
    top) is first the one that makes the median of the normalised squared
    residuals that of a chi-square of 2 degrees of freedom (robust to a
    minority of wrong points), then the maximum-likelihood one over the
    points within GCP_AGREE of it; under their own pose the residuals are
    scaled by 2N / (2N - 6) for the six pose parameters fitted to them. With MEASURE_POINTS such points
    or more it replaces the stated sigma; with fewer (a handful of residuals
    say little) the stated sigma is the log-normal prior (PRIOR_LOG_SD) of
    the measurement, whose 2N - 6 degrees of freedom (2N under another pose)
    weigh it: the posterior mode (MIN_GCP_SIGMA_M at least), so that four
    points clicked to a pixel hold a good survey and four rough ones do not.
    """
    errors = gcps.errors_px(camera)
    depth = np.maximum((gcps.xyz @ camera.R.T + camera.t)[:, 2], 1e-3)
    focal = 0.5 * (camera.K[0, 0] + camera.K[1, 1])
    finite = np.isfinite(errors)
    if finite.sum() < 4:
        return gcps
    n = int(finite.sum())
    squared = np.where(finite, errors, 0.0) ** 2 * ((2 * n) / (2 * n - 6) if fitted else 1.0)

    def var(sigma: float) -> np.ndarray:
        return gcps.click_px**2 + (focal * sigma / depth) ** 2

    robust = float(
        minimize_scalar(
            lambda sg: (np.median(squared[finite] / var(sg)[finite]) - CHI2_2_MEDIAN) ** 2,
            bounds=(0.0, 50.0),
            method="bounded",
            options={"xatol": 1e-4},
        ).x
    )
    inliers = finite & (squared <= GCP_AGREE**2 * var(robust))
    sigma = robust
    if inliers.sum() >= 4:
        sigma = float(
            minimize_scalar(
                lambda sg: float(np.sum(2.0 * np.log(var(sg)[inliers]) + squared[inliers] / var(sg)[inliers])),
                bounds=(0.0, 50.0),
                method="bounded",
                options={"xatol": 1e-4},
            ).x
        )
    if inliers.sum() < MEASURE_POINTS and gcps.sigma_m > 0:
        used = inliers if inliers.sum() >= 4 else finite  # four points fitted by a pose have no outlier to tell
        dof = 2 * int(used.sum()) - (6 if fitted else 0)
        weight = max(dof, 1) / (2 * int(used.sum()))  # the pose's six parameters took their share of the residuals

        def posterior(log_sigma: float) -> float:
            v = var(math.exp(log_sigma))[used]
            data = weight * float(np.sum(2.0 * np.log(v) + squared[used] / v))
            return data + (log_sigma - math.log(gcps.sigma_m)) ** 2 / PRIOR_LOG_SD**2

        sigma = math.exp(
            minimize_scalar(
                posterior, bounds=(math.log(MIN_GCP_SIGMA_M), math.log(50.0)), method="bounded", options={"xatol": 1e-4}
            ).x
        )
    return replace(gcps, sigma_m=sigma)


def gcp_pose(camera: Camera, gcps: GcpPrior, ransac_px: float = 8.0) -> Pose:
    """The pose the GCPs give alone (CalibrationInputError when they cannot: too few, collinear, none within the
    threshold).

    The RANSAC threshold is widened to GCP_AGREE sigmas of the survey at
    the points' depths (under a first pose from all the points): with a
    rough survey every point is off by tens of pixels, none is an outlier.
    """
    pose = pose_from_points(gcps.uv, gcps.xyz, camera.K, camera.dist, camera.dist_model, 1e6, source="GCPs")
    first = replace(camera, R=pose.R, t=pose.t, to_estimate=())
    threshold = max(ransac_px, GCP_AGREE * float(np.median(gcps.sigma_px(first))))
    return pose_from_points(gcps.uv, gcps.xyz, camera.K, camera.dist, camera.dist_model, threshold, source="GCPs")


def gcp_camera(camera: Camera, gcps: GcpPrior, ransac_px: float = 8.0) -> Camera:
    """The camera posed by its GCPs alone (``gcp_pose``)."""
    pose = gcp_pose(camera, gcps, ransac_px)
    return replace(camera, R=pose.R, t=pose.t, to_estimate=())


def _gcp_candidate(
    gcp_camera: Camera, clock, xy, path, prior: SlopePrior, gate_px: float, delta: float, seed: int
) -> Candidate | None:
    """The GCPs' own pose with the line the votes find under it (the nearest sample within the gate of each tracked
    frame), or None.
    """
    uv, valid = gcp_camera.project(
        path.positions(np.arange(path.starts.min(), path.ends.max() + 1)) if len(path.starts) else np.zeros((0, 3))
    )
    samples = np.arange(path.starts.min(), path.ends.max() + 1)[valid]
    if len(samples) < 2:
        return None
    pairs = cKDTree(xy).sparse_distance_matrix(cKDTree(uv[valid]), gate_px, output_type="ndarray")
    if len(pairs) < 2:
        return None
    try:
        line = find_line(samples[pairs["j"]], clock[pairs["i"]], pairs["v"], delta, seed=seed, prior=prior)
    except ValueError:
        return None
    return Candidate(gcp_camera, line.alpha, line.beta, "gcp")


def _settle_intrinsics(
    result: TargetPose, clock, xy, path, prior, gate_px, f_scale, gcps, free, unknown_k: bool
) -> TargetPose:
    """Keep free the intrinsics the target determines (posterior std below DETERMINED), refit with the others held.

    A camera without K whose focal length is not determined fails
    (pose_undetermined): its pose would rest on a guess.
    """
    fit = result.fit
    width = result.camera.image_size[0]
    limit = {
        "f": DETERMINED["f"] * fit.camera.K[0, 0],
        "cx": DETERMINED["cx"] * width,
        "cy": DETERMINED["cy"] * width,
        "k1": DETERMINED["k1"],
    }
    stds = fit.intrinsics_std
    kept = tuple(
        k for k in free if stds.get(k, np.inf) < limit[k] and (k != "cx" or stds.get("cy", np.inf) < limit["cy"])
    )
    if unknown_k and "f" not in kept:
        raise PoseError(
            result.camera.name,
            "pose_undetermined",
            f"the track does not determine the focal length (+-{stds.get('f', np.inf):.0f} px)",
        )
    if kept != tuple(free):
        fit = fit_pose_and_line(
            fit.camera, clock, xy, path, fit.alpha, fit.beta, fit.inliers, gate_px, f_scale, prior, gcps, kept
        )
    values = {"f": fit.camera.K[0, 0], "cx": fit.camera.K[0, 2], "cy": fit.camera.K[1, 2], "k1": fit.camera.dist[0]}
    names = [k for k in INTRINSICS if k in free or (k == "cy" and "cx" in free)]
    report = {
        k: (
            float(values[k]),
            float(fit.intrinsics_std.get(k, stds.get(k, np.nan))),
            k in kept or (k == "cy" and "cx" in kept),
        )
        for k in names
    }
    return replace(result, camera=fit.camera, fit=fit, intrinsics=report)


@dataclass(frozen=True)
class MoverPose:
    """A pose from every mover: the pose (fitted on the identified track), the identification under it, the tracklet it
    started from, and the tracklets tried (id -> why they gave nothing, or "").
    """

    pose: TargetPose
    identification: Identification
    tracklet: int
    tried: dict[int, str]


Final = tuple[JointFit, Identification, int, OffsetSearch]  # a refit, the identification it is fitted on, its tracklet


def pose_from_movers(
    camera: Camera,
    detections: Detections,
    trajectory: Trajectory,
    fps: float | None,
    params: IdentifyParams,
    gcps: GcpPrior | None = None,
    gcp_camera: Camera | None = None,
    free: tuple[str, ...] = (),
    offsets: tuple[float, float] | None = None,
    windows: tuple[tuple[int, int], ...] | None = None,
    max_roll_deg: float | None = None,
) -> MoverPose:
    """The camera's pose from every mover of its video (detections), without a track of the target.

    Identification needs a projection to pick the target, so the movers'
    tracklets are the candidates. Each tracklet of at least MIN_TRACKLET_FRAMES
    frames whose image path is not a straight line (a straight walk fits a
    pose from any straight stretch of the log), the longest image paths
    first, at most MAX_TRACKLETS, gets the offset search and joint fits of
    ``pose_from_track``; under each of its TRACKLET_CANDIDATES best fits at
    distinct offsets, the target is identified among every mover
    (sync/identify/identify.py: its other tracklets, other visits to the view join)
    and the pose and line are fitted again on the identified track. One
    tracklet of a few seconds seldom determines a pose; the identified
    track, with every visit, does. The search stops once the best refit so
    far (most frames, then the smallest residual scale) is fitted on a
    track that another tracklet's pose identifies too (``same_track``).
    That refit's track is settled (``_settled``: the pose fitted on the
    blobs that are the target's own, the target identified again under it,
    pose and line refitted), so that whichever of the confirming tracklets
    came first, the result is the same; it wins, with the best refit at a
    distinct offset as its runner-up, and is checked as
    ``pose_from_track``'s. trajectory: the prepared trajectory; params:
    identification's (its eps_px is the pose's gate, its f_scale_px the
    fit's loss scale); offsets: the range of beta (clock units) each
    tracklet's search covers (None: all the log allows); windows: the
    frames ([start, stop), 0-based) where the scan stage's coarse line puts
    the target in view: only a tracklet with MIN_TRACKLET_FRAMES frames in
    them is tried (the frames read outside them, for the breaks only, show
    movers at times the target is out of view; None: every tracklet);
    max_roll_deg: without GCPs, the upright prior's tolerance
    (``ranked_pose``). Identification still sees every mover. The result's
    ``tried`` names the tracklets tried before the search stopped. Raises
    PoseError when no tracklet leads to a determined pose.
    """
    prior = slope_prior(fps, trajectory.rate, params.rate_sigma)
    eps_px, delta, seed, f_scale = params.eps_px, params.delta, params.seed, params.f_scale_px
    unknown_k = "intrinsics" in camera.to_estimate
    if unknown_k:
        free = tuple(sorted(set(free) | {"f", "cx", "k1"}, key=INTRINSICS.index))
    path = PiecewiseTrajectory(trajectory)
    stated = gcps
    survey = gcps is not None and gcp_camera is not None and not free
    if survey:
        gcps = measured_gcps(gcps, gcp_camera)  # type: ignore[arg-type]
    _, row_clock = detections_clock(detections, fps)
    ids, counts = np.unique(detections.id, return_counts=True)
    inside = in_windows(detections.frame, windows) if windows is not None else np.ones(len(detections), bool)
    tried: dict[int, str] = {}
    ranked = []
    for tid in ids[counts >= MIN_TRACKLET_FRAMES]:
        rows = np.flatnonzero(detections.id == tid)
        if inside[rows].sum() < MIN_TRACKLET_FRAMES:
            tried[int(tid)] = "outside_windows"
            continue
        xy = detections.xy[rows]
        if straightness(xy) < STRAIGHT:
            tried[int(tid)] = "straight_path"
            continue
        ranked.append((-float(np.linalg.norm(np.diff(xy, axis=0), axis=1).sum()), int(tid), rows))
    ranked.sort(key=lambda item: item[:2])
    if not ranked:
        raise PoseError(
            camera.name,
            "too_few_frames",
            f"no mover's tracklet has {MIN_TRACKLET_FRAMES} frames on a path that is not straight"
            + (" in the scan's windows" if windows is not None else "")
            + f" ({len(ids)} tracklets)",
        )
    finals: list[Final] = []
    for _, tid, rows in ranked[:MAX_TRACKLETS]:
        try:
            search, fits = candidate_fits(
                camera,
                row_clock[rows],
                detections.xy[rows],
                path,
                prior,
                fps,
                eps_px,
                gcps,
                gcp_camera,
                free,
                f_scale,
                seed,
                delta,
                MIN_TRACKLET_FRAMES,
                offsets,
            )
        except PoseError as exc:
            tried[tid] = exc.cause
            continue
        starts: list[JointFit] = []
        for fit in fits:
            if len(starts) < TRACKLET_CANDIDATES and all(
                abs(fit.beta - other.beta) > DISTINCT_S * (fps or 0.0) for other in starts
            ):
                starts.append(fit)
        reasons = []
        for fit in starts:
            try:
                identified = identify_target(fit.camera, detections, trajectory, fps, params)
                clock = row_clock[identified.rows]
                start = (
                    reprojection_errors(fit.camera, clock, identified.track.xy, path, identified.alpha, identified.beta)
                    <= eps_px
                )
                refit = fit_pose_and_line(
                    fit.camera,
                    clock,
                    identified.track.xy,
                    path,
                    identified.alpha,
                    identified.beta,
                    start,
                    eps_px,
                    f_scale,
                    prior,
                    gcps,
                    fit.layout.free,
                )
            except (SyncError, ValueError) as exc:
                reasons.append(str(exc).split(": ", 1)[-1][:80])
                continue
            if gcps is None or gcps_agree(gcps, refit):
                finals.append((refit, identified, tid, search))
        tried[tid] = "; ".join(reasons)
        if _confirmed(finals):
            break
    finals.sort(key=lambda final: _rank(final[0]))
    if finals:
        rounds = partial(
            _settle_round,
            detections=detections,
            trajectory=trajectory,
            fps=fps,
            params=params,
            path=path,
            prior=prior,
            gcps=gcps,
            row_clock=row_clock,
        )
        finals[0] = _settled(finals[0], rounds)
    if survey:
        return _movers_with_survey(
            camera,
            detections,
            trajectory,
            fps,
            params,
            stated,  # type: ignore[arg-type]
            gcp_camera,  # type: ignore[arg-type]
            finals,
            tried,
            path,
            prior,
            row_clock,
            offsets,
        )
    if not finals:
        causes = ", ".join(sorted({c for c in tried.values() if c})) or "no fit"
        raise PoseError(
            camera.name,
            "no_fit",
            f"none of the {min(len(ranked), MAX_TRACKLETS)} longest curved tracklets leads to a pose under which the "
            f"target is identified ({causes[:200]})",
        )
    _, identified, tid, search = finals[0]
    pose = ranked_pose(
        [final[0] for final in finals],
        search,
        identified.track.xy,
        fps or 0.0,
        gcps is not None,
        gcp_camera,
        max_roll_deg=max_roll_deg,
    )
    clock = row_clock[identified.rows]
    if free:
        pose = _settle_intrinsics(pose, clock, identified.track.xy, path, prior, eps_px, f_scale, gcps, free, unknown_k)
    check_determined(pose, clock, path, gcps is not None)
    return MoverPose(pose, identified, tid, tried)


def _rank(fit: JointFit) -> tuple[int, float]:
    """The order of the refits: most frames within the gate first, then the smallest residual scale."""
    return -fit.support, fit.scale_px


def same_track(a: Identification, b: Identification) -> bool:
    """Whether two identifications found the same track: CONFIRM_SHARE of the larger's detection rows in both."""
    shared = np.intersect1d(a.rows, b.rows, assume_unique=True).size
    return shared >= CONFIRM_SHARE * max(len(a.rows), len(b.rows))


def _confirmed(finals: list[Final]) -> bool:
    """Whether the best refit so far is fitted on a track that another tracklet's pose identifies too."""
    if len(finals) < 2:
        return False
    _, identified, tid, _ = min(finals, key=lambda final: _rank(final[0]))
    return any(other != tid and same_track(identified, found) for _, found, other, _ in finals)


def _settled(final: Final, settle_round: Callable[[Final], Final | None]) -> Final:
    """The final's track identified again under a pose that does not depend on the tracklet it started from, and its
    refit (``settle_round``: ``_settle_round`` with the camera's evidence).

    A merged blob's point is placed within it by the projection under the
    pose the target was identified with (``Identification.merged``), so a
    refit on it keeps part of that pose: tracklets that lead to the same
    frames give refits a few tenths of a frame apart. Each round fits the
    pose and line on the frames whose blob is the target's own (their
    points are the blobs' centres), identifies the target again under that
    pose and refits pose and line on its track; the rounds stop when the
    target's own blobs and their points (within SETTLED_PX) are those the
    round started from, at most SETTLE_ROUNDS. A round is not taken when
    fewer than MIN_FRAMES blobs are the target's own, when a step fails, or
    when its refit leaves the GCPs.
    """
    for _ in range(SETTLE_ROUNDS):
        settled = settle_round(final)
        if settled is None:
            break
        before, after = final[1], settled[1]
        final = settled
        if _own_points_alike(before, after):
            break
    return final


def _own_points_alike(a: Identification, b: Identification) -> bool:
    """Whether two identifications have the same blobs as the target's own, their points within SETTLED_PX."""
    own_a, own_b = ~a.merged, ~b.merged
    return np.array_equal(a.rows[own_a], b.rows[own_b]) and bool(
        np.all(np.abs(a.track.xy[own_a] - b.track.xy[own_b]) <= SETTLED_PX)
    )


def _settle_round(
    final: Final,
    detections: Detections,
    trajectory: Trajectory,
    fps: float | None,
    params: IdentifyParams,
    path: PiecewiseTrajectory,
    prior: SlopePrior | None,
    gcps: GcpPrior | None,
    row_clock: np.ndarray,
) -> Final | None:
    """One round of ``_settled``: the pose on the target's own blobs, the target identified under it, the refit; None
    when it is not taken."""
    refit, identified, tid, search = final
    own = ~identified.merged
    if own.sum() < MIN_FRAMES:
        return None
    eps_px, f_scale, free = params.eps_px, params.f_scale_px, refit.layout.free
    try:
        clock = row_clock[identified.rows][own]
        anchor = fit_pose_and_line(
            refit.camera,
            clock,
            identified.track.xy[own],
            path,
            refit.alpha,
            refit.beta,
            refit.errors[own] <= eps_px,
            eps_px,
            f_scale,
            prior,
            gcps,
            free,
        )
        again = identify_target(anchor.camera, detections, trajectory, fps, params)
        clock = row_clock[again.rows]
        start = reprojection_errors(anchor.camera, clock, again.track.xy, path, anchor.alpha, anchor.beta) <= eps_px
        settled = fit_pose_and_line(
            anchor.camera,
            clock,
            again.track.xy,
            path,
            anchor.alpha,
            anchor.beta,
            start,
            eps_px,
            f_scale,
            prior,
            gcps,
            free,
        )
    except (SyncError, ValueError):
        return None
    if gcps is not None and not gcps_agree(gcps, settled):
        return None
    return settled, again, tid, search


def in_windows(frames: np.ndarray, windows: tuple[tuple[int, int], ...]) -> np.ndarray:
    """(N,) whether each 0-based frame lies in one of the windows ([start, stop), stop excluded)."""
    if not windows:
        return np.zeros(len(frames), bool)
    starts, stops = np.array(sorted(windows), dtype=np.int64).T
    k = np.searchsorted(starts, frames, side="right") - 1
    return (k >= 0) & (frames < np.maximum.accumulate(stops)[np.maximum(k, 0)])


def _movers_with_survey(
    camera: Camera,
    detections: Detections,
    trajectory: Trajectory,
    fps,
    params: IdentifyParams,
    gcps: GcpPrior,
    gcp_camera: Camera,
    finals,
    tried,
    path,
    prior,
    row_clock,
    offsets,
) -> MoverPose:
    """With GCPs: the pose from GCPs and the identified track together, or from the track alone when they conflict
    (``_survey_and_target``), on the first final's track (the best refit's, settled), or on the target identified
    under the GCPs' own pose when no refit kept the GCPs (the target as the GCP pose sees it)."""
    if finals:
        _, identified, tid, _ = finals[0]
    else:
        try:
            identified = identify_target(gcp_camera, detections, trajectory, fps, params)
        except SyncError as exc:
            causes = ", ".join(sorted({c for c in tried.values() if c})) or "no fit"
            raise PoseError(
                camera.name,
                "gcp_conflict",
                f"no tracklet gives a pose that keeps the GCPs ({causes[:120]}), and the target is not found under "
                f"the GCPs' own pose ({exc})",
            ) from None
        tid = -1
    clock = row_clock[identified.rows]
    pose = _survey_and_target(
        camera,
        clock,
        identified.track.xy,
        path,
        prior,
        fps,
        params.eps_px,
        gcps,
        gcp_camera,
        params.f_scale_px,
        params.seed,
        params.delta,
        offsets,
    )
    return MoverPose(pose, identified, tid, tried)


def estimate_pose(
    camera: Camera,
    track: Track | None,
    detections: Detections | None,
    trajectory: Trajectory,
    fps: float | None,
    params: IdentifyParams,
    gcps: GcpPrior | None = None,
    ransac_px: float = 8.0,
    start: Camera | None = None,
    offsets: tuple[float, float] | None = None,
    log_model: LogModel | None = None,
    windows: tuple[tuple[int, int], ...] | None = None,
    max_roll_deg: float | None = None,
) -> tuple[TargetPose, Identification | None]:
    """A camera's pose from the target: from its track when it has one (``pose_from_track``), else from every mover
    (``pose_from_movers``).

    trajectory: the prepared trajectory (the one the sync fits); params:
    identification's parameters (eps_px is the gate, f_scale_px the loss
    scale, rate_sigma the clock prior's width); gcps: GCPs as a prior (with
    4 or more, their own pose is a starting candidate; ransac_px: its
    outlier threshold before widening; start: that pose when already
    known); offsets: the range of beta (clock units) searched, e.g. around
    the scan stage's coarse line (None: all the log allows); windows: the
    scan stage's windows, where a pose from movers looks for the target's
    tracklets (``pose_from_movers``; None: everywhere); log_model: the log's
    error (with a bias, the search from a track fits the bias with the pose,
    and the fits allow the part of it a fixed pose cannot absorb,
    ``pose_from_track``'s); max_roll_deg: without GCPs, the upright-mount
    prior's tolerance (degrees, sync/pose/upright.py; None: off). A camera
    without K gets its intrinsics fitted too. Returns the pose and, from movers, the identification under it.
    Raises PoseError.
    """
    if start is None and gcps is not None and len(gcps.xyz) >= 4:
        try:
            start = gcp_camera(camera, gcps, ransac_px)
        except CalibrationInputError:
            start = None
    if track is None:
        if detections is None:
            raise PoseError(camera.name, "too_few_frames", "neither a track nor any mover's detections")
        found = pose_from_movers(
            camera,
            detections,
            trajectory,
            fps,
            params,
            gcps,
            start,
            offsets=offsets,
            windows=windows,
            max_roll_deg=max_roll_deg,
        )
        return found.pose, found.identification
    clock = camera_clock(track, fps)
    values = clock.clock_at(track.frame, FrameTimes.of_track(track))
    prior = slope_prior(fps, trajectory.rate, params.rate_sigma)
    path = PiecewiseTrajectory(trajectory)
    pose = pose_from_track(
        camera,
        values,
        track.xy,
        path,
        prior,
        fps,
        params.eps_px,
        gcps,
        start,
        (),
        params.f_scale_px,
        params.seed,
        params.delta,
        offsets,
        log_model,
        max_roll_deg,
    )
    return pose, None


METRE_LEVEL_M = 0.3  # a log whose stated median sigma reaches this gives a pose good for timing, not for 3D


def pose_log_sigma(prepared: Trajectory, log_model: LogModel) -> float | None:
    """The log's error a pose from the target absorbs (metres, pose_info's): the median of the prepared log's sigmas,
    at least the model's horizontal bias when it has one; None when neither is known."""
    sigma = None if prepared.sigma is None else float(np.median(prepared.sigma))
    if log_model.has_bias:
        sigma = max(sigma or 0.0, log_model.horizontal_m)
    return sigma


def pose_info(pose: TargetPose, log_sigma_m: float | None) -> PoseInfo:
    """What camera.json says of a pose from the target: its source, uncertainty, and whether it serves 3D.

    The pose absorbs the log's slowly varying error (a consumer GPS's metres
    of bias), so it is as good in 3D as the log: ``for_3d`` only when the
    log states its accuracy (per-fix sigmas) and their median is below
    METRE_LEVEL_M. log_sigma_m: that median, or None when the log states none.
    """
    if log_sigma_m is None:
        for_3d, note = False, "good for timing; in 3D only as good as the log, which states no accuracy"
    elif log_sigma_m >= METRE_LEVEL_M:
        for_3d, note = (
            False,
            f"good for timing, not for 3D: the log's error (median {log_sigma_m:.2g} m) is in the pose",
        )
    else:
        for_3d, note = True, ""
    return PoseInfo(pose.source, round(pose.fit.center_std_m, 4), round(pose.fit.rotation_std_deg, 4), for_3d, note)
