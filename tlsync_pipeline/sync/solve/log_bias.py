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

A white log's error at a fix is seen at once by every camera that sees the
target then (views of one patch): fit_white_log fits those cameras' lines
with the error at every fix and half fix under their frames (the measured
white noise as the knots' prior), each camera's pixels weighed by the
correlation left in its residuals against the log so corrected, not by
its own refinement's covariance against the log as logged (which counts
the very error the knots model as lost information).
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
from tlsync_pipeline.sync.identify.refine import BLOCKS
from tlsync_pipeline.sync.kernels.gauss_markov import interpolation_parts as _interpolation_parts
from tlsync_pipeline.sync.kernels.gauss_markov import prior_whitening as _prior_whitening
from tlsync_pipeline.sync.kernels.slope import SlopePrior
from tlsync_pipeline.sync.kernels.sparse_lm import (
    levenberg_marquardt,
    residual_correlation,
    robust_cost,
    soft_l1_except,
    variance_factor,
)
from tlsync_pipeline.sync.kernels.velocity import image_velocity
from tlsync_pipeline.sync.model.log_model import PRIOR_LOG_SD, LogModel
from tlsync_pipeline.trajectory import PiecewiseTrajectory

KNOTS_PER_TAU = 4  # knots of the bias per correlation time between the visits
VISIT_KNOT_S = 2.0  # seconds between knots during a visit: a Gauss-Markov bias moves by sigma x sqrt(2 dt / tau) in dt
MAX_KNOTS = 400
SAMPLE_STEP = 1e-3  # samples: finite-difference step of a position along the path
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
    measured (fit_log_bias_measured); common: per camera d(alpha, beta) per std of a shift of the log's time that
    every camera shares and the fit does not resolve (with_common_shift), or None."""

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
    common: dict[str, np.ndarray] | None = None

    def at(self, samples: np.ndarray) -> np.ndarray:
        """(N, 3) bias at sample coordinates (linear between knots, constant beyond them)."""
        return np.column_stack([np.interp(samples, self.knots, self.values[:, k]) for k in range(3)])

    def line_cov(self, a: str, b: str) -> np.ndarray:
        """2x2 covariance between camera a's and camera b's (alpha, beta) through the bias (a == b: the bias part of a's
        own).
        """
        shared = self.sensitivity[a] @ self.cov @ self.sensitivity[b].T
        if self.common is None:
            return shared
        return shared + np.outer(self.common[a], self.common[b])

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
    return _fitted(problem, z, converged, estimate, prior, model)


def fit_white_log(
    cameras: list[BiasCamera],
    path: PiecewiseTrajectory,
    rate: float,
    model: LogModel,
    f_scale: float,
    estimate: bool = True,
) -> LogBias | None:
    """Every camera's line and the log's white error at each fix, fitted together: for cameras that see the target at
    the same time (shared_fixes), which see each fix's error at once. The knots are the fixes around the cameras'
    frames (white_knots), their prior the model's white noise on every axis, correlated over one fix interval (the
    smoothed log's error at a fix leans on its neighbours'). Each camera's pixels are weighed by their variance factor
    and the correlation left in its residuals against the log so corrected (_Joint.remeasured): its own refinement's
    covariance, measured against the log as logged, counts the very error the knots model as lost information.
    None when the fixes are more than MAX_KNOTS. ``estimate`` as fit_log_bias's."""
    knots = white_knots(cameras, path)
    if knots is None:
        return None
    prior = np.full(3, model.white_m)
    whiten = _prior_whitening(knots, rate, 1.0 / rate, prior)
    problem = _Joint(cameras, path, knots, whiten, f_scale, rate, measured=True)
    z = np.concatenate([problem.x0, np.zeros(3 * len(knots))])
    converged = True
    if estimate:
        z, converged = _graduated(problem, z, f_scale)
        problem = problem.remeasured(z)
        z, converged = _graduated(problem, z, f_scale)
    return _fitted(problem, z, converged, estimate, prior, model)


