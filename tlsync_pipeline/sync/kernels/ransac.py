"""Robust fit of the line t_c = alpha * t_r + beta in the voting space.

This is the paper's RANSAC (Brito et al., eq. 4): hypotheses from two random
votes, scored by their number of inliers (votes whose distance to the line in
the voting space, |t_c - alpha * t_r - beta| / sqrt(1 + alpha^2), is at most
delta; exact ties go to the smaller sum of inlier distances), then least
squares on the inliers of the best hypothesis: the robust fit of
sync/kernels/robust.py over lines (``LineModel``). Vectorised with numpy and
deterministic for a given seed.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from tlsync_pipeline.sync.kernels.robust import (
    Draws,
    InlierCount,
    Preemption,
    iterations,
    polish,
    robust_fit,
    uniform_samples,
    within,
)

# Above this many votes, hypotheses are first scored on a random subset of
# this size and only the best few are scored on all votes (preemptive RANSAC).
SCORE_SUBSET = 20_000
_FINALISTS = 32


@dataclass(frozen=True)
class LineFit:
    """A fitted line frame = alpha * sample + beta.

    inliers: boolean mask over the votes; residual_rms: RMS frame residual of
    the inliers; iterations: hypotheses drawn.
    """

    alpha: float
    beta: float
    inliers: np.ndarray
    residual_rms: float
    iterations: int

    @property
    def n_inliers(self) -> int:
        return int(self.inliers.sum())


def ransac_iterations(p: float, r: float, sample_size: int = 2) -> int:
    """Iterations needed to draw an all-inlier sample with probability p (eq. 4).

    r is the expected inlier ratio of the votes.
    """
    if not (0 < p < 1 and 0 < r <= 1):
        raise ValueError(f"need 0 < p < 1 and 0 < r <= 1, got p={p}, r={r}")
    if r == 1:
        return 1
    return iterations(p, r, sample_size)


def distance_to_line(sample, frame, alpha, beta):
    """Orthogonal distance of votes (sample, frame) to frame = alpha * sample + beta (broadcasts)."""
    return np.abs(frame - alpha * sample - beta) / np.sqrt(1.0 + alpha * alpha)


def least_squares_line(sample: np.ndarray, frame: np.ndarray) -> tuple[float, float]:
    """Least-squares (alpha, beta) of frame = alpha * sample + beta."""
    design = np.column_stack([sample, np.ones_like(sample)])
    (alpha, beta), *_ = np.linalg.lstsq(design, frame, rcond=None)
    return float(alpha), float(beta)


@dataclass(frozen=True)
class LineModel:
    """Lines frame = alpha * sample + beta over votes (sample, frame), the model class of the robust fit
    (sync/kernels/robust.py): a model is (alpha, beta); a row's residual is its orthogonal distance.

    A minimal sample is two votes; only increasing lines are hypotheses
    (clocks do not run backwards). line_fit: the fit to a set of votes
    (least squares); increasing: a fit that is not increasing is refused.
    """

    sample: np.ndarray
    frame: np.ndarray
    line_fit: Callable[[np.ndarray, np.ndarray], tuple[float, float]] = least_squares_line
    increasing: bool = False

    @property
    def rows(self) -> int:
        return len(self.sample)

    def estimate(self, samples: np.ndarray) -> np.ndarray:
        """(k, 2) lines through the pairs of votes (2, n) that give an increasing one."""
        i, j = samples
        ds = self.sample[j] - self.sample[i]
        usable = ds != 0
        alpha = np.divide(self.frame[j] - self.frame[i], ds, out=np.zeros(len(i)), where=usable)
        usable &= alpha > 0
        alpha = alpha[usable]
        return np.column_stack([alpha, self.frame[i[usable]] - alpha * self.sample[i[usable]]])

    def residuals(self, model: np.ndarray) -> np.ndarray:
        return distance_to_line(self.sample, self.frame, model[0], model[1])

    def residuals_many(self, models: np.ndarray, rows: np.ndarray | None) -> np.ndarray:
        sample, frame = (self.sample, self.frame) if rows is None else (self.sample[rows], self.frame[rows])
        return distance_to_line(sample[None, :], frame[None, :], models[:, :1], models[:, 1:])

    def refit(self, rows: np.ndarray) -> np.ndarray | None:
        """line_fit on the votes (mask); None with fewer than 2 distinct samples, or a line not increasing if asked."""
        sample = self.sample[rows]
        if not rows.any() or np.ptp(sample) == 0:
            return None
        alpha, beta = self.line_fit(sample, self.frame[rows])
        if self.increasing and not alpha > 0:
            return None
        return np.array([alpha, beta])


def fit_line_ransac(
    sample: np.ndarray,
    frame: np.ndarray,
    delta: float = 0.5,
    p: float = 0.99,
    r: float = 0.05,
    seed: int = 0,
) -> LineFit:
    """The paper's RANSAC line fit over votes (sample t_r, frame t_c).

    Only increasing lines (alpha > 0) are hypotheses: clocks do not run
    backwards. Raises ValueError with fewer than 2 distinct samples.
    """
    sample = np.asarray(sample, dtype=np.float64)
    frame = np.asarray(frame, dtype=np.float64)
    if len(np.unique(sample)) < 2:
        raise ValueError("the votes cover fewer than 2 distinct target samples: no line can be fitted")
    n = ransac_iterations(p, r)
    model = LineModel(sample, frame)
    # All n hypotheses at once, the subset drawn after them; ties go to the smaller sum of inlier distances.
    draws, preemption = Draws(n), Preemption(SCORE_SUBSET, _FINALISTS, first=False)
    rng, score = np.random.default_rng(seed), InlierCount(delta, spread=True)
    best = robust_fit(model, rng, uniform_samples(len(sample), 2), score, draws, preemption)
    if best is None:
        raise ValueError("no increasing line through any two votes: the votes do not move forward in time")
    polished = polish(model, within(delta), 5, start=best.model, min_inliers=2)  # until the inlier set settles
    assert polished is not None, "a polish from a model always has one"
    a, b = float(polished.model[0]), float(polished.model[1])
    inliers = polished.inliers
    residual = frame[inliers] - a * sample[inliers] - b
    rms = float(np.sqrt(np.mean(residual**2))) if len(residual) else float("nan")
    return LineFit(a, b, inliers, rms, n)
