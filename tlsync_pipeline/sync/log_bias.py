"""The log's slowly varying bias, estimated with every camera's line, and what it leaves uncertain.

A consumer receiver's error is mostly a bias that wanders over a minute
(sync/log_model.py). A bias along the direction of travel is a time error
(1 m at 1.4 m/s is 21 frames at 30 fps), so each camera's own refinement,
which takes the log as exact, is off by what the bias was during its visit.
The bias is the same target's for every camera: it is modelled as one 3D
function of the log's time, linear between knots every quarter of the
correlation time, with the Gauss-Markov prior of the log model (zero mean;
per axis, the covariance sigma^2 exp(-|dt| / tau) between knots). All
cameras' lines and the knots are fitted together on the frames each
camera's refinement used, by robust least squares (soft L1 on the pixel
residuals, the priors quadratic), the lines parametrised as the refinement
does (1 / alpha, and the sample at the middle clock value).

What a camera cannot tell apart from its time offset (a straight walk
through its view: a bias along the walk), it leaves at the prior: the
estimate stays near zero and the uncertainty is the prior's. The
uncertainty of the lines is the joint posterior's: each camera's own
(tracking, calibration) plus ``S_c P S_c^T``, where P is the knots'
posterior covariance and S_c how camera c's line follows the knots (the
exact marginal of the joint Gaussian, by the block inverse); cameras whose
visits share the bias are correlated by ``S_a P S_b^T``, which the pairs'
intervals include. Observability of the bias at a camera's visit is
1 - posterior variance / prior variance (horizontal), 0 to 1.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from calibration.camera import Camera
from tlsync_pipeline.sync.log_model import LogModel
from tlsync_pipeline.sync.slope import SlopePrior
from tlsync_pipeline.trajectory import PiecewiseTrajectory

KNOTS_PER_TAU = 4  # knots of the bias per correlation time between the visits
VISIT_KNOT_S = 2.0  # seconds between knots during a visit: a Gauss-Markov bias moves by sigma x sqrt(2 dt / tau) in dt
MAX_KNOTS = 400
SAMPLE_STEP = 1e-3  # samples: finite-difference step of a position along the path
METRE_STEP = 1e-3  # metres: finite-difference step of a position in space


@dataclass(frozen=True)
class BiasCamera:
    """One camera as the joint fit sees it: the clock values (frame units) and tracked pixels of the frames its
    refinement used, their weights (sigma_weights), its line, the (alpha, beta) covariance of its own refinement,
    and its slope prior (or None)."""

    name: str
    camera: Camera
    clock: np.ndarray
    xy: np.ndarray
    weight: np.ndarray
    alpha: float
    beta: float
    cov: np.ndarray
    prior: SlopePrior | None

    @property
    def middle(self) -> float:
        return float(np.median(self.clock))


@dataclass(frozen=True)
class LogBias:
    """The fitted bias and the lines: knots (sample coordinates), values (K, 3) metres, their posterior covariance
    (3K, 3K, knot-major: x, y, z of knot 0, then of knot 1 ...), prior (3,) per-axis std (m); per camera its line
    (alpha, beta) and sensitivity (2, 3K): d(alpha, beta) / d(knot values); converged: the solver's verdict."""

    knots: np.ndarray
    values: np.ndarray
    cov: np.ndarray
    prior: np.ndarray
    lines: dict[str, tuple[float, float]]
    sensitivity: dict[str, np.ndarray]
    converged: bool

    def at(self, samples: np.ndarray) -> np.ndarray:
        """(N, 3) bias at sample coordinates (linear between knots, constant beyond them)."""
        return np.column_stack([np.interp(samples, self.knots, self.values[:, k]) for k in range(3)])

    def line_cov(self, a: str, b: str) -> np.ndarray:
        """2x2 covariance between camera a's and camera b's (alpha, beta) through the bias (a == b: the bias part of a's own)."""
        return self.sensitivity[a] @ self.cov @ self.sensitivity[b].T

    def std_at(self, sample: float) -> np.ndarray:
        """(3,) posterior std of the bias at one sample coordinate."""
        weights = _interpolation(np.array([sample]), self.knots)[0]
        rows = np.kron(weights, np.eye(3))  # (3, 3K)
        return np.sqrt(np.diag(rows @ self.cov @ rows.T))

    def observability(self, sample: float) -> float:
        """1 - posterior / prior variance of the horizontal bias at one sample coordinate (0: only the prior, 1: known)."""
        std = self.std_at(sample)
        return float(np.clip(1.0 - (std[0] ** 2 + std[1] ** 2) / (self.prior[0] ** 2 + self.prior[1] ** 2), 0.0, 1.0))


