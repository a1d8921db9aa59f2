"""Whether the log reads backwards in time: the votes' support for the best line running backwards, against the line's.

A thin line (backed by fewer than BACKWARD_BELOW frames) is checked against
it, by identification (sync/identify/identify.py) and by the plausibility
checks of the sync stage (sync/solve/plausibility.py).
"""

from __future__ import annotations

import numpy as np

from tlsync_pipeline.sync.kernels.line_search import find_line
from tlsync_pipeline.sync.kernels.ransac import distance_to_line
from tlsync_pipeline.sync.kernels.slope import SlopePrior

BACKWARD_BELOW = 60  # a line backed by fewer frames is checked against the best line running backwards in time ...
MIN_BACKWARD = 20  # ... which, with at least this many frames ...
BACKWARD_RATIO = 1.2  # ... and this many times the line's, says the log is reversed in time


def line_support(vote_sample: np.ndarray, vote_clock: np.ndarray, alpha: float, beta: float, delta: float) -> int:
    """Distinct frames with a vote within delta (orthogonal distance in the voting space) of the line."""
    near = distance_to_line(vote_sample, vote_clock, alpha, beta) <= delta
    return int(np.unique(np.asarray(vote_clock)[near]).size)


def backward_support(
    vote_sample: np.ndarray,
    vote_clock: np.ndarray,
    vote_dist: np.ndarray,
    delta: float,
    prior: SlopePrior | None,
    seed: int,
) -> int:
    """``line_support`` of the best line clock = -alpha x sample + beta (alpha in the prior's band): the log read
    backwards.
    """
    backwards = -np.asarray(vote_sample, dtype=np.float64)
    try:
        found = find_line(backwards, vote_clock, vote_dist, delta, seed=seed, prior=prior)
    except ValueError:
        return 0
    return line_support(backwards, vote_clock, found.alpha, found.beta, delta)


def backwards_better(forward: int, backward: int) -> bool:
    """Whether the votes back a line running backwards in time (``backward`` frames) clearly better than the forward
    one.
    """
    return backward >= max(MIN_BACKWARD, BACKWARD_RATIO * forward)
