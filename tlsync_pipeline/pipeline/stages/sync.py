"""The sync stage: every camera's line and the timeline into ``timeline.json``."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

from calibration.camera import read_camera
from tlsync_pipeline.artefacts.calibration import read_calibration_report
from tlsync_pipeline.artefacts.clock import read_clock
from tlsync_pipeline.artefacts.identification import IdentificationSummary, read_identification
from tlsync_pipeline.artefacts.video_info import read_video_info
from tlsync_pipeline.atomic import atomic_path
from tlsync_pipeline.errors import INPUT_ERRORS, InputError, SyncError
from tlsync_pipeline.ingest.report import read_ingest_report
from tlsync_pipeline.outputs.diagnostics import run_warnings
from tlsync_pipeline.pipeline.spec import Options, Sources, StageResult, StageSpec
from tlsync_pipeline.pipeline.stages.cameras import (
    CameraFiles,
    CamerasParams,
    camera_files,
    cameras_params,
    container_fps,
    log_model_of,
)
from tlsync_pipeline.pipeline.workspace import Artefact, StageFiles
from tlsync_pipeline.sync.clock_prior import with_clock_checks
from tlsync_pipeline.sync.identify.breaks import merged
from tlsync_pipeline.sync.model.log_model import LogModelChoice
from tlsync_pipeline.sync.model.params import SyncParams
from tlsync_pipeline.sync.model.status import WEAK, Reason
from tlsync_pipeline.sync.pose.pose_timing import PoseTiming
from tlsync_pipeline.sync.solve.methods import CameraInput
from tlsync_pipeline.sync.solve.plausibility import LogUnitError
from tlsync_pipeline.sync.solve.synchronize import CameraResult, synchronize, with_identification_line
from tlsync_pipeline.sync.timeline import CameraLine, ScanSummary, StageWarning, Timeline, write_timeline
from tlsync_pipeline.sync.vote.visits import near_views
from tlsync_pipeline.sync.vote.votes import Votes, read_votes
from tlsync_pipeline.trajectory import Trajectory, read_trajectory
from trackers.breaks import Break
from trackers.track import read_track

TRUNCATED = "truncated"  # flag of a camera whose video ends before its announced end
POSIX_2000 = 946_684_800.0

if TYPE_CHECKING:
    from tlsync_pipeline.pipeline.project import Project


@dataclass(frozen=True)
class SyncStageParams(CamerasParams):
    """The cameras, their fps (CamerasParams), every [sync] key (the lines' fit reads them all), the log's error model,
    and the file the target's trajectory comes from with its [target] key (named when every camera says its units are
    wrong)."""

    sync: SyncParams = field(default_factory=SyncParams)
    log_model: LogModelChoice = field(default_factory=LogModelChoice)
    source: tuple[str, Path] | None = None
    container_fps: Mapping[str, float] = field(default_factory=dict)
    picks: Mapping[str, float] = field(default_factory=dict)  # [[cameras]] pick_start_s by camera


def read_camera_inputs(cameras: dict[str, CameraFiles]) -> dict[str, CameraInput]:
    """CameraInput per camera from its files.

    A camera whose target could not be identified among its movers has no
    track.csv (its votes carry the reason): its track is None. A camera the
    calibrate stage posed from the target brings that pose fit's timing
    (read_pose_timing).
    """
    out = {}
    for name, c in cameras.items():
        assert c.camera is not None and c.track is not None, "declared by the stage"
        cam = read_camera(c.camera, name=name)
        track = None if c.identification is not None and not c.track.exists() else read_track(c.track)
        out[name] = CameraInput(
            cam,
            track,
            c.fps if c.fps is not None else cam.fps,
            breaks=read_breaks(c),
            pose_timing=read_pose_timing(c.calibration_report) if c.calibration_report is not None else None,
        )
    return out


def read_pose_timing(path: Path) -> PoseTiming | None:
    """The timing of the calibrate stage's pose from the target (calibration_report.json's ``target_pose.timing``),
    or None when the camera's pose is not the target's."""
    timing = (read_calibration_report(path).content.get("target_pose") or {}).get("timing")
    return None if timing is None else PoseTiming.from_dict(timing, str(path))


def read_breaks(camera: CameraFiles) -> tuple[Break, ...]:
    """Where a camera's recording may leave its steady clock: video.json's breaks (track stage) and the drop its
    movers' votes show (identification.json), in frame order."""
    found: tuple[Break, ...] = ()
    if camera.video_info is not None and camera.video_info.exists():
        found += read_video_info(camera.video_info).breaks
    if camera.identification is not None and camera.identification.exists():
        found += read_identification(camera.identification).breaks
    return merged(found)


def _readable(paths: dict[str, CameraFiles], usable: dict[str, CameraFiles]) -> dict[str, CameraInput]:
    """Every usable camera's inputs, and those of the cameras without votes whose files can be read (what they
    track helps tell a log in another unit, sync/solve/plausibility.py)."""
    out = {}
    for name, c in paths.items():
        try:
            out.update(read_camera_inputs({name: c}))
        except INPUT_ERRORS:
            if name in usable:
                raise
    return out


