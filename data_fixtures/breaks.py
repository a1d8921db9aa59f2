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
  steadily (``stamped``: with the container's times showing the cut). The
  earlier recording shows another moment of the scene: its light
  ``light`` times the later one's, and ``parked`` a car (a dark box of a
  twelfth of the picture) that has left by the restart; with neither, the
  same pictures (a scene where nothing changed in between).
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
    repeated frame after each ``every`` frames), stamped (``restart``: the container's times show the cut), light
    and parked (``restart``: the earlier recording's light, relative, and a car parked in it)."""

    kind: str
    frame: int = 0
    size: int = 0
    every: int = 0
    stamped: bool = False
    light: float = 1.0
    parked: bool = False

    def label(self) -> str:
        if self.kind == "repeat":
            return f"repeat 1/{self.every}"
        return f"{self.kind} {self.size}" + (" stamped" if self.stamped else "")

    def earlier(self, picture: np.ndarray) -> np.ndarray:
        """A picture (BGR, uint8) of the earlier recording of a ``restart``: its light and its parked car."""
        out = np.clip(picture.astype(np.float32) * self.light, 0, 255).astype(np.uint8)
        if self.parked:
            h, w = out.shape[:2]
            out[h // 2 : h // 2 + h // 6, w // 8 : w // 8 + w // 2] = (40, 40, 48)
        return out


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
            shown = edit.earlier(frames[p]) if edit.kind == "restart" and k < edit.frame else frames[p]
            write(av.VideoFrame.from_ndarray(shown, format="bgr24"), float(times[k]))
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


def frames_showing(source: np.ndarray, original: np.ndarray) -> np.ndarray:
    """The edited (fractional) frames showing the instants of ``original`` (fractional original frames); NaN where
    no frame does (dropped, before or after the recording). source: ``edited_source``'s."""
    source = np.asarray(source, dtype=np.float64)
    index = np.flatnonzero(np.isfinite(source))
    shown = source[index]
    original = np.asarray(original, dtype=np.float64)
    j = np.clip(np.searchsorted(shown, original, side="right") - 1, 0, len(shown) - 1)
    frac = original - shown[j]
    nxt = np.minimum(j + 1, len(shown) - 1)
    steady = (nxt > j) & (shown[nxt] - shown[j] == 1) & (index[nxt] - index[j] == 1)
    valid = (frac >= -0.5) & ((frac <= 0.5) | ((frac < 1) & steady))
    valid &= ~((j == 0) & (frac < 0) & (index[0] > 0))
    return np.where(valid, index[j] + frac, np.nan)


def pair_errors(
    timeline,
    lines: dict[str, tuple[float, float]],
    sources: dict[str, np.ndarray],
    a: str,
    b: str,
    times: dict | None = None,
) -> tuple[np.ndarray, int, int]:
    """How the timeline maps A's frames to B's against the truth: |mapped - true| (frames of B) over
    A's frames it maps whose instant B recorded; how many of those it leaves unmapped; how many it maps into B's
    video though B did not record their instant (a dropped stretch, an unknown segment mapped anyway).

    lines: each camera's true line (alpha, beta) on its original frames; sources: each camera's ``edited_source``
    (``np.arange(n)`` for an unedited camera); times: the cameras' presentation times (``FrameTimes`` by name, as
    the export stage reads them: exact maps for presentation-time clocks).
    """
    (aa, ba), (ab, bb) = lines[a], lines[b]
    frames = np.arange(len(sources[a]), dtype=np.float64)
    estimated = timeline.match(a, b, frames, times)
    inside = np.isfinite(estimated) & (estimated > -0.5) & (estimated < len(sources[b]) - 0.5)
    truth = frames_showing(sources[b], ab * (sources[a] - ba) / aa + bb)
    recorded = np.isfinite(truth)
    mapped = recorded & np.isfinite(estimated)
    return (
        np.abs(estimated[mapped] - truth[mapped]),
        int(np.count_nonzero(recorded & ~np.isfinite(estimated))),
        int(np.count_nonzero(inside & ~recorded)),
    )


def video_times(folder: str | Path, cameras) -> dict:
    """Each camera's presentation times of every frame (``FrameTimes``) from its video in a raw project's folder."""
    from tlsync_pipeline.sync.model.clock import FrameTimes
    from trackers.video import presentation_times

    out = {}
    for name in cameras:
        times = presentation_times(Path(folder) / name / "video.mp4")
        if times is not None:
            out[name] = FrameTimes(np.arange(len(times), dtype=np.float64), times)
    return out
