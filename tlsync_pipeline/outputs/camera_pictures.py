"""One camera's pictures and what the report's player plays: drawn from its artefacts, its video decoded once.

``draw_camera`` takes a ``CameraJob`` (plain values: it may run in another
process) and draws the voting space, the tracked path against the projected
one and, with a video, the band swap before and after synchronization, the
movers and the panels of the pairs' strips; it makes the player's proxy
where the browser cannot play the video (proxy.py), kept until the video
changes. Files go to the job's folder; the render stage gathers them.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import quote

import numpy as np

from tlsync_pipeline.atomic import atomic_path
from tlsync_pipeline.errors import SyncError
from tlsync_pipeline.outputs import bandswap
from tlsync_pipeline.outputs.pictures import (
    PanelRequest,
    choose_movers_frame,
    draw_panel,
    each_frame_once,
    plot_candidate_votes,
    plot_trajectory,
    plot_votes,
    render_movers,
    toward_keyframes,
    write_png,
)
from tlsync_pipeline.outputs.player import PlayerVideo
from tlsync_pipeline.outputs.proxy import make_proxy, needs_proxy
from tlsync_pipeline.outputs.report_content import Picture
from tlsync_pipeline.sync.identify.identify import candidate_votes
from tlsync_pipeline.sync.model.clock import FrameTimes
from tlsync_pipeline.sync.solve.methods import CameraInput
from tlsync_pipeline.sync.timeline import CameraLine
from tlsync_pipeline.sync.vote.votes import Votes, compute_votes, read_votes
from tlsync_pipeline.trajectory import PiecewiseTrajectory, Trajectory
from trackers.detections import read_detections
from trackers.track import Track
from trackers.video import keyframe_indices, presentation_times, probe_video

EMBEDDED_JPEG_QUALITY = 85
KEYFRAME_REACH = 0.05  # a band swap's frame moves to a tracked keyframe within this share of the track's span


@dataclass(frozen=True)
class DrawnCamera:
    """What draw_camera made: the pictures for the report, the files written, the strip panels (in the job's
    request order), what the player plays and the proxy written (None: the video itself plays)."""

    pictures: list[Picture]
    written: list[Path]
    panels: list[np.ndarray]
    player: PlayerVideo
    proxy: Path | None


@dataclass(frozen=True)
class CameraJob:
    """What draw_camera needs to draw one camera's pictures (plain values: it may run in another process).

    requests: the panels of the pairs' strips to draw from its video;
    proxy: the camera's proxy policy; windows: the frames the track stage
    read, when it read windows (a proxy holds those only); n_frames: its
    video's frames; recast_px: where the line was fitted on other votes than
    the vote stage's (``votes``), with a pose or a log the sync found
    itself, the vote radius (pixels) the voting space's votes are cast again
    at with the camera (its pose the line's) on ``prepared``; None: the vote
    stage's votes are the line's.
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
    recast_px: float | None
    times: FrameTimes | None
    video: Path | None
    detections: Path | None
    requests: list[PanelRequest]
    proxy: str
    windows: list[tuple[int, int]] | None
    n_frames: int
    out_dir: Path
    work: Path


def draw_camera(job: CameraJob) -> DrawnCamera:
    """One camera's pictures, its strip panels and what the player plays, decoding its video once.

    The voting space, the tracked path against the projected one, and with a
    video: the band swap, the movers (detections), the strip panels
    (job.requests), every frame they need decoded in one forward pass.
    """
    name, line, track = job.name, job.line, job.inputs.track
    assert track is not None, "a synchronized camera has a track"
    made = [
        plot_votes(name, shown_votes(job, track), line, job.delta, job.out_dir / f"votes_{name}.png", job.times),
        plot_trajectory(
            name, job.inputs.camera, track, job.path_model, line, job.out_dir / f"trajectory_{name}.png", job.times
        ),
    ]
    titles = [
        "voting space"
        + (" (votes cast again with the pose and log the line was fitted with)" if job.recast_px is not None else ""),
        "tracked against projected",
    ]
    panels: list[np.ndarray] = []
    if job.video is not None:
        keyframes = keyframe_indices(job.video)  # read_frames indexes the video's packets anyway (kept per process)
        swap_frames = band_swap_frames(track, keyframes)
        movers = read_detections(job.detections) if job.detections is not None else None
        movers_frame = choose_movers_frame(movers, track, keyframes) if movers is not None else None
        kept = set(swap_frames) | ({movers_frame} if movers_frame is not None else set())
        panels_of: dict[int, list[int]] = {}
        for i, request in enumerate(job.requests):
            panels_of.setdefault(request.frame, []).append(i)
        images: dict[int, np.ndarray] = {}
        drawn: dict[int, np.ndarray] = {}
        width, height = job.inputs.camera.image_size
        for index, image in each_frame_once(job.video, kept | set(panels_of), int(width) * int(height) * 3):
            for i in panels_of.get(index, []):
                drawn[i] = draw_panel(image, job.inputs.camera, job.requests[i])
            if index in kept:
                images[index] = image
        panels = [drawn[i] for i in range(len(job.requests))]
        made.append(
            write_band_swap(
                name,
                job.inputs,
                line,
                job.path_model,
                job.rate,
                job.times,
                {f: images[f] for f in swap_frames},
                job.out_dir / f"swap_{name}.png",
            )
        )
        titles.append("band swap: before and after")
        if movers is not None and movers_frame is not None:
            made.append(
                render_movers(
                    images[movers_frame],
                    movers_frame,
                    movers,
                    track,
                    job.inputs.camera,
                    job.path_model,
                    line,
                    job.times,
                    job.out_dir / f"movers_{name}.png",
                )
            )
            titles.append("every mover, the identified target and the projected path")
            votes, rows = candidate_votes(job.inputs.camera, movers, job.prepared, job.eps_px)
            made.append(
                plot_candidate_votes(
                    name,
                    votes,
                    movers.matching(track)[rows],
                    line,
                    job.delta,
                    job.out_dir / f"votes_movers_{name}.png",
                    job.times,
                )
            )
            titles.append("voting space of every mover")
    pictures = [
        (photo if title.startswith("band swap") else picture)(title, path, job.work)
        for title, path in zip(titles, made)
    ]
    player, proxy = player_video(job)
    return DrawnCamera(pictures, made, panels, player, proxy)


def shown_votes(job: CameraJob, track: Track) -> Votes:
    """The votes the camera's voting space shows: the vote stage's, or (job.recast_px) those cast again with the line's
    pose on the log it was fitted to (the vote stage's when that casts none)."""
    if job.recast_px is not None:
        try:
            return compute_votes(job.inputs.camera, track, job.prepared, job.recast_px)
        except SyncError:
            pass
    return read_votes(job.votes).votes


def draw_panels(video: Path, camera, requests: list[PanelRequest]) -> list[np.ndarray]:
    """The strip panels ``requests`` of one camera's video (in order), every frame they need decoded once."""
    panels_of: dict[int, list[int]] = {}
    for i, request in enumerate(requests):
        panels_of.setdefault(request.frame, []).append(i)
    width, height = camera.image_size
    drawn = {}
    for index, image in each_frame_once(video, set(panels_of), int(width) * int(height) * 3):
        for i in panels_of[index]:
            drawn[i] = draw_panel(image, camera, requests[i])
    return [drawn[i] for i in range(len(requests))]


def band_swap_frames(track, keyframes: np.ndarray | None = None) -> list[int]:
    """The tracked frames a band swap shows: at 20, 50 and 80 % of the track, each moved to a tracked keyframe
    within KEYFRAME_REACH of the track's span when there is one (``toward_keyframes``: it decodes alone)."""
    picks = [int(f) for f in np.quantile(track.frame, [0.2, 0.5, 0.8], method="nearest")]
    return toward_keyframes(picks, track.frame, keyframes, KEYFRAME_REACH * float(np.ptp(track.frame)))


def write_band_swap(
    name: str,
    inputs,
    line: CameraLine,
    path_model: PiecewiseTrajectory,
    rate: float | None,
    times: FrameTimes | None,
    images: dict[int, np.ndarray],
    path: Path,
) -> Path:
    """swap_<camera>.png: band swaps of the tracked frames ``images`` (band_swap_frames), the target rendered before and
    after synchronization.

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
                _panel(
                    inputs.camera,
                    image,
                    path_model,
                    before,
                    f"before: {name} frame {f}, its time {_seconds(own)} as log time",
                ),
                _panel(
                    inputs.camera,
                    image,
                    path_model,
                    after,
                    f"after: {name} frame {f} at log time {_seconds(after / rate if rate else None)}",
                ),
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
    table: np.ndarray | None
    if job.times is not None and len(job.times.frame) == job.n_frames:
        table = job.times.time_s  # every frame's time, already read (a presentation-time clock): not demuxed again
    else:
        table = presentation_times(job.video)  # a proxy keeps the video's times, and may hold only its windows
    return PlayerVideo(
        src, proxy is not None, codec, table if table is not None else np.arange(job.n_frames) / fps
    ), proxy


def ensure_proxy(video: Path, path: Path, windows: list[tuple[int, int]] | None = None) -> Path:
    """The proxy of ``video`` (of its ``windows`` only, when given) at ``path``, made again only when the video (size,
    modification time) or the windows changed."""
    stat = video.stat()
    stamp = {
        "source": str(video.resolve()),
        "size": stat.st_size,
        "mtime_ns": stat.st_mtime_ns,
        "windows": [list(w) for w in windows] if windows else None,
    }
    marker = path.with_suffix(".json")
    if path.exists() and _stamp(marker) == stamp:
        return path
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        make_proxy(video, tmp, windows=windows)
    with atomic_path(marker) as tmp:
        tmp.write_text(json.dumps(stamp), encoding="utf-8")
    return path


def picture(title: str, path: Path, work: Path) -> Picture:
    return Picture(title, Path(path).relative_to(work).as_posix(), Path(path).read_bytes())


def photo(title: str, path: Path, work: Path) -> Picture:
    """A picture of video frames, embedded as JPEG (a fifth of the PNG beside it)."""
    import cv2

    ok, data = cv2.imencode(".jpg", cv2.imread(str(path)), [cv2.IMWRITE_JPEG_QUALITY, EMBEDDED_JPEG_QUALITY])
    if not ok:
        return picture(title, path, work)
    return Picture(title, Path(path).relative_to(work).as_posix(), data.tobytes(), media_type="image/jpeg")


def _stamp(marker: Path) -> dict | None:
    """The proxy's record of the video it was made from, or None."""
    try:
        return json.loads(marker.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
