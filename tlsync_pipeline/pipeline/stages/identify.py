"""The identify stage: a camera's every mover in, its target's track.csv and identification.json out.

For a camera whose track stage detected every mover (blob kind), or that
brings its own ``detections = ...``: the trajectory, projected into the
camera, picks the target among the movers (sync/identify.py). An init box
seeds the identity: the tracklet in it at the init frame is preferred. The
identified target's ``track.csv`` then serves the vote, sync, export and
render stages as any track does; ``identification.json`` holds the summary
that sync writes into timeline.json, or the reason the target could not be
identified (the camera is then listed as not synchronized, the others are).
"""

from __future__ import annotations

import json
from dataclasses import asdict
from typing import Any

from calibration.camera import read_camera
from tlsync_pipeline.errors import SyncError
from tlsync_pipeline.pipeline.spec import StageSpec
from tlsync_pipeline.pipeline.stages.cameras import has_no_rows, tracks_every_mover
from tlsync_pipeline.pipeline.workspace import StageFiles
from tlsync_pipeline.sync.registry import params_from_table, params_table
from tlsync_pipeline.sync.synchronize import identify, prepare_trajectory
from tlsync_pipeline.trajectory import read_trajectory
from trackers.detections import read_detections, seed_tracklets
from trackers.track import write_track
from trackers.video import check_init_box, probe_video


def run_identify(files: StageFiles, fps: float | None, sync: dict[str, Any], source: str | None = None, seed: dict | None = None) -> dict:
    """The identify stage: ``track.csv`` of the identified target and ``identification.json``.

    source: the video the track stage detected the movers in (None when the
    project brings its detections); no mover in it: the target was never
    found. seed: the tracker's ``init`` box and ``init_frame``, or None.
    """
    params = params_from_table(sync)
    warnings: list[str] = []
    camera = read_camera(files.path("camera"), name=files.camera)
    prepared = prepare_trajectory(read_trajectory(files.path("trajectory")), params)
    try:
        if source is not None and has_no_rows(files.path("detections")):
            raise SyncError(f"{source}: the target was never found (no moving object in any frame)")
        detections = read_detections(files.path("detections"))
        if seed:
            check_init_box(files.path("video"), probe_video(files.path("video")), seed["init"], seed["init_frame"])
        prefer = seed_tracklets(detections, seed["init"], seed["init_frame"]) if seed else frozenset()
        if seed and not prefer:
            warnings.append(f"camera {files.camera}: no mover inside the init box {seed['init']} near frame {seed['init_frame']}; the target is identified without it")
        found = identify(camera, detections, prepared, fps or camera.fps, params, prefer)
    except SyncError as exc:
        files.output("track").unlink(missing_ok=True)
        with files.write("identification") as tmp:
            tmp.write_text(json.dumps({"error": str(exc)}, indent=1) + "\n", encoding="utf-8")
        return {"error": str(exc), "warnings": warnings}
    with files.write("track") as tmp:
        write_track(found.track, tmp)
    with files.write("identification") as tmp:
        tmp.write_text(json.dumps(asdict(found.summary()), indent=1) + "\n", encoding="utf-8")
    seeded = f", seeded by the init box (tracklet {min(prefer)})" if prefer else ""
    lift = f"; the log's point is {abs(found.lift_m):.2f} m {'above' if found.lift_m > 0 else 'below'} the movers' centres, the track moved to it" if found.lift_m else ""
    return {"identified_frames": len(found.track), "warnings": warnings, "message": f"wrote {files.output('track')} ({len(found.track)} identified frames{seeded}{lift})"}


def brings_movers(project, cam: str) -> bool:
    """Whether the camera's target is to be identified among every mover (detected, or brought as ``detections``)."""
    spec = project.camera(cam)
    if spec["track"] is not None:
        return False
    return spec.get("detections") is not None or (spec.get("video") is not None and tracks_every_mover(spec))


def _init_seed(project, cam: str) -> dict | None:
    """The blob tracker's init box and frame, which seed the identity, or None."""
    tracker = project.camera(cam).get("tracker") or {}
    if project.camera(cam).get("detections") is not None or tracker.get("init") is None:
        return None
    return {"init": list(tracker["init"]), "init_frame": tracker.get("init_frame", 0)}


def _detected_video(project, cam: str) -> str | None:
    """The video the track stage detects this camera's movers in (None when the project brings its detections)."""
    spec = project.camera(cam)
    return None if spec.get("detections") is not None else spec.get("video")


def identify_inputs(src, cam: str) -> dict:
    """The camera, its movers and the trajectory; with an init box, the video it is checked against."""
    inputs = {"camera": src.artefact("camera", cam), "detections": src.artefact("detections", cam), "trajectory": src.artefact("trajectory")}
    if _init_seed(src.project, cam) is not None:
        inputs["video"] = src.project.camera(cam)["video"]
    return inputs


SPEC = StageSpec(
    "identify",
    inputs=identify_inputs,
    params=lambda project, cam, options: {"fps": project.camera(cam)["fps"], "sync": params_table(project.sync), "source": _detected_video(project, cam), "seed": _init_seed(project, cam)},
    outputs=("track", "identification"),
    run=run_identify,
    per_camera=True,
    light=True,
    applies=brings_movers,
)
