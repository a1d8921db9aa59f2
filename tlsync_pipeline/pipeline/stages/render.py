"""The render stage: pictures, charts, the player's proxies, report.html and report.md, from cached artefacts.

Writes under ``<work>/render/``: per camera the voting space, the trajectory
check and the before/after band swap (outputs/camera_pictures.py); per pair
of cameras the strip of matching frames; the offsets and residuals charts;
proxy clips for videos a browser cannot play. Then ``<work>/report.html``
(self-contained) and ``<work>/report.md``, which gather every stage's
warnings. This module reads the artefacts and writes the files; the drawing
is in outputs/.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

import numpy as np

from calibration.camera import Camera
from tlsync_pipeline.artefacts.calibration import read_calibration_report
from tlsync_pipeline.artefacts.exports import write_text
from tlsync_pipeline.artefacts.kinds import artefact_path
from tlsync_pipeline.artefacts.scan import read_scan
from tlsync_pipeline.atomic import atomic_path
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.ingest.report import read_ingest_report
from tlsync_pipeline.outputs.calibration_report import calibration_summary, sync_pose_clause
from tlsync_pipeline.outputs.camera_pictures import (
    KEYFRAME_REACH,
    CameraJob,
    DrawnCamera,
    draw_camera,
    draw_panels,
    photo,
    picture,
)
from tlsync_pipeline.outputs.diagnostics import StageRun, run_warnings
from tlsync_pipeline.outputs.pictures import (
    PairPlan,
    PanelRequest,
    assemble_pair,
    choose_frames,
    pair_frames,
    plan_pair,
    write_png,
)
from tlsync_pipeline.outputs.player import player_data
from tlsync_pipeline.outputs.plots import offsets_plot, recordings_plot, residuals_plot, track_residuals
from tlsync_pipeline.outputs.report_content import Picture, ReportContent
from tlsync_pipeline.outputs.report_html import report_html
from tlsync_pipeline.outputs.report_md import report_markdown
from tlsync_pipeline.pipeline.executors import SerialExecutor, run_each
from tlsync_pipeline.pipeline.spec import Options, Sources, StageResult, StageSpec
from tlsync_pipeline.pipeline.stages.cameras import CameraFiles, CamerasParams, camera_files, cameras_params
from tlsync_pipeline.pipeline.stages.export import frame_count, frame_times
from tlsync_pipeline.pipeline.stages.sync import read_camera_inputs
from tlsync_pipeline.pipeline.strip_requests import StripRequest, read_requests, write_requests
from tlsync_pipeline.pipeline.workspace import Artefact, StageFiles
from tlsync_pipeline.sync.model.clock import FrameTimes
from tlsync_pipeline.sync.model.log_model import LogModel
from tlsync_pipeline.sync.model.methods import params_from_table, preparation_of, prepare_trajectory
from tlsync_pipeline.sync.solve.methods import CameraInput
from tlsync_pipeline.sync.timeline import Timeline, read_timeline
from tlsync_pipeline.sync.vote.log_error import vote_radius
from tlsync_pipeline.sync.vote.visits import near_views
from tlsync_pipeline.trajectory import PiecewiseTrajectory, Trajectory, read_trajectory
from trackers.video import keyframe_indices

if TYPE_CHECKING:
    from tlsync_pipeline.pipeline.project import Project

T = TypeVar("T")

EXPORT_LABELS = (  # the export stage's artefacts the report links to, by kind
    ("frame map (CSV)", "frame_map"),
    ("offsets (CSV)", "offsets"),
    ("ffmpeg commands", "ffmpeg"),
    ("OpenTimelineIO timeline (DaVinci Resolve, Premiere via plug-in, ...)", "timeline_otio"),
    ("FCPXML timeline (Final Cut Pro, DaVinci Resolve)", "timeline_fcpxml"),
    ("sync.json (offsets with their sign convention)", "sync_json"),
)


@dataclass(frozen=True)
class RenderParams(CamerasParams):
    """The cameras and their fps (CamerasParams); proxy: camera -> proxy policy ("auto", "always", "never")."""

    proxy: Mapping[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class _Scene:
    """What every picture of the run is drawn from: the timeline, the trajectory as logged and as the sync method
    prepared it, the synchronized cameras' inputs, files, presentation times, videos and frame counts."""

    timeline: Timeline
    trajectory: Trajectory
    prepared: Trajectory
    cameras: dict[str, CameraFiles]
    inputs: dict[str, CameraInput]
    times: dict[str, FrameTimes | None]
    videos: dict[str, Path]
    n_frames: dict[str, int]
    path_model: PiecewiseTrajectory

    def keyframes(self, name: str) -> np.ndarray | None:
        """The keyframe indices of the camera's video (demuxed once per process), None without a packet index."""
        return keyframe_indices(self.videos[name])