def camera_votes(cameras: dict[str, CameraFiles]) -> dict[str, Votes | SyncError]:
    """Each camera's votes.npz: its Votes, or the SyncError the vote stage met."""
    out: dict[str, Votes | SyncError] = {}
    for name, c in cameras.items():
        assert c.votes is not None, "declared by the stage"
        found = read_votes(c.votes)
        out[name] = SyncError(found.error) if found.error else found.votes
    return out


def run_sync(files: StageFiles, params: SyncStageParams) -> StageResult:
    """The sync stage: each camera's line fitted to the vote stage's votes, ``timeline.json``.

    timeline.json's ``warnings``: those the stages that made its inputs
    recorded, then the sync method's per camera (also this stage's warnings).
    A camera whose ``votes.npz`` records why it has no vote (the target never
    found, never near its projection, its pose not found by the calibrate
    stage) is listed under ``failed`` with that reason, unless a later pass of
    synchronize() on the log the others corrected synchronizes it. A camera whose video the track
    stage found truncated gets the flag ``truncated``; one whose clock stage
    found a recording time is checked against it (the flag ``clock_disagrees``
    when they disagree: sync/clock_prior.py). Cameras left out (their own tasks
    did not complete) are listed under ``failed`` too.
    """
    paths = camera_files(files, params)
    votes = camera_votes(paths)
    usable = {name: c for name, c in paths.items() if not isinstance(votes[name], SyncError)}
    found = {n: read_identification(c.identification).summary for n, c in paths.items() if c.identification is not None}
    try:
        inputs = {
            n: replace(i, pick_start_s=params.picks.get(n), identification=found.get(n))
            for n, i in _readable(paths, usable).items()
        }
        trajectory = near_views(read_trajectory(files.path("trajectory")), [c.camera for c in inputs.values()])
        timeline, _ = synchronize(inputs, trajectory, params.sync, votes, log_model_of(files, params.log_model))
    except LogUnitError as exc:
        key, source = params.source or ("trajectory", files.path("trajectory"))
        raise InputError(f"{source} ([target] {key}): {exc}") from None
    failed = not_synchronized(list(paths), votes, timeline)
    lines = {
        name: _with_scan(_flag_truncated(line, paths[name]), paths[name]) for name, line in timeline.cameras.items()
    }
    lines = {
        name: _with_container_fps(line, params.fps.get(name), params.container_fps.get(name))
        for name, line in lines.items()
    }
    timeline = replace(timeline, cameras=lines, failed={**failed, **params.left_out})
    timeline = with_identifications(timeline, found)
    priors = {
        n: prior for n, c in paths.items() if c.clock is not None and (prior := read_clock(c.clock).prior) is not None
    }
    if priors:
        timeline = with_clock_checks(timeline, priors, log_on_utc(files, timeline))
    own = tuple(f"{name}: {text}" for name, line in timeline.cameras.items() for text in line.warnings or ())
    timeline = replace(
        timeline, warnings=(*run_warnings(files.history), *(StageWarning("sync", None, text) for text in own))
    )
    with files.write("timeline") as tmp:
        write_timeline(timeline, tmp)
    return StageResult(warnings=own, failed=timeline.failed, facts={"synchronized": timeline.names})


def not_synchronized(names: list[str], votes: dict[str, Votes | SyncError], timeline: Timeline) -> dict[str, str]:
    """Why each of the cameras ``names`` is not synchronized: the sync's reason, or the vote stage's for a camera
    without votes (a camera the vote stage failed that the sync's second pass synchronized, on votes of its own, is
    not: timeline.json lists a camera under ``cameras`` or ``failed``, never both)."""
    return {
        name: timeline.failed.get(name, str(votes[name]))
        for name in names
        if name in timeline.failed or (isinstance(votes[name], SyncError) and name not in timeline.cameras)
    }


def log_on_utc(files: StageFiles, timeline: Timeline) -> bool:
    """Whether the target's times are UTC: as the ingest report says; a trajectory the project brings, when its
    times are after 2000 (POSIX seconds, docs/formats.md)."""
    if files.has("ingest_report"):
        return read_ingest_report(files.path("ingest_report")).clock == "UTC"
    return timeline.target_t0 is not None and timeline.target_t0 >= POSIX_2000


def with_identifications(timeline: Timeline, found: dict[str, IdentificationSummary | None]) -> Timeline:
    """The timeline with each identified camera's line carrying its identification summary, its covariance widened
    by the identification's line (synchronize.with_identification_line)."""
    lines = {
        n: with_identification_line(replace(line, identification=summary))
        if isinstance(summary := found.get(n), IdentificationSummary)
        else line
        for n, line in timeline.cameras.items()
    }
    return replace(timeline, cameras=lines)


FPS_TOLERANCE = (
    5e-4  # the fps key and the video's container may differ by this fraction (rounding of 30000/1001 and the like)
)


