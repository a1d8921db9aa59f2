"""Camera model (K, distortion, R, t; projection) and its calibration.

This package never imports ``tlsync_pipeline`` nor ``trackers``. Its names
are imported on first use (OpenCV loads only when a camera is needed).
"""

from __future__ import annotations

import importlib
from typing import Any

_WHERE = {
    "Camera": "calibration.camera",
    "read_camera": "calibration.camera",
    "write_camera": "calibration.camera",
    "CalibrationInputError": "calibration.errors",
}

__all__ = ["Camera", "CalibrationInputError", "read_camera", "write_camera"]


def __getattr__(name: str) -> Any:
    if name not in _WHERE:
        raise AttributeError(f"module 'calibration' has no attribute {name!r}")
    return getattr(importlib.import_module(_WHERE[name]), name)
