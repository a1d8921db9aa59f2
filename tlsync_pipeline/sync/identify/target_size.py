"""The target's size in metres, from the boxes of its tracked positions.

A tracked box of w x h pixels at depth z (metres, along the optical axis)
spans w z / f_x by h z / f_y metres. The target keeps its size in metres
while its image grows and shrinks with distance; a blob merged with a
passer-by does not (it is wider or taller), nor one cut by an occluder.

The reference size is a low quantile (SIZE_QUANTILE) of the sizes in
metres, not their median: in a crowd most of the target's blobs may be
merged with someone else's, all larger than the target alone. Fragments
(a few pixels of the target seen between occluders: less than
FRAGMENT_AREA of the median area) are left out of it first: a reference
that small would give every other box a slack that leaves the line free.
The area, not each side: when most blobs are merged side by side, the
target alone is less than half the median width but not a fragment.

The refinement uses it for a box slack: a box larger than the reference by
more than SLACK_TOLERANCE says the target is somewhere inside it, not at its
centre, so the residual of that frame is the distance from the projection
to the region where the target's centre can be, (box - reference) / 2 either
side of the box centre, and not to the centre itself. Identification
(sync/identify/identify.py) reports, for such a box, the target's own box: the part
of the blob nearest the projected path (``target_within``).
"""

from __future__ import annotations

import numpy as np

from calibration.camera import Camera
from tlsync_pipeline.trajectory import PiecewiseTrajectory

SIZE_QUANTILE = 0.1
SLACK_TOLERANCE = 1.15
FRAGMENT_AREA = (
    0.2  # a box of less than this share of the median area (in square metres) is a fragment, left out of the reference
)
MIN_SIZES = 8  # known sizes needed for a reference


def depth(camera: Camera, xyz: np.ndarray) -> np.ndarray:
    """(N,) depth of world points (N, 3) along the camera's optical axis, metres."""
    return (np.asarray(xyz, dtype=np.float64) @ camera.R.T + camera.t)[:, 2]


def depth_on_line(
    camera: Camera, path: PiecewiseTrajectory, clock: np.ndarray, alpha: float, beta: float
) -> np.ndarray:
    """(N,) depth (metres) of the target at each clock value's sample under the line clock = alpha * sample + beta; NaN
    off the path.
    """
    s = (np.asarray(clock, dtype=np.float64) - beta) / alpha
    run = path.run_of(s)
    z = np.full(len(s), np.nan)
    on = run >= 0
    if on.any():
        z[on] = depth(camera, path(s[on], run[on]))
    return z


def sizes_in_metres(camera: Camera, w: np.ndarray, h: np.ndarray, z: np.ndarray) -> np.ndarray:
    """(N, 2) box width and height in metres at depths z (NaN where a size or depth is unknown)."""
    return np.column_stack([np.asarray(w) * z / camera.K[0, 0], np.asarray(h) * z / camera.K[1, 1]])


def reference_size(metres: np.ndarray) -> np.ndarray | None:
    """(2,) the target's width and height in metres (SIZE_QUANTILE of the known sizes but fragments), or None with fewer
    than MIN_SIZES.
    """
    known = np.isfinite(metres).all(axis=1) & (metres > 0).all(axis=1)
    if known.sum() < MIN_SIZES:
        return None
    sizes = metres[known]
    area = sizes.prod(axis=1)
    whole = area >= FRAGMENT_AREA * np.median(area)
    if whole.sum() >= MIN_SIZES:
        sizes = sizes[whole]
    return np.quantile(sizes, SIZE_QUANTILE, axis=0)


def box_slack(camera: Camera, box_px: np.ndarray, z: np.ndarray, reference_m: np.ndarray) -> np.ndarray:
    """(N, 2) pixels either side of each box's centre where the target's centre may be (0 for a box of the target's size
    or less).
    """
    expected = reference_m[None, :] * np.array([camera.K[0, 0], camera.K[1, 1]]) / np.maximum(z, 1e-9)[:, None]
    slack = 0.5 * (box_px - SLACK_TOLERANCE * expected)
    return np.where(np.isfinite(slack) & (slack > 0), slack, 0.0)


def slack_on_line(
    camera: Camera, path: PiecewiseTrajectory, clock: np.ndarray, box_px: np.ndarray, alpha: float, beta: float
) -> np.ndarray | None:
    """(N, 2) box slack (pixels) of each box at the target's depth under the line clock = alpha * sample + beta.

    The reference size is taken from these boxes; None when they give none
    (fewer than MIN_SIZES boxes with a size on the path).
    """
    z = depth_on_line(camera, path, clock, alpha, beta)
    reference = reference_size(sizes_in_metres(camera, box_px[:, 0], box_px[:, 1], z))
    return None if reference is None else box_slack(camera, box_px, z, reference)


def beyond_slack(offset: np.ndarray, slack: np.ndarray) -> np.ndarray:
    """(N, 2) what is left of each offset (pixels, box centre to projection) outside the box's slack: the refinement's
    residual.
    """
    return np.sign(offset) * np.maximum(np.abs(offset) - slack, 0.0)


def target_within(
    xy: np.ndarray, box_px: np.ndarray, offset: np.ndarray, slack: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The target's centre and box (pixels) inside each blob: the part of the blob nearest the projection.

    xy: (N, 2) blob centres; box_px: (N, 2) blob sizes; offset: (N, 2) from
    each centre to the projection (non-finite: none, the centre is kept);
    slack: (N, 2) from box_slack. The centre moves toward the projection by
    at most the slack; the box shrinks by the slack on each side (a box of
    the target's size is kept as it is).
    """
    move = np.clip(np.where(np.isfinite(offset), offset, 0.0), -slack, slack)
    return xy + move, box_px - 2 * slack
