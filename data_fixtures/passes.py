"""Pass scenes: a target crossing the non-overlapping views of a row of cameras, with ground control points.

Cameras stand SPACING_M apart along the x axis, DISTANCE_M back from the
route and HEIGHT_M up, each looking across the route at its own stretch of
it (the views do not overlap; checked). The target (data_fixtures.crowd.Route:
constant speed, rounded corners) walks along y = 0 and, in each view, either
turns (``"turn"``: a random polyline through the view, so the pose is
determined by the path) or walks straight through (``"straight"``: the
degenerate case of a pose from the target). A ``drone`` flies the same
plan at changing heights (a path in 3D), a walker keeps its centre at one
height (a path in a plane).

Per camera: its true camera (640x480, 30 fps by default, a little lens
distortion), its track (the true projection at each frame's time plus
Gaussian pixel noise), its line frame = alpha * sample + beta (each camera
starts recording at its own time), and GCPS_PER_CAMERA ground control points
spread over its view (on the ground and on 2-4 m poles) whose world
coordinates are surveyed with ``gcp_noise_m`` of error per horizontal axis
(a phone or a web map: 0.5-3 m; RTK: 0.01) and their true pixels.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from calibration.camera import Camera
from data_fixtures.crowd import Route
from data_fixtures.gcp import looking_at
from data_fixtures.scene import Scene, check_views_disjoint
from tlsync_pipeline.sync.timeline import Relation
from tlsync_pipeline.trajectory import Trajectory
from trackers.track import Track

SPACING_M = 60.0
DISTANCE_M = 16.0
HEIGHT_M = 8.0
VIEW_HALF_M = 9.0  # half the stretch of route a view covers, metres
GCPS_PER_CAMERA = 8
WALKER_CENTRE_M = 0.9


@dataclass(frozen=True)
class GcpSet:
    """One camera's ground control points: pixels (N, 2, as clicked), surveyed world points (N, 3, with the survey's
    error), true world points.
    """

    uv: np.ndarray
    xyz: np.ndarray
    true_xyz: np.ndarray


@dataclass
class PassScene:
    """The scene (trajectory with noise, true cameras, tracks, lines) and each camera's GCPs."""

    scene: Scene
    gcps: dict[str, GcpSet]


