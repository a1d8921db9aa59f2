"""The scan stage: where in a camera's video the track stage must read every frame (``scan.json``).

For a camera whose movers the track stage detects (blob kind) in its own
video, with ``[track] scan = "auto"`` (the default): the coarse pass
(sync/identify/scan.py) reads the keyframes only, finds when the target is in view
and writes the windows of frames the track stage then reads in full; or,
with the reason, that every frame is to be read (``"full"``: a short video,
no packet index, an ambiguous coarse line, ...). With ``scan = "full"`` the
stage does not run and the track stage reads every frame.

Its cache key holds the camera and the trajectory; the track stage's holds
only scan.json, so a changed calibration re-runs this pass (about a tenth
of decoding the video) and the track stage only when the windows change.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from calibration.camera import Camera, read_camera
from calibration.errors import CalibrationInputError
from tlsync_pipeline.artefacts.scan import ScanPlan, write_scan
from tlsync_pipeline.errors import InputError, one_line
from tlsync_pipeline.pipeline.spec import Options, Sources, StageResult, StageSpec
from tlsync_pipeline.pipeline.stages.calibrate import CalibrateParams, survey_inputs, survey_params, survey_pose
from tlsync_pipeline.pipeline.stages.camera_plan import scan_pose, scans
from tlsync_pipeline.pipeline.workspace import Artefact, StageFiles
from tlsync_pipeline.sync.identify.identify import IdentifyParams, identify_params
from tlsync_pipeline.sync.identify.scan import (
    COARSE_STEPS_S,
    OffsetPrior,
    before_coarse,
    coarse_stride,
    full_scan,
    keyframe_range,
    margin_frames,
    plan_scan,
    prior_slope,
)
from tlsync_pipeline.sync.model.methods import preparation_of, prepare_trajectory
from tlsync_pipeline.sync.model.params import Preparation
from tlsync_pipeline.trajectory import Trajectory, read_trajectory
from trackers.background import Background, sample_background_frames, write_background
from trackers.breaks import KeyframeMeter, check_spans, still_packet_runs
from trackers.detections import COLUMNS, Detections, make_detections
from trackers.tracking import detect_keyframe_movers, movers_detector, movers_params
from trackers.video import frame_count, keyframe_indices, packet_sizes, presentation_times, probe_video

if TYPE_CHECKING:
    from tlsync_pipeline.pipeline.project import Project


def scan_video(
    video: Path,
    camera: Camera,
    prepared: Trajectory,
    fps: float | None,
    params: IdentifyParams,
    parameters: dict | None = None,
    prior: OffsetPrior | None = None,
    background: Background | None = None,
    decoded: dict[int, np.ndarray] | None = None,
) -> ScanPlan:
    """The scan of one video: every frame (with the reason) when the coarse pass would not pay, else its plan.

    The coarse pass reads keyframes about COARSE_STEPS_S[0] apart, and the
    ones between (about COARSE_STEPS_S[1] apart) only when those could not
    decide (too few on the line, a competing line, no line), with one
    detector (one background model) for both.

    prepared: the trajectory as the sync method prepares it; parameters:
    the blob detector's by name; prior: what the camera's clock says about
    its offset (the keyframes read are those where the log can be seen,
    ``keyframe_range``); None: every keyframe may show the target;
    background: the video's background model (None: sampled here);
    decoded: luma frames already decoded by index (the background's
    samples), not decoded again.
    """
    n_frames, keys = frame_count(video), keyframe_indices(video)
    why = before_coarse(camera, prepared, n_frames, keys, fps, params)
    if why is not None or n_frames is None or keys is None:
        return full_scan(n_frames if n_frames is not None else probe_video(video).n_frames, why or "no packet index")
    times = presentation_times(video)
    detector = movers_detector(video, parameters, background)
    keyframes = KeyframeMeter()
    read = np.zeros(0, np.int64)
    found: list[Detections] = []
    plan = full_scan(n_frames, "no keyframe to read")
    candidates = keys
    if prior is not None:
        lo, hi = keyframe_range(prepared, prior_slope(fps, prepared, params), prior, n_frames, margin_frames(fps, 0.0))
        candidates = keys[(keys >= lo) & (keys < hi)]
    for step in COARSE_STEPS_S:  # about 4 s apart; 2 s where those cannot decide
        more = np.setdiff1d(candidates[:: coarse_stride(keys, n_frames, fps, step)], read)
        if len(more) == 0:
            continue
        found.append(
            detect_keyframe_movers(
                video,
                indices=more.tolist(),
                first_id=sum(len(f) for f in found),
                detector=detector,
                meter=keyframes,
                decoded=decoded,
            )
        )
        read = np.union1d(read, more)
        movers = make_detections(np.concatenate([np.column_stack([getattr(f, c) for c in COLUMNS]) for f in found]))
        plan = plan_scan(camera, movers, prepared, fps, params, keys, n_frames, times, prior, read=read)
        if not plan.undecided:
            break
    return with_break_checks(plan, video, keyframes)


def with_break_checks(plan: ScanPlan, video: Path, keyframes: KeyframeMeter) -> ScanPlan:
    """The plan with the spans outside its windows where a break may lie (``checks``: a cut between two keyframes
    read, a run of packets coded to almost nothing), so that the track stage's PictureMeter judges them; a plan
    reading every frame as it is."""
    if plan.full:
        return plan
    packets = packet_sizes(video)
    suspects = keyframes.suspects() + (still_packet_runs(*packets) if packets is not None else [])
    return dataclasses.replace(plan, checks=check_spans(suspects, plan.windows, plan.n_frames))


@dataclass(frozen=True)
class ScanStageParams:
    """fps: the camera's nominal frame rate (None: camera.json's); identify: identification's [sync] keys (the
    coarse pass votes and searches as it does); preparation: how the trajectory is prepared; parameters: the
    blob detector's (the tracker table's ``parameters``)."""

    fps: float | None
    identify: IdentifyParams
    preparation: Preparation
    parameters: Mapping[str, float]
    survey: CalibrateParams | None = (
        None  # the surveyed pose's (GCPs, board) when the project brings no posed camera.json
    )


def run_scan(files: StageFiles, params: ScanStageParams) -> StageResult:
    """The scan stage: ``scan.json`` (ScanPlan.to_dict) of the camera's video.

    The pose it votes with is the camera.json the project brings, or the GCPs'
    or board's alone (survey_pose; the target may refine it later in calibrate):
    when they give none, every frame is read, with the reason.
    """
    prepared = prepare_trajectory(read_trajectory(files.path("trajectory")), params.preparation)
    video = files.path("video")
    background, samples = sample_background_frames(video, movers_params(video, dict(params.parameters)))
    if params.survey is None:
        camera = read_camera(files.path("camera"), name=files.camera)
        plan = scan_video(
            video,
            camera,
            prepared,
            params.fps or camera.fps,
            params.identify,
            dict(params.parameters),
            background=background,
            decoded=samples,
        )
    else:
        try:
            camera = survey_pose(files, params.survey)[0]
        except (InputError, CalibrationInputError) as exc:
            plan = full_scan(
                frame_count(video) or probe_video(video).n_frames,
                f"no pose to scan with ({one_line(str(exc))})",
            )
        else:
            plan = scan_video(
                video,
                camera,
                prepared,
                params.fps or camera.fps,
                params.identify,
                dict(params.parameters),
                background=background,
                decoded=samples,
            )
    with files.write("scan") as tmp:
        write_scan(plan, tmp)
    with files.write("background") as tmp:
        write_background(background, tmp)
    facts = {k: v for k, v in plan.to_dict().items() if k != "windows"}
    return StageResult(f"{files.output('scan')}: {plan.summary()}", facts={**facts, "windows": len(plan.windows)})


def scan_stage_params(project: Project, cam: str, options: Options) -> ScanStageParams:
    camera = project.camera(cam)
    survey = survey_params(project, cam) if scan_pose(project, cam) == "survey" else None
    return ScanStageParams(
        camera.fps, identify_params(project.sync), preparation_of(project.sync), camera.tracker.parameters, survey
    )


def scan_inputs(src: Sources, cam: str) -> dict[str, Path | Artefact]:
    """The camera's video, the trajectory, and its posed camera.json or the files of its surveyed
    pose (survey_inputs).
    """
    camera = src.project.camera(cam)
    assert camera.video is not None, "the stage applies to a camera with a video"
    pose = (
        {"camera": camera.camera}
        if scan_pose(src.project, cam) == "camera" and camera.camera is not None
        else survey_inputs(src, cam)
    )
    return {"video": camera.video, **pose, "trajectory": src.artefact("trajectory")}


SPEC = StageSpec(
    "scan",
    inputs=scan_inputs,
    params=scan_stage_params,
    outputs=("scan", "background"),
    run=run_scan,
    per_camera=True,
    heavy=True,
    applies=scans,
)
