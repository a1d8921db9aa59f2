"""The pose search's score under a log whose bias wanders: a pose and the log's bias over the visit, fitted together.

A consumer receiver's bias wanders by metres over a camera's visit
(sync/log_model.py); a fixed pose absorbs its mean but not its wander, which
at the target's depth is tens of pixels: at the right offset a rigid pose
leaves most tracked positions beyond the search's threshold, and offsets
whose trajectory is wrong score as well (drone2 under a drone's GNSS: every
candidate of three cameras of four was thousands of frames off). Here each
candidate offset is scored by the pose and the bias of the log's points
over the visit fitted together: the bias linear between knots every
KNOT_S seconds of the track, under its Gauss-Markov prior (the log model's
std and correlation time), the pixels robust (truncated quadratic at CUT
sigmas). A wrong offset can only be explained by a bias its prior makes
unlikely, and the score says so: it is the MSAC-like count of explained
positions less the prior's cost, n - (sum min((e / sigma)^2, CUT^2) +
b^T Q b) / CUT^2 (in positions).

The fit alternates the pose (SQPnP on the positions corrected by the bias)
and the bias (the normal equations of the pixels linearised at the pose,
with the prior), over STEPS scales from the log's unabsorbed error seen at
the target's depth down to sigma: at the first scale the wander's tens of
pixels are inliers, at the last only what the bias explains.

Pixels are distortion-free (the search's); world metres; clock in frame
units (sync/clock.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import solveh_banded

from tlsync_pipeline.sync.kernels.gauss_markov import interpolation_parts, prior_whitening
from tlsync_pipeline.sync.model.log_model import LogModel

KNOT_S = 5.0  # seconds between the bias's knots over the visit
CUT = 3.0  # a position's pixel error counts at most this many sigmas
STEPS = 6  # scales of the alternation, from the log's error in pixels down to sigma
MIN_POINTS = 12  # positions the pose needs
BAND = 5  # half-bandwidth of the knots' normal equations (neighbouring knots, three axes each)


@dataclass(frozen=True)
class VisitBias:
    """The log's bias over one camera's visit, as the search models it: knots (clock units) every KNOT_S seconds over
    the searched positions' clock span, each position's two knots and the right one's weight, and the prior's
    precision Q (3K x 3K, knot-major) of the log model's Gauss-Markov bias; unabsorbed_m: the log's error a
    fixed pose cannot absorb over the span (LogModel.unabsorbed_m), which sets the first scale."""

    left: np.ndarray
    right: np.ndarray
    weight: np.ndarray
    precision: np.ndarray
    unabsorbed_m: float

    @classmethod
    def over(cls, clock: np.ndarray, fps: float, model: LogModel, knot_s: float = KNOT_S) -> VisitBias:
        """The bias over positions at clock values ``clock`` (frame units) of a camera at ``fps`` under ``model``, its
        knots at most ``knot_s`` seconds apart."""
        span_s = float(np.ptp(clock)) / fps
        count = max(2, int(np.ceil(span_s / knot_s)) + 1)
        knots = np.linspace(float(clock.min()), float(clock.max()) + 1e-9, count)
        left, right, weight = interpolation_parts(clock, knots)
        sigma = np.array([model.bias_m, model.bias_m, model.bias_vertical_m])
        whiten = prior_whitening(knots / fps, 1.0, model.tau_s, np.maximum(sigma, 1e-6)).toarray()
        return cls(left, right, weight, whiten.T @ whiten, model.unabsorbed_m(span_s))

    @property
    def knots(self) -> int:
        return self.precision.shape[0] // 3


def fit_with_bias(
    xyz: np.ndarray, uv: np.ndarray, K: np.ndarray, bias: VisitBias, on: np.ndarray, sigma_px: float, pnp
) -> tuple[float, tuple | None, np.ndarray]:
    """(support, pose, bias) of one candidate offset (see the module): xyz (n, 3) the log's positions of the
    searched rows ``on`` (a mask over the rows the VisitBias was made for), uv (n, 2) their distortion-free pixels,
    pnp(xyz, uv, K) -> (rvec, tvec) or None; bias (K, 3) metres at the knots. Support 0 and pose None when the pose
    cannot be fitted."""
    import cv2

    left, right, u = bias.left[on], bias.right[on], bias.weight[on]
    n_rows = len(bias.left)
    values = np.zeros((bias.knots, 3))
    keep = np.ones(len(xyz), dtype=bool)
    focal = 0.5 * (K[0, 0] + K[1, 1])
    scales = None
    for step in range(STEPS + 1):
        corrected = xyz + (1.0 - u)[:, None] * values[left] + u[:, None] * values[right]
        pose = pnp(corrected[keep], uv[keep], K) if keep.sum() >= MIN_POINTS else None
        if pose is None:
            return 0.0, None, values
        R = cv2.Rodrigues(pose[0])[0]
        cam = corrected @ R.T + pose[1].ravel()
        depth = cam[:, 2]
        if not np.median(depth) > 0:
            return 0.0, None, values
        with np.errstate(divide="ignore", invalid="ignore"):
            h = cam @ K.T
            residual = h[:, :2] / h[:, 2:3] - uv
        error = np.where(depth > 0, np.linalg.norm(residual, axis=1), np.inf)
        error = np.where(np.isfinite(error), error, np.inf)
        if scales is None:
            start = focal * bias.unabsorbed_m / float(np.median(depth[depth > 0]))
            scales = np.geomspace(max(start, sigma_px), sigma_px, STEPS)
        if step == STEPS:
            break
        keep = (error <= CUT * scales[step]) & (depth > 0)
        values = values + _bias_step(cam, residual, keep, K, R, left, right, u, values, bias.precision, scales[step])
    data = float(np.minimum((error / sigma_px) ** 2, CUT**2).sum()) + CUT**2 * (n_rows - len(xyz))
    prior = float(values.ravel() @ bias.precision @ values.ravel())
    return n_rows - (data + prior) / CUT**2, pose, values


def _bias_step(cam, residual, keep, K, R, left, right, u, values, precision, scale) -> np.ndarray:
    """The Gauss-Newton step of the knots' bias (K, 3) with the pose held: pixels linearised in the world point,
    the kept ones at std ``scale``, the prior's precision."""
    z = cam[:, 2]
    jac = np.zeros((len(z), 2, 3))
    jac[:, 0, 0] = K[0, 0] / z
    jac[:, 0, 2] = -K[0, 0] * cam[:, 0] / z**2 - K[0, 1] * cam[:, 1] / z**2
    jac[:, 0, 1] = K[0, 1] / z
    jac[:, 1, 1] = K[1, 1] / z
    jac[:, 1, 2] = -K[1, 1] * cam[:, 1] / z**2
    jac = jac @ R  # d pixel / d world point
    w = keep / scale**2
    jtj = np.einsum("nij,nik->njk", jac, jac) * w[:, None, None]
    jtr = np.einsum("nij,ni->nj", jac, np.where(keep[:, None], residual, 0.0)) * w[:, None]
    count = values.shape[0]
    near, across, far = ((1 - u) ** 2)[:, None, None], ((1 - u) * u)[:, None, None], (u**2)[:, None, None]
    blocks = _summed_by(
        np.concatenate([left * count + left, left * count + right, right * count + left, right * count + right]),
        np.concatenate([near * jtj, across * jtj, across * jtj, far * jtj]),
        count * count,
    ).reshape(count, count, 3, 3)
    gradient = _summed_by(
        np.concatenate([left, right]), np.concatenate([(1 - u)[:, None] * jtr, u[:, None] * jtr]), count
    )
    normal = blocks.transpose(0, 2, 1, 3).reshape(3 * count, 3 * count) + precision
    rhs = gradient.ravel() + precision @ values.ravel()
    # block tridiagonal: LAPACK's banded Cholesky (a dense solve of this size was 100 times slower here)
    upper = np.zeros((BAND + 1, 3 * count))
    for d in range(BAND + 1):
        upper[BAND - d, d:] = np.diagonal(normal, d)
    try:
        return -solveh_banded(upper, rhs).reshape(count, 3)
    except np.linalg.LinAlgError:
        return np.zeros_like(values)


def _summed_by(index: np.ndarray, values: np.ndarray, cells: int) -> np.ndarray:
    """(cells, ...) the rows of ``values`` (m, ...) summed by their cell ``index`` (m,), in their order: np.add.at's
    sums (the same numbers, added in the same order) by one np.bincount, several times faster on a pose's few rows."""
    width = int(np.prod(values.shape[1:]))
    flat = (index[:, None] * width + np.arange(width)).ravel()
    return np.bincount(flat, values.ravel(), minlength=cells * width).reshape(cells, *values.shape[1:])
