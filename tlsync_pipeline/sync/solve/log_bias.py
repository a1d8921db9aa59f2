"""The log's slowly varying bias, estimated with every camera's line, and what it leaves uncertain.

A consumer receiver's error is mostly a bias that wanders over a minute
(sync/model/log_model.py). A bias along the direction of travel is a time error
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

import copy
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp
from scipy.optimize import minimize
from scipy.sparse.linalg import splu

from calibration.camera import Camera
from tlsync_pipeline.sync.kernels.gauss_markov import interpolation_parts as _interpolation_parts
from tlsync_pipeline.sync.kernels.gauss_markov import prior_whitening as _prior_whitening
from tlsync_pipeline.sync.kernels.slope import SlopePrior
from tlsync_pipeline.sync.kernels.velocity import image_velocity
from tlsync_pipeline.sync.model.log_model import PRIOR_LOG_SD, LogModel
from tlsync_pipeline.trajectory import PiecewiseTrajectory

KNOTS_PER_TAU = 4  # knots of the bias per correlation time between the visits
VISIT_KNOT_S = 2.0  # seconds between knots during a visit: a Gauss-Markov bias moves by sigma x sqrt(2 dt / tau) in dt
MAX_KNOTS = 400
SAMPLE_STEP = 1e-3  # samples: finite-difference step of a position along the path
METRE_STEP = 1e-3  # metres: finite-difference step of a position in space
SEEN_VELOCITY_S = 0.25  # seconds each side of a frame over which the target's image velocity is measured on its track
SCALE_SPLIT_S = 10.0  # s: the marginal likelihood's short error term is correlated below this, the bias above it
FAST_TAU_S = 2.0  # s: the short term's prior correlation time (the smoothed log's white noise over a few fixes)
DECISIVE_NATS = 6.9  # log posterior gain that rejects the model's bias: the likelihood ratio's 99.9 % for 2 values
BELOW_PRIOR = float(
    np.exp(-2.0 * PRIOR_LOG_SD)
)  # an estimate under this share of the model's bias is outside its prior
FAST_FLOOR_M = 0.05  # m: the short term's prior std when the model has no white noise (the knots' interpolation)


@dataclass(frozen=True)
class BiasCamera:
    """One camera as the joint fit sees it: the clock values (frame units) and tracked pixels of the frames its
    refinement used, their weights (sigma_weights), its line, the (alpha, beta) covariance its pixels are weighed by
    in the fit and the marginal likelihood (Refinement.cov_joint), its slope prior (or None), and cov_interval: its
    refinement's own covariance, by which its pixels count in the bias's posterior, the lines' intervals (None: cov).
    """

    name: str
    camera: Camera
    clock: np.ndarray
    xy: np.ndarray
    weight: np.ndarray
    alpha: float
    beta: float
    cov: np.ndarray
    prior: SlopePrior | None
    cov_interval: np.ndarray | None = None

    @property
    def middle(self) -> float:
        return float(np.median(self.clock))


@dataclass(frozen=True)
class KnotInformation:
    """What the cameras' pixels say of the knots' precision (3K, 3K, knot-major), kept in its structure: ``banded -
    low_rank @ low_rank.T``. ``banded`` (sparse) sums the cameras' frames, each of which touches the two knots around
    it; ``low_rank`` (3K, r) is what marginalising the lines takes away, two columns a camera, nonzero over its
    visit's knots. Dense, the difference fills every visit's block."""

    banded: sp.csc_matrix
    low_rank: np.ndarray

    def dense(self) -> np.ndarray:
        """The (3K, 3K) precision as one array."""
        return self.banded.toarray() - self.low_rank @ self.low_rank.T

    def __matmul__(self, values: np.ndarray) -> np.ndarray:
        """The precision times a (3K,) vector of knot values, without forming it."""
        return self.banded @ values - self.low_rank @ (self.low_rank.T @ values)


@dataclass(frozen=True)
class LogBias:
    """The fitted bias and the lines: knots (sample coordinates), values (K, 3) metres, their posterior covariance
    (3K, 3K, knot-major: x, y, z of knot 0, then of knot 1 ...), prior (3,) per-axis std (m); per camera its line
    (alpha, beta) and sensitivity (2, 3K): d(alpha, beta) / d(knot values); converged: the solver's verdict;
    information (3K, 3K) and evidence (3K,): what the cameras' pixels say of the knots b, the likelihood
    exp(-b^T information b / 2 + evidence^T b) (the lines marginalised; information is the posterior's inverse less
    the prior's, both from one expansion of the fit's cost); model: the error model whose prior it was fitted with;
    estimate: the bias's (horizontal std m, correlation time s) of the largest marginal likelihood, or None when not
    measured (fit_log_bias_measured)."""

    knots: np.ndarray
    values: np.ndarray
    cov: np.ndarray
    prior: np.ndarray
    lines: dict[str, tuple[float, float]]
    sensitivity: dict[str, np.ndarray]
    converged: bool
    information: KnotInformation
    evidence: np.ndarray
    model: LogModel
    estimate: tuple[float, float] | None = None

    def at(self, samples: np.ndarray) -> np.ndarray:
        """(N, 3) bias at sample coordinates (linear between knots, constant beyond them)."""
        return np.column_stack([np.interp(samples, self.knots, self.values[:, k]) for k in range(3)])

    def line_cov(self, a: str, b: str) -> np.ndarray:
        """2x2 covariance between camera a's and camera b's (alpha, beta) through the bias (a == b: the bias part of a's
        own).
        """
        return self.sensitivity[a] @ self.cov @ self.sensitivity[b].T

    def std_at(self, sample: float) -> np.ndarray:
        """(3,) posterior std of the bias at one sample coordinate."""
        rows = sp.kron(_interpolation(np.array([sample]), self.knots), sp.eye(3)).toarray()  # (3, 3K)
        return np.sqrt(np.diag(rows @ self.cov @ rows.T))

    def observability(self, sample: float) -> float:
        """1 - posterior / prior variance of the horizontal bias at one sample coordinate (0: only
        the prior, 1: known).
        """
        std = self.std_at(sample)
        return float(np.clip(1.0 - (std[0] ** 2 + std[1] ** 2) / (self.prior[0] ** 2 + self.prior[1] ** 2), 0.0, 1.0))


def fit_log_bias(
    cameras: list[BiasCamera],
    path: PiecewiseTrajectory,
    rate: float,
    model: LogModel,
    f_scale: float,
    estimate: bool = True,
) -> LogBias:
    """Every camera's line and the log's bias, fitted together (see the module); ``rate``: log samples per second.

    estimate False: no fit; the bias at zero, the cameras' lines as they are, and the bias's uncertainty at its prior
    (the data told nothing that was used).
    """
    knots = _knots(cameras, path, rate, model)
    prior = np.array([model.bias_m, model.bias_m, model.bias_vertical_m])
    whiten = _prior_whitening(knots, rate, model.tau_s, prior)
    problem = _Joint(cameras, path, knots, whiten, f_scale, rate)
    z = np.concatenate([problem.x0, np.zeros(3 * len(knots))])
    converged = True
    if estimate:
        z, converged = _graduated(problem, z, f_scale)
    posterior, sensitivity, information, evidence = problem.uncertainty(z)
    if not estimate:
        posterior = np.linalg.pinv((whiten.T @ whiten).toarray())
    lines = {c.name: problem.line(z, k) for k, c in enumerate(cameras)}
    values = z[2 * len(cameras) :].reshape(-1, 3)
    return LogBias(knots, values, posterior, prior, lines, sensitivity, converged, information, evidence, model)


def fit_log_bias_measured(
    cameras: list[BiasCamera], path: PiecewiseTrajectory, rate: float, model: LogModel, f_scale: float
) -> LogBias:
    """fit_log_bias under the model's prior, with the bias's std and correlation time of the largest marginal
    likelihood (bias_marginal_likelihood) as its estimate (where the fit stopped when it did not converge, recorded
    only: the expansion holds at any point). The fit is redone under the estimate, which becomes its model, when the
    pixels reject the model's bias (the estimate gains DECISIVE_NATS of log posterior over the model's values) for one
    smaller than the log's own white noise or than BELOW_PRIOR of the model's bias (two of its prior's log-normal stds
    below it): a good receiver's log declared a phone's, an RTK log's bias of centimetres among them; and when the
    estimate is larger than the model's bias, up to the model's over BELOW_PRIOR: a log that wanders more than
    declared (the estimate's log-normal prior already pulls it towards the model's). Otherwise the model's prior
    stands: a smaller estimate within reach of it, applied, moved drone2's worst pair from 1.11 to 1.34 frames and cost
    phone walks accuracy (docs/algorithm.md, "The log's error")."""
    bias = fit_log_bias(cameras, path, rate, model, f_scale)
    if not model.has_bias:
        return bias
    found, gain = bias_marginal_likelihood(bias, rate, model)
    if "bias_m" not in found.measured:
        return bias
    estimate = (found.bias_m, found.tau_s)
    if not bias.converged or not _applies(found, gain, model):
        return replace(bias, estimate=estimate)
    again = fit_log_bias(cameras, path, rate, found, f_scale)
    return replace(again if again.converged else bias, estimate=estimate)


def _applies(found: LogModel, gain: float, model: LogModel) -> bool:
    """Whether the bias's estimate replaces the model's: decisively smaller (see fit_log_bias_measured), or larger
    than the model's and within its prior's reach (under its std over BELOW_PRIOR; beyond it, a fit in a wrong basin
    rather than a receiver)."""
    if found.bias_m > model.bias_m:
        return found.bias_m <= model.bias_m / BELOW_PRIOR
    return gain >= DECISIVE_NATS and found.bias_m < max(model.white_m, BELOW_PRIOR * model.bias_m)


def bias_marginal_likelihood(bias: LogBias, rate: float, model: LogModel) -> tuple[LogModel, float]:
    """The model with the bias's horizontal std and correlation time (the vertical std in the model's proportion)
    of the largest marginal likelihood of the cameras' pixels: type-II maximum likelihood on the fit's Gaussian
    approximation. The knots' error is two Gauss-Markov terms: the bias (correlation time above SCALE_SPLIT_S, the
    model's std and time as log-normal priors, PRIOR_LOG_SD) and a short one (below SCALE_SPLIT_S, prior std the
    model's white noise, prior time FAST_TAU_S): what the smoothed log's white noise and the knots' interpolation
    leave, which one term would take for a fast bias. The pixels say of the knots b what a likelihood
    exp(-b^T H b / 2 + h^T b) says (H: LogBias.information; h = (Q_0 + H) b_0 from the fit's b_0 and the model's
    prior precision Q_0); with b = s + f, s and f of precisions Q_s and Q_f, the evidence is
    log |Q_s| / 2 + log |Q_f| / 2 - log |A| / 2 + g^T A^-1 g / 2, A = diag(Q_s, Q_f) + [[H, H], [H, H]],
    g = (h, h): H is banded less a low rank (KnotInformation), so A is too (_log_det_and_quadratic: a sparse LU of
    the banded part, a solve per column of the low rank; marginalising the lines had filled each visit's block, whose
    LU cost 0.5 s an evaluation on drone2 flown twice slower). Sigmas within 0.01-30 m.
    Also the log posterior (nats) the estimate gains over the model's values (0: the model kept)."""
    ratio = model.bias_vertical_m / model.bias_m if model.bias_m > 0 else 2.0
    start = np.log([model.bias_m, max(model.tau_s, SCALE_SPLIT_S), max(model.white_m, FAST_FLOOR_M), FAST_TAU_S])
    both = sp.kron(np.ones((2, 2)), bias.information.banded, format="csc")
    lines = np.vstack([bias.information.low_rank, bias.information.low_rank])
    g = np.r_[bias.evidence, bias.evidence]

    def negative(theta: np.ndarray) -> float:
        sigma, tau, fast, fast_tau = np.exp(theta)
        slow_whiten = _prior_whitening(bias.knots, rate, tau, np.array([sigma, sigma, ratio * sigma]))
        fast_whiten = _prior_whitening(bias.knots, rate, fast_tau, np.array([fast, fast, ratio * fast]))
        precision = sp.block_diag([slow_whiten.T @ slow_whiten, fast_whiten.T @ fast_whiten], format="csc")
        log_det_prior = float(np.sum(np.log(slow_whiten.diagonal())) + np.sum(np.log(fast_whiten.diagonal())))
        half_log_det, quadratic = _log_det_and_quadratic(precision + both, lines, g)
        evidence = log_det_prior - half_log_det + 0.5 * quadratic
        return -evidence + 0.5 * float(np.sum(((theta - start) / PRIOR_LOG_SD) ** 2))

    bounds = [
        (np.log(0.01), np.log(30.0)),
        (np.log(SCALE_SPLIT_S), np.log(3600.0)),
        (np.log(0.01), np.log(30.0)),
        (np.log(0.5), np.log(SCALE_SPLIT_S)),
    ]
    found = minimize(negative, start, method="L-BFGS-B", bounds=bounds)
    at_model = negative(start)
    if not np.isfinite(found.fun) or found.fun > at_model:
        return model, 0.0
    sigma, tau = np.exp(found.x[:2])
    measured = tuple(sorted({*model.measured, "bias_m", "tau_s"}))
    estimated = replace(
        model, bias_m=float(sigma), bias_vertical_m=float(ratio * sigma), tau_s=float(tau), measured=measured
    )
    return estimated, float(at_model - found.fun)


