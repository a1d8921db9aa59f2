"""A pedestrian walking at a steady pace through the views of fixed cameras, logged by a receiver with realistic errors.

The route visits one zone per camera, about ``spacing_m`` apart on a line.
With ``route = "turns"`` the walker turns inside every view (60-110
degrees), which is what makes a log's bias observable; with ``"straight"``
each view is crossed in a straight line, in alternating directions (the
degenerate case: a constant bias along the walk cannot be told from a time
offset). Between views the walker goes round behind the cameras, out of
every view. Each camera records from before the walk starts to after it
ends, at its nominal fps with a small clock drift; its track is the true
position projected into it plus pixel noise. The log is the true path
sampled at the receiver's rate with the errors of a LogErrorModel
(data_fixtures/log_error.py). Truth: each camera's line frame = alpha *
sample + beta on the log's sample grid (sample = t * rate, t = 0 at the
walk's start).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from calibration.camera import Camera
from data_fixtures.log_error import PRESETS, LogErrorModel, log_errors
from data_fixtures.scene import Scene, check_views_disjoint
from tlsync_pipeline.sync.timeline import Relation
from tlsync_pipeline.trajectory import Trajectory
from trackers.track import Track

WALKER_HEIGHT_M = 1.0  # the logged and tracked point above the ground


@dataclass(frozen=True)
class WalkSpec:
    """cameras: how many; route: "turns" or "straight" (see the module); speed_mps: the walker's pace; fps: the cameras'
    nominal rates (cycled); image_size: pixels; tracking_noise_px: std per axis; clock_drift: std of each camera's
    relative rate error; log: the receiver's error model; lead_s: the latest a camera starts before the walk."""

    cameras: int = 3
    route: str = "turns"
    speed_mps: float = 1.4
    fps: tuple[float, ...] = (30.0,)
    image_size: tuple[int, int] = (1280, 720)
    tracking_noise_px: float = 2.0
    clock_drift: float = 3e-5
    log: LogErrorModel = field(default_factory=lambda: PRESETS["rtk"])
    lead_s: float = 30.0
    spacing_m: float = 70.0
    camera_distance_m: float = 18.0
    camera_height_m: float = 6.0


def make_walk_scene(seed: int, spec: WalkSpec = WalkSpec()) -> Scene:
    """A deterministic walk scene (see the module); the Scene's noise holds the log model and its bias at each fix."""
    rng = np.random.default_rng(seed)
    zones = [np.array([k * spec.spacing_m, rng.uniform(-5.0, 5.0)]) for k in range(spec.cameras)]
    waypoints = _route(rng, zones, spec.route)
    path = _Path(waypoints, spec.speed_mps)
    names = [f"cam{k}" for k in range(spec.cameras)]
    cameras = {
        n: _camera(rng, n, z, spec, spec.fps[k % len(spec.fps)], spec.route)
        for k, (n, z) in enumerate(zip(names, zones))
    }
    check_views_disjoint(cameras, path.at(np.linspace(0.0, path.duration, int(path.duration * 20))))
    rate = spec.log.rate_hz
    t_fix = np.arange(0.0, path.duration, 1.0 / rate)
    errors, bias = log_errors(rng, t_fix, spec.log)
    samples = np.arange(len(t_fix), dtype=np.float64)
    true_xyz = path.at(t_fix)
    lines, tracks, n_frames = {}, {}, {}
    for name, camera in cameras.items():
        assert camera.fps is not None
        fps_true = camera.fps * (1.0 + rng.normal(0.0, spec.clock_drift))
        start = -rng.uniform(5.0, spec.lead_s)  # the video's first frame, seconds on the walk's clock
        n_frames[name] = int(math.ceil((path.duration + rng.uniform(5.0, spec.lead_s) - start) * fps_true))
        # frame = (t - start) * fps_true, t = sample / rate
        lines[name] = Relation(fps_true / rate, -start * fps_true)
        tracks[name] = _track(rng, camera, path, start, fps_true, n_frames[name], spec.tracking_noise_px)
    return Scene(
        trajectory=Trajectory(samples, true_xyz + errors, rate, 0.0),
        true_trajectory=Trajectory(samples, true_xyz, rate, 0.0),
        cameras=cameras,
        true_cameras=cameras,
        tracks=tracks,
        lines=lines,
        n_frames=n_frames,
        noise={"log": spec.log, "bias_m": bias, "S_t_px": spec.tracking_noise_px, "route": spec.route},
    )


