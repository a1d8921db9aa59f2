"""The track stage: each camera's video in, its movers or its target's track out (work folder).

With the blob kind every mover is detected: ``detections.csv`` (the
identify stage then picks the target among them, the init box if any
seeding the identity, and writes ``track.csv``). With CSRT the one target
is tracked from its init box: ``track.csv``. ``track_camera`` is the pure part; ``write_track_atomic`` and
``write_detections_atomic`` the writers (also used by ``tlsync track-video``).
"""

from __future__ import annotations

import dataclasses
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

from tlsync_pipeline.artefacts.scan import ScanPlan, read_scan
from tlsync_pipeline.artefacts.video_info import VideoInfo, write_video_info
from tlsync_pipeline.atomic import atomic_path
from tlsync_pipeline.pipeline.spec import Options, Sources, StageResult, StageSpec
from tlsync_pipeline.pipeline.stages.camera_plan import scans
from tlsync_pipeline.pipeline.workspace import Artefact, StageFiles
from trackers.background import Background, read_background
from trackers.breaks import Break, PictureMeter, container_breaks
from trackers.detections import Detections, write_detections
from trackers.track import Track, write_track
from trackers.tracking import detect_movers, track_video
from trackers.video import DecodeCount, TruncatedVideoWarning, keyframe_indices, presentation_times, probe_video

if TYPE_CHECKING:
    from tlsync_pipeline.pipeline.project import Project, TrackerConfig


def track_camera(
    name: str,
    video: Path,
    tracker: TrackerConfig,
    progress: bool = True,
    plan: ScanPlan | None = None,
    count: DecodeCount | None = None,
    meter: PictureMeter | None = None,
    background: Background | None = None,
) -> Track | Detections:
    """Every mover (``tracker.every_mover``) or the target (CSRT from its init box) in one camera's video.

    plan: the scan stage's scan.json for every mover (None, or mode
    "full": every frame); count: filled with the frames decoded; meter:
    fed the frames read (trackers/breaks.py); background: the scan stage's
    model of the video for every mover (None: sampled here).
    """
    label = f"{name} ({video.name})"
    if tracker.every_mover:
        windows = None if plan is None or plan.full else list(plan.read_windows)
        return detect_movers(
            video,
            params=dict(tracker.parameters),
            progress=progress,
            label=label,
            windows=windows,
            count=count,
            meter=meter,
            background=background,
        )
    return track_video(
        video,
        kind=tracker.kind,
        init=tracker.init,
        init_frame=tracker.init_frame,
        params=dict(tracker.parameters),
        progress=progress,
        label=label,
        meter=meter,
    )


def write_track_atomic(track: Track, path: Path) -> None:
    """Write track.csv so that an interrupted run never leaves a half file in its place."""
    with atomic_path(path) as tmp:
        write_track(track, tmp)


def write_detections_atomic(detections: Detections, path: Path) -> None:
    """Write detections.csv atomically."""
    with atomic_path(path) as tmp:
        write_detections(detections, tmp)


def run_track(files: StageFiles, tracker: TrackerConfig) -> StageResult:
    """The track stage: ``detections.csv`` (every mover) or ``track.csv`` (one target) of one camera's video, and what
    the video holds, ``video.json``.

    A truncated video still gives a track (of the frames it holds); its
    warning is the stage's, and video.json says how many frames exist.
    """
    video = files.path("video")
    plan = read_scan(files.path("scan")) if files.has("scan") else None
    background = read_background(files.path("background")) if files.has("background") else None
    count = DecodeCount()
    meter = PictureMeter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", TruncatedVideoWarning)
        result = track_camera(
            files.camera_name,
            video,
            tracker,
            progress=files.progress,
            plan=plan,
            count=count,
            meter=meter,
            background=background,
        )
    truncation = next((w.message for w in caught if isinstance(w.message, TruncatedVideoWarning)), None)
    for item in caught:
        warnings.warn_explicit(item.message, item.category, item.filename, item.lineno)
    recorded = tuple(sorted({str(w.message) for w in caught if issubclass(w.category, TruncatedVideoWarning)}))
    info = video_info(video, truncation)
    read = reading(plan, count, info.frames, isinstance(result, Detections))
    with files.write("video_info") as tmp:
        write_video_info(dataclasses.replace(info, **read, breaks=tuple(video_breaks(video, meter))), tmp)
    if isinstance(result, Detections):
        write_detections_atomic(result, files.output("detections"))
        facts = {"detections": len(result), "tracklets": int(len(result.tracklet_ids())), **read}
        return StageResult(
            f"wrote {files.output('detections')} ({len(result)} detections; {read_summary(read, info.frames)})",
            recorded,
            facts=facts,
        )
    write_track_atomic(result, files.output("track"))
    return StageResult(
        f"wrote {files.output('track')} ({len(result)} tracked frames)", recorded, facts={"tracked_frames": len(result)}
    )


