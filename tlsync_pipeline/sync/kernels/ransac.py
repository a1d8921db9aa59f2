"""Robust fit of the line t_c = alpha * t_r + beta in the voting space.

This is the paper's RANSAC (Brito et al., eq. 4): hypotheses from two random
votes, scored by their number of inliers (votes whose distance to the line in
the voting space, |t_c - alpha * t_r - beta| / sqrt(1 + alpha^2), is at most
delta; exact ties go to the smaller sum of inlier distances), then least
squares on the inliers of the best hypothesis. Vectorised with numpy and
deterministic for a given seed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# Hypotheses x votes evaluated at once when counting inliers (memory bound).
_CHUNK_ELEMENTS = 1 << 22
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
    return max(1, math.ceil(math.log(1 - p) / math.log(1 - r**sample_size)))


def distance_to_line(sample, frame, alpha, beta):
    """Orthogonal distance of votes (sample, frame) to frame = alpha * sample + beta (broadcasts)."""
    return np.abs(frame - alpha * sample - beta) / np.sqrt(1.0 + alpha * alpha)


def score_lines(sample: np.ndarray, frame: np.ndarray, alpha: np.ndarray, beta: np.ndarray, delta: float) -> tuple[np.ndarray, np.ndarray]:
    """For each line (alpha[k], beta[k]): its inlier count and the sum of its inliers' distances."""
    counts = np.zeros(len(alpha), dtype=np.int64)
    spread = np.zeros(len(alpha))
    step = max(1, _CHUNK_ELEMENTS // max(1, len(sample)))
    for start in range(0, len(alpha), step):
        a = alpha[start : start + step, None]
        b = beta[start : start + step, None]
        residual = distance_to_line(sample[None, :], frame[None, :], a, b)
        inlier = residual <= delta
        counts[start : start + step] = inlier.sum(axis=1)
        spread[start : start + step] = np.where(inlier, residual, 0.0).sum(axis=1)
    return counts, spread


def best_line(counts: np.ndarray, spread: np.ndarray) -> int:
    """Index of the line with the most inliers; ties go to the smallest sum of inlier distances."""
    return int(np.lexsort((spread, -counts))[0])


def least_squares_line(sample: np.ndarray, frame: np.ndarray) -> tuple[float, float]:
    """Least-squares (alpha, beta) of frame = alpha * sample + beta."""
    design = np.column_stack([sample, np.ones_like(sample)])
    (alpha, beta), *_ = np.linalg.lstsq(design, frame, rcond=None)
    return float(alpha), float(beta)


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
    rng = np.random.default_rng(seed)
    i, j = rng.integers(len(sample), size=(2, n))
    ds = sample[j] - sample[i]
    usable = ds != 0
    alpha = np.divide(frame[j] - frame[i], ds, out=np.zeros(n), where=usable)
    usable &= alpha > 0
    alpha = alpha[usable]
    beta = frame[i[usable]] - alpha * sample[i[usable]]
    if len(alpha) == 0:
        raise ValueError("no increasing line through any two votes: the votes do not move forward in time")
    if len(sample) > SCORE_SUBSET:
        subset = rng.choice(len(sample), SCORE_SUBSET, replace=False)
        rough, rough_spread = score_lines(sample[subset], frame[subset], alpha, beta, delta)
        finalists = np.lexsort((rough_spread, -rough))[:_FINALISTS]
        alpha, beta = alpha[finalists], beta[finalists]
    best = best_line(*score_lines(sample, frame, alpha, beta, delta))
    a, b = float(alpha[best]), float(beta[best])
    inliers = distance_to_line(sample, frame, a, b) <= delta
    for _ in range(5):  # least squares on the inliers until the inlier set settles
        if len(np.unique(sample[inliers])) < 2:
            break
        a, b = least_squares_line(sample[inliers], frame[inliers])
        updated = distance_to_line(sample, frame, a, b) <= delta
        if np.array_equal(updated, inliers) or updated.sum() < 2:
            break
        inliers = updated
    residual = frame[inliers] - a * sample[inliers] - b
    rms = float(np.sqrt(np.mean(residual**2))) if len(residual) else float("nan")
    return LineFit(a, b, inliers, rms, n)
