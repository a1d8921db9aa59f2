"""The log's bias fitted with every camera's line and, free, the poses from the target: the log corrected by it.

A pose fitted to the target alone under a log with a bias (sync/pose/pose.py)
absorbs the bias over its visit. Where the target hovers, a bias of a metre
or two (a drone's GNSS) is as large as the path it flies in a view, and the
pose search lands far from the truth: on drone2's hover-only tracks the poses
were 15-50 m and 35-73 degrees off (their lines 2-23 frames); on the same log
with the true bias taken out, 0.1-0.5 m and 0.1-0.9 degrees. The joint fit
of the lines with the bias holds the poses, takes their error for the bias
(sync/solve/posed_bias.py), and its refit of each pose on the log so
corrected only moves within that wrong basin.

Here every pose from the target is a free unknown (6 values: Rodrigues
rotation, translation, flat prior) of one fit with every camera's line and
the bias's knots: the bias is the same target's for every camera, and
cameras that see it at the same time from different directions tell it from
their poses. On drone2's hover-only tracks the bias so fitted took the
log's error at the visits from 0.5-2.7 m (rms per axis, seeds 0-2) to 0.5-0.9 m, and the
pose search on the log corrected by it lands in the true poses' basin
(synchronize's second pass, ``free_pose_correction``).

The fit: the bias linear between knots (log_bias's spacing), under the log
model's Gauss-Markov prior; each camera's pixels robust (soft L1 at the loss
scale) on the frames its pose and line explain (within posed_bias's
GATE_MEDIANS of their median error, at least eps_px; at most MAX_FRAMES,
evenly spread), divided by their variance factor times the correlation
left in them (sparse_lm's ``residual_correlation``), both measured at the poses and
lines the fit starts from; Levenberg-Marquardt on the normal equations
(sync/kernels/sparse_lm.py). (Fitted first with the pixels as they are, then so weighed,
the fit on drone2's hover-only seed 0 diverged to a bias of 10 m.) Where
the solver stops before it converges, the bias where it stopped is kept: it
is a correction the second pass tests on every camera's evidence again, not
a result.

Clock units: frames (sync/model/clock.py); pixels as tracked; world metres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from calibration.camera import Camera
from calibration.lens import project_with_jacobian
from tlsync_pipeline.sync.identify.identify import identify_params
from tlsync_pipeline.sync.identify.refine import BLOCKS
from tlsync_pipeline.sync.kernels.gauss_markov import interpolation_parts, prior_whitening
from tlsync_pipeline.sync.kernels.slope import SlopePrior, slope_prior
from tlsync_pipeline.sync.kernels.sparse_lm import (
    levenberg_marquardt,
    residual_correlation,
    soft_l1_except,
    variance_factor,
)
from tlsync_pipeline.sync.model.log_model import LogModel
from tlsync_pipeline.sync.model.params import SyncParams
from tlsync_pipeline.sync.pose.pose_fit import MIN_FRAMES, Layout, camera_at, reprojection_errors
from tlsync_pipeline.sync.solve.log_bias import bias_knots
from tlsync_pipeline.sync.solve.methods import CameraData
from tlsync_pipeline.sync.solve.posed_bias import GATE_MEDIANS
from tlsync_pipeline.sync.timeline import CameraLine, LogCorrection
from tlsync_pipeline.trajectory import PiecewiseTrajectory, Trajectory

MAX_FRAMES = 400  # frames of a camera in the fit, evenly spread over those its pose and line explain
OFF_PATH = 10.0  # the residual of a frame off the path or behind its camera (its derivative zero)


@dataclass(frozen=True)
class JointCamera:
    """One camera in the fit: its camera (its pose: the start, or held), the clock values (frame units) and tracked
    pixels of its frames, its line (alpha, beta) to start from, its slope prior (or None), and whether its pose is
    free."""

    name: str
    camera: Camera
    clock: np.ndarray
    xy: np.ndarray
    alpha: float
    beta: float
    prior: SlopePrior | None
    free: bool

    @property
    def middle(self) -> float:
        return float(np.median(self.clock))


@dataclass(frozen=True)
class FreePoseBias:
    """The fit's bias at its knots (sample coordinates; values (K, 3) metres, the true position being the log's plus
    it), the cameras with their poses as fitted, their lines (alpha, beta), and the solver's verdict."""

    knots: np.ndarray
    values: np.ndarray
    cameras: dict[str, Camera]
    lines: dict[str, tuple[float, float]]
    converged: bool

    def at(self, samples: np.ndarray) -> np.ndarray:
        """(N, 3) bias at sample coordinates (linear between knots, constant beyond them)."""
        return np.column_stack([np.interp(samples, self.knots, self.values[:, k]) for k in range(3)])