def _fitted(
    problem: _Joint, z: np.ndarray, converged: bool, estimate: bool, prior: np.ndarray, model: LogModel
) -> LogBias:
    """The LogBias of the joint problem at z (its uncertainty from the expansion there)."""
    cameras, knots, whiten = problem.cameras, problem.knots, problem.whiten
    posterior, sensitivity, information, evidence = problem.uncertainty(z)
    if not estimate:
        posterior = np.linalg.pinv((whiten.T @ whiten).toarray())
    lines = {c.name: problem.line(z, k) for k, c in enumerate(cameras)}
    values = z[2 * len(cameras) :].reshape(-1, 3)
    return LogBias(knots, values, posterior, prior, lines, sensitivity, converged, information, evidence, model)


def with_common_shift(bias: LogBias, rate: float, shift_s: float) -> LogBias:
    """The bias with a shift of the log's time of std ``shift_s`` (seconds) shared by every camera: camera c's beta
    moves by alpha_c x rate x the shift, which the pairs' relations do not see."""
    common = {name: np.array([0.0, line[0] * rate * shift_s]) for name, line in bias.lines.items()}
    return replace(bias, common=common)


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
    """Knot sample coordinates over the cameras' visits (bias_knots)."""
    return bias_knots([(c.clock - c.beta) / c.alpha for c in cameras], path, rate, model)


def bias_knots(visits: list[np.ndarray], path: PiecewiseTrajectory, rate: float, model: LogModel) -> np.ndarray:
    """Knot sample coordinates: every VISIT_KNOT_S over each visit (``visits``: each camera's frames' samples; the
    bias wanders within it), every tau / KNOTS_PER_TAU from one correlation time before the first visit to one after
    the last; at most MAX_KNOTS."""
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


def _visit_samples(c: BiasCamera) -> np.ndarray:
    """The log samples of the camera's frames under its line."""
    return (c.clock - c.beta) / c.alpha


def _fixes_around(samples: np.ndarray, fixes: np.ndarray) -> np.ndarray:
    """Indices of the fixes either side of each sample coordinate (the log's error there is theirs)."""
    right = np.clip(np.searchsorted(fixes, samples, side="right"), 1, len(fixes) - 1)
    return np.unique(np.r_[right - 1, right])


def shared_fixes(visits: list[np.ndarray], path: PiecewiseTrajectory) -> int:
    """The longest run of consecutive intervals between the log's fixes in which two or more cameras have frames
    (``visits``: each camera's frames' log samples): cameras that see the target at the same time see those fixes'
    errors at once; a walk from one view into the next within one interval is a run of one."""
    fixes = path.sample
    seen = [np.unique(np.clip(np.searchsorted(fixes, v, side="right") - 1, 0, None)) for v in visits if len(v)]
    if not seen:
        return 0
    both = np.bincount(np.concatenate(seen), minlength=len(fixes)) >= 2
    runs = np.diff(np.flatnonzero(np.diff(np.r_[0, both.astype(int), 0])))[::2]
    return int(runs.max(initial=0))


