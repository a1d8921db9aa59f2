"""Breaks in a recording: where its frames stop following one steady clock.

Recorders drop frames under load, repeat a frame when the encoder stalls
and cut recordings into pieces. Two sources are read here, both while the
video is read anyway:

- the container's presentation times (``container_breaks``): an interval
  more than ``GAP`` nominal intervals long is a ``gap`` (frames missing, or
  a recording cut and restarted), one under ``REPEAT`` of it a ``repeat``
  (times standing still or stepping back);
- the pictures (``PictureMeter``, fed the luma frames the tracker reads): a
  frame where no pixel differs from the previous frame's by more than
  ``STILL_LEVELS`` grey levels (the coding noise of the same picture encoded
  twice) between frames where some pixel changes by ``MOVING_LEVELS`` or
  more (something moved, or the sensor's noise), while the picture holds a
  mover (a blob off the background: the stalled picture still shows it), is
  ``frozen``: the same picture again, while the clock went on
  (``frozen_runs``). A still scene without a mover, coded at a low rate,
  repeats its pictures too: the target leaving the view and coming back is
  not a freeze. A frame whose picture changes at once and stays changed
  (``scene_cuts``: on the plane averaged down to CUT_WIDTH pixels, its
  content or its mean brightness changes by far more than between the
  frames either side, and the change holds) is a ``cut``: a recording
  stopped and restarted later into the same file shows another moment of
  the scene (other movers, another light) from one frame to the next.

A drop that leaves neither trace (frames missing, times re-stamped) shows
only against the target's path: tlsync_pipeline/sync/identify/breaks.py finds it in
the votes.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from trackers.video import merge_windows

GAP = 1.5  # an interval between presentation times longer than this many nominal intervals is a gap
REPEAT = 0.5  # one shorter than this share of the nominal interval is a repeat
STILL_LEVELS = 20  # grey levels: a frame no pixel of which differs from the previous frame's by more may repeat it
MOVING_LEVELS = 40  # ... when the frames before and after it change some pixel by this much or more
REPEATED_SHARE = 1 / 3  # a run holding a keyframe coded afresh repeats its picture exactly in this share of the rest

CUT_WIDTH = 64  # px: the luma plane is averaged down to this width for cuts (sensor noise and far movers fade)
CUT_CONTENT = 3.0  # %: a change of the picture's content (the plane over its mean) of this mean size ...
CUT_GAIN = 0.04  # ... or of its mean brightness (|log ratio|), and CUT_GAIN_FLICKER times the median of the
CUT_GAIN_FLICKER = 10.0  # video's own brightness steps (its flicker; a median is not moved by the cuts) ...
CUT_SPIKE = 3.0  # ... this many times the change of each of the two frames before it and the two after it ...
REPEATED_PICTURE = 0.05  # %: a content step this small is the same picture again (its steps say nothing of flicker)
CUT_HOLDS = 0.6  # ... and holding: the two frames after it differ from the two before it by this share of it

SUSPECT_CONTENT = 1.5  # %: a change of content between keyframes read of this mean size ...
SUSPECT_GAIN = 0.03  # ... or of brightness (|log ratio|), and SUSPECT_GAIN_FLICKER times the 90th percentile of the
SUSPECT_GAIN_FLICKER = 2.5  # video's brightness steps between keyframes read (its flicker seen seconds apart) ...
KEYFRAME_SPIKE = (
    2.0  # ... and this many times the changes either side of it is read frame by frame: a cut may lie there
)
STILL_PACKET = 0.1  # share of the median inter-coded packet (bytes): a packet this small may repeat a picture ...
STILL_RUN = 2  # ... in a run of this many frames or more, read frame by frame
CHECK_MARGIN = 3  # frames read either side of a suspect: the meter judges a break by the frames around it

KINDS = ("gap", "repeat", "frozen", "drop", "cut")


@dataclass(frozen=True)
class Break:
    """A place where a camera's frames leave its steady clock.

    kind: "gap" (presentation times jump forward), "repeat" (times stand
    still or step back), "frozen" (the same picture repeated), "drop" (the
    target's path jumps: frames missing without a trace in the container),
    "cut" (the picture changes at once: a recording stopped and restarted);
    frame: the first 0-based frame after the break (for "frozen": the first
    repeated picture); size: frames, missing (gap, drop; negative: the
    clock stepped back) or repeated (frozen, repeat); 0 for a cut (unknown).
    """

    kind: str
    frame: int
    size: float

    def describe(self) -> str:
        """The break in words: "frozen 25 frames at frame 412"."""
        if self.kind == "cut":
            return f"a cut (the picture changes at once) at frame {self.frame}"
        what = {"gap": "gap of", "repeat": "repeated times over", "frozen": "frozen", "drop": "jump of"}[self.kind]
        return f"{what} {self.size:.3g} frame{'' if abs(self.size) == 1 else 's'} at frame {self.frame}"

    def to_dict(self) -> dict:
        return {"kind": self.kind, "frame": self.frame, "size": round(float(self.size), 3)}

    @classmethod
    def from_dict(cls, entry: dict) -> Break:
        return cls(str(entry["kind"]), int(entry["frame"]), float(entry["size"]))


def repeated_frames(breaks: Sequence[Break]) -> np.ndarray:
    """The 0-based frames of the frozen runs and repeated times among ``breaks``: they show no instant of their own."""
    runs = [np.arange(b.frame, b.frame + max(round(b.size), 1)) for b in breaks if b.kind in ("frozen", "repeat")]
    return np.concatenate(runs).astype(np.int64) if runs else np.zeros(0, np.int64)


def container_breaks(times: np.ndarray, fps: float | None = None) -> list[Break]:
    """Gaps and repeats in a video's presentation times (s, one per frame in order).

    The nominal interval is 1 / fps, or the median interval without fps.
    Consecutive repeated intervals are one break.
    """
    times = np.asarray(times, dtype=np.float64)
    if len(times) < 3:
        return []
    step = np.diff(times)
    nominal = 1.0 / fps if fps else float(np.median(step))
    if not nominal > 0:
        return []
    out: list[Break] = []
    k = 0
    while k < len(step):
        ratio = step[k] / nominal
        if ratio > GAP:
            out.append(Break("gap", k + 1, round(float(ratio - 1.0), 3)))
        elif ratio < REPEAT:
            run = k
            while run + 1 < len(step) and step[run + 1] / nominal < REPEAT:
                run += 1
            out.append(Break("repeat", k + 1, float(run - k + 1)))
            k = run
        k += 1
    return out


class PictureMeter:
    """Frozen frames and cuts of a video, measured on the luma frames as they are read.

    ``feed(index, gray, movers)`` each frame in order (a frame not
    consecutive to the previous one starts afresh); ``breaks()`` the frozen
    runs (``frozen_runs``) and the cuts (``scene_cuts``) in frame order.
    Per frame it keeps six numbers (the largest pixel change, whether a
    mover is in view, two picture changes of two numbers each) and, for
    the cuts, the last three frames' planes averaged down to CUT_WIDTH.
    """

    def __init__(self) -> None:
        import cv2  # here, not at the module's top: timeline.json's reader imports Break, and start-up loads no OpenCV

        self._cv2 = cv2
        self._last: tuple[int, np.ndarray] | None = None
        self._small: list[tuple[int, np.ndarray, float]] = []
        self._frames: list[int] = []
        self._change: list[int] = []
        self._movers: list[bool] = []
        self._step: list[tuple[float, float]] = []
        self._across: list[tuple[float, float]] = []

    def feed(self, index: int, gray: np.ndarray, movers: bool) -> None:
        """One luma frame (H, W, uint8) with its 0-based index, and whether the detector found a mover in it."""
        cv2 = self._cv2
        small, mean = _small_plane(cv2, gray)
        if self._last is not None and self._last[0] == index - 1 and self._last[1].shape == gray.shape:
            self._frames.append(index)
            self._change.append(int(cv2.norm(gray, self._last[1], cv2.NORM_INF)))  # max |difference|, in one pass
            self._movers.append(movers)
            self._step.append(_picture_change(self._small[-1], (index, small, mean)))
            back = self._small[-3] if len(self._small) >= 3 and self._small[-3][0] == index - 3 else None
            self._across.append(_picture_change(back, (index, small, mean)) if back is not None else (np.nan, np.nan))
        else:
            self._small = []
        self._small = [*self._small[-2:], (index, small, mean)]
        self._last = (index, gray)

    def breaks(self, keyframes: Sequence[int] | np.ndarray = ()) -> list[Break]:
        """The frozen runs and the cuts, in frame order; keyframes: the video's keyframes (0-based frames), whose
        pictures are coded afresh (``frozen_runs``)."""
        frames = np.array(self._frames, dtype=np.int64)
        step = np.array(self._step, dtype=np.float64).reshape(-1, 2)
        across = np.array(self._across, dtype=np.float64).reshape(-1, 2)
        change = np.array(self._change, dtype=np.int64)
        keyframe = np.isin(frames, np.asarray(keyframes, dtype=np.int64))
        found = frozen_runs(frames, change, np.array(self._movers, dtype=bool), keyframe)
        return sorted(found + scene_cuts(frames, step, across), key=lambda b: b.frame)


def _small_plane(cv2, gray: np.ndarray) -> tuple[np.ndarray, float]:
    """The luma plane averaged down to CUT_WIDTH pixels wide (float32), and its mean (grey levels, at least 1)."""
    h, w = gray.shape[:2]
    width = min(CUT_WIDTH, w)
    stride = max(1, w // (4 * CUT_WIDTH))  # every stride-th pixel: still 4 x 4 or more averaged into each one
    size = (width, max(1, round(h * width / w)))
    small = cv2.resize(gray[::stride, ::stride], size, interpolation=cv2.INTER_AREA).astype(np.float32)
    return small, max(float(small.mean()), 1.0)


def _picture_change(a: tuple[int, np.ndarray, float], b: tuple[int, np.ndarray, float]) -> tuple[float, float]:
    """(content, brightness) change between two small planes with their means: the mean absolute difference of the
    planes over their means (%), and |log| of the ratio of their means."""
    _, plane_a, mean_a = a
    _, plane_b, mean_b = b
    content = 100.0 * float(np.abs(plane_a / mean_a - plane_b / mean_b).mean())
    return content, abs(float(np.log(mean_b / mean_a)))


def scene_cuts(frames: np.ndarray, step: np.ndarray, across: np.ndarray) -> list[Break]:
    """Cuts from each frame's change of picture since the previous frame and since the frame three before.

    frames: 0-based frames, each consecutive to frame - 1; step (N, 2): the
    change (content %, brightness |log ratio|; ``PictureMeter``) from frame
    - 1; across (N, 2): from frame - 3 (NaN when not read). Frame f is a cut
    when, in content or in brightness, its step is at least CUT_CONTENT (or
    CUT_GAIN and CUT_GAIN_FLICKER times the median of the brightness steps
    between pictures that are not repeated) and CUT_SPIKE times the steps
    of frames f - 2, f - 1, f + 1 and f + 2 (a moving picture, a mover
    passing close, flicker change every frame), and frames f + 1 and f + 2
    differ from frames f - 2 and f - 1 by CUT_HOLDS of it (the change holds:
    not a flash or a dropped-out frame).
    """
    frames = np.asarray(frames, dtype=np.int64)
    step = np.asarray(step, dtype=np.float64).reshape(-1, 2)
    across = np.asarray(across, dtype=np.float64).reshape(-1, 2)
    out = []
    shown = step[step[:, 0] > REPEATED_PICTURE, 1]  # the brightness steps of new pictures (a freeze's are 0)
    flicker = float(np.median(shown)) if len(shown) else 0.0
    floor = np.array([CUT_CONTENT, max(CUT_GAIN, CUT_GAIN_FLICKER * flicker)])
    for k in range(2, len(frames) - 2):
        if frames[k + 2] - frames[k - 2] != 4:
            continue
        jump = step[k]
        around = np.max(step[[k - 2, k - 1, k + 1, k + 2]], axis=0)
        cut = (
            (jump >= floor)
            & (jump >= CUT_SPIKE * around)
            & (np.minimum(across[k + 1], across[k + 2]) >= CUT_HOLDS * jump)
        )
        if cut.any():
            out.append(Break("cut", int(frames[k]), 0.0))
    return out


def frozen_runs(
    frames: np.ndarray, change: np.ndarray, movers: np.ndarray, keyframe: np.ndarray | None = None
) -> list[Break]:
    """Frozen runs from each frame's largest change of a pixel since the previous frame (grey levels; frames
    consecutive to the previous one only), whether it holds a mover and whether it is a keyframe.

    A run of frames changing no pixel by more than STILL_LEVELS, most of
    them holding a mover, is a freeze when the frames just before and just
    after it change some pixel by MOVING_LEVELS or more: a still scene coded
    at a low rate repeats its pictures too, and a freeze where nothing moves
    cannot be told from it. A keyframe changing no pixel by MOVING_LEVELS
    may repeat the picture too, in a run REPEATED_SHARE of whose other
    frames change no pixel at all: a repeated picture coded afresh differs
    from the one before by the coding's noise (up to about 30 grey levels
    at crf 20), and the frames predicted from it converge on it, repeating
    it exactly; a still scene's noise, coded again each frame, changes
    some pixel by 1-10 levels in most frames (crf 35).
    """
    still = change <= STILL_LEVELS
    recoded = np.zeros(len(change), dtype=bool)
    if keyframe is not None:
        recoded = np.asarray(keyframe, dtype=bool) & ~still & (change < MOVING_LEVELS)
        still = still | recoded
    moving = change >= MOVING_LEVELS
    out = []
    k = 0
    while k < len(frames):
        if not still[k]:
            k += 1
            continue
        run = k
        while run + 1 < len(frames) and still[run + 1] and frames[run + 1] == frames[run] + 1:
            run += 1
        framed = k >= 1 and run + 1 < len(frames) and moving[k - 1] and moving[run + 1]
        if (
            framed
            and frames[k - 1] == frames[k] - 1
            and frames[run + 1] == frames[run] + 1
            and movers[k : run + 1].mean() >= 0.5
            and (not recoded[k : run + 1].any() or _repeats_exactly(change[k : run + 1][~recoded[k : run + 1]]))
        ):
            out.append(Break("frozen", int(frames[k]), float(run - k + 1)))
        k = run + 1
    return out


class KeyframeMeter:
    """Where between the keyframes the scan stage reads a cut may lie, from the keyframes' small planes.

    ``feed(index, gray)`` each keyframe read, in order within a pass (a
    keyframe before the last one fed starts another pass: the coarse pass
    reads the keyframes between in a second one); ``suspects()`` the
    (previous keyframe, keyframe) pairs to read between
    (``keyframe_suspects``), of every pass. Per keyframe it keeps three
    numbers, and the last keyframe's small plane.
    """

    def __init__(self) -> None:
        import cv2

        self._cv2 = cv2
        self._passes: list[tuple[list[int], list[tuple[float, float]]]] = []
        self._last: tuple[int, np.ndarray, float] | None = None

    def feed(self, index: int, gray: np.ndarray) -> None:
        """One keyframe's luma plane (H, W, uint8) and its 0-based frame."""
        small, mean = _small_plane(self._cv2, gray)
        if self._last is None or self._last[0] >= index or self._last[1].shape != small.shape:
            self._passes.append(([index], []))
        else:
            frames, steps = self._passes[-1]
            frames.append(index)
            steps.append(_picture_change(self._last, (index, small, mean)))
        self._last = (index, small, mean)

    def suspects(self) -> list[tuple[int, int]]:
        """(previous keyframe, keyframe) pairs, 0-based frames, between which a cut may lie, in frame order; the
        brightness steps are judged against the flicker of every pass's steps together (``keyframe_flicker``)."""
        steps = [np.array(s, dtype=np.float64).reshape(-1, 2) for _, s in self._passes]
        flicker = keyframe_flicker(np.concatenate(steps)) if steps else 0.0
        found = {pair for (frames, _), s in zip(self._passes, steps) for pair in keyframe_suspects(frames, s, flicker)}
        return sorted(found)


