"""The vote stage: one camera's votes (paper eq. 3) into ``votes.npz``."""

from __future__ import annotations

import numpy as np

from calibration.camera import read_camera
from tlsync_pipeline.errors import SyncError
from tlsync_pipeline.pipeline.spec import StageSpec
from tlsync_pipeline.pipeline.workspace import StageFiles
from tlsync_pipeline.sync.votes import Votes, compute_votes, save_votes
from tlsync_pipeline.trajectory import read_trajectory
from trackers.track import read_track


def run_vote(files: StageFiles, eps_px: float) -> dict:
    """The vote stage: every (frame, sample) pair within eps_px, saved to ``votes.npz``.

    A camera without any vote is not an error here: the reason is saved and
    the sync stage lists the camera as not synchronized.
    """
    cam = read_camera(files.path("camera"), name=files.camera)
    try:
        votes = compute_votes(cam, read_track(files.path("track")), read_trajectory(files.path("trajectory")), eps_px)
        error = None
    except SyncError as exc:
        votes, error = Votes(np.zeros(0), np.zeros(0), np.zeros(0)), str(exc)
    save_votes(files.output("votes"), votes, error)
    return {"votes": len(votes), **({"error": error} if error else {})}


SPEC = StageSpec(
    "vote",
    inputs=lambda src, cam: {"camera": src.artefact("camera", cam), "track": src.artefact("track", cam), "trajectory": src.artefact("trajectory")},
    params=lambda project, cam, options: {"eps_px": project.sync.eps_px},
    outputs=("votes",),
    run=run_vote,
    per_camera=True,
)
