"""The vote stage: one camera's votes (paper eq. 3) into ``votes.npz``.

A camera that brings every mover (detections.csv) votes with every candidate.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from calibration.camera import read_camera
from tlsync_pipeline.errors import SyncError
from tlsync_pipeline.sync.identify import candidate_votes
from tlsync_pipeline.sync.votes import Votes, compute_votes, save_votes
from tlsync_pipeline.trajectory import read_trajectory
from trackers.detections import read_detections
from trackers.track import read_track


def run_vote(name: str, camera: Path, track: Path, trajectory: Path, eps_px: float, out: Path, detections: Path | None = None) -> dict:
    """The vote stage: every (frame, sample) pair within eps_px, saved to ``votes.npz``.

    A camera without any vote is not an error here: the reason is saved and
    the sync stage lists the camera as not synchronized.
    """
    cam = read_camera(camera, name=name)
    try:
        if detections is not None:
            votes, _ = candidate_votes(cam, read_detections(detections), read_trajectory(trajectory), eps_px)
        else:
            votes = compute_votes(cam, read_track(track), read_trajectory(trajectory), eps_px)
        error = None
    except SyncError as exc:
        votes, error = Votes(np.zeros(0), np.zeros(0), np.zeros(0)), str(exc)
    save_votes(out, votes, error)
    return {"votes": len(votes), **({"error": error} if error else {})}
