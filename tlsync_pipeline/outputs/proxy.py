"""Small H.264 proxy clips for the report's player, where a browser cannot play the camera's own file.

Browsers play H.264, VP8, VP9 and AV1 in MP4/MOV/WebM files; anything else
(MPEG-4 part 2, HEVC without hardware support, MJPEG, AVI or MKV
containers...) gets a proxy: every frame, upright, scaled to PROXY_HEIGHT
pixels high, H.264 (yuv420p, a keyframe every second for quick seeking), with
each frame's presentation time kept, so frame indices and times are those of
the original and the frame map applies unchanged.

The policy per camera: "auto" (a proxy only when needed), "always", "never".
"""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import av
import cv2

from trackers.video import iter_frames, probe_video

PROXY_HEIGHT = 360
BROWSER_CODECS = frozenset({"h264", "vp8", "vp9", "av1"})
BROWSER_CONTAINERS = frozenset({".mp4", ".m4v", ".mov", ".webm"})
POLICIES = ("auto", "always", "never")
_TIME_BASE = Fraction(1, 90000)


def browser_plays(codec: str, suffix: str) -> bool:
    """Whether common browsers play this codec in this container (by file suffix)."""
    return codec.lower() in BROWSER_CODECS and suffix.lower() in BROWSER_CONTAINERS


def needs_proxy(codec: str, suffix: str, policy: str = "auto") -> bool:
    """Whether to make a proxy under ``policy`` (auto: only when the browser cannot play the file)."""
    if policy not in POLICIES:
        raise ValueError(f"proxy policy {policy!r}: expected one of {', '.join(POLICIES)}")
    return policy == "always" or (policy == "auto" and not browser_plays(codec, suffix))


def proxy_size(width: int, height: int, target_height: int = PROXY_HEIGHT) -> tuple[int, int]:
    """Even width and height at most ``target_height`` high, keeping the aspect ratio."""
    scale = min(1.0, target_height / height)
    return max(2, round(width * scale / 2) * 2), max(2, round(height * scale / 2) * 2)


def make_proxy(source: Path, destination: Path, target_height: int = PROXY_HEIGHT) -> Path:
    """Transcode ``source`` into an H.264 MP4 at ``destination`` (the caller makes the write atomic)."""
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
        for frame in iter_frames(source):
            image = cv2.resize(frame.image, (width, height), interpolation=cv2.INTER_AREA)
            out = av.VideoFrame.from_ndarray(image, format="bgr24")
            pts = round(frame.time_s / _TIME_BASE)
            out.pts = pts if last_pts is None or pts > last_pts else last_pts + 1
            out.time_base = _TIME_BASE
            last_pts = out.pts
            for packet in stream.encode(out):
                output.mux(packet)
        for packet in stream.encode():
            output.mux(packet)
    return destination
