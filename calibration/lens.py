"""The lens model switch: OpenCV's polynomial model or cv2.fisheye, in one place.

``dist_model`` is "opencv" (k1 k2 p1 p2 k3, or the 8-coefficient rational
model) or "fisheye" (k1..k4). Pixels are full-resolution pixels with the
origin at the centre of the top-left pixel (OpenCV's convention).
"""

from __future__ import annotations

import numpy as np

DISTORTION_MODELS = ("opencv", "fisheye")
_UNDISTORT_ITERATIONS, _UNDISTORT_EPS = 50, 1e-12


def project_points(points, rvec, tvec, K: np.ndarray, dist: np.ndarray, dist_model: str) -> np.ndarray:
    """Pixels (N, 2) of 3D points (N, 3) seen from the pose (rvec, tvec: Rodrigues, metres)."""
    import cv2  # OpenCV loads with the first projection, not with the module

    pts = np.asarray(points, dtype=np.float64).reshape(-1, 1, 3)
    rvec = np.asarray(rvec, dtype=np.float64).reshape(3, 1)
    tvec = np.asarray(tvec, dtype=np.float64).reshape(3, 1)
    if dist_model == "fisheye":
        return cv2.fisheye.projectPoints(pts, rvec, tvec, K, dist)[0].reshape(-1, 2)
    return cv2.projectPoints(pts, rvec, tvec, K, dist)[0].reshape(-1, 2)


_POLYNOMIAL_LENGTHS = (0, 4, 5, 8, 12)  # OpenCV's coefficient counts without the tilted sensor (14)


def distort_normalized(normalized: np.ndarray, K: np.ndarray, dist: np.ndarray, dist_model: str) -> np.ndarray:
    """Pixels (N, 2) of normalized image points (N, 2: x / z, y / z) through the lens model.

    The polynomial model is evaluated here term by term in OpenCV's own order
    (projectPoints), which gives its very numbers without the Jacobian it
    always computes (N x 2 x 15: ten times the projection's cost on tens of
    thousands of points); a tilted sensor and the fisheye model go through
    OpenCV. The skew K[0, 1] is left out, as projectPoints does.
    """
    normalized = np.asarray(normalized, dtype=np.float64).reshape(-1, 2)
    dist = np.asarray(dist, dtype=np.float64).ravel()
    if dist_model != "opencv" or len(dist) not in _POLYNOMIAL_LENGTHS:
        rays = np.column_stack([normalized, np.ones(len(normalized))])
        return project_points(rays, np.zeros(3), np.zeros(3), K, dist, dist_model)
    k = np.zeros(12)
    k[: len(dist)] = dist
    x, y = normalized[:, 0], normalized[:, 1]
    r2 = x * x + y * y
    r4 = r2 * r2
    r6 = r4 * r2
    a1, a2, a3 = 2 * x * y, r2 + 2 * x * x, r2 + 2 * y * y
    cdist = 1 + k[0] * r2 + k[1] * r4 + k[4] * r6
    icdist2 = 1.0 / (1 + k[5] * r2 + k[6] * r4 + k[7] * r6)
    xd = x * cdist * icdist2 + k[2] * a1 + k[3] * a2 + k[8] * r2 + k[9] * r4
    yd = y * cdist * icdist2 + k[2] * a3 + k[3] * a1 + k[10] * r2 + k[11] * r4
    return np.column_stack([xd * K[0, 0] + K[0, 2], yd * K[1, 1] + K[1, 2]])


