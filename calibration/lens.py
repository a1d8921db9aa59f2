"""The lens model switch: OpenCV's polynomial model or cv2.fisheye, in one place.

``dist_model`` is "opencv" (k1 k2 p1 p2 k3, or the 8-coefficient rational
model) or "fisheye" (k1..k4). Pixels are full-resolution pixels with the
origin at the centre of the top-left pixel (OpenCV's convention).
"""

from __future__ import annotations

import cv2
import numpy as np

DISTORTION_MODELS = ("opencv", "fisheye")
_UNDISTORT_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-12)


def project_points(points, rvec, tvec, K: np.ndarray, dist: np.ndarray, dist_model: str) -> np.ndarray:
    """Pixels (N, 2) of 3D points (N, 3) seen from the pose (rvec, tvec: Rodrigues, metres)."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 1, 3)
    rvec = np.asarray(rvec, dtype=np.float64).reshape(3, 1)
    tvec = np.asarray(tvec, dtype=np.float64).reshape(3, 1)
    if dist_model == "fisheye":
        return cv2.fisheye.projectPoints(pts, rvec, tvec, K, dist)[0].reshape(-1, 2)
    return cv2.projectPoints(pts, rvec, tvec, K, dist)[0].reshape(-1, 2)


def undistort_pixels(uv, K: np.ndarray, dist: np.ndarray, dist_model: str, P: np.ndarray | None = None) -> np.ndarray:
    """Distortion-free positions (N, 2) of distorted pixels: in pixels of P (K when given), else normalized."""
    pts = np.asarray(uv, dtype=np.float64).reshape(-1, 1, 2)
    if dist_model == "fisheye":
        return cv2.fisheye.undistortPoints(pts, K, dist, None, None, P, _UNDISTORT_CRITERIA).reshape(-1, 2)
    return cv2.undistortPoints(pts, K, dist, None, None, P, _UNDISTORT_CRITERIA).reshape(-1, 2)
