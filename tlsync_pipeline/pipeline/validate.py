"""Every input of a project checked before any stage runs, in seconds: a bad one is named by its key.

For each file the project names ([target] trajectory or log, and per camera
camera, track, detections, video and the [cameras.calibration] files):
it exists, is a regular file of bounded size (not a device, a pipe or a
file of the system), is readable, and holds what its key expects, found
without doing the work: tables and camera files are read (small), logs
and detections are sniffed from their first bytes, videos are probed
(the container's metadata, no decoding). Then the files against each other:
a track's frames within its video and its positions within the camera's
image, the camera's image_size the video's size, a trajectory that moves
like a target in seconds and metres, and no file given for two cameras.
The error names the camera and the key (the project file is the command's),
then the file's own message (its line, field or frame).
"""

from __future__ import annotations

import glob
import hashlib
from collections.abc import Callable
from pathlib import Path

import numpy as np

from calibration.camera import Camera, read_camera
from calibration.extrinsics import read_gcps
from tlsync_pipeline.errors import INPUT_ERRORS, InputError
from tlsync_pipeline.ingest.detect import detect_format
from tlsync_pipeline.ingest.units import implausible_motion
from tlsync_pipeline.inputs import MAX_SMALL_BYTES, MAX_TEXT_BYTES, read_text_file, regular_file
from tlsync_pipeline.pipeline.checks import check_track_fits_video
from tlsync_pipeline.pipeline.project import CameraConfig, Project
from tlsync_pipeline.trajectory import read_trajectory, stranded
from trackers.detections import REQUIRED_COLUMNS as DETECTION_COLUMNS
from trackers.track import Track, read_track
from trackers.video import VideoInfo, probe_video

HEAD_BYTES = 64 << 10  # bytes read to sniff a large table
OUTSIDE_SHARE = 0.05  # a track with more than this share of its positions outside the image is of another image
STRANDED_SAMPLES = 10  # a trajectory with more samples in a row between gaps (runs too short to interpolate) is refused
SAME_BYTES = 1 << 20  # bytes hashed at each end of two videos of the same size to call them the same file


def validate_project(project: Project, used: set[Path] | None = None) -> None:
    """Check the files the project names (see the module doc); InputError naming the key of the first bad one.

    used: the project's files the tasks about to run read (None: every file);
    the others are left for the run that needs them. No file may serve two
    cameras, whatever runs.
    """
    _same_files(project)
    wanted = (lambda path: True) if used is None else (lambda path: path in used)
    target = project.target
    if target.trajectory is not None and wanted(target.trajectory):
        _checked(
            project,
            "[target]",
            "trajectory",
            target.trajectory,
            lambda path: _trajectory(path, target.time_unit, target.length_unit),
        )
    if target.log is not None and wanted(target.log):
        _checked(project, "[target]", "log", target.log, lambda path: _log(path, target.format))
    for camera in project.cameras:
        _camera(project, camera, wanted)


def _checked(project: Project, where: str, key: str, path: Path, check: Callable[[Path], object]) -> object:
    """check(path), its errors prefixed with the project key: ``[[cameras]] 'cam1' video: FILE: why``."""
    try:
        return check(path)
    except INPUT_ERRORS as exc:
        text = str(exc)
        raise InputError(f"{where} {key}: " + (text if text.startswith(str(path)) else f"{path}: {text}")) from None


def _relative(project: Project, path: Path) -> str:
    """The path as the project file would write it: relative inside the project's folder, absolute outside it."""
    return path.relative_to(project.root).as_posix() if path.is_relative_to(project.root) else str(path)


