"""The scan stage: where in a camera's video the track stage must read every frame (``scan.json``).

For a camera whose movers the track stage detects (blob kind) in its own
video, with ``[track] scan = "auto"`` (the default): the coarse pass
(sync/scan.py) reads the keyframes only, finds when the target is in view
and writes the windows of frames the track stage then reads in full; or,
with the reason, that every frame is to be read (``"full"``: a short video,
no packet index, an ambiguous coarse line, ...). With ``scan = "full"`` the
stage does not run and the track stage reads every frame.

Its cache key holds the camera and the trajectory; the track stage's holds
only scan.json, so a changed calibration re-runs this pass (about a tenth
of decoding the video) and the track stage only when the windows change.
"""

from __future__ import annotations

import json
from typing import Any

from pathlib import Path

import numpy as np

from calibration.camera import Camera, read_camera
from tlsync_pipeline.pipeline.spec import StageSpec
from tlsync_pipeline.pipeline.stages.cameras import scans
from tlsync_pipeline.pipeline.workspace import StageFiles
from tlsync_pipeline.sync.params import SyncParams
from tlsync_pipeline.sync.registry import params_from_table, params_table
from tlsync_pipeline.sync.scan import COARSE_STEPS_S, ScanPlan, before_coarse, coarse_stride, full_scan, plan_scan
from tlsync_pipeline.sync.synchronize import prepare_trajectory
from tlsync_pipeline.trajectory import Trajectory, read_trajectory
from trackers.detections import COLUMNS, Detections, make_detections
from trackers.tracking import detect_keyframe_movers
from trackers.video import frame_count, keyframe_indices, presentation_times, probe_video

SCAN_FORMAT = "tlsync-scan"


def scan_video(video: Path, camera: Camera, prepared: Trajectory, fps: float | None, params: SyncParams, parameters: dict | None = None) -> ScanPlan:
    """The scan of one video: every frame (with the reason) when the coarse pass would not pay, else its plan.

    The coarse pass reads keyframes about COARSE_STEPS_S[0] apart, and the
    ones between (about COARSE_STEPS_S[1] apart) only when those could not
    decide (too few on the line, a competing line, no line).

    prepared: the trajectory as the sync method prepares it; parameters:
    the blob detector's by name.
    """
    n_frames, keys = frame_count(video), keyframe_indices(video)
    why = before_coarse(camera, prepared, n_frames, keys, fps, params)
    if why is not None or n_frames is None or keys is None:
        return full_scan(n_frames if n_frames is not None else probe_video(video).n_frames, why or "no packet index")
    times = presentation_times(video)
    read = np.zeros(0, np.int64)
    found: list[Detections] = []
    plan = full_scan(n_frames, "no keyframe to read")
    for step in COARSE_STEPS_S:  # about 4 s apart; 2 s where those cannot decide
        more = np.setdiff1d(keys[:: coarse_stride(keys, n_frames, fps, step)], read)
        if len(more) == 0:
            continue
        found.append(detect_keyframe_movers(video, parameters, indices=more.tolist(), first_id=sum(len(f) for f in found)))
        read = np.union1d(read, more)
        movers = make_detections(np.concatenate([np.column_stack([getattr(f, c) for c in COLUMNS]) for f in found]))
        plan = plan_scan(camera, movers, prepared, fps, params, keys, n_frames, times, read=read)
        if not plan.undecided:
            break
    return plan


def run_scan(files: StageFiles, fps: float | None, sync: dict[str, Any], parameters: dict) -> dict:
    """The scan stage: ``scan.json`` (ScanPlan.to_dict) of the camera's video.

    fps: the project's for the camera (None: its camera.json's); sync: the
    [sync] table (eps_px, rate_sigma, p, seed, the method's trajectory);
    parameters: the blob detector's (the tracker table's ``parameters``).
    """
    params = params_from_table(sync)
    camera = read_camera(files.path("camera"), name=files.camera)
    prepared = prepare_trajectory(read_trajectory(files.path("trajectory")), params)
    plan = scan_video(files.path("video"), camera, prepared, fps or camera.fps, params, parameters)
    with files.write("scan") as tmp:
        tmp.write_text(json.dumps({"format": SCAN_FORMAT, **plan.to_dict()}, indent=1) + "\n", encoding="utf-8")
    return {**plan.to_dict(), "windows": len(plan.windows), "message": f"{files.output('scan')}: {plan.summary()}"}


SPEC = StageSpec(
    "scan",
    inputs=lambda src, cam: {"video": src.project.camera(cam)["video"], "camera": src.artefact("camera", cam), "trajectory": src.artefact("trajectory")},
    params=lambda project, cam, options: {
        "fps": project.camera(cam)["fps"],
        "sync": params_table(project.sync),
        "parameters": project.camera(cam)["tracker"]["parameters"],
    },
    outputs=("scan",),
    run=run_scan,
    per_camera=True,
    applies=scans,
)