def white_knots(cameras: list[BiasCamera], path: PiecewiseTrajectory) -> np.ndarray | None:
    """The knots of the log's white error: the sample coordinates of the fixes around every camera's frames (and one
    more each side) and the half-way points between consecutive ones (the error bends between fixes as the cubic path
    through them does); None when they are more than MAX_KNOTS."""
    fixes = path.sample
    around = np.concatenate([_fixes_around(_visit_samples(c), fixes) for c in cameras])
    kept = fixes[np.unique(np.clip(np.r_[around - 1, around, around + 1], 0, len(fixes) - 1))]
    halves = (kept[1:] + kept[:-1])[np.diff(kept) <= 1.0 + 1e-9] / 2.0
    knots = np.unique(np.r_[kept, halves])
    return knots if 2 <= len(knots) <= MAX_KNOTS else None


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

    No matrix runs over frames: a frame's pixels depend on its camera's two line parameters and on the two knots
    around it (6 values), so its Jacobian rows have 8 entries, and the normal equations are summed frame by frame
    into each knot interval (normal_equations). A trial step's residuals project only the frames' positions
    (_views); the finite differences are projected once the step is taken (_pixels).
    ``rate``: the log's samples per second (the window of the image velocity, ``seen_rates``). ``measured``: each
    camera's inflation is its residuals' variance factor alone, until ``remeasured`` at a fit's optimum (fit_white_log).
    """

    def __init__(
        self,
        cameras: list[BiasCamera],
        path: PiecewiseTrajectory,
        knots: np.ndarray,
        whiten: sp.csr_matrix,
        f_scale: float,
        rate: float,
        measured: bool = False,
    ):
        self.cameras, self.path, self.knots, self.whiten, self.f_scale = cameras, path, knots, whiten, f_scale
        self.prior_weight = 1.0
        self.seen = [image_velocity(c.clock, c.xy, SEEN_VELOCITY_S * c.alpha * rate) for c in cameras]
        self.n = len(cameras)
        self.leading = 2 * self.n
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
        self.loss: Callable = soft_l1_except(self.quadratic)
        self._cache: dict[bytes, list[_CameraRows]] = {}
        self._view_cache: dict[bytes, list[_CameraView]] = {}
        self.inflation = np.ones(self.n)
        self.correlation: np.ndarray | None = np.ones(self.n) if measured else None
        start = np.concatenate([self.x0, np.zeros(3 * len(knots))])
        self.inflation = np.array(
            [
                variance_factor(rows.residual, f_scale)
                if measured
                else _inflation(
                    c, rows.residual, rows.local_jacobian(c, len(knots)), f_scale, start[2 * k : 2 * k + 2], c.cov
                )
                for k, (c, rows) in enumerate(zip(cameras, self._pixels(start)))
            ]
        )
        self._cache.clear()

    def remeasured(self, z: np.ndarray) -> _Joint:
        """The same problem with each camera's inflation measured on its residuals at z, against the log corrected by
        z's knots: their variance factor times the correlation left in them (residual_correlation)."""
        inflation, correlation = np.ones(self.n), np.ones(self.n)
        for k, (c, rows) in enumerate(zip(self.cameras, self._pixels(z))):
            r = rows.residual / rows.scale
            jac = rows.local_jacobian(c, len(self.knots))[:, :2].toarray() / rows.scale
            correlation[k] = residual_correlation(r, jac, self.f_scale, BLOCKS)
            inflation[k] = variance_factor(r, self.f_scale) * correlation[k]
        again = copy.copy(self)
        again.inflation, again.correlation = inflation, correlation
        again._cache, again._view_cache = {}, {}
        return again

    def with_prior_weight(self, weight: float) -> _Joint:
        """The same problem with its priors times ``weight`` (the cameras' pixels and inflation shared)."""
        stiffer = copy.copy(self)
        stiffer.prior_weight = weight
        return stiffer

    def line(self, z: np.ndarray, k: int) -> tuple[float, float]:
        u, s0 = z[2 * k : 2 * k + 2]
        return 1.0 / u, self.cameras[k].middle - s0 / u

    def _views(self, z: np.ndarray) -> list[_CameraView]:
        """Per camera: its frames at z (the line's samples, the bias added)."""
        key = z.tobytes()
        if key not in self._view_cache:
            self._view_cache.clear()
            bias = z[2 * self.n :].reshape(-1, 3)
            views = []
            for k, c in enumerate(self.cameras):
                u, s0 = z[2 * k : 2 * k + 2]
                views.append(_camera_view(c, self.path, self.knots, bias, s0 + u * (c.clock - c.middle)))
            self._view_cache[key] = views
        return self._view_cache[key]

    def _pixels(self, z: np.ndarray) -> list[_CameraRows]:
        """Per camera: its pixel rows at z (residuals and derivatives, divided by its inflation's root)."""
        key = z.tobytes()
        if key not in self._cache:
            self._cache.clear()
            bias = z[2 * self.n :].reshape(-1, 3)
            self._cache[key] = [
                _camera_rows(c, self.path, self.knots, bias, view).scaled(1.0 / np.sqrt(self.inflation[k]))
                for k, (c, view) in enumerate(zip(self.cameras, self._views(z)))
            ]
        return self._cache[key]

    def residual(self, z: np.ndarray) -> np.ndarray:
        """The residuals at z (pixels, then the priors), without the derivatives (a trial step's): 10 for a frame off
        the path or the image (the rows, _pixels, also where a finite difference leaves the image)."""
        pixels = [
            view.residual(c) * (1.0 / np.sqrt(self.inflation[k]))
            for k, (c, view) in enumerate(zip(self.cameras, self._views(z)))
        ]
        priors = [
            self.prior_weight * (c.prior.alpha * z[2 * k] - 1.0) / c.prior.sigma
            for k, c in enumerate(self.cameras)
            if c.prior is not None
        ]
        return np.concatenate(
            [*(r.ravel() for r in pixels), priors, self.prior_weight * (self.whiten @ z[2 * self.n :])]
        )

    def _prior_jacobian(self) -> sp.csr_matrix:
        """The priors' rows of the Jacobian (each slope prior, then the whitened bias prior), constant."""
        slope = [(k, c.prior) for k, c in enumerate(self.cameras) if c.prior is not None]
        lines, whiten = 2 * self.n, self.whiten
        rows = sp.csr_matrix(
            ([p.alpha / p.sigma for _, p in slope], ([*range(len(slope))], [2 * k for k, _ in slope])),
            shape=(len(slope), lines + whiten.shape[1]),
        )
        return self.prior_weight * sp.vstack(
            [rows, sp.hstack([sp.csr_matrix((whiten.shape[0], lines)), whiten])], format="csr"
        )

    def normal_equations(
        self, z: np.ndarray, weights: np.ndarray, curvature: np.ndarray
    ) -> tuple[np.ndarray, sp.csc_matrix]:
        """J^T weights and J^T diag(curvature) J of the residuals' Jacobian J at z (weights and curvature: one per
        residual), sparse: each camera's two line columns over its visit's knots, the knots' 3x3 blocks banded."""
        lines = 2 * self.n
        width = lines + 3 * len(self.knots)
        gradient = np.zeros(width)
        entries: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        start = 0
        for k, (c, rows) in enumerate(zip(self.cameras, self._pixels(z))):
            end = start + rows.residual.size
            line_gradient, knot_gradient, line_curvature, line_knot, knot_knot, left = rows.normal_terms(
                c, weights[start:end], curvature[start:end]
            )
            start = end
            knot_columns = lines + 3 * left[:, None] + np.arange(6)  # (G, 6)
            gradient[2 * k : 2 * k + 2] += line_gradient
            np.add.at(gradient, knot_columns, knot_gradient)
            line_columns = np.array([2 * k, 2 * k + 1])
            groups = len(left)
            across_rows = np.broadcast_to(line_columns[None, :, None], (groups, 2, 6))
            across_columns = np.broadcast_to(knot_columns[:, None, :], (groups, 2, 6))
            entries += [
                (np.repeat(line_columns, 2), np.tile(line_columns, 2), line_curvature.ravel()),
                (across_rows.ravel(), across_columns.ravel(), line_knot.ravel()),
                (across_columns.ravel(), across_rows.ravel(), line_knot.ravel()),
                (
                    np.broadcast_to(knot_columns[:, :, None], (groups, 6, 6)).ravel(),
                    np.broadcast_to(knot_columns[:, None, :], (groups, 6, 6)).ravel(),
                    knot_knot.ravel(),
                ),
            ]
        priors = self._prior_jacobian()
        gradient += priors.T @ weights[start:]
        row_index, column_index, values = (np.concatenate(part) for part in zip(*entries))
        pixels = sp.csc_matrix((values, (row_index, column_index)), shape=(width, width))
        return gradient, (pixels + priors.T @ sp.diags(curvature[start:]) @ priors).tocsc()

    def _seen_along(self, k: int, rows: _CameraRows, z: np.ndarray) -> np.ndarray:
        """Camera k's pixels' derivative in the sample (2N,) taken from the target's image velocity on its track
        (``seen``) where it is measured, from the log's elsewhere."""
        c = self.cameras[k]
        seen = (self.seen[k] * c.weight[:, None] / (z[2 * k] * np.sqrt(self.inflation[k]))).ravel()
        return np.where(np.isfinite(seen), seen, rows.along * rows.scale)

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
        banded = sp.csc_matrix((3 * len(self.knots), 3 * len(self.knots)))
        banded_interval = banded
        low_rank, low_rank_interval = [], []
        score = np.zeros(3 * len(self.knots))
        blocks = []
        for k, rows in enumerate(self._pixels(z)):
            c, x = self.cameras[k], z[2 * k : 2 * k + 2]
            r, jac = rows.residual, rows.local_jacobian(c, len(self.knots), self._seen_along(k, rows, z))
            bread, variance = _bread(c, r, jac, self.f_scale), variance_factor(r, self.f_scale)
            if self.correlation is not None:  # measured against the corrected log: the posterior's weighing too
                correlation, own = float(self.correlation[k]), 1.0
            else:
                correlation = _correlation_factor(bread, variance, x, c.cov)
                interval = c.cov if c.cov_interval is None else c.cov_interval
                own = correlation / _correlation_factor(bread, variance, x, interval)
            inflation = variance * correlation
            h = bread / inflation
            g = _gradient(c, r, jac, self.f_scale, z[2 * k]) / inflation
            h_tt, h_tb, h_bb = h[:2, :2], h[:2, 2:], h[2:, 2:]
            root = _pinv_sqrt(h_tt)  # a camera whose line the residuals do not determine tells nothing of the bias
            gain = root @ root @ h_tb  # (2, 3K)
            banded = banded + sp.csc_matrix(h_bb)
            low_rank.append(h_tb.T @ root)
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


