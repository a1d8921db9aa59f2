"""Joint least-squares fit of a camera's pose, its line and (optionally) its intrinsics, from the target.

Unknowns: the pose (Rodrigues rotation ``rvec``, translation ``tvec``;
world -> camera, X_cam = R X + t, metres), the line clock = alpha * sample
+ beta (parametrised as s = s0 + u (clock - clock_mid) around the middle
frame, as in sync/identify/refine.py) and, when asked, the focal length ``f`` (fy
keeps the given fx/fy ratio), the principal point ``cx``, ``cy`` and the
first radial distortion term ``k1``.

Residuals, all in pixels of the loss scale ``f_scale`` at one sigma:

- each tracked position against the trajectory projected at its continuous
  sample (soft L1, scale f_scale, as the refinement);
- each ground control point (GcpPrior) against its projection, scaled by
  f_scale / sigma_px, sigma_px = sqrt(click_px^2 + (focal x sigma_m /
  depth)^2): the GCPs are a prior on the pose, as good as the survey
  (soft L1 too: one wrong point cannot drag the pose);
- the slope prior (sync/kernels/slope.py) and the intrinsics' priors (IntrinsicsPrior),
  quadratic.

The Jacobian is analytic (OpenCV's projection Jacobians, calibration.lens).
Each frame's residual depends on the line through its sample only, so its
column is the projection's rate along the path times ds/d(u, s0).

Extra unknowns shared with other cameras (a log bias, issue 24) enter as
more columns of the same system: ``Layout`` names every slice of the
parameter vector, and the trajectory is evaluated through ``positions``.

The covariance is the M-estimator sandwich of sync/identify/refine.py: the track's
part of the meat is the larger (in the metric of the frame-by-frame one) of
the frame-by-frame and the BLOCKS-block sums of scores (errors shared by
neighbouring frames), plus a model-error term (an unseen pixel offset of
std model_error_px shared by each block: the log's and the model's errors,
which the fit absorbs); GCPs and priors count at their stated sigmas.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

from calibration.camera import Camera
from calibration.lens import project_with_jacobian
from tlsync_pipeline.sync.kernels.slope import SlopePrior
from tlsync_pipeline.trajectory import PiecewiseTrajectory

BLOCKS = 8
PASSES = 4
MIN_FRAMES = 8
MAX_FIT_FRAMES = 2000  # frames of a long track used per fit (evenly spread); all are scored
MODEL_ERROR_PX = (
    1.0  # pixel offset shared by each block of frames that the residuals cannot show (log, model), in the covariance
)
INTRINSICS = ("f", "cx", "cy", "k1")


@dataclass(frozen=True)
class GcpPrior:
    """Ground control points as a prior on the pose.

    uv: (N, 2) pixels as clicked (distorted); xyz: (N, 3) world metres;
    sigma_m: std of each world coordinate (the survey's quality, metres);
    click_px: std of a click (pixels); names: one per point; weight: how
    many times its information the fit gives the survey (the track's
    inflation, ``JointFit.track_inflation``: the fit counts every frame as
    independent, and the GCPs keep their due share against that).
    """

    uv: np.ndarray
    xyz: np.ndarray
    sigma_m: float
    names: tuple[str, ...] = ()
    click_px: float = 1.0
    weight: float = 1.0

    def sigma_px(self, camera: Camera) -> np.ndarray:
        """(N,) pixel std of each point seen from the camera: the click and the survey's error at its depth."""
        depth = np.maximum((self.xyz @ camera.R.T + camera.t)[:, 2], 1e-3)
        focal = 0.5 * (camera.K[0, 0] + camera.K[1, 1])
        return np.sqrt(self.click_px**2 + (focal * self.sigma_m / depth) ** 2)

    def errors_px(self, camera: Camera) -> np.ndarray:
        """(N,) reprojection error of each point under the camera, pixels (inf behind it)."""
        uv, valid = camera.project(self.xyz)
        out = np.full(len(self.xyz), np.inf)
        out[valid] = np.linalg.norm(uv[valid] - self.uv[valid], axis=1)
        return out


@dataclass(frozen=True)
class IntrinsicsPrior:
    """Gaussian priors of the intrinsics the fit may move: value and std of f (px), cx, cy (px), k1."""

    f: tuple[float, float]
    cx: tuple[float, float]
    cy: tuple[float, float]
    k1: tuple[float, float]

    @classmethod
    def around(cls, camera: Camera) -> IntrinsicsPrior:
        """Weak priors around the camera's values: f within 50 %, the principal point within 5 % of the image, k1 within
        0.2.
        """
        w, h = camera.image_size
        K = camera.K
        return cls(
            (float(K[0, 0]), 0.5 * float(K[0, 0])),
            (float(K[0, 2]), 0.05 * w),
            (float(K[1, 2]), 0.05 * h),
            (float(camera.dist[0]) if len(camera.dist) else 0.0, 0.2),
        )


@dataclass(frozen=True)
class Layout:
    """Named slices of the parameter vector: pose, line, then the free intrinsics in INTRINSICS order."""

    free: tuple[str, ...] = ()
    names: tuple[str, ...] = field(init=False)

    def __post_init__(self):
        object.__setattr__(
            self, "names", ("rx", "ry", "rz", "tx", "ty", "tz", "u", "s0", *[k for k in INTRINSICS if k in self.free])
        )

    def index(self, name: str) -> int:
        return self.names.index(name)

    def __len__(self) -> int:
        return len(self.names)


@dataclass(frozen=True)
class JointFit:
    """The fitted camera (pose, and intrinsics where free) and line, with their uncertainty.

    alpha, beta: the line on the camera clock; cov: covariance of the
    parameter vector (``layout.names``); frames_used: frames in the last
    fit; support: given frames whose reprojection is within the gate;
    scale_px: robust residual scale (1.4826 MAD); center_std_m /
    rotation_std_deg: one-sigma camera centre (metres, root of the trace)
    and rotation (degrees); se_beta: std of beta (frames);
    intrinsics_std: std of each free intrinsic; gcp_errors_px: each GCP's
    reprojection error under the fitted camera (empty without GCPs);
    track_inflation: the pose's variance as the track's residuals show it
    (errors shared by neighbouring frames: the larger of the frame-by-frame
    and the block estimate) over the variance if every frame were
    independent (mean over the six pose parameters, at least 1): what the
    fit overcounts one frame's information by.
    """

    camera: Camera
    alpha: float
    beta: float
    cov: np.ndarray
    layout: Layout
    frames_used: int
    support: int
    scale_px: float
    center_std_m: float
    rotation_std_deg: float
    se_beta: float
    intrinsics_std: dict[str, float]
    gcp_errors_px: np.ndarray
    converged: bool
    message: str
    errors: np.ndarray  # (N,) pixel error of each given frame under the fit (inf off the trajectory)
    gate_px: float = 10.0
    track_inflation: float = 1.0
    line_cov: np.ndarray | None = None  # (2, 2) covariance of (alpha, beta)
    survey_line_cov: np.ndarray | None = None  # (2, 2) the same from the survey's error alone (_survey_line_cov)

    @property
    def inliers(self) -> np.ndarray:
        """(N,) the given frames within the gate."""
        return self.errors <= self.gate_px

    def within(self, px: float) -> int:
        """Given frames whose reprojection is within ``px``."""
        return int((self.errors <= px).sum())


def camera_at(camera: Camera, x: np.ndarray, layout: Layout) -> Camera:
    """The camera with the pose and free intrinsics of parameter vector x."""
    import cv2

    K = camera.K.copy()
    dist = camera.dist.copy()
    if "f" in layout.free:
        ratio = camera.K[1, 1] / camera.K[0, 0]
        K[0, 0], K[1, 1] = x[layout.index("f")], x[layout.index("f")] * ratio
    if "cx" in layout.free:
        K[0, 2], K[1, 2] = x[layout.index("cx")], x[layout.index("cy")]
    if "k1" in layout.free:
        dist[0] = x[layout.index("k1")]
    R = cv2.Rodrigues(np.asarray(x[0:3], dtype=np.float64))[0]
    return Camera(
        camera.name,
        K,
        dist,
        R,
        np.asarray(x[3:6], dtype=np.float64),
        camera.image_size,
        camera.fps,
        camera.dist_model,
        dict(camera.extra),
    )


def fit_pose_and_line(
    camera: Camera,
    clock: np.ndarray,
    xy: np.ndarray,
    path: PiecewiseTrajectory,
    alpha: float,
    beta: float,
    start: np.ndarray,
    gate_px: float,
    f_scale: float = 3.0,
    prior: SlopePrior | None = None,
    gcps: GcpPrior | None = None,
    free: tuple[str, ...] = (),
    intrinsics_prior: IntrinsicsPrior | None = None,
    model_error_px: float = MODEL_ERROR_PX,
) -> JointFit:
    """Fit pose, line (and the ``free`` intrinsics) to the tracked positions, from the camera's pose and the line given.

    clock: (N,) camera clock of the tracked frames (frame units); xy: (N, 2)
    tracked pixels; start: (N,) frames to fit first (those the starting
    pose and line explain). After each fit the frame set becomes every
    frame within gate_px of its projection, at most PASSES fits.
    model_error_px: std of an unseen pixel offset shared by each of BLOCKS
    runs of frames (the log's and the model's errors), added to the
    covariance as in sync/identify/refine.py. Raises
    ValueError when fewer than MIN_FRAMES frames fall on the trajectory.
    """
    layout = Layout(tuple(k for k in INTRINSICS if k in free or (k == "cy" and "cx" in free)))
    if layout.free and intrinsics_prior is None:
        intrinsics_prior = IntrinsicsPrior.around(camera)
    clock = np.asarray(clock, dtype=np.float64)
    xy = np.asarray(xy, dtype=np.float64)
    use = np.asarray(start, dtype=bool) & (path.run_of((clock - beta) / alpha) >= 0)
    if use.sum() < MIN_FRAMES:
        raise ValueError(f"only {int(use.sum())} tracked frames fall on the trajectory under the line")
    for _ in range(PASSES):
        c_mid = float(np.median(clock[use]))
        x = _vector(camera, alpha, beta, c_mid, layout)
        fit_rows = _spread(np.flatnonzero(use), MAX_FIT_FRAMES)
        solved = _solve(
            camera,
            clock[fit_rows],
            xy[fit_rows],
            path,
            x,
            c_mid,
            layout,
            f_scale,
            prior,
            gcps,
            intrinsics_prior,
            model_error_px,
        )
        camera, alpha, beta = solved.camera, solved.alpha, solved.beta
        error = reprojection_errors(camera, clock, xy, path, alpha, beta)
        grown = error <= gate_px
        if grown.sum() < MIN_FRAMES or np.array_equal(grown, use):
            break
        use = grown
    error = reprojection_errors(camera, clock, xy, path, alpha, beta)
    return JointFit(
        camera,
        alpha,
        beta,
        solved.cov,
        layout,
        solved.frames,
        int((error <= gate_px).sum()),
        solved.scale_px,
        solved.center_std_m,
        solved.rotation_std_deg,
        solved.se_beta,
        solved.intrinsics_std,
        gcps.errors_px(camera) if gcps is not None else np.zeros(0),
        solved.converged,
        solved.message,
        error,
        gate_px,
        solved.inflation,
        solved.line_cov,
        solved.survey_line_cov,
    )


def reprojection_errors(
    camera: Camera, clock: np.ndarray, xy: np.ndarray, path: PiecewiseTrajectory, alpha: float, beta: float
) -> np.ndarray:
    """(N,) pixel distance from each tracked position to the trajectory's projection at its sample on the line (inf off
    the trajectory).
    """
    s = (clock - beta) / alpha
    run = path.run_of(s)
    on = np.flatnonzero(run >= 0)
    out = np.full(len(clock), np.inf)
    if len(on):
        uv, valid = camera.project(path(s[on], run[on]))
        out[on[valid]] = np.linalg.norm(uv[valid] - xy[on[valid]], axis=1)
    return out


def _spread(rows: np.ndarray, at_most: int) -> np.ndarray:
    """At most ``at_most`` of the rows, evenly spread."""
    if len(rows) <= at_most:
        return rows
    return rows[np.linspace(0, len(rows) - 1, at_most).round().astype(np.int64)]


def _vector(camera: Camera, alpha: float, beta: float, c_mid: float, layout: Layout) -> np.ndarray:
    values = {
        "f": camera.K[0, 0],
        "cx": camera.K[0, 2],
        "cy": camera.K[1, 2],
        "k1": camera.dist[0] if len(camera.dist) else 0.0,
    }
    return np.array(
        [*camera.rvec, *camera.t, 1.0 / alpha, (c_mid - beta) / alpha, *[values[k] for k in layout.names[8:]]],
        dtype=np.float64,
    )


@dataclass(frozen=True)
class _Solved:
    """One fit's result (the fields of JointFit it fills)."""

    camera: Camera
    alpha: float
    beta: float
    cov: np.ndarray
    frames: int
    scale_px: float
    center_std_m: float
    rotation_std_deg: float
    se_beta: float
    intrinsics_std: dict[str, float]
    converged: bool
    message: str
    inflation: float
    line_cov: np.ndarray
    survey_line_cov: np.ndarray | None


def _solve(
    camera, clock, xy, path, x0, c_mid, layout, f_scale, prior, gcps, intrinsics_prior, model_error_px
) -> _Solved:
    """One robust fit from x0: the fitted camera, line, covariance and uncertainty summaries."""
    run = path.run_of(x0[7] + x0[6] * (clock - c_mid))
    keep = run >= 0
    clock, xy, run = clock[keep], xy[keep], run[keep]
    n = len(clock)
    dc = clock - c_mid
    gcp_weight = f_scale * np.sqrt(gcps.weight) / gcps.sigma_px(camera) if gcps is not None else None
    priors = _prior_rows(layout, f_scale, prior, intrinsics_prior)
    last: dict = {}

    def evaluate(x):
        key = x.tobytes()
        if key not in last:
            last.clear()
            last[key] = _residuals(camera, x, layout, path, clock, dc, run, xy, gcps, gcp_weight, priors, f_scale)
        return last[key]

    n_robust = 2 * n + (2 * len(gcps.xyz) if gcps is not None else 0)

    def loss(z):
        t = 1.0 + z
        out = np.vstack([2.0 * (np.sqrt(t) - 1.0), t**-0.5, -0.5 * t**-1.5])
        out[0, n_robust:], out[1, n_robust:], out[2, n_robust:] = z[n_robust:], 1.0, 0.0
        return out

    scale = np.array(
        [1e-3] * 3
        + [1e-2] * 3
        + [0.1 / max(float(np.ptp(clock)), 1.0) * abs(x0[6]) + 1e-9, 0.1]
        + [_INTRINSIC_SCALE[k] for k in layout.names[8:]]
    )
    solution = least_squares(
        lambda x: evaluate(x)[0],
        x0,
        jac=lambda x: evaluate(x)[1],
        loss=loss,
        f_scale=f_scale,
        x_scale=scale,
        method="trf",
        max_nfev=100,
    )
    x = solution.x
    r, jac = evaluate(x)
    fitted = camera_at(camera, x, layout)
    gcp_rows = 2 * len(gcps.xyz) if gcps is not None else 0
    cov, shared, naive = _covariance(
        r, jac, n, n_robust, f_scale, model_error_px, gcps.weight if gcps is not None else 1.0, gcp_rows
    )
    u, s0 = x[6], x[7]
    alpha, beta = 1.0 / u, c_mid - s0 / u
    d_beta = np.zeros(len(x))
    d_beta[6], d_beta[7] = s0 / u**2, -1.0 / u
    d_line = np.zeros((2, len(x)))
    d_line[0, 6], d_line[1] = -1.0 / u**2, d_beta
    survey = None
    if gcps is not None:
        to_line = d_line[:, 6:8]
        survey = to_line @ _survey_line_cov(jac, n, gcp_rows, f_scale * np.sqrt(gcps.weight)) @ to_line.T
    pixel = np.linalg.norm(r[: 2 * n].reshape(n, 2), axis=1)
    converged = bool(solution.success and np.all(np.isfinite(cov)) and u > 0)
    return _Solved(
        fitted,
        float(alpha),
        float(beta),
        cov,
        n,
        float(1.4826 * np.median(np.abs(pixel - np.median(pixel)))),
        _center_std(x, cov),
        float(np.degrees(np.sqrt(max(np.trace(cov[:3, :3]), 0.0)))),
        float(np.sqrt(max(d_beta @ cov @ d_beta, 0.0))),
        {k: float(np.sqrt(max(cov[layout.index(k), layout.index(k)], 0.0))) for k in layout.names[8:]},
        converged,
        str(solution.message),
        _inflation(shared, naive),
        d_line @ cov @ d_line.T,
        survey,
    )


def _survey_line_cov(jac: np.ndarray, n_frames: int, gcp_rows: int, gcp_scale: float) -> np.ndarray:
    """Covariance of the line's parameters (u, s0, as the parameter vector's) from the survey's error alone: the pose
    as the GCPs alone determine it (their rows of ``jac``, divided by ``gcp_scale`` back to one pixel sigma each), and
    the line that then best explains the track under each such pose (the track's rows and the priors: its line given
    the pose). A straight crossing's track hardly tells a pose moved along the path from a time shift, so there the
    survey's error is the timing's; the joint covariance, which counts the track's weak information on that move,
    can be several times smaller. NaN where the GCPs alone do not determine the pose."""
    track = 2 * n_frames
    gcp = jac[track : track + gcp_rows, :6] / gcp_scale
    given = np.vstack([jac[:track], jac[track + gcp_rows :]])
    bread = given.T @ given
    try:
        pose_cov = np.linalg.inv(gcp.T @ gcp)
        follow = -np.linalg.solve(bread[6:8, 6:8], bread[6:8, :6])  # d(u, s0) / d(pose) with the track held
    except np.linalg.LinAlgError:
        return np.full((2, 2), np.nan)
    return follow @ pose_cov @ follow.T


def _inflation(shared: np.ndarray, naive: np.ndarray) -> float:
    """Mean over the six pose parameters of the track's variance as its residuals show it over the frame-by-frame one,
    at least 1.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.diag(shared)[:6] / np.diag(naive)[:6]
    ratio = ratio[np.isfinite(ratio)]
    return max(float(np.mean(ratio)), 1.0) if len(ratio) else 1.0


_INTRINSIC_SCALE = {"f": 10.0, "cx": 5.0, "cy": 5.0, "k1": 0.01}


def _prior_rows(
    layout: Layout, f_scale: float, prior: SlopePrior | None, intrinsics: IntrinsicsPrior | None
) -> list[tuple[int, float, float]]:
    """(parameter index, value, std) of every quadratic prior: the slope (on u = 1/alpha) and the free intrinsics."""
    rows = []
    if prior is not None:
        rows.append((layout.index("u"), 1.0 / prior.alpha, prior.sigma / prior.alpha))
    if intrinsics is not None:
        for name in layout.names[8:]:
            value, std = getattr(intrinsics, name)
            rows.append((layout.index(name), value, std))
    return rows


def _residuals(camera, x, layout, path, clock, dc, run, xy, gcps, gcp_weight, priors, f_scale):
    """Stacked residuals (track rows, GCP rows, prior rows) and their Jacobian at x."""
    current = camera_at(camera, x, layout)
    rvec, tvec = x[0:3], x[3:6]
    s = x[7] + x[6] * dc
    position = path(s, run)
    velocity = path(s, run, nu=1)
    uv, blocks = project_with_jacobian(position, rvec, tvec, current.K, current.dist, current.dist_model)
    r = uv - xy
    jac = np.zeros((len(clock), 2, len(layout)))
    jac[:, :, 0:3] = blocks["rvec"]
    jac[:, :, 3:6] = blocks["tvec"]
    rate = np.einsum("nij,jk,nk->ni", blocks["tvec"], current.R, velocity)  # pixels per sample
    jac[:, :, 6] = rate * dc[:, None]
    jac[:, :, 7] = rate
    _intrinsic_columns(jac, blocks, layout, current)
    bad = ~np.isfinite(r).all(axis=1)
    r[bad] = 0.0
    jac[bad] = 0.0
    rows_r, rows_j = [r.ravel()], [jac.reshape(-1, len(layout))]
    if gcps is not None:
        guv, gblocks = project_with_jacobian(gcps.xyz, rvec, tvec, current.K, current.dist, current.dist_model)
        gj = np.zeros((len(gcps.xyz), 2, len(layout)))
        gj[:, :, 0:3] = gblocks["rvec"]
        gj[:, :, 3:6] = gblocks["tvec"]
        _intrinsic_columns(gj, gblocks, layout, current)
        rows_r.append(((guv - gcps.uv) * gcp_weight[:, None]).ravel())
        rows_j.append((gj * gcp_weight[:, None, None]).reshape(-1, len(layout)))
    if priors:
        rows_r.append(np.array([f_scale * (x[k] - value) / std for k, value, std in priors]))
        pj = np.zeros((len(priors), len(layout)))
        for row, (k, _, std) in enumerate(priors):
            pj[row, k] = f_scale / std
        rows_j.append(pj)
    return np.concatenate(rows_r), np.vstack(rows_j)


def _intrinsic_columns(jac: np.ndarray, blocks: dict, layout: Layout, camera: Camera) -> None:
    if "f" in layout.free:
        ratio = camera.K[1, 1] / camera.K[0, 0]
        jac[:, :, layout.index("f")] = blocks["f"][:, :, 0] + ratio * blocks["f"][:, :, 1]
    if "cx" in layout.free:
        jac[:, :, layout.index("cx")] = blocks["c"][:, :, 0]
        jac[:, :, layout.index("cy")] = blocks["c"][:, :, 1]
    if "k1" in layout.free:
        jac[:, :, layout.index("k1")] = blocks["dist"][:, :, 0]


def _covariance(
    r: np.ndarray,
    jac: np.ndarray,
    n_frames: int,
    n_robust: int,
    f_scale: float,
    model_error_px: float,
    gcp_weight: float = 1.0,
    gcp_rows: int = 0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sandwich covariance of the parameters (see the module docstring); its track part alone, as the residuals show it
    (frame by frame or in blocks, no model error); and the same with every frame independent. The ``gcp_rows`` rows
    after the track's are the GCPs', fitted at ``gcp_weight`` times their information: at their stated sigma a row's
    variance is gcp_weight f_scale^2, so the survey's error reaches the covariance in full, not divided by the
    weight."""
    p = jac.shape[1]
    z = (r[:n_robust] / f_scale) ** 2
    psi = np.r_[r[:n_robust] / np.sqrt(1 + z), r[n_robust:]]
    dpsi = np.r_[(1 + z) ** -1.5, np.ones(len(r) - n_robust)]
    bread = jac.T @ (jac * dpsi[:, None])
    try:
        inv = np.linalg.inv(bread)
    except np.linalg.LinAlgError:
        return np.full((p, p), np.inf), np.full((p, p), np.inf), np.full((p, p), np.inf)
    track = 2 * n_frames
    scores = (jac[:track] * psi[:track, None]).reshape(n_frames, 2, p).sum(axis=1)
    independent = scores.T @ scores * n_frames / max(n_frames - p, 1)
    blocks = np.array([b.sum(axis=0) for b in np.array_split(scores, min(BLOCKS, n_frames))])
    clustered = blocks.T @ blocks * len(blocks) / max(len(blocks) - 1, 1)
    c_ind = inv @ independent @ inv
    c_clu = inv @ clustered @ inv
    try:
        ratio = float(np.trace(np.linalg.solve(c_ind, c_clu))) / p
    except np.linalg.LinAlgError:
        ratio = 1.0
    meat = clustered if ratio > 1.0 else independent
    rest = jac[track:]
    stated = np.ones(len(rest))
    stated[:gcp_rows] = gcp_weight
    meat = meat + f_scale**2 * rest.T @ (
        rest * (dpsi[track:] * stated)[:, None]
    )  # GCPs and priors at their stated sigma (one sigma = f_scale, a GCP row scaled by sqrt(gcp_weight))
    lever = np.array(
        [
            b.sum(axis=0)
            for b in np.array_split((jac[:track] * dpsi[:track, None]).reshape(n_frames, 2, p), min(BLOCKS, n_frames))
        ]
    )
    shared = inv @ (clustered if ratio > 1.0 else independent) @ inv
    meat = meat + model_error_px**2 * np.einsum("bik,bil->kl", lever, lever)
    return inv @ meat @ inv, shared, c_ind


def _center_std(x: np.ndarray, cov: np.ndarray) -> float:
    """One-sigma camera centre (root of the trace of its covariance), metres, by first-order propagation."""

    def centre(p):
        import cv2

        return -cv2.Rodrigues(p[:3])[0].T @ p[3:6]

    c0 = centre(x)
    jc = np.zeros((3, len(x)))
    for k in range(6):
        step = np.zeros(len(x))
        step[k] = 1e-6
        jc[:, k] = (centre(x + step) - c0) / 1e-6
    return float(np.sqrt(max(np.trace(jc @ cov @ jc.T), 0.0)))