class _Problem:
    """The joint problem in z = (per camera: its pose's 6 values when free, 1 / alpha, the sample at its middle
    clock value; then the knots' values, knot-major). Residuals: each camera's pixel offsets over the root of its
    inflation (1 until ``remeasure``), then each slope prior and the whitened bias prior (quadratic); a free pose has
    no prior. The interface sync/kernels/sparse_lm's ``levenberg_marquardt`` solves: residual, normal_equations,
    scale, loss."""

    def __init__(self, cameras: list[JointCamera], path: PiecewiseTrajectory, knots: np.ndarray, whiten: sp.csr_matrix):
        self.cameras, self.path, self.knots, self.whiten = cameras, path, knots, whiten
        self.offsets: list[int] = []
        start: list[np.ndarray] = []
        scale: list[np.ndarray] = []
        for c in cameras:
            self.offsets.append(sum(len(s) for s in start))
            pose = [*c.camera.rvec, *c.camera.t] if c.free else []
            span = max(float(np.ptp(c.clock)), 1.0)
            start.append(np.array([*pose, 1.0 / c.alpha, (c.middle - c.beta) / c.alpha]))
            scale.append(np.array([*([1e-3] * 3 + [1e-2] * 3 if c.free else []), 0.1 / span / c.alpha + 1e-9, 0.1]))
        self.lines = sum(len(s) for s in start)
        self.leading = self.lines
        self.z0 = np.concatenate([*start, np.zeros(3 * len(knots))])
        self.scale = np.concatenate([*scale, np.full(3 * len(knots), 0.1)])
        self.inflation = np.ones(len(cameras))
        pixels = sum(2 * len(c.clock) for c in cameras)
        priors = sum(1 for c in cameras if c.prior is not None) + whiten.shape[0]
        self.loss = soft_l1_except(np.r_[np.zeros(pixels, bool), np.ones(priors, bool)])
        self._cache: dict[bytes, tuple[np.ndarray, sp.csr_matrix]] = {}

    def camera(self, z: np.ndarray, k: int) -> Camera:
        """Camera k with its pose at z."""
        c, o = self.cameras[k], self.offsets[k]
        return camera_at(c.camera, z[o : o + 6], Layout()) if c.free else c.camera

    def line(self, z: np.ndarray, k: int) -> tuple[float, float]:
        """Camera k's (alpha, beta) at z."""
        o = self.offsets[k] + (6 if self.cameras[k].free else 0)
        u, s0 = z[o : o + 2]
        return 1.0 / u, self.cameras[k].middle - s0 / u

    def _camera_rows(self, z: np.ndarray, k: int) -> tuple[np.ndarray, sp.coo_matrix]:
        """Camera k's (2N,) pixel residuals (not inflated) and their sparse Jacobian in z."""
        c, o = self.cameras[k], self.offsets[k]
        line_at = o + (6 if c.free else 0)
        u, s0 = z[line_at : line_at + 2]
        dc = c.clock - c.middle
        s = s0 + u * dc
        run = self.path.run_of(s)
        on = run >= 0
        n = len(s)
        position = np.zeros((n, 3))
        velocity = np.zeros((n, 3))
        position[on] = self.path(s[on], run[on])
        velocity[on] = self.path(s[on], run[on], nu=1)
        left, right, w = interpolation_parts(s, self.knots)
        bias = z[self.lines :].reshape(-1, 3)
        position += (1.0 - w)[:, None] * bias[left] + w[:, None] * bias[right]
        camera = self.camera(z, k)
        uv, blocks = project_with_jacobian(position, camera.rvec, camera.t, camera.K, camera.dist, camera.dist_model)
        depth = position @ camera.R[2] + camera.t[2]
        residual = uv - c.xy
        good = on & (depth > 0) & np.isfinite(residual).all(axis=1)
        point = np.einsum("nij,jk->nik", blocks["tvec"], camera.R)  # d pixel / d world point
        rate = np.einsum("nik,nk->ni", point, velocity)  # pixels per sample
        columns = [np.full((n, 2), line_at), np.full((n, 2), line_at + 1)]
        values = [rate * dc[:, None], rate]
        if c.free:
            for j in range(3):
                columns += [np.full((n, 2), o + j), np.full((n, 2), o + 3 + j)]
                values += [blocks["rvec"][:, :, j], blocks["tvec"][:, :, j]]
        for j in range(3):
            columns += [
                np.broadcast_to((self.lines + 3 * left + j)[:, None], (n, 2)),
                np.broadcast_to((self.lines + 3 * right + j)[:, None], (n, 2)),
            ]
            values += [point[:, :, j] * (1.0 - w)[:, None], point[:, :, j] * w[:, None]]
        value = np.stack(values, axis=2)
        value[~good] = 0.0
        residual[~good] = OFF_PATH
        rows = np.broadcast_to(np.arange(2 * n).reshape(n, 2)[:, :, None], value.shape)
        column = np.stack(columns, axis=2)
        jac = sp.coo_matrix((value.ravel(), (rows.ravel(), column.ravel())), shape=(2 * n, len(self.z0)))
        return residual.ravel(), jac

    def _priors(self, z: np.ndarray) -> tuple[np.ndarray, sp.csr_matrix]:
        """The priors' residuals and Jacobian: each slope prior, then the whitened bias's."""
        residuals, rows = [], []
        width = len(self.z0)
        for k, c in enumerate(self.cameras):
            line_at = self.offsets[k] + (6 if c.free else 0)
            if c.prior is not None:
                residuals.append(np.array([(c.prior.alpha * z[line_at] - 1.0) / c.prior.sigma]))
                rows.append(sp.csr_matrix(([c.prior.alpha / c.prior.sigma], ([0], [line_at])), shape=(1, width)))
        residuals.append(self.whiten @ z[self.lines :])
        rows.append(sp.hstack([sp.csr_matrix((self.whiten.shape[0], self.lines)), self.whiten], format="csr"))
        return np.concatenate(residuals), sp.vstack(rows, format="csr")

    def evaluate(self, z: np.ndarray) -> tuple[np.ndarray, sp.csr_matrix]:
        """All residuals (the pixels over their inflation's root) and their Jacobian at z."""
        key = z.tobytes()
        if key not in self._cache:
            self._cache.clear()
            parts = [self._camera_rows(z, k) for k in range(len(self.cameras))]
            weights = np.concatenate([np.full(len(r), 1.0 / np.sqrt(f)) for (r, _), f in zip(parts, self.inflation)])
            prior_r, prior_j = self._priors(z)
            residual = np.r_[np.concatenate([r for r, _ in parts]) * weights, prior_r]
            jac = sp.vstack([sp.diags(weights) @ sp.vstack([j for _, j in parts]), prior_j], format="csr")
            self._cache[key] = (residual, jac)
        return self._cache[key]

    def residual(self, z: np.ndarray) -> np.ndarray:
        return self.evaluate(z)[0]

    def normal_equations(
        self, z: np.ndarray, weights: np.ndarray, curvature: np.ndarray
    ) -> tuple[np.ndarray, sp.csc_matrix]:
        """J^T weights and J^T diag(curvature) J at z."""
        jac = self.evaluate(z)[1]
        return jac.T @ weights, (jac.T @ sp.diags(curvature) @ jac).tocsc()

    def remeasure(self, z: np.ndarray, f_scale: float) -> None:
        """Each camera's inflation measured on its residuals at z: their variance factor (sparse_lm's) times the
        correlation left in them in its pose's and line's columns (residual_correlation)."""
        self._cache.clear()
        for k, c in enumerate(self.cameras):
            r, jac = self._camera_rows(z, k)
            o = self.offsets[k]
            own = jac.tocsc()[:, o : o + (8 if c.free else 2)].toarray()
            residual = r.reshape(-1, 2)
            correlation = residual_correlation(residual, own, f_scale, BLOCKS)
            self.inflation[k] = variance_factor(residual, f_scale) * correlation
        self._cache.clear()


