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
from tlsync_pipeline.outputs.summary import calibration_summary
from tlsync_pipeline.pipeline.origin import origin_inputs, resolve_origin
from tlsync_pipeline.pipeline.spec import Sources, StageSpec
from tlsync_pipeline.pipeline.stages.cameras import has_calibration
from tlsync_pipeline.pipeline.stages.intrinsics import check_calibration
from tlsync_pipeline.pipeline.workspace import StageFiles

if TYPE_CHECKING:
    from tlsync_pipeline.pipeline.project import Project

# Keys of [cameras.calibration] the pose uses as parameters (its files are inputs; the rest is the intrinsics stage's).
POSE_KEYS = ("pattern", "square", "ransac_px", "board_pose")


def gcp_world_points(table: GcpTable, origin: Origin | None) -> np.ndarray:
    """Local metres (N, 3) of a GCP table; geodetic points go through geodetic_to_enu around ``origin``."""
    if table.xyz is not None:
        return table.xyz
    if not isinstance(origin, Origin):
        raise InputError(
            f'{table.source}: geodetic GCPs cannot use origin = "first" (the log\'s first fix is not known when calibrating); '
            'set [target] origin = [lat, lon, alt] or "gcps"'
        )
    return geodetic_to_enu(table.geodetic[:, 0], table.geodetic[:, 1], table.geodetic[:, 2], origin)


def calibrate_pose(name: str, cal: dict, known: Camera, intrinsics_report: dict, origin: Origin | str | None, fps: float | None, gcp: Path | None, board_image: Path | None) -> tuple[Camera, dict]:
    """A camera from known intrinsics and its pose source (``gcp`` or ``board_image``); writes nothing.

    ``cal``: the [cameras.calibration] settings (pattern, square, ransac_px,
    board_pose R and t). Returns the Camera (world = the project's local
    frame) and a JSON-ready report: ``intrinsics`` (as given) and ``pose``
    (per-point reprojection errors, predicted uncertainty).
    """
    K, dist, dist_model, size = known.K, known.dist, known.dist_model, known.image_size
    report: dict = {"camera": name, "intrinsics": intrinsics_report}
    pose: Pose | None = None
    if gcp is not None:
        table = read_gcps(gcp)
        _check_in_image(table, size)
        origin = origin if table.geodetic is not None else None
        xyz = gcp_world_points(table, origin)
        pose = pose_from_points(table.uv, xyz, K, dist, dist_model, cal["ransac_px"], source=table.source)
        report["pose"] = {"source": table.source, "kind": "geodetic" if table.geodetic is not None else "local", **pose.to_report(table.names)}
        for point, uv, world in zip(report["pose"]["points"], table.uv, xyz):
            point.update(uv=uv.tolist(), xyz=world.tolist())
        if isinstance(origin, Origin):
            report["pose"]["origin"] = {"lat": origin.lat, "lon": origin.lon, "alt": origin.alt}
    elif board_image is not None:
        board = cal["board_pose"]
        pattern = parse_pattern(cal["pattern"], cal["square"], source=f"camera {name!r}: [cameras.calibration] pattern")
        gray = cv2.imread(str(board_image), cv2.IMREAD_GRAYSCALE | cv2.IMREAD_IGNORE_ORIENTATION)
        if gray is None:
            raise InputError(f"{board_image}: cannot read the image (board_pose)")
        if (gray.shape[1], gray.shape[0]) != tuple(size):
            raise InputError(f"{board_image}: image is {gray.shape[1]}x{gray.shape[0]}, the camera's intrinsics are for {size[0]}x{size[1]}")
        corners, _, reason = detect_board(gray, pattern.size)
        if corners is None:
            raise InputError(f"{board_image}: board_pose: {reason} (pattern {pattern})")
        pose = pose_from_board(gray, corners, pattern, board["R"], board["t"], K, dist, dist_model, source=str(board_image))
        report["pose"] = {"source": str(board_image), "kind": "board", **pose.to_report()}
    else:
        report["pose"] = None
        report["warning"] = "no gcp or board_pose: camera.json has identity R and zero t (intrinsics only)"

    R, t = (pose.R, pose.t) if pose is not None else (np.eye(3), np.zeros(3))
    camera = Camera(name, K, dist, R, t, tuple(size), fps, dist_model, dict(known.extra))
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


