"""Poses from the target fitted again under the log's bias that every camera's line estimates together.

A pose fitted to the target under a log with a bias (sync/pose/pose.py)
absorbs the bias's mean over its visit and takes its wander as noise, and
its line moves with it: on drone2 flown at 1.9 m/s at most, without poses,
under a drone's GNSS, the poses were 1.6-7 m and 2-11 degrees off and the
lines 1-11 frames (docs/accuracy.md). Each camera alone cannot tell its
timing from the bias's wander along the path: the line fitted with the bias
over one visit was as far off with the true pose held. The bias is the
same target's for every camera, and cameras that see it at the same time
from different directions tell it apart: the joint fit of every line with
the bias (sync/solve/log_bias.py) estimates it. Each pose from the target is
then fitted again with its line (sync/pose/pose_fit.py) on the log
corrected by that estimate, and the joint fit is made again on the poses so
refitted, ROUNDS times (LATER_ROUNDS in synchronize()'s later passes, whose
log the pass before corrected with these poses free); the caller's joint
fit on the last poses gives the
lines, and their pictures are drawn on the log corrected by the bias the
poses were last refitted on (PoseRefit.correction, Timeline.log_correction).
Their intervals add the last refit's covariance of its line (the joint fit
holds the poses fixed) and keep beta's variance at least the pose alone's
(synchronize's ``_with_pose_cov``). A camera synchronized
alone has no other camera to tell the bias apart with: synchronize() leaves
its pose and line as the target gave them.

With the poses held, the joint fit takes their error for the bias and is
sure of it; where the target hovers a bias of centimetres is seconds, and
the refit drags the lines with it (drone2's hover-only tracks: 30-70 frames
off, joint stds of 4-11 frames). The refit is kept only where its lines stay
where the poses alone allow (refit_kept: each line's move from its pose
alone's, in that line's std, at most MAX_MOVE; on drone2 the largest was
1.1-4.3 where the hovers' refit went wrong, 0.3-0.8 on the flight creeping
at 1.9 m/s);
otherwise synchronize() keeps every pose and line as the target gave them, and
synchronizes again on the log corrected by the bias fitted with those poses
free (sync/solve/pose_joint.py).
The refit is given up before its last poses' refit and the caller's fit
where the last round's joint fit already moves a line beyond GIVE_UP_MOVE of
its std (refit_hopeless): on drone2's 15 variants (4 and 7 cameras, a
drone's and a phone's log) the caller's fit moved the largest line 0.66-1.40
times as far as that one, never the 0.4 a kept refit would need from there;
the earlier rounds' fits are no guide (down to 0.52 and 0.20 times: the
hover-only tracks' seed 2 moved 3.2, 1.2, 0.75 stds, and was kept at 0.66).

Clock units: frames (sync/model/clock.py); pixels as tracked; world metres.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from tlsync_pipeline.sync.identify.identify import identify_params
from tlsync_pipeline.sync.kernels.slope import slope_prior
from tlsync_pipeline.sync.model.log_model import LogModel
from tlsync_pipeline.sync.model.methods import method_options
from tlsync_pipeline.sync.model.params import SyncParams
from tlsync_pipeline.sync.pose.pose_fit import fit_pose_and_line, reprojection_errors
from tlsync_pipeline.sync.solve.log_bias import LogBias
from tlsync_pipeline.sync.solve.methods import CameraData, JointMethod
from tlsync_pipeline.sync.timeline import CameraLine, LogCorrection
from tlsync_pipeline.trajectory import PiecewiseTrajectory, Trajectory

ROUNDS = 3  # joint fits before the caller's, each followed by the poses' refit (drone2: settled by the third)
LATER_ROUNDS = 2  # the same in synchronize()'s later passes, on a log the pass before corrected with these poses free
GATE_MEDIANS = 3.0  # a frame enters the pose's refit within this many median reprojection errors (at least eps_px)
MAX_MOVE = 1.0  # the refit is kept when each line's move from its pose alone's is at most this many of its std
GIVE_UP_MOVE = 2.5  # the refit is given up when the last round's joint fit moves a line beyond this many stds


def bias_correction(bias: LogBias, source: str = "bias_refit") -> LogCorrection:
    """The log's correction by the bias's estimate (the joint fit models the true position as the log's plus it),
    ``source`` as LogCorrection's."""
    return LogCorrection(bias.knots, bias.values, source)


def refit_pose(
    data: CameraData, line: CameraLine, path: PiecewiseTrajectory, params: SyncParams, rate: float | None
) -> tuple[CameraData, CameraLine, np.ndarray] | None:
    """The camera's pose and line fitted together on ``path`` (the corrected log), from its pose and line, and that
    fit's (2, 2) covariance of (alpha, beta); the frames within GATE_MEDIANS of their median reprojection error (at
    least eps_px). None when the fit fails, does not converge or has no finite covariance of its line."""
    errors = reprojection_errors(data.camera, data.track_clock, data.track.xy, path, line.alpha, line.beta)
    finite = np.isfinite(errors)
    if not finite.any():
        return None
    gate = max(params.eps_px, GATE_MEDIANS * float(np.median(errors[finite])))
    try:
        fit = fit_pose_and_line(
            data.camera,
            data.track_clock,
            data.track.xy,
            path,
            line.alpha,
            line.beta,
            errors <= gate,
            gate,
            identify_params(params).f_scale_px,
            slope_prior(data.fps, rate, params.rate_sigma),
        )
    except ValueError:
        return None
    if not fit.converged or fit.line_cov is None or not np.isfinite(fit.line_cov).all():
        return None
    camera = replace(data.camera, R=fit.camera.R, t=fit.camera.t)
    return replace(data, camera=camera), replace(line, alpha=fit.alpha, beta=fit.beta), fit.line_cov


@dataclass(frozen=True)
class PoseRefit:
    """The poses' refit (refit_poses): every camera's data and line, those of the cameras posed from the target
    refitted, each refitted camera's last refit's (2, 2) covariance of (alpha, beta), for its interval, and the
    correction of the log the poses were last refitted on (the last round's bias estimate; None when no round fitted a
    bias): the log their pictures are drawn on."""

    data: dict[str, CameraData]
    lines: dict[str, CameraLine]
    covs: dict[str, np.ndarray]
    correction: LogCorrection | None = None


def refit_poses(
    method: JointMethod,
    data: dict[str, CameraData],
    lines: dict[str, CameraLine],
    posed: set[str],
    prepared: Trajectory,
    params: SyncParams,
    log_model: LogModel,
    rounds: int = ROUNDS,
) -> PoseRefit | None:
    """The cameras' data and lines with the poses of the cameras ``posed`` from the target refitted under the log's
    bias (the module): ``rounds`` joint fits of every camera's line with the bias, each followed by each such pose and
    its line fitted on the log corrected by the bias's estimate. A camera whose refit fails keeps its pose and line
    (and has no covariance). Unchanged when the joint fit gives no bias; None, given up, when the last round's joint
    fit has already left the poses alone's lines too far to be kept (refit_hopeless)."""
    alone, middles = lines, track_middles(data, posed)
    data, lines = dict(data), dict(lines)
    covs: dict[str, np.ndarray] = {}
    correction = None
    for round_ in range(rounds):
        fitted, bias = method.refine_with_log_bias(data, lines, prepared, params, method_options(params), log_model)
        if bias is None:
            break
        last = round_ == rounds - 1
        if last and refit_hopeless(line_moves(middles, alone, {n: fitted[n] for n in posed if n in fitted})):
            return None
        correction = bias_correction(bias)
        path = PiecewiseTrajectory(correction.applied(prepared))
        for name in posed:
            refit = refit_pose(data[name], fitted.get(name, lines[name]), path, params, prepared.rate)
            if refit is not None:
                data[name], covs[name] = refit[0], refit[2]
                lines[name] = replace(lines[name], alpha=refit[1].alpha, beta=refit[1].beta)
    return PoseRefit(data, lines, covs, correction)


def track_middles(data: dict[str, CameraData], names: set[str]) -> dict[str, float]:
    """Each named camera's middle tracked clock value (frames), where line_moves measures its line's move."""
    return {n: float(np.median(data[n].track_clock)) for n in names}


def line_moves(
    middles: dict[str, float], alone: dict[str, CameraLine], refitted: dict[str, CameraLine]
) -> dict[str, float]:
    """Each camera's line moved by the refit (``refitted``) from its pose alone's (``alone``) at the camera's middle
    tracked clock value (``middles``, frames), over the pose alone's std there; the cameras whose line alone has no
    finite covariance are left out."""
    moves = {}
    for name, line in refitted.items():
        before, middle = alone[name], middles[name]
        if before.cov is None or not np.isfinite(before.cov).all():
            continue
        sample = (middle - before.beta) / before.alpha
        moved = middle - (line.alpha * sample + line.beta)  # frames between the two lines at that sample
        g = np.array([sample, 1.0])
        std = float(np.sqrt(max(g @ np.asarray(before.cov, dtype=np.float64) @ g, 0.0)))
        moves[name] = abs(moved) / std if std > 0 else np.inf
    return moves


def refit_kept(moves: dict[str, float]) -> bool:
    """Whether the refit's lines stay where the poses alone allow: each line's move in its std (line_moves) at most
    MAX_MOVE."""
    return bool(moves) and max(moves.values()) <= MAX_MOVE


def refit_hopeless(moves: dict[str, float]) -> bool:
    """Whether the refit is given up at the last round's joint fit (line_moves of its lines): a line moved beyond
    GIVE_UP_MOVE of its std, or no line's move can be measured (nor will the caller's fit's be, for refit_kept)."""
    return not moves or max(moves.values()) > GIVE_UP_MOVE
