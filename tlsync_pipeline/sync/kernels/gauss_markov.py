"""A log's bias as a first-order Gauss-Markov process on knots: its prior's whitening and the knots' interpolation.

Shared by the joint fit of every camera's line with the log's bias (sync/solve/log_bias.py) and the pose search's
score under a biased log (sync/pose/pose_bias.py). Knots are sample coordinates (or any coordinate with ``rate``
units per second); values are knot-major (x, y, z of knot 0, then of knot 1 ...).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp


def prior_whitening(knots: np.ndarray, rate: float, tau_s: float, sigma: np.ndarray) -> sp.csr_matrix:
    """(3K, 3K) sparse W such that W b is standard normal under the Gauss-Markov prior (knot-major b).

    A first-order Gauss-Markov process is Markov: W is its innovations, b_0 / sigma and then
    (b_k - phi_k b_(k-1)) / (sigma sqrt(1 - phi_k^2)) with phi_k = exp(-dt_k / tau), bidiagonal per axis
    (the inverse Cholesky factor of the exponential covariance).
    """
    phi = np.exp(-np.diff(knots) / rate / tau_s)
    root = np.sqrt(np.maximum(1.0 - phi**2, 1e-12))
    diagonal = np.r_[1.0, 1.0 / root]
    inverse_root = sp.diags([diagonal, -phi / root], [0, -1], format="csr")  # (K, K)
    return sp.kron(inverse_root, sp.diags(1.0 / sigma), format="csr")


def interpolation_parts(samples: np.ndarray, knots: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each sample coordinate the knots around it (left, right indices) and the right one's weight u (0 to 1):
    linear between knots, the end knot beyond them."""
    s = np.clip(samples, knots[0], knots[-1])
    right = np.clip(np.searchsorted(knots, s, side="right"), 1, len(knots) - 1)
    left = right - 1
    return left, right, (s - knots[left]) / (knots[right] - knots[left])
