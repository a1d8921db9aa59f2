"""Recordings with breaks, made by editing a rendered video's decoded frames and encoding them again (PyAV).

Each edit says, for every frame of the edited video, which frame of the
steady original recording it shows (``source``: a fractional original frame;
NaN for a frozen repeat, which shows no new instant), and what the container
says its presentation time is. The truth of the edited camera is then its
original line through ``source``: edited frame f shows the instant of
original frame source[f].

Kinds (``BreakEdit``):
- ``frozen``: ``size`` copies of the frame before ``frame`` inserted there
  (a stall; the later frames come late), times re-stamped steadily;
- ``dropped``: ``size`` frames removed from ``frame`` on, times re-stamped
  steadily (no trace in the container);
- ``gap``: the same frames removed, their presentation times kept (the
  container shows the gap);
- ``repeat``: one frame repeated every ``every`` frames (a 29.97 source
  recorded at 30), times re-stamped;
- ``restart``: the frames before ``frame`` belong to an earlier recording
  ``size`` frames before (cut and restarted into one file), re-stamped
  steadily (``stamped``: with the container's times showing the cut).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import av
import numpy as np

from data_fixtures.video import h264_writer

EDITS = ("frozen", "dropped", "gap", "repeat", "restart")


@dataclass(frozen=True)
class BreakEdit:
    """One edit of a recording: kind (EDITS), 0-based frame where it happens, size in frames, every (``repeat``: a
    repeated frame after each ``every`` frames), stamped (``restart``: the container's times show the cut)."""

    kind: str
    frame: int = 0
    size: int = 0
    every: int = 0
    stamped: bool = False

    def label(self) -> str:
        if self.kind == "repeat":
            return f"repeat 1/{self.every}"
        return f"{self.kind} {self.size}" + (" stamped" if self.stamped else "")


def edited_source(edit: BreakEdit, n_frames: int) -> tuple[np.ndarray, np.ndarray]:
    """(picture, source) per edited frame: the original frame whose picture it shows, and the original (fractional)
    frame whose instant it shows (NaN: a frozen repeat). ``restart`` frames before the cut show the original pictures
    at instants ``size`` frames earlier."""
    index = np.arange(n_frames, dtype=np.float64)
    if edit.kind == "frozen":
        picture = np.concatenate([index[: edit.frame], np.full(edit.size, edit.frame - 1.0), index[edit.frame :]])
        source = np.concatenate([index[: edit.frame], np.full(edit.size, np.nan), index[edit.frame :]])
    elif edit.kind in ("dropped", "gap"):
        picture = np.concatenate([index[: edit.frame], index[edit.frame + edit.size :]])
        source = picture.copy()
    elif edit.kind == "repeat":
        parts, sources = [], []
        for start in range(0, n_frames, edit.every):
            chunk = index[start : start + edit.every]
            parts.append(chunk)
            sources.append(chunk)
            if start + edit.every < n_frames:
                parts.append(chunk[-1:])
                sources.append(np.array([np.nan]))
        picture, source = np.concatenate(parts), np.concatenate(sources)
    elif edit.kind == "restart":
        picture = index.copy()
        source = np.where(index < edit.frame, index - edit.size, index)
    else:
        raise ValueError(f"unknown edit {edit.kind!r}; expected one of {EDITS}")
    return picture.astype(np.int64), source


def edit_video(src: str | Path, dst: str | Path, edit: BreakEdit, fps: float) -> np.ndarray:
    """Write ``src`` edited by ``edit`` to ``dst`` (H.264, crf 20); returns the source of each edited frame
    (``edited_source``)."""
    with av.open(str(src)) as container:
        frames = [frame.to_ndarray(format="bgr24") for frame in container.decode(video=0)]
    picture, source = edited_source(edit, len(frames))
    times = np.arange(len(picture)) / fps
    if edit.kind == "gap":
        times = source / fps
    elif edit.kind == "restart" and edit.stamped:
        times = np.where(np.arange(len(picture)) < edit.frame, times, times + edit.size / fps)
    h, w = frames[0].shape[:2]
    options = {"crf": "20", "preset": "veryfast", "g": "30", "keyint_min": "30"}
    with h264_writer(dst, fps, (w, h), options) as write:
        for k, p in enumerate(picture):
            write(av.VideoFrame.from_ndarray(frames[p], format="bgr24"), float(times[k]))
    return source


def edit_camera(directory: str | Path, camera: str, edit: BreakEdit, fps: float) -> np.ndarray:
    """Edit ``camera``'s video of a raw project (data_fixtures.raw_project) in place; returns its frames' sources."""
    video = Path(directory) / camera / "video.mp4"
    tmp = video.with_name("original.mp4")
    video.rename(tmp)
    try:
        return edit_video(tmp, video, edit, fps)
    finally:
        tmp.unlink()


def pair_errors(frames_b: np.ndarray, source_a: np.ndarray, source_b_of, truth_a: tuple[float, float], truth_b: tuple[float, float]) -> np.ndarray:
    """|estimated - true| (frames of B) for A's frames whose instants B recorded: ``frames_b`` the estimated frames of
    B at A's frames, ``source_a`` the instant (original frame) each of A's frames shows, ``source_b_of`` a function
    from B's estimated frames to the original frames whose instants they show, truth_a/b each camera's true line
    (alpha, beta) on its original frames."""
    (aa, ba), (ab, bb) = truth_a, truth_b
    true_original_b = ab * (source_a - ba) / aa + bb
    return np.abs(source_b_of(frames_b) - true_original_b)
