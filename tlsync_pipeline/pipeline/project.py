"""The project file (TOML): what to synchronize and how, as typed, frozen configuration.

``load_project`` parses the file once into a ``Project``: its ``[target]``
(``TargetConfig``), each ``[[cameras]]`` table (``CameraConfig`` with its
``[cameras.tracker]`` and ``[cameras.calibration]``) and ``[sync]``
(``SyncParams``, sync/model/params.py). Each key is a dataclass field declared with
``key``: its converter (which checks the value) and its default, the one place
defaults live. Paths are absolute (relative to the project file in the file).
Unknown keys are errors with a "did you mean"; docs/project.md explains each
key.
"""

from __future__ import annotations

import difflib
import math
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any, TypeVar

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

import numpy as np

from calibration.choices import MAX_FRAMES, MAX_VIEW_ERROR, RANSAC_PX, parse_corners
from calibration.choices import MODELS as CALIBRATION_MODELS
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.geodesy import Origin
from tlsync_pipeline.ingest.formats import FORMATS
from tlsync_pipeline.ingest.params import IngestParams, RigidTransform
from tlsync_pipeline.ingest.recording_time import parse_utc, parse_utc_offset
from tlsync_pipeline.ingest.records import ALTITUDE_REFERENCES
from tlsync_pipeline.ingest.units import LENGTH_UNITS, TIME_UNITS, unit_scale
from tlsync_pipeline.outputs.choices import PROXY_POLICIES
from tlsync_pipeline.sync.model.choices import GCP_SIGMA_M, SCAN_MODES
from tlsync_pipeline.sync.model.log_model import AUTO, LogModelChoice
from tlsync_pipeline.sync.model.log_model import PRESETS as LOG_MODELS
from tlsync_pipeline.sync.model.methods import METHODS, params_from_table
from tlsync_pipeline.sync.model.params import SyncParams, parameter_fields
from trackers.choices import DEFAULT_KIND as DEFAULT_TRACKER_KIND
from trackers.choices import KINDS as TRACKER_KINDS

WORK_DIR_NAME = "work"
PROJECT_FILE_NAME = "project.toml"  # what a folder given as the project holds

Converter = Callable[[Any, Path], Any]
Config = TypeVar("Config")


def key(
    convert: Converter, default: Any = None, *, required: bool = False, factory: Callable[[], Any] | None = None
) -> Any:
    """A key of a table: its converter (raises ValueError naming what it expected) and default."""
    metadata = {"convert": convert, "required": required}
    if factory is not None:
        return field(default_factory=factory, metadata=metadata)
    return field(default=default, metadata=metadata)


def table(config: type) -> Any:
    """A sub-table (``[cameras.tracker]``) parsed into ``config``; absent: ``config``'s defaults."""
    return field(default_factory=config, metadata={"table": config})


# Converters: (value from TOML, project folder) -> typed value, ValueError when the value is wrong.


def _path(value: Any, root: Path) -> Path:
    if not isinstance(value, str) or not value:
        raise ValueError(f"expected a file path (string), got {value!r}")
    return (root / value).resolve()


_NAME_FORBIDDEN = '/\\:,*?"<>|'


def _name(value: Any, root: Path) -> str:
    """A camera name, used as a folder name in the work folder and in file names (cameras/<name>/, votes_<name>.png).

    Refused: names that would leave or scatter that folder ('.', '..', a leading
    dot, path separators), and characters some file systems or CSV headers reject.
    """
    expected = f"a name that does not start with '.', without spaces at its ends and without any of {_NAME_FORBIDDEN}"
    if not isinstance(value, str) or not value or value != value.strip():
        raise ValueError(f"expected {expected}, got {value!r}")
    if value.startswith(".") or any(c in _NAME_FORBIDDEN or not c.isprintable() for c in value):
        raise ValueError(
            f"{value!r} cannot be a camera name: it is used as a folder name in the work folder; expected {expected}"
        )
    return value