def run_render(files: StageFiles, params: RenderParams) -> StageResult:
    """The render stage: pictures, charts, proxies, report.html and report.md; and the strips asked for earlier.

    Pictures of an earlier run that this one did not draw are removed
    (remove_other_pictures): of cameras no longer synchronized, of strips
    asked for that cannot be drawn now. The asked-for strips (StripRequest)
    are drawn again, but are not the stage's artefacts: they never make it
    stale. The result's facts: per default pair "A,B", the frames drawn
    ([frame of B, frame of A]) and the pictures removed.
    """
    scene = _read_scene(files, params)
    work, out_dir = files.output("report").parent, files.output("pictures")
    notes: list[str] = []
    requests: dict[str, list[PanelRequest]] = {}
    plans, drawn = _plan_strips(scene, default_pairs(scene), StripRequest(), requests, notes)
    asked = []
    for request in read_requests(out_dir):
        pairs = [
            pair for pair in request.pairs or default_pairs(scene) if not _strip_problem(scene, *pair, request.frames)
        ]
        asked += [
            (plan, request.file_name(plan.a, plan.b)) for plan in _plan_strips(scene, pairs, request, requests, [])[0]
        ]
    jobs = [_camera_job(scene, name, params, requests.get(name, []), out_dir, work) for name in scene.timeline.cameras]
    charts_part = (draw_charts, {"scene": scene, "out_dir": out_dir, "work": work})
    called = run_each(files.workers or SerialExecutor(), [*((draw_camera, {"job": job}) for job in jobs), charts_part])
    cameras: dict[str, DrawnCamera] = {job.name: call.value for job, call in zip(jobs, called)}
    charts: list[Picture] = called[-1].value
    panels = {n: c.panels for n, c in cameras.items()}
    written = [path for camera in cameras.values() for path in camera.written] + [
        camera.proxy for camera in cameras.values() if camera.proxy is not None
    ]
    strips = []
    for plan in plans:
        path = write_png(out_dir / f"strip_{plan.a}_{plan.b}.png", strip_of(plan, panels))
        written.append(path)
        strips.append(photo(f"{plan.a} and {plan.b}: matching frames", path, work))
    requested = [write_png(out_dir / name, strip_of(plan, panels)) for plan, name in asked]
    written += [work / c.href for c in charts]
    notes = list(dict.fromkeys([*notes, *(w for call in called for w in call.warnings)]))
    content = _report_content(files, scene, params, cameras, strips, charts, notes)
    removed = remove_other_pictures(out_dir, written + requested)
    with files.write("report_html") as tmp:
        write_text(report_html(content), tmp)
    with files.write("report") as tmp:
        write_text(report_markdown(content), tmp)
    return StageResult(
        "; ".join(notes) or None,
        outputs=tuple(written),
        facts={"frames": drawn, "removed": [p.name for p in removed], "report": str(files.output("report_html"))},
        worker_cpu_s=sum(call.cpu_s for call in called if call.elsewhere),
    )


def _read_scene(files: StageFiles, params: RenderParams) -> _Scene:
    """What the pictures are drawn from: the timeline's, each camera with the pose its line was fitted with, on the
    log its lines were fitted to (``drawn_as_fitted``)."""
    timeline = read_timeline(files.path("timeline"))
    cameras = camera_files(files, params)
    synchronized = {n: c for n, c in cameras.items() if n in timeline.cameras}
    logged = read_trajectory(files.path("trajectory"))
    inputs, logged = drawn_as_fitted(timeline, read_camera_inputs(synchronized), logged)
    trajectory = near_views(logged, [c.camera for c in inputs.values()])
    prepared = prepare_trajectory(trajectory, preparation_of(params_from_table(timeline.params.table())))
    return _Scene(
        timeline,
        trajectory,
        prepared,
        cameras,
        inputs,
        {name: frame_times(cameras[name], line) for name, line in timeline.cameras.items()},
        {n: c.video for n, c in synchronized.items() if c.video is not None},
        {n: frame_count(c) for n, c in synchronized.items()},
        PiecewiseTrajectory(prepared),
    )


