"""The export stage: frame_map.csv, offsets.csv, ffmpeg.sh and the editors' timelines from timeline.json.

Editors' timelines (timeline.otio, timeline.fcpxml when the OTIO FCPXML
adapter can write the cameras' rates, sync.json) need the reference camera's
frame rate.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from tlsync_pipeline.artefacts.exports import write_offsets, write_rows, write_text
from tlsync_pipeline.artefacts.jsonfile import write_document
from tlsync_pipeline.artefacts.video_info import read_video_info
from tlsync_pipeline.outputs.editors import Piece, Placement, fcpxml_text, otio_text, sync_document
from tlsync_pipeline.outputs.exports import ffmpeg_commands, frame_map_rows, offsets, reference_seconds, start_frames
from tlsync_pipeline.pipeline.spec import ProjectWide, Sources, StageResult, StageSpec
from tlsync_pipeline.pipeline.stages.cameras import CameraFiles, camera_files
from tlsync_pipeline.pipeline.workspace import Artefact, StageFiles
from tlsync_pipeline.sync.model.clock import FrameTimes
from tlsync_pipeline.sync.model.status import HALF_95
from tlsync_pipeline.sync.timeline import CameraLine, Timeline, read_timeline
from trackers.track import read_track
from trackers.video import presentation_times, probe_video

EXPORTS = (
    "frame_map",
    "offsets",
    "ffmpeg",
    "timeline_otio",
    "timeline_fcpxml",
    "sync_json",
)  # the stage's artefact kinds


def frame_count(camera: CameraFiles) -> int:
    """Frames of a camera's video: as decoded by the track stage (a truncated video holds fewer than announced),
    else from the container; without a video, its last tracked frame + 1."""
    if camera.video_info is not None:
        return read_video_info(camera.video_info).frames
    if camera.video is not None:
        count = probe_video(camera.video).n_frames
        if count > 0:
            return count
    assert camera.track is not None, "declared by the stage"
    track = read_track(camera.track)
    return int(track.frame.max()) + 1


def frame_times(camera: CameraFiles, line: CameraLine) -> FrameTimes | None:
    """Presentation times that make a camera's frame mapping exact.

    None for a frame-index clock (it needs none); for a presentation-time
    clock the video's own table of every frame, else (no video, or no
    timestamps) the tracked frames' times from track.csv.
    """
    if not line.clock.vfr:
        return None
    if camera.video is not None:
        times = presentation_times(camera.video)
        if times is not None:
            return FrameTimes(np.arange(len(times), dtype=np.float64), times)
    assert camera.track is not None, "declared by the stage"
    return FrameTimes.of_track(read_track(camera.track))


def run_export(files: StageFiles, params: ProjectWide) -> StageResult:
    """The export stage: frame_map.csv, offsets.csv, ffmpeg.sh, timeline.otio, timeline.fcpxml and sync.json
    (synchronized cameras only).

    Cameras left out (their own tasks did not complete) are not in the timeline either.
    An editor timeline it cannot write is said in its message (the report's
    exports section shows it), not as a warning: warnings are about the
    inputs and the timeline (timeline.json lists them).
    """
    cameras = camera_files(files, params)
    tl = read_timeline(files.path("timeline"))
    if not tl.cameras:
        # No camera synchronized: exports of an earlier timeline would look current.
        for kind in EXPORTS:
            files.output(kind).unlink(missing_ok=True)
        return StageResult("no camera synchronized: no exports (earlier ones removed)", facts={"exported": []})
    n_frames = {name: frame_count(cameras[name]) for name in tl.names}
    times = {name: frame_times(cameras[name], line) for name, line in tl.cameras.items()}
    with files.write("frame_map") as tmp:
        write_rows(frame_map_rows(tl, n_frames, times), tmp)
    rows = offsets(tl, times)
    with files.write("offsets") as tmp:
        write_offsets(rows, tmp)
    videos = {name: (str(c.video) if c.video is not None else None) for name, c in cameras.items()}
    base = files.output("ffmpeg").parent.parent.parent  # ffmpeg.sh runs in the folder that holds the work folder
    with files.write("ffmpeg") as tmp:
        write_text(
            ffmpeg_commands(
                rows, {name: None if v is None else os.path.relpath(v, base) for name, v in videos.items()}
            ),
            tmp,
        )
    notes = []
    placements = editor_placements(tl, rows, videos, n_frames, times)
    if placements is None:
        notes.append(f"no editor timelines: the reference camera {tl.names[0]} has no frame rate")
    else:
        with files.write("timeline_otio") as tmp:
            write_text(otio_text(placements), tmp)
        with files.write("sync_json") as tmp:
            write_document(sync_document(placements, tl.names[0]), tmp)
        fcpxml, why_not = fcpxml_text(placements)
        if fcpxml is None:
            notes.append(f"no timeline.fcpxml: {why_not}")
        else:
            with files.write("timeline_fcpxml") as tmp:
                write_text(fcpxml, tmp)
    return StageResult("; ".join(notes) or None, facts={"exported": tl.names, "n_frames": n_frames})


def editor_placements(
    tl: Timeline,
    rows: list[dict],
    videos: dict[str, str | None],
    n_frames: dict[str, int],
    times: dict[str, FrameTimes | None] | None = None,
) -> list[Placement] | None:
    """Each camera's placement on the editors' timeline from its offsets.csv row; None without every camera's fps."""
    times = times or {}
    if any(r["start_s"] is None or not r["fps"] for r in rows):
        return None
    reference = tl.names[0]
    placements = []
    for r in rows:
        name = r["camera"]
        se = tl.start_offset_se(reference, name) if name != reference else None
        half = None if se is None or se[1] is None else HALF_95 * se[1]
        vfr = tl.cameras[name].clock.vfr
        pieces = segment_pieces(tl, name, n_frames[name], times)
        placements.append(
            Placement(
                name,
                videos.get(name),
                r["start_s"],
                r["fps"],
                n_frames[name],
                n_frames[name] / r["fps"],
                r["clock_rate"],
                half,
                vfr,
                pieces,
            )
        )
    return placements


def segment_pieces(tl: Timeline, name: str, n_frames: int, times: dict[str, FrameTimes | None]) -> tuple[Piece, ...]:
    """The segments of known offset of a camera's recording that breaks, as editor clips (none for one segment)."""
    pieces = []
    for seg in tl.cameras[name].clock.segments:
        first, stop = max(seg.start, 0), min(seg.stop, n_frames)
        if seg.shift is not None and stop > first:
            pieces.append(
                Piece(first, stop - first, reference_seconds(tl, start_frames(tl, name, float(first), times), times))
            )
    return tuple(pieces)


def export_inputs(src: Sources, camera: None) -> dict[str, Path | Artefact]:
    """timeline.json, and every camera's track and video (frame counts; video.json when the track stage makes it)."""
    inputs = {"timeline": src.artefact("timeline")}
    for spec in src.project.cameras:
        inputs[f"track:{spec.name}"] = src.artefact("track", spec.name)
        if spec.video is not None:
            inputs[f"video:{spec.name}"] = spec.video
        if src.made("video_info", spec.name):
            inputs[f"video_info:{spec.name}"] = src.artefact("video_info", spec.name)
    return inputs


SPEC = StageSpec(
    "export",
    inputs=export_inputs,
    params=lambda project, camera, options: ProjectWide(tuple(project.names)),
    outputs=EXPORTS,
    run=run_export,
    runs_without_failed_cameras=True,
)
