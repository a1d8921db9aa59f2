"""Synthetic test videos (H.264 through PyAV) with the target's true image position per frame.

The scene: a textured background, a global lighting flicker, Gaussian sensor
noise and H.264 compression (libx264, yuv420p, B-frames, a keyframe every
``gop`` frames). The target is a bright textured disc drawn with anti-aliased
edges; its true position is the disc centre in pixels (origin at the centre
of the top-left pixel, the Track convention). By default it follows a loop
wider than the image, so it leaves and re-enters the view; a thin static pole
occludes it partly when it passes behind; a larger dark distractor crosses
the image; optionally a grey look-alike of the target's size wanders inside
the view from the first frame to the last. Presentation times may be
jittered (variable frame rate).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

import av
import cv2
import numpy as np

TIME_BASE = Fraction(1, 90000)


@dataclass(frozen=True)
class RenderedVideo:
    """A rendered video and its truth.

    truth: (N, 2) true target centre per frame (pixels; NaN where the
    scene has no target); times: (N,) presentation times (s) written to
    the container; in_view: (N,) the whole disc is inside the image;
    out_of_view: (N,) no part of the disc is inside the image.
    """

    path: Path
    truth: np.ndarray
    times: np.ndarray
    in_view: np.ndarray
    out_of_view: np.ndarray
    image_size: tuple[int, int]
    radius: float
    fps: float

    def entries(self) -> list[int]:
        """Frames where the whole disc comes back into view after having been fully out of it."""
        out = []
        was_out = False
        for k in range(len(self.truth)):
            if self.out_of_view[k]:
                was_out = True
            elif self.in_view[k] and was_out:
                out.append(k)
                was_out = False
        return out


def loop_positions(n_frames: int, image_size: tuple[int, int], period: float = 200.0, reach: float = 1.2) -> np.ndarray:
    """A figure-of-eight loop ``reach`` times wider than the image: the target leaves and re-enters."""
    w, h = image_size
    t = np.arange(n_frames, dtype=np.float64)
    phase = 2 * np.pi * t / period
    x = (w - 1) / 2 + reach * (w / 2) * np.sin(phase + 0.3)
    y = (h - 1) / 2 + 0.3 * h * np.sin(2 * phase + 0.3)
    return np.column_stack([x, y])


LOOKALIKE_GREY = 185.0  # the look-alike's grey: brighter than the background, like the target (225)


def lookalike_positions(n_frames: int, image_size: tuple[int, int], period: float = 170.0) -> np.ndarray:
    """A loop inside the view (never within 15 % of an edge) that crosses the target's ``loop_positions`` path."""
    w, h = image_size
    phase = 2 * np.pi * np.arange(n_frames, dtype=np.float64) / period
    return np.column_stack([(w - 1) / 2 + 0.35 * w * np.cos(phase), (h - 1) / 2 + 0.3 * h * np.sin(3 * phase + 1.0)])


