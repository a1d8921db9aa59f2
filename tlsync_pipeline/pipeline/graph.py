"""The stages of the pipeline and the tasks a project makes of them.

calibrate -> track -> ingest -> vote -> sync -> export -> render. calibrate,
track and vote run once per camera, the others once per project. A task is
one stage for one camera (or the project): the files it reads (hashed for its
cache key), its parameters, the artefacts it writes, the tasks that make its
input files, and the function that does the work. That function runs in a
worker process: it takes plain values (paths, numbers), writes its artefacts
atomically and returns a small JSON-able summary.

A file the user brings in the project file (``camera = ...``, ``track = ...``,
``[target] trajectory = ...``) takes the place of the stage that would make it.
"""

from __future__ import annotations

import glob
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from calibration.camera import read_camera
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.pipeline import layout
from tlsync_pipeline.pipeline.project import Project
from tlsync_pipeline.pipeline.stages import STAGE_VERSIONS, STAGES
from tlsync_pipeline.pipeline.stages.calibrate import has_calibration, run_calibrate
from tlsync_pipeline.pipeline.stages.export import run_export
from tlsync_pipeline.pipeline.stages.ingest import run_ingest
from tlsync_pipeline.pipeline.stages.render import run_render
from tlsync_pipeline.pipeline.stages.sync import run_sync
from tlsync_pipeline.pipeline.stages.track import run_track
from tlsync_pipeline.pipeline.stages.vote import run_vote
from tlsync_pipeline.sync.registry import params_table, vote_table
from tlsync_pipeline.trajectory import read_trajectory
from trackers.track import read_track


@dataclass
class Task:
    """One stage for one camera (camera None: the whole project)."""

    stage: str
    camera: str | None
    inputs: dict[str, Path]
    params: dict[str, Any]
    outputs: list[Path]
    deps: list[str]
    fn: Callable[..., dict]
    kwargs: dict[str, Any] = field(default_factory=dict)
    problem: str | None = None  # why it cannot run (an input the project does not say how to make)

    @property
    def id(self) -> str:
        return f"{self.stage}/{self.camera}" if self.camera else self.stage

    @property
    def version(self) -> int:
        return STAGE_VERSIONS[self.stage]


@dataclass
class Given:
    """An artefact the user brings instead of running a stage."""

    stage: str
    camera: str | None
    path: Path

    @property
    def id(self) -> str:
        return f"{self.stage}/{self.camera}" if self.camera else self.stage


@dataclass
class Graph:
    """Every task of a project in an order where inputs come before their users."""

    project: Project
    work: Path
    tasks: dict[str, Task]
    given: dict[str, Given]

    def select(self, stage: str, camera: str | None = None) -> list[str]:
        """Task ids of one stage (for one camera: its task, or the project-wide one); InputError when none."""
        if stage not in STAGES:
            raise InputError(f"unknown stage {stage!r}; stages: {', '.join(STAGES)}")
        if camera is not None:
            self.project.camera(camera)
        ids = [t for t, task in self.tasks.items() if task.stage == stage and (camera is None or task.camera in (camera, None))]
        if not ids:
            given = [g for g in self.given.values() if g.stage == stage and (camera is None or g.camera == camera)]
            if given:
                raise InputError(f"{given[0].id}: the project brings this artefact ({given[0].path}); there is no stage to run")
            raise InputError(f"{self.project.path}: nothing to run for stage {stage}" + (f" and camera {camera}" if camera else ""))
        return ids


@dataclass(frozen=True)
class Options:
    """Run options that are stage parameters (they enter the cache keys)."""

    render_pairs: tuple[tuple[str, str], ...] | None = None
    render_frames: tuple[int, ...] | None = None
    truth: Path | None = None
    progress: bool = True


# ---------------------------------------------------------------------------
# Building the graph


