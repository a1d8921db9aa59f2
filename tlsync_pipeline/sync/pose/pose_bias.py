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
from functools import cached_property, lru_cache

import numpy as np
from scipy.linalg.lapack import dpbsv

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

    @cached_property
    def band(self) -> np.ndarray:
        """The prior's precision in LAPACK's upper banded storage (BAND + 1, 3K)."""
        return _banded(self.precision)


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
    knots = _Knots.of(left, right, u)
    keep = np.ones(len(xyz), dtype=bool)
    focal = 0.5 * (K[0, 0] + K[1, 1])
    scales = None
    with np.errstate(divide="ignore", invalid="ignore"):
        for step in range(STEPS + 1):
            corrected = xyz + (1.0 - u)[:, None] * values[left] + u[:, None] * values[right]
            pose = pnp(corrected[keep], uv[keep], K) if keep.sum() >= MIN_POINTS else None
            if pose is None:
                return 0.0, None, values
            R = cv2.Rodrigues(pose[0])[0]
            cam = corrected @ R.T + pose[1].ravel()
            depth = cam[:, 2]
            if not _median_positive(depth):
                return 0.0, None, values
            h = cam @ K.T
            residual = h[:, :2] / h[:, 2:3] - uv
            error = np.where(depth > 0, np.sqrt(residual[:, 0] ** 2 + residual[:, 1] ** 2), np.inf)
            error = np.where(np.isfinite(error), error, np.inf)
            if scales is None:
                start = focal * bias.unabsorbed_m / float(np.median(depth[depth > 0]))
                scales = np.geomspace(max(start, sigma_px), sigma_px, STEPS)
            if step == STEPS:
                break
            keep = (error <= CUT * scales[step]) & (depth > 0)
            step_values = _bias_step(cam, residual, keep, K, R, knots, values, bias.precision, bias.band, scales[step])
            values = values + step_values
    data = float(np.minimum((error / sigma_px) ** 2, CUT**2).sum()) + CUT**2 * (n_rows - len(xyz))
    prior = float(values.ravel() @ bias.precision @ values.ravel())
    return n_rows - (data + prior) / CUT**2, pose, values


def _median_positive(values: np.ndarray) -> bool:
    """Whether the median of ``values`` is positive (np.median's verdict, by counting where it is certain)."""
    half, positive = len(values) / 2.0, np.count_nonzero(values > 0)
    if positive == half or not np.isfinite(values).all():
        return bool(np.median(values) > 0)
    return bool(positive > half)


def _bias_step(cam, residual, keep, K, R, knots: _Knots, values, precision, band, scale) -> np.ndarray:
    """The Gauss-Newton step of the knots' bias (K, 3) with the pose held: pixels linearised in the world point,
    the kept ones at std ``scale``, the prior's precision (and in LAPACK's banded storage ``band``, _banded)."""
    x, y, z = cam.T
    inverse = 1.0 / z
    du = np.stack([K[0, 0] * inverse, K[0, 1] * inverse, -(K[0, 0] * x + K[0, 1] * y) * inverse**2])
    dv = np.stack([np.zeros_like(z), K[1, 1] * inverse, -K[1, 1] * y * inverse**2])
    du, dv = R.T @ du, R.T @ dv  # (3, n) d pixel / d world point
    w = keep / scale**2
    wu, wv = du * w, dv * w
    kept = np.where(keep[:, None], residual, 0.0)
    table = np.empty((33, len(z)))  # by position: its J^T J three times weighed (9 each), its J^T r twice (3 each)
    jtj, jtr = table[:9].reshape(3, 3, -1), wu * kept[:, 0] + wv * kept[:, 1]
    np.multiply(wu[:, None], du[None], out=jtj)
    jtj += wv[:, None] * dv[None]
    np.multiply(table[:9], knots.near * knots.far, out=table[9:18])
    np.multiply(table[:9], knots.far * knots.far, out=table[18:27])
    table[:9] *= knots.near * knots.near
    np.multiply(jtr, knots.near, out=table[27:30])
    np.multiply(jtr, knots.far, out=table[30:33])
    ordered = table if knots.order is None else table[:, knots.order]
    sums = np.add.reduceat(ordered, knots.starts, axis=1).T  # (G, 33) by left knot
    count, at = values.shape[0], knots.at
    blocks = np.zeros((2 * count - 1, 9))  # the diagonal blocks, then the upper off-diagonal ones
    blocks[at] += sums[:, :9]
    blocks[at + 1] += sums[:, 18:27]
    blocks[count + at] = sums[:, 9:18]
    gradient = np.zeros((count, 3))
    gradient[at] += sums[:, 27:30]
    gradient[at + 1] += sums[:, 30:33]
    # block tridiagonal: LAPACK's banded Cholesky (a dense solve of this size was 100 times slower here)
    upper = band.copy()
    cells, source = _band_cells(count)
    upper.ravel()[cells] += blocks.ravel()[source]
    rhs = gradient.ravel() + precision @ values.ravel()
    _, step, info = dpbsv(upper, rhs, lower=0)  # scipy's solveh_banded, without its checks' overhead
    return -step.reshape(count, 3) if info == 0 else np.zeros_like(values)


@dataclass(frozen=True)
class _Knots:
    """The searched positions' knots as _bias_step sums them: each position's weights on its left and right knots
    (near 1 - u, far u), the positions' order by left knot (None: in it already), where each left knot's run starts
    in it, and those knots."""

    near: np.ndarray
    far: np.ndarray
    order: np.ndarray | None
    starts: np.ndarray
    at: np.ndarray

    @classmethod
    def of(cls, left: np.ndarray, right: np.ndarray, u: np.ndarray) -> _Knots:
        if np.any(right != left + 1):
            raise ValueError("the bias step needs each position's right knot to follow its left one")
        order = None if np.all(left[1:] >= left[:-1]) else np.argsort(left, kind="stable")
        ordered = left if order is None else left[order]
        starts = np.flatnonzero(np.r_[True, ordered[1:] != ordered[:-1]])
        return cls(1.0 - u, u, order, starts, ordered[starts])


@lru_cache(maxsize=64)
def _band_cells(count: int) -> tuple[np.ndarray, np.ndarray]:
    """For a block tridiagonal (3 count)-square matrix of 3x3 blocks, its upper band in LAPACK's banded storage
    (BAND + 1, 3 count): the storage's flat cells that hold a block's entry, and which entry: its index in the
    diagonal blocks' (count, 3, 3) then the upper off-diagonal blocks' (count - 1, 3, 3) values, raveled."""
    size = 3 * count
    cells, source = [], []
    for d in range(BAND + 1):
        column = np.arange(d, size)
        row = column - d
        block, a, b = row // 3, row % 3, column % 3
        same, next_ = column // 3 == block, column // 3 == block + 1
        cells += [(BAND - d) * size + column[same], (BAND - d) * size + column[next_]]
        source += [9 * block[same] + 3 * a[same] + b[same], 9 * count + 9 * block[next_] + 3 * a[next_] + b[next_]]
    return np.concatenate(cells), np.concatenate(source)


def _banded(matrix: np.ndarray) -> np.ndarray:
    """A symmetric matrix of half-bandwidth at most BAND in LAPACK's upper banded storage (BAND + 1, n)."""
    upper = np.zeros((BAND + 1, len(matrix)))
    for d in range(min(BAND, len(matrix) - 1) + 1):
        upper[BAND - d, d:] = np.diagonal(matrix, d)
    return upper
