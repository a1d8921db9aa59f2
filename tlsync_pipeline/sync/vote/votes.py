"""The voting space (Brito et al., eq. 3).

A vote is a pair (t_c, t_r): a tracked frame t_c of one camera and a target
sample t_r whose projection into that camera lies within eps pixels of the
tracked position. Pairs are found with k-d trees, never with a full
frames x samples distance matrix, a block of frames at a time.

A frame's votes come in runs of consecutive samples, one per pass of the
path near its tracked position. A slow or hovering target makes a run long
(2 eps over the path's pixels per sample), and a K times slower flight has K
times the frames with K times longer runs: its votes grow as K^2. A run
says where the line may cross that frame; its samples beyond
MAX_RUN_VOTES add memory, not information. A longer run keeps its closest
vote and every m-th sample (m = ceil(length / MAX_RUN_VOTES)), at a phase
that turns with the frame so that neighbouring frames keep the samples
between; the closest vote of each sample is kept too. The line search's
thinning (closest vote per frame and per sample) sees the same votes.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from calibration.camera import Camera
from tlsync_pipeline.errors import InputError, SyncError
from tlsync_pipeline.trajectory import Trajectory
from trackers.track import Track

MAX_RUN_VOTES = 48  # votes kept of one frame's run of consecutive samples (see the module)
FRAMES_PER_BLOCK = 512  # tracked frames whose votes are found at once (bounds the memory of a slow target's pairs)


@dataclass(frozen=True)
class Votes:
    """Candidate (frame, sample) pairs with their pixel distance.

    frame: float64 (M,) 0-based frame indices t_c; sample: float64 (M,)
    trajectory grid coordinates t_r; dist: float64 (M,) pixels.
    """

    frame: np.ndarray
    sample: np.ndarray
    dist: np.ndarray

    def __len__(self) -> int:
        return len(self.frame)


def project_trajectory(camera: Camera, trajectory: Trajectory) -> tuple[np.ndarray, np.ndarray]:
    """Projected pixels (K, 2) and grid coordinates (K,) of the samples the camera can image."""
    uv, valid = camera.project(trajectory.xyz)
    return uv[valid], trajectory.sample[valid]


def compute_votes(camera: Camera, track: Track, trajectory: Trajectory, eps_px: float) -> Votes:
    """Every (frame, sample) pair whose pixel distance is at most eps_px.

    Raises SyncError when there is no vote, naming the closest distance found.
    """
    uv, sample = project_trajectory(camera, trajectory)
    if len(uv) == 0:
        raise SyncError(
            f"camera {camera.name}: no trajectory sample projects into its image; "
            "check the camera pose (R, t) and that the trajectory is in the same world frame"
        )
    tracked = track.xy
    projected_tree = cKDTree(uv)
    blocks = [
        _block_votes(tracked[start : start + FRAMES_PER_BLOCK], start, projected_tree, sample, eps_px)
        for start in range(0, len(tracked), FRAMES_PER_BLOCK)
    ]
    rows, columns, dist = (np.concatenate([b[k] for b in blocks]) for k in range(3))
    if len(rows) == 0:
        dist, nearest = projected_tree.query(tracked, k=1)
        k = int(np.argmin(dist))
        raise SyncError(
            f"camera {camera.name}: the target never comes within eps = {eps_px:g} px of its projection; "
            f"the closest is {dist[k]:.1f} px (frame {track.frame[k]}, sample {sample[nearest[k]]:g}). "
            "Check the camera pose and the track, or raise [sync] eps_px"
        )
    return Votes(frame=track.frame[rows].astype(np.float64), sample=sample[columns], dist=dist)


def _block_votes(
    tracked: np.ndarray, first_row: int, projected_tree: cKDTree, sample: np.ndarray, eps_px: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The votes of a block of tracked positions (rows from first_row on) against the projected samples, each frame's
    long runs thinned (see the module): track rows, sample indices (into ``sample``) and pixel distances."""
    pairs = cKDTree(tracked).sparse_distance_matrix(projected_tree, eps_px, output_type="ndarray")
    row, column, dist = pairs["i"].astype(np.int64), pairs["j"].astype(np.int64), pairs["v"].astype(np.float64)
    keep = thinned_runs(row, column, sample, dist)
    return row[keep] + first_row, column[keep], dist[keep]


def thinned_runs(row: np.ndarray, column: np.ndarray, sample: np.ndarray, dist: np.ndarray) -> np.ndarray:
    """Which votes (frame rows, indices into the increasing grid samples ``sample``, pixel distances) are kept when
    each frame's runs of consecutive samples are thinned to about MAX_RUN_VOTES (see the module): a boolean mask."""
    keep = np.ones(len(row), dtype=bool)
    many = np.flatnonzero(np.bincount(row)[row] > MAX_RUN_VOTES) if len(row) else np.zeros(0, np.int64)
    if len(many) == 0:  # no frame has a run that long
        return keep
    key = row[many] * len(sample) + column[many]  # unique: a pair is found once
    order = many[np.argsort(key.astype(np.int32) if len(key) and key.max() < 2**31 else key)]
    row_o, sample_o, dist_o = row[order], sample[column[order]], dist[order]
    starts = np.flatnonzero(np.r_[True, (row_o[1:] != row_o[:-1]) | (np.diff(sample_o) > 1.5)])
    length = np.diff(np.r_[starts, len(order)])
    run = np.repeat(np.arange(len(starts)), length)
    step = np.repeat(-(-length // MAX_RUN_VOTES), length)
    position = np.arange(len(order)) - starts[run]
    closest_of_run = dist_o == np.minimum.reduceat(dist_o, starts)[run]
    keep[order] = (position % step == row_o % step) | closest_of_run
    by_sample = np.argsort(column)
    column_s = column[by_sample]
    first = np.flatnonzero(np.r_[True, column_s[1:] != column_s[:-1]])
    closest_of_sample = np.full(len(sample), np.inf)
    closest_of_sample[column_s[first]] = np.minimum.reduceat(dist[by_sample], first)
    return keep | (dist == closest_of_sample[column])


@dataclass(frozen=True)
class CameraVotes:
    """votes.npz: a camera's votes, or (error set, votes empty) why it has none."""

    votes: Votes
    error: str | None = None


def write_votes(found: CameraVotes, path: Path) -> None:
    """Write ``votes.npz``: frame, sample, dist arrays and, for a camera without votes, the reason."""
    with open(path, "wb") as handle:
        np.savez(
            handle,
            frame=found.votes.frame,
            sample=found.votes.sample,
            dist=found.votes.dist,
            error=np.array(found.error or ""),
        )


def read_votes(path: Path) -> CameraVotes:
    """Read ``votes.npz``."""
    try:
        with np.load(path) as data:
            return CameraVotes(Votes(data["frame"], data["sample"], data["dist"]), str(data["error"]) or None)
    except (OSError, KeyError, ValueError) as exc:
        raise InputError(f"{path}: not a tlsync votes file ({exc})") from None