def build_graph(project: Project, work: Path, options: Options = Options()) -> Graph:
    """The tasks of ``project`` with artefacts under ``work``; InputError when an input is missing."""
    work = Path(work).resolve()
    tasks: dict[str, Task] = {}
    given: dict[str, Given] = {}

    def add(task: Task) -> None:
        tasks[task.id] = task

    problems: list[str] = []

    def source(make, *args):
        """(path, producing task) of an input, or (None, None) with the reason kept in ``problems``."""
        try:
            return make(project, *args, work, add, given, options.progress)
        except InputError as exc:
            problems.append(str(exc))
            return None, None

    trajectory, trajectory_dep = source(_trajectory_source)
    trajectory_problem = problems[-1] if trajectory is None else None
    sync_table = params_table(project.sync)
    vote_params = vote_table(project.sync)
    cameras = {}
    for spec in project.cameras:
        name = spec["name"]
        before = len(problems)
        camera_file, camera_dep = source(_camera_source, spec)
        track_file, track_dep = source(_track_source, spec)
        deps = [d for d in (camera_dep, track_dep, trajectory_dep) if d]
        votes = layout.votes_npz(work, name)
        inputs = {k: v for k, v in {"camera": camera_file, "track": track_file, "trajectory": trajectory}.items() if v is not None}
        problem = problems[before] if len(problems) > before else trajectory_problem
        add(
            Task(
                "vote",
                name,
                inputs,
                vote_params,
                [votes],
                deps,
                run_vote,
                {"name": name, "camera": camera_file, "track": track_file, "trajectory": trajectory, "params": vote_params, "out": votes},
                problem,
            )
        )
        cameras[name] = {"camera": camera_file, "track": track_file, "votes": votes, "fps": spec["fps"], "video": spec.get("video"), "deps": deps + [f"vote/{name}"]}

    names = list(cameras)
    sync_inputs = {f"{kind}:{n}": cameras[n][kind] for n in names for kind in ("camera", "track", "votes")}
    sync_inputs["trajectory"] = trajectory
    timeline = layout.timeline_json(work)
    sync_params = {**sync_table, "fps": {n: cameras[n]["fps"] for n in names}, "order": names}
    sync_deps = sorted({d for n in names for d in cameras[n]["deps"]})
    camera_args = {n: {k: cameras[n][k] for k in ("camera", "track", "votes", "fps", "video")} for n in names}
    add(Task("sync", None, sync_inputs, sync_params, [timeline], sync_deps, run_sync, {"cameras": camera_args, "trajectory": trajectory, "params": sync_table, "out": timeline}))

    export_inputs = {"timeline": timeline, **{f"track:{n}": cameras[n]["track"] for n in names}}
    export_inputs.update({f"video:{n}": cameras[n]["video"] for n in names if cameras[n]["video"]})
    outputs = [layout.frame_map_csv(work), layout.offsets_csv(work), layout.ffmpeg_script(work)]
    add(Task("export", None, export_inputs, {"fps": sync_params["fps"]}, outputs, ["sync"] + [d for d in sync_deps if d.startswith("track/")], run_export, {"cameras": camera_args, "timeline": timeline, "work": work}))

    render_inputs = {**sync_inputs, "timeline": timeline, **{f"video:{n}": cameras[n]["video"] for n in names if cameras[n]["video"]}}
    if options.truth is not None:
        render_inputs["truth"] = Path(options.truth).resolve()
    render_params = {
        "pairs": [list(p) for p in options.render_pairs] if options.render_pairs else None,
        "frames": list(options.render_frames) if options.render_frames else None,
        "delta": project.sync.delta,
    }
    add(
        Task(
            "render",
            None,
            render_inputs,
            render_params,
            [layout.report_md(work)],
            ["sync", "export"] + sync_deps,
            run_render,
            {"cameras": camera_args, "trajectory": trajectory, "timeline": timeline, "work": work, "truth": render_inputs.get("truth"), **render_params},
        )
    )
    if problems:
        for task in tasks.values():
            if task.camera is None and task.stage != "ingest":
                task.problem = problems[0]
                task.inputs = {k: v for k, v in task.inputs.items() if v is not None}
    return Graph(project, work, tasks, given)