def _log_det_and_quadratic(banded: sp.csc_matrix, low_rank: np.ndarray, g: np.ndarray) -> tuple[float, float]:
    """log |A| / 2 and g^T A^-1 g of the positive definite A = banded - low_rank @ low_rank.T, by a sparse LU of the
    banded part and the low rank's r columns (the determinant lemma and Woodbury's identity): no dense matrix over
    the knots. (inf, 0) where A is not positive definite."""
    try:
        factor = splu(banded)
    except RuntimeError:  # singular
        return np.inf, 0.0
    solved = factor.solve(np.column_stack([g, low_rank]))
    y, across = solved[:, 0], low_rank.T @ solved[:, 1:]
    capacitance = np.eye(low_rank.shape[1]) - across
    sign, log_det_capacitance = np.linalg.slogdet(capacitance)
    if sign <= 0:
        return np.inf, 0.0
    half_log_det = 0.5 * (float(np.sum(np.log(np.abs(factor.U.diagonal())))) + log_det_capacitance)
    projected = low_rank.T @ y
    return half_log_det, float(g @ y + projected @ np.linalg.solve(capacitance, projected))


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


def _interpolation(samples: np.ndarray, knots: np.ndarray) -> sp.csr_matrix:
    """(N, K) sparse weights of the knots at each sample coordinate (two per row)."""
    left, right, u = _interpolation_parts(samples, knots)
    rows = np.arange(len(samples))
    return sp.csr_matrix((np.r_[1.0 - u, u], (np.r_[rows, rows], np.r_[left, right])), shape=(len(samples), len(knots)))