def _camera(project: Project, config: CameraConfig, wanted: Callable[[Path], bool]) -> None:
    """One camera's files that the run reads, each alone, then against each other (a track against its video and its
    camera).
    """
    where = f"[[cameras]] {config.name!r}"
    calibration = config.calibration
    video: VideoInfo | None = None
    track_used = config.track is not None and wanted(config.track)
    if config.video is not None and (wanted(config.video) or track_used):
        video = _checked(project, where, "video", config.video, probe_video)  # type: ignore[assignment]
    camera: Camera | None = None
    if config.camera is not None and (wanted(config.camera) or track_used):
        camera = _checked(
            project,
            where,
            "camera",
            config.camera,
            lambda path: read_camera(regular_file(path, MAX_SMALL_BYTES, "camera.json"), name=config.name),
        )  # type: ignore[assignment]
        if video is not None:
            _checked(project, where, "camera", config.camera, lambda path: _image_of_video(path, camera, video))  # type: ignore[arg-type]
    if config.track is not None and track_used:
        track = _checked(
            project,
            where,
            "track",
            config.track,
            lambda path: read_track(regular_file(path, MAX_TEXT_BYTES, "track CSV")),
        )
        if video is not None:
            _checked(project, where, "track", config.track, lambda path: check_track_fits_video(path, video))
        size = (
            tuple(camera.image_size)
            if camera is not None
            else (video.width, video.height)
            if video is not None
            else None
        )
        if size is not None:
            _checked(project, where, "track", config.track, lambda path: _track_not_normalised(path, track, size))  # type: ignore[arg-type]
        if camera is not None:
            _checked(project, where, "track", config.track, lambda path: _track_in_image(path, track, camera))  # type: ignore[arg-type]
    if config.detections is not None and wanted(config.detections):
        _checked(
            project,
            where,
            "detections",
            config.detections,
            lambda path: _table_head(path, DETECTION_COLUMNS, "detections CSV"),
        )
    if video is not None and config.video is not None and config.camera is None and wanted(config.video):
        _checked(project, where, "video", config.video, lambda path: _video_of_calibration(path, video, config))
    table = f"{where} [cameras.calibration]"
    if calibration.images is not None:
        images = [Path(name) for name in sorted(glob.glob(calibration.images))]
        for image in (image for image in images if wanted(image)):
            _checked(project, table, "images", image, lambda path: regular_file(path, what="checkerboard photo"))
    if calibration.video is not None and wanted(calibration.video):
        _checked(project, table, "video", calibration.video, probe_video)
    if calibration.intrinsics is not None and wanted(calibration.intrinsics):
        _checked(
            project,
            table,
            "intrinsics",
            calibration.intrinsics,
            lambda path: read_text_file(path, MAX_SMALL_BYTES, "intrinsics JSON"),
        )
    if calibration.gcp is not None and wanted(calibration.gcp):
        _checked(
            project,
            table,
            "gcp",
            calibration.gcp,
            lambda path: read_gcps(regular_file(path, MAX_SMALL_BYTES, "GCP CSV")),
        )
    if calibration.board_pose is not None and wanted(calibration.board_pose.image):
        _checked(
            project,
            table,
            "board_pose.image",
            calibration.board_pose.image,
            lambda path: regular_file(path, what="board image"),
        )


def _trajectory(path: Path, time_unit: float, length_unit: float) -> None:
    """The trajectory CSV, read; InputError when, in seconds and metres, it cannot be a target's."""
    trajectory = read_trajectory(path)
    _not_degrees(trajectory.xyz)
    lost = stranded(trajectory)
    if lost > STRANDED_SAMPLES:
        raise InputError(
            f"{path}: {lost} samples in a row sit between gaps on the grid of {trajectory.rate or 1:g} Hz (their "
            f"times are not on "
            "the log's rate), and the sync would not use them; resample it onto one rate (give it as [target] log, "
            "with max_gap_s above its longest interval)"
        )
    t = trajectory.seconds(trajectory.sample)
    if t is not None:
        problem = implausible_motion(np.asarray(t) * time_unit, trajectory.xyz * length_unit)
        if problem:
            raise InputError(f"{path}: {problem}")


def _not_degrees(xyz: np.ndarray) -> None:
    """InputError when a local trajectory's x, y are longitudes and latitudes: values of degrees away from the origin
    that span less than a kilometre's worth of a degree (0.01) where metres would move metres."""
    x, y = xyz[:, 0], xyz[:, 1]
    span = np.ptp(xyz[:, :2], axis=0) if len(xyz) else np.zeros(2)
    lon_lat = np.abs(x).max() <= 180 and np.abs(y).max() <= 90
    lat_lon = np.abs(x).max() <= 90 and np.abs(y).max() <= 180
    if (
        len(xyz) >= 2
        and (lon_lat or lat_lon)
        and min(np.abs(x).min(), np.abs(y).min()) >= 1.0
        and 0 < span.max() < 0.01
    ):
        raise InputError(
            f"columns x, y look like {'longitude and latitude' if lon_lat else 'latitude and longitude'} in degrees "
            f"(x {x[0]:.6g}, y {y[0]:.6g}, "
            f"spanning {span[0]:.2g} x {span[1]:.2g}), not metres: give the log as time,lat,lon,alt in [target] log "
            f"(it is then ingested), not as [target] trajectory"
        )


def _log(path: Path, fmt: str) -> None:
    """A log file (or a ROS 2 bag folder) whose format is known or detected from its first bytes."""
    if not path.is_dir():
        regular_file(path, what="log")
    if fmt == "auto":
        detect_format(path)


def _table_head(path: Path, required: tuple[str, ...], what: str) -> None:
    """A large CSV table sniffed: a regular text file of bounded size whose header names the required columns."""
    regular_file(path, MAX_TEXT_BYTES, what)
    with path.open("rb") as handle:
        head = handle.read(HEAD_BYTES)
    if b"\x00" in head:
        raise InputError(f"{path}: not a text file (it holds NUL bytes), expected a {what}")
    header = [c.strip() for c in head.decode("utf-8", errors="replace").split("\n", 1)[0].split(",")]
    missing = [c for c in required if c not in header]
    if missing:
        raise InputError(
            f"{path}:1: the header lacks column(s) {', '.join(missing)}; expected a {what} with {','.join(required)}"
        )


