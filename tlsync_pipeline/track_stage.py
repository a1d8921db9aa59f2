"""The track stage: each camera's video in, its track.csv out (work folder).

``track_camera`` is the pure part (a camera table in, a Track out);
``track_project`` writes ``<work>/cameras/<name>/track.csv`` atomically.
"""

from __future__ import annotations

from pathlib import Path

from tlsync_pipeline import layout
from tlsync_pipeline.atomic import atomic_path
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.project import Project
from trackers.track import Track, write_track
from trackers.tracking import track_video


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


def track_project(project: Project, work_dir: Path, camera: str | None = None, progress: bool = True) -> dict[str, Path]:
    """Track every camera that has a video (or only ``camera``); returns the track.csv written per camera.

    Cameras without a video that bring their own track are skipped; a camera
    with neither is an error.
    """
    specs = [project.camera(camera)] if camera is not None else project.cameras
    for spec in specs:
        if spec["video"] is None and (camera is not None or spec["track"] is None):
            raise InputError(f"{project.path}: camera {spec['name']!r}: no 'video' key: the track stage needs the camera's video file")
    written = {}
    for spec in specs:
        if spec["video"] is None:
            continue
        path = layout.track_csv(work_dir, spec["name"])
        write_track_atomic(track_camera(spec, progress=progress), path)
        written[spec["name"]] = path
    return written
