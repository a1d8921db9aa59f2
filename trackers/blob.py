"""Blob tracker: background subtraction, connected components, gated association.

Per frame (grey):

1. Background model on a downscaled frame: a per-pixel running mean and mean
   absolute deviation, initialised from the per-pixel median of frames sampled
   across the whole video (so a moving target is not part of it), updated
   where no foreground is found. A global gain (frame mean / background mean
   over background pixels) absorbs lighting flicker and auto exposure.
2. Foreground = |frame - gain * background| > max(threshold * deviation,
   min_contrast); connected components of it, kept if their area is within
   [min_area, max_area], are the candidate blobs.
3. Each candidate's centroid is refined in a small window around it: the
   centroid (image moments) of the difference to a background at that
   resolution (kept, like the downscaled one, in the lighting of the initial
   background and scaled by the frame's global gain), with weights rising
   from 0 (noise level) to 1 (a fraction of the blob's contrast) so edge
   pixels count by how much the blob covers them and the blob's own texture
   does not pull the centroid. A gain measured around each blob instead is
   pulled by neighbouring walkers in a crowd. The resolution is the
   coarsest level of the downscale's halvings (full, 1/2, 1/4, ...) where
   the blob's smaller side still spans REFINE_MIN_SIDE pixels: a small blob
   is refined at full resolution, a walker 300 px tall at 1080p at a quarter
   of it, for a fraction of the work and an error far below its own size.
4. Association: while tracking, the candidate nearest to the constant-velocity
   prediction, within a gate and of a similar size and the same polarity
   (brighter / darker than the background); after ``patience`` frames without
   one the target is lost. Lost, a candidate must be followed consistently for
   ``confirm`` frames (and look like the target seen before: size and
   polarity) to be (re-)acquired; those frames are then reported too. Once the
   target has been seen, only a new object can be it again: one that appears
   after the target was last seen, entering the view at its edge or within
   reach of where the target vanished; the other blobs, followed all along,
   never are (a look-alike that wanders in the view while the target is out
   of it is not reported).

The reported point is the blob's centroid (full-resolution pixels, origin at
the centre of the top-left pixel).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

import numpy as np

from trackers.errors import TrackInputError


@dataclass(frozen=True)
class BlobParams:
    """Blob tracker parameters; sizes in full-resolution pixels, counts in frames."""

    scale: int = 0  # downscale factor of the background model; 0: automatic (working width <= 480 px)
    threshold: float = 4.0  # foreground: difference above threshold x the pixel's mean absolute deviation
    min_contrast: float = 12.0  # ... and above this many grey levels
    min_area: float = 6.0  # candidate blob area bounds (pixels)
    max_area: float = 0.0  # 0: automatic, the larger of 20,000 px and 1/20 of the frame
    learning_rate: float = 0.02  # background update rate per frame
    background_frames: int = 15  # frames sampled across the video for the initial background
    gate_px: float = 25.0  # association gate around the prediction
    size_ratio: float = 3.0  # accepted area ratio to the target's
    confirm: int = 3  # consecutive consistent frames to (re-)acquire
    patience: int = 5  # frames without a consistent detection before the target is lost
    max_speed_px: float = 40.0  # largest motion between frames while acquiring
    max_candidates: int = 25  # more blobs than this in a frame: a global change, frame skipped

    @classmethod
    def from_dict(cls, values: dict | None, where: str = "tracker parameters") -> BlobParams:
        return params_from_dict(cls, values, where)


@dataclass(frozen=True)
class Blob:
    """A candidate blob: refined centroid (x, y), area and box (w, h) in full-resolution pixels.

    polarity: +1 brighter than the background, -1 darker; contrast: mean
    absolute difference to the background (grey levels).
    """

    x: float
    y: float
    area: float
    w: float
    h: float
    polarity: int
    contrast: float


REFINE_MIN_SIDE = 24  # pixels the blob's smaller side spans at the resolution it is refined at (at least)
AUTO_MAX_AREA_PX = 20000.0  # the automatic max_area: at least this many pixels ...
AUTO_MAX_AREA_SHARE = 1 / 20  # ... or this share of the frame


class BlobDetector:
    """Background model and candidate blobs, frame after frame (grey, full resolution)."""

    def __init__(self, background: np.ndarray, params: BlobParams = BlobParams(), deviation: np.ndarray | None = None):
        """background: (H, W) full-resolution grey background (e.g. ``median_background``)."""
        import cv2

        # numba takes 0.4 s to import: a detector's process pays it, not every tlsync process
        import trackers.blob_passes as blob_passes

        self.passes = blob_passes
        self.params = params
        h, w = background.shape
        self.size = (w, h)
        self.scale = params.scale or max(1, int(math.ceil(w / 480)))
        self.small_size = (max(1, w // self.scale), max(1, h // self.scale))
        self.max_area = params.max_area or max(AUTO_MAX_AREA_PX, AUTO_MAX_AREA_SHARE * w * h)
        # The backgrounds are kept in the lighting of the initial one; a frame's gain maps them to its own.
        # bg: the working scale's, learnt every frame; bg_levels: the finer ones (full resolution and the
        # halvings above the working scale), for the refinement only. At scale 1 bg is the full-resolution one.
        levels = self._pyramid(background.astype(np.float32))
        self.bg = levels.pop(self.scale)
        self.bg_levels = levels
        if deviation is None:
            deviation = np.full((h, w), 2.0, np.float32)
        self.dev = np.maximum(self._pyramid(deviation.astype(np.float32))[self.scale], 1.0)
        self.background_mask = np.full(self.small_size[::-1], 255, np.uint8)
        self.mask = np.zeros(self.small_size[::-1], np.uint8)
        self.frames = 0
        self.noise = float(np.median(self.dev)) * 1.25
        # 16-bit labels when they cannot overflow (8-connected components of a small frame: at most a quarter of its
        # pixels, rounded up per axis): OpenCV computes the components' statistics about three times faster.
        most = ((self.small_size[0] + 1) // 2) * ((self.small_size[1] + 1) // 2)
        self._label_type = cv2.CV_16U if most < 65535 else cv2.CV_32S

    def detect(self, gray: np.ndarray) -> list[Blob]:
        """Update the model with one frame; the candidate blobs, refined at full resolution."""
        import cv2

        if gray.shape[::-1] != self.size:
            raise TrackInputError(
                f"frame size {gray.shape[1]}x{gray.shape[0]} differs from the video's {self.size[0]}x{self.size[1]}"
            )
        p = self.params
        s = self.scale
        levels = self._pyramid(gray)
        small = levels[s]
        gain = self.passes.frame_gain(small, self.bg, self.background_mask)
        diff = np.empty(small.shape, np.float32)
        self.passes.foreground(small, self.bg, self.dev, gain, p.threshold, p.min_contrast, diff, self.mask)
        blobs = []
        rx, ry, rw, rh = cv2.boundingRect(self.mask)  # components only where there is foreground
        if rw and rh:
            _, labels, stats, _ = cv2.connectedComponentsWithStats(
                self.mask[ry : ry + rh, rx : rx + rw], connectivity=8, ltype=self._label_type
            )
            areas = stats[:, cv2.CC_STAT_AREA] * (s * s)
            keep = np.flatnonzero((areas >= p.min_area) & (areas <= self.max_area))
            keep = keep[keep > 0]
            if len(keep) > p.max_candidates:
                keep = keep[:0]  # a global change (light switched, camera bumped): no trustworthy blob
            for i in keep.tolist():
                blob = self._refine(levels, labels, i, stats[i], diff, (rx, ry), gain)
                if blob is not None:
                    blobs.append(blob)
        # learn the background where there is no foreground (dilated)
        self.background_mask = cv2.bitwise_not(cv2.dilate(self.mask, _KERNEL3))
        self.passes.learn(small, diff, self.bg, self.dev, self.background_mask, gain, p.learning_rate)
        self.frames += 1
        if self.frames % 8 == 0:  # the refinement's backgrounds follow more slowly
            for f, background in self.bg_levels.items():
                self.passes.learn_level(
                    levels[f], background, self.background_mask, s // f, gain, min(1.0, 8 * p.learning_rate)
                )
        return blobs

    def _pyramid(self, image: np.ndarray) -> dict[int, np.ndarray]:
        """{factor: image area-averaged by factor} for 1 (full), each halving, and the scale factor (the working frame).

        Pixel (i, j) at factor f is the mean of full pixels [i*f, i*f+f) x
        [j*f, j*f+f) (the frame cropped to a multiple of the scale). Even
        factors go by halves, each rounding to the nearest grey level on 8-bit
        frames: several times faster than one step by 4 or 8. 8-bit frames
        are halved by a compiled pass (``blob_passes.halve``, bit-identical to
        OpenCV's INTER_AREA by 2, in about two thirds of its time), the float
        images of the initial model by OpenCV.
        """
        import cv2

        sw, sh = self.small_size
        s = self.scale
        levels = {1: image}
        image = image[: sh * s, : sw * s]
        f = 1
        while (s // f) % 2 == 0:
            f *= 2
            size = (sw * s // f, sh * s // f)
            if image.dtype == np.uint8:
                half = np.empty(size[::-1], np.uint8)
                self.passes.halve(image, half)
            else:
                half = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
            image = half
            levels[f] = image
        if f < s and image.dtype == np.uint8 and s // f == 3:
            levels[s] = np.empty((sh, sw), np.uint8)
            self.passes.third(image, levels[s])
        elif f < s:
            levels[s] = cv2.resize(image, (sw, sh), interpolation=cv2.INTER_AREA)
        return levels

    def support(self, box: tuple[float, float, float, float]) -> float:
        """Fraction of foreground pixels of the last frame inside box (x, y, w, h), full-resolution pixels."""
        s = self.scale
        x0, y0 = max(0, int(box[0] / s)), max(0, int(box[1] / s))
        x1 = min(self.small_size[0], int(math.ceil((box[0] + box[2]) / s)))
        y1 = min(self.small_size[1], int(math.ceil((box[1] + box[3]) / s)))
        if x1 <= x0 or y1 <= y0:
            return 0.0
        return float(np.count_nonzero(self.mask[y0:y1, x0:x1])) / ((x1 - x0) * (y1 - y0))

    def _refine(self, levels, labels, label, stat, diff, offset, gain) -> Blob | None:
        """The component ``label`` (labels and stat of the region starting at small pixel ``offset``), refined.

        levels: the frame's pyramid (``_pyramid``); diff: the small frame's
        difference to the background. The refinement (trackers.blob_passes.refine)
        runs at the coarsest level where the blob's smaller side spans
        REFINE_MIN_SIDE pixels; the result is in full-resolution pixels.
        """
        s = self.scale
        x, y, bw, bh, _ = stat.tolist()
        f = max((f for f in levels if min(bw, bh) * s >= REFINE_MIN_SIDE * f), default=1)
        background = self.bg if f == s else self.bg_levels[f]
        ok, polarity, contrast, area, lx, ly = self.passes.refine(
            labels,
            label,
            (x, y, bw, bh),
            offset,
            diff,
            levels[f],
            background,
            s // f,
            gain,
            self.noise,
            self.small_size,
        )
        if not ok:
            return None
        # level pixel i covers full pixels [i*f, i*f+f)
        return Blob(
            lx * f + (f - 1) / 2, ly * f + (f - 1) / 2, area * f * f, float(bw * s), float(bh * s), polarity, contrast
        )


_KERNEL3 = np.ones((3, 3), np.uint8)


def load_compiled_passes() -> None:
    """Load (from numba's cache, else compile) every compiled pass for the types the detector hands it: 8-bit frames
    and masks, float32 backgrounds, 16- or 32-bit labels, frames halved or cut to a third whether contiguous or
    cropped. A process whose workers fork from it (a run's fork server) pays this once instead of every worker
    (about 0.5 s of CPU; compiling them, about 2 s). Small arrays and no OpenCV call: OpenCV's thread pool, once
    started, would be inherited broken by every fork."""
    import trackers.blob_passes as passes

    frame = np.zeros((12, 12), np.uint8)
    for image in (frame, frame[:, :11]):  # contiguous, and cropped to a multiple of the scale
        passes.halve(image, np.zeros((6, 5), np.uint8))
        passes.third(image, np.zeros((4, 3), np.uint8))
    small, mask = np.zeros((6, 6), np.uint8), np.zeros((6, 6), np.uint8)
    background, deviation, diff = (np.ones((6, 6), np.float32) for _ in range(3))
    passes.frame_gain(small, background, mask)
    passes.foreground(small, background, deviation, 1.0, 4.0, 12.0, diff, mask)
    passes.learn(small, diff, background, deviation, mask, 1.0, 0.02)
    passes.learn_level(frame, np.ones((12, 12), np.float32), mask, 2, 1.0, 0.02)
    for labels in (np.ones((2, 2), np.uint16), np.ones((2, 2), np.int32)):
        passes.refine(labels, 1, (0, 0, 2, 2), (1, 1), diff, frame, np.ones((12, 12), np.float32), 2, 1.0, 2.0, (6, 6))


@dataclass
class _State:
    x: float
    y: float
    vx: float
    vy: float
    frame: int
    area: float
    polarity: int


@dataclass(frozen=True)
class _Lost:
    """Where and when the target was last seen, for its re-acquisition: frame, position (px), speed (px/frame)."""

    frame: int
    x: float
    y: float
    speed: float


class BlobTracker:
    """Associates the detector's blobs over frames into the target's track.

    ``step`` takes a frame index and its blobs and returns the detections to
    report for this and (on acquisition) the few frames before it, as
    (frame, Blob, score) tuples. Scores in (0, 1]: how well the blob matches
    the prediction (position and size).

    Once the target has been seen, the other blobs are followed too (as
    chains of consistent detections), and a lost target is re-acquired only
    by a new object where the target can be: a chain that starts after the
    target was last seen, entering the view at its edge (within
    ``edge_margin`` of it; with ``image_size``) or within reach of where the
    target was last seen (the gate plus twice its speed for each frame
    since). A look-alike that was in view while the target was followed is
    never taken for it. Gates grow with the target's size (its area's square
    root, when above ``gate_px``): at 720p a target moves more pixels per
    frame than at 240p.
    """

    def __init__(
        self,
        params: BlobParams = BlobParams(),
        init: tuple[float, float, float, float] | None = None,
        image_size: tuple[int, int] | None = None,
    ):
        """image_size: (width, height) of the frames, pixels (None: re-acquisition within reach only)."""
        self.params = params
        self.state: _State | None = None
        self.signature: tuple[float, int] | None = None  # (area, polarity) of the target seen so far
        self.chains: list[list[tuple[int, Blob]]] = []
        self.init = init
        self.image_size = image_size
        self.lost: _Lost | None = None  # the target seen, then lost: where to look for it again
        if init is not None:
            x, y, w, h = init
            self.state = _State(x + (w - 1) / 2, y + (h - 1) / 2, 0.0, 0.0, -1, math.pi / 4 * w * h, 0)

    def start(self, frame: int) -> None:
        """Mark the init box's frame (the tracker is told the target is there)."""
        if self.state is not None and self.state.frame < 0:
            self.state.frame = frame - 1

    def step(self, frame: int, blobs: list[Blob]) -> list[tuple[int, Blob, float]]:
        if self.state is None:
            return self._acquire(frame, blobs)
        p = self.params
        st = self.state
        dt = frame - st.frame
        px, py = st.x + st.vx * dt, st.y + st.vy * dt
        gate = max(p.gate_px, math.sqrt(st.area)) * (1 + 0.5 * (dt - 1))  # a large target moves more pixels per frame
        best, best_cost = None, math.inf
        for b in blobs:
            if not st.polarity:  # from the init box, not seen yet: any blob inside the box
                assert self.init is not None, "a state without polarity comes from the init box"
                x, y, w, h = self.init
                if x <= b.x <= x + w and y <= b.y <= y + h and b.area <= 2 * w * h:
                    cost = (math.hypot(b.x - st.x, b.y - st.y) / max(w, h)) ** 2
                    if cost < best_cost:
                        best, best_cost = b, cost
                continue
            if b.polarity != st.polarity:
                continue
            ratio = abs(math.log(max(b.area, 1e-6) / st.area))
            dist = math.hypot(b.x - px, b.y - py)
            if dist > gate or ratio > math.log(p.size_ratio):
                continue
            cost = (dist / gate) ** 2 + (ratio / math.log(p.size_ratio)) ** 2
            if cost < best_cost:
                best, best_cost = b, cost
        if self.signature is not None:  # the other movers, so that none is later taken for the target
            self._extend_chains(frame, [b for b in blobs if b is not best])
        if best is not None:
            self._update(best, frame)
            return [(frame, best, math.exp(-best_cost))]
        if dt > p.patience:
            if st.polarity:
                self.lost = _Lost(st.frame, st.x, st.y, math.hypot(st.vx, st.vy))
            self.state = None
            if self.lost is None:
                self.chains = []
        return []

    def _update(self, b: Blob, frame: int) -> None:
        st = self.state
        assert st is not None, "updated while tracking"
        dt = frame - st.frame
        if st.frame >= 0 and st.polarity:
            a = 0.6
            st.vx = a * (b.x - st.x) / dt + (1 - a) * st.vx
            st.vy = a * (b.y - st.y) / dt + (1 - a) * st.vy
        st.area = 0.8 * st.area + 0.2 * b.area if st.polarity else b.area  # the init box's area is only a guess
        st.x, st.y, st.frame, st.polarity = b.x, b.y, frame, b.polarity
        self.signature = (st.area, st.polarity)

    def _plausible(self, b: Blob) -> bool:
        if self.signature is None:
            return True
        area, polarity = self.signature
        return polarity in (0, b.polarity) and abs(math.log(max(b.area, 1e-6) / area)) <= math.log(
            self.params.size_ratio
        )

    def _extend_chains(self, frame: int, blobs: list[Blob]) -> list[list[tuple[int, Blob]]]:
        """Continue each chain that reached the previous frame with its nearest consistent blob (constant velocity
        after two detections, max_speed_px before); every blob left over starts a chain. Returns the chains."""
        p = self.params
        extended: list[list[tuple[int, Blob]]] = []
        used = set()
        for chain in sorted(self.chains, key=len, reverse=True):
            last_frame, last = chain[-1]
            if last_frame != frame - 1:
                continue
            if len(chain) >= 2:
                (_, prev) = chain[-2]
                px, py = 2 * last.x - prev.x, 2 * last.y - prev.y
                gate = max(p.gate_px, math.sqrt(last.area))
            else:
                px, py, gate = last.x, last.y, p.max_speed_px
            best, best_d = None, math.inf
            for k, b in enumerate(blobs):
                d = math.hypot(b.x - px, b.y - py)
                if (
                    k not in used
                    and d <= gate
                    and abs(math.log(b.area / last.area)) <= math.log(p.size_ratio)
                    and b.polarity == last.polarity
                    and d < best_d
                ):
                    best, best_d = k, d
            if best is not None:
                used.add(best)
                extended.append(chain + [(frame, blobs[best])])
        extended += [[(frame, b)] for k, b in enumerate(blobs) if k not in used]
        self.chains = extended
        return extended

    def _plausible_tail(self, chain: list[tuple[int, Blob]]) -> list[tuple[int, Blob]]:
        """The chain's last detections that look like the target (all of them before the target was seen)."""
        k = len(chain)
        while k > 0 and self._plausible(chain[k - 1][1]):
            k -= 1
        return chain[k:]

    def _may_be_the_target(self, chain: list[tuple[int, Blob]]) -> bool:
        """Whether a chain can be the lost target: a new object (started after the target was last seen) entering
        the view at its edge or appearing within reach of where the target was last seen."""
        lost = self.lost
        if lost is None:
            return True
        frame, first = chain[0]
        if frame <= lost.frame:
            return False
        reach = max(self.params.gate_px, math.sqrt(first.area)) + 2.0 * lost.speed * (frame - lost.frame)
        if math.hypot(first.x - lost.x, first.y - lost.y) <= reach:
            return True
        if self.image_size is None:
            return False
        w, h = self.image_size
        margin = self.edge_margin(first)
        return first.x < margin or first.y < margin or first.x > w - 1 - margin or first.y > h - 1 - margin

    def edge_margin(self, blob: Blob) -> float:
        """Pixels from the image's edge within which an object entering the view is first seen: the gate, or
        the blob's larger side."""
        return max(self.params.gate_px, blob.w, blob.h)

    def _acquire(self, frame: int, blobs: list[Blob]) -> list[tuple[int, Blob, float]]:
        p = self.params
        extended = self._extend_chains(frame, [b for b in blobs if self._plausible(b)] if self.lost is None else blobs)
        ready = [c for c in extended if len(self._plausible_tail(c)) >= p.confirm and self._may_be_the_target(c)]
        if not ready:
            return []
        chosen = min(ready, key=self._preference)
        chain = self._plausible_tail(chosen)  # an object entering the view is first seen cut by the edge: smaller
        self.state = _State(chain[0][1].x, chain[0][1].y, 0.0, 0.0, chain[0][0], chain[0][1].area, chain[0][1].polarity)
        out = [(chain[0][0], chain[0][1], 0.5)]
        for f, b in chain[1:]:
            out.append((f, b, 0.5))
            self._update(b, f)
        self.chains = [c for c in extended if c is not chosen]
        self.lost = None
        return out

    def _preference(self, chain: list[tuple[int, Blob]]) -> float:
        """Lower is better: the size of the target seen before, else the most salient (contrast x size)."""
        b = chain[-1][1]
        if self.signature is not None:
            return abs(math.log(b.area / self.signature[0]))
        return -b.contrast * math.sqrt(b.area)


def median_background(frames: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Per-pixel median of grey frames (each scaled to the common mean first) and the mean absolute deviation.

    Frames are scaled in 8 bits (rounded, so within half a grey level); the
    median comes from a sorting network of per-pixel minima and maxima, about
    seven times faster than numpy's partition across frames at 1080p.
    """
    import cv2

    means = np.array([cv2.mean(f)[0] for f in frames])
    gains = np.median(means) / np.maximum(means, 1e-3)
    scaled = [cv2.convertScaleAbs(f, alpha=float(g)) for f, g in zip(frames, gains)]
    ordered = _sorted_planes(scaled)
    n = len(frames)
    if n % 2:
        median = ordered[n // 2].astype(np.float32)
    else:
        median = (ordered[n // 2 - 1].astype(np.float32) + ordered[n // 2]) / 2
    deviation = np.zeros(median.shape, np.float32)
    for frame in scaled:
        cv2.accumulate(cv2.absdiff(frame.astype(np.float32), median), deviation)
    return median, deviation / n


def _sorted_planes(planes: list[np.ndarray]) -> list[np.ndarray]:
    """8-bit images sorted pixel by pixel (Batcher's odd-even merge sort network; padded with 255)."""
    import cv2

    size = 1 << max(0, len(planes) - 1).bit_length()
    a = list(planes) + [np.full_like(planes[0], 255)] * (size - len(planes))
    p = 1
    while p < size:
        k = p
        while k >= 1:
            for j in range(k % p, size - k, 2 * k):
                for i in range(min(k, size - j - k)):
                    if (i + j) // (2 * p) == (i + j + k) // (2 * p):
                        low, high = a[i + j], a[i + j + k]
                        a[i + j], a[i + j + k] = cv2.min(low, high), cv2.max(low, high)
            k //= 2
        p *= 2
    return a[: len(planes)]


def params_from_dict(cls, values: dict | None, where: str):
    """A parameters dataclass from a table of numbers by name; TrackInputError (with a "did you mean") otherwise."""
    if not values:
        return cls()
    names = {f.name: f for f in fields(cls)}
    out = cls()
    for key, value in values.items():
        if key not in names:
            import difflib

            close = difflib.get_close_matches(key, list(names), n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else f" (expected one of: {', '.join(names)})"
            raise TrackInputError(f"{where}: unknown parameter {key!r}{hint}")
        default = getattr(out, key)
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float))
            or (isinstance(default, int) and not isinstance(value, int))
        ):
            raise TrackInputError(
                f"{where}: parameter {key!r}: expected {'an integer' if isinstance(default, int) else 'a number'}, "
                f"got {value!r}"
            )
        if value < 0 or not math.isfinite(value):
            raise TrackInputError(f"{where}: parameter {key!r}: expected a non-negative number, got {value!r}")
        out = replace(out, **{key: type(default)(value)})
    return out
