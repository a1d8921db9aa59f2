"""The upright-mount prior of a pose from the target: a fixed camera is mounted with the world's up pointing up in its
image, give or take a small roll.

Without a survey, a turning walk seen for 16-23 s is explained about as
well by poses turned 135-180 degrees about the optical axis (the image's
up pointing down or sideways) at offsets hundreds to thousands of frames
off: another stretch of the log, mirrored by the turned pose, matches the
track (docs/calibration.md, "Under a log with a bias"). No fixed mount
looks like that: with the prior on (``[sync] upright_roll_deg``,
docs/project.md) such a pose cannot be the answer, but it stays a rival
with all its evidence (sync/pose/pose.py, ``ranked_pose``): a rolled pose
that explains the track at another offset still says the track leaves the
offset open. World frame: ENU metres (z up); camera frame: x right, y
down, z forward.
"""

from __future__ import annotations

import numpy as np

OFF_DEG = 180.0  # a tolerance of this or more turns the prior off
NEAR_VERTICAL_DEG = 15.0  # an optical axis within this of the world's vertical has no roll to judge


def roll_deg(R: np.ndarray) -> float:
    """Angle (degrees, signed, in (-180, 180]) between the image's up and the world's up as the camera (rotation R,
    world to camera) sees it; 0 for an optical axis within NEAR_VERTICAL_DEG of the vertical (looking straight up or
    down, where the image has no up)."""
    up = np.asarray(R, dtype=np.float64)[:, 2]  # the world's up in camera coordinates
    if np.hypot(up[0], up[1]) < np.sin(np.radians(NEAR_VERTICAL_DEG)):
        return 0.0
    return float(np.degrees(np.arctan2(up[0], -up[1])))


def is_upright(R: np.ndarray, max_roll_deg: float | None) -> bool:
    """Whether the camera's roll is within max_roll_deg (None, or OFF_DEG or more: every pose is)."""
    return max_roll_deg is None or max_roll_deg >= OFF_DEG or abs(roll_deg(R)) <= max_roll_deg