class _Joint:
    """The joint problem in z = (x_c = (1 / alpha_c, sample at camera c's middle clock) for each camera, then the
    knots' values, knot-major); residuals: each camera's weighted pixel offsets divided by its inflation (unit
    variance: _inflation), then each slope prior, then the whitened bias prior, the priors times ``prior_weight``
    (1: as stated, the weight the posterior's covariance gives them).

    Every matrix over frames is sparse: a frame's pixels depend on its camera's two line parameters and on the
    two knots around it (6 values), so the Jacobian has 8 entries a row whatever the number of cameras and knots.
    ``rate``: the log's samples per second (the window of the image velocity, ``seen_rates``).
    """

    def __init__(
        self,
        cameras: list[BiasCamera],
        path: PiecewiseTrajectory,
        knots: np.ndarray,
        whiten: sp.csr_matrix,
        f_scale: float,
        rate: float,
    ):
        self.cameras, self.path, self.knots, self.whiten, self.f_scale = cameras, path, knots, whiten, f_scale
        self.prior_weight = 1.0
        self.seen = [image_velocity(c.clock, c.xy, SEEN_VELOCITY_S * c.alpha * rate) for c in cameras]
        self.n = len(cameras)
        self.x0 = np.concatenate([[1.0 / c.alpha, (c.middle - c.beta) / c.alpha] for c in cameras])
        spans = [max(float(np.ptp(c.clock)), 1.0) for c in cameras]
        self.scale = np.concatenate(
            [
                np.concatenate([[0.1 / span / c.alpha + 1e-9, 0.1] for c, span in zip(cameras, spans)]),
                np.full(3 * len(knots), 0.1),
            ]
        )
        self.priors = [c.prior for c in cameras if c.prior is not None]
        pixels = sum(2 * len(c.clock) for c in cameras)
        self.quadratic = np.r_[np.zeros(pixels, bool), np.ones(len(self.priors) + whiten.shape[0], bool)]
        self.loss: Callable = _soft_l1_except(self.quadratic)
        self._cache: dict[bytes, tuple[list[np.ndarray], list[sp.csr_matrix]]] = {}
        self.inflation = np.ones(self.n)
        start = np.concatenate([self.x0, np.zeros(3 * len(knots))])
        self.inflation = np.array(
            [
                _inflation(c, r, j, f_scale, start[2 * k : 2 * k + 2], c.cov)
                for k, (c, r, j) in enumerate(zip(cameras, *self._pixels(start)))
            ]
        )
        self._cache.clear()

    def with_prior_weight(self, weight: float) -> _Joint:
        """The same problem with its priors times ``weight`` (the cameras' pixels and inflation shared)."""
        stiffer = copy.copy(self)
        stiffer.prior_weight = weight
        return stiffer

    def line(self, z: np.ndarray, k: int) -> tuple[float, float]:
        u, s0 = z[2 * k : 2 * k + 2]
        return 1.0 / u, self.cameras[k].middle - s0 / u

    def _pixels(self, z: np.ndarray) -> tuple[list[np.ndarray], list[sp.csr_matrix]]:
        """Per camera: (N, 2) weighted residuals and their (2N, 2 + 3K) sparse Jacobian in (its x, the knots)."""
        key = z.tobytes()
        if key not in self._cache:
            self._cache.clear()
            bias = z[2 * self.n :].reshape(-1, 3)
            residuals, jacobians = [], []
            for k, c in enumerate(self.cameras):
                u, s0 = z[2 * k : 2 * k + 2]
                s = s0 + u * (c.clock - c.middle)
                r, along, knots = _camera_rows(c, self.path, self.knots, bias, s)
                scale = 1.0 / np.sqrt(self.inflation[k])
                residuals.append(r * scale)
                line = np.column_stack([along * np.repeat(c.clock - c.middle, 2), along])
                jacobians.append(scale * sp.hstack([sp.csr_matrix(line), knots], format="csr"))
            self._cache[key] = (residuals, jacobians)
        return self._cache[key]

    def residual(self, z: np.ndarray) -> np.ndarray:
        residuals, _ = self._pixels(z)
        priors = [
            self.prior_weight * (c.prior.alpha * z[2 * k] - 1.0) / c.prior.sigma
            for k, c in enumerate(self.cameras)
            if c.prior is not None
        ]
        return np.concatenate(
            [*(r.ravel() for r in residuals), priors, self.prior_weight * (self.whiten @ z[2 * self.n :])]
        )

    def jacobian(self, z: np.ndarray) -> sp.csr_matrix:
        _, jacobians = self._pixels(z)
        lines = 2 * self.n
        rows = []
        for k, jac in enumerate(jacobians):
            before, after = sp.csr_matrix((jac.shape[0], 2 * k)), sp.csr_matrix((jac.shape[0], lines - 2 * k - 2))
            rows.append(sp.hstack([before, jac[:, :2], after, jac[:, 2:]], format="csr"))
        for k, c in enumerate(self.cameras):
            if c.prior is not None:
                rows.append(
                    sp.csr_matrix(
                        ([self.prior_weight * c.prior.alpha / c.prior.sigma], ([0], [2 * k])), shape=(1, len(z))
                    )
                )
        rows.append(
            sp.hstack([sp.csr_matrix((self.whiten.shape[0], lines)), self.prior_weight * self.whiten], format="csr")
        )
        return sp.vstack(rows, format="csr")

    def _seen_line_columns(self, k: int, jac: sp.csr_matrix, z: np.ndarray) -> sp.csr_matrix:
        """Camera k's Jacobian with its line's columns (pixels per unit of 1 / alpha and of the middle sample) taken
        from the target's image velocity on its track (``seen``) where it is measured, from the log's elsewhere."""
        c = self.cameras[k]
        logged = np.asarray(jac[:, 1].todense()).ravel()
        seen = (self.seen[k] * c.weight[:, None] / (z[2 * k] * np.sqrt(self.inflation[k]))).ravel()
        along = np.where(np.isfinite(seen), seen, logged)
        line = np.column_stack([along * np.repeat(c.clock - c.middle, 2), along])
        return sp.hstack([sp.csr_matrix(line), jac[:, 2:]], format="csr")

    def uncertainty(self, z: np.ndarray) -> tuple[np.ndarray, dict[str, np.ndarray], KnotInformation, np.ndarray]:
        """The knots' posterior covariance (m^2), each camera's sensitivity d(alpha, beta) / d(knots), and what the
        pixels say of the knots b (the lines marginalised): the likelihood exp(-b^T H b / 2 + h^T b), H (3K, 3K) the
        posterior's inverse less the prior's, h (3K,) = H b_z - the marginalised gradient of the cost at z, both from
        one quadratic expansion of the cost at z (z need not be its optimum).

        A frame's pixels move with the line (time) as the target moved in the image: its velocity measured on the
        track (image_velocity), not the log's projected. The log's motion over less than a knot's spacing carries
        the bias's unresolved wander and the white noise: taken as the target's, it tells the bias along the path
        from a time shift where the path is straight (on straight walks at 5 m/s under a drone's log, 78 % of the
        pairs' intervals held the truth; 95 % with the track's velocity). The same line columns give h, so a
        direction along the path H leaves uninformed carries no evidence either.

        Each camera's information is its robust bread J^T psi' J divided by its residuals' variance factor
        (sum psi^2 / sum psi', the M-estimator's), inflated by its covariance (BiasCamera.cov) over that naive
        one where residuals correlate in time; its gradient J^T psi is divided the same; the prior's is W^T W. The
        posterior inflates each camera's by its own refinement's covariance (BiasCamera.cov_interval) instead.
        """
        residuals, jacobians = self._pixels(z)
        banded = sp.csc_matrix((3 * len(self.knots), 3 * len(self.knots)))
        banded_interval = banded
        low_rank, low_rank_interval = [], []
        score = np.zeros(3 * len(self.knots))
        blocks = []
        for k, (r, jac) in enumerate(zip(residuals, jacobians)):
            c, x = self.cameras[k], z[2 * k : 2 * k + 2]
            jac = self._seen_line_columns(k, jac, z)
            inflation = _inflation(c, r, jac, self.f_scale, x, c.cov)
            h = _bread(c, r, jac, self.f_scale) / inflation
            g = _gradient(c, r, jac, self.f_scale, z[2 * k]) / inflation
            h_tt, h_tb, h_bb = h[:2, :2], h[:2, 2:], h[2:, 2:]
            root = _pinv_sqrt(h_tt)  # a camera whose line the residuals do not determine tells nothing of the bias
            gain = root @ root @ h_tb  # (2, 3K)
            banded = banded + sp.csc_matrix(h_bb)
            low_rank.append(h_tb.T @ root)
            own = inflation / _inflation(
                c, r, jac, self.f_scale, x, c.cov if c.cov_interval is None else c.cov_interval
            )
            banded_interval = banded_interval + sp.csc_matrix(own * h_bb)
            low_rank_interval.append(np.sqrt(own) * h_tb.T @ root)
            score = score + g[2:] - gain.T @ g[:2]
            blocks.append((gain, z[2 * k : 2 * k + 2]))
        data = KnotInformation(banded, np.hstack(low_rank))
        seen = KnotInformation(banded_interval, np.hstack(low_rank_interval))
        posterior = np.linalg.pinv((self.whiten.T @ self.whiten).toarray() + seen.dense())
        sensitivity = {}
        for c, (gain, (u, s0)) in zip(self.cameras, blocks):
            to_line = np.array(
                [[-1.0 / u**2, 0.0], [s0 / u**2, -1.0 / u]]
            )  # d(alpha, beta) / d(u, s0), beta = middle - s0 / u
            sensitivity[c.name] = to_line @ (-gain)
        return posterior, sensitivity, data, data @ z[2 * self.n :] - score


