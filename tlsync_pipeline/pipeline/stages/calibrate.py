"""The calibrate stage: a camera's pose (and its intrinsics, from the intrinsics stage or a camera.json) -> Camera and report.

The intrinsics come from the intrinsics stage (checkerboard photos or video,
``cameras/<cam>/intrinsics.json``) or from an existing camera.json
(``intrinsics``); the pose from ground control points (``gcp``) or a board at
a known world pose (``board_pose``). Geodetic GCPs (u,v,lat,lon,alt) are
converted to the project's local ENU frame with tlsync_pipeline.geodesy,
around the project's origin (see pipeline/origin.py), so cameras and trajectory
share one world frame. Without a pose source the camera.json has identity R
and zero t (intrinsics only). Editing a GCP file re-runs this stage only, not
the checkerboard detection.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np

from calibration.camera import Camera, read_camera, write_camera
from calibration.extrinsics import (
    GcpTable,
    Pose,
    pose_from_board,
    pose_from_points,
    read_gcps,
)
from calibration.intrinsics import detect_board, parse_pattern
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.geodesy import Origin, geodetic_to_enu
from tlsync_pipeline.outputs.plots import calibration_plot
from tlsync_pipeline.outputs.summary import calibration_summary
from tlsync_pipeline.pipeline.origin import check_gcp_places, origin_inputs, resolve_origin
from tlsync_pipeline.pipeline.spec import Options, Sources, StageResult, StageSpec
from tlsync_pipeline.pipeline.stages.intrinsics import check_calibration
from tlsync_pipeline.pipeline.workspace import Artefact, StageFiles

if TYPE_CHECKING:
    from tlsync_pipeline.pipeline.project import Project

@dataclass(frozen=True, eq=False)
class KnownBoard:
    """A checkerboard at a known world pose: inner corners COLSxROWS, square side (metres), board -> world R (3x3) and t (metres)."""

    pattern: str
    square: float
    R: np.ndarray
    t: np.ndarray


@dataclass(frozen=True)
class CalibrateParams:
    """What the pose reads: the camera's fps (kept in camera.json); with GCPs, their outlier threshold (pixels)
    and the ENU origin setting; with a board at a known pose, the board (its photo is an input)."""

    fps: float | None
    ransac_px: float | None = None
    origin: Origin | str | None = None
    board: KnownBoard | None = None


def gcp_world_points(table: GcpTable, origin: Origin | str | None) -> np.ndarray:
    """Local metres (N, 3) of a GCP table; geodetic points go through geodetic_to_enu around ``origin``."""
    if table.xyz is not None:
        return table.xyz
    if not isinstance(origin, Origin) or table.geodetic is None:
        raise InputError(
            f'{table.source}: geodetic GCPs cannot use origin = "first" (the log\'s first fix is not known when calibrating); '
            'set [target] origin = [lat, lon, alt] or "gcps"'
        )
    return geodetic_to_enu(table.geodetic[:, 0], table.geodetic[:, 1], table.geodetic[:, 2], origin)


def calibrate_pose(name: str, params: CalibrateParams, known: Camera, intrinsics_report: dict, origin: Origin | str | None, gcp: Path | None, board_image: Path | None) -> tuple[Camera, dict]:
    """A camera from known intrinsics and its pose source (``gcp`` or ``board_image``); writes nothing.

    origin: the resolved ENU origin (geodetic GCPs). Returns the Camera (world =
    the project's local frame) and a JSON-ready report: ``intrinsics`` (as
    given) and ``pose`` (per-point reprojection errors, predicted uncertainty).
    """
    K, dist, dist_model, size = known.K, known.dist, known.dist_model, known.image_size
    report: dict = {"camera": name, "intrinsics": intrinsics_report}
    pose: Pose | None = None
    if gcp is not None:
        table = read_gcps(gcp)
        _check_in_image(table, size)
        origin = origin if table.geodetic is not None else None
        if isinstance(origin, Origin):
            check_gcp_places(table, origin, "the [target] origin" if isinstance(params.origin, Origin) else "the origin (the centroid of every camera's GCPs)")
        xyz = gcp_world_points(table, origin)
        assert params.ransac_px is not None, "calibrate_params gives GCPs their threshold"
        pose = pose_from_points(table.uv, xyz, K, dist, dist_model, params.ransac_px, source=table.source)
        report["pose"] = {"source": table.source, "kind": "geodetic" if table.geodetic is not None else "local", **pose.to_report(table.names)}
        for point, uv, world in zip(report["pose"]["points"], table.uv, xyz):
            point.update(uv=uv.tolist(), xyz=world.tolist())
        if isinstance(origin, Origin):
            report["pose"]["origin"] = {"lat": origin.lat, "lon": origin.lon, "alt": origin.alt}
    elif board_image is not None and params.board is not None:
        board = params.board
        pattern = parse_pattern(board.pattern, board.square, source=f"camera {name!r}: [cameras.calibration] pattern")
        gray = cv2.imread(str(board_image), cv2.IMREAD_GRAYSCALE | cv2.IMREAD_IGNORE_ORIENTATION)
        if gray is None:
            raise InputError(f"{board_image}: cannot read the image (board_pose)")
        if (gray.shape[1], gray.shape[0]) != tuple(size):
            raise InputError(f"{board_image}: image is {gray.shape[1]}x{gray.shape[0]}, the camera's intrinsics are for {size[0]}x{size[1]}")
        corners, _, reason = detect_board(gray, pattern.size)
        if corners is None:
            raise InputError(f"{board_image}: board_pose: {reason} (pattern {pattern})")
        pose = pose_from_board(gray, corners, pattern, board.R, board.t, K, dist, dist_model, source=str(board_image))
        report["pose"] = {"source": str(board_image), "kind": "board", **pose.to_report()}
    else:
        report["pose"] = None
        report["warning"] = "no gcp or board_pose: camera.json has identity R and zero t (intrinsics only)"

    R, t = (pose.R, pose.t) if pose is not None else (np.eye(3), np.zeros(3))
    camera = Camera(name, K, dist, R, t, (int(size[0]), int(size[1])), params.fps, dist_model, dict(known.extra))
    return camera, report


def known_intrinsics(path: Path) -> dict:
    """The intrinsics part of the report for intrinsics taken from an existing camera.json."""
    known = read_camera(path)
    return {"source": str(path), "K": known.K.tolist(), "dist": known.dist.tolist(), "dist_model": known.dist_model, "image_size": list(known.image_size)}


def _check_in_image(table: GcpTable, size: tuple[int, int]) -> None:
    w, h = size
    for (u, v), line in zip(table.uv, table.lines):
        if not (-0.5 <= u <= w - 0.5 and -0.5 <= v <= h - 0.5):
            raise InputError(f"{table.source}:{line}: pixel ({u:g}, {v:g}) is outside the {w}x{h} image")


def run_calibrate(files: StageFiles, params: CalibrateParams) -> StageResult:
    """The calibrate stage: camera.json, calibration_report.json and calibration.png of one camera."""
    known = read_camera(files.path("intrinsics"))
    if files.has("intrinsics_report"):  # calibrated by the intrinsics stage: its rms stays in camera.json
        intrinsics_report = json.loads(files.path("intrinsics_report").read_text(encoding="utf-8"))
    else:  # a given camera.json: only its intrinsics are taken
        known = Camera(known.name, known.K, known.dist, known.R, known.t, known.image_size, known.fps, known.dist_model)
        intrinsics_report = known_intrinsics(files.path("intrinsics"))
    gcp = files.path("gcp") if files.has("gcp") else None
    origin = params.origin
    if gcp is not None and read_gcps(gcp).geodetic is not None:
        origin = resolve_origin(origin, [files.path(label) for label in files.inputs if label.startswith("origin-gcp:")], "[target]")
    board_image = files.path("board_pose_image") if files.has("board_pose_image") else None
    camera, report = calibrate_pose(files.camera_name, params, known, intrinsics_report, origin, gcp, board_image)
    with files.write("camera") as tmp:
        write_camera(camera, tmp)
    with files.write("calibration_report") as tmp:
        tmp.write_text(json.dumps(report, indent=1) + "\n", encoding="utf-8")
    with files.write("calibration_picture") as tmp:
        tmp.write_bytes(calibration_plot(report, camera.image_size))
    return StageResult(message=f"{calibration_summary(report)}; wrote {files.output('camera')}", warnings=pose_warnings(report))


def pose_warnings(report: dict) -> tuple[str, ...]:
    """The calibrate stage's warnings, from its report: ground control points left out as outliers, a camera without a pose."""
    pose = report.get("pose") or {}
    out = [
        f"ground control point {point.get('name', '?')} left out as an outlier ({point.get('error_px', float('nan')):.1f} px)"
        for point in pose.get("points", [])
        if not point.get("inlier", True)
    ]
    return tuple(out + ([report["warning"]] if report.get("warning") else []))


