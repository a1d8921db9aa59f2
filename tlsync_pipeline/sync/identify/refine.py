"""Sub-frame refinement of a camera line by continuous-time reprojection.

Given a starting line frame = alpha * sample + beta (from the line search)
and the frames it explains, alpha and beta are re-estimated by minimising the
pixel distance between each tracked position and the trajectory projected at
the continuous sample s = (frame - beta) / alpha. The trajectory is
interpolated by the one trajectory model, trajectory.PiecewiseTrajectory (a
cubic spline per contiguous run of samples; gaps are never bridged). The
loss is robust (soft L1, scale ``f_scale`` px), solved by
scipy.optimize.least_squares with the line parametrised around the middle of
the frames used (well conditioned). Each frame's residual depends on the line
only through its sample s, so the Jacobian is the projection's rate along the
path (pixels per sample, one projected step of the spline's derivative) times
ds/d(parameters): one evaluation gives residuals and Jacobian. The covariance of (alpha, beta) is the
M-estimator sandwich with a Bartlett (Newey-West) kernel over neighbouring
frames, so residuals correlated in time (pose and log errors move neighbouring
frames alike) widen the interval.

Per-sample sigmas of the trajectory (``Trajectory.sigma``, metres: the log's
stated position uncertainty) weight the residuals: a sample's sigma, seen
from the camera, is sigma_px = focal length x sigma / depth, and its
frame's residual is scaled by f_scale / sqrt(f_scale^2 + sigma_px^2). A log
whose sigmas are small against the tracker's pixel noise is fitted as
without weights; a noisy stretch (a float or single solution among RTK
fixes) counts less.

With a slope prior (sync/kernels/slope.py) the fit holds alpha near the nominal
fps / log rate: one more residual, f_scale x (alpha / alpha_0 - 1) / sigma
(the prior counts as a pixel residual of the loss scale at one sigma, under
a plain quadratic loss: a stretch of biased positions must not outweigh it
the way it outweighs one outlying frame), in the fit and in the covariance.

"frame" may be any camera clock coordinate in frame units (the frame index,
or presentation time x nominal fps for a variable-frame-rate video).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from calibration.camera import Camera
from tlsync_pipeline.sync.identify.target_size import beyond_slack, slack_on_line
from tlsync_pipeline.sync.kernels.slope import SlopePrior
from tlsync_pipeline.trajectory import PiecewiseTrajectory, Trajectory

MIN_FRAMES = 8
PASSES = 4  # fits, each on the frames within gate_px of the previous one


# Contiguous blocks of frames for the clustered covariance and the model error.
BLOCKS = 8
# The joint fit with the log's bias (sync/solve/log_bias.py) weighs a camera's pixels against the priors by how much
# its covariance exceeds the naive one: with an unseen offset of this many weighted pixels per block (so the log's
# noise seen in the image, which lowers the weights, counts in full), as tuned on the wild bench's walks.
JOINT_OFFSET = 3.0
# Step along the trajectory (samples) of the projection's rate, the refinement's Jacobian.
RATE_STEP = 1e-4


@dataclass(frozen=True)
class Refinement:
    """The refined line and its uncertainty.

    cov: 2x2 covariance of (alpha, beta), of which cov_model is the part the
    model error (calibration, pose) adds and cov_log_white the part the log's
    white noise, averaged over the fixes each block of frames spans, adds;
    cov_joint: the covariance the joint fit with the log's bias weighs the
    camera's pixels by (JOINT_OFFSET); frames_used: tracked frames in the
    final fit (used: which of the given frames); scale_px: robust residual scale (1.4826 MAD of pixel
    residuals); perpendicular: median |sin| of the angle between the target's
    velocity and the viewing ray over those frames (near 0: motion along the
    ray, little timing information); converged: the solver's verdict.
    """

    alpha: float
    beta: float
    cov: np.ndarray
    frames_used: int
    scale_px: float
    perpendicular: float
    converged: bool
    message: str
    cov_model: np.ndarray
    cov_log_white: np.ndarray
    cov_joint: np.ndarray
    used: np.ndarray

    @property
    def se_alpha(self) -> float:
        return float(np.sqrt(self.cov[0, 0]))

    @property
    def se_beta(self) -> float:
        return float(np.sqrt(self.cov[1, 1]))


def refine_line(
    camera: Camera,
    frame: np.ndarray,
    xy: np.ndarray,
    trajectory: Trajectory | PiecewiseTrajectory,
    alpha: float,
    beta: float,
    start: np.ndarray,
    f_scale: float = 3.0,
    gate_px: float = 10.0,
    model_error_px: float = 0.0,
    prior: SlopePrior | None = None,
    box: np.ndarray | None = None,
) -> Refinement:
    """Refine frame = alpha * sample + beta from the tracked positions.

    frame: (N,) camera clock in frames; xy: (N, 2) tracked pixels; start:
    boolean mask of the frames the line search explained (the starting set).
    After a first fit on them, every tracked frame whose reprojection is
    within gate_px joins and the fit is repeated. model_error_px: std of a
    pixel offset shared by each of BLOCKS runs of frames (calibration and pose
    errors), added to the covariance with the log's white noise averaged over
    the fixes each run spans; prior: what the frame rates say about
    alpha (sync/kernels/slope.py), or None; box: (N, 2) tracked box sizes, pixels
    (NaN unknown), whose excess over the target's size (sync/identify/target_size.py)
    becomes slack around the tracked position. Raises ValueError when fewer than
    MIN_FRAMES frames can be used.
    """
    path = trajectory if isinstance(trajectory, PiecewiseTrajectory) else PiecewiseTrajectory(trajectory)
    frame = np.asarray(frame, dtype=np.float64)
    xy = np.asarray(xy, dtype=np.float64)
    box = None if box is None else np.asarray(box, dtype=np.float64)
    use = np.asarray(start, dtype=bool) & (path.run_of((frame - beta) / alpha) >= 0)
    if use.sum() < MIN_FRAMES:
        raise ValueError(f"only {int(use.sum())} tracked frames fall on the trajectory under the line")
    for _ in range(PASSES):
        slack = None if box is None else slack_on_line(camera, path, frame[use], box[use], alpha, beta)
        fit = _fit(camera, frame[use], xy[use], path, alpha, beta, f_scale, model_error_px, prior, slack)
        alpha, beta = fit.alpha, fit.beta
        s = (frame - beta) / alpha
        run = path.run_of(s)
        candidate = run >= 0
        uv, valid = camera.project(path(s[candidate], run[candidate]))
        error = np.full(len(frame), np.inf)
        error[np.flatnonzero(candidate)[valid]] = np.linalg.norm(uv[valid] - xy[candidate][valid], axis=1)
        grown = error <= gate_px
        if grown.sum() < MIN_FRAMES or np.array_equal(grown, use):
            break
        use = grown
    return Refinement(
        fit.alpha,
        fit.beta,
        fit.cov,
        int(use.sum()),
        fit.scale_px,
        fit.perpendicular,
        fit.converged,
        fit.message,
        fit.cov_model,
        fit.cov_log_white,
        fit.cov_joint,
        use,
    )


@dataclass(frozen=True)
class _Fit:
    """One robust fit: the line, its covariance (and the model error's and the log's white noise's parts of it, and
    the joint fit's weighting covariance), the robust residual scale (px), the solver's verdict, and perpendicular
    (Refinement)."""

    alpha: float
    beta: float
    cov: np.ndarray
    scale_px: float
    converged: bool
    message: str
    perpendicular: float
    cov_model: np.ndarray
    cov_log_white: np.ndarray
    cov_joint: np.ndarray


class _PixelResiduals:
    """The fit's residuals and Jacobian in x = (1 / alpha, sample at c_mid): tracked minus projected position beyond the
    slack,
    weighted per frame (sigma_weights), and the slope prior's residual last (when there is a prior).

    least_squares asks for the residuals, then the Jacobian, at the same x: one evaluation serves both.
    """

    def __init__(
        self,
        camera: Camera,
        path: PiecewiseTrajectory,
        frame: np.ndarray,
        xy: np.ndarray,
        run: np.ndarray,
        slack: np.ndarray,
        weight: np.ndarray,
        c_mid: float,
        f_scale: float,
        prior: SlopePrior | None,
    ):
        self.camera, self.path, self.frame, self.xy, self.run, self.slack, self.weight = (
            camera,
            path,
            frame,
            xy,
            run,
            slack,
            weight,
        )
        self.c_mid, self.f_scale, self.prior = c_mid, f_scale, prior
        self.prior_slope = f_scale * prior.alpha / prior.sigma if prior is not None else 0.0
        self._last: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}

    def pixels(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(N, 2) weighted residuals beyond the slack and (N, 2, 2) their Jacobian in x."""
        key = x.tobytes()
        if key not in self._last:
            self._last.clear()
            self._last[key] = self._evaluate(x)
        return self._last[key]

    def _evaluate(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        s = x[1] + x[0] * (self.frame - self.c_mid)
        r, rate = _offsets_and_rates(self.camera, self.path, s, self.run, self.xy)
        outside = np.abs(r) > self.slack
        r = beyond_slack(r, self.slack) * self.weight[:, None]
        rate = np.where(outside, rate, 0.0) * self.weight[:, None]
        invalid = ~np.isfinite(r).all(axis=1)
        r[invalid] = 10.0 * self.f_scale
        rate[invalid | ~np.isfinite(rate).all(axis=1)] = 0.0
        return r, rate[:, :, None] * np.stack([self.frame - self.c_mid, np.ones(len(self.frame))], axis=1)[:, None, :]

    def residual(self, x: np.ndarray) -> np.ndarray:
        r = self.pixels(x)[0].ravel()
        if self.prior is None:
            return r
        return np.append(r, self.f_scale * (self.prior.alpha * x[0] - 1.0) / self.prior.sigma)

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        jac = self.pixels(x)[1].reshape(-1, 2)
        return np.vstack([jac, [self.prior_slope, 0.0]]) if self.prior is not None else jac


def _fit(
    camera: Camera,
    frame: np.ndarray,
    xy: np.ndarray,
    path: PiecewiseTrajectory,
    alpha: float,
    beta: float,
    f_scale: float,
    model_error_px: float,
    prior: SlopePrior | None = None,
    slack: np.ndarray | None = None,
) -> _Fit:
    """One robust fit of the line on the frames that fall on the path under the starting line.

    slack: (N, 2) pixels either side of each position within which the
    projection leaves no residual, or None.
    """
    order = np.argsort(frame, kind="stable")
    frame, xy = frame[order], xy[order]
    slack = np.zeros_like(xy) if slack is None else slack[order]
    c_mid = float(np.median(frame))
    run = path.run_of((frame - beta) / alpha)
    keep = run >= 0
    frame, xy, run, slack = frame[keep], xy[keep], run[keep], slack[keep]
    span = max(float(frame[-1] - frame[0]), 1.0)
    x0 = np.array([1.0 / alpha, (c_mid - beta) / alpha])
    noise_px = _log_noise_px(camera, path, x0[1] + x0[0] * (frame - c_mid), run)
    weight = _noise_weights(noise_px, len(frame), f_scale)
    problem = _PixelResiduals(camera, path, frame, xy, run, slack, weight, c_mid, f_scale, prior)
    scale = np.array([0.1 / span * abs(x0[0]) + 1e-9, 0.1])
    loss = "soft_l1" if prior is None else _soft_l1_but_last
    solution = least_squares(
        problem.residual,
        x0,
        jac=problem.jacobian,
        loss=loss,
        f_scale=f_scale,
        x_scale=scale,
        method="trf",
        max_nfev=200,
    )
    x = solution.x
    r, jac = problem.pixels(x)
    u, s0 = x
    shared = _shared_offsets(s0 + u * (frame - c_mid), noise_px, model_error_px)
    cov_x, model_x, white_x, joint_x = _sandwich_covariance(r, jac, f_scale, weight, shared, problem.prior_slope)
    with np.errstate(
        divide="ignore", invalid="ignore", over="ignore"
    ):  # a fit gone astray (u 0, a singular covariance): not ok below
        a = 1.0 / u
        d = np.array([[-1.0 / u**2, 0.0], [s0 / u**2, -a]])  # d(alpha, beta) / d(x)
        cov = d @ cov_x @ d.T
    residual_px = np.linalg.norm(r, axis=1)
    scale_px = float(1.4826 * np.median(np.abs(residual_px - np.median(residual_px)))) if len(r) else float("nan")
    perpendicular = _perpendicular(camera, path, x[1] + x[0] * (frame - c_mid), run)
    ok = bool(solution.success and np.all(np.isfinite(cov)) and u > 0)
    return _Fit(
        float(a),
        float(c_mid - a * s0),
        cov,
        scale_px,
        ok,
        str(solution.message),
        perpendicular,
        d @ model_x @ d.T,
        d @ white_x @ d.T,
        d @ joint_x @ d.T,
    )


@dataclass(frozen=True)
class _SharedOffsets:
    """The std (pixels) of an image offset each block of frames (BLOCKS contiguous runs) shares that the residuals
    cannot show: model: the calibration's and the pose's (model_error_px, every block's); log_white: per block, the
    log's white noise averaged over the fixes the block spans (a fix's error is every frame's between it and the
    next)."""

    model: float
    log_white: np.ndarray


def _shared_offsets(sample: np.ndarray, noise_px: np.ndarray | None, model_error_px: float) -> _SharedOffsets:
    """The shared offsets of the frames at log samples ``sample`` (sorted), whose log noise seen in the image is
    noise_px (pixels per frame, None without sigmas)."""
    blocks = min(BLOCKS, len(sample))
    if noise_px is None:
        return _SharedOffsets(model_error_px, np.zeros(blocks))
    white = [
        float(np.median(px)) / np.sqrt(max(float(s[-1] - s[0]), 1.0))
        for s, px in zip(np.array_split(sample, blocks), np.array_split(noise_px, blocks))
    ]
    return _SharedOffsets(model_error_px, np.array(white))


def _sandwich_covariance(
    r: np.ndarray,
    jac: np.ndarray,
    f_scale: float,
    weight: np.ndarray,
    shared: _SharedOffsets,
    prior_slope: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Covariance of x: the soft L1 M-estimator's sandwich, frame by frame or block by block (the larger), plus the
    offsets each block's frames share; those offsets' parts of it (the model error's, the log's white noise's); and
    the sandwich with JOINT_OFFSET weighted pixels shared by each block instead (the joint fit's weighting).

    r: (N, 2) weighted residuals; jac: (N, 2, 2) their Jacobian; weight: (N,) each frame's weight (a pixel offset
    moves its weighted residual by weight times it); prior_slope: the slope prior's Jacobian (0 without a prior),
    whose information counts as bread and, at one sigma = f_scale, as noise (meat).
    """
    z = (r / f_scale) ** 2
    psi = r / np.sqrt(1 + z)  # soft L1 influence
    dpsi = (1 + z) ** -1.5
    prior_info = np.diag([prior_slope**2, 0.0])
    bread = np.einsum("nik,ni,nil->kl", jac, dpsi, jac) + prior_info
    g = np.einsum("nik,ni->nk", jac, psi)
    n = len(g)
    try:
        inv = np.linalg.inv(bread)
    except np.linalg.LinAlgError:
        inv = np.full((2, 2), np.inf)  # a singular fit: an infinite (non-finite) covariance, which the caller refuses
    # Frame by frame (heteroscedasticity) and block by block (errors shared by
    # neighbouring frames: pose, log); the larger.
    independent = g.T @ g * n / max(n - 2, 1)
    blocks = _block_sums(g)
    clustered = blocks.T @ blocks * len(blocks) / max(len(blocks) - 1, 1)
    # An unseen pixel offset shared by each block of frames, propagated through
    # the fit: how the block's scores move per pixel of it.
    weighted = _block_sums(jac * dpsi[:, :, None])
    lever = _block_sums(jac * (dpsi * weight[:, None])[:, :, None])
    model = shared.model**2 * np.einsum("bik,bil->kl", lever, lever)
    white = np.einsum("b,bik,bil->kl", shared.log_white**2, lever, lever)
    joint = JOINT_OFFSET**2 * np.einsum("bik,bil->kl", weighted, weighted)
    with np.errstate(invalid="ignore", over="ignore"):  # inf x 0 of a singular fit: NaN, refused by the caller
        meat = independent if np.trace(inv @ independent @ inv) >= np.trace(inv @ clustered @ inv) else clustered
        return (
            inv @ (meat + model + white + f_scale**2 * prior_info) @ inv,
            inv @ model @ inv,
            inv @ white @ inv,
            inv @ (meat + joint + f_scale**2 * prior_info) @ inv,
        )


def _block_sums(values: np.ndarray) -> np.ndarray:
    """Sums of ``values`` (N, ...) over BLOCKS contiguous runs of frames (fewer when N is smaller)."""
    return np.array([b.sum(axis=0) for b in np.array_split(values, min(BLOCKS, len(values)))])


def _offsets_and_rates(
    camera: Camera, path: PiecewiseTrajectory, s: np.ndarray, run: np.ndarray, xy: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(N, 2) pixel offset from xy to the projection at samples s (NaN where it does not project) and (N, 2) its rate,
    pixels per sample.
    """
    position = path(s, run)
    moved = position + RATE_STEP * path(s, run, nu=1)
    uv, _ = camera.project(np.concatenate([position, moved]))
    n = len(s)
    return uv[:n] - xy, (uv[n:] - uv[:n]) / RATE_STEP


def _soft_l1_but_last(z: np.ndarray) -> np.ndarray:
    """scipy least_squares loss (rho, rho', rho''): soft L1 for every residual but the last (the slope prior), which
    stays quadratic.
    """
    t = 1.0 + z
    out = np.vstack([2.0 * (np.sqrt(t) - 1.0), t**-0.5, -0.5 * t**-1.5])
    out[:, -1] = z[-1], 1.0, 0.0
    return out


def _log_noise_px(camera: Camera, path: PiecewiseTrajectory, s: np.ndarray, run: np.ndarray) -> np.ndarray | None:
    """The log's white noise (each sample's sigma) seen in the image at samples s: focal x sigma / depth (pixels per
    frame); None when the trajectory has no sigmas."""
    sigma = path.sigma(s)
    if sigma is None:
        return None
    depth = np.maximum((path(s, run) @ camera.R.T + camera.t)[:, 2], 1e-6)
    return 0.5 * (camera.K[0, 0] + camera.K[1, 1]) * sigma / depth


def sigma_weights(
    camera: Camera, path: PiecewiseTrajectory, s: np.ndarray, run: np.ndarray, f_scale: float
) -> np.ndarray:
    """Residual scale per frame: f_scale / sqrt(f_scale^2 + sigma_px^2), sigma_px the log's noise in the image
    (_log_noise_px; ones without sigmas).
    """
    return _noise_weights(_log_noise_px(camera, path, s, run), len(s), f_scale)


def _noise_weights(noise_px: np.ndarray | None, n: int, f_scale: float) -> np.ndarray:
    """f_scale / sqrt(f_scale^2 + noise_px^2) per frame; n ones without noise."""
    return np.ones(n) if noise_px is None else f_scale / np.sqrt(f_scale**2 + noise_px**2)


def _perpendicular(camera: Camera, path: PiecewiseTrajectory, s: np.ndarray, run: np.ndarray) -> float:
    """Median over moving frames of |sin| of the angle between velocity and viewing ray (1 when no frame moves)."""
    position = path(s, run)
    velocity = path(s, run, nu=1)
    ray = position - camera.center
    length = np.linalg.norm(ray, axis=1, keepdims=True)
    ray = np.divide(ray, length, out=np.zeros_like(ray), where=length > 0)
    speed = np.linalg.norm(velocity, axis=1)
    moving = speed > 1e-6 * max(speed.max(initial=0.0), 1e-300)
    if not moving.any():
        return 1.0
    sin = np.linalg.norm(np.cross(velocity[moving], ray[moving]), axis=1) / speed[moving]
    return float(np.median(sin))
