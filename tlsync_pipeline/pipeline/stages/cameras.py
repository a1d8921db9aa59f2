"""Per-camera files and parameters of the project-wide stages (sync, export, render); not a stage."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from calibration.camera import Camera, read_camera
from calibration.errors import CalibrationInputError
from tlsync_pipeline.errors import INPUT_ERRORS, SyncError
from tlsync_pipeline.ingest.report import read_ingest_report
from tlsync_pipeline.pipeline.spec import ProjectWide, Sources
from tlsync_pipeline.pipeline.workspace import Artefact, StageFiles
from tlsync_pipeline.sync.log_model import LogModel, LogModelChoice
from trackers.video import probe_video

if TYPE_CHECKING:
    from tlsync_pipeline.pipeline.project import Project

CAMERA_FILES = ("camera", "track", "votes", "video", "identification", "detections", "video_info", "scan", "clock")


@dataclass(frozen=True)
class CameraFiles:
    """One camera's files a project-wide stage declared as ``<kind>:<camera>`` (None: not declared) and its nominal fps."""

    name: str
    camera: Path | None = None
    track: Path | None = None
    votes: Path | None = None
    video: Path | None = None
    identification: Path | None = None
    detections: Path | None = None
    video_info: Path | None = None
    scan: Path | None = None
    clock: Path | None = None
    fps: float | None = None


@dataclass(frozen=True)
class CamerasParams(ProjectWide):
    """The cameras a project-wide stage serves (ProjectWide) and each one's nominal fps (None: its camera.json's)."""

    fps: Mapping[str, float | None] = field(default_factory=dict)


def camera_files(files: StageFiles, params: ProjectWide) -> dict[str, CameraFiles]:
    """Per camera the stage serves, the files it declared (kinds: CAMERA_FILES) and, with CamerasParams, its fps."""
    fps = params.fps if isinstance(params, CamerasParams) else {}
    return {
        n: CameraFiles(n, **{k: files.path(f"{k}:{n}") for k in CAMERA_FILES if files.has(f"{k}:{n}")}, fps=fps.get(n))
        for n in params.cameras
    }


def cameras_params(project: Project) -> CamerasParams:
    """The cameras in project order and their fps (None: the camera.json's)."""
    return CamerasParams(tuple(project.names), fps={c.name: c.fps for c in project.cameras})


def target_pose_wanted(project: Project, name: str) -> bool:
    """Whether the camera's pose comes from the target: a camera.json of its own without a pose, or a calibration
    table without board_pose whose GCPs, if any, are a prior (gcp_sigma_m > 0)."""
    camera = project.camera(name)
    if camera.camera is not None:
        return not _posed(camera.camera)
    cal = camera.calibration
    if not cal.given or cal.board_pose is not None:
        return False
    return cal.gcp is None or gcp_sigma(project, name) > 0


def gcp_sigma(project: Project, name: str) -> float:
    """The camera's GCP survey sigma (metres): its [cameras.calibration] gcp_sigma_m, else [calibration]'s."""
    own = project.camera(name).calibration.gcp_sigma_m
    return project.calibration.gcp_sigma_m if own is None else own


def _posed(path: Path) -> bool:
    """Whether a camera.json the project brings has a pose (an unreadable one counts as posed: reading it later names the fault)."""
    try:
        return read_camera(path).posed
    except CalibrationInputError:
        return True


def scan_pose(project: Project, cam: str) -> str | None:
    """Where the coarse pass (scan stage) takes the camera's pose from: "camera", the posed camera.json the project
    brings; "survey", its GCPs or board at a known pose alone (the target may refine that pose later, calibrate);
    None: nowhere (the pose comes from the target alone)."""
    camera = project.camera(cam)
    if camera.camera is not None:
        return "camera" if _posed(camera.camera) else None
    cal = camera.calibration
    has_intrinsics = cal.board_views or cal.intrinsics is not None
    return "survey" if has_intrinsics and (cal.gcp is not None or cal.board_pose is not None) else None


def scans(project: Project, cam: str) -> bool:
    """Whether the camera's video gets a coarse pass (the scan stage): every mover detected in its own video,
    ``[track] scan = "auto"``, a pose to vote with (scan_pose) and a trajectory (a project of videos alone is tracked whole)."""
    camera = project.camera(cam)
    every_mover = camera.track is None and camera.detections is None and camera.video is not None and camera.tracker.every_mover
    logged = project.target.trajectory is not None or project.target.log is not None
    return project.track.scan == "auto" and every_mover and scan_pose(project, cam) is not None and logged


def has_no_rows(csv_path: Path) -> bool:
    """Whether a CSV artefact a stage wrote (track.csv, detections.csv) holds its header and no row."""
    with open(csv_path, encoding="utf-8") as handle:
        return sum(1 for line in handle if line.strip()) <= 1


def container_fps(project: Project) -> dict[str, float]:
    """Each camera with a video and an fps key: the frame rate its video's container states (a video that cannot be
    probed is left out: the run's validation names it)."""
    out = {}
    for camera in project.cameras:
        if camera.video is None or camera.fps is None:
            continue
        try:
            fps = probe_video(camera.video).fps
        except INPUT_ERRORS:
            continue
        if fps and math.isfinite(fps):
            out[camera.name] = float(fps)
    return out


POSE_ERROR = "pose_error"  # camera.json field: why the calibrate stage found no pose (the camera is then not synchronized)


def pose_problem(camera: Camera) -> SyncError | None:
    """Why a camera cannot be synchronized for want of a pose (the calibrate stage's reason, in its camera.json), or None when it has one."""
    if camera.posed:
        return None
    return SyncError(str(camera.extra.get(POSE_ERROR) or f"camera {camera.name}: it has no pose (R, t)"))


def log_model_of(files: StageFiles, choice: LogModelChoice) -> LogModel:
    """The log's error model: [target]'s choice, "auto" resolved by what ingest_report.json suggests (when the task
    declares it: the project ingests a log), else "none"."""
    suggested = None
    if files.has("ingest_report"):
        suggested = (read_ingest_report(files.path("ingest_report")).log_model or {}).get("name")
    return choice.resolve(suggested)


def ingest_report_input(src: Sources) -> dict[str, Path | Artefact]:
    """The ingest report, when the project ingests a log (what its log model suggests, its clock)."""
    return {"ingest_report": src.artefact("ingest_report")} if src.made("ingest_report") else {}