def _number(value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ValueError(f"expected a number, got {value!r}")
    return float(value)


def _choice(*options: str, what: str = "") -> Converter:
    """A converter accepting one of ``options``; the message suggests the closest."""

    def convert(value: Any, root: Path) -> str:
        if value not in options:
            raise ValueError(f"unknown {what} {value!r}{suggest(str(value), list(options))}")
        return value

    return convert


def _finite(value: Any, root: Path) -> float:
    return _number(value)


def _positive(value: Any, root: Path) -> float:
    number = _number(value)
    if number <= 0:
        raise ValueError(f"expected a positive number, got {value!r}")
    return number


def _probability(value: Any, root: Path) -> float:
    number = _number(value)
    if not 0 < number < 1:
        raise ValueError(f"expected a number strictly between 0 and 1, got {value!r}")
    return number


def _ratio(value: Any, root: Path) -> float:
    number = _number(value)
    if not 0 < number <= 1:
        raise ValueError(f"expected a number in (0, 1], got {value!r}")
    return number


def _non_negative(value: Any, root: Path) -> float:
    number = _number(value)
    if number < 0:
        raise ValueError(f"expected a number >= 0, got {value!r}")
    return number


def _boolean(value: Any, root: Path) -> bool:
    if not isinstance(value, bool):
        raise ValueError(f"expected true or false, got {value!r}")
    return value


def _integer(value: Any, root: Path) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise ValueError(f"expected an integer, got {value!r}")
    return value


def _count(value: Any, root: Path) -> int:
    if _integer(value, root) < 1:
        raise ValueError(f"expected a positive integer, got {value!r}")
    return value


def _frame_index(value: Any, root: Path) -> int:
    if _integer(value, root) < 0:
        raise ValueError(f"expected a 0-based frame index, got {value!r}")
    return value


def _text(value: Any, root: Path) -> str:
    if not isinstance(value, str) or not value:
        raise ValueError(f"expected a non-empty string, got {value!r}")
    return value


def _origin(value: Any, root: Path) -> Origin | str:
    if value in ("first", "gcps"):
        return value
    if not isinstance(value, list) or len(value) != 3:
        raise ValueError(f'expected "first", "gcps" or [lat, lon, alt] (degrees, degrees, metres), got {value!r}')
    return Origin(*(_number(v) for v in value))


def _glob(value: Any, root: Path) -> str:
    if not isinstance(value, str) or not value:
        raise ValueError(f'expected a file pattern (string, e.g. "boards/*.jpg"), got {value!r}')
    return str(root / value)


def _pattern(value: Any, root: Path) -> str:
    if not isinstance(value, str):
        raise ValueError(
            f'expected inner corners as "COLSxROWS" (e.g. "7x6" for a board of 8x7 squares), got {value!r}'
        )
    cols, rows = parse_corners(value)
    return f"{cols}x{rows}"


def _box(value: Any, root: Path) -> tuple[float, float, float, float]:
    if not isinstance(value, list) or len(value) != 4:
        raise ValueError(f"expected a box [x, y, w, h] in pixels (top-left corner and size), got {value!r}")
    x, y, w, h = (_number(v) for v in value)
    if w <= 0 or h <= 0:
        raise ValueError(f"box {value!r}: width and height must be positive")
    return x, y, w, h


def _time_unit(value: Any, root: Path) -> float:
    return unit_scale(value, TIME_UNITS, "seconds")


def _length_unit(value: Any, root: Path) -> float:
    return unit_scale(value, LENGTH_UNITS, "metres")


def _parameters(value: Any, root: Path) -> dict[str, float]:
    if not isinstance(value, dict):
        raise ValueError(f"expected a table of tracker parameters, got {value!r}")
    for number in value.values():
        _number(number)
    return dict(value)


@dataclass(frozen=True, eq=False)
class BoardPose:
    """A checkerboard at a known world pose: its photo, and board -> world rotation R (3x3) and
    translation t (metres).
    """

    image: Path
    R: np.ndarray
    t: np.ndarray


def _board_pose(value: Any, root: Path) -> BoardPose:
    if not isinstance(value, dict):
        raise ValueError(
            'expected a table {image = "board.jpg", R = [[...], [...], [...]] or rvec = [...], t = [x, y, z]}'
        )
    unknown = set(value) - {"image", "R", "rvec", "t"}
    if unknown:
        raise ValueError(f"unknown key(s) {', '.join(sorted(unknown))}; expected image, R or rvec, t")
    if "image" not in value or "t" not in value or ("R" in value) == ("rvec" in value):
        raise ValueError("needs image, t and one of R (3x3) or rvec (3)")
    try:
        t = np.asarray(value["t"], dtype=np.float64)
        rotation = np.asarray(value.get("R", value.get("rvec")), dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError("R, rvec and t must be numbers") from None
    if t.shape != (3,) or not np.all(np.isfinite(t)):
        raise ValueError(f"t: expected [x, y, z] metres, got {value['t']!r}")
    if "rvec" in value:
        if rotation.shape != (3,) or not np.all(np.isfinite(rotation)):
            raise ValueError(f"rvec: expected 3 numbers (Rodrigues vector, radians), got {value['rvec']!r}")
        from scipy.spatial.transform import Rotation  # only for a transform given as a rotation vector

        R = Rotation.from_rotvec(rotation).as_matrix()
    else:
        R = rotation
        if (
            R.shape != (3, 3)
            or not np.all(np.isfinite(R))
            or np.abs(R.T @ R - np.eye(3)).max() > 1e-3
            or np.linalg.det(R) < 0
        ):
            raise ValueError("R: expected a 3x3 rotation matrix (list of rows)")
    return BoardPose(_path(value["image"], root), R, t)


def _utc_offset(value: Any, root: Path) -> float:
    """Local time - UTC in seconds, from hours (2, -3.5) or "+02:00" / "-0330" / "Z"."""
    return parse_utc_offset(value)


def _recorded(value: Any, root: Path) -> str:
    """ "metadata", "off", or an ISO 8601 time with its zone (kept as written)."""
    if value in ("metadata", "off"):
        return value
    if not isinstance(value, str) or parse_utc(value) is None:
        raise ValueError(
            f'expected "metadata", "off" or an ISO 8601 time with its zone (e.g. "2026-03-01T13:00:05+01:00"), got '
            f"{value!r}"
        )
    return value


def _rigid_transform(value: Any, root: Path) -> RigidTransform:
    if not isinstance(value, dict) or not set(value) <= {"R", "yaw_deg", "t"} or ("R" in value and "yaw_deg" in value):
        raise ValueError(f"expected {{R = 3x3 rotation or yaw_deg = degrees, t = [x, y, z] metres}}, got {value!r}")
    t = value.get("t", [0.0, 0.0, 0.0])
    if not isinstance(t, list) or len(t) != 3:
        raise ValueError(f"t: expected [x, y, z] metres, got {t!r}")
    t = [_number(v) for v in t]
    if "yaw_deg" in value:
        return RigidTransform.from_yaw(_number(value["yaw_deg"]), t)
    R = value.get("R", [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    if not isinstance(R, list) or len(R) != 3 or not all(isinstance(r, list) and len(r) == 3 for r in R):
        raise ValueError(f"R: expected a 3x3 rotation (list of 3 rows), got {R!r}")
    return RigidTransform(np.array([[_number(v) for v in r] for r in R]), np.array(t))


@dataclass(frozen=True)
class TargetConfig:
    """[target]: the target's trajectory CSV, or its raw log and how the ingest stage reads it (docs/ingest.md).

    origin: the ENU origin shared by the log and geodetic GCPs (an Origin, "first",
    "gcps", or None: see pipeline/origin.py); time_unit, length_unit: seconds and
    metres per unit of the log's (or the trajectory's) times and positions
    (ingest/units.py). The other keys are IngestParams'.
    """

    trajectory: Path | None = key(_path)
    origin: Origin | str | None = key(_origin)
    log: Path | None = key(_path)
    format: str = key(_choice("auto", *FORMATS, what="log format"), "auto")
    topic: str | None = key(_text)
    rate: float | None = key(_positive, IngestParams.rate)
    max_gap_s: float | None = key(_positive, IngestParams.max_gap_s)
    max_speed_mps: float | None = key(_positive, IngestParams.max_speed_mps)
    smoothing_s: float = key(_non_negative, IngestParams.smoothing_s)
    odometry_transform: RigidTransform | None = key(_rigid_transform, IngestParams.transform)
    altitude_reference: str | None = key(
        _choice(*ALTITUDE_REFERENCES, what="altitude reference"), IngestParams.altitude_reference
    )
    altitude_offset_m: float = key(_finite, IngestParams.altitude_offset_m)
    utc_offset: float | None = key(
        _utc_offset
    )  # s: local - UTC of a log whose clock is local (DJI SRT, the DJI app's CSV)
    log_model: str = key(
        _choice(AUTO, *LOG_MODELS, what="log model"), AUTO
    )  # the log's error model (sync/model/log_model.py)
    white_sigma_m: float | None = key(_non_negative)
    bias_sigma_m: float | None = key(_non_negative)
    bias_tau_s: float | None = key(_positive)

    time_unit: float = key(_time_unit, IngestParams.time_unit)
    length_unit: float = key(_length_unit, IngestParams.length_unit)

    @property
    def log_error(self) -> LogModelChoice:
        """The log's error model as [target] chooses it: a preset or "auto", and overrides."""
        return LogModelChoice(self.log_model, self.white_sigma_m, self.bias_sigma_m, self.bias_tau_s)

    @property
    def converts_trajectory(self) -> bool:
        """Whether the trajectory the project brings is not in seconds and metres: the ingest stage converts it."""
        return self.trajectory is not None and (self.time_unit != 1.0 or self.length_unit != 1.0)

    def ingest_params(self, origin: Origin | str) -> IngestParams:
        """The ingest's parameters, with the ENU origin resolved (pipeline/origin.py)."""
        return IngestParams(
            origin=origin,
            rate=self.rate,
            max_gap_s=self.max_gap_s,
            max_speed_mps=self.max_speed_mps,
            smoothing_s=self.smoothing_s,
            transform=self.odometry_transform,
            altitude_reference=self.altitude_reference,
            altitude_offset_m=self.altitude_offset_m,
            time_unit=self.time_unit,
            length_unit=self.length_unit,
        )


@dataclass(frozen=True)
class TrackerConfig:
    """[cameras.tracker]: how the track stage follows the target (docs/tracking.md).

    kind: "blob" (every mover; identify then picks the target) or "csrt";
    init: box [x, y, w, h] pixels in frame init_frame (0-based): CSRT starts
    there, for blob it seeds the identity; parameters: the tracker's by name.
    """

    kind: str = key(_choice(*TRACKER_KINDS, what="tracker kind"), DEFAULT_TRACKER_KIND)
    init: tuple[float, float, float, float] | None = key(_box)
    init_frame: int = key(_frame_index, 0)
    parameters: Mapping[str, float] = key(_parameters, factory=dict)

    @property
    def every_mover(self) -> bool:
        """Whether the track stage detects every mover (blob) rather than following one target (CSRT)."""
        return self.kind == "blob"


@dataclass(frozen=True)
class CalibrationConfig:
    """[cameras.calibration]: where the calibrate stages take the camera's intrinsics and pose from
    (docs/calibration.md).
    """

    images: str | None = key(_glob)
    video: Path | None = key(_path)
    intrinsics: Path | None = key(_path)
    pattern: str | None = key(_pattern)
    square: float | None = key(_positive)
    model: str = key(_choice(*CALIBRATION_MODELS, what="model"), CALIBRATION_MODELS[0])
    gcp: Path | None = key(_path)
    board_pose: BoardPose | None = key(_board_pose)
    max_frames: int = key(_count, MAX_FRAMES)
    max_view_error: float = key(_positive, MAX_VIEW_ERROR)
    ransac_px: float = key(_positive, RANSAC_PX)
    gcp_sigma_m: float | None = key(_non_negative)

    @property
    def board_views(self) -> bool:
        """Whether the intrinsics come from checkerboard views (photos or a video) the intrinsics
        stage calibrates from.
        """
        return self.images is not None or self.video is not None

    @property
    def given(self) -> bool:
        """Whether the table says anything to calibrate from."""
        return self.board_views or any(v is not None for v in (self.intrinsics, self.gcp, self.board_pose))


@dataclass(frozen=True)
class ProjectCalibration:
    """[calibration]: what holds for every camera's calibration unless its [cameras.calibration] says otherwise.

    gcp_sigma_m: how good the GCPs' survey is (metres per coordinate, one
    sigma): the target refines the GCPs' pose with them as a prior; 0: the
    GCPs are exact and give the pose alone (docs/calibration.md).
    """

    gcp_sigma_m: float = key(_non_negative, GCP_SIGMA_M)


@dataclass(frozen=True)
class ClockConfig:
    """[cameras.clock]: the camera's own clock as a check on its offset (docs/algorithm.md, docs/ingest.md).

    recorded: "metadata" (the video's trusted recording time: GoPro GPS, a DJI
    subtitle file on UTC, a phone's QuickTime creationdate), "off", or the UTC
    of the video's time 0 as an ISO 8601 time with its zone; tolerance_s: how
    far that may be off (s; None: the source's own), which also lets an
    untrusted source (MP4 creation_time) be used; utc_offset: local - UTC (s)
    of a DJI subtitle file beside the video.
    """

    recorded: str = key(_recorded, "metadata")
    tolerance_s: float | None = key(_positive)
    utc_offset: float | None = key(_utc_offset)


@dataclass(frozen=True)
class CameraConfig:
    """One [[cameras]] table: the files the camera brings (absolute paths) and how to make the others."""

    name: str = key(_name, "", required=True)
    camera: Path | None = key(_path)
    track: Path | None = key(_path)
    detections: Path | None = key(_path)
    fps: float | None = key(_positive)
    pick_start_s: float | None = key(
        _finite
    )  # the line picked where two remain: the log's time (s after its first fix) at the first frame
    video: Path | None = key(_path)
    proxy: str = key(_choice(*PROXY_POLICIES, what="proxy policy"), PROXY_POLICIES[0])
    tracker: TrackerConfig = table(TrackerConfig)
    calibration: CalibrationConfig = table(CalibrationConfig)
    clock: ClockConfig = table(ClockConfig)

    @property
    def tracked(self) -> bool:
        """Whether the track stage runs: a video and no track of the user's."""
        return self.track is None and self.video is not None

    @property
    def brings_movers(self) -> bool:
        """Whether the target is identified among every mover: detections brought, or detected in the video (blob)."""
        return self.track is None and (
            self.detections is not None or (self.video is not None and self.tracker.every_mover)
        )


@dataclass(frozen=True)
class TrackConfig:
    """[track]: how the track stage reads every camera's video (docs/tracking.md).

    scan: "auto" (a coarse pass over the keyframes of each camera whose every
    mover is detected in its video; every frame is then read only in the
    windows where it puts the target in view, sync/identify/scan.py) or "full"
    (every frame of every video).
    """

    scan: str = key(_choice(*SCAN_MODES, what="scan mode"), SCAN_MODES[0])


@dataclass(frozen=True)
class Project:
    """A validated project: its file, [target], the cameras in file order (the first is the reference), [sync],
    [calibration], [track].
    """

    path: Path
    target: TargetConfig
    cameras: tuple[CameraConfig, ...]
    sync: SyncParams
    calibration: ProjectCalibration = field(default_factory=ProjectCalibration)
    track: TrackConfig = field(default_factory=TrackConfig)

    @property
    def root(self) -> Path:
        return self.path.parent

    @property
    def default_work_dir(self) -> Path:
        return self.root / WORK_DIR_NAME

    @property
    def names(self) -> list[str]:
        return [c.name for c in self.cameras]

    def camera(self, name: str) -> CameraConfig:
        """The camera named ``name``; InputError listing the names otherwise."""
        for cam in self.cameras:
            if cam.name == name:
                return cam
        raise InputError(
            f"{self.path}: no camera named {name!r}{suggest(name, self.names)}; cameras: {', '.join(self.names)}"
        )


# Converters of the checks that sync parameters declare (sync/model/params.py).
_CHECKS: dict[str, Converter] = {
    "positive": _positive,
    "probability": _probability,
    "ratio": _ratio,
    "non_negative": _non_negative,
    "finite": _finite,
    "integer": _integer,
    "boolean": _boolean,
}


def sync_keys() -> dict[str, Converter]:
    """The [sync] table's keys and their converters: the shared parameters, ``method`` and every registered method's
    own.
    """
    keys = {name: _CHECKS[check] for name, (_, check) in parameter_fields(SyncParams).items()}
    keys["method"] = _choice(*METHODS, what="sync method")
    for method in METHODS.values():
        keys.update({name: _CHECKS[check] for name, (_, check) in parameter_fields(method.params_type).items()})
    return keys


def project_file(path: str | Path) -> Path:
    """``path`` itself, or for a folder the project.toml it holds; InputError naming what the folder holds otherwise."""
    path = Path(path)
    if not path.is_dir():
        return path
    if (path / PROJECT_FILE_NAME).is_file():
        return path / PROJECT_FILE_NAME
    others = sorted(p.name for p in path.glob("*.toml") if p.is_file())
    hint = (
        f"give the project file, e.g. {path / others[0]}"
        if others
        else "give the project file, or the folder that holds it"
    )
    raise InputError(f"{path}: no {PROJECT_FILE_NAME} in this folder; {hint}")


def load_project(path: str | Path) -> Project:
    """Read and validate a project file (or the project.toml of a folder); InputError naming the file, the table and the
    key otherwise.
    """
    path = project_file(path).resolve()
    try:
        raw = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(f"{path}: file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path}: invalid TOML: {exc}") from None
    _check_keys(raw, ["target", "cameras", "track", "sync", "calibration"], path, "top level")
    target = parse_config(TargetConfig, raw.get("target", {}), path, "target")
    items = raw.get("cameras", [])
    if not isinstance(items, list):
        raise InputError(f"{path}: cameras: expected an array of tables [[cameras]]")
    cameras = tuple(parse_config(CameraConfig, item, path, f"cameras #{i + 1}") for i, item in enumerate(items))
    if not cameras:
        raise InputError(f"{path}: no [[cameras]] table; a project needs at least one camera")
    _check_unique_names(cameras, path)
    calibration = parse_config(ProjectCalibration, raw.get("calibration", {}), path, "calibration")
    track = parse_config(TrackConfig, raw.get("track", {}), path, "track")
    return Project(path, target, cameras, _parse_sync(raw.get("sync", {}), path), calibration, track)


def parse_config(config: type[Config], raw: Any, path: Path, where: str) -> Config:
    """One TOML table parsed into the dataclass ``config`` (fields declared with ``key`` or ``table``); missing keys
    take their defaults.
    """
    _check_keys(raw, [f.name for f in fields(config)], path, f"[{where}]")  # type: ignore[arg-type]
    values: dict[str, Any] = {}
    for item in fields(config):  # type: ignore[arg-type]
        sub = f"{where}.{item.name}"
        if "table" in item.metadata:
            values[item.name] = parse_config(item.metadata["table"], raw.get(item.name, {}), path, sub)
        elif item.name in raw:
            try:
                values[item.name] = item.metadata["convert"](raw[item.name], path.parent)
            except ValueError as exc:
                raise InputError(f"{path}: [{where}]: key {item.name!r}: {exc}") from None
        elif item.metadata.get("required"):
            raise InputError(f"{path}: [{where}]: missing required key {item.name!r}")
    return config(**values)


def _parse_sync(raw: Any, path: Path) -> SyncParams:
    keys = sync_keys()
    _check_keys(raw, list(keys), path, "[sync]")
    values = {}
    for name, value in raw.items():
        try:
            values[name] = keys[name](value, path.parent)
        except ValueError as exc:
            raise InputError(f"{path}: [sync]: key {name!r}: {exc}") from None
    return params_from_table(values)


def _check_keys(raw: Any, known: list[str], path: Path, label: str) -> None:
    if not isinstance(raw, dict):
        raise InputError(f"{path}: {label}: expected a table, got {type(raw).__name__}")
    for name in raw:
        if name not in known:
            raise InputError(f"{path}: {label}: unknown key {name!r}{suggest(name, known)}")


def _check_unique_names(cameras: tuple[CameraConfig, ...], path: Path) -> None:
    seen: dict[str, str] = {}
    for cam in cameras:
        folded = cam.name.casefold()
        if folded in seen:
            same = "" if seen[folded] == cam.name else f" (same as {seen[folded]!r} on file systems that ignore case)"
            raise InputError(f"{path}: [[cameras]]: duplicate camera name {cam.name!r}{same}; names must be unique")
        seen[folded] = cam.name


def suggest(word: str, choices: list[str]) -> str:
    """' (did you mean X?)' for the closest of ``choices``, else the list of them."""
    close = difflib.get_close_matches(word, choices, n=1)
    return f" (did you mean {close[0]!r}?)" if close else f" (expected one of: {', '.join(choices)})"
