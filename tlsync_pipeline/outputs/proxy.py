"""Small H.264 proxy clips for the report's player, where a browser cannot play the camera's own file.

Browsers play H.264, VP8, VP9 and AV1 in MP4/MOV/WebM files; anything else
(MPEG-4 part 2, HEVC without hardware support, MJPEG, AVI or MKV
containers...) gets a proxy: every frame, upright, scaled to PROXY_HEIGHT
pixels high, H.264 (yuv420p, a keyframe every second for quick seeking), with
each frame's presentation time kept, so frame indices and times are those of
the original and the frame map applies unchanged.

The policy per camera: "auto" (a proxy only when needed), "always", "never".

A video the track stage read in windows (a long recording, sync/identify/scan.py)
gets a proxy of those windows only, each gap marked by one grey card at
its first frame's time (the player then shows the card there): a proxy of
every frame would cost about three decodes of the whole recording, where
the rest of the run decoded a tenth of it.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from fractions import Fraction
from pathlib import Path

import numpy as np

from tlsync_pipeline.outputs.choices import PROXY_POLICIES
from trackers.video import iter_frames, iter_windows, merge_windows, presentation_times, probe_video

PROXY_HEIGHT = 360
BROWSER_CODECS = frozenset({"h264", "vp8", "vp9", "av1"})
BROWSER_CONTAINERS = frozenset({".mp4", ".m4v", ".mov", ".webm"})
_TIME_BASE = Fraction(1, 90000)


def browser_plays(codec: str, suffix: str) -> bool:
    """Whether common browsers play this codec in this container (by file suffix)."""
    return codec.lower() in BROWSER_CODECS and suffix.lower() in BROWSER_CONTAINERS


def needs_proxy(codec: str, suffix: str, policy: str = "auto") -> bool:
    """Whether to make a proxy under ``policy`` (auto: only when the browser cannot play the file)."""
    if policy not in PROXY_POLICIES:
        raise ValueError(f"proxy policy {policy!r}: expected one of {', '.join(PROXY_POLICIES)}")
    return policy == "always" or (policy == "auto" and not browser_plays(codec, suffix))


def proxy_size(width: int, height: int, target_height: int = PROXY_HEIGHT) -> tuple[int, int]:
    """Even width and height at most ``target_height`` high, keeping the aspect ratio."""
    scale = min(1.0, target_height / height)
    return max(2, round(width * scale / 2) * 2), max(2, round(height * scale / 2) * 2)


def make_proxy(
    source: Path, destination: Path, target_height: int = PROXY_HEIGHT, windows: Sequence[tuple[int, int]] | None = None
) -> Path:
    """Transcode ``source`` into an H.264 MP4 at ``destination`` (the caller makes the write atomic).

    windows: only the frames inside these [start, stop) windows (0-based),
    and a card at the first frame of each gap; None: every frame.
    """
    import av

    info = probe_video(source)
    width, height = proxy_size(info.width, info.height, target_height)
    rate = Fraction(info.fps).limit_denominator(1001) if info.fps else Fraction(30)
    with av.open(str(destination), mode="w", format="mp4") as output:
        stream = output.add_stream("libx264", rate=rate)
        stream.width, stream.height, stream.pix_fmt = width, height, "yuv420p"
        stream.time_base = _TIME_BASE
        stream.codec_context.time_base = _TIME_BASE
        stream.options = {"crf": "28", "preset": "veryfast", "g": str(max(1, round(float(rate))))}
        last_pts = None
        for time_s, image in _proxy_frames(source, windows, (width, height)):
            out = av.VideoFrame.from_ndarray(image, format="bgr24")
            pts = round(time_s / _TIME_BASE)
            out.pts = pts if last_pts is None or pts > last_pts else last_pts + 1
            out.time_base = _TIME_BASE
            last_pts = out.pts
            for packet in stream.encode(out):
                output.mux(packet)
        for packet in stream.encode():
            output.mux(packet)
    return destination


def _proxy_frames(
    source: Path, windows: Sequence[tuple[int, int]] | None, size: tuple[int, int]
) -> Iterator[tuple[float, np.ndarray]]:
    """(presentation time s, image at ``size``) of every frame, or of the windows' frames with a card at each gap's
    first frame.
    """
    import cv2

    times = None if windows is None else presentation_times(source)
    if windows is None or times is None:  # no timestamps: no windows to read either
        for frame in iter_frames(source):
            yield frame.time_s, cv2.resize(frame.image, size, interpolation=cv2.INTER_AREA)
        return
    n = len(times)
    windows = merge_windows(windows)
    gaps = [(a, b) for a, b in zip([0] + [w[1] for w in windows], [w[0] for w in windows] + [n]) if b > a]
    card = _card(size)
    frames = iter_windows(source, windows)
    pending = next(frames, None)
    for start, _ in gaps + [(n, n)]:
        while pending is not None and pending.index < start:
            yield pending.time_s, cv2.resize(pending.image, size, interpolation=cv2.INTER_AREA)
            pending = next(frames, None)
        if start < n:
            yield float(times[start]), card


def _card(size: tuple[int, int]) -> np.ndarray:
    """A grey frame saying that the frames up to the next picture were not decoded (the target is not in view there)."""
    import cv2

    width, height = size
    image = np.full((height, width, 3), 96, np.uint8)
    scale = max(0.35, width / 1200)
    for k, line in enumerate(("not in this proxy:", "the target is not in view here")):
        cv2.putText(
            image,
            line,
            (max(4, width // 20), height // 2 + int((k - 0.5) * 40 * scale)),
            cv2.FONT_HERSHEY_SIMPLEX,
            scale,
            (230, 230, 230),
            1,
            cv2.LINE_AA,
        )
    return image
