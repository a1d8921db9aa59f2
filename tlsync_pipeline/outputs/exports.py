"""Exports for other tools: a frame map CSV, offsets in seconds, ffmpeg commands.

- frame_map.csv: one row per frame of every camera: the camera, its frame,
  the target sample t_r it shows, that sample's time (s, when the target's
  clock is known) and the matching frame of every other camera (empty when
  that camera was not recording then, or when the frame lies in a segment of
  unknown offset of a recording that breaks: sync/identify/segments.py). Matching frames are real numbers (the
  relation is continuous); round them for a frame index. They go through
  each camera's clock (Timeline.match): exact for variable-frame-rate
  cameras too, through their videos' presentation times.
- offsets.csv: per camera, when its frame 0 was taken relative to the
  reference camera's frame 0 (frames of the reference and seconds), its
  frame rate, and its clock rate against the reference.
- ffmpeg.sh: commands that trim every video so that all start at the same
  instant, and the -itsoffset alternative that keeps the files.
"""

from __future__ import annotations

import shlex

import numpy as np

from tlsync_pipeline.sync.model.clock import FrameTimes
from tlsync_pipeline.sync.timeline import Timeline


def frame_map_rows(timeline: Timeline, n_frames: dict[str, int], times: dict[str, FrameTimes | None] | None = None):
    """Rows of the frame map (header first), for the synchronized cameras.

    times: presentation times of variable-frame-rate cameras (by name), with
    which the matches are exact (Timeline.match).
    """
    times = times or {}
    names = timeline.names
    yield ["camera", "frame", "sample", "target_time_s"] + [f"frame_{n}" for n in names]
    for name in names:
        line = timeline.cameras[name]
        frames = np.arange(n_frames[name], dtype=np.float64)
        sample = line.sample_at(frames, times.get(name))
        seconds = None if timeline.target_rate is None else (timeline.target_t0 or 0.0) + sample / timeline.target_rate
        others = {}
        for other in names:
            if other != name:
                matched = timeline.match(name, other, frames, times)
                inside = (matched > -0.5) & (matched < n_frames[other] - 0.5)
                others[other] = np.where(inside, matched, np.nan)
        for i in range(len(frames)):
            known = bool(
                np.isfinite(sample[i])
            )  # a frame in a segment of unknown offset (sync/identify/segments.py) maps to nothing
            row = [
                name,
                str(i),
                f"{sample[i]:.3f}" if known else "",
                "" if seconds is None or not known else f"{seconds[i]:.6f}",
            ]
            for other in names:
                if other == name:
                    row.append(str(i))
                else:
                    value = others[other][i]
                    row.append("" if np.isnan(value) else f"{value:.3f}")
            yield row


def offsets(timeline: Timeline, times: dict[str, FrameTimes | None] | None = None) -> list[dict]:
    """Per camera: start relative to the reference (frames of the reference, seconds), fps, clock rate.

    start_frames: the reference's (fractional) frame taken with the camera's
    frame 0 (Timeline.match, exact with ``times``; ``start_frames``); start_s: seconds from the
    reference's frame 0 to then, on the reference's clock. clock_rate:
    seconds elapsed on this camera's nominal clock per second of the
    reference's (1 when both run at their nominal rates).
    """
    times = times or {}
    ref = timeline.names[0]
    ref_line = timeline.cameras[ref]
    rows = []
    for name in timeline.names:
        line = timeline.cameras[name]
        frames = start_frames(timeline, name, 0.0, times)
        seconds = None if ref_line.clock.fps is None else reference_seconds(timeline, frames, times)
        rel = timeline.clock_relation(ref, name)
        rate = rel.alpha * ref_line.fps / line.fps if ref_line.fps and line.fps else None
        rows.append(
            {
                "camera": name,
                "reference": ref,
                "start_frames": frames,
                "start_s": seconds,
                "fps": line.fps,
                "clock_rate": rate,
            }
        )
    return rows


def start_frames(timeline: Timeline, name: str, frame: float, times: dict[str, FrameTimes | None]) -> float:
    """The reference camera's (fractional) frame taken with camera ``name``'s ``frame``.

    Frame 0 of a recording that breaks (sync/identify/segments.py) may lie in a
    segment of unknown offset: its start is then the one of the line's
    segment, as if it reached back to frame 0 (what `pairs` say).
    """
    ref = timeline.names[0]
    found = float(timeline.match(name, ref, np.array([frame]), times)[0])
    line_segment = next((seg for seg in timeline.cameras[name].clock.segments if seg.source == "line"), None)
    if np.isfinite(found) or line_segment is None:
        return found
    first = float(max(line_segment.start, 0))
    return (
        float(timeline.match(name, ref, np.array([first]), times)[0])
        - (first - frame) * timeline.clock_relation(name, ref).alpha
    )


def reference_seconds(timeline: Timeline, frames: float, times: dict[str, FrameTimes | None]) -> float:
    """Seconds after the reference camera's frame 0 at its (fractional) frame ``frames`` (its fps known)."""
    ref = timeline.names[0]
    clock = timeline.cameras[ref].clock
    return float(clock.seconds_at(clock.clock_at(frames, times.get(ref)), times.get(ref)))


def synced_video(camera: str) -> str:
    """The file ffmpeg.sh writes a camera's trimmed video to, beside the work folder."""
    return f"{camera}_synced.mp4"


def ffmpeg_commands(rows: list[dict], videos: dict[str, str | None]) -> str:
    """A shell script (kept at <work>/exports/) trimming every video to the common start (the latest camera's frame 0).

    videos: camera -> its video's path relative to the folder that holds the
    work folder, where the script runs (it changes to it), so that the
    script still works when the project is moved or copied with its work
    folder. Each camera's trimmed video goes to its own file, named after
    the camera (synced_video), in that folder.
    """
    lines = [
        "#!/bin/sh",
        "# Made by tlsync from timeline.json. Times are seconds on each camera's own clock.",
        "set -e",
        'cd "$(dirname "$0")/../.."  # the folder that holds the work folder: the outputs go there',
    ]
    timed = [r for r in rows if r["start_s"] is not None]
    if not timed:
        lines.append(
            "# The reference camera's frame rate is unknown: offsets in seconds cannot be given (see offsets.csv)."
        )
        return "\n".join(lines) + "\n"
    latest = max(r["start_s"] for r in timed)
    earliest = min(r["start_s"] for r in timed)
    lines.append(
        f"# 1) Trim: every output starts at the latest start ({latest:+.3f} s after {rows[0]['reference']}'s frame 0)."
    )
    for r in timed:
        video = videos.get(r["camera"]) or f"{r['camera']}.mp4"
        out = synced_video(r["camera"])
        lines.append(
            f"ffmpeg -y -ss {latest - r['start_s']:.3f} -i {shlex.quote(str(video))} -c:v libx264 -crf 18 -an "
            f"{shlex.quote(out)}"
        )
    lines.append("# 2) Or keep the files and delay each input when combining them (-itsoffset before its -i):")
    inputs = " ".join(
        f"-itsoffset {r['start_s'] - earliest:.3f} -i "
        f"{shlex.quote(str(videos.get(r['camera']) or r['camera'] + '.mp4'))}"
        for r in timed
    )
    lines.append(f"# ffmpeg {inputs} -filter_complex hstack=inputs={len(timed)} combined_synced.mp4")
    return "\n".join(lines) + "\n"