def fit_log_bias(cameras: list[BiasCamera], path: PiecewiseTrajectory, rate: float, model: LogModel, f_scale: float, estimate: bool = True) -> LogBias:
    """Every camera's line and the log's bias, fitted together (see the module); ``rate``: log samples per second.

    estimate False: no fit; the bias at zero, the cameras' lines as they are, and the bias's uncertainty at its prior
    (the data told nothing that was used).
    """
    knots = _knots(cameras, path, rate, model)
    prior = np.array([model.bias_m, model.bias_m, model.bias_vertical_m])
    whiten = _prior_whitening(knots, rate, model.tau_s, prior)
    problem = _Joint(cameras, path, knots, whiten, f_scale)
    z = np.concatenate([problem.x0, np.zeros(3 * len(knots))])
    converged = True
    if estimate:
        solution = least_squares(problem.residual, z, jac=problem.jacobian, loss=problem.loss, f_scale=f_scale, x_scale=problem.scale, method="trf", max_nfev=100)
        z, converged = solution.x, bool(solution.success)
    posterior, sensitivity = problem.uncertainty(z)
    if not estimate:
        posterior = np.linalg.pinv(whiten.T @ whiten)
    lines = {c.name: problem.line(z, k) for k, c in enumerate(cameras)}
    return LogBias(knots, z[2 * len(cameras) :].reshape(-1, 3), posterior, prior, lines, sensitivity, converged)


def _knots(cameras: list[BiasCamera], path: PiecewiseTrajectory, rate: float, model: LogModel) -> np.ndarray:
    """Knot sample coordinates: every VISIT_KNOT_S over each camera's visit (the bias wanders within it), every
    tau / KNOTS_PER_TAU from one correlation time before the first visit to one after the last."""
    visits = [(c.clock - c.beta) / c.alpha for c in cameras]
    lo_all = max(float(min(v.min() for v in visits)) - model.tau_s * rate, float(path.sample[0]))
    hi_all = min(float(max(v.max() for v in visits)) + model.tau_s * rate, float(path.sample[-1]))
    sparse = max(model.tau_s * rate / KNOTS_PER_TAU, 1.0)
    knots = [np.linspace(lo_all, hi_all, max(2, int(np.ceil((hi_all - lo_all) / sparse)) + 1))]
    dense = max(VISIT_KNOT_S * rate, 1.0)
    for v in visits:
        lo, hi = float(v.min()) - dense, float(v.max()) + dense
        knots.append(np.linspace(lo, hi, max(2, int(np.ceil((hi - lo) / dense)) + 1)))
    merged = np.unique(np.clip(np.concatenate(knots), lo_all, hi_all))
    keep = np.r_[True, np.diff(merged) > 0.25 * dense]  # no two knots closer than a quarter of the visits' spacing
    merged = merged[keep]
    return merged if len(merged) <= MAX_KNOTS else np.linspace(lo_all, hi_all, MAX_KNOTS)


def _prior_whitening(knots: np.ndarray, rate: float, tau_s: float, sigma: np.ndarray) -> np.ndarray:
    """(3K, 3K) W such that W b is standard normal under the Gauss-Markov prior (knot-major b)."""
    dt = np.abs(knots[:, None] - knots[None, :]) / rate
    correlation = np.exp(-dt / tau_s) + 1e-9 * np.eye(len(knots))
    inverse_root = np.linalg.inv(np.linalg.cholesky(correlation))  # L^-1, L L^T = correlation
    return np.kron(inverse_root, np.diag(1.0 / sigma))


def _interpolation(samples: np.ndarray, knots: np.ndarray) -> np.ndarray:
    """(N, K) weights of the knots at each sample coordinate: linear between knots, the end knot beyond them."""
    s = np.clip(samples, knots[0], knots[-1])
    right = np.clip(np.searchsorted(knots, s, side="right"), 1, len(knots) - 1)
    left = right - 1
    u = (s - knots[left]) / (knots[right] - knots[left])
    weights = np.zeros((len(s), len(knots)))
    weights[np.arange(len(s)), left] = 1.0 - u
    weights[np.arange(len(s)), right] += u
    return weights


