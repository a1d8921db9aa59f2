"""The vote stage: one camera's votes (paper eq. 3) into ``votes.npz``, on the trajectory the sync method fits.

A camera whose target could not be identified among its movers (identify
stage) gets no votes, with that reason.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from calibration.camera import read_camera
from tlsync_pipeline.artefacts.identification import read_identification
from tlsync_pipeline.errors import SyncError
from tlsync_pipeline.pipeline.spec import Options, Sources, StageResult, StageSpec
from tlsync_pipeline.pipeline.stages.cameras import has_no_rows, ingest_report_input, log_model_of, pose_problem
from tlsync_pipeline.pipeline.workspace import Artefact, StageFiles
from tlsync_pipeline.sync.model.log_model import LogModelChoice
from tlsync_pipeline.sync.model.methods import preparation_of, prepare_trajectory
from tlsync_pipeline.sync.model.params import Preparation
from tlsync_pipeline.sync.vote.log_error import gate_model, vote_radius
from tlsync_pipeline.sync.vote.visits import near_views
from tlsync_pipeline.sync.vote.votes import CameraVotes, Votes, compute_votes, write_votes
from tlsync_pipeline.trajectory import read_trajectory
from trackers.track import read_track

if TYPE_CHECKING:
    from tlsync_pipeline.pipeline.project import Project


@dataclass(frozen=True)
class VoteParams:
    """eps_px: vote radius (pixels, eq. 3); preparation: the trajectory the votes are cast on (the sync method's);
    source: the video the track stage tracked the target in (None when the project brings the track); log_model:
    the log's error, which widens the camera's vote radius (log_error.vote_radius)."""

    eps_px: float
    preparation: Preparation
    source: Path | None = None
    log_model: LogModelChoice = field(default_factory=LogModelChoice)


def run_vote(files: StageFiles, params: VoteParams) -> StageResult:
    """The vote stage: every (frame, sample) pair within eps_px, saved to ``votes.npz``.

    The votes are cast on the trajectory as the chosen sync method prepares
    it (smoothed, for "refined"): they are the votes the sync stage fits and
    render draws. A camera without any vote is not an error here: the reason
    is saved (the sync stage lists the camera as not synchronized) and the
    camera is reported as failed. So is a camera whose track stage found the
    target in no frame of its video.
    """
    camera = read_camera(files.path("camera"), name=files.camera)
    try:
        if (
            files.has("identification")
            and (failed := read_identification(files.path("identification")).error) is not None
        ):
            raise SyncError(failed)
        if (problem := pose_problem(camera)) is not None:
            raise problem
        if params.source is not None and has_no_rows(files.path("track")):
            raise SyncError(f"{params.source}: the target was never found (the track stage found it in no frame)")
        logged = near_views(read_trajectory(files.path("trajectory")), [camera])
        prepared = prepare_trajectory(logged, params.preparation)
        radius = vote_radius(camera, prepared, params.eps_px, gate_model(log_model_of(files, params.log_model), logged))
        votes = compute_votes(camera, read_track(files.path("track")), prepared, radius)
        error = None
    except SyncError as exc:
        votes, error = Votes(np.zeros(0), np.zeros(0), np.zeros(0)), str(exc)
    with files.write("votes") as tmp:
        write_votes(CameraVotes(votes, error), tmp)
    return StageResult(failed={files.camera_name: error} if error else {}, facts={"votes": len(votes)})


def vote_inputs(src: Sources, cam: str) -> dict[str, Path | Artefact]:
    """The camera, its track and the trajectory; for a camera identified among its movers, the identification too."""
    inputs = {
        "camera": src.artefact("camera", cam),
        "track": src.artefact("track", cam),
        "trajectory": src.artefact("trajectory"),
    }
    if src.made("identification", cam):
        inputs["identification"] = src.artefact("identification", cam)
    return {**inputs, **ingest_report_input(src)}


def vote_params(project: Project, cam: str, options: Options) -> VoteParams:
    camera = project.camera(cam)
    return VoteParams(
        project.sync.eps_px,
        preparation_of(project.sync),
        camera.video if camera.track is None else None,
        project.target.log_error.for_vote_radius,
    )


SPEC = StageSpec(
    "vote",
    inputs=vote_inputs,
    params=vote_params,
    outputs=("votes",),
    run=run_vote,
    per_camera=True,
    light=True,
)
