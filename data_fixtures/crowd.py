"""Crowd scenes: a logged walker among look-alike walkers, seen by surveillance cameras.

Two (or more) fixed cameras, 5 m up and tilted down, look at disjoint patches
of ground 5-15 m ahead (people about 100 px tall close by and 40 px far away
at 480x360). The target visits each camera's patch in turn, several times
(VISIT_S seconds each), leaving every view in between and coming back to it. Its log is the
position of its body centre (half its height above the ground), sampled at
``log_rate`` Hz with GPS-like noise.

Distractor walkers have the target's size, colour and speed. Each walks
straight through the view along a line that crosses the target's route;
about half of them pass the crossing point within a second or two of the
target, so they occlude it or merge with its blob. Every person is a dark
silhouette (an ellipse of 0.45 m by its height) drawn far to near, so nearer
people hide farther ones. The videos add a global flicker, a lighting drop
(a cloud) of 20 %, Gaussian sensor noise and H.264 compression.

Truth: per camera, the target's image position per frame (the projection of
its body centre; NaN where it is out of view), whether it is visible (in
view and at least half unoccluded), and the camera lines
frame = alpha * sample + beta of the log's sample grid (different frame
rates, shifted starts), as a ``data_fixtures.scene.Scene``.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import av
import cv2
import numpy as np

from calibration.camera import Camera, write_camera
from data_fixtures.gps_logs import write_gpx_log
from data_fixtures.log_error import LogErrorModel, log_errors
from data_fixtures.scene import Scene, check_views_disjoint, write_truth
from data_fixtures.video import _background, h264_writer
from tlsync_pipeline.geodesy import Origin, enu_to_geodetic
from tlsync_pipeline.sync.solve.methods import CameraInput
from tlsync_pipeline.sync.timeline import Relation
from tlsync_pipeline.trajectory import Trajectory, write_trajectory
from trackers.track import Track

CAMERA_HEIGHT_M = 5.0
# between neighbouring cameras' headings: tilted down, each view spans up to ~85 deg of azimuth near its bottom edge
YAW_STEP_DEG = 90.0
# views "shared": between neighbouring cameras' headings round the one patch they all watch
SHARED_YAW_STEP_DEG = 75.0
SHARED_VISIT_S = 5.0  # seconds the target walks in the shared patch per visit
SHARED_AWAY_M = (
    14.0  # the least distance from the shared patch's middle of the points where the target leaves the views
)
VISIT_S = 5.0  # seconds the target walks in a camera's patch per visit
NEAR_M, FAR_M = 5.5, 15.0  # ground patch walked on, distance ahead of the camera
PATCH_HALF_WIDTH_M = 5.0
PERSON_WIDTH_M = 0.45
TARGET_HEIGHT_M = 1.75
PERSON_GREY = 55.0  # every walker's grey level (target included), +- a little
# the white part of a detected blob's centroid about the silhouette's centre, where the target walks alone (std per
# axis, pixels; the bound's tracking noise): frame to frame, 0.7-1.1 px across the body and 2.1-2.4 px along it
CENTROID_NOISE_PX = 1.7


@dataclass(frozen=True)
class CrowdSpec:
    """What to render.

    fps / n_frames: per camera; distractors: walkers in view at a time, per
    camera; speed_mps: walking speed of everyone (+-15 %); gps_noise_m: std
    of the log's position noise per axis; log_error: a receiver's error
    model instead (data_fixtures/log_error.py: a Gauss-Markov bias plus
    white noise, at log_rate; the scene is otherwise the same); noise:
    sensor noise std (grey levels); crf: H.264 quality (higher: more
    compression); views: "apart" (each camera its own patch of ground, the
    target visiting them in turn) or "shared" (every camera, from its own
    place and heading, watches one patch at the same time, the target
    leaving every view between visits: a multi-view surveillance set).
    """

    fps: tuple[float, ...] = (10.0, 5.0)
    n_frames: tuple[int, ...] = (450, 225)
    image_size: tuple[int, int] = (480, 360)
    distractors: int = 6
    log_rate: float = 10.0
    speed_mps: float = 1.4
    gps_noise_m: float = 0.02
    log_error: LogErrorModel | None = None
    noise: float = 3.0
    crf: int = 28
    seed: int = 0
    views: str = "apart"

    def log_model(self) -> LogErrorModel:
        """The log's error model: ``log_error``, or white ``gps_noise_m`` on every axis at ``log_rate``."""
        if self.log_error is not None:
            return self.log_error
        return LogErrorModel("white", self.log_rate, self.gps_noise_m, self.gps_noise_m)


