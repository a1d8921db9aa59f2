"""The blob detector's per-pixel passes, compiled (numba): one pass over the pixels where OpenCV took several.

A frame of the background model and each candidate's refinement were chains
of whole-array OpenCV and numpy calls (difference, absolute value,
threshold, masks, histogram, clipping, moments), each a pass over the
pixels and a Python call; on a 1080p crowd frame their calls cost more than
their arithmetic. Here each is one or two compiled loops with no
temporaries. The arithmetic is the same (float32 pixels, float64 sums).

Conventions: images are (rows, columns) arrays; grey levels; masks are
uint8, non-zero where set.
"""

from __future__ import annotations

from typing import Any

import numba
import numpy as np

_COMPILE: dict[str, Any] = {"nogil": True, "cache": True}

DECILE_BINS = 512  # histogram of the differences for their 90th percentile: grey levels
DECILE_RANGE = (2.0**-20, 512.0)  # positive values only


@numba.njit(fastmath={"reassoc"}, **_COMPILE)
def frame_gain(small: np.ndarray, background: np.ndarray, mask: np.ndarray) -> float:
    """Frame mean / background mean over the mask's pixels of every other row (1.0 when there are none).

    Branch-free, the frame's sum in integers and the background's in float64
    summed in any order (``reassoc``), so that the loop vectorises.
    """
    frame_sum = np.int64(0)
    background_sum = 0.0
    for y in range(0, small.shape[0], 2):
        for x in range(small.shape[1]):
            selected = mask[y, x] != 0
            frame_sum += np.int64(small[y, x]) if selected else 0
            background_sum += np.float64(background[y, x]) if selected else 0.0
    return frame_sum / background_sum if background_sum > 0 else 1.0


@numba.njit(**_COMPILE)
def halve(image: np.ndarray, out: np.ndarray) -> None:
    """out = the 8-bit image area-averaged by 2 (out's shape; each 2 x 2 mean rounded half up, as OpenCV's INTER_AREA by
    2).
    """
    for y in range(out.shape[0]):
        top = image[2 * y]
        bottom = image[2 * y + 1]
        row = out[y]
        for x in range(out.shape[1]):
            total = (
                np.uint16(top[2 * x])
                + np.uint16(top[2 * x + 1])
                + np.uint16(bottom[2 * x])
                + np.uint16(bottom[2 * x + 1])
            )
            row[x] = np.uint8((total + 2) >> 2)


