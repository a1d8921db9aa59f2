"""Entry points: a video file in, the target's Track (``track_video``) or every mover (``detect_movers``) out."""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np

from trackers.blob import BlobDetector, BlobParams, BlobTracker, median_background
from trackers.detections import Detections, make_detections
from trackers.errors import TrackInputError
from trackers.movers import MoverLinker
from trackers.track import Track
from trackers.video import VideoInfo, check_init_box, iter_frames, probe_video, sample_frames

KINDS = ("blob", "csrt")
# Every-mover detection expects crowds: a frame is taken as a global change (skipped) only above this many blobs.
MOVERS_MAX_CANDIDATES = 200


def track_video(
    path: str | Path,
    kind: str = "blob",
    init: Sequence[float] | None = None,
    init_frame: int = 0,
    params: dict | None = None,
    progress: bool = True,
    label: str | None = None,
) -> Track:
    """Track the target through ``path``; frames without a confident position are absent.

    kind: "blob" (reports the blob centroid) or "csrt" (the box centre);
    init: optional box [x, y, w, h] (pixels, top-left corner and size)
    around the target in frame ``init_frame`` (0-based); tracking starts
    there. Without it the first confidently moving blob is the target.
    params: tracker parameters by name (BlobParams, CsrtParams); label:
    the progress bar's title (default: the file name). Returns a
    Track with time_s (presentation time, s), w, h and score.
    """
    path = Path(path)
    if kind not in KINDS:
        raise TrackInputError(f"unknown tracker kind {kind!r}; expected one of: {', '.join(KINDS)}")
    info = probe_video(path)
    box = check_init_box(path, info, init, init_frame)
    where = f"{path}: tracker parameters"
    if kind == "blob":
        blob_params = BlobParams.from_dict(params, where)
        steps = _blob_steps(path, info, blob_params, box, init_frame, progress, label)
    else:
        from trackers.csrt import CsrtParams, csrt_steps

        csrt_params, blob_params = CsrtParams.from_dict(params, where)
        steps = csrt_steps(path, info, csrt_params, blob_params, box, init_frame, progress, _detector(path, blob_params), label)
    rows = {}
    while True:
        try:
            frame, time_s, x, y, w, h, score = next(steps)
        except StopIteration as stop:
            n_read = stop.value
            break
        rows[frame] = (time_s, x, y, w, h, score)
    if init_frame >= n_read:
        raise TrackInputError(f"{path}: init frame {init_frame} is past the end of the video ({n_read} frames)")
    frames = np.array(sorted(rows), dtype=np.int64)
    cols = np.array([rows[f] for f in frames], dtype=np.float64).reshape(-1, 6)
    return Track(frames, cols[:, 1], cols[:, 2], time_s=cols[:, 0], w=cols[:, 3], h=cols[:, 4], score=cols[:, 5])


def detect_movers(path: str | Path, params: dict | None = None, progress: bool = True, label: str | None = None) -> Detections:
    """Every moving-object candidate of every frame of ``path``, linked into tracklets.

    The blob detector's candidates (background subtraction) linked by
    trackers.movers.MoverLinker; params: BlobParams by name; label: the
    progress bar's title. Detections carry time_s (presentation time, s).
    """
    path = Path(path)
    probe_video(path)
    blob_params = BlobParams.from_dict({"max_candidates": MOVERS_MAX_CANDIDATES, **(params or {})}, f"{path}: tracker parameters")
    detector = _detector(path, blob_params)
    linker = MoverLinker(blob_params)
    rows = []
    for index, time_s, gray in iter_frames(path, gray=True, progress=progress, desc=label):
        for tracklet, blob, score in linker.step(index, detector.detect(gray)):
            rows.append((index, time_s, tracklet, blob.x, blob.y, blob.w, blob.h, score))
    return make_detections(rows)


def _detector(path: Path, params: BlobParams) -> BlobDetector:
    """A blob detector whose background is the median of (luma) frames sampled over the video."""
    frames = sample_frames(path, params.background_frames, gray=True)
    background, deviation = median_background(frames)
    return BlobDetector(background, params, deviation)


def _blob_steps(path, info: VideoInfo, params: BlobParams, box, init_frame: int, progress: bool, label: str | None):
    """Yields (frame, time_s, x, y, w, h, score) rows; returns the number of frames read."""
    detector = _detector(path, params)
    tracker = BlobTracker(params, box, (info.width, info.height))
    times = {}
    index = -1
    for index, time_s, gray in iter_frames(path, gray=True, progress=progress, desc=label):
        times[index] = time_s
        blobs = detector.detect(gray)
        if index < init_frame:
            continue
        if index == init_frame:
            tracker.start(index)
        for frame, blob, score in tracker.step(index, blobs):
            yield frame, times[frame], blob.x, blob.y, blob.w, blob.h, score
        times = {f: t for f, t in times.items() if f > index - 2 * params.confirm - 2}
    return index + 1
