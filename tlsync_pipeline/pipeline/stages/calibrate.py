"""The calibrate stage: a camera's pose (and its intrinsics, from the intrinsics stage or a camera.json) -> Camera and
report.

The intrinsics come from the intrinsics stage (checkerboard photos or video,
``cameras/<cam>/intrinsics.json``), from an existing camera.json
(``intrinsics``), or from the camera's own camera.json when it has no pose
(``camera = ...`` without R, t). The pose comes from:

- a board at a known world pose (``board_pose``): source ``board``;
- ground control points (``gcp``) with ``gcp_sigma_m = 0`` (an exact
  survey): source ``gcp``;
- the target (sync/pose/pose.py), with the GCPs as a prior weighted by
  ``gcp_sigma_m`` (source ``gcp+target``) or without any (source
  ``target``). The task then also reads the camera's track (or every
  mover's detections) and the trajectory, so it runs after the track and
  ingest stages; the log's error model is the sync stage's (``[target]
  log_model``, or what the ingest report suggests), so that under a
  metre-level log the pose and the log's bias are fitted together, and
  the pose fit's line goes to the sync stage in the report's
  ``target_pose.timing``. A pose the target does not determine fails the
  camera with the cause and its remedy.

Geodetic GCPs (u,v,lat,lon,alt) are converted to the project's local ENU
frame with tlsync_pipeline.geodesy, around the project's origin (see
pipeline/origin.py), so cameras and trajectory share one world frame.
Editing a GCP file re-runs this stage only, not the checkerboard detection.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from calibration.camera import Camera, PoseInfo, read_camera, write_camera
from calibration.errors import CalibrationInputError
from calibration.extrinsics import (
    GcpTable,
    Pose,
    pose_from_board,
    pose_from_points,
    read_gcps,
)
from calibration.intrinsics import detect_board, parse_pattern
from tlsync_pipeline.artefacts.calibration import CalibrationReport, read_intrinsics_report, write_calibration_report
from tlsync_pipeline.artefacts.scan import ScanPlan, read_scan
from tlsync_pipeline.artefacts.video_info import read_video_info
from tlsync_pipeline.errors import InputError, SyncError
from tlsync_pipeline.geodesy import Origin, geodetic_to_enu
from tlsync_pipeline.outputs.calibration_report import calibration_plot, calibration_summary
from tlsync_pipeline.pipeline.origin import check_gcp_places, origin_inputs, resolve_origin
from tlsync_pipeline.pipeline.spec import Options, Sources, StageResult, StageSpec
from tlsync_pipeline.pipeline.stages.camera_plan import gcp_sigma, scans, target_pose_wanted
from tlsync_pipeline.pipeline.stages.cameras import POSE_ERROR, has_no_rows, ingest_report_input, log_model_of
from tlsync_pipeline.pipeline.stages.intrinsics import check_calibration
from tlsync_pipeline.pipeline.workspace import Artefact, StageFiles
from tlsync_pipeline.sync.identify.identify import IdentifyParams, identify_params
from tlsync_pipeline.sync.model.log_model import PRESETS, LogModel, LogModelChoice
from tlsync_pipeline.sync.model.methods import preparation_of, prepare_trajectory
from tlsync_pipeline.sync.model.params import Preparation, SyncParams
from tlsync_pipeline.sync.pose.pose import GCP_AGREE, estimate_pose, gcp_pose, pose_info, pose_log_sigma
from tlsync_pipeline.sync.pose.pose_fit import GcpPrior
from tlsync_pipeline.sync.vote.log_error import measured, with_log_noise
from tlsync_pipeline.trajectory import Trajectory, read_trajectory
from trackers.breaks import repeated_frames
from trackers.detections import Detections, read_detections
from trackers.track import Track, read_track

if TYPE_CHECKING:
    from tlsync_pipeline.pipeline.project import Project


@dataclass(frozen=True, eq=False)
class KnownBoard:
    """A checkerboard at a known world pose: inner corners COLSxROWS, square side (metres), board -> world R (3x3) and t
    (metres).
    """

    pattern: str
    square: float
    R: np.ndarray
    t: np.ndarray


@dataclass(frozen=True)
class TargetPoseParams:
    """What a pose from the target reads: the GCPs' survey sigma (metres; None without GCPs), identification's
    parameters (gate, loss scale, clock prior: sync/identify/identify.py), how the trajectory is prepared, the video
    the track stage found the target or the movers in (None: the project brings them), the log's error model
    ([target] log_model and its overrides, as the sync stage reads them: "auto" is what the ingest report suggests),
    and the upright-mount prior's tolerance in degrees ([sync] upright_roll_deg: sync/pose/upright.py)."""

    gcp_sigma_m: float | None
    identify: IdentifyParams
    preparation: Preparation
    source: Path | None = None
    log_model: LogModelChoice = field(default_factory=LogModelChoice)
    upright_roll_deg: float = SyncParams.upright_roll_deg


