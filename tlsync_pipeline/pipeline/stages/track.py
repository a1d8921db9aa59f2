"""The track stage: each camera's video in, its movers or its target's track out (work folder).

Without an init box, the blob tracker's kind detects every mover (the
target is identified among them by the sync stage): ``detections.csv``.
With an init box, or with CSRT, the single target is tracked: ``track.csv``.
"""

from __future__ import annotations

from pathlib import Path

from tlsync_pipeline.atomic import atomic_path
from tlsync_pipeline.errors import InputError
from trackers.detections import Detections, write_detections
from trackers.track import Track, write_track
from trackers.tracking import detect_movers, follows_every_mover, track_video


def tracks_every_mover(spec: dict) -> bool:
    """Whether the camera's track stage detects every mover (blob tracker, no init box) rather than one target."""
    tracker = spec.get("tracker") or {}
    return follows_every_mover(tracker.get("kind", "blob"), tracker.get("init"), tracker.get("init_frame", 0))


def track_camera(spec: dict, progress: bool = True) -> Track | Detections:
    """Every mover (``tracks_every_mover``) or the target in the video of one camera table (``[[cameras]]`` with its ``[cameras.tracker]``)."""
    if spec.get("video") is None:
        raise InputError(f"camera {spec['name']!r}: no 'video' key: the track stage needs the camera's video file")
    tracker = spec["tracker"]
    label = f"{spec['name']} ({Path(spec['video']).name})"
    if tracks_every_mover(spec):
        return detect_movers(spec["video"], params=tracker["parameters"], progress=progress, label=label)
    return track_video(
        spec["video"],
        kind=tracker["kind"],
        init=tracker["init"],
        init_frame=tracker["init_frame"],
        params=tracker["parameters"],
        progress=progress,
        label=label,
    )


def write_track_atomic(track: Track, path: Path) -> None:
    """Write track.csv so that an interrupted run never leaves a half file in its place."""
    with atomic_path(path) as tmp:
        write_track(track, tmp)


def write_detections_atomic(detections: Detections, path: Path) -> None:
    """Write detections.csv atomically."""
    with atomic_path(path) as tmp:
        write_detections(detections, tmp)


def run_track(spec: dict, out: Path, progress: bool = True) -> dict:
    """The track stage: ``detections.csv`` (every mover) or ``track.csv`` (one target) at ``out``."""
    result = track_camera(spec, progress=progress)
    if isinstance(result, Detections):
        write_detections_atomic(result, out)
        return {"detections": len(result), "tracklets": int(len(result.tracklet_ids())), "message": f"wrote {out} ({len(result)} detections)"}
    write_track_atomic(result, out)
    return {"tracked_frames": len(result), "message": f"wrote {out} ({len(result)} tracked frames)"}
