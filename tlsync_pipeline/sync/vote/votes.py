"""The voting space (Brito et al., eq. 3).

A vote is a pair (t_c, t_r): a tracked frame t_c of one camera and a target
sample t_r whose projection into that camera lies within eps pixels of the
tracked position. Pairs are found with k-d trees, never with a full
frames x samples distance matrix.
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
    pairs = cKDTree(tracked).sparse_distance_matrix(projected_tree, eps_px, output_type="ndarray")
    if len(pairs) == 0:
        dist, nearest = projected_tree.query(tracked, k=1)
        k = int(np.argmin(dist))
        raise SyncError(
            f"camera {camera.name}: the target never comes within eps = {eps_px:g} px of its projection; "
            f"the closest is {dist[k]:.1f} px (frame {track.frame[k]}, sample {sample[nearest[k]]:g}). "
            "Check the camera pose and the track, or raise [sync] eps_px"
        )
    return Votes(
        frame=track.frame[pairs["i"]].astype(np.float64),
        sample=sample[pairs["j"]],
        dist=pairs["v"].astype(np.float64),
    )


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
