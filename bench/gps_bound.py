"""The first-order bound on eps_t for a walk or crowd scene: what an efficient estimator that knows the log's error
model exactly can reach.

Any data_fixtures.scene.Scene whose ``noise`` holds the log's error model
(``"log"``, a LogErrorModel) and the tracking noise (``"S_t_px"``, pixels):
data_fixtures/walk.py's and data_fixtures/crowd.py's (a crowd scene's
tracks are the frames where the target is visible, its tracking noise the
blob centroid's, CENTROID_NOISE_PX).

The scene's measurements, linearised at the truth: every tracked frame's
pixels (the scene's tracking noise, white per axis) as a function of each
camera's line (alpha, beta) and of the log's error at the fixes around the
visits (x_log(s) - e(s), e linear between fixes); the priors: each camera's
slope near fps / rate (``rate_sigma``), and the log's error with its exact
covariance (per axis Gauss-Markov sigma^2 exp(-|dt| / tau) plus white
noise on the diagonal; fixes away from every visit are marginalised out,
which the Gauss-Markov covariance of the kept ones does exactly). The
inverse of the information is the Cramer-Rao covariance of the lines; the
bound's eps_t is the worst pair's eps_t (eq. 5) of line errors drawn from
it. No estimator of these measurements does better on average; the bench
compares tlsync's eps_t with this (bench/gps_error.py --bound).

The sync is told a preset (a phone's 2 m / 60 s for a receiver whose bias
is 1 m), not the receiver's exact model: with ``assumed`` (the bias's std
and correlation time the estimator takes as its prior), the covariance is
that of the same linear estimator under that prior, its error measured
under the receiver's true one: M^-1 (P_a^-1 P P_a^-1 + D) M^-1, P_a^-1 P P_a^-1 in the log
error's block (D the pixels' and the slope prior's information, M = D +
P_a^-1, P_a the assumed covariance, P the true; P_a = P gives the bound): the bound for the information the sync has.

With ``gcps`` (per camera its ground control points' world positions and their pixels' noise), the poses are not
known but estimated with the lines: each camera's pose (a small rotation and a move of its centre) is six more unknowns,
held by its GCPs' pixels (their noise, white per axis; the world points exact) and by the target's own pixels, as an
estimator that fits every pose with the lines and the log's error together would hold it.
With ``poses_free`` and no ``gcps`` each camera's pose is estimated with no prior (a pose from the target), and
``pair_draws`` gives every pair's eps_t, not only the worst (bench/real_flight_gps.py --bound).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import cv2
import numpy as np

from calibration.camera import Camera
from data_fixtures.log_error import LogErrorModel
from data_fixtures.scene import Scene

FIX_MARGIN = 2  # fixes kept beyond each end of a visit
POSE_PARAMETERS = 6  # a pose's unknowns: a small rotation (radians, world axes) and a move of its centre (metres)
POSE_STEP = 1e-6  # finite-difference step of a pose's unknowns


@dataclass(frozen=True)
class Survey:
    """A camera's ground control points: world positions (G, 3) metres, exact, and the std of their clicked pixels
    (per axis, pixels)."""

    xyz: np.ndarray
    noise_px: float


def line_covariance(
    scene: Scene,
    rate_sigma: float,
    assumed: LogErrorModel | None = None,
    gcps: dict[str, Survey] | None = None,
    poses_free: bool = False,
) -> tuple[list[str], np.ndarray]:
    """The camera names and the (2C, 2C) Cramer-Rao covariance of their lines (alpha_0, beta_0, alpha_1, ...); with
    ``assumed``, the error covariance of the estimator whose log-error prior is that model; with ``gcps``, of an
    estimator that fits the poses too, each held by its GCPs (see the module); with ``poses_free``, the poses fitted
    with no prior (a pose from the target)."""
    model: LogErrorModel = scene.noise["log"]
    noise_px = float(scene.noise["S_t_px"])
    truth = scene.true_trajectory
    rate = float(truth.rate)
    names = list(scene.cameras)
    samples = {n: (scene.tracks[n].frame - scene.lines[n].beta) / scene.lines[n].alpha for n in names}
    fixes = _fixes_near(samples.values(), len(truth.sample))
    n_lines, n_err = 2 * len(names), 3 * len(fixes)
    n_pose = 0 if gcps is None and not poses_free else POSE_PARAMETERS * len(names)
    size = n_lines + n_err + n_pose
    information = np.zeros((size, size))
    for k, name in enumerate(names):
        s = samples[name]
        camera, line = scene.cameras[name], scene.lines[name]
        position = np.column_stack([np.interp(s, truth.sample, truth.xyz[:, a]) for a in range(3)])
        velocity = np.column_stack(
            [np.interp(s, truth.sample, np.gradient(truth.xyz[:, a])) for a in range(3)]
        )  # metres per sample
        gradient = _projection_gradient(camera, position)  # (N, 2, 3) pixels per metre
        along = np.einsum("nij,nj->ni", gradient, velocity)  # pixels per sample
        jac = np.zeros((len(s), 2, size))
        jac[:, :, 2 * k] = along * (-s / line.alpha)[:, None]  # ds / dalpha = -s / alpha
        jac[:, :, 2 * k + 1] = along * (-1.0 / line.alpha)  # ds / dbeta
        weights = _interpolation(s, fixes)  # (N, F)
        jac[:, :, n_lines : n_lines + n_err] = -(gradient[:, :, None, :] * weights[:, None, :, None]).reshape(
            len(s), 2, -1
        )
        if n_pose:
            pose = slice(n_lines + n_err + POSE_PARAMETERS * k, n_lines + n_err + POSE_PARAMETERS * (k + 1))
            jac[:, :, pose] = _pose_gradient(camera, position)
        if gcps is not None:
            survey = _pose_gradient(camera, gcps[name].xyz).reshape(-1, POSE_PARAMETERS)
            information[pose, pose] += survey.T @ survey / gcps[name].noise_px ** 2
        flat = jac.reshape(-1, size)
        information += flat.T @ flat / noise_px**2
        if rate_sigma > 0:
            nominal = camera.fps / rate
            information[2 * k, 2 * k] += 1.0 / (rate_sigma * nominal) ** 2
    log = slice(n_lines, n_lines + n_err)
    if assumed is None:
        information[log, log] += np.linalg.inv(_error_covariance(fixes / rate, model))
        return names, np.linalg.inv(information)[:n_lines, :n_lines]
    data = information.copy()  # the pixels' and the slope prior's
    prior_inverse = np.linalg.inv(_error_covariance(fixes / rate, assumed))
    information[log, log] += prior_inverse
    inverse = np.linalg.inv(information)
    pulled = inverse[:, log] @ prior_inverse  # how the assumed prior pulls the estimate towards zero error
    covariance = pulled @ _error_covariance(fixes / rate, model) @ pulled.T + inverse @ data @ inverse
    return names, covariance[:n_lines, :n_lines]


def worst_pair_draws(
    scene: Scene,
    rate_sigma: float,
    draws: int,
    rng: np.random.Generator,
    assumed: LogErrorModel | None = None,
    gcps: dict[str, Survey] | None = None,
) -> np.ndarray:
    """(draws,) the worst pair's eps_t (frames) of line errors drawn from the Cramer-Rao covariance (with ``assumed``:
    from the covariance of the estimator under that prior; with ``gcps``: of the poses estimated too,
    line_covariance)."""
    return pair_draws(scene, rate_sigma, draws, rng, assumed, gcps).max(axis=0)


def pair_draws(
    scene: Scene,
    rate_sigma: float,
    draws: int,
    rng: np.random.Generator,
    assumed: LogErrorModel | None = None,
    gcps: dict[str, Survey] | None = None,
    poses_free: bool = False,
) -> np.ndarray:
    """(ordered pairs, draws) each pair's eps_t (frames) of line errors drawn from the Cramer-Rao covariance (with
    ``assumed``, ``gcps`` and ``poses_free``: as line_covariance)."""
    names, covariance = line_covariance(scene, rate_sigma, assumed, gcps, poses_free)
    errors = rng.multivariate_normal(np.zeros(len(covariance)), covariance, size=draws)  # (D, 2C)
    pairs = []
    for i, a in enumerate(names):
        frames = np.arange(scene.n_frames[a], dtype=np.float64)
        la = scene.lines[a]
        s = (frames - la.beta) / la.alpha  # A's frames as samples; B's frame there is alpha_b s + beta_b
        for j, b in enumerate(names):
            if a == b:
                continue
            lb = scene.lines[b]
            # frame_B(f_A) = alpha_b (f_A - beta_a) / alpha_a + beta_b; its error to first order per unit of each
            # parameter
            d_alpha_a, d_beta_a = -lb.alpha * s / la.alpha, -lb.alpha / la.alpha
            d_alpha_b, d_beta_b = s, 1.0
            step = (
                np.outer(errors[:, 2 * i], d_alpha_a)
                + errors[:, 2 * i + 1, None] * d_beta_a
                + np.outer(errors[:, 2 * j], d_alpha_b)
                + errors[:, 2 * j + 1, None] * d_beta_b
            )
            pairs.append(np.mean(np.abs(step), axis=1))
    return np.array(pairs)


def _fixes_near(visits, n_fixes: int) -> np.ndarray:
    """Sample coordinates of the fixes whose error reaches a tracked frame (FIX_MARGIN more on each side)."""
    keep: set[int] = set()
    for s in visits:
        lo = max(int(np.floor(s.min())) - FIX_MARGIN, 0)
        hi = min(int(np.ceil(s.max())) + FIX_MARGIN, n_fixes - 1)
        keep.update(range(lo, hi + 1))
    return np.array(sorted(keep), dtype=np.float64)


def _interpolation(s: np.ndarray, fixes: np.ndarray) -> np.ndarray:
    """(N, F) weights of the kept fixes at samples s (linear between consecutive fixes)."""
    right = np.clip(np.searchsorted(fixes, s, side="right"), 1, len(fixes) - 1)
    left = right - 1
    u = np.clip((s - fixes[left]) / (fixes[right] - fixes[left]), 0.0, 1.0)
    weights = np.zeros((len(s), len(fixes)))
    weights[np.arange(len(s)), left] = 1.0 - u
    weights[np.arange(len(s)), right] += u
    return weights


def _error_covariance(t: np.ndarray, model: LogErrorModel) -> np.ndarray:
    """(3F, 3F) covariance of the log's error at times t (s), fix-major: Gauss-Markov per axis plus white."""
    correlation = np.exp(-np.abs(t[:, None] - t[None, :]) / model.tau_s)
    bias = np.array([model.bias_h_m, model.bias_h_m, model.bias_v_m]) ** 2
    white = np.array([model.white_h_m, model.white_h_m, model.white_v_m]) ** 2
    return np.kron(correlation, np.diag(bias)) + np.kron(np.eye(len(t)), np.diag(white)) + 1e-12 * np.eye(3 * len(t))