# Test size: two cameras at 10 and 5 fps, 45 s each, 480x360.
SMALL = CrowdSpec()


@dataclass
class CameraTruth:
    """Per frame of one camera, the target's silhouette and the crowd.

    xy: (N, 2) target centre, pixels (NaN when no part of it is in the
    image); axes: (N, 2) its ellipse's semi-axes (across, along the body),
    pixels; angle: (N,) the body axis' tilt from vertical, degrees; visible:
    (N,) centre inside the image and at least half of the body unoccluded;
    people: (N,) people at least partly in the image.
    """

    xy: np.ndarray
    axes: np.ndarray
    angle: np.ndarray
    visible: np.ndarray
    people: np.ndarray
    video: Path | None = None

    def on_target(self, frame: np.ndarray, xy: np.ndarray) -> np.ndarray:
        """Whether each point (pixels) at each frame lies on the target's silhouette."""
        frame = np.asarray(frame, dtype=np.int64)
        d = np.asarray(xy, dtype=np.float64) - self.xy[frame]
        theta = np.radians(self.angle[frame])
        across = d[:, 0] * np.cos(theta) + d[:, 1] * np.sin(theta)
        along = -d[:, 0] * np.sin(theta) + d[:, 1] * np.cos(theta)
        inside = (across / self.axes[frame, 0]) ** 2 + (along / self.axes[frame, 1]) ** 2 <= 1.0
        return np.where(np.isfinite(inside), inside, False) & np.isfinite(self.xy[frame, 0])


@dataclass
class CrowdScene:
    """The scene (cameras, log, lines, true target tracks) and per-camera frame truth."""

    scene: Scene
    truth: dict[str, CameraTruth] = field(default_factory=dict)


@dataclass(frozen=True)
class _View:
    """A camera's ground frame (x right, y ahead, metres): its heading ``yaw`` (radians, counter-clockwise from +y)
    and the ground point ``foot`` below it (world x, y, metres)."""

    yaw: float
    foot: tuple[float, float] = (0.0, 0.0)

    def to_world(self, local: np.ndarray) -> np.ndarray:
        return _to_world(self.yaw, local) + np.asarray(self.foot)

    def to_local(self, point: np.ndarray) -> np.ndarray:
        return _to_world(-self.yaw, np.asarray(point) - np.asarray(self.foot))

    def sees(self, point: np.ndarray) -> bool:
        """Whether a world ground point is well inside the view (about 0.6 x distance wide on each side)."""
        x, y = self.to_local(point)
        return NEAR_M + 0.5 <= y <= FAR_M - 0.5 and abs(x) <= min(PATCH_HALF_WIDTH_M, 0.45 * y)


def _views(count: int, kind: str, rng) -> list[_View]:
    """``count`` cameras' views: "apart", all at the origin YAW_STEP_DEG apart (disjoint patches); "shared", round one
    patch SHARED_YAW_STEP_DEG apart, each 9.5-11.5 m from its middle (the origin's 10.25 m ahead)."""
    offsets = [k - (count - 1) / 2 for k in range(count)]
    if kind == "apart":
        return [_View(math.radians(YAW_STEP_DEG * o)) for o in offsets]
    assert kind == "shared", f"views are apart or shared, not {kind!r}"
    middle = np.array([0.0, (NEAR_M + FAR_M) / 2])
    views = []
    for o in offsets:
        yaw = math.radians(SHARED_YAW_STEP_DEG * o)
        foot = middle - _to_world(yaw, np.array([0.0, rng.uniform(9.5, 11.5)]))
        views.append(_View(yaw, (float(foot[0]), float(foot[1]))))
    return views


def _to_world(yaw: float, local: np.ndarray) -> np.ndarray:
    """Ground point(s) from a camera's local ground frame (x right, y ahead, metres) to the world's."""
    c, s_ = math.cos(yaw), math.sin(yaw)
    local = np.asarray(local, dtype=np.float64)
    return np.stack([c * local[..., 0] - s_ * local[..., 1], s_ * local[..., 0] + c * local[..., 1]], axis=-1)


