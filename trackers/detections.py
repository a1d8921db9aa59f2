"""Every mover in one video and its ``detections.csv`` file.

One row per moving-object candidate per frame: frame (0-based decoded frame
index), time_s (presentation time, s), id (the tracklet the candidate is
linked into; candidates of one tracklet are one object followed over
frames), x, y (pixels, origin at the centre of the top-left pixel), w, h
(box size, pixels) and score (detection confidence in [0, 1]). A frame may
have several rows or none.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from trackers.errors import TrackInputError
from trackers.track import Track, check_indices, read_table

COLUMNS = ("frame", "time_s", "id", "x", "y", "w", "h", "score")
REQUIRED_COLUMNS = ("frame", "id", "x", "y")


@dataclass(frozen=True)
class Detections:
    """Candidates of every frame, sorted by frame then id.

    frame, id: int64 (N,); time_s, x, y, w, h, score: float64 (N,) (time_s,
    w, h NaN when unknown; score 1 when unknown).
    """

    frame: np.ndarray
    time_s: np.ndarray
    id: np.ndarray
    x: np.ndarray
    y: np.ndarray
    w: np.ndarray
    h: np.ndarray
    score: np.ndarray

    def __len__(self) -> int:
        return len(self.frame)

    @property
    def xy(self) -> np.ndarray:
        """(N, 2) pixel positions."""
        return np.column_stack([self.x, self.y])

    def tracklet_ids(self) -> np.ndarray:
        """Distinct tracklet ids, ascending."""
        return np.unique(self.id)

    def subset(self, rows: np.ndarray) -> Detections:
        """The given rows (indices or boolean mask), in frame order."""
        rows = np.flatnonzero(rows) if np.asarray(rows).dtype == bool else np.asarray(rows, dtype=np.int64)
        rows = rows[np.lexsort((self.id[rows], self.frame[rows]))]
        return Detections(*(getattr(self, c)[rows] for c in COLUMNS))

    def matching(self, track: Track, tolerance_px: float = 0.01) -> np.ndarray:
        """(N,) whether each row is the one an identified track took its position from: the rows a track was made of.

        The row of the track's frame whose box holds the track's position
        (widened by tolerance_px; a row without a size: its centre within
        tolerance_px), the nearest centre when several boxes do. An
        identified track may hold the target's part of a merged blob, not
        its centre.
        """
        out = np.zeros(len(self), dtype=bool)
        if not len(track):
            return out
        where = np.searchsorted(track.frame, self.frame).clip(0, len(track) - 1)
        same = track.frame[where] == self.frame
        dx, dy = np.abs(track.x[where] - self.x), np.abs(track.y[where] - self.y)
        half_w, half_h = (np.where(np.isfinite(s), s / 2, 0.0) + tolerance_px for s in (self.w, self.h))
        holds = np.flatnonzero(same & (dx <= half_w) & (dy <= half_h))
        if not len(holds):
            return out
        nearest = holds[np.lexsort((np.hypot(dx[holds], dy[holds]), self.frame[holds]))]
        out[nearest[np.r_[True, self.frame[nearest][1:] != self.frame[nearest][:-1]]]] = True
        return out

    def to_track(self, rows: np.ndarray) -> Track:
        """A single-target Track from rows with at most one per frame (indices or boolean mask)."""
        chosen = self.subset(rows)
        if len(np.unique(chosen.frame)) != len(chosen):
            raise ValueError("a track takes at most one detection per frame")
        time_s = chosen.time_s if np.isfinite(chosen.time_s).all() else None
        return Track(chosen.frame, chosen.x, chosen.y, time_s=time_s, w=chosen.w, h=chosen.h, score=chosen.score)


def follows_every_mover(kind: str, init, init_frame: int = 0) -> bool:
    """Whether a single-video request (``tlsync track-video``) means every mover (blob kind, no init box, from the first
    frame) rather than one target.
    """
    return kind == "blob" and init is None and init_frame == 0


SEED_FRAMES = 5  # frames either side of the init frame where a mover in the init box is looked for


def seed_tracklets(detections: Detections, box, init_frame: int) -> frozenset[int]:
    """The tracklet an init box [x, y, w, h] (pixels, top-left corner and size) points at in ``init_frame`` (0-based).

    The candidate whose centre lies inside the box, in the frame nearest
    init_frame (within SEED_FRAMES), nearest the box centre; empty when no
    mover is there (the target stood still, or the box is elsewhere).
    """
    x, y, w, h = (float(v) for v in box)
    near = np.abs(detections.frame - init_frame) <= SEED_FRAMES
    inside = near & (detections.x >= x) & (detections.x <= x + w) & (detections.y >= y) & (detections.y <= y + h)
    rows = np.flatnonzero(inside)
    if len(rows) == 0:
        return frozenset()
    order = np.lexsort(
        (
            np.hypot(detections.x[rows] - (x + w / 2), detections.y[rows] - (y + h / 2)),
            np.abs(detections.frame[rows] - init_frame),
        )
    )
    return frozenset({int(detections.id[rows[order[0]]])})


def make_detections(rows: list[tuple] | np.ndarray) -> Detections:
    """Detections from rows (frame, time_s, id, x, y, w, h, score), sorted by frame then id."""
    values = np.asarray(rows, dtype=np.float64).reshape(-1, len(COLUMNS))
    order = np.lexsort((values[:, 2], values[:, 0]))
    values = values[order]
    cols = {c: values[:, k] for k, c in enumerate(COLUMNS)}
    cols["frame"] = cols["frame"].astype(np.int64)
    cols["id"] = cols["id"].astype(np.int64)
    return Detections(**cols)


def read_detections(path: str | Path) -> Detections:
    """Read and validate ``detections.csv``; errors name the file and line.

    Required columns: frame, id, x, y; time_s, w, h, score are optional.
    """
    path = Path(path)
    optional = tuple(c for c in COLUMNS if c not in REQUIRED_COLUMNS)
    cols, lines = read_table(
        path, REQUIRED_COLUMNS, optional, f"a header '{','.join(COLUMNS)}' and one row per detection"
    )
    check_indices(path, "frame", cols["frame"], lines, "a 0-based integer frame index")
    check_indices(path, "id", cols["id"], lines, "a non-negative integer tracklet id")
    if len(lines) == 0:
        raise TrackInputError(f"{path}: no detection (a header but no row)")
    defaults = {"time_s": math.nan, "w": math.nan, "h": math.nan, "score": 1.0}
    detections = make_detections(
        np.column_stack([cols[c] if c in cols else np.full(len(lines), defaults[c]) for c in COLUMNS])
    )
    pairs = detections.frame * (int(detections.id.max()) + 1) + detections.id
    dup = np.flatnonzero(np.diff(pairs) == 0)
    if len(dup):
        k = dup[0]
        raise TrackInputError(f"{path}: tracklet {detections.id[k]} has two detections in frame {detections.frame[k]}")
    return detections


def write_detections(detections: Detections, path: str | Path) -> None:
    """Write ``detections.csv`` (all columns)."""
    fmt = ["%d", "%.6f", "%d", "%.4f", "%.4f", "%.2f", "%.2f", "%.4f"]
    with Path(path).open("w", newline="", encoding="utf-8") as handle:
        handle.write(",".join(COLUMNS) + "\n")
        if len(detections):
            np.savetxt(handle, np.column_stack([getattr(detections, c) for c in COLUMNS]), fmt=fmt, delimiter=",")
