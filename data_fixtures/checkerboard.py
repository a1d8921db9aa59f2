"""Rendered checkerboard photos from a known camera, with the truth.

Rendering is by inverse mapping: every output pixel (supersampled) is undistorted
to a ray of the true camera, the ray is cut with the board plane and the board's
colour is read there, so the true corner positions are exact up to antialiasing.
Then the photo is degraded like a real one: uneven light, defocus blur, sensor
noise, JPEG compression. Conventions: the board's inner corner (i, j) is at
(i * square, j * square, 0) metres in board coordinates, i along the pattern's
columns; the outer square next to corner (0, 0) (at negative x and y) is dark.
Pixel (0, 0) is the centre of the top-left pixel.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from calibration.lens import project_points, undistort_pixels


@dataclass(frozen=True)
class BoardView:
    """One rendered photo: board pose (board -> camera) and what it shows."""

    name: str
    rvec: np.ndarray | None  # None when the board is absent
    tvec: np.ndarray | None
    kind: str  # "full", "cut" (part of the board outside the image) or "absent"
    corners: np.ndarray | None  # (N, 2) true inner-corner pixels, row by row


@dataclass(frozen=True)
class CheckerboardSet:
    """Rendered images plus the true camera and board."""

    K: np.ndarray
    dist: np.ndarray
    image_size: tuple[int, int]
    pattern: tuple[int, int]  # inner corners (columns, rows)
    square: float  # metres
    views: list[BoardView]
    images: list[np.ndarray] = field(repr=False)  # BGR uint8, after degradation

    def truth(self) -> dict:
        return {
            "K": self.K.tolist(),
            "dist": self.dist.tolist(),
            "image_size": list(self.image_size),
            "pattern": list(self.pattern),
            "square": self.square,
            "views": [
                {
                    "name": v.name,
                    "kind": v.kind,
                    "rvec": None if v.rvec is None else v.rvec.tolist(),
                    "tvec": None if v.tvec is None else v.tvec.tolist(),
                }
                for v in self.views
            ],
        }


def default_camera(image_size: tuple[int, int] = (960, 720)) -> tuple[np.ndarray, np.ndarray]:
    """A camera with non-square pixels (fx != fy), an off-centre principal point and barrel distortion."""
    w, h = image_size
    fx = 0.82 * w
    K = np.array([[fx, 0.0, 0.508 * w], [0.0, fx * 1.04, 0.493 * h], [0.0, 0.0, 1.0]])
    dist = np.array([-0.25, 0.08, 0.0012, -0.0008, 0.0])
    return K, dist


def render_checkerboards(
    seed: int = 0,
    n_full: int = 16,
    n_cut: int = 2,
    n_absent: int = 1,
    image_size: tuple[int, int] = (960, 720),
    pattern: tuple[int, int] = (9, 6),
    square: float = 0.03,
    K: np.ndarray | None = None,
    dist: np.ndarray | None = None,
    blur_px: tuple[float, float] = (0.3, 1.2),
    noise: tuple[float, float] = (1.0, 4.0),
    jpeg_quality: tuple[int, int] = (80, 95),
    supersample: int = 2,
    dist_model: str = "opencv",
    fill: tuple[float, float] = (0.35, 0.75),
) -> CheckerboardSet:
    """Render ``n_full`` complete views, ``n_cut`` cut-off views and ``n_absent`` views without a board.

    Blur (Gaussian sigma, px), noise (sigma, grey levels) and JPEG quality are
    drawn uniformly from their ranges per image; views are shuffled.
    ``dist_model`` is "opencv" (k1 k2 p1 p2 k3) or "fisheye" (k1..k4); ``fill`` is the
    range of the board's size as a fraction of the image width.
    """
    rng = np.random.default_rng(seed)
    if K is None or dist is None:
        K, dist = default_camera(image_size)
    rays = _pixel_rays(K, dist, image_size, supersample, dist_model)
    background = _background(rng, image_size)
    kinds = ["full"] * n_full + ["cut"] * n_cut + ["absent"] * n_absent
    rng.shuffle(kinds)
    views, images = [], []
    for index, kind in enumerate(kinds):
        name = f"board_{index:03d}.png"
        if kind == "absent":
            rvec = tvec = corners = None
            grey = background.copy()
        else:
            rvec, tvec, corners = _pose(rng, K, dist, dist_model, image_size, pattern, square, fill, cut=kind == "cut")
            grey = _shade(rays, rvec, tvec, pattern, square, background, supersample)
        images.append(_degrade(rng, grey, blur_px, noise, jpeg_quality))
        views.append(BoardView(name, rvec, tvec, kind, corners))
    return CheckerboardSet(K, dist, image_size, pattern, square, views, images)


def write_checkerboards(boards: CheckerboardSet, directory: str | Path) -> Path:
    """Write the images (names of the views) and ``truth.json`` into ``directory``; returns it."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    for view, image in zip(boards.views, boards.images):
        cv2.imwrite(str(directory / view.name), image)  # PNG: the JPEG artefacts are already in
    (directory / "truth.json").write_text(json.dumps(boards.truth(), indent=1) + "\n", encoding="utf-8")
    return directory