def drawn_as_fitted(
    timeline: Timeline, inputs: dict[str, CameraInput], trajectory: Trajectory
) -> tuple[dict[str, CameraInput], Trajectory]:
    """The synchronized cameras' inputs with the pose each line was fitted with where the sync found it itself
    (CameraLine.pose: camera.json keeps the calibrate stage's), and the log corrected as those poses were fitted on it
    (Timeline.log_correction: the sync's later passes' correction, then the bias its last pass's lines' poses were
    fitted on; as given without one)."""
    posed = {
        n: replace(i, camera=line.pose.on(i.camera)) if (line := timeline.cameras[n]).pose is not None else i
        for n, i in inputs.items()
    }
    correction = timeline.log_correction
    return posed, trajectory if correction is None else correction.applied(trajectory)


def fitted_radius(timeline: Timeline, camera: Camera, prepared: Trajectory) -> float:
    """The vote radius (pixels) the sync gave the camera: log_error.vote_radius under timeline.json's gate model
    (``log_error.model.gate``), [sync] eps_px without one."""
    eps_px = timeline.params.shared.eps_px
    gate = (timeline.log_model or {}).get("gate")
    return eps_px if not gate else vote_radius(camera, prepared, eps_px, LogModel(**gate))


def default_pairs(scene: _Scene) -> list[tuple[str, str]]:
    """The strips drawn by default: the first synchronized camera with a video, with each other one with a video.

    Cameras without a video have no strip (a tracks-only project has none):
    that is expected, not a warning.
    """
    names = [n for n in scene.timeline.names if n in scene.videos]
    return [(names[0], other) for other in names[1:]] if names else []


def _strip_problem(scene: _Scene, a: str, b: str, frames: tuple[int, ...] | None) -> str | None:
    """Why the strip of A, B cannot be drawn from this timeline (a camera not synchronized, without a video, a frame
    past B's end), or None."""
    for name in (a, b):
        if name not in scene.timeline.cameras:
            return f"{name} is not synchronized"
        if name not in scene.videos:
            return f"{name} has no video (a strip shows video frames)"
    late = [f for f in frames or () if not 0 <= f < scene.n_frames[b]]
    if late:
        return f"frame {late[0]} is not a frame of {b} (0 to {scene.n_frames[b] - 1})"
    return None


def _plan_strips(
    scene: _Scene,
    pairs: list[tuple[str, str]],
    request: StripRequest,
    requests: dict[str, list[PanelRequest]],
    notes: list[str],
) -> tuple[list[PairPlan], dict[str, list[list[int]]]]:
    """The strips of ``pairs`` to draw (their panels appended to ``requests``) and, per pair "A,B", the frames drawn.

    request: the frames of B asked for (None: chosen) and the true relations (A's true match drawn too), or none.
    """
    tl, plans, drawn = scene.timeline, [], {}
    for a, b in pairs:
        track_b = scene.inputs[b].track
        assert track_b is not None, "a synchronized camera has a track"
        chosen = (
            list(request.frames)
            if request.frames
            else choose_frames(
                track_b.frame,
                lambda f: tl.match(b, a, f, scene.times),  # noqa: B023 (called here)
                scene.n_frames[a],
                scene.n_frames[b],
                keyframes=(scene.keyframes(a), scene.keyframes(b)),
                reach=KEYFRAME_REACH,
            )
        )
        plan = plan_pair(
            a,
            b,
            chosen,
            tl,
            scene.inputs,
            scene.path_model,
            scene.n_frames,
            dict(request.truth) if request.truth else None,
            scene.times,
            requests,
        )
        if not plan.rows:
            notes.append(f"{a}, {b}: no strip of matching frames: the two videos never record at the same time")
            continue
        drawn[f"{a},{b}"] = [[f, fa] for f, fa in pair_frames(a, b, chosen, tl, scene.times).items()]
        plans.append(plan)
    return plans, drawn


def strip_of(plan: PairPlan, panels: dict[str, list]) -> np.ndarray:
    """The strip of a planned pair (it has rows: _plan_strips keeps only those)."""
    strip = assemble_pair(plan, panels)
    assert strip is not None, "a planned strip has rows"
    return strip


