"""Under a log with a bias, which pose fits of one camera are one timing and which are rivals.

Two fits of a pose from the target (sync/pose/pose_fit.py's JointFit, each
with its own pose and line) give one synchronization when their offsets
differ by less than their betas' stds and the log's bias can explain
together: a bias of sigma metres along the path moves the track's match
by sigma / speed of time, and a pose fitted to the track trades its
rotation against that shift. Such fits are one answer whose interval must
hold them all (``one_timing``; the spread is added to beta's variance).
A fit beyond that band is a rival: it would give another synchronization.
How probable it is against the best is weighed on the track block by
block (``rival_probability``), as sync/solve/rival.py weighs two lines:
frames of a block of BLOCK_S seconds share the log's error and the
tracker's, so a block counts once; each block's mean Student-t loss of its
frames' reprojection errors under either fit, at the looser fit's scale
(a fit that explains a part of the track tightly and misses the rest does
not set the scale the log's wander leaves the right pose at: on drone2
under a phone's GNSS the right pose's scatter was 65 px, a rival's that
explained a third of the track 10 px); the rival's probability is that of
the paired differences (rival minus best) having a mean below zero: their
mean over its standard error is Student-t with blocks - 1 degrees of
freedom (the spread is measured on the blocks themselves: a 16 s visit
has 16, where the normal's tail would put a rival the evidence does not
rule out, 2.3 standard errors off on a phone walk, under 1 %).

Only fitted offsets can be weighed so. Under a metre-level log the search's
coarse pass scores many offsets alike (a pose and the bias's knots absorb
any corner of a turning walk), and only a few of them are fitted: an
offset the coarse pass cannot tell from its top that no fit is one timing
with (``untested_offsets``) is a rival never weighed. Its score is the
count of the search's positions explained; two offsets' counts differ by
the noise of their misses (their sum's square root, as two Poisson
counts), and an offset within NEAR_TOP_Z of that noise below the top is
alike. Such an offset is then fitted (sync/pose/pose.py,
``fitted_untested``), and weighed as any fit: the fit it starts may
converge to the best's timing (on drone2's hovers under a drone's GNSS, an
offset 4 s from the best, beyond the bias's 2 s band, converged to it) or
to a rival the track's blocks weigh.

Clock values in frame units (sync/model/clock.py); pixels; metres.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import stdtr

from tlsync_pipeline.sync.model.log_model import LogModel, log_drift
from tlsync_pipeline.sync.pose.pose_fit import JointFit
from tlsync_pipeline.trajectory import PiecewiseTrajectory

Z95 = 1.959964
DISTINCT_S = 1.0  # offsets closer than this (seconds) are one timing whatever the stds
BLOCK_S = 1.0  # seconds of the camera's clock a block of frames spans
STUDENT_DOF = 4.0  # degrees of freedom of a frame's Student-t loss
MIN_SCALE_PX = 1.0  # the loss's scale is never taken below this (pixels)
MIN_BLOCKS = 3  # fewer blocks than this tell nothing: the rival keeps half the posterior
OFF_TRACK_Z = 6.0  # a frame a fit maps off the log costs the loss of an error this many scales long
SLOWEST_SHARE = 0.1  # a target the log's drift hides is taken as moving at this share of the drift
NEAR_TOP_Z = 1.645  # a coarse offset less than this many standard errors below the top is alike (one-sided 95 %)


def bias_frames(
    fit: JointFit, clock: np.ndarray, path: PiecewiseTrajectory, model: LogModel, rate: float | None = None
) -> float:
    """How far (clock units) the log's bias can move the track's match along the path under the fit's line: the
    median over the fit's inliers of alpha x (the bias's std along the target's motion) / (the target's metres per
    sample); 0 without a bias or where the target does not move. The target's speed is the log's with the bias's
    drift taken out (``LogModel.drift_m_s`` at ``rate`` fixes per second; None: not known, the log's speed as it is):
    a hovering target's log moves with its bias as fast as the target creeps (drone2 at 0.1 m/s under a drone's
    error: its log at 0.7 m/s), and the bias is seconds of timing there, not a fraction. Below the drift the speed is
    not measured: it is taken as SLOWEST_SHARE of the drift."""
    if not model.has_bias:
        return 0.0
    s = (clock[fit.inliers] - fit.beta) / fit.alpha
    run = path.run_of(s)
    on = run >= 0
    if not on.any():
        return 0.0
    velocity = path(s[on], run[on], nu=1)  # metres per sample
    speed = np.linalg.norm(velocity, axis=1)
    moving = speed > 0
    if not moving.any():
        return 0.0
    drift = log_drift(model, rate)  # metres per sample
    own = np.maximum(np.sqrt(np.maximum(speed[moving] ** 2 - drift**2, 0.0)), SLOWEST_SHARE * drift)
    sigma = np.array([model.bias_m, model.bias_m, model.bias_vertical_m])
    along = np.sqrt(((velocity[moving] / speed[moving, None]) ** 2 * sigma**2).sum(axis=1))
    return float(abs(fit.alpha) * np.median(along / np.maximum(own, 1e-12)))


def one_timing(best: JointFit, other: JointFit, bias: float, fps: float) -> bool:
    """Whether the other fit's offset is the best's timing: within DISTINCT_S seconds, or within the 95 % spread of
    the two betas' stds plus ``bias`` (clock units, ``bias_frames``)."""
    return bool(abs(other.beta - best.beta) <= timing_band(best.se_beta, other.se_beta, bias, fps))


