"""Per-camera files and parameters of the project-wide stages (sync, export, render); not a stage."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from tlsync_pipeline.errors import INPUT_ERRORS, SyncError
from tlsync_pipeline.pipeline.spec import ProjectWide
from tlsync_pipeline.pipeline.workspace import StageFiles
from tlsync_pipeline.sync.timeline import IdentificationSummary
from trackers.video import probe_video

if TYPE_CHECKING:
    from tlsync_pipeline.pipeline.project import Project

CAMERA_FILES = ("camera", "track", "votes", "video", "identification", "detections", "video_info", "clock")
VIDEO_INFO_FORMAT = "tlsync-video"  # video.json, written by the track stage


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


def read_identification(path) -> IdentificationSummary | SyncError:
    """A camera's identification.json (identify stage): the summary, or the SyncError that kept its target from being identified."""
    data = json.loads(path.read_text(encoding="utf-8"))
    return SyncError(data["error"]) if "error" in data else IdentificationSummary.from_dict(data)


def has_no_rows(csv_path: Path) -> bool:
    """Whether a CSV artefact a stage wrote (track.csv, detections.csv) holds its header and no row."""
    with open(csv_path, encoding="utf-8") as handle:
        return sum(1 for line in handle if line.strip()) <= 1


def read_video_info(path: Path) -> dict:
    """video.json as the track stage wrote it: frames (that exist), announced, truncated (docs/formats.md)."""
    return json.loads(Path(path).read_text(encoding="utf-8"))


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
