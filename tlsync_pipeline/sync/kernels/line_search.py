"""Robust search for the line frame = alpha * sample + beta in the voting space.

The default method's replacement for the paper's RANSAC, for voting spaces
where the true line holds only 1-2 % of the votes (a hovering target makes
each of its frames vote for hundreds of samples; a path that crosses itself
adds blobs and false lines):

1. thinning: only the best vote (smallest pixel distance) of each frame and
   of each sample is kept, so a hover block of H frames x S samples shrinks
   from H * S votes to at most H + S scattered ones (with several candidates
   per frame, each candidate object is thinned on its own);
2. hypotheses are lines through two thinned votes, half drawn anywhere and
   half from votes close in frame order (inliers are contiguous in time), in
   batches until the count of eq. 4 for the best inlier ratio found so far is
   reached (adaptive RANSAC, capped; sync/kernels/robust.py's loop);
3. a hypothesis scores the number of distinct frames among its inliers
   (orthogonal distance <= delta), not raw votes;
4. the best hypotheses are polished by least squares on their inliers
   (local optimisation) and rescored;
5. a second search without the winner's inliers measures the support of the
   best competing line (ambiguity, e.g. a periodic path).

With a slope prior (sync/kernels/slope.py: what the frame rates say), steps 2-3 are
replaced by an exhaustive sweep: for slopes across the prior's band, spaced
so that neighbouring slopes part by less than delta over the votes' span,
each vote's intercept beta = frame - alpha x sample is computed and the
windows of width 2 delta (vertically: 2 delta sqrt(1 + alpha^2)) holding
the most votes give the candidate lines (a sort and a binary search per
slope: no random draws, nothing missed); polishing is then least squares
with the prior as one more equation (its weight: the variance of votes
within the inlier band over the prior's variance), the slope kept in the
band.

Deterministic for a seed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import partial

import numpy as np

from tlsync_pipeline.sync.kernels.ransac import LineModel, distance_to_line, least_squares_line
from tlsync_pipeline.sync.kernels.robust import (
    Draws,
    InlierCount,
    Preemption,
    Refine,
    Sampler,
    Scores,
    best_finalist,
    polish,
    robust_fit,
    score_many,
    within,
)
from tlsync_pipeline.sync.kernels.slope import SlopePrior

BATCH = 1024  # hypotheses scored per batch
MAX_HYPOTHESES = 60_000
SCORE_SUBSET = 12_000  # votes used to rank hypotheses (all votes for the finalists)
_FINALISTS = 16


@dataclass(frozen=True)
class LineSearch:
    """Result of the line search over votes (sample, frame).

    alpha, beta: the polished line; inliers: mask over all the votes given
    (orthogonal distance <= delta); support: distinct frames among the thinned
    inliers; runner_up: the same for the best line not using those inliers;
    thinned: number of votes kept by thinning; hypotheses: lines scored;
    rival: that best line not using the inliers, (alpha, beta), or None.
    """

    alpha: float
    beta: float
    inliers: np.ndarray
    support: int
    runner_up: int
    thinned: int
    hypotheses: int
    residual_rms: float
    rival: tuple[float, float] | None = None

    @property
    def n_inliers(self) -> int:
        return int(self.inliers.sum())


def thin_votes(sample: np.ndarray, frame: np.ndarray, dist: np.ndarray, group: np.ndarray | None = None) -> np.ndarray:
    """Indices of the votes that are the closest of their frame or of their sample (the first such vote on a tie).

    group: optional (M,) object id of each vote (e.g. a tracklet): the
    closest per frame and per sample are then taken within each group.
    """
    keep = np.zeros(len(frame), dtype=bool)
    for key in (frame, sample):
        codes, groups = _group_codes(key)
        if group is not None and len(codes):
            owner, _ = _group_codes(np.asarray(group))
            _, codes = np.unique(owner.astype(np.int64) * groups + codes, return_inverse=True)
            codes, groups = codes.ravel(), int(codes.max()) + 1
        closest = np.full(groups, np.inf)
        np.minimum.at(closest, codes, dist)
        candidates = np.flatnonzero(dist == closest[codes])
        _, first = np.unique(codes[candidates], return_index=True)
        keep[candidates[first]] = True
    return np.flatnonzero(keep)


def _group_codes(key: np.ndarray) -> tuple[np.ndarray, int]:
    """A code 0..groups-1 per element, equal for equal values: the offset from the smallest for whole numbers (no sort),
    else by np.unique.
    """
    if len(key) == 0:
        return np.zeros(0, np.intp), 0
    low, high = float(key.min()), float(key.max())
    if high - low < 4 * len(key) + 1024 and np.array_equal(key, np.floor(key)):
        return (key - low).astype(np.intp), int(high - low) + 1
    values, codes = np.unique(key, return_inverse=True)
    return codes.ravel(), len(values)


def _pairs(m: int, window: int) -> Sampler:
    """Pairs of votes (sorted by frame) among m: half anywhere, half within ``window`` votes of each other."""

    def draw(rng: np.random.Generator, n: int) -> np.ndarray:
        i = rng.integers(m, size=n)
        j = rng.integers(m, size=n)
        local = np.arange(n) % 2 == 1
        offset = rng.integers(1, window + 1, size=n) * rng.choice((-1, 1), size=n)
        return np.stack([i, np.where(local, np.clip(i + offset, 0, m - 1), j)])

    return draw


def _line_model(
    sample: np.ndarray, frame: np.ndarray, delta: float, prior: SlopePrior | None
) -> tuple[LineModel, InlierCount, Refine]:
    """The votes (sorted by frame) as lines to fit, the score (distinct inlier frames) and the polish of a line."""
    fit = least_squares_line if prior is None else partial(_map_line, prior=prior, delta=delta)
    model = LineModel(sample, frame, fit, increasing=True)
    return model, InlierCount(delta, groups=frame), partial(_polish, model, delta)


def _search(rng, sample, frame, delta, p, r_min, prior):
    """Best line over votes sorted by frame: (alpha, beta, support, lines scored); the sweep with a prior, adaptive
    RANSAC without.
    """
    if prior is not None:
        return _sweep(rng, sample, frame, delta, prior)
    model, rule, polished = _line_model(sample, frame, delta, prior)
    draws = Draws(MAX_HYPOTHESES, BATCH, confidence=p, ratio=r_min)
    preemption = Preemption(SCORE_SUBSET, _FINALISTS, ordered=True)
    found = robust_fit(model, rng, _pairs(len(sample), max(5, len(sample) // 50)), rule, draws, preemption, polished)
    if found is None:
        return None
    return float(found.model[0]), float(found.model[1]), found.score, found.drawn


SWEEP_PEAKS = 4  # candidate lines kept per slope of the sweep
MAX_SWEEP_SLOPES = 512
SWEEP_SUBSET = 4 * SCORE_SUBSET  # votes the sweep counts windows on (all votes for the finalists)


def _sweep(rng, sample, frame, delta, prior: SlopePrior):
    """Best line with its slope in the prior's band, by sweeping slopes and intercepts: (alpha, beta, support, lines
    scored).

    The windows are counted on at most SWEEP_SUBSET votes drawn at random
    (a line of 1 % support still has hundreds there); the finalists are
    polished and scored on every vote.
    """
    low, high = prior.band
    span = float(np.ptp(sample))
    steps = int(min(MAX_SWEEP_SLOPES, max(1, math.ceil((high - low) * span / delta))))
    slopes = np.unique(np.r_[prior.alpha, np.linspace(low, high, steps + 1)]) if steps > 1 else np.array([prior.alpha])
    counted = (
        np.sort(rng.choice(len(sample), SWEEP_SUBSET, replace=False)) if len(sample) > SWEEP_SUBSET else slice(None)
    )
    s_counted, f_counted = sample[counted], frame[counted]
    pool_a, pool_b, pool_s = [], [], []
    for alpha in slopes:
        width = 2 * delta * math.sqrt(1 + alpha * alpha)
        intercept = np.sort(f_counted - alpha * s_counted)
        counts = np.searchsorted(intercept, intercept + width, side="right") - np.arange(len(intercept))
        for k in _peaks(intercept, counts, width):
            pool_a.append(alpha)
            pool_b.append(intercept[k] + width / 2)
            pool_s.append(counts[k])
    model, rule, polished = _line_model(sample, frame, delta, prior)
    found = Scores(np.array(pool_s), len(s_counted))
    best, support = best_finalist(model, rule, np.column_stack([pool_a, pool_b]), found, _FINALISTS, polished)
    return float(best[0]), float(best[1]), support, len(slopes) * len(s_counted)


def _peaks(intercept: np.ndarray, counts: np.ndarray, width: float) -> list[int]:
    """Up to SWEEP_PEAKS windows of most votes (intercepts sorted), each starting more than one window width from those
    kept before.
    """
    kept: list[int] = []
    left = counts.astype(np.float64)
    for _ in range(SWEEP_PEAKS):
        k = int(np.argmax(left))
        if left[k] <= 0:
            break
        kept.append(k)
        lo = np.searchsorted(intercept, intercept[k] - width, side="left")
        hi = np.searchsorted(intercept, intercept[k] + width, side="right")
        left[lo:hi] = -1.0
    return kept


def _polish(model: LineModel, delta: float, line: np.ndarray) -> np.ndarray:
    """Least squares on the inliers, widened then narrowed, until the set settles (LO-RANSAC); with the prior, a MAP fit
    kept in its band.
    """
    polished = polish(model, within(2 * delta, delta), 4, start=line)
    assert polished is not None, "a polish from a line always has one"
    return polished.model


def _map_line(sample, frame, prior: SlopePrior, delta: float) -> tuple[float, float]:
    """Least squares line with the slope prior as one more equation, the slope then kept in the prior's band.

    Weight of the prior: the variance of a vote uniform in the inlier band
    (delta^2 / 3) over the prior's variance (sigma x alpha)^2.
    """
    weight = delta**2 / 3 / (prior.sigma * prior.alpha) ** 2
    s_mean, f_mean = sample.mean(), frame.mean()
    ds, df = sample - s_mean, frame - f_mean
    a = (ds @ df + weight * prior.alpha) / (ds @ ds + weight)
    a = float(np.clip(a, *prior.band))
    return a, float(f_mean - a * s_mean)


def find_line(
    sample: np.ndarray,
    frame: np.ndarray,
    dist: np.ndarray,
    delta: float = 0.5,
    p: float = 0.99,
    r_min: float = 0.01,
    seed: int = 0,
    group: np.ndarray | None = None,
    prior: SlopePrior | None = None,
    apart: float = 0.0,
) -> LineSearch:
    """The line frame = alpha * sample + beta best supported by the votes.

    r_min: the smallest inlier ratio (of thinned votes) the search must
    find with probability p; group: the object each vote comes from when
    several candidates vote per frame (thinning is per object); prior:
    what the frame rates say about the slope (sync/kernels/slope.py), or None for
    any increasing line; apart: frames (along the frame axis) within which a
    line is the same answer as the best one, not a rival: the runner-up is
    searched among the votes farther than that (and than delta) from the
    best line. The sweep ranks its lines by votes (several a frame where
    movers vote together) and keeps the _FINALISTS best, which may all lie
    near one line of many votes on few frames: a runner-up with more
    distinct frames than the best is then the answer, the best its rival.
    Raises ValueError when no increasing line exists (fewer than 2 distinct
    samples, or votes that never move forward).
    """
    sample = np.asarray(sample, dtype=np.float64)
    frame = np.asarray(frame, dtype=np.float64)
    dist = np.asarray(dist, dtype=np.float64)
    if len(np.unique(sample)) < 2:
        raise ValueError("the votes cover fewer than 2 distinct target samples: no line can be fitted")
    rng = np.random.default_rng(seed)
    kept = thin_votes(sample, frame, dist, None if group is None else np.asarray(group))
    kept = kept[np.lexsort((sample[kept], frame[kept]))]
    ts, tf = sample[kept], frame[kept]
    found = _search(rng, ts, tf, delta, p, r_min, prior)
    if found is None:
        raise ValueError("no increasing line through any two votes: the votes do not move forward in time")
    alpha, beta, support, drawn = found
    runner_up, rival = 0, None
    rest = distance_to_line(ts, tf, alpha, beta) > max(delta, apart / np.hypot(1.0, alpha))
    if rest.sum() >= 2 and len(np.unique(ts[rest])) >= 2:
        second = _search(rng, ts[rest], tf[rest], delta, p, r_min, prior)
        if second is not None:
            runner_up, rival = second[2], (float(second[0]), float(second[1]))
    if rival is not None and runner_up > support:
        (alpha, beta), rival = rival, (alpha, beta)
        model, rule, _ = _line_model(ts, tf, delta, prior)
        runner_up, support = support, int(score_many(model, np.array([[alpha, beta]]), rule).value[0])
    on_line = distance_to_line(ts, tf, alpha, beta) <= delta
    inliers = distance_to_line(sample, frame, alpha, beta) <= delta
    residual = tf[on_line] - alpha * ts[on_line] - beta
    rms = float(np.sqrt(np.mean(residual**2))) if on_line.any() else float("nan")
    return LineSearch(alpha, beta, inliers, support, runner_up, len(kept), drawn, rms, rival)