def draw_calibration(report: dict, image_size: tuple[int, int], path: Path) -> None:
    """PNG: detected corners (one colour per view) and GCPs over the image frame; per-view errors."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    intr = report.get("intrinsics") or {}
    views = intr.get("per_view") or []
    w, h = image_size
    fig, axes = plt.subplots(1, 2, figsize=(13, 5), gridspec_kw={"width_ratios": [1.4, 1]})
    ax = axes[0]
    cmap = plt.get_cmap("tab20")
    for i, view in enumerate(views):
        c = np.asarray(view.get("corners", []))
        if len(c):
            ax.plot(c[:, 0], c[:, 1], ".", ms=2.5, color=cmap(i % 20))
    pose = report.get("pose")
    if pose and pose.get("kind") != "board":
        uv = np.array([p["uv"] for p in pose["points"]])
        inl = np.array([p["inlier"] for p in pose["points"]])
        ax.plot(uv[inl, 0], uv[inl, 1], "k+", ms=10, label="GCP")
        if (~inl).any():
            ax.plot(uv[~inl, 0], uv[~inl, 1], "rx", ms=10, label="GCP outlier")
        for p in pose["points"]:
            ax.annotate(f"{p['name']} {p['error_px']:.1f}px", p["uv"], fontsize=7, xytext=(4, 4), textcoords="offset points")
        ax.legend(loc="lower right", fontsize=8)
    ax.set_xlim(-0.5, w - 0.5)
    ax.set_ylim(h - 0.5, -0.5)
    ax.set_aspect("equal")
    ax.set_title(f"{report['camera']}: corner coverage ({len(views)} views), {w}x{h}")
    ax = axes[1]
    if views:
        errors = [v["rms_px"] for v in views]
        ax.bar(range(len(views)), errors, color=[cmap(i % 20) for i in range(len(views))])
        ax.axhline(intr["rms_px"], color="k", ls="--", lw=1, label=f"RMS {intr['rms_px']:.3f} px")
        ax.set_xticks(range(len(views)), [Path(v["image"]).name for v in views], rotation=90, fontsize=6)
        ax.set_ylabel("RMS reprojection error (px)")
        ax.legend(fontsize=8)
        rejected = len(intr.get("rejected", []))
        ax.set_title(f"per-view error; {rejected} image(s) rejected (see report)")
    else:
        ax.text(0.5, 0.5, "intrinsics from\n" + str(intr.get("source", "?")), ha="center", va="center", transform=ax.transAxes)
        ax.set_axis_off()
    fig.tight_layout()
    fig.savefig(path, dpi=90, format="png")
    plt.close(fig)


def run_calibrate(files: StageFiles, calibration: dict, fps: float | None, origin: Origin | str | None) -> dict:
    """The calibrate stage: camera.json, calibration_report.json and calibration.png of one camera."""
    known = read_camera(files.path("intrinsics"))
    if files.has("intrinsics_report"):  # calibrated by the intrinsics stage: its rms stays in camera.json
        intrinsics_report = json.loads(files.path("intrinsics_report").read_text(encoding="utf-8"))
    else:  # a given camera.json: only its intrinsics are taken
        known = Camera(known.name, known.K, known.dist, known.R, known.t, known.image_size, known.fps, known.dist_model)
        intrinsics_report = known_intrinsics(files.path("intrinsics"))
    gcp = files.path("gcp") if files.has("gcp") else None
    if gcp is not None and read_gcps(gcp).geodetic is not None:
        origin = resolve_origin(origin, [files.path(label) for label in files.inputs if label.startswith("origin-gcp:")], "[target]")
    board_image = files.path("board_pose_image") if files.has("board_pose_image") else None
    camera, report = calibrate_pose(files.camera, calibration, known, intrinsics_report, origin, fps, gcp, board_image)
    with files.write("camera") as tmp:
        write_camera(camera, tmp)
    with files.write("calibration_report") as tmp:
        tmp.write_text(json.dumps(report, indent=1) + "\n", encoding="utf-8")
    with files.write("calibration_picture") as tmp:
        draw_calibration(report, camera.image_size, tmp)
    return {"message": f"{calibration_summary(report)}; wrote {files.output('camera')}"}


def calibrate_inputs(src: Sources, name: str) -> dict[str, Path]:
    """The intrinsics (the intrinsics stage's, or the given camera.json), the pose's files, and the origin's GCPs."""
    check_calibration(src.project, name)
    cal = src.project.camera(name)["calibration"]
    if src.made("intrinsics", name):
        inputs = {"intrinsics": src.artefact("intrinsics", name), "intrinsics_report": src.artefact("intrinsics_report", name)}
    else:
        inputs = {"intrinsics": cal["intrinsics"]}
    if cal.get("gcp") is not None:
        inputs["gcp"] = cal["gcp"]
        inputs.update(origin_inputs(src.project))
    if cal.get("board_pose") is not None:
        inputs["board_pose_image"] = cal["board_pose"]["image"]
    return inputs


def calibrate_params(project: Project, name: str, options) -> dict:
    """The pose's keys of [cameras.calibration] (the board's pose without its image, an input), fps and the origin setting."""
    cal = project.camera(name)["calibration"]
    settings = {k: cal[k] for k in POSE_KEYS}
    if settings["board_pose"] is not None:
        settings["board_pose"] = {k: v for k, v in settings["board_pose"].items() if k != "image"}
    return {"calibration": settings, "fps": project.camera(name)["fps"], "origin": project.target.get("origin")}


SPEC = StageSpec(
    "calibrate",
    inputs=calibrate_inputs,
    params=calibrate_params,
    outputs=("camera", "calibration_report", "calibration_picture"),
    run=run_calibrate,
    per_camera=True,
    light=True,
    applies=lambda project, name: project.camera(name)["camera"] is None and has_calibration(project.camera(name)),
)