def surveillance_camera(name: str, view: _View, image_size: tuple[int, int], fps: float, rng) -> Camera:
    """A camera CAMERA_HEIGHT_M above its view's foot, turned to its heading, tilted down at the middle of its patch."""
    w, h = image_size
    centre = np.array([*view.foot, CAMERA_HEIGHT_M])
    aim = np.r_[view.to_world(np.array([rng.uniform(-0.3, 0.3), (NEAR_M + FAR_M) / 2 + 1.0])), 0.0]
    forward = (aim - centre) / np.linalg.norm(aim - centre)
    right = np.cross(forward, [0, 0, 1.0])
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    R = np.vstack([right, down, forward])
    focal = 0.84 * w  # 480 px: a 1.75 m person is ~100 px tall at 6 m and ~40 px at 15 m
    K = np.array(
        [[focal, 0, (w - 1) / 2 + rng.uniform(-4, 4)], [0, focal, (h - 1) / 2 + rng.uniform(-4, 4)], [0, 0, 1.0]]
    )
    dist = np.array([rng.uniform(-0.08, -0.02), 0.0, 0.0, 0.0, 0.0])
    return Camera(name, K, dist, R, -R @ centre, (w, h), float(fps))


def make_crowd_scene(spec: CrowdSpec = SMALL, directory: str | Path | None = None) -> CrowdScene:
    """Build the scene; with ``directory``, also render each camera's video there (``<name>.mp4``)."""
    rng = np.random.default_rng(spec.seed)
    names = [f"cam{k}" for k in range(len(spec.fps))]
    views = _views(len(names), spec.views, rng)
    cameras = {n: surveillance_camera(n, views[k], spec.image_size, spec.fps[k], rng) for k, n in enumerate(names)}
    starts = [rng.uniform(0.5, 3.0) for _ in names]  # each camera starts recording at its own time
    patches: list[tuple[_View, ...]] = [(v,) for v in views] if spec.views == "apart" else [tuple(views)]
    route, stays = _target_route(
        rng, cameras, patches, max(s + n / f for s, n, f in zip(starts, spec.n_frames, spec.fps)), spec.speed_mps
    )
    end_s = route.duration
    samples = np.arange(int(math.floor(end_s * spec.log_rate)) + 1, dtype=np.float64)
    true_xyz = route.at(samples / spec.log_rate)
    if spec.views == "apart":
        check_views_disjoint(
            cameras, route.at(np.linspace(0, end_s, int(end_s * 50))), "crowd scene: a point of the target's route"
        )
    xyz = true_xyz + rng.normal(0.0, spec.gps_noise_m, true_xyz.shape) if spec.gps_noise_m > 0 else true_xyz
    if spec.log_error is not None:  # its own stream: the people and the videos stay those of the same seed
        xyz = true_xyz + log_errors(np.random.default_rng([spec.seed, 1]), samples / spec.log_rate, spec.log_error)[0]
    lines, tracks, truth = {}, {}, {}
    walkers = []
    for k, patch in enumerate(patches):  # shared: one crowd, seen by every camera
        recording = (starts[k], starts[k] + (spec.n_frames[k] - 1) / spec.fps[k])
        if spec.views == "shared":
            recording = (min(starts), max(s + (n - 1) / f for s, n, f in zip(starts, spec.n_frames, spec.fps)))
        walkers += _distractors(rng, patch, route, stays[k], recording, spec.distractors, spec.speed_mps)
    for k, name in enumerate(names):
        camera, fps, count = cameras[name], spec.fps[k], spec.n_frames[k]
        start_s = starts[k]
        lines[name] = Relation(fps / spec.log_rate, -start_s * fps)
        times = start_s + np.arange(count) / fps
        frame_truth = _frame_truth(camera, route, walkers, times)
        seen = np.flatnonzero(frame_truth.visible)
        tracks[name] = Track(
            seen.astype(np.int64), frame_truth.xy[seen, 0], frame_truth.xy[seen, 1], time_s=times[seen] - start_s
        )
        if directory is not None:
            Path(directory).mkdir(parents=True, exist_ok=True)
            path = Path(directory) / f"{name}.mp4"
            _render(path, camera, route, walkers, times, start_s, spec, rng)
            frame_truth.video = path
        truth[name] = frame_truth
    scene = Scene(
        trajectory=Trajectory(samples, xyz, spec.log_rate, 0.0),
        true_trajectory=Trajectory(samples, true_xyz, spec.log_rate, 0.0),
        cameras=cameras,
        true_cameras=cameras,
        tracks=tracks,
        lines=lines,
        n_frames=dict(zip(names, spec.n_frames)),
        noise={
            "distractors": spec.distractors,
            "log": spec.log_model(),
            "S_t_px": CENTROID_NOISE_PX,
            "sensor_noise": spec.noise,
            "crf": spec.crf,
        },
    )
    return CrowdScene(scene, truth)