def _pinv_sqrt(matrix: np.ndarray) -> np.ndarray:
    """The symmetric square root of a symmetric positive semi-definite matrix's pseudo-inverse (np.linalg.pinv's
    cut-off: eigenvalues below 1e-15 of the largest count as zero)."""
    values, vectors = np.linalg.eigh(matrix)
    kept = values > 1e-15 * max(float(values.max(initial=0.0)), 0.0)
    inverse_root = np.zeros_like(values)
    inverse_root[kept] = 1.0 / np.sqrt(values[kept])
    return (vectors * inverse_root) @ vectors.T


def _camera_rows(
    c: BiasCamera, path: PiecewiseTrajectory, knots: np.ndarray, bias: np.ndarray, s: np.ndarray
) -> tuple[np.ndarray, np.ndarray, sp.csr_matrix]:
    """One camera's (N, 2) weighted pixel residuals at samples s, their (2N,) derivative in s, and their (2N, 3K)
    sparse derivative in the knots (rows u0, v0, u1, v1 ...)."""
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
    gradient = np.stack(
        [(uv_all[(2 + a) * n : (3 + a) * n] - uv) / METRE_STEP for a in range(3)], axis=2
    )  # (N, 2, 3) pixels per metre
    r = (uv - c.xy) * c.weight[:, None]
    along = rate * c.weight[:, None]
    gradient = gradient * c.weight[:, None, None]
    finite = np.isfinite(r).all(axis=1) & np.isfinite(along).all(axis=1)
    bad = ~(finite & np.isfinite(gradient.reshape(n, -1)).all(axis=1))
    r[bad] = 10.0
    along[bad] = 0.0
    gradient[bad] = 0.0
    left, right, u = _interpolation_parts(s, knots)
    rows = np.broadcast_to(np.arange(2 * n).reshape(n, 2, 1), (n, 2, 3))
    columns = np.arange(3)[None, None, :]
    values = np.concatenate([(gradient * (1.0 - u)[:, None, None]).ravel(), (gradient * u[:, None, None]).ravel()])
    at_left = (columns + 3 * left[:, None, None] + 0 * rows).ravel()
    at_right = (columns + 3 * right[:, None, None] + 0 * rows).ravel()
    indices = (np.r_[rows.ravel(), rows.ravel()], np.r_[at_left, at_right])
    return r, along.ravel(), sp.csr_matrix((values, indices), shape=(2 * n, 3 * len(knots)))


