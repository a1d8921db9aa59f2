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
the target: size and polarity) and CSRT restarts on a box around it.

CSRT runs only where the blobs leave doubt: while the target is followed, a
frame with exactly one blob fitting the target near its predicted position
and no other blob near reports that blob's centroid; the other frames go to
CSRT. The reported point is then the box centre, (x + (w - 1) / 2,
y + (h - 1) / 2), full-resolution pixels. CSRT uses a lighter configuration
than OpenCV's default (no colour names, no segmentation, 9 scales) on the
luma plane, refreshed only in the window it reads (``_Canvas``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from trackers.blob import BlobDetector, BlobParams, BlobTracker, params_from_dict
from trackers.breaks import PictureMeter
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
    def from_dict(cls, values: dict | None, where: str = "tracker parameters") -> tuple[CsrtParams, BlobParams]:
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
                raise TrackInputError(
                    f"{exc}; the blob detector's parameters ({', '.join(sorted(blob_keys))}) are accepted too"
                ) from None
            raise

    def opencv(self):
        """OpenCV's TrackerCSRT.Params with these values."""
        import cv2

        p = cv2.TrackerCSRT.Params()
        p.psr_threshold = float(self.psr_threshold)
        p.number_of_scales = int(self.number_of_scales)
        p.template_size = float(self.template_size)
        p.admm_iterations = int(self.admm_iterations)
        p.use_color_names = bool(self.use_color_names)
        p.use_segmentation = bool(self.use_segmentation)
        return p


def _create(params: CsrtParams):
    import cv2

    factory = getattr(cv2.TrackerCSRT, "create", None) or cv2.TrackerCSRT_create
    return factory(params.opencv())


class _Canvas:
    """A full-size 3-channel image of which only a window around the target holds the current frame.

    CSRT reads pixels only around its box (its template: the box plus
    ``CSRT_PADDING`` times its side, at the current scale) but converts a
    whole grey frame to BGR on every call; filling only the window it reads
    costs a window, not a frame. Outside the window the canvas holds
    whatever was written before, which CSRT does not read.
    """

    def __init__(self, height: int, width: int):
        self.image = np.zeros((height, width, 3), np.uint8)

    def fill(self, gray: np.ndarray, centre: tuple[float, float], box_size: tuple[float, float]) -> np.ndarray:
        """Copy the window of ``gray`` that CSRT may read around ``centre`` (box size w, h, pixels);
        returns the canvas.
        """
        w, h = box_size
        template = max(w, h) + CSRT_PADDING * math.sqrt(w * h)
        half = (
            int(math.ceil(1.25 * template)) + 8
        )  # the template around the old centre and around a new one up to half a template away
        height, width = gray.shape
        x0, y0 = max(0, int(centre[0]) - half), max(0, int(centre[1]) - half)
        x1, y1 = min(width, int(centre[0]) + half + 1), min(height, int(centre[1]) + half + 1)
        self.image[y0:y1, x0:x1] = gray[y0:y1, x0:x1, None]
        return self.image


CSRT_PADDING = 3.0  # OpenCV's CSRT default: its template is the box plus this many times sqrt(w * h)


def _unambiguous(blobs, prediction: tuple[float, float], gate: float, clearance: float, signature, size_ratio: float):
    """The one blob that can be the target near ``prediction``, or None when there is none or the choice is not clear.

    A blob can be the target when it is within ``gate`` pixels of the
    prediction, of the target's polarity and within ``size_ratio`` of its
    area; the choice is clear when it is the only such blob and no other
    blob at all (a distractor, a split target) is within ``clearance``.
    """
    area, polarity = signature
    near = [b for b in blobs if math.hypot(b.x - prediction[0], b.y - prediction[1]) <= clearance]
    fits = [
        b
        for b in near
        if math.hypot(b.x - prediction[0], b.y - prediction[1]) <= gate
        and polarity in (0, b.polarity)
        and abs(math.log(max(b.area, 1e-6) / area)) <= math.log(size_ratio)
    ]
    return fits[0] if len(fits) == 1 and len(near) == 1 else None


def csrt_steps(
    path,
    info,
    params: CsrtParams,
    blob_params: BlobParams,
    box,
    init_frame: int,
    progress: bool,
    detector: BlobDetector,
    label: str | None = None,
    meter: PictureMeter | None = None,
):
    """Yields (frame, time_s, x, y, w, h, score) rows; returns the number of frames read; meter: fed every frame read
    (trackers/breaks.py).

    While the target is followed, a frame whose blobs leave no doubt (one
    blob fits the target near its predicted position and no other blob is
    near) reports that blob's centroid; CSRT runs only on the other frames,
    restarted when needed from the last reported box in the frame before.
    """
    width, height = info.width, info.height
    acquirer = BlobTracker(blob_params)
    if box is not None:
        acquirer.signature = (math.pi / 4 * box[2] * box[3], 0)
    canvas = _Canvas(height, width)
    tracker = None  # CSRT, when it follows the target; None while the blobs do
    last = None  # (cx, cy, w, h) of the last reported box, None when the target is lost
    velocity = (0.0, 0.0)  # pixels per frame
    last_frame = -1
    previous = None  # the frame before this one (grey), where CSRT restarts
    held: list[tuple] = []  # rows of low foreground support, reported only if support comes back
    index = -1
    for index, time_s, gray in iter_frames(path, gray=True, progress=progress, desc=label):
        blobs = detector.detect(gray)
        if meter is not None:
            meter.feed(index, gray, bool(blobs))
        if index < init_frame:
            previous = gray
            continue
        if last is None:
            start = None
            if index == init_frame and box is not None:
                start = tuple(int(round(v)) for v in box)
                inside = [b for b in blobs if box[0] <= b.x <= box[0] + box[2] and box[1] <= b.y <= box[1] + box[3]]
                if inside:  # what the target looks like to the blob detector, for re-acquisition
                    b = max(inside, key=lambda b: b.area)
                    acquirer.signature = (b.area, b.polarity)
                centre = _centre(start)
            else:
                found = acquirer.step(index, blobs)
                if found:
                    _, b, _ = found[-1]
                    m = params.box_margin
                    start = (
                        int(round(b.x - b.w / 2 - m)),
                        int(round(b.y - b.h / 2 - m)),
                        int(round(b.w + 2 * m)),
                        int(round(b.h + 2 * m)),
                    )
                    acquirer.state = None  # the blob tracker only (re-)acquires
                    acquirer.signature = acquirer.signature or (b.area, b.polarity)
                    centre = (b.x, b.y, float(start[2]), float(start[3]))
            if start is not None:
                tracker = _create(params)
                tracker.init(canvas.fill(gray, centre[:2], centre[2:]), start)
                last, velocity, last_frame, held = centre, (0.0, 0.0), index, []
                yield (index, time_s, last[0], last[1], last[2], last[3], 1.0)
            previous = gray
            continue
        dt = index - last_frame
        prediction = (last[0] + velocity[0] * dt, last[1] + velocity[1] * dt)
        gate = blob_params.gate_px * (1 + 0.5 * (dt - 1)) + 0.5 * max(last[2], last[3])
        blob = None
        if acquirer.signature is not None and acquirer.signature[1] != 0:
            blob = _unambiguous(blobs, prediction, gate, 2 * gate, acquirer.signature, blob_params.size_ratio)
        if blob is not None:
            cx, cy, w, h, ok = blob.x, blob.y, last[2], last[3], True
            tracker = None
        else:
            if tracker is None:  # restart CSRT on the last reported box, in the frame it was reported in
                tracker = _create(params)
                start = (
                    int(round(last[0] - (last[2] - 1) / 2)),
                    int(round(last[1] - (last[3] - 1) / 2)),
                    int(round(last[2])),
                    int(round(last[3])),
                )
                assert previous is not None, "a box was reported in an earlier frame"
                tracker.init(canvas.fill(previous, last[:2], last[2:]), start)
            ok, rect = tracker.update(canvas.fill(gray, last[:2], last[2:]))
            cx, cy, w, h = _centre(rect)
        jump = math.hypot(cx - last[0], cy - last[1])
        lost = (
            not ok
            or jump > params.max_jump * max(last[2], last[3]) + 10.0
            or not (0 <= cx <= width - 1 and 0 <= cy <= height - 1)
        )
        bx, by = cx - (w - 1) / 2, cy - (h - 1) / 2
        support = detector.support((bx, by, w, h))
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
            if blob is not None and acquirer.signature is not None and acquirer.signature[1] != 0:
                area, polarity = acquirer.signature
                acquirer.signature = (0.8 * area + 0.2 * blob.area, polarity)
            a = 0.6
            velocity = (
                a * (cx - last[0]) / dt + (1 - a) * velocity[0],
                a * (cy - last[1]) / dt + (1 - a) * velocity[1],
            )
            last, last_frame = (cx, cy, float(w), float(h)), index
        if lost:
            tracker, last, held = None, None, []
            acquirer.chains = []
        previous = gray
    return index + 1


def _centre(rect) -> tuple[float, float, float, float]:
    x, y, w, h = (float(v) for v in rect)
    return x + (w - 1) / 2, y + (h - 1) / 2, w, h
