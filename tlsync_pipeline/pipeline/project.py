"""The project file (TOML): what to synchronize and how.

Paths are relative to the project file. Unknown keys are errors with a
"did you mean". The schema below is the reference; docs/project.md explains
each key.
"""

from __future__ import annotations

import difflib
import inspect
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, NamedTuple

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

import numpy as np
from scipy.spatial.transform import Rotation

from calibration.extrinsics import pose_from_points
from calibration.intrinsics import MODELS as CALIBRATION_MODELS
from calibration.intrinsics import calibrate_video, parse_corners
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.geodesy import Origin
from tlsync_pipeline.ingest import ALTITUDE_REFERENCES, FORMATS
from tlsync_pipeline.ingest.process import IngestParams
from tlsync_pipeline.outputs.proxy import POLICIES as PROXY_POLICIES
from tlsync_pipeline.sync.params import SyncParams, parameter_fields
from tlsync_pipeline.sync.registry import METHODS, params_from_table
from tlsync_pipeline.sync.scan import SCAN_MODES
from trackers.tracking import KINDS as TRACKER_KINDS
from trackers.tracking import track_video

WORK_DIR_NAME = "work"


class Field(NamedTuple):
    """One key of a table: its converter (raises ValueError), default, and whether required."""

    convert: Callable[[Any, Path], Any]
    default: Any = None
    required: bool = False


def _default(function: Callable, parameter: str) -> Any:
    """The default value of a component's parameter: defaults are defined once, by the component."""
    return inspect.signature(function).parameters[parameter].default


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
        raise ValueError(f"{value!r} cannot be a camera name: it is used as a folder name in the work folder; expected {expected}")
    return value


