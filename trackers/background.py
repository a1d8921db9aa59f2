"""A video's background model for every-mover detection, and its file (``background.npy``).

The scan stage samples it once; the track stage reads it back instead of
decoding the same frames again. The file holds the model exactly, so a
detector made from it is the one made from the frames.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from trackers.blob import BlobParams, median_background
from trackers.errors import TrackInputError
from trackers.video import sample_frames


@dataclass(frozen=True, eq=False)
class Background:
    """median: (H, W) per-pixel median of luma frames sampled over the video; deviation: (H, W) their mean absolute
    deviation from it (grey levels, float32)."""

    median: np.ndarray
    deviation: np.ndarray


def sample_background(path: str | Path, params: BlobParams) -> Background:
    """The background of ``path``: the median of params.background_frames luma frames spread over the video."""
    return sample_background_frames(path, params)[0]


def sample_background_frames(path: str | Path, params: BlobParams) -> tuple[Background, dict[int, np.ndarray]]:
    """The background of ``path`` (``sample_background``) and the luma frames it is the median of, by 0-based index:
    keyframes as a rule, which the scan's coarse pass then need not decode again."""
    frames = sample_frames(Path(path), params.background_frames, gray=True)
    median, deviation = median_background(list(frames.values()))
    return Background(median.astype(np.float32), deviation.astype(np.float32)), frames


def write_background(background: Background, path: str | Path) -> None:
    """Write ``background.npy``: a (2, H, W) float32 array, the median then the deviation (the same bytes for the same
    model, so a re-run that samples it again leaves the track stage fresh)."""
    with open(path, "wb") as handle:
        np.save(handle, np.stack([background.median, background.deviation]).astype(np.float32), allow_pickle=False)


def read_background(path: str | Path) -> Background:
    """Read ``background.npy``; TrackInputError naming the file when it is not a (2, H, W) float32 array."""
    try:
        planes = np.load(path, allow_pickle=False)
    except (OSError, ValueError) as exc:
        raise TrackInputError(f"{path}: not a background model ({exc})") from None
    if planes.dtype != np.float32 or planes.ndim != 3 or planes.shape[0] != 2:
        raise TrackInputError(f"{path}: not a background model (a (2, H, W) float32 array; got {planes.shape})")
    return Background(planes[0], planes[1])
