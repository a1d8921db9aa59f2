"""The track stage: each camera's video in, its track.csv out (work folder).

``track_camera`` is the pure part (a camera table in, a Track out);
``write_track_atomic`` the writer. The stage graph (stages.py) runs them per
camera into ``<work>/cameras/<name>/track.csv``.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

from tlsync_pipeline.atomic import atomic_path
from tlsync_pipeline.errors import InputError
from trackers.track import Track, write_track
from trackers.tracking import track_video
from trackers.video import TruncatedVideoWarning, probe_video

VIDEO_INFO_FORMAT = "tlsync-video"


def track_camera(spec: dict, progress: bool = True) -> Track:
    """Track the target in the video of one camera table (``[[cameras]]`` with its ``[cameras.tracker]``)."""
    if spec.get("video") is None:
        raise InputError(f"camera {spec['name']!r}: no 'video' key: the track stage needs the camera's video file")
    tracker = spec["tracker"]
    return track_video(
        spec["video"],
        kind=tracker["kind"],
        init=tracker["init"],
        init_frame=tracker["init_frame"],
        params=tracker["parameters"],
        progress=progress,
        label=f"{spec['name']} ({Path(spec['video']).name})",
    )


def write_track_atomic(track: Track, path: Path) -> None:
    """Write track.csv so that an interrupted run never leaves a half file in its place."""
    with atomic_path(path) as tmp:
        write_track(track, tmp)


def run_track(spec: dict, out: Path, info_out: Path, progress: bool = True) -> dict:
    """The track stage: the target's track in one camera's video, ``track.csv``, and what the video holds, ``video.json``.

    A truncated video still gives a track (of the frames it holds); its
    warning is the stage's, and video.json says how many frames exist.
    """
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", TruncatedVideoWarning)
        track = track_camera(spec, progress=progress)
    truncation = next((w.message for w in caught if isinstance(w.message, TruncatedVideoWarning)), None)
    for item in caught:
        warnings.warn_explicit(item.message, item.category, item.filename, item.lineno)
    write_track_atomic(track, out)
    write_video_info(video_info(spec["video"], truncation), info_out)
    return {"tracked_frames": len(track), "message": f"wrote {out} ({len(track)} tracked frames)"}


def video_info(video: Path, truncation: TruncatedVideoWarning | None) -> dict:
    """What a camera's video holds: its frames (0-based indices 0..frames-1 exist), the container's count, whether it is truncated."""
    announced = probe_video(video).n_frames
    frames = truncation.frames_read if truncation is not None else announced
    return {"format": VIDEO_INFO_FORMAT, "video": str(video), "frames": frames, "announced": announced, "truncated": truncation is not None}


def write_video_info(info: dict, path: Path) -> None:
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(info, indent=1) + "\n", encoding="utf-8")


def read_video_info(path: Path) -> dict:
    """video.json as the track stage wrote it."""
    return json.loads(Path(path).read_text(encoding="utf-8"))