def _bread(c: BiasCamera, r: np.ndarray, jac: sp.csr_matrix, f_scale: float) -> np.ndarray:
    """One camera's robust Gauss-Newton information J^T psi' J (its slope prior included), in (its x, the knots)."""
    dpsi = (1.0 + (r / f_scale) ** 2) ** -1.5
    bread = (jac.T @ sp.diags(dpsi.ravel()) @ jac).toarray()
    if c.prior is not None:
        bread[0, 0] += (c.prior.alpha / c.prior.sigma) ** 2
    return bread


def _gradient(c: BiasCamera, r: np.ndarray, jac: sp.csr_matrix, f_scale: float, u: float) -> np.ndarray:
    """One camera's gradient of its robust cost J^T psi (its slope prior's included; u its 1 / alpha), in (its x, the
    knots): the bread's companion."""
    psi = r / np.sqrt(1.0 + (r / f_scale) ** 2)
    gradient = np.asarray(jac.T @ psi.ravel()).ravel()
    if c.prior is not None:
        gradient[0] += (c.prior.alpha * u - 1.0) * c.prior.alpha / c.prior.sigma**2
    return gradient


def _inflation(
    c: BiasCamera, r: np.ndarray, jac: sp.csr_matrix, f_scale: float, x: np.ndarray, cov: np.ndarray
) -> float:
    """What one camera's residuals' information is divided by: their variance factor (sum psi^2 / sum psi', the
    M-estimator's) times how much more the covariance ``cov`` of its line says than that naive one (>= 1)."""
    variance = _variance_factor(r, f_scale)
    return variance * _correlation_factor(_bread(c, r, jac, f_scale), variance, x, cov)