@dataclass(frozen=True)
class UserInputs:
    """A crowd project's inputs as a user brings them, instead of the fixtures' exact poses and CSV log.

    gpx: the log as a GPX file (geodetic, at ORIGIN), its error model left undeclared (ingest suggests one);
    gcps: ground points per camera on its patch (0: camera.json with the true pose), their pixels clicked with
    ``gcp_noise_px`` of noise (std per axis), the camera's intrinsics given and ``gcp_sigma_m`` left at its default.
    """

    gpx: bool = True
    gcps: int = 6
    gcp_noise_px: float = 1.0


ORIGIN = Origin(46.5197, 6.6323, 380.0)
START_UTC = 1_750_000_000.0  # POSIX seconds of log sample 0


def write_crowd_project(
    directory: str | Path, spec: CrowdSpec = SMALL, inputs: UserInputs | None = None
) -> tuple[Path, CrowdScene]:
    """A raw project: per camera its video and camera.json, the target's trajectory CSV, truth.json.

    The cameras have no tracker table: the track stage's default (every
    mover, no init box) is what is exercised. ``inputs``: a GPX log and GCPs instead (UserInputs).
    """
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    crowd = make_crowd_scene(spec, directory)
    scene = crowd.scene
    if inputs is not None and inputs.gpx:
        write_gpx_log(directory / "target.gpx", scene.trajectory, ORIGIN, START_UTC)
        parts = [f'[target]\nlog = "target.gpx"\norigin = [{ORIGIN.lat}, {ORIGIN.lon}, {ORIGIN.alt}]\n']
    else:
        write_trajectory(scene.trajectory, directory / "trajectory.csv")
        parts = ['[target]\ntrajectory = "trajectory.csv"\n']
    surveyed = ground_gcps(scene, spec.seed, inputs) if inputs is not None and inputs.gcps else {}
    for name, camera in scene.cameras.items():
        entry = f'[[cameras]]\nname = "{name}"\nvideo = "{name}.mp4"\nfps = {camera.fps!r}\n'
        if name in surveyed:
            intrinsics = {k: v for k, v in camera.to_dict().items() if k not in ("R", "t")}
            (directory / f"{name}_intrinsics.json").write_text(json.dumps(intrinsics, indent=1) + "\n", "utf-8")
            _write_ground_gcps(directory / f"{name}_gcp.csv", *surveyed[name])
            entry += f'[cameras.calibration]\nintrinsics = "{name}_intrinsics.json"\ngcp = "{name}_gcp.csv"\n'
        else:
            write_camera(camera, directory / f"{name}.json")
            entry += f'camera = "{name}.json"\n'
        parts.append(entry)
    project = directory / "project.toml"
    project.write_text("\n".join(parts), encoding="utf-8")
    write_truth(scene, directory)
    return project, crowd


