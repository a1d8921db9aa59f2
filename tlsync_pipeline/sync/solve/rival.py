"""How probable a rival line is against the best one, on all of a camera's evidence with the log's bias absorbed.

The line search reports its best line and the best line without its votes
(a rival). With a wide vote radius (a metre-level log) a single pass leaves
a blob of votes that holds more than one line, so support alone cannot tell
a second pass from the first seen through a wide radius. Here each line is
judged by how well it explains the whole track: under the line
clock = alpha x sample + beta, each tracked frame's sample is the logged
path's point; that point, moved by a bias of the log, is projected and
compared with the tracked position. The bias is what the log's error model
allows (sync/model/log_model.py): a Gauss-Markov bias, linear between knots
a correlation time apart over the visit under the process's prior, the knots
correlated as it has them (sync/pose/pose_bias.py's VisitBias; a constant
for a camera of unknown fps). Finer knots bend a wrong line onto the track
as well as the right one (on phone walk scenes, a quarter of a correlation
time left rivals of two cameras above 1 %). It is fitted for
each line (Gauss-Newton, iteratively reweighted), with its prior; so are a
few intercepts around each line (the band the vote radius spans: the line
search's line is only as close as its votes).

The track's frames are grouped in blocks of BLOCK_S seconds (at least one
interval between two fixes of the log): frames of a block share the log's
white error and the tracker's, so a block counts once. A block's mean
residual scores a Student-t loss at the scale the better line's blocks show
(robust, at least MIN_SCALE_PX): the image positions, the target's image
speed and direction along the path all enter, since a line that maps the
track onto the wrong part of the path cannot be bent onto it by a bias that
moves slowly. A block a line maps outside the log costs the loss at
OUTSIDE_Z scales. The rival's probability is that of the paired blocks'
loss differences (rival minus best, plus the two bias priors' difference)
having a mean below zero: Phi(-sum / (sd x sqrt(blocks))). A sum over
independent blocks would be the log of the likelihood ratio, but two
stretches of a log walked alike carry independent white errors, and their
ratio swings by several units when neither line is better; the paired
spread measures that swing, so two passes alike stay near 1/2 and a rival
that misses the track block after block goes to 0.

The line search's rival is the best line its votes hold besides the
winner. Under a metre-level bias at a camera's depth the votes hold little
(drone2 under a phone's 2 m, a 900 px vote radius: the right line had
fewer distinct frames with a vote near it than a line 21 s off, and 15
windows 50-90 s off had more), so the track itself is searched too
(``scanned_line``): the bias-absorbed score of each intercept at the line's
slope, SCAN_STEP_S apart over every start that maps at least half the
track inside the log, on at most SCAN_FRAMES of its frames. Its best,
when it lies beyond the band of the line, is a rival weighed as the line
search's is.

Two lines whose profiled intercepts come within the band of each other
are one line seen through a wide vote radius (the line search's two lines
are the ends of one pass's blob of votes): no second answer. The one line
is the better scored of the two profiles, so the rival's probability is 0
when the best line's profile scores better and 1 otherwise (the camera is
then refitted on the rival's votes).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from calibration.camera import Camera
from tlsync_pipeline.sync.model.log_model import LogModel
from tlsync_pipeline.sync.pose.pose_bias import VisitBias
from tlsync_pipeline.trajectory import PiecewiseTrajectory

BLOCK_S = 1.0  # seconds of the camera's clock a block of frames spans (at least one fix interval of the log)
BLOCK_FRAMES = 30  # the same for a camera of unknown fps
STUDENT_DOF = 4.0  # degrees of freedom of the blocks' Student-t loss: a few blocks off (a tracker slip) cost little
MIN_SCALE_PX = 1.0  # the blocks' scale is never taken below this (pixels)
OUTSIDE_Z = 6.0  # a block the line maps outside the log costs the loss of a residual this many scales long
BIAS_FLOOR_M = (1.0, 2.0)  # horizontal and vertical bias std allowed at least, whatever the model (an undeclared log)
MIN_BLOCKS = 3  # fewer blocks than this tell nothing: the rival keeps half the posterior
SCAN_STEP_S = 1.0  # seconds of the camera's clock between two intercepts the scan tries
SCAN_STEPS = 600  # most intercepts the scan tries (wider steps over a longer log)
SCAN_FRAMES = 120  # most tracked frames the scan scores each intercept on (evenly spread over the track)
SCAN_COARSE_ROUNDS = 2  # IRLS rounds of the scan's first pass over every intercept
SCAN_FINE = 8  # intercepts of best first-pass score the scan fits in full
PROFILE_STEPS = 9  # intercepts tried on each side of a line, across the band of its votes
IRLS_ROUNDS = 4
JACOBIAN_STEP_M = 0.01


@dataclass(frozen=True)
class LineScore:
    """A line's fit to the track: its intercept after the profile, its score (the blocks' losses and the bias prior's
    -log density), the log's bias fitted at the visit's middle (the logged point minus the target's, metres, ENU) and
    the
    blocks' median residual (pixels)."""

    beta: float
    score: float
    bias_m: tuple[float, float, float]
    median_px: float


@dataclass(frozen=True)
class RivalOdds:
    """The best line's and the rival's scores, and the rival's posterior probability (equal prior odds)."""

    best: LineScore
    rival: LineScore
    rival_probability: float
    joined: bool = False  # the profiled lines came within the band of each other: one line, not two
    scanned: tuple[float, float] | None = None  # the rival's line (alpha, beta) when the scan found it


def bias_sigmas(model: LogModel) -> np.ndarray:
    """(3,) std of the log's bias per ENU axis (metres): the model's, at least BIAS_FLOOR_M."""
    return np.array([max(model.bias_m, BIAS_FLOOR_M[0])] * 2 + [max(model.bias_vertical_m, BIAS_FLOOR_M[1])])


def rival_odds(
    camera: Camera,
    clock: np.ndarray,
    xy: np.ndarray,
    path: PiecewiseTrajectory,
    best: tuple[float, float],
    rival: tuple[float, float],
    model: LogModel,
    fps: float | None,
    rate: float | None,
    band_frames: float,
) -> RivalOdds:
    """The two lines (alpha, beta) on the camera's track (clock: each tracked frame's clock value; xy: its pixels).

    band_frames: half the width (clock units) of the band of votes one line
    spans: each line's intercept is profiled over +-band_frames.
    """
    clock = np.asarray(clock, dtype=np.float64)
    xy = np.asarray(xy, dtype=np.float64)
    context = _Context(camera, path, clock, xy, _blocks(clock, fps, rate), _visit_bias(clock, fps, model))
    fits = [context.profile(alpha, beta, band_frames) for alpha, beta in (best, rival)]
    scale = max(MIN_SCALE_PX, min(f.scale for f in fits))
    (best_score, best_loss), (rival_score, rival_loss) = (context.score(f, scale) for f in fits)
    if _apart(clock, best[0], fits[0].beta, rival[0], fits[1].beta) <= band_frames:
        return RivalOdds(best_score, rival_score, 0.0 if best_score.score <= rival_score.score else 1.0, joined=True)
    difference = rival_loss - best_loss
    prior = (rival_score.score - float(rival_loss.sum())) - (best_score.score - float(best_loss.sum()))
    spread = float(np.std(difference, ddof=1)) * math.sqrt(len(difference)) if len(difference) >= MIN_BLOCKS else 0.0
    if spread <= 0.0:
        return RivalOdds(best_score, rival_score, 0.5)
    probability = 0.5 * math.erfc((float(difference.sum()) + prior) / spread / math.sqrt(2.0))
    return RivalOdds(best_score, rival_score, probability)


def scanned_line(
    camera: Camera,
    clock: np.ndarray,
    xy: np.ndarray,
    path: PiecewiseTrajectory,
    alpha: float,
    model: LogModel,
    fps: float,
    rate: float | None,
) -> float | None:
    """The intercept (clock units) at slope ``alpha`` whose bias-corrected fit scores the track best (see the module),
    among starts SCAN_STEP_S apart (at most SCAN_STEPS of them) that map at least half the track inside the log,
    scored on at most SCAN_FRAMES tracked frames: every start after SCAN_COARSE_ROUNDS rounds of its fit, the
    SCAN_FINE best fitted in full; None when no start does."""
    clock = np.asarray(clock, dtype=np.float64)
    rows = np.unique(np.linspace(0, len(clock) - 1, min(SCAN_FRAMES, len(clock))).round().astype(np.int64))
    c, uv = clock[rows], np.asarray(xy, dtype=np.float64)[rows]
    middle = float(np.median(c))
    lo = middle - alpha * float(path.ends.max())
    hi = middle - alpha * float(path.starts.min())
    step = max(SCAN_STEP_S * fps, (hi - lo) / SCAN_STEPS)
    context = _Context(camera, path, c, uv, _blocks(c, fps, rate), _visit_bias(c, fps, model))
    coarse = _mapped([context.fit(alpha, beta, SCAN_COARSE_ROUNDS) for beta in np.arange(lo, hi + step, step)])
    if not coarse:
        return None
    scale = max(MIN_SCALE_PX, float(np.median([f.scale for f in coarse])))
    coarse.sort(key=lambda f: context.score(f, scale)[0].score)
    fine = _mapped([context.fit(alpha, f.beta) for f in coarse[:SCAN_FINE]]) or coarse[:1]
    return min(fine, key=lambda f: context.score(f, scale)[0].score).beta


def _mapped(fits: list[_Fit]) -> list[_Fit]:
    """The fits with a finite scale that map at least half the frames inside the log."""
    return [f for f in fits if np.isfinite(f.scale) and np.isfinite(f.residual[:, 0]).mean() >= 0.5]


def _blocks(clock: np.ndarray, fps: float | None, rate: float | None) -> np.ndarray:
    """Each frame's block (0, 1, ...: BLOCK_S seconds of the camera's clock, at least one interval between fixes)."""
    per_block = BLOCK_S * fps if fps else BLOCK_FRAMES
    if fps and rate:
        per_block = max(per_block, fps / rate)
    block = np.floor((clock - clock.min()) / per_block).astype(np.int64)
    return np.unique(block, return_inverse=True)[1].ravel()


def _visit_bias(clock: np.ndarray, fps: float | None, model: LogModel) -> VisitBias:
    """The log's bias over the track's frames at clock values ``clock``: knots a correlation time apart under the
    model's Gauss-Markov prior, its std at least BIAS_FLOOR_M; one constant knot when the fps, hence the visit's
    seconds, is unknown."""
    sigma = bias_sigmas(model)
    if not fps:
        none = np.zeros(len(clock), dtype=np.int64)
        return VisitBias(none, none, np.zeros(len(clock)), np.diag(1.0 / sigma**2), 0.0)
    floored = replace(model, bias_m=float(sigma[0]), bias_vertical_m=float(sigma[2]))
    return VisitBias.over(clock, fps, floored, max(model.tau_s, BLOCK_S))


@dataclass(frozen=True)
class _Fit:
    beta: float
    residual: np.ndarray  # (B, 2) block mean residuals (pixels), NaN for blocks outside the log
    bias: np.ndarray  # (K, 3) the bias at the knots (metres; minus the log's error)
    scale: float  # robust scale of the inside blocks' residuals


class _Context:
    """One camera's track and the log's path, for scoring lines."""

    def __init__(self, camera, path, clock, xy, block, bias: VisitBias):
        self.camera, self.path, self.clock, self.xy, self.block, self.bias = camera, path, clock, xy, block, bias
        self.blocks = int(block.max()) + 1
        self.count = np.bincount(block, minlength=self.blocks).astype(np.float64)
        self.middle = int(np.argmin(np.abs(clock - np.median(clock))))  # the frame at the visit's middle

    def profile(self, alpha: float, beta: float, band: float) -> _Fit:
        """The intercept within +-band of beta whose bias-corrected fit has the least loss at the scale of the
        intercepts' best fit (each at its own scale, a fit whose every block is far off would look as good)."""
        fits = [self.fit(alpha, b) for b in beta + np.linspace(-band, band, 2 * PROFILE_STEPS + 1)]
        scales = [f.scale for f in fits if np.isfinite(f.scale)]
        if not scales:
            return fits[PROFILE_STEPS]
        scale = max(MIN_SCALE_PX, min(scales))
        return min(fits, key=lambda f: self.score(f, scale)[0].score if np.isfinite(f.scale) else np.inf)

    def _mean(self, values: np.ndarray) -> np.ndarray:
        """Per-block mean of per-frame rows."""
        out = np.zeros((self.blocks, values.shape[1]))
        for k in range(values.shape[1]):
            out[:, k] = np.bincount(self.block, values[:, k], minlength=self.blocks)
        return out / self.count[:, None]

    def _at_frames(self, values: np.ndarray) -> np.ndarray:
        """(N, 3) the bias at each frame from its (K, 3) knot values."""
        u = self.bias.weight[:, None]
        return (1.0 - u) * values[self.bias.left] + u * values[self.bias.right]

    def _block_jacobian(self, d: np.ndarray) -> np.ndarray:
        """(B, 2, 3K) per-block mean of the pixels' derivative in the knots' values, from (N, 2, 3) pixels per metre."""
        knots = self.bias.knots
        out = np.zeros(self.blocks * knots * 6)
        for index, share in ((self.bias.left, 1.0 - self.bias.weight), (self.bias.right, self.bias.weight)):
            flat = ((self.block * knots + index)[:, None] * 6 + np.arange(6)).ravel()
            out += np.bincount(flat, (d.reshape(-1, 6) * share[:, None]).ravel(), minlength=len(out))
        jac = out.reshape(self.blocks, knots, 2, 3).transpose(0, 2, 1, 3).reshape(self.blocks, 2, 3 * knots)
        return jac / self.count[:, None, None]

    def fit(self, alpha: float, beta: float, rounds: int = IRLS_ROUNDS) -> _Fit:
        """The bias at the knots of the line, fitted by ``rounds`` of iteratively reweighted Gauss-Newton with its
        prior (the residuals are those before the last round's step)."""
        s = (self.clock - beta) / alpha
        run = self.path.run_of(s)
        inside = run >= 0
        bias = np.zeros((self.bias.knots, 3))
        if inside.sum() < 2:
            return _Fit(beta, np.full((self.blocks, 2), np.nan), bias, np.inf)
        point = np.full((len(s), 3), np.nan)
        point[inside] = self.path(s[inside], run[inside])
        block_inside = np.bincount(self.block[inside], minlength=self.blocks) == self.count
        precision = self.bias.precision
        residual = np.full((self.blocks, 2), np.nan)
        scale = np.inf
        for _ in range(rounds):
            moved = np.nan_to_num(point + self._at_frames(bias))  # the log corrected: bias is minus the log's error
            uv, valid = self.camera.project(moved)
            r = self.xy - uv
            ok = block_inside & (np.bincount(self.block[valid & inside], minlength=self.blocks) == self.count)
            d = np.zeros((len(s), 2, 3))
            for a in range(3):
                step = np.zeros(3)
                step[a] = JACOBIAN_STEP_M
                plus, _ = self.camera.project(moved + step)
                d[:, :, a] = (plus - uv) / JACOBIAN_STEP_M
            residual = np.where(ok[:, None], self._mean(np.nan_to_num(r)), np.nan)
            if ok.sum() < 2:
                return _Fit(beta, residual, bias, np.inf)
            scale = _robust_scale(residual[ok])
            j_block = self._block_jacobian(np.nan_to_num(d))[ok]
            z2 = np.sum(residual[ok] ** 2, axis=1) / max(scale, MIN_SCALE_PX) ** 2
            weight = (STUDENT_DOF + 2.0) / (STUDENT_DOF + z2) / max(scale, MIN_SCALE_PX) ** 2
            normal = np.einsum("b,bij,bik->jk", weight, j_block, j_block) + precision
            rhs = np.einsum("b,bij,bi->j", weight, j_block, residual[ok]) - precision @ bias.ravel()
            bias = bias + np.linalg.solve(normal, rhs).reshape(-1, 3)
        return _Fit(beta, residual, bias, scale)

    def score(self, fit: _Fit, scale: float) -> tuple[LineScore, np.ndarray]:
        """The line's score and each block's loss: the Student-t loss of its residual at ``scale``, OUTSIDE_Z scales for
        a block outside the log; the score adds the bias prior's -log density."""
        inside = np.isfinite(fit.residual[:, 0])
        z2 = np.where(inside, np.sum(np.nan_to_num(fit.residual) ** 2, axis=1) / scale**2, OUTSIDE_Z**2)
        loss = 0.5 * (STUDENT_DOF + 2.0) * np.log1p(z2 / STUDENT_DOF)
        values = fit.bias.ravel()
        prior = 0.5 * float(values @ self.bias.precision @ values)
        median = float(np.median(np.linalg.norm(fit.residual[inside], axis=1))) if inside.any() else float("inf")
        at_middle = self._at_frames(fit.bias)[self.middle]
        bias = (-float(at_middle[0]), -float(at_middle[1]), -float(at_middle[2]))
        return LineScore(fit.beta, float(loss.sum()) + prior, bias, median), loss


def _apart(clock: np.ndarray, alpha: float, beta: float, other_alpha: float, other_beta: float) -> float:
    """How far (clock units) the other line lies from the line at the middle of the track's clock values."""
    sample = (float(np.median(clock)) - beta) / alpha
    return abs(other_alpha * sample + other_beta - float(np.median(clock)))


def _robust_scale(residual: np.ndarray) -> float:
    """Per-axis std of 2-D residuals from their median length (Rayleigh: median = sigma sqrt(2 ln 2))."""
    return float(np.median(np.linalg.norm(residual, axis=1)) / math.sqrt(2.0 * math.log(2.0)))