class _Joint:
    """The joint problem in z = (x_c = (1 / alpha_c, sample at camera c's middle clock) for each camera, then the
    knots' values, knot-major); residuals: each camera's weighted pixel offsets, then each slope prior, then the
    whitened bias prior (times f_scale: a prior at one sigma weighs as a pixel residual of the loss scale)."""

    def __init__(self, cameras: list[BiasCamera], path: PiecewiseTrajectory, knots: np.ndarray, whiten: np.ndarray, f_scale: float):
        self.cameras, self.path, self.knots, self.whiten, self.f_scale = cameras, path, knots, whiten, f_scale
        self.n = len(cameras)
        self.x0 = np.concatenate([[1.0 / c.alpha, (c.middle - c.beta) / c.alpha] for c in cameras])
        spans = [max(float(np.ptp(c.clock)), 1.0) for c in cameras]
        self.scale = np.concatenate([np.concatenate([[0.1 / span / c.alpha + 1e-9, 0.1] for c, span in zip(cameras, spans)]), np.full(3 * len(knots), 0.1)])
        self.priors = [c.prior for c in cameras if c.prior is not None]
        pixels = sum(2 * len(c.clock) for c in cameras)
        self.quadratic = np.r_[np.zeros(pixels, bool), np.ones(len(self.priors) + whiten.shape[0], bool)]
        self.loss: Callable = _soft_l1_except(self.quadratic)
        self._cache: dict[bytes, tuple[list[np.ndarray], list[np.ndarray]]] = {}
        self.inflation = np.ones(self.n)
        start = np.concatenate([self.x0, np.zeros(3 * len(knots))])
        self.inflation = np.array([_inflation(c, r, j, f_scale, start[2 * k : 2 * k + 2]) for k, (c, r, j) in enumerate(zip(cameras, *self._pixels(start)))])
        self._cache.clear()

    def line(self, z: np.ndarray, k: int) -> tuple[float, float]:
        u, s0 = z[2 * k : 2 * k + 2]
        return 1.0 / u, self.cameras[k].middle - s0 / u

    def _pixels(self, z: np.ndarray) -> tuple[list[np.ndarray], list[np.ndarray]]:
        """Per camera: (N, 2) weighted residuals and (N, 2, 2 + 3K) their Jacobian in (its x, the knots)."""
        key = z.tobytes()
        if key not in self._cache:
            self._cache.clear()
            bias = z[2 * self.n :].reshape(-1, 3)
            residuals, jacobians = [], []
            for k, c in enumerate(self.cameras):
                u, s0 = z[2 * k : 2 * k + 2]
                s = s0 + u * (c.clock - c.middle)
                r, jac = _camera_rows(c, self.path, self.knots, bias, s)
                scale = 1.0 / np.sqrt(self.inflation[k])
                residuals.append(r * scale)
                jacobians.append(scale * np.concatenate([jac[:, :, :1] * (c.clock - c.middle)[:, None, None], jac[:, :, :1], jac[:, :, 1:]], axis=2))
            self._cache[key] = (residuals, jacobians)
        return self._cache[key]

    def residual(self, z: np.ndarray) -> np.ndarray:
        residuals, _ = self._pixels(z)
        priors = [self.f_scale * (c.prior.alpha * z[2 * k] - 1.0) / c.prior.sigma for k, c in enumerate(self.cameras) if c.prior is not None]
        return np.concatenate([*(r.ravel() for r in residuals), priors, self.f_scale * (self.whiten @ z[2 * self.n :])])

    def jacobian(self, z: np.ndarray) -> np.ndarray:
        _, jacobians = self._pixels(z)
        size = len(z)
        rows = []
        for k, jac in enumerate(jacobians):
            block = np.zeros((jac.shape[0] * 2, size))
            flat = jac.reshape(-1, jac.shape[2])
            block[:, 2 * k : 2 * k + 2] = flat[:, :2]
            block[:, 2 * self.n :] = flat[:, 2:]
            rows.append(block)
        for k, c in enumerate(self.cameras):
            if c.prior is not None:
                row = np.zeros((1, size))
                row[0, 2 * k] = self.f_scale * c.prior.alpha / c.prior.sigma
                rows.append(row)
        prior = np.zeros((self.whiten.shape[0], size))
        prior[:, 2 * self.n :] = self.f_scale * self.whiten
        rows.append(prior)
        return np.vstack(rows)

    def uncertainty(self, z: np.ndarray) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """The knots' posterior covariance (m^2) and each camera's sensitivity d(alpha, beta) / d(knots).

        Each camera's information is its robust bread J^T psi' J divided by its residuals' variance factor
        (sum psi^2 / sum psi', the M-estimator's), inflated by its own refinement's covariance over that naive
        one where residuals correlate in time; the prior's is W^T W.
        """
        residuals, jacobians = self._pixels(z)
        information = self.whiten.T @ self.whiten
        blocks = []
        for k, (r, jac) in enumerate(zip(residuals, jacobians)):
            h = _bread(self.cameras[k], r, jac, self.f_scale) / _inflation(self.cameras[k], r, jac, self.f_scale, z[2 * k : 2 * k + 2])
            h_tt, h_tb, h_bb = h[:2, :2], h[:2, 2:], h[2:, 2:]
            gain = np.linalg.pinv(h_tt) @ h_tb  # (2, 3K); a camera whose line the residuals do not determine tells nothing of the bias
            information = information + h_bb - h_tb.T @ gain
            blocks.append((gain, z[2 * k : 2 * k + 2]))
        posterior = np.linalg.pinv(information)
        sensitivity = {}
        for c, (gain, (u, s0)) in zip(self.cameras, blocks):
            to_line = np.array([[-1.0 / u**2, 0.0], [s0 / u**2, -1.0 / u]])  # d(alpha, beta) / d(u, s0), beta = middle - s0 / u
            sensitivity[c.name] = to_line @ (-gain)
        return posterior, sensitivity