def _number(value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ValueError(f"expected a number, got {value!r}")
    return float(value)


def _choice(*options: str, what: str = "") -> Callable[[Any, Path], str]:
    """A converter accepting one of ``options``; the message suggests the closest."""

    def convert(value: Any, root: Path) -> str:
        if value not in options:
            raise ValueError(f"unknown {what} {value!r}{_suggest(str(value), list(options))}")
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


def _origin(value: Any, root: Path) -> Origin | str:
    if value in ("first", "gcps"):
        return value
    if not isinstance(value, list) or len(value) != 3:
        raise ValueError(f'expected "first", "gcps" or [lat, lon, alt] (degrees, degrees, metres), got {value!r}')
    return Origin(*(_number(v) for v in value))


def _glob(value: Any, root: Path) -> str:
    if not isinstance(value, str) or not value:
        raise ValueError(f"expected a file pattern (string, e.g. \"boards/*.jpg\"), got {value!r}")
    return str(root / value)


def _pattern(value: Any, root: Path) -> str:
    if not isinstance(value, str):
        raise ValueError(f"expected inner corners as \"COLSxROWS\" (e.g. \"7x6\" for a board of 8x7 squares), got {value!r}")
    cols, rows = parse_corners(value)
    return f"{cols}x{rows}"


def _board_pose(value: Any, root: Path) -> dict:
    if not isinstance(value, dict):
        raise ValueError("expected a table {image = \"board.jpg\", R = [[...], [...], [...]] or rvec = [...], t = [x, y, z]}")
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
        R = Rotation.from_rotvec(rotation).as_matrix()
    else:
        R = rotation
        if R.shape != (3, 3) or not np.all(np.isfinite(R)) or np.abs(R.T @ R - np.eye(3)).max() > 1e-3 or np.linalg.det(R) < 0:
            raise ValueError("R: expected a 3x3 rotation matrix (list of rows)")
    return {"image": _path(value["image"], root), "R": R, "t": t}


def _count(value: Any, root: Path) -> int:
    if _integer(value, root) < 1:
        raise ValueError(f"expected a positive integer, got {value!r}")
    return value


TARGET_SCHEMA = {
    "trajectory": Field(_path),
    "origin": Field(_origin),
}


def _box(value: Any, root: Path) -> tuple[float, float, float, float]:
    if not isinstance(value, list) or len(value) != 4:
        raise ValueError(f"expected a box [x, y, w, h] in pixels (top-left corner and size), got {value!r}")
    box = tuple(_number(v) for v in value)
    if box[2] <= 0 or box[3] <= 0:
        raise ValueError(f"box {value!r}: width and height must be positive")
    return box


def _frame_index(value: Any, root: Path) -> int:
    if _integer(value, root) < 0:
        raise ValueError(f"expected a 0-based frame index, got {value!r}")
    return value


def _parameters(value: Any, root: Path) -> dict:
    if not isinstance(value, dict):
        raise ValueError(f"expected a table of tracker parameters, got {value!r}")
    for key, number in value.items():
        _number(number)
    return dict(value)


# [cameras.tracker]: how the track stage follows the target in the camera's video.
TRACKER_SCHEMA = {
    "kind": Field(_choice(*TRACKER_KINDS, what="tracker kind"), _default(track_video, "kind")),
    "init": Field(_box),
    "init_frame": Field(_frame_index, 0),
    "parameters": Field(_parameters, {}),
}


# [cameras.calibration]: how the calibrate stage makes this camera's camera.json.
CALIBRATION_SCHEMA = {
    "images": Field(_glob),
    "video": Field(_path),
    "intrinsics": Field(_path),
    "pattern": Field(_pattern),
    "square": Field(_positive),
    "model": Field(_choice(*CALIBRATION_MODELS, what="model"), CALIBRATION_MODELS[0]),
    "gcp": Field(_path),
    "board_pose": Field(_board_pose),
    "max_frames": Field(_count, _default(calibrate_video, "max_frames")),
    "max_view_error": Field(_positive, _default(calibrate_video, "max_view_error")),
    "ransac_px": Field(_positive, _default(pose_from_points, "ransac_px")),
}


def _text(value: Any, root: Path) -> str:
    if not isinstance(value, str) or not value:
        raise ValueError(f"expected a non-empty string, got {value!r}")
    return value


def _rigid_transform(value: Any, root: Path):
    from tlsync_pipeline.ingest.process import RigidTransform

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
    return RigidTransform([[_number(v) for v in r] for r in R], t)


# The ingest stage's keys ([target] log -> work/target/trajectory.csv); docs/ingest.md.
INGEST_SCHEMA = {
    "log": Field(_path),
    "format": Field(_choice("auto", *FORMATS, what="log format"), "auto"),
    "topic": Field(_text),
    "rate": Field(_positive),
    "max_gap_s": Field(_positive),
    "max_speed_mps": Field(_positive, IngestParams.max_speed_mps),
    "smoothing_s": Field(_non_negative, IngestParams.smoothing_s),
    "odometry_transform": Field(_rigid_transform),
    "altitude_reference": Field(_choice(*ALTITUDE_REFERENCES, what="altitude reference")),
    "altitude_offset_m": Field(_finite, IngestParams.altitude_offset_m),
}
TARGET_SCHEMA.update(INGEST_SCHEMA)
CAMERA_SCHEMA = {
    "name": Field(_name, required=True),
    "camera": Field(_path),
    "track": Field(_path),
    "detections": Field(_path),
    "fps": Field(_positive),
    "video": Field(_path),
    "proxy": Field(_choice(*PROXY_POLICIES, what="proxy policy"), PROXY_POLICIES[0]),
    "tracker": TRACKER_SCHEMA,
    "calibration": CALIBRATION_SCHEMA,
}
# Converters of the checks that sync parameters declare (sync/params.py).
_CHECKS = {
    "positive": _positive,
    "probability": _probability,
    "ratio": _ratio,
    "non_negative": _non_negative,
    "finite": _finite,
    "integer": _integer,
    "boolean": _boolean,
}


def sync_schema() -> dict[str, Field]:
    """The [sync] table's keys: the shared parameters, ``method`` (a registered method) and every method's own parameters."""
    schema = {name: Field(_CHECKS[check], default) for name, (default, check) in parameter_fields(SyncParams).items()}
    schema["method"] = Field(_choice(*METHODS, what="sync method"), SyncParams().method)
    for method in METHODS.values():
        schema.update({name: Field(_CHECKS[check], default) for name, (default, check) in parameter_fields(method.params_type).items()})
    return schema


# [track]: how the track stage reads each camera's video. scan: "auto" reads every frame only where a coarse pass over
# the keyframes puts the target in view (sync/scan.py), "full" every frame of the video.
TRACK_SCHEMA = {
    "scan": Field(_choice(*SCAN_MODES, what="scan mode"), SCAN_MODES[0]),
}


def project_schema() -> dict:
    """The whole project file's schema (the [sync] keys as registered now); a dict is a table, a one-element list an array of tables."""
    return {"target": TARGET_SCHEMA, "cameras": [CAMERA_SCHEMA], "track": TRACK_SCHEMA, "sync": sync_schema()}


@dataclass(frozen=True)
class Project:
    """A validated project: absolute paths, per-camera tables in file order."""

    path: Path
    target: dict
    cameras: list[dict]
    sync: SyncParams
    track: dict = field(default_factory=lambda: {"scan": SCAN_MODES[0]})

    @property
    def root(self) -> Path:
        return self.path.parent

    @property
    def default_work_dir(self) -> Path:
        return self.root / WORK_DIR_NAME

    def camera(self, name: str) -> dict:
        """The camera table named ``name``; InputError listing the names otherwise."""
        for cam in self.cameras:
            if cam["name"] == name:
                return cam
        names = ", ".join(c["name"] for c in self.cameras)
        raise InputError(f"{self.path}: no camera named {name!r}{_suggest(name, [c['name'] for c in self.cameras])}; cameras: {names}")


def load_project(path: str | Path) -> Project:
    """Read and validate a project file."""
    path = Path(path).resolve()
    try:
        raw = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(f"{path}: file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path}: invalid TOML: {exc}") from None
    data = parse_table(raw, project_schema(), path, "", path.parent)
    cameras = data["cameras"]
    if not cameras:
        raise InputError(f"{path}: no [[cameras]] table; a project needs at least one camera")
    seen: dict[str, str] = {}
    for cam in cameras:
        folded = cam["name"].casefold()
        if folded in seen:
            same = "" if seen[folded] == cam["name"] else f" (same as {seen[folded]!r} on file systems that ignore case)"
            raise InputError(f"{path}: [[cameras]]: duplicate camera name {cam['name']!r}{same}; names must be unique")
        seen[folded] = cam["name"]
    return Project(path, data["target"], cameras, params_from_table(data["sync"]), data["track"])


def parse_table(raw: Any, schema: dict, path: Path, where: str, root: Path) -> dict:
    """Validate one TOML table against a schema; missing optional keys get defaults."""
    label = f"[{where}]" if where else "top level"
    if not isinstance(raw, dict):
        raise InputError(f"{path}: {label}: expected a table, got {type(raw).__name__}")
    for key in raw:
        if key not in schema:
            raise InputError(f"{path}: {label}: unknown key {key!r}{_suggest(key, list(schema))}")
    out: dict[str, Any] = {}
    for key, spec in schema.items():
        sub = f"{where}.{key}" if where else key
        if isinstance(spec, dict):
            out[key] = parse_table(raw.get(key, {}), spec, path, sub, root)
        elif isinstance(spec, list):
            items = raw.get(key, [])
            if not isinstance(items, list):
                raise InputError(f"{path}: {key}: expected an array of tables [[{sub}]]")
            out[key] = [parse_table(item, spec[0], path, f"{sub} #{i + 1}", root) for i, item in enumerate(items)]
        elif key in raw:
            try:
                out[key] = spec.convert(raw[key], root)
            except ValueError as exc:
                raise InputError(f"{path}: {label}: key {key!r}: {exc}") from None
        elif spec.required:
            raise InputError(f"{path}: {label}: missing required key {key!r}")
        else:
            out[key] = spec.default
    return out


def _suggest(word: str, choices: list[str]) -> str:
    close = difflib.get_close_matches(word, choices, n=1)
    return f" (did you mean {close[0]!r}?)" if close else f" (expected one of: {', '.join(choices)})"
