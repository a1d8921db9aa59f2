"""The intrinsics stage: a camera's checkerboard photos or video -> ``intrinsics.json`` and its report.

A stage of its own so that the slow part (detecting the board in every view)
is cached apart from the pose: editing a GCP file re-runs only calibrate.
``intrinsics.json`` is a camera.json without a pose (no R, t; ``rms`` kept);
``intrinsics_report.json`` holds the calibration report's ``intrinsics`` part
(per-view errors and detected corners, rejected views with reasons).
"""

from __future__ import annotations

import glob
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from calibration.camera import write_camera
from calibration.errors import PatternMismatch
from calibration.intrinsics import calibrate_images, calibrate_video, parse_pattern
from tlsync_pipeline.artefacts.calibration import IntrinsicsReport, write_intrinsics_report
from tlsync_pipeline.errors import InputError, error_details, with_details
from tlsync_pipeline.pipeline.spec import Options, Sources, StageResult, StageSpec
from tlsync_pipeline.pipeline.workspace import Artefact, StageFiles

if TYPE_CHECKING:
    from tlsync_pipeline.pipeline.project import Project

IMAGE_PREFIX = "image:"
INTRINSICS_SOURCES = ("images", "video", "intrinsics")


@dataclass(frozen=True)
class IntrinsicsParams:
    """The checkerboard (inner corners COLSxROWS, square side in metres), the lens model, the per-view outlier
    threshold (pixels), what the report names as the views' source, and for a video the frames sampled."""

    pattern: str
    square: float
    model: str
    max_view_error: float
    source: str
    max_frames: int | None = None


def check_calibration(project: Project, name: str) -> None:
    """InputError when a camera's [cameras.calibration] table cannot work (no or several intrinsics sources, ...)."""
    where = f"{project.path}: camera {name!r}: [cameras.calibration]"
    cal = project.camera(name).calibration
    sources = [k for k in INTRINSICS_SOURCES if getattr(cal, k) is not None]
    if not sources:
        raise InputError(
            f"{where}: give the intrinsics' source: images (a glob of checkerboard photos), video, or intrinsics (a "
            f"camera.json)"
        )
    if len(sources) > 1:
        raise InputError(f"{where}: give only one of images, video, intrinsics (got {', '.join(sources)})")
    if cal.gcp is not None and cal.board_pose is not None:
        raise InputError(f"{where}: give either gcp or board_pose for the camera's pose, not both")
    if cal.board_views or cal.board_pose is not None:
        missing = [k for k in ("pattern", "square") if getattr(cal, k) is None]
        if missing:
            raise InputError(
                f"{where}: missing key(s) {', '.join(missing)} (the checkerboard's inner corners COLSxROWS and square "
                f"side in metres)"
            )


def run_intrinsics(files: StageFiles, params: IntrinsicsParams) -> StageResult:
    """Calibrate the camera's intrinsics from its board views (``image:*`` inputs or ``video``), with ``files.cores``
    processes.
    """
    board = parse_pattern(
        params.pattern, params.square, source=f"camera {files.camera!r}: [cameras.calibration] pattern"
    )
    try:
        if files.has("video"):
            assert params.max_frames is not None, "intrinsics_params gives a video its frame count"
            result = calibrate_video(
                files.path("video"),
                board,
                params.model,
                params.max_frames,
                workers=files.cores,
                progress=files.progress,
                max_view_error=params.max_view_error,
            )
        else:
            images = [str(files.path(label)) for label in files.inputs if label.startswith(IMAGE_PREFIX)]
            result = calibrate_images(
                images,
                board,
                params.model,
                workers=files.cores,
                progress=files.progress,
                max_view_error=params.max_view_error,
                label=params.source,
            )
    except PatternMismatch as exc:
        raise with_details(
            InputError(f'{exc}: set pattern = "{exc.seen}" in [cameras.calibration]'), *error_details(exc)
        ) from None
    report = result.to_report()
    report["source"] = params.source
    relative = {
        str(files.path(label)): label[len(IMAGE_PREFIX) :] for label in files.inputs if label.startswith(IMAGE_PREFIX)
    }
    for view in report["per_view"]:
        view["corners"] = np.round(result.corners[view["image"]], 3).tolist()
    for view in report["per_view"] + report["rejected"]:  # photos named like source: relative to the project folder
        view["image"] = relative.get(view["image"], view["image"])
    with files.write("intrinsics") as tmp:
        write_camera(result.camera(files.camera_name), tmp)
    with files.write("intrinsics_report") as tmp:
        write_intrinsics_report(IntrinsicsReport(report), tmp)
    rejected = tuple(f"checkerboard view {view['image']} rejected: {view['reason']}" for view in report["rejected"])
    return StageResult(warnings=rejected, facts={"rms_px": result.rms, "views_used": len(result.used)})


def intrinsics_inputs(src: Sources, name: str) -> dict[str, Path | Artefact]:
    """The board views: every image the glob matches (labelled by path relative to the project folder), or the video."""
    check_calibration(src.project, name)
    cal = src.project.camera(name).calibration
    if cal.video is not None:
        return {"video": cal.video}
    assert cal.images is not None  # check_calibration: one source
    matches = [Path(m) for m in sorted(glob.glob(os.path.expanduser(cal.images), recursive=True))]
    if not matches:
        raise InputError(
            f"{src.project.path}: camera {name!r}: [cameras.calibration] images: no file matches {cal.images}"
        )
    return {IMAGE_PREFIX + os.path.relpath(m, src.project.root): m for m in matches}


def intrinsics_params(project: Project, name: str, options: Options) -> IntrinsicsParams:
    cal = project.camera(name).calibration
    assert cal.pattern is not None and cal.square is not None  # check_calibration
    source = cal.video or cal.images
    return IntrinsicsParams(
        cal.pattern,
        cal.square,
        cal.model,
        cal.max_view_error,
        os.path.relpath(str(source), project.root),
        cal.max_frames if cal.video is not None else None,
    )


SPEC = StageSpec(
    "intrinsics",
    inputs=intrinsics_inputs,
    params=intrinsics_params,
    outputs=("intrinsics", "intrinsics_report"),
    run=run_intrinsics,
    per_camera=True,
    applies=lambda project, name: project.camera(name).camera is None and project.camera(name).calibration.board_views,
)