def board_points(pattern: tuple[int, int], square: float) -> np.ndarray:
    """(cols * rows, 3) inner-corner coordinates on the board, row by row (metres)."""
    cols, rows = pattern
    grid = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2) * square
    return np.column_stack([grid, np.zeros(len(grid))])


def _pixel_rays(K, dist, image_size, supersample, dist_model="opencv") -> np.ndarray:
    """Normalized rays (h, w, s*s, 2) through the supersampling points of every pixel."""
    w, h = image_size
    offsets = (np.arange(supersample) + 0.5) / supersample - 0.5
    ox, oy = np.meshgrid(offsets, offsets)
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float64)
    px = (xs[..., None] + ox.ravel()).reshape(-1)
    py = (ys[..., None] + oy.ravel()).reshape(-1)
    norm = undistort_pixels(np.column_stack([px, py]), K, dist, dist_model)
    return norm.reshape(h, w, supersample * supersample, 2)


def _shade(rays, rvec, tvec, pattern, square, background, supersample) -> np.ndarray:
    """Grey image (float, 0..255) of the board seen along ``rays`` over ``background``."""
    R = cv2.Rodrigues(np.asarray(rvec, dtype=np.float64))[0]
    t = np.asarray(tvec, dtype=np.float64).ravel()
    normal = R[:, 2]
    d = rays[..., 0] * normal[0] + rays[..., 1] * normal[1] + normal[2]
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (normal @ t) / d
    # Board coordinates of the hit point: R^T (s * ray - t).
    px, py = s * rays[..., 0] - t[0], s * rays[..., 1] - t[1]
    pz = s - t[2]
    bx = R[0, 0] * px + R[1, 0] * py + R[2, 0] * pz
    by = R[0, 1] * px + R[1, 1] * py + R[2, 1] * pz
    cols, rows = pattern
    margin = 0.6 * square
    on_board = (
        (s > 0)
        & (bx > -square - margin)
        & (bx < cols * square + margin)
        & (by > -square - margin)
        & (by < rows * square + margin)
    )
    on_squares = (bx >= -square) & (bx < cols * square) & (by >= -square) & (by < rows * square)
    a = np.floor(bx / square).astype(np.int64)
    b = np.floor(by / square).astype(np.int64)
    dark = on_squares & ((a + b) % 2 == 0)
    value = np.where(dark, 25.0, 225.0)
    samples = np.where(on_board, value, background[..., None])
    return samples.mean(axis=-1)


