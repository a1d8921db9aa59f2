"""Camera model (K, distortion, R, t; projection) and its calibration.

This package never imports ``tlsync_pipeline`` nor ``trackers``.
"""

from calibration.camera import Camera, read_camera, write_camera
from calibration.errors import CalibrationInputError

__all__ = ["Camera", "CalibrationInputError", "read_camera", "write_camera"]