def keyframe_flicker(step: np.ndarray) -> float:
    """The video's flicker between keyframes read: the 90th percentile of their brightness steps (|log ratio|;
    ``step`` (N, 2) as ``keyframe_suspects`` takes it), 0 without any. The long fixtures' light (6 % flicker)
    steps by 0.08-0.13 at that percentile between keyframes 2-4 s apart, and by at most 1.6 times it where a step
    stands out of its neighbours'; a restart in other light steps once by more."""
    gains = np.asarray(step, dtype=np.float64).reshape(-1, 2)[:, 1]
    return float(np.percentile(gains, 90)) if len(gains) else 0.0


def keyframe_suspects(frames: list[int], step: np.ndarray, flicker: float = 0.0) -> list[tuple[int, int]]:
    """Pairs of consecutive keyframes read (0-based ``frames``, in order) whose change of picture (``step``
    (len(frames) - 1, 2): content %, brightness |log ratio| from each keyframe to the next) may hide a cut: at least
    SUSPECT_CONTENT, or SUSPECT_GAIN and SUSPECT_GAIN_FLICKER times the video's ``flicker`` (``keyframe_flicker``),
    and KEYFRAME_SPIKE times the change into the pair's first keyframe and out of its second (those that exist).

    A suspect is only a place to read every frame: the PictureMeter judges it (``scene_cuts``).
    """
    step = np.asarray(step, dtype=np.float64).reshape(-1, 2)
    floor = np.array([SUSPECT_CONTENT, max(SUSPECT_GAIN, SUSPECT_GAIN_FLICKER * flicker)])
    out = []
    for k in range(len(step)):
        around = [step[j] for j in (k - 1, k + 1) if 0 <= j < len(step)]
        spike = np.all([step[k] >= KEYFRAME_SPIKE * a for a in around], axis=0) if around else np.ones(2, bool)
        if ((step[k] >= floor) & spike).any():
            out.append((int(frames[k]), int(frames[k + 1])))
    return out