def draw_requested(files: StageFiles, params: RenderParams, request: StripRequest) -> list[Path]:
    """Draw the strips ``request`` asks for from the render stage's inputs (cached artefacts), beside its pictures,
    and remember the request so that the next render draws it again; returns the pictures written.

    InputError when a pair cannot be drawn from the current timeline. The
    caller holds the work folder's lock; the render stage's artefacts and
    manifest are not touched.
    """
    scene = _read_scene(files, params)
    out_dir = files.output("pictures")
    pairs = list(request.pairs or default_pairs(scene))
    if not pairs:
        raise InputError("render: no pair of synchronized cameras with videos to draw a strip of; give --pair A,B")
    for a, b in pairs:
        problem = _strip_problem(scene, a, b, request.frames)
        if problem:
            raise InputError(f"--pair {a},{b}: {problem}")
    requests: dict[str, list[PanelRequest]] = {}
    notes: list[str] = []
    plans, _ = _plan_strips(scene, pairs, request, requests, notes)
    if notes:
        raise InputError(notes[0])
    panels = {
        name: draw_panels(scene.videos[name], scene.inputs[name].camera, wanted) for name, wanted in requests.items()
    }
    written = [write_png(out_dir / request.file_name(plan.a, plan.b), strip_of(plan, panels)) for plan in plans]
    write_requests([r for r in read_requests(out_dir) if r != request] + [request], out_dir)
    return written


def _camera_job(
    scene: _Scene, name: str, params: RenderParams, requests: list[PanelRequest], out_dir: Path, work: Path
) -> CameraJob:
    files = scene.cameras[name]
    assert files.votes is not None, "declared by the stage"
    return CameraJob(
        name=name,
        inputs=scene.inputs[name],
        line=scene.timeline.cameras[name],
        path_model=scene.path_model,
        prepared=scene.prepared,
        eps_px=scene.timeline.params.shared.eps_px,
        rate=scene.trajectory.rate,
        delta=scene.timeline.params.shared.delta,
        votes=files.votes,
        recast_px=fitted_radius(scene.timeline, scene.inputs[name].camera, scene.prepared)
        if scene.timeline.cameras[name].pose is not None or scene.timeline.log_correction is not None
        else None,
        times=scene.times[name],
        video=scene.videos.get(name),
        detections=files.detections if name in scene.videos else None,
        requests=requests,
        proxy=params.proxy.get(name, "auto"),
        windows=read_windows(files.scan),
        n_frames=scene.n_frames[name],
        out_dir=out_dir,
        work=work,
    )


def draw_charts(scene: _Scene, out_dir: Path, work: Path) -> list[Picture]:
    """The offsets and residuals charts, written; none when no camera is synchronized (nor any of
    an earlier timeline). A part of the stage beside the cameras' (run_each): on a worker, this process loads no
    matplotlib.
    """
    tl = scene.timeline
    if not tl.cameras:
        return []
    residuals = {
        n: track_residuals(
            scene.inputs[n].camera, scene.inputs[n].track, scene.path_model, tl.cameras[n], scene.times[n]
        )
        for n in tl.cameras
    }
    charts = [
        _write_chart(
            out_dir / "offsets.png",
            offsets_plot(tl, list(tl.statuses().values())),
            work,
            "offsets: every camera's start with its 95 % interval",
        ),
        _write_chart(
            out_dir / "residuals.png",
            residuals_plot(residuals, tl.params.shared.eps_px, 1.0 / tl.target_rate if tl.target_rate else None),
            work,
            "residuals: tracked minus projected position over time, with the vote gate",
        ),
    ]
    if any(line.breaks for line in tl.cameras.values()):
        picture = recordings_plot(tl, scene.n_frames, scene.times)
        charts.append(
            _write_chart(
                out_dir / "recordings.png",
                picture,
                work,
                "recordings: each camera's segments on the reference's clock, its breaks where they happened",
            )
        )
    return charts