@dataclass(frozen=True)
class CalibrateParams:
    """What the pose reads: the camera's fps (kept in camera.json); with GCPs, their outlier threshold (pixels)
    and the ENU origin setting; with a board at a known pose, the board (its photo is an input); with a pose
    from the target, its parameters."""

    fps: float | None
    ransac_px: float | None = None
    origin: Origin | str | None = None
    board: KnownBoard | None = None
    target: TargetPoseParams | None = None


def gcp_world_points(table: GcpTable, origin: Origin | str | None) -> np.ndarray:
    """Local metres (N, 3) of a GCP table; geodetic points go through geodetic_to_enu around ``origin``."""
    if table.xyz is not None:
        return table.xyz
    if not isinstance(origin, Origin) or table.geodetic is None:
        raise InputError(
            f'{table.source}: geodetic GCPs cannot use origin = "first" (the log\'s first fix is not known when '
            f"calibrating); "
            'set [target] origin = [lat, lon, alt] or "gcps"'
        )
    return geodetic_to_enu(table.geodetic[:, 0], table.geodetic[:, 1], table.geodetic[:, 2], origin)


def calibrate_pose(
    name: str,
    params: CalibrateParams,
    known: Camera,
    intrinsics_report: dict,
    origin: Origin | str | None,
    gcp: Path | None,
    board_image: Path | None,
) -> tuple[Camera, dict, GcpPrior | None]:
    """A camera from known intrinsics and its GCPs or board (``gcp`` or ``board_image``); writes nothing.

    origin: the resolved ENU origin (geodetic GCPs). Returns the Camera (world =
    the project's local frame; without a pose when neither gives one), a
    JSON-ready report: ``intrinsics`` (as given) and ``pose`` (per-point
    reprojection errors, predicted uncertainty), and the GCPs as a prior for
    a pose from the target (``params.target``; None otherwise). With a pose
    from the target the GCPs' own pose is only its start: when they give
    none (too few, a survey too rough for every point) the report says so
    and the target's pose goes on without it.
    """
    import cv2

    K, dist, dist_model, size = known.K, known.dist, known.dist_model, known.image_size
    report: dict = {"camera": name, "intrinsics": intrinsics_report}
    pose: Pose | None = None
    prior: GcpPrior | None = None
    source = None
    if gcp is not None:
        table = read_gcps(gcp)
        _check_in_image(table, size)
        origin = origin if table.geodetic is not None else None
        if isinstance(origin, Origin):
            check_gcp_places(
                table,
                origin,
                "the [target] origin"
                if isinstance(params.origin, Origin)
                else "the origin (the centroid of every camera's GCPs)",
            )
        xyz = gcp_world_points(table, origin)
        assert params.ransac_px is not None, "calibrate_params gives GCPs their threshold"
        target = params.target
        if target is not None and target.gcp_sigma_m is not None:
            prior = GcpPrior(table.uv, xyz, target.gcp_sigma_m, table.names)
            try:
                if "intrinsics" in known.to_estimate:
                    raise CalibrationInputError("the camera has no K yet")
                pose = gcp_pose(known, prior, params.ransac_px)
            except CalibrationInputError as exc:
                report["warning"] = f"the GCPs alone give no pose ({exc}); the target's pose starts without them"
        else:
            pose = pose_from_points(table.uv, xyz, K, dist, dist_model, params.ransac_px, source=table.source)
        if pose is not None:
            source = "gcp"
            report["pose"] = {
                "source": table.source,
                "kind": "geodetic" if table.geodetic is not None else "local",
                **pose.to_report(table.names),
            }
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
            raise InputError(
                f"{board_image}: image is {gray.shape[1]}x{gray.shape[0]}, the camera's intrinsics are for "
                f"{size[0]}x{size[1]}"
            )
        corners, _, reason = detect_board(gray, pattern.size)
        if corners is None:
            raise InputError(f"{board_image}: board_pose: {reason} (pattern {pattern})")
        pose = pose_from_board(gray, corners, pattern, board.R, board.t, K, dist, dist_model, source=str(board_image))
        report["pose"] = {"source": str(board_image), "kind": "board", **pose.to_report()}
        source = "board"
    if pose is None:
        report.setdefault("pose", None)
        return (
            replace(
                known,
                name=name,
                fps=params.fps,
                R=np.eye(3),
                t=np.zeros(3),
                to_estimate=tuple(sorted(set(known.to_estimate) | {"pose"})),
                pose_info=None,
            ),
            report,
            prior,
        )
    info = PoseInfo(source or "gcp", pose.position_std_m, pose.rotation_std_deg)
    camera = Camera(
        name,
        K,
        dist,
        pose.R,
        pose.t,
        (int(size[0]), int(size[1])),
        params.fps,
        dist_model,
        dict(known.extra),
        pose_info=info,
    )
    return camera, report, prior