def _variance_factor(r: np.ndarray, f_scale: float) -> float:
    """The M-estimator's variance factor of residuals r under the soft L1 loss: sum psi^2 / sum psi'."""
    q = (r / f_scale) ** 2
    psi, dpsi = r / np.sqrt(1.0 + q), (1.0 + q) ** -1.5
    return max(float(np.sum(psi**2) / max(np.sum(dpsi), 1e-12)), 1e-6)


def _correlation_factor(bread: np.ndarray, variance: float, x: np.ndarray, cov: np.ndarray) -> float:
    """How much a covariance ``cov`` of the camera's (alpha, beta) exceeds the naive one from its residuals (>= 1):
    residuals correlated in time (pose, log) carry less information than their number says."""
    try:
        naive_x = variance * np.linalg.inv(bread[:2, :2])
    except np.linalg.LinAlgError:
        return 1.0
    u, s0 = x
    d = np.array([[-1.0 / u**2, 0.0], [s0 / u**2, -1.0 / u]])
    naive = d @ naive_x @ d.T
    ratio = np.trace(cov) / max(np.trace(naive), 1e-300)
    return float(np.clip(ratio, 1.0, 1e6)) if np.isfinite(ratio) else 1.0


def _graduated(problem: _Joint, z: np.ndarray, f_scale: float) -> tuple[np.ndarray, bool]:
    """The joint optimum with the priors as stated: of the optima reached from z (the cameras' own lines) and from
    the optimum with the priors' std f_scale times smaller (a prior's sigma weighing as a pixel residual of the
    loss scale), the one of least cost. The problem is not convex: from the cameras' lines the solver can slide to
    far worse optima (drone walk scene 0: a camera with few votes and a 24 m vertical bias, at 80 times the cost),
    and from the stiffer optimum it can stay in a worse basin (phone walk scenes)."""
    stiff, _ = _levenberg_marquardt(problem.with_prior_weight(f_scale), z, f_scale)
    found = [_levenberg_marquardt(problem, start, f_scale) for start in (z, stiff)]
    return min(found, key=lambda f: _cost(problem, f[0], f_scale))


