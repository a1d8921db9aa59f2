"""Synthetic scenes following the paper's protocol (Brito et al., Section 4.2).

A smooth random 3D target trajectory visits one zone per camera; each camera
looks at its own zone, so no point of the trajectory is seen by two cameras:
zones on a ring, each camera looking outward (``layout="ring"``, a few
cameras), or along a straight road, each camera beside it looking across
(``layout="path"``, any number). Camera k's frames relate to target samples by
frame = alpha_k * sample + beta_k. Noise, as in the paper:

- S_t, tracking noise: Gaussian, std S_t pixels, on each tracked coordinate;
- S_c, projection error: the written camera's pose is perturbed so that its
  mean reprojection error over the visible trajectory is S_c pixels;
- S_l, localisation noise: Gaussian, std S_l % of the smallest camera's field
  of view (its image width in metres at its zone), on each logged coordinate.

The tracked position of frame f is the true trajectory at the continuous
sample (f - beta) / alpha, so sub-sample timing is part of the scene.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field, is_dataclass, replace
from pathlib import Path

import cv2
import numpy as np
from scipy.interpolate import CubicSpline
from scipy.optimize import brentq

from calibration.camera import Camera, write_camera
from tlsync_pipeline.sync.timeline import Relation
from tlsync_pipeline.trajectory import Trajectory, write_trajectory
from trackers.track import Track, write_track

PAPER_LINES = ((2.0, 4.0), (2.0, 45.0))
ZONE_RADIUS_M = 60.0
CAMERA_DISTANCE_M = 25.0
CAMERA_HEIGHT_M = 6.0
PATH_SPACING_M = 40.0  # between zones along the road of the "path" layout
LAYOUTS = ("ring", "path")
CENTRE = np.array([0.0, 0.0, 2.0])  # where a ring scene's path starts and ends (behind every camera)
ZONE_HALF_WIDTH_M = 7.0
WAYPOINT_EVERY = 20  # samples between random waypoints inside a zone
WAYPOINT_STEP_M = 5.0  # metres between consecutive waypoints
TRANSIT_SAMPLES = 8  # samples kept free between two cameras' windows
REST_SPEED_M = WAYPOINT_STEP_M / WAYPOINT_EVERY  # metres per sample on the way to and from the rest point
REST_EVERY = 100  # samples between waypoints while the target rests, out of every view


@dataclass
class Scene:
    """A synthetic scene and its truth.

    trajectory/cameras/tracks are what a user would have (with noise);
    true_trajectory/true_cameras are noise-free; lines[name] maps samples to
    frames (frame = alpha * sample + beta); n_frames[name] is the video length.
    """

    trajectory: Trajectory
    true_trajectory: Trajectory
    cameras: dict[str, Camera]
    true_cameras: dict[str, Camera]
    tracks: dict[str, Track]
    lines: dict[str, Relation]
    n_frames: dict[str, int]
    noise: dict = field(default_factory=dict)

    def truth_pairs(self) -> dict[str, Relation]:
        """Every ordered pair "A->B": frame_B = alpha * frame_A + beta."""
        return pairs_of_lines(self.lines)


def pairs_of_lines(lines: dict[str, Relation]) -> dict[str, Relation]:
    """Every ordered pair "A->B" of cameras whose ``lines`` give frame = alpha * sample + beta: frame_B = alpha *
    frame_A + beta."""
    out = {}
    for a, la in lines.items():
        for b, lb in lines.items():
            if a != b:
                alpha = lb.alpha / la.alpha
                out[f"{a}->{b}"] = Relation(alpha, lb.beta - alpha * la.beta)
    return out


def make_scene(
    seed: int = 0,
    lines: tuple[tuple[float, float], ...] = PAPER_LINES,
    n_frames: int | tuple[int, ...] = 512,
    tracking_noise_px: float = 0.0,
    projection_error_px: float = 0.0,
    localisation_noise_pct: float = 0.0,
    target_rate: float = 15.0,
    image_size: tuple[int, int] = (640, 480),
    hover_fraction: float = 0.0,
    crossings: int = 0,
    frame_time_jitter: float = 0.0,
    window_samples: float | None = None,
    layout: str = "ring",
) -> Scene:
    """Build a deterministic scene: one camera per (alpha, beta) in ``lines``.

    n_frames: frames per camera (one value for all, or one per camera);
    target_rate: trajectory samples per second (camera fps = alpha * rate).
    hover_fraction: share of each camera's window the target spends
    motionless at one point (it then flies faster to catch up);
    crossings: how many times, after the hover, the path flies back through
    the hover point (a path crossing itself);
    frame_time_jitter: each frame interval is (1 + U(-j, j)) / fps, so the
    presentation times (track time_s) drift; lines then map samples to the
    camera clock in frame units, time_s * fps.
    window_samples: longest stay in each camera's zone (samples), centred in
    the share of the videos it would have had; between stays the target
    walks to the scene's centre, behind every camera, and rests there (a long
    recording in which it crosses each view once; ring layout only).
    layout: "ring" (zones on a circle of ZONE_RADIUS_M, views disjoint for up
    to about 8 cameras) or "path" (zones PATH_SPACING_M apart along a road
    at y = ZONE_RADIUS_M, in the cameras' order, for many cameras).
    """
    if layout not in LAYOUTS:
        raise ValueError(f"layout {layout!r}: expected one of {', '.join(LAYOUTS)}")
    if layout == "path" and window_samples is not None:
        raise ValueError("window_samples (rests at the scene's centre between stays) needs the ring layout")
    rng = np.random.default_rng(seed)
    names = [f"cam{k}" for k in range(len(lines))]
    counts = [n_frames] * len(lines) if isinstance(n_frames, int) else list(n_frames)
    relations = {n: Relation(float(a), float(b)) for n, (a, b) in zip(names, lines)}
    windows = _visibility_windows(relations, dict(zip(names, counts)), window_samples)
    n_samples = int(math.ceil(max(w[1] for w in windows.values()))) + 2 * TRANSIT_SAMPLES
    if layout == "path":  # along the road in the order of the visits
        order = sorted(names, key=lambda n: windows[n][0])
        zones = {n: _zone_centre(order.index(n), len(names), layout) for n in names}
        ends = (zones[order[0]] - [PATH_SPACING_M, 0.0, -2.0], zones[order[-1]] + [PATH_SPACING_M, 0.0, 2.0])
    else:
        zones = {n: _zone_centre(k, len(names)) for k, n in enumerate(names)}
        ends = (CENTRE, CENTRE)
    spline = _trajectory_spline(rng, windows, zones, n_samples, crossings, rest=window_samples is not None, ends=ends)
    if hover_fraction > 0:
        spline = _Hovering(spline, windows, hover_fraction)
    samples = np.arange(n_samples, dtype=np.float64)
    true_xyz = spline(samples)
    true_cameras = {
        n: _look_at_camera(
            rng,
            n,
            zones[n],
            spline(np.linspace(*windows[n], 200)),
            image_size,
            relations[n].alpha * target_rate,
            _outward(zones[n], layout),
        )
        for n in names
    }
    check_views_disjoint(true_cameras, spline(np.linspace(0, n_samples - 1, 20 * n_samples)))

    tracks = {}
    for n, count in zip(names, counts):
        tracks[n] = _track(
            rng, true_cameras[n], spline, relations[n], count, n_samples, tracking_noise_px, frame_time_jitter
        )
    cameras = {n: _perturb_pose(rng, c, true_xyz, projection_error_px) for n, c in true_cameras.items()}
    fov_m = min(c.image_size[0] * np.linalg.norm(c.center - zones[n]) / c.K[0, 0] for n, c in true_cameras.items())
    sigma_m = localisation_noise_pct / 100.0 * fov_m
    xyz = true_xyz + rng.normal(0.0, sigma_m, true_xyz.shape) if sigma_m > 0 else true_xyz
    return Scene(
        trajectory=Trajectory(samples, xyz, target_rate, 0.0),
        true_trajectory=Trajectory(samples, true_xyz, target_rate, 0.0),
        cameras=cameras,
        true_cameras=true_cameras,
        tracks=tracks,
        lines=relations,
        n_frames=dict(zip(names, counts)),
        noise={
            "S_t_px": tracking_noise_px,
            "S_c_px": projection_error_px,
            "S_l_pct": localisation_noise_pct,
            "S_l_m": sigma_m,
            "hover_fraction": hover_fraction,
            "crossings": crossings,
            "frame_time_jitter": frame_time_jitter,
        },
    )


ROAD_ALPHAS = (2.0, 1.0, 5.0 / 3.0)  # 30, 15 and 25 fps at the default 15 Hz log, in turn


def road_scene(seed: int, n_cameras: int, slot_samples: int = 150, video_samples: int = 110, **kwargs) -> Scene:
    """``n_cameras`` along a road (the "path" layout), the target passing each in turn: camera k records the
    target samples [k x slot_samples, k x slot_samples + video_samples) at 30, 15 or 25 fps in turn (the gaps let the
    target walk between the zones at about three times its pace inside them). kwargs: as make_scene."""
    alphas = [ROAD_ALPHAS[k % len(ROAD_ALPHAS)] for k in range(n_cameras)]
    lines = tuple((a, -a * k * slot_samples) for k, a in enumerate(alphas))
    n_frames = tuple(int(round(a * video_samples)) for a in alphas)
    return make_scene(seed, lines=lines, n_frames=n_frames, layout="path", **kwargs)


def write_scene(scene: Scene, directory: str | Path, poses: bool = True) -> Path:
    """Write the scene as a project folder; returns the path of project.toml.

    Layout: project.toml, trajectory.csv, truth.json, and camK/camera.json +
    camK/track.csv per camera. poses: False writes each camera.json without
    R, t (K, dist, image_size only): the poses are then to come from the target.
    """
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    write_trajectory(scene.trajectory, directory / "trajectory.csv")
    parts = ['[target]\ntrajectory = "trajectory.csv"\n']
    for name, camera in scene.cameras.items():
        (directory / name).mkdir(exist_ok=True)
        write_camera(camera if poses else replace(camera, to_estimate=("pose",)), directory / name / "camera.json")
        write_track(scene.tracks[name], directory / name / "track.csv")
        parts.append(
            f'[[cameras]]\nname = "{name}"\ncamera = "{name}/camera.json"\ntrack = "{name}/track.csv"\nfps = '
            f"{camera.fps!r}\n"
        )
    parts.append("[sync]\neps_px = 10.0\ndelta = 0.5\np = 0.99\nr = 0.05\nseed = 0\n")
    project = directory / "project.toml"
    project.write_text("\n".join(parts), encoding="utf-8")
    write_truth(scene, directory)
    return project


def write_truth(scene: Scene, directory: Path) -> None:
    """Write ``directory/truth.json``: frame counts, camera lines, every pair, noise levels (a noise model as its
    fields)."""
    truth = {
        "n_frames": scene.n_frames,
        "cameras_to_target": {n: {"alpha": r.alpha, "beta": r.beta} for n, r in scene.lines.items()},
        "pairs": {k: {"alpha": r.alpha, "beta": r.beta} for k, r in scene.truth_pairs().items()},
        "noise": scene.noise,
    }
    (directory / "truth.json").write_text(json.dumps(truth, indent=1, default=_fields) + "\n", encoding="utf-8")


def _fields(value):
    """A dataclass's fields, for json.dumps."""
    if is_dataclass(value) and not isinstance(value, type):
        return asdict(value)
    raise TypeError(f"{type(value).__name__} is not JSON serializable")


def _visibility_windows(
    relations: dict[str, Relation], counts: dict[str, int], longest: float | None = None
) -> dict[str, tuple[float, float]]:
    """Disjoint sample intervals, one per camera, inside the samples its video covers.

    Cameras are served earliest coverage end first; each takes an equal share
    of what is left of its coverage with the cameras still waiting for it
    (with ``longest``: at most that many samples, centred in the share).
    """
    coverage = {}
    for n, rel in relations.items():
        lo, hi = sorted(((0 - rel.beta) / rel.alpha, (counts[n] - 1 - rel.beta) / rel.alpha))
        coverage[n] = (max(lo, 0.0) + TRANSIT_SAMPLES / 2, hi - TRANSIT_SAMPLES / 2)
    waiting = sorted(coverage, key=lambda n: coverage[n][1])
    windows, cursor = {}, 0.0
    while waiting:
        n = waiting.pop(0)
        lo = max(cursor + TRANSIT_SAMPLES, coverage[n][0])
        sharing = 1 + sum(coverage[m][0] < coverage[n][1] for m in waiting)
        hi = min(coverage[n][1], lo + max(3 * WAYPOINT_EVERY, (coverage[n][1] - lo) / sharing))
        if hi - lo < 3 * WAYPOINT_EVERY:
            raise ValueError(
                f"camera {n}: its video covers too few target samples apart from the other cameras' "
                f"({max(hi - lo, 0):.0f})"
            )
        if longest is not None and hi - lo > longest:
            lo = lo + (hi - lo - longest) / 2
            hi = lo + longest
        windows[n] = (lo, hi)
        cursor = hi
    return windows


def _zone_centre(k: int, n: int, layout: str = "ring") -> np.ndarray:
    if layout == "path":
        return np.array([k * PATH_SPACING_M, ZONE_RADIUS_M, 0.0])
    angle = 2 * math.pi * k / n
    return np.array([ZONE_RADIUS_M * math.cos(angle), ZONE_RADIUS_M * math.sin(angle), 0.0])


def _outward(zone: np.ndarray, layout: str) -> np.ndarray:
    """The horizontal direction a camera looks at its zone along: away from the ring's centre, or across the road."""
    return np.array([0.0, 1.0, 0.0]) if layout == "path" else zone / np.linalg.norm(zone)


class _Hovering:
    """A path that stops at a point for a share of each window, then catches up.

    path(s) = spline(warp(s)), warp piecewise linear: identity outside the
    windows, flat during the hover (which starts a third into the window, at
    the waypoint the crossings return to), steeper after it.
    """

    def __init__(self, spline, windows, fraction):
        self.spline = spline
        knots = [(-1e9, -1e9)]
        for lo, hi in sorted(windows.values()):
            grid = _waypoint_times(lo, hi)
            start = grid[_anchor(grid)]
            knots += [(lo, lo), (start, start), (start + fraction * (hi - lo), start), (hi, hi)]
        knots.append((1e9, 1e9))
        self.x, self.y = np.array(knots).T

    def __call__(self, s):
        return self.spline(np.interp(s, self.x, self.y))


def _waypoint_times(lo: float, hi: float) -> np.ndarray:
    return np.linspace(lo, hi, max(3, int((hi - lo) / WAYPOINT_EVERY) + 1))


def _anchor(grid: np.ndarray) -> int:
    """The waypoint a third into the window: where the target hovers and that crossings revisit."""
    return int(np.argmin(np.abs(grid - (grid[0] + (grid[-1] - grid[0]) / 3))))


def _trajectory_spline(
    rng,
    windows,
    zones,
    n_samples,
    crossings: int = 0,
    rest: bool = False,
    ends: tuple[np.ndarray, np.ndarray] = (CENTRE, CENTRE),
) -> CubicSpline:
    """A C2 path that wanders inside each camera's zone during its window.

    Inside a zone, waypoints are a random walk of constant step and bounded
    turn (so the target never stops), kept within the zone; heights vary.
    With crossings > 0, the waypoint a third into the window is revisited
    that many times, evenly spaced over the rest of the window. With rest,
    the target walks to the scene's centre between stays (``_rest``). ends:
    where the path starts and ends (out of every view).
    """
    times: list[float] = []
    points: list[list[float]] = []
    stays = sorted(windows.items(), key=lambda item: item[1][0])
    for name, (lo, hi) in stays:
        travel = float(np.linalg.norm(zones[name][:2])) / REST_SPEED_M  # samples between the centre and the zone
        if rest:
            _rest(rng, times, points, times[-1] + travel if times else REST_EVERY / 2, lo - travel)
        grid = _waypoint_times(lo, hi)
        count = len(grid)
        position = zones[name][:2] + rng.uniform(-0.5, 0.5, 2) * ZONE_HALF_WIDTH_M
        heading = rng.uniform(0, 2 * math.pi)
        anchor = _anchor(grid)
        revisits = set(np.linspace(anchor, count - 1, crossings + 2).round().astype(int)[1:-1]) if crossings else set()
        for k, t in enumerate(grid):
            times.append(t)
            points.append([position[0], position[1], rng.uniform(0.5, 5.0)])
            if k in revisits:
                points[-1] = list(points[len(points) - 1 - (k - anchor)])
            heading += rng.uniform(-1.0, 1.0)
            step = WAYPOINT_STEP_M * np.array([math.cos(heading), math.sin(heading)])
            if np.abs(position + step - zones[name][:2]).max() > ZONE_HALF_WIDTH_M:
                to_centre = zones[name][:2] - position
                heading = math.atan2(to_centre[1], to_centre[0]) + rng.uniform(-0.5, 0.5)
                step = WAYPOINT_STEP_M * np.array([math.cos(heading), math.sin(heading)])
            position = position + step
    if rest and stays:
        _rest(rng, times, points, times[-1] + travel, n_samples - REST_EVERY / 2)
    knots = np.array([-1.0] + times + [n_samples])
    return CubicSpline(knots, np.array([list(ends[0])] + points + [list(ends[1])]), axis=0, bc_type="natural")


def _rest(rng, times: list, points: list, start: float, stop: float) -> None:
    """Waypoints near the scene's centre (behind every camera) every REST_EVERY samples in [start, stop); none when the
    gap is too short.
    """
    for t in np.arange(start, stop - WAYPOINT_EVERY, REST_EVERY):
        times.append(float(t))
        points.append([*rng.uniform(-2.0, 2.0, 2), 1.5])


def _look_at_camera(rng, name, zone, window_points, image_size, fps, outward) -> Camera:
    """A camera CAMERA_DISTANCE_M before its zone along ``outward`` (unit, horizontal), looking at the zone."""
    centre = zone - CAMERA_DISTANCE_M * outward + [0, 0, CAMERA_HEIGHT_M]
    target = zone + [0, 0, 2.0]
    forward = (target - centre) / np.linalg.norm(target - centre)
    right = np.cross(forward, [0, 0, 1.0])
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    R = np.vstack([right, down, forward])
    t = -R @ centre
    cam = (window_points - centre) @ R.T
    normalized = np.abs(cam[:, :2] / cam[:, 2:3])
    w, h = image_size
    focal = 0.9 * min(w / 2 / np.quantile(normalized[:, 0], 0.9), h / 2 / np.quantile(normalized[:, 1], 0.9))
    aspect = rng.uniform(0.98, 1.02)
    K = np.array(
        [[focal, 0, w / 2 + rng.uniform(-10, 10)], [0, focal * aspect, h / 2 + rng.uniform(-10, 10)], [0, 0, 1.0]]
    )
    dist = np.array([rng.uniform(-0.2, 0.05), rng.uniform(-0.05, 0.05), 0.0, 0.0, 0.0])
    return Camera(name, K, dist, R, t, (w, h), float(fps))


def check_views_disjoint(
    cameras: dict[str, Camera], points: np.ndarray, what: str = "scene generator: a trajectory point"
) -> None:
    """Raise AssertionError when any world point (N, 3) is seen by two cameras (the views must not overlap)."""
    seen = np.zeros(len(points), dtype=int)
    for camera in cameras.values():
        uv, valid = camera.project(points)
        seen += valid & camera.in_image(np.nan_to_num(uv, nan=-1e9))
    if (seen > 1).any():
        raise AssertionError(f"{what} is visible in two cameras")


def _track(
    rng, camera: Camera, spline, line: Relation, n_frames: int, n_samples: int, noise_px: float, jitter: float = 0.0
) -> Track:
    frames = np.arange(n_frames)
    clock = frames.astype(np.float64)  # camera clock in frame units: time_s * fps
    if jitter > 0:
        clock = np.r_[0.0, np.cumsum(1.0 + rng.uniform(-jitter, jitter, n_frames - 1))]
    assert camera.fps is not None, "the scene's cameras have their frame rates"
    times = clock / camera.fps
    sample = (clock - line.beta) / line.alpha
    inside = (sample >= 0) & (sample <= n_samples - 1)
    frames, sample, times = frames[inside], sample[inside], times[inside]
    uv, valid = camera.project(spline(sample))
    keep = valid & camera.in_image(np.nan_to_num(uv, nan=-1e9))
    frames, uv, times = frames[keep], uv[keep], times[keep]
    if noise_px > 0:
        uv = uv + rng.normal(0.0, noise_px, uv.shape)
    return Track(frames.astype(np.int64), uv[:, 0], uv[:, 1], time_s=times)


def _perturb_pose(rng, camera: Camera, points: np.ndarray, mean_error_px: float) -> Camera:
    """The camera with its pose moved so that the mean reprojection error is mean_error_px."""
    if mean_error_px <= 0:
        return camera
    uv_true, valid = camera.project(points)
    visible = valid & camera.in_image(np.nan_to_num(uv_true, nan=-1e9))
    direction = rng.normal(size=6)
    depth = float(np.median((points[visible] @ camera.R.T + camera.t)[:, 2]))
    direction[3:] *= depth  # a rotation of 1 rad and a translation of `depth` m move pixels alike

    def moved(scale: float) -> Camera:
        rvec = camera.rvec + 1e-3 * scale * direction[:3]
        R = cv2.Rodrigues(rvec)[0]
        return Camera(
            camera.name,
            camera.K,
            camera.dist,
            R,
            camera.t + 1e-3 * scale * direction[3:],
            camera.image_size,
            camera.fps,
        )

    def excess(scale: float) -> float:
        uv, _ = moved(scale).project(points[visible])
        return float(np.mean(np.linalg.norm(uv - uv_true[visible], axis=1))) - mean_error_px

    hi = 1.0
    while excess(hi) < 0:
        hi *= 2
    return moved(brentq(excess, 0.0, hi, xtol=1e-6))