def fit_free_poses(
    cameras: list[JointCamera], path: PiecewiseTrajectory, rate: float, model: LogModel, f_scale: float
) -> FreePoseBias | None:
    """Every camera's line, its pose where free, and the log's bias fitted together (see the module); None when the
    fit leaves a value not finite."""
    visits = [(c.clock - c.beta) / c.alpha for c in cameras]
    knots = bias_knots(visits, path, rate, model)
    prior = np.array([model.bias_m, model.bias_m, model.bias_vertical_m])
    problem = _Problem(cameras, path, knots, prior_whitening(knots, rate, model.tau_s, prior))
    problem.remeasure(problem.z0, f_scale)
    z, converged = levenberg_marquardt(problem, problem.z0, f_scale)
    if not np.isfinite(z).all():
        return None
    return FreePoseBias(
        knots,
        z[problem.lines :].reshape(-1, 3),
        {c.name: problem.camera(z, k) for k, c in enumerate(cameras)},
        {c.name: problem.line(z, k) for k, c in enumerate(cameras)},
        converged,
    )


def joint_camera(
    data: CameraData, line: CameraLine, free: bool, path: PiecewiseTrajectory, params: SyncParams, rate: float | None
) -> JointCamera | None:
    """One camera as the fit takes it: the frames its pose and line explain (within GATE_MEDIANS of their median
    reprojection error, at least eps_px; at most MAX_FRAMES, evenly spread); None when fewer than MIN_FRAMES."""
    errors = reprojection_errors(data.camera, data.track_clock, data.track.xy, path, line.alpha, line.beta)
    finite = np.isfinite(errors)
    if finite.sum() < MIN_FRAMES:
        return None
    gate = max(params.eps_px, GATE_MEDIANS * float(np.median(errors[finite])))
    used = np.flatnonzero(errors <= gate)
    if len(used) < MIN_FRAMES:
        return None
    keep = used[np.linspace(0, len(used) - 1, min(MAX_FRAMES, len(used))).round().astype(np.int64)]
    return JointCamera(
        data.name,
        data.camera,
        data.track_clock[keep],
        data.track.xy[keep],
        line.alpha,
        line.beta,
        slope_prior(data.fps, rate, params.rate_sigma),
        free,
    )


def free_pose_correction(
    data: dict[str, CameraData],
    lines: dict[str, CameraLine],
    posed: set[str],
    prepared: Trajectory,
    params: SyncParams,
    log_model: LogModel,
) -> LogCorrection | None:
    """The log's correction by the bias fitted with every camera's line (``lines``, on ``data``) and the poses of the
    cameras ``posed`` (from the target) free, on the prepared log (fit_free_poses); None without the log's rate, when
    a camera has too few frames its pose and line explain, or when the fit fails."""
    if prepared.rate is None:
        return None
    path = PiecewiseTrajectory(prepared)
    cameras = [joint_camera(data[n], lines[n], n in posed, path, params, prepared.rate) for n in lines]
    chosen = [c for c in cameras if c is not None]
    if len(chosen) < len(cameras):
        return None
    found = fit_free_poses(chosen, path, prepared.rate, log_model, identify_params(params).f_scale_px)
    if found is None:
        return None
    return LogCorrection(found.knots, found.values)