def make_pass_scene(
    seed: int = 0,
    paths: tuple[str, ...] = ("turn", "turn", "turn"),
    fps: float = 30.0,
    log_rate: float = 10.0,
    speed_mps: float = 1.4,
    drone: bool = False,
    tracking_noise_px: float = 2.0,
    log_noise_m: float = 0.02,
    gcp_noise_m: float = 0.0,
    image_size: tuple[int, int] = (640, 480),
    view_walk_s: float = 0.0,
) -> PassScene:
    """A deterministic pass scene, one camera per entry of ``paths`` (``"turn"`` or ``"straight"``).

    log_noise_m: white noise per axis of the logged positions (RTK: 0.02);
    gcp_noise_m: survey error per horizontal axis of each GCP; view_walk_s:
    seconds a ``"turn"`` walk lasts at least inside its view (more random
    waypoints in the view: a long track, for the speed bench).
    """
    rng = np.random.default_rng(seed)
    names = [f"cam{k}" for k in range(len(paths))]
    waypoints = [np.array([-VIEW_HALF_M - 15.0, 0.0])]
    for k, kind in enumerate(paths):
        x0 = k * SPACING_M
        if kind == "turn":
            for u in np.sort(rng.uniform(-0.8, 0.8, 4)) * VIEW_HALF_M:
                waypoints.append(np.array([x0 + u, rng.uniform(-5.0, 7.0)]))
            while view_walk_s > 0 and _walked(waypoints, x0) < speed_mps * view_walk_s:
                waypoints.append(np.array([x0 + rng.uniform(-0.8, 0.8) * VIEW_HALF_M, rng.uniform(-5.0, 7.0)]))
        elif kind != "straight":
            raise ValueError(f"unknown path kind {kind!r}: 'turn' or 'straight'")
        waypoints.append(np.array([x0 + VIEW_HALF_M + 15.0, 0.0]))
    ground = np.array(waypoints)
    if drone:
        plan = np.column_stack([ground, rng.uniform(3.0, 12.0, len(ground))])
        route = Route(plan, speed_mps, 0.0)
    else:
        route = Route(ground, speed_mps, 2 * WALKER_CENTRE_M)
    samples = np.arange(math.floor(route.duration * log_rate) + 1, dtype=np.float64)
    true_xyz = route.at(samples / log_rate)
    xyz = true_xyz + log_noise_m * rng.standard_normal(true_xyz.shape)
    cameras, tracks, lines, counts, gcps = {}, {}, {}, {}, {}
    w, h = image_size
    for k, name in enumerate(names):
        x0 = k * SPACING_M
        R, t = looking_at([x0 + rng.uniform(-2, 2), -DISTANCE_M, HEIGHT_M], [x0, 2.0, 0.5 if not drone else 4.0])
        focal = 0.5 * w / math.tan(math.radians(rng.uniform(30.0, 36.0)))
        K = np.array(
            [
                [focal, 0.0, (w - 1) / 2 + rng.uniform(-8, 8)],
                [0.0, focal, (h - 1) / 2 + rng.uniform(-8, 8)],
                [0.0, 0.0, 1.0],
            ]
        )
        dist = np.array([rng.uniform(-0.15, 0.05), rng.uniform(-0.05, 0.05), 0.0, 0.0, 0.0])
        cameras[name] = Camera(name, K, dist, R, t, image_size, fps)
    check_views_disjoint(
        cameras,
        route.at(np.linspace(0.0, route.duration, int(route.duration * 50))),
        "pass scene: a point of the route",
    )
    t_all = np.linspace(0.0, route.duration, int(route.duration * 20))
    for name, camera in cameras.items():
        uv, valid = camera.project(route.at(t_all))
        seen = t_all[valid & camera.in_image(np.nan_to_num(uv, nan=-1e9))]
        start = float(seen.min() - rng.uniform(5.0, 20.0))
        end = float(seen.max() + rng.uniform(5.0, 20.0))
        count = int((end - start) * fps)
        times = start + np.arange(count) / fps
        uv, valid = camera.project(route.at(times))
        inside = valid & camera.in_image(np.nan_to_num(uv, nan=-1e9)) & (times >= 0) & (times <= route.duration)
        frames = np.flatnonzero(inside)
        noisy = uv[frames] + tracking_noise_px * rng.standard_normal((len(frames), 2))
        tracks[name] = Track(frames.astype(np.int64), noisy[:, 0], noisy[:, 1], time_s=times[frames] - start)
        lines[name] = Relation(fps / log_rate, -start * fps)
        counts[name] = count
        gcps[name] = _gcps(rng, camera, gcp_noise_m)
    scene = Scene(
        trajectory=Trajectory(samples, xyz, log_rate, 0.0),
        true_trajectory=Trajectory(samples, true_xyz, log_rate, 0.0),
        cameras=cameras,
        true_cameras=cameras,
        tracks=tracks,
        lines=lines,
        n_frames=counts,
        noise={
            "S_t_px": tracking_noise_px,
            "log_noise_m": log_noise_m,
            "gcp_noise_m": gcp_noise_m,
            "paths": list(paths),
            "drone": drone,
        },
    )
    return PassScene(scene, gcps)


def _walked(waypoints: list[np.ndarray], x0: float) -> float:
    """Metres of the polyline walked between waypoints inside the view centred at x0."""
    inside = [w for w in waypoints if abs(w[0] - x0) <= VIEW_HALF_M]
    return float(np.linalg.norm(np.diff(inside, axis=0), axis=1).sum()) if len(inside) > 1 else 0.0


def _gcps(rng, camera: Camera, noise_m: float) -> GcpSet:
    """GCPS_PER_CAMERA points over the camera's view, one per cell of a 4 x 2 grid of the image: on the ground, or atop
    a 2-4 m pole.
    """
    w, h = camera.image_size
    world = []
    for i in range(4):
        for j in range(2):
            u, v = (i + rng.uniform(0.2, 0.8)) * w / 4, (0.5 + j + rng.uniform(0.1, 0.6)) * h / 2.6
            ray = camera.R.T @ np.linalg.solve(camera.K, [u, v, 1.0])
            height = 0.0 if rng.random() < 0.5 else rng.uniform(2.0, 4.0)
            depth = (height - camera.center[2]) / ray[2] if ray[2] < -1e-3 else 25.0
            world.append(camera.center + min(depth, 40.0) * ray)
    xyz = np.array(world)[:GCPS_PER_CAMERA]
    uv, valid = camera.project(xyz)
    keep = valid & camera.in_image(np.nan_to_num(uv, nan=-1e9))
    surveyed = xyz.copy()
    surveyed[:, :2] += noise_m * rng.standard_normal((len(xyz), 2))  # drawn at every noise level: one scene per seed
    return GcpSet(uv[keep], surveyed[keep], xyz[keep])
