"""The export stage: frame_map.csv, offsets.csv and ffmpeg.sh from timeline.json."""

from __future__ import annotations

import csv
from pathlib import Path

from tlsync_pipeline.atomic import atomic_path
from tlsync_pipeline.outputs.exports import ffmpeg_commands, frame_map_rows, offsets
from tlsync_pipeline.pipeline import layout
from tlsync_pipeline.sync.timeline import read_timeline
from trackers.track import read_track
from trackers.video import probe_video


def frame_count(camera: dict) -> int:
    """Frames of a camera's video (from the container), or its last tracked frame + 1 without a video."""
    if camera.get("video"):
        count = probe_video(camera["video"]).n_frames
        if count > 0:
            return count
    track = read_track(camera["track"])
    return int(track.frame.max()) + 1


def run_export(cameras: dict[str, dict], timeline: Path, work: Path) -> dict:
    """The export stage: frame_map.csv, offsets.csv and ffmpeg.sh from timeline.json (of its synchronized cameras only)."""
    tl = read_timeline(timeline)
    if not tl.cameras:
        # No camera synchronized: exports of an earlier timeline would look current.
        for path in (layout.frame_map_csv(work), layout.offsets_csv(work), layout.ffmpeg_script(work)):
            path.unlink(missing_ok=True)
        return {"exported": [], "message": "no camera synchronized: no exports (earlier ones removed)"}
    n_frames = {name: frame_count(cameras[name]) for name in tl.names}
    with atomic_path(layout.frame_map_csv(work)) as tmp:
        with tmp.open("w", newline="", encoding="utf-8") as handle:
            csv.writer(handle).writerows(frame_map_rows(tl, n_frames))
    fps = {name: tl.cameras[name].fps for name in tl.names}
    rows = offsets(tl, fps)
    with atomic_path(layout.offsets_csv(work)) as tmp:
        with tmp.open("w", newline="", encoding="utf-8") as handle:
            writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows({k: ("" if v is None else (f"{v:.6f}" if isinstance(v, float) else v)) for k, v in r.items()} for r in rows)
    videos = {name: (str(c["video"]) if c.get("video") else None) for name, c in cameras.items()}
    with atomic_path(layout.ffmpeg_script(work)) as tmp:
        tmp.write_text(ffmpeg_commands(rows, videos), encoding="utf-8")
    return {"exported": tl.names, "n_frames": n_frames}
