"""Checks of the files a project brings against each other, before any stage runs.

A track the user brings for a camera that also has a video must fit in that
video: a frame past its last one means the track belongs to another video (or
to another numbering), and would otherwise go through sync and export and
fail only when render decodes it.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

from tlsync_pipeline.errors import InputError
from trackers.track import read_track
from trackers.video import VideoInfo, probe_video

ESTIMATE_SLACK = 0.02  # a frame count estimated from the duration may be off by this fraction


def check_track_fits_video(track_path: Path, video: Path | VideoInfo) -> None:
    """InputError naming the track's file, line and frame, and the video's frame count, when a tracked frame is past the
    video's end.

    Frames are 0-based. A count the container only estimates (from its
    duration) is given ESTIMATE_SLACK; an unknown count is not checked.
    """
    track = read_track(track_path)
    info = video if isinstance(video, VideoInfo) else probe_video(video)
    video_path = info.path
    if info.n_frames <= 0:
        return
    limit = info.n_frames if info.counted else math.ceil(info.n_frames * (1 + ESTIMATE_SLACK)) + 1
    if int(track.frame.max()) < limit:
        return
    where, frame = _first_row_at_or_after(track_path, limit)
    counted = "" if info.counted else " (estimated from its duration)"
    raise InputError(
        f"{where}: frame {frame} is past the end of the camera's video {video_path}, which has {info.n_frames} "
        f"frames{counted} "
        f"(0-based: the last is {info.n_frames - 1}); is this the track of another video?"
    )


def _first_row_at_or_after(track_path: Path, limit: int) -> tuple[str, int]:
    """("FILE:LINE", frame) of the first row of the track file (already read by read_track) whose frame is >= limit."""
    with open(track_path, newline="", encoding="utf-8-sig") as handle:
        rows = csv.reader(handle)
        column = [h.strip() for h in next(rows)].index("frame")
        frames = ((rows.line_num, float(row[column])) for row in rows if row)
        line, frame = next((line, frame) for line, frame in frames if frame >= limit)
    return f"{track_path}:{line}", int(frame)