def pose_from_target(
    camera: Camera,
    params: TargetPoseParams,
    prior: GcpPrior | None,
    track: Track | None,
    detections: Detections | None,
    trajectory: Trajectory,
    ransac_px: float,
    offsets: tuple[float, float] | None = None,
    windows: tuple[tuple[int, int], ...] | None = None,
    log_model: LogModel = PRESETS["none"],
) -> tuple[Camera, dict]:
    """The camera posed by the target (its GCPs, if any, a prior; its GCP pose, if any, the start), and the report's
    ``target_pose`` (with the pose fit's ``timing``, which the sync stage gives the camera's line); offsets: the range
    of the line's beta searched (frames; None: all the log allows); windows: the frames where a pose from movers looks
    for the target's tracklets (the scan's windows; None: every frame); log_model: the log's error as declared or
    suggested, its white noise measured on the log (sync/vote/log_error.py's ``measured``) as synchronize() does:
    with a bias, the pose and the bias are fitted together.

    Raises PoseError (sync/pose/pose.py) when the target does not determine the pose.
    """
    log_model = measured(log_model, trajectory)
    prepared = with_log_noise(prepare_trajectory(trajectory, params.preparation), log_model)
    start = camera if camera.posed else None
    unposed = camera if not camera.posed else camera.without_pose()
    found, _ = estimate_pose(
        unposed,
        track,
        detections,
        prepared,
        camera.fps,
        params.identify,
        prior,
        ransac_px,
        start,
        offsets,
        log_model=log_model,
        windows=windows,
        max_roll_deg=params.upright_roll_deg,
    )
    info = pose_info(found, pose_log_sigma(prepared, log_model))
    posed = replace(found.camera, name=camera.name, fps=camera.fps, extra=dict(camera.extra), pose_info=info)
    return posed, found.to_report(info, prior)


def known_intrinsics(path: Path) -> dict:
    """The intrinsics part of the report for intrinsics taken from an existing camera.json (K null when it has none: the
    target's to fit).
    """
    known = read_camera(path)
    K = None if "intrinsics" in known.to_estimate else known.K.tolist()
    return {
        "source": str(path),
        "K": K,
        "dist": known.dist.tolist(),
        "dist_model": known.dist_model,
        "image_size": list(known.image_size),
    }


def _check_in_image(table: GcpTable, size: tuple[int, int]) -> None:
    w, h = size
    for (u, v), line in zip(table.uv, table.lines):
        if not (-0.5 <= u <= w - 0.5 and -0.5 <= v <= h - 0.5):
            raise InputError(f"{table.source}:{line}: pixel ({u:g}, {v:g}) is outside the {w}x{h} image")


def survey_pose(files: StageFiles, params: CalibrateParams) -> tuple[Camera, dict, GcpPrior | None]:
    """The camera from its intrinsics and its surveyed pose (GCPs or a board at a known pose; none without them), the
    report, and the GCPs as a prior for a pose from the target (calibrate_pose), from the task's declared files
    (survey_inputs)."""
    known = read_camera(files.path("intrinsics"))
    if files.has("intrinsics_report"):  # calibrated by the intrinsics stage: its rms stays in camera.json
        intrinsics_report = dict(read_intrinsics_report(files.path("intrinsics_report")).content)
    else:  # a given camera.json: only its intrinsics are taken
        known = Camera(
            known.name,
            known.K,
            known.dist,
            known.R,
            known.t,
            known.image_size,
            known.fps,
            known.dist_model,
            to_estimate=known.to_estimate,
        )
        intrinsics_report = known_intrinsics(files.path("intrinsics"))
    gcp = files.path("gcp") if files.has("gcp") else None
    origin = params.origin
    if gcp is not None and read_gcps(gcp).geodetic is not None:
        origin = resolve_origin(
            origin, [files.path(label) for label in files.inputs if label.startswith("origin-gcp:")], "[target]"
        )
    board_image = files.path("board_pose_image") if files.has("board_pose_image") else None
    return calibrate_pose(files.camera_name, params, known, intrinsics_report, origin, gcp, board_image)