def video_breaks(video: Path, meter: PictureMeter) -> list[Break]:
    """Where the video leaves its steady clock: gaps and repeats of the container's presentation times (every frame,
    demux only), frozen runs and cuts among the frames the tracker read, in frame order (trackers/breaks.py)."""
    times = presentation_times(video)
    keys = keyframe_indices(video)
    found = (container_breaks(times) if times is not None else []) + meter.breaks(() if keys is None else keys)
    return sorted(found, key=lambda b: b.frame)


def reading(plan: ScanPlan | None, count: DecodeCount, frames: int, every_mover: bool) -> dict:
    """How the video was read, for video.json: "scan" ("windows" or "full"), why every frame ("scan_reason"), frames
    decoded by the coarse pass ("keyframes_decoded") and by this stage ("frames_decoded")."""
    if plan is None:
        why = '[track] scan = "full"' if every_mover else "one target followed from frame to frame"
        return {"scan": "full", "scan_reason": why, "keyframes_decoded": 0, "frames_decoded": count.decoded or frames}
    return {
        "scan": plan.mode,
        "scan_reason": plan.reason,
        "keyframes_decoded": plan.keyframes_read,
        "frames_decoded": count.decoded,
    }


def read_summary(read: dict, frames: int) -> str:
    """Frames decoded against frames skipped, and why every frame when so."""
    if read["scan"] == "full":
        return f"every frame decoded: {read['scan_reason']}"
    skipped = max(0, frames - read["frames_decoded"])
    return (
        f"{read['frames_decoded']} of {frames} frames decoded, {skipped} skipped, after "
        f"{read['keyframes_decoded']} keyframes"
    )


def video_info(video: Path, truncation: TruncatedVideoWarning | None) -> VideoInfo:
    """What a camera's video holds: its frames (0-based indices 0..frames-1 exist), the container's count, whether it is
    truncated.
    """
    announced = probe_video(video).n_frames
    frames = truncation.frames_read if truncation is not None else announced
    return VideoInfo(str(video), frames, announced, truncation is not None)


def tracking_params(project: Project, cam: str, options: Options) -> TrackerConfig:
    """What the track stage's work depends on: the tracker table, without the init box for every mover (it seeds
    identify, not detection).
    """
    tracker = project.camera(cam).tracker
    return dataclasses.replace(tracker, init=None, init_frame=0) if tracker.every_mover else tracker


def track_inputs(src: Sources, cam: str) -> dict[str, Path | Artefact]:
    """The camera's video, and the scan stage's windows and background model when it has them."""
    video = src.project.camera(cam).video
    assert video is not None, "the stage applies to a camera with a video"
    inputs: dict[str, Path | Artefact] = {"video": video}
    if scans(src.project, cam):
        inputs["scan"] = src.artefact("scan", cam)
        inputs["background"] = src.artefact("background", cam)
    return inputs


SPEC = StageSpec(
    "track",
    inputs=track_inputs,
    params=tracking_params,
    outputs=(
        "track",
        "detections",
        "video_info",
    ),  # track.csv or detections.csv (every mover: track.csv then comes from identify), and video.json
    run=run_track,
    per_camera=True,
    heavy=True,
    applies=lambda project, cam: project.camera(cam).tracked,
)