def ground_gcps(scene: Scene, seed: int, inputs: UserInputs) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per camera ``inputs.gcps`` points on the ground of its patch, spread over it: their world positions (G, 3)
    metres, exact (surveyed), and their clicked pixels (G, 2), the true projections plus ``inputs.gcp_noise_px`` of
    noise; the seed's own stream, so the scene stays that of the seed."""
    rng = np.random.default_rng([seed, 2])
    out = {}
    for name, camera in scene.cameras.items():
        w, h = camera.image_size
        points: list[np.ndarray] = []
        while len(points) < inputs.gcps:
            k = len(points)
            u = (k % 3 + rng.uniform(0.15, 0.85)) * w / 3
            v = h * (0.45 + 0.5 * (k // 3 % 2 + rng.uniform(0.1, 0.9)) / 2)  # the lower part: the ground
            ray = camera.R.T @ np.linalg.solve(camera.K, [u, v, 1.0])
            centre = -camera.R.T @ camera.t
            if ray[2] >= -1e-3:
                continue
            ground = centre - centre[2] / ray[2] * ray
            uv, valid = camera.project(ground[None])
            if valid[0] and camera.in_image(uv)[0]:
                points.append(ground)
        world = np.array(points)
        uv, _ = camera.project(world)
        out[name] = (world, uv + rng.normal(0.0, inputs.gcp_noise_px, uv.shape))
    return out


def _write_ground_gcps(path: Path, world: np.ndarray, uv: np.ndarray) -> None:
    """GCPs (world (G, 3) metres, pixels (G, 2)) as u,v,lat,lon,alt."""
    geo = enu_to_geodetic(world, ORIGIN)
    rows = ["name,u,v,lat,lon,alt"]
    rows += [
        f"P{i + 1},{p[0]:.2f},{p[1]:.2f},{lat:.8f},{lon:.8f},{alt:.3f}"
        for i, (p, (lat, lon, alt)) in enumerate(zip(uv, geo))
    ]
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")


class Route:
    """A path walked (or flown) at a constant speed: position (x, y, centre height) at time t (s).

    The path is the waypoints' polyline, cut into pieces of at most 1 m,
    with its corners rounded (Chaikin's corner cutting, four times): turns
    over about a metre that never swing outside the polyline. Waypoints
    (N, 2) are on the ground (the centre at half the walker's ``height``);
    waypoints (N, 3) give the centre's height themselves (a drone).
    """

    def __init__(self, waypoints: np.ndarray, speed: float, height: float):
        waypoints = np.asarray(waypoints, dtype=np.float64)
        pieces = [
            np.linspace(a, b, max(1, int(np.ceil(np.linalg.norm(b - a)))) + 1)[:-1]
            for a, b in zip(waypoints[:-1], waypoints[1:])
        ]
        points = np.vstack(pieces + [waypoints[-1:]])
        for _ in range(4):
            a, b = points[:-1], points[1:]
            cut = np.empty((2 * len(a), points.shape[1]))
            cut[0::2], cut[1::2] = 0.75 * a + 0.25 * b, 0.25 * a + 0.75 * b
            points = np.vstack([points[:1], cut, points[-1:]])
        self.arc = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))]
        self.points = points
        self.speed = speed
        self.height = height
        self.duration = self.arc[-1] / speed

    def ground(self, t: np.ndarray) -> np.ndarray:
        d = np.clip(np.asarray(t, dtype=np.float64) * self.speed, 0.0, self.arc[-1])
        return np.column_stack([np.interp(d, self.arc, self.points[:, 0]), np.interp(d, self.arc, self.points[:, 1])])

    def at(self, t: np.ndarray) -> np.ndarray:
        """Body centre (N, 3), metres."""
        g = self.ground(t)
        if self.points.shape[1] == 3:
            d = np.clip(np.asarray(t, dtype=np.float64) * self.speed, 0.0, self.arc[-1])
            return np.column_stack([g, np.interp(d, self.arc, self.points[:, 2])])
        return np.column_stack([g, np.full(len(g), self.height / 2)])


def _patch_point(rng, patch: tuple[_View, ...], near: np.ndarray | None = None) -> np.ndarray:
    """A random ground point (world) well inside every view of ``patch``; with ``near``, 3-6 m from it."""
    while True:
        if near is None:
            y = rng.uniform(NEAR_M + 0.5, FAR_M - 0.5)
            point = patch[0].to_world(np.array([rng.uniform(-1.0, 1.0) * min(PATCH_HALF_WIDTH_M, 0.45 * y), y]))
        else:
            heading = rng.uniform(0, 2 * math.pi)
            point = near + rng.uniform(3.0, 6.0) * np.array([math.cos(heading), math.sin(heading)])
        if all(view.sees(point) for view in patch):
            return point


