"""The render stage: pictures, charts, the player's proxies, report.html and report.md, from cached artefacts.

Writes under ``<work>/render/``: per camera the voting space, the trajectory
check and the before/after band swap; per pair of cameras the strip of
matching frames; the offsets and residuals charts; proxy clips for videos a
browser cannot play. Then ``<work>/report.html`` (self-contained) and
``<work>/report.md``, which gather every stage's warnings.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import quote

import cv2
import numpy as np

from tlsync_pipeline.atomic import atomic_path
from tlsync_pipeline.ingest.process import Gap, IngestReport
from tlsync_pipeline.outputs import bandswap
from tlsync_pipeline.outputs.diagnostics import (
    StageWarning,
    all_statuses,
    calibration_warnings,
    ingest_warnings,
    summary_warnings,
    sync_warnings,
)
from tlsync_pipeline.outputs.pictures import (
    PanelRequest,
    assemble_pair,
    choose_frames,
    choose_movers_frame,
    default_pairs,
    draw_panel,
    each_frame_once,
    pair_frames,
    plan_pair,
    plot_candidate_votes,
    plot_trajectory,
    plot_votes,
    render_movers,
    toward_keyframes,
    write_png,
)
from tlsync_pipeline.outputs.player import PlayerVideo, player_data
from tlsync_pipeline.outputs.plots import offsets_plot, residuals_plot, track_residuals
from tlsync_pipeline.outputs.proxy import make_proxy, needs_proxy
from tlsync_pipeline.outputs.report_content import Picture, ReportContent, StageRun
from tlsync_pipeline.outputs.report_html import report_html
from tlsync_pipeline.outputs.report_md import report_markdown
from tlsync_pipeline.outputs.summary import calibration_summary
from tlsync_pipeline.pipeline.executors import WORKER_CPU, SerialExecutor, run_each
from tlsync_pipeline.pipeline.spec import Sources, StageSpec
from tlsync_pipeline.pipeline.stages.cameras import camera_files, camera_params
from tlsync_pipeline.pipeline.stages.export import frame_count, frame_times
from tlsync_pipeline.pipeline.stages.sync import read_camera_inputs
from tlsync_pipeline.pipeline.workspace import StageFiles
from tlsync_pipeline.sync.clock import FrameTimes
from tlsync_pipeline.sync.identify import candidate_votes
from tlsync_pipeline.sync.methods import CameraInput
from tlsync_pipeline.sync.registry import params_from_table
from tlsync_pipeline.sync.synchronize import prepare_trajectory
from tlsync_pipeline.sync.timeline import CameraLine, Timeline, read_timeline, read_truth
from tlsync_pipeline.sync.votes import load_votes
from tlsync_pipeline.trajectory import PiecewiseTrajectory, Trajectory, read_trajectory
from trackers.detections import read_detections
from trackers.video import keyframe_indices, presentation_times, probe_video

EMBEDDED_JPEG_QUALITY = 85
KEYFRAME_REACH = 0.05  # a band swap's frame moves to a tracked keyframe within this share of the track's span
EXPORT_LABELS = (
    ("frame map (CSV)", "frame_map.csv"),
    ("offsets (CSV)", "offsets.csv"),
    ("ffmpeg commands", "ffmpeg.sh"),
    ("OpenTimelineIO timeline (DaVinci Resolve, Premiere via plug-in, ...)", "timeline.otio"),
    ("FCPXML timeline (Final Cut Pro, DaVinci Resolve)", "timeline.fcpxml"),
    ("sync.json (offsets with their sign convention)", "sync.json"),
)


def run_render(
    files: StageFiles,
    cameras: list[str],
    fps: dict[str, float | None],
    pairs: list | None = None,
    frames: list | None = None,
    delta: float = 0.5,
    proxy: dict | None = None,
    left_out: dict[str, str] | None = None,
) -> dict:
    """The render stage: pictures, charts, proxies, report.html and report.md.

    proxy: camera -> "auto" | "always" | "never" (default auto: a proxy when
    the browser cannot play the camera's video). left_out: cameras whose own
    tasks did not complete (camera -> why), named in the report's notes.
    Returns the files written and, per pair "A,B", the frames drawn: [frame
    of B, frame of A]. Pictures of an earlier run that this one did not draw
    are removed (remove_other_pictures).
    """
    tl = read_timeline(files.path("timeline"))
    traj = read_trajectory(files.path("trajectory"))
    sync_params = params_from_table(tl.params)
    prepared = prepare_trajectory(traj, sync_params)
    path_model = PiecewiseTrajectory(prepared)
    names = cameras
    cameras = camera_files(files, cameras, fps)
    inputs = read_camera_inputs({n: c for n, c in cameras.items() if n in tl.cameras})
    times = {name: frame_times(cameras[name], line) for name, line in tl.cameras.items()}
    work = files.output("report").parent
    out_dir = files.output("pictures")
    videos = {n: Path(c["video"]) for n, c in cameras.items() if c.get("video") and n in tl.cameras}
    n_frames = {n: frame_count(cameras[n]) for n in tl.cameras}

    truth_pairs = read_truth(files.path("truth"))[0] if files.has("truth") else None
    pair_list = [tuple(p) for p in pairs] if pairs else default_pairs(tl)
    notes = [f"{name}: no pictures ({why})" for name, why in (left_out or {}).items()]
    drawn = {}
    plans = []
    requests: dict[str, list[PanelRequest]] = {}
    for a, b in pair_list:
        if a not in videos or b not in videos:
            notes.append(f"{a}, {b}: no strip of matching frames (needs both cameras' videos)")
            continue
        chosen = list(frames) if frames else choose_frames(inputs[b].track.frame, lambda f: tl.match(b, a, f, times), n_frames[a], n_frames[b])
        plan = plan_pair(a, b, chosen, tl, inputs, path_model, n_frames, truth_pairs, times, requests)
        if not plan.rows:
            notes.append(f"{a}, {b}: the two videos never record at the same time")
        else:
            drawn[f"{a},{b}"] = [[f, fa] for f, fa in pair_frames(a, b, chosen, tl, times).items()]
            plans.append(plan)

    jobs = [
        CameraJob(
            name=name,
            inputs=inputs[name],
            line=line,
            path_model=path_model,
            prepared=prepared,
            eps_px=sync_params.eps_px,
            rate=traj.rate,
            delta=delta,
            votes=cameras[name]["votes"],
            times=times[name],
            video=videos.get(name),
            detections=cameras[name].get("detections") if name in videos else None,
            requests=requests.get(name, []),
            proxy=(proxy or {}).get(name, "auto"),
            windows=read_windows(cameras[name].get("scan")),
            n_frames=n_frames[name],
            out_dir=out_dir,
            work=work,
        )
        for name, line in tl.cameras.items()
    ]
    drawn_cameras = run_each(files.workers or SerialExecutor(), draw_camera, [{"job": job} for job in jobs])
    warnings = [w for result in drawn_cameras for w in result.get("warnings", [])]
    written: list[Path] = [path for result in drawn_cameras for path in result["written"]]
    camera_pictures = {job.name: result["pictures"] for job, result in zip(jobs, drawn_cameras)}
    panels = {job.name: result["panels"] for job, result in zip(jobs, drawn_cameras)}
    pair_pictures = []
    for plan in plans:
        path = write_png(out_dir / f"strip_{plan.a}_{plan.b}.png", assemble_pair(plan, panels))
        written.append(path)
        pair_pictures.append(_photo(f"{plan.a} and {plan.b}: matching frames", path, work))

    statuses = all_statuses(tl)
    charts = [
        _write_chart(out_dir / "offsets.png", offsets_plot(tl, statuses), work, "offsets: every camera's start with its 95 % interval"),
        _write_chart(
            out_dir / "residuals.png",
            residuals_plot(
                {n: track_residuals(inputs[n].camera, inputs[n].track, path_model, tl.cameras[n], times[n]) for n in tl.cameras},
                float(tl.params.get("eps_px", 10.0)),
                1.0 / tl.target_rate if tl.target_rate else None,
            ),
            work,
            "residuals: tracked minus projected position over time, with the vote gate",
        ),
    ] if tl.cameras else []  # no camera synchronized: no chart (nor any picture of an earlier timeline)
    written += [work / c.href for c in charts]

    played = {job.name: result["player"] for job, result in zip(jobs, drawn_cameras)}
    written += [result["proxy"] for result in drawn_cameras if result["proxy"] is not None]
    ingest = _read_json(files.path("ingest_report")) if files.has("ingest_report") else None
    player = player_data(tl, {n: inputs[n].camera for n in tl.cameras}, traj, played, utc=bool(ingest and ingest.get("t0_utc") and ingest.get("clock", "UTC") == "UTC"))

    content = ReportContent(
        title="tlsync run report",
        timeline=tl,
        statuses=statuses,
        warnings=gather_warnings(files, tl, names, ingest, notes),
        stages=[StageRun(h["stage"], h["camera"], h["created"], h["seconds"]) for h in files.history if h["stage"] != "render"] + [StageRun("render", None, "this run", None)],
        calibration={n: calibration_summary(r) for n in names if (r := _declared_json(files, f"calibration_report:{n}"))},
        ingest=_ingest_summary(ingest),
        charts=charts,
        camera_pictures=camera_pictures,
        pair_pictures=pair_pictures,
        calibration_pictures=[_picture(f"{n}: calibration", files.path(f"calibration_picture:{n}"), work) for n in names if files.has(f"calibration_picture:{n}") and files.path(f"calibration_picture:{n}").exists()],
        exports=[(label, f"exports/{name}") for label, name in EXPORT_LABELS if (work / "exports" / name).exists()],
        player=player,
    )
    removed = remove_other_pictures(out_dir, written)
    with files.write("report_html") as tmp:
        tmp.write_text(report_html(content), encoding="utf-8")
    with files.write("report") as tmp:
        tmp.write_text(report_markdown(content), encoding="utf-8")
    summary = {
        "outputs": [str(p) for p in written],
        "notes": notes,
        "report": str(files.output("report_html")),
        "frames": drawn,
        "removed": [p.name for p in removed],
        WORKER_CPU: sum(result[WORKER_CPU] for result in drawn_cameras),
    }
    return {**summary, "warnings": list(dict.fromkeys(warnings))} if warnings else summary


def remove_other_pictures(out_dir: Path, written: list[Path]) -> list[Path]:
    """Delete the pictures in ``out_dir`` this run did not draw (of cameras no longer synchronized, of other pairs); returns them.

    render/ belongs to the render stage: a picture left from an earlier
    timeline would look like a result of this one.
    """
    keep = {Path(p).resolve() for p in written}
    stale = [p for p in out_dir.glob("*.png") if p.resolve() not in keep] if out_dir.is_dir() else []
    for path in stale:
        path.unlink(missing_ok=True)
    return stale


@dataclass(frozen=True)
class CameraJob:
    """What draw_camera needs to draw one camera's pictures (plain values: it may run in another process).

    requests: the panels of the pairs' strips to draw from its video;
    proxy: the camera's proxy policy; windows: the frames the track stage
    read, when it read windows (a proxy holds those only); n_frames: its
    video's frames.
    """

    name: str
    inputs: CameraInput
    line: CameraLine
    path_model: PiecewiseTrajectory
    prepared: Trajectory  # the trajectory the line was fitted to (path_model's), for every mover's votes
    eps_px: float
    rate: float | None
    delta: float
    votes: Path
    times: FrameTimes | None
    video: Path | None
    detections: Path | None
    requests: list[PanelRequest]
    proxy: str
    windows: list[tuple[int, int]] | None
    n_frames: int
    out_dir: Path
    work: Path


def draw_camera(job: CameraJob) -> dict:
    """One camera's pictures, its strip panels and what the player plays, decoding its video once.

    The voting space, the tracked path against the projected one, and with a
    video: the band swap, the movers (detections), the strip panels
    (job.requests), every frame they need decoded in one forward pass.
    Returns {"pictures": [Picture], "written": [Path], "panels": [image],
    "player": PlayerVideo, "proxy": Path or None}.
    """
    name, line, track = job.name, job.line, job.inputs.track
    votes, _ = load_votes(job.votes)
    made = [
        plot_votes(name, votes, line, job.delta, job.out_dir / f"votes_{name}.png", job.times),
        plot_trajectory(name, job.inputs.camera, track, job.path_model, line, job.out_dir / f"trajectory_{name}.png", job.times),
    ]
    titles = ["voting space", "tracked against projected"]
    panels: list[np.ndarray] = []
    if job.video is not None:
        keyframes = keyframe_indices(job.video)  # read_frames indexes the video's packets anyway (kept per process)
        swap_frames = band_swap_frames(track, keyframes)
        movers = read_detections(job.detections) if job.detections is not None else None
        movers_frame = choose_movers_frame(movers, track, keyframes) if movers is not None else None
        kept = set(swap_frames) | ({movers_frame} if movers is not None else set())
        panels_of = {}
        for i, request in enumerate(job.requests):
            panels_of.setdefault(request.frame, []).append(i)
        images, drawn = {}, {}
        width, height = job.inputs.camera.image_size
        for index, image in each_frame_once(job.video, kept | set(panels_of), int(width) * int(height) * 3):
            for i in panels_of.get(index, []):
                drawn[i] = draw_panel(image, job.inputs.camera, job.requests[i])
            if index in kept:
                images[index] = image
        panels = [drawn[i] for i in range(len(job.requests))]
        made.append(write_band_swap(name, job.inputs, line, job.path_model, job.rate, job.times, {f: images[f] for f in swap_frames}, job.out_dir / f"swap_{name}.png"))
        titles.append("band swap: before and after")
        if movers is not None:
            made.append(render_movers(images[movers_frame], movers_frame, movers, track, job.inputs.camera, job.path_model, line, job.times, job.out_dir / f"movers_{name}.png"))
            titles.append("every mover, the identified target and the projected path")
            votes, rows = candidate_votes(job.inputs.camera, movers, job.prepared, job.eps_px)
            made.append(plot_candidate_votes(name, votes, movers.matching(track)[rows], line, job.delta, job.out_dir / f"votes_movers_{name}.png", job.times))
            titles.append("voting space of every mover")
    pictures = [(_photo if title.startswith("band swap") else _picture)(title, path, job.work) for title, path in zip(titles, made)]
    player, proxy = player_video(job)
    return {"pictures": pictures, "written": made, "panels": panels, "player": player, "proxy": proxy}


def band_swap_frames(track, keyframes: np.ndarray | None = None) -> list[int]:
    """The tracked frames a band swap shows: at 20, 50 and 80 % of the track, each moved to a tracked keyframe
    within 5 % of the track's span when there is one (``toward_keyframes``: it decodes alone)."""
    picks = [int(f) for f in np.quantile(track.frame, [0.2, 0.5, 0.8], method="nearest")]
    return toward_keyframes(picks, track.frame, keyframes, KEYFRAME_REACH * float(np.ptp(track.frame)))


def write_band_swap(name: str, inputs, line: CameraLine, path_model: PiecewiseTrajectory, rate: float | None, times: FrameTimes | None, images: dict[int, np.ndarray], path: Path) -> Path:
    """swap_<camera>.png: band swaps of the tracked frames ``images`` (band_swap_frames), the target rendered before and after synchronization.

    after: at the sample the camera's line gives the frame; before: at the
    frame's own time since the camera's frame 0 (seconds on its clock, frame
    index / fps), taken as time since the log's first sample.
    """
    rows = []
    for f, image in sorted(images.items()):
        own = float(line.clock.seconds_at(line.clock.clock_at(float(f), times), times)) if line.clock.fps else None
        before = own * rate if own is not None and rate else float(f)
        after = float(line.sample_at(float(f), times))
        rows.append(
            (
                _panel(inputs.camera, image, path_model, before, f"before: {name} frame {f}, its time {_seconds(own)} as log time"),
                _panel(inputs.camera, image, path_model, after, f"after: {name} frame {f} at log time {_seconds(after / rate if rate else None)}"),
            )
        )
    picture = bandswap.before_after(rows, bandswap.target_radius(inputs.track))
    return write_png(path, picture)


def _seconds(value: float | None) -> str:
    return "?" if value is None else f"{value:.2f} s"


def _panel(camera, image: np.ndarray, path_model: PiecewiseTrajectory, sample: float, text: str) -> bandswap.Panel:
    point = path_model.positions(sample)[0]
    uv = None
    if np.isfinite(point[0]):
        projected, valid = camera.project(point[None, :])
        if valid[0] and camera.in_image(projected)[0]:
            uv = (float(projected[0, 0]), float(projected[0, 1]))
    if uv is None:
        text += " (target out of view)"
    return bandswap.Panel(image, uv, text)


def player_video(job: CameraJob) -> tuple[PlayerVideo, Path | None]:
    """What the player plays for the camera (its video, or a proxy made now when needed), and the proxy written.

    The frames' presentation times: ``job.times`` when it holds every frame's (run_render read the video's table
    for a presentation-time clock), else the played video's own, demuxed here.
    """
    fps = job.line.fps or 1.0
    if job.video is None:
        return PlayerVideo(None, False, None, np.arange(job.n_frames) / fps), None
    codec = probe_video(job.video).codec
    source, proxy = job.video, None
    if needs_proxy(codec, job.video.suffix, job.proxy):
        source = proxy = ensure_proxy(job.video, job.out_dir / "proxy" / f"{job.name}.mp4", job.windows)
    src = quote(Path(os.path.relpath(source, job.work)).as_posix())
    if job.times is not None and len(job.times.frame) == job.n_frames:
        table = job.times.time_s  # every frame's time, already read (a presentation-time clock): not demuxed again
    else:
        table = presentation_times(job.video)  # a proxy keeps the video's times, and may hold only its windows
    return PlayerVideo(src, proxy is not None, codec, table if table is not None else np.arange(job.n_frames) / fps), proxy


def ensure_proxy(video: Path, path: Path, windows: list[tuple[int, int]] | None = None) -> Path:
    """The proxy of ``video`` (of its ``windows`` only, when given) at ``path``, made again only when the video (size,
    modification time) or the windows changed."""
    stat = video.stat()
    stamp = {"source": str(video.resolve()), "size": stat.st_size, "mtime_ns": stat.st_mtime_ns, "windows": [list(w) for w in windows] if windows else None}
    marker = path.with_suffix(".json")
    if path.exists() and _read_json(marker) == stamp:
        return path
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        make_proxy(video, tmp, windows=windows)
    with atomic_path(marker) as tmp:
        tmp.write_text(json.dumps(stamp), encoding="utf-8")
    return path


def read_windows(scan: Path | None) -> list[tuple[int, int]] | None:
    """The windows of a scan.json (the scan stage's) when the track stage read windows, else None."""
    if scan is None:
        return None
    plan = json.loads(Path(scan).read_text(encoding="utf-8"))
    return [(int(a), int(b)) for a, b in plan["windows"]] if plan["mode"] == "windows" else None


def gather_warnings(files: StageFiles, tl: Timeline, names: list[str], ingest: dict | None, notes: list[str]) -> list[StageWarning]:
    """Every warning the stages recorded, in stage order, and render's own notes."""
    found: list[StageWarning] = []
    for name in names:
        report = _declared_json(files, f"calibration_report:{name}")
        if report:
            found += calibration_warnings(name, report)
    if ingest:
        found += ingest_warnings(ingest)
    for run in files.history:
        if run["stage"] != "render":
            found += summary_warnings(run["stage"], run["camera"], {"warnings": run.get("warnings")})
    found += sync_warnings(tl)
    found += [StageWarning("render", None, note) for note in notes]
    order = {}  # pipeline order: the history lists the graph's tasks in it
    for run in files.history + [{"stage": w.stage} for w in found]:
        order.setdefault(run["stage"], len(order))
    return sorted(found, key=lambda w: order[w.stage] if w.stage != "render" else len(order))


def _declared_json(files: StageFiles, label: str) -> dict | None:
    """A declared JSON input (None when not declared or unreadable)."""
    return _read_json(files.path(label)) if files.has(label) else None


def _read_json(path: Path) -> dict | None:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def _ingest_summary(report: dict | None) -> str | None:
    if not report:
        return None
    fields = {k: v for k, v in report.items() if k != "format_version"}
    fields["gaps"] = [Gap(**g) for g in fields.get("gaps", [])]
    try:
        return IngestReport(**fields).summary()
    except TypeError:
        return None


def _picture(title: str, path: Path, work: Path) -> Picture:
    return Picture(title, Path(path).relative_to(work).as_posix(), Path(path).read_bytes())


def _photo(title: str, path: Path, work: Path) -> Picture:
    """A picture of video frames, embedded as JPEG (a fifth of the PNG beside it)."""
    ok, data = cv2.imencode(".jpg", cv2.imread(str(path)), [cv2.IMWRITE_JPEG_QUALITY, EMBEDDED_JPEG_QUALITY])
    if not ok:
        return _picture(title, path, work)
    return Picture(title, Path(path).relative_to(work).as_posix(), data.tobytes(), media_type="image/jpeg")


def _write_chart(path: Path, png: bytes, work: Path, title: str) -> Picture:
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        tmp.write_bytes(png)
    return Picture(title, path.relative_to(work).as_posix(), png)


def render_inputs(src: Sources, camera: None) -> dict:
    """What the pictures and the report show: every camera's files, votes and calibration report, the trajectory and
    its ingest report, the timeline, the exports."""
    inputs = {"timeline": src.artefact("timeline"), "trajectory": src.artefact("trajectory"), "offsets": src.artefact("offsets")}
    if src.made("ingest_report"):
        inputs["ingest_report"] = src.artefact("ingest_report")
    for spec in src.project.cameras:
        name = spec["name"]
        inputs.update({f"{kind}:{name}": src.artefact(kind, name) for kind in ("camera", "track", "votes")})
        if src.made("identification", name):
            inputs[f"detections:{name}"] = src.artefact("detections", name)
        if spec.get("video") is not None:
            inputs[f"video:{name}"] = spec["video"]
        for kind in ("calibration_picture", "calibration_report", "video_info", "scan"):
            if src.made(kind, name):
                inputs[f"{kind}:{name}"] = src.artefact(kind, name)
    if src.options.truth is not None:
        inputs["truth"] = Path(src.options.truth).resolve()
    return inputs


def render_params(project, camera: None, options) -> dict:
    return {
        **camera_params(project),
        "pairs": [list(p) for p in options.render_pairs] if options.render_pairs else None,
        "frames": list(options.render_frames) if options.render_frames else None,
        "delta": project.sync.delta,
        "proxy": {spec["name"]: spec["proxy"] for spec in project.cameras},
    }


SPEC = StageSpec(
    "render",
    inputs=render_inputs,
    params=render_params,
    outputs=("pictures", "report_html", "report"),
    run=run_render,
    history=True,
    runs_without_failed_cameras=True,
)