def distortion_jacobian(normalized: np.ndarray, K: np.ndarray, dist: np.ndarray, dist_model: str) -> np.ndarray | None:
    """(N, 2, 2) derivative of the pixels (distort_normalized's) in the normalized image points (N, 2), analytic for
    the polynomial model; None for the models distort_normalized leaves to OpenCV (a tilted sensor, the fisheye)."""
    normalized = np.asarray(normalized, dtype=np.float64).reshape(-1, 2)
    dist = np.asarray(dist, dtype=np.float64).ravel()
    if dist_model != "opencv" or len(dist) not in _POLYNOMIAL_LENGTHS:
        return None
    k = np.zeros(12)
    k[: len(dist)] = dist
    x, y = normalized[:, 0], normalized[:, 1]
    r2 = x * x + y * y
    r4 = r2 * r2
    cdist = 1 + k[0] * r2 + k[1] * r4 + k[4] * r4 * r2
    icdist2 = 1.0 / (1 + k[5] * r2 + k[6] * r4 + k[7] * r4 * r2)
    radial = cdist * icdist2
    d_radial = (k[0] + 2 * k[1] * r2 + 3 * k[4] * r4) * icdist2 - radial * icdist2 * (
        k[5] + 2 * k[6] * r2 + 3 * k[7] * r4
    )  # d radial / d r2
    prism_x, prism_y = k[8] + 2 * k[9] * r2, k[10] + 2 * k[11] * r2  # d (thin prism) / d r2
    out = np.empty((len(x), 2, 2))
    out[:, 0, 0] = radial + 2 * x * x * d_radial + 2 * k[2] * y + 6 * k[3] * x + 2 * x * prism_x
    out[:, 0, 1] = 2 * x * y * d_radial + 2 * k[2] * x + 2 * k[3] * y + 2 * y * prism_x
    out[:, 1, 0] = 2 * x * y * d_radial + 2 * k[2] * x + 2 * k[3] * y + 2 * x * prism_y
    out[:, 1, 1] = radial + 2 * y * y * d_radial + 6 * k[2] * y + 2 * k[3] * x + 2 * y * prism_y
    out[:, 0] *= K[0, 0]
    out[:, 1] *= K[1, 1]
    return out


def undistort_pixels(uv, K: np.ndarray, dist: np.ndarray, dist_model: str, P: np.ndarray | None = None) -> np.ndarray:
    """Distortion-free positions (N, 2) of distorted pixels: in pixels of P (K when given), else normalized."""
    import cv2

    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, _UNDISTORT_ITERATIONS, _UNDISTORT_EPS)
    pts = np.asarray(uv, dtype=np.float64).reshape(-1, 1, 2)
    if dist_model == "fisheye":
        return cv2.fisheye.undistortPoints(pts, K, dist, None, None, P, criteria).reshape(-1, 2)
    return cv2.undistortPoints(pts, K, dist, None, None, P, criteria).reshape(-1, 2)


def project_with_jacobian(
    points, rvec, tvec, K: np.ndarray, dist: np.ndarray, dist_model: str
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Pixels (N, 2) of 3D points (N, 3) and their Jacobians, (N, 2, k) blocks by parameter.

    Blocks: ``rvec`` (3), ``tvec`` (3; also d pixel / d camera-frame point),
    ``f`` (fx, fy), ``c`` (cx, cy), ``dist`` (the model's coefficients).
    OpenCV's projectPoints and fisheye.projectPoints give them analytically.
    """
    import cv2

    pts = np.asarray(points, dtype=np.float64).reshape(-1, 1, 3)
    rvec = np.asarray(rvec, dtype=np.float64).reshape(3, 1)
    tvec = np.asarray(tvec, dtype=np.float64).reshape(3, 1)
    n = len(pts)
    if dist_model == "fisheye":
        uv, jac = cv2.fisheye.projectPoints(pts, rvec, tvec, K, dist)
        jac = jac.reshape(n, 2, -1)
        blocks = {
            "f": jac[:, :, 0:2],
            "c": jac[:, :, 2:4],
            "dist": jac[:, :, 4:8],
            "rvec": jac[:, :, 8:11],
            "tvec": jac[:, :, 11:14],
        }
    else:
        uv, jac = cv2.projectPoints(pts, rvec, tvec, K, dist)
        jac = jac.reshape(n, 2, -1)
        blocks = {
            "rvec": jac[:, :, 0:3],
            "tvec": jac[:, :, 3:6],
            "f": jac[:, :, 6:8],
            "c": jac[:, :, 8:10],
            "dist": jac[:, :, 10:],
        }
    return uv.reshape(-1, 2), blocks