_PAIRS = (np.array([0, 0, 0, 1, 1, 2]), np.array([0, 1, 2, 1, 2, 2]))  # a symmetric 3x3's upper triangle
_SYMMETRIC = np.array([[0, 1, 2], [1, 3, 4], [2, 4, 5]])  # the 3x3 from its upper triangle's six values


def _pair_sum(values: np.ndarray) -> np.ndarray:
    """(..., N) sums of a frame's two pixel rows, (..., N, 2) given."""
    return values[..., 0] + values[..., 1]


@dataclass(frozen=True)
class _CameraRows:
    """One camera's pixel rows at its samples s: the (N, 2) weighted residuals times ``scale``; before it, their
    (2N,) derivative in s (rows u0, v0, u1, v1 ...) and their (N, 2, 3) derivative in the bias's position; the knots
    around each frame (left, its right neighbour's weight u: the bias is linear between them)."""

    residual: np.ndarray
    along: np.ndarray
    gradient: np.ndarray
    left: np.ndarray
    u: np.ndarray
    scale: float = 1.0

    def scaled(self, factor: float) -> _CameraRows:
        """The rows with their residuals times ``factor``, which the derivatives' uses apply."""
        return replace(self, residual=self.residual * factor, scale=factor)

    def local_jacobian(self, c: BiasCamera, knots: int, along: np.ndarray | None = None) -> sp.csr_matrix:
        """The rows' sparse (2N, 2 + 3K) Jacobian in (the camera's line: 1 / alpha, the middle sample; the knots, 3
        values each), 8 entries a row (the line's two, the left and the right knot's x, y, z), all times ``scale``.
        ``along``: the derivative in s to use, ``scale`` included (None: the log's)."""
        n = len(self.left)
        values = np.empty((n, 2, 8))
        if along is None:
            values[:, :, 0] = (self.along * np.repeat(c.clock - c.middle, 2)).reshape(n, 2) * self.scale
            values[:, :, 1] = self.along.reshape(n, 2) * self.scale
        else:
            values[:, :, 0] = (along * np.repeat(c.clock - c.middle, 2)).reshape(n, 2)
            values[:, :, 1] = along.reshape(n, 2)
        values[:, :, 2:5] = (self.gradient * (1.0 - self.u)[:, None, None]) * self.scale
        values[:, :, 5:8] = (self.gradient * self.u[:, None, None]) * self.scale
        columns = np.empty((n, 2, 8), int)
        columns[:, :, 0], columns[:, :, 1] = 0, 1
        at_left = 2 + 3 * self.left[:, None] + np.arange(3)
        columns[:, :, 2:5] = at_left[:, None, :]
        columns[:, :, 5:8] = (at_left + 3)[:, None, :]
        indptr = np.arange(0, 16 * n + 1, 8)
        return sp.csr_matrix((values.ravel(), columns.ravel(), indptr), shape=(2 * n, 2 + 3 * knots))

    def normal_terms(
        self, c: BiasCamera, weights: np.ndarray, curvature: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The rows' share of the normal equations, J^T (weights) and J^T diag(curvature) J, summed knot by knot
        without forming J: a frame's two rows hold the line's two columns and the two knots around it, so its
        products are the line's derivative b and the bias's g (times dc, the frame's clock from the middle, and the
        knots' weights 1 - u, u) summed over the frames that share a left knot. Returns (the line's gradient (2,), the
        knots' gradient by left knot (G, 6: left x y z, right x y z), the line's curvature (2, 2), line by knot
        (G, 2, 6), knot by knot (G, 6, 6)) and, last, the G left knots."""
        n = len(self.left)
        b = self.along.reshape(n, 2) * self.scale
        g = np.ascontiguousarray(self.gradient.transpose(2, 0, 1)) * self.scale  # (3, N, 2)
        w, cv = weights.reshape(n, 2), curvature.reshape(n, 2)
        dc = c.clock - c.middle
        weighted = cv * g
        wb, cbb = _pair_sum(w * b), _pair_sum(cv * b * b)
        wg, cbg, cgg = _pair_sum(w * g), _pair_sum(weighted * b), _pair_sum(weighted[_PAIRS[0]] * g[_PAIRS[1]])
        near, far = 1.0 - self.u, self.u
        table = np.empty((36, n))  # by frame: the knots' gradient, line by knot, knot by knot (six a 3x3)
        blocks = [(near, wg), (far, wg), (dc * near, cbg), (dc * far, cbg), (near, cbg), (far, cbg)]
        blocks += [(near * near, cgg), (near * far, cgg), (far * far, cgg)]
        row = 0
        for factor, values in blocks:
            np.multiply(values, factor, out=table[row : row + len(values)])
            row += len(values)
        left = self.left
        if np.any(left[1:] < left[:-1]):
            order = np.argsort(left, kind="stable")
            left, table = left[order], table[:, order]
        starts = np.flatnonzero(np.r_[True, left[1:] != left[:-1]])
        sums = np.add.reduceat(table, starts, axis=1).T  # (G, 36)
        groups = len(starts)
        line_gradient = np.array([np.sum(dc * wb), np.sum(wb)])
        line_curvature = np.array([[np.sum(dc * dc * cbb), np.sum(dc * cbb)], [np.sum(dc * cbb), np.sum(cbb)]])
        line_knot = sums[:, 6:18].reshape(groups, 2, 6)
        near_near, near_far, far_far = (sums[:, 18 + 6 * j : 24 + 6 * j][:, _SYMMETRIC] for j in range(3))
        knot_knot = np.block([[near_near, near_far], [near_far, far_far]])
        return line_gradient, sums[:, :6], line_curvature, line_knot, knot_knot, left[starts]


@dataclass(frozen=True)
class _CameraView:
    """One camera's frames where the log, with the bias, puts the target at samples s: the samples' runs of the path
    (-1: off it), the (N, 3) positions (metres) and their (N, 2) pixels, the knots around each frame (left, its
    right neighbour's weight u)."""

    s: np.ndarray
    run: np.ndarray
    position: np.ndarray
    uv: np.ndarray
    left: np.ndarray
    u: np.ndarray

    def residual(self, c: BiasCamera) -> np.ndarray:
        """(N, 2) weighted pixel residuals; 10 for a frame off the path or off the image."""
        r = (self.uv - c.xy) * c.weight[:, None]
        r[~np.isfinite(r).all(axis=1)] = 10.0
        return r


def _camera_view(
    c: BiasCamera, path: PiecewiseTrajectory, knots: np.ndarray, bias: np.ndarray, s: np.ndarray
) -> _CameraView:
    """The camera's frames at samples s, the bias (K, 3) added to the path (_CameraView)."""
    run = path.run_of(s)
    on = run >= 0
    position = np.full((len(s), 3), np.nan)
    position[on] = path(s[on], run[on])
    left, right, u = _interpolation_parts(s, knots)
    position += (1.0 - u)[:, None] * bias[left] + u[:, None] * bias[right]
    uv, _ = c.camera.project(position)
    return _CameraView(s, run, position, uv, left, u)


def _camera_rows(
    c: BiasCamera, path: PiecewiseTrajectory, knots: np.ndarray, bias: np.ndarray, view: _CameraView
) -> _CameraRows:
    """One camera's pixel rows at its view's samples (_CameraRows): the derivative in space analytic where the lens
    model has one (Camera.point_jacobian), by finite differences otherwise, and along the path (the frame's run) the
    one in space times the position's finite difference; a frame off the path or off the image, or whose derivatives
    are not finite, has a residual of 10 and no derivative."""
    n = len(view.s)
    on = view.run >= 0
    ahead = np.full((n, 3), np.nan)
    ahead[on] = path(view.s[on] + SAMPLE_STEP, view.run[on])
    left_ahead, right_ahead, u_ahead = _interpolation_parts(view.s + SAMPLE_STEP, knots)
    ahead += (1.0 - u_ahead)[:, None] * bias[left_ahead] + u_ahead[:, None] * bias[right_ahead]
    uv = view.uv
    gradient = c.camera.pixels_per_metre(view.position, uv)  # (N, 2, 3)
    rate = np.einsum("nij,nj->ni", gradient, (ahead - view.position) / SAMPLE_STEP)  # pixels per sample
    r = (uv - c.xy) * c.weight[:, None]
    along = rate * c.weight[:, None]
    gradient = gradient * c.weight[:, None, None]
    finite = np.isfinite(r).all(axis=1) & np.isfinite(along).all(axis=1)
    bad = ~(finite & np.isfinite(gradient.reshape(n, -1)).all(axis=1))
    r[bad] = 10.0
    along[bad] = 0.0
    gradient[bad] = 0.0
    return _CameraRows(r, along.ravel(), gradient, view.left, view.u)


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
    variance = variance_factor(r, f_scale)
    return variance * _correlation_factor(_bread(c, r, jac, f_scale), variance, x, cov)


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
    stiff, _ = levenberg_marquardt(problem.with_prior_weight(f_scale), z, f_scale)
    found = [levenberg_marquardt(problem, start, f_scale) for start in (z, stiff)]
    return min(found, key=lambda f: _cost(problem, f[0], f_scale))


def _cost(problem: _Joint, z: np.ndarray, f_scale: float) -> float:
    """The joint problem's robust cost at z (infinite where a residual is not finite)."""
    return robust_cost(problem, problem.residual(z), f_scale)