def run_calibrate(files: StageFiles, params: CalibrateParams) -> StageResult:
    """The calibrate stage: camera.json, calibration_report.json and calibration.png of one camera."""
    camera, report, prior = survey_pose(files, params)
    failed = {}
    if params.target is not None:
        try:
            camera, report["target_pose"] = _pose_from_target_files(files, camera, params, prior)
        # the camera cannot be synchronized: camera.json without a pose says why, identify and vote pass it on
        except SyncError as exc:
            failed[files.camera_name] = str(exc)
            camera = replace(
                camera,
                R=np.eye(3),
                t=np.zeros(3),
                to_estimate=tuple(sorted(set(camera.to_estimate) | {"pose"})),
                pose_info=None,
                extra={**camera.extra, POSE_ERROR: str(exc)},
            )
            report["target_pose"] = {
                "error": str(exc),
                "cause": getattr(exc, "cause", None),
                "remedy": getattr(exc, "remedy", None),
            }
    with files.write("camera") as tmp:
        write_camera(camera, tmp)
    with files.write("calibration_report") as tmp:
        write_calibration_report(CalibrationReport(report), tmp)
    with files.write("calibration_picture") as tmp:
        tmp.write_bytes(calibration_plot(report, camera.image_size))
    return StageResult(
        message=f"{calibration_summary(report)}; wrote {files.output('camera')}",
        warnings=pose_warnings(report),
        failed=failed,
    )


def pose_warnings(report: dict) -> tuple[str, ...]:
    """The calibrate stage's warnings, from its report: ground control points left out as outliers, GCPs that give no
    pose, GCPs that disagree with the target's track, a pose from the target that serves timing but not 3D."""
    pose = report.get("pose") or {}
    out = [
        f"ground control point {point.get('name', '?')} left out as an outlier "
        f"({point.get('error_px', float('nan')):.1f} px)"
        for point in pose.get("points", [])
        if not point.get("inlier", True)
    ]
    target = report.get("target_pose") or {}
    disagree = target.get("gcps_disagree") or []
    if disagree:
        sigma = f"{GCP_AGREE:g} sigmas of {target.get('gcp_sigma_m', float('nan')):.2g} m"
        if target.get("source") == "target":
            out.append(
                f"ground control points {', '.join(disagree)} disagree with the target's track (beyond {sigma}): the "
                f"pose is the track's alone; check those points (pixel against world point) and that the log is in "
                f"the GCPs' frame"
            )
        else:
            out.append(
                f"ground control points {', '.join(disagree)} disagree with the track and the other points (beyond "
                f"{sigma}): left out of the pose; check them"
            )
    return tuple(out + [w for w in (report.get("warning"), target.get("note")) if w])


def _pose_from_target_files(
    files: StageFiles, camera: Camera, params: CalibrateParams, prior: GcpPrior | None
) -> tuple[Camera, dict]:
    """``pose_from_target`` on the task's track (or detections) and trajectory; SyncError when the target was never
    found or gives no pose.
    """
    assert params.target is not None
    label = "track" if files.has("track") else "detections"
    if params.target.source is not None and has_no_rows(files.path(label)):
        raise SyncError(f"{params.target.source}: the target was never found (no moving object in any frame)")
    track = read_track(files.path("track")) if label == "track" else None
    detections = read_detections(files.path("detections")) if label == "detections" else None
    if files.has("video_info"):  # frozen pictures show the target where it was, at a later frame: no evidence of pose
        repeated = repeated_frames(read_video_info(files.path("video_info")).breaks)
        if track is not None:
            keep = ~np.isin(track.frame, repeated)
            track = Track(**{k: v[keep] for k, v in track.columns().items()})
        if detections is not None:
            detections = detections.subset(np.flatnonzero(~np.isin(detections.frame, repeated)))
    scan = read_scan(files.path("scan")) if files.has("scan") else None
    offsets = coarse_offsets(scan, camera.fps) if scan is not None else None
    windows = scan.windows if scan is not None and not scan.full else None
    return pose_from_target(
        camera,
        params.target,
        prior,
        track,
        detections,
        read_trajectory(files.path("trajectory")),
        params.ransac_px or 8.0,
        offsets,
        windows,
        log_model_of(files, params.target.log_model),
    )


COARSE_MARGIN_S = (
    3.0  # seconds either side of the scan's coarse offset (good to a second or two) the pose's search covers
)


