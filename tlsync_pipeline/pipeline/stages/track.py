"""The track stage: each camera's video in, its track.csv out (work folder).

``track_camera`` is the pure part (a camera table in, a Track out);
``write_track_atomic`` the writer. The stage graph (stages.py) runs them per
camera into ``<work>/cameras/<name>/track.csv``.
"""

from __future__ import annotations

import warnings
from pathlib import Path

from tlsync_pipeline.atomic import atomic_path
from tlsync_pipeline.errors import InputError
from trackers.track import Track, write_track
from trackers.tracking import track_video
from trackers.video import TruncatedVideoWarning


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


def run_track(spec: dict, out: Path, progress: bool = True) -> dict:
    """The track stage: the target's track in one camera's video, ``track.csv``.

    Warnings raised while reading the video (a truncated file) are recorded in
    the summary's ``warnings`` (the manifest keeps them for the report).
    """
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", TruncatedVideoWarning)
        track = track_camera(spec, progress=progress)
    for warning in caught:  # still shown where they were before
        warnings.warn_explicit(warning.message, warning.category, warning.filename, warning.lineno)
    write_track_atomic(track, out)
    recorded = sorted({str(w.message) for w in caught if issubclass(w.category, TruncatedVideoWarning)})
    return {"tracked_frames": len(track), "warnings": recorded, "message": f"wrote {out} ({len(track)} tracked frames)"}