@numba.njit(**_COMPILE)
def third(image: np.ndarray, out: np.ndarray) -> None:
    """out = the 8-bit image area-averaged by 3 (out's shape; each 3 x 3 mean rounded to the nearest level, as
    OpenCV's INTER_AREA by 3: a sum of nine levels is never a tie).
    """
    for y in range(out.shape[0]):
        top = image[3 * y]
        middle = image[3 * y + 1]
        bottom = image[3 * y + 2]
        row = out[y]
        for x in range(out.shape[1]):
            c = 3 * x
            total = (
                np.uint16(top[c])
                + np.uint16(top[c + 1])
                + np.uint16(top[c + 2])
                + np.uint16(middle[c])
                + np.uint16(middle[c + 1])
                + np.uint16(middle[c + 2])
                + np.uint16(bottom[c])
                + np.uint16(bottom[c + 1])
                + np.uint16(bottom[c + 2])
            )
            row[x] = np.uint8((total + 4) // 9)


@numba.njit(**_COMPILE)
def foreground(small, background, deviation, gain, threshold, min_contrast, diff, mask) -> None:
    """diff = small - gain x background; mask = 255 where |diff| > max(threshold x deviation, min_contrast), else 0."""
    g = np.float32(gain)
    t = np.float32(threshold)
    c = np.float32(min_contrast)
    for y in range(small.shape[0]):
        for x in range(small.shape[1]):
            d = np.float32(small[y, x]) - g * background[y, x]
            diff[y, x] = d
            mask[y, x] = 255 if abs(d) > max(t * deviation[y, x], c) else 0


@numba.njit(**_COMPILE)
def learn(small, diff, background, deviation, where, gain, rate) -> None:
    """Where ``where`` is set: background and mean absolute deviation move by ``rate`` toward the frame / gain and
    |diff|; deviation >= 1.
    """
    r = np.float32(rate)
    keep = np.float32(1.0 - rate)
    inverse_gain = np.float32(1.0 / gain)
    for y in range(small.shape[0]):
        for x in range(small.shape[1]):
            if where[y, x]:
                background[y, x] = keep * background[y, x] + r * (np.float32(small[y, x]) * inverse_gain)
                deviation[y, x] = max(keep * deviation[y, x] + r * abs(diff[y, x]), np.float32(1.0))


@numba.njit(**_COMPILE)
def learn_level(image, background, where, k, gain, rate) -> None:
    """Where the working frame's mask ``where`` (k times coarser than image) is set: background moves by rate toward
    image / gain.

    Pixels beyond the working frame's coverage (the frame cropped to a multiple of k) are left alone.
    Each row is updated whole (one branch-free loop, which vectorises), then
    the pixels of the mask's unset cells (the foreground: few) get their
    values back.
    """
    r = np.float32(rate)
    inverse_gain = np.float32(1.0 / gain)
    rows = min(where.shape[0], background.shape[0] // k)
    cols = min(where.shape[1], background.shape[1] // k)
    held = np.empty(cols, np.int64)  # the unset cells of a mask row
    kept = np.empty(cols * k, np.float32)  # their pixels' values in one level row, before the update
    for wy in range(rows):
        where_row = where[wy]
        n_held = 0
        for wx in range(cols):
            if not where_row[wx]:
                held[n_held] = wx
                n_held += 1
        for y in range(wy * k, wy * k + k):
            background_row = background[y]
            image_row = image[y]
            for i in range(n_held):
                for j in range(k):
                    kept[i * k + j] = background_row[held[i] * k + j]
            for x in range(cols * k):
                b = background_row[x]
                background_row[x] = b + r * (np.float32(image_row[x]) * inverse_gain - b)
            for i in range(n_held):
                for j in range(k):
                    background_row[held[i] * k + j] = kept[i * k + j]


@numba.njit(**_COMPILE)
def upper_decile(hist: np.ndarray) -> float:
    """The 90th percentile (numpy's linear rank) of values counted in DECILE_BINS bins over DECILE_RANGE; -1 if none."""
    total = hist.sum()
    if total <= 0:
        return -1.0
    lo, hi = DECILE_RANGE
    rank = 0.9 * (total - 1) + 0.5  # numpy's linear rank 0.9 (n - 1), as a position in the counts
    below = 0.0
    b = 0
    while below + hist[b] < rank and b < DECILE_BINS - 1:
        below += hist[b]
        b += 1
    return lo + (b + (rank - below) / hist[b]) * (hi - lo) / DECILE_BINS


@numba.njit(**_COMPILE)
def refine(labels, label, box, offset, diff, image, background, k, gain, noise, small_size):
    """Refine one connected component at an image level ``k`` times finer than the working frame.

    labels: component labels of a region starting at working pixel
    ``offset`` (x, y); box: the component's (x, y, w, h) in labels; diff: the
    working frame's difference to the background. The support is the
    component dilated by one working pixel, in its box grown by one (clipped
    to small_size (w, h)). On the level's window over the support: d = the
    difference of the blob's polarity (image - gain x background); top = the
    90th percentile of its positive values (every other row, a histogram to
    about a grey level); weights clip(d - low, 0, high - low) with low =
    max(top / 4, 3 noise), high = 0.6 top, so edge pixels count by how much
    the blob covers them. Returns (ok, polarity, contrast, area, x, y):
    polarity +1/-1, contrast the mean |diff| over the component, area the
    weights' sum / (high - low) (level pixels) and (x, y) their centroid in
    the level's pixels.
    """
    bx, by, bw, bh = box
    x0, y0 = bx + offset[0], by + offset[1]
    signed = 0.0
    absolute = 0.0
    count = 0
    for y in range(bh):
        for x in range(bw):
            if labels[by + y, bx + x] == label:
                d = diff[y0 + y, x0 + x]
                signed += d
                absolute += abs(d)
                count += 1
    if count == 0:
        return False, 1, 0.0, 0.0, 0.0, 0.0
    polarity = 1 if signed >= 0 else -1
    contrast = absolute / count
    gx0, gy0 = max(0, x0 - 1), max(0, y0 - 1)
    gx1, gy1 = min(small_size[0], x0 + bw + 1), min(small_size[1], y0 + bh + 1)
    height, width = gy1 - gy0, gx1 - gx0
    across = np.zeros((height, width), np.uint8)  # the component widened by one pixel to the left and right ...
    for y in range(bh):
        row = y0 + y - gy0
        for x in range(bw):
            if labels[by + y, bx + x] == label:
                column = x0 + x - gx0
                across[row, max(0, column - 1)] = 1
                across[row, column] = 1
                across[row, min(width - 1, column + 1)] = 1
    support = across.copy()  # ... then by one row up and down: dilated by one pixel (3 x 3), in the grown box
    for y in range(height):
        for x in range(width):
            if across[y, x]:
                if y > 0:
                    support[y - 1, x] = 1
                if y + 1 < height:
                    support[y + 1, x] = 1
    fx0, fy0 = gx0 * k, gy0 * k
    rows, cols = support.shape[0] * k, support.shape[1] * k
    p = np.float32(polarity)
    pg = np.float32(polarity * gain)
    lo, hi = DECILE_RANGE
    bin_width = (hi - lo) / DECILE_BINS
    hist = np.zeros(DECILE_BINS, np.float64)
    column_cell = np.empty(cols, np.int64)  # the support's column of each window column (no division per pixel)
    for x in range(cols):
        column_cell[x] = x // k
    for y in range(0, rows, 2):  # every other row: as good an estimate, half the work
        support_row = support[y // k]
        for x in range(cols):
            if support_row[column_cell[x]]:
                d = p * np.float32(image[fy0 + y, fx0 + x]) - pg * background[fy0 + y, fx0 + x]
                if lo <= d < hi:
                    hist[min(int((d - lo) / bin_width), DECILE_BINS - 1)] += 1
    top = upper_decile(hist)
    if top < 0:
        return False, polarity, contrast, 0.0, 0.0, 0.0
    low = max(0.25 * top, 3.0 * noise)
    high = 0.6 * top
    if high <= low:
        return False, polarity, contrast, 0.0, 0.0, 0.0
    span = np.float32(high - low)
    low32 = np.float32(low)
    m00 = 0.0
    m10 = 0.0
    m01 = 0.0
    for y in range(rows):
        support_row = support[y // k]
        for x in range(cols):
            if support_row[column_cell[x]]:
                d = p * np.float32(image[fy0 + y, fx0 + x]) - pg * background[fy0 + y, fx0 + x]
                w = min(max(d - low32, np.float32(0.0)), span)
                m00 += w
                m10 += w * x
                m01 += w * y
    if m00 <= 0:
        return False, polarity, contrast, 0.0, 0.0, 0.0
    return True, polarity, contrast, m00 / span, fx0 + m10 / m00, fy0 + m01 / m00