def calibrate_inputs(src: Sources, name: str) -> dict[str, Path | Artefact]:
    """The intrinsics (the intrinsics stage's, or the given camera.json), the pose's files, and the origin's GCPs."""
    check_calibration(src.project, name)
    cal = src.project.camera(name).calibration
    inputs: dict[str, Path | Artefact] = {}
    if src.made("intrinsics", name):
        inputs = {"intrinsics": src.artefact("intrinsics", name), "intrinsics_report": src.artefact("intrinsics_report", name)}
    elif cal.intrinsics is not None:
        inputs = {"intrinsics": cal.intrinsics}
    if cal.gcp is not None:
        inputs["gcp"] = cal.gcp
        inputs.update(origin_inputs(src.project))
    if cal.board_pose is not None:
        inputs["board_pose_image"] = cal.board_pose.image
    return inputs


def calibrate_params(project: Project, name: str, options: Options) -> CalibrateParams:
    """The camera's fps; the GCPs' threshold and the origin setting with GCPs; the board (without its photo, an input) with board_pose."""
    camera = project.camera(name)
    cal = camera.calibration
    board = None
    if cal.board_pose is not None:
        assert cal.pattern is not None and cal.square is not None  # check_calibration
        board = KnownBoard(cal.pattern, cal.square, cal.board_pose.R, cal.board_pose.t)
    if cal.gcp is None:
        return CalibrateParams(camera.fps, board=board)
    return CalibrateParams(camera.fps, cal.ransac_px, project.target.origin, board)


SPEC = StageSpec(
    "calibrate",
    inputs=calibrate_inputs,
    params=calibrate_params,
    outputs=("camera", "calibration_report", "calibration_picture"),
    run=run_calibrate,
    per_camera=True,
    light=True,
    applies=lambda project, name: project.camera(name).camera is None and project.camera(name).calibration.given,
)
