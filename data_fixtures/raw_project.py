"""A complete raw project, as a user would bring it, with its truth.

From a synthetic scene (data_fixtures.scene: cameras with non-overlapping
views, a target trajectory, each camera's frame = alpha * sample + beta), per
camera: an H.264 video of the target (data_fixtures.video), checkerboard
photos taken with that camera's true intrinsics (data_fixtures.checkerboard)
and a GCP CSV (surveyed world points in the camera's view, as WGS84
latitude/longitude/height, with their true pixels; their world points
surveyed with ``gcp_noise_m`` of error per horizontal axis, as a phone or a
web map gives them, the project then leaving gcp_sigma_m at its default;
exact GCPs are declared surveyed, SURVEYED_M; no GCP file with ``gcps = 0``:
the poses then come from the target); for the target: a GPX log of its trajectory
(data_fixtures.gps_logs). The project file asks tlsync to calibrate, track
and ingest all of it; truth.json holds the true relations.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from data_fixtures.scene import Scene, make_scene, write_truth
from tlsync_pipeline.geodesy import Origin, enu_to_geodetic

ORIGIN = Origin(46.5197, 6.6323, 380.0)
START_UTC = 1_750_000_000.0  # POSIX seconds of target sample 0
PATTERN = (7, 5)  # inner corners
SURVEYED_M = 0.02  # what the project says of exact GCPs: an RTK survey
SQUARE_M = 0.04


@dataclass(frozen=True)
class RawProjectSpec:
    """What to generate: lines (alpha, beta) per camera, frames per camera, image size, target rate (Hz), checkerboard
    photos and GCPs per camera (0: no GCP file), the GCPs' survey error (metres per horizontal axis), seed;
    gcp_draw: which draw of the survey error (another draw moves the GCPs, nothing else);
    recorded_zone_s: the videos carry the recording time a phone writes (its true start, whole seconds, in
    this time zone: local - UTC, s), None for none; window_samples: longest stay of the target in each
    camera's zone (samples; None: its whole share, see data_fixtures.scene.make_scene)."""

    lines: tuple[tuple[float, float], ...] = ((3.0, 300.0), (2.5, -150.0), (1.5, 200.0))
    n_frames: tuple[int, ...] = (900, 750, 450)
    image_size: tuple[int, int] = (480, 360)
    target_rate: float = 10.0
    boards: int = 10
    gcps: int = 8
    seed: int = 0
    gcp_noise_m: float = 0.0
    gcp_draw: int = 0
    window_samples: float | None = None
    recorded_zone_s: float | None = 7200.0


# Small and quick, for tests: 30, 25 and 15 fps, shifts of hundreds of frames, 320x240.
SMALL = RawProjectSpec(
    lines=((3.0, -210.0), (2.5, -350.0), (1.5, 0.0)), n_frames=(230, 190, 120), image_size=(320, 240), boards=8, gcps=8
)
# A long recording: 1500 frames a camera at 15 fps, the target in cam1's frames 764-1225 (render it with
# data_fixtures.long_video, two look-alikes wandering); the scan stage reads it in windows around the target's stay.
LONG_RECORDING = RawProjectSpec(
    lines=((1.5, 75.0), (1.5, -75.0)),
    n_frames=(1500, 1500),
    image_size=(320, 240),
    boards=8,
    gcps=8,
    window_samples=300,
)


def make_raw_project(
    directory: str | Path, spec: RawProjectSpec = RawProjectSpec(), progress=None, render=None
) -> tuple[Path, Scene]:
    """Write the raw project into ``directory``; returns (project.toml, the scene with the truth).

    render: the scene renderer, called as ``render(camera, positions, fps,
    path, seed=...)`` with the target's true pixel position per frame (None
    where it is not in the picture); default
    ``data_fixtures.video.render_camera_video``.
    """
    from data_fixtures.checkerboard import render_checkerboards, write_checkerboards
    from data_fixtures.gps_logs import write_gpx_log
    from data_fixtures.video import render_camera_video, tag_recording_time

    say = progress or (lambda message: None)
    render = render or render_camera_video
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    scene = _scene(spec)
    rng = np.random.default_rng(spec.seed + 1)
    write_gpx_log(directory / "target.gpx", scene.true_trajectory, ORIGIN, START_UTC)
    parts = [
        "# Made by `tlsync demo`: raw videos, checkerboard photos, GCPs and a GPX log.\n"
        f'[target]\nlog = "target.gpx"\norigin = [{ORIGIN.lat}, {ORIGIN.lon}, {ORIGIN.alt}]\n'
        "log_model = \"rtk\"  # the GPX holds an RTK-grade path; a phone's or a watch's: leave the default (auto)\n"
    ]
    if spec.gcps and not spec.gcp_noise_m:
        parts.append(
            f"[calibration]\ngcp_sigma_m = {SURVEYED_M}  # the GCPs are surveyed (RTK); a phone's or a web map's: "
            f"leave the default\n"
        )
    for k, (name, camera) in enumerate(scene.true_cameras.items()):
        folder = directory / name
        say(f"{name}: video ({scene.n_frames[name]} frames at {camera.fps:g} fps)")
        track = scene.tracks[name]
        where = dict(zip(track.frame.tolist(), track.xy))
        positions = [where.get(f) for f in range(scene.n_frames[name])]
        folder.mkdir(exist_ok=True)
        render(camera, positions, camera.fps, folder / "video.mp4", seed=spec.seed + k)
        if spec.recorded_zone_s is not None:
            tag_recording_time(folder / "video.mp4", recording_utc(scene, name), spec.recorded_zone_s)
        say(f"{name}: checkerboard photos and GCPs")
        boards = render_checkerboards(
            seed=spec.seed + 10 + k,
            n_full=spec.boards,
            n_cut=1,
            n_absent=1,
            image_size=camera.image_size,
            pattern=PATTERN,
            square=SQUARE_M,
            K=camera.K,
            dist=camera.dist,
        )
        write_checkerboards(boards, folder / "boards")
        gcp_line = ""
        if spec.gcps:
            _write_gcps(folder / "gcp.csv", camera, scene, name, spec.gcps, rng, survey_error(spec, k))
            gcp_line = f'gcp = "{name}/gcp.csv"\n'
        parts.append(
            f'[[cameras]]\nname = "{name}"\nvideo = "{name}/video.mp4"\nfps = {camera.fps!r}\n'
            f'[cameras.calibration]\nimages = "{name}/boards/*.png"\npattern = "{PATTERN[0]}x{PATTERN[1]}"\nsquare = '
            f"{SQUARE_M}\n{gcp_line}"
            '[cameras.tracker]\nkind = "blob"\n'
        )
    project = directory / "project.toml"
    project.write_text("\n".join(parts), encoding="utf-8")
    write_truth(scene, directory)
    return project, scene