def _with_container_fps(line: CameraLine, fps: float | None, container: float | None) -> CameraLine:
    """The camera's line with a weak reason when its fps key differs from its video's container rate (not when the
    container's times jump: its average rate then counts the gap, and the breaks say so)."""
    jumps = any(b.kind in ("gap", "repeat") for b in line.breaks or ())
    if fps is None or container is None or jumps or abs(fps / container - 1.0) <= FPS_TOLERANCE:
        return line
    reason = Reason(
        "fps_container",
        WEAK,
        f"fps = {fps:g} but the video's container says {container:.6g} fps ({100 * abs(fps / container - 1):.2g} % "
        f"apart): the line's slope prior and the offsets in seconds use {fps:g}",
        "set fps to the rate the camera recorded at (the container's, unless it is wrong)",
    )
    return replace(line, checks=(*(line.checks or ()), reason))


def _with_scan(line: CameraLine, camera: CameraFiles) -> CameraLine:
    """The camera's line with how its video was read (video.json), when the track stage read it."""
    info = read_video_info(camera.video_info) if camera.video_info is not None else None
    if info is None or info.scan is None:
        return line
    return replace(
        line, scan=ScanSummary(info.scan, info.scan_reason, info.frames, info.keyframes_decoded, info.frames_decoded)
    )


def _flag_truncated(line: CameraLine, camera: CameraFiles) -> CameraLine:
    """The camera's line with the flag ``truncated`` when the track stage found its video shorter than announced."""
    if camera.video_info is None or not read_video_info(camera.video_info).truncated:
        return line
    return replace(line, flags=(*(line.flags or ()), TRUNCATED))


def load_inputs(project: Project) -> tuple[dict[str, CameraInput], Trajectory]:
    """Every camera's calibration and track, and the target's trajectory (a project that brings them all)."""
    if project.target.trajectory is None:
        raise InputError(f"{project.path}: [target]: missing key 'trajectory' (the target's trajectory CSV)")
    cameras = {}
    for spec in project.cameras:
        if spec.camera is None or spec.track is None:
            missing, what = (
                ("camera", "calibration (camera.json)") if spec.camera is None else ("track", "track (track.csv)")
            )
            raise InputError(f"{project.path}: camera {spec.name!r}: missing key {missing!r}: the camera's {what}")
        camera = read_camera(spec.camera, name=spec.name)
        cameras[spec.name] = CameraInput(
            camera,
            read_track(spec.track),
            spec.fps if spec.fps is not None else camera.fps,
            pick_start_s=spec.pick_start_s,
        )
    return cameras, read_trajectory(project.target.trajectory)


def run_project(project: Project, out_dir: Path) -> tuple[Timeline, dict[str, CameraResult]]:
    """Synchronize a project that brings every camera's calibration and track; write ``out_dir/timeline.json``
    atomically.
    """
    cameras, trajectory = load_inputs(project)
    timeline, results = synchronize(cameras, trajectory, project.sync)
    with atomic_path(out_dir / "timeline.json") as tmp:
        write_timeline(timeline, tmp)
    return timeline, results


def sync_inputs(src: Sources, camera: None) -> dict[str, Path | Artefact]:
    """Every camera's calibration, track and votes (and video.json when the track stage makes it, the calibration
    report when the calibrate stage does: a pose from the target's timing), and the trajectory.
    """
    names = src.project.names
    inputs = {f"{kind}:{name}": src.artefact(kind, name) for name in names for kind in ("camera", "track", "votes")}
    inputs.update(
        {
            f"calibration_report:{name}": src.artefact("calibration_report", name)
            for name in names
            if src.made("calibration_report", name)
        }
    )
    inputs.update(
        {
            f"identification:{name}": src.artefact("identification", name)
            for name in names
            if src.made("identification", name)
        }
    )
    inputs.update(
        {f"video_info:{name}": src.artefact("video_info", name) for name in names if src.made("video_info", name)}
    )
    inputs.update({f"clock:{name}": src.artefact("clock", name) for name in names if src.made("clock", name)})
    if src.made("ingest_report"):
        inputs["ingest_report"] = src.artefact("ingest_report")
    return {**inputs, "trajectory": src.artefact("trajectory")}


def sync_params(project: Project, camera: None, options: Options) -> SyncStageParams:
    cameras = cameras_params(project)
    target = project.target
    source = (
        ("trajectory", target.trajectory)
        if target.trajectory is not None
        else ("log", target.log)
        if target.log is not None
        else None
    )
    picks = {c.name: c.pick_start_s for c in project.cameras if c.pick_start_s is not None}
    return SyncStageParams(
        cameras.cameras,
        fps=cameras.fps,
        sync=project.sync,
        log_model=target.log_error,
        source=source,
        container_fps=container_fps(project),
        picks=picks,
    )


SPEC = StageSpec(
    "sync",
    inputs=sync_inputs,
    params=sync_params,
    outputs=("timeline",),
    run=run_sync,
    history=True,
    runs_without_failed_cameras=True,
)
