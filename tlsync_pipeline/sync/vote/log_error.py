"""The log's error as the votes see it: its white noise measured on its own fixes, and each camera's vote radius.

The error model itself (LogModel, its presets, the project's choice) is sync/model/log_model.py.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from tlsync_pipeline.sync.model.log_model import PRESETS, PRIOR_LOG_SD, LogModel
from tlsync_pipeline.trajectory import Trajectory

if TYPE_CHECKING:
    from calibration.camera import Camera

VOTE_SIGMAS = 3.0  # a vote's radius covers this many standard deviations of the log's error, seen from the camera
MAD_TO_SD = 1.4826  # a normal variable's std over its median absolute deviation
RADIUS_POINTS = 500  # most fixes the vote radius is measured at
OVERRULE_SPREADS = 3.0  # a declared white noise is overruled by a measurement further than this many of its stds (log)
UNDECIDED_SPREADS = 2.0  # fixes within this many of their stds (log) of a receiver without a bias cannot rule it out


def vote_radius(camera: Camera, trajectory: Trajectory, eps_px: float, model: LogModel) -> float:
    """The vote radius for one camera (pixels): eps_px, or VOTE_SIGMAS times the log's error as this camera sees it,
    whichever is larger. The error is the model's horizontal and vertical std (a receiver's heights wander twice as
    far: seen across from a few metres up, a vertical error moves the projection by its whole length) projected at
    the fixes in view: the image std along its widest axis, the median over those fixes (RADIUS_POINTS of them at
    most). A log whose error puts every fix beside the image (a walk along its edge, a bias of metres) is seen at the
    fixes within one image size of it."""
    if model.horizontal_m <= 0 and model.vertical_m <= 0:
        return eps_px
    uv, valid = camera.project(trajectory.xyz)
    uv = np.nan_to_num(uv, nan=-1e9)
    seen = valid & camera.in_image(uv)
    if not seen.any():
        width, height = camera.image_size
        seen = valid & (np.abs(uv[:, 0] - width / 2) < 1.5 * width) & (np.abs(uv[:, 1] - height / 2) < 1.5 * height)
    if not seen.any():
        return eps_px
    points = trajectory.xyz[seen][:: max(1, int(seen.sum()) // RADIUS_POINTS)]
    return max(eps_px, VOTE_SIGMAS * float(np.median(_image_std(camera, points, model))))


def _image_std(camera: Camera, points: np.ndarray, model: LogModel) -> np.ndarray:
    """(N,) std (pixels) along the widest axis of the image error at each point that the log's error (horizontal and
    vertical std, independent axes) moves its projection by: the projection's Jacobian by central differences."""
    step = 0.05  # metres
    sigma = np.array([model.horizontal_m, model.horizontal_m, model.vertical_m])
    columns = []
    for axis in range(3):
        move = np.zeros(3)
        move[axis] = step
        ahead, _ = camera.project(points + move)
        behind, _ = camera.project(points - move)
        columns.append((ahead - behind) / (2 * step) * sigma[axis])
    jacobian = np.stack(columns, axis=2)  # (N, 2, 3): pixels per std of each axis
    cov = jacobian @ np.swapaxes(jacobian, 1, 2)
    widest = np.linalg.eigvalsh(np.nan_to_num(cov, nan=0.0))[:, -1]
    return np.sqrt(np.maximum(widest, 0.0))


def white_from_log(trajectory: Trajectory) -> tuple[float, int]:
    """The log's white noise (m, std per horizontal axis) from its own fixes, and how many second differences
    measured it: the robust std (median absolute deviation) of the second differences of consecutive samples over
    sqrt(6), pooled over east and north. A smooth motion leaves second differences near zero except in turns,
    which the median ignores; a wandering bias adds 2 sigma^2 dt / tau per sample, small against white noise
    (0.1 m^2 for a phone's 1 m / 60 s at 1 Hz, 6 times less than its 0.5 m of white noise)."""
    if trajectory.sigma is not None or len(trajectory) < 3:
        return 0.0, 0
    step = np.diff(trajectory.sample)
    usual = float(np.median(step))
    consecutive = (step[1:] == step[:-1]) & (np.abs(step[1:] - usual) < 1e-6 * max(usual, 1.0))
    second = (trajectory.xyz[2:, :2] - 2.0 * trajectory.xyz[1:-1, :2] + trajectory.xyz[:-2, :2])[consecutive]
    if len(second) < 10:
        return 0.0, 0
    return float(MAD_TO_SD * np.median(np.abs(second)) / math.sqrt(6.0)), int(second.size)


def noise_beyond_turns(trajectory: Trajectory) -> float:
    """The scatter of the log's fixes (m, std per horizontal axis) that a path's steady turns do not make: the robust
    std of the third differences of consecutive samples over sqrt(20), pooled over east and north. A path turning all
    along (a constant acceleration) reads as noise in second differences (white_from_log: the raw demo's exact log
    0.13 m) and leaves none in third differences (0.013 m); a receiver's white noise reads the same in both (a
    drone's 0.11 m, a phone's 0.52-0.62 m). 0 when the log states its sigmas or is too short to tell."""
    if trajectory.sigma is not None or len(trajectory) < 4:
        return 0.0
    step = np.diff(trajectory.sample)
    usual = float(np.median(step))
    regular = np.abs(step - usual) < 1e-6 * max(usual, 1.0)
    third = np.diff(trajectory.xyz[:, :2], n=3, axis=0)[regular[2:] & regular[1:-1] & regular[:-2]]
    if len(third) < 10:
        return 0.0
    return float(MAD_TO_SD * np.median(np.abs(third)) / math.sqrt(20.0))


