"""The tracked target's image velocity at each frame: the slope of a straight line through its pixels nearby."""

from __future__ import annotations

import numpy as np


def image_velocity(clock: np.ndarray, xy: np.ndarray, half_window: float) -> np.ndarray:
    """(N, 2) image velocity of the tracked target at each frame, pixels per clock unit: the slope of a straight line
    fitted to its pixels over the frames within ``half_window`` clock units of it; NaN where fewer than 3 frames are."""
    order = np.argsort(clock, kind="stable")
    t, xy = clock[order] - np.median(clock), xy[order]
    lo = np.searchsorted(t, t - half_window, "left")
    hi = np.searchsorted(t, t + half_window, "right")

    def window_sum(values: np.ndarray) -> np.ndarray:
        total = np.r_[0.0, np.cumsum(values)]
        return total[hi] - total[lo]

    n, s1, s2 = window_sum(np.ones(len(t))), window_sum(t), window_sum(t * t)
    spread = n * s2 - s1 * s1
    usable = (n >= 3) & (spread > 0)
    out = np.full((len(t), 2), np.nan)
    for axis in range(2):
        slope = n * window_sum(xy[:, axis] * t) - s1 * window_sum(xy[:, axis])
        out[usable, axis] = slope[usable] / spread[usable]
    return out[np.argsort(order)]
