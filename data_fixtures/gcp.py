"""Ground control points seen by a known camera, with optional pixel noise, and their CSV files."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np


def looking_at(center, target, up=(0.0, 0.0, 1.0)) -> tuple[np.ndarray, np.ndarray]:
    """World -> camera (R, t) of a camera at ``center`` looking at ``target`` (metres, z up)."""
    center, target = np.asarray(center, float), np.asarray(target, float)
    z = target - center
    z /= np.linalg.norm(z)
    x = np.cross(z, up)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.vstack([x, y, z])
    return R, -R @ center


def make_gcps(K, dist, R, t, image_size, n=8, seed=0, noise_px=0.0, extent=((-15, 15), (-5, 30), (0.0, 4.0))):
    """``n`` world points (N, 3, metres) inside ``extent`` that the camera sees, and their pixels (N, 2) plus noise.

    Points are spread over the image (one per cell of a coarse grid where possible)
    and lie at least 2 m in front of the camera. Returns (uv_noisy, xyz, uv_true).
    """
    rng = np.random.default_rng(seed)
    w, h = image_size
    lo, hi = np.array([e[0] for e in extent]), np.array([e[1] for e in extent])
    rvec = cv2.Rodrigues(np.asarray(R, float))[0]
    cells: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]] = {}
    extra = []
    for _ in range(20000):
        X = rng.uniform(lo, hi)
        if (R @ X + t)[2] < 2.0:
            continue
        uv = cv2.projectPoints(X.reshape(1, 1, 3), rvec, t, K, dist)[0].ravel()
        if not (0.05 * w < uv[0] < 0.95 * w and 0.05 * h < uv[1] < 0.95 * h):
            continue
        cell = (int(3 * uv[0] / w), int(3 * uv[1] / h))
        if cell not in cells:
            cells[cell] = (uv, X)
        elif len(extra) < n:
            extra.append((uv, X))
        if len(cells) == 9 and len(extra) >= n:
            break
    chosen = (list(cells.values()) + extra)[:n]
    order = rng.permutation(len(chosen))
    uv_true = np.array([chosen[i][0] for i in order])
    xyz = np.array([chosen[i][1] for i in order])
    return uv_true + rng.normal(0.0, noise_px, uv_true.shape), xyz, uv_true


def write_gcp_csv(path: str | Path, uv: np.ndarray, points: np.ndarray, geodetic: bool = False) -> Path:
    """Write ``u,v,x,y,z`` (or ``u,v,lat,lon,alt`` when ``geodetic``) with a name column."""
    path = Path(path)
    header = "name,u,v,lat,lon,alt" if geodetic else "name,u,v,x,y,z"
    rows = [
        f"p{i}," + ",".join(repr(float(x)) for x in (u, v, a, b, c))
        for i, ((u, v), (a, b, c)) in enumerate(zip(uv, points))
    ]
    path.write_text(header + "\n" + "\n".join(rows) + "\n", encoding="utf-8")
    return path