def measured(model: LogModel, trajectory: Trajectory) -> LogModel:
    """The model with its white noise measured on the log's own fixes (white_from_log), the preset's value as a
    log-normal prior (PRIOR_LOG_SD): the posterior mode of log sigma, the measurement's variance about 4 / count
    (the median absolute deviation's of correlated second differences). An undeclared log (no white noise in its
    model) takes the measurement as it is. Unchanged when the log states its sigmas or is too short to tell."""
    white, count = white_from_log(trajectory)
    if count == 0 or white <= 0:
        return model
    data, prior = 4.0 / count, PRIOR_LOG_SD**2
    receiver = _receiver_of(model, noise_beyond_turns(trajectory), math.sqrt(data))
    if model.white_m > 0:
        white = math.exp((math.log(white) / data + math.log(model.white_m) / prior) / (1.0 / data + 1.0 / prior))
    if receiver is not None:
        model = replace(receiver, measured=(*model.measured, "receiver"))
    return replace(model, white_m=white, measured=tuple(sorted({*model.measured, "white_m"})))


def gate_model(model: LogModel, trajectory: Trajectory) -> LogModel:
    """The model whose error sets a camera's vote radius and identification's gate (vote_radius): the measured one
    (measured), except for a receiver with a bias that ingest only suggested from the log's kind whose fixes cannot rule
    out a receiver without one (their scatter, noise_beyond_turns, within UNDECIDED_SPREADS of its stds in log of that
    preset's white noise): that receiver, with the white noise measured. Its gate keeps the cameras on a target that
    follows the log; the suggested bias stays the prior of the fits that measure it from the cameras' pixels (the pose
    from the target, the joint fit's marginal likelihood). A short GPX of 66 fixes with 0.3 m of white noise may read
    0.39 m: a phone's 2 m / 4 m of bias in its gate, hundreds of pixels, lets identification follow passers-by."""
    found = measured(model, trajectory)
    if not (found.suggested and found.has_bias):
        return found
    _, count = white_from_log(trajectory)
    scatter = noise_beyond_turns(trajectory)
    if count == 0 or scatter <= 0:
        return found
    spread = math.sqrt(4.0 / count)
    unbiased = [p for p in PRESETS.values() if p.white_m > 0 and not p.has_bias]
    nearest = min(unbiased, key=lambda p: abs(math.log(scatter / p.white_m)))
    if abs(math.log(scatter / nearest.white_m)) > UNDECIDED_SPREADS * spread:
        return found
    return replace(
        nearest, white_m=found.white_m, suggested=True, measured=tuple(sorted({*found.measured, "receiver"}))
    )


def _receiver_of(model: LogModel, white: float, spread: float) -> LogModel | None:
    """The receiver the log's fixes say it is (``white``: noise_beyond_turns, so that an exact path turning all along is
    no receiver's; ``spread``: the std of its logarithm), or None to keep the model's:

    - a model without a bias whose fixes scatter as a receiver that wanders: the preset whose white noise is nearest
      (in log) to the one measured, when it has a bias, the measurement is at least the white noise of the least noisy
      preset with a bias, nearer to that preset's than to the model's and, where the model states a white noise, more
      than OVERRULE_SPREADS spreads from it. Its bias then applies (a receiver that noisy wanders too: a drone's log
      declared RTK, or undeclared); a good GPX declared white 0.3 m whose 66 fixes read 0.39 m by chance is no phone's;
    - a receiver with a bias that ingest only suggested from the log's kind (a GPX: a phone's) whose fixes scatter as
      a receiver without one: the preset without a bias whose white noise is nearest to the one measured, when it is
      nearer than the suggestion's and than every preset's with a bias (a GPX whose fixes show 0.3 m of white noise
      is a 0.3 m white log, not a phone's; one that shows 0.5 m stays a phone's). Fixes that scatter less than a
      wandering receiver's least (an RTK-like scatter) say nothing of a bias: consumer receivers smooth their fixes
      and wander all the same, so the suggestion stands."""
    if white <= 0:
        return None
    nearest = min((p for p in PRESETS.values() if p.white_m > 0), key=lambda p: abs(math.log(white / p.white_m)))
    least_wandering = min(p.white_m for p in PRESETS.values() if p.has_bias)
    if model.has_bias:
        if not model.suggested or nearest.has_bias or nearest.white_m < least_wandering:
            return None
        if abs(math.log(white / model.white_m)) <= abs(math.log(white / nearest.white_m)):
            return None
        return replace(nearest, suggested=True)
    if white < least_wandering:
        return None
    if not nearest.has_bias:
        return None
    if model.white_m > 0:
        off = abs(math.log(white / model.white_m))
        if off <= abs(math.log(white / nearest.white_m)) or off <= OVERRULE_SPREADS * spread:
            return None
    return nearest


def with_log_noise(trajectory: Trajectory, model: LogModel) -> Trajectory:
    """The trajectory with the model's white noise as every sample's sigma, when the log states none."""
    if trajectory.sigma is not None or model.white_m <= 0:
        return trajectory
    return replace(trajectory, sigma=np.full(len(trajectory), model.white_m))
