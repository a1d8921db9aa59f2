"""The part of a long log the cameras can see: its samples near the target's visits to their views.

A day-long log at 100 Hz holds millions of samples of which the cameras
see seconds. Votes, the sync's fit and the pictures need only the samples
whose position some camera could see, with a margin for the smoothing;
the rest is cut before the trajectory is prepared. Grid positions are kept
(the cut parts are gaps), so votes, lines and seconds are unchanged. A log
of at most LONG_SAMPLES samples is left whole.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from calibration.camera import Camera
from tlsync_pipeline.trajectory import Trajectory

LONG_SAMPLES = (
    200_000  # a log of more samples than this is cut to the cameras' views (33 min at 100 Hz, 5.5 h at 10 Hz)
)
WIDEN = (
    0.5  # the image widened by this share of its size on each side (distortion, the vote radius, a target half in view)
)
MARGIN_S = 5.0  # seconds kept on each side of the samples in view (the smoothing's context); 50 samples without times
CHUNK = 1 << 20  # samples projected at once


def in_view(camera: Camera, xyz: np.ndarray) -> np.ndarray:
    """bool (N,): positions (N, 3) in front of the camera whose pinhole projection falls in its widened image."""
    w, h = camera.image_size
    seen = np.zeros(len(xyz), dtype=bool)
    for lo in range(0, len(xyz), CHUNK):
        local = xyz[lo : lo + CHUNK] @ camera.R.T + camera.t
        z = local[:, 2]
        front = z > 1e-6
        with np.errstate(divide="ignore", invalid="ignore"):
            u = camera.K[0, 0] * local[:, 0] / z + camera.K[0, 2]
            v = camera.K[1, 1] * local[:, 1] / z + camera.K[1, 2]
        seen[lo : lo + CHUNK] = (
            front & (u > -WIDEN * w) & (u < (1 + WIDEN) * w) & (v > -WIDEN * h) & (v < (1 + WIDEN) * h)
        )
    return seen


def near_views(trajectory: Trajectory, cameras: Iterable[Camera]) -> Trajectory:
    """The trajectory's samples within MARGIN_S of one any camera sees; the whole trajectory when it is short or a
    camera has no pose.
    """
    cameras = list(cameras)
    if len(trajectory) <= LONG_SAMPLES or not cameras or not all(c.posed for c in cameras):
        return trajectory
    seen = np.zeros(len(trajectory), dtype=bool)
    for camera in cameras:
        seen |= in_view(camera, trajectory.xyz)
    margin = MARGIN_S * (trajectory.rate or 10.0)
    sample = trajectory.sample
    hits = sample[seen]
    if len(hits) == 0:
        return trajectory  # nothing in view: the sync says so on the whole log
    nearest = np.searchsorted(hits, sample)
    before = np.abs(sample - hits[np.clip(nearest - 1, 0, len(hits) - 1)])
    after = np.abs(hits[np.clip(nearest, 0, len(hits) - 1)] - sample)
    keep = np.minimum(before, after) <= margin
    sigma = None if trajectory.sigma is None else trajectory.sigma[keep]
    return Trajectory(sample[keep], trajectory.xyz[keep], trajectory.rate, trajectory.t0, sigma)
