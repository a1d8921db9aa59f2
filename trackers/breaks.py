"""Breaks in a recording: where its frames stop following one steady clock.

Recorders drop frames under load, repeat a frame when the encoder stalls
and cut recordings into pieces. Two sources are read here, both while the
video is read anyway:

- the container's presentation times (``container_breaks``): an interval
  more than ``GAP`` nominal intervals long is a ``gap`` (frames missing, or
  a recording cut and restarted), one under ``REPEAT`` of it a ``repeat``
  (times standing still or stepping back);
- the pictures (``FreezeMeter``, fed the luma frames the tracker reads): a
  frame where no pixel differs from the previous frame's by more than
  ``STILL_LEVELS`` grey levels (the coding noise of the same picture encoded
  twice) between frames where some pixel changes by ``MOVING_LEVELS`` or
  more (something moved, or the sensor's noise), while the picture holds a
  mover (a blob off the background: the stalled picture still shows it), is
  ``frozen``: the same picture again, while the clock went on
  (``frozen_runs``). A still scene without a mover, coded at a low rate,
  repeats its pictures too: the target leaving the view and coming back is
  not a freeze.

A drop that leaves neither trace (frames missing, times re-stamped) shows
only against the target's path: tlsync_pipeline/sync/identify/breaks.py finds it in
the votes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

GAP = 1.5  # an interval between presentation times longer than this many nominal intervals is a gap
REPEAT = 0.5  # one shorter than this share of the nominal interval is a repeat
STILL_LEVELS = 20  # grey levels: a frame no pixel of which differs from the previous frame's by more may repeat it
MOVING_LEVELS = 40  # ... when the frames before and after it change some pixel by this much or more

KINDS = ("gap", "repeat", "frozen", "drop")


@dataclass(frozen=True)
class Break:
    """A place where a camera's frames leave its steady clock.

    kind: "gap" (presentation times jump forward), "repeat" (times stand
    still or step back), "frozen" (the same picture repeated), "drop" (the
    target's path jumps: frames missing without a trace in the container);
    frame: the first 0-based frame after the break (for "frozen": the first
    repeated picture); size: frames, missing (gap, drop; negative: the
    clock stepped back) or repeated (frozen, repeat).
    """

    kind: str
    frame: int
    size: float

    def describe(self) -> str:
        """The break in words: "frozen 25 frames at frame 412"."""
        what = {"gap": "gap of", "repeat": "repeated times over", "frozen": "frozen", "drop": "jump of"}[self.kind]
        return f"{what} {self.size:.3g} frame{'' if abs(self.size) == 1 else 's'} at frame {self.frame}"

    def to_dict(self) -> dict:
        return {"kind": self.kind, "frame": self.frame, "size": round(float(self.size), 3)}

    @classmethod
    def from_dict(cls, entry: dict) -> Break:
        return cls(str(entry["kind"]), int(entry["frame"]), float(entry["size"]))


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


class FreezeMeter:
    """Frozen frames of a video, measured on the luma frames as they are read.

    ``feed(index, gray, movers)`` each frame in order (a frame not
    consecutive to the previous one starts afresh); ``breaks()`` the frozen
    runs.
    """

    def __init__(self) -> None:
        import cv2  # here, not at the module's top: timeline.json's reader imports Break, and start-up loads no OpenCV

        self._absdiff = cv2.absdiff
        self._last: tuple[int, np.ndarray] | None = None
        self._frames: list[int] = []
        self._change: list[int] = []
        self._movers: list[bool] = []

    def feed(self, index: int, gray: np.ndarray, movers: bool) -> None:
        """One luma frame (H, W, uint8) with its 0-based index, and whether the detector found a mover in it."""
        if self._last is not None and self._last[0] == index - 1 and self._last[1].shape == gray.shape:
            self._frames.append(index)
            self._change.append(int(self._absdiff(gray, self._last[1]).max()))
            self._movers.append(movers)
        self._last = (index, gray)

    def breaks(self) -> list[Break]:
        """The frozen runs: ``frozen`` breaks at their first repeated frame, of their length in frames."""
        return frozen_runs(
            np.array(self._frames, dtype=np.int64),
            np.array(self._change, dtype=np.int64),
            np.array(self._movers, dtype=bool),
        )


def frozen_runs(frames: np.ndarray, change: np.ndarray, movers: np.ndarray) -> list[Break]:
    """Frozen runs from each frame's largest change of a pixel since the previous frame (grey levels; frames
    consecutive to the previous one only) and whether it holds a mover.

    A run of frames changing no pixel by more than STILL_LEVELS, most of
    them holding a mover, is a freeze when the frames just before and just
    after it change some pixel by MOVING_LEVELS or more: a still scene coded
    at a low rate repeats its pictures too, and a freeze where nothing moves
    cannot be told from it.
    """
    still = change <= STILL_LEVELS
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
        ):
            out.append(Break("frozen", int(frames[k]), float(run - k + 1)))
        k = run + 1
    return out
