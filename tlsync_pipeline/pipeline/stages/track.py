"""The track stage: each camera's video in, its track.csv out (work folder).

``track_camera`` is the pure part (a camera table in, a Track out);
``write_track_atomic`` the writer (also used by ``tlsync track-video``).
"""

from __future__ import annotations

import warnings
from pathlib import Path

from tlsync_pipeline.atomic import atomic_path
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.pipeline.spec import StageSpec
from tlsync_pipeline.pipeline.workspace import StageFiles
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


def run_track(files: StageFiles, tracker: dict) -> dict:
    """The track stage: the target's track in one camera's video, ``track.csv``.

    Warnings raised while reading the video (a truncated file) are recorded in
    the summary's ``warnings`` (the manifest keeps them for the report).
    """
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", TruncatedVideoWarning)
        track = track_camera({"name": files.camera, "video": files.path("video"), "tracker": tracker}, progress=files.progress)
    for warning in caught:  # still shown where they were before
        warnings.warn_explicit(warning.message, warning.category, warning.filename, warning.lineno)
    write_track_atomic(track, files.output("track"))
    recorded = sorted({str(w.message) for w in caught if issubclass(w.category, TruncatedVideoWarning)})
    return {"tracked_frames": len(track), "warnings": recorded, "message": f"wrote {files.output('track')} ({len(track)} tracked frames)"}


def _applies(project, cam: str) -> bool:
    spec = project.camera(cam)
    return spec["track"] is None and spec.get("video") is not None


SPEC = StageSpec(
    "track",
    inputs=lambda src, cam: {"video": src.project.camera(cam)["video"]},
    params=lambda project, cam, options: {"tracker": project.camera(cam)["tracker"]},
    outputs=("track",),
    run=run_track,
    per_camera=True,
    applies=_applies,
)
