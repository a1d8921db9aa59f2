"""The vote stage: one camera's votes (paper eq. 3) into ``votes.npz``."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from calibration.camera import read_camera
from tlsync_pipeline.errors import SyncError
from tlsync_pipeline.sync.votes import Votes, compute_votes, save_votes
from tlsync_pipeline.trajectory import read_trajectory
from trackers.track import read_track


def run_vote(name: str, camera: Path, track: Path, trajectory: Path, eps_px: float, out: Path, source: Path | None = None) -> dict:
    """The vote stage: every (frame, sample) pair within eps_px, saved to ``votes.npz``.

    A camera without any vote is not an error here: the reason is saved and
    the sync stage lists the camera as not synchronized. So is a camera whose
    track stage found the target in no frame of ``source`` (its video).
    """
    cam = read_camera(camera, name=name)
    try:
        if source is not None and _no_tracked_frame(track):
            raise SyncError(f"{source}: the target was never found (the track stage found it in no frame)")
        votes = compute_votes(cam, read_track(track), read_trajectory(trajectory), eps_px)
        error = None
    except SyncError as exc:
        votes, error = Votes(np.zeros(0), np.zeros(0), np.zeros(0)), str(exc)
    save_votes(out, votes, error)
    return {"votes": len(votes), **({"error": error} if error else {})}


def _no_tracked_frame(track: Path) -> bool:
    """Whether a track.csv the track stage wrote holds its header and no row."""
    with open(track, encoding="utf-8") as handle:
        return sum(1 for line in handle if line.strip()) <= 1
