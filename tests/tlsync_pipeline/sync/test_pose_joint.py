"""The log's bias fitted with the lines and the poses from the target free (sync/solve/pose_joint.py), on a
synthetic hover seen at once by three cameras around it, with a known wandering bias."""

from __future__ import annotations

from dataclasses import replace

import cv2
import numpy as np

from calibration.camera import Camera
from data_fixtures.gcp import looking_at
from tlsync_pipeline.sync.identify.refine import BLOCKS
from tlsync_pipeline.sync.kernels.sparse_lm import residual_correlation
from tlsync_pipeline.sync.model.log_model import PRESETS
from tlsync_pipeline.sync.solve.pose_joint import JointCamera, fit_free_poses
from tlsync_pipeline.trajectory import PiecewiseTrajectory, Trajectory

RATE = 5.0  # log fixes per second
FPS = 25.0
ALPHA = FPS / RATE  # frames per sample


def _scene():
    """A target creeping over a 6 x 4 x 3 m box for 120 s (the true path), its log off by a bias that wanders 0.8 m
    (x, y) and 1.2 m (z) over a 60 s period, and three cameras 20-25 m around it that see all of it."""
    sample = np.arange(0.0, 120.0 * RATE)
    t = sample / RATE
    xyz = np.column_stack([3.0 * np.sin(t / 9.0), 2.0 * np.sin(t / 6.0 + 0.5), 5.0 + 1.5 * np.sin(t / 11.0)])
    wander = np.column_stack(
        [0.8 * np.sin(2 * np.pi * t / 60.0), 0.8 * np.cos(2 * np.pi * t / 60.0), 1.2 * np.sin(2 * np.pi * t / 45.0)]
    )
    true = Trajectory(sample, xyz, RATE, 0.0)
    logged = Trajectory(sample, xyz + wander, RATE, 0.0)
    K = np.array([[1500.0, 0.0, 960.0], [0.0, 1500.0, 540.0], [0.0, 0.0, 1.0]])
    cameras = {}
    for k, (angle, distance) in enumerate([(0.0, 20.0), (2.1, 25.0), (4.2, 22.0)]):
        centre = np.array([distance * np.cos(angle), distance * np.sin(angle), 1.5])
        R, tvec = looking_at(centre, [0.0, 0.0, 5.0])
        cameras[f"cam{k}"] = Camera(f"cam{k}", K, np.zeros(5), R, tvec, (1920, 1080), FPS)
    return true, logged, wander, cameras


def _seen(camera: Camera, true: Trajectory, beta: float, rng: np.random.Generator):
    """The camera's clock values (frames) and tracked pixels (0.5 px noise) of the true path under its line."""
    clock = np.arange(0.0, 115.0 * FPS, 3.0)
    s = (clock - beta) / ALPHA
    path = PiecewiseTrajectory(true)
    uv, _ = camera.project(path(s, path.run_of(s)))
    return clock, uv + rng.normal(0.0, 0.5, uv.shape)


def _moved(camera: Camera, centre_m: np.ndarray, degrees: float) -> Camera:
    """The camera moved by ``centre_m`` and turned by ``degrees`` about its x axis."""
    turn = cv2.Rodrigues(np.array([np.radians(degrees), 0.0, 0.0]))[0]
    R = turn @ camera.R
    return replace(camera, R=R, t=-R @ (camera.center + centre_m))


def test_the_bias_fitted_with_the_poses_free_takes_out_most_of_the_logs_wander():
    true, logged, wander, cameras = _scene()
    rng = np.random.default_rng(0)
    offsets = {"cam0": -40.0, "cam1": 13.0, "cam2": 27.0}
    starts = {"cam0": (np.array([1.5, -1.0, 0.8]), 1.5), "cam1": (np.array([-1.0, 1.2, -0.6]), -1.0)}
    joint = []
    for name, camera in cameras.items():
        clock, xy = _seen(camera, true, offsets[name], rng)
        start = _moved(camera, *starts.get(name, (np.array([0.8, 0.8, 1.0]), 1.2)))
        joint.append(JointCamera(name, start, clock, xy, ALPHA, offsets[name] + 6.0, None, True))
    found = fit_free_poses(joint, PiecewiseTrajectory(logged), RATE, PRESETS["drone"], 3.0)

    assert found is not None
    seen = true.sample[(true.sample > 5 * RATE) & (true.sample < 110 * RATE)]
    left = found.at(seen) + wander[seen.astype(int)]  # what is left of the log's error once corrected
    wander_sd = np.std(wander[seen.astype(int)], axis=0)
    assert np.linalg.norm(np.std(left, axis=0)) < 0.6 * np.linalg.norm(wander_sd), (np.std(left, axis=0), wander_sd)


def test_residuals_correlated_in_blocks_count_for_less_than_their_number():
    rng = np.random.default_rng(2)
    n = 400
    jac = np.column_stack([np.ones(2 * n), np.tile(np.linspace(-1, 1, n), 2)])
    white = rng.normal(0.0, 1.0, (n, 2))
    slow = np.repeat(rng.normal(0.0, 1.0, (8, 2)), n // 8, axis=0)  # one offset shared by each eighth
    assert residual_correlation(white, jac, 3.0, BLOCKS) < 2.0
    assert residual_correlation(0.2 * white + slow, jac, 3.0, BLOCKS) > 5.0