def coarse_offsets(scan: ScanPlan, fps: float | None) -> tuple[float, float] | None:
    """The range of beta (frames) around the scan stage's coarse line when the video was read in its windows (the
    detections exist only there), else None: the search covers every offset the log allows."""
    coarse = scan.coarse
    if scan.full or coarse is None or not fps:
        return None
    return float(coarse.beta) - COARSE_MARGIN_S * fps, float(coarse.beta) + COARSE_MARGIN_S * fps


def survey_inputs(src: Sources, name: str) -> dict[str, Path | Artefact]:
    """The intrinsics (the intrinsics stage's, the given camera.json), the surveyed pose's files
    and the origin's GCPs.
    """
    camera = src.project.camera(name)
    cal = camera.calibration
    inputs: dict[str, Path | Artefact] = {}
    if camera.camera is not None:
        if cal.board_views or cal.intrinsics is not None:
            raise InputError(
                f"{src.project.path}: camera {name!r}: give either 'camera' (a camera.json) or an intrinsics source "
                f"in [cameras.calibration], not both"
            )
        inputs = {"intrinsics": camera.camera}
    else:
        check_calibration(src.project, name)
        if src.made("intrinsics", name):
            inputs = {
                "intrinsics": src.artefact("intrinsics", name),
                "intrinsics_report": src.artefact("intrinsics_report", name),
            }
        elif cal.intrinsics is not None:
            inputs = {"intrinsics": cal.intrinsics}
    if cal.gcp is not None:
        inputs["gcp"] = cal.gcp
        inputs.update(origin_inputs(src.project))
    if cal.board_pose is not None:
        inputs["board_pose_image"] = cal.board_pose.image
    return inputs


def calibrate_inputs(src: Sources, name: str) -> dict[str, Path | Artefact]:
    """survey_inputs; for a pose from the target also the track (or every mover's detections), the trajectory and
    the ingest report (the log model it suggests) when the project ingests a log."""
    camera, cal = src.project.camera(name), src.project.camera(name).calibration
    inputs = survey_inputs(src, name)
    if target_pose_wanted(src.project, name):
        try:
            inputs["trajectory"] = src.artefact("trajectory")
            if camera.brings_movers:
                inputs["detections"] = src.artefact("detections", name)
            else:
                inputs["track"] = src.artefact("track", name)
            if src.made("video_info", name):  # the breaks the track stage found
                inputs["video_info"] = src.artefact("video_info", name)
            if scans(src.project, name):  # read in windows around a coarse line: the pose's offset search stays near it
                inputs["scan"] = src.artefact("scan", name)
            inputs.update(ingest_report_input(src))
        except InputError as exc:
            alone = "; or set gcp_sigma_m = 0 for the GCPs' pose alone" if cal.gcp is not None else ""
            raise InputError(f"{exc} (its pose comes from the target{alone})") from None
    return inputs


def survey_params(project: Project, name: str) -> CalibrateParams:
    """The camera's fps; the GCPs' threshold and the origin setting with GCPs; the board (without its photo, an input)
    with board_pose.
    """
    camera = project.camera(name)
    cal = camera.calibration
    board = None
    if cal.board_pose is not None:
        assert cal.pattern is not None and cal.square is not None  # check_calibration
        board = KnownBoard(cal.pattern, cal.square, cal.board_pose.R, cal.board_pose.t)
    if cal.gcp is None:
        return CalibrateParams(camera.fps, board=board)
    return CalibrateParams(camera.fps, cal.ransac_px, project.target.origin, board)


def calibrate_params(project: Project, name: str, options: Options) -> CalibrateParams:
    """survey_params, and a pose from the target's parameters when it gives the pose."""
    camera = project.camera(name)
    if not target_pose_wanted(project, name):
        return survey_params(project, name)
    source = camera.video if camera.tracked else None
    target = TargetPoseParams(
        gcp_sigma(project, name) if camera.calibration.gcp is not None else None,
        identify_params(project.sync),
        preparation_of(project.sync),
        source,
        project.target.log_error,
        project.sync.upright_roll_deg,
    )
    return replace(survey_params(project, name), target=target)


SPEC = StageSpec(
    "calibrate",
    inputs=calibrate_inputs,
    params=calibrate_params,
    outputs=("camera", "calibration_report", "calibration_picture"),
    run=run_calibrate,
    per_camera=True,
    light=True,
    applies=lambda project, name: (
        (project.camera(name).camera is None and project.camera(name).calibration.given)
        or target_pose_wanted(project, name)
    ),
)
