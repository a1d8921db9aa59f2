"""What the project asks of each camera, from its configuration alone: whether its video gets a coarse pass (scan),
where the pass takes its pose from, whether its pose comes from the target, its GCPs' sigma; not a stage.

Read by the scan, track and calibrate stages; it imports nothing of ``sync``, so the track stage does not either.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from calibration.camera import read_camera
from calibration.errors import CalibrationInputError

if TYPE_CHECKING:
    from tlsync_pipeline.pipeline.project import Project


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
    """Whether a camera.json the project brings has a pose (an unreadable one counts as posed: reading it later names
    the fault).
    """
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
    ``[track] scan = "auto"``, a pose to vote with (scan_pose) and a trajectory (a project of videos alone is tracked
    whole)."""
    camera = project.camera(cam)
    every_mover = (
        camera.track is None and camera.detections is None and camera.video is not None and camera.tracker.every_mover
    )
    logged = project.target.trajectory is not None or project.target.log is not None
    return project.track.scan == "auto" and every_mover and scan_pose(project, cam) is not None and logged
