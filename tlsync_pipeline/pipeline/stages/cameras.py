"""Per-camera files and parameters of the project-wide stages (sync, export, render), and what identify, vote and
sync read alike (the log model the ingest report suggests, a pose's absence); not a stage."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from calibration.camera import Camera
from tlsync_pipeline.errors import INPUT_ERRORS, SyncError
from tlsync_pipeline.ingest.report import read_ingest_report
from tlsync_pipeline.pipeline.spec import ProjectWide, Sources
from tlsync_pipeline.pipeline.workspace import Artefact, StageFiles
from tlsync_pipeline.sync.model.log_model import LogModel, LogModelChoice
from trackers.video import probe_video

if TYPE_CHECKING:
    from tlsync_pipeline.pipeline.project import Project

CAMERA_FILES = (
    "camera",
    "calibration_report",
    "track",
    "votes",
    "video",
    "identification",
    "detections",
    "video_info",
    "scan",
    "clock",
)


@dataclass(frozen=True)
class CameraFiles:
    """One camera's files a project-wide stage declared as ``<kind>:<camera>`` (None: not declared)
    and its nominal fps.
    """

    name: str
    camera: Path | None = None
    calibration_report: Path | None = None
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


POSE_ERROR = (
    "pose_error"  # camera.json field: why the calibrate stage found no pose (the camera is then not synchronized)
)


def pose_problem(camera: Camera) -> SyncError | None:
    """Why a camera cannot be synchronized for want of a pose (the calibrate stage's reason, in its camera.json), or
    None when it has one.
    """
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
