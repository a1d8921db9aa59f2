"""The calibrate stage: a camera's ``[cameras.calibration]`` table -> Camera and report.

Intrinsics come from checkerboard photos (``images``), a checkerboard video
(``video``) or an existing camera.json (``intrinsics``); the pose from ground
control points (``gcp``) or a board at a known world pose (``board_pose``).
Geodetic GCPs (u,v,lat,lon,alt) are converted to the project's local ENU frame
with tlsync_pipeline.geodesy, around the project's origin (see project_origin),
so cameras and trajectory share one world frame. Without a pose source the
camera.json has identity R and zero t (intrinsics only).
"""

from __future__ import annotations

import json
from pathlib import Path

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
from calibration.intrinsics import (
    Intrinsics,
    calibrate_images,
    calibrate_video,
    detect_board,
    parse_pattern,
)
from tlsync_pipeline.atomic import atomic_path
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.geodesy import Origin, geodetic_to_enu
from tlsync_pipeline.outputs.summary import calibration_summary
from tlsync_pipeline.pipeline import layout
from tlsync_pipeline.pipeline.project import Project


def has_calibration(spec: dict) -> bool:
    """Whether the camera table has a [cameras.calibration] table with something to calibrate from."""
    cal = spec.get("calibration") or {}
    return any(cal.get(k) is not None for k in ("images", "video", "intrinsics", "gcp", "board_pose"))


def project_origin(project: Project) -> Origin | str:
    """The ENU origin shared by geodetic GCPs and the target's log (ingest uses this too).

    ``[target] origin = [lat, lon, alt]``: that point. ``"gcps"``, or unset while
    some camera has geodetic GCPs: the centroid (mean latitude, longitude,
    height) of every camera's geodetic GCPs. ``"first"``, or unset without
    geodetic GCPs: the string "first" (the log's first fix, known to ingest only).
    """
    origin = project.target.get("origin")
    if isinstance(origin, Origin) or origin == "first":
        return origin
    points = []
    for spec in project.cameras:
        gcp = (spec.get("calibration") or {}).get("gcp")
        if gcp is not None:
            table = read_gcps(gcp)
            if table.geodetic is not None:
                points.append(table.geodetic)
    if not points:
        if origin == "gcps":
            raise InputError(f'{project.path}: [target]: origin = "gcps" but no camera has geodetic (lat,lon,alt) ground control points')
        return "first"
    lat, lon, alt = np.concatenate(points).mean(axis=0)
    return Origin(float(lat), float(lon), float(alt))


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