def timing_band(se_a: float, se_b: float, bias: float, fps: float) -> float:
    """How far (clock units) two offsets of beta stds ``se_a`` and ``se_b`` may lie and be one timing: DISTINCT_S
    seconds, or the 95 % spread of their difference plus ``bias`` (``bias_frames``), the larger."""
    return max(DISTINCT_S * fps, Z95 * math.hypot(se_a, se_b) + bias)


def timing_spread(best: JointFit, fits: list[JointFit], bias: float, fps: float) -> float:
    """The largest distance (clock units) of a fit that is one timing with the best from the best's beta (0 alone)."""
    return max((abs(f.beta - best.beta) for f in fits if one_timing(best, f, bias, fps)), default=0.0)


def rival_probability(best: JointFit, rival: JointFit, clock: np.ndarray, fps: float) -> float:
    """The rival fit's posterior probability against the best's (equal prior odds) on the track's blocks (see the
    module); clock: each tracked frame's clock value, the fits' ``errors`` being per frame."""
    block = np.floor((clock - clock.min()) / (BLOCK_S * fps)).astype(np.int64)
    block = np.unique(block, return_inverse=True)[1].ravel()
    blocks = int(block.max()) + 1 if len(block) else 0
    if blocks < MIN_BLOCKS:
        return 0.5
    scale = max(MIN_SCALE_PX, best.scale_px, rival.scale_px)
    count = np.bincount(block, minlength=blocks)

    def losses(fit: JointFit) -> np.ndarray:
        z2 = np.where(np.isfinite(fit.errors), fit.errors / scale, OFF_TRACK_Z) ** 2
        loss = 0.5 * (STUDENT_DOF + 2.0) * np.log1p(z2 / STUDENT_DOF)
        return np.bincount(block, loss, minlength=blocks) / count

    difference = losses(rival) - losses(best)
    spread = float(np.std(difference, ddof=1)) * math.sqrt(blocks)
    if spread <= 0.0:
        return 0.5
    return float(stdtr(blocks - 1, -float(difference.sum()) / spread))


def untested_offsets(
    betas: np.ndarray,
    support: np.ndarray,
    points: int,
    fits: list[JointFit],
    best: JointFit,
    bias: float,
    fps: float,
    fitted_at: tuple[float, ...] = (),
) -> np.ndarray:
    """The offsets (clock units) of the search's coarse pass (``betas`` ascending, ``support``: explained positions of
    ``points``) alike with its top (see the module), one per timing, that no fit is one timing with and no pose was
    fitted from (``fitted_at``: offsets a fit started at, wherever it converged); empty when each was fitted. Only the
    profile's local maxima are offsets of their own (a peak's shoulders are its timing), and a timing spans the band
    ``one_timing`` gives two fits of the best's beta std."""
    band = timing_band(best.se_beta, best.se_beta, bias, fps)
    support = np.where(np.isfinite(support), np.asarray(support, dtype=np.float64), -np.inf)
    if not np.isfinite(support).any():
        return np.zeros(0)
    padded = np.concatenate([[-np.inf], support, [-np.inf]])
    peak = np.isfinite(support) & (support >= padded[:-2]) & (support >= padded[2:])
    top = float(support.max())
    alike: list[float] = []
    for k in np.flatnonzero(peak)[np.argsort(-support[peak], kind="stable")]:
        misses = max(2.0 * points - top - float(support[k]), 1.0)
        if (top - float(support[k])) / math.sqrt(misses) >= NEAR_TOP_Z:
            break
        beta = float(betas[k])
        if all(abs(beta - b) > band for b in alike):
            alike.append(beta)
    fitted = np.array([f.beta for f in fits] + list(fitted_at))
    return np.array([b for b in alike if not np.any(np.abs(fitted - b) <= band)])