def _trajectory_source(project: Project, work: Path, add, given, progress: bool = True) -> tuple[Path, str | None]:
    """The trajectory file and the task that makes it (None when the project brings it); InputError when neither."""
    path = project.target.get("trajectory")
    if path is not None:
        given["ingest"] = Given("ingest", None, path)
        return path, None
    log = project.target.get("log")
    if log is None:
        raise InputError(f"{project.path}: [target]: give 'log' (a GPS or odometry log to ingest) or 'trajectory' (a metric trajectory CSV)")
    inputs = {"log": Path(log), **_origin_inputs(project)}
    params = {k: v for k, v in project.target.items() if k not in ("trajectory", "log")}
    out = layout.trajectory_csv(work)
    add(Task("ingest", None, inputs, params, [out, layout.ingest_report(work)], [], run_ingest, {"project": project, "work": work}))
    return out, "ingest"


def _origin_inputs(project: Project) -> dict[str, Path]:
    """When the ENU origin is the centroid of every camera's GCPs (no ``[target] origin``, or "gcps"), they are all inputs."""
    if project.target.get("origin") not in (None, "gcps"):
        return {}
    gcps = {}
    for spec in project.cameras:
        gcp = (spec.get("calibration") or {}).get("gcp")
        if gcp is not None:
            gcps[f"origin-gcp:{spec['name']}"] = Path(gcp)
    return gcps


def _camera_source(project: Project, spec: dict, work: Path, add, given, progress: bool = True) -> tuple[Path, str | None]:
    name = spec["name"]
    if spec["camera"] is not None:
        given[f"calibrate/{name}"] = Given("calibrate", name, spec["camera"])
        return spec["camera"], None
    calibration = spec.get("calibration") or {}
    if not has_calibration(spec):
        raise InputError(f"{project.path}: camera {name!r}: give 'camera' (a camera.json) or a [cameras.calibration] table to calibrate it from")
    inputs: dict[str, Path] = {}
    if calibration.get("images") is not None:
        matches = sorted(glob.glob(str(calibration["images"])))
        if not matches:
            raise InputError(f"{project.path}: camera {name!r}: [cameras.calibration] images: no file matches {calibration['images']}")
        inputs.update({f"image:{Path(m).name}": Path(m) for m in matches})
    for key in ("video", "intrinsics", "gcp"):
        if calibration.get(key) is not None:
            inputs[key] = Path(calibration[key])
    if calibration.get("board_pose") is not None:
        inputs["board_pose_image"] = Path(calibration["board_pose"]["image"])
    if calibration.get("gcp") is not None:
        inputs.update(_origin_inputs(project))
    params = {"calibration": {k: v for k, v in calibration.items() if k != "images"}, "fps": spec["fps"], "origin": project.target.get("origin")}
    out = layout.camera_json(work, name)
    outputs = [out, layout.calibration_report(work, name), layout.calibration_picture(work, name)]
    add(Task("calibrate", name, inputs, params, outputs, [], run_calibrate, {"project": project, "name": name, "work": work, "progress": progress}))
    return out, f"calibrate/{name}"


def _track_source(project: Project, spec: dict, work: Path, add, given, progress: bool = True) -> tuple[Path, str | None]:
    name = spec["name"]
    if spec["track"] is not None:
        given[f"track/{name}"] = Given("track", name, spec["track"])
        return spec["track"], None
    if spec.get("video") is None:
        raise InputError(f"{project.path}: camera {name!r}: give 'track' (a track.csv) or 'video' (to track the target in)")
    params = {"tracker": spec.get("tracker"), "fps": spec["fps"]}
    out = layout.track_csv(work, name)
    add(Task("track", name, {"video": Path(spec["video"])}, params, [out], [], run_track, {"spec": spec, "out": out, "progress": progress}))
    return out, f"track/{name}"


def check_given(graph: Graph, wanted: list[str]) -> None:
    """Read the artefacts the user brings that ``wanted`` tasks use, so bad input stops the run before any stage runs."""
    readers = {"calibrate": read_camera, "track": read_track, "ingest": read_trajectory}
    used = {path for tid in wanted for path in graph.tasks[tid].inputs.values()}
    for item in graph.given.values():
        if item.path in used:
            readers[item.stage](item.path)