def still_packet_runs(sizes: np.ndarray, keyframe: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) runs (0-based frames) of at least STILL_RUN frames whose packets are inter-coded and at most
    STILL_PACKET of the median inter-coded packet (bytes): a picture repeated codes to almost nothing.

    A run is only a place to read every frame: the PictureMeter judges it (``frozen_runs``).
    """
    sizes = np.asarray(sizes, dtype=np.float64)
    keyframe = np.asarray(keyframe, dtype=bool)
    inter = sizes[~keyframe]
    if len(inter) == 0:
        return []
    tiny = np.concatenate([[False], (sizes <= STILL_PACKET * float(np.median(inter))) & ~keyframe, [False]])
    edges = np.flatnonzero(np.diff(tiny.astype(np.int8)))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True) if b - a >= STILL_RUN]


def check_spans(
    suspects: list[tuple[int, int]], windows: tuple[tuple[int, int], ...], n_frames: int
) -> tuple[tuple[int, int], ...]:
    """[start, stop) spans of 0-based frames to read so that the PictureMeter judges each suspect (a [start, stop)
    span, keyframe pair or still run): each widened by CHECK_MARGIN frames, clipped to the video, those inside a
    window left out (read anyway), merged."""
    spans = []
    for start, stop in suspects:
        a, b = max(0, start - CHECK_MARGIN), min(n_frames, stop + CHECK_MARGIN)
        if b > a and not any(w0 <= a and b <= w1 for w0, w1 in windows):
            spans.append((a, b))
    return tuple(merge_windows(spans))


def _repeats_exactly(change: np.ndarray) -> bool:
    """Whether REPEATED_SHARE or more of these frames change no pixel (grey levels since the previous frame)."""
    return len(change) > 0 and bool(np.count_nonzero(change == 0) >= REPEATED_SHARE * len(change))