def _scene(spec: RawProjectSpec) -> Scene:
    return make_scene(
        spec.seed,
        spec.lines,
        spec.n_frames,
        target_rate=spec.target_rate,
        image_size=spec.image_size,
        window_samples=spec.window_samples,
    )


def survey_error(spec: RawProjectSpec, k: int) -> np.ndarray:
    """(gcps, 2) metres east and north by which camera k's GCPs are surveyed wrong (draw ``spec.gcp_draw``)."""
    key = [spec.seed, 7, k] if not spec.gcp_draw else [spec.seed, 7, k, spec.gcp_draw]
    return spec.gcp_noise_m * np.random.default_rng(key).standard_normal((spec.gcps, 2))


def rewrite_gcps(directory: str | Path, spec: RawProjectSpec) -> None:
    """Write every camera's gcp.csv of a project ``make_raw_project`` made with the same scene again, with the survey
    error of ``spec`` (another ``gcp_draw`` or ``gcp_noise_m``): the same points, the other files untouched."""
    scene = _scene(spec)
    rng = np.random.default_rng(spec.seed + 1)
    for k, (name, camera) in enumerate(scene.true_cameras.items()):
        _write_gcps(Path(directory) / name / "gcp.csv", camera, scene, name, spec.gcps, rng, survey_error(spec, k))


def recording_utc(scene: Scene, name: str) -> float:
    """POSIX seconds of the camera's frame 0 (its true line: frame = alpha * sample + beta; sample 0 at START_UTC)."""
    line, rate = scene.lines[name], scene.true_trajectory.rate
    assert rate is not None, "a scene's trajectory has a rate"
    return START_UTC + (-line.beta / line.alpha) / rate


def _write_gcps(path: Path, camera, scene: Scene, name: str, count: int, rng, survey: np.ndarray | None = None) -> None:
    """``count`` surveyed points spread over the camera's image, at the depths where the target moves: u,v,lat,lon,alt.

    The pixels are the points' true projections; their world positions are
    off by ``survey`` (count, 2: metres east and north; drawn by the caller
    from a generator of its own, so the scene and the other files stay the
    same at every noise level).
    """
    line = scene.lines[name]
    samples = np.clip(
        np.round((scene.tracks[name].frame - line.beta) / line.alpha).astype(int), 0, len(scene.true_trajectory) - 1
    )
    depth = (scene.true_trajectory.xyz[samples] @ camera.R.T + camera.t)[:, 2]
    w, h = camera.image_size
    cells = [(i, j) for i in range(4) for j in range(3)]
    order = rng.permutation(len(cells))[:count]
    rays = []
    for k in order:  # one point per cell of a 4 x 3 grid over the image: a good spread
        i, j = cells[k]
        u, v = (i + rng.uniform(0.2, 0.8)) * w / 4, (j + rng.uniform(0.2, 0.8)) * h / 3
        ray = np.linalg.solve(camera.K, [u, v, 1.0])
        rays.append(camera.R.T @ (rng.uniform(np.quantile(depth, 0.1), np.quantile(depth, 0.9)) * ray - camera.t))
    world = np.array(rays)
    uv, valid = camera.project(world)
    keep = valid & camera.in_image(uv)
    surveyed = world.copy()
    if survey is not None:
        surveyed[:, : survey.shape[1]] += survey[: len(world)]
    geo = enu_to_geodetic(surveyed[keep], ORIGIN)
    rows = ["name,u,v,lat,lon,alt"]
    rows += [
        f"P{i + 1},{p[0]:.2f},{p[1]:.2f},{lat:.8f},{lon:.8f},{alt:.3f}"
        for i, (p, (lat, lon, alt)) in enumerate(zip(uv[keep], geo))
    ]
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
