"""The clock spread a log's bias explains at the target's own speed, from its track."""

from __future__ import annotations

import numpy as np
import pytest

from calibration.camera import Camera
from tlsync_pipeline.sync.solve.slow_motion import bias_time_spread
from tlsync_pipeline.trajectory import PiecewiseTrajectory, Trajectory

FPS, RATE, DEPTH = 30.0, 10.0, 40.0


def _camera() -> Camera:
    """Looking straight down from DEPTH metres at the origin (x east to the right of the image)."""
    K = np.array([[1000.0, 0.0, 960.0], [0.0, 1000.0, 540.0], [0.0, 0.0, 1.0]])
    R = np.diag([1.0, -1.0, -1.0])
    return Camera("down", K, np.zeros(5), R, -R @ np.array([0.0, 0.0, DEPTH]), (1920, 1080), FPS)


@pytest.mark.parametrize("speed", [0.3, 1.0, 5.0])
def test_a_bias_along_a_straight_pass_is_its_own_length_over_the_speed(speed):
    camera = _camera()
    sample = np.arange(0.0, 30 * RATE)
    xyz = np.column_stack([speed * (sample / RATE - 15.0), np.zeros_like(sample), np.zeros_like(sample)])
    path = PiecewiseTrajectory(Trajectory(sample, xyz, RATE))
    alpha, beta = FPS / RATE, 12.0
    seconds = min(20.0, 20.0 / speed)  # in view: within 10 m of the middle
    clock = alpha * (15.0 - seconds / 2) * RATE + beta + np.arange(0.0, seconds * FPS)
    uv, _ = camera.project(path((clock - beta) / alpha, np.zeros(len(clock), int)))
    noisy = uv + np.random.default_rng(0).normal(0.0, 0.3, uv.shape)
    spread = bias_time_spread(camera, clock, noisy, path, alpha, beta, np.array([1.0, 1.0, 2.0]), FPS)
    assert spread is not None
    assert spread.frames == pytest.approx(1.0 / speed * FPS, rel=0.05)  # only the bias along x is time
    assert spread.speed_m_s == pytest.approx(speed, rel=0.05)