def _out_of_view(rng, cameras: dict[str, Camera], middle: np.ndarray) -> np.ndarray:
    """A random ground point SHARED_AWAY_M or more from ``middle`` (world x, y) where no camera sees any of a standing
    walker."""
    for attempt in range(1000):
        heading = rng.uniform(0, 2 * math.pi)
        away = rng.uniform(SHARED_AWAY_M, SHARED_AWAY_M + 2.0 + attempt / 50)
        point = middle + away * np.array([math.cos(heading), math.sin(heading)])
        body = np.array([[*point, z] for z in (0.0, TARGET_HEIGHT_M / 2, TARGET_HEIGHT_M)])
        if not any(_in_image(camera, body).any() for camera in cameras.values()):
            return point
    raise AssertionError("crowd scene: no ground point near the patch is out of every view")


def _in_image(camera: Camera, points: np.ndarray) -> np.ndarray:
    """(N,) whether each world point (N, 3) projects inside the camera's image."""
    uv, valid = camera.project(points)
    return valid & camera.in_image(np.nan_to_num(uv, nan=-1e9))


def _target_route(
    rng, cameras: dict[str, Camera], patches: list[tuple[_View, ...]], duration_s: float, speed: float
) -> tuple[Route, list[list[tuple[float, float]]]]:
    """The target's waypoints: visits to each patch in turn (about VISIT_S seconds each; one patch seen by every
    camera: SHARED_VISIT_S), for ``duration_s`` in all.

    Between visits it leaves the view it is in (several patches: crossing
    the narrow gap between the views, or the ground below them; one: out
    of every view) and comes back to it a visit later. Returns the route
    and, per camera, the (start, end) times of the target's stays in its
    image.
    """
    shared = len(patches) == 1
    middle = patches[0][0].to_world(np.array([0.0, (NEAR_M + FAR_M) / 2]))
    start = _out_of_view(rng, cameras, middle) if shared else patches[0][0].to_world(np.array([0.0, 2.5]))
    points: list[np.ndarray] = [start]
    visit = 0
    while Route(np.array(points), speed, TARGET_HEIGHT_M).duration < duration_s + 2.0:
        patch = patches[visit % len(patches)]
        stay: list[np.ndarray] = [_patch_point(rng, patch)]
        length = 0.0  # walked inside the patch
        while length < speed * (SHARED_VISIT_S if shared else VISIT_S):
            nxt = _patch_point(rng, patch, stay[-1])
            length += float(np.linalg.norm(nxt - stay[-1]))
            stay.append(nxt)
        points += stay + ([_out_of_view(rng, cameras, middle)] if shared else [])
        visit += 1
    route = Route(np.array(points), speed, TARGET_HEIGHT_M)
    t = np.arange(0.0, route.duration, 0.1)
    stays = []
    for camera in cameras.values():
        seen = np.r_[False, _in_image(camera, route.at(t)), False].astype(int)
        edges = np.flatnonzero(np.diff(seen))
        stays.append([(t[a], t[b - 1]) for a, b in zip(edges[0::2], edges[1::2])])
    return route, stays