def _cost(problem: _Joint, z: np.ndarray, f_scale: float) -> float:
    """The joint problem's robust cost at z (infinite where a residual is not finite)."""
    return _robust_cost(problem, problem.residual(z), f_scale)


def _robust_cost(problem: _Joint, residual: np.ndarray, f_scale: float) -> float:
    """The robust cost of residuals: soft L1 at f_scale on the pixels, quadratic on the priors."""
    if not np.isfinite(residual).all():
        return np.inf
    return 0.5 * f_scale**2 * float(np.sum(problem.loss((residual / f_scale) ** 2)[0]))


def _levenberg_marquardt(
    problem: _Joint, z: np.ndarray, f_scale: float, max_nfev: int = 100, tol: float = 1e-8
) -> tuple[np.ndarray, bool]:
    """The robust least squares of the joint problem from z: Levenberg-Marquardt on the normal equations, which are
    (2C + 3K) square whatever the number of frames (J sparse), with the loss's curvature as scipy's least_squares
    scales it and the damping in the units of ``problem.scale``. Converged: the cost, the step or the gradient
    stopped changing (relative ``tol``) within ``max_nfev`` evaluations of the residuals."""

    def cost(residual: np.ndarray) -> float:
        return _robust_cost(problem, residual, f_scale)

    units = 1.0 / problem.scale**2
    residual = problem.residual(z)
    current, evaluations, damping, moved = cost(residual), 1, -1.0, True
    while evaluations < max_nfev:
        if moved:
            rho = problem.loss((residual / f_scale) ** 2)
            jac = problem.jacobian(z)
            gradient = jac.T @ (rho[1] * residual)
            if np.max(np.abs(gradient * problem.scale)) <= tol * max(current, 1e-12):
                return z, True
            curvature = np.maximum(rho[1] + 2.0 * rho[2] * (residual / f_scale) ** 2, 1e-10)
            hessian = (jac.T @ sp.diags(curvature) @ jac).tocsc()
            damping = 1e-3 * float(np.max(hessian.diagonal() / units)) if damping < 0 else damping
        step = _solve_sparse((hessian + sp.diags(damping * units)).tocsc(), -gradient)
        trial_residual = problem.residual(z + step) if np.isfinite(step).all() else np.full_like(residual, np.nan)
        trial = cost(trial_residual)
        evaluations += 1
        moved = trial <= current
        if not moved:
            damping *= 4.0
            continue
        z, residual, drop, current = z + step, trial_residual, current - trial, trial
        damping /= 3.0
        small_step = np.linalg.norm(step / problem.scale) <= tol * (tol + np.linalg.norm(z / problem.scale))
        if drop <= tol * current or small_step:
            return z, True
    return z, False


def _solve_sparse(matrix: sp.csc_matrix, rhs: np.ndarray) -> np.ndarray:
    """matrix^-1 rhs by a sparse LU (the normal equations are banded in the knots, with a few dense rows per camera);
    NaN when the matrix is singular."""
    try:
        return splu(matrix).solve(rhs)
    except RuntimeError:  # exactly singular
        return np.full_like(rhs, np.nan)


def _soft_l1_except(quadratic: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """scipy least_squares loss (rho, rho', rho''): soft L1, but quadratic where ``quadratic`` is set (the priors)."""

    def loss(z: np.ndarray) -> np.ndarray:
        t = 1.0 + z
        out = np.vstack([2.0 * (np.sqrt(t) - 1.0), t**-0.5, -0.5 * t**-1.5])
        out[0, quadratic], out[1, quadratic], out[2, quadratic] = z[quadratic], 1.0, 0.0
        return out

    return loss
