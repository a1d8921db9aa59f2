"""The project file (TOML): what to synchronize and how.

Paths are relative to the project file. Unknown keys are errors with a
"did you mean". The schema below is the reference; docs/project.md explains
each key.
"""

from __future__ import annotations

import difflib
import math
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, NamedTuple

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

from tlsync_pipeline.errors import InputError

WORK_DIR_NAME = "work"
# "paper": Brito et al.'s RANSAC as published; "refined": robust line search +
# continuous-time refinement with uncertainty (docs/algorithm.md).
SYNC_METHODS = ("paper", "refined")


class Field(NamedTuple):
    """One key of a table: its converter (raises ValueError), default, and whether required."""

    convert: Callable[[Any, Path], Any]
    default: Any = None
    required: bool = False


def _path(value: Any, root: Path) -> Path:
    if not isinstance(value, str) or not value:
        raise ValueError(f"expected a file path (string), got {value!r}")
    return (root / value).resolve()


def _name(value: Any, root: Path) -> str:
    if not isinstance(value, str) or not value.strip() or any(c in value for c in "/\\:,"):
        raise ValueError(f"expected a non-empty name without '/', '\\', ':' or ',', got {value!r}")
    return value


def _number(value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ValueError(f"expected a number, got {value!r}")
    return float(value)


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


def _method(value: Any, root: Path) -> str:
    if value not in SYNC_METHODS:
        raise ValueError(f"expected one of {', '.join(repr(m) for m in SYNC_METHODS)}, got {value!r}")
    return value


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


TARGET_SCHEMA = {
    "trajectory": Field(_path),
}
CAMERA_SCHEMA = {
    "name": Field(_name, required=True),
    "camera": Field(_path),
    "track": Field(_path),
    "fps": Field(_positive),
}
SYNC_SCHEMA = {
    "eps_px": Field(_positive, 10.0),
    "delta": Field(_positive, 0.5),
    "p": Field(_probability, 0.99),
    "r": Field(_ratio, 0.05),
    "seed": Field(_integer, 0),
    "method": Field(_method, "refined"),
    "r_min": Field(_ratio, 0.01),
    "f_scale_px": Field(_positive, 3.0),
    "smooth_trajectory": Field(_boolean, True),
    "model_error_px": Field(_non_negative, 3.0),
}
# A dict is a table, a one-element list an array of tables.
PROJECT_SCHEMA = {
    "target": TARGET_SCHEMA,
    "cameras": [CAMERA_SCHEMA],
    "sync": SYNC_SCHEMA,
}


@dataclass(frozen=True)
class SyncParams:
    """Voting and line-fit parameters (paper Table 1 defaults).

    method: "refined" (default) or "paper"; r_min: smallest inlier ratio the
    refined line search must find; f_scale_px: robust loss scale of the
    refinement (pixels); smooth_trajectory: the refined method first smooths
    the logged trajectory (cross-validated smoothing spline). r is the
    paper's expected inlier ratio; model_error_px: pixel error of the
    calibration and log that the refined method's intervals allow for.
    """

    eps_px: float = 10.0
    delta: float = 0.5
    p: float = 0.99
    r: float = 0.05
    seed: int = 0
    method: str = "refined"
    r_min: float = 0.01
    f_scale_px: float = 3.0
    smooth_trajectory: bool = True
    model_error_px: float = 3.0


@dataclass(frozen=True)
class Project:
    """A validated project: absolute paths, per-camera tables in file order."""

    path: Path
    target: dict
    cameras: list[dict]
    sync: SyncParams

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
    data = parse_table(raw, PROJECT_SCHEMA, path, "", path.parent)
    cameras = data["cameras"]
    if not cameras:
        raise InputError(f"{path}: no [[cameras]] table; a project needs at least one camera")
    seen: set[str] = set()
    for cam in cameras:
        if cam["name"] in seen:
            raise InputError(f"{path}: [[cameras]]: duplicate camera name {cam['name']!r}; names must be unique")
        seen.add(cam["name"])
    return Project(path, data["target"], cameras, SyncParams(**data["sync"]))


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
