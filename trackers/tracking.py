"""Entry points: a video file in, the target's Track (``track_video``) or every mover (``detect_movers``) out."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from trackers.background import Background, sample_background
from trackers.blob import BlobDetector, BlobParams, BlobTracker
from trackers.breaks import KeyframeMeter, PictureMeter
from trackers.choices import DEFAULT_KIND, KINDS
from trackers.detections import Detections, make_detections
from trackers.errors import TrackInputError
from trackers.movers import MoverLinker
from trackers.track import Track
from trackers.video import (
    DecodeCount,
    VideoInfo,
    check_init_box,
    iter_frames,
    iter_keyframes,
    iter_windows,
    probe_video,
)

# Every-mover detection expects crowds: a frame is taken as a global change (skipped) only above this many blobs.
MOVERS_MAX_CANDIDATES = 200


def track_video(
    path: str | Path,
    kind: str = DEFAULT_KIND,
    init: Sequence[float] | None = None,
    init_frame: int = 0,
    params: dict | None = None,
    progress: bool = True,
    label: str | None = None,
    meter: PictureMeter | None = None,
) -> Track:
    """Track the target through ``path``; frames without a confident position are absent.

    kind: "blob" (reports the blob centroid) or "csrt" (the box centre);
    init: optional box [x, y, w, h] (pixels, top-left corner and size)
    around the target in frame ``init_frame`` (0-based); tracking starts
    there. Without it the first confidently moving blob is the target.
    params: tracker parameters by name (BlobParams, CsrtParams); label:
    the progress bar's title (default: the file name); meter: fed every
    frame read (trackers/breaks.py). Returns a
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
        steps = _blob_steps(path, info, blob_params, box, init_frame, progress, label, meter)
    else:
        from trackers.csrt import CsrtParams, csrt_steps

        csrt_params, blob_params = CsrtParams.from_dict(params, where)
        steps = csrt_steps(
            path, info, csrt_params, blob_params, box, init_frame, progress, _detector(path, blob_params), label, meter
        )
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


def detect_movers(
    path: str | Path,
    params: dict | None = None,
    progress: bool = True,
    label: str | None = None,
    windows: Sequence[tuple[int, int]] | None = None,
    count: DecodeCount | None = None,
    meter: PictureMeter | None = None,
    background: Background | None = None,
) -> Detections:
    """Every moving-object candidate of every frame of ``path``, linked into tracklets.

    The blob detector's candidates (background subtraction) linked by
    trackers.movers.MoverLinker; params: BlobParams by name; label: the
    progress bar's title. Detections carry time_s (presentation time, s).
    windows: read only the frames inside these [start, stop) windows
    (0-based, stop excluded; ``iter_windows``), None: every frame. The
    background model starts afresh from the video's median at each window
    (frames 1 apart continue it), so a window's detections do not depend
    on the frames skipped before it. count: filled with the frames decoded;
    meter: fed every frame read (trackers/breaks.py); background: the
    video's model as ``sample_background`` gives it (None: sampled here).
    """
    path = Path(path)
    probe_video(path)
    blob_params = movers_params(path, params)
    if background is None:
        background = sample_background(path, blob_params)
    linker = MoverLinker(blob_params)
    if windows is None:
        frames = iter_frames(path, gray=True, progress=progress, desc=label)
    else:
        frames = iter_windows(path, windows, gray=True, progress=progress, desc=label, count=count)
    rows = []
    detector, last = None, -2
    for index, time_s, gray in frames:
        if detector is None or index != last + 1:
            detector = BlobDetector(background.median, blob_params, background.deviation)
        last = index
        blobs = detector.detect(gray)
        if meter is not None:
            meter.feed(index, gray, bool(blobs))
        for tracklet, blob, score in linker.step(index, blobs):
            rows.append((index, time_s, tracklet, blob.x, blob.y, blob.w, blob.h, score))
        if windows is None and count is not None:
            count.decoded += 1
            count.yielded += 1
    return make_detections(rows)


def detect_keyframe_movers(
    path: str | Path,
    params: dict | None = None,
    count: DecodeCount | None = None,
    indices: Sequence[int] | None = None,
    first_id: int = 0,
    detector: BlobDetector | None = None,
    meter: KeyframeMeter | None = None,
    decoded: dict[int, np.ndarray] | None = None,
) -> Detections:
    """Every moving-object candidate of every keyframe (or of those at frame ``indices``) of ``path``
    (``iter_keyframes``): the coarse pass.

    The same detector and background model as ``detect_movers`` (or
    ``detector``, one ``movers_detector`` made for the video and kept across
    calls), fed the keyframes only (each decoded alone). Keyframes are too
    far apart to link movers over, so each candidate is a tracklet of its
    own (ids from ``first_id`` on). meter: fed each keyframe read
    (trackers/breaks.py); decoded: luma images already decoded by frame
    index (the background's samples), not decoded again. TrackInputError
    when the video has no packet index.
    """
    path = Path(path)
    if detector is None:
        detector = movers_detector(path, params)
    rows: list[tuple] = []
    for index, time_s, gray in iter_keyframes(path, gray=True, count=count, indices=indices, decoded=decoded):
        if meter is not None:
            meter.feed(index, gray)
        for blob in detector.detect(gray):
            rows.append((index, time_s, first_id + len(rows), blob.x, blob.y, blob.w, blob.h, 1.0))
    return make_detections(rows)


def movers_detector(path: str | Path, params: dict | None = None, background: Background | None = None) -> BlobDetector:
    """The blob detector of every-mover detection for ``path``: its background the median of frames sampled over the
    video (``background``, or sampled here when None).
    """
    path = Path(path)
    probe_video(path)
    blob_params = movers_params(path, params)
    if background is None:
        background = sample_background(path, blob_params)
    return BlobDetector(background.median, blob_params, background.deviation)


def movers_params(path: Path, params: dict | None) -> BlobParams:
    """The blob parameters of every-mover detection: the user's over MOVERS_MAX_CANDIDATES."""
    return BlobParams.from_dict(
        {"max_candidates": MOVERS_MAX_CANDIDATES, **(params or {})}, f"{path}: tracker parameters"
    )


def _detector(path: Path, params: BlobParams) -> BlobDetector:
    """A blob detector whose background is the median of (luma) frames sampled over the video."""
    background = sample_background(path, params)
    return BlobDetector(background.median, params, background.deviation)


def _blob_steps(
    path,
    info: VideoInfo,
    params: BlobParams,
    box,
    init_frame: int,
    progress: bool,
    label: str | None,
    meter: PictureMeter | None = None,
):
    """Yields (frame, time_s, x, y, w, h, score) rows; returns the number of frames read."""
    detector = _detector(path, params)
    tracker = BlobTracker(params, box, (info.width, info.height))
    times = {}
    index = -1
    for index, time_s, gray in iter_frames(path, gray=True, progress=progress, desc=label):
        times[index] = time_s
        blobs = detector.detect(gray)
        if meter is not None:
            meter.feed(index, gray, bool(blobs))
        if index < init_frame:
            continue
        if index == init_frame:
            tracker.start(index)
        for frame, blob, score in tracker.step(index, blobs):
            yield frame, times[frame], blob.x, blob.y, blob.w, blob.h, score
        times = {f: t for f, t in times.items() if f > index - 2 * params.confirm - 2}
    return index + 1