@dataclass(frozen=True)
class _Walker:
    """A distractor: straight walk from start (at t0) to end, at speed; height; grey level."""

    start: np.ndarray
    end: np.ndarray
    t0: float
    speed: float
    height: float
    grey: float

    def ground(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Ground positions (N, 2) at times t and whether the walker is on its way."""
        t = np.asarray(t, dtype=np.float64)
        length = float(np.linalg.norm(self.end - self.start))
        d = (t - self.t0) * self.speed
        on = (d >= 0) & (d <= length)
        frac = np.clip(d / length, 0.0, 1.0)[:, None]
        return self.start + frac * (self.end - self.start), on


def _distractors(
    rng,
    patch: tuple[_View, ...],
    route: Route,
    stays: list[tuple[float, float]],
    recording: tuple[float, float],
    count: int,
    speed: float,
) -> list[_Walker]:
    """About ``count`` walkers in view at any time, each crossing the target's route in the patch (in the frame of its
    first view)."""
    if count <= 0:
        return []
    span = recording[1] - recording[0]
    crossing_s = 2 * (PATCH_HALF_WIDTH_M + 4.0) / speed
    walkers = []
    for _ in range(int(math.ceil(count * (span + crossing_s) / crossing_s))):
        t_target = rng.uniform(*stays[rng.integers(len(stays))]) if stays else rng.uniform(*recording)
        point = route.ground(np.array([t_target]))[0]
        local = patch[0].to_local(point)
        if abs(local[0]) > 0.6 * local[1] or not NEAR_M <= local[1] <= FAR_M:
            point = _patch_point(rng, patch)
        if rng.random() < 0.5:
            t_cross = t_target + rng.uniform(-1.5, 1.5)  # at nearly the same time: occlusion or merged blobs
        else:
            t_cross = rng.uniform(recording[0] - crossing_s / 2, recording[1] + crossing_s / 2)
        heading = (
            patch[0].yaw + rng.uniform(-math.pi / 2.5, math.pi / 2.5) + rng.choice((0.0, math.pi))
        )  # mostly across the view
        direction = np.array([math.cos(heading), math.sin(heading)])
        half = PATCH_HALF_WIDTH_M + 5.0
        start, end = point - half * direction, point + half * direction
        v = speed * rng.uniform(0.85, 1.15)
        walkers.append(
            _Walker(start, end, t_cross - half / v, v, rng.uniform(1.6, 1.85), PERSON_GREY + rng.uniform(-8, 8))
        )
    return walkers


def _people(
    camera: Camera, route: Route, walkers: list[_Walker], t: float
) -> list[tuple[float, np.ndarray, float, float, bool]]:
    """People at time t, far to near: (depth, ground xy, height, grey, is_target)."""
    out = [(None, route.ground(np.array([t]))[0], route.height, PERSON_GREY, True)]
    for w in walkers:
        g, on = w.ground(np.array([t]))
        if on[0]:
            out.append((None, g[0], w.height, w.grey, False))
    rows = []
    for _, g, height, grey, is_target in out:
        depth = float((camera.R @ np.array([g[0], g[1], height / 2]) + camera.t)[2])
        rows.append((depth, g, height, grey, is_target))
    return sorted(rows, key=lambda r: -r[0])


def _silhouette(camera: Camera, ground: np.ndarray, height: float):
    """(centre uv, semi-axes (a, b), angle deg) of a person's image ellipse, or None when behind the camera."""
    pts = np.array([[ground[0], ground[1], 0.0], [ground[0], ground[1], height / 2], [ground[0], ground[1], height]])
    uv, valid = camera.project(pts)
    if not valid.all():
        return None
    axis = uv[2] - uv[0]
    b = float(np.linalg.norm(axis)) / 2
    depth = float((camera.R @ pts[1] + camera.t)[2])
    a = PERSON_WIDTH_M / 2 * camera.K[0, 0] / depth
    angle = math.degrees(math.atan2(axis[1], axis[0])) - 90.0
    return uv[1], (a, b), angle


def _frame_truth(camera: Camera, route: Route, walkers: list[_Walker], times: np.ndarray) -> CameraTruth:
    """Target centre per frame (NaN unless the whole body centre is inside), visibility and people counts."""
    w, h = camera.image_size
    xy = np.full((len(times), 2), np.nan)
    axes = np.full((len(times), 2), np.nan)
    angle = np.zeros(len(times))
    visible = np.zeros(len(times), bool)
    people = np.zeros(len(times), int)
    for k, t in enumerate(times):
        rows = _people(camera, route, walkers, t)
        masks: list = []
        for _depth, g, height, _, is_target in rows:
            shape = _silhouette(camera, g, height)
            if shape is None:
                masks.append(None)
                continue
            (cx, cy), (a, b), tilt = shape
            masks.append(shape)
            in_image = -a < cx < w + a and -b < cy < h + b
            people[k] += in_image
            if is_target and in_image:
                xy[k], axes[k], angle[k] = (cx, cy), (a, b), tilt
                visible[k] = 0 <= cx <= w - 1 and 0 <= cy <= h - 1
        if visible[k]:
            visible[k] = _unoccluded_share(rows, masks, (w, h)) >= 0.5
    return CameraTruth(xy, axes, angle, visible, people)


def _ellipse_patch(shape, size: tuple[int, int]) -> tuple[int, int, np.ndarray]:
    """(x0, y0, coverage) of an image ellipse: anti-aliased, sub-pixel placed, uint8 0-255, clipped to the image."""
    (cx, cy), (a, b), angle = shape
    reach = max(a, b) + 2
    x0, y0 = max(0, int(cx - reach)), max(0, int(cy - reach))
    x1, y1 = min(size[0], int(cx + reach) + 2), min(size[1], int(cy + reach) + 2)
    if x1 <= x0 or y1 <= y0:
        return x0, y0, np.zeros((0, 0), np.uint8)
    mask = np.zeros((y1 - y0, x1 - x0), np.uint8)
    scale = 1 << 4
    centre = (int(round((cx - x0) * scale)), int(round((cy - y0) * scale)))
    axes = (max(1, int(round(a * scale))), max(1, int(round(b * scale))))
    cv2.ellipse(mask, centre, axes, angle, 0, 360, 255, -1, cv2.LINE_AA, 4)
    return x0, y0, mask


