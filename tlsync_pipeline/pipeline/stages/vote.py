"""The vote stage: one camera's votes (paper eq. 3) into ``votes.npz``, on the trajectory the sync method fits.

A camera whose target could not be identified among its movers (identify
stage) gets no votes, with that reason.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from calibration.camera import read_camera
from tlsync_pipeline.errors import SyncError
from tlsync_pipeline.pipeline.spec import Sources, StageSpec
from tlsync_pipeline.pipeline.stages.cameras import has_no_rows, read_identification
from tlsync_pipeline.pipeline.workspace import StageFiles
from tlsync_pipeline.sync.methods import CameraInput
from tlsync_pipeline.sync.registry import params_from_table, vote_table
from tlsync_pipeline.sync.synchronize import cast_votes, prepare_trajectory
from tlsync_pipeline.sync.votes import Votes, save_votes
from tlsync_pipeline.trajectory import read_trajectory
from trackers.track import read_track


def run_vote(files: StageFiles, source: Path | None = None, **params: Any) -> dict:
    """The vote stage: every (frame, sample) pair within eps_px, saved to ``votes.npz``.

    params: the ``[sync]`` keys the votes depend on (sync.registry.vote_table). The votes are cast on the trajectory as the
    chosen sync method prepares it (smoothed, for "refined"): they are the
    votes the sync stage fits and render draws. A camera without any vote is
    not an error here: the reason is saved and the sync stage lists the
    camera as not synchronized. So is a camera whose track stage found the
    target in no frame of ``source`` (its video; None when the project
    brings the track).
    """
    sync_params = params_from_table(params)
    camera = read_camera(files.path("camera"), name=files.camera)
    try:
        if files.has("identification") and isinstance(found := read_identification(files.path("identification")), SyncError):
            raise found
        if source is not None and has_no_rows(files.path("track")):
            raise SyncError(f"{source}: the target was never found (the track stage found it in no frame)")
        prepared = prepare_trajectory(read_trajectory(files.path("trajectory")), sync_params)
        votes = cast_votes(CameraInput(camera, read_track(files.path("track")), None), prepared, sync_params)
        error = None
    except SyncError as exc:
        votes, error = Votes(np.zeros(0), np.zeros(0), np.zeros(0)), str(exc)
    save_votes(files.output("votes"), votes, error)
    return {"votes": len(votes), **({"error": error} if error else {})}


def vote_inputs(src: Sources, cam: str) -> dict:
    """The camera, its track and the trajectory; for a camera identified among its movers, the identification too."""
    inputs = {"camera": src.artefact("camera", cam), "track": src.artefact("track", cam), "trajectory": src.artefact("trajectory")}
    if src.made("identification", cam):
        inputs["identification"] = src.artefact("identification", cam)
    return inputs


def _tracked_video(project, cam: str) -> Path | None:
    """The video the track stage tracks this camera's target in (None when the project brings the track)."""
    spec = project.camera(cam)
    return spec.get("video") if spec["track"] is None else None


SPEC = StageSpec(
    "vote",
    inputs=vote_inputs,
    params=lambda project, cam, options: {**vote_table(project.sync), "source": _tracked_video(project, cam)},
    outputs=("votes",),
    run=run_vote,
    per_camera=True,
    light=True,
)
