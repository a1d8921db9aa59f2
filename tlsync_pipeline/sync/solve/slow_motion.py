"""The time a log's bias explains at a camera's visit, from the target's speed as its track shows it.

A bias of the log along the target's motion is a time error: b metres at v
m/s are b / v seconds. The joint fit with the bias (sync/solve/log_bias.py)
states this through the projected log's velocity under the fitted line; on
a target that hovers in view, a line on the wrong part of the log sees the
log's speed there, not the target's. Here the speed is the track's own:
each frame's image velocity (pixels per clock unit) against how the bias
moves the projected position (the projection's Jacobian, pixels per metre)
gives, by least squares over the frames that constrain the line (weighted
by the squared image speed: what a frame says of the time), the clock shift
that a constant bias during the visit explains,

    d_clock = g . b,  g = -sum_i J_i^T v_i / sum_i |v_i|^2   (frames per metre),

whose std under the bias's per-axis std is the spread stated here. The
target's effective speed across the view is that of the smallest motion
in space that moves its image as tracked (the Jacobian's pseudo-inverse),
weighted the same way.

A step of a visit's clock between two parts of it (``step_spread``) is what
the bias explains on each part: over a visit that turns or slows, each
part's shift differs from the whole visit's (a pass out and back shifts its
two halves by opposite amounts that a spread over the whole cancels).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from calibration.camera import Camera
from tlsync_pipeline.sync.kernels.velocity import image_velocity
from tlsync_pipeline.sync.solve.log_bias import SEEN_VELOCITY_S
from tlsync_pipeline.trajectory import PiecewiseTrajectory

MIN_FRAMES = 3  # frames with a measured image velocity needed for a spread


@dataclass(frozen=True)
class BiasSpread:
    """The clock's std (frames) that the log's bias explains at a visit, and the target's effective speed across the
    view (m/s: the information-weighted mean of its frames' speeds)."""

    frames: float
    speed_m_s: float


def bias_time_spread(
    camera: Camera,
    clock: np.ndarray,
    xy: np.ndarray,
    path: PiecewiseTrajectory,
    alpha: float,
    beta: float,
    bias_sd_m: np.ndarray,
    fps: float,
) -> BiasSpread | None:
    """The spread of the camera's clock (frames) that a bias with per-axis std ``bias_sd_m`` (3,) explains over the
    frames (clock values, tracked pixels xy) that constrain the line clock = alpha x sample + beta (see the module);
    fps: clock units per second. None when fewer than MIN_FRAMES frames have a measured velocity and a projection."""
    velocity = image_velocity(clock, xy, SEEN_VELOCITY_S * fps)
    s = (clock - beta) / alpha
    run = path.run_of(s)
    usable = (run >= 0) & np.all(np.isfinite(velocity), axis=1)
    if usable.sum() < MIN_FRAMES:
        return None
    points, velocity = path(s[usable], run[usable]), velocity[usable]
    uv, valid = camera.project(points)
    jacobian = camera.pixels_per_metre(points, uv)  # (N, 2, 3)
    valid &= np.all(np.isfinite(jacobian), axis=(1, 2))
    if valid.sum() < MIN_FRAMES:
        return None
    jacobian, velocity = jacobian[valid], velocity[valid]
    speed2 = np.sum(velocity**2, axis=1)
    energy = float(speed2.sum())
    if not energy > 0:
        return BiasSpread(float("inf"), 0.0)
    g = -np.einsum("nij,ni->j", jacobian, velocity) / energy
    frames = float(np.sqrt(np.sum((g * bias_sd_m) ** 2)))
    across = np.linalg.norm(
        np.einsum("nij,nj->ni", np.linalg.pinv(jacobian), velocity), axis=1
    )  # metres per clock unit
    speed = float(np.sum(speed2 * across) / energy) * fps
    return BiasSpread(frames, speed)


def step_spread(
    camera: Camera,
    frame: np.ndarray,
    clock: np.ndarray,
    xy: np.ndarray,
    path: PiecewiseTrajectory,
    alpha: float,
    beta: float,
    bias_sd_m: np.ndarray,
    fps: float,
) -> Callable[[float], float]:
    """The std (frames) of the step between a visit's clock before a frame and after it that the log's bias explains,
    as a function of that frame (0-based): each side's ``bias_time_spread`` over the tracked frames ``frame`` (their
    clock values ``clock``, pixels ``xy``) on that side, the bias independent on the two sides (it wanders):
    sqrt(before^2 + after^2). inf when a side has no spread to measure."""
    frame = np.asarray(frame)

    def at(split: float) -> float:
        sides = [
            bias_time_spread(camera, clock[side], xy[side], path, alpha, beta, bias_sd_m, fps)
            for side in (frame < split, frame >= split)
        ]
        return math.inf if any(s is None for s in sides) else math.hypot(*(s.frames for s in sides if s is not None))

    return at