def _camera_rows(c: BiasCamera, path: PiecewiseTrajectory, knots: np.ndarray, bias: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(N, 2) weighted pixel residuals of one camera at samples s, and (N, 2, 1 + 3K) their Jacobian in s and in the knots."""
    run = path.run_of(s)
    on = run >= 0
    weights = _interpolation(s, knots)
    position = np.full((len(s), 3), np.nan)
    position[on] = path(s[on], run[on])
    position += weights @ bias
    ahead = np.full((len(s), 3), np.nan)
    ahead[on] = path(s[on] + SAMPLE_STEP, run[on])
    ahead += _interpolation(s + SAMPLE_STEP, knots) @ bias
    moved = [position + METRE_STEP * axis for axis in np.eye(3)]
    uv_all, _ = c.camera.project(np.concatenate([position, ahead, *moved]))
    n = len(s)
    uv = uv_all[:n]
    rate = (uv_all[n : 2 * n] - uv) / SAMPLE_STEP  # pixels per sample
    gradient = np.stack([(uv_all[(2 + a) * n : (3 + a) * n] - uv) / METRE_STEP for a in range(3)], axis=2)  # (N, 2, 3) pixels per metre
    r = (uv - c.xy) * c.weight[:, None]
    jac = np.zeros((n, 2, 1 + 3 * len(knots)))
    jac[:, :, 0] = rate * c.weight[:, None]
    jac[:, :, 1:] = (gradient[:, :, None, :] * weights[:, None, :, None]).reshape(n, 2, -1) * c.weight[:, None, None]
    bad = ~(np.isfinite(r).all(axis=1) & np.isfinite(jac.reshape(n, -1)).all(axis=1))
    r[bad] = 10.0
    jac[bad] = 0.0
    return r, jac


def _bread(c: BiasCamera, r: np.ndarray, jac: np.ndarray, f_scale: float) -> np.ndarray:
    """One camera's robust Gauss-Newton information J^T psi' J (its slope prior included), in (its x, the knots)."""
    dpsi = (1.0 + (r / f_scale) ** 2) ** -1.5
    flat_j = jac.reshape(-1, jac.shape[2])
    bread = flat_j.T @ (dpsi.ravel()[:, None] * flat_j)
    if c.prior is not None:
        bread[0, 0] += (c.prior.alpha / c.prior.sigma) ** 2
    return bread


def _inflation(c: BiasCamera, r: np.ndarray, jac: np.ndarray, f_scale: float, x: np.ndarray) -> float:
    """What one camera's residuals' information is divided by: their variance factor (sum psi^2 / sum psi', the
    M-estimator's) times how much more its own refinement's covariance says than that naive one (>= 1)."""
    q = (r / f_scale) ** 2
    psi, dpsi = r / np.sqrt(1.0 + q), (1.0 + q) ** -1.5
    variance = max(float(np.sum(psi**2) / max(np.sum(dpsi), 1e-12)), 1e-6)
    return variance * _correlation_factor(c, _bread(c, r, jac, f_scale), variance, x)


def _correlation_factor(c: BiasCamera, bread: np.ndarray, variance: float, x: np.ndarray) -> float:
    """How much the camera's own refinement's covariance of (alpha, beta) exceeds the naive one from its residuals (>= 1):
    residuals correlated in time (pose, log) carry less information than their number says."""
    try:
        naive_x = variance * np.linalg.inv(bread[:2, :2])
    except np.linalg.LinAlgError:
        return 1.0
    u, s0 = x
    d = np.array([[-1.0 / u**2, 0.0], [s0 / u**2, -1.0 / u]])
    naive = d @ naive_x @ d.T
    ratio = np.trace(c.cov) / max(np.trace(naive), 1e-300)
    return float(np.clip(ratio, 1.0, 1e6)) if np.isfinite(ratio) else 1.0


def _soft_l1_except(quadratic: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """scipy least_squares loss (rho, rho', rho''): soft L1, but quadratic where ``quadratic`` is set (the priors)."""

    def loss(z: np.ndarray) -> np.ndarray:
        t = 1.0 + z
        out = np.vstack([2.0 * (np.sqrt(t) - 1.0), t**-0.5, -0.5 * t**-1.5])
        out[0, quadratic], out[1, quadratic], out[2, quadratic] = z[quadratic], 1.0, 0.0
        return out

    return loss