def _unoccluded_share(rows, masks, size) -> float:
    """Share of the target's silhouette not covered by the people drawn after it (nearer)."""
    k = next(i for i, r in enumerate(rows) if r[4])
    if masks[k] is None:
        return 0.0
    x0, y0, own = _ellipse_patch(masks[k], size)
    own = own > 127
    total = int(own.sum())
    if total == 0:
        return 0.0
    covered = np.zeros_like(own)
    for shape in masks[k + 1 :]:
        if shape is None:
            continue
        u0, v0, other = _ellipse_patch(shape, size)
        ox0, oy0 = max(x0, u0), max(y0, v0)
        ox1, oy1 = min(x0 + own.shape[1], u0 + other.shape[1]), min(y0 + own.shape[0], v0 + other.shape[0])
        if ox1 > ox0 and oy1 > oy0:
            covered[oy0 - y0 : oy1 - y0, ox0 - x0 : ox1 - x0] |= other[oy0 - v0 : oy1 - v0, ox0 - u0 : ox1 - u0] > 127
    return float((own & ~covered).sum()) / total


def _lighting(rng, times: np.ndarray) -> np.ndarray:
    """Global gain per frame: flicker and a 20 % drop (a cloud) over 1.5 s at a random moment."""
    t = times - times[0]
    gain = 1.0 + 0.03 * np.sin(2 * np.pi * t / 3.7) + 0.01 * rng.standard_normal(len(t))
    at = rng.uniform(0.3, 0.7) * max(t[-1], 1.0)
    return gain * (1.0 - 0.2 * np.clip((t - at) / 1.5, 0.0, 1.0))


def _render(
    path: Path,
    camera: Camera,
    route: Route,
    walkers: list[_Walker],
    times: np.ndarray,
    start_s: float,
    spec: CrowdSpec,
    rng,
) -> None:
    """Write the camera's H.264 video: background, people far to near, lighting, noise."""
    w, h = camera.image_size
    assert camera.fps is not None, "the crowd's cameras have their frame rates"
    background = _background(rng, w, h)
    gains = _lighting(rng, times)
    with h264_writer(
        path, camera.fps, (w, h), {"crf": str(spec.crf), "preset": "veryfast", "g": "30", "threads": "1"}
    ) as write:  # one thread: the same bytes every run
        for k, t in enumerate(times):
            image = background.copy()
            for _, g, height, grey, _ in _people(camera, route, walkers, t):
                shape = _silhouette(camera, g, height)
                if shape is None:
                    continue
                x0, y0, patch = _ellipse_patch(shape, (w, h))
                region = image[y0 : y0 + patch.shape[0], x0 : x0 + patch.shape[1]]
                region += patch.astype(np.float32) / 255.0 * (grey - region)
            image = image * gains[k] + rng.normal(0.0, spec.noise, image.shape)
            grey_frame = np.clip(image, 0, 255).astype(np.uint8)
            write(av.VideoFrame.from_ndarray(cv2.cvtColor(grey_frame, cv2.COLOR_GRAY2BGR), format="bgr24"), t - start_s)


def true_track_inputs(scene: Scene, seed: int) -> dict[str, CameraInput]:
    """Each camera's true track of the target with the blob centroid's white noise (CENTROID_NOISE_PX per axis,
    pixels; the seed's own stream), its true pose and nominal fps: the sync's inputs without detection or
    calibration error."""
    rng = np.random.default_rng(100 + seed)
    inputs = {}
    for name, camera in scene.cameras.items():
        t = scene.tracks[name]
        noise = rng.normal(0.0, CENTROID_NOISE_PX, (2, len(t.frame)))
        inputs[name] = CameraInput(camera, Track(t.frame, t.x + noise[0], t.y + noise[1], time_s=t.time_s), camera.fps)
    return inputs