def _route(rng, zones: list[np.ndarray], kind: str) -> np.ndarray:
    """(M, 2) waypoints: through each zone (turning, or straight in alternating directions), round behind the cameras
    between zones.
    """
    points: list[np.ndarray] = []
    for k, centre in enumerate(zones):
        if kind == "turns":
            heading = rng.uniform(-0.4, 0.4) + (0.0 if k % 2 == 0 else math.pi)
            turn = rng.choice([-1.0, 1.0]) * rng.uniform(math.radians(60), math.radians(110))
            entry = centre - 9.0 * np.array([math.cos(heading), math.sin(heading)])
            exit_ = centre + 9.0 * np.array([math.cos(heading + turn), math.sin(heading + turn)])
            inside = [
                entry - 12.0 * np.array([math.cos(heading), math.sin(heading)]),
                entry,
                centre,
                exit_,
                exit_ + 12.0 * np.array([math.cos(heading + turn), math.sin(heading + turn)]),
            ]
        elif kind == "straight":
            direction = 1.0 if k % 2 == 0 else -1.0
            inside = [centre + [-22.0 * direction, 0.0], centre + [22.0 * direction, 0.0]]
        else:
            raise ValueError(f"unknown route {kind!r}: expected 'turns' or 'straight'")
        if points:
            behind = -45.0  # metres south of the zones: behind every camera
            points += [np.array([points[-1][0], behind]), np.array([inside[0][0], behind])]
        points += inside
    return np.array(points)


class _Path:
    """A constant-speed walk along waypoints (corners rounded over 2 m): position (x, y, height) at times t (s)."""

    def __init__(self, waypoints: np.ndarray, speed: float):
        dense = _rounded(waypoints, 2.0)
        step = np.linalg.norm(np.diff(dense, axis=0), axis=1)
        self.arc = np.r_[0.0, np.cumsum(step)]
        self.dense = dense
        self.speed = speed
        self.duration = float(self.arc[-1] / speed)

    def at(self, t: np.ndarray) -> np.ndarray:
        s = np.clip(np.asarray(t, dtype=np.float64) * self.speed, 0.0, self.arc[-1])
        x = np.interp(s, self.arc, self.dense[:, 0])
        y = np.interp(s, self.arc, self.dense[:, 1])
        return np.column_stack([x, y, np.full(len(s), WALKER_HEIGHT_M)])


def _rounded(waypoints: np.ndarray, radius: float, per_metre: int = 10) -> np.ndarray:
    """The polyline through the waypoints with each corner replaced by a quadratic Bezier arc over ``radius`` metres,
    densely sampled.
    """
    out = [waypoints[0]]
    for a, b, c in zip(waypoints[:-2], waypoints[1:-1], waypoints[2:]):
        into, outof = b - a, c - b
        r = min(radius, 0.45 * np.linalg.norm(into), 0.45 * np.linalg.norm(outof))
        p0 = b - r * into / np.linalg.norm(into)
        p2 = b + r * outof / np.linalg.norm(outof)
        out += list(np.linspace(out[-1], p0, max(2, int(np.linalg.norm(p0 - out[-1]) * per_metre)))[1:])
        u = np.linspace(0.0, 1.0, max(3, int(2 * r * per_metre)))[:, None]
        out += list(((1 - u) ** 2 * p0 + 2 * u * (1 - u) * b + u**2 * p2)[1:])
    out += list(
        np.linspace(out[-1], waypoints[-1], max(2, int(np.linalg.norm(waypoints[-1] - out[-1]) * per_metre)))[1:]
    )
    return np.array(out)


def _camera(rng, name: str, zone: np.ndarray, spec: WalkSpec, fps: float, route: str) -> Camera:
    """A camera south of its zone (within +-25 degrees, +-8 for straight routes), looking at the zone's centre, seeing
    about +-12 m.
    """
    azimuth = rng.uniform(-1.0, 1.0) * math.radians(25.0 if route == "turns" else 8.0)
    ground = np.r_[zone, 0.0]
    centre = (
        ground
        + spec.camera_distance_m * np.array([math.sin(azimuth), -math.cos(azimuth), 0.0])
        + [0.0, 0.0, spec.camera_height_m]
    )
    target = ground + [0.0, 0.0, WALKER_HEIGHT_M]
    forward = (target - centre) / np.linalg.norm(target - centre)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    R = np.vstack([right, down, forward])
    w, h = spec.image_size
    focal = (w / 2) / (12.0 / spec.camera_distance_m)
    K = np.array([[focal, 0.0, w / 2 + rng.uniform(-8, 8)], [0.0, focal, h / 2 + rng.uniform(-8, 8)], [0.0, 0.0, 1.0]])
    return Camera(name, K, np.zeros(5), R, -R @ centre, (w, h), float(fps))


def _track(rng, camera: Camera, path: _Path, start: float, fps_true: float, n_frames: int, noise_px: float) -> Track:
    """The walker's projection in every frame where it is in view (0-based frames, time_s from the nominal fps), plus
    noise.
    """
    assert camera.fps is not None
    frames = np.arange(n_frames)
    t = start + frames / fps_true
    walking = (t >= 0.0) & (t <= path.duration)
    frames, t = frames[walking], t[walking]
    uv, valid = camera.project(path.at(t))
    keep = valid & camera.in_image(np.nan_to_num(uv, nan=-1e9))
    frames, uv = frames[keep], uv[keep] + rng.normal(0.0, noise_px, (int(keep.sum()), 2))
    return Track(frames.astype(np.int64), uv[:, 0], uv[:, 1], time_s=frames / camera.fps)