def _image_of_video(path: Path, camera: Camera, video: VideoInfo) -> None:
    """The camera's image_size is its video's frame size."""
    if (video.width, video.height) != tuple(camera.image_size):
        raise InputError(
            f"{path}: image_size {list(camera.image_size)} but the camera's video {video.path.name} is {video.width} "
            f"x {video.height}; "
            "give the calibration of the video's resolution (or scale K and image_size to it)"
        )


def _video_of_calibration(path: Path, video: VideoInfo, config: CameraConfig) -> None:
    """The camera's video has the size of the images its intrinsics come from ([cameras.calibration] intrinsics,
    checkerboard video or the first checkerboard photo): a downscaled copy of the video would be calibrated at the
    wrong scale, every pose fit then failing for no visible reason."""
    calibration = config.calibration
    size, source = None, ""
    if calibration.intrinsics is not None and calibration.intrinsics.is_file():
        size, source = tuple(read_camera(calibration.intrinsics).image_size), "the intrinsics"
    elif calibration.video is not None and calibration.video.is_file():
        info = probe_video(calibration.video)
        size, source = (info.width, info.height), "the checkerboard video"
    elif calibration.images is not None:
        import cv2  # noqa: PLC0415 - OpenCV only for a project that calibrates from photos

        first = next(iter(sorted(glob.glob(calibration.images))), None)
        image = None if first is None else cv2.imread(first, cv2.IMREAD_UNCHANGED)
        size, source = (None, "") if image is None else ((image.shape[1], image.shape[0]), "the checkerboard photos")
    if size is None or (video.width, video.height) == size:
        return
    ratio = video.width / size[0]
    scale = (
        f" ({ratio:.3g} of their size: a downscaled copy?)"
        if abs(video.height / size[1] - ratio) < 0.01 * ratio
        else ""
    )
    raise InputError(
        f"{path}: {video.width} x {video.height}, but {source} are of {size[0]} x {size[1]} images{scale}; "
        "give the original video, or calibrate with images of the video's resolution"
    )


def _track_not_normalised(path: Path, track: Track, size: tuple[int, int]) -> None:
    """The track's positions are pixels, not fractions of the image (every x, y within 0..1 of an image wider than
    that).
    """
    xy = track.xy
    if len(xy) >= 2 and min(size) > 4 and xy.min() >= 0.0 and xy.max() <= 1.0 and np.ptp(xy, axis=0).max() > 0:
        w, h = size
        raise InputError(
            f"{path}: every x, y lies within 0..1: normalised coordinates? give pixels of the {w} x {h} image (x * "
            f"{w}, y * {h})"
        )


def _track_in_image(path: Path, track: Track, camera: Camera) -> None:
    """The track's positions lie inside the camera's image (a few strays allowed)."""
    w, h = camera.image_size
    xy = track.xy
    outside = (xy[:, 0] < -0.5) | (xy[:, 0] > w - 0.5) | (xy[:, 1] < -0.5) | (xy[:, 1] > h - 0.5)
    if outside.mean() > OUTSIDE_SHARE:
        k = int(np.argmax(outside))
        raise InputError(
            f"{path}: {outside.mean():.0%} of its positions lie outside the camera's {w} x {h} image (frame "
            f"{track.frame[k]}: {xy[k, 0]:.0f}, {xy[k, 1]:.0f}): "
            "a track of another resolution, or another camera's camera.json?"
        )


def _same_files(project: Project) -> None:
    """No video, track, detections or camera file given for two cameras (the same path or the same content)."""
    for key in ("video", "track", "detections", "camera"):
        seen: dict[str, str] = {}
        for camera in project.cameras:
            path = getattr(camera, key)
            if path is None or not path.is_file():
                continue
            identity = _identity(path)
            if identity in seen:
                raise InputError(
                    f"[[cameras]] {camera.name!r} {key} ({_relative(project, path)}) is the same file as the {key} of "
                    f"camera {seen[identity]!r}: each camera needs its own"
                )
            seen[identity] = camera.name


def _identity(path: Path) -> str:
    """What makes two files the same: their size and the SHA-256 of their first and last SAME_BYTES."""
    size = path.stat().st_size
    digest = hashlib.sha256(str(size).encode())
    with path.open("rb") as handle:
        digest.update(handle.read(SAME_BYTES))
        if size > 2 * SAME_BYTES:
            handle.seek(size - SAME_BYTES)
        digest.update(handle.read(SAME_BYTES))
    return digest.hexdigest()
