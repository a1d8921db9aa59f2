"""The clock spread a log's bias explains at the target's own speed, from its track."""

from __future__ import annotations

import numpy as np
import pytest

from calibration.camera import Camera
from tlsync_pipeline.sync.solve.slow_motion import bias_time_spread, step_spread
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


def test_a_pass_out_and_back_steps_by_what_the_bias_explains_on_each_leg():
    """A target flown 10 m east and back at 1 m/s under a bias of 1 m east: the bias shifts the clock of the leg out
    30 frames one way and of the leg back 30 frames the other, a step of 60 frames at the turn. Over the whole visit the
    two legs' shifts cancel (a spread of nearly 0, under which such a step would be named a drop); the step's std at
    the turn is each leg's spread together."""
    camera, speed = _camera(), 1.0
    sample = np.arange(0.0, 20 * RATE + 1)
    x = np.where(sample < 10 * RATE, sample / RATE, 20.0 - sample / RATE) * speed - 5.0
    path = PiecewiseTrajectory(Trajectory(sample, np.column_stack([x, np.zeros_like(x), np.zeros_like(x)]), RATE))
    alpha, beta = FPS / RATE, 12.0
    frame = np.arange(0, int(20 * FPS))
    clock = frame.astype(np.float64)
    uv, _ = camera.project(path((clock - beta) / alpha, np.zeros(len(clock), int)))
    sd = np.array([1.0, 1.0, 2.0])
    whole = bias_time_spread(camera, clock, uv, path, alpha, beta, sd, FPS)
    assert whole is not None and whole.frames < 5.0
    turn = 10 * FPS + beta
    step = 2 * 1.0 / speed * FPS  # the bias's 1 m east: the leg out 30 frames late, the leg back 30 early
    assert step_spread(camera, frame, clock, uv, path, alpha, beta, sd, FPS)(turn) == pytest.approx(
        np.sqrt(2.0) * FPS / speed, rel=0.1
    )
    assert step / step_spread(camera, frame, clock, uv, path, alpha, beta, sd, FPS)(turn) < 3.0
