"""The sync stage: every camera's line and the timeline into ``timeline.json``."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from calibration.camera import read_camera
from tlsync_pipeline.atomic import atomic_path
from tlsync_pipeline.errors import InputError, SyncError
from tlsync_pipeline.pipeline.spec import Sources, StageSpec
from tlsync_pipeline.pipeline.stages.cameras import camera_files, camera_params, read_identification, read_video_info
from tlsync_pipeline.pipeline.workspace import StageFiles
from tlsync_pipeline.sync.methods import CameraInput
from tlsync_pipeline.sync.registry import params_from_table, params_table
from tlsync_pipeline.sync.synchronize import CameraResult, synchronize
from tlsync_pipeline.sync.timeline import IdentificationSummary, ScanSummary, Timeline, write_timeline
from tlsync_pipeline.sync.votes import load_votes
from tlsync_pipeline.trajectory import Trajectory, read_trajectory
from trackers.track import read_track

TRUNCATED = "truncated"  # flag of a camera whose video ends before its announced end

if TYPE_CHECKING:
    from tlsync_pipeline.pipeline.project import Project


def read_camera_inputs(cameras: dict[str, dict]) -> dict:
    """CameraInput per camera from the paths of ``stages.cameras.camera_files``.

    A camera whose target could not be identified among its movers has no
    track.csv (its votes carry the reason): its track is None.
    """
    out = {}
    for name, c in cameras.items():
        cam = read_camera(c["camera"], name=name)
        track = None if c.get("identification") is not None and not c["track"].exists() else read_track(c["track"])
        out[name] = CameraInput(cam, track, c["fps"] if c["fps"] is not None else cam.fps)
    return out


def read_votes(cameras: dict[str, dict]) -> dict:
    """Each camera's votes.npz: its Votes, or the SyncError the vote stage met."""
    out = {}
    for name, c in cameras.items():
        votes, error = load_votes(c["votes"])
        out[name] = SyncError(error) if error else votes
    return out


def run_sync(files: StageFiles, cameras: list[str], fps: dict[str, float | None], sync: dict, left_out: dict[str, str] | None = None) -> dict:
    """The sync stage: each camera's line fitted to the vote stage's votes, ``timeline.json``.

    sync: the ``[sync]`` table (sync.registry.params_table). A camera whose
    ``votes.npz`` records why it has no vote (the target never found, never
    near its projection) is listed under ``failed`` with that reason, without
    reading its other files. A camera whose video the track stage found
    truncated gets the flag ``truncated``. ``left_out``: cameras whose own
    tasks did not complete (camera -> why), listed under ``failed`` too.
    """
    paths = camera_files(files, cameras, fps)
    votes = read_votes(paths)
    usable = {name: c for name, c in paths.items() if not isinstance(votes[name], SyncError)}
    timeline, _ = synchronize(read_camera_inputs(usable), read_trajectory(files.path("trajectory")), params_from_table(sync), votes)
    failed = {name: str(votes[name]) if name not in usable else timeline.failed[name] for name in paths if name not in usable or name in timeline.failed}
    lines = {name: _with_scan(_flag_truncated(line, paths[name]), paths[name]) for name, line in timeline.cameras.items()}
    timeline = replace(timeline, cameras=lines, failed={**failed, **(left_out or {})})
    timeline = with_identifications(timeline, {n: read_identification(c["identification"]) for n, c in paths.items() if c.get("identification") is not None})
    with files.write("timeline") as tmp:
        write_timeline(timeline, tmp)
    return {"synchronized": timeline.names, "failed": timeline.failed}


def with_identifications(timeline: Timeline, found: dict) -> Timeline:
    """The timeline with each identified camera's line carrying its identification summary."""
    lines = {n: replace(line, identification=found[n]) if isinstance(found.get(n), IdentificationSummary) else line for n, line in timeline.cameras.items()}
    return replace(timeline, cameras=lines)


def _with_scan(line, camera: dict):
    """The camera's line with how its video was read (video.json), when the track stage read it."""
    info = read_video_info(camera["video_info"]) if camera.get("video_info") else {}
    if "scan" not in info:
        return line
    return replace(line, scan=ScanSummary(info["scan"], info["scan_reason"], int(info["frames"]), int(info["keyframes_decoded"]), int(info["frames_decoded"])))


def _flag_truncated(line, camera: dict):
    """The camera's line with the flag ``truncated`` when the track stage found its video shorter than announced."""
    if not camera.get("video_info") or not read_video_info(camera["video_info"])["truncated"]:
        return line
    return replace(line, flags=(*(line.flags or ()), TRUNCATED))


def load_inputs(project: Project) -> tuple[dict[str, CameraInput], Trajectory]:
    """Every camera's calibration and track, and the target's trajectory."""
    if project.target["trajectory"] is None:
        raise InputError(f"{project.path}: [target]: missing key 'trajectory' (the target's trajectory CSV)")
    cameras = {}
    for spec in project.cameras:
        for key, what in (("camera", "calibration (camera.json)"), ("track", "track (track.csv)")):
            if spec[key] is None:
                raise InputError(f"{project.path}: camera {spec['name']!r}: missing key {key!r}: the camera's {what}")
        camera = read_camera(spec["camera"], name=spec["name"])
        fps = spec["fps"] if spec["fps"] is not None else camera.fps
        cameras[spec["name"]] = CameraInput(camera, read_track(spec["track"]), fps)
    return cameras, read_trajectory(project.target["trajectory"])


def run_project(project: Project, out_dir: Path) -> tuple[Timeline, dict[str, CameraResult]]:
    """Synchronize the project's cameras and write ``out_dir/timeline.json`` atomically."""
    cameras, trajectory = load_inputs(project)
    timeline, results = synchronize(cameras, trajectory, project.sync)
    with atomic_path(out_dir / "timeline.json") as tmp:
        write_timeline(timeline, tmp)
    return timeline, results


def sync_inputs(src: Sources, camera: None) -> dict:
    """Every camera's calibration, track and votes (and video.json when the track stage makes it), and the trajectory."""
    inputs = {f"{kind}:{spec['name']}": src.artefact(kind, spec["name"]) for spec in src.project.cameras for kind in ("camera", "track", "votes")}
    inputs.update({f"identification:{spec['name']}": src.artefact("identification", spec["name"]) for spec in src.project.cameras if src.made("identification", spec["name"])})
    inputs.update({f"video_info:{spec['name']}": src.artefact("video_info", spec["name"]) for spec in src.project.cameras if src.made("video_info", spec["name"])})
    return {**inputs, "trajectory": src.artefact("trajectory")}


SPEC = StageSpec(
    "sync",
    inputs=sync_inputs,
    params=lambda project, camera, options: {**camera_params(project), "sync": params_table(project.sync)},
    outputs=("timeline",),
    run=run_sync,
    runs_without_failed_cameras=True,
)
