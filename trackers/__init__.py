"""The target's 2D track: its type and file, video reading and trackers.

``track_video(path, kind="blob"|"csrt", init=None, init_frame=0, params=None,
progress=True)`` is the one entry point: a video file in, a Track out.
This package never imports ``tlsync_pipeline`` nor ``calibration``. Its
names are imported on first use (OpenCV and PyAV load only when a video is read).
"""

from __future__ import annotations

import importlib
from typing import Any

_WHERE = {
    "TrackInputError": "trackers.errors",
    "Track": "trackers.track",
    "read_track": "trackers.track",
    "write_track": "trackers.track",
    "track_video": "trackers.tracking",
    "iter_frames": "trackers.video",
    "probe_video": "trackers.video",
    "read_frames": "trackers.video",
}

__all__ = [
    "Track",
    "TrackInputError",
    "iter_frames",
    "probe_video",
    "read_frames",
    "read_track",
    "track_video",
    "write_track",
]


def __getattr__(name: str) -> Any:
    if name not in _WHERE:
        raise AttributeError(f"module 'trackers' has no attribute {name!r}")
    return getattr(importlib.import_module(_WHERE[name]), name)
