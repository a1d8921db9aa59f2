"""Trap projects: a working project with one ordinary mistake in it, as users make them.

Each trap edits a copy of a project that brings its trajectory CSV and
every camera's camera.json and track.csv (``write_scene``'s layout, or the
real flight's), in place. ``TRAPS`` maps a trap's name to the edit; the
victim of a per-camera trap is the project's second camera. The tests
(tests/end_to_end/test_traps.py) expect each to be synchronized right or to
exit non-zero with its cause named.
"""

from __future__ import annotations

import json
import shutil
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

FOOT = 0.3048


def read_project(root: Path) -> dict:
    """The project file's tables."""
    return tomllib.loads((root / "project.toml").read_text(encoding="utf-8"))


def write_project(root: Path, project: dict) -> None:
    """Write the tables back (scalars, lists of numbers and one level of sub-tables, as these projects hold)."""

    def value(v) -> str:
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        return repr(v)

    def table(header: str, entries: dict) -> list[str]:
        lines = [header] + [f"{k} = {value(v)}" for k, v in entries.items() if not isinstance(v, dict)]
        for k, v in entries.items():
            if isinstance(v, dict):
                lines += table(f"[{header.strip('[]')}.{k}]", v)
        return lines

    lines: list[str] = []
    for name, entries in project.items():
        if name == "cameras":
            for camera in entries:
                lines += table("[[cameras]]", camera) + [""]
        else:
            lines += table(f"[{name}]", entries) + [""]
    (root / "project.toml").write_text("\n".join(lines), encoding="utf-8")


def _table(path: Path) -> tuple[list[str], np.ndarray]:
    header = path.read_text(encoding="utf-8").splitlines()[0].split(",")
    return header, np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)


def _write_table(path: Path, header: list[str], data: np.ndarray) -> None:
    fmt = ["%d" if name in ("frame", "id") else "%.6f" for name in header]
    np.savetxt(path, data, delimiter=",", header=",".join(header), comments="", fmt=fmt)


def _trajectory(root: Path) -> Path:
    return root / read_project(root)["target"]["trajectory"]


def _camera_file(root: Path, index: int, key: str) -> Path:
    return root / read_project(root)["cameras"][index][key]


def edit_trajectory(root: Path, edit: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]) -> None:
    """Replace the trajectory's t and x, y, z columns by edit(t, xyz)."""
    path = _trajectory(root)
    header, data = _table(path)
    t, xyz = edit(data[:, header.index("t")].copy(), data[:, [header.index(c) for c in "xyz"]].copy())
    data = data[: len(t)].copy()
    data[:, header.index("t")] = t
    data[:, [header.index(c) for c in "xyz"]] = xyz
    _write_table(path, header, data)


def edit_camera(root: Path, index: int, edit: Callable[[dict], None]) -> None:
    """Edit camera ``index``'s camera.json in place."""
    path = _camera_file(root, index, "camera")
    data = json.loads(path.read_text(encoding="utf-8"))
    edit(data)
    path.write_text(json.dumps(data, indent=1), encoding="utf-8")


def edit_track(root: Path, index: int, edit: Callable[[list[str], np.ndarray], np.ndarray]) -> None:
    """Replace camera ``index``'s track rows by edit(header, rows)."""
    path = _camera_file(root, index, "track")
    header, data = _table(path)
    _write_table(path, header, edit(header, data))


def edit_key(root: Path, index: int | None, key: str, value) -> None:
    """Set a key of camera ``index`` (None: of [target]) in project.toml; value None removes it."""
    project = read_project(root)
    entries = project["target"] if index is None else project["cameras"][index]
    if value is None:
        entries.pop(key, None)
    else:
        entries[key] = value
    write_project(root, project)


def _moved_pose(root: Path, index: int, metres: float) -> None:
    def move(data: dict) -> None:
        R, t = np.asarray(data["R"]), np.asarray(data["t"])
        data["t"] = (t - R @ np.array([metres, 0.0, 0.0])).tolist()

    edit_camera(root, index, move)


def _swap_poses(root: Path, a: int, b: int) -> None:
    first, second = _camera_file(root, a, "camera"), _camera_file(root, b, "camera")
    da, db = json.loads(first.read_text()), json.loads(second.read_text())
    for key in ("K", "dist", "R", "t", "image_size"):
        da[key], db[key] = db[key], da[key]
    first.write_text(json.dumps(da, indent=1))
    second.write_text(json.dumps(db, indent=1))


def _rotate_poses(root: Path) -> None:
    n = len(read_project(root)["cameras"])
    files = [_camera_file(root, k, "camera") for k in range(n)]
    data = [json.loads(f.read_text()) for f in files]
    for k, f in enumerate(files):
        moved = dict(data[k])
        moved.update({key: data[(k + 1) % n][key] for key in ("K", "dist", "R", "t", "image_size")})
        f.write_text(json.dumps(moved, indent=1))