def _projection_gradient(camera, position: np.ndarray, step: float = 1e-3) -> np.ndarray:
    """(N, 2, 3) pixels per metre of the projection at each position (central differences)."""
    out = np.zeros((len(position), 2, 3))
    for a in range(3):
        offset = np.zeros(3)
        offset[a] = step
        plus, _ = camera.project(position + offset)
        minus, _ = camera.project(position - offset)
        out[:, :, a] = (plus - minus) / (2 * step)
    return out


def _pose_gradient(camera: Camera, position: np.ndarray) -> np.ndarray:
    """(N, 2, 6) pixels per unit of the pose's unknowns at positions (N, 3): a rotation of the camera about the world
    axes through its centre (radians) and a move of its centre (metres), by central differences."""
    out = np.zeros((len(position), 2, POSE_PARAMETERS))
    for k in range(POSE_PARAMETERS):
        step = np.zeros(POSE_PARAMETERS)
        step[k] = POSE_STEP
        plus, _ = _moved(camera, step).project(position)
        minus, _ = _moved(camera, -step).project(position)
        out[:, :, k] = (plus - minus) / (2 * POSE_STEP)
    return out


def _moved(camera: Camera, step: np.ndarray) -> Camera:
    """The camera turned by step[:3] (a rotation vector, world axes) and its centre moved by step[3:] (metres)."""
    R = camera.R @ cv2.Rodrigues(step[:3])[0].T
    centre = camera.center + step[3:]
    return replace(camera, R=R, t=-R @ centre)
