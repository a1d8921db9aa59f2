"""Long, high-resolution camera videos made quickly (for the throughput benches).

The same scene as ``data_fixtures.video`` (textured background, global
lighting flicker, Gaussian sensor noise, an anti-aliased bright textured disc
as the target, H.264 with B-frames), optionally with look-alikes (discs like
the target wandering the image at its speed, crossing it), built for speed at 1080p and minutes of
video: frames are composed directly in YUV 4:2:0 (no colour conversion), the
noise of each frame is a randomly shifted window of one pre-drawn noise field,
and only the target's patch is drawn in floating point. Rendering then costs
about what x264 costs (about 35 ms per 1080p frame on one core), against
about 130 ms for ``data_fixtures.video.render_video``.

``render_long_camera_video`` has the signature of
``data_fixtures.video.render_camera_video``, so either can be handed to
``data_fixtures.raw_project.make_raw_project`` as its scene renderer.
"""

from __future__ import annotations

from pathlib import Path

import av
import cv2
import numpy as np

from data_fixtures.video import _background, _draw_target, h264_writer

NOISE_MARGIN = 64  # pixels of noise field beyond the frame, in each direction, for the random shifts


def render_long_video(
    path: str | Path,
    positions: np.ndarray,
    image_size: tuple[int, int],
    fps: float,
    radius: float = 12.0,
    seed: int = 0,
    noise: float = 2.0,
    flicker: float = 0.06,
    crf: int = 20,
    gop: int = 60,
    look_alikes: np.ndarray | None = None,
) -> Path:
    """Render ``positions`` ((N, 2) target centres in pixels, NaN rows: no target) to an MP4 at ``fps``.

    look_alikes: (K, N, 2) centres of K discs drawn like the target (NaN:
    not drawn), under it. Presentation times are k / fps (s). Pixels: origin
    at the centre of the top-left pixel (the Track convention).
    """
    path = Path(path)
    rng = np.random.default_rng(seed)
    w, h = image_size
    positions = np.asarray(positions, dtype=np.float64).reshape(-1, 2)
    others = np.zeros((0, len(positions), 2)) if look_alikes is None else np.asarray(look_alikes, dtype=np.float64)
    background = _background(rng, w, h).astype(np.float32)
    field = rng.normal(0.0, noise, (h + NOISE_MARGIN, w + NOISE_MARGIN))
    brighter = np.clip(field, 0, 255).astype(np.uint8)
    darker = np.clip(-field, 0, 255).astype(np.uint8)
    del field
    size = int(2 * radius + 8)
    texture = rng.uniform(-25, 25, size=(size, size))
    patch_y, patch_x = np.mgrid[0 : size + 6, 0 : size + 6].astype(np.float32)
    chroma = np.full((h // 2, w), 128, np.uint8)  # U and V planes, stacked as yuv420p expects
    n_frames = len(positions)
    gains = (
        1.0 + flicker * np.sin(2 * np.pi * np.arange(n_frames) / 37.0) + flicker * 0.3 * rng.standard_normal(n_frames)
    )
    shifts = rng.integers(0, NOISE_MARGIN, size=(n_frames, 2))
    with h264_writer(
        path, fps, (w, h), {"crf": str(crf), "preset": "veryfast", "g": str(gop), "keyint_min": str(gop)}
    ) as write:
        for k in range(n_frames):
            luma = cv2.convertScaleAbs(background, alpha=float(gains[k]))
            for cx, cy in (*others[:, k], positions[k]):
                if np.isfinite(cx):
                    _draw_patch(luma, background, gains[k], cx, cy, radius, texture, patch_x, patch_y)
            dy, dx = shifts[k]
            cv2.add(luma, brighter[dy : dy + h, dx : dx + w], dst=luma)
            cv2.subtract(luma, darker[dy : dy + h, dx : dx + w], dst=luma)
            write(av.VideoFrame.from_ndarray(np.concatenate([luma, chroma]), format="yuv420p"), k / fps)
    return path


def _draw_patch(luma, background, gain, cx, cy, radius, texture, patch_x, patch_y) -> None:
    """Draw the target (``data_fixtures.video``'s disc) into ``luma`` around (cx, cy), in floating point on its patch
    only.
    """
    h, w = luma.shape
    x0, y0 = int(np.floor(cx - radius - 2)), int(np.floor(cy - radius - 2))
    x1, y1 = x0 + patch_x.shape[1], y0 + patch_x.shape[0]
    cx0, cy0, cx1, cy1 = max(0, x0), max(0, y0), min(w, x1), min(h, y1)
    if cx0 >= cx1 or cy0 >= cy1:
        return
    patch = background[cy0:cy1, cx0:cx1] * np.float32(gain)
    rows, cols = cy1 - cy0, cx1 - cx0
    _draw_target(patch, patch_x[:rows, :cols], patch_y[:rows, :cols], cx - cx0, cy - cy0, radius, texture)
    luma[cy0:cy1, cx0:cx1] = np.clip(np.rint(patch), 0, 255).astype(np.uint8)


def render_long_camera_video(
    camera, positions, fps: float, path: str | Path, seed: int = 0, radius: float | None = None, look_alikes: int = 0
) -> Path:
    """``render_long_video`` with a camera's image size and per-frame positions (None: not drawn).

    radius: the target's radius in pixels (default: 1/160 of the image width,
    12 px at 1080p). look_alikes: how many discs like the target wander the
    image at the target's median speed (``wandering_paths``).
    """
    rows = np.asarray([(np.nan, np.nan) if p is None else tuple(p) for p in positions], dtype=np.float64).reshape(-1, 2)
    w, _ = camera.image_size
    steps = np.hypot(*np.diff(rows, axis=0).T)
    speed = float(np.median(steps[np.isfinite(steps)])) if np.isfinite(steps).any() else w / 400
    others = wandering_paths(
        np.random.default_rng(seed + 7919), len(rows), tuple(camera.image_size), speed, look_alikes
    )
    return render_long_video(
        path, rows, tuple(camera.image_size), fps, radius=radius or w / 160, seed=seed, look_alikes=others
    )


def wandering_paths(
    rng: np.random.Generator, n_frames: int, image_size: tuple[int, int], speed: float, count: int
) -> np.ndarray:
    """(count, n_frames, 2) centres (pixels) of walkers wandering the image at ``speed`` pixels a frame.

    Each starts at a random point with a random heading that turns smoothly
    (a correlated random turn rate, about 1 rad a second at 30 fps) and is
    mirrored at a margin of 5 % of the image, so walkers stay in view and
    cross each other and the target.
    """
    w, h = image_size
    low, high = np.array([0.05 * w, 0.05 * h]), np.array([0.95 * w, 0.95 * h])
    out = np.empty((count, n_frames, 2))
    for j in range(count):
        point = rng.uniform(low, high)
        heading = rng.uniform(0.0, 2.0 * np.pi)
        turn = 0.0
        for k in range(n_frames):
            out[j, k] = point
            turn = 0.95 * turn + rng.normal(0.0, 0.01)
            heading += turn
            step = speed * np.array([np.cos(heading), np.sin(heading)])
            if not low[0] <= point[0] + step[0] <= high[0]:
                heading = np.pi - heading
            if not low[1] <= point[1] + step[1] <= high[1]:
                heading = -heading
            point = np.clip(point + speed * np.array([np.cos(heading), np.sin(heading)]), low, high)
    return out
