"""A camera's calibration report as people read it: the calibration picture (PNG) and one line of text.

Pure functions of calibration_report.json's content (the calibrate stage writes it; render shows it again).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tlsync_pipeline.outputs.figures import png as _png
from tlsync_pipeline.outputs.figures import pyplot as _pyplot
from tlsync_pipeline.outputs.figures import tight_layout


def calibration_plot(report: dict, image_size: tuple[int, int]) -> bytes:
    """The calibration picture (PNG): detected corners (one colour per view) and GCPs over the image frame; per-view
    errors.

    report: the calibrate stage's calibration_report.json (GCP errors under the GCPs' pose, and "-> after" under
    the pose from the target when there is one).
    """
    plt = _pyplot()

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
        after = {g["name"]: g["after_px"] for g in (report.get("target_pose") or {}).get("gcps", [])}
        for p in pose["points"]:
            moved = f" -> {after[p['name']]:.1f}px" if after.get(p["name"]) is not None else ""
            ax.annotate(
                f"{p['name']} {p['error_px']:.1f}px{moved}",
                p["uv"],
                fontsize=7,
                xytext=(4, 4),
                textcoords="offset points",
            )
        ax.legend(loc="lower right", fontsize=8)
    ax.set_xlim(-0.5, w - 0.5)
    ax.set_ylim(h - 0.5, -0.5)
    ax.set_aspect("equal")
    target = report.get("target_pose")
    title = f"{report['camera']}: corner coverage ({len(views)} views), {w}x{h}"
    if target and "error" in target:
        title += f"\nno pose from the target ({target.get('cause') or 'see the report'})"
    elif target:
        title += (
            f"\npose from the target ({target['source']}): +-{target['center_std_m']:.3f} m, "
            f"+-{target['rotation_std_deg']:.3f} deg" + ("" if target.get("for_3d", True) else ", timing only")
        )
    ax.set_title(title, fontsize=9)
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
        ax.text(
            0.5,
            0.5,
            "intrinsics from\n" + str(intr.get("source", "?")),
            ha="center",
            va="center",
            transform=ax.transAxes,
        )
        ax.set_axis_off()
    tight_layout(fig)
    return _png(fig)


def calibration_summary(report: dict) -> str:
    """One line about a camera's calibration report: views, RMS, intrinsics, pose."""
    intr = report["intrinsics"]
    text = f"{report['camera']}: "
    if "rms_px" in intr:
        K = intr["K"]
        text += (
            f"{intr['views_used']}/{intr['views_used'] + intr['views_rejected']} views, RMS {intr['rms_px']:.3f} "
            f"px, fx {K[0][0]:.2f} fy {K[1][1]:.2f} cx {K[0][2]:.2f} cy {K[1][2]:.2f}"
        )
    else:
        text += f"intrinsics from {intr['source']}"
    pose = report.get("pose")
    if pose:
        n_in = sum(p["inlier"] for p in pose["points"])
        text += (
            f"; pose from {n_in}/{len(pose['points'])} {pose['kind']} points, RMS {pose['rms_px']:.2f} px "
            f"(+-{pose['rotation_std_deg']:.3f} deg, +-{pose['position_std_m']:.3f} m)"
        )
    target = report.get("target_pose")
    if target and "error" in target:
        cause = f"{target['cause']}; " if target.get("cause") else ""
        again = "under a log with a bias the sync searches it again on the log the other cameras correct"
        text += f"; no pose from the target ({cause}{again})"
    elif target:
        text += f"; {target_pose_summary(target)}"
    elif not pose:
        text += "; no pose"
    return text


def target_pose_summary(target: dict) -> str:
    """One clause about a pose from the target (calibration_report.json's ``target_pose``): source, frames, uncertainty,
    how far it moved, what it serves.
    """
    text = (
        f"pose from the target ({target['source']}, {target['frames']} frames, +-{target['center_std_m']:.3f} m, "
        f"+-{target['rotation_std_deg']:.3f} deg"
    )
    if target.get("moved_m") is not None:
        text += f"; {target['moved_m']:.2f} m and {target['moved_deg']:.2f} deg from the GCPs' pose"
    text += ")"
    if not target.get("for_3d", True):
        text += ": good for timing, not for 3D"
    return text


POSE_SOURCE_TEXT = {
    "target": "posed from the target",
    "second_pass": "searched again on the log corrected for its bias",
    "bias_refit": "refitted under the log's bias every camera's line estimates",
}


def sync_pose_clause(source: str, center: np.ndarray, report: dict | None) -> str:
    """One clause saying that a camera's line was fitted with a pose the sync found itself (timeline.json's
    ``cameras.<name>.pose``: its ``source``, its camera centre in metres), how, how far that centre lies from the
    calibrate stage's pose from the target (when ``report``, calibration_report.json's content, has one), and that the
    pictures draw it."""
    how = ", then ".join(POSE_SOURCE_TEXT[part] for part in source.split("+"))
    text = f"the sync fitted its line with a pose of its own ({how})"
    given = ((report or {}).get("target_pose") or {}).get("camera_center_m")
    if given is not None:
        text += f", its centre {float(np.linalg.norm(center - np.asarray(given))):.2f} m from this one"
    return text + ": the pictures and the player draw that pose (timeline.json)"
