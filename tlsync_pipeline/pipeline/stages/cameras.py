"""Per-camera files and parameters of the project-wide stages (sync, export, render); not a stage."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING

from tlsync_pipeline.errors import SyncError
from tlsync_pipeline.pipeline.workspace import StageFiles
from tlsync_pipeline.sync.timeline import IdentificationSummary

if TYPE_CHECKING:
    from tlsync_pipeline.pipeline.project import Project

CAMERA_FILES = ("camera", "track", "votes", "video", "identification", "detections", "video_info", "scan")
VIDEO_INFO_FORMAT = "tlsync-video"  # video.json, written by the track stage


def camera_files(files: StageFiles, names: list[str], fps: dict[str, float | None] | None = None) -> dict[str, dict]:
    """Per camera, the paths a stage declared as ``<kind>:<camera>`` (kinds: CAMERA_FILES) and, given ``fps``, the camera's fps."""
    out = {n: {k: files.path(f"{k}:{n}") for k in CAMERA_FILES if files.has(f"{k}:{n}")} for n in names}
    for n in out if fps is not None else ():
        out[n]["fps"] = fps[n]
    return out


def camera_params(project: Project) -> dict:
    """The cameras in project order and their fps (None: the camera.json's)."""
    return {"cameras": [c["name"] for c in project.cameras], "fps": {c["name"]: c["fps"] for c in project.cameras}}


def read_identification(path) -> IdentificationSummary | SyncError:
    """A camera's identification.json (identify stage): the summary, or the SyncError that kept its target from being identified."""
    data = json.loads(path.read_text(encoding="utf-8"))
    return SyncError(data["error"]) if "error" in data else IdentificationSummary.from_dict(data)


def tracks_every_mover(spec: dict) -> bool:
    """Whether a camera's track stage detects every mover (blob kind) rather than one target (CSRT)."""
    return (spec.get("tracker") or {}).get("kind", "blob") == "blob"


def has_calibration(spec: dict) -> bool:
    """Whether the camera table has a [cameras.calibration] table with something to calibrate from."""
    cal = spec.get("calibration") or {}
    return any(cal.get(k) is not None for k in ("images", "video", "intrinsics", "gcp", "board_pose"))


def scans(project: Project, cam: str) -> bool:
    """Whether the camera's video gets a coarse pass (the scan stage): every mover detected in its own video,
    ``[track] scan = "auto"``, and a calibration and a trajectory to vote with (a project of videos alone is tracked whole)."""
    spec = project.camera(cam)
    every_mover = spec["track"] is None and spec.get("detections") is None and spec.get("video") is not None and tracks_every_mover(spec)
    calibrated = spec["camera"] is not None or has_calibration(spec)
    logged = project.target["trajectory"] is not None or project.target["log"] is not None
    return project.track["scan"] == "auto" and every_mover and calibrated and logged


def has_no_rows(csv_path: Path) -> bool:
    """Whether a CSV artefact a stage wrote (track.csv, detections.csv) holds its header and no row."""
    with open(csv_path, encoding="utf-8") as handle:
        return sum(1 for line in handle if line.strip()) <= 1


def read_video_info(path: Path) -> dict:
    """video.json as the track stage wrote it: frames (that exist), announced, truncated (docs/formats.md)."""
    return json.loads(Path(path).read_text(encoding="utf-8"))