def render_video(
    path: str | Path,
    n_frames: int = 300,
    image_size: tuple[int, int] = (320, 240),
    fps: float = 25.0,
    positions: np.ndarray | None = None,
    radius: float = 6.0,
    seed: int = 0,
    noise: float = 2.0,
    flicker: float = 0.06,
    occluder: bool = True,
    distractor: bool = True,
    lookalike: bool = False,
    jitter: float = 0.0,
    rotation: int = 0,
    crf: int = 20,
    gop: int = 30,
    times: np.ndarray | None = None,
) -> RenderedVideo:
    """Render the scene to ``path`` (MP4, moov at the front) and return the truth.

    positions: (n_frames, 2) target centres (NaN rows: no target), default
    ``loop_positions``; lookalike: a grey disc of the target's size moving
    inside the view in every frame (``lookalike_positions``); jitter: presentation-time jitter as a fraction of the
    frame interval (uniform, times stay increasing); rotation: a display
    rotation (counter-clockwise degrees, multiple of 90) written as metadata,
    the stored pixels being rotated the other way, so a reader honouring it
    sees the scene upright; times: the frames' presentation times (s,
    increasing; e.g. ``phone_times``) instead of fps with ``jitter``.
    """
    path = Path(path)
    rng = np.random.default_rng(seed)
    w, h = image_size
    if positions is None:
        positions = loop_positions(n_frames, image_size)
    positions = np.asarray(positions, dtype=np.float64).reshape(n_frames, 2)
    background = _background(rng, w, h)
    pole_x = int(w * 0.62) if occluder else None
    if pole_x is not None:
        background[:, pole_x - 1 : pole_x + 2] = 45.0
    texture = rng.uniform(-25, 25, size=(int(2 * radius + 8),) * 2)
    gains = (
        1.0 + flicker * np.sin(2 * np.pi * np.arange(n_frames) / 37.0) + flicker * 0.3 * rng.standard_normal(n_frames)
    )
    times = _times(rng, n_frames, fps, jitter) if times is None else np.asarray(times, dtype=np.float64)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    lookalike_at = lookalike_positions(n_frames, image_size)

    sw, sh = (h, w) if rotation % 180 else (w, h)
    with h264_writer(
        path, fps, (sw, sh), {"crf": str(crf), "preset": "veryfast", "g": str(gop), "keyint_min": str(gop)}, rotation
    ) as write:
        for k in range(n_frames):
            image = background.copy()
            if distractor:
                _draw_distractor(image, k, n_frames, w, h)
            if lookalike:
                _draw_target(
                    image, xx, yy, float(lookalike_at[k, 0]), float(lookalike_at[k, 1]), radius, texture, LOOKALIKE_GREY
                )
            cx, cy = positions[k]
            if np.isfinite(cx):
                _draw_target(image, xx, yy, cx, cy, radius, texture)
            if pole_x is not None:
                image[:, pole_x - 1 : pole_x + 2] = 45.0
            image = image * gains[k] + rng.normal(0.0, noise, image.shape)
            grey = np.clip(image, 0, 255).astype(np.uint8)
            bgr = cv2.merge([grey, np.clip(grey.astype(np.int16) + 6, 0, 255).astype(np.uint8), grey])
            if rotation:
                bgr = np.ascontiguousarray(np.rot90(bgr, k=-(rotation // 90)))
            write(av.VideoFrame.from_ndarray(bgr, format="bgr24"), times[k])
    margin_in = (
        (positions[:, 0] >= radius)
        & (positions[:, 0] <= w - 1 - radius)
        & (positions[:, 1] >= radius)
        & (positions[:, 1] <= h - 1 - radius)
    )
    margin_out = (
        (positions[:, 0] < -radius - 1)
        | (positions[:, 0] > w + radius)
        | (positions[:, 1] < -radius - 1)
        | (positions[:, 1] > h + radius)
    )
    absent = ~np.isfinite(positions[:, 0])
    exact_times = np.round(times / float(TIME_BASE)) * float(TIME_BASE)
    return RenderedVideo(path, positions, exact_times, margin_in & ~absent, margin_out | absent, (w, h), radius, fps)


@contextmanager
def h264_writer(
    path: str | Path, fps: float, size: tuple[int, int], options: dict[str, str], rotation: int = 0
) -> Iterator[Callable[[av.VideoFrame, float], None]]:
    """An H.264 MP4 (yuv420p, TIME_BASE) at ``path``: yields write(frame, time_s) (presentation time, s); flushes and
    closes on exit.

    size: (width, height) of the encoded frames, pixels; options: libx264's
    (crf, preset, g, ...); rotation: display rotation, degrees clockwise.
    """
    container = av.open(str(path), mode="w", options={"movflags": "+faststart"})
    try:
        stream = container.add_stream("libx264", rate=Fraction(fps).limit_denominator(1001))
        stream.width, stream.height = size
        stream.pix_fmt = "yuv420p"
        stream.codec_context.time_base = TIME_BASE
        stream.options = dict(options)
        if rotation:
            stream.set_display_rotation(rotation)

        def write(frame: av.VideoFrame, time_s: float) -> None:
            frame.pts = int(round(time_s / TIME_BASE))
            frame.time_base = TIME_BASE
            for packet in stream.encode(frame):
                container.mux(packet)

        yield write
        for packet in stream.encode():
            container.mux(packet)
    finally:
        container.close()


def tag_recording_time(path: str | Path, utc_s: float, zone_s: float = 7200.0) -> Path:
    """Give a video the recording time a phone writes: ``com.apple.quicktime.creationdate`` (local time with its
    zone, whole seconds, truncated) and ``creation_time`` (UTC, whole seconds); the packets are copied unchanged."""
    import datetime as dt
    import os

    path = Path(path)
    utc = dt.datetime.fromtimestamp(int(np.floor(utc_s)), dt.timezone.utc)
    local = utc.astimezone(dt.timezone(dt.timedelta(seconds=zone_s)))
    tags = {
        "com.apple.quicktime.creationdate": local.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "creation_time": utc.strftime("%Y-%m-%dT%H:%M:%S.000000Z"),
    }
    tmp = path.with_name(path.name + ".part")
    with (
        av.open(str(path)) as source,
        av.open(str(tmp), "w", format="mp4", options={"movflags": "use_metadata_tags+faststart"}) as out,
    ):
        out.metadata.update(tags)
        streams = {s.index: out.add_stream_from_template(s) for s in source.streams.video}
        for packet in source.demux(*source.streams.video):
            if packet.dts is None:
                continue
            packet.stream = streams[packet.stream.index]
            out.mux(packet)
    os.replace(tmp, path)
    return path


def render_camera_video(
    camera, positions, fps: float, path: str | Path, seed: int = 0, radius: float = 6.0
) -> RenderedVideo:
    """Render the target at given per-frame pixel positions (None/NaN: not drawn) in ``camera``'s image size.

    For the pipeline demo: ``positions`` are the projections of a
    ``data_fixtures.scene`` trajectory into ``camera`` (a calibration.Camera).
    """
    rows = [(np.nan, np.nan) if p is None else tuple(p) for p in positions]
    xy = np.asarray(rows, dtype=np.float64)
    return render_video(
        path,
        n_frames=len(xy),
        image_size=tuple(camera.image_size),
        fps=fps,
        positions=xy,
        seed=seed,
        radius=radius,
        occluder=False,
        distractor=False,
    )


def _background(rng: np.random.Generator, w: int, h: int) -> np.ndarray:
    """Smooth multi-scale texture with a few hard edges, grey levels about 60-170."""
    image = np.zeros((h, w), np.float32)
    for sigma, amplitude in ((24.0, 30.0), (6.0, 14.0), (1.5, 8.0)):
        layer = cv2.GaussianBlur(rng.standard_normal((h, w)).astype(np.float32), (0, 0), sigma)
        image += amplitude * layer / (layer.std() + 1e-9)
    image += 115.0
    for _ in range(6):
        x0, y0 = int(rng.integers(0, w)), int(rng.integers(0, h))
        cv2.rectangle(
            image,
            (x0, y0),
            (x0 + int(rng.integers(10, 50)), y0 + int(rng.integers(10, 40))),
            float(rng.uniform(70, 160)),
            -1,
        )
    return np.clip(image, 40, 190)


def _draw_target(image, xx, yy, cx, cy, radius, texture, grey: float = 225.0) -> None:
    """A bright disc (``grey``, ~225 for the target) with a weak texture, anti-aliased by pixel coverage."""
    x0, x1 = int(max(0, np.floor(cx - radius - 2))), int(min(image.shape[1], np.ceil(cx + radius + 3)))
    y0, y1 = int(max(0, np.floor(cy - radius - 2))), int(min(image.shape[0], np.ceil(cy + radius + 3)))
    if x0 >= x1 or y0 >= y1:
        return
    d = np.hypot(xx[y0:y1, x0:x1] - cx, yy[y0:y1, x0:x1] - cy)
    cover = np.clip(radius + 0.5 - d, 0.0, 1.0)
    tex = texture[: y1 - y0, : x1 - x0]
    patch = grey + tex * (d < radius * 0.7)
    image[y0:y1, x0:x1] = image[y0:y1, x0:x1] * (1 - cover) + patch * cover


def _draw_distractor(image, k: int, n_frames: int, w: int, h: int) -> None:
    """A dark rounded box, four times the target's area, crossing the image diagonally in the middle third."""
    start, stop = n_frames // 3, 2 * n_frames // 3
    if not start <= k < stop:
        return
    s = (k - start) / max(1, stop - start - 1)
    cx, cy = -30 + s * (w + 60), h * 0.8 - s * h * 0.5
    cv2.rectangle(image, (int(cx - 12), int(cy - 8)), (int(cx + 12), int(cy + 8)), 25.0, -1)


def phone_times(n_frames: int, fps: float, interval_jitter: float, start_s: float = 0.0, seed: int = 0) -> np.ndarray:
    """Presentation times (s) of a phone-like variable-frame-rate stream.

    Each frame interval is (1 + U(-interval_jitter, interval_jitter)) / fps,
    so the times drift from any constant rate; frame 0 is at start_s (streams
    need not start at 0).
    """
    rng = np.random.default_rng(seed)
    intervals = (1.0 + rng.uniform(-interval_jitter, interval_jitter, n_frames - 1)) / fps
    return start_s + np.r_[0.0, np.cumsum(intervals)]


def _times(rng: np.random.Generator, n_frames: int, fps: float, jitter: float) -> np.ndarray:
    times = np.arange(n_frames) / fps
    if jitter:
        times = times + rng.uniform(-jitter / 2, jitter / 2, n_frames) / fps
        times[0] = 0.0
    return times


def blank_video(path: str | Path, n_frames: int, image_size: tuple[int, int], fps: float = 30.0) -> Path:
    """A grey H.264 video of ``n_frames`` frames at ``fps`` (a container for projects that bring their tracks: fast to
    write).
    """
    path = Path(path)
    with av.open(str(path), "w") as container:
        stream = container.add_stream("libx264", rate=Fraction(fps).limit_denominator(1001))
        stream.width, stream.height = image_size
        stream.pix_fmt = "yuv420p"
        stream.options = {"preset": "ultrafast"}
        frame = av.VideoFrame.from_ndarray(np.full((image_size[1], image_size[0], 3), 128, np.uint8), format="rgb24")
        for _ in range(n_frames):
            container.mux(stream.encode(frame))
        container.mux(stream.encode())
    return path