def _background(rng, image_size) -> np.ndarray:
    """A smooth random grey background (float, 0..255) with some edges."""
    w, h = image_size
    low = rng.uniform(60, 190, size=(6, 8))
    img = cv2.resize(low, (w, h), interpolation=cv2.INTER_CUBIC)
    for _ in range(6):
        x0, y0 = rng.integers(0, w), rng.integers(0, h)
        cv2.rectangle(
            img,
            (int(x0), int(y0)),
            (int(x0 + rng.integers(20, w // 4)), int(y0 + rng.integers(20, h // 4))),
            float(rng.uniform(40, 210)),
            -1,
        )
    return np.clip(img, 0, 255)


def _pose(rng, K, dist, dist_model, image_size, pattern, square, fill, cut: bool):
    """A random board pose whose inner corners are all in the image (or some outside when ``cut``)."""
    w, h = image_size
    cols, rows = pattern
    obj = board_points(pattern, square)
    centre = obj.mean(axis=0)
    board_size = max(cols + 1, rows + 1) * square
    for _ in range(500):
        # Board tilted up to ~40 degrees, in-plane rotation anywhere, filling ``fill`` of the width.
        tilt = rng.normal(0.0, 0.35, size=2).clip(-0.7, 0.7)
        spin = rng.uniform(-np.pi, np.pi)
        R = cv2.Rodrigues(np.array([tilt[0], tilt[1], 0.0]))[0] @ cv2.Rodrigues(np.array([0.0, 0.0, spin]))[0]
        depth = K[0, 0] * board_size / (rng.uniform(*fill) * w)
        target = rng.uniform([0.15 * w, 0.15 * h], [0.85 * w, 0.85 * h]) if not cut else rng.uniform([0.0, 0.0], [w, h])
        ray = np.linalg.solve(K, [target[0], target[1], 1.0])
        t = ray / ray[2] * depth - R @ centre
        rvec = cv2.Rodrigues(R)[0].ravel()
        cam = obj @ R.T + t
        if np.any(cam[:, 2] <= 0.05):
            continue
        uv = project_points(obj, rvec, t, K, dist, dist_model)
        inside = (uv[:, 0] >= 8) & (uv[:, 0] <= w - 9) & (uv[:, 1] >= 8) & (uv[:, 1] <= h - 9)
        # Make sure the whole board (with its border) is in view for full boards.
        outline = np.array([[-1.6, -1.6], [cols + 0.6, -1.6], [cols + 0.6, rows + 0.6], [-1.6, rows + 0.6]]) * square
        out_uv = project_points(np.column_stack([outline, np.zeros(4)]), rvec, t, K, dist, dist_model)
        outline_inside = np.all((out_uv >= 0) & (out_uv <= [w - 1, h - 1]))
        if not cut and inside.all() and outline_inside:
            return rvec, t, uv
        if cut and 0.4 < inside.mean() < 0.8:
            return rvec, t, uv
    raise RuntimeError("could not place the board; use a larger image or a smaller pattern")


def _degrade(rng, grey, blur_px, noise, jpeg_quality) -> np.ndarray:
    """Uneven light, blur, noise and JPEG compression; returns a BGR uint8 image."""
    h, w = grey.shape
    ys, xs = np.mgrid[0:h, 0:w]
    gx, gy = rng.uniform(-0.35, 0.35, size=2)
    light = 1.0 + gx * (xs / w - 0.5) + gy * (ys / h - 0.5)
    r2 = ((xs - w / 2) ** 2 + (ys - h / 2) ** 2) / (0.25 * (w * w + h * h))
    light *= 1.0 - 0.25 * r2  # vignetting
    img = grey * light
    sigma = rng.uniform(*blur_px)
    if sigma > 0.05:
        img = cv2.GaussianBlur(img, (0, 0), sigma)
    img = img + rng.normal(0.0, rng.uniform(*noise), size=img.shape)
    img = np.clip(np.round(img), 0, 255).astype(np.uint8)
    bgr = cv2.cvtColor(img, cv2.COLOR_GRAY2BGR)
    quality = int(rng.integers(jpeg_quality[0], jpeg_quality[1] + 1))
    ok, buf = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, quality])
    return cv2.imdecode(buf, cv2.IMREAD_COLOR)


def harsh_photo(
    image: np.ndarray,
    seed: int,
    size: tuple[int, int] | None = None,
    blur_px: float = 2.5,
    noise: float = 8.0,
    light: float = 0.7,
    screen_period: float | None = None,
) -> np.ndarray:
    """A rendered photo made hard: upscaled to ``size`` (exact factor: corners map as (u + 0.5) * f - 0.5),
    strong defocus blur, a strong light gradient (``light`` = brightness drop across the image), sensor noise
    and, when ``screen_period`` (px) is given, the board shown on a screen: display gamma and a slightly
    rotated pixel grid (moire once downscaled). Returns a grey uint8 image."""
    rng = np.random.default_rng(seed)
    grey = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY).astype(np.float64) if image.ndim == 3 else image.astype(np.float64)
    if size is not None:
        grey = cv2.resize(grey, size, interpolation=cv2.INTER_CUBIC)
    h, w = grey.shape
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float64)
    if screen_period:
        grey = 255.0 * (grey / 255.0).clip(0, 1) ** 2.2  # the display's gamma, not undone
        angle = np.radians(rng.uniform(1.0, 4.0))
        u = xs * np.cos(angle) + ys * np.sin(angle)
        v = -xs * np.sin(angle) + ys * np.cos(angle)
        grid = (0.75 + 0.25 * np.cos(2 * np.pi * u / screen_period)) * (
            0.8 + 0.2 * np.cos(2 * np.pi * v / screen_period)
        )
        grey = grey * grid + 12.0  # dark pixels of a screen glow a little
    direction = rng.uniform(0, 2 * np.pi)
    ramp = (np.cos(direction) * (xs / w - 0.5) + np.sin(direction) * (ys / h - 0.5)) + 0.5
    grey = grey * (1.0 - light * ramp.clip(0, 1))
    grey = cv2.GaussianBlur(grey, (0, 0), blur_px)
    grey = grey + rng.normal(0.0, noise, grey.shape)
    return np.clip(np.round(grey), 0, 255).astype(np.uint8)