def calibrate_camera(project: Project, spec: dict, progress: bool = True) -> tuple[Camera, dict]:
    """Calibrate one camera from its ``[cameras.calibration]`` table; writes nothing.

    Returns the Camera (world = the project's local frame) and a JSON-ready report:
    ``intrinsics`` (RMS, per-view errors and detected corners, rejected images with
    reasons) and ``pose`` (per-point reprojection errors, predicted uncertainty).
    """
    name = spec["name"]
    where = f"{project.path}: camera {name!r}: [cameras.calibration]"
    cal = spec.get("calibration") or {}
    sources = [k for k in ("images", "video", "intrinsics") if cal.get(k) is not None]
    if not sources:
        raise InputError(f"{where}: give the intrinsics' source: images (a glob of checkerboard photos), video, or intrinsics (a camera.json)")
    if len(sources) > 1:
        raise InputError(f"{where}: give only one of images, video, intrinsics (got {', '.join(sources)})")
    if cal.get("gcp") is not None and cal.get("board_pose") is not None:
        raise InputError(f"{where}: give either gcp or board_pose for the camera's pose, not both")
    pattern = None
    if cal.get("images") or cal.get("video") or cal.get("board_pose"):
        missing = [k for k in ("pattern", "square") if cal.get(k) is None]
        if missing:
            raise InputError(f"{where}: missing key(s) {', '.join(missing)} (the checkerboard's inner corners COLSxROWS and square side in metres)")
        pattern = parse_pattern(cal["pattern"], cal["square"], source=f"{where}: pattern")

    report: dict = {"camera": name}
    intrinsics: Intrinsics | None = None
    if cal.get("images") is not None:
        intrinsics = calibrate_images(cal["images"], pattern, cal["model"], progress=progress, max_view_error=cal["max_view_error"])
    elif cal.get("video") is not None:
        intrinsics = calibrate_video(cal["video"], pattern, cal["model"], cal["max_frames"], progress=progress, max_view_error=cal["max_view_error"])
    if intrinsics is not None:
        K, dist, dist_model, size = intrinsics.K, intrinsics.dist, intrinsics.dist_model, intrinsics.image_size
        report["intrinsics"] = intrinsics.to_report()
        report["intrinsics"]["source"] = str(cal.get("images") or cal.get("video"))
        for view in report["intrinsics"]["per_view"]:
            view["corners"] = np.round(intrinsics.corners[view["image"]], 3).tolist()
    else:
        known = read_camera(cal["intrinsics"])
        K, dist, dist_model, size = known.K, known.dist, known.dist_model, known.image_size
        report["intrinsics"] = {"source": str(cal["intrinsics"]), "K": K.tolist(), "dist": dist.tolist(), "dist_model": dist_model, "image_size": list(size)}

    pose: Pose | None = None
    if cal.get("gcp") is not None:
        table = read_gcps(cal["gcp"])
        _check_in_image(table, size)
        origin = project_origin(project) if table.geodetic is not None else None
        xyz = gcp_world_points(table, origin)
        pose = pose_from_points(table.uv, xyz, K, dist, dist_model, cal["ransac_px"], source=table.source)
        report["pose"] = {"source": table.source, "kind": "geodetic" if table.geodetic is not None else "local", **pose.to_report(table.names)}
        for point, uv, world in zip(report["pose"]["points"], table.uv, xyz):
            point.update(uv=uv.tolist(), xyz=world.tolist())
        if isinstance(origin, Origin):
            report["pose"]["origin"] = {"lat": origin.lat, "lon": origin.lon, "alt": origin.alt}
    elif cal.get("board_pose") is not None:
        board = cal["board_pose"]
        gray = cv2.imread(str(board["image"]), cv2.IMREAD_GRAYSCALE | cv2.IMREAD_IGNORE_ORIENTATION)
        if gray is None:
            raise InputError(f"{board['image']}: cannot read the image (board_pose)")
        if (gray.shape[1], gray.shape[0]) != tuple(size):
            raise InputError(f"{board['image']}: image is {gray.shape[1]}x{gray.shape[0]}, the camera's intrinsics are for {size[0]}x{size[1]}")
        corners, _, reason = detect_board(gray, pattern.size)
        if corners is None:
            raise InputError(f"{board['image']}: board_pose: {reason} (pattern {pattern})")
        pose = pose_from_board(gray, corners, pattern, board["R"], board["t"], K, dist, dist_model, source=str(board["image"]))
        report["pose"] = {"source": str(board["image"]), "kind": "board", **pose.to_report()}
    else:
        report["pose"] = None
        report["warning"] = "no gcp or board_pose: camera.json has identity R and zero t (intrinsics only)"

    R, t = (pose.R, pose.t) if pose is not None else (np.eye(3), np.zeros(3))
    extra = {"rms": intrinsics.rms} if intrinsics is not None else {}
    camera = Camera(name, K, dist, R, t, tuple(size), spec.get("fps"), dist_model, extra)
    return camera, report


def _check_in_image(table: GcpTable, size: tuple[int, int]) -> None:
    w, h = size
    for (u, v), line in zip(table.uv, table.lines):
        if not (-0.5 <= u <= w - 0.5 and -0.5 <= v <= h - 0.5):
            raise InputError(f"{table.source}:{line}: pixel ({u:g}, {v:g}) is outside the {w}x{h} image")


def write_calibration(work: Path, camera: Camera, report: dict) -> list[Path]:
    """Write camera.json, calibration_report.json and calibration.png atomically; returns the paths."""
    paths = [layout.camera_json(work, camera.name), layout.calibration_report(work, camera.name), layout.calibration_picture(work, camera.name)]
    with atomic_path(paths[0]) as tmp:
        write_camera(camera, tmp)
    with atomic_path(paths[1]) as tmp:
        tmp.write_text(json.dumps(report, indent=1) + "\n", encoding="utf-8")
    with atomic_path(paths[2]) as tmp:
        draw_calibration(report, camera.image_size, tmp)
    return paths


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


def run_calibrate(project: Project, name: str, work: Path, progress: bool = True) -> dict:
    """The calibrate stage: camera.json, calibration_report.json and calibration.png of one camera."""
    camera, report = calibrate_camera(project, project.camera(name), progress=progress)
    paths = write_calibration(work, camera, report)
    return {"message": f"{calibration_summary(report)}; wrote {paths[0]}"}