def _other_flight(root: Path) -> None:
    from data_fixtures.scene import make_scene

    other = make_scene(seed=7, lines=((2.0, 4.0), (2.0, 45.0), (1.0, -30.5)), n_frames=(512, 512, 300))

    def replace_log(t, xyz):
        n = min(len(t), len(other.trajectory))
        return t[:n], other.trajectory.xyz[:n]

    edit_trajectory(root, replace_log)


def _random_walk(t, xyz):
    rng = np.random.default_rng(1)
    step = float(np.median(np.linalg.norm(np.diff(xyz, axis=0), axis=1)))
    return t, xyz.mean(axis=0) + np.cumsum(rng.normal(0.0, step, xyz.shape), axis=0)


def _log_ends_early(t, xyz):
    n = max(8, len(t) // 6)
    return t[:n], xyz[:n]


def _copy_file(root: Path, key: str, source: int, target: int) -> None:
    shutil.copyfile(_camera_file(root, source, key), _camera_file(root, target, key))


def _track_of(root: Path, source: int, target: int) -> None:
    """Camera ``target`` given camera ``source``'s track, its frames 7 later and its positions half a pixel off (not the
    same file).
    """
    header, rows = _table(_camera_file(root, source, "track"))
    rows[:, header.index("frame")] += 7
    rows[:, [header.index("x"), header.index("y")]] += 0.5
    kept = [i for i, name in enumerate(header) if name != "time_s"]  # the times were the other video's
    header, rows = [header[i] for i in kept], rows[:, kept]
    _write_table(_camera_file(root, target, "track"), header, rows)


def _scaled_track(factor: float) -> Callable[[list[str], np.ndarray], np.ndarray]:
    def edit(header: list[str], rows: np.ndarray) -> np.ndarray:
        rows = rows.copy()
        rows[:, [header.index("x"), header.index("y")]] *= factor
        return rows

    return edit


def _fps(root: Path, index: int, factor: float) -> None:
    camera = read_project(root)["cameras"][index]
    edit_key(root, index, "fps", float(camera["fps"]) * factor)


def _far_frame(header: list[str], rows: np.ndarray) -> np.ndarray:
    rows = rows.copy()
    rows[-1, header.index("frame")] = 1e12
    return rows


def _gap_over(root: Path, index: int) -> None:
    """Cut out the part of the log the camera sees (its line to the target's samples from truth.json, its tracked
    frames).
    """
    truth = json.loads((root / "truth.json").read_text())
    name = read_project(root)["cameras"][index]["name"]
    line = truth["cameras_to_target"][name]
    _, rows = _table(_camera_file(root, index, "track"))
    samples = (rows[:, 0] - line["beta"]) / line["alpha"]
    header, data = _table(_trajectory(root))
    sample = np.arange(len(data))
    keep = (sample < samples.min() - 2) | (sample > samples.max() + 2)
    _write_table(_trajectory(root), header, data[keep])


def _excel_track(root: Path, index: int) -> None:
    """Camera ``index``'s track as a spreadsheet in a European locale saves it: a byte-order mark, ';' and decimal
    commas.
    """
    path = _camera_file(root, index, "track")
    text = path.read_text(encoding="utf-8").replace(",", ";").replace(".", ",")
    path.write_text("\ufeff" + text.replace("\n", "\r\n"), encoding="utf-8")


def _passwd_track(root: Path, index: int) -> None:
    """A file of the system given as camera ``index``'s track (a copy of a passwd file, not the real one)."""
    _camera_file(root, index, "track").write_text(
        "root:x:0:0:root:/root:/bin/bash\ndaemon:x:1:1:daemon:/usr/sbin:/usr/sbin/nologin\n"
    )


def _lon_lat(t, xyz):
    """x, y replaced by the longitude and latitude (degrees) of those metres at 47.38 N, 8.54 E."""
    lat = 47.3769 + xyz[:, 1] / 111_320.0
    lon = 8.5417 + xyz[:, 0] / (111_320.0 * np.cos(np.radians(47.3769)))
    return t, np.column_stack([lon, lat, xyz[:, 2]])


def _normalised(root: Path, index: int) -> None:
    """Camera ``index``'s track in fractions of its image (x / width, y / height)."""
    w, h = json.loads(_camera_file(root, index, "camera").read_text())["image_size"]
    edit_track(
        root, index, lambda header, rows: rows / [1.0 if c not in "xy" else (w if c == "x" else h) for c in header]
    )


def _frame_in_seconds(root: Path, index: int) -> None:
    """Camera ``index``'s frame column holding seconds (frame / 30, with their decimals), as a track exported by time
    would.
    """
    path = _camera_file(root, index, "track")
    header, rows = _table(path)
    rows[:, header.index("frame")] /= 30.0
    np.savetxt(path, rows, delimiter=",", header=",".join(header), comments="", fmt="%.6f")


def _shadow(header: list[str], rows: np.ndarray) -> np.ndarray:
    """The track of the target's shadow: 60 px below it in every frame."""
    rows = rows.copy()
    rows[:, header.index("y")] += 60.0
    return rows


def _another_object(header: list[str], rows: np.ndarray) -> np.ndarray:
    """The tracker locked on another object in the same frames: one crossing the image right to left, swaying."""
    rows = rows.copy()
    n = len(rows)
    rows[:, header.index("x")] = np.linspace(600.0, 40.0, n)
    rows[:, header.index("y")] = 300.0 + 20.0 * np.sin(np.arange(n) / 30.0)
    return rows


def _ned(t, xyz):
    return t, np.column_stack([xyz[:, 1], xyz[:, 0], -xyz[:, 2]])


TRAPS: dict[str, Callable[[Path], None]] = {
    # the log
    "t_sample_numbers": lambda root: edit_trajectory(root, lambda t, xyz: (np.arange(len(t), dtype=float), xyz)),
    "t_milliseconds": lambda root: edit_trajectory(root, lambda t, xyz: (t * 1000.0, xyz)),
    "t_twice": lambda root: edit_trajectory(root, lambda t, xyz: (t * 2.0, xyz)),
    "reversed_in_time": lambda root: edit_trajectory(root, lambda t, xyz: (t, xyz[::-1])),
    "feet": lambda root: edit_trajectory(root, lambda t, xyz: (t, xyz / FOOT)),
    "shifted_5m": lambda root: edit_trajectory(root, lambda t, xyz: (t, xyz + [5.0, 0.0, 0.0])),
    "mirrored_x": lambda root: edit_trajectory(root, lambda t, xyz: (t, xyz * [-1.0, 1.0, 1.0])),
    "rotated_90": lambda root: edit_trajectory(
        root, lambda t, xyz: (t, xyz @ Rotation.from_euler("z", 90, degrees=True).as_matrix().T)
    ),
    "z_flipped": lambda root: edit_trajectory(root, lambda t, xyz: (t, xyz * [1.0, 1.0, -1.0])),
    "ned_not_enu": lambda root: edit_trajectory(root, _ned),
    "random_walk": lambda root: edit_trajectory(root, _random_walk),
    "heights_47m_high": lambda root: edit_trajectory(root, lambda t, xyz: (t, xyz + [0.0, 0.0, 47.0])),
    "antenna_1_5m_above": lambda root: edit_trajectory(root, lambda t, xyz: (t, xyz + [0.0, 0.0, 1.5])),
    "z_zero": lambda root: edit_trajectory(root, lambda t, xyz: (t, xyz * [1.0, 1.0, 0.0])),
    "lon_lat_in_x_y": lambda root: edit_trajectory(root, _lon_lat),
    "another_flight": _other_flight,
    "log_ends_early": lambda root: edit_trajectory(root, _log_ends_early),
    "log_misses_a_camera": lambda root: _gap_over(root, 1),
    # a camera's inputs
    "poses_swapped": lambda root: _swap_poses(root, 0, 1),
    "poses_rotated": _rotate_poses,
    "camera_json_copied": lambda root: _copy_file(root, "camera", 0, 1),
    "track_copied": lambda root: _copy_file(root, "track", 2, 1),
    "track_of_another_camera": lambda root: _track_of(root, 2, 1),
    "track_of_the_shadow": lambda root: edit_track(root, 1, _shadow),
    "track_of_another_object": lambda root: edit_track(root, 1, _another_object),
    "fps_twice": lambda root: _fps(root, 1, 2.0),
    "fps_half": lambda root: _fps(root, 1, 0.5),
    "track_half_resolution": lambda root: edit_track(root, 1, _scaled_track(0.5)),
    "track_double_resolution": lambda root: edit_track(root, 1, _scaled_track(2.0)),
    "pose_moved_5m": lambda root: _moved_pose(root, 1, 5.0),
    "pose_moved_50m": lambda root: _moved_pose(root, 1, 50.0),
    "image_size_huge": lambda root: edit_camera(root, 1, lambda data: data.update(image_size=[10**9, 10**9])),
    # odd files
    "track_is_dev_zero": lambda root: edit_key(root, 1, "track", "/dev/zero"),
    "track_is_proc_environ": lambda root: edit_key(root, 1, "track", "/proc/self/environ"),
    "track_frame_1e12": lambda root: edit_track(root, 1, _far_frame),
    "track_normalised": lambda root: _normalised(root, 1),
    "track_frame_in_seconds": lambda root: _frame_in_seconds(root, 1),
    "track_saved_by_excel": lambda root: _excel_track(root, 1),
    "track_is_passwd": lambda root: _passwd_track(root, 1),
    "video_is_dev_urandom": lambda root: edit_key(root, 1, "video", "/dev/urandom"),
    "video_missing": lambda root: edit_key(root, 1, "video", "missing/video.mp4"),
}
