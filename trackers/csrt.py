"""CSRT tracker (opencv-contrib) with loss detection and re-acquisition by the blob detector.

Started from a box (init = [x, y, w, h] at init_frame) or from the blob
tracker's first confirmed detection (a box around the blob). The target is
declared lost when

- CSRT's ``update`` fails (its peak-to-sidelobe ratio falls below
  ``psr_threshold``);
- the box centre jumps more than ``max_jump`` box sizes from its last position;
- the box centre leaves the image;
- the box has almost no foreground (blob detector's background model) for
  ``patience`` frames: CSRT stays put on background texture when the target
  leaves, so those frames are withdrawn from the track.

Lost, the blob tracker re-acquires the target (a consistent blob looking like
the target: size and polarity) and CSRT restarts on a box around it. The
reported point is the box centre, (x + (w - 1) / 2, y + (h - 1) / 2) in
full-resolution pixels.

Speed: CSRT runs on the full frame with a lighter configuration than
OpenCV's default (no colour names, no segmentation, 9 scales); its cost is
set by its template (``template_size``), not by the frame size.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import cv2

from trackers.blob import BlobDetector, BlobParams, BlobTracker, params_from_dict
from trackers.errors import TrackInputError
from trackers.video import iter_frames


@dataclass(frozen=True)
class CsrtParams:
    """CSRT parameters (OpenCV's names where they are OpenCV's) and loss detection."""

    psr_threshold: float = 0.035  # CSRT's own: update fails below this peak-to-sidelobe ratio
    number_of_scales: int = 9
    template_size: int = 120
    admm_iterations: int = 4
    use_color_names: int = 0  # 0/1
    use_segmentation: int = 0  # 0/1
    max_jump: float = 1.5  # largest move between frames, in box sizes (plus 10 px)
    min_support: float = 0.08  # foreground fraction of the box below which it may be on background
    patience: int = 4  # frames of low support before the target is declared lost
    box_margin: float = 3.0  # pixels added around a blob's box when CSRT starts from it

    @classmethod
    def from_dict(cls, values: dict | None, where: str = "tracker parameters") -> tuple["CsrtParams", BlobParams]:
        """Split a parameters table into CSRT and blob-detector parameters (keys of either)."""
        values = dict(values or {})
        own = {f.name for f in fields(cls)}
        blob_keys = {f.name for f in fields(BlobParams)}
        csrt_part = {k: v for k, v in values.items() if k in own or k not in blob_keys}
        blob_part = {k: v for k, v in values.items() if k in blob_keys and k not in own}
        try:
            return params_from_dict(cls, csrt_part, where), BlobParams.from_dict(blob_part, where)
        except TrackInputError as exc:
            if "unknown parameter" in str(exc):
                raise TrackInputError(f"{exc}; the blob detector's parameters ({', '.join(sorted(blob_keys))}) are accepted too") from None
            raise

    def opencv(self) -> "cv2.TrackerCSRT_Params":
        p = cv2.TrackerCSRT.Params()
        p.psr_threshold = float(self.psr_threshold)
        p.number_of_scales = int(self.number_of_scales)
        p.template_size = float(self.template_size)
        p.admm_iterations = int(self.admm_iterations)
        p.use_color_names = bool(self.use_color_names)
        p.use_segmentation = bool(self.use_segmentation)
        return p


def _create(params: CsrtParams):
    factory = getattr(cv2.TrackerCSRT, "create", None) or cv2.TrackerCSRT_create
    return factory(params.opencv())


def csrt_steps(path, info, params: CsrtParams, blob_params: BlobParams, box, init_frame: int, progress: bool, detector: BlobDetector, label: str | None = None):
    """Yields (frame, time_s, x, y, w, h, score) rows; returns the number of frames read."""
    width, height = info.width, info.height
    acquirer = BlobTracker(blob_params)
    if box is not None:
        acquirer.signature = (math.pi / 4 * box[2] * box[3], 0)
    tracker = None
    last = None  # (cx, cy, w, h) of the last accepted box
    held: list[tuple] = []  # rows of low foreground support, reported only if support comes back
    index = -1
    for index, time_s, bgr in iter_frames(path, gray=False, progress=progress, desc=label):
        gray = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY)
        blobs = detector.detect(gray)
        if index < init_frame:
            continue
        if tracker is None:
            start = None
            if index == init_frame and box is not None:
                start = tuple(int(round(v)) for v in box)
                inside = [b for b in blobs if box[0] <= b.x <= box[0] + box[2] and box[1] <= b.y <= box[1] + box[3]]
                if inside:  # what the target looks like to the blob detector, for re-acquisition
                    b = max(inside, key=lambda b: b.area)
                    acquirer.signature = (b.area, b.polarity)
            else:
                found = acquirer.step(index, blobs)
                if found:
                    _, b, _ = found[-1]
                    m = params.box_margin
                    start = (int(round(b.x - b.w / 2 - m)), int(round(b.y - b.h / 2 - m)), int(round(b.w + 2 * m)), int(round(b.h + 2 * m)))
                    acquirer.state = None  # the blob tracker only (re-)acquires
                    acquirer.signature = acquirer.signature or (b.area, b.polarity)
            if start is not None:
                tracker = _create(params)
                tracker.init(bgr, start)
                last = _centre(start)
                held = []
                yield (index, time_s, last[0], last[1], float(start[2]), float(start[3]), 1.0)
            continue
        ok, rect = tracker.update(bgr)
        cx, cy, w, h = _centre(rect)
        jump = math.hypot(cx - last[0], cy - last[1])
        lost = (
            not ok
            or jump > params.max_jump * max(last[2], last[3]) + 10.0
            or not (0 <= cx <= width - 1 and 0 <= cy <= height - 1)
        )
        support = detector.support((rect[0], rect[1], rect[2], rect[3]))
        if not lost:
            score = float(min(1.0, support / 0.5))
            row = (index, time_s, cx, cy, float(w), float(h), score)
            if support >= params.min_support:
                yield from held
                held = []
                yield row
            else:
                held.append(row)
                lost = len(held) > params.patience
            last = (cx, cy, w, h)
        if lost:
            tracker, held = None, []
            acquirer.chains = []
    return index + 1


def _centre(rect) -> tuple[float, float, float, float]:
    x, y, w, h = (float(v) for v in rect)
    return x + (w - 1) / 2, y + (h - 1) / 2, w, h
