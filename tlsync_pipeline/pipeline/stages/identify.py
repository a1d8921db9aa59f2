"""The identify stage: a camera's every mover in, its target's track.csv and identification.json out.

For a camera whose track stage detected every mover (blob kind), or that
brings its own ``detections = ...``: the trajectory, projected into the
camera, picks the target among the movers (sync/identify/identify.py). An init box
seeds the identity: the tracklet in it at the init frame is preferred. The
identified target's ``track.csv`` then serves the vote, sync, export and
render stages as any track does; ``identification.json`` holds the summary
that sync writes into timeline.json, or the reason the target could not be
identified (the camera is then listed as not synchronized, the others are).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

from calibration.camera import read_camera
from tlsync_pipeline.artefacts.identification import IdentificationRecord, write_identification
from tlsync_pipeline.artefacts.video_info import read_video_info
from tlsync_pipeline.errors import SyncError
from tlsync_pipeline.pipeline.spec import Options, Sources, StageResult, StageSpec
from tlsync_pipeline.pipeline.stages.cameras import has_no_rows, ingest_report_input, log_model_of, pose_problem
from tlsync_pipeline.pipeline.workspace import Artefact, StageFiles
from tlsync_pipeline.sync.identify.breaks import identify_in_segments
from tlsync_pipeline.sync.identify.followers import picked_line
from tlsync_pipeline.sync.identify.identify import IdentifyParams, identify_params
from tlsync_pipeline.sync.model.log_model import LogModelChoice
from tlsync_pipeline.sync.model.methods import preparation_of, prepare_trajectory
from tlsync_pipeline.sync.model.params import Preparation
from tlsync_pipeline.sync.vote.log_error import gate_model, vote_radius
from tlsync_pipeline.sync.vote.visits import near_views
from tlsync_pipeline.trajectory import read_trajectory
from trackers.detections import read_detections, seed_tracklets
from trackers.track import write_track
from trackers.video import check_init_box, probe_video

if TYPE_CHECKING:
    from tlsync_pipeline.pipeline.project import Project


@dataclass(frozen=True)
class InitSeed:
    """The blob tracker's init box [x, y, w, h] (pixels) and its 0-based frame: the mover in it is preferred as the
    target.
    """

    box: tuple[float, float, float, float]
    frame: int


@dataclass(frozen=True)
class IdentifyStageParams:
    """fps: the camera's nominal frame rate (None: camera.json's); identify: identification's [sync] keys;
    preparation: how the trajectory is prepared; source: the video the movers were detected in (None: the
    project brings its detections); seed: an init box, or None; log_model: the log's error, which widens the
    camera's vote radius and gate (log_error.vote_radius); pick_start_s: the start the user picked between the
    identified mover and another on the target's path ([[cameras]] pick_start_s), or None."""

    fps: float | None
    identify: IdentifyParams
    preparation: Preparation
    source: Path | None = None
    seed: InitSeed | None = None
    log_model: LogModelChoice = field(default_factory=LogModelChoice)
    pick_start_s: float | None = None


def run_identify(files: StageFiles, params: IdentifyStageParams) -> StageResult:
    """The identify stage: ``track.csv`` of the identified target and ``identification.json``.

    A camera whose target cannot be identified (no mover in its video, none
    near the projected path) gets no track.csv and an identification.json
    holding why; the stage reports it as failed for that camera.
    """
    warnings: list[str] = []
    camera = read_camera(files.path("camera"), name=files.camera)
    logged = near_views(read_trajectory(files.path("trajectory")), [camera])
    prepared = prepare_trajectory(logged, params.preparation)
    seed = params.seed
    try:
        if (problem := pose_problem(camera)) is not None:
            raise problem
        if params.source is not None and has_no_rows(files.path("detections")):
            raise SyncError(f"{params.source}: the target was never found (no moving object in any frame)")
        detections = read_detections(files.path("detections"))
        if seed is not None:
            check_init_box(files.path("video"), probe_video(files.path("video")), list(seed.box), seed.frame)
        prefer = seed_tracklets(detections, list(seed.box), seed.frame) if seed is not None else frozenset()
        if seed is not None and not prefer:
            warnings.append(
                f"camera {files.camera}: no mover inside the init box {list(seed.box)} near frame {seed.frame}; the "
                f"target is identified without it"
            )
        radius = vote_radius(
            camera, prepared, params.identify.eps_px, gate_model(log_model_of(files, params.log_model), logged)
        )
        breaks = read_video_info(files.path("video_info")).breaks if files.has("video_info") else ()
        found, breaks = identify_in_segments(
            camera,
            detections,
            prepared,
            params.fps or camera.fps,
            replace(params.identify, eps_px=radius),
            prefer,
            breaks,
            picked_line(params.pick_start_s, params.fps or camera.fps, prepared.rate),
        )
    except SyncError as exc:
        files.output("track").unlink(missing_ok=True)
        with files.write("identification") as tmp:
            write_identification(IdentificationRecord(None, str(exc)), tmp)
        return StageResult(warnings=tuple(warnings), failed={files.camera_name: str(exc)})
    with files.write("track") as tmp:
        write_track(found.track, tmp)
    with files.write("identification") as tmp:
        write_identification(IdentificationRecord(found.summary(), breaks=breaks), tmp)
    seeded = f", seeded by the init box (tracklet {min(prefer)})" if prefer else ""
    lift = (
        f"; the log's point is {abs(found.lift_m):.2f} m {'above' if found.lift_m > 0 else 'below'} the movers' "
        f"centres, the track moved to it"
        if found.lift_m
        else ""
    )
    message = f"wrote {files.output('track')} ({len(found.track)} identified frames{seeded}{lift})"
    return StageResult(message, tuple(warnings), facts={"identified_frames": len(found.track)})


def identify_stage_params(project: Project, cam: str, options: Options) -> IdentifyStageParams:
    camera = project.camera(cam)
    tracker = camera.tracker
    seed = (
        InitSeed(tracker.init, tracker.init_frame) if camera.detections is None and tracker.init is not None else None
    )
    source = camera.video if camera.detections is None else None
    return IdentifyStageParams(
        camera.fps,
        identify_params(project.sync),
        preparation_of(project.sync),
        source,
        seed,
        project.target.log_error.for_vote_radius,
        camera.pick_start_s,
    )


def identify_inputs(src: Sources, cam: str) -> dict[str, Path | Artefact]:
    """The camera, its movers and the trajectory; with an init box, the video it is checked against."""
    camera = src.project.camera(cam)
    inputs = {
        "camera": src.artefact("camera", cam),
        "detections": src.artefact("detections", cam),
        "trajectory": src.artefact("trajectory"),
    }
    if camera.detections is None and camera.tracker.init is not None and camera.video is not None:
        inputs["video"] = camera.video
    if src.made("video_info", cam):
        inputs["video_info"] = src.artefact("video_info", cam)  # the breaks the track stage found
    return {**inputs, **ingest_report_input(src)}


SPEC = StageSpec(
    "identify",
    inputs=identify_inputs,
    params=identify_stage_params,
    outputs=("track", "identification"),
    run=run_identify,
    per_camera=True,
    light=True,
    applies=lambda project, cam: project.camera(cam).brings_movers,
)
