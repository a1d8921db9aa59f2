"""One clock put onto another: a fine relative clock (a flight clock in ms, a video's subtitle times, a
device's power-on clock) and a coarse absolute one written beside it (whole-second UTC, a wall clock). Pure functions.

Each row has a fine time c and a coarse time w of the same instant. Within
a recording run the two differ by a constant: t = c + offset. A run ends
where the fine clock goes back or w - c jumps by more than ``break_s`` (a
pause, a restart, clips joined into one file).

- Coarse times with sub-second digits: offset = the median of w - c.
- Whole-second coarse times (the second the instant fell in, now and then a
  second off): each d = w - c lies in (offset - 1, offset]; the offset is
  the mean of the d values in the one-second window holding the most of
  them, plus half a second (the mean fraction of a second). It is good to
  half the widest gap between the rows' phases within a second (rows 0.1 s
  apart: 0.05 s; rows exactly 1 s apart, all at one phase: 0.5 s); time
  differences inside a run are exact.
"""

from __future__ import annotations

import numpy as np


def whole_second_offset(d: np.ndarray) -> float:
    """coarse - fine from d = whole-second coarse - fine: the mean of the densest one-second window of d, plus 0.5 s."""
    d = np.sort(d)
    counts = np.searchsorted(d, d + 1.0, side="left") - np.arange(len(d))
    j = int(np.argmax(counts))
    return float(d[j : j + counts[j]].mean() + 0.5)


def onto_coarse_clock(
    fine_s: np.ndarray, coarse_s: np.ndarray, whole_seconds: bool, break_s: float
) -> tuple[np.ndarray, np.ndarray]:
    """(fine times put on the coarse clock, the run each row belongs to, 0-based); see the module notes."""
    fine_s, coarse_s = np.asarray(fine_s, dtype=float), np.asarray(coarse_s, dtype=float)
    run = np.zeros(len(fine_s), dtype=int)
    if not len(fine_s):
        return fine_s.copy(), run
    d = coarse_s - fine_s
    breaks = np.flatnonzero((np.diff(fine_s) < 0) | (np.abs(np.diff(d)) > break_s)) + 1
    t = np.empty_like(fine_s)
    for k, rows in enumerate(np.split(np.arange(len(fine_s)), breaks)):
        run[rows] = k
        t[rows] = fine_s[rows] + (whole_second_offset(d[rows]) if whole_seconds else float(np.median(d[rows])))
    return t, run


def whole_second_uncertainty(fine_s: np.ndarray) -> float:
    """How far a whole-second anchor can be off (s): half the widest gap between the rows' phases within a second."""
    phases = np.sort(np.mod(np.asarray(fine_s, dtype=float), 1.0))
    if not len(phases):
        return 0.5
    gaps = np.diff(np.r_[phases, phases[0] + 1.0])
    return float(gaps.max() / 2)