def _report_content(
    files: StageFiles,
    scene: _Scene,
    params: RenderParams,
    cameras: dict[str, DrawnCamera],
    strips: list[Picture],
    charts: list[Picture],
    notes: list[str],
) -> ReportContent:
    tl, work = scene.timeline, files.output("report").parent
    ingest = _optional(read_ingest_report, files.path("ingest_report")) if files.has("ingest_report") else None
    utc = bool(ingest and ingest.t0_utc and ingest.clock == "UTC")
    player = player_data(
        tl,
        {n: scene.inputs[n].camera for n in tl.cameras},
        scene.trajectory,
        {n: c.player for n, c in cameras.items()},
        utc=utc,
    )
    reports = {
        n: dict(report.content)
        for n in params.cameras
        if files.has(f"calibration_report:{n}")
        and (report := _optional(read_calibration_report, files.path(f"calibration_report:{n}")))
        and report.content
    }
    runs = [run for run in files.history if run.stage != "render"]
    pictures = [files.path(f"calibration_picture:{n}") for n in params.cameras if files.has(f"calibration_picture:{n}")]
    return ReportContent(
        title="tlsync run report",
        timeline=tl,
        statuses=list(tl.statuses([n for n in params.cameras if n in tl.cameras or n in tl.failed]).values()),
        warnings=run_warnings(runs),
        notes={"pictures": notes, "exports": [run.message for run in runs if run.stage == "export" and run.message]},
        stages=runs + [StageRun("render", None, "this run", None)],
        calibration={n: _calibration_line(n, r, tl) for n, r in reports.items()},
        ingest=ingest.summary(with_warnings=False) if ingest else None,
        charts=charts,
        camera_pictures={n: c.pictures for n, c in cameras.items()},
        pair_pictures=strips,
        calibration_pictures=[
            picture(f"{path.parent.name}: calibration", path, work) for path in pictures if path.exists()
        ],
        exports=[
            (label, artefact_path(kind)) for label, kind in EXPORT_LABELS if (work / artefact_path(kind)).exists()
        ],
        player=player,
    )


def _calibration_line(name: str, report: dict, timeline: Timeline) -> str:
    """The camera's calibration in one line, and the pose its line was fitted with when the sync found it itself."""
    line = timeline.cameras.get(name)
    if line is None or line.pose is None:
        return calibration_summary(report)
    return f"{calibration_summary(report)}; {sync_pose_clause(line.pose.source, line.pose.center, report)}"


def remove_other_pictures(out_dir: Path, written: list[Path]) -> list[Path]:
    """Delete the pictures in ``out_dir`` this run did not draw (of cameras no longer synchronized, of strips asked
    for that cannot be drawn now); returns them.

    render/ belongs to the render stage: a picture left from an earlier
    timeline would look like a result of this one.
    """
    keep = {Path(p).resolve() for p in written}
    stale = [p for p in out_dir.glob("*.png") if p.resolve() not in keep] if out_dir.is_dir() else []
    for path in stale:
        path.unlink(missing_ok=True)
    return stale


def _optional(reader: Callable[[Path], T], path: Path) -> T | None:
    """What ``reader`` reads of a file the report shows if it can (None: unreadable)."""
    try:
        return reader(path)
    except (OSError, InputError):
        return None


def _write_chart(path: Path, png: bytes, work: Path, title: str) -> Picture:
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        tmp.write_bytes(png)
    return Picture(title, path.relative_to(work).as_posix(), png)


def read_windows(scan: Path | None) -> list[tuple[int, int]] | None:
    """The windows of a scan.json (the scan stage's) when the track stage read windows, else None."""
    if scan is None:
        return None
    plan = read_scan(scan)
    return None if plan.full else list(plan.windows)


def render_inputs(src: Sources, camera: None) -> dict[str, Path | Artefact]:
    """What the pictures and the report show: every camera's files, votes and calibration report, the trajectory and
    its ingest report, the timeline, the exports."""
    inputs = {
        "timeline": src.artefact("timeline"),
        "trajectory": src.artefact("trajectory"),
        "offsets": src.artefact("offsets"),
    }
    if src.made("ingest_report"):
        inputs["ingest_report"] = src.artefact("ingest_report")
    for spec in src.project.cameras:
        name = spec.name
        inputs.update({f"{kind}:{name}": src.artefact(kind, name) for kind in ("camera", "track", "votes")})
        if src.made("identification", name):
            inputs[f"detections:{name}"] = src.artefact("detections", name)
        if spec.video is not None:
            inputs[f"video:{name}"] = spec.video
        for kind in ("calibration_picture", "calibration_report", "video_info", "scan"):
            if src.made(kind, name):
                inputs[f"{kind}:{name}"] = src.artefact(kind, name)
    return inputs


def render_params(project: Project, camera: None, options: Options) -> RenderParams:
    cameras = cameras_params(project)
    return RenderParams(cameras.cameras, fps=cameras.fps, proxy={c.name: c.proxy for c in project.cameras})


SPEC = StageSpec(
    "render",
    inputs=render_inputs,
    params=render_params,
    outputs=("pictures", "report_html", "report"),
    run=run_render,
    history=True,
    runs_without_failed_cameras=True,
)
